"""The route to chaos of a study's sweep: how its periodic motion is lost, told as data.

A study sweeps one parameter (a friction coefficient, a clearance, the crank speed) and finds the
motion periodic at some values and chaotic at others (brute force: a stroboscopic section and the
largest Lyapunov exponent at each value, ``nld.analysis.bifurcation``). This module says *how* one
turns into the other:

* :func:`route_to_chaos` finds the period-1 orbit at a start value by Newton shooting
  (``nld.analysis.orbits``) and follows it over the sweep's range (``nld.analysis.continuation``:
  pseudo-arclength both ways where available, else natural continuation; for parameters that move
  together, e.g. both clearances of the excavator, :func:`linked_branch` steps the family itself),
  with its Floquet multipliers, the located bifurcations and the way each end of the branch ends;
  the orbit is polished by Newton at every sweep value the branch spans, so that it can be compared
  with the brute-force section there;
* with ``cascade`` set, :func:`follow_doublings` switches at every supercritical period doubling
  to the doubled branch (from the flip eigenvector) and follows it within the range, and on to
  period 4 ... (a cost cap in points, every end with its reason), with the interval ratios of the
  doublings (Feigenbaum's delta the smooth reference) or why there are too few (docs/route.md);
* :func:`agreement` checks every branch point called stable against the brute-force section at
  that value (the section points must lie on the orbit within the integration error), or says why
  not (coexistence: the assembly's motion went to another attractor; continuum: the orbit is one
  of a continuum of permanent-contact orbits selected by the history, docs/orbits.md);
* :func:`route_table` merges both into ordered rows: each a regime (period p stable, unstable,
  neutral continuum, chaotic, coexisting ...) over a parameter interval and the transition that ends
  it (period doubling, fold, Neimark-Sacker, grazing, contact change, onset of chaos where λ1 turns
  positive, end of the branch), the located value ± its uncertainty, the evidence (multipliers,
  onset counts, λ1 on each side) and whether the brute-force diagram agrees; :func:`route_sentence`
  says the sequence in one sentence;
* :func:`route_figure` draws the branches (stable solid, unstable dashed, neutral dotted) over the
  brute-force diagram with λ1 beneath on the same parameter axis, the transitions marked.

Stability words follow docs/orbits.md: an orbit is "stable" when its largest multiplier (the
contact memory's neutral multiplier of a permanent-contact orbit left out) is below 1 by more than
its uncertainty, "unstable" when above by more, else "neutral"; a permanent-contact orbit is one of
a continuum (regime "neutral continuum", whatever its other multipliers say). References: Kuznetsov
(2004) ch. 4 and 10; di Bernardo et al. (2008) ch. 8 (grazing, contact changes); Seydel (2010).
Units: the parameter's SI unit; λ1 per crank revolution.
"""
from __future__ import annotations

import math
import time

import numpy as np
import pandas as pd

from nld.analysis.continuation import orbit_stability

__all__ = ["route_to_chaos", "linked_branch", "orbit_stability", "branch_ends", "agreement",
           "sweep_regimes", "route_table", "route_sentence", "route_figure", "orbit_rows",
           "follow_doublings", "add_doublings", "check_cascade", "delta_sentence",
           "route_record", "route_tables", "orbits_at", "orbit_exponent", "ROUTE_COLUMNS",
           "TRANSITIONS", "REGIMES"]

REGIMES = ("period {p} stable", "period {p} unstable", "period {p} neutral continuum",
           "period {p}", "chaotic", "coexisting", "regular", "not established")
TRANSITIONS = ("period_doubling", "fold", "neimark_sacker", "grazing", "contact_change",
               "onset_of_chaos", "end_of_chaos", "regime_change", "branch_end", "range_end")
ROUTE_COLUMNS = ["sweep", "param", "order", "source", "regime", "period", "from", "to",
                 "transition", "at", "at_unc", "evidence", "lambda_before", "lambda_after",
                 "agrees"]
_SHORT = {"period_doubling": "PD", "fold": "fold", "neimark_sacker": "NS", "grazing": "grazing",
          "contact_change": "contact change", "onset_of_chaos": "chaos", "end_of_chaos": "order",
          "regime_change": "change", "branch_end": "end", "range_end": "range end"}


# ---------------------------------------------------------------------------------------------------
# the orbit's stability words (one rule: nld.analysis.orbits.multiplier_stability)


def _critical_multipliers(o) -> np.ndarray:
    """The multipliers that decide stability (the memory's neutral ones left out)."""
    return np.asarray(o.deciding_multipliers)


def multiplier_uncertainty(o) -> float:
    """The orbit's uncertainty of max |mu| (``PeriodicOrbit.multiplier_uncertainty``)."""
    u = float(o.multiplier_uncertainty)
    return u if math.isfinite(u) else 0.0


def memory_neutral(o) -> bool:
    """The orbit has the contact memory's neutral multiplier (one of a continuum)."""
    return bool(o.memory_neutral)


def orbit_class(o) -> str:
    """The regime word of one orbit: "stable", "unstable" or "neutral continuum" (a continuum
    member that is not unstable, or a neutral orbit)."""
    s = orbit_stability(o)
    if s == "unstable":
        return "unstable"
    if memory_neutral(o) or s == "neutral":
        return "neutral continuum" if memory_neutral(o) else "neutral"
    return "stable"


def branch_ends(br) -> list[dict]:
    """How each end of a branch ends: dicts ``direction`` (-1 low, +1 high), ``value``,
    ``reason`` and ``detail`` (``Branch.ends``; a branch joined by :func:`linked_branch` keeps
    them in its settings; else from the branch's message and its extreme values)."""
    ends = br.ends
    if not ends and (br.settings or {}).get("ends"):
        return [dict(e) for e in br.settings["ends"]]
    if ends:
        return [{"direction": int(e.direction), "value": float(e.value), "reason": str(e.reason),
                 "detail": str(e.detail)} for e in ends]
    if not br.values:
        return []
    v = np.asarray(br.values, dtype=float)
    rng = (br.settings or {}).get("range") or (br.settings or {}).get("values") or [v.min(), v.max()]
    lo_r, hi_r = float(np.min(rng)), float(np.max(rng))
    out = []
    msg = br.message or ""
    for d, val, lim in ((-1, float(v.min()), lo_r), (+1, float(v.max()), hi_r)):
        eps = 1e-9 * max(abs(lim), 1e-30) + 1e-15
        if abs(val - lim) <= eps:
            out.append({"direction": d, "value": val, "reason": "range_end", "detail": ""})
        else:
            out.append({"direction": d, "value": val, "reason": "newton_failure",
                        "detail": msg})
    return out


def _continue(system, orbit, param, values, *, method, max_points, locate_tol,
              criticality: bool = True):
    """continue_orbit over the whole range of ``values`` (pseudo-arclength both ways), falling back
    to natural continuation over ``values`` when arclength is not wanted or fails at once;
    ``criticality``: decide super-/subcritical at each located bifurcation (a search for the
    bifurcating orbit on both sides: the costliest part of a short branch)."""
    from nld.analysis.continuation import continue_orbit
    from nld.errors import SolveError
    lo, hi = float(min(values)), float(max(values))
    if method == "arclength":
        try:
            br = continue_orbit(system, orbit, param, range=(lo, hi), method="arclength",
                                max_points=max_points, locate_tol=locate_tol,
                                criticality=criticality)
            if len(br.values) >= 2:
                return br
        except SolveError:
            pass
    return continue_orbit(system, orbit, param, values, method="natural", locate_tol=locate_tol,
                          criticality=criticality)


# ---------------------------------------------------------------------------------------------------
# a family of several keys set together (e.g. both clearances): natural steps with bisection


def _keys(param) -> list[str]:
    return [k.strip() for k in param.split(",")] if isinstance(param, str) else list(param)


def _linked_system(scene, overrides, keys, value):
    from nld.systems.core import SceneSystem
    return SceneSystem(scene, list(overrides) + [f"{k}={value!r}" for k in keys])


def _classify_step(oa, ob) -> tuple[str | None, str]:
    """The bifurcation kind between two orbits of a branch, from their contact onsets (per joint)
    and multipliers: "contact_change" when the onsets differ, or when the stability changes by a
    jump of the multipliers (the stable side's largest below 0.5 or the unstable side's above 2:
    no multiplier crossed the unit circle continuously, a non-smooth change); else
    "period_doubling" (a real multiplier through -1), "fold" (through +1) or "neimark_sacker"."""
    if not np.array_equal(np.asarray(oa.onsets), np.asarray(ob.onsets)):
        return "contact_change", (f"contact onsets per period {np.asarray(oa.onsets).tolist()} -> "
                                  f"{np.asarray(ob.onsets).tolist()}")
    sa, sb = orbit_stability(oa), orbit_stability(ob)
    if sa == sb:
        return None, ""
    ma = _critical_multipliers(oa)
    mb = _critical_multipliers(ob)
    if not ma.size or not mb.size:
        return None, ""
    lo, hi = (ma, mb) if sa == "stable" else (mb, ma)
    m = hi[int(np.argmax(np.abs(hi)))]
    if np.max(np.abs(lo)) < 0.5 or abs(m) > 2.0:
        return "contact_change", (f"max |mu| jumps {np.max(np.abs(lo)):.3g} -> {abs(m):.3g} with "
                                  f"the same onsets: a non-smooth change, no multiplier crossing")
    if abs(m.imag) > 1e-9 * max(1.0, abs(m)):
        return "neimark_sacker", f"complex pair |mu| = {abs(m):.4g}"
    return ("period_doubling" if m.real < 0 else "fold"), f"real multiplier {m.real:.4g}"


