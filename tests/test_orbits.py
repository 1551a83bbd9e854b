"""Periodic orbits (nld.analysis.orbits) and the derived maps (nld.systems.derived): orbits and
multipliers against closed forms, published orbit counts, finite differences and the tangent
exponent (issue 24)."""
import math

import numpy as np
import pytest
from numba import njit

from nld.analysis.orbits import find_orbits, periodic_orbit
from nld.errors import InputError
from nld.systems import ContinuousSystem, PoincareMap, StroboscopicMap, henon, impact_oscillator, logistic

import impact_closed_form as closed


# ------------------------------------------------------------------ maps with known orbits
def test_henon_fixed_point_and_its_eigenvalues_closed_form():
    a, b = 1.4, 0.3
    o = periodic_orbit(henon(a, b), 1, [0.5, 0.1])
    xs = (-(1 - b) + math.sqrt((1 - b) ** 2 + 4 * a)) / (2 * a)
    assert o.converged
    assert np.allclose(o.points[0], [xs, b * xs], atol=1e-12)
    lam = np.sort(np.linalg.eigvals(np.array([[-2 * a * xs, 1.0], [b, 0.0]])).real)
    assert np.allclose(np.sort(o.multipliers.real), lam, atol=1e-10)
    assert o.stable is False                      # a saddle


def test_logistic_period_two_orbit_and_multiplier():
    o = periodic_orbit(logistic(4.0), 2, [0.3])
    pts = np.sort(o.points.ravel())
    assert np.allclose(pts, [(5 - math.sqrt(5)) / 8, (5 + math.sqrt(5)) / 8], atol=1e-12)
    # f'(x1) f'(x2) = 16 (1 - 2 x1)(1 - 2 x2) = -4
    assert o.multipliers.size == 1 and abs(o.multipliers[0] - (-4.0)) < 1e-9


# the default seeds (400 close returns a period, a 20 x 20 grid) under -m slow (12 s of Newton
# solves in Python); the default run seeds from 100 close returns and a 10 x 10 grid (3 s), which
# still needs the grid for the fixed point off the attractor (without it: 1 of the 2)
@pytest.mark.parametrize("seeds", [dict(seeds_per_period=100, grid=10),
                                   pytest.param(dict(grid=20), marks=pytest.mark.slow)])
def test_henon_orbit_count_matches_published_table(seeds):
    # prime-period orbits of the Henon map at (1.4, 0.3), periods 1..8: 2, 1, 0, 1, 0, 2, 4, 7
    # (Alligood, Sauer & Yorke 1996, Table 5.1 from Biham & Wenzel; Davidchack & Lai 1999)
    orbs = find_orbits(henon(), 8, **seeds)
    counts = [sum(1 for o in orbs if o.period == p) for p in range(1, 9)]
    assert counts == [2, 1, 0, 1, 0, 2, 4, 7]
    for o in orbs:          # each a true orbit of its period, and unstable (a chaotic saddle's)
        assert o.residual < 1e-10 and o.stable is False


def test_stabilising_transformations_alone_find_the_published_orbits():
    # Schmelcher & Diakonos: x <- x + lam C (f^p(x) - x) over the 8 signed permutations C, from 60
    # attractor points, no close-return or grid seeds: the same 2, 1, 0, 1, 0, 2, 4, 7 (the
    # fixed point off the attractor included)
    orbs = find_orbits(henon(), 8, seeds_per_period=0, stabilising=60)
    assert [sum(1 for o in orbs if o.period == p) for p in range(1, 9)] == [2, 1, 0, 1, 0, 2, 4, 7]


def test_newton_that_fails_says_so_and_returns_its_best_iterate():
    o = periodic_orbit(henon(), 7, np.full((7, 2), 5.0), max_iter=3)
    assert not o.converged
    assert "converge" in o.message or "stalled" in o.message
    assert o.stable is None


# ------------------------------------------------------------------ the impact oscillator
P0 = [0.05, 0.8, 1.0, 1.5, 10.0, 0.5]


@pytest.fixture(scope="module")
def reference():
    return closed.periodic_orbit(P0, [1.8, 0.3])


def test_impact_oscillator_orbit_and_multipliers_match_the_closed_form(reference):
    x_ref, M_ref, n_ref, v_ref = reference
    o = periodic_orbit(impact_oscillator(*P0), 1, [1.0, 0.5], rtol=1e-12)
    assert o.converged and o.stable is True
    assert np.max(np.abs(o.points[0] - x_ref)) < 1e-8
    mu_ref = np.linalg.eigvals(M_ref)
    assert np.max(np.abs(np.sort_complex(o.multipliers) - np.sort_complex(mu_ref))) < 1e-8
    assert np.max(np.abs(o.monodromy - M_ref)) < 1e-8
    # the stated uncertainty covers the true error and is not absurdly wide
    err = np.max(np.abs(np.sort_complex(o.multipliers) - np.sort_complex(mu_ref)))
    assert err <= np.max(o.multiplier_error) + 1e-12 and np.max(o.multiplier_error) < 1e-6
    assert o.onsets_per_period == n_ref == 1
    assert abs(o.min_approach_speed - v_ref) < 1e-8
    # Liouville: ln|det M| = int tr J dt + sum ln|det S|
    assert abs(o.det_check["difference"]) < 1e-8


