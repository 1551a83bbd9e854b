"""Tests of the added integrators: DOP853 (nld.integrators.dop853), Rodas4 (nld.integrators.rosenbrock),
the scipy backend, and simulate(method=...).

Every integrator call on a test problem goes through a module-level ``@njit(cache=True)`` wrapper
of tests/problems.py (``adaptive``, ``fixed``) whose rhs/events are globals, so numba's disk cache
holds it (a dispatcher passed from Python is never found in the cache; see
nld/integrators/dopri5.py); test_events and test_tangent use the same wrappers.
"""
import importlib
import math

import numpy as np
import pytest

from nld.errors import InputError
from nld.integrators import (METHODS, NON_FINITE, SINGULAR, STIFF, STOPPED, SUCCESS,
                             method_status_message)
from nld.integrators import rosenbrock as rosmod

# the package attribute ``dop853`` is the function; the module is in sys.modules
d853mod = importlib.import_module("nld.integrators.dop853")
from nld.run.simulate import simulate

# ------------------------------------------------------------------ test problems
# shared with test_events and test_tangent (tests/problems.py): every integrator compiles once
from problems import (BANG, LIN, NAN, OFFSET, PEND, VDP, adaptive, fixed)  # noqa: E402
from nld.integrators import EVENT_SAMPLES  # noqa: E402


def lin_fixed(lam, h, n):
    return fixed(1, np.ones(1), h, n, np.array([LIN, lam]))


def pend_fixed(which, h, n):
    return fixed(which, np.array([1.0, 0.0]), h, n, np.array([PEND]))


def pend_adaptive(which, t_eval, rtol, atol):
    return adaptive(which, 0.0, np.array([1.0, 0.0]), t_eval, False, np.array([PEND]), np.zeros(1),
                    rtol, atol, 0.0, 0.0, 10**6, 0, 8, EVENT_SAMPLES)


def vdp_solve(which, t_eval, mu, rtol, max_steps):
    return adaptive(which, 0.0, np.array([2.0, 0.0]), t_eval, False, np.array([VDP, mu]), np.zeros(1),
                    rtol, np.full(2, rtol), 0.0, 0.0, max_steps, 0, 8, EVENT_SAMPLES)


def nan_solve(which, t_eval):
    return adaptive(which, 0.0, np.zeros(1), t_eval, False, np.array([NAN, 0.5]), np.zeros(1), 1e-8,
                    np.full(1, 1e-10), 0.0, 0.0, 10**5, 0, 8, EVENT_SAMPLES)


def bang_solve(which, t_eval, stop, land, rtol):
    z = np.array([1.0, 0.0])
    out = adaptive(which, 0.0, np.array([1.0, 0.0]), t_eval, land,
                   np.array([BANG, 9.81, 1.0 if stop else 0.0]), z, rtol, np.full(2, 1e-12), 0.0, 0.0,
                   10**5, 1, 64, EVENT_SAMPLES)
    return out, z


T1 = math.sqrt(2.0 / 9.81)       # first zero of x(t) = 1 - 9.81 t^2 / 2


def bang_exact(t, a=9.81):
    t1 = math.sqrt(2.0 / a)
    v = a * t1
    tau = t % (4.0 * t1)
    if tau <= t1:
        return 1.0 - 0.5 * a * tau**2
    if tau <= 3.0 * t1:
        s = tau - t1
        return -v * s + 0.5 * a * s**2
    s = tau - 3.0 * t1
    return v * s - 0.5 * a * s**2


# ------------------------------------------------------------------ 1. coefficients and order