def linked_branch(scene, overrides, param, values, orbit, *, start: float, rtol, bisect: int = 3,
                  transient: int = 10, guess: str = "previous", max_iter: int | None = None,
                  progress=None):
    """Follow ``orbit`` (the period-1 orbit at ``start``) over ``values``, outwards from ``start``
    both ways, with every key of ``param`` (comma-separated scene keys, e.g. "joints.A.clearance,
    joints.B.clearance") set to the value: natural continuation (Newton from the previous orbit).

    Where Newton from the previous orbit fails, the orbit is sought again from the state after
    ``transient`` revolutions of a run at that value: a converged orbit there is the branch
    continued through a non-smooth point (a contact gained or lost: the onset count changes) or a
    jump to another orbit, and the branch goes on from it; none: the branch ends there (its end's
    reason "newton_failure"). ``guess`` "run": the run's state first at every value, the previous
    orbit where that fails (for a non-smooth map whose Newton basins are narrower than the steps: an
    orbit per value, joined where the onset counts and stability agree). Between two points whose stability or onset count differ, ``bisect``
    bisections in the value (Newton from the orbit on the start's side) locate the change: value ±
    half the final bracket. ``max_iter``: Newton's iteration limit per solve (None: the
    orbits module's default; a solve from a good guess converges in 1-3 steps, and one that has not
    converged in a few is stalling: on the excavator each step is a tangent revolution, and the
    failed solves across a contact change were most of the route's cost, docs/route.md). Returns a
    ``nld.analysis.continuation.Branch`` (values increasing;
    ``settings["ends"]``: how each end ends, as :func:`branch_ends` gives them)."""
    from nld.analysis.continuation import Bifurcation, Branch
    from nld.analysis.orbits import periodic_orbit
    from nld.errors import SolveError
    keys = _keys(param)
    settings = {"param": param, "method": ("natural (keys set together), restarted from a run "
                "where Newton fails" if guess != "run" else "an orbit per value from a run "
                "(keys set together), joined where onsets and stability agree"),
                "period": orbit.period, "rtol": rtol, "guess": guess,
                "values": [float(v) for v in values], "bisect": bisect, "transient": transient,
                "max_iter": max_iter, "ends": []}
    it = {} if max_iter is None else {"max_iter": int(max_iter)}

    def solve(v, like=None):
        S = _linked_system(scene, overrides, keys, v)
        try:
            if like is None:
                o = periodic_orbit(S, orbit.period, transient=transient, rtol=rtol, **it)
            else:
                o = periodic_orbit(S, like.period, guess=like.points[0], z=like.z[0], rtol=rtol,
                                   **it)
        except SolveError as e:
            return None, str(e)
        return (o, "") if o.converged else (None, o.message)

    bifs = []

    def walk(seq, direction):
        vals, orbs = [float(start)], [orbit]
        end = {"direction": direction, "value": float(start), "reason": "range_end", "detail": ""}
        for v in seq:
            v = float(v)
            a, oa = vals[-1], orbs[-1]
            first, second = (None, oa) if guess == "run" else (oa, None)
            o, why = solve(v, first)
            restarted = False
            if o is None:
                o, why2 = solve(v, second)
                restarted = o is not None and guess != "run"
                if o is None:
                    end = {"direction": direction, "value": a, "reason": "newton_failure",
                           "detail": f"no period-{orbit.period} orbit at {v:.6g} (Newton from "
                                     f"the orbit at {a:.6g} and from a run of {transient} "
                                     f"revolutions: {why if guess != 'run' else why2}; "
                                     f"{why2 if guess != 'run' else why})"}
                    return vals, orbs, end
            if progress is not None:
                progress(v, o)
            kind, det = _classify_step(oa, o)
            if kind or restarted:
                lo, olo, hi, ohi = a, oa, v, o
                for _ in range(bisect):
                    mid = 0.5 * (lo + hi)
                    om, _w = solve(mid, olo)
                    if om is not None and _classify_step(olo, om)[0] is None:
                        lo, olo = mid, om
                    else:
                        hi = mid
                        if om is not None:
                            ohi = om
                kind, det = _classify_step(olo, ohi)
                kind = kind or "contact_change"
                crit = _critical_multipliers(ohi)
                m = crit[int(np.argmax(np.abs(crit)))] if crit.size else None
                det = (f"{det}; onsets {olo.onsets.tolist()} -> {ohi.onsets.tolist()}, max |mu| "
                       f"{olo.max_abs_multiplier:.3g} -> {ohi.max_abs_multiplier:.3g}, smallest "
                       f"approach speed {oa.min_approach_speed:.3g} -> "
                       f"{olo.min_approach_speed:.3g} m/s"
                       + ("; Newton from the orbit before it fails beyond it: the orbit found again "
                          "from a run" if restarted else ""))
                bifs.append(Bifurcation(kind, 0.5 * (lo + hi), 0.5 * abs(hi - lo), m, olo,
                                        f"{kind} at {0.5 * (lo + hi):.6g} ± "
                                        f"{0.5 * abs(hi - lo):.2g}: {det}", (min(lo, hi),
                                                                            max(lo, hi))))
            vals.append(v)
            orbs.append(o)
        end["value"] = vals[-1]
        return vals, orbs, end

    up = sorted(float(v) for v in values if v > start)
    down = sorted((float(v) for v in values if v < start), reverse=True)
    vu, ou, eu = walk(up, +1)
    vd, od, ed = walk(down, -1)
    vals = vd[::-1] + vu[1:]
    orbs = od[::-1] + ou[1:]
    settings["ends"] = [ed, eu]
    msg = "; ".join(f"{'low' if e['direction'] < 0 else 'high'} end: {e['reason']}"
                    + (f" ({e['detail']})" if e["detail"] else "") for e in (ed, eu))
    return Branch(param, orbit.period, vals, orbs, sorted(bifs, key=lambda b: b.value), msg,
                  settings)


# ---------------------------------------------------------------------------------------------------
# the doubled branches: switching at a supercritical period doubling, with a cost cap


CASCADE_KEYS = ("max_period", "step", "max_points")


def check_cascade(cascade) -> dict | None:
    """The route's ``cascade`` setting as a dict (None: off): ``max_period`` (an integer >= 2:
    the largest period followed), ``step`` (> 0: the natural step along a doubled branch, the
    parameter's SI unit), ``max_points`` (an integer >= 2: the cost cap, the points of all the
    doubled branches together). InputError naming the key otherwise, before any work."""
    from nld.errors import InputError
    if cascade is None or cascade is False:
        return None
    if not isinstance(cascade, dict):
        raise InputError(f"cascade = {cascade!r}: give a dict with keys {', '.join(CASCADE_KEYS)}")
    bad = sorted(set(cascade) - set(CASCADE_KEYS))
    if bad:
        raise InputError(f"cascade: unknown key {bad[0]!r} (allowed: {', '.join(CASCADE_KEYS)})")
    c = {"max_period": cascade.get("max_period", 4), "step": cascade.get("step"),
         "max_points": cascade.get("max_points", 20)}
    for k in ("max_period", "max_points"):
        v = c[k]
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 2:
            raise InputError(f"cascade.{k} = {v!r}: must be an integer >= 2")
    st = c["step"]
    if isinstance(st, bool) or not isinstance(st, (int, float)) or not (math.isfinite(st)
                                                                      and st > 0):
        raise InputError(f"cascade.step = {st!r}: must be a positive number (the parameter's unit)")
    c["max_period"], c["max_points"], c["step"] = int(c["max_period"]), int(c["max_points"]), \
        float(st)
    return c


