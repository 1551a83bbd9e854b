"""Event location shared by every integrator (dopri5, dop853, rodas and the tangent DOPRI5).

An event function g_k(t, y, z) is tracked on a side ``sgn[k]`` (+1 / -1; 0 while undetermined).
After every accepted step [t, t + h] the integrator calls :func:`locate_earliest` with the
step's dense output ``interp(theta, cont, out)`` (``cont[0]`` is the state at t for every
method here), g at both ends, and the number ``n_samples`` of interior samples:

1. **Scan.** Every event function is evaluated on the dense output at ``n_samples`` equally
   spaced interior points t + j h / (n_samples + 1), in order, and the scan stops at the first
   sample at which some g_k has left its tracked side (``g_k * sgn[k] <= 0``). With
   ``n_samples = 0`` only the step's end is looked at (the classic test: a sign change between
   the ends, so two roots in one step are not seen).
2. **Refine.** With ``n_samples > 0`` the sub-interval found is split again into ``REFINE``
   equal pieces (REFINE - 1 more evaluations, spent only on steps with an event), and the first
   piece at whose right end some g_k has left its side is kept. A function whose sign is the
   same at both ends of the sub-interval but changes at a refinement point is caught here.
3. **Root.** Every function that has left its side at the right end of that piece is located
   in the piece by Illinois (modified regula falsi) to ``tol``; the earliest root wins.

The integrator then cuts the step at the earliest root (retaking it from t so that the state
there is a true solution of the method), fires every event whose root is within ``tol`` of it
(``on_event`` may change z and so the vector field), and restarts from there: any later root of
the former step is found by the next step. What can still be missed: two sign changes of one
function closer together than the spacing of the samples (h / (n_samples + 1), or that over
REFINE inside a piece that is refined) that fall between two samples; no finite sampling can
exclude that (docs/integrator.md, "Events").

Compilation: ``events`` and ``interp`` arrive as first-class functions (nld.integrators.core) and
the location functions are inlined into each integrator (numba ``inline='always'``): compiled out
of line they saved about 4 s of each integrator's one-time compilation but made every step slower
(the reference counting of their array arguments; docs/performance.md, "Compile time").

``n_samples = 0`` reproduces the ends-only location of nld before issue 13 item 5 bit for bit.
DOP853, whose dense output costs three rhs evaluations, calls this only for steps that a scan of
the same samples on the cubic Hermite interpolant of the step's ends has flagged
(``nld.integrators.dop853._hermite_screen``).
"""
import numpy as np
from numba import njit

from nld.settings import SIMULATE

EPS = 2.220446049250313e-16
ROOT_RTOL = 1.0e-12
ROOT_MAXITER = 200

EVENT_SAMPLES = SIMULATE.event_samples  # default interior samples per step (nld.settings)
MAX_EVENT_SAMPLES = 64  # input validation bound (a cost of 64 event evaluations per step)
REFINE = 8             # pieces the first sub-interval with a sign change is split into


@njit(cache=True)
def set_unknown_signs(g, sgn):
    """Give every event whose tracked sign is still undetermined (0) the sign of g_k."""
    for k in range(g.shape[0]):
        if sgn[k] == 0:
            if g[k] > 0.0:
                sgn[k] = 1
            elif g[k] < 0.0:
                sgn[k] = -1


@njit(cache=True)
def find_crossings(gnew, sgn, crossed):
    """crossed[k] = g_k left the side it is tracked on; returns whether any did."""
    any_crossed = False
    for k in range(gnew.shape[0]):
        crossed[k] = sgn[k] != 0 and gnew[k] * sgn[k] <= 0.0
        if crossed[k]:
            any_crossed = True
    return any_crossed


@njit(cache=False, inline='always')
def bracket_root(events, interp, k, s, t, h, ta, tb, ga, gb, cont, yint, gtmp, p, z, tol):
    """Illinois (modified regula falsi) for g_k on the dense output ``interp(theta, cont, out)``
    of the step [t, t + h], within [ta, tb] where g_k leaves side s (ga = g_k(ta) on side s,
    gb = g_k(tb) on the other side or 0). Returns (a, b): a on side s, b on the new side (or at
    the root), b - a <= tol (or a few ulps of b).

    If ga is not strictly on side s (just after an event at ta, g_k is zero up to round-off and
    may lie on either side), the left end is moved to the first of ta + tol*4^j (j = 0, 1, ...)
    where g_k is on side s; if there is none, the crossing is "now" and (ta, ta) is returned."""
    if gb == 0.0:
        return tb, tb
    a = ta
    fa = ga
    if ga * s <= 0.0:
        d = tol
        while True:
            a = ta + d
            if a >= tb:
                return ta, ta
            interp((a - t) / h, cont, yint)
            events(a, yint, p, z, gtmp)
            fa = gtmp[k]
            if fa * s > 0.0:
                break
            d *= 4.0
    b = tb
    fb = gb
    side = 0
    for _ in range(ROOT_MAXITER):
        if b - a <= tol or b - a <= 4.0 * EPS * abs(b):
            break
        c = b - fb * (b - a) / (fb - fa)
        if not (c > a and c < b):
            c = 0.5 * (a + b)
        interp((c - t) / h, cont, yint)
        events(c, yint, p, z, gtmp)
        fc = gtmp[k]
        if fc == 0.0:           # on the root: both ends there (a stays on the old side's
            return c, c         # closure; the tangent integrator evaluates f- at a_star)
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
    return a, b


