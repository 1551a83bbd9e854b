"""Contact and friction laws (nld/laws/contact/*.py, nld/laws/friction.py) against hand-computed values.

Reference values are written out as arithmetic with concrete numbers so that each one can be
checked with a pocket calculator; the laws are never used to compute their own expected values.
"""
import math

import numba
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from nld.laws.contact.flores import flores
from nld.laws.contact.gonthier import gonthier
from nld.laws.contact.hertz import hertz
from nld.laws.contact.hertz_damped import hertz_damped
from nld.laws.contact.hunt_crossley import hunt_crossley
from nld.laws.contact.lankarani_nikravesh import lankarani_nikravesh
from nld.laws.elastic import contact_energy, journal_bearing_stiffness
from nld.laws.friction import ambrosio, coulomb, slip_velocity, viscous

# Common numbers: K = 1e10 N/m^1.5, n = 1.5, delta = 1e-5 m, ddot = 0.3 m/s, v_minus = 0.5 m/s,
# cr = 0.9.
K, N, DELTA, DDOT, VM, CR = 1e10, 1.5, 1e-5, 0.3, 0.5, 0.9
# delta^1.5 = (1e-5)^1.5 = 1e-7.5 = 3.1622776601683794e-8, so K delta^n = 316.22776601683796 N.
K_DN = 1e10 * 3.1622776601683794e-8
REL = 1e-12

DISSIPATIVE = [lankarani_nikravesh, hunt_crossley, flores, gonthier]


# ---------------------------------------------------------------- normal force: values by hand

def test_hertz_value():
    assert K_DN == pytest.approx(316.22776601683796, rel=REL)
    assert hertz(DELTA, DDOT, K, N) == pytest.approx(K_DN, rel=REL)
    # ddot does not matter for the elastic law
    assert hertz(DELTA, -5.0, K, N) == pytest.approx(K_DN, rel=REL)


def test_hertz_damped_value():
    # C = 1000 N s/m: 316.22776601683796 + 1000 * 0.3 = 616.22776601683796 N
    assert hertz_damped(DELTA, DDOT, K, N, 1000.0) == pytest.approx(616.22776601683796, rel=REL)
    # force jumps at onset: at delta -> 0+ the force is C ddot = 300 N, not 0
    assert hertz_damped(1e-300, DDOT, K, N, 1000.0) == pytest.approx(300.0, rel=REL)


def test_lankarani_nikravesh_value():
    # 1 + 3 (1 - 0.81) / 4 * 0.3 / 0.5 = 1 + 0.1425 * 0.6 = 1.0855
    expected = 316.22776601683796 * 1.0855
    assert lankarani_nikravesh(DELTA, DDOT, K, N, CR, VM) == pytest.approx(expected, rel=REL)


def test_hunt_crossley_value():
    # chi/K * ddot = 3 (1 - 0.9) / (2 * 0.5) * 0.3 = 0.3 * 0.3 = 0.09
    expected = 316.22776601683796 * 1.09
    assert hunt_crossley(DELTA, DDOT, K, N, CR, VM) == pytest.approx(expected, rel=REL)


def test_flores_value():
    # chi/K * ddot = 8 (1 - 0.9) / (5 * 0.9 * 0.5) * 0.3 = 0.8 / 2.25 * 0.3 = 0.10666...
    expected = 316.22776601683796 * (1.0 + 0.8 / 2.25 * 0.3)
    assert flores(DELTA, DDOT, K, N, CR, VM) == pytest.approx(expected, rel=REL)


def test_gonthier_value():
    # chi/K * ddot = (1 - 0.81) / (0.9 * 0.5) * 0.3 = 0.19 / 0.45 * 0.3 = 0.12666...
    expected = 316.22776601683796 * (1.0 + 0.19 / 0.45 * 0.3)
    assert gonthier(DELTA, DDOT, K, N, CR, VM) == pytest.approx(expected, rel=REL)


