"""DOPRI5 for a trajectory together with its tangent vectors, saltation at every event.

The tangent (variational) dynamics of y' = f(t, y, z) (z: the discrete state, changed only at
events) are w' = D_y f(t, y, z) w + D_z f(t, y, z) w_z with w_z constant between events. This
integrator advances the reference state y and k tangent vectors (w, w_z) in lock step: the same
Dormand-Prince 5(4) stages (so the tangent is the exact derivative of the numerical map, step
sizes frozen), the same steps, the same event location. At an event g_k(t, y) = 0 with reset
z+ = R(t, y, z-) (``on_event``) and a vector field that jumps from f- to f+, each tangent vector
is mapped by the saltation matrix (Mueller 1995; Leine & Nijmeijer 2004, sec. 7; Kong et al. 2023):

    dtau  = -(grad g . w) / gdot,   gdot = dg/dt + grad g . f-     (time shift of the event)
    w+    = w + (f- - f+) dtau                                        (R leaves y alone)
    w_z+  = D_t R dtau + D_y R (w + f- dtau) + D_z R w_z              (memory reset, e.g. LN v-)

which is S = DR + (f+ - DR f- - R_t) grad g^T / gdot written for a reset acting on z only
(docs/lyapunov.md, "Saltation"). f- is the field at the left end of the located root bracket
(the old branch), f+ the field at the right end with the reset discrete state (the new branch).
A grazing event (gdot = 0 to round-off) is counted and gets no time-shift term.

Error control (``tangent_err``): 1 includes every tangent vector in the step-size control, each
with the absolute tolerance ``atol_i * ||w||_s`` (its current scaled size) and the same rtol
weights as its state, and the step is accepted only when both the state's and every vector's
RMS errors are <= 1; 0 controls the state only (the tangents then ride on the state's steps).
Including them is the default: on a stiff contact an explicit method runs at its stability
limit, where the state's stiff component is held at the error tolerance but a tangent vector's
stiff component, O(1) after each re-orthonormalisation, would not be (docs/lyapunov.md).

Between ``marks`` (re-orthonormalisation times, landed on exactly) the vectors are not touched; at
each mark the scaled vectors w_c / scales are orthonormalised by modified Gram-Schmidt (twice),
the memory parts w_z transformed by the same triangular factor (w -> w R^-1 for both parts),
and ln R_cc recorded in ``logs[mark, c]``.

Event location: nld.integrators.events, shared with the plain integrators: after every accepted
step every event function is also evaluated at ``event_samples`` interior points of the step's
dense output (default 3: 1/4, 1/2, 3/4), so that a contact lost and regained within one step
(two sign changes) is located; the first sub-interval with a change is refined and the earliest
root found by Illinois' method.
"""
import math

import numpy as np
from numba import njit

from .core import (BETA, FACC1, FACC2, NON_FINITE, RUNNING, STOPPED, changed, copy_vector,
                   event_workspace, finish, finite, first_step, next_step, pi_control,
                   pi_start, running, rweight, step_cap, work_vectors)
from .dopri5 import (A21, A31, A32, A41, A42, A43, A51, A52, A53, A54, A61, A62, A63, A64, A65,
                     A71, A73, A74, A75, A76, C2, C3, C4, C5, E1, E3, E4, E5, E6, E7, EXPO1,
                     dense_coeffs, interp)
from .core import (EVENTS_SIG, INTERP_SIG, JVP_SIG, ON_EVENT_JVP_SIG, ON_EVENT_SIG, RHS_SIG, native,
                   no_events, no_on_event, state_vector, vector)
from .events import EVENT_SAMPLES, ROOT_RTOL, locate_earliest, set_unknown_signs
from .aot import compiled
from .ownership import borrowed, keep_alive
GRAZE_RTOL = 1e-12         # |gdot| below this fraction of its terms' size: grazing

# diag entries
DG_SALT, DG_GRAZE, DG_MINRATIO, DG_LOGDET, DG_DIV, DG_EVENTS, DG_SIMUL, DG_UP = 0, 1, 2, 3, 4, 5, 6, 7
N_DIAG = 8


@njit(cache=True)
def new_diag():
    d = np.zeros(N_DIAG)
    d[DG_MINRATIO] = np.inf
    return d