def test_stroboscopic_monodromy_over_three_periods_matches_the_closed_form(reference):
    # six contact events (three onsets, three separations) inside one map step
    x_ref = reference[0] + np.array([0.02, -0.03])
    T3 = 3 * 2 * math.pi / P0[1]
    x_end, M_ref, n_on, _ = closed.flow(P0, x_ref, T3)
    m = StroboscopicMap(impact_oscillator(*P0), 3, rtol=1e-12)
    st = m.step(x_ref, relabel=True, jacobian=True)
    assert n_on == 3 and int(st.onsets[0]) == 3
    assert np.max(np.abs(st.x - x_end)) < 1e-9
    assert np.max(np.abs(st.M - M_ref)) < 1e-8


def test_stable_orbit_multiplier_equals_the_tangent_exponent():
    from nld.analysis.lyapunov import lyapunov_tangent
    S = impact_oscillator(*P0)
    o = periodic_orbit(S, 1, [1.0, 0.5], rtol=1e-11)
    S.y0 = o.points[0]
    S.z0 = o.z[0]
    lam = lyapunov_tangent(S, 1, transient=0.0, total=40 * S.period, rtol=1e-11)
    per_period = lam.exponent * S.period
    assert abs(per_period - math.log(o.max_abs_multiplier)) < max(3 * lam.uncertainty * S.period, 1e-3)


def test_distance_to_grazing_is_the_closed_form_approach_speed():
    # a smaller stop offset: deeper impacts, larger approach speed than the default's
    o1 = periodic_orbit(impact_oscillator(*P0), 1, [1.8, 0.3], rtol=1e-11)
    p2 = list(P0)
    p2[3] = 1.3
    o2 = periodic_orbit(impact_oscillator(*p2), 1, [1.6, 0.3], rtol=1e-11)
    ref2 = closed.periodic_orbit(p2, o2.points[0])
    assert o2.converged and abs(o2.min_approach_speed - ref2[3]) < 1e-7
    assert o2.min_approach_speed > o1.min_approach_speed


# ------------------------------------------------------------------ a Poincaré map
@njit(cache=True)
def hopf_rhs(t, y, p, z, dy):
    r2 = y[0] * y[0] + y[1] * y[1]
    dy[0] = (p[0] - r2) * y[0] - p[1] * y[1]
    dy[1] = p[1] * y[0] + (p[0] - r2) * y[1]


def test_poincare_map_limit_cycle_multiplier_closed_form():
    # r' = r (a - r^2), theta' = w: limit cycle r = sqrt(a), period 2 pi / w, multiplier
    # exp(-2 a 2 pi / w) of the section y = 0, x > 0
    a, w = 1.0, 2.0
    S = ContinuousSystem(hopf_rhs, [0.5, 0.0], [a, w], "hopf")
    P = PoincareMap(S, [0.0, 1.0], 0.0, +1, dt=0.05)
    o = periodic_orbit(P, 1, [0.5, 0.0], rtol=1e-10)
    assert o.converged
    assert abs(o.points[0, 0] - math.sqrt(a)) < 1e-8
    assert o.multipliers.size == 1
    assert abs(o.multipliers[0].real - math.exp(-2 * a * 2 * math.pi / w)) < 1e-8


# ------------------------------------------------------------------ a clearance scene
def test_scene_monodromy_equals_central_differences_through_contact_events():
    from nld.systems import SceneSystem
    from nld.analysis.orbits import section_points
    S = SceneSystem("slider_crank")
    m = StroboscopicMap(S, 1, rtol=1e-12)
    X, Z = section_points(m, m.y0, m.z0, 6)
    x, z = X[-1], Z[-1]
    st = m.step(x, z, jacobian=True, relabel=True)
    assert st.onsets.sum() >= 2                     # impacts inside the revolution
    Ms = st.M * m.scales[None, :] / m.scales[:, None]
    best = np.inf
    for hh in (1e-5, 1e-6):
        Mfd = np.zeros_like(st.M)
        for j in range(m.n):
            h = hh * m.scales[j]
            xp, xm = x.copy(), x.copy()
            xp[j] += h
            xm[j] -= h
            Mfd[:, j] = (m.step(xp, z, relabel=True).x - m.step(xm, z, relabel=True).x) / (2 * h)
        Mf = Mfd * m.scales[None, :] / m.scales[:, None]
        best = min(best, np.linalg.norm(Mf - Ms) / np.linalg.norm(Ms))
    assert best < 1e-4


