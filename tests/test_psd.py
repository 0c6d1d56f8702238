"""PSD conventions (ISO 10110-8), band figures, peaks, NaN handling."""

from __future__ import annotations

import numpy as np
import pytest

from polishpath.errors import ParameterError
from polishpath.psd import (
    PSD,
    band_average,
    band_rms,
    detrend_map,
    detrend_profiles,
    find_peaks,
    psd_1d,
    psd_2d,
    radial_psd,
    suppression_ratio,
)

DX = 0.005  # mm


def test_parseval_1d_no_window_is_exact():
    z = np.random.default_rng(0).normal(0, 3.0, size=(20, 1000))
    p = psd_1d(z, DX, window="none", detrend="piston")
    zc = z - z.mean(axis=1, keepdims=True)
    assert np.sum(p.psd) * p.df == pytest.approx(np.mean(zc**2), rel=1e-10)
    assert band_rms(p, 0, 1e9) ** 2 == pytest.approx(np.var(z, axis=1).mean(), rel=1e-10)


@pytest.mark.parametrize("window", ["hann", "tukey"])
def test_parseval_1d_window_power_corrected(window):
    z = np.random.default_rng(1).normal(0, 2.0, size=(200, 512))
    p = psd_1d(z, DX, window=window, detrend="piston")
    assert np.sum(p.psd) * p.df == pytest.approx(4.0, rel=0.05)


@pytest.mark.parametrize("window", ["none", "hann", "tukey"])
def test_sinusoid_peak_at_one_over_wavelength_with_right_power(window):
    n, lam, amp = 4000, 0.5, 3.0  # 20 mm profile, 40 whole periods
    x = np.arange(n) * DX
    p = psd_1d(amp * np.sin(2 * np.pi * x / lam + 0.3), DX, window=window, detrend="none")
    k = np.argmax(p.psd)
    assert p.freq[k] == pytest.approx(1 / lam, abs=1e-12)
    # all the power (amp^2 / 2) sits at / right around the peak
    rms_peak = band_rms(p, 1 / lam - 3 * p.df, 1 / lam + 3 * p.df)
    # Tukey's flat top leaks a little further than +-3 bins (side lobes)
    assert rms_peak == pytest.approx(amp / np.sqrt(2), rel=1e-3 if window != "tukey" else 1e-2)
    if window == "none":
        assert p.psd[k] * p.df == pytest.approx(amp**2 / 2, rel=1e-9)
    assert p.units == "nm^2 mm" and p.kind == "1d"


def test_parseval_2d_and_radial():
    rng = np.random.default_rng(2)
    z = rng.normal(0, 1.5, size=(128, 160))
    p2 = psd_2d(z, 0.01, 0.02, window="none", detrend="piston")
    var = np.var(z)
    assert p2.psd.sum() * p2.params["dfx_per_mm"] * p2.params["dfy_per_mm"] == pytest.approx(var, rel=1e-10)
    r = radial_psd(p2)
    assert r.kind == "2d-radial" and r.units == "nm^2 mm^2"
    # radial band RMS vs. direct sum over the same annulus of the 2D PSD
    lo, hi = 3 * r.df, 20 * r.df
    FX, FY = np.meshgrid(p2.fx, p2.fy)
    fr = np.hypot(FX, FY)
    m = (fr >= lo - r.df / 2) & (fr < hi + r.df / 2)
    direct = p2.psd[m].sum() * p2.params["dfx_per_mm"] * p2.params["dfy_per_mm"]
    assert band_rms(r, lo, hi) ** 2 == pytest.approx(direct, rel=0.05)


def test_2d_sinusoid_peak():
    ny, nx, dx = 64, 200, 0.01
    x = np.arange(nx) * dx
    lam = 0.25  # 8 periods over 2 mm
    z = np.tile(2.0 * np.cos(2 * np.pi * x / lam), (ny, 1))
    p2 = psd_2d(z, dx, window="none", detrend="none")
    j, i = np.unravel_index(np.argmax(p2.psd), p2.psd.shape)
    assert abs(p2.fx[i]) == pytest.approx(1 / lam) and p2.fy[j] == 0


