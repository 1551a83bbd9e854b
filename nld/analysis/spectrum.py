"""Frequency spectra of simulated signals, with frequencies as orders of the crank frequency.

* :func:`spectrum` -- one-sided power spectral density of a uniformly sampled series, by Welch's
  averaged periodogram (default) or a single windowed FFT periodogram; frequencies in Hz and as
  orders (multiples) of the crank frequency.
* :func:`peaks` -- the largest spectral peaks, with the peak frequency refined by parabolic
  interpolation of log power between bins.
* :func:`table_spectrum` -- the spectrum of one column of a scene run table (default: the contact
  force ``<joint>.Fn`` of the first clearance joint): transient dropped, resampled uniformly.
* :func:`scene_spectrum` -- simulate a scene and take :func:`table_spectrum` of the run.

Units: ``freq_hz`` in Hz; ``order`` = freq_hz / crank frequency (dimensionless); ``power`` is a
density in (unit of the signal)^2/Hz (N^2/Hz for a force), so sum(power) * df is the mean square
of the (detrended) signal (Parseval; exact for ``method="fft"`` with ``window="boxcar"``, and for
any window it is the window-weighted mean square); ``amplitude`` is the amplitude (unit of the
signal) that a pure sinusoid centred on that bin would have (``scaling="spectrum"``), so a peak's
amplitude reads directly as the amplitude of the harmonic (within the window's scalloping loss,
<= 15 % for Hann between bins, 0 at bin centres; the parabolic refinement in :func:`peaks` does
not correct amplitudes).

Window: Hann by default (sidelobes -31 dB, falling 18 dB/octave: harmonics of very different power
stay separable; main lobe 4 bins wide). ``"boxcar"`` (no window) gives the sharpest peaks and exact
Parseval, but leaks heavily (-13 dB sidelobes) when a frequency is not a bin centre; ``"flattop"``
reads amplitudes to 0.1 % at the cost of a 10-bin main lobe; any ``scipy.signal.get_window`` name.

Resolution: df = fs / nperseg (Welch; default nperseg = the largest power of two <= N/4, so about
7 averaged segments with 50 % overlap) or fs / N (fft). Two frequencies closer than about two bins
(Hann) are not resolved. The refined peak frequency is accurate to a small fraction of a bin for
an isolated peak.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from nld.errors import InputError
from nld.settings import SPECTRUM, SPECTRUM_SPANS

__all__ = ["spectrum", "peaks", "table_spectrum", "scene_spectrum", "resample_uniform",
           "crank_frequency_of"]

METHODS = ("welch", "fft")


def _check_series(series) -> np.ndarray:
    x = np.asarray(series, dtype=float).ravel()
    if x.size < 8:
        raise InputError(f"series: {x.size} samples; need at least 8")
    if not np.all(np.isfinite(x)):
        raise InputError("series: contains NaN or inf (a failed run? drop those rows first)")
    return x


def spectrum(series, dt: float, *, method: str = "welch", window="hann", nperseg: int | None = None,
             crank_frequency: float | None = None, detrend: str | bool = "constant") -> pd.DataFrame:
    """One-sided power spectrum of a uniformly sampled series.

    series: samples (any unit U); dt: sample spacing (s). method: ``"welch"`` (averaged over
    50 %-overlapping segments of ``nperseg`` samples, default the largest power of two <= N/4;
    lower variance, coarser resolution) or ``"fft"`` (a single periodogram of the whole series,
    resolution 1/(N dt)). window: a ``scipy.signal.get_window`` name (default ``"hann"``).
    crank_frequency (Hz): the ``order`` column is freq_hz / crank_frequency (NaN if None).
    detrend: ``"constant"`` (remove the mean, default), ``"linear"`` or False.

    Returns a DataFrame ``freq_hz, order, power, amplitude`` (power in U^2/Hz, amplitude in U, see
    the module docstring); ``attrs`` hold ``resolution_hz``, ``fs``, ``method``, ``window``,
    ``nperseg``, ``crank_frequency``.
    """
    from scipy import signal
    x = _check_series(series)
    if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
        raise InputError(f"dt = {dt!r}: must be a positive sample spacing (s)")
    if method not in METHODS:
        raise InputError(f"method = {method!r}: must be one of {', '.join(METHODS)}")
    if crank_frequency is not None and not (math.isfinite(crank_frequency) and crank_frequency > 0):
        raise InputError(f"crank_frequency = {crank_frequency!r}: must be a positive frequency (Hz)")
    fs = 1.0 / dt
    n = x.size
    try:
        if method == "welch":
            if nperseg is None:
                nperseg = 2 ** int(math.floor(math.log2(max(n // 4, 8))))
            nperseg = int(nperseg)
            if not 8 <= nperseg <= n:
                raise InputError(f"nperseg = {nperseg}: must be in [8, {n}] (the series length)")
            kw = dict(fs=fs, window=window, nperseg=nperseg, noverlap=nperseg // 2,
                      detrend=detrend, return_onesided=True)
            f, pxx = signal.welch(x, scaling="density", **kw)
            _, sxx = signal.welch(x, scaling="spectrum", **kw)
            seg = nperseg
        else:
            kw = dict(fs=fs, window=window, detrend=detrend, return_onesided=True)
            f, pxx = signal.periodogram(x, scaling="density", **kw)
            _, sxx = signal.periodogram(x, scaling="spectrum", **kw)
            seg = n
    except ValueError as e:          # an unknown window name, ...
        raise InputError(f"spectrum: {' '.join(str(e).split())}") from None
    amp = np.sqrt(2.0 * sxx)
    amp[0] = math.sqrt(sxx[0])
    if seg % 2 == 0:
        amp[-1] = math.sqrt(sxx[-1])
    df = pd.DataFrame({"freq_hz": f, "order": f / crank_frequency if crank_frequency else np.nan,
                       "power": pxx, "amplitude": amp})
    df.attrs.update(resolution_hz=fs / seg, fs=fs, method=method, window=str(window), nperseg=seg,
                    crank_frequency=crank_frequency, n_samples=n)
    return df


def peaks(spec: pd.DataFrame, n: int = 10, *, min_order: float | None = None,
          refine: bool = True) -> pd.DataFrame:
    """The ``n`` largest local maxima of a :func:`spectrum` table, largest power first.

    Returns ``freq_hz, order, power, amplitude`` (power and amplitude of the peak bin).
    The DC bin is never a peak. With ``refine`` the peak frequency is the vertex of the parabola
    through log power at the peak bin and its neighbours (an isolated Hann peak: error a few % of
    a bin). min_order: ignore peaks below this order (e.g. 0.5 to skip slow drifts).
    """
    from scipy.signal import find_peaks
    if n < 1:
        raise InputError(f"n = {n!r}: must be >= 1")
    p = spec["power"].to_numpy()
    f = spec["freq_hz"].to_numpy()
    idx, _ = find_peaks(np.concatenate([[-np.inf], p[1:]]))   # no peak at DC
    idx = idx[p[idx] > 0]
    fc = spec.attrs.get("crank_frequency")
    if min_order is not None and fc:
        idx = idx[f[idx] / fc >= min_order]
    idx = idx[np.argsort(p[idx])[::-1]][:n]
    freq = f[idx].astype(float)
    if refine and len(f) > 1:
        dfb = f[1] - f[0]
        for j, i in enumerate(idx):
            # skip a bin-centred peak (neighbours below -40 dB, e.g. a whole number of periods
            # with no window): its bin frequency is already exact
            if 0 < i < len(p) - 1 and min(p[i - 1], p[i + 1]) > 1e-4 * p[i]:
                a, b, c = np.log(p[i - 1]), np.log(p[i]), np.log(p[i + 1])
                den = a - 2 * b + c
                if den < 0:
                    freq[j] = f[i] + 0.5 * (a - c) / den * dfb
    out = pd.DataFrame({"freq_hz": freq, "order": freq / fc if fc else np.nan,
                        "power": p[idx], "amplitude": spec["amplitude"].to_numpy()[idx]})
    out.attrs.update(spec.attrs)
    return out.reset_index(drop=True)


def resample_uniform(t, x, dt: float | None = None):
    """(t_uniform, x_uniform): linear interpolation of (t, x) onto a uniform grid of step dt
    (default the median step of t); returns the input unchanged when it is already uniform to
    1e-9 of the step."""
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    if t.size < 2:
        raise InputError("the run has fewer than 2 samples")
    steps = np.diff(t)
    if np.any(steps <= 0):
        raise InputError("the time column is not strictly increasing")
    h = float(np.median(steps)) if dt is None else float(dt)
    if dt is None and np.max(np.abs(steps - h)) <= 1e-9 * h:
        return t, x
    m = int(math.floor((t[-1] - t[0]) / h * (1 + 1e-12))) + 1
    tu = t[0] + h * np.arange(m)
    return tu, np.interp(tu, t, x)


def crank_frequency_of(table: pd.DataFrame) -> float | None:
    """Mean crank speed / 2 pi (Hz) from the ``driver.speed`` column, None if absent or zero."""
    if "driver.speed" not in table.columns:
        return None
    w = table["driver.speed"].to_numpy(dtype=float)
    w = w[np.isfinite(w)]
    if not w.size or np.mean(np.abs(w)) == 0.0:
        return None
    return float(np.mean(np.abs(w)) / (2 * math.pi))


def _default_observable(table: pd.DataFrame) -> str:
    fn = [c for c in table.columns if c.endswith(".Fn")]
    if not fn:
        raise InputError("the table has no contact force column <joint>.Fn (no clearance joint): "
                         "name an observable")
    return fn[0]


def table_spectrum(table: pd.DataFrame, observable: str | None = None, *, transient: float = 0.0,
                   transient_revs: float | None = None, crank_frequency: float | None = None,
                   method: str = "welch", window="hann", nperseg: int | None = None,
                   detrend: str | bool = "constant", whole_revs: bool = True) -> pd.DataFrame:
    """Spectrum of one column of a run table (``SimulationResult.table`` or a loaded file).

    observable: a column (default the contact force ``<joint>.Fn`` of the first clearance joint,
    N). The rows with t < t0 + transient (s) are dropped (or transient_revs crank periods);
    the rest is resampled uniformly (linear interpolation at the median step, a no-op for the
    uniform grid ``simulate`` outputs by default). crank_frequency (Hz): default mean
    ``driver.speed`` / 2 pi of the kept rows. whole_revs: keep only a whole number of crank
    revolutions (when one revolution is a whole number of samples, as for ``simulate``'s
    ``samples_per_rev`` grid): ``simulate`` returns both end points, N revolutions + 1 sample;
    trimmed, the crank harmonics fall exactly on FFT bins. Other arguments as :func:`spectrum`;
    ``attrs`` add ``observable``, ``t_start``, ``t_end``.
    """
    if "t" not in table.columns:
        raise InputError("the table has no time column 't'")
    obs = observable or _default_observable(table)
    if obs not in table.columns:
        raise InputError(f"observable {obs!r}: no such column; available: {', '.join(table.columns)}")
    t = table["t"].to_numpy(dtype=float)
    fc_all = crank_frequency or crank_frequency_of(table)
    if transient_revs is not None:
        if not fc_all:
            raise InputError("transient_revs needs a crank frequency: give transient (s)")
        transient = transient_revs / fc_all
    if not (math.isfinite(transient) and transient >= 0):
        raise InputError(f"transient = {transient!r}: must be a time >= 0 (s)")
    keep = t >= t[0] + transient - 1e-12 * max(1.0, abs(t[-1]))
    kept = table.loc[keep]
    if len(kept) < 8:
        raise InputError(f"only {len(kept)} samples after the transient of {transient:g} s: "
                         "run longer or drop less")
    fc = crank_frequency or crank_frequency_of(kept)
    tu, xu = resample_uniform(kept["t"].to_numpy(dtype=float), kept[obs].to_numpy(dtype=float))
    if whole_revs and fc:
        h = float(tu[1] - tu[0])
        per_rev = 1.0 / (fc * h)                  # samples per revolution
        revs = math.floor(len(tu) / per_rev + 1e-9)
        n_keep = int(round(revs * per_rev))
        if revs >= 1 and abs(n_keep - revs * per_rev) < 1e-6 * per_rev and 8 <= n_keep <= len(tu):
            tu, xu = tu[:n_keep], xu[:n_keep]
    spec = spectrum(xu, float(tu[1] - tu[0]), method=method, window=window, nperseg=nperseg,
                    crank_frequency=fc, detrend=detrend)
    spec.attrs.update(observable=obs, t_start=float(tu[0]), t_end=float(tu[-1]))
    return spec


def scene_spectrum(scene, observable: str | None = None, *, overrides=None,
                   revs: float = SPECTRUM_SPANS.revs, transient_revs: float = SPECTRUM_SPANS.transient_revs,
                   samples_per_rev: int = SPECTRUM.samples_per_rev, rtol: float = SPECTRUM.rtol,
                   method: str = "welch", window="hann", nperseg: int | None = None):
    """Simulate ``scene`` for transient_revs + revs crank revolutions (``samples_per_rev`` output
    points per revolution: Nyquist = samples_per_rev/2 crank orders) and return
    ``(spectrum, result)`` of :func:`table_spectrum` after the transient."""
    from nld.run.simulate import simulate
    res = simulate(scene, revs=transient_revs + revs, samples_per_rev=samples_per_rev, rtol=rtol,
                   overrides=overrides)
    if not res.success:
        from nld.errors import SolveError
        raise SolveError(f"integration failed: {res.message}")
    return table_spectrum(res.table, observable, transient_revs=transient_revs, method=method,
                          window=window, nperseg=nperseg), res
