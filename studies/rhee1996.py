"""Study: Rhee & Akay (1996)-style four-bar with a coupler-rocker clearance (scene ``four_bar``).

    nld study rhee1996 [--quick] [--out-dir DIR]

Effect of the clearance size and of the friction coefficient on the regularity of the motion:

* six cases (three clearances at the scene's friction mu = 0.01; three friction coefficients at the
  scene's clearance 0.25 mm): stroboscopic Poincare sections of the journal eccentricity (B.ex, B.ey)
  (:func:`nld.analysis.poincare.stroboscopic`), the largest Lyapunov exponent from the end of the section
  (:func:`nld.analysis.lyapunov.lyapunov_tangent`, tangent dynamics with saltation at every contact event), a sampled run continued from there for the contact-force
  spectrum (:func:`nld.analysis.spectrum.table_spectrum`) and the force peaks;
* two bifurcation sweeps with the exponent at every point (:func:`nld.analysis.bifurcation.sweep`): in the
  clearance (mu = 0.01) and in the friction coefficient (c = 0.25 mm).

Outputs in ``out_dir``: ``rhee1996.pdf``; ``rhee1996.parquet`` (the sampled runs of the six cases,
``case`` first); ``rhee1996_sections.parquet`` (section points per case, with ``B.ex/c``, ``B.ey/c``:
the eccentricity over the case's clearance, as plotted); ``rhee1996_sweeps.parquet`` (both sweeps and
their checks, ``case`` = clearance, friction, clearance_check, friction_check first, as
``nld.analysis.bifurcation.load_sweep``, with ``B.ex/c``, ``B.ey/c``); ``rhee1996_spectra.parquet``;
``rhee1996_peaks.csv`` (the contact-force maximum of every revolution of each sampled run, located
from the dense output: :func:`nld.analysis.extrema.revolution_maxima`); ``rhee1996_summary.csv`` (the
per-case table printed in the report: Fn_rev_mean +- Fn_rev_ci95 is the mean of that case's
per-revolution maxima with its 95 % batch-means interval, :func:`nld.analysis.peaks.peak_interval`;
max_Fn the largest of them, a single extreme; rms_Fn and contact_fraction over that case's rows of
``rhee1996.parquet``; lambda that of the case's exponent).

A case or sweep point is called chaotic only when lambda - uncertainty > 0 over a section of at least
MIN_SECTION_POINTS points, and a verdict holds only if a run at ``rtol_check`` over ``check_span``
times the averaging span agrees (else 'not established'; the cases from the same state, the sweep
points not called regular again from the assembly); every exponent in the report states its estimator, tolerance, averaging
span and uncertainty from the result's own settings.
"""
from __future__ import annotations

import time
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

from nld.output.report import ec_limit
from nld.study import verdict as verdict_rule
from nld.analysis.verdict import CHAOTIC, COEXISTING, NOT_ESTABLISHED, PERMANENT_CONTACT, REGULAR, \
    SHORT, UNCERTAIN

SCENE = "four_bar"
STEM = "rhee1996"
TITLE = "Four-bar with a coupler-rocker clearance: clearance size and friction vs regularity (Rhee & Akay 1996 style)"
CITATION = ("Rhee J., Akay A. (1996), \"Dynamic response of a revolute joint with clearance\", "
            "Mechanism and Machine Theory 31(1):121-134")

FULL = dict(rtol=1e-8, transient_revs=100, section_revs=200, lyap_revs=200, spec_revs=20,
            samples_per_rev=720, peak_detect=20, sweep_transient=100, sweep_revs=100, sweep_lyap=100,
            clearances=[0.02e-3, 0.03e-3, 0.05e-3, 0.075e-3, 0.1e-3, 0.15e-3, 0.2e-3, 0.25e-3,
                        0.3e-3, 0.4e-3, 0.5e-3],
            frictions=[0.0, 0.005, 0.01, 0.02, 0.04, 0.06, 0.08, 0.1, 0.15, 0.2, 0.3],
            rtol_check=1e-10, check_span=2, workers=2,
            census=dict(starts=16, transient=100, record=100, rtol=1e-8, always=[]),
            route=dict(param="joints.B.friction.mu", start=0.1, chaotic=0.0, max_period=2,
                       transient=50, method="arclength", max_points=60,
                       values=[0.0, 0.005, 0.01, 0.02, 0.04, 0.06, 0.08, 0.1, 0.15, 0.2, 0.3]))
QUICK = dict(rtol=1e-7, transient_revs=10, section_revs=30, lyap_revs=20, spec_revs=4,
             samples_per_rev=360, peak_detect=20, sweep_transient=10, sweep_revs=12, sweep_lyap=12,
             clearances=[0.05e-3, 0.25e-3, 0.5e-3], frictions=[0.0, 0.1, 0.3],
             rtol_check=1e-8, check_span=1, workers=1,   # quick: the check over the same span (CI time)
             # quick mode runs the census at one case even where its verdict holds, so that the
             # path is exercised (the report says so)
             census=dict(starts=2, transient=10, record=16, rtol=1e-7, always=["mu=0.3"]),
             route=dict(param="joints.B.friction.mu", start=0.1, chaotic=None, max_period=0,
                        transient=10, values=[0.09, 0.1], rtol=1e-8, method="natural"))
# smoke (the test suite's default run; the quick mode is its -m slow variant): the quick mode's pages
# and checks on the sweeps' end points, with shorter spans
SMOKE = dict(QUICK, transient_revs=4, section_revs=10, lyap_revs=8, spec_revs=3, sweep_transient=4,
             sweep_revs=6, sweep_lyap=6, clearances=[0.05e-3, 0.5e-3], frictions=[0.0, 0.1, 0.3],
             census=dict(QUICK["census"], transient=4),
             route=dict(QUICK["route"], transient=5, rtol=1e-7))
MODE_LABELS = {"quick": "QUICK MODE: short transients and averages",
               "smoke": "SMOKE MODE (test only): the quick mode's pages on shorter spans"}

# name -> (group, overrides, clearance [m], mu)
CASES = {
    "c=0.05mm": ("clearance", ["joints.B.clearance=0.05e-3"], 0.05e-3, 0.01),
    "c=0.25mm": ("clearance", [], 0.25e-3, 0.01),
    "c=0.5mm": ("clearance", ["joints.B.clearance=0.5e-3"], 0.5e-3, 0.01),
    "mu=0": ("friction", ["joints.B.friction.mu=0.0"], 0.25e-3, 0.0),
    "mu=0.1": ("friction", ["joints.B.friction.mu=0.1"], 0.25e-3, 0.1),
    "mu=0.3": ("friction", ["joints.B.friction.mu=0.3"], 0.25e-3, 0.3),
}
COLORS = {"c=0.05mm": "tab:green", "c=0.25mm": "tab:blue", "c=0.5mm": "tab:purple",
          "mu=0": "tab:red", "mu=0.1": "tab:orange", "mu=0.3": "tab:brown"}
