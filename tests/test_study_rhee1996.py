"""Study rhee1996 (studies/rhee1996.py) in quick mode: files, pages, tables consistent with the data.

Quick mode takes about 20-25 s on two cores with a warm kernel cache (six four-bar cases and two
three-point sweeps at rtol 1e-7).
"""
from __future__ import annotations

import numpy as np
import pytest

from nld.analysis.peaks import peak_interval
from nld.output.io import load_table
from nld.output.report import Report, source_date_epoch
from study_harness import MODES, count_pages, run_quick_recorded


@pytest.fixture(scope="module", params=MODES)
def quick_run_rec(request, tmp_path_factory):
    """The smoke run (the quick run under -m slow), once, with what went into the report recorded
    (study_harness.ReportRecorder)."""
    return run_quick_recorded("rhee1996.py", tmp_path_factory, request.param)


@pytest.fixture(scope="module")
def quick_run(quick_run_rec):
    return quick_run_rec[:3]


def test_quick_writes_pdf_and_data(quick_run):
    study, out, pdf = quick_run
    assert pdf == out / "rhee1996.pdf" and pdf.is_file()
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF") and study.MODE.encode() in data
    # title page(s) + intro, findings, case table, sweep table, sections, 2 sweeps, spectra,
    # convergence, discussion; the route to chaos: one page per sweep; the coexisting motions
    # (attractor census) table
    title_pages = Report(out / "x.pdf", study.TITLE, scene=study.SCENE).title_page_count()
    assert count_pages(pdf) == title_pages + 13
    for suffix in ("", "_sections", "_sweeps", "_spectra"):
        assert (out / f"rhee1996{suffix}.parquet").is_file()
    assert (out / "rhee1996_summary.csv").is_file() and (out / "rhee1996_peaks.csv").is_file()


def test_summary_matches_stored_series(quick_run):
    study, out, _ = quick_run
    runs, prov = load_table(out / "rhee1996.parquet")
    summary, _ = load_table(out / "rhee1996_summary.csv")
    sections, _ = load_table(out / "rhee1996_sections.parquet")
    assert prov["mode"] == study.MODE and prov["scene"] == "four_bar"
    assert set(summary["case"]) == set(study.CASES) == set(runs["case"])
    peaks, _ = load_table(out / "rhee1996_peaks.csv")
    for _, row in summary.iterrows():
        fn = runs.loc[runs["case"] == row["case"], "B.Fn"].to_numpy()
        assert row["rms_Fn"] == pytest.approx(np.sqrt(np.mean(fn ** 2)), rel=1e-9)
        # per-revolution peaks, located on the stored run: never below its samples of that revolution
        pk = peaks[peaks["case"] == row["case"]].sort_values("rev")
        assert list(pk["rev"]) == list(range(study.MODE_SETTINGS["spec_revs"]))
        t = runs.loc[runs["case"] == row["case"], "t"].to_numpy()
        period = pk["t_start"].iloc[1] - pk["t_start"].iloc[0]
        for _, p in pk.iterrows():
            sel = (t >= p["t_start"] - 1e-12) & (t <= p["t_start"] + period * (1 + 1e-9))
            assert p["sampled"] == pytest.approx(fn[sel].max(), rel=1e-12)
            assert p["peak"] >= p["detected"] >= p["sampled"]
        # mean +- 95 % interval of those peaks (nld.analysis.peaks), the extreme beside it
        iv = peak_interval(pk["peak"].to_numpy())
        assert row["Fn_rev_mean"] == pytest.approx(iv.mean, rel=1e-12) and 0 < row["Fn_rev_ci95"]
        assert row["Fn_rev_ci95"] == pytest.approx(iv.half_width, rel=1e-12)
        assert row["max_Fn"] == pk["peak"].max() >= fn.max() * (1 - 1e-12) and row["max_Fn"] > row["Fn_rev_mean"]
        assert row["status"] == "ok"
        assert (sections["case"] == row["case"]).sum() == study.MODE_SETTINGS["section_revs"]
        assert np.isfinite(row["lambda_per_rev"]) and row["lambda_unc_per_rev"] >= 0


