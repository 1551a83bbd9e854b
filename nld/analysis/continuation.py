"""Continuation of periodic orbits in one parameter, with the bifurcations located and named.

:func:`continue_orbit` follows a periodic orbit (``nld.analysis.orbits``) of a scene, a forced
flow or a map as one parameter changes, with a predictor-corrector scheme (Allgower & Georg 1990;
Kuznetsov 2004, ch. 10; Seydel 2010, ch. 4):

* natural-parameter continuation over given values (the previous orbit, extrapolated along the
  secant, as the guess; it cannot pass a fold and says so);
* pseudo-arclength continuation over a range (Keller 1977): the unknowns are the shooting points
  and the parameter, the extra equation t . (V - V_pred) = 0 with t the branch's unit tangent (the
  null vector of [G_x, G_lambda], G_lambda by a forward difference), adaptive step (x1.5 after a
  corrector of <= 3 Newton steps, /2 after a failure, retried before anything else), in BOTH
  directions from the start orbit, landing exactly on the range's ends; every end of a branch
  carries a reason (:data:`END_REASONS`, :class:`BranchEnd`) and the branch says "completed" only
  when it covered the range (docs/continuation.md).

Along the branch the Floquet multipliers (neutral memory multipliers of a permanent-contact orbit
left out) are watched for the codimension-one bifurcations of a map (Kuznetsov 2004, ch. 4):
**period doubling** (a real multiplier through -1: the test function prod(mu + 1) changes sign),
**fold** (through +1: prod(mu - 1), and the parameter turns back), **Neimark-Sacker** (a complex
pair through |mu| = 1), and the discontinuity-induced bifurcations of impacting systems
(di Bernardo et al. 2008, ch. 8; Nordmark 1991): **grazing** (a contact's normal approach speed
on the orbit goes to 0 and the number of contacts per period changes) and, generally, the
**appearance or loss of a contact** per period at a finite approach speed (``contact_change``: the
branch jumps to another orbit; a compliant contact law makes such jumps possible). Period doubling, Neimark-Sacker and grazing are
located by bisection in the parameter (a corrector solve per step) to ``locate_tol``, the stated
tolerance being the final bracket (a whole step where a Newton failed inside: then not "located")
plus the crossing multiplier's uncertainty over its slope; a fold by bisection in the arclength,
with the attractor the motion jumps to beyond it. Period doublings and Neimark-Sacker points are
called super- or subcritical where decidable (:func:`bifurcation_criticality`: the doubled branch's
side; an invariant circle's sqrt growth). :func:`period_doubled_orbit` starts the doubled branch at
a located period doubling; :func:`follow_cascade` follows a cascade by branch switching (Seydel
2010, sec. 7.4; COCO's hybrid po toolbox, Dankowicz & Schilder 2013) and gives the interval ratios
(Feigenbaum's delta the smooth reference).

Parameters: for a scene a scene key as ``nld --set`` takes it (``joints.B.clearance``,
``driver.speed``); the kernel is the same at every value (parameters are kernel arguments; a
value that changes the scene's structure is refused). For another system the index of p or a
name of ``system.param_names``. Units: the parameter's SI unit.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from nld.errors import InputError, SceneError, SolveError
from nld.analysis.orbits import (PeriodicOrbit, Shooting, finite, check_period, map_source,
                                 periodic_orbit, section_points)
from nld.systems.derived import NumbaMap, PoincareMap, StroboscopicMap, as_map

__all__ = ["Family", "Bifurcation", "Branch", "BranchEnd", "Cascade", "continue_orbit",
           "period_doubled_orbit", "follow_cascade", "bifurcation_criticality", "orbit_stability",
           "KINDS", "END_REASONS", "CRITICALITIES", "FEIGENBAUM_DELTA"]

ARCLENGTH_PARAM_UNIT = 0.02       # of the range: the parameter's weight in the arclength
KINDS = ("period_doubling", "fold", "neimark_sacker", "grazing", "contact_change")
# why a branch ends in one direction (BranchEnd.reason): the requested range's end reached (or
# the start value is that end); a fold the continuation cannot pass (natural continuation) with
# the attractor the motion jumps to; a grazing / a contact change where no step crosses; the
# corrector failing at the shortest step (with its residual); the number of points exhausted
END_REASONS = ("range_end", "fold", "grazing", "contact_change", "newton_failure", "step_limit")
CRITICALITIES = ("supercritical", "subcritical", "undetermined")


# ---------------------------------------------------------------------------------------------------
# a system as a function of one parameter


class Family:
    """``system`` with one parameter varied: ``at(value)`` is the system at that value (cached).

    The parameter is addressed by the System interface alone (``system.parameter(param)``,
    ``system.with_parameter(param, value)``, nld.systems.base): for a scene a scene key
    (``joints.B.clearance``: the same kernel at every value), else a name of ``param_names`` or an
    index of p."""

    def __init__(self, system, param):
        self.base = system
        self.param = param
        self._cache: dict = {}
        self.kind = "scene" if system.is_scene else "p"
        if system.is_scene and not isinstance(param, str):
            raise InputError(f"param = {param!r}: for a scene give a scene key, e.g. "
                             f"joints.B.clearance or driver.speed")
        self.value0 = system.parameter(param)          # InputError for a key it does not have
        names = list(system.param_names)
        self.label = param if isinstance(param, str) or not names else names[int(param)]
        if not isinstance(param, str) and not names:
            self.label = f"p[{int(param)}]"

    def check(self, value: float, what: str = "value") -> float:
        """value as a float in the parameter's domain, else InputError naming the parameter, the
        value and the domain's rule (a scene's own check: a friction coefficient >= 0, a
        clearance > 0 ...; a forcing frequency > 0), before any integration."""
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise InputError(f"{what} = {value!r}: not a number") from None
        if not math.isfinite(value):
            raise InputError(f"{what} = {value!r}: must be finite")
        try:
            from nld.model.scene import NO_VALUE, resolve_scene, scene_value
            keys = [k.strip() for k in str(self.param).split(",")]    # several: set together
            if self.kind == "scene" and all(scene_value(self.base.scene, k) is not NO_VALUE
                                            for k in keys):
                # the scene's own domain check only (cheap: no system is built for it; a value
                # that changes the structure is refused by at())
                resolve_scene(self.base.scene, [f"{k}={value!r}" for k in keys])
            else:
                self.at(value)                         # with_parameter: a forcing frequency > 0
        except (InputError, SceneError) as e:
            rule = str(e)
            if self.kind != "scene":                   # with_parameter's message names the key
                rule = rule.split(": ", 1)[-1]
            raise InputError(f"{what} {self.param} = {value:g} is outside the parameter's "
                             f"domain: {rule}") from None
        return value

    def owns(self, orbit: PeriodicOrbit) -> bool:
        """Whether ``orbit`` is an orbit of this family's system (same equations, same states):
        a scene's kernel, a flow's right-hand side or a map's function, and the state names."""
        b = self.base
        if isinstance(b, (NumbaMap, PoincareMap, StroboscopicMap)):
            b = map_source(b)
        src = map_source(orbit.map)
        if b.is_scene or src.is_scene:
            return b.is_scene and src.is_scene and b.kernel.key == src.kernel.key
        if b.is_map != src.is_map or (b.f is not src.f if b.is_map else b.rhs is not src.rhs):
            return False
        if b.builtin_code != src.builtin_code:
            return False
        names = list(b.state_names)
        return not names or list(orbit.state_names)[:len(names)] == names

    def at(self, value: float):
        value = float(value)
        if value in self._cache:
            return self._cache[value]
        s = self.base.with_parameter(self.param, value)
        if len(self._cache) > 64:
            self._cache.clear()
        self._cache[value] = s
        return s

    def map_at(self, value, like):
        """The derived map of ``like``'s kind at value (a Poincaré map keeps its section)."""
        s = self.at(value)
        if isinstance(like, NumbaMap):
            return NumbaMap(s)
        if isinstance(like, PoincareMap):
            return PoincareMap(s, like.normal, like.offset, like.direction, dt=like.dt,
                               t_min=like.t_min, t_max=like.t_max, rtol=like.rtol)
        return StroboscopicMap(s, like.periods, like.rtol)


# ---------------------------------------------------------------------------------------------------
# results


def orbit_stability(o: PeriodicOrbit) -> str:
    """"stable", "unstable" or "neutral" for a branch row: ``PeriodicOrbit.stability``
    (nld.analysis.orbits.multiplier_stability: the deciding multipliers, a continuum's neutral
    memory multiplier left out, against 1 and their uncertainty), an unconverged orbit "neutral":
    no row calls an orbit stable whose largest multiplier is within its uncertainty of the unit
    circle."""
    s = o.stability
    return "neutral" if s == "unconverged" else s


def _uncertainty(o: PeriodicOrbit) -> float:
    u = o.multiplier_uncertainty
    return float(u) if math.isfinite(u) else 0.0


