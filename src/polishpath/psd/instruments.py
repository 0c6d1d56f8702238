"""Instruments' own files: Zygo MetroPro ``.dat`` (binary) and Zygo ASCII, 4D Technology HDF5 (4Sight
``.h5`` and 4D InSight ``.4D``).

Each reader returns the map's heights in nm, its pixel size in mm and what it
found (``params``), which :func:`polishpath.psd.read_measurement` makes a
:class:`~polishpath.psd.io.Measurement`; invalid pixels are NaN (counted in ``params["n_nan"]``), and
the rows in the file's order: all three store the camera's top row first (the
largest y as the instrument displays the map), as the Zygo ``.datx`` does;
:func:`polishpath.dwell.read_error_map` flips them so that rows go up in y
(``params["rows"] = "top first"`` says so). The layouts follow the formats as
the open readers document them (Zygo's MetroPro Reference Guide, Gwyddion's
``metropro`` module, prysm's ``io``; for 4D, the open FizCam/4Sight readers);
the parsing is written here because none of those is a small, maintained
dependency for reading one array (prysm pulls in its optics stack, Gwyddion is
a C application).

Zygo MetroPro ``.dat`` (big-endian; header formats 1 and 2: 834 bytes, 3: 4096)
    ``magic`` (0x881B036F / 70 / 71) at 0, ``header_format`` int16 at 4,
    ``header_size`` int32 at 6; intensity: width, height, buckets uint16 at 52,
    54, 56, its byte count int32 at 60; phase ("connected") data: width, height
    uint16 at 68, 70, byte count int32 at 72; ``intf_scale_factor`` float32 at
    164, ``wavelength_in`` (m) at 168, ``obliquity_factor`` at 176,
    ``lateral_res`` (m per pixel, 0 when not calibrated) at 184;
    ``phase_res`` int16 at 218 (0, 1, 2: R = 4096, 32768, 131072 counts per
    wave); ``data_sign`` int16 at 232 (1: heights inverted). After the header
    the intensity frames (uint16), then the phase as int32 rows; a count at or
    above 2147483640 is "no data". Height (m) = count x scale factor x
    obliquity x wavelength / R.
Zygo ASCII (``.asc``: MetroPro's "Zygo ASCII Data File - Format 2")
    Fourteen header lines, then ``#``; line 3 the intensity window (origin x,
    y, width, height, buckets, range), line 4 the phase window (origin x, y,
    width, height), line 8 ``source, intf_scale_factor, wavelength_in,
    numeric_aperture, obliquity_factor, magnification, lateral_res,
    time_stamp``, line 11 ``phase_res, phase_avgs, minimum_area_size,
    discon_action, discon_filter, connection_order, remove_tilt_bias,
    data_sign, codev_type`` (``phase_res`` its *first* number and
    ``data_sign`` its eighth, as the header's field list in the MetroPro
    Reference Guide and the open readers have them; a real NewView file's
    line 11 reads ``1 0 7 1 60 0 0 0 0``). The data follow as
    whitespace-separated integer counts: the intensity block, ``#``, the
    phase block (row after row), ``#``; the counts and "no data" as in ``.dat``.
4D Technology HDF5, 4Sight layout (``.h5`` from 4Sight, PhaseCam / AccuFiz)
    The surface in ``measurement0/genraw/data`` (float32), in the group's
    ``height_units`` (``"wv"``: waves; ``nm``, ``um``, ``mm`` taken as
    they say; absent: waves), the wavelength as the group's ``wavelength``
    attribute (text such as ``"632.79998799999998000000 nm"``, or a number of
    nm); pixels without data hold float32's largest value (> 1e38). The
    pixel size is the group's ``xpix`` with its unit (``"0.00711100000000000010
    mm"`` in a real 4Sight 1.8 file); without it give ``dx_mm``. The group's
    ``wedge`` (0.5 for a surface seen in reflection) is reported in
    ``params["wedge"]`` and **not** applied: 4Sight applied it when it made
    the data, and the open readers (opticalib's ``fromPhaseCam4020``, the
    FizCam reader) take heights = data x wavelength; a file saved as OPD
    needs ``[error_map] scale``.
4D Technology HDF5, 4D InSight layout (``.4D``, also PhaseCam 6110)
    The surface in ``Measurement/SurfaceInWaves/Data`` (waves), the
    wavelength as ``Measurement``'s ``WavelengthInNanometers``; pixels
    without data are NaN; the pixel size the first ``PixelSizeInMicrons``
    attribute found under ``Measurement`` (else give ``dx_mm``). A file of
    several measurements (``Measurement/Measurement_<n>``) is refused.
"""

