"""Adaptive Dormand-Prince 5(4) integrator with dense output and event location, in numba.

Coefficients, error estimator, 4th-order continuous extension, PI ("Lund") step-size control
and the automatic initial step follow Hairer's DOPRI5 (Hairer, Norsett & Wanner, *Solving
Ordinary Differential Equations I*, 2nd ed., Springer 1993, sec. II.4-II.6 and the Fortran
code ``dopri5.f``). See ``docs/integrator.md``.

The integrator takes the user's functions as first-class function arguments
(``nld.integrators.core``: compiled once per machine, whatever the functions):

* ``rhs(t, y, p, z, dy)``            writes dy/dt into ``dy`` in place.
* ``events(t, y, p, z, g)``          writes the ``n_events`` event functions into ``g``.
* ``on_event(k, direction, t, y, p, z) -> int``  called at a located zero crossing of g_k;
  may modify ``z``; returns 0 to continue, 1 to stop (status 1).

``p`` (parameters) is read only; ``z`` (discrete state) is modified only by ``on_event``, in
place, so the caller sees its final value.

Compilation: ``dopri5_core`` is compiled once, for first-class function arguments, and cached on
disk; ``dopri5`` (Python) converts numba functions to them (``nld.integrators.core.front``). The
step-size control, initial step, output writing and statuses are nld.integrators.core's; this
file holds the tableau, the stages, the error estimate, the dense output and the loop.
"""

import numpy as np
from numba import njit

# the statuses and controller constants are re-exported here for older imports
from .core import (ACCEPTED, BETA, EPS, EXPO_EVENT, FACC1, FACC1_EVENT, FACC2,  # noqa: F401
                   FACMAX, FACMIN, FACOLD0, MAX_NONFINITE, MAX_STEPS, NON_FINITE, RETRY, RUNNING,
                   SAFE, STEP_UNDERFLOW, STOPPED, SUCCESS, event_workspace, fire_and_restart,
                   fixed_times, front, judge, method_status_message, new_run, next_step,
                   no_events, no_on_event, pi_accept, pi_control, pi_start, rejected_shrink,
                   retake_finite, rms_error, running, rweight, solution, start, work_vectors,
                   write_outputs)
from .ownership import borrowed, keep_alive
from .events import (EVENT_SAMPLES, ROOT_MAXITER, ROOT_RTOL, find_crossings,  # noqa: F401
                     fire_events, locate_earliest, set_unknown_signs)

# ---------------------------------------------------------------- Hairer's DOPRI5 coefficients
C2 = 1.0 / 5.0
C3 = 3.0 / 10.0
C4 = 4.0 / 5.0
C5 = 8.0 / 9.0

A21 = 1.0 / 5.0
A31 = 3.0 / 40.0
A32 = 9.0 / 40.0
A41 = 44.0 / 45.0
A42 = -56.0 / 15.0
A43 = 32.0 / 9.0
A51 = 19372.0 / 6561.0
A52 = -25360.0 / 2187.0
A53 = 64448.0 / 6561.0
A54 = -212.0 / 729.0
A61 = 9017.0 / 3168.0
A62 = -355.0 / 33.0
A63 = 46732.0 / 5247.0
A64 = 49.0 / 176.0
A65 = -5103.0 / 18656.0
A71 = 35.0 / 384.0
A73 = 500.0 / 1113.0
A74 = 125.0 / 192.0
A75 = -2187.0 / 6784.0
A76 = 11.0 / 84.0

# error estimator: (5th order) - (embedded 4th order)
E1 = 71.0 / 57600.0
E3 = -71.0 / 16695.0
E4 = 71.0 / 1920.0
E5 = -17253.0 / 339200.0
E6 = 22.0 / 525.0
E7 = -1.0 / 40.0

# dense output (continuous extension of order 4)
D1 = -12715105075.0 / 11282082432.0
D3 = 87487479700.0 / 32700410799.0
D4 = -10690763975.0 / 1880347072.0
D5 = 701980252875.0 / 199316789632.0
D6 = -1453857185.0 / 822651844.0
D7 = 69997945.0 / 29380423.0

# ---------------------------------------------------------------- step-size control
EXPO1 = 0.2 - 0.75 * BETA      # err^EXPO1: the PI controller's exponent for order 5 (Hairer)


