"""Validation of the Lyapunov-exponent estimators (nld.analysis.lyapunov) on systems with known exponents
(references.md section 5) and on the slider-crank scene. docs/lyapunov.md lists the values.

Quick variants run by default; long ones are marked slow (pytest -m slow).
"""
import math
import warnings

import numpy as np
import pytest
from numba import njit

from nld import systems as S
from nld.errors import InputError, SolveError
from nld.analysis.lyapunov import (cross_events, _import_nolds, lyapunov_benettin, lyapunov_nolds,
                          lyapunov_spectrum)

LN2 = math.log(2.0)
HENON_L1 = 0.4192          # Henon (1.4, 0.3), largest exponent per iteration
LORENZ = (0.9056, 0.0, -14.5723)   # Lorenz (10, 28, 8/3), per unit time; sum -41/3
LORENZ_SUM = -(10.0 + 1.0 + 8.0 / 3.0)


# ------------------------------------------------------------------ maps
def test_logistic_r4_is_ln2():
    m = S.logistic(4.0)
    b = lyapunov_benettin(m)
    q = lyapunov_spectrum(m)
    assert abs(b.exponent - LN2) < 0.01
    assert abs(q.exponent - LN2) < 0.01
    assert b.units == "1/iteration" and b.per_revolution is None


def test_henon_spectrum_and_sum():
    m = S.henon(1.4, 0.3)
    q = lyapunov_spectrum(m)                     # analytic Jacobian, QR every iteration
    assert abs(q.exponents[0] - HENON_L1) < 0.01
    assert abs(q.exponents[1] - (-1.6232)) < 0.01
    assert abs(q.total - math.log(0.3)) < 1e-6   # det J = -b at every point
    b = lyapunov_benettin(m)
    assert abs(b.exponent - HENON_L1) < 0.01
    assert abs(b.exponent - q.exponents[0]) < b.uncertainty + q.uncertainty[0]
    # finite-difference Jacobian when the map has none
    fd = S.DiscreteMap(S.henon_f, [0.0, 0.0], [1.4, 0.3], "henon-fd")
    qf = lyapunov_spectrum(fd, total=20_000)
    assert abs(qf.total - math.log(0.3)) < 1e-6
    assert abs(qf.exponents[0] - HENON_L1) < 0.02


# ------------------------------------------------------------------ flows
@pytest.mark.parametrize("a, y0", [(-0.5, 1.0), (-0.5, 0.0), (0.3, 0.0)])
def test_linear_flow_exponent_is_a(a, y0):
    s = S.linear(a, y0=[y0])
    b = lyapunov_benettin(s, total=50.0)
    q = lyapunov_spectrum(s, total=50.0)
    assert abs(b.exponent - a) < 1e-6
    assert abs(q.exponent - a) < 1e-6


def test_lorenz_benettin():
    r = lyapunov_benettin(S.lorenz(), total=1000.0)
    assert abs(r.exponent - LORENZ[0]) < 0.03
    assert r.uncertainty < 0.03
    assert r.history[-1] == pytest.approx(r.exponent)
    assert r.times[-1] == pytest.approx(1000.0)
    assert r.units == "1/s"


def test_lorenz_spectrum_and_agreement():
    s = S.lorenz()
    q = lyapunov_spectrum(s, 3)                          # renorm every 0.1, 500 time units
    assert abs(q.exponents[0] - LORENZ[0]) < 0.03
    assert abs(q.exponents[1]) < 0.03                    # autonomous flow: a zero exponent
    assert abs(q.exponents[2] - LORENZ[2]) < 0.05
    assert abs(q.total - LORENZ_SUM) < 0.05              # trace of the Jacobian
    b = lyapunov_benettin(s, total=1000.0, seed=3)
    assert abs(b.exponent - q.exponents[0]) <= b.uncertainty + q.uncertainty[0]


def test_duffing_forced_has_no_zero_exponent():
    """Forced Duffing (time not a state): two exponents summing to -delta, the first positive."""
    s = S.duffing()
    q = lyapunov_spectrum(s, total=300 * s.period)
    assert abs(q.total + 0.3) < 1e-4
    assert q.exponents[0] - q.uncertainty[0] > 0.0
    assert q.per_revolution[0] == pytest.approx(q.exponents[0] * s.period)


