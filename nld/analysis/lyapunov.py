"""Lyapunov exponents of any system of ``nld.systems.core`` (flows, maps, mechanism scenes).

Estimators (see docs/lyapunov.md):

* :func:`lyapunov_benettin` -- largest exponent from two trajectories (Benettin et al. 1980):
  a reference and a perturbed copy at scaled distance d0, both integrated by DOPRI5 with the
  same rtol and per-state atol (``system.tolerance(rtol)``) on *their own* states (each trajectory has its own
  step-size control, event location and discrete state z), renormalised back to d0 every
  ``renorm_interval``. For a map: the two orbits, renormalised every ``renorm_interval``
  iterations.
* :func:`lyapunov_spectrum` -- the first k exponents.
  Flows: tangent-free "perturbation-vector" method: k perturbed trajectories around the
  reference, their separations orthonormalised by QR (Gram-Schmidt) every interval; the logs of
  |R_jj| accumulate the exponents. Maps: the tangent map (analytic Jacobian, or central finite
  differences) applied to an orthonormal frame, re-orthonormalised by QR every iteration.
* :func:`lyapunov_nolds` -- Rosenstein (nolds.lyap_r) and Eckmann (nolds.lyap_e) estimates from a
  scalar time series, for comparison only.

Distances are measured in the scaled norm ||dy||_s = sqrt(sum_i (dy_i / scale_i)^2) with the
system's per-state scales (for a scene: clearance-based, ``nld.run.simulate.state_scales``), so the
tiny journal coordinates are not swamped by angles and the result does not depend on units.

Units: flows 1/s (natural log per second of the system's time); ``per_revolution`` = exponent x
period (natural log per crank revolution for a scene, per forcing period for a forced system);
maps per iteration.

Uncertainty (docs/lyapunov.md, "Uncertainty"): the local stretching rates, averaged over whole
periods, give ``block_se``, the blocking standard error of their mean extrapolated to long blocks
(:func:`blocking_se`); ``history_spread`` = half the range of the running estimate over its last
half; ``uncertainty = max(t x block_se, history_spread)``, t the 95 % Student-t quantile for the
blocks of the coarsest blocking level (:func:`interval_quantile`). Its coverage of published
exponents is measured in benchmarks/lyapunov_coverage.py.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from nld.errors import InputError
from nld.settings import LYAPUNOV_DEFAULTS, TANGENT, check_rtol
from nld.systems.core import (advance, builtin_map, builtin_map_jac, period_shift, restart_labels,
                              wrap_angles)

__all__ = ["LyapunovResult", "SpectrumResult", "lyapunov_tangent", "lyapunov_benettin",
           "largest_exponent", "ESTIMATORS",
           "lyapunov_spectrum", "blocking_se", "interval_quantile", "uncertainty_from_rates",
           "lyapunov_nolds", "DEFAULTS"]

# documented defaults (docs/lyapunov.md): nld.settings.LYAPUNOV_DEFAULTS, with the settings shared
# with the command line (LYAPUNOV, TANGENT_SPANS, BENETTIN_SPANS, TANGENT, BENETTIN)
DEFAULTS = LYAPUNOV_DEFAULTS


# ---------------------------------------------------------------- results
@dataclass
class LyapunovResult:
    """Largest Lyapunov exponent.

    exponent: 1/s for a flow (1/time unit), per iteration for a map.
    per_revolution: exponent x period (per crank revolution / forcing period), None without one.
    history: running estimate after each renormalisation interval, at ``times`` (s or
    iterations counted from the end of the transient).
    uncertainty = block_se + history_spread (see module docstring).
    local_rates: ln(d_i/d0)/T_i of every interval.
    """
    exponent: float
    per_revolution: float | None
    history: np.ndarray
    times: np.ndarray
    uncertainty: float
    block_se: float
    history_spread: float
    units: str
    local_rates: np.ndarray
    method: str
    system: str
    period: float | None
    settings: dict = field(default_factory=dict)
    period_name: str = "revolution"
    diagnostics: dict = field(default_factory=dict)
    check: dict | None = None

    @property
    def uncertainty_per_revolution(self):
        return None if self.period is None else self.uncertainty * self.period

    @property
    def per_period(self):
        """exponent x period (per crank revolution of a scene, per forcing period)."""
        return self.per_revolution

    def __str__(self):
        s = (f"{self.method} {self.system}: lambda1 = {self.exponent:.6g} +- "
             f"{self.uncertainty:.2g} {self.units}")
        if self.per_revolution is not None:
            s += (f" = {self.per_revolution:.4g} +- {self.uncertainty_per_revolution:.2g}"
                  f" per {self.period_name}")
        return s


@dataclass
class SpectrumResult:
    """First k Lyapunov exponents (descending as computed by QR; not re-sorted).

    exponents, uncertainty, block_se, history_spread: arrays of k; history: (n_intervals, k);
    per_revolution: exponents x period or None; total: sum of the k exponents (with its own
    uncertainty ``total_uncertainty``).
    """
    exponents: np.ndarray
    per_revolution: np.ndarray | None
    history: np.ndarray
    times: np.ndarray
    uncertainty: np.ndarray
    block_se: np.ndarray
    history_spread: np.ndarray
    total: float
    total_uncertainty: float
    units: str
    local_rates: np.ndarray
    method: str
    system: str
    period: float | None
    settings: dict = field(default_factory=dict)
    period_name: str = "revolution"
    diagnostics: dict = field(default_factory=dict)

    @property
    def exponent(self) -> float:
        return float(self.exponents[0])

    @property
    def uncertainty_per_revolution(self):
        return None if self.period is None else self.uncertainty * self.period

    def __str__(self):
        ex = ", ".join(f"{e:.5g}+-{u:.2g}" for e, u in zip(self.exponents, self.uncertainty))
        return (f"{self.method} {self.system}: [{ex}] {self.units}, sum {self.total:.6g}"
                f" +- {self.total_uncertainty:.2g}")


COVERAGE_LEVEL = 0.95     # uncertainty = t_{0.975, dof} x (blocking standard error)
MIN_BLOCKS = 16           # the coarsest blocking level kept


def interval_quantile(n: int, level: float = COVERAGE_LEVEL) -> float:
    """The Student-t quantile that turns the blocking standard error of n local rates into the
    reported uncertainty (a two-sided ``level`` interval).

    Its degrees of freedom are those of the coarsest blocking level of :func:`blocking_se`, the
    last with at least 8 blocks (8 - 15 blocks for any n >= 8: 12 for 50, 100 or 200 periods),
    minus one: the extrapolated standard error is no better determined than that level's. (The
    factor was 2.1 before, the quantile for 20 fixed blocks; blocking leaves fewer at its coarsest
    level, and 2.1 covered published exponents in 93.7 % of 700 default runs, 92.9 % over 50
    periods: benchmarks/results/lyapunov_coverage.md.)"""
    from scipy.stats import t as student_t
    nb = int(n)
    if nb >= 8:
        while nb // 2 >= 8:
            nb //= 2
    return float(student_t.ppf(0.5 + 0.5 * level, max(nb - 1, 1)))


def blocking_se(rates: np.ndarray) -> tuple[float, int]:
    """Standard error of the mean of the local rates, from blocking (Flyvbjerg & Petersen,
    J. Chem. Phys. 91 (1989) 461) extrapolated to infinitely long blocks.

    Neighbouring rates are averaged in pairs again and again (block length tau = 1, 2, 4, ...
    intervals) and the naive standard error se(tau) = std/sqrt(N_blocks) of every level with at
    least 8 blocks is kept. The mean of a block of length tau is ln(|w_end|/|w_start|)/tau: a
    diffusive part, whose variance falls like 2D/tau, plus the fluctuation of ln|w| at the two
    ends (the direction of the vector against the local stretching), a variance C/tau^2 that
    does not average out within a block. Hence N_blocks se(tau)^2 tau = 2D + C/tau: se(tau)^2
    is linear in 1/tau, falling when C > 0 (local rates of a flow are anti-correlated: a stretch
    is undone in the next interval) and rising for positive short-time correlations (C < 0).
    A weighted straight-line fit of se^2 against 1/tau (weights from the error of each level's
    variance, 2 se^4/(N_blocks - 1)) gives the intercept: the standard error of infinitely long
    blocks. When the fit is not positive the coarsest level's value is used. Returned: the
    standard error and the number of levels fitted."""
    x = np.asarray(rates, dtype=float)
    x = x[np.isfinite(x)]
    if x.size < 2:
        return float("nan"), 0
    taus, se2, w = [], [], []
    length = 1
    while x.size >= 8:
        nb = x.size
        v = float(np.var(x, ddof=1) / nb)
        taus.append(length)
        se2.append(v)
        w.append((nb - 1) / (2.0 * v * v) if v > 0 else 0.0)
        m = nb // 2
        x = 0.5 * (x[:2 * m:2] + x[1:2 * m:2])
        length *= 2
    if not taus:
        v = float(np.var(np.asarray(rates, dtype=float), ddof=1) / len(rates))
        return math.sqrt(v), 0
    se2 = np.array(se2)
    if len(taus) < 3 or not np.all(np.isfinite(w)) or sum(w) == 0:
        return float(math.sqrt(se2[-1])), len(taus)
    # the 1/tau form holds for blocks longer than the correlation time: fit the coarser half
    # of the levels (at least the three coarsest)
    i0 = min(len(taus) // 2, len(taus) - 3)
    taus, se2, w = taus[i0:], se2[i0:], w[i0:]
    X = 1.0 / np.array(taus, dtype=float)
    W = np.array(w)
    A = np.vstack([np.ones_like(X), X]).T
    coef = np.linalg.lstsq(A * np.sqrt(W)[:, None], se2 * np.sqrt(W), rcond=None)[0]
    a = float(coef[0])
    if not (a > 0 and math.isfinite(a)):
        return float(math.sqrt(se2[-1])), len(taus)
    return math.sqrt(a), len(taus)


def _stats(rates: np.ndarray, weights: np.ndarray, n_blocks: int | None = None):
    """Running estimate, blocking standard error, half-range of the last half of the history.

    The mean is weighted by the interval lengths; the standard error is the blocking estimate
    (``blocking_se``) of the rates (equal intervals in every estimator). n_blocks is kept for
    the call signature: blocking chooses the block length itself."""
    csum = np.cumsum(rates * weights)
    cw = np.cumsum(weights)
    hist = csum / cw
    est = float(hist[-1])
    n = rates.shape[0]
    se, _ = blocking_se(rates)
    tail = hist[n // 2:]
    spread = float(0.5 * (tail.max() - tail.min())) if tail.size else float("nan")
    return est, hist, se, spread


def _uncertainty(se: float, spread: float, n: int) -> float:
    """The reported uncertainty of the mean of n local rates: t blocking standard errors
    (``interval_quantile``: a 95 % interval), and never less than the half-range of the running
    estimate over its last half."""
    return max(interval_quantile(n) * se, spread)


def uncertainty_from_rates(rates) -> tuple[float, float]:
    """(estimate, uncertainty) of equally long local rates (e.g. ``result.local_rates``, per
    period) by the rule every estimator here reports; a shorter prefix gives what a shorter run
    would have reported (benchmarks/lyapunov_coverage.py)."""
    x = np.asarray(rates, dtype=float)
    est, _, se, spread = _stats(x, np.ones(x.shape))
    return est, _uncertainty(se, spread, x.shape[0])


def _spectrum_result(system, rates, weights, n_blocks, method, settings) -> "SpectrumResult":
    """A SpectrumResult from the local rates (n_intervals, k) of any spectrum estimator."""
    k = rates.shape[1]
    ex, se, sp, hist = np.empty(k), np.empty(k), np.empty(k), np.empty((rates.shape[0], k))
    for j in range(k):
        ex[j], hist[:, j], se[j], sp[j] = _stats(rates[:, j], weights, n_blocks)
    tot, _, tse, tsp = _stats(rates.sum(axis=1), weights, n_blocks)
    period = None if system.is_map else system.period
    return SpectrumResult(
        exponents=ex, per_revolution=None if period is None else ex * period, history=hist,
        times=np.cumsum(weights),
        uncertainty=np.array([_uncertainty(a, b, rates.shape[0]) for a, b in zip(se, sp)]),
        block_se=se, history_spread=sp, total=tot,
        total_uncertainty=_uncertainty(tse, tsp, rates.shape[0]),
        units=_units(system), local_rates=rates, method=method, system=system.name,
        period=period, settings=settings,
        period_name=system.period_name or "revolution")


def _units(system) -> str:
    return "1/iteration" if system.is_map else f"1/{system.time_unit}"


# the record of local rates (one row of k values per renormalisation interval) must fit in this
MAX_RECORD_BYTES = 2**30


def max_intervals(k: int = 1) -> int:
    """The most renormalisation intervals a run of k exponents may record (MAX_RECORD_BYTES)."""
    return MAX_RECORD_BYTES // (8 * max(1, int(k)))


def _check_record(name: str, value, n_int: int, k: int, interval: float, unit: str) -> None:
    """InputError naming ``name`` when ``n_int`` intervals of ``k`` rates do not fit in memory."""
    limit = max_intervals(k)
    if n_int > limit:
        raise InputError(f"{name} = {value!r}: {n_int:.3g} renormalisation intervals of {interval:g} "
                         f"{unit} would need {n_int * 8 * k / 2**30:.3g} GiB for their record; at most "
                         f"{limit:.3g} intervals ({limit * interval:.3g} {unit}) with k = {k}")


def check_seed(seed, name: str = "seed") -> int:
    """``seed`` as an int >= 0 (numpy's generators take no negative seed), else InputError."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"{name} = {seed!r}: must be a whole number >= 0")
    return int(seed)


def _check_positive(name, v):
    if not (isinstance(v, (int, float, np.floating, np.integer)) and math.isfinite(v) and v > 0):
        raise InputError(f"{name} = {v!r}: must be a positive number")


def _random_unit(rng, n):
    u = rng.standard_normal(n)
    return u / np.linalg.norm(u)


# ---------------------------------------------------------------- maps (numba)
@njit(inline="always")
def _map_benettin(f, x, p, scales, u, d0, n_transient, n_intervals, every):
    n = x.shape[0]
    y = x.copy()
    tmp = np.empty(n)
    for _ in range(n_transient):
        f(y, p, tmp)
        y, tmp = tmp, y
    yp = y + d0 * scales * u
    tmp2 = np.empty(n)
    logs = np.empty(n_intervals)
    for i in range(n_intervals):
        for _ in range(every):
            f(y, p, tmp)
            y, tmp = tmp, y
            f(yp, p, tmp2)
            yp, tmp2 = tmp2, yp
        d = 0.0
        for j in range(n):
            d += ((yp[j] - y[j]) / scales[j]) ** 2
        d = math.sqrt(d)
        if d > 0.0 and math.isfinite(d):
            logs[i] = math.log(d / d0)
            for j in range(n):
                yp[j] = y[j] + (d0 / d) * (yp[j] - y[j])
        else:       # collapsed (superstable point) or escaped: restart the perturbation
            logs[i] = -np.inf if d == 0.0 else np.nan
            for j in range(n):
                yp[j] = y[j] + d0 * scales[j] * u[j]
    return logs, y


@njit(inline="always")
def _fd_jacobian(f, x, p, scales, J):
    n = x.shape[0]
    xp = x.copy()
    fp = np.empty(n)
    fm = np.empty(n)
    for j in range(n):
        h = 1e-6 * scales[j] * max(1.0, abs(x[j]) / scales[j])
        xp[j] = x[j] + h
        f(xp, p, fp)
        xp[j] = x[j] - h
        f(xp, p, fm)
        xp[j] = x[j]
        for i in range(n):
            J[i, j] = (fp[i] - fm[i]) / (2.0 * h)


@njit(inline="always")
def _map_qr(f, jac, use_fd, x, p, scales, Q0, n_transient, n_intervals, every):
    """Tangent-map QR (Eckmann-Ruelle / Shimada-Nagashima): logs |R_jj| per interval.

    The frame lives in scaled coordinates: the scaled Jacobian S^-1 J S is applied."""
    n = x.shape[0]
    k = Q0.shape[1]
    y = x.copy()
    tmp = np.empty(n)
    for _ in range(n_transient):
        f(y, p, tmp)
        y, tmp = tmp, y
    Q = Q0.copy()
    J = np.empty((n, n))
    logs = np.empty((n_intervals, k))
    for i in range(n_intervals):
        for _ in range(every):
            if use_fd:
                _fd_jacobian(f, y, p, scales, J)
            else:
                jac(y, p, J)
            for a in range(n):
                for b in range(n):
                    J[a, b] = J[a, b] * scales[b] / scales[a]
            Q = J @ Q
            f(y, p, tmp)
            y, tmp = tmp, y
        Qn, R = np.linalg.qr(Q)
        for j in range(k):
            r = R[j, j]
            logs[i, j] = math.log(abs(r)) if r != 0.0 else -np.inf
            if r < 0.0:
                for a in range(n):
                    Qn[a, j] = -Qn[a, j]
        Q = np.ascontiguousarray(Qn)
    return logs, y


# The map routines take the map as an argument (compiled per map and process, not found in
# numba's disk cache); the built-in maps go through these cached wrappers instead.
@njit(cache=True)
def _map_benettin_builtin(x, p, scales, u, d0, n_transient, n_intervals, every):
    return _map_benettin(builtin_map, x, p, scales, u, d0, n_transient, n_intervals, every)


@njit(cache=True)
def _map_qr_builtin(x, p, scales, Q0, n_transient, n_intervals, every):
    return _map_qr(builtin_map, builtin_map_jac, False, x, p, scales, Q0, n_transient,
                   n_intervals, every)


def _builtin_p(system):
    return np.concatenate(([float(system.builtin_code)], system.p))


def _map_settings(system, transient, total, renorm_interval):
    d = DEFAULTS["map"]
    transient = d["transient"] if transient is None else transient
    total = d["total"] if total is None else total
    every = d["renorm_interval"] if renorm_interval is None else renorm_interval
    for nm, v in (("transient", transient), ("total", total), ("renorm_interval", every)):
        if int(v) != v or v < (0 if nm == "transient" else 1):
            raise InputError(f"{nm} = {v!r}: must be a whole number of iterations (map "
                             f"{system.name})")
    n_int = int(total) // int(every)
    if n_int < 2:
        raise InputError(f"total = {total!r}: need at least two renormalisation intervals")
    _check_record("total", total, n_int, system.n, int(every), "iterations")
    return int(transient), n_int, int(every)


# ---------------------------------------------------------------- flows: settings
def _flow_settings(system, transient, total, renorm_interval, d0, rtol, spectrum):
    d = DEFAULTS["spectrum_flow" if spectrum else "flow"]
    base = system.period if system.period is not None else 1.0
    if renorm_interval is None:
        if spectrum:
            renorm_interval = (base * d["interval_period"] if system.period is not None
                               else d["interval_no_period"])
        else:
            renorm_interval = base * d["interval_base"]
    _check_positive("renorm_interval", renorm_interval)
    transient = d["transient_base"] * base if transient is None else transient
    total = d["total_base"] * base if total is None else total
    if not (math.isfinite(transient) and transient >= 0):
        raise InputError(f"transient = {transient!r}: must be a time >= 0")
    _check_positive("total", total)
    d0 = d["d0"] if d0 is None else d0
    _check_positive("d0", d0)
    rtol = d["rtol"] if rtol is None else rtol
    check_rtol(rtol)
    n_int = int(round(total / renorm_interval))
    if n_int < 2:
        raise InputError(f"total = {total!r}: need at least two renormalisation intervals "
                         f"of {renorm_interval:g}")
    _check_record("total", total, n_int, system.n if spectrum else 1, float(renorm_interval),
                  system.time_unit)
    return float(transient), n_int, float(renorm_interval), float(d0), float(rtol)


def rescale_memory(system, z, zp, factor):
    """Renormalisation of the perturbed copy's memory states (``system.memory``: a contact
    law's approach velocity recorded at onset) together with its continuous state: where both
    trajectories are in the same contact (both memories set), the copy's memory is put back on
    the line to the reference's by the same factor as the state, zp = z + factor (zp - z), i.e.
    to what the memory of the rescaled copy is to first order. Where only one of them is in
    contact the copy's memory is its own (its onset or separation is handled by
    ``cross_events``). Without this the copy keeps, for the rest of a contact, the memory of a
    trajectory it is no longer near, and every renormalisation injects a spurious force
    difference (docs/lyapunov.md, "The discrete state")."""
    for m in system.memory:
        if zp[m] != 0.0 and z[m] != 0.0:
            zp[m] = z[m] + factor * (zp[m] - z[m])


def cross_events(system, t, y_old, y_new, z):
    """Renormalisation moves a perturbed state from y_old to y_new. Where that jump crosses an
    event surface (g_k changes sign) the crossing is reported to ``on_event`` as the integrator
    would, so the discrete state stays consistent: a scene records the approach velocity of a
    contact the jump entered (otherwise the contact law would see no onset and fall back on
    its minimum approach velocity, i.e. a far too damped impact)."""
    ne = system.n_events
    if ne == 0:
        return
    g_old, g_new = np.empty(ne), np.empty(ne)
    system.events(t, y_old, system.p, z, g_old)
    system.events(t, y_new, system.p, z, g_new)
    for k in range(ne):
        s_new = np.sign(g_new[k])
        if s_new != 0 and s_new != np.sign(g_old[k]):
            system.on_event(k, int(s_new), t, y_new, system.p, z)


# ---------------------------------------------------------------- Benettin
def lyapunov_benettin(system, *, transient=None, total=None, renorm_interval=None, d0=None,
                      rtol=None, seed: int = 0, checks: int | None = None,
                      max_growth: float | None = None, n_blocks: int | None = None,
                      progress=None) -> LyapunovResult:
    """Largest Lyapunov exponent by the two-trajectory method of Benettin et al. (1980).

    system: any ``nld.systems.core`` system (ContinuousSystem, SceneSystem, DiscreteMap).

    Flows (times in the system's unit, s):
      renorm_interval T: the system's period (a scene: one crank revolution), else 1.0.
      transient: 20 periods (else 20), integrated first and discarded.
      total: 500 periods (else 500), the averaging time after the transient.
      d0: 1e-5, the separation in the scaled norm ||dy / scales|| (for a scene: 1e-5 of the
        clearance-based scales, i.e. nanometres at the journal).
      rtol: 1e-10; atol = system.tolerance(rtol). *Both* trajectories are integrated by DOPRI5 under this
        error control, each with its own step sizes, event location and discrete state z.
      checks: 32 per interval when the system has a period, else 1: the separation is measured
        every T/checks and, where it exceeds max_growth * d0 (max_growth: 10), renormalised
        there (a chaotic scene stretches by e^10 or more per revolution, far out of the linear
        range). The perturbed state is always renormalised at the end of each interval.
    Maps (iterations): renorm_interval 1, transient 1000, total 100000, d0 1e-9.
    seed: the random direction of the initial perturbation. n_blocks: 20 (uncertainty).

    The local rate of interval i is (sum of ln(d/d0) over its renormalisations) / T; the exponent
    is their mean. A renormalisation that moves the perturbed state across an event surface
    (a contact onset) reports the crossing to the system's ``on_event`` (see cross_events).
    """
    rng = np.random.default_rng(check_seed(seed))
    n_blocks = DEFAULTS["n_blocks"] if n_blocks is None else int(n_blocks)
    if system.is_map:
        n_tr, n_int, every = _map_settings(system, transient, total, renorm_interval)
        d0 = DEFAULTS["map"]["d0"] if d0 is None else d0
        _check_positive("d0", d0)
        u = _random_unit(rng, system.n)
        if system.builtin_code is not None:
            logs, _ = _map_benettin_builtin(system.y0.copy(), _builtin_p(system), system.scales,
                                            u, float(d0), n_tr, n_int, every)
        else:
            logs, _ = _map_benettin(system.f, system.y0.copy(), system.p, system.scales, u,
                                    float(d0), n_tr, n_int, every)
        if not np.all(np.isfinite(logs)):
            warnings.warn(f"{system.name}: {np.sum(~np.isfinite(logs))} intervals with a "
                          "collapsed or escaped perturbation were left out", RuntimeWarning)
            logs = logs[np.isfinite(logs)]
        T = float(every)
        rates = logs / T
        settings = dict(transient=n_tr, total=n_int * every, renorm_interval=every, d0=d0,
                        seed=seed, n_blocks=n_blocks)
        period = None
    else:
        transient, n_int, T, d0, rtol = _flow_settings(system, transient, total,
                                                       renorm_interval, d0, rtol, False)
        dflt = DEFAULTS["flow"]
        if checks is None:
            checks = dflt["checks_with_period"] if system.period is not None else 1
        checks = int(checks)
        if checks < 1:
            raise InputError(f"checks = {checks!r}: must be >= 1")
        max_growth = dflt["max_growth"] if max_growth is None else float(max_growth)
        if not max_growth >= 1.0:
            raise InputError(f"max_growth = {max_growth!r}: must be >= 1")
        y, z = system.y0.copy(), system.z0.copy()
        t_start = system.t0
        if transient > 0:
            y, z = advance(system, y, z, t_start, t_start + transient, rtol)
            t_start += transient
        sc = system.scales
        u = _random_unit(rng, system.n)
        yp, zp = y + d0 * sc * u, z.copy()
        rates = np.empty(n_int)
        n_renorm = 0
        base = system.period if system.period is not None else 1.0
        bar = _progress_bar(n_int * T / base, f"lyapunov (benettin) {system.name}",
                            "rev" if system.period_name == "revolution" else
                            "periods", progress)
        for i in range(n_int):
            bar.update(T / base)
            t0 = t_start + i * T
            acc = 0.0
            for c in range(checks):
                ta = t0 + c * T / checks
                tb = t0 + (c + 1) * T / checks if c < checks - 1 else t0 + T
                y, z = advance(system, y, z, ta, tb, rtol)
                yp, zp = advance(system, yp, zp, ta, tb, rtol)
                dy = yp - y
                d = float(np.linalg.norm(dy / sc))
                if not (d > 0.0 and math.isfinite(d)):
                    raise InputError(f"{system.name}: separation {d!r} at t = {tb:g}: the two "
                                     f"trajectories coincide or diverged; change d0 or rtol")
                if c == checks - 1 or d > max_growth * d0:
                    acc += math.log(d / d0)
                    yp_new = y + (d0 / d) * dy
                    rescale_memory(system, z, zp, d0 / d)
                    cross_events(system, tb, yp, yp_new, zp)
                    yp = yp_new
                    n_renorm += 1
            rates[i] = acc / T
        bar.close()
        settings = dict(estimator="benettin", transient=transient, total=n_int * T,
                        renorm_interval=T, d0=d0, rtol=rtol, seed=seed, checks=checks, max_growth=max_growth,
                        renormalisations=n_renorm, n_blocks=n_blocks, norm="scaled",
                        scales=system.scales.tolist())
        period = system.period
    weights = np.full(rates.shape, T)
    times = np.cumsum(weights)
    est, hist, se, spread = _stats(rates, weights, n_blocks)
    return LyapunovResult(
        exponent=est, per_revolution=None if period is None else est * period, history=hist,
        times=times, uncertainty=_uncertainty(se, spread, rates.shape[0]), block_se=se,
        history_spread=spread,
        units=_units(system), local_rates=rates, method="benettin", system=system.name,
        period=period, settings=settings,
        period_name=system.period_name or "revolution")


# ---------------------------------------------------------------- spectrum
DERIVED_TRANSIENT, DERIVED_TOTAL = 20, 200


def _derived_map_spectrum(m, k, Q0, transient, total, n_blocks, seed) -> "SpectrumResult":
    """The spectrum of a derived map (``nld.systems.derived``: a stroboscopic or Poincaré map of
    a flow) from the product of its Jacobians (the monodromies, saltation included), QR at every
    iteration in the scaled norm. transient / total in iterations (defaults 20 / 200: each
    iteration integrates the flow with its tangent vectors over one period)."""
    n_tr = DERIVED_TRANSIENT if transient is None else int(transient)
    n_int = DERIVED_TOTAL if total is None else int(total)
    if n_tr < 0 or n_int < 2:
        raise InputError(f"transient = {transient!r}, total = {total!r}: need transient >= 0 and "
                         f"total >= 2 iterations")
    s = np.asarray(m.scales, dtype=float)
    x, z = m.y0.copy(), m.z0.copy()
    for _ in range(n_tr):
        st = m.step(x, z)
        x, z = st.x, st.z
    Q = Q0.copy()
    rates = np.empty((n_int, k))
    for i in range(n_int):
        st = m.step(x, z, jacobian=True)
        A = (st.M * s[None, :] / s[:, None]) @ Q
        Q, R = np.linalg.qr(A)
        d = np.diag(R)
        rates[i] = np.log(np.abs(d))
        Q = Q * np.sign(d)[None, :]
        x, z = st.x, st.z
    settings = dict(transient=n_tr, total=n_int, renorm_interval=1, seed=seed, n_blocks=n_blocks,
                    jacobian="monodromy (tangent integration with saltation)",
                    rtol=m.rtol)
    return _spectrum_result(m, rates, np.ones(n_int), n_blocks, "tangent QR of the derived map",
                            settings)


def lyapunov_spectrum(system, k: int | None = None, *, transient=None, total=None,
                      renorm_interval=None, d0=None, rtol=None, seed: int = 0,
                      n_blocks: int | None = None) -> SpectrumResult:
    """The first k Lyapunov exponents (default k = number of states).

    Flows: perturbation-vector method, no tangent equations. k perturbed trajectories
    y_j = y + d0 * scales * q_j (q_j orthonormal) are integrated next to the reference, each by
    DOPRI5 with rtol and atol = system.tolerance(rtol) on its own states and with its own discrete state;
    every renorm_interval the scaled separations (y_j - y)/(d0 scales) are QR-factorised
    (Gram-Schmidt), ln|R_jj| / T are the local rates and the q_j are replaced by the columns of Q.
      renorm_interval: period/32 (a scene: 1/32 crank revolution), else 0.1 -- short, so that
      the separations stay linear and the strongly contracting directions are not lost in the
      integration error before the next QR.
      transient: 20 periods (else 20); total: 500 periods (else 500); d0: 1e-5; rtol: 1e-10.
    Maps: tangent map with the analytic Jacobian when the map has one (else central finite
    differences), QR every renorm_interval (default 1) iteration(s); transient 1000,
    total 100000 iterations.
    """
    n = system.n
    k = n if k is None else int(k)
    if not 1 <= k <= n:
        raise InputError(f"k = {k!r}: must be between 1 and the number of states {n}")
    rng = np.random.default_rng(check_seed(seed))
    n_blocks = DEFAULTS["n_blocks"] if n_blocks is None else int(n_blocks)
    Q0 = np.linalg.qr(rng.standard_normal((n, k)))[0]
    Q0 = np.ascontiguousarray(Q0)
    if system.is_derived:
        return _derived_map_spectrum(system, k, Q0, transient, total, n_blocks, seed)
    if system.is_map:
        n_tr, n_int, every = _map_settings(system, transient, total, renorm_interval)
        use_fd = system.jacobian is None
        # numba needs a callable of the Jacobian's signature in the branch not taken
        jac = _no_jac if use_fd else system.jacobian
        if system.builtin_code is not None and not use_fd:
            logs, _ = _map_qr_builtin(system.y0.copy(), _builtin_p(system), system.scales, Q0,
                                      n_tr, n_int, every)
        else:
            logs, _ = _map_qr(system.f, jac, use_fd, system.y0.copy(), system.p, system.scales,
                              Q0, n_tr, n_int, every)
        T = float(every)
        rates = logs / T
        settings = dict(transient=n_tr, total=n_int * every, renorm_interval=every, seed=seed,
                        n_blocks=n_blocks, jacobian="finite differences" if use_fd else "analytic")
        period = None
        method = "tangent QR"
    else:
        transient, n_int, T, d0, rtol = _flow_settings(system, transient, total,
                                                       renorm_interval, d0, rtol, True)
        y, z = system.y0.copy(), system.z0.copy()
        t_start = system.t0
        if transient > 0:
            y, z = advance(system, y, z, t_start, t_start + transient, rtol)
            t_start += transient
        sc = system.scales
        Q = Q0
        yp = [y + d0 * sc * Q[:, j] for j in range(k)]
        zp = [z.copy() for _ in range(k)]
        rates = np.empty((n_int, k))
        D = np.empty((n, k))
        for i in range(n_int):
            t = t_start + i * T
            t1 = t + T
            y, z = advance(system, y, z, t, t1, rtol)
            for j in range(k):
                yp[j], zp[j] = advance(system, yp[j], zp[j], t, t1, rtol)
                D[:, j] = (yp[j] - y) / (sc * d0)
            Q, R = np.linalg.qr(D)
            diag = np.diag(R)
            if not np.all(np.isfinite(diag)) or np.any(diag == 0.0):
                raise InputError(f"{system.name}: degenerate perturbations at t = {t1:g}; "
                                 "shorten renorm_interval or change d0")
            rates[i] = np.log(np.abs(diag)) / T
            Q = Q * np.sign(diag)
            # the memory differences follow the separations: Z_new = Z_old R^-1 (as Q = D R^-1)
            mem = system.memory
            if mem.size:
                Zd = np.array([zp[j][mem] - z[mem] for j in range(k)]).T     # (m, k)
                both = np.array([(zp[j][mem] != 0.0) & (z[mem] != 0.0) for j in range(k)]).T
                Rs = np.sign(diag)[:, None] * R                  # D = Q Rs after the sign fix
                Zn = np.linalg.solve(Rs.T, Zd.T).T                # Zd Rs^-1
            for j in range(k):
                yj = y + d0 * sc * Q[:, j]
                if mem.size:
                    for a, m in enumerate(mem):
                        if both[a, j]:
                            zp[j][m] = z[m] + Zn[a, j]
                cross_events(system, t1, yp[j], yj, zp[j])
                yp[j] = yj
        settings = dict(transient=transient, total=n_int * T, renorm_interval=T, d0=d0,
                        rtol=rtol, seed=seed, n_blocks=n_blocks, norm="scaled",
                        scales=system.scales.tolist())
        period = system.period
        method = "perturbation vectors (QR)"
    weights = np.full(n_int, T)
    return _spectrum_result(system, rates, weights, n_blocks, method, settings)


# ---------------------------------------------------------------- tangent dynamics
def _progress_bar(total: float, desc: str, unit: str, enabled):
    """The progress bar of nld.progress (stderr; None: automatic, as the command line set it)."""
    from nld.progress import progress_bar
    return progress_bar(total=total, unit=unit, desc=desc, enabled=enabled, delay=2.0)


def _advance_bounded(system, y, z, t0, t1, rtol):
    """``advance`` over [t0, t1] in stretches of at most 50 periods, each near the time origin
    and with the angles wrapped (so long transients keep their accuracy at tight rtol)."""
    if system.period is None:
        return advance(system, y, z, t0, t1, rtol)
    span = 50.0 * system.period
    t = t0
    while t < t1:
        te = min(t1, t + span)
        sh = period_shift(system, t)
        y = wrap_angles(system, y)
        y, z = advance(system, y, restart_labels(system, t - sh, y, z), t - sh, te - sh, rtol)
        t = te
    return y, z


def _per_period(rates: np.ndarray, T: float, period) -> np.ndarray:
    """Local rates (n, k) averaged over groups of whole periods (rows: periods); a flow without
    a period is grouped by its time unit. Unchanged when the interval does not divide it."""
    if period is None:
        period = 1.0          # flows without a period: the base time unit of the defaults
    m = int(round(period / T))
    if m <= 1 or abs(m * T - period) > 1e-9 * period or rates.shape[0] < 2 * m:
        return rates
    n = (rates.shape[0] // m) * m
    return rates[:n].reshape(n // m, m, rates.shape[1]).mean(axis=1)


def lyapunov_tangent(system, k: int = 1, *, transient=None, total=None, renorm_interval=None,
                     rtol=None, seed: int = 0, align=None, tangent_err: bool = TANGENT.tangent_err,
                     target_uncertainty: float | None = TANGENT.target_uncertainty, max_total=None,
                     progress=None, check: bool = False, n_blocks: int | None = None):
    """The first k Lyapunov exponents from the tangent (variational) dynamics, with saltation
    matrices at every event (docs/lyapunov.md). The default estimator of ``nld lyapunov``.

    system: any continuous system of ``nld.systems.core`` (scene, built-in or user ODE); a map is
    sent to the tangent-map QR of ``lyapunov_spectrum``. k: number of exponents (default 1).

    The reference trajectory and k tangent vectors are integrated in lock step by DOPRI5
    (``nld.systems.tangent``, ``nld.integrators.tangent``): the same stages and steps, the event
    location of the reference, each tangent vector mapped by the event's saltation matrix; the
    vectors are re-orthonormalised (modified Gram-Schmidt in the scaled norm) every
    ``renorm_interval`` and ln R_cc / T are the local rates (Benettin et al. 1980; Shimada &
    Nagashima 1979). Times in the system's unit (s):
      transient: 20 periods (else 20): the state alone, by ``advance``, discarded;
      align: 2 periods (else 2): the tangent vectors settle onto the leading directions;
        discarded;
      total: 200 periods (else 200): the averaging time; with ``target_uncertainty`` the
        minimum averaging time, extended in steps of total/4 until the relative uncertainty
        (uncertainty / |lambda_1|) is reached or ``max_total`` (default 10 x total) is spent;
      renorm_interval: period/8 (else 0.1): short enough that the spread of the exponents over
        one interval stays far inside the 16 digits of the vectors;
      rtol: 1e-10, atol = system.tolerance(rtol). tangent_err: the tangent vectors take part in
        the step-size control (nld.integrators.tangent).
    seed: the random initial frame. progress: a bar on stderr (None: when it is a terminal).
    check: also compute lambda_1 with the two-trajectory estimator (``lyapunov_benettin``,
      same transient, averaging time and rtol) and report both in ``result.check``.

    Returns a LyapunovResult for k = 1, else a SpectrumResult; ``diagnostics`` holds the event
    and saltation counts (events, upward crossings = contact onsets of a scene, grazing events,
    simultaneous events) and per-period rates of them; ``settings`` every setting used.
    """
    from nld.systems.tangent import diag_dict, run_tangent, tangent_functions
    from nld.integrators.tangent import N_DIAG, crossing_diag
    from nld.systems.derived import memory_pairs
    if system.is_map:
        return lyapunov_spectrum(system, k, transient=transient, total=total,
                                 renorm_interval=renorm_interval, seed=seed, n_blocks=n_blocks)
    n = system.n
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= n:
        raise InputError(f"k = {k!r}: must be a whole number between 1 and the number of "
                         f"states {n}")
    k = int(k)
    seed = check_seed(seed)
    base = system.period if system.period is not None else 1.0
    d = DEFAULTS["tangent"]
    if renorm_interval is None:
        renorm_interval = (base * d["interval_period"] if system.period is not None
                           else d["interval_no_period"])
    _check_positive("renorm_interval", renorm_interval)
    transient = d["transient_base"] * base if transient is None else transient
    total = d["total_base"] * base if total is None else total
    align = d["align_base"] * base if align is None else align
    for nm, v in (("transient", transient), ("align", align)):
        if not (isinstance(v, (int, float, np.floating, np.integer)) and math.isfinite(v)
                and v >= 0):
            raise InputError(f"{nm} = {v!r}: must be a time >= 0")
    _check_positive("total", total)
    rtol = d["rtol"] if rtol is None else rtol
    check_rtol(rtol)
    if target_uncertainty is not None:
        if not (isinstance(target_uncertainty, (int, float, np.floating)) and
                0 < target_uncertainty < 1):
            raise InputError(f"target_uncertainty = {target_uncertainty!r}: must be a relative "
                             "uncertainty in (0, 1), e.g. 0.05")
        max_total = TANGENT.max_total_factor * total if max_total is None else max_total
        _check_positive("max_total", max_total)
        if max_total < total:
            raise InputError(f"max_total = {max_total!r}: must be >= total = {total!r}")
    T = float(renorm_interval)
    n_int = int(round(total / T))
    if n_int < 2:
        raise InputError(f"total = {total!r}: need at least two renormalisation intervals of {T:g}")
    _, how = tangent_functions(system)
    rng = np.random.default_rng(check_seed(seed))
    y, z = system.y0.copy(), system.z0.copy()
    t = system.t0
    if transient > 0:
        y, z = _advance_bounded(system, y, z, t, t + transient, rtol)
        t += transient
    Q0 = np.linalg.qr(rng.standard_normal((n, k)))[0].T          # (k, n), scaled
    W = np.ascontiguousarray(Q0 * system.scales)
    Wz = np.zeros((k, z.size))
    h = 0.0
    if align > 0:
        n_al = max(1, int(round(align / T)))
        sh = period_shift(system, t)
        y = wrap_angles(system, y)
        z = restart_labels(system, t - sh, y, z)
        run = run_tangent(system, y, z, W, Wz, t - sh, (t - sh) + T * np.arange(1, n_al + 1),
                          rtol, tangent_err=tangent_err, h0=h)
        y, z, W, Wz, h, t = run.y, run.z, run.W, run.Wz, run.h_next, run.t + sh
    n_ev = int(system.n_events)
    diag = crossing_diag(n_ev)          # + per event: smallest onset speed, onset count
    logs: list[np.ndarray] = []
    n_target = n_int
    n_max = n_int if target_uncertainty is None else int(round(max_total / T))
    if target_uncertainty is None:
        _check_record("total", total, n_max, k, T, system.time_unit)
    else:
        _check_record("max_total", max_total, n_max, k, T, system.time_unit)
    chunk = max(1, int(round((base if system.period is not None else 1.0) / T)))
    chunk = min(max(chunk, n_int // 200), 100_000)
    bar = _progress_bar(n_max * T / base, f"lyapunov {system.name}",
                        "rev" if system.period_name == "revolution" else
                        ("periods" if system.period is not None else system.time_unit), progress)
    done = 0
    reached = None
    stats = np.zeros(5, dtype=np.int64)
    try:
        while done < n_target:
            m = min(chunk, n_target - done)
            # near the time origin, angles wrapped (systems.period_shift, wrap_angles)
            sh = period_shift(system, t)
            y = wrap_angles(system, y)
            z = restart_labels(system, t - sh, y, z)
            marks = (t - sh) + T * np.arange(1, m + 1)
            run = run_tangent(system, y, z, W, Wz, t - sh, marks, rtol, tangent_err=tangent_err,
                              h0=h, diag=diag)
            y, z, W, Wz, h = run.y, run.z, run.W, run.Wz, run.h_next
            t = marks[run.logs.shape[0] - 1] + sh if run.logs.shape[0] else t
            logs.append(run.logs)
            stats += run.stats
            done += run.logs.shape[0]
            bar.update(run.logs.shape[0] * T / base)
            if run.status == 1:
                break
            if target_uncertainty is not None and done >= n_target and n_target < n_max:
                r1 = _per_period(np.concatenate(logs) / T, T, system.period)[:, 0]
                est, _, se, sp = _stats(r1, np.ones(r1.shape))
                u = _uncertainty(se, sp, r1.shape[0])
                if abs(est) > 0 and u / abs(est) <= target_uncertainty:
                    reached = True
                else:
                    n_target = min(n_max, n_target + max(1, n_int // 4))
    finally:
        bar.close()
    L = np.concatenate(logs) if logs else np.zeros((0, k))
    if L.shape[0] < 2:
        raise InputError(f"{system.name}: the tangent run stopped after {L.shape[0]} intervals")
    rates = L / T
    if target_uncertainty is not None and reached is None:
        reached = False
    # statistics per whole period (a forced system's local rates repeat with the forcing: the
    # mean over whole periods is exact for a periodic motion, and blocks of whole periods are
    # what the blocking estimate should start from); a trailing part period is dropped
    per = _per_period(rates, T, system.period)
    Tw = T * (rates.shape[0] // per.shape[0]) if per.shape[0] else T
    weights = np.full(per.shape[0], Tw)
    times = np.cumsum(weights)
    avg_time = float(per.shape[0] * Tw)
    rates = per
    dd = diag_dict(diag)
    if system.period is not None:
        periods = L.shape[0] * T / system.period
        dd["events_per_period"] = dd["events"] / periods
        dd["onsets_per_period"] = dd["upward_crossings"] / periods
    dd["steps"] = int(stats[1])
    dd["rejected"] = int(stats[2])
    # permanent contact: a contact-law memory that no onset reset over the averaging span is a
    # neutral direction (multiplier 1) set by the history; the exponent is conditional on it
    frozen = {name: float(z[i]) for i, e, name in memory_pairs(system)
              if e >= 0 and diag[N_DIAG + n_ev + e] == 0}
    dd["permanent_contact"] = bool(frozen)
    if frozen:
        dd["conditional_on_memory"] = frozen
    settings = dict(estimator="tangent", transient=float(transient), align=float(align),
                    total=avg_time, renorm_interval=T, rtol=float(rtol), seed=seed,
                    tangent_err=bool(tangent_err), jacobian=how, norm="scaled",
                    scales=system.scales.tolist(), integrator="dopri5 (tangent, lock step)",
                    target_uncertainty=target_uncertainty,
                    max_total=None if target_uncertainty is None else float(max_total),
                    target_reached=reached)
    period = system.period
    pname = system.period_name or "revolution"
    if k == 1:
        est, hist, se, sp = _stats(rates[:, 0], weights, n_blocks)
        res = LyapunovResult(
            exponent=est, per_revolution=None if period is None else est * period,
            history=hist, times=times, uncertainty=_uncertainty(se, sp, rates.shape[0]),
            block_se=se,
            history_spread=sp, units=_units(system), local_rates=rates[:, 0],
            method="tangent", system=system.name, period=period, settings=settings,
            period_name=pname, diagnostics=dd)
        if check:
            b = lyapunov_benettin(system, transient=transient, total=avg_time, rtol=rtol,
                                  seed=seed)
            diff = abs(b.exponent - res.exponent)
            res.check = dict(benettin=b.exponent, benettin_uncertainty=b.uncertainty,
                             tangent=res.exponent, tangent_uncertainty=res.uncertainty,
                             difference=diff, agree=bool(diff <= b.uncertainty + res.uncertainty),
                             benettin_settings=b.settings)
        return res
    res = _spectrum_result(system, rates, weights, n_blocks, "tangent QR", settings)
    res.diagnostics = dd
    return res


ESTIMATORS = ("tangent", "benettin")


def largest_exponent(system, estimator: str = "tangent", *, total, transient=0.0, rtol=None,
                     d0=None, seed: int = 0, progress=False,
                     tangent_err: bool | None = None) -> LyapunovResult:
    """lambda_1 of ``system`` by the named estimator, as the sweeps and studies call it.

    estimator: "tangent" (default: :func:`lyapunov_tangent`, tangent dynamics with saltation,
    its default alignment and renormalisation interval) or "benettin"
    (:func:`lyapunov_benettin`, two trajectories, separation ``d0``). total: the averaging time
    (s); transient: discarded first (s, default 0: a sweep starts from the end of a section,
    already on the attractor); rtol: default the estimator's (1e-10). The result's
    ``settings`` hold everything used; ``nld.output.report.estimator_text`` turns them into one line.
    tangent_err (tangent estimator): the tangent vectors in the step-size control (default
    ``nld.settings.TANGENT.tangent_err``, True; docs/lyapunov.md, "Error control").
    """
    if estimator not in ESTIMATORS:
        raise InputError(f"estimator = {estimator!r}: must be one of {', '.join(ESTIMATORS)}")
    if estimator == "tangent":
        return lyapunov_tangent(system, transient=transient, total=total, rtol=rtol, seed=seed,
                                progress=progress,
                                tangent_err=TANGENT.tangent_err if tangent_err is None else tangent_err)
    return lyapunov_benettin(system, transient=transient, total=total, rtol=rtol, d0=d0,
                             seed=seed, progress=progress)


@njit
def _no_jac(x, p, J):
    pass


# ---------------------------------------------------------------- nolds (comparison only)
def _import_nolds():
    """nolds 0.6.x fails to import on Python 3.11 (``importlib.resources.files`` of the module
    ``nolds.datasets``, which is not a package). Retry with files() of a module mapped to its
    package, which is what the datasets module means."""
    try:
        import nolds
        return nolds
    except TypeError:
        import importlib.resources as res
        import sys
        orig = res.files

        def files(anchor=None):
            try:
                return orig(anchor)
            except TypeError:
                # a module or a package object: importlib's anchor, not an nld system (a third party's shim)
                name = anchor if isinstance(anchor, str) else getattr(anchor, "__name__", "")
                return orig(name.rpartition(".")[0])

        for m in [m for m in sys.modules if m == "nolds" or m.startswith("nolds.")]:
            del sys.modules[m]
        res.files = files
        try:
            import nolds
        finally:
            res.files = orig
        return nolds


NOLDS_DEFAULTS = {
    "rosenstein": dict(emb_dim=10, lag=None, min_tsep=None, trajectory_len=20, fit="poly"),
    "eckmann": dict(emb_dim=10, matrix_dim=4, min_nb=None, min_tsep=0),
}


def lyapunov_nolds(series, dt: float, method: str = "rosenstein", **settings):
    """Lyapunov exponent(s) of a scalar, evenly sampled series with nolds, per second.

    For comparison only: these reconstruct the dynamics from one observable by delay embedding
    and are much less accurate than :func:`lyapunov_benettin` on the equations.

    series: samples x(i dt); dt: sampling step (s). Returns value(s) x 1/dt (per second; nolds
    itself works per sample, its ``tau`` is not used).

    method="rosenstein" -> float, nolds.lyap_r (Rosenstein et al. 1993), defaults
      emb_dim=10 (embedding dimension), lag=None (nolds: where the autocorrelation falls to
      1 - 1/e), min_tsep=None (nolds: the mean period from the FFT; neighbours closer in time are
      excluded), trajectory_len=20 (samples followed; the fit must stay in the linear part of the
      divergence curve, so choose dt x trajectory_len of a few 1/lambda at most),
      fit="poly" (least squares: deterministic; nolds' default RANSAC is random).
    method="eckmann" -> array of matrix_dim exponents, nolds.lyap_e (Eckmann et al. 1986),
      defaults emb_dim=10, matrix_dim=4 ((emb_dim-1) must be divisible by (matrix_dim-1)),
      min_nb=None (nolds: min(2 matrix_dim, matrix_dim + 4)), min_tsep=0. Reliable in sign, not
      magnitude (nolds issue 36).
    Beware: nolds' own Lorenz test compares with 2.4, the Lyapunov *dimension*, not the exponent.
    Memory is O(N^2) for rosenstein: keep series to a few thousand samples.
    """
    _check_positive("dt", dt)
    x = np.asarray(series, dtype=float).ravel()
    if x.size < 10 or not np.all(np.isfinite(x)):
        raise InputError("series: need at least 10 finite samples")
    if "tau" in settings:
        raise InputError("tau: not used; give dt (the result is already per second)")
    nolds = _import_nolds()
    if method == "rosenstein":
        kw = dict(NOLDS_DEFAULTS["rosenstein"])
        kw.update(settings)
        return float(nolds.lyap_r(x, tau=1, **kw)) / dt
    if method == "eckmann":
        kw = dict(NOLDS_DEFAULTS["eckmann"])
        kw.update(settings)
        return np.asarray(nolds.lyap_e(x, tau=1, **kw), dtype=float) / dt
    raise InputError(f"method = {method!r}: must be 'rosenstein' or 'eckmann'")
