"""The workpiece: a height map (nm) on a rectangular patch of the part (mm).

The surface's own sag is not in the map: it is the deviation from the design
surface, which is what removal changes and what a PSD measures.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ParameterError
from ..types import Provenance

#: default sampling, mm (5 um: resolves 10^5 1/m = 100 1/mm at Nyquist)
DEFAULT_DX_MM = 0.005


@dataclass(frozen=True)
class Workpiece:
    """Height map of a patch of the part.

    Attributes
    ----------
    height_nm : (Ny, Nx) float
        Surface error, nm (design sag removed); rows along y. Stored read-only (a writeable array
        given is copied), so results derived from it (the smoothing spectrum) can be reused.
    dx_mm : float
        Pixel pitch in x and y, mm.
    origin_mm : (2,) float64
        (x, y) of the centre of pixel [0, 0], mm.
    provenance : Provenance
    """

    height_nm: np.ndarray
    dx_mm: float
    origin_mm: np.ndarray = field(default_factory=lambda: np.zeros(2))
    provenance: Provenance = field(default_factory=lambda: Provenance("simulate", "workpiece"))

    def __post_init__(self):
        h = np.asarray(self.height_nm)
        if h.ndim != 2 or min(h.shape) < 8:
            raise ParameterError(f"a workpiece height map must be 2D and at least 8 x 8, got {h.shape}.")
        if not np.isfinite(h).all():
            raise ParameterError("the workpiece height map has NaN pixels.",
                                 "Fill them (e.g. psd_2d's interpolation) or crop the map before simulating.")
        object.__setattr__(self, "origin_mm", np.asarray(self.origin_mm, dtype=np.float64))
        if h.flags.writeable:  # a private, read-only copy: the map cannot change under what is derived from it
            h = h.copy()
            h.setflags(write=False)
        object.__setattr__(self, "height_nm", h)

    @property
    def shape(self) -> tuple[int, int]:
        return tuple(np.shape(self.height_nm))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the pixel centres, mm."""
        ny, nx = self.shape
        x0, y0 = self.origin_mm
        return float(x0), float(y0), float(x0 + (nx - 1) * self.dx_mm), float(y0 + (ny - 1) * self.dx_mm)


def _grid_shape(bounds, dx_mm):
    xmin, ymin, xmax, ymax = map(float, bounds)
    if not (xmax > xmin and ymax > ymin):
        raise ParameterError(f"patch bounds must be (xmin, ymin, xmax, ymax) with max > min, got {bounds}.")
    if not (np.isfinite(dx_mm) and dx_mm > 0):
        raise ParameterError(f"dx_mm must be a positive pitch in mm, got {dx_mm}.")
    nx = int(np.floor((xmax - xmin) / dx_mm + 1e-9)) + 1
    ny = int(np.floor((ymax - ymin) / dx_mm + 1e-9)) + 1
    if nx * ny > 64_000_000:
        raise ParameterError(f"a {nx} x {ny} grid is too large to simulate in memory.",
                             "Use a smaller patch or a coarser dx_mm.")
    return ny, nx


def flat_workpiece(bounds, dx_mm: float = DEFAULT_DX_MM) -> Workpiece:
    """A perfect (zero-error) patch.

    Parameters
    ----------
    bounds : (xmin, ymin, xmax, ymax)
        Patch extent, mm.
    dx_mm : float
        Pixel pitch, mm.
    """
    ny, nx = _grid_shape(bounds, dx_mm)
    return Workpiece(np.zeros((ny, nx), dtype=np.float32), float(dx_mm), np.array(bounds[:2], dtype=float),
                     Provenance("simulate", "flat_workpiece", {"bounds": list(map(float, bounds)), "dx_mm": dx_mm}))


def synthetic_workpiece(bounds, dx_mm: float = DEFAULT_DX_MM, *, rms_nm: float = 2.0, exponent: float = 2.5,
                        band_per_mm: tuple[float, float] = (1.0, 100.0), seed: int = 0) -> Workpiece:
    """A random surface with an isotropic power-law PSD.

    The 2D PSD is ``~ f^-exponent`` for ``f`` in ``band_per_mm`` and zero
    outside; the map is scaled to ``rms_nm`` (the band RMS).

    Parameters
    ----------
    bounds : (xmin, ymin, xmax, ymax)
        Patch extent, mm.
    dx_mm : float
        Pixel pitch, mm.
    rms_nm : float
        RMS height of the surface, nm.
    exponent : float
        Power-law exponent of the 2D PSD (typical polished glass: 2-3).
    band_per_mm : (float, float)
        Frequencies carrying error, 1/mm.
    seed : int
        Random seed (recorded).

    Returns
    -------
    Workpiece
    """
    ny, nx = _grid_shape(bounds, dx_mm)
    if rms_nm < 0:
        raise ParameterError(f"rms_nm must be >= 0, got {rms_nm}.")
    rng = np.random.default_rng(seed)
    fx = np.fft.rfftfreq(nx, d=dx_mm)
    fy = np.fft.fftfreq(ny, d=dx_mm)
    f = np.hypot(fx[None, :], fy[:, None])
    amp = np.zeros_like(f)
    inb = (f >= band_per_mm[0]) & (f <= band_per_mm[1])
    amp[inb] = f[inb] ** (-exponent / 2.0)
    spec = amp * (rng.standard_normal(f.shape) + 1j * rng.standard_normal(f.shape))
    import scipy.fft as sfft

    z = sfft.irfft2(spec, s=(ny, nx), workers=-1)
    s = z.std()
    z = z * (rms_nm / s) if s > 0 else z
    return Workpiece(z.astype(np.float32), float(dx_mm), np.array(bounds[:2], dtype=float),
                     Provenance("simulate", "synthetic_workpiece",
                                {"bounds": list(map(float, bounds)), "dx_mm": dx_mm, "rms_nm": rms_nm,
                                 "exponent": exponent, "band_per_mm": list(band_per_mm)}, seed=seed))


def workpiece_from_measurement(measurement, origin_mm=(0.0, 0.0)) -> Workpiece:
    """A workpiece from a measured map (:class:`polishpath.psd.Measurement`).

    Parameters
    ----------
    measurement : Measurement
        A ``kind="map"`` measurement with square pixels; NaN pixels are
        refused (fill or crop them first).
    origin_mm : (float, float)
        Position of pixel [0, 0] in the path's plane, mm.
    """
    if measurement.kind != "map":
        raise ParameterError("a workpiece needs a 2D map, not a profile.", "Measure an area or synthesise one.")
    if abs(measurement.dx_mm - (measurement.dy_mm or measurement.dx_mm)) > 1e-9 * measurement.dx_mm:
        raise ParameterError("the measured map must have square pixels.", "Resample it to equal dx and dy.")
    return Workpiece(np.asarray(measurement.z_nm, dtype=np.float32), float(measurement.dx_mm),
                     np.asarray(origin_mm, dtype=float),
                     Provenance("simulate", "measured_workpiece", {"source": measurement.source}))
