"""Non-smooth laws as hybrid modes (issue 14; docs/contact-laws.md, "Modes").

* Switched loads branch on the discrete state set at the located event (excavator at tight rtol).
* Coulomb stick/slip: a driven stick-slip scene whose stick and slip intervals, periodic orbit and
  friction work are known in closed form, matched to 1e-8.
* The smooth Ambrosio law converges to the hybrid Coulomb result as its velocity thresholds -> 0.
* hertz_damped contact as a mode: the force jump at onset happens at the located event.

The closed-form scene ("stick_slip_wheel"): a wheel (journal, radius Rj, inertia I) turns about a
fixed pivot at its centre inside a drum (bearing, radius Rb = Rj + c) driven at constant speed W
about its own centre; the centres are (c + d) apart, so the penetration d, the normal force
Fn = K d^1.5 and the contact point are constant and the slip velocity is vt = Rj w - Rb W exactly.
A torque T(t) = T0 tri(W t) (a triangle wave, the crank_table load) acts on the wheel:
    I w' = T(t) - Rj Ft,   Ft = mu Fn sign(vt) in slip, |Ft| <= mu_s Fn in stick (w = Wb = W Rb/Rj).
This is the belt-driven stick-slip oscillator of Leine & Nijmeijer (2004, sec. 5.3) with the
spring replaced by the prescribed torque: the scene model has no linear torsion spring (its spring
load acts between two points, which is not linear in an angle), so the oscillator with a spring
is not built as a scene. Starting in stick at t = 0 (w = Wb, T = 0):
    stick until T(t1) = mu_s Fn Rj;   slip+ until int_{t1}^{t2} (T - mu Fn Rj) dt = 0 (w = Wb again),
    stick (|T(t2)| <= mu_s Fn Rj) until T(t3) = -mu_s Fn Rj, slip- (the mirror image), ...
and, T being odd over a half period, the orbit is periodic from the start.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from nld.kernel.compile import compile_scene
from nld.model.scene import load_scene
from nld.run.simulate import simulate

W = 2.0 * math.pi          # rad/s, drum speed (period 1 s)
RJ, C, D = 0.05, 1e-4, 1e-5
K = 1e9                    # N/m^1.5
I_W = 1e-3                 # kg m^2
MU, MU_S, T0 = 0.25, 0.3, 0.6

WHEEL = f"""
[scene]
name = "stick_slip_wheel"
gravity = [0.0, 0.0]

[ground]
points = {{ O = [0.0, 0.0], P = [0.0, {-(C + D)!r}] }}

[bodies.drum]
mass = 1.0
inertia = 0.01
points = {{ O = [0.0, 0.0], C = [0.0, 0.0] }}

[bodies.wheel]
mass = 1.0
inertia = {I_W!r}
points = {{ P = [0.0, 0.0], J = [0.0, 0.0] }}

[joints.O]
type = "revolute"
bodies = ["drum", "ground"]
points = ["O", "O"]

[joints.P]
type = "revolute"
bodies = ["wheel", "ground"]
points = ["P", "P"]

[joints.J]
type = "revolute"
bodies = ["wheel", "drum"]
points = ["J", "C"]
clearance = {C!r}
journal_radius = {RJ!r}

[joints.J.contact]
law = "hertz"
stiffness = {K!r}
exponent = 1.5

[joints.J.friction]
law = "coulomb"
mu = {MU!r}
mu_s = {MU_S!r}

[driver]
joint = "O"
mode = "speed"
speed = {W!r}
angle0 = 0.0