from __future__ import annotations

import re
import struct
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MeasurementFileError, require

#: MetroPro header magic numbers -> header format
ZYGO_MAGIC = {0x881B036F: 1, 0x881B0370: 2, 0x881B0371: 3}
#: phase_res -> counts per wave
ZYGO_PHASE_RES = {0: 4096, 1: 32768, 2: 131072}
#: a phase count at or above this is "no data"
ZYGO_INVALID_PHASE = 2147483640
#: 4D HDF5: a value above this is "no data" (float32's largest, written for masked pixels)
FOURD_INVALID = 1e38

_ROWS = "top first: the file's first row is the map's largest y"


def is_metropro_dat(path: Path) -> bool:
    """Whether ``path`` starts with a MetroPro ``.dat`` magic number."""
    with open(path, "rb") as f:
        head = f.read(4)
    return len(head) == 4 and struct.unpack(">I", head)[0] in ZYGO_MAGIC


def is_zygo_ascii(path: Path) -> bool:
    """Whether ``path`` is a Zygo ASCII data file (its first line says so)."""
    with open(path, "rb") as f:
        head = f.read(64)
    return head.lstrip().startswith(b"Zygo ASCII Data File")


def _heights_from_counts(counts: np.ndarray, scale: float, obliquity: float, wavelength_m: float, phase_res: int,
                         name: str) -> np.ndarray:
    """Phase counts -> heights in nm, "no data" counts -> NaN."""
    if phase_res not in ZYGO_PHASE_RES:
        raise MeasurementFileError(f"{name}: unknown phase resolution code {phase_res} (0, 1 or 2 expected).",
                                   "Is the file complete? Export it again from MetroPro or Mx.")
    for what, v in (("wavelength", wavelength_m), ("interferometric scale factor", scale),
                    ("obliquity factor", obliquity)):
        if not (np.isfinite(v) and v > 0):
            raise MeasurementFileError(f"{name}: the header's {what} is {v!r}, so its heights cannot be scaled.",
                                       "Export the file again from MetroPro or Mx.")
    z = counts.astype(np.float64)
    invalid = counts >= ZYGO_INVALID_PHASE
    z *= scale * obliquity * wavelength_m / ZYGO_PHASE_RES[phase_res] * 1e9
    z[invalid] = np.nan
    return z


def _lateral(res_m: float, dx_mm: float | None, name: str) -> tuple[float, str]:
    if dx_mm is not None:
        return float(dx_mm), "argument"
    if np.isfinite(res_m) and res_m > 0:
        return float(res_m) * 1e3, "lateral_res"
    raise MeasurementFileError(f"{name} does not state its lateral resolution (lateral_res is {res_m!r}).",
                               "Pass the pixel size (dx_mm / --dx / [error_map] dx_mm) in mm.")