N_PEAKS = 3
PEAK_LEVEL = 0.95          # level of the per-revolution peak intervals (nld.analysis.peaks.peak_interval)
PERIOD_TOL = 1e-6          # section period: points repeat to PERIOD_TOL x clearance
# the route's agreement check: a branch orbit called stable lies on the brute-force section when the
# section's last points are within PERIOD_TOL_ROUTE x clearance of it (the sweep's transient of 100
# revolutions at rtol 1e-8 leaves the motion about that close to an orbit whose multipliers are 0.9)
PERIOD_TOL_ROUTE = 1e-3
# a verdict "chaotic" needs a positive exponent AND a section long enough to show it: with fewer
# points the section cannot tell an attractor from a transient, whatever the exponent says
MIN_SECTION_POINTS = 50
# e/c axes of the sections and bifurcation diagrams: +-1 = the journal touches the bearing
EC_LIM = 1.15


VERDICT_COLORS = {CHAOTIC: "tab:red", SHORT: "tab:orange", REGULAR: "tab:blue",
                  UNCERTAIN: "0.5", NOT_ESTABLISHED: "tab:olive", COEXISTING: "tab:pink",
                  PERMANENT_CONTACT: "tab:cyan"}
UNCERTAINTY_TEXT = ("uncertainty: block standard error of the local rates + spread of the running "
                    "estimate over its last half")


# the one verdict rule (nld.analysis.verdict) with this study's MIN_SECTION_POINTS:
# verdict(lam, unc, n_points) ('chaotic' needs that many section points)
verdict = partial(verdict_rule, min_points=MIN_SECTION_POINTS)


def check_text(st) -> str:
    """How a verdict is checked (report text)."""
    return (f"A verdict holds only if it survives a change of tolerance and of averaging span: every "
            f"case's exponent is computed again from the same state at rtol {st['rtol_check']:g} over "
            f"{st['check_span']}x the span, and every sweep point not called regular is run again from "
            f"the assembly at rtol {st['rtol_check']:g} with {st['check_span']}x the averaging span; "
            "where the two verdicts differ, or the two exponents by more than 3x their combined "
            "uncertainty, the point is 'not established' (nld.study.checked_verdict). "
            "A case's verdict must also agree with that of the sweep point of the same parameters (run "
            "from the assembly: another history of the same system).")


def estimator_line(settings: dict, period: float | None) -> str:
    """Estimator, tolerance, averaging span (from an exponent's own settings) and what the
    uncertainty is."""
    from nld.output.report import estimator_text
    st = {k: v for k, v in dict(settings or {}).items() if k != "scales"}
    return estimator_text(st, None, period) + "; " + UNCERTAINTY_TEXT


def sweep_estimator_settings(df: pd.DataFrame, period: float) -> dict:
    """The exponent settings of a sweep, from the sweep's own provenance (every point used them):
    estimator, rtol, and the averaging span (lyapunov_revs periods from the end of the section)."""
    prov = dict(df.attrs.get("provenance", {}) or {})
    out = {"method": prov.get("lyapunov_estimator") or "?", "transient": 0.0,
           "total": float(prov.get("lyapunov_revs", float("nan"))) * period}
    if prov.get("lyapunov_rtol") is not None:
        out["rtol"] = float(prov["lyapunov_rtol"])
    return out


# --------------------------------------------------------------------------------------- runs


def run_case(name, st):
    """Section, exponent and the continued sampled run of one case."""
    from nld.analysis.extrema import revolution_maxima
    from nld.analysis.lyapunov import lyapunov_tangent
    from nld.analysis.peaks import peak_interval
    from nld.analysis.poincare import period_of, stroboscopic
    from nld.analysis.spectrum import peaks, table_spectrum
    from nld.systems.core import SceneSystem
    _, ov, c, mu = CASES[name]
    t0 = time.perf_counter()
    sec = stroboscopic(SCENE, transient_revs=st["transient_revs"], revs=st["section_revs"],
                       observables=["B.ex", "B.ey", "rocker.omega"], overrides=ov, rtol=st["rtol"])
    # period relative to the clearance: a fixed point repeats to ~1e-7 c (the friction regularisation's
    # floor, docs/analysis.md), which the default scale (the points' own range) would call aperiodic
    per = period_of(sec.table[["B.ex", "B.ey"]], tol=PERIOD_TOL, scale=c) if sec.success else 0
    system = SceneSystem(SCENE, ov)
    system.y0 = np.array(sec.y_final, float)
    system.z0 = np.array(sec.z_final, float)
    lyap = lyapunov_tangent(system, transient=0.0, total=st["lyap_revs"] * sec.period, rtol=st["rtol"])
    # the same trajectory continued from the end of the section (t = 0 is a multiple of the period),
    # its contact-force maximum located in every revolution from the dense output
    # (nld.analysis.extrema, as zhang2013); every peak_detect-th detection sample is stored
    run = revolution_maxima(SCENE, ["B.Fn"], revs=st["spec_revs"], rtol=st["rtol"], overrides=ov,
                            samples_per_rev=st["samples_per_rev"] * st["peak_detect"],
                            keep_every=st["peak_detect"], absolute=False, y0=sec.y_final, z0=sec.z_final)
    tab = run.table.drop(columns="steady")
    spec = table_spectrum(tab, "B.Fn")
    pk = peaks(spec, n=N_PEAKS)
    fn = tab["B.Fn"].to_numpy()
    fn_rev = run.maxima["peak"].to_numpy(float)
    iv = peak_interval(fn_rev, PEAK_LEVEL) if fn_rev.size >= 2 and np.all(np.isfinite(fn_rev)) else None
    n_sec = int(len(sec.table))
    row = {"case": name, "group": CASES[name][0], "clearance_mm": c * 1e3, "mu": mu,
           "lambda_per_rev": lyap.per_revolution, "lambda_unc_per_rev": lyap.uncertainty_per_revolution,
           "verdict_main": verdict(lyap.per_revolution, lyap.uncertainty_per_revolution, n_sec),
           "section_points": n_sec, "section_period": int(per),
           "Fn_rev_mean": float(np.mean(fn_rev)) if fn_rev.size else float("nan"),
           "Fn_rev_ci95": iv.half_width if iv else float("nan"),
           "max_Fn": float(np.max(fn_rev)) if fn_rev.size else float("nan"),
           "rms_Fn": float(np.sqrt(np.mean(fn ** 2))),
           "contact_fraction": float(np.mean(fn > 0)),
           "peak_orders": ", ".join(f"{o:.2f}" for o in pk["order"]),
           "status": "ok" if (sec.success and run.success) else f"{sec.message} / {run.message}",
           "wall_s": time.perf_counter() - t0}
    return dict(section=sec, lyap=lyap, table=tab, spectrum=spec, peaks=pk, row=row,
                maxima=run.maxima.assign(case=name)[["case", *run.maxima.columns]])


def check_case(name, y, z, st, period):
    """The case's exponent again from the same state (the end of its section) at rtol_check over
    check_span x the averaging span: the verdict check (nld.study.checked_verdict)."""
    from nld.analysis.lyapunov import lyapunov_tangent
    from nld.systems.core import SceneSystem
    t0 = time.perf_counter()
    system = SceneSystem(SCENE, CASES[name][1])
    system.y0 = np.array(y, float)
    system.z0 = np.array(z, float)
    lyap = lyapunov_tangent(system, transient=0.0, total=st["check_span"] * st["lyap_revs"] * period,
                            rtol=st["rtol_check"])
    return {"lambda_check": lyap.per_revolution, "lambda_check_unc": lyap.uncertainty_per_revolution,
            "check_wall_s": time.perf_counter() - t0, "check_settings": dict(lyap.settings)}


