"""Reading measured profiles and maps: plain text, CSV, Zygo ``.datx`` (and, through
:mod:`polishpath.psd.instruments`, Zygo MetroPro ``.dat`` / ASCII, 4D Technology ``.h5`` / ``.4D`` and Digital
Surf ``.sur`` / ``.pro``, what Taylor Hobson's TalyMap / TalyProfile save).

Everything is converted to nanometres (heights) and millimetres (lateral).
Units come from the file when it says them (a ``# units`` comment, a column
header such as ``x_mm,z_um`` or ``x [mm]``, the .datx converters) or from the
caller; when neither says, mm / nm are *assumed* and ``params["units_assumed"]``
says so.
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import progress
from ..errors import MeasurementFileError, require
from . import instruments

#: formats that store the top row (the map's largest y) first: the error-map reader flips them (a Digital Surf
#: ``.sur`` is not among them: its layout does not say which edge its first line is, so its rows stay as stored)
TOP_ROW_FIRST = ("datx", "metropro-dat", "zygo-ascii", "4d-h5")

_TO_MM = {"m": 1e3, "mm": 1.0, "um": 1e-3, "µm": 1e-3, "micron": 1e-3, "nm": 1e-6}
_TO_NM = {"m": 1e9, "mm": 1e6, "um": 1e3, "µm": 1e3, "micron": 1e3, "nm": 1.0, "a": 0.1, "angstrom": 0.1}
_ZYGO_UNITS = {"meters": "m", "millimeters": "mm", "milimeters": "mm", "micrometers": "um",
               "microns": "um", "nanometers": "nm", "angstroms": "angstrom"}


@dataclass(frozen=True)
class Measurement:
    """A measured profile or height map, in nm and mm.

    Attributes
    ----------
    z_nm : (N,) or (Ny, Nx) float64
        Heights, nm; NaN where the instrument had no data.
    dx_mm : float
        Sampling interval along x (profile) or pixel width, mm.
    dy_mm : float or None
        Pixel height for maps, mm; None for profiles.
    kind : str
        ``"profile"`` or ``"map"``.
    source : str
        File it was read from.
    params : dict
        Format, units found or assumed, NaN count, resampling done.
    """

    z_nm: np.ndarray
    dx_mm: float
    dy_mm: float | None = None
    kind: str = "profile"
    source: str = ""
    params: dict[str, Any] = field(default_factory=dict)

    @property
    def n_nan(self) -> int:
        """Number of missing samples."""
        return int((~np.isfinite(self.z_nm)).sum())


def _unit_factor(unit: str, table: dict[str, float], what: str) -> float:
    u = unit.strip().lower().replace("μ", "µ")
    u = _ZYGO_UNITS.get(u, u)
    if u not in table:
        raise MeasurementFileError(f"unknown {what} unit {unit!r}.", f"Use one of {sorted(table)}.")
    return table[u]


def _header_units(lines: list[str]) -> dict[str, str]:
    """``# lateral_unit: um`` / ``# height_unit: nm`` / ``# dx: 0.5 um`` comments."""
    out = {}
    for ln in lines:
        m = re.match(r"^\s*[#%;]\s*([A-Za-z_ ]+?)\s*[:=]\s*(.+?)\s*$", ln)
        if m:
            out[m.group(1).strip().lower().replace(" ", "_")] = m.group(2)
    return out


def _col_unit(name: str) -> str | None:
    m = re.search(r"[\[(]\s*([A-Za-zµμ]+)\s*[\])]|_([A-Za-zµμ]+)$", name.strip())
    if not m:
        return None
    return m.group(1) or m.group(2)


