"""Continuation that does not stop early and says why it ends (issue 40 items 1-2, issue 38 item 9,
issue 37 classes 2 and 6): both directions over the whole range, a reason for every end, a real
fold (hardening Duffing against harmonic balance, with the jump), a real Neimark-Sacker (the
delayed logistic map at r = 2), the Duffing period-doubling cascade with Feigenbaum's ratios,
honest brackets where the bisection fails, and bad input refused before any work."""
import math

import numpy as np
import pytest
from numba import njit

import nld.analysis.continuation as cont
from nld.analysis.continuation import (END_REASONS, FEIGENBAUM_DELTA, continue_orbit,
                                       follow_cascade, orbit_stability)
from nld.analysis.orbits import periodic_orbit, section_points
from nld.errors import InputError
from nld.systems import DiscreteMap, StroboscopicMap, duffing, impact_oscillator


@njit(cache=False)
def _delayed_logistic(x, p, out):
    out[0] = p[0] * x[0] * (1.0 - x[1])
    out[1] = x[0]


@pytest.fixture(scope="module")
def delayed_logistic():
    M = DiscreteMap(_delayed_logistic, [0.4, 0.4], [1.8], "delayed logistic",
                    state_names=["x", "x_prev"])
    return M, periodic_orbit(M, 1, [0.45, 0.45])


# hardening Duffing x'' + 0.05 x' + x + 0.05 x^3 = 0.1 cos(w t): a resonance curve bent to the right
HARD = dict(delta=0.05, alpha=1.0, beta=0.05, gamma=0.1)


def _harmonic_balance_folds(delta, beta, gamma, **_):
    """The folds of the harmonic-balance resonance curve A^2 [(1 - w^2 + 3/4 beta A^2)^2 +
    (delta w)^2] = gamma^2 (Nayfeh & Mook 1979, ch. 4): the local extrema of w(A)."""
    A = np.linspace(0.05, 4.0, 400001)
    k = 1 + 0.75 * beta * A * A
    B, C = 2 * k - delta ** 2, k * k - (gamma / A) ** 2
    disc = B * B - 4 * C
    w = np.sqrt(np.where(disc >= 0, (B + np.sqrt(np.abs(disc))) / 2, np.nan))
    dw = np.diff(w)
    i = np.where(np.sign(dw[:-1]) * np.sign(dw[1:]) < 0)[0] + 1
    return sorted(float(w[j]) for j in i if np.isfinite(w[j]))


@pytest.fixture(scope="module")
def hardening():
    S = duffing(omega=0.9, y0=(0.3, 0.0), **HARD)
    return S, periodic_orbit(S, 1, transient=200, rtol=1e-10)


def test_arclength_runs_both_ways_to_the_range_ends_and_names_them():
    S = impact_oscillator()
    o = periodic_orbit(S, 1, [1.8, 0.3], rtol=1e-10)
    br = continue_orbit(S, o, "d", range=(1.2, 1.8), locate=False)
    assert [e.direction for e in br.ends] == [-1, 1]
    assert all(e.reason in END_REASONS for e in br.ends)
    # the start value 1.5 is inside the range: the branch goes down to 1.2 and up to 1.8, and
    # lands on both ends exactly
    assert min(br.values) == 1.2 and max(br.values) == 1.8
    assert br.completed and br.message == "completed"
    assert [e.reason for e in br.ends] == ["range_end", "range_end"]
    # branch order from a to b through the start
    assert list(br.values) == sorted(br.values)


def test_a_branch_that_did_not_cover_the_range_never_says_completed():
    S = impact_oscillator()
    o = periodic_orbit(S, 1, [1.8, 0.3], rtol=1e-10)
    # a first step of 1e-7 of a range of 1.5 and 6 points per direction cannot cover it
    br = continue_orbit(S, o, "d", range=(1.5, 3.0), step=1e-7, max_points=6, locate=False)
    assert not br.completed and "completed" not in br.message
    up = [e for e in br.ends if e.direction == 1][0]
    assert up.reason == "step_limit" and up.value < 3.0
    assert "covered d = 1.5 ... " in br.message


