"""Chaos maps: the largest Lyapunov exponent (and the 0-1 test) over a grid of two scene parameters.

    from nld.analysis.chaos_map import chaos_map, chaos_map_plot, load_chaos_map
    df = chaos_map("slider_crank_olyaei", "joints.B.clearance", [1e-4, 2e-4, 5e-4],
                   "joints.B.friction.mu", [0.0, 0.05, 0.1], transient_revs=20, revs=100,
                   rtol=1e-10, out="maps/sc", resume=True)
    fig = chaos_map_plot(df)                       # lambda per revolution, onset boundary lambda = 0
    fig = chaos_map_plot(df, value="K")            # the 0-1 test's K

Every grid cell (x, y) is one scene (the base scene, ``base_overrides``, then each key of
``param_x`` set to x and each key of ``param_y`` set to y: a parameter may be a tuple of ``--set``
keys set together, e.g. the clearances of joints A and B) and runs:

1. a stroboscopic section (:func:`nld.analysis.poincare.stroboscopic`): ``transient_revs`` crank
   revolutions discarded, then ``revs`` section points of ``observable`` (default: ``<J>.ex`` of
   the first clearance joint), at ``rtol``;
2. the largest Lyapunov exponent from the end of the section (its state lies at a multiple of
   the crank period, so the trajectory is continued) over ``lyapunov_revs`` (default ``revs``)
   revolutions, at ``lyapunov_rtol`` (default ``rtol``), by ``estimator``: "tangent" (default,
   :func:`nld.analysis.lyapunov.lyapunov_tangent`: tangent dynamics with saltation matrices at every
   contact event, 2 revolutions of alignment first) or "benettin"
   (:func:`nld.analysis.lyapunov.lyapunov_benettin`, two trajectories with separation ``d0``, default the
   Lyapunov module's 1e-4 in the scaled norm); ``seed`` sets the initial direction;
3. the 0-1 test for chaos (:func:`nld.analysis.zero_one.zero_one_test`) of the section series: a cheap
   second opinion from the points already computed (no extra integration). It needs ``revs`` >=
   30 (else K is NaN with a note) and is rough below a few hundred points. A section that repeats
   to ``period_tol`` (period 1 by :func:`nld.analysis.poincare.period_of`) is a fixed point: K = 0;
4. optionally (``rtol_check``) the exponent again from the same state at a second tolerance, over
   ``check_span`` times the span (a chaos verdict must survive a change of tolerance and of
   averaging time; ``check_span`` 1 keeps the span). A
   cell whose two exponents differ by more than ``CHECK_FACTOR`` x (the sum of their
   uncertainties), or whose two verdicts differ, is "not established" whatever their signs (the
   one verdict rule, ``nld.analysis.verdict``): the value belongs to the integrator, not
   to the mechanism (seen with the stiff Lankarani-Nikravesh contact in permanent contact:
   docs/lyapunov.md, "Tolerance-dependent exponents").

Parallel runs, files and resume are :mod:`nld.sweeps`'s (the point files and provenance checks
of :mod:`nld.sweeps.store`, the worker warm-up, batching and Dask client of
:mod:`nld.sweeps.executors`): the cells are independent points of a sweep whose "value" is the
pair (x, y). ``workers`` local spawned processes (default the CPU
count; 1 runs in this process) or ``dask`` (a ``distributed.Client`` or scheduler address).
``out=DIR`` holds ``point-grid-<index>.parquet`` per finished cell (index = iy * len(values_x) +
ix; rows: the section points with the cell's results repeated; metadata: final state and wall
time) and ``provenance.json``; ``resume=True`` skips the cells whose file exists (the settings must
match). A failing cell (bad value, failed integration, failed exponent) is recorded with status
"failed" and its message, and the map goes on.

Result (one row per cell, y outer, x inner): ``x, y, ix, iy, exponent`` (1/s), ``uncertainty``
(1/s, block standard error + history spread, docs/lyapunov.md), ``per_revolution`` and
``uncertainty_per_revolution`` (natural log per crank revolution), ``verdict`` ("chaotic":
exponent - uncertainty > 0, "regular": exponent + uncertainty < 0, "uncertain" otherwise,
"failed"; with ``rtol_check`` both exponents must give the same verdict and agree, else "not
established"; ``nld.analysis.verdict``), ``K``, ``K_spread`` (half the
inter-quartile range of K_c), ``period`` (of the section, 0 none), ``status``, ``message``,
``per_revolution_check``, ``uncertainty_per_revolution_check`` (the exponent at ``rtol_check``
per revolution; NaN without it). ``attrs``: ``provenance``, ``param_x``, ``param_y`` (lists of
keys), ``wall_s`` ({index: seconds}).
"""
from __future__ import annotations

