"""Curves of grazing points of periodic orbits in two parameters.

A periodic orbit **grazes** where one of its contacts has zero normal approach speed at its onset
(the trajectory touches the contact surface tangentially: gap = 0 and d(gap)/dt = 0; di Bernardo,
Budd, Champneys & Kowalczyk 2008, ch. 8; Nordmark 1991; COCO's ``impact`` example continues such
points with the grazing time as an unknown). One-parameter continuation
(:func:`nld.analysis.continuation.continue_orbit`) locates a grazing by bisection on the orbit's
contact count, to ``locate_tol`` of the parameter, and names it grazing only where the approach
speed on the contact side goes to zero (a count change at a finite speed is a jump).

:func:`continue_grazing` follows such a point in a second parameter by **re-locating it at each
value of the second parameter** (natural continuation in param2 with a secant predictor in
param1): at each param2 value, the orbit is solved at the predicted param1 value minus a bracket
half-width (Newton from the last curve point's orbit), continued over [pred - w, pred + w]
by ``continue_orbit`` (natural) and the grazing located there by the same bisection; the bracket
is widened x4 (up to 3 times) where no grazing lies in it, and the param2 step halved (down to
1/64 of the first) where none is found at all. **Choice** (docs/codim2.md): the shooting of nld
does not expose the grazing time as an unknown, so the extended system of COCO (orbit, grazing
time, both parameters; gap = 0 and approach speed = 0 there) is not built; re-locating costs a
bisection (about 20 orbit solves) per point but uses the one-parameter test that is already
checked. It cannot pass a turning point of the grazing curve in param2 (the curve ends there with
reason "not_found").

Units: the parameters' SI units; the condition column is the smallest approach speed at a contact
onset on the contact side of the located bracket (m/s on a scene), 0 on an exact grazing; NaN
where that side's contact is too shallow for the event detection to count (the bisection put it
on the contact side from its trajectory: continuation's _enters_contact). A grazing curve has no
special points of its own here but its ends (``leaves_domain``): its turning points are not seen
by natural continuation in param2.
"""
from __future__ import annotations

import math
import time

from nld.errors import InputError, SceneError, SolveError
from nld.analysis.continuation import ARCLENGTH_PARAM_UNIT, Bifurcation, Family, continue_orbit
from nld.analysis.orbits import periodic_orbit
from nld.analysis.bifurcation_curve import BifurcationCurve, CurveEnd, curve_inputs, domain_exits

__all__ = ["continue_grazing", "WIDEN", "MIN_STEP_FRACTION"]

WIDEN = 3                 # bracket widenings (x4 each) before the param2 step is halved
MIN_STEP_FRACTION = 1 / 64  # the shortest param2 step, of the first


def _locate(fam2, param, value2, guess_orbit, pred, w, locate_tol, tol):
    """The grazing nearest ``pred`` in [pred - w, pred + w] at param2 = value2, or None."""
    sys2 = fam2.at(value2)
    fam1 = Family(sys2, param)
    lo, hi = pred - w, pred + w
    for v in (lo, hi):
        fam1.check(v, f"{fam1.label}:")
    s_lo = fam1.at(lo)
    o = periodic_orbit(s_lo, guess_orbit.period, guess_orbit.points[0], z=guess_orbit.z[0],
                       rtol=guess_orbit.settings.get("rtol"), tol=tol)
    if not o.converged:
        return None
    # two values only: a branch point at the prediction (often within a hair of the grazing)
    # would be the contact side whose approach speed the grazing test compares with
    br = continue_orbit(s_lo, o, param, [lo, hi], locate=True, locate_tol=locate_tol,
                        criticality=False)
    gz = [b for b in br.bifurcations if b.kind == "grazing" and b.orbit is not None]
    if not gz:
        return None
    return min(gz, key=lambda b: abs(b.value - pred))


