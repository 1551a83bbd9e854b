"""Adaptive Dormand-Prince 8(5,3) integrator (Hairer's DOP853) with 7th-order dense output and
event location, in numba, with the interface, events and statuses of :mod:`nld.integrators.dopri5`.

Method: the explicit 12-stage Runge-Kutta pair of Dormand & Prince of order 8 with Hairer's
error estimator combining an embedded 5th-order and 3rd-order solution, the 7th-order continuous
extension (three extra stages) and the step-size control and initial step of the Fortran code
``dop853.f`` (E. Hairer, S. P. Norsett, G. Wanner, *Solving Ordinary Differential Equations I*,
2nd ed., Springer 1993, sec. II.5 and II.10). The coefficients are Hairer's, as tabulated in
``dop853.f`` (and, to the same 30 digits, in SciPy's ``dop853_coefficients.py``; the tests check
that the two agree). See ``docs/integrators.md``.

Interface (identical to ``dopri5``)::

    status, t_reached, Y, n_out, stats, ev_t, ev_k, ev_dir, n_ev, Z = dop853(
        rhs, events, on_event, t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax,
        max_steps, n_events, max_log)

``stats = [steps, accepted, rejected, rhs evaluations, events]`` (length 5, as dopri5).
Statuses: those of dopri5, plus ``STIFF = -6`` from Hairer's stiffness detection (dop853.f): when
15 accepted steps are limited by stability rather than accuracy, the run stops there instead of
going on with a noisy, possibly wrong stiff component (seen on heavily damped persistent contact);
use the stiff solver ``rodas``.

Events are located by :mod:`nld.integrators.events` (shared by every integrator: interior
samples of the dense output, Illinois, earliest root wins, step retaken to land on it). The
7th-order dense output costs three more rhs evaluations, so the interior samples are first
screened on the cubic Hermite interpolant of the step's ends (``_hermite_screen``) and the dense
output is formed only for a step the screen, the step's end or an output time flags.

Compilation and step control: as for dopri5, ``dop853_core`` is compiled once for first-class
function arguments and ``dop853`` is its Python front; the step-control core (initial step,
landing, PI control, output writing, statuses) is nld.integrators.core's.
"""

import math

import numpy as np
from numba import njit

from .core import (MAX_RELOCATE, RUNNING, STIFF, all_finite, copy_vector, finite,
                   event_workspace, fire_and_restart, fixed_times, front, new_run, next_step,
                   pi_control, pi_start, relocate, retake_finite, running, rweight, scan_due,
                   solution, start, work_vectors, write_outputs)
from .ownership import borrowed, keep_alive
from .events import (EVENT_SAMPLES, ROOT_RTOL, find_crossings, locate_earliest,  # noqa: F401
                     set_unknown_signs)

# ---------------------------------------------------------------- Hairer's DOP853 coefficients
# Rows 0..11: the 12 stages; row 12: the 8th-order weights B (the FSAL point, K[12] =
# f(t + h, y_new)); rows 13..15: the three extra stages of the dense output.
C = np.array([0.0,
              0.526001519587677318785587544488e-01,
              0.789002279381515978178381316732e-01,
              0.118350341907227396726757197510,
              0.281649658092772603273242802490,
              0.333333333333333333333333333333,
              0.25,
              0.307692307692307692307692307692,
              0.651282051282051282051282051282,
              0.6,
              0.857142857142857142857142857142,
              1.0,
              1.0,
              0.1,
              0.2,
              0.777777777777777777777777777778])

