"""The scaffold of a study (``studies/NAME.py``, run by ``nld study NAME [--quick]``).

A study module defines ``STEM`` (the file names of its outputs), ``TITLE``, the settings of each
mode (``FULL``, ``QUICK``, optionally ``SMOKE``: dicts), optionally ``MODE_LABELS`` (``{mode:
label}``, a label may name settings as ``{rtol:g}``), ``CITATION``, and a
``main(quick=False, out_dir=Path("reports")) -> Path`` that does little more than::

    def main(quick: bool = False, out_dir: Path = Path("reports")) -> Path:
        study = Study(globals(), quick, out_dir)         # mode, settings, out_dir, start time
        st = study.settings
        result = compute(st, workers=study.workers(st["workers"]))     # the study's own work
        study.provenance(scene=base, integrator="dopri5", rtol=st["rtol"], source=CITATION,
                         settings=st, compute_wall_s=study.elapsed())
        study.save(".parquet", {"case": result})               # data + provenance sidecar
        with study.report({"Mode": study.label, "rtol": st["rtol"]}, scene=base,
                          subject="...", keywords=["..."]) as rep:
            rep.text_page("What this report shows", ["..."])
        return study.pdf

What it gives (all of it written once here, so that studies do not repeat it):

* the mode (``full``, ``quick`` or ``smoke``), its settings (a copy of the module's dict) and its
  label (:attr:`Study.label`: "full mode", or ``MODE_LABELS[mode]`` formatted with the settings);
* the output directory (created) and the paths of the outputs (:meth:`Study.path`, :attr:`Study.pdf`);
* the provenance dict (:meth:`Study.provenance`: study, mode, nld version, git hash, the scene
  and its parameters, then the study's own keys) and the writing of tables with it
  (:meth:`Study.save`: parquet with a ``case`` column from a dict of frames, or CSV/parquet);
* the :class:`nld.output.report.Report` with the standard subtitle (red in quick and smoke mode),
  keywords (ending with the mode) and wall time counted from the start of the study
  (:meth:`Study.report`);
* the worker count (:meth:`Study.workers`: the default or NLD_WORKERS), progress lines
  (:meth:`Study.stage`), a work directory for resumable work (:meth:`Study.work_dir`) and a
  process-pool map that survives Ctrl-C (:meth:`Study.map`);
* the helpers several studies need: :func:`sde` (is SOURCE_DATE_EPOCH set: leave timings out),
  :func:`timing` / :func:`drop_timing` (a timing, or "not shown" under SOURCE_DATE_EPOCH),
  :func:`verdict` (chaotic / regular / uncertain from an exponent, its uncertainty and the
  section length) and :func:`checked_verdict` (a verdict holds only if a run at a tighter
  tolerance over a longer span gives the same): ``nld.analysis.verdict``'s, re-exported.

The numbers a study writes do not depend on the scaffold: it only names, places and labels them.
"""
from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import sys
import time

import numpy as np
from pathlib import Path
from types import SimpleNamespace

__all__ = ["Study", "pool_map", "work_dir", "sde", "timing", "drop_timing", "run_table", "verdict",
           "checked_verdict", "merge_checks", "NOT_SHOWN", "SHORT", "NOT_ESTABLISHED",
           "staged_outputs", "full_mode_outputs"]

NOT_SHOWN = "not shown (SOURCE_DATE_EPOCH)"
# the verdict rule is nld.analysis.verdict's (the only one): verdict(lam, unc, n_points,
# min_points, failed) and checked_verdict(main, check) are its functions under the names the
# studies use
from nld.analysis.verdict import (NOT_ESTABLISHED, SHORT, checked_verdict,  # noqa: E402
                                  exponent_verdict as verdict)
_SETTINGS = {"full": "FULL", "quick": "QUICK", "smoke": "SMOKE"}


def sde() -> bool:
    """True when SOURCE_DATE_EPOCH is set: a reproducible report, timings are left out."""
    from nld.output.report import source_date_epoch
    return source_date_epoch() is not None


def timing(text: str) -> str:
    """``text`` (a wall time), or "not shown (SOURCE_DATE_EPOCH)" for a reproducible report."""
    return NOT_SHOWN if sde() else text