def follow_doublings(system, branch, param, lo: float, hi: float, *, step: float,
                     max_period: int = 4, max_points: int = 20, values=(),
                     locate_tol: float | None = None, criticality: bool = True):
    """The doubled branches of ``branch`` (a continued branch of ``system`` in ``param``) inside
    [lo, hi]: at each located period doubling called supercritical (its period-2p orbit found
    on the side where the p-orbit is unstable: ``Bifurcation.new_orbit``, from the flip
    eigenvector, nld.analysis.continuation.bifurcation_criticality), the doubled orbit is
    followed away from the doubling by natural continuation (``continue_orbit``, Newton from the
    previous orbit with a secant predictor) in steps of ``step`` to the range's end in that
    direction, with the sweep's ``values`` inside that stretch added (so that the branch has an
    orbit at each of them); the doublings located on a doubled branch are followed the same way
    while the period is <= ``max_period`` (Seydel 2010, sec. 7.4; Kuznetsov 2004, sec. 10.3).
    The cost cap: ``max_points`` points for all the doubled branches together; a branch cut by it
    ends with the reason "step_limit". Every end carries its reason (``BranchEnd``:
    range_end, fold with its jump target, grazing / contact_change, newton_failure with the
    residual, step_limit). Returns a ``nld.analysis.continuation.Cascade``: ``branches`` (the
    given branch first), ``doublings`` (every supercritical or other period doubling met, in the
    order met along the chain), ``ratios`` (successive interval ratios along the chain: three
    doublings at least), ``message``, ``settings`` (``parent``: per branch the index of its
    parent and of the doubling it was born at; ``points``: points used)."""
    from nld.analysis.continuation import Cascade, Family, continue_orbit
    from nld.errors import InputError, SceneError, SolveError
    lo, hi = float(min(lo, hi)), float(max(lo, hi))
    fam = Family(system, param)
    branches, parent, doublings, notes = [branch], [None], [], []
    budget = int(max_points)
    queue = [0]
    while queue:
        ib = queue.pop(0)
        cur = branches[ib]
        pds = sorted((b for b in cur.bifurcations if b.kind == "period_doubling"
                      and lo <= b.value <= hi), key=lambda b: b.value)
        for bif in pds:
            doublings.append(bif)
            if 2 * cur.period > max_period:
                notes.append(f"the period-{2 * cur.period} branch at {bif.value:.6g} is beyond "
                             f"max_period = {max_period}")
                continue
            if bif.criticality != "supercritical" or bif.new_orbit is None:
                notes.append(f"the doubling at {bif.value:.6g} is {bif.criticality}: no doubled "
                             f"branch followed")
                continue
            v2 = float(bif.new_value)
            d = 1.0 if v2 > bif.value else -1.0
            bound = hi if d > 0 else lo
            if (bound - v2) * d <= 0:
                notes.append(f"the range ends at the doubling at {bif.value:.6g}")
                continue
            if budget < 1:
                notes.append(f"the cap of {max_points} points was used up before the doubling "
                             f"at {bif.value:.6g}")
                continue
            grid = _doubled_grid(bif.value, v2, bound, step)
            grid += [float(v) for v in values if (v - v2) * d > 0 and (bound - v) * d >= 0]
            grid = sorted(set(grid), key=lambda v: (v - v2) * d)
            cut = len(grid) > budget
            grid = grid[:budget]
            try:
                br2 = continue_orbit(fam.at(v2), bif.new_orbit, param, [v2] + grid,
                                     method="natural", locate_tol=locate_tol,
                                     criticality=criticality)
            except (InputError, SceneError, SolveError) as e:
                notes.append(f"the period-{2 * cur.period} branch from {v2:.6g} could not be "
                             f"continued ({e})")
                continue
            _cut_collapse(br2, d)
            budget -= max(len(br2.values) - 1, 0)
            for e in br2.ends:
                if e.direction == d and e.reason == "range_end" and cut:
                    e.reason = "step_limit"
                    e.detail = (f"the cascade's cap of {max_points} points (all doubled branches "
                                f"together) reached before the range's end {bound:.6g}")
                elif e.direction != d:
                    e.reason, e.detail = "range_end", (f"born at the period doubling at "
                                                       f"{bif.value:.6g} ± {bif.tolerance:.2g}")
            branches.append(br2)
            parent.append((ib, len(doublings) - 1))
            queue.append(len(branches) - 1)
    # the ratios along the chain of doublings p -> 2p -> 4p ... (the first of each period)
    chain = []
    for b in doublings:
        if b.orbit is not None and (not chain or b.orbit.period == 2 * chain[-1].orbit.period):
            chain.append(b)
    vals = [b.value for b in chain]
    ratios = [float((vals[k + 1] - vals[k]) / (vals[k + 2] - vals[k + 1]))
              for k in range(len(vals) - 2)]
    msg = "; ".join(notes) if notes else "every doubling met followed"
    return Cascade(branches, doublings, ratios, msg,
                   {"range": [lo, hi], "max_period": int(max_period), "step": float(step),
                    "max_points": int(max_points), "points": int(max_points) - budget,
                    "parent": parent, "chain": [b.value for b in chain]})


def _doubled_grid(at: float, v2: float, bound: float, step: float) -> list[float]:
    """The values after ``v2`` (the doubled orbit's first value, at distance d0 from the doubling
    at ``at``) towards ``bound``: distances from the doubling growing geometrically (2 d0, 4 d0,
    ...: the doubled orbit's halves part as the square root of the distance, so a fixed step from
    a point near the doubling would land Newton on the p-orbit) until the spacing reaches
    ``step``, then ``step`` apart, ``bound`` last."""
    d = 1.0 if bound > v2 else -1.0
    d0 = max(abs(v2 - at), 1e-12 * max(abs(at), 1.0))
    out, x, gap = [], abs(v2 - at), d0
    while gap < step:
        x += gap
        gap *= 2.0
        out.append(at + d * x)
    while True:
        x += step
        v = at + d * x
        if (bound - v) * d <= 1e-9 * step:
            break
        out.append(v)
    return [v for v in out if (bound - v) * d > 1e-9 * step] + [float(bound)]


def _cut_collapse(br, direction) -> None:
    """A doubled branch's points from the first whose halves coincide (within 10 x the Newton
    tolerance in the map's scales: Newton from the previous orbit found the period-p orbit run
    twice, not a period-2p orbit) are dropped; the branch then ends there with the reason
    "newton_failure" and says so."""
    from nld.analysis.continuation import BranchEnd
    half = br.period // 2
    for k, o in enumerate(br.orbits):
        m = o.map
        spread = float(np.max(np.abs(m.difference(o.points[0], o.points[half])
                                     / np.asarray(m.scales, dtype=float))))
        if spread <= 10 * o.tolerance and k > 0:
            bad = br.values[k]
            br.values, br.orbits = br.values[:k], br.orbits[:k]
            last = br.values[-1]
            br.bifurcations = [b for b in br.bifurcations
                               if (b.value - last) * direction <= 0]
            br.ends = [e for e in br.ends if e.direction != direction] + [BranchEnd(
                direction, float(last), "newton_failure",
                f"Newton from the period-{br.period} orbit at {last:.6g} converged at "
                f"{bad:.6g} to the period-{half} orbit run twice (its halves coincide to "
                f"{spread:.2g} of the scales): no period-{br.period} orbit found there")]
            br.message += f"; cut at {last:.6g}: the period-{half} orbit found at {bad:.6g}"
            return


def delta_sentence(ratios, n_doublings: int) -> str:
    """Feigenbaum's δ from the interval ratios of a chain of doublings, or why there is none."""
    from nld.analysis.continuation import FEIGENBAUM_DELTA
    if not ratios:
        return (f"{n_doublings} period doubling(s) located along the chain: too few to form the "
                f"interval ratio δ (three needed; Feigenbaum's δ = {FEIGENBAUM_DELTA:.4f} is the "
                f"smooth reference)")
    return ("interval ratios " + ", ".join(f"{r:.4g}" for r in ratios)
            + f" (Feigenbaum's δ = {FEIGENBAUM_DELTA:.4f} the smooth reference)")


# ---------------------------------------------------------------------------------------------------
# the workflow


