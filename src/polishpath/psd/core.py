"""Power spectral density of profiles and maps (ISO 10110-8 conventions).

Conventions (stated once, used everywhere in polishpath):

* Heights in nanometres, lateral lengths in millimetres, spatial frequencies in
  cycles per millimetre (1/mm). The paper's band 10^3-10^5 1/m is 1-100 1/mm.
* 1D PSD (profiles, as from a stylus profilometer): **one-sided**, in nm^2 mm,
  normalised so that ``sum(psd) * df`` over all positive frequencies equals the
  variance of the (detrended, piston-free) profile (Parseval). ISO 10110-8
  writes the same quantity as a two-sided PSD over +-f; the one-sided value is
  twice the two-sided one, and band RMS is the same either way.
* 2D PSD (maps): two-sided in (fx, fy), in nm^2 mm^2, with
  ``sum(psd) * dfx * dfy`` equal to the variance. The azimuthal (radial)
  average keeps the 2D units; its band RMS is ``sqrt(int 2 pi f PSD(f) df)``.
* Windows are power-corrected (divided by ``mean(w**2)``) so a window does not
  change the total power of broadband data.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ParameterError

#: The paper's band, 10^3 - 10^5 1/m, in 1/mm.
PAPER_BAND_PER_MM: tuple[float, float] = (1.0, 100.0)

_WINDOWS = ("hann", "tukey", "none")
_NAN_POLICIES = ("drop", "interpolate", "raise")


@dataclass(frozen=True)
class PSD:
    """A one-dimensional spectrum: 1D profile PSD or azimuthal average of a 2D PSD.

    Attributes
    ----------
    freq : (K,) float64
        Spatial frequencies, 1/mm, increasing, DC excluded.
    psd : (K,) float64
        Spectral density: nm^2 mm (``kind="1d"``) or nm^2 mm^2 (``kind="2d-radial"``).
    kind : str
        ``"1d"`` (one-sided profile PSD) or ``"2d-radial"`` (azimuthal average of the 2D PSD).
    units : str
        Units of ``psd`` (``"nm^2 mm"`` or ``"nm^2 mm^2"``).
    params : dict
        How it was computed: window, detrend, sampling, number of profiles,
        NaN handling, variance of the data (``variance_nm2``) ...
    """

    freq: np.ndarray
    psd: np.ndarray
    kind: str = "1d"
    units: str = "nm^2 mm"
    params: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        f = np.array(self.freq, dtype=np.float64)
        p = np.array(self.psd, dtype=np.float64)
        if f.ndim != 1 or p.shape != f.shape:
            raise ParameterError(f"PSD freq and psd must be 1D arrays of equal length, got {f.shape} and {p.shape}.")
        if self.kind not in ("1d", "2d-radial"):
            raise ParameterError(f"PSD kind must be '1d' or '2d-radial', got {self.kind!r}.")
        f.setflags(write=False)
        p.setflags(write=False)
        object.__setattr__(self, "freq", f)
        object.__setattr__(self, "psd", p)

    @property
    def df(self) -> float:
        """Frequency bin width, 1/mm."""
        return float(self.params.get("df_per_mm", self.freq[1] - self.freq[0] if len(self.freq) > 1 else np.nan))

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly form (lists)."""
        return {"kind": self.kind, "units": self.units, "freq_per_mm": self.freq.tolist(),
                "psd": self.psd.tolist(), "params": dict(self.params)}


@dataclass(frozen=True)
class PSD2D:
    """A two-sided 2D PSD of a height map.

    Attributes
    ----------
    fx : (Nx,) float64
        Frequencies along x, 1/mm, increasing (fft-shifted).
    fy : (Ny,) float64
        Frequencies along y, 1/mm, increasing (fft-shifted).
    psd : (Ny, Nx) float64
        Spectral density, nm^2 mm^2; ``psd.sum() * dfx * dfy`` = variance.
    units : str
        ``"nm^2 mm^2"``.
    params : dict
        Window, detrend, sampling, NaN handling, variance.
    """

    fx: np.ndarray
    fy: np.ndarray
    psd: np.ndarray
    units: str = "nm^2 mm^2"
    params: dict[str, Any] = field(default_factory=dict)