[[loads]]
type = "torque"
body = "wheel"
value = {T0!r}
modulation = "crank_table"
table_angles = [0.0, {math.pi / 2!r}, {math.pi!r}, {3 * math.pi / 2!r}]
table_values = [0.0, 1.0, 0.0, -1.0]
"""


@pytest.fixture(scope="module")
def wheel_scene(tmp_path_factory):
    p = tmp_path_factory.mktemp("hybrid") / "stick_slip_wheel.toml"
    p.write_text(WHEEL, encoding="utf-8")
    return p


def closed_form():
    """Stick/slip switching times of the first period, slip energy and the orbit's constants."""
    rb = RJ + C
    fn = K * D ** 1.5
    fs, fk = MU_S * fn * RJ, MU * fn * RJ          # N m: static limit and kinetic friction torques
    wb = W * rb / RJ                               # rad/s: the wheel's speed in stick
    tq = math.pi / (2.0 * W)                       # s: a quarter period of T
    a = T0 / tq                                    # N m/s: slope of T
    t1 = fs / a                                    # T(t1) = fs on the rising quarter
    c0 = a * (tq * tq - t1 * t1) / 2.0 - fk * (tq - t1)   # int_{t1}^{tq} (T - fk)
    tau = ((T0 - fk) + math.sqrt((T0 - fk) ** 2 + 2.0 * a * c0)) / a
    t2 = tq + tau                                  # int_{t1}^{t2} (T - fk) = 0 on the falling quarter
    assert t1 < tq < t2 < 2 * tq and abs(T0 - a * tau) <= fs   # the regime the formulas assume
    t3 = t1 + 2 * tq                               # T(t3) = -fs
    t4 = t2 + 2 * tq
    # int_{t1}^{t2} u dt, u = (w - wb) = (1/I) int_{t1}^{t} (T - fk): exact polynomial integration
    P = np.polynomial.Polynomial
    rise = P([-fk, a])                             # T - fk on [t1, tq] (T = a t)
    fall = P([T0 + a * tq - fk, -a])               # T - fk on [tq, t2] (T = T0 - a (t - tq))
    u1 = rise.integ(lbnd=t1) / I_W
    u2 = (fall.integ(lbnd=tq) + u1(tq) * I_W) / I_W
    slip_angle = (u1.integ(lbnd=t1)(tq) + u2.integ(lbnd=tq)(t2))   # rad, beyond the stick speed
    u_max = u2((tq + (T0 - fk) / a))               # T = fk on the falling quarter
    return dict(t=[t1, t2, t3, t4], wb=wb, slip_angle=slip_angle, u_max=u_max, fk=fk, fs=fs,
                period=4 * tq, energy=2.0 * fk * slip_angle, t_peak=tq + (T0 - fk) / a)


def run_wheel(scene, y0, **kw):
    """simulate from (y0, modes of y0): the wheel's pivot is off the drum's centre, which the ideal
    assembly (clearance joints closed) cannot place, so the start state is given."""
    kern = compile_scene(scene)
    z0 = np.zeros(kern.n_z)
    kern.init_modes(0.0, y0, kern.params(scene), z0)
    return simulate(scene, y0=y0, z0=z0, kernel=kern, **kw)


def _switches(res, joint="J"):
    ev = res.events
    sel = ev[ev.joint.isin([f"{joint}.slip", f"{joint}.stick"])]
    return sel.t.to_numpy(), sel.joint.to_numpy(), sel.direction.to_numpy()


@pytest.fixture(scope="module")
def wheel_run(wheel_scene):
    scene = load_scene(str(wheel_scene))
    cf = closed_form()
    # start in stick: w = wb (init_modes finds vt = 0 and |T(0)| = 0 <= mu_s Fn Rj)
    # output every 1/4000 period and at the closed-form extrema of the slip speed
    grid = np.linspace(0.0, 3 * cf["period"], 12001)
    peaks = cf["t_peak"] + 0.5 * cf["period"] * np.arange(6)
    res = run_wheel(scene, np.array([0.0, cf["wb"]]), t_eval=np.union1d(np.union1d(grid, peaks), cf["t"][:2]),
                    rtol=1e-12, hmax=1e-3)
    assert res.success, res.message
    return scene, res, cf


