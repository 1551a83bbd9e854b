"""Hand-written right-hand side of the Flores slider-crank with a clearance at the rod-slider joint.

An independent derivation of the equations of motion of ``nld/scenes/slider_crank.toml``, written
by hand (not generated, not copied from the generated kernel), used two ways:

* ``tests/test_handwritten_equivalence.py`` checks that the scene kernel that nld generates gives
  the same accelerations (to 1e-10 relative) and the same trajectories;
* ``benchmarks/bench_simulator.py`` times it against the generated kernel through the same
  integrator (the "how much does generality cost" number).

Model and derivation
--------------------
Crank O-A (length a), pivoted at the ground origin O, prescribed angle theta = theta0 + w t
(constant speed, so no crank angular acceleration). Connecting rod A-B: pin A on the crank (ideal),
centre of mass G on the segment AB at distance d from A, journal centre B at distance L from A,
mass m2, inertia J2 about G. Slider: mass m3, bearing centre P = (s, 0) on an ideal guide along
the global x axis through O. Radial clearance c between the rod journal and the slider bearing.

State y = [s, phi, s_dot, phi_dot]; phi is the rod angle relative to the crank, so the rod's
absolute angle is psi = theta + phi, psi_dot = w + phi_dot, psi_ddot = phi_ddot.

Unit vectors e_t = (cos theta, sin theta), e_p = (cos psi, sin psi), e_p' = (-sin psi, cos psi).
Kinematics:  r_A = a e_t, a_A = -a w^2 e_t;  r_G = r_A + d e_p;  r_B = r_A + L e_p,
             v_B = v_A + L psi_dot e_p'.
Clearance vector (slider bearing centre minus rod journal centre) e = P - r_B, e_dot = (s_dot, 0) - v_B;
eccentricity |e|, normal n = e/|e|, penetration delta = |e| - c, penetration rate
delta_dot = e_dot . n (> 0 approaching). Contact force F >= 0: on the rod +F n (pushes the journal
back towards the bearing centre), on the slider -F n.

Slider (Newton along the guide; the guide takes the normal reaction and the weight):
    m3 s_ddot = -F n_x + m3 g_x.
Rod (Newton-Euler, pin force F_A from the crank eliminated):
    m2 a_G = F_A + m2 g + F n,   J2 psi_ddot = (r_A - r_G) x F_A + (r_B - r_G) x F n,
with a_G = a_A + d psi_ddot e_p' - d psi_dot^2 e_p and u x v = u_x v_y - u_y v_x. Substituting
F_A = m2 a_G - m2 g - F n and e_p x e_p' = 1, e_p x e_p = 0:
    (J2 + m2 d^2) psi_ddot = m2 d e_p x (g - a_A) + L e_p x (F n).
This is the moment balance about the moving pin A; the crank's own mass and inertia do not enter
(its motion is prescribed).

Contact laws (docs/contact-laws.md; references.md section 4):
    law 0, Lankarani-Nikravesh:  F = K delta^n (1 + 3 (1 - cr^2) / 4 * delta_dot / v_minus),
           v_minus = z[0] (approach velocity stored at onset by ``on_event``) or, if z[0] <= 0,
           the floor v_min;
    law 1, Hertz with linear damping:  F = K delta^n + C delta_dot, applied only in contact mode
           (z[0] > 0, set at the located onset: the jump C delta_dot happens at the event);
both clamped at F >= 0 and zero for delta <= 0. K is the journal-in-bearing Hertz stiffness
K = 4 / (3 (sigma_1 + sigma_2)) sqrt(R_J R_B / (R_B - R_J)), sigma = (1 - nu^2) / E, R_B = R_J + c,
computed here from the scene's Young's moduli and Poisson ratios (not taken from nld).

Event: g = |e| - c (contact onset when it rises through 0, loss when it falls through 0). At onset
``on_event`` stores z[0] = max(delta_dot, v_min); at loss z[0] = 0.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from nld.integrators.dopri5 import dopri5

# indices of the hand-written parameter vector p_hand
A_CRANK, D_ROD, L_ROD, M_ROD, J_ROD, M_SLIDER, GX, GY, OMEGA, THETA0, CLEAR, K_C, N_EXP, CR, V_MIN, C_DAMP, LAW = range(17)
N_PARAMS = 17
LAW_CODES = {"lankarani_nikravesh": 0.0, "hertz_damped": 1.0}
PARAM_NAMES = ("a", "d", "L", "m2", "J2", "m3", "gx", "gy", "omega", "theta0", "c", "K", "n", "cr",
               "v_min", "C", "law")


@njit(cache=True, fastmath=False)
def rhs(t, y, p, z, dy):
    """dy/dt of y = [s, phi, s_dot, phi_dot] (see the module docstring for the derivation)."""
    a = p[0]
    L = p[2]
    w = p[8]
    th = p[9] + w * t
    ct = math.cos(th)
    st = math.sin(th)
    psi = th + y[1]
    cp = math.cos(psi)
    sp = math.sin(psi)
    psid = w + y[3]
    # journal centre B on the rod and its velocity
    bx = a * ct + L * cp
    by = a * st + L * sp
    vbx = -a * w * st - L * psid * sp
    vby = a * w * ct + L * psid * cp
    # clearance vector: slider bearing centre (s, 0) minus journal centre
    ex = y[0] - bx
    ey = -by
    ecc = math.sqrt(ex * ex + ey * ey)
    fx = 0.0      # contact force on the rod (the slider gets -f)
    fy = 0.0
    delta = ecc - p[10]
    # law 1: contact is a mode, z[0] > 0 from the located onset to the located loss (issue 14);
    # in the mode the damping C ddot acts also at delta <= 0 (the located onset has delta = 0 only
    # to the root tolerance: docs/contact-laws.md, "Modes")
    if (p[16] == 0.0 and delta > 0.0) or (p[16] != 0.0 and z[0] > 0.0 and ecc > 0.0):
        nx = ex / ecc
        ny = ey / ecc
        ddot = (y[2] - vbx) * nx - vby * ny
        if p[16] == 0.0:
            dn = delta ** p[12]
            vm = z[0] if z[0] > 0.0 else p[14]
            f = p[11] * dn * (1.0 + 0.75 * (1.0 - p[13] * p[13]) * ddot / vm)
        else:
            f = p[15] * ddot
            if delta > 0.0:
                f += p[11] * delta ** p[12]
        if f > 0.0:
            fx = f * nx
            fy = f * ny
    # slider along the x guide
    s_dd = p[6] - fx / p[5]
    # rod: moment balance about the moving crank pin A (a_A = -a w^2 e_t)
    m2d = p[3] * p[1]
    gax = p[6] + a * w * w * ct
    gay = p[7] + a * w * w * st
    psi_dd = (m2d * (cp * gay - sp * gax) + L * (cp * fy - sp * fx)) / (p[4] + m2d * p[1])
    dy[0] = y[2]
    dy[1] = y[3]
    dy[2] = s_dd
    dy[3] = psi_dd


@njit(cache=True)
def _gap(t, y, p):
    """(|e| - c, delta_dot) at state y."""
    a = p[0]
    L = p[2]
    w = p[8]
    th = p[9] + w * t
    psi = th + y[1]
    psid = w + y[3]
    ex = y[0] - a * math.cos(th) - L * math.cos(psi)
    ey = -a * math.sin(th) - L * math.sin(psi)
    dex = y[2] + a * w * math.sin(th) + L * psid * math.sin(psi)
    dey = -a * w * math.cos(th) - L * psid * math.cos(psi)
    ecc = math.sqrt(ex * ex + ey * ey)
    ddot = (dex * ex + dey * ey) / ecc if ecc > 0.0 else 0.0
    return ecc - p[10], ddot


@njit(cache=True)
def events(t, y, p, z, g):
    g[0] = _gap(t, y, p)[0]


@njit(cache=True)
def on_event(k, direction, t, y, p, z):
    if direction > 0:
        z[0] = max(_gap(t, y, p)[1], p[14])
    else:
        z[0] = 0.0
    return 0


def solve(t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps, n_events, max_log):
    """nld's dopri5 on this kernel, called as the generated kernels' ``solve`` calls it (the
    integrator compiled once, these functions passed as first-class function arguments)."""
    return dopri5(rhs, events, on_event, t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax,
                  max_steps, n_events, max_log)


@njit(cache=True)
def contact_force(t, y, p, z):
    """Normal contact force F (N) and penetration delta (m) at state y (for error measures)."""
    a = p[0]
    L = p[2]
    w = p[8]
    th = p[9] + w * t
    psi = th + y[1]
    psid = w + y[3]
    ex = y[0] - a * math.cos(th) - L * math.cos(psi)
    ey = -a * math.sin(th) - L * math.sin(psi)
    ecc = math.sqrt(ex * ex + ey * ey)
    delta = ecc - p[10]
    if delta <= 0.0 or (p[16] != 0.0 and z[0] <= 0.0):
        return 0.0, delta
    dex = y[2] + a * w * math.sin(th) + L * psid * math.sin(psi)
    dey = -a * w * math.cos(th) - L * psid * math.cos(psi)
    ddot = (dex * ex + dey * ey) / ecc
    dn = delta ** p[12]
    if p[16] == 0.0:
        vm = z[0] if z[0] > 0.0 else p[14]
        f = p[11] * dn * (1.0 + 0.75 * (1.0 - p[13] * p[13]) * ddot / vm)
    else:
        f = p[11] * dn + p[15] * ddot
    return max(f, 0.0), delta


def journal_position(t, y, p):
    """World position (x, y) of the rod's journal centre B for rows y (array n x 4) at times t (m)."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    th = p[THETA0] + p[OMEGA] * t
    psi = th + y[:, 1]
    return np.stack([p[A_CRANK] * np.cos(th) + p[L_ROD] * np.cos(psi),
                     p[A_CRANK] * np.sin(th) + p[L_ROD] * np.sin(psi)], axis=1)


