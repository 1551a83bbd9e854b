"""Tests of the numba DOPRI5 integrator (nld.integrators.dopri5).

To keep compilation short, only two (rhs, events, on_event) combinations are compiled for
``dopri5``: a parametrised scalar right-hand side (decay, constant, kink, blow-up, NaN) and a
"bang-bang" oscillator whose force sign lives in the discrete state z.
"""

import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from numba import njit

from nld.integrators import (
    MAX_STEPS,
    NON_FINITE,
    STEP_UNDERFLOW,
    STOPPED,
    SUCCESS,
    dopri5,
    Solution,
    dopri5_fixed,
    no_events,
    no_on_event,
    status_message,
)

from nld.errors import InputError
from nld.integrators.core import inlined
from nld.integrators.dopri5 import dopri5_core
from nld.integrators.dopri5 import interp as dopri5_interp
from nld.integrators.events import EVENT_SAMPLES

# ------------------------------------------------------------------ test problems


@njit
def scalar_rhs(t, y, p, z, dy):
    """dy = p0*y + p1*|t - p2| + p3 + p4*y^2; NaN for t >= p5."""
    if t >= p[5]:
        dy[0] = np.nan
        return
    dy[0] = p[0] * y[0] + p[1] * abs(t - p[2]) + p[3] + p[4] * y[0] * y[0]


def sp(decay=0.0, kink=0.0, t_kink=0.0, const=0.0, square=0.0, t_nan=np.inf):
    return np.array([decay, kink, t_kink, const, square, t_nan])


A_G = 9.81
T1 = math.sqrt(2.0 / A_G)      # first zero of x(t) = 1 - a t^2 / 2


@njit
def bang_rhs(t, y, p, z, dy):
    """x'' = -a * z0 (z0 = +-1 switched by on_event): a ball / bang-bang oscillator."""
    dy[0] = y[1]
    dy[1] = -p[0] * z[0]


@njit
def bang_events(t, y, p, z, g):
    """g0 = x; g_k = x - p[1 + k] for k >= 1 (passive level crossings)."""
    g[0] = y[0]
    for k in range(1, g.shape[0]):
        g[k] = y[0] - p[1 + k]


@njit
def bang_on_event(k, direction, t, y, p, z):
    if k == 0:
        z[0] = direction      # force now points back towards x = 0
        z[1] += 1.0           # count contacts
        z[2] = y[1]           # record the approach velocity
        return int(p[1])      # p[1] = 1: stop at the first zero of x
    return 0


def bang_exact(t, a=A_G):
    """Analytic x(t) of the bang-bang oscillator x(0)=1, v(0)=0 (period 4*T1)."""
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


@njit
def osc_rhs(t, y, p, z, dy):
    dy[0] = y[1]
    dy[1] = -y[0]


EMPTY = np.zeros(0)


def run_scalar(p, y0, t_eval, rtol=1e-8, atol=1e-12, land=False, max_steps=100000, h0=0.0,
               hmax=0.0):
    return dopri5(scalar_rhs, no_events, no_on_event, 0.0, np.array([y0], dtype=np.float64), np.asarray(t_eval, dtype=np.float64), land,
                  p, np.zeros(1), rtol, np.array([atol]), h0, hmax, max_steps, 0, 16)


def run_bang(t_eval, stop=False, levels=(), rtol=1e-10, atol=1e-12, max_log=64, land=False,
             hmax=0.0):
    p = np.array([A_G, 1.0 if stop else 0.0] + list(levels))
    z = np.array([1.0, 0.0, 0.0])
    out = dopri5(bang_rhs, bang_events, bang_on_event, 0.0, np.array([1.0, 0.0]),
                 np.asarray(t_eval, dtype=np.float64), land, p, z, rtol,
                 np.array([atol, atol]), 0.0, hmax, 100000, 1 + len(levels), max_log)
    Z = out[9]
    # the discrete state recorded per output row is the z in force there
    assert Z.shape == (len(t_eval), 3)
    return out[:9], z


# ------------------------------------------------------------------ 1. convergence order


