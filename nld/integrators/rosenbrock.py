"""Stiff integrator: Hairer & Wanner's RODAS (Rodas4), a 6-stage L-stable, stiffly accurate
Rosenbrock method of order 4 with an embedded order-3 error estimate and a 3rd-order dense output,
in numba, with the interface, events and statuses of :mod:`nld.integrators.dopri5`.

Method: coefficients (``METH = 1`` of ``ROCOE``), stage formulation (the transformed variables
``ak_i`` of the code, so each stage costs one rhs evaluation and one back-substitution with the
single LU factor of ``I/(h*gamma) - J``), error estimate (the last stage increment), continuous
extension and step-size control (``fac = clip(err^(1/4)/0.9, 1/6, 5)`` with Gustafsson's
predictive controller) follow Hairer's Fortran code ``rodas.f`` (E. Hairer, G. Wanner, *Solving
Ordinary Differential Equations II*, 2nd ed., Springer 1996, sec. IV.7). See
``docs/integrators.md``.

The Jacobian is computed inside numba by forward differences of the user's ``rhs``, column by
column, with increments ``sqrt(eps) * max(|y_j|, atol_j / rtol)`` (scaled to the state's error
scale); the problem is treated as non-autonomous, with ``df/dt`` by a forward difference too.
One Jacobian (n + 2 rhs evaluations) per accepted point; a rejected step re-uses it with a new LU.

Interface (identical to ``dopri5``)::

    status, t_reached, Y, n_out, stats, ev_t, ev_k, ev_dir, n_ev, Z = rodas(
        rhs, events, on_event, t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax,
        max_steps, n_events, max_log)

``stats = [steps, accepted, rejected, rhs evaluations, events, jacobians, LU decompositions]``
(length 7; rhs evaluations include those spent on finite differences). An additional status
``SINGULAR = -5``: the iteration matrix was singular 5 times in a row (the step is halved first).
Events: as dopri5 (nld.integrators.events: interior samples of the dense output, which costs no
rhs evaluation here; step retaken from t with the same Jacobian and a new LU to land on the
event).
"""

import math

import numpy as np
from numba import njit

from .core import (EPS, MAX_RELOCATE, NON_FINITE, RUNNING, SINGULAR, STOPPED, copy_vector,
                   event_workspace, finite, fixed_times, front, new_run, next_step,
                   no_events, relocate, rms_error, running, scan_due, settle, solution, start,
                   work_vectors, write_outputs)
from .ownership import borrowed, keep_alive
from .events import (EVENT_SAMPLES, find_crossings, fire_events, locate_earliest,  # noqa: F401
                     set_unknown_signs)
from .dopri5 import ROOT_RTOL  # noqa: F401

MAX_SINGULAR = 5
SQRT_EPS = math.sqrt(EPS)

# ---------------------------------------------------------------- Rodas4 (rodas.f, ROCOE METH=1)
C2 = 0.386
C3 = 0.21
C4 = 0.63
D1 = 0.2500000000000000e+00
D2 = -0.1043000000000000e+00
D3 = 0.1035000000000000e+00
D4 = -0.3620000000000023e-01
A21 = 0.1544000000000000e+01
A31 = 0.9466785280815826e+00
A32 = 0.2557011698983284e+00
A41 = 0.3314825187068521e+01
A42 = 0.2896124015972201e+01
A43 = 0.9986419139977817e+00
A51 = 0.1221224509226641e+01
A52 = 0.6019134481288629e+01
A53 = 0.1253708332932087e+02
A54 = -0.6878860361058950e+00
C21 = -0.5668800000000000e+01
C31 = -0.2430093356833875e+01
C32 = -0.2063599157091915e+00
C41 = -0.1073529058151375e+00
C42 = -0.9594562251023355e+01
C43 = -0.2047028614809616e+02
C51 = 0.7496443313967647e+01
C52 = -0.1024680431464352e+02
C53 = -0.3399990352819905e+02
C54 = 0.1170890893206160e+02
C61 = 0.8083246795921522e+01
C62 = -0.7981132988064893e+01
C63 = -0.3152159432874371e+02
C64 = 0.1631930543123136e+02
C65 = -0.6058818238834054e+01
GAMMA = 0.2500000000000000e+00
D21 = 0.1012623508344586e+02
D22 = -0.7487995877610167e+01
D23 = -0.3480091861555747e+02
D24 = -0.7992771707568823e+01
D25 = 0.1025137723295662e+01
D31 = -0.6762803392801253e+00
D32 = 0.6087714651680015e+01
D33 = 0.1643084320892478e+02
D34 = 0.2476722511418386e+02
D35 = -0.6594389125716872e+01