def continue_grazing(system, bif: Bifurcation, param2, range2, *, param, stops=(),
                     step: float | None = None, max_points: int = 100, tol: float | None = None,
                     locate_tol: float | None = None, progress=None):
    """Follow a located grazing ``bif`` (from ``continue_orbit(system, orbit, param,
    ...).bifurcations``) in ``param2`` over ``range2`` (module docstring).

    step: the first param2 step in units of (range2 width)/50 (default 1); it grows x1.5 after
    a point found in the first bracket, up to 4 units. locate_tol: the bisection's tolerance in
    param1 (default min(bif.tolerance, 1e-6 |bif.value|)). stops: param2 values landed on
    exactly (every point of a grazing curve is at an exact param2 value). Returns a
    :class:`nld.analysis.codim2.BifurcationCurve` of kind "grazing": tolerance1 the located
    bracket's width, condition and distance the contact side's approach speed. Bad input raises
    InputError before any integration."""
    if not isinstance(bif, Bifurcation) or bif.kind != "grazing":
        raise InputError("bif: give a grazing Bifurcation from continue_orbit(...).bifurcations")
    fam1, fam2, a, b, lo2, hi2, stops, h0 = curve_inputs(system, bif, param, param2, range2,
                                                         stops, max_points, step)
    o0 = bif.orbit
    v20 = fam2.value0
    unit2 = abs(b - a) * ARCLENGTH_PARAM_UNIT
    ltol = float(locate_tol) if locate_tol is not None else \
        min(max(bif.tolerance, 0.0) or math.inf, 1e-6 * max(abs(bif.value), 1e-300))
    if not (ltol > 0 and math.isfinite(ltol)):
        raise InputError(f"locate_tol = {locate_tol!r}: must be a positive number")
    t_start = time.perf_counter()
    eps = 1e-12 * max(abs(lo2), abs(hi2), unit2)
    targets = sorted(set([lo2, hi2] + stops))
    start = (bif.value, v20, bif, v20 in targets)
    segments, ends = {}, []
    solves = [0]
    for direction in (-1, 1):
        pts = []
        segments[direction] = pts
        end2 = lo2 if direction < 0 else hi2
        if abs(end2 - v20) <= eps:
            ends.append(CurveEnd(direction, bif.value, v20, "range_end",
                                 "the start value is the range's end"))
            continue
        hist = [(v20, bif.value)]
        last = bif
        h = h0 * unit2
        end = None
        while end is None:
            if len(pts) + 1 >= max_points:
                end = CurveEnd(direction, hist[-1][1], hist[-1][0], "step_limit",
                               f"{max_points} points used in this direction")
                break
            v2p = hist[-1][0]
            nxt = v2p + direction * h
            cross = [x for x in targets if (x - v2p) * (nxt - x) >= 0 and abs(x - v2p) > eps]
            if cross:
                nxt = min(cross, key=lambda y: abs(y - v2p))
            if len(hist) >= 2:
                (x1, y1), (x2, y2) = hist[-2], hist[-1]
                pred = y2 + (y2 - y1) * (nxt - x2) / (x2 - x1)
                move = abs(pred - y2)
            else:
                # no slope yet: a bracket of the parameter's arclength unit (0.02 of it)
                pred, move = hist[-1][1], 0.5 * ARCLENGTH_PARAM_UNIT * abs(hist[-1][1])
            w = max(2.0 * move, 100.0 * ltol, 1e-4 * abs(pred))
            found = None
            why = ""
            try:
                for k in range(WIDEN + 1):
                    solves[0] += 1
                    found = _locate(fam2, param, nxt, last.orbit, pred, w * 4 ** k, ltol, tol)
                    if found is not None:
                        break
            except (InputError, SceneError) as e:
                end = CurveEnd(direction, hist[-1][1], hist[-1][0], "domain", str(e))
                break
            except SolveError as e:
                why = str(e)
            if found is None:
                if h > MIN_STEP_FRACTION * h0 * unit2 * 1.0001:
                    h *= 0.5
                    continue
                end = CurveEnd(direction, hist[-1][1], hist[-1][0], "not_found",
                               f"no grazing within {w * 4 ** WIDEN:.3g} of the predicted "
                               f"{fam1.label} = {pred:g} at {fam2.label} = {nxt:g}, down to a "
                               f"step of {h:.3g} (the curve may turn back in {fam2.label}, or "
                               f"the contact change became a jump){'; ' + why if why else ''}")
                break
            landed = any(abs(nxt - x) <= eps for x in targets)
            pts.append((found.value, nxt, found, landed))
            hist.append((nxt, found.value))
            last = found
            if progress is not None:
                progress(len(pts), max_points, found.value, nxt)
            if abs(nxt - end2) <= eps:
                end = CurveEnd(direction, found.value, nxt, "range_end", "the range's end")
            elif k == 0:
                h = min(1.5 * h, 4.0 * h0 * unit2)
        ends.append(end)
    recs = list(reversed(segments.get(-1, []))) + [start] + segments.get(1, [])

    def speed(bf):
        s = bf.orbit.min_approach_speed
        return float(s) if math.isfinite(s) else math.nan

    curve = BifurcationCurve("grazing", param, param2, o0.period,
                             [r[0] for r in recs], [r[1] for r in recs],
                             [r[2].orbit for r in recs], [speed(r[2]) for r in recs],
                             [speed(r[2]) for r in recs], [float(r[2].tolerance) for r in recs],
                             [bool(r[3]) for r in recs], [], ends, "", {})
    curve.special_points = domain_exits(curve, fam2.label)
    curve.message = ("completed" if curve.completed else
                     "; ".join(f"direction {e.direction:+d} ended at ({e.value1:g}, {e.value2:g}): "
                               f"{e.reason}: {e.detail}" for e in ends))
    curve.settings = {"kind": "grazing", "param": param, "param2": param2, "range2": [a, b],
                      "stops": stops, "start": [bif.value, v20], "step": h0,
                      "locate_tol": ltol, "tol": tol, "rtol": o0.settings.get("rtol"),
                      "map": o0.settings.get("map"),
                      "method": "re-located at each param2 value (natural continuation in "
                                "param2, secant predictor, bisection on the contact count)",
                      "brackets": solves[0], "wall_s": time.perf_counter() - t_start}
    return curve