import copy
import math
from collections.abc import Iterable
import os
import time
from dataclasses import dataclass

import numpy as np
import pandas as pd

from nld.settings import CHAOS_MAP_SPANS, LYAPUNOV, check_rtol
from nld.analysis.bifurcation import RESUME_SETTINGS, PointSpec, plain_value, warm_up
from nld.analysis.verdict import CHECK_FACTOR, NOT_ESTABLISHED, SHORT, verdict as verdict_rule
from nld.errors import InputError
from nld.sweeps.store import ResultStore

__all__ = ["chaos_map", "load_chaos_map", "chaos_map_plot", "param_label", "SUMMARY_COLUMNS"]

DIRECTION = "grid"
SUMMARY_COLUMNS = ["x", "y", "ix", "iy", "exponent", "uncertainty", "per_revolution",
                   "uncertainty_per_revolution", "verdict", "K", "K_spread", "period", "status",
                   "message", "per_revolution_check", "uncertainty_per_revolution_check"]
MIN_ZERO_ONE = 30          # section points the 0-1 test needs (n_cut >= 3)
# settings checked on resume besides bifurcation's (nld.analysis.bifurcation.RESUME_SETTINGS), also
# when the directory holds no finished cell yet
_EXTRA_SETTINGS = ("kind", "d0", "seed", "observable", "zero_one", "rtol_check", "check_span",
                   "min_section_points", "lyapunov_integrator", "estimator")
# what a provenance.json written before an extra setting existed stands for (dopri5, two
# trajectories, a check over the same span)
_EXTRA_DEFAULTS = {"lyapunov_integrator": "dopri5", "estimator": "benettin", "check_span": 1.0,
                   "min_section_points": 0}
# exponents at two tolerances "agree" when they differ by at most CHECK_FACTOR combined
# uncertainties (nld.analysis.verdict.CHECK_FACTOR, imported above)


@dataclass
class _Job:
    """Everything a worker needs for a cell (picklable)."""
    spec: PointSpec          # scene, section and tolerance settings (bifurcation's point spec)
    keys_x: list
    keys_y: list
    observable: str | None
    d0: float | None
    seed: int
    zero_one: dict
    rtol_check: float | None = None
    check_span: float = 1.0
    min_section_points: int = 0
    lyapunov_method: str = "dopri5"
    estimator: str = "tangent"


# ---------------------------------------------------------------------------------------------------
# one cell


def _keys(param, name: str) -> list[str]:
    if isinstance(param, str):
        keys = [param]
    elif isinstance(param, (list, tuple)) and param and all(isinstance(k, str) for k in param):
        keys = list(param)
    else:
        raise InputError(f"{name} = {param!r}: a --set key (e.g. joints.B.clearance) or a list of "
                         "keys set together")
    return keys


def param_label(keys) -> str:
    """``["joints.A.clearance", "joints.B.clearance"]`` -> ``"joints.A,B.clearance"``."""
    keys = [keys] if isinstance(keys, str) else list(keys)
    if len(keys) == 1:
        return keys[0]
    parts = [k.split(".") for k in keys]
    if len({len(p) for p in parts}) == 1:
        diff = [i for i in range(len(parts[0])) if len({p[i] for p in parts}) > 1]
        if len(diff) == 1:
            i = diff[0]
            p = list(parts[0])
            p[i] = ",".join(q[i] for q in parts)
            return ".".join(p)
    return " = ".join(keys)


def _cell_scene(job: _Job, x, y):
    from nld.model.scene import apply_overrides, scene_from_dict
    raw = copy.deepcopy(job.spec.raw)
    apply_overrides(raw, {**{k: x for k in job.keys_x}, **{k: y for k in job.keys_y}})
    return scene_from_dict(raw, job.spec.source)