def drop_timing(df, *columns):
    """``df`` without ``columns`` (wall times) when SOURCE_DATE_EPOCH is set, else ``df``."""
    return df.drop(columns=list(columns)) if sde() else df


def run_table(runs: dict, columns: dict):
    """The "Run statistics" table: a row per run of ``runs`` ({case: run record}) with its case,
    success, then ``columns`` ({label: key}: the record's ``key``, ``stats.KEY`` its integrator
    statistic) and its wall time [s] (left out under SOURCE_DATE_EPOCH)."""
    import pandas as pd
    rows = []
    for name, r in runs.items():
        st = r.get("stats", {})
        rows.append({"case": name, "success": bool(r["success"]),
                     **{label: st.get(key[6:]) if key.startswith("stats.") else r.get(key)
                        for label, key in columns.items()},
                     "wall time": round(r["wall_s"], 2)})
    return drop_timing(pd.DataFrame(rows), "wall time")


def merge_checks(pts, checked=None):
    """``pts`` (one row per sweep point: ``value``, ``verdict_main``) with the check's columns
    ``lambda_check``, ``lambda_check_unc``, ``verdict_check`` (blank where the point was not run
    again) and the final ``verdict`` (:func:`checked_verdict`: the same word and the two
    exponents per revolution within CHECK_FACTOR x their combined uncertainty; pts needs
    ``lambda_per_rev`` and ``lambda_unc_per_rev``). checked: the same kind of table for
    the points run again (``value``, ``lambda_per_rev``, ``lambda_unc_per_rev``, ``verdict_main``,
    ``status``), or None."""
    import numpy as np
    out = pts.copy()
    lam = np.full(len(out), np.nan)
    unc = np.full(len(out), np.nan)
    ver = [""] * len(out)
    if checked is not None and len(checked):
        by_value = {float(r["value"]): r for _, r in checked.iterrows()}
        for i, v in enumerate(out["value"].astype(float)):
            r = by_value.get(v)
            if r is not None:
                lam[i], unc[i] = r["lambda_per_rev"], r["lambda_unc_per_rev"]
                ver[i] = r["verdict_main"] if r["status"] == "ok" else "failed"
    out["lambda_check"] = lam
    out["lambda_check_unc"] = unc
    out["verdict_check"] = ver
    out["verdict"] = [checked_verdict(m, c or None, lam=lm, unc=um, lam_check=lc, unc_check=uc)
                      for m, c, lm, um, lc, uc in zip(out["verdict_main"], ver, out["lambda_per_rev"],
                                                      out["lambda_unc_per_rev"], lam, unc)]
    return out


def work_dir(out_dir, stem: str, mode: str, name: str) -> Path:
    """Where the work ``name`` of a study keeps its finished parts, so that an interrupted study
    run again resumes: ``out_dir/.work/STEM-MODE-NAME-GIT``, tied to the git commit (parts
    computed by other code are not reused)."""
    from nld.output.provenance import git_hash
    return Path(out_dir) / ".work" / f"{stem}-{mode}-{name}-{git_hash()[:12]}"


def pool_map(fn, items, workers: int) -> list:
    """``[fn(*item) for item in items]``, on ``workers`` spawned processes when > 1 and there
    is more than one item; results in the order of ``items``.

    The pool is the sweeps' (nld.sweeps.executors.process_pool, one item per task): workers
    ignore SIGINT (it reaches the whole process group) and show no progress bars; on Ctrl-C,
    SIGTERM or an error the pool is ended at once (nld.interrupt.end_pool) instead of waiting
    for items that may take minutes. ``fn`` is a module-level function of the study: a worker
    imports the study from its folder by its file name (which the processes inherit on
    sys.path)."""
    items = list(items)
    if workers <= 1 or len(items) <= 1:
        return [fn(*it) for it in items]
    from nld.sweeps.executors import process_pool
    fn = _importable(fn)
    done = dict(process_pool(_numbered, fn, [(i, *it) for i, it in enumerate(items)],
                             workers=min(workers, len(items)), batch_size=1))
    return [done[i] for i in range(len(items))]


