"""The evidence of chaos control is right (issue 38 item 5) and the controller refuses what it
cannot do (issue 37, classes 1, 5, 6, 7): the closed-loop lambda1 against an exact exponent of a
linear delay equation, the effort's decay rate, a tiny delay refused before any work, the
counts of ogy / run_delayed checked, and a target that needs no control said to need none.
docs/control.md, "The evidence"."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from numba import njit

from nld.analysis import control as C
from nld.cli import main
from nld.errors import InputError
from nld.systems.core import ContinuousSystem, henon


@njit(cache=True)
def two_rates(t, y, p, z, dy):
    dy[0] = -p[0] * y[0]
    dy[1] = -p[1] * y[1]


def _linear_loop(a=0.05, c=0.12, K=0.5, tau=1.0):
    """x' = -a x + K (x(t - tau) - x(t)) (Pyragas' law on x), w' = -c w: a linear delay loop whose
    exponents are the roots of s = -(a + K) + K exp(-s tau) (Lambert W: the largest is real) and
    -c, close below it (the closed loop of a captured orbit has such a spectrum: a slow mode with
    others just below, so that the early intervals, where the perturbation still decays in them,
    biased lambda1)."""
    from scipy.special import lambertw
    S = ContinuousSystem(two_rates, [1.0, 1.0], [a, c], "two_rates", ["x", "w"], period=tau)
    fb = C.pyragas(S, K, tau, "x")
    exact = -(a + K) + lambertw(K * tau * math.exp((a + K) * tau)).real / tau
    assert -c < exact < 0
    return S, fb, float(exact)


@pytest.mark.parametrize("span", [16, 32])
def test_lambda1_interval_covers_the_exact_exponent_of_a_linear_delay_loop(span):
    """Before: 2 intervals of alignment and the batch means' error alone gave -0.0497 +- 0.0037
    (16 tau) and -0.0421 +- 0.0035 (32 tau) for the exact -0.0331."""
    S, fb, exact = _linear_loop()
    r = C.delayed_lyapunov(S, fb, span * fb.delay)
    assert r.status == "ok" and r.settings["align"] == span // 4
    assert abs(r.lambda1 - exact) <= r.uncertainty, (r.lambda1, r.uncertainty, exact)
    assert r.uncertainty < 0.5 * abs(exact)          # and it says something


def test_effort_decay_rate_is_the_slope_after_capture():
    tau = 0.012
    k = np.arange(100)
    eff = np.where(k < 30, 5.0, 2.0 * np.exp(-0.06 * k)) * (1 + 0.01 * np.sin(k))
    rate = C.effort_decay_rate(eff, 30, tau)
    assert rate * tau == pytest.approx(-0.06, abs=2e-3)
    assert math.isnan(C.effort_decay_rate(eff, None, tau))          # not captured
    assert math.isnan(C.effort_decay_rate(eff[:36], 30, tau))       # too few periods after


# ---------------------------------------------------------------- issue 37
def test_a_tiny_delay_is_refused_before_any_work_naming_the_delay():
    S, fb, _ = _linear_loop()
    tiny = fb.with_(delay=1e-9)
    with pytest.raises(InputError) as e:
        C.run_delayed(S, tiny, 100.0)
    msg = str(e.value)
    assert msg.startswith("delay = 1e-09: ") and "\n" not in msg
    assert "shortest delay that fits is" in msg
    assert "revolution" not in msg and "samples_per" not in msg
    shortest = float(msg.rsplit("fits is ", 1)[1].split()[0])
    need, steps, _ = C.delay_run_size(S, shortest * 1.01, 100.0, 50)
    from nld.run.simulate import MAX_OUTPUT_BYTES
    assert need <= MAX_OUTPUT_BYTES and steps <= C.MAX_STEPS       # the value named fits
    with pytest.raises(InputError, match=r"^delay = 1e-09: .*steps"):
        C.delayed_lyapunov(S, tiny, 1.0, interval=1e-3)


def test_cli_tiny_delay_is_one_line_naming_the_option(capsys):
    rc = main(["control", "slider_crank_olyaei", "--set", "joints.B.clearance=2e-4", "--set",
               "joints.B.friction.mu=0", "--delay", "1e-9", "--quiet"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1
    assert err.startswith("nld: error: --delay = 1e-09: a delay that short") and "GiB" in err
    assert "shortest delay that fits is" in err


@pytest.mark.parametrize("kw, words", [
    (dict(n_iter=0), "n_iter = 0: must be a whole number >= 1"),
    (dict(n_iter=-5), "n_iter = -5: must be a whole number >= 1"),
    (dict(n_iter=2.5), "n_iter = 2.5: must be a whole number >= 1"),
    (dict(window=0), "window = 0: must be a whole number >= 1"),
    (dict(lyapunov_iter=-1), "lyapunov_iter = -1: must be a whole number >= 1"),
])
def test_ogy_counts_are_checked(kw, words):
    with pytest.raises(InputError) as e:
        C.ogy(henon(), 0, dp_max=0.1, radius=0.1, **kw)
    assert str(e.value).startswith(words) and "\n" not in str(e.value)


@pytest.mark.parametrize("spd", [0, -3, 1.5])
def test_run_delayed_samples_per_delay_is_checked(spd):
    S, fb, _ = _linear_loop()
    with pytest.raises(InputError) as e:
        C.run_delayed(S, fb, 10.0, samples_per_delay=spd)
    assert str(e.value).startswith(f"samples_per_delay = {spd!r}: must be a whole number >= 1")


def test_ogy_on_a_stable_orbit_says_there_is_nothing_to_control():
    """Hénon at a = 0.2, b = 0.3: the fixed point (1.09, 0.33) is stable (mu 0.37, -0.81); before, ogy
    reported it 'captured' with an effort of 0 -> 0 and a 'controlled' lambda1."""
    H = henon(a=0.2, b=0.3)
    r = C.ogy(H, 0, dp_max=0.1, radius=0.5, n_iter=200, x0=[0.5, 0.2], lyapunov_iter=50)
    assert r.orbit.stable is True
    assert r.status == "nothing to control" and "nothing to control" in r.message
    assert not r.active.any() and np.all(r.dp == 0.0)
    assert r.captured_at is None and math.isnan(r.lambda1_controlled)
    assert np.all(r.gains == 0.0)


def test_ogy_that_never_acts_says_so():
    """The chaotic Hénon map, a radius no iterate comes within: no perturbation, no capture."""
    r = C.ogy(henon(), 0, dp_max=0.1, radius=1e-9, n_iter=50, x0=[0.1, 0.1], lyapunov_iter=20)
    assert r.status == "not controlled" and "no control applied" in r.message
    assert not r.active.any() and r.captured_at is None


def test_cli_ogy_on_a_stable_orbit(capsys):
    # mu = 0, c = 0.05 mm: a stable period-1 motion in permanent contact (test_cli_control)
    rc = main(["control", "slider_crank_olyaei", "--set", "joints.B.friction.mu=0", "--set",
               "joints.B.clearance=5e-5", "--method", "ogy", "--revs", "4", "--transient", "2",
               "--rtol", "1e-7", "--json", "--quiet"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["settings"]["target_orbit"]["stable"] is True
    assert out["status"] == "nothing to control"
    assert "nothing to control" in out["settings"]["message"]
    assert out["captured_at_revolution"] is None and out["lambda1_controlled"] is None
    assert out["settings"]["active_revolutions"] == 0
