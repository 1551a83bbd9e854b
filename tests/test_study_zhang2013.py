"""Study zhang2013_excavator (studies/zhang2013_excavator.py) in smoke mode (quick mode, the main
job as a user runs it, under -m slow): files, pages, table.

Quick mode (studies/zhang2013_excavator.py QUICK, ANALYSIS_QUICK): 5 cases x (1 + 5) crank revolutions
at rtol 1e-6 with the per-revolution peaks located (nld.analysis.extrema), then the chaos analysis: 5 sweep
points x (1 + 2 + 2 x 2) revolutions, all at rtol 1e-7. About 30-45 s on two cores with a warm kernel cache.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import os
import shutil
import subprocess

from nld.cli import main
from nld.output.io import load_table
from nld.output.report import Report
from study_harness import MODES, ROOT, count_pages, load_study


def _tracked_state():
    """git's view of the tracked files (status) and the mtimes of the committed reports, or None
    outside a git checkout."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        return None
    status = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
                            capture_output=True, text=True, timeout=60).stdout
    files = subprocess.run(["git", "-C", str(ROOT), "ls-files", "reports", "studies"],
                           capture_output=True, text=True, timeout=60).stdout.split()
    return status, {f: (ROOT / f).stat().st_mtime_ns for f in files if (ROOT / f).exists()}


@pytest.fixture(scope="module", params=MODES)
def quick_run(request, tmp_path_factory):
    """The main job as a user runs it, from a fresh directory: ``nld study zhang2013 --quick``
    through the command line, writing to ./nld-out/ (the default), under -m slow; in the default
    run the study's smoke mode (SMOKE, ANALYSIS_SMOKE: no route) into ./nld-out/ of a fresh
    directory. The module gets MODE, MODE_SETTINGS and MODE_ANALYSIS."""
    mode = request.param
    study = load_study("zhang2013_excavator.py")
    cwd = tmp_path_factory.mktemp(f"zhang2013_cwd_{mode}")
    before = _tracked_state()
    old = os.getcwd()
    os.chdir(cwd)
    try:
        if mode == "quick":
            assert main(["study", "zhang2013", "--quick", "--quiet"]) == 0
        else:
            study.main(quick=True, smoke=True, out_dir=cwd / "nld-out")
    finally:
        os.chdir(old)
    study.MODE, study.MODE_SETTINGS = mode, getattr(study, mode.upper())
    study.MODE_ANALYSIS = getattr(study, f"ANALYSIS_{mode.upper()}")
    out = cwd / "nld-out"
    return study, out, out / "zhang2013_excavator.pdf", before


def test_the_main_job_leaves_the_checkout_clean(quick_run):
    """No tracked file changes (the committed full-mode reports in reports/ are not touched)."""
    before = quick_run[3]
    if before is None:
        pytest.skip("not a git checkout")
    after = _tracked_state()
    assert after[0] == before[0]
    assert after[1] == before[1]


def test_no_section_under_the_minimum_is_called_chaotic(quick_run):
    """Quick mode's sections have 2 points: a positive exponent reads 'λ1 > 0, short', never
    'chaotic'; every exponent carries its estimator settings (rtol of the analysis)."""
    import json
    study, out, _, _ = quick_run
    pts, _ = load_table(out / "zhang2013_excavator_chaos.csv")
    short = pts[pts["section_points"] < study.MIN_SECTION_POINTS]
    assert len(short) == len(pts) and (short["verdict"] != "chaotic").all()
    pos = pts[(pts["status"] == "ok") & (pts["lambda_per_rev"] - pts["lambda_unc_per_rev"] > 0)]
    assert (pos["verdict"] == "λ1 > 0, short").all()
    for st in pts.loc[pts["status"] == "ok", "estimator_settings"]:
        d = json.loads(st)
        assert d["rtol"] == study.MODE_ANALYSIS["rtol"] and d["total"] > 0 and d["method"]
    assert study.verdict("ok", 2.0, 0.5, 60) == "chaotic"
    assert study.verdict("ok", 2.0, 0.5, 8) == "λ1 > 0, short"
    assert study.verdict("ok", -2.0, 0.5, 8) == "regular"
    line = study.estimator_line(pts, 2 * np.pi / study.OMEGA1)
    assert "rtol 1e-07" in line and "averaged over 2 rev" in line


