"""Dynamical systems for the chaos analyses: defined once, analysed by any method.

In the style of DynamicalSystems.jl, a system is an object that carries everything an analysis
needs (equations, parameters, initial state, per-state scales, forcing period), and every analysis
(``nld.analysis.lyapunov`` ...) takes any system:

* :class:`ContinuousSystem` -- an ODE ``y' = f(t, y)`` given as a numba-compiled
  ``rhs(t, y, p, z, dy)`` (writes dy in place; ``z`` is a discrete state, an empty array for a
  plain ODE), optionally with event functions (``events(t, y, p, z, g)``,
  ``on_event(k, direction, t, y, p, z) -> int``) that may change ``z``.
* :class:`DiscreteMap` -- a map ``x_{n+1} = f(x_n)`` given as a numba-compiled ``f(x, p, out)``,
  optionally with its Jacobian ``jac(x, p, J)``.
* :class:`SceneSystem` -- a mechanism scene compiled to its kernel (``nld.kernel.compile``): the scene's
  rhs/events/on_event, the assembled initial state, the clearance-based state scales of
  ``nld.run.simulate.state_scales`` and the crank period.
* built-ins: :func:`lorenz`, :func:`duffing`, :func:`logistic`, :func:`henon`, :func:`linear`.

:func:`advance` integrates a continuous system over one interval with the system's integrator
(``method``: the adaptive DOPRI5 of ``nld.integrators.dopri5`` by default, or DOP853, or the stiff
Rodas4 of ``nld.integrators.rosenbrock``; relative tolerance ``rtol``, the system's absolute
tolerance ``system.tolerance(rtol)`` (``rtol * scales`` per state; a scene's positions absolute,
rates relative), events located so contact onsets of a scene are handled), through the one
integrator call ``nld.systems.base.integrate``.
:func:`iterate` applies a map.

Compilation: the integrators are compiled once per machine for first-class function arguments
(``nld.integrators.core``); a system's functions are compiled for that signature on first use
(disk-cached like any ``@njit(cache=True)`` function), so a new user system or scene costs the
compilation of its own functions only.

Units: the time of a flow is in seconds (``time_unit``), so exponents are in 1/s; for a scene the
state is [independent coordinates (m or rad), their rates (m/s or rad/s)]. A map's "time" is the
iteration count.
"""
from __future__ import annotations

import functools
import math

import numpy as np
from numba import njit

from nld.errors import InputError, SolveError
from nld.integrators import NATIVE_METHODS, bind, kernel_solver, method_status_message
from nld.integrators.dopri5 import dopri5, no_events, no_on_event
from nld.integrators.events import EVENT_SAMPLES, check_event_samples
from nld.settings import LYAPUNOV
from nld.systems.base import Solution, System, integrate

__all__ = ["System", "Solution", "integrate", "ContinuousSystem", "DiscreteMap", "SceneSystem",
           "advance", "iterate", "trajectory",
           "lorenz", "duffing", "logistic", "henon", "linear", "SYSTEM_METHODS", "check_system_method"]

DEFAULT_MAX_STEPS = LYAPUNOV.max_steps
SYSTEM_METHODS = NATIVE_METHODS


def check_system_method(method, field: str = "method") -> str:
    """``method`` if it is one of SYSTEM_METHODS, else InputError naming ``field``."""
    if method not in SYSTEM_METHODS:
        raise InputError(f"{field} = {method!r}: must be one of {', '.join(SYSTEM_METHODS)}")
    return method


def _as_vector(x, what: str) -> np.ndarray:
    a = np.array(x, dtype=float).ravel()
    if a.size == 0:
        raise InputError(f"{what} is empty: a system needs at least one state")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{what} = {a!r}: must be finite")
    return a


def _takes_event_samples(solve) -> bool:
    """Whether a ``solve=`` wrapper accepts event_samples as a 14th argument."""
    import inspect
    fn = getattr(solve, "py_func", solve)     # a numba dispatcher's Python function: introspection
    try:
        params = list(inspect.signature(fn).parameters.values())
    except (TypeError, ValueError):
        return False
    if any(q.kind is inspect.Parameter.VAR_POSITIONAL for q in params):
        return True
    return len([q for q in params if q.kind in (inspect.Parameter.POSITIONAL_ONLY,
                                                 inspect.Parameter.POSITIONAL_OR_KEYWORD)]) >= 14


def _scales(scales, n: int) -> np.ndarray:
    if scales is None:
        return np.ones(n)
    s = np.array(scales, dtype=float).ravel()
    if s.shape != (n,) or not np.all(np.isfinite(s)) or not np.all(s > 0):
        raise InputError(f"scales = {scales!r}: must be {n} positive finite numbers (one per state)")
    return s


