"""Instruments' own measurement files (issue 28 item 5): a real Zygo .datx, and MetroPro .dat, Zygo ASCII,
4D Technology HDF5 and a Form Talysurf text export written to their documented layouts.

Each reader: heights in nm, lateral in mm, invalid pixels as NaN with their count, the rows' order stated
(interferometers store the top row first; the error map's rows go up in y).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from instrument_files import write_4d_h5, write_metropro_dat, write_zygo_ascii
from polishpath.dwell import read_error_map
from polishpath.errors import MeasurementFileError
from polishpath.psd import read_measurement

from conftest import shared_measurement_path

# real instrument files live in ../shared/data/measurements (tests/data/measurements/SOURCES.md); the tests
# that read them skip where it does not hold them
REAL_DATX = "zygo_test.datx"  # a Zygo GPI .datx (TWANG006/monolithic data/zygo_test.datx, MIT)
REAL_DAT = "metropro-1.dat"  # a Zygo NewView MetroPro .dat (SurfaceTopography's metropro-1.dat, MIT)


def _map(h=24, w=31, nan_corner=True):
    """A map with a known shape: heights rise towards the *top* row (row 0 as the camera stores it)."""
    i, j = np.mgrid[0:h, 0:w]
    z = 40.0 * (h - 1 - i) / (h - 1) + 3.0 * np.sin(j / 3.0)  # nm; row 0 the highest
    if nan_corner:
        z[:3, :4] = np.nan
    return z


# --- a real instrument file ----------------------------------------------------------------------------------


def test_real_zygo_datx_reads_with_its_own_units_and_no_data():
    h5py = pytest.importorskip("h5py")
    real = shared_measurement_path(REAL_DATX)
    with h5py.File(real, "r") as f:
        ds = next(iter(f["Data"]["Surface"].values()))
        raw = ds[()]
        assert ds.attrs["Unit"][0] in (b"Fringes", "Fringes")
    no_data = raw >= np.finfo(np.float64).max  # counted here with h5py alone
    m = read_measurement(real)
    assert m.kind == "map" and m.z_nm.shape == (259, 33)
    assert m.dx_mm == pytest.approx(1.0, rel=1e-6)  # 0.001 m in the /Attributes group (the converter is in pixels)
    assert m.params["dx_source"].startswith("/Attributes")
    assert m.n_nan == int(no_data.sum()) == 776
    ok = ~no_data
    np.testing.assert_allclose(m.z_nm[ok], raw[ok] * 0.5 * 632.79998e0, rtol=1e-6)  # fringes x scale x wavelength
    rms = np.std(m.z_nm[ok])
    assert 10 < rms < 1000  # a polished surface's figure, nm: units neither m nor fringes


def test_real_zygo_datx_as_an_error_map_has_its_rows_flipped(recwarn):
    pytest.importorskip("h5py")
    real = shared_measurement_path(REAL_DATX)
    m = read_measurement(real)
    e = read_error_map(real)
    np.testing.assert_array_equal(e.z_nm, m.z_nm[::-1])
    assert "flipped" in e.params["rows"]
    assert e.dx_mm == pytest.approx(1.0, rel=1e-6)


def _real_dat(tmp_path) -> Path:
    p = tmp_path / "metropro-1.dat"
    p.write_bytes(shared_measurement_path(REAL_DAT).read_bytes())
    return p


def test_real_metropro_dat_agrees_with_an_independent_reader(tmp_path):
    """A Zygo NewView file written by MetroPro 8.1.5 (640 x 480, 20X Mirau, 570 nm): the figures another open
    reader (SurfaceTopography) asserts for the same file: 640 x 480 pixels over 0.70288 x 0.52716 mm, RMS height
    75.288222 nm, 3.911386 nm after removing a quadratic surface, 75.24071 nm as the mean of the rows' variances."""
    m = read_measurement(_real_dat(tmp_path))
    assert m.params["format"] == "metropro-dat" and m.params["header_format"] == 1
    assert m.params["phase_res"] == 1 and m.params["wavelength_nm"] == pytest.approx(570.0, rel=1e-6)
    assert m.z_nm.shape == (480, 640) and m.n_nan == 0
    assert m.dx_mm * 640 == pytest.approx(0.7028812979115173, rel=1e-6)
    assert m.dy_mm * 480 == pytest.approx(0.527160973433638, rel=1e-6)
    z = m.z_nm
    assert np.std(z) == pytest.approx(75.288222047, rel=1e-6)  # 32768 counts per wave (phase_res 1), not 4096
    i, j = (a.ravel() for a in np.mgrid[0:480, 0:640].astype(float))
    a = np.stack([np.ones_like(i), i, j, i * i, j * j, i * j], axis=1)
    resid = z.ravel() - a @ np.linalg.lstsq(a, z.ravel(), rcond=None)[0]
    assert np.sqrt(np.mean(resid ** 2)) == pytest.approx(3.911386124, rel=1e-6)
    # the rows are lines along x (the 640-pixel axis): the transposed map would give 4.50 nm here
    assert np.sqrt(np.mean(np.var(z, axis=1))) == pytest.approx(75.24071, rel=1e-6)