@dataclass
class Bifurcation:
    """A bifurcation found between two branch points.

    kind: one of KINDS; value: the parameter value (SI unit of the parameter), within
    ``tolerance`` (the width of the final bracket: honest, also where the bisection stopped
    early); ``located`` True when that bracket reached the requested ``locate_tol`` (else the
    value is only bracketed and ``detail`` says why); multiplier: the critical multiplier
    (complex) or None (grazing); orbit: the orbit at the located value (the branch's side before
    it); criticality: "supercritical", "subcritical" or "undetermined" (period doubling: the side
    of the bifurcation where the doubled orbit exists; Neimark-Sacker: an invariant circle
    growing as sqrt(distance) on the unstable side; :func:`follow_cascade`, docs/continuation.md);
    jump: for a fold, the attractor the motion jumps to beyond it (one line); detail: one line
    for humans."""
    kind: str
    value: float
    tolerance: float
    multiplier: complex | None
    orbit: PeriodicOrbit | None
    detail: str
    between: tuple = ()
    located: bool = True
    criticality: str = "undetermined"
    jump: str = ""
    new_orbit: PeriodicOrbit | None = field(default=None, repr=False)
    new_value: float | None = None

    def to_dict(self) -> dict:
        m = self.multiplier
        return {"kind": self.kind, "value": self.value, "tolerance": self.tolerance,
                "located": bool(self.located),
                "multiplier_re": None if m is None else float(np.real(m)),
                "multiplier_im": None if m is None else float(np.imag(m)),
                "criticality": self.criticality, "jump": self.jump,
                "detail": self.detail}


@dataclass
class BranchEnd:
    """Where and why a branch ends in one direction from its start orbit: ``direction`` -1 (to
    smaller parameter values) or +1, ``value`` the last branch point's parameter value,
    ``reason`` one of :data:`END_REASONS`, ``detail`` one line (the residual of a failed
    corrector, the jump target at a fold, the domain ...)."""
    direction: int
    value: float
    reason: str
    detail: str

    def to_dict(self) -> dict:
        return {"direction": int(self.direction), "value": float(self.value),
                "reason": self.reason, "detail": self.detail}


@dataclass
class Branch:
    """A continued branch: ``values`` and ``orbits`` in branch order (failed points are not
    included), the located ``bifurcations``, ``ends`` (one :class:`BranchEnd` per direction from
    the start orbit) and ``message`` ("completed" only when the branch reached both ends of what
    was asked; else what it covered and why it ended)."""
    param: object
    period: int
    values: list
    orbits: list
    bifurcations: list
    message: str
    settings: dict = field(default_factory=dict)
    ends: list = field(default_factory=list)

    @property
    def completed(self) -> bool:
        """Every direction ended at the requested range's end."""
        return bool(self.ends) and all(e.reason == "range_end" for e in self.ends)

    def table(self) -> pd.DataFrame:
        """One row per branch point: value, converged, residual, stability ("stable",
        "unstable" or "neutral": :func:`orbit_stability`; column ``stable``), max |mu|, the
        largest |mu| that decides stability (a continuum's neutral memory multiplier left out:
        ``max_abs_deciding``) and its uncertainty, the multipliers (re, im columns by decreasing modulus), onsets per period,
        smallest approach speed, continuum, and the orbit's first section point (one column per
        state)."""
        rows = []
        for v, o in zip(self.values, self.orbits):
            r = {"value": v, "period": o.period, "converged": o.converged, "residual": o.residual,
                 "stable": orbit_stability(o),
                 "max_abs_multiplier": o.max_abs_multiplier,
                 "max_abs_deciding": (float(np.max(np.abs(_critical(o))))
                                      if _critical(o).size else math.nan),
                 "multiplier_uncertainty": _uncertainty(o),
                 "onsets_per_period": o.onsets_per_period,
                 "min_approach_speed": o.min_approach_speed, "continuum": o.continuum}
            for i, m in enumerate(o.multipliers):
                r[f"mu{i}_re"] = float(m.real)
                r[f"mu{i}_im"] = float(m.imag)
            for k in range(o.period):
                for name, x in zip(o.state_names, o.points[k]):
                    r[f"{name}[{k}]" if o.period > 1 else name] = float(x)
            rows.append(r)
        return pd.DataFrame(rows)

    def bifurcation_table(self) -> pd.DataFrame:
        return pd.DataFrame([b.to_dict() for b in self.bifurcations],
                            columns=["kind", "value", "tolerance", "located", "multiplier_re",
                                     "multiplier_im", "criticality", "jump", "detail"])

    def ends_table(self) -> pd.DataFrame:
        return pd.DataFrame([e.to_dict() for e in self.ends],
                            columns=["direction", "value", "reason", "detail"])


# ---------------------------------------------------------------------------------------------------
# test functions


def _critical(o: PeriodicOrbit) -> np.ndarray:
    """The multipliers that decide stability: a continuum's neutral memory multipliers dropped
    (``PeriodicOrbit.deciding_multipliers``)."""
    return o.deciding_multipliers


def _tests(o: PeriodicOrbit) -> dict:
    mu = _critical(o)
    cplx = mu[np.abs(mu.imag) > 1e-9 * np.maximum(1.0, np.abs(mu))]
    return {"pd": float(np.real(np.prod(mu + 1.0))) if mu.size else 1.0,
            "fold": float(np.real(np.prod(mu - 1.0))) if mu.size else 1.0,
            "ns": float(np.real(np.prod(np.abs(cplx[cplx.imag > 0]) ** 2 - 1.0)))
            if cplx.size else None,
            "contacts": int(o.onsets_per_period)}


# ---------------------------------------------------------------------------------------------------
# correctors


def _orbit_at(fam, value, like_map, orbit_guess: PeriodicOrbit, X=None, rtol=None, tol=None,
              max_iter=8):
    """The period-p orbit at ``value`` from a guess (the orbit's points, or X)."""
    m = fam.map_at(value, like_map)
    pts = orbit_guess.points if X is None else X
    return periodic_orbit(m, orbit_guess.period, np.array(pts), z=orbit_guess.z[0], tol=tol,
                          check=True, max_iter=max_iter,
                          shooting=orbit_guess.settings.get("shooting", "auto"))


def _arclength_corrector(fam, like_map, o_prev: PeriodicOrbit, V_pred, t_vec, lam_scale, frozen,
                         tol, max_iter=8, info=None):
    """Newton on [G(U, lam); t . (V - V_pred)] = 0 (V = (U, lam / lam_scale), U the scaled
    shooting points). Returns (orbit, value, iterations) or None; on None, ``info`` (a dict)
    gets the last residual ("residual") and why ("why")."""
    info = {} if info is None else info
    info["residual"] = math.nan
    p = o_prev.period
    multiple = o_prev.settings.get("shooting") == "multiple"
    V = V_pred.copy()
    Z = [np.array(z) for z in (o_prev.z if multiple else o_prev.z[:1])]
    hist = []
    for it in range(1, max_iter + 1):
        lam = V[-1] * lam_scale
        try:
            m = fam.map_at(lam, like_map)
        except (InputError, SceneError) as e:   # the Newton left the parameter's domain (mu < 0)
            info["why"] = f"the corrector left the parameter's domain ({e})"
            return None
        sh = Shooting(m, p, multiple)
        npts = p if multiple else 1
        X = V[:-1].reshape(npts, m.n) * sh.s
        try:
            r, J, steps = sh.evaluate(X, Z, True)
            dl = PARAM_FD_STEP * lam_scale
            m2 = fam.map_at(lam + dl, like_map)
            Gl = _g_lambda(sh, Shooting(m2, p, multiple), X, Z, dl, lam_scale)
        except (SolveError, InputError, SceneError) as e:
            info["why"] = f"the integration failed ({e})"
            return None
        if not (finite(r) and finite(J) and finite(Gl)):
            info["why"] = "the map is not finite at the corrector's iterate"
            return None
        J = J.copy()
        if frozen.size:
            J[:, frozen] = 0.0
        res = float(np.max(np.abs(r)))
        info["residual"] = res
        hist.append(res)
        if len(hist) >= 3 and res > tol and (res > 0.9 * hist[-3] or res > 10.0 * hist[0]):
            # no progress over two iterations, or diverging: a shorter step will do better than
            # more iterations here (each costs an integration with the tangent)
            info["why"] = (f"the corrector stalls (residuals {', '.join(f'{x:.2g}' for x in hist)})")
            return None
        A = np.vstack([np.column_stack([J, Gl]), t_vec[None, :]])
        F = np.concatenate([r, [float(t_vec @ (V - V_pred))]])
        if res <= tol and abs(F[-1]) <= 1e-8:
            o = periodic_orbit(m, p, X, z=Z[0], tol=tol, check=True, max_iter=3,
                               shooting="multiple" if multiple else "single")
            if o.converged:
                return o, lam, it
            info["why"] = f"the polished orbit did not converge ({o.message})"
            return None
        try:
            dV = np.linalg.lstsq(A, -F, rcond=1e-12)[0]
        except np.linalg.LinAlgError:
            info["why"] = "the corrector's matrix is singular"
            return None
        if frozen.size:
            dV[frozen] = 0.0
        V = V + dV
        if multiple:
            Z = [steps[(i - 1) % p].z for i in range(p)]
    info["why"] = f"no convergence in {max_iter} corrector iterations"
    return None


def _g_lambda(sh, sh2, X, Z, dl, lam_scale):
    """G_lambda (per lambda unit) by a forward difference of two residuals evaluated ALIKE
    (both without the tangent integration): a map integrated with its tangent and one integrated
    without it differ by more than rtol (3.6e-5 scaled on slider_crank_olyaei's impacting orbit
    at rtol 1e-10, where the step sequences differ), which a difference of one of each divides by
    the small dl and turns into a wrong G_lambda."""
    r0, _, _ = sh.evaluate(X, [np.array(z) for z in Z], False)
    r2, _, _ = sh2.evaluate(X, [np.array(z) for z in Z], False)
    return (r2 - r0) / dl * lam_scale


def _unknowns(o: PeriodicOrbit, m):
    """The scaled shooting unknowns of an orbit (all p points for multiple shooting)."""
    s = np.asarray(m.scales, dtype=float)
    pts = o.points if o.settings.get("shooting") == "multiple" else o.points[:1]
    return (np.asarray(pts) / s).ravel()


