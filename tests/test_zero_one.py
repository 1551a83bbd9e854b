"""The 0-1 test for chaos (nld.analysis.zero_one): logistic map (chaotic r = 4, 3.6; periodic r = 3.5,
3.83), its mean-square displacement against the definition, invariances, input checks, and a
scene's stroboscopic series against the sign of the largest Lyapunov exponent."""
import math

import numpy as np
import pytest

from nld.errors import InputError
from nld.analysis.zero_one import _msd, zero_one_test


def logistic(r, n, x=0.3, transient=1000):
    out = np.empty(n)
    for _ in range(transient):
        x = r * x * (1 - x)
    for i in range(n):
        x = r * x * (1 - x)
        out[i] = x
    return out


@pytest.mark.parametrize("r, lo, hi", [(4.0, 0.99, 1.0),      # lambda = ln 2
                                       (3.6, 0.8, 1.0),       # weakly chaotic, lambda ~ 0.18
                                       (3.5, -0.05, 0.05),    # period 4
                                       (3.83, -0.05, 0.05)])  # period 3 window
def test_logistic(r, lo, hi):
    res = zero_one_test(logistic(r, 1000))
    assert lo <= res.K <= hi, res
    assert res.N == 1000 and res.n_cut == 100 and res.Kc.shape == res.c.shape == (100,)
    assert np.all((res.c > math.pi / 5) & (res.c < 4 * math.pi / 5))
    assert res.D.shape == (100, 100)


def test_msd_equals_the_definition():
    """The FFT sums equal the direct mean over j of |p(j+n)-p(j)|^2 + |q(j+n)-q(j)|^2."""
    x = logistic(4.0, 300)
    c = np.array([0.9, 1.7, 2.4])
    M = _msd(x, c, 30)
    j = np.arange(1, 301)
    for k, cc in enumerate(c):
        p, q = np.cumsum(x * np.cos(j * cc)), np.cumsum(x * np.sin(j * cc))
        ref = [np.mean((p[n:] - p[:-n]) ** 2 + (q[n:] - q[:-n]) ** 2) for n in range(1, 31)]
        np.testing.assert_allclose(M[k], ref, rtol=1e-11)


def test_invariances_and_determinism():
    x, y = logistic(4.0, 600), logistic(3.5, 600)
    for form in ("paper", "mean_free"):                     # scale: a correlation coefficient
        assert zero_one_test(1e-6 * x, form=form).K == pytest.approx(zero_one_test(x, form=form).K,
                                                                     abs=1e-9)
    # mean: exactly with the mean-free form; the paper's form to its zero-mean cross term
    for s in (x, y):
        assert zero_one_test(3 * s + 7, form="mean_free").K == pytest.approx(
            zero_one_test(s, form="mean_free").K, abs=1e-9)
        assert zero_one_test(3 * s + 7).K == pytest.approx(zero_one_test(s).K, abs=5e-3)
        assert zero_one_test(s).K == pytest.approx(zero_one_test(s, form="mean_free").K, abs=5e-3)
    # the paper's D_c is M_c - V_osc of the series itself
    c = np.array([1.1])
    xi = np.arange(1, 61)
    d_paper = _msd(x, c, 60)[0] - x.mean() ** 2 * (1 - np.cos(c[0] * xi)) / (1 - np.cos(c[0]))
    np.testing.assert_allclose(zero_one_test(x, c=c, n_cut=60).D[0], d_paper, rtol=1e-12)
    d_free = zero_one_test(x, c=c, n_cut=60, form="mean_free").D[0]
    assert 0 < np.max(np.abs(d_paper - d_free)) < 0.1 * np.max(d_free)
    a, b = zero_one_test(x), zero_one_test(x)
    assert a.K == b.K and np.array_equal(a.c, b.c)          # fixed seed
    assert zero_one_test(x, seed=1).c[0] != a.c[0]


