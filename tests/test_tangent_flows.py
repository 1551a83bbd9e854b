"""Tangent (variational) Lyapunov estimator on reference flows and user ODEs (Lorenz, Duffing, a
linear flow, a user Lorenz with its own Jacobian / autodiff / finite differences) and the
uncertainty of its estimate. Split from tests/test_tangent.py so that the two files compile on
two workers (pytest --dist loadfile)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from nld.analysis.lyapunov import blocking_se, lyapunov_tangent
from nld.systems.core import ContinuousSystem, duffing, linear, lorenz


# ---------------------------------------------------------------- reference flows
def test_lorenz_spectrum_and_sum():
    r = lyapunov_tangent(lorenz(), k=3, total=500.0)
    assert r.exponents[0] == pytest.approx(0.906, abs=0.04)
    assert abs(r.exponents[1]) < 0.04
    assert r.exponents[2] == pytest.approx(-14.572, abs=0.06)
    assert r.total == pytest.approx(-41.0 / 3.0, abs=1e-6)
    assert r.settings["jacobian"] == "analytic"


def test_duffing_sum_and_linear_flow_exact():
    r = lyapunov_tangent(duffing(), k=2, total=300 * 2 * math.pi / 1.2)
    assert r.total == pytest.approx(-0.3, abs=1e-8)
    assert r.exponents[0] > r.uncertainty[0]
    assert r.system.startswith("duffing(delta=0.3")
    lin = lyapunov_tangent(linear(-0.5, y0=(1.0, 2.0)), k=2, total=20.0)
    assert np.allclose(lin.exponents, -0.5, atol=1e-9)


@pytest.mark.parametrize("how", ["autodiff",
                                 pytest.param("jacobian", marks=pytest.mark.slow),
                                 pytest.param("fd", marks=pytest.mark.slow)])
def test_user_jacobian_autodiff_and_fd_agree(how):
    """A user ODE's tangent from its own Jacobian, from autodiff of its source, from finite
    differences: each compiles its own tangent solver (about a minute cold), so the default run
    keeps autodiff (the path the scenes use) and the other two are slow variants."""
    @njit
    def rhs(t, y, p, z, dy):
        dy[0] = p[0] * (y[1] - y[0])
        dy[1] = y[0] * (p[1] - y[2]) - y[1]
        dy[2] = y[0] * y[1] - p[2] * y[2]

    @njit
    def jac(t, y, p, z, J):
        J[0, 0] = -p[0]; J[0, 1] = p[0]; J[0, 2] = 0.0
        J[1, 0] = p[1] - y[2]; J[1, 1] = -1.0; J[1, 2] = -y[0]
        J[2, 0] = y[1]; J[2, 1] = y[0]; J[2, 2] = -p[2]
    # rho = 0.5: the origin is a stable node, lambda1 = (-(sigma + 1) + sqrt((sigma - 1)^2
    # + 4 sigma rho)) / 2 exactly (the leading eigenvalue of the Jacobian there)
    p = [10.0, 0.5, 8.0 / 3.0]
    exact = (-11.0 + math.sqrt(81.0 + 20.0)) / 2.0
    kw = {"jacobian": dict(jacobian=jac), "autodiff": {}, "fd": dict(jvp="fd")}[how]
    S = ContinuousSystem(rhs, [1.0, 1.0, 1.0], p, "lorenz-user", **kw)
    r = lyapunov_tangent(S, transient=80.0, total=30.0)
    assert r.settings["jacobian"] == how
    assert r.exponent == pytest.approx(exact, abs=1e-4)
    # chaotic parameters: the same estimate as the built-in Lorenz within the uncertainties
    S = ContinuousSystem(rhs, [1.0, 1.0, 1.0], [10.0, 28.0, 8.0 / 3.0], "lorenz-user", **kw)
    a, b = lyapunov_tangent(S, total=200.0), lyapunov_tangent(lorenz(), total=200.0)
    assert abs(a.exponent - b.exponent) <= a.uncertainty + b.uncertainty


# ---------------------------------------------------------------- uncertainty and target
def test_blocking_standard_error_sees_correlation():
    rng = np.random.default_rng(0)
    white = rng.standard_normal(4096)
    se, L = blocking_se(white)
    assert se == pytest.approx(1 / 64, rel=0.5)
    ar = np.empty(4096)
    ar[0] = 0.0
    for i in range(1, 4096):                       # AR(1), phi = 0.9: se ~ sqrt(19) x naive
        ar[i] = 0.9 * ar[i - 1] + rng.standard_normal()
    se2, _ = blocking_se(ar)
    naive = np.std(ar, ddof=1) / 64
    assert se2 == pytest.approx(naive * math.sqrt(19.0), rel=0.3)


def test_uncertainty_covers_the_lorenz_exponent():
    """20 independent 100-time-unit estimates: the reported uncertainty covers the reference
    0.9056 in at least 80 % of them (a ~95 % interval)."""
    ref = 0.9056
    hits = 0
    for seed in range(20):
        y0 = (1.0 + 0.1 * seed, 1.0, 1.0)
        r = lyapunov_tangent(lorenz(y0=y0), total=100.0, seed=seed)
        hits += abs(r.exponent - ref) <= r.uncertainty
    assert hits >= 16


def test_target_uncertainty_is_reached_or_said_not_reached():
    r = lyapunov_tangent(lorenz(), total=50.0, target_uncertainty=0.05, max_total=2000.0)
    assert r.settings["target_reached"] is True
    assert r.uncertainty / r.exponent <= 0.05
    assert r.settings["total"] >= 50.0
    q = lyapunov_tangent(lorenz(), total=20.0, target_uncertainty=1e-4, max_total=60.0)
    assert q.settings["target_reached"] is False
    assert q.settings["total"] == pytest.approx(60.0, rel=1e-9)


def test_systems_from_the_same_functions_share_their_compiled_solvers():
    """A parameter sweep over user systems compiles the integrator and the tangent solver once:
    systems made from the same functions share them (nothing is compiled by this test); other
    functions get their own."""
    from nld.systems.core import _make_solver, lorenz_rhs
    from nld.systems.tangent import tangent_functions
    a = ContinuousSystem(lorenz_rhs, [1.0, 1.0, 1.0], [10.0, 28.0, 8.0 / 3.0], "a")
    b = ContinuousSystem(lorenz_rhs, [1.0, 1.0, 1.0], [10.0, 0.5, 8.0 / 3.0], "b")
    assert tangent_functions(a)[0] is tangent_functions(b)[0]
    assert _make_solver(a.rhs, a.events, a.on_event) is _make_solver(b.rhs, b.events, b.on_event)

    @njit
    def other(t, y, p, z, dy):
        dy[0] = -y[0]
    c = ContinuousSystem(other, [1.0], [], "c")
    assert tangent_functions(c)[0] is not tangent_functions(a)[0]
    assert _make_solver(c.rhs, c.events, c.on_event) is not _make_solver(a.rhs, a.events, a.on_event)
