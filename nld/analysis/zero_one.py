"""The 0-1 test for chaos (Gottwald & Melbourne 2004, 2009) on any observable series.

    from nld.analysis.zero_one import zero_one_test
    r = zero_one_test(series)          # r.K ~ 0: regular (periodic, quasi-periodic); ~ 1: chaotic
    r.K, r.Kc, r.c                     # the median and the per-c values

Method: the *modified* mean-square displacement with the correlation method of Gottwald &
Melbourne (2009), "On the implementation of the 0-1 test for chaos", SIAM J. Appl. Dyn. Syst.
8:129-145 (the test itself: Proc. R. Soc. Lond. A 460 (2004) 603-611). For a series
phi(j), j = 1 .. N, and a frequency c:

* translation variables  p_c(n) = sum_{j<=n} phi(j) cos(j c),  q_c(n) = sum_{j<=n} phi(j) sin(j c);
  they are bounded for regular dynamics and behave like a Brownian motion for chaotic dynamics;
* mean-square displacement  M_c(n) = mean_j [p_c(j+n) - p_c(j)]^2 + [q_c(j+n) - q_c(j)]^2,
  j = 1 .. N - n (all available pairs), for n = 1 .. n_cut (default n_cut = round(N/10));
* the oscillating term is removed:  D_c(n) = M_c(n) - V_osc(c, n),
  V_osc = (E phi)^2 (1 - cos n c) / (1 - cos c), E phi the mean of the series (``form="paper"``,
  the default); ``form="mean_free"`` takes M_c of phi - E phi instead (the same up to a cross term
  of zero mean, see :func:`zero_one_test`);
* K_c = correlation coefficient of (n, D_c(n)), n = 1 .. n_cut (the "correlation method");
* K = median of K_c over ``n_c`` (100) frequencies c drawn uniformly from (pi/5, 4 pi/5) with a
  fixed ``seed`` (the range avoids the resonances at c = 0 and pi; the median discards the few
  c that resonate with a frequency of a regular signal, whose K_c is near 1).

K is invariant to the scale of the series; to its mean exactly with form="mean_free", in
expectation with the paper's form. The sums over j
are computed exactly with FFTs (autocorrelation of p_c + i q_c), O(n_c N log N).

Input requirements (Gottwald & Melbourne 2009, sections 3 and 5):

* the series should not be oversampled: a finely sampled flow looks locally regular and gives K
  near 0 even when the flow is chaotic. Sample a flow coarsely (e.g. Lorenz every 0.5-1 s, about
  the decorrelation time) or use a Poincare section (a stroboscopic map of a forced system).
* N of a few hundred at least; with N ~ 100 individual K_c scatter widely, and K becomes a rough
  indication only. The transient must be removed first.
* The test answers "regular or chaotic", not how chaotic: K is not a Lyapunov exponent, and a
  weakly chaotic series can need a long N to reach K ~ 1.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from nld.errors import InputError

__all__ = ["ZeroOneResult", "zero_one_test", "DEFAULTS"]

DEFAULTS = dict(n_c=100, c_min=math.pi / 5, c_max=4 * math.pi / 5, seed=0, cut_fraction=0.1,
                min_cut=3)


@dataclass
class ZeroOneResult:
    """Result of :func:`zero_one_test`.

    K: median of Kc (dimensionless, ~0 regular, ~1 chaotic). Kc: the per-frequency correlation
    coefficients, at the frequencies ``c`` (rad per sample). n_cut: largest n of D_c(n); N: the
    series length. D: (n_c, n_cut) modified mean-square displacements (unit of the series
    squared), for plots. settings: n_c, c range, seed.
    """
    K: float
    Kc: np.ndarray
    c: np.ndarray
    n_cut: int
    N: int
    D: np.ndarray = field(repr=False)
    settings: dict = field(default_factory=dict)

    @property
    def spread(self) -> float:
        """Half the inter-quartile range of Kc: a rough measure of how well K is determined."""
        if self.Kc.size == 0 or not np.any(np.isfinite(self.Kc)):
            return float("nan")
        q1, q3 = np.nanpercentile(self.Kc, [25, 75])
        return float(0.5 * (q3 - q1))

    def __str__(self):
        return (f"0-1 test: K = {self.K:.3f} (median of {self.Kc.size} K_c, "
                f"quartile half-range {self.spread:.2g}; N = {self.N}, n_cut = {self.n_cut})")


def _as_series(series) -> np.ndarray:
    try:
        import pandas as pd
        if isinstance(series, pd.DataFrame):
            if series.shape[1] != 1:
                raise InputError("series: a DataFrame with one column, or pick one observable "
                                 "(e.g. section.table['B.ex'])")
            series = series.iloc[:, 0]
    except ImportError:           # pragma: no cover - pandas is a dependency
        pass
    x = np.asarray(series, dtype=float)
    if x.ndim != 1:
        x = x.ravel() if x.ndim == 2 and 1 in x.shape else None
        if x is None:
            raise InputError("series: give one observable (a 1-D array)")
    return x


def _msd(phi: np.ndarray, c: np.ndarray, n_cut: int) -> np.ndarray:
    """M_c(n), n = 1..n_cut, for every c (rows): mean over j = 1..N-n of |z(j+n) - z(j)|^2 with
    z = p + i q. Uses sum |z(j+n) - z(j)|^2 = S2(j in n..N-1) + S2(j in 0..N-1-n)
    - 2 Re sum z(j+n) conj z(j), the last term from the FFT autocorrelation."""
    N = phi.size
    j = np.arange(1, N + 1, dtype=float)
    z = np.cumsum(phi[None, :] * np.exp(1j * np.outer(c, j)), axis=1)      # (n_c, N)
    a2 = np.abs(z) ** 2
    cs = np.concatenate([np.zeros((c.size, 1)), np.cumsum(a2, axis=1)], axis=1)
    nfft = 1 << int(math.ceil(math.log2(2 * N)))
    F = np.fft.fft(z, nfft, axis=1)
    acf = np.fft.ifft(np.abs(F) ** 2, axis=1)[:, : n_cut + 1]               # sum_j z(j+n) conj z(j)
    n = np.arange(1, n_cut + 1)
    tail = cs[:, N][:, None] - cs[:, n]            # sum over j >= n of |z(j)|^2
    head = cs[:, N - n]                            # sum over j <= N-1-n
    M = (tail + head - 2.0 * acf[:, 1:].real) / (N - n)[None, :]
    return np.maximum(M, 0.0)


def zero_one_test(series, *, n_c: int | None = None, c_range=None, seed: int | None = None,
                  n_cut: int | None = None, c=None, atol: float = 0.0,
                  form: str = "paper") -> ZeroOneResult:
    """0-1 test for chaos of an observable series (see the module docstring).

    series: 1-D samples phi(1..N) of one observable, evenly spaced in time or section count
      (a Poincare-section series such as ``section.table["B.ex"]``, a coarsely sampled flow, the
      iterates of a map); transient removed. At least 10 n_cut samples (default: 30).
    n_c: number of random frequencies (100); c_range: (c_min, c_max) in rad per sample, default
      (pi/5, 4 pi/5); seed: the generator seed of the frequencies (0), so K is deterministic;
      c: explicit frequencies instead (n_c, c_range and seed are then not used).
    n_cut: largest lag n of D_c(n) (default round(N/10), at least 3).
    atol: a series whose spread max - min is <= atol (unit of the series) is a fixed point:
      K = 0 with every K_c 0 (default 0: only an exactly constant series). Give it for data with
      noise, e.g. a period-1 stroboscopic series that repeats to the integration error: the test
      cannot tell noise from chaos (zero-mean noise alone gives K ~ 1), so the noise on a constant
      could decide K.
    form: "paper" (default): D_c = M_c - V_osc of the series itself, as Gottwald & Melbourne
      (2009); "mean_free": M_c of the series minus its mean (D_c without the zero-mean cross
      term 2 E phi Re(...) of the paper's form). They agree for a series whose fluctuations are
      not small against its mean (logistic map: K to 1e-3). They differ for a nearly constant
      series with a large mean, such as a period-1 section that repeats to the integration noise
      or has a decaying transient. There the paper's cross term dominates D_c, so K depends on
      the mean. It gave K ~ 0 on the slider-crank's period-1 section, but 0.57 for white noise of
      1e-12 on 0.25. The mean-free form sees the noise or transient alone and gives K up to ~1.
      Neither form gives a reliable verdict there: declare such a series a fixed point with atol,
      or with period_of as nld.analysis.chaos_map does. The paper form is not invariant to an offset of
      the series; the mean-free form is, to round-off.

    Returns a :class:`ZeroOneResult` (K, Kc per c, c, ...).
    """
    if form not in ("paper", "mean_free"):
        raise InputError(f"form = {form!r}: 'paper' or 'mean_free'")
    x = _as_series(series)
    if not np.all(np.isfinite(x)):
        raise InputError("series: every sample must be finite (remove failed points first)")
    N = x.size
    if n_cut is None:
        n_cut = max(DEFAULTS["min_cut"], int(round(DEFAULTS["cut_fraction"] * N)))
    if isinstance(n_cut, bool) or int(n_cut) != n_cut or n_cut < DEFAULTS["min_cut"]:
        raise InputError(f"n_cut = {n_cut!r}: must be an integer >= {DEFAULTS['min_cut']}")
    n_cut = int(n_cut)
    if N < 10 * n_cut:
        raise InputError(f"series: {N} samples are too few for n_cut = {n_cut}; the 0-1 test needs "
                         f"N >= 10 n_cut (at least {10 * DEFAULTS['min_cut']}, better several hundred)")
    if c is not None:
        cs = np.atleast_1d(np.asarray(c, dtype=float))
        if cs.size == 0 or not np.all((cs > 0) & (cs < math.pi)):
            raise InputError(f"c = {c!r}: frequencies must lie in (0, pi)")
        settings = dict(c="given", n_c=int(cs.size))
    else:
        n_c = DEFAULTS["n_c"] if n_c is None else n_c
        if isinstance(n_c, bool) or int(n_c) != n_c or n_c < 1:
            raise InputError(f"n_c = {n_c!r}: must be an integer >= 1")
        lo, hi = (DEFAULTS["c_min"], DEFAULTS["c_max"]) if c_range is None else map(float, c_range)
        if not (0 < lo < hi < math.pi):
            raise InputError(f"c_range = {c_range!r}: need 0 < c_min < c_max < pi")
        seed = DEFAULTS["seed"] if seed is None else int(seed)
        cs = np.random.default_rng(seed).uniform(lo, hi, int(n_c))
        settings = dict(n_c=int(n_c), c_range=[lo, hi], seed=seed)
    settings["n_cut"] = n_cut
    xi = np.arange(1, n_cut + 1, dtype=float)
    if not (atol >= 0.0 and math.isfinite(atol)):
        raise InputError(f"atol = {atol!r}: must be a number >= 0")
    settings["atol"] = float(atol)
    if np.ptp(x) <= atol:      # a fixed point: p, q bounded, D_c identically 0 (up to round-off)
        return ZeroOneResult(0.0, np.zeros(cs.size), cs, n_cut, N, np.zeros((cs.size, n_cut)),
                             settings)
    # D_c(n) = M_c(n) - V_osc(c, n). With phi = E phi + psi, M_c of phi is exactly
    # V_osc + M_c of psi + a cross term 2 E phi Re(...) of zero mean (the oscillating part of p_c,
    # q_c has the j-independent squared increment V_osc). form="paper" (default) keeps the cross
    # term, as Gottwald & Melbourne (2009) do; form="mean_free" takes M_c of psi, which drops it.
    settings["form"] = form
    if form == "paper":
        mean = float(np.mean(x))
        D = _msd(x, cs, n_cut) - mean ** 2 * (1.0 - np.cos(np.outer(cs, xi))) / (1.0 - np.cos(cs))[:, None]
    else:
        D = _msd(x - float(np.mean(x)), cs, n_cut)
    xc = xi - xi.mean()
    Dc = D - D.mean(axis=1, keepdims=True)
    den = np.sqrt(np.sum(Dc ** 2, axis=1) * np.sum(xc ** 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        Kc = np.where(den > 0, (Dc @ xc) / den, 0.0)
    K = float(np.median(Kc))
    return ZeroOneResult(K, Kc, cs, n_cut, N, D, settings)
