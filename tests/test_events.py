"""Event location inside a step (nld.integrators.events, issue 13 item 5): every integrator scans
``event_samples`` interior points of each step's dense output, so sign changes that the step's
ends do not show are located, in order, each once; ``event_samples = 0`` is the ends-only test.

The integrators are called through the module-level ``@njit(cache=True)`` wrapper of
tests/problems.py with global functions (loaded from numba's disk cache, see
nld/integrators/dopri5.py; test_integrators compiles the same one)."""
import numpy as np
import pytest
from numba import njit

from nld.errors import InputError
from nld.integrators import EVENT_SAMPLES, dopri5
from problems import UNIT, adaptive

METHODS = {0: "dopri5", 1: "dop853", 2: "rodas"}


@njit(cache=True)
def unit_rhs(t, y, p, z, dy):
    dy[0] = 1.0


@njit(cache=True)
def cubic_events(t, y, p, z, g):
    """g0: three roots p[0..2]; g1: two roots p[3], p[4] (y = t)."""
    g[0] = (y[0] - p[0]) * (y[0] - p[1]) * (y[0] - p[2])
    g[1] = (y[0] - p[3]) * (y[0] - p[4])


@njit(cache=True)
def count_on_event(k, direction, t, y, p, z):
    z[k] += 1.0
    return 0


def _events(which, roots, m, h=0.1):
    """y' = 1 from y(0) = 0 to t = 1 in steps of at most h (exact: the dense output is y = t), with
    the events of problems.problem_events (g0 roots roots[0:3], g1 roots[3:5]); the shared wrapper
    of tests/problems.py, so the integrators compile once for the whole test run."""
    p = np.array([UNIT, *roots], dtype=float)
    out = adaptive(which, 0.0, np.zeros(1), np.array([1.0]), True, p, np.zeros(2), 1e-6,
                   np.array([1e-6]), h, h, 1000, 2, 16, m)
    assert out[0] == 0
    n = int(out[8])
    return out[5][:n], out[6][:n], out[7][:n]


ROOTS = (0.305, 0.34, 0.375, 0.62, 0.66)   # g0: three in the step [0.3, 0.4]; g1: two in [0.6, 0.7]


@pytest.mark.parametrize("which", [0, 1, 2], ids=METHODS.get)
def test_every_sign_change_in_a_step_is_located_in_order(which):
    """Steps of 0.1: g0 has three roots in [0.3, 0.4] (one change seen from the ends), g1 two
    roots 0.04 apart in [0.6, 0.7] (no change seen from the ends). With the default interior
    samples all five are located, in order, each once, with the right directions."""
    t, k, d = _events(which, ROOTS, EVENT_SAMPLES)
    assert list(k) == [0, 0, 0, 1, 1]
    assert np.allclose(t, ROOTS, rtol=0, atol=1e-10)
    assert list(d) == [1, -1, 1, -1, 1]          # g0 starts negative, g1 positive


@pytest.mark.parametrize("which", [0, 1, 2], ids=METHODS.get)
def test_ends_only_misses_them(which):
    """The same run with event_samples = 0 (the step's ends only) sees one change of g0 and none
    of g1: what the interior samples are for (and proof that the test above can fail)."""
    t, k, d = _events(which, ROOTS, 0)
    assert list(k) == [0]


@pytest.mark.parametrize("which", [0, 1, 2], ids=METHODS.get)
def test_the_earliest_of_close_roots_comes_first(which):
    """Three roots of g0 in the first quarter of the step [0.3, 0.4] (0.0016 apart): the quarter
    with the change is refined, so the event fired is the earliest root, not whichever one
    regula falsi converges to."""
    roots = (0.3020, 0.3036, 0.3052, 5.0, 6.0)
    t, k, d = _events(which, roots, EVENT_SAMPLES)
    assert len(t) >= 1 and k[0] == 0 and t[0] == pytest.approx(0.3020, abs=1e-10)


@pytest.mark.parametrize("m", [1, 4, 9])
def test_more_samples_resolve_closer_roots(m):
    """Two roots of g1 0.03 apart inside the step [0.3, 0.4], both before the single sample
    (0.35) of m = 1, which misses them; m = 4 (samples 0.02 apart) and 9 resolve them."""
    roots = (5.0, 6.0, 7.0, 0.305, 0.335)
    t, k, d = _events(0, roots, m)
    if m == 1:
        assert len(t) == 0
    else:
        assert list(k) == [1, 1] and np.allclose(t, roots[3:], rtol=0, atol=1e-10)


@pytest.mark.parametrize("bad", [-1, 65, 2.5, "3", True])
def test_event_samples_bad_input_is_one_line(bad):
    from nld.run.simulate import simulate
    with pytest.raises(InputError) as e:
        simulate("slider_crank", revs=0.01, event_samples=bad)
    msg = str(e.value)
    assert msg.startswith("event_samples = ") and "\n" not in msg


def test_system_refuses_bad_event_samples_and_a_wrapper_without_it():
    from nld.systems.core import ContinuousSystem
    with pytest.raises(InputError, match="event_samples = -2"):
        ContinuousSystem(unit_rhs, [0.0], event_samples=-2)

    def old_solve(t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps, n_events,
                  max_log):
        return dopri5(unit_rhs, cubic_events, count_on_event, t0, y0, t_eval, land, p, z, rtol,
                      atol, h0, hmax, max_steps, n_events, max_log)
    with pytest.raises(InputError, match="event_samples = 0.*13 arguments"):
        ContinuousSystem(unit_rhs, [0.0], solve=old_solve, event_samples=0)
    S = ContinuousSystem(unit_rhs, [0.0], solve=old_solve)      # the default: accepted
    assert S.event_samples == EVENT_SAMPLES


def test_dop853_forms_its_dense_output_only_for_steps_the_screen_flags():
    """dop853 scans its interior samples on the cubic Hermite interpolant of the step's ends and
    forms its 7th-order dense output (3 more rhs evaluations) only for a flagged step: with every
    root far outside the run, the default sampling costs no rhs evaluation over ends-only; with the
    roots of ROOTS inside two steps it costs some (the flagged steps), and all five are found (the
    test above)."""
    def nfev(roots, m):
        p = np.array([UNIT, *roots], dtype=float)
        out = adaptive(1, 0.0, np.zeros(1), np.array([1.0]), True, p, np.zeros(2), 1e-6,
                       np.array([1e-6]), 0.1, 0.1, 1000, 2, 16, m)
        assert out[0] == 0
        return int(out[4][3]), int(out[8])
    far = (5.0, 6.0, 7.0, 8.0, 9.0)
    assert nfev(far, EVENT_SAMPLES) == nfev(far, 0)
    (n3, ev3), (n0, ev0) = nfev(ROOTS, EVENT_SAMPLES), nfev(ROOTS, 0)
    assert ev3 == 5 and ev0 == 1 and n3 > n0