def add_case_checks(res, checks, st):
    """Put each case's check into its row: lambda_check, lambda_check_unc, verdict_check and the
    final verdict (nld.study.checked_verdict of the main and the check verdicts and exponents)."""
    from nld.study import checked_verdict
    for name, chk in zip(CASES, checks):
        row = res[name]["row"]
        row["lambda_check"] = chk["lambda_check"]
        row["lambda_check_unc"] = chk["lambda_check_unc"]
        row["verdict_check"] = verdict(chk["lambda_check"], chk["lambda_check_unc"], row["section_points"])
        row["verdict"] = checked_verdict(row["verdict_main"], row["verdict_check"],
                                         lam=row["lambda_per_rev"], unc=row["lambda_unc_per_rev"],
                                         lam_check=chk["lambda_check"], unc_check=chk["lambda_check_unc"])
        res[name]["check_settings"] = chk["check_settings"]


def run_sweeps(st):
    from nld.analysis.bifurcation import sweep
    kw = dict(transient_revs=st["sweep_transient"], revs=st["sweep_revs"], observables=["B.ex", "B.ey"],
              rtol=st["rtol"], lyapunov=True, lyapunov_revs=st["sweep_lyap"], lyapunov_rtol=st["rtol"],
              workers=st["workers"])
    out = {}
    t0 = time.perf_counter()
    out["clearance"] = sweep(SCENE, "joints.B.clearance", st["clearances"], **kw)
    out["friction"] = sweep(SCENE, "joints.B.friction.mu", st["frictions"], **kw)
    return out, time.perf_counter() - t0