class ContinuousSystem(System):
    """An ODE y' = rhs(t, y) (a flow), optionally with events and a discrete state.

    rhs:    numba function ``rhs(t, y, p, z, dy)`` writing dy/dt into ``dy``.
    y0:     initial state (n values).
    p:      parameter vector (read only), default empty.
    name:   label used in results.
    state_names: names of the n states (default y0, y1, ...).
    scales: per-state absolute scales (default 1): the absolute tolerance of state i is
            ``rtol * scales[i]`` and separations are measured as ||dy_i / scales[i]||.
            ``tolerance(rtol)`` gives the integrators' atol vector; a scene system overrides
            it (``tolerance_fn``) with ``nld.run.simulate.tolerances`` (positions absolute).
    period: forcing period (s) of a forced system (crank period of a scene), or None.
    z0:     initial discrete state (default empty); events/on_event/n_events: as for
            ``nld.integrators.dopri5`` (default none).
    solve:  optional ``solve(t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps,
            n_events, max_log[, event_samples])`` returning a ``nld.integrators.Solution`` (as
            ``Kernel.module.solve``, or ``nld.integrators.bind(method, rhs, events,
            on_event)``); default: that, made here. A wrapper without ``event_samples`` runs the integrator's
            default and refuses another ``event_samples``.
    hmax:   step cap (s); default period/20 for a forced system, else none.
    time_unit: unit of t (default "s"): exponents are reported per time_unit.
    t0:     the time of y0 (default 0); analyses start there (the forcing phase of a forced
            system or a scene depends on it).
    method: the integrator of :func:`advance` and of every analysis: "dopri5" (default),
            "dop853" (stops with status STIFF where Hairer's stiffness detection fires) or
            "rodas" (Rodas4 with a finite-difference Jacobian; reproduces Lorenz' exponent, but
            on contact scenes it is slow and its exponents are not reliable: docs/lyapunov.md,
            "Tolerance-dependent exponents"). ``solve=`` must then be a wrapper of that method.
    jacobian: optional numba ``jac(t, y, p, z, J)`` writing the n x n Jacobian df/dy into J,
            used by the tangent estimator (``nld.systems.tangent``).
    jvp:    where the tangent estimator takes Jacobian-vector products from when no jacobian
            is given: "auto" (default: forward differentiation of the rhs source by
            ``nld.kernel.autodiff`` when it knows every construct, else finite differences),
            "autodiff" (refuse if it cannot), "fd" (central finite differences).
    memory: indices of the entries of z that are memory states (a contact law's approach
            velocity): part of the perturbation of the two-trajectory estimators (rescaled
            with the state at each renormalisation); default none. Scenes set them.
    period_name: what one period is called in results ("forcing period"; a scene:
            "revolution").
    init_modes: optional ``init_modes(t, y, p, z)`` setting the discrete labels of z (contact
            and stick/slip modes, branches; not the memory entries) consistently with (t, y),
            in place: used where a state is set that no integration reached (a Newton iterate
            of ``nld.analysis.orbits``). Scenes set the kernel's.
    event_samples: interior points of every step's dense output at which the event functions
            are evaluated, so that two sign changes within one step are both located (default
            ``nld.integrators.EVENT_SAMPLES``, 3; 0: the step's ends only;
            docs/integrator.md, "Events"). Used by every integration of the system (advance,
            the Lyapunov estimators, Poincare sections).
    """

    # is_map, builtin_code (set for the built-in flows), angle_states, kernel ...: declared on
    # nld.systems.base.System

    def __init__(self, rhs, y0, p=(), name: str = "system", state_names=None, scales=None,
                 period: float | None = None, *, z0=None, events=None, on_event=None,
                 n_events: int = 0, solve=None, hmax: float | None = None, time_unit: str = "s",
                 t0: float = 0.0, method: str = "dopri5", jacobian=None, jvp: str = "auto",
                 memory=(), period_name: str = "forcing period", event_samples: int | None = None,
                 init_modes=None):
        self.method = check_system_method(method)
        self.init_modes = init_modes
        self.event_samples = (EVENT_SAMPLES if event_samples is None
                              else check_event_samples(event_samples))
        if jvp not in ("auto", "autodiff", "fd"):
            raise InputError(f"jvp = {jvp!r}: must be 'auto', 'autodiff' or 'fd'")
        self.jacobian = jacobian
        self.jvp = jvp
        self.period_name = str(period_name)
        self.rhs = rhs
        self.y0 = _as_vector(y0, "y0")
        self.n = self.y0.size
        self.p = np.ascontiguousarray(np.array(p, dtype=float).ravel())
        self.z0 = np.zeros(0) if z0 is None else np.array(z0, dtype=float).ravel()
        self.name = str(name)
        self.state_names = ([f"y{i}" for i in range(self.n)] if state_names is None
                            else [str(s) for s in state_names])
        if len(self.state_names) != self.n:
            raise InputError(f"state_names = {state_names!r}: need {self.n} names")
        self.scales = _scales(scales, self.n)
        self.tolerance_fn = None
        if period is not None and not (math.isfinite(period) and period > 0):
            raise InputError(f"period = {period!r}: must be a positive time or None")
        self.period = None if period is None else float(period)
        self.events = no_events if events is None else events
        self.on_event = no_on_event if on_event is None else on_event
        self.n_events = int(n_events)
        if self.n_events and events is None:
            raise InputError(f"n_events = {n_events}: give the events function too")
        self._solve = solve
        self._solve_samples = solve is None or _takes_event_samples(solve)
        if not self._solve_samples and self.event_samples != EVENT_SAMPLES:
            raise InputError(f"event_samples = {event_samples!r}: the solve= wrapper takes 13 "
                             f"arguments; add event_samples as its 14th and pass it on to the "
                             f"integrator")
        if hmax is None:
            hmax = self.period / 20.0 if self.period is not None else 0.0
        self.hmax = float(hmax)
        self.time_unit = time_unit
        self.t0 = float(t0)
        self.memory = np.array(sorted(int(i) for i in memory), dtype=np.int64)
        if self.memory.size and (self.memory.min() < 0 or self.memory.max() >= self.z0.size):
            raise InputError(f"memory = {list(memory)!r}: must index entries of z0 "
                             f"(0..{self.z0.size - 1})")

    def tolerance(self, rtol: float) -> np.ndarray:
        """The atol vector for the integrators at ``rtol``: ``rtol * scales`` by default; n
        absolute tolerances then n rtol weights when ``tolerance_fn`` is set (scenes)."""
        if self.tolerance_fn is not None:
            return np.ascontiguousarray(self.tolerance_fn(float(rtol)), dtype=float)
        return np.ascontiguousarray(rtol * self.scales, dtype=float)

    def solve(self, t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps, n_events,
              max_log, event_samples=None):
        """The system's integrator (``method``) with this system's functions (arguments and
        results as ``nld.integrators.dopri5.dopri5``; event_samples None: the system's)."""
        if self._solve is None:
            self._solve = _make_solver(self.rhs, self.events, self.on_event, self.method)
        m = self.event_samples if event_samples is None else check_event_samples(event_samples)
        if not self._solve_samples:
            if m != EVENT_SAMPLES:
                raise InputError(f"event_samples = {m!r}: the solve= wrapper of {self.name} takes "
                                 f"13 arguments; add event_samples as its 14th")
            return self._solve(t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps,
                               n_events, max_log)
        return self._solve(t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps,
                           n_events, max_log, m)

    def integrate(self, t0: float, y, z, t_eval, *, land: bool = True, rtol: float = LYAPUNOV.rtol,
                  atol=None, hmax: float | None = None, max_steps: int = DEFAULT_MAX_STEPS,
                  max_log: int = 1) -> Solution:
        """:func:`nld.systems.base.integrate` of this system: a typed :class:`Solution`."""
        return integrate(self, t0, y, z, t_eval, land=land, rtol=rtol, atol=atol, hmax=hmax,
                         max_steps=max_steps, max_log=max_log)

    def __repr__(self):
        per = "" if self.period is None else f", period={self.period:.6g} {self.time_unit}"
        meth = "" if self.method == "dopri5" else f", method={self.method!r}"
        return f"{type(self).__name__}({self.name!r}, n={self.n}{per}{meth})"