def read_measurement(file, *, lateral_unit: str | None = None, height_unit: str | None = None,
                     dx_mm: float | None = None, dy_mm: float | None = None) -> Measurement:
    """Read a measured profile or surface map.

    Parameters
    ----------
    file : str or Path
        ``.datx`` (Zygo HDF5, needs h5py), a Zygo MetroPro binary ``.dat``, a Zygo ASCII ``.asc``,
        a 4D Technology ``.h5`` (see :mod:`polishpath.psd.instruments`), ``.csv``, or plain text
        (``.txt``/``.dat``/``.xyz``/``.asc``/``.prf``/other). Text layouts, by column count:
        2 columns ``x z`` = profile; 3 columns ``x y z`` = point list on a
        regular grid; more columns = a grid of heights (one row per line, needs
        ``dx_mm`` or a ``# dx: <value> <unit>`` comment).
    lateral_unit, height_unit : str, optional
        Units of x/y and z in the file (``"m"``, ``"mm"``, ``"um"``, ``"nm"``);
        override what the file says. Default: from the file, else mm and nm (assumed).
    dx_mm, dy_mm : float, optional
        Sampling for grid files without coordinates, mm.

    Returns
    -------
    Measurement

    Raises
    ------
    MeasurementFileError
        Missing file, unknown layout or units, scattered points that are not on a grid.
    """
    path = Path(file)
    if not path.exists():
        raise MeasurementFileError(f"measurement file {str(path)!r} does not exist.", "Check the path.")
    for what, unit, table in (("lateral", lateral_unit, _TO_MM), ("height", height_unit, _TO_NM)):
        if unit is not None:
            _unit_factor(unit, table, what)  # an unknown unit is refused before reading
    for name, v in (("dx_mm", dx_mm), ("dy_mm", dy_mm)):
        _check_spacing(v, name, "the argument")
    suffix = path.suffix.lower()
    if path.is_file() and instruments.is_digital_surf(path):  # .sur / .pro (TalyMap, TalyProfile, Mountains)
        z, dx, params = instruments.read_digital_surf(path, dx_mm=dx_mm)
        kind = params.pop("kind")
        m = Measurement(z, dx, params.pop("dy_mm", None), kind, str(path), params)
        if height_unit is not None or lateral_unit is not None:
            progress.warn(f"{path.name} states its own units (Digital Surf header): the unit options are not used "
                          "for it.")
    elif suffix == ".datx":
        m = _read_datx(path, dx_mm=dx_mm, lateral_unit=lateral_unit, height_unit=height_unit)
    elif (suffix == ".dat" and instruments.is_metropro_dat(path)) or (suffix == ".asc" and instruments.is_zygo_ascii(path)) \
            or suffix in (".h5", ".hdf5", ".4d"):
        read = {".dat": instruments.read_metropro_dat, ".asc": instruments.read_zygo_ascii}.get(suffix,
                                                                                              instruments.read_4d_h5)
        z, dx, params = read(path, dx_mm=dx_mm)
        m = Measurement(z, dx, dx, "map", str(path), params)
        if height_unit is not None or lateral_unit is not None:
            progress.warn(f"{path.name} states its own units ({m.params['format']}: heights from the wavelength, "
                          "pixel size from the header): the unit options are not used for it.")
    else:
        text = _text_of(path)
        m = _read_text(text, str(path), csv_like=path.suffix.lower() == ".csv", lateral_unit=lateral_unit,
                       height_unit=height_unit, dx_mm=dx_mm, dy_mm=dy_mm)
    check_heights(m.z_nm, path.name)
    _check_spacing(m.dx_mm, "the sampling interval", path.name)
    if m.dy_mm is not None:
        _check_spacing(m.dy_mm, "the pixel height", path.name)
    _say_what_was_assumed(m, path)
    return m


def _text_of(path: Path) -> str:
    """The file's text: UTF-16 when it starts with its byte-order mark, else UTF-8, else Windows-1252 (the
    encodings Windows instrument software exports in).

    A file with NUL bytes at its start and no UTF-16 mark is no text layout: it is refused naming the formats
    read (a Taylor Hobson binary ``.prf`` / ``.mod``, a MetroPro ``.dat`` under another name ...) instead of
    a confusing parse error.
    """
    raw = path.read_bytes()
    if raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        return raw.decode("utf-16", errors="replace")
    if b"\0" in raw[:4096]:
        raise MeasurementFileError(
            f"{path.name} is a binary file in a format polishpath does not read (read: Zygo .datx, MetroPro .dat, "
            "Zygo ASCII .asc, 4D .h5 / .4D, Digital Surf .sur / .pro, and text or CSV profiles and maps; a Taylor "
            "Hobson binary .prf / .mod is not read: its layout is not published).",
            "Export the measurement as text from the instrument's software (Form Talysurf: the profile as x z "
            "text, or as a .sur from TalyProfile / TalyMap), or give a binary Zygo / 4D file its own extension "
            "(.dat, .datx, .h5, .4D).")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:  # Windows software writes its code page: 'Z (µm)' with µ as the byte 0xB5
        return raw.decode("cp1252", errors="replace")


