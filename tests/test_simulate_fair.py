"""Fair figures of a residual (issue 18): band RMS, lattice peaks, PVn, detrending, ripple amplitude."""

from __future__ import annotations

import numpy as np
import pytest

from polishpath.errors import ParameterError
from polishpath.simulate import (
    FairMetrics,
    band_rms_nm,
    detrend_residual,
    fair_metrics,
    lattice_frequencies,
    lattice_peak_db,
    pvn,
    ripple_amplitude,
)
from polishpath.simulate import fair

DX = 0.01  # mm
N = 400    # 4 x 4 mm maps


def _grid(n=N, dx=DX):
    y, x = np.mgrid[0:n, 0:n] * dx
    return x, y


@pytest.mark.parametrize("direction", ["x", "y", "diagonal"])
def test_sinusoid_band_rms_is_amplitude_over_sqrt2(direction):
    x, y = _grid()
    a, lam = 3.0, 0.25
    u = {"x": x, "y": y, "diagonal": (x + y) / np.sqrt(2)}[direction]
    z = a * np.sin(2 * np.pi * u / lam + 0.3)
    assert band_rms_nm(z, DX) == pytest.approx(a / np.sqrt(2), rel=2e-3)
    # the same ripple outside the band counts nothing
    assert band_rms_nm(z, DX, band=(8.0, 100.0)) < 0.01 * a


def test_band_rms_over_all_frequencies_is_the_windowed_rms_parseval():
    rng = np.random.default_rng(3)
    z = rng.standard_normal((128, 160))
    ok = np.ones(z.shape, bool)
    w = fair._window(ok, DX, fair.taper_width_mm((1.0, 100.0)))
    zc = z - np.sum(z * w * w) / np.sum(w * w)
    direct = np.sqrt(np.sum((zc * w) ** 2) / np.sum(w * w))
    assert band_rms_nm(z, DX, band=(0.0, 1e6)) == pytest.approx(direct, rel=1e-10)
    # white noise: the band's share of the power is its share of the (2D) frequency plane
    full = band_rms_nm(z, DX, band=(0.0, 1e6))
    assert band_rms_nm(z, DX, band=(0.0, 25.0)) < full


def test_lattice_frequencies():
    assert np.allclose(lattice_frequencies(0.5), [1.0, 2.0, 4.0, 6.0])
    assert np.allclose(lattice_frequencies(0.25, n_harmonics=1), [2.0, 4.0])
    with pytest.raises(ParameterError):
        lattice_frequencies(0.0)
    with pytest.raises(ParameterError):
        lattice_frequencies(0.5, n_harmonics=0)


def test_peak_of_a_sinusoid_in_noise_has_the_expected_db():
    x, _ = _grid()
    rng = np.random.default_rng(1)
    sigma, a, lam = 1.0, 0.3, 0.25  # 1/lam = 4 1/mm, a whole number of bins of the 4 mm rows
    z = a * np.sin(2 * np.pi * x / lam) + sigma * rng.standard_normal((N, N))
    # rows see the sinusoid: peak / background = 1 + a^2 / (4 sigma^2) * sum_r (sum w_r)^2 / sum w^2
    w = fair._window(np.ones((N, N), bool), DX, fair.taper_width_mm())
    expected = 10 * np.log10(1 + a**2 / (4 * sigma**2) * np.sum(w.sum(axis=1) ** 2) / np.sum(w * w))
    assert expected > 6
    assert lattice_peak_db(z, DX, lam) == pytest.approx(expected, abs=0.5)


def test_white_noise_and_off_lattice_ripple_read_about_zero_db():
    rng = np.random.default_rng(2)
    z = rng.standard_normal((N, N))
    for s in (0.25, 0.3, 0.5):
        assert abs(lattice_peak_db(z, DX, s)) < 1.0
    # a strong ripple at a frequency that is not the path's does not count
    x, _ = _grid()
    off = z + 2 * np.sin(2 * np.pi * x * 6.0)  # 6 1/mm, between the lattice's 4 and 8 1/mm (8 bins from each)
    assert abs(lattice_peak_db(off, DX, 0.25)) < 1.0
    assert lattice_peak_db(off, DX, 1 / 6.0) > 15


def test_lattice_peak_needs_a_frequency_in_the_band():
    z = np.random.default_rng(0).standard_normal((64, 64))
    with pytest.raises(ParameterError, match="lattice frequency"):
        lattice_peak_db(z, DX, 0.5, band=(50.0, 60.0))