def hertz_stiffness(R_journal, clearance, E1, nu1, E2, nu2):
    """Journal-in-bearing Hertz stiffness (N/m^1.5), R_bearing = R_journal + clearance."""
    s = (1.0 - nu1 * nu1) / E1 + (1.0 - nu2 * nu2) / E2
    Rb = R_journal + clearance
    return 4.0 / (3.0 * s) * math.sqrt(R_journal * Rb / (Rb - R_journal))


def hand_params(scene) -> np.ndarray:
    """p_hand of a slider-crank scene with the layout of nld/scenes/slider_crank.toml.

    Reads the lengths, masses, gravity, crank speed and contact data from the Scene object and
    refuses (ValueError) any scene whose geometry this hand derivation does not cover.
    """
    def need(cond, what):
        if not cond:
            raise ValueError(f"hand-written slider-crank does not cover this scene: {what}")

    cr_, rod, sl = scene.bodies["crank"], scene.bodies["rod"], scene.bodies["slider"]
    jO, jA, jB, jS = (scene.joints[k] for k in ("O", "A", "B", "S"))
    need(np.allclose(scene.ground_points["O"], 0.0) and np.allclose(scene.ground_points["G"], 0.0),
         "ground points O and G at the origin")
    need(tuple(jS.axis) == (1.0, 0.0), "guide along x")
    need(np.allclose(sl.points["B"], sl.points["S"]), "slider bearing centre at the sliding point")
    need(jO.clearance == 0.0 and jA.clearance == 0.0 and jB.clearance > 0.0, "only B has clearance")
    need(jB.friction.law == "none" or jB.friction.mu == 0.0, "no friction")
    need(jB.friction.tangential_damping == 0.0, "no tangential damping")
    need(not scene.loads, "no loads")
    need(scene.driver is not None and scene.driver.mode == "speed" and scene.driver.joint == "O",
         "speed-driven crank at O")
    oa = np.subtract(cr_.points["A"], cr_.points["O"])
    need(abs(oa[1]) == 0.0 and oa[0] > 0.0, "crank points O, A on the crank's +x axis")
    ab = np.subtract(rod.points["B"], rod.points["A"])
    need(abs(ab[1]) == 0.0 and ab[0] > 0.0 and rod.points["A"][1] == 0.0,
         "rod points A, G, B on the rod's +x axis")
    c = scene.joints["B"].contact
    need(c.law in LAW_CODES, f"contact law {c.law!r}")
    p = np.zeros(N_PARAMS)
    p[A_CRANK] = oa[0]
    p[D_ROD] = -rod.points["A"][0]
    p[L_ROD] = ab[0]
    p[M_ROD] = rod.mass
    p[J_ROD] = rod.inertia
    p[M_SLIDER] = sl.mass
    p[GX], p[GY] = scene.gravity
    p[OMEGA] = scene.driver.speed
    p[THETA0] = scene.driver.angle0
    p[CLEAR] = jB.clearance
    p[K_C] = c.stiffness if c.stiffness is not None else hertz_stiffness(
        jB.journal_radius, jB.clearance, c.young[0], c.poisson[0], c.young[1], c.poisson[1])
    p[N_EXP] = c.exponent
    p[CR] = c.restitution
    p[V_MIN] = c.min_approach_velocity
    p[C_DAMP] = c.damping
    p[LAW] = LAW_CODES[c.law]
    return p
