"""Built-in scene family: the four-bar and the slider-crank variants run, close their loops and, for the
four-bar, tend to the ideal mechanism as the clearance shrinks (docs/models/four_bar.md,
docs/models/slider_crank.md).

Each scene's kernel is compiled once (about 6-12 s cold, cached in NLD_CACHE_DIR); runs themselves take
tens of milliseconds.
"""
import numpy as np
import pytest

from nld.model.ideal import ideal_solution, loop_closure_error
from nld.model.scene import load_scene
from nld.run.simulate import simulate

NEW_SCENES = ["four_bar", "slider_crank_crankpin", "slider_crank_two", "slider_crank_olyaei"]
CLEARANCE_JOINTS = {"four_bar": ["B"], "slider_crank_crankpin": ["A"], "slider_crank_two": ["A", "B"],
                    "slider_crank_olyaei": ["B"]}


@pytest.mark.parametrize("name", NEW_SCENES)
def test_scene_runs_three_revolutions(name):
    res = simulate(name, revs=3)
    assert res.success, res.message
    tb = res.table
    period = 2 * np.pi / abs(load_scene(name).driver.speed)
    assert tb["t"].iloc[-1] == pytest.approx(3 * period, rel=1e-12)
    assert np.isfinite(tb.to_numpy()).all()
    sc = load_scene(name)
    for j in CLEARANCE_JOINTS[name]:
        assert tb[f"{j}.Fn"].max() > 0.0                              # the joint does make contact
        # no runaway penetration (the 5000 rpm crank-pin impacts reach about 0.1 mm, 115 kN)
        assert tb[f"{j}.penetration"].max() < 0.5 * sc.joints[j].clearance


def test_scene_descriptions_and_clearance_joints():
    for name in NEW_SCENES:
        sc = load_scene(name)
        assert sc.name == name and sc.description and "\n" not in sc.description
        assert sorted(j.name for j in sc.joints.values() if j.has_clearance) == CLEARANCE_JOINTS[name]
    ol = load_scene("slider_crank_olyaei").joints["B"]
    assert ol.contact.law == "lankarani_nikravesh" and ol.friction.law == "ambrosio"
    assert (ol.friction.mu, ol.friction.v0, ol.friction.v1) == (0.1, 1e-4, 1e-2)


@pytest.mark.parametrize("name", NEW_SCENES)
def test_ideal_solution_closes_the_loop(name):
    sc = load_scene(name)
    times = np.linspace(0.0, 2 * np.pi / abs(sc.driver.speed), 721)
    df = ideal_solution(sc, times)
    assert loop_closure_error(sc, df) < 1e-10


def test_four_bar_assembles_on_the_open_branch():
    """angle0 hints select the branch with B above the ground line: a full-turn crank, a rocker that
    swings about 45 degrees and stays in (1.4, 2.3) rad."""
    sc = load_scene("four_bar")
    times = np.linspace(0.0, 2 * np.pi / sc.driver.speed, 721)
    df = ideal_solution(sc, times)
    th = df["rocker.theta"].to_numpy()
    assert 1.4 < th.min() and th.max() < 2.3
    assert np.degrees(th.max() - th.min()) == pytest.approx(45.0, abs=2.0)
    assert (df["rocker.y"] > 0).all() and (df["coupler.y"] > 0).all()


def _last_rev_rocker_error(clearance):
    ov = [f"joints.B.clearance={clearance!r}"]
    res = simulate("four_bar", revs=3, overrides=ov)
    assert res.success, res.message
    tb = res.table
    period = 2 * np.pi / abs(load_scene("four_bar").driver.speed)
    last = tb["t"].to_numpy() >= 2 * period - 1e-12
    df = ideal_solution(load_scene("four_bar", ov), tb["t"].to_numpy()[last])
    return float(np.max(np.abs(tb["rocker.theta"].to_numpy()[last] - df["rocker.theta"].to_numpy())))


def test_four_bar_tends_to_ideal_as_clearance_shrinks():
    clearances = (0.5e-3, 0.15e-3, 0.05e-3)
    errs = [_last_rev_rocker_error(c) for c in clearances]
    assert errs[0] > errs[1] > errs[2]
    # first-order bound: a journal offset e moves the rocker by at most about e / (c_rocker sin mu_min),
    # rocker length 0.15 m, smallest transmission angle 40.5 deg (measured: 10.2-10.3 rad/m times c)
    gain = 1.0 / (0.15 * np.sin(np.radians(40.54)))
    for c, e in zip(clearances, errs):
        assert 0.5 * gain * c < e < 1.1 * gain * c


def test_four_bar_zero_clearance_matches_ideal_solution():
    ov = ["joints.B.clearance=0"]
    res = simulate("four_bar", revs=3, overrides=ov)
    assert res.success, res.message
    tb = res.table
    df = ideal_solution(load_scene("four_bar", ov), tb["t"].to_numpy())
    assert np.max(np.abs(tb["rocker.theta"] - df["rocker.theta"])) < 1e-8
    assert np.max(np.abs(tb["coupler.theta"] - df["coupler.theta"])) < 1e-8
    tau, tau_ref = tb["driver.torque"].to_numpy(), df["driver.torque"].to_numpy()
    assert np.max(np.abs(tau - tau_ref)) < 1e-6 * np.max(np.abs(tau_ref))
