"""Stability of periodic orbits (issue 38 items 6, 7): "stable" / "unstable" / "neutral" from the
multipliers other than the contact memory's neutral one, never "stable" within the uncertainty
of 1; a Poincaré-map orbit's time period and trajectory."""
import math

import numpy as np
from numba import njit

from nld.analysis.orbits import find_orbits, periodic_orbit
from nld.systems import ContinuousSystem, PoincareMap, henon, logistic


def test_multiplier_minus_one_is_neutral_not_stable():
    # the logistic map's fixed point 1 - 1/r at r = 3 has f' = 2 - r = -1: the period doubling
    o = periodic_orbit(logistic(3.0), 1, [0.6])
    assert o.converged and abs(o.points[0, 0] - 2.0 / 3.0) < 1e-12
    assert abs(abs(o.multipliers[0]) - 1.0) < 1e-12
    assert o.stability == "neutral" and o.stable is None
    assert o.multiplier_uncertainty > abs(abs(o.multipliers[0]) - 1.0)
    # away from it the verdicts are the closed form's: f' = 2 - r
    assert periodic_orbit(logistic(2.8), 1, [0.6]).stability == "stable"
    assert periodic_orbit(logistic(3.2), 1, [0.6]).stability == "unstable"
    o = periodic_orbit(henon(), 1, [0.5, 0.1])
    assert o.stability == "unstable" and o.stable is False and not o.memory_neutral
    assert o.to_dict()["stability"] == "unstable"


@njit(cache=True)
def hopf_rhs(t, y, p, z, dy):
    r2 = y[0] * y[0] + y[1] * y[1]
    dy[0] = (p[0] - r2) * y[0] - p[1] * y[1]
    dy[1] = p[1] * y[0] + (p[0] - r2) * y[1]


def test_poincare_orbit_carries_its_time_period_and_trajectory():
    # r' = r (a - r^2), theta' = w: the cycle r = sqrt(a) returns to y = 0, x > 0 after 2 pi / w
    a, w = 1.0, 2.0
    S = ContinuousSystem(hopf_rhs, [0.5, 0.0], [a, w], "hopf")
    o = periodic_orbit(PoincareMap(S, [0.0, 1.0], 0.0, +1, dt=0.05), 1, [0.5, 0.0], rtol=1e-10)
    assert o.converged and o.stability == "stable"
    assert abs(o.time_period - 2 * math.pi / w) < 1e-8
    assert o.to_dict()["time_period"] == o.time_period
    # the stated uncertainty covers the multiplier's true error
    mu = math.exp(-2 * a * 2 * math.pi / w)
    assert abs(o.multipliers[0].real - mu) <= o.multiplier_uncertainty
    t, Y = o.trajectory(100)
    assert t.shape == (100,) and Y.shape == (100, 2)
    assert np.max(np.abs(np.hypot(Y[:, 0], Y[:, 1]) - math.sqrt(a))) < 1e-7
    # uniformly in time around the cycle: theta = w t
    th = np.unwrap(np.arctan2(Y[:, 1], Y[:, 0]))
    assert np.max(np.abs(th - w * t)) < 1e-7
    # period 2 by multiple shooting: twice the time
    o2 = periodic_orbit(PoincareMap(S, [0.0, 1.0], 0.0, +1, dt=0.05), 2, [0.5, 0.0], rtol=1e-10)
    assert abs(o2.time_period - 4 * math.pi / w) < 1e-8


# ------------------------------------------------------------------ equilibria on a Poincaré section
def test_equilibria_on_the_section_are_no_periodic_orbits():
    # Lorenz (10, 28, 8/3): C+- = (+-sqrt(72), +-sqrt(72), 27) lie on the section z = 27, where
    # the flow vanishes: no orbit (issue 38 item 3). The AB cycle is one, with its published
    # period T = 1.5586522107 and multiplier 4.712947274 (Viswanath 2003)
    from nld.systems import lorenz
    c = math.sqrt(72.0)
    P = PoincareMap(lorenz(), [0.0, 0.0, 1.0], 27.0, +1)
    o = periodic_orbit(P, 1, [c + 1e-3, c - 1e-3, 27.0])
    assert not o.converged and o.stability == "unconverged" and o.stable is None
    assert "equilibrium" in o.message
    orbs = find_orbits(P, max_period=2)
    assert orbs
    for o in orbs:
        assert np.min(np.abs(np.abs(o.points[:, :2]) - c)) > 1e-3
    ab = [o for o in orbs if o.period == 2]
    assert len(ab) == 1
    assert abs(ab[0].time_period - 1.5586522107) < 1e-8
    assert abs(ab[0].max_abs_multiplier - 4.712947274) < 1e-6
    assert ab[0].stability == "unstable"
