"""Continuation of periodic orbits in one parameter, with the bifurcations located and named.

:func:`continue_orbit` follows a periodic orbit (``nld.analysis.orbits``) of a scene, a forced
flow or a map as one parameter changes, with a predictor-corrector scheme (Allgower & Georg 1990;
Kuznetsov 2004, ch. 10; Seydel 2010, ch. 4):

* natural-parameter continuation over given values (the previous orbit, extrapolated along the
  secant, as the guess; it cannot pass a fold and says so);
* pseudo-arclength continuation over a range (Keller 1977): the unknowns are the shooting points
  and the parameter, the extra equation t . (V - V_pred) = 0 with t the branch's unit tangent (the
  null vector of [G_x, G_lambda], G_lambda by a forward difference), adaptive step (x1.5 after a
  corrector of <= 3 Newton steps, /2 after a failure).

Along the branch the Floquet multipliers (neutral memory multipliers of a permanent-contact orbit
left out) are watched for the codimension-one bifurcations of a map (Kuznetsov 2004, ch. 4):
**period doubling** (a real multiplier through -1: the test function prod(mu + 1) changes sign),
**fold** (through +1: prod(mu - 1), and the parameter turns back), **Neimark-Sacker** (a complex
pair through |mu| = 1), and the discontinuity-induced bifurcations of impacting systems
(di Bernardo et al. 2008, ch. 8; Nordmark 1991): **grazing** (a contact's normal approach speed
on the orbit goes to 0 and the number of contacts per period changes) and, generally, the
**appearance or loss of a contact** per period at a finite approach speed (``contact_change``: the
branch jumps to another orbit; a compliant contact law makes such jumps possible). Period doubling, Neimark-Sacker and grazing are
located by bisection in the parameter (a corrector solve per step) to ``locate_tol``; a fold by
its bracketing branch points. :func:`period_doubled_orbit` starts the doubled branch at a located
period doubling.

Parameters: for a scene a scene key as ``nld --set`` takes it (``joints.B.clearance``,
``driver.speed``); the kernel is the same at every value (parameters are kernel arguments; a
value that changes the scene's structure is refused). For another system the index of p or a
name of ``system.param_names``. Units: the parameter's SI unit.
"""
from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from nld.errors import InputError, SceneError, SolveError
from nld.analysis.orbits import PeriodicOrbit, _Shooting, _finite, check_period, periodic_orbit
from nld.systems.derived import NumbaMap, PoincareMap, StroboscopicMap, as_map

__all__ = ["Family", "Bifurcation", "Branch", "continue_orbit", "period_doubled_orbit",
           "KINDS"]

ARCLENGTH_PARAM_UNIT = 0.02       # of the range: the parameter's weight in the arclength
KINDS = ("period_doubling", "fold", "neimark_sacker", "grazing", "contact_change")


# ---------------------------------------------------------------------------------------------------
# a system as a function of one parameter