def _check_spacing(v: float | None, what: str, where: str) -> None:
    """A spacing (mm) that is given must be finite and > 0: a zero or NaN pixel size is refused, named."""
    if v is not None and not (isinstance(v, (int, float, np.floating)) and np.isfinite(v) and v > 0):
        raise MeasurementFileError(f"{where}: {what} must be a positive number of mm, got {v!r}.",
                                   "Give the pixel size (dx_mm / '# dx: 0.005 mm', --dx) as a positive length.")


def check_heights(z: np.ndarray, name: str, what: str = "height") -> int:
    """Refuse infinite values in a measured array; return how many are NaN (no data).

    An interferometer marks the pixels it could not measure (outside its
    aperture, dropouts) as NaN or a "no data" sentinel, read as NaN: those are
    kept as missing data and counted. An infinite value is never a
    measurement: :class:`MeasurementFileError` names the count, the first
    position and what to do.

    Parameters
    ----------
    z : (N,) or (Ny, Nx) float64
        Heights (any unit).
    name : str
        The file's name, for the message.
    """
    bad = np.isinf(z)
    n = int(bad.sum())
    if n:
        first = tuple(int(i) for i in np.argwhere(bad)[0])
        at = f"row {first[0]}, column {first[1]}" if len(first) == 2 else f"sample {first[0]}"
        raise MeasurementFileError(
            f"{name}: {n} of {z.size} {what} values are infinite (the first at {at}).",
            "An infinite value is not a measurement: write NaN (no data) where the instrument measured nothing, "
            "or export the file again from the instrument's software.")
    return int(np.isnan(z).sum())


def _say_what_was_assumed(m: Measurement, path: Path) -> None:
    """Warn on stderr for every unit taken as a default and for any resampling (never silently)."""
    assumed = m.params.get("units_assumed") or []
    if assumed:
        opts = " / ".join(("--lateral-unit" if "lateral" in a else "--height-unit") for a in assumed)
        progress.warn(f"{path.name} does not say its units: assumed {' and '.join(assumed)}. "
                      f"If that is wrong, pass {opts} (m, mm, um, nm).")
    if m.params.get("resampled"):
        progress.warn(f"{path.name}: {m.params['resampled']}.")
    if m.n_nan:
        what = "pixels" if m.kind == "map" else "samples"
        marked = "NaN or the file's no-data value" if m.params.get("no_data_value") is not None else "NaN"
        progress.warn(f"{path.name}: {m.n_nan} of {m.z_nm.size} {what} have no data ({marked}): "
                      "kept as missing, never as zero height (the error map's coverage check, the TIF reader or the "
                      "PSD's --nan policy decides what is done with them).")


def _parse_rows(text: str, csv_like: bool):
    comments, header, rows = [], None, []
    delim = None
    for ln in text.splitlines():
        s = ln.strip()
        if not s:
            continue
        if s[0] in "#%;":
            comments.append(s)
            continue
        if delim is None:
            delim = "," if ("," in s and (csv_like or s.count(",") >= 1)) else (";" if ";" in s else "\t" if "\t" in s else None)
        parts = next(csv.reader(io.StringIO(s), delimiter=delim)) if delim else s.split()
        parts = [p.strip() for p in parts if p.strip() != ""]
        vals = []
        numeric = True
        for p in parts:
            try:
                vals.append(float(p))
            except ValueError:
                if p.lower() in ("nan", "na", "", "no data", "-", "*"):
                    vals.append(np.nan)
                else:
                    numeric = False
                    break
        if not numeric:
            if rows:
                raise MeasurementFileError(f"non-numeric line inside the data: {s[:60]!r}.",
                                           "Keep header lines at the top or prefix them with '#'.")
            header = parts
            continue
        rows.append(vals)
    return comments, header, rows


