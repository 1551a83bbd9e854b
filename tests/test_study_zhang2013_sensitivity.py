"""Study zhang2013_sensitivity (studies/zhang2013_sensitivity.py, issue 28).

Default run (a few seconds, no integration: the suite's 5-minute budget has no room for the
excavator's compilation here): the smoke mode with ``revolution_maxima`` replaced by a stand-in that
returns known per-revolution peaks, so that the study's own code runs end to end (grid, per-point
files, resume, tables with provenance, the answer, the report and the page the zhang2013 study
borrows). ``-m slow``: the same smoke mode integrated for real (25 s cold) and the quick mode through
``nld study`` (about 40 s warm on 2 cores).
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from nld.analysis.peaks import peak_interval
from nld.output.io import load_table
from study_harness import ROOT, load_study

CALLS = []


def fake_revolution_maxima(scene, columns, *, revs, transient_revs, samples_per_rev, keep_every, **kw):
    """Peaks 10 + rev + 10 mu (mu at A) + 5 [reversed kernel], the crank at its speed."""
    CALLS.append(scene)
    mu = kw["kernel"].params()[kw["kernel"].layout.index["joints.A.friction.mu"]] if kw.get("kernel") \
        else scene.joints["A"].friction.mu
    peaks = 10.0 + np.arange(revs) + 10.0 * abs(mu) + (5.0 if mu < 0 else 0.0)
    n = (transient_revs + revs) * samples_per_rev // keep_every + 1
    t = np.linspace(0.0, (transient_revs + revs) * 2 * math.pi / scene.driver.speed, n)
    table = pd.DataFrame({"t": t, "rod.omega": np.sin(t), "driver.torque": np.full(n, 80.0),
                          "crank.omega": np.full(n, scene.driver.speed)})
    maxima = pd.DataFrame({"rev": np.arange(revs), "column": "rod.omega", "peak": peaks})
    return SimpleNamespace(success=True, maxima=maxima, table=table, message="ok", t_reached=float(t[-1]),
                           stats={"accepted": 10, "rejected": 1}, events=3, status=0)


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    import nld.analysis.extrema as extrema
    study = load_study("zhang2013_sensitivity.py")
    out = tmp_path_factory.mktemp("zhang2013_sensitivity")
    real = extrema.revolution_maxima
    extrema.revolution_maxima = fake_revolution_maxima
    try:
        pdf = study.main(quick=False, out_dir=out, smoke=True)
    finally:
        extrema.revolution_maxima = real
    return study, out, pdf


def test_smoke_writes_the_report_and_the_tables_with_provenance(smoke):
    study, out, pdf = smoke
    assert pdf == out / "zhang2013_sensitivity.pdf" and pdf.read_bytes().startswith(b"%PDF")
    assert b"smoke" in pdf.read_bytes()
    summary, prov = load_table(out / "zhang2013_sensitivity_summary.csv")
    peaks, _ = load_table(out / "zhang2013_sensitivity_peaks.csv")
    assert prov["study"] == "zhang2013_sensitivity" and prov["mode"] == "smoke" and prov["scene"] == "excavator"
    assert prov["steady_revs"] == study.SMOKE["steady_revs"] and "git_hash" in prov
    assert prov["paper_values"] == {"f=0": 40.0, "f=0.05": 90.0, "r=0.01mm": 20.0, "r=0.5mm": 200.0}
    assert set(summary["base"]) == {"f=0", "f=0.05"} and summary["success"].all()
    # each mean and interval is that of the stored per-revolution peaks (nld.analysis.peaks)
    for _, r in summary.iterrows():
        p = peaks[peaks["key"] == r["key"]].sort_values("rev")["peak"].to_numpy(float)
        assert len(p) == study.SMOKE["steady_revs"]
        iv = peak_interval(p, 0.95)
        assert r["mean"] == pytest.approx(iv.mean, rel=1e-12)
        assert r["half_width"] == pytest.approx(iv.half_width, rel=1e-9)
        assert r["paper"] == study.BASES[r["base"]][1]
        assert r["mean"] == pytest.approx(10.5 + 10 * r["f"])      # the stand-in's peaks
        assert r["crank_speed_min"] == r["crank_speed_max"] == pytest.approx(15.6)
        assert r["mean_torque"] == 80.0 and r["steps"] == 10 and not r["growing"]


def test_a_second_run_resumes_from_the_point_files(smoke, tmp_path):
    """The finished points are read back from <out>/.work/ (one JSON per point), not recomputed."""
    study, out, _ = smoke
    files = list((out / ".work").glob("zhang2013_sensitivity-smoke-points-*/*.json"))
    assert len(files) == 2
    before, _ = load_table(out / "zhang2013_sensitivity_summary.csv")
    n = len(CALLS)
    study.main(quick=False, out_dir=out, smoke=True)
    assert len(CALLS) == n                                        # nothing integrated again
    after, _ = load_table(out / "zhang2013_sensitivity_summary.csv")
    assert list(after["wall_s"]) == list(before["wall_s"])        # the stored runs, not new ones
    assert list(after["mean"]) == list(before["mean"])


def test_the_page_for_the_zhang2013_report_reads_the_csv(smoke, tmp_path):
    """paper_page (what the zhang2013 study adds in full mode) works from the CSV as read back, and
    the zhang2013 study finds it."""
    from nld.output.report import Report
    study, out, _ = smoke
    summary, prov = load_table(out / "zhang2013_sensitivity_summary.csv")
    with Report(tmp_path / "page.pdf", "page") as rep:
        study.paper_page(rep, summary, prov)
    assert (tmp_path / "page.pdf").read_bytes().startswith(b"%PDF")
    text = " ".join(study.answer(summary, study.trend_rows(summary)))
    assert "f=0: largest" in text and "f=0.05: largest" in text
    tr = study.trend_rows(summary)
    assert len(tr) == 1 and tr["trend"].iloc[0] == "not resolved"    # 10.5 -> 11 against ± 1.9 (2 revolutions)
    assert tr["change"].iloc[0] == pytest.approx(0.5)
    zhang = load_study("zhang2013_excavator.py")
    assert zhang.SENSITIVITY_CSV == ROOT / "reports" / "zhang2013_sensitivity_summary.csv"


def test_reversed_kernel_negates_only_the_friction_coefficients():
    study = load_study("zhang2013_sensitivity.py")
    from nld.kernel.compile import compile_scene
    from nld.model.scene import resolve_scene
    k = compile_scene(resolve_scene("excavator", ["joints.A.friction.mu=0.05", "joints.B.friction.mu=0.02"]))
    p, q = k.params(), study.reversed_kernel(k).params()
    ia, ib = k.layout.index["joints.A.friction.mu"], k.layout.index["joints.B.friction.mu"]
    assert (q[ia], q[ib]) == (-0.05, -0.02)
    mask = np.ones(p.size, bool)
    mask[[ia, ib]] = False
    assert np.array_equal(p[mask], q[mask]) and study.reversed_kernel(k).columns == k.columns


def test_full_grid_pairs_every_setting_at_f0_and_f005():
    """In full mode every unknown's value is run at both f = 0 and f = 0.05, the scene's own values
    are among them, and the point keys are unique per physics and settings."""
    from nld.model.scene import load_scene
    study = load_study("zhang2013_sensitivity.py")
    d = study.defaults(load_scene("excavator"))
    pts = study.grid(dict(study.FULL), d)
    fb = [p for p in pts if p["base"] in ("f=0", "f=0.05")]
    pairs = {}
    for p in fb:
        pairs.setdefault((p["sweep"], p["series"], p["x"]), set()).add(p["base"])
    assert all(v == {"f=0", "f=0.05"} for v in pairs.values())
    assert 1.0 in study.FULL["damping"] and 0.0 in study.FULL["damping"]
    assert d["M43"] in study.FULL["m43"] and d["K2"] in study.FULL["k2"] and 3.91e7 in study.FULL["k2"]
    assert d["l4"] in study.FULL["l4"] and math.isclose(d["rho"] + d["l3"], 0.565)
    assert any(math.isclose(R, 0.565) for R in study.FULL["R"])
    assert {p["series"] for p in pts if p["base"] == "friction"} == set(study.FULL["readings"])
    keys = {}
    for p in pts:
        keys.setdefault(p["key"], set()).add((tuple(p["overrides"]), p["reversed"], p["motor"]))
    assert all(len(v) == 1 for v in keys.values())


def test_the_name_zhang2013_still_runs_the_main_job():
    from nld.cli.study import find_study
    assert find_study("zhang2013", ROOT / "studies").name == "zhang2013_excavator.py"
    assert find_study("zhang2013_s", ROOT / "studies").name == "zhang2013_sensitivity.py"


@pytest.mark.slow
def test_smoke_mode_integrated(tmp_path):
    study = load_study("zhang2013_sensitivity.py")
    study.main(quick=False, out_dir=tmp_path, smoke=True)
    summary, _ = load_table(tmp_path / "zhang2013_sensitivity_summary.csv")
    peaks, _ = load_table(tmp_path / "zhang2013_sensitivity_peaks.csv")
    assert summary["success"].all() and (summary["mean"] > 2.41).all()   # above the ideal joints' 2.41 rad/s
    for _, r in summary.iterrows():
        p = peaks[peaks["key"] == r["key"]].sort_values("rev")["peak"].to_numpy(float)
        assert r["mean"] == pytest.approx(peak_interval(p).mean, rel=1e-12)


@pytest.mark.slow
def test_quick_mode_through_the_command_line(tmp_path, monkeypatch):
    """nld study zhang2013_sensitivity --quick: the friction readings, the motor, the figures."""
    from nld.cli import main
    monkeypatch.chdir(tmp_path)
    assert main(["study", "zhang2013_sensitivity", "--quick", "--quiet"]) == 0
    study = load_study("zhang2013_sensitivity.py")
    summary, prov = load_table(tmp_path / "nld-out" / "zhang2013_sensitivity_summary.csv")
    assert prov["mode"] == "quick" and summary["success"].all()
    motor = summary[summary["sweep"] == "motor inertia"]
    assert len(motor) == 2 and (motor["crank_speed_max"] > motor["crank_speed_min"]).all()
    assert set(summary.loc[summary["base"] == "friction", "series"]) == set(study.QUICK["readings"])
    # the geometry of the full mode's extreme pivots stays feasible: the head swings through pi/2
    from nld.model.scene import resolve_scene
    d = study.defaults(resolve_scene("excavator"))
    for l4, rho in [(min(study.FULL["l4"]), d["rho"]), (max(study.FULL["l4"]), d["rho"]),
                    (d["l4"], min(study.FULL["R"]) - d["l3"]), (d["l4"], max(study.FULL["R"]) - d["l3"])]:
        g = study.geometry(resolve_scene("excavator", study._pivot(d, l4, rho)))
        assert g["theta3_min"] < 90.0 < g["theta3_max"] and 60.0 < g["transmission_min"] < g["transmission_max"] < 120.0