def test_detrend_removes_mean_tilt_and_power_exactly():
    x, y = _grid(200)
    rng = np.random.default_rng(4)
    rough = rng.standard_normal(x.shape)
    form = 40.0 + 3.0 * x - 7.0 * y + 11.0 * ((x - 0.3) ** 2 + (y - 1.1) ** 2)
    assert np.abs(detrend_residual(form, DX)).max() < 1e-9
    assert np.allclose(detrend_residual(form + rough, DX), detrend_residual(rough, DX), atol=1e-9)
    r = detrend_residual(rough, DX)
    # the residual is orthogonal to the four terms
    for t in (np.ones_like(x), x, y, x * x + y * y):
        assert abs(np.sum(r * t)) < 1e-8 * np.sqrt(np.sum(t * t) * np.sum(r * r))


def test_detrend_with_a_mask_and_nans():
    x, y = _grid(200)
    form = 1.0 + 2.0 * x + 0.5 * (x * x + y * y)
    mask = np.hypot(x - 1.0, y - 1.0) < 0.8
    z = np.where(mask, form, 1e6)  # whatever lies outside the mask does not matter
    z[100, 100] = np.nan
    r = detrend_residual(z, DX, mask)
    assert np.isnan(r[~mask]).all() and np.isnan(r[100, 100])
    assert np.nanmax(np.abs(r)) < 1e-9
    with pytest.raises(ParameterError, match="boolean"):
        detrend_residual(z, DX, mask.astype(int))
    with pytest.raises(ParameterError, match="no valid pixel"):
        detrend_residual(z, DX, np.zeros_like(mask))
    with pytest.raises(ParameterError, match="do not determine"):
        line = np.zeros_like(mask)
        line[50, :] = True
        detrend_residual(z, DX, line)


def test_masked_band_rms_ignores_the_outside_and_nans_equal_a_mask():
    x, y = _grid()
    a, lam = 2.0, 0.2
    z = a * np.cos(2 * np.pi * y / lam)
    mask = np.hypot(x - 2.0, y - 2.0) < 1.9
    outside = np.where(mask, z, 1e5)
    assert band_rms_nm(outside, DX, mask=mask) == pytest.approx(a / np.sqrt(2), rel=5e-3)
    assert band_rms_nm(np.where(mask, z, np.nan), DX) == band_rms_nm(outside, DX, mask=mask)
    assert lattice_peak_db(np.where(mask, z, np.nan), DX, lam) == lattice_peak_db(outside, DX, lam, mask=mask)


def test_pvn():
    z = np.zeros((20, 20))
    z[3, 4], z[10, 11] = 2.0, -3.0
    assert pvn(z, 50.0) == pytest.approx(0.1)
    mask = np.ones_like(z, bool)
    mask[10, 11] = False
    assert pvn(z, 50.0, mask) == pytest.approx(0.04)
    with pytest.raises(ParameterError, match="depth"):
        pvn(z, 0.0)


def test_ripple_amplitude_is_the_first_harmonic():
    x, y = _grid(300)
    lam = 0.5  # 50 pixels per period
    z = 1.5 * np.cos(2 * np.pi * y / lam - 1.0) + 0.4 * np.cos(4 * np.pi * y / lam) + 7.0 + 0.2 * x
    assert ripple_amplitude(z, DX, lam, axis=0) == pytest.approx(1.5, rel=1e-12)
    assert ripple_amplitude(z, DX, lam / 2, axis=0) == pytest.approx(0.4, rel=1e-12)
    assert ripple_amplitude(z.T, DX, lam, axis=1) == pytest.approx(1.5, rel=1e-12)
    with pytest.raises(ParameterError):
        ripple_amplitude(z, DX, 100.0)


def test_fair_metrics_detrends_itself_and_records_parameters():
    x, y = _grid()
    rng = np.random.default_rng(5)
    ripple = 2.0 * np.sin(2 * np.pi * y / 0.25) + 0.1 * rng.standard_normal(x.shape)
    start_minus_removal = ripple + 100.0 + 5 * x - 3 * y + 2 * (x * x + y * y)
    m = fair_metrics(start_minus_removal, DX, 0.25, 80.0)
    assert isinstance(m, FairMetrics)
    r = fair_metrics(ripple, DX, 0.25, 80.0)
    for name in ("residual_band_rms_nm", "lattice_peak_db", "pvn", "residual_rms_nm", "residual_pv_nm"):
        assert getattr(m, name) == pytest.approx(getattr(r, name), rel=1e-6), name
    assert m.residual_band_rms_nm == pytest.approx(np.sqrt(2.0 + 0.01), rel=0.02)
    assert m.lattice_peak_db > 20
    assert m.pvn == pytest.approx(m.residual_pv_nm / 80.0)
    assert m.params["spacing_mm"] == 0.25 and m.params["band_per_mm"] == [1.0, 100.0]
    assert "version" in m.params and m.to_dict()["pvn"] == m.pvn
    mask = np.zeros(x.shape, bool)
    mask[50:350, 50:350] = True
    mm = fair_metrics(start_minus_removal, DX, 0.25, 80.0, mask=mask)
    assert mm.params["n_valid_pixels"] == 300 * 300
    assert mm.residual_band_rms_nm == pytest.approx(m.residual_band_rms_nm, rel=0.02)