A = np.zeros((16, 16))
A[1, 0] = 5.26001519587677318785587544488e-2
A[2, 0] = 1.97250569845378994544595329183e-2
A[2, 1] = 5.91751709536136983633785987549e-2
A[3, 0] = 2.95875854768068491816892993775e-2
A[3, 2] = 8.87627564304205475450678981324e-2
A[4, 0] = 2.41365134159266685502369798665e-1
A[4, 2] = -8.84549479328286085344864962717e-1
A[4, 3] = 9.24834003261792003115737966543e-1
A[5, 0] = 3.7037037037037037037037037037e-2
A[5, 3] = 1.70828608729473871279604482173e-1
A[5, 4] = 1.25467687566822425016691814123e-1
A[6, 0] = 3.7109375e-2
A[6, 3] = 1.70252211019544039314978060272e-1
A[6, 4] = 6.02165389804559606850219397283e-2
A[6, 5] = -1.7578125e-2
A[7, 0] = 3.70920001185047927108779319836e-2
A[7, 3] = 1.70383925712239993810214054705e-1
A[7, 4] = 1.07262030446373284651809199168e-1
A[7, 5] = -1.53194377486244017527936158236e-2
A[7, 6] = 8.27378916381402288758473766002e-3
A[8, 0] = 6.24110958716075717114429577812e-1
A[8, 3] = -3.36089262944694129406857109825
A[8, 4] = -8.68219346841726006818189891453e-1
A[8, 5] = 2.75920996994467083049415600797e1
A[8, 6] = 2.01540675504778934086186788979e1
A[8, 7] = -4.34898841810699588477366255144e1
A[9, 0] = 4.77662536438264365890433908527e-1
A[9, 3] = -2.48811461997166764192642586468
A[9, 4] = -5.90290826836842996371446475743e-1
A[9, 5] = 2.12300514481811942347288949897e1
A[9, 6] = 1.52792336328824235832596922938e1
A[9, 7] = -3.32882109689848629194453265587e1
A[9, 8] = -2.03312017085086261358222928593e-2
A[10, 0] = -9.3714243008598732571704021658e-1
A[10, 3] = 5.18637242884406370830023853209
A[10, 4] = 1.09143734899672957818500254654
A[10, 5] = -8.14978701074692612513997267357
A[10, 6] = -1.85200656599969598641566180701e1
A[10, 7] = 2.27394870993505042818970056734e1
A[10, 8] = 2.49360555267965238987089396762
A[10, 9] = -3.0467644718982195003823669022
A[11, 0] = 2.27331014751653820792359768449
A[11, 3] = -1.05344954667372501984066689879e1
A[11, 4] = -2.00087205822486249909675718444
A[11, 5] = -1.79589318631187989172765950534e1
A[11, 6] = 2.79488845294199600508499808837e1
A[11, 7] = -2.85899827713502369474065508674
A[11, 8] = -8.87285693353062954433549289258
A[11, 9] = 1.23605671757943030647266201528e1
A[11, 10] = 6.43392746015763530355970484046e-1
A[12, 0] = 5.42937341165687622380535766363e-2
A[12, 5] = 4.45031289275240888144113950566
A[12, 6] = 1.89151789931450038304281599044
A[12, 7] = -5.8012039600105847814672114227
A[12, 8] = 3.1116436695781989440891606237e-1
A[12, 9] = -1.52160949662516078556178806805e-1
A[12, 10] = 2.01365400804030348374776537501e-1
A[12, 11] = 4.47106157277725905176885569043e-2
A[13, 0] = 5.61675022830479523392909219681e-2
A[13, 6] = 2.53500210216624811088794765333e-1
A[13, 7] = -2.46239037470802489917441475441e-1
A[13, 8] = -1.24191423263816360469010140626e-1
A[13, 9] = 1.5329179827876569731206322685e-1
A[13, 10] = 8.20105229563468988491666602057e-3
A[13, 11] = 7.56789766054569976138603589584e-3
A[13, 12] = -8.298e-3
A[14, 0] = 3.18346481635021405060768473261e-2
A[14, 5] = 2.83009096723667755288322961402e-2
A[14, 6] = 5.35419883074385676223797384372e-2
A[14, 7] = -5.49237485713909884646569340306e-2
A[14, 10] = -1.08347328697249322858509316994e-4
A[14, 11] = 3.82571090835658412954920192323e-4
A[14, 12] = -3.40465008687404560802977114492e-4
A[14, 13] = 1.41312443674632500278074618366e-1
A[15, 0] = -4.28896301583791923408573538692e-1
A[15, 5] = -4.69762141536116384314449447206
A[15, 6] = 7.68342119606259904184240953878
A[15, 7] = 4.06898981839711007970213554331
A[15, 8] = 3.56727187455281109270669543021e-1
A[15, 12] = -1.39902416515901462129418009734e-3
A[15, 13] = 2.9475147891527723389556272149
A[15, 14] = -9.15095847217987001081870187138

