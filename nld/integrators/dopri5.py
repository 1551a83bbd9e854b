"""Adaptive Dormand-Prince 5(4) integrator with dense output and event location, in numba.

Coefficients, error estimator, 4th-order continuous extension, PI ("Lund") step-size control
and the automatic initial step follow Hairer's DOPRI5 (Hairer, Norsett & Wanner, *Solving
Ordinary Differential Equations I*, 2nd ed., Springer 1993, sec. II.4-II.6 and the Fortran
code ``dopri5.f``). See ``docs/integrator.md``.

Everything with ``@njit`` takes the user's functions as arguments (numba dispatchers):

* ``rhs(t, y, p, z, dy)``            writes dy/dt into ``dy`` in place.
* ``events(t, y, p, z, g)``          writes the ``n_events`` event functions into ``g``.
* ``on_event(k, direction, t, y, p, z) -> int``  called at a located zero crossing of g_k;
  may modify ``z``; returns 0 to continue, 1 to stop (status 1).

``p`` (parameters) is read only; ``z`` (discrete state) is modified only by ``on_event``, in
place, so the caller sees its final value.

Caching: numba names the type of a jitted-function argument after the function's memory
address, so a ``dopri5`` specialization compiled by a call *from Python* is never found in the
disk cache by a later process (each new process recompiles, ~5 s). ``dopri5`` and its helpers
that take the user's functions are therefore ``inline='always'``: call ``dopri5`` from a
``@njit(cache=True)`` wrapper in which rhs/events/on_event are module globals, and the wrapper
(with dopri5 inlined) is loaded from the disk cache.
"""

import math

import numpy as np
from numba import njit

# ---------------------------------------------------------------- statuses
SUCCESS = 0          # reached t_end
STOPPED = 1          # on_event returned 1
MAX_STEPS = -1       # max_steps exceeded
STEP_UNDERFLOW = -2  # step size underflow after a rejection
NON_FINITE = -3      # non-finite values that halving the step could not cure

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

# ---------------------------------------------------------------- step-size control (Hairer)
BETA = 0.04
EXPO1 = 0.2 - 0.75 * BETA
SAFE = 0.9
FACMIN = 0.2    # hnew/h >= FACMIN
FACMAX = 10.0   # hnew/h <= FACMAX
FACC1 = 1.0 / FACMIN
FACC2 = 1.0 / FACMAX
FACOLD0 = 1.0e-4
MAX_NONFINITE = 50

EPS = 2.220446049250313e-16
ROOT_RTOL = 1.0e-12
ROOT_MAXITER = 200


# ---------------------------------------------------------------- kernels
@njit(cache=True, inline='always')
def rweight(atol, n, i):
    """Weight of rtol for state i: ``atol[n + i]`` when ``atol`` has 2n entries, else 1.

    The error scale of state i is ``atol[i] + rtol * rweight * max(|y_i|, |ynew_i|)``. A weight
    of 0 makes the control of that state purely absolute: used for angles that wind (a relative
    joint angle grows by 2 pi per crank revolution, so a relative tolerance would loosen as the
    run goes on) and for positions whose size says nothing about the accuracy needed (a journal
    position of 0.1 m next to a clearance of 0.1 mm). docs/integrator.md, "Tolerances"."""
    if atol.shape[0] == 2 * n:
        return atol[n + i]
    return 1.0


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


@njit(cache=True)
def _error_norm(h, y, ynew, k1, k3, k4, k5, k6, k7, atol, rtol):
    """RMS of err_i / (atol_i + rtol*max(|y_i|, |ynew_i|)); NaN if anything is non-finite."""
    n = y.shape[0]
    acc = 0.0
    for i in range(n):
        yn = ynew[i]
        if not math.isfinite(yn):
            return np.nan
        e = h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i])
        sk = atol[i] + rtol * rweight(atol, n, i) * max(abs(y[i]), abs(yn))
        q = e / sk
        acc += q * q
    if n == 0:
        return 0.0
    err = math.sqrt(acc / n)
    if not math.isfinite(err):
        return np.nan
    return err


