"""Ctrl-C (SIGINT) that never crashes a compiled integration, and is honoured within a second.

Why a plain Ctrl-C used to end in a segmentation fault
------------------------------------------------------
numba-compiled code never looks at signals: CPython's own SIGINT handler only sets a flag, and the
interpreter raises ``KeyboardInterrupt`` at the next bytecode it runs. The first bytecode after a
long kernel call is *not* the caller's: while numba converts the kernel's result tuple to Python
objects (boxing the arrays), it calls the Python function ``numba.core.serialize._numba_unpickle``.
The pending ``KeyboardInterrupt`` is raised inside that function, it returns NULL, and numba's
boxing code does not check for it: a tuple with a NULL item, then ``SystemError: ... returned a
result with an exception set`` in small cases and a segmentation fault (exit 139) in the
integrators' 10-item result (measured: 5 of 5 tries on ``nld simulate slider_crank --revs 6000``,
and reproduced by a 10-line ``@njit`` function returning a tuple of arrays).

The cure has two parts:

* :func:`deferred` -- while a compiled call runs, SIGINT only sets a flag (a Python handler that
  does not raise, so nothing is raised inside numba's boxing); the caller checks
  :attr:`Deferral.requested` between calls. ``nld.run.simulate`` integrates in chunks (one crank
  revolution of simulated time by default) inside it, so it sees the request within one chunk and
  stops with what it has (:class:`nld.errors.Interrupted` carries the partial result).
* :func:`install` -- the command line's process-wide handler: it raises ``KeyboardInterrupt`` as
  usual, except when the interrupted frame is numba's own Python code (the boxing above, in code
  that does not use :func:`deferred`, e.g. a Lyapunov integration): then it arms a trace function
  on the calling frames that raises ``KeyboardInterrupt`` at the next line run outside numba,
  i.e. right after the compiled call returned its (intact) result.

Worker processes of sweeps and chaos maps ignore SIGINT (:func:`ignore_in_worker`): a terminal's
Ctrl-C reaches the whole process group, and the main process ends the pool itself (finished
points are already on disk; the points in progress are lost and run again on resume).

A pool starts inside :func:`spawning`: its workers and helper threads are created with SIGINT
and SIGTERM blocked. A worker unblocks them once SIGINT is ignored (a Ctrl-C while it still imports
cannot kill it with a traceback); the helper threads keep them blocked, so a signal sent to the
process always reaches the main thread (a signal the kernel handed to a helper thread would not
wake the main thread waiting for results in a lock: the Ctrl-C would wait for the next finished
batch). A signal that arrives while the pool starts is delivered when it has started.

SIGTERM (``kill``, a batch scheduler, a container stop, systemd) is handled like SIGINT: the
command line's handler and :func:`deferred` take both, so a SIGTERM'd run stops the same way,
ends its pool and keeps what finished; :func:`received` says which signal it was (the command
line exits with 128 + its number: 130 for SIGINT, 143 for SIGTERM). It reaches only the main
process, which ends its workers (:func:`end_pool`: SIGTERM, then SIGKILL after 2 s). A worker
also dies with its parent when the parent is killed outright (SIGKILL, a crash: nothing in it
runs): on Linux the kernel sends it SIGKILL then (``PR_SET_PDEATHSIG``, set by
:func:`ignore_in_worker`), so no worker is left computing and writing point files.
"""
from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading

__all__ = ["deferred", "Deferral", "install", "ignore_in_worker", "in_main_thread", "received",
           "forget_received",
           "SIGNALS", "end_pool", "called_from_compiled", "spawning"]

_NUMBA_DIR = None

# the signals that stop a run cleanly (SIGTERM is missing on some platforms' signal module)
SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM") if hasattr(signal, n))
_RECEIVED: list[int] = []


def received() -> int | None:
    """The last stopping signal (SIGINT or SIGTERM) that arrived in this process, or None."""
    return _RECEIVED[-1] if _RECEIVED else None


def forget_received() -> None:
    """Forget the stopping signals received so far (a front end, before it installs its handlers:
    a signal from then on is counted)."""
    _RECEIVED.clear()


def _note(signum) -> None:
    _RECEIVED.append(int(signum))


