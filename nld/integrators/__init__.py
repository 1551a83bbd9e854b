"""Numerical integrators (numba) and the dispatch of ``simulate(method=...)``.

* ``dopri5``  Dormand-Prince 5(4), Hairer's DOPRI5 (the default)
* ``dop853``  Dormand-Prince 8(5,3), Hairer's DOP853, 7th-order dense output
* ``rodas``   Rodas4, Hairer-Wanner's stiff (L-stable) Rosenbrock method, numba FD Jacobian
* ``scipy:RK45``, ``scipy:DOP853``, ``scipy:Radau``, ``scipy:LSODA``  scipy.integrate.solve_ivp
  on the same kernel, event to event (a reference, slow: Python calls per step)

All return a :class:`Solution` (a named tuple: ``status, t, Y, n_out, stats, ev_t, ev_k, ev_dir,
n_ev, Z``) with the dopri5 statuses; see docs/integrator.md. The native methods are compiled once
per machine for first-class function arguments (nld.integrators.core); their step-size control,
initial step, output writing and statuses are nld.integrators.core's.
"""

from .core import (
    MAX_STEPS,
    NON_FINITE,
    STEP_UNDERFLOW,
    STOPPED,
    SUCCESS,
    Solution,
    native,
    no_events,
    no_on_event,
)
from .dopri5 import dopri5, dopri5_fixed, status_message
from .dop853 import STIFF, dop853, dop853_fixed
from .events import EVENT_SAMPLES, MAX_EVENT_SAMPLES, check_event_samples
from .rosenbrock import SINGULAR, rodas, rodas_fixed

# The one registry of the native methods: name -> (module in nld.integrators, integrator function,
# name of the kernel's solve function). The code generator binds one solve function per entry to
# the kernel's functions (nld.kernel.codegen, ``bind``); systems and simulate pick it by name; an
# integrator is added here and in its own file (docs/architecture.md, "Add an integrator").
NATIVE = {
    "dopri5": ("dopri5", "dopri5", "solve"),
    "dop853": ("dop853", "dop853", "solve_dop853"),
    "rodas": ("rosenbrock", "rodas", "solve_rodas"),
}
NATIVE_METHODS = tuple(NATIVE)


def native_integrator(method: str):
    """The numba integrator function of a native method (``dopri5``, ``dop853``, ``rodas``)."""
    import importlib
    module, function, _ = NATIVE[method]
    return getattr(importlib.import_module(f"{__name__}.{module}"), function)


def bind(method: str, rhs, events=None, on_event=None):
    """``solve(t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps, n_events, max_log,
    event_samples=EVENT_SAMPLES)``: the native ``method`` with these functions (a kernel's
    ``solve``, ``solve_dop853``, ``solve_rodas``; a user system's solver). Nothing is compiled
    here: the integrator is compiled once per machine, the functions on the first call."""
    integrator = native_integrator(method)

    def solve(t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps, n_events, max_log,
              event_samples=EVENT_SAMPLES):
        return integrator(rhs, events, on_event, t0, y0, t_eval, land, p, z, rtol, atol, h0,
                          hmax, max_steps, n_events, max_log, event_samples)

    solve.method = method
    solve.functions = (rhs, events, on_event)
    return solve


def kernel_solver(kernel_module, method: str):
    """A compiled kernel's generated wrapper of a native method (``solve``, ``solve_dop853``...)."""
    return getattr(kernel_module, NATIVE[method][2])
SCIPY_METHODS = ("RK45", "DOP853", "Radau", "LSODA")
METHODS = NATIVE_METHODS + tuple(f"scipy:{m}" for m in SCIPY_METHODS)

STATS_NAMES = ("steps", "accepted", "rejected", "rhs", "events", "jac", "lu")

__all__ = [
    "Solution",
    "native",
    "bind",
    "dopri5",
    "dopri5_fixed",
    "dop853",
    "dop853_fixed",
    "rodas",
    "rodas_fixed",
    "status_message",
    "method_status_message",
    "solve_method",
    "check_method",
    "no_events",
    "no_on_event",
    "check_event_samples",
    "EVENT_SAMPLES",
    "MAX_EVENT_SAMPLES",
    "METHODS",
    "NATIVE",
    "NATIVE_METHODS",
    "native_integrator",
    "kernel_solver",
    "SUCCESS",
    "STOPPED",
    "MAX_STEPS",
    "STEP_UNDERFLOW",
    "NON_FINITE",
    "SINGULAR",
    "STIFF",
]


def check_method(method: str) -> str:
    """The method name, or ValueError listing the valid ones."""
    if method not in METHODS:
        raise ValueError(f"unknown integrator method {method!r}: choose one of {', '.join(METHODS)}")
    return method


def solve_method(kernel, method, t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps,
                 n_events, max_log, event_samples=EVENT_SAMPLES):
    """Integrate a compiled kernel with ``method`` (same arguments and results as the generated
    ``solve``; ``z`` is updated in place). The native methods run the kernel module's generated
    ``solve_dop853`` / ``solve_rodas`` wrappers (disk-cached per kernel). ``event_samples``:
    interior samples of each step's dense output scanned for event sign changes (native
    methods; the scipy methods use solve_ivp's own detection, a sign change between step ends)."""
    check_method(method)
    event_samples = int(event_samples)
    if method in NATIVE:
        fn = getattr(kernel.module, NATIVE[method][2], None)
        if fn is None:
            raise RuntimeError(f"kernel {kernel.source_path} has no {NATIVE[method][2]}: it was generated "
                               f"by an older nld; delete it from the kernel cache")
        return fn(t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps, n_events, max_log,
                  event_samples)
    from .scipy_backend import solve_scipy
    return solve_scipy(kernel, y0, z, t_eval, p, method.split(":", 1)[1], rtol, atol, t0=t0,
                       hmax=hmax, max_steps=max_steps, max_log=max_log, land=land)


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


def _drop_stale_caches():
    from .core import drop_stale_caches
    from .dop853 import dop853_core
    from .dopri5 import dopri5_core
    from .rosenbrock import rodas_core
    from .tangent import dopri5_tangent_core
    return drop_stale_caches([dopri5_core, dop853_core, rodas_core, dopri5_tangent_core])


_drop_stale_caches()
