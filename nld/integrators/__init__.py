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
    SINGULAR,
    STEP_UNDERFLOW,
    STIFF,
    STOPPED,
    SUCCESS,
    Solution,
    method_status_message,
    native,
    no_events,
    no_on_event,
)
from .dopri5 import dopri5, dopri5_fixed, status_message
from .dop853 import dop853, dop853_fixed
from .events import EVENT_SAMPLES, MAX_EVENT_SAMPLES, check_event_samples
from .rosenbrock import rodas, rodas_fixed

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


def _drop_stale_caches():
    from .core import drop_stale_caches
    from .dop853 import dop853_core
    from .dopri5 import dopri5_core
    from .rosenbrock import rodas_core
    from .tangent import dopri5_tangent_core
    return drop_stale_caches([dopri5_core, dop853_core, rodas_core, dopri5_tangent_core])


_drop_stale_caches()
