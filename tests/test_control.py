"""Chaos control (issue 26, generic part): the delay integrator (nld.integrators.delay) against the
method-of-steps closed form and its order; Pyragas / EDFC on the Rössler system; OGY on the Hénon
map; Nakajima's odd-number verdict; the one-line input errors. docs/control.md."""
from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from nld.analysis import control as C
from nld.errors import InputError
from nld.integrators.delay import STATE, DelayLaw, dde, sampled_history
from nld.systems.core import henon

# Pyragas 1992's setting: Rössler a = b = 0.2, c = 5.7, control on y, K = 0.2. tau: the period of
# the period-1 UPO, 5.8810884556 as found by periodic_orbit on the Poincaré map x = 0, x' > 0
# (test_pyragas_rossler_upo_slow recomputes it and compares the controlled motion with the UPO).
TAU_ROSSLER = 5.88


@njit(cache=True)
def zero_rhs(t, y, p, z, dy):
    for i in range(y.shape[0]):
        dy[i] = 0.0


@njit(cache=True)
def half_event(t, y, p, z, g):
    g[0] = y[0] - 0.5


@njit(cache=True)
def count_event(k, direction, t, y, p, z):
    z[0] += 1.0
    return 0


@njit(cache=True)
def unit_rhs(t, y, p, z, dy):
    dy[0] = 1.0


@njit(cache=True)
def level_event(t, y, p, z, g):
    g[0] = y[0] - p[0]


def steps_closed_form(t: float) -> float:
    """y'(t) = -y(t - 1), y = 1 for t <= 0: y(t) = sum_{k=0}^{n} (-1)^k (t - k + 1)^k / k! on
    [n - 1, n] (method of steps; on [0, 3]: 1 - t, + (t-1)^2/2, - (t-2)^3/6)."""
    n = math.floor(t) + 1
    return sum((-1) ** k * (t - (k - 1)) ** k / math.factorial(k) for k in range(n + 1))


def _neg_delay_law():
    return DelayLaw.make(1, 0, [1.0], [0], gd=[[-1.0]], kinds=[STATE], targets=[0])


def _run(te, law, rtol=1e-8, h=0.0, land=False, history=None, **kw):
    return dde(zero_rhs, None, None, 0.0, [1.0], np.asarray(te, dtype=float), land, np.zeros(0),
               np.zeros(0), rtol, np.array([rtol]), h, h, 10**6, 0, 1, law, history, **kw)


def test_dde_closed_form_and_breaking_points():
    law = _neg_delay_law()
    te = np.linspace(0.0, 3.0, 61)
    exact = np.array([steps_closed_form(t) for t in te])
    assert exact[20] == pytest.approx(0.0) and exact[40] == pytest.approx(0.5 - 1.0 + 0.0)
    out = _run(te, law, rtol=1e-6)
    assert out.status == 0
    # the solution is a polynomial of degree <= 3 between breaking points, which DOPRI5 and its
    # dense output reproduce exactly when no step straddles one
    assert np.max(np.abs(out.Y[:, 0] - exact)) < 1e-13
    # the input is u = -y(t - 1): -1 on [0, 1], then -(2 - t) ...
    assert out.U[30, 0] == pytest.approx(-exact[10], abs=1e-13)
    # breaking points placed wrongly (origin 0.37): steps straddle t = 1, 2, error >> round-off
    bad = _run(te, law, rtol=1e-6, t_break0=0.37)
    assert np.max(np.abs(bad.Y[:, 0] - exact)) > 1e-8


def test_dde_order_fixed_steps():
    """Fixed steps h (rtol so loose that every step is accepted, hmax = h0 = h) on [0, 8], where
    the solution is a degree-8 piecewise polynomial: the error at t = 8 falls like h^5."""
    law = _neg_delay_law()
    hs = [0.25, 0.125, 0.0625, 0.03125]
    errs = []
    for h in hs:
        out = _run([8.0], law, rtol=1e3, h=h, land=True)
        assert out.status == 0 and out.stats[2] == 0 and out.stats[1] == round(8.0 / h)
        errs.append(abs(out.Y[0, 0] - steps_closed_form(8.0)))
    orders = [math.log2(errs[i] / errs[i + 1]) for i in range(len(errs) - 1)]
    assert all(4.5 < q < 5.8 for q in orders), orders
    # adaptive: the error follows the tolerance
    e = [abs(_run([8.0], law, rtol=r, land=True).Y[0, 0] - steps_closed_form(8.0))
         for r in (1e-6, 1e-9)]
    assert e[1] < e[0] / 30 and e[1] < 1e-8