def _make_solver(rhs, events, on_event, method: str = "dopri5"):
    """The solve function of the integrator ``method`` for user functions
    (``nld.integrators.bind``; systems made from the same functions share it)."""
    key = (rhs, events, on_event, method)
    if key in _USER_SOLVERS:
        return _USER_SOLVERS[key]
    solve = bind(method, rhs, events, on_event)
    _USER_SOLVERS[key] = solve
    return solve


# the solvers compiled for user functions, by (rhs, events, on_event, method)
_USER_SOLVERS: dict = {}


class DiscreteMap(System):
    """A map x_{n+1} = f(x_n).

    f:   numba function ``f(x, p, out)`` writing the image of x into ``out``.
    x0:  initial state; p: parameters; name: label.
    jacobian: optional numba ``jac(x, p, J)`` writing the n x n Jacobian into J (default: central
         finite differences with steps 1e-6 * scales).
    scales: per-state scales of the separation norm (default 1).

    Both functions must be numba-compiled (``@njit``): the analyses call them from compiled code.
    Each is called once here, on x0, with guard memory around its output: a function that writes
    outside ``out`` (n values) or ``J`` (n x n) -- memory corruption in compiled code, where no
    index is checked -- or leaves part of it unwritten is refused (InputError), before any run.
    """

    is_map = True
    period = None
    time_unit = "iteration"
    builtin_code = None      # set for the built-in maps (cached analyses via builtin_map)

    def __init__(self, f, x0, p=(), name: str = "map", jacobian=None, state_names=None,
                 scales=None):
        self.f = f
        self.y0 = _as_vector(x0, "x0")
        self.n = self.y0.size
        self.p = np.ascontiguousarray(np.array(p, dtype=float).ravel())
        self.name = str(name)
        self.jacobian = jacobian
        _probe_map_function(f, "f", "f(x, p, out)", self.y0, self.p, (self.n,))
        if jacobian is not None:
            _probe_map_function(jacobian, "jacobian", "jac(x, p, J)", self.y0, self.p,
                                (self.n, self.n))
        self.state_names = ([f"x{i}" for i in range(self.n)] if state_names is None
                            else [str(s) for s in state_names])
        self.scales = _scales(scales, self.n)
        self.tolerance_fn = None
        self.z0 = np.zeros(0)

    @property
    def x0(self):
        return self.y0

    def __repr__(self):
        return f"DiscreteMap({self.name!r}, n={self.n})"