def read_metropro_dat(path, dx_mm: float | None = None) -> tuple[np.ndarray, float, dict[str, Any]]:
    """Read a Zygo MetroPro binary ``.dat`` file (layout in the module's docstring).

    Parameters
    ----------
    path : str or Path
    dx_mm : float, optional
        Pixel size, mm, instead of the header's ``lateral_res``.

    Returns
    -------
    z_nm : (height, width) float64
        Heights, nm; NaN where the instrument had no data; the rows as stored (top first).
    dx_mm : float
        Pixel size, mm (square pixels).
    params : dict
        Format, wavelength, phase resolution, where the pixel size came from, NaN count.
    """
    p = Path(path)
    raw = p.read_bytes()
    if len(raw) < 4 or struct.unpack_from(">I", raw, 0)[0] not in ZYGO_MAGIC:
        raise MeasurementFileError(f"{p.name} is not a Zygo MetroPro .dat file (no MetroPro header).",
                                   "A .dat of plain numbers is read as text only when it does not start like one.")
    if len(raw) < 834:
        raise MeasurementFileError(f"{p.name} starts like a Zygo MetroPro .dat but has {len(raw)} bytes, fewer than "
                                   "its header alone (834).", "Is the file complete? Copy it again from the instrument.")
    fmt = ZYGO_MAGIC[struct.unpack_from(">I", raw, 0)[0]]
    hsize = struct.unpack_from(">i", raw, 6)[0]
    iw, ih, nb = struct.unpack_from(">HHH", raw, 52)
    ac_bytes = struct.unpack_from(">i", raw, 60)[0]
    w, h = struct.unpack_from(">HH", raw, 68)
    cn_bytes = struct.unpack_from(">i", raw, 72)[0]
    scale, wl = struct.unpack_from(">ff", raw, 164)
    obliquity = struct.unpack_from(">f", raw, 176)[0]
    res_m = struct.unpack_from(">f", raw, 184)[0]
    phase_res = struct.unpack_from(">h", raw, 218)[0]
    sign = struct.unpack_from(">h", raw, 232)[0]
    if w * h == 0:
        raise MeasurementFileError(f"{p.name} holds no phase (height) data, only intensity.",
                                   "Save the measurement with its phase data in MetroPro.")
    if ac_bytes != 2 * iw * ih * nb or hsize not in (834, 4096):
        raise MeasurementFileError(
            f"{p.name}: its MetroPro header is inconsistent (header size {hsize} bytes, format {fmt}; intensity "
            f"{iw} x {ih} x {nb} frames but {ac_bytes} bytes).",
            "The file is damaged or not a MetroPro .dat: save the measurement again from MetroPro or Mx.")
    start = hsize + ac_bytes
    if cn_bytes != 4 * w * h or start + cn_bytes > len(raw):
        raise MeasurementFileError(
            f"{p.name}: the header promises {w} x {h} phase values ({cn_bytes} bytes) after {start} bytes, "
            f"but the file has {len(raw)} bytes.", "Is the file complete? Copy it again from the instrument.")
    counts = np.frombuffer(raw, dtype=">i4", count=w * h, offset=start).reshape(h, w)
    z = _heights_from_counts(counts, scale, obliquity, wl, phase_res, p.name)
    if sign == 1:
        z = -z
    dx, src = _lateral(res_m, dx_mm, p.name)
    params: dict[str, Any] = {"format": "metropro-dat", "header_format": fmt, "units_assumed": [],
                              "wavelength_nm": float(wl) * 1e9, "phase_res": int(phase_res), "dx_source": src,
                              "n_nan": int(np.isnan(z).sum()), "no_data_value": ZYGO_INVALID_PHASE, "rows": _ROWS}
    return z, dx, params


def _ascii_numbers(line: str) -> list[float]:
    """The numbers of a header line, quoted text left out."""
    return [float(t) for t in re.sub(r'"[^"]*"', " ", line).split()]


