"""Delay-differential equations: DOPRI5 with its dense output kept as the history.

The equations are those of any ``ContinuousSystem`` with a delayed, linear feedback law on top
(the form of time-delayed feedback control, Pyragas 1992; Socolar, Sukow & Gauthier 1994) and an
optional nonlinear coupling for a general DDE:

    v_j(t) = (1 - R_j) y_{c_j}(t - tau_j) + R_j v_j(t - tau_j)          (channel j, m of them)
    u_i(t) = clip(u0_i + sum_j Gd[i, j] v_j(t) + sum_k Gy[i, k] y_k(t), -u_max_i, u_max_i)
    p_eff  = p, with p_eff[target_i] += u_i for each input i of kind PARAM
    y'(t)  = rhs(t, y, p_eff, z) + sum_{i of kind STATE} u_i e_{target_i}
             + coupling(t, y, v, p_eff, z)

A channel with memory R_j = 0 is the plain delayed signal y_c(t - tau); with R_j in (0, 1) it is
the extended (EDFC) sum (1 - R) sum_{k>=1} R^(k-1) y_c(t - k tau) in its exact recursive form
(Socolar et al. 1994, eq. 2): the channel's own values are kept as a history beside the state's.

**History.** Every accepted step [t, t + h] of the DOPRI5 pair (nld.integrators.dopri5: Hairer's
tableau, error estimate and 4th-order continuous extension) is stored as a *piece*: its start,
its end, the step length that scales its dense-output variable theta, and the five coefficients
of Hairer's continuous extension y(t + theta h) = c0 + theta (c1 + (1 - theta) (c2 + theta (c3 +
(1 - theta) c4))). Delayed values are this polynomial at the delayed time. The channels' values on
each piece are stored in the same form, fitted exactly through their values at theta = 0, 1/4,
1/2, 3/4, 1 (the five coefficients of the form are a basis of the quartics). Before the start the
history is a given one (a constant y0 by default; ``sampled_history`` for a table or a function,
cubic Hermite pieces; the ``history`` of an earlier run to continue it), and a channel's history
there is taken equal to its signal (exact for a constant history and for a history on a
tau-periodic orbit, the case of control). Pieces older than the longest delay (or ``keep``) are
dropped as the run goes on, so memory stays bounded on long runs.

**Steps.** The step is capped at the shortest delay, so that every delayed time t + c h - tau of
a step's stages lies in the stored history (no implicit overlap iteration). The derivative jumps
that the start propagates -- the solution's derivative at t0 differs from the history's, so y''
jumps at t0 + tau, y''' at t0 + 2 tau ... (Bellen & Zennaro, *Numerical Methods for Delay
Differential Equations*, Oxford 2003, sec. 3.1-3.2: breaking points) -- are *landed on*: no step
straddles t_break0 + k tau_j (k >= 1, every delay, up to the end; an EDFC channel carries the
jump of every k). Landing keeps DOPRI5's order; straddling would cut it to the jump's order.

**Events.** The system's events / on_event are located on each step's dense output by the one
locator every nld integrator uses (nld.integrators.events), the step retaken to the root as in
DOPRI5, and the discrete state z changed by on_event. Events and on_event see the effective
parameters p_eff (a PARAM input also moves an event that depends on it, e.g. a stick/slip
switch that compares forces): exact at the step's end, at a located root and at the restart, and
frozen at the step end's value while a step's dense output is scanned for sign changes (an
O(h du/dt) difference inside one step). With the base p instead, a load driven by the
controller chattered between stick and slip on the excavator scene (10^5 events in 0.06 s).

**Compiled once.** ``dde_core`` takes rhs, events, on_event and coupling as first-class function
arguments (nld.integrators.core) and the law as arrays, so it is compiled once per machine for
every system and every law (a gain sweep never recompiles).

Step-size control, initial step, verdict on a step, output rows, firing events:
nld.integrators.core (``pi_control``, ``first_step``, ``next_step``, ``running``,
``write_outputs``, ``fire``); the initial step is HINIT's first guess (no extra field
evaluation, as in the tangent DOPRI5). Units: t in the system's time
unit (s); everything else in the system's units.
"""
from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass

import numpy as np
from numba import njit, types

from nld.errors import InputError
from nld.integrators.core import (BETA, EVENTS_SIG, FACC1, FACC2, ON_EVENT_SIG, RHS_SIG, RUNNING,
                                  STOPPED, Solution, drop_stale_caches, event_workspace,
                                  finish, fire, first_step, initial_rows, native, new_run,
                                  next_step, no_events, no_on_event, pi_control, pi_start,
                                  retake_finite, rms_error, running, state_vector, step_cap,
                                  vector, write_outputs)
from nld.integrators.aot import compiled
from nld.integrators.ownership import borrowed, keep_alive
from nld.integrators.dopri5 import (A21, A31, A32, A41, A42, A43, A51, A52, A53, A54, A61, A62,
                                    A63, A64, A65, A71, A73, A74, A75, A76, C2, C3, C4, C5,
                                    EXPO1, dense_coeffs, error_estimate, interp,
                                    stage_vectors)