def test_contact_energy_value():
    # K delta^2.5 / 2.5 = 1e10 * (1e-5)^2.5 / 2.5 = 1e10 * 3.1622776601683794e-13 / 2.5
    assert contact_energy(DELTA, K, N) == pytest.approx(1e10 * 3.1622776601683794e-13 / 2.5, rel=REL)
    assert contact_energy(0.0, K, N) == 0.0
    assert contact_energy(-1e-6, K, N) == 0.0
    # dV/ddelta = K delta^n (finite difference)
    h = 1e-10
    dv = (contact_energy(DELTA + h, K, N) - contact_energy(DELTA - h, K, N)) / (2 * h)
    assert dv == pytest.approx(K_DN, rel=1e-6)


# ---------------------------------------------------------------- normal force: zero and clamp

@pytest.mark.parametrize("delta", [0.0, -1e-9, -1.0])
def test_zero_without_penetration(delta):
    assert hertz(delta, DDOT, K, N) == 0.0
    assert hertz_damped(delta, DDOT, K, N, 1000.0) == 0.0
    for law in DISSIPATIVE:
        assert law(delta, DDOT, K, N, CR, VM) == 0.0
        assert law(delta, -DDOT, K, N, CR, VM) == 0.0


def test_clamped_at_zero_no_adhesion():
    # hertz_damped: 316.2 + 1000 * (-1) < 0 -> 0
    assert hertz_damped(DELTA, -1.0, K, N, 1000.0) == 0.0
    # flores at cr = 0.5: 1 + 8 * 0.5 / (5 * 0.5 * 0.5) * (-0.5) / 0.5 = 1 - 3.2 = -2.2 < 0 -> 0
    assert flores(DELTA, -0.5, K, N, 0.5, VM) == 0.0
    # lankarani_nikravesh with cr = 0: 1 + 0.75 * (-1.0) / 0.5 = -0.5 < 0 -> 0
    assert lankarani_nikravesh(DELTA, -1.0, K, N, 0.0, VM) == 0.0
    # a large separation rate never gives a negative force
    for law in DISSIPATIVE:
        assert law(DELTA, -100.0, K, N, 0.5, VM) == 0.0


def test_restitution_branch_below_elastic():
    # separating (ddot < 0) with a small rate: positive, below the elastic force
    for law in DISSIPATIVE:
        f = law(DELTA, -0.01, K, N, CR, VM)
        assert 0.0 < f < K_DN


def test_laws_inline_into_njit_caller():
    @numba.njit
    def caller(delta, ddot):
        return (
            hertz(delta, ddot, 1e10, 1.5)
            + hertz_damped(delta, ddot, 1e10, 1.5, 1000.0)
            + lankarani_nikravesh(delta, ddot, 1e10, 1.5, 0.9, 0.5)
            + hunt_crossley(delta, ddot, 1e10, 1.5, 0.9, 0.5)
            + flores(delta, ddot, 1e10, 1.5, 0.9, 0.5)
            + gonthier(delta, ddot, 1e10, 1.5, 0.9, 0.5)
            + contact_energy(delta, 1e10, 1.5)
            + coulomb(ddot, 100.0, 0.1)
            + ambrosio(ddot, 100.0, 0.1, 0.01, 0.03)
            + viscous(ddot, 2.0)
            + slip_velocity(0.1, 0.2, 0.6, 0.8, 1.0, 2.0, 0.0095, 0.01)
        )

    expected = (
        hertz(DELTA, DDOT, K, N)
        + hertz_damped(DELTA, DDOT, K, N, 1000.0)
        + lankarani_nikravesh(DELTA, DDOT, K, N, CR, VM)
        + hunt_crossley(DELTA, DDOT, K, N, CR, VM)
        + flores(DELTA, DDOT, K, N, CR, VM)
        + gonthier(DELTA, DDOT, K, N, CR, VM)
        + contact_energy(DELTA, K, N)
        + coulomb(DDOT, 100.0, 0.1)
        + ambrosio(DDOT, 100.0, 0.1, 0.01, 0.03)
        + viscous(DDOT, 2.0)
        + slip_velocity(0.1, 0.2, 0.6, 0.8, 1.0, 2.0, 0.0095, 0.01)
    )
    assert caller(DELTA, DDOT) == pytest.approx(expected, rel=1e-14)