def test_stick_slip_times_match_closed_form(wheel_run):
    _, res, cf = wheel_run
    t, kind, _ = _switches(res)
    # per period: stick->slip (stick margin), slip->stick (slip velocity), twice
    assert list(kind[:4]) == ["J.stick", "J.slip", "J.stick", "J.slip"]
    assert len(t) == 12
    expect = np.concatenate([np.array(cf["t"]) + k * cf["period"] for k in range(3)])
    np.testing.assert_allclose(t, expect, rtol=0, atol=1e-8 * cf["period"])


def test_stick_slip_orbit_and_friction_work(wheel_run):
    _, res, cf = wheel_run
    tab = res.table
    w = tab["wheel.omega"].to_numpy()
    u = w - cf["wb"]
    tt = tab["t"].to_numpy()
    # slip+ peak and slip- trough of the relative speed at the closed-form times, every half period
    pk = np.isin(tt, cf["t_peak"] + 0.5 * cf["period"] * np.arange(6))
    assert pk.sum() == 6
    np.testing.assert_allclose(u[pk], cf["u_max"] * np.array([1, -1] * 3), rtol=1e-8)
    assert np.abs(u).max() <= cf["u_max"] * (1 + 1e-9)
    # the orbit is periodic: the angle advances by wb * period every period (slip+ and slip-
    # angles cancel), and by wb (t2 - t1) + slip angle over the first slip
    ph = tab["wheel.theta"].to_numpy()
    k = [np.argmin(np.abs(tt - m * cf["period"])) for m in (0, 1, 2, 3)]
    np.testing.assert_allclose(np.diff(ph[k]), cf["wb"] * cf["period"], rtol=1e-9)
    i1, i2 = (int(np.argmin(np.abs(tt - x))) for x in cf["t"][:2])
    assert ph[i2] - ph[i1] == pytest.approx(cf["wb"] * (cf["t"][1] - cf["t"][0]) + cf["slip_angle"], rel=1e-8)
    # in stick the slip velocity is held at zero by the constraint
    t, _, _ = _switches(res)
    stick = (tt > t[1] + 1e-3) & (tt < t[2] - 1e-3)
    assert np.abs(tab["J.slip"].to_numpy()[stick]).max() < 1e-9 * RJ * cf["wb"]
    # the stick force follows T/Rj within the static limit
    ft = tab["J.Ft"].to_numpy()[stick]
    tq = tab["driver.angle"].to_numpy()[stick]
    tri = np.interp(tq % (2 * math.pi), [0, math.pi / 2, math.pi, 3 * math.pi / 2, 2 * math.pi], [0, 1, 0, -1, 0])
    np.testing.assert_allclose(ft, T0 * tri / RJ, rtol=1e-9, atol=1e-9 * T0 / RJ)
    assert np.abs(ft).max() <= cf["fs"] / RJ * (1 + 1e-9)


def test_friction_power_equals_energy_lost(wheel_run):
    """Over one period of the stick-slip orbit the friction work (the time integral of Ft vt from
    the observed columns) equals the closed-form 2 mu Fn Rj * (slip angle beyond the stick speed),
    and the energy balance closes: load work = friction work (kinetic energy is periodic)."""
    _, res, cf = wheel_run
    tab = res.table
    tt = tab["t"].to_numpy()
    sel = (tt >= cf["period"] - 1e-12) & (tt <= 2 * cf["period"] + 1e-12)
    from scipy.integrate import simpson
    fric = simpson(tab["J.Ft"].to_numpy()[sel] * tab["J.slip"].to_numpy()[sel], x=tt[sel])
    assert fric == pytest.approx(cf["energy"], rel=1e-5)
    tq = tab["driver.angle"].to_numpy()[sel]
    tri = np.interp(tq % (2 * math.pi), [0, math.pi / 2, math.pi, 3 * math.pi / 2, 2 * math.pi], [0, 1, 0, -1, 0])
    load_work = simpson(T0 * tri * tab["wheel.omega"].to_numpy()[sel], x=tt[sel])
    # the wheel's work done by the load and by friction (on the wheel: -Rj Ft w) sum to zero
    wheel_fric = simpson(-RJ * tab["J.Ft"].to_numpy()[sel] * tab["wheel.omega"].to_numpy()[sel], x=tt[sel])
    # (Simpson on the 1/4000-period grid across the kinks of w at the switches: 1e-4 measured)
    assert load_work + wheel_fric == pytest.approx(0.0, abs=1e-3 * abs(load_work))