def test_sweep_exponents_match_table(quick_run):
    study, out, _ = quick_run
    sweeps, prov = load_table(out / "rhee1996_sweeps.parquet")
    period = 2 * np.pi / prov["scene_parameters"]["driver"]["speed"]
    assert {"clearance", "friction"} <= set(sweeps["case"]) <= {"clearance", "friction", "clearance_check",
                                                                   "friction_check"}
    sw = sweeps[sweeps["case"] == "friction"]
    fr = sw.drop_duplicates("index")
    assert sorted(fr["value"].astype(float)) == sorted(study.MODE_SETTINGS["frictions"])
    pts = study.sweep_points(sw, period, clearance=0.25e-3)
    assert np.allclose(pts["lambda_per_rev"], fr.sort_values("index")["lyapunov"] * period)
    assert len(sw[sw["index"] == 0]) == study.MODE_SETTINGS["sweep_revs"]
    # friction makes the four-bar regular: the largest coefficient has a smaller exponent than mu = 0
    assert pts["lambda_per_rev"].iloc[-1] < pts["lambda_per_rev"].iloc[0]


def census_of(out) -> dict:
    """{point: census verdict} of the study's census table."""
    cen, _ = load_table(out / "rhee1996_census.csv")
    return dict(zip(cen["point"], cen["census_verdict"]))


def test_the_census_page_data(quick_run):
    """Quick mode runs the census at mu = 0.3 (st["census"]["always"]) besides every point whose
    verdict is not established: its runs add up to the starts, fractions with Wilson intervals
    around them, and an established verdict is left as it was."""
    study, out, _ = quick_run
    cen, prov = load_table(out / "rhee1996_census.csv")
    summary, _ = load_table(out / "rhee1996_summary.csv")
    assert "mu=0.3" in set(cen["point"]) and prov["census"]["settings"]["starts"] == 2
    for point, g in cen.groupby("point"):
        assert g["count"].sum() <= g["starts"].iloc[0]
        assert ((g["fraction_lo"] <= g["fraction"]) & (g["fraction"] <= g["fraction_hi"])).all()
        assert set(g["kind"]) <= {"periodic", "quasi-periodic", "chaotic", "permanent contact",
                                  "escaping", "unsettled"}
    row = summary[summary["case"] == "mu=0.3"].iloc[0]
    if row["verdict_main"] == row["verdict_check"]:
        assert row["verdict"] != "not established"


def test_verdicts_need_the_minimum_section(quick_run):
    study, out, _ = quick_run
    summary, _ = load_table(out / "rhee1996_summary.csv")
    assert study.MIN_SECTION_POINTS > 0
    for _, r in summary.iterrows():
        assert r["section_points"] == study.MODE_SETTINGS["section_revs"]
        lam, unc = r["lambda_per_rev"], r["lambda_unc_per_rev"]
        expect = ("regular" if lam + unc < 0 else
                  ("chaotic" if r["section_points"] >= study.MIN_SECTION_POINTS else "λ1 > 0, short")
                  if lam - unc > 0 else "uncertain")
        assert r["verdict_main"] == expect
        # the check: the same state at rtol_check over check_span x the span
        lc, uc = r["lambda_check"], r["lambda_check_unc"]
        expect_c = ("regular" if lc + uc < 0 else
                    ("chaotic" if r["section_points"] >= study.MIN_SECTION_POINTS else "λ1 > 0, short")
                    if lc - uc > 0 else "uncertain")
        assert r["verdict_check"] == expect_c
        checked = expect if expect == expect_c else "not established"
        sweep = r["verdict_sweep"] if isinstance(r["verdict_sweep"], str) else ""
        want = (checked if not sweep or sweep == checked else
                "failed" if "failed" in (checked, sweep) else "not established")
        # 'not established' is replaced by the attractor census's verdict (issue 25)
        assert r["verdict"] == (census_of(out).get(r["case"], want) if want == "not established"
                                else want)
    # a short section is never called chaotic
    assert not ((summary["section_points"] < study.MIN_SECTION_POINTS) & (summary["verdict"] == "chaotic")).any()


