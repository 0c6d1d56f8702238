"""Non-finite and out-of-range values in every input file: refused (exit 2, the count, the file, the fix) or,
where a shop file legitimately has them (NaN outside an interferometer's aperture), accepted with a warning
that gives the count and what was done with them (issue 25 item 2).

Readers covered: error maps (grid, x y z, .datx, TIF-as-map), measured TIF maps, measurements for the PSD
(profiles, grids, .datx), meshes (STL, OBJ, PLY, OFF), machine profiles and job files (TOML allows
``nan`` and ``inf``).
"""

from __future__ import annotations

import numpy as np
import pytest

from test_bad_input import cli, refused

PART = "xy-polynomial:radius=6,triangles=900"
PLAN = ("--spacing", "0.8", "--seed", "3", "--no-report", "-q", "--tif", "gaussian:fwhm=3,peak_rate=2.5")


def _grid_map(path, z, dx_mm=0.1):
    """A grid-of-heights text map, nm, with its pixel size in a comment."""
    rows = "\n".join(" ".join("nan" if np.isnan(v) else repr(float(v)) for v in r) for r in z)
    path.write_text(f"# dx: {dx_mm} mm\n# height_unit: nm\n{rows}\n")
    return path


def _smooth_map(n=161, dx=0.1):
    o = (np.arange(n) - (n - 1) / 2) * dx
    X, Y = np.meshgrid(o, o)
    return 20.0 * (X**2 + Y**2) / o.max() ** 2 + 5.0 * X / o.max()


def test_error_map_with_a_block_of_infinite_heights_is_refused(tmp_path):
    """Issue 25's case: a 5 x 5 block of inf was planned with exit 0, the pixels silently 'uncovered'."""
    z = _smooth_map()
    z[70:75, 80:85] = np.inf
    m = _grid_map(tmp_path / "err.txt", z)
    err = refused(cli("plan", PART, *PLAN, "--error-map", m, "-o", tmp_path / "out"), "err.txt", "25 of", "infinite",
                  "NaN (no data)")
    assert not (tmp_path / "out").exists(), "a refused job leaves no output folder"
    assert "row 70, column 80" in err


def test_error_map_with_minus_infinity_in_xyz_points_is_refused(tmp_path):
    z = _smooth_map(41, 0.4)
    o = (np.arange(41) - 20) * 0.4
    X, Y = np.meshgrid(o, o)
    z[3, 4] = -np.inf
    pts = np.column_stack([X.ravel(), Y.ravel(), z.ravel()])
    (tmp_path / "err.xyz").write_text("# lateral_unit: mm\n# height_unit: nm\n"
                                      + "\n".join(f"{float(a)!r} {float(b)!r} {float(c)!r}" for a, b, c in pts) + "\n")
    refused(cli("plan", PART, *PLAN, "--error-map", tmp_path / "err.xyz", "-o", tmp_path / "out"),
            "err.xyz", "1 of 1681", "infinite")


def test_error_map_nan_pixels_are_accepted_with_their_count(tmp_path):
    """NaN outside the aperture is an interferometer's normal output: used as no data, counted in a warning."""
    z = _smooth_map()
    o = (np.arange(161) - 80) * 0.1
    X, Y = np.meshgrid(o, o)
    z[np.hypot(X, Y) > 7.9] = np.nan
    n_nan = int(np.isnan(z).sum())
    m = _grid_map(tmp_path / "err.txt", z)
    r = cli("plan", PART, *PLAN, "--error-map", m, "-o", tmp_path / "out")
    assert r.returncode == 0, r.stderr
    assert f"err.txt: {n_nan} of {z.size} pixels have no data (NaN)" in r.stderr
    assert "kept as missing" in r.stderr


def test_error_map_api_refuses_infinite_heights():
    from polishpath.dwell import ErrorMap
    from polishpath.errors import ParameterError

    z = np.zeros((10, 10))
    z[2, 3] = np.inf
    z[4, 4] = np.nan  # no data: fine
    with pytest.raises(ParameterError, match="1 infinite height"):
        ErrorMap(z, 0.1, 0.1)
    assert ErrorMap(np.where(np.isinf(z), 0.0, z), 0.1, 0.1).valid.sum() == 99