def test_ambrosio_converges_to_hybrid(wheel_scene):
    """The smooth Ambrosio law (no stiction: it is the mu_s = mu case) approaches the hybrid Coulomb
    solution as its thresholds v0 < v1 -> 0: the error at the end of one period falls with v1."""
    base = load_scene(str(wheel_scene), ["joints.J.friction.mu_s=0.25"])
    cf = closed_form()
    y0 = np.array([0.0, cf["wb"]])
    ref = run_wheel(base, y0, t_end=cf["period"], rtol=1e-11, samples_per_rev=200)
    assert ref.success, ref.message
    errs = []
    for v1 in (1e-3, 1e-4, 1e-5):
        sc = load_scene(str(wheel_scene), ["joints.J.friction.law=ambrosio", "joints.J.friction.mu_s=0.25",
                                           f"joints.J.friction.v0={v1 / 10!r}", f"joints.J.friction.v1={v1!r}"])
        r = run_wheel(sc, y0, t_end=cf["period"], rtol=1e-10, samples_per_rev=200)
        assert r.success, r.message
        errs.append(float(np.abs(r.table["wheel.omega"] - ref.table["wheel.omega"]).max()))
    assert errs[2] < errs[1] < errs[0]
    assert errs[2] < 0.02 * errs[0]


def test_hertz_damped_force_jumps_only_at_events():
    """hertz_damped: the normal force is zero in free mode and starts at C*ddot0 at the located
    onset; the contact column and the mode agree at every output (no contact force before the
    event)."""
    res = simulate("slider_crank", revs=2, rtol=1e-8, samples_per_rev=2000,
                   overrides=["joints.B.contact.law=hertz_damped", "joints.B.contact.damping=400"])
    assert res.success, res.message
    ev = res.events
    assert (ev.joint == "B").sum() > 4
    fn = res.table["B.Fn"].to_numpy()
    pen = res.table["B.penetration"].to_numpy()
    assert np.all(fn[pen < -1e-12] == 0.0)
    # contact mode runs the unclamped force (smooth inside a step); the clamp at F = 0 is a located
    # event, so no output carries an adhesive pull (a missed clamp would show one of kN)
    assert (ev.joint == "B.clamp").sum() > 4
    assert fn.min() >= -1e-6 * fn.max(), (fn.min(), fn.max())


def test_hertz_damped_contact_mode_keeps_damping_at_the_onset():
    """In contact mode the force is C*ddot at delta <= 0 (the located onset state has |delta| ~
    1e-12 m of either sign), the law's own value for delta > 0 while it is positive, and not
    clamped: the clamp is the located mode change (a kink inside a step cost rejections)."""
    from nld.laws.contact.hertz_damped import hertz_damped, hertz_damped_contact
    K, n, C = 1e10, 1.5, 400.0
    assert hertz_damped_contact(-1e-13, 2.0, K, n, C) == C * 2.0
    assert hertz_damped(-1e-13, 2.0, K, n, C) == 0.0
    for d, v in ((1e-6, 0.5), (1e-6, -0.01)):
        assert hertz_damped_contact(d, v, K, n, C) == hertz_damped(d, v, K, n, C) > 0.0
    assert hertz_damped(3e-7, -2.0, K, n, C) == 0.0          # the law clamps ...
    assert hertz_damped_contact(-1e-13, -2.0, K, n, C) == -C * 2.0
    assert hertz_damped_contact(1e-9, -2.0, K, n, C) == K * 1e-9**1.5 - C * 2.0 < 0.0


