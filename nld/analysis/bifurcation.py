"""Bifurcation sweeps: stroboscopic Poincaré points over a range of any scene parameter.

:func:`sweep` runs, for every value of one ``--set`` key (``driver.speed``,
``joints.B.clearance``, ``joints.B.friction.mu`` ...), a stroboscopic section
(:func:`nld.analysis.poincare.stroboscopic`): ``transient_revs`` crank revolutions discarded, then ``revs``
section points; each point also gets a period estimate (:func:`nld.analysis.poincare.period_of`) and,
optionally, the largest Lyapunov exponent (``nld.analysis.lyapunov.largest_exponent``: the tangent
estimator with saltation by default, the two-trajectory one on request).

* Independent points (default) run in parallel (:mod:`nld.sweeps`): a local ``ProcessPoolExecutor`` (spawned
  workers, each warmed once by an initializer that loads the kernel from numba's disk cache;
  points sent in batches), or a Dask cluster (``dask=`` scheduler address or
  ``distributed.Client``). The numbers do not depend on where a point ran: local and Dask
  sweeps give identical tables, point for point.
* ``continuation=True``: each point starts from the previous point's final state (a multiple of
  the crank period, so the trajectory is continued, not restarted); the sweep is then sequential
  per direction and runs in this process. ``up_down=True`` sweeps the values in the given order
  ("up") and then back ("down"); with continuation the down sweep starts from the end of the up
  sweep, which exposes hysteresis (coexisting attractors).
* A point that fails (a SceneError for its value, an integration that stops: non-finite state,
  max_steps, ...) is recorded with status "failed" and its message, and the sweep goes on; with
  continuation the next point restarts from the assembled initial state.

Output (``out=DIR``): one parquet file per finished point, ``DIR/point-<direction>-<index>.parquet``,
written atomically when the point finishes (a killed sweep loses only the points in progress),
with the point's final state and wall time in its metadata, plus ``DIR/provenance.json`` (nld
version, git hash, scene with all its parameters, param, values, tolerances and settings).
``resume=True`` skips the points whose file exists (the settings must match those in
provenance.json); the files are those of :class:`nld.sweeps.store.ResultStore`. :func:`load_sweep` reads the directory back into one table.

Table columns: ``value`` (the parameter value), ``direction`` ("up"/"down"), ``index`` (position
of the value in ``values``), ``rev`` (crank revolution of the section point; -1 on the single row of
a failed point), the observables (SI units of their table columns), ``period`` (0: none found
up to n_max), ``lyapunov`` (1/s; NaN when not computed), ``lyapunov_uncertainty`` (1/s),
``status`` ("ok"/"failed"), ``message``. Rows come in sweep order: the up points by
increasing index, then the down points by decreasing index, then by rev.
"""
from __future__ import annotations

import copy
import math
from collections.abc import Iterable
import os
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from nld.errors import InputError
from nld.settings import BIFURCATION_SPANS, SECTIONS, check_rtol
from nld.sweeps.store import META_KEY, PROVENANCE, ResultStore  # noqa: F401 - META_KEY re-exported

__all__ = ["sweep", "load_sweep", "parse_values", "check_values"]

DIRECTIONS = ("up", "down")
# settings that must match for resume=True
RESUME_SETTINGS = ("scene_parameters", "param", "values", "transient_revs", "revs", "observables",
             "rtol", "continuation", "up_down", "max_steps", "period_tol", "n_max", "lyapunov",
             "lyapunov_revs", "lyapunov_rtol", "lyapunov_estimator")


@dataclass
class PointSpec:
    """Everything a worker needs to run a point (picklable)."""
    raw: dict                    # resolved scene (scene_to_dict) with the base overrides applied
    source: str
    param: str
    transient_revs: int
    revs: int
    observables: list | None
    rtol: float
    max_steps: int
    period_tol: float
    n_max: int
    lyapunov: bool
    lyapunov_revs: int
    lyapunov_rtol: float | None
    lyapunov_estimator: str = "tangent"
    cache_dir: str | None = field(default=None)


# ---------------------------------------------------------------------------------------------------
# one point