def test_real_metropro_dat_as_an_error_map_has_its_rows_flipped(tmp_path, recwarn):
    """The real .dat read as a figuring error map: the same pixels, rows reversed (row 0 at the smallest y), the
    pixel size from the header in both directions."""
    p = _real_dat(tmp_path)
    m = read_measurement(p)
    e = read_error_map(p)
    np.testing.assert_array_equal(e.z_nm, m.z_nm[::-1])
    assert "flipped" in e.params["rows"]
    assert e.dx_mm == pytest.approx(1.0982520e-3, rel=1e-6) and e.dy_mm == pytest.approx(e.dx_mm)


def test_real_metropro_dat_bytes_cut_short_are_refused(tmp_path):
    p = _real_dat(tmp_path)
    p.write_bytes(p.read_bytes()[:-4 * 640])  # the last phase row lost
    with pytest.raises(MeasurementFileError, match="Is the file complete"):
        read_measurement(p)


# --- MetroPro binary .dat ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("header_format, phase_res", [(1, 0), (2, 1), (3, 2)])
def test_metropro_dat_heights_pixels_and_no_data(tmp_path, header_format, phase_res):
    z = _map()
    p = write_metropro_dat(tmp_path / "m.dat", z, lateral_res_m=2.5e-4, header_format=header_format,
                           phase_res=phase_res)
    m = read_measurement(p)
    step = 0.5 * 632.8e-9 / {0: 4096, 1: 32768, 2: 131072}[phase_res] * 1e9  # nm per count
    assert m.params["format"] == "metropro-dat" and m.params["header_format"] == header_format
    assert m.z_nm.shape == z.shape and m.dx_mm == pytest.approx(0.25, rel=1e-6)
    assert m.n_nan == 12
    np.testing.assert_allclose(m.z_nm, z, atol=0.51 * step + 1e-9 * np.nanmax(z), equal_nan=True)


def test_metropro_dat_inverted_sign_and_missing_lateral_resolution(tmp_path):
    z = _map(nan_corner=False)
    p = write_metropro_dat(tmp_path / "m.dat", z, sign=1, lateral_res_m=0.0)
    with pytest.raises(MeasurementFileError, match="does not state its lateral resolution"):
        read_measurement(p)
    m = read_measurement(p, dx_mm=0.1)
    np.testing.assert_allclose(m.z_nm, z, atol=0.01)
    assert m.params["dx_source"] == "argument"


def test_metropro_dat_truncated_is_refused(tmp_path):
    p = write_metropro_dat(tmp_path / "m.dat", _map(), truncate=100)
    with pytest.raises(MeasurementFileError, match="Is the file complete"):
        read_measurement(p)


def test_a_dat_of_plain_numbers_is_still_text(tmp_path):
    x = np.arange(64) * 0.01
    (tmp_path / "p.dat").write_text("# lateral_unit: mm\n# height_unit: nm\n"
                                    + "\n".join(f"{a} {np.sin(a * 9):.6f}" for a in x))
    m = read_measurement(tmp_path / "p.dat")
    assert m.kind == "profile" and m.params["format"] == "text"