def test_start_time_t0_is_used():
    s = S.duffing()
    s.t0 = 2.0
    t, Y = S.trajectory(s, 3, 0.1)
    assert t[0] == 2.0 and np.array_equal(Y[0], s.y0)
    y, _ = S.advance(s, s.y0, s.z0, 2.0, 2.3)
    assert np.allclose(S.trajectory(s, 4, 0.1)[1][3], y, rtol=1e-7, atol=1e-9)


def test_nolds_wrappers_units_and_determinism():
    nolds = _import_nolds()
    s = S.lorenz()
    dt = 0.02
    _, Y = S.trajectory(s, 1500, dt, transient=50.0)
    x = Y[:, 0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)     # nolds' notes on lag / min_tsep
        r1 = lyapunov_nolds(x, dt)
        r2 = lyapunov_nolds(x, dt)
        ref = nolds.lyap_r(x, emb_dim=10, trajectory_len=20, fit="poly", tau=dt)
        e = lyapunov_nolds(x, dt, method="eckmann")
    assert r1 == r2                                # fit="poly": deterministic
    assert r1 == pytest.approx(ref, rel=1e-12)     # per second, as nolds with tau = dt
    assert 0.3 < r1 < 2.0                          # comparison only: right order, positive
    assert e[0] > 0.0                              # lyap_e: reliable in sign only
    with pytest.raises(InputError):
        lyapunov_nolds(x, dt, tau=dt)


# ------------------------------------------------------------------ events and renormalisation
@njit(cache=True)
def _lin_rhs(t, y, p, z, dy):
    dy[0] = 1.0


@njit(cache=True)
def _lin_events(t, y, p, z, g):
    g[0] = y[0] - 1.0


@njit(cache=True)
def _lin_on_event(k, direction, t, y, p, z):
    z[0] = direction
    return 0


def test_renormalisation_across_an_event_surface_reports_it():
    s = S.ContinuousSystem(_lin_rhs, [0.0], name="ramp", z0=[0.0], events=_lin_events,
                           on_event=_lin_on_event, n_events=1)
    z = np.zeros(1)
    cross_events(s, 0.0, np.array([0.9]), np.array([1.1]), z)
    assert z[0] == 1.0
    cross_events(s, 0.0, np.array([1.2]), np.array([1.1]), z)   # no crossing: unchanged
    assert z[0] == 1.0
    cross_events(s, 0.0, np.array([1.1]), np.array([0.5]), z)
    assert z[0] == -1.0


def test_bad_input():
    with pytest.raises(InputError):
        lyapunov_spectrum(S.henon(), k=3)
    with pytest.raises(InputError):
        lyapunov_benettin(S.lorenz(), total=0.5)          # fewer than two intervals
    with pytest.raises(InputError):
        lyapunov_benettin(S.logistic(), renorm_interval=0.5)
    with pytest.raises(InputError):
        S.advance(S.henon(), [0.0, 0.0], np.zeros(0), 0.0, 1.0)
    with pytest.raises(InputError):
        S.ContinuousSystem(S.lorenz_rhs, [1.0, 1.0, 1.0], scales=[1.0, -1.0, 1.0])


# ------------------------------------------------------------------ scenes
CHAOTIC = None                       # default slider-crank: 5000 rpm, 0.5 mm clearance
PERIODIC = ["driver.speed=50", "joints.B.contact.restitution=0.5"]   # 477 rpm, period-1


def test_scene_system_wraps_the_kernel():
    s = S.SceneSystem("slider_crank")
    assert s.n == 4 and s.state_names == ["slider.s", "rod.phi", "slider.s_dot", "rod.phi_dot"]
    assert s.period == pytest.approx(2 * math.pi / 523.5987755982989)
    assert s.scales[0] == pytest.approx(0.5e-3)          # a slide: scaled by the clearance
    assert s.n_events == 1 and s.z0.shape == (1,)
    y, z = S.advance(s, s.y0, s.z0, 0.0, s.period)
    assert np.all(np.isfinite(y))


def test_scene_chaotic_quick():
    """5000 rpm: both estimators positive over 40 revolutions (after 10)."""
    s = S.SceneSystem("slider_crank", CHAOTIC)
    P = s.period
    b = lyapunov_benettin(s, transient=10 * P, total=40 * P)
    q = lyapunov_spectrum(s, 2, transient=10 * P, total=40 * P)
    assert b.exponent - b.uncertainty > 0.0
    assert q.exponents[0] - q.uncertainty[0] > 0.0
    assert b.per_revolution == pytest.approx(b.exponent * P)
    assert b.settings["checks"] == 32 and b.settings["renorm_interval"] == pytest.approx(P)