def _frozen(o: PeriodicOrbit, m) -> np.ndarray:
    """Unknowns held fixed: the memory entries of a continuum orbit (a history, not a state the
    branch can move)."""
    if not o.continuum or m.memory.size == 0:
        return np.zeros(0, dtype=np.int64)
    npts = o.period if o.settings.get("shooting") == "multiple" else 1
    return np.array([k * m.n + m.n_y + j for k in range(npts) for j in range(m.memory.size)],
                    dtype=np.int64)


def _tangent(fam, like_map, o: PeriodicOrbit, value, lam_scale, prev_t=None):
    """The unit tangent of the branch at (o, value): null vector of [G_U, G_lam]."""
    m = fam.map_at(value, like_map)
    p = o.period
    multiple = o.settings.get("shooting") == "multiple"
    sh = Shooting(m, p, multiple)
    npts = p if multiple else 1
    X = o.points[:npts]
    Z = [np.array(z) for z in o.z[:npts]]
    r, J, _ = sh.evaluate(X, Z, True)
    dl = PARAM_FD_STEP * lam_scale
    Gl = _g_lambda(sh, Shooting(fam.map_at(value + dl, like_map), p, multiple), X, Z, dl,
                   lam_scale)
    fz = _frozen(o, m)
    J = J.copy()
    if fz.size:
        J[:, fz] = 0.0
    A = np.column_stack([J, Gl])
    if fz.size:
        keep = np.setdiff1d(np.arange(A.shape[1]), fz)
        _, _, vt = np.linalg.svd(A[:, keep])
        t = np.zeros(A.shape[1])
        t[keep] = vt[-1]
    else:
        _, _, vt = np.linalg.svd(A)
        t = vt[-1]
    t /= np.linalg.norm(t)
    if prev_t is not None and float(t @ prev_t) < 0:
        t = -t
    return t


# ---------------------------------------------------------------------------------------------------
# the continuation


def check_values(values, value0, param, *, contain: bool = True):
    v = np.array(values, dtype=float).ravel()
    if v.size < 2 or not np.all(np.isfinite(v)):
        raise InputError(f"values = {values!r}: give at least two finite values of {param}")
    if np.any(np.diff(v) == 0):
        raise InputError(f"values: {param} repeats a value; give distinct values")
    if not contain:
        return v
    lo, hi = min(v[0], v[-1]), max(v[0], v[-1])
    span = max(hi - lo, abs(value0) * 1e-12)
    if not (lo - 1e-9 * span <= value0 <= hi + 1e-9 * span):
        raise InputError(f"values {v[0]:g} ... {v[-1]:g} of {param} do not contain the start "
                         f"orbit's value {value0:g}")
    return v


def _check_owner(fam, orbit: PeriodicOrbit, system, param, tol):
    """The orbit must be an orbit of ``system`` (same equations) at the system's value of the
    parameter: InputError saying which, before any continuation step."""
    sys_name = system.name
    if not fam.owns(orbit) or orbit.points.shape[1] != fam.map_at(fam.value0, orbit.map).n:
        raise InputError(f"orbit: an orbit of {orbit.system_name} ({', '.join(orbit.state_names)}),"
                         f" not of {sys_name}: continue an orbit on the system it belongs to")
    m = fam.map_at(fam.value0, orbit.map)
    multiple = orbit.settings.get("shooting") == "multiple"
    npts = orbit.period if multiple else 1
    try:
        r, _, _ = Shooting(m, orbit.period, multiple).evaluate(
            orbit.points[:npts], [np.array(z) for z in orbit.z[:npts]], True)
        res = float(np.max(np.abs(r)))
    except SolveError as e:
        res, why = math.inf, f" ({e})"
    else:
        why = ""
    if not res <= 100.0 * max(tol, orbit.residual):
        raise InputError(f"orbit: not a period-{orbit.period} orbit of {sys_name} at {param} = "
                         f"{fam.value0:g} (residual {res:.3g}{why}): give the system at the "
                         f"orbit's own parameter value")


def _range_pair(range) -> tuple[float, float]:
    """(a, b) of a ``range`` argument, or an InputError naming it."""
    try:
        a, b = (float(x) for x in range)
    except (TypeError, ValueError):
        raise InputError(f"range = {range!r}: give (a, b)") from None
    return a, b


def continue_orbit(system, orbit: PeriodicOrbit, param, values=None, *, range=None,
                   method: str | None = None, step: float | None = None, max_points: int = 200,
                   tol: float | None = None, locate: bool = True, locate_tol: float | None = None,
                   criticality: bool = True, progress=None, on_point=None) -> Branch:
    """Follow ``orbit`` of ``system`` (the system at the orbit's parameter value) in ``param``.

    values: parameter values for natural continuation (must contain the start value; the
            branch is followed from the start outwards to both ends given), or
    range:  (a, b) for pseudo-arclength continuation (Keller 1977; Allgower & Georg 1990) from
            the start value in BOTH directions, to a and to b (a range end is landed on
            exactly); first step ``step`` (default |b - a| / 50), adaptive (x1.5 after an easy
            corrector, up to max(4 step, |b - a| / 25)); a failed step is retried at half the
            length down to step / 1000, then across a non-smooth point by a natural step;
            at most ``max_points`` points per direction.
    method: "natural" or "arclength" (default: natural with values, arclength with range).
    locate: locate the bifurcations (module docstring) to ``locate_tol`` (default 1e-4 of the
            parameter's step); a value whose bracket did not shrink to it says so
            (``Bifurcation.located`` False, ``tolerance`` the real width).
    criticality: decide super-/subcritical for period doublings and Neimark-Sacker points
            (:func:`bifurcation_criticality`).
    on_point: optional callable (value, orbit) after each branch point (a CLI writes it).
    Every value asked for is checked against the parameter's domain before any integration.
    Returns a :class:`Branch`: the orbits carry their multipliers and contact statistics;
    ``ends`` says for each direction where and why the branch ended (:data:`END_REASONS`), and
    ``message`` is "completed" only when both directions reached their end of the range.
    """
    if not isinstance(orbit, PeriodicOrbit):
        raise InputError("orbit: give a PeriodicOrbit (from nld.analysis.orbits.periodic_orbit)")
    if not orbit.converged:
        raise InputError(f"orbit: the start orbit did not converge ({orbit.message})")
    fam = Family(system, param)
    like = orbit.map
    v0 = fam.value0
    if values is None and range is None:
        raise InputError("give values (natural continuation) or range=(a, b) (pseudo-arclength)")
    method = method or ("natural" if values is not None else "arclength")
    if method not in ("natural", "arclength"):
        raise InputError(f"method = {method!r}: must be 'natural' or 'arclength'")
    if isinstance(max_points, bool) or not isinstance(max_points, (int, np.integer)) or max_points < 2:
        raise InputError(f"max_points = {max_points!r}: must be an integer >= 2")
    tol = orbit.tolerance if tol is None else float(tol)
    t_start = time.perf_counter()
    settings = {"param": param, "method": method, "period": orbit.period, "tol": tol,
                "rtol": orbit.settings.get("rtol"), "map": orbit.settings.get("map")}
    if method == "natural":
        if values is None:
            raise InputError("method 'natural' needs values")
        v = check_values(values, v0, param)
        for x in (v.min(), v.max()):
            fam.check(x, "values:")
        _check_owner(fam, orbit, system, param, tol)
        settings["values"] = v.tolist()
        vals, orbs, ends = _natural(fam, like, orbit, v0, v, tol, progress, on_point)
        dstep = float(np.min(np.abs(np.diff(v))))
        crossed = []
    else:
        if range is None:
            rng = check_values(values, v0, param)
            a, b = float(rng[0]), float(rng[-1])
        else:
            a, b = _range_pair(range)
            check_values([a, b], v0, param)
        fam.check(a, "range:")
        fam.check(b, "range:")
        settings["range"] = [a, b]
        dstep = float(step) if step is not None else abs(b - a) / 50.0
        if not (dstep > 0 and math.isfinite(dstep)):
            raise InputError(f"step = {step!r}: must be a positive parameter step")
        _check_owner(fam, orbit, system, param, tol)
        settings["step"] = dstep
        vals, orbs, ends, crossed = _arclength(fam, like, orbit, v0, a, b, dstep,
                                               int(max_points), tol, progress, on_point)
    settings["lam_scale"] = _lam_scale(settings)
    bifs = []
    ltol = locate_tol if locate_tol is not None else 1e-4 * dstep
    for i in np.arange(len(orbs) - 1):
        bifs += _detect(fam, like, vals[i], orbs[i], vals[i + 1], orbs[i + 1], tol, locate,
                        ltol, step=dstep, lam_scale=settings["lam_scale"])
    if locate and criticality:
        for bf in bifs:
            bf.criticality, why = bifurcation_criticality(fam, like, bf, dstep)
            if why:
                bf.detail += f"; {bf.criticality}: {why}"
    for e in ends:
        # an arclength direction that turned back at a fold: the fold's jump target in its end
        folds = [bf for bf in bifs if bf.kind == "fold" and bf.jump]
        if e.reason == "fold" and folds and "jump" not in e.detail:
            f = max(folds, key=lambda bf: bf.value * e.direction)
            e.detail += f"; the fold at {fam.label} = {f.value:.6g}: {f.jump}"
    settings["wall_s"] = time.perf_counter() - t_start
    msg = _message(fam, ends, vals)
    if crossed:
        msg += ("; crossed by a natural step where the arclength corrector failed (a non-smooth "
                "point of the branch): " + ", ".join(crossed))
    return Branch(param, orbit.period, vals, orbs, bifs, msg, settings, ends)