def test_dop853_coefficients_match_scipy():
    """Hairer's DOP853 tableau as transcribed here equals SciPy's (another transcription)."""
    sc = pytest.importorskip("scipy.integrate._ivp.dop853_coefficients")
    assert np.array_equal(d853mod.C, sc.C)
    assert np.array_equal(d853mod.A, sc.A)
    assert np.array_equal(d853mod.B, sc.B)
    assert np.array_equal(d853mod.E3, sc.E3)
    assert np.array_equal(d853mod.E5, sc.E5)
    assert np.array_equal(d853mod.D, sc.D)
    # consistency: sum_j a_ij = c_i, weights sum to 1
    assert np.allclose(d853mod.A.sum(axis=1), d853mod.C, atol=1e-14)
    assert abs(d853mod.B.sum() - 1.0) < 1e-14


def test_rodas_is_l_stable():
    """One Rodas4 step of y' = lambda y with h*lambda = -1e8 damps to ~0 (R(-inf) = 0: L-stable,
    stiffly accurate), where an explicit step would blow up; h*lambda = -1 gives ~exp(-1)."""
    for hl, want, tol in ((-1e8, 0.0, 1e-6), (-1.0, math.exp(-1.0), 1e-3)):
        y = lin_fixed(hl, 1.0, 1)
        assert abs(y[0] - want) < tol, (hl, y)


def _order(errs, hs):
    return np.polyfit(np.log(hs), np.log(errs), 1)[0]


def test_dop853_fixed_step_order_is_eight():
    ref = pend_adaptive(1, np.array([0.0, 20.0]), 1e-14, np.full(2, 1e-16))[2][-1]
    hs, errs = [], []
    for n in (40, 56, 80):
        h = 20.0 / n
        errs.append(np.abs(pend_fixed(0, h, n) - ref).max())
        hs.append(h)
    q = _order(errs, hs)
    assert 7.5 < q < 8.8, (q, errs)


def test_rodas_fixed_step_order_is_four():
    ref = pend_adaptive(1, np.array([0.0, 20.0]), 1e-14, np.full(2, 1e-16))[2][-1]
    hs, errs = [], []
    for n in (400, 800, 1600):
        h = 20.0 / n
        errs.append(np.abs(pend_fixed(1, h, n) - ref).max())
        hs.append(h)
    q = _order(errs, hs)
    assert 3.7 < q < 4.3, (q, errs)


@pytest.mark.parametrize("which", [1, 2])
def test_adaptive_error_follows_tolerance(which):
    """Global error tracks the tolerance (within a modest factor) and shrinks with it."""
    te = np.linspace(0.0, 10.0, 11)
    ref = pend_adaptive(1, te, 1e-14, np.full(2, 1e-16))[2]
    errs = []
    for rtol in (1e-5, 1e-7, 1e-9):
        st, _, Y, n_out, stats, *_ = pend_adaptive(which, te, rtol, np.full(2, rtol))
        assert st == SUCCESS and n_out == len(te)
        errs.append(np.abs(Y - ref).max())
        assert errs[-1] < 100 * rtol, (rtol, errs[-1])
    assert errs[2] < errs[1] < errs[0]


# ------------------------------------------------------------------ 2. stiffness


def test_rodas_solves_stiff_van_der_pol_with_far_fewer_steps():
    """Van der Pol mu = 1000 on [0, 400]: dopri5 is stability-bound (~10^5 steps), Rodas4 needs
    a few hundred, and both agree with a tight Rodas4 run."""
    te = np.linspace(0.0, 400.0, 5)
    st_r, _, Y_r, _, stats_r, *_ = vdp_solve(2, te, 1000.0, 1e-6, 10**6)
    st_e, _, Y_e, _, stats_e, *_ = vdp_solve(0, te, 1000.0, 1e-6, 10**6)
    st_ref, _, Y_ref, *_ = vdp_solve(2, te, 1000.0, 1e-10, 10**6)
    assert st_r == SUCCESS and st_e == SUCCESS and st_ref == SUCCESS
    assert stats_r[0] * 50 < stats_e[0], (stats_r, stats_e)
    assert stats_r[5] == stats_r[1] and stats_r[6] >= stats_r[0]     # one J per accepted step
    assert np.abs(Y_r[:, 0] - Y_ref[:, 0]).max() < 1e-3
    assert np.abs(Y_e[:, 0] - Y_ref[:, 0]).max() < 1e-3


