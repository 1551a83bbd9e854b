"""nld.analysis.peaks.peak_interval: coverage of the true mean on synthetic series (AR(1) with known
mean and correlation, i.i.d.), the realisation pool, and bad input. About 2 s."""
import math

import numpy as np
import pytest

from nld.analysis.peaks import integrated_autocorrelation_time, peak_interval
from nld.errors import InputError

MU = 3.0


def ar1(rng, n, phi, mu=MU):
    """Stationary AR(1): x_i = phi x_{i-1} + e_i, e ~ N(0, 1), started from its stationary law."""
    e = rng.standard_normal(n)
    x = np.empty(n)
    x[0] = e[0] / math.sqrt(1.0 - phi * phi)
    for i in range(1, n):
        x[i] = phi * x[i - 1] + e[i]
    return mu + x


def test_tau_of_ar1():
    """tau = (1 + phi) / (1 - phi) for AR(1): 3 at phi = 0.5 (long series, within 15 %)."""
    rng = np.random.default_rng(0)
    assert integrated_autocorrelation_time(ar1(rng, 20000, 0.5)) == pytest.approx(3.0, rel=0.15)
    assert integrated_autocorrelation_time(ar1(rng, 20000, 0.0)) == pytest.approx(1.0, abs=0.1)


def test_ar1_batch_means_cover_at_the_stated_rate():
    """Correlated series (phi = 0.5, n = 200): the 95 % batch-means interval covers the true mean in
    about 95 % of 400 seeded replicates (binomial sd 1.1 %: 0.90 - 0.985 accepted), where the plain
    standard error (1.96 x SE) covers about 72 %."""
    rng = np.random.default_rng(7)
    R, cover, naive = 400, 0, 0
    for _ in range(R):
        x = ar1(rng, 200, 0.5)
        iv = peak_interval(x)
        assert iv.method == "batch means" and iv.level == 0.95 and iv.batch >= 5
        cover += iv.contains(MU)
        naive += abs(iv.mean - MU) <= 1.96 * iv.naive_se
    assert 0.90 <= cover / R <= 0.985
    assert naive / R < 0.80


def test_iid_agrees_with_plain_se():
    """Independent values (n = 400): the interval covers at about 95 % and its half-width is within
    15 % of 1.96 plain standard errors on average."""
    rng = np.random.default_rng(3)
    R, cover, ratio = 300, 0, []
    for _ in range(R):
        x = MU + rng.standard_normal(400)
        iv = peak_interval(x)
        cover += iv.contains(MU)
        ratio.append(iv.half_width / (1.96 * x.std(ddof=1) / math.sqrt(x.size)))
        assert iv.naive_se == pytest.approx(x.std(ddof=1) / 20.0)
    assert 0.91 <= cover / R <= 0.985
    assert np.mean(ratio) == pytest.approx(1.0, abs=0.15)


def test_realisations_pool_covers():
    """K = 10 independent strongly correlated realisations (phi = 0.8, 20 values each): the pooled
    t interval over realisation means covers at about 95 % (300 replicates)."""
    rng = np.random.default_rng(11)
    R, cover = 300, 0
    for _ in range(R):
        iv = peak_interval([ar1(rng, 20, 0.8) for _ in range(10)])
        assert iv.method == "realisations" and iv.realisations == 10 and iv.dof == 9 and iv.n == 200
        cover += iv.contains(MU)
    assert 0.91 <= cover / R <= 0.985


def test_describe_states_level_and_method():
    iv = peak_interval(np.arange(40.0) % 7, level=0.9)
    assert "90 % Student-t" in iv.describe() and "batch means" in iv.describe()
    assert iv.lower < iv.mean < iv.upper
    pool = peak_interval([[1.0, 2.0], [2.0, 3.0], [1.5, 2.5]])
    assert pool.mean == pytest.approx(2.0) and "3 independent realisations" in str(pool)


@pytest.mark.parametrize("args, kw, word", [
    (([1.0, 2.0, 3.0],), {"level": 1.5}, "level"),
    (([1.0, 2.0, 3.0],), {"level": True}, "level"),
    (([1.0, 2.0, 3.0],), {"batch_factor": 0}, "batch_factor"),
    (([1.0, 2.0, 3.0],), {"window_c": -1}, "window_c"),
    (([1.0],), {}, "peaks"),
    (([1.0, float("nan"), 2.0],), {}, "peaks"),
    (([[1.0, 2.0], [np.inf, 1.0]],), {}, "peaks"),
    (([],), {}, "peaks"),
])
def test_bad_input(args, kw, word):
    with pytest.raises(InputError, match=word) as e:
        peak_interval(*args, **kw)
    assert "\n" not in str(e.value)


def test_slider_crank_realisations_agree_within_their_intervals():
    """Quick variant of benchmarks/peak_intervals.py: 10 seeded perturbed realisations of the
    chaotic, impacting slider_crank (10 transient + 20 steady revolutions, 720 detection samples):
    each realisation's 95 % batch-means interval of max |rod omega| contains the pooled value of the
    other nine in at least 8 of 10 (expected 9.5; P(<= 7 | 0.95) = 1 %; measured 10, the plain
    +- SE 6), and the realisations are
    distinct runs. About 2 s with a warm kernel cache."""
    from nld.analysis.extrema import revolution_maxima
    from nld.kernel.compile import compile_scene
    from nld.model.scene import resolve_scene
    from nld.run.simulate import initial_state
    kern = compile_scene(resolve_scene("slider_crank", None))
    y, _, _ = initial_state(kern)
    series = []
    for seed in range(10):
        y0 = y * (1.0 + 1e-6 * np.random.default_rng(seed).standard_normal(y.size))
        run = revolution_maxima("slider_crank", ["rod.omega"], revs=20, transient_revs=10,
                                samples_per_rev=720, keep_every=10, keep_revs=0, refine_top=2,
                                kernel=kern, y0=y0)
        assert run.success, run.message
        series.append(run.maxima["peak"].to_numpy(float))
    assert len({s[0] for s in series}) == 10
    total, count = sum(s.sum() for s in series), sum(s.size for s in series)
    inside = sum(peak_interval(s).contains((total - s.sum()) / (count - s.size)) for s in series)
    assert inside >= 8, inside
    pool = peak_interval(series)
    assert pool.realisations == 10 and pool.half_width < np.median([peak_interval(s).half_width
                                                                      for s in series])