def test_fixed_step_order_is_five():
    y0 = np.array([1.0, 0.0])
    t_end = 4.0
    errs = []
    for n in (8, 16, 32):
        y = dopri5_fixed(osc_rhs, 0.0, y0, t_end / n, n, EMPTY, EMPTY)
        errs.append(math.hypot(y[0] - math.cos(t_end), y[1] + math.sin(t_end)))
    orders = [math.log2(errs[0] / errs[1]), math.log2(errs[1] / errs[2])]
    for q in orders:
        assert abs(q - 5.0) < 0.3, (errs, orders)


# ------------------------------------------------------------------ 2. adaptive accuracy


def test_decay_tight_tolerance():
    status, t_r, Y, n_out, stats, *_ = run_scalar(sp(decay=-1.0), 1.0, [0.0, 5.0], rtol=1e-10,
                                                   atol=1e-14)
    assert status == SUCCESS and t_r == 5.0 and n_out == 2
    assert Y[0, 0] == 1.0
    assert abs(Y[1, 0] - math.exp(-5.0)) < 1e-8
    assert stats[0] == stats[1] + stats[2]
    assert stats[3] >= 6 * stats[0]


def test_error_decreases_with_rtol():
    errs = []
    for rtol in (1e-4, 1e-6, 1e-8):
        status, _, Y, _, _, *_ = run_scalar(sp(decay=-1.0), 1.0, [0.0, 5.0], rtol=rtol,
                                            atol=rtol * 1e-3)
        assert status == SUCCESS
        errs.append(abs(Y[1, 0] - math.exp(-5.0)))
    assert errs[0] > errs[1] > errs[2], errs
    assert errs[2] < 1e-8


def test_y0_and_inputs_unchanged_and_validation():
    y0 = np.array([1.0])
    te = np.linspace(0.0, 1.0, 5)
    dopri5(scalar_rhs, no_events, no_on_event, 0.0, y0, te, False, sp(decay=-1.0),
           np.zeros(1), 1e-6, np.array([1e-9]), 0.0, 0.0, 1000, 0, 4)
    assert y0[0] == 1.0 and te[-1] == 1.0
    # t_eval = [t0] only: nothing to integrate
    status, t_r, Y, n_out, stats, *_ = run_scalar(sp(decay=-1.0), 2.0, [0.0])
    assert status == SUCCESS and t_r == 0.0 and n_out == 1 and Y[0, 0] == 2.0
    assert stats[1] == 0
    with pytest.raises(ValueError):
        run_scalar(sp(decay=-1.0), 1.0, np.array([0.0, 2.0, 1.0]))


# ------------------------------------------------------------------ 3. dense output


def test_dense_output_matches_exp():
    te = np.linspace(0.0, 5.0, 200)
    status, _, Y, n_out, stats, *_ = run_scalar(sp(decay=-1.0), 1.0, te, rtol=1e-9,
                                                atol=1e-13)
    assert status == SUCCESS and n_out == 200
    assert stats[1] < 150          # steps are not forced onto the 200 output times
    assert np.max(np.abs(Y[:, 0] - np.exp(-te))) < 1e-7


# ------------------------------------------------------------------ 4. events


def test_falling_ball_stops_at_ground():
    te = np.linspace(0.0, 1.0, 11)
    (status, t_r, Y, n_out, stats, ev_t, ev_k, ev_dir, n_ev), z = run_bang(te, stop=True)
    assert status == STOPPED
    assert abs(t_r - T1) < 1e-10
    assert n_ev == 1 and ev_k[0] == 0 and ev_dir[0] == -1 and abs(ev_t[0] - T1) < 1e-10
    assert stats[4] == 1
    # z was changed by on_event only: new force sign, contact count, approach velocity
    assert z[0] == -1.0 and z[1] == 1.0 and abs(z[2] + A_G * T1) < 1e-8
    n_expected = int(np.sum(te <= T1))
    assert n_out == n_expected
    assert np.allclose(Y[:n_out, 0], 1.0 - 0.5 * A_G * te[:n_out] ** 2, atol=1e-12, rtol=0)
    assert np.all(np.isnan(Y[n_out:]))