def crossing_diag(n_events: int) -> np.ndarray:
    """A diag array with the per-event block: ``N_DIAG`` summary entries, then for each event
    the smallest |dg/dt| of its upward crossings (inf: none; for a scene's penetration event the
    normal approach speed at contact onset, m/s), then each event's count of upward crossings."""
    d = np.zeros(N_DIAG + 2 * int(n_events))
    d[DG_MINRATIO] = np.inf
    d[N_DIAG:N_DIAG + int(n_events)] = np.inf
    return d


@njit(cache=True)
def _orthonormalise(W, Wz, scales, logs_row):
    """Modified Gram-Schmidt (twice) of the scaled rows W[c]/scales; Wz rows follow."""
    k, n = W.shape
    nz = Wz.shape[1]
    for c in range(k):
        for i in range(n):
            W[c, i] /= scales[i]
    for c in range(k):
        for _rep in range(2):
            for j in range(c):
                r = 0.0
                for i in range(n):
                    r += W[c, i] * W[j, i]
                for i in range(n):
                    W[c, i] -= r * W[j, i]
                for i in range(nz):
                    Wz[c, i] -= r * Wz[j, i]
        nr = 0.0
        for i in range(n):
            nr += W[c, i] * W[c, i]
        nr = math.sqrt(nr)
        logs_row[c] = math.log(nr) if nr > 0.0 else -np.inf
        if nr > 0.0:
            for i in range(n):
                W[c, i] /= nr
            for i in range(nz):
                Wz[c, i] /= nr
    for c in range(k):
        for i in range(n):
            W[c, i] *= scales[i]


@njit(cache=True)
def _scaled_norm(w, scales):
    s = 0.0
    for i in range(w.shape[0]):
        q = w[i] / scales[i]
        s += q * q
    return math.sqrt(s)


@njit(cache=False, inline='always')
def _stage_eval(rhs, rhs_jvp, ts, ytmp, p, z, W, Wz, KW, s, KY, wtmp, want_div, trace_tmp, unit):
    """KY[s] = f(ts, ytmp); KW[s, c] = J (wtmp_c, Wz_c); returns tr J when want_div."""
    k = W.shape[0]
    n = ytmp.shape[0]
    for c in range(k):
        for i in range(n):
            wtmp[i] = W[c, i]
        rhs_jvp(ts, ytmp, p, z, KY[s], 0.0, wtmp, Wz[c], KW[s, c])
    tr = 0.0
    if want_div:
        zz = np.zeros(Wz.shape[1])
        for m in range(n):
            for i in range(n):
                unit[i] = 0.0
            unit[m] = 1.0
            rhs_jvp(ts, ytmp, p, z, trace_tmp, 0.0, unit, zz, wtmp)
            tr += wtmp[m]
    return tr


ATAB = np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                 [A21, 0.0, 0.0, 0.0, 0.0, 0.0],
                 [A31, A32, 0.0, 0.0, 0.0, 0.0],
                 [A41, A42, A43, 0.0, 0.0, 0.0],
                 [A51, A52, A53, A54, 0.0, 0.0],
                 [A61, A62, A63, A64, A65, 0.0],
                 [A71, 0.0, A73, A74, A75, A76]])
CTAB = np.array([0.0, C2, C3, C4, C5, 1.0, 1.0])
BTAB = np.array([A71, 0.0, A73, A74, A75, A76, 0.0])
ETAB = np.array([E1, 0.0, E3, E4, E5, E6, E7])


@njit(cache=True)
def _div_step(h, trs):
    """The step's integral of tr(df/dy) by the 5th-order weights (sum-rule diagnostic)."""
    s = 0.0
    for j in range(7):
        s += BTAB[j] * trs[j]
    return h * s