def _lam_scale(settings) -> float:
    if "range" in settings:
        a, b = settings["range"]
        return max(abs(b - a) * ARCLENGTH_PARAM_UNIT, 1e-300)
    v = settings["values"]
    return max(abs(v[-1] - v[0]) * ARCLENGTH_PARAM_UNIT, 1e-300)


def _message(fam, ends, vals) -> str:
    """"completed" when every direction reached its end of the range; else where each direction
    ended and why (never "completed" for a branch that did not cover what was asked)."""
    if ends and all(e.reason == "range_end" for e in ends):
        return "completed"
    parts = []
    for e in ends:
        way = "towards larger values" if e.direction > 0 else "towards smaller values"
        parts.append(f"{way}: {e.reason.replace('_', ' ')} at {fam.label} = {e.value:g} "
                     f"({e.detail})")
    lo, hi = (min(vals), max(vals)) if vals else (math.nan, math.nan)
    return f"covered {fam.label} = {lo:g} ... {hi:g} only; " + "; ".join(parts)


def _end_after_failure(fam, like, o_last, o_first, lam, direction, tol, detail,
                       offset: float = 0.0, probe: bool = False) -> BranchEnd:
    """Why a branch ends at (o_last, lam) where no step succeeded: a fold (a multiplier at +1,
    with the jump target), a grazing (the approach speed at a contact fell towards zero), else a
    Newton failure (detail: the residual)."""
    mu = _critical(o_last)
    near1 = mu[int(np.argmin(np.abs(mu - 1.0)))] if mu.size else None
    if probe and offset > 0:
        # natural continuation: a short pseudo-arclength run from the last orbit towards the
        # failed value tells a fold (the branch turns back before it) from a failed Newton
        x = lam + direction * offset
        try:
            vals, _, ends_p, _ = _arclength(fam, like, o_last, lam, lam, x, offset / 4, 12, tol,
                                            None, None)
        except (SolveError, InputError, SceneError, np.linalg.LinAlgError):
            vals, ends_p = [], []
        far = [e for e in ends_p if e.direction == direction]
        if vals and far and not (far[0].reason == "range_end" and abs(far[0].value - x) <=
                                 1e-9 * max(1.0, abs(x))):
            turn = max(vals) if direction > 0 else min(vals)
            if (turn - lam) * direction > 0 and (x - turn) * direction > 0 and \
                    (vals[-1] - turn) * direction < 0 or far[0].reason == "fold":
                jt = _jump_target(fam, like, o_last, lam, direction, tol, offset)
                return BranchEnd(direction, lam, "fold",
                                 f"the branch turns back at {fam.label} = {turn:.6g} (a fold; "
                                 f"pseudo-arclength continuation passes it); {jt}")
    if near1 is not None and abs(near1 - 1.0) < 2 * SMOOTH_CROSSING:
        jt = _jump_target(fam, like, o_last, lam, direction, tol, offset)
        return BranchEnd(direction, lam, "fold",
                         f"a multiplier at {near1.real:.4g} (a fold: no orbit of the branch "
                         f"beyond); {jt}")
    if (o_last.onsets_per_period > 0 and o_first.onsets_per_period > 0
            and math.isfinite(o_first.min_approach_speed) and o_first.min_approach_speed > 0
            and o_last.min_approach_speed <= 0.2 * o_first.min_approach_speed):
        return BranchEnd(direction, lam, "grazing",
                         f"the smallest approach speed fell to {o_last.min_approach_speed:.3g} "
                         f"(from {o_first.min_approach_speed:.3g}): a contact about to be lost; "
                         + detail)
    return BranchEnd(direction, lam, "newton_failure", detail)


def _natural(fam, like, orbit, v0, v, tol, progress, on_point):
    """Natural continuation outwards from v0 over the values (both directions). Returns
    (values, orbits, ends)."""
    eps = 1e-12 * max(1.0, abs(v0))
    up = sorted(x for x in v if x > v0 + eps)                   # outwards from v0, both ways
    down = sorted((x for x in v if x < v0 - eps), reverse=True)
    res = {v0: orbit}
    ends = []
    done = 0
    for direction, seq in ((-1, down), (1, up)):
        prev = [(v0, orbit)]
        end = None
        if not seq:
            end = BranchEnd(direction, v0, "range_end", "the start value is the values' end")
        for x in seq:
            o_last = prev[-1][1]
            X = None
            if len(prev) >= 2:          # secant predictor of the shooting points
                (va, oa), (vb, ob) = prev[-2], prev[-1]
                if oa.points.shape == ob.points.shape:
                    X = ob.points + (ob.points - oa.points) * (x - vb) / (vb - va)
            try:
                o = _orbit_at(fam, x, like, o_last, X, tol=tol)
                if not o.converged and X is not None:
                    o = _orbit_at(fam, x, like, o_last, None, tol=tol)
            except SolveError as e:
                end = _end_after_failure(fam, like, o_last, orbit, prev[-1][0], direction, tol,
                                         f"the integration failed at {fam.label} = {x:g} ({e})",
                                         abs(x - prev[-1][0]), True)
                break
            done += 1
            if progress is not None:
                progress(done, len(up) + len(down), x)
            if not o.converged:
                end = _end_after_failure(
                    fam, like, o_last, orbit, prev[-1][0], direction, tol,
                    f"no orbit at the next value {x:g}: Newton's residual {o.residual:.3g} "
                    f"(tolerance {o.tolerance:.3g}; {o.message}); pseudo-arclength "
                    f"continuation passes folds", abs(x - prev[-1][0]), True)
                break
            res[x] = o
            prev.append((x, o))
            if on_point is not None:
                on_point(x, o)
        if end is None:
            end = BranchEnd(direction, prev[-1][0], "range_end", "the last value asked for")
        ends.append(end)
    keys = sorted(res) if v[0] <= v[-1] else sorted(res, reverse=True)
    return keys, [res[k] for k in keys], ends


def _land(fam, like, o, lam, V, t, lam_scale, bound, tol):
    """The orbit exactly at the range's end ``bound`` (a fixed-value Newton from the predictor
    that reaches it), or None."""
    if abs(t[-1]) < 1e-14:
        return None
    h = (bound / lam_scale - V[-1]) / t[-1]
    Vp = V + h * t
    m = fam.map_at(lam, like)
    npts = o.period if o.settings.get("shooting") == "multiple" else 1
    X = Vp[:-1].reshape(npts, m.n) * np.asarray(m.scales, dtype=float)
    try:
        on = _orbit_at(fam, bound, like, o, X if npts > 1 else X[0], tol=tol)
        if not on.converged:
            on = _orbit_at(fam, bound, like, o, None, tol=tol)
    except (SolveError, InputError, SceneError):
        return None
    return (on, bound, int(on.iterations)) if on.converged else None


def _arclength(fam, like, orbit, v0, a, b, ds, max_points, tol, progress, on_point):
    """Pseudo-arclength continuation from v0 in both directions (towards a and towards b).
    Returns (values, orbits, ends, crossed)."""
    # the parameter's unit in the arclength: 1/50 of the range, so that a default step (range/50)
    # is one unit of arclength when the branch is flat, as a clearance-sized change of the state
    # is; with the whole range as the unit a branch steep in the scaled state crawled in the
    # parameter (1e-7 per step on slider_crank_olyaei)
    lam_scale = max(abs(b - a) * ARCLENGTH_PARAM_UNIT, 1e-300)
    lo, hi = min(a, b), max(a, b)
    eps = 1e-12 * max(abs(lo), abs(hi), lam_scale)
    h_max = max(4 * ds, abs(b - a) / 25.0) / lam_scale
    h_min = 1e-3 * ds / lam_scale
    segments = {}
    ends = []
    crossed = []            # non-smooth points crossed by a natural step
    m0 = fam.map_at(v0, like)
    t0 = _tangent(fam, like, orbit, v0, lam_scale)
    for direction in (-1, 1):
        target = lo if direction < 0 else hi
        pts = []
        segments[direction] = pts
        if abs(target - v0) <= eps:
            ends.append(BranchEnd(direction, v0, "range_end", "the start value is the range's end"))
            continue
        t = t0 if t0[-1] * direction > 0 else -t0
        o, lam = orbit, v0
        h = ds / lam_scale
        end = None
        while end is None:
            if len(pts) + 1 >= max_points:
                end = BranchEnd(direction, lam, "step_limit",
                                f"{max_points} points per direction used before reaching "
                                f"{target:g}")
                break
            U = _unknowns(o, fam.map_at(lam, like))
            V = np.concatenate([U, [lam / lam_scale]])
            ok = None
            landed = None
            info = {}
            while h >= h_min:
                V_pred = V + h * t
                lam_pred = V_pred[-1] * lam_scale
                bound = hi if t[-1] > 0 else lo
                if (lam_pred - bound) * math.copysign(1.0, t[-1]) > 0:
                    # the predictor leaves the range: land on its end at a fixed value
                    ok = _land(fam, like, o, lam, V, t, lam_scale, bound, tol)
                    if ok is not None:
                        landed = bound
                        break
                else:
                    ok = _arclength_corrector(fam, like, o, V_pred, t, lam_scale,
                                              _frozen(o, m0), tol, info=info)
                    if ok is not None and not (lo - eps <= ok[1] <= hi + eps):
                        ok = None               # corrected outside the range: shorter
                    if ok is not None:
                        break
                h *= 0.5
            if ok is None:
                # a non-smooth point (a contact gained or lost, grazing): the branch has a kink
                # there and no tangent; step across it at a fixed parameter value instead (what
                # natural continuation does), then resume the arclength from the far side
                way = 1.0 if t[-1] >= 0 else -1.0
                room = (hi - lam) if way > 0 else (lam - lo)
                ok = _natural_step(fam, like, o, lam, way, min(ds, room), tol) if room > eps \
                    else None
                if ok is None:
                    res = info.get("residual", math.nan)
                    why = info.get("why", "")
                    end = _end_after_failure(
                        fam, like, o, orbit, lam, direction, tol,
                        f"the corrector failed at {fam.label} = {lam:g}: residual {res:.3g} "
                        f"(tolerance {tol:.3g}{'; ' + why if why else ''}) at steps down to "
                        f"{h_min * lam_scale:.3g}, and natural steps of {min(ds, room):.3g} ... "
                        f"{min(ds, room) * NATURAL_STEP_MIN:.3g} failed too",
                        NATURAL_STEP_MIN * ds)
                    break
                crossed.append(f"{fam.label} = {lam:g} -> {ok[1]:g}")
                if abs(ok[1] - (hi if way > 0 else lo)) <= eps:
                    landed = ok[1]
                h = ds / lam_scale
            o_new, lam_new, its = ok
            pts.append((lam_new, o_new))
            if on_point is not None:
                on_point(lam_new, o_new)
            if progress is not None:
                progress(len(pts), max_points, lam_new)
            if landed is not None:
                detail = ("the range's end" if abs(landed - target) <= eps else
                          f"the range's other end, reached after the branch turned back at a "
                          f"fold (it never reached {target:g})")
                end = BranchEnd(direction, landed, "range_end" if abs(landed - target) <= eps
                                else "fold", detail)
                break
            t_new = _tangent(fam, like, o_new, lam_new, lam_scale, t)
            o, lam, t = o_new, lam_new, t_new
            if its <= 3:
                h = min(1.5 * h, h_max)
        ends.append(end)
    # branch order: from the a side through v0 to the b side
    seg_lo, seg_hi = segments.get(-1, []), segments.get(1, [])
    if a > b:
        seg_lo, seg_hi = seg_hi, seg_lo
    ordered = list(reversed(seg_lo)) + [(v0, orbit)] + seg_hi
    return [x for x, _ in ordered], [o for _, o in ordered], ends, crossed