def test_sweep_verdicts_checked_at_the_tighter_tolerance(quick_run):
    """Every sweep point not called regular is run again (rtol_check, check_span x the span); its
    verdict holds only where the two agree."""
    study, out, _ = quick_run
    sweeps, prov = load_table(out / "rhee1996_sweeps.parquet")
    period = 2 * np.pi / prov["scene_parameters"]["driver"]["speed"]
    for name, c in (("clearance", None), ("friction", 0.25e-3)):
        pts = study.sweep_points(sweeps[sweeps["case"] == name], period, clearance=c)
        stored = prov["sweep_points"][name]
        assert [p["verdict_main"] for p in stored] == list(pts["verdict_main"])
        chk = sweeps[sweeps["case"] == f"{name}_check"]
        checked = sorted(chk["value"].astype(float).unique()) if len(chk) else []
        assert checked == sorted(float(v) for v, vd in zip(pts["value"], pts["verdict_main"]) if vd != "regular")
        for p in stored:
            if p["verdict_check"]:
                want = (p["verdict_main"] if p["verdict_main"] == p["verdict_check"]
                        else ("failed" if "failed" in (p["verdict_main"], p["verdict_check"])
                              else "not established"))
                if want == "not established":       # the census decides (issue 25)
                    want = set(census_of(out).values()) or {want}
                    assert p["verdict"] in want
                else:
                    assert p["verdict"] == want
            else:
                assert p["verdict_main"] == "regular" and p["verdict"] == "regular"


def test_eccentricity_over_clearance_saved(quick_run):
    study, out, _ = quick_run
    sections, _ = load_table(out / "rhee1996_sections.parquet")
    for name, (_, _, c, _) in study.CASES.items():
        s = sections[sections["case"] == name]
        assert np.allclose(s["B.ex/c"], s["B.ex"] / c, rtol=1e-12)
        assert np.allclose(s["B.ey/c"], s["B.ey"] / c, rtol=1e-12)
        assert np.hypot(s["B.ex/c"], s["B.ey/c"]).max() <= 1.1
    sweeps, _ = load_table(out / "rhee1996_sweeps.parquet")
    ok = sweeps[sweeps["status"] == "ok"]
    cl = ok[ok["case"] == "clearance"]
    assert np.allclose(cl["B.ex/c"], cl["B.ex"] / cl["value"].astype(float), rtol=1e-12)
    fr = ok[ok["case"] == "friction"]
    assert np.allclose(fr["B.ex/c"], fr["B.ex"] / 0.25e-3, rtol=1e-12)
    assert ok["B.ex/c"].between(-1.1, 1.1).all() and ok["B.ey/c"].between(-1.1, 1.1).all()


def test_figures_compare_and_state_their_estimator(quick_run_rec):
    study, out, _, rec = quick_run_rec
    _, prov = load_table(out / "rhee1996_summary.csv")
    q = study.MODE_SETTINGS
    period = 2 * np.pi / prov["scene_parameters"]["driver"]["speed"]
    # every exponent: estimator, tolerance, averaging span and the uncertainty, from the settings
    for words, revs in (("Poincaré sections", q["lyap_revs"]), ("against the clearance", q["sweep_lyap"]),
                        ("against the friction", q["sweep_lyap"]), ("Convergence", q["lyap_revs"])):
        cap = rec.figure(words)["caption"]
        assert "estimator tangent" in cap and f"rtol {q['rtol']:g}" in cap, words
        assert f"averaged over {revs:.3g} rev" in cap and "uncertainty:" in cap, words
    for t in rec.tables:
        if t["title"].startswith(("Period-1 branch", "Periodic orbits at")):
            continue            # the route-to-chaos tables hold multipliers, no exponent
        assert "estimator tangent" in t["notes"] and f"rtol {q['rtol']:g}" in t["notes"], t["title"]
    # sections: e/c, the six panels on the same axes; the minimum count is stated
    sec = rec.figure("Poincaré sections")
    assert len({(a["xlim"], a["ylim"]) for a in sec["axes"]}) == 1
    assert 1.0 < sec["axes"][0]["ylim"][1] < 1.5 and all("/ c" in a["xlabel"] for a in sec["axes"])
    assert f"fewer than {study.MIN_SECTION_POINTS} points" in sec["caption"]
    # both sweeps: the same labels, e/c range and λ1 range; x label only under the bottom panel
    sweeps = [rec.figure("against the clearance"), rec.figure("against the friction")]
    for f in sweeps:
        top, bottom = f["axes"]
        assert top["xlabel"] == "" and "[" in bottom["xlabel"]
        assert top["ylabel"] == "B.ex / c [−]" and top["ylim"] == sweeps[0]["axes"][0]["ylim"]
        assert bottom["ylim"] == sweeps[0]["axes"][1]["ylim"]
    # spectra: one y-range, and the axes reach past every peak the table lists
    spec = rec.figure("Spectra")
    assert len({a["ylim"] for a in spec["axes"]}) == 1
    summary, _ = load_table(out / "rhee1996_summary.csv")
    top_order = max(float(o) for s in summary["peak_orders"] for o in s.split(","))
    assert spec["axes"][0]["xlim"][1] >= top_order / period
    # convergence panels on one y-range
    assert len({a["ylim"] for a in rec.figure("Convergence")["axes"]}) == 1
    # the title page's wall time is the whole run's, not the report's
    if source_date_epoch() is None:
        assert rec.wall_time() >= prov["compute_wall_s"]