_GUARD = -1.2345678901234567e300       # a value no map writes by chance


def _probe_map_function(fn, name: str, signature: str, x0, p, shape) -> None:
    """Check a map's function once on x0: numba-compiled, and writing all of its output array of
    ``shape`` and nothing outside it (guard memory on both sides); else InputError."""
    from numba.core.dispatcher import Dispatcher
    what = "map" if name == "f" else "Jacobian"
    if not isinstance(fn, Dispatcher):
        raise InputError(f"{name} = {fn!r}: the {what} must be a numba-compiled function "
                         f"{signature} (decorate it with @numba.njit)")
    size = int(np.prod(shape))
    pad = max(64, 4 * size)
    buf = np.full(pad + size + pad, _GUARD)
    out = buf[pad:pad + size].reshape(shape)
    try:
        fn(x0.copy(), p, out)
    except Exception as e:        # noqa: BLE001 - numba typing errors, errors of the function
        first = " ".join(str(e).split())[:200]
        raise InputError(f"{name}: calling {signature} on x0 failed ({type(e).__name__}: {first}); "
                         f"it must be a numba function {signature} writing {' x '.join(map(str, shape))} "
                         "values") from None
    if np.any(buf[:pad] != _GUARD) or np.any(buf[pad + size:] != _GUARD):
        raise InputError(f"{name}: {signature} writes outside its output array of shape {shape} "
                         f"(called on x0 = {x0.tolist()}): index it within {' x '.join(map(str, shape))}")
    if np.any(out == _GUARD):
        raise InputError(f"{name}: {signature} leaves part of its output array of shape {shape} "
                         f"unwritten (called on x0 = {x0.tolist()}): write every entry")


# ---------------------------------------------------------------- integration of one interval
def wrap_angles(system, y, like=None):
    """y with its angle states (``system.angle_states``) brought into [-pi, pi) by whole turns
    (the dynamics depend on angles through sin and cos only). With ``like``, the turns are those
    that wrap ``like`` (to move a nearby trajectory with the reference, keeping their difference)."""
    idx = system.angle_states
    if idx.size == 0:
        return y
    ref = y if like is None else like
    turns = np.floor((ref[idx] + math.pi) / (2.0 * math.pi))
    out = np.array(y, dtype=float)
    out[idx] -= 2.0 * math.pi * turns
    return out


def restart_labels(system, t: float, y, z) -> np.ndarray:
    """z with the labels that the time decides set from (t, y): the branches of a scene's
    switched loads (``crank_halves``: sin of the crank angle; ``angle_threshold``), by the
    kernel's ``init_modes``; every other entry (contact memory, stick/slip modes) kept. t: the
    restart time in the system's time unit (s for a scene); y: the state there (SI, the
    kernel's order). Returns a new array (z itself for a system without such labels).

    Called where an integration restarts from a state that a run reached at another time: a
    run continued near the time origin (``period_shift``), a map's next iteration from t0. A
    ``crank_halves`` load switches at every whole crank revolution, exactly where stroboscopic
    runs stop: a run that stops a round-off before the switch carries the old branch, and the
    restart at the shifted time, where sin(omega t) is exactly 0 or of the other sign, saw no
    crossing, so the load kept the wrong sign for half a revolution (found on the excavator:
    tangent runs that sat in one-impact motions for tens of revolutions, docs/lyapunov.md)."""
    f = system.relabel_time_labels
    if f is None:
        return z
    z = np.array(z, dtype=float)
    f(float(t), np.ascontiguousarray(y, dtype=float), system.p, z)
    return z


def period_shift(system, t: float) -> float:
    """A whole number of forcing periods to subtract from the time t so that an integration
    starting at t runs near the time origin: exact for a periodic forcing, and it keeps the
    crank angle omega t and t itself small (their round-off grows with t and, after some
    hundred revolutions, exceeds the absolute tolerance that rtol 1e-11 asks)."""
    if system.period is None:
        return 0.0
    return math.floor((t - system.t0) / system.period) * system.period


ESCAPE_GROWTH = 1e6     # |y| this many times max(1, |y0|) before a failure: an escape, not stiffness


def escape_probe(system, t0: float, y, z, t_fail: float, rtol: float, atol=None, hmax=None,
                 y_fail=None):
    """(|y|, t) where a failed integration from (t0, y, z) was last seen growing without bound,
    else None. |y| is the Euclidean norm of the state over its scales. y_fail: the state at
    t_fail if the integrator returned it; otherwise the run is repeated (a failure path only)
    with outputs at t0 + (t_fail - t0)(1 - 2^-k), k = 1..52, and the last one reached is used.
    An escape: that norm is at least ESCAPE_GROWTH x max(1, |y(t0)|)."""
    sc = np.asarray(system.scales, dtype=float)
    base = max(1.0, float(np.linalg.norm(np.asarray(y, float) / sc)))
    t_fail = float(t_fail)
    if y_fail is not None and np.all(np.isfinite(y_fail)):
        norm, t_seen = float(np.linalg.norm(np.asarray(y_fail, float) / sc)), t_fail
    else:
        if not t_fail > t0:
            return None
        te = np.unique(t0 + (t_fail - t0) * (1.0 - 2.0 ** -np.arange(1, 53)))
        te = np.ascontiguousarray(te[(te > t0) & (te < t_fail)])
        if te.size == 0:
            return None
        out = integrate(system, t0, y, z, te, land=False, rtol=rtol, atol=atol, hmax=hmax,
                        max_steps=DEFAULT_MAX_STEPS)
        good = [i for i in range(int(out.n_out)) if np.all(np.isfinite(out.Y[i]))]
        if not good:
            return None
        norm, t_seen = float(np.linalg.norm(out.Y[good[-1]] / sc)), float(te[good[-1]])
    return (norm, t_seen) if norm >= ESCAPE_GROWTH * base else None