def _importable(fn):
    """A study's module-level function as a spawned process imports it: from the study's module
    by its file name (the folder put on sys.path, which the processes inherit)."""
    import importlib
    src = Path(fn.__code__.co_filename).resolve()
    if str(src.parent) not in sys.path:
        sys.path.insert(0, str(src.parent))
    return getattr(importlib.import_module(src.stem), fn.__name__)


def background(fn, *args, enabled: bool = True):
    """``fn(*args)`` (a module-level function of the study) on a process of its own while the
    study goes on (nld.sweeps.executors.Background; use it as a context manager, so that an
    interrupted study ends it); ``enabled`` False: run now in this process (one worker) and hold
    the value. Either way ``.result()`` gives it."""
    from nld.sweeps.executors import Background
    return Background(_importable(fn), *args) if enabled else _Done(fn(*args))


class _Done:
    """:func:`background`'s value computed at once (``enabled`` False)."""

    def __init__(self, value):
        self.value = value

    def result(self):
        return self.value

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def _numbered(fn, i, *args):
    """(i, fn(*args)): a pool_map item with its place in the list (a pool returns them as they
    finish)."""
    return i, fn(*args)


# ---------------------------------------------------------------------------------------------------
# outputs replaced only by a whole study (nld study), and the full-mode outputs already there

_STAGING: list = []       # [(out_dir resolved, staging dir)] while nld study runs a study


def _staged(path: Path) -> Path:
    """Where a study output for ``path`` is written now: in the staging directory while
    :func:`staged_outputs` is active for its directory, else ``path`` itself."""
    if _STAGING:
        out, stage = _STAGING[-1]
        try:
            if Path(path).parent.resolve() == out:
                stage.mkdir(parents=True, exist_ok=True)
                return stage / Path(path).name
        except OSError:
            pass
    return Path(path)


@contextlib.contextmanager
def staged_outputs(out_dir, stem: str, command: str | None = None):
    """The outputs a study writes into ``out_dir`` (:meth:`Study.save`, :meth:`Study.report`)
    go to a hidden staging directory while the block runs, and replace those in ``out_dir`` only
    when the block ends normally: a study that fails or is interrupted leaves ``out_dir`` as it was
    (a committed report is never half replaced). What it had written is moved to
    ``out_dir/STEM.partial/`` (with ``partial.json`` saying so) instead; the handle's ``partial``
    is that directory (None when nothing was written)."""
    out = Path(out_dir).resolve()
    stage = out / f".staging-{stem}-{os.getpid()}"
    handle = SimpleNamespace(partial=None, stage=stage, files=[])
    _STAGING.append((out, stage))
    try:
        yield handle
    except BaseException as e:
        _STAGING.pop()
        handle.partial = _keep_partial(out, stage, stem, e, command)
        raise
    else:
        _STAGING.pop()
        files = sorted(stage.iterdir()) if stage.is_dir() else []
        for f in files:
            os.replace(f, out / f.name)
        handle.files = [out / f.name for f in files]
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _keep_partial(out: Path, stage: Path, stem: str, exc: BaseException, command) -> Path | None:
    files = sorted(stage.iterdir()) if stage.is_dir() else []
    if not files:
        return None
    dest = out / f"{stem}.partial"
    try:
        if dest.exists():
            shutil.rmtree(dest)
        os.replace(stage, dest)
        why = "interrupted" if isinstance(exc, KeyboardInterrupt) else \
            f"failed: {type(exc).__name__}: {' '.join(str(exc).split())}"
        (dest / "partial.json").write_text(json.dumps(
            {"partial": True, "study": stem, "reason": why, "command": command,
             "files": [f.name for f in files]}, indent=2) + "\n", encoding="utf-8")
    except OSError:
        return None
    return dest


_KEYWORDS = re.compile(rb"/Keywords\s*\((.*?)\)\s*/", re.S)


