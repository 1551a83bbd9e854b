"""Study olyaei2012_control (studies/olyaei2012_control.py, issue 26 item 7).

Default run (no integration: the suite's 5-minute budget has no room for the delay integrator's
compile here): the smoke mode with the two expensive parts, ``controlled_case`` (nld control's
control_scene and the sampled contact force) and ``free_case`` (nld.run.simulate), replaced by
stand-ins with known numbers, so that the study's own code runs end to end (tables, CSV with
provenance, report) and every number it writes can be checked against the stand-in. ``-m slow``:
the quick mode through ``nld study`` (the default controlled run, three gains; about 40 s warm).
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from nld.output.io import load_table
from study_harness import ROOT, load_study

T = 0.012            # the stand-ins' crank period (s)
SPR = 4              # samples per revolution
NREV = 8             # controlled revolutions
CAP = 3              # capture revolution
C = 2e-4             # clearance (m)


def fake_free(st):
    sec = pd.DataFrame({"rev": np.arange(10, 16), "t": np.arange(10, 16) * T,
                        "B.ex": np.full(6, 0.5 * C), "B.ey": np.full(6, -0.5 * C)})
    return dict(section=sec, onsets_per_rev=np.array([4, 3, 5, 4, 4]), T=T, clearance=C,
                drive_rms=90.0, drive_peak=700.0, drive_samples=500, wall_s=1.0, steps=100)


def fake_controlled(st, say):
    n = NREV * SPR + 1
    t = 0.12 + np.arange(n) * T / SPR
    i = np.arange(n)
    u = np.where(i <= CAP * SPR, 2.0, 1e-3)
    ex = np.where(i < CAP * SPR, 0.3 * C, 1.01 * C)
    hist = pd.DataFrame({"t": t, "rev": i / SPR, "u": u, "rod.phi_dot": np.full(n, 5.0),
                         "B.ex": ex, "B.ey": np.zeros(n), "B.Fn_elastic": np.full(n, 10.0),
                         "B.Fn": np.where(i > CAP * SPR, 12.0, np.nan)})
    orbit = {"multipliers": [[-16.3, 0.0], [1.0, 0.0], [-0.002, 0.0]],
             "odd_number_limitation": {"message": "0 real multipliers > 1: not limited"}}
    settings = dict(method="edfc", body="rod", signal="rod.phi_dot", gain=1.0, memory=0.9,
                    delay_revolutions=1.0, revs=NREV, transient_revs=10, lyapunov_revs=4,
                    rtol=1e-8, uncertainty_uncontrolled=0.3, uncertainty_controlled=0.05,
                    lyapunov_controlled_memory="held (permanent contact)",
                    controlled_orbit=orbit, target_orbit=orbit, distance_to_target=21.0,
                    periodicity=4e-6, target_found_by="newton from the transient")
    out = {"lambda1_uncontrolled": 4.0, "lambda1_controlled": -0.13, "lambda1_uncertainty": 0.3,
           "effort_rms_initial": 2.0, "effort_rms_final": 1e-3, "captured_at_revolution": CAP,
           "orbit_distance": 1e-5, "onsets_per_period": 0.0, "settings": settings,
           "stability_domain": {"gains": [0.5, 1.0], "memory": 0.9, "lambda1": [1.0, -0.1],
                                "uncertainty": [0.2, 0.05], "stable": [False, True],
                                "transient_revs": 2, "span_revs": 4},
           "provenance": {"command": "nld control slider_crank_olyaei"}}
    return dict(out=out, history=hist, onset_t=np.array([0.121, 0.125, 0.13]), t_start=0.12, T=T,
                clearance=C, wall_s=2.0, samples_per_rev=SPR)


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    study = load_study("olyaei2012_control.py")
    study.controlled_case, study.free_case = fake_controlled, fake_free
    out = tmp_path_factory.mktemp("olyaei2012_control")
    pdf = study.main(quick=False, out_dir=out, smoke=True)
    return study, out, pdf


def test_smoke_writes_the_report_and_the_tables_with_provenance(smoke):
    study, out, pdf = smoke
    assert pdf == out / "olyaei2012_control.pdf" and pdf.read_bytes().startswith(b"%PDF")
    for suffix in ("summary", "domain", "revolutions", "sections", "torque"):
        df, prov = load_table(out / f"olyaei2012_control_{suffix}.csv")
        assert len(df) and prov["study"] == "olyaei2012_control" and prov["mode"] == "smoke"
        assert prov["scene"] == "slider_crank_olyaei" and "git_hash" in prov
        assert prov["overrides"] == study.OVERRIDES and prov["paper"] == study.CITATION
        assert prov["settings"]["gains"] == study.SMOKE["gains"]
    assert (out / "olyaei2012_control_history.parquet").is_file()


def test_the_numbers_follow_from_the_stand_ins(smoke):
    study, out, _ = smoke
    summ, _ = load_table(out / "olyaei2012_control_summary.csv")
    v = dict(zip(summ["quantity"], summ["value"]))
    u = dict(zip(summ["quantity"], summ["uncertainty"]))
    q_free = next(q for q in v if q.startswith("lambda1 free"))
    q_ctl = next(q for q in v if q.startswith("lambda1 controlled"))
    assert (v[q_free], u[q_free], v[q_ctl], u[q_ctl]) == (4.0, 0.3, -0.13, 0.05)
    q_on = next(q for q in v if q.startswith("contact onsets per revolution, free"))
    assert v[q_on] == pytest.approx(4.0) and u[q_on] == pytest.approx(np.std([4, 3, 5, 4, 4], ddof=1)
                                                                       / math.sqrt(5))
    assert v[next(q for q in v if q.startswith("captured at"))] == CAP
    assert v[next(q for q in v if q.startswith("last contact onset"))] == pytest.approx(0.01 / T)
    notes = " ".join(summ["note"].fillna("").astype(str))
    assert "-16.3" in notes and "not limited" in notes
    dom, _ = load_table(out / "olyaei2012_control_domain.csv")
    assert list(dom["K"]) == [0.5, 1.0] and list(dom["lambda1"]) == [1.0, -0.1]
    assert list(dom["stable"]) == [False, True]
    assert list(dom["verdict"]) == ["unstable", "stable"]
    tq, _ = load_table(out / "olyaei2012_control_torque.csv")
    assert tq["rms"].tolist() == pytest.approx([2.0, 1e-3, 90.0])
    assert tq["peak"].tolist() == pytest.approx([2.0, 1e-3, 700.0])
    # the drive torque's row counts its samples (issue 42: it said "samples 0")
    assert tq["samples"].tolist() == [CAP * SPR + 1, (NREV - CAP) * SPR, 500]
    revs, _ = load_table(out / "olyaei2012_control_revolutions.csv")
    assert len(revs) == NREV
    # revolution k holds the samples (k, k + 1]: 2 N m up to the capture's sample, 1e-3 after
    assert revs["effort_rms"].tolist() == pytest.approx([2.0] * CAP + [1e-3] * (NREV - CAP))
    assert revs["onsets"].tolist() == [3] + [0] * (NREV - 1)
    secs, _ = load_table(out / "olyaei2012_control_sections.csv")
    n = secs["case"].value_counts()
    assert (n["free"], n["controlled, before capture"], n["controlled, after capture"]) == (6, CAP, NREV - CAP)
    fr = secs[secs["case"] == "free"]
    assert fr["onsets"].iloc[:5].tolist() == [4, 3, 5, 4, 4] and math.isnan(fr["onsets"].iloc[5])
    after = secs[secs["case"] == "controlled, after capture"]
    assert after["ex/c"].to_numpy() == pytest.approx(1.01)


def test_the_study_runs_nld_control_with_its_defaults():
    """control_kwargs: the library call of nld control's workflow (no parser in the study) with
    the study's scene, spans, tolerance and gains only, so method, gain, memory and signal are nld
    control's defaults; the command line it records parses to the same arguments."""
    import inspect
    import shlex

    from nld.analysis.scene_control import control_scene
    from nld.cli import build_parser
    study = load_study("olyaei2012_control.py")
    kw = study.control_kwargs(dict(study.FULL))
    assert kw["scene"] == "slider_crank_olyaei" and kw["overrides"] == study.OVERRIDES
    assert set(kw) <= set(inspect.signature(control_scene).parameters)
    assert not {"method", "gain", "memory", "signal", "body", "delay"} & set(kw)
    assert kw["gains"] == pytest.approx(np.linspace(0.1, 3.0, 30)) and kw["revs"] == 300
    assert len(study.QUICK["gains"]) == 3
    a = build_parser().parse_args(shlex.split(kw["command"])[1:])
    assert (a.scene, a.overrides, a.transient, a.revs, a.lyapunov_revs, a.scan_transient,
            a.rtol) == (kw["scene"], kw["overrides"], kw["transient"], kw["revs"],
                        kw["lyapunov_revs"], kw["scan_transient"], kw["rtol"])
    assert list(a.gains) == kw["gains"]
    assert a.gain is None and a.memory is None and a.method is None and a.signal is None