# --- helpers -------------------------------------------------------------------------


def window_1d(n: int, window: str = "hann", tukey_alpha: float = 0.25) -> np.ndarray:
    """Taper of length ``n``.

    Parameters
    ----------
    n : int
        Number of samples.
    window : {"hann", "tukey", "none"}
        Window name. Hann is the usual choice for ISO 10110-8 PSDs of
        non-periodic data; Tukey keeps more of the data; none is for periodic data.
    tukey_alpha : float
        Tapered fraction of the Tukey window (0..1).

    Returns
    -------
    (n,) float64
    """
    # Written with numpy (periodic forms, as scipy.signal.windows(..., sym=False)):
    # importing scipy.signal costs seconds, more than the PSD itself.
    k = np.arange(n) / n
    if window == "hann":
        return 0.5 - 0.5 * np.cos(2 * np.pi * k)
    if window == "tukey":
        a = float(tukey_alpha)
        if a <= 0:
            return np.ones(n)
        if a >= 1:
            return 0.5 - 0.5 * np.cos(2 * np.pi * k)
        w = np.ones(n)
        lo = k < a / 2
        hi = k > 1 - a / 2
        w[lo] = 0.5 * (1 - np.cos(2 * np.pi * k[lo] / a))
        w[hi] = 0.5 * (1 - np.cos(2 * np.pi * (1 - k[hi]) / a))
        return w
    if window in ("none", None, "rect", "boxcar"):
        return np.ones(n)
    raise ParameterError(f"unknown window {window!r}.", f"Use one of {_WINDOWS}.")


def _poly_order(detrend) -> int:
    if detrend in (None, "none"):
        return -1
    if detrend == "piston":
        return 0
    if detrend == "tilt":
        return 1
    if detrend in ("form", "poly2", "power"):
        return 2
    if isinstance(detrend, (int, np.integer)) and detrend >= 0:
        return int(detrend)
    if isinstance(detrend, str) and detrend.startswith("poly") and detrend[4:].isdigit():
        return int(detrend[4:])
    raise ParameterError(f"unknown detrend {detrend!r}.",
                         "Use 'none', 'piston', 'tilt', 'form' (2nd-order polynomial) or 'polyN'.")


def detrend_profiles(z: np.ndarray, x: np.ndarray, detrend="tilt") -> np.ndarray:
    """Remove a least-squares polynomial from each profile (row) of ``z``.

    Parameters
    ----------
    z : (P, N) float64
        Profiles, nm (no NaN).
    x : (N,) float64
        Positions along the profile, mm.
    detrend : {"none", "piston", "tilt", "form"} or int
        Polynomial order removed: piston 0, tilt 1, form 2, or an explicit order.

    Returns
    -------
    (P, N) float64
        Residual profiles, nm.
    """
    order = _poly_order(detrend)
    if order < 0:
        return z.copy()
    t = (x - x.mean()) / max(np.ptp(x), 1e-300)
    # least squares by projection on an orthonormal basis of the polynomials (the same fit as lstsq,
    # two matrix products instead of a factorisation per call on thousands of profiles)
    Q, _ = np.linalg.qr(np.vander(t, order + 1))
    return z - (z @ Q) @ Q.T


def detrend_map(z: np.ndarray, dx_mm: float, dy_mm: float, detrend="tilt") -> np.ndarray:
    """Remove a least-squares 2D polynomial surface (piston, tilt or form) from a map.

    Parameters
    ----------
    z : (Ny, Nx) float64
        Height map, nm; NaN pixels are ignored in the fit and stay NaN.
    dx_mm, dy_mm : float
        Pixel spacing, mm.
    detrend : {"none", "piston", "tilt", "form"} or int
        Total polynomial degree removed.

    Returns
    -------
    (Ny, Nx) float64
    """
    order = _poly_order(detrend)
    if order < 0:
        return z.copy()
    ny, nx = z.shape
    y, x = np.mgrid[0:ny, 0:nx]
    x = (x - (nx - 1) / 2) / max(nx, 1)
    y = (y - (ny - 1) / 2) / max(ny, 1)
    terms = [x**i * y**j for i in range(order + 1) for j in range(order + 1 - i)]
    A = np.stack([t.ravel() for t in terms], axis=1)
    ok = np.isfinite(z.ravel())
    coef, *_ = np.linalg.lstsq(A[ok], z.ravel()[ok], rcond=None)
    return z - (A @ coef).reshape(z.shape)


