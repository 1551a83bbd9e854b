"""Study: work-precision diagrams of every integrator on every built-in scene and three hard cases.

    nld study work_precision [--quick] [--out-dir DIR]

For each case (a built-in scene, or a scene with overrides) and each method of
``nld.simulate(method=...)`` (dopri5, dop853, rodas, scipy:RK45, scipy:DOP853, scipy:Radau,
scipy:LSODA) over a ladder of relative tolerances, the CPU time of the integration is set against
its error, measured against a reference computed by a DIFFERENT method at rtol 1e-12 (dop853,
or dopri5 for the two 8th-order Dormand-Prince methods; rodas where neither can run). The motion
is chaotic, so errors are only meaningful over short windows or as statistics:

* ``journal_err``: largest distance between the journal-centre offsets (ex, ey of every clearance
  joint) of run and reference over a *window* of the first ``window_revs`` crank revolutions, a
  couple of Lyapunov times (about 7 e-foldings per revolution on the slider-crank, README);
  ``journal_err_rel`` is that divided by the smallest clearance;
* ``pre_contact_err``: the same on the smooth part before the reference's first contact onset
  (free flight from the centred start; the integrator's own accuracy, no impact in between);
* ``peak_force_err``: relative error of the peak normal contact force on the window (largest over
  the clearance joints, sampled on the window's output grid);
* ``onset_err``: largest |t_run - t_ref| of the contact onsets on the window (events of the
  result, direction +1), each reference onset matched with the nearest run onset at the same
  joint; ``onset_err_rel`` = / crank period; ``n_onsets`` vs ``n_onsets_ref``;
* ``ecc_mean_diff``, ``ecc_std_diff``: difference of the mean and standard deviation of the
  eccentricity (|e| / c) at the stroboscopic Poincare points (once per crank revolution, after a
  transient) over a longer run of ``long_revs`` revolutions; ``ecc_se`` is the reference's
  standard error std/sqrt(N), the statistical floor of such a comparison.

The timed integration is the one ``simulate`` performs (the kernel module's ``solve`` or
``nld.integrators.solve_method`` with simulate's arguments: absolute tolerances
``nld.run.simulate.tolerances``, hmax = period/20, contact events on, the same event-log length),
without the per-row observation and the table that simulate builds afterwards (the same work for
every method); the study checks once per case that this gives simulate's answer. CPU time of the
process (``time.process_time``), minimum over repeats.

Recommendation per case: among all (method, rtol) that succeed, the one with the least CPU time
on the window whose journal error is <= ``REC_JOURNAL`` x the smallest clearance, peak-force
error <= ``REC_FORCE`` and onset-time error <= ``REC_ONSET`` x the period (when the window has
onsets). Output in ``out_dir``: ``work_precision.pdf``, ``work_precision.parquet`` (one row per
run, provenance in the metadata and the .json sidecar) and
``work_precision_recommended.parquet`` (the recommendation table as printed).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pandas as pd

STEM = "work_precision"
TITLE = "Work-precision of the integrators on clearance mechanisms, with recommended settings"

ALL_METHODS = ("dopri5", "dop853", "rodas", "scipy:RK45", "scipy:DOP853", "scipy:Radau", "scipy:LSODA")
FAMILY = {"dopri5": "dp5", "scipy:RK45": "dp5", "dop853": "dp8", "scipy:DOP853": "dp8",
          "rodas": "rodas", "scipy:Radau": "radau", "scipy:LSODA": "lsoda"}
REF_RTOL = 1e-12
REF_CANDIDATES = ("dop853", "dopri5", "rodas")

EXCEPTION = -99           # status of a run whose integrator raised (see Setup.solve)
REC_JOURNAL = 1e-2        # x smallest clearance
REC_FORCE = 1e-2          # relative error of the peak contact force
REC_ONSET = 1e-3          # x crank period

# case -> settings. window_revs: error window; long_revs: stroboscopic run (0: none);
# transient_revs: Poincare points before this are dropped.
CASES = {
    "slider_crank": dict(scene="slider_crank", overrides=(), window_revs=0.25, long_revs=40,
                         label="slider_crank: Flores, 0.5 mm at rod-slider, 5000 rpm, LN "
                               "(also the hard case '0.5 mm at 5000 rpm')"),
    "slider_crank_crankpin": dict(scene="slider_crank_crankpin", overrides=(), window_revs=0.25,
                                  long_revs=40, label="slider_crank_crankpin: 0.5 mm at crank-rod"),
    "slider_crank_two": dict(scene="slider_crank_two", overrides=(), window_revs=0.25, long_revs=40,
                             label="slider_crank_two: 0.5 mm at crank-rod and rod-slider"),
    "slider_crank_olyaei": dict(scene="slider_crank_olyaei", overrides=(), window_revs=0.25,
                                long_revs=40, label="slider_crank_olyaei: LN + Ambrosio friction mu 0.1"),
    "four_bar": dict(scene="four_bar", overrides=(), window_revs=0.25, long_revs=15,
                     label="four_bar: 0.25 mm at coupler-rocker, 300 rpm"),
    "excavator": dict(scene="excavator", overrides=(), window_revs=0.01, long_revs=0,
                      label="excavator: seed paper, clearances A and B, Coulomb friction, 15.6 rad/s"),
    "stiff_K9.59e11_c0.01mm": dict(
        scene="slider_crank", overrides=("joints.B.contact.stiffness=9.59e11", "joints.B.clearance=1e-5"),
        window_revs=0.1, long_revs=15,
        label="hard: slider_crank with K = 9.59e11 N/m^1.5 at 0.01 mm clearance"),
    "10000rpm": dict(scene="slider_crank", overrides=("driver.speed=1047.1975511965977",),
                     window_revs=0.25, long_revs=40, label="hard: slider_crank at 10 000 rpm"),
}

FULL = dict(cases=tuple(CASES), methods=ALL_METHODS,
            ladder=(1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10),
            window_points=2000, transient_revs=5, repeats=5, repeat_budget=0.3,
            cap_window_s=3.0, cap_long_s=4.0, max_steps=20_000_000)
QUICK = dict(cases=("slider_crank",), methods=("dopri5", "scipy:LSODA"),
             ladder=(1e-5, 1e-7, 1e-9), window_points=500, transient_revs=2, repeats=1,
             repeat_budget=0.0, cap_window_s=2.0, cap_long_s=2.0, max_steps=5_000_000,
             long_revs=10)

COLORS = {"dopri5": "tab:blue", "dop853": "tab:orange", "rodas": "tab:green", "scipy:RK45": "tab:purple",
          "scipy:DOP853": "tab:brown", "scipy:Radau": "tab:pink", "scipy:LSODA": "tab:gray"}
MARKERS = {"dopri5": "o", "dop853": "s", "rodas": "D", "scipy:RK45": "^", "scipy:DOP853": "v",
           "scipy:Radau": "<", "scipy:LSODA": ">"}


# ------------------------------------------------------------------------------ integration


class Setup:
    """A case compiled: scene, kernel, initial state, tolerance scales, grids."""

    def __init__(self, name: str, spec: dict, settings: dict):
        from nld.kernel.compile import compile_scene
        from nld.model.scene import load_scene
        from nld.run.simulate import crank_period, initial_state
        self.name, self.spec = name, spec
        self.scene = load_scene(spec["scene"], list(spec["overrides"]) or None)
        self.kern = compile_scene(self.scene)
        self.p = self.kern.params(self.scene)
        self.y0, self.z0, self.q = initial_state(self.kern)
        self.period = crank_period(self.scene)
        self.clearances = {j: self.scene.joints[j].clearance for j in self.kern.topo.clearance}
        self.cmin = min(self.clearances.values())
        self.t_window = spec["window_revs"] * self.period
        self.t_win_eval = np.linspace(0.0, self.t_window, settings["window_points"] + 1)
        long_revs = settings.get("long_revs", spec["long_revs"]) if spec["long_revs"] else 0
        self.long_revs = int(long_revs)
        self.t_long_eval = self.period * np.arange(self.long_revs + 1, dtype=float)
        self.transient = min(settings["transient_revs"], max(0, self.long_revs - 2))

    def solve(self, method: str, rtol: float, t_eval, max_steps: int):
        """simulate()'s integration call with simulate()'s arguments; returns the raw tuple.
        An exception raised inside the integrator (scipy's Radau on a NaN Jacobian) is returned as a
        failed run: status EXCEPTION, no output rows, the message in ``self.last_exception``."""
        try:
            return self._solve(method, rtol, t_eval, max_steps)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            self.last_exception = f"{method} rtol {rtol:g}: {type(exc).__name__}: {exc}"
            n = len(self.y0)
            e = np.empty(0)
            return (EXCEPTION, 0.0, np.full((len(t_eval), n), np.nan), 0, np.array([0, 0, 0, 0, 0]), e,
                    np.empty(0, np.int64), e, 0, np.zeros((len(t_eval), max(1, len(self.z0)))))

    def _solve(self, method: str, rtol: float, t_eval, max_steps: int):
        from nld.integrators import solve_method
        from nld.run.simulate import tolerances
        # the tolerance vector once per rtol, outside the timed call's repeats (~30 us of Python
        # walking the geometry; numbalsoda's state scales are likewise computed once)
        cache = self.__dict__.setdefault("_atol", {})
        if rtol not in cache:
            cache[rtol] = tolerances(self.kern, self.q, rtol)
        atol = cache[rtol]
        t_end = float(t_eval[-1])
        n_revs = t_end / self.period
        max_log = int(min(1_000_000, 1000 + 400 * n_revs))
        z = np.array(self.z0, dtype=float)
        y0 = np.ascontiguousarray(self.y0, dtype=float)
        return solve_method(self.kern, method, 0.0, y0, t_eval, False, self.p, z, float(rtol), atol,
                            0.0, float(self.period / 20.0), int(max_steps), int(self.kern.n_events),
                            max_log)

    def observe(self, t_eval, out) -> pd.DataFrame:
        status, t_reached, Y, n_out, st, ev_t, ev_k, ev_dir, n_logged, Z = out
        rows = np.empty((n_out, len(self.kern.columns)))
        self.kern.module.observe_all(t_eval, Y, Z, n_out, self.p, rows)
        tab = pd.DataFrame(rows, columns=self.kern.columns)
        tab.insert(0, "t", t_eval[:n_out])
        return tab

    def events(self, out) -> pd.DataFrame:
        status, t_reached, Y, n_out, st, ev_t, ev_k, ev_dir, n_logged, Z = out
        names = self.kern.z_layout.event_names      # contacts, loads, stick/slip and clamp events
        nl = min(int(n_logged), len(ev_t))
        return pd.DataFrame({"t": ev_t[:nl], "joint": [names[k] for k in ev_k[:nl]],
                             "direction": ev_dir[:nl]})


def _timed(fn, repeats: int, budget: float):
    """(result of the first call, min CPU time over up to ``repeats`` calls while the total < budget)."""
    c0 = time.process_time()
    out = fn()
    best = time.process_time() - c0
    total = best
    k = 1
    while k < repeats and total < budget:
        c0 = time.process_time()
        fn()
        dt = time.process_time() - c0
        best, total, k = min(best, dt), total + dt, k + 1
    return out, best


# ---------------------------------------------------------------------------------- measures


def window_measures(setup: Setup, tab: pd.DataFrame, ev: pd.DataFrame, ref_tab: pd.DataFrame,
                    ref_ev: pd.DataFrame) -> dict:
    """Error measures of a window run (``tab``) against the reference window run."""
    n = min(len(tab), len(ref_tab))
    out = dict(journal_err=np.nan, journal_err_rel=np.nan, pre_contact_err=np.nan, peak_force_err=np.nan,
               onset_err=np.nan, onset_err_rel=np.nan, n_onsets=np.nan, n_onsets_ref=np.nan)
    if n < len(ref_tab):           # the run stopped early: no window error
        return out
    d = np.zeros(n)
    for j in setup.clearances:
        d = np.maximum(d, np.hypot(tab[f"{j}.ex"].to_numpy()[:n] - ref_tab[f"{j}.ex"].to_numpy()[:n],
                                   tab[f"{j}.ey"].to_numpy()[:n] - ref_tab[f"{j}.ey"].to_numpy()[:n]))
    out["journal_err"] = float(np.max(d))
    out["journal_err_rel"] = out["journal_err"] / setup.cmin
    # contact onsets only (not load switches, stick/slip or hertz_damped clamp events)
    ron = ref_ev[(ref_ev.direction > 0) & (ref_ev.t <= setup.t_window) & ref_ev.joint.isin(list(setup.clearances))]
    t_first = float(ron.t.min()) if len(ron) else setup.t_window
    pre = ref_tab["t"].to_numpy()[:n] < t_first
    if pre.sum() >= 3:
        out["pre_contact_err"] = float(np.max(d[pre]))
    errs = []
    for j in setup.clearances:
        fr = float(np.max(ref_tab[f"{j}.Fn"].to_numpy()))
        if fr > 0:
            errs.append(abs(float(np.max(tab[f"{j}.Fn"].to_numpy())) - fr) / fr)
    if errs:
        out["peak_force_err"] = max(errs)
    on = ev[(ev.direction > 0) & (ev.t <= setup.t_window) & ev.joint.isin(list(setup.clearances))]
    out["n_onsets"], out["n_onsets_ref"] = float(len(on)), float(len(ron))
    if len(ron):
        worst = 0.0
        for j, tr in zip(ron.joint, ron.t):
            tj = on.t[on.joint == j].to_numpy()
            worst = max(worst, float(np.min(np.abs(tj - tr))) if tj.size else math.inf)
        out["onset_err"] = worst if math.isfinite(worst) else np.nan
        out["onset_err_rel"] = out["onset_err"] / setup.period
    return out


MEASURES = ("journal_err", "journal_err_rel", "pre_contact_err", "peak_force_err", "onset_err", "onset_err_rel",
            "n_onsets", "n_onsets_ref", "ecc_mean_diff", "ecc_std_diff", "ecc_se", "ecc_mean_ref")


def poincare_stats(setup: Setup, tab: pd.DataFrame) -> dict | None:
    """Mean and std of the eccentricity |e|/c at the stroboscopic points after the transient."""
    if len(tab) < setup.long_revs + 1:
        return None
    s = tab.iloc[setup.transient:]
    return {j: (float(np.mean(s[f"{j}.eccentricity"] / c)), float(np.std(s[f"{j}.eccentricity"] / c)),
                len(s)) for j, c in setup.clearances.items()}


def poincare_measures(st: dict | None, ref: dict | None) -> dict:
    out = dict(ecc_mean_diff=np.nan, ecc_std_diff=np.nan, ecc_se=np.nan, ecc_mean_ref=np.nan)
    if st is None or ref is None:
        return out
    out["ecc_mean_diff"] = max(abs(st[j][0] - ref[j][0]) for j in ref)
    out["ecc_std_diff"] = max(abs(st[j][1] - ref[j][1]) for j in ref)
    out["ecc_se"] = max(ref[j][1] / math.sqrt(ref[j][2]) for j in ref)
    out["ecc_mean_ref"] = max(ref[j][0] for j in ref)
    return out


def _status_ok(out) -> bool:
    return int(out[0]) >= 0


# ---------------------------------------------------------------------------------- the runs


def references(setup: Setup, settings: dict, log) -> dict:
    """Reference runs at REF_RTOL by each candidate method (window and long): {method: dict}."""
    refs = {}
    for m in REF_CANDIDATES:
        if len(refs) >= 2:
            break
        c0 = time.process_time()
        out = setup.solve(m, REF_RTOL, setup.t_win_eval, 50_000_000)
        if not _status_ok(out) or int(out[3]) < len(setup.t_win_eval):
            log(f"  reference {m} failed on the window: status {int(out[0])}")
            continue
        r = dict(tab=setup.observe(setup.t_win_eval, out), ev=setup.events(out), stats=None,
                 cpu=time.process_time() - c0)
        if setup.long_revs:
            outl = setup.solve(m, REF_RTOL, setup.t_long_eval, 200_000_000)
            r["stats"] = poincare_stats(setup, setup.observe(setup.t_long_eval, outl)) if _status_ok(outl) else None
        refs[m] = r
        log(f"  reference {m} rtol {REF_RTOL:g}: {r['cpu']:.2f} s CPU, {len(r['ev'])} events on the window")
    return refs


def pick_reference(method: str, refs: dict) -> str | None:
    for m in refs:
        if FAMILY[m] != FAMILY[method]:
            return m
    return None


def run_case(name: str, settings: dict, log=print) -> tuple[pd.DataFrame, dict]:
    """Every (method, rtol) of the case: DataFrame of runs, and case info."""
    from nld.run.simulate import simulate
    spec = CASES[name]
    setup = Setup(name, spec, settings)
    log(f"case {name}: period {setup.period * 1e3:.3f} ms, window {spec['window_revs']} rev, "
        f"long run {setup.long_revs} rev")
    refs = references(setup, settings, log)
    # the reference-to-reference difference: how well the error floor is known
    ref_names = list(refs)
    floor = {}
    if len(ref_names) == 2:
        a, b = refs[ref_names[0]], refs[ref_names[1]]
        floor = window_measures(setup, a["tab"], a["ev"], b["tab"], b["ev"])
        floor.update(poincare_measures(a["stats"], b["stats"]))
    # check once that the timed call is simulate()'s
    chk = simulate(setup.scene, t_eval=setup.t_win_eval, rtol=settings["ladder"][0], method="dopri5",
                   max_steps=settings["max_steps"])
    own = setup.observe(setup.t_win_eval, setup.solve("dopri5", settings["ladder"][0], setup.t_win_eval,
                                                      settings["max_steps"]))
    cols = [f"{j}.{c}" for j in setup.clearances for c in ("ex", "ey")]
    same = bool(np.array_equal(chk.table[cols].to_numpy(), own[cols].to_numpy()))
    rows = []
    for m in settings["methods"]:
        ref_m = pick_reference(m, refs)
        # warm-up: loads (or compiles) the method's integrator for this kernel
        setup.solve(m, settings["ladder"][0], setup.t_win_eval[:3], settings["max_steps"])
        skip_window = skip_long = False
        for rtol in settings["ladder"]:
            row = dict(method=m, rtol=rtol, reference=ref_m or "none", status=np.nan, cpu_s=np.nan,
                       revs_per_s=np.nan, steps=np.nan, rhs=np.nan, cpu_long_s=np.nan, long_status=np.nan,
                       note="", **dict.fromkeys(MEASURES, np.nan))
            if skip_window:
                row["note"] = f"skipped: a looser rtol took more than {settings['cap_window_s']:g} s"
                rows.append(row)
                continue
            out, cpu = _timed(lambda: setup.solve(m, rtol, setup.t_win_eval, settings["max_steps"]),
                              settings["repeats"], settings["repeat_budget"])
            row.update(status=int(out[0]), cpu_s=cpu, revs_per_s=spec["window_revs"] / cpu if cpu > 0 else np.nan,
                       steps=int(out[4][1]), rhs=int(out[4][3]))
            if cpu > settings["cap_window_s"]:
                skip_window = True
            if ref_m is not None:
                r = refs[ref_m]
                row.update(window_measures(setup, setup.observe(setup.t_win_eval, out), setup.events(out),
                                           r["tab"], r["ev"]))
            if int(out[0]) == EXCEPTION:
                row["note"] = "exception: " + setup.last_exception[:120]
                log("  " + row["note"])
            elif not _status_ok(out):
                row["note"] = "window run failed"
            # long run for the Poincare statistics, unless its cost is out of proportion
            if setup.long_revs and ref_m is not None:
                est = cpu * setup.long_revs / spec["window_revs"]
                if skip_long or est > settings["cap_long_s"]:
                    row["note"] = (row["note"] + "; " if row["note"] else "") + "long run skipped (cost)"
                else:
                    outl, cpul = _timed(lambda: setup.solve(m, rtol, setup.t_long_eval, settings["max_steps"]),
                                        1, 0.0)
                    row.update(cpu_long_s=cpul, long_status=int(outl[0]))
                    if cpul > settings["cap_long_s"]:
                        skip_long = True
                    st = poincare_stats(setup, setup.observe(setup.t_long_eval, outl)) if _status_ok(outl) else None
                    row.update(poincare_measures(st, refs[ref_m]["stats"]))
            rows.append(row)
            log(f"  {m:13s} rtol {rtol:.0e}: {cpu * 1e3:9.2f} ms, journal err/c "
                f"{row.get('journal_err_rel', np.nan):.2e}, status {row['status']}")
    df = pd.DataFrame(rows)
    info = dict(label=spec["label"], scene=spec["scene"], overrides=list(spec["overrides"]),
                period_s=setup.period, window_revs=spec["window_revs"], long_revs=setup.long_revs,
                transient_revs=setup.transient, clearance_min_m=setup.cmin,
                references={m: dict(cpu_s=r["cpu"], events=int(len(r["ev"]))) for m, r in refs.items()},
                reference_floor={k: (None if v != v else float(v)) for k, v in floor.items()},
                timed_call_equals_simulate=same)
    return df, info


def recommend(df: pd.DataFrame, info: dict) -> dict:
    """The cheapest (window CPU time) configuration that meets the criterion, or the most accurate."""
    ok = df[(df.status >= 0) & df.journal_err_rel.notna()]
    has_onsets = ok.n_onsets_ref.fillna(0) > 0
    meets = ok[(ok.journal_err_rel <= REC_JOURNAL)
               & (ok.peak_force_err.fillna(0.0) <= REC_FORCE)
               & (~has_onsets | (ok.onset_err_rel <= REC_ONSET))]
    if len(meets):
        best = meets.loc[meets.cpu_s.idxmin()]
        met = True
    elif len(ok):
        best = ok.loc[ok.journal_err_rel.idxmin()]
        met = False
    else:
        return dict(method="none", rtol=np.nan, met=False)
    natives = meets[meets.method.isin(("dopri5", "dop853", "rodas"))] if len(meets) else meets
    return dict(method=best.method, rtol=float(best.rtol), met=met, cpu_ms=1e3 * float(best.cpu_s),
                revs_per_s=float(best.revs_per_s), journal_err_rel=float(best.journal_err_rel),
                peak_force_err=float(best.peak_force_err), onset_err_rel=float(best.onset_err_rel),
                ecc_mean_diff=float(best.ecc_mean_diff),
                n_meeting=int(len(meets)), n_runs=int(len(df)),
                best_scipy=(meets[meets.method.str.startswith("scipy:")].sort_values("cpu_s").iloc[0].method
                            + f" {meets[meets.method.str.startswith('scipy:')].sort_values('cpu_s').iloc[0].rtol:.0e}"
                            if len(meets) and meets.method.str.startswith("scipy:").any() else "none"),
                best_scipy_ms=(1e3 * float(meets[meets.method.str.startswith("scipy:")].cpu_s.min())
                               if len(meets) and meets.method.str.startswith("scipy:").any() else np.nan),
                best_native=(natives.sort_values("cpu_s").iloc[0].method if len(natives) else "none"))


# ---------------------------------------------------------------------------------- figures

PANELS = (("journal_err_rel", "cpu_s", "max journal error / clearance (window)"),
          ("peak_force_err", "cpu_s", "relative error of peak contact force (window)"),
          ("onset_err_rel", "cpu_s", "contact-onset time error / period (window)"),
          ("ecc_mean_diff", "cpu_long_s", "|Δ mean eccentricity| at Poincaré points (long run)"))


def _fig_case(rep, name, df, info, rec):
    with rep.style():
        fig, axes = rep.subplots(2, 2, title=f"Work-precision: {name}")
        for ax, (col, tcol, lab) in zip(axes.flat, PANELS):
            placed = []          # (log x, log y) of the rtol labels: one label where curves start together
            for m in df.method.unique():
                d = df[(df.method == m) & df[col].notna() & df[tcol].notna()].sort_values("rtol", ascending=False)
                if not len(d):
                    continue
                y = np.maximum(d[col].to_numpy(float), 1e-16)
                ax.loglog(d[tcol] * 1e3, y, marker=MARKERS.get(m, "o"), color=COLORS.get(m), ms=4, label=m)
                at = (math.log10(max(float(d[tcol].iloc[0]) * 1e3, 1e-300)), math.log10(float(y[0])))
                # a label is about 20 x 8 pt: on these panels (4-5 decades over ~330 pt in x, up to
                # 14 over ~190 pt in y) 0.45 decade in x or 0.8 in y keeps two labels apart
                if not any(abs(at[0] - a) < 0.45 and abs(at[1] - b) < 0.8 for a, b in placed):
                    placed.append(at)
                    ax.annotate(f"{d.rtol.iloc[0]:.0e}", (d[tcol].iloc[0] * 1e3, y[0]), fontsize=6.5,
                                color=COLORS.get(m), xytext=(2, 2), textcoords="offset points")
            if col == "journal_err_rel":
                ax.axhline(REC_JOURNAL, color="k", ls=":", lw=0.8, label="criterion")
            if col == "peak_force_err":
                ax.axhline(REC_FORCE, color="k", ls=":", lw=0.8, label="criterion")
            if col == "onset_err_rel":
                ax.axhline(REC_ONSET, color="k", ls=":", lw=0.8, label="criterion")
            if col == "ecc_mean_diff" and df.ecc_se.notna().any():
                ax.axhline(float(df.ecc_se.dropna().iloc[0]), color="k", ls="--", lw=0.8,
                           label="standard error of the mean (ref.)")
            if rec.get("method") not in (None, "none") and tcol == "cpu_s":
                r = df[(df.method == rec["method"]) & (df.rtol == rec["rtol"])]
                if len(r) and r[col].notna().all():
                    ax.plot(r.cpu_s * 1e3, np.maximum(r[col], 1e-16), marker="*", ms=13, color="red",
                            ls="", label="recommended", zorder=5)
            ax.margins(0.15)        # room for the rtol labels inside the panel
            xl = "CPU time of the window run [ms]" if tcol == "cpu_s" else "CPU time of the long run [ms]"
            ax.set_xlabel(xl)
            ax.set_ylabel(lab)
            if not ax.has_data():
                ax.text(0.5, 0.5, "no data (no long run / no contact in the window)", transform=ax.transAxes,
                        ha="center", va="center")
            else:
                ax.legend(fontsize=6.5, loc="best")
    fl = info.get("reference_floor", {})
    rf = (f"reference-to-reference difference: journal {fl.get('journal_err_rel', float('nan')) or float('nan'):.1e} c, "
          f"peak force {fl.get('peak_force_err', float('nan')) or float('nan'):.1e}, onset "
          f"{fl.get('onset_err_rel', float('nan')) or float('nan'):.1e} T" if fl else "one reference only")
    rep.figure(fig, caption=(
        f"{info['label']}. Window: first {info['window_revs']:g} crank revolution(s) "
        f"(period {info['period_s'] * 1e3:.3f} ms); long run: {info['long_revs']} revolutions, Poincaré points "
        f"after {info['transient_revs']}. Each curve is one method over the rtol ladder (the loosest rtol is "
        f"labelled, once where curves start together); errors against a different method at rtol {REF_RTOL:g} ({', '.join(info['references'])}); "
        f"{rf}. Dotted: the recommendation criterion; red star: the recommended setting. Errors below 1e-16 "
        f"are drawn at 1e-16."))


# ---------------------------------------------------------------------------------- main


def _fmt(v, f="{:.2g}"):
    return "–" if v is None or v != v else f.format(v)


def main(quick: bool = False, out_dir: Path = Path("reports"), *, cases=None, log=print,
         cache_dir=None) -> Path:
    """Run the study; ``cases``: a subset of CASES; ``cache_dir``: keep each case's runs there (pickle,
    keyed by case and mode) and reuse them on the next call (for resuming a long full run)."""
    from nld.study import Study
    study = Study(globals(), quick, out_dir)
    settings = study.settings
    if cases is not None:
        settings["cases"] = tuple(cases)
    frames, infos, recs = run_cases(settings, study.mode, cache_dir, log)
    wall = study.elapsed()
    rec_df = recommendation_table(recs)
    # wall time on the title page: the runs (as computed, also when resumed from cache_dir) + the report
    study.provenance(
        scene=", ".join(sorted({CASES[c]["scene"] for c in settings["cases"]})),
        integrator=", ".join(settings["methods"]), reference_rtol=REF_RTOL,
        settings={k: (list(v) if isinstance(v, tuple) else v) for k, v in settings.items()},
        criterion=dict(journal_err_rel=REC_JOURNAL, peak_force_err=REC_FORCE, onset_err_rel=REC_ONSET),
        cases=infos, recommended={k: {kk: (vv if not isinstance(vv, float) or vv == vv else None)
                                      for kk, vv in v.items()} for k, v in recs.items()},
        wall_s=wall, runs_wall_s=sum(float(i.get("wall_s", 0.0)) for i in infos.values()))
    study.prov["pages"] = _report(study, frames, infos, recs, rec_df)
    study.save(".parquet", frames)
    study.save("_recommended.parquet", rec_df)
    log(f"wrote {study.pdf} ({wall:.1f} s of runs)")
    return study.pdf


def run_cases(settings: dict, mode: str, cache_dir, log):
    """({case: runs}, {case: info}, {case: recommendation}) of settings["cases"]; with ``cache_dir``
    each case's runs are kept there and read back on the next call."""
    import pickle
    frames, infos, recs = {}, {}, {}
    for name in settings["cases"]:
        cached = Path(cache_dir) / f"{STEM}_{mode}_{name}.pkl" if cache_dir else None
        if cached is not None and cached.is_file():
            df, info = pickle.loads(cached.read_bytes())
            log(f"case {name}: runs from {cached}")
        else:
            t_case = time.perf_counter()
            df, info = run_case(name, settings, log)
            info["wall_s"] = time.perf_counter() - t_case
            if cached is not None:
                cached.parent.mkdir(parents=True, exist_ok=True)
                cached.write_bytes(pickle.dumps((df, info)))
        frames[name], infos[name] = df, info
        recs[name] = recommend(df, info)
    return frames, infos, recs


