"""Newton shooting where an orbit exists (issue 38 item 4): a failed integration inside Newton
backs off instead of ending the search, a residual that keeps falling is not called a stall, and
the flip saddles in permanent contact of slider_crank_olyaei at mu = 0 (the orbits `nld control`
stabilises) are found and checked against finite differences of the map."""
import math

import numpy as np
import pytest
from numba import njit

import nld.analysis.orbits as O
from nld.errors import SolveError
from nld.systems import DiscreteMap, henon


class _FailingJacobian(O.Shooting):
    """Shooting whose Jacobian evaluations 2 and 3 fail as a stiff tangent integration does."""

    def __init__(self, *a):
        super().__init__(*a)
        self.calls = 0

    def evaluate(self, X, Z, jacobian):
        if jacobian:
            self.calls += 1
            if self.calls in (2, 3):
                raise SolveError("dopri5: step size underflow (simulated)")
        return super().evaluate(X, Z, jacobian)


def test_a_failed_jacobian_evaluation_inside_newton_backs_off():
    # evaluation 2 is the full step's (always guarded), 3 the re-evaluation with the Jacobian
    # after a backtracked trial was accepted: it ended the Newton with the solver's error
    m = O.as_map(henon())
    sh = _FailingJacobian(m, 1, False)
    X = np.array([[0.8, 0.2]])
    out = O._newton(sh, X, [m.z0.copy()], 1e-10, 30)
    assert sh.calls > 3
    assert out[6], out[7]                       # converged, to the closed-form fixed point
    a, b = 1.4, 0.3
    xs = (-(1 - b) + math.sqrt((1 - b) ** 2 + 4 * a)) / (2 * a)
    assert np.allclose(out[0][0], [xs, b * xs], atol=1e-10)


@njit(cache=True)
def _root_f(x, p, out):
    # x -> x + sign(x) |x|^0.6: the fixed point 0; Newton maps x to -2x/3, each step leaves
    # (2/3)^0.6 = 0.784 of the residual (linear convergence)
    out[0] = x[0] + math.copysign(abs(x[0]) ** 0.6, x[0])


@njit(cache=True)
def _root_jac(x, p, J):
    J[0, 0] = 1.0 + 0.6 * max(abs(x[0]), 1e-300) ** -0.4


def test_a_residual_that_keeps_falling_is_not_a_stall():
    D = DiscreteMap(_root_f, [1.0], [], "root", jacobian=_root_jac)
    o = O.periodic_orbit(D, 1, [1.0], tol=1e-6, max_iter=80)
    assert o.converged, o.message
    assert abs(o.points[0, 0]) ** 0.6 <= 1e-6
    # the residual fell by 0.784 per step: about ln(1e-6) / ln(0.784) = 57 steps
    assert 50 <= o.iterations <= 62


def _scene():
    from nld.systems import SceneSystem
    return SceneSystem("slider_crank_olyaei", ["joints.B.clearance=2e-4",
                                               "joints.B.friction.mu=0"])


def test_permanent_contact_flip_saddle_at_mu0_against_finite_differences():
    # a period-1 orbit in permanent contact at mu = 0 (one of a continuum: the contact memory
    # never reset), a flip saddle; the guess is 2 state scales off in the slider's rate
    S = _scene()
    m = O.StroboscopicMap(S, 1, 1e-8)
    g = np.array([0.170205358, -0.000318824628, 0.144253757, -736.040174, 0.076548933])
    g[2] += 2.0 * m.scales[2]
    o = O.periodic_orbit(m, 1, g)
    assert o.converged and o.onsets_per_period == 0
    assert o.memory_neutral and o.stability == "unstable"
    mu = o.deciding_multipliers
    assert mu[0].real < -1.0 and abs(mu[0].imag) == 0
    # the map's Jacobian in the flow's states (the memory held) by central differences
    x, z = o.points[0], o.z[0]
    n = m.n_y
    F = np.zeros((n, n))
    for j in range(n):
        h = 1e-5 * m.scales[j]
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        F[:, j] = (m.difference(m.step(xp, z, relabel=True).x, m.step(xm, z, relabel=True).x)[:n]
                   / (2 * h))
    mu_fd = np.linalg.eigvals(F)
    lead = mu_fd[np.argmax(np.abs(mu_fd))]
    assert abs(lead - mu[0]) <= 1e-3 * abs(mu[0]) + o.multiplier_uncertainty


@pytest.mark.slow
def test_cli_period_1_at_mu0_finds_the_orbit_newton_from_the_transient_misses(capsys):
    # issue 38 item 4: "step size underflow" (exit 1) before; Newton from the chaotic transient
    # stalls, the close returns of the section give the flip saddle (about 50 s)
    import json
    from nld.cli import main
    rc = main(["orbits", "slider_crank_olyaei", "--set", "joints.B.clearance=2e-4", "--set",
               "joints.B.friction.mu=0", "--period", "1", "--rtol", "1e-8", "--json", "--quiet"])
    assert rc == 0
    o = json.loads(capsys.readouterr().out)["orbits"][0]
    assert o["converged"] and o["period"] == 1 and o["stability"] == "unstable"
    assert o["memory_neutral"] and "close return" in o["message"]


def test_memory_column_of_an_orbit_in_contact_at_the_section_is_not_zero():
    # issue 38 item 7: the mu = 0.1 orbit has one onset per period, but the journal is in contact
    # at the section: the memory recorded at the last onset acts through the damping force until
    # the separation, so its column of the monodromy is not zero (16.8 in the rod.phi_dot row,
    # scaled); the monodromy against central differences of the map (h = 1e-4 scales)
    from nld.systems import SceneSystem
    S = SceneSystem("slider_crank_olyaei", ["joints.B.clearance=2e-4", "joints.B.friction.mu=0.1"])
    o = O.periodic_orbit(S, 1, transient=10, rtol=1e-10)
    assert o.converged and o.onsets_per_period == 1 and not o.memory_neutral
    assert o.stability == "stable" and abs(o.time_period - S.period) < 1e-15
    assert abs(o.multipliers[0] - (-0.5518)) < 1e-3 and abs(o.multipliers[1] - 0.1298) < 1e-3
    m = o.map
    x, z = o.points[0], o.z[0]
    n = m.n
    F = np.zeros((n, n))
    for j in range(n):
        h = 1e-4 * m.scales[j]
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        F[:, j] = m.difference(m.step(xp, z, relabel=True).x, m.step(xm, z, relabel=True).x) / (2 * h)
    s = m.scales
    Ms = o.monodromy * s[None, :] / s[:, None]
    Fs = F * s[None, :] / s[:, None]
    col = Ms[:, -1]
    assert abs(col[o.state_names.index("rod.phi_dot")]) > 10.0
    assert np.linalg.norm(Fs[:, -1] - col) < 0.02 * np.linalg.norm(col)
    assert np.linalg.norm(Fs - Ms) < 0.02 * np.linalg.norm(Ms)       # measured 3.2e-3