def full_mode_outputs(out_dir, stem: str) -> list[Path]:
    """The outputs of a full-mode run of study ``stem`` in ``out_dir``, recognised by their
    provenance wherever the directory is: a sidecar ``STEM*.json`` whose provenance says
    ``"study": STEM, "mode": "full"``, or a ``STEM.pdf`` whose keywords end with the mode "full"
    (nld.output.report.Report.metadata)."""
    d = Path(out_dir)
    if not d.is_dir():
        return []
    found = []
    for side in sorted(d.glob(f"{glob_escape(stem)}*.json")):
        try:
            prov = json.loads(side.read_text(encoding="utf-8"))
        except (OSError, ValueError, UnicodeDecodeError):
            continue
        if isinstance(prov, dict) and prov.get("study") == stem and prov.get("mode") == "full":
            found.append(side)
    pdf = d / f"{stem}.pdf"
    if pdf.is_file():
        try:
            with open(pdf, "rb") as f:
                data = f.read()
        except OSError:
            data = b""
        m = _KEYWORDS.search(data)
        if m:
            words = [w.strip() for w in m.group(1).split(b";")]
            if words and words[0] == b"nld" and words[-1] == b"full":
                found.append(pdf)
    return found


def glob_escape(text: str) -> str:
    return re.sub(r"([*?\[])", r"[\1]", text)


class Study:
    """One run of a study in one mode; see the module docstring.

    module: the study module, its name, or its ``globals()`` (a study loaded from its file by
    ``nld study`` or a test need not be in sys.modules: pass ``globals()``). quick, smoke: the mode
    (smoke, for tests, wins over quick). out_dir: where the outputs go (created).
    """

    def __init__(self, module, quick: bool = False, out_dir=Path("reports"), *, smoke: bool = False):
        if isinstance(module, str):
            module = sys.modules[module]
        elif isinstance(module, dict):
            module = SimpleNamespace(**module)
        self.module = module
        self.start = time.perf_counter()
        self.stem: str = self.module.STEM
        self.title: str = self.module.TITLE
        self.mode = "smoke" if smoke else "quick" if quick else "full"
        self.quick = self.mode != "full"
        self.settings = dict(getattr(self.module, _SETTINGS[self.mode]))
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.prov: dict = {}

    # ------------------------------------------------------------------ names and places
    @property
    def label(self) -> str:
        """The mode as said on the title page: "full mode", or MODE_LABELS[mode] with the settings."""
        labels = getattr(self.module, "MODE_LABELS", {})
        if self.mode == "full" or self.mode not in labels:
            return "full mode" if self.mode == "full" else f"{self.mode.upper()} MODE"
        return labels[self.mode].format(**self.settings)

    @property
    def pdf(self) -> Path:
        return self.path(".pdf")

    def path(self, suffix: str) -> Path:
        """``out_dir / (STEM + suffix)``, e.g. ``path("_summary.csv")``."""
        return self.out_dir / f"{self.stem}{suffix}"

    def work_dir(self, name: str) -> Path:
        """:func:`work_dir` of this study, mode and output directory."""
        return work_dir(self.out_dir, self.stem, self.mode, name)

    # ------------------------------------------------------------------ time, workers, progress
    def elapsed(self) -> float:
        """Seconds since the study started."""
        return time.perf_counter() - self.start

    @staticmethod
    def workers(default: int) -> int:
        """Worker processes: ``default`` or NLD_WORKERS (nld.output.report.study_workers)."""
        from nld.output.report import study_workers
        return study_workers(default)

    def stage(self, what: str, label: str | None = None) -> None:
        """A progress line "label: what" (nld.progress.stage; label defaults to STEM)."""
        from nld.progress import stage
        stage(label or self.stem, what)

    @staticmethod
    def map(fn, items, workers: int) -> list:
        """:func:`pool_map`: ``[fn(*item) for item in items]`` on ``workers`` processes."""
        return pool_map(fn, items, workers)

    # ------------------------------------------------------------------ provenance and data
    def provenance(self, scene=None, **extra) -> dict:
        """The provenance of every file the study writes (kept as :attr:`prov`): study, mode,
        nld_version, git_hash; with ``scene`` (a Scene) its name and every parameter
        (scene, scene_parameters), or only ``scene`` when it is a string; then ``extra`` in its
        order (integrator, rtol, source, settings, compute_wall_s, ...)."""
        from nld.output.provenance import git_hash
        from nld.version import __version__
        prov = {"study": self.stem, "mode": self.mode, "nld_version": __version__, "git_hash": git_hash()}
        if isinstance(scene, str):
            prov["scene"] = scene
        elif scene is not None:
            from nld.model.scene import scene_to_dict
            prov.update(scene=scene.name, scene_parameters=scene_to_dict(scene))
        prov.update(extra)
        self.prov = prov
        return prov

    def save(self, suffix: str, data) -> Path:
        """Write ``data`` to ``path(suffix)`` with the provenance: a ``{case: DataFrame}`` dict is
        stacked with a leading ``case`` column (nld.output.report.save_study_data), a DataFrame is
        written as it is (nld.output.io.save_table: .parquet or .csv, with a .json sidecar)."""
        from nld.output.report import save_study_data
        target = self.path(suffix)
        written = save_study_data(data, _staged(target), self.prov)
        return target.with_name(written.name)

    # ------------------------------------------------------------------ report
    def report(self, settings: dict, *, scene=None, subject: str | None = None, keywords=(),
               subtitle: str | None = "", **kw):
        """The study's Report (a context manager) at :attr:`pdf`: TITLE, the provenance, the title
        page's ``settings``; subtitle "full mode" or the mode label (red outside full mode; pass
        ``subtitle`` to change it, None for none); keywords end with the mode unless they name it;
        the wall time counts from the start of ``nld study`` or of this Study, whichever is
        earlier. ``kw``: more arguments of Report."""
        from nld.output.report import Report, study_start
        keywords = list(keywords) + ([] if self.mode in keywords else [self.mode])
        return Report(_staged(self.pdf), self.title, scene=scene, provenance=self.prov, settings=settings,
                      subtitle=self.label if subtitle == "" else subtitle, highlight_subtitle=self.quick,
                      subject=subject, keywords=keywords,
                      started=min(self.start, study_start() or self.start), **kw)