# ---------------------------------------------------------------- 1-DOF impact: restitution

def _impact(force, v_minus, m=1.0, k=1e10):
    """m x'' = -F(x, x'), x = penetration, from x = 0 with x' = v_minus; returns rebound/approach
    speed ratio and the solution."""

    def rhs(t, y):
        return [y[1], -force(y[0], y[1]) / m]

    def exit_contact(t, y):
        return y[0]

    exit_contact.terminal = True
    exit_contact.direction = -1.0
    # contact time scale: (m / (k v^(1/2)))^(2/5) ~ 1e-4 s here
    sol = solve_ivp(
        rhs, (0.0, 1e-2), [0.0, v_minus], method="DOP853", rtol=1e-11, atol=[1e-16, 1e-12],
        events=exit_contact, dense_output=True,
    )
    assert sol.status == 1, "the body did not leave the contact"
    v_out = sol.y_events[0][0][1]
    return -v_out / v_minus, sol


def test_hertz_impact_is_elastic_and_conserves_energy():
    v0, m = 0.5, 1.0
    ratio, sol = _impact(lambda d, dd: hertz(d, dd, K, N), v0, m)
    assert ratio == pytest.approx(1.0, abs=1e-6)
    # kinetic + contact potential is constant along the trajectory
    e0 = 0.5 * m * v0**2
    for t in np.linspace(0.0, sol.t[-1], 50):
        x, v = sol.sol(t)
        assert 0.5 * m * v**2 + contact_energy(x, K, N) == pytest.approx(e0, rel=1e-6)


def test_lankarani_nikravesh_restitution_near_cr_for_high_cr():
    v0 = 0.5
    ratio, _ = _impact(lambda d, dd: lankarani_nikravesh(d, dd, K, N, 0.9, v0), v0)
    assert ratio == pytest.approx(0.9, abs=0.02)


def test_flores_closer_than_lankarani_nikravesh_at_low_cr():
    v0 = 0.5
    r_ln, _ = _impact(lambda d, dd: lankarani_nikravesh(d, dd, K, N, 0.5, v0), v0)
    r_fl, _ = _impact(lambda d, dd: flores(d, dd, K, N, 0.5, v0), v0)
    assert abs(r_fl - 0.5) < abs(r_ln - 0.5)
    assert r_fl == pytest.approx(0.5, abs=0.05)


@pytest.mark.parametrize("law", DISSIPATIVE)
def test_dissipative_laws_lose_energy(law):
    v0 = 0.5
    r1, _ = _impact(lambda d, dd: law(d, dd, K, N, 0.8, v0), v0)
    r2, _ = _impact(lambda d, dd: law(d, dd, K, N, 0.6, v0), v0)
    assert 0.0 < r2 < r1 < 1.0


# ---------------------------------------------------------------- stiffness

def test_journal_bearing_stiffness_flores_joint():
    # Flores joint: R_B = 10 mm, R_J = 9.5 mm, E = 207 GPa, nu = 0.3 for both.
    # sigma = (1 - 0.3^2) / 207e9 = 0.91 / 2.07e11 = 4.396135265700483e-12 1/Pa
    # 4 / (3 * (2 * 4.396135265700483e-12)) = 1.5164835164835165e11
    # sqrt(0.0095 * 0.010 / (0.010 - 0.0095)) = sqrt(9.5e-5 / 5e-4) = sqrt(0.19) = 0.4358898943540673
    # K = 1.5164835164835165e11 * 0.4358898943540673 = 6.610198397896845e10 N/m^1.5
    k = journal_bearing_stiffness(0.0095, 0.010, 207e9, 0.3, 207e9, 0.3)
    assert k == pytest.approx(1.5164835164835165e11 * 0.4358898943540673, rel=1e-12)
    assert k == pytest.approx(6.6e10, rel=0.01)
    # the pi-form with h = (1 - nu^2) / (pi E) and 4 / (3 pi (h_i + h_j)) is the same number;
    # mixing conventions (sigma in the pi-form) would give 2.1e10: a factor pi off.
    h = 0.91 / (math.pi * 207e9)
    assert k == pytest.approx(4.0 / (3.0 * math.pi * 2 * h) * math.sqrt(0.19), rel=1e-12)
    assert k / 2.104e10 == pytest.approx(math.pi, rel=1e-3)


