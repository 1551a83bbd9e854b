"""Run a scene: assemble, integrate, observe. ``simulate`` is the one entry point of the API.

Like ``scipy.integrate.solve_ivp``, the result carries ``status``, ``message`` and ``success``; a run
that cannot meet its tolerance stops there and says where and why instead of returning garbage.
"""
from __future__ import annotations

import math
import time
from collections import namedtuple
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from nld.errors import InputError, InputTypeError, Interrupted, SolveError
from nld.interrupt import deferred
from nld.kernel.compile import Kernel, compile_scene
from nld.kernel.support import writable_vector
from nld.progress import progress_bar
from nld.settings import SIMULATE, check_rtol
from nld.integrators.core import as_solution
from nld.model.scene_model import Scene
from nld.model.topology import GROUND

DEFAULT_RTOL = SIMULATE.rtol                           # when the scene recommends none
DEFAULT_SAMPLES_PER_REV = SIMULATE.samples_per_rev
DEFAULT_CHUNK_REVS = 1.0
INTERRUPTED = -9               # status of a run stopped by Ctrl-C (SIGINT), see integrate_chunked
MAX_OUTPUT_BYTES = 4 * 2**30   # refuse a run whose output table alone would exceed this
CHUNK_LOG = 50_000             # event-log entries allocated per chunk (the whole log: max_log)
PROGRESS_DELAY = 2.0           # s: a simulate shows its progress bar only after this long


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


def crank_period(scene: Scene, field: str | None = None) -> float:
    """2 pi / |driver.speed| (s); InputError for a scene without a crank speed (naming ``field``,
    the argument that needed the period, e.g. ``revs``)."""
    if scene.driver is None or scene.driver.speed == 0.0:
        what = "no driver" if scene.driver is None else "driver.speed = 0"
        lead = f"{field}: " if field else ""
        raise InputError(f"{lead}scene {scene.name!r} has {what}, so no crank period to count "
                         "revolutions: give t_end (s, --t-end) instead")
    return 2.0 * math.pi / abs(scene.driver.speed)


def _period_or_none(scene: Scene) -> float | None:
    try:
        return crank_period(scene)
    except InputError:
        return None


# ---------------------------------------------------------------------------------------------------
# argument checks (one line naming the argument, the value and what is allowed)


def check_scene_arg(scene, name: str = "scene") -> None:
    """InputTypeError unless ``scene`` is a Scene, a built-in name or a path (str / os.PathLike)."""
    import os
    if isinstance(scene, Scene | str | os.PathLike):
        return
    raise InputTypeError(f"{name} = {scene!r}: must be a built-in scene name, the path of a .toml "
                         "file or an nld Scene")


def check_number(name: str, v, *, minimum: float | None = None, strict: bool = True,
                 maximum: float | None = None, unit: str = "") -> float:
    """``float(v)`` if v is a finite real number within the bounds, else InputError/InputTypeError
    naming ``name``."""
    u = f" {unit}" if unit else ""
    if isinstance(v, bool) or not isinstance(v, int | float | np.integer | np.floating):
        raise InputTypeError(f"{name} = {v!r}: must be a number{(' (' + unit + ')') if unit else ''}")
    f = float(v)
    if not math.isfinite(f):
        raise InputError(f"{name} = {v!r}: must be a finite number{u}")
    if minimum is not None and (f <= minimum if strict else f < minimum):
        raise InputError(f"{name} = {v!r}: must be {'>' if strict else '>='} {minimum:g}{u}")
    if maximum is not None and f > maximum:
        raise InputError(f"{name} = {v!r}: must be <= {maximum:g}{u}")
    return f


def check_int(name: str, v, minimum: int) -> int:
    """``int(v)`` for an integer >= minimum (a float with an integer value is accepted)."""
    if isinstance(v, bool) or not isinstance(v, int | float | np.integer | np.floating):
        raise InputTypeError(f"{name} = {v!r}: must be an integer >= {minimum}")
    if isinstance(v, float | np.floating) and not (math.isfinite(v) and float(v).is_integer()):
        raise InputError(f"{name} = {v!r}: must be an integer >= {minimum}")
    if v < minimum:
        raise InputError(f"{name} = {v!r}: must be an integer >= {minimum}")
    return int(v)