def test_an_orbit_of_another_system_or_value_is_named_as_such():
    S = impact_oscillator()
    o = periodic_orbit(S, 1, [1.8, 0.3], rtol=1e-10)
    with pytest.raises(InputError, match="an orbit of .*not of duffing"):
        continue_orbit(duffing(), o, "gamma", range=(0.4, 0.6))
    with pytest.raises(InputError, match="not a period-1 orbit of .* at d = 1.7"):
        continue_orbit(impact_oscillator(d=1.7), o, "d", range=(1.6, 1.9))


def test_a_range_outside_the_parameter_domain_is_refused_before_any_work(monkeypatch):
    S = duffing(gamma=0.2)
    o = periodic_orbit(S, 1, transient=20, rtol=1e-8)

    def no_work(*a, **k):
        raise AssertionError("integrated before the domain was checked")
    monkeypatch.setattr(cont, "_arclength", no_work)
    monkeypatch.setattr(cont, "_natural", no_work)
    with pytest.raises(InputError, match="omega = -0.2 is outside the parameter's domain"):
        continue_orbit(S, o, "omega", range=(-0.2, 1.2))
    with pytest.raises(InputError, match="outside the parameter's domain"):
        continue_orbit(S, o, "omega", [1.2, 0.5, 0.0])


def test_fold_of_the_hardening_duffing_where_harmonic_balance_puts_it_and_the_jump(hardening):
    S, o = hardening
    hb_low, hb_high = _harmonic_balance_folds(**HARD)[:2]
    br = continue_orbit(S, o, "omega", range=(0.9, 1.3), step=0.005, max_points=400,
                        criticality=False)
    assert br.completed
    folds = sorted((b for b in br.bifurcations if b.kind == "fold"), key=lambda b: b.value)
    assert len(folds) == 2
    low, high = folds
    # harmonic balance is first order in the nonlinearity (3/4 beta A^2 = 0.13 at the peak):
    # its folds within 0.2 %; the located values' stated widths are far below that
    assert low.value == pytest.approx(hb_low, rel=2e-3)
    assert high.value == pytest.approx(hb_high, rel=2e-3)
    assert all(b.located and b.tolerance < 1e-5 for b in folds)
    # between the folds the branch has an unstable (middle) part; outside them it is stable
    tab = br.table()
    mid = tab[(tab["value"] > low.value + 1e-3) & (tab["value"] < high.value - 1e-3)]
    assert "unstable" in set(mid["stable"])
    assert set(tab[tab["value"] < low.value - 1e-2]["stable"]) == {"stable"}
    # the jump from the upper (resonant) branch's fold: to a stable small-amplitude period-1
    # orbit; brute force agrees: from the fold's orbit, integrated just below the fold it stays
    # large, just above it falls to the small amplitude
    assert "jumps to a period-1 orbit (stable" in high.jump
    top = max((o_ for v, o_ in zip(br.values, br.orbits) if abs(v - high.value) < 0.01),
              key=lambda q: abs(q.points[0, 0]) + abs(q.points[0, 1]))
    amp = []
    for w in (high.value - 0.002, high.value + 0.002):
        m = StroboscopicMap(duffing(omega=w, y0=top.points[0], **HARD), 1, 1e-9)
        X, _ = section_points(m, m.y0, m.z0, 600)
        amp.append(float(np.max(np.hypot(X[-50:, 0], X[-50:, 1]))))
    assert amp[0] > 1.2 and amp[1] < 1.0
    # natural continuation cannot pass the fold: it ends there with the reason and the jump
    nat = continue_orbit(S, o, "omega", np.arange(0.9, 1.10, 0.01), criticality=False,
                         locate=False)
    up = [e for e in nat.ends if e.direction == 1][0]
    assert up.reason == "fold" and "jumps to a period-1 orbit" in up.detail
    assert up.value == pytest.approx(high.value, abs=0.011) and not nat.completed