# ---------------------------------------------------------------- step-size control (rodas.f)
SAFE = 0.9
FAC1 = 5.0           # fac = h/hnew is kept in [FAC2, FAC1]: 0.2 <= hnew/h <= 6 (rodas.f names)
FAC2 = 1.0 / 6.0


# ================================================================ linear algebra (small, dense)
@njit(cache=True)
def lu_factor(a, piv):
    """In-place LU with partial pivoting (full row swaps); False if a pivot is 0 or non-finite."""
    n = a.shape[0]
    for k in range(n):
        ip = k
        amax = abs(a[k, k])
        for i in range(k + 1, n):
            v = abs(a[i, k])
            if v > amax:
                amax = v
                ip = i
        piv[k] = ip
        if not (amax > 0.0) or not math.isfinite(amax):
            return False
        if ip != k:
            for j in range(n):
                tmp = a[k, j]
                a[k, j] = a[ip, j]
                a[ip, j] = tmp
        inv = 1.0 / a[k, k]
        for i in range(k + 1, n):
            f = a[i, k] * inv
            a[i, k] = f
            if f != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= f * a[k, j]
    return True


@njit(cache=True)
def lu_solve(a, piv, b):
    """Solve with the factors of ``lu_factor``; b is overwritten by the solution."""
    n = a.shape[0]
    for k in range(n):
        ip = piv[k]
        if ip != k:
            tmp = b[k]
            b[k] = b[ip]
            b[ip] = tmp
    for i in range(n):
        acc = b[i]
        for j in range(i):
            acc -= a[i, j] * b[j]
        b[i] = acc
    for i in range(n - 1, -1, -1):
        acc = b[i]
        for j in range(i + 1, n):
            acc -= a[i, j] * b[j]
        b[i] = acc / a[i, i]


# ================================================================ Rodas kernels
@njit(cache=False, inline='always')
def _same_sides(events, t, ytmp, p, z, gbase, gtmp, ne):
    """Whether every event function that is nonzero at the base point keeps its sign at (t, ytmp)."""
    if ne == 0:
        return True
    events(t, ytmp, p, z, gtmp)
    for k in range(ne):
        if gbase[k] * gtmp[k] < 0.0:
            return False
    return True


@njit(cache=True)
def _pick_difference(fp, fm, f0, dp, dm, out):
    """out = the derivative estimate from f(+dp) = fp and f(+dm) = fm (dp > 0 > dm, f0 = f(0)).

    Where the forward and backward quotients agree (|a - b| <= 0.1 (|a| + |b|), a smooth f) the
    central difference is used; where they do not, a discontinuity of f (Coulomb friction's sign
    of the slip, a force clamp) lies between -|dm| and dp and the smaller quotient, the one-sided
    difference on the smooth side, is used. Returns whether all entries are finite."""
    finite = True
    for i in range(out.shape[0]):
        qa = (fp[i] - f0[i]) / dp
        qb = (fm[i] - f0[i]) / dm
        if abs(qa - qb) <= 0.1 * (abs(qa) + abs(qb)):
            v = (fp[i] - fm[i]) / (dp - dm)
        elif abs(qa) <= abs(qb):
            v = qa
        else:
            v = qb
        out[i] = v
        if not math.isfinite(v):
            finite = False
    return finite