def test_quick_writes_pdf_parquet_and_summary(quick_run):
    study, out, pdf, _ = quick_run
    assert pdf == out / "zhang2013_excavator.pdf" and pdf.is_file()
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF")
    assert study.MODE.encode() in data              # PDF Keywords carry the mode
    # title page(s) + intro, summary table, peak-location table, maxima figure, 3 discussion pages
    # (trends, figure by figure, why), 3 figures x 2 groups, 2 force pages, the phase plot, the chaos
    # analysis (text, exponent table, sections, 2 bifurcation diagrams, spectra), the route to chaos
    # (one page per sweep), the run statistics
    title_pages = Report(out / "x.pdf", study.TITLE, scene=study.SCENE).title_page_count()
    # (a text page longer than 30 wrapped lines continues on a second page: the intro and the
    # figure-by-figure page may, depending on the numbers)
    assert title_pages + 25 <= count_pages(pdf) <= title_pages + 28
    assert (out / "zhang2013_excavator.parquet").is_file()
    # the route as data: both sweeps, in order
    route = pd.read_csv(out / "zhang2013_excavator_route.csv")
    assert set(route["sweep"]) == {"clearance", "friction"}
    for _, g in route.groupby("sweep"):
        assert list(g["order"]) == list(range(1, len(g) + 1)) and (g["from"] <= g["to"]).all()
    assert (out / "zhang2013_excavator_summary.csv").is_file()


def test_parquet_holds_every_case_with_provenance(quick_run):
    study, out, _, _ = quick_run
    df, prov = load_table(out / "zhang2013_excavator.parquet")
    assert list(df.columns[:2]) == ["case", "steady"]
    assert set(df["case"]) == set(study.CASES) | {"ideal"}
    assert prov["mode"] == study.MODE and prov["scene"] == "excavator"
    assert prov["rtol"] == study.MODE_SETTINGS["rtol"]
    assert "git_hash" in prov and "scene_parameters" in prov
    for name in study.CASES:
        assert prov["cases"][name]["success"], prov["cases"][name]["message"]
        n = (df["case"] == name).sum()
        assert n == (df["case"] == "ideal").sum()     # same output times as the ideal twin
        assert df.loc[df["case"] == name, "steady"].any()
        # the stored samples: transient + plotted revolutions at samples_per_rev / keep_every
        q = study.MODE_SETTINGS
        assert n == (q["transient_revs"] + q["plot_revs"]) * q["samples_per_rev"] // q["keep_every"] + 1


def test_summary_is_the_mean_of_the_stored_per_revolution_maxima(quick_run):
    """Each 'nld' value is the mean, '± 95 %' the half-width of the 95 % interval
    (nld.analysis.peaks.peak_interval), of the located maxima of the steady revolutions stored in
    _maxima.csv; there are QUICK['steady_revs'] of them per case and quantity, every one
    converged; the paper's numbers are those of CASES."""
    from nld.analysis.peaks import peak_interval
    study, out, _, _ = quick_run
    summary, _ = load_table(out / "zhang2013_excavator_summary.csv")
    maxima, _ = load_table(out / "zhang2013_excavator_maxima.csv")
    n = study.MODE_SETTINGS["steady_revs"]
    assert set(summary["case"]) == set(study.CASES) == set(maxima["case"])
    for qty, (col, _, unit) in study.QUANTITIES.items():
        for name, (_, _, _, paper) in study.CASES.items():
            row = summary[(summary["quantity"] == qty) & (summary["case"] == name)]
            assert len(row) == 1
            row = row.iloc[0]
            m = maxima[(maxima["case"] == name) & (maxima["column"] == col)]
            assert sorted(m["rev"]) == list(range(n)) and row["revs"] == n
            assert row["unit"] == unit
            assert row["nld"] == pytest.approx(m["peak"].mean(), rel=1e-12)
            iv = peak_interval(m.sort_values("rev")["peak"].to_numpy(float), 0.95)
            assert row["± 95 %"] == pytest.approx(iv.half_width, rel=1e-9)
            assert row["batch"] == iv.batch and row["realisations"] == 1
            assert row["sampled"] == pytest.approx(m["sampled"].mean(), rel=1e-12)
            assert m["converged"].all()
            if col == "rod.omega":
                assert row["paper"] == paper or (np.isnan(paper) and np.isnan(row["paper"]))


