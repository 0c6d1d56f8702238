"""Rotating-tool TIF (feed-velocity dependent), machine time model, time-correlated process noise."""

from __future__ import annotations

import numpy as np
import pytest

from polishpath.errors import ParameterError
from polishpath.psd import band_rms, psd_1d
from polishpath.simulate import (
    ProcessNoise,
    flat_workpiece,
    path_clock,
    path_motion_samples,
    process_noise_factor,
    rotating_tool_tif,
    simulate_removal,
)

DX = 0.01


def plan_square(pattern: str, size_mm: float, spacing_mm: float, seed: int = 0):
    """A real pattern of the planner on a centred square: dwell points (N, 2) mm and piece offsets."""
    from polishpath.plan import plan
    from polishpath.types import Region

    h = size_mm / 2
    p = plan(Region(np.array([[-h, -h], [h, -h], [h, h], [-h, h]])), spacing_mm, pattern, seed=seed)
    return np.asarray(p.uv), np.asarray(p.pieces)


def test_zero_feed_tif_is_axisymmetric_and_feed_leans_it_sideways():
    tif = rotating_tool_tif(230, 1.0, "hertz", peak_rate_nm_s=10.0, feed_mm_min=0.0)
    k0 = tif.kernel_at(0.02, (0.0, 0.0))
    assert np.allclose(k0, k0[::-1, :]) and np.allclose(k0, k0[:, ::-1]) and np.allclose(k0, k0.T)
    assert k0.max() == pytest.approx(10.0, rel=0.02)  # peak rate at zero feed
    # travelling +x with CCW spin: the -y side runs against the feed and removes more
    v = 3.0  # mm/s: feed / rim speed = 0.12, where the first-order shift holds
    k = tif.kernel_at(0.02, (v, 0.0))
    h = k.shape[0] // 2
    o = (np.arange(k.shape[0]) - h) * 0.02
    assert np.allclose(k, k[:, ::-1], rtol=1e-9, atol=1e-12)  # symmetric fore/aft ...
    yc = np.sum(k * o[:, None]) / k.sum()
    omega = 230 * 2 * np.pi / 60
    assert yc == pytest.approx(-v / (2 * omega), rel=0.1)  # ... shifted by ~ v / (2 omega) across the travel
    # reversing the feed mirrors the footprint
    assert np.allclose(tif.kernel_at(0.02, (-v, 0.0)), k[::-1, :])


def test_basis_reproduces_exact_kernels_and_volume():
    tif = rotating_tool_tif(230, 1.0, "hertz", peak_rate_nm_s=10.0)
    b = tif.basis(0.02, (5.0, 15.0), tol=2e-3)
    for s, phi in ((5.0, 0.0), (9.3, 2.1), (15.0, -0.7)):
        ex = tif.kernel_at(0.02, (s * np.cos(phi), s * np.sin(phi)), oversample=3)
        c = b.coefficients(np.array([s]), np.array([phi]))[:, 0]
        ap = sum(ci * ki for ci, ki in zip(c, b.kernels))
        assert np.linalg.norm(ap - ex) / np.linalg.norm(ex) < 5e-3
        assert ap.sum() * 0.02**2 == pytest.approx(tif.volume_rate_at(s), rel=1e-3)


def test_rotating_removal_conserves_volume_and_coarse_grid_matches_fine():
    tif = rotating_tool_tif(230, 0.6, "hertz", peak_rate_nm_s=20.0)
    xy = plan_square("raster", 2.0, 0.25)[0]
    wp = flat_workpiece((-1.8, -1.8, 1.8, 1.8), 0.01)
    dwell = np.full(len(xy), 0.025)  # 10 mm/s
    fine = simulate_removal(xy, dwell, wp, tif, removal_dx_mm=0.01)
    coarse = simulate_removal(xy, dwell, wp, tif, removal_dx_mm=0.02)
    assert coarse.stats["rotating"]["removal_dx_mm"] == pytest.approx(0.02)
    for r in (fine, coarse):
        assert r.stats["removed_volume_nm_mm2"] == pytest.approx(r.stats["expected_volume_nm_mm2"], rel=2e-3)
    # 20 um is coarse for a 0.6 mm contact (the default uses 1/100 of the radius): still within 1 %
    assert np.abs(fine.removal_nm - coarse.removal_nm).max() < 1e-2 * fine.removal_nm.max()