def test_route_to_chaos_branch_saved_with_its_sentence(quick_run):
    import json

    import pandas as pd
    study, out, pdf = quick_run
    br = pd.read_csv(out / "rhee1996_route_branch.csv")
    assert sorted(br["value"]) == [0.09, 0.1] and set(br["sweep"]) == {"friction"}
    assert br["converged"].all() and (br["residual"] <= 1e-5).all()      # 1e3 rtol (1e-8)
    # the four-bar runs in permanent contact at mu 0.09-0.1: no onset, the memory's multiplier 1,
    # which is a continuum, not a stable orbit
    assert (br["onsets_per_period"] == 0).all() and br["continuum"].all()
    assert (br["stability"] == "neutral continuum").all()
    assert (br["min_Fn"] > 0).all() and (br["max_Fn"] > br["min_Fn"]).all()
    prov = json.loads((out / "rhee1996_route_branch.csv.json").read_text())
    assert "period-1 orbit" in prov["route_to_chaos"]["friction"]["route"]


def test_route_rows_and_agreement_with_the_brute_force(quick_run):
    """Issue 40 items 3-4: the route rows of both sweeps, in order, each transition inside its
    interval; every branch point called stable or neutral lies on the brute-force section at that
    value, or the row says where and why not."""
    import pandas as pd
    from nld.analysis.route import ROUTE_COLUMNS
    study, out, pdf = quick_run
    rt = pd.read_csv(out / "rhee1996_route.csv")
    assert list(rt.columns) == ROUTE_COLUMNS
    assert set(rt["sweep"]) == {"clearance", "friction"}
    for name, g in rt.groupby("sweep"):
        assert list(g["order"]) == list(range(1, len(g) + 1))
        assert (g["from"] <= g["to"]).all()
        bf = g[g["source"] == "brute force"]
        # the brute-force runs tile the sweep's values, each change between its two points
        assert all(f > t for f, t in zip(list(bf["from"])[1:], list(bf["to"])[:-1]))
        for _, r in bf.iterrows():
            if r["transition"] != "range_end":
                assert r["to"] <= r["at"] - r["at_unc"] + 1e-12 or r["at_unc"] == 0
    cont = rt[rt["source"] == "continuation"]
    assert len(cont) >= 1
    # the branch point at mu = 0.1 is a sweep value: checked against the brute-force section
    assert cont["agrees"].notna().all()
    for a in cont["agrees"]:
        assert a == "yes" or a.startswith(("no at", "n/a", "not checked"))
        if a.startswith("no at"):
            assert "(" in a          # the reason is given
    # and independently: the branch's section point against the stored brute-force section
    from nld.output.io import load_table
    sw, _ = load_table(out / "rhee1996_sweeps.parquet")
    br = pd.read_csv(out / "rhee1996_route_branch.csv")
    from nld.model.scene import load_scene
    c = load_scene(study.SCENE).joints["B"].clearance
    fr = sw[(sw["case"] == "friction") & (sw["rev"] >= 0)] if "case" in sw.columns else sw
    for _, b in br[br["value"].isin(study.MODE_SETTINGS["frictions"])].iterrows():
        pts = fr[np.isclose(fr["value"], b["value"])][["B.ex", "B.ey"]].to_numpy()[-8:]
        d = np.max(np.abs(pts - b[["B.ex", "B.ey"]].to_numpy(float))) / c
        row = cont[(cont["from"] <= b["value"]) & (cont["to"] >= b["value"])].iloc[0]
        if b["stability"] != "unstable":
            assert (d <= study.PERIOD_TOL_ROUTE) == (row["agrees"] == "yes"), (d, row["agrees"])
