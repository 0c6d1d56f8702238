"""Direction-dependent tool influence functions (TIF) for the simulation.

The plain :class:`TIF` type and its Gaussian / measured constructors live in
:mod:`polishpath.dwell.tif` (one type shared by the dwell-time solver and the
simulation); they are re-exported here so ``polishpath.simulate.tif`` keeps its names.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..dwell.tif import DEFAULT_FWHM_MM, DEFAULT_PEAK_RATE_NM_S, FWHM_PER_SIGMA, TIF, gaussian_tif, measured_tif
from ..errors import ParameterError

__all__ = ["TIF", "DirectionalTIF", "gaussian_tif", "measured_tif", "tilted_tool_tif",
           "DEFAULT_FWHM_MM", "DEFAULT_PEAK_RATE_NM_S", "FWHM_PER_SIGMA"]


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