def test_hertz_damped_error_comparable_to_ln():
    """slider_crank at rtol 1e-8 over 0.25 revolution: the journal error of hertz_damped (to its own
    run at rtol 1e-12) within 20x LN's. With hertz_damped() (0 at delta <= 0) in contact mode, the
    onset state's delta of either sign put a jump of C*ddot0 inside the first step after the onset
    that DOPRI5's error estimate hardly sees: 280x LN's (benchmarks/results/hybrid.md); after the
    fix 8x, about the 7x greater sensitivity of the hertz_damped trajectory to its initial
    velocities (measured)."""
    def err(ov):
        kw = dict(revs=0.25, samples_per_rev=4000, overrides=ov)
        ref, r = simulate("slider_crank", rtol=1e-12, **kw), simulate("slider_crank", rtol=1e-8, **kw)
        d = np.hypot(r.table["B.ex"].to_numpy() - ref.table["B.ex"].to_numpy(),
                     r.table["B.ey"].to_numpy() - ref.table["B.ey"].to_numpy())
        return d.max() / 0.5e-3          # / clearance
    e_ln = err([])
    e_hd = err(["joints.B.contact.law=hertz_damped", "joints.B.contact.damping=400"])
    assert e_hd < 20 * e_ln, (e_hd, e_ln)


def test_hertz_damped_contacts_do_not_cascade_rejections():
    """slider_crank hertz_damped, 0.25 revolution (10 contacts) at rtol 1e-8. Until stop 20 every
    contact cost DOP853 6-12 rejections at the onset (the first step starts at the free-flight size
    and shrank at most 3x per try, as err^(1/8), while the error after an onset falls like h^~4)
    and 4-7 at the clamp (a kink inside the step: the contact mode clamped its force): 159
    rejected for 181 accepted; dopri5 76 for 381. Now a rejected first step after a mode change
    shrinks as O(h^4), and the contact mode runs the unclamped force (the clamp is located)."""
    ov = ["joints.B.contact.law=hertz_damped", "joints.B.contact.damping=400"]
    for method, share in (("dop853", 0.35), ("dopri5", 0.10)):
        r = simulate("slider_crank", revs=0.25, rtol=1e-8, samples_per_rev=8, method=method,
                     overrides=ov)
        assert r.success, r.message
        assert (r.events.joint == "B").sum() >= 16
        assert r.stats["rejected"] < share * r.stats["accepted"], (method, r.stats)


def test_free_mode_clamp_event_and_scene_tolerances():
    """Two shortcuts of stop 21 give what they replace: (a) the kernel's events() skips the clamp
    force in free mode, where the clamp function is sigma * 1 (inactive), and computes it in the
    contact and clamped modes (sigma * F, sigma * -F); (b) SceneSystem.tolerance keeps the state
    scales and equals nld.run.simulate.tolerances (which walks the geometry every call)."""
    from nld.run.simulate import initial_state, tolerances
    from nld.systems.core import SceneSystem
    S = SceneSystem("slider_crank", ["joints.B.contact.law=hertz_damped", "joints.B.contact.damping=400"])
    kern = S.kernel
    y0, z0, q = initial_state(kern)
    zl = kern.z_layout
    ci = zl.clamp[0]
    g = np.empty(kern.n_events)
    y = y0.copy()
    y[0] += 0.3e-3                                # the journal off centre (ecc > 0) ...
    y[2] += 3.0                                   # ... and a slider velocity: ddot != 0
    vals = {}
    for mode in (0.0, 1.0, -1.0):
        z = z0.copy()
        z[ci] = mode
        z[zl.sig_c[ci]] = -1.0
        kern.module.events(0.0, y, S.p, z, g)
        vals[mode] = g[zl.ev_c[ci]]
    assert vals[0.0] == -1.0
    assert vals[1.0] == -vals[-1.0] != 0.0
    for rtol in (1e-6, 1e-9):
        assert np.array_equal(S.tolerance(rtol), tolerances(kern, q, rtol))


