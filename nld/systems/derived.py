"""Derived systems: the stroboscopic map and the Poincaré map of a flow, as maps with Jacobians.

In the spirit of DynamicalSystemsBase.jl's ``StroboscopicMap`` / ``PoincareMap`` (Datseris 2018;
Datseris & Parlitz 2022, ch. 4), a flow seen once per period or once per crossing of a section is
itself a system: :class:`StroboscopicMap` advances a forced flow (a scene: one crank revolution)
by whole periods, :class:`PoincareMap` advances an autonomous flow to its next crossing of a
hyperplane. Both take a state and return the next one, and on request the map's Jacobian -- for the
stroboscopic map the *monodromy matrix* of the period -- from the tangent integrator
(``nld.integrators.tangent``), which maps the tangent vectors through every event by its saltation
matrix (Müller 1995; Leine & Nijmeijer 2004, sec. 7; di Bernardo et al. 2008, ch. 2.5). The
periodic-orbit, continuation and control analyses (``nld.analysis.orbits``,
``nld.analysis.continuation``) work on these maps; :func:`as_map` also wraps a
:class:`~nld.systems.DiscreteMap` (numba map with its Jacobian) in the same interface.

The state of a derived map (its "augmented state" x) is the flow's continuous state y followed by
the *memory* entries of the discrete state z (``system.memory``: the approach velocity that a
Lankarani-Nikravesh contact law records at each contact onset). The memory is a state of the
motion: between onsets it is constant and it sets the contact damping, so a periodic orbit must
reproduce it, and its direction is part of the monodromy (docs/orbits.md, "Memory state"). The
other entries of z (contact and stick/slip modes, switched-load branches, the dependent coordinates'
Newton warm start) are labels that follow from x; a map carries them from one step to the next.

Units: the state in the flow's SI units (a scene: m, rad, m/s, rad/s; the memory: m/s); the
period of a stroboscopic map in s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from nld.errors import InputError, SolveError
from nld.integrators.tangent import N_DIAG, DG_DIV, DG_LOGDET, DG_GRAZE, crossing_diag
from nld.systems.base import System, integrate
from nld.systems.core import failure_message, restart_labels, wrap_angles as wrap_angles_of
from nld.systems.section import locate_crossing

__all__ = ["MapStep", "SectionRun", "StroboscopicMap", "PoincareMap", "NumbaMap", "as_map",
           "contact_events"]

# event log length of the plain (no-Jacobian) step: enough for any number of onsets per period
_MAX_LOG = 4096
MIN_STEP_BUDGET = 20_000


@dataclass
class MapStep:
    """One application of a derived map.

    x:  the image (augmented state: y then the memory entries of z), SI units.
    z:  the full discrete state after the step (labels carried on).
    M:  the map's Jacobian dx'/dx ((N, N), N = len(x)) when asked, else None. For a
        stroboscopic map the monodromy matrix of the period, saltation at every event included;
        for a Poincaré map the projected Jacobian (it maps into the section's tangent space).
    onsets: upward crossings of each contact event (a scene: contact onsets per clearance joint).
    min_approach: per contact event the smallest |dg/dt| at an upward crossing (a scene: the
        normal approach speed at contact onset, m/s; inf where none); with M only.
    log_det_saltation, divergence: sum of ln|det S| over the saltations and the integral of
        tr(df/dy) over the step (with M and ``divergence=True``); the Liouville check of det M.
    grazing: events whose crossing speed was zero to round-off (no time-shift term).
    time: the flow time the step took (s): the period, or the return time of a Poincaré map.
    """
    x: np.ndarray
    z: np.ndarray
    M: np.ndarray | None = None
    onsets: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    min_approach: np.ndarray = field(default_factory=lambda: np.zeros(0))
    log_det_saltation: float = math.nan
    divergence: float = math.nan
    grazing: int = 0
    time: float = math.nan


@dataclass
class SectionRun:
    """Section points of a run (:meth:`StroboscopicMap.orbit`).

    X: (m, N) the recorded points (augmented state, SI; angles wrapped), m = n unless the run
    failed or was interrupted.
    z: the discrete state after the last recorded point. onsets: contact onsets per contact event
    over the recorded steps. gaps: (m, n_contacts) the contact events' values at the points (a
    scene: penetration, m; > 0 in contact). success / message: as for an integrator result.
    y_start: the flow state the recording started from (after the transient).
    t: (m,) the times of the points (s). Y, Z: (m, n) and (m, nz) the flow states (angles *not*
    wrapped: as integrated) and discrete states at the points. status, t_reached, stats: the
    integrator's status (``nld.run.simulate.INTERRUPTED`` after Ctrl-C), where it stopped (s) and
    its counters (steps, accepted, rejected, rhs, events ...). z_reached: the discrete state
    where the integration stopped (that of the last point when it succeeded). step_onsets:
    (m, n_contacts) the onsets of each contact event in the step that ends at each point, t in
    (t_k - T, t_k] (empty where the event log overflowed).
    """
    X: np.ndarray
    z: np.ndarray
    onsets: np.ndarray
    gaps: np.ndarray
    success: bool
    message: str
    y_start: np.ndarray
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    Y: np.ndarray | None = None
    Z: np.ndarray | None = None
    status: int = 0
    t_reached: float = math.nan
    stats: np.ndarray = field(default_factory=lambda: np.zeros(5, dtype=np.int64))
    z_reached: np.ndarray | None = None
    step_onsets: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), dtype=np.int64))


def contact_events(system) -> np.ndarray:
    """Indices of the events that are contacts: a scene's penetration events (one per clearance
    joint, upward = onset); for another flow ``system.contact_events`` if set, else all events."""
    if system.is_scene:
        return np.arange(len(system.kernel.topo.clearance), dtype=np.int64)
    ce = system.contact_events
    if ce is not None:
        return np.array(ce, dtype=np.int64)
    return np.arange(int(system.n_events), dtype=np.int64)


def memory_pairs(system) -> list:
    """(z index, contact event index, name) of each memory entry of ``system``: a scene's
    z[ci] is reset at the onset of clearance joint ci (event ci, named ``<joint>.v_onset``);
    another flow's memory entry j by contact event j (named ``z<i>``), -1 where there is none."""
    mem = [int(i) for i in system.memory]
    if system.is_scene:
        return [(i, i, f"{system.kernel.topo.clearance[i]}.v_onset") for i in mem]
    ce = contact_events(system)
    return [(i, int(ce[j]) if j < ce.size else -1, f"z{i}") for j, i in enumerate(mem)]


