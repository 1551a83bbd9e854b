"""Continuation on an IMPACTING scene against brute force (issue 38 item 9): slider_crank_olyaei
with a 0.2 mm clearance at B has a period-1 orbit with one contact onset per revolution; followed
down in the friction coefficient it loses stability through -1. The located value is checked
against a sweep at a step finer than its stated tolerance, with the critical multiplier of each
sweep point from a finite-difference monodromy (the map re-integrated from perturbed points: no
tangent integration, no saltation matrices)."""
import numpy as np
import pytest

from nld.analysis.continuation import Family, continue_orbit
from nld.analysis.orbits import periodic_orbit

PARAM = "joints.B.friction.mu"


def _fd_flip_multiplier(m, o, h=1e-5):
    """The flip multiplier of the orbit o from map differences: u' (P(x + h v) - P(x - h v)) /
    (2 h u' v), v and u the right and left eigenvectors of the multiplier nearest -1 (only
    directions: errors in them enter the quotient at second order). The map is evaluated as the
    Newton evaluated it (with the tangent integration, whose output is not used)."""
    s = np.asarray(m.scales, dtype=float)
    Ms = o.monodromy * s[None, :] / s[:, None]
    w, V = np.linalg.eig(Ms)
    k = int(np.argmin(np.abs(w + 1.0)))
    v = np.real(V[:, k])
    wl, U = np.linalg.eig(Ms.T)
    u = np.real(U[:, int(np.argmin(np.abs(wl - w[k])))])
    x, z = o.points[0], o.z[0]
    d = m.difference(m.step(x + h * v * s, z, jacobian=True).x,
                     m.step(x - h * v * s, z, jacobian=True).x) / s
    return float(u @ d / (2 * h * (u @ v)))


def test_period_doubling_of_an_impacting_orbit_against_a_finite_difference_sweep():
    from nld.systems import SceneSystem
    S = SceneSystem("slider_crank_olyaei", ["joints.B.clearance=2e-4", f"{PARAM}=0.0835"])
    o = periodic_orbit(S, 1, transient=40, rtol=1e-10)
    assert o.converged and o.onsets_per_period == 1 and not o.continuum   # impacting
    br = continue_orbit(S, o, PARAM, [0.0835, 0.0825], locate_tol=5e-5, criticality=False)
    pds = [b for b in br.bifurcations if b.kind == "period_doubling"]
    assert len(pds) == 1 and pds[0].located and pds[0].orbit.onsets_per_period == 1
    v, tol = pds[0].value, pds[0].tolerance
    # the tolerance: the bracket plus the crossing multiplier's uncertainty over its slope
    assert 0.0825 < v < 0.0835 and tol < 1e-3
    # brute force: a sweep at tol / 2 over v +- tol; the map-difference multiplier crosses -1
    # once, inside it, from below -1 (less friction, less damping) to above
    fam = Family(S, PARAM)
    xs = v + np.linspace(-1.0, 1.0, 5) * tol
    crit, prev = [], pds[0].orbit
    for x in xs:
        m = fam.map_at(x, o.map)
        ox = periodic_orbit(m, 1, prev.points[0], z=prev.z[0], tol=o.tolerance, check=False)
        assert ox.converged and ox.onsets_per_period == 1
        crit.append(_fd_flip_multiplier(m, ox))
        prev = ox
    crit = np.array(crit)
    # the crossing lies inside the stated interval: below -1 at its lower end, above at its
    # upper end (between them the map differences scatter by a few 1e-3, the size of the
    # multipliers' uncertainty that widened the interval)
    assert crit[0] < -1.0 < crit[-1], crit
    assert np.all(np.abs(crit + 1.0) < 0.02), crit