# G_lambda (the residual's derivative in the parameter) is a forward difference over 1/100 of
# lambda's unit (1/5000 of the requested range): the residual carries the integration error
# (~rtol), and the former step of 1e-6 lambda let that noise swing G_lambda by orders of magnitude
# and change its sign between Newton iterations (slider_crank_olyaei in permanent contact at
# mu = 0.1: the corrector never converged); with this step it converges in 3 iterations
PARAM_FD_STEP = 1e-2
SMOOTH_CROSSING = 0.05      # a fold / period doubling whose multiplier stays this far from +-1
                            # on both sides of its bracket is called non-smooth (a jump)
NATURAL_STEP_MIN = 1e-2     # the shortest natural step tried across a non-smooth point, x ds


def _natural_step(fam, like, o, lam, direction, ds, tol):
    """(orbit, value, iterations) at lam + direction * d from the orbit o at lam, d = ds, ds/4,
    ... down to NATURAL_STEP_MIN ds (a Newton at a fixed parameter value from o's points), or
    None. Used where the pseudo-arclength corrector fails at ever shorter steps: at a contact
    gained or lost the branch has a kink (no tangent), which a fixed-value step does not need."""
    d = ds
    while d >= NATURAL_STEP_MIN * ds * (1 - 1e-12):
        x = lam + direction * d
        try:
            on = _orbit_at(fam, x, like, o, tol=tol)
        except (SolveError, InputError, SceneError):
            on = None
        if on is not None and on.converged:
            return on, x, int(on.iterations)
        d *= 0.25
    return None


JUMP_ITERATIONS = (2000, 400)   # map iterations from a fold's orbit beyond it: (maps, flows)
JUMP_MAX_PERIOD = 8


def _jump_target(fam, like, o, value, direction, tol, offset: float = 0.0) -> str:
    """Where the motion goes beyond a fold: from the fold side's orbit, at value + direction *
    offset (a value where that orbit no longer exists), the map iterated JUMP_ITERATIONS times,
    then the settled motion recognised as a periodic orbit of period <= JUMP_MAX_PERIOD (refined
    by Newton) or said to be none. One line."""
    x_at = value + direction * offset
    try:
        m = fam.map_at(x_at, like)
    except (InputError, SceneError) as e:
        return f"jump target not sought ({e})"
    n = JUMP_ITERATIONS[0] if isinstance(m, NumbaMap) else JUMP_ITERATIONS[1]
    x, z = np.array(o.points[0], dtype=float), np.array(o.z[0])
    try:
        for _ in range(n):
            st = m.step(x, z)
            x, z = st.x, st.z
            if not finite(x):
                return f"beyond the fold (at {fam.label} = {x_at:g}) the motion is not bounded"
        X, Z = section_points(m, x, z, 2 * JUMP_MAX_PERIOD + 1)
    except SolveError as e:
        return f"jump target not found (the integration failed: {e})"
    s = np.asarray(m.scales, dtype=float)
    for k in range(1, JUMP_MAX_PERIOD + 1):
        d = np.max(np.abs(m.difference(X[k:k + JUMP_MAX_PERIOD], X[:JUMP_MAX_PERIOD]) / s))
        if d < 1e-3:
            try:
                oj = periodic_orbit(m, k, X[:k] if k > 1 else X[0], z=Z[0], tol=tol, check=True)
            except (SolveError, InputError):
                break
            if oj.converged:
                away = float(np.max(np.abs(m.difference(oj.points[0], o.points[0]) / s)))
                pt = ", ".join(f"{nm} = {v:.5g}" for nm, v in zip(oj.state_names, oj.points[0]))
                return (f"at {fam.label} = {x_at:g} the motion jumps to a period-{k} orbit "
                        f"({orbit_stability(oj)}, max |mu| {oj.max_abs_multiplier:.4g}; {pt}; "
                        f"{away:.3g} scaled from the fold's orbit)")
            break
    return (f"at {fam.label} = {x_at:g} no periodic motion of period <= {JUMP_MAX_PERIOD} settled "
            f"within {n} iterations (chaotic, or a long transient)")


# ---------------------------------------------------------------------------------------------------
# detection and location


def _bisect(fam, like, va, oa, vb, ob, same_side, tol_v, tol, max_iter=40):
    """Bisection in the parameter between branch points a and b: same_side(orbit, value) True on
    a's side. Returns (value, orbit_a_side, orbit_b_side, width, located, why): width the final
    bracket's (the honest uncertainty: where a corrector solve fails at a midpoint the bracket
    is returned as it stands, possibly a whole step), located whether it reached tol_v, why a
    line when it did not."""
    why = ""
    for _ in range(max_iter):
        if abs(vb - va) <= tol_v:
            break
        vm = 0.5 * (va + vb)
        Xg = 0.5 * (oa.points + ob.points) if oa.points.shape == ob.points.shape else None
        try:
            om = _orbit_at(fam, vm, like, oa, Xg, tol=tol)
        except SolveError as e:
            why = f"the corrector failed at {fam.label} = {vm:.6g} ({e})"
            break
        if not om.converged:
            why = (f"the corrector failed at {fam.label} = {vm:.6g} (residual {om.residual:.3g},"
                   f" tolerance {om.tolerance:.3g})")
            break
        if same_side(om, vm):
            va, oa = vm, om
        else:
            vb, ob = vm, om
    width = abs(vb - va)
    located = bool(width <= tol_v * (1 + 1e-9))
    if not located and not why:
        why = f"the bisection stopped after {max_iter} halvings"
    return 0.5 * (va + vb), oa, ob, width, located, why


FOLD_BISECTIONS = 24        # halvings of the arclength bracket of a fold (tolerance permitting)


def _locate_fold(fam, like, va, oa, vb, ob, tol, locate_tol, lam_scale):
    """A fold between branch points a and b (the fold test prod(mu - 1) changes sign): the
    parameter has an extremum there, so it is bisected in the arclength along a's tangent (the
    corrector on the hyperplanes t . (V - V_a - s t) = 0), and the value is the vertex of the
    parabola through the three points nearest the sign change. Returns (value, orbit_a_side,
    orbit_b_side, width, located, why, beyond): width bounds the distance from the bracket's
    values to the vertex (the fold lies between them); beyond +1 when the fold is a maximum
    of the parameter (no orbit of the branch above it), -1 for a minimum."""
    m_a = fam.map_at(va, like)
    try:
        t = _tangent(fam, like, oa, va, lam_scale)
        Va = np.concatenate([_unknowns(oa, m_a), [va / lam_scale]])
        Vb = np.concatenate([_unknowns(ob, fam.map_at(vb, like)), [vb / lam_scale]])
    except (SolveError, ValueError):
        return (0.5 * (va + vb), oa, ob, abs(vb - va), False,
                "the tangent at the bracket could not be computed", 0)
    if Va.size != Vb.size:
        return (0.5 * (va + vb), oa, ob, abs(vb - va), False, "the bracket's orbits differ", 0)
    if float(t @ (Vb - Va)) < 0:
        t = -t
    sa, sb = 0.0, float(t @ (Vb - Va))
    fa = _tests(oa)["fold"]
    pts = [(sa, va, oa), (sb, vb, ob)]
    lo, hi = (sa, va, oa), (sb, vb, ob)
    why = ""
    fz = _frozen(oa, m_a)
    for _ in range(FOLD_BISECTIONS):
        sm = 0.5 * (lo[0] + hi[0])
        ok = _arclength_corrector(fam, like, oa, Va + sm * t, t, lam_scale, fz, tol)
        if ok is None:
            why = f"the corrector failed inside the fold's bracket at arclength {sm:.3g}"
            break
        om, vm, _ = ok
        pts.append((sm, vm, om))
        if math.copysign(1.0, _tests(om)["fold"]) == math.copysign(1.0, fa):
            lo = (sm, vm, om)
        else:
            hi = (sm, vm, om)
        if len(pts) >= 3:
            near = sorted(pts, key=lambda q: abs(q[0] - 0.5 * (lo[0] + hi[0])))[:3]
            if max(abs(q[1] - lo[1]) for q in near) <= 0.25 * locate_tol:
                break
    near = sorted(pts, key=lambda q: abs(q[0] - 0.5 * (lo[0] + hi[0])))[:3]
    ss = np.array([q[0] for q in near])
    ll = np.array([q[1] for q in near])
    vertex = None
    if len(near) == 3 and np.ptp(ss) > 0:
        c2, c1, c0 = np.polyfit(ss - ss.mean(), ll, 2)
        if c2 != 0:
            sv = -c1 / (2 * c2)
            if abs(sv + ss.mean() - 0.5 * (lo[0] + hi[0])) <= abs(hi[0] - lo[0]) + np.ptp(ss):
                vertex = float(c0 - c1 * c1 / (4 * c2))
    if vertex is None:
        vertex = 0.5 * (lo[1] + hi[1])
        why = why or "no parabola through the bracket"
    width = max(abs(vertex - lo[1]), abs(vertex - hi[1]))
    beyond = 1 if vertex >= 0.5 * (lo[1] + hi[1]) else -1
    located = bool(width <= locate_tol and not why)
    if not located and not why:
        why = f"the bracket's values are {width:.2g} from the vertex after {len(pts) - 2} halvings"
    return vertex, lo[2], hi[2], width, located, why, beyond