def _fill_nan_rows(z: np.ndarray) -> tuple[np.ndarray, int]:
    """Linear interpolation of NaN samples along each row (ends held constant)."""
    z = z.copy()
    n_filled = 0
    idx = np.arange(z.shape[1])
    for r in range(z.shape[0]):
        bad = ~np.isfinite(z[r])
        if bad.any():
            good = ~bad
            if good.sum() < 2:
                continue
            z[r, bad] = np.interp(idx[bad], idx[good], z[r, good])
            n_filled += int(bad.sum())
    return z, n_filled


# --- 1D ----------------------------------------------------------------------------------


def psd_1d(z_nm, dx_mm: float, *, window: str = "hann", detrend="tilt", nan: str = "drop",
           tukey_alpha: float = 0.25, axis: int = -1) -> PSD:
    """One-sided 1D PSD of a profile, or the average over the profiles (rows) of a map.

    Parameters
    ----------
    z_nm : (N,) or (P, N) array_like
        Heights, nm; each row is one profile sampled every ``dx_mm``.
    dx_mm : float
        Sampling interval along the profile, mm.
    window : {"hann", "tukey", "none"}
        Taper, power-corrected by ``mean(w**2)``.
    detrend : {"none", "piston", "tilt", "form"} or int
        Polynomial removed from each profile before the transform (the mean is
        always removed afterwards, so the DC bin carries no power).
    nan : {"drop", "interpolate", "raise"}
        Missing samples: drop the profiles that contain any, linearly
        interpolate them along the profile, or raise. What was done is recorded
        in ``params`` (``n_profiles_dropped``, ``n_samples_interpolated``).
    tukey_alpha : float
        Tapered fraction for the Tukey window.
    axis : int
        Axis along which the profiles run (for 2D input).

    Returns
    -------
    PSD
        ``kind="1d"``, ``units="nm^2 mm"``, frequencies ``k / (N dx)`` for
        ``k = 1 .. N//2`` in 1/mm.

    Raises
    ------
    ParameterError
        Bad sampling, too few samples, unknown options, or no usable profile.
    """
    z = np.asarray(z_nm, dtype=np.float64)
    if z.ndim == 1:
        z = z[None, :]
    elif z.ndim == 2:
        if axis in (0, -2):
            z = z.T
    else:
        raise ParameterError(f"psd_1d needs a profile (N,) or profiles (P, N), got shape {z.shape}.")
    if not (np.isfinite(dx_mm) and dx_mm > 0):
        raise ParameterError(f"dx_mm must be a positive sampling interval in mm, got {dx_mm}.")
    if nan not in _NAN_POLICIES:
        raise ParameterError(f"unknown nan policy {nan!r}.", f"Use one of {_NAN_POLICIES}.")
    n = z.shape[1]
    if n < 8:
        raise ParameterError(f"a profile needs at least 8 samples for a PSD, got {n}.")
    bad_rows = ~np.isfinite(z).all(axis=1)
    n_dropped = 0
    n_interp = 0
    if bad_rows.any():
        if nan == "raise":
            raise ParameterError(f"{int((~np.isfinite(z)).sum())} samples are NaN or infinite.",
                                 "Skip those profiles with --nan drop or fill them with --nan interpolate "
                                 "(nan='drop' / nan='interpolate' in Python).")
        if nan == "drop":
            n_dropped = int(bad_rows.sum())
            z = z[~bad_rows]
        else:
            z, n_interp = _fill_nan_rows(z)
            still = ~np.isfinite(z).all(axis=1)
            n_dropped = int(still.sum())
            z = z[~still]
    if z.shape[0] == 0:
        raise ParameterError("no profile without missing samples is left.",
                             "Use --nan interpolate (nan='interpolate' in Python) or crop the data to its valid part.")
    x = np.arange(n) * dx_mm
    zd = detrend_profiles(z, x, detrend)
    zd -= zd.mean(axis=1, keepdims=True)
    variance = float(np.mean(zd**2))
    w = window_1d(n, window, tukey_alpha)
    zd *= w
    import scipy.fft as sfft  # threads, and the periodogram summed over blocks of profiles (no full complex copy)

    spec = np.zeros(n // 2 + 1)
    for r0 in range(0, zd.shape[0], 512):
        X = sfft.rfft(zd[r0:r0 + 512], axis=1, workers=2)
        spec += np.sum(X.real**2 + X.imag**2, axis=0)
    p = (spec / zd.shape[0]) * dx_mm / (n * np.mean(w**2))
    p[1:] *= 2.0
    if n % 2 == 0:
        p[-1] /= 2.0  # the Nyquist bin has no negative-frequency twin
    f = np.fft.rfftfreq(n, d=dx_mm)
    params = {
        "window": window, "detrend": detrend if not isinstance(detrend, np.integer) else int(detrend),
        "dx_mm": float(dx_mm), "n_samples": int(n), "n_profiles": int(z.shape[0]),
        "n_profiles_dropped": n_dropped, "n_samples_interpolated": n_interp, "nan_policy": nan,
        "df_per_mm": float(1.0 / (n * dx_mm)), "variance_nm2": variance, "sided": "one",
        "convention": "ISO 10110-8 (one-sided: sum(psd)*df = variance)",
    }
    if window == "tukey":
        params["tukey_alpha"] = tukey_alpha
    return PSD(f[1:], p[1:], kind="1d", units="nm^2 mm", params=params)


# --- 2D ----------------------------------------------------------------------------------


def _prepare_map(map_nm, dx_mm, dy_mm, nan, max_nan_fraction):
    z = np.array(map_nm, dtype=np.float64)
    if z.ndim != 2 or min(z.shape) < 8:
        raise ParameterError(f"a 2D PSD needs a map of at least 8 x 8 pixels, got shape {z.shape}.")
    for name, d in (("dx_mm", dx_mm), ("dy_mm", dy_mm)):
        if not (np.isfinite(d) and d > 0):
            raise ParameterError(f"{name} must be a positive pixel spacing in mm, got {d}.")
    bad = ~np.isfinite(z)
    n_bad = int(bad.sum())
    frac = n_bad / z.size
    if n_bad:
        if nan == "raise":
            raise ParameterError(f"{n_bad} pixels ({100 * frac:.2f} %) are NaN.",
                                 "Fill them with --nan interpolate (nan='interpolate' in Python), or crop the map.")
        if nan == "drop":
            raise ParameterError("--nan drop applies to profiles, not to a 2D map's radial PSD.",
                                 "Use --nan interpolate (nan='interpolate' in Python) or crop the map.")
        if frac > max_nan_fraction:
            raise ParameterError(
                f"{100 * frac:.1f} % of the pixels are NaN, more than max_nan_fraction={max_nan_fraction}.",
                "Crop the map to its valid part or raise max_nan_fraction.")
        # Fill along rows, then along columns for rows that were all NaN.
        z, _ = _fill_nan_rows(z)
        zt, _ = _fill_nan_rows(z.T)
        z = zt.T
        if not np.isfinite(z).all():
            raise ParameterError("could not interpolate the missing pixels (whole rows and columns missing).",
                                 "Crop the map to its valid part.")
    return z, n_bad


def psd_2d(map_nm, dx_mm: float, dy_mm: float | None = None, *, window: str = "hann", detrend="tilt",
           nan: str = "interpolate", max_nan_fraction: float = 0.2, tukey_alpha: float = 0.25) -> PSD2D:
    """Two-sided 2D PSD of a height map.

    Parameters
    ----------
    map_nm : (Ny, Nx) array_like
        Heights, nm; rows along y, columns along x.
    dx_mm, dy_mm : float
        Pixel spacing along x and y, mm (``dy_mm`` defaults to ``dx_mm``).
    window : {"hann", "tukey", "none"}
        Separable taper ``w(y) w(x)``, power-corrected.
    detrend : {"none", "piston", "tilt", "form"} or int
        2D polynomial removed before the transform.
    nan : {"interpolate", "raise"}
        Missing pixels are linearly interpolated along rows (then columns) and
        the count is recorded in ``params["n_pixels_interpolated"]``, or raise.
    max_nan_fraction : float
        Refuse to interpolate more than this fraction of the pixels.
    tukey_alpha : float
        Tapered fraction for the Tukey window.

    Returns
    -------
    PSD2D
        ``psd`` (Ny, Nx) in nm^2 mm^2, fft-shifted, with ``sum * dfx * dfy`` = variance.
    """
    dy_mm = dx_mm if dy_mm is None else dy_mm
    if nan not in _NAN_POLICIES:
        raise ParameterError(f"unknown nan policy {nan!r}.", "Use 'interpolate' or 'raise'.")
    z, n_bad = _prepare_map(map_nm, dx_mm, dy_mm, nan, max_nan_fraction)
    z = detrend_map(z, dx_mm, dy_mm, detrend)
    z = z - z.mean()
    variance = float(np.mean(z**2))
    ny, nx = z.shape
    w = np.outer(window_1d(ny, window, tukey_alpha), window_1d(nx, window, tukey_alpha))
    zw = z * w
    spec = np.abs(np.fft.fft2(zw)) ** 2
    p = spec * dx_mm * dy_mm / (nx * ny * np.mean(w**2))
    p[0, 0] = 0.0  # piston carries no surface error
    p = np.fft.fftshift(p)
    fx = np.fft.fftshift(np.fft.fftfreq(nx, d=dx_mm))
    fy = np.fft.fftshift(np.fft.fftfreq(ny, d=dy_mm))
    params = {"window": window, "detrend": detrend, "dx_mm": float(dx_mm), "dy_mm": float(dy_mm),
              "shape": [int(ny), int(nx)], "n_pixels_interpolated": n_bad, "nan_policy": nan,
              "dfx_per_mm": float(1 / (nx * dx_mm)), "dfy_per_mm": float(1 / (ny * dy_mm)),
              "variance_nm2": variance, "sided": "two"}
    return PSD2D(fx, fy, p, params=params)


def radial_psd(map_or_psd2d, dx_mm: float | None = None, dy_mm: float | None = None, **kwargs) -> PSD:
    """Azimuthally averaged 2D PSD.

    Parameters
    ----------
    map_or_psd2d : (Ny, Nx) array_like or PSD2D
        A height map in nm (then ``dx_mm`` is required and ``kwargs`` go to
        :func:`psd_2d`) or an already computed 2D PSD.
    dx_mm, dy_mm : float, optional
        Pixel spacing, mm (only for a map).

    Returns
    -------
    PSD
        ``kind="2d-radial"``, ``units="nm^2 mm^2"``; bins of width
        ``df = max(dfx, dfy)`` centred on ``k df``, ``k = 1 .. min(Nx, Ny)//2``.
        ``params["variance_nm2"]`` is the map variance; the band RMS is
        ``sqrt(sum 2 pi f psd df)``.
    """
    if isinstance(map_or_psd2d, PSD2D):
        p2 = map_or_psd2d
    else:
        if dx_mm is None:
            raise ParameterError("radial_psd of a map needs dx_mm (pixel spacing in mm).")
        p2 = psd_2d(map_or_psd2d, dx_mm, dy_mm, **kwargs)
    dfx = p2.params.get("dfx_per_mm", p2.fx[1] - p2.fx[0])
    dfy = p2.params.get("dfy_per_mm", p2.fy[1] - p2.fy[0])
    df = max(dfx, dfy)
    FX, FY = np.meshgrid(p2.fx, p2.fy)
    fr = np.hypot(FX, FY)
    k = np.rint(fr / df).astype(np.int64)
    kmax = min(len(p2.fx), len(p2.fy)) // 2
    sums = np.bincount(k.ravel(), weights=p2.psd.ravel(), minlength=kmax + 1)[: kmax + 1]
    counts = np.bincount(k.ravel(), minlength=kmax + 1)[: kmax + 1]
    kk = np.arange(1, kmax + 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = sums[1:] / counts[1:]
    params = dict(p2.params)
    params.update({"df_per_mm": float(df), "average": "azimuthal", "sided": "radial"})
    return PSD(kk * df, np.nan_to_num(mean), kind="2d-radial", units="nm^2 mm^2", params=params)


# --- band figures --------------------------------------------------------------------------


def _band_mask(psd: PSD, f_lo_per_mm: float, f_hi_per_mm: float) -> np.ndarray:
    if not (0 <= f_lo_per_mm < f_hi_per_mm):
        raise ParameterError(f"band must satisfy 0 <= f_lo < f_hi (1/mm), got ({f_lo_per_mm}, {f_hi_per_mm}).")
    m = (psd.freq >= f_lo_per_mm) & (psd.freq <= f_hi_per_mm)
    if not m.any():
        raise ParameterError(
            f"the band {f_lo_per_mm}-{f_hi_per_mm} 1/mm holds no frequency of this PSD "
            f"(it spans {psd.freq[0]:.4g}-{psd.freq[-1]:.4g} 1/mm).",
            "Use a longer profile/map for low frequencies or finer sampling for high ones, or change the band.")
    return m


def band_coverage(psd: PSD, f_lo_per_mm: float, f_hi_per_mm: float) -> tuple[float, float]:
    """Part of the band ``[f_lo, f_hi]`` (1/mm) that the PSD actually resolves, as ``(lo, hi)`` in 1/mm."""
    return max(f_lo_per_mm, float(psd.freq[0])), min(f_hi_per_mm, float(psd.freq[-1]))


def band_rms(psd: PSD, f_lo_per_mm: float, f_hi_per_mm: float) -> float:
    """RMS height (nm) of the frequencies in ``[f_lo, f_hi]`` (1/mm).

    ``sqrt(sum psd df)`` for a 1D PSD, ``sqrt(sum 2 pi f psd df)`` for a radial 2D PSD.
    Over the whole spectrum this equals the standard deviation of the detrended data.
    """
    m = _band_mask(psd, f_lo_per_mm, f_hi_per_mm)
    df = psd.df
    if psd.kind == "1d":
        return float(np.sqrt(np.sum(psd.psd[m]) * df))
    return float(np.sqrt(np.sum(2 * np.pi * psd.freq[m] * psd.psd[m]) * df))


def band_average(psd: PSD, f_lo_per_mm: float = 1.0, f_hi_per_mm: float = 100.0) -> float:
    """Average PSD over the band ``[f_lo, f_hi]`` (1/mm), in the PSD's own units.

    The arithmetic mean over the (uniformly spaced) frequency bins in the band,
    i.e. ``int PSD df / bandwidth`` — the paper's "average PSD in 10^3-10^5 1/m".
    """
    m = _band_mask(psd, f_lo_per_mm, f_hi_per_mm)
    return float(np.mean(psd.psd[m]))


def suppression_ratio(before: PSD, after: PSD, band: tuple[float, float] = PAPER_BAND_PER_MM) -> float:
    """Suppression ratio ``1 - avg_after / avg_before`` of the band-average PSD.

    Parameters
    ----------
    before, after : PSD
        Spectra of the same kind and units.
    band : (float, float)
        Frequency band in 1/mm (default 1-100 1/mm = 10^3-10^5 1/m).

    Returns
    -------
    float
        1 = error removed, 0 = unchanged, negative = made worse.
    """
    if before.kind != after.kind or before.units != after.units:
        raise ParameterError(f"cannot compare a {before.kind} PSD ({before.units}) with a {after.kind} PSD "
                             f"({after.units}).", "Compute both with the same function.")
    b = band_average(before, *band)
    if b <= 0:
        raise ParameterError("the 'before' PSD has no power in the band; the ratio is undefined.")
    return float(1.0 - band_average(after, *band) / b)


def find_peaks(psd: PSD, spacing_mm: float | None = None, *, min_excess_decades: float = 0.3, n_sigma: float = 6.0,
               band: tuple[float, float] | None = None, max_harmonic: int = 6, max_peaks: int = 10,
               smooth_bins: int = 3, baseline_bins: int = 31) -> list[dict[str, Any]]:
    """Spectral peaks, named after the path spacing and its harmonics.

    A peak is a local maximum of the (lightly smoothed) log10 PSD that stands
    at least ``min_excess_decades`` above the running median of log10 PSD over
    ``baseline_bins`` bins (the local broadband level) and at least
    ``n_sigma`` robust standard deviations (1.4826 MAD) of that excess over the
    whole spectrum, so a single noisy profile needs a stronger peak than an
    average of many. Comparing with a local
    median rather than with neighbouring dips keeps the speckle of a single,
    unaveraged profile from being reported as peaks.

    Parameters
    ----------
    psd : PSD
        Spectrum to search.
    spacing_mm : float, optional
        Path spacing, mm. Peaks within ``max(2 df, 3 %)`` of ``n / spacing_mm``
        are named ``"1/spacing"``, ``"2/spacing"``...; at ``1/(2 spacing)`` (period
        of a bidirectional raster) ``"1/(2 spacing)"``.
    min_excess_decades : float
        Minimum height above the local baseline in log10 units (0.3 = factor 2).
    n_sigma : float
        Minimum height in robust standard deviations of the excess.
    band : (float, float), optional
        Restrict the search to this band, 1/mm.
    max_harmonic : int
        Highest harmonic that gets a name.
    max_peaks : int
        Keep the strongest ones.
    smooth_bins : int
        Moving-average length applied to log10(PSD) before searching (1 = none).
    baseline_bins : int
        Width of the running-median baseline, in bins.

    Returns
    -------
    list of dict
        ``freq_per_mm``, ``wavelength_mm``, ``psd`` (value at the peak, PSD
        units), ``excess_decades``, ``harmonic`` (int or None) and ``label``;
        strongest first.
    """
    from scipy.ndimage import median_filter, uniform_filter1d

    logp = np.log10(np.maximum(psd.psd, np.finfo(float).tiny))
    if smooth_bins > 1:
        logp = uniform_filter1d(logp, smooth_bins, mode="nearest")
    base = median_filter(logp, size=max(3, baseline_bins), mode="nearest")
    excess = logp - base
    sigma = 1.4826 * float(np.median(np.abs(excess - np.median(excess))))
    threshold = max(min_excess_decades, n_sigma * sigma)
    # local maxima above the threshold (numpy, to avoid importing scipy.signal)
    inner = (excess[1:-1] >= excess[:-2]) & (excess[1:-1] > excess[2:]) & (excess[1:-1] >= threshold)
    idx = np.flatnonzero(inner) + 1
    out = []
    f1 = 1.0 / spacing_mm if spacing_mm else None
    for i in idx:
        f = float(psd.freq[i])
        if band is not None and not (band[0] <= f <= band[1]):
            continue
        label, harmonic = "", None
        if f1:
            n = int(round(f / f1))
            if 1 <= n <= max_harmonic and abs(f - n * f1) <= max(2.0 * psd.df, 0.03 * n * f1):
                harmonic = n
                label = "1/spacing" if n == 1 else f"{n}/spacing"
            elif abs(f - 0.5 * f1) <= max(2.0 * psd.df, 0.03 * 0.5 * f1):
                label = "1/(2 spacing)"
        out.append({"freq_per_mm": f, "wavelength_mm": 1.0 / f, "psd": float(psd.psd[i]),
                    "excess_decades": float(excess[i]), "harmonic": harmonic, "label": label})
    out.sort(key=lambda d: -d["excess_decades"])
    return out[:max_peaks]