@pytest.mark.parametrize("hmax", [0.0, 0.1])
def test_force_switch_piecewise_solution(hmax):
    # x'' = -a z0 with z0 flipped at every zero of x: the error estimate of this piecewise
    # quadratic motion is 0, so without hmax the steps are as long as the events allow.
    period = 4.0 * T1
    te = np.linspace(0.0, 2.0 * period, 97)
    (status, t_r, Y, n_out, stats, ev_t, ev_k, ev_dir, n_ev), z = run_bang(
        te, levels=(0.5,), hmax=hmax)
    assert status == SUCCESS and n_out == len(te)
    assert t_r == te[-1]
    # zeros of x at T1, 3 T1, 5 T1, 7 T1 with alternating direction
    k0 = ev_k[:n_ev] == 0
    assert np.allclose(ev_t[:n_ev][k0], [T1, 3 * T1, 5 * T1, 7 * T1], atol=1e-10, rtol=0)
    assert list(ev_dir[:n_ev][k0]) == [-1, 1, -1, 1]
    assert z[1] == 4.0 and stats[4] == n_ev
    exact = np.array([bang_exact(t) for t in te])
    assert np.max(np.abs(Y[:, 0] - exact)) < 1e-8
    # passive crossings of x = 0.5 (g1): first one at sqrt(1/a)
    k1 = ev_k[:n_ev] == 1
    assert abs(ev_t[:n_ev][k1][0] - math.sqrt(1.0 / A_G)) < 1e-10
    if hmax > 0:
        # a step that spans two crossings of g1 cannot see them: hmax is the user's guard
        s1 = math.sqrt(1.0 / A_G)
        expected = [s1, period - s1, period + s1, 2 * period - s1]
        assert np.allclose(ev_t[:n_ev][k1], expected, atol=1e-10, rtol=0)
        assert list(ev_dir[:n_ev][k1]) == [-1, 1, -1, 1]


def test_simultaneous_events_and_log_limit():
    te = np.array([0.0, 4.0 * T1])
    (status, t_r, Y, n_out, stats, ev_t, ev_k, ev_dir, n_ev), z = run_bang(
        te, levels=(0.0,), max_log=3)
    assert status == SUCCESS
    # g0 and g1 are identical: both fire together, twice (at T1 and 3 T1)
    assert n_ev == 4 and stats[4] == 4
    assert ev_t.shape == (3,)
    assert ev_t[0] == ev_t[1] and abs(ev_t[0] - T1) < 1e-10
    assert sorted(ev_k[:2]) == [0, 1]
    assert abs(ev_t[2] - 3 * T1) < 1e-10
    assert z[1] == 2.0
    assert abs(Y[1, 0] - 1.0) < 1e-9


# ------------------------------------------------------------------ 5. landing on t_eval


def test_land_hits_output_times():
    te = np.linspace(0.0, 10.0, 51)
    p = sp(const=1.0)
    free = run_scalar(p, 0.0, te, rtol=1e-6, land=False)
    landed = run_scalar(p, 0.0, te, rtol=1e-6, land=True)
    assert free[0] == landed[0] == SUCCESS
    assert free[4][1] < 10             # y' = 1 is integrated exactly: few, long steps
    assert landed[4][1] >= 50          # every output time is a step end
    # y = t at the step ends (sums of step lengths), no interpolation
    assert np.max(np.abs(landed[2][:, 0] - te)) < 1e-13


def test_land_accuracy_decay():
    te = np.linspace(0.0, 3.0, 41)
    status, _, Y, n_out, _, *_ = run_scalar(sp(decay=-1.0), 1.0, te, rtol=1e-11, atol=1e-15,
                                            land=True)
    assert status == SUCCESS and n_out == 41
    assert np.max(np.abs(Y[:, 0] - np.exp(-te))) < 1e-10


