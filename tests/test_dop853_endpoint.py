"""DOP853's step-end derivative (issue 38 item 8): K[12] = f(t + h, y_new) is the next step's
first stage (FSAL) but not part of DOP853's error estimate, so a step whose end state is finite
and whose end derivative is not was accepted, and the run then stopped non-finite (status -3)
however small the later steps. The fault is injected here: the right-hand side returns NaN once,
on the first call at the same time as the call before it after t = 0.5 (the step-end derivative:
stage 11 and K[12] are both evaluated at t + h)."""
from __future__ import annotations


import numpy as np
import pytest
from numba import njit

from nld.integrators import SUCCESS, dop853, dopri5


@njit(cache=True)
def glitch_rhs(t, y, p, z, dy):
    """y' = -y; NaN once (p = [t_arm, armed, last t]) on a second call in a row at one t."""
    if p[1] != 0.0 and t >= p[0] and t == p[2]:
        p[1] = 0.0
        dy[0] = np.nan
    else:
        dy[0] = -y[0]
    p[2] = t


@njit(cache=True)
def no_events(t, y, p, z, g):
    pass


@njit(cache=True)
def no_on_event(k, direction, t, y, p, z):
    return 0


@pytest.mark.parametrize("method", [dop853, dopri5])
def test_a_non_finite_step_end_derivative_is_a_rejected_step(method):
    p = np.array([0.5, 1.0, -1.0])
    te = np.array([0.0, 2.0])       # no output time inside the step with the fault (the dense
    #                                  output, formed for one, would have been rejected as NaN)
    sol = method(glitch_rhs, no_events, no_on_event, 0.0, np.array([1.0]), te, False, p,
                 np.zeros(0), 1e-10, np.array([1e-12]), 0.0, 0.1, 100_000, 0, 1, 0)
    assert p[1] == 0.0                                  # the fault was met
    assert sol.status == SUCCESS, sol.status           # before: dop853 status -3 at t ~ 0.5
    assert np.allclose(sol.Y[:, 0], np.exp(-te), rtol=1e-8, atol=0)
    assert sol.stats[2] >= 1                            # the step with the fault was rejected
