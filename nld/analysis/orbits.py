"""Periodic orbits of maps and of flows through contact: Newton shooting, Floquet multipliers, UPOs.

A period-p orbit of a map P (the stroboscopic map of a forced flow or a scene: one crank
revolution; a Poincaré map; any :class:`~nld.systems.DiscreteMap`) is a zero of
G(x) = P^p(x) - x. :func:`periodic_orbit` solves it by Newton's method with the map's Jacobian,
which for a flow is the monodromy matrix from the tangent integrator with saltation at every
contact event (``nld.systems.derived``):

* single shooting: the unknown is the orbit's first section point, the Newton matrix
  M - I with M = M_{p-1} ... M_0 the product of the one-period monodromies;
* multiple shooting (default for p >= 2): the unknowns are all p section points, the residuals
  P(x_i) - x_{i+1 mod p}, the Newton matrix block-cyclic with blocks M_i and -I (Ascher,
  Mattheij & Russell 1995, ch. 4; Seydel 2010, ch. 7.3), which keeps the conditioning of a
  strongly unstable orbit at that of one period.

The Newton steps are computed in the scaled variables x / scales by least squares (SVD: a
neutral direction, e.g. the memory of a contact law in permanent contact, gets no step), damped by
backtracking on the scaled residual and, where that fails, by Levenberg-Marquardt. Converged
means the scaled max-norm residual is <= ``tol`` (default 1e3 * rtol for a flow, 1e-10 for a
map): the accuracy at which the integration can reproduce a period. A Newton that does not get
there says so (``converged`` False, ``message``) and returns the best iterate.

Floquet multipliers: the eigenvalues of the orbit's monodromy M, with an uncertainty from a
second evaluation at 10 rtol (|mu(rtol) - mu(10 rtol)|, an upper estimate of the error at rtol).
Stability (``PeriodicOrbit.stability``) is decided by the multipliers that are not the contact
memory's neutral one: an orbit on which a memory entry is never reset (permanent contact or no
contact) has a multiplier 1 in the memory direction (one of a continuum of orbits: ``memory_neutral``)
which is left out and said so. With mu_max the largest remaining |mu| and u its uncertainty
(``multiplier_uncertainty``: the largest |mu(rtol) - mu(10 rtol)| of the deciding multipliers, at
least the scaled residual times max(1, mu_max), the part of the error a point off the orbit by the
residual leaves; for a map given exactly only that floor): "stable" when mu_max + u < 1, "unstable"
when mu_max - u > 1, "neutral" otherwise (and for a continuum with nothing else deciding); never
"stable" within the uncertainty of 1. The determinant of M is checked against the Liouville
formula ln|det M| = int tr(df/dy) dt + sum ln|det S| (S the saltation matrices) where no memory is
reset (docs/orbits.md). :func:`find_orbits` lists the distinct orbits of periods 1..P from close
returns of the section (Auerbach et al. 1987; So et al. 1996) refined by Newton; for a map also
from the attractor and a grid, as the stabilising transformations of Schmelcher & Diakonos
(1997) and Davidchack & Lai (1999) would be seeded.

Units: section points in the flow's SI units (docs/orbits.md); min_approach_speed in m/s for a
scene (the normal approach speed at contact onset, the distance to grazing).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import itertools

import numpy as np
from numba import njit

from nld.errors import InputError, SolveError
from nld.systems.derived import NumbaMap, PoincareMap, StroboscopicMap, as_map, never_reset

__all__ = ["map_source", "PeriodicOrbit", "periodic_orbit", "find_orbits", "floquet", "check_period",
           "section_points", "prime_period"]

DEFAULT_MAX_ITER = 30
# a Newton step that leaves more than this fraction of the residual counts towards a stall (three
# in a row end the Newton)
STALL_RATIO = 0.9


def check_period(period, field: str = "period") -> int:
    """period as an int >= 1, else InputError naming ``field``."""
    if isinstance(period, bool) or not isinstance(period, (int, np.integer)):
        if isinstance(period, float) and period.is_integer() and period >= 1:
            return int(period)
        raise InputError(f"{field} = {period!r}: must be a whole number of periods >= 1")
    if period < 1:
        raise InputError(f"{field} = {period!r}: must be a whole number of periods >= 1")
    return int(period)


# the most shooting unknowns (period x augmented state size): the multiple-shooting Newton matrix
# is dense, (p N)^2 doubles, and its SVD costs ~ (p N)^3 flops: 4000 unknowns are 128 MB and tens
# of seconds; a longer period is refused before any integration (issue 37, class 1)
MAX_SHOOTING_UNKNOWNS = 4000


def max_period_for(n_states: int) -> int:
    """The longest period whose shooting fits MAX_SHOOTING_UNKNOWNS for a map of n_states."""
    return max(1, MAX_SHOOTING_UNKNOWNS // max(1, int(n_states)))


def check_size(period: int, n_states: int, field: str = "period") -> None:
    """InputError naming ``field`` when a period-``period`` orbit of a map with ``n_states``
    (augmented) states is beyond MAX_SHOOTING_UNKNOWNS, with the largest value that fits."""
    most = max_period_for(n_states)
    if period > most:
        raise InputError(f"{field} = {period}: too long: shooting over {period} periods has "
                         f"{period * n_states:.3g} unknowns ({n_states} per period), a dense "
                         f"Newton matrix of {8.0 * (period * n_states) ** 2 / 2**30:.3g} GiB; at "
                         f"most {most} ({MAX_SHOOTING_UNKNOWNS} unknowns)")


def _whole(value, field: str, least: int) -> int:
    """value as an int >= least, else InputError naming ``field``."""
    if isinstance(value, (float, np.floating)) and float(value).is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
        raise InputError(f"{field} = {value!r}: must be a whole number >= {least}")
    return int(value)



def map_source(m):
    """The system under the map ``m`` of an orbit analysis (``nld.systems.derived.as_map``): the
    flow of a derived map, the DiscreteMap of a wrapped one; whose parameters the map has."""
    return m.system if isinstance(m, NumbaMap) else m.flow

@dataclass
class PeriodicOrbit:
    """A period-p orbit of a map (section points of a flow's periodic motion).

    period:      p (map iterations: crank revolutions of a scene).
    points:      (p, N) the orbit's points on the section, augmented state (the flow's state then
                 the memory entries; ``state_names``), SI units.
    z:           the discrete state at each point (labels: contact and stick/slip modes ...).
    residual:    scaled max-norm of P(x_i) - x_{i+1} at the returned points; ``tolerance`` the
                 value it had to reach; ``converged`` whether it did; ``iterations`` Newton steps.
    multipliers: Floquet multipliers (complex, by decreasing modulus) and ``multiplier_error``
                 (|mu(rtol) - mu(10 rtol)|; 0 for a map given exactly); ``monodromy`` (N, N).
    stable:      True only when ``stability`` is "stable", False when "unstable", else None.
    multiplier_uncertainty: the uncertainty u of the largest deciding |mu| (module docstring:
                 from the second evaluation at 10 rtol, at least residual x max(1, |mu|)).
    return_times: the flow time of each of the p map steps (s; the forcing period, or a Poincaré
                 map's return times; empty for a DiscreteMap); ``time_period`` their sum.
    onsets:      contact onsets per contact event over the whole period (a scene: per clearance
                 joint); ``onsets_per_period`` their sum; ``min_approach_speed`` the smallest
                 normal approach speed at an onset on the orbit (m/s; inf: no onset).
    continuum:   True when a memory entry is never reset on the orbit (permanent contact or no
                 contact): it is then a neutral direction (multiplier 1) and the orbit one of a
                 continuum, selected by the history (docs/orbits.md, "Memory state");
                 ``memory_neutral`` is the same.
    det_check:   {"log_det_M", "liouville", "difference"} or None where not applicable.
    """
    period: int
    points: np.ndarray
    z: list
    residual: float
    tolerance: float
    converged: bool
    iterations: int
    message: str
    multipliers: np.ndarray
    multiplier_error: np.ndarray
    monodromy: np.ndarray
    stable: bool | None
    onsets: np.ndarray
    onsets_per_period: int
    min_approach_speed: float
    continuum: bool
    det_check: dict | None
    state_names: list
    system_name: str
    settings: dict = field(default_factory=dict)
    map: object = field(default=None, repr=False)
    multiplier_uncertainty: float = math.nan
    return_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    n_memory_neutral: int = 0

    @property
    def max_abs_multiplier(self) -> float:
        return float(np.max(np.abs(self.multipliers))) if self.multipliers.size else math.nan

    @property
    def memory_neutral(self) -> bool:
        """The orbit has the contact memory's neutral multiplier (1, a memory entry never reset:
        one of a continuum of orbits); stability is then decided by the other multipliers."""
        return bool(self.continuum)

    @property
    def deciding_multipliers(self) -> np.ndarray:
        """The multipliers that decide stability: the memory's neutral ones (those nearest 1,
        one per never-reset memory entry) left out."""
        return _deciding(self.multipliers, self.n_memory_neutral)

    @property
    def stability(self) -> str:
        """"stable", "unstable" or "neutral" (module docstring): decided by the multipliers other
        than the contact memory's neutral one; "neutral" when the largest of them is within
        ``multiplier_uncertainty`` of 1 in modulus, or nothing else decides. "unconverged" for an
        orbit whose Newton did not converge (no orbit, no stability)."""
        if not self.converged:
            return "unconverged"
        return {True: "stable", False: "unstable", None: "neutral"}[self.stable]

    @property
    def stability_text(self) -> str:
        """The stability in words, with the memory direction named where it is neutral."""
        st = self.stability
        if self.memory_neutral and st != "unconverged":
            return (f"{st} (neutral in the contact memory's direction, multiplier 1: one of a "
                    f"continuum; stability from the other multipliers)")
        return st

    @property
    def time_period(self) -> float:
        """The orbit's period in time (s): the sum of its map steps' flow times (p forcing
        periods; a Poincaré map's return times); nan for a DiscreteMap."""
        return float(np.sum(self.return_times)) if len(self.return_times) else math.nan

    def trajectory(self, n_per_period: int = 200):
        """The flow's states along the whole orbit: (t (s) from the first point, Y), n_per_period
        samples per map step (a stroboscopic map's period, or a Poincaré map's return time)."""
        m = self.map
        if not isinstance(m, (StroboscopicMap, PoincareMap)):
            raise InputError("trajectory(): only for an orbit of a flow's stroboscopic or "
                             "Poincaré map")
        if isinstance(n_per_period, bool) or not isinstance(n_per_period, (int, np.integer)) \
                or n_per_period < 2:
            raise InputError(f"n_per_period = {n_per_period!r}: must be an integer >= 2")
        ts, ys = [], []
        t_start = 0.0
        for i in range(self.period):
            if isinstance(m, StroboscopicMap):
                t, Y = m.trajectory(self.points[i], self.z[i], n_per_period + 1)
                dt = m.T
            else:
                dt = float(self.return_times[i])
                y, zz = m.unpack(self.points[i], self.z[i], relabel=True)
                te = m.t0 + dt * np.arange(n_per_period + 1) / n_per_period
                out, _, _ = m._plain(y, zz, m.t0, te[-1], t_eval=te)
                t, Y = te - m.t0, out.Y[:n_per_period + 1].copy()
            ts.append(t[:-1] + t_start)
            ys.append(Y[:-1])
            t_start += dt
        return np.concatenate(ts), np.vstack(ys)

    def observe(self, columns, n_per_period: int = 200):
        """A scene orbit's table columns (``nld simulate`` columns, SI units) along the whole
        orbit: a DataFrame with ``t`` (s from the first section point) and the columns."""
        import pandas as pd
        m = self.map
        if isinstance(n_per_period, bool) or not isinstance(n_per_period, (int, np.integer)) \
                or n_per_period < 2:
            raise InputError(f"n_per_period = {n_per_period!r}: must be an integer >= 2")
        if not isinstance(m, StroboscopicMap) or not m.flow.is_scene:
            raise InputError("observe(): only for an orbit of a scene's stroboscopic map")
        kern = m.flow.kernel
        cols = [columns] if isinstance(columns, str) else list(columns)
        bad = [c for c in cols if c not in kern.columns]
        if bad:
            raise InputError(f"column {bad[0]!r}: no such column; available: {', '.join(kern.columns)}")
        idx = [list(kern.columns).index(c) for c in cols]
        row = np.empty(len(kern.columns))
        out = {"t": []}
        out.update({c: [] for c in cols})
        for i in range(self.period):
            t, Y, Zs = m.trajectory(self.points[i], self.z[i], n_per_period + 1, with_z=True)
            for k in range(n_per_period):
                kern.module.observe(float(m.t0 + t[k]), np.ascontiguousarray(Y[k]), m.flow.p,
                                    np.ascontiguousarray(Zs[k]), row)
                out["t"].append(t[k] + i * m.T)
                for c, j in zip(cols, idx):
                    out[c].append(row[j])
        return pd.DataFrame(out)

    def to_dict(self) -> dict:
        """The JSON form of ``nld orbits --json``."""
        return {"period": self.period, "points": self.points.tolist(),
                "state_names": list(self.state_names),
                "residual": self.residual, "tolerance": self.tolerance,
                "converged": self.converged, "iterations": self.iterations,
                "message": self.message,
                "multipliers": [[float(m.real), float(m.imag)] for m in self.multipliers],
                "multiplier_error": [float(e) for e in self.multiplier_error],
                "max_abs_multiplier": self.max_abs_multiplier, "stable": self.stable,
                "stability": self.stability, "memory_neutral": self.memory_neutral,
                "multiplier_uncertainty": self.multiplier_uncertainty,
                "time_period": (None if not math.isfinite(self.time_period)
                                else self.time_period),
                "return_times": [float(t) for t in self.return_times],
                "onsets_per_period": int(self.onsets_per_period),
                "onsets": [int(o) for o in self.onsets],
                "min_approach_speed": (None if not math.isfinite(self.min_approach_speed)
                                       else self.min_approach_speed),
                "continuum": self.continuum, "det_check": self.det_check}


# ---------------------------------------------------------------------------------------------------
# evaluation of the shooting residual


class Shooting:
    """The residual and Jacobian of (multiple) shooting on a map, in scaled variables."""

    def __init__(self, m, p: int, multiple: bool):
        self.m = m
        self.p = p
        self.multiple = multiple
        self.s = np.asarray(m.scales, dtype=float)
        self.N = m.n

    def frozen(self, steps) -> np.ndarray:
        """Columns of the unknowns held fixed: memory entries never reset on the evaluated
        orbit (permanent contact or none: a history value, a neutral direction of the map;
        docs/orbits.md, "Memory state")."""
        idx = never_reset(self.m, steps)
        if idx.size == 0:
            return idx
        npts = self.p if self.multiple else 1
        return np.array([k * self.N + i for k in range(npts) for i in idx], dtype=np.int64)

    def evaluate(self, X, Z, jacobian: bool):
        """Residual (scaled, flat), Jacobian (scaled) or None, the steps, the new labels."""
        m, p, N, s = self.m, self.p, self.N, self.s
        steps = []
        if self.multiple:
            r = np.empty(p * N)
            for i in range(p):
                st = m.step(X[i], Z[i], jacobian=jacobian, relabel=True)
                steps.append(st)
                r[i * N:(i + 1) * N] = m.difference(st.x, X[(i + 1) % p]) / s
            J = None
            if jacobian:
                J = np.zeros((p * N, p * N))
                for i in range(p):
                    J[i * N:(i + 1) * N, i * N:(i + 1) * N] = steps[i].M * s[None, :] / s[:, None]
                    j = (i + 1) % p
                    J[i * N:(i + 1) * N, j * N:(j + 1) * N] -= np.eye(N)
                fz = self.frozen(steps)
                if fz.size:
                    J[:, fz] = 0.0
            return r, J, steps
        x, z = X[0], Z[0]
        M = np.eye(N) if jacobian else None
        for i in range(p):
            st = m.step(x, z, jacobian=jacobian, relabel=i == 0)
            steps.append(st)
            if jacobian:
                M = st.M @ M
            x, z = st.x, st.z
        r = m.difference(x, X[0]) / s
        J = (M * s[None, :] / s[:, None] - np.eye(N)) if jacobian else None
        if jacobian:
            fz = self.frozen(steps)
            if fz.size:
                J[:, fz] = 0.0
        return r, J, steps

    def points_after(self, X, steps):
        """The section points implied by the steps (single shooting: the trajectory)."""
        if self.multiple:
            return X
        out = [X[0]]
        for st in steps[:-1]:
            out.append(st.x)
        return np.array(out)


def finite(a) -> bool:
    return bool(np.all(np.isfinite(a)))


def _solve_step(J, r, lam: float = 0.0):
    """Least-squares Newton step (SVD, relative cutoff 1e-12), or the LM step with lam."""
    if lam > 0.0:
        A = J.T @ J
        A[np.diag_indices_from(A)] += lam * (np.diag(A) + 1e-12)
        return np.linalg.solve(A, -J.T @ r)
    return np.linalg.lstsq(J, -r, rcond=1e-12)[0]


def _newton(sh: Shooting, X, Z, tol: float, max_iter: int, progress=None):
    """Damped Newton / Levenberg-Marquardt on the shooting residual. Returns (X, Z, r, J,
    steps, iterations, converged, message)."""
    p, N, s = sh.p, sh.N, sh.s

    def unflat(U):
        return U.reshape(p if sh.multiple else 1, N) * s

    def pack_X(Xs):
        return (np.asarray(Xs)[: (p if sh.multiple else 1)] / s).ravel()

    r, J, steps = sh.evaluate(X, Z, True)
    if not finite(r) or not finite(J):
        return X, Z, r, J, steps, 0, False, "the map is not finite at the guess"
    res = float(np.max(np.abs(r)))
    best = (res, X, Z, r, J, steps)
    it = 0
    message = ""
    lam = 0.0
    stalls = 0
    while res > tol and it < max_iter:
        it += 1
        if progress is not None:
            progress(it, res)
        U = pack_X(X)
        accepted = False
        for attempt in range(3):
            try:
                dU = _solve_step(J, r, lam)
            except np.linalg.LinAlgError:
                lam = max(1e-3, 10 * lam)
                continue
            alpha = 1.0
            while alpha >= 1.0 / 16:
                Xt = unflat(U + alpha * dU)
                Zt = [np.array(z) for z in Z]
                try:
                    full = alpha == 1.0
                    rt, Jt, st = sh.evaluate(Xt, Zt, full)
                except SolveError:
                    rt = None
                if rt is not None and finite(rt):
                    rest = float(np.max(np.abs(rt)))
                    if rest < (1.0 - 1e-4 * alpha) * res or rest <= tol:
                        if not full:
                            # the Jacobian at the accepted trial: a failed tangent integration
                            # (a step size underflow in a stiff contact) rejects the trial too
                            try:
                                rt, Jt, st = sh.evaluate(Xt, Zt, True)
                                rest = float(np.max(np.abs(rt)))
                            except SolveError:
                                Jt = None
                        if Jt is not None and finite(Jt) and finite(rt):
                            accepted = True
                            break
                alpha *= 0.25
            if accepted:
                break
            lam = max(1e-4, 10.0 * lam)     # Levenberg-Marquardt: shorter, gradient-like steps
        if not accepted:
            message = (f"Newton stalled at residual {res:.3g} (tolerance {tol:.3g}): no step "
                       f"reduces it (the guess may be far from an orbit, or the tolerance below "
                       f"the integration's accuracy)")
            break
        lam = lam / 10.0 if lam > 1e-6 else 0.0
        X = Xt
        if sh.multiple:
            # the labels at x_{i+1} are those the step from x_i arrived with
            Z = [st[(i - 1) % p].z for i in range(p)]
        # a step that cuts the residual by less than 10 % counts as a stall (damped steps that cut
        # it by a third each are progress: a flip saddle from a far guess)
        stalls = stalls + 1 if rest > STALL_RATIO * res else 0
        r, J, steps, res = rt, Jt, st, rest
        if res < best[0]:
            best = (res, X, Z, r, J, steps)
        if stalls >= 3:
            message = (f"Newton stalled at residual {res:.3g} (tolerance {tol:.3g}): the "
                       f"residual no longer falls (the integration's accuracy?)")
            break
    res, X, Z, r, J, steps = best
    # polish: Newton converges quadratically until the integration's accuracy; up to two more
    # full steps while each cuts the residual by 4 or more
    for _ in range(2 if res <= tol else 0):
        try:
            dU = _solve_step(J, r)
            Xt = unflat(pack_X(X) + dU)
            rt, Jt, st = sh.evaluate(Xt, [np.array(z) for z in Z], True)
        except (SolveError, np.linalg.LinAlgError):
            break
        rest = float(np.max(np.abs(rt))) if finite(rt) else math.inf
        if not (rest <= 0.25 * res) or not finite(Jt):
            break
        it += 1
        X = Xt
        if sh.multiple:
            Z = [st[(i - 1) % p].z for i in range(p)]
        res, r, J, steps = rest, rt, Jt, st
    converged = res <= tol
    if not converged and not message:
        message = f"no convergence in {max_iter} Newton steps (residual {res:.3g}, tolerance {tol:.3g})"
    if converged:
        message = f"converged in {it} Newton step{'s' if it != 1 else ''}"
    return X, Z, r, J, steps, it, converged, message


def floquet(M) -> np.ndarray:
    """The eigenvalues of a monodromy matrix, by decreasing modulus (then argument)."""
    mu = np.linalg.eigvals(np.asarray(M, dtype=float))
    order = np.lexsort((-np.angle(mu), -np.abs(mu)))
    return mu[order]


def _match(a, b) -> np.ndarray:
    """|a_i - b_j| for the greedy closest pairing of two multiplier sets."""
    b = list(b)
    err = np.empty(len(a))
    for i, x in enumerate(a):
        j = int(np.argmin([abs(x - y) for y in b]))
        err[i] = abs(x - b[j])
        b.pop(j)
    return err


def orbit_monodromy(steps, p):
    M = np.eye(steps[0].M.shape[0])
    for st in steps[:p]:
        M = st.M @ M
    return M


def _with_rtol(m, rtol):
    if isinstance(m, StroboscopicMap):
        return StroboscopicMap(m.flow, m.periods, rtol)
    if isinstance(m, PoincareMap):
        return PoincareMap(m.flow, m.normal, m.offset, m.direction, dt=m.dt, t_min=m.t_min,
                           t_max=m.t_max, rtol=rtol)
    return None


def section_points(m, x, z, count: int):
    """``count`` successive points of the map from (x, z): (X (count, N), Z list)."""
    X, Z = [np.asarray(x, dtype=float)], [np.array(z, dtype=float)]
    for _ in range(count - 1):
        st = m.step(X[-1], Z[-1])
        X.append(st.x)
        Z.append(st.z)
    return np.array(X), Z


def periodic_orbit(system, period: int = 1, guess=None, *, z=None, shooting: str = "auto",
                   rtol: float | None = None, tol: float | None = None, transient: int = 0,
                   max_iter: int = DEFAULT_MAX_ITER, check: bool = True,
                   progress=None) -> PeriodicOrbit:
    """A period-``period`` orbit of ``system`` by Newton shooting (module docstring).

    system:   a flow with a forcing period (a scene system: one crank revolution is one period),
              a StroboscopicMap / PoincareMap, or a DiscreteMap.
    guess:    a section point (the flow's state y, or the augmented state (y, memory)), or for
              multiple shooting a (period, ...) array of them; default: the system's initial
              state after ``transient`` map iterations.
    z:        the discrete state that goes with the guess (default: from the transient, or the
              system's z0).
    shooting: "single", "multiple" or "auto" (multiple for period >= 2).
    rtol:     the integrations' relative tolerance (flows; default ``nld.settings.LYAPUNOV.rtol``).
    tol:      the scaled residual that counts as converged (default 1e3 rtol; maps 1e-10).
    check:    compute the multipliers' uncertainty (a second evaluation at 10 rtol) and the
              determinant check.
    progress: optional callable (iteration, residual).
    Returns a :class:`PeriodicOrbit`; raises InputError for bad arguments, never returns an
    unconverged orbit as converged.
    """
    p = check_period(period)
    if shooting not in ("auto", "single", "multiple"):
        raise InputError(f"shooting = {shooting!r}: must be 'auto', 'single' or 'multiple'")
    if isinstance(transient, bool) or not isinstance(transient, (int, np.integer)) or transient < 0:
        raise InputError(f"transient = {transient!r}: must be a whole number of periods >= 0")
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
        raise InputError(f"max_iter = {max_iter!r}: must be an integer >= 1")
    m = as_map(system, rtol)
    if rtol is not None and not isinstance(m, NumbaMap) and m.rtol != rtol:
        m = _with_rtol(m, float(rtol))
    check_size(p, m.n)
    multiple = shooting == "multiple" or (shooting == "auto" and p >= 2)
    if tol is not None and (isinstance(tol, bool) or
                            not isinstance(tol, (int, float, np.integer, np.floating))):
        raise InputError(f"tol = {tol!r}: must be a positive number")
    tol = float(tol) if tol is not None else (1e-10 if isinstance(m, NumbaMap) else 1e3 * m.rtol)
    if not (tol > 0 and math.isfinite(tol)):
        raise InputError(f"tol = {tol!r}: must be a positive number")
    z0 = m.z0 if z is None else np.array(z, dtype=float).ravel()
    if z0.size != m.z0.size:
        raise InputError(f"z: {z0.size} values given, the system's discrete state has {m.z0.size}")
    X = _guess_points(m, guess, z0, p, transient)
    if isinstance(X, tuple):
        X, Z = X
    else:
        Z = [z0.copy() for _ in range(len(X))]
    if not multiple:
        X, Z = X[:1], Z[:1]
    sh = Shooting(m, p, multiple)
    Xs, Zs, r, J, steps, it, converged, message = _newton(sh, np.asarray(X), Z, tol,
                                                        int(max_iter), progress)
    points = Xs if multiple else sh.points_after(Xs, steps)
    zs = Zs if multiple else [Zs[0]] + [st.z for st in steps[:-1]]
    if not isinstance(m, NumbaMap):
        zs = [m.unpack(points[i], zs[i], relabel=True)[1] for i in range(p)]
    res = float(np.max(np.abs(r)))
    if converged and isinstance(m, PoincareMap):
        why = _equilibrium(m, points, zs, [st.time for st in steps[:p]], max(res, tol))
        if why:
            converged, message = False, why
    M = orbit_monodromy(steps, p)
    det_check = None
    onsets = np.sum([st.onsets for st in steps], axis=0) if len(steps[0].onsets) \
        else np.zeros(0, dtype=np.int64)
    mins = (np.min([st.min_approach for st in steps], axis=0) if steps[0].min_approach.size
            else np.zeros(0))
    if isinstance(m, PoincareMap):
        B = m.plane_basis
        Bf = np.zeros((m.n, B.shape[1] + m.memory.size))
        Bf[:m.n_y, :B.shape[1]] = B
        Bf[m.n_y:, B.shape[1]:] = np.eye(m.memory.size)

        def multipliers(MM):
            return floquet(Bf.T @ MM @ Bf)
    else:
        multipliers = floquet
    mu = multipliers(M)
    err = np.zeros(mu.size)
    if check and converged and not isinstance(m, NumbaMap):
        m2 = _with_rtol(m, min(10.0 * m.rtol, 1e-4))
        steps2 = []
        for i in range(p):
            steps2.append(m2.step(points[i], zs[i], jacobian=True, divergence=True,
                                   relabel=True))
        M2 = orbit_monodromy(steps2, p)
        err = _match(mu, multipliers(M2))
        if m.memory.size == 0 and isinstance(m, StroboscopicMap):
            ld = float(np.linalg.slogdet(M2)[1])
            liou = float(sum(s.divergence + s.log_det_saltation for s in steps2))
            det_check = {"log_det_M": ld, "liouville": liou, "difference": ld - liou,
                         "rtol": m2.rtol}
    n_neutral = 0
    if m.memory.size and onsets.size:
        # a memory entry of a joint without an onset on the orbit is never reset
        scene = m.flow.is_scene       # a memory entry: a scene's by its joint, else by its index
        for j, zi in enumerate(m.memory):
            ci = int(zi) if scene else j
            if ci < onsets.size and onsets[ci] == 0:
                n_neutral += 1
    continuum = n_neutral > 0
    stable, unc = multiplier_stability(mu, err, n_neutral, res)
    settings = {"period": p, "shooting": "multiple" if multiple else "single",
                "rtol": m.rtol, "tol": tol, "max_iter": int(max_iter),
                "transient": int(transient), "map": repr(m)}
    return PeriodicOrbit(p, np.asarray(points), [np.array(q) for q in zs], res, tol, converged, it,
                         message, mu, err, M, stable if converged else None,
                         onsets.astype(np.int64), int(np.sum(onsets)) if onsets.size else 0,
                         float(np.min(mins)) if mins.size else math.inf, continuum, det_check,
                         list(m.state_names), system.name, settings, m,
                         unc if converged else math.nan,
                         np.array([float(st.time) for st in steps[:p]]) if not
                         isinstance(m, NumbaMap) else np.zeros(0), n_neutral)


EQUILIBRIUM_EXCURSION = 1e3


def _equilibrium(m, points, zs, times, res: float, samples: int = 32) -> str:
    """Why a fixed point of a Poincaré map is no periodic orbit, or "": a section point where the
    flow (nearly) vanishes, an equilibrium on the section, returns to itself with an arbitrary
    return time (round-off crossings). Test: the trajectory from each point over its return time
    stays within EQUILIBRIUM_EXCURSION x the residual (scaled) of the point; a periodic orbit
    moves away from its section point and comes back (issue 38 item 3)."""
    for i, x in enumerate(points):
        y, zz = m.unpack(x, zs[i], relabel=True)
        te = m.t0 + float(times[i]) * np.arange(1, samples + 1) / samples
        out, _, _ = m._plain(y, zz, m.t0, te[-1], t_eval=te)
        ys = out.Y[:samples]
        exc = float(np.max(np.abs(ys - y[None, :]) / m.scales[None, :m.n_y]))
        if exc <= EQUILIBRIUM_EXCURSION * res:
            f = np.empty(m.n_y)
            m.flow.rhs(m.t0, np.ascontiguousarray(y), m.p, zz, f)
            speed = float(np.max(np.abs(f) / m.scales[:m.n_y]))
            what = ("an equilibrium on the section" if speed * float(times[i]) <= 1.0
                    else "a return time of ~0")
            return (f"{what}, no periodic orbit: the trajectory from the point "
                    f"({', '.join(f'{v:.6g}' for v in y)}; |f| = {float(np.max(np.abs(f))):.3g}) "
                    f"stays within {exc:.2g} (scaled) of it over the 'return' time "
                    f"{float(times[i]):.4g}")
    return ""


def _deciding(mu, n_neutral: int) -> np.ndarray:
    """mu without the n_neutral multipliers nearest 1 (the never-reset memory's)."""
    mu = np.asarray(mu)
    if n_neutral <= 0 or mu.size == 0:
        return mu
    drop = np.argsort(np.abs(mu - 1.0))[:n_neutral]
    return np.delete(mu, drop)


def multiplier_stability(mu, err, n_neutral: int, residual: float):
    """(stable: True / False / None, u): the verdict of the deciding multipliers (module
    docstring) and the uncertainty u of their largest modulus. The one stability rule of nld:
    ``PeriodicOrbit.stability``, branch rows, the census and the route all read it."""
    mu, err = np.asarray(mu), np.asarray(err, dtype=float)
    keep = np.ones(mu.size, dtype=bool)
    if n_neutral > 0 and mu.size:
        keep[np.argsort(np.abs(mu - 1.0))[:n_neutral]] = False
    dec, e = mu[keep], err[keep] if err.size == mu.size else np.zeros(int(keep.sum()))
    if dec.size == 0:
        return None, 0.0
    amax = float(np.max(np.abs(dec)))
    floor = max(float(residual) if math.isfinite(residual) else math.inf, 1e-13) * max(1.0, amax)
    u = max(float(np.max(e)) if e.size else 0.0, floor)
    if not math.isfinite(amax):
        return None, u
    if amax + u < 1.0:
        return True, u
    if amax - u > 1.0:
        return False, u
    return None, u


def _guess_points(m, guess, z0, p, transient):
    """The shooting points from a guess (p points: iterates of a single guess)."""
    if guess is None:
        x = m.y0.copy()
        z = z0.copy()
        for _ in range(int(transient)):
            st = m.step(x, z)
            x, z = st.x, st.z
        return section_points(m, x, z, p)
    g = np.array(guess, dtype=float)
    if g.ndim == 1:
        if g.size == m.n_y and m.n != m.n_y:
            g = m.pack(g, z0)
        if g.size != m.n:
            raise InputError(f"guess: {g.size} values given, need {m.n} "
                             f"({', '.join(m.state_names)}) or {m.n_y}")
        if not np.all(np.isfinite(g)):
            raise InputError(f"guess = {g.tolist()!r}: must be finite")
        x, z = g, z0.copy()
        for _ in range(int(transient)):
            st = m.step(x, z)
            x, z = st.x, st.z
        return section_points(m, x, z, p)
    if g.ndim == 2 and g.shape[0] == p and g.shape[1] in (m.n, m.n_y):
        if g.shape[1] != m.n:
            g = np.array([m.pack(row, z0) for row in g])
        if not np.all(np.isfinite(g)):
            raise InputError("guess: must be finite")
        return g
    raise InputError(f"guess: shape {g.shape}: need ({m.n},) or ({p}, {m.n})")


# ---------------------------------------------------------------------------------------------------
# all orbits up to a period


def prime_period(m, X, tol) -> int:
    """The least d | p with x_0 = x_d (within tol, scaled): X the p points of an orbit of the
    map m (a period-2 orbit that converged on a fixed point has prime period 1)."""
    p = len(X)
    for d in range(1, p):
        if p % d == 0 and np.max(np.abs(m.difference(X[d], X[0]) / m.scales)) <= tol:
            return d
    return p


def _same_orbit(m, A, B, tol) -> bool:
    """Two orbits of one period are one if a point of A is a point of B (cyclic shifts)."""
    for b in B:
        if np.max(np.abs(m.difference(A[0], b) / m.scales)) <= tol:
            return True
    return False


# ---------------------------------------------------------------------------------------------------
# stabilising transformations (Schmelcher & Diakonos 1997)


def signed_permutations(n: int) -> list:
    """The n! 2^n signed permutation matrices C of Schmelcher & Diakonos (1997): for each
    hyperbolic fixed point one of them makes it a stable fixed point of
    x -> x + lam C (f(x) - x) for small lam > 0."""
    if n > 4:
        raise InputError(f"stabilising transformations: {n} states give {math.factorial(n) * 2**n} "
                         "matrices; use them for maps of at most 4 states")
    out = []
    for perm in itertools.permutations(range(n)):
        for signs in itertools.product((1.0, -1.0), repeat=n):
            C = np.zeros((n, n))
            for i, j in enumerate(perm):
                C[i, j] = signs[i]
            out.append(C)
    return out


@njit(cache=False)
def _sd_iterate(f, x0, p, C, lam, period, max_steps, tol, bound):
    """x <- x + lam C (f^period(x) - x) from x0 until max |f^p(x) - x| <= tol (returns x, True)
    or max_steps / leaving |x| <= bound (returns x, False)."""
    n = x0.shape[0]
    x = x0.copy()
    y = np.empty(n)
    tmp = np.empty(n)
    d = np.empty(n)
    for _ in range(max_steps):
        for i in range(n):
            y[i] = x[i]
        for _k in range(period):
            f(y, p, tmp)
            for i in range(n):
                y[i] = tmp[i]
        big = 0.0
        for i in range(n):
            d[i] = y[i] - x[i]
            if abs(d[i]) > big:
                big = abs(d[i])
        if not big <= bound:
            return x, False
        if big <= tol:
            return x, True
        for i in range(n):
            acc = 0.0
            for j in range(n):
                acc += C[i, j] * d[j]
            x[i] += lam * acc
    return x, False


def stabilised_seeds(m: NumbaMap, period: int, starts, *, lam: float | None = None,
                     max_steps: int = 2000, tol: float = 1e-9) -> list:
    """Fixed points of f^period reached by the stabilising transformations from each start and
    each signed permutation C (Schmelcher & Diakonos 1997; Davidchack & Lai 1999 use the same C
    with a semi-implicit step): x <- x + lam C (f^p(x) - x), lam default 0.5 / 1.5^period (the
    multipliers of f^p grow with p). Returns the converged points (for Newton to polish)."""
    if not isinstance(m, NumbaMap):
        raise InputError("stabilising transformations: only for a DiscreteMap (a cheap map)")
    lam = 0.5 / 1.5 ** period if lam is None else float(lam)
    bound = 1e6 * float(np.max(np.abs(m.scales)))
    out = []
    for C in signed_permutations(m.n):
        for x0 in starts:
            x, ok = _sd_iterate(m.system.f, np.ascontiguousarray(x0, dtype=float), m.p, C, lam,
                                int(period), int(max_steps), float(tol), bound)
            if ok:
                out.append(x)
    return out


def find_orbits(system, max_period: int = 4, *, n_points: int | None = None,
                transient: int | None = None, seeds_per_period: int | None = None,
                rtol: float | None = None, tol: float | None = None, grid: int = 0,
                stabilising: int = 0, progress=None, min_period: int = 1) -> list[PeriodicOrbit]:
    """The distinct periodic orbits of periods 1..max_period near the system's attractor.

    Seeds: the close returns ||P^p(x_i) - x_i|| of ``n_points`` section points after a
    ``transient`` (defaults: maps 2000 points after 100; flows 120 after 50), the
    ``seeds_per_period`` closest per period (maps 400, flows 6), and for a map a ``grid`` x grid
    lattice over the box of the points enlarged by half its size (default 0: none), and for a map
    with ``stabilising`` > 0 the fixed points of f^p reached by the stabilising transformations of
    Schmelcher & Diakonos (1997) from that many attractor points (:func:`stabilised_seeds`);
    ``min_period``: search periods min_period..max_period only. Each seed is
    refined by :func:`periodic_orbit` (multiple shooting for p >= 2); orbits that are not of prime
    period p, or equal to one found (any cyclic shift), are dropped. Returns the converged orbits
    by period, then by decreasing max |mu|.
    """
    P = check_period(max_period, "max_period")
    P0 = check_period(min_period, "min_period")
    if P0 > P:
        raise InputError(f"min_period = {min_period!r}: must be <= max_period = {P}")
    m = as_map(system, rtol)
    is_flow = not isinstance(m, NumbaMap)
    n_points = _whole(n_points if n_points is not None else default_points(m), "n_points", 2)
    transient = _whole(transient if transient is not None else (50 if is_flow else 100),
                       "transient", 0)
    spp = _whole(seeds_per_period if seeds_per_period is not None else (6 if is_flow else 400),
                 "seeds_per_period", 0)
    grid = _whole(grid, "grid", 0)
    stabilising = _whole(stabilising, "stabilising", 0)
    if P >= n_points:
        raise InputError(f"max_period = {P}: the close returns of period p need more than p of "
                         f"the n_points = {n_points} section points: at most {n_points - 1} "
                         f"(or raise n_points)")
    check_size(P, m.n, "max_period")
    if tol is not None and not (isinstance(tol, (int, float, np.floating)) and
                                not isinstance(tol, bool) and math.isfinite(tol) and tol > 0):
        raise InputError(f"tol = {tol!r}: must be a positive number")
    if stabilising and is_flow:
        raise InputError(f"stabilising = {stabilising}: stabilising transformations are for a "
                         f"DiscreteMap only (a flow's seeds are the close returns)")
    if grid and is_flow:
        raise InputError(f"grid = {grid}: a seed grid is for a DiscreteMap only (a flow's seeds "
                         f"are the close returns)")
    if stabilising:
        signed_permutations(m.n)        # refuses maps of more than 4 states
    x0, z0 = _iterate(m, m.y0, m.z0, transient)
    X, Z = section_points(m, x0, z0, n_points)
    found: list[PeriodicOrbit] = []
    dedup_tol = 1e-6
    for p in range(P0, P + 1):
        d = np.array([np.max(np.abs(m.difference(X[i + p], X[i]) / m.scales))
                      for i in range(n_points - p)])
        order = np.argsort(d)
        seeds = []
        for i in order:
            if len(seeds) >= spp:
                break
            if any(abs(int(i) - j) < p for j in seeds) and is_flow:
                continue
            seeds.append(int(i))
        starts = [(X[i:i + p], Z[i:i + p]) for i in seeds]
        if grid and not is_flow:
            lo, hi = X.min(axis=0), X.max(axis=0)
            span = hi - lo
            axes = [np.linspace(lo[k] - span[k] / 2, hi[k] + span[k] / 2, grid)
                    for k in range(m.n)]
            for pt in np.array(np.meshgrid(*axes)).reshape(m.n, -1).T:
                starts.append((section_points(m, pt, m.z0, p)[0], [m.z0] * p))
        if stabilising and not is_flow:
            pick = X[np.linspace(0, len(X) - 1, int(stabilising)).astype(int)]
            for x in stabilised_seeds(m, p, pick):
                starts.append((section_points(m, x, m.z0, p)[0], [m.z0] * p))
        per_p: list[PeriodicOrbit] = []
        for k, (Xs, Zs) in enumerate(starts):
            if progress is not None:
                progress(p, k, len(starts))
            if not finite(Xs) or np.max(np.abs(Xs)) > 1e8 * np.max(m.scales):
                continue
            try:
                orb = periodic_orbit(m, p, np.array(Xs), z=Zs[0], tol=tol, check=is_flow,
                                     max_iter=20 if is_flow else 12)
            except (SolveError, FloatingPointError, np.linalg.LinAlgError, ValueError):
                continue
            if not orb.converged or not finite(orb.points):
                continue
            if prime_period(m, orb.points, max(dedup_tol, 10 * orb.tolerance)) != p:
                continue
            if any(_same_orbit(m, orb.points, o.points, max(dedup_tol, 10 * orb.tolerance))
                   for o in per_p):
                continue
            per_p.append(orb)
        per_p.sort(key=lambda o: -o.max_abs_multiplier)
        found += per_p
    return found


def default_points(m) -> int:
    """find_orbits' default number of section points: 120 for a flow's map, 2000 for a map."""
    return 2000 if isinstance(m, NumbaMap) else 120


def _iterate(m, x, z, n):
    for _ in range(int(n)):
        st = m.step(x, z)
        x, z = st.x, st.z
    return x, z