def _run_cell(job: _Job, index: int, ix: int, iy: int, x, y) -> dict:
    """Run one cell; never raises for a bad value or a failed run (status 'failed')."""
    from nld.kernel.compile import compile_scene
    from nld.analysis.lyapunov import largest_exponent
    from nld.analysis.poincare import default_observables, period_of, section_scales, stroboscopic
    from nld.systems.core import SceneSystem
    from nld.analysis.zero_one import zero_one_test
    spec = job.spec
    start = time.perf_counter()
    notes = []
    status, message = "ok", ""
    lam = unc = per_rev = unc_rev = K = K_spread = math.nan
    lam_c = unc_c = per_rev_c = unc_rev_c = math.nan
    permanent = False
    period = 0
    obs = job.observable
    y_final = z_final = None
    table = None
    try:
        scene = _cell_scene(job, x, y)
        kern = compile_scene(scene)
        if obs is None:
            obs = default_observables(kern)[0]
        sec = stroboscopic(scene, transient_revs=spec.transient_revs, revs=spec.revs,
                           observables=[obs], rtol=spec.rtol, kernel=kern,
                           max_steps=spec.max_steps)
        message = sec.message if not sec.success else ""
        if not sec.success or len(sec.table) < spec.revs:
            raise _CellFailed(f"section: {sec.message}")
        table = sec.table.drop(columns=["t"]).rename(columns={obs: "value"})
        table.insert(1, "observable", [obs] * len(table))
        series = sec.table[obs].to_numpy(dtype=float)
        period = period_of(series, tol=spec.period_tol, n_max=spec.n_max,
                           scale=section_scales(scene, [obs]))
        y_final, z_final = sec.y_final.tolist(), sec.z_final.tolist()
        # the 0-1 test of the section series (no extra integration)
        if spec.revs < MIN_ZERO_ONE:
            notes.append(f"K not computed: {spec.revs} section points (the 0-1 test needs "
                         f">= {MIN_ZERO_ONE})")
        elif period == 1:
            K, K_spread = 0.0, 0.0
            notes.append("section is a fixed point (period 1): K = 0")
        else:
            zo = zero_one_test(series, **job.zero_one)
            K, K_spread = zo.K, zo.spread
        # the largest exponent, continuing from the end of the section
        system = SceneSystem(scene, kernel=kern, method=job.lyapunov_method)
        system.y0 = np.array(sec.y_final, dtype=float)
        system.z0 = np.array(sec.z_final, dtype=float)
        res = largest_exponent(system, job.estimator, total=spec.lyapunov_revs * sec.period,
                               rtol=spec.lyapunov_rtol, d0=job.d0, seed=job.seed)
        lam, unc = float(res.exponent), float(res.uncertainty)
        per_rev, unc_rev = float(res.per_revolution), float(res.uncertainty_per_revolution)
        permanent = bool(res.diagnostics.get("permanent_contact", False))
        if permanent:
            mem = res.diagnostics.get("conditional_on_memory", {})
            notes.append("permanent contact: no contact onset over the span, lambda conditional "
                         "on the recorded memory " + ", ".join(f"{k} = {v:.4g} m/s"
                                                               for k, v in mem.items()))
        if job.rtol_check is not None:      # the same exponent at a second tolerance and span
            chk = largest_exponent(system, job.estimator,
                                   total=job.check_span * spec.lyapunov_revs * sec.period,
                                   rtol=job.rtol_check, d0=job.d0, seed=job.seed)
            lam_c, unc_c = float(chk.exponent), float(chk.uncertainty)
            per_rev_c = float(chk.per_revolution)
            unc_rev_c = float(chk.uncertainty_per_revolution)
            if verdict_rule(lam, unc, lam_check=lam_c, unc_check=unc_c) == NOT_ESTABLISHED:
                notes.append(f"lambda depends on the tolerance: {per_rev:.3g} +- {unc_rev:.2g} per "
                             f"revolution at rtol {spec.lyapunov_rtol:g}, {per_rev_c:.3g} +- "
                             f"{unc_rev_c:.2g} at rtol {job.rtol_check:g}")
    except Exception as e:        # noqa: BLE001 - a cell's failure is data, the map goes on
        status = "failed"
        message = (str(e) if isinstance(e, _CellFailed)
                   else f"{type(e).__name__}: {' '.join(str(e).split())}")
    n_sec = int((table["rev"] >= 0).sum()) if table is not None and "rev" in table else 0
    # the one verdict rule (nld.analysis.verdict): a positive exponent over a section shorter
    # than min_section_points cannot tell an attractor from a transient ("λ1 > 0, short")
    verdict = verdict_rule(lam, unc, lam_check=lam_c, unc_check=unc_c, n_points=n_sec,
                           min_points=job.min_section_points,
                           failed=status != "ok" or not math.isfinite(lam),
                           permanent_contact=permanent)
    if verdict == SHORT:
        notes.append(f"lambda > 0 over a section of {n_sec} points (a chaotic verdict needs "
                     f"{job.min_section_points})")
    if notes:
        message = (message + "; " if message else "") + "; ".join(notes)
    if table is None:
        table = pd.DataFrame({"rev": np.array([-1], dtype=np.int64),
                              "observable": [obs if obs is not None else ""],
                              "value": np.array([np.nan])})
    n = len(table)
    head = {"x": [x] * n, "y": [y] * n, "ix": np.full(n, ix, dtype=np.int64),
            "iy": np.full(n, iy, dtype=np.int64)}
    summary = {"exponent": lam, "uncertainty": unc, "per_revolution": per_rev,
               "uncertainty_per_revolution": unc_rev,
               "verdict": verdict,
               "K": K, "K_spread": K_spread, "period": int(period), "status": status,
               "message": message, "per_revolution_check": per_rev_c,
               "uncertainty_per_revolution_check": unc_rev_c}
    table = pd.concat([pd.DataFrame(head), table.reset_index(drop=True)], axis=1)
    for k, v in summary.items():
        table[k] = [v] * n if isinstance(v, str) else np.full(n, v)
    return dict(direction=DIRECTION, index=int(index), value=[x, y], status=status,
                message=message, y_final=y_final, z_final=z_final,
                wall=time.perf_counter() - start, table=table)