def _read_text(text, source, *, csv_like, lateral_unit, height_unit, dx_mm, dy_mm) -> Measurement:
    comments, header, rows = _parse_rows(text, csv_like)
    if not rows:
        raise MeasurementFileError(f"{source!r} holds no numeric data.", "Give x z, x y z or a grid of heights.")
    ncols = {len(r) for r in rows}
    if len(ncols) != 1:
        raise MeasurementFileError(f"{source!r}: rows have different numbers of columns {sorted(ncols)}.",
                                   "Every data line needs the same number of values.")
    data = np.array(rows, dtype=np.float64)
    meta = _header_units(comments)
    assumed = []
    lu = lateral_unit or meta.get("lateral_unit") or meta.get("xy_unit") or meta.get("x_unit")
    hu = height_unit or meta.get("height_unit") or meta.get("z_unit")
    if header and not lu:
        lu = _col_unit(header[0])
    if header and not hu:
        hu = _col_unit(header[-1])
    if not lu:
        lu, _ = "mm", assumed.append("lateral unit mm")
    if not hu:
        hu, _ = "nm", assumed.append("height unit nm")
    kx = _unit_factor(lu, _TO_MM, "lateral")
    kz = _unit_factor(hu, _TO_NM, "height")
    params: dict[str, Any] = {"format": "csv" if csv_like else "text", "lateral_unit": lu, "height_unit": hu,
                              "units_assumed": assumed, "header": header}
    nc = data.shape[1]
    if nc == 2:
        x = data[:, 0] * kx
        z = data[:, 1] * kz
        _finite_coordinates(source, x=x)
        order = np.argsort(x)
        x, z = x[order], z[order]
        d = np.diff(x)
        if len(x) < 8 or (d <= 0).any():
            raise MeasurementFileError(f"{source!r}: a profile needs >= 8 samples with distinct x, got {len(x)} "
                                       f"samples{' with repeated x' if len(x) >= 8 else ''}.",
                                       "Give the whole profile as x z lines, one sample a line, x increasing.")
        step = float(np.median(d))
        if np.max(np.abs(d - step)) > 1e-3 * step:
            xs = x[0] + step * np.arange(int(round((x[-1] - x[0]) / step)) + 1)
            z = np.interp(xs, x, z)  # NaN samples stay NaN where they touch the interpolant
            params["resampled"] = (f"x is not uniformly spaced (steps {d.min():.4g} to {d.max():.4g} mm): resampled "
                                   f"linearly to a {step:.4g} mm grid of {len(xs)} points")
        params["n_nan"] = int(np.isnan(z).sum())
        return Measurement(z, step, None, "profile", source, params)
    if nc == 3:
        x, y, z = data[:, 0] * kx, data[:, 1] * kx, data[:, 2] * kz
        _finite_coordinates(source, x=x, y=y)
        ux, uy = np.unique(np.round(x, 9)), np.unique(np.round(y, 9))
        if len(ux) * len(uy) > 2 * len(x) or len(ux) < 8 or len(uy) < 8:
            raise MeasurementFileError(
                f"{source!r}: the x y z points are not on a regular grid ({len(ux)} x values, {len(uy)} y values, "
                f"{len(x)} points).", "Export the map as a regular grid (most instrument software can).")
        ddx, ddy = np.diff(ux), np.diff(uy)
        sx, sy = float(np.median(ddx)), float(np.median(ddy))
        if np.max(np.abs(ddx - sx)) > 1e-3 * sx or np.max(np.abs(ddy - sy)) > 1e-3 * sy:
            raise MeasurementFileError(f"{source!r}: grid spacing is not uniform.", "Resample to a uniform grid.")
        grid = np.full((len(uy), len(ux)), np.nan)  # grid nodes without a point stay NaN (counted)
        ix = np.searchsorted(ux, np.round(x, 9))
        iy = np.searchsorted(uy, np.round(y, 9))
        grid[iy, ix] = z
        params["n_nan"] = int(np.isnan(grid).sum())
        params["layout"] = "x y z points"
        params["origin_mm"] = [float(ux[0]), float(uy[0])]  # the map's own coordinates (figuring aligns with them)
        return Measurement(grid, sx, sy, "map", source, params)
    # grid of heights
    dxv = dx_mm
    if dxv is None and "dx" in meta:
        dxv = _value_with_unit(meta["dx"])
    if dxv is None:
        raise MeasurementFileError(f"{source!r} is a grid of heights without coordinates.",
                                   "Pass dx_mm (pixel size in mm) or add a '# dx: 0.005 mm' comment line.")
    dyv = dy_mm if dy_mm is not None else (_value_with_unit(meta["dy"]) if "dy" in meta else dxv)
    # a grid has no coordinates: the lateral unit only scales dx, so a dx given in mm or with its own unit
    # ('# dx: 5 um') leaves nothing assumed
    if "lateral unit mm" in assumed and (dx_mm is not None or re.search(r"[A-Za-zµμ]\s*$", meta.get("dx", ""))):
        assumed.remove("lateral unit mm")
    grid = data * kz
    params["layout"] = "grid"
    params["n_nan"] = int(np.isnan(grid).sum())
    return Measurement(grid, float(dxv), float(dyv), "map", source, params)