# --- Zygo ASCII ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("intensity", [True, False])
def test_zygo_ascii_heights_pixels_and_no_data(tmp_path, intensity):
    z = _map()
    p = write_zygo_ascii(tmp_path / "m.asc", z, lateral_res_m=5e-5, intensity=intensity)
    m = read_measurement(p)
    assert m.params["format"] == "zygo-ascii"
    assert m.z_nm.shape == z.shape and m.dx_mm == pytest.approx(0.05, rel=1e-6) and m.n_nan == 12
    np.testing.assert_allclose(m.z_nm, z, atol=0.01, equal_nan=True)


def test_zygo_ascii_inverted_data_sign(tmp_path):
    """DataSign (line 11's eighth number) 1: the heights are the counts' opposite, as in the binary file."""
    z = _map(nan_corner=False)
    m = read_measurement(write_zygo_ascii(tmp_path / "m.asc", z, sign=1))
    np.testing.assert_allclose(m.z_nm, z, atol=0.01)


def test_zygo_ascii_with_missing_values_is_refused(tmp_path):
    p = write_zygo_ascii(tmp_path / "m.asc", _map())
    text = p.read_text().splitlines()
    p.write_text("\n".join(text[:-3] + text[-1:]) + "\n")  # two lines of phase counts lost
    with pytest.raises(MeasurementFileError, match="promises 31 x 24 phase values"):
        read_measurement(p)


# --- 4D Technology HDF5 ---------------------------------------------------------------------------------------


def test_4d_h5_waves_to_nm_sentinel_and_pixel_size(tmp_path):
    pytest.importorskip("h5py")
    z = _map()
    p = write_4d_h5(tmp_path / "m.h5", z, wavelength="632.8 nm")
    with pytest.raises(MeasurementFileError, match="does not state its pixel size"):
        read_measurement(p)
    m = read_measurement(p, dx_mm=0.2)
    assert m.params["format"] == "4d-h5" and m.n_nan == 12 and m.dx_mm == 0.2
    np.testing.assert_allclose(m.z_nm, z, rtol=1e-6, atol=1e-4, equal_nan=True)  # float32 waves
    m = read_measurement(write_4d_h5(tmp_path / "x.h5", z, wavelength=532.0, xpix="120 um"))
    assert m.dx_mm == pytest.approx(0.12) and m.params["dx_source"] == "xpix"
    np.testing.assert_allclose(m.z_nm, z, rtol=1e-6, atol=1e-4, equal_nan=True)


def test_4d_h5_in_the_layout_of_a_real_4sight_file(tmp_path):
    """The attributes a real 4Sight 1.8 file carries (M4's test/data/img_0046.h5: height_units "wv", the
    wavelength as "632.79998799999998000000 nm", xpix "0.00711100000000000010 mm", wedge 0.5; SOURCES.md):
    heights = waves x that wavelength, the pixel from xpix, the wedge reported and not applied."""
    pytest.importorskip("h5py")
    z = _map()
    p = write_4d_h5(tmp_path / "m.h5", z, wavelength="632.79998799999998000000 nm",
                    xpix="0.00711100000000000010 mm", height_units="wv", wedge=0.5, version="1.8")
    m = read_measurement(p)
    assert m.dx_mm == pytest.approx(0.007111, rel=1e-12) and m.params["dx_source"] == "xpix"
    assert m.params["wavelength_nm"] == pytest.approx(632.799988, rel=1e-12)
    assert m.params["wedge"] == 0.5 and m.params["height_units"] == "wv" and m.params["software"] == "4Sight 1.8"
    assert m.n_nan == 12
    np.testing.assert_allclose(m.z_nm, z, rtol=1e-6, atol=1e-4, equal_nan=True)