def _check_run_args(*, t_end, revs, samples_per_rev, t0, chunk_revs, max_steps, hmax) -> None:
    check_number("t0", t0, minimum=None, unit="s")
    if t_end is not None and revs is not None:
        raise InputError(f"revs = {revs!r} and t_end = {t_end!r}: give one of them, not both")
    if revs is not None:
        check_number("revs", revs, minimum=0.0, unit="crank revolutions")
    if t_end is not None:
        check_number("t_end", t_end, unit="s")
    check_int("samples_per_rev", samples_per_rev, 1)
    if chunk_revs is not None:
        check_number("chunk_revs", chunk_revs, minimum=0.0, unit="crank revolutions")
    check_int("max_steps", max_steps, 1)
    if hmax is not None:
        check_number("hmax", hmax, minimum=0.0, unit="s")


def output_rows(scene: Scene, span: float, samples_per_rev: int, ncols: int | None = None,
                field: str = "revs") -> int:
    """Number of output rows of a run of ``span`` s at ``samples_per_rev`` per crank revolution
    (1001 for a scene without a crank period); InputError naming ``field`` when the table would
    not fit MAX_OUTPUT_BYTES."""
    per = _period_or_none(scene)
    if per is None:
        return 1001
    revs = span / per
    n = revs * samples_per_rev + 1
    width = (ncols or 40) + 2 * 12
    if n * width * 8 > MAX_OUTPUT_BYTES:
        fit = MAX_OUTPUT_BYTES / (width * 8)
        value = (f"{revs:.6g} revolutions" if field.endswith("revs")
                 else f"{span:.6g} s ({revs:.6g} revolutions)")
        raise InputError(f"{field} = {value} at {samples_per_rev} samples per revolution: "
                         f"{n:.3g} output rows would need {n * width * 8 / 2**30:.3g} GiB; at most "
                         f"{fit:.3g} rows ({fit / samples_per_rev:.3g} revolutions) fit the "
                         f"{MAX_OUTPUT_BYTES / 2**30:g} GiB output limit: "
                         + ("lower --revs / --t-end or --samples-per-rev" if field.startswith("--")
                            else "lower revs / t_end or samples_per_rev, or give t_eval"))
    return max(2, int(round(n)))


def state_arg(name: str, v, n: int) -> np.ndarray:
    """A start state given by the caller: n finite numbers."""
    try:
        a = np.asarray(v, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InputTypeError(f"{name} = {v!r}: must be {n} numbers") from None
    if a.size != n:
        raise InputError(f"{name}: {a.size} values given, the scene's state has {n} "
                         f"(e.g. y_final / z_final of a run of the same scene)")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name}: must hold finite numbers")
    return a