def _finite_coordinates(source: str, **coords: np.ndarray) -> None:
    """Refuse NaN or infinite x / y coordinates: a sample must say where it is."""
    for axis, c in coords.items():
        bad = ~np.isfinite(c)
        if bad.any():
            raise MeasurementFileError(
                f"{source!r}: {int(bad.sum())} of {len(c)} {axis} coordinates are NaN or infinite "
                f"(the first on data line {int(np.argmax(bad)) + 1}).",
                f"Every sample needs a finite {axis}; leave out the samples without one (a missing height is NaN).")


def _value_with_unit(s: str) -> float:
    m = re.match(r"^\s*([-+0-9.eE]+)\s*([A-Za-zµμ]*)\s*$", s)
    if not m:
        raise MeasurementFileError(f"cannot read the spacing {s!r}.", "Write it as e.g. '0.005 mm'.")
    return float(m.group(1)) * _unit_factor(m.group(2) or "mm", _TO_MM, "lateral")


# --- Zygo .datx ------------------------------------------------------------------------------


def _attr_scalar(v):
    a = np.asarray(v)
    if a.dtype.names:  # compound
        return a
    v = a.ravel()[0] if a.size else None
    if isinstance(v, bytes):
        v = v.decode("utf-8", errors="replace")
    return v


def _read_datx(path: Path, dx_mm: float | None, lateral_unit: str | None = None,
               height_unit: str | None = None) -> Measurement:
    """Zygo Mx ``.datx``: HDF5 with the height map in ``/Data/Surface/<name>``.

    Layout (as documented by open readers such as prysm and Gwyddion): the
    dataset carries attributes ``Unit`` (``NanoMeters``, ``MicroMeters``,
    ``Meters`` or ``Fringes``), ``No Data`` (sentinel for missing pixels),
    ``Wavelength`` (m), ``Interferometric Scale Factor``, ``Obliquity Factor``,
    and ``X Converter`` / ``Y Converter`` compounds whose ``Parameters[1]`` is
    the pixel size in ``BaseUnit`` (normally metres). Lateral resolution may
    also be in ``/Attributes/<group>`` as ``...Resolution:Value`` / ``:Unit``.
    """
    h5py = require("h5py", "reading Zygo .datx", extra="zygo")
    params: dict[str, Any] = {"format": "datx", "units_assumed": []}
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise MeasurementFileError(f"{str(path)!r} is not a readable HDF5 (.datx) file ({exc}).",
                                   "Is the file complete? Save it again from Mx as .datx, or export the map as "
                                   "text.") from None
    with f:
        if "Data" not in f or "Surface" not in f["Data"] or not len(f["Data"]["Surface"].keys()):
            raise MeasurementFileError(f"{str(path)!r} has no /Data/Surface dataset.",
                                       "Export the surface (not only intensity) from Mx.")
        key = list(f["Data"]["Surface"].keys())[0]
        ds = f["Data"]["Surface"][key]
        z = np.array(ds[()], dtype=np.float64)
        attrs = ds.attrs
        no_data = _attr_scalar(attrs["No Data"]) if "No Data" in attrs else None
        if no_data is not None:
            z[z >= float(no_data)] = np.nan  # the instrument's "no data" pixels (counted, warned about)
            params["no_data_value"] = float(no_data)
        if height_unit is not None:
            unit = height_unit
        elif "Unit" in attrs:
            unit = str(_attr_scalar(attrs["Unit"]))
        else:
            unit = "nm"
            params["units_assumed"].append("height unit nm")
        params["z_unit_in_file"] = unit
        if unit.lower() == "fringes":
            if "Wavelength" not in attrs:
                raise MeasurementFileError(f"{str(path)!r}: heights are in fringes but the file has no Wavelength.",
                                           "Pass --height-unit with the unit of the heights, or export in nm.")
            wl_m = float(_attr_scalar(attrs["Wavelength"]))
            if not (np.isfinite(wl_m) and wl_m > 0):
                raise MeasurementFileError(f"{str(path)!r}: heights are in fringes but the wavelength is {wl_m!r}.",
                                           "Pass --height-unit with the unit of the heights, or export in nm.")
            sf = float(_attr_scalar(attrs.get("Interferometric Scale Factor", 1.0)))
            ob = float(_attr_scalar(attrs.get("Obliquity Factor", 1.0)))
            z = z * sf * ob * wl_m * 1e9
        else:
            z = z * _unit_factor(unit, _TO_NM, "height")
        dx = dx_mm
        src = "argument"
        if dx is None and "X Converter" in attrs:
            conv = np.asarray(attrs["X Converter"]).ravel()[0]
            try:
                base = conv["BaseUnit"]
                base = base.decode() if isinstance(base, bytes) else str(base)
                par = np.asarray(conv["Parameters"]).ravel()
                if len(par) > 1 and par[1] > 0:
                    dx = float(par[1]) * _unit_factor(lateral_unit or base, _TO_MM, "lateral")
                    src = "X Converter"
            except (KeyError, ValueError, IndexError, MeasurementFileError):
                dx = None
        if dx is None and "Attributes" in f:
            for g in f["Attributes"].values():
                for k, v in g.attrs.items():
                    if k.endswith("Resolution:Value"):
                        u = g.attrs.get(k[: -len("Value")] + "Unit", "Meters")
                        dx = float(_attr_scalar(v)) * _unit_factor(str(_attr_scalar(u)), _TO_MM, "lateral")
                        src = f"/Attributes {k}"
                        break
        if dx is None or not (np.isfinite(dx) and dx > 0):
            raise MeasurementFileError(f"{str(path)!r} does not state its lateral resolution.",
                                       "Pass the pixel size (dx_mm / --dx / [error_map] dx_mm) in mm.")
    params.update({"dx_source": src, "dataset": f"/Data/Surface/{key}", "n_nan": int(np.isnan(z).sum()),
                   "note": "rows kept in file order (Zygo stores y downwards); irrelevant for PSDs"})
    if z.ndim == 1 or 1 in z.shape:
        return Measurement(z.ravel(), dx, None, "profile", str(path), params)
    return Measurement(z, dx, dx, "map", str(path), params)