@njit(cache=False, inline='always')
def fd_jacobian(rhs, events, t, y, f0, p, z, typ, hscale, J, fx, ytmp, fp, fm, col, gbase, gtmp,
                ne):
    """J = df/dy and fx = df/dt at (t, y), f0 = f(t, y), by differences of the rhs inside numba.

    Column j uses the increments +-sqrt(eps)*max(|y_j|, typ_j) (typ: the state's error scale),
    t the increments +-sqrt(eps)*max(|t|, hscale). Both sides are evaluated and combined by
    ``_pick_difference`` (central where f is smooth, one-sided on the smooth side of a jump).
    An increment that would put an event function (gbase = the events at (t, y)) on the other
    side of its zero, i.e. across a contact onset or a load switch, is not used: the difference
    is then one-sided on the side of the base point.
    Returns (whether J and fx are finite, rhs evaluations used: 2n + 2 at most)."""
    n = y.shape[0]
    for j in range(n):
        ytmp[j] = y[j]
    finite = True
    nev = 0
    for j in range(n + 1):
        if j < n:
            yj = y[j]
            d = SQRT_EPS * max(abs(yj), typ[j])
            if not (d > 0.0):
                d = SQRT_EPS
            ytmp[j] = yj + d
            dp = ytmp[j] - yj
            ok_p = _same_sides(events, t, ytmp, p, z, gbase, gtmp, ne)
            if ok_p:
                rhs(t, ytmp, p, z, fp)
                nev += 1
            ytmp[j] = yj - d
            dm = ytmp[j] - yj
            ok_m = _same_sides(events, t, ytmp, p, z, gbase, gtmp, ne)
            if ok_m or not ok_p:
                rhs(t, ytmp, p, z, fm)
                nev += 1
            ytmp[j] = yj
        else:
            d = SQRT_EPS * max(abs(t), hscale)
            if not (d > 0.0):
                d = SQRT_EPS
            tp = t + d
            tm = t - d
            dp = tp - t
            dm = tm - t
            ok_p = _same_sides(events, tp, y, p, z, gbase, gtmp, ne)
            if ok_p:
                rhs(tp, y, p, z, fp)
                nev += 1
            ok_m = _same_sides(events, tm, y, p, z, gbase, gtmp, ne)
            if ok_m or not ok_p:
                rhs(tm, y, p, z, fm)
                nev += 1
        if ok_p and ok_m:
            good = _pick_difference(fp, fm, f0, dp, dm, col)
        elif ok_p:
            good = True
            for i in range(n):
                col[i] = (fp[i] - f0[i]) / dp
                if not math.isfinite(col[i]):
                    good = False
        else:
            good = True
            for i in range(n):
                col[i] = (fm[i] - f0[i]) / dm
                if not math.isfinite(col[i]):
                    good = False
        if not good:
            finite = False
        if j < n:
            for i in range(n):
                J[i, j] = col[i]
        else:
            for i in range(n):
                fx[i] = col[i]
    return finite, nev


@njit(cache=True)
def _work(n):
    """(f0, fx, dy, AK, J, E, piv): f(t, y), df/dt, a stage's derivative, the stage increments,
    the Jacobian, the iteration matrix and its pivots."""
    return (np.empty(n), np.empty(n), np.empty(n), np.empty((6, n)), np.empty((n, n)),
            np.empty((n, n)), np.zeros(n, dtype=np.int64))


@njit(cache=True)
def _build_matrix(J, fac, E):
    """E = fac*I - J."""
    n = J.shape[0]
    for i in range(n):
        for j in range(n):
            E[i, j] = -J[i, j]
        E[i, i] += fac


