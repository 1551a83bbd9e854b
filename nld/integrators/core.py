"""What every native integrator shares: the typed result, the compiled-function arguments, and the
step-control core (accept/reject, PI step-size control, initial step, output writing, statuses).

Method files (``dopri5.py``, ``dop853.py``, ``rosenbrock.py``, ``tangent.py``, ``delay.py``) hold
their tableau, their stage computation, error estimate and dense output, and call the helpers
below for everything else, as scipy's ``_ivp/rk.py`` sits over ``base.py`` and diffrax's
``_solver/`` over ``_step_size_controller/``: the start of a run (``new_run``, ``start``,
``first_step``), the loop head (``running``), the next try (``next_step``), the verdict on a step
and the counters (``judge``, ``settle``), the PI controller (``pi_start``, ``pi_control``), the
error norm (``rms_error``), the event hand-off (``scan_due``, ``relocate``, ``retake_finite``,
``fire``, ``fire_and_restart``), output writing (``write_outputs``), the result
and its message (``solution``, ``method_status_message``); docs/integrator.md, "Step-control
core". The helpers on scalars are ordinary compiled functions, cached on their own and shared by
every integrator. Those that take several arrays and run every step (the stages, the event
location, output writing) are inlined by numba (``inline='always'``): called out of line, the
reference counting of their array arguments made a step 15 % slower (measured:
benchmarks/bench_builds.py, before the step loops worked on borrowed views,
``nld.integrators.ownership``, which made that counting cheap); inlining costs compile time once per
machine, at install where the cores are built ahead of time (``nld.integrators.aot``). The small ones that
run once per run (``new_run``, ``work_vectors``, ``solution``, ``pi_start``) are inlined too, so
that they add no compilation of their own. A new per-step helper must be measured: inlined, one
taking arrays (a swap of two arrays, the end-of-step event check) made a DOPRI5 step 10 % slower
(docs/performance.md, "One step-control core").

**Compiled once per machine.** The integrators take the scene's (or user's) ``rhs``, ``events``,
``on_event`` (and the tangent JVPs) as *first-class function* arguments of a fixed signature
(``numba.types.FunctionType``, the constants ``RHS``, ``EVENTS``, ``ON_EVENT``...), so numba
compiles each integrator once, for that signature, and its disk cache serves every scene and
every user system afterwards: a new scene compiles only its own small functions. The Python
fronts (``dopri5(...)`` etc.) turn numba functions into :class:`NativeFunction` objects (the
addresses of their compiled code for the signature) with :func:`native` and coerce the arrays,
so exactly one specialisation per integrator exists. ``inlined(dopri5_core)`` is an uncached
twin that, called with plain numba dispatchers, compiles the integrator with the functions
inlined (the old build, once per scene and process): kept for the side-by-side measurement in
benchmarks/bench_indirection.py and the round-off test in tests/test_compile_once.py.
docs/performance.md, "Compiled once". The fronts call the cores through
``nld.integrators.aot.compiled``: the build made at install (numba.pycc) where it is current,
numba's dispatcher (this once-per-machine JIT) otherwise; docs/performance.md, "Built at install".

Step-size control: Hairer, Norsett & Wanner, *Solving ODEs I*, 2nd ed. 1993, sec. II.4 (the
initial step HINIT, the error norm) and the Lund-stabilised PI controller of DOPRI5/DOP853
(sec. IV.2 of vol. II); Rodas4 uses its own (Gustafsson) controller in rosenbrock.py.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit, types
from numba.core.typing.typeof import typeof_impl

from nld.errors import InputError
from nld.interrupt import called_from_compiled

from .aot import compiled
from .events import (EPS, EVENT_SAMPLES, find_crossings, fire_events, locate_earliest,
                     set_unknown_signs)

# ---------------------------------------------------------------- statuses
SUCCESS = 0          # reached t_end
STOPPED = 1          # on_event returned 1
MAX_STEPS = -1       # max_steps exceeded
STEP_UNDERFLOW = -2  # step size underflow after a rejection
NON_FINITE = -3      # non-finite values that halving the step could not cure
SINGULAR = -5        # rodas: the iteration matrix was singular MAX_SINGULAR times in a row
STIFF = -6           # dop853: the step size is limited by stability (Hairer's stiffness test)

MAX_NONFINITE = 50   # halvings after non-finite values before NON_FINITE
MAX_RELOCATE = 8     # event location: retakes of a step to land on a root (``relocate``)
RUNNING = 2          # not a final status: the run goes on (``running``; never returned)

# ---------------------------------------------------------------- PI step-size control (Hairer)
BETA = 0.04
SAFE = 0.9
FACMIN = 0.2    # hnew/h >= FACMIN
FACMAX = 10.0   # hnew/h <= FACMAX
FACC1 = 1.0 / FACMIN
FACC2 = 1.0 / FACMAX
FACOLD0 = 1.0e-4
# After an event that changed the mode (z: the first step on a new branch of the vector field)
# a rejected step shrinks by up to FACC1_EVENT (not FACC1), and as if its error were O(h^4)
# (EXPO_EVENT; never less than the usual shrink): the step starts at the previous branch's size,
# and at a contact onset the solution is not smooth (a force like (t - t*)^1.5), so err^(1/(q+1))
# under-shrinks and the first step took 6-12 rejections (benchmarks/results/hybrid.md, stop 21).
# Only mode changes: a user rhs that branches on the sign of a state (tests/test_tangent.py's
# piecewise-linear oscillator) lands on either side of its switch, and with the larger shrink
# its first step became short enough for its dense output to show spurious sign changes at
# round-off level (two extra events at one instant).
FACC1_EVENT = 1.0e3
EXPO_EVENT = 1.0 / 4.0


# ================================================================ the typed result
Solution = namedtuple("Solution", ["status", "t", "Y", "n_out", "stats", "ev_t", "ev_k", "ev_dir",
                                   "n_ev", "Z"])
Solution.__doc__ = """Result of a native integrator (a named tuple: fields by name or position).