# --- measurements (psd) --------------------------------------------------------------------------------------


def _profile_text(x, z):
    return "# lateral_unit: mm\n# height_unit: nm\n" + "\n".join(f"{float(a)!r} {float(b)!r}" for a, b in zip(x, z)) + "\n"


def test_profile_with_infinite_height_is_refused(tmp_path):
    x = np.arange(200) * 0.01
    z = np.sin(x * 20)
    z[17] = np.inf
    (tmp_path / "p.txt").write_text(_profile_text(x, z))
    refused(cli("psd", tmp_path / "p.txt"), "p.txt", "1 of 200 height values are infinite", "sample 17")


def test_profile_with_infinite_x_is_refused(tmp_path):
    x = np.arange(200) * 0.01
    x[5] = np.inf
    (tmp_path / "p.txt").write_text(_profile_text(x, np.sin(np.arange(200) * 0.2)))
    refused(cli("psd", tmp_path / "p.txt"), "p.txt", "1 of 200 x coordinates are NaN or infinite", "data line 6")


def test_profile_nan_samples_are_named_in_a_warning(tmp_path):
    x = np.arange(200) * 0.01
    z = np.sin(x * 20)
    z[[3, 50, 51]] = np.nan
    (tmp_path / "p.txt").write_text(_profile_text(x, z))
    r = cli("psd", tmp_path / "p.txt", "--nan", "interpolate")
    assert r.returncode == 0, r.stderr
    assert "p.txt: 3 of 200 samples have no data (NaN)" in r.stderr


@pytest.mark.parametrize("dx", ["0 mm", "-0.1 mm"])
def test_grid_with_zero_or_negative_pixel_size_is_refused(tmp_path, dx):
    rows = "\n".join(" ".join("1.0" for _ in range(20)) for _ in range(20))
    (tmp_path / "g.txt").write_text(f"# dx: {dx}\n{rows}\n")
    refused(cli("psd", tmp_path / "g.txt"), "g.txt", "must be a positive number of mm")


def test_datx_no_data_pixels_are_counted_and_infinite_pixels_refused(tmp_path):
    pytest.importorskip("h5py")
    from polishpath.psd.io import write_datx_like

    z = np.outer(np.linspace(-5, 5, 64), np.ones(64))
    z[:4] = np.nan  # written as the No Data sentinel
    write_datx_like(tmp_path / "m.datx", z, 0.05)
    r = cli("psd", tmp_path / "m.datx")
    assert r.returncode == 0, r.stderr
    assert "m.datx: 256 of 4096 pixels have no data (NaN or the file's no-data value)" in r.stderr
    z[10, 10] = -np.inf
    write_datx_like(tmp_path / "bad.datx", z, 0.05, no_data=1e38)
    import h5py

    with h5py.File(tmp_path / "bad.datx", "r+") as f:  # an infinity that is not the sentinel
        ds = next(iter(f["Data"]["Surface"].values()))
        a = ds[()]
        a[10, 10] = -np.inf
        ds[...] = a
    refused(cli("psd", tmp_path / "bad.datx"), "bad.datx", "1 of 4096 height values are infinite")


# --- measured TIF maps ---------------------------------------------------------------------------------------


def _spot(n=41, dx=0.1, peak=10.0):
    o = (np.arange(n) - (n - 1) / 2) * dx
    X, Y = np.meshgrid(o, o)
    return peak * np.exp(-(X**2 + Y**2) / (2 * 0.5**2))


def test_measured_tif_nan_and_noise_set_to_zero_with_their_counts(tmp_path):
    from polishpath.dwell import tif_from_spec

    a = _spot()
    a[0, :5] = np.nan
    a[40, 40] = -0.2  # noise below zero: 2 % of the peak
    _grid_map(tmp_path / "tif.txt", a)
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stderr(buf):
        t = tif_from_spec(f"measured:file={tmp_path / 'tif.txt'}")
    assert "5 pixel(s) without data (NaN) and 1 small negative rate(s)" in buf.getvalue()
    assert np.isfinite(t.array).all() and t.array.min() == 0.0