def test_neimark_sacker_of_the_delayed_logistic_map_at_r_2(delayed_logistic):
    # x' = r x (1 - y), y' = x: the fixed point 1 - 1/r has multipliers of modulus sqrt(r - 1),
    # a complex pair through the unit circle at r = 2 with argument pi / 3; supercritical (an
    # invariant circle for r > 2)
    M, o = delayed_logistic
    br = continue_orbit(M, o, 0, range=(1.8, 2.2), step=0.02)
    ns = [b for b in br.bifurcations if b.kind == "neimark_sacker"]
    assert len(ns) == 1 and ns[0].located
    assert abs(ns[0].value - 2.0) <= ns[0].tolerance and ns[0].tolerance < 1e-5
    assert abs(abs(ns[0].multiplier) - 1.0) < 1e-5
    assert abs(abs(np.angle(ns[0].multiplier)) - math.pi / 3) < 1e-4
    assert ns[0].criticality == "supercritical"
    # no other bifurcation, and the rows' stability flips at r = 2 with nothing called stable
    # within its uncertainty of the unit circle
    assert [b.kind for b in br.bifurcations] == ["neimark_sacker"]
    for v, o_ in zip(br.values, br.orbits):
        assert orbit_stability(o_) == ("stable" if v < 2.0 - 1e-9 else "unstable"
                                       if v > 2.0 + 1e-9 else "neutral")


def test_a_failed_bisection_reports_its_real_bracket(delayed_logistic, monkeypatch):
    """Where the corrector fails inside the bisection the bracket is what it is: the value is
    'bracketed', not 'located', and its tolerance is the bracket's width (here a whole step)."""
    M, o = delayed_logistic
    real = cont._orbit_at
    calls = {"n": 0}

    def failing(fam, value, like, guess, X=None, rtol=None, tol=None, max_iter=8):
        on = real(fam, value, like, guess, X, rtol, tol, max_iter)
        if calls.get("bisecting"):
            calls["n"] += 1
            on.converged = False
        return on
    real_bisect = cont._bisect

    def bisect(*a, **k):
        calls["bisecting"] = True
        try:
            return real_bisect(*a, **k)
        finally:
            calls["bisecting"] = False
    monkeypatch.setattr(cont, "_orbit_at", failing)
    monkeypatch.setattr(cont, "_bisect", bisect)
    br = continue_orbit(M, o, 0, [1.8, 1.9, 2.1], method="natural")
    ns = [b for b in br.bifurcations if b.kind == "neimark_sacker"]
    assert len(ns) == 1 and calls["n"] >= 1
    b = ns[0]
    assert not b.located and b.tolerance >= 0.2 - 1e-12 and 1.9 - 1e-9 <= b.value - b.tolerance / 2
    assert "bracketed in" in b.detail and "not located" in b.detail and "±" not in b.detail
    assert b.criticality == "undetermined"
    assert bool(br.bifurcation_table()["located"].iloc[0]) is False


def test_duffing_period_doubling_cascade_with_feigenbaum_ratios():
    S = duffing(gamma=0.25)
    o = periodic_orbit(S, 1, transient=50, rtol=1e-10)
    br = continue_orbit(S, o, "gamma", range=(0.25, 0.30), step=0.005)
    c = follow_cascade(S, br, "gamma", max_period=8)
    assert [b.period for b in c.branches] == [1, 2, 4, 8]
    vals = [d.value for d in c.doublings]
    assert len(vals) == 4 and all(np.diff(vals) > 0)
    assert all(d.criticality == "supercritical" and d.located for d in c.doublings)
    # each doubled branch is stable just past its doubling, and carries the period it says
    for b in c.branches[1:]:
        assert orbit_stability(b.orbits[0]) == "stable"
        m = b.orbits[0].map
        assert np.max(np.abs(m.difference(b.orbits[0].points[0], b.orbits[0].points[b.period // 2])
                             / m.scales)) > 1e-3
    # successive interval ratios approach Feigenbaum's delta (4.80 and 4.67 here)
    assert len(c.ratios) == 2
    assert abs(c.ratios[0] - FEIGENBAUM_DELTA) < 0.25 * FEIGENBAUM_DELTA
    assert abs(c.ratios[1] - FEIGENBAUM_DELTA) < 0.02 * FEIGENBAUM_DELTA
    # brute force between the third and fourth doubling: period 8 from the period-8 orbit
    g = 0.5 * (vals[2] + vals[3])
    o8 = c.branches[3].orbits[0]
    m = StroboscopicMap(duffing(gamma=g, y0=o8.points[0]), 1, 1e-10)
    X, _ = section_points(m, m.y0, m.z0, 800)
    tail = X[-16:, 0]
    assert np.ptp(tail[::8]) < 1e-6 and np.ptp(tail[::4]) > 1e-4
    tab = c.table()
    assert list(tab["period_to"]) == [2, 4, 8, 16]