MISSED_CONTACT_SAMPLES = 4001   # trajectory samples per period checked for a missed contact


def _enters_contact(fam, like, o: PeriodicOrbit, value) -> bool:
    """Whether the orbit's trajectory (one period, MISSED_CONTACT_SAMPLES samples) has a contact
    event function both > 0 (in contact: penetration) and < 0 somewhere: a contact entered and
    left. The peak between samples is the vertex of the parabola through the three samples around
    the largest value, so a contact shallower than the sample spacing is seen. Only for
    stroboscopic maps of flows with contact events; False otherwise."""
    m = fam.map_at(value, like)
    if not isinstance(m, StroboscopicMap) or m.contacts.size == 0:
        return False
    sysm = m.flow
    g = np.zeros(max(1, int(sysm.n_events)))
    for i in range(o.period):
        try:
            t, Y, Z = m.trajectory(o.points[i], o.z[i], MISSED_CONTACT_SAMPLES, with_z=True)
        except SolveError:
            return False
        G = np.empty((t.size, m.contacts.size))
        for k in range(t.size):
            sysm.events(float(t[k] + m.t0), np.ascontiguousarray(Y[k]), sysm.p,
                        np.ascontiguousarray(Z[k]), g)
            G[k] = g[m.contacts]
        for j in range(m.contacts.size):
            gj = G[:, j]
            if not np.any(gj < 0.0):
                continue                    # in contact throughout: no onset to miss
            k = int(np.argmax(gj))
            peak = gj[k]
            if peak <= 0.0 and 0 < k < gj.size - 1:
                # the peak between samples: the vertex of the parabola through the three samples
                # around the largest (a contact shallower than the sample spacing resolves)
                g0, g1, g2 = gj[k - 1], gj[k], gj[k + 1]
                curv = g2 - 2.0 * g1 + g0
                if curv < 0.0:
                    peak = g1 - (g2 - g0) ** 2 / (8.0 * curv)
            if peak > 0.0:
                return True
    return False


def _crossing_coordinate(o: PeriodicOrbit, kind: str) -> float:
    """The quantity that crosses a critical value at the bifurcation: the real multiplier nearest
    -1 (period doubling), the modulus of the complex pair nearest the unit circle (NS)."""
    mu = _critical(o)
    if mu.size == 0:
        return math.nan
    if kind == "period_doubling":
        return float(np.real(mu[int(np.argmin(np.abs(mu + 1.0)))]))
    cpl = mu[np.abs(mu.imag) > 0]
    if cpl.size == 0:
        return math.nan
    return float(np.abs(cpl[int(np.argmin(np.abs(np.abs(cpl) - 1.0)))]))


def _crossing_error(o: PeriodicOrbit, kind: str) -> float:
    """The uncertainty of the crossing multiplier (its |mu(rtol) - mu(10 rtol)|, at least the
    residual times its modulus): the error of the other multipliers does not move the crossing."""
    mu = np.asarray(o.multipliers)
    err = np.asarray(o.multiplier_error, dtype=float)
    if mu.size == 0:
        return 0.0
    if kind == "period_doubling":
        i = int(np.argmin(np.abs(mu + 1.0)))
    else:
        i = int(np.argmin(np.abs(np.abs(mu) - 1.0) + np.where(np.abs(mu.imag) > 0, 0.0, np.inf)))
    e = float(err[i]) if err.size == mu.size and math.isfinite(err[i]) else 0.0
    res = o.residual if math.isfinite(o.residual) else 0.0
    return max(e, res * max(1.0, float(abs(mu[i]))))


def _where(fam, v, w, located, why, tol_v) -> str:
    """The located value in words: "at p = v ± w" when located to the requested tolerance, else
    the bracket and why it is wider."""
    if located:
        return f"at {fam.label} = {v:.6g} ± {w:.2g}"
    return (f"bracketed in {fam.label} = {v - w / 2:.6g} ... {v + w / 2:.6g} (width {w:.2g}, not "
            f"located to {tol_v:.2g}: {why})")


def _detect(fam, like, va, oa, vb, ob, tol, locate, locate_tol, *, step=None, lam_scale=None):
    out = []
    step = abs(vb - va) if step is None else step
    lam_scale = max(abs(vb - va), 1e-300) if lam_scale is None else lam_scale
    ta, tb = _tests(oa), _tests(ob)
    checks = []
    # the multiplier tests compare like with like: across a change of the contact pattern (onsets
    # per period, or a memory that becomes never reset) the set of multipliers itself changes
    # (a reset memory contributes a 0, a never reset one the neutral 1): that change is reported as
    # grazing / contact_change below, not as a fold or period doubling
    same_kind = oa.continuum == ob.continuum and ta["contacts"] == tb["contacts"]
    if not same_kind:
        ta = dict(ta, pd=1.0, fold=1.0, ns=None)
        tb = dict(tb, pd=1.0, fold=1.0, ns=None)
    if ta["pd"] * tb["pd"] < 0:
        checks.append(("period_doubling", "pd"))
    if ta["fold"] * tb["fold"] < 0:
        checks.append(("fold", "fold"))
    if ta["ns"] is not None and tb["ns"] is not None and ta["ns"] * tb["ns"] < 0:
        checks.append(("neimark_sacker", "ns"))
    for kind, key in checks:
        sign_a = math.copysign(1.0, ta[key])
        beyond = 0
        if locate and kind == "fold":
            v, o1, o2, w, located, why, beyond = _locate_fold(fam, like, va, oa, vb, ob, tol,
                                                              locate_tol, lam_scale)
        elif locate:
            def same(o, v, key=key, sign_a=sign_a):
                tv = _tests(o)[key]
                return tv is not None and math.copysign(1.0, tv) == sign_a
            v, o1, o2, w, located, why = _bisect(fam, like, va, oa, vb, ob, same, locate_tol,
                                                 tol)
        else:
            v, o1, o2, w = 0.5 * (va + vb), oa, ob, abs(vb - va)
            located, why = False, "not located (locate=False)"
        target = {"period_doubling": -1.0, "fold": 1.0}.get(kind)
        name = {"period_doubling": "period doubling (a multiplier through -1)",
                "fold": "fold (a multiplier through +1)",
                "neimark_sacker": "Neimark-Sacker (a complex pair through |mu| = 1)"}[kind]
        jump = ""
        if target is not None:
            # the multiplier nearest the crossing value on each side of the bracket
            near = []
            for o in (o1, o2):
                mu = _critical(o)
                near.append(mu[int(np.argmin(np.abs(mu - target)))] if mu.size else None)
            crit = min((c for c in near if c is not None), key=lambda c: abs(c - target),
                       default=None)
            if all(c is not None and abs(c - target) > SMOOTH_CROSSING for c in near):
                # the test changed sign but no multiplier is near the crossing value on either
                # side: the multipliers jump (a non-smooth point of the branch, e.g. where the
                # contact pattern changes within the bracket), not a smooth bifurcation
                jump = (f"; non-smooth: no multiplier near {target:+g} on either side (nearest "
                        f"{near[0].real:.3g} and {near[1].real:.3g}): the multipliers jump")
        else:
            cpl = _critical(o1)
            cpl = cpl[np.abs(cpl.imag) > 0]
            crit = cpl[int(np.argmin(np.abs(np.abs(cpl) - 1.0)))] if cpl.size else None
        noise = ""
        if kind != "fold" and locate and not jump:
            # the multipliers' own uncertainty moves the crossing too: u / |d(crit)/d(param)|
            # (the slope from the branch points), added to the bracket's width
            u = max(_crossing_error(o1, kind), _crossing_error(o2, kind))
            ca_, cb_ = _crossing_coordinate(oa, kind), _crossing_coordinate(ob, kind)
            slope = abs(cb_ - ca_) / abs(vb - va) if abs(vb - va) > 0 else 0.0
            if u > 0 and slope > 0 and math.isfinite(u / slope):
                w = w + u / slope
                noise = (f" (bracket plus {u / slope:.2g} from the multipliers' uncertainty "
                         f"{u:.2g})")
        jt = ""
        if kind == "fold" and locate and beyond and not jump:
            # the attractor beyond the fold, from the bracket's stable side (none: the motion is
            # not on this part of the branch)
            st = [o for o in (o1, o2) if orbit_stability(o) == "stable"]
            if st:
                jt = _jump_target(fam, like, st[0], v, beyond, tol,
                                  max(10 * w, 0.1 * step))
        out.append(Bifurcation(kind, float(v), float(w), None if crit is None else complex(crit),
                               o1, f"{name} {_where(fam, v, w, located, why, locate_tol)}"
                               f"{noise}{jump}"
                               + (f"; {jt}" if jt else ""), (va, vb), located, "undetermined",
                               jt))
    if ta["contacts"] != tb["contacts"]:
        ca = ta["contacts"]
        if locate:
            def contacts(o, v):
                # an orbit with fewer counted onsets whose trajectory nevertheless enters a
                # contact (and leaves it) has a contact too shallow for the event detection:
                # count it as on the contact side, else grazing is located short of its value
                n = o.onsets_per_period
                if n < max(ta["contacts"], tb["contacts"]) and _enters_contact(fam, like, o, v):
                    return n + 1
                return n
            v, o1, o2, w, located, why = _bisect(fam, like, va, oa, vb, ob,
                                                 lambda o, v: contacts(o, v) == ca, locate_tol,
                                                 tol)
        else:
            v, o1, o2, w = 0.5 * (va + vb), oa, ob, abs(vb - va)
            located, why = False, "not located (locate=False)"
        with_contact = o1 if o1.onsets_per_period > o2.onsets_per_period else o2
        speed = with_contact.min_approach_speed
        # the contact side's end counts fewer onsets than the branch's contact side: it was put
        # there by _enters_contact (a contact too shallow to count); with locate=False the ends
        # are the branch points themselves
        shallow = locate and with_contact.onsets_per_period < max(ta["contacts"], tb["contacts"])
        if shallow:
            # the bracket's contact side has a contact too shallow to be counted (it entered the
            # contact side by _enters_contact): its approach speed is below the detection's
            speed = 0.0
        far = oa if oa.onsets_per_period > ob.onsets_per_period else ob
        # grazing: the approach speed goes to zero as the contact is lost; a contact count that
        # changes at a finite approach speed is a jump to another orbit (not a grazing)
        graze = (math.isfinite(far.min_approach_speed) and math.isfinite(speed)
                 and speed <= 0.2 * far.min_approach_speed)
        kind = "grazing" if graze else "contact_change"
        what = "grazing" if graze else "contact count change at a finite approach speed (a jump)"
        side = ("a contact too shallow for the event detection on the contact side (seen on "
                "its trajectory)" if shallow else f"approach speed {speed:.3g} on the contact side")
        detail = (f"{what}: contacts per period {o1.onsets_per_period} -> "
                  f"{o2.onsets_per_period} {_where(fam, v, w, located, why, locate_tol)} "
                  f"({side}, {far.min_approach_speed:.3g} at the branch point)")
        out.append(Bifurcation(kind, float(v), float(w), None, with_contact, detail, (va, vb),
                               located))
    return out