def in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def _numba_dir() -> str:
    global _NUMBA_DIR
    if _NUMBA_DIR is None:
        try:
            import numba
            _NUMBA_DIR = os.path.dirname(os.path.abspath(numba.__file__)) + os.sep
        except Exception:        # noqa: BLE001 - no numba: nothing to protect
            _NUMBA_DIR = "\0"
    return _NUMBA_DIR


_CALLED_FROM_COMPILED: set = set()


def called_from_compiled(fn):
    """Mark the Python function ``fn`` as one that compiled code calls while it converts its
    arguments or results (nld's unboxing hooks for first-class functions, the unpickler of the
    cores built at install): a signal arriving inside it is deferred as one arriving in numba's
    own Python code is (a ``KeyboardInterrupt`` raised there is not checked by the compiled
    caller). Returns ``fn``."""
    _CALLED_FROM_COMPILED.add(getattr(fn, "__code__", None))
    return fn


def _in_numba(frame) -> bool:
    """The interrupted frame is numba's Python code (numba's boxing calls _numba_unpickle) or a
    function marked :func:`called_from_compiled`."""
    return frame is not None and (frame.f_code in _CALLED_FROM_COMPILED or os.path.abspath(
        frame.f_code.co_filename).startswith(_numba_dir()))


class Deferral:
    """Handle of :func:`deferred`: ``requested`` turns True when SIGINT arrived."""

    def __init__(self):
        self.requested = False
        self.handled = False      # the caller acted on the request: do not raise on exit
        self.active = False

    def _handler(self, signum, frame):
        _note(signum)
        self.requested = True


_DEFERRAL_STACK: list[Deferral] = []


@contextlib.contextmanager
def deferred():
    """Within the block SIGINT (and SIGTERM where :func:`install` took it) sets
    ``Deferral.requested`` instead of raising (main thread only;
    elsewhere, where Python delivers no signals, the handle simply stays False). Nested blocks
    share the outermost handle. On leaving the block the previous handler is restored; a request
    that the block did not act upon is not lost: ``KeyboardInterrupt`` is raised on exit unless the
    block already raised one (or an :class:`nld.errors.Interrupted`) or set ``handled``."""
    if _DEFERRAL_STACK:
        yield _DEFERRAL_STACK[-1]
        return
    d = Deferral()
    if not in_main_thread():
        yield d
        return
    previous = {}
    try:
        for sig in SIGNALS:
            # SIGTERM only where the command line took it (install); elsewhere its default
            # action (the end of the process) is what a program using nld expects. An ignored
            # SIGINT stays ignored (a pool worker: the main process ends the pool).
            if (sig == signal.SIGINT and signal.getsignal(sig) is not signal.SIG_IGN) \
                    or signal.getsignal(sig) is _cli_handler:
                previous[sig] = signal.signal(sig, d._handler)
    except (ValueError, OSError):        # e.g. an embedded interpreter without signals
        for sig, h in previous.items():
            signal.signal(sig, h)
        yield d
        return
    d.active = True
    _DEFERRAL_STACK.append(d)
    raised = False
    try:
        yield d
    except KeyboardInterrupt:
        raised = True
        raise
    finally:
        _DEFERRAL_STACK.pop()
        for sig, h in previous.items():
            signal.signal(sig, h)
        prev = previous.get(received(), previous.get(signal.SIGINT))
        if d.requested and not d.handled and not raised and prev not in (signal.SIG_IGN, None):
            raise KeyboardInterrupt


def _under_numba(frame) -> bool:
    """``frame`` or one of its callers is numba's code (or marked :func:`called_from_compiled`):
    Python code that compiled code is running, e.g. cloudpickle or numpy called by numba's
    ``_numba_unpickle`` when its memo misses (the first call of a kernel in a process)."""
    f = frame
    while f is not None:
        if _in_numba(f):
            return True
        f = f.f_back
    return False


def _arm_raise(frame) -> None:
    """Raise KeyboardInterrupt at the next line that Python runs outside numba's code: a trace
    function on the frames below the interrupted one (the caller of the compiled function).
    Not in a frame that numba's code called (a KeyboardInterrupt raised there is dropped or
    crashes the boxing, and the request would be lost): only once no numba frame is left on the
    stack, i.e. after the compiled call returned."""
    armed = []

    def tracer(fr, event, arg):
        if _under_numba(fr):
            return tracer
        sys.settrace(None)
        for f in armed:
            f.f_trace = None
        raise KeyboardInterrupt

    f = frame.f_back
    while f is not None:
        if not _in_numba(f):
            f.f_trace = tracer
            armed.append(f)
        f = f.f_back
    sys.settrace(tracer)