B = A[12, :12].copy()

# embedded 3rd-order weights (Hairer's BHH1..3): E3 = B - BHH
BHH1 = 0.244094488188976377952755905512
BHH2 = 0.733846688281611857341361741547
BHH3 = 0.220588235294117647058823529412e-1
E3 = np.zeros(13)
E3[:12] = B
E3[0] -= BHH1
E3[8] -= BHH2
E3[11] -= BHH3

E5 = np.zeros(13)
E5[0] = 0.1312004499419488073250102996e-1
E5[5] = -0.1225156446376204440720569753e+1
E5[6] = -0.4957589496572501915214079952
E5[7] = 0.1664377182454986536961530415e+1
E5[8] = -0.3503288487499736816886487290
E5[9] = 0.3341791187130174790297318841
E5[10] = 0.8192320648511571246570742613e-1
E5[11] = -0.2235530786388629525884427845e-1
D = np.zeros((4, 16))
D[0, 0] = -0.84289382761090128651353491142e+1
D[0, 5] = 0.56671495351937776962531783590
D[0, 6] = -0.30689499459498916912797304727e+1
D[0, 7] = 0.23846676565120698287728149680e+1
D[0, 8] = 0.21170345824450282767155149946e+1
D[0, 9] = -0.87139158377797299206789907490
D[0, 10] = 0.22404374302607882758541771650e+1
D[0, 11] = 0.63157877876946881815570249290
D[0, 12] = -0.88990336451333310820698117400e-1
D[0, 13] = 0.18148505520854727256656404962e+2
D[0, 14] = -0.91946323924783554000451984436e+1
D[0, 15] = -0.44360363875948939664310572000e+1
D[1, 0] = 0.10427508642579134603413151009e+2
D[1, 5] = 0.24228349177525818288430175319e+3
D[1, 6] = 0.16520045171727028198505394887e+3
D[1, 7] = -0.37454675472269020279518312152e+3
D[1, 8] = -0.22113666853125306036270938578e+2
D[1, 9] = 0.77334326684722638389603898808e+1
D[1, 10] = -0.30674084731089398182061213626e+2
D[1, 11] = -0.93321305264302278729567221706e+1
D[1, 12] = 0.15697238121770843886131091075e+2
D[1, 13] = -0.31139403219565177677282850411e+2
D[1, 14] = -0.93529243588444783865713862664e+1
D[1, 15] = 0.35816841486394083752465898540e+2
D[2, 0] = 0.19985053242002433820987653617e+2
D[2, 5] = -0.38703730874935176555105901742e+3
D[2, 6] = -0.18917813819516756882830838328e+3
D[2, 7] = 0.52780815920542364900561016686e+3
D[2, 8] = -0.11573902539959630126141871134e+2
D[2, 9] = 0.68812326946963000169666922661e+1
D[2, 10] = -0.10006050966910838403183860980e+1
D[2, 11] = 0.77771377980534432092869265740
D[2, 12] = -0.27782057523535084065932004339e+1
D[2, 13] = -0.60196695231264120758267380846e+2
D[2, 14] = 0.84320405506677161018159903784e+2
D[2, 15] = 0.11992291136182789328035130030e+2
D[3, 0] = -0.25693933462703749003312586129e+2
D[3, 5] = -0.15418974869023643374053993627e+3
D[3, 6] = -0.23152937917604549567536039109e+3
D[3, 7] = 0.35763911791061412378285349910e+3
D[3, 8] = 0.93405324183624310003907691704e+2
D[3, 9] = -0.37458323136451633156875139351e+2
D[3, 10] = 0.10409964950896230045147246184e+3
D[3, 11] = 0.29840293426660503123344363579e+2
D[3, 12] = -0.43533456590011143754432175058e+2
D[3, 13] = 0.96324553959188282948394950600e+2
D[3, 14] = -0.39177261675615439165231486172e+2
D[3, 15] = -0.14972683625798562581422125276e+3

