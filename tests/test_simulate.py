"""Removal model: volume conservation, time density, seeds, raster peak, direction dependence."""

from __future__ import annotations

import numpy as np
import pytest

from polishpath.errors import ParameterError
from polishpath.psd import find_peaks, psd_1d
from polishpath.simulate import (
    ProcessNoise,
    Smoothing,
    compare_paths,
    dwell_from_feed,
    flat_workpiece,
    gaussian_tif,
    measured_tif,
    path_time_samples,
    profile_psd,
    rasterize_time,
    simulate_removal,
    synthetic_workpiece,
    tilted_tool_tif,
)
from polishpath.simulate.workpiece import Workpiece

DX = 0.01  # mm: small grids keep the tests fast


def plan_square(pattern: str, size_mm: float, spacing_mm: float, seed: int = 0):
    """A real pattern of the planner on a centred square: dwell points (N, 2) mm and piece offsets."""
    from polishpath.plan import plan
    from polishpath.types import Region

    h = size_mm / 2
    p = plan(Region(np.array([[-h, -h], [h, -h], [h, h], [-h, h]])), spacing_mm, pattern, seed=seed)
    return np.asarray(p.uv), np.asarray(p.pieces)


def _raster(size=4.0, spacing=0.5):
    return plan_square("raster", size, spacing)[0]


def test_path_time_samples_conserve_time_and_follow_segments():
    xy = np.array([[0, 0], [1, 0], [1, 2], [3, 2]], float)
    t = np.array([1.0, 2.0, 0.5, 4.0])
    s, w, head, arc = path_time_samples(xy, t, 0.01)
    assert w.sum() == pytest.approx(t.sum(), rel=1e-12)
    # every sample lies on the polyline: x in [0,1] at y=0, or x=1, or y=2
    on = (np.isclose(s[:, 1], 0) & (s[:, 0] <= 1)) | np.isclose(s[:, 0], 1) | np.isclose(s[:, 1], 2)
    assert on.all()
    # time of point 1 is spread over half of segment 0 and half of segment 1 (0.5 + 1.0 mm)
    near1 = ((s[:, 1] == 0) & (s[:, 0] > 0.5)) | ((np.isclose(s[:, 0], 1)) & (s[:, 1] < 1))
    assert w[near1].sum() == pytest.approx(2.0, rel=1e-9)
    assert arc.max() == pytest.approx(5.0, abs=0.01)
    # a lone point is one sample holding all its time
    s1, w1, _, _ = path_time_samples(np.array([[0.3, 0.4]]), np.array([7.0]), 0.01)
    assert len(s1) == 1 and w1[0] == 7.0


def test_rasterized_time_density_integrates_to_total_time():
    xy = _raster()
    t = np.full(len(xy), 0.3)
    s, w, _, _ = path_time_samples(xy, t, DX / 2)
    wp = flat_workpiece((-3, -3, 3, 3), DX)
    d, lost = rasterize_time(s, w, wp.shape, wp.origin_mm, DX)
    assert lost == 0.0
    assert d.sum() * DX * DX == pytest.approx(t.sum(), rel=1e-12)


