"""The profilometer-style PSD of a height map (rows and columns averaged).

Shared by the path comparison (:mod:`.compare`) and the simulation of a job's
path (:mod:`.jobpath`); it lives below both so that neither imports the other.

Units: nm (heights), mm (pitch), 1/mm (frequencies).
"""

from __future__ import annotations

import weakref

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
    key = _view_key(map_nm, dx_mm, window, detrend)
    if key is not None:
        for ref, k, val in _PSD_CACHE:
            if ref() is map_nm.base and k == key:
                return val
    z = np.asarray(map_nm, dtype=np.float64)
    if z.shape[0] != z.shape[1]:
        n = min(z.shape)
        z = z[:n, :n]
    a = psd_1d(z, dx_mm, window=window, detrend=detrend, nan="raise")
    b = psd_1d(z.T, dx_mm, window=window, detrend=detrend, nan="raise")
    params = dict(a.params)
    params.update({"directions": "rows+columns", "n_profiles": a.params["n_profiles"] + b.params["n_profiles"],
                   "variance_nm2": 0.5 * (a.params["variance_nm2"] + b.params["variance_nm2"])})
    out = PSD(a.freq, 0.5 * (a.psd + b.psd), kind="1d", units=a.units, params=params)
    if key is not None:
        _PSD_CACHE.append((weakref.ref(map_nm.base), key, out))
        del _PSD_CACHE[:-_PSD_CACHE_SIZE]
    return out


#: the PSDs of the last few windows of read-only maps (the start of a seed, judged once per path)
_PSD_CACHE: list = []
_PSD_CACHE_SIZE = 2


def _view_key(a, dx_mm, window, detrend):
    """What identifies a window of a read-only array (its base, where it starts, its shape and strides), or
    None for an array that could change under a cache (writeable, or not a view of a read-only base)."""
    if not isinstance(a, np.ndarray) or a.flags.writeable or not isinstance(a.base, np.ndarray) \
            or a.base.flags.writeable or not isinstance(detrend, (str, int)):
        return None
    start = a.__array_interface__["data"][0] - a.base.__array_interface__["data"][0]
    return (start, a.shape, a.strides, a.dtype.str, float(dx_mm), str(window), detrend)
