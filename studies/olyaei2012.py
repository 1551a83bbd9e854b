"""Study: chaos in the slider-crank with a rod-slider clearance, Olyaei & Ghazavi (2012) style.

    nld study olyaei2012 [--quick] [--out-dir DIR]
    python -c "from pathlib import Path; import runpy; runpy.run_path('studies/olyaei2012.py')['main'](True, Path('reports'))"

Scene ``slider_crank_olyaei``: the Flores slider-crank (0.5 mm radial clearance at the rod-slider joint
B, Lankarani-Nikravesh contact, restitution 0.9, 5000 rpm) with Ambrosio's modified Coulomb friction
(mu = 0.1). With :func:`nld.analysis.bifurcation.sweep` (stroboscopic section once per crank revolution, period
detection, and the largest Lyapunov exponent by :func:`nld.analysis.lyapunov.lyapunov_tangent` (tangent
dynamics with saltation matrices at every contact event) from the end of each section):

* bifurcation diagram and exponent against the crank speed (driver.speed, clearance 0.5 mm);
* bifurcation diagram and exponent against the clearance (joints.B.clearance, 5000 rpm);
* bifurcation diagram and exponent against the friction coefficient (joints.B.friction.mu, 0.5 mm,
  5000 rpm), the third parameter of the chaos literature (Farahanchi & Shaw: chaos at low friction);
* the crank-speed sweep again at mu = 0.05 (the chaotic side of the friction sweep);
* Poincare maps of a periodic (regular) and a chaotic state, picked from the sweeps (most negative and
  most positive exponent), over a longer section, with the exponent's convergence at a tighter
  tolerance;
* where chaos sets in: the chaotic windows of each sweep and the interpolated lambda = 0 crossings.

Outputs in ``out_dir``: ``olyaei2012.pdf``; ``olyaei2012.parquet`` (the sweeps stacked, ``case`` =
sweep name first, the columns of :func:`nld.analysis.bifurcation.load_sweep` and ``B.ex/c``, ``B.ey/c``: the
eccentricity over the point's clearance, as plotted); ``olyaei2012_points.csv`` (one row
per sweep point: value, lambda per revolution +- uncertainty, verdict, detected period);
``olyaei2012_sections.parquet`` (the two showcase sections, ``case`` = regular / chaotic, with
``B.ex/c``, ``B.ey/c``); a point or state is called chaotic only when lambda - uncertainty > 0 over a
section of at least MIN_SECTION_POINTS points ('λ1 > 0, short' below that);
``olyaei2012_summary.csv`` (per sweep: counts, the largest and smallest exponent, onset; each number
follows from the points file, which the test checks); ``olyaei2012_tolcheck.csv`` (the largest exponent
of each sweep recomputed at three tolerances).
"""
from __future__ import annotations

import math
import time
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

from nld.output.report import ec_limit
from nld.analysis.route import save_route
from nld.study import sde, verdict as verdict_rule
from nld.analysis.verdict import CHAOTIC, COEXISTING, FAILED, NOT_ESTABLISHED, PERMANENT_CONTACT, \
    REGULAR, SHORT, UNCERTAIN

SCENE = "slider_crank_olyaei"
STEM = "olyaei2012"
TITLE = "Chaos in a slider-crank with a rod-slider clearance (Olyaei & Ghazavi 2012 style)"
CITATION = ("A. A. Olyaei, M. R. Ghazavi (2012), \"Stabilizing slider-crank mechanism with clearance joints\", "
            "Mechanism and Machine Theory 53:17-29")
RPM = 30.0 / math.pi                    # rad/s -> rpm
SPEED0 = 5000.0 / RPM                   # rad/s, the scene's crank speed

# sweep settings: rtol of the sections, transient and section revolutions, exponent revolutions/rtol;
# case_*: the two showcase states (longer sections, exponent at a tighter tolerance)
FULL = dict(rtol=1e-8, transient_revs=100, revs=64, lyap_revs=64, lyap_rtol=1e-10,
            speeds=list(np.arange(500.0, 6001.0, 125.0) / RPM),
            clearances=list(np.geomspace(0.02e-3, 0.5e-3, 29)),
            frictions=[0.0, 0.01, 0.02, 0.03, 0.05, 0.075, 0.1, 0.15, 0.2, 0.3],
            speeds_low_mu=list(np.arange(500.0, 6001.0, 250.0) / RPM),
            case_transient=100, case_revs=300, case_lyap_revs=200, case_lyap_rtol=1e-10,
            check_rtol_factor=0.1, check_span=2, workers=2,
            census=dict(starts=16, transient=100, record=100, rtol=1e-9, always=[]),
            route=dict(param="joints.B.friction.mu", start=0.1, chaotic=0.02, max_period=2,
                       transient=50, method="arclength", max_points=60,
                       values=[0.0, 0.01, 0.02, 0.03, 0.05, 0.075, 0.1, 0.15, 0.2, 0.3]))
QUICK = dict(rtol=1e-7, transient_revs=10, revs=12, lyap_revs=10, lyap_rtol=1e-10,
             speeds=[1500.0 / RPM, 3000.0 / RPM, SPEED0], clearances=[0.05e-3, 0.5e-3],
             frictions=[0.0, 0.1], speeds_low_mu=[1500.0 / RPM, SPEED0],
             case_transient=10, case_revs=20, case_lyap_revs=12, case_lyap_rtol=1e-10,
             check_rtol_factor=0.1, check_span=1, workers=1,   # quick: the check over the same span (CI time)
             # quick mode runs the census at one point even where its verdict holds, so that the
             # path is exercised
             census=dict(starts=2, transient=10, record=16, rtol=1e-7, always=[("friction", 0)]),
             route=dict(param="joints.B.friction.mu", start=0.1, chaotic=None, max_period=0,
                        transient=10, values=[0.09, 0.1], rtol=1e-8, method="natural"))
SMOKE = dict(QUICK, transient_revs=2, revs=4, lyap_revs=3, speeds=[3000.0 / RPM, SPEED0],
             clearances=[0.05e-3], frictions=[0.0], speeds_low_mu=[SPEED0], case_transient=2, case_revs=6, case_lyap_revs=4)
# the clearance sweep's route (full mode): the permanent-contact period-1 orbit reached from c =
# 0.28 mm after 100 revolutions (unstable, multiplier -1.28; tests/test_continuation.py) followed up
# in the clearance by natural steps over the sweep's values 0.2814 and 0.3157 mm and three values
# between them, with the period doubling located to 2e-8 m (0.286132 mm, where the sweep's sections
# turn from period 2 to period 1) and its criticality decided (supercritical: the period-2 orbit is
# stable at 0.285858 mm, where the period-1 orbit is unstable). The orbit is one of a continuum (the
# contact memory): the doubling value depends on the history by about 0.4 µm (docs/orbits.md).
# Cost (time.process_time): 19 CPU s, 11 s without the criticality;
# the same route over the sweep's values from 0.224 to 0.5 mm did not finish in 400 s (wall, at a
# load of 7 on 2 cores), so the branch is followed around the doubling only.
# cascade: at the supercritical doubling the period-2 branch is followed down to the range's end
# (nld.analysis.route.follow_doublings: natural steps growing from the doubling to 0.5 µm, the
# sweep's 0.2814 mm on the way, at most 16 points for all doubled branches): 15 points, period 2
# (neutral continuum: stable but for the memory's 1) to 0.28 mm, no further doubling in the range;
# cost 17-19 CPU s (time.process_time around it, three runs; the route 36-38 CPU s with it).
# docs/route.md.
FULL["route_clearance"] = dict(
    param="joints.B.clearance", start=0.28e-3, chaotic=None, max_period=0, transient=100,
    rtol=1e-10, method="natural", criticality=True, locate_tol=2e-8,
    cascade=dict(max_period=4, step=0.5e-6, max_points=16),
    values=sorted([c for c in FULL["clearances"] if 0.28e-3 <= c <= 0.32e-3]
                  + [0.2835e-3, 0.287e-3, 0.29e-3]))
MODE_LABELS = {"quick": "QUICK MODE: {transient_revs} + {revs} revolutions per point, rtol {rtol:g}, a few points per sweep",
               "smoke": "SMOKE MODE (test only): a handful of revolutions"}

OBS = ["B.ex", "B.ey"]
# period of a section: successive points agree to PERIOD_TOL_C of the clearance (nld.analysis.poincare.period_of
# with scale = c); the integration and friction-regularisation floor is about 1e-5 c here
PERIOD_TOL_C = 1e-4
# tolerance check of the exponent: (estimator, rtol) at which lambda is recomputed; the two-trajectory
# estimator (Benettin, d0 = 1e-4) is the independent check of the tangent one
TOL_CHECK = [("tangent", 1e-8), ("tangent", 1e-10), ("tangent", 1e-11), ("benettin", 1e-10)]


def _tc_key(est, rtol):
    return f"{est} rtol={rtol:g}"


def _tc_label(est, rtol):
    return f"{'B ' if est == 'benettin' else ''}{rtol:g}"
