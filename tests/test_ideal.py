"""Tests of nld.model.ideal: the ideal-joint reference in absolute coordinates."""
import math

import numpy as np
import pytest

from nld.model import ideal
from nld.errors import SolveError
from nld.model.scene import load_scene
from nld.model.scene_model import Body, Driver, Joint, Load, Scene

R, L = 0.05, 0.12                      # slider-crank crank and rod lengths (m)


def slider_crank(**kw):
    """The built-in slider-crank (nld/scenes/slider_crank.toml) with optional field changes."""
    sc = load_scene("slider_crank")
    for k, v in kw.items():
        setattr(sc, k, v)
    return sc


def one_rev(scene, n=2000, endpoint=False):
    w = scene.driver.speed
    return np.linspace(0.0, 2 * np.pi / w, n, endpoint=endpoint)


def periodic_derivative(y, h):
    """8th-order central difference of periodic samples y (spacing h)."""
    c = (4 / 5, -1 / 5, 4 / 105, -1 / 280)
    return sum(ck * (np.roll(y, -k - 1) - np.roll(y, k + 1)) for k, ck in enumerate(c)) / h


def four_bar(loads=(), gravity=(0.0, -9.81), speed=120.0, angle0=0.3):
    """Crank-rocker: ground 0.1, crank 0.03, coupler 0.1, rocker 0.08 (upper branch).

    Joint body orders are mixed on purpose (ground first / second) to exercise the sign conventions.
    """
    return Scene(
        name="four_bar", gravity=gravity,
        ground_points={"O": (0.0, 0.0), "C": (0.1, 0.0), "Q": (0.05, 0.12)},
        bodies={
            "crank": Body("crank", 0.1, 2e-5, {"O": (-0.015, 0.0), "A": (0.015, 0.0)}),
            "coupler": Body("coupler", 0.25, 3e-4, {"A": (-0.05, 0.0), "B": (0.05, 0.0),
                                                    "P": (0.0, 0.02)}, angle0=0.9),
            "rocker": Body("rocker", 0.2, 1.5e-4, {"C": (-0.04, 0.0), "B": (0.04, 0.0)}, angle0=1.7),
        },
        joints={
            "O": Joint("O", "revolute", ("ground", "crank"), ("O", "O")),
            "A": Joint("A", "revolute", ("crank", "coupler"), ("A", "A")),
            "B": Joint("B", "revolute", ("rocker", "coupler"), ("B", "B"), clearance=1e-4,
                       journal_radius=5e-3),
            "C": Joint("C", "revolute", ("rocker", "ground"), ("C", "C")),
        },
        driver=Driver("O", "speed", speed, angle0),
        loads=list(loads),
    )


FOUR_BAR_LOADS = [
    Load("torque", body="rocker", value=2.0, modulation="angle_threshold", threshold=1.6),
    Load("force", body="coupler", point="P", value=(3.0, -5.0), modulation="crank_table",
         table_angles=(0.0, 2.0, 4.0), table_values=(1.0, -0.5, 0.25)),
    Load("spring", bodies=("rocker", "ground"), points=("B", "Q"), stiffness=500.0,
         free_length=0.05, damping=0.8),
    Load("torque", body="coupler", value=-0.7, modulation="crank_halves"),
]


# ---------------------------------------------------------------------------------- slider-crank
def test_assemble_slider_crank():
    sc = slider_crank()
    q, qd = ideal.assemble(sc)
    names = list(sc.bodies)
    crank, slider = names.index("crank"), names.index("slider")
    th = q[crank, 2]
    pin = q[crank, :2] + R / 2 * np.array([math.cos(th), math.sin(th)])
    assert np.allclose(pin, [0.05, 0.0], atol=1e-13)
    assert q[slider, 0] == pytest.approx(0.05 + 0.12, abs=1e-13)
    assert abs(q[slider, 1]) < 1e-13
    w = sc.driver.speed
    assert qd[crank, 2] == pytest.approx(w, rel=1e-14)
    assert qd[slider, 0] == pytest.approx(0.0, abs=1e-12)        # dead centre