from nld.integrators.events import (EPS, EVENT_SAMPLES, ROOT_RTOL, locate_earliest,
                                    set_unknown_signs)

__all__ = ["DelayLaw", "History", "DelaySolution", "dde", "dde_core", "constant_history",
           "sampled_history", "history_eval", "combine_histories", "no_coupling", "COUPLING_SIG",
           "STATE", "PARAM"]

STATE = 0     # an input added to one state derivative
PARAM = 1     # an input added to one parameter of p

_F = types.float64
_A = types.float64[::1]
COUPLING_SIG = types.void(_F, _A, _A, _A, _A, _A)   # coupling(t, y, v, p, z, dy): adds into dy

# the channel pieces: values at these theta fitted by the continuous extension's basis
_NODES = np.array([0.0, 0.25, 0.5, 0.75, 1.0])


def _basis(th):
    th = np.asarray(th, dtype=float)
    return np.stack([np.ones_like(th), th, th * (1 - th), th * th * (1 - th),
                     th * th * (1 - th) ** 2], axis=-1)


_VINV = np.ascontiguousarray(np.linalg.inv(_basis(_NODES)))


@njit(cache=True)
def no_coupling(t, y, v, p, z, dy):
    """Placeholder coupling: adds nothing."""
    pass


# ================================================================ the history buffer
@njit(cache=True)
def _find(ht0, count, tq):
    """The last piece i < count with ht0[i] <= tq (0 when tq is before every piece)."""
    hi = count - 1
    if tq >= ht0[hi]:
        return hi
    if tq <= ht0[0]:
        return 0
    lo = 0
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if ht0[mid] <= tq:
            lo = mid
        else:
            hi = mid
    return lo


@njit(cache=True)
def _poly(c, i, j, th):
    """Hairer's continuous-extension form of coefficients c[i, :, j] at theta."""
    th1 = 1.0 - th
    return c[i, 0, j] + th * (c[i, 1, j] + th1 * (c[i, 2, j] + th * (c[i, 3, j] + th1 * c[i, 4, j])))


@njit(cache=True)
def _channels(ts, taus, cst, cR, hc, hs, ht0, hh, ht1, count, v):
    """The channel values v_j(ts) from the history (times clamped to the stored span)."""
    for j in range(taus.shape[0]):
        tq = ts - taus[j]
        i = _find(ht0, count, tq)
        x = tq
        if x < ht0[i]:
            x = ht0[i]
        if x > ht1[i]:
            x = ht1[i]
        s = _poly(hc, i, cst[j], (x - ht0[i]) / hh[i])
        R = cR[j]
        if R > 0.0:
            L = ht1[i] - ht0[i]
            sr = _poly(hs, i, j, (x - ht0[i]) / L if L > 0.0 else 0.0)
            v[j] = (1.0 - R) * s + R * sr
        else:
            v[j] = s


@njit(cache=True)
def _inputs(ts, ys, p, pe, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind, iidx, hc, hs, ht0, hh,
            ht1, count):
    """Channels v, inputs u (clipped to +-u_max) and the effective parameters pe at (ts, ys)
    (pe must hold a copy of p: only the entries that PARAM inputs drive are written)."""
    if taus.shape[0] > 0:
        _channels(ts, taus, cst, cR, hc, hs, ht0, hh, ht1, count, v)
    # pe holds p (copied once by the caller) except at the PARAM targets, reset here
    for i in range(u0.shape[0]):
        if ikind[i] == PARAM:
            pe[iidx[i]] = p[iidx[i]]
    n = ys.shape[0]
    for i in range(u0.shape[0]):
        a = u0[i]
        for j in range(taus.shape[0]):
            a += Gd[i, j] * v[j]
        for k in range(n):
            a += Gy[i, k] * ys[k]
        if a > umax[i]:
            a = umax[i]
        elif a < -umax[i]:
            a = -umax[i]
        u[i] = a
        if ikind[i] == PARAM:
            pe[iidx[i]] += a


@njit(cache=False)
def _field(rhs, coupling, ts, ys, p, pe, z, dy, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind, iidx,
           hc, hs, ht0, hh, ht1, count):
    """dy = the closed-loop vector field at (ts, ys): rhs with p_eff, + STATE inputs, + coupling."""
    _inputs(ts, ys, p, pe, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind, iidx, hc, hs, ht0, hh,
            ht1, count)
    rhs(ts, ys, pe, z, dy)
    for i in range(u0.shape[0]):
        if ikind[i] == STATE:
            dy[iidx[i]] += u[i]
    coupling(ts, ys, v, pe, z, dy)