def _check_t_eval(t_eval, t0: float, ncols: int) -> np.ndarray:
    try:
        a = np.asarray(t_eval, dtype=float)
    except (TypeError, ValueError):
        raise InputTypeError(f"t_eval = {t_eval!r}: must be an array of times (s)") from None
    if a.ndim != 1 or a.size == 0:
        raise InputError(f"t_eval: must be a non-empty 1-d array of times (s), got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError("t_eval: must hold finite times (s)")
    if np.any(np.diff(a) < 0):
        raise InputError("t_eval: the times must be sorted ascending")
    if a[0] < t0:
        raise InputError(f"t_eval[0] = {a[0]!r}: must be >= t0 = {t0!r} s")
    if a.size * (ncols + 24) * 8 > MAX_OUTPUT_BYTES:
        raise InputError(f"t_eval: {a.size} output times would need more than the "
                         f"{MAX_OUTPUT_BYTES / 2**30:g} GiB output limit")
    return a


def state_scales(kernel: Kernel, q0: np.ndarray) -> np.ndarray:
    """Absolute error scales of the states (positions, then velocities).

    A joint angle is scaled by c_min / L, L the largest distance from its pivot to a clearance-joint
    centre that it moves (so an angle error of one scale moves the journal by about one clearance);
    a slide or a floating position by c_min (m). Velocities take the same scale times the crank speed.
    """
    from nld.model.assembly import forward_poses, world_point
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
                centres.append((bi, world_point(sc, topo.body_names, poses, zero, bi, pn)[0]))
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
            pivot = world_point(sc, topo.body_names, poses, zero, e.parent, e.parent_point)[0]
        moved = [r for bi, r in centres if k in topo.ancestors(bi)]
        L = max([float(np.hypot(*(r - pivot))) for r in moved] + [0.0])
        if L <= 0.0:
            L = max(0.1, max((math.hypot(*v) for b in sc.bodies.values() for v in b.points.values()),
                             default=0.1))
        pos.append(cmin / L)
    pos = np.array(pos)
    wref = max(abs(sc.driver.speed), 1.0) if sc.driver is not None else 1.0
    return np.concatenate([pos, pos * wref])


def initial_state(kernel: Kernel, t0: float = 0.0):
    """State y0 (independent coordinates and speeds) and discrete state z0 of the assembled scene
    (modes of switched loads, contacts and friction set from the state at t0: Kernel.init_modes)."""
    from nld.model.assembly import initial_coordinates
    q, qd = initial_coordinates(kernel.scene, kernel.topo)
    ind = kernel.topo.independent
    y0 = np.concatenate([q[ind], qd[ind]])
    z0 = np.zeros(kernel.n_z)
    nc, nd = len(kernel.topo.clearance), len(kernel.topo.dependent)
    z0[nc:nc + nd] = q[kernel.topo.dependent]
    kernel.init_modes(t0, y0, kernel.params(), z0)
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
    return tolerances_from_scales(state_scales(kernel, q0), rtol)


def tolerances_from_scales(scales: np.ndarray, rtol: float) -> np.ndarray:
    """:func:`tolerances` from precomputed ``state_scales`` (computing the scales walks the
    scene's geometry in Python, ~30 us; a system that integrates many short windows keeps them)."""
    sc = np.asarray(scales, dtype=float)
    out = np.ones(2 * sc.size)
    out[: sc.size] = rtol * sc
    out[sc.size: sc.size + sc.size // 2] = 0.0
    return out


def simulate(scene: Scene | str, *, t_end: float | None = None, revs: float | None = None,
             rtol: float | None = None, t_eval=None, samples_per_rev: int = DEFAULT_SAMPLES_PER_REV,
             overrides=None, y0=None, z0=None, t0: float = 0.0, land: bool = False,
             max_steps: int = SIMULATE.max_steps, hmax: float | None = None, kernel: Kernel | None = None,
             raise_on_failure: bool = False, method: str | None = None,
             chunk_revs: float | None = DEFAULT_CHUNK_REVS, progress: bool | None = None,
             event_samples: int | None = None) -> SimulationResult:
    """Simulate a scene with the adaptive Dormand-Prince 5(4) integrator (or ``method``).

    scene: a Scene, a built-in name or a TOML path (``overrides`` as for ``nld --set``).
    t_end (s) or revs (crank revolutions): the end of the run. rtol: relative tolerance (default:
    the scene's ``[scene] rtol``, the work-precision recommendation of docs/performance.md, else
    1e-8); absolute tolerances as ``tolerances`` (positions absolute, clearance-scaled). t_eval:
    output times (s); default ``samples_per_rev`` per crank revolution. land: land exactly on the
    output times (stroboscopic sampling). hmax (s): step cap, default a twentieth of a crank
    period. method: the scene's ``[scene] method``, else "dopri5"; or "dop853", "rodas" (stiff),
    "scipy:RK45|DOP853|Radau|LSODA" (docs/integrator.md).
    chunk_revs: the integration runs in chunks of this many crank revolutions of simulated time
    (``None``: one call), so that Ctrl-C is honoured within a chunk and a progress bar moves; the
    integrator restarts at each chunk boundary from the state there (the results agree with one
    call to the tolerance, see ``integrate_chunked``). On Ctrl-C (SIGINT) the run stops at the
    next chunk boundary and raises :class:`nld.errors.Interrupted` (a KeyboardInterrupt) whose
    ``partial`` is the result so far (status ``INTERRUPTED``, table up to there).
    progress: a progress bar in crank revolutions on stderr (None: only when stderr is a terminal
    and the run takes more than 2 s; see ``nld.progress``).
    event_samples: interior points of every step's dense output at which the event functions
    (contact gaps, load switches) are evaluated, so that a contact lost and regained within one
    step is located (None: ``nld.integrators.EVENT_SAMPLES``, 3; 0: the step's ends only, nld's
    behaviour before issue 13; docs/integrator.md, "Events"). Native methods only.
    """
    from nld.integrators.dopri5 import status_message
    check_scene_arg(scene)
    _check_run_args(t_end=t_end, revs=revs, samples_per_rev=samples_per_rev, t0=t0,
                    chunk_revs=chunk_revs, max_steps=max_steps, hmax=hmax)
    from nld.integrators.events import EVENT_SAMPLES, check_event_samples
    event_samples = EVENT_SAMPLES if event_samples is None else check_event_samples(event_samples)
    from nld.model.scene import resolve_scene
    scene = resolve_scene(scene, overrides)
    if rtol is None:        # the scene's recommended tolerance (docs/performance.md), else 1e-8
        rtol = scene.rtol if scene.rtol is not None else DEFAULT_RTOL
    if method is None:
        method = scene.method or "dopri5"
    check_rtol(rtol)
    if method != "dopri5":
        from nld.integrators import METHODS
        if method not in METHODS:
            raise InputError(f"method = {method!r}: choose one of {', '.join(METHODS)}")
    kern = kernel if kernel is not None else compile_scene(scene)
    p = kern.params(scene)
    if t_eval is not None:
        t_eval = _check_t_eval(t_eval, t0, len(kern.columns))
    if t_end is None:
        if t_eval is not None and revs is None:
            t_end = float(t_eval[-1]) if t_eval[-1] > t0 else t0 + 1e-9 * max(1.0, abs(t0))
        else:
            if revs is None:
                revs = 1.0
            t_end = t0 + revs * crank_period(scene, "revs")
    if not (math.isfinite(t_end) and t_end > t0):
        raise InputError(f"t_end = {t_end!r}: must be a finite time after t0 = {t0} s")
    if t_eval is None:
        n = output_rows(scene, t_end - t0, samples_per_rev, len(kern.columns),
                        "revs" if revs is not None else "t_end")
        t_eval = np.linspace(t0, t_end, n)
    t_eval = writable_vector(t_eval)        # one compiled observe_all / solve for every caller
    if y0 is None or z0 is None:
        y0_, z0_, q_init = initial_state(kern)
        y0 = y0_ if y0 is None else state_arg("y0", y0, kern.n_state)
        if z0 is None:
            z0 = z0_.copy()
            kern.init_modes(t0, y0, p, z0)     # the branches of this start state and parameters
        else:
            z0 = state_arg("z0", z0, kern.n_z)
    else:
        y0, z0 = state_arg("y0", y0, kern.n_state), state_arg("z0", z0, kern.n_z)
        q_init = None
    relabel = kern.time_labels()
    if relabel is not None:
        # a given z0 may come from a run that stopped at another time (a whole revolution
        # before a crank_halves switch): the switched loads' branches from (t0, y0)
        z0 = np.array(z0, dtype=float)
        relabel(t0, np.ascontiguousarray(y0, dtype=float), p, z0)
    z = np.array(z0, dtype=float)
    ncols = len(kern.columns)
    start = time.perf_counter()
    if kern.n_state == 0:
        # no freedom left: the mechanism is a kinematic chain driven by the crank
        rows = np.empty((len(t_eval), ncols))
        interrupted = False
        with deferred() as sig:
            for i, t in enumerate(t_eval):
                # nothing is integrated, so no event sets the modes: take them from the state
                kern.module.init_modes(t, y0, p, z)
                kern.module.observe(t, y0, p, z, rows[i])
                if sig.requested:
                    sig.handled = interrupted = True
                    rows = rows[: i + 1]
                    break
        status, t_reached, n_out = 0, float(t_eval[len(rows) - 1]), len(rows)
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
            solve = kern.module.solve
        else:
            from nld.integrators import solve_method

            def solve(*a):
                return solve_method(kern, method, *a)
        span = _chunk_span(chunk_revs, scene, t0, t_end, hmax)
        out = integrate_chunked(solve, float(t0), np.ascontiguousarray(y0, dtype=float), t_eval,
                                bool(land), p, z, float(rtol), atol, float(hmax), int(max_steps),
                                int(n_ev), max_log, span, progress=progress,
                                period=_period_or_none(scene), desc=f"simulate {scene.name}",
                                event_samples=event_samples)
        interrupted = out[-1]
        out = out[:-1]
        status, t_reached, Y, n_out, st, ev_t, ev_k, ev_dir, n_logged, Z = out
        stats = dict(steps=int(st[0]), accepted=int(st[1]), rejected=int(st[2]), rhs=int(st[3]),
                     events=int(st[4]))
        if len(st) > 5:
            stats.update(jac=int(st[5]), lu=int(st[6]))
        if status == INTERRUPTED:
            message = interrupted_message(t_reached, t0, t_end, n_out, len(t_eval), scene)
        elif method == "dopri5":
            message = status_message(status, t_reached, st)
        else:
            from nld.integrators import method_status_message
            message = method_status_message(method, status, t_reached, st)
        rows = np.empty((n_out, ncols))
        with deferred() as sig:
            kern.module.observe_all(t_eval, Y, Z, n_out, p, rows)
            if sig.requested:
                sig.handled = interrupted = True
        nl = min(int(n_logged), max_log)
        names = kern.z_layout.event_names
        ev = pd.DataFrame({"t": ev_t[:nl], "joint": [names[k] for k in ev_k[:nl]], "direction": ev_dir[:nl]})
        y_final = Y[n_out - 1].copy() if n_out else np.asarray(y0, float)
        if status < 0:
            message += failure_context(kern, rows, n_out)
    wall = time.perf_counter() - start
    table = pd.DataFrame(rows, columns=kern.columns, copy=False)    # no transposing copy (1 s per 10^6 rows)
    table.insert(0, "t", t_eval[: len(rows)])
    prov = provenance(scene, kern, rtol=rtol, t_end=t_end, wall=wall, integrator=method)
    prov["event_samples"] = int(event_samples)
    if interrupted and status != INTERRUPTED and n_out < len(t_eval):
        status = INTERRUPTED
        message = interrupted_message(t_reached, t0, t_end, n_out, len(t_eval), scene)
    if interrupted:
        prov.update(partial=status == INTERRUPTED, interrupted=True)
    res = SimulationResult(table, int(status), message, float(t_reached), stats, ev, y_final, z, prov)
    if interrupted:
        raise Interrupted(message, partial=res, kept=f"{n_out} of {len(t_eval)} output rows "
                                                       f"(t = {t0:g} .. {t_reached:.6g} s)")
    if raise_on_failure and not res.success:
        raise SolveError(res.message)
    return res


def _chunk_span(chunk_revs, scene: Scene, t0: float, t_end: float, hmax: float) -> float:
    """Simulated time (s) of one chunk of integrate_chunked: chunk_revs crank periods; without a
    crank period 20 hmax; None: the whole run."""
    if chunk_revs is None:
        return math.inf
    per = _period_or_none(scene)
    if per is None:
        return 20.0 * hmax if hmax > 0 else math.inf
    return float(chunk_revs) * per


def integrate_chunked(solve, t0, y0, t_eval, land, p, z, rtol, atol, hmax, max_steps, n_events,
                      max_log, span, *, progress=None, period=None, desc="simulate",
                      event_samples=None):
    """``solve(t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps, n_events, max_log,
    event_samples)`` (a kernel's compiled integrator) from t0 to t_eval[-1] in chunks of ``span``
    s of simulated time, with SIGINT deferred (``nld.interrupt.deferred``). ``event_samples``
    None: the integrator's default (``solve`` is then called with 13 arguments).

    Returns a :data:`ChunkedSolution`, the named tuple ``(status, t, Y, n_out, stats, ev_t, ev_k,
    ev_dir, n_ev, Z)`` of the integrator for the whole run, plus ``interrupted`` (bool): on Ctrl-C the loop stops after the
    chunk in progress and returns what it has, status INTERRUPTED.

    Chunk boundaries lie at t0 + k span (deterministic: the same run gives the same numbers
    whatever the machine's speed). Each chunk's output times are those of t_eval in
    (previous boundary, boundary], plus the boundary itself when it is not one of them (that row
    gives the state to restart from and is dropped). The integrator lands exactly on every
    boundary (one short step) and restarts there with its FSAL derivative and event signs
    re-evaluated, the discrete state ``z`` carried over, and the initial step h0 = the mean step
    of the previous chunk (at most ``hmax``): the step sequence after a boundary differs from
    that of one call, so the results differ by an integration error of the tolerance's order
    (measured in tests/test_interrupt.py: the journal eccentricity to a small fraction of the
    clearance at rtol 1e-8 over the first revolutions, the same contact events).
    """
    n = y0.shape[0]
    n_eval = t_eval.shape[0]
    t_final = float(t_eval[-1])
    Y = np.full((n_eval, n), np.nan)
    Zo = np.zeros((n_eval, z.shape[0]))
    ev_t, ev_k, ev_dir = [], [], []
    n_logged = 0
    stats = None
    status = 0
    t_reached = t0
    n_out = 0
    interrupted = False
    y = np.ascontiguousarray(y0, dtype=float).copy()
    t = float(t0)
    h0 = 0.0
    steps_left = int(max_steps)
    n_chunks = 1 if not math.isfinite(span) else max(1, int(math.ceil((t_final - t0) / span - 1e-9)))
    total = (t_final - t0) / period if period else None
    unit = "rev" if period else "s"
    lo = 0
    with deferred() as sig, progress_bar(total=total if period else t_final - t0, unit=unit,
                                         desc=desc, enabled=progress, delay=PROGRESS_DELAY) as bar:
        for k in range(1, n_chunks + 1):
            b = t_final if k == n_chunks else t0 + k * span
            if b - t < 1e-9 * span and k < n_chunks:
                continue
            hi = int(np.searchsorted(t_eval, b, side="right"))
            te = t_eval[lo:hi]
            extra = te.size == 0 or te[-1] != b
            if extra:
                te = np.append(te, b)
            te = np.ascontiguousarray(te)
            log_k = max(1, min(max_log - len(ev_t), CHUNK_LOG))
            if event_samples is None:
                out = solve(t, y, te, land, p, z, rtol, atol, h0, hmax, steps_left, n_events, log_k)
            else:
                out = solve(t, y, te, land, p, z, rtol, atol, h0, hmax, steps_left, n_events, log_k,
                            int(event_samples))
            st_k, t_k, Y_k, n_k, stats_k, evt_k, evk_k, evd_k, nlog_k, Z_k = as_solution(out)
            n_k = int(n_k)
            stats_k = np.asarray(stats_k, dtype=np.int64)
            stats = stats_k.copy() if stats is None else stats + stats_k
            keep = min(n_k, hi - lo)
            Y[lo:lo + keep] = Y_k[:keep]
            Zo[lo:lo + keep] = Z_k[:keep]
            m = min(int(nlog_k), log_k)
            room = max(0, max_log - len(ev_t))
            ev_t.extend(evt_k[:min(m, room)])
            ev_k.extend(evk_k[:min(m, room)])
            ev_dir.extend(evd_k[:min(m, room)])
            n_logged += int(nlog_k)
            n_out = lo + keep
            status = int(st_k)
            t_reached = float(t_k)
            steps_left -= int(stats_k[0])
            if status != 0 or n_k < te.size:
                break
            acc = int(stats_k[1])
            h0 = min(hmax, (b - t) / acc) if acc > 0 and hmax > 0 else 0.0
            y = np.ascontiguousarray(Y_k[te.size - 1]).copy()
            bar.update(((b - t) / period) if period else (b - t))
            t = b
            lo = hi
            if sig.requested and k < n_chunks:
                interrupted = True
                status = INTERRUPTED
                break
            if steps_left <= 0 and k < n_chunks:
                status = -1
                break
        if sig.requested:
            interrupted = True
            sig.handled = True
    if stats is None:
        stats = np.zeros(5, dtype=np.int64)
    return ChunkedSolution(status, t_reached, Y, n_out, stats, np.array(ev_t, dtype=float),
                           np.array(ev_k, dtype=np.int64), np.array(ev_dir, dtype=np.int64),
                           n_logged, Zo, interrupted)


# integrate_chunked's result: the integrator's Solution fields for the whole run, then whether
# Ctrl-C stopped it (a named tuple: read by name, e.g. by nld.systems.base.integrate)
ChunkedSolution = namedtuple("ChunkedSolution", ["status", "t", "Y", "n_out", "stats", "ev_t",
                                                 "ev_k", "ev_dir", "n_ev", "Z", "interrupted"])


def interrupted_message(t_reached, t0, t_end, n_out, n_eval, scene=None) -> str:
    """Message of a run stopped by Ctrl-C (status INTERRUPTED)."""
    per = _period_or_none(scene) if scene is not None else None
    revs = f", {(t_reached - t0) / per:.4g} of {(t_end - t0) / per:.4g} revolutions" if per else ""
    return (f"interrupted (SIGINT) at t = {t_reached:.9g} s of {t_end:.9g} s{revs}: partial result, "
            f"{n_out} of {n_eval} output rows")


def failure_context(kern: Kernel, rows, n_out) -> str:
    """What a failed run's last output row says of its clearance joints (appended to its message;
    also used by nld.analysis.poincare for a section that stopped)."""
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
    from nld.version import __version__
    from nld.output.provenance import git_hash
    from nld.model.scene import scene_to_dict
    d = {"nld_version": __version__, "git_hash": git_hash(), "scene": scene.name,
         "scene_parameters": scene_to_dict(scene), "integrator": "dopri5"}
    if kern is not None:
        d["kernel"] = kern.key
    d.update(extra)
    return d
