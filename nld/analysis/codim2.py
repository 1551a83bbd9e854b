"""Curves of period doublings, folds and Neimark-Sacker points of periodic orbits in two parameters.

:func:`continue_bifurcation` takes a period doubling, a fold or a Neimark-Sacker point located by
one-parameter continuation (:class:`nld.analysis.continuation.Bifurcation` from ``continue_orbit``)
and follows it as a second parameter changes, by pseudo-arclength continuation (Keller 1977) of the
**extended system** (Kuznetsov 2004, sec. 10.3.2-10.3.3; Govaerts 2000, ch. 4):

    unknowns  V = (U, lam1 / sigma1, lam2 / sigma2)     U the scaled shooting points
    equations G(U, lam1, lam2) = 0                      the periodic-orbit (shooting) residual
              g(U, lam1, lam2) = 0                      the defining condition
              t . (V - V_pred) = 0                      the arclength

with the defining condition a **bordered test function** (Govaerts 2000, sec. 4.4; MatCont's and
BifurcationKit.jl's minimally augmented systems): A = M + I (period doubling) or A = M - I (fold),
M the orbit's monodromy (p-period map Jacobian, in the shooting's scaled variables), and

    [ A    b ] [v]   [0]
    [ c^T  0 ] [g] = [1]

(A = C2(M) - I for Neimark-Sacker: C2 the second compound / bialternate matrix, eigenvalues
mu_i mu_j, i < j; Kuznetsov 2004, sec. 10.3.3), and g is a smooth function that vanishes
exactly where A is singular (a multiplier -1 or +1; a pair with product 1), with b and c the
left and right singular vectors of A's smallest singular value at the last curve point
(updated after every point, oriented by continuity). A contact orbit's memory entries that are
never reset on the orbit (permanent contact or none) are neutral directions with multiplier
exactly 1 (docs/orbits.md): their rows and columns are removed from M before the test (and held
fixed in the shooting), so a continuum's memory multiplier never counts as a fold.

The Jacobian of the extended system: G_U is the shooting's own (monodromy from the tangent
integration with saltation); the other columns -- G and g in each parameter, g in U -- are
forward differences (a tangent integration per column; steps :data:`FD_U` of the scaled state
and :data:`FD_PARAM` of the parameter's arclength unit, large enough to sit above the adaptive
integrator's noise). This costs (n p + 3) tangent integrations per Newton iteration.

Along the curve, between consecutive points, the curve's kind is watched (Kuznetsov 2004,
sec. 9.5 and 10.3; Govaerts 2000, ch. 9): a **turning point** of the curve in either parameter
(the tangent's component changes sign: the curve folds back in that parameter); **fold-flip**
(a multiplier +1 on a period-doubling curve; a multiplier -1 on a fold curve); **1:2
resonance** (a second multiplier -1 on a doubling curve) and **1:1 resonance** (a second
multiplier +1 on a fold curve); a **contact change** (the number of contact onsets per period
changes: the curve meets a grazing curve, di Bernardo et al. 2008, ch. 8; Nordmark 1991). These
special points are bracketed between two curve points, not located further (docs/codim2.md).

Units: the parameters' SI units.
"""
from __future__ import annotations

import math
import time

import numpy as np

from nld.errors import InputError, SceneError, SolveError
from nld.analysis.continuation import ARCLENGTH_PARAM_UNIT, Bifurcation, Family
from nld.analysis.orbits import (PeriodicOrbit, Shooting, finite, orbit_monodromy,
                                 periodic_orbit)
from nld.systems.derived import never_reset
from nld.analysis.bifurcation_curve import (CURVE_END_REASONS, CURVE_KINDS, SPECIAL_KINDS,  # noqa: F401
                                           BifurcationCurve, CurveEnd, SpecialPoint, curve_inputs,
                                           domain_exits)

__all__ = ["BifurcationCurve", "CurveEnd", "SpecialPoint", "continue_bifurcation", "plot_curves",
           "CURVE_KINDS", "CURVE_END_REASONS", "SPECIAL_KINDS", "FD_U", "FD_PARAM"]