@njit(cache=False)
def _dstep(rhs, coupling, t, h, t_new, y, k1, k2, k3, k4, k5, k6, k7, ytmp, ynew, p, pe, z, v, u,
           taus, cst, cR, Gd, Gy, u0, umax, ikind, iidx, hc, hs, ht0, hh, ht1, count):
    """One DOPRI5 step of the closed loop from (t, y), k1 = field(t, y): k2..k7 and ynew."""
    n = y.shape[0]
    for i in range(n):
        ytmp[i] = y[i] + h * A21 * k1[i]
    _field(rhs, coupling, t + C2 * h, ytmp, p, pe, z, k2, v, u, taus, cst, cR, Gd, Gy, u0, umax,
           ikind, iidx, hc, hs, ht0, hh, ht1, count)
    for i in range(n):
        ytmp[i] = y[i] + h * (A31 * k1[i] + A32 * k2[i])
    _field(rhs, coupling, t + C3 * h, ytmp, p, pe, z, k3, v, u, taus, cst, cR, Gd, Gy, u0, umax,
           ikind, iidx, hc, hs, ht0, hh, ht1, count)
    for i in range(n):
        ytmp[i] = y[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i])
    _field(rhs, coupling, t + C4 * h, ytmp, p, pe, z, k4, v, u, taus, cst, cR, Gd, Gy, u0, umax,
           ikind, iidx, hc, hs, ht0, hh, ht1, count)
    for i in range(n):
        ytmp[i] = y[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i])
    _field(rhs, coupling, t + C5 * h, ytmp, p, pe, z, k5, v, u, taus, cst, cR, Gd, Gy, u0, umax,
           ikind, iidx, hc, hs, ht0, hh, ht1, count)
    for i in range(n):
        ytmp[i] = y[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] + A65 * k5[i])
    _field(rhs, coupling, t_new, ytmp, p, pe, z, k6, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind,
           iidx, hc, hs, ht0, hh, ht1, count)
    for i in range(n):
        ynew[i] = y[i] + h * (A71 * k1[i] + A73 * k3[i] + A74 * k4[i] + A75 * k5[i] + A76 * k6[i])
    _field(rhs, coupling, t_new, ynew, p, pe, z, k7, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind,
           iidx, hc, hs, ht0, hh, ht1, count)


@njit(cache=True)
def _make_room(ht0, hh, ht1, hc, hs, count, t_keep):
    """Room for one more piece: drop the pieces that end before t_keep (moving the rest to the
    front), and double the buffer when it is still more than half full."""
    cap = ht0.shape[0]
    if count < cap:
        return ht0, hh, ht1, hc, hs, count
    i0 = 0
    while i0 < count - 1 and ht1[i0] < t_keep:
        i0 += 1
    if i0 > 0:
        for i in range(i0, count):
            ht0[i - i0] = ht0[i]
            hh[i - i0] = hh[i]
            ht1[i - i0] = ht1[i]
            for r in range(5):
                for j in range(hc.shape[2]):
                    hc[i - i0, r, j] = hc[i, r, j]
                for j in range(hs.shape[2]):
                    hs[i - i0, r, j] = hs[i, r, j]
        count -= i0
    if 2 * count > cap:
        a0, a1, a2, c, s = _pieces(ht0, hh, ht1, hc, hs, 0, count, 2 * cap)
        return a0, a1, a2, c, s, count
    return ht0, hh, ht1, hc, hs, count


@njit(cache=True)
def _pieces(ht0, hh, ht1, hc, hs, i0, k, cap):
    """New history arrays of capacity cap holding the k pieces of these from piece i0 on."""
    a0 = np.empty(cap)
    a1 = np.empty(cap)
    a2 = np.empty(cap)
    c = np.empty((cap, 5, hc.shape[2]))
    s = np.empty((cap, 5, hs.shape[2]))
    for i in range(k):
        a0[i] = ht0[i0 + i]
        a1[i] = hh[i0 + i]
        a2[i] = ht1[i0 + i]
        for r in range(5):
            for j in range(hc.shape[2]):
                c[i, r, j] = hc[i0 + i, r, j]
            for j in range(hs.shape[2]):
                s[i, r, j] = hs[i0 + i, r, j]
    return a0, a1, a2, c, s


@njit(cache=True)
def _push(ta, h, tb, cont, vn, ht0, hh, ht1, hc, hs, count):
    """Store the piece [ta, tb] (dense output ``cont`` scaled by h; channel node values vn at
    theta = 0, 1/4, 1/2, 3/4, 1 of [ta, tb], turned into coefficients). Room must exist."""
    i = count
    ht0[i] = ta
    hh[i] = h
    ht1[i] = tb
    for r in range(5):
        for j in range(hc.shape[2]):
            hc[i, r, j] = cont[r, j]
    for j in range(hs.shape[2]):
        for r in range(5):
            acc = 0.0
            for q in range(5):
                acc += _VINV[r, q] * vn[q, j]
            hs[i, r, j] = acc
    return count + 1


@njit(cache=True)
def _channel_nodes(ta, tb, taus, cst, cR, hc, hs, ht0, hh, ht1, count, v, vn):
    """The channel values at the five nodes of the piece [ta, tb] (history before it only)."""
    for q in range(5):
        _channels(ta + _NODES[q] * (tb - ta), taus, cst, cR, hc, hs, ht0, hh, ht1, count, v)
        for j in range(taus.shape[0]):
            vn[q, j] = v[j]