def test_land_on_kink():
    # y' = |t - 1|: smooth on each side of t = 1; a step ending exactly at 1 integrates exactly
    te = np.array([0.0, 0.37, 1.0, 1.6, 2.0])
    exact = np.where(te <= 1.0, te - 0.5 * te**2, 0.5 + 0.5 * (te - 1.0) ** 2)
    p = sp(kink=1.0, t_kink=1.0)
    landed = run_scalar(p, 0.0, te, rtol=1e-5, atol=1e-8, land=True, h0=0.3)
    free = run_scalar(p, 0.0, te, rtol=1e-5, atol=1e-8, land=False, h0=0.3)
    assert landed[0] == free[0] == SUCCESS
    err_landed = np.max(np.abs(landed[2][:, 0] - exact))
    err_free = np.max(np.abs(free[2][:, 0] - exact))
    assert err_landed < 1e-13, err_landed
    assert err_free > 100 * max(err_landed, 1e-15), (err_free, err_landed)


def test_hmax_caps_step():
    status, _, _, _, stats, *_ = run_scalar(sp(const=1.0), 0.0, [0.0, 1.0], hmax=0.01)
    assert status == SUCCESS and stats[1] >= 100


# ------------------------------------------------------------------ 6. failures


def test_blow_up_fails_cleanly():
    # y' = y^2, y(0) = 1: y = 1/(1 - t) blows up at t = 1
    te = np.linspace(0.0, 2.0, 20)
    status, t_r, Y, n_out, stats, *_ = run_scalar(sp(square=1.0), 1.0, te, rtol=1e-8)
    assert status in (STEP_UNDERFLOW, NON_FINITE)
    assert abs(t_r - 1.0) < 1e-6
    assert n_out == int(np.sum(te < 1.0)) == int(np.sum(te <= t_r))
    assert np.all(np.isfinite(Y[:n_out]))
    assert np.allclose(Y[:n_out, 0], 1.0 / (1.0 - te[:n_out]), rtol=1e-6, atol=0)
    assert np.all(np.isnan(Y[n_out:]))
    msg = status_message(status, t_r, stats)
    assert "t = 1" in msg and "\n" not in msg


def test_nan_rhs_is_rejected_then_reported():
    te = np.linspace(0.0, 1.0, 11)
    # NaN from t = 0.55 on: the integrator creeps up to it, then gives up with status -3
    status, t_r, Y, n_out, stats, *_ = run_scalar(sp(decay=-1.0, t_nan=0.55), 1.0, te)
    assert status == NON_FINITE
    assert 0.55 - 1e-9 < t_r < 0.55
    assert n_out == 6 and np.all(np.isfinite(Y[:6])) and np.all(np.isnan(Y[6:]))
    assert np.allclose(Y[:6, 0], np.exp(-te[:6]), rtol=1e-7)
    # NaN from the start: 50 consecutive non-finite rejections
    status, t_r, Y, n_out, stats, *_ = run_scalar(sp(decay=-1.0, t_nan=0.0), 1.0, te)
    assert status == NON_FINITE and t_r == 0.0 and n_out == 1
    assert stats[1] == 0 and stats[2] == 50


def test_max_steps():
    te = np.linspace(0.0, 5.0, 11)
    status, t_r, Y, n_out, stats, *_ = run_scalar(sp(decay=-1.0), 1.0, te, rtol=1e-12,
                                                  atol=1e-16, max_steps=5)
    assert status == MAX_STEPS
    assert stats[0] == 5 and 0.0 < t_r < 5.0
    assert n_out == int(np.sum(te <= t_r))
    assert np.all(np.isfinite(Y[:n_out])) and np.all(np.isnan(Y[n_out:]))
    assert "max_steps" in status_message(status, t_r, stats)


def test_status_messages():
    stats = np.array([10, 8, 2, 61, 0])
    assert status_message(SUCCESS, 2.0, stats).startswith("reached t_end")
    assert "event" in status_message(STOPPED, 0.5, stats)
    msg = status_message(STEP_UNDERFLOW, 0.123, stats)
    assert msg.startswith("step size underflow at t = 0.123 s: the tolerance cannot be met")
    assert "non-finite" in status_message(NON_FINITE, 1.0, stats)
    for s in (SUCCESS, STOPPED, MAX_STEPS, STEP_UNDERFLOW, NON_FINITE, 7):
        assert "\n" not in status_message(s, 1.0, stats)


# ------------------------------------------------------------------ called from jitted code


_DOPRI5_INLINED = inlined(dopri5_core)