FD_U = 1e-5          # forward-difference step in the scaled shooting unknowns
FD_PARAM = 1e-2      # forward-difference step in a parameter, of its arclength unit sigma
TURN_NOISE = 1e-6     # a unit tangent's parameter component below this is taken as zero
MAX_MOVE = 2.0       # a corrector farther than this many steps from its predictor diverged


# ---------------------------------------------------------------------------------------------------
# the extended system


class _Domain(Exception):
    pass


class _Extended:
    """G and g of the extended system at (U, lam1, lam2) for one orbit's shooting layout."""

    def __init__(self, system, param1, param2, kind, orbit: PeriodicOrbit, sigma1, sigma2):
        self.fam2 = Family(system, param2)
        self.param1 = param1
        self.kind = kind
        self.like = orbit.map
        self.p = orbit.period
        self.multiple = orbit.settings.get("shooting") == "multiple"
        self.npts = self.p if self.multiple else 1
        self.sigma = np.array([sigma1, sigma2], dtype=float)
        self._fam1 = {}
        self.sign = 1.0 if kind == "period_doubling" else -1.0     # A = M + sign I
        self.b = None
        self.c = None
        self.keep = None            # state indices of the reduced monodromy
        self.frozen = np.zeros(0, dtype=np.int64)
        self.integrations = 0
        self.s0 = None

    def map_at(self, l1, l2):
        try:
            f1 = self._fam1.get(l2)
            if f1 is None:
                f1 = Family(self.fam2.at(l2), self.param1)
                if len(self._fam1) > 32:
                    self._fam1.clear()
                self._fam1[l2] = f1
            f1.check(l1)
            self.fam2.check(l2)
            return f1.map_at(l1, self.like)
        except (InputError, SceneError) as e:
            raise _Domain(str(e)) from None

    def matrix(self, Mr):
        """A of the bordered test: M + I (doubling), M - I (fold), or for Neimark-Sacker
        C2(M) - I with C2 the second compound (bialternate) matrix, eigenvalues mu_i mu_j
        (i < j): singular where a pair has mu_i mu_j = 1 (Kuznetsov 2004, sec. 10.3.3; Govaerts
        2000, ch. 4; also at a neutral saddle, a real pair with product 1: said in docs)."""
        n = Mr.shape[0]
        if self.kind != "neimark_sacker":
            return Mr + self.sign * np.eye(n)
        pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
        C = np.empty((len(pairs), len(pairs)))
        for a, (i, j) in enumerate(pairs):
            for b, (k, l) in enumerate(pairs):
                C[a, b] = Mr[i, k] * Mr[j, l] - Mr[i, l] * Mr[j, k]
        return C - np.eye(len(pairs))

    def distance(self, mu_c) -> float:
        if self.kind == "neimark_sacker":
            return abs(abs(mu_c) - 1.0)
        return abs(mu_c - (-1.0 if self.kind == "period_doubling" else 1.0))

    def reduced(self, M, s):
        Ms = M * s[None, :] / s[:, None]
        k = self.keep
        return Ms[np.ix_(k, k)]

    def test(self, A):
        n = A.shape[0]
        B = np.zeros((n + 1, n + 1))
        B[:n, :n] = A
        B[:n, n] = self.b
        B[n, :n] = self.c
        rhs = np.zeros(n + 1)
        rhs[n] = 1.0
        return float(np.linalg.solve(B, rhs)[n])

    def set_borders(self, A):
        U, _, Vt = np.linalg.svd(A)
        b, c = U[:, -1], Vt[-1]
        if self.b is not None:
            if float(b @ self.b) < 0:
                b = -b
            if float(c @ self.c) < 0:
                c = -c
        self.b, self.c = b, c

    def evaluate(self, V, Z, jacobian_shooting=True):
        """(r, g, A, J, steps, map) at V; raises _Domain, SolveError."""
        l1, l2 = V[-2] * self.sigma[0], V[-1] * self.sigma[1]
        m = self.map_at(l1, l2)
        sh = Shooting(m, self.p, self.multiple)
        if self.s0 is None:
            self.s0 = np.asarray(sh.s, dtype=float).copy()
        # fixed scales: a scene's scales follow its clearance (slider.s in units of the
        # clearance), and unknowns scaled at each parameter value would move the orbit by the
        # rescaling alone (a clearance change of 1e-4 gave a scaled residual of 6)
        sh.s = self.s0
        X = V[:-2].reshape(self.npts, m.n) * sh.s
        r, J, steps = sh.evaluate(X, Z, True)
        self.integrations += self.p
        if not (finite(r) and finite(J)):
            raise SolveError("the map is not finite at the iterate")
        M = orbit_monodromy(steps, self.p)
        if self.keep is None:
            fz = never_reset(m, steps)
            self.keep = np.setdiff1d(np.arange(m.n), fz)
            self.frozen = np.array([k * m.n + i for k in range(self.npts) for i in fz],
                                   dtype=np.int64)
        A = self.matrix(self.reduced(M, sh.s))
        if self.b is None:
            self.set_borders(A)
        g = self.test(A)
        return r, g, A, J, steps, m

    def system_jacobian(self, V, Z, r, g, J):
        """The (nU + 1) x (nU + 2) Jacobian of (G, g) in V: G_U analytic, the rest by forward
        differences."""
        nU = V.size - 2
        D = np.zeros((nU + 1, nU + 2))
        D[:nU, :nU] = J
        for j in range(nU + 2):
            if j < nU and j in self.frozen:
                continue
            h = FD_U if j < nU else FD_PARAM
            Vh = V.copy()
            Vh[j] += h
            rh, gh, _, _, _, _ = self.evaluate(Vh, [np.array(z) for z in Z])
            if j >= nU:
                D[:nU, j] = (rh - r) / h
            D[nU, j] = (gh - g) / h
        if self.frozen.size:
            D[:, self.frozen] = 0.0
        return D


