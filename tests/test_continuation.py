"""Continuation of periodic orbits (nld.analysis.continuation): a grazing bifurcation where the
closed form puts it, a period doubling where the brute-force diagram doubles, the doubled branch,
bad input (issue 24)."""
import math

import numpy as np
import pytest

from nld.analysis.continuation import Family, continue_orbit, period_doubled_orbit
from nld.analysis.orbits import periodic_orbit, section_points
from nld.errors import InputError
from nld.systems import StroboscopicMap, duffing, henon, impact_oscillator


@pytest.fixture(scope="module")
def impact_orbit():
    S = impact_oscillator()
    return S, periodic_orbit(S, 1, [1.8, 0.3], rtol=1e-10)


def test_grazing_located_where_the_free_orbit_reaches_the_stop(impact_orbit):
    # the free (no-contact) orbit is harmonic with amplitude F / sqrt((1 - w^2)^2 + (2 zeta w)^2):
    # the impacting orbit grazes the stop when d reaches that amplitude
    S, o = impact_orbit
    zeta, w, F = S.p[0], S.p[1], S.p[2]
    d_graze = F / math.sqrt((1 - w * w) ** 2 + (2 * zeta * w) ** 2)
    for method, kw in (("natural", dict(values=np.linspace(1.5, 3.0, 16))),
                       ("arclength", dict(range=(1.5, 3.0)))):
        br = continue_orbit(S, o, "d", **kw)
        graze = [b for b in br.bifurcations if b.kind == "grazing"]
        assert len(graze) == 1, method
        g = graze[0]
        # within the stated width: a contact too shallow for the event detection is found on
        # the trajectory (continuation._enters_contact), so the located value is not biased low
        assert abs(g.value - d_graze) <= g.tolerance, (method, g.value, d_graze, g.tolerance)
        # the contact side's orbit: one onset at a vanishing approach speed, or a contact too
        # shallow to count, seen on its trajectory
        assert ((g.orbit.onsets_per_period == 1 and g.orbit.min_approach_speed < 0.01)
                or (g.orbit.onsets_per_period == 0 and "too shallow" in g.detail)), g.detail
        # beyond it the orbit is the free harmonic one, no contact, multiplier modulus exp(-zeta T)
        far = br.orbits[-1]
        assert far.onsets_per_period == 0
        assert abs(far.max_abs_multiplier - math.exp(-zeta * 2 * math.pi / w)) < 1e-7
        tab = br.table()
        assert len(tab) == len(br.values) and set(tab["stable"]) <= {"stable", "unstable", ""}


def test_arclength_crosses_a_kink_by_a_natural_step(impact_orbit, monkeypatch):
    """Where the pseudo-arclength corrector fails at every step length (a non-smooth point of the
    branch: a contact gained or lost gives the branch a kink, no tangent), the continuation takes
    a step at a fixed parameter value across it, says so, and goes on; the orbit beyond is the one
    natural continuation finds there. The kink is simulated: the corrector refuses every point
    beyond d = 2.0 until the natural step has crossed it."""
    import nld.analysis.continuation as cont
    S, o = impact_orbit
    real = cont._arclength_corrector
    state = {"crossed": False, "refused": 0}

    def corrector(fam, like, o_prev, V_pred, t_vec, lam_scale, frozen, tol, max_iter=8,
                  info=None):
        if not state["crossed"] and V_pred[-1] * lam_scale > 2.0:
            state["refused"] += 1
            return None
        return real(fam, like, o_prev, V_pred, t_vec, lam_scale, frozen, tol, max_iter, info)

    real_step = cont._natural_step

    def natural_step(*a, **k):
        out = real_step(*a, **k)
        state["crossed"] = out is not None
        return out
    monkeypatch.setattr(cont, "_arclength_corrector", corrector)
    monkeypatch.setattr(cont, "_natural_step", natural_step)
    br = continue_orbit(S, o, "d", range=(1.5, 2.4), max_points=60)
    assert state["refused"] >= 2 and state["crossed"]
    assert "crossed by a natural step" in br.message and max(br.values) >= 2.4 - 1e-9
    # the point past the kink, d0 + ds = the first value beyond 2.0, is the natural continuation's
    x = min(v for v in br.values if v > 2.0)
    before = [v for v in br.values if v <= 2.0]
    assert x == pytest.approx(max(before) + 0.9 / 50, rel=1e-12)
    ref = continue_orbit(S, o, "d", values=before + [x], locate=False)
    got = br.orbits[list(br.values).index(x)]
    assert np.allclose(got.points, ref.orbits[-1].points, atol=1e-8)


def test_a_fold_whose_multipliers_jump_is_called_non_smooth(impact_orbit):
    """The fold test (prod(mu - 1) changes sign) between two branch points names a smooth fold
    when a multiplier is near +1 on a side of the bracket, and says 'non-smooth' when both sides'
    nearest multipliers stay 0.1 or more away from it (they jumped across a kink of the branch)."""
    import dataclasses

    import nld.analysis.continuation as cont
    S, o = impact_orbit
    fam = cont.Family(S, "d")

    def with_mu(*mu):
        return dataclasses.replace(o, multipliers=np.array(mu, dtype=complex), continuum=False)
    smooth = cont._detect(fam, o.map, 1.5, with_mu(0.97, 0.2), 1.51, with_mu(1.02, 0.2), 1e-8,
                          False, 1e-4)
    jump = cont._detect(fam, o.map, 1.5, with_mu(0.85, 0.2), 1.51, with_mu(1.30, 0.2), 1e-8,
                        False, 1e-4)
    assert [b.kind for b in smooth] == ["fold"] == [b.kind for b in jump]
    assert "non-smooth" not in smooth[0].detail and abs(smooth[0].multiplier - 1.02) < 1e-12
    assert "non-smooth" in jump[0].detail and "0.85 and 1.3" in jump[0].detail