@pytest.mark.parametrize("change, needle", [
    ("negative", "negative removal rates down to -5"),
    ("inf", "infinite"),
    ("zero", "no positive removal rate"),
])
def test_measured_tif_out_of_range_values_refused(tmp_path, change, needle):
    a = _spot()
    if change == "negative":
        a[0, 0] = -5.0  # half the peak below zero: a height map, not removal
    elif change == "inf":
        a[3, 3] = np.inf
    else:
        a[:] = 0.0
    _grid_map(tmp_path / "tif.txt", a)
    refused(cli("plan", PART, "--spacing", "0.8", "--seed", "3", "--no-report", "-q", "--error-map",
                _grid_map(tmp_path / "err.txt", _smooth_map()), "--tif", f"measured:file={tmp_path / 'tif.txt'}",
                "-o", tmp_path / "out"), "tif.txt", needle)


@pytest.mark.parametrize("spec", ["rate=nan", "dwell_s=0", "dwell_s=-2", "rate=inf"])
def test_measured_tif_spec_numbers_must_be_positive(tmp_path, spec):
    from polishpath.dwell import tif_from_spec
    from polishpath.errors import ParameterError

    _grid_map(tmp_path / "tif.txt", _spot())
    with pytest.raises(ParameterError, match="must be a positive number"):
        tif_from_spec(f"measured:file={tmp_path / 'tif.txt'},{spec}")


# --- meshes ----------------------------------------------------------------------------------------------------

MESHES = {
    "t.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 nan\nv 2 0 inf\nf 1 2 3\nf 2 4 3\nf 2 5 4\n",
    "t.off": "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 inf\n3 0 1 2\n3 1 3 2\n",
    "t.ply": ("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
              "element face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n1 1 nan\n"
              "3 0 1 2\n3 1 3 2\n"),
    "t.stl": ("solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 -inf\nendloop\n"
              "endfacet\nendsolid t\n"),
}


@pytest.mark.parametrize("name", sorted(MESHES))
def test_mesh_with_non_finite_vertices_is_refused_with_the_count(tmp_path, name):
    (tmp_path / name).write_text(MESHES[name])
    n = 2 if name == "t.obj" else 1
    refused(cli("plan", tmp_path / name, "--spacing", "0.2", "-o", tmp_path / "out", "-q"),
            f"{n} vertices with NaN or infinite coordinates", "Fix or remove them")


# --- machine profiles and job files (TOML has nan and inf) ----------------------------------------------------


@pytest.mark.parametrize("line, needle", [
    ("max_feed_mm_min = nan", "max_feed_mm_min must be a positive number, got nan"),
    ("max_feed_mm_min = inf", "max_feed_mm_min must be a positive number, got inf"),
    ("max_acceleration_mm_s2 = [1000, -1, 500]", "max_acceleration_mm_s2 must be a positive number, got -1"),
    ("period_ms = 0", "period_ms must be a positive number, got 0"),
])
def test_machine_profile_non_finite_or_out_of_range_refused(tmp_path, line, needle):
    (tmp_path / "m.toml").write_text(f"[machine]\nname = \"m\"\n{line}\n")
    refused(cli("plan", "hemisphere:R=10,triangles=600", "--spacing", "1.5", "--machine", tmp_path / "m.toml",
                "-o", tmp_path / "out", "-q"), needle)


