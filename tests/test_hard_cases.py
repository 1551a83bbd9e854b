"""Hard regression cases (nld.run.hard_cases, docs/integrator.md "Hard cases").

Each case must either run within its tolerance (status 0, all finite, the journal positions of a
short window within a bound of an independent run: another method or a much tighter tolerance) and
pass its physics check, or stop with its expected clear message. The default run uses each case's
shortened variant (``quick_revs``); the full-length runs are marked slow.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from nld.run import hard_cases as hc
from nld.run.hard_cases import CASES, run_case

# cases whose expected outcome is met today
MET = [n for n in CASES if n not in ("stiff_damped_rodas_tight",)]
# the six cases of issue 5 (plus the stiff pair)
ISSUE = ["seed_k1_r001", "flores_05mm_5000rpm", "coulomb_f005", "grazing", "energy_10krev",
         "crank_10000rpm"]


def _assert_outcome(rep):
    res, case = rep.result, rep.case
    assert rep.checks, "no checks were run"
    if case.expectation == "success":
        assert res.status == 0, res.message
        assert np.isfinite(res.table.to_numpy()).all()
        assert np.isfinite(res.y_final).all()
        assert res.t_reached == pytest.approx(res.table["t"].iloc[-1], rel=1e-12)
        comp = rep.check("journal position vs")
        assert 0.0 <= comp.value <= case.ref_bound, str(comp)
        assert rep.reference is not None and rep.reference.status == 0
    else:
        frag = case.expectation.split(":", 1)[1]
        assert res.status < 0 and frag in res.message, res.message
        assert np.isfinite(res.table.to_numpy()).all()
    assert rep.passed, rep.summary()


def test_the_issue_cases_are_named():
    assert set(ISSUE) <= set(CASES)
    seed = CASES["seed_k1_r001"]
    assert seed.scene == "excavator" and "joints.A.clearance=1e-5" in seed.overrides
    sc = hc._scene(seed)
    assert sc.joints["A"].clearance == 1e-5
    assert sc.joints["A"].contact.stiffness == pytest.approx(9.59e11, rel=1e-3)
    assert hc._scene(CASES["flores_05mm_5000rpm"]).joints["B"].clearance == 5e-4
    assert hc._scene(CASES["flores_05mm_5000rpm"]).driver.speed == pytest.approx(5000 * np.pi / 30)
    assert hc._scene(CASES["crank_10000rpm"]).driver.speed == pytest.approx(10000 * np.pi / 30, rel=1e-4)
    fr = hc._scene(CASES["coulomb_f005"]).joints["B"].friction
    assert fr.law == "coulomb" and fr.mu == 0.05
    assert CASES["energy_10krev"].revs == 1e4
    for c in CASES.values():
        assert c.expectation == "success" or c.expectation.startswith("stop:")


# DOP853 on the stiff hertz_damped scene costs a compilation of DOP853 for a kernel no other test
# uses (about a minute of a cold run); the same stop ("became stiff", naming rodas) stays in the
# default run on slider_crank's kernel (test_lyapunov's
# test_scene_dop853_reports_stiffness_instead_of_an_exponent) and on Van der Pol
# (test_integrators' test_dop853_detects_stiffness)
SLOW_QUICK = {"stiff_damped_dop853"}


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in SLOW_QUICK else n
                                  for n in MET])
def test_hard_case_quick(name):
    rep = run_case(name, quick=True)
    _assert_outcome(rep)
    res, case = rep.result, rep.case
    if case.check == "slip_reversal":
        with_rev = rep.check("B: contacts with a slip reversal")
        assert with_rev.value >= case.check_bound
        # the reversals on the window are those of the 1000x tighter run
        win = rep.check("B: slip reversals on the window")
        assert win.ok and win.value > 0, str(win)
    elif case.check == "grazing":
        pen = rep.check("max penetration")
        assert 0.0 < pen.value < case.check_bound
        ev = rep.check("contact events vs reference")
        assert ev.value == ev.bound and ev.value >= 2
        assert (res.events.direction == 1).sum() >= 1
    elif case.check == "energy":
        first = rep.checks[3]              # after status, finite, comparison
        assert first.name.startswith(("relative energy drift", "power balance"))
        assert first.value < case.check_bound, str(first)   # the quick variant's bound


def test_slip_reversals_happen_inside_contacts():
    """The Coulomb case's reversals are inside contact intervals: the count is zero on the
    same output with the contact flag cleared, and the sign changes of the slip are real."""
    rep = run_case("coulomb_f005", quick=True, compare=False)
    tab = rep.result.table
    rev, with_rev, runs = hc.slip_reversals(tab, "B")
    assert rev >= with_rev >= 2 and runs >= with_rev
    free = tab.copy()
    free["B.contact"] = 0.0
    assert hc.slip_reversals(free, "B") == (0, 0, 0)


def test_grazing_contacts_are_tiny():
    """Every contact of the grazing case penetrates far less than the clearance (1e-5 m)."""
    rep = run_case("grazing", quick=True, compare=False)
    tab = rep.result.table
    pen = tab["B.penetration"].to_numpy()
    inside = tab["B.contact"].to_numpy() > 0
    assert inside.any()
    assert pen[inside].max() < 1e-7 and pen[~inside].max() <= 1e-12
    # the contacts are short: under 1 % of the run in contact
    assert inside.mean() < 0.01


def test_comparison_can_fail(monkeypatch):
    """The window comparison is a real check: an impossible bound fails it."""
    monkeypatch.setitem(CASES, "tight", dataclasses.replace(CASES["flores_05mm_5000rpm"], ref_bound=1e-15))
    rep = run_case("tight", revs=0.3)
    assert not rep.passed
    assert not rep.check("journal position vs").ok


def test_stiff_rodas_at_tight_tolerance_stops_clearly():
    """Rodas at rtol 1e-9 on the stiff damped contact: either it runs within its tolerance or it
    stops with a clear message (today: step size underflow at the first contact onset), finite."""
    rep = run_case("stiff_damped_rodas_tight")
    res = rep.result
    assert np.isfinite(res.table.to_numpy()).all()
    if res.status != 0:
        assert "underflow" in res.message and "rodas" in res.message
        assert res.t_reached < 0.21
    else:
        assert rep.passed, rep.summary()


def test_stiff_rodas_at_tight_tolerance_succeeds():
    """Until issue 14 rodas at rtol <= 1e-9 stopped with a step size underflow at the first contact
    onset (t = 0.00677 s), where the damping force jumps by C * approach speed; the jump is now
    applied at the located onset (hertz_damped contact mode)."""
    rep = run_case("stiff_damped_rodas_tight")
    assert rep.passed, rep.summary()


def test_main_prints_reports(capsys):
    from nld.cli import main
    # (the rodas case: its kernel and Rodas4 wrapper are compiled by test_integrators anyway)
    assert main(["hard-cases", "--quick", "stiff_damped_rodas"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("stiff_damped_rodas: PASS") and "journal position vs" in out
    assert main(["hard-cases", "--list"]) == 0
    out = capsys.readouterr().out
    assert all(f"{n}:" in out for n in CASES)
    assert main(["hard-cases", "no_such_case"]) == 2
    assert "no_such_case" in capsys.readouterr().err


# ---------------------------------------------------------------- full length (slow)
LONG = [n for n in MET if CASES[n].has_long_variant]


@pytest.mark.slow
@pytest.mark.parametrize("name", LONG)
def test_hard_case_full(name):
    rep = run_case(name)
    _assert_outcome(rep)


@pytest.mark.slow
def test_energy_10krev_dop853():
    """dop853, rtol 1e-10, conservative free crank (slider_crank, driver.mode=torque, hertz):
    the 10^4 revolutions (until issue 38 a strict xfail: status -3 after ~905 revolutions; the
    quick variant, 200 revolutions, is in the default run through test_hard_case_quick)."""
    rep = run_case("energy_10krev_dop853")
    assert rep.passed, rep.summary()


@pytest.mark.slow
def test_dop853_outputs_before_the_stop_are_finite():
    """dop853 wrote NaN rows here (outputs in [10.8559, 10.8562] s) until a step whose dense-output
    stages are not finite was rejected (the quick variant: tests/test_integrators.py)."""
    from nld.run.simulate import simulate
    te = np.concatenate([np.linspace(0.0, 10.8559, 100, endpoint=False), np.linspace(10.8559, 10.8562, 301)])
    r = simulate("slider_crank", t_end=float(te[-1]), t_eval=te, rtol=1e-10, method="dop853",
                 overrides=list(hc.CONSERVATIVE))
    tab = r.table
    assert np.isfinite(tab[tab.t <= r.t_reached].drop(columns=["t"]).to_numpy()).all()
    # and it runs through the point where it used to stop (status -3 at t = 10.8559595 s)
    assert r.status == 0 and r.t_reached == pytest.approx(te[-1])