def _critical_mu(ext: _Extended, o: PeriodicOrbit):
    """(mu_c, its uncertainty, the other deciding multipliers)."""
    mu = o.multipliers
    err = np.asarray(o.multiplier_error, dtype=float)
    if o.continuum and mu.size:
        k = int(np.argmin(np.abs(mu - 1.0)))
        mu, err = np.delete(mu, k), (np.delete(err, k) if err.size == o.multipliers.size else err)
    if ext.kind == "neimark_sacker":
        # the pair nearest the unit circle (its member with Im > 0, where there is one)
        score = np.abs(np.abs(mu) - 1.0) + np.where(mu.imag >= 0, 0.0, 1e-12)
        k = int(np.argmin(score))
    else:
        k = int(np.argmin(np.abs(mu - (-1.0 if ext.kind == "period_doubling" else 1.0))))
    e = float(err[k]) if err.size > k else 0.0
    return mu[k], max(e, o.residual * max(1.0, abs(mu[k]))), np.delete(mu, k)


def _corrector(ext, V_pred, Z, t_vec, fix2, tol, gtol, max_iter=10, info=None,
               max_move=math.inf):
    """Newton on [G; g; t.(V - V_pred)] (or lam2 fixed at fix2 / sigma2). Returns (V, Z, its,
    D) or None (info: why). An iterate farther than ``max_move`` from V_pred (the Newton
    diverging: a forcing frequency heading to 0 makes one period endless) counts as a
    failure."""
    info = {} if info is None else info
    info.pop("domain", None)
    V = V_pred.copy()
    polished = None
    Z = [np.array(z) for z in Z]
    for it in range(1, max_iter + 2):
        if it == max_iter + 1 and polished is None:
            break
        try:
            r, g, A, J, steps, m = ext.evaluate(V, Z)
            if polished is None:
                D = ext.system_jacobian(V, Z, r, g, J)
            else:
                # the step past the tolerances: the last point's finite-difference columns (it
                # moved by less than the tolerances) with this point's analytic G_U, not a
                # fresh Jacobian (n p + 2 tangent integrations saved per curve point)
                D = polished[3].copy()
                nU = V.size - 2
                D[:nU, :nU] = J
                if ext.frozen.size:
                    D[:, ext.frozen] = 0.0
        except _Domain as e:
            if polished is not None:
                return polished[:6]
            info["why"] = f"domain: {e}"
            info["domain"] = True
            return None
        except SolveError as e:
            if polished is not None:
                return polished[:6]
            info["why"] = f"the integration failed ({e})"
            return None
        res = float(np.max(np.abs(r)))
        info["residual"], info["condition"] = res, g
        if fix2 is None:
            last = float(t_vec @ (V - V_pred))
            row = t_vec
        else:
            last = V[-1] - fix2 / ext.sigma[1]
            row = np.zeros(V.size)
            row[-1] = 1.0
        if polished is not None:
            # one Newton step past the tolerances (quadratic convergence): kept where it did not
            # make the residuals worse, so that a point is not left at the tolerance's edge (a
            # residual of 1e-8 moved a fold of the hardening Duffing by 3e-8 in the frequency)
            Vp, Zp, itp, Dp, rp, gp, resp = polished
            if res <= max(resp, 1e-3 * tol) and abs(g) <= max(abs(gp), 1e-3 * gtol) \
                    and abs(last) <= 1e-9:
                return V, Z, it, D, r, g
            return Vp, Zp, itp, Dp, rp, gp
        if res <= tol and abs(g) <= gtol and abs(last) <= 1e-9:
            polished = (V.copy(), [np.array(z) for z in Z], it, D, r, g, res)
        F = np.concatenate([r, [g, last]])
        Af = np.vstack([D, row[None, :]])
        try:
            dV = np.linalg.lstsq(Af, -F, rcond=1e-12)[0]
        except np.linalg.LinAlgError:
            info["why"] = "the extended system's matrix is singular"
            return None
        if ext.frozen.size:
            dV[ext.frozen] = 0.0
        V = V + dV
        if float(np.linalg.norm(V - V_pred)) > max_move:
            if polished is not None:
                return polished[:6]
            info["why"] = (f"the corrector diverged (moved {np.linalg.norm(V - V_pred):.3g} "
                           f"from the predictor, more than {max_move:.3g})")
            return None
        if ext.multiple:
            Z = [steps[(i - 1) % ext.p].z for i in range(ext.p)]
    info["why"] = f"no convergence in {max_iter} iterations"
    return None