# ------------------------------------------------------------------ switched loads
def _excavator_ambrosio(revs, rtol, **kw):
    return simulate("excavator", revs=revs, rtol=rtol, samples_per_rev=10,
                    overrides=["joints.A.friction.law=ambrosio", "joints.B.friction.law=ambrosio"], **kw)


def test_excavator_switched_load_tight_rtol():
    """Before issue 14 the crank-halves load branched on q mod 2 pi < pi while its event was sin(q):
    at rtol 1e-11 this run stopped with a step-size underflow at t = 2.62 s (6.5 revolutions)."""
    res = _excavator_ambrosio(8, 1e-11)
    assert res.success, res.message
    ev = res.events
    assert (ev.joint == "load0").sum() >= 15          # two switches per revolution, all located


@pytest.mark.slow
def test_excavator_switched_load_1000_revolutions():
    """Before issue 14: step-size underflow at t = 17.7 s (44 revolutions) at rtol 1e-10.

    Stop 19: with the default max_steps (5e7) the run reached t = 174.9 s (434 revolutions) without an
    underflow and stopped at the step limit (about 1.15e5 steps per revolution), so the limit is
    raised here; with it the 1000 revolutions pass (186 s on the 2-core development machine)."""
    res = _excavator_ambrosio(1000, 1e-10, max_steps=200_000_000)
    assert res.success, res.message


# ------------------------------------------------------------------ excavator Coulomb cost
def test_excavator_coulomb_no_chatter():
    """One revolution at rtol 1e-7: Coulomb f = 0.1 (stick/slip modes) within 3x the steps of f = 0
    (the sign law integrated as smooth took > 5e7 steps)."""
    def run(mu):
        return simulate("excavator", revs=1, rtol=1e-7, samples_per_rev=10,
                        overrides=[f"joints.A.friction.mu={mu}", f"joints.B.friction.mu={mu}"])
    r0, r1 = run(0.0), run(0.1)
    assert r0.success and r1.success, (r0.message, r1.message)
    assert r1.stats["steps"] <= 3 * r0.stats["steps"]
    ev = r1.events
    assert ev.joint.str.endswith(".stick").any()      # the stick mode is used


# ------------------------------------------------------------------ tangent dynamics
def test_tangent_vector_matches_finite_differences_through_stick_slip(wheel_scene):
    """The tangent integrator's w(t1) equals the central difference of two of nld's trajectories
    from t = 0.3 s (slip+) to 1.3 s, through slip -> stick (the saltation projects onto the stick
    manifold: the slip-speed perturbation vanishes, the angle keeps the time shift), stick -> slip-,
    slip- -> stick and stick -> slip+ (generated events_jvp / on_event_jvp through the stick
    multiplier's solve)."""
    from nld.systems.core import SceneSystem, advance
    from nld.systems.tangent import diag_dict, run_tangent
    cf = closed_form()
    S = SceneSystem(load_scene(str(wheel_scene)), y0=[0.0, cf["wb"]])
    t0, t1 = 0.3, 1.3
    y, z = advance(S, S.y0, S.z0, 0.0, t0, 1e-12)
    v = np.array([0.3, 1.0]) * S.scales
    r = run_tangent(S, y, z, v[None, :], np.zeros((1, z.size)), t0, [t1], 1e-12)
    w = math.exp(r.logs[0, 0]) * r.W[0]
    assert diag_dict(r.diag)["saltations"] >= 4
    # not smaller: in stick the slip speed keeps the residual it had at the located event
    # (~ its rate x the root tolerance, 1e-11 m/s), which differs between the two runs and
    # would dominate a difference quotient with eps = 1e-6 (error 4e-2 measured)
    # The residuals themselves make the difference quotient scatter: measured relative errors
    # 7e-10 ... 2.3e-5 over eps 1e-3, 3e-3, 1e-2 and event_samples 0, 3, 8, while w is the same
    # to 1e-8 for every sampling. Asserted: the best of the three within 1e-5, all within 5e-5.
    errs = []
    for eps in (1e-3, 3e-3, 1e-2):
        yp, _ = advance(S, y + eps * v, z.copy(), t0, t1, 1e-13)
        ym, _ = advance(S, y - eps * v, z.copy(), t0, t1, 1e-13)
        fd = (yp - ym) / (2 * eps)
        errs.append(np.linalg.norm((fd - w) / S.scales) / np.linalg.norm(w / S.scales))
    assert min(errs) < 1e-5 and max(errs) < 5e-5, (w, errs)
    assert abs(w[1]) < 1e-9 * S.scales[1]          # the slip-speed perturbation: projected out