def test_slider_crank_against_closed_form():
    sc = slider_crank()
    t = one_rev(sc, 1000, endpoint=True)
    df = ideal.ideal_solution(sc, t)
    w = sc.driver.speed
    th = sc.driver.angle0 + w * t
    assert np.allclose(df["driver.angle"], th, rtol=0, atol=1e-12)
    s, c = np.sin(th), np.cos(th)
    beta = np.sqrt(L**2 - R**2 * s**2)
    x = R * c + beta
    xd = -R * w * s - R**2 * w * s * c / beta
    xdd = (-R * w**2 * c - R**2 * w**2 * np.cos(2 * th) / beta
           - R**4 * w**2 * np.sin(2 * th) ** 2 / (4 * beta**3))
    for col, ref in (("slider.x", x), ("slider.vx", xd), ("slider.ax", xdd)):
        err = np.max(np.abs(df[col].to_numpy() - ref)) / np.max(np.abs(ref))
        assert err < 1e-9, (col, err)
    for col in ("slider.y", "slider.vy", "slider.ay", "slider.theta", "slider.omega", "slider.alpha"):
        assert np.max(np.abs(df[col])) < 1e-9 * max(1.0, np.max(np.abs(xdd)))
    # rod angle: sin(phi) = -R sin(theta) / L
    phi = np.arcsin(-R * s / L)
    assert np.max(np.abs(df["rod.theta"] - phi)) < 1e-12
    assert ideal.loop_closure_error(sc, df) < 1e-10


def test_slider_crank_columns():
    sc = slider_crank()
    df = ideal.ideal_solution(sc, one_rev(sc, 10))
    expected = ["t", "driver.angle", "driver.speed", "driver.torque"]
    for b in sc.bodies:
        expected += [f"{b}.{c}" for c in ("x", "y", "theta", "vx", "vy", "omega", "ax", "ay", "alpha")]
    for jn, j in sc.joints.items():
        expected += [f"{jn}.Fx", f"{jn}.Fy"] + ([f"{jn}.M"] if j.type == "prismatic" else [])
    expected += ["energy.kinetic", "energy.potential", "energy.total", "power.driver", "power.loads"]
    assert list(df.columns) == expected
    assert np.allclose(df["driver.speed"], sc.driver.speed, rtol=1e-14, atol=0)


def _slider_crank_with_loads():
    sc = slider_crank()
    sc.loads = [
        Load("force", body="slider", point="S", value=(-40.0, 5.0), modulation="crank_halves"),
        Load("torque", body="rod", value=0.8, modulation="crank_table",
             table_angles=(0.0, 3.0, 5.0), table_values=(1.0, -1.0, 0.5)),
        Load("spring", bodies=("rod", "ground"), points=("B", "O"), stiffness=2.0e3,
             free_length=0.1, damping=1.5),
        Load("torque", body="rod", value=-0.3, modulation="angle_threshold", threshold=0.1),
    ]
    return sc


def test_slider_crank_power_balance():
    sc = _slider_crank_with_loads()
    n = 2000
    t = one_rev(sc, n)
    df = ideal.ideal_solution(sc, t)
    assert ideal.loop_closure_error(sc, df) < 1e-10
    dE = periodic_derivative(df["energy.total"].to_numpy(), t[1] - t[0])
    resid = df["power.driver"] + df["power.loads"] - dE
    peak = np.max(np.abs(df["power.driver"]))
    assert np.max(np.abs(resid)) < 1e-6 * peak
    assert np.max(np.abs(df["power.loads"])) > 1.0          # the loads do work
    # integral form: the energy is periodic, so the net work over a revolution vanishes
    work = np.mean(df["power.driver"] + df["power.loads"]) * (t[-1] + t[1])
    assert abs(work) < 1e-6 * peak * t[-1]


def test_slider_crank_mean_driver_torque_zero_without_loads():
    sc = slider_crank(gravity=(0.0, 0.0), loads=[])
    df = ideal.ideal_solution(sc, one_rev(sc, 1024))
    tau = df["driver.torque"].to_numpy()
    assert np.max(np.abs(tau)) > 10.0
    assert abs(np.mean(tau)) < 1e-9 * np.max(np.abs(tau))
    assert np.max(np.abs(df["power.loads"])) == 0.0
    assert np.ptp(df["energy.potential"]) == 0.0