@njit(cache=False, inline='always')
def _saltation(events_jvp, on_event_jvp, first, t, y, p, z, zold, W, Wz, fminus, fplus,
               crossed, troot_b, t_fire, sgn, diag, gtmp, gd, unit, wtmp, zcopy, zdz, zzero):
    """Map every tangent vector through the event ``first`` (module docstring)."""
    k, n = W.shape
    nz = Wz.shape[1]
    ne = gtmp.shape[0]
    # gdot = dg/dt + grad g . f-, and the size of its terms (grazing test)
    events_jvp(t, y, p, zold, gtmp, 1.0, fminus, zzero, gd)
    gdot = gd[first]
    for i in range(n):
        unit[i] = 0.0
    events_jvp(t, y, p, zold, gtmp, 1.0, unit, zzero, gd)
    scale = abs(gd[first])
    for i in range(n):
        unit[i] = 1.0
        events_jvp(t, y, p, zold, gtmp, 0.0, unit, zzero, gd)
        scale += abs(gd[first] * fminus[i])
        unit[i] = 0.0
    if sgn[first] > 0 and diag.shape[0] >= N_DIAG + 2 * ne:
        # per event: the smallest |gdot| of its upward crossings, and their count
        if abs(gdot) < diag[N_DIAG + first]:
            diag[N_DIAG + first] = abs(gdot)
        diag[N_DIAG + ne + first] += 1.0
    ratio = abs(gdot) / scale if scale > 0.0 else 0.0
    if ratio < diag[DG_MINRATIO]:
        diag[DG_MINRATIO] = ratio
    graze = not (ratio > GRAZE_RTOL)
    if graze:
        diag[DG_GRAZE] += 1
    else:
        # det S on y = gdot+ / gdot- (matrix determinant lemma)
        events_jvp(t, y, p, zold, gtmp, 1.0, fplus, zzero, gd)
        if gd[first] != 0.0 and gdot != 0.0:
            diag[DG_LOGDET] += math.log(abs(gd[first] / gdot))
        diag[DG_SALT] += 1
    for c in range(k):
        for i in range(n):
            wtmp[i] = W[c, i]
        events_jvp(t, y, p, zold, gtmp, 0.0, wtmp, Wz[c], gd)
        dtau = 0.0 if graze else -gd[first] / gdot
        # memory reset: w_z+ = R_t dtau + R_y (w + f- dtau) + R_z w_z
        for i in range(nz):
            zcopy[i] = zold[i]
            zdz[i] = Wz[c, i]
        for i in range(n):
            unit[i] = wtmp[i] + fminus[i] * dtau
        for q in range(ne):
            if crossed[q] and troot_b[q] <= t_fire:
                on_event_jvp(q, sgn[q], t, y, p, zcopy, dtau, unit, zdz)
        for i in range(nz):
            Wz[c, i] = zdz[i]
        for i in range(n):
            W[c, i] = wtmp[i] + (fminus[i] - fplus[i]) * dtau