@njit(cache=False, inline='always')
def _stages(rhs, t, h, t_new, y, k1, k2, k3, k4, k5, k6, k7, ytmp, ynew, p, z):
    """One DOPRI5 step from (t, y) with k1 = f(t, y): fills k2..k7, ynew; k7 = f(t_new, ynew)."""
    n = y.shape[0]
    for i in range(n):
        ytmp[i] = y[i] + h * A21 * k1[i]
    rhs(t + C2 * h, ytmp, p, z, k2)
    for i in range(n):
        ytmp[i] = y[i] + h * (A31 * k1[i] + A32 * k2[i])
    rhs(t + C3 * h, ytmp, p, z, k3)
    for i in range(n):
        ytmp[i] = y[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i])
    rhs(t + C4 * h, ytmp, p, z, k4)
    for i in range(n):
        ytmp[i] = y[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i])
    rhs(t + C5 * h, ytmp, p, z, k5)
    for i in range(n):
        ytmp[i] = y[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i]
                              + A65 * k5[i])
    rhs(t_new, ytmp, p, z, k6)
    for i in range(n):
        ynew[i] = y[i] + h * (A71 * k1[i] + A73 * k3[i] + A74 * k4[i] + A75 * k5[i]
                              + A76 * k6[i])
    rhs(t_new, ynew, p, z, k7)


@njit(cache=False, inline='always')
def stage_vectors(n):
    """k1..k7, the stage derivatives of a step (7 vectors of n)."""
    return (np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n),
            np.empty(n))


@njit(cache=True)
def error_estimate(h, k1, k3, k4, k5, k6, k7, e):
    """Hairer's error estimate of a DOPRI5 step, (5th order) - (embedded 4th order), into e; its
    norm is ``nld.integrators.core.rms_error``."""
    for i in range(e.shape[0]):
        e[i] = h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i])


@njit(cache=True)
def dense_coeffs(h, y, ynew, k1, k3, k4, k5, k6, k7, cont):
    """Hairer's continuous extension in cont = [y, r2, r3, r4, r5]:
    y(t+th*h) = y + th*(r2 + (1-th)*(r3 + th*(r4 + (1-th)*r5)))."""
    n = y.shape[0]
    for i in range(n):
        ydiff = ynew[i] - y[i]
        bspl = h * k1[i] - ydiff
        cont[0, i] = y[i]
        cont[1, i] = ydiff
        cont[2, i] = bspl
        cont[3, i] = ydiff - h * k7[i] - bspl
        cont[4, i] = h * (D1 * k1[i] + D3 * k3[i] + D4 * k4[i] + D5 * k5[i] + D6 * k6[i]
                          + D7 * k7[i])


@njit(cache=True)
def interp(theta, cont, out):
    """Dense output y(t + theta h) from cont = [y, r2, r3, r4, r5] (Hairer's CONTD5)."""
    th1 = 1.0 - theta
    for i in range(out.shape[0]):
        out[i] = cont[0, i] + theta * (cont[1, i] + th1 * (cont[2, i] + theta * (
            cont[3, i] + th1 * cont[4, i])))