# ---------------------------------------------------------------- step-size control (dop853.f)
SAFE = 0.9
FAC1 = 0.333     # hnew/h >= FAC1
FAC2 = 6.0       # hnew/h <= FAC2
FACC1 = 1.0 / FAC1
# After a mode change a rejected step shrinks faster: nld.integrators.core.rejected_shrink
FACC2 = 1.0 / FAC2
BETA = 0.0       # dop853.f default: no PI term
EXPO1 = 1.0 / 8.0 - BETA * 0.2
FACOLD0 = 1.0e-4

# ---------------------------------------------------------------- stiffness detection (dop853.f)
HLAMB_STIFF = 6.1   # |h| * (Lipschitz estimate along the last stage) above this: a stiff step
N_STIFF = 15        # this many stiff steps (not separated by 6 non-stiff ones) stop the run



# ================================================================ DOP853 kernels
@njit(cache=False, inline='always')
def _stages(rhs, t, h, t_new, y, K, ytmp, ynew, p, z):
    """One DOP853 step from (t, y) with K[0] = f(t, y): fills K[1..11], ynew and
    K[12] = f(t_new, ynew) (FSAL)."""
    n = y.shape[0]
    for s in range(1, 12):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            ytmp[i] = y[i] + h * acc
        ts = t_new if s == 11 else t + C[s] * h
        rhs(ts, ytmp, p, z, K[s])
    for i in range(n):
        acc = 0.0
        for j in range(12):
            acc += B[j] * K[j, i]
        ynew[i] = y[i] + h * acc
    rhs(t_new, ynew, p, z, K[12])


@njit(cache=True)
def _error_norm(h, y, ynew, K, atol, rtol, cautious):
    """Hairer's DOP853 error: |h| err5^2 / sqrt(n (err5^2 + 0.01 err3^2)) (RMS-scaled);
    NaN if anything is non-finite.

    The combination is O(h^8) for a smooth solution, but where the 3rd-order estimate is more
    than 10x the 5th-order one it is *smaller* than the 5th-order estimate. That happens on the
    step that starts at a contact onset (the force grows like (t - t*)^1.5, the solution is not
    smooth there) and let a step with a wrong impact velocity through. With ``cautious`` (the
    first step after an event) the error is at least the plain 5th-order estimate.

    The step's end derivative K[12] = f(t + h, ynew) is not in either estimate (DOPRI5's is:
    its E7 weighs k7), but it is the next step's K[0] (FSAL): a finite ynew whose derivative is
    not finite (a state the right-hand side cannot evaluate, e.g. past a contact the stages did
    not see) was accepted, and every later step was non-finite, halved 50 times, status -3.
    It is checked here: NaN, the step is retried with h halved. (Issue 38: the hard case
    energy_10krev_dop853 stopped with status -3 after ~905 revolutions on the machine it was
    measured on, right after a contact onset, while dopri5 ran on; this is the way a run of
    dop853, and not of dopri5, turns non-finite for good after a finite step. That stop was not
    reproduced on the machine of the fix: tests/test_dop853_endpoint.py injects the fault.)"""
    n = y.shape[0]
    err = 0.0
    err2 = 0.0
    for i in range(n):
        yn = ynew[i]
        if not (math.isfinite(yn) and math.isfinite(K[12, i])):
            return np.nan
        sk = atol[i] + rtol * rweight(atol, n, i) * max(abs(y[i]), abs(yn))
        e3 = 0.0
        e5 = 0.0
        for j in range(12):
            e3 += E3[j] * K[j, i]
            e5 += E5[j] * K[j, i]
        err2 += (e3 / sk) ** 2
        err += (e5 / sk) ** 2
    if n == 0:
        return 0.0
    deno = err + 0.01 * err2
    if deno <= 0.0:
        deno = 1.0
    e = abs(h) * err * math.sqrt(1.0 / (n * deno))
    if cautious:
        e = max(e, abs(h) * math.sqrt(err / n))
    if not math.isfinite(e):
        return np.nan
    return e


@njit(cache=True)
def _stiff_step(h, K, ynew, y12):
    """dop853.f's test: h*sqrt(|K12 - K11|^2 / |ynew - y12|^2) > 6.1 (y12 = the last stage's
    argument, K11 = f(t_new, y12), K12 = f(t_new, ynew)): the step is at the stability limit."""
    stnum = 0.0
    stden = 0.0
    for i in range(ynew.shape[0]):
        stnum += (K[12, i] - K[11, i]) ** 2
        stden += (ynew[i] - y12[i]) ** 2
    if stden > 0.0:
        return abs(h) * math.sqrt(stnum / stden) > HLAMB_STIFF
    return False


