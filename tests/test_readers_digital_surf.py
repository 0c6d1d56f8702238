"""Digital Surf ``.sur`` / ``.pro`` (issue 28 item 5, the profilometer): what Taylor Hobson's TalyProfile /
TalyMap (Mountains-based) save for a Form Talysurf trace, read as a profile for ``polishpath psd`` and refused,
with its cause and the fix, as an error map (a profile is not a 2D map).

Files are written to the layout Gwyddion's ``surffile`` module and SurfaceTopography's ``SUR`` reader document
(tests/instrument_files.py ``write_digital_surf``); two real Digital Surf surfaces (SurfaceTopography's
``sur-2.sur`` / ``sur-3.sur``, MIT) are checked where they are present beside the repository
(``../shared/data/measurements``), against the figure SurfaceTopography's own test asserts.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from instrument_files import write_digital_surf
from polishpath.dwell import read_error_map
from polishpath.errors import MeasurementFileError
from polishpath.psd import read_measurement

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "measurements"


def _trace(n=4000, dx_mm=0.0005):
    """A Form Talysurf-like trace: 2 mm at 0.5 um, a 40 um period ripple and a 0.3 um bow, heights in nm."""
    x = np.arange(n) * dx_mm
    return 12.0 * np.sin(2 * np.pi * x / 0.04) + 300.0 * ((x - x.mean()) / np.ptp(x)) ** 2


def _same_up_to_piston(a, b, atol):
    ok = np.isfinite(a) & np.isfinite(b)
    assert np.array_equal(np.isfinite(a), np.isfinite(b))
    np.testing.assert_allclose(a[ok] - a[ok].mean(), b[ok] - b[ok].mean(), atol=atol)


# --- a profile ----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("bits, z_unit, compressed", [(32, "µm", False), (16, "nm", False), (32, "mm", True)])
def test_a_talysurf_profile_saved_as_sur_reads_as_a_profile(tmp_path, bits, z_unit, compressed):
    z = _trace()
    z[100:103] = np.nan  # three samples the stylus did not measure
    p = write_digital_surf(tmp_path / "trace.sur", z, dx_mm=0.0005, bits=bits, z_unit=z_unit, compressed=compressed)
    m = read_measurement(p)
    assert m.kind == "profile" and m.z_nm.shape == (4000,) and m.dy_mm is None
    assert m.dx_mm == pytest.approx(0.0005, rel=1e-6)
    assert m.params["format"] == "digital-surf" and m.params["acquisition"] == "contact stylus"
    assert m.params["compressed"] is compressed and m.n_nan == 3
    # 16 bits over the trace's span: a step of span / 30000
    _same_up_to_piston(m.z_nm, z, atol=(np.nanmax(z) - np.nanmin(z)) / 30000 if bits == 16 else 1e-4)


def test_a_pro_extension_and_a_comment_zone_are_read(tmp_path):
    z = _trace(512)
    p = write_digital_surf(tmp_path / "trace.pro", z, comment=b"Form Talysurf PGI 1240, 112/2009 stylus")
    _same_up_to_piston(read_measurement(p).z_nm, z, atol=1e-4)


def test_not_measured_points_are_nan_only_when_the_header_says_so(tmp_path):
    z = _trace(256)
    z[10] = np.nan
    assert read_measurement(write_digital_surf(tmp_path / "a.sur", z)).n_nan == 1
    # without the flag the code is a height like any other (as SurfaceTopography reads it)
    assert read_measurement(write_digital_surf(tmp_path / "b.sur", z, nonmeasured=False)).n_nan == 0


def test_psd_command_reads_a_sur_profile(tmp_path):
    from test_bad_input import cli

    p = write_digital_surf(tmp_path / "trace.sur", _trace())
    r = cli("psd", p)
    assert r.returncode == 0, r.stderr
    assert "trace.sur: profile" in r.stdout and "4000" in r.stdout, r.stdout


def test_a_profile_is_refused_as_an_error_map_naming_the_cause_and_the_fix(tmp_path):
    p = write_digital_surf(tmp_path / "trace.sur", _trace())
    with pytest.raises(MeasurementFileError) as err:
        read_error_map(p)
    assert "holds a profile (4000 samples along one line, digital-surf), not a surface map" in err.value.message
    assert "Give a 2D map" in err.value.hint and "[zernike]" in err.value.hint and "polishpath psd" in err.value.hint


def test_the_plan_command_refuses_a_profile_error_map_with_exit_2(tmp_path):
    from test_bad_input import cli, refused

    p = write_digital_surf(tmp_path / "trace.sur", _trace())
    r = cli("plan", "xy-polynomial:radius=6,triangles=900", "--spacing", "0.8", "--seed", "3", "--no-report", "-q",
            "--tif", "gaussian:fwhm=3,peak_rate=2.5", "--error-map", p, "-o", tmp_path / "out")
    refused(r, "holds a profile", "not a surface map", "Give a 2D map")


# --- a surface ------------------------------------------------------------------------------------------------------


def test_a_sur_surface_rows_as_stored_with_its_own_steps(tmp_path, recwarn):
    i, j = np.mgrid[0:20, 0:33]
    z = 5.0 * i + 0.5 * np.sin(j / 2.0)  # heights rise with the file's line number
    p = write_digital_surf(tmp_path / "map.sur", z, dx_mm=0.002, dy_mm=0.003, z_unit="nm", xy_unit="µm")
    m = read_measurement(p)
    assert m.kind == "map" and m.z_nm.shape == (20, 33)
    assert m.dx_mm == pytest.approx(0.002, rel=1e-6) and m.dy_mm == pytest.approx(0.003, rel=1e-6)
    _same_up_to_piston(m.z_nm, z, atol=1e-5)
    e = read_error_map(p)  # not an interferometer's top-first file: the rows stay as stored
    assert e.params["rows"].startswith("as stored") and np.all(np.diff(e.z_nm[:, 4]) > 0)
    assert e.dy_mm == pytest.approx(0.003, rel=1e-6)


@pytest.mark.parametrize("inversion", [1, 2, 3])
def test_an_inverted_or_mirrored_sur_is_turned_back(tmp_path, inversion):
    i, j = np.mgrid[0:12, 0:17]
    z = 3.0 * i + 1.0 * j ** 1.5
    z[0, 0] = np.nan
    m = read_measurement(write_digital_surf(tmp_path / "m.sur", z, z_unit="nm", inversion=inversion))
    _same_up_to_piston(m.z_nm, z, atol=1e-5)


# --- bad files ------------------------------------------------------------------------------------------------------


def _patched(tmp_path, at, fmt, value, **kw):
    import struct

    p = write_digital_surf(tmp_path / "m.sur", _trace(64), **kw)
    raw = bytearray(p.read_bytes())
    struct.pack_into(fmt, raw, at, value)
    p.write_bytes(bytes(raw))
    return p


def _bytes(p, raw):
    p.write_bytes(raw)
    return p


BAD = [
    ("cut in its header", lambda t: _bytes(t / "m.sur", b"DIGITAL SURF" + bytes(88)),
     "fewer than its header alone (512)", "Copy it again"),
    ("cut in its data", lambda t: write_digital_surf(t / "m.sur", _trace(64), truncate=40),
     "the header promises 64 x 1 points of 32 bits", "Is the file complete?"),
    ("a series of profiles", lambda t: write_digital_surf(t / "m.sur", _trace(64), n_objects=3),
     "studiable of type 1 with 3 objects", "one profile or one surface per file"),
    ("a binary image", lambda t: write_digital_surf(t / "m.sur", _trace(64), studiable=3),
     "studiable of type 3", "one profile or one surface per file"),
    ("point count disagreeing", lambda t: _patched(t, 116, "<I", 65),
     "header is inconsistent (64 points x 1 lines but 65 points", "save it again"),
    ("heights in furlongs", lambda t: _patched(t, 212, "16s", b"furlong"),
     "unknown height unit 'furlong'", "metric units"),
    ("a zero z step", lambda t: _patched(t, 128, "<f", 0.0), "its z step is 0.0", "Save the studiable again"),
    ("a Macintosh byte order", lambda t: _patched(t, 12, "<h", 257), "in format 257", "one profile or one surface"),
    ("compressed data damaged", lambda t: _patched(t, 512 + 12 + 4, "<I", 0xDEADBEEF, compressed=True),
     "cannot be unpacked", "Save it again, uncompressed"),
]


@pytest.mark.parametrize("name, make, cause, fix", BAD, ids=[b[0] for b in BAD])
def test_a_bad_sur_is_refused_naming_the_cause_and_the_fix(tmp_path, name, make, cause, fix):
    with pytest.raises(MeasurementFileError) as err:
        read_measurement(make(tmp_path))
    assert cause in err.value.message, err.value.message
    assert err.value.hint and fix in err.value.hint, err.value.hint


def test_the_psd_command_refuses_a_bad_sur_with_exit_2(tmp_path):
    from test_bad_input import cli, refused

    refused(cli("psd", write_digital_surf(tmp_path / "m.sur", _trace(64), n_objects=3)), "3 objects",
            "one profile or one surface per file")


# --- real Digital Surf files, where present beside the repository -------------------------------------------------


def test_real_digital_surf_surface_agrees_with_surfacetopography():
    """SurfaceTopography's sur-3.sur (MIT): 512 x 512 points over 0.151319552 m and an RMS height of
    0.0019200491394179297 m over all points, its test's figures (it reads the not-measured code -2 as a height);
    with the code read as no data (233,009 points) the RMS is 1.1131994 mm."""
    p = SHARED / "sur-3.sur"
    if not p.exists():
        pytest.skip(f"{p} is not present (the steering repository's shared data)")
    raw_rms = 0.0019200491394179297 * 1e9  # nm
    m = read_measurement(p)
    assert m.z_nm.shape == (512, 512) and m.n_nan == 233009
    assert 512 * m.dx_mm == pytest.approx(151.319552, rel=1e-6)  # mm
    z = np.where(np.isnan(m.z_nm), -2 * 1e-9 * 1e9, m.z_nm)  # the code's own height (-2 x the 1 nm step)
    assert np.sqrt(np.mean((z - z.mean()) ** 2)) == pytest.approx(raw_rms, rel=1e-6)
    assert np.nanstd(m.z_nm) == pytest.approx(1.1131994265859693e6, rel=1e-6)