def period_doubled_orbit(system, param, bif: Bifurcation, *,
                         tol: float | None = None) -> PeriodicOrbit:
    """The period-2p orbit born at a located period doubling of the branch of ``system`` in
    ``param``: guessed from x* + eps v (v the eigenvector of the multiplier near -1, eps from 1e-2
    to 0.3 of the scales) at the end of the bifurcation's bracket where the p-orbit is unstable,
    and refined by multiple shooting; an orbit whose halves coincide (the p-orbit itself) is not
    accepted. The value is in ``result.settings['value']``."""
    if bif.kind != "period_doubling" or bif.orbit is None:
        raise InputError("bif: give a located period_doubling bifurcation")
    o = bif.orbit
    m = o.map
    fam = Family(system, param)
    w, V = np.linalg.eig(o.monodromy)
    k = int(np.argmin(np.abs(w + 1.0)))
    v = np.real(V[:, k])
    v /= np.max(np.abs(v / m.scales))
    va, vb = bif.between
    # the p-orbit's side beyond the bifurcation: where its critical multiplier is below -1
    side = vb if np.min(np.real(_critical(o))) > -1.0 else va
    for eps in (1e-2, 3e-2, 1e-1, 3e-1):
        for value in (bif.value + (side - bif.value) * frac for frac in (0.5, 1.0)):
            mm = fam.map_at(value, m)
            o2 = periodic_orbit(mm, 2 * o.period, o.points[0] + eps * v * m.scales, z=o.z[0],
                                tol=tol, check=True)
            if o2.converged:
                spread = np.max(np.abs(mm.difference(o2.points[0], o2.points[o.period])
                                       / mm.scales))
                if spread > 10 * o2.tolerance:
                    o2.settings["value"] = value
                    return o2
    raise InputError(f"no period-{2 * o.period} orbit found near the period doubling at "
                     f"{bif.value:g} (only the period-{o.period} orbit)")


CRITICAL_OFFSET = 0.02       # of the continuation's step: where the doubled orbit is sought
NS_ITERATIONS = 6000         # map iterations on the unstable side of a Neimark-Sacker point
NS_OFFSET = 0.1              # of the step: the nearer distance there (growth rate ~ distance)


DOUBLED_GUESSES = (1e-2, 3e-2, 1e-1, 3e-1)   # x* + eps v: eps in the scales
DOUBLED_MAX_ITER = 10        # Newton steps per guess (an orbit that exists converges in a few)


def _doubled_at(fam, like, o: PeriodicOrbit, value, tol):
    """The period-2p orbit at ``value`` near the p-orbit o (x* + eps v, v the eigenvector of
    the multiplier nearest -1, eps 1e-2 ... 0.3 of the scales), or None; the p-orbit itself (its
    halves coinciding) and an orbit far from o are not accepted."""
    m = fam.map_at(value, like)
    w, V = np.linalg.eig(o.monodromy)
    k = int(np.argmin(np.abs(w + 1.0)))
    v = np.real(V[:, k])
    s = np.asarray(m.scales, dtype=float)
    v = v / np.max(np.abs(v / s))
    for eps in DOUBLED_GUESSES:
        try:
            o2 = periodic_orbit(m, 2 * o.period, o.points[0] + eps * v * s, z=o.z[0], tol=tol,
                                check=True, max_iter=DOUBLED_MAX_ITER)
        except (SolveError, InputError):
            continue
        if not o2.converged:
            continue
        spread = np.max(np.abs(m.difference(o2.points[0], o2.points[o.period]) / s))
        near = min(np.max(np.abs(m.difference(o2.points[0], q) / s)) for q in o.points)
        if spread > 10 * o2.tolerance and near <= 0.5:
            o2.settings["value"] = float(value)
            return o2
    return None


def bifurcation_criticality(fam, like, bif: Bifurcation, step: float):
    """(criticality, why) of a located bifurcation (Kuznetsov 2004, sec. 4.5 and 4.7): a period
    doubling is supercritical when the doubled orbit exists on the side where the p-orbit has
    turned unstable through -1 (and not on the other), subcritical when it exists on the stable
    side only -- the doubled branch's direction, sought at CRITICAL_OFFSET steps (at least 20
    bracket widths) on each side; a Neimark-Sacker point of a map is supercritical when on its
    unstable side the motion settles on an invariant circle whose radius grows as
    sqrt(distance) (two distances, ratio 4: radii in ratio 1.4 ... 2.9), subcritical when it
    leaves the neighbourhood. Otherwise "undetermined", with why. Sets ``bif.new_orbit``."""
    if bif.kind not in ("period_doubling", "neimark_sacker") or bif.orbit is None:
        return "undetermined", ""
    if not bif.located:
        return "undetermined", "not located"
    va, vb = bif.between
    o = bif.orbit
    key = "pd" if bif.kind == "period_doubling" else "ns"
    ta = _tests(o)[key]
    if ta is None:
        return "undetermined", "no critical multiplier on the bracket's side"
    # o is at the a side of the located value: its test's sign is the a side's
    flipped_a = ta < 0 if key == "pd" else ta > 0
    dir_u = math.copysign(1.0, (va if flipped_a else vb) - bif.value)
    d = max(20 * bif.tolerance, CRITICAL_OFFSET * step)
    if bif.kind == "period_doubling":
        try:
            on_u = _doubled_at(fam, like, _orbit_near(fam, like, o, bif.value + dir_u * d), bif.value + dir_u * d, o.tolerance)
            on_s = _doubled_at(fam, like, _orbit_near(fam, like, o, bif.value - dir_u * d), bif.value - dir_u * d, o.tolerance)
        except (InputError, SceneError, SolveError) as e:
            return "undetermined", f"the doubled orbit could not be sought ({e})"
        if on_u is not None and on_s is None:
            bif.new_orbit, bif.new_value = on_u, bif.value + dir_u * d
            return "supercritical", (f"the period-{2 * o.period} orbit exists where the "
                                     f"period-{o.period} orbit is unstable "
                                     f"({orbit_stability(on_u)} at {fam.label} = "
                                     f"{bif.value + dir_u * d:.6g})")
        if on_s is not None and on_u is None:
            bif.new_orbit, bif.new_value = on_s, bif.value - dir_u * d
            return "subcritical", (f"the period-{2 * o.period} orbit exists where the "
                                   f"period-{o.period} orbit is stable "
                                   f"({orbit_stability(on_s)} at {fam.label} = "
                                   f"{bif.value - dir_u * d:.6g})")
        return "undetermined", (f"a period-{2 * o.period} orbit found on "
                                f"{'both sides' if on_u is not None else 'neither side'} at "
                                f"± {d:.3g}")
    m = fam.map_at(bif.value, like)
    if not isinstance(m, NumbaMap):
        return "undetermined", "decided by iteration for maps only"
    radii = []
    d = max(20 * bif.tolerance, NS_OFFSET * step)      # the circle must grow within the iterations
    for dd in (d, 4 * d):
        value = bif.value + dir_u * dd
        try:
            of = _orbit_near(fam, like, o, value)
        except (InputError, SolveError) as e:
            return "undetermined", f"no orbit on the unstable side ({e})"
        mm = fam.map_at(value, like)
        s = np.asarray(mm.scales, dtype=float)
        w, V = np.linalg.eig(of.monodromy)
        v = np.real(V[:, int(np.argmax(np.abs(w)))])
        x = of.points[0] + 1e-3 * s * v / np.max(np.abs(v))
        z = of.z[0]
        dist = []
        for k in range(NS_ITERATIONS):
            for _ in range(of.period):
                st = mm.step(x, z)
                x, z = st.x, st.z
            if not finite(x):
                break
            if k >= NS_ITERATIONS // 2:
                dist.append(float(np.max(np.abs(mm.difference(x, of.points[0]) / s))))
        if not dist or not finite(x) or max(dist) > 0.5:
            return "subcritical", (f"on the unstable side ({fam.label} = {value:.6g}) the motion "
                                   f"leaves the orbit's neighbourhood: no small invariant circle")
        radii.append(float(np.mean(dist)))
    ratio = radii[1] / radii[0] if radii[0] > 0 else math.inf
    if 1.4 <= ratio <= 2.9:
        return "supercritical", (f"an invariant circle on the unstable side, radius "
                                 f"{radii[0]:.3g} and {radii[1]:.3g} at {d:.3g} and {4 * d:.3g} "
                                 f"from it (ratio {ratio:.3g}; sqrt law: 2)")
    return "undetermined", f"radii {radii[0]:.3g}, {radii[1]:.3g}: not the sqrt law"