def test_dop853_detects_stiffness():
    """Hairer's stiffness detection stops DOP853 on the stiff Van der Pol with a clear message."""
    te = np.linspace(0.0, 400.0, 5)
    st, t, Y, n_out, stats, *_ = vdp_solve(1, te, 1000.0, 1e-6, 10**6)
    assert st == STIFF
    assert 0.0 < t < 400.0 and np.all(np.isfinite(Y[:n_out]))
    msg = method_status_message("dop853", st, t, stats)
    assert "stiff" in msg and "rodas" in msg


# ------------------------------------------------------------------ 3. events and statuses


@pytest.mark.parametrize("which", [1, 2])
def test_events_of_bang_bang_oscillator(which):
    te = np.linspace(0.0, 10.0 * T1, 41)
    (st, t, Y, n_out, stats, ev_t, ev_k, ev_dir, n_ev, Z), z = bang_solve(which, te, False, False,
                                                                         1e-10)
    assert st == SUCCESS and n_out == len(te)
    assert n_ev == 5 and z[1] == 5.0
    assert np.allclose(ev_t[:5] / T1, [1, 3, 5, 7, 9], atol=1e-9)
    assert list(ev_dir[:5]) == [-1, 1, -1, 1, -1]
    exact = np.array([bang_exact(ti) for ti in te])
    assert np.abs(Y[:, 0] - exact).max() < 1e-8
    # the discrete state in force at each output row
    assert np.all(Z[te < T1, 0] == 1.0) and np.all(Z[(te > T1) & (te < 3 * T1), 0] == -1.0)


@pytest.mark.parametrize("which", [1, 2])
def test_stop_on_event_and_land(which):
    (st, t, Y, n_out, *_), z = bang_solve(which, np.linspace(0.0, 3.0, 7), True, False, 1e-10)
    assert st == STOPPED and abs(t - T1) < 1e-10 and n_out == 1   # only t = 0 precedes T1
    te = np.array([0.0, 0.1, 0.2, 0.3])
    (st, t, Y, n_out, *_), z = bang_solve(which, te, False, True, 1e-10)
    assert st == SUCCESS and t == 0.3
    assert np.abs(Y[:, 0] - (1.0 - 0.5 * 9.81 * te**2)).max() < 1e-12


@pytest.mark.parametrize("which", [1, 2])
def test_non_finite_rhs_stops_with_status(which):
    st, t, Y, n_out, stats, *_ = nan_solve(which, np.linspace(0.0, 1.0, 11))
    assert st == NON_FINITE
    assert t <= 0.5 + 1e-12 and np.all(np.isfinite(Y[:n_out]))
    assert np.all(np.isnan(Y[n_out:]))


def test_lu_solves_and_flags_singular():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(6, 6))
    b = rng.normal(size=6)
    lu = a.copy()
    piv = np.zeros(6, dtype=np.int64)
    assert rosmod.lu_factor(lu, piv)
    x = b.copy()
    rosmod.lu_solve(lu, piv, x)
    assert np.allclose(a @ x, b, atol=1e-12)
    s = np.ones((3, 3))
    assert not rosmod.lu_factor(s, np.zeros(3, dtype=np.int64))
    assert "singular" in method_status_message("rodas", SINGULAR, 0.1, np.zeros(7))


def test_pick_difference_avoids_a_jump():
    """Central difference where f is smooth, one-sided on the smooth side of a jump."""
    f0 = np.array([0.0, 0.0])
    fp = np.array([1e-8, 1.0])       # component 1 jumps by 1 between 0 and +d
    fm = np.array([-1e-8, -1e-8])
    out = np.empty(2)
    rosmod._pick_difference(fp, fm, f0, 1e-8, -1e-8, out)
    assert np.allclose(out, [1.0, 1.0])


