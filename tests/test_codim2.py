"""Curves of period doublings and folds in two parameters (nld.analysis.codim2).

Forced Duffing oscillators: each curve is checked against points located one at a time by
one-parameter continuation at other values of the second parameter, against Liouville's formula,
and (the cusp) against harmonic balance."""
import math

import numpy as np
import pytest
from numba import njit

from nld.analysis.codim2 import continue_bifurcation
from nld.analysis.continuation import Bifurcation, continue_orbit
from nld.analysis.orbits import periodic_orbit
from nld.errors import InputError
from nld.systems import DiscreteMap, duffing

from test_continuation_robust import _harmonic_balance_folds

DELTA = 0.3          # the double-well Duffing's damping (nld.systems.duffing's default)


def _doubling(omega):
    """The first period doubling of the period-1 orbit of the double-well Duffing at omega,
    located by one-parameter continuation in gamma."""
    S = duffing(gamma=0.23, omega=omega)
    o = periodic_orbit(S, 1, transient=50, rtol=1e-10)
    br = continue_orbit(S, o, "gamma", range=(0.23, 0.30), step=0.005, criticality=False)
    pds = [b for b in br.bifurcations if b.kind == "period_doubling"]
    assert pds and pds[0].located
    return S, pds[0]


@pytest.fixture(scope="module")
def doubling_curve():
    S, pd = _doubling(1.2)
    return pd, continue_bifurcation(S, pd, "omega", (1.15, 1.25), param="gamma", stops=(1.18,))


def test_doubling_curve_passes_through_doublings_located_one_at_a_time(doubling_curve):
    pd, c = doubling_curve
    assert c.completed and c.kind == "period_doubling"
    assert [e.reason for e in c.ends] == ["range_end", "range_end"]
    for w in (1.15, 1.18, 1.25):
        _, ref = _doubling(w)
        i = c.values2.index(w)
        assert c.landed[i]
        # agree within the located value's stated tolerance plus the curve point's own
        assert abs(c.value1_at(w) - ref.value) <= ref.tolerance + c.tolerance1[i]
        # and the start point is the located doubling it came from
    j = c.values2.index(1.2)
    assert abs(c.values1[j] - pd.value) <= pd.tolerance + c.tolerance1[j]


def test_multipliers_along_the_doubling_curve(doubling_curve):
    _, c = doubling_curve
    for w, o, d in zip(c.values2, c.orbits, c.distance):
        mu = o.multipliers
        # one real multiplier at -1 (to the curve's accuracy) ...
        k = int(np.argmin(np.abs(mu + 1.0)))
        assert abs(mu[k] + 1.0) == pytest.approx(d) and d < 1e-6
        # ... and their product exp(-delta T) (Liouville: the divergence is -delta), T = 2 pi / w
        assert np.prod(mu).real == pytest.approx(math.exp(-DELTA * 2 * math.pi / w), rel=1e-6)
    assert not c.special_points


HARD = dict(delta=0.05, alpha=1.0, beta=0.05)   # a hardening Duffing: a resonance curve bent right


def _folds(gamma):
    S = duffing(omega=0.9, y0=(0.3, 0.0), gamma=gamma, **HARD)
    o = periodic_orbit(S, 1, transient=200, rtol=1e-10)
    br = continue_orbit(S, o, "omega", range=(0.9, 1.3), step=0.005, max_points=400,
                        criticality=False)
    folds = sorted((b for b in br.bifurcations if b.kind == "fold"), key=lambda b: b.value)
    assert len(folds) == 2 and all(f.located for f in folds)
    return S, folds


def test_fold_curves_meet_at_their_cusp_and_agree_with_one_parameter_folds():
    S, (low, high) = _folds(0.1)
    c = continue_bifurcation(S, high, "gamma", (0.07, 0.12), param="omega")
    # from the upper fold down in gamma, through the cusp, back up along the lower fold
    cusps = [s for s in c.special_points if s.kind == "cusp"]
    assert len(cusps) == 1
    down, up = c.ends
    assert up.reason == "range_end" and down.reason == "turned_back"
    # the folds located by one-parameter continuation at gamma = 0.12 are both on the curve
    _, (low12, high12) = _folds(0.12)
    ends = sorted(c.values1[i] for i, v in enumerate(c.values2) if v == 0.12 and c.landed[i])
    tols = [c.tolerance1[i] for i, v in enumerate(c.values2) if v == 0.12 and c.landed[i]]
    assert len(ends) == 2
    assert abs(ends[0] - low12.value) <= low12.tolerance + max(tols)
    assert abs(ends[1] - high12.value) <= high12.tolerance + max(tols)
    # the cusp where harmonic balance puts it: the largest gamma with no fold pair
    # (first order in the nonlinearity: its folds are within 0.2 %, the cusp within 1 %)
    lo, hi = 0.05, 0.1
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        if len(_harmonic_balance_folds(delta=0.05, beta=0.05, gamma=mid)) >= 2:
            hi = mid
        else:
            lo = mid
    assert cusps[0].value2 == pytest.approx(hi, rel=1e-2)
    # located where the curve's gamma direction changes sign, uncertain by at most its bracket
    i, j = cusps[0].between
    assert min(c.values2[i], c.values2[j]) - 1e-12 <= cusps[0].value2 <= \
        max(c.values2[i], c.values2[j]) + 1e-12
    assert 0 < cusps[0].uncertainty2 <= abs(c.values2[j] - c.values2[i]) + 1e-15
    assert c.special_table()["uncertainty2"].notna().all()
    # every point a fold: a multiplier +1 to the curve's accuracy
    assert max(c.distance) < 1e-6