def test_slider_crank_reaction_signs():
    """Newton-Euler for each body from the joint reaction columns (force on the FIRST body)."""
    sc = _slider_crank_with_loads()
    sc.loads = []                                     # only gravity: applied forces m g
    df = ideal.ideal_solution(sc, one_rev(sc, 200))
    g = np.asarray(sc.gravity)
    on = {b: np.zeros((len(df), 2)) for b in sc.bodies}
    for jn, j in sc.joints.items():
        F = df[[f"{jn}.Fx", f"{jn}.Fy"]].to_numpy()
        b0, b1 = j.bodies
        if b0 != "ground":
            on[b0] += F
        if b1 != "ground":
            on[b1] -= F
    scale = np.max(np.abs(df["O.Fx"]))
    for b, body in sc.bodies.items():
        ma = body.mass * df[[f"{b}.ax", f"{b}.ay"]].to_numpy()
        assert np.max(np.abs(on[b] + body.mass * g - ma)) < 1e-9 * scale, b
    # rod moment balance about its centre of mass: forces at A (second body) and B (second body)
    th = df["rod.theta"].to_numpy()
    mom = np.zeros(len(df))
    for jn in ("A", "B"):
        sx, sy = sc.bodies["rod"].points[sc.joints[jn].points[1]]
        ax, ay = np.cos(th) * sx - np.sin(th) * sy, np.sin(th) * sx + np.cos(th) * sy
        F = -df[[f"{jn}.Fx", f"{jn}.Fy"]].to_numpy()
        mom += ax * F[:, 1] - ay * F[:, 0]
    Ia = sc.bodies["rod"].inertia * df["rod.alpha"].to_numpy()
    assert np.max(np.abs(mom - Ia)) < 1e-9 * scale * L
    # all forces on the slider act at its centre of mass: no guide couple
    assert np.max(np.abs(df["S.M"])) < 1e-9 * scale * L
    # the guide pushes on the slider vertically only
    assert np.max(np.abs(df["S.Fx"])) < 1e-9 * scale


# ---------------------------------------------------------------------------------- four-bar
def test_four_bar_assembles_and_closes():
    fb = four_bar()
    q, qd = ideal.assemble(fb)
    # B on the upper intersection of the circles about A (r 0.1) and C (r 0.08)
    A = 0.03 * np.array([math.cos(0.3), math.sin(0.3)])
    C = np.array([0.1, 0.0])
    d = np.linalg.norm(C - A)
    a = (0.1**2 - 0.08**2 + d**2) / (2 * d)
    h = math.sqrt(0.1**2 - a**2)
    u = (C - A) / d
    B = A + a * u + h * np.array([-u[1], u[0]])
    th = q[2, 2]
    assert np.allclose(q[2, :2] + 0.04 * np.array([math.cos(th), math.sin(th)]), B, atol=1e-13)
    df = ideal.ideal_solution(fb, one_rev(fb, 500))
    assert ideal.loop_closure_error(fb, df) < 1e-10
    # crank-rocker: the rocker oscillates, the coupler does not turn round
    assert np.ptp(df["rocker.theta"]) < np.pi
    assert np.ptp(df["coupler.theta"]) < np.pi


def test_four_bar_driver_torque_from_power_balance():
    fb = four_bar(loads=FOUR_BAR_LOADS)
    n = 2000
    t = one_rev(fb, n)
    df = ideal.ideal_solution(fb, t)
    assert ideal.loop_closure_error(fb, df) < 1e-10
    dT = sum(fb.bodies[b].mass * (df[f"{b}.vx"] * df[f"{b}.ax"] + df[f"{b}.vy"] * df[f"{b}.ay"])
             + fb.bodies[b].inertia * df[f"{b}.omega"] * df[f"{b}.alpha"] for b in fb.bodies)
    dV = periodic_derivative(df["energy.potential"].to_numpy(), t[1] - t[0])
    tau_pb = (dT.to_numpy() + dV - df["power.loads"].to_numpy()) / df["driver.speed"].to_numpy()
    tau = df["driver.torque"].to_numpy()
    assert np.max(np.abs(tau - tau_pb)) < 1e-6 * np.max(np.abs(tau))
    # the modulated loads actually switch
    assert np.ptp(df["power.loads"]) > 0.1