class Family:
    """``system`` with one parameter varied: ``at(value)`` is the system at that value (cached)."""

    def __init__(self, system, param):
        self.base = system
        self.param = param
        self._cache: dict = {}
        if getattr(system, "kernel", None) is not None:
            from nld.model.scene import resolve_scene
            if not isinstance(param, str):
                raise InputError(f"param = {param!r}: for a scene give a scene key, e.g. "
                                 f"joints.B.clearance or driver.speed")
            self.kind = "scene"
            self.value0 = self._scene_value(system.scene, param)
            resolve_scene(system.scene, [f"{param}={self.value0!r}"])   # checks the key
        else:
            self.kind = "p"
            names = list(getattr(system, "param_names", []) or [])
            if isinstance(param, str):
                if param not in names:
                    raise InputError(f"param = {param!r}: {system.name} has parameters "
                                     f"{', '.join(names) if names else '(unnamed: give an index of p)'}")
                self.index = names.index(param)
            elif isinstance(param, (int, np.integer)) and not isinstance(param, bool) \
                    and 0 <= param < system.p.size:
                self.index = int(param)
            else:
                raise InputError(f"param = {param!r}: must be a name in {names} or an index of p "
                                 f"(0..{system.p.size - 1})")
            self.value0 = float(system.p[self.index])

    @staticmethod
    def _scene_value(scene, key: str) -> float:
        from nld.model.scene import scene_to_dict
        node = scene_to_dict(scene)
        for part in key.split("."):
            if not isinstance(node, dict) or part not in node:
                raise InputError(f"param = {key!r}: no such scene key")
            node = node[part]
        try:
            return float(node)
        except (TypeError, ValueError):
            raise InputError(f"param = {key!r}: is {node!r}, not a number") from None

    def at(self, value: float):
        value = float(value)
        if value in self._cache:
            return self._cache[value]
        b = self.base
        if self.kind == "scene":
            from nld.kernel.compile import compile_scene
            from nld.model.scene import resolve_scene
            from nld.systems.core import SceneSystem
            sc = resolve_scene(b.scene, [f"{self.param}={value!r}"])
            kern = compile_scene(sc)
            if kern.key != b.kernel.key:
                raise InputError(f"{self.param} = {value:g} changes the scene's structure (e.g. a "
                                 f"clearance of 0 is an ideal joint): continue within one structure")
            s = SceneSystem(sc, kernel=kern, method=b.method)
        else:
            s = copy.copy(b)
            s.p = b.p.copy()
            s.p[self.index] = value
            pi = getattr(b, "period_index", None)
            if pi is not None and pi == self.index and b.period is not None:
                if not value > 0:
                    raise InputError(f"{self.param} = {value!r}: the forcing frequency must be > 0")
                s.period = 2.0 * math.pi / value
                s.hmax = s.period / 20.0
            for attr in ("_tangent_solver",):
                if hasattr(b, attr):
                    setattr(s, attr, getattr(b, attr))
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


@dataclass
class Bifurcation:
    """A bifurcation found between two branch points.

    kind: one of KINDS; value: the located parameter value (SI unit of the parameter), within
    ``tolerance``; multiplier: the critical multiplier (complex) or None (grazing); orbit: the
    orbit at the located value (the branch's side before it); detail: one line for humans."""
    kind: str
    value: float
    tolerance: float
    multiplier: complex | None
    orbit: PeriodicOrbit | None
    detail: str
    between: tuple = ()

    def to_dict(self) -> dict:
        m = self.multiplier
        return {"kind": self.kind, "value": self.value, "tolerance": self.tolerance,
                "multiplier_re": None if m is None else float(np.real(m)),
                "multiplier_im": None if m is None else float(np.imag(m)),
                "detail": self.detail}


@dataclass
class Branch:
    """A continued branch: ``values`` and ``orbits`` in branch order (failed points are not
    included; ``message`` says why the branch ended), the located ``bifurcations``."""
    param: object
    period: int
    values: list
    orbits: list
    bifurcations: list
    message: str
    settings: dict = field(default_factory=dict)

    def table(self) -> pd.DataFrame:
        """One row per branch point: value, converged, residual, stable, max |mu|, the
        multipliers (re, im columns by decreasing modulus), onsets per period, smallest approach
        speed, continuum, and the orbit's first section point (one column per state)."""
        rows = []
        for v, o in zip(self.values, self.orbits):
            r = {"value": v, "period": o.period, "converged": o.converged, "residual": o.residual,
                 "stable": ("" if o.stable is None else ("stable" if o.stable else "unstable")),
                 "max_abs_multiplier": o.max_abs_multiplier,
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
                            columns=["kind", "value", "tolerance", "multiplier_re",
                                     "multiplier_im", "detail"])


# ---------------------------------------------------------------------------------------------------
# test functions