def failure_message(system, out, t0: float, y, z, rtol: float, atol=None, hmax=None, y_fail=None,
                    method=None) -> str:
    """The one-line message of a failed integration ``out`` of ``system`` from (t0, y, z):
    method_status_message, without the contact guess for a system without events, and naming
    an escape to infinity where the state was growing without bound (escape_probe)."""
    from nld.integrators.core import NON_FINITE, STEP_UNDERFLOW
    escape = None
    if int(out.status) in (STEP_UNDERFLOW, NON_FINITE):
        escape = escape_probe(system, t0, y, z, out.t, rtol, atol, hmax, y_fail)
    return method_status_message(method or system.method, out.status, out.t, out.stats,
                                 contacts=int(system.n_events) > 0, escape=escape)


def advance(system: ContinuousSystem, y, z, t0: float, t1: float, rtol: float = LYAPUNOV.rtol, *,
            atol=None, max_steps: int = DEFAULT_MAX_STEPS, hmax: float | None = None,
            max_log: int = 1):
    """Integrate ``system`` from (t0, y, z) to t1 with its integrator (``system.method``,
    DOPRI5 by default), landing exactly on t1; returns (y(t1), z(t1)), new arrays.

    rtol: relative tolerance; atol: absolute tolerance per state (default ``system.tolerance(rtol)``).
    Events (contact onsets of a scene) are located and handled by ``on_event``, which updates
    the discrete state; the inputs are not modified (z is copied). hmax: step cap (default the
    system's); max_log: the event log's length. A failed integration raises
    :class:`nld.errors.SolveError` (``failure_message``). ``nld.systems.section.land`` is this
    call (plus t1 <= t0: the start itself).
    """
    if system.is_map:
        raise InputError(f"{system.name} is a map: use iterate(), not advance()")
    out = integrate(system, t0, y, z, np.array([float(t1)]), land=True, rtol=rtol, atol=atol,
                    hmax=hmax, max_steps=max_steps, max_log=max_log)
    if out.status != 0 or out.n_out < 1:
        raise SolveError(f"{system.name}: " + failure_message(system, out, float(t0), y, z, rtol,
                                                                atol, hmax))
    return out.Y[0].copy(), out.z


@njit
def _iterate(f, x, p, n):
    y = x.copy()
    tmp = np.empty_like(y)
    for _ in range(n):
        f(y, p, tmp)
        y, tmp = tmp, y
    return y


def iterate(system: DiscreteMap, x, n: int) -> np.ndarray:
    """x after n iterations of the map (a DiscreteMap, or a derived stroboscopic / Poincaré map
    of ``nld.systems.derived``, whose discrete state starts at its z0 and is carried along)."""
    if system.is_derived:
        x, z = np.asarray(x, dtype=float), system.z0
        for _ in range(int(n)):
            st = system.step(x, z)
            x, z = st.x, st.z
        return x
    return _iterate(system.f, np.ascontiguousarray(x, dtype=float), system.p, int(n))


# ---------------------------------------------------------------- built-in flows
@njit(cache=True)
def lorenz_rhs(t, y, p, z, dy):
    """Lorenz (1963): x' = s(y - x), y' = x(r - z) - y, z' = x y - b z; p = [s, r, b]."""
    dy[0] = p[0] * (y[1] - y[0])
    dy[1] = y[0] * (p[1] - y[2]) - y[1]
    dy[2] = y[0] * y[1] - p[2] * y[2]


@njit(cache=True)
def duffing_rhs(t, y, p, z, dy):
    """Forced Duffing x'' + d x' + a x + b x^3 = g cos(w t); p = [d, a, b, g, w]."""
    dy[0] = y[1]
    dy[1] = -p[0] * y[1] - p[1] * y[0] - p[2] * y[0] ** 3 + p[3] * math.cos(p[4] * t)


@njit(cache=True)
def linear_rhs(t, y, p, z, dy):
    """x' = a x (componentwise); p = [a]."""
    for i in range(y.shape[0]):
        dy[i] = p[0] * y[i]


# One disk-cached DOPRI5 for all built-in flows (one compilation instead of one per system):
# the rhs dispatches on a model code that _BuiltinSolve puts in front of the parameters.
_LORENZ, _DUFFING, _LINEAR = 0, 1, 2


@njit(cache=True)
def _builtin_rhs(t, y, p, z, dy):
    code = int(p[0])
    q = p[1:]
    if code == _LORENZ:
        lorenz_rhs(t, y, q, z, dy)
    elif code == _DUFFING:
        duffing_rhs(t, y, q, z, dy)
    else:
        linear_rhs(t, y, q, z, dy)