def test_the_names_resolve():
    from nld.cli.study import find_study
    assert find_study("olyaei2012", ROOT / "studies").name == "olyaei2012.py"
    assert find_study("olyaei2012_control", ROOT / "studies").name == "olyaei2012_control.py"
    assert find_study("olyaei2012_c", ROOT / "studies").name == "olyaei2012_control.py"


@pytest.mark.slow
def test_quick_mode_through_the_command_line(tmp_path, monkeypatch):
    """nld study olyaei2012_control --quick: control works (lambda1 controlled < free, effort falls),
    the CSV files and their provenance are complete."""
    from nld.cli import main
    monkeypatch.chdir(tmp_path)
    assert main(["study", "olyaei2012_control", "--quick", "--quiet"]) == 0
    out = tmp_path / "nld-out"
    summ, prov = load_table(out / "olyaei2012_control_summary.csv")
    assert prov["mode"] == "quick" and prov["control_settings"]["method"] == "edfc"
    v = dict(zip(summ["quantity"], summ["value"]))
    u = dict(zip(summ["quantity"], summ["uncertainty"]))
    free = next(x for q, x in v.items() if q.startswith("lambda1 free"))
    q_ctl = next(q for q in v if q.startswith("lambda1 controlled"))
    ctl = v[q_ctl]
    assert free > 1.0 and ctl + u[q_ctl] < 0
    # issue 38: against an independent estimate, the effort's decay after capture
    decay = next(x for q, x in v.items() if q.startswith("effort decay rate"))
    assert abs(ctl - decay) <= u[q_ctl], (ctl, u[q_ctl], decay)
    first = v["effort rms, first controlled revolution"]
    last = v["effort rms, last controlled revolution"]
    assert last < 0.05 * first
    dom, _ = load_table(out / "olyaei2012_control_domain.csv")
    assert len(dom) == 3 and dom["lambda1"].notna().all()
    tq, _ = load_table(out / "olyaei2012_control_torque.csv")
    assert tq["rms"].iloc[2] > 1.0                                   # the drive torque, N m
    for suffix in ("revolutions", "sections", "torque", "domain"):
        _, p = load_table(out / f"olyaei2012_control_{suffix}.csv")
        assert p["git_hash"] and p["settings"]["gains"] == [0.3, 1.0, 2.0]
    assert (out / "olyaei2012_control.pdf").read_bytes().startswith(b"%PDF")


def test_the_stability_verdict_is_one_rule_for_table_and_figure():
    """Issue 42: lambda1 about -0.06 with an uncertainty of 0.067 was listed "stable False" and left
    out of the stable range without a word; the verdict says which of stable / unstable /
    undecided, by one rule (the table's stable column is verdict == stable)."""
    study = load_study("olyaei2012_control.py")
    assert study.verdict(-0.06, 0.067) == "undecided"
    assert study.verdict(-0.06, 0.017) == "stable" and study.verdict(0.5, 0.2) == "unstable"
    assert study.verdict(float("nan"), 0.1) == "failed"
    assert "lambda1 + uncertainty < 0" in study.STABLE_RULE
    dom = pd.DataFrame({"K": [0.5, 0.7, 1.0, 1.5, 2.0, 3.0],
                        "verdict": ["unstable", "stable", "stable", "undecided", "stable",
                                    "stable"]})
    assert study.gain_ranges(dom, "stable") == "0.7-1, 2-3"
    assert study.gain_ranges(dom, "undecided") == "1.5"