def read_zygo_ascii(path, dx_mm: float | None = None) -> tuple[np.ndarray, float, dict[str, Any]]:
    """Read a Zygo ASCII data file (``.asc``; layout in the module's docstring).

    Returns
    -------
    z_nm, dx_mm, params
        As :func:`read_metropro_dat`.
    """
    p = Path(path)
    text = p.read_text(encoding="latin-1")
    lines = text.splitlines()
    if not lines or not lines[0].strip().startswith("Zygo ASCII Data File"):
        raise MeasurementFileError(f"{p.name} is not a Zygo ASCII data file (its first line does not say so).",
                                   "Export it from MetroPro as 'Zygo ASCII Data File', or give it as plain text.")
    try:
        hash_at = next(i for i, ln in enumerate(lines) if ln.strip() == "#")
        head = lines[:hash_at]
        iw, ih, nb = (int(v) for v in _ascii_numbers(head[2])[2:5])
        pw, ph = (int(v) for v in _ascii_numbers(head[3])[2:4])
        src, scale, wl, _na, obliquity, _mag, res_m = _ascii_numbers(head[7])[:7]
        line11 = _ascii_numbers(head[10])
        phase_res, sign = int(line11[0]), int(line11[7])
    except (StopIteration, ValueError, IndexError):
        raise MeasurementFileError(f"{p.name}: its header is not the Zygo ASCII layout (14 lines, then '#').",
                                   "Export it again from MetroPro (File > Save Data As > ASCII).") from None
    blocks = "\n".join(lines[hash_at + 1:]).split("#")
    if len(blocks) < 2:
        raise MeasurementFileError(f"{p.name}: the data blocks do not end with '#' (the intensity block, '#', the "
                                   "phase block, '#').", "Is the file complete? Export it again from MetroPro.")
    try:
        intensity, phase = np.array(blocks[0].split(), dtype=np.int64), np.array(blocks[1].split(), dtype=np.int64)
    except ValueError:
        raise MeasurementFileError(f"{p.name}: a data block holds something else than whole numbers.",
                                   "Is the file complete and unedited?") from None
    if intensity.size != iw * ih * nb or phase.size != pw * ph or phase.size == 0:
        raise MeasurementFileError(
            f"{p.name}: the header promises {pw} x {ph} phase values and {iw * ih * nb} intensity values; the file "
            f"holds {phase.size} and {intensity.size}.", "Is the file complete? Export it again.")
    z = _heights_from_counts(phase.reshape(ph, pw), scale, obliquity, wl, phase_res, p.name)
    if sign == 1:
        z = -z
    dx, srcx = _lateral(res_m, dx_mm, p.name)
    params: dict[str, Any] = {"format": "zygo-ascii", "units_assumed": [], "wavelength_nm": float(wl) * 1e9,
                              "phase_res": phase_res, "dx_source": srcx, "n_nan": int(np.isnan(z).sum()),
                              "no_data_value": ZYGO_INVALID_PHASE, "rows": _ROWS}
    return z, dx, params


def _text_attr(v) -> str:
    a = np.asarray(v).ravel()
    v = a[0] if a.size else v
    return v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v)


def _value_unit_mm(text: str, what: str, name: str, to: dict[str, float]) -> float:
    m = re.match(r"^\s*([-+0-9.eE]+)\s*([A-Za-zµμ]*)\s*$", text)
    fix = "Save the file again from 4Sight, or give the value (--dx for the pixel size)."
    if not m:
        raise MeasurementFileError(f"{name}: cannot read the {what} {text!r} (a number and a unit expected).", fix)
    unit = (m.group(2) or "").lower().replace("μ", "µ")
    if unit not in to:
        raise MeasurementFileError(f"{name}: unknown unit {m.group(2)!r} in the {what} {text!r} "
                                   f"(known: {', '.join(sorted(u for u in to if u))}).", fix)
    try:
        return float(m.group(1)) * to[unit]
    except ValueError:
        raise MeasurementFileError(f"{name}: cannot read the {what} {text!r} (a number and a unit expected).",
                                   fix) from None


#: 4Sight ``height_units`` -> nm per unit (``None``: waves, times the file's wavelength)
FOURD_HEIGHT_UNITS = {"wv": None, "waves": None, "wave": None, "": None, "nm": 1.0, "um": 1e3, "µm": 1e3,
                      "mm": 1e6}


def _first_attr(group, name: str):
    """The first ``name`` attribute on ``group`` or any group or dataset below it (None if none has it)."""
    if name in group.attrs:
        return group.attrs[name]
    found = []

    def visit(_key, obj):
        if name in obj.attrs:
            found.append(obj.attrs[name])
            return True
        return None

    group.visititems(visit)
    return found[0] if found else None


