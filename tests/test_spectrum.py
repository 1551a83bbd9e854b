"""Spectra (nld.analysis.spectrum): known frequencies, Parseval, orders of the crank frequency, run tables."""
import math

import numpy as np
import pandas as pd
import pytest

from nld.errors import InputError
from nld.analysis.spectrum import peaks, resample_uniform, spectrum, table_spectrum

FS = 2000.0          # Hz
FC = 12.5            # Hz, "crank" frequency
# (frequency Hz, amplitude): orders 2, 3, 8 of FC
TONES = [(25.0, 3.0), (37.5, 1.0), (100.0, 0.5)]


def _signal(n, tones=TONES, dc=0.0, noise=0.0, seed=0):
    t = np.arange(n) / FS
    x = dc + sum(a * np.sin(2 * np.pi * f * t + 0.3 * k) for k, (f, a) in enumerate(tones))
    if noise:
        x = x + noise * np.random.default_rng(seed).normal(size=n)
    return t, x


@pytest.mark.parametrize("method", ["welch", "fft"])
def test_known_frequencies_give_peaks_at_the_right_hz_and_orders(method):
    """Resolution: fft df = FS/N = 0.25 Hz; welch (nperseg 1024 of N = 8000) df = 1.95 Hz.
    The refined peaks are within a tenth of a bin of the true frequencies."""
    n = 8000
    _, x = _signal(n, noise=0.05)
    spec = spectrum(x, 1 / FS, method=method, crank_frequency=FC)
    df_expected = FS / n if method == "fft" else FS / 1024
    assert spec.attrs["resolution_hz"] == pytest.approx(df_expected)
    assert list(spec.columns) == ["freq_hz", "order", "power", "amplitude"]
    assert np.allclose(spec.order, spec.freq_hz / FC)
    pk = peaks(spec, 3)
    assert len(pk) == 3
    order = np.argsort(pk.freq_hz.to_numpy())
    got = pk.freq_hz.to_numpy()[order]
    assert np.allclose(got, [f for f, _ in TONES], atol=0.1 * df_expected)
    assert np.allclose(pk.order.to_numpy()[order], [2, 3, 8], atol=0.1 * df_expected / FC)
    # the largest power first, i.e. the largest amplitude
    assert pk.freq_hz.iloc[0] == pytest.approx(25.0, abs=0.1 * df_expected)
    if method == "fft":
        # bin-centred tones: the amplitude column reads the sine amplitudes (Hann: exact at centres)
        amps = pk.amplitude.to_numpy()[order]
        assert np.allclose(amps, [a for _, a in TONES], rtol=0.02)


def test_off_bin_frequency_is_refined_between_bins():
    n = 4096
    f0 = 123.37             # between bins of df = FS/n = 0.488 Hz
    t = np.arange(n) / FS
    x = np.sin(2 * np.pi * f0 * t)
    spec = spectrum(x, 1 / FS, method="fft")
    df = spec.attrs["resolution_hz"]
    pk = peaks(spec, 1)
    assert abs(pk.freq_hz.iloc[0] - f0) < 0.05 * df
    raw = peaks(spec, 1, refine=False)
    assert abs(raw.freq_hz.iloc[0] - f0) <= 0.5 * df
    assert np.isnan(pk.order.iloc[0])        # no crank frequency given


def test_parseval_for_the_fft_method():
    """sum(power) * df = mean square: exact with no window; with Hann the window-weighted mean
    square sum((w x)^2) / sum(w^2); with detrend='constant' the variance."""
    n = 3001
    _, x = _signal(n, dc=1.7, noise=0.3)
    spec = spectrum(x, 1 / FS, method="fft", window="boxcar", detrend=False)
    df = spec.attrs["resolution_hz"]
    assert spec.power.sum() * df == pytest.approx(np.mean(x * x), rel=1e-12)
    spec = spectrum(x, 1 / FS, method="fft", window="boxcar")
    assert spec.power.sum() * df == pytest.approx(np.var(x), rel=1e-12)
    from scipy.signal import get_window
    w = get_window("hann", n)
    spec = spectrum(x, 1 / FS, method="fft", window="hann", detrend=False)
    assert spec.power.sum() * df == pytest.approx(np.sum((w * x) ** 2) / np.sum(w * w), rel=1e-12)
    # Welch: the averaged density integrates to the mean square of a stationary signal (~1 %)
    spec = spectrum(x, 1 / FS, method="welch", detrend=False)
    assert spec.power.sum() * spec.attrs["resolution_hz"] == pytest.approx(np.mean(x * x), rel=0.03)