@njit(cache=True)
def _dense_coeffs(h, y, ynew, k1, k3, k4, k5, k6, k7, r2, r3, r4, r5):
    """Hairer's continuous extension: y(t+th*h) = y + th*(r2 + (1-th)*(r3 + th*(r4 + (1-th)*r5)))."""
    n = y.shape[0]
    for i in range(n):
        ydiff = ynew[i] - y[i]
        bspl = h * k1[i] - ydiff
        r2[i] = ydiff
        r3[i] = bspl
        r4[i] = ydiff - h * k7[i] - bspl
        r5[i] = h * (D1 * k1[i] + D3 * k3[i] + D4 * k4[i] + D5 * k5[i] + D6 * k6[i]
                     + D7 * k7[i])


@njit(cache=True)
def _interp(theta, y, r2, r3, r4, r5, out):
    th1 = 1.0 - theta
    for i in range(y.shape[0]):
        out[i] = y[i] + theta * (r2[i] + th1 * (r3[i] + theta * (r4[i] + th1 * r5[i])))


@njit(cache=True)
def _interp_row(theta, y, r2, r3, r4, r5, Y, row):
    th1 = 1.0 - theta
    for i in range(y.shape[0]):
        Y[row, i] = y[i] + theta * (r2[i] + th1 * (r3[i] + theta * (r4[i] + th1 * r5[i])))


@njit(cache=False, inline='always')
def _initial_step(rhs, t0, y, f0, p, z, atol, rtol, hmax, span, y1, f1):
    """Hairer's HINIT for a 5th-order method (one extra rhs evaluation)."""
    n = y.shape[0]
    dnf = 0.0
    dny = 0.0
    for i in range(n):
        sk = atol[i] + rtol * rweight(atol, n, i) * abs(y[i])
        dnf += (f0[i] / sk) ** 2
        dny += (y[i] / sk) ** 2
    if dnf <= 1e-10 or dny <= 1e-10 or not math.isfinite(dnf) or not math.isfinite(dny):
        h = 1.0e-6
    else:
        h = math.sqrt(dny / dnf) * 0.01
    h = min(h, hmax, span)
    for i in range(n):
        y1[i] = y[i] + h * f0[i]
    rhs(t0 + h, y1, p, z, f1)
    der2 = 0.0
    for i in range(n):
        sk = atol[i] + rtol * rweight(atol, n, i) * abs(y[i])
        der2 += ((f1[i] - f0[i]) / sk) ** 2
    der2 = math.sqrt(der2) / h
    der12 = max(abs(der2), math.sqrt(dnf))
    if not math.isfinite(der12):
        h1 = abs(h) * 1.0e-3
    elif der12 <= 1e-15:
        h1 = max(1.0e-6, abs(h) * 1.0e-3)
    else:
        h1 = (0.01 / der12) ** (1.0 / 5.0)
    return min(100.0 * abs(h), h1, hmax, span)


@njit(cache=False, inline='always')
def _locate(events, k, s, t, h, t_new, gl, gr, y, r2, r3, r4, r5, yint, gtmp, p, z, tol):
    """Illinois (modified regula falsi) for g_k on the dense output of the step [t, t_new].

    ``s`` is the tracked sign of g_k (the side it is on), gr = g_k(t_new) is on the other
    side or 0. Returns the bracket end on the new side, i.e. at most ``tol`` after the root.

    If gl = g_k(t) is not strictly on side s (just after an event at t, g_k(t) is zero up
    to round-off and may lie on either side), the left end is moved to the first of
    t + tol*4^j (j = 0, 1, ...) where g_k is on side s; if there is none, the crossing is
    "now" and t is returned."""
    if gr == 0.0:
        return t_new
    a = t
    fa = gl
    if gl * s <= 0.0:
        d = tol
        while True:
            a = t + d
            if a >= t_new:
                return t
            _interp((a - t) / h, y, r2, r3, r4, r5, yint)
            events(a, yint, p, z, gtmp)
            fa = gtmp[k]
            if fa * s > 0.0:
                break
            d *= 4.0
    b = t_new
    fb = gr
    side = 0
    for _ in range(ROOT_MAXITER):
        if b - a <= tol or b - a <= 4.0 * EPS * abs(b):
            break
        c = b - fb * (b - a) / (fb - fa)
        if not (c > a and c < b):
            c = 0.5 * (a + b)
        _interp((c - t) / h, y, r2, r3, r4, r5, yint)
        events(c, yint, p, z, gtmp)
        fc = gtmp[k]
        if fc == 0.0:
            return c
        if fc * fb > 0.0:          # c is on b's side: b moves, a is retained
            b = c
            fb = fc
            if side == -1:
                fa *= 0.5
            side = -1
        else:                      # c is on a's side (or fc is NaN): a moves
            a = c
            fa = fc
            if side == 1:
                fb *= 0.5
            side = 1
    return b