def test_permanent_contact_orbit_is_reported_as_a_continuum():
    # slider_crank_olyaei at its defaults runs period-1 in permanent contact: the Lankarani-
    # Nikravesh memory is never reset, so it is a neutral direction (multiplier 1)
    from nld.systems import SceneSystem
    o = periodic_orbit(SceneSystem("slider_crank_olyaei"), 1, transient=10, rtol=1e-10)
    assert o.converged and o.onsets_per_period == 0
    assert o.continuum
    assert np.min(np.abs(o.multipliers - 1.0)) < 1e-9
    assert o.stable is True          # the other multipliers are inside the unit circle
    # issue 38 item 6: neutral in the memory direction, stable by the others, and said so
    assert o.memory_neutral and o.stability == "stable" and "memory" in o.stability_text
    dec = o.deciding_multipliers
    assert dec.size == o.multipliers.size - 1 and np.max(np.abs(dec)) < 1 - o.multiplier_uncertainty


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize("period", [0, -1, 1.5, "2", True])
def test_bad_period_is_refused(period):
    with pytest.raises(InputError, match="period"):
        periodic_orbit(henon(), period, [0.5, 0.1])


def test_bad_guess_and_settings_are_refused():
    with pytest.raises(InputError, match="guess"):
        periodic_orbit(henon(), 1, [0.5, 0.1, 0.2])
    with pytest.raises(InputError, match="guess"):
        periodic_orbit(henon(), 2, np.zeros((3, 2)))
    with pytest.raises(InputError, match="shooting"):
        periodic_orbit(henon(), 1, [0.5, 0.1], shooting="double")
    with pytest.raises(InputError, match="autonomous"):
        periodic_orbit(ContinuousSystem(hopf_rhs, [0.5, 0.0], [1.0, 2.0], "hopf"), 1)
    with pytest.raises(InputError, match="z"):
        periodic_orbit(impact_oscillator(), 1, [1.0, 0.5], z=[0.0, 1.0])


def test_map_analyses_take_a_derived_map():
    # the spectrum of the stroboscopic map started on a stable orbit is ln|mu_i| per iteration
    from nld.analysis.lyapunov import lyapunov_spectrum
    from nld.systems import iterate
    S = impact_oscillator(*P0)
    o = periodic_orbit(S, 1, [1.0, 0.5], rtol=1e-11)
    S.y0, S.z0 = o.points[0], o.z[0]
    m = StroboscopicMap(S, 1, rtol=1e-11)
    assert np.max(np.abs(iterate(m, m.y0, 5) - o.points[0])) < 1e-8
    sp = lyapunov_spectrum(m, transient=0, total=200)
    expect = np.sort(np.log(np.abs(o.multipliers)))[::-1]
    assert np.max(np.abs(sp.exponents - expect)) < 0.02
    assert sp.units == "1/iteration"


def test_map_step_budget_follows_the_steps_a_step_takes():
    S = impact_oscillator(*P0)
    m = StroboscopicMap(S, 1, rtol=1e-10)
    assert m.step_budget() >= 10_000_000          # nothing known yet: not limited
    m.step([1.8, 0.3], relabel=True)
    n = m.typical_steps
    assert n > 0 and m.step_budget() == max(20_000, 20 * n)


def test_permanent_contact_exponent_is_flagged_conditional_on_the_memory():
    # issue 25's slider_crank_olyaei case: in permanent contact the Lankarani-Nikravesh memory
    # is never reset; the tangent estimator says so and names the value, and the orbit's
    # multipliers (its exponent) change with that history value
    from nld.analysis.lyapunov import lyapunov_tangent
    from nld.systems import SceneSystem
    S = SceneSystem("slider_crank_olyaei")
    lam = lyapunov_tangent(S, transient=20 * S.period, total=8 * S.period, rtol=1e-10)
    dg = lam.diagnostics
    assert dg["permanent_contact"] and list(dg["conditional_on_memory"]) == ["B.v_onset"]
    v = dg["conditional_on_memory"]["B.v_onset"]
    assert v > 0
    o1 = periodic_orbit(S, 1, transient=20, rtol=1e-10)
    # the same last impact reached by two integrations (the transient's, the map's): same memory
    assert o1.continuum and abs(o1.points[0, -1] - v) < 1e-3 * v
    x2 = o1.points[0].copy()
    x2[-1] = 3 * v                       # another history: a harder last impact
    o2 = periodic_orbit(S, 1, x2, z=o1.z[0], rtol=1e-10)
    assert o2.converged and o2.continuum and abs(o2.points[0, -1] - 3 * v) < 1e-12
    mu1, mu2 = (np.sort(np.abs(o.multipliers))[-2] for o in (o1, o2))
    assert abs(mu1 - mu2) > 10 * (np.max(o1.multiplier_error) + np.max(o2.multiplier_error))
    # an impacting motion is not flagged
    lam_i = lyapunov_tangent(SceneSystem("slider_crank"), transient=5 * S.period,
                             total=4 * S.period, rtol=1e-9)
    assert not lam_i.diagnostics["permanent_contact"]