def _solve_builtin(t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps, n_events,
                   max_log, event_samples):
    return dopri5(_builtin_rhs, no_events, no_on_event, t0, y0, t_eval, land, p, z, rtol, atol,
                  h0, hmax, max_steps, n_events, max_log, event_samples)


class _BuiltinSolve:
    """``solve`` of a built-in flow: the cached integrator with the model code prepended to p."""

    def __init__(self, code: int):
        self.code = float(code)

    def __call__(self, t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps, n_events,
                 max_log, event_samples=EVENT_SAMPLES):
        pp = np.empty(p.shape[0] + 1)
        pp[0] = self.code
        pp[1:] = p
        return _solve_builtin(t0, y0, t_eval, land, pp, z, rtol, atol, h0, hmax, max_steps,
                              n_events, max_log, int(event_samples))


def lorenz(sigma: float = 10.0, rho: float = 28.0, beta: float = 8.0 / 3.0,
           y0=(1.0, 1.0, 1.0)) -> ContinuousSystem:
    """Lorenz system; at the classical (10, 28, 8/3) the spectrum is 0.906, 0, -14.572 (1/time)."""
    name = ("lorenz" if (sigma, rho, beta) == (10.0, 28.0, 8.0 / 3.0)
            else f"lorenz(sigma={sigma:g}, rho={rho:g}, beta={beta:g})")
    s = ContinuousSystem(lorenz_rhs, y0, [sigma, rho, beta], name, ["x", "y", "z"],
                         solve=_BuiltinSolve(_LORENZ))
    s.builtin_code = _LORENZ
    s.param_names = ["sigma", "rho", "beta"]
    return s


def duffing(delta: float = 0.3, alpha: float = -1.0, beta: float = 1.0, gamma: float = 0.5,
            omega: float = 1.2, y0=(1.0, 0.0)) -> ContinuousSystem:
    """Forced Duffing oscillator x'' + delta x' + alpha x + beta x^3 = gamma cos(omega t).

    State [x, x']; period 2 pi / omega. Time is not a state, so there is no zero exponent and
    the two exponents sum to -delta exactly. The defaults (Guckenheimer & Holmes' double well)
    are chaotic.
    """
    s = ContinuousSystem(duffing_rhs, y0, [delta, alpha, beta, gamma, omega],
                         f"duffing(delta={delta:g}, alpha={alpha:g}, beta={beta:g}, "
                         f"gamma={gamma:g}, omega={omega:g})",
                         ["x", "x_dot"], period=2.0 * math.pi / omega, solve=_BuiltinSolve(_DUFFING))
    s.builtin_code = _DUFFING
    s.param_names = ["delta", "alpha", "beta", "gamma", "omega"]
    s.period_index = 4          # the forcing frequency: the period follows it
    return s


def linear(a: float = -0.5, y0=(0.0,)) -> ContinuousSystem:
    """x' = a x (every state); every Lyapunov exponent is a.

    The default reference is the fixed point 0, so that for a > 0 the reference stays bounded
    over any horizon (a separation d0 away from a state that has grown to 1e9 is lost in
    round-off)."""
    y0 = np.atleast_1d(np.array(y0, dtype=float))
    s = ContinuousSystem(linear_rhs, y0, [a], f"linear(a={a:g})", solve=_BuiltinSolve(_LINEAR))
    s.builtin_code = _LINEAR
    return s


# ---------------------------------------------------------------- built-in maps
@njit(cache=True)
def logistic_f(x, p, out):
    """x -> r x (1 - x); p = [r]."""
    out[0] = p[0] * x[0] * (1.0 - x[0])


@njit(cache=True)
def logistic_jac(x, p, J):
    J[0, 0] = p[0] * (1.0 - 2.0 * x[0])


@njit(cache=True)
def henon_f(x, p, out):
    """(x, y) -> (1 - a x^2 + y, b x); p = [a, b]."""
    x0 = x[0]
    out[0] = 1.0 - p[0] * x0 * x0 + x[1]
    out[1] = p[1] * x0


@njit(cache=True)
def henon_jac(x, p, J):
    J[0, 0] = -2.0 * p[0] * x[0]
    J[0, 1] = 1.0
    J[1, 0] = p[1]
    J[1, 1] = 0.0


_LOGISTIC, _HENON = 0, 1


@njit(cache=True)
def builtin_map(x, p, out):
    """The built-in maps behind one function (p = [code, parameters...]), so that the map
    analyses compiled for it are disk-cached once for all of them (nld.analysis.lyapunov)."""
    if int(p[0]) == _LOGISTIC:
        logistic_f(x, p[1:], out)
    else:
        henon_f(x, p[1:], out)


@njit(cache=True)
def builtin_map_jac(x, p, J):
    if int(p[0]) == _LOGISTIC:
        logistic_jac(x, p[1:], J)
    else:
        henon_jac(x, p[1:], J)