def test_journal_bearing_stiffness_different_materials():
    # steel journal (207 GPa, 0.3) in bronze bearing (110 GPa, 0.34), R_J = 9.5 mm, R_B = 10 mm
    # sigma_i = 0.91 / 207e9 = 4.396135265700483e-12, sigma_j = (1 - 0.1156) / 110e9 = 8.04e-12
    # 4 / (3 * 12.436135265700483e-12) * sqrt(0.19)
    k = journal_bearing_stiffness(0.0095, 0.010, 207e9, 0.3, 110e9, 0.34)
    assert k == pytest.approx(4.0 / (3.0 * 12.436135265700483e-12) * 0.4358898943540673, rel=1e-12)


@pytest.mark.parametrize(
    "args, name",
    [
        ((0.0, 0.010, 207e9, 0.3, 207e9, 0.3), "R_journal"),
        ((-0.001, 0.010, 207e9, 0.3, 207e9, 0.3), "R_journal"),
        ((0.010, 0.010, 207e9, 0.3, 207e9, 0.3), "R_bearing"),
        ((0.011, 0.010, 207e9, 0.3, 207e9, 0.3), "R_bearing"),
        ((0.0095, 0.010, 0.0, 0.3, 207e9, 0.3), "E_journal"),
        ((0.0095, 0.010, 207e9, 0.3, -1.0, 0.3), "E_bearing"),
        ((0.0095, 0.010, 207e9, 0.5, 207e9, 0.3), "nu_journal"),
        ((0.0095, 0.010, 207e9, 0.3, 207e9, -0.1), "nu_bearing"),
        ((0.0095, 0.010, float("nan"), 0.3, 207e9, 0.3), "E_journal"),
        ((0.0095, float("inf"), 207e9, 0.3, 207e9, 0.3), "R_bearing"),
    ],
)
def test_journal_bearing_stiffness_rejects_bad_input(args, name):
    with pytest.raises(ValueError, match=f"^{name} = ") as info:
        journal_bearing_stiffness(*args)
    assert "\n" not in str(info.value)


# ---------------------------------------------------------------- friction

def test_coulomb_values_and_signs():
    # mu = 0.1, Fn = 200 N -> mu Fn = 20 N
    assert coulomb(0.3, 200.0, 0.1) == pytest.approx(20.0, rel=REL)
    assert coulomb(-0.3, 200.0, 0.1) == pytest.approx(-20.0, rel=REL)
    assert coulomb(-1e-12, 200.0, 0.1) == pytest.approx(-20.0, rel=REL)
    # seed eqs 10-11: sigma = +1 for vt >= 0, so +mu Fn at vt == 0
    assert coulomb(0.0, 200.0, 0.1) == pytest.approx(20.0, rel=REL)
    assert coulomb(0.3, 0.0, 0.1) == 0.0