def _cli_handler(signum, frame):
    _note(signum)
    if _in_numba(frame):
        # inside numba's boxing of a kernel's result: raising here crashes the process
        _arm_raise(frame)
        return
    raise KeyboardInterrupt


def install() -> None:
    """Process-wide SIGINT and SIGTERM handler of the command line (see the module docstring); main
    thread only, and only for a signal that is not ignored (SIGINT of a background job of a
    non-interactive shell)."""
    if not in_main_thread():
        return
    for sig in SIGNALS:
        try:
            if signal.getsignal(sig) is signal.SIG_IGN:
                continue
            signal.signal(sig, _cli_handler)
        except (ValueError, OSError):
            pass


def ignore_in_worker() -> None:
    """A pool worker ignores SIGINT (the main process ends the pool, module docstring), keeps
    SIGTERM's default action (end_pool sends it) and, on Linux, is killed when its parent dies.
    A worker started inside :func:`spawning` has both signals blocked until here: a Ctrl-C that
    reached it while it imported is dropped (it is ignored now), a SIGTERM ends it now."""
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        if hasattr(signal, "SIGTERM"):
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
    except (ValueError, OSError):
        pass
    if hasattr(signal, "pthread_sigmask"):
        try:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, SIGNALS)
        except (ValueError, OSError):
            pass
    die_with_parent()


@contextlib.contextmanager
def spawning():
    """Block SIGINT and SIGTERM in this thread while a pool starts its processes and threads
    (main thread, POSIX; elsewhere nothing). Why:

    * a spawned worker inherits the blocked mask through exec, so a Ctrl-C that reaches the whole
      process group while the worker still imports (before :func:`ignore_in_worker`) cannot
      kill it with a traceback on stderr (and break the pool);
    * the pool's helper threads (the executor's manager and queue feeder threads) are created
      with the mask too, so the kernel never hands a signal sent to the process to one of them:
      it goes to the main thread, which may be blocked waiting for results and is only woken by
      a signal delivered to itself (else the request waits for the next finished batch);
    * a signal that arrives meanwhile stays pending and is delivered when the block ends: it
      is not lost, it is handled in the caller (e.g. a KeyboardInterrupt that ends the pool)."""
    if not (hasattr(signal, "pthread_sigmask") and in_main_thread()):
        yield
        return
    try:
        old = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    except (ValueError, OSError):
        yield
        return
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def die_with_parent() -> None:
    """Linux: ask the kernel to SIGKILL this process when its parent ends (``prctl
    PR_SET_PDEATHSIG``); a parent already gone -> exit now. Elsewhere nothing."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        PR_SET_PDEATHSIG = 1
        parent = os.getppid()
        libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
        if parent == 1 or os.getppid() != parent:      # the parent died before the call
            os._exit(1)
    except Exception:             # noqa: BLE001 - no prctl: the parent's end_pool still works
        pass


def end_pool(ex, grace: float = 2.0) -> list[int]:
    """End the worker processes of a ProcessPoolExecutor now and release it without waiting:
    SIGTERM to every worker, SIGKILL to any still alive after ``grace`` seconds. Returns the
    workers' process ids (a worker ended while it wrote leaves its temporary file behind:
    nld.output.io.remove_temporary removes it)."""
    import time
    procs = list((getattr(ex, "_processes", None) or {}).values())
    pids = [p.pid for p in procs if getattr(p, "pid", None) is not None]
    for p in procs:
        try:
            p.terminate()
        except Exception:         # noqa: BLE001 - already gone
            pass
    try:
        ex.shutdown(wait=False, cancel_futures=True)
    except Exception:             # noqa: BLE001
        pass
    deadline = time.monotonic() + grace
    for p in procs:
        try:
            p.join(timeout=max(0.0, deadline - time.monotonic()))
            if p.is_alive():
                p.kill()
                p.join(timeout=1.0)
        except Exception:         # noqa: BLE001
            pass
    return pids
