"""Lyapunov exponents of any system of ``nld.systems`` (flows, maps, mechanism scenes).

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
system's per-state scales (for a scene: clearance-based, ``nld.simulate.state_scales``), so the
tiny journal coordinates are not swamped by angles and the result does not depend on units.

Units: flows 1/s (natural log per second of the system's time); ``per_revolution`` = exponent x
period (natural log per crank revolution for a scene, per forcing period for a forced system);
maps per iteration.

Uncertainty: the local stretching rates r_i = ln(d_i/d0)/T_i are cut into ``n_blocks`` (20)
contiguous blocks; ``block_se`` = std(block means)/sqrt(n_blocks) (standard error);
``history_spread`` = half the range of the running estimate over its last half;
``uncertainty = block_se + history_spread``.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from .errors import InputError
from .systems import advance, builtin_map, builtin_map_jac

__all__ = ["LyapunovResult", "SpectrumResult", "lyapunov_benettin", "lyapunov_spectrum",
           "lyapunov_nolds", "DEFAULTS"]

# documented defaults (docs/lyapunov.md); "base" = the system's period (a scene: one crank
# revolution), or 1 time unit for a flow without period
DEFAULTS = {
    # Benettin, flows: renorm_interval = base, checks = 32 per interval when the system has a
    # period (else 1), early renormalisation when the separation exceeds max_growth * d0,
    # transient = 20 base, total = 500 base
    "flow": dict(rtol=1e-10, d0=1e-5, max_growth=10.0, checks_with_period=32,
                 transient_base=20.0, total_base=500.0, interval_base=1.0),
    # perturbation vectors, flows: renorm_interval = base / 32 (period) or 0.1 (no period)
    "spectrum_flow": dict(rtol=1e-10, d0=1e-5, transient_base=20.0, total_base=500.0,
                          interval_period=1.0 / 32.0, interval_no_period=0.1),
    "map": dict(d0=1e-9, renorm_interval=1, transient=1000, total=100_000),
    "n_blocks": 20,
}


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

    @property
    def uncertainty_per_revolution(self):
        return None if self.period is None else self.uncertainty * self.period

    def __str__(self):
        s = (f"{self.method} {self.system}: lambda1 = {self.exponent:.6g} +- "
             f"{self.uncertainty:.2g} {self.units}")
        if self.per_revolution is not None:
            s += (f" = {self.per_revolution:.4g} +- {self.uncertainty_per_revolution:.2g}"
                  " per revolution")
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

    @property
    def exponent(self) -> float:
        return float(self.exponents[0])

    def __str__(self):
        ex = ", ".join(f"{e:.5g}+-{u:.2g}" for e, u in zip(self.exponents, self.uncertainty))
        return (f"{self.method} {self.system}: [{ex}] {self.units}, sum {self.total:.6g}"
                f" +- {self.total_uncertainty:.2g}")


def _stats(rates: np.ndarray, weights: np.ndarray, n_blocks: int):
    """Running estimate, block standard error, half-range of the last half of the history."""
    csum = np.cumsum(rates * weights)
    cw = np.cumsum(weights)
    hist = csum / cw
    est = float(hist[-1])
    n = rates.shape[0]
    nb = int(min(n_blocks, n))
    if nb >= 2:
        means = np.array([np.sum(r * w) / np.sum(w) for r, w in
                          zip(np.array_split(rates, nb), np.array_split(weights, nb))])
        se = float(np.std(means, ddof=1) / math.sqrt(nb))
    else:
        se = float("nan")
    tail = hist[n // 2:]
    spread = float(0.5 * (tail.max() - tail.min())) if tail.size else float("nan")
    return est, hist, se, spread


def _units(system) -> str:
    return "1/iteration" if system.is_map else f"1/{system.time_unit}"


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
    if not (isinstance(rtol, (int, float)) and 1e-14 <= rtol < 1):
        raise InputError(f"rtol = {rtol!r}: must be a number in [1e-14, 1)")
    n_int = int(round(total / renorm_interval))
    if n_int < 2:
        raise InputError(f"total = {total!r}: need at least two renormalisation intervals "
                         f"of {renorm_interval:g}")
    return float(transient), n_int, float(renorm_interval), float(d0), float(rtol)


def _cross_events(system, t, y_old, y_new, z):
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
                      max_growth: float | None = None, n_blocks: int | None = None
                      ) -> LyapunovResult:
    """Largest Lyapunov exponent by the two-trajectory method of Benettin et al. (1980).

    system: any ``nld.systems`` system (ContinuousSystem, SceneSystem, DiscreteMap).

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
    (a contact onset) reports the crossing to the system's ``on_event`` (see _cross_events).
    """
    rng = np.random.default_rng(seed)
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
        for i in range(n_int):
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
                    _cross_events(system, tb, yp, yp_new, zp)
                    yp = yp_new
                    n_renorm += 1
            rates[i] = acc / T
        settings = dict(transient=transient, total=n_int * T, renorm_interval=T, d0=d0,
                        rtol=rtol, seed=seed, checks=checks, max_growth=max_growth,
                        renormalisations=n_renorm, n_blocks=n_blocks, norm="scaled",
                        scales=system.scales.tolist())
        period = system.period
    weights = np.full(rates.shape, T)
    times = np.cumsum(weights)
    est, hist, se, spread = _stats(rates, weights, n_blocks)
    return LyapunovResult(
        exponent=est, per_revolution=None if period is None else est * period, history=hist,
        times=times, uncertainty=se + spread, block_se=se, history_spread=spread,
        units=_units(system), local_rates=rates, method="benettin", system=system.name,
        period=period, settings=settings)


# ---------------------------------------------------------------- spectrum
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
    rng = np.random.default_rng(seed)
    n_blocks = DEFAULTS["n_blocks"] if n_blocks is None else int(n_blocks)
    Q0 = np.linalg.qr(rng.standard_normal((n, k)))[0]
    Q0 = np.ascontiguousarray(Q0)
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
            for j in range(k):
                yj = y + d0 * sc * Q[:, j]
                _cross_events(system, t1, yp[j], yj, zp[j])
                yp[j] = yj
        settings = dict(transient=transient, total=n_int * T, renorm_interval=T, d0=d0,
                        rtol=rtol, seed=seed, n_blocks=n_blocks, norm="scaled",
                        scales=system.scales.tolist())
        period = system.period
        method = "perturbation vectors (QR)"
    weights = np.full(n_int, T)
    times = np.cumsum(weights)
    ex, se, sp, hist = np.empty(k), np.empty(k), np.empty(k), np.empty((n_int, k))
    for j in range(k):
        ex[j], hist[:, j], se[j], sp[j] = _stats(rates[:, j], weights, n_blocks)
    tot, _, tse, tsp = _stats(rates.sum(axis=1), weights, n_blocks)
    return SpectrumResult(
        exponents=ex, per_revolution=None if period is None else ex * period, history=hist,
        times=times, uncertainty=se + sp, block_se=se, history_spread=sp, total=tot,
        total_uncertainty=tse + tsp, units=_units(system), local_rates=rates, method=method,
        system=system.name, period=period, settings=settings)


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