def test_removal_conserves_volume():
    xy = _raster()
    dwell = np.full(len(xy), 0.5)
    tif = gaussian_tif(4.0, fwhm_mm=0.8)
    wp = flat_workpiece((-4, -4, 4, 4), DX)
    r = simulate_removal(xy, dwell, wp, tif)
    vol = r.removal_nm.astype(float).sum() * DX * DX
    # total removed = TIF volume x total time (analytic Gaussian volume 2 pi sigma^2 peak)
    sigma = 0.8 / (2 * np.sqrt(2 * np.log(2)))
    assert vol == pytest.approx(4.0 * 2 * np.pi * sigma**2 * dwell.sum(), rel=1e-4)
    assert r.stats["removed_volume_nm_mm2"] == pytest.approx(r.stats["expected_volume_nm_mm2"], rel=1e-5)
    assert (r.removal_nm > -1e-3).all()
    assert np.allclose(r.after_nm, r.before_nm - r.removal_nm, atol=1e-4)
    # uniform dwell on a grid removes depth = volume rate x dwell / spacing^2 in the middle
    c = r.removal_nm[wp.shape[0] // 2, wp.shape[1] // 2]
    assert c == pytest.approx(tif.volume_rate * 0.5 / 0.25, rel=0.01)


def test_same_seed_same_result_and_seed_matters():
    xy = _raster()
    dwell = np.full(len(xy), 0.5)
    tif = gaussian_tif(4.0, fwhm_mm=0.8)
    wp = synthetic_workpiece((-3, -3, 3, 3), DX, rms_nm=1.0, seed=3)
    noise = ProcessNoise(0.1, 1.0)
    a = simulate_removal(xy, dwell, wp, tif, noise=noise, seed=7)
    b = simulate_removal(xy, dwell, wp, tif, noise=noise, seed=7)
    c = simulate_removal(xy, dwell, wp, tif, noise=noise, seed=8)
    assert np.array_equal(a.after_nm, b.after_nm)
    assert not np.allclose(a.after_nm, c.after_nm)
    assert a.provenance.seed == 7 and a.provenance.params["noise"]["rms"] == 0.1
    assert np.array_equal(synthetic_workpiece((-1, -1, 1, 1), DX, seed=3).height_nm,
                          synthetic_workpiece((-1, -1, 1, 1), DX, seed=3).height_nm)


def test_process_noise_has_requested_rms():
    from polishpath.simulate import process_noise_factor

    arc = np.linspace(0, 5000, 200000)
    f = process_noise_factor(arc, ProcessNoise(0.05, 2.0), seed=1)
    assert f.std() == pytest.approx(0.05, rel=0.1) and f.mean() == pytest.approx(1.0, abs=0.01)
    # correlated over ~2 mm: neighbours 0.1 mm apart nearly equal, 20 mm apart independent
    g = f - 1
    step = arc[1] - arc[0]
    c_near = np.corrcoef(g[:-4], g[4:])[0, 1]
    lag = int(20 / step)
    c_far = np.corrcoef(g[:-lag], g[lag:])[0, 1]
    assert c_near > 0.9 and abs(c_far) < 0.1


def test_raster_residual_shows_peak_at_one_over_spacing():
    spacing = 0.5
    xy = plan_square("raster", 6.0, spacing)[0]  # lines along x, stepping in y
    tif = gaussian_tif(5.0, fwhm_mm=0.5)  # narrow enough to leave ripple
    wp = flat_workpiece((-3.5, -3.5, 3.5, 3.5), DX)
    r = simulate_removal(xy, np.full(len(xy), 0.2), wp, tif)
    n0 = int(1.5 / DX)
    core = r.after_nm[n0:-n0, n0:-n0]
    cols = psd_1d(core.T, DX)  # profiles across the raster lines (along y)
    peaks = find_peaks(cols, spacing_mm=spacing, band=(0.5, 100))
    assert peaks and peaks[0]["label"] == "1/spacing"
    assert peaks[0]["freq_per_mm"] == pytest.approx(1 / spacing, abs=cols.df)


def test_direction_dependent_tif_marks_every_other_raster_line():
    spacing = 0.5
    xy = plan_square("raster", 6.0, spacing)[0]
    base = gaussian_tif(5.0, fwhm_mm=0.9)  # too wide for ripple at 1/spacing
    wp = flat_workpiece((-3.5, -3.5, 3.5, 3.5), DX)
    n0 = int(1.5 / DX)
    plain = simulate_removal(xy, np.full(len(xy), 0.2), wp, base)
    tilted = simulate_removal(xy, np.full(len(xy), 0.2), wp, tilted_tool_tif(base, asymmetry=0.2))
    p_plain = psd_1d(plain.after_nm[n0:-n0, n0:-n0].T, DX)
    p_tilt = psd_1d(tilted.after_nm[n0:-n0, n0:-n0].T, DX)
    labels = [d["label"] for d in find_peaks(p_tilt, spacing_mm=spacing)]
    assert "1/(2 spacing)" in labels  # lines run alternately +x and -x
    from polishpath.psd import band_rms

    f = 1 / (2 * spacing)
    ripple_tilt = band_rms(p_tilt, f - 3 * p_tilt.df, f + 3 * p_tilt.df)
    ripple_plain = band_rms(p_plain, f - 3 * p_plain.df, f + 3 * p_plain.df)
    assert ripple_tilt > 100 * ripple_plain
    # rate 1 +- 0.2 on alternate lines: line weights alternate +-0.2 D p, whose comb has a
    # cosine of amplitude 2 * 0.2 D at 1/(2 spacing), attenuated by the Gaussian's transfer function
    sigma = 0.9 / 2.3548
    expect = 2 * 0.2 * tilted.stats["mean_depth_nm"] * np.exp(-2 * np.pi**2 * sigma**2 * f**2) / np.sqrt(2)
    assert ripple_tilt == pytest.approx(expect, rel=0.1)
    assert tilted.stats["n_direction_groups"] >= 2


def test_measured_tif_matches_gaussian():
    g = gaussian_tif(3.0, sigma_mm=0.3)
    arr = g.kernel(0.02)
    m = measured_tif(arr, 0.02)
    assert m.volume_rate == pytest.approx(g.volume_rate, rel=1e-3)
    xy = plan_square("rectangular", 2.0, 0.5)[0]
    wp = flat_workpiece((-2, -2, 2, 2), DX)
    a = simulate_removal(xy, np.ones(len(xy)), wp, g)
    b = simulate_removal(xy, np.ones(len(xy)), wp, m)
    assert np.abs(a.removal_nm - b.removal_nm).max() < 0.01 * a.removal_nm.max()


def test_synthetic_workpiece_rms_and_power_law():
    wp = synthetic_workpiece((0, 0, 5.12, 5.12), DX, rms_nm=3.0, exponent=2.5, band_per_mm=(1, 40), seed=2)
    assert np.std(wp.height_nm) == pytest.approx(3.0, rel=1e-3)
    from polishpath.psd import radial_psd

    r = radial_psd(np.asarray(wp.height_nm, float), DX, window="none", detrend="piston")
    m = (r.freq > 2) & (r.freq < 30)
    slope = np.polyfit(np.log(r.freq[m]), np.log(r.psd[m]), 1)[0]
    assert slope == pytest.approx(-2.5, abs=0.3)


def test_smoothing_reduces_short_wavelengths_more():
    wp = synthetic_workpiece((0, 0, 5, 5), DX, rms_nm=2.0, band_per_mm=(0.2, 50), seed=4)
    from polishpath.simulate import smooth_surface

    s = smooth_surface(wp.height_nm, DX, 200.0, Smoothing(100.0, 1.0))
    pb = profile_psd(np.asarray(wp.height_nm), DX)
    pa = profile_psd(s, DX)
    ratio = pa.psd / pb.psd
    assert ratio[(pb.freq > 5) & (pb.freq < 40)].max() < 0.05  # exp(-2)^2 ~ 0.02
    assert ratio[pb.freq < 0.25].min() > 0.5  # long wavelengths barely touched


def test_compare_paths_writes_outputs_and_records_parameters(tmp_path):
    size, spacing = 5.0, 0.5
    wp = synthetic_workpiece((-2.5, -2.5, 2.5, 2.5), 0.02, rms_nm=1.0, seed=1)
    t = 0.3
    sp, pieces = plan_square("spiral", size, spacing)
    ra = plan_square("raster", size, spacing)[0]
    pr = plan_square("pseudorandom", size, spacing, seed=1)[0]
    paths = {"raster": (ra, np.full(len(ra), t)),
             "spiral": (sp, np.full(len(sp), t), pieces),
             "pseudorandom": (pr, np.full(len(pr), t))}
    out = compare_paths(paths, wp, gaussian_tif(5.0, fwhm_mm=0.6), seed=5, spacing_mm=spacing,
                        eval_inset_mm=1.0, out_dir=tmp_path)
    assert [r["name"] for r in out["rows"]] == ["raster", "spiral", "pseudorandom"]
    for r in out["rows"]:
        assert r["before"] > 0 and r["after"] > 0
        assert r["suppression_ratio"] == pytest.approx(1 - r["after"] / r["before"])
    assert out["params"]["seed"] == 5 and out["params"]["tif"]["fwhm_mm"] == pytest.approx(0.6)
    for f in ("table.txt", "results.json", "psd.png", "residual_raster.png", "residual_spiral.png"):
        assert (tmp_path / f).stat().st_size > 0
    assert "raster" in (tmp_path / "table.txt").read_text()


def test_planned_grid_patterns_visit_every_grid_point_once():
    for pat in ("raster", "rectangular", "pseudorandom"):
        p = plan_square(pat, 3.0, 0.5, seed=2)[0]
        ij = np.rint((p + 1.5) / 0.5).astype(int)
        assert len({tuple(v) for v in ij}) == len(p) == 49, pat
    r = plan_square("rectangular", 3.0, 0.5)[0]
    assert np.allclose(np.abs(np.diff(r, axis=0)).sum(axis=1), 0.5)


def test_bad_inputs_raise():
    wp = flat_workpiece((0, 0, 1, 1), DX)
    with pytest.raises(ParameterError, match="dwell_s"):
        simulate_removal(np.zeros((3, 2)), np.ones(2), wp, gaussian_tif())
    with pytest.raises(ParameterError):
        simulate_removal(np.zeros((3, 2)), -np.ones(3), wp, gaussian_tif())
    with pytest.raises(ParameterError, match="NaN"):
        Workpiece(np.full((10, 10), np.nan), DX)
    with pytest.raises(ParameterError):
        gaussian_tif(fwhm_mm=-1)
    with pytest.raises(ParameterError):
        ProcessNoise(rms=2.0)
    assert dwell_from_feed(np.array([[0, 0], [1, 0]]), 60.0) == pytest.approx([0.5, 0.5])


def test_points_time_model_puts_time_at_dwell_points():
    xy = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    s, w, _, _ = path_time_samples(xy, np.array([1.0, 2.0, 3.0]), 0.01, time_model="points")
    assert np.array_equal(s, xy) and np.array_equal(w, [1.0, 2.0, 3.0])
    wp = flat_workpiece((-1, -1, 2, 2), DX)
    tif = gaussian_tif(2.0, fwhm_mm=0.5)
    a = simulate_removal(xy, np.array([1.0, 2.0, 3.0]), wp, tif, time_model="points")
    b = simulate_removal(xy, np.array([1.0, 2.0, 3.0]), wp, tif)
    assert a.stats["removed_volume_nm_mm2"] == pytest.approx(b.stats["removed_volume_nm_mm2"], rel=1e-5)  # float32 FFT
    # stop-and-dwell: the deepest spot is a dwell point (the one with the most time)
    j, i = np.unravel_index(np.argmax(a.removal_nm), a.removal_nm.shape)
    assert (i * DX - 1, j * DX - 1) == pytest.approx((1.0, 1.0), abs=DX)
    with pytest.raises(ParameterError, match="time_model"):
        path_time_samples(xy, np.ones(3), 0.01, time_model="teleport")


def test_compare_patterns_records_everything(tmp_path):
    from polishpath.simulate import compare_patterns

    out = compare_patterns(8.0, ("raster", "rectangular"), 0.5, seed=3, dx_mm=0.02, out_dir=tmp_path,
                           tif=gaussian_tif())
    p = out["params"]
    assert p["seed"] == 3 and p["spacing_mm"] == 0.5 and p["workpiece"]["seed"] == 3
    assert p["plans"]["raster"]["provenance"]["method"] == "raster"
    assert p["plans"]["rectangular"]["n_points"] == 17 * 17
    # equal dwell per point removes the requested depth
    for r in out["rows"]:
        assert r["mean_depth_nm"] == pytest.approx(200.0, rel=0.05)
    assert (tmp_path / "results.json").exists() and (tmp_path / "residual_rectangular.png").exists()


def test_compare_patterns_with_the_pseudorandom_planner():
    from polishpath.simulate import compare_patterns

    out = compare_patterns(8.0, ("pseudorandom", "raster"), 0.5, seed=1, dx_mm=0.02, tif=gaussian_tif())
    assert out["params"]["plans"]["pseudorandom"]["provenance"]["seed"] == 1
    assert {r["name"] for r in out["rows"]} == {"pseudorandom", "raster"}
    assert all(np.isfinite(r["suppression_ratio"]) for r in out["rows"])


def test_compare_patterns_feed_dwell_keeps_total_time():
    from polishpath.simulate import compare_patterns

    eq = compare_patterns(8.0, ("spiral",), 0.5, seed=0, dx_mm=0.04, noise=None, tif=gaussian_tif())
    fd = compare_patterns(8.0, ("spiral",), 0.5, seed=0, dx_mm=0.04, noise=None, dwell="feed",
                          tif=gaussian_tif())
    assert fd["rows"][0]["total_time_s"] == pytest.approx(eq["rows"][0]["total_time_s"], rel=1e-9)
    assert fd["params"]["dwell"] == "feed"
    with pytest.raises(ParameterError, match="dwell"):
        compare_patterns(8.0, ("spiral",), 0.5, dx_mm=0.04, dwell="sometimes")


def test_workpiece_from_measurement(tmp_path):
    from polishpath.psd import read_measurement
    from polishpath.simulate import workpiece_from_measurement

    z = np.random.default_rng(0).normal(size=(40, 50))
    f = tmp_path / "g.txt"
    f.write_text("# dx: 20 um\n" + "\n".join(" ".join(f"{v:.8g}" for v in r) for r in z))
    wp = workpiece_from_measurement(read_measurement(f), origin_mm=(1.0, 2.0))
    assert wp.dx_mm == pytest.approx(0.02) and wp.shape == (40, 50)
    assert wp.bounds == pytest.approx((1.0, 2.0, 1.0 + 49 * 0.02, 2.0 + 39 * 0.02))
    assert np.allclose(wp.height_nm, z, atol=1e-5)
    z[3, 3] = np.nan
    f.write_text("# dx: 20 um\n" + "\n".join(" ".join(f"{v:.8g}" for v in r) for r in z))
    with pytest.raises(ParameterError, match="NaN"):
        workpiece_from_measurement(read_measurement(f))
