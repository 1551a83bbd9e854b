"""Physics checks of the core simulator (issue 2): energy balance, ideal-joint limit, kernels."""
import numpy as np
import pytest

from nld.model.ideal import ideal_solution
from nld.kernel.compile import compile_scene
from nld.model.scene import load_scene
from nld.run.simulate import simulate

CONSERVATIVE = ['driver.mode="torque"', 'joints.B.contact.law="hertz"']


def test_energy_conserved_free_crank_elastic_contact():
    """No damping, no friction, free crank: kinetic + gravity + contact energy is constant.

    The crank turns freely from the benchmark speed; Hertz contact stores K delta^2.5/2.5.
    At rtol 1e-11 the relative drift over more than ten impacts stays below 1e-8.
    """
    r = simulate("slider_crank", revs=3, rtol=1e-11, overrides=CONSERVATIVE)
    assert r.success, r.message
    n_contacts = int((r.events.direction == 1).sum())
    assert n_contacts >= 10
    E = r.table["energy.total"].to_numpy()
    drift = np.abs(E - E[0]).max() / abs(E[0])
    assert drift < 1e-8, drift
    # the energy really moved between forms: the contact did work on the bodies
    assert r.table["B.Fn"].max() > 100.0


def test_energy_drift_shrinks_with_tolerance():
    """The integrator, not luck, keeps the energy: a looser tolerance drifts more."""
    drifts = []
    for rtol in (1e-6, 1e-10):
        r = simulate("slider_crank", revs=1, rtol=rtol, overrides=CONSERVATIVE)
        E = r.table["energy.total"].to_numpy()
        drifts.append(np.abs(E - E[0]).max() / abs(E[0]))
    assert drifts[1] < drifts[0] / 100


def test_zero_clearance_is_an_ideal_joint_matching_independent_reference():
    """clearance = 0 compiles a closed loop (no contact code) that matches nld.model.ideal (absolute coords)."""
    sc = load_scene("slider_crank", ["joints.B.clearance=0"])
    k = compile_scene(sc)
    src = k.source_path.read_text()
    assert "lankarani_nikravesh(" not in src.split("def rhs")[1]
    assert k.topo.cuts == ["B"] and k.n_state == 0
    r = simulate(sc, revs=1, rtol=1e-8)
    assert r.success, r.message
    ref = ideal_solution(sc, r.table.t.to_numpy())
    for col, scale in (("slider.x", 0.17), ("rod.theta", 1.0), ("rod.omega", 200.0),
                       ("slider.ax", 2e4), ("rod.alpha", 1.3e5), ("driver.torque", 140.0)):
        err = np.abs(r.table[col].to_numpy() - ref[col].to_numpy()).max()
        assert err < 1e-9 * scale, (col, err)


@pytest.mark.parametrize("c_big,c_small", [(5e-4, 2e-5)])
def test_clearance_solution_tends_to_ideal(c_big, c_small):
    """The slider motion approaches the ideal kinematics as the clearance shrinks."""
    errs = []
    for c in (c_big, c_small):
        r = simulate("slider_crank", revs=1, rtol=1e-7,
                     overrides=[f"joints.B.clearance={c}", "driver.speed=100.0"])
        assert r.success, r.message
        ref = ideal_solution(load_scene("slider_crank", ["driver.speed=100.0"]), r.table.t.to_numpy())
        errs.append(np.abs(r.table["slider.x"].to_numpy() - ref["slider.x"].to_numpy()).max())
    # the deviation is bounded by the clearance and shrinks with it
    assert errs[0] < 2 * c_big
    assert errs[1] < errs[0] / 5


def test_parameters_do_not_recompile():
    """Changing numbers keeps the kernel; changing structure (friction on) selects another one."""
    k1 = compile_scene(load_scene("slider_crank", ["joints.B.clearance=1e-4"]))
    k2 = compile_scene(load_scene("slider_crank", ["joints.B.clearance=3e-4", "driver.speed=200"]))
    assert k1.key == k2.key and k1.module is k2.module
    k3 = compile_scene(load_scene("slider_crank", ['joints.B.friction.law="coulomb"', "joints.B.friction.mu=0.1"]))
    assert k3.key != k1.key
    src1, src3 = k1.source_path.read_text(), k3.source_path.read_text()
    assert "coulomb(" not in src1 and "coulomb(" in src3
    p1, p2 = k1.params(load_scene("slider_crank", ["joints.B.clearance=1e-4"])), k2.params(
        load_scene("slider_crank", ["joints.B.clearance=3e-4", "driver.speed=200"]))
    i = k1.layout.index["joints.B.clearance"]
    assert p1[i] == 1e-4 and p2[i] == 3e-4


def test_contact_force_acts_along_normal_and_penetration_consistent():
    r = simulate("slider_crank", revs=1, rtol=1e-8)
    tb = r.table
    ecc = np.hypot(tb["B.ex"], tb["B.ey"])
    assert np.allclose(ecc, tb["B.eccentricity"], rtol=0, atol=1e-15)
    assert np.allclose(tb["B.penetration"], tb["B.eccentricity"] - 0.5e-3, atol=1e-15)
    assert ((tb["B.Fn"] > 0) == (tb["B.penetration"] > 0)).all()
    # penetrations stay micrometric for a 6.6e10 N/m^1.5 steel joint
    assert tb["B.penetration"].max() < 100e-6