def _scene_for(spec: PointSpec, value):
    from nld.model.scene import apply_overrides, scene_from_dict
    raw = copy.deepcopy(spec.raw)
    apply_overrides(raw, {spec.param: value})
    return scene_from_dict(raw, spec.source)


def _failed_table(spec: PointSpec, observables) -> pd.DataFrame:
    d = {"rev": np.array([-1], dtype=np.int64)}
    for o in observables:
        d[o] = np.array([np.nan])
    return pd.DataFrame(d)


def _run_point(spec: PointSpec, direction: str, index: int, value, y0=None, z0=None) -> dict:
    """Run one point; never raises for a bad value or a failed integration (status 'failed')."""
    from nld.kernel.compile import compile_scene
    from nld.analysis.poincare import default_observables, period_of, section_scales, stroboscopic
    start = time.perf_counter()
    notes = []
    obs = spec.observables
    status, message = "ok", ""
    lyap = lyap_unc = math.nan
    y_final = z_final = None
    period = 0
    try:
        scene = _scene_for(spec, value)
        kern = compile_scene(scene)
        if obs is None:
            obs = default_observables(kern)
        if y0 is not None and (len(y0) != kern.n_state or len(z0) != kern.n_z):
            notes.append("continuation reset: the state size changed")
            y0 = z0 = None
        sec = stroboscopic(scene, transient_revs=spec.transient_revs, revs=spec.revs,
                           observables=obs, rtol=spec.rtol, y0=y0, z0=z0, kernel=kern,
                           max_steps=spec.max_steps)
        message = sec.message
        if not sec.success or len(sec.table) < spec.revs:
            status = "failed"
            table = _failed_table(spec, obs)
        else:
            table = sec.table.drop(columns=["t"]).reset_index(drop=True)
            period = period_of(sec.points, tol=spec.period_tol, n_max=spec.n_max,
                               scale=section_scales(scene, sec.observables))
            y_final, z_final = sec.y_final.tolist(), sec.z_final.tolist()
            if spec.lyapunov:
                lyap, lyap_unc, note = _lyapunov(spec, scene, kern, sec)
                if note:
                    notes.append(note)
    except Exception as e:        # noqa: BLE001 - a point's failure is data, the sweep goes on
        status = "failed"
        message = f"{type(e).__name__}: {' '.join(str(e).split())}"
        obs = obs if obs is not None else []
        table = _failed_table(spec, obs)
    if notes:
        message = (message + "; " if message else "") + "; ".join(notes)
    n = len(table)
    table.insert(0, "index", np.full(n, int(index), dtype=np.int64))
    table.insert(0, "direction", [direction] * n)
    table.insert(0, "value", [value] * n)
    table["period"] = np.full(n, int(period), dtype=np.int64)
    table["lyapunov"] = np.full(n, lyap)
    table["lyapunov_uncertainty"] = np.full(n, lyap_unc)
    table["status"] = [status] * n
    table["message"] = [message] * n
    wall = time.perf_counter() - start
    return dict(direction=direction, index=int(index), value=value, status=status,
                message=message, y_final=y_final, z_final=z_final, wall=wall, table=table)


def _lyapunov(spec: PointSpec, scene, kern, sec):
    """(exponent 1/s, uncertainty 1/s, note) from the end of the section, or NaNs and a note."""
    try:
        from nld.analysis.lyapunov import largest_exponent
        from nld.systems.core import SceneSystem
    except ImportError as e:
        return math.nan, math.nan, f"lyapunov skipped: nld.analysis.lyapunov not available ({e})"
    try:
        system = SceneSystem(scene, kernel=kern)
        system.y0 = np.array(sec.y_final, dtype=float)
        system.z0 = np.array(sec.z_final, dtype=float)
        res = largest_exponent(system, spec.lyapunov_estimator,
                               total=spec.lyapunov_revs * sec.period, rtol=spec.lyapunov_rtol)
        return float(res.exponent), float(res.uncertainty), ""
    except Exception as e:        # noqa: BLE001
        return math.nan, math.nan, f"lyapunov failed: {type(e).__name__}: {' '.join(str(e).split())}"