def test_period_doubling_where_the_brute_force_diagram_doubles():
    S = duffing(gamma=0.20)
    o = periodic_orbit(S, 1, transient=50, rtol=1e-10)
    br = continue_orbit(S, o, "gamma", range=(0.20, 0.30), step=0.005)
    pds = [b for b in br.bifurcations if b.kind == "period_doubling"]
    assert len(pds) == 1
    g = pds[0].value
    assert abs(pds[0].multiplier + 1.0) < 1e-3
    # brute force: the stroboscopic section after a long transient, just below and above
    periods = []
    for gg in (g - 0.005, g + 0.005):
        m = StroboscopicMap(duffing(gamma=gg, y0=o.points[0]), 1, 1e-10)
        X, _ = section_points(m, m.y0, m.z0, 300)
        tail = X[-8:, 0]
        periods.append(1 if np.ptp(tail) < 1e-6 else (2 if np.ptp(tail[::2]) < 1e-6 else 0))
    assert periods == [1, 2]
    o2 = period_doubled_orbit(S, "gamma", pds[0])
    assert o2.period == 2 and o2.converged and o2.stable is True
    assert np.max(np.abs(o2.points[0] - o2.points[1])) > 1e-3
    # the doubled branch, continued, doubles again where the brute-force section goes 2 -> 4
    g2 = o2.settings["value"]
    br2 = continue_orbit(duffing(gamma=g2), o2, "gamma", range=(g2, 0.30), step=0.005)
    pd4 = [b for b in br2.bifurcations if b.kind == "period_doubling"]
    assert len(pd4) == 1 and pd4[0].value > g
    g4 = pd4[0].value
    periods = []
    for gg in (g4 - 0.002, g4 + 0.002):
        m = StroboscopicMap(duffing(gamma=gg, y0=o2.points[0]), 1, 1e-10)
        X, _ = section_points(m, m.y0, m.z0, 400)
        tail = X[-8:, 0]
        periods.append(2 if np.ptp(tail[::2]) < 1e-6 else (4 if np.ptp(tail[::4]) < 1e-6 else 0))
    assert periods == [2, 4]


def test_bad_continuation_input_is_refused(impact_orbit):
    S, o = impact_orbit
    with pytest.raises(InputError, match="param"):
        continue_orbit(S, o, "stiffness", np.linspace(1.5, 2.0, 3))
    with pytest.raises(InputError, match="do not contain the start"):
        continue_orbit(S, o, "d", np.linspace(2.0, 3.0, 5))
    with pytest.raises(InputError, match="values"):
        continue_orbit(S, o, "d", [1.5])
    with pytest.raises(InputError, match="give values"):
        continue_orbit(S, o, "d")
    with pytest.raises(InputError, match="param"):
        Family(henon(), 7)


def test_scene_parameter_family_keeps_one_kernel():
    from nld.systems import SceneSystem
    S = SceneSystem("slider_crank_olyaei")
    fam = Family(S, "joints.B.friction.mu")
    assert fam.value0 == pytest.approx(0.1)
    s2 = fam.at(0.05)
    assert s2.kernel.key == S.kernel.key and not np.array_equal(s2.p, S.p)
    with pytest.raises(InputError, match="no such scene key"):
        Family(S, "joints.B.friction.muu")


def test_period_doubling_on_a_clearance_scene_where_the_section_doubles():
    # slider_crank_olyaei (5000 rpm, mu = 0.1): the permanent-contact period-1 orbit reached from
    # c = 0.28 mm is unstable (multiplier < -1); followed up in the clearance it regains stability
    # through -1. Brute force from the orbit's own state (same contact-law memory): period 2 just
    # below the located value, period 1 just above (the study's sweep from the assembly has
    # period-2 sections at 0.281 mm and period 1 at 0.316 mm)
    from nld.systems import SceneSystem
    S = SceneSystem("slider_crank_olyaei", ["joints.B.clearance=0.28e-3"])
    o1 = periodic_orbit(S, 1, transient=100, rtol=1e-10)
    assert o1.converged and o1.continuum and o1.stable is False
    br = continue_orbit(S, o1, "joints.B.clearance", [0.28e-3, 0.2835e-3, 0.287e-3, 0.29e-3],
                        locate_tol=2e-8, criticality=False)
    pds = [b for b in br.bifurcations if b.kind == "period_doubling"]
    assert len(pds) == 1 and 0.28e-3 < pds[0].value < 0.29e-3
    assert abs(pds[0].multiplier + 1.0) < 0.05
    fam = Family(S, "joints.B.clearance")
    spread = []
    for dc in (-1.5e-6, 1.5e-6):
        m = fam.map_at(pds[0].value + dc, o1.map)
        X, _ = section_points(m, o1.points[0], o1.z[0], 150)
        tail = X[-10:]
        spread.append([float(np.max(np.abs(m.difference(tail[k:], tail[:-k]) / m.scales)))
                       for k in (1, 2)])
    (below1, below2), (above1, _) = spread
    assert below1 > 0.1 and below2 < 1e-3        # period 2 below
    assert above1 < 1e-3                         # period 1 above