def _4sight(f, name: str) -> tuple[np.ndarray, float, float | None, dict[str, Any]]:
    """The 4Sight layout: (waves-or-units data, nm per data unit, dx_mm from xpix or None, params)."""
    g = f["measurement0/genraw"]
    z = np.array(g["data"][()], dtype=np.float64)
    if "wavelength" not in g.attrs:
        raise MeasurementFileError(f"{name}: measurement0/genraw has no wavelength attribute, so its waves "
                                   "cannot be turned into nm.", "Save the file again from 4Sight.")
    wl = g.attrs["wavelength"]
    wl_nm = (_value_unit_mm(_text_attr(wl), "wavelength", name, {"nm": 1.0, "": 1.0, "um": 1e3, "µm": 1e3})
             if isinstance(np.asarray(wl).ravel()[0], (bytes, str)) else float(np.asarray(wl).ravel()[0]))
    if not (np.isfinite(wl_nm) and wl_nm > 0):
        raise MeasurementFileError(f"{name}: the wavelength is {wl_nm!r} nm.", "Save the file again from 4Sight.")
    units = _text_attr(g.attrs["height_units"]).strip() if "height_units" in g.attrs else ""
    key = units.lower().replace("μ", "µ")
    if key not in FOURD_HEIGHT_UNITS:
        raise MeasurementFileError(f"{name}: unknown height unit {units!r} in measurement0/genraw's height_units "
                                   f"(known: {', '.join(sorted(k for k in FOURD_HEIGHT_UNITS if k))}).",
                                   "Save the surface from 4Sight in waves (wv) or nm.")
    per_unit = FOURD_HEIGHT_UNITS[key]
    dx = None
    if "xpix" in g.attrs:
        dx = _value_unit_mm(_text_attr(g.attrs["xpix"]), "pixel size (xpix)", name,
                            {"mm": 1.0, "um": 1e-3, "µm": 1e-3, "m": 1e3})
    params: dict[str, Any] = {"format": "4d-h5", "layout": "4Sight measurement0/genraw", "wavelength_nm": wl_nm,
                              "height_units": units or "wv (assumed: no height_units)"}
    if "wedge" in g.attrs:
        params["wedge"] = float(np.asarray(g.attrs["wedge"]).ravel()[0])
    if "4D" in f and "_4Sight_version" in f["4D"].attrs:
        params["software"] = "4Sight " + _text_attr(f["4D"].attrs["_4Sight_version"])
    return z, (wl_nm if per_unit is None else per_unit), dx, params


def _insight(f, name: str) -> tuple[np.ndarray, float, float | None, dict[str, Any]]:
    """The 4D InSight ``.4D`` layout: (waves, nm per wave, dx_mm from PixelSizeInMicrons or None, params)."""
    g = f["Measurement"]
    if "SurfaceInWaves" not in g:
        n = sum(1 for k in g if k.startswith("Measurement_"))
        raise MeasurementFileError(
            f"{name}: Measurement holds {n} measurements (Measurement_<n>), not one surface." if n else
            f"{name}: Measurement has no SurfaceInWaves (the 4D InSight surface).",
            "Save one averaged surface measurement per file from 4D InSight.")
    z = np.array(g["SurfaceInWaves/Data"][()], dtype=np.float64)
    wl = g.attrs.get("WavelengthInNanometers")
    wl_nm = float(np.asarray(wl).ravel()[0]) if wl is not None else float("nan")
    if not (np.isfinite(wl_nm) and wl_nm > 0):
        raise MeasurementFileError(f"{name}: Measurement's WavelengthInNanometers is "
                                   f"{'missing' if wl is None else repr(wl_nm)}, so its waves cannot be turned into "
                                   "nm.", "Save the file again from 4D InSight.")
    pix_um = _first_attr(g, "PixelSizeInMicrons")
    dx = None
    if pix_um is not None:
        dx = float(np.asarray(pix_um).ravel()[0]) * 1e-3
        if not (np.isfinite(dx) and dx > 0):
            dx = None
    params: dict[str, Any] = {"format": "4d-h5", "layout": "4D InSight Measurement/SurfaceInWaves",
                              "wavelength_nm": wl_nm, "height_units": "waves"}
    return z, wl_nm, dx, params