@njit(cache=True)
def _next_break(t, t_b0, taus, t_end):
    """The first breaking point t_b0 + k tau_j (k >= 1) after t, or t_end."""
    best = t_end
    tiny = 4.0 * EPS * max(1.0, abs(t))
    for j in range(taus.shape[0]):
        tau = taus[j]
        k = math.floor((t - t_b0) / tau) + 1.0
        if k < 1.0:
            k = 1.0
        bp = t_b0 + k * tau
        while bp <= t + tiny:
            k += 1.0
            bp = t_b0 + k * tau
        if bp < best:
            best = bp
    return best


@njit(cache=True)
def _row_inputs(i0, i1, t_eval, Y, U, S, p, pe, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind, iidx,
                hc, hs, ht0, hh, ht1, count):
    """The channel values S and the inputs U at the output rows i0 <= i < i1 (states Y)."""
    for i in range(i0, i1):
        _inputs(t_eval[i], Y[i], p, pe, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind, iidx, hc, hs,
                ht0, hh, ht1, count)
        for j in range(v.shape[0]):
            S[i, j] = v[j]
        for j in range(u.shape[0]):
            U[i, j] = u[j]


@njit(cache=True)
def _write_rows(t, h, t_hi, y_hi, cont, t_eval, i_out, Y, Zo, z, U, S, p, pe, v, u, taus, cst, cR,
                Gd, Gy, u0, umax, ikind, iidx, hc, hs, ht0, hh, ht1, count):
    """Rows for t_eval in (t, t_hi]: the state and the discrete state (``write_outputs``), the
    channel values S and the inputs U there."""
    i_new = write_outputs(interp, t, h, t_hi, y_hi, cont, t_eval, i_out, Y, Zo, z)
    _row_inputs(i_out, i_new, t_eval, Y, U, S, p, pe, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind,
                iidx, hc, hs, ht0, hh, ht1, count)
    return i_new