def never_reset(m, steps) -> np.ndarray:
    """Positions in the augmented state of the memory entries that no contact onset reset during
    ``steps`` (a permanent contact or no contact): neutral directions, a history, not a state."""
    mem = m.memory
    if len(mem) == 0 or not steps or steps[0].onsets.size == 0:
        return np.zeros(0, dtype=np.int64)
    total = np.sum([st.onsets for st in steps], axis=0)
    out = []
    for j, e in enumerate(m.memory_events):
        pos = list(m.contacts).index(e) if e in m.contacts else -1
        if pos < 0 or total[pos] == 0:
            out.append(m.n_y + j)
    return np.array(out, dtype=np.int64)


def label_entries(system) -> np.ndarray:
    """Entries of z that are discrete labels (modes, branches, contact flags): not memory and, for
    a scene, not the dependent coordinates' warm start. A periodic orbit must return to them."""
    nz = system.z0.size
    skip = set(int(i) for i in system.memory)
    if system.is_scene:
        nc, nd = len(system.kernel.topo.clearance), len(system.kernel.topo.dependent)
        skip |= set(range(nc, nc + nd))
    return np.array([i for i in range(nz) if i not in skip], dtype=np.int64)


class _FlowMap(System):
    """What the two derived maps share: the augmented state and the tangent run."""

    is_map = True
    is_derived = True
    time_unit = "iteration"

    def __init__(self, system, rtol: float | None):
        from nld.settings import LYAPUNOV, check_rtol
        if system.is_map:
            raise InputError(f"{system.name} is already a map: a derived map needs a flow")
        self.flow = system
        self.rtol = float(LYAPUNOV.rtol if rtol is None else check_rtol(rtol))
        self.memory = np.array(system.memory, dtype=np.int64)
        self.n_y = system.n
        self.n = system.n + self.memory.size
        self.p = system.p
        self.z0 = system.z0.copy()
        self.y0 = self.pack(system.y0, system.z0)
        self.contacts = contact_events(system)
        self.labels = label_entries(system)
        # the contact event that resets each memory entry (a scene: z[ci] is reset at the onset
        # of clearance joint ci; another flow: memory entry j by contact event j), -1: none
        if system.is_scene:
            self.memory_events = self.memory.copy()
        else:
            self.memory_events = np.array([j if j < self.contacts.size else -1
                                           for j in range(self.memory.size)], dtype=np.int64)
        mem_names = [f"z{i}" for i in self.memory]
        if system.is_scene:
            mem_names = [f"{system.kernel.topo.clearance[i]}.v_onset" for i in self.memory]
        self.state_names = list(system.state_names) + mem_names
        self.scales = np.concatenate([system.scales, self._memory_scales()])
        # step budget of one map step: 20x the most steps a step has taken so far (at least
        # MIN_STEP_BUDGET), so that a Newton trial state far off the attractor (a journal deep in
        # its bearing: a stiff contact, tiny steps) fails in bounded time instead of running for
        # minutes; the Newton treats the failure as a rejected trial
        self.typical_steps = 0
        self.angle_states = system.angle_states

    # ------------------------------------------------------------------ parameters
    def parameter(self, key) -> float:
        """The flow's parameter ``key`` (``System.parameter`` of the flow)."""
        return self.flow.parameter(key)

    def with_parameter(self, key, value):
        """The same map (periods or section, rtol) of the flow at ``key`` = value."""
        return self._of(self.flow.with_parameter(key, value))

    def _memory_scales(self) -> np.ndarray:
        """A scale for each memory entry (an approach velocity, m/s): the largest rate scale of a
        scene (clearance x crank speed), else 1."""
        if self.memory.size == 0:
            return np.zeros(0)
        s = self.flow.scales
        v = float(np.max(s[s.size // 2:])) if self.flow.is_scene else 1.0
        return np.full(self.memory.size, v)

    # ------------------------------------------------------------------ augmented state
    def pack(self, y, z) -> np.ndarray:
        """x = (y, z[memory])."""
        y = np.asarray(y, dtype=float).ravel()
        z = np.asarray(z, dtype=float).ravel()
        if y.size != self.n_y:
            raise InputError(f"y: {y.size} values given, the flow has {self.n_y} states")
        return np.concatenate([y, z[self.memory] if self.memory.size else np.zeros(0)])

    def unpack(self, x, z, relabel: bool = False):
        """(y, z) from x and a discrete state (copied) whose labels are kept, or with
        ``relabel`` set from y by the flow's ``init_modes`` where it has one."""
        x = np.asarray(x, dtype=float).ravel()
        z = np.array(z, dtype=float)
        y = x[:self.n_y].copy()
        init = self.flow.init_modes
        if relabel and init is not None:
            init(self.t0, np.ascontiguousarray(y), self.flow.p, z)
        # the map restarts at t0 whatever time x was reached at: the time's labels from y
        z = restart_labels(self.flow, self.t0, y, z)
        if self.memory.size:
            z[self.memory] = x[self.n_y:]
        return y, z

    def difference(self, a, b) -> np.ndarray:
        """a - b with angle differences brought into [-pi, pi) (whole turns are one state)."""
        d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
        idx = self.angle_states
        if idx.size:
            d[idx] -= 2.0 * math.pi * np.floor((d[idx] + math.pi) / (2.0 * math.pi))
        return d

    # ------------------------------------------------------------------ integration
    def step_budget(self) -> int:
        """The most steps one map step may take: unbounded (5e7) until a step has succeeded,
        then 20x the most steps a step has taken (at least MIN_STEP_BUDGET)."""
        if self.typical_steps == 0:
            return 50_000_000
        return int(max(MIN_STEP_BUDGET, 20 * self.typical_steps))

    def _plain(self, y, z, t0, t1, t_eval=None):
        """Integrate the flow from (t0, y, z) to t1 (landing there), counting contact onsets;
        with t_eval also return the states there (no landing on them)."""
        sysm = self.flow
        atol = sysm.tolerance(self.rtol)
        z = np.array(z, dtype=float)
        te = np.array([float(t1)]) if t_eval is None else np.asarray(t_eval, dtype=float)
        out = integrate(sysm, t0, y, z, te, land=t_eval is None, rtol=self.rtol, atol=atol,
                        max_steps=self.step_budget(), max_log=_MAX_LOG)
        if out.status != 0 or out.n_out < te.size:
            raise SolveError(f"{sysm.name}: " + failure_message(sysm, out, float(t0), y, z,
                                                                  self.rtol, atol)
                             + (f" (the map step's budget is {self.step_budget()} steps: 20x the "
                                f"most a step has taken)" if out.status == -1 and self.typical_steps
                                else ""))
        if t_eval is None:
            self.typical_steps = max(self.typical_steps, int(out.stats[0]))
        onsets = np.zeros(self.contacts.size, dtype=np.int64)
        k, d = out.ev_k[:out.n_ev], out.ev_dir[:out.n_ev]
        for j, e in enumerate(self.contacts):
            onsets[j] = int(np.count_nonzero((k == e) & (d > 0)))
        if out.n_ev >= _MAX_LOG:
            onsets[:] = -1          # the log overflowed: unknown
        return out, out.z, onsets

    def _tangent(self, y, z, t0, t1, divergence: bool = False):
        """(y(t1), z(t1), M, step info) from the tangent integrator, vectors from the identity."""
        from nld.systems.tangent import run_tangent
        sysm = self.flow
        n, m = self.n_y, self.memory.size
        N = n + m
        W = np.zeros((N, n))
        W[:n, :n] = np.eye(n)
        Wz = np.zeros((N, z.size))
        for j, i in enumerate(self.memory):
            Wz[n + j, i] = 1.0
        ne = int(sysm.n_events)
        diag = crossing_diag(ne)
        run = run_tangent(sysm, y, z, W, Wz, t0, [t1], self.rtol, want_div=divergence,
                          diag=diag, orthonormalise=False,
                          max_steps=self.step_budget())
        self.typical_steps = max(self.typical_steps, int(run.stats[0]) // 2)
        if run.status != 0:
            raise SolveError(f"{sysm.name}: the tangent integration stopped at t = {run.t:.6g} s "
                             f"(an on_event stop) before the end of the step")
        M = np.empty((N, N))
        M[:n, :] = run.W.T
        for j, i in enumerate(self.memory):
            M[n + j, :] = run.Wz[:, i]
        onsets = np.array([int(diag[N_DIAG + ne + e]) for e in self.contacts], dtype=np.int64)
        mins = np.array([diag[N_DIAG + e] for e in self.contacts])
        info = dict(onsets=onsets, min_approach=mins, log_det_saltation=float(diag[DG_LOGDET]),
                    divergence=float(diag[DG_DIV]) if divergence else math.nan,
                    grazing=int(diag[DG_GRAZE]))
        return run.y, run.z, M, info


class StroboscopicMap(_FlowMap):
    """The flow of a forced system (a scene: the crank revolution) sampled once every
    ``periods`` forcing periods: x_{k+1} = P(x_k), P the flow map from the phase t0 (the
    system's ``t0``) over periods * T, T the forcing period (s).

    system: a :class:`~nld.systems.ContinuousSystem` with a period (a scene system: the crank
    period). rtol: the integrations' relative tolerance (absolute: ``system.tolerance(rtol)``),
    default ``nld.settings.LYAPUNOV.rtol``. Time restarts at t0 every step (the forcing is
    T-periodic), so the map is the same at every step and round-off does not grow with the
    revolution count.
    """

    def __init__(self, system, periods: int = 1, rtol: float | None = None):
        super().__init__(system, rtol)
        if system.period is None:
            raise InputError(f"{system.name} has no forcing period: a stroboscopic map needs a "
                             f"forced flow (use PoincareMap for an autonomous one)")
        if isinstance(periods, bool) or not isinstance(periods, (int, np.integer)) or periods < 1:
            raise InputError(f"periods = {periods!r}: must be an integer >= 1")
        self.periods = int(periods)
        self.T = float(system.period) * self.periods
        self.t0 = float(system.t0)
        self.name = f"stroboscopic map of {system.name}"
        self.period_name = system.period_name

    def _of(self, flow) -> "StroboscopicMap":
        return StroboscopicMap(flow, self.periods, self.rtol)

    def step(self, x, z=None, *, jacobian: bool = False, divergence: bool = False,
             relabel: bool = False) -> MapStep:
        """P(x) (and its monodromy with ``jacobian``); z: the discrete state whose labels go with
        x (default the system's z0; ``relabel``: labels set from x by the flow's init_modes).
        Raises SolveError if the integration fails."""
        z = self.z0 if z is None else z
        y, zz = self.unpack(x, z, relabel)
        t0, t1 = self.t0, self.t0 + self.T
        if jacobian:
            y1, z1, M, info = self._tangent(y, zz, t0, t1, divergence)
        else:
            out, z1, onsets = self._plain(y, zz, t0, t1)
            y1, M, info = out.Y[0].copy(), None, dict(onsets=onsets)
        from nld.systems.core import wrap_angles
        y1 = wrap_angles(self.flow, y1)
        return MapStep(self.pack(y1, z1), z1, M, time=self.T, **info)

    def __call__(self, x, z=None):
        s = self.step(x, z)
        return s.x, s.z

    def orbit(self, x, z=None, n: int = 100, *, transient: int = 0, land: bool = False,
              start: bool = False, relabel: bool = True, progress: bool | None = None,
              max_steps: int | None = None, desc: str | None = None) -> "SectionRun":
        """The section points x_1 .. x_n after ``transient`` steps (``start``: x_0 .. x_{n-1},
        the first the state after the transient itself) at t = t0 + k T.

        Two ways to integrate:

        * ``land=False`` (default): two integrations, the transient, then the n steps sampled on
          the dense output (no landing at each period, so n steps cost one integration, not n;
          the census, ``nld.analysis.attractors``). Never raises for a failed integration: the
          result says how far it got.
        * ``land=True``: one integration from x, in chunks of one map step
          (``nld.run.simulate.integrate_chunked``), landing exactly on every section time, so a
          point carries the integration error only, no interpolation error; ``progress``: a bar
          in map steps (None: only on a terminal, after 2 s); Ctrl-C (or SIGTERM where the command
          line took it) stops it at the next step's end and raises :class:`nld.errors.Interrupted`
          whose ``partial`` is the SectionRun of the points reached (status
          ``nld.run.simulate.INTERRUPTED``). The Poincaré sections of ``nld.analysis.poincare``
          are this run. A failed integration is reported in the result, not raised.

        z: the discrete state with x (default the system's z0); ``relabel``: its labels set from
        x by the flow's init_modes (off: z taken as given, e.g. a previous run's). max_steps: the
        integrator's step budget for the whole run (default 5e7). Contact onsets are counted over
        the recorded steps only; ``gaps`` are the contact events' values (a scene: the
        penetration, m, > 0 in contact) at each recorded point. InputError when the points would
        not fit ``nld.run.simulate.MAX_OUTPUT_BYTES``."""
        from nld.run.simulate import MAX_OUTPUT_BYTES
        z = self.z0 if z is None else z
        y, zz = self.unpack(x, z, relabel=relabel)
        t0 = self.t0
        n, transient = int(n), int(transient)
        sysm = self.flow
        width = 2 * self.n_y + 2 * zz.size + self.n + self.contacts.size + 1
        if n * width * 8 > MAX_OUTPUT_BYTES:
            raise InputError(f"n = {n}: {n:.3g} section points would need "
                             f"{n * width * 8 / 2**30:.3g} GiB; at most "
                             f"{MAX_OUTPUT_BYTES // (width * 8):.3g} fit the "
                             f"{MAX_OUTPUT_BYTES / 2**30:g} GiB output limit")
        max_steps = 50_000_000 if max_steps is None else int(max_steps)
        atol = sysm.tolerance(self.rtol)
        if land:
            return self._orbit_landing(y, zz, n, transient, start, atol, max_steps, progress,
                                       desc)
        if transient > 0:
            try:
                out, zz, _ = self._plain(y, zz, t0, t0 + transient * self.T)
            except SolveError as e:
                return SectionRun(np.zeros((0, self.n)), zz, np.zeros(self.contacts.size, np.int64),
                                  np.zeros((0, self.contacts.size)), False, str(e), y,
                                  Y=np.zeros((0, self.n_y)), Z=np.zeros((0, zz.size)), status=-1,
                                  t_reached=t0, z_reached=np.array(zz))
            y = wrap_angles_of(self.flow, out.Y[0].copy())
            zz = restart_labels(self.flow, t0, y, zz)
        # time restarts at t0 after the transient (the forcing is T-periodic)
        k0 = 0 if start else 1
        te = t0 + self.T * np.arange(k0, n + k0)
        out = integrate(sysm, t0, y, zz, te, land=False, rtol=self.rtol, atol=atol,
                        max_steps=max_steps, max_log=_MAX_LOG + 400 * n)
        m = int(out.n_out)
        onsets = self._count_onsets(out.ev_k[:out.n_ev], out.ev_dir[:out.n_ev])
        ok = out.status == 0 and m == n
        msg = "" if ok else f"{sysm.name}: " + failure_message(sysm, out, float(t0), y, zz,
                                                                 self.rtol, atol)
        Z = np.array(out.Z[:m])
        z_end = np.array(Z[-1]) if m else np.array(zz)
        run = self._section_run(te[:m], np.array(out.Y[:m]), Z, onsets, ok, msg, y,
                                int(out.status), float(out.t), out.stats, z_end, z_end,
                                shift=transient * self.T)
        if out.n_ev < _MAX_LOG + 400 * n:
            run.step_onsets = self._step_onsets(te[:m], out.ev_t[:out.n_ev],
                                                out.ev_k[:out.n_ev], out.ev_dir[:out.n_ev])
        return run

    def _step_onsets(self, te, ev_t, ev_k, ev_dir) -> np.ndarray:
        """(m, n_contacts): the onsets of each contact event in each step (te_k - T, te_k]
        from an event log."""
        out = np.zeros((te.size, self.contacts.size), dtype=np.int64)
        if te.size == 0:
            return out
        edges = np.concatenate([[te[0] - self.T], te])
        ev_k, ev_dir = np.asarray(ev_k), np.asarray(ev_dir)
        for j, e in enumerate(self.contacts):
            t = np.asarray(ev_t, dtype=float)[(ev_k == e) & (ev_dir > 0)]
            k = np.searchsorted(edges, t, side="left") - 1     # t in (edges[k], edges[k+1]]
            k = k[(k >= 0) & (k < te.size)]
            out[:, j] = np.bincount(k, minlength=te.size)
        return out

    def _count_onsets(self, k, d) -> np.ndarray:
        onsets = np.zeros(self.contacts.size, dtype=np.int64)
        for j, e in enumerate(self.contacts):
            onsets[j] = int(np.count_nonzero((k == e) & (d > 0)))
        return onsets

    def _section_run(self, t, Y, Z, onsets, ok, msg, y_start, status, t_reached, stats, z_end,
                     z_reached, shift=0.0) -> "SectionRun":
        """The SectionRun of the raw states Y, Z at integration times t (X: angles wrapped,
        memory packed); ``shift``: added to t and t_reached for the run's times (the dense
        mode's integration restarts at t0 after the transient)."""
        sysm = self.flow
        m = t.size
        X = np.empty((m, self.n))
        gaps = np.zeros((m, self.contacts.size))
        g = np.zeros(max(1, int(sysm.n_events)))
        for i in range(m):
            yi = wrap_angles_of(sysm, Y[i].copy())
            X[i] = self.pack(yi, Z[i])
            if self.contacts.size:
                sysm.events(float(t[i]), np.ascontiguousarray(yi), sysm.p,
                            np.ascontiguousarray(Z[i]), g)
                gaps[i] = g[self.contacts]
        return SectionRun(X, z_end, onsets, gaps, bool(ok), msg, y_start, t=np.array(t) + shift,
                          Y=Y, Z=Z, status=int(status), t_reached=float(t_reached) + shift,
                          stats=np.asarray(stats, dtype=np.int64).copy(),
                          z_reached=np.array(z_reached, dtype=float))

    def _orbit_landing(self, y, zz, n, transient, start, atol, max_steps, progress, desc):
        """orbit(land=True): one chunked integration from t0 landing on every section time."""
        from nld.errors import Interrupted
        from nld.integrators import method_status_message
        from nld.run.simulate import INTERRUPTED, event_log_size, interrupted_message
        sysm = self.flow
        t0 = self.t0
        k0 = transient if start else transient + 1
        k = np.arange(k0, k0 + n)
        te = np.ascontiguousarray(t0 + k * self.T, dtype=float)
        y = np.ascontiguousarray(y, dtype=float)
        max_log = event_log_size((te[-1] - t0) / float(sysm.period))
        out = integrate(sysm, t0, y, zz, te, land=True, rtol=self.rtol, atol=atol,
                        max_steps=max_steps, max_log=max_log, span=self.T, progress=progress,
                        desc=desc or f"section {sysm.name}")
        status, t_reached, Y, st, Z, z = out.status, out.t, out.Y, out.stats, out.Z, out.z
        ev_t, ev_k, ev_dir, n_logged = out.ev_t, out.ev_k, out.ev_dir, out.n_ev
        m = int(out.n_out)
        # onsets over the recorded steps: after the first recorded point's time (start) or the
        # transient's end
        t_rec = t0 + transient * self.T
        after = ev_t > t_rec
        onsets = self._count_onsets(ev_k[after], ev_dir[after])
        if n_logged > max_log:
            onsets[:] = -1          # the log overflowed: unknown
        ok = status == 0 and m == n
        if status == INTERRUPTED:
            msg = interrupted_message(t_reached, t0, float(te[-1]), m, n)
        elif ok:
            msg = ""
        else:       # (no escape probe: it would repeat the whole run in one call)
            msg = f"{sysm.name}: " + method_status_message(
                sysm.method, status, t_reached, st, contacts=int(sysm.n_events) > 0)
        Zm = np.array(Z[:m])
        z_end = np.array(Zm[-1]) if m else np.array(zz)
        run = self._section_run(te[:m], np.array(Y[:m]), Zm, onsets, ok, msg, y, status,
                                t_reached, st, z_end, z)
        if n_logged <= max_log:
            run.step_onsets = self._step_onsets(te[:m], ev_t[:n_logged], ev_k[:n_logged],
                                                ev_dir[:n_logged])
        if out.interrupted:
            raise Interrupted(msg or "interrupted", partial=run,
                              kept=f"{m} of {n} section points (t = {t0:g} .. {t_reached:.6g} s)")
        return run

    def trajectory(self, x, z=None, n_samples: int = 200, *, with_z: bool = False):
        """The flow's states along one step from x: (t (s) from the step's start, Y (n_samples,
        n)), and the discrete state in force at each sample (n_samples, nz) with ``with_z``."""
        z = self.z0 if z is None else z
        y, zz = self.unpack(x, z, relabel=True)
        te = self.t0 + self.T * np.arange(n_samples) / (n_samples - 1)
        out, _, _ = self._plain(y, zz, self.t0, te[-1], t_eval=te)
        if with_z:
            return te - self.t0, out.Y[:n_samples].copy(), out.Z[:n_samples].copy()
        return te - self.t0, out.Y[:n_samples].copy()

    def __repr__(self):
        return f"StroboscopicMap({self.flow.name!r}, periods={self.periods}, rtol={self.rtol:g})"


class PoincareMap(_FlowMap):
    """The first return of an autonomous flow to the hyperplane normal . y = offset, crossed in
    ``direction`` (+1: normal . f > 0).

    The crossing is bracketed on the dense output (``dt`` apart, s; default 1/50 of the flow's
    ``hmax`` or 0.01) after a dead time ``t_min`` (s, default 2 dt) and located by
    ``nld.systems.section.locate_crossing``, the routine of ``hyperplane_section`` too: Brent's
    method on the crossing time, g evaluated on landing integrations, |dt| <= 1e-13 max(1, t) s.
    Its Jacobian is the projection (I - f n^T / (n . f)) Phi of the flow's state-transition
    matrix Phi to the return time (the return time's dependence on the start), which maps into
    the section's tangent space; its multipliers (``nld.analysis.orbits``) are those of that
    restriction.
    """

    def __init__(self, system, normal, offset: float = 0.0, direction: int = 1, *,
                 dt: float | None = None, t_min: float | None = None, t_max: float = 1e4,
                 rtol: float | None = None):
        super().__init__(system, rtol)
        nrm = np.array(normal, dtype=float).ravel()
        if nrm.size != system.n or not np.all(np.isfinite(nrm)) or not np.any(nrm):
            raise InputError(f"normal = {normal!r}: must be {system.n} finite numbers, not all 0")
        if direction not in (1, -1):
            raise InputError(f"direction = {direction!r}: must be +1 or -1")
        self.normal = nrm
        self.offset = float(offset)
        self.direction = int(direction)
        self.dt = float(dt) if dt is not None else (system.hmax / 50.0 if system.hmax > 0
                                                    else 0.01)
        if not (self.dt > 0 and math.isfinite(self.dt)):
            raise InputError(f"dt = {dt!r}: must be a positive time (s)")
        self.t_min = 2.0 * self.dt if t_min is None else float(t_min)
        self.t_max = float(t_max)
        self.t0 = float(system.t0)
        self.name = f"Poincaré map of {system.name}"
        self.period_name = "return"
        # an orthonormal basis of the section's tangent space (for the multipliers)
        q, _ = np.linalg.qr(np.column_stack([nrm] + [np.eye(system.n)[i]
                                                      for i in range(system.n)]))
        self.plane_basis = q[:, 1:system.n]

    def _of(self, flow) -> "PoincareMap":
        return PoincareMap(flow, self.normal, self.offset, self.direction, dt=self.dt,
                           t_min=self.t_min, t_max=self.t_max, rtol=self.rtol)

    def _g(self, y):
        return float(self.normal @ y) - self.offset

    def _crossing(self, y, z):
        """(t*, y(t*), z(t*)) of the first crossing after t_min."""
        t = self.t0
        chunk = 64
        while t - self.t0 < self.t_max:
            te = t + self.dt * np.arange(1, chunk + 1)
            out, _, _ = self._plain(y, z, t, te[-1], t_eval=te)
            prev_t, prev_y, prev_z = t, y, z
            for i in range(te.size):
                yi = out.Y[i]
                g0, g1 = self._g(prev_y), self._g(yi)
                if (te[i] - self.t0 > self.t_min and self.direction * g0 < 0.0
                        and self.direction * g1 >= 0.0):
                    return locate_crossing(self.flow, lambda t, yy, zz: self._g(yy), prev_t,
                                           prev_y, prev_z, te[i], rtol=self.rtol,
                                           max_steps=self.step_budget())
                prev_t, prev_y, prev_z = te[i], yi, out.Z[i].copy()
            t, y, z = te[-1], out.Y[-1].copy(), out.Z[-1].copy()
        raise SolveError(f"{self.flow.name}: no crossing of the section within t_max = "
                         f"{self.t_max:g} s")

    def step(self, x, z=None, *, jacobian: bool = False, divergence: bool = False,
             relabel: bool = False) -> MapStep:
        """The next crossing from x (and the projected Jacobian with ``jacobian``)."""
        z = self.z0 if z is None else z
        y, zz = self.unpack(x, z, relabel)
        tc, yc, zc = self._crossing(y, zz)
        info = {}
        M = None
        if jacobian:
            y1, z1, M, info = self._tangent(y, zz, self.t0, tc, divergence)
            f = np.empty(self.n_y)
            self.flow.rhs(tc, np.ascontiguousarray(y1), self.p, z1, f)
            nf = float(self.normal @ f)
            if nf == 0.0:
                raise SolveError(f"{self.flow.name}: the flow is tangent to the section at the "
                                 f"crossing (n . f = 0)")
            # the first-order correction onto the plane (the tangent run's own crossing)
            y1 = y1 - f * self._g(y1) / nf
            P = np.eye(self.n_y) - np.outer(f, self.normal) / nf
            M[:self.n_y, :] = P @ M[:self.n_y, :]
            yc, zc = y1, z1
        return MapStep(self.pack(yc, zc), zc, M, time=tc - self.t0, **info)

    def __call__(self, x, z=None):
        s = self.step(x, z)
        return s.x, s.z

    def __repr__(self):
        return (f"PoincareMap({self.flow.name!r}, normal={self.normal.tolist()}, "
                f"offset={self.offset:g}, direction={self.direction:+d})")


class NumbaMap(System):
    """A :class:`~nld.systems.DiscreteMap` in the derived maps' interface (no discrete state):
    ``step(x, jacobian=True)`` gives f(x) and its Jacobian (the map's ``jacobian`` or central
    finite differences, steps 1e-6 * scales)."""

    is_map = True
    is_derived = False
    period_name = "iteration"

    def __init__(self, system):
        self.flow = None
        self.system = system
        self.name = system.name
        self.n = self.n_y = system.n
        self.p = system.p
        self.y0 = system.y0.copy()
        self.z0 = np.zeros(0)
        self.memory = np.zeros(0, dtype=np.int64)
        self.contacts = np.zeros(0, dtype=np.int64)
        self.labels = np.zeros(0, dtype=np.int64)
        self.scales = system.scales
        self.state_names = list(system.state_names)
        self.angle_states = np.zeros(0, dtype=np.int64)
        self.rtol = 0.0
        self._tmp = np.empty(self.n)
        self._checked = False

    def parameter(self, key) -> float:
        return self.system.parameter(key)

    def with_parameter(self, key, value):
        """The map at ``key`` = value (``System.with_parameter`` of the DiscreteMap)."""
        return NumbaMap(self.system.with_parameter(key, value))

    def pack(self, y, z=None):
        return np.asarray(y, dtype=float).ravel().copy()

    def unpack(self, x, z=None):
        return np.asarray(x, dtype=float).ravel().copy(), np.zeros(0)

    def difference(self, a, b):
        return np.asarray(a, dtype=float) - np.asarray(b, dtype=float)

    def _jac(self, x):
        J = np.zeros((self.n, self.n))
        jac = self.system.jacobian
        if jac is not None:
            jac(x, self.p, J)
            return J
        f = self.system.f
        fp, fm = np.empty(self.n), np.empty(self.n)
        for j in range(self.n):
            h = 1e-6 * self.scales[j]
            xp, xm = x.copy(), x.copy()
            xp[j] += h
            xm[j] -= h
            f(xp, self.p, fp)
            f(xm, self.p, fm)
            J[:, j] = (fp - fm) / (2.0 * h)
        return J

    def step(self, x, z=None, *, jacobian: bool = False, divergence: bool = False,
             relabel: bool = False) -> MapStep:
        x = np.ascontiguousarray(x, dtype=float)
        out = np.empty(self.n)
        self.system.f(x, self.p, out)
        return MapStep(out, np.zeros(0), self._jac(x) if jacobian else None, time=1.0)

    def __call__(self, x, z=None):
        return self.step(x).x, np.zeros(0)

    def __repr__(self):
        return f"NumbaMap({self.name!r})"


def as_map(system, rtol: float | None = None):
    """The map an orbit analysis works on: a derived map as it is, a DiscreteMap wrapped
    (:class:`NumbaMap`), a forced flow's one-period :class:`StroboscopicMap` at ``rtol``."""
    if isinstance(system, (_FlowMap, NumbaMap)):
        return system
    if system.is_map:
        return NumbaMap(system)
    if system.period is None:
        raise InputError(f"{system.name} is an autonomous flow: give a PoincareMap(system, normal, "
                         f"offset) to find its periodic orbits")
    return StroboscopicMap(system, 1, rtol)