def test_located_peaks_not_below_the_samples_and_inside_their_revolution(quick_run):
    """refined >= detection-sampled >= stored-sampled in every revolution; each peak time lies in its
    revolution; the sampled maxima equal the stored table's where the table holds the revolution."""
    study, out, _, _ = quick_run
    maxima, prov = load_table(out / "zhang2013_excavator_maxima.csv")
    df, _ = load_table(out / "zhang2013_excavator.parquet")
    period = 2 * np.pi / study.OMEGA1
    assert (maxima["peak"] >= maxima["detected"]).all()
    assert (maxima["detected"] >= maxima["sampled"]).all()
    assert ((maxima["t_peak"] >= maxima["t_start"] - 1e-12)
            & (maxima["t_peak"] <= maxima["t_start"] + period + 1e-12)).all()
    # the located peak is well above the sampled one somewhere: the sampling does limit the peaks
    assert (maxima["peak"] > 1.05 * maxima["sampled"]).any()
    ts = study.MODE_SETTINGS["transient_revs"] * period
    for name in study.CASES:
        rows = df[(df["case"] == name) & df["steady"]]
        first = rows[rows["t"] <= ts + period + 1e-9]
        m = maxima[(maxima["case"] == name) & (maxima["rev"] == 0) & (maxima["column"] == "rod.omega")]
        assert m["sampled"].iloc[0] == pytest.approx(np.abs(first["rod.omega"]).max(), rel=1e-12)
    # the check run at check_factor x the samples finds the same peaks (same trajectory)
    check, _ = load_table(out / "zhang2013_excavator_maxima_check.csv")
    assert len(check) == len(study.CASES) * len(study.QUANTITIES) * study.MODE_SETTINGS["check_revs"]
    merged = check.merge(maxima, on=["case", "column", "rev"], suffixes=("_chk", ""))
    assert len(merged) == len(check)
    if study.MODE != "smoke":       # smoke's 1440 samples per revolution miss narrow spikes (the
        # located peaks stop depending on the sampling from 14400: the study's comment)
        assert np.allclose(merged["peak"], merged["peak_chk"], rtol=1e-3)


def test_clearance_raises_the_peaks(quick_run):
    """Impacts make the rod turn faster than with ideal joints; the 0.5 mm clearance more than the
    0.01 mm one (in the mean of the located per-revolution maxima)."""
    study, out, _, _ = quick_run
    summary, _ = load_table(out / "zhang2013_excavator_summary.csv")
    om = summary[summary["quantity"] == "max |rod.omega|"].set_index("case")
    assert (om["nld"] > om["ideal joints"]).all()
    assert om.loc["r=0.5mm", "nld"] > om.loc["r=0.01mm", "nld"]