def route_to_chaos(scene, overrides, param: str, values, *, start: float, chaotic: float | None,
                   rtol: float = 1e-10, transient: int = 50, max_period: int = 2,
                   seeds_per_period: int = 4, locate_tol: float | None = None,
                   method: str = "arclength", max_points: int = 60, polish: bool = True,
                   observables=(), guess: str = "previous", bisect: int = 3,
                   max_iter: int | None = None, criticality: bool = True,
                   cascade: dict | None = None, progress=None) -> dict:
    """The period-1 orbit of ``scene`` at ``param`` = ``start`` (Newton shooting from the state
    after ``transient`` revolutions), continued over the range of ``values`` (the sweep's values;
    ``method`` "arclength": pseudo-arclength both ways from ``start``, at most ``max_points``
    points; "natural": over ``values``; ``param`` with several comma-separated keys: the keys set
    together, :func:`linked_branch` from ``start`` upwards over ``values``, with ``guess``,
    ``bisect`` and ``max_iter``; ``criticality`` False: super-/subcritical not decided, the
    located bifurcations' criticality "undetermined"), its multipliers and
    the bifurcations located (``locate_tol``, default 1e-3 of the smallest step of ``values``); with
    ``polish`` the orbit again at each of ``values`` inside the branch's span (Newton from the
    nearest branch point: ``at_values``, for :func:`agreement`); ``observables``: table columns
    whose values at the section points are kept per polished orbit; and the distinct orbits of
    periods 1..``max_period`` at ``chaotic`` (None: none searched). ``cascade`` (None: off; a dict
    ``max_period``, ``step``, ``max_points``: :func:`check_cascade`): at each supercritical period
    doubling of the branch the doubled branch is followed within the range, and so on up to
    ``max_period`` (:func:`follow_doublings`; one key only).

    Returns a dict: ``orbit`` (the start orbit), ``branch`` (``Branch`` or None), ``ends``
    (:func:`branch_ends`), ``at_values`` ({value: orbit}), ``section`` ({value: {observable:
    array over the orbit's points}}), ``force`` ((min, max) contact force of the first clearance
    joint along each branch point), ``upos``, ``route`` (one sentence about the branch), ``param``,
    ``settings`` and ``wall_s``; with ``cascade`` also ``doubled`` (one dict per doubled branch:
    ``branch``, ``ends``, ``born`` (the doubling it was born at: value, tolerance, criticality,
    period), ``at_values``, ``section``, ``curve``) and ``cascade`` (``doublings`` [(period, value,
    tolerance, criticality)], ``ratios``, ``delta`` (one sentence), ``message``, ``points``,
    ``cpu_s``: the process time of the doubled branches). Never raises for a failed solve: the
    failure is in ``route``; a bad ``cascade`` is an InputError before any work."""
    from nld.analysis.orbits import find_orbits, periodic_orbit
    from nld.errors import SolveError
    from nld.systems.core import SceneSystem
    t0 = time.perf_counter()
    values = sorted(float(v) for v in values)
    linked = len(_keys(param)) > 1
    cascade = check_cascade(cascade)
    grid = sorted(set(values + [float(start)]))
    steps = np.diff(grid) if len(grid) > 1 else np.array([1.0])
    ltol = locate_tol if locate_tol is not None else 1e-3 * float(np.min(steps))
    out = {"orbit": None, "branch": None, "ends": [], "at_values": {}, "section": {},
           "upos": [], "route": "", "param": param, "force": [],
           "settings": dict(rtol=rtol, transient_revs=transient, start=start, chaotic=chaotic,
                            max_period=max_period, seeds_per_period=seeds_per_period,
                            locate_tol=ltol, values=values, method="linked" if linked else method,
                            max_points=max_points, guess=guess, bisect=bisect,
                            max_iter=max_iter, criticality=criticality, cascade=cascade)}
    keys = _keys(param)
    S = _linked_system(scene, overrides, keys, start) if linked else \
        SceneSystem(scene, list(overrides) + [f"{param}={start!r}"])
    try:
        o = periodic_orbit(S, 1, transient=transient, rtol=rtol)
    except SolveError as e:
        out["route"] = f"no period-1 orbit at {param} = {start:g}: {e}"
        out["wall_s"] = time.perf_counter() - t0
        return out
    out["orbit"] = o
    if not o.converged:
        out["route"] = (f"no period-1 orbit at {param} = {start:g} ({o.message}): the motion found "
                        f"there from the assembly is not periodic with period 1")
    else:
        if linked:
            br = linked_branch(scene, overrides, param, grid, o, start=start, rtol=rtol,
                               transient=transient, guess=guess, bisect=bisect,
                               max_iter=max_iter)
        else:
            br = _continue(S, o, param, grid, method=method, max_points=max_points,
                           locate_tol=ltol, criticality=criticality)
        out["branch"] = br
        out["ends"] = branch_ends(br)
        joint = S.kernel.topo.clearance[0] if S.kernel.topo.clearance else None
        out["joint"] = joint
        if joint is not None:
            for orb in br.orbits:
                try:
                    f = orb.observe(f"{joint}.Fn", 400)[f"{joint}.Fn"].to_numpy(float)
                    out["force"].append((float(f.min()), float(f.max())))
                except SolveError:
                    out["force"].append((float("nan"), float("nan")))
        if polish:
            out["at_values"] = _polish(scene, overrides, keys, br, values, rtol)
        if observables:
            out["section"] = {v: _section_of(orb, observables) for v, orb in out["at_values"].items()}
            # the branch's own points (in branch order), for the curve between the sweep values
            out["curve"] = [(float(v), _section_of(orb, observables), orbit_class(orb))
                            for v, orb in zip(br.values, br.orbits)]
        out["route"] = branch_sentence(br, param, start, out["ends"])
        if cascade is not None and not linked:
            add_doublings(out, S, br, param, grid, values=values, locate_tol=ltol,
                          criticality=criticality, cascade=cascade, observables=observables)
    if chaotic is not None and max_period >= 1:
        try:
            Sc = _linked_system(scene, overrides, keys, chaotic)
            out["upos"] = find_orbits(Sc, max_period, transient=transient, rtol=rtol,
                                      seeds_per_period=seeds_per_period, n_points=80)
        except SolveError as e:
            out["upos_error"] = str(e)
    out["wall_s"] = time.perf_counter() - t0
    return out


def add_doublings(out: dict, S, br, param, grid, *, values, cascade: dict, locate_tol=None,
                  criticality: bool = True, observables=()) -> None:
    """The doubled branches of ``br`` (a branch of system ``S`` in ``param``; any system:
    :func:`follow_doublings` over the range of ``grid``, ``cascade`` as :func:`check_cascade`
    takes it), each polished at the ``values`` it spans, into ``out["doubled"]`` and
    ``out["cascade"]`` (with the process time they took), and told in ``out["route"]``: the
    part of :func:`route_to_chaos` that follows the doublings."""
    cascade = check_cascade(cascade)
    ltol = locate_tol
    from nld.analysis.continuation import Family
    c0 = time.process_time()
    fam = Family(S, param)
    cas = follow_doublings(S, br, param, min(grid), max(grid), values=values, locate_tol=ltol,
                           criticality=criticality, **cascade)
    entries = []
    for b2, par in zip(cas.branches[1:], cas.settings["parent"][1:]):
        bif = cas.doublings[par[1]]
        e = {"branch": b2, "ends": branch_ends(b2),
             "born": {"value": float(bif.value), "tolerance": float(bif.tolerance),
                      "criticality": bif.criticality, "period": int(bif.orbit.period)},
             "at_values": {}, "section": {}, "curve": []}
        e["at_values"] = _polish(None, (), (), b2, values, b2.settings.get("rtol") or
                                 out.get("settings", {}).get("rtol"), system_at=fam.at)
        if observables:
            e["section"] = {v: _section_of(o, observables) for v, o in e["at_values"].items()}
            e["curve"] = [(float(v), _section_of(o, observables), orbit_class(o))
                          for v, o in zip(b2.values, b2.orbits)]
        entries.append(e)
    out["doubled"] = entries
    out["cascade"] = {"doublings": [(int(b.orbit.period), float(b.value), float(b.tolerance),
                                     b.criticality) for b in cas.doublings],
                      "ratios": list(cas.ratios), "chain": cas.settings["chain"],
                      "delta": delta_sentence(cas.ratios, len(cas.settings["chain"])),
                      "message": cas.message, "points": cas.settings["points"],
                      "cpu_s": time.process_time() - c0}
    for e in entries:
        b2 = e["branch"]
        v = np.asarray(b2.values, dtype=float)
        far = [x for x in e["ends"] if not x["detail"].startswith("born at")]
        out["route"] = out.get("route", "") + (
                         f" The period-{b2.period} orbit born at the period doubling at "
                         f"{e['born']['value']:.6g} ({e['born']['criticality']}) is followed over "
                         f"{v.min():.6g} ... {v.max():.6g} "
                         f"({', '.join(sorted({orbit_class(o) for o in b2.orbits}))})"
                         + "".join(f"; it ends at {x['value']:.6g}: {x['reason'].replace('_', ' ')}"
                                   + (f" ({x['detail']})" if x["detail"] else "") for x in far)
                         + ".")
    out["route"] = out.get("route", "") + f" Cascade: {out['cascade']['delta']}."


def _polish(scene, overrides, keys, br, values, rtol, system_at=None) -> dict:
    """{value: orbit} at each of ``values`` inside the branch's span, by Newton from the nearest
    branch point (the branch point itself where it is at that value); ``system_at``: value ->
    system (default the scene with the keys set)."""
    from nld.analysis.orbits import periodic_orbit
    from nld.errors import SolveError
    bv = np.asarray(br.values, dtype=float)
    out = {}
    if bv.size == 0:
        return out
    for v in values:
        if not (bv.min() - 1e-12 <= v <= bv.max() + 1e-12):
            continue
        k = int(np.argmin(np.abs(bv - v)))
        if abs(bv[k] - v) <= 1e-12 * max(1.0, abs(v)):
            out[v] = br.orbits[k]
            continue
        try:
            o = periodic_orbit(system_at(v) if system_at is not None else
                               _linked_system(scene, overrides, keys, v), br.period,
                               guess=br.orbits[k].points[0], z=br.orbits[k].z[0], rtol=rtol)
        except SolveError:
            continue
        if o.converged:
            out[v] = o
    return out


def orbits_at(scene, overrides, param, values, *, period: int = 1, transient: int = 10,
              rtol: float = 1e-10, max_iter: int | None = None, observables=()) -> dict:
    """The period-``period`` orbit at each of ``values`` found on its own (Newton from the state
    after ``transient`` revolutions of a run at that value; ``param`` one key or several set
    together), for points no branch reaches (e.g. a periodic window beyond the branch's end).
    Returns {"at_values": {value: converged orbit}, "section": {value: {observable: values at the
    orbit's points}}, "failed": {value: Newton's message}}: the form :func:`agreement` reads."""
    from nld.analysis.orbits import periodic_orbit
    from nld.errors import SolveError
    keys = _keys(param)
    out = {"at_values": {}, "section": {}, "failed": {}}
    it = {} if max_iter is None else {"max_iter": int(max_iter)}
    for v in values:
        v = float(v)
        try:
            o = periodic_orbit(_linked_system(scene, overrides, keys, v), period,
                               transient=transient, rtol=rtol, **it)
        except SolveError as e:
            out["failed"][v] = str(e)
            continue
        if not o.converged:
            out["failed"][v] = o.message
            continue
        out["at_values"][v] = o
        if observables:
            out["section"][v] = _section_of(o, observables)
    return out