def sweep_points(df: pd.DataFrame, period: float, clearance=None) -> pd.DataFrame:
    """One row per sweep point: value, lambda per revolution +- uncertainty, section period.

    clearance: None (the swept value is the clearance) or the fixed clearance (m); the section period
    is recomputed with points repeating to PERIOD_TOL x clearance (the sweep's own ``period`` column
    uses the points' range as the scale)."""
    from nld.analysis.poincare import period_of
    first = df.drop_duplicates(["direction", "index"]).sort_values("index")
    periods, npts = [], []
    for _, r in first.iterrows():
        g = df[(df["direction"] == r["direction"]) & (df["index"] == r["index"]) & (df["rev"] >= 0)]
        c = float(r["value"]) if clearance is None else clearance
        ok = r["status"] == "ok" and len(g) >= 2
        periods.append(period_of(g[["B.ex", "B.ey"]], tol=PERIOD_TOL, scale=c,
                                 n_max=max(1, min(16, len(g) // 2))) if ok else 0)
        npts.append(int(len(g)) if r["status"] == "ok" else 0)
    lam = first["lyapunov"].to_numpy(float) * period
    unc = first["lyapunov_uncertainty"].to_numpy(float) * period
    return pd.DataFrame({"value": first["value"].astype(float).to_numpy(),
                         "lambda_per_rev": lam, "lambda_unc_per_rev": unc,
                         "section_points": np.array(npts, dtype=int),
                         "verdict_main": [verdict(a, b, n) for a, b, n in zip(lam, unc, npts)],
                         "period": np.array(periods, dtype=int),
                         "status": first["status"].to_numpy()})


def add_sweep_verdicts(res, pts_c, pts_f):
    """Each case's verdict against the sweep point of the same parameters (a run from the assembly:
    another history of the same system): verdict_sweep (blank where no sweep point matches) and the
    final verdict, which holds only if that point's checked verdict agrees too. At c = 0.05 mm the
    case (from the end of its section) and the sweep point (from the assembly) fell on different
    motions: an intermittent regime, whose verdict depends on which stretch is averaged."""
    from nld.study import checked_verdict
    for name, (group, _, c, mu) in CASES.items():
        pts, v = (pts_c, c) if group == "clearance" else (pts_f, mu)
        hit = pts[np.isclose(pts["value"].astype(float), v, rtol=1e-9, atol=1e-15)]
        row = res[name]["row"]
        row["verdict_sweep"] = str(hit["verdict"].iloc[0]) if len(hit) else ""
        if len(hit):
            row["verdict"] = checked_verdict(row["verdict"], row["verdict_sweep"])


def sweep_checks(st, pts_c, pts_f, clearance):
    """The verdict check of the sweeps: every point not called regular is run again from the
    assembly (transient, section, exponent) at rtol_check with check_span x the averaging span.
    Returns ({sweep: check sweep table or None}, wall time)."""
    from nld.analysis.bifurcation import sweep
    kw = dict(transient_revs=st["sweep_transient"], revs=st["sweep_revs"], observables=["B.ex", "B.ey"],
              rtol=st["rtol_check"], lyapunov=True, lyapunov_revs=st["check_span"] * st["sweep_lyap"],
              lyapunov_rtol=st["rtol_check"], workers=st["workers"])
    out = {}
    t0 = time.perf_counter()
    for name, param, pts in (("clearance", "joints.B.clearance", pts_c),
                             ("friction", "joints.B.friction.mu", pts_f)):
        vals = [float(v) for v, vd in zip(pts["value"], pts["verdict_main"]) if vd != REGULAR]
        out[name] = sweep(SCENE, param, vals, **kw) if vals else None
    return out, time.perf_counter() - t0


def add_sweep_checks(pts, chk, period, clearance=None):
    """pts with lambda_check, lambda_check_unc, verdict_check (empty where not checked) and the
    final verdict (nld.study.merge_checks)."""
    from nld.study import merge_checks
    return merge_checks(pts, None if chk is None else sweep_points(chk, period, clearance))


def with_ec(df: pd.DataFrame, clearance=None) -> pd.DataFrame:
    """The table with the journal eccentricity over the clearance, ``B.ex/c`` and ``B.ey/c``
    (dimensionless; +-1 = touching the bearing). clearance: None (a clearance sweep: the swept
    value) or the fixed clearance (m)."""
    c = df["value"].astype(float).to_numpy() if clearance is None else float(clearance)
    return df.assign(**{"B.ex/c": df["B.ex"].to_numpy(float) / c, "B.ey/c": df["B.ey"].to_numpy(float) / c})


# ------------------------------------------------------------------------------------- figures


def _fig_sections(rep, res, period):
    th = np.linspace(0, 2 * np.pi, 200)
    lim = ec_limit(*[with_ec(res[n]["section"].table, CASES[n][2]) for n in CASES], floor=EC_LIM)
    with rep.style():
        # the same limits on every panel (set below; not shared axes, whose hidden tick labels
        # make the tight layout overlap the titles with an equal aspect)
        fig, axes = rep.subplots(2, 3, squeeze=False,
                                 title="Poincaré sections (stroboscopic, once per crank revolution): "
                                       "journal eccentricity at B over the clearance")
        for ax, name in zip(axes.ravel(), CASES):
            r = res[name]
            c = CASES[name][2]
            tab = with_ec(r["section"].table, c)
            ax.scatter(tab["B.ex/c"], tab["B.ey/c"], s=5, color=COLORS[name], linewidths=0,
                       label="section points")
            ax.plot(np.cos(th), np.sin(th), color="0.6", lw=0.6, ls=":", label="clearance circle e = c")
            ax.set_aspect("equal", adjustable="box")
            ax.set_xlim(-lim, lim)
            ax.set_ylim(-lim, lim)
            row = r["row"]
            ax.set_title(f"{name} (c = {row['clearance_mm']:g} mm, μ = {row['mu']:g}): "
                         f"{row['section_points']} points\n"
                         f"λ1 = {row['lambda_per_rev']:.3g} ± {row['lambda_unc_per_rev']:.2g} /rev "
                         f"({row['verdict']}), period {row['section_period'] or 'none'}", fontsize=8)
            ax.set_xlabel("B.ex / c [−]")
            ax.set_ylabel("B.ey / c [−]")
        axes[0, 0].legend(loc="lower left", fontsize=7)
    est = estimator_line(res[next(iter(CASES))]["lyap"].settings, period)
    rep.figure(fig, caption="Each point is the journal centre relative to the bearing centre at t = kT "
                            "(k after the transient), divided by the clearance c of that case, so that the "
                            "panels compare (all on the same axes; dotted: the clearance circle e = c). A "
                            "period-n orbit gives n points; a cloud or a curve is a non-periodic (chaotic or "
                            "quasi-periodic) motion; a section of fewer than "
                            f"{MIN_SECTION_POINTS} points is not called chaotic whatever the exponent "
                            "('λ1 > 0, short'). λ1: largest Lyapunov exponent (natural log per crank "
                            f"revolution) from the end of the section; {est}.")


def _lam_panel(ax, pts, x, ylim=None):
    """λ1 ± uncertainty against the parameter, coloured by verdict (the same legend in every sweep)."""
    ok = (pts["status"] == "ok").to_numpy()
    lam, unc = pts["lambda_per_rev"].to_numpy(float), pts["lambda_unc_per_rev"].to_numpy(float)
    x = np.asarray(x, float)
    ax.plot(x[ok], lam[ok], color="0.6", lw=0.8)
    for v, col in VERDICT_COLORS.items():
        sel = ok & (pts["verdict"] == v).to_numpy()
        if sel.any():
            ax.errorbar(x[sel], lam[sel], yerr=unc[sel], fmt="o", ms=3.5, capsize=2, color=col,
                        label=f"{v} ({int(sel.sum())})")
    ax.axhline(0.0, color="k", lw=0.8, ls="--")
    for xi, p in zip(x[ok], pts["period"].to_numpy()[ok]):
        if p:
            ax.annotate(f"P{p}", (xi, 0), textcoords="offset points", xytext=(0, 6), fontsize=7,
                        ha="center", color="tab:blue")
    ax.set_ylabel("λ1 [1/revolution]")
    if ylim is not None:
        ax.set_ylim(*ylim)
    ax.legend(loc="upper right", fontsize=7.5)


def lam_ylim(*pts_list):
    """A common y-range for the λ1 panels of the sweeps (they are compared)."""
    lo, hi = [0.0], [0.0]
    for p in pts_list:
        ok = p[p["status"] == "ok"]
        if len(ok):
            lo.append(float((ok["lambda_per_rev"] - ok["lambda_unc_per_rev"]).min()))
            hi.append(float((ok["lambda_per_rev"] + ok["lambda_unc_per_rev"]).max()))
    lo, hi = min(lo), max(hi)
    pad = 0.08 * max(hi - lo, 1.0)
    return lo - pad, hi + pad


def _fig_sweep(rep, sw, pts, xlabel, title, param_scale, log, clearance, period, ylim, elim):
    with rep.style():
        fig, (a1, a2) = rep.subplots(2, 1, sharex=True, title=title)
        ok = sw[(sw["status"] == "ok") & (sw["rev"] >= 0)]
        ec = with_ec(ok, clearance)
        a1.scatter(ec["value"].astype(float) * param_scale, ec["B.ex/c"], s=4, color="tab:blue",
                   linewidths=0, label="section points")
        for yv in (-1.0, 1.0):
            a1.axhline(yv, color="0.6", lw=0.6, ls=":")
        a1.set_ylim(-elim, elim)
        a1.set_ylabel("B.ex / c [−]")
        a1.legend(loc="upper right", fontsize=7.5)
        _lam_panel(a2, pts, pts["value"] * param_scale, ylim)
        a2.set_xlabel(xlabel)
        if log:
            a2.set_xscale("log")
    est = estimator_line(sweep_estimator_settings(sw, period), period)
    rep.figure(fig, caption="Top: section points of the journal eccentricity B.ex after the transient, "
                            "divided by the clearance c of the point (±1, dotted: the journal touches the "
                            "bearing; a single point per parameter value = period 1). Bottom: the largest "
                            "exponent from the end of each section (both sweeps on the same λ1 range); "
                            "chaotic: λ1 − uncertainty > 0 over at least "
                            f"{MIN_SECTION_POINTS} section points ('λ1 > 0, short' below that), regular: "
                            "λ1 + uncertainty < 0, each confirmed by a run at a tighter tolerance over a "
                            "longer span ('not established' where that run disagrees); 'Pn' marks a section that repeats with period n "
                            "(nld.analysis.poincare.period_of: points repeating to 1e-6 of the clearance). "
                            f"λ1: {est}.")


def _spectra_max_order(res) -> float:
    """Crank orders shown: at least 20, and every peak the table lists inside the axes."""
    top = [float(res[n]["peaks"]["order"].max()) for n in CASES if len(res[n]["peaks"])]
    return max([20.0] + [1.1 * o for o in top])


def _fig_spectra(rep, res):
    from nld.output.plots import spectrum_plot
    max_order = _spectra_max_order(res)
    with rep.style():
        fig, axes = rep.subplots(2, 3, squeeze=False, sharex=True, sharey=True,
                                 title="Spectra of the normal contact force at B")
        for ax, name in zip(axes.ravel(), CASES):
            r = res[name]
            spectrum_plot(r["spectrum"], ax=ax, peaks=r["peaks"], max_order=max_order,
                          orders=[], title=name)
            if ax.get_legend() is not None:
                ax.get_legend().remove()
            ax.set_ylabel("PSD of B.Fn [N²/Hz]")
            ax.set_xlabel("frequency [Hz]" if ax in axes[-1] else "")
        axes[0, 0].legend(["spectrum", f"{N_PEAKS} largest peaks"], loc="upper right", fontsize=7.5)
    rep.figure(fig, caption="Welch spectra (Hann window) of B.Fn over the sampled run after the section "
                            f"(top axis: crank orders; red dots: the {N_PEAKS} largest peaks, whose crank "
                            f"orders are in the summary table). Axes up to {max_order:.0f} crank orders, "
                            "beyond the highest listed peak; all panels on the same axes. A periodic motion "
                            "puts the power on the harmonics; a chaotic one spreads it in a broadband floor.")


def _fig_convergence(rep, res, period):
    from nld.output.plots import exponent_convergence
    lo, hi = [0.0], [0.0]
    for name in CASES:              # a common y-range that ignores the first tenth of each run
        ly = res[name]["lyap"]
        h = np.asarray(ly.history, float) * period
        h = h[len(h) // 10:]
        u = float(ly.uncertainty_per_revolution)
        f = float(ly.per_revolution)
        lo += [float(np.nanmin(h)) if h.size else f, f - u]
        hi += [float(np.nanmax(h)) if h.size else f, f + u]
    pad = 0.08 * max(max(hi) - min(lo), 1.0)
    with rep.style():
        fig, axes = rep.subplots(2, 3, squeeze=False, sharex=True, sharey=True,
                                 title="Convergence of the largest exponent")
        for ax, name in zip(axes.ravel(), CASES):
            ly = res[name]["lyap"]
            exponent_convergence(ly, per_revolution=True, ax=ax,
                                 title=f"{name}: λ1 = {ly.per_revolution:.3g} ± "
                                       f"{ly.uncertainty_per_revolution:.2g} /rev",
                                 labels=["running estimate"])
            ax.set_ylim(min(lo) - pad, max(hi) + pad)
            if ax.get_legend() is not None:
                ax.get_legend().remove()
            ax.set_ylabel("λ1 [1/revolution]")
            ax.set_xlabel("averaging time [revolutions]" if ax in axes[-1] else "")
        axes[0, 0].legend(loc="upper right", fontsize=7.5)
    est = estimator_line(res[next(iter(CASES))]["lyap"].settings, period)
    rep.figure(fig, caption="Running estimate of λ1 (per revolution) with the final value ± its uncertainty "
                            "(band); all panels on the same axes (the first tenth of a run may leave them). "
                            f"λ1: {est}.")


# --------------------------------------------------------------------------------------- text


def _f(v, d=3):
    return "n/a" if v != v else f"{v:.{d}g}"


def _texts(summary, pts_c, pts_f, st, mode_label):
    s = summary.set_index("case")

    def lam(n):
        return f"{_f(s.loc[n, 'lambda_per_rev'])} ± {_f(s.loc[n, 'lambda_unc_per_rev'], 2)}"

    def fn_rev(n):
        return f"{_f(s.loc[n, 'Fn_rev_mean'])} ± {_f(s.loc[n, 'Fn_rev_ci95'], 2)}"

    intro = [
        f"Source: {CITATION}. What it reported (as summarised in shared/references.md, tagged [U], and by "
        "the seed paper, Zhang et al. 2013: 'the numerical results showed that nonlinearity depended on both "
        "the size of the clearance and the coefficient of friction between the pin and bearing'; the paper "
        "itself could not be read here): a four-bar linkage with a revolute clearance at the "
        "coupler-rocker joint, impacts and Coulomb friction, studied with Poincaré sections; the "
        "nonlinearity (chaos) of the response depends on the clearance size and on friction. The usual "
        "reading of that work, and of the later four-bar studies (e.g. Farahan et al. 2017, bifurcation "
        "against clearance), is: a larger clearance gives a more irregular (chaotic) motion, and friction "
        "in the joint dissipates energy and makes the motion more regular. No numbers of the paper are "
        "available to us, so only these qualitative trends are compared.",
        "What is repeated: the built-in scene four_bar (docs/models/four_bar.md: a representative "
        "crank-rocker, NOT the paper's dimensions; 300 rpm; Lankarani-Nikravesh contact, restitution 0.9; "
        "Ambrósio's modified Coulomb friction) with the clearance at B (coupler-rocker) varied at μ = 0.01 "
        "and the friction coefficient varied at c = 0.25 mm.",
        f"Method ({mode_label}): each case is integrated from the ideal assembly over "
        f"{st['transient_revs']} crank revolutions (discarded), then {st['section_revs']} stroboscopic "
        f"section points; λ1 (tangent dynamics with saltation matrices at every contact event, scaled norm, 2 revolutions of alignment) over {st['lyap_revs']} "
        f"revolutions from the end of the section; then {st['spec_revs']} revolutions sampled "
        f"{st['samples_per_rev']} times per revolution for the spectrum, the contact-force maximum of "
        f"each located from the dense output ({st['samples_per_rev'] * st['peak_detect']} detection "
        "samples per revolution, the largest refined; nld.analysis.extrema) and reported as the mean "
        "of these per-revolution peaks ± its 95 % batch-means interval (nld.analysis.peaks), beside "
        "the largest of them (a single extreme). Sweeps: "
        f"{len(st['clearances'])} clearances and {len(st['frictions'])} friction coefficients, "
        f"{st['sweep_transient']} + {st['sweep_revs']} revolutions each, λ1 over {st['sweep_lyap']}. "
        f"rtol {st['rtol']:g} everywhere (absolute tolerances scaled by the clearance). A case or a sweep "
        f"point is called chaotic only when λ1 - uncertainty > 0 over a section of at least "
        f"{MIN_SECTION_POINTS} points (a positive exponent over a shorter section reads 'λ1 > 0, short'); "
        "regular when λ1 + uncertainty < 0. " + check_text(st) + " Eccentricities are shown over the "
        "clearance (e/c, ±1 = touching the bearing) so that different clearances compare.",
    ]
    ok_c = pts_c[pts_c["status"] == "ok"]
    ok_f = pts_f[pts_f["status"] == "ok"]

    def trend(p, what, scale, unit):
        if len(p) < 2:
            return f"{what}: not enough points."
        lo, hi = p.iloc[0], p.iloc[-1]
        ch = p[p["verdict"] == CHAOTIC]
        sh = p[p["verdict"] == SHORT]
        rg = p[p["verdict"] == REGULAR]
        xv = np.log(p["value"].to_numpy(float)) if what == "clearance" else p["value"].to_numpy(float)
        r = np.corrcoef(xv, p["lambda_per_rev"])[0, 1] if len(p) > 2 else float("nan")
        return (f"{what}: λ1 = {_f(lo['lambda_per_rev'])} /rev at {lo['value'] * scale:g} {unit}, "
                f"{_f(hi['lambda_per_rev'])} /rev at {hi['value'] * scale:g} {unit}; "
                f"max {_f(p['lambda_per_rev'].max())}, min {_f(p['lambda_per_rev'].min())}; "
                f"{len(ch)} of {len(p)} points chaotic (λ1 - unc > 0 over at least {MIN_SECTION_POINTS} "
                f"section points), {len(sh)} with λ1 - unc > 0 over a shorter section, {len(rg)} regular "
                f"(λ1 + unc < 0); "
                f"correlation of λ1 with {'log ' if what == 'clearance' else ''}{what}: {_f(r, 2)}.")

    found = [
        "Cases (section, exponent, spectrum; table on the next page):",
        f"- clearance at μ = 0.01: λ1 = {lam('c=0.05mm')} (0.05 mm), {lam('c=0.25mm')} (0.25 mm), "
        f"{lam('c=0.5mm')} (0.5 mm) per revolution; peak contact force per revolution "
        + ", ".join(fn_rev(n) for n in ("c=0.05mm", "c=0.25mm", "c=0.5mm")) + " N (mean ± 95 % interval "
        f"over {st['spec_revs']} revolutions; largest single peak {_f(s.loc['c=0.05mm', 'max_Fn'])}, "
        f"{_f(s.loc['c=0.25mm', 'max_Fn'])}, {_f(s.loc['c=0.5mm', 'max_Fn'])} N).",
        f"- friction at c = 0.25 mm: λ1 = {lam('mu=0')} (μ = 0), {lam('c=0.25mm')} (0.01), {lam('mu=0.1')} "
        f"(0.1), {lam('mu=0.3')} (0.3) per revolution; section periods {int(s.loc['mu=0', 'section_period'])}, "
        f"{int(s.loc['c=0.25mm', 'section_period'])}, {int(s.loc['mu=0.1', 'section_period'])}, "
        f"{int(s.loc['mu=0.3', 'section_period'])} (0 = none found).",
        "Sweeps:",
        "- " + trend(ok_c, "clearance", 1e3, "mm"),
        "- " + trend(ok_f, "friction", 1.0, ""),
    ]
    return intro, found


def _discussion(summary, pts_c, pts_f):
    s = summary.set_index("case")
    ok_c = pts_c[pts_c["status"] == "ok"]
    ok_f = pts_f[pts_f["status"] == "ok"]
    fr_ok = bool(len(ok_f) >= 2 and ok_f["lambda_per_rev"].iloc[-1] < ok_f["lambda_per_rev"].iloc[0])
    first_reg = ok_f[ok_f["lambda_per_rev"] + ok_f["lambda_unc_per_rev"] < 0]
    mu_reg = f"{first_reg['value'].iloc[0]:g}" if len(first_reg) else "none in the sweep"
    cl_chaotic = ok_c[ok_c["verdict"] == CHAOTIC]
    cl_short = ok_c[ok_c["verdict"] == SHORT]
    cl_incr = bool(len(ok_c) >= 2 and ok_c["lambda_per_rev"].iloc[-1] > ok_c["lambda_per_rev"].iloc[0])
    lines = [
        "Friction: " + ("REPRODUCED. " if fr_ok else "NOT reproduced. ") +
        f"λ1 falls from {_f(ok_f['lambda_per_rev'].iloc[0])} /rev at μ = {ok_f['value'].iloc[0]:g} to "
        f"{_f(ok_f['lambda_per_rev'].iloc[-1])} /rev at μ = {ok_f['value'].iloc[-1]:g}; the first "
        f"friction coefficient with an established negative exponent is {mu_reg}. Friction damps the "
        "tangential sliding of the journal, the journal is dragged along the bearing wall and stays in "
        "contact (contact fraction "
        f"{_f(s.loc['mu=0', 'contact_fraction'], 2)} at μ = 0 vs {_f(s.loc['mu=0.3', 'contact_fraction'], 2)} "
        "at μ = 0.3), and the section collapses to few points.",
        "Clearance: " + (
            f"at μ = 0.01 {len(cl_chaotic)} of {len(ok_c)} clearances are chaotic (an established positive "
            f"exponent over at least {MIN_SECTION_POINTS} section points)"
            + (f", {len(cl_short)} more have a positive exponent over too short a section to be called "
               "chaotic" if len(cl_short) else "") + "; "
            f"λ1 goes from {_f(ok_c['lambda_per_rev'].iloc[0])} /rev at {ok_c['value'].iloc[0] * 1e3:g} mm "
            f"to {_f(ok_c['lambda_per_rev'].iloc[-1])} /rev at {ok_c['value'].iloc[-1] * 1e3:g} mm "
            f"(max {_f(ok_c['lambda_per_rev'].max())}). " +
            (f"Overall the exponent is larger at large clearances than at the smallest, as the source's "
             f"trend says, but not monotonically: it peaks at "
             f"{ok_c['value'].iloc[int(np.argmax(ok_c['lambda_per_rev'].to_numpy()))] * 1e3:g} mm and "
             f"is lowest at {ok_c['value'].iloc[int(np.argmin(ok_c['lambda_per_rev'].to_numpy()))] * 1e3:g} mm "
             "(see the sweep table); at small clearances the journal stays in contact longer "
             f"(contact fraction {_f(s.loc['c=0.05mm', 'contact_fraction'], 2)} at 0.05 mm vs "
             f"{_f(s.loc['c=0.5mm', 'contact_fraction'], 2)} at 0.5 mm), and the impact forces grow with "
             f"the clearance (per-revolution peak {_f(s.loc['c=0.05mm', 'Fn_rev_mean'])} ± "
             f"{_f(s.loc['c=0.05mm', 'Fn_rev_ci95'], 2)} -> {_f(s.loc['c=0.5mm', 'Fn_rev_mean'])} ± "
             f"{_f(s.loc['c=0.5mm', 'Fn_rev_ci95'], 2)} N). "
             if cl_incr else
             "The exponent does NOT grow monotonically with the clearance here: at this light load "
             "(joint reaction 0.5-19 N with ideal joints) the journal rattles chaotically at every "
             "clearance tried, down to 0.02 mm; what grows with the clearance is the size of the "
             "attractor (section spread, in mm) and the impact forces, not λ1 per revolution. ")),
        "Why the results can differ from the source: (1) the scene is a representative four-bar, not the "
        "paper's (its lengths, masses, speed and contact parameters could not be read; docs/models/"
        "four_bar.md); the joint is lightly loaded, so the journal leaves the wall readily; (2) friction is "
        "Ambrósio's regularised Coulomb law (v0 = 1e-4, v1 = 1e-2 m/s), not a pure Coulomb law; (3) the "
        "exponents are finite-time estimates over a few hundred revolutions (quick mode: a few tens), with "
        "the stated uncertainty; values within their uncertainty of 0 are 'uncertain'; (4) sections in "
        "a chaotic regime are only meaningful statistically (docs/analysis.md).",
        "Spectra: the contact force of a regular case concentrates on crank harmonics; chaotic cases "
        "show impact trains with a broadband floor. The three largest peaks (orders) per case are in the "
        "summary table; the peak forces are located from the integrator's dense output in every "
        "revolution (not read off the output samples, which can fall between the impacts' maxima).",
    ]
    return lines


# ----------------------------------------------------------------------------------------- main


def main(quick: bool = False, out_dir: Path = Path("reports"), *, smoke: bool = False) -> Path:
    """Run the study (module docstring); write the PDF and the data files; return the PDF.
    smoke: the test suite's short mode (SMOKE)."""
    from nld.model.scene import load_scene
    from nld.run.simulate import crank_period
    from nld.study import Study
    study = Study(globals(), quick, out_dir, smoke=smoke)
    st = study.settings
    st["workers"] = study.workers(st["workers"])
    base = load_scene(SCENE)
    period = crank_period(base)
    res = run_cases(study, st, period)
    sweeps, pts_c, pts_f, walls = run_all_sweeps(study, st, period, base.joints["B"].clearance)
    add_sweep_verdicts(res, pts_c, pts_f)
    cen = run_census(study, st, res, pts_c, pts_f, base.joints["B"].clearance)
    summary = pd.DataFrame([res[n]["row"] for n in CASES])
    route = run_routes(study, st, sweeps, pts_c, pts_f, base.joints["B"].clearance)
    wall = study.elapsed()
    _provenance(study, base, st, res, sweeps, pts_c, pts_f, summary, period, walls, wall)
    _save(study, base, res, sweeps, summary, cen)
    from nld.analysis.route import save_route
    from nld.study import sde
    save_route(study, {"friction": route["route"]}, route["table"], sde())
    _report(study, base, res, sweeps, pts_c, pts_f, summary, period, wall, route, cen)
    return study.pdf


def run_cases(study, st, period) -> dict:
    """The six cases (run_case) and their verdict checks (check_case): {name: case result}."""
    study.stage("cases")
    res = dict(zip(CASES, study.map(run_case, [(n, st) for n in CASES], st["workers"])))
    study.stage("case checks")
    checks = study.map(check_case, [(n, res[n]["section"].y_final, res[n]["section"].z_final, st, period)
                                    for n in CASES], st["workers"])
    add_case_checks(res, checks, st)
    return res


def run_all_sweeps(study, st, period, c_f):
    """Both sweeps, their points and verdict checks. Returns (sweeps with the check sweeps,
    clearance points, friction points, (sweep wall, check wall) in s); c_f: the scene's
    clearance (m), fixed in the friction sweep."""
    study.stage("sweeps")
    sweeps, sweep_wall = run_sweeps(st)
    pts_c = sweep_points(sweeps["clearance"], period)
    pts_f = sweep_points(sweeps["friction"], period, clearance=c_f)
    study.stage("sweep checks")
    chk, check_wall = sweep_checks(st, pts_c, pts_f, c_f)
    pts_c = add_sweep_checks(pts_c, chk["clearance"], period)
    pts_f = add_sweep_checks(pts_f, chk["friction"], period, clearance=c_f)
    sweeps.update({f"{k}_check": v for k, v in chk.items() if v is not None})
    return sweeps, pts_c, pts_f, (sweep_wall, check_wall)


def _provenance(study, base, st, res, sweeps, pts_c, pts_f, summary, period, walls, wall):
    study.provenance(scene=base, integrator="dopri5", rtol=st["rtol"], source=CITATION, settings=st,
                     cases={n: {"overrides": CASES[n][1]} for n in CASES},
                     summary=summary.to_dict(orient="records"), sweep_wall_s=walls[0], compute_wall_s=wall,
                     sweep_check_wall_s=walls[1], min_section_points=MIN_SECTION_POINTS,
                     verdict_check=check_text(st),
                     case_estimator={n: estimator_line(res[n]["lyap"].settings, period) for n in CASES},
                     case_check_estimator={n: estimator_line(res[n]["check_settings"], period) for n in CASES},
                     sweep_points={"clearance": pts_c.to_dict(orient="records"),
                                   "friction": pts_f.to_dict(orient="records")},
                     sweep_estimator={k: estimator_line(sweep_estimator_settings(v, period), period)
                                      for k, v in sweeps.items()})


def run_routes(study, st, sweeps, pts_c, pts_f, c_f) -> dict:
    """The route to chaos of both sweeps (nld.analysis.route): the period-1 orbit of the friction
    sweep continued over its range (st["route"]) and checked against the brute-force section at
    every sweep value (to PERIOD_TOL_ROUTE x the clearance), and the route rows of both sweeps
    (the clearance sweep: brute force alone). Returns {"route", "agree", "table"}."""
    from nld.analysis.route import agreement, route_table, run_route
    route = run_route(study, SCENE, st["route"], observables=["B.ex", "B.ey"])
    agree = agreement(route, sweeps["friction"], ["B.ex", "B.ey"], c_f, tol=PERIOD_TOL_ROUTE)
    table = pd.concat([route_table("clearance", "joints.B.clearance", pts_c, period_col="period"),
                       route_table("friction", st["route"]["param"], pts_f, period_col="period",
                                   route=route, agree=agree)], ignore_index=True)
    return {"route": route, "agree": agree, "table": table}


def run_census(study, st, res, pts_c, pts_f, c_f):
    """The attractor census (nld.analysis.coexistence.census_points) at every case and sweep point
    whose verdict is 'not established' (one census per parameter pair), and at the cases of
    st["census"]["always"]; the census verdict replaces 'not established' in the case rows and the
    sweep points. Returns the census table."""
    from nld.analysis.coexistence import census_points, census_verdicts
    points, where = {}, {}
    for name, (group, ov, c, mu) in CASES.items():
        if res[name]["row"]["verdict"] == NOT_ESTABLISHED or name in st["census"]["always"]:
            points[name] = (ov, res[name]["row"]["verdict"])
            where[(round(c, 12), mu)] = name
    for pts, key, fixed in ((pts_c, "joints.B.clearance", None), (pts_f, "joints.B.friction.mu", c_f)):
        for v, vd in zip(pts["value"].astype(float), pts["verdict"]):
            pair = (round(v if fixed is None else fixed, 12), 0.01 if fixed is None else v)
            if vd == NOT_ESTABLISHED and pair not in where:
                where[pair] = f"c={pair[0] * 1e3:g}mm, μ={pair[1]:g}"
                points[where[pair]] = ([f"{key}={v!r}"], vd)
    c = st["census"]
    cen = census_points(SCENE, points, starts=c["starts"], transient=c["transient"],
                        record=c["record"], rtol=c["rtol"], seed=c.get("seed", 0),
                        workers=st["workers"], stage=study.stage)
    got = census_verdicts(cen)
    for name in CASES:
        if name in got and res[name]["row"]["verdict"] == NOT_ESTABLISHED:
            res[name]["row"]["verdict"] = got[name]
    for pts, fixed in ((pts_c, None), (pts_f, c_f)):
        for i, (v, vd) in enumerate(zip(pts["value"].astype(float), pts["verdict"])):
            pair = (round(v if fixed is None else fixed, 12), 0.01 if fixed is None else v)
            if vd == NOT_ESTABLISHED and where.get(pair) in got:
                pts.loc[pts.index[i], "verdict"] = got[where[pair]]
    return cen


def _save(study, base, res, sweeps, summary, cen=None):
    study.save(".parquet", {n: res[n]["table"] for n in CASES})
    # sections and sweeps with the eccentricity over the clearance (B.ex/c, B.ey/c) as plotted
    study.save("_sections.parquet", {n: with_ec(res[n]["section"].table, CASES[n][2]) for n in CASES})
    c_f = base.joints["B"].clearance
    study.save("_sweeps.parquet", {k: with_ec(v, None if k.startswith("clearance") else c_f).reset_index(drop=True)
                                   for k, v in sweeps.items()})
    study.save("_spectra.parquet", {n: pd.DataFrame(res[n]["spectrum"]) for n in CASES})
    study.save("_peaks.csv", pd.concat([res[n]["maxima"] for n in CASES], ignore_index=True))
    study.save("_summary.csv", summary)
    if cen is not None:
        study.prov["census"] = dict(settings=study.settings["census"],
                                    points=sorted(set(cen["point"])))
        study.save("_census.csv", cen)


def _report(study, base, res, sweeps, pts_c, pts_f, summary, period, wall, route=None, cen=None):
    from nld.study import census_page, sde, timing
    st, mode_label, prov = study.settings, study.label, study.prov
    shown = summary.drop(columns=["group", "status"] + (["wall_s"] if sde() else []))
    shown = shown.rename(columns={"clearance_mm": "c", "lambda_per_rev": "λ1", "lambda_unc_per_rev": "± unc",
                                  "verdict_main": "verdict 1", "lambda_check": "λ1 check",
                                  "lambda_check_unc": "± check", "verdict_check": "verdict 2",
                                  "verdict_sweep": "sweep",
                                  "section_period": "period", "section_points": "points",
                                  "contact_fraction": "in contact", "Fn_rev_mean": "Fn/rev",
                                  "Fn_rev_ci95": "± 95 %", "max_Fn": "Fn extreme",
                                  "peak_orders": "peak orders", "wall_s": "wall"})
    settings = {"Mode": mode_label, "rtol": st["rtol"],
                "Cases": f"{st['transient_revs']} transient + {st['section_revs']} section revs, λ1 over "
                         f"{st['lyap_revs']} revs, spectrum over {st['spec_revs']} revs",
                "Sweeps": f"{len(st['clearances'])} clearances, {len(st['frictions'])} μ values; "
                          f"{st['sweep_transient']} + {st['sweep_revs']} revs, λ1 over {st['sweep_lyap']}",
                "Compute wall time": timing(f"{wall:.1f} s")}
    rep = study.report(settings, scene=base,
                       subject="Clearance size and friction vs chaos in a four-bar with a clearance joint",
                       keywords=["clearance joint", "four-bar", "Rhee Akay 1996", "Lyapunov"])
    intro, found = _texts(summary, pts_c, pts_f, st, mode_label)
    with rep:
        rep.text_page("What this report reproduces", intro)
        rep.text_page("What we found", found)
        rep.table("Cases: exponent, section period, contact force, spectral peaks", shown,
                  col_units={"c": "mm", "λ1": "1/rev", "± unc": "1/rev", "λ1 check": "1/rev",
                             "± check": "1/rev", "Fn/rev": "N", "± 95 %": "N", "Fn extreme": "N",
                             "rms_Fn": "N", "wall": "s"},
                  notes=["λ1 ± unc: largest Lyapunov exponent per crank revolution (lambda_per_rev, "
                         "lambda_unc_per_rev in the CSV); verdict 1 'chaotic' if λ1 - unc > 0 and the section "
                         f"has at least {MIN_SECTION_POINTS} points ('λ1 > 0, short' below that), 'regular' if "
                         f"λ1 + unc < 0. λ1: {prov['case_estimator'][next(iter(CASES))]}. λ1 check, verdict 2: "
                         f"{prov['case_check_estimator'][next(iter(CASES))]}, from the same state. sweep: the "
                         "verdict of the sweep point with the same parameters (run from the assembly, next "
                         "table). verdict: verdict 1 where verdict 2 and the sweep agree, else 'not "
                         "established', which the attractor census then replaces (page 'Coexisting "
                         "motions'). points: section "
                         "points. period: period of the "
                         "Poincaré section (points repeat to 1e-6 of the clearance; 0 = none up to 16). "
                         f"Fn/rev ± 95 %: mean of the contact-force maxima of the {st['spec_revs']} "
                         "revolutions of the sampled run (each located from the dense output, "
                         f"{STEM}_peaks.csv) with its 95 % batch-means interval (nld.analysis.peaks."
                         "peak_interval; Fn_rev_mean, Fn_rev_ci95 in the CSV); Fn extreme: the largest of "
                         "these maxima, a single extreme (max_Fn). rms_Fn, in contact (fraction of samples "
                         f"with B.Fn > 0): over the sampled run stored in {STEM}.parquet (B.Fn). peak_orders: crank orders of "
                         "the three largest peaks of the B.Fn spectrum."],
                  float_format=lambda v: f"{v:.4g}")
        sw_table = pd.concat([pts_c.assign(sweep="clearance", value=pts_c["value"] * 1e3),
                              pts_f.assign(sweep="friction mu")], ignore_index=True)
        sw_table = sw_table[["sweep", "value", "lambda_per_rev", "lambda_unc_per_rev", "section_points",
                             "verdict_main", "lambda_check", "verdict_check", "verdict", "period",
                             "status"]].rename(
            columns={"section_points": "points", "lambda_per_rev": "λ1", "lambda_unc_per_rev": "± unc",
                     "verdict_main": "verdict 1", "lambda_check": "λ1 check", "verdict_check": "verdict 2"})
        se = prov["sweep_estimator"]
        se_text = (f"λ1 (both sweeps): {se['clearance']}." if se["clearance"] == se["friction"] else
                   f"λ1 (clearance sweep): {se['clearance']}. λ1 (friction sweep): {se['friction']}.")
        rep.table("Sweeps: largest exponent and section period per point", sw_table,
                  col_units={"value": "mm or −", "λ1": "1/rev", "± unc": "1/rev", "λ1 check": "1/rev"},
                  notes=[f"{se_text} verdict 1 as in the case table (at least "
                         f"{MIN_SECTION_POINTS} section points for 'chaotic'). verdict 2: the point run "
                         f"again from the assembly at rtol {st['rtol_check']:g} with {st['check_span']}x the "
                         "averaging span (points called regular by verdict 1 are not run again; blank). "
                         "verdict: verdict 1 where verdict 2 agrees, else 'not established', which "
                         "the attractor census then replaces (page 'Coexisting motions'). "
                         "value: clearance in mm, or the friction coefficient. period: of the section, "
                         "points repeating to 1e-6 of the clearance (0 = none up to 16). Stored in "
                         f"{STEM}_sweeps.parquet (lyapunov in 1/s; x period {period:.4g} s = per rev)."],
                  float_format=lambda v: f"{v:.4g}")
        census_page(rep, cen, st, "case or sweep point")
        _fig_sections(rep, res, period)
        ylim = lam_ylim(pts_c, pts_f)
        elim = ec_limit(with_ec(sweeps["clearance"]),
                      with_ec(sweeps["friction"], base.joints["B"].clearance), floor=EC_LIM)
        _fig_sweep(rep, sweeps["clearance"], pts_c, "clearance c [mm]",
                   "Bifurcation diagram and λ1 against the clearance (μ = 0.01)", 1e3, True, None, period,
                   ylim, elim)
        _fig_sweep(rep, sweeps["friction"], pts_f, "friction coefficient μ [−]",
                   f"Bifurcation diagram and λ1 against the friction coefficient "
                   f"(c = {base.joints['B'].clearance * 1e3:g} mm)", 1.0, False, base.joints["B"].clearance,
                   period, ylim, elim)
        if route is not None:
            from nld.study import route_page
            tab = route["table"]
            route_page(rep, None, sweeps["clearance"], pts_c, tab[tab["sweep"] == "clearance"],
                       "B.ex", label="clearance c (μ = 0.01)", symbol="c", scale=1e3, unit="mm",
                       param_scale=1e3, param_unit="mm", logx=True)
            route_page(rep, route["route"], sweeps["friction"], pts_f, tab[tab["sweep"] == "friction"],
                       "B.ex", label=f"friction coefficient μ (c = {base.joints['B'].clearance * 1e3:g} mm)",
                       symbol="μ", scale=1e3, unit="mm", agree=route["agree"])
        _fig_spectra(rep, res)
        _fig_convergence(rep, res, period)
        rep.text_page("Source vs ours: trends and why they differ", _discussion(summary, pts_c, pts_f))


if __name__ == "__main__":
    import sys
    print(main(quick="--quick" in sys.argv, smoke="--smoke" in sys.argv))
