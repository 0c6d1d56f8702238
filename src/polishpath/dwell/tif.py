"""Tool influence functions (TIF): removal rate in nm/s around the tool centre.

The one ``TIF`` type of the project: the dwell-time solver (:mod:`polishpath.dwell`)
and the simulation (:mod:`polishpath.simulate`, which imports it from here) share it.

Defaults describe small-tool sponge polishing (see docs/simulation.md for
sources): Gaussian removal footprint of FWHM 1.0 mm and peak rate 5 nm/s.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..defaults import DEFAULT_PEAK_RATE_NM_S  # the Gaussian TIF's peak rate, nm/s
from ..errors import ParameterError

FWHM_PER_SIGMA = 2.0 * np.sqrt(2.0 * np.log(2.0))

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
    if not (np.isfinite(dx_mm) and dx_mm > 0):
        raise ParameterError(f"dx_mm must be positive, got {dx_mm}.")
    if a.max() <= 0 or a.min() < -1e-9 * a.max():  # below zero beyond rounding: not a removal rate
        raise ParameterError(f"a measured TIF's rates must be >= 0 nm/s with a positive peak; got {a.min():.4g} to "
                             f"{a.max():.4g} nm/s.", "Set its noise below zero to zero first.")
    a.setflags(write=False)
    return TIF("measured", {"dx_mm": float(dx_mm), "peak_rate_nm_s": float(a.max()), "shape": list(a.shape)}, a)


#: negative rates down to this share of the peak are a measured spot's noise (set to zero, counted); more is refused
NEGATIVE_RATE_NOISE = 0.05


def _rates_from_map(a: np.ndarray, name: str) -> np.ndarray:
    """A measured removal-rate map (nm/s) made usable, every change named.

    Pixels without data (NaN: outside the instrument's aperture, around the
    spot) become zero removal, and small negative rates (noise around zero,
    down to :data:`NEGATIVE_RATE_NOISE` of the peak) become zero; a warning
    gives both counts. A map without a positive peak, or with negative rates
    beyond the noise (a height map, not a removal map: the sign is the other
    way), is refused.
    """
    from .. import progress

    a = np.array(a, dtype=np.float64)
    n_nan = int(np.isnan(a).sum())
    peak = float(np.nanmax(a)) if n_nan < a.size else float("nan")
    if not (np.isfinite(peak) and peak > 0):
        raise ParameterError(f"{name}: the measured TIF has no positive removal rate (peak {peak!r} nm/s).",
                             "Give a removal map (depth removed > 0) of one spot, with its rate= or dwell_s=.")
    low = float(np.nanmin(a))
    if low < -NEGATIVE_RATE_NOISE * peak:
        raise ParameterError(
            f"{name}: the measured TIF has negative removal rates down to {low:.4g} nm/s "
            f"({100 * -low / peak:.1f} % of its {peak:.4g} nm/s peak; noise allows {100 * NEGATIVE_RATE_NOISE:g} %).",
            "Is it a height map (material left) rather than the depth removed? Give removal as positive depth.")
    n_neg = int((a < 0).sum())
    if n_nan or n_neg:
        progress.warn(f"{name}: {n_nan} pixel(s) without data (NaN) and {n_neg} small negative rate(s) (noise, "
                      f"at least {low:.3g} nm/s) of {a.size} in the measured TIF set to zero removal.")
    a[np.isnan(a) | (a < 0)] = 0.0
    return a


def parse_tif_spec(spec: str) -> tuple[str, dict[str, Any]]:
    """Split a ``--tif`` spec into its kind and parameters.

    ``gaussian:fwhm=MM,peak_rate=NM_PER_S`` (or ``sigma=MM``);
    ``measured:file=PATH,rate=1`` or ``measured:PATH`` (a removal-rate map in
    nm/s read with the ``polishpath psd`` readers; ``dwell_s=T`` divides a
    removal-depth map by its spot's dwell time; ``dx=MM`` for a grid without
    coordinates); ``rotating:rpm=230,radius=2,peak_rate=100`` (the simulation's
    rotating-tool model, built by the pipeline).
    """
    s = spec.strip()
    kind, _, rest = s.partition(":")
    kind = kind.strip().lower()
    if kind not in ("gaussian", "measured", "rotating"):
        raise ParameterError(f"unknown TIF kind {kind!r} in --tif {spec!r}.",
                             "Use gaussian:fwhm=MM,peak_rate=NM_PER_S, measured:file=PATH or rotating:rpm=RPM,radius=MM.")
    params: dict[str, Any] = {}
    for part in filter(None, (p.strip() for p in rest.split(","))):
        key, eq, val = part.partition("=")
        if not eq:
            if kind == "measured" and "file" not in params:
                params["file"] = key
                continue
            raise ParameterError(f"--tif {spec!r}: {part!r} is not key=value.")
        key = key.strip().lower()
        try:
            params[key] = float(val) if key != "file" and key != "pressure" else val.strip()
        except ValueError:
            raise ParameterError(f"--tif {spec!r}: {key} must be a number, got {val!r}.") from None
    allowed = {"gaussian": {"fwhm", "sigma", "peak_rate"}, "measured": {"file", "rate", "dwell_s", "dx"},
               "rotating": {"rpm", "radius", "peak_rate", "feed", "pressure"}}[kind]
    unknown = set(params) - allowed
    if unknown:
        raise ParameterError(f"--tif {spec!r}: unknown key(s) {', '.join(sorted(unknown))} for a {kind} TIF.",
                             f"Keys: {', '.join(sorted(allowed))}.")
    return kind, params


def tif_from_spec(spec: str, base_dir=None) -> TIF:
    """A Gaussian or measured TIF from a ``--tif`` spec (the rotating tool is built by the pipeline)."""
    from pathlib import Path

    kind, p = parse_tif_spec(spec)
    if kind == "gaussian":
        if "fwhm" in p and "sigma" in p:
            raise ParameterError(f"--tif {spec!r}: give fwhm or sigma, not both.")
        if "peak_rate" not in p:
            raise ParameterError(f"--tif {spec!r}: a Gaussian TIF needs peak_rate (nm/s).",
                                 "e.g. --tif gaussian:fwhm=2,peak_rate=50")
        return gaussian_tif(p["peak_rate"], fwhm_mm=p.get("fwhm"), sigma_mm=p.get("sigma"))
    if kind == "measured":
        if "file" not in p:
            raise ParameterError(f"--tif {spec!r}: a measured TIF needs its file (measured:file=PATH).")
        for key in ("rate", "dwell_s", "dx"):
            if key in p and not (np.isfinite(p[key]) and p[key] > 0):
                raise ParameterError(f"--tif {spec!r}: {key} must be a positive number, got {p[key]!r}.")
        from ..psd import read_measurement

        f = Path(p["file"])
        if base_dir is not None and not f.is_absolute() and (Path(base_dir) / f).exists():
            f = Path(base_dir) / f
        m = read_measurement(f, dx_mm=p.get("dx"))
        if m.kind != "map":
            raise ParameterError(f"{f.name}: a measured TIF must be a 2D map (a removal spot).")
        if m.dy_mm and abs(m.dy_mm - m.dx_mm) > 1e-9 * m.dx_mm:
            raise ParameterError(f"{f.name}: a measured TIF needs square pixels (dx {m.dx_mm}, dy {m.dy_mm} mm).")
        a = m.z_nm * p.get("rate", 1.0) / p.get("dwell_s", 1.0)
        t = measured_tif(_rates_from_map(a, f.name), m.dx_mm)
        t.params["file"] = str(f)
        return t
    raise ParameterError(f"--tif {spec!r}: the rotating-tool TIF is built by the pipeline (polishpath plan).")