def test_scene_periodic_quick():
    """477 rpm, restitution 0.5: a period-1 motion with impacts; lambda1 <= 0 within its
    uncertainty, for both estimators."""
    s = S.SceneSystem("slider_crank", PERIODIC)
    P = s.period
    b = lyapunov_benettin(s, transient=30 * P, total=20 * P)
    q = lyapunov_spectrum(s, 2, transient=30 * P, total=20 * P)
    assert b.exponent <= b.uncertainty
    assert q.exponents[0] <= q.uncertainty[0]
    assert np.sign(b.exponent) == np.sign(q.exponents[0])


@pytest.mark.slow
def test_scene_chaotic_long_agreement():
    s = S.SceneSystem("slider_crank")
    b = lyapunov_benettin(s)                            # 20 + 500 revolutions
    q = lyapunov_spectrum(s, 2, total=200 * s.period)
    assert b.exponent - b.uncertainty > 0.0
    assert abs(b.exponent - q.exponents[0]) <= b.uncertainty + q.uncertainty[0]


@pytest.mark.slow
def test_scene_periodic_long():
    s = S.SceneSystem("slider_crank", PERIODIC)
    P = s.period
    b = lyapunov_benettin(s, transient=50 * P, total=100 * P)
    assert b.exponent + b.uncertainty < 0.0


@pytest.mark.slow
def test_user_system_without_cached_solver():
    """A ContinuousSystem from a user rhs (DOPRI5 compiled from Python, not disk-cached)."""
    s = S.ContinuousSystem(S.lorenz_rhs, [1.0, 1.0, 1.0], [10.0, 28.0, 8.0 / 3.0], "lorenz-user")
    r = lyapunov_benettin(s, total=1000.0)
    assert abs(r.exponent - LORENZ[0]) < 0.03


# ------------------------------------------------------------------ the stiff integrator
def test_method_is_checked_and_carried():
    with pytest.raises(InputError, match="method"):
        S.SceneSystem("slider_crank", method="euler")
    with pytest.raises(InputError, match="method"):
        S.ContinuousSystem(S.lorenz_rhs, [1.0, 1.0, 1.0], method="rk4")
    s = S.SceneSystem("slider_crank", method="rodas")
    assert s.method == "rodas" and s._solve is s.kernel.module.solve_rodas


@pytest.mark.slow
def test_lorenz_with_the_stiff_method():
    """Benettin with both trajectories integrated by Rodas4 (finite-difference Jacobian of a user
    right-hand side) reproduces Lorenz' 0.906 as DOPRI5 does. Slow for its compilation (Rodas4
    for a user rhs, about 45 s cold); the default run keeps Rodas4's accuracy
    (test_integrators: Van der Pol, slider_crank) and Benettin with a non-default integrator
    (test_chaos_map: DOP853, equal to lyapunov_benettin's value)."""
    s = S.ContinuousSystem(S.lorenz_rhs, [1.0, 1.0, 1.0], [10.0, 28.0, 8.0 / 3.0], "lorenz-rodas",
                           method="rodas")
    r = lyapunov_benettin(s, total=1000.0, rtol=1e-9)
    assert abs(r.exponent - LORENZ[0]) < 0.03 and r.uncertainty < 0.03


def test_scene_dop853_reports_stiffness_instead_of_an_exponent():
    """On the period-1 slider-crank (journal in damped continuous contact) DOP853's stiffness
    detection stops the run at rtol 1e-10: the exponent is refused with a message naming the
    method and the remedy, not computed from stability-limited steps (docs/lyapunov.md)."""
    s = S.SceneSystem("slider_crank", PERIODIC, method="dop853")
    with pytest.raises(SolveError, match="dop853: the problem became stiff"):
        lyapunov_benettin(s, transient=30 * s.period, total=20 * s.period, rtol=1e-10)


def test_largest_exponent_passes_the_tangent_error_control():
    """The studies choose the tangent vectors' error control through largest_exponent; the
    result's settings say which ran, and on Lorenz both controls give the published exponent
    (0.9056, Sprott) within their uncertainties."""
    from nld.analysis.lyapunov import largest_exponent
    out = {}
    for te in (True, False):
        r = largest_exponent(S.lorenz(), "tangent", total=200.0, transient=10.0, tangent_err=te)
        assert r.settings["tangent_err"] is te
        assert abs(r.exponent - 0.9056) < 3 * r.uncertainty + 0.02, (te, r.exponent, r.uncertainty)
        out[te] = r
    assert out[True].settings["rtol"] == out[False].settings["rtol"]