def orbit_exponent(o) -> tuple[float, float]:
    """The largest Lyapunov exponent of a periodic orbit from its multipliers, per iteration of
    the map it is an orbit of (per crank revolution for a one-revolution stroboscopic map):
    ln(max |mu|) / period, the contact memory's neutral multiplier left out (Floquet: the exponents
    of a periodic orbit are the logarithms of its multipliers over the period; Parker & Chua 1989
    ch. 2), and its uncertainty from the multiplier's: u(max |mu|) / (max |mu| period)."""
    crit = _critical_multipliers(o)
    m = float(np.max(np.abs(crit))) if crit.size else float(o.max_abs_multiplier)
    if not (m > 0 and math.isfinite(m)):
        return float("nan"), float("nan")
    return math.log(m) / o.period, multiplier_uncertainty(o) / (m * o.period)


def _section_of(orbit, observables) -> dict:
    """{observable: values at the orbit's section points} (scene table columns)."""
    from nld.analysis.continuation import orbit_observable
    flow = orbit.map.flow
    return {name: orbit_observable(flow, orbit, name) for name in observables}


def branch_sentence(br, param, start, ends) -> str:
    """One or two sentences: where the period-1 branch from ``start`` runs, its stability and how
    each end ends."""
    vals = np.asarray(br.values, dtype=float)
    cls = sorted({orbit_class(o) for o in br.orbits})
    s = (f"The period-1 orbit at {param} = {start:g} is followed over {vals.min():.4g} ... "
         f"{vals.max():.4g} ({', '.join(cls)}; {len(br.bifurcations)} bifurcation(s) located).")
    for e in ends:
        side = "low" if e["direction"] < 0 else "high"
        if e["reason"] == "range_end":
            s += f" Its {side} end is the end of the range ({e['value']:.4g})."
        else:
            s += (f" Its {side} end at {e['value']:.4g}: {e['reason'].replace('_', ' ')}"
                  + (f" ({e['detail']})" if e["detail"] else "") + ".")
    return s


# ---------------------------------------------------------------------------------------------------
# agreement of the branch with the brute-force diagram


def agreement(route: dict, sweep: pd.DataFrame, observables, scales, *, tol: float = 1e-3,
              settled: int = 8) -> pd.DataFrame:
    """Each orbit of ``route["at_values"]`` (the branch at the sweep's values) against the
    brute-force section at that value (``sweep``: rows ``value``, the ``observables``, optionally
    ``status``). A point agrees when the last ``settled`` section points all lie within ``tol``
    (scaled by ``scales``, one per observable: e.g. the clearance) of one of the orbit's points.
    Returns one row per value and branch (the doubled branches' orbits, ``route["doubled"]``,
    after the period-1 branch's): value, class (stable / unstable / neutral continuum), distance
    (the largest scaled distance of a section point to the orbit), agrees (bool), why (for a
    stable point that does not agree: "coexistence" when the brute-force motion is settled
    elsewhere, or "continuum" for a permanent-contact orbit, whose neighbours are orbits too),
    period (the orbit's)."""
    rows = []
    obs = list(observables)
    sc = np.asarray(scales, dtype=float) * np.ones(len(obs))
    ok = sweep[sweep["status"] == "ok"] if "status" in sweep.columns else sweep
    if "rev" in ok.columns:
        ok = ok[ok["rev"] >= 0]
    cases = [(v, o, route.get("section") or {}) for v, o in
             sorted(route.get("at_values", {}).items())]
    for e in route.get("doubled", []):
        cases += [(v, o, e.get("section") or {}) for v, o in sorted(e["at_values"].items())]
    for v, o, secs in cases:
        pts = ok[np.isclose(ok["value"].to_numpy(float), v, rtol=1e-12, atol=0.0)]
        if not len(pts) or v not in secs:
            continue
        Y = np.column_stack([np.atleast_1d(secs[v][k]) for k in obs])
        # each run of the sweep at this value (both directions of a hysteresis sweep): the
        # largest scaled distance of its last points to the orbit; the smallest over the runs
        groups = [g for _, g in pts.groupby("direction")] if "direction" in pts.columns else [pts]
        dist, X = float("inf"), pts[obs].to_numpy(float)[-settled:]
        for g in groups:
            Xg = g[obs].to_numpy(float)[-settled:]
            if not Xg.size:
                continue
            d = np.abs(Xg[:, None, :] - Y[None, :, :]) / sc
            dg = float(np.max(np.min(np.max(d, axis=2), axis=1)))
            if dg < dist:
                dist, X = dg, Xg
        cls = orbit_class(o)
        agrees = bool(np.isfinite(dist) and dist <= tol)
        why = ""
        if cls != "unstable" and not agrees:
            spread = float(np.max(np.ptp(X, axis=0) / sc)) if len(X) > 1 else 0.0
            if memory_neutral(o):
                why = "continuum"
            elif spread <= tol:
                why = "coexistence (the brute force settled on another periodic motion)"
            else:
                why = "coexistence (the brute force from the assembly is not on the orbit)"
        rows.append({"value": v, "class": cls, "max_abs_mu": o.max_abs_multiplier,
                     "mu_unc": multiplier_uncertainty(o), "onsets": int(o.onsets_per_period),
                     "distance": dist, "agrees": agrees, "why": why, "period": int(o.period)})
    return pd.DataFrame(rows, columns=["value", "class", "max_abs_mu", "mu_unc", "onsets",
                                       "distance", "agrees", "why", "period"])


# ---------------------------------------------------------------------------------------------------
# the route as rows


def sweep_regimes(pts: pd.DataFrame, period_col: str | None = None) -> list[str]:
    """The brute-force regime at each sweep point (``pts``: ``verdict`` and optionally a section
    period column, 0 = none): "chaotic", "coexisting", "period p" (regular with a period),
    "regular" (no period found), "not established" (uncertain, short, failed ...)."""
    out = []
    for _, r in pts.iterrows():
        vd = str(r.get("verdict", ""))
        p = int(r[period_col]) if period_col and period_col in r and np.isfinite(r[period_col]) else 0
        if vd == "chaotic":
            out.append("chaotic")
        elif vd == "coexisting":
            out.append("coexisting")
        elif vd == "regular":
            out.append(f"period {p}" if p > 0 else "regular")
        else:
            out.append("not established")
    return out


def _lam(pts, i) -> str:
    if i is None or i < 0 or i >= len(pts):
        return ""
    r = pts.iloc[i]
    lam, unc = float(r.get("lambda_per_rev", np.nan)), float(r.get("lambda_unc_per_rev", np.nan))
    return "" if not np.isfinite(lam) else f"{lam:+.3g} ± {unc:.2g} at {float(r['value']):.4g}"


def route_table(sweep_name: str, param: str, pts: pd.DataFrame, *, period_col: str | None = None,
                route: dict | None = None, agree: pd.DataFrame | None = None) -> pd.DataFrame:
    """The route of one sweep as ordered rows (:data:`ROUTE_COLUMNS`), by increasing parameter.

    pts: the sweep points (``value``, ``lambda_per_rev``, ``lambda_unc_per_rev``, ``verdict``,
    optionally ``period_col``). route: :func:`route_to_chaos`'s result for this sweep (None: the
    rows come from the brute force alone). agree: :func:`agreement`'s table.

    Rows with source "continuation": each stretch of the branch with one stability class, ended by
    the located bifurcation (value ± tolerance, multipliers) or by the branch's end (its reason).
    Rows with source "brute force": each run of sweep points with one regime, ended by the change
    to the next (onset of chaos where λ1 turns positive, end of chaos, or a regime change; located
    at the midpoint ± half the spacing, or at a located bifurcation of the branch inside that
    interval)."""
    pts = pts.sort_values("value").reset_index(drop=True)
    vals = pts["value"].to_numpy(float)
    reg = sweep_regimes(pts, period_col)
    rows = []
    bifs = []
    if route is not None and route.get("branch") is not None:
        br = route["branch"]
        bifs = sorted(br.bifurcations, key=lambda b: b.value)
        ag1 = agree[agree["period"] == br.period] if (agree is not None and len(agree) and
                                                       "period" in agree.columns) else agree
        rows += _branch_rows(br, route, pts, ag1)
        for e in route.get("doubled", []):
            rows += _doubled_rows(e, route, pts, agree)
    # brute-force runs
    i = 0
    while i < len(vals):
        j = i
        while j + 1 < len(vals) and reg[j + 1] == reg[i]:
            j += 1
        if j + 1 < len(vals):
            a, b = vals[j], vals[j + 1]
            nxt = reg[j + 1]
            if nxt == "chaotic":
                kind = "onset_of_chaos"
            elif reg[i] == "chaotic":
                kind = "end_of_chaos"
            else:
                kind = "regime_change"
            inside = [bf for bf in bifs if a <= bf.value <= b]
            if inside:
                bf = inside[0]
                at, unc = bf.value, bf.tolerance
                ev = f"{reg[i]} -> {nxt}; branch: {bf.detail}"
            else:
                at, unc = 0.5 * (a + b), 0.5 * (b - a)
                ev = f"{reg[i]} -> {nxt} between sweep points {a:.4g} and {b:.4g}"
        else:
            kind, at, unc, ev = "range_end", vals[j], 0.0, "last sweep point"
            nxt = ""
        rows.append({"source": "brute force", "regime": reg[i],
                     "period": _period_of(reg[i]), "from": vals[i], "to": vals[j],
                     "transition": kind, "at": at, "at_unc": unc, "evidence": ev,
                     "lambda_before": _lam(pts, j), "lambda_after": _lam(pts, j + 1),
                     "agrees": _bf_agrees(vals[i], vals[j], reg[i], route, agree)})
        i = j + 1
    df = pd.DataFrame(rows)
    if not len(df):
        return pd.DataFrame(columns=ROUTE_COLUMNS)
    df = df.sort_values(["from", "source"], kind="stable").reset_index(drop=True)
    df.insert(0, "order", np.arange(1, len(df) + 1))
    df.insert(0, "param", param)
    df.insert(0, "sweep", sweep_name)
    return df[ROUTE_COLUMNS]


