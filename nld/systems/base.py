"""What a system is: the interface every analysis takes, written down once.

In the style of DynamicalSystemsBase.jl's ``DynamicalSystem`` (one interface -- current state,
current parameters, ``set_parameter!``, ``step!`` -- that core and derived systems all implement,
so that every analysis takes any of them; Datseris 2018), a nld system is an instance of
:class:`System`. Its implementations:

* ``nld.systems.core.ContinuousSystem`` -- a flow (user ODE, built-in Lorenz / Duffing / linear),
  with events and a discrete state;
* ``nld.systems.core.SceneSystem`` -- a mechanism scene compiled to its kernel (a
  ContinuousSystem subclass that also carries ``scene`` and ``kernel``);
* ``nld.systems.core.DiscreteMap`` -- a map given by a numba function;
* ``nld.systems.derived.StroboscopicMap`` / ``PoincareMap`` -- the maps derived from a flow, and
  ``NumbaMap`` -- a DiscreteMap in the derived maps' step interface.

Every field below is declared on :class:`System` with a default, so an analysis reads
``system.kernel`` or ``system.memory`` directly (no ``getattr`` probe); what kind of system it is,
is a declared field (``is_map``, ``is_derived``, ``is_scene``) or an ``isinstance`` test.

A flow is integrated through ONE call site, :func:`integrate` (it builds the integrator's
positional call from the system: its ``solve``, parameters, event count, step cap, event samples
and its own tolerance ``system.tolerance(rtol)``) and returns one typed result,
:class:`Solution`, whose fields are read by name. A map is stepped by ``step(x, z)``, which
returns a ``nld.systems.derived.MapStep``.

Parameters are addressed one way: ``system.parameter(key)`` and ``system.with_parameter(key,
value)`` (the system at another value, sharing the compiled functions: no recompilation), with
``key`` an index of ``p``, a name of ``param_names`` or, for a scene, a scene key such as
``joints.B.clearance`` / ``driver.speed`` or a name of the kernel's parameter layout such as
``loads.0.value`` (docs/architecture.md, "The System interface").

Units: SI. The time of a flow is in ``time_unit`` (s); a map's time is the iteration count.
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np

from nld.errors import InputError
from nld.integrators.core import as_solution

__all__ = ["System", "Solution", "integrate", "TangentSolution", "integrate_tangent"]


@dataclass(slots=True)
class Solution:
    """One integration of a flow (:func:`integrate`), read by name.

    status:  the integrator's status (0 success; ``nld.integrators.core`` names the others).
    t:       the time reached (s).
    Y:       (len(t_eval), n) states at t_eval (SI); NaN rows where not reached.
    n_out:   rows of Y filled.
    stats:   int64 counters [steps, accepted, rejected, rhs evaluations, events (, Jacobians, LUs)].
    ev_t, ev_k, ev_dir: the event log (time s, event index, direction +1 up / -1 down), n_ev
             entries.
    n_ev:    events logged.
    Z:       (len(t_eval), nz) discrete state in force at each output row.
    z:       the discrete state where the integration stopped (a copy of the start's, updated).
    interrupted: Ctrl-C stopped a chunked run (``span``) at a chunk's end (status INTERRUPTED).
    """
    status: int
    t: float
    Y: np.ndarray
    n_out: int
    stats: np.ndarray
    ev_t: np.ndarray
    ev_k: np.ndarray
    ev_dir: np.ndarray
    n_ev: int
    Z: np.ndarray
    z: np.ndarray
    interrupted: bool = False

    @property
    def ok(self) -> bool:
        """The integration succeeded and filled every output row."""
        return int(self.status) == 0 and int(self.n_out) == self.Y.shape[0]


class System:
    """The interface of every nld system (module docstring). Fields, with their defaults:

    name:          label used in results and messages.
    n:             dimension: the number of (continuous) states; ``dimension`` is the same.
    y0:            initial state (n values, SI: m, rad, m/s, rad/s for a scene).
    z0:            initial discrete state (contact modes, memory, branches; empty if none).
    t0:            the time of y0 (s); analyses start there.
    p:             parameter vector (float64, read only by the compiled functions).
    param_names:   names of the entries of p (empty: address them by index).
    scales:        per-state absolute scales (units of each state): absolute tolerance
                   ``rtol * scales`` by default, separations measured as ||dy / scales||.
    period:        forcing period (s) of a forced flow (a scene: the crank period), else None.
    period_name:   what one period is called ("forcing period", "revolution", "iteration").
    period_index:  index of p that sets the period (the forcing frequency, rad/s), else None.
    state_names:   names of the n states.
    angle_states:  indices of the states that are angles (rad), wrapped by whole turns.
    memory:        indices of z that are memory states (a contact law's approach velocity, m/s).
    contact_events: indices of the events that are contacts (None: for a scene its clearance
                   joints, for another flow every event; ``nld.systems.derived.contact_events``).
    n_events:      number of event functions of a flow (0 for a map).
    time_unit:     unit of the time ("s" for a flow, "iteration" for a map).
    is_map:        a map (stepped), not a flow (integrated).
    is_derived:    a map derived from a flow (stroboscopic or Poincaré).
    is_scene:      a mechanism scene (``scene`` and ``kernel`` are set).
    scene, kernel: the Scene and its compiled Kernel (None unless is_scene).
    builtin_code:  the model code of a built-in system (shared cached integrator), else None.
    relabel_time_labels: ``f(t, y, p, z)`` setting the labels of z that time decides (a scene's
                   switched loads), else None (``nld.systems.core.restart_labels``).
    init_modes:    ``init_modes(t, y, p, z)`` setting z's labels from (t, y), else None.
    """

    name: str = "system"
    n: int = 0
    p: np.ndarray = np.zeros(0)
    param_names: tuple = ()
    z0: np.ndarray = np.zeros(0)
    t0: float = 0.0
    period: float | None = None
    period_name: str | None = None    # None: a DiscreteMap's (the analyses' defaults apply)
    period_index: int | None = None
    angle_states: np.ndarray = np.zeros(0, dtype=np.int64)
    memory: np.ndarray = np.zeros(0, dtype=np.int64)
    contact_events = None
    n_events: int = 0
    time_unit: str = "s"
    is_map: bool = False
    is_derived: bool = False
    is_scene: bool = False
    scene = None
    kernel = None
    builtin_code: int | None = None
    relabel_time_labels = None
    init_modes = None
    _tangent_solver = None        # the tangent integrator, cached by nld.systems.tangent

    @property
    def dimension(self) -> int:
        """The number of continuous states (DynamicalSystemsBase's ``dimension``)."""
        return int(self.n)

    # ------------------------------------------------------------------ parameters
    def _param_index(self, key, field: str = "param") -> int:
        """The index of p that ``key`` (a name of param_names or an index) addresses."""
        names = list(self.param_names or [])
        if isinstance(key, str):
            if key not in names:
                raise InputError(f"{field} = {key!r}: no such parameter of {self.name}; parameters: "
                                 f"{', '.join(names) if names else '(unnamed: give an index of p)'}")
            return names.index(key)
        if isinstance(key, (int, np.integer)) and not isinstance(key, bool) \
                and 0 <= key < self.p.size:
            return int(key)
        raise InputError(f"{field} = {key!r}: a parameter name or an index of p "
                         f"(0..{self.p.size - 1})")

    def parameter_index(self, key, field: str = "param") -> int:
        """The index of p that ``key`` addresses (a name of param_names or an index of p; a scene:
        also a name of its parameter layout), for an analysis that perturbs p itself (a
        controller's input); InputError naming ``field``, the key and what is allowed otherwise."""
        return self._param_index(key, field)

    def parameter(self, key) -> float:
        """The value of the parameter ``key`` (a name of param_names or an index of p)."""
        return float(self.p[self._param_index(key)])

    def with_parameter(self, key, value):
        """This system with parameter ``key`` at ``value`` (a shallow copy sharing the compiled
        functions and caches; p copied). Setting ``period_index`` (the forcing frequency, rad/s)
        also sets the period 2 pi / value and the step cap period / 20."""
        i = self._param_index(key)
        value = float(value)
        s = copy.copy(self)
        s.p = self.p.copy()
        s.p[i] = value
        if self.period_index is not None and self.period_index == i and self.period is not None:
            if not value > 0:
                raise InputError(f"{key} = {value!r}: the forcing frequency must be > 0")
            s.period = 2.0 * math.pi / value
            s.hmax = s.period / 20.0
        return s


def integrate(system, t0: float, y, z, t_eval, *, land: bool, rtol: float, atol=None,
              hmax: float | None = None, max_steps: int, max_log: int = 1,
              event_samples: int | None = None, span: float | None = None, progress=None,
              desc: str = "integrate") -> Solution:
    """Integrate the flow ``system`` from (t0, y, z) with its integrator (``system.solve``):
    the one place in nld.systems that builds the integrator's call.

    t_eval: output times (s, increasing); ``land``: land exactly on them (else dense output).
    rtol: relative tolerance; atol: absolute tolerances (default ``system.tolerance(rtol)``, the
    system's own: a scene's positions absolute, rates relative). hmax: step cap (s; default the
    system's). max_steps: step budget; max_log: event log length; event_samples: default the
    system's. z is copied, y is not written: the inputs are not modified. Returns a :class:`Solution`.

    span (s): run in chunks of that much simulated time with Ctrl-C honoured at each chunk's end
    and a progress bar (``progress``, ``desc``; ``nld.run.simulate.integrate_chunked``, which
    owns that loop): ``Solution.interrupted`` says whether Ctrl-C stopped it. event_samples is
    then the system's. None: one call.
    """
    atol = system.tolerance(rtol) if atol is None else np.ascontiguousarray(atol, dtype=float)
    zz = np.array(z, dtype=float)
    y = np.ascontiguousarray(y, dtype=float)
    t_eval = np.ascontiguousarray(t_eval, dtype=float)
    hmax = float(system.hmax if hmax is None else hmax)
    if span is not None:
        from nld.run.simulate import integrate_chunked
        out = integrate_chunked(system.solve, float(t0), y, t_eval, bool(land), system.p, zz,
                                float(rtol), atol, hmax, int(max_steps), int(system.n_events),
                                int(max_log), float(span), progress=progress, period=system.period,
                                desc=desc)
        interrupted = bool(out.interrupted)
    else:
        out = as_solution(system.solve(float(t0), y, t_eval, bool(land), system.p, zz,
                                       float(rtol), atol, 0.0, hmax, int(max_steps),
                                       int(system.n_events), int(max_log), event_samples))
        interrupted = False
    # the integrator's fields read by name, passed in Solution's order (keywords cost 2 us more
    # per call: a map step or a section's landing integrations make many calls)
    return Solution(out.status, out.t, out.Y, out.n_out, out.stats, out.ev_t, out.ev_k,
                    out.ev_dir, out.n_ev, out.Z, zz, interrupted)


@dataclass(slots=True)
class TangentSolution:
    """One integration of a flow with its tangent vectors (:func:`integrate_tangent`), by name.

    status:  the integrator's status (0 success, 1 stopped by on_event; <0 failures).
    t:       the time reached (s).
    y:       the state there (SI).
    n_done:  the marks passed (rows of ``logs`` filled).
    stats:   int64 counters as :class:`Solution`'s.
    h_next:  the step size proposed for a continuation (s).
    """
    status: int
    t: float
    y: np.ndarray
    n_done: int
    stats: np.ndarray
    h_next: float


def integrate_tangent(system, solve, t0: float, y, z, W, Wz, marks, rtol: float, *, atol=None,
                      tangent_err: bool, want_div: bool, h0: float, max_steps: int, diag, logs,
                      orthonormalise: bool) -> TangentSolution:
    """Integrate the flow ``system`` and the tangent vectors W (k, n) with discrete parts Wz
    (k, nz) from (t0, y, z) through the times ``marks`` with its tangent integrator ``solve``
    (``nld.systems.tangent.tangent_functions(system)[0]``; arguments as
    ``nld.integrators.tangent``): the one place that builds that integrator's call, beside
    :func:`integrate` (its signature differs: tangent vectors, marks, the renormalisation logs).
    atol: default ``system.tolerance(rtol)``; step cap, event count and event samples the
    system's. z, W, Wz, diag and logs are contiguous float arrays the integrator updates in place
    (the caller copies what it must keep). Returns a :class:`TangentSolution`."""
    atol = system.tolerance(rtol) if atol is None else np.ascontiguousarray(atol, dtype=float)
    out = solve(float(t0), y, z, W, Wz, marks, system.p, float(rtol), atol, system.scales,
                float(h0), float(system.hmax), int(max_steps), int(system.n_events),
                bool(tangent_err), bool(want_div), diag, logs,
                int(system.event_samples), bool(orthonormalise))
    return TangentSolution(*out)      # the compiled integrator's 6-tuple, in its declared order
