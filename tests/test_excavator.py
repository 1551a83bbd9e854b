"""The seed paper's excavating linkage (nld/scenes/excavator.toml, docs/models/excavator.md).

Zhang, Liu, Xu, Hou (2013): eccentric crank OA, connecting rod AB, cutter head rocking about
D = (l4, R - l3); clearances at A (r1 = 0.07 mm, R1 = 80 mm) and B (r2 = 0.03 mm, R2 = 20 mm), Hertz
contact with linear damping and Coulomb friction (seed eqs 5-13), crushing torque by eq. 19, spring
torque by eq. 20.

Cost (warm numba cache, one core): the default three revolutions about 6-10 s; Coulomb friction at
f = 0.05 about 20 s per revolution (sticking at B makes the explicit steps tiny); without friction a
revolution takes a fraction of a second. The long variants are marked slow (pytest -m slow).
"""
import math

import numpy as np
import pytest

from nld.model.ideal import ideal_solution, loop_closure_error
from nld.model.scene import load_scene
from nld.run.simulate import simulate

RTOL = 1e-7
NAME = "excavator"


def friction(mu):
    return [f"joints.A.friction.mu={mu!r}", f"joints.B.friction.mu={mu!r}"]


def clearances(r1, r2):
    return [f"joints.A.clearance={r1!r}", f"joints.B.clearance={r2!r}"]


def period():
    return 2 * math.pi / abs(load_scene(NAME).driver.speed)


def rod_omega_max(overrides, revs):
    """max |rod.omega| (rad/s) over the run, from the assembled start (journals centred)."""
    res = simulate(NAME, revs=revs, rtol=RTOL, overrides=overrides)
    assert res.success, res.message
    return float(np.abs(res.table["rod.omega"]).max())


def test_scene_carries_the_seed_parameters():
    sc = load_scene(NAME)
    b, j = sc.bodies, sc.joints
    dist = lambda p, q: math.dist(p, q)                                          # noqa: E731
    assert dist(b["crank"].points["O"], b["crank"].points["A"]) == pytest.approx(0.020)   # l1
    assert dist(b["rod"].points["A"], b["rod"].points["B"]) == pytest.approx(0.130)       # l2
    assert dist(b["rod"].points["A"], (0.0, 0.0)) == pytest.approx(0.07427)              # ls2
    assert dist(b["cutter"].points["B"], b["cutter"].points["C"]) == pytest.approx(0.365)  # l3
    assert dist(b["cutter"].points["B"], b["cutter"].points["T"]) == pytest.approx(0.190)  # lT
    assert dist(b["cutter"].points["B"], (0.0, 0.0)) == pytest.approx(0.180)             # ls3
    # D = (l4, R - l3) on the ground and R - l3 from B on the cutter (seed eq. 2)
    l4, h = sc.ground_points["D"]
    assert dist(b["cutter"].points["B"], b["cutter"].points["D"]) == pytest.approx(h)
    assert (l4, h) == pytest.approx((0.130, 0.200))
    assert [b[n].mass for n in ("crank", "rod", "cutter")] == [0.609, 1.757, 3.986]
    assert [b[n].inertia for n in ("rod", "cutter")] == [0.009, 0.041]
    # seed J_s1 = 6e-4 kg m^2 is about O: the scene holds the centroidal value
    assert b["crank"].inertia + 0.609 * 0.020**2 == pytest.approx(6.0e-4, rel=1e-3)
    assert (j["A"].clearance, j["A"].journal_radius) == (0.07e-3, 0.080)
    assert (j["B"].clearance, j["B"].journal_radius) == (0.03e-3, 0.020)
    assert j["A"].contact.law == j["B"].contact.law == "hertz_damped"
    assert j["A"].friction.law == j["B"].friction.law == "coulomb"
    assert j["A"].contact.stiffness == 9.59e11
    assert sc.driver.speed == 15.6 and sc.gravity == (0.0, -9.81)
    mods = [ld.modulation for ld in sc.loads]
    assert mods == ["crank_halves", "angle_threshold", "constant"]
    assert sc.loads[2].value == (0.0, 8000.0)                                    # F_Ty at T


def test_defaults_run_three_revolutions():
    res = simulate(NAME, revs=3, rtol=RTOL)
    assert res.success, res.message
    tb = res.table
    assert tb["t"].iloc[-1] == pytest.approx(3 * period(), rel=1e-12)
    assert np.isfinite(tb.to_numpy()).all()
    for jn in "AB":
        on = tb[f"{jn}.contact"] > 0
        assert on.mean() > 0.9                      # the working load keeps both joints closed
        assert tb[f"{jn}.Fn"].max() > 0.0
        # static penetration under the ~6 kN working load: micrometres, not millimetres
        assert 1e-6 < tb.loc[on, f"{jn}.penetration"].median() < 1e-5
        assert tb[f"{jn}.penetration"].max() < 1e-4                 # impacts: tens of micrometres
    # the crank delivers about the 1.2 kW that M43 absorbs (plus friction and impact losses)
    last = tb["t"] >= 2 * period() - 1e-12
    assert 1.1e3 < tb.loc[last, "power.driver"].mean() < 1.6e3


