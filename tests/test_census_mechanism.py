"""The attractor census on mechanisms and flows against the orbit solver (issue 38, items 1, 2,
7, 9; issue 37, classes 2 and 5 for the census).

The census's periodic attractors are the orbits of Newton shooting that their runs lie on
(nld.analysis.attractors, docs/attractors.md "Period test"): on the impacting slider-crank cell of
issue 38 (clearance 0.2 mm, mu = 0.1: one contact onset per revolution, multipliers -0.5518,
0.1298) the census must report the orbit that ``periodic_orbit`` finds, with λ1 = ln max|μ| and
the tangent estimator's λ1 agreeing with it, and a whole number of onsets per period.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from nld.analysis import attractors as A
from nld.analysis.attractors import census, census_sweep
from nld.errors import InputError, SceneError

@njit(cache=True)
def _cubic(x, p, out):
    """x -> a x - (a - 1) x^3 (as tests/test_attractors.py)."""
    out[0] = p[0] * x[0] - (p[0] - 1.0) * x[0] ** 3


CELL = ["joints.B.clearance=2e-4", "joints.B.friction.mu=0.1"]
RTOL = 1e-10


@pytest.fixture(scope="module")
def cell():
    from nld.systems.core import SceneSystem
    return SceneSystem("slider_crank_olyaei", CELL)


@pytest.fixture(scope="module")
def cell_census(cell):
    # (of the 16 starts of issue 38's command, 12 reach the impacting orbit, 4 permanent contact)
    return census(cell, 3, seed=0, transient=40, record=24, rtol=RTOL, lyapunov_members=1,
                  progress=False)


@pytest.fixture(scope="module")
def cell_orbit(cell):
    from nld.analysis.orbits import periodic_orbit
    return periodic_orbit(cell, 1, rtol=RTOL, transient=50)


def test_the_impacting_orbit_is_a_periodic_attractor(cell_census, cell_orbit):
    """Issue 38 item 1: the runs that settle on the impacting orbit are periodic of period 1,
    not 'unsettled' (their plain-integration section points jitter by ~1e-5..1e-4 of the scales
    at rtol 1e-10, far above 1e3 rtol), and the attractor is the orbit of ``nld orbits``."""
    r = cell_census
    per = [a for a in r.attractors if a.kind == "periodic"]
    assert len(per) == 1, str(r)
    a = per[0]
    assert a.period == 1 and a.count >= 1
    # every run is either on the orbit or in permanent contact (no unsettled run)
    assert r.unsettled == 0 and r.failed == 0, str(r)
    assert set(r.runs["kind"]) <= {"periodic", "permanent contact"}
    # the same orbit as periodic_orbit from the default start: points to the Newton tolerance
    o = cell_orbit
    assert o.converged and o.period == 1
    d = np.max(np.abs(o.map.difference(a.points[0], o.points[0]) / o.map.scales))
    assert d <= 10 * o.tolerance, d
    # λ1 per revolution = ln max|μ| of the independent orbit
    assert a.lambda1 == pytest.approx(math.log(o.max_abs_multiplier), abs=1e-4)
    assert a.lambda1 == pytest.approx(-0.5946, abs=2e-3)
    # second method: the tangent estimator along the census runs agrees within its uncertainty
    assert math.isfinite(a.lambda1_tangent)
    assert abs(a.lambda1_tangent - a.lambda1) <= 3 * a.lambda1_tangent_uncertainty + 0.01


def test_a_periodic_attractor_has_whole_onsets_per_period(cell_census, cell_orbit):
    """Issue 38 item 2: a period-p attractor has a whole number of contact onsets per period (the
    orbit's), equal to the count of the orbit from Newton; one orbit is one attractor."""
    a = [a for a in cell_census.attractors if a.kind == "periodic"][0]
    assert a.onsets_per_orbit == cell_orbit.onsets_per_period == 1
    assert a.onsets_per_period * a.period == a.onsets_per_orbit
    # each of its runs counted one onset per revolution over its record
    runs = cell_census.runs
    got = runs[runs["attractor"] == a.id]["onsets_per_period"].to_numpy()
    assert np.all(np.abs(got - 1.0) <= 1.0 / 24 + 1e-12), got
    # and the section run counts them revolution by revolution: one in each
    from nld.systems.derived import StroboscopicMap
    sm = StroboscopicMap(cell_orbit.map.flow, rtol=RTOL)
    sr = sm.orbit(a.points[0], a.orbit.z[0], 6, relabel=False)
    assert sr.step_onsets.tolist() == [[1]] * 6
    d = a.to_dict()
    assert d["onsets_per_orbit"] == 1 and len(d["multipliers"]) == 5
    assert np.allclose(d["orbit_points"], a.points) and len(d["orbit_points"]) == 1


def test_a_fractional_onset_count_is_not_periodic():
    """Issue 38 item 2: a run that passes the section's period test with onsets that differ from
    period to period (a grazing contact that comes and goes: 1.045 per revolution) is not called
    periodic; the same number in every period is."""
    X = np.zeros((40, 2))

    def run(mean, period, steps=None):
        r = A._Run("ok", X, np.zeros(0), mean, False, {}, period, 1e-6)
        if steps is not None:
            r.step_onsets = np.asarray(steps, dtype=np.int64)
        return r
    assert not A._whole_onsets(run(1.045, 1))                       # from the mean alone
    assert A._whole_onsets(run(1.5, 2))                             # 3 onsets per 2 revolutions
    assert A._whole_onsets(run(0.0, 1))
    # from the per-revolution counts of the settled half of the record
    assert A._whole_onsets(run(1.5, 2, [1, 2] * 20))
    assert not A._whole_onsets(run(1.05, 1, [1] * 38 + [2, 1]))
    assert not A._whole_onsets(run(1.5, 1, [1, 2] * 20))


def test_one_period_test():
    """Issue 38 item 1: nld poincare and the census decide periodicity with one function."""
    from nld.analysis import poincare
    assert A.section_period is poincare.section_period
    rng = np.random.default_rng(1)
    X = np.tile(np.array([[0.0, 1.0], [2.0, 3.0], [4.0, 5.0]]), (10, 1))
    X += 1e-8 * rng.standard_normal(X.shape)
    assert poincare.period_of(X, tol=1e-6, scale=[1.0, 1.0]) == 3
    assert A.section_period(X, [1.0, 1.0], tol=1e-6, max_period=8) == 3
    assert A.section_period(X, [1.0, 1.0], tol=1e-9, max_period=8) == 0


def test_census_of_an_autonomous_flow_through_a_poincare_map():
    """Issue 38 item 7: an autonomous flow's census through a Poincaré map. Lorenz at rho = 350
    has a stable symmetric periodic orbit (section x = 0, upward): the census finds it as the
    orbit of periodic_orbit, λ1 per return = ln max|μ|, and the runs' distance to it shrinks by
    max|μ| per return (a second method)."""
    from nld.analysis.orbits import periodic_orbit
    from nld.systems.core import lorenz
    from nld.systems.derived import PoincareMap
    s = lorenz(rho=350.0)
    with pytest.raises(InputError, match="autonomous flow"):
        census(s, 2, sampler=((-10, -10, 340), (10, 10, 360)))
    r = census(s, 3, sampler=((-10, -10, 340), (10, 10, 360)), section=([1, 0, 0], 0.0, 1),
               transient=20, record=40, rtol=1e-9, progress=False)
    assert [a.kind for a in r.attractors] == ["periodic"], str(r)
    a = r.attractors[0]
    assert a.period == 1 and a.count == 3 and r.unsettled == 0
    pm = PoincareMap(s, [1, 0, 0], 0.0, 1, rtol=1e-9)
    o = periodic_orbit(pm, 1, transient=30)
    assert o.converged
    assert np.max(np.abs(a.points[0] - o.points[0])) <= 1e-6
    assert a.lambda1 == pytest.approx(math.log(o.max_abs_multiplier), abs=1e-6)
    # contraction of a run towards the orbit, return by return
    x, z = pm.y0.copy(), pm.z0.copy()
    d = []
    for _ in range(30):
        st = pm.step(x, z)
        x, z = st.x, st.z
        d.append(float(np.max(np.abs(x - o.points[0]))))
    ratio = (d[25] / d[15]) ** (1 / 10)
    assert ratio == pytest.approx(o.max_abs_multiplier, rel=0.02)


def test_census_arguments_are_checked():
    """Issue 37 class 5: workers, a sampler's non-finite state or discrete state of the wrong
    length: one InputError naming the argument."""
    from nld.systems.core import DiscreteMap, duffing
    m = DiscreteMap(_cubic, [0.3], [1.2], "cubic map")
    with pytest.raises(InputError, match="workers = 0"):
        census(m, 4, sampler=((-1.0,), (1.0,)), workers=0)
    with pytest.raises(InputError, match="non-finite"):
        census(m, 4, sampler=lambda rng: np.array([np.nan]))
    with pytest.raises(InputError, match="discrete state z of 3 values"):
        census(m, 4, sampler=lambda rng: (np.array([0.1]), np.zeros(3)))
    with pytest.raises(InputError, match="sampler = \\(lo, hi\\)"):
        census(m, 4, sampler=((-np.inf,), (1.0,)))
    with pytest.raises(InputError, match="section"):
        census(duffing(), 2, sampler=((-1, -1), (1, 1)), section=([1, 0], 0.0))


def test_census_sweep_checks_every_value_first(tmp_path, monkeypatch):
    """Issue 37 class 2: ``nld attractors --param --values A,B`` checks every value before any
    census runs (it checked only the first and failed at B after A's work)."""
    calls = []
    monkeypatch.setattr(A, "census", lambda *a, **k: calls.append(1))
    out = tmp_path / "sweep"
    with pytest.raises((InputError, SceneError), match="joints.B.clearance = -1"):
        census_sweep("slider_crank_olyaei", "joints.B.clearance", [2e-4, -1.0], out=out,
                     starts=1, workers=1, progress=False)
    assert not calls and not (out.exists() and any(out.iterdir()))


def test_cli_values_checked_before_work(tmp_path, capsys):
    from nld.cli.app import main
    out = tmp_path / "sw"
    assert main(["attractors", "slider_crank_olyaei", "--param", "joints.B.clearance",
                 "--values", "2e-4,-1", "--out", str(out), "--starts", "1", "--workers",
                 "1"]) == 2
    assert "joints.B.clearance = -1" in capsys.readouterr().err
    assert not (out.exists() and any(out.iterdir()))



@pytest.mark.slow
def test_impacts_that_stop_are_permanent_contact_not_periodic():
    """Issue 38 item 2 on a mechanism: the committed olyaei2012 census (mu = 0.05, 4750 rpm,
    starts of seed 0, transient and record 100, rtol 1e-9) listed start 11 as "periodic, period
    1" with 0.4 contact onsets per revolution: its journal impacted early in the record and then
    stayed in contact. It is permanent contact (no onset over the settled window; its Newton orbit
    has the memory's neutral multiplier), and no periodic attractor has a fractional onset count.
    Quick variants in the default run: the slider-crank cell above and the unit cases."""
    from nld.systems.core import SceneSystem
    s = SceneSystem("slider_crank_olyaei", ["joints.B.friction.mu=0.05",
                                            f"driver.speed={4750 * math.pi / 30!r}"])
    sample = A.scene_sampler(s)
    rng = np.random.default_rng(0)
    y, z = [sample(rng) for _ in range(12)][11]
    r = census(s, 1, sampler=lambda rng: (y.copy(), z.copy()), transient=100, record=100,
               rtol=1e-9, lyapunov_members=1, check=False, progress=False)
    assert [a.kind for a in r.attractors] == ["permanent contact"], str(r)
    assert r.attractors[0].onsets_per_period == 0.0