def _period_of(regime: str) -> int:
    if regime.startswith("period "):
        try:
            return int(regime.split()[1])
        except ValueError:
            return 0
    return 0


def _bf_agrees(a, b, regime, route, agree) -> str:
    """Whether the branch agrees with a brute-force run over [a, b]."""
    if route is None or route.get("branch") is None or agree is None or not len(agree):
        return "no branch here"
    sub = agree[(agree["value"] >= a - 1e-15) & (agree["value"] <= b + 1e-15)]
    p = _period_of(regime)
    if "period" in sub.columns:
        sp = sub[(sub["period"] == p) & (sub["class"] != "unstable")] if p > 1 else sub[:0]
        if len(sp):           # a doubled branch of the brute force's period here
            bad = sp[~sp["agrees"]]
            return f"yes (the period-{p} branch)" if not len(bad) else (
                "no at " + ", ".join(f"{v:.4g} (period-{p} branch: {w})"
                                      for v, w in zip(bad["value"], bad["why"])))
        sub = sub[sub["period"] == 1]
    if not len(sub):
        return "no branch here"
    st = sub[sub["class"] != "unstable"]
    if regime.startswith("period 1"):
        bad = st[~st["agrees"]]
        return "yes" if len(st) and not len(bad) else (
            "no branch point stable here" if not len(st) else
            "no at " + ", ".join(f"{v:.4g} ({w})" for v, w in zip(bad["value"], bad["why"])))
    if len(st):
        return ("branch stable here too: " + ", ".join(f"{v:.4g}" for v in st["value"])
                + " (coexistence or continuum)")
    return "yes (branch unstable here)"


def _stretches(cls):
    """(i, j) of each run of equal stability words in ``cls`` (branch order)."""
    i = 0
    while i < len(cls):
        j = i
        while j + 1 < len(cls) and cls[j + 1] == cls[i]:
            j += 1
        yield i, j
        i = j + 1


def _multiplier_text(o, *, memory_value: bool = True) -> str:
    """The evidence's multiplier clause of a branch orbit: max |mu| ± its uncertainty, the
    memory's neutral 1 named (``memory_value``: with the largest of the others beside it) and
    the contact onsets per period."""
    mu = _critical_multipliers(o)
    note = ""
    if memory_neutral(o):
        if not memory_value:
            note = " (the memory's neutral 1 included)"
        elif mu.size:
            note = f" (without the memory's 1: {np.max(np.abs(mu)):.4g})"
    return (f"max |mu| {o.max_abs_multiplier:.4g} ± {multiplier_uncertainty(o):.2g}{note}"
            f", {o.onsets_per_period} onsets/period")


def _interior_transition(bifs, a: float, b: float, before: str, after: str, mtxt: str):
    """(kind, at, uncertainty, evidence) of the change between two branch points a < b: the
    first of ``bifs`` located between them, else a regime change at the midpoint."""
    inside = [x for x in bifs if a <= x.value <= b]
    if inside:
        x = inside[0]
        return x.kind, x.value, x.tolerance, f"{x.detail}; {mtxt}"
    return ("regime_change", 0.5 * (a + b), 0.5 * (b - a),
            f"{before} -> {after} between branch points; {mtxt}")


def _agrees_word(word: str, sub) -> str:
    """The route row's agreement with the brute force over its stretch (``sub``: the agreement
    rows there, or None)."""
    if word == "unstable":
        return "n/a (unstable: brute force does not show it)"
    if sub is None or not len(sub):
        return "not checked (no sweep point on this stretch)"
    bad = sub[~sub["agrees"]]
    return "yes" if not len(bad) else "no at " + ", ".join(
        f"{v:.4g} ({w})" for v, w in zip(bad["value"], bad["why"]))


def _branch_rows(br, route, pts, agree) -> list[dict]:
    vals = np.asarray(br.values, dtype=float)
    order = np.argsort(vals, kind="stable")
    vals = vals[order]
    orbs = [br.orbits[k] for k in order]
    cls = [orbit_class(o) for o in orbs]
    bifs = sorted(br.bifurcations, key=lambda b: b.value)
    ends = {e["direction"]: e for e in route.get("ends", [])}
    pv = pts["value"].to_numpy(float)
    rows = []
    for i, j in _stretches(cls):
        mtxt = _multiplier_text(orbs[j])
        if j + 1 < len(vals):
            kind, at, unc, ev = _interior_transition(bifs, vals[j], vals[j + 1], cls[i],
                                                     cls[j + 1], mtxt)
        else:
            e = ends.get(+1, {"reason": "range_end", "detail": "", "value": vals[j]})
            kind = e["reason"] if e["reason"] in ("fold", "grazing", "contact_change") else \
                ("range_end" if e["reason"] == "range_end" else "branch_end")
            at, unc = vals[j], 0.0
            ev = f"branch end: {e['reason']}" + (f" ({e['detail']})" if e["detail"] else "") \
                + f"; {mtxt}"
        ib = int(np.searchsorted(pv, vals[j], side="right")) - 1
        if agree is not None and len(agree):
            sub = agree[(agree["value"] >= vals[i] - 1e-15) & (agree["value"] <= vals[j] + 1e-15)]
        else:
            sub = agree
        rows.append({"source": "continuation", "regime": f"period {br.period} {cls[i]}",
                     "period": br.period, "from": vals[i], "to": vals[j], "transition": kind,
                     "at": at, "at_unc": unc, "evidence": ev,
                     "lambda_before": _lam(pts, ib), "lambda_after": _lam(pts, ib + 1),
                     "agrees": _agrees_word(cls[i], sub)})
    lo = ends.get(-1)
    if rows and lo is not None and lo["reason"] != "range_end":
        rows[0]["evidence"] += (f"; low end at {lo['value']:.4g}: {lo['reason']}"
                                + (f" ({lo['detail']})" if lo["detail"] else ""))
    return rows


def _doubled_rows(e, route, pts, agree) -> list[dict]:
    """The rows of one doubled branch (``route["doubled"]`` entry), in branch order from its
    doubling outwards: each stretch with one stability word, its transition the one that ends it
    AWAY from the doubling it was born at (a further located bifurcation, else the branch's far
    end with its reason); the evidence names the doubling it was born at and, on the last row,
    the cascade's interval ratios or why there are none."""
    br = e["branch"]
    vals = np.asarray(br.values, dtype=float)
    orbs = list(br.orbits)
    cls = [orbit_class(o) for o in orbs]
    born = e["born"]
    far = next((x for x in e["ends"] if not str(x["detail"]).startswith("born at")),
               {"reason": "range_end", "detail": "", "value": vals[-1]})
    pv = pts["value"].to_numpy(float)
    sub_all = (agree[agree["period"] == br.period] if agree is not None and len(agree)
               and "period" in agree.columns else None)
    rows = []
    for i, j in _stretches(cls):
        mtxt = _multiplier_text(orbs[j], memory_value=False)
        if j + 1 < len(vals):
            a, b = sorted((vals[j], vals[j + 1]))
            kind, at, unc, ev = _interior_transition(br.bifurcations, a, b, cls[i], cls[j + 1],
                                                     mtxt)
        else:
            kind = far["reason"] if far["reason"] in ("fold", "grazing", "contact_change",
                                                       "range_end") else "branch_end"
            at, unc = float(far["value"]), 0.0
            ev = (f"branch end: {far['reason']}" + (f" ({far['detail']})" if far["detail"] else "")
                  + f"; {mtxt}")
        ev = (f"born at the period doubling of the period-{born['period']} orbit at "
              f"{born['value']:.6g} ± {born['tolerance']:.2g} ({born['criticality']}); " + ev)
        lo, hi = float(min(vals[i], vals[j])), float(max(vals[i], vals[j]))
        sub = None if sub_all is None else sub_all[(sub_all["value"] >= lo - 1e-15)
                                                   & (sub_all["value"] <= hi + 1e-15)]
        ib = int(np.searchsorted(pv, at, side="right")) - 1
        rows.append({"source": "continuation", "regime": f"period {br.period} {cls[i]}",
                     "period": br.period, "from": lo, "to": hi, "transition": kind,
                     "at": at, "at_unc": unc, "evidence": ev,
                     "lambda_before": _lam(pts, ib), "lambda_after": _lam(pts, ib + 1),
                     "agrees": _agrees_word(cls[i], sub)})
    if rows and route.get("cascade"):
        rows[-1]["evidence"] += f"; cascade: {route['cascade']['delta']}"
    return rows