@njit(cache=True)
def dopri5_core(rhs, events, on_event, interp_fn, t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax,
                max_steps, n_events, max_log, event_samples):
    """Adaptive DOPRI5 from t0 to t_eval[-1] (the jitted core; call ``dopri5``).

    event_samples: interior points of every accepted step's dense output at which the event
    functions are also evaluated, so that sign changes between the step's ends are located
    (nld.integrators.events; 0: the ends only).

    returns (status, t_reached, Y, n_out, stats, ev_t, ev_k, ev_dir, n_ev, Z), as the fields of
    nld.integrators.core.Solution

    Z[i] is the discrete state z in force at output row i (for observing hysteresis laws).

    status: 0 reached t_end, 1 stopped by on_event, -1 max_steps exceeded, -2 step size
    underflow, -3 non-finite values. Y has one row per t_eval (NaN where not reached);
    the first n_out rows are filled. stats = [steps, accepted, rejected, rhs evals, events].
    """
    n = y0.shape[0]
    n_eval = t_eval.shape[0]
    ne = n_events
    Y, Zo, stats, ev_t, ev_k, ev_dir, y, ynew, ytmp, yint, zsave = new_run(
        t0, y0, t_eval, atol, z, max_log, 5)

    # work arrays, allocated once
    k1, k2, k3, k4, k5, k6, k7 = stage_vectors(n)
    cont = np.empty((5, n))                 # dense output of the last step
    gcur, gnew, gtmp, gw, sgn, troot_a, troot, crossed = event_workspace(ne)
    # the loop works on borrowed views (no reference counting; nld.integrators.ownership)
    owners = (y, ynew, ytmp, yint, zsave, k1, k2, k3, k4, k5, k6, k7, cont, gcur, gnew, gtmp, gw,
              sgn, troot_a, troot, crossed)
    (y, ynew, ytmp, yint, zsave, k1, k2, k3, k4, k5, k6, k7, cont, gcur, gnew, gtmp, gw, sgn,
     troot_a, troot, crossed) = borrowed(owners)
    p, z, atol, t_eval, Yb, Zb, evt, evk, evd = borrowed((p, z, atol, t_eval, Y, Zo, ev_t, ev_k,
                                                          ev_dir))

    t = t0
    i_out, t_end, h, hcap, nfev = start(rhs, events, t0, y, k1, p, z, atol, rtol, h0, hmax,
                                        t_eval, Yb, Zb, ytmp, k2, 5.0, gcur, sgn)
    n_steps = n_acc = n_rej = n_nonfinite = n_ev = 0
    status = RUNNING
    hnew, facold, reject, new_branch = pi_start(h)

    while True:
        status = running(status, t, t_end, n_steps, max_steps)
        if status != RUNNING:
            break
        t_new, h = next_step(t, h, hcap, t_eval[i_out] if land else t_end)
        n_steps += 1

        _stages(rhs, t, h, t_new, y, k1, k2, k3, k4, k5, k6, k7, ytmp, ynew, p, z)
        nfev += 6
        error_estimate(h, k1, k3, k4, k5, k6, k7, ytmp)     # ytmp is free after the stages
        err = rms_error(y, ynew, ytmp, atol, rtol)
        ok, status, h, hnew, facold, n_nonfinite, reject, new_branch, n_rej, n_acc = pi_control(
            err, EXPO1, BETA, FACC1, FACC2, h, t, hnew, facold, n_nonfinite, reject, new_branch,
            n_rej, n_acc)
        if not ok:
            continue

        # ------------------------------------------------ event detection and location
        have_event = False
        dense_done = False
        t_star = t_new
        tol = ROOT_RTOL * max(1.0, abs(t_new))
        if ne > 0:
            events(t_new, ynew, p, z, gnew)
            if event_samples > 0 or find_crossings(gnew, sgn, crossed):
                dense_coeffs(h, y, ynew, k1, k3, k4, k5, k6, k7, cont)
                dense_done = True
                have_event, a_star, t_star, first = locate_earliest(
                    events, interp_fn, event_samples, t, h, t_new, gcur, gnew, sgn, cont, yint, gtmp,
                    gw, p, z, tol, crossed, troot_a, troot)

        if not have_event:
            # dense output for t_eval in (t, t_new]
            if i_out < n_eval and t_eval[i_out] <= t_new:
                if t_eval[i_out] < t_new and not dense_done:
                    dense_coeffs(h, y, ynew, k1, k3, k4, k5, k6, k7, cont)
                i_out = write_outputs(interp_fn, t, h, t_new, ynew, cont, t_eval, i_out, Yb, Zb, z)
            t = t_new
            y, ynew = ynew, y
            k1, k7 = k7, k1     # FSAL
            if ne > 0:
                gcur, gnew = gnew, gcur
                set_unknown_signs(gcur, sgn)
            h = hnew
            continue

        # ------------------------------------------------ at the earliest root t_star
        h_d = h
        if t_star > t:
            if t_star < t_new:
                # retake the step so the state at t_star is a true 5th-order solution
                interp((t_star - t) / h, cont, yint)
                _stages(rhs, t, t_star - t, t_star, y, k1, k2, k3, k4, k5, k6, k7, ytmp, ynew, p,
                        z)
                nfev += 6
                if retake_finite(ynew, yint):
                    h_d = t_star - t
                    dense_coeffs(h_d, y, ynew, k1, k3, k4, k5, k6, k7, cont)
            i_out = write_outputs(interp_fn, t, h_d, t_star, ynew, cont, t_eval, i_out, Yb, Zb, z)
            t = t_star
            y, ynew = ynew, y

        # fire every crossing whose root is within tol of t_star; restart with k1 and g there
        status, n_ev, new_branch, nfev = fire_and_restart(
            rhs, events, on_event, crossed, troot, t_star, tol, sgn, t, y, p, z, zsave, evt, evk,
            evd, n_ev, max_log, k1, gcur, nfev)
        if status != RUNNING:
            break
        h = hnew

    keep_alive(owners)
    return solution(status, t, Y, i_out, stats, ev_t, ev_k, ev_dir, n_ev, Zo, n_steps, n_acc, n_rej,
                    nfev)


dopri5 = front(dopri5_core, interp)


@njit(cache=False)
def dopri5_fixed(rhs, t0, y0, h, n_steps, p, z):
    """n_steps fixed DOPRI5 steps of size h (5th-order solution, no control, no events)."""
    y, ynew, ytmp, _ = work_vectors(y0)
    k1, k2, k3, k4, k5, k6, k7 = stage_vectors(y0.shape[0])
    rhs(t0, y, p, z, k1)
    for s in range(n_steps):
        t, t_new = fixed_times(t0, h, s)
        _stages(rhs, t, h, t_new, y, k1, k2, k3, k4, k5, k6, k7, ytmp, ynew, p, z)
        y, ynew = ynew, y
        k1, k7 = k7, k1
    return y


def status_message(status, t_reached, stats):
    """One-line human description of a dopri5 result (``method_status_message`` without the
    method's name)."""
    return method_status_message("dopri5", status, t_reached, stats).removeprefix("dopri5: ")