def write_datx_like(path, z_nm: np.ndarray, dx_mm: float, *, unit: str = "NanoMeters", no_data: float = 1e38) -> Path:
    """Write a minimal Zygo-style ``.datx`` (HDF5) file, for examples and tests.

    Parameters
    ----------
    path : str or Path
        Output file.
    z_nm : (Ny, Nx) float64
        Heights, nm; NaN becomes the ``No Data`` sentinel.
    dx_mm : float
        Pixel size, mm (stored in metres in ``X Converter``/``Y Converter``).
    unit : str
        ``"NanoMeters"`` or ``"MicroMeters"`` (values are converted).
    no_data : float
        Sentinel written for missing pixels.
    """
    h5py = require("h5py", "writing a .datx file", extra="zygo")
    scale = {"NanoMeters": 1.0, "MicroMeters": 1e-3}[unit]
    z = np.array(z_nm, dtype=np.float64) * scale
    z[~np.isfinite(z)] = no_data
    conv_t = np.dtype([("Category", h5py.string_dtype()), ("BaseUnit", h5py.string_dtype()),
                       ("Parameters", np.float64, (4,))])
    with h5py.File(path, "w") as f:
        ds = f.create_group("Data").create_group("Surface").create_dataset("{00000000-0000-0000-0000-000000000001}", data=z)
        ds.attrs["Unit"] = np.array([unit.encode()], dtype=object)
        ds.attrs["No Data"] = np.array([no_data])
        ds.attrs["Wavelength"] = np.array([632.8e-9])
        ds.attrs["Interferometric Scale Factor"] = np.array([0.5])
        ds.attrs["Obliquity Factor"] = np.array([1.0])
        for name in ("X Converter", "Y Converter"):
            conv = np.array([("LateralCat", "Meters", [0.0, dx_mm * 1e-3, 0.0, 0.0])], dtype=conv_t)
            ds.attrs.create(name, conv, dtype=conv_t)
        g = f.create_group("Attributes").create_group("{00000000-0000-0000-0000-000000000002}")
        g.attrs["Data Context.Lateral Resolution:Value"] = np.array([dx_mm * 1e-3])
        g.attrs["Data Context.Lateral Resolution:Unit"] = np.array([b"Meters"], dtype=object)
    return Path(path)
