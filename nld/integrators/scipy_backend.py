"""scipy.integrate.solve_ivp on a compiled kernel, with the result layout of the numba integrators.

``solve_scipy(kernel, y0, z0, t_eval, p, method, rtol, atol)`` integrates the kernel's numba
``rhs`` with ``method`` in {"RK45", "DOP853", "Radau", "LSODA"}. The contact-onset memory (the
discrete state z, changed only by the kernel's ``on_event``) is handled by running solve_ivp from
event to event: every event function g_k of the kernel is a *terminal* solve_ivp event whose
``direction`` is the crossing away from the side g_k is tracked on (so the event just fired is not
found again at the restart), and ``on_event`` is called between segments, as the numba integrators
do at a located root. Outputs come from each segment's dense output.

Returns ``(status, t_reached, Y, n_out, stats, ev_t, ev_k, ev_dir, n_ev, Z)`` as ``dopri5``, with
``stats = [steps, accepted, rejected, rhs, events, jac, lu]`` from solve_ivp's counters (``nfev``,
``njev``, ``nlu``; accepted = the steps solve_ivp returned; solve_ivp does not report rejected
steps, so ``rejected = -1``). ``z0`` is updated in place (the final discrete state), like ``z`` in
the numba integrators. ``max_steps`` bounds the number of rhs evaluations here.

A reference and a cross-check, not a production path: every rhs evaluation is a Python call
(~30-100x slower than the numba methods, see /work/shared/references.md section 6).
"""
from __future__ import annotations

import math

import numpy as np

from .core import Solution
from .dopri5 import MAX_STEPS, NON_FINITE, STEP_UNDERFLOW
from .events import log_event

SCIPY_METHODS = ("RK45", "DOP853", "Radau", "LSODA")
MAX_EMPTY_SEGMENTS = 100      # consecutive zero-length segments before giving up (event chatter)


class _Budget(Exception):
    pass