# sweep name -> (param key, label, plot scale, plot unit, log x)
SWEEPS = {
    "speed": ("driver.speed", "crank speed", RPM, "rpm", False),
    "clearance": ("joints.B.clearance", "radial clearance c", 1e3, "mm", True),
    "friction": ("joints.B.friction.mu", "friction coefficient μ", 1.0, "−", False),
    "speed_mu0.05": ("driver.speed", "crank speed at μ = 0.05", RPM, "rpm", False),
}
# base overrides of a sweep (applied before the swept value), and its values in the settings
BASE = {"speed_mu0.05": ["joints.B.friction.mu=0.05"]}
SETTINGS_KEY = {"speed": "speeds", "clearance": "clearances", "friction": "frictions",
                "speed_mu0.05": "speeds_low_mu"}
FIXED = {"speed": "c = 0.5 mm, μ = 0.1", "clearance": "5000 rpm, μ = 0.1", "friction": "c = 0.5 mm, 5000 rpm",
         "speed_mu0.05": "c = 0.5 mm"}
# exponents above this (per revolution) are drawn on the upper edge of the plot with their value
LAMBDA_CLIP = 25.0
# showcase of a chaotic state: candidates tried in order of lambda - uncertainty until one stays chaotic
MAX_CHAOTIC_CANDIDATES = 3


C0 = 0.5e-3                # m, the scene's radial clearance at B (main() checks it)
# a verdict "chaotic" needs a positive exponent AND a section long enough to show it: with fewer
# points the section cannot tell an attractor from a transient, whatever the exponent says
MIN_SECTION_POINTS = 50
# e/c axes of the sections and bifurcation diagrams: +-1 = the journal touches the bearing
EC_LIM = 1.15


VERDICT_COLORS = {CHAOTIC: "tab:red", SHORT: "tab:orange", REGULAR: "tab:blue", UNCERTAIN: "0.5",
                  NOT_ESTABLISHED: "tab:olive", COEXISTING: "tab:pink",
                  PERMANENT_CONTACT: "tab:cyan"}
UNCERTAINTY_TEXT = ("uncertainty: block standard error of the local rates + spread of the running "
                    "estimate over its last half")


# the one verdict rule (nld.analysis.verdict) with this study's MIN_SECTION_POINTS:
# _verdict(lam, unc, n_points) (below it a positive exponent is SHORT)
_verdict = partial(verdict_rule, min_points=MIN_SECTION_POINTS)


def _clearance(name: str, value: float) -> float:
    """The clearance (m) of a point of sweep ``name`` (or of its check, ``NAME_check``)."""
    return float(value) if name.removesuffix("_check") == "clearance" else C0


def with_ec(df: pd.DataFrame, c) -> pd.DataFrame:
    """The table with the journal eccentricity over the clearance, ``B.ex/c`` and ``B.ey/c``
    (dimensionless; +-1 = touching the bearing); c: a clearance (m) or one per row."""
    c = np.asarray(c, float)
    return df.assign(**{"B.ex/c": df["B.ex"].to_numpy(float) / c, "B.ey/c": df["B.ey"].to_numpy(float) / c})


def estimator_line(settings: dict, period: float | None) -> str:
    """Estimator, tolerance, averaging span (from an exponent's own settings) and what the
    uncertainty is."""
    from nld.output.report import estimator_text
    import re
    st = {k: v for k, v in dict(settings or {}).items() if k != "scales"}
    # in revolutions only: the crank period differs between the points compared
    return re.sub(r" \([^()]* s\)", "", estimator_text(st, None, period)) + "; " + UNCERTAINTY_TEXT


def sweep_estimator_line(df: pd.DataFrame) -> str:
    """The exponent settings of a sweep, from the sweep's own provenance (every point used them):
    estimator, rtol, and the averaging span (lyapunov_revs periods from the end of the section)."""
    prov = dict(df.attrs.get("provenance", {}) or {})
    st = {"method": prov.get("lyapunov_estimator") or "?", "transient": 0.0}
    if prov.get("lyapunov_rtol") is not None:
        st["rtol"] = float(prov["lyapunov_rtol"])
    line = estimator_line(st, None)
    return line.replace("; uncertainty", f"; averaged over {prov.get('lyapunov_revs', '?')} rev; uncertainty")


# --------------------------------------------------------------------------------------- runs


def run_sweeps(st: dict):
    """The three sweeps; returns ({name: load_sweep table}, {name: wall s})."""
    from nld.analysis.bifurcation import sweep
    out, walls = {}, {}
    for name, (param, *_rest) in SWEEPS.items():
        t0 = time.perf_counter()
        out[name] = sweep(SCENE, param, [float(v) for v in st[SETTINGS_KEY[name]]], overrides=BASE.get(name),
                          transient_revs=st["transient_revs"], revs=st["revs"], observables=OBS,
                          rtol=st["rtol"], lyapunov=True, lyapunov_revs=st["lyap_revs"],
                          lyapunov_rtol=st["lyap_rtol"], workers=st["workers"])
        walls[name] = time.perf_counter() - t0
    return out, walls


