"""Study work_precision (studies/work_precision.py) in quick mode: pages, data, recommendation.

Quick mode: slider_crank, dopri5 and scipy:LSODA, rtol 1e-5 / 1e-7 / 1e-9, reference dop853 at
rtol 1e-12; about 10 s with a warm kernel cache (NLD_CACHE_DIR).
"""
from __future__ import annotations

import importlib.util
import math
import re
from pathlib import Path

import numpy as np
import pytest

from nld.output.io import load_table
from nld.output.report import Report

ROOT = Path(__file__).resolve().parent.parent
STUDY = ROOT / "studies" / "work_precision.py"


def load_study():
    spec = importlib.util.spec_from_file_location("work_precision_study_under_test", STUDY)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def count_pages(path) -> int:
    try:
        from pypdf import PdfReader
    except ImportError:
        return len(re.findall(rb"/Type\s*/Page(?![a-zA-Z])", path.read_bytes()))
    return len(PdfReader(str(path)).pages)


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    study = load_study()
    out = tmp_path_factory.mktemp("work_precision")
    pdf = study.main(quick=True, out_dir=out, log=lambda *a: None)
    runs, prov = load_table(out / "work_precision.parquet")
    rec, _ = load_table(out / "work_precision_recommended.parquet")
    return study, out, pdf, runs, prov, rec


def test_quick_pdf_pages(quick_run):
    study, out, pdf, runs, prov, _ = quick_run
    assert pdf == out / "work_precision.pdf" and pdf.is_file()
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF") and b"quick" in data
    pages = prov["pages"]
    cases = study.QUICK["cases"]
    assert pages["text"] == 1 and pages["recommendation"] == 1
    assert pages["figures"] == len(cases)                      # one work-precision page per case
    assert pages["runs_table"] == math.ceil(len(runs) / 24)    # the table of every run
    title_pages = Report(out / "x.pdf", study.TITLE).title_page_count()
    assert count_pages(pdf) == title_pages + 1 + 1 + len(cases) + math.ceil(len(runs) / 24)


def test_every_run_stored_with_a_different_reference(quick_run):
    study, _, _, runs, prov, _ = quick_run
    q = study.QUICK
    assert len(runs) == len(q["cases"]) * len(q["methods"]) * len(q["ladder"])
    assert prov["mode"] == "quick" and prov["reference_rtol"] <= 1e-12
    assert "git_hash" in prov and "nld_version" in prov
    for c in q["cases"]:
        assert prov["cases"][c]["timed_call_equals_simulate"]
    for m, ref in zip(runs["method"], runs["reference"]):
        assert ref in study.REF_CANDIDATES and study.FAMILY[ref] != study.FAMILY[m]
    assert (runs["status"] >= 0).all()
    assert runs["journal_err_rel"].notna().all() and (runs["cpu_s"] > 0).all()


def test_recommendation_table_matches_stored_runs(quick_run):
    study, _, _, runs, prov, rec = quick_run
    for _, r in rec.iterrows():
        d = runs[runs["case"] == r["case"]]
        row = d[(d["method"] == r["method"]) & (d["rtol"] == r["rtol"])]
        assert len(row) == 1
        row = row.iloc[0]
        # the table's numbers are the stored run's numbers
        assert r["journal err / c"] == row["journal_err_rel"]
        assert r["peak-force err"] == row["peak_force_err"]
        assert r["CPU per window"] == pytest.approx(1e3 * row["cpu_s"], rel=1e-12)
        assert r["rev/s"] == pytest.approx(prov["cases"][r["case"]]["window_revs"] / row["cpu_s"], rel=1e-12)
        # it meets the criterion, and no cheaper run of the case does
        meets = ((d["journal_err_rel"] <= study.REC_JOURNAL) & (d["peak_force_err"].fillna(0) <= study.REC_FORCE)
                 & ((d["n_onsets_ref"].fillna(0) == 0) | (d["onset_err_rel"] <= study.REC_ONSET)))
        assert bool(r["criterion met"]) == bool(meets.any())
        if r["criterion met"]:
            assert meets[row.name] if row.name in meets.index else False
            assert row["cpu_s"] == d.loc[meets, "cpu_s"].min()


def test_error_decreases_as_tolerance_tightens(quick_run):
    """On the window (a couple of Lyapunov times from the centred start) each method's journal error
    falls with every rung of the ladder (two decades each), by > 100x over the ladder."""
    _, _, _, runs, _, _ = quick_run
    for (case, method), d in runs.groupby(["case", "method"]):
        d = d.sort_values("rtol", ascending=False)
        err = d["journal_err"].to_numpy()
        assert np.all(np.diff(err) < 0), (case, method, err)
        assert err[-1] < err[0] / 100, (case, method, err)
        # peak contact force too, over the whole ladder
        f = d["peak_force_err"].to_numpy()
        assert f[-1] < f[0], (case, method, f)