# ------------------------------------------------------------------ 4. the mechanism


@pytest.fixture(scope="module")
def slider_ref():
    return simulate("slider_crank", revs=0.2, rtol=1e-12, method="dop853")


@pytest.mark.parametrize("method", METHODS)
def test_every_method_agrees_with_tight_reference_on_slider_crank(method, slider_ref):
    """Journal position (B.ex, B.ey) on the first 0.2 revolution (6 impacts) within
    K * rtol * clearance of a DOP853 rtol 1e-12 run, with simulate's tolerance vector (positions
    absolute). Measured K at rtol 1e-7: dopri5 40, dop853 25, rodas 25, scipy RK45 1400,
    DOP853 110, LSODA 210, Radau 26. Bounds: K = 300 for the numba methods, 3000 for scipy's."""
    rtol, c = 1e-7, 5e-4
    K = 3000 if method.startswith("scipy:") else 300
    r = simulate("slider_crank", revs=0.2, rtol=rtol, method=method)
    assert r.status == 0, r.message
    err = np.abs(r.table[["B.ex", "B.ey"]].to_numpy() - slider_ref.table[["B.ex", "B.ey"]].to_numpy()).max()
    assert err < K * rtol * c, err
    assert len(r.events) == len(slider_ref.events)
    assert r.provenance["integrator"] == method
    assert {"steps", "accepted", "rejected", "rhs", "events"} <= set(r.stats)
    if method == "rodas" or method.startswith("scipy:"):
        assert {"jac", "lu"} <= set(r.stats)
    assert r.message.startswith(method) or method == "dopri5"


def test_default_method_is_dopri5_and_unknown_method_is_rejected():
    r = simulate("slider_crank", revs=0.02)
    assert r.provenance["integrator"] == "dopri5" and set(r.stats) == {
        "steps", "accepted", "rejected", "rhs", "events"}
    with pytest.raises(InputError, match="method"):
        simulate("slider_crank", revs=0.02, method="euler")


def test_generated_kernel_has_the_wrappers():
    from nld.kernel.compile import compile_scene
    from nld.model.scene import load_scene
    k = compile_scene(load_scene("slider_crank"))
    assert all(hasattr(k.module, f) for f in ("solve", "solve_dop853", "solve_rodas"))


STIFF_CONTACT = ["driver.speed=15.0", 'joints.B.contact.law="hertz_damped"', "joints.B.contact.damping=2e6",
                 "joints.B.contact.stiffness=1e10"]


def test_rodas_on_stiff_damped_contact():
    """Heavily damped persistent contact (hertz_damped, C = 2e6 N s/m): Rodas4 takes ~2000 steps
    for half a revolution where dopri5 takes ~10^6; the result agrees with a tighter Rodas run."""
    r = simulate("slider_crank", revs=0.5, rtol=1e-6, method="rodas", overrides=STIFF_CONTACT)
    assert r.status == 0, r.message
    assert r.stats["steps"] < 5000
    ref = simulate("slider_crank", revs=0.5, rtol=1e-8, method="rodas", overrides=STIFF_CONTACT)
    err = np.abs(r.table[["B.ex", "B.ey"]].to_numpy() - ref.table[["B.ex", "B.ey"]].to_numpy()).max()
    assert err < 1e-5, err


@pytest.mark.slow
def test_dop853_stops_on_stiff_damped_contact():
    """The same scene: DOP853 stops with the stiffness message instead of returning a wrong
    answer. Slow only for the compilation (DOP853 for this kernel, ~25 s cold); the stiffness
    detection itself stays in the default run (test_dop853_detects_stiffness, Van der Pol)."""
    d = simulate("slider_crank", revs=0.5, rtol=1e-6, method="dop853", overrides=STIFF_CONTACT)
    assert d.status == STIFF and "rodas" in d.message