def _tangent(D, prev=None):
    keep = np.where(np.any(D != 0.0, axis=0))[0]
    _, _, vt = np.linalg.svd(D[:, keep])
    t = np.zeros(D.shape[1])
    t[keep] = vt[-1]
    t /= np.linalg.norm(t)
    if prev is not None and float(t @ prev) < 0:
        t = -t
    return t


def _point(ext, V, Z, D, r, g_V, tol):
    """The polished PeriodicOrbit at V and the point's record. tolerance1: how far param1 may
    be from the curve at this param2: twice the next Newton step's param1 component (param2
    fixed) from the residuals (r, g) left at V (linear convergence at a rate <= 1/2), plus the
    multipliers' uncertainty u carried through
    the test function (|dg/dmu| taken as 1: the bordered g of a simple multiplier with the
    singular vectors as borders is -+(mu -+ 1) to first order)."""
    l1, l2 = V[-2] * ext.sigma[0], V[-1] * ext.sigma[1]
    m = ext.map_at(l1, l2)
    X = V[:-2].reshape(ext.npts, m.n) * ext.s0
    o = periodic_orbit(m, ext.p, X, z=Z[0], tol=tol, check=True, max_iter=3,
                       shooting="multiple" if ext.multiple else "single")
    ext.integrations += 2 * ext.p
    A = ext.matrix(ext.reduced(o.monodromy, ext.s0))
    g = ext.test(A)
    ext.set_borders(A)
    mu_c, u, _ = _critical_mu(ext, o)
    nU = V.size - 2
    E = np.vstack([D, np.eye(1, V.size, V.size - 1)])
    try:
        step_r = np.linalg.lstsq(E, -np.concatenate([r, [g_V, 0.0]]), rcond=1e-12)[0][nU]
        step_u = np.linalg.lstsq(E, np.eye(1, nU + 2, nU)[0], rcond=1e-12)[0][nU]
        # the Jacobian's finite-difference columns make the corrector converge linearly: with a
        # rate <= 1/2 the distance left is <= twice the next step
        tol1 = (2.0 * abs(step_r) + u * abs(step_u)) * ext.sigma[0]
    except np.linalg.LinAlgError:
        tol1 = math.nan
    return o, l1, l2, g, ext.distance(mu_c), tol1