def _critical(o: PeriodicOrbit) -> np.ndarray:
    """The multipliers that decide stability: a continuum's neutral memory multiplier dropped."""
    mu = o.multipliers
    if o.continuum and mu.size:
        mu = np.delete(mu, int(np.argmin(np.abs(mu - 1.0))))
    return mu


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
                         tol, max_iter=8):
    """Newton on [G(U, lam); t . (V - V_pred)] = 0 (V = (U, lam / lam_scale), U the scaled
    shooting points). Returns (orbit, value, iterations) or None."""
    p = o_prev.period
    multiple = o_prev.settings.get("shooting") == "multiple"
    V = V_pred.copy()
    Z = [np.array(z) for z in (o_prev.z if multiple else o_prev.z[:1])]
    for it in range(1, max_iter + 1):
        lam = V[-1] * lam_scale
        try:
            m = fam.map_at(lam, like_map)
        except (InputError, SceneError):     # the Newton left the parameter's domain (mu < 0)
            return None
        sh = _Shooting(m, p, multiple)
        npts = p if multiple else 1
        X = V[:-1].reshape(npts, m.n) * sh.s
        try:
            r, J, steps = sh.evaluate(X, Z, True)
            dl = PARAM_FD_STEP * lam_scale
            m2 = fam.map_at(lam + dl, like_map)
            r2, _, _ = _Shooting(m2, p, multiple).evaluate(X, Z, False)
        except (SolveError, InputError, SceneError):
            return None
        if not (_finite(r) and _finite(J) and _finite(r2)):
            return None
        Gl = (r2 - r) / dl * lam_scale
        J = J.copy()
        if frozen.size:
            J[:, frozen] = 0.0
        res = float(np.max(np.abs(r)))
        A = np.vstack([np.column_stack([J, Gl]), t_vec[None, :]])
        F = np.concatenate([r, [float(t_vec @ (V - V_pred))]])
        if res <= tol and abs(F[-1]) <= 1e-8:
            o = periodic_orbit(m, p, X, z=Z[0], tol=tol, check=True, max_iter=3,
                               shooting="multiple" if multiple else "single")
            return (o, lam, it) if o.converged else None
        try:
            dV = np.linalg.lstsq(A, -F, rcond=1e-12)[0]
        except np.linalg.LinAlgError:
            return None
        if frozen.size:
            dV[frozen] = 0.0
        V = V + dV
        if multiple:
            Z = [steps[(i - 1) % p].z for i in range(p)]
    return None


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
    sh = _Shooting(m, p, multiple)
    npts = p if multiple else 1
    X = o.points[:npts]
    Z = [np.array(z) for z in o.z[:npts]]
    r, J, _ = sh.evaluate(X, Z, True)
    dl = PARAM_FD_STEP * lam_scale
    r2, _, _ = _Shooting(fam.map_at(value + dl, like_map), p, multiple).evaluate(X, Z, False)
    Gl = (r2 - r) / dl * lam_scale
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


def check_values(values, value0, param):
    v = np.array(values, dtype=float).ravel()
    if v.size < 2 or not np.all(np.isfinite(v)):
        raise InputError(f"values = {values!r}: give at least two finite values of {param}")
    if np.any(np.diff(v) == 0):
        raise InputError(f"values: {param} repeats a value; give distinct values")
    lo, hi = min(v[0], v[-1]), max(v[0], v[-1])
    span = max(hi - lo, abs(value0) * 1e-12)
    if not (lo - 1e-9 * span <= value0 <= hi + 1e-9 * span):
        raise InputError(f"values {v[0]:g} ... {v[-1]:g} of {param} do not contain the start "
                         f"orbit's value {value0:g}")
    return v