def test_scipy_backend_updates_discrete_state_and_logs_events(slider_ref):
    r = simulate("slider_crank", revs=0.2, rtol=1e-7, method="scipy:LSODA")
    assert r.status == 0
    assert list(r.events.direction) == list(slider_ref.events.direction)
    # contact onset/loss times (measured 7e-9 s at rtol 1e-7)
    assert np.allclose(r.events.t, slider_ref.events.t, rtol=0, atol=1e-7)
    # z holds the approach velocity of the last contact onset, as the numba integrators leave it
    assert r.z_final[0] == pytest.approx(slider_ref.z_final[0], rel=1e-3)
    assert r.stats["rejected"] == -1 and "rejections not reported" in r.message
    with pytest.raises(ValueError, match="land"):
        simulate("slider_crank", revs=0.02, method="scipy:RK45", land=True)


# ------------------------------------------------------------------ per-state rtol weights
def offset_solve(which, t_eval, atol):
    """x = 1e4 + cos t (problem OFFSET) at rtol 1e-6 with the tolerance vector atol."""
    return adaptive(which, 0.0, np.array([1.0e4 + 1.0, 0.0]), t_eval, False, np.array([OFFSET, 1.0e4]),
                    np.zeros(0), 1e-6, atol, 0.0, 0.0, 10**6, 0, 8, EVENT_SAMPLES)


@pytest.mark.parametrize("which", [0, 1, 2])
def test_zero_rtol_weight_makes_the_control_absolute(which):
    """atol of length 2n = atol then rtol weights: weight 0 on x holds x - X0 to atol, where the
    plain relative test lets the error grow with |x| = 1e4 (the winding-angle problem)."""
    te = np.linspace(0.0, 20.0, 41)
    exact = 1.0e4 + np.cos(te)
    a = 1e-9
    out_rel = offset_solve(which, te, np.array([a, a]))
    out_abs = offset_solve(which, te, np.array([a, a, 0.0, 1.0]))
    err_rel = np.abs(out_rel[2][:, 0] - exact).max()
    err_abs = np.abs(out_abs[2][:, 0] - exact).max()
    assert out_rel[0] == SUCCESS and out_abs[0] == SUCCESS
    assert err_abs < 1e-6, err_abs
    assert err_rel > 10.0 * err_abs, (err_rel, err_abs)
    with pytest.raises(ValueError):
        offset_solve(which, te, np.array([a, a, 0.0]))


def test_dop853_rejects_a_step_whose_dense_output_is_not_finite():
    """slider_crank at rtol 1e-4: a long free-flight step whose three extra dense-output stages
    met the contact gave NaN outputs and then a non-finite stop at t = 4.41 ms (before the fix);
    the step is now rejected and the run goes on, with every output finite."""
    r = simulate("slider_crank", t_end=0.0045, rtol=1e-4, method="dop853", samples_per_rev=20000)
    assert r.status == SUCCESS, r.message
    assert np.isfinite(r.table[["B.ex", "B.ey", "B.Fn"]].to_numpy()).all()
    ref = simulate("slider_crank", t_end=0.0045, rtol=1e-10, samples_per_rev=20000)
    assert len(r.events) == len(ref.events)


def test_scipy_radau_failure_is_a_status_not_an_exception():
    """scipy's Radau raised ValueError (LU of a non-finite Jacobian) on slider_crank_two at rtol
    1e-8; the backend reports the non-finite status instead (or succeeds with finite output)."""
    r = simulate("slider_crank_two", revs=0.25, rtol=1e-8, method="scipy:Radau", samples_per_rev=8000)
    assert r.status in (SUCCESS, NON_FINITE), r.message
    if r.status == NON_FINITE:
        assert "non-finite" in r.message and r.t_reached < 0.25 * 60 / 5000
    else:
        assert np.isfinite(r.table.drop(columns=["t"]).to_numpy()).all()