@njit(cache=False, inline='always')
def _stages(rhs, t, h, t_new, y, f0, fx, E, piv, AK, ytmp, ynew, dy, p, z):
    """One Rodas4 step with the factored E = I/(h*gamma) - J: fills AK[0..5] and ynew
    (5 rhs evaluations). AK[5] is the error estimate."""
    n = y.shape[0]
    hc21 = C21 / h
    hc31 = C31 / h
    hc32 = C32 / h
    hc41 = C41 / h
    hc42 = C42 / h
    hc43 = C43 / h
    hc51 = C51 / h
    hc52 = C52 / h
    hc53 = C53 / h
    hc54 = C54 / h
    hc61 = C61 / h
    hc62 = C62 / h
    hc63 = C63 / h
    hc64 = C64 / h
    hc65 = C65 / h
    hd1 = h * D1
    hd2 = h * D2
    hd3 = h * D3
    hd4 = h * D4
    ak1 = AK[0]
    ak2 = AK[1]
    ak3 = AK[2]
    ak4 = AK[3]
    ak5 = AK[4]
    ak6 = AK[5]
    for i in range(n):
        ak1[i] = f0[i] + hd1 * fx[i]
    lu_solve(E, piv, ak1)
    for i in range(n):
        ytmp[i] = y[i] + A21 * ak1[i]
    rhs(t + C2 * h, ytmp, p, z, dy)
    for i in range(n):
        ak2[i] = dy[i] + hd2 * fx[i] + hc21 * ak1[i]
    lu_solve(E, piv, ak2)
    for i in range(n):
        ytmp[i] = y[i] + A31 * ak1[i] + A32 * ak2[i]
    rhs(t + C3 * h, ytmp, p, z, dy)
    for i in range(n):
        ak3[i] = dy[i] + hd3 * fx[i] + hc31 * ak1[i] + hc32 * ak2[i]
    lu_solve(E, piv, ak3)
    for i in range(n):
        ytmp[i] = y[i] + A41 * ak1[i] + A42 * ak2[i] + A43 * ak3[i]
    rhs(t + C4 * h, ytmp, p, z, dy)
    for i in range(n):
        ak4[i] = dy[i] + hd4 * fx[i] + hc41 * ak1[i] + hc42 * ak2[i] + hc43 * ak3[i]
    lu_solve(E, piv, ak4)
    for i in range(n):
        ytmp[i] = y[i] + A51 * ak1[i] + A52 * ak2[i] + A53 * ak3[i] + A54 * ak4[i]
    rhs(t_new, ytmp, p, z, dy)
    for i in range(n):
        ak5[i] = dy[i] + hc51 * ak1[i] + hc52 * ak2[i] + hc53 * ak3[i] + hc54 * ak4[i]
    lu_solve(E, piv, ak5)
    # embedded solution (order 3)
    for i in range(n):
        ytmp[i] += ak5[i]
    rhs(t_new, ytmp, p, z, dy)
    for i in range(n):
        ak6[i] = (dy[i] + hc61 * ak1[i] + hc62 * ak2[i] + hc63 * ak3[i] + hc64 * ak4[i]
                  + hc65 * ak5[i])
    lu_solve(E, piv, ak6)
    # new solution (order 4)
    for i in range(n):
        ynew[i] = ytmp[i] + ak6[i]


@njit(cache=True)
def _error_norm(y, ynew, ak6, atol, rtol):
    """The error norm (``rms_error``) of the estimate ak6 (the last stage increment)."""
    return rms_error(y, ynew, ak6, atol, rtol)


@njit(cache=True)
def _dense(y, ynew, AK, cont):
    """cont = [y, ynew, c2, c3] of the 3rd-order continuous extension (no rhs evaluation)."""
    for i in range(y.shape[0]):
        cont[0, i] = y[i]
        cont[1, i] = ynew[i]
        cont[2, i] = (D21 * AK[0, i] + D22 * AK[1, i] + D23 * AK[2, i] + D24 * AK[3, i]
                      + D25 * AK[4, i])
        cont[3, i] = (D31 * AK[0, i] + D32 * AK[1, i] + D33 * AK[2, i] + D34 * AK[3, i]
                      + D35 * AK[4, i])


@njit(cache=True)
def interp(theta, cont, out):
    """Dense output y(t + theta h) = (1-s) y0 + s (y1 + (1-s) (c2 + s c3)) (rodas.f CONTRO)."""
    s1 = 1.0 - theta
    for i in range(out.shape[0]):
        out[i] = cont[0, i] * s1 + theta * (cont[1, i] + s1 * (cont[2, i] + theta * cont[3, i]))