# ================================================================ the integrator
@njit(cache=True)
def dde_core(rhs, events, on_event, coupling, t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax,
             max_steps, n_events, max_log, event_samples, taus, cst, cR, Gd, Gy, u0, umax, ikind,
             iidx, t_break0, keep, ht0_in, hh_in, ht1_in, hc_in, hs_in):
    """Adaptive DOPRI5 for the delayed closed loop of the module docstring, from t0 to
    t_eval[-1] (the jitted core; call :func:`dde`).

    Law arrays: taus (m,) delays, cst (m,) signal state index, cR (m,) memories; Gd (nu, m),
    Gy (nu, n), u0, umax (nu,), ikind (nu,) STATE/PARAM, iidx (nu,) the state or parameter index.
    History in: pieces (ht0, hh, ht1, hc (k, 5, n), hs (k, 5, m)) covering [t0 - max tau, t0].
    t_break0: origin of the breaking points; keep: history span to keep and return (>= max tau).

    Returns the fields of nld.integrators.core.Solution, then U (n_eval, nu) and S (n_eval, m)
    (inputs and channel values at the output rows), the history pieces covering [t - keep, t],
    and the next step size proposed.
    """
    n = y0.shape[0]
    n_eval = t_eval.shape[0]
    m = taus.shape[0]
    nu = u0.shape[0]
    ne = n_events
    Y, Zo, stats, ev_t, ev_k, ev_dir, y, ynew, ytmp, yint, zsave = new_run(
        t0, y0, t_eval, atol, z, max_log, 5)
    U = np.empty((n_eval, nu))
    S = np.empty((n_eval, m))
    for i in range(n_eval):
        for j in range(nu):
            U[i, j] = np.nan
        for j in range(m):
            S[i, j] = np.nan

    # the history buffer, seeded with the given pieces
    count = ht0_in.shape[0]
    ht0, hh, ht1, hc, hs = _pieces(ht0_in, hh_in, ht1_in, hc_in, hs_in, 0, count,
                                   max(64, 2 * count))
    tau_min = np.inf
    for j in range(m):
        tau_min = min(tau_min, taus[j])

    k1, k2, k3, k4, k5, k6, k7 = stage_vectors(n)
    cont = np.empty((5, n))
    pe = p.copy()
    pev = p.copy()      # the effective parameters the events see
    v = np.empty(m)
    u = np.empty(nu)
    vn = np.empty((5, m))
    gcur, gnew, gtmp, gw, sgn, troot_a, troot, crossed = event_workspace(ne)
    # the loop works on borrowed views of the fixed work arrays and the arguments (no reference
    # counting; nld.integrators.ownership); the history buffer, which grows, stays owned
    owners = (y, ynew, ytmp, yint, zsave, k1, k2, k3, k4, k5, k6, k7, cont, pe, pev, v, u, vn, gcur,
              gnew, gtmp, gw, sgn, troot_a, troot, crossed)
    (y, ynew, ytmp, yint, zsave, k1, k2, k3, k4, k5, k6, k7, cont, pe, pev, v, u, vn, gcur, gnew,
     gtmp, gw, sgn, troot_a, troot, crossed) = borrowed(owners)
    p, z, atol, t_eval, taus, cst, cR, Gd, Gy, u0, umax, ikind, iidx = borrowed((
        p, z, atol, t_eval, taus, cst, cR, Gd, Gy, u0, umax, ikind, iidx))

    t = t0
    i_out = initial_rows(t0, y0, z, t_eval, Y, Zo)
    _row_inputs(0, i_out, t_eval, Y, U, S, p, pe, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind,
                iidx, hc, hs, ht0, hh, ht1, count)
    status = RUNNING
    n_steps = n_acc = n_rej = n_nonfinite = n_ev = nfev = 0
    h = hcap = h0
    t_end = t_eval[n_eval - 1] if i_out < n_eval else t0
    if i_out < n_eval:
        _field(rhs, coupling, t, y, p, pe, z, k1, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind,
               iidx, hc, hs, ht0, hh, ht1, count)
        nfev = 1
        if ne > 0:
            _inputs(t, y, p, pev, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind, iidx, hc, hs, ht0,
                    hh, ht1, count)
            events(t, y, pev, z, gcur)
            set_unknown_signs(gcur, sgn)
        hcap = step_cap(t_end - t0, hmax)
        if m > 0 and tau_min < hcap:
            hcap = tau_min
        h = first_step(y, k1, atol, rtol, h0, hcap, t_end - t0)
    hnew, facold, reject, new_branch = pi_start(h)
    while True:
        status = running(status, t, t_end, n_steps, max_steps)
        if status != RUNNING:
            break
        target = t_eval[i_out] if land else t_end
        if m > 0:
            bp = _next_break(t, t_break0, taus, t_end)
            if bp < target:
                target = bp
        t_new, h = next_step(t, h, hcap, target)
        n_steps += 1
        # ---------------- the DOPRI5 stages on the closed-loop field
        _dstep(rhs, coupling, t, h, t_new, y, k1, k2, k3, k4, k5, k6, k7, ytmp, ynew, p, pe, z, v,
               u, taus, cst, cR, Gd, Gy, u0, umax, ikind, iidx, hc, hs, ht0, hh, ht1, count)
        nfev += 6
        error_estimate(h, k1, k3, k4, k5, k6, k7, ytmp)     # ytmp is free after the stages
        err = rms_error(y, ynew, ytmp, atol, rtol)
        ok, status, h, hnew, facold, n_nonfinite, reject, new_branch, n_rej, n_acc = pi_control(
            err, EXPO1, BETA, FACC1, FACC2, h, t, hnew, facold, n_nonfinite, reject, new_branch,
            n_rej, n_acc)
        if not ok:
            continue
        dense_coeffs(h, y, ynew, k1, k3, k4, k5, k6, k7, cont)

        # ---------------- events on the dense output
        have_event = False
        t_star = t_new
        tol = ROOT_RTOL * max(1.0, abs(t_new))
        if ne > 0:
            # the events see the effective parameters, frozen over the step at its end
            _inputs(t_new, ynew, p, pev, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind, iidx, hc,
                    hs, ht0, hh, ht1, count)
            events(t_new, ynew, pev, z, gnew)
            have_event, a_star, t_star, first = locate_earliest(
                events, interp, event_samples, t, h, t_new, gcur, gnew, sgn, cont, yint, gtmp, gw,
                pev, z, tol, crossed, troot_a, troot)
        t_hi = t_new
        h_d = h
        if have_event:
            t_hi = t_star
            if t_star > t and t_star < t_new:
                # retake the step to the root: a true 5th-order state there
                interp((t_star - t) / h, cont, yint)
                _dstep(rhs, coupling, t, t_star - t, t_star, y, k1, k2, k3, k4, k5, k6, k7, ytmp,
                       ynew, p, pe, z, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind, iidx, hc, hs,
                       ht0, hh, ht1, count)
                nfev += 6
                if retake_finite(ynew, yint):
                    h_d = t_star - t
                    dense_coeffs(h_d, y, ynew, k1, k3, k4, k5, k6, k7, cont)
        if t_hi > t:
            # store the piece [t, t_hi] in the history, then write the outputs in it
            if m > 0:
                _channel_nodes(t, t_hi, taus, cst, cR, hc, hs, ht0, hh, ht1, count, v, vn)
            # (calls guarded: a call with this many array arguments costs ~0.5 us)
            if count == ht0.shape[0]:
                ht0, hh, ht1, hc, hs, count = _make_room(ht0, hh, ht1, hc, hs, count, t - keep)
            count = _push(t, h_d, t_hi, cont, vn, ht0, hh, ht1, hc, hs, count)
            if i_out < n_eval and t_eval[i_out] <= t_hi:
                i_out = _write_rows(t, h_d, t_hi, ynew, cont, t_eval, i_out, Y, Zo, z, U, S, p,
                                    pe, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind, iidx, hc, hs,
                                    ht0, hh, ht1, count)
            t = t_hi
            y, ynew = ynew, y
        if not have_event:
            k1, k7 = k7, k1          # FSAL
            if ne > 0:
                gcur, gnew = gnew, gcur
                set_unknown_signs(gcur, sgn)
            h = hnew
            continue
        # ---------------- fire the events at t_star, restart with the new z
        _inputs(t, y, p, pev, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind, iidx, hc, hs, ht0, hh,
                ht1, count)
        stop, n_ev, new_branch = fire(on_event, crossed, troot, t_star, tol, sgn, t, y, pev, z,
                                      zsave, ev_t, ev_k, ev_dir, n_ev, max_log)
        _field(rhs, coupling, t, y, p, pe, z, k1, v, u, taus, cst, cR, Gd, Gy, u0, umax, ikind,
               iidx, hc, hs, ht0, hh, ht1, count)
        events(t, y, pev, z, gcur)
        set_unknown_signs(gcur, sgn)
        nfev += 1
        if stop:
            status = STOPPED
            break
        h = hnew
    finish(stats, n_steps, n_acc, n_rej, nfev, n_ev)
    keep_alive(owners)
    # the history kept: pieces ending at or after t - keep
    i0 = 0
    while i0 < count - 1 and ht1[i0] < t - keep:
        i0 += 1
    o0, o1, o2, oc, os_ = _pieces(ht0, hh, ht1, hc, hs, i0, count - i0, count - i0)
    return (status, t, Y, i_out, stats, ev_t, ev_k, ev_dir, n_ev, Zo, U, S, o0, o1, o2, oc, os_,
            h)