# --- the simulation against closed form (issue 18) ----------------------------------------------


def _straight_raster(spacing, n_passes, x0, x1, step):
    """Passes along x at y = k * spacing, one piece each, points every ``step`` mm, uniform time."""
    xs = np.arange(x0, x1 + 1e-9, step)
    pts = np.concatenate([np.c_[xs, np.full(len(xs), k * spacing)] for k in range(n_passes)])
    pieces = np.arange(n_passes + 1) * len(xs)
    return pts, np.full(len(pts), 0.01), pieces


@pytest.mark.parametrize("time_model", ["segments", "points"])
@pytest.mark.parametrize("sigma_over_s", [0.2, 0.25, 0.3])
def test_raster_ripple_first_harmonic_matches_closed_form(sigma_over_s, time_model):
    """Straight passes at spacing s, Gaussian TIF of width sigma: the ripple's first harmonic is
    2 exp(-2 pi^2 sigma^2 / s^2) times the mean depth (Poisson summation of the passes' Gaussians)."""
    from polishpath.simulate import flat_workpiece, gaussian_tif, simulate_removal

    s, dx = 0.5, 0.01
    sigma = sigma_over_s * s
    n_passes = 12
    path, dwell, pieces = _straight_raster(s, n_passes, 0.0, 4.0, 0.02)
    # the grid is offset by a third of a pixel, so the passes fall between pixel rows (bilinear splat)
    wp = flat_workpiece((-1.0 + dx / 3, -1.0 + dx / 3, 5.0, n_passes * s + 0.5), dx)
    res = simulate_removal(path, dwell, wp, gaussian_tif(10.0, sigma_mm=sigma), pieces=pieces,
                           time_model=time_model)
    # evaluate away from the ends of the passes (x in [1, 3] mm) and from the first and last passes:
    # y over whole periods [3 s, 9 s)
    x = wp.origin_mm[0] + np.arange(wp.shape[1]) * dx
    y = wp.origin_mm[1] + np.arange(wp.shape[0]) * dx
    j0 = int(np.argmin(np.abs(y - 3 * s)))
    rows = slice(j0, j0 + int(round(6 * s / dx)))
    cols = (x > 1.0) & (x < 3.0)
    removal = res.removal_nm.astype(np.float64)[rows][:, cols]
    depth = removal.mean()
    amp = ripple_amplitude(removal, dx, s, axis=0)
    expected = 2 * np.exp(-2 * np.pi**2 * sigma_over_s**2)
    assert amp / depth == pytest.approx(expected, rel=0.02)
    # the whole deviation (-0.18 %) is the bilinear splat of passes lying 2/3 of a pixel past a row: its
    # transfer at 1/s is |1/3 + 2/3 exp(-2 pi i dx / s)|
    splat = abs(1 / 3 + 2 / 3 * np.exp(-2j * np.pi * dx / s))
    assert amp / depth == pytest.approx(expected * splat, rel=1e-4)
    # and the same pass-to-pass uniformity along the passes (no ripple along x)
    assert ripple_amplitude(removal, dx, 0.5, axis=1) < 1e-3 * depth


def test_stop_and_dwell_removal_does_not_depend_on_the_visiting_order():
    """time_model="points" with a direction-independent TIF: every order of the same dwell points removes the
    same (to round-off)."""
    from polishpath.plan import plan
    from polishpath.simulate import flat_workpiece, gaussian_tif, simulate_removal
    from polishpath.types import Region

    h = 1.5
    p = plan(Region(np.array([[-h, -h], [h, -h], [h, h], [-h, h]])), 0.25, "pseudorandom", seed=3)
    pts = np.asarray(p.uv, dtype=np.float64)
    rng = np.random.default_rng(11)
    dwell = rng.uniform(0.5, 1.5, len(pts))
    wp = flat_workpiece((-2.5, -2.5, 2.5, 2.5), 0.02)
    tif = gaussian_tif(20.0, sigma_mm=0.2)
    ref = simulate_removal(pts, dwell, wp, tif, time_model="points").removal_nm.astype(np.float64)
    assert ref.max() > 10.0
    for _ in range(3):
        order = rng.permutation(len(pts))
        other = simulate_removal(pts[order], dwell[order], wp, tif, time_model="points").removal_nm
        assert np.abs(other - ref).max() <= 1e-5 * ref.max()
