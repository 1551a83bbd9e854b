"""The typed result of a two-parameter continuation: a curve of codim-1 points (period doubling,
fold, Neimark-Sacker, grazing) in the plane of two parameters, its special (codim-2) points and
where and why it ends. Written by nld.analysis.codim2 (bordered test functions) and
nld.analysis.grazing_curve (grazing re-located at each value); docs/codim2.md.

Units: the parameters' own (SI).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from nld.errors import InputError

__all__ = ["BifurcationCurve", "CurveEnd", "SpecialPoint", "domain_exits", "curve_inputs", "CURVE_KINDS",
           "CURVE_END_REASONS", "SPECIAL_KINDS"]

CURVE_KINDS = ("period_doubling", "fold", "neimark_sacker", "grazing")
# why a curve ends in one direction from its start point: param2's range end reached; the
# curve turned back in param2 (a cusp, a turning point) and reached the range's other end; a
# parameter left its domain (a clearance <= 0, a friction coefficient < 0, a frequency <= 0 ...);
# the corrector failed at the shortest step; max_points used
# (a grazing curve, followed by re-locating the grazing at each param2 value: "not_found" where
# no grazing lies in the widened bracket at the shortest param2 step; nld.analysis.grazing_curve)
CURVE_END_REASONS = ("range_end", "turned_back", "domain", "newton_failure", "step_limit",
                     "not_found")
SPECIAL_KINDS = ("turning_point", "cusp", "fold_flip", "resonance_1_1", "resonance_1_2",
                 "contact_change", "leaves_domain")

@dataclass
class SpecialPoint:
    """A point where the curve's kind changes, bracketed between curve points ``between``
    (indices into the curve): ``kind`` one of :data:`SPECIAL_KINDS`; ``value1``, ``value2`` the
    linear interpolation of the sign change of its test function between the two points,
    ``uncertainty1``, ``uncertainty2`` how far the true point may be from it in each parameter
    (the interpolation's larger distance to the bracket's ends plus the points' tolerance1: the
    test function is only known to change sign somewhere between them); for ``leaves_domain``
    the last point inside and the last step; ``detail`` one line."""
    kind: str
    value1: float
    value2: float
    between: tuple
    detail: str
    uncertainty1: float = math.nan
    uncertainty2: float = math.nan

    def to_dict(self) -> dict:
        return {"kind": self.kind, "value1": self.value1, "value2": self.value2,
                "uncertainty1": self.uncertainty1, "uncertainty2": self.uncertainty2,
                "between": list(self.between), "detail": self.detail}


@dataclass
class CurveEnd:
    """Where and why the curve ends in one direction (-1: towards smaller param2, +1: larger, as
    the curve set off from its start point): reason one of :data:`CURVE_END_REASONS`."""
    direction: int
    value1: float
    value2: float
    reason: str
    detail: str

    def to_dict(self) -> dict:
        return {"direction": self.direction, "value1": self.value1, "value2": self.value2,
                "reason": self.reason, "detail": self.detail}


@dataclass
class BifurcationCurve:
    """A curve of period doublings or folds in (param1, param2).

    values1, values2: the parameters at each curve point (curve order, from the range's first
    end through the start point), SI units; orbits: the periodic orbit there (its multipliers
    and their uncertainty); condition: the bordered test function g at the orbit (0 on the
    curve); distance: |mu_c -+ 1| of the critical multiplier mu_c (the one nearest -1 for a
    doubling, +1 for a fold); tolerance1: how far in param1 the point may be from the true
    curve at its param2 value, (distance + the multiplier's uncertainty) / |d mu_c / d param1|
    along the one-parameter branch; landed: True where the point sits exactly on a requested
    param2 value (a range end or one of ``stops``); special_points, ends, message ("completed"
    when both directions reached param2's range ends), settings (with wall_s and the number of
    tangent integrations ``integrations``: periods of the orbit integrated)."""
    kind: str
    param1: object
    param2: object
    period: int
    values1: list
    values2: list
    orbits: list
    condition: list
    distance: list
    tolerance1: list
    landed: list
    special_points: list
    ends: list
    message: str
    settings: dict = field(default_factory=dict)

    @property
    def completed(self) -> bool:
        return bool(self.ends) and all(e.reason == "range_end" for e in self.ends)

    @property
    def multipliers(self) -> list:
        return [o.multipliers for o in self.orbits]

    def value1_at(self, value2: float) -> float:
        """param1 at a landed param2 value (a range end or a stop), else InputError."""
        for v1, v2, ld in zip(self.values1, self.values2, self.landed):
            if ld and v2 == value2:
                return v1
        raise InputError(f"value2 = {value2!r}: not a landed point of the curve (landed at "
                         f"{[v for v, ld in zip(self.values2, self.landed) if ld]})")

    def table(self) -> pd.DataFrame:
        rows = []
        for i, o in enumerate(self.orbits):
            r = {"value1": self.values1[i], "value2": self.values2[i],
                 "condition": self.condition[i], "distance": self.distance[i],
                 "tolerance1": self.tolerance1[i], "landed": self.landed[i],
                 "residual": o.residual, "onsets_per_period": o.onsets_per_period,
                 "min_approach_speed": o.min_approach_speed}
            for k, m in enumerate(o.multipliers):
                r[f"mu{k}_re"] = float(m.real)
                r[f"mu{k}_im"] = float(m.imag)
            rows.append(r)
        return pd.DataFrame(rows)

    def special_table(self) -> pd.DataFrame:
        return pd.DataFrame([s.to_dict() for s in self.special_points],
                            columns=["kind", "value1", "uncertainty1", "value2", "uncertainty2",
                                     "between", "detail"])


def domain_exits(curve: BifurcationCurve, label2: str) -> list:
    """A ``leaves_domain`` SpecialPoint for each end of ``curve`` where a parameter left its
    domain: at the last point inside, uncertain by the distance to its neighbour (the step the
    corrector could not take lies beyond it)."""
    out = []
    n = len(curve.values1)
    for e in curve.ends:
        if e.reason != "domain" or n == 0:
            continue
        i = 0 if e.direction < 0 else n - 1
        j = 1 if e.direction < 0 else n - 2
        j = min(max(j, 0), n - 1)
        out.append(SpecialPoint("leaves_domain", e.value1, e.value2, (min(i, j), max(i, j)),
                                f"the curve leaves the parameters' domain towards "
                                f"{'smaller' if e.direction < 0 else 'larger'} {label2}: {e.detail}",
                                abs(curve.values1[i] - curve.values1[j]),
                                abs(curve.values2[i] - curve.values2[j])))
    return out


def curve_inputs(system, bif, param, param2, range2, stops, max_points, step):
    """The checked inputs of a two-parameter continuation from ``bif`` (a located Bifurcation with
    a converged orbit), before any integration: ``(fam1, fam2, a, b, lo, hi, stops, h0)`` --
    the families of ``param`` and ``param2`` (nld.analysis.continuation.Family), range2's ends
    as given and sorted, the sorted ``stops`` strictly inside it, the first step ``h0``. Bad
    input -> InputError naming the argument, its value and what is allowed."""
    from nld.analysis.continuation import Family, check_values
    o0 = bif.orbit
    if o0 is None or not o0.converged:
        raise InputError("bif: has no converged orbit at its located value")
    fam2 = Family(system, param2)
    fam1 = Family(system, param)
    fam1.check(bif.value, f"bif.value ({fam1.label})")
    try:
        a, b = (float(x) for x in range2)
    except (TypeError, ValueError):
        raise InputError(f"range2 = {range2!r}: give (a, b)") from None
    check_values([a, b], fam2.value0, fam2.label)
    fam2.check(a, "range2:")
    fam2.check(b, "range2:")
    lo, hi = min(a, b), max(a, b)
    stops = sorted(float(s) for s in stops)
    for s in stops:
        if not lo < s < hi:
            raise InputError(f"stops: {fam2.label} = {s:g} is not inside range2 {lo:g} ... {hi:g}")
    if isinstance(max_points, bool) or not isinstance(max_points, (int, np.integer)) \
            or max_points < 2:
        raise InputError(f"max_points = {max_points!r}: must be an integer >= 2")
    h0 = 1.0 if step is None else float(step)
    if not (h0 > 0 and math.isfinite(h0)):
        raise InputError(f"step = {step!r}: must be a positive number")
    return fam1, fam2, a, b, lo, hi, stops, h0