def route_sentence(table: pd.DataFrame, symbol: str, *, scale: float = 1.0, unit: str = "") -> str:
    """The sequence of a :func:`route_table` in one sentence, told from the periodic end towards
    the chaotic one (by decreasing parameter when the chaos lies at the low end): the brute-force
    regimes (the branch's stability word where a continued branch covers a period-1 stretch) and the
    transitions between them, each at its located value ± uncertainty (the branch's where it
    located one inside the interval), e.g. "period 1, stable (μ = 0.1–0.04) → contact change at
    μ = 0.035 ± 1e-05 → period 2 (μ = 0.02) → onset of chaos at μ = 0.015 ± 0.005 → chaotic
    (μ = 0.01–0)"."""
    bf = table[table["source"] == "brute force"].reset_index(drop=True)
    allc = table[table["source"] == "continuation"]
    cont = allc[allc["period"] == 1]
    u = f" {unit}" if unit else ""
    if not len(bf):
        return "No sweep points."
    reg = list(bf["regime"])
    down = reg[0] == "chaotic" and reg[-1] != "chaotic"

    def num(x):
        return f"{x * scale:.4g}"

    def at(r):
        return (f"{symbol} = {num(r['at'])}" + (f" ± {r['at_unc'] * scale:.2g}" if r["at_unc"] > 0
                                               else "") + u)

    def name_of(r):
        name = r["regime"]
        if name.startswith("period 1") and len(cont):
            c = cont[(cont["from"] <= r["to"]) & (cont["to"] >= r["from"])]
            if len(c):
                name = " / ".join(dict.fromkeys(x.replace("period 1 ", "period 1, ")
                                                for x in c["regime"]))
        lo, hi = (r["to"], r["from"]) if down else (r["from"], r["to"])
        return f"{name} ({symbol} = {num(lo)}–{num(hi)}{u})" if lo != hi else \
            f"{name} ({symbol} = {num(lo)}{u})"

    def word(r, before, after):
        k = r["transition"]
        if (k == "end_of_chaos" and down) or (k == "onset_of_chaos" and not down):
            w = "onset of chaos (λ1 turns positive)"
        elif k in ("end_of_chaos", "onset_of_chaos"):
            w = "end of chaos (λ1 turns negative)"
        elif k == "regime_change":
            pa, pb = _period_of(before), _period_of(after)
            w = ("period doubling (brute force)" if pa and pb == 2 * pa else
                 "period halving (brute force)" if pb and pa == 2 * pb else "regime change")
        else:
            w = k.replace("_", " ")
        if "branch: " in r["evidence"]:
            kind = r["evidence"].split("branch: ")[1].split(" at ")[0]
            w = f"{kind.replace('_', ' ')} of the period-1 orbit" + (
                ", onset of chaos" if "chaos" in w else "")
        return f"{w} at {at(r)}"

    idx = list(range(len(bf)))
    parts = []
    if down:
        idx = idx[::-1]
        for n, i in enumerate(idx):
            parts.append(name_of(bf.iloc[i]))
            if n + 1 < len(idx):
                parts.append(word(bf.iloc[idx[n + 1]], reg[i], reg[idx[n + 1]]))
    else:
        for n, i in enumerate(idx):
            parts.append(name_of(bf.iloc[i]))
            if n + 1 < len(idx):
                parts.append(word(bf.iloc[i], reg[i], reg[i + 1]))
    s = " → ".join(parts) + "."
    if len(cont):
        ends = [r for _, r in cont.iterrows() if r["transition"] not in ("range_end", "regime_change")]
        for r in ends:
            s += (f" The continued period-1 branch: {r['transition'].replace('_', ' ')} at "
                  f"{at(r)} ({r['evidence'].split(';')[0]}).")
    for p in sorted({int(x) for x in allc["period"]} - {1}):
        s += " " + _doubled_sentence(allc, p, at, name_of=lambda r: (
            f"{r['regime'].replace(f'period {p} ', f'period {p}, ')} ({symbol} = "
            f"{num(r['from'])}–{num(r['to'])}{u})"))
    return s