# ------------------------------------------------------------------ both laws: energy and ideal limit
BOTH = ["joints.A.contact.law=hertz_damped", "joints.A.contact.damping=300",
        "joints.A.friction.law=coulomb", "joints.A.friction.mu=0.1", "joints.A.friction.mu_s=0.15",
        "joints.B.friction.law=ambrosio", "joints.B.friction.mu=0.1"]


def test_both_laws_power_balance():
    """hertz_damped + hybrid Coulomb at A, LN + Ambrosio at B: driver power + load power (with the
    contact damping and friction power) = d(total energy)/dt, as test_simulator's balance."""
    r = simulate("slider_crank_two", revs=0.5, rtol=1e-11, samples_per_rev=20000, overrides=BOTH)
    assert r.success, r.message
    tb = r.table
    assert (r.events.joint == "A").sum() >= 2
    t = tb.t.to_numpy()
    E = tb["energy.total"].to_numpy()
    P = (tb["power.driver"] + tb["power.loads"]).to_numpy()
    work = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(t))])
    scale = np.abs(P).max() * (t[-1] - t[0])
    assert np.abs((E - E[0]) - work).max() < 2e-3 * scale


def test_hybrid_coulomb_tends_to_ideal():
    """With hybrid Coulomb friction the slider approaches the ideal kinematics as the clearance
    shrinks (test_simulator's ideal-limit check)."""
    from nld.model.ideal import ideal_solution
    errs = []
    for c in (5e-4, 2e-5):
        ov = [f"joints.B.clearance={c}", "driver.speed=100.0", "joints.B.friction.law=coulomb",
              "joints.B.friction.mu=0.1", "joints.B.friction.mu_s=0.12"]
        r = simulate("slider_crank", revs=1, rtol=1e-7, overrides=ov)
        assert r.success, r.message
        ref = ideal_solution(load_scene("slider_crank", ["driver.speed=100.0"]), r.table.t.to_numpy())
        errs.append(np.abs(r.table["slider.x"].to_numpy() - ref["slider.x"].to_numpy()).max())
    assert errs[0] < 2 * 5e-4
    assert errs[1] < errs[0] / 5


def test_mode_code_only_for_the_laws_a_scene_has():
    """Events, z entries and stick rows are generated only for the laws and loads a scene has."""
    k = compile_scene(load_scene("slider_crank"))            # LN, no friction, no switched load
    src = k.source_path.read_text()
    assert k.n_events == 1 and k.n_z == 1
    assert "Jt0_" not in src and "def init_modes" in src
    off = compile_scene(load_scene("excavator", ["joints.A.friction.mu=0", "joints.B.friction.mu=0"]))
    # 2 penetrations, 2 switched loads, 2 hertz_damped clamps; no friction code at all
    assert off.n_events == 6 and off.z_layout.event_names[2:4] == ["load0", "load1"]
    assert "Jt0_" not in off.source_path.read_text() and "coulomb(" not in off.source_path.read_text().split("def rhs")[1].split("def events")[0]
    on = compile_scene(load_scene("excavator"))               # Coulomb f = 0.01 at A and B
    assert on.n_events == 10 and on.n_z == off.n_z + 8
    assert on.z_layout.event_names[4:8] == ["A.slip", "A.stick", "B.slip", "B.stick"]


