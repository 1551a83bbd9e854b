"""Where a Ctrl-C could be delayed or dropped (issue 37, class 8), in-process and quick:

* a pool's helper threads must block SIGINT/SIGTERM, else the kernel may hand a signal sent to
  the process to one of them and the main thread, asleep in a lock waiting for results, is not
  woken (nld.interrupt.spawning);
* a worker starts with them blocked and unblocks them once SIGINT is ignored;
* a signal that arrives while they are blocked is delivered afterwards, not lost;
* the trace function armed for a signal inside numba's code raises only once no numba frame is
  on the stack, not in Python code that numba's code itself called.
"""
from __future__ import annotations

import os
import signal
import sys
import threading
from contextlib import closing
from pathlib import Path

import pytest

import nld.interrupt as ni
from nld.sweeps.executors import execute

main_thread_only = pytest.mark.skipif(threading.current_thread() is not threading.main_thread(),
                                      reason="signals reach the main thread only")
needs_proc = pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="needs Linux /proc")


def _mask(status: str, field: str) -> int:
    for ln in status.splitlines():
        if ln.startswith(field + ":"):
            return int(ln.split()[1], 16)
    raise AssertionError(field)


def _bit(sig) -> int:
    return 1 << (int(sig) - 1)


def worker_state(payload, k):
    """A sweep point that reports its process's SIGINT disposition and blocked signals."""
    status = Path("/proc/self/status").read_text()
    return {"direction": "grid", "index": k,
            "ignored": signal.getsignal(signal.SIGINT) is signal.SIG_IGN,
            "blocked": _mask(status, "SigBlk")}


@needs_proc
@main_thread_only
def test_pool_threads_block_the_stopping_signals_and_workers_unblock_them():
    items = [(k,) for k in range(4)]
    before = {t.native_id for t in threading.enumerate()}     # other tests' threads (Dask ...)
    main_tid = threading.main_thread().native_id
    with closing(execute(worker_state, None, items, workers=2, batch_size=1)) as it:
        first = next(it)
        blocked = {}
        for t in threading.enumerate():
            if t.native_id not in before and t.is_alive():
                status = Path(f"/proc/self/task/{t.native_id}/status").read_text()
                blocked[t.name] = _mask(status, "SigBlk")
        rest = list(it)
    assert blocked, "the pool started no thread"
    for name, m in blocked.items():
        assert m & _bit(signal.SIGINT) and m & _bit(signal.SIGTERM), name
    main_status = Path(f"/proc/self/task/{main_tid}/status").read_text()
    assert not _mask(main_status, "SigBlk") & _bit(signal.SIGINT)     # restored in the caller
    for rec in [first] + rest:
        assert rec["ignored"]
        assert not rec["blocked"] & (_bit(signal.SIGINT) | _bit(signal.SIGTERM))


@main_thread_only
def test_a_signal_during_spawning_is_delivered_after_it():
    got = []
    old = signal.signal(signal.SIGINT, lambda s, f: got.append(s))
    try:
        with ni.spawning():
            signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)   # to this thread
            for _ in range(1000):      # bytecodes run, the handler does not: the signal is blocked
                pass
            assert got == []
        for _ in range(1000):
            if got:
                break
        assert got == [signal.SIGINT]
    finally:
        signal.signal(signal.SIGINT, old)


def _python_called_by_numba(done):
    """Stands for Python code that numba's boxing calls (cloudpickle on a memo miss)."""
    x = 0
    for k in range(3):
        x += k
    done.append(x)
    return x


def _boxing_hook(done):
    """Stands for numba's ``_numba_unpickle``: the signal is handled in it, then it calls on."""
    ni._cli_handler(signal.SIGINT, sys._getframe())
    _python_called_by_numba(done)
    return "boxed"


ni.called_from_compiled(_boxing_hook)


def test_the_armed_interrupt_waits_until_the_compiled_call_returned():
    if sys.gettrace() is not None:
        pytest.skip("a tracer (coverage, a debugger) is active")
    done, after = [], []
    with pytest.raises(KeyboardInterrupt):
        r = _boxing_hook(done)           # returns intact: the interrupt waits for this frame
        after.append(r)                  # raised at this line, back in the caller
    assert done == [3] and after == []
    assert sys.gettrace() is None


START = '''
import os, signal, sys
class Hook:                       # a Ctrl-C while the commands' modules are imported
    def find_spec(self, name, path=None, target=None):
        if name == "nld.cli.app":
            os.kill(os.getpid(), signal.SIGINT)
        return None
sys.meta_path.insert(0, Hook())
from nld.cli import main
sys.exit(main(["scenes"]))
'''


def test_ctrl_c_while_the_command_line_starts_is_one_line(tmp_path):
    import subprocess
    root = Path(__file__).resolve().parent.parent
    env = dict(os.environ, PYTHONPATH=str(root))
    p = subprocess.run([sys.executable, "-c", START], env=env, cwd=tmp_path, capture_output=True,
                       text=True, timeout=300, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert p.returncode == 130, p.stderr
    assert p.stderr == "nld: interrupted: nothing kept (the command had not started)\n"


def test_the_command_line_starts_without_the_heavy_modules(tmp_path):
    """Until the handler is installed only light modules load (the window of a plain
    KeyboardInterrupt traceback stays short): nld and nld.cli import no numpy, pandas, numba."""
    import subprocess
    root = Path(__file__).resolve().parent.parent
    code = ("import sys, nld, nld.cli, nld.interrupt\n"
            "print(sorted(m for m in ('numpy', 'pandas', 'numba', 'scipy') if m in sys.modules))")
    p = subprocess.run([sys.executable, "-c", code], env=dict(os.environ, PYTHONPATH=str(root)),
                       cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "[]"