def _doubled_sentence(cont, p, at, name_of) -> str:
    """"The doubled branch: period p/2 → period doubling at … → period p, … (…) → its end
    at …" from the continuation rows of period p, in branch order (away from the doubling of the
    period-p/2 rows it was born at), with the cascade's interval ratios or why there are none."""
    rows = cont[cont["period"] == p]
    par = cont[(cont["period"] == p // 2) & (cont["transition"] == "period_doubling")]
    parts = [f"period {p // 2}"]
    down = True
    if len(par):
        pr = par.iloc[int(np.argmin(np.abs(par["at"].to_numpy(float) - rows["from"].mean())))]
        parts.append(f"period doubling at {at(pr)}")
        down = pr["at"] >= rows["to"].max()
    rows = rows.sort_values("from", ascending=not down)
    tail = ""
    for _, r in rows.iterrows():
        parts.append(name_of(r))
        k = r["transition"]
        w = ("end of the range" if k == "range_end" else
             f"branch end ({r['evidence'].split('branch end: ')[1].split(';')[0]})"
             if k == "branch_end" and "branch end: " in r["evidence"] else k.replace("_", " "))
        parts.append(f"{w} at {at(r)}")
        if "cascade: " in r["evidence"]:
            tail = " Cascade: " + r["evidence"].split("cascade: ")[1] + "."
    return f"The doubled branch: {' → '.join(parts)}.{tail}"


# ---------------------------------------------------------------------------------------------------
# the figure


def _label_transitions(ax, labels, logx: bool) -> None:
    """The transitions' labels along the top of ``ax``, each in the first row (of up to 6, 9 pt
    apart) where it clears the label to its left: widths estimated at 0.55 x the 7-pt font per
    character over the panel's width (a label that moves to another row never covers its
    neighbour, as the former rows by turn did)."""
    import math
    if not labels:
        return
    lo, hi = ax.get_xlim()
    f = (lambda v: math.log10(max(v, 1e-300))) if logx else (lambda v: v)
    span = (f(hi) - f(lo)) or 1.0
    fig = ax.get_figure()
    # the legends beside the panel take about a fifth of its width once laid out
    width_pt = max(ax.get_position().width * fig.get_figwidth() * 72.0 * 0.75, 1.0)
    ends: list[float] = []
    for x, text, colour in sorted(labels):
        start = (f(x) - f(lo)) / span + 2.0 / width_pt
        end = start + (len(text) * 7 * 0.55 + 4) / width_pt
        row = next((k for k, e in enumerate(ends) if start > e), None)
        if row is None:
            row = len(ends) if len(ends) < 6 else min(range(len(ends)), key=ends.__getitem__)
            ends.append(end) if row == len(ends) else None
        ends[row] = end
        ax.annotate(text, (x, 1.0), xycoords=("data", "axes fraction"), xytext=(2, -10 - 9 * row),
                    textcoords="offset points", fontsize=7, color=colour, rotation=0)



def _draw_branch(ax, period, sec, at_values, curve, observable, scale, param_scale, colour,
                 shown) -> None:
    """One branch over the brute force: its curve through its own points in branch order (p
    lines for a period-p orbit: the observable at each section point; styled by stability), and
    circles at the sweep values (filled: stable)."""
    vs = sorted(v for v in sec if observable in sec[v])
    ys = {v: np.atleast_1d(sec[v][observable]) for v in vs}
    styles = {"stable": "-", "unstable": "--", "neutral continuum": ":", "neutral": ":"}
    cls = {v: orbit_class(at_values[v]) for v in vs}
    curve = curve or [(v, sec[v], cls[v]) for v in vs]
    for k in range(period):
        for (a, sa, ca), (b, sb, cb) in zip(curve[:-1], curve[1:]):
            c = ca if ca == cb else "unstable" if "unstable" in (ca, cb) else ca
            lab = f"period {period}, {c}"
            ax.plot([a * param_scale, b * param_scale],
                    [np.atleast_1d(sa[observable])[k] * scale,
                     np.atleast_1d(sb[observable])[k] * scale],
                    styles[c], color=colour, lw=1.6, label=None if lab in shown else lab)
            shown.add(lab)
        for v in vs:
            c = cls[v]
            lab = f"period-{period} orbit at a sweep value ({c})"
            ax.plot(v * param_scale, ys[v][k] * scale, "o", ms=3.5, color=colour,
                    mfc=colour if c == "stable" else "white",
                    label=None if lab in shown else lab)
            shown.add(lab)


def route_figure(ax, bx, route: dict | None, sweep: pd.DataFrame | None, pts: pd.DataFrame,
                 table: pd.DataFrame, observable: str, *, label: str, scale: float = 1.0,
                 unit: str = "", param_scale: float = 1.0, param_unit: str = "",
                 logx: bool = False):
    """Two axes ``ax`` over ``bx`` sharing the parameter axis: above, the brute-force section points (grey)
    with the branch (stable solid, unstable dashed, neutral dotted; the observable at the orbit's
    section points) and its doubled branches (``route["doubled"]``: p lines for a period-p
    orbit, in the next colours) and its located transitions marked; beneath, λ1 per revolution
    ± its uncertainty at each sweep point (filled: chaotic). The transitions of ``table`` are vertical
    lines through both, labelled. Returns the two axes."""
    if sweep is not None and len(sweep) and observable in sweep.columns:
        ok = sweep[sweep["status"] == "ok"] if "status" in sweep.columns else sweep
        ax.scatter(ok["value"].to_numpy(float) * param_scale, ok[observable].to_numpy(float) * scale,
                   s=7.0, linewidths=0, color="0.55", label="brute force (section points)")
    shown = set()
    if route is not None and route.get("branch") is not None and route.get("section"):
        _draw_branch(ax, route["branch"].period, route["section"], route["at_values"],
                     route.get("curve"), observable, scale, param_scale, "C0", shown)
    for n, e in enumerate((route or {}).get("doubled", [])):
        if e.get("curve"):
            _draw_branch(ax, e["branch"].period, e["section"], e["at_values"], e["curve"],
                         observable, scale, param_scale, f"C{n + 1}", shown)
    pv = pts["value"].to_numpy(float) * param_scale
    lam = pts["lambda_per_rev"].to_numpy(float)
    unc = pts["lambda_unc_per_rev"].to_numpy(float)
    chaotic = (pts["verdict"] == "chaotic").to_numpy() if "verdict" in pts else lam > 0
    bx.errorbar(pv, lam, yerr=unc, fmt="none", ecolor="0.4", lw=0.8, capsize=2)
    bx.plot(pv[~chaotic], lam[~chaotic], "o", ms=4, mfc="white", color="k", label="not chaotic")
    bx.plot(pv[chaotic], lam[chaotic], "o", ms=4, color="tab:red", label="chaotic")
    bx.axhline(0.0, color="k", lw=0.6)
    marks = table[table["transition"].isin(
        ["period_doubling", "fold", "neimark_sacker", "grazing", "contact_change",
         "onset_of_chaos", "end_of_chaos", "regime_change", "branch_end"])]
    seen = set()
    # one mark per location: the branch's kind first, a brute-force change only where none is
    marks = marks.assign(_k=(marks["transition"] == "regime_change").astype(int)).sort_values(
        ["_k", "at"], kind="stable")
    labels = []
    for _, r in marks.iterrows():
        x = r["at"] * param_scale
        key = round(x, 12)
        if key in seen:
            continue
        seen.add(key)
        colour = "tab:red" if r["transition"] in ("onset_of_chaos", "end_of_chaos") else "tab:green"
        for axx in (ax, bx):
            axx.axvline(x, color=colour, lw=0.9, ls="-.")
            if r["at_unc"] > 0:
                axx.axvspan((r["at"] - r["at_unc"]) * param_scale,
                            (r["at"] + r["at_unc"]) * param_scale, color=colour, alpha=0.08, lw=0)
        labels.append((x, f"{_SHORT.get(r['transition'], r['transition'])} {x:.4g}", colour))
    ax.set_ylabel(f"{observable}" + (f" [{unit}]" if unit else ""))
    bx.set_ylabel("λ1 [1/rev]")
    bx.set_xlabel(label + (f" [{param_unit}]" if param_unit else ""))
    if logx:
        from matplotlib.ticker import FormatStrFormatter, NullFormatter
        bx.set_xscale("log")
        bx.xaxis.set_major_formatter(FormatStrFormatter("%g"))
        bx.xaxis.set_minor_formatter(NullFormatter())
    _label_transitions(ax, labels, logx)      # after the scale: positions on the final axis
    h, lab = ax.get_legend_handles_labels()
    if h:
        ax.legend(h, lab, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    bx.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return ax, bx


# ---------------------------------------------------------------------------------------------------
# tables and records


def orbit_rows(orbits, value_of=None) -> pd.DataFrame:
    """A table of orbits (a branch's or a search's): period, stability (stable / unstable /
    neutral, the memory's neutral multiplier left out), max |mu| ± its uncertainty, onsets per
    period, smallest approach speed (m/s), continuum, residual."""
    rows = []
    for i, o in enumerate(orbits):
        r = {} if value_of is None else {"value": value_of(i)}
        r.update(period=o.period, stability=orbit_class(o),
                 max_abs_mu=o.max_abs_multiplier, mu_error=multiplier_uncertainty(o),
                 onsets=o.onsets_per_period,
                 min_approach=(o.min_approach_speed if np.isfinite(o.min_approach_speed)
                               else float("nan")),
                 continuum=o.continuum, residual=o.residual)
        rows.append(r)
    return pd.DataFrame(rows)


def route_record(route: dict, sde: bool = False) -> dict:
    """The provenance record of :func:`route_to_chaos` (plain JSON types); ``sde``: leave the
    wall time out (SOURCE_DATE_EPOCH)."""
    br = route.get("branch")
    st = dict(route.get("settings", {}))
    return {"route": route.get("route", ""), "param": route.get("param"), "settings": st,
            "bifurcations": [] if br is None else [b.to_dict() for b in br.bifurcations],
            "branch_message": None if br is None else br.message,
            "ends": route.get("ends", []),
            "upos": [o.to_dict() for o in route.get("upos", [])],
            "doubled": [{"period": e["branch"].period, "born": e["born"], "ends": e["ends"],
                         "values": [float(min(e["branch"].values)), float(max(e["branch"].values))],
                         "bifurcations": [b.to_dict() for b in e["branch"].bifurcations]}
                        for e in route.get("doubled", [])],
            "cascade": ({k: v for k, v in route["cascade"].items() if not (sde and k == "cpu_s")}
                        if route.get("cascade") else None),
            "wall_s": None if sde else route.get("wall_s")}


def route_tables(route: dict) -> dict:
    """The tables of :func:`route_to_chaos` to save: ``branch`` (one row per branch point, with its
    stability word and the contact force range; the doubled branches' points after the period-1
    branch's, column ``period``, the observables at each section point as ``name[k]``) and
    ``orbits`` (the orbits found in the chaotic range)."""
    out = {}
    br = route.get("branch")
    if br is not None:
        t = br.table()
        t.insert(4, "stability", [orbit_class(o) for o in br.orbits])
        if "stable" in t.columns:
            t = t.drop(columns=["stable"])
        t.insert(5, "mu_uncertainty", [multiplier_uncertainty(o) for o in br.orbits])
        if route.get("force") and len(route["force"]) == len(t):
            t["min_Fn"] = [f[0] for f in route["force"]]
            t["max_Fn"] = [f[1] for f in route["force"]]
        curve = route.get("curve") or []
        if len(curve) == len(t):
            # the observables at the orbit's (first) section point, as the brute force records them
            for name in curve[0][1] if curve else []:
                t[name] = [float(np.atleast_1d(c[1][name])[0]) for c in curve]
        parts = [t]
        for e in route.get("doubled", []):
            b2 = e["branch"]
            t2 = b2.table()
            t2.insert(4, "stability", [orbit_class(o) for o in b2.orbits])
            t2 = t2.drop(columns=["stable"]) if "stable" in t2.columns else t2
            t2.insert(5, "mu_uncertainty", [multiplier_uncertainty(o) for o in b2.orbits])
            if len(e.get("curve") or []) == len(t2):
                for name in e["curve"][0][1]:
                    for k in range(b2.period):
                        t2[f"{name}[{k}]"] = [float(np.atleast_1d(c[1][name])[k])
                                              for c in e["curve"]]
            parts.append(t2)
        out["branch"] = pd.concat(parts, ignore_index=True) if len(parts) > 1 else t
    ups = route.get("upos") or []
    out["orbits"] = (pd.concat([orbit_rows([o]).assign(
        point=[o.points[0].tolist()]) for o in ups], ignore_index=True) if ups
        else pd.DataFrame(columns=["period", "stability", "max_abs_mu"]))
    return out


# ---------------------------------------------------------------------------------------------------
# a study's route (duck-typed on nld.study.Study: stage, prov, save)


def run_route(study, scene, r: dict, *, overrides=(), observables=()) -> dict:
    """:func:`route_to_chaos` with a study's route settings ``r`` (param, values, start, chaotic,
    transient, max_period, optional rtol, method, max_points, guess, bisect, max_iter, cascade)
    and a progress stage."""
    study.stage(f"route to chaos: the period-1 orbit in {r['param']}"
                + (" and its doubled branches" if r.get("cascade") else ""))
    return route_to_chaos(scene, list(overrides), r["param"], r["values"], start=r["start"],
                          chaotic=r.get("chaotic"), transient=r["transient"],
                          max_period=r.get("max_period", 0), rtol=r.get("rtol", 1e-10),
                          method=r.get("method", "arclength"),
                          max_points=r.get("max_points", 60), observables=observables,
                          guess=r.get("guess", "previous"), bisect=r.get("bisect", 3),
                          max_iter=r.get("max_iter"), criticality=r.get("criticality", True),
                          locate_tol=r.get("locate_tol"), cascade=r.get("cascade"))


def save_route(study, routes: dict, table: pd.DataFrame, sde: bool = False) -> None:
    """The route's provenance records (``study.prov["route_to_chaos"]``: {sweep: record}) and
    tables: ``<stem>_route.csv`` (``table``: every sweep's rows, :func:`route_table`),
    ``<stem>_route_branch.csv`` (one row per branch point of every continued sweep, column
    ``sweep`` first) and ``<stem>_route_orbits.csv`` (the orbits found in a chaotic range)."""
    study.prov["route_to_chaos"] = {k: route_record(v, sde) for k, v in routes.items()
                                    if v is not None}
    study.save("_route.csv", table)
    parts = {"branch": [], "orbits": []}
    for sweep, route in routes.items():
        if route is None:
            continue
        for name, tab in route_tables(route).items():
            parts[name].append(tab.assign(sweep=sweep)[["sweep"] + list(tab.columns)])
    for name, frames in parts.items():
        if frames:
            study.save(f"_route_{name}.csv", pd.concat(frames, ignore_index=True))
