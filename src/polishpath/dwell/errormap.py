"""Measured surface error in: maps, Zernike coefficients, alignment to the part, coverage.

An :class:`ErrorMap` is a height map (nm) on a regular grid in the map's own
frame (pixel ``[i, j]`` at ``origin + (j dx, i dy)``, mm), NaN where the
instrument had no data (a mask, never zero). An :class:`Alignment` places it
on the part's projected x, y (the interferometer's view): the part point
``p`` reads the map at ``m = F R(-rotation) (p - offset) / scale`` where ``F``
flips x or y. :func:`sample_error` reads it bilinearly (NaN if any of the
four pixels is NaN or the point is off the map).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import CoverageError, MeasurementFileError, ParameterError, SpecError

#: a Zernike map has at most 2 x this + 1 pixels a side (pixel_mm >= radius / this)
ZERNIKE_MAX_HALF_PIXELS = 4000

#: heights in nm per unit, for ``--error-units`` and Zernike TOML files
HEIGHT_UNITS_NM = {"nm": 1.0, "um": 1e3, "µm": 1e3, "mm": 1e6, "m": 1e9, "angstrom": 0.1, "pm": 1e-3}


@dataclass(frozen=True)
class ErrorMap:
    """A measured surface error map.

    Attributes
    ----------
    z_nm : (ny, nx) float64
        Surface error (height above the wanted surface), nm; NaN = no data.
    dx_mm, dy_mm : float
        Pixel size along x (columns) and y (rows), mm.
    origin_mm : (float, float)
        Map-frame x, y of pixel ``[0, 0]``'s centre, mm.
    source : str
        File it came from (or ``"zernike"``/``"array"``).
    params : dict
        Units found or assumed, format, Zernike terms.
    """

    z_nm: np.ndarray
    dx_mm: float
    dy_mm: float
    origin_mm: tuple[float, float] = (0.0, 0.0)
    source: str = "array"
    params: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        z = np.array(self.z_nm, dtype=np.float64)
        if z.ndim != 2 or min(z.shape) < 2:
            raise ParameterError(f"an error map must be a 2D array of at least 2 x 2 pixels, got shape {z.shape}.")
        n_inf = int(np.isinf(z).sum())
        if n_inf:  # NaN is "no data" (a mask); an infinite height is never a measurement
            raise ParameterError(
                f"the error map {self.source!r} has {n_inf} infinite height(s) of {z.size} pixels.",
                "Write NaN (no data) where the instrument measured nothing, or export the map again.")
        z.setflags(write=False)
        object.__setattr__(self, "z_nm", z)
        for name in ("dx_mm", "dy_mm"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(f"error map {name} must be a positive number of mm, got {v!r}.")
        object.__setattr__(self, "origin_mm", (float(self.origin_mm[0]), float(self.origin_mm[1])))

    @classmethod
    def centred(cls, z_nm, dx_mm: float, dy_mm: float | None = None, **kw) -> ErrorMap:
        """A map whose centre pixel sits at the map frame's origin (an interferometer's usual frame)."""
        z = np.asarray(z_nm, dtype=np.float64)
        dy = dx_mm if dy_mm is None else dy_mm
        origin = (-(z.shape[1] - 1) / 2 * dx_mm, -(z.shape[0] - 1) / 2 * dy)
        return cls(z, dx_mm, dy, origin, **kw)

    @property
    def valid(self) -> np.ndarray:
        """(ny, nx) bool: pixels with data."""
        return np.isfinite(self.z_nm)

    def rms_nm(self) -> float:
        v = self.z_nm[self.valid]
        return float(np.sqrt(np.mean((v - v.mean()) ** 2))) if v.size else float("nan")


@dataclass(frozen=True)
class Alignment:
    """Where the map sits on the part (projected x, y, mm).

    Attributes
    ----------
    offset_mm : (float, float)
        Part x, y of the map frame's origin, mm.
    rotation_deg : float
        Rotation of the map frame on the part, degrees counter-clockwise.
    flip : {"none", "x", "y"}
        Mirror the map's x (or y) axis first (a map seen from the other side, a fold mirror).
    scale : float
        Map millimetres per part millimetre are ``1/scale`` (a magnification error of the instrument).
    """

    offset_mm: tuple[float, float] = (0.0, 0.0)
    rotation_deg: float = 0.0
    flip: str = "none"
    scale: float = 1.0

    def __post_init__(self):
        if self.flip not in ("none", "x", "y"):
            raise ParameterError(f"error map flip must be 'none', 'x' or 'y', got {self.flip!r}.")
        if not (math.isfinite(self.scale) and self.scale > 0):
            raise ParameterError(f"error map scale must be a positive number, got {self.scale!r}.")
        if not math.isfinite(self.rotation_deg):
            raise ParameterError(f"error map rotation must be a number of degrees, got {self.rotation_deg!r}.")
        object.__setattr__(self, "offset_mm", (float(self.offset_mm[0]), float(self.offset_mm[1])))

    @classmethod
    def from_dict(cls, d: dict[str, Any] | None) -> Alignment:
        """From an ``[error_map]`` table: ``offset_mm = [x, y]``, ``rotation_deg``, ``flip``, ``scale``."""
        d = dict(d or {})
        known = {"offset_mm", "rotation_deg", "flip", "scale"}
        kw = {k: d[k] for k in known if k in d}
        if "offset_mm" in kw:
            off = kw["offset_mm"]
            if not (isinstance(off, (list, tuple)) and len(off) == 2):
                raise SpecError(f"[error_map] offset_mm must be [x, y] in mm, got {off!r}.")
            kw["offset_mm"] = (float(off[0]), float(off[1]))
        try:
            return cls(**kw)
        except TypeError as exc:  # pragma: no cover - guarded by `known`
            raise SpecError(f"[error_map]: {exc}") from None

    def to_dict(self) -> dict[str, Any]:
        return {"offset_mm": list(self.offset_mm), "rotation_deg": self.rotation_deg, "flip": self.flip,
                "scale": self.scale}

    def part_to_map(self, xy: np.ndarray) -> np.ndarray:
        """Map-frame coordinates (K, 2) mm of part points ``xy`` (K, 2) mm."""
        p = np.asarray(xy, dtype=np.float64) - np.asarray(self.offset_mm)
        a = -math.radians(self.rotation_deg)
        c, s = math.cos(a), math.sin(a)
        m = np.column_stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1]]) / self.scale
        if self.flip == "x":
            m[:, 0] = -m[:, 0]
        elif self.flip == "y":
            m[:, 1] = -m[:, 1]
        return m


def sample_error(emap: ErrorMap, xy_part: np.ndarray, alignment: Alignment | None = None) -> np.ndarray:
    """The error (nm) at part points ``xy_part`` (K, 2) mm: bilinear, NaN off the map or next to a NaN pixel."""
    m = (alignment or Alignment()).part_to_map(np.asarray(xy_part, dtype=np.float64).reshape(-1, 2))
    fx = (m[:, 0] - emap.origin_mm[0]) / emap.dx_mm
    fy = (m[:, 1] - emap.origin_mm[1]) / emap.dy_mm
    ny, nx = emap.z_nm.shape
    out = np.full(len(m), np.nan)
    ok = (fx >= 0) & (fy >= 0) & (fx <= nx - 1) & (fy <= ny - 1)
    j0 = np.minimum(np.floor(fx[ok]).astype(np.int64), nx - 2)
    i0 = np.minimum(np.floor(fy[ok]).astype(np.int64), ny - 2)
    tx, ty = fx[ok] - j0, fy[ok] - i0
    z = emap.z_nm
    v = ((1 - ty) * ((1 - tx) * z[i0, j0] + tx * z[i0, j0 + 1])
         + ty * ((1 - tx) * z[i0 + 1, j0] + tx * z[i0 + 1, j0 + 1]))
    out[ok] = v  # NaN propagates from any NaN neighbour
    return out


def uncovered_fraction(values: np.ndarray, inside: np.ndarray) -> float:
    """Share of the aperture's samples (``inside``) where the map gave no value."""
    n = int(inside.sum())
    return float((~np.isfinite(values[inside])).sum() / n) if n else 1.0