def read_4d_h5(path, dx_mm: float | None = None) -> tuple[np.ndarray, float, dict[str, Any]]:
    """Read a 4D Technology HDF5 file: 4Sight ``.h5`` or 4D InSight ``.4D`` (layouts in the module's docstring).

    Parameters
    ----------
    path : str or Path
    dx_mm : float, optional
        Pixel size, mm, instead of the file's (``xpix`` / ``PixelSizeInMicrons``).

    Returns
    -------
    z_nm : (height, width) float64
        Heights, nm (data x the file's wavelength, or x its ``height_units``); NaN where 4D had no data; the
        rows as stored (top first).
    dx_mm : float
        Pixel size, mm.
    params : dict
        Format and layout, wavelength, height units, ``wedge`` (reported, not applied), where the pixel size
        came from, NaN count.
    """
    h5py = require("h5py", "reading 4D Technology .h5 / .4D files", extra="zygo")
    p = Path(path)
    try:
        f = h5py.File(p, "r")
    except OSError as exc:
        raise MeasurementFileError(f"{p.name} is not a readable HDF5 file ({exc}).",
                                   "Is the file complete? Save it again from 4Sight as .h5, or give the map as "
                                   "text.") from None
    with f:
        if "measurement0/genraw/data" in f:
            z, nm_per, dx_file, params = _4sight(f, p.name)
        elif "Measurement" in f and isinstance(f["Measurement"], h5py.Group):
            z, nm_per, dx_file, params = _insight(f, p.name)
        else:
            raise MeasurementFileError(f"{p.name} has no measurement0/genraw/data (the 4Sight surface) and no "
                                       "Measurement/SurfaceInWaves (4D InSight's).",
                                       "Save the measurement from 4Sight as .h5 (or 4D InSight as .4D) with its "
                                       "surface data.")
    if z.ndim != 2 or min(z.shape) < 2:
        raise MeasurementFileError(f"{p.name}: the 4D surface is not a 2D map (shape {z.shape}).",
                                   "Save one surface measurement per file from 4Sight.")
    invalid = ~(np.abs(z) < FOURD_INVALID)  # the sentinel, and NaN as written
    n_inf = int(np.isinf(z).sum())
    z = z * nm_per
    z[invalid] = np.nan
    if dx_mm is not None:
        dx, src = float(dx_mm), "argument"
    elif dx_file is not None:
        dx, src = dx_file, ("xpix" if params["layout"].startswith("4Sight") else "PixelSizeInMicrons")
    else:
        raise MeasurementFileError(f"{p.name} does not state its pixel size.",
                                   "Pass the pixel size (dx_mm / --dx / [error_map] dx_mm) in mm.")
    params.update({"units_assumed": [], "dx_source": src, "n_nan": int(np.isnan(z).sum()),
                   "no_data_value": FOURD_INVALID, "rows": _ROWS, "infinite_as_no_data": n_inf})
    return z, dx, params


# --- Digital Surf .sur / .pro (what Taylor Hobson's TalyMap / TalyProfile, Mountains-based, save) -------------

#: Digital Surf magic numbers -> compressed data
SUR_MAGIC = {b"DIGITAL SURF": False, b"DSCOMPRESSED": True}
#: Digital Surf studiable types read here
SUR_PROFILE, SUR_SURFACE = 1, 2
#: Digital Surf acquisition types (the header's code), for ``params["acquisition"]``
SUR_ACQUISITION = {0: "unknown", 1: "contact stylus", 2: "scanning optical gauge", 3: "thermocouple", 4: "unknown",
                   5: "contact stylus with skid", 6: "AFM", 7: "STM", 8: "video", 9: "interferometer",
                   10: "structured light projection"}
_SUR_UNITS_M = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "nm": 1e-9, "a": 1e-10, "å": 1e-10, "pm": 1e-12}


def is_digital_surf(path: Path) -> bool:
    """Whether ``path`` starts with a Digital Surf magic (``DIGITAL SURF`` / ``DSCOMPRESSED``)."""
    with open(path, "rb") as f:
        return f.read(12) in SUR_MAGIC


def _sur_text(raw: bytes, at: int, n: int) -> str:
    return raw[at:at + n].split(b"\0")[0].decode("latin-1").strip()