@njit(cache=True)
def dopri5_tangent_core(rhs, rhs_jvp, events, events_jvp, on_event, on_event_jvp, interp_fn, t0, y0, z, W,
                        Wz, marks, p, rtol, atol, scales, h0, hmax, max_steps, n_events,
                        tangent_err, want_div, diag, logs, event_samples, orthonormalise):
    """Integrate (y, W, Wz) from t0 through every time in ``marks`` (ascending, > t0),
    re-orthonormalising the tangent vectors at each (module docstring). The jitted core, compiled
    once for first-class function arguments (nld.integrators.core); call ``dopri5_tangent``.

    W (k, n): tangent vectors of y as rows; Wz (k, nz): their discrete-state parts; z: the
    discrete state. z, W, Wz, diag and logs (len(marks), k) are updated in place.
    Returns (status, t_reached, y, n_marks_done, stats, h_next); statuses and stats as dopri5.
    """
    n = y0.shape[0]
    k = W.shape[0]
    nz = Wz.shape[1]
    ne = n_events
    n_marks = marks.shape[0]
    stats = np.zeros(5, dtype=np.int64)

    y, ynew, ytmp, yint = work_vectors(y0)
    ya = np.empty(n)
    yb = np.empty(n)
    KY = np.empty((7, n))
    KW = np.empty((7, k, n))
    Wt = np.empty((k, n))          # stage tangents
    Wnew = np.empty((k, n))
    wtmp = np.empty(n)
    unit = np.empty(n)
    trace_tmp = np.empty(n)
    cont = np.empty((5, n))
    fminus = np.empty(n)
    fplus = np.empty(n)
    zold = np.empty(nz)
    zcopy = np.empty(nz)
    gcur, gnew, gtmp, gw, sgn, troot_a, troot_b, crossed = event_workspace(ne)
    gd = np.empty(ne)
    zzero = np.zeros(nz)
    zdz = np.empty(nz)

    t = t0
    i_mark = 0
    if n_marks == 0:
        return 0, t, y, 0, stats, h0
    # the loop works on borrowed views (no reference counting; nld.integrators.ownership); the
    # state returned is an owned copy
    owners = (y, ynew, ytmp, yint, ya, yb, KY, KW, Wt, Wnew, wtmp, unit, trace_tmp, cont, fminus,
              fplus, zold, zcopy, gcur, gnew, gtmp, gw, sgn, troot_a, troot_b, crossed, gd, zzero,
              zdz)
    (y, ynew, ytmp, yint, ya, yb, KY, KW, Wt, Wnew, wtmp, unit, trace_tmp, cont, fminus, fplus,
     zold, zcopy, gcur, gnew, gtmp, gw, sgn, troot_a, troot_b, crossed, gd, zzero,
     zdz) = borrowed(owners)
    z, W, Wz, marks, p, atol, scales, diag, logs = borrowed((z, W, Wz, marks, p, atol, scales, diag,
                                                            logs))
    t_end = marks[n_marks - 1]
    n_steps = n_acc = n_rej = n_nonfinite = 0
    status = RUNNING

    tr1 = _stage_eval(rhs, rhs_jvp, t, y, p, z, W, Wz, KW, 0, KY, wtmp, want_div, trace_tmp, unit)
    nfev = 1
    if ne > 0:
        events(t, y, p, z, gcur)
        set_unknown_signs(gcur, sgn)

    hcap = step_cap(t_end - t0, hmax)
    h = first_step(y, KY[0], atol, rtol, h0, hcap, t_end - t0)
    hnew, facold, reject, new_branch = pi_start(h)
    trs = np.zeros(7)
    retake = False           # the next pass recomputes the step [t, t_star] after an event
    t_star = t
    a_star = t
    first = -1
    tol = 0.0
    while True:
        if not retake:
            status = running(status, t, t_end, n_steps, max_steps)
            if status != RUNNING:
                break
            t_new, h = next_step(t, h, hcap, marks[i_mark])
            n_steps += 1
        else:
            t_new = t_star
            h = t_star - t

        # ---------------------------------------------- stages (state and tangents)
        trs[0] = tr1
        for st in range(1, 7):
            for i in range(n):
                acc = 0.0
                for j in range(st):
                    acc += ATAB[st, j] * KY[j, i]
                ytmp[i] = y[i] + h * acc
            for c in range(k):
                for i in range(n):
                    acc = 0.0
                    for j in range(st):
                        acc += ATAB[st, j] * KW[j, c, i]
                    Wt[c, i] = W[c, i] + h * acc
            if st == 6:
                for i in range(n):
                    ynew[i] = ytmp[i]
                for c in range(k):
                    for i in range(n):
                        Wnew[c, i] = Wt[c, i]
            trs[st] = _stage_eval(rhs, rhs_jvp, t + CTAB[st] * h, ytmp, p, z, Wt, Wz, KW, st,
                                  KY, wtmp, want_div, trace_tmp, unit)
        nfev += 6

        if retake:
            if not finite(ynew):
                status = NON_FINITE
                break
        else:
            # ------------------------------------------ error
            acc = 0.0
            values_finite = True
            for i in range(n):
                if not math.isfinite(ynew[i]):
                    values_finite = False
                e = 0.0
                for j in range(7):
                    e += ETAB[j] * KY[j, i]
                e *= h
                sk = atol[i] + rtol * rweight(atol, n, i) * max(abs(y[i]), abs(ynew[i]))
                acc += (e / sk) ** 2
            err = math.sqrt(acc / n)
            for c in range(k):
                nrm = _scaled_norm(W[c], scales)
                acc = 0.0
                for i in range(n):
                    if not math.isfinite(Wnew[c, i]):
                        values_finite = False
                    if tangent_err:
                        e = 0.0
                        for j in range(7):
                            e += ETAB[j] * KW[j, c, i]
                        e *= h
                        sk = atol[i] * nrm + rtol * rweight(atol, n, i) * max(abs(W[c, i]),
                                                                                abs(Wnew[c, i]))
                        if sk > 0.0:
                            acc += (e / sk) ** 2
                if tangent_err:
                    ec = math.sqrt(acc / n)
                    if ec > err:
                        err = ec
            if not values_finite:
                err = np.nan
            ok, status, h, hnew, facold, n_nonfinite, reject, new_branch, n_rej, n_acc = \
                pi_control(err, EXPO1, BETA, FACC1, FACC2, h, t, hnew, facold, n_nonfinite,
                           reject, new_branch, n_rej, n_acc)
            if not ok:
                continue

            # ------------------------------------------ events: scan the step, earliest root
            have_event = False
            tol = ROOT_RTOL * max(1.0, abs(t_new))
            if ne > 0:
                events(t_new, ynew, p, z, gnew)
                dense_coeffs(h, y, ynew, KY[0], KY[2], KY[3], KY[4], KY[5], KY[6], cont)
                have_event, a_star, t_star, first = locate_earliest(
                    events, interp_fn, event_samples, t, h, t_new, gcur, gnew, sgn, cont, yint, gtmp,
                    gw, p, z, tol, crossed, troot_a, troot_b)
            if not have_event:
                if want_div:
                    diag[DG_DIV] += _div_step(h, trs)
                t = t_new
                for i in range(n):
                    y[i] = ynew[i]
                    KY[0, i] = KY[6, i]
                for c in range(k):
                    for i in range(n):
                        W[c, i] = Wnew[c, i]
                        KW[0, c, i] = KW[6, c, i]
                tr1 = trs[6]
                if ne > 0:
                    for q in range(ne):
                        gcur[q] = gnew[q]
                    set_unknown_signs(gcur, sgn)
                if t >= marks[i_mark]:
                    if orthonormalise:
                        _orthonormalise(W, Wz, scales, logs[i_mark])
                        for c in range(k):      # the vectors changed: their derivatives too
                            for i in range(n):
                                wtmp[i] = W[c, i]
                            rhs_jvp(t, y, p, z, KY[0], 0.0, wtmp, Wz[c], KW[0, c])
                        nfev += 1
                    i_mark += 1
                h = hnew
                continue

            # ------------------------------------------ event at the earliest root t_star
            # the field on the old branch, at the left end of the bracket
            # (within 2 tol of the root: a bracket whose old-side end did not move while the
            # root was refined from the new side can end far before it)
            a_star = max(a_star, t_star - 2.0 * tol)
            interp((a_star - t) / h, cont, ya)
            rhs(a_star, ya, p, z, fminus)
            interp((t_star - t) / h, cont, yb)     # on the new side (for f+)
            nfev += 1
            if t_star > t:
                retake = True       # recompute the step [t, t_star]: state and tangents
                continue

        # ---------------------------------------------- at the event (t_star): land there
        if retake:
            retake = False
            if want_div:
                diag[DG_DIV] += _div_step(h, trs)
            t = t_star
            for i in range(n):
                y[i] = ynew[i]
            for c in range(k):
                for i in range(n):
                    W[c, i] = Wnew[c, i]

        # ---------------------------------------------- fire the events, saltation
        copy_vector(z, zold)
        stop = False
        n_fired = 0
        for q in range(ne):
            if crossed[q] and troot_b[q] <= t_star + tol:
                direction = -sgn[q]
                sgn[q] = direction
                if on_event(q, direction, t, y, p, z) == 1:
                    stop = True
                n_fired += 1
                if direction > 0:
                    diag[DG_UP] += 1
        diag[DG_EVENTS] += n_fired
        if n_fired > 1:
            diag[DG_SIMUL] += n_fired - 1
        # the field on the new branch: at the landed state when it is on the new side, else
        # (round-off put it on the old side) at the bracket's right end on the straddling
        # step's dense output, which is on the new side by construction
        use_b = False
        if first >= 0:
            events(t, y, p, z, gtmp)
            use_b = gtmp[first] * sgn[first] < 0.0
        if use_b:
            rhs(t, yb, p, z, fplus)
        else:
            rhs(t, y, p, z, fplus)
        nfev += 1
        if first >= 0:
            _saltation(events_jvp, on_event_jvp, first, t, y, p, z, zold, W, Wz, fminus, fplus,
                       crossed, troot_b, t_star + tol, sgn, diag, gtmp, gd, unit, wtmp, zcopy,
                       zdz, zzero)
        # restart: derivatives at the event point with the new discrete state; a mode change
        # (on_event changed z) starts a new branch of the vector field
        new_branch = changed(z, zold)
        tr1 = _stage_eval(rhs, rhs_jvp, t, y, p, z, W, Wz, KW, 0, KY, wtmp, want_div,
                          trace_tmp, unit)
        nfev += 1
        events(t, y, p, z, gcur)
        set_unknown_signs(gcur, sgn)
        if t >= marks[i_mark]:
            if orthonormalise:
                _orthonormalise(W, Wz, scales, logs[i_mark])
                tr1 = _stage_eval(rhs, rhs_jvp, t, y, p, z, W, Wz, KW, 0, KY, wtmp, want_div,
                                  trace_tmp, unit)
            i_mark += 1
        if stop:
            status = STOPPED
            break
        h = hnew

    finish(stats, n_steps, n_acc, n_rej, nfev, int(diag[DG_EVENTS]))
    y_end = y.copy()
    keep_alive(owners)
    return status, t, y_end, i_mark, stats, hnew