@njit(cache=False, inline='always')
def dopri5(rhs, events, on_event, t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax,
           max_steps, n_events, max_log):
    """Adaptive DOPRI5 from t0 to t_eval[-1].

    returns (status, t_reached, Y, n_out, stats, ev_t, ev_k, ev_dir, n_ev, Z)

    Z[i] is the discrete state z in force at output row i (for observing hysteresis laws).

    status: 0 reached t_end, 1 stopped by on_event, -1 max_steps exceeded, -2 step size
    underflow, -3 non-finite values. Y has one row per t_eval (NaN where not reached);
    the first n_out rows are filled. stats = [steps, accepted, rejected, rhs evals, events].
    """
    n = y0.shape[0]
    n_eval = t_eval.shape[0]
    ne = n_events

    for i in range(1, n_eval):
        if t_eval[i] < t_eval[i - 1]:
            raise ValueError("t_eval must be sorted ascending")
    if n_eval > 0 and t_eval[0] < t0:
        raise ValueError("t_eval must lie within [t0, t_end]")
    if atol.shape[0] != n and atol.shape[0] != 2 * n:
        raise ValueError("atol must have one entry per state (or 2n: atol, then rtol weights)")

    Y = np.full((n_eval, n), np.nan)
    Zo = np.zeros((n_eval, z.shape[0]))     # discrete state in force at each output row
    stats = np.zeros(5, dtype=np.int64)
    ev_t = np.empty(max_log, dtype=np.float64)      # only the first n_ev entries are written
    ev_k = np.empty(max_log, dtype=np.int64)
    ev_dir = np.empty(max_log, dtype=np.int64)
    n_ev = 0

    # work arrays, allocated once
    y = np.empty(n)
    ynew = np.empty(n)
    ytmp = np.empty(n)
    yint = np.empty(n)
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    k5 = np.empty(n)
    k6 = np.empty(n)
    k7 = np.empty(n)
    r2 = np.empty(n)
    r3 = np.empty(n)
    r4 = np.empty(n)
    r5 = np.empty(n)
    gcur = np.empty(ne)
    gnew = np.empty(ne)
    gtmp = np.empty(ne)
    sgn = np.zeros(ne, dtype=np.int64)      # tracked sign of g_k (0 = undetermined)
    troot = np.empty(ne)
    crossed = np.zeros(ne, dtype=np.bool_)

    for i in range(n):
        y[i] = y0[i]
    t = t0
    i_out = 0
    while i_out < n_eval and t_eval[i_out] <= t0:
        for j in range(n):
            Y[i_out, j] = y0[j]
        Zo[i_out, :] = z
        i_out += 1
    if i_out >= n_eval:
        return 0, t0, Y, i_out, stats, ev_t, ev_k, ev_dir, n_ev, Zo
    t_end = t_eval[n_eval - 1]

    n_steps = 0
    n_acc = 0
    n_rej = 0
    nfev = 0

    rhs(t, y, p, z, k1)
    nfev += 1
    if ne > 0:
        events(t, y, p, z, gcur)
        for k in range(ne):
            if gcur[k] > 0.0:
                sgn[k] = 1
            elif gcur[k] < 0.0:
                sgn[k] = -1

    span = t_end - t0
    hcap = span
    if hmax > 0.0 and hmax < hcap:
        hcap = hmax
    if h0 > 0.0:
        h = min(h0, hcap)
    else:
        h = _initial_step(rhs, t0, y, k1, p, z, atol, rtol, hcap, span, ytmp, k2)
        nfev += 1
    if not (h > 0.0) or not math.isfinite(h):
        h = 1e-6 * span

    facold = FACOLD0
    reject = False
    n_nonfinite = 0
    status = 0

    while True:
        if t >= t_end:
            status = 0
            break
        if n_steps >= max_steps:
            status = -1
            break
        target = t_eval[i_out] if land else t_end
        if h > hcap:
            h = hcap
        if h < 4.0 * EPS * abs(t):      # never a step that does not move t
            h = 4.0 * EPS * abs(t)
        if t + 1.01 * h >= target:      # land on the target, no sliver step (as in DOPRI5)
            t_new = target
        else:
            t_new = t + h
        h = t_new - t
        n_steps += 1

        _stages(rhs, t, h, t_new, y, k1, k2, k3, k4, k5, k6, k7, ytmp, ynew, p, z)
        nfev += 6
        err = _error_norm(h, y, ynew, k1, k3, k4, k5, k6, k7, atol, rtol)

        if not math.isfinite(err):
            # non-finite solution or error estimate: reject and halve
            n_rej += 1
            n_nonfinite += 1
            reject = True
            h = 0.5 * h
            if n_nonfinite >= MAX_NONFINITE or h < 16.0 * EPS * abs(t) or h < 1e-300:
                status = -3
                break
            continue
        n_nonfinite = 0

        fac11 = err ** EXPO1
        if err > 1.0:
            # rejected
            h = h / min(FACC1, fac11 / SAFE)
            reject = True
            n_rej += 1
            if h < 16.0 * EPS * abs(t) or h < 1e-300:
                status = -2
                break
            continue

        # accepted: PI (Lund-stabilized) proposal for the next step
        fac = fac11 / facold ** BETA
        fac = max(FACC2, min(FACC1, fac / SAFE))
        hnew = h / fac
        if reject:
            hnew = min(hnew, h)
        reject = False
        facold = max(err, FACOLD0)
        n_acc += 1

        # ------------------------------------------------ event detection
        have_event = False
        if ne > 0:
            events(t_new, ynew, p, z, gnew)
            for k in range(ne):
                crossed[k] = sgn[k] != 0 and gnew[k] * sgn[k] <= 0.0
                if crossed[k]:
                    have_event = True

        if not have_event:
            # dense output for t_eval in (t, t_new]
            dense_done = False
            while i_out < n_eval and t_eval[i_out] <= t_new:
                te = t_eval[i_out]
                if te == t_new:
                    for j in range(n):
                        Y[i_out, j] = ynew[j]
                else:
                    if not dense_done:
                        _dense_coeffs(h, y, ynew, k1, k3, k4, k5, k6, k7, r2, r3, r4, r5)
                        dense_done = True
                    _interp_row((te - t) / h, y, r2, r3, r4, r5, Y, i_out)
                Zo[i_out, :] = z
                i_out += 1
            t = t_new
            y, ynew = ynew, y
            k1, k7 = k7, k1     # FSAL
            if ne > 0:
                gcur, gnew = gnew, gcur
                for k in range(ne):
                    if sgn[k] == 0:
                        if gcur[k] > 0.0:
                            sgn[k] = 1
                        elif gcur[k] < 0.0:
                            sgn[k] = -1
            h = hnew
            continue

        # ------------------------------------------------ event location
        _dense_coeffs(h, y, ynew, k1, k3, k4, k5, k6, k7, r2, r3, r4, r5)
        tol = ROOT_RTOL * max(1.0, abs(t_new))
        t_star = t_new
        for k in range(ne):
            if crossed[k]:
                troot[k] = _locate(events, k, sgn[k], t, h, t_new, gcur[k], gnew[k], y, r2,
                                   r3, r4, r5, yint, gtmp, p, z, tol)
                if troot[k] < t_star:
                    t_star = troot[k]

        if t_star > t:
            if t_star < t_new:
                # retake the step so the state at t_star is a true 5th-order solution
                _interp((t_star - t) / h, y, r2, r3, r4, r5, yint)
                h_s = t_star - t
                _stages(rhs, t, h_s, t_star, y, k1, k2, k3, k4, k5, k6, k7, ytmp, ynew, p, z)
                nfev += 6
                ok = True
                for j in range(n):
                    if not math.isfinite(ynew[j]):
                        ok = False
                        break
                if ok:
                    h_d = h_s
                    _dense_coeffs(h_d, y, ynew, k1, k3, k4, k5, k6, k7, r2, r3, r4, r5)
                else:
                    # fall back on the (finite) interpolant of the original step
                    h_d = h
                    for j in range(n):
                        ynew[j] = yint[j]
            else:
                h_d = h
            while i_out < n_eval and t_eval[i_out] <= t_star:
                te = t_eval[i_out]
                if te == t_star:
                    for j in range(n):
                        Y[i_out, j] = ynew[j]
                else:
                    _interp_row((te - t) / h_d, y, r2, r3, r4, r5, Y, i_out)
                Zo[i_out, :] = z
                i_out += 1
            t = t_star
            y, ynew = ynew, y

        # fire every crossing whose root is within tol of t_star
        stop = False
        for k in range(ne):
            if crossed[k] and troot[k] <= t_star + tol:
                direction = -sgn[k]
                if n_ev < max_log:
                    ev_t[n_ev] = t
                    ev_k[n_ev] = k
                    ev_dir[n_ev] = direction
                n_ev += 1
                sgn[k] = direction
                if on_event(k, direction, t, y, p, z) == 1:
                    stop = True
        # z may have changed: FSAL is invalid, recompute k1 and g at the event point
        rhs(t, y, p, z, k1)
        nfev += 1
        events(t, y, p, z, gcur)
        for k in range(ne):
            if sgn[k] == 0:
                if gcur[k] > 0.0:
                    sgn[k] = 1
                elif gcur[k] < 0.0:
                    sgn[k] = -1
        if stop:
            status = 1
            break
        h = hnew

    stats[0] = n_steps
    stats[1] = n_acc
    stats[2] = n_rej
    stats[3] = nfev
    stats[4] = n_ev
    return status, t, Y, i_out, stats, ev_t, ev_k, ev_dir, n_ev, Zo