# ------------------------------------------------------------------ stick/slip chatter corner
# r1 = r2 = 0.01 mm (and 0.02 mm), f = 0.01: both journals in permanent contact (Fn ~ 6 kN), the
# rod pin B switching stick <-> slip ~170 times a revolution around its relative-rotation
# reversals. Before a51d484 (slip event on s (vt - vt0)) the run stopped at the step cap at
# t = 0.455 s (r = 0.01 mm, rtol 1e-5) and t = 0.432 s (0.02 mm, rtol 1e-7): B.slip fired at every
# step at one instant with alternating direction (a slip reversal whose new slip-velocity function
# started on the wrong side by the round-off residual of v_t; benchmarks/results/hybrid.md,
# "Stick/slip chatter at small clearance").
_CORNER_REVS = 1.5
# a stick/slip transition needs a zero crossing of v_t; v_t oscillates at most at the contact
# vibration frequency (k = 1.5 Fn / delta ~ 1.4e9 N/m on ~1 kg: ~6 kHz, 2 crossings a period, ~5e3
# per revolution if v_t hovered at zero all revolution); measured ~230 events per revolution at
# rtol 1e-5 ... 1e-9; chatter gives one per step (2e4 - 2e5 per revolution)
_CORNER_EVENTS_PER_REV = 1000


def _corner(r, rtol):
    return simulate("excavator", revs=_CORNER_REVS, rtol=rtol, samples_per_rev=360, max_steps=400_000,
                    overrides=[f"joints.A.clearance={r}", f"joints.B.clearance={r}",
                               "joints.A.friction.mu=0.01", "joints.B.friction.mu=0.01"])


@pytest.fixture(scope="module")
def corner_reference():
    return {r: _corner(r, 1e-9) for r in (1e-5, 2e-5)}


@pytest.mark.parametrize("r, rtol, ecc_tol", [(1e-5, 1e-5, 0.5), (1e-5, 1e-6, 0.25), (2e-5, 1e-7, 0.05)])
def test_excavator_small_clearance_no_stick_slip_chatter(corner_reference, r, rtol, ecc_tol):
    """The chatter corner finishes with a bounded number of events, no mode lasting zero time, and
    the trajectory of a tight tolerance (journal eccentricities within ecc_tol clearances; measured
    0.20 / 0.11 / 0.002 c against rtol 1e-9). Fails before a51d484: the first and third stop at
    the step cap (max_steps 400 000) at t = 0.455 s and 0.432 s."""
    res, ref = _corner(r, rtol), corner_reference[r]
    assert res.success and ref.success, (res.message, ref.message)
    ev = res.events
    assert len(ev) <= _CORNER_EVENTS_PER_REV * _CORNER_REVS, len(ev)
    assert res.stats["events"] <= 0.05 * res.stats["steps"], res.stats
    fr = ev[ev.joint.str.endswith((".slip", ".stick"))]
    assert len(fr) > 50                                   # the stick/slip switching is there
    for _, g in fr.groupby(fr.joint.str.split(".").str[0]):
        assert np.diff(g.t.to_numpy()).min() > 0.0       # no stick -> slip -> stick at one instant
    # the same switching as the reference: stick/slip transitions within 20 %
    n, n_ref = len(fr), ref.events.joint.str.endswith((".slip", ".stick")).sum()
    assert abs(n - n_ref) <= 0.2 * n_ref, (n, n_ref)
    for c in ("A.eccentricity", "B.eccentricity"):
        err = np.abs(res.table[c].to_numpy() - ref.table[c].to_numpy()).max()
        assert err <= ecc_tol * r, (c, err / r)
    assert np.abs(res.table["cutter.theta"].to_numpy() - ref.table["cutter.theta"].to_numpy()).max() < 5e-5
