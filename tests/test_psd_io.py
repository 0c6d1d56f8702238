"""Reading measurements (text, CSV, Zygo .datx) and the file-level analysis."""

from __future__ import annotations

import numpy as np
import pytest

from polishpath.psd import MeasurementFileError, analyze_file, compare_files, read_measurement, write_datx_like


def _profile(n=2000, dx=0.005, amp=2.0, lam=0.5, seed=0):
    x = np.arange(n) * dx
    z = amp * np.sin(2 * np.pi * x / lam) + 0.05 * np.random.default_rng(seed).normal(size=n)
    return x, z


def test_text_profile_with_units_in_header(tmp_path):
    x, z = _profile()
    f = tmp_path / "p.txt"
    # x in micrometres, z in micrometres: reader must convert to mm and nm
    lines = ["# lateral_unit: um", "# height_unit: um"] + [f"{a * 1e3:.6f} {b * 1e-3:.9e}" for a, b in zip(x, z)]
    f.write_text("\n".join(lines))
    m = read_measurement(f)
    assert m.kind == "profile" and m.dx_mm == pytest.approx(0.005)
    assert np.allclose(m.z_nm, z, atol=1e-5)
    assert m.params["units_assumed"] == []


def test_csv_profile_units_from_column_names_and_nan(tmp_path):
    x, z = _profile()
    f = tmp_path / "p.csv"
    rows = ["x_mm,z_um"] + [f"{a},{b * 1e-3}" for a, b in zip(x, z)]
    rows[100] = f"{x[99]},nan"
    f.write_text("\n".join(rows))
    m = read_measurement(f)
    assert m.n_nan == 1 and np.nanmax(np.abs(m.z_nm - z)) < 1e-6
    res = analyze_file(f, spacing_mm=0.5)
    assert res["kind"] == "profile" and np.isfinite(res["band_rms_nm"])
    assert res["psd_params"]["n_samples_interpolated"] == 1  # said, not silently zeroed
    assert res["peaks"][0]["label"] == "1/spacing"


def test_units_assumed_are_reported(tmp_path):
    x, z = _profile(n=100)
    f = tmp_path / "plain.dat"
    f.write_text("\n".join(f"{a} {b}" for a, b in zip(x, z)))
    m = read_measurement(f)
    assert "lateral unit mm" in m.params["units_assumed"] and "height unit nm" in m.params["units_assumed"]


def test_xyz_points_and_grid_maps(tmp_path):
    ny, nx, dx = 20, 30, 0.01
    z = np.random.default_rng(1).normal(size=(ny, nx))
    Y, X = np.mgrid[0:ny, 0:nx] * dx
    f = tmp_path / "m.xyz"
    order = np.random.default_rng(2).permutation(ny * nx)  # any order
    pts = np.stack([X.ravel(), Y.ravel(), z.ravel()], axis=1)[order]
    f.write_text("\n".join(" ".join(f"{v:.10g}" for v in r) for r in pts))
    m = read_measurement(f)
    assert m.kind == "map" and m.z_nm.shape == (ny, nx) and np.allclose(m.z_nm, z)
    g = tmp_path / "grid.txt"
    g.write_text("# dx: 10 um\n" + "\n".join(" ".join(f"{v:.10g}" for v in r) for r in z))
    mg = read_measurement(g)
    assert mg.dx_mm == pytest.approx(0.01) and np.allclose(mg.z_nm, z)
    h = tmp_path / "grid_nodx.txt"
    h.write_text("\n".join(" ".join(f"{v:.10g}" for v in r) for r in z))
    with pytest.raises(MeasurementFileError, match="dx"):
        read_measurement(h)
    assert read_measurement(h, dx_mm=0.02).dx_mm == 0.02


def test_scattered_points_and_missing_file_raise(tmp_path):
    f = tmp_path / "s.xyz"
    pts = np.random.default_rng(3).uniform(size=(200, 3))
    f.write_text("\n".join(" ".join(map(str, r)) for r in pts))
    with pytest.raises(MeasurementFileError, match="regular grid"):
        read_measurement(f)
    with pytest.raises(MeasurementFileError, match="does not exist"):
        read_measurement(tmp_path / "nope.txt")


def test_datx_roundtrip_with_no_data_pixels(tmp_path):
    pytest.importorskip("h5py")
    z = np.random.default_rng(4).normal(size=(64, 80)) * 3
    z[5, 6] = np.nan
    z[40, 10:14] = np.nan
    f = write_datx_like(tmp_path / "m.datx", z, 0.004, unit="MicroMeters")
    m = read_measurement(f)
    assert m.kind == "map" and m.dx_mm == pytest.approx(0.004)
    assert m.n_nan == 5 and np.allclose(m.z_nm[np.isfinite(z)], z[np.isfinite(z)], atol=1e-9)
    assert m.params["dx_source"] == "X Converter"
    res = analyze_file(f)
    assert res["n_nan"] == 5 and res["psd_params"]["n_profiles_dropped"] == 2  # rows with NaN dropped, and said
    assert "psd_radial" in res


def test_datx_fringes_and_attribute_resolution(tmp_path):
    h5py = pytest.importorskip("h5py")
    z = np.ones((16, 16)) * 0.1  # fringes
    with h5py.File(tmp_path / "f.datx", "w") as f:
        ds = f.create_group("Data").create_group("Surface").create_dataset("k", data=z)
        ds.attrs["Unit"] = np.array([b"Fringes"], dtype=object)
        ds.attrs["No Data"] = np.array([1e38])
        ds.attrs["Wavelength"] = np.array([632.8e-9])
        ds.attrs["Interferometric Scale Factor"] = np.array([0.5])
        ds.attrs["Obliquity Factor"] = np.array([1.0])
        g = f.create_group("Attributes").create_group("g")
        g.attrs["Data Context.Data Attributes.Resolution:Value"] = np.array([2.0])
        g.attrs["Data Context.Data Attributes.Resolution:Unit"] = np.array([b"MicroMeters"], dtype=object)
    m = read_measurement(tmp_path / "f.datx")
    assert m.z_nm[0, 0] == pytest.approx(0.1 * 0.5 * 632.8)
    assert m.dx_mm == pytest.approx(0.002)


def test_compare_files_suppression(tmp_path):
    x, z = _profile(n=4000)
    a, b = tmp_path / "before.txt", tmp_path / "after.txt"
    a.write_text("\n".join(f"{u} {v}" for u, v in zip(x, z)))
    b.write_text("\n".join(f"{u} {v / 2}" for u, v in zip(x, z)))  # half the height = quarter of the PSD
    res = compare_files(a, b)
    assert res["suppression_ratio"] == pytest.approx(0.75, abs=1e-6)
    assert res["band_rms_ratio"] == pytest.approx(0.5, abs=1e-6)
