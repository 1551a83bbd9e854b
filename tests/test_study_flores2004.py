"""Study flores2004 (studies/flores2004.py) in quick mode: files, pages, tables against the stored series.

Quick mode: 3 clearances x (2 transient + 10 revolutions) at rtol 1e-8, 2880 samples per revolution,
and the ideal twin; about 15-20 s on two cores with a warm kernel cache (one compilation otherwise).
"""
from __future__ import annotations

import numpy as np
import pytest

from nld.output.io import load_table
from nld.output.report import Report
from study_harness import count_pages, run_quick


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    return run_quick("flores2004.py", tmp_path_factory)


def test_quick_writes_pdf_and_data(quick_run):
    study, out, pdf = quick_run
    assert pdf == out / "flores2004.pdf" and pdf.is_file()
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF")
    assert b"quick" in data                          # PDF keywords carry the mode
    # title page(s) + intro, key-number table, findings, why they differ, slider acceleration,
    # crank moment, orbits, contact force, 2 clearance-size pages, peaks vs clearance,
    # per-revolution table, run statistics; long text pages continue on up to 2 more pages
    title_pages = Report(out / "x.pdf", study.TITLE, scene=study.SCENE).title_page_count()
    assert title_pages + 13 <= count_pages(pdf) <= title_pages + 15
    for f in ("flores2004.parquet", "flores2004_summary.csv", "flores2004_per_rev.csv"):
        assert (out / f).is_file(), f


def test_parquet_cases_and_provenance(quick_run):
    study, out, _ = quick_run
    df, prov = load_table(out / "flores2004.parquet")
    names = [study.case_name(c) for c in study.CLEARANCES]
    assert set(df["case"]) == set(names) | {"ideal"}
    assert prov["mode"] == "quick" and prov["scene"] == "slider_crank"
    assert prov["rtol"] == study.QUICK["rtol"]
    assert "git_hash" in prov and "scene_parameters" in prov
    n = (df["case"] == "ideal").sum()
    assert n == study.QUICK["plotted_revs"] * study.QUICK["samples_per_rev"] + 1
    for name in names:
        assert prov["cases"][name]["success"], prov["cases"][name]["message"]
        rows = df[df["case"] == name]
        assert len(rows) == n                        # same output times as the ideal twin
        assert np.allclose(rows["t"].to_numpy(), df.loc[df["case"] == "ideal", "t"].to_numpy())
        assert set(np.unique(rows["mode"])) <= {0, 1, 2}


def test_summary_equals_max_of_stored_series(quick_run):
    study, out, _ = quick_run
    df, _ = load_table(out / "flores2004.parquet")
    s, _ = load_table(out / "flores2004_summary.csv")
    s = s.set_index("case")
    for name in list(s.index):
        rows = df[df["case"] == name]
        assert s.loc[name, "peak_abs_slider_ax_m_s2"] == pytest.approx(rows["slider.ax"].abs().max(), rel=1e-12)
        assert s.loc[name, "peak_abs_torque_Nm"] == pytest.approx(rows["driver.torque"].abs().max(), rel=1e-12)
        fn = rows["B.F"] if name == "ideal" else rows["B.Fn"]
        assert s.loc[name, "peak_Fn_N"] == pytest.approx(fn.max(), rel=1e-12)
        if name != "ideal":
            mode = rows["mode"].to_numpy()
            assert s.loc[name, "free_flight_pct"] == pytest.approx(100 * np.mean(mode == 0), rel=1e-12)
            assert s.loc[name, "max_penetration_m"] == pytest.approx(rows["B.penetration"].max(), rel=1e-12)
    # impacts make the peaks exceed the ideal-joint ones at the benchmark clearance
    bench = study.case_name(study.BENCHMARK_CLEARANCE)
    assert s.loc[bench, "ax_over_ideal"] > 1 and s.loc[bench, "Fn_over_ideal"] > 1


def test_per_revolution_peaks(quick_run):
    study, out, _ = quick_run
    df, _ = load_table(out / "flores2004.parquet")
    pr, _ = load_table(out / "flores2004_per_rev.csv")
    for name, g in pr.groupby("case"):
        assert sorted(g["revolution"]) == list(range(study.QUICK["stats_revs"]))
        # the plotted revolutions are the stored window: their peaks are the window's peak
        rows = df[df["case"] == name]
        assert g.loc[g["plotted"], "peak_abs_slider_ax_m_s2"].max() == pytest.approx(
            rows["slider.ax"].abs().max(), rel=1e-12)
    # beside each window peak (a single extreme) the summary gives the per-revolution mean with its
    # 95 % batch-means interval (nld.analysis.peaks.peak_interval of the per-revolution peaks)
    from nld.analysis.peaks import peak_interval
    s, _ = load_table(out / "flores2004_summary.csv")
    s = s.set_index("case")
    for name, g in pr.groupby("case"):
        for col in ("peak_Fn_N", "peak_abs_slider_ax_m_s2", "peak_abs_torque_Nm"):
            v = g.sort_values("revolution")[col].to_numpy()
            iv = peak_interval(v)
            assert s.loc[name, f"{col}_rev_mean"] == pytest.approx(v.mean(), rel=1e-12)
            assert s.loc[name, f"{col}_rev_ci95"] == pytest.approx(iv.half_width, rel=1e-12) and iv.half_width > 0
            assert v.min() < s.loc[name, f"{col}_rev_mean"] < v.max() and s.loc[name, col] <= v.max()
    assert np.isnan(s.loc["ideal", "peak_Fn_N_rev_mean"])