def test_dde_continuation_history_and_events():
    law = _neg_delay_law()
    whole = _run([3.0], law, land=True, rtol=1e-10)
    first = _run([1.5], law, land=True, rtol=1e-10)
    assert first.history.t1[-1] == 1.5 and first.history.t0[0] <= 0.5
    second = dde(zero_rhs, None, None, 1.5, first.Y[0], np.array([3.0]), True, np.zeros(0),
                 np.zeros(0), 1e-10, np.array([1e-10]), first.h_last, 0.0, 10**6, 0, 1, law,
                 first.history, t_break0=0.0)
    assert abs(second.Y[0, 0] - whole.Y[0, 0]) < 1e-12
    assert abs(second.Y[0, 0] - steps_closed_form(3.0)) < 1e-12
    # a history given as a table: y = 1 - t (t <= 0) makes y(t) on [0, 1] = 1 - t + t^2 / 2 - ...
    # here only checked against the same history as a function sampled finely
    th = np.linspace(-1.0, 0.0, 41)
    hist = sampled_history(th, (1.0 + 0.0 * th)[:, None], law)
    tab = _run([3.0], law, land=True, rtol=1e-10, history=hist)
    assert abs(tab.Y[0, 0] - whole.Y[0, 0]) < 1e-12
    # an event: y = 1 - t crosses 0.5 at t = 0.5, located on the dense output, z counts it
    z = np.zeros(1)
    ev = dde(zero_rhs, half_event, count_event, 0.0, [1.0], np.array([3.0]), True, np.zeros(0), z,
             1e-10, np.array([1e-10]), 0.0, 0.0, 10**6, 1, 8, law)
    assert ev.status == 0 and ev.n_ev >= 1 and z[0] == ev.n_ev
    assert ev.ev_t[0] == pytest.approx(0.5, abs=1e-10) and ev.ev_dir[0] == -1
    assert abs(ev.Y[0, 0] - steps_closed_form(3.0)) < 1e-9


def test_events_see_the_effective_parameters():
    """A PARAM input moves an event that depends on that parameter: y' = 1, g = y - p0, the input
    adds u = 0.5 (an offset) to p0 = 1, so the crossing is at t = 1.5, not 1 (with the base p a
    controlled load made a stick/slip switch chatter on the excavator scene)."""
    from nld.integrators.delay import PARAM
    law = DelayLaw.make(1, 1, [0.7], [0], gd=[[0.0]], u0=[0.5], kinds=[PARAM], targets=[0])
    z = np.zeros(1)
    out = dde(unit_rhs, level_event, count_event, 0.0, [0.0], np.array([3.0]), True,
              np.array([1.0]), z, 1e-10, np.array([1e-10]), 0.0, 0.0, 10**5, 1, 4, law)
    assert out.status == 0 and out.n_ev == 1 and z[0] == 1.0
    assert out.ev_t[0] == pytest.approx(1.5, abs=1e-9) and out.ev_dir[0] == 1


@pytest.fixture(scope="module")
def rossler_controlled():
    S = C.rossler()
    fb = C.pyragas(S, 0.2, TAU_ROSSLER, "y")
    res = C.control_delayed(S, fb, transient=50.0, duration=40 * TAU_ROSSLER,
                            lyapunov_span=32 * TAU_ROSSLER)
    return S, fb, res


def test_pyragas_rossler(rossler_controlled):
    S, fb, r = rossler_controlled
    assert r.run.status == 0
    # chaotic without control (Rossler: lambda1 ~ 0.07), non-trivial lambda1 < 0 with it
    assert r.lambda1_uncontrolled > 0.02
    assert r.lambda1_controlled + 2 * r.uncertainty_controlled < 0, r.message
    # non-invasive: the effort falls to a small fraction; the motion becomes tau-periodic
    assert r.effort_rms_initial > 0.05
    assert r.effort_rms_final < 0.02 * r.effort_rms_initial
    assert r.captured_at is not None and r.captured_at < 30
    assert r.periodicity < 0.05
    assert r.status == "controlled"


def test_edfc_channel_is_the_weighted_sum(rossler_controlled):
    """The recursive EDFC channel v(t) = (1-R) s(t-tau) + R v(t-tau) equals the truncated sum
    (1-R) sum_{k=1}^{N} R^(k-1) s(t - k tau) + R^N s0 (constant history s0) read off the run."""
    S, fb, _ = rossler_controlled
    R = 0.4
    f = fb.with_(memory=R, gain=0.1)
    spd = 50
    run = C.run_delayed(S, f, 6 * f.delay, samples_per_delay=spd)
    s = run.Y[:, f.signal]
    s0 = S.y0[f.signal]
    i = run.t.size - 1 - 7           # a sample not on a multiple of tau
    N = i // spd
    want = sum((1 - R) * R ** (k - 1) * s[i - k * spd] for k in range(1, N + 1)) + R ** N * s0
    assert run.v[i] == pytest.approx(want, abs=1e-6)
    assert run.u[i] == pytest.approx(f.gain * (run.v[i] - s[i]), abs=1e-12)


