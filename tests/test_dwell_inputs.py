"""Deterministic figuring (issue 17): the inputs and cases test_dwell.py does not cover.

A curved part end to end, a Zygo .datx map end to end, a measured TIF map file, the [error_map] alignment of a
job.toml against the same alignment through the API, the solver's convergence report, and the two-iteration
example (small).
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from polishpath.dwell import (
    Alignment,
    ErrorMap,
    figure_dwell_times,
    gaussian_tif,
    read_error_map,
    sample_error,
    tif_from_spec,
    zernike_surface,
)


@pytest.fixture(scope="module")
def small_part():
    from polishpath.pipeline import run

    job = run(surface="xy-polynomial:radius=8,triangles=1500", spacing=0.5, seed=3, report=False)
    return job.surface, job.surface_path


def _quiet(fn, *a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return fn(*a, **kw)


def test_curved_part_end_to_end(tmp_path):
    """A sphere cap (R 25 mm, 10 mm aperture radius, 2.2 mm sag): the map over projected x, y, read at each x, y."""
    from polishpath.pipeline import run

    (tmp_path / "err.toml").write_text("[zernike]\nordering = \"fringe\"\nradius_mm = 11.0\nunits = \"nm\"\n"
                                       "coefficients = [0, 0, 0, 40.0, 15.0, -10.0]\npixel_mm = 0.05\n")
    job = _quiet(run, surface="sphere:R=25,radius=10,triangles=2500", spacing=0.6, seed=2,
                 error_map=str(tmp_path / "err.toml"), tif="gaussian:fwhm=3,peak_rate=15", report=False,
                 error_map_options={"ca_margin_mm": 1.5})
    fig, pr = job.figuring, job.figuring_prediction
    xyz = job.surface_path.xyz
    assert np.ptp(xyz[:, 2]) > 1.5  # a curved part
    assert fig.solution.solver == "lsq"  # the dwell points are no lattice in x, y
    # the map is over projected x, y: the target's error at each pixel is the map read at that pixel's x, y
    emap = read_error_map(tmp_path / "err.toml")
    t = fig.target
    xy = t.grid.xy()
    np.testing.assert_allclose(t.error_nm.ravel(), sample_error(emap, xy), equal_nan=True, atol=1e-9)
    # each dwell point reads it at its x, y: the map's value there vs the target grid's, within a pixel's slope
    from scipy.interpolate import RegularGridInterpolator

    g = t.grid
    ax = (g.origin_mm[1] + np.arange(g.shape[0]) * g.pitch_mm, g.origin_mm[0] + np.arange(g.shape[1]) * g.pitch_mm)
    at_points = RegularGridInterpolator(ax, t.error_nm)(xyz[:, [1, 0]])
    direct = sample_error(emap, xyz[:, :2])
    ok = np.isfinite(at_points) & np.isfinite(direct)
    assert ok.mean() > 0.9
    np.testing.assert_allclose(at_points[ok], direct[ok], atol=0.05)
    # the predicted (machine-timed) residual on the part
    assert pr["residual_rms_nm"] <= 0.1 * fig.stats["initial_rms_nm"], (pr["residual_rms_nm"], fig.stats)
    assert np.all(fig.times_s >= fig.solution.t_min_s)


def test_datx_error_map_end_to_end(tmp_path, small_part):
    pytest.importorskip("h5py", reason="Zygo .datx needs h5py (the [zygo] extra)")
    from polishpath.psd.io import write_datx_like

    z = zernike_surface([0, 0, 0, 60.0, 20.0, 0, 15.0], 9.0, "fringe", 0.05)  # Z7 (coma) is not symmetric in y
    z[200, 150:160] = np.nan  # drop-outs: the No Data sentinel
    f = write_datx_like(tmp_path / "err.datx", z[::-1], 0.05, unit="MicroMeters")  # stored in um, top row first
    m = read_error_map(f)
    np.testing.assert_allclose(m.z_nm, z, rtol=1e-9, atol=1e-9, equal_nan=True)
    assert m.dx_mm == pytest.approx(0.05) and m.params["format"] == "datx"
    surface, spath = small_part
    tif = gaussian_tif(15.0, fwhm_mm=3.0)
    a = _quiet(figure_dwell_times, surface, spath, m, tif, max_feed_mm_min=3000.0, ca_margin_mm=1.0)
    b = _quiet(figure_dwell_times, surface, spath, ErrorMap.centred(z, 0.05), tif, max_feed_mm_min=3000.0,
               ca_margin_mm=1.0)
    # the times of an ill-conditioned deconvolution move with the last bit of the map (um -> nm): the removal does not
    np.testing.assert_allclose(a.target.removal_nm, b.target.removal_nm, rtol=1e-9, atol=1e-9, equal_nan=True)
    v, init = a.target.valid, a.stats["initial_rms_nm"]
    assert np.sqrt(np.mean((a.ideal_removal_nm - b.ideal_removal_nm)[v] ** 2)) <= 0.005 * init
    assert a.stats["ideal_residual_rms_nm"] == pytest.approx(b.stats["ideal_residual_rms_nm"], abs=0.005 * init)
    assert a.times_s.sum() == pytest.approx(b.times_s.sum(), rel=0.01)
    assert a.stats["error_map"].endswith("err.datx")
    assert a.stats["ideal_residual_rms_nm"] <= 0.05 * a.stats["initial_rms_nm"]


def test_measured_tif_map_file(tmp_path, small_part):
    """A removal spot measured as a grid text file (depth nm, pixel 0.1 mm, 4 s dwell) is the Gaussian it samples."""
    sigma, peak = 3.0 / 2.3548200450309493, 15.0
    o = np.arange(-40, 41) * 0.1
    X, Y = np.meshgrid(o, o)
    depth = 4.0 * peak * np.exp(-(X**2 + Y**2) / (2 * sigma**2))  # nm after a 4 s spot
    f = tmp_path / "spot.txt"
    f.write_text("# height_unit: nm\n# lateral_unit: mm\n# dx: 0.1 mm\n"
                 + "\n".join(" ".join(f"{v:.9g}" for v in row) for row in depth) + "\n")
    tif = tif_from_spec(f"measured:file={f},dwell_s=4")
    ref = gaussian_tif(peak, sigma_mm=sigma)
    assert tif.kind == "measured" and tif.params["dx_mm"] == pytest.approx(0.1)
    assert tif.params["peak_rate_nm_s"] == pytest.approx(peak, rel=1e-6)
    assert tif.volume_rate == pytest.approx(ref.volume_rate, rel=0.01)
    # a wrong pixel size in the spec overrides the file: twice the pixel, four times the volume
    assert tif_from_spec(f"measured:file={f},dwell_s=4,dx=0.2").volume_rate == pytest.approx(4 * tif.volume_rate,
                                                                                             rel=0.02)
    surface, spath = small_part
    z = zernike_surface([0, 0, 0, 60.0, 20.0], 9.0, "fringe", 0.05)
    kw = dict(max_feed_mm_min=3000.0, ca_margin_mm=1.0)
    a = _quiet(figure_dwell_times, surface, spath, ErrorMap.centred(z, 0.05), tif, **kw)
    b = _quiet(figure_dwell_times, surface, spath, ErrorMap.centred(z, 0.05), ref, **kw)
    assert a.stats["ideal_residual_rms_nm"] <= 0.05 * a.stats["initial_rms_nm"]
    assert a.times_s.sum() == pytest.approx(b.times_s.sum(), rel=0.03)


def test_alignment_from_job_toml_matches_the_api(tmp_path, small_part):
    from polishpath.config import JobConfig
    from polishpath.pipeline import figure_for_job

    pix = 0.05
    z = zernike_surface([0, 0, 0, 30.0, 10.0, -8.0, 12.0, -9.0], 14.0, "fringe", pix) + 0.0
    h = (z.shape[0] - 1) // 2
    X, _ = np.meshgrid(np.arange(-h, h + 1) * pix, np.arange(-h, h + 1) * pix)
    z = z + 2.0 * X  # a tilt: the flip and the rotation change the map on the part
    f = tmp_path / "map.txt"
    f.write_text("# height_unit: nm\n# lateral_unit: mm\n# dx: 0.05 mm\n"
                 + "\n".join(" ".join("nan" if not np.isfinite(v) else f"{v:.10g}" for v in row) for row in z) + "\n")
    (tmp_path / "job.toml").write_text(
        "[job]\nsurface = \"xy-polynomial:radius=8,triangles=1500\"\nspacing = 0.5\nseed = 3\nerror_map = \"map.txt\"\nforce = true\n"  # a 16 nm PV map under a 23 nm floor
        "tif = \"gaussian:fwhm=3,peak_rate=15\"\n[error_map]\noffset_mm = [1.5, -0.75]\nrotation_deg = 25.0\n"
        "flip = \"y\"\nscale = 1.1\nca_margin_mm = 1.0\nmax_feed_mm_min = 3000.0\n")
    cfg = JobConfig.from_toml(tmp_path / "job.toml")
    surface, spath = small_part
    fig, _ = _quiet(figure_for_job, cfg, surface, spath)
    al = Alignment(offset_mm=(1.5, -0.75), rotation_deg=25.0, flip="y", scale=1.1)
    assert fig.provenance.params["alignment"] == al.to_dict()
    want = sample_error(ErrorMap.centred(z, pix), fig.target.grid.xy(), al).reshape(fig.target.grid.shape)
    np.testing.assert_allclose(fig.target.error_nm, want, equal_nan=True, atol=1e-9)
    api = _quiet(figure_dwell_times, surface, spath, ErrorMap.centred(z, pix), gaussian_tif(15.0, fwhm_mm=3.0),
                 max_feed_mm_min=3000.0, alignment=al, ca_margin_mm=1.0, t_min_s=fig.solution.t_min_s, force=True)
    np.testing.assert_allclose(api.target.removal_nm, fig.target.removal_nm, atol=1e-9, equal_nan=True)
    v, init = fig.target.valid, fig.stats["initial_rms_nm"]
    assert np.sqrt(np.mean((api.ideal_removal_nm - fig.ideal_removal_nm)[v] ** 2)) <= 0.005 * init
    assert api.stats["ideal_residual_rms_nm"] == pytest.approx(fig.stats["ideal_residual_rms_nm"], abs=0.005 * init)
    # and the alignment matters: without it the part reads another error
    plain = sample_error(ErrorMap.centred(z, pix), fig.target.grid.xy()).reshape(fig.target.grid.shape)
    v = fig.target.valid & np.isfinite(plain)
    assert np.abs(plain[v] - fig.target.error_nm[v]).max() > 5.0


def test_non_convergence_is_reported_with_numbers(small_part):
    surface, spath = small_part
    z = zernike_surface([0, 0, 0, 60.0, 20.0], 9.0, "fringe", 0.05)
    with pytest.warns(UserWarning, match=r"did not converge .*iteration limit 5 reached: relative residual "
                                         r"[0-9.e-]+ -> [0-9.e-]+"):
        fig = figure_dwell_times(surface, spath, ErrorMap.centred(z, 0.05), gaussian_tif(15.0, fwhm_mm=3.0),
                                 max_feed_mm_min=3000.0, ca_margin_mm=1.0, max_iter=5)
    st = fig.solution.stats
    assert not fig.solution.converged and st["iterations"] == 5
    assert 0 < st["relative_residual"] < st["relative_residual_start"] < 1
    done = _quiet(figure_dwell_times, surface, spath, ErrorMap.centred(z, 0.05), gaussian_tif(15.0, fwhm_mm=3.0),
                  max_feed_mm_min=3000.0, ca_margin_mm=1.0)
    assert done.solution.converged, done.solution.stats["message"]
    assert done.solution.stats["relative_residual_change_30"] <= 1e-3
    assert done.solution.stats["relative_residual"] < st["relative_residual"]


def test_two_iteration_example_runs(tmp_path):
    """examples/figuring/run_two_iterations.py on a smaller part: iteration 2 starts from iteration 1's result."""
    import importlib.util
    from pathlib import Path

    ex = Path(__file__).resolve().parents[1] / "examples" / "figuring" / "run_two_iterations.py"
    spec = importlib.util.spec_from_file_location("run_two_iterations", ex)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    # the small part reads only 12 nm PV of the map: at 15 nm/s the floor (14 nm) is above it and refused
    figs = mod.main(tmp_path, surface="xy-polynomial:radius=7,triangles=1200", spacing=0.6, report=False,
                    tif="gaussian:fwhm=3,peak_rate=5")
    one, two = figs
    assert (tmp_path / "after-1.xyz").is_file() and (tmp_path / "it2" / "toolpath.nc").is_file()
    assert json.loads((tmp_path / "it2" / "summary.json").read_text())["figuring"]["error_map"].endswith("after-1.xyz")
    assert one["residual_rms_nm"] <= 0.15 * one["initial_rms_nm"]
    # the second iteration's error is what the first left (the process 5 % off plus 0.5 nm of texture) ...
    assert one["residual_rms_nm"] < two["initial_rms_nm"] < 0.5 * one["initial_rms_nm"]
    # ... and it takes it down again with the gentler finishing tool (its floor under the error), removing less
    # (dwell x peak rate: 2 nm/s against 5 nm/s)
    assert two["residual_rms_nm"] < two["initial_rms_nm"] and not two["forced"]
    assert two["floor_nm"] < two["initial_pv_nm"]
    assert two["total_time_s"] * 2.0 < one["total_time_s"] * 5.0