@njit
def _jitted_driver(t_eval, p, z, rtol, atol):
    # the jitted core with plain numba functions: the integrator compiled with them inlined
    return _DOPRI5_INLINED(bang_rhs, bang_events, bang_on_event, dopri5_interp, 0.0, np.array([1.0, 0.0]), t_eval,
                       False, p, z, rtol, atol, 0.0, 0.0, 100000, 1, 16, EVENT_SAMPLES)


@pytest.mark.slow
def test_callable_from_jitted_code_and_inlined_equals_indirect():
    """The core called from jitted code with the functions inlined gives the same trajectory,
    events and counts, bit for bit, as the compiled-once integrator with the functions passed as
    first-class function arguments (no arithmetic differs between the two builds). Slow: it
    compiles a whole inlined DOPRI5 (8 s); the default run keeps the same bit-for-bit check on a
    scene (tests/test_compile_once.py, the shipped contact law)."""
    te = np.linspace(0.0, 4.0 * T1, 9)
    p = np.array([A_G, 0.0])
    z = np.array([1.0, 0.0, 0.0])
    out = _jitted_driver(te, p, z, 1e-10, np.array([1e-12, 1e-12]))
    ref, _ = run_bang(te)
    assert out[0] == SUCCESS and out[8] == 2
    assert np.array_equal(out[2], ref[2])
    assert np.array_equal(out[4], ref[4])
    assert np.array_equal(out[5][:2], ref[5][:2])


def test_result_is_named():
    out = dopri5(bang_rhs, bang_events, bang_on_event, 0.0, np.array([1.0, 0.0]),
                 np.linspace(0.0, T1, 3), False, np.array([A_G, 0.0]), np.array([1.0, 0.0, 0.0]),
                 1e-10, np.array([1e-12, 1e-12]), 0.0, 0.0, 100000, 1, 16)
    assert isinstance(out, Solution)
    assert out.status == out[0] == SUCCESS and out.Y is out[2] and out.n_ev == out[8]


def test_plain_python_function_is_refused():
    def rhs(t, y, p, z, dy):
        dy[0] = 1.0
    with pytest.raises(InputError, match="rhs = 'rhs': must be a numba-compiled function"):
        dopri5(rhs, None, None, 0.0, np.array([0.0]), np.array([1.0]), False, EMPTY, EMPTY, 1e-6,
               np.array([1e-9]), 0.0, 0.0, 100, 0, 1)


@pytest.mark.slow
def test_integrator_compiled_once_per_machine(tmp_path):
    """A second process with *another* right-hand side loads dopri5 from numba's disk cache: the
    integrator is compiled once per machine, not per model (quick variant in the default run:
    tests/test_compile_once.py)."""
    (tmp_path / "model_mod.py").write_text(textwrap.dedent("""
        import sys
        import numpy as np
        from numba import njit
        from nld.integrators import dopri5
        from nld.integrators.dopri5 import dopri5_core

        if sys.argv[1] == "a":
            @njit
            def rhs(t, y, p, z, dy):
                dy[0] = -y[0]
        else:
            @njit
            def rhs(t, y, p, z, dy):
                dy[0] = -2.0 * y[0] + 0.5 * t

        out = dopri5(rhs, None, None, 0.0, np.array([1.0]), np.linspace(0.0, 1.0, 3), False,
                     np.zeros(0), np.zeros(0), 1e-8, np.array([1e-12]), 0.0, 0.0, 10000, 0, 1)
        assert out.status == 0
        print(sum(dopri5_core.stats.cache_hits.values()), sum(dopri5_core.stats.cache_misses.values()))
    """))
    env = dict(os.environ)
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env["PYTHONPATH"] = os.pathsep.join([root, env.get("PYTHONPATH", "")])
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "numba-cache")
    env["NLD_AOT"] = "0"            # numba's JIT path (the install-time build: tests/test_aot.py)
    got = []
    for which in ("a", "b"):
        r = subprocess.run([sys.executable, "model_mod.py", which], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
        got.append(tuple(int(v) for v in r.stdout.split()[-2:]))
    assert got == [(0, 1), (1, 0)]