@njit(cache=False, inline='always')
def first_crossing_piece(events, interp, t, h, tl, tr, n_pieces, sgn, gl, gr, ga, gb, cont, yint,
                         p, z):
    """Split [tl, tr] (inside the step [t, t + h] with dense output ``cont``) into ``n_pieces``
    equal pieces and return (found, ta, tb): the first piece at whose right end some g_k with a
    tracked sign has left its side. gl, gr: every g at tl and tr; on return ga, gb hold every g
    at ta and tb (gb = gr when the piece is the last). ga/gb must not alias gl/gr."""
    ne = gl.shape[0]
    for q in range(ne):
        ga[q] = gl[q]
    ta = tl
    for j in range(1, n_pieces + 1):
        if j < n_pieces:
            tb = tl + (j / n_pieces) * (tr - tl)
            interp((tb - t) / h, cont, yint)
            events(tb, yint, p, z, gb)
        else:
            tb = tr
            for q in range(ne):
                gb[q] = gr[q]
        for q in range(ne):
            if sgn[q] != 0 and gb[q] * sgn[q] <= 0.0:
                return True, ta, tb
        for q in range(ne):
            ga[q] = gb[q]
        ta = tb
    return False, tr, tr


@njit(cache=False, inline='always')
def locate_earliest(events, interp, n_samples, t, h, t_new, gcur, gnew, sgn, cont, yint, gtmp, gw,
                    p, z, tol, crossed, troot_a, troot_b):
    """The earliest root in (t, t_new] of any event function that leaves its tracked side, on the
    dense output ``interp(theta, cont, out)`` of the step (module docstring: scan n_samples
    interior points, refine the first sub-interval with a change into REFINE pieces, Illinois).

    h: the length of the dense output's step (theta = (x - t) / h; t_new <= t + h up to
    round-off). gcur, gnew: every g at t and t_new. gw: work array (4, n_events). Returns
    (found, a_star, t_star, first): t_star the bracket end on the new side of the earliest root
    (at most tol after it), a_star the end on the old side, first its event index. For every
    event with crossed[k] (those that left their side in the same piece), troot_a[k], troot_b[k]
    are its own bracket; fire those with troot_b[k] <= t_star + tol."""
    ne = gcur.shape[0]
    ga = gw[0]
    gb = gw[1]
    found, ta, tb = first_crossing_piece(events, interp, t, h, t, t_new, n_samples + 1, sgn, gcur,
                                         gnew, ga, gb, cont, yint, p, z)
    if not found:
        for q in range(ne):
            crossed[q] = False
        return False, t_new, t_new, -1
    if n_samples > 0 and tb - ta > tol:
        ga2 = gw[2]
        gb2 = gw[3]
        found2, ta2, tb2 = first_crossing_piece(events, interp, t, h, ta, tb, REFINE, sgn, ga, gb,
                                                ga2, gb2, cont, yint, p, z)
        if found2:       # always, as gb has a change; kept for safety
            ta = ta2
            tb = tb2
            for q in range(ne):
                ga[q] = ga2[q]
                gb[q] = gb2[q]
    first = -1
    a_star = ta
    t_star = tb
    for q in range(ne):
        crossed[q] = sgn[q] != 0 and gb[q] * sgn[q] <= 0.0
        if crossed[q]:
            ra, rb = bracket_root(events, interp, q, sgn[q], t, h, ta, tb, ga[q], gb[q], cont,
                                  yint, gtmp, p, z, tol)
            troot_a[q] = ra
            troot_b[q] = rb
            if first < 0 or rb < t_star:
                t_star = rb
                a_star = ra
                first = q
    return True, a_star, t_star, first


@njit(cache=True, inline='always')
def log_event(ev_t, ev_k, ev_dir, n_ev, max_log, t, k, direction):
    """Entry n_ev of the event log (time, event index, direction), written while the log has room
    (max_log entries); returns n_ev + 1 (events are counted beyond the log)."""
    if n_ev < max_log:
        ev_t[n_ev] = t
        ev_k[n_ev] = k
        ev_dir[n_ev] = direction
    return n_ev + 1


@njit(cache=False, inline='always')
def fire_events(on_event, crossed, troot, t_star, tol, sgn, t, y, p, z, ev_t, ev_k, ev_dir,
                n_ev, max_log):
    """Call on_event for every crossing whose root is within tol of t_star, log it and flip its
    tracked sign. Returns (stop, n_ev)."""
    stop = False
    for k in range(crossed.shape[0]):
        if crossed[k] and troot[k] <= t_star + tol:
            direction = -sgn[k]
            n_ev = log_event(ev_t, ev_k, ev_dir, n_ev, max_log, t, k, direction)
            sgn[k] = direction
            if on_event(k, direction, t, y, p, z) == 1:
                stop = True
    return stop, n_ev


def check_event_samples(value, field: str = "event_samples") -> int:
    """``value`` as an int in [0, MAX_EVENT_SAMPLES], or InputError naming the field (one line)."""
    from nld.errors import InputError
    ok = isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))
    if not ok or not 0 <= int(value) <= MAX_EVENT_SAMPLES:
        raise InputError(f"{field} = {value!r}: expected an integer from 0 (the step's ends only) "
                         f"to {MAX_EVENT_SAMPLES} (interior samples of every step's dense output "
                         f"scanned for event sign changes; default {EVENT_SAMPLES})")
    return int(value)