def test_four_bar_impossible_raises():
    fb = four_bar()
    fb.ground_points["C"] = (0.3, 0.0)                # 0.03 + 0.1 + 0.08 < 0.3: cannot close
    with pytest.raises(SolveError):
        ideal.assemble(fb)


def test_underdetermined_least_norm():
    fb = four_bar()
    fb.driver = None                                  # one free coordinate left
    q, qd = ideal.assemble(fb)
    ref, _ = ideal.assemble(four_bar(angle0=0.0))    # the hints: crank angle0 = 0 without a driver
    mdl = ideal._Model(fb)
    assert np.max(np.abs(mdl.phi(mdl.extend(q[None]), np.zeros(1)))) < 1e-12
    assert np.allclose(qd, 0.0)
    assert np.allclose(q, ref, atol=0.05)             # stays near the hinted configuration


def test_assemble_guess_and_time():
    sc = slider_crank()
    w = sc.driver.speed
    t = 0.3 * np.pi / w                               # crank at 54 degrees
    q, qd = ideal.assemble(sc, t)
    th = sc.driver.angle0 + w * t
    slider = list(sc.bodies).index("slider")
    assert q[slider, 0] == pytest.approx(R * math.cos(th) + math.sqrt(L**2 - (R * math.sin(th))**2),
                                         abs=1e-13)
    q2, _ = ideal.assemble(sc, t, guess=q + 1e-3)
    assert np.allclose(q2, q, atol=1e-13)


# ---------------------------------------------------------------------------------- moving guide
def quick_return(gravity=(0.0, -9.81), speed=80.0):
    """Whitworth-type quick return: crank O-A, a block pinned to the crank at A that slides on a
    rocker pivoted at C. The guide is on a moving body, its axis is not the body's x axis, the
    sliding point is off the block's centre of mass and the block keeps a relative angle of 0.2."""
    return Scene(
        name="quick_return", gravity=gravity,
        ground_points={"O": (0.0, 0.0), "C": (0.0, -0.1)},
        bodies={
            "crank": Body("crank", 0.2, 5e-5, {"O": (-0.02, 0.0), "A": (0.02, 0.0)}),
            "rocker": Body("rocker", 0.4, 1.2e-3, {"C": (-0.06, -0.08), "G": (-0.06, -0.08)},
                           angle0=0.3),
            "block": Body("block", 0.1, 1e-5, {"P": (0.0, 0.0), "S": (0.01, -0.005)}, angle0=0.5),
        },
        joints={
            "O": Joint("O", "revolute", ("crank", "ground"), ("O", "O")),
            "C": Joint("C", "revolute", ("ground", "rocker"), ("C", "C")),
            "A": Joint("A", "revolute", ("crank", "block"), ("A", "P")),
            "S": Joint("S", "prismatic", ("rocker", "block"), ("G", "S"), axis=(0.6, 0.8)),
        },
        driver=Driver("O", "speed", speed, 0.3),
        loads=[Load("force", body="block", point="S", value=(1.0, 2.0)),
               Load("spring", bodies=("rocker", "ground"), points=("G", "O"), stiffness=300.0,
                    free_length=0.05, damping=0.5)],
    )


def _rot(th, s):
    return np.cos(th) * s[0] - np.sin(th) * s[1], np.sin(th) * s[0] + np.cos(th) * s[1]