@njit(cache=False)
def dopri5_fixed(rhs, t0, y0, h, n_steps, p, z):
    """n_steps fixed DOPRI5 steps of size h (5th-order solution, no control, no events)."""
    n = y0.shape[0]
    y = y0.copy()
    ynew = np.empty(n)
    ytmp = np.empty(n)
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    k5 = np.empty(n)
    k6 = np.empty(n)
    k7 = np.empty(n)
    rhs(t0, y, p, z, k1)
    for s in range(n_steps):
        t = t0 + s * h
        t_new = t0 + (s + 1) * h
        _stages(rhs, t, h, t_new, y, k1, k2, k3, k4, k5, k6, k7, ytmp, ynew, p, z)
        y, ynew = ynew, y
        k1, k7 = k7, k1
    return y


@njit(cache=True)
def no_events(t, y, p, z, g):
    """Placeholder ``events`` for n_events = 0 (never called)."""
    pass


@njit(cache=True)
def no_on_event(k, direction, t, y, p, z):
    """Placeholder ``on_event`` that never stops."""
    return 0


def status_message(status, t_reached, stats):
    """One-line human description of a dopri5 result."""
    st = [int(v) for v in stats] + [0] * max(0, 5 - len(stats))
    counts = f"{st[1]} steps, {st[2]} rejected, {st[3]} rhs evaluations"
    t = float(t_reached)
    status = int(status)
    if status == SUCCESS:
        return f"reached t_end = {t:.9g} s ({counts})"
    if status == STOPPED:
        return f"stopped by an event at t = {t:.9g} s ({counts}, {st[4]} events)"
    if status == MAX_STEPS:
        return (f"max_steps exceeded at t = {t:.9g} s after {st[0]} steps: raise max_steps, "
                f"loosen the tolerance or use the stiff solver")
    if status == STEP_UNDERFLOW:
        return (f"step size underflow at t = {t:.9g} s: the tolerance cannot be met "
                f"(stiff contact or a singularity? try a looser rtol/atol or the stiff solver)")
    if status == NON_FINITE:
        return (f"non-finite value (NaN/inf) in the solution at t = {t:.9g} s: the state "
                f"diverged (check parameters and initial conditions, or use the stiff solver)")
    return f"unknown integrator status {status} at t = {t:.9g} s"