def check_coverage(values: np.ndarray, inside: np.ndarray, max_uncovered: float, source: str = "the error map",
                   pixel_mm: float | None = None) -> float:
    """Refuse a map that leaves more than ``max_uncovered`` of the aperture without data.

    Returns the uncovered fraction; raises :class:`CoverageError` naming it.
    """
    frac = uncovered_fraction(values, inside)
    if frac > max_uncovered:
        area = f" ({frac * inside.sum() * pixel_mm**2:.4g} mm^2)" if pixel_mm else ""
        raise CoverageError(
            f"{source} does not cover the part: {100 * frac:.2f} % of the part's clear aperture{area} has no "
            f"data (off the map or masked), more than the {100 * max_uncovered:.2f} % allowed.",
            "Check the alignment ([error_map] offset_mm, rotation_deg, flip, scale in job.toml) and the map's "
            "pixel size and lateral unit (--error-units / the file's units); or raise [error_map] max_uncovered.",
        )
    return frac


def read_error_map(file, *, height_unit: str | None = None, lateral_unit: str | None = None,
                   dx_mm: float | None = None) -> ErrorMap:
    """Read a measured error map: the readers of ``polishpath psd`` or a Zernike TOML file.

    Parameters
    ----------
    file : str or Path
        ``.datx`` (Zygo), ``.csv``, grid text, ``x y z`` text (see
        :func:`polishpath.psd.read_measurement`), or ``.toml`` with a
        ``[zernike]`` table (see :func:`zernike_error_map`).
    height_unit, lateral_unit : str, optional
        Units in the file (``--error-units``): override what the file says.
        When neither the file nor these say, nm / mm are assumed and a
        ``UserWarning`` says so.
    dx_mm : float, optional
        Pixel size for grid files without coordinates, mm.

    Returns
    -------
    ErrorMap
        Centred on the map frame's origin unless the file gives coordinates (``x y z`` text).
        Row ``i`` of a grid is at ``y = origin + i dy`` (rows go up in y); an interferometer's
        file (``.datx``, MetroPro ``.dat``, Zygo ASCII, 4D ``.h5``) stores its top row first, so
        its rows are flipped.
    """
    p = Path(file)
    if p.suffix.lower() == ".toml":
        from ..surfaces.spec import read_toml

        return zernike_error_map(read_toml(p), source=str(p), height_unit=height_unit)
    from ..psd import read_measurement
    from ..psd.io import TOP_ROW_FIRST

    m = read_measurement(p, lateral_unit=lateral_unit, height_unit=height_unit, dx_mm=dx_mm)
    if m.kind != "map":
        raise MeasurementFileError(
            f"{p.name} holds a profile ({m.z_nm.size} samples along one line, {m.params.get('format', 'text')}), "
            "not a surface map: a profile says nothing about the heights beside its line, so no dwell times can be "
            "solved from it.",
            "Give a 2D map (.datx, .dat, .asc, .h5, .sur surface, a grid of heights, or x y z points); for a "
            "rotationally symmetric error fitted to the profile, give it as Zernike terms in a .toml ([zernike]); "
            "'polishpath psd' reads the profile itself.")
    assumed = list(m.params.get("units_assumed") or [])
    if assumed:
        warnings.warn(f"{p.name}: {' and '.join(assumed)} assumed (the file does not say); "
                      "give --error-units (heights) or [error_map] lateral_unit to be sure.", UserWarning, stacklevel=2)
    origin = m.params.get("origin_mm")
    params = {k: v for k, v in m.params.items() if k not in ("header", "note")}
    z = m.z_nm
    if params.get("format") in TOP_ROW_FIRST:
        # an interferometer's file stores its rows as the camera sees them, top row (largest y) first;
        # the map's rows go up in y
        z = z[::-1]
        params["rows"] = "flipped: the file's first row is the map's largest y"
    if origin is not None:
        return ErrorMap(z, m.dx_mm, m.dy_mm or m.dx_mm, tuple(origin), str(p), params)
    return ErrorMap.centred(z, m.dx_mm, m.dy_mm or m.dx_mm, source=str(p), params=params)