def continue_orbit(system, orbit: PeriodicOrbit, param, values=None, *, range=None,
                   method: str | None = None, step: float | None = None, max_points: int = 200,
                   tol: float | None = None, locate: bool = True, locate_tol: float | None = None,
                   progress=None, on_point=None) -> Branch:
    """Follow ``orbit`` of ``system`` (the system at the orbit's parameter value) in ``param``.

    values: parameter values for natural continuation (must contain the start value; the
            branch is followed from the start outwards to both ends given), or
    range:  (a, b) for pseudo-arclength continuation from the start value towards b (then back
            towards a if a is on the other side), first step ``step`` (default |b - a| / 50),
            at most ``max_points`` points.
    method: "natural" or "arclength" (default: natural with values, arclength with range).
    locate: locate the bifurcations (module docstring) to ``locate_tol`` (default 1e-4 of the
            parameter's step).
    on_point: optional callable (value, orbit) after each branch point (a CLI writes it).
    Returns a :class:`Branch`; the orbits carry their multipliers and contact statistics.
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
        settings["values"] = v.tolist()
        vals, orbs, msg = _natural(fam, like, orbit, v0, v, tol, progress, on_point)
        dstep = float(np.min(np.abs(np.diff(v))))
    else:
        if range is None:
            rng = check_values(values, v0, param)
            a, b = float(rng[0]), float(rng[-1])
        else:
            try:
                a, b = (float(x) for x in range)
            except (TypeError, ValueError):
                raise InputError(f"range = {range!r}: give (a, b)") from None
            check_values([a, b], v0, param)
        settings["range"] = [a, b]
        dstep = float(step) if step is not None else abs(b - a) / 50.0
        if not (dstep > 0 and math.isfinite(dstep)):
            raise InputError(f"step = {step!r}: must be a positive parameter step")
        settings["step"] = dstep
        vals, orbs, msg = _arclength(fam, like, orbit, v0, a, b, dstep, int(max_points), tol,
                                     progress, on_point)
    bifs = []
    for i in np.arange(len(orbs) - 1):
        bifs += _detect(fam, like, vals[i], orbs[i], vals[i + 1], orbs[i + 1], tol, locate,
                        locate_tol if locate_tol is not None else 1e-4 * dstep)
    settings["wall_s"] = time.perf_counter() - t_start
    return Branch(param, orbit.period, vals, orbs, bifs, msg, settings)


def _natural(fam, like, orbit, v0, v, tol, progress, on_point):
    """Natural continuation outwards from v0 over the values (both directions)."""
    eps = 1e-12 * max(1.0, abs(v0))
    up = sorted(x for x in v if x > v0 + eps)                   # outwards from v0, both ways
    down = sorted((x for x in v if x < v0 - eps), reverse=True)
    res = {v0: orbit}
    msgs = []
    done = 0
    for seq in (up, down):
        prev = [(v0, orbit)]
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
                msgs.append(f"stopped at {x:g}: {e}")
                break
            done += 1
            if progress is not None:
                progress(done, len(up) + len(down), x)
            if not o.converged:
                msgs.append(f"stopped at {fam.param} = {x:g}: no orbit there ({o.message}); a fold "
                            f"or the end of the branch (pseudo-arclength continuation passes "
                            f"folds)")
                break
            res[x] = o
            prev.append((x, o))
            if on_point is not None:
                on_point(x, o)
    keys = sorted(res) if v[0] <= v[-1] else sorted(res, reverse=True)
    return keys, [res[k] for k in keys], "; ".join(msgs) or "completed"


def _arclength(fam, like, orbit, v0, a, b, ds, max_points, tol, progress, on_point):
    """Pseudo-arclength continuation from v0 towards b, then from v0 towards a."""
    # the parameter's unit in the arclength: 1/50 of the range, so that a default step (range/50)
    # is one unit of arclength when the branch is flat, as a clearance-sized change of the state
    # is; with the whole range as the unit a branch steep in the scaled state crawled in the
    # parameter (1e-7 per step on slider_crank_olyaei)
    lam_scale = max(abs(b - a) * ARCLENGTH_PARAM_UNIT, 1e-300)
    segments = []
    msgs = []
    crossed = []            # non-smooth points crossed by a natural step
    for target in ([b, a] if a != v0 else [b]):
        if abs(target - v0) <= 1e-12 * lam_scale:
            continue
        direction = 1.0 if target > v0 else -1.0
        m0 = fam.map_at(v0, like)
        t = _tangent(fam, like, orbit, v0, lam_scale)
        if t[-1] * direction < 0:
            t = -t
        o, lam = orbit, v0
        h = ds / lam_scale
        pts = []
        while len(pts) + 1 < max_points:
            U = _unknowns(o, fam.map_at(lam, like))
            V = np.concatenate([U, [lam / lam_scale]])
            ok = None
            while h >= 1e-3 * ds / lam_scale:        # shorter: a non-smooth point
                V_pred = V + h * t
                ok = _arclength_corrector(fam, like, o, V_pred, t, lam_scale,
                                          _frozen(o, m0), tol)
                if ok is not None:
                    break
                h *= 0.5
            if ok is None:
                # a non-smooth point (a contact gained or lost, grazing): the branch has a kink
                # there and no tangent; step across it at a fixed parameter value instead (what
                # natural continuation does), then resume the arclength from the far side
                ok = _natural_step(fam, like, o, lam, direction, ds, tol)
                if ok is None:
                    msgs.append(f"towards {target:g}: the corrector failed at {fam.param} = "
                                f"{lam:g} even with a step of {h * lam_scale:.3g}, and so did "
                                f"natural steps of {ds:.3g} ... {ds * NATURAL_STEP_MIN:.3g}")
                    break
                crossed.append(f"{fam.param} = {lam:g} -> {ok[1]:g}")
                h = ds / lam_scale
            o_new, lam_new, its = ok
            pts.append((lam_new, o_new))
            if on_point is not None:
                on_point(lam_new, o_new)
            if progress is not None:
                progress(len(pts), max_points, lam_new)
            t = _tangent(fam, like, o_new, lam_new, lam_scale, t)
            o, lam = o_new, lam_new
            if its <= 3:
                h = min(1.5 * h, 4 * ds / lam_scale)
            if (lam - target) * direction >= 0:
                break
            if not (min(a, b) - 0.5 * abs(b - a) <= lam <= max(a, b) + 0.5 * abs(b - a)):
                break
        segments.append(pts)
    # branch order: from the a side through v0 to the b side
    seg_b = segments[0] if segments else []
    seg_a = segments[1] if len(segments) > 1 else []
    ordered = list(reversed(seg_a)) + [(v0, orbit)] + seg_b
    if crossed:
        msgs.append("crossed by a natural step where the arclength corrector failed (a non-smooth "
                    "point of the branch): " + ", ".join(crossed))
    return [x for x, _ in ordered], [o for _, o in ordered], "; ".join(msgs) or "completed"


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


# ---------------------------------------------------------------------------------------------------
# detection and location


def _bisect(fam, like, va, oa, vb, ob, same_side, tol_v, tol, max_iter=40):
    """Bisection in the parameter between branch points a and b: same_side(orbit) True on a's
    side. Returns (value, orbit_a_side, orbit_b_side, width)."""
    for _ in range(max_iter):
        if abs(vb - va) <= tol_v:
            break
        vm = 0.5 * (va + vb)
        Xg = 0.5 * (oa.points + ob.points) if oa.points.shape == ob.points.shape else None
        try:
            om = _orbit_at(fam, vm, like, oa, Xg, tol=tol)
        except SolveError:
            break
        if not om.converged:
            break
        if same_side(om, vm):
            va, oa = vm, om
        else:
            vb, ob = vm, om
    return 0.5 * (va + vb), oa, ob, abs(vb - va)


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


def _detect(fam, like, va, oa, vb, ob, tol, locate, locate_tol):
    out = []
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
        if locate and kind != "fold":
            def same(o, v, key=key, sign_a=sign_a):
                tv = _tests(o)[key]
                return tv is not None and math.copysign(1.0, tv) == sign_a
            v, o1, o2, w = _bisect(fam, like, va, oa, vb, ob, same, locate_tol, tol)
        else:
            v, o1, o2, w = 0.5 * (va + vb), oa, ob, abs(vb - va)
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
        out.append(Bifurcation(kind, float(v), float(w), None if crit is None else complex(crit),
                               o1, f"{name} at {fam.param} = {v:.6g} ± {w:.2g}{jump}", (va, vb)))
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
            v, o1, o2, w = _bisect(fam, like, va, oa, vb, ob,
                                   lambda o, v: contacts(o, v) == ca, locate_tol, tol)
        else:
            v, o1, o2, w = 0.5 * (va + vb), oa, ob, abs(vb - va)
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
                  f"{o2.onsets_per_period} at {fam.param} = {v:.6g} ± {w:.2g} ({side}, "
                  f"{far.min_approach_speed:.3g} at the branch point)")
        out.append(Bifurcation(kind, float(v), float(w), None, with_contact, detail, (va, vb)))
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


def orbit_observable(system, orbit: PeriodicOrbit, name: str) -> np.ndarray:
    """The value of ``name`` at each of the orbit's section points: a table column of a scene
    (``nld simulate`` columns, SI units, from the kernel's ``observe`` at the section time), else
    a state name of the system."""
    kern = getattr(system, "kernel", None)
    m = orbit.map
    out = np.empty(orbit.period)
    if kern is not None and name in kern.columns:
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
                         + (f" nor a column ({', '.join(kern.columns)})" if kern is not None else ""))
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
        curves.append({"period": br.period, "values": list(br.values), "y": y,
                       "stable": [o.stable for o in br.orbits], "bifurcations": bifs})
    return curves
