"""Test problems for the integrators, shared by tests/test_integrators.py, tests/test_events.py and
tests/test_tangent.py: one right-hand side, one event function and one reset for all of them
(chosen by p[0]). The adaptive integrators are compiled once per machine whatever the functions
(nld.integrators.core); the fixed-step ones (used for convergence orders only) inline them.
"""
import math
from pathlib import Path

import numpy as np
from numba import njit

from nld.integrators import dop853, dop853_fixed, dopri5, rodas, rodas_fixed
from nld.kernel.compile import drop_stale_numba_cache

# numba's disk cache of this module checks only this file's timestamp, not the integrators'
# (inlined into the wrappers below): after an integrator change a local run would test stale code
drop_stale_numba_cache(Path(__file__))

PEND, VDP, NAN, BANG, LIN, OFFSET, UNIT = 0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0


@njit(cache=True)
def problem_rhs(t, y, p, z, dy):
    """The test problem p[0], with its parameters in p[1:]:

    PEND    forced pendulum x'' = -sin x + 0.3 cos t: nonlinear and non-autonomous (tests df/dt);
    VDP     Van der Pol x'' = mu (1 - x^2) x' - x, mu = p[1];
    NAN     y' = 1, NaN from t = p[1] on;
    BANG    x'' = -a z0, a = p[1], z0 = +-1 switched by problem_on_event (a bang-bang
            oscillator; period 4 sqrt(2/a));
    LIN     y' = lam y, lam = p[1];
    OFFSET  x'' = -(x - X0), X0 = p[1]: x = X0 + cos t, a small motion on a large value (like a
            winding angle);
    UNIT    y' = 1 (y = t exactly in any step), with the events of problem_events.
    """
    kind = p[0]
    if kind == PEND:
        dy[0] = y[1]
        dy[1] = -math.sin(y[0]) + 0.3 * math.cos(t)
    elif kind == VDP:
        dy[0] = y[1]
        dy[1] = p[1] * (1.0 - y[0] * y[0]) * y[1] - y[0]
    elif kind == NAN:
        dy[0] = np.nan if t >= p[1] else 1.0
    elif kind == BANG:
        dy[0] = y[1]
        dy[1] = -p[1] * z[0]
    elif kind == LIN:
        dy[0] = p[1] * y[0]
    elif kind == UNIT:
        dy[0] = 1.0
    else:
        dy[0] = y[1]
        dy[1] = -(y[0] - p[1])


@njit(cache=True)
def problem_events(t, y, p, z, g):
    """UNIT: g0 = (y - p1)(y - p2)(y - p3) (three roots), g1 = (y - p4)(y - p5) (two roots),
    n_events = 2. Otherwise BANG's event x = 0 (n_events = 1)."""
    if p[0] == UNIT:
        g[0] = (y[0] - p[1]) * (y[0] - p[2]) * (y[0] - p[3])
        g[1] = (y[0] - p[4]) * (y[0] - p[5])
    else:
        g[0] = y[0]


@njit(cache=True)
def problem_on_event(k, direction, t, y, p, z):
    """UNIT: z[k] counts the events of g_k. BANG: z0 takes the crossing direction, z1 counts
    crossings; stop if p[2] != 0."""
    if p[0] == UNIT:
        z[k] += 1.0
        return 0
    z[0] = direction
    z[1] += 1.0
    return int(p[2])


def adaptive(which, t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps, n_events, max_log,
             event_samples):
    """which = 0 dopri5, 1 dop853, 2 rodas on problem p[0] (arguments and results as
    nld.integrators.dopri5.dopri5): the shared integrators, compiled once, with these functions."""
    if which == 0:
        return dopri5(problem_rhs, problem_events, problem_on_event, t0, y0, t_eval, land, p, z,
                      rtol, atol, h0, hmax, max_steps, n_events, max_log, event_samples)
    if which == 1:
        return dop853(problem_rhs, problem_events, problem_on_event, t0, y0, t_eval, land, p, z,
                      rtol, atol, h0, hmax, max_steps, n_events, max_log, event_samples)
    return rodas(problem_rhs, problem_events, problem_on_event, t0, y0, t_eval, land, p, z,
                 rtol, atol, h0, hmax, max_steps, n_events, max_log, event_samples)


def dopri5_solve(t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps, n_events, max_log,
                 event_samples):
    """A ``solve=`` wrapper (nld.systems.core.ContinuousSystem) of dopri5 on the test problems."""
    return adaptive(0, t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps, n_events,
                    max_log, event_samples)


@njit
def fixed(which, y0, h, n, p):
    """n fixed steps of size h: which = 0 dop853, 1 rodas."""
    z = np.zeros(1)
    if which == 0:
        return dop853_fixed(problem_rhs, 0.0, y0, h, n, p, z)
    return rodas_fixed(problem_rhs, 0.0, y0, h, n, p, z, np.ones(y0.shape[0]))
