"""The generated slider-crank kernel equals an independent hand derivation of the same mechanism.

``benchmarks/handwritten_slider_crank.py`` derives the equations of motion of
``nld/scenes/slider_crank.toml`` by hand (Newton-Euler for the rod about its crank pin, Newton for
the slider; the contact stiffness from the Hertz formula, not from nld). Here:

* at ~50 random states (free flight, grazing and penetrating contact up to 50 um, approaching and
  separating, stored and floored approach velocities, rod angles shifted by whole turns, times
  over three crank revolutions) both right-hand sides agree to 1e-10 relative;
* the comparison is sharp enough to fail: a relative change of 1e-6 in any one hand-written
  parameter (or 1e-6 rad in the crank phase) breaks the agreement;
* 0.3 crank revolutions at rtol 1e-9 through nld's dopri5 agree to 1e-7 relative in positions.
"""
from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from nld.kernel.compile import compile_scene
from nld.model.scene import load_scene
from nld.run.simulate import crank_period, initial_state, state_scales

ROOT = Path(__file__).resolve().parents[1]
RTOL_RHS = 1e-10
N_STATES = 50
HD_DAMPING = 400.0     # N s/m for the hertz_damped variant


def _load_hand():
    name = "handwritten_slider_crank"
    if name in sys.modules:
        return sys.modules[name]
    from nld.kernel.compile import drop_stale_numba_cache
    drop_stale_numba_cache(ROOT / "benchmarks" / f"{name}.py")
    spec = importlib.util.spec_from_file_location(name, ROOT / "benchmarks" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


H = _load_hand()

SCENES = {
    "lankarani_nikravesh": None,
    "hertz_damped": {"joints.B.contact.law": "hertz_damped", "joints.B.contact.damping": HD_DAMPING},
}


@pytest.fixture(scope="module", params=list(SCENES))
def setup(request):
    scene = load_scene("slider_crank", SCENES[request.param])
    kern = compile_scene(scene)
    return request.param, scene, kern, kern.params(scene), H.hand_params(scene)


def random_states(ph, n=N_STATES, seed=20240611):
    """(t, y, z) samples built from a chosen clearance vector e = P - B (slider minus journal).

    The eccentricity |e| = c + delta with delta in [-c, 50 um]; the journal lies on the rod's
    circle about the crank pin, which fixes the rod angle; phi is then shifted by whole turns
    (angle offsets) and the velocities are random, so penetration rates of both signs occur.
    """
    rng = np.random.default_rng(seed)
    a, L, c, w = ph[H.A_CRANK], ph[H.L_ROD], ph[H.CLEAR], ph[H.OMEGA]
    out = []
    for i in range(n):
        kind = i % 5
        if kind in (0, 1):
            delta = rng.uniform(1e-7, 50e-6)          # penetrating
        elif kind == 2:
            delta = 10.0 ** rng.uniform(-12, -8)      # grazing contact
        else:
            delta = -rng.uniform(0.0, c)              # free flight (or touching)
        t = rng.uniform(0.0, 3.0 * 2.0 * math.pi / abs(w))
        th = ph[H.THETA0] + w * t
        alpha = rng.uniform(0.0, 2.0 * math.pi)
        ex, ey = (c + delta) * math.cos(alpha), (c + delta) * math.sin(alpha)
        by = -ey                                       # the bearing centre is on the guide, y = 0
        psi = math.asin((by - a * math.sin(th)) / L)
        bx = a * math.cos(th) + L * math.cos(psi)
        phi = psi - th + 2.0 * math.pi * rng.integers(-2, 3)
        y = np.array([bx + ex, phi, rng.normal(0.0, 30.0), rng.normal(-w * 0.4, 400.0)])
        z = np.array([0.0 if i % 3 == 0 else rng.uniform(0.01, 3.0)])
        out.append((t, y, z))
    return out


def _zfull(kern, z, t=None, y=None, p=None):
    """The scene kernel's discrete state with the hand kernel's z[0] (other modes: their start).

    hertz_damped: the hand model's contact mode (z[0] > 0) clamps its force with max(F, 0), as
    the paper writes it. The kernel's contact mode does not: the clamp is a located event to its
    clamped mode z[0] < 0 (docs/contact-laws.md, "Modes"). So at a state whose unclamped force
    K max(d, 0)^n + C d' (the kernel's clamp event function) is negative the kernel is given the
    clamped mode, the mode it is in there on a trajectory."""
    zz = np.ones(kern.n_z)
    zz[0] = z[0]
    if y is not None and kern.z_layout.clamp and z[0] > 0.0:
        g = np.empty(kern.n_events)
        kern.module.events(t, y, p, zz, g)
        if g[kern.z_layout.ev_c[0]] < 0.0:
            zz[0] = -z[0]
    return zz


def _rhs_pair(kern, p, ph, t, y, z, hand_p=None):
    d_scene = np.empty(4)
    d_hand = np.empty(4)
    kern.module.rhs(t, y, p, _zfull(kern, z, t, y, p), d_scene)
    H.rhs(t, y, ph if hand_p is None else hand_p, z.copy(), d_hand)
    return d_scene, d_hand


def _max_rel(kern, p, ph, states, hand_p=None):
    worst = 0.0
    for t, y, z in states:
        ds, dh = _rhs_pair(kern, p, ph, t, y, z, hand_p)
        rel = np.abs(dh - ds) / np.maximum(np.abs(ds), 1e-3)   # 1e-3 m/s^2, rad/s^2: far below any term
        worst = max(worst, float(rel.max()))
    return worst


def test_states_cover_contact(setup):
    _, _, _, _, ph = setup
    states = random_states(ph)
    gaps = np.array([H._gap(t, y, ph)[0] for t, y, _ in states])
    forces = np.array([H.contact_force(t, y, ph, z)[0] for t, y, z in states])
    rates = np.array([H._gap(t, y, ph)[1] for t, y, _ in states])
    assert len(states) == N_STATES
    assert (gaps > 0).sum() >= 25 and gaps.max() <= 50e-6 * (1 + 1e-6)
    assert (forces > 0).sum() >= 10              # loaded contacts
    assert ((gaps > 0) & (forces == 0)).sum() >= 3   # separating fast enough for the clamp
    assert (rates > 0).any() and (rates < 0).any()


def test_rhs_equal_at_random_states(setup):
    law, _, kern, p, ph = setup
    states = random_states(ph)
    for t, y, z in states:
        ds, dh = _rhs_pair(kern, p, ph, t, y, z)
        rel = np.abs(dh - ds) / np.maximum(np.abs(ds), 1e-3)
        assert rel.max() <= RTOL_RHS, (law, t, y, z, ds, dh)


def test_stiffness_from_hertz_formula(setup):
    _, scene, kern, p, ph = setup
    # the scene vector carries nld's own stiffness; the hand value is from the formula
    assert ph[H.K_C] == pytest.approx(p[kern.layout.names.index("joints.B.contact.stiffness")], rel=1e-12)
    assert ph[H.K_C] == pytest.approx(6.6e10, rel=0.01)   # references.md section 4


@pytest.mark.parametrize("name", [n for n in H.PARAM_NAMES if n != "law"])
def test_comparison_can_fail(setup, name):
    """A 1e-6 change of any hand parameter that the law uses is seen by the comparison."""
    law, _, kern, p, ph = setup
    i = H.PARAM_NAMES.index(name)
    if (law == "lankarani_nikravesh" and name == "C") or (law == "hertz_damped" and name in ("cr", "v_min")):
        pytest.skip(f"{name} is not used by {law}")
    states = random_states(ph)
    bad = ph.copy()
    if bad[i] == 0.0:
        bad[i] = 1e-6 if name == "theta0" else 1e-6 * 9.81      # phase (rad) or gravity x (m/s^2)
    else:
        bad[i] *= 1.0 + 1e-6
    assert _max_rel(kern, p, ph, states) <= RTOL_RHS
    assert _max_rel(kern, p, ph, states, hand_p=bad) > 100 * RTOL_RHS, name


def test_events_agree(setup):
    _, _, kern, p, ph = setup
    g1 = np.empty(kern.n_events)
    g2 = np.empty(1)
    for t, y, z in random_states(ph):
        kern.module.events(t, y, p, _zfull(kern, z), g1)
        H.events(t, y, ph, z, g2)
        assert abs(g1[0] - g2[0]) <= 1e-15 + 1e-12 * abs(g2[0])
        for direction in (1, -1):
            z1, z2 = _zfull(kern, np.array([7.0])), np.array([7.0])
            kern.module.on_event(0, direction, t, y, p, z1)
            H.on_event(0, direction, t, y, ph, z2)
            assert z1[0] == pytest.approx(z2[0], rel=1e-10, abs=1e-14)


def run_pair(scene, kern, p, ph, revs=0.3, rtol=1e-9):
    """Both kernels through nld's dopri5 (each module's ``solve``) with simulate's arguments."""
    y0, z0, q = initial_state(kern)
    atol = rtol * state_scales(kern, q)
    per = crank_period(scene)
    t_eval = np.linspace(0.0, revs * per, int(round(revs * 360)) + 1)
    outs = []
    for mod, par, ne in ((kern.module, p, kern.n_events), (H, ph, 1)):
        z = z0.copy()
        out = mod.solve(0.0, y0.copy(), t_eval, False, par, z, rtol, atol, 0.0, per / 20.0,
                        50_000_000, ne, 200_000)
        assert out[0] == 0
        outs.append(out)
    return t_eval, outs


def _check_trajectories(scene, kern, p, ph):
    t_eval, (o_scene, o_hand) = run_pair(scene, kern, p, ph)
    Ys, Yh = o_scene[2], o_hand[2]
    assert np.isfinite(Ys).all() and np.isfinite(Yh).all()
    def contacts(o):      # events of the penetration function (hertz_damped adds its clamp events)
        return int((o[6][: o[8]] == 0).sum())
    assert contacts(o_scene) == contacts(o_hand) and contacts(o_hand) > 0   # same contact events
    for k in (0, 1):                                           # positions s (m), phi (rad)
        rel = np.abs(Ys[:, k] - Yh[:, k]).max() / np.abs(Ys[:, k]).max()
        assert rel <= 1e-7, (k, rel)
    eB = np.abs(H.journal_position(t_eval, Ys, ph) - H.journal_position(t_eval, Yh, ph)).max()
    assert eB <= 1e-3 * ph[H.CLEAR]


def test_trajectory_agrees():
    scene = load_scene("slider_crank")
    kern = compile_scene(scene)
    _check_trajectories(scene, kern, kern.params(scene), H.hand_params(scene))


@pytest.mark.slow
def test_trajectory_agrees_hertz_damped():
    scene = load_scene("slider_crank", SCENES["hertz_damped"])
    kern = compile_scene(scene)
    _check_trajectories(scene, kern, kern.params(scene), H.hand_params(scene))