def test_ogy_henon_fixed_point():
    H = henon()
    r = C.ogy(H, 0, dp_max=0.1, radius=0.1, n_iter=1500, x0=[0.1, 0.1], lyapunov_iter=100)
    o = r.orbit
    assert o.converged and o.period == 1
    lam_s = float(np.min(np.abs(o.multipliers)))
    # pole placement: the unstable multiplier (-1.92) moved to 0, the stable one kept
    cl = np.sort(np.abs(r.closed_loop_multipliers))
    assert cl[0] < 1e-8 and cl[1] == pytest.approx(lam_s, rel=1e-6)
    assert r.captured_at is not None and r.captured_at < 1200
    assert r.orbit_distance < 1e-10
    assert 0 < r.effort_rms_initial < 0.1 and r.effort_rms_final < 1e-10
    assert r.lambda1_uncontrolled > 0.2 and r.lambda1_controlled == pytest.approx(math.log(lam_s),  # 50 iterations: O(1/50) bias
                                                                                  abs=0.03)
    # before control came on, the orbit was chaotic: the map wandered far from the fixed point
    first = int(np.argmax(r.active))
    assert np.max(np.abs(r.x[:first] - o.points[0])) > 0.5


def test_odd_number_limitation():
    v = C.odd_number_limitation([-1.92, 0.156])
    assert v.n_real_above_one == 0 and v.limited is False
    v = C.odd_number_limitation([2.5, 0.3])
    assert v.n_real_above_one == 1 and v.limited is True and "Nakajima" in v.message
    v = C.odd_number_limitation([2.5, 0.3], autonomous=True)
    assert v.limited is None and "Fiedler" in v.message
    assert C.odd_number_limitation([1.5 + 0.5j, 1.5 - 0.5j]).n_real_above_one == 0
    assert C.odd_number_limitation([3.0, 1.2, 0.1]).limited is False


@pytest.mark.parametrize("kw, field", [
    (dict(delay=-1.0), "delay"),
    (dict(delay=0.0), "delay"),
    (dict(signal="w"), "signal"),
    (dict(memory=1.0), "memory"),
    (dict(memory=-0.1), "memory"),
    (dict(gain=float("nan")), "gain"),
    (dict(gain=float("inf")), "gain"),
    (dict(input="param", target="q"), "target"),
    (dict(input="torque"), "input"),
])
def test_bad_input_one_line(kw, field):
    S = C.rossler()
    args = dict(gain=0.2, delay=5.88, signal="y")
    args.update(kw)
    with pytest.raises(InputError) as e:
        C.delayed_feedback(S, args.pop("gain"), args.pop("delay"), args.pop("signal"), **args)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(field) and ":" in msg


def test_ogy_bad_input():
    H = henon()
    with pytest.raises(InputError, match=r"^dp_max = -1"):
        C.ogy(H, 0, dp_max=-1, radius=0.1)
    with pytest.raises(InputError, match=r"^param = 'q'"):
        C.ogy(H, "q", dp_max=0.1, radius=0.1)


@pytest.mark.slow
def test_pyragas_rossler_upo_slow():
    """The UPO from periodic_orbit (Poincaré map x = 0): tau = its period; the controlled motion
    is the UPO (polyline distance) with vanishing effort; the stability domain over K."""
    from nld.analysis.orbits import periodic_orbit
    from nld.systems.core import advance
    from nld.systems.derived import PoincareMap
    S = C.rossler()
    y, _ = advance(S, S.y0, S.z0, 0.0, 100.0, 1e-10)
    S0 = C.rossler(y0=y)
    o = periodic_orbit(PoincareMap(S0, [1.0, 0.0, 0.0], 0.0, 1), 1)
    assert o.converged and o.stable is False
    T = C.orbit_period_time(o)
    assert T == pytest.approx(5.881, abs=2e-3)
    assert C.odd_number_limitation(o).n_real_above_one == 0
    fb = C.pyragas(S, 0.2, T, "y")
    r = C.control_delayed(S, fb, transient=100.0, duration=60 * T, lyapunov_span=30 * T,
                          target=o)
    assert r.effort_rms_final < 1e-6 * r.effort_rms_initial
    assert r.orbit_distance < 1e-3
    assert r.lambda1_controlled + 2 * r.uncertainty_controlled < 0 < r.lambda1_uncontrolled
    scan = C.stability_domain(S, fb, [0.0, 0.2, 0.4], y0=r.run.y, t0=r.run.t[-1],
                              history=r.run.history, transient=10 * T, span=20 * T)
    assert scan.lambda1[0, 0] > 0 and scan.stable[0, 1]


@pytest.mark.slow
def test_ogy_duffing_stroboscopic_slow():
    """OGY on a flow's stroboscopic map (monodromy from the tangent integrator, parameter
    sensitivity by finite differences of one period): the forced Duffing period-1 saddle."""
    from nld.analysis.orbits import find_orbits
    from nld.systems.core import duffing
    D = duffing()
    found = find_orbits(D, max_period=1)
    o = [q for q in getattr(found, "orbits", found) if q.stable is False][0]
    r = C.ogy(D, "gamma", orbit=o, dp_max=0.05, radius=0.3, n_iter=400, lyapunov_iter=50,
              window=30)
    assert r.status == "controlled" and r.orbit_distance < 1e-6
    assert np.min(np.abs(r.closed_loop_multipliers)) < 1e-8
    assert r.lambda1_uncontrolled > 0 > r.lambda1_controlled
    assert r.effort_rms_final < 1e-6 * r.effort_rms_initial
