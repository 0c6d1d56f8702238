"""Tool influence functions (TIF): removal rate in nm/s around the tool centre.

Defaults describe small-tool sponge polishing (see docs/simulation.md for
sources): Gaussian removal footprint of FWHM 1.0 mm and peak rate 5 nm/s.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ParameterError

FWHM_PER_SIGMA = 2.0 * np.sqrt(2.0 * np.log(2.0))

#: default Gaussian TIF of a small sponge tool: peak removal rate, nm/s
DEFAULT_PEAK_RATE_NM_S = 5.0
#: default full width at half maximum of the removal footprint, mm
DEFAULT_FWHM_MM = 1.0


@dataclass(frozen=True)
class TIF:
    """A tool influence function: removal rate (nm/s) as a function of the offset from the tool centre.

    Attributes
    ----------
    kind : str
        ``"gaussian"`` or ``"measured"``.
    params : dict
        Gaussian: ``peak_rate_nm_s``, ``sigma_mm``, ``fwhm_mm``, ``offset_mm``.
        Measured: ``dx_mm`` of the array, ``peak_rate_nm_s``.
    array : (ky, kx) float64 or None
        Measured removal rates, nm/s, centred on the tool centre (measured kind).
    """

    kind: str
    params: dict[str, Any] = field(default_factory=dict)
    array: np.ndarray | None = None

    @property
    def radius_mm(self) -> float:
        """Radius beyond which the rate is negligible (< 1e-6 of the peak for a Gaussian), mm."""
        if self.kind == "gaussian":
            off = np.hypot(*self.params.get("offset_mm", (0.0, 0.0)))
            return float(5.3 * self.params["sigma_mm"] + off)
        ky, kx = self.array.shape
        return float(0.5 * max(kx, ky) * self.params["dx_mm"])

    @property
    def volume_rate(self) -> float:
        """Removed volume per second, nm mm^2 / s (integral of the rate over the plane)."""
        if self.kind == "gaussian":
            return float(self.params["peak_rate_nm_s"] * 2 * np.pi * self.params["sigma_mm"] ** 2)
        return float(self.array.sum() * self.params["dx_mm"] ** 2)

    def kernel(self, dx_mm: float) -> np.ndarray:
        """The TIF sampled on a grid of pitch ``dx_mm``, odd-sized and centred.

        Parameters
        ----------
        dx_mm : float
            Grid pitch, mm.

        Returns
        -------
        (k, k) float64
            Removal rate, nm/s, at offsets ``(i - k//2) * dx_mm``. The discrete
            volume ``kernel.sum() * dx_mm**2`` matches :attr:`volume_rate`
            (rescaled where the sampling is coarse).
        """
        r = self.radius_mm
        h = max(1, int(np.ceil(r / dx_mm)))
        o = np.arange(-h, h + 1) * dx_mm
        X, Y = np.meshgrid(o, o)
        if self.kind == "gaussian":
            s = self.params["sigma_mm"]
            ox, oy = self.params.get("offset_mm", (0.0, 0.0))
            k = self.params["peak_rate_nm_s"] * np.exp(-((X - ox) ** 2 + (Y - oy) ** 2) / (2 * s * s))
        else:
            from scipy.interpolate import RegularGridInterpolator

            a = self.array
            d = self.params["dx_mm"]
            ay = (np.arange(a.shape[0]) - (a.shape[0] - 1) / 2) * d
            ax = (np.arange(a.shape[1]) - (a.shape[1] - 1) / 2) * d
            f = RegularGridInterpolator((ay, ax), a, bounds_error=False, fill_value=0.0)
            k = f(np.stack([Y.ravel(), X.ravel()], axis=1)).reshape(X.shape)
        vol = k.sum() * dx_mm**2
        if vol > 0:
            k *= self.volume_rate / vol
        return k


def gaussian_tif(peak_rate_nm_s: float = DEFAULT_PEAK_RATE_NM_S, *, fwhm_mm: float | None = None,
                 sigma_mm: float | None = None, offset_mm: tuple[float, float] = (0.0, 0.0)) -> TIF:
    """Gaussian TIF ``R(r) = peak * exp(-r^2 / (2 sigma^2))``.

    Parameters
    ----------
    peak_rate_nm_s : float
        Removal rate at the centre, nm/s.
    fwhm_mm : float, optional
        Full width at half maximum, mm (``= 2.3548 sigma``). Default 1.0 mm.
    sigma_mm : float, optional
        Standard deviation, mm (give this or ``fwhm_mm``).
    offset_mm : (float, float)
        Shift of the footprint from the tool centre, mm (a tilted tool removes
        ahead of or behind its axis).

    Returns
    -------
    TIF
    """
    if fwhm_mm is not None and sigma_mm is not None:
        raise ParameterError("give fwhm_mm or sigma_mm, not both.")
    if sigma_mm is None:
        sigma_mm = (DEFAULT_FWHM_MM if fwhm_mm is None else fwhm_mm) / FWHM_PER_SIGMA
    if not (np.isfinite(sigma_mm) and sigma_mm > 0):
        raise ParameterError(f"the TIF width must be positive, got sigma={sigma_mm} mm.")
    if not (np.isfinite(peak_rate_nm_s) and peak_rate_nm_s >= 0):
        raise ParameterError(f"peak_rate_nm_s must be >= 0 nm/s, got {peak_rate_nm_s}.")
    return TIF("gaussian", {"peak_rate_nm_s": float(peak_rate_nm_s), "sigma_mm": float(sigma_mm),
                            "fwhm_mm": float(sigma_mm * FWHM_PER_SIGMA),
                            "offset_mm": (float(offset_mm[0]), float(offset_mm[1]))})


def measured_tif(rate_nm_s, dx_mm: float) -> TIF:
    """TIF from a measured removal-rate map.

    Parameters
    ----------
    rate_nm_s : (ky, kx) array_like
        Removal rate, nm/s (a measured removal spot divided by its dwell
        time), centred on the tool centre; NaN not allowed.
    dx_mm : float
        Pixel size of the array, mm.

    Returns
    -------
    TIF
    """
    a = np.array(rate_nm_s, dtype=np.float64)
    if a.ndim != 2 or min(a.shape) < 3:
        raise ParameterError(f"a measured TIF must be a 2D array of at least 3 x 3, got shape {a.shape}.")
    if not np.isfinite(a).all():
        raise ParameterError("the measured TIF contains NaN or infinite values.", "Fill or crop them first.")
    if not dx_mm > 0:
        raise ParameterError(f"dx_mm must be positive, got {dx_mm}.")
    a.setflags(write=False)
    return TIF("measured", {"dx_mm": float(dx_mm), "peak_rate_nm_s": float(a.max()), "shape": list(a.shape)}, a)


@dataclass(frozen=True)
class DirectionalTIF:
    """A TIF that depends on the direction of travel.

    The path is split by travel direction into ``len(tifs)`` equal sectors
    centred on ``k * 2 pi / len(tifs)`` (radians, counter-clockwise from +x);
    sector k removes with ``tifs[k]``.

    Attributes
    ----------
    tifs : tuple of TIF
    params : dict
    """

    tifs: tuple[TIF, ...]
    params: dict[str, Any] = field(default_factory=dict)

    @property
    def directions_rad(self) -> np.ndarray:
        """Sector centres, radians."""
        return np.arange(len(self.tifs)) * 2 * np.pi / len(self.tifs)

    @property
    def radius_mm(self) -> float:
        return max(t.radius_mm for t in self.tifs)

    def sector(self, heading_rad: np.ndarray) -> np.ndarray:
        """Sector index (M,) of travel headings (M,) radians."""
        n = len(self.tifs)
        return np.rint(np.mod(heading_rad, 2 * np.pi) / (2 * np.pi / n)).astype(np.int64) % n


def tilted_tool_tif(base: TIF | None = None, *, asymmetry: float = 0.1, tilt_direction_rad: float = 0.0,
                    lead_mm: float = 0.0, n_directions: int = 8) -> DirectionalTIF:
    """Direction-dependent Gaussian TIF of a tilted rotating tool.

    A spinning tool tilted towards ``tilt_direction_rad`` removes more when it
    travels one way than the other: the rate is scaled by
    ``1 + asymmetry * cos(heading - tilt_direction)`` and the footprint is
    shifted ``lead_mm`` along the heading.

    Parameters
    ----------
    base : TIF, optional
        Gaussian TIF for travel across the tilt (default :func:`gaussian_tif`).
    asymmetry : float
        Relative rate change: travel along the tilt removes ``1 + asymmetry``
        times the base rate, against it ``1 - asymmetry`` (0..1).
    tilt_direction_rad : float
        Direction of the tilt, radians from +x.
    lead_mm : float
        Shift of the footprint along the direction of travel, mm.
    n_directions : int
        Number of direction sectors.

    Returns
    -------
    DirectionalTIF
    """
    base = base or gaussian_tif()
    if base.kind != "gaussian":
        raise ParameterError("tilted_tool_tif needs a Gaussian base TIF.")
    if not (0 <= asymmetry < 1) or n_directions < 2:
        raise ParameterError("asymmetry must be in [0, 1) and n_directions >= 2.")
    tifs = []
    for k in range(n_directions):
        h = k * 2 * np.pi / n_directions
        tifs.append(gaussian_tif(base.params["peak_rate_nm_s"] * (1 + asymmetry * np.cos(h - tilt_direction_rad)),
                                 sigma_mm=base.params["sigma_mm"], offset_mm=(lead_mm * np.cos(h), lead_mm * np.sin(h))))
    return DirectionalTIF(tuple(tifs), {"kind": "tilted", "asymmetry": asymmetry, "tilt_direction_rad": tilt_direction_rad,
                                        "lead_mm": lead_mm, "n_directions": n_directions, "base": dict(base.params)})