def logistic(r: float = 4.0, x0: float = 0.4) -> DiscreteMap:
    """Logistic map x -> r x (1 - x); at r = 4 the exponent is ln 2 per iteration."""
    m = DiscreteMap(logistic_f, [x0], [r], f"logistic(r={r:g})", jacobian=logistic_jac,
                    state_names=["x"])
    m.builtin_code = _LOGISTIC
    return m


def henon(a: float = 1.4, b: float = 0.3, x0=(0.0, 0.0)) -> DiscreteMap:
    """Henon map; at (1.4, 0.3): 0.419, -1.623 per iteration, sum ln b."""
    m = DiscreteMap(henon_f, x0, [a, b], f"henon(a={a:g}, b={b:g})", jacobian=henon_jac,
                    state_names=["x", "y"])
    m.builtin_code = _HENON
    return m


# ---------------------------------------------------------------- scenes
def _plain(v) -> bool:
    """Whether a field is data (numbers, strings, arrays, tuples/lists/dicts of them)."""
    if v is None or isinstance(v, (bool, int, float, str, np.ndarray, np.generic)):
        return True
    if isinstance(v, (tuple, list)):
        return all(_plain(x) for x in v)
    if isinstance(v, dict):
        return all(isinstance(k, str) and _plain(x) for k, x in v.items())
    return False


def _scene_system(scene, method, event_samples):
    """A SceneSystem again from its pickled scene and settings (SceneSystem.__reduce__)."""
    return SceneSystem(scene, method=method, event_samples=event_samples)


class SceneSystem(ContinuousSystem):
    """A mechanism scene as a :class:`ContinuousSystem` (``is_scene``; fields ``scene``, ``kernel``).

    scene_or_name: a Scene, a built-in scene name or a TOML path; overrides as for
    ``nld.model.scene.load_scene`` (``["driver.speed=50", "joints.B.clearance=1e-4"]``).
    The system uses the kernel's rhs/events/on_event and its disk-cached ``solve``; y0, z0 from
    ``nld.run.simulate.initial_state``; scales from ``nld.run.simulate.state_scales`` (angles scaled by
    clearance / lever arm, slides by the clearance, rates by those times the crank speed);
    period = crank period (s); hmax = period / 20 as in ``simulate``. method: the analyses'
    integrator, "dopri5" (default, whatever the scene's ``[scene] method``: analysis results do
    not change with a scene file's recommendation), "dop853" or "rodas" (the kernel's
    disk-cached ``solve_dop853`` / ``solve_rodas``).
    event_samples: as for :class:`ContinuousSystem` (default 3 interior samples per step).
    y0: a start state instead of the assembled one (for a scene the ideal assembly cannot place,
    e.g. a journal held off its bearing's centre); its discrete state from ``Kernel.init_modes``.
    kernel: the compiled kernel to use (default ``nld.kernel.compile.compile_scene``, cached by
    structure).

    Parameters: ``parameter(key)`` / ``with_parameter(key, value)`` take a scene key
    (``joints.B.clearance``, ``driver.speed``: the scene rebuilt at that value on the same
    kernel, its state re-assembled), a name of the kernel's parameter layout (``loads.0.value``:
    that entry of p) or an index of p.
    """

    is_scene = True

    def __reduce__(self):
        # pickled as its scene and settings plus its plain fields (state, parameters, scales ...);
        # the kernel's functions are bound again on the other side (nld.kernel.compile.Kernel
        # pickles as its scene), so that orbits and branches of a scene cross processes
        plain = {k: v for k, v in self.__dict__.items() if _plain(v)}
        return _scene_system, (self.scene, self.method, self.event_samples), plain

    def __copy__(self):
        # copy.copy stays a shallow copy sharing the kernel (with_parameter, the census), not
        # the rebuild that __reduce__ describes for another process
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        return new

    def __init__(self, scene_or_name, overrides=None, *, kernel=None, method: str = "dopri5",
                 event_samples: int | None = None, y0=None):
        from nld.kernel.codegen import needs_onset_velocity
        from nld.kernel.compile import compile_scene
        from nld.model.scene import resolve_scene
        from nld.run.simulate import crank_period, initial_state, state_scales, tolerances_from_scales
        scene = resolve_scene(scene_or_name, overrides)
        kern = kernel if kernel is not None else compile_scene(scene)
        if kern.n_state == 0:
            raise InputError(f"scene {scene.name!r} has no free coordinates (a kinematic chain): "
                             "nothing to analyse")
        if y0 is None:
            y0, z0, q = initial_state(kern)
        else:
            y0 = np.array(y0, dtype=float).ravel()
            if y0.size != kern.n_state:
                raise InputError(f"y0: must have {kern.n_state} entries (the scene's state), not {y0.size}")
            q = np.zeros(len(kern.topo.coords))
            q[kern.topo.independent] = y0[: len(kern.topo.independent)]
            z0 = np.zeros(kern.n_z)
            kern.init_modes(0.0, y0, kern.params(scene), z0)
        try:
            period = crank_period(scene)
        except InputError:
            period = None
        mod = kern.module
        solve = kernel_solver(mod, check_system_method(method))
        memory = [ci for ci, jn in enumerate(kern.topo.clearance)
                  if needs_onset_velocity(scene.joints[jn])]
        super().__init__(mod.rhs, y0, kern.params(scene), scene.name, kern.state_labels(),
                         state_scales(kern, q), period, z0=z0, events=mod.events,
                         on_event=mod.on_event, n_events=kern.n_events, solve=solve,
                         method=method, memory=memory, period_name="revolution",
                         event_samples=event_samples)
        self.scene = scene
        self.kernel = kern
        self.init_modes = kern.init_modes
        self.relabel_time_labels = kern.time_labels()
        self.angle_states = np.array([i for i, k in enumerate(kern.topo.independent)
                                      if kern.topo.coords[k].kind in ("crank", "rev", "fth")],
                                     dtype=np.int64)
        self.tolerance_fn = functools.partial(tolerances_from_scales, self.scales)   # picklable

    # ------------------------------------------------------------------ parameters
    def _param_index(self, key, field: str = "param") -> int:
        """The index of p of a name of the kernel's parameter layout or an index of p."""
        if isinstance(key, str):
            layout = self.kernel.layout
            if key not in layout.index:
                raise InputError(f"{field} = {key!r}: no such scene key or entry of the scene's "
                                 f"parameter vector; entries: {', '.join(layout.names)}")
            return int(layout.index[key])
        return super()._param_index(key, field)

    def _scene_value(self, key: str):
        """The value at scene key ``key`` (a dotted path of the scene's dict), else None."""
        from nld.model.scene import scene_value
        return scene_value(self.scene, key, None)

    @staticmethod
    def _linked(key):
        """The scene keys of a key that names several, comma-separated, set together
        ("joints.A.clearance,joints.B.clearance"), else None."""
        if isinstance(key, str) and "," in key:
            return [k.strip() for k in key.split(",") if k.strip()]
        return None

    def parameter(self, key) -> float:
        """The value of a scene key (SI), or of an entry of p (layout name or index); of several
        keys set together (comma-separated), their common value."""
        keys = self._linked(key)
        if keys:
            vals = [self.parameter(k) for k in keys]
            if any(v != vals[0] for v in vals):
                raise InputError(f"param = {key!r}: the keys set together have different values "
                                 f"({', '.join(f'{v:g}' for v in vals)}): give the scene one value")
            return vals[0]
        if isinstance(key, str):
            node = self._scene_value(key)
            if node is not None:
                try:
                    return float(node)
                except (TypeError, ValueError):
                    raise InputError(f"param = {key!r}: is {node!r}, not a number") from None
        return super().parameter(key)

    def with_parameter(self, key, value):
        """The scene at ``key`` = value: a scene key rebuilds the scene (same kernel: no
        recompilation; InputError where the value changes the structure, e.g. a clearance of
        0) and re-assembles its initial state; so do several scene keys set together
        (comma-separated: "joints.A.clearance,joints.B.clearance"); a layout name or an index
        sets that entry of p."""
        keys = self._linked(key) or ([key] if isinstance(key, str) else [])
        if keys and (len(keys) > 1 or self._scene_value(key) is not None):
            from nld.kernel.compile import compile_scene
            from nld.model.scene import resolve_scene
            for k in keys:
                if self._scene_value(k) is None:
                    raise InputError(f"param = {k!r}: no such scene key of {self.name}")
            value = float(value)
            sc = resolve_scene(self.scene, [f"{k}={value!r}" for k in keys])
            kern = compile_scene(sc)
            if kern.key != self.kernel.key:
                raise InputError(f"{key} = {value:g} changes the scene's structure (e.g. a "
                                 f"clearance of 0 is an ideal joint): stay within one structure")
            return SceneSystem(sc, kernel=kern, method=self.method,
                               event_samples=self.event_samples)
        return super().with_parameter(key, value)