def test_moving_guide_kinematics_and_dynamics():
    qr = quick_return()
    n = 2000
    t = one_rev(qr, n)
    h = t[1] - t[0]
    df = ideal.ideal_solution(qr, t)
    assert ideal.loop_closure_error(qr, df) < 1e-10
    assert np.allclose(df["block.theta"] - df["rocker.theta"], 0.2, rtol=0, atol=1e-12)
    assert np.ptp(df["rocker.theta"]) < np.pi                # the rocker oscillates
    # velocities and accelerations against differences of the positions / velocities
    for b in qr.bodies:
        for p, v in (("x", "vx"), ("y", "vy"), ("theta", "omega"), ("vx", "ax"), ("vy", "ay"),
                     ("omega", "alpha")):
            y = df[f"{b}.{p}"].to_numpy()
            if p == "theta" and b == "crank":
                y = y - qr.driver.speed * t                  # not periodic: remove the ramp
                ref = df[f"{b}.{v}"].to_numpy() - qr.driver.speed
            else:
                ref = df[f"{b}.{v}"].to_numpy()
            err = np.max(np.abs(periodic_derivative(y, h) - ref))
            assert err <= 1e-8 * max(np.max(np.abs(df[f"{b}.{v}"])), 1e-3), (b, v, err)
    # power balance
    dE = periodic_derivative(df["energy.total"].to_numpy(), h)
    resid = df["power.driver"] + df["power.loads"] - dE
    assert np.max(np.abs(resid)) < 1e-6 * np.max(np.abs(df["power.driver"]))
    # Newton-Euler of block and rocker from the reaction columns (prismatic couple about the
    # sliding point, force at the sliding point)
    g = np.asarray(qr.gravity)
    FA = df[["A.Fx", "A.Fy"]].to_numpy()       # on the crank by the block
    FS = df[["S.Fx", "S.Fy"]].to_numpy()       # on the rocker by the block
    MS = df["S.M"].to_numpy()
    FC = df[["C.Fx", "C.Fy"]].to_numpy()       # on the ground by the rocker
    blk, rk = qr.bodies["block"], qr.bodies["rocker"]
    tb, tr = df["block.theta"].to_numpy(), df["rocker.theta"].to_numpy()
    load = np.array([1.0, 2.0])
    scale = np.max(np.abs(FA))
    fb = -FA - FS + blk.mass * g + load
    assert np.max(np.abs(fb - blk.mass * df[["block.ax", "block.ay"]].to_numpy())) < 1e-9 * scale
    aP = _rot(tb, blk.points["P"])
    aS = _rot(tb, blk.points["S"])
    mb = (aP[0] * -FA[:, 1] - aP[1] * -FA[:, 0]) + (aS[0] * (load[1] - FS[:, 1])
                                                   - aS[1] * (load[0] - FS[:, 0])) - MS
    assert np.max(np.abs(mb - blk.inertia * df["block.alpha"])) < 1e-9 * scale * 0.1
    # rocker: the spring at G is an applied force too
    rG = np.stack(_rot(tr, rk.points["G"]), axis=1)
    pG = df[["rocker.x", "rocker.y"]].to_numpy() + rG
    d = -pG
    Ls = np.linalg.norm(d, axis=1)
    u = d / Ls[:, None]
    vG = df[["rocker.vx", "rocker.vy"]].to_numpy() + df["rocker.omega"].to_numpy()[:, None] * np.stack(
        (-rG[:, 1], rG[:, 0]), axis=1)
    Fsp = (300.0 * (Ls - 0.05) + 0.5 * np.einsum("nk,nk->n", u, -vG))[:, None] * u
    fr = -FC + FS + rk.mass * g + Fsp
    assert np.max(np.abs(fr - rk.mass * df[["rocker.ax", "rocker.ay"]].to_numpy())) < 1e-9 * scale
    rS = df[["block.x", "block.y"]].to_numpy() + np.stack(aS, axis=1) - df[["rocker.x", "rocker.y"]].to_numpy()
    rC = np.stack(_rot(tr, rk.points["C"]), axis=1)
    mr = (rC[:, 0] * -FC[:, 1] - rC[:, 1] * -FC[:, 0]) + (rS[:, 0] * FS[:, 1] - rS[:, 1] * FS[:, 0]) \
        + MS + (rG[:, 0] * Fsp[:, 1] - rG[:, 1] * Fsp[:, 0])
    assert np.max(np.abs(mr - rk.inertia * df["rocker.alpha"])) < 1e-9 * scale * 0.1
    assert np.max(np.abs(MS)) > 1e-3 * scale * 0.01       # the couple is exercised