def test_constant_and_noise():
    """A constant is regular (K = 0). Zero-mean noise reads as chaos in both forms, and so does
    small noise on a large mean in the mean-free form; in the paper's form K is then set by the
    cross term and means nothing (0.57 here). atol declares such a series a fixed point."""
    assert zero_one_test(np.full(100, 0.25)).K == 0.0
    noise = 1e-12 * np.random.default_rng(0).standard_normal(300)
    assert zero_one_test(noise).K > 0.9 and zero_one_test(noise, form="mean_free").K > 0.9
    assert zero_one_test(0.25 + noise, form="mean_free").K > 0.9
    for form in ("paper", "mean_free"):
        assert zero_one_test(0.25 + noise, atol=1e-9, form=form).K == 0.0
    # a quasi-periodic series is regular
    n = np.arange(2000)
    assert abs(zero_one_test(np.sin(0.7 * n) + np.cos(math.sqrt(2) * n)).K) < 0.05


def test_bad_input():
    with pytest.raises(InputError, match="too few"):
        zero_one_test(np.arange(20.0))
    with pytest.raises(InputError, match="finite"):
        zero_one_test(np.r_[np.arange(100.0), np.nan])
    with pytest.raises(InputError, match="c_range"):
        zero_one_test(logistic(4.0, 100), c_range=(0.0, 1.0))
    with pytest.raises(InputError, match="n_cut"):
        zero_one_test(logistic(4.0, 100), n_cut=2)
    with pytest.raises(InputError, match="frequencies"):
        zero_one_test(logistic(4.0, 100), c=[4.0])
    with pytest.raises(InputError, match="form"):
        zero_one_test(logistic(4.0, 100), form="other")
    with pytest.raises(InputError, match="1-D"):
        zero_one_test(np.zeros((10, 10)))


# ------------------------------------------------------------------ a scene
C = 0.5e-3                     # slider_crank's clearance at B (m)


def _section_and_exponent(overrides, transient):
    """100 stroboscopic points of B.ex at rtol 1e-10, then lambda1 (Benettin) over 20 revolutions
    from the end of the section. rtol 1e-10: at 1e-8 and 1e-9 the periodic case's section wanders
    over the clearance (lambda ~ +3 per revolution, K ~ 1): see docs/analysis.md."""
    from nld.analysis.lyapunov import lyapunov_tangent
    from nld.analysis.poincare import stroboscopic
    from nld.systems.core import SceneSystem
    sec = stroboscopic("slider_crank", transient_revs=transient, revs=100, overrides=overrides,
                       rtol=1e-10)
    s = SceneSystem("slider_crank", overrides)
    s.y0, s.z0 = sec.y_final.copy(), sec.z_final.copy()
    return sec.table["B.ex"].to_numpy(), lyapunov_tangent(s, transient=0.0, total=20 * s.period)


def test_scene_chaotic_series():
    """Default slider-crank (5000 rpm, lambda ~ 5 per revolution): K ~ 1 and lambda1 > 0."""
    x, lam = _section_and_exponent(None, 10)
    res = zero_one_test(x)
    assert np.ptp(x) > 0.3 * C                     # the section covers the clearance
    assert res.K > 0.95 and res.spread < 0.05, res
    assert zero_one_test(x, form="mean_free").K > 0.95
    assert lam.exponent - lam.uncertainty > 0, lam


def test_scene_periodic_series():
    """50 rad/s, restitution 0.5 (period 1, lambda ~ -0.5 per revolution). After 20 revolutions the
    section still carries a decaying transient (7e-6 c over the 100 points), later only integration
    noise (1e-7 c). The paper's form reads it as regular, K ~ 0, agreeing with lambda1 < 0. The
    mean-free form sees only the transient and noise and gives K ~ 0.8, which is why a period-1
    section needs the paper's form or a tolerance (atol, as period_of's)."""
    x, lam = _section_and_exponent(["driver.speed=50", "joints.B.contact.restitution=0.5"], 20)
    assert 1e-6 * C < np.ptp(x) < 1e-4 * C
    res = zero_one_test(x)
    assert abs(res.K) < 0.2, res
    assert lam.exponent + lam.uncertainty < 0, lam
    assert zero_one_test(x, form="mean_free").K > 0.5
    assert zero_one_test(x[20:], atol=1e-6 * C, form="mean_free").K == 0.0