def test_table_spectrum_drops_the_transient_and_resamples():
    n = 4000
    t, x = _signal(n)
    x = x + np.where(t < 0.5, 50.0, 0.0)        # a "transient" in the first 0.5 s
    table = pd.DataFrame({"t": t, "J.Fn": x, "driver.speed": np.full(n, 2 * np.pi * FC)})
    spec = table_spectrum(table, transient=0.5, method="fft", window="boxcar", whole_revs=False)
    assert spec.attrs["observable"] == "J.Fn"            # the default: the first .Fn column
    assert spec.attrs["crank_frequency"] == pytest.approx(FC)
    assert spec.attrs["t_start"] >= 0.5
    assert spec.attrs["n_samples"] == n - 1000
    # without the transient the spectrum is the pure tones: power sums to their variance
    df = spec.attrs["resolution_hz"]
    assert spec.power.sum() * df == pytest.approx(np.var(x[t >= 0.5]), rel=1e-12)
    # whole_revs (default): 3000 samples = 18.75 revolutions of 160 samples -> 18 revolutions,
    # and the tones (orders 2, 3, 8) are exactly on bins: no leakage, amplitudes exact
    spec = table_spectrum(table, transient=0.5, method="fft", window="boxcar")
    assert spec.attrs["n_samples"] == 18 * 160
    pk = peaks(spec, 3)
    assert np.allclose(pk.order, [2, 3, 8], atol=1e-12)
    assert np.allclose(pk.amplitude, [a for _, a in TONES], rtol=1e-9)
    # transient_revs = revolutions of the crank
    spec2 = table_spectrum(table, transient_revs=0.5 * FC, method="fft", window="boxcar")
    assert np.allclose(spec2.power, spec.power)
    # a non-uniform time column is resampled at its median step
    keep = np.sort(np.random.default_rng(2).choice(n, size=3000, replace=False))
    tu, xu = resample_uniform(t[keep], x[keep])
    assert np.allclose(np.diff(tu), np.median(np.diff(t[keep])))
    assert resample_uniform(t, x)[0] is t
    with pytest.raises(InputError, match="no such column"):
        table_spectrum(table, "B.Fn")
    with pytest.raises(InputError, match="samples after the transient"):
        table_spectrum(table, transient=10.0)


def test_slider_crank_slider_position_has_crank_harmonics():
    """The slider position of the slider-crank: fundamental at order 1, second harmonic next
    (crank r = 50 mm, rod l = 120 mm: the 2nd harmonic is about r/(4 l) of the fundamental)."""
    from nld.run.simulate import simulate
    res = simulate("slider_crank", revs=12, samples_per_rev=256)
    spec = table_spectrum(res.table, "slider.x", transient_revs=2, method="fft", window="boxcar")
    fc = spec.attrs["crank_frequency"]
    assert fc == pytest.approx(5000 / 60)
    pk = peaks(spec, 2)
    assert np.allclose(pk.order, [1, 2], atol=0.01)
    ratio = pk.amplitude.iloc[1] / pk.amplitude.iloc[0]
    r, L = 0.05, 0.12
    assert ratio == pytest.approx(r / (4 * L), rel=0.1)
    # the default observable of a run: the contact force of the clearance joint
    assert table_spectrum(res.table, transient_revs=2).attrs["observable"] == "B.Fn"


def test_input_errors():
    x = np.zeros(100)
    with pytest.raises(InputError, match="method"):
        spectrum(x, 1e-3, method="psd")
    with pytest.raises(InputError, match="dt"):
        spectrum(x, 0.0)
    with pytest.raises(InputError, match="nperseg"):
        spectrum(x, 1e-3, nperseg=1000)
    with pytest.raises(InputError, match="NaN"):
        spectrum(np.full(100, np.nan), 1e-3)
    with pytest.raises(InputError, match="window"):
        spectrum(x, 1e-3, window="nosuchwindow")


def test_spectrum_plot_marks_harmonics():
    from nld.output.plots import spectrum_plot
    _, x = _signal(8000)
    spec = spectrum(x, 1 / FS, crank_frequency=FC)
    spec.attrs["observable"] = "B.Fn"
    fig = spectrum_plot(spec, peaks=peaks(spec, 3), max_order=10)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "frequency (Hz)"
    assert ax.get_ylabel() == "power spectral density (N²/Hz)"
    assert ax.get_xlim()[1] == pytest.approx(10 * FC)
    vlines = [ln for ln in ax.get_lines() if ln.get_linestyle() == ":"]
    assert len(vlines) == 10
    assert math.isclose(vlines[2].get_xdata()[0], 3 * FC)


def test_cli_spectrum_of_a_saved_run(monkeypatch, capsys, tmp_path):
    from test_poincare import _patched_cli
    from nld.output.io import load_table, save_table
    from nld.run.simulate import simulate
    cli = _patched_cli(monkeypatch)
    res = simulate("slider_crank", revs=6, samples_per_rev=128)
    run = save_table(res.table, tmp_path / "run.parquet", res.provenance)
    out = tmp_path / "spec.csv"
    rc = cli.main(["spectrum", "--table", str(run), "--observable", "slider.x", "--method", "fft",
                   "--transient-revs", "1", "--peaks", "2", "--out", str(out)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "spectrum of slider.x" in text and "crank frequency 83.3333 Hz" in text
    spec, prov = load_table(out)
    assert list(spec.columns) == ["freq_hz", "order", "power", "amplitude"]
    assert prov["kind"] == "spectrum" and prov["observable"] == "slider.x"
    assert cli.main(["spectrum"]) == 2
    assert "SCENE or --table" in capsys.readouterr().err