def _others(ext, o):
    """Test functions of the codim-2 points on the curve: the other deciding multipliers'
    prod(mu - 1) and prod(mu + 1) (real parts)."""
    _, _, rest = _critical_mu(ext, o)
    if rest.size == 0:
        return 1.0, 1.0
    return float(np.real(np.prod(rest - 1.0))), float(np.real(np.prod(rest + 1.0)))


def continue_bifurcation(system, bif: Bifurcation, param2, range2, *, param, stops=(),
                         step: float | None = None, scale1: float | None = None,
                         max_points: int = 100, tol: float | None = None,
                         gtol: float | None = None, progress=None) -> BifurcationCurve:
    """Follow a located period doubling, fold, Neimark-Sacker or grazing point ``bif`` (of a
    branch continued in ``param``; grazing: :func:`nld.analysis.grazing_curve.continue_grazing`)
    in
    ``param2`` over ``range2`` = (a, b), which must contain the system's value of param2.

    system: the system of the branch (its value of ``param`` is replaced by ``bif.value``).
    param:  the branch's parameter (the one ``bif.value`` is a value of); param2: the second
            parameter (a scene key or a name / index of p, as ``continue_orbit`` takes them).
    stops:  param2 values (inside the range) where the curve lands exactly (for comparison with
            one-parameter continuation at those values, or a chaos map's columns).
    step:   the first arclength step, in units of (range2 width)/50 when the curve runs along
            param2 (default 1); adaptive (x1.5 after a corrector of <= 3 iterations, /2 after a
            failure down to step/1000), at most 4 steps.
    scale1: param1's arclength unit (default 0.02 |bif.value|, 0.02 when it is 0); param2's is
            0.02 of the range. The shooting unknowns are in the map's scales at the start
            (fixed along the curve).
    tol:    the shooting residual's tolerance (default the orbit's); gtol: the test function's
            (default tol).
    progress: optional callable (points in this direction, max_points, value1, value2) after
            each curve point.
    Returns a :class:`BifurcationCurve`. Bad input raises InputError before any integration.
    """
    if not isinstance(bif, Bifurcation):
        raise InputError("bif: give a Bifurcation from continue_orbit(...).bifurcations")
    if bif.kind not in CURVE_KINDS:
        raise InputError(f"bif.kind = {bif.kind!r}: continue_bifurcation follows "
                         f"{', '.join(CURVE_KINDS)} (docs/codim2.md: what remains)")
    if bif.kind == "grazing":
        from nld.analysis.grazing_curve import continue_grazing
        return continue_grazing(system, bif, param2, range2, param=param, stops=stops,
                                step=step, max_points=max_points, tol=tol, progress=progress)
    fam1, fam2, a, b, lo, hi, stops, h0 = curve_inputs(system, bif, param, param2, range2, stops,
                                                       max_points, step)
    o0 = bif.orbit
    v20 = fam2.value0
    sigma2 = max(abs(b - a) * ARCLENGTH_PARAM_UNIT, 1e-300)
    sigma1 = float(scale1) if scale1 is not None else \
        (ARCLENGTH_PARAM_UNIT * abs(bif.value) if bif.value != 0 else ARCLENGTH_PARAM_UNIT)
    if not (sigma1 > 0 and math.isfinite(sigma1)):
        raise InputError(f"scale1 = {scale1!r}: must be a positive number")
    tol = o0.tolerance if tol is None else float(tol)
    gtol = tol if gtol is None else float(gtol)
    t_start = time.perf_counter()
    ext = _Extended(system, param, param2, bif.kind, o0, sigma1, sigma2)
    m0 = ext.map_at(bif.value, v20)
    ext.s0 = np.asarray(m0.scales, dtype=float).copy()
    U0 = (np.asarray(o0.points[:ext.npts]) / ext.s0).ravel()
    V0 = np.concatenate([U0, [bif.value / sigma1, v20 / sigma2]])
    Z0 = [np.array(z) for z in o0.z[:ext.npts]]
    info = {}
    first = _corrector(ext, V0, Z0, None, v20, tol, gtol, max_iter=15, info=info)
    if first is None:
        raise SolveError(f"the start point of the {bif.kind} curve did not converge at "
                         f"{fam2.label} = {v20:g}: {info.get('why', '')} (residual "
                         f"{info.get('residual', math.nan):.3g}, condition "
                         f"{info.get('condition', math.nan):.3g})")
    V, Z, _, D, r, gV = first
    start = _point(ext, V, Z, D, r, gV, tol)
    start = start[:2] + (v20,) + start[3:] + (V, Z, D)
    t0 = _tangent(D)
    eps = 1e-12 * max(abs(lo), abs(hi), sigma2)
    targets = sorted(set([lo, hi] + stops))
    segments, ends = {}, []
    h_max, h_min = 4.0 * h0, 1e-3 * h0
    for direction in (-1, 1):
        pts = []
        segments[direction] = pts
        end2 = lo if direction < 0 else hi
        if abs(end2 - v20) <= eps:
            ends.append(CurveEnd(direction, start[1], v20, "range_end",
                                 "the start value is the range's end"))
            continue
        t = t0 if t0[-1] * direction > 0 else -t0
        V, Z, D = start[6], start[7], start[8]
        h = h0
        end = None
        while end is None:
            if len(pts) + 1 >= max_points:
                end = CurveEnd(direction, V[-2] * sigma1, V[-1] * sigma2, "step_limit",
                               f"{max_points} points used in this direction")
                break
            l2 = V[-1] * sigma2
            ok, landed, info = None, None, {}
            while h >= h_min:
                V_pred = V + h * t
                p2 = V_pred[-1] * sigma2
                cross = [x for x in targets if (x - l2) * (p2 - x) > 0 and abs(x - l2) > eps]
                if cross and abs(t[-1]) > 1e-12:
                    x = min(cross, key=lambda y: abs(y - l2))
                    hl = (x / sigma2 - V[-1]) / t[-1]
                    ok = _corrector(ext, V + hl * t, Z, t, x, tol, gtol, info=info,
                                    max_move=MAX_MOVE * max(abs(hl), h_min))
                    if ok is not None:
                        landed = x
                        break
                else:
                    ok = _corrector(ext, V_pred, Z, t, None, tol, gtol, info=info,
                                    max_move=MAX_MOVE * h)
                    if ok is not None and not (lo - eps <= ok[0][-1] * sigma2 <= hi + eps):
                        ok = None
                    if ok is not None:
                        break
                h *= 0.5
            if ok is None:
                reason = "domain" if info.get("domain") else "newton_failure"
                end = CurveEnd(direction, V[-2] * sigma1, V[-1] * sigma2, reason,
                               f"{info.get('why', '')} (residual {info.get('residual', math.nan):.3g},"
                               f" condition {info.get('condition', math.nan):.3g}, tolerances "
                               f"{tol:.3g} / {gtol:.3g}; step down to {h:.3g})")
                break
            V, Z, its, D, r, gV = ok
            try:
                rec = _point(ext, V, Z, D, r, gV, tol)
            except _Domain as e:
                end = CurveEnd(direction, V[-2] * sigma1, V[-1] * sigma2, "domain", str(e))
                break
            if landed is not None:
                rec = rec[:2] + (landed,) + rec[3:]      # exactly the value asked for
            t = _tangent(D, t)
            pts.append(rec + (landed is not None, t.copy()))
            if progress is not None:
                progress(len(pts), max_points, rec[1], rec[2])
            if landed is not None and abs(landed - end2) <= eps:
                end = CurveEnd(direction, rec[1], landed, "range_end", "the range's end")
            elif landed is not None and (abs(landed - lo) <= eps or abs(landed - hi) <= eps):
                end = CurveEnd(direction, rec[1], landed, "turned_back",
                               "the range's other end, after the curve turned back in "
                               f"{fam2.label}")
            if its <= 3:
                h = min(1.5 * h, h_max)
        ends.append(end)
    # curve order: from the lower-param2 side through the start
    s_lo = list(reversed(segments.get(-1, [])))
    s_hi = segments.get(1, [])
    start_rec = start[:6] + (abs(v20 - lo) <= eps or abs(v20 - hi) <= eps or v20 in stops, t0)
    recs = s_lo + [start_rec] + s_hi
    curve = BifurcationCurve(bif.kind, param, param2, o0.period,
                             [r[1] for r in recs], [r[2] for r in recs], [r[0] for r in recs],
                             [r[3] for r in recs], [r[4] for r in recs], [r[5] for r in recs],
                             [bool(r[6]) for r in recs], [], ends, "", {})
    curve.special_points = _special(ext, recs, fam1.label, fam2.label) + \
        domain_exits(curve, fam2.label)
    curve.message = ("completed" if curve.completed else
                     "; ".join(f"direction {e.direction:+d} ended at ({e.value1:g}, {e.value2:g}): "
                               f"{e.reason}: {e.detail}" for e in ends))
    curve.settings = {"kind": bif.kind, "param": param, "param2": param2, "range2": [a, b],
                      "stops": stops, "start": [bif.value, v20], "step": h0,
                      "scale1": sigma1, "scale2": sigma2, "tol": tol, "gtol": gtol,
                      "rtol": o0.settings.get("rtol"), "map": o0.settings.get("map"),
                      "fd_u": FD_U, "fd_param": FD_PARAM, "jacobian": "G_U analytic (tangent "
                      "integration); G_lam, g_U, g_lam forward differences",
                      "integrations": ext.integrations,
                      "wall_s": time.perf_counter() - t_start}
    return curve


