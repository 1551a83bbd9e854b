"""Codim-2 points on bifurcation curves and grazing curves (nld.analysis.codim2,
nld.analysis.grazing_curve), each against a closed form.

* The Henon map x' = 1 - a x^2 + y, y' = b x: its fixed point's multipliers solve
  mu^2 + 2 a x mu - b = 0 (product -b). On the period-doubling curve (mu = -1) the other
  multiplier is b, the curve is a = 3 (1 - b)^2 / 4, and a second multiplier -1 (1:2 resonance)
  sits at (a, b) = (3, -1); on the fold curve (mu = +1) the other multiplier is -b, the curve is
  a = -(1 - b)^2 / 4 and the 1:1 resonance (a second +1) sits at (a, b) = (-1, -1). (A forced
  damped Duffing cannot have either: its two multipliers' product is exp(-delta T) in (0, 1).)
* A map with the fixed point 0 for all parameters and the multipliers a - 1 and b there: its
  flip curve is a = 0, and on it the fold-flip (the other multiplier through +1) sits at b = 1.
* The impact oscillator x'' + 2 zeta x' + x = F cos(omega t) (free of the stop at x = d): its
  period-1 orbit grazes the stop where the linear response's amplitude
  F / sqrt((1 - omega^2)^2 + (2 zeta omega)^2) equals the gap d (tests/impact_closed_form.py)."""
import math

import numpy as np
import pytest

from nld.analysis.codim2 import continue_bifurcation
from nld.analysis.continuation import continue_orbit
from nld.analysis.orbits import periodic_orbit
from numba import njit

from nld.systems import DiscreteMap, henon, impact_oscillator


@pytest.fixture(scope="module")
def henon_branches():
    M = henon(a=0.2, b=0.3)
    o = periodic_orbit(M, 1, [0.8, 0.25])
    up = continue_orbit(M, o, 0, range=(0.2, 0.5), step=0.01, criticality=False)
    down = continue_orbit(M, o, 0, range=(-0.3, 0.2), step=0.01, criticality=False)
    pd = [b for b in up.bifurcations if b.kind == "period_doubling"]
    fold = [b for b in down.bifurcations if b.kind == "fold"]
    assert len(pd) == 1 and len(fold) == 1
    return M, pd[0], fold[0]


@pytest.mark.parametrize("kind, special, a_of_b, at", [
    ("period_doubling", "resonance_1_2", lambda b: 3 * (1 - b) ** 2 / 4, (3.0, -1.0)),
    ("fold", "resonance_1_1", lambda b: -(1 - b) ** 2 / 4, (-1.0, -1.0)),
])
def test_henon_resonance_on_the_curve_where_the_closed_form_puts_it(henon_branches, kind,
                                                                     special, a_of_b, at):
    M, pd, fold = henon_branches
    c = continue_bifurcation(M, pd if kind == "period_doubling" else fold, 1, (-1.3, 0.3),
                             param=0, scale1=0.1)
    assert c.completed and c.kind == kind
    for a, b, tol1 in zip(c.values1, c.values2, c.tolerance1):
        assert abs(a - a_of_b(b)) <= tol1 + 1e-9
    sp = [s for s in c.special_points if s.kind == special]
    assert len(sp) == 1 and len(c.special_points) == 1
    s = sp[0]
    # the closed form's point lies inside the stated uncertainty, which is the bracket's size
    assert abs(s.value1 - at[0]) <= s.uncertainty1 and abs(s.value2 - at[1]) <= s.uncertainty2
    i, j = s.between
    assert s.uncertainty2 <= abs(c.values2[j] - c.values2[i]) + 1e-15
    assert c.special_table()["kind"].tolist() == [special]


def _graze_force(omega, zeta=0.05, d=1.5):
    return d * math.sqrt((1 - omega ** 2) ** 2 + (2 * zeta * omega) ** 2)


def test_impact_oscillator_grazing_curve_is_the_closed_form():
    S = impact_oscillator(zeta=0.05, omega=0.8, F=0.5, d=1.5)
    o = periodic_orbit(S, 1, [1.0, 0.5], rtol=1e-10)
    assert o.converged and o.onsets_per_period == 0
    br = continue_orbit(S, o, "F", [0.5, 0.6], locate_tol=1e-6, criticality=False)
    gz = [b for b in br.bifurcations if b.kind == "grazing"]
    assert len(gz) == 1
    c = continue_bifurcation(S, gz[0], "omega", (0.79, 0.81), param="F", stops=(0.805,), step=10)
    assert c.completed and c.kind == "grazing" and len(c.values1) >= 4
    assert c.value1_at(0.805) == c.values1[c.values2.index(0.805)]
    for F, w, tol1 in zip(c.values1, c.values2, c.tolerance1):
        assert abs(F - _graze_force(w)) <= tol1
    # the contact side's approach speed is small (grazing), where the contact was counted
    speeds = np.array(c.condition, dtype=float)
    assert np.all(speeds[np.isfinite(speeds)] < 1e-2)


@njit(cache=False)
def _fold_flip_map(x, p, out):
    out[0] = (p[0] - 1.0) * x[0] - x[0] ** 3 + 0.3 * x[1]
    out[1] = p[1] * x[1] - x[1] ** 3 + 0.2 * x[0] * x[1]


@njit(cache=False)
def _fold_flip_jac(x, p, J):
    J[0, 0] = p[0] - 1.0 - 3.0 * x[0] ** 2
    J[0, 1] = 0.3
    J[1, 0] = 0.2 * x[1]
    J[1, 1] = p[1] - 3.0 * x[1] ** 2 + 0.2 * x[0]


def test_fold_flip_on_a_doubling_curve_where_the_closed_form_puts_it():
    M = DiscreteMap(_fold_flip_map, [0.0, 0.0], [0.3, 0.5], "fold-flip map",
                    jacobian=_fold_flip_jac, state_names=["x", "y"])
    o = periodic_orbit(M, 1, [0.01, 0.01])
    br = continue_orbit(M, o, 0, range=(-0.3, 0.3), step=0.02, criticality=False)
    pd = [b for b in br.bifurcations if b.kind == "period_doubling"]
    assert len(pd) == 1
    c = continue_bifurcation(M, pd[0], 1, (0.5, 1.5), param=0)
    assert c.completed and all(abs(a) <= t + 1e-12 for a, t in zip(c.values1, c.tolerance1))
    # one special point: the fold-flip (no turning point: a stays 0 along the curve, its
    # tangent component is rounding noise)
    assert [s.kind for s in c.special_points] == ["fold_flip"]
    s = c.special_points[0]
    assert abs(s.value1) <= s.uncertainty1 + 1e-12 and abs(s.value2 - 1.0) <= s.uncertainty2
    assert s.uncertainty2 < 0.1
