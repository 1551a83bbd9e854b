"""Study: onset of chaos over clearance x friction for the slider-crank and the excavator.

    nld study chaos_onset [--quick] [--out-dir DIR]

For two mechanisms, the largest Lyapunov exponent (per crank revolution) over a grid of clearance size
x friction coefficient, with the onset boundary (the lambda = 0 contour) drawn, by
:func:`nld.analysis.chaos_map.chaos_map` (stroboscopic section, then the tangent-dynamics exponent with saltation
matrices at every contact event from its end, and the
0-1 test of the section where it has >= 30 points):

* ``slider_crank``: scene ``slider_crank_olyaei`` (Flores slider-crank, rod-slider clearance B,
  Ambrosio modified Coulomb friction, 5000 rpm); grid ``joints.B.clearance`` x ``joints.B.friction.mu``;
* ``excavator``: the seed paper's linkage (Zhang et al. 2013), the clearances of A and B set equal
  and the friction coefficients of A and B set equal (Coulomb law integrated as hybrid stick/slip
  modes, issue 14). Its grid is coarse and its runs are a few revolutions only.

Outputs in ``out_dir``: ``chaos_onset.pdf``; ``chaos_onset.parquet`` (one row per grid cell of both
maps, ``case`` = map name first, the columns of ``chaos_map``); ``chaos_onset_summary.csv`` (per map:
counts of chaotic / regular / uncertain cells and the largest and smallest exponent, which equal the
max / min of ``per_revolution`` over that map's rows of the parquet); ``chaos_onset_boundary.csv``
(per friction value: the clearances where lambda changes sign, interpolated linearly);
``chaos_onset_curves.csv`` (full mode: the slider-crank's bifurcation curves of its period-1 orbit
in (clearance, friction), one row per curve point and per codim-2 point, SI units; CURVES_FULL,
nld.analysis.codim2; empty in quick mode, which says why).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import pandas as pd

from nld.analysis.verdict import (CHAOTIC, FAILED, NOT_ESTABLISHED, PERMANENT_CONTACT, REGULAR,
                                  SHORT, UNCERTAIN)

STEM = "chaos_onset"
TITLE = "Onset of chaos over clearance x friction: slider-crank and excavator (largest Lyapunov exponent)"

SC = dict(scene="slider_crank_olyaei", param_x="joints.B.clearance", param_y="joints.B.friction.mu",
          label="slider-crank (slider_crank_olyaei, clearance at the rod-slider joint B, 5000 rpm)")
EX = dict(scene="excavator", param_x=["joints.A.clearance", "joints.B.clearance"],
          param_y=["joints.A.friction.mu", "joints.B.friction.mu"],
          label="excavator (Zhang et al. 2013 linkage, equal clearances and friction at A and B, 15.6 rad/s)")

FULL = {
    "slider_crank": dict(values_x=[0.05e-3, 0.075e-3, 0.1e-3, 0.15e-3, 0.2e-3, 0.3e-3, 0.5e-3],
                         values_y=[0.0, 0.02, 0.05, 0.08, 0.1, 0.15, 0.2],
                         # rtol 1e-10: at 1e-8 and 1e-9 a periodic state in continuous contact comes out
                         # chaotic (lambda1 +3.1 and +3.9 per rev against -0.35 at 1e-10; docs/analysis.md)
                         # rtol_check 1e-11: each exponent again from the same state; a cell
                         # whose two values disagree is 'uncertain' (docs/lyapunov.md: c = 0.1 mm,
                         # mu = 0.1 gave 82 per rev at 1e-10, 44 at 1e-11, an exponent of the integrator)
                         transient_revs=50, revs=100, lyapunov_revs=100, rtol=1e-10, d0=None,
                         rtol_check=1e-11, check_span=2),
    # mu = 0.1 is back in the grid: with Coulomb friction as hybrid stick/slip modes (issue 14) it costs
    # about 1.5x the steps of mu = 0 (it exceeded 5e7 steps while the sign law chattered). rtol 1e-7:
    # at 1e-6 the cell c = 0.01 mm, mu = 0.01 switches stick <-> slip at nearly every step
    # (studies/zhang2013_excavator.py)
    "excavator": dict(values_x=[1e-5, 3e-5, 1e-4, 5e-4], values_y=[0.0, 0.01, 0.02, 0.05, 0.1],
                      transient_revs=2, revs=2, lyapunov_revs=4, rtol=1e-7, d0=None, rtol_check=1e-8,
                      check_span=2),
}
QUICK = {
    "slider_crank": dict(values_x=[0.1e-3, 0.25e-3, 0.5e-3], values_y=[0.0, 0.1, 0.2],
                         transient_revs=5, revs=30, lyapunov_revs=10, rtol=1e-7, d0=None,
                         rtol_check=1e-8, check_span=2),
    "excavator": dict(values_x=[3e-5, 3e-4], values_y=[0.0, 0.01],
                      transient_revs=0, revs=1, lyapunov_revs=2, rtol=1e-5, d0=None, rtol_check=None),
}
# Bifurcation curves of the slider-crank's period-1 orbit over its chaos map (issue 41): the orbit at
# the start (clearance, friction) after a transient, its branch in the clearance at the start
# friction (natural continuation at the values of `branch`, bifurcations located to locate_tol),
# then the first located bifurcation of each kind in `kinds` followed in the friction coefficient
# over range2 (nld.analysis.codim2.continue_bifurcation), landing on the map's friction rows.
# The start is the permanent-contact orbit reached from c = 0.28 mm at mu = 0.1, whose doubling
# near 0.28613 mm is checked by one-parameter continuation (tests/test_codim2.py, slow)
CURVES_FULL = dict(start_c=0.28e-3, start_mu=0.1, transient_revs=100, rtol=1e-10,
                   # (a branch over 0.25 ... 0.35 mm at 7 values had not finished after 6 min
                   # of CPU on the loaded 2-core machine: the branch is kept to the doubling's
                   # neighbourhood, 14.5 s idle; folds and grazing of the period-1 orbit are then
                   # not on it, and the page says so)
                   branch=[0.28e-3, 0.2835e-3, 0.287e-3, 0.29e-3],
                   locate_tol=2e-8, kinds=("period_doubling", "fold", "grazing"),
                   range2=(0.0, 0.2), max_points=50)
FULL["curves"] = CURVES_FULL
# quick mode: no curve (stated on its page): a curve's orbits need rtol 1e-10 and hundreds of
# revolutions with tangents (minutes), the quick map's cells 1e-7 and tens of revolutions
QUICK["curves"] = None
CURVES_SKIPPED = ("not computed in quick mode: a curve's orbits need rtol 1e-10 and a few hundred "
                  "revolutions with tangents (minutes on 2 cores), against the quick map's tens of "
                  "revolutions at rtol 1e-7")
MAPS = {"slider_crank": SC, "excavator": EX}
# a cell is called chaotic only over a section of at least this many points (as the other studies:
# a shorter section cannot tell an attractor from a transient); the excavator map's 2-point
# sections therefore give no chaotic cell, only regular or uncertain ones
MIN_SECTION_POINTS = 50
MODE_LABELS = {"quick": "QUICK MODE: 3 x 3 (slider-crank) and 2 x 2 (excavator) cells, very short runs"}


# what `nld study chaos_onset` keeps when interrupted (Ctrl-C): said in its one-line message
INTERRUPT_KEEPS = ("the finished cells are kept under <out>/.work/; run the same command again to "
                   "resume from them")


def work_dir(out_dir: Path, name: str, mode: str) -> Path:
    """Where the map ``name`` keeps one parquet file per finished cell, so an interrupted study
    run again resumes instead of starting over (the full mode takes about 31 min on 2 idle
    cores): nld.study.work_dir, tied to the git commit."""
    from nld.study import work_dir as _work_dir
    return _work_dir(out_dir, STEM, mode, name)


def run_map(name: str, st: dict, workers: int, work: Path | None = None):
    """One exponent map; cells already in ``work`` (same settings) are read, not recomputed."""
    import shutil

    from nld.analysis.chaos_map import chaos_map
    from nld.errors import InputError
    m = MAPS[name]
    t0 = time.perf_counter()
    if work is not None:
        for old in work.parent.glob(f"{STEM}-*-{name}-*"):
            if old != work and old.is_dir():
                shutil.rmtree(old)           # cells of other code or another mode

    def run(resume: bool):
        return chaos_map(m["scene"], m["param_x"], st["values_x"], m["param_y"], st["values_y"],
                         transient_revs=st["transient_revs"], revs=st["revs"],
                         lyapunov_revs=st["lyapunov_revs"], rtol=st["rtol"], d0=st["d0"],
                         workers=workers, rtol_check=st.get("rtol_check"),
                         check_span=st.get("check_span", 1.0), min_section_points=MIN_SECTION_POINTS,
                         out=work, resume=resume)

    if work is None:
        df = run(False)
    else:
        try:
            df = run(True)
        except InputError:                   # the directory holds a map with other settings
            shutil.rmtree(work)
            df = run(True)
    walls = df.attrs.get("wall_s", {})
    df["wall_s"] = [float(walls.get(int(iy) * len(st["values_x"]) + int(ix), math.nan))
                    for ix, iy in zip(df["ix"], df["iy"])]
    return df, time.perf_counter() - t0


def summarise(name: str, df: pd.DataFrame) -> dict:
    ok = df[df["status"] == "ok"]
    lam = ok["per_revolution"].astype(float)
    v = df["verdict"]
    return {"map": name, "cells": len(df), "chaotic": int((v == CHAOTIC).sum()),
            "regular": int((v == REGULAR).sum()),
            "uncertain": int(v.isin([UNCERTAIN, SHORT]).sum()),
            "not_established": int((v == NOT_ESTABLISHED).sum()),
            "permanent_contact": int((v == PERMANENT_CONTACT).sum()),
            "failed": int((v == FAILED).sum()),
            "tolerance_dependent": int(df["message"].str.contains("depends on the tolerance").sum()),
            "max_lambda_per_rev": float(lam.max()) if len(lam) else math.nan,
            "min_lambda_per_rev": float(lam.min()) if len(lam) else math.nan,
            "median_uncertainty_per_rev": float(ok["uncertainty_per_revolution"].median()) if len(ok) else math.nan}


def boundary(name: str, df: pd.DataFrame) -> pd.DataFrame:
    """For each friction value: the clearances at which lambda changes sign along the clearance axis
    (linear interpolation of lambda in log clearance between neighbouring cells)."""
    rows = []
    for y, g in df.sort_values("x").groupby("y", sort=True):
        g = g[g["status"] == "ok"]
        xs, ls = g["x"].to_numpy(float), g["per_revolution"].to_numpy(float)
        cross = []
        for i in range(len(xs) - 1):
            a, b = ls[i], ls[i + 1]
            if a == 0 or a * b < 0:
                la, lb = math.log(xs[i]), math.log(xs[i + 1])
                cross.append(math.exp(la + (lb - la) * a / (a - b)) if a != b else xs[i])
        if len(ls) == 0:
            note = "no finished cell"
        elif cross:
            note = "sign change"
        elif (ls > 0).all():
            note = "chaotic at every clearance (lambda > 0)"
        else:
            note = "regular at every clearance (lambda < 0)" if (ls < 0).all() else "lambda = 0"
        rows.append({"map": name, "mu": float(y),
                     "onset clearances [mm]": ", ".join(f"{c * 1e3:.3g}" for c in cross) or "-",
                     "lambda range [1/rev]": f"{ls.min():.3g} .. {ls.max():.3g}" if len(ls) else "-",
                     "note": note})
    return pd.DataFrame(rows)


def _fig_map(rep, name, df, st, value="lambda"):
    from nld.analysis.chaos_map import chaos_map_plot
    m = MAPS[name]
    with rep.style():
        fig, ax = rep.subplots(1, 1, title=(f"{'Largest Lyapunov exponent' if value == 'lambda' else '0-1 test K'}"
                                            f" over clearance x friction: {name}"))
        chaos_map_plot(df, value=value, ax=ax, x_scale=1e3, x_log=True,
                       x_label="radial clearance c [mm]" + (" (A and B)" if name == "excavator" else ""),
                       y_label="friction coefficient μ [−]" + (" (A and B)" if name == "excavator" else ""))
    cap = (f"{m['label']}. Each cell: {st['transient_revs']} transient revolutions, a {st['revs']}-point "
           f"stroboscopic section, then λ1 (tangent dynamics with saltation, 2 revolutions of alignment) "
           f"over {st['lyapunov_revs']} revolutions at rtol {st['rtol']:g}" +
           (f", checked at rtol {st['rtol_check']:g} over {st.get('check_span', 1):g}x that span (a cell "
            "whose two exponents disagree is hatched as uncertain)" if st.get("rtol_check") else "") + ". "
           "Colour and number: λ1 per crank revolution (± its uncertainty); black line: λ1 = 0, the onset "
           "boundary, interpolated between cell centres; hatched: verdict uncertain (|λ1| <= uncertainty"
           + (", or the two tolerances disagree)." if st.get("rtol_check") else ")."))
    if value == "K":
        cap = (f"{m['label']}. The 0-1 test for chaos (Gottwald-Melbourne) on the {st['revs']}-point "
               "section of the journal eccentricity: K near 0 regular, near 1 chaotic (rough with this "
               "few points); a second opinion on the exponent map, no extra integration.")
    rep.figure(fig, caption=cap)


def _check_text(st) -> str:
    if not st.get("rtol_check"):
        return ", no tolerance check"
    return (f"; every exponent is computed again from the same state at rtol {st['rtol_check']:g} over "
            f"{st.get('check_span', 1):g}x the averaging span and the "
            "cell is 'uncertain' unless both agree in verdict and to 3 x their combined uncertainty "
            "(an explicit integrator on a stiff contact state can return a steady, large, "
            "tolerance-dependent exponent of its own: docs/lyapunov.md)")


def _texts(summ, bnd, maps, st_all, mode_label, walls):
    s = summ.set_index("map")

    def line(name):
        r = s.loc[name]
        return (f"{name}: {int(r['cells'])} cells, {int(r['chaotic'])} chaotic, {int(r['regular'])} regular, "
                f"{int(r['uncertain'])} uncertain, {int(r['not_established'])} not established "
                f"({int(r['tolerance_dependent'])} because λ1 changed with the tolerance), "
                f"{int(r['permanent_contact'])} in permanent contact (λ1 conditional on the "
                "contact memory), "
                f"{int(r['failed'])} failed; λ1 from {r['min_lambda_per_rev']:.3g} to "
                f"{r['max_lambda_per_rev']:.3g} per revolution (median uncertainty "
                f"{r['median_uncertainty_per_rev']:.2g}); wall time {walls[name]:.0f} s.")

    def by_mu(name):
        df = maps[name]
        out = []
        for y, g in df.groupby("y", sort=True):
            ok = g[g["status"] == "ok"]
            out.append(f"μ = {y:g}: mean λ1 {ok['per_revolution'].mean():.3g}, "
                       f"{(ok['verdict'] == CHAOTIC).sum()}/{len(g)} chaotic")
        return "; ".join(out)

    def by_c(name):
        df = maps[name]
        out = []
        for x, g in df.groupby("x", sort=True):
            ok = g[g["status"] == "ok"]
            out.append(f"c = {x * 1e3:g} mm: mean λ1 {ok['per_revolution'].mean():.3g}")
        return "; ".join(out)

    sc, ex = st_all["slider_crank"], st_all["excavator"]
    intro = [
        "What this reproduces: no single paper. Three sources state trends, none a map or a number: "
        "Olyaei & Ghazavi (2012, MMT 53) found chaos in a slider-crank with a rod-slider clearance and "
        "modified Coulomb friction 'under specific conditions' (Poincaré maps, bifurcation diagrams, "
        "largest exponent); Rhee & Akay (1996) found that the nonlinearity of a four-bar's clearance joint "
        "depends on both the clearance and the friction coefficient (as quoted by the seed paper); "
        "Farahanchi & Shaw (1991) report chaos at high speed and low friction with near-elastic impacts. "
        "The seed paper (Zhang et al. 2013) states that a larger clearance and a larger friction "
        "coefficient both make the excavator's vibration stronger, but computes no exponent. "
        "(shared/references.md §3 tags these [U] / [V abstract]; no published Lyapunov exponent of a "
        "clearance mechanism was found, so our values with their error bars are the reference.)",
        f"What is computed ({mode_label}): the map of the largest Lyapunov exponent λ1 over clearance x "
        "friction for the slider-crank (scene slider_crank_olyaei) and for the excavator (scene excavator, "
        "A and B together), with nld.analysis.chaos_map.chaos_map, and the boundary λ1 = 0 between regular and "
        "chaotic motion.",
        f"- slider-crank: {len(sc['values_x'])} x {len(sc['values_y'])} cells; per cell "
        f"{sc['transient_revs']} transient revolutions, {sc['revs']} section points, λ1 over "
        f"{sc['lyapunov_revs']} revolutions, rtol {sc['rtol']:g}" + _check_text(sc) + ".",
        f"- excavator: {len(ex['values_x'])} x {len(ex['values_y'])} cells, COARSE: per cell "
        f"{ex['transient_revs']} transient revolutions, {ex['revs']} section point(s), λ1 over only "
        f"{ex['lyapunov_revs']} revolutions, rtol {ex['rtol']:g}" + _check_text(ex) +
        ". Coulomb friction runs as hybrid stick/slip modes "
        "(issue 14: the tangent dynamics are mapped through the mode switches by their saltation "
        "matrices). Its exponents are short finite-time estimates with large "
        "uncertainties: read their signs, not their values.",
    ]
    found = [line("slider_crank"), "By friction: " + by_mu("slider_crank") + ".",
             "By clearance: " + by_c("slider_crank") + ".",
             line("excavator"), "By friction: " + by_mu("excavator") + ".",
             "By clearance: " + by_c("excavator") + ".",
             "Onset boundary (λ1 = 0 along the clearance axis at each friction value): see the table on the "
             "next page and the black contour of the maps."]
    return intro, found


def _check_discussion(sc: pd.DataFrame) -> str:
    """What the tolerance check says, per friction value (empty without a check)."""
    if "per_revolution_check" not in sc or not sc["per_revolution_check"].notna().any():
        return ""
    parts = []
    for y, g in sc.groupby("y", sort=True):
        v = g["verdict"]
        parts.append(f"μ = {y:g}: {(v == CHAOTIC).sum()} C / {(v == REGULAR).sum()} R / "
                     f"{v.isin([UNCERTAIN, NOT_ESTABLISHED]).sum()} ? / "
                     f"{(v == PERMANENT_CONTACT).sum()} P")
    ok = sc[sc["status"] == "ok"]
    lower = int((ok["per_revolution_check"] < ok["per_revolution"]).sum())
    return (" The tolerance check by friction value (chaotic / regular / uncertain or not "
            "established / permanent contact): " + "; ".join(parts) +
            f". In {lower} of {len(ok)} cells the exponent is lower at the tighter tolerance. A verdict "
            "is established mainly where the exponent is clearly positive or negative at both tolerances; "
            "an onset boundary is claimed only there.")


def _discussion(summ, maps):
    sc = maps["slider_crank"]
    ex = maps["excavator"]
    lo_mu = sc[sc["y"] == sc["y"].min()]
    hi_mu = sc[sc["y"] == sc["y"].max()]
    frac = lambda g: (g["verdict"] == CHAOTIC).mean()
    ex_reg = int((ex["verdict"] == REGULAR).sum())
    ok = sc[sc["status"] == "ok"]
    rho_mu = ok[["y", "per_revolution"]].rank().corr().iloc[0, 1] if len(ok) > 2 else math.nan
    rho_c = ok[["x", "per_revolution"]].rank().corr().iloc[0, 1] if len(ok) > 2 else math.nan
    regularises = frac(hi_mu) < frac(lo_mu)
    lines = [
        f"Slider-crank: at μ = {sc['y'].min():g} {frac(lo_mu):.0%} of the clearances are chaotic (mean λ1 "
        f"{lo_mu['per_revolution'].mean():.3g}/rev), at μ = {sc['y'].max():g} {frac(hi_mu):.0%} (mean "
        f"{hi_mu['per_revolution'].mean():.3g}/rev); rank correlation of λ1 with μ over all cells "
        f"{rho_mu:.2f}, with the clearance {rho_c:.2f}. " +
        ("Friction regularises, in agreement with Farahanchi & Shaw's 'chaos at low friction' and with Rhee "
         "& Akay's dependence on friction: friction damps the journal's sliding along the bearing and keeps "
         "it in contact. " if regularises else
         "Friction does NOT regularise in this grid, unlike Farahanchi & Shaw's 'chaos at low friction'. ") +
        ("Larger clearances tend to larger exponents. " if rho_c > 0.3 else
         "No clear trend with the clearance. " if abs(rho_c) <= 0.3 else "Larger clearances tend to smaller exponents. ") +
        "The onset boundary is not a single smooth curve: several cells near λ1 = 0 alternate in sign "
        "between neighbours (windows of regular motion inside the chaotic region, and finite-time estimates "
        "over 100 revolutions), so the contour is fragmented; read it as a band." + _check_discussion(sc),
        f"Excavator: {ex_reg} of {len(ex)} cells regular. " + (
            "Every cell has a positive exponent: the journals rattle in their clearances over the short "
            "runs at every clearance and friction tried, so no onset boundary lies inside this grid. The "
            "seed paper's statement that friction makes the motion stronger is not tested by a sign change "
            "here; the values per cell are in the parquet. " if ex_reg == 0 else
            "The boundary is drawn where the sign changes between neighbouring cells. ") +
        "These are estimates over a few revolutions only (coarse by necessity, see the method); the "
        "transient after the ideal-joint start is short, so part of the positive exponent may be transient "
        "rattle.",
        "Why the results may differ from the sources: the sources' dimensions, speeds and contact "
        "parameters are not those of our scenes (docs/models/), none of them published a map or an "
        "exponent, and Rhee & Akay / Olyaei & Ghazavi could not be read here ([U]). Finite-time exponents "
        "near zero, and exponents that change with the tolerance (stiff contact states, docs/lyapunov.md), "
        "are hatched as uncertain: their sign or size is not established, and a boundary drawn through "
        "them is not a result.",
    ]
    return lines


def _report(study, maps, walls, summ, bnd, wall, workers, res=None, ex=None):
    from nld.study import timing
    st_all, mode_label = study.settings, study.label
    settings = {"Mode": mode_label, "Maps": "slider_crank_olyaei (B), excavator (A and B together)",
                "Method": ("nld.analysis.chaos_map.chaos_map: stroboscopic section + λ1 (tangent dynamics with "
                           "saltation) + 0-1 test"),
                "Workers": workers,
                "Compute wall time": timing(f"{wall:.1f} s (slider-crank {walls['slider_crank']:.1f} s, "
                                            f"excavator {walls['excavator']:.1f} s)"),
                "Cell time (sum over cells)": timing(", ".join(f"{n} {float(maps[n]['wall_s'].sum()):.0f} s"
                                                               for n in MAPS)
                                                     + " (cells finished by an interrupted earlier run are "
                                                       "read back, not recomputed)")}
    rep = study.report(settings, subject="Largest Lyapunov exponent over clearance x friction, onset boundary",
                       keywords=["clearance joint", "chaos map", "Lyapunov", "slider-crank", "excavator"])
    intro, found = _texts(summ, bnd, maps, st_all, mode_label, walls)
    with rep:
        rep.text_page("What this report reproduces and how", intro)
        rep.text_page("What we found", found)
        shown = summ.rename(columns={"max_lambda_per_rev": "max λ1", "min_lambda_per_rev": "min λ1",
                                     "median_uncertainty_per_rev": "median unc"})
        rep.table("Per map: verdicts and exponent range", shown,
                  col_units={"max λ1": "1/rev", "min λ1": "1/rev", "median unc": "1/rev"},
                  notes=[f"Verdict per cell: chaotic if λ1 - unc > 0, regular if λ1 + unc < 0, else uncertain. "
                         f"max / min λ1: over the finished cells of the map ({STEM}.parquet, column "
                         f"per_revolution). Also in {STEM}_summary.csv."],
                  float_format=lambda v: f"{v:.4g}")
        rep.table("Onset boundary: where λ1 changes sign along the clearance axis", bnd,
                  notes=["Linear interpolation of λ1 in log(clearance) between neighbouring cells of the "
                         f"same friction value; '-' where λ1 keeps its sign. Also in {STEM}_boundary.csv."])
        _fig_map(rep, "slider_crank", maps["slider_crank"], st_all["slider_crank"])
        _fig_map(rep, "slider_crank", maps["slider_crank"], st_all["slider_crank"], value="K")
        _fig_map(rep, "excavator", maps["excavator"], st_all["excavator"])
        rep.text_page("Sources vs ours: trends and why they differ", _discussion(summ, maps))
        sc = maps["slider_crank"]
        rep.text_page("Bifurcation curves against the map: what they explain and what they cost",
                      _curves_texts(res, ex if ex is not None else explain(sc, {"curves": []}),
                                    walls["slider_crank"], len(sc)))
        if res is not None and ex is not None and len(ex):
            rep.table("Map boundary cells against the curves", ex,
                      notes=["Per friction row: neighbouring cells (clearances in mm) with a "
                             "regular/chaotic sign change (map_boundary) or crossed by a curve; "
                             "agree: the map's boundary and a curve's crossing coincide (or "
                             "neither). Curve points in chaos_onset_curves.csv."])
        _fig_curves(rep, sc, st_all["slider_crank"], res)


# ------------------------------------------------------------------------------- bifurcation curves


def follow_curves(cs: dict, values_y, log=None) -> dict:
    """The slider-crank's bifurcation curves in (clearance, friction) (CURVES_FULL): returns
    {"curves": [BifurcationCurve], "branch": Branch, "notes": [one line per kind], "walls":
    {"orbit_and_branch": s, kind: s}}."""
    from nld.analysis.codim2 import continue_bifurcation
    from nld.analysis.continuation import continue_orbit
    from nld.analysis.orbits import periodic_orbit
    from nld.errors import InputError, SolveError
    from nld.systems import SceneSystem
    clear, mu = SC["param_x"], SC["param_y"]
    t0 = time.perf_counter()
    S = SceneSystem(SC["scene"], [f"{clear}={cs['start_c']!r}", f"{mu}={cs['start_mu']!r}"])
    o1 = periodic_orbit(S, 1, transient=cs["transient_revs"], rtol=cs["rtol"])
    out = {"curves": [], "branch": None, "notes": [], "walls": {}}
    if not o1.converged:
        out["notes"].append(f"no period-1 orbit at the start ({o1.message}): no curve")
        out["walls"]["orbit_and_branch"] = time.perf_counter() - t0
        return out
    br = continue_orbit(S, o1, clear, cs["branch"], locate_tol=cs["locate_tol"], criticality=False)
    out["branch"] = br
    if log is not None:
        log(f"branch: {br.message}; " + "; ".join(b.detail for b in br.bifurcations))
    out["walls"]["orbit_and_branch"] = time.perf_counter() - t0
    lo, hi = min(cs["range2"]), max(cs["range2"])
    stops = [float(v) for v in values_y if lo < v < hi]
    for kind in cs["kinds"]:
        cands = [b for b in br.bifurcations if b.kind == kind and b.located and b.orbit is not None]
        if not cands:
            out["notes"].append(f"{kind}: none located on the period-1 branch in the clearance over "
                                f"{min(cs['branch']) * 1e3:g} ... {max(cs['branch']) * 1e3:g} mm at "
                                f"mu = {cs['start_mu']:g} ({br.message})")
            continue
        bif = cands[0]
        t = time.perf_counter()
        if log is not None:
            log(f"{kind} at c = {bif.value:.9g} m: following in mu")
        try:
            c = continue_bifurcation(S, bif, mu, cs["range2"], param=clear, stops=stops,
                                     max_points=cs["max_points"],
                                     progress=None if log is None else
                                     (lambda i, n, v1, v2: log(f"  {i}: c = {v1:.9g} m, "
                                                               f"mu = {v2:.6g} "
                                                               f"({time.perf_counter() - t:.0f} s)")))
        except (SolveError, InputError) as e:
            out["notes"].append(f"{kind} at c = {bif.value * 1e3:.6g} mm: the curve did not start "
                                f"({e})")
            out["walls"][kind] = time.perf_counter() - t
            continue
        out["walls"][kind] = time.perf_counter() - t
        out["curves"].append(c)
        out["notes"].append(f"{kind} at c = {bif.value * 1e3:.7g} mm ± {bif.tolerance * 1e3:.2g} mm "
                            f"(mu = {cs['start_mu']:g}): {len(c.values1)} curve points in "
                            f"{out['walls'][kind]:.0f} s; {c.message}")
    return out


def curves_table(res: dict) -> pd.DataFrame:
    """One row per curve point (and per codim-2 point, ``row`` = "special"), SI units."""
    rows = []
    for c in res["curves"]:
        for i in range(len(c.values1)):
            o = c.orbits[i]
            rows.append({"curve": c.kind, "row": "point", "index": i, "clearance_m": c.values1[i],
                         "mu": c.values2[i], "tolerance_clearance_m": c.tolerance1[i],
                         "uncertainty_mu": 0.0, "condition": c.condition[i],
                         "distance": c.distance[i], "landed": bool(c.landed[i]),
                         "onsets_per_period": o.onsets_per_period, "continuum": bool(o.continuum),
                         "detail": "", "wall_s": c.settings.get("wall_s", math.nan)})
        for sp in c.special_points:
            rows.append({"curve": c.kind, "row": "special", "index": -1, "clearance_m": sp.value1,
                         "mu": sp.value2, "tolerance_clearance_m": sp.uncertainty1,
                         "uncertainty_mu": sp.uncertainty2, "condition": math.nan,
                         "distance": math.nan, "landed": False, "onsets_per_period": -1,
                         "continuum": False, "detail": f"{sp.kind}: {sp.detail}",
                         "wall_s": c.settings.get("wall_s", math.nan)})
    cols = ["curve", "row", "index", "clearance_m", "mu", "tolerance_clearance_m", "uncertainty_mu",
            "condition", "distance", "landed", "onsets_per_period", "continuum", "detail", "wall_s"]
    return pd.DataFrame(rows, columns=cols)


def _curve_c_at(c, y: float) -> list:
    """The clearances where curve ``c`` crosses the friction value y (linear between points)."""
    xs, ys = c.values1, c.values2
    out = []
    for i in range(len(xs)):
        if ys[i] == y:
            out.append(xs[i])
        elif i + 1 < len(xs) and (ys[i] - y) * (ys[i + 1] - y) < 0:
            w = (y - ys[i]) / (ys[i + 1] - ys[i])
            out.append(xs[i] + w * (xs[i + 1] - xs[i]))
    return sorted(set(out))


def explain(df: pd.DataFrame, res: dict) -> pd.DataFrame:
    """Per friction row of the map: the sign changes of lambda along the clearance (pairs of
    neighbouring finished cells, regular/chaotic verdicts) and for each the curves that cross
    the row between the two cells ("explained"); and each curve crossing that lies between two
    cells with the same verdict (a disagreement)."""
    rows = []
    for y, g in df.sort_values("x").groupby("y", sort=True):
        xs = g["x"].to_numpy(float)
        ver = g["verdict"].tolist()
        cross = {c.kind: _curve_c_at(c, float(y)) for c in res["curves"]}
        for i in range(len(xs) - 1):
            a, b = ver[i], ver[i + 1]
            curves_here = [k for k, cs in cross.items() if any(xs[i] < x <= xs[i + 1] for x in cs)]
            change = {a, b} == {REGULAR, CHAOTIC}
            if not change and not curves_here:
                continue
            rows.append({"mu": float(y), "c_left_mm": xs[i] * 1e3, "c_right_mm": xs[i + 1] * 1e3,
                         "left": a, "right": b, "map_boundary": change,
                         "curves": ", ".join(curves_here) or "-",
                         "agree": change == bool(curves_here)})
    return pd.DataFrame(rows, columns=["mu", "c_left_mm", "c_right_mm", "left", "right",
                                       "map_boundary", "curves", "agree"])


def _curves_texts(res, ex: pd.DataFrame, map_wall: float, cells: int) -> list:
    if res is None:
        return [f"Bifurcation curves: {CURVES_SKIPPED}."]
    cs = CURVES_FULL
    n_b = int(ex["map_boundary"].sum()) if len(ex) else 0
    lines = [
        "Method: the period-1 orbit of slider_crank_olyaei at c = "
        f"{cs['start_c'] * 1e3:g} mm, μ = {cs['start_mu']:g} ({cs['transient_revs']} transient "
        f"revolutions, rtol {cs['rtol']:g}), continued in the clearance over "
        f"{min(cs['branch']) * 1e3:g} … {max(cs['branch']) * 1e3:g} mm (bifurcations located to "
        f"{cs['locate_tol']:.0e} m); the first located bifurcation of each kind followed in μ over "
        f"{cs['range2'][0]:g} … {cs['range2'][1]:g} by nld.analysis.codim2.continue_bifurcation "
        f"(at most {cs['max_points']} points per direction, landing on the map's friction rows). "
        "Orbit and branch: " + f"{res['walls'].get('orbit_and_branch', math.nan):.0f} s.",
        "Curves: " + " ".join(n + "." for n in res["notes"]),
    ]
    for c in res["curves"]:
        sp = "; ".join(f"{s.kind} at c = {s.value1 * 1e3:.5g} ± {s.uncertainty1 * 1e3:.2g} mm, "
                       f"μ = {s.value2:.4g} ± {s.uncertainty2:.2g}" for s in c.special_points)
        expl = int((ex["curves"].str.contains(c.kind) & ex["map_boundary"]).sum()) if len(ex) else 0
        lines.append(f"{c.kind} curve: c from {min(c.values1) * 1e3:.5g} to "
                     f"{max(c.values1) * 1e3:.5g} mm over μ {min(c.values2):.3g} … "
                     f"{max(c.values2):.3g}; tolerance in c ≤ {max(c.tolerance1) * 1e3:.2g} mm; "
                     f"codim-2 points: {sp or 'none'}. It explains {expl} of the map's {n_b} "
                     f"regular/chaotic sign changes along the clearance. Cost: "
                     f"{c.settings.get('wall_s', math.nan):.0f} s wall, "
                     f"{c.settings.get('integrations', '?')} revolutions with tangents, against the "
                     f"map's {map_wall:.0f} s for {cells} cells.")
    dis = ex[~ex["agree"]] if len(ex) else ex
    if len(ex):
        lines.append(
            f"Where they disagree ({len(dis)} of {len(ex)} cell pairs): a map boundary that no curve "
            "crosses is not the loss of stability of THIS period-1 orbit (another attractor, a "
            "cascade of further doublings after the first, or a boundary crisis of a chaotic "
            "attractor: none of these is a curve of the period-1 orbit); a curve between two cells "
            "of the same verdict is a bifurcation the map does not see (the orbit followed is not "
            "the attractor the map's transient reached: coexistence, e.g. the permanent-contact "
            "orbit whose memory sets its doubling, docs/orbits.md), or both sides regular (a "
            "doubling to a stable period-2 orbit).")
        if len(dis) and (dis["left"].eq("permanent contact") | dis["right"].eq("permanent contact")).any():
            lines.append(
                "Cells in permanent contact: the map's exponent there is conditional on the contact "
                "memory and decides neither chaos nor its onset; a doubling curve of the "
                "permanent-contact period-1 orbit inside them is the boundary of its stability "
                "(period-2 motion beyond a supercritical doubling), finer than a cell: a "
                "disagreement of resolution, not of result.")
        for r in dis.head(12).itertuples():
            what = ("map boundary, no curve" if r.map_boundary else f"{r.curves} between "
                    f"{r.left} and {r.right} cells")
            lines.append(f"- μ = {r.mu:g}, c {r.c_left_mm:g} … {r.c_right_mm:g} mm: {what}.")
    return lines


def _fig_curves(rep, df, st, res):
    from nld.analysis.chaos_map import chaos_map_plot
    from nld.analysis.codim2 import plot_curves
    with rep.style():
        fig, ax = rep.subplots(1, 1, title="Bifurcation curves of the period-1 orbit over the "
                                           "slider-crank's chaos map")
        chaos_map_plot(df, value="lambda", ax=ax, x_scale=1e3, x_log=True, annotate=False,
                       x_label="radial clearance c [mm]", y_label="friction coefficient μ [−]")
        if res is not None and res["curves"]:
            xl, yl = ax.get_xlim(), ax.get_ylim()
            plot_curves(res["curves"], ax=ax, x_scale=1e3, x_label="radial clearance c [mm]",
                        y_label="friction coefficient μ [−]", legend=True)
            ax.set_xlim(*xl)
            ax.set_ylim(*yl)
    cap = ("The largest Lyapunov exponent map (colour, black line λ1 = 0) with the bifurcation curves "
           "of the period-1 orbit (nld.analysis.codim2): period doubling red, fold blue, grazing orange "
           "dashed; codim-2 points marked with their uncertainty. " +
           ("" if res is not None else "No curve: " + CURVES_SKIPPED + "."))
    rep.figure(fig, caption=cap)


# ----------------------------------------------------------------------------------------- main


def run_curves(cs: dict, values_y) -> dict:
    """:func:`follow_curves`, or (when it fails) no curve and the failure said on the page (the map
    is kept)."""
    from nld.errors import InputError, SolveError
    t_c = time.perf_counter()
    try:
        return follow_curves(cs, values_y)
    except (SolveError, InputError) as e:
        return {"curves": [], "branch": None, "notes": [f"the curves failed: {e}"],
                "walls": {"orbit_and_branch": time.perf_counter() - t_c}}


def main(quick: bool = False, out_dir: Path = Path("reports")) -> Path:
    from nld.study import Study
    study = Study(globals(), quick, out_dir)
    st_all, workers = study.settings, study.workers(1 if quick else 2)
    maps, walls = {}, {}
    for name in MAPS:
        maps[name], walls[name] = run_map(name, st_all[name], workers, study.work_dir(name))
    cs = st_all.get("curves")
    res = run_curves(cs, st_all["slider_crank"]["values_y"]) if cs else None
    ctab = curves_table(res) if res is not None else curves_table({"curves": []})
    ex = explain(maps["slider_crank"], res if res is not None else {"curves": []})
    summ = pd.DataFrame([summarise(n, maps[n]) for n in MAPS])
    bnd = pd.concat([boundary(n, maps[n]) for n in MAPS], ignore_index=True)
    wall = study.elapsed()
    study.provenance(maps={n: {**MAPS[n], **st_all[n], "wall_s": walls[n],
                               "chaos_map_provenance": maps[n].attrs.get("provenance", {})} for n in MAPS},
                     summary=summ.to_dict(orient="records"), compute_wall_s=wall, workers=workers,
                     curves=({"settings": cs, "notes": res["notes"], "walls": res["walls"],
                              "ends": {c.kind: [e.to_dict() for e in c.ends] for c in res["curves"]}}
                             if res is not None else {"skipped": CURVES_SKIPPED}))
    study.save(".parquet", {n: pd.DataFrame(maps[n]).reset_index(drop=True) for n in MAPS})
    study.save("_summary.csv", summ)
    study.save("_boundary.csv", bnd)
    study.save("_curves.csv", ctab)
    _report(study, maps, walls, summ, bnd, wall, workers, res, ex)
    return study.pdf


if __name__ == "__main__":
    import sys
    print(main(quick="--quick" in sys.argv))