def warm_up(spec: PointSpec, value) -> None:
    """Load the kernel of ``value``'s scene (numba disk cache) and run a few steps: the warm-up
    of every worker process of a parallel sweep (nld.sweeps.executors)."""
    if spec.cache_dir and not os.environ.get("NLD_CACHE_DIR"):
        os.environ["NLD_CACHE_DIR"] = spec.cache_dir
    from nld.kernel.compile import compile_scene
    from nld.run.simulate import crank_period, simulate
    scene = _scene_for(spec, value)
    kern = compile_scene(scene)
    simulate(scene, t_eval=np.array([0.0, 0.01 * crank_period(scene)]), land=True,
             kernel=kern, rtol=spec.rtol)


# ---------------------------------------------------------------------------------------------------
# files


def load_sweep(out) -> pd.DataFrame:
    """All finished points of a sweep directory as one table (see the module docstring), sweep
    order; ``attrs["provenance"]`` holds provenance.json."""
    store = ResultStore.existing(out, "sweep")
    prov = store.provenance()
    frames = [rec["table"] for rec in store.records()]
    if not frames:
        df = pd.DataFrame(columns=["value", "direction", "index", "rev", "period", "lyapunov",
                                   "lyapunov_uncertainty", "status", "message"])
    else:
        df = _sorted(pd.concat(frames, ignore_index=True))
    df.attrs["provenance"] = prov
    return df


def _sorted(df: pd.DataFrame) -> pd.DataFrame:
    if df.empty:
        return df
    dkey = df["direction"].map({"up": 0, "down": 1}).to_numpy()
    ikey = np.where(dkey == 0, df["index"].to_numpy(), -df["index"].to_numpy())
    order = np.lexsort((df["rev"].to_numpy(), ikey, dkey))
    return df.iloc[order].reset_index(drop=True)


# ---------------------------------------------------------------------------------------------------
# the sweep


def parse_values(text: str, name: str = "--values") -> list[float]:
    """``"100:500:9"`` -> 9 values from 100 to 500 (linspace, ends included); ``"1,2,5"`` -> a list.
    A value given twice (``300:300:3``, ``1,1``) -> InputError naming ``name``."""
    text = str(text).strip()
    try:
        if ":" in text:
            parts = text.split(":")
            if len(parts) != 3:
                raise ValueError
            a, b, n = float(parts[0]), float(parts[1]), int(parts[2])
            if n < 1 or not (math.isfinite(a) and math.isfinite(b)):
                raise ValueError
            vals = [float(v) for v in np.linspace(a, b, n)]
        else:
            vals = [float(v) for v in text.split(",") if v.strip()]
            if not vals or not all(math.isfinite(v) for v in vals):
                raise ValueError
    except ValueError:
        raise InputError(f"{name} = {text!r}: give START:STOP:NUM (e.g. 100:500:9) or a "
                         "comma-separated list of finite numbers") from None
    if len(set(vals)) < len(vals):
        twice = next(v for v in vals if vals.count(v) > 1)
        hint = ("START = STOP gives NUM identical values: give NUM = 1 or another STOP"
                if ":" in text else "give each value once")
        raise InputError(f"{name} = {text!r}: the value {twice:g} appears {vals.count(twice)} "
                         f"times (the same point computed again); {hint}")
    return vals


def plain_value(v):
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, bool) or not isinstance(v, (int, float, str)):
        raise InputError(f"values: {v!r} is not a number or a string")
    return float(v) if isinstance(v, int) else v