def test_bidirectional_raster_prints_half_spacing_stripes_with_a_rotating_tool():
    spacing = 0.25
    xy = plan_square("raster", 6.0, spacing)[0]  # lines along x, alternately +x and -x
    wp = flat_workpiece((-3.2, -3.2, 3.2, 3.2), DX)
    tif = rotating_tool_tif(230, 0.5, "uniform", peak_rate_nm_s=20.0)
    n0 = int(1.2 / DX)

    def ripple(r):
        p = psd_1d(r.removal_nm[n0:-n0, n0:-n0].T, DX)  # profiles across the lines
        f = 1 / (2 * spacing)
        return p, band_rms(p, f - 3 * p.df, f + 3 * p.df)

    moving = simulate_removal(xy, np.full(len(xy), 0.025), wp, tif)  # 10 mm/s
    still = simulate_removal(xy, np.full(len(xy), 0.025), wp, tif, time_model="points")  # stop and dwell: no feed
    p_mov, r_mov = ripple(moving)
    _, r_still = ripple(still)
    m = (p_mov.freq > 0.5) & (p_mov.freq < 50)
    assert p_mov.freq[m][np.argmax(p_mov.psd[m])] == pytest.approx(1 / (2 * spacing), abs=p_mov.df)
    assert r_mov > 30 * r_still
    assert moving.stats["rotating"]["n_terms"] > 1 and still.stats["rotating"]["n_terms"] >= 1


def test_machine_time_model_runs_the_smoothed_path():
    xy = plan_square("raster", 2.0, 0.5)[0]
    dwell = np.full(len(xy), 0.05)
    s, t, head, arc, length, info = path_motion_samples(xy, dwell, 0.005, time_model="machine")
    assert info["period_ms"] > 0 and info["n_interp_samples"] > len(xy)
    # every sample lies near the dwell grid's lines or the rounded turns between them
    assert np.abs(s).max() < 1.0 + 0.2
    # time: what the interpolator takes (>= the wish where curvature slows the tool), close to it here
    assert t.sum() == pytest.approx(dwell.sum(), rel=0.25)
    assert info["machine_time_s"] == pytest.approx(t.sum())
    assert np.all(np.diff(arc[np.argsort(arc)]) >= 0) and length.sum() == pytest.approx(arc.max(), rel=0.01)
    wp = flat_workpiece((-1.5, -1.5, 1.5, 1.5), DX)
    r = simulate_removal(xy, dwell, wp, rotating_tool_tif(230, 0.5, peak_rate_nm_s=10.0), time_model="machine")
    assert r.stats["motion"]["machine_time_s"] == pytest.approx(r.stats["effective_time_s"])
    assert r.stats["removed_volume_nm_mm2"] == pytest.approx(r.stats["expected_volume_nm_mm2"], rel=5e-3)


def test_noise_correlated_in_time_not_space():
    n = ProcessNoise(0.05, correlation_time_s=1.0)
    arc = np.linspace(0, 1000, 200001)  # mm
    t = np.full(len(arc), 1e-3)  # 0.2 s total ... slow
    clock = path_clock(arc, t)
    f = process_noise_factor(arc, n, 3, clock_s=clock)
    g = f - 1
    # the clock runs 200 s over 1000 mm: 1 s of correlation is 5 mm of path
    lag_near = int(0.5 / (arc[1] - arc[0]))
    lag_far = int(30 / (arc[1] - arc[0]))
    assert np.corrcoef(g[:-lag_near], g[lag_near:])[0, 1] > 0.9
    assert abs(np.corrcoef(g[:-lag_far], g[lag_far:])[0, 1]) < 0.15
    with pytest.raises(ParameterError, match="clock"):
        process_noise_factor(arc, n, 3)
    with pytest.raises(ParameterError):
        ProcessNoise(0.05, correlation_time_s=0.0)


def test_rotating_tif_bad_inputs():
    with pytest.raises(ParameterError):
        rotating_tool_tif(0.0)
    with pytest.raises(ParameterError):
        rotating_tool_tif(230, -1.0)
    with pytest.raises(ParameterError, match="pressure"):
        rotating_tool_tif(230, 1.0, "conical")