def test_4d_h5_heights_saved_in_nm_are_not_scaled_by_the_wavelength(tmp_path):
    pytest.importorskip("h5py")
    z = _map()
    m = read_measurement(write_4d_h5(tmp_path / "m.h5", z, xpix="0.1 mm", height_units="nm"))
    np.testing.assert_allclose(m.z_nm, z, rtol=1e-6, atol=1e-4, equal_nan=True)
    m = read_measurement(write_4d_h5(tmp_path / "u.h5", z, xpix="0.1 mm", height_units="um"))
    np.testing.assert_allclose(m.z_nm, z, rtol=1e-6, atol=1e-3, equal_nan=True)


def test_4d_insight_file_waves_nan_and_pixel_size(tmp_path):
    pytest.importorskip("h5py")
    from instrument_files import write_4d_insight

    z = _map()
    p = write_4d_insight(tmp_path / "m.4D", z, wavelength_nm=632.8, pixel_um=55.0)
    m = read_measurement(p)
    assert m.params["layout"].startswith("4D InSight") and m.params["dx_source"] == "PixelSizeInMicrons"
    assert m.dx_mm == pytest.approx(0.055) and m.n_nan == 12
    np.testing.assert_allclose(m.z_nm, z, rtol=1e-6, atol=1e-4, equal_nan=True)
    p = write_4d_insight(tmp_path / "n.4D", z, wavelength_nm=632.8)
    with pytest.raises(MeasurementFileError, match="does not state its pixel size"):
        read_measurement(p)
    assert read_measurement(p, dx_mm=0.3).dx_mm == 0.3


# --- every interferometer format: the rows as an error map -----------------------------------------------------


@pytest.mark.parametrize("fmt", ["dat", "asc", "h5", "4D", "datx"])
def test_interferometer_rows_go_up_in_y_as_an_error_map(tmp_path, fmt, recwarn):
    """The file's first row is the top of the map (largest y): the error map's row 0 is its bottom."""
    z = _map(nan_corner=False)  # the file's row 0 is the highest: heights rise with y on the part
    if fmt in ("h5", "4D", "datx"):
        pytest.importorskip("h5py")
    if fmt == "dat":
        p = write_metropro_dat(tmp_path / "m.dat", z, lateral_res_m=1e-4)
    elif fmt == "asc":
        p = write_zygo_ascii(tmp_path / "m.asc", z, lateral_res_m=1e-4)
    elif fmt == "h5":
        p = write_4d_h5(tmp_path / "m.h5", z, xpix="0.1 mm")
    elif fmt == "4D":
        from instrument_files import write_4d_insight

        p = write_4d_insight(tmp_path / "m.4D", z, pixel_um=100.0)
    else:
        from polishpath.psd.io import write_datx_like

        p = write_datx_like(tmp_path / "m.datx", z, 0.1)
    e = read_error_map(p)
    col = e.z_nm[:, 5]
    assert np.all(np.diff(col) > 0), "heights must rise with the row index (y up)"
    assert e.dy_mm == pytest.approx(0.1, rel=1e-6)


# --- a profilometer's export --------------------------------------------------------------------------------------


def test_form_talysurf_text_export_reads_its_units_from_the_header(tmp_path):
    """A Form Talysurf profile exported as text: a block of settings, then 'X (mm)  Z (µm)' columns."""
    x = np.arange(400) * 0.0005  # 0.5 um sampling
    z_um = 0.12 * np.sin(2 * np.pi * x / 0.05)
    lines = ["Form Talysurf PGI 1240", "Profile: primary", "Traverse length = 0.2 mm", "X (mm)\tZ (µm)"]
    lines += [f"{a:.6f}\t{b:.6f}" for a, b in zip(x, z_um)]
    p = tmp_path / "trace.prf"
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    m = read_measurement(p)
    assert m.kind == "profile" and not m.params["units_assumed"]
    assert m.dx_mm == pytest.approx(0.0005, rel=1e-6)
    np.testing.assert_allclose(m.z_nm, z_um * 1e3, atol=1e-3)


def test_psd_command_reads_a_metropro_dat(tmp_path):
    from test_bad_input import cli

    p = write_metropro_dat(tmp_path / "m.dat", _map(64, 64, nan_corner=False), lateral_res_m=1e-4)
    r = cli("psd", p)
    assert r.returncode == 0, r.stderr
    assert "m.dat: map (64, 64) at 100 um, 0 missing pixels" in r.stdout