# ---------------------------------------------------------------------------------------------------
# the route to chaos of a study's sweep: the workflow is nld.analysis.route's; here only its page


def route_page(rep, route: dict | None, sweep, pts, table, observable: str, *, label: str,
               symbol: str, scale: float = 1.0, unit: str = "", param_scale: float = 1.0,
               param_unit: str = "", logx: bool = False, agree=None) -> None:
    """The report page of one sweep's route to chaos (nld.analysis.route): ONE figure, the
    brute-force diagram (grey) with the continued branch over it (stable solid, unstable dashed,
    neutral dotted) and λ1 beneath on the same parameter axis, the transitions of ``table``
    (:func:`nld.analysis.route.route_table`) marked; the caption states the sequence in one
    sentence (:func:`nld.analysis.route.route_sentence`), how the branch was found and where it
    disagrees with the brute force (``agree``: :func:`nld.analysis.route.agreement`)."""
    from nld.analysis.route import route_figure, route_sentence
    sentence = route_sentence(table, symbol, scale=param_scale, unit=param_unit)
    with rep.style():
        fig, (ax, bx) = rep.subplots(2, 1, title=f"Route to chaos in the {label}", sharex=True,
                                     gridspec_kw={"height_ratios": [3, 1.4]})
        route_figure(ax, bx, route, sweep, pts, table, observable, label=label, scale=scale,
                     unit=unit, param_scale=param_scale, param_unit=param_unit, logx=logx)
    cap = [f"Route: {sentence}"]
    if route is not None and route.get("branch") is not None:
        st = route["settings"]
        cap.append(
            f"Branch: the period-1 orbit at {symbol} = {st['start'] * param_scale:.4g}"
            f"{' ' + param_unit if param_unit else ''} (Newton shooting on the stroboscopic map, "
            f"rtol {st['rtol']:g}) continued ({st['method']}) over the sweep's range, and "
            f"polished by Newton at each sweep value it spans (circles: filled stable, open "
            f"unstable or neutral). " + route["route"])
    elif route is not None:
        cap.append(f"Branch: {route['route']}")
    else:
        cap.append("No branch was continued in this sweep: the rows come from the brute force "
                   "alone (regime changes located between sweep points, ± half the spacing).")
    if route is not None and route.get("settings", {}).get("chaotic") is not None:
        from nld.analysis.route import orbit_class
        ups = route.get("upos") or []
        st = route["settings"]
        cap.append(f"Periodic orbits of periods 1..{st['max_period']} inside the chaotic range "
                   f"({symbol} = {st['chaotic'] * param_scale:.4g}): "
                   + (", ".join(f"period {o.period} {orbit_class(o)} (max |mu| "
                                f"{o.max_abs_multiplier:.3g})" for o in ups) if ups else
                      "none found" + (f" ({route['upos_error']})" if route.get("upos_error") else ""))
                   + " (the _route_orbits.csv table).")
    if agree is not None and len(agree):
        bad = agree[(agree["class"] != "unstable") & (~agree["agrees"])]
        cap.append("Agreement: every branch point called stable or neutral lies on the "
                   "brute-force section at its value (within the integration error)." if not len(bad)
                   else "Agreement: the brute-force section is not on the branch at "
                   + "; ".join(f"{v * param_scale:.4g} ({w})" for v, w in zip(bad["value"], bad["why"]))
                   + ".")
    cap.append("Grey: brute-force section points; lines dash-dot: transitions (green: of the "
               "branch or the regime, red: of λ1), shaded: their uncertainty. Beneath: λ1 per "
               "revolution ± its uncertainty (red: chaotic). Every row with its evidence is in "
               "the study's _route.csv.")
    rep.figure(fig, caption=" ".join(cap))


