"""Run a scene: assemble, integrate, observe. ``simulate`` is the one entry point of the API.

Like ``scipy.integrate.solve_ivp``, the result carries ``status``, ``message`` and ``success``; a run
that cannot meet its tolerance stops there and says where and why instead of returning garbage.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from .errors import InputError, SolveError
from .kernel import Kernel, compile_scene
from .scene_model import Scene
from .topology import GROUND

DEFAULT_RTOL = 1e-8
DEFAULT_SAMPLES_PER_REV = 360


@dataclass
class SimulationResult:
    table: pd.DataFrame            # one row per output time, named columns in SI units
    status: int                    # 0 success, <0 failure (see nld.integrators.dopri5)
    message: str
    t_reached: float               # s
    stats: dict                    # steps, accepted, rejected, rhs evaluations, events
    events: pd.DataFrame           # contact onset (+1) / loss (-1) per clearance joint
    y_final: np.ndarray            # state at t_reached
    z_final: np.ndarray            # discrete state at t_reached
    provenance: dict = field(default_factory=dict)

    @property
    def success(self) -> bool:
        return self.status >= 0


def crank_period(scene: Scene) -> float:
    if scene.driver is None or scene.driver.speed == 0.0:
        raise InputError("the scene has no crank speed: give t_end (s) instead of revolutions")
    return 2.0 * math.pi / abs(scene.driver.speed)


def state_scales(kernel: Kernel, q0: np.ndarray) -> np.ndarray:
    """Absolute error scales of the states (positions, then velocities).

    A joint angle is scaled by c_min / L, L the largest distance from its pivot to a clearance-joint
    centre that it moves (so an angle error of one scale moves the journal by about one clearance);
    a slide or a floating position by c_min (m). Velocities take the same scale times the crank speed.
    """
    from .assembly import _point, forward_poses
    sc, topo = kernel.scene, kernel.topo
    cl = [sc.joints[j].clearance for j in topo.clearance]
    cmin = min(cl) if cl else 1e-3
    poses = forward_poses(sc, topo, q0)
    zero = np.zeros_like(poses)
    centres = []
    for jn in topo.clearance:
        j = sc.joints[jn]
        for b, pn in zip(j.bodies, j.points):
            bi = topo.body_index(b)
            if bi != GROUND:
                centres.append((bi, _point(sc, topo.body_names, poses, zero, bi, pn)[0]))
    pos = []
    for k in topo.independent:
        c = topo.coords[k]
        if c.kind in ("pri", "fx", "fy"):
            pos.append(cmin)
            continue
        e = topo.edges[c.body]
        if c.kind == "fth":
            pivot = poses[c.body, :2]
        else:
            pivot = _point(sc, topo.body_names, poses, zero, e.parent, e.parent_point)[0]
        moved = [r for bi, r in centres if k in topo.ancestors(bi)]
        L = max([float(np.hypot(*(r - pivot))) for r in moved] + [0.0])
        if L <= 0.0:
            L = max(0.1, max((math.hypot(*v) for b in sc.bodies.values() for v in b.points.values()),
                             default=0.1))
        pos.append(cmin / L)
    pos = np.array(pos)
    wref = max(abs(sc.driver.speed), 1.0) if sc.driver is not None else 1.0
    return np.concatenate([pos, pos * wref])


def initial_state(kernel: Kernel):
    """State y0 (independent coordinates and speeds) and discrete state z0 of the assembled scene."""
    from .assembly import initial_coordinates
    q, qd = initial_coordinates(kernel.scene, kernel.topo)
    ind = kernel.topo.independent
    y0 = np.concatenate([q[ind], qd[ind]])
    z0 = np.zeros(kernel.n_z)
    z0[len(kernel.topo.clearance):] = q[kernel.topo.dependent]
    return y0, z0, q


def event_log_size(n_revs: float) -> int:
    """Length of the event log simulate allocates for a run of n_revs crank revolutions (contacts
    per revolution are tens; a needlessly long log costs page faults on short runs)."""
    return int(min(1_000_000, 1000 + 400 * n_revs))


def tolerances(kernel: Kernel, q0: np.ndarray, rtol: float) -> np.ndarray:
    """The integrators' 2n tolerance vector: absolute tolerances, then per-state rtol weights.

    ``atol = rtol * state_scales`` (clearance-scaled: an angle error of one scale moves a journal
    by one clearance). Positions (angles, slides, floating positions) get rtol weight 0, so their
    control is purely absolute, at the clearance scale: a joint angle measured from a rotating
    crank winds by 2 pi per revolution and a relative term would loosen the tolerance as the run
    goes on, and a journal position of 0.1 m says nothing about the micrometres that matter.
    Velocities keep the relative term (weight 1). Measured: the same steps as the plain relative
    test, and 10x smaller journal errors at rtol 1e-6 (docs/formulation.md section 7).
    nld.integrators.dopri5.rweight implements the weights.
    """
    sc = state_scales(kernel, q0)
    w = np.ones(sc.size)
    w[: sc.size // 2] = 0.0
    return np.ascontiguousarray(np.concatenate([rtol * sc, w]))


def simulate(scene: Scene | str, *, t_end: float | None = None, revs: float | None = None,
             rtol: float | None = None, t_eval=None, samples_per_rev: int = DEFAULT_SAMPLES_PER_REV,
             overrides=None, y0=None, z0=None, t0: float = 0.0, land: bool = False,
             max_steps: int = 50_000_000, hmax: float | None = None, kernel: Kernel | None = None,
             raise_on_failure: bool = False, method: str | None = None) -> SimulationResult:
    """Simulate a scene with the adaptive Dormand-Prince 5(4) integrator (or ``method``).

    scene: a Scene, a built-in name or a TOML path (``overrides`` as for ``nld --set``).
    t_end (s) or revs (crank revolutions): the end of the run. rtol: relative tolerance (default:
    the scene's ``[scene] rtol``, the work-precision recommendation of docs/performance.md, else
    1e-8); absolute tolerances as ``tolerances`` (positions absolute, clearance-scaled). t_eval:
    output times (s); default ``samples_per_rev`` per crank revolution. land: land exactly on the
    output times (stroboscopic sampling). hmax (s): step cap, default a twentieth of a crank
    period. method: the scene's ``[scene] method``, else "dopri5"; or "dop853", "rodas" (stiff),
    "scipy:RK45|DOP853|Radau|LSODA" (docs/integrator.md).
    """
    from .integrators.dopri5 import status_message
    from .scene import load_scene
    if isinstance(scene, str):
        scene = load_scene(scene, overrides)
    elif overrides:
        from .scene import apply_overrides, scene_from_dict, scene_to_dict
        raw = scene_to_dict(scene)
        apply_overrides(raw, overrides)
        scene = scene_from_dict(raw, scene.source)
    if rtol is None:        # the scene's recommended tolerance (docs/performance.md), else 1e-8
        rtol = scene.rtol if scene.rtol is not None else DEFAULT_RTOL
    if method is None:
        method = scene.method or "dopri5"
    if not (isinstance(rtol, float | int) and 1e-14 <= rtol < 1):
        raise InputError(f"rtol = {rtol!r}: must be a number in [1e-14, 1)")
    if method != "dopri5":
        from .integrators import METHODS
        if method not in METHODS:
            raise InputError(f"method = {method!r}: choose one of {', '.join(METHODS)}")
    kern = kernel if kernel is not None else compile_scene(scene)
    p = kern.params(scene)
    if t_end is None:
        if revs is None:
            revs = 1.0
        t_end = t0 + revs * crank_period(scene)
    if not (math.isfinite(t_end) and t_end > t0):
        raise InputError(f"t_end = {t_end!r}: must be a finite time after t0 = {t0} s")
    if t_eval is None:
        try:
            per = crank_period(scene)
            n = max(2, int(round((t_end - t0) / per * samples_per_rev)) + 1)
        except InputError:
            n = 1001
        t_eval = np.linspace(t0, t_end, n)
    t_eval = np.ascontiguousarray(t_eval, dtype=float)
    if y0 is None or z0 is None:
        y0_, z0_, q_init = initial_state(kern)
        y0 = y0_ if y0 is None else np.asarray(y0, float)
        z0 = z0_ if z0 is None else np.asarray(z0, float)
    else:
        q_init = None
    z = np.array(z0, dtype=float)
    ncols = len(kern.columns)
    start = time.perf_counter()
    if kern.n_state == 0:
        # no freedom left: the mechanism is a kinematic chain driven by the crank
        rows = np.empty((len(t_eval), ncols))
        for i, t in enumerate(t_eval):
            kern.module.observe(t, y0, p, z, rows[i])
        status, t_reached, n_out = 0, float(t_eval[-1]), len(t_eval)
        stats = dict(steps=0, accepted=0, rejected=0, rhs=0, events=0)
        ev = pd.DataFrame({"t": [], "joint": [], "direction": []})
        y_final = y0
        message = "kinematic chain: no free coordinates, evaluated by position analysis"
        if rows[:, kern.columns.index("newton.ok")].min() < 1.0:
            status, message = -4, "position analysis failed: the loop cannot be closed (dead point?)"
    else:
        if q_init is None:
            q_scale = np.zeros(len(kern.topo.coords))
            q_scale[kern.topo.independent] = y0[: len(kern.topo.independent)]
        else:
            q_scale = q_init
        atol = tolerances(kern, q_scale, rtol)
        if hmax is None:
            try:
                hmax = crank_period(scene) / 20.0
            except InputError:
                hmax = (t_end - t0) / 20.0
        n_ev = kern.n_events
        # event log sized to the run (contacts per revolution are tens): a huge log costs page faults
        try:
            n_revs = (t_end - t0) / crank_period(scene)
        except InputError:
            n_revs = 100.0
        max_log = event_log_size(n_revs)
        if method == "dopri5":
            out = kern.module.solve(float(t0), np.ascontiguousarray(y0, dtype=float), t_eval, bool(land), p, z,
                                    float(rtol), atol, 0.0, float(hmax), int(max_steps), int(n_ev), max_log)
        else:
            from .integrators import solve_method
            out = solve_method(kern, method, float(t0), np.ascontiguousarray(y0, dtype=float), t_eval, bool(land),
                               p, z, float(rtol), atol, 0.0, float(hmax), int(max_steps), int(n_ev), max_log)
        status, t_reached, Y, n_out, st, ev_t, ev_k, ev_dir, n_logged, Z = out
        stats = dict(steps=int(st[0]), accepted=int(st[1]), rejected=int(st[2]), rhs=int(st[3]),
                     events=int(st[4]))
        if len(st) > 5:
            stats.update(jac=int(st[5]), lu=int(st[6]))
        if method == "dopri5":
            message = status_message(status, t_reached, st)
        else:
            from .integrators import method_status_message
            message = method_status_message(method, status, t_reached, st)
        rows = np.empty((n_out, ncols))
        kern.module.observe_all(t_eval, Y, Z, n_out, p, rows)
        nl = min(int(n_logged), max_log)
        names = kern.topo.clearance + [f"load{i}" for i, ld in enumerate(scene.loads)
                                       if ld.modulation in ("crank_halves", "angle_threshold")]
        ev = pd.DataFrame({"t": ev_t[:nl], "joint": [names[k] for k in ev_k[:nl]], "direction": ev_dir[:nl]})
        y_final = Y[n_out - 1].copy() if n_out else np.asarray(y0, float)
        if status < 0:
            message += _failure_context(kern, rows, n_out)
    wall = time.perf_counter() - start
    table = pd.DataFrame(rows, columns=kern.columns)
    table.insert(0, "t", t_eval[: len(rows)])
    prov = provenance(scene, kern, rtol=rtol, t_end=t_end, wall=wall, integrator=method)
    res = SimulationResult(table, int(status), message, float(t_reached), stats, ev, y_final, z, prov)
    if raise_on_failure and not res.success:
        raise SolveError(res.message)
    return res


def _failure_context(kern: Kernel, rows, n_out) -> str:
    if not n_out or not kern.topo.clearance:
        return ""
    last = rows[n_out - 1]
    parts = []
    for jn in kern.topo.clearance:
        pen = last[kern.columns.index(f"{jn}.penetration")]
        fn = last[kern.columns.index(f"{jn}.Fn")]
        parts.append(f"{jn}: penetration {pen:.3g} m, Fn {fn:.3g} N")
    return " (last output: " + "; ".join(parts) + ")"


def provenance(scene: Scene, kern: Kernel | None = None, **extra) -> dict:
    """Version, git hash, scene parameters and settings, stored with every saved result."""
    from . import __version__
    from .provenance import git_hash
    from .scene import scene_to_dict
    d = {"nld_version": __version__, "git_hash": git_hash(), "scene": scene.name,
         "scene_parameters": scene_to_dict(scene), "integrator": "dopri5"}
    if kern is not None:
        d["kernel"] = kern.key
    d.update(extra)
    return d