class _CellFailed(Exception):
    pass


# ---------------------------------------------------------------------------------------------------
# the map


def _summary(frames) -> pd.DataFrame:
    if not frames:
        return pd.DataFrame(columns=SUMMARY_COLUMNS)
    df = pd.concat(frames, ignore_index=True)
    first = df.drop_duplicates(["iy", "ix"]).sort_values(["iy", "ix"], kind="stable")
    return first[SUMMARY_COLUMNS].reset_index(drop=True)


def _sections(frames) -> pd.DataFrame:
    df = pd.concat(frames, ignore_index=True)
    return df.sort_values(["iy", "ix", "rev"], kind="stable").reset_index(drop=True)


def _values(v, name):
    if isinstance(v, (str, bytes)) or not isinstance(v, Iterable):
        from nld.errors import InputTypeError
        raise InputTypeError(f"{name} = {v!r}: must be a list or array of numbers")
    v = v.tolist() if isinstance(v, np.ndarray) else list(v)
    if not v:
        raise InputError(f"{name}: give at least one value")
    return [plain_value(a) for a in v]


def chaos_map(scene, param_x, values_x, param_y, values_y, *,
              transient_revs: int = CHAOS_MAP_SPANS.transient_revs,
              revs: int = CHAOS_MAP_SPANS.revs, rtol: float = LYAPUNOV.rtol, workers: int | None = None, dask=None,
              out=None, resume: bool = False, base_overrides=None,
              lyapunov_revs: int | None = None, lyapunov_rtol: float | None = None,
              d0: float | None = None, seed: int = 0, observable: str | None = None,
              zero_one: dict | None = None, period_tol: float = 1e-6,
              max_steps: int = LYAPUNOV.max_steps, batch_size: int | None = None,
              progress=None, rtol_check: float | None = None, check_span: float = 1.0,
              min_section_points: int = 0,
              lyapunov_method: str = "dopri5", estimator: str = "tangent",
              on_point=None) -> pd.DataFrame:
    """The largest Lyapunov exponent and the 0-1 test over the grid values_x x values_y.

    scene: Scene, built-in name or TOML path; base_overrides: ``--set`` values applied first.
    param_x, param_y: a ``--set`` key, or a list of keys set to the same value (e.g.
    ``["joints.A.friction.mu", "joints.B.friction.mu"]``); values_x, values_y: numbers.
    transient_revs, revs, rtol, max_steps: the stroboscopic section of each cell (revs points).
    rtol defaults to 1e-10, the Lyapunov module's: a looser tolerance can change the verdict (the
    slider-crank at 50 rad/s with restitution 0.5 is period 1 with lambda = -0.35 +- 0.25 per
    revolution at 1e-10, but wanders over the clearance with lambda = +3.1 +- 0.6 at 1e-9 and
    +3.9 +- 1.5 at 1e-8, K ~ 1: the integration error decides the attractor there).
    lyapunov_revs (default revs), lyapunov_rtol (default rtol), seed: the exponent, from the end
    of the section, by ``estimator`` "tangent" (default, :func:`nld.analysis.lyapunov.lyapunov_tangent`)
    or "benettin" (:func:`nld.analysis.lyapunov.lyapunov_benettin` with separation d0, default 1e-4 in
    the scaled norm; d0 is refused with the tangent estimator).
    rtol_check (default None: no check): a second tolerance at which the exponent is recomputed
    from the same state, averaged over ``check_span`` (default 1, >= 1) times the span; the cell
    is "not established" unless both agree (module docstring, step 4). A cell whose exponent
    span had no contact onset under a law with memory is "permanent contact" (its exponent is
    conditional on the recorded memory; docs/contact-laws.md). min_section_points (default 0):
    a cell with a positive exponent over a section of fewer points is "λ1 > 0, short", not chaotic
    (a short section cannot tell an attractor from a transient; the studies use 50). It costs about check_span x
    (rtol / rtol_check)^(1/5) times the exponent (DOPRI5's steps), twice or more.
    lyapunov_method: the integrator of the exponent (and of its check): "dopri5" (default; the
    only one of the tangent estimator); with estimator="benettin" also "dop853" (stops with a message where its stiffness detection fires) or
    "rodas" (Rodas4, experimental: tried on cells whose journal stays in stiff damped contact, it
    did not cure their tolerance-dependent exponent, is 10-100 times slower with its
    finite-difference Jacobian, and gave a wrong positive exponent on a period-1 orbit at rtol
    1e-5 and 1e-6; docs/lyapunov.md). The sections always use DOPRI5.
    observable: the section observable of the 0-1 test (default ``<J>.ex`` of the first clearance
    joint); zero_one: keyword arguments of :func:`nld.analysis.zero_one.zero_one_test` (default none:
    100 frequencies, seed 0). period_tol: a section repeating to this relative tolerance is a fixed
    point (K = 0).
    workers, dask, batch_size, out, resume, progress, on_point: as :func:`nld.analysis.bifurcation.sweep`
    (a bar in cells; on_point(done, total, record)); Ctrl-C keeps the finished cells in ``out``
    and raises :class:`nld.errors.Interrupted`.

    Returns one row per cell (see the module docstring), also for resumed cells.
    """
    from nld.version import __version__
    from nld.analysis.poincare import check_count, load_scene_arg
    from nld.output.provenance import git_hash
    from nld.model.scene import NO_VALUE, scene_to_dict, scene_value
    from nld.progress import split_progress
    from nld.sweeps.engine import run_points
    bar_on, on_point = split_progress(progress, on_point)
    keys_x, keys_y = _keys(param_x, "param_x"), _keys(param_y, "param_y")
    if set(keys_x) & set(keys_y):
        raise InputError(f"param_x and param_y share {sorted(set(keys_x) & set(keys_y))}")
    sc = load_scene_arg(scene, base_overrides)
    raw = scene_to_dict(sc)
    for k in keys_x + keys_y:
        if scene_value(raw, k) is NO_VALUE:
            raise InputError(f"parameter {k!r}: not a value of scene {sc.name!r} (a --set key such "
                             "as joints.B.clearance or joints.B.friction.mu)")
    vx, vy = _values(values_x, "values_x"), _values(values_y, "values_y")
    check_rtol(rtol, "rtol")
    if lyapunov_rtol is not None:
        check_rtol(lyapunov_rtol, "lyapunov_rtol")
    transient_revs = check_count("transient_revs", transient_revs, 0)
    revs = check_count("revs", revs, 1)
    lyapunov_revs = revs if lyapunov_revs is None else check_count("lyapunov_revs", lyapunov_revs, 2)
    if lyapunov_revs < 2:
        raise InputError(f"lyapunov_revs = {lyapunov_revs}: need at least 2 revolutions")
    if d0 is not None and not (isinstance(d0, (int, float)) and math.isfinite(d0) and d0 > 0):
        raise InputError(f"d0 = {d0!r}: must be a positive number")
    zero_one = dict(zero_one or {})
    from nld.systems.core import check_system_method
    lyapunov_method = check_system_method(lyapunov_method, "lyapunov_method")
    from nld.analysis.lyapunov import ESTIMATORS
    if estimator not in ESTIMATORS:
        raise InputError(f"estimator = {estimator!r}: must be one of {', '.join(ESTIMATORS)}")
    if estimator == "tangent" and lyapunov_method != "dopri5":
        raise InputError(f"lyapunov_method = {lyapunov_method!r}: the tangent estimator runs on "
                         "dopri5 only; use estimator='benettin' for another integrator")
    if estimator == "tangent" and d0 is not None:
        raise InputError(f"d0 = {d0!r}: a separation of the two-trajectory estimator; the "
                         "tangent estimator has none (use estimator='benettin')")
    check_rtol(rtol_check, "rtol_check", none_ok=True)
    if not (isinstance(min_section_points, (int, np.integer)) and not isinstance(min_section_points, bool)
            and min_section_points >= 0):
        raise InputError(f"min_section_points = {min_section_points!r}: must be an integer >= 0")
    if not (isinstance(check_span, (int, float)) and not isinstance(check_span, bool)
            and 1.0 <= check_span <= 100.0):
        raise InputError(f"check_span = {check_span!r}: must be a number in [1, 100] (the check's "
                         "averaging span over the exponent's)")
    from nld.analysis.lyapunov import check_seed
    seed = check_seed(seed)
    spec = PointSpec(raw=raw, source=sc.source, param=keys_x[0], transient_revs=transient_revs,
                      revs=revs, observables=[observable] if observable else None,
                      rtol=float(rtol), max_steps=int(max_steps), period_tol=float(period_tol),
                      n_max=int(min(16, max(1, revs // 2))), lyapunov=True,
                      lyapunov_revs=int(lyapunov_revs),
                      lyapunov_rtol=float(rtol if lyapunov_rtol is None else lyapunov_rtol),
                      cache_dir=os.environ.get("NLD_CACHE_DIR"),
                      lyapunov_estimator=estimator)
    job = _Job(spec=spec, keys_x=keys_x, keys_y=keys_y, observable=observable,
               d0=None if d0 is None else float(d0), seed=seed, zero_one=zero_one,
               rtol_check=None if rtol_check is None else float(rtol_check),
               check_span=float(check_span), min_section_points=int(min_section_points),
               lyapunov_method=lyapunov_method, estimator=estimator)
    settings = dict(scene=sc.name, scene_parameters=raw, param=[keys_x, keys_y], values=[vx, vy],
                    transient_revs=transient_revs, revs=revs, observables=spec.observables,
                    rtol=spec.rtol, continuation=False, up_down=False, max_steps=spec.max_steps,
                    period_tol=spec.period_tol, n_max=spec.n_max, lyapunov=True,
                    lyapunov_revs=spec.lyapunov_revs, lyapunov_rtol=spec.lyapunov_rtol,
                    d0=job.d0, seed=job.seed, observable=observable, zero_one=zero_one,
                    rtol_check=job.rtol_check, check_span=job.check_span,
                    min_section_points=job.min_section_points,
                    lyapunov_integrator=lyapunov_method,
                    estimator=estimator, lyapunov_estimator=estimator)
    prov = dict(nld_version=__version__, git_hash=git_hash(), kind="chaos_map",
                integrator=f"dopri5 (sections), {lyapunov_method} (exponents)",
                base_overrides=_plain_overrides(base_overrides),
                lyapunov_method=(f"{estimator} (nld.analysis.lyapunov."
                                 f"{'lyapunov_tangent' if estimator == 'tangent' else 'lyapunov_benettin'})"),
                zero_one_method="Gottwald-Melbourne 2009 modified correlation (nld.analysis.zero_one)",
                **settings)
    cells = [(iy * len(vx) + ix, ix, iy, vx[ix], vy[iy]) for iy in range(len(vy))
             for ix in range(len(vx))]
    store = None
    done = {}
    if out is not None:
        store = ResultStore(out)
        store.check_settings(prov, _EXTRA_SETTINGS, what="run", defaults=_EXTRA_DEFAULTS)
        store.prepare(prov, RESUME_SETTINGS, resume=resume)
        if resume:
            done = store.finished(DIRECTION)
    elif resume:
        raise InputError("resume=True needs out (the directory of the interrupted map)")
    start = time.perf_counter()
    todo = [c for c in cells if (DIRECTION, c[0]) not in done]
    # each worker loads the kernel once (the cells share one structure)
    results = run_points(_run_cell, job, todo, done=done, total=len(cells), store=store,
                         workers=workers, dask=dask, batch_size=batch_size,
                         warm=(warm_up, (job.spec, todo[0][3])) if todo else None,
                         progress=bar_on, on_point=on_point, desc=f"chaos map {sc.name}",
                         unit="cell")
    results = {index: rec for (_, index), rec in results.items()}
    df = _summary([results[c[0]]["table"] for c in cells if c[0] in results])
    prov["wall"] = time.perf_counter() - start
    prov["cells_run"] = len(todo)
    df.attrs.update(provenance=prov, param_x=keys_x, param_y=keys_y,
                    wall_s={int(k): float(r.get("wall", math.nan)) for k, r in results.items()})
    return df


def _plain_overrides(ov):
    if ov is None:
        return []
    if isinstance(ov, str):
        return [ov]
    if isinstance(ov, dict):
        return [f"{k}={v}" for k, v in ov.items()]
    return [str(o) if isinstance(o, str) else f"{o[0]}={o[1]}" for o in ov]


def load_chaos_map(out, *, sections: bool = False) -> pd.DataFrame:
    """The finished cells of a map directory: one row per cell (as :func:`chaos_map`), or with
    ``sections=True`` every section point (columns ``x, y, ix, iy, rev, observable, value`` and the
    cell's results). ``attrs["provenance"]`` holds provenance.json."""
    store = ResultStore.existing(out, "chaos map")
    prov = store.provenance()
    recs = store.records(DIRECTION)
    frames = [r["table"] for r in recs]
    df = (_sections(frames) if frames else pd.DataFrame()) if sections else _summary(frames)
    param = prov.get("param") or [[], []]
    df.attrs.update(provenance=prov, param_x=param[0], param_y=param[1],
                    wall_s={int(r["index"]): float(r.get("wall", math.nan)) for r in recs})
    return df


# ---------------------------------------------------------------------------------------------------
# plot


def _edges(v: np.ndarray, log: bool) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if v.size == 1:
        return np.array([v[0] * 0.9, v[0] * 1.1]) if log else np.array([v[0] - 0.5, v[0] + 0.5])
    if log:
        lv = np.log(v)
        mid = 0.5 * (lv[1:] + lv[:-1])
        return np.exp(np.concatenate([[2 * lv[0] - mid[0]], mid, [2 * lv[-1] - mid[-1]]]))
    mid = 0.5 * (v[1:] + v[:-1])
    return np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])


def _is_log(v) -> bool:
    v = np.asarray(v, dtype=float)
    if v.size < 3 or np.any(v <= 0):
        return False
    r = v[1:] / v[:-1]
    d = np.diff(v)
    return bool(np.allclose(r, r[0], rtol=1e-6) and not np.allclose(d, d[0], rtol=1e-6))


def chaos_map_plot(df: pd.DataFrame, *, value: str = "lambda", ax=None, title: str | None = None,
                   x_label: str | None = None, y_label: str | None = None, x_scale: float = 1.0,
                   y_scale: float = 1.0, x_log: bool | None = None, y_log: bool | None = None,
                   colorbar: bool = True, annotate: bool = True):
    """The map of a :func:`chaos_map` table; returns the Figure.

    value="lambda": pcolormesh of the exponent per crank revolution (diverging colours, 0 white),
      the lambda = 0 contour (the onset boundary, drawn through the cell centres, linear
      interpolation; only where both neighbours are finite), cells whose sign is not established
      (|lambda| <= uncertainty, or verdict "uncertain": the exponents at rtol and rtol_check
      disagree) hatched "//", failed cells grey with an "x".
    value="K": the 0-1 test's K (0 regular ... 1 chaotic), with the K = 0.5 contour; cells
      without K grey.
    x_scale, y_scale: factors for the axes (e.g. 1e3 with a label in mm); x_log, y_log: log axes
      (default: when the values are geometrically spaced). annotate: print each cell's value.
    Axis labels default to the parameters (``attrs["param_x"]``) with their units.
    """
    from matplotlib.colors import TwoSlopeNorm
    from matplotlib.patches import Rectangle
    from nld.output.plots import figure_axes, unit_of
    if value not in ("lambda", "K"):
        raise InputError(f"value = {value!r}: 'lambda' or 'K'")
    fig, ax = figure_axes(ax)
    xs = np.sort(df["x"].astype(float).unique())
    ys = np.sort(df["y"].astype(float).unique())
    ix = np.searchsorted(xs, df["x"].astype(float))
    iy = np.searchsorted(ys, df["y"].astype(float))
    Z = np.full((ys.size, xs.size), np.nan)
    U = np.full_like(Z, np.nan)
    failed = np.zeros(Z.shape, dtype=bool)
    col = "per_revolution" if value == "lambda" else "K"
    Z[iy, ix] = df[col].astype(float).to_numpy()
    uncertain = np.zeros(Z.shape, dtype=bool)
    checked = "per_revolution_check" in df and df["per_revolution_check"].notna().any()
    if value == "lambda":
        U[iy, ix] = df["uncertainty_per_revolution"].astype(float).to_numpy()
        uncertain[iy, ix] = np.abs(Z[iy, ix]) <= U[iy, ix]
        if "verdict" in df:          # includes the cells whose exponent fails the tolerance check
            uncertain[iy, ix] |= df["verdict"].isin(["uncertain", NOT_ESTABLISHED,
                                                     SHORT]).to_numpy()
    failed[iy, ix] = (df["status"] != "ok").to_numpy() | ~np.isfinite(Z[iy, ix])
    x_log = _is_log(xs) if x_log is None else x_log
    y_log = _is_log(ys) if y_log is None else y_log
    xe, ye = _edges(xs, x_log) * x_scale, _edges(ys, y_log) * y_scale
    if value == "lambda":
        m = np.nanmax(np.abs(Z)) if np.any(np.isfinite(Z)) else 1.0
        m = m if m > 0 else 1.0
        norm = TwoSlopeNorm(vcenter=0.0, vmin=-m, vmax=m)
        mesh = ax.pcolormesh(xe, ye, np.ma.masked_invalid(Z), cmap="RdBu_r", norm=norm,
                             shading="flat")
        clabel = "λ₁ per crank revolution (−)"
        level, ccol = 0.0, "black"
    else:
        mesh = ax.pcolormesh(xe, ye, np.ma.masked_invalid(Z), cmap="viridis", vmin=0.0, vmax=1.0,
                             shading="flat")
        clabel = "0-1 test K (−)"
        level, ccol = 0.5, "white"
    ax.set_facecolor("#d0d0d0")          # failed / missing cells
    if colorbar:
        fig.colorbar(mesh, ax=ax, label=clabel)
    xc, yc = xs * x_scale, ys * y_scale
    if xs.size >= 2 and ys.size >= 2 and np.any(np.isfinite(Z)):
        zmin, zmax = np.nanmin(Z), np.nanmax(Z)
        if zmin < level < zmax:
            ax.contour(xc, yc, np.ma.masked_invalid(Z), levels=[level], colors=ccol,
                       linewidths=1.8)
            ax.plot([], [], color=ccol, lw=1.8,
                    label="λ₁ = 0 (onset of chaos)" if value == "lambda" else "K = 0.5")
    for j in range(ys.size):
        for i in range(xs.size):
            w, h = xe[i + 1] - xe[i], ye[j + 1] - ye[j]
            if failed[j, i]:
                ax.add_patch(Rectangle((xe[i], ye[j]), w, h, fill=False, hatch="xx",
                                       edgecolor="#606060", lw=0))
            elif value == "lambda" and uncertain[j, i]:
                ax.add_patch(Rectangle((xe[i], ye[j]), w, h, fill=False, hatch="//",
                                       edgecolor="#404040", lw=0))
            if annotate and np.isfinite(Z[j, i]):
                txt = (f"{Z[j, i]:.2g}\n±{U[j, i]:.1g}" if value == "lambda" and np.isfinite(U[j, i])
                       else f"{Z[j, i]:.2f}")
                xm = math.sqrt(xe[i] * xe[i + 1]) if x_log else 0.5 * (xe[i] + xe[i + 1])
                ym = math.sqrt(ye[j] * ye[j + 1]) if y_log else 0.5 * (ye[j] + ye[j + 1])
                ax.text(xm, ym, txt, ha="center", va="center", fontsize=6.5, color="black")
    if value == "lambda":
        ax.add_patch(Rectangle((0, 0), 0, 0, fill=False, hatch="//", edgecolor="#404040",
                               label=("uncertain: |λ₁| ≤ unc. or tolerances disagree" if checked
                                      else "|λ₁| ≤ uncertainty")))
    if failed.any():
        ax.add_patch(Rectangle((0, 0), 0, 0, fill=False, hatch="xx", edgecolor="#606060",
                               label="failed / no value"))
    if x_log:
        ax.set_xscale("log")
    if y_log:
        ax.set_yscale("log")
    ax.set_xlim(xe[0], xe[-1])
    ax.set_ylim(ye[0], ye[-1])
    px, py = df.attrs.get("param_x") or ["x"], df.attrs.get("param_y") or ["y"]
    ax.set_xlabel(x_label or f"{param_label(px)} ({unit_of(px[0]) or '−'})")
    ax.set_ylabel(y_label or f"{param_label(py)} ({unit_of(py[0]) or '−'})")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", fontsize=7, framealpha=0.85)
    ax.grid(False)
    if title:
        ax.set_title(title)
    return fig