# ---------------------------------------------------------------- coexisting motions: the census
# workflow is nld.analysis.coexistence's (census_points, census_verdicts); here only its page


def census_page(rep, df, st: dict, what: str) -> None:
    """The report page "Coexisting motions" of a :func:`nld.analysis.coexistence.census_points`
    table ``df``: the census at every point whose verdict was not established, its attractors,
    basin fractions (Wilson 95 %), λ1 and onsets per revolution.
    what: the points' description for the text."""
    c = st["census"]
    if df is None or not len(df):
        rep.text_page("Coexisting motions (attractor census)", [
            f"No {what} had a verdict 'not established', so no census was run."])
        return
    show = df.drop(columns=["verdict_before", "starts"]).rename(columns={
        "census_verdict": "census", "fraction_lo": "lo", "fraction_hi": "hi",
        "lambda1_per_rev": "λ1/rev", "lambda1_unc_per_rev": "±", "onsets_per_rev": "onsets/rev",
        "onsets_per_orbit": "onsets/orbit", "max_abs_mu": "max|μ|"})
    rep.table("Coexisting motions (attractor census)", show, notes=[
        f"Where the verdict of a {what} was 'not established' (the exponent's verdict changed "
        f"with the tolerance and the averaging span), the attractor census "
        f"(nld.analysis.attractors, docs/attractors.md) says which motions coexist there: "
        f"{c['starts']} seeded starts (the assembled state with the journal placed across its "
        f"clearance circle, sampled rates and contact memories), {c['transient']} revolutions "
        f"of transient and {c['record']} recorded per start at rtol {c['rtol']:g}; each run "
        f"classed on its stroboscopic section; fraction = share of starts with its Wilson 95 % "
        f"interval [lo, hi]; λ1 per revolution (estimator tangent with saltation, rtol "
        f"{c['rtol']:g}, averaged over the {c['record']} recorded revolutions) on up to 2 runs "
        f"of the attractor (± their larger uncertainty + half their spread). 'permanent contact': no "
        f"contact onset under the Lankarani–Nikravesh law over the recorded span, so the motion "
        f"and its λ1 depend on the memory the last impact left (range in 'memory'); "
        f"'periodic': runs on a stable orbit found by Newton shooting from them "
        f"(nld.analysis.orbits.periodic_orbit): its multipliers (max|μ|), λ1 = ln max|μ| / p "
        f"and its whole number of contact onsets per orbit (p revolutions); "
        f"'unsettled': runs neither periodic nor resolved within the run. The census verdict "
        f"replaces 'not established': 'coexisting' where more than one motion was found."])