def test_ambrosio_ramp():
    mu, fn, v0, v1 = 0.1, 200.0, 0.01, 0.03
    # below v0: no friction
    assert ambrosio(0.0, fn, mu, v0, v1) == 0.0
    assert ambrosio(0.005, fn, mu, v0, v1) == 0.0
    assert ambrosio(-0.005, fn, mu, v0, v1) == 0.0
    assert ambrosio(v0, fn, mu, v0, v1) == 0.0
    # midpoint 0.02: c_d = (0.02 - 0.01) / (0.03 - 0.01) = 0.5 -> 0.1 * 0.5 * 200 = 10 N
    assert ambrosio(0.02, fn, mu, v0, v1) == pytest.approx(10.0, rel=1e-12)
    # quarter point 0.015: c_d = 0.005 / 0.02 = 0.25 -> 5 N
    assert ambrosio(0.015, fn, mu, v0, v1) == pytest.approx(5.0, rel=1e-12)
    # at and above v1: full Coulomb 20 N
    assert ambrosio(v1, fn, mu, v0, v1) == pytest.approx(20.0, rel=1e-12)
    assert ambrosio(2.0, fn, mu, v0, v1) == pytest.approx(20.0, rel=1e-12)


def test_ambrosio_negative_slip_does_not_vanish():
    # the public-code bug (signed vt in c_d) would give c_d = 0 here and no friction
    mu, fn, v0, v1 = 0.1, 200.0, 0.01, 0.03
    assert ambrosio(-0.02, fn, mu, v0, v1) == pytest.approx(-10.0, rel=1e-12)
    assert ambrosio(-0.015, fn, mu, v0, v1) == pytest.approx(-5.0, rel=1e-12)
    assert ambrosio(-0.05, fn, mu, v0, v1) == pytest.approx(-20.0, rel=1e-12)
    # odd in vt
    for vt in [0.012, 0.02, 0.029, 0.5]:
        assert ambrosio(-vt, fn, mu, v0, v1) == -ambrosio(vt, fn, mu, v0, v1)


def test_viscous():
    # Ct = 50 N s/m: 50 * 0.3 = 15 N, 50 * (-0.3) = -15 N
    assert viscous(0.3, 50.0) == pytest.approx(15.0, rel=REL)
    assert viscous(-0.3, 50.0) == pytest.approx(-15.0, rel=REL)


def test_slip_velocity_hand_value():
    # e' = (0.2, -0.1) m/s, n at 30 deg: (cos 30, sin 30) = (0.8660254037844387, 0.5)
    # t = (-0.5, 0.8660254037844387); e'.t = -0.1 - 0.08660254037844387 = -0.18660254037844387
    # + w_J R_J = 10 * 0.0095 = 0.095; - w_B R_B = -(-4) * 0.010 = +0.04
    # v_t = -0.18660254037844387 + 0.095 + 0.04 = -0.05160254037844387 m/s
    nx, ny = math.cos(math.radians(30.0)), math.sin(math.radians(30.0))
    vt = slip_velocity(0.2, -0.1, nx, ny, 10.0, -4.0, 0.0095, 0.010)
    assert vt == pytest.approx(-0.05160254037844387, rel=1e-12)


def test_slip_velocity_matches_seed_eq5_for_equal_radii():
    # seed eq 5: v_t = e_y' cos a - e_x' sin a + (w_i - w_{i+1}) R_i
    a, dex, dey, wi, wj, r = 2.1, -0.7, 0.4, 3.0, -1.5, 0.02
    seed = dey * math.cos(a) - dex * math.sin(a) + (wi - wj) * r
    assert slip_velocity(dex, dey, math.cos(a), math.sin(a), wi, wj, r, r) == pytest.approx(seed, rel=1e-12)