def _sur_unit_m(unit: str, what: str, name: str) -> float:
    u = unit.strip().lower().replace("μ", "µ").replace("\u00b5", "µ")
    if u not in _SUR_UNITS_M:
        raise MeasurementFileError(f"{name}: unknown {what} unit {unit!r} in its Digital Surf header "
                                   f"(known: {', '.join(sorted(_SUR_UNITS_M))}).",
                                   "Save the studiable again from TalyMap / Mountains in metric units.")
    return _SUR_UNITS_M[u]


def read_digital_surf(path, dx_mm: float | None = None) -> tuple[np.ndarray, float, dict[str, Any]]:
    """Read a Digital Surf ``.sur`` / ``.pro`` file: one profile or one surface.

    The layout, as Gwyddion's ``surffile`` module and SurfaceTopography's ``SUR`` reader document it (and
    surfalize for the compressed form and the no-data code): a 512-byte little-endian header, then a comment
    and a private zone of the sizes it gives, then the points as int16 or int32, line after line (x fastest).
    Header fields by byte offset: magic ``DIGITAL SURF`` (or ``DSCOMPRESSED``) at 0, format int16 at 12 (0: PC),
    object count uint16 at 14, version at 16, studiable type at 18 (1 profile, 2 surface), object and operator
    names (30 characters) at 20 and 50, acquisition type at 82, "non-measured points" flag at 86, bits per point
    at 98 (16 or 32), smallest and largest point int32 at 100 and 104, points per line and lines int32 at 108
    and 112, total points at 116, x, y, z steps float32 at 120, 124, 128, the axis names at 132, 148, 164 and the
    step units (16 characters) at 180 (x), 196 (y), 212 (z), the inversion code uint16 at 290 (1 z inverted;
    2 and 3 also mirrored in x or y), compressed data size uint32 at 324, comment and private zone sizes uint16
    at 334 and 336, the z offset float32 at 474. Height = point x z step in the z step unit; a point equal to
    the smallest point - 2 is "not measured" when the flag is 1. The z offset is a constant (piston) and is
    left out (reported in ``params``).

    Parameters
    ----------
    path : str or Path
    dx_mm : float, optional
        Sampling interval / pixel width, mm, instead of the header's x step.

    Returns
    -------
    z_nm : (n,) or (lines, points) float64
        Heights, nm: a profile (one line) as a 1D array, a surface as a 2D array with the file's first line as
        row 0; NaN where the instrument measured nothing.
    dx_mm : float
        Sampling interval along x, mm.
    params : dict
        ``format`` "digital-surf", ``kind`` ("profile" / "map"), ``dy_mm`` for a surface, the acquisition type,
        object name, units, NaN count, inversion applied.
    """
    import zlib

    p = Path(path)
    raw = p.read_bytes()
    magic = raw[:12]
    if magic not in SUR_MAGIC:
        raise MeasurementFileError(f"{p.name} is not a Digital Surf file (no 'DIGITAL SURF' header).",
                                   "Save the studiable from TalyMap / TalyProfile / Mountains as .sur.")
    if len(raw) < 512:
        raise MeasurementFileError(f"{p.name} starts like a Digital Surf file but has {len(raw)} bytes, fewer than its "
                                   "header alone (512).", "Is the file complete? Copy it again.")
    fmt, n_obj, _version, stype = struct.unpack_from("<hHhh", raw, 12)
    acq, = struct.unpack_from("<h", raw, 82)
    nonmeasured, = struct.unpack_from("<h", raw, 86)
    bits, = struct.unpack_from("<h", raw, 98)
    zmin, _zmax, nx, ny, npts = struct.unpack_from("<iiiiI", raw, 100)
    sx, sy, sz = struct.unpack_from("<fff", raw, 120)
    ux, uy, uz = (_sur_text(raw, o, 16) for o in (180, 196, 212))
    inversion, = struct.unpack_from("<H", raw, 290)
    zipped, = struct.unpack_from("<I", raw, 324)
    n_comment, n_private = struct.unpack_from("<HH", raw, 334)
    z_offset, = struct.unpack_from("<f", raw, 474)
    fix = "Save one profile or one surface per file from TalyMap / TalyProfile / Mountains (.sur)."
    if fmt != 0:
        raise MeasurementFileError(f"{p.name}: a Digital Surf file in format {fmt} (0, the PC byte order, expected).",
                                   fix)
    if n_obj > 1 or stype not in (SUR_PROFILE, SUR_SURFACE):
        raise MeasurementFileError(f"{p.name} holds a Digital Surf studiable of type {stype} with {n_obj} objects "
                                   "(one profile, type 1, or one surface, type 2, is read).", fix)
    if bits not in (16, 32) or nx < 1 or ny < 1 or npts != nx * ny:
        raise MeasurementFileError(
            f"{p.name}: its Digital Surf header is inconsistent ({nx} points x {ny} lines but {npts} points, "
            f"{bits} bits a point).", "The file is damaged: save it again from TalyMap / Mountains.")
    start = 512 + n_comment + n_private
    dtype = np.dtype("<i2" if bits == 16 else "<i4")
    if SUR_MAGIC[magic]:
        try:
            n_dir, = struct.unpack_from("<I", raw, start)
            dirs = [struct.unpack_from("<II", raw, start + 4 + 8 * k) for k in range(n_dir)]
            at, chunks = start + 4 + 8 * n_dir, []
            for size_raw, size_zip in dirs:
                chunk = zlib.decompress(raw[at:at + size_zip])
                if len(chunk) != size_raw:
                    raise ValueError
                chunks.append(chunk)
                at += size_zip
            data = b"".join(chunks)
        except (struct.error, zlib.error, ValueError):
            raise MeasurementFileError(f"{p.name}: its compressed Digital Surf data ({zipped} bytes) cannot be "
                                       "unpacked.", "Is the file complete? Save it again, uncompressed.") from None
    else:
        data = raw[start:]
    if len(data) < npts * dtype.itemsize:
        raise MeasurementFileError(
            f"{p.name}: the header promises {nx} x {ny} points of {bits} bits after {start} bytes, but the file holds "
            f"{len(data)} bytes of data.", "Is the file complete? Copy it again.")
    counts = np.frombuffer(data, dtype=dtype, count=npts).reshape(ny, nx)
    to_nm = _sur_unit_m(uz, "height", p.name) * 1e9
    if not (np.isfinite(sz) and sz != 0):
        raise MeasurementFileError(f"{p.name}: its z step is {sz!r}, so its points cannot be scaled to heights.",
                                   "Save the studiable again from TalyMap / Mountains.")
    z = counts.astype(np.float64) * (float(sz) * to_nm)
    if nonmeasured == 1:
        z[counts == zmin - 2] = np.nan
    if inversion in (1, 2, 3):
        z = -z
        if inversion == 2:
            z = z[:, ::-1]
        elif inversion == 3:
            z = z[::-1]
    if dx_mm is not None:
        dx, src = float(dx_mm), "argument"
    else:
        dx, src = float(sx) * _sur_unit_m(ux, "x step", p.name) * 1e3, "header"
    kind = "profile" if ny == 1 else "map"
    params: dict[str, Any] = {
        "format": "digital-surf", "kind": kind, "units_assumed": [], "dx_source": src,
        "studiable_type": "profile" if stype == SUR_PROFILE else "surface",
        "acquisition": SUR_ACQUISITION.get(acq, f"code {acq}"), "object": _sur_text(raw, 20, 30),
        "operator": _sur_text(raw, 50, 30), "units": {"x": ux, "y": uy, "z": uz}, "compressed": SUR_MAGIC[magic],
        "z_offset_left_out": float(z_offset), "inversion": int(inversion),
        "no_data_value": (zmin - 2) if nonmeasured == 1 else None,
        "rows": "as stored: the file's first line is row 0 (Digital Surf does not say which edge it is)"}
    if kind == "map":
        params["dy_mm"] = float(sy) * _sur_unit_m(uy, "y step", p.name) * 1e3 if dx_mm is None else float(dx_mm)
        out = z
    else:
        out = z[0]
    params["n_nan"] = int(np.isnan(out).sum())
    return out, dx, params