@njit(cache=False)
def _damped_delayed_logistic(x, p, out):
    out[0] = p[0] * x[0] * (1.0 - x[1]) - p[1] * x[0]
    out[1] = x[0]


@njit(cache=False)
def _damped_delayed_logistic_jac(x, p, J):
    J[0, 0] = p[0] * (1.0 - x[1]) - p[1]
    J[0, 1] = -p[0] * x[0]
    J[1, 0] = 1.0
    J[1, 1] = 0.0


def test_neimark_sacker_curve_of_a_map_against_its_closed_form():
    # x' = r x (1 - y) - a x, y' = x: fixed point x* = y* = 1 - (1 + a) / r, Jacobian
    # [[1, -r x*], [1, 0]]: det = r - 1 - a, trace 1, so the pair crosses |mu| = 1 on the line
    # r = 2 + a, at the angle pi / 3 (2 cos(theta) = 1). The map's exact Jacobian is given: with
    # the default central differences the multipliers are good to ~1e-10 only (their stated
    # uncertainty for a map is 0) and the curve's points were 1e-10 off the line
    M = DiscreteMap(_damped_delayed_logistic, [0.4, 0.4], [1.8, 0.1], "damped delayed logistic",
                    jacobian=_damped_delayed_logistic_jac, state_names=["x", "x_prev"])
    o = periodic_orbit(M, 1, [0.4, 0.4])
    br = continue_orbit(M, o, 0, range=(1.8, 2.4), step=0.02, criticality=False)
    ns = [b for b in br.bifurcations if b.kind == "neimark_sacker"]
    assert len(ns) == 1
    c = continue_bifurcation(M, ns[0], 1, (0.0, 0.3), param=0, stops=(0.2,))
    assert c.completed and len(c.values1) > 5
    for r, a, tol1, o in zip(c.values1, c.values2, c.tolerance1, c.orbits):
        assert abs(r - (2.0 + a)) <= tol1 + 1e-12
        mu = o.multipliers[0]
        assert abs(abs(mu) - 1.0) < 1e-9
        assert abs(abs(np.angle(mu)) - math.pi / 3) < 1e-9


def test_bad_input_is_refused_before_any_integration(monkeypatch, doubling_curve):
    pd, _ = doubling_curve
    S = duffing(gamma=pd.value, omega=1.2)
    import nld.analysis.codim2 as c2

    def boom(*a, **k):
        raise AssertionError("integrated before checking the input")

    monkeypatch.setattr(c2._Extended, "evaluate", boom)
    ns = Bifurcation("contact_change", pd.value, 1e-6, None, pd.orbit, "")
    with pytest.raises(InputError, match="bif.kind = 'contact_change'"):
        continue_bifurcation(S, ns, "omega", (1.1, 1.3), param="gamma")
    with pytest.raises(InputError, match="do not contain"):
        continue_bifurcation(S, pd, "omega", (1.3, 1.4), param="gamma")
    with pytest.raises(InputError, match="forcing frequency must be > 0"):
        continue_bifurcation(S, pd, "omega", (-0.1, 1.3), param="gamma")
    with pytest.raises(InputError, match="stops: omega = 1.4"):
        continue_bifurcation(S, pd, "omega", (1.1, 1.3), param="gamma", stops=(1.4,))
    with pytest.raises(InputError, match="param = 'kappa'"):
        continue_bifurcation(S, pd, "kappa", (1.1, 1.3), param="gamma")


@pytest.mark.slow
def test_slider_crank_doubling_at_mu_0_1_lies_on_the_curve_from_another_mu():
    # slider_crank_olyaei (5000 rpm): the permanent-contact period-1 orbit reached from c = 0.28 mm
    # regains stability through -1 near c = 0.28613 mm (tests/test_continuation.py). Its doubling
    # in the clearance is located at mu = 0.1 and, from the same orbit (same memory: the history
    # of a continuum orbit sets its doubling, docs/orbits.md) continued to mu = 0.1012, there too;
    # the curve followed in mu from the second lands at mu = 0.1 on the first.
    from nld.systems import SceneSystem
    clear, fric = "joints.B.clearance", "joints.B.friction.mu"
    values = [0.28e-3, 0.2835e-3, 0.287e-3, 0.29e-3]
    S = SceneSystem("slider_crank_olyaei", [f"{clear}=0.28e-3"])
    o1 = periodic_orbit(S, 1, transient=100, rtol=1e-10)
    assert o1.converged and o1.continuum
    pd_a = [b for b in continue_orbit(S, o1, clear, values, locate_tol=2e-8,
                                      criticality=False).bifurcations
            if b.kind == "period_doubling"][0]
    br_mu = continue_orbit(S, o1, fric, [0.1, 0.1012], locate=False)
    S2 = SceneSystem("slider_crank_olyaei", [f"{clear}=0.28e-3", f"{fric}=0.1012"])
    pd_b = [b for b in continue_orbit(S2, br_mu.orbits[-1], clear, values, locate_tol=2e-8,
                                      criticality=False).bifurcations
            if b.kind == "period_doubling"][0]
    assert pd_a.located and pd_b.located
    c = continue_bifurcation(S2, pd_b, fric, (0.0995, 0.1012), param=clear, stops=(0.1,))
    i = c.values2.index(0.1)
    assert c.landed[i] and c.orbits[i].continuum
    assert abs(c.values1[i] - pd_a.value) <= pd_a.tolerance + pd_b.tolerance + c.tolerance1[i]
    # the two located doublings are farther apart than that: the curve carried the difference
    assert abs(pd_b.value - pd_a.value) > 3 * (pd_a.tolerance + pd_b.tolerance)