def solve_scipy(kernel, y0, z0, t_eval, p, method, rtol, atol, *, t0=None, hmax=0.0,
                max_steps=10_000_000, max_log=200_000, land=False):
    """Integrate ``kernel`` with scipy's ``method`` from t0 (default t_eval[0]) to t_eval[-1].

    rtol: scalar; atol: scalar, one per state, or 2n (atol, then rtol weights per state); hmax > 0 caps the step (solve_ivp's max_step).
    land=True is not supported (solve_ivp does not land on output times): ValueError.
    """
    from scipy.integrate import solve_ivp

    if method not in SCIPY_METHODS:
        raise ValueError(f"scipy method {method!r}: choose one of {', '.join(SCIPY_METHODS)}")
    if land:
        raise ValueError("land=True is not supported by the scipy methods (use dopri5/dop853/rodas)")
    mod = kernel.module
    t_eval = np.ascontiguousarray(t_eval, dtype=float)
    p = np.ascontiguousarray(p, dtype=float)
    y0 = np.ascontiguousarray(y0, dtype=float)
    z = z0                                  # updated in place
    n = y0.shape[0]
    ne = int(kernel.n_events)
    n_eval = t_eval.shape[0]
    if t0 is None:
        t0 = float(t_eval[0]) if n_eval else 0.0
    if np.any(np.diff(t_eval) < 0):
        raise ValueError("t_eval must be sorted ascending")
    if n_eval and t_eval[0] < t0:
        raise ValueError("t_eval must lie within [t0, t_end]")

    Y = np.full((n_eval, n), np.nan)
    Zo = np.zeros((n_eval, z.shape[0]))
    stats = np.zeros(7, dtype=np.int64)
    stats[2] = -1
    ev_t = np.zeros(max_log)
    ev_k = np.zeros(max_log, dtype=np.int64)
    ev_dir = np.zeros(max_log, dtype=np.int64)
    n_ev = 0
    i_out = 0
    while i_out < n_eval and t_eval[i_out] <= t0:
        Y[i_out] = y0
        Zo[i_out] = z
        i_out += 1
    if i_out >= n_eval:
        return Solution(0, float(t0), Y, i_out, stats, ev_t, ev_k, ev_dir, n_ev, Zo)
    t_end = float(t_eval[-1])

    counter = [0]
    budget = int(max_steps)

    def fun(t, y):
        counter[0] += 1
        if counter[0] > budget:
            raise _Budget
        dy = np.empty(n)
        mod.rhs(t, np.ascontiguousarray(y, dtype=float), p, z, dy)
        return dy

    gbuf = np.empty(max(ne, 1))

    def make_event(k):
        def ev(t, y):
            mod.events(t, np.ascontiguousarray(y, dtype=float), p, z, gbuf)
            return gbuf[k]
        ev.terminal = True
        ev.direction = 0.0
        return ev

    evs = [make_event(k) for k in range(ne)]
    sgn = np.zeros(ne, dtype=np.int64)

    def update_signs(t, y):
        if ne:
            g = np.empty(ne)
            mod.events(t, y, p, z, g)
            for k in range(ne):
                if sgn[k] == 0 and g[k] != 0.0 and math.isfinite(g[k]):
                    sgn[k] = 1 if g[k] > 0.0 else -1

    t = float(t0)
    y = y0.copy()
    update_signs(t, y)
    status = 0
    n_empty = 0
    max_step = float(hmax) if hmax and hmax > 0.0 else np.inf
    atol_arg = np.asarray(atol, dtype=float)
    rtol_arg = float(rtol)
    if atol_arg.ndim == 1 and atol_arg.shape[0] == 2 * n:
        # atol, then per-state rtol weights (nld.integrators.dopri5.rweight); Radau accepts a
        # scalar rtol only, so there the weights are dropped (its control is then looser)
        if method != "Radau":
            rtol_arg = np.maximum(rtol * atol_arg[n:], 100 * np.finfo(float).eps)
        atol_arg = atol_arg[:n]
    while t < t_end:
        for k in range(ne):
            evs[k].direction = float(-sgn[k])
        try:
            sol = solve_ivp(fun, (t, t_end), y, method=method, rtol=rtol_arg, atol=atol_arg,
                            events=evs if ne else None, dense_output=True, max_step=max_step)
        except _Budget:
            status = MAX_STEPS
            break
        except (ValueError, ArithmeticError, np.linalg.LinAlgError):
            # e.g. Radau's LU of a Jacobian with inf/NaN entries: solve_ivp raises instead of
            # returning a failure; report it as the non-finite status at the segment start
            status = NON_FINITE
            break
        stats[0] += len(sol.t) - 1
        stats[1] += len(sol.t) - 1
        stats[3] += int(sol.nfev)
        stats[5] += int(sol.njev)
        stats[6] += int(sol.nlu)
        t_seg = float(sol.t[-1])
        y_seg = np.ascontiguousarray(sol.y[:, -1], dtype=float)
        while i_out < n_eval and t_eval[i_out] <= t_seg:
            te = t_eval[i_out]
            Y[i_out] = y_seg if te == t_seg else sol.sol(te)
            Zo[i_out] = z
            i_out += 1
        if sol.status < 0:
            status = NON_FINITE if not np.all(np.isfinite(y_seg)) or "finite" in sol.message \
                else STEP_UNDERFLOW
            t, y = t_seg, y_seg
            break
        if not np.all(np.isfinite(y_seg)):
            status = NON_FINITE
            t, y = t_seg, y_seg
            break
        n_empty = n_empty + 1 if t_seg <= t else 0
        t, y = t_seg, y_seg
        if sol.status == 0:
            break
        # terminal event(s): fire on_event for each, as the numba integrators do
        if n_empty > MAX_EMPTY_SEGMENTS:
            status = STEP_UNDERFLOW
            break
        stop = False
        for k in range(ne):
            if len(sol.t_events[k]):
                direction = int(-sgn[k]) if sgn[k] != 0 else 1
                n_ev = log_event(ev_t, ev_k, ev_dir, n_ev, max_log, float(t), k, direction)
                sgn[k] = direction
                if mod.on_event(k, direction, t, y, p, z) == 1:
                    stop = True
        update_signs(t, y)
        if stop:
            status = 1
            break
    stats[3] = max(stats[3], counter[0])
    stats[4] = n_ev
    return Solution(status, float(t), Y, i_out, stats, ev_t, ev_k, ev_dir, n_ev, Zo)
