"""The Study scaffold (nld.study): the example study of docs/studies.md ("Adding a study") runs in
quick mode, directly and through `nld study`, and writes its PDF and its data with provenance; the
process pool of a study loaded from its file works; the shared helpers behave as the studies did."""
from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest

from study_harness import ROOT, count_pages, load_study


def example_source() -> str:
    """The example study of docs/studies.md (the first python block under "## Adding a study")."""
    text = (ROOT / "docs" / "studies.md").read_text()
    section = text.split("## Adding a study", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


@pytest.fixture
def example(tmp_path, monkeypatch):
    d = tmp_path / "studies"
    d.mkdir()
    path = d / "lorenz_demo.py"
    path.write_text(example_source())
    monkeypatch.setenv("NLD_STUDIES_DIR", str(d))
    monkeypatch.delenv("NLD_WORKERS", raising=False)
    return path


def check_outputs(out: Path, pdf: Path, mode: str = "quick"):
    assert pdf == out / "lorenz_demo.pdf" and pdf.is_file() and count_pages(pdf) >= 4
    from nld.output.io import load_table
    table, prov = load_table(out / "lorenz_demo_summary.csv")
    assert (out / "lorenz_demo_summary.csv.json").is_file()
    assert list(prov)[:4] == ["study", "mode", "nld_version", "git_hash"]
    assert prov["study"] == "lorenz_demo" and prov["mode"] == mode
    assert prov["rtol"] == 1e-6 and prov["settings"]["rhos"] == [10.0, 28.0]
    assert "Lorenz" in prov["source"] and prov["compute_wall_s"] > 0
    assert list(table["rho"]) == [10.0, 28.0] and (table["z_max"] > table["z_min"]).all()
    return table


def test_example_study_quick_writes_pdf_and_provenance(example, tmp_path):
    from study_harness import ReportRecorder
    mod = load_study(example)
    with ReportRecorder() as rec:
        pdf = mod.main(quick=True, out_dir=tmp_path / "out")
    check_outputs(tmp_path / "out", pdf)
    info = dict(rec.info)
    assert info["Mode"] == "QUICK MODE: 5 s per run" and info["Runs"] == "2 x 5 s"
    assert info["Method"] == "scipy RK45" and info["rtol"] == "1e-06"
    assert rec.figure("Range of z")["axes"][0]["xlabel"] == "rho [-]"


def test_example_study_through_nld_study_with_a_worker_pool(example, tmp_path, monkeypatch, capsys):
    """`nld study` imports the study under another name; NLD_WORKERS=2 sends the runs to two
    spawned processes, which import the study from its folder: the same numbers."""
    from nld.cli import main
    out = tmp_path / "pool"
    monkeypatch.setenv("NLD_WORKERS", "2")
    assert main(["study", "lorenz", "--quick", "--quiet", "--out", str(out)]) == 0
    pooled = check_outputs(out, out / "lorenz_demo.pdf")
    monkeypatch.setenv("NLD_WORKERS", "1")
    assert main(["study", "lorenz", "--quick", "--quiet", "--out", str(tmp_path / "one")]) == 0
    pd.testing.assert_frame_equal(pooled, check_outputs(tmp_path / "one", tmp_path / "one" / "lorenz_demo.pdf"))


def test_study_modes_paths_and_labels(example, tmp_path):
    from nld.study import Study
    mod = load_study(example)
    full = Study(vars(mod), False, tmp_path / "a" / "b")
    assert full.out_dir.is_dir() and full.mode == "full" and not full.quick and full.label == "full mode"
    assert full.settings == mod.FULL and full.settings is not mod.FULL
    assert full.pdf == tmp_path / "a" / "b" / "lorenz_demo.pdf"
    assert full.path("_x.csv").name == "lorenz_demo_x.csv"
    quick = Study(vars(mod), True, tmp_path)
    assert quick.quick and quick.label == "QUICK MODE: 5 s per run"
    assert quick.work_dir("map").parent == tmp_path / ".work"
    assert quick.work_dir("map").name.startswith("lorenz_demo-quick-map-")


def test_shared_helpers(monkeypatch):
    from nld.study import NOT_SHOWN, drop_timing, run_table, timing, verdict
    assert verdict(2.0, 0.5, 60, 50) == "chaotic"
    assert verdict(2.0, 0.5, 8, 50) == "λ1 > 0, short"
    assert verdict(-2.0, 0.5, 8, 50) == "regular"
    assert verdict(0.1, 0.5, 80, 50) == "uncertain"
    assert verdict(float("nan"), 0.5, 80, 50) == "failed"
    assert verdict(2.0, 0.5, 80, 50, failed=True) == "failed"
    from nld.study import NOT_ESTABLISHED, checked_verdict
    assert checked_verdict("chaotic", "chaotic") == "chaotic"
    assert checked_verdict("regular", None) == "regular"           # not checked
    assert checked_verdict("chaotic", "regular") == NOT_ESTABLISHED  # rhee1996 c = 0.05 mm
    assert checked_verdict("chaotic", "uncertain") == NOT_ESTABLISHED
    assert checked_verdict("regular", "failed") == "failed"
    runs = {"a": {"success": 1, "stats": {"accepted": 10}, "contact_events": 3, "wall_s": 1.234}}
    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    assert timing("1.0 s") == "1.0 s"
    df = run_table(runs, {"accepted steps": "stats.accepted", "events": "contact_events"})
    assert df.to_dict(orient="records") == [{"case": "a", "success": True, "accepted steps": 10,
                                              "events": 3, "wall time": 1.23}]
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    assert timing("1.0 s") == NOT_SHOWN
    assert "wall time" not in run_table(runs, {}).columns
    assert list(drop_timing(df, "wall time").columns) == ["case", "success", "accepted steps", "events"]


def test_merge_checks_needs_the_same_word_and_agreeing_exponents():
    """The verdict check of the studies' sweeps is the one rule (nld.analysis.verdict): the
    same word *and* exponents within CHECK_FACTOR x their combined uncertainty."""
    import pandas as pd

    from nld.study import merge_checks
    pts = pd.DataFrame({"value": [1.0, 2.0, 3.0], "verdict_main": ["chaotic"] * 3,
                        "lambda_per_rev": [3.0, 3.0, 3.0], "lambda_unc_per_rev": [0.1] * 3})
    chk = pd.DataFrame({"value": [1.0, 2.0, 3.0], "verdict_main": ["chaotic", "chaotic", "regular"],
                        "lambda_per_rev": [3.4, 9.0, -1.0], "lambda_unc_per_rev": [0.1] * 3,
                        "status": ["ok"] * 3})
    out = merge_checks(pts, chk)
    assert list(out["verdict"]) == ["chaotic", "not established", "not established"]
    assert list(out["verdict_check"]) == ["chaotic", "chaotic", "regular"]