status   0 reached t_end, 1 stopped by on_event, < 0 failed (``nld.integrators.status_message``)
t        the time reached (s)
Y        (len(t_eval), n) states at t_eval; NaN rows where not reached
n_out    rows of Y filled
stats    int64 [steps, accepted, rejected, rhs evaluations, events (, Jacobians, LUs: rodas)]
ev_t, ev_k, ev_dir   the event log: time, event index, direction (+1 up, -1 down); n_ev entries
n_ev     events logged
Z        (len(t_eval), nz) discrete state in force at each output row
"""


def method_status_message(method: str, status, t_reached, stats, *, contacts: bool = True,
                          escape=None) -> str:
    """One-line description of a result of any method (dopri5's wording, method-aware hints).

    contacts: the system has contact (or other) events; False drops the "stiff contact" guess
    from a step-size underflow. escape: (|y|, t) where the solution was last seen growing without
    bound (nld.systems.core.escape_probe); given, a step-size underflow or a non-finite state is
    reported as that escape, not as a tolerance or stiffness problem."""
    st = [int(v) for v in stats] + [0] * max(0, 7 - len(stats))
    t = float(t_reached)
    status = int(status)
    rej = "rejections not reported" if st[2] < 0 else f"{st[2]} rejected"
    counts = f"{st[1]} steps, {rej}, {st[3]} rhs evaluations"
    if len(stats) > 5 and (st[5] or st[6]):
        counts += f", {st[5]} Jacobians, {st[6]} LU decompositions"
    stiff = method in ("rodas", "scipy:Radau", "scipy:LSODA")
    hint = "the tolerance" if stiff else "the tolerance or use the stiff solver (method='rodas')"
    if status == SUCCESS:
        return f"{method}: reached t_end = {t:.9g} s ({counts})"
    if status == STOPPED:
        return f"{method}: stopped by an event at t = {t:.9g} s ({counts}, {st[4]} events)"
    if status == MAX_STEPS:
        what = "rhs evaluation budget (max_steps)" if method.startswith("scipy:") else "max_steps"
        return (f"{method}: {what} exceeded at t = {t:.9g} s after {st[0]} steps: raise max_steps, "
                f"loosen {hint}")
    if escape is not None and status in (STEP_UNDERFLOW, NON_FINITE):
        norm, t_seen = escape
        what = "step size underflow" if status == STEP_UNDERFLOW else "non-finite value (NaN/inf)"
        return (f"{method}: {what} at t = {t:.9g} s: the solution grows without bound (|y| = "
                f"{norm:.3g} at t = {t_seen:.9g} s; an escape to infinity or a finite-time blow-up, "
                f"not a tolerance problem: check the model, its parameters and the initial state)")
    if status == STEP_UNDERFLOW:
        guess = "stiff contact or a singularity?" if contacts else "a singularity or a stiff system?"
        return (f"{method}: step size underflow at t = {t:.9g} s: the tolerance cannot be met "
                f"({guess} loosen {hint})")
    if status == NON_FINITE:
        return (f"{method}: non-finite value (NaN/inf) in the solution at t = {t:.9g} s: the state "
                f"diverged (check parameters and initial conditions, or loosen {hint})")
    if status == STIFF:
        return (f"{method}: the problem became stiff at t = {t:.9g} s ({counts}): the step size is "
                f"limited by stability, not accuracy, and an explicit method would go on with noisy, "
                f"possibly wrong stiff components; use method='rodas' (if the cause is a jump of the "
                f"forces instead, e.g. Coulomb friction sticking, use dopri5 or a regularized friction law)")
    if status == SINGULAR:
        return (f"{method}: the iteration matrix I/(h*gamma) - J was singular {5} times in a row at "
                f"t = {t:.9g} s (check the model for a singular mass matrix or NaN Jacobian entries)")
    return f"{method}: unknown integrator status {status} at t = {t:.9g} s"


def as_solution(out) -> "Solution":
    """``out`` as a Solution (a user's ``solve=`` wrapper may return the plain 10-tuple)."""
    return out if isinstance(out, Solution) else Solution(*out)


# ================================================================ first-class function arguments
_F = types.float64
_I = types.int64
_A = types.float64[::1]
RHS_SIG = types.void(_F, _A, _A, _A, _A)                        # rhs(t, y, p, z, dy)
EVENTS_SIG = RHS_SIG                                            # events(t, y, p, z, g)
ON_EVENT_SIG = _I(_I, _I, _F, _A, _A, _A)                       # on_event(k, dir, t, y, p, z) -> int
INTERP_SIG = types.void(_F, types.float64[:, ::1], _A)          # interp(theta, cont, out)
JVP_SIG = types.void(_F, _A, _A, _A, _A, _F, _A, _A, _A)        # rhs_jvp / events_jvp
ON_EVENT_JVP_SIG = _I(_I, _I, _F, _A, _A, _A, _F, _A, _A)       # on_event_jvp
INTERP = types.FunctionType(INTERP_SIG)
RHS = types.FunctionType(RHS_SIG)
EVENTS = types.FunctionType(EVENTS_SIG)
ON_EVENT = types.FunctionType(ON_EVENT_SIG)
JVP = types.FunctionType(JVP_SIG)
ON_EVENT_JVP = types.FunctionType(ON_EVENT_JVP_SIG)

_SIG_TEXT = {
    RHS_SIG: "rhs(t, y, p, z, dy) writing dy in place and returning nothing",
    ON_EVENT_SIG: "on_event(k, direction, t, y, p, z) returning an int (0 go on, 1 stop)",
    JVP_SIG: "jvp(t, y, p, z, out, t_d, y_d, z_d, out_d) returning nothing",
    INTERP_SIG: "interp(theta, cont, out) writing the dense output into out",
    ON_EVENT_JVP_SIG: "on_event_jvp(k, direction, t, y, p, z, t_d, y_d, z_d) returning an int",
}


class NativeFunction(types.WrapperAddressProtocol):
    """A numba-compiled function as a first-class function argument of a fixed signature: the
    addresses of its compiled code (the C wrapper, and numba's own entry so that exceptions
    raised in it propagate). Made by :func:`native`; keeps the dispatcher alive."""

    __slots__ = ("dispatcher", "sig", "_type", "_c_addr", "_jit_addr")

    def __init__(self, dispatcher, sig):
        cres = dispatcher.get_compile_result(sig)
        self.dispatcher = dispatcher
        self.sig = sig
        self._type = types.FunctionType(sig)
        self._c_addr = cres.library.get_pointer_to_function(cres.fndesc.llvm_cfunc_wrapper_name)
        self._jit_addr = cres.library.get_pointer_to_function(cres.fndesc.llvm_func_name)

    def __wrapper_address__(self):
        return self._c_addr

    def __jit_address__(self):
        return self._jit_addr

    def signature(self):
        return self.sig

    def __repr__(self):
        return f"NativeFunction({getattr(self.dispatcher, '__name__', '?')}: {self.sig})"


@typeof_impl.register(NativeFunction)
def _typeof_native(val, c):
    # the registered typeof makes a call with NativeFunction arguments as cheap as one with
    # arrays (numba's generic WrapperAddressProtocol typing rebuilds the type: ~5 us per argument)
    return val._type


def _install_jit_address_hook():
    """numba calls a first-class function through its C wrapper (exceptions raised inside are
    printed and dropped) unless it knows the function's own entry point, which it looks up only
    for its dispatchers. This teaches it the entry point of a NativeFunction, so that an
    exception in a scene function (np.linalg.solve on a singular matrix) propagates as it did
    when the functions were inlined. Without the hook (another numba) the C wrapper is used."""
    try:
        from numba.experimental import function_type as ft
    except ImportError:                      # pragma: no cover - other numba layouts
        return False
    orig = getattr(ft, "_get_jit_address", None)
    orig_w = getattr(ft, "_get_wrapper_address", None)
    if orig is None or orig_w is None or getattr(orig, "_nld_hook", False):
        return orig is not None

    def _get_jit_address(func, sig):
        if type(func) is NativeFunction:
            return func._jit_addr
        return orig(func, sig)

    def _get_wrapper_address(func, sig):
        # numba's own checks the signature's precision first (about 2 us a call, for every
        # function argument of every call); a NativeFunction's signature is precise by making
        if type(func) is NativeFunction:
            return func._c_addr
        return orig_w(func, sig)

    # numba calls them while unboxing a call's arguments: a signal there is deferred
    called_from_compiled(_get_jit_address)
    called_from_compiled(_get_wrapper_address)
    _get_jit_address._nld_hook = True
    ft._get_jit_address = _get_jit_address
    ft._get_wrapper_address = _get_wrapper_address
    return True


JIT_ADDRESS_HOOK = _install_jit_address_hook()

_NATIVE: dict[tuple[int, object], NativeFunction] = {}


def native(fn, sig, field: str = "function") -> NativeFunction:
    """``fn`` (a numba ``@njit`` function, or a NativeFunction) as a first-class function of
    signature ``sig`` (one of the ``*_SIG`` constants); compiled for it on first use (disk-cached
    like any numba function). InputError, naming ``field``, if ``fn`` is not a numba function or
    its result type does not match."""
    if isinstance(fn, NativeFunction):
        if fn.sig != sig:
            raise InputError(f"{field} = {fn!r}: expected signature {sig}")
        return fn
    key = (id(fn), sig)
    got = _NATIVE.get(key)
    if got is not None and got.dispatcher is fn:
        return got
    if not hasattr(fn, "get_compile_result"):
        raise InputError(f"{field} = {getattr(fn, '__name__', fn)!r}: must be a numba-compiled function "
                         f"(decorate it with numba.njit): {_SIG_TEXT.get(sig, sig)}")
    try:
        got = NativeFunction(fn, sig)
    except Exception as e:      # numba typing errors: wrong arity, wrong argument use
        raise InputError(f"{field} = {getattr(fn, '__name__', fn)!r} does not compile as "
                         f"{_SIG_TEXT.get(sig, sig)}: {' '.join(str(e).split())[:300]}") from None
    ret = fn.overloads[sig.args].signature.return_type
    if ret != sig.return_type and not (sig.return_type == types.int64 and isinstance(ret, types.Integer)):
        raise InputError(f"{field} = {getattr(fn, '__name__', fn)!r} returns {ret}: expected "
                         f"{_SIG_TEXT.get(sig, sig)}")
    _NATIVE[key] = got
    return got


def vector(a) -> np.ndarray:
    """``a`` as a writable, C-contiguous float64 vector (itself when it already is one)."""
    if isinstance(a, np.ndarray) and a.dtype == np.float64 and a.ndim == 1 and a.flags.c_contiguous \
            and a.flags.writeable:
        return a
    return np.array(a, dtype=np.float64).reshape(-1)


def state_vector(z, field: str = "z") -> np.ndarray:
    """The discrete state, updated in place by the integrator: it must already be a writable,
    C-contiguous float64 vector (a copy would hide the update from the caller)."""
    if isinstance(z, np.ndarray) and z.dtype == np.float64 and z.ndim == 1 and z.flags.c_contiguous \
            and z.flags.writeable:
        return z
    raise InputError(f"{field}: must be a writable, C-contiguous float64 vector (it is updated in "
                     f"place); got {type(z).__name__} {getattr(z, 'dtype', '')}")


# ================================================================ the step-control core
@njit(cache=True)
def check_arguments(t0, t_eval, atol, n):
    """ValueError for unsorted t_eval, t_eval before t0, or atol of the wrong length."""
    n_eval = t_eval.shape[0]
    for i in range(1, n_eval):
        if t_eval[i] < t_eval[i - 1]:
            raise ValueError("t_eval must be sorted ascending")
    if n_eval > 0 and t_eval[0] < t0:
        raise ValueError("t_eval must lie within [t0, t_end]")
    if atol.shape[0] != n and atol.shape[0] != 2 * n:
        raise ValueError("atol must have one entry per state (or 2n: atol, then rtol weights)")


@njit(cache=True)
def new_outputs(n_eval, n, nz, max_log, n_stats):
    """(Y, Z, stats, ev_t, ev_k, ev_dir): the output rows (NaN until written), the discrete state
    at each row, the counters and the event log (only the first n_ev entries are written)."""
    Y = np.empty((n_eval, n))
    for i in range(n_eval):             # loops, not np.full / slice assignment: numba compiles
        for j in range(n):              # those generic implementations (seconds of a cold start)
            Y[i, j] = np.nan
    Zo = np.zeros((n_eval, nz))
    stats = np.zeros(n_stats, dtype=np.int64)
    ev_t = np.empty(max_log, dtype=np.float64)
    ev_k = np.empty(max_log, dtype=np.int64)
    ev_dir = np.empty(max_log, dtype=np.int64)
    return Y, Zo, stats, ev_t, ev_k, ev_dir


@njit(cache=False, inline='always')
def new_run(t0, y0, t_eval, atol, z, max_log, n_stats):
    """The arrays of a run, after ``check_arguments``: (Y, Z, stats, ev_t, ev_k, ev_dir) of
    ``new_outputs``, (y, ynew, ytmp, yint) of ``work_vectors`` and zsave (a copy of the discrete
    state before the events fire)."""
    n = y0.shape[0]
    check_arguments(t0, t_eval, atol, n)
    Y, Zo, stats, ev_t, ev_k, ev_dir = new_outputs(t_eval.shape[0], n, z.shape[0], max_log, n_stats)
    y, ynew, ytmp, yint = work_vectors(y0)
    return Y, Zo, stats, ev_t, ev_k, ev_dir, y, ynew, ytmp, yint, np.empty(z.shape[0])


@njit(cache=False, inline='always')
def work_vectors(y0):
    """(y, ynew, ytmp, yint): the state (a copy of y0), the step's end, a stage's argument and
    the dense output's value, the work vectors of every integrator."""
    n = y0.shape[0]
    return y0.copy(), np.empty(n), np.empty(n), np.empty(n)


@njit(cache=True)
def event_workspace(ne):
    """Work arrays of the event location for ne event functions: (gcur, gnew, gtmp, gw, sgn,
    troot_a, troot, crossed): g at the step's start and end, scratch, the 4 sample rows, the
    tracked sides (0 = undetermined), the root brackets, the functions that changed side."""
    return (np.empty(ne), np.empty(ne), np.empty(ne), np.empty((4, ne)),
            np.zeros(ne, dtype=np.int64), np.empty(ne), np.empty(ne), np.zeros(ne, dtype=np.bool_))


@njit(cache=False)
def start(rhs, events, t0, y, f0, p, z, atol, rtol, h0, hmax, t_eval, Y, Zo, ytmp, ftmp, order,
          gcur, sgn):
    """The start of a run: the rows of t_eval at t0 (``initial_rows``), f0 = f(t0, y), the event
    functions' sides at t0, the step cap and the first step (h0 if positive, else Hairer's HINIT
    for a method of this order). Returns (i_out, t_end, h, hcap, rhs evaluations); when no
    output lies after t0, t_end = t0 (the run ends at once with SUCCESS) and nothing is
    evaluated."""
    i_out = initial_rows(t0, y, z, t_eval, Y, Zo)
    n_eval = t_eval.shape[0]
    if i_out >= n_eval:
        return i_out, t0, h0, h0, 0
    t_end = t_eval[n_eval - 1]
    span = t_end - t0
    rhs(t0, y, p, z, f0)
    nfev = 1
    if gcur.shape[0] > 0:
        events(t0, y, p, z, gcur)
        set_unknown_signs(gcur, sgn)
    hcap = step_cap(span, hmax)
    if h0 > 0.0:
        h = min(h0, hcap)
    else:
        h = initial_step(rhs, t0, y, f0, p, z, atol, rtol, hcap, span, ytmp, ftmp, order)
        nfev += 1
    return i_out, t_end, usable_step(h, span), hcap, nfev


@njit(cache=False, inline='always')
def fire(on_event, crossed, troot, t_star, tol, sgn, t, y, p, z, zsave, ev_t, ev_k, ev_dir, n_ev,
         max_log):
    """At a located event: fire every crossing whose root is within tol of t_star (on_event may
    change z; ``fire_events``). Returns (stop, n_ev, new_branch): new_branch when on_event changed
    z (a new branch of the vector field, ``rejected_shrink``)."""
    copy_vector(z, zsave)
    stop, n_ev = fire_events(on_event, crossed, troot, t_star, tol, sgn, t, y, p, z, ev_t,
                             ev_k, ev_dir, n_ev, max_log)
    return stop, n_ev, changed(z, zsave)


@njit(cache=False)
def fire_and_restart(rhs, events, on_event, crossed, troot, t_star, tol, sgn, t, y, p, z, zsave,
                     ev_t, ev_k, ev_dir, n_ev, max_log, f0, gcur, nfev):
    """``fire``, then restart there: f0 = f(t, y) (counted in nfev) and g with the new discrete
    state (FSAL is invalid). Returns (status, n_ev, new_branch, nfev): status STOPPED when
    on_event asked to stop (``running`` ends the run), else RUNNING."""
    stop, n_ev, new_branch = fire(on_event, crossed, troot, t_star, tol, sgn, t, y, p, z, zsave,
                                  ev_t, ev_k, ev_dir, n_ev, max_log)
    rhs(t, y, p, z, f0)
    events(t, y, p, z, gcur)
    set_unknown_signs(gcur, sgn)
    return STOPPED if stop else RUNNING, n_ev, new_branch, nfev + 1


@njit(cache=False, inline='always')
def scan_due(events, event_samples, t_new, ynew, p, z, gnew, sgn, crossed):
    """g at a step's end (t_new, ynew) into gnew; whether the step is to be scanned for roots:
    always with interior samples, else when some g left its tracked side (``find_crossings``).
    Used on the retaken steps of an event (dop853, rodas); the per-step scan of every method
    writes these two lines out: inlined there, the helper made a DOPRI5 step about 10 % slower
    (the reference counts of its array arguments, benchmarks/bench_builds.py)."""
    events(t_new, ynew, p, z, gnew)
    return event_samples > 0 or find_crossings(gnew, sgn, crossed)


@njit(cache=False, inline='always')
def relocate(it, events, interp_fn, event_samples, t, dense_h, t_c, a_star, t_star, first, gcur,
             gnew, sgn, cont, yint, gtmp, gw, p, z, tol, crossed, troot_a, troot_b):
    """One pass of the relocation of an event (dop853, rodas: the step retaken from t to land on
    the root, until the root is at the retaken step's end; MAX_RELOCATE passes at most). From
    the second pass on, the earliest root is located again on the dense output of the retaken
    step [t, t_c] (length dense_h). Returns (retake, fire, a_star, t_star, first): retake the
    step to t_star (yint: the dense output there, the fallback of ``retake_finite``); else the
    relocation ends, and the event fires (``fire``) or comes later (t_c is a plain step end)."""
    if it > 0:
        found, a_star, t_star, first = locate_earliest(
            events, interp_fn, event_samples, t, dense_h, t_c, gcur, gnew, sgn, cont, yint, gtmp,
            gw, p, z, tol, crossed, troot_a, troot_b)
        if not found:
            return False, False, a_star, t_star, first
    if t_star <= t or t_star >= t_c - tol:
        return False, True, a_star, t_star, first
    interp_fn((t_star - t) / dense_h, cont, yint)
    return True, True, a_star, t_star, first


@njit(cache=False, inline='always')
def retake_finite(ynew, yint):
    """Whether a step retaken to land on a root ends finite; if not, ynew falls back on yint
    (the dense output of the longer step at the root)."""
    if finite(ynew):
        return True
    copy_vector(yint, ynew)
    return False


@njit(cache=True)
def initial_rows(t0, y0, z, t_eval, Y, Zo):
    """Write the rows of t_eval at or before t0 (the initial state); returns the next row."""
    n = y0.shape[0]
    i_out = 0
    while i_out < t_eval.shape[0] and t_eval[i_out] <= t0:
        for j in range(n):
            Y[i_out, j] = y0[j]
        copy_row(z, Zo, i_out)
        i_out += 1
    return i_out


@njit(cache=True)
def copy_row(z, Zo, i):
    """Zo[i, :] = z (a loop: numba compiles slice assignment generically, seconds cold)."""
    for j in range(z.shape[0]):
        Zo[i, j] = z[j]


@njit(cache=False, inline='always')
def write_outputs(interp, t, h, t_hi, y_hi, cont, t_eval, i_out, Y, Zo, z):
    """Rows for t_eval in (t, t_hi]: y_hi at t_hi itself, else the dense output ``interp`` of the
    step [t, t + h] (coefficients ``cont``). Returns the next output index."""
    n_eval = t_eval.shape[0]
    n = y_hi.shape[0]
    while i_out < n_eval and t_eval[i_out] <= t_hi:
        te = t_eval[i_out]
        if te == t_hi:
            for j in range(n):
                Y[i_out, j] = y_hi[j]
        else:
            interp((te - t) / h, cont, Y[i_out])
        copy_row(z, Zo, i_out)
        i_out += 1
    return i_out


@njit(cache=True)
def finish(stats, n_steps, n_acc, n_rej, nfev, n_ev):
    """Write the common counters into stats (further entries are the method's)."""
    stats[0] = n_steps
    stats[1] = n_acc
    stats[2] = n_rej
    stats[3] = nfev
    stats[4] = n_ev


@njit(cache=False, inline='always')
def solution(status, t, Y, n_out, stats, ev_t, ev_k, ev_dir, n_ev, Zo, n_steps, n_acc, n_rej,
             nfev):
    """``finish``, then the fields of :class:`Solution` as the tuple a jitted core returns."""
    finish(stats, n_steps, n_acc, n_rej, nfev, n_ev)
    return status, t, Y, n_out, stats, ev_t, ev_k, ev_dir, n_ev, Zo


@njit(cache=False, inline='always')
def rms_error(y, ynew, e, atol, rtol):
    """The error norm of dopri5 and rodas: the RMS of e_i / (atol_i + rtol w_i max(|y_i|,
    |ynew_i|)) (e: the method's error estimate, w_i: ``rweight``); NaN if ynew or the norm is not
    finite (``judge`` then halves the step)."""
    n = y.shape[0]
    acc = 0.0
    for i in range(n):
        yn = ynew[i]
        if not math.isfinite(yn):
            return np.nan
        sk = atol[i] + rtol * rweight(atol, n, i) * max(abs(y[i]), abs(yn))
        q = e[i] / sk
        acc += q * q
    if n == 0:
        return 0.0
    err = math.sqrt(acc / n)
    if not math.isfinite(err):
        return np.nan
    return err


@njit(cache=True)
def rweight(atol, n, i):
    """Weight of rtol for state i: ``atol[n + i]`` when ``atol`` has 2n entries, else 1.

    The error scale of state i is ``atol[i] + rtol * rweight * max(|y_i|, |ynew_i|)``. A weight
    of 0 makes the control of that state purely absolute: used for angles that wind (a relative
    joint angle grows by 2 pi per crank revolution, so a relative tolerance would loosen as the
    run goes on) and for positions whose size says nothing about the accuracy needed (a journal
    position of 0.1 m next to a clearance of 0.1 mm). docs/integrator.md, "Tolerances"."""
    if atol.shape[0] == 2 * n:
        return atol[n + i]
    return 1.0


@njit(cache=True)
def step_cap(span, hmax):
    """The largest step: the span, or hmax when it is positive and smaller."""
    hcap = span
    if hmax > 0.0 and hmax < hcap:
        hcap = hmax
    return hcap


@njit(cache=True)
def first_guess(y, f0, atol, rtol):
    """(h, ||f0||^2): HINIT's first guess 0.01 ||y|| / ||f0|| in the error norm (1e-6 when
    either norm is tiny or not finite); the tangent DOPRI5 uses it alone, without the second
    derivative estimate (no extra rhs evaluation)."""
    n = y.shape[0]
    dnf = 0.0
    dny = 0.0
    for i in range(n):
        sk = atol[i] + rtol * rweight(atol, n, i) * abs(y[i])
        dnf += (f0[i] / sk) ** 2
        dny += (y[i] / sk) ** 2
    if dnf <= 1e-10 or dny <= 1e-10 or not math.isfinite(dnf) or not math.isfinite(dny):
        return 1.0e-6, dnf
    return math.sqrt(dny / dnf) * 0.01, dnf


@njit(cache=False)
def initial_step(rhs, t0, y, f0, p, z, atol, rtol, hmax, span, y1, f1, order):
    """Hairer's HINIT for a method of the given order (one extra rhs evaluation)."""
    n = y.shape[0]
    h, dnf = first_guess(y, f0, atol, rtol)
    h = min(h, hmax, span)
    for i in range(n):
        y1[i] = y[i] + h * f0[i]
    rhs(t0 + h, y1, p, z, f1)
    der2 = 0.0
    for i in range(n):
        sk = atol[i] + rtol * rweight(atol, n, i) * abs(y[i])
        der2 += ((f1[i] - f0[i]) / sk) ** 2
    der2 = math.sqrt(der2) / h
    der12 = max(abs(der2), math.sqrt(dnf))
    if not math.isfinite(der12):
        h1 = abs(h) * 1.0e-3
    elif der12 <= 1e-15:
        h1 = max(1.0e-6, abs(h) * 1.0e-3)
    else:
        h1 = (0.01 / der12) ** (1.0 / order)
    return min(100.0 * abs(h), h1, hmax, span)


@njit(cache=True)
def first_step(y, f0, atol, rtol, h0, hcap, span):
    """The first step without HINIT's extra rhs evaluation (the tangent DOPRI5, the delay
    integrator): h0 if positive, else ``first_guess`` on the state; capped at hcap, usable."""
    if h0 > 0.0:
        h = min(h0, hcap)
    else:
        h = min(first_guess(y, f0, atol, rtol)[0], hcap)
    return usable_step(h, span)


@njit(cache=True)
def fixed_times(t0, h, s):
    """(t, t_new) of step s of a fixed-step run from t0 with steps h (no accumulated sum)."""
    return t0 + s * h, t0 + (s + 1) * h


@njit(cache=True)
def usable_step(h, span):
    """h, or 1e-6 of the span when h is not a positive finite number."""
    if not (h > 0.0) or not math.isfinite(h):
        return 1e-6 * span
    return h


@njit(cache=True)
def next_step(t, h, hcap, target):
    """(t_new, h) of the next try: h capped, at least a few ulps of t, landing on ``target``
    when within 1 % of it (no sliver step, as in DOPRI5)."""
    if h > hcap:
        h = hcap
    if h < 4.0 * EPS * abs(t):      # never a step that does not move t
        h = 4.0 * EPS * abs(t)
    if t + 1.01 * h >= target:
        t_new = target
    else:
        t_new = t + h
    return t_new, t_new - t


@njit(cache=True)
def running(status, t, t_end, n_steps, max_steps):
    """The head of every integrator's loop: the status the run ends with before its next step
    (a failure the step control set, SUCCESS at t_end, MAX_STEPS), or RUNNING."""
    if status != RUNNING:
        return status
    if t >= t_end:
        return SUCCESS
    if n_steps >= max_steps:
        return MAX_STEPS
    return RUNNING


@njit(cache=True)
def too_small(h, t):
    """A step this small after a rejection cannot move t: the run fails (underflow)."""
    return h < 16.0 * EPS * abs(t) or h < 1e-300


@njit(cache=True)
def nonfinite_gives_up(h, t, n_nonfinite):
    """After a halving for non-finite values: give up (status NON_FINITE)?"""
    return n_nonfinite >= MAX_NONFINITE or too_small(h, t)


ACCEPTED = 1         # judge(): the step is accepted
RETRY = 2            # judge(): retry the step with the returned h


@njit(cache=True)
def judge(err, h, t, n_nonfinite, shrink):
    """The verdict on a step whose (RMS, scaled) error estimate is ``err``, for every method:

    * err not finite (NaN/inf in the solution or its error): RETRY with h halved, or NON_FINITE
      after MAX_NONFINITE halvings in a row or when h cannot move t;
    * err > 1: RETRY with h / shrink (the method's factor h_old / h_new), or STEP_UNDERFLOW when
      that step cannot move t;
    * else ACCEPTED (h unchanged; the caller proposes the next step).

    Returns (verdict, h, n_nonfinite): the count of non-finite halvings in a row."""
    if not math.isfinite(err):
        h = 0.5 * h
        n_nonfinite += 1
        if nonfinite_gives_up(h, t, n_nonfinite):
            return NON_FINITE, h, n_nonfinite
        return RETRY, h, n_nonfinite
    if err > 1.0:
        h = h / shrink
        if too_small(h, t):
            return STEP_UNDERFLOW, h, 0
        return RETRY, h, 0
    return ACCEPTED, h, 0


@njit(cache=True)
def settle(err, shrink, h, t, n_nonfinite, n_rej, n_acc):
    """``judge`` with the counters: (accepted, status, h, n_nonfinite, n_rej, n_acc). An accepted
    step counts in n_acc (h unchanged); a rejected one in n_rej, with status RUNNING (retry with
    the returned h) or the failure (NON_FINITE, STEP_UNDERFLOW: ``running`` ends the run)."""
    verdict, h, n_nonfinite = judge(err, h, t, n_nonfinite, shrink)
    if verdict == ACCEPTED:
        return True, RUNNING, h, n_nonfinite, n_rej, n_acc + 1
    if verdict == RETRY:
        return False, RUNNING, h, n_nonfinite, n_rej + 1, n_acc
    return False, verdict, h, n_nonfinite, n_rej + 1, n_acc


@njit(cache=False, inline='always')
def pi_start(h):
    """The state of ``pi_control`` at the start: (hnew, facold, reject, new_branch)."""
    return h, FACOLD0, False, False


@njit(cache=True)
def pi_control(err, expo1, beta, facc1, facc2, h, t, hnew, facold, n_nonfinite, reject,
               new_branch, n_rej, n_acc):
    """The step control of the explicit pairs (dopri5, dop853, the tangent DOPRI5, the delay
    integrator) on a step with error estimate err: ``settle`` with the shrink of
    ``rejected_shrink`` (fac11 = err^expo1), and on acceptance the next step by ``pi_accept``.

    Returns (accepted, status, h, hnew, facold, n_nonfinite, reject, new_branch, n_rej, n_acc):
    h the step to retry after a rejection (hnew, facold unchanged then), hnew the proposal after
    an acceptance; reject and new_branch as they stand for the next step (both False after an
    acceptance; new_branch kept through rejections)."""
    fac11 = err ** expo1
    ok, status, h, n_nonfinite, n_rej, n_acc = settle(
        err, rejected_shrink(err, fac11, facc1, new_branch), h, t, n_nonfinite, n_rej, n_acc)
    if ok:
        hnew, facold = pi_accept(h, err, fac11, facold, reject, beta, facc1, facc2)
        return ok, status, h, hnew, facold, n_nonfinite, False, False, n_rej, n_acc
    return ok, status, h, hnew, facold, n_nonfinite, True, new_branch, n_rej, n_acc


@njit(cache=True)
def rejected_shrink(err, fac11, facc1, new_branch):
    """The factor h_old / h_new after a rejected step (err > 1): Hairer's min(facc1, fac11 / SAFE)
    (fac11 = err^EXPO1 of the method), and on the first step after a mode change at least
    min(FACC1_EVENT, err^EXPO_EVENT / SAFE) (the comment at FACC1_EVENT). Used by dopri5, dop853
    and the tangent DOPRI5."""
    shrink = min(facc1, fac11 / SAFE)
    if new_branch:
        shrink = max(shrink, min(FACC1_EVENT, err ** EXPO_EVENT / SAFE))
    return shrink


@njit(cache=True)
def pi_next_step(h, fac11, facold, reject, beta, facc1, facc2):
    """The next step after an accepted one, by the Lund-stabilised PI controller of DOPRI5 and
    DOP853 (each with its constants): h / clip(err^expo1 / facold^beta / SAFE, facc2, facc1)
    (fac11 = err^expo1), no larger than h right after a rejection."""
    fac = fac11 / facold ** beta
    fac = max(facc2, min(facc1, fac / SAFE))
    hnew = h / fac
    if reject:
        hnew = min(hnew, h)
    return hnew


@njit(cache=True)
def pi_accept(h, err, fac11, facold, reject, beta, facc1, facc2):
    """After an accepted step: (the next step by ``pi_next_step``, the controller's memory of the
    error, max(err, FACOLD0))."""
    return pi_next_step(h, fac11, facold, reject, beta, facc1, facc2), max(err, FACOLD0)


@njit(cache=False, inline='always')
def finite(a):
    """Whether every entry of the vector a is finite."""
    for i in range(a.shape[0]):
        if not math.isfinite(a[i]):
            return False
    return True


@njit(cache=True)
def copy_vector(src, dst):
    """dst[:] = src (a loop: numba compiles slice assignment generically, seconds cold)."""
    for i in range(src.shape[0]):
        dst[i] = src[i]


@njit(cache=True)
def changed(z, zsave):
    """Whether on_event changed the discrete state (a new branch of the vector field)."""
    for i in range(z.shape[0]):
        if z[i] != zsave[i]:
            return True
    return False


@njit(cache=True)
def all_finite(a):
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            if not math.isfinite(a[i, j]):
                return False
    return True


@njit(cache=True)
def no_events(t, y, p, z, g):
    """Placeholder ``events`` for n_events = 0 (never called)."""
    pass


@njit(cache=True)
def no_on_event(k, direction, t, y, p, z):
    """Placeholder ``on_event`` that never stops."""
    return 0


def functions(rhs, events, on_event):
    """The three scene functions as first-class function arguments (``native``); ``events`` /
    ``on_event`` None: the placeholders."""
    return (native(rhs, RHS_SIG, "rhs"),
            native(no_events if events is None else events, EVENTS_SIG, "events"),
            native(no_on_event if on_event is None else on_event, ON_EVENT_SIG, "on_event"))


def front(core, interp):
    """The Python front of a jitted integrator core ``core(rhs, events, on_event, interp, t0, y0,
    t_eval, land, p, z, rtol, atol, h0, hmax, max_steps, n_events, max_log, event_samples)``
    (``interp``: the method's dense output, passed to the shared event location): converts the
    functions to NativeFunction and the arguments to the one compiled signature, and returns a
    :class:`Solution`."""
    def solve(rhs, events, on_event, t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps,
              n_events, max_log, event_samples=EVENT_SAMPLES):
        f, g, o = functions(rhs, events, on_event)
        return Solution(*compiled(core)(f, g, o, native(interp, INTERP_SIG, "interp"), float(t0), vector(y0), vector(t_eval), bool(land), vector(p),
                              state_vector(z), float(rtol), vector(atol), float(h0), float(hmax),
                              int(max_steps), int(n_events), int(max_log), int(event_samples)))

    solve.core = core
    solve.interp = interp
    solve.__name__ = core.__name__.replace("_core", "")
    solve.__doc__ = core.__doc__
    return solve


def drop_stale_caches(dispatchers) -> int:
    """Delete numba's disk cache of these integrator cores when a source file of
    nld/integrators is newer than it; returns the number of files deleted.

    numba keys its cache on the timestamp of the file that defines a function, not of the files
    whose functions are inlined into it: the step-control core (this file) and the event location
    (events.py) are inlined into every integrator, so after a change of either an integrator
    would load stale machine code. Called once at the import of nld.integrators (a few stat calls);
    after an upgrade the first run recompiles the integrators once."""
    from pathlib import Path
    here = Path(__file__).resolve().parent
    try:
        newest = max(f.stat().st_mtime for f in here.glob("*.py"))
    except (OSError, ValueError):
        return 0
    n = 0
    for d in dispatchers:
        try:
            cf = d._cache._cache_file
            index = Path(cf._index_path)
            data = cf._data_name_pattern.replace("{number:d}", "*")
        except AttributeError:          # another numba: leave its cache alone
            continue
        files = [index] + list(index.parent.glob(data))
        for f in files:
            try:
                stale = f.stat().st_mtime < newest
            except FileNotFoundError:   # another process removed it
                continue
            if stale:
                f.unlink(missing_ok=True)
                n += 1
    return n


_INLINED: dict = {}


def inlined(core):
    """An uncached twin of a jitted integrator core for calls with plain numba functions (numba
    dispatchers, not NativeFunction): each call signature compiles the whole integrator with the
    functions inlined, the build nld used before the integrators were compiled once. Not written
    to the disk cache (its types name function addresses of one process). For the side-by-side
    measurement (benchmarks/bench_indirection.py) and the round-off test
    (tests/test_compile_once.py); nothing in nld runs it."""
    twin = _INLINED.get(core)
    if twin is None:
        twin = _INLINED[core] = njit(cache=False)(core.py_func)
    return twin
