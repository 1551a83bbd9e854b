"""Study rhee1996 (studies/rhee1996.py) in quick mode: files, pages, tables consistent with the data.

Quick mode takes about 20-25 s on two cores with a warm kernel cache (six four-bar cases and two
three-point sweeps at rtol 1e-7).
"""
from __future__ import annotations

import numpy as np
import pytest

from nld.io import load_table
from nld.report import Report
from study_harness import count_pages, run_quick


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    return run_quick("rhee1996.py", tmp_path_factory)


def test_quick_writes_pdf_and_data(quick_run):
    study, out, pdf = quick_run
    assert pdf == out / "rhee1996.pdf" and pdf.is_file()
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF") and b"quick" in data
    # title page(s) + intro, findings, case table, sweep table, sections, 2 sweeps, spectra,
    # convergence, discussion
    title_pages = Report(out / "x.pdf", study.TITLE, scene=study.SCENE).title_page_count()
    assert count_pages(pdf) == title_pages + 10
    for suffix in ("", "_sections", "_sweeps", "_spectra"):
        assert (out / f"rhee1996{suffix}.parquet").is_file()
    assert (out / "rhee1996_summary.csv").is_file()


def test_summary_matches_stored_series(quick_run):
    study, out, _ = quick_run
    runs, prov = load_table(out / "rhee1996.parquet")
    summary, _ = load_table(out / "rhee1996_summary.csv")
    sections, _ = load_table(out / "rhee1996_sections.parquet")
    assert prov["mode"] == "quick" and prov["scene"] == "four_bar"
    assert set(summary["case"]) == set(study.CASES) == set(runs["case"])
    for _, row in summary.iterrows():
        fn = runs.loc[runs["case"] == row["case"], "B.Fn"].to_numpy()
        assert row["max_Fn"] == pytest.approx(fn.max(), rel=1e-12)
        assert row["rms_Fn"] == pytest.approx(np.sqrt(np.mean(fn ** 2)), rel=1e-9)
        assert row["status"] == "ok"
        assert (sections["case"] == row["case"]).sum() == study.QUICK["section_revs"]
        assert np.isfinite(row["lambda_per_rev"]) and row["lambda_unc_per_rev"] >= 0


def test_sweep_exponents_match_table(quick_run):
    study, out, _ = quick_run
    sweeps, prov = load_table(out / "rhee1996_sweeps.parquet")
    period = 2 * np.pi / prov["scene_parameters"]["driver"]["speed"]
    assert set(sweeps["case"]) == {"clearance", "friction"}
    sw = sweeps[sweeps["case"] == "friction"]
    fr = sw.drop_duplicates("index")
    assert sorted(fr["value"].astype(float)) == sorted(study.QUICK["frictions"])
    pts = study.sweep_points(sw, period, clearance=0.25e-3)
    assert np.allclose(pts["lambda_per_rev"], fr.sort_values("index")["lyapunov"] * period)
    assert len(sw[sw["index"] == 0]) == study.QUICK["sweep_revs"]
    # friction makes the four-bar regular: the largest coefficient has a smaller exponent than mu = 0
    assert pts["lambda_per_rev"].iloc[-1] < pts["lambda_per_rev"].iloc[0]