# ================================================================ Python side
History = namedtuple("History", ["t0", "h", "t1", "cont", "chan"])
History.__doc__ = """The history of a delay integration as pieces (arrays, k pieces):
t0, t1 (k,) each piece's start and end, h (k,) the length that scales its theta,
cont (k, 5, n) the state's continuous-extension coefficients, chan (k, 5, m) the channels'."""

DelaySolution = namedtuple("DelaySolution", Solution._fields + ("U", "S", "history", "h_last"))
DelaySolution.__doc__ = """Result of :func:`dde`: the fields of nld.integrators.core.Solution,
then U (n_eval, nu) the inputs u_i and S (n_eval, m) the channel values v_j at the output rows,
``history`` (a :class:`History` covering [t - keep, t]: pass it to a next call to continue the
run) and ``h_last`` (the next step size proposed: that call's h0)."""


@dataclass(frozen=True)
class DelayLaw:
    """A linear delayed feedback law (module docstring): m channels, nu inputs, n states.

    delays (m,) tau_j > 0 (time unit of the system); signals (m,) state index c_j; memories (m,)
    R_j in [0, 1); gd (nu, m), gy (nu, n) gains; u0 (nu,) offsets; u_max (nu,) > 0 clip (inf:
    none); kinds (nu,) STATE or PARAM; targets (nu,) the state index (STATE) or parameter index
    (PARAM) each input acts on. Build with :meth:`make` (checks every field)."""
    delays: np.ndarray
    signals: np.ndarray
    memories: np.ndarray
    gd: np.ndarray
    gy: np.ndarray
    u0: np.ndarray
    u_max: np.ndarray
    kinds: np.ndarray
    targets: np.ndarray

    @property
    def m(self) -> int:
        return int(self.delays.size)

    @property
    def nu(self) -> int:
        return int(self.u0.size)

    @property
    def tau_max(self) -> float:
        return float(self.delays.max()) if self.delays.size else 0.0

    @classmethod
    def make(cls, n: int, n_p: int, delays, signals, memories=None, gd=None, gy=None, u0=None,
             u_max=None, kinds=None, targets=None) -> "DelayLaw":
        """Checked law for a system of n states and n_p parameters (InputError naming the
        field otherwise). Defaults: memories 0, no inputs."""
        d = np.array(delays, dtype=float).ravel()
        m = d.size
        if m and (not np.all(np.isfinite(d)) or np.any(d <= 0)):
            raise InputError(f"delay = {d.tolist()!r}: every delay must be a positive finite time")
        sg = np.array(signals, dtype=np.int64).ravel()
        if sg.size != m or np.any(sg < 0) or np.any(sg >= n):
            raise InputError(f"signal = {sg.tolist()!r}: one state index per delay, each in "
                             f"0..{n - 1}")
        R = np.zeros(m) if memories is None else np.array(memories, dtype=float).ravel()
        if R.size != m or not np.all(np.isfinite(R)) or np.any(R < 0) or np.any(R >= 1):
            raise InputError(f"memory = {R.tolist()!r}: R must be in [0, 1) (0: Pyragas' plain "
                             f"delay; R -> 1 weights ever older periods)")
        kinds_a = np.zeros(0, dtype=np.int64) if kinds is None else \
            np.array(kinds, dtype=np.int64).ravel()
        nu = kinds_a.size
        tg = np.zeros(nu, dtype=np.int64) if targets is None else \
            np.array(targets, dtype=np.int64).ravel()
        if tg.size != nu:
            raise InputError(f"targets = {tg.tolist()!r}: one per input ({nu})")
        for kd, ix in zip(kinds_a, tg):
            if kd == STATE and not 0 <= ix < n:
                raise InputError(f"input target = {int(ix)}: a state index in 0..{n - 1}")
            if kd == PARAM and not 0 <= ix < n_p:
                raise InputError(f"input target = {int(ix)}: a parameter index in "
                                 f"0..{n_p - 1}" if n_p else "input target: the system has no "
                                 "parameters")
            if kd not in (STATE, PARAM):
                raise InputError(f"input kind = {int(kd)}: 0 (add to a state derivative) or 1 "
                                 f"(add to a parameter)")
        G = np.zeros((nu, m)) if gd is None else np.array(gd, dtype=float).reshape(nu, m)
        H = np.zeros((nu, n)) if gy is None else np.array(gy, dtype=float).reshape(nu, n)
        if not (np.all(np.isfinite(G)) and np.all(np.isfinite(H))):
            raise InputError(f"gain = {G.tolist()!r}, {H.tolist()!r}: must be finite numbers")
        o = np.zeros(nu) if u0 is None else np.array(u0, dtype=float).reshape(nu)
        if not np.all(np.isfinite(o)):
            raise InputError(f"u0 = {o.tolist()!r}: must be finite")
        um = np.full(nu, np.inf) if u_max is None else np.array(u_max, dtype=float).reshape(nu)
        if np.any(np.isnan(um)) or np.any(um <= 0):
            raise InputError(f"u_max = {um.tolist()!r}: must be > 0 (inf: no limit)")
        c = np.ascontiguousarray
        return cls(c(d), c(sg), c(R), c(G), c(H), c(o), c(um), c(kinds_a), c(tg))