def sweep(scene, param: str, values, *, transient_revs: int = BIFURCATION_SPANS.transient_revs,
          revs: int = BIFURCATION_SPANS.revs,
          observables=None, rtol: float = SECTIONS.rtol, continuation: bool = False, up_down: bool = False,
          workers: int | None = None, dask=None, out=None, resume: bool = False,
          lyapunov: bool = False, overrides=None, max_steps: int = SECTIONS.max_steps,
          period_tol: float = 1e-6, n_max: int = 16, lyapunov_revs: int | None = None,
          lyapunov_rtol: float | None = None, batch_size: int | None = None,
          progress=None, on_point=None, lyapunov_estimator: str = "tangent") -> pd.DataFrame:
    """Bifurcation sweep of ``param`` over ``values`` (see the module docstring).

    scene: Scene, built-in name or TOML path; overrides: base ``--set`` values applied first.
    param: any ``--set`` key (``driver.speed``, ``joints.B.clearance``, ...); values: numbers
    (or strings, for a key that takes a string).
    transient_revs, revs, observables, rtol, max_steps: as :func:`nld.analysis.poincare.stroboscopic`.
    period_tol, n_max: as :func:`nld.analysis.poincare.period_of`.
    continuation / up_down: see the module docstring.
    workers: local worker processes (default: the CPU count, at most one per point; 1 runs in
    this process); dask: a ``distributed.Client`` or a scheduler address ("tcp://host:8786")
    instead of the local pool. batch_size: points per task (default ceil(points/(4 workers))).
    out: output directory (one parquet per point + provenance.json); resume: skip the points
    whose file exists. lyapunov: also the largest exponent over ``lyapunov_revs`` (default revs)
    revolutions from the end of the section (rtol ``lyapunov_rtol``, default the lyapunov
    module's 1e-10) by ``lyapunov_estimator``: "tangent" (default,
    ``nld.analysis.lyapunov.lyapunov_tangent``, saltation at every contact event) or "benettin"
    (``nld.analysis.lyapunov.lyapunov_benettin``, two trajectories), skipped with a note in ``message`` when
    nld.analysis.lyapunov is not available. progress: a progress bar in points on stderr (None: when
    stderr is a terminal, True, False; see nld.progress); a callable is taken as ``on_point``.
    on_point: optional callable(done, total, record) called as each point finishes.

    Ctrl-C (KeyboardInterrupt): the points in progress are abandoned (the worker processes are
    ended), the finished ones are already in ``out``; :class:`nld.errors.Interrupted` is raised
    with ``kept`` saying how many, and ``resume=True`` continues.

    Returns the table of all points (also the resumed ones), as :func:`load_sweep`.
    """
    from nld.version import __version__
    from nld.output.provenance import git_hash
    from nld.model.scene import NO_VALUE, scene_to_dict, scene_value
    from nld.analysis.poincare import check_count, load_scene_arg
    from nld.progress import split_progress
    from nld.sweeps.engine import Tracker, run_points
    bar_on, on_point = split_progress(progress, on_point)
    sc = load_scene_arg(scene, overrides)
    raw = scene_to_dict(sc)
    if not isinstance(param, str) or scene_value(raw, param) is NO_VALUE:
        raise InputError(f"param = {param!r}: not a value of scene {sc.name!r} (a --set key such as "
                         "driver.speed or joints.B.clearance)")
    if isinstance(values, (str, bytes)) or not isinstance(values, Iterable):
        from nld.errors import InputTypeError
        raise InputTypeError(f"values = {values!r}: must be a list or array of values (parse_values "
                             "reads 'START:STOP:NUM')")
    check_rtol(rtol, "rtol")
    values = [plain_value(v) for v in (values.tolist() if isinstance(values, np.ndarray) else values)]
    if not values:
        raise InputError("values: give at least one")
    transient_revs = check_count("transient_revs", transient_revs, 0)
    revs = check_count("revs", revs, 1)
    if isinstance(observables, str):
        observables = [o.strip() for o in observables.split(",") if o.strip()]
    lyapunov_revs = revs if lyapunov_revs is None else check_count("lyapunov_revs", lyapunov_revs, 2)
    from nld.analysis.lyapunov import ESTIMATORS
    if lyapunov_estimator not in ESTIMATORS:
        raise InputError(f"lyapunov_estimator = {lyapunov_estimator!r}: must be one of "
                         f"{', '.join(ESTIMATORS)}")
    spec = PointSpec(raw=raw, source=sc.source, param=param, transient_revs=transient_revs, revs=revs,
                 observables=list(observables) if observables is not None else None,
                 rtol=float(rtol), max_steps=int(max_steps), period_tol=float(period_tol),
                 n_max=int(min(n_max, max(1, revs // 2))), lyapunov=bool(lyapunov),
                 lyapunov_revs=int(lyapunov_revs),
                 lyapunov_rtol=None if lyapunov_rtol is None else float(lyapunov_rtol),
                 cache_dir=os.environ.get("NLD_CACHE_DIR"),
                 lyapunov_estimator=lyapunov_estimator)
    settings = dict(scene=sc.name, scene_parameters=raw, param=param, values=values,
                    transient_revs=transient_revs, revs=revs, observables=spec.observables,
                    rtol=spec.rtol, continuation=bool(continuation), up_down=bool(up_down),
                    max_steps=spec.max_steps, period_tol=spec.period_tol, n_max=spec.n_max,
                    lyapunov=spec.lyapunov, lyapunov_revs=spec.lyapunov_revs,
                    lyapunov_rtol=spec.lyapunov_rtol,
                    lyapunov_estimator=lyapunov_estimator if spec.lyapunov else None)
    prov = dict(nld_version=__version__, git_hash=git_hash(), kind="bifurcation",
                integrator="dopri5", **settings)
    store = None
    done = {}
    if out is not None:
        store = ResultStore(out)
        store.prepare(prov, RESUME_SETTINGS, resume=resume)
        if resume:
            done = store.finished()
    elif resume:
        raise InputError("resume=True needs out (the directory of the interrupted sweep)")
    dirs = ["up", "down"] if up_down else ["up"]
    order = {"up": list(range(len(values))), "down": list(range(len(values)))[::-1]}
    points = [(d, i, values[i]) for d in dirs for i in order[d]]
    todo = [pt for pt in points if (pt[0], pt[1]) not in done]
    start = time.perf_counter()
    run = dict(store=store, desc=f"bifurcation {param}", unit="point", progress=bar_on,
               on_point=on_point)
    if continuation:
        with Tracker(len(points), done=done, **run) as track:
            _run_chain(spec, points, done, store, track.finished)
        results = track.results
    else:
        results = run_points(_run_point, spec, todo, done=done, total=len(points), workers=workers,
                             dask=dask, batch_size=batch_size,
                             warm=(warm_up, (spec, todo[0][2])) if todo else None, **run)
    frames = [results[(d, i)]["table"] for d, i, _ in points if (d, i) in results]
    df = _sorted(pd.concat(frames, ignore_index=True)) if frames else pd.DataFrame()
    prov["wall"] = time.perf_counter() - start
    df.attrs["provenance"] = prov
    return df


def _run_chain(spec, points, done, store, finished):
    """Continuation: sequential, each point from the previous point's final state."""
    y = z = None
    for d, i, v in points:
        if (d, i) in done:
            rec = done[(d, i)]
        else:
            rec = _run_point(spec, d, i, v, y, z)
            if store is not None:
                store.write(rec)
            finished(rec)
        if rec.get("status") == "ok" and rec.get("y_final") is not None:
            y, z = np.array(rec["y_final"], dtype=float), np.array(rec["z_final"], dtype=float)
        else:
            y = z = None




def check_values(scene, overrides, keys, values, option: str) -> None:
    """InputError naming ``option`` when the scene refuses one of ``values`` for ``keys`` (the
    command line refuses a sweep whose points would fail the scene check; the API records such a
    point as 'failed' and goes on)."""
    from nld.errors import SceneError
    from nld.analysis.poincare import load_scene_arg
    from nld.model.scene import NO_VALUE, apply_overrides, scene_from_dict, scene_to_dict, scene_value
    sc = load_scene_arg(scene, overrides)
    raw0 = scene_to_dict(sc)
    for key in keys:
        if scene_value(raw0, key) is NO_VALUE:
            return              # the sweep itself names the bad key
    for v in values:
        raw = copy.deepcopy(raw0)
        try:
            for key in keys:
                apply_overrides(raw, {key: v})
            scene_from_dict(raw, sc.source)
        except (SceneError, InputError) as e:
            raise InputError(f"{option}: the value {v!r} is refused by the scene: {e}") from None