def zernike_error_map(data: dict[str, Any], *, source: str = "zernike", height_unit: str | None = None) -> ErrorMap:
    """An error map from Zernike coefficients.

    ``data`` (a TOML document) holds a ``[zernike]`` table:

    .. code-block:: toml

       [zernike]
       ordering = "fringe"      # or "standard" (Noll, normalised)
       radius_mm = 25.0         # normalisation radius
       units = "nm"             # of the coefficients (nm, um, mm, m, angstrom)
       coefficients = [0, 0, 0, 30.0, 0, 0, 0, 0, -12.0]   # Z1, Z2, ...
       # or: terms = { 4 = 30.0, 9 = -12.0 }
       pixel_mm = 0.25          # sampling of the map (default radius / 200)

    The map covers the unit disc (NaN outside), centred on the map frame's origin.
    """
    t = data.get("zernike", data)
    if not isinstance(t, dict):
        raise SpecError(f"{source}: [zernike] must be a table.")
    unknown = set(t) - {"ordering", "radius_mm", "units", "coefficients", "terms", "pixel_mm"}
    if unknown:
        raise SpecError(f"{source}: unknown [zernike] key(s) {', '.join(sorted(unknown))}.",
                        "Keys: ordering, radius_mm, units, coefficients or terms, pixel_mm.")
    order = str(t.get("ordering", "fringe")).lower()
    if order not in ("fringe", "standard"):
        raise SpecError(f"{source}: [zernike] ordering must be 'fringe' or 'standard', got {order!r}.")
    radius = t.get("radius_mm")
    if not (isinstance(radius, (int, float)) and math.isfinite(radius) and radius > 0):
        raise SpecError(f"{source}: [zernike] needs radius_mm, the normalisation radius in mm (a finite number > 0), "
                        f"got {radius!r}.")
    unit = height_unit or t.get("units")
    if unit is None:
        warnings.warn(f"{source}: Zernike coefficient unit nm assumed; give units = \"nm\" (or --error-units).",
                      UserWarning, stacklevel=2)
        unit = "nm"
    k = HEIGHT_UNITS_NM.get(str(unit).lower())
    if k is None:
        raise SpecError(f"{source}: unknown Zernike unit {unit!r}.", f"Use one of {sorted(HEIGHT_UNITS_NM)}.")
    if "terms" in t:
        terms = {int(j): float(c) for j, c in dict(t["terms"]).items()}
        coeffs = [terms.get(j, 0.0) for j in range(1, max(terms, default=0) + 1)]
    else:
        coeffs = [float(c) for c in t.get("coefficients", [])]
    if not coeffs:
        raise SpecError(f"{source}: [zernike] has no coefficients.", "Give coefficients = [Z1, Z2, ...] or terms.")
    bad = [j + 1 for j, c in enumerate(coeffs) if not math.isfinite(c)]
    if bad:
        raise SpecError(f"{source}: {len(bad)} Zernike coefficient(s) are NaN or infinite (Z{bad[0]} first).",
                        "Every coefficient must be a finite number (0 for a term not present).")
    pix = t.get("pixel_mm", radius / 200.0)
    if not (isinstance(pix, (int, float)) and math.isfinite(pix) and radius / ZERNIKE_MAX_HALF_PIXELS <= pix):
        raise SpecError(f"{source}: [zernike] pixel_mm must be a positive number of mm of at least radius / "
                        f"{ZERNIKE_MAX_HALF_PIXELS} ({radius / ZERNIKE_MAX_HALF_PIXELS:.4g} mm), got {pix!r}.",
                        "Leave it out for radius / 200.")
    pix = float(pix)
    z = zernike_surface(np.asarray(coeffs) * k, float(radius), order, pix)
    return ErrorMap.centred(z, pix, source=source,
                            params={"format": "zernike", "ordering": order, "radius_mm": float(radius),
                                    "coefficients_nm": list(np.asarray(coeffs) * k), "units": str(unit)})


def zernike_surface(coeffs_nm, radius_mm: float, ordering: str = "fringe", pixel_mm: float | None = None) -> np.ndarray:
    """Zernike sum (nm) sampled on a centred square grid over the disc of ``radius_mm`` (NaN outside).

    The grid has ``2 ceil(radius / pixel) + 1`` pixels a side; pixel ``[i, j]``
    at ``((j - c) pixel, (i - c) pixel)``. The polynomials are those of the
    surface specs (:class:`polishpath.surfaces.sag.ZernikeSag`).
    """
    from ..surfaces.sag import ZernikeSag

    pix = radius_mm / 200.0 if pixel_mm is None else pixel_mm
    h = int(math.ceil(radius_mm / pix))
    o = np.arange(-h, h + 1) * pix
    X, Y = np.meshgrid(o, o)
    z = ZernikeSag(coeffs=tuple(float(c) for c in coeffs_nm), norm_radius=radius_mm, order=ordering)(X, Y)
    z[np.hypot(X, Y) > radius_mm * (1 + 1e-9)] = np.nan
    return z