def constant_history(y0, t0: float, law: DelayLaw, span: float | None = None) -> History:
    """The constant history y(t) = y0 for t in [t0 - span, t0] (span default: the longest delay)
    as one piece; each channel's history is its signal's constant value."""
    y0 = np.asarray(y0, dtype=float).ravel()
    span = float(law.tau_max if span is None else span) or 1.0
    cont = np.zeros((1, 5, y0.size))
    cont[0, 0] = y0
    chan = np.zeros((1, 5, law.m))
    chan[0, 0] = y0[law.signals]
    return History(np.array([t0 - span]), np.array([span]), np.array([float(t0)]), cont, chan)


def _to_coeffs(values, axis_nodes=0):
    """Coefficients (5, ...) of the continuous-extension form through values at _NODES."""
    return np.tensordot(_VINV, values, axes=(1, axis_nodes))


def sampled_history(t, Y, law: DelayLaw, dY=None) -> History:
    """A history from samples Y (k, n) at ascending times t (k >= 2): cubic Hermite pieces (slopes
    dY, default ``np.gradient``), written in the continuous-extension form (c4 = 0); each
    channel's history is its signal's (module docstring)."""
    t = np.asarray(t, dtype=float).ravel()
    Y = np.asarray(Y, dtype=float)
    if Y.ndim != 2 or Y.shape[0] != t.size or t.size < 2 or np.any(np.diff(t) <= 0):
        raise InputError(f"history: need k >= 2 ascending times and a (k, n) table; got {t.size} "
                         f"times and shape {Y.shape}")
    if not np.all(np.isfinite(Y)):
        raise InputError("history: the table has non-finite values")
    D = np.gradient(Y, t, axis=0) if dY is None else np.asarray(dY, dtype=float)
    h = np.diff(t)
    k = h.size
    n = Y.shape[1]
    cont = np.empty((k, 5, n))
    ydiff = Y[1:] - Y[:-1]
    bspl = h[:, None] * D[:-1] - ydiff
    cont[:, 0] = Y[:-1]
    cont[:, 1] = ydiff
    cont[:, 2] = bspl
    cont[:, 3] = ydiff - h[:, None] * D[1:] - bspl
    cont[:, 4] = 0.0
    chan = np.ascontiguousarray(cont[:, :, law.signals])
    return History(t[:-1].copy(), h.copy(), t[1:].copy(), cont, chan)


def _dbasis(th):
    th = np.asarray(th, dtype=float)
    return np.stack([np.zeros_like(th), np.ones_like(th), 1 - 2 * th, 2 * th - 3 * th * th,
                     2 * th * (1 - th) * (1 - 2 * th)], axis=-1)


def _eval_pieces(coef, a, hscale, times, idx, derivative=False):
    th = (times - a[idx]) / hscale[idx]
    if derivative:
        return np.einsum("kr,krj->kj", _dbasis(th), coef[idx]) / hscale[idx][:, None]
    return np.einsum("kr,krj->kj", _basis(th), coef[idx])


def history_eval(hist: History, times, derivative: bool = False):
    """(states (k, n), channels (k, m)) of a history at the given times (clamped to its span);
    with ``derivative`` their time derivatives instead (the pieces' own, one-sided at a piece's
    start)."""
    times = np.atleast_1d(np.asarray(times, dtype=float))
    idx = np.clip(np.searchsorted(hist.t0, times, side="right") - 1, 0, hist.t0.size - 1)
    x = np.clip(times, hist.t0[idx], hist.t1[idx])
    Yv = _eval_pieces(hist.cont, hist.t0, hist.h, x, idx, derivative)
    L = hist.t1 - hist.t0
    Cv = _eval_pieces(hist.chan, hist.t0, np.where(L > 0, L, 1.0), x, idx, derivative)
    return Yv, Cv