def recommendation_table(recs: dict) -> pd.DataFrame:
    rec_rows = []
    for name, r in recs.items():
        rec_rows.append({"case": name, "method": r["method"], "rtol": r["rtol"],
                         "criterion met": r["met"], "CPU per window": r.get("cpu_ms", np.nan),
                         "rev/s": r.get("revs_per_s", np.nan),
                         "journal err / c": r.get("journal_err_rel", np.nan),
                         "peak-force err": r.get("peak_force_err", np.nan),
                         "onset err / T": r.get("onset_err_rel", np.nan),
                         "best scipy meeting it": r.get("best_scipy", "none"),
                         "its CPU": r.get("best_scipy_ms", np.nan)})
    return pd.DataFrame(rec_rows)


def _report(study, frames, infos, recs, rec_df) -> dict:
    """Write the PDF; returns the pages of each part."""
    settings, mode = study.settings, study.mode
    ladder = ", ".join(f"{r:.0e}" for r in settings["ladder"])
    pages = {}
    t_report = time.perf_counter()
    with study.report({"mode": mode, "cases": ", ".join(settings["cases"]),
                       "methods": ", ".join(settings["methods"]), "rtol ladder": ladder,
                       "reference": f"different method at rtol {REF_RTOL:g}"},
                      subtitle=study.label if study.quick else None, keywords=[mode, "work-precision"]) as rep:
        n0 = rep.page_count
        rep.text_page("What is measured", [
            "Work-precision diagrams: for each case and each integrator method of nld.simulate(method=...), "
            f"over the rtol ladder {ladder}, the CPU time of the integration against its error. The timed call is "
            "the one simulate() makes, with simulate()'s arguments (absolute tolerances scaled by the clearance, "
            "hmax = period/20, contact events on); the per-row observation and table building are not timed. "
            "CPU time of the process, minimum over repeats; compilation and loading are excluded (warm-up run).",
            f"Reference: a DIFFERENT method at rtol {REF_RTOL:g}: dop853 for every method except the 8th-order "
            "Dormand-Prince pair (dop853, scipy:DOP853), which is compared with dopri5 at the same rtol (rodas if "
            "one of them fails). The two references are compared with each other; that difference (in each "
            "figure's caption) is the floor below which errors are not resolved.",
            "The motion is chaotic (about 7 e-foldings per crank revolution on the slider-crank), so trajectory "
            "errors are measured only on a short window from the start, and the long run is compared by statistics:",
            "- journal error: the largest distance between the journal-centre offsets of run and reference over "
            "the window (all clearance joints), divided by the smallest clearance c;",
            "- peak contact force: relative error of the largest normal contact force on the window (output grid);",
            "- contact onsets: each reference onset on the window matched with the nearest onset of the run at the "
            "same joint; the largest time difference, divided by the crank period T;",
            "- Poincaré statistics: the eccentricity |e|/c at one stroboscopic point per crank revolution after a "
            "transient; the difference of its mean from the reference's, against the standard error of the mean "
            "(dashed line): differences at that level are sampling noise, not integration error;",
            "- smooth window (parquet column pre_contact_err): the journal error before the first contact onset.",
            f"Recommendation per case: the configuration with the least CPU time on the window whose journal error "
            f"is <= {REC_JOURNAL:g} c, peak-force error <= {REC_FORCE:g} and onset-time error <= {REC_ONSET:g} T "
            "(when the window has onsets). Any method qualifies; the table also names the cheapest scipy "
            "configuration meeting the same criterion. Runs slower than a cap skip the tighter rungs "
            "(noted in the data).",
        ])
        pages["text"] = rep.page_count - n0
        n0 = rep.page_count
        rep.table("Recommended method and tolerance per case", rec_df,
                  col_units={"CPU per window": "ms", "its CPU": "ms"},
                  float_format=lambda v: f"{v:.3g}",
                  notes=[f"Criterion: least CPU time with journal error <= {REC_JOURNAL:g} c, peak-force error "
                         f"<= {REC_FORCE:g}, onset error <= {REC_ONSET:g} T on the window. 'criterion met' False: "
                         "no run met it; the most accurate run is shown. rev/s = window revolutions per CPU "
                         "second of the integration. Window lengths and references per case: figure captions."])
        pages["recommendation"] = rep.page_count - n0
        n0 = rep.page_count
        for name in settings["cases"]:
            _fig_case(rep, name, frames[name], infos[name], recs[name])
        pages["figures"] = rep.page_count - n0
        n0 = rep.page_count
        allruns = pd.concat([frames[n].assign(case=n) for n in settings["cases"]], ignore_index=True)
        show = allruns[["case", "method", "rtol", "status", "cpu_s", "journal_err_rel", "pre_contact_err",
                        "peak_force_err", "onset_err_rel", "n_onsets", "n_onsets_ref", "ecc_mean_diff",
                        "ecc_se"]].copy()
        show["cpu_s"] = show["cpu_s"] * 1e3
        show = show.rename(columns={"cpu_s": "CPU", "journal_err_rel": "journal/c",
                                    "pre_contact_err": "pre-contact", "peak_force_err": "peak F",
                                    "onset_err_rel": "onset/T", "ecc_mean_diff": "Δmean ecc"})
        rep.table("All runs", show, col_units={"CPU": "ms", "pre-contact": "m"},
                  float_format=lambda v: f"{v:.3g}", rows_per_page=24,
                  notes=["status < 0: failed (no window errors). n_onsets: contact onsets on the window (run / "
                         "reference). ecc_se: standard error of the reference's mean eccentricity."])
        pages["runs_table"] = rep.page_count - n0
        rep.wall_time = study.prov["runs_wall_s"] + (time.perf_counter() - t_report)
    return pages


if __name__ == "__main__":
    import sys
    main(quick="--quick" in sys.argv)