def test_slip_velocity_from_contact_point_kinematics():
    # finite-difference check: contact point on the journal is x_J + R_J n, on the bearing x_B + R_B n;
    # differentiate each material point (body-fixed) and project the relative velocity on t.
    xj, vj, th_j, wj, rj = np.array([0.003, -0.004]), np.array([0.3, 0.1]), 0.4, 7.0, 0.0095
    xb, vb, th_b, wb, rb = np.array([0.0, 0.0]), np.array([-0.2, 0.5]), -0.2, -3.0, 0.010
    e = xj - xb
    n = e / np.linalg.norm(e)
    t = np.array([-n[1], n[0]])
    # body-fixed offsets of the current contact point
    def rot(a):
        return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    sj, sb = rot(-th_j) @ (rj * n), rot(-th_b) @ (rb * n)
    h = 1e-7
    pj = lambda s: xj + vj * s + rot(th_j + wj * s) @ sj
    pb = lambda s: xb + vb * s + rot(th_b + wb * s) @ sb
    rel = ((pj(h) - pj(-h)) - (pb(h) - pb(-h))) / (2 * h)
    de = vj - vb
    vt = slip_velocity(de[0], de[1], n[0], n[1], wj, wb, rj, rb)
    assert vt == pytest.approx(float(rel @ t), rel=1e-7)


# ---------------------------------------------------------------- the law registry (issue 16)

MY_LAW = '''
import numba
from nld.laws.law import ContactLaw


@numba.njit(cache=False, inline="always")
def {name}(delta, ddot, K, n, cr, v_minus):
    """Lankarani-Nikravesh written again, times {scale}."""
    if delta <= 0.0:
        return 0.0
    dn = delta**n
    chi = 3.0 * (1.0 - cr * cr) * K / (4.0 * v_minus)
    f = K * dn + chi * dn * ddot
    return {scale} * max(f, 0.0)


LAW = ContactLaw(name="{name}", force={name}, extra=("restitution", "v_minus"))
'''


def test_a_law_is_one_file(tmp_path, monkeypatch):
    """Adding a contact law is one file: a module holding the force and LAW, registered, is picked
    by the scene's contact.law; written as Lankarani-Nikravesh it gives LN's trajectory bit for
    bit, and scaled by 2 it gives another one (the file's force is what runs)."""
    import importlib

    import nld
    from nld.laws.law import contact_law, contact_laws, register
    monkeypatch.syspath_prepend(str(tmp_path))
    for name, scale in (("ln_again", "1.0"), ("ln_twice", "2.0")):
        (tmp_path / f"{name}.py").write_text(MY_LAW.format(name=name, scale=scale))
        register(importlib.import_module(name).LAW)
    assert {"ln_again", "ln_twice"} <= set(contact_laws())
    assert contact_law("ln_again").onset_velocity

    def run(law):
        r = nld.simulate("slider_crank", revs=0.2, rtol=1e-8, overrides={"joints.B.contact.law": law})
        assert r.status == 0
        return r.table[["B.ex", "B.ey", "B.Fn"]].to_numpy()

    ln = run("lankarani_nikravesh")
    assert np.array_equal(run("ln_again"), ln)
    assert np.abs(run("ln_twice") - ln).max() > 1e-6 * np.abs(ln).max()


def test_registry_checks_its_laws():
    from nld.laws.contact import hertz as hertz_module
    from nld.laws.law import ContactLaw, contact_law, contact_laws, register
    from nld.model.scene import load_scene
    from nld.errors import SceneError
    assert set(contact_laws()) >= {"hertz", "hertz_damped", "lankarani_nikravesh", "hunt_crossley",
                                   "flores", "gonthier"}
    assert contact_law("hertz") is hertz_module.LAW and contact_law("hertz").conservative
    assert contact_law("hertz_damped").jump_at_onset and not contact_law("hertz_damped").onset_velocity
    with pytest.raises(ValueError, match="extra argument 'speed'"):
        ContactLaw(name="x", force=hertz, extra=("speed",))
    with pytest.raises(ValueError, match="needs the unclamped force and the contact-mode force"):
        ContactLaw(name="x", force=hertz, jump_at_onset=True)
    with pytest.raises(ValueError, match="already registered"):
        register(ContactLaw(name="hertz", force=hertz))
    with pytest.raises(KeyError, match="known: "):
        contact_law("nope")
    with pytest.raises(SceneError, match="contact.law"):
        load_scene("slider_crank", overrides={"joints.B.contact.law": "nope"})