@njit(cache=False, inline='always')
def _dense(rhs, t, h, y, ynew, K, ytmp, cont, p, z):
    """Three extra stages K[13..15] and the coefficients of the 7th-order continuous extension:
    cont = [y, F0..F6] (K[0] = f(t, y), K[12] = f(t + h, ynew) must be current)."""
    n = y.shape[0]
    for s in range(13, 16):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            ytmp[i] = y[i] + h * acc
        rhs(t + C[s] * h, ytmp, p, z, K[s])
    for i in range(n):
        dy = ynew[i] - y[i]
        bspl = h * K[0, i] - dy
        cont[0, i] = y[i]
        cont[1, i] = dy
        cont[2, i] = bspl
        cont[3, i] = dy - h * K[12, i] - bspl
        for r in range(4):
            acc = 0.0
            for j in range(16):
                acc += D[r, j] * K[j, i]
            cont[4 + r, i] = h * acc


@njit(cache=False, inline='always')
def _hermite_screen(events, n_samples, t, h, y, ynew, K, yint, gtmp, sgn, p, z):
    """Whether some event function with a tracked side has left it at one of ``n_samples``
    equally spaced interior points t + j h / (n_samples + 1) of the step, evaluated on the cubic
    Hermite interpolant of the step's ends (y, K[0] = f(t, y), ynew, K[12] = f(t + h, ynew): the
    first four terms of CONTD8, no extra stage). The 7th-order dense output costs three more rhs
    evaluations; it is formed only for a step this screen (or the step's end) flags, and the
    scan, refinement and root are then taken on it (nld.integrators.events)."""
    n = y.shape[0]
    ne = gtmp.shape[0]
    for j in range(1, n_samples + 1):
        th = j / (n_samples + 1)
        th1 = 1.0 - th
        for i in range(n):
            dy = ynew[i] - y[i]
            bspl = h * K[0, i] - dy
            yint[i] = y[i] + th * (dy + th1 * (bspl + th * (dy - h * K[12, i] - bspl)))
        events(t + th * h, yint, p, z, gtmp)
        for q in range(ne):
            if sgn[q] != 0 and gtmp[q] * sgn[q] <= 0.0:
                return True
    return False


@njit(cache=True)
def _untrusted(n_acc, n_rej, h):
    """A step whose dense output is not finite: its extra stages met a force the 12 stages of the
    step did not see (a contact inside the step), so the step is not trusted. Counted as
    rejected and retried with h halved: returns (n_acc, n_rej, reject, h)."""
    return n_acc - 1, n_rej + 1, True, 0.5 * h


@njit(cache=True)
def interp(theta, cont, out):
    """Dense output y(t + theta h) from cont = [y, F0..F6] (Hairer's CONTD8)."""
    th1 = 1.0 - theta
    for i in range(out.shape[0]):
        out[i] = cont[0, i] + theta * (cont[1, i] + th1 * (cont[2, i] + theta * (
            cont[3, i] + th1 * (cont[4, i] + theta * (cont[5, i] + th1 * (
                cont[6, i] + theta * cont[7, i]))))))