def combine_histories(ref: History, other: History, alpha: float, t_from: float,
                      shift: float = 0.0) -> History:
    """ref + alpha (other - ref - shift ref') on [t_from, end] as pieces on the union of both
    meshes (exact up to round-off: on each union interval both are quartics, written in the same
    form; ref' is the derivative of ref's pieces, ``shift`` removes a time-shift component).
    Used to renormalise a perturbed copy's whole history segment (the state of a DDE is the
    function on [t - tau, t]; Farmer 1982)."""
    end = min(ref.t1[-1], other.t1[-1])
    cuts = np.union1d(np.concatenate([ref.t0, ref.t1[-1:]]),
                      np.concatenate([other.t0, other.t1[-1:]]))
    cuts = cuts[(cuts > t_from) & (cuts < end)]
    edges = np.concatenate([[t_from], cuts, [end]])
    a, b = edges[:-1], edges[1:]
    keep = b > a
    a, b = a[keep], b[keep]
    tt = a[:, None] + _NODES[None, :] * (b - a)[:, None]          # (k, 5)
    flat = tt.ravel()
    Yr, Cr = history_eval(ref, flat)
    Yo, Co = history_eval(other, flat)
    Yd = Yo - Yr
    Cd = Co - Cr
    if shift != 0.0:
        dY, dC = history_eval(ref, flat, derivative=True)
        Yd -= shift * dY
        Cd -= shift * dC
    Yc = (Yr + alpha * Yd).reshape(a.size, 5, -1)
    Cc = (Cr + alpha * Cd).reshape(a.size, 5, -1)
    cont = np.ascontiguousarray(np.einsum("rq,kqj->krj", _VINV, Yc))
    chan = np.ascontiguousarray(np.einsum("rq,kqj->krj", _VINV, Cc))
    return History(a.copy(), (b - a).copy(), b.copy(), cont, chan)


def dde(rhs, events, on_event, t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps,
        n_events, max_log, law: DelayLaw, history=None, *, coupling=None,
        event_samples: int = EVENT_SAMPLES, t_break0: float | None = None,
        keep: float | None = None) -> DelaySolution:
    """Integrate the delayed closed loop (module docstring) from (t0, y0) to t_eval[-1].

    Arguments as ``nld.integrators.dopri5.dopri5`` (rhs, events, on_event: numba functions of the
    nld signatures; z updated in place), plus ``law`` (:class:`DelayLaw`), ``history`` (None: the
    constant y0; a :class:`History` covering [t0 - max tau, t0], e.g. an earlier run's; or a
    (t, Y) table for :func:`sampled_history`), ``coupling`` (optional numba ``coupling(t, y, v,
    p, z, dy)`` adding a nonlinear delayed term into dy; v the channel values), ``t_break0``
    (the origin of the breaking points, default t0: pass the first start when continuing a run)
    and ``keep`` (the history span returned, default and at least the longest delay).
    Returns a :class:`DelaySolution` (statuses as dopri5's)."""
    y0 = vector(y0)
    if history is None:
        history = constant_history(y0, float(t0), law)
    elif not isinstance(history, History):
        th, Yh = history
        history = sampled_history(th, Yh, law)
    if history.cont.shape[1:] != (5, y0.size) or history.chan.shape[1:] != (5, law.m):
        raise InputError(f"history: pieces of shape {history.cont.shape[1:]} / "
                         f"{history.chan.shape[1:]}, expected (5, {y0.size}) / (5, {law.m})")
    if law.gy.shape[1] != y0.size:
        raise InputError(f"law: built for {law.gy.shape[1]} states, y0 has {y0.size}")
    keep = max(float(law.tau_max), float(keep or 0.0))
    f = native(rhs, RHS_SIG, "rhs")
    g = native(no_events if events is None else events, EVENTS_SIG, "events")
    o = native(no_on_event if on_event is None else on_event, ON_EVENT_SIG, "on_event")
    c = native(no_coupling if coupling is None else coupling, COUPLING_SIG, "coupling")
    # every array as the one compiled signature has it (a core built at install reads what it
    # is given as that type: nld.integrators.aot); a law made by hand with other dtypes is coerced
    m, nu = law.delays.size, law.u0.size
    c3 = lambda a: np.ascontiguousarray(a, dtype=float).reshape(-1, 5, np.shape(a)[-1])  # noqa: E731
    ints = lambda a: np.ascontiguousarray(a, dtype=np.int64).reshape(-1)  # noqa: E731
    mat = lambda a, k: np.ascontiguousarray(a, dtype=float).reshape(nu, k)  # noqa: E731
    out = compiled(dde_core)(f, g, o, c, float(t0), y0, vector(t_eval), bool(land), vector(p),
                   state_vector(z), float(rtol), vector(atol), float(h0), float(hmax),
                   int(max_steps), int(n_events), int(max_log), int(event_samples),
                   vector(law.delays), ints(law.signals), vector(law.memories), mat(law.gd, m),
                   mat(law.gy, y0.size), vector(law.u0), vector(law.u_max), ints(law.kinds),
                   ints(law.targets), float(t0 if t_break0 is None else t_break0), keep,
                   vector(history.t0), vector(history.h), vector(history.t1), c3(history.cont),
                   c3(history.chan))
    return DelaySolution(*out[:12], History(*out[12:17]), float(out[17]))


drop_stale_caches([dde_core])
