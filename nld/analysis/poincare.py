"""Poincaré sections: stroboscopic maps, hyperplane sections and period detection.

* :func:`stroboscopic` -- the state sampled at exact multiples of the crank period T = 2 pi/|omega|
  of a speed-driven crank (or of the forcing period of a forced ODE), after a transient given in
  revolutions: the orbit of the system's :class:`nld.systems.StroboscopicMap` (one path for
  scenes and ODEs). The integrator *lands* on every sampling time, so a section point carries
  only the integration error, no interpolation error.
* :func:`hyperplane_section` -- crossings of a hypersurface g = level in a chosen direction: the
  crank angle = theta0 (mod 2 pi) of a torque-driven crank, or any observable (table column of a
  scene, state of an ODE) crossing a level. Crossings are bracketed on a fine output grid and then
  located by ``nld.systems.section.locate_crossing`` (Brent on landing integrations, the routine
  of :class:`nld.systems.PoincareMap`), or on a Hermite interpolant (see the function).
* :func:`period_of` -- period-n detection of a sequence of section points, by
  :func:`section_period`, the one period test of nld (the attractor census uses it too).

Scenes are given as a :class:`~nld.model.scene_model.Scene`, a built-in name or a TOML path plus
``overrides`` (as ``nld --set``); any other ODE as a :class:`nld.systems.ContinuousSystem` (a numba
``rhs(t, y, p, z, dy)`` integrated by ``nld.integrators.dopri5``), see :func:`stroboscopic_rhs`.
Units: times in s, every observable in the SI unit of its table column (docs/analysis.md).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from nld.errors import InputError, Interrupted
from nld.settings import LYAPUNOV, POINCARE_SPANS, SECTIONS

__all__ = ["Section", "stroboscopic", "stroboscopic_rhs", "hyperplane_section", "period_of",
           "section_period", "section_scales",
           "default_observables", "check_scene_observables"]

TWO_PI = 2.0 * math.pi
DEFAULT_PERIOD_TOL = 1e-6
DEFAULT_N_MAX = 16
DEFAULT_SAMPLES_PER_REV = SECTIONS.samples_per_rev


@dataclass
class Section:
    """Points of a Poincaré section and the state at the end of the run.

    table:   one row per section point: ``rev`` (stroboscopic: revolution / forcing-period count
             since t = 0) or ``crossing`` (hyperplane: crossing count), ``t`` (s) and the
             observables (SI units of the table columns).
    y_final, z_final, t_final: continuous and discrete state at the end of the run (for a
             stroboscopic section: at the last section point, a multiple of the period, so a
             next run started from it at t0 = 0 continues the same trajectory).
    status, message: as ``nld.run.simulate`` (status < 0: the integration failed; the table holds the
             points reached).
    period:  sampling period T (s) of a stroboscopic section, None for a hyperplane section.
    """
    table: pd.DataFrame
    observables: list[str]
    y_final: np.ndarray
    z_final: np.ndarray
    t_final: float
    status: int
    message: str
    period: float | None = None
    provenance: dict = field(default_factory=dict)

    @property
    def success(self) -> bool:
        return self.status >= 0

    @property
    def points(self) -> np.ndarray:
        """The observables as an (n_points, n_observables) array."""
        return self.table[self.observables].to_numpy(dtype=float)

    def period_of(self, tol: float = DEFAULT_PERIOD_TOL, n_max: int = DEFAULT_N_MAX) -> int:
        """Period of the section points (see :func:`period_of`)."""
        return period_of(self.points, tol=tol, n_max=n_max)


# ---------------------------------------------------------------------------------------------------
# helpers


def _is_system(obj) -> bool:
    """A System (nld.systems.base), not a scene given by object, name or path."""
    from nld.systems.base import System
    return isinstance(obj, System)


def load_scene_arg(scene, overrides):
    """Scene from a Scene/name/path plus overrides (as nld.run.simulate does)."""
    from nld.model.scene import resolve_scene
    from nld.run.simulate import check_scene_arg
    check_scene_arg(scene)
    return resolve_scene(scene, overrides)


def default_observables(kernel) -> list[str]:
    """The journal eccentricity components ``<J>.ex, <J>.ey`` (m) of the first clearance joint;
    without clearance joints, angle and rate of the first moving body that is not the crank."""
    clear = kernel.topo.clearance
    if clear:
        return [f"{clear[0]}.ex", f"{clear[0]}.ey"]
    crank = None
    sc = kernel.scene
    if sc.driver is not None:
        j = sc.joints[sc.driver.joint]
        crank = j.bodies[0] if j.bodies[0] != "ground" else j.bodies[1]
    for b in sc.bodies:
        if b != crank:
            return [f"{b}.theta", f"{b}.omega"]
    return ["driver.angle", "driver.speed"]


def check_scene_observables(scene, observables, overrides=None) -> list[str]:
    """``observables`` (a list or comma-separated text) checked against the table columns of
    ``scene`` (with ``overrides``); InputError naming the first unknown one and the columns."""
    from nld.kernel.compile import compile_scene
    kern = compile_scene(load_scene_arg(scene, overrides))
    return _check_observables(observables, ["t"] + list(kern.columns))


def _check_observables(observables, available, what="column") -> list[str]:
    if isinstance(observables, str):
        observables = [o.strip() for o in observables.split(",") if o.strip()]
    observables = list(observables)
    if not observables:
        raise InputError("observables: give at least one")
    bad = [o for o in observables if o not in available]
    if bad:
        raise InputError(f"observable {bad[0]!r}: no such {what}; available: {', '.join(available)}")
    return observables


def check_count(name, v, minimum):
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < minimum:
        raise InputError(f"{name} = {v!r}: must be an integer >= {minimum}")
    return int(v)


def _system_observables(system):
    return ["t"] + list(system.state_names)


# ---------------------------------------------------------------------------------------------------
# stroboscopic map


def stroboscopic(scene, *, transient_revs: int = POINCARE_SPANS.transient_revs,
                 revs: int = POINCARE_SPANS.revs, observables=None,
                 overrides=None, rtol: float = SECTIONS.rtol, y0=None, z0=None, kernel=None,
                 max_steps: int = SECTIONS.max_steps, progress: bool | None = None) -> Section:
    """Stroboscopic Poincaré map: observables at t = k T, k = transient_revs .. transient_revs+revs-1.

    scene: Scene, built-in name or TOML path (``overrides`` as ``nld --set``) of a mechanism with
    a speed-driven crank, T = 2 pi / |driver.speed|; or a :class:`nld.systems.ContinuousSystem`
    with a forcing ``period`` (T), whose observables are its state names (and ``t``).
    transient_revs: whole periods integrated and discarded first; revs: number of section points.
    observables: table columns (``B.ex``, ``B.ey``, ``rod.theta``, ``rod.omega`` ...; default
    :func:`default_observables`). rtol: relative tolerance (absolute: rtol x clearance-based state
    scales, as ``simulate``). y0, z0: start state at t = 0 (e.g. ``y_final``/``z_final`` of a
    previous section: continuation).

    One path for scenes and systems: the section is the orbit of the system's stroboscopic map,
    ``nld.systems.StroboscopicMap(system, rtol=rtol).orbit(..., land=True, start=True)`` (a
    scene: its :func:`nld.systems.SceneSystem`, with ``simulate``'s tolerances, step cap and
    start state, so the points are those of ``simulate(..., t_eval=k*T, land=True)`` bit for
    bit); one integration from t = 0 in chunks of one period.

    Accuracy: the integrator lands exactly on every sampling time, so the points carry the
    integration error only, no interpolation error. Measured against rtol 1e-12 (docs/analysis.md):
    the Flores slider-crank (chaotic) 1e-4 of the clearance after one revolution at rtol 1e-8,
    growing to the clearance itself within a few revolutions (only the statistics of a chaotic
    section are meaningful); the period-1 four-bar at 10 rad/s 1e-5 of the clearance at
    rtol 1e-8, 1e-6 at rtol 1e-10.

    progress: a bar in crank revolutions (see ``nld.run.simulate``). Ctrl-C raises
    :class:`nld.errors.Interrupted` whose ``partial`` is the Section of the points reached.
    """
    from nld.settings import check_rtol
    from nld.run.simulate import INTERRUPTED, MAX_OUTPUT_BYTES, interrupted_message
    from nld.systems.derived import StroboscopicMap
    transient_revs = check_count("transient_revs", transient_revs, 0)
    revs = check_count("revs", revs, 1)
    sc = kern = None
    if _is_system(scene):
        system = scene
        if system.is_map:
            raise InputError(f"{system.name} is a map: iterate it, a stroboscopic section is for "
                             "flows")
        if system.period is None:
            raise InputError(f"{system.name}: a stroboscopic section needs a forcing period "
                             "(ContinuousSystem(period=...))")
        obs = _check_observables(observables if observables is not None
                                 else list(system.state_names), _system_observables(system),
                                 "state")
        y = np.ascontiguousarray(system.y0 if y0 is None else y0, dtype=float).copy()
        z = np.array(system.z0 if z0 is None else z0, dtype=float)
        if y.shape != (system.n,):
            raise InputError(f"y0 = {y0!r}: need {system.n} values")
        check_rtol(rtol)
    else:
        from nld.kernel.compile import compile_scene
        from nld.run.simulate import state_arg, initial_state
        from nld.systems.core import SceneSystem
        sc = load_scene_arg(scene, overrides)
        if sc.driver is None or sc.driver.mode != "speed":
            raise InputError(f"scene {sc.name!r}: a stroboscopic section needs a speed-driven "
                             "crank (driver.mode = \"speed\"); use hyperplane_section for a "
                             "torque-driven crank (crank angle = theta0 mod 2 pi)")
        kern = kernel if kernel is not None else compile_scene(sc)
        obs = _check_observables(observables if observables is not None
                                 else default_observables(kern), ["t"] + list(kern.columns))
        fit = MAX_OUTPUT_BYTES // ((len(kern.columns) + 24) * 8)
        if revs > fit:          # the table holds every column at each section time
            raise InputError(f"revs = {revs}: {revs:.3g} section points would need "
                             f"{revs * (len(kern.columns) + 24) * 8 / 2**30:.3g} GiB; at most "
                             f"{fit:.3g} fit the {MAX_OUTPUT_BYTES / 2**30:g} GiB output limit")
        check_rtol(rtol)
        # the start state and the tolerances exactly as ``simulate`` sets them: the assembled
        # state's scales unless both y0 and z0 are given (then the scales at y0)
        if y0 is None or z0 is None:
            y_a, z_a, _ = initial_state(kern)
            y = y_a if y0 is None else state_arg("y0", y0, kern.n_state)
            if z0 is None:
                z = z_a.copy()
                kern.init_modes(0.0, y, kern.params(sc), z)
            else:
                z = state_arg("z0", z0, kern.n_z)
            system = SceneSystem(sc, kernel=kern, method=sc.method or "dopri5")
        else:
            y, z = state_arg("y0", y0, kern.n_state), state_arg("z0", z0, kern.n_z)
            system = SceneSystem(sc, kernel=kern, method=sc.method or "dopri5", y0=y)
    smap = StroboscopicMap(system, rtol=rtol)
    T = smap.T
    k = np.arange(transient_revs, transient_revs + revs)
    t_end = float(k[-1] * T) if k[-1] > 0 else T * 1e-9     # (messages: a one-point section at 0)
    start = time.perf_counter()
    interrupted = False
    try:
        run = smap.orbit(smap.pack(y, z), z, revs, transient=transient_revs, land=True,
                         start=True, relabel=False, progress=progress, max_steps=max_steps,
                         desc=f"stroboscopic {sc.name if sc is not None else system.name}")
    except Interrupted as e:
        from nld.systems.derived import SectionRun
        if not isinstance(e.partial, SectionRun):
            raise
        run, interrupted = e.partial, True
    n = run.t.size
    status, t_reached = int(run.status), float(run.t_reached)
    table = pd.DataFrame({"rev": k[:n].astype(np.int64), "t": run.t})
    if sc is not None:
        from nld.interrupt import deferred
        from nld.run.simulate import failure_context, provenance
        ncols = len(kern.columns)
        rows = np.empty((n, ncols))
        with deferred() as sig:
            kern.module.observe_all(np.ascontiguousarray(run.t), np.ascontiguousarray(run.Y),
                                    np.ascontiguousarray(run.Z), n, system.p, rows)
            if sig.requested:
                sig.handled = interrupted = True
        for o in obs:
            if o != "t":
                table[o] = rows[:, kern.columns.index(o)]
        msg = (interrupted_message(t_reached, 0.0, t_end, n, revs, sc) if status == INTERRUPTED
               else _status_text(system, status, t_reached, run.stats))
        if status < 0:
            msg += failure_context(kern, rows, n)
        if interrupted and status != INTERRUPTED and n < revs:
            status, msg = INTERRUPTED, interrupted_message(t_reached, 0.0, t_end, n, revs, sc)
        prov = provenance(sc, kern, rtol=rtol, t_end=t_end, wall=time.perf_counter() - start,
                          integrator=_method(system))
        prov["event_samples"] = int(system.event_samples)
        if interrupted:
            prov.update(partial=status == INTERRUPTED, interrupted=True)
        prov.update(kind="stroboscopic", transient_revs=transient_revs, revs=revs, period=T,
                    observables=obs, rtol=rtol, status=status, message=msg,
                    wall=time.perf_counter() - start, continued=y0 is not None,
                    overrides=dict(overrides) if isinstance(overrides, dict)
                    else list(overrides or []))
    else:
        for o in obs:
            if o != "t":
                table[o] = run.Y[:, system.state_names.index(o)]
        msg = (interrupted_message(t_reached, 0.0, t_end, n, revs) if status == INTERRUPTED
               else _status_text(system, status, t_reached, run.stats))
        prov = _system_provenance(system, kind="stroboscopic", transient_revs=transient_revs,
                                  revs=revs, period=T, observables=obs, rtol=rtol, status=status,
                                  message=msg, wall=time.perf_counter() - start)
        if interrupted:
            prov.update(partial=True, interrupted=True)
    y_final = run.Y[n - 1].copy() if n else np.asarray(y, float).copy()
    sec = Section(table, obs, y_final, np.array(run.z_reached, dtype=float), t_reached, status,
                  msg, T, prov)
    if interrupted:
        raise Interrupted(msg, partial=sec,
                          kept=f"{n} of {revs} section points (t = 0 .. {t_reached:.6g} s)")
    return sec


def _method(system) -> str:
    """The integrator a system runs (``system.method``; dopri5 for a system without one)."""
    return str(system.method or "dopri5")


def _status_text(system, status, t_reached, stats) -> str:
    """The status message of a run of ``system`` in the words of the method it ran."""
    from nld.integrators import method_status_message
    from nld.integrators.dopri5 import status_message
    m = _method(system)
    return (status_message(status, t_reached, stats) if m == "dopri5"
            else method_status_message(m, status, t_reached, stats))


def _system_provenance(system, **extra) -> dict:
    from nld.version import __version__
    from nld.output.provenance import git_hash
    d = {"nld_version": __version__, "git_hash": git_hash(), "system": system.name,
         "parameters": system.p.tolist(), "integrator": _method(system)}
    d.update(extra)
    return d


def stroboscopic_rhs(rhs, y0, p, period: float, *, transient_revs: int = POINCARE_SPANS.transient_revs,
                     revs: int = POINCARE_SPANS.revs, rtol: float = LYAPUNOV.rtol,
                     state_names=None, scales=None, name: str = "ode",
                     observables=None, max_steps: int = LYAPUNOV.max_steps, solve=None) -> Section:
    """Stroboscopic map of any T-periodic ODE given as a numba ``rhs(t, y, p, z, dy)``.

    The ODE is wrapped in :class:`nld.systems.ContinuousSystem` (DOPRI5 of
    ``nld.integrators.dopri5`` with ``no_events``/``no_on_event``). The integrator is compiled
    once per machine (nld.integrators.core); a user rhs costs only its own compilation. ``solve``
    (optional): ``solve(t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps, n_events,
    max_log)`` returning a ``nld.integrators.Solution``, e.g. ``nld.integrators.bind("dop853",
    rhs)`` for another method. Example, the forced
    Duffing oscillator::

        from nld.systems.core import duffing_rhs
        sec = stroboscopic_rhs(duffing_rhs, [1, 0], [0.3, -1, 1, 0.2, 1.2], 2*pi/1.2,
                               transient_revs=200, revs=50)

    (``nld.systems.duffing(...)`` gives the same system with a disk-cached integrator.)
    """
    from nld.systems.core import ContinuousSystem
    system = ContinuousSystem(rhs, y0, p, name, state_names, scales, period, solve=solve)
    return stroboscopic(system, transient_revs=transient_revs, revs=revs, observables=observables,
                        rtol=rtol, max_steps=max_steps)


# ---------------------------------------------------------------------------------------------------
# hyperplane sections


class _Flow:
    """What a hyperplane section needs of a scene or an ODE: solve, observe, rhs, state."""

    def __init__(self, system, columns, observe_rows, observe_one):
        self.system = system
        self.columns = columns            # observable names
        self.observe_rows = observe_rows  # (t_eval, Y, Z, n) -> (n, ncols)
        self.observe_one = observe_one    # (t, y, z) -> (ncols,)


def _scene_flow(scene, overrides, kernel):
    from nld.kernel.compile import compile_scene
    from nld.systems.core import SceneSystem
    sc = load_scene_arg(scene, overrides)
    kern = kernel if kernel is not None else compile_scene(sc)
    system = SceneSystem(sc, kernel=kern)
    mod, p = kern.module, system.p
    cols = ["t"] + list(kern.columns)
    ncols = len(kern.columns)

    def rows(t_eval, Y, Z, n):
        out = np.empty((n, ncols))
        mod.observe_all(t_eval, Y, Z, n, p, out)
        return np.column_stack([t_eval[:n], out])

    def one(t, y, z):
        row = np.empty(ncols)
        mod.observe(float(t), np.ascontiguousarray(y), p, np.array(z, dtype=float), row)
        return np.concatenate([[t], row])
    return _Flow(system, cols, rows, one), sc


def _system_flow(system):
    cols = _system_observables(system)

    def rows(t_eval, Y, Z, n):
        return np.column_stack([t_eval[:n], Y[:n]])

    def one(t, y, z):
        return np.concatenate([[t], y])
    return _Flow(system, cols, rows, one)


def hyperplane_section(scene, *, observable: str = "driver.angle", level: float | None = None,
                       direction: int = 1, modulo: float | None = None, transient_revs: float = 0.0,
                       revs: float | None = None, t_transient: float | None = None,
                       t_end: float | None = None, observables=None, overrides=None,
                       rtol: float = SECTIONS.rtol, samples_per_rev: int = DEFAULT_SAMPLES_PER_REV,
                       dt: float | None = None, y0=None, z0=None, refine: bool = True,
                       kernel=None, max_steps: int = SECTIONS.max_steps,
                       progress: bool | None = None) -> Section:
    """Poincaré section at the crossings of ``observable`` through ``level`` in ``direction``.

    scene: Scene / name / TOML path (+ ``overrides``), or a ContinuousSystem (observables: its
    state names). observable: a table column (default ``driver.angle``, the crank angle; with
    ``modulo`` = 2 pi, the default for ``driver.angle``, the section is angle = level mod 2 pi and
    ``level`` defaults to driver.angle0). direction: +1 increasing, -1 decreasing, 0 both.
    Time span: the transient ``transient_revs`` nominal crank periods (2 pi/|driver.speed| of the
    initial speed; or ``t_transient`` s), then ``revs`` periods (or up to ``t_end`` s).
    observables: columns recorded at each crossing (default: those of :func:`stroboscopic`).

    Location: the run is output on a grid of ``samples_per_rev`` points per period (or step
    ``dt`` s) from the dense output of DOPRI5 (4th order, error ~ the tolerance); a sign change of
    g = observable - level (the branch level + 2 pi m for an angle) between two grid points
    brackets a crossing (a crossing pair inside one grid step is missed: keep the grid finer than
    the fastest return). Then

    * ``refine=True`` (default): ``nld.systems.section.locate_crossing``, the routine of the
      Poincaré map (``nld.systems.PoincareMap``) too: the bracket is re-integrated from the
      stored state at its left end with the integrator landing exactly on each trial time, and
      Brent's method finds the root to |dt| <= 1e-13 max(1, t): the section point is then as
      accurate as the integration itself (|g| at the point ~1e-12 of the observable's scale).
      Where the landing integrations do not change sign over the bracket (g at its right end
      within the integration error of 0), the right end is the point.
    * ``refine=False``: the state is interpolated by a cubic Hermite polynomial between grid
      points (states and rhs derivatives at both ends) and the root found on it: error
      O(h^4 |y''''|), h the grid step; about 1e-9 relative for 360 points per revolution of a smooth
      observable, worse across an impact (an impact inside the bracket breaks the smoothness).
    """
    from scipy.optimize import brentq
    from nld.systems.section import XTOL_REL, locate_crossing
    if direction not in (-1, 0, 1):
        raise InputError(f"direction = {direction!r}: must be +1, -1 or 0")
    if _is_system(scene):
        if scene.is_map:
            raise InputError(f"{scene.name} is a map: its iterates are already a section")
        flow = _system_flow(scene)
        sc = None
        period = scene.period
        default_obs = list(scene.state_names)
    else:
        flow, sc = _scene_flow(scene, overrides, kernel)
        from nld.run.simulate import crank_period
        try:
            period = crank_period(sc)
        except InputError:
            period = None
        default_obs = default_observables(flow.system.kernel)
    system = flow.system
    if observable not in flow.columns:
        raise InputError(f"observable {observable!r}: not available; available: {', '.join(flow.columns)}")
    obs = _check_observables(observables if observables is not None else default_obs, flow.columns)
    if modulo is None and observable == "driver.angle":
        modulo = TWO_PI
    if level is None:
        level = (sc.driver.angle0 if (sc is not None and sc.driver is not None
                                      and observable == "driver.angle") else 0.0)
    level = float(level)
    if modulo is not None and not (math.isfinite(modulo) and modulo > 0):
        raise InputError(f"modulo = {modulo!r}: must be a positive number or None")
    # time span
    if t_transient is None:
        if transient_revs and period is None:
            raise InputError("no period known: give t_transient (s) instead of transient_revs")
        t_transient = float(transient_revs) * (period or 0.0)
    if t_end is None:
        if revs is None or period is None:
            raise InputError("give t_end (s), or revs with a scene/system that has a period")
        t_end = t_transient + float(revs) * period
    if not (math.isfinite(t_end) and t_end > t_transient >= 0):
        raise InputError(f"t_end = {t_end!r}: must be after the transient {t_transient!r} s")
    if dt is None:
        if period is None:
            raise InputError("no period known: give dt (s), the output grid step")
        samples_per_rev = check_count("samples_per_rev", samples_per_rev, 4)
        dt = period / samples_per_rev
    n_grid = int(math.ceil((t_end - t_transient) / dt)) + 1
    grid = np.ascontiguousarray(np.linspace(t_transient, t_end, n_grid))
    y = np.ascontiguousarray(system.y0 if y0 is None else y0, dtype=float).copy()
    z = np.array(system.z0 if z0 is None else z0, dtype=float)
    atol = system.tolerance(rtol)
    hmax = float(system.hmax)
    start = time.perf_counter()
    from nld.interrupt import deferred
    from nld.run.simulate import INTERRUPTED, integrate_chunked, interrupted_message
    out = integrate_chunked(system.solve, 0.0, y, grid, False, system.p, z.copy(), float(rtol),
                            atol, hmax, int(max_steps), int(system.n_events), 1000,
                            period if period else math.inf, progress=progress, period=period,
                            desc=f"poincare {system.name}".strip())
    status, t_reached, Y, n_out, st, Z = out[0], out[1], out[2], int(out[3]), out[4], out[9]
    interrupted = bool(out[-1])
    if status == INTERRUPTED:
        msg = interrupted_message(t_reached, 0.0, t_end, n_out, len(grid))
    else:
        msg = _status_text(system, status, t_reached, st)
    rows = flow.observe_rows(grid, Y, Z, n_out)
    gi = flow.columns.index(observable)
    oi = [flow.columns.index(o) for o in obs]
    g = rows[:, gi] - level
    if modulo is not None:
        branch = np.floor(g / modulo)
    else:
        branch = np.where(g >= 0.0, 0.0, -1.0)
    idx = np.nonzero(branch[1:] != branch[:-1])[0]
    mod = modulo if modulo is not None else 0.0

    def sub_level(i):
        # the branch crossed in [i, i+1]: level + modulo * max(branch) (increasing or decreasing)
        return mod * max(branch[i], branch[i + 1]) if modulo is not None else 0.0

    points, times = [], []
    rhs = system.rhs
    with deferred() as sig:
        for i in idx:
            if sig.requested:        # a Ctrl-C while refining: keep the crossings found so far
                interrupted = sig.handled = True
                break
            up = branch[i + 1] > branch[i]
            if direction == 1 and not up or direction == -1 and up:
                continue
            off = sub_level(i)
            t0, t1 = grid[i], grid[i + 1]
            g0 = g[i] - off
            if g0 == 0.0:
                tc, yc, zc = t0, Y[i].copy(), Z[i].copy()
            elif refine and not interrupted:     # interrupted: the cheap Hermite location
                def G(t, yt, zt, off=off):
                    return flow.observe_one(t, yt, zt)[gi] - level - off
                try:
                    tc, yc, zc = locate_crossing(system, G, t0, Y[i], Z[i], t1, rtol=rtol,
                                                 atol=atol, hmax=hmax, max_steps=max_steps)
                except (ValueError, RuntimeError):      # a failed re-integration
                    continue
            else:
                f0, f1 = np.empty(system.n), np.empty(system.n)
                rhs(t0, Y[i], system.p, Z[i].copy(), f0)
                rhs(t1, Y[i + 1], system.p, Z[i + 1].copy(), f1)
                h = t1 - t0

                def herm(t, i=i, f0=f0, f1=f1, h=h):
                    s = (t - grid[i]) / h
                    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
                    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
                    return h00 * Y[i] + h10 * h * f0 + h01 * Y[i + 1] + h11 * h * f1

                def G(t, i=i, off=off, herm=herm):
                    return flow.observe_one(t, herm(t), Z[i])[gi] - level - off
                try:
                    tc = brentq(G, t0, t1, xtol=XTOL_REL * max(1.0, abs(t1)),
                                rtol=4 * np.finfo(float).eps)
                except ValueError:      # the Hermite interpolant does not change sign: midpoint guess
                    continue
                yc, zc = herm(tc), Z[i].copy()
            row = flow.observe_one(tc, yc, zc)
            times.append(tc)
            points.append(row[oi])
        if sig.requested:
            interrupted = sig.handled = True
    table = pd.DataFrame({"crossing": np.arange(len(times), dtype=np.int64),
                          "t": np.array(times, dtype=float)})
    P = np.array(points, dtype=float).reshape(len(times), len(oi))
    for j, o in enumerate(obs):
        if o != "t":
            table[o] = P[:, j]
    y_final = Y[n_out - 1].copy() if n_out else y
    z_final = np.array(Z[n_out - 1], dtype=float) if n_out else z
    base = _system_provenance(system) if sc is None else _scene_provenance(sc, system)
    base.update(kind="hyperplane", observable=observable, level=level, direction=direction,
                modulo=modulo, t_transient=t_transient, t_end=t_end, grid_step=dt, refine=refine,
                rtol=rtol, observables=obs, status=int(status), message=msg,
                wall=time.perf_counter() - start)
    sec = Section(table, obs, y_final, z_final, float(t_reached), int(status), msg, None, base)
    if interrupted:
        base.update(partial=True)
        raise Interrupted(msg, partial=sec, kept=f"{len(times)} section points (crossings up to "
                                                 f"t = {t_reached:.6g} s)")
    return sec


def _scene_provenance(sc, system) -> dict:
    from nld.run.simulate import provenance
    return provenance(sc, integrator=_method(system))


# ---------------------------------------------------------------------------------------------------
# period detection


def section_scales(scene, columns) -> np.ndarray:
    """Physical scale of each section column for :func:`period_of`: the joint's radial clearance (m)
    for an eccentricity component of a clearance joint (``J.ex``, ``J.ey``, ``J.e``), NaN (the
    points' own range) for any other column. A DataFrame gives its columns as period_of selects
    them."""
    if isinstance(columns, pd.DataFrame):
        columns = [c for c in columns.columns if c not in ("rev", "crossing", "t")
                   and pd.api.types.is_numeric_dtype(columns[c])]
    elif isinstance(columns, str):
        columns = [columns]
    out = np.full(len(columns), np.nan)
    for i, col in enumerate(columns):
        joint, _, comp = str(col).rpartition(".")
        j = scene.joints.get(joint) if joint else None
        if j is not None and comp in ("ex", "ey", "e") and j.clearance > 0.0:
            out[i] = j.clearance
    return out


def section_period(X, scales=None, *, tol: float, max_period: int, angles=None,
                   window: int | None = None) -> int:
    """The period test of nld: the smallest p <= max_period with max_i ||x_{i+p} - x_i|| <= tol
    over the last ``window`` points of X (default all), 0 for none (not periodic, or not settled).

    X: (n, N) section points, oldest first. The norm is the max-norm of the differences divided
    by ``scales`` (one per coordinate; default 1), angle coordinates (indices ``angles``) wrapped
    into [-pi, pi) first -- the scaled max-norm of the shooting residual of
    ``nld.analysis.orbits.periodic_orbit``. Period p needs at least p pairs (every phase repeats
    at least once), so n >= 2p. :func:`period_of` (``nld poincare``, bifurcation diagrams, chaos
    maps) and the attractor census (``nld.analysis.attractors``) both decide with this test."""
    X = np.asarray(X, dtype=float)
    if X.ndim == 1:
        X = X[:, None]
    if window is not None:
        X = X[-int(window):]
    n = X.shape[0]
    if n < 2 or not np.all(np.isfinite(X)):
        return 0
    sc = np.ones(X.shape[1]) if scales is None else np.broadcast_to(
        np.asarray(scales, dtype=float), (X.shape[1],))
    ang = np.zeros(0, dtype=np.int64) if angles is None else np.asarray(angles, dtype=np.int64)
    for p in range(1, min(int(max_period), n // 2) + 1):
        d = X[p:] - X[:-p]
        if ang.size:
            d[:, ang] -= 2.0 * math.pi * np.floor((d[:, ang] + math.pi) / (2.0 * math.pi))
        if float(np.max(np.abs(d / sc))) <= tol:
            return p
    return 0


def period_of(points, tol: float = DEFAULT_PERIOD_TOL, n_max: int = DEFAULT_N_MAX, *,
              scale=None, window: int | None = None) -> int:
    """Smallest period n <= n_max of a sequence of section points, 0 for none (aperiodic).

    points: (N, d) array or a DataFrame (its numeric columns other than rev/crossing/t), oldest
    first, transient already dropped. Each coordinate is divided by its scale (default
    max(range, rms) of that coordinate over the points; a coordinate whose scale is 0 is
    constant and ignored; or give ``scale``, one value per coordinate, NaN for the default:
    :func:`section_scales` gives the clearance for eccentricity components, so a fixed point
    whose eccentricity is near 0 is not judged on its own tiny range). Period n holds when
    max |p[i+n] - p[i]| / scale <= tol for every i in the last ``window`` points (default all)
    and at least n such pairs exist (every phase repeats at least once), so N >= 2n is needed:
    :func:`section_period`, the one period test of nld, on these scales.
    """
    if isinstance(points, pd.DataFrame):
        cols = [c for c in points.columns if c not in ("rev", "crossing", "t")
                and pd.api.types.is_numeric_dtype(points[c])]
        P = points[cols].to_numpy(dtype=float)
    else:
        P = np.asarray(points, dtype=float)
    if P.ndim == 1:
        P = P[:, None]
    if window is not None:
        P = P[-int(window):]
    if len(P) < 2 or not np.all(np.isfinite(P)):
        return 0
    s = np.maximum(np.ptp(P, axis=0), np.sqrt(np.mean(P * P, axis=0)))
    if scale is not None:
        given = np.broadcast_to(np.asarray(scale, dtype=float), (P.shape[1],))
        s = np.where(np.isnan(given), s, given)
    keep = s > 0
    if not np.any(keep):
        return 1
    return section_period(P[:, keep], s[keep], tol=tol, max_period=n_max)