def test_compare_patterns_default_is_the_rotating_sponge_and_removes_the_depth():
    from polishpath.simulate import compare_patterns

    out = compare_patterns(12.0, ("raster", "spiral"), 0.5, seed=0, dx_mm=0.04, noise=None)
    p = out["params"]
    assert p["tif"]["kind"] == "rotating" and p["tif"]["rpm"] == 230.0
    assert p["dwell_s_per_point"] == pytest.approx(0.5 / 10.0)  # spacing / (600 mm/min)
    assert p["tif_rate_scale"] > 0
    for r in out["rows"]:
        assert r["mean_depth_nm"] == pytest.approx(200.0, rel=0.1)
        assert r["rotating"]["mean_speed_mm_s"] == pytest.approx(10.0, rel=0.1)


def test_pruned_fft_helpers_equal_the_plain_2d_transforms():
    import scipy.fft as sfft

    from polishpath.simulate.removal import _PaddedRfft2, _upsample_crop

    rng = np.random.default_rng(0)
    a = rng.standard_normal((37, 41)).astype(np.float32)
    f = _PaddedRfft2(40, 45, 64, 72)
    assert np.allclose(f(a), sfft.rfft2(a, s=(64, 72)), atol=1e-4)
    b = rng.standard_normal((20, 25)).astype(np.float32)  # a smaller array in the same buffers: no stale data
    assert np.allclose(f(b), sfft.rfft2(b, s=(64, 72)), atol=1e-4)
    # the zero-padded inverse, cropped, against building the padded spectrum and inverting it in 2D
    sy, sx, q = 30, 36, 3
    acc = sfft.rfft2(rng.standard_normal((sy, sx))).astype(np.complex64)
    big = np.zeros((q * sy, q * sx // 2 + 1), dtype=np.complex64)
    ncol, npos, nneg = sx // 2, (sy + 1) // 2, (sy - 1) // 2
    big[:npos, :ncol] = acc[:npos, :ncol]
    big[q * sy - nneg:, :ncol] = acc[sy - nneg:, :ncol]
    ref = sfft.irfft2(big, s=(q * sy, q * sx))[5:70, 7:90]
    assert np.allclose(_upsample_crop(acc, sy, sx, q, 5, 70, 7, 90), ref, atol=1e-6)


def test_basis_is_reused_for_the_same_tool_grid_and_speeds_and_rebuilt_otherwise():
    tif = rotating_tool_tif(230, 0.6, "hertz", peak_rate_nm_s=20.0)
    sp = np.array([8.0, 10.0, 10.0, 12.0])
    a = tif.basis(0.02, (8.0, 12.0), sample_speeds=sp, sample_times=np.ones(4))
    assert tif.basis(0.02, (8.0, 12.0), sample_speeds=sp, sample_times=np.ones(4)) is a
    b = tif.basis(0.02, (8.0, 12.0), sample_speeds=sp, sample_times=np.array([1.0, 1.0, 1.0, 5.0]))
    assert b is not a
    assert tif.scaled(2.0).basis(0.02, (8.0, 12.0), sample_speeds=sp, sample_times=np.ones(4)) is not a
    c = tif.basis(0.01, (8.0, 12.0), sample_speeds=sp, sample_times=np.ones(4))
    assert c.kernels[0].shape != a.kernels[0].shape


def test_smoothing_spectrum_is_reused_only_for_the_same_read_only_map():
    from polishpath.simulate import Smoothing, smooth_surface, synthetic_workpiece

    wp = synthetic_workpiece((0, 0, 1.5, 1.5), DX, seed=1)
    assert not wp.height_nm.flags.writeable
    sm = Smoothing(100.0, 0.3)
    first = smooth_surface(wp.height_nm, DX, 50.0, sm)
    assert np.array_equal(smooth_surface(wp.height_nm, DX, 50.0, sm), first)  # from the cached spectrum
    other = synthetic_workpiece((0, 0, 1.5, 1.5), DX, seed=2)
    assert not np.allclose(smooth_surface(other.height_nm, DX, 50.0, sm), first)
    # a writeable array is never cached: changing it changes the result
    z = np.array(wp.height_nm)
    s1 = smooth_surface(z, DX, 50.0, sm)
    z *= 2.0
    assert np.allclose(smooth_surface(z, DX, 50.0, sm), 2.0 * s1, rtol=1e-4, atol=1e-4)
    # a workpiece keeps its own copy of a writeable map
    from polishpath.simulate import Workpiece

    src = np.zeros((20, 20), np.float32)
    w = Workpiece(src, DX)
    src[0, 0] = 5.0
    assert w.height_nm[0, 0] == 0.0