def test_failure_is_reported_not_garbage():
    r = simulate("slider_crank", revs=1, rtol=1e-8, max_steps=50)
    assert not r.success and r.status == -1
    assert "t =" in r.message or "steps" in r.message
    assert np.isfinite(r.table.drop(columns=["driver.angle"]).to_numpy()).all()


def test_observed_accelerations_match_finite_differences():
    """Accelerations reported in the table are the derivatives of the reported velocities."""
    r = simulate("slider_crank", revs=0.25, rtol=1e-11, samples_per_rev=20000,
                 overrides=["joints.B.clearance=0.5e-3", "driver.speed=50"])
    tb = r.table
    t = tb.t.to_numpy()
    free = (tb["B.contact"].to_numpy() == 0)
    for v, a in (("rod.omega", "rod.alpha"), ("slider.vx", "slider.ax")):
        fd = np.gradient(tb[v].to_numpy(), t)
        ok = free[1:-1] & free[:-2] & free[2:]
        err = np.abs(fd[1:-1] - tb[a].to_numpy()[1:-1])[ok]
        assert err.max() < 1e-4 * np.abs(tb[a]).max() + 1e-6, (a, err.max())


LOADED_TOML = """
[scene]
name = "loaded_slider_crank"
gravity = [0.0, -9.81]
[ground]
points = { O = [0.0, 0.0], G = [0.0, 0.01], K = [0.3, 0.1] }
[bodies.crank]
mass = 0.30
inertia = 1.0e-4
points = { O = [-0.025, 0.0], A = [0.025, 0.0] }
[bodies.rod]
mass = 0.21
inertia = 2.5e-4
points = { A = [-0.06, 0.0], B = [0.06, 0.0], P = [0.0, 0.01] }
angle0 = -0.05
[bodies.slider]
mass = 0.14
inertia = 1.0e-4
points = { B = [0.0, -0.01], S = [0.0, 0.0] }
[joints.O]
type = "revolute"
bodies = ["crank", "ground"]
points = ["O", "O"]
[joints.A]
type = "revolute"
bodies = ["crank", "rod"]
points = ["A", "A"]
[joints.B]
type = "revolute"
bodies = ["slider", "rod"]
points = ["B", "B"]
clearance = 0.0
journal_radius = 9.5e-3
[joints.S]
type = "prismatic"
bodies = ["ground", "slider"]
points = ["G", "S"]
axis = [1.0, 0.1]
[driver]
joint = "O"
mode = "speed"
speed = 80.0
angle0 = 0.3
[[loads]]
type = "force"
body = "slider"
point = "S"
value = [-40.0, 5.0]
modulation = "crank_halves"
[[loads]]
type = "torque"
body = "rod"
value = 1.5
modulation = "crank_table"
table_angles = [0.0, 2.0, 4.0]
table_values = [1.0, -0.5, 0.25]
[[loads]]
type = "spring"
bodies = ["rod", "ground"]
points = ["P", "K"]
stiffness = 800.0
free_length = 0.1
damping = 0.5
[[loads]]
type = "torque"
body = "rod"
value = 0.7
modulation = "angle_threshold"
threshold = -0.1
"""


def test_loads_and_tilted_guide_match_independent_reference(tmp_path):
    """Gravity, a modulated force, a crank table torque, a spring-damper, a threshold torque and a
    tilted guide: the loop kernel (clearance 0) and the absolute-coordinate reference agree."""
    f = tmp_path / "loaded.toml"
    f.write_text(LOADED_TOML)
    sc = load_scene(str(f))
    r = simulate(sc, revs=1, rtol=1e-8, samples_per_rev=180)
    assert r.success, r.message
    ref = ideal_solution(sc, r.table.t.to_numpy())
    for col in ("slider.x", "slider.y", "rod.theta", "rod.alpha", "driver.torque", "energy.total",
                "power.loads"):
        a, b = r.table[col].to_numpy(), ref[col].to_numpy()
        assert np.abs(a - b).max() < 1e-8 * max(1.0, np.abs(b).max()), (col, np.abs(a - b).max())


def test_loads_with_clearance_power_balance(tmp_path):
    """With a clearance and the same loads, driver power + load power = d(total energy)/dt."""
    f = tmp_path / "loaded.toml"
    f.write_text(LOADED_TOML.replace("clearance = 0.0", "clearance = 2e-4"))
    r = simulate(load_scene(str(f)), revs=0.5, rtol=1e-11, samples_per_rev=20000)
    assert r.success, r.message
    tb = r.table
    t = tb.t.to_numpy()
    E = tb["energy.total"].to_numpy()
    P = (tb["power.driver"] + tb["power.loads"]).to_numpy()
    # integrate the power with the trapezoidal rule and compare with the energy change
    work = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(t))])
    scale = np.abs(P).max() * (t[-1] - t[0])
    assert np.abs((E - E[0]) - work).max() < 2e-3 * scale


def test_torque_driven_closed_loop_conserves_energy():
    """A free crank with all joints ideal: a loop kept closed by Newton, energy constant."""
    sc = load_scene("slider_crank", ["joints.B.clearance=0", 'driver.mode="torque"', "driver.speed=300"])
    r = simulate(sc, revs=3, rtol=1e-10)
    assert r.success, r.message
    E = r.table["energy.total"].to_numpy()
    assert np.abs(E - E[0]).max() < 1e-8 * abs(E[0])
    # the loop stays closed: slider pin and rod end coincide
    from nld.model.ideal import loop_closure_error
    assert loop_closure_error(sc, r.table) < 1e-10