def test_ideal_solution_closes_the_loop_and_is_a_crank_rocker():
    sc = load_scene(NAME)
    times = np.linspace(0.0, period(), 1441)
    df = ideal_solution(sc, times)                  # raises if some crank angle cannot be assembled
    assert loop_closure_error(sc, df) < 1e-10
    th1 = np.mod(df["crank.theta"].to_numpy(), 2 * np.pi)
    th2, th3 = df["rod.theta"].to_numpy(), df["cutter.theta"].to_numpy()
    # Grashof: shortest + longest <= sum of the other two, the crank the shortest link
    l1, l2, rocker = 0.020, 0.130, 0.200
    ground = math.hypot(0.130, 0.200)
    assert l1 + ground <= l2 + rocker and l1 == min(l1, l2, rocker, ground)
    # transmission angle (rod against rocker line) stays away from 0 and 180 degrees
    mu = np.degrees(np.abs(np.angle(np.exp(1j * (th2 - th3)))))
    assert 70.0 < mu.min() and mu.max() < 110.0
    # the cutter head swings about theta3 = pi/2 and reverses within 1 degree of crank 0 and pi,
    # so eq. 19's halves are its strokes and M43 always resists the motion
    assert th3.min() < np.pi / 2 < th3.max() and np.degrees(th3.max() - th3.min()) == pytest.approx(11.5, abs=0.5)
    w3 = df["cutter.omega"].to_numpy()
    flips = th1[:-1][np.diff(np.sign(w3)) != 0]
    assert len(flips) == 2
    assert np.degrees(np.abs(np.angle(np.exp(1j * np.sort(flips)) / np.exp(1j * np.array([0.0, np.pi]))))).max() < 1.0
    assert df["power.loads"].mean() == pytest.approx(-1.2e3, rel=0.05)


def test_small_clearance_tends_to_the_ideal_rod_angle():
    """Last revolution, no friction (cheap); the floor is the elastic contact deflection (~10 um)."""
    errs = []
    for s in (1.0, 0.1, 0.01):
        ov = clearances(0.07e-3 * s, 0.03e-3 * s) + friction(0.0)
        res = simulate(NAME, revs=3, rtol=RTOL, overrides=ov)
        assert res.success, res.message
        tb = res.table
        last = tb["t"].to_numpy() >= 2 * period() - 1e-12
        df = ideal_solution(load_scene(NAME, ov), tb["t"].to_numpy()[last])
        errs.append(float(np.max(np.abs(tb["rod.theta"].to_numpy()[last] - df["rod.theta"].to_numpy()))))
    assert errs[0] > errs[1] > errs[2]
    assert errs[1] < 0.2 * errs[0]
    assert errs[0] < 2 * (0.07e-3 + 0.03e-3) / 0.130     # rad: within the clearance play over l2
    assert errs[2] < 3e-5                                 # rad: elastic deflection / l2


def _clearance_trend(revs):
    small = rod_omega_max(clearances(0.01e-3, 0.01e-3) + friction(0.01), revs)
    large = rod_omega_max(clearances(0.5e-3, 0.5e-3) + friction(0.01), revs)
    return small, large


def test_seed_clearance_trend_first_revolution():
    """Seed Fig. 7: max |rod omega| 20 -> 200 rad/s for r = 0.01 -> 0.5 mm at f = 0.01.
    Measured here: 3.2 -> 13 rad/s in the first revolution."""
    small, large = _clearance_trend(1)
    assert large > 2.0 * small


@pytest.mark.slow
def test_seed_clearance_trend_three_revolutions():
    """Measured: 3.17 -> 22.9 rad/s over three revolutions (every revolution's maximum of the
    large clearance exceeds every one of the small clearance by 4x or more)."""
    small, large = _clearance_trend(3)
    assert large > 3.0 * small


FRICTION_XFAIL = ("seed trend not reproduced: max |rod omega| does not grow systematically from f = 0 to "
                  "f = 0.05 in this model (the seed: 40 -> 90 rad/s, x2.25; asserted here: x1.5); the "
                  "revolution-to-revolution scatter of the impact peaks exceeds any friction effect. "
                  "Measured (rtol 1e-7): 1 rev 4.76 vs 4.89, 3 revs 6.99 vs 6.83 rad/s; 10 revs 9.02 vs "
                  "6.95 rad/s with the earlier relative position control (docs/models/excavator.md)")


@pytest.mark.xfail(reason=FRICTION_XFAIL, strict=False)
def test_seed_friction_trend_first_revolution():
    """Seed Fig. 4: max |rod omega| 40 -> 90 rad/s for f = 0 -> 0.05 at the default clearances."""
    assert rod_omega_max(friction(0.05), 1) > 1.5 * rod_omega_max(friction(0.0), 1)


@pytest.mark.slow
@pytest.mark.xfail(reason=FRICTION_XFAIL, strict=False)
def test_seed_friction_trend_ten_revolutions():
    """3-6 minutes: Coulomb friction at f = 0.05 needs ~1.3e8 steps for ten revolutions."""
    res = simulate(NAME, revs=10, rtol=RTOL, overrides=friction(0.05), max_steps=400_000_000)
    assert res.success, res.message
    assert float(np.abs(res.table["rod.omega"]).max()) > 1.5 * rod_omega_max(friction(0.0), 10)