def test_chaos_analysis_table_matches_stored_sections(quick_run):
    study, out, _, _ = quick_run
    pts, prov = load_table(out / "zhang2013_excavator_chaos.csv")
    secs, _ = load_table(out / "zhang2013_excavator_sections.parquet")
    an = study.MODE_ANALYSIS
    assert prov["analysis"]["rtol"] == an["rtol"]
    # the route's points below the committed sweep are added to it (docs/route.md)
    assert sorted(pts.loc[pts["sweep"] == "clearance", "value"]) == sorted(
        set(an["clearances"]) | set(study.ROUTE_CLEARANCES[study.MODE]))
    assert sorted(pts.loc[pts["sweep"] == "friction", "value"]) == sorted(an["frictions"])
    # every paper case is a point of a sweep, with a finished section and a finite exponent
    swept = {"clearance": an["clearances"], "friction": an["frictions"]}
    for name, (sweep, value) in study.CASE_POINTS.items():
        if not np.isclose(swept[sweep], value).any():
            continue              # smoke mode sweeps one point of each
        p = pts[(pts["sweep"] == sweep) & np.isclose(pts["value"], value)]
        assert len(p) == 1 and p["status"].iloc[0] == "ok", name
        s = secs[(secs["sweep"] == sweep) & np.isclose(secs["value"], value) & (secs["rev"] >= 0)]
        assert len(s) == p["section_points"].iloc[0] == an["section_revs"]
        assert np.isfinite(p["lambda_per_rev"].iloc[0])
        # the journal stays within its clearance plus the contact penetration (a few µm under ~10 kN)
        assert (np.hypot(s["A.ex"], s["A.ey"]) < study._case_clearance(name, "A") + 10e-6).all()
    period = 2 * np.pi / study.OMEGA1
    ok = pts[pts["status"] == "ok"]
    assert np.allclose(ok["lambda_per_rev"], ok["lambda"] * period, rtol=1e-9)
    spectra, _ = load_table(out / "zhang2013_excavator_spectra.parquet")
    assert {f"{n}:{j}" for n in study.CASES for j in "AB"} == set(spectra["case"])


def test_the_verdict_check_runs_from_the_section_end(monkeypatch):
    """Full mode's check (not in quick mode): a point with a definite verdict gets its exponent
    again from the same section end, at rtol_check over check_span x the span; the row carries
    both verdicts and the checked one (nld.study.checked_verdict)."""
    import nld.analysis.lyapunov as lyap
    study = load_study("zhang2013_excavator.py")
    an = dict(study.ANALYSIS_SMOKE, lyap_revs=1, rtol_check=1e-8, check_span=2)
    calls = []
    real = lyap.largest_exponent

    def spy(system, estimator, **kw):
        calls.append((system.y0.copy(), system.z0.copy(), kw["rtol"], kw["total"]))
        return real(system, estimator, **kw)
    monkeypatch.setattr(lyap, "largest_exponent", spy)
    # a definite verdict whatever 1 revolution gives (the check is what is tested here)
    monkeypatch.setattr(study, "verdict", lambda status, per, uper, n: "chaotic" if status == "ok" else "failed")
    _, row = study.analysis_point("friction", 0, 0.0, an)
    assert row["status"] == "ok", row["message"]
    assert len(calls) == 2
    (y1, z1, r1, T1), (y2, z2, r2, T2) = calls
    np.testing.assert_array_equal(y1, y2)                # the same start: the same motion
    np.testing.assert_array_equal(z1, z2)
    assert (r1, r2) == (an["rtol"], an["rtol_check"]) and T2 == pytest.approx(2 * T1)
    assert np.isfinite(row["lambda_check_per_rev"]) and row["lambda_check_unc_per_rev"] > 0
    assert row["verdict_main"] == row["verdict_check"] == row["verdict"] == "chaotic"
    # no check where the verdict is uncertain
    calls.clear()
    monkeypatch.setattr(study, "verdict", lambda status, per, uper, n: "uncertain")
    _, row = study.analysis_point("friction", 0, 0.0, an)
    assert len(calls) == 1 and row["verdict_check"] == "" and row["verdict"] == "uncertain"

    # a check that fails keeps the main result and says so: verdict 'failed' (checked_verdict)
    calls.clear()
    monkeypatch.setattr(study, "verdict", lambda status, per, uper, n: "chaotic" if status == "ok" else "failed")

    def failing(system, estimator, **kw):
        calls.append(kw["rtol"])
        if kw["rtol"] == an["rtol_check"]:
            raise RuntimeError("integration stopped")
        return real(system, estimator, **kw)
    monkeypatch.setattr(lyap, "largest_exponent", failing)
    tab, row = study.analysis_point("friction", 0, 0.0, an)
    assert row["status"] == "ok" and np.isfinite(row["lambda_per_rev"]) and (tab["rev"] >= 0).all()
    assert row["verdict_check"] == "failed" == row["verdict"] and "check failed" in row["message"]