@njit(cache=True)
def no_events_jvp(t, y, p, z, g, td, yd, zd, gd):
    """Placeholder ``events_jvp`` for a system without events (never called)."""
    pass


@njit(cache=True)
def no_on_event_jvp(k, direction, t, y, p, z, td, yd, zd):
    """Placeholder ``on_event_jvp`` for a system without events (never called)."""
    return 0


def _in_place(a, field: str) -> np.ndarray:
    """A 2-d array the integrator updates in place: must be writable C-contiguous float64."""
    if isinstance(a, np.ndarray) and a.dtype == np.float64 and a.ndim == 2 and a.flags.c_contiguous \
            and a.flags.writeable:
        return a
    from nld.errors import InputError
    raise InputError(f"{field}: must be a writable, C-contiguous 2-d float64 array (it is updated "
                     f"in place); got {type(a).__name__} {getattr(a, 'dtype', '')} "
                     f"{getattr(a, 'shape', '')}")


def dopri5_tangent(rhs, rhs_jvp, events, events_jvp, on_event, on_event_jvp, t0, y0, z, W, Wz,
                   marks, p, rtol, atol, scales, h0, hmax, max_steps, n_events, tangent_err,
                   want_div, diag, logs, event_samples=EVENT_SAMPLES, orthonormalise=True):
    """DOPRI5 with tangent vectors and saltation (``dopri5_tangent_core``; module docstring).

    rhs, events, on_event as for dopri5 (events / on_event None: no events); rhs_jvp,
    events_jvp (None: none), on_event_jvp their forward derivatives
    (``jvp(t, y, p, z, out, t_d, y_d, z_d, out_d)``, ``on_event_jvp(k, direction, t, y, p, z,
    t_d, y_d, z_d)``), numba functions converted here to first-class function arguments, so the
    integrator is compiled once per machine. z, W, Wz, diag and logs are updated in place.
    orthonormalise False: the vectors are left alone at the marks (logs untouched), so W after
    one period started from the identity is the monodromy matrix (``nld.systems.derived``).
    diag may carry the per-event block of ``crossing_diag``.
    Returns (status, t_reached, y, n_marks_done, stats, h_next)."""
    return compiled(dopri5_tangent_core)(
        native(rhs, RHS_SIG, "rhs"), native(rhs_jvp, JVP_SIG, "rhs_jvp"),
        native(no_events if events is None else events, EVENTS_SIG, "events"),
        native(no_events_jvp if events_jvp is None else events_jvp, JVP_SIG, "events_jvp"),
        native(no_on_event if on_event is None else on_event, ON_EVENT_SIG, "on_event"),
        native(no_on_event_jvp if on_event_jvp is None else on_event_jvp, ON_EVENT_JVP_SIG,
               "on_event_jvp"), native(interp, INTERP_SIG, "interp"),
        float(t0), vector(y0), state_vector(z), _in_place(W, "W"), _in_place(Wz, "Wz"),
        vector(marks), vector(p), float(rtol), vector(atol), vector(scales), float(h0),
        float(hmax), int(max_steps), int(n_events), bool(tangent_err), bool(want_div),
        state_vector(diag, "diag"), _in_place(logs, "logs"), int(event_samples),
        bool(orthonormalise))


def bind_tangent(rhs, rhs_jvp, events=None, events_jvp=None, on_event=None, on_event_jvp=None):
    """``solve_tangent(t0, y0, z, W, Wz, marks, p, rtol, atol, scales, h0, hmax, max_steps,
    n_events, tangent_err, want_div, diag, logs, event_samples=EVENT_SAMPLES,
    orthonormalise=True)``: the tangent DOPRI5 with these functions (a kernel's
    ``solve_tangent``, a user system's). Nothing is compiled here."""
    def solve_tangent(t0, y0, z, W, Wz, marks, p, rtol, atol, scales, h0, hmax, max_steps,
                      n_events, tangent_err, want_div, diag, logs, event_samples=EVENT_SAMPLES,
                      orthonormalise=True):
        return dopri5_tangent(rhs, rhs_jvp, events, events_jvp, on_event, on_event_jvp, t0, y0, z,
                              W, Wz, marks, p, rtol, atol, scales, h0, hmax, max_steps, n_events,
                              tangent_err, want_div, diag, logs, event_samples, orthonormalise)
    solve_tangent.functions = (rhs, rhs_jvp, events, events_jvp, on_event, on_event_jvp)
    return solve_tangent
