"""The uncertainty that ``nld lyapunov`` calls "about 95 %" covers published exponents (issue 25,
item 4; benchmarks/lyapunov_coverage.py, benchmarks/results/lyapunov_coverage.md).

The quick check re-evaluates nld's interval rule (``uncertainty_from_rates``: what
``lyapunov_tangent`` reports) on the recorded per-period local rates of 700 default tangent runs
(7 systems of Sprott 2003, Appendix A, x 100 seeded starting states): no integration, so no
compilation. The slow one integrates: it checks that a recorded run is what the estimator gives
today, and coverage on fresh runs from other starting states.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from nld.analysis.lyapunov import uncertainty_from_rates

DATA = Path(__file__).resolve().parents[1] / "benchmarks" / "results" / "lyapunov_coverage.npz"


def _recorded():
    z = np.load(DATA)
    return z, [str(s) for s in z["systems"]]


def _coverage(length: int):
    """Pooled and per-system fraction of recorded runs whose interval over their first
    ``length`` periods covers the published value (within its precision); runs whose full
    estimate is negative (another attractor) are left out (there are none)."""
    z, names = _recorded()
    hits = total = 0
    per = {}
    for name in names:
        ref, prec = float(z[f"{name}_ref"]), float(z[f"{name}_prec"])
        other = z[f"{name}_rows"][:, 0] < 0.0
        h = n = 0
        for x, o in zip(z[f"{name}_rates"][:, :length], other):
            if o:
                continue
            est, unc = uncertainty_from_rates(x)
            h += abs(est - ref) <= unc + prec
            n += 1
        per[name] = h / n
        hits += h
        total += n
    return hits / total, per, total


@pytest.mark.parametrize("length", [200, 100, 50])
def test_interval_covers_published_exponents_on_recorded_runs(length):
    """Over the default 200 periods (time units) and over 100 and 50 (chaos maps, studies), the
    interval covers the published lambda1 in 93 - 97.5 % of the 700 runs pooled (95 % within
    about 2.5 binomial standard deviations, 0.8 % each), and in at least 88 % on every system.
    The rule before issue 25 (2.1 x the blocking standard error) covered 92.9 % over 50 periods
    and fails; an interval made twice as wide would cover ~100 % and fails too. Measured with the
    t quantile: 94.1 / 95.9 / 94.1 % pooled, 90 % the worst system."""
    pooled, per, total = _coverage(length)
    assert total == 700
    assert 0.93 <= pooled <= 0.975, (length, pooled, per)
    assert min(per.values()) >= 0.88, (length, per)


def test_recorded_runs_cover_forced_oscillators_and_flows():
    """The fixture holds the issue's kinds of system with published small exponents: forced
    (Duffing-type) oscillators and autonomous flows, each with 100 runs."""
    z, names = _recorded()
    assert {"ueda", "duffing_two_well", "lorenz", "rossler"} <= set(names)
    for name in names:
        assert z[f"{name}_rates"].shape == (100, 200)
        assert 0.0 < float(z[f"{name}_ref"]) < 1.0


# ---------------------------------------------------------------- slow: fresh integrations
def _ueda(y0):
    from nld.systems.core import duffing
    return duffing(delta=0.05, alpha=0.0, beta=1.0, gamma=7.5, omega=1.0, y0=y0)


def _two_well(y0):
    from nld.systems.core import duffing
    return duffing(delta=0.25, alpha=-1.0, beta=1.0, gamma=0.4, omega=1.0, y0=y0)


@pytest.mark.slow
def test_recorded_run_is_what_the_estimator_gives_now():
    """Run 7 of the recorded Ueda runs (start and seed from the fixture) reproduces its estimate,
    and its reported uncertainty is the rule's value on its rates: the fixture is today's."""
    from nld.analysis.lyapunov import lyapunov_tangent
    z, _ = _recorded()
    r = lyapunov_tangent(_ueda(z["ueda_y0"][7]), seed=7, progress=False)
    assert r.exponent == pytest.approx(z["ueda_rows"][7, 0], rel=1e-6, abs=1e-9)
    assert r.uncertainty == pytest.approx(uncertainty_from_rates(r.local_rates)[1], rel=1e-12)


@pytest.mark.slow
def test_default_interval_covers_published_forced_oscillators():
    """120 fresh default runs (60 each of Ueda, 0.1034, and Duffing's two-well oscillator, 0.1572;
    Sprott 2003 A.4.5, A.4.6) from starting states the fixture does not use: at least 108 covered
    (90 %; with 95 % coverage 6 misses are expected and 13 or more happen with probability
    below 1 %)."""
    from nld.analysis.lyapunov import lyapunov_tangent
    rng = np.random.default_rng(25)
    hits = 0
    for make, ref, box in ((_ueda, 0.1034, 3.0), (_two_well, 0.1572, 2.0)):
        for i in range(60):
            y0 = rng.uniform(-box, box, 2)
            r = lyapunov_tangent(make(y0), seed=100 + i, progress=False)
            assert math.isfinite(r.uncertainty) and r.exponent > 0.0
            hits += abs(r.exponent - ref) <= r.uncertainty + 1e-4
    assert hits >= 108, hits