@pytest.mark.parametrize("table, needle", [
    ("[job]\nsurface = \"hemisphere:R=10,triangles=600\"\nspacing = nan\n", "spacing (--spacing) must be a number"),
    ("[job]\nsurface = \"hemisphere:R=10,triangles=600\"\nspacing = 1.5\nfeed_mm_min = inf\n", "must be a number"),
    ("[job]\nsurface = \"hemisphere:R=10,triangles=600\"\nspacing = 1.5\nerror_map = \"e.txt\"\n"
     "[error_map]\nmax_uncovered = nan\n", "[error_map] max_uncovered must be >= 0 and <= 1, got nan"),
    ("[job]\nsurface = \"hemisphere:R=10,triangles=600\"\nspacing = 1.5\nerror_map = \"e.txt\"\n"
     "[error_map]\ndx_mm = 0\n", "[error_map] dx_mm must be > 0, got 0"),
    ("[job]\nsurface = \"hemisphere:R=10,triangles=600\"\nspacing = 1.5\nerror_map = \"e.txt\"\n"
     "[error_map]\noffset_mm = [nan, 0]\n", "offset_mm must be two finite numbers"),
    ("[job]\nsurface = \"hemisphere:R=10,triangles=600\"\nspacing = 1.5\nerror_map = \"e.txt\"\n"
     "[error_map]\nmax_feed_mm_min = -inf\n", "[error_map] max_feed_mm_min must be > 0, got -inf"),
    ("[job]\nsurface = \"hemisphere:R=10,triangles=600\"\nspacing = 1.5\nerror_map = \"e.txt\"\n"
     "[error_map]\nbias_nm = inf\n", "[error_map] bias_nm must be >= 0, got inf"),
])
def test_job_file_non_finite_or_out_of_range_refused(tmp_path, table, needle):
    (tmp_path / "job.toml").write_text(table)
    _grid_map(tmp_path / "e.txt", _smooth_map(41, 0.4), 0.4)
    refused(cli("plan", "--config", tmp_path / "job.toml", "-o", tmp_path / "out", "-q"), needle)


# --- Zernike error maps, surface specs and dwell-time files ---------------------------------------------------


@pytest.mark.parametrize("body, needle", [
    ("radius_mm = 8.0\ncoefficients = [0, 0, 0, nan, 2.0]\n", "1 Zernike coefficient(s) are NaN or infinite (Z4 first)"),
    ("radius_mm = inf\ncoefficients = [0, 0, 0, 10]\n", "a finite number > 0), got inf"),
    ("radius_mm = 8.0\ncoefficients = [0, 0, 0, 10]\npixel_mm = 0\n", "pixel_mm must be a positive number"),
    ("radius_mm = 8.0\ncoefficients = [0, 0, 0, 10]\npixel_mm = nan\n", "pixel_mm must be a positive number"),
])
def test_zernike_error_map_non_finite_or_out_of_range_refused(tmp_path, body, needle):
    (tmp_path / "z.toml").write_text(f"[zernike]\nunits = \"nm\"\n{body}")
    refused(cli("plan", PART, *PLAN, "--error-map", tmp_path / "z.toml", "-o", tmp_path / "out"), "z.toml", needle)


@pytest.mark.parametrize("line, needle", [
    ("coeffs = [0.0, 0.0, 0.0, 0.0, nan, 0.0, 0.01]", "coeffs has 1 NaN or infinite value(s) of 7"),
    ("k = inf", "k has 1 NaN or infinite value(s)"),
    ("R = nan", "R has 1 NaN or infinite value(s)"),
])
def test_surface_spec_with_non_finite_numbers_is_refused(tmp_path, line, needle):
    key = line.split(" = ")[0]
    base = {"R": "R = 400.0", "k": "k = 0.0", "coeffs": "coeffs = [0.0, 0.0, 0.0, 0.0, 0.02, 0.0, 0.01]"}
    base[key] = line
    (tmp_path / "s.toml").write_text("[surface]\ntype = \"zernike\"\norder = \"fringe\"\nnorm_radius = 30.0\n"
                                     + "\n".join(base.values()) + "\ntriangles = 2000\n[aperture]\ntype = \"circle\"\n"
                                     "radius = 30.0\n")
    refused(cli("info", tmp_path / "s.toml"), needle)


def test_dwell_time_file_with_nan_names_the_count_and_the_first(tmp_path):
    (tmp_path / "t.csv").write_text("dwell_time\n0.5\nnan\n0.5\n-1\n")
    refused(cli("plan", "hemisphere:R=10,triangles=600", "--spacing", "1.5", "--dwell-times", tmp_path / "t.csv",
                "-o", tmp_path / "out", "-q"), "t.csv: 2 of 4 dwell times", "the first is time 2: nan")
