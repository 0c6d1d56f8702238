"""Bad files of every measurement format (issue 28 item 5): each is refused with an error that names the cause
and the fix (MeasurementFileError, exit 2 on the command line, no traceback), never read as something else.

The damaged files are made from good ones written to the documented layouts (tests/instrument_files.py), with
one field or a few bytes changed.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from instrument_files import write_4d_h5, write_metropro_dat, write_zygo_ascii
from polishpath.errors import MeasurementFileError
from polishpath.psd import read_measurement



def _z():
    i, j = np.mgrid[0:24, 0:31]
    return 20.0 * i / 23 + 3.0 * np.sin(j / 3.0)


def _patched_dat(tmp_path, offset, fmt, value):
    p = write_metropro_dat(tmp_path / "m.dat", _z(), lateral_res_m=1e-4)
    raw = bytearray(p.read_bytes())
    struct.pack_into(fmt, raw, offset, value)
    p.write_bytes(bytes(raw))
    return p


def _asc_lines(tmp_path):
    p = write_zygo_ascii(tmp_path / "m.asc", _z())
    return p, p.read_text().splitlines()


def _asc_edit(tmp_path, edit):
    p, lines = _asc_lines(tmp_path)
    p.write_text("\n".join(edit(lines)) + "\n")
    return p


def _h5(tmp_path, build):
    h5py = pytest.importorskip("h5py")
    p = tmp_path / "m.h5"
    with h5py.File(p, "w") as f:
        build(f)
    return p


def _4d_group(f, wavelength=b"632.8 nm", xpix=None):
    g = f.create_group("measurement0").create_group("genraw")
    g.create_dataset("data", data=np.zeros((8, 8), np.float32))
    if wavelength is not None:
        g.attrs["wavelength"] = wavelength
    if xpix is not None:
        g.attrs["xpix"] = xpix


def _datx(tmp_path, build):
    h5py = pytest.importorskip("h5py")
    p = tmp_path / "m.datx"
    with h5py.File(p, "w") as f:
        build(f, h5py)
    return p


def _datx_surface(f, h5py, unit=b"Fringes", resolution=True):
    ds = f.create_group("Data").create_group("Surface").create_dataset("{0}", data=np.zeros((8, 8)))
    ds.attrs["Unit"] = np.array([unit], dtype=object)
    if resolution:
        g = f.create_group("Attributes").create_group("{1}")
        g.attrs["Data Context.Lateral Resolution:Value"] = np.array([1e-4])
        g.attrs["Data Context.Lateral Resolution:Unit"] = np.array([b"Meters"], dtype=object)


def _text(tmp_path, name, text, encoding="utf-8"):
    p = tmp_path / name
    p.write_bytes(text.encode(encoding) if isinstance(text, str) else text)
    return p


# (name, file maker, words the message must hold, words the fix must hold)
CASES = [
    # --- Zygo MetroPro .dat
    ("dat cut inside its header", lambda t: _text(t, "m.dat", struct.pack(">I", 0x881B036F) + bytes(96)),
     "fewer than its header alone (834)", "Is the file complete"),
    ("dat cut in its phase data", lambda t: write_metropro_dat(t / "m.dat", _z(), truncate=40),
     "the header promises 31 x 24 phase values", "Is the file complete"),
    ("dat with intensity only", lambda t: _dat_no_phase(t),
     "holds no phase (height) data", "Save the measurement with its phase data"),
    ("dat with an unknown phase resolution", lambda t: _patched_dat(t, 218, ">h", 9),
     "unknown phase resolution code 9", "Export it again"),
    ("dat with a zero wavelength", lambda t: _patched_dat(t, 168, ">f", 0.0),
     "the header's wavelength is 0.0", "Export the file again"),
    ("dat whose intensity size disagrees", lambda t: _patched_dat(t, 60, ">i", 123),
     "its MetroPro header is inconsistent", "save the measurement again"),
    ("dat of unknown binary content", lambda t: _text(t, "m.dat", bytes(range(256)) * 8),
     "is a binary file in a format polishpath does not read", "Export the measurement as text"),
    # --- Zygo ASCII
    ("asc whose header lines are broken", lambda t: _asc_edit(t, lambda ls: ls[:7] + ["a b c"] + ls[8:]),
     "its header is not the Zygo ASCII layout", "Export it again from MetroPro"),
    ("asc with letters among the counts", lambda t: _asc_edit(t, lambda ls: ls[:20] + ["12 x3 7"] + ls[21:]),
     "a data block holds something else than whole numbers", "Is the file complete"),
    ("asc without its '#' terminators", lambda t: _asc_edit(t, lambda ls: [x for x in ls if x != "#"][:14]
                                                             + ["#"] + [x for x in ls[15:] if x != "#"]),
     "the data blocks do not end with '#'", "Is the file complete"),
    ("asc with an unknown phase resolution", lambda t: _asc_edit(t, lambda ls: ls[:10] + ["5 0 7 1 60 0 0 0 0"]
                                                                  + ls[11:]),
     "unknown phase resolution code 5", "Export it again"),
    # --- 4D Technology .h5
    ("h5 that is not HDF5", lambda t: _text(t, "m.h5", "measurement0 genraw data\n1 2 3\n"),
     "is not a readable HDF5 file", "Save it again from 4Sight"),
    ("h5 without the 4D surface", lambda t: _h5(t, lambda f: f.create_dataset("other", data=np.zeros(3))),
     "has no measurement0/genraw/data", "Save the measurement from 4Sight"),
    ("h5 without a wavelength", lambda t: _h5(t, lambda f: _4d_group(f, wavelength=None, xpix=b"0.1 mm")),
     "has no wavelength attribute", "Save the file again from 4Sight"),
    ("h5 with an unreadable wavelength", lambda t: _h5(t, lambda f: _4d_group(f, b"six hundred nm", b"0.1 mm")),
     "cannot read the wavelength 'six hundred nm'", "Save the file again from 4Sight"),
    ("h5 with a pixel size in furlongs", lambda t: _h5(t, lambda f: _4d_group(f, xpix=b"0.1 furlong")),
     "unknown unit 'furlong' in the pixel size", "--dx"),
    ("h5 without a pixel size", lambda t: _h5(t, lambda f: _4d_group(f)),
     "does not state its pixel size", "--dx"),
    ("h5 in an unknown height unit", lambda t: _h5(t, lambda f: _4d_units(f, b"furlong")),
     "unknown height unit 'furlong' in measurement0/genraw's height_units", "waves (wv) or nm"),
    ("4D InSight file of several measurements", lambda t: _insight(t, measurements=3),
     "Measurement holds 3 measurements", "one averaged surface measurement per file"),
    ("4D InSight file without a wavelength", lambda t: _insight(t, wavelength_nm=None),
     "WavelengthInNanometers is missing", "Save the file again from 4D InSight"),
    ("h5 of neither 4D layout", lambda t: _h5(t, lambda f: f.create_group("Something")),
     "has no measurement0/genraw/data (the 4Sight surface) and no Measurement/SurfaceInWaves", "as .4D"),
    # --- Zygo .datx
    ("datx that is not HDF5", lambda t: _text(t, "m.datx", "Data Surface\n"),
     "is not a readable HDF5 (.datx) file", "Save it again from Mx"),
    ("datx without a surface", lambda t: _datx(t, lambda f, h: f.create_group("Data").create_group("Intensity")),
     "has no /Data/Surface dataset", "Export the surface"),
    ("datx in fringes without a wavelength", lambda t: _datx(t, _datx_surface),
     "heights are in fringes but the file has no Wavelength", "--height-unit"),
    ("datx without a lateral resolution",
     lambda t: _datx(t, lambda f, h: _datx_surface(f, h, unit=b"NanoMeters", resolution=False)),
     "does not state its lateral resolution", "--dx"),
    # --- profilometer text (Form Talysurf's export) and other text
    ("binary Taylor Hobson .prf", lambda t: _text(t, "trace.prf", b"\x00\x01PRF\x00" + bytes(range(256)) * 4),
     "a Taylor Hobson binary .prf / .mod is not read", "the profile as x z text"),
    ("empty profile", lambda t: _text(t, "trace.txt", "Form Talysurf PGI 1240\nX (mm)\tZ (um)\n"),
     "holds no numeric data", "Give x z, x y z or a grid of heights"),
    ("profile with ragged lines", lambda t: _text(t, "trace.txt", "0 1\n1 2\n2 3 4\n"),
     "rows have different numbers of columns", "Every data line needs the same number of values"),
    ("profile in an unknown unit", lambda t: _text(t, "trace.txt", "X (mm)\tZ (furlong)\n"
                                                   + "".join(f"{i * 0.1}\t{i}\n" for i in range(20))),
     "unknown height unit 'furlong'", "Use one of"),
    ("profile of five samples", lambda t: _text(t, "trace.txt", "".join(f"{i * 0.1} {i}\n" for i in range(5))),
     "a profile needs >= 8 samples with distinct x, got 5", "Give the whole profile"),
    ("profile with text inside the data", lambda t: _text(t, "trace.txt", "0 1\n1 2\nend of data\n2 3\n"),
     "non-numeric line inside the data", "prefix them with '#'"),
]


def _4d_units(f, units):
    _4d_group(f, xpix=b"0.1 mm")
    f["measurement0/genraw"].attrs["height_units"] = units


def _insight(tmp_path, **kw):
    pytest.importorskip("h5py")
    from instrument_files import write_4d_insight

    return write_4d_insight(tmp_path / "m.4D", _z(), pixel_um=50.0, **kw)


def _dat_no_phase(tmp_path):
    """A MetroPro file saved with its intensity frames only: phase width and height 0, no phase bytes."""
    p = write_metropro_dat(tmp_path / "m.dat", _z(), lateral_res_m=1e-4)
    raw = bytearray(p.read_bytes())
    w, h = struct.unpack_from(">HH", raw, 68)
    struct.pack_into(">HHi", raw, 68, 0, 0, 0)
    p.write_bytes(bytes(raw[:len(raw) - 4 * w * h]))
    return p


@pytest.mark.parametrize("name, make, cause, fix", CASES, ids=[c[0] for c in CASES])
def test_a_bad_file_is_refused_naming_the_cause_and_the_fix(tmp_path, name, make, cause, fix):
    p = make(tmp_path)
    with pytest.raises(MeasurementFileError) as err:
        read_measurement(p)
    assert cause in err.value.message, err.value.message
    assert err.value.hint and fix in err.value.hint, err.value.hint


@pytest.mark.parametrize("name", ["dat with an unknown phase resolution", "asc whose header lines are broken",
                                  "h5 that is not HDF5", "datx without a surface", "binary Taylor Hobson .prf"])
def test_the_psd_command_refuses_a_bad_file_with_exit_2(tmp_path, name):
    from test_bad_input import cli, refused

    _, make, cause, fix = next(c for c in CASES if c[0] == name)
    refused(cli("psd", make(tmp_path)), cause, fix)


def test_a_metropro_file_cut_in_its_header_is_refused(tmp_path):
    raw = write_metropro_dat(tmp_path / "whole.dat", np.zeros((48, 64))).read_bytes()
    p = tmp_path / "m.dat"
    p.write_bytes(raw[:500])
    with pytest.raises(MeasurementFileError, match="has 500 bytes, fewer than its header alone"):
        read_measurement(p)


# --- text exports in the encodings Windows instrument software writes -------------------------------------------


@pytest.mark.parametrize("encoding", ["utf-16", "cp1252", "utf-8-sig"])
def test_a_talysurf_text_export_reads_in_windows_encodings(tmp_path, encoding):
    """'Z (µm)' in UTF-16 (with its byte-order mark), Windows-1252 (µ as the byte 0xB5) or UTF-8 with a BOM: the
    unit is read, never refused as binary or mistaken for another unit."""
    x = np.arange(64) * 0.001
    lines = ["Form Talysurf PGI 1240", "X (mm)\tZ (µm)"] + [f"{a:.4f}\t{0.05 * np.sin(a * 300):.6f}" for a in x]
    p = _text(tmp_path, "trace.txt", "\r\n".join(lines) + "\r\n", encoding)
    m = read_measurement(p)
    assert m.kind == "profile" and not m.params["units_assumed"] and m.params["height_unit"] == "µm"
    np.testing.assert_allclose(m.z_nm, 50 * np.sin(x * 300), atol=1e-3)
