"""The profilometer-style PSD of a height map (rows and columns averaged).

Shared by the path comparison (:mod:`.compare`) and the simulation of a job's
path (:mod:`.jobpath`); it lives below both so that neither imports the other.

Units: nm (heights), mm (pitch), 1/mm (frequencies).
"""

from __future__ import annotations

import numpy as np

from ..psd.core import PSD, psd_1d

__all__ = ["profile_psd"]


def profile_psd(map_nm: np.ndarray, dx_mm: float, *, window: str = "hann", detrend="tilt") -> PSD:
    """Profilometer-style PSD of a map: 1D PSDs of all rows and all columns, averaged.

    Averaging both directions makes the figure independent of how the
    profilometer would have been aligned to a directional (raster) texture.

    Parameters
    ----------
    map_nm : (n, n) float
        Square height map, nm.
    dx_mm : float
        Pixel pitch, mm.

    Returns
    -------
    PSD
        ``kind="1d"``, nm^2 mm; ``params["directions"] = "rows+columns"``.
    """
    z = np.asarray(map_nm, dtype=np.float64)
    if z.shape[0] != z.shape[1]:
        n = min(z.shape)
        z = z[:n, :n]
    a = psd_1d(z, dx_mm, window=window, detrend=detrend, nan="raise")
    b = psd_1d(z.T, dx_mm, window=window, detrend=detrend, nan="raise")
    params = dict(a.params)
    params.update({"directions": "rows+columns", "n_profiles": a.params["n_profiles"] + b.params["n_profiles"],
                   "variance_nm2": 0.5 * (a.params["variance_nm2"] + b.params["variance_nm2"])})
    return PSD(a.freq, 0.5 * (a.psd + b.psd), kind="1d", units=a.units, params=params)