@njit(cache=True)
def rodas_core(rhs, events, on_event, interp_fn, t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax,
               max_steps, n_events, max_log, event_samples):
    """Adaptive Rodas4 from t0 to t_eval[-1]; same arguments and results as dopri5 (the jitted
    core; call ``rodas``).

    returns (status, t_reached, Y, n_out, stats, ev_t, ev_k, ev_dir, n_ev, Z), as the fields of
    nld.integrators.core.Solution

    status: 0 reached t_end, 1 stopped by on_event, -1 max_steps exceeded, -2 step size
    underflow, -3 non-finite values, -5 iteration matrix repeatedly singular.
    stats = [steps, accepted, rejected, rhs evals, events, jacobians, LU decompositions].
    event_samples: interior samples of every step's dense output scanned for event sign changes
    (nld.integrators.events).
    """
    n = y0.shape[0]
    n_eval = t_eval.shape[0]
    ne = n_events
    Y, Zo, stats, ev_t, ev_k, ev_dir, y, ynew, ytmp, yint, _ = new_run(
        t0, y0, t_eval, atol, z, max_log, 7)

    f0, fx, dy, AK, J, E, piv = _work(n)
    cont = np.empty((4, n))
    typ = np.empty(n)
    gcur, gnew, gtmp, gw, sgn, troot_a, troot, crossed = event_workspace(ne)

    # the loop works on borrowed views (no reference counting; nld.integrators.ownership)
    owners = (y, ynew, ytmp, yint, f0, fx, dy, AK, J, E, piv, cont, typ, gcur, gnew, gtmp, gw, sgn,
              troot_a, troot, crossed)
    (y, ynew, ytmp, yint, f0, fx, dy, AK, J, E, piv, cont, typ, gcur, gnew, gtmp, gw, sgn,
     troot_a, troot, crossed) = borrowed(owners)
    p, z, atol, t_eval, Yb, Zb, evt, evk, evd = borrowed((p, z, atol, t_eval, Y, Zo, ev_t, ev_k,
                                                          ev_dir))

    for i in range(n):
        typ[i] = atol[i] / rtol
    t = t0
    i_out, t_end, h, hcap, nfev = start(rhs, events, t0, y, f0, p, z, atol, rtol, h0, hmax,
                                        t_eval, Yb, Zb, ytmp, dy, 4.0, gcur, sgn)
    n_steps = n_acc = n_rej = n_nonfinite = n_ev = 0
    status = RUNNING
    njac = 0
    nlu = 0
    hnew = h
    reject = False
    need_f0 = False      # f0 = f(t, y) is current
    need_jac = True
    n_sing = 0
    hacc = 0.0
    erracc = 1.0

    while True:
        status = running(status, t, t_end, n_steps, max_steps)
        if status != RUNNING:
            break
        t_new, h = next_step(t, h, hcap, t_eval[i_out] if land else t_end)

        if need_jac:
            if need_f0:
                rhs(t, y, p, z, f0)
                nfev += 1
                need_f0 = False
            # gcur = events(t, y) is current here (start, accepted step, or event point)
            ok, nev = fd_jacobian(rhs, events, t, y, f0, p, z, typ, h, J, fx, ytmp, dy, ynew, yint,
                             gcur, gtmp, ne)
            nfev += nev
            njac += 1
            need_jac = False
            for i in range(n):
                if not math.isfinite(f0[i]):
                    ok = False
            if not ok:
                # non-finite derivatives at an accepted point: a smaller step cannot help
                status = NON_FINITE
                break

        n_steps += 1
        _build_matrix(J, 1.0 / (h * GAMMA), E)
        nlu += 1
        if not lu_factor(E, piv):
            n_sing += 1
            n_rej += 1
            reject = True
            h = 0.5 * h
            if n_sing >= MAX_SINGULAR:
                status = SINGULAR
                break
            continue
        n_sing = 0

        _stages(rhs, t, h, t_new, y, f0, fx, E, piv, AK, ytmp, ynew, dy, p, z)
        nfev += 5
        err = _error_norm(y, ynew, AK[5], atol, rtol)
        fac = max(FAC2, min(FAC1, err ** 0.25 / SAFE))
        ok, status, h, n_nonfinite, n_rej, n_acc = settle(err, fac, h, t, n_nonfinite, n_rej,
                                                          n_acc)
        if not ok:
            reject = True
            continue

        # accepted; Gustafsson's predictive controller
        hnew = h / fac
        if n_acc > 1:
            facgus = (hacc / h) * (err * err / erracc) ** 0.25 / SAFE
            facgus = max(FAC2, min(FAC1, facgus))
            fac = max(fac, facgus)
            hnew = h / fac
        hacc = h
        erracc = max(1.0e-2, err)
        if reject:
            hnew = min(hnew, h)
        reject = False
        need_jac = True
        need_f0 = True

        # ------------------------------------------------ event detection
        have_event = False
        dense_done = False
        tol = ROOT_RTOL * max(1.0, abs(t_new))
        t_star = t_new
        a_star = t_new
        first = -1
        if ne > 0:
            events(t_new, ynew, p, z, gnew)
            if event_samples > 0 or find_crossings(gnew, sgn, crossed):
                _dense(y, ynew, AK, cont)
                dense_done = True
                have_event, a_star, t_star, first = locate_earliest(
                    events, interp_fn, event_samples, t, h, t_new, gcur, gnew, sgn, cont, yint,
                    gtmp, gw, p, z, tol, crossed, troot_a, troot)

        if not have_event:
            if i_out < n_eval and t_eval[i_out] <= t_new:
                if t_eval[i_out] < t_new and not dense_done:
                    _dense(y, ynew, AK, cont)
                i_out = write_outputs(interp_fn, t, h, t_new, ynew, cont, t_eval, i_out, Yb, Zb, z)
            t = t_new
            y, ynew = ynew, y
            if ne > 0:
                gcur, gnew = gnew, gcur
                set_unknown_signs(gcur, sgn)
            h = hnew
            continue

        # ------------------------------------------------ event location
        # as dop853: locate on the dense output, retake the step (same Jacobian, new LU) to land
        # on the root, check the retaken end state, iterate until the root is at its end
        t_c = t_new             # end of the current step, state ynew
        dense_h = h             # cont is the dense output of [t, t + dense_h]
        fire = True
        for it in range(MAX_RELOCATE):
            retake, fire, a_star, t_star, first = relocate(
                it, events, interp_fn, event_samples, t, dense_h, t_c, a_star, t_star, first, gcur,
                gnew, sgn, cont, yint, gtmp, gw, p, z, tol, crossed, troot_a, troot)
            if not retake:
                break
            h_s = t_star - t
            _build_matrix(J, 1.0 / (h_s * GAMMA), E)
            nlu += 1
            ok = lu_factor(E, piv)
            if ok:
                _stages(rhs, t, h_s, t_star, y, f0, fx, E, piv, AK, ytmp, ynew, dy, p, z)
                nfev += 5
                ok = finite(ynew)
            t_c = t_star
            if not ok:          # fall back on the interpolant of the longer step
                copy_vector(yint, ynew)
                break
            _dense(y, ynew, AK, cont)
            dense_h = h_s
            fire = scan_due(events, event_samples, t_c, ynew, p, z, gnew, sgn, crossed)
            if not fire:
                break           # the event comes later: t_c is a plain step end

        if t_star > t:
            i_out = write_outputs(interp_fn, t, dense_h, t_c, ynew, cont, t_eval, i_out, Yb, Zb, z)
            t = t_c
            y, ynew = ynew, y

        if not fire:
            gcur, gnew = gnew, gcur
            set_unknown_signs(gcur, sgn)
            h = hnew
            continue

        # fire; restart with g there (f0 and the Jacobian at the next step)
        stop, n_ev = fire_events(on_event, crossed, troot, t_star, tol, sgn, t, y, p, z, evt,
                                 evk, evd, n_ev, max_log)
        events(t, y, p, z, gcur)
        set_unknown_signs(gcur, sgn)
        if stop:
            status = STOPPED
            break
        h = hnew

    keep_alive(owners)
    stats[5] = njac
    stats[6] = nlu
    return solution(status, t, Y, i_out, stats, ev_t, ev_k, ev_dir, n_ev, Zo, n_steps, n_acc, n_rej,
                    nfev)


rodas = front(rodas_core, interp)


@njit(cache=False)
def rodas_fixed(rhs, t0, y0, h, n_steps, p, z, typ):
    """n_steps fixed Rodas4 steps of size h (4th-order solution, finite-difference Jacobian at
    every step, no control, no events). typ: the state scales of the Jacobian increments."""
    y, ynew, ytmp, fx2 = work_vectors(y0)
    f0, fx, dy, AK, J, E, piv = _work(y0.shape[0])
    gnone = np.zeros(0)
    for s in range(n_steps):
        t, t_new = fixed_times(t0, h, s)
        hs = t_new - t
        rhs(t, y, p, z, f0)
        fd_jacobian(rhs, no_events, t, y, f0, p, z, typ, hs, J, fx, ytmp, dy, ynew, fx2, gnone,
                    gnone, 0)
        _build_matrix(J, 1.0 / (hs * GAMMA), E)
        if not lu_factor(E, piv):
            y[:] = np.nan
            return y
        _stages(rhs, t, hs, t_new, y, f0, fx, E, piv, AK, ytmp, ynew, dy, p, z)
        y, ynew = ynew, y
    return y