def _bracketed(kind, ra, rb, i, w, detail):
    """A SpecialPoint at the fraction w in [0, 1] from curve point ra to rb, with the
    uncertainty of a sign change known only to lie between them (SpecialPoint)."""
    w = min(max(float(w), 0.0), 1.0)
    d1, d2 = rb[1] - ra[1], rb[2] - ra[2]
    far = max(w, 1.0 - w)
    tol = max(_finite_or0(ra[5]), _finite_or0(rb[5]))
    return SpecialPoint(kind, ra[1] + w * d1, ra[2] + w * d2, (i, i + 1), detail,
                        far * abs(d1) + tol, far * abs(d2))


def _finite_or0(x) -> float:
    return float(x) if x is not None and math.isfinite(x) else 0.0


def _special(ext, recs, label1, label2):
    """The codim-2 points between consecutive curve points (module docstring; docs/codim2.md):
    each the linear interpolation of its test function's sign change, with the bracket as its
    uncertainty."""
    out = []
    kind = ext.kind
    for i in range(len(recs) - 1):
        ra, rb = recs[i], recs[i + 1]
        ta, tb = ra[7], rb[7]
        # tangents are oriented along each direction's travel; re-orient b along a
        if float(ta @ tb) < 0:
            tb = -tb
        qa, qb = ta[-2:] / np.linalg.norm(ta[-2:]), tb[-2:] / np.linalg.norm(tb[-2:])
        if kind == "fold" and float(qa @ qb) < 0 and (ta[-1] * tb[-1] < 0 or
                                                      ta[-2] * tb[-2] < 0):
            # the curve's projection on the parameter plane reverses: a cusp (two fold curves
            # meet tangentially; Kuznetsov 2004, sec. 8.2 and 9.5). Located where the reversing
            # parameter's direction (the tangent's component) changes sign
            k = -1 if ta[-1] * tb[-1] < 0 else -2
            w = ta[k] / (ta[k] - tb[k])
            out.append(_bracketed("cusp", ra, rb, i, w,
                                  "the fold curve's projection on the parameter plane reverses "
                                  f"(the two folds of the branch meet; {label2 if k == -1 else label1}"
                                  " direction changes sign)"))
            continue
        for k, lab in ((-2, label1), (-1, label2)):
            # (a parameter that stays constant along the curve has a tangent component of
            # rounding size whose sign flips at random: not a turning point)
            if ta[k] * tb[k] < 0 and max(abs(ta[k]), abs(tb[k])) > TURN_NOISE:
                w = ta[k] / (ta[k] - tb[k])
                out.append(_bracketed("turning_point", ra, rb, i, w,
                                      f"the curve turns back in {lab}"))
        fa, pa = _others(ext, ra[0])
        fb, pb = _others(ext, rb[0])
        checks = [] if kind == "neimark_sacker" else \
            [("fold_flip", pa, pb, "a second multiplier through -1 on a fold curve"),
             ("resonance_1_1", fa, fb, "a second multiplier through +1 on a fold curve")] \
            if kind == "fold" else \
            [("fold_flip", fa, fb, "a multiplier through +1 on a period-doubling curve"),
             ("resonance_1_2", pa, pb, "a second multiplier through -1 on a period-doubling "
                                       "curve")]
        for name, xa, xb, why in checks:
            if xa * xb < 0:
                w = xa / (xa - xb)
                out.append(_bracketed(name, ra, rb, i, w,
                                      f"{why} (bracketed between curve points {i}, {i + 1})"))
        if ra[0].onsets_per_period != rb[0].onsets_per_period:
            out.append(_bracketed("contact_change", ra, rb, i, 0.5,
                                  f"contact onsets per period {ra[0].onsets_per_period} -> "
                                  f"{rb[0].onsets_per_period}: the curve meets a grazing curve"))
    return out