def trajectory(system, n_samples: int, dt: float, *, transient: float = 0.0,
               rtol: float = LYAPUNOV.rtol):
    """States sampled every dt after a transient: (t, Y), Y[i] = y(t0 + transient + i dt).

    Flows: the system's integrator with dense output (t in s), relative tolerance rtol and the
    system's own absolute tolerance ``system.tolerance(rtol)`` (a scene's positions absolute,
    rates relative), as every integration of the system. Maps: dt is ignored,
    Y[i] = x_{transient + i}.
    """
    n_samples = int(n_samples)
    if system.is_map:
        x = iterate(system, system.y0, int(transient))
        Y = np.empty((n_samples, system.n))
        for i in range(n_samples):
            Y[i] = x
            x = iterate(system, x, 1)
        return np.arange(n_samples, dtype=float) + int(transient), Y
    y, z = system.y0.copy(), system.z0.copy()
    t0 = system.t0
    if transient > 0:
        y, z = advance(system, y, z, t0, t0 + transient, rtol)
    t_eval = t0 + transient + dt * np.arange(n_samples)
    # the system's own tolerance, system.tolerance(rtol), as every integration of the system
    out = integrate(system, t0 + transient, y, z, t_eval, land=False, rtol=rtol,
                    max_steps=DEFAULT_MAX_STEPS)
    if out.status != 0:
        raise SolveError(f"{system.name}: " + failure_message(system, out, float(t0 + transient), y,
                                                                z, rtol))
    return t_eval, out.Y