def test_detrend_removes_plane_and_form():
    x = np.linspace(0, 5, 200)
    z = np.stack([3 + 2 * x, 1 - x + 0.5 * x**2])
    assert np.abs(detrend_profiles(z[:1], x, "tilt")).max() < 1e-9
    assert np.abs(detrend_profiles(z, x, "form")).max() < 1e-9
    assert np.abs(detrend_profiles(z[1:], x, "tilt")).max() > 0.1
    Y, X = np.mgrid[0:50, 0:60] * 0.1
    m = 1 + 0.2 * X - 0.3 * Y + 0.05 * X * Y
    assert np.abs(detrend_map(m, 0.1, 0.1, "form")).max() < 1e-9
    assert np.abs(detrend_map(m, 0.1, 0.1, "tilt")).max() > 1e-3


def test_nan_profiles_are_dropped_interpolated_or_refused():
    rng = np.random.default_rng(3)
    z = rng.normal(size=(10, 256))
    z[2, 5] = np.nan
    z[7, 100:103] = np.nan
    p = psd_1d(z, DX, nan="drop")
    assert p.params["n_profiles"] == 8 and p.params["n_profiles_dropped"] == 2
    q = psd_1d(z, DX, nan="interpolate")
    assert q.params["n_profiles"] == 10 and q.params["n_samples_interpolated"] == 4
    assert np.isfinite(q.psd).all()
    with pytest.raises(ParameterError, match="NaN"):
        psd_1d(z, DX, nan="raise")
    with pytest.raises(ParameterError):
        psd_1d(np.full((3, 64), np.nan), DX, nan="drop")


def test_nan_map_interpolated_and_counted_or_refused():
    rng = np.random.default_rng(4)
    z = rng.normal(size=(64, 64))
    z[10:12, 20:25] = np.nan
    p2 = psd_2d(z, 0.01)
    assert p2.params["n_pixels_interpolated"] == 10 and np.isfinite(p2.psd).all()
    z[:, :20] = np.nan  # 31 % missing
    with pytest.raises(ParameterError, match="NaN"):
        psd_2d(z, 0.01)
    with pytest.raises(ParameterError):
        psd_2d(z, 0.01, nan="raise")


def test_band_average_and_suppression_ratio():
    f = np.arange(1, 2001) * 0.05
    before = PSD(f, 1.0 / f**2, params={"df_per_mm": 0.05})
    after = PSD(f, 0.25 / f**2, params={"df_per_mm": 0.05})
    assert suppression_ratio(before, after) == pytest.approx(0.75)
    band = (f >= 1) & (f <= 100)
    assert band_average(before, 1, 100) == pytest.approx(np.mean(1 / f[band] ** 2))
    assert suppression_ratio(before, before, band=(2, 50)) == pytest.approx(0.0)
    with pytest.raises(ParameterError, match="band"):
        band_average(before, 200, 300)
    r = PSD(f, 1 / f**2, kind="2d-radial", units="nm^2 mm^2", params={"df_per_mm": 0.05})
    with pytest.raises(ParameterError):
        suppression_ratio(before, r)


def test_find_peaks_names_spacing_and_harmonics():
    n = 4000
    x = np.arange(n) * DX
    rng = np.random.default_rng(5)
    z = 2 * np.sin(2 * np.pi * x / 0.5) + 0.5 * np.sin(2 * np.pi * 2 * x / 0.5) + 0.05 * rng.normal(size=(30, n))
    peaks = find_peaks(psd_1d(z, DX), spacing_mm=0.5)
    labels = {d["label"] for d in peaks}
    assert {"1/spacing", "2/spacing"} <= labels
    top = peaks[0]
    assert top["freq_per_mm"] == pytest.approx(2.0) and top["harmonic"] == 1
    for seed in range(3):
        noise = np.random.default_rng(seed).normal(size=(1, n))
        assert find_peaks(psd_1d(noise, DX), spacing_mm=0.5) == []


def test_bad_inputs_raise_clear_errors():
    with pytest.raises(ParameterError, match="dx_mm"):
        psd_1d(np.zeros(100), 0.0)
    with pytest.raises(ParameterError, match="window"):
        psd_1d(np.zeros(100), 0.01, window="kaiser")
    with pytest.raises(ParameterError, match="8 samples"):
        psd_1d(np.zeros(4), 0.01)