CURVE_STYLES = {"period_doubling": ("C3", "-", "period doubling"), "fold": ("C0", "-", "fold"),
                "neimark_sacker": ("C2", "-", "Neimark-Sacker"), "grazing": ("C1", "--", "grazing")}
SPECIAL_MARKERS = {"cusp": "^", "turning_point": "o", "fold_flip": "s", "resonance_1_1": "D",
                   "resonance_1_2": "d", "contact_change": "x", "leaves_domain": "|"}


def plot_curves(curves, *, ax=None, x_scale: float = 1.0, y_scale: float = 1.0,
                x_label: str | None = None, y_label: str | None = None, title: str | None = None,
                legend: bool = True):
    """Bifurcation curves in the (param1, param2) plane (param1 across, param2 up), each kind in
    its colour (:data:`CURVE_STYLES`), the codim-2 points marked (:data:`SPECIAL_MARKERS`) with
    their uncertainty as error bars. ``ax``: draw into it (e.g. over a chaos map); returns the
    figure."""
    from nld.output.plots import figure_axes
    fig, ax = figure_axes(ax)
    shown = set()
    for c in curves:
        col, ls, name = CURVE_STYLES.get(c.kind, ("k", "-", c.kind))
        x = np.asarray(c.values1, dtype=float) * x_scale
        y = np.asarray(c.values2, dtype=float) * y_scale
        ax.plot(x, y, ls, color=col, lw=1.6, marker=".", ms=3,
                label=f"{name} curve" if name not in shown else None)
        shown.add(name)
        for s in c.special_points:
            mk = SPECIAL_MARKERS.get(s.kind, "*")
            ax.errorbar([s.value1 * x_scale], [s.value2 * y_scale],
                        xerr=[_finite_or0(s.uncertainty1) * x_scale],
                        yerr=[_finite_or0(s.uncertainty2) * y_scale], fmt=mk, color="k",
                        ms=6, mfc="none", capsize=2,
                        label=s.kind.replace("_", " ") if s.kind not in shown else None)
            shown.add(s.kind)
    if x_label is not None or curves:
        ax.set_xlabel(x_label if x_label is not None else str(curves[0].param1))
    if y_label is not None or curves:
        ax.set_ylabel(y_label if y_label is not None else str(curves[0].param2))
    if title is not None:
        ax.set_title(title)
    if legend and shown:
        ax.legend(fontsize=7)
    return fig