def sweep_points(name: str, df: pd.DataFrame) -> pd.DataFrame:
    """One row per point: value, lambda (1/s and per revolution) +- uncertainty, verdict, period."""
    first = df.drop_duplicates(["direction", "index"]).sort_values("index")
    v = first["value"].to_numpy(float)
    speed = v if SWEEPS[name][0] == "driver.speed" else np.full(len(v), SPEED0)
    period = 2 * np.pi / speed
    lam = first["lyapunov"].to_numpy(float)
    unc = first["lyapunov_uncertainty"].to_numpy(float)
    per, uper = lam * period, unc * period
    from nld.analysis.poincare import period_of
    pc, npts = [], []
    for i, val in zip(first["index"], v):
        g = df[(df["index"] == i) & (df["status"] == "ok")]
        npts.append(int(len(g)))
        c = _clearance(name, val)
        pc.append(period_of(g[OBS].to_numpy(float), tol=PERIOD_TOL_C, scale=c,
                            n_max=min(16, max(1, len(g) // 2))) if len(g) >= 2 else 0)
    return pd.DataFrame({"sweep": name, "param": SWEEPS[name][0], "index": first["index"].to_numpy(int),
                         "value": v, "period_s": period, "lambda_1_s": lam, "lambda_unc_1_s": unc,
                         "lambda_per_rev": per, "lambda_unc_per_rev": uper,
                         "section_points": np.array(npts, dtype=int),
                         "verdict_main": [_verdict(a, b, n) for a, b, n in zip(per, uper, npts)],
                         "section_period": first["period"].to_numpy(int),
                         "period_c": np.array(pc, dtype=int),
                         "status": first["status"].to_numpy()})


def check_points(st: dict, points: dict, sweeps: dict):
    """The verdict check: every sweep point not called regular is run again from the assembly with
    both tolerances (section and exponent) times check_rtol_factor and the exponent averaged over
    check_span x the span; its verdict holds only if both runs agree (nld.study.merge_checks).
    Adds the check sweeps to ``sweeps`` (as NAME_check); returns {name: points with the check}."""
    from nld.analysis.bifurcation import sweep
    from nld.study import merge_checks
    f = st["check_rtol_factor"]
    out = {}
    for name, pts in points.items():
        vals = [float(v) for v, vd in zip(pts["value"], pts["verdict_main"]) if vd != REGULAR]
        chk = None
        if vals:
            sweeps[f"{name}_check"] = sweep(
                SCENE, SWEEPS[name][0], vals, overrides=BASE.get(name),
                transient_revs=st["transient_revs"], revs=st["revs"], observables=OBS,
                rtol=st["rtol"] * f, lyapunov=True, lyapunov_revs=st["check_span"] * st["lyap_revs"],
                lyapunov_rtol=st["lyap_rtol"] * f, workers=st["workers"])
            chk = sweep_points(name, sweeps[f"{name}_check"])
        out[name] = merge_checks(pts, chk)
    return out


def chaotic_windows(pts: pd.DataFrame):
    """Contiguous runs of chaotic points: [(first value, last value, count)]."""
    out, cur = [], None
    for v, verdict in zip(pts["value"], pts["verdict"]):
        if verdict == CHAOTIC:
            cur = [v, v, 1] if cur is None else [cur[0], v, cur[2] + 1]
        elif cur is not None:
            out.append(tuple(cur))
            cur = None
    if cur is not None:
        out.append(tuple(cur))
    return out


def zero_crossings(pts: pd.DataFrame, log: bool):
    """Values where lambda per revolution changes sign (linear interpolation, in log for log sweeps)."""
    ok = pts[pts["status"] == "ok"]
    x, lam = ok["value"].to_numpy(float), ok["lambda_per_rev"].to_numpy(float)
    out = []
    for i in range(len(x) - 1):
        a, b = lam[i], lam[i + 1]
        if a * b < 0:
            xa, xb = (math.log(x[i]), math.log(x[i + 1])) if log else (x[i], x[i + 1])
            xc = xa + (xb - xa) * a / (a - b)
            out.append((math.exp(xc) if log else xc, "up" if b > a else "down"))
    return out


def verdict_counts(points: dict) -> dict:
    """Points per class over all sweeps, each point in exactly one class (a failed run is
    "failed", else its verdict), so that the counts add up to the number of points."""
    out: dict = {}
    for pts in points.values():
        cls = np.where(pts["status"].to_numpy() != "ok", FAILED, pts["verdict"].astype(str).to_numpy())
        for c in cls:
            out[str(c)] = out.get(str(c), 0) + 1
    return out


def tally_text(counts: dict) -> str:
    """"Of N points, a are chaotic, b regular, ...": every class with a count, largest first after
    chaotic and regular, so that the parts add up to N."""
    n = sum(counts.values())
    order = [CHAOTIC, REGULAR] + sorted((k for k in counts if k not in (CHAOTIC, REGULAR)),
                                            key=lambda k: -counts[k])
    parts = [f"{counts.get(k, 0)} {k}" for k in order if k in (CHAOTIC, REGULAR) or counts.get(k)]
    return f"Of {n} points, " + ", ".join(parts[:-1]) + (" and " if len(parts) > 1 else "") + parts[-1]


def check_uncertainty(lam: float, unc: float, checks) -> float:
    """The uncertainty of an exponent ``lam`` ± ``unc`` that a tolerance check recomputed as
    ``checks`` (the other runs' values): the estimator's own uncertainty and the largest distance
    to a check run added in quadrature, so that the stated interval covers the spread between the
    runs (a check that moves λ1 by 0.012 cannot leave it at ± 1e-7)."""
    c = np.asarray([x for x in np.atleast_1d(np.asarray(checks, dtype=float)) if np.isfinite(x)])
    spread = float(np.max(np.abs(c - lam))) if c.size else 0.0
    return float(math.hypot(unc if np.isfinite(unc) else 0.0, spread))


def _with_check(tolcheck) -> pd.DataFrame:
    """The tolerance-check table with ``unc_with_check_per_rev`` (:func:`check_uncertainty`)."""
    tc = tolcheck.copy()
    cols = [f"lambda {_tc_key(est, rt)}" for est, rt in TOL_CHECK]
    tc["unc_with_check_per_rev"] = [
        check_uncertainty(r["sweep_lambda_per_rev"], r["sweep_unc_per_rev"], [r[c] for c in cols if c in r])
        for _, r in tc.iterrows()]
    return tc


def summary_table(points: dict) -> pd.DataFrame:
    rows = []
    for name, pts in points.items():
        ok = pts[pts["status"] == "ok"]
        win = chaotic_windows(pts)
        ch = pts[pts["verdict"] == CHAOTIC]
        rows.append({"sweep": name, "param": SWEEPS[name][0], "points": len(pts),
                     "chaotic": int((pts["verdict"] == CHAOTIC).sum()),
                     "regular": int((pts["verdict"] == REGULAR).sum()),
                     "positive_short": int((pts["verdict"] == SHORT).sum()),
                     "uncertain": int((pts["verdict"] == UNCERTAIN).sum()),
                     "coexisting": int((pts["verdict"] == COEXISTING).sum()),
                     "permanent_contact": int((pts["verdict"] == PERMANENT_CONTACT).sum()),
                     "not_established": int((pts["verdict"] == NOT_ESTABLISHED).sum()),
                     "failed": int((pts["status"] != "ok").sum()),
                     "periodic_sections": int((ok["period_c"] > 0).sum()),
                     "max_lambda_per_rev": float(ok["lambda_per_rev"].max()) if len(ok) else math.nan,
                     "argmax_value": float(ok.loc[ok["lambda_per_rev"].idxmax(), "value"]) if len(ok) else math.nan,
                     "min_lambda_per_rev": float(ok["lambda_per_rev"].min()) if len(ok) else math.nan,
                     "argmin_value": float(ok.loc[ok["lambda_per_rev"].idxmin(), "value"]) if len(ok) else math.nan,
                     "first_chaotic_value": float(ch["value"].min()) if len(ch) else math.nan,
                     "last_chaotic_value": float(ch["value"].max()) if len(ch) else math.nan,
                     "chaotic_windows": len(win),
                     "lambda_zero_crossings": len(zero_crossings(pts, SWEEPS[name][4]))})
    return pd.DataFrame(rows)


def run_census(study, st: dict, points: dict):
    """The attractor census (nld.analysis.coexistence.census_points) at every sweep point whose
    checked verdict is 'not established' (and at st["census"]["always"]: (sweep, index) pairs); the census verdict
    ('coexisting', or the one attractor's class) replaces 'not established' in ``points``.
    Returns the census table."""
    from nld.analysis.coexistence import census_points, census_verdicts
    todo, where = {}, {}
    for name, pts in points.items():
        for i, (v, vd) in enumerate(zip(pts["value"].astype(float), pts["verdict"])):
            if vd == NOT_ESTABLISHED or (name, i) in [tuple(a) for a in st["census"]["always"]]:
                label = f"{name}: {_fmt_value(name, v)}"
                todo[label] = (_overrides(name, v), vd)
                where[(name, i)] = label
    c = st["census"]
    cen = census_points(SCENE, todo, starts=c["starts"], transient=c["transient"],
                        record=c["record"], rtol=c["rtol"], seed=c.get("seed", 0),
                        workers=st["workers"], stage=study.stage)
    got = census_verdicts(cen)
    for (name, i), label in where.items():
        pts = points[name]
        if pts["verdict"].iloc[i] == NOT_ESTABLISHED and label in got:
            pts.loc[pts.index[i], "verdict"] = got[label]
    return cen


def _overrides(name: str, value: float):
    return list(BASE.get(name, [])) + [f"{SWEEPS[name][0]}={value!r}"]


def pick_states(points: dict):
    """(regular point, [chaotic candidates]): rows of the points table. Regular: the most negative
    exponent among regular points, preferring a periodic section; chaotic candidates: the points
    with lambda - uncertainty > 0 (chaotic, or SHORT: the showcase's longer section decides), by
    decreasing lambda - uncertainty (at most MAX_CHAOTIC_CANDIDATES)."""
    allp = pd.concat(points.values(), ignore_index=True)
    reg = allp[allp["verdict"] == REGULAR]
    per = reg[reg["period_c"] > 0]
    pool = per if len(per) else reg
    regular = pool.loc[pool["lambda_per_rev"].idxmin()].to_dict() if len(pool) else None
    ch = allp[allp["verdict"].isin([CHAOTIC, SHORT])]
    ch = ch.assign(_key=ch["lambda_per_rev"] - ch["lambda_unc_per_rev"]).sort_values("_key", ascending=False)
    chaotic = [r.drop(labels="_key").to_dict() for _, r in ch.head(MAX_CHAOTIC_CANDIDATES).iterrows()]
    return regular, chaotic


def run_state(pt: dict, st: dict):
    """Longer stroboscopic section of one state and its exponent at the tighter tolerance."""
    from nld.analysis.lyapunov import lyapunov_tangent
    from nld.analysis.poincare import period_of, stroboscopic
    from nld.systems.core import SceneSystem
    ov = _overrides(pt["sweep"], pt["value"])
    t0 = time.perf_counter()
    sec = stroboscopic(SCENE, transient_revs=st["case_transient"], revs=st["case_revs"],
                       observables=OBS + ["rod.omega", "slider.vx"], overrides=ov, rtol=st["rtol"])
    system = SceneSystem(SCENE, ov)
    system.y0 = np.array(sec.y_final, float)
    system.z0 = np.array(sec.z_final, float)
    lyap = lyapunov_tangent(system, transient=0.0, total=st["case_lyap_revs"] * sec.period,
                            rtol=st["case_lyap_rtol"])
    c = _clearance(pt["sweep"], pt["value"])
    p = period_of(sec.table[OBS], tol=PERIOD_TOL_C, scale=c, n_max=min(16, st["case_revs"] // 2))
    pts = sec.points[:, :2]
    spread = float(np.max(np.ptp(pts, axis=0))) if len(pts) else math.nan
    n = int(len(sec.table))
    return dict(section=sec, lyap=lyap, overrides=ov, period=int(p), spread_m=spread, clearance=c,
                section_points=n, verdict=_verdict(lyap.per_revolution, lyap.uncertainty_per_revolution, n),
                success=bool(sec.success), message=sec.message, wall_s=time.perf_counter() - t0)


def tolerance_check(points: dict, st: dict) -> pd.DataFrame:
    """lambda of the largest-exponent point of each sweep recomputed at the TOL_CHECK tolerances, from
    the end of a fresh section (same transient and section length as the sweep)."""
    from nld.analysis.lyapunov import largest_exponent
    from nld.analysis.poincare import stroboscopic
    from nld.systems.core import SceneSystem
    rows, est_lines = [], {}
    for name, pts in points.items():
        ok = pts[pts["status"] == "ok"]
        if not len(ok):
            continue
        pt = ok.loc[ok["lambda_per_rev"].idxmax()]
        ov = _overrides(name, float(pt["value"]))
        sec = stroboscopic(SCENE, transient_revs=st["transient_revs"], revs=st["revs"], observables=OBS,
                           overrides=ov, rtol=st["rtol"])
        row = {"sweep": name, "value": float(pt["value"]), "sweep_lambda_per_rev": float(pt["lambda_per_rev"]),
               "sweep_unc_per_rev": float(pt["lambda_unc_per_rev"])}
        for est, rtol in TOL_CHECK:
            system = SceneSystem(SCENE, ov)
            system.y0 = np.array(sec.y_final, float)
            system.z0 = np.array(sec.z_final, float)
            r = largest_exponent(system, est, total=st["lyap_revs"] * sec.period, rtol=rtol)
            key = _tc_key(est, rtol)
            row[f"lambda {key}"] = float(r.per_revolution)
            row[f"unc {key}"] = float(r.uncertainty_per_revolution)
            est_lines.setdefault(key, estimator_line(r.settings, sec.period))
        rows.append(row)
    out = pd.DataFrame(rows)
    out.attrs["estimators"] = est_lines     # (estimator, rtol) key -> line from the results' settings
    return out


# ------------------------------------------------------------------------------------- figures


def _fmt_value(name, v):
    _, _, scale, unit, _ = SWEEPS[name]
    return f"{v * scale:.4g} {unit}" if unit != "−" else f"{v:.4g}"


def lam_ylim(points: dict):
    """A common y-range for the λ1 panels of the sweeps (they are compared); exponents above
    LAMBDA_CLIP are drawn on the upper edge with their value."""
    lo, hi = [-1.0], [1.0]
    for pts in points.values():
        ok = pts[(pts["status"] == "ok") & np.isfinite(pts["lambda_per_rev"])]
        if len(ok):
            lo.append(float((ok["lambda_per_rev"] - ok["lambda_unc_per_rev"]).min()))
            hi.append(float((ok["lambda_per_rev"] + ok["lambda_unc_per_rev"]).max()))
    lo, hi = min(lo), min(max(hi), LAMBDA_CLIP)
    pad = 0.08 * (hi - lo)
    return lo - pad, hi + pad


def _fig_sweep(rep, name, sw, pts, st, ylim, elim):
    param, label, scale, unit, log = SWEEPS[name]
    fixed = FIXED[name]
    with rep.style():
        fig, (a1, a2, a3) = rep.subplots(3, 1, sharex=True,
                                         title=f"Bifurcation diagram and largest Lyapunov exponent "
                                               f"against the {label} ({fixed})")
        ok = sw[sw["status"] == "ok"]
        # eccentricity over the clearance of the point: comparable across sweeps and clearances
        ec = with_ec(ok, [_clearance(name, v) for v in ok["value"].astype(float)])
        xs = ec["value"].astype(float).to_numpy() * scale
        for ax, col in ((a1, "B.ex/c"), (a2, "B.ey/c")):
            ax.scatter(xs, ec[col], s=4, color="tab:blue", linewidths=0, label="section points")
            for yv in (-1.0, 1.0):
                ax.axhline(yv, color="0.6", lw=0.6, ls=":")
            ax.set_ylabel(f"journal {col.replace('B.', 'e_').replace('/c', '')} / c [−]")
            ax.set_ylim(-elim, elim)
        a1.legend(loc="upper right", fontsize=7.5)
        x = pts["value"].to_numpy(float) * scale
        lam, unc = pts["lambda_per_rev"].to_numpy(float), pts["lambda_unc_per_rev"].to_numpy(float)
        a3.plot(x, lam, color="0.6", lw=0.8)
        for v, colr in VERDICT_COLORS.items():
            sel = (pts["verdict"] == v).to_numpy()
            if sel.any():
                a3.errorbar(x[sel], lam[sel], yerr=unc[sel], fmt="o", ms=3.5, capsize=2,
                            color=colr, label=f"{v} ({int(sel.sum())})")
        for xi, p in zip(x, pts["period_c"]):
            if p:
                a3.annotate(f"P{p}", (xi, 0), textcoords="offset points", xytext=(0, 6), fontsize=7,
                            ha="center", color="tab:blue")
        a3.axhline(0.0, color="k", lw=0.8, ls="--")
        a3.set_ylim(*ylim)
        for xi, li, ui in zip(x, lam, unc):
            if li > ylim[1]:
                a3.annotate(f"↑ {li:.3g} ± {ui:.2g}", (xi, ylim[1]), textcoords="offset points",
                            xytext=(4, -12), fontsize=7.5, color="tab:red")
        a3.set_ylabel("λ1 [1/revolution]")
        a3.set_xlabel(f"{label} [{unit}]")
        a3.legend(loc="upper right", fontsize=7.5)
        if log:
            a3.set_xscale("log")
    rep.figure(fig, caption=(f"Each parameter value: {st['transient_revs']} transient revolutions, then "
                             f"{st['revs']} stroboscopic section points (t = kT) of the journal centre "
                             "relative to the bearing centre, divided by the clearance c of the point (top: "
                             "e_x / c, middle: e_y / c; ±1, dotted: the journal touches the bearing; the same "
                             "axes in every sweep; a single point per value = period 1, a vertical spread = a "
                             "non-periodic motion). Bottom: the largest Lyapunov exponent per crank revolution "
                             "± its uncertainty, from the end of the section (the same λ1 range in every "
                             f"sweep); red: λ1 − uncertainty > 0 over at least {MIN_SECTION_POINTS} section "
                             f"points (chaotic), orange: λ1 − uncertainty > 0 over fewer ('{SHORT}', not "
                             "called chaotic), blue: λ1 + uncertainty < 0 (regular), grey: undecided; 'Pn': "
                             "the section repeats with period n to 1e-4 of the clearance. λ1: "
                             + sweep_estimator_line(sw) + "."))


def _state_title(k, s):
    return (f"{k} candidate" if k == CHAOTIC and s["verdict"] != CHAOTIC else k)


def _fig_states(rep, states):
    from nld.output.plots import exponent_convergence
    names = [k for k in ("regular", "chaotic") if states.get(k)]
    if not names:
        return False
    lo, hi = [0.0], [0.0]            # convergence panels on a common y-range (first tenth left out)
    for k in names:
        ly = states[k]["lyap"]
        h = np.asarray(ly.history, float) * ly.period
        h = h[len(h) // 10:]
        f, u = float(ly.per_revolution), float(ly.uncertainty_per_revolution)
        lo += [float(np.nanmin(h)) if h.size else f, f - u]
        hi += [float(np.nanmax(h)) if h.size else f, f + u]
    pad = 0.08 * max(max(hi) - min(lo), 1.0)
    th = np.linspace(0, 2 * np.pi, 300)
    lim = ec_limit(*[with_ec(states[k]["section"].table, states[k]["clearance"]) for k in names], floor=EC_LIM)
    with rep.style():
        fig, axes = rep.subplots(2, len(names), squeeze=False,
                                 title="Poincaré maps (once per crank revolution) of a regular and a "
                                       "chaotic state, and their exponents")
        for j, k in enumerate(names):
            s = states[k]
            pt = s["point"]
            sec = s["section"]
            ax = axes[0, j]
            tab = with_ec(sec.table, s["clearance"])
            ax.scatter(tab["B.ex/c"], tab["B.ey/c"], s=6, linewidths=0,
                       color=VERDICT_COLORS.get(s["verdict"], "k"), label="section points")
            ax.plot(np.cos(th), np.sin(th), color="0.5", lw=0.7, ls=":", label="clearance circle e = c")
            ax.set_aspect("equal", adjustable="box")
            ax.set_xlim(-lim, lim)
            ax.set_ylim(-lim, lim)
            ax.set_xlabel("journal e_x / c [−]")
            ax.set_ylabel("journal e_y / c [−]")
            ax.legend(loc="lower left", fontsize=7)
            ax.set_title(f"{_state_title(k, s)}: {SWEEPS[pt['sweep']][1]} = {_fmt_value(pt['sweep'], pt['value'])}; "
                         f"{s['section_points']} points, period {s['period'] or 'none'} (n ≤ 16)", fontsize=9)
            ly = s["lyap"]
            exponent_convergence(ly, per_revolution=True, ax=axes[1, j], labels=["running estimate"],
                                 title=f"{_state_title(k, s)}: λ1 = {ly.per_revolution:.3g} ± "
                                       f"{ly.uncertainty_per_revolution:.2g} per revolution ({s['verdict']})")
            axes[1, j].set_ylim(min(lo) - pad, max(hi) + pad)
            axes[1, j].set_ylabel("λ1 [1/revolution]")
            axes[1, j].set_xlabel("averaging time [revolutions]")
            axes[1, j].legend(loc="upper right", fontsize=7.5)
    ests = []
    for k in names:
        e = estimator_line(states[k]["lyap"].settings, states[k]["lyap"].period)
        if e not in [x for _, x in ests]:
            ests.append((k, e))
    est = " | ".join(e if len(ests) == 1 else f"{k}: {e}" for k, e in ests)
    rep.figure(fig, caption=("Top: stroboscopic Poincaré maps of the journal centre (relative to the bearing "
                             "centre, over the clearance c; both on the same axes), after the transient; "
                             "dotted: the clearance circle. Bottom: running estimate of λ1 from the end of "
                             "the section (band: final ± uncertainty; both on the same y-range). A state is "
                             f"called chaotic only when λ1 − uncertainty > 0 over a section of at least "
                             f"{MIN_SECTION_POINTS} points (else '{SHORT}'). The regular state contracts "
                             "(λ1 < 0) onto a point or a few points, the chaotic one spreads over a strange "
                             f"set. λ1: {est}."))
    return True


def _fig_state_other(rep, states):
    from nld.output.plots import poincare_scatter
    names = [k for k in ("regular", "chaotic") if states.get(k)]
    if not names:
        return False
    with rep.style():
        fig, axes = rep.subplots(1, len(names), squeeze=False,
                                 title="The same Poincaré maps in the slider velocity and rod angular velocity")
        for j, k in enumerate(names):
            sec = states[k]["section"]
            ax = axes[0, j]
            tab = sec.table
            if k == REGULAR:
                # a tight cluster: deviations from its mean point
                mv, mw = float(tab["slider.vx"].mean()), float(tab["rod.omega"].mean())
                tab = tab.assign(**{"slider.vx": (tab["slider.vx"] - mv) * 1e6, "rod.omega": (tab["rod.omega"] - mw) * 1e6})
                poincare_scatter(tab, "slider.vx", "rod.omega", ax=ax, s=6,
                                 color=VERDICT_COLORS.get(states[k]["verdict"], "tab:blue"))
                ax.set_xlabel(f"slider velocity v_x − ({mv:.6g} m/s) [µm/s]")
                ax.set_ylabel(f"rod angular velocity ω − ({mw:.6g}) [µrad/s]")
            else:
                poincare_scatter(tab, "slider.vx", "rod.omega", ax=ax, s=6,
                                 color=VERDICT_COLORS.get(states[k]["verdict"], "tab:red"))
                ax.set_xlabel("slider velocity v_x [m/s]")
                ax.set_ylabel("rod angular velocity ω [rad/s]")
            ax.set_title(_state_title(k, states[k]), fontsize=9)
    rep.figure(fig, caption="The section points of the previous page in two velocity coordinates (regular state: "
                            "deviations from the mean point, in micro-units: a period-1 point being approached, down "
                            "to the floor set by the integration and the friction regularisation).")
    return True


# ---------------------------------------------------------------------------------------- text


def _f(v, unit="", digits=3):
    if v is None or v != v:
        return "n/a"
    return f"{v:.{digits}g}" + (f" {unit}" if unit else "")


def _onset_lines(points):
    out = []
    for name, pts in points.items():
        param, label, scale, unit, log = SWEEPS[name]
        win = chaotic_windows(pts)
        zc = zero_crossings(pts, log)
        lo, hi = pts["value"].min(), pts["value"].max()
        ws = "; ".join(f"{_fmt_value(name, a)} to {_fmt_value(name, b)} ({n} point{'s' if n > 1 else ''})"
                       for a, b, n in win) or "none"
        zs = ", ".join(f"{_fmt_value(name, v)} (λ1 {'rises' if d == 'up' else 'falls'} through 0)"
                       for v, d in zc) or "none"
        out.append(f"- {label} ({_fmt_value(name, lo)} to {_fmt_value(name, hi)}, {len(pts)} points): chaotic "
                   f"windows: {ws}. λ1 = 0 crossings (interpolated between neighbouring points): {zs}.")
    return out


def _texts(points, summary, states, st, mode_label, tolcheck=None):
    s = summary.set_index("sweep")
    sp, cl, fr, sl = points["speed"], points["clearance"], points["friction"], points["speed_mu0.05"]

    def at(pts, v):
        i = int(np.argmin(np.abs(pts["value"].to_numpy(float) - v)))
        r = pts.iloc[i]
        return r

    base_sp = at(sp, SPEED0)
    intro = [
        f"Source: {CITATION}. Olyaei & Ghazavi study a slider-crank with a clearance at the connecting rod - "
        "slider joint, Lankarani-Nikravesh contact and modified Coulomb friction, show with Poincaré maps, "
        "bifurcation diagrams and the largest Lyapunov exponent that its motion can be periodic or chaotic "
        "depending on the parameters, and then stabilise the chaotic motion by delayed feedback control.",
        "What the source reported, as far as known here (shared/references.md, section 3): the model and the "
        "methods above [U]; no numbers. Their link data, clearance, speeds and the parameter values at which "
        "they find chaos could not be confirmed, and no published numeric Lyapunov exponent for a clearance "
        "slider-crank was found. Related statements to test: chaos appears at high crank speed and low "
        "friction with near-elastic impacts (Farahanchi & Shaw 1991) [V abstract]; nonlinearity depends on "
        "the clearance size (Rhee & Akay 1996) [U]. The comparison is therefore one of kind (are there "
        "periodic and chaotic regimes, in which direction of each parameter), not of numbers; the "
        "control part of the paper is not repeated.",
        f"What is repeated ({mode_label}): scene 'slider_crank_olyaei' = the Flores benchmark (crank 0.05 m, "
        "rod 0.12 m, 0.5 mm radial clearance at B, journal 9.5 mm, restitution 0.9, 5000 rpm) with Ambrosio's "
        "modified Coulomb friction μ = 0.1 (v0 = 1e-4, v1 = 1e-2 m/s). Four sweeps with nld.analysis.bifurcation.sweep: "
        f"the crank speed ({len(sp)} values, {_fmt_value('speed', sp['value'].min())} to "
        f"{_fmt_value('speed', sp['value'].max())}), the clearance ({len(cl)} values, "
        f"{_fmt_value('clearance', cl['value'].min())} to {_fmt_value('clearance', cl['value'].max())}, "
        f"log-spaced), the friction coefficient ({len(fr)} values), and the crank speed again at μ = 0.05 "
        f"({len(sl)} values; the friction sweep puts this value on the chaotic side). Each point starts from the assembled "
        f"ideal state, runs {st['transient_revs']} transient revolutions and {st['revs']} section points at "
        f"rtol {st['rtol']:g} (error control scaled by the clearance), then λ1 from the tangent dynamics "
        f"(nld.analysis.lyapunov.lyapunov_tangent: the variational equations integrated with the trajectory, "
        f"each contact onset and separation mapped by its saltation matrix, Gram-Schmidt 8 times a "
        f"revolution, 2 revolutions of alignment) over {st['lyap_revs']} revolutions at rtol "
        f"{st['lyap_rtol']:g}. Verdict: chaotic if λ1 − uncertainty > 0, "
        "regular if λ1 + uncertainty < 0 (the uncertainty is a block standard error plus the spread of the "
        "running estimate). Exponents are per crank revolution (natural log): a separation grows by e^λ1 "
        f"each revolution. A point is called chaotic only when, in addition, its section has at least "
        f"{MIN_SECTION_POINTS} points; a positive exponent over a shorter section reads '{SHORT}'. "
        "Eccentricities are shown over the clearance (e/c, ±1 = touching the bearing) so that sweeps "
        "and clearances compare.",
    ]
    reg, cha = states.get("regular"), states.get("chaotic")
    found = [
        "What we find:",
        f"- Both regimes exist. {tally_text(verdict_counts(points))}. "
        f"At the scene's own point (5000 rpm, c = 0.5 mm, μ = 0.1) λ1 = {_f(base_sp['lambda_per_rev'])} ± "
        f"{_f(base_sp['lambda_unc_per_rev'], digits=2)} per revolution ({base_sp['verdict']}).",
        f"- Crank speed: λ1 from {_f(s.loc['speed', 'min_lambda_per_rev'])} (at "
        f"{_fmt_value('speed', s.loc['speed', 'argmin_value'])}) to {_f(s.loc['speed', 'max_lambda_per_rev'])} "
        f"per revolution (at {_fmt_value('speed', s.loc['speed', 'argmax_value'])}).",
        f"- Clearance: λ1 from {_f(s.loc['clearance', 'min_lambda_per_rev'])} (at "
        f"{_fmt_value('clearance', s.loc['clearance', 'argmin_value'])}) to "
        f"{_f(s.loc['clearance', 'max_lambda_per_rev'])} (at "
        f"{_fmt_value('clearance', s.loc['clearance', 'argmax_value'])}).",
        f"- Friction: λ1 from {_f(s.loc['friction', 'min_lambda_per_rev'])} (at μ = "
        f"{_fmt_value('friction', s.loc['friction', 'argmin_value'])}) to "
        f"{_f(s.loc['friction', 'max_lambda_per_rev'])} (at μ = "
        f"{_fmt_value('friction', s.loc['friction', 'argmax_value'])}); at μ = 0 λ1 = "
        f"{_f(at(fr, 0.0)['lambda_per_rev'])} ({at(fr, 0.0)['verdict']}).",
        f"- Crank speed at μ = 0.05: λ1 from {_f(s.loc['speed_mu0.05', 'min_lambda_per_rev'])} (at "
        f"{_fmt_value('speed', s.loc['speed_mu0.05', 'argmin_value'])}) to "
        f"{_f(s.loc['speed_mu0.05', 'max_lambda_per_rev'])} (at "
        f"{_fmt_value('speed', s.loc['speed_mu0.05', 'argmax_value'])}); {int(s.loc['speed_mu0.05', 'chaotic'])} "
        f"of {int(s.loc['speed_mu0.05', 'points'])} points chaotic.",
    ]
    if reg:
        found.append(f"- Regular showcase ({SWEEPS[reg['point']['sweep']][1]} = "
                     f"{_fmt_value(reg['point']['sweep'], reg['point']['value'])}): {len(reg['section'].table)} "
                     f"section points spread over {_f(reg['spread_m'] * 1e6, 'µm')}, detected period "
                     f"{reg['period'] or 'none'} (n ≤ 16, to 1e-4 of the clearance); λ1 = {_f(reg['lyap'].per_revolution)} ± "
                     f"{_f(reg['lyap'].uncertainty_per_revolution, digits=2)} per revolution at rtol "
                     f"{st['case_lyap_rtol']:g} over {st['case_lyap_revs']} revolutions (sweep: "
                     f"{_f(reg['point']['lambda_per_rev'])} ± {_f(reg['point']['lambda_unc_per_rev'], digits=2)}).")
    else:
        found.append("- No regular point was found in the sweeps: no regular showcase.")
    if cha and len(cha["tried"]) > 1:
        found.append("- Chaotic candidates that did not stay chaotic over the longer run (transient chaos or an "
                     "unconverged sweep exponent): " + "; ".join(
                         f"{SWEEPS[t['sweep']][1]} = {_fmt_value(t['sweep'], t['value'])}: λ1 = "
                         f"{_f(t['lambda_per_rev'])} ± {_f(t['lambda_unc_per_rev'], digits=2)}"
                         for t in cha["tried"][:-1]) + ".")
    if cha:
        found.append(f"- {'Chaotic showcase' if cha['verdict'] == CHAOTIC else 'Chaotic candidate showcase'} "
                     f"({SWEEPS[cha['point']['sweep']][1]} = "
                     f"{_fmt_value(cha['point']['sweep'], cha['point']['value'])}): {len(cha['section'].table)} "
                     f"section points spread over {_f(cha['spread_m'] * 1e6, 'µm')}; λ1 = "
                     f"{_f(cha['lyap'].per_revolution)} ± {_f(cha['lyap'].uncertainty_per_revolution, digits=2)} "
                     f"per revolution at rtol {st['case_lyap_rtol']:g} over {st['case_lyap_revs']} revolutions "
                     f"(sweep: {_f(cha['point']['lambda_per_rev'])} ± "
                     f"{_f(cha['point']['lambda_unc_per_rev'], digits=2)}); verdict: {cha['verdict']}"
                     + (f" (a section of fewer than {MIN_SECTION_POINTS} points is not called chaotic)"
                        if cha["verdict"] == SHORT else "") + ".")
    else:
        found.append("- No chaotic point was found in the sweeps: no chaotic showcase.")
    if tolcheck is not None and len(tolcheck):
        parts = []
        for _, r in tolcheck.iterrows():
            vals = ", ".join(f"{_f(r[f'lambda {_tc_key(est, rt)}'])} ({est}, rtol {rt:g})"
                             for est, rt in TOL_CHECK)
            u = check_uncertainty(r["sweep_lambda_per_rev"], r["sweep_unc_per_rev"],
                                  [r[f"lambda {_tc_key(est, rt)}"] for est, rt in TOL_CHECK])
            parts.append(f"{r['sweep']} sweep at {_fmt_value(r['sweep'], r['value'])}: {vals}; so λ1 = "
                         f"{_f(r['sweep_lambda_per_rev'])} ± {_f(u, digits=2)}")
        found.append("- Tolerance check of the largest exponent of each sweep (the uncertainty stated with it "
                     "includes the spread between the check runs): " + "; ".join(parts) + ".")
    onset = ["Where chaos sets in (per sweep):", *_onset_lines(points)]
    allp = pd.concat(points.values(), ignore_index=True)
    big = allp[allp["lambda_per_rev"] > LAMBDA_CLIP]
    if len(big):
        onset.append(f"- Exponents above {LAMBDA_CLIP:g} per revolution (" + "; ".join(
            f"{SWEEPS[r['sweep']][1]} = {_fmt_value(r['sweep'], r['value'])}: {_f(r['lambda_per_rev'])} ± "
            f"{_f(r['lambda_unc_per_rev'], digits=2)}" for _, r in big.iterrows())
            + ") carry uncertainties of a third of their value or more and exceed the frictionless benchmark's "
            "10 per revolution (docs/lyapunov.md) several times: single large jumps of the separation (a contact "
            "re-onset at a tiny approach velocity changes the Lankarani-Nikravesh damping of that contact, "
            "docs/lyapunov.md) dominate them. Read them as 'not regular over this window', not as values; the "
            "chaotic-showcase candidates above show whether such a state stays chaotic over a longer run.")
    # trends against the literature's statements, from the data
    def mean_lam(pts, sel):          # the median: robust to the few unconverged large exponents
        v = pts.loc[sel & (pts["status"] == "ok"), "lambda_per_rev"]
        return float(v.median()) if len(v) else math.nan
    def halves(pts):
        v = pts["value"].to_numpy(float)
        return mean_lam(pts, v >= np.median(v)), mean_lam(pts, v < np.median(v))
    hi_sp, lo_sp = halves(sp)
    hi_sl, lo_sl = halves(sl)
    frv = fr["value"].to_numpy(float)
    lo_fr, hi_fr = mean_lam(fr, frv <= 0.02), mean_lam(fr, frv >= 0.1)
    clv = cl["value"].to_numpy(float)
    lo_cl, hi_cl = mean_lam(cl, clv < np.median(clv)), mean_lam(cl, clv >= np.median(clv))
    trends = [
        "Against the literature's statements:",
        f"- 'Chaos at high crank speed': at μ = 0.1, {int(s.loc['speed', 'chaotic'])} of "
        f"{int(s.loc['speed', 'points'])} speeds are chaotic (median λ1 {_f(hi_sp)} over the upper half of the "
        f"range, {_f(lo_sp)} over the lower half): "
        + ("NOT reproduced at μ = 0.1: no speed in the range is chaotic. " if int(s.loc['speed', 'chaotic']) == 0 else
           ("higher speeds are more chaotic, as stated. " if hi_sp > lo_sp else
            "higher speeds are not more chaotic. "))
        + f"At μ = 0.05, {int(s.loc['speed_mu0.05', 'chaotic'])} of {int(s.loc['speed_mu0.05', 'points'])} speeds "
        f"are chaotic" + (f", from {_fmt_value('speed', s.loc['speed_mu0.05', 'first_chaotic_value'])} to "
                          f"{_fmt_value('speed', s.loc['speed_mu0.05', 'last_chaotic_value'])}"
                          if int(s.loc['speed_mu0.05', 'chaotic']) else "")
        + f" (median λ1 {_f(hi_sl)} over the upper half, {_f(lo_sl)} over the lower half): "
        + ("chaos appears only at high speed, as stated, when the friction is low enough."
           if int(s.loc['speed_mu0.05', 'chaotic']) and hi_sl > lo_sl and
           s.loc['speed_mu0.05', 'first_chaotic_value'] >= np.median(sl['value']) else
           "the statement is not reproduced in this form."),
        f"- 'Chaos at low friction': median λ1 for μ ≤ 0.02 {_f(lo_fr)}, for μ ≥ 0.1 {_f(hi_fr)} per revolution: "
        + ("low friction is more chaotic, as stated." if lo_fr > hi_fr else
           "NOT reproduced: low friction is not more chaotic here."),
        f"- Clearance size (5000 rpm, μ = 0.1): median λ1 over the smaller half of the clearances {_f(lo_cl)}, "
        f"over the larger half {_f(hi_cl)} per revolution; {int(s.loc['clearance', 'chaotic'])} of "
        f"{int(s.loc['clearance', 'points'])} clearances chaotic"
        + (f", all between {_fmt_value('clearance', s.loc['clearance', 'first_chaotic_value'])} and "
           f"{_fmt_value('clearance', s.loc['clearance', 'last_chaotic_value'])}: the regularity depends on the "
           "clearance, but not monotonically (chaotic windows between regular clearances)."
           if int(s.loc['clearance', 'chaotic']) else ": no clearance is chaotic here."),
    ]
    why = [
        "Why our results may differ from the paper's:",
        "- Parameters. The paper's own link data, clearance, friction law constants and speeds could not be "
        "confirmed; the scene keeps the Flores bodies, clearance and 5000 rpm and takes μ = 0.1, v0, v1 from "
        "Flores et al. (2006) (docs/models/slider_crank.md). Where chaos sets in depends on all of them: "
        "the friction sweep shows that μ alone moves the motion between chaos and regularity.",
        "- Friction regularisation. Ambrosio's law has no stiction and vanishes below v0 = 1e-4 m/s; in "
        "continuous contact the friction damps the journal's sliding and rolling along the bearing wall, "
        "which is what makes the default point regular here. Another friction law (LuGre, plain Coulomb) "
        "or other v0, v1 would change the boundaries.",
        "- Method. The paper integrates in absolute coordinates with constraint stabilisation (usual in "
        "this literature); nld uses minimal coordinates (the clearance cuts the only loop) and adaptive "
        "Dormand-Prince with located contact events. λ1 here comes from the tangent (variational) "
        "dynamics integrated in lock step with the trajectory, with a saltation matrix at every contact "
        "event (docs/lyapunov.md); an exponent from a time series "
        "(Wolf/Rosenstein) or from a stroboscopic map would differ in value, not in sign, for a clear case.",
        f"- Finite runs. {st['transient_revs']} transient revolutions and {st['lyap_revs']}-revolution "
        "exponents: long transients (chaotic transients before a periodic attractor, or the reverse) "
        "are possible near the boundaries; points marked 'uncertain' and single isolated chaotic or regular "
        "points should be read as the boundary's width, not as a resolved structure. Quick mode uses far "
        "shorter runs and a looser tolerance: its verdicts are indicative only.",
        "- Period detection. The sweep's own test (successive points equal to 1e-6 of their spread, column "
        "section_period) never finds a period here: the section points of a regular state still scatter by "
        "about 1e-5 of the clearance from revolution to revolution (integration tolerance and the friction "
        "regularisation; a floor also seen on the four-bar, docs/analysis.md). The report therefore calls a "
        f"section periodic when its points repeat to {PERIOD_TOL_C:g} of the clearance (column period_c).",
        "- Tolerance and estimator. An earlier version of this study used two trajectories (Benettin) "
        "whose perturbed copy kept the contact memory of the unperturbed one; in long contacts this "
        "injected spurious growth at every renormalisation, and λ1 moved 10-100x with the tolerance "
        "(issue 13). The tangent estimator has no separation to choose and maps every contact event "
        f"exactly; the sweeps use it at rtol {st['lyap_rtol']:g}, and the tolerance-check table "
        "recomputes the largest exponent of each sweep at three tolerances and with the (fixed) "
        "two-trajectory estimator as an independent check.",
    ]
    return intro, found, onset + trends, why


def _run_table(walls, states, sweeps):
    rows = []
    for name, w in walls.items():
        if name not in sweeps:
            rows.append({"run": name, "points": None, "failed": None, "wall time": round(w, 1)})
            continue
        first = sweeps[name].drop_duplicates(["direction", "index"])
        rows.append({"run": f"sweep {name}", "points": len(first), "failed": int((first["status"] != "ok").sum()),
                     "wall time": round(w, 1)})
    for k, s in states.items():
        if s:
            rows.append({"run": f"state {k}", "points": len(s["section"].table), "failed": int(not s["success"]),
                         "wall time": round(s["wall_s"], 1)})
    from nld.study import drop_timing
    return drop_timing(pd.DataFrame(rows), "wall time")


# ----------------------------------------------------------------------------------------- main


def main(quick: bool = False, out_dir: Path = Path("reports"), *, smoke: bool = False) -> Path:
    """Run the study; write the PDF and the data files; return the PDF's path.

    Full: speed (45 values, 500-6000 rpm), clearance (29, 0.02-0.5 mm), friction (10) and speed at
    mu = 0.05 (23 values) sweeps, 100 transient + 64 section revolutions at rtol 1e-8, λ1 over 64
    revolutions at rtol 1e-10; showcase states 100 + 300 revolutions, λ1 over 200 at rtol 1e-10.
    quick: 3 + 2 + 2 + 2 points, 10 + 12 revolutions at rtol 1e-7 (λ1 at 1e-10). smoke: fewer still.
    """
    from nld.study import Study
    study = Study(globals(), quick, out_dir, smoke=smoke)
    st = study.settings
    st["workers"] = study.workers(st["workers"])
    base = load_base()
    sweeps, walls = run_sweeps(st)
    points = _timed(walls, "verdict check", check_points, st,
                    {name: sweep_points(name, df) for name, df in sweeps.items()}, sweeps)
    cen = _timed(walls, "attractor census", run_census, study, st, points)
    summary = summary_table(points)
    states = showcase_states(points, st, walls)
    tolcheck = _timed(walls, "tolerance check", tolerance_check, points, st)
    route = run_routes(study, st, sweeps, points)   # the period-1 orbits continued (ROUTE_SWEEPS)
    walls["route to chaos"] = sum(r["wall_s"] for r in route["routes"].values())
    total_wall = study.elapsed()
    _provenance(study, base, sweeps, summary, states, tolcheck, walls, total_wall)
    stacked = _save(study, sweeps, points, summary, tolcheck, states, cen)
    save_route(study, route["routes"], route["table"], sde())
    _report(study, base, sweeps, points, summary, states, tolcheck, walls, stacked, total_wall, route,
            cen)
    return study.pdf


# the route's agreement check: a branch orbit called stable lies on the brute-force section when the
# section's last points are within ROUTE_TOL x the clearance of it (after 100 transient revolutions
# at rtol 1e-8)
ROUTE_TOL = 1e-3
# the route pages: sweep -> (symbol, logarithmic parameter axis)
ROUTE_SYMBOLS = {"speed": ("ω", False), "clearance": ("c", True), "friction": ("μ", False),
                 "speed_mu0.05": ("ω", False)}


# the sweeps whose period-1 orbit is continued: sweep -> the settings key of its route (the others'
# rows come from the brute force alone)
ROUTE_SWEEPS = {"friction": "route", "clearance": "route_clearance"}


def run_routes(study, st, sweeps, points) -> dict:
    """The route to chaos of every sweep (nld.analysis.route): the period-1 orbit of each sweep of
    ROUTE_SWEEPS whose settings key is in ``st`` (st["route"]: friction, st["route_clearance"]:
    clearance) continued over its values and checked against the brute-force section at each sweep
    value it spans (to ROUTE_TOL x the route's start clearance: C0, or its start in the clearance
    sweep); the route rows of every sweep (the others from the brute force alone). Returns
    {"routes": {sweep: route}, "agrees": {sweep: agreement}, "table"}."""
    from nld.analysis.route import agreement, route_table, run_route
    routes, agrees = {}, {}
    for name, key in ROUTE_SWEEPS.items():
        if st.get(key):
            routes[name] = run_route(study, SCENE, st[key], observables=["B.ex", "B.ey"])
            scale = st[key]["start"] if name == "clearance" else C0
            agrees[name] = agreement(routes[name], sweeps[name], ["B.ex", "B.ey"], scale,
                                     tol=ROUTE_TOL)
    table = pd.concat([route_table(name, SWEEPS[name][0], points[name], period_col="period_c",
                                   route=routes.get(name), agree=agrees.get(name))
                       for name in SWEEPS], ignore_index=True)
    return {"routes": routes, "agrees": agrees, "table": table}


def load_base():
    """The scene, checked to have the clearance C0 the study assumes."""
    from nld.model.scene import load_scene
    base = load_scene(SCENE)
    if abs(base.joints["B"].clearance - C0) > 1e-12:
        raise RuntimeError(f"scene {SCENE}: clearance at B {base.joints['B'].clearance!r} m, the study "
                           f"assumes C0 = {C0!r} m")
    return base


def _timed(walls: dict, key: str, fn, *args):
    """fn(*args), its wall time (s) put into walls[key]."""
    t0 = time.perf_counter()
    out = fn(*args)
    walls[key] = time.perf_counter() - t0
    return out


def showcase_states(points: dict, st: dict, walls: dict) -> dict:
    """The regular and the chaotic showcase state ({"regular": ..., "chaotic": ...}, None where no
    point qualifies): the chaotic candidates are tried in order until one has lambda - unc > 0."""
    reg_pt, cha_cands = pick_states(points)
    states = {"regular": None, "chaotic": None}
    t_st = time.perf_counter()
    if reg_pt is not None:
        states["regular"] = dict(run_state(reg_pt, st), point=reg_pt, tried=[])
    tried = []
    for pt in cha_cands:
        s = dict(run_state(pt, st), point=pt)
        tried.append({"sweep": pt["sweep"], "value": float(pt["value"]),
                      "lambda_per_rev": float(s["lyap"].per_revolution),
                      "lambda_unc_per_rev": float(s["lyap"].uncertainty_per_revolution)})
        s["tried"] = tried
        states["chaotic"] = s
        if s["lyap"].per_revolution - s["lyap"].uncertainty_per_revolution > 0:
            break
    walls["showcase states"] = time.perf_counter() - t_st
    return states


def _provenance(study, base, sweeps, summary, states, tolcheck, walls, total_wall):
    from nld.study import sde
    st = study.settings
    state_rec = {k: (None if s is None else
                     {"sweep": s["point"]["sweep"], "value": float(s["point"]["value"]), "overrides": s["overrides"],
                      "lambda_per_rev": float(s["lyap"].per_revolution),
                      "lambda_unc_per_rev": float(s["lyap"].uncertainty_per_revolution),
                      "period": s["period"], "spread_m": s["spread_m"], "success": s["success"],
                      "section_points": s["section_points"], "verdict": s["verdict"],
                      "message": s["message"], "candidates_tried": s["tried"],
                      **({} if sde() else {"wall_s": s["wall_s"]})})
                 for k, s in states.items()}
    study.provenance(
        scene=base,
        integrator="dopri5 (adaptive Dormand-Prince 5(4)), nld.analysis.bifurcation.sweep / nld.analysis.lyapunov",
        source=CITATION, **{k: v for k, v in st.items() if k not in SETTINGS_KEY.values()},
        speeds_rad_s=[float(v) for v in st["speeds"]],
        speeds_low_mu_rad_s=[float(v) for v in st["speeds_low_mu"]],
        clearances_m=[float(v) for v in st["clearances"]],
        frictions=[float(v) for v in st["frictions"]],
        observables=OBS, states=state_rec, summary=summary.to_dict(orient="records"),
        min_section_points=MIN_SECTION_POINTS,
        sweep_estimator={name: sweep_estimator_line(df) for name, df in sweeps.items()},
        tolcheck_estimator=dict(tolcheck.attrs.get("estimators", {})),
        state_estimator={k: estimator_line(s["lyap"].settings, s["lyap"].period) for k, s in states.items() if s},
        **({} if sde() else {"wall_s": {"sweeps": walls, "total_before_report": total_wall}}))


def _save(study, sweeps, points, summary, tolcheck, states, cen=None) -> dict:
    stacked = {}
    for name, df in sweeps.items():
        # with the eccentricity over the clearance of the point (B.ex/c, B.ey/c) as plotted
        d = with_ec(df, [_clearance(name, v) for v in df["value"].astype(float)])
        d.attrs = {}
        stacked[name] = d
    study.save(".parquet", stacked)
    study.save("_points.csv", pd.concat(points.values(), ignore_index=True))
    study.save("_summary.csv", summary)
    study.save("_tolcheck.csv", tolcheck)
    if cen is not None:
        study.prov["census"] = dict(settings=study.settings["census"],
                                    points=sorted(set(cen["point"])))
        study.save("_census.csv", cen)
    secs = {k: with_ec(s["section"].table, s["clearance"]) for k, s in states.items() if s}
    if secs:
        study.save("_sections.parquet", secs)
    return stacked


def _report(study, base, sweeps, points, summary, states, tolcheck, walls, stacked, total_wall,
            route=None, cen=None):
    from nld.study import census_page, timing
    st, mode_label, prov = study.settings, study.label, study.prov
    report_settings = {
        "Mode": mode_label,
        "Sweeps": (f"speed {len(st['speeds'])}, clearance {len(st['clearances'])}, friction "
                   f"{len(st['frictions'])}, speed at μ = 0.05 {len(st['speeds_low_mu'])} values"),
        "Per point": f"{st['transient_revs']} transient + {st['revs']} section revolutions",
        "rtol": st["rtol"],
        "atol": "rtol x clearance scales",
        "λ1 (sweeps)": f"tangent (saltation), {st['lyap_revs']} rev, rtol {st['lyap_rtol']:g}",
        "Showcase states": (f"{st['case_transient']} + {st['case_revs']} rev, λ1 over {st['case_lyap_revs']} rev "
                            f"at rtol {st['case_lyap_rtol']:g}"),
        "Workers": st["workers"],
        "Wall time (runs)": timing(f"{total_wall:.0f} s"),
    }
    rep = study.report(report_settings, scene=base,
                       subject="Chaos in the clearance slider-crank (Olyaei & Ghazavi 2012 style) with nld",
                       keywords=["clearance joint", "slider-crank", "chaos", "Olyaei 2012"])
    intro, found, onset, why = _texts(points, summary, states, st, mode_label, tolcheck)
    with rep:
        rep.text_page("What this report repeats", intro)
        rep.text_page("What we find", found)
        rep.text_page("Where chaos sets in, and the literature's trends", onset)
        rep.text_page("Why the results may differ from the paper's", why)
        shown = summary.drop(columns=["param"]).copy()
        for c in ("argmax_value", "argmin_value", "first_chaotic_value", "last_chaotic_value"):
            shown[c] = [_fmt_value(n, v) if v == v else "–" for n, v in zip(summary["sweep"], summary[c])]
        shown = shown.rename(columns={"max_lambda_per_rev": "max λ1", "min_lambda_per_rev": "min λ1",
                                      "argmax_value": "at", "argmin_value": "at ", "periodic_sections": "periodic",
                                      "first_chaotic_value": "first chaotic", "last_chaotic_value": "last chaotic",
                                      "chaotic_windows": "windows", "lambda_zero_crossings": "λ1 = 0 crossings",
                                      "positive_short": "λ1 > 0 short"})
        rep.table("Summary of the sweeps", shown, col_units={"max λ1": "1/rev", "min λ1": "1/rev"},
                  notes=["Verdicts are checked: every point not called regular is run again from the assembly "
                         f"at {st['check_rtol_factor']:g}x both tolerances with λ1 over {st['check_span']}x the "
                         "span, and keeps its verdict only if the two give the same verdict and exponents within 3x "
                         "their combined uncertainty ('not established' otherwise, "
                         "which the attractor census then replaces: page 'Coexisting motions'; "
                         "columns verdict_main, lambda_check, verdict_check of the points file). "
                         "Per sweep: points by verdict (chaotic: λ1 − uncertainty > 0 over a section of at least "
                         f"{MIN_SECTION_POINTS} points; λ1 > 0 short: λ1 − uncertainty > 0 over fewer, not called "
                         "chaotic; regular: λ1 + uncertainty < 0, else uncertain), sections detected periodic (n ≤ 16), the largest and smallest "
                         "λ1 per revolution and where, the smallest and largest chaotic value, the number of "
                         "contiguous chaotic windows and of sign changes of λ1. Every point in "
                         f"{STEM}_points.csv; each number here follows from that file. λ1 (all sweeps): "
                         + " | ".join(dict.fromkeys(prov["sweep_estimator"].values())) + "."],
                  float_format=lambda v: f"{v:.4g}")
        census_page(rep, cen, st, "sweep point")
        ylim = lam_ylim(points)
        elim = ec_limit(*stacked.values(), floor=EC_LIM)
        for name in SWEEPS:
            _fig_sweep(rep, name, sweeps[name], points[name], st, ylim, elim)
            if route is not None:
                from nld.study import route_page
                _param, label, pscale, punit, _log = SWEEPS[name]
                symbol, logx = ROUTE_SYMBOLS[name]
                tab = route["table"]
                route_page(rep, route["routes"].get(name), sweeps[name], points[name],
                           tab[tab["sweep"] == name], "B.ex", label=f"{label} ({FIXED[name]})",
                           symbol=symbol, scale=1e3, unit="mm", param_scale=pscale,
                           param_unit="" if punit == "−" else punit, logx=logx,
                           agree=route["agrees"].get(name))
        tc = _with_check(tolcheck)
        tc.insert(4, "unc_with_check_per_rev", tc.pop("unc_with_check_per_rev"))
        tc["value"] = [_fmt_value(n, v) for n, v in zip(tc["sweep"], tc["value"])]
        ren = {"sweep_lambda_per_rev": "λ1 (sweep)", "sweep_unc_per_rev": "± (sweep)",
               "unc_with_check_per_rev": "± with the check"}
        for est, rt in TOL_CHECK:
            key = _tc_key(est, rt)
            ren[f"lambda {key}"] = f"λ1 {_tc_label(est, rt)}"
            ren[f"unc {key}"] = f"± {_tc_label(est, rt)}"
        tc = tc.rename(columns=ren)
        rep.table("Tolerance check of the largest exponents", tc,
                  col_units={c: "1/rev" for c in tc.columns if c.startswith(("λ1", "±"))},
                  notes=["For the point with the largest λ1 of each sweep: λ1 per revolution recomputed from the "
                         "end of a fresh section of the same length by the tangent estimator at the rtol given in "
                         "the header, and (B) by the two-trajectory estimator (Benettin, d0 = 1e-4 in the scaled "
                         "norm), an independent check. '± with the check': the sweep's uncertainty and the "
                         "largest distance to a check run in quadrature (the interval to quote). "
                         "The sweeps use the tangent estimator at rtol "
                         f"{st['lyap_rtol']:g}. A sign that changes with the tolerance is a numerical artefact, not "
                         f"chaos. Stored in {STEM}_tolcheck.csv. Settings of each column, from its results: "
                         + " | ".join(f"{_tc_label(*k.split(' rtol=')[0:1], float(k.split('rtol=')[1]))}: {v}"
                                      for k, v in prov["tolcheck_estimator"].items()) + "."],
                  float_format=lambda v: f"{v:.3g}")
        _fig_states(rep, states)
        _fig_state_other(rep, states)
        rep.table("Run statistics", _run_table(walls, states, sweeps), col_units={"wall time": "s"},
                  notes=["Wall time of each sweep (nld.analysis.bifurcation.sweep, "
                         f"{st['workers']} worker process(es)) and of each showcase state on this machine "
                         "(left out when SOURCE_DATE_EPOCH is set). Provenance (versions, git hash, every "
                         "scene parameter, the settings) is in the parquet metadata and its .json sidecar."])


if __name__ == "__main__":
    import sys
    print(main(quick="--quick" in sys.argv, smoke="--smoke" in sys.argv))