def _orbit_near(fam, like, o: PeriodicOrbit, value) -> PeriodicOrbit:
    """The p-orbit at ``value`` from o (raises SolveError when Newton does not converge)."""
    on = _orbit_at(fam, value, like, o, tol=o.tolerance)
    if not on.converged:
        raise SolveError(f"no period-{o.period} orbit at {fam.label} = {value:g} "
                         f"(residual {on.residual:.3g})")
    return on


@dataclass
class Cascade:
    """A period-doubling cascade followed by branch switching (:func:`follow_cascade`):
    ``branches`` of period p, 2p, 4p ... (each continued from its doubling), ``doublings`` the
    located period doublings in order, ``ratios`` the successive interval ratios
    (v_{k+1} - v_k) / (v_{k+2} - v_{k+1}) (Feigenbaum's delta = 4.6692... is the smooth
    reference), ``message`` why it stopped."""
    branches: list
    doublings: list
    ratios: list
    message: str
    settings: dict = field(default_factory=dict)

    def table(self) -> pd.DataFrame:
        rows = []
        for k, b in enumerate(self.doublings):
            rows.append({"period_from": b.orbit.period, "period_to": 2 * b.orbit.period,
                         "value": b.value, "tolerance": b.tolerance, "located": b.located,
                         "criticality": b.criticality,
                         "interval_ratio": self.ratios[k - 2] if k >= 2 else math.nan})
        return pd.DataFrame(rows, columns=["period_from", "period_to", "value", "tolerance",
                                           "located", "criticality", "interval_ratio"])


FEIGENBAUM_DELTA = 4.669201609102990


def follow_cascade(system, branch: Branch, param, *, max_period: int = 8, range=None,
                   step: float | None = None, locate_tol: float | None = None,
                   max_points: int = 200, progress=None) -> Cascade:
    """Follow a period-doubling cascade from a continued ``branch`` (of ``system`` in ``param``,
    :func:`continue_orbit`): at the first located period doubling along the range, switch to the
    doubled branch (started from the flip eigenvector on the side where it exists:
    :func:`bifurcation_criticality`; Seydel 2010, sec. 7.4; Kuznetsov 2004, sec. 10.3), continue
    it by pseudo-arclength towards the range's end, locate its doubling, and so on while the
    period is <= ``max_period``. range: (a, b), default the branch's; step: the first branch's
    (default the branch's step), each later branch's is 1/20 of the last interval between
    doublings (the intervals shrink by about delta), its range the last interval beyond the
    doubling (the next doubling is nearer than that in a cascade). Returns a :class:`Cascade`."""
    P = check_period(max_period, "max_period")
    if not isinstance(branch, Branch) or not branch.orbits:
        raise InputError("branch: give a Branch from continue_orbit")
    fam = Family(system, param)
    if range is None:
        rng = branch.settings.get("range") or [branch.settings["values"][0],
                                               branch.settings["values"][-1]]
        a, b = float(rng[0]), float(rng[-1])
    else:
        a, b = _range_pair(range)
    fam.check(a, "range:")
    fam.check(b, "range:")
    direction = 1.0 if b >= a else -1.0
    step0 = float(step) if step is not None else float(branch.settings.get("step") or
                                                       abs(b - a) / 50.0)
    branches, doublings = [branch], []
    cur = branch
    message = ""
    while True:
        last = doublings[-1].value if doublings else None
        pds = [x for x in cur.bifurcations if x.kind == "period_doubling"
               and (last is None or (x.value - last) * direction > 0)]
        pds.sort(key=lambda x: (x.value - a) * direction)
        if not pds:
            message = (f"no period doubling on the period-{cur.period} branch within "
                       f"{param} = {min(cur.values):g} ... {max(cur.values):g}")
            break
        bif = pds[0]
        if bif.criticality == "undetermined" or bif.new_orbit is None:
            crit, why = bifurcation_criticality(fam, cur.orbits[0].map, bif, step0 if last is
                                                None else abs(bif.value - last))
            bif.criticality = crit
            if why and why not in bif.detail:
                bif.detail += f"; {crit}: {why}"
        doublings.append(bif)
        if 2 * cur.period > P:
            message = f"period {2 * cur.period} is beyond max_period = {P}"
            break
        if bif.criticality != "supercritical" or bif.new_orbit is None:
            message = (f"the doubling at {param} = {bif.value:.6g} is {bif.criticality}: no "
                       f"doubled branch followed")
            break
        v2 = float(bif.new_value)
        interval = abs(bif.value - last) if last is not None else None
        end = b if interval is None else bif.value + direction * min(abs(b - bif.value),
                                                                       1.2 * interval)
        if (end - v2) * direction <= 0:
            message = f"the range ends at the doubling at {param} = {bif.value:.6g}"
            break
        ds = step0 if interval is None else interval / 20.0
        ltol = locate_tol if locate_tol is not None else 1e-4 * ds
        try:
            br2 = continue_orbit(fam.at(v2), bif.new_orbit, param, range=(v2, end), step=ds,
                                 max_points=max_points, locate_tol=ltol, progress=progress)
        except (InputError, SolveError) as e:
            message = f"the period-{2 * cur.period} branch could not be continued ({e})"
            break
        branches.append(br2)
        cur = br2
    vals = [x.value for x in doublings]
    ratios = [(vals[k + 1] - vals[k]) / (vals[k + 2] - vals[k + 1])
              for k in np.arange(len(vals) - 2)]
    return Cascade(branches, doublings, [float(r) for r in ratios], message,
                   {"range": [a, b], "max_period": P, "step": step0})


def orbit_observable(system, orbit: PeriodicOrbit, name: str) -> np.ndarray:
    """The value of ``name`` at each of the orbit's section points: a table column of a scene
    (``nld simulate`` columns, SI units, from the kernel's ``observe`` at the section time), else
    a state name of the system."""
    kern = system.kernel if system.is_scene else None
    m = orbit.map
    out = np.empty(orbit.period)
    if system.is_scene and name in kern.columns:
        j = list(kern.columns).index(name)
        row = np.empty(len(kern.columns))
        for i in np.arange(orbit.period):
            y, z = m.unpack(orbit.points[i], orbit.z[i])
            kern.module.observe(float(system.t0), np.ascontiguousarray(y), system.p, z, row)
            out[i] = row[j]
        return out
    names = list(orbit.state_names)
    if name not in names:
        raise InputError(f"observable {name!r}: not a state ({', '.join(names)})"
                         + (f" nor a column ({', '.join(kern.columns)})" if system.is_scene else ""))
    return orbit.points[:, names.index(name)].copy()


def branch_curves(branches, system, observable: str) -> list[dict]:
    """The data of ``nld.output.plots.branch_diagram``: per branch its period, values, the
    observable at the section points (n_values, period), stability, and the located
    bifurcations as (kind, value, observable there)."""
    curves = []
    for br in branches:
        fam = Family(system, br.param)
        y = np.array([orbit_observable(fam.at(v), o, observable)
                      for v, o in zip(br.values, br.orbits)])
        bifs = [(b.kind, b.value, orbit_observable(fam.at(b.value), b.orbit, observable))
                for b in br.bifurcations if b.orbit is not None]
        stab = [orbit_stability(o) for o in br.orbits]
        curves.append({"period": br.period, "values": list(br.values), "y": y,
                       "stable": [{"stable": True, "unstable": False}.get(x) for x in stab],
                       "stability": stab, "bifurcations": bifs})
    return curves