@njit(cache=True)
def dop853_core(rhs, events, on_event, interp_fn, t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax,
                max_steps, n_events, max_log, event_samples):
    """Adaptive DOP853 from t0 to t_eval[-1]; same arguments, results and statuses as dopri5
    (the jitted core; call ``dop853``).

    returns (status, t_reached, Y, n_out, stats, ev_t, ev_k, ev_dir, n_ev, Z), as the fields of
    nld.integrators.core.Solution

    status: 0 reached t_end, 1 stopped by on_event, -1 max_steps exceeded, -2 step size
    underflow, -3 non-finite values, -6 the problem became stiff (Hairer's stiffness detection:
    15 steps at the stability limit; an explicit method would go on with noisy, possibly wrong
    stiff components: use rodas). stats = [steps, accepted, rejected, rhs evals, events].
    event_samples: interior samples of every step's dense output scanned for event sign changes
    (nld.integrators.events); with event_samples > 0 and events, every accepted step computes
    its dense output (3 more rhs evaluations).
    """
    n = y0.shape[0]
    n_eval = t_eval.shape[0]
    ne = n_events
    Y, Zo, stats, ev_t, ev_k, ev_dir, y, ynew, ytmp, yint, zsave = new_run(
        t0, y0, t_eval, atol, z, max_log, 5)

    K = np.empty((16, n))
    cont = np.empty((8, n))
    gcur, gnew, gtmp, gw, sgn, troot_a, troot, crossed = event_workspace(ne)
    # the loop works on borrowed views (no reference counting; nld.integrators.ownership)
    owners = (y, ynew, ytmp, yint, zsave, K, cont, gcur, gnew, gtmp, gw, sgn, troot_a, troot,
              crossed)
    (y, ynew, ytmp, yint, zsave, K, cont, gcur, gnew, gtmp, gw, sgn, troot_a, troot,
     crossed) = borrowed(owners)
    p, z, atol, t_eval, Yb, Zb, evt, evk, evd = borrowed((p, z, atol, t_eval, Y, Zo, ev_t, ev_k,
                                                          ev_dir))

    t = t0
    i_out, t_end, h, hcap, nfev = start(rhs, events, t0, y, K[0], p, z, atol, rtol, h0, hmax,
                                        t_eval, Yb, Zb, ytmp, K[1], 8.0, gcur, sgn)
    n_steps = n_acc = n_rej = n_nonfinite = n_ev = 0
    status = RUNNING
    hnew, facold, reject, new_branch = pi_start(h)
    iasti = 0
    nonsti = 0
    after_event = False

    while True:
        status = running(status, t, t_end, n_steps, max_steps)
        if status != RUNNING:
            break
        if iasti >= N_STIFF:
            status = STIFF
            break
        t_new, h = next_step(t, h, hcap, t_eval[i_out] if land else t_end)
        n_steps += 1

        _stages(rhs, t, h, t_new, y, K, ytmp, ynew, p, z)
        nfev += 12
        err = _error_norm(h, y, ynew, K, atol, rtol, after_event)
        ok, status, h, hnew, facold, n_nonfinite, reject, new_branch, n_rej, n_acc = pi_control(
            err, EXPO1, BETA, FACC1, FACC2, h, t, hnew, facold, n_nonfinite, reject, new_branch,
            n_rej, n_acc)
        if not ok:
            continue
        after_event = False
        # Hairer's stiffness detection: |h| * |f(ynew) - f(y12)| / |ynew - y12| at t_new
        if _stiff_step(h, K, ynew, ytmp):
            nonsti = 0
            iasti += 1
        else:
            nonsti += 1
            if nonsti == 6:
                iasti = 0

        # ------------------------------------------------ event detection, dense output
        # The dense output is formed for a step the event screen flags (a side change at its end,
        # or on the Hermite screen of its interior) or with an output time inside it. (One block
        # for both, one `if` on the two conditions, made a step 5 % slower: kept apart.)
        have_event = False
        dense_done = False
        tol = ROOT_RTOL * max(1.0, abs(t_new))
        t_star = t_new
        a_star = t_new
        first = -1
        if ne > 0:
            events(t_new, ynew, p, z, gnew)
            if find_crossings(gnew, sgn, crossed) or (event_samples > 0 and _hermite_screen(
                    events, event_samples, t, h, y, ynew, K, yint, gtmp, sgn, p, z)):
                _dense(rhs, t, h, y, ynew, K, ytmp, cont, p, z)
                nfev += 3
                if not all_finite(cont):
                    n_acc, n_rej, reject, h = _untrusted(n_acc, n_rej, h)
                    continue
                dense_done = True
                have_event, a_star, t_star, first = locate_earliest(
                    events, interp_fn, event_samples, t, h, t_new, gcur, gnew, sgn, cont, yint, gtmp,
                    gw, p, z, tol, crossed, troot_a, troot)

        if not have_event:
            if i_out < n_eval and t_eval[i_out] <= t_new:
                if t_eval[i_out] < t_new and not dense_done:
                    _dense(rhs, t, h, y, ynew, K, ytmp, cont, p, z)
                    nfev += 3
                    if not all_finite(cont):
                        n_acc, n_rej, reject, h = _untrusted(n_acc, n_rej, h)
                        continue
                i_out = write_outputs(interp_fn, t, h, t_new, ynew, cont, t_eval, i_out, Yb, Zb, z)
            t = t_new
            y, ynew = ynew, y
            for i in range(n):          # FSAL
                K[0, i] = K[12, i]
            if ne > 0:
                gcur, gnew = gnew, gcur
                set_unknown_signs(gcur, sgn)
            h = hnew
            continue

        # ------------------------------------------------ event location
        # The earliest root t_star is located on the dense output of [t, t_c]; retake the step
        # from t to land on it, and check the retaken (accurate) step: the dense output of a
        # step that straddles a contact onset can be poor, so the root may be late (the retaken
        # step would cross the event unchecked) or early (the event has not happened yet).
        # Iterate on the retaken step until the root is at its end (at most MAX_RELOCATE).
        t_c = t_new             # end of the current step, state ynew
        h_c = h
        dense_h = h             # cont is the dense output of [t, t + dense_h]
        dense_ok = True         # ... and belongs to the current step
        fire = True
        for it in range(MAX_RELOCATE):
            retake, fire, a_star, t_star, first = relocate(
                it, events, interp_fn, event_samples, t, dense_h, t_c, a_star, t_star, first, gcur,
                gnew, sgn, cont, yint, gtmp, gw, p, z, tol, crossed, troot_a, troot)
            if not retake:
                break
            _stages(rhs, t, t_star - t, t_star, y, K, ytmp, ynew, p, z)
            nfev += 12
            t_c = t_star
            if not retake_finite(ynew, yint):
                break
            if not finite(K[12]):
                # the retaken step ends finite but its end derivative (the next K[0]) is not:
                # as for a non-finite end, the dense output at the root instead, and its
                # derivative (the event fires there: ``fire`` is True from relocate)
                copy_vector(yint, ynew)
                rhs(t_star, ynew, p, z, K[12])
                nfev += 1
                break
            h_c = t_star - t
            dense_ok = False
            fire = scan_due(events, event_samples, t_c, ynew, p, z, gnew, sgn, crossed)
            if not fire:
                break           # the event comes later: t_c is a plain step end
            _dense(rhs, t, h_c, y, ynew, K, ytmp, cont, p, z)
            nfev += 3
            dense_h = h_c
            dense_ok = True

        if t_star > t:
            if not dense_ok and i_out < n_eval and t_eval[i_out] < t_c:
                _dense(rhs, t, h_c, y, ynew, K, ytmp, cont, p, z)
                nfev += 3
                dense_h = h_c
            i_out = write_outputs(interp_fn, t, dense_h, t_c, ynew, cont, t_eval, i_out, Yb, Zb, z)
            t = t_c
            y, ynew = ynew, y

        if not fire:
            for i in range(n):          # FSAL: K[12] = f(t_c, ynew) of the retaken step
                K[0, i] = K[12, i]
            gcur, gnew = gnew, gcur
            set_unknown_signs(gcur, sgn)
            h = hnew
            continue

        status, n_ev, new_branch, nfev = fire_and_restart(
            rhs, events, on_event, crossed, troot, t_star, tol, sgn, t, y, p, z, zsave, evt, evk,
            evd, n_ev, max_log, K[0], gcur, nfev)
        after_event = True
        h = hnew

    keep_alive(owners)
    return solution(status, t, Y, i_out, stats, ev_t, ev_k, ev_dir, n_ev, Zo, n_steps, n_acc, n_rej,
                    nfev)


dop853 = front(dop853_core, interp)


@njit(cache=False)
def dop853_fixed(rhs, t0, y0, h, n_steps, p, z):
    """n_steps fixed DOP853 steps of size h (8th-order solution, no control, no events)."""
    y, ynew, ytmp, _ = work_vectors(y0)
    K = np.empty((16, y0.shape[0]))
    rhs(t0, y, p, z, K[0])
    for s in range(n_steps):
        t, t_new = fixed_times(t0, h, s)
        _stages(rhs, t, t_new - t, t_new, y, K, ytmp, ynew, p, z)
        y, ynew = ynew, y
        copy_vector(K[12], K[0])
    return y