# --- what `polishpath psd` prints: the band RMS is the band's, and says where the height is ------------------------


def _sine_dat(tmp_path, dx_m=1e-4, period_px=16):
    """A 64 x 64 MetroPro map holding a 10 nm RMS sine along x (period 16 pixels)."""
    j = np.mgrid[0:64, 0:64][1]
    z = 10.0 * np.sqrt(2.0) * np.sin(2 * np.pi * j / period_px)
    return write_metropro_dat(tmp_path / "sine.dat", z, lateral_res_m=dx_m)


def test_psd_command_on_a_sine_below_the_band_says_so(tmp_path):
    """At 0.1 mm pixels the sine's wavelength is 1.6 mm (0.625 1/mm), outside the default band 1-100 1/mm: the
    band RMS is a few thousandths of a nm, which is right for the band (the quantised heights' harmonics); the
    output says how much of the variance the band holds, where the strongest component is, and which --band
    measures it. With that band the same file gives the sine's 10 nm."""
    from test_bad_input import cli

    p = _sine_dat(tmp_path)
    r = cli("psd", p)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    rms = float(out.split("  RMS ")[1].split(" nm")[0])
    band = float(out.split("band RMS ")[1].split(" nm")[0])
    assert 9.0 < rms < 10.5 and band < 0.05
    assert "of which the data resolves 1-5 1/mm" in out  # Nyquist of 0.1 mm pixels: 5 1/mm
    assert "strongest component: 0.625 1/mm (wavelength 1.6 mm), below the band" in out
    assert "--band 0.208,1.88" in out and "not a reading error" in out
    r2 = cli("psd", p, "--band", "0.208,1.88")
    assert r2.returncode == 0, r2.stderr
    band2 = float(r2.stdout.split("band RMS ")[1].split(" nm")[0])
    assert band2 == pytest.approx(10.0, rel=0.05)
    assert "note:" not in r2.stdout and "inside the band" in r2.stdout


def test_band_share_and_strongest_frequency():
    from polishpath.psd import psd_1d
    from polishpath.psd.analyze import band_variance_fraction, strongest_frequency

    x = np.arange(1024) * 0.01  # mm
    z = 10 * np.sin(2 * np.pi * 0.5 * x) + 1 * np.sin(2 * np.pi * 20 * x)  # nm: 0.5 and 20 1/mm, powers 100 : 1
    p = psd_1d(z, 0.01, window="hann", detrend="none")
    assert strongest_frequency(p) == pytest.approx(0.5, abs=p.df)
    assert band_variance_fraction(p, (1, 100)) == pytest.approx(1 / 101, rel=0.05)
    assert band_variance_fraction(p, (0.01, 100)) == pytest.approx(1.0)


# --- a grid of heights: its dx says the lateral unit ------------------------------------------------------------


def test_a_grid_whose_dx_has_a_unit_assumes_no_lateral_unit(tmp_path):
    """A grid has no coordinates, so the lateral unit only scales dx: '# dx: 5 um' (or dx_mm) leaves nothing
    lateral assumed and no warning for it; '# dx: 0.5' (no unit) is taken as mm and says so."""
    rows = "\n".join(" ".join(f"{(i * j) % 7:.1f}" for j in range(12)) for i in range(10))
    p = tmp_path / "g.txt"
    p.write_text("# dx: 5 um\n# height_unit: nm\n" + rows + "\n")
    m = read_measurement(p)
    assert m.params["units_assumed"] == [] and m.dx_mm == pytest.approx(0.005)
    p.write_text("# dx: 0.5\n# height_unit: nm\n" + rows + "\n")
    assert read_measurement(p).params["units_assumed"] == ["lateral unit mm"]
    p.write_text("# height_unit: nm\n" + rows + "\n")
    m = read_measurement(p, dx_mm=0.25)
    assert m.params["units_assumed"] == [] and m.dx_mm == 0.25
