"""Fair figures of a polished residual: band RMS, lattice peaks, PVn (issue 18).

The paper's before/after suppression of the band-average PSD mixes the initial
roughness the pad smooths, the broadband removal noise and the periodic marks
the path prints. The functions here judge the *residual* of a run (start
minus removal) on its own, as the literature that simulates path ripple does:

* :func:`detrend_residual` removes mean, tilt and power (ISO 10110-8) over the
  valid pixels;
* :func:`band_rms_nm` is the RMS of the residual's content with spatial
  frequency ``f_lo <= |f| <= f_hi`` (the paper's band 10^3-10^5 1/m), from the
  2D PSD; :func:`band_powers_nm2` splits its square over rings of frequency
  (where in the band a residual's power sits);
* :func:`lattice_peak_db` is the largest PSD peak at the path's own
  frequencies (:func:`lattice_frequencies`) over the local background, in dB,
  from the profile PSDs of the rows and of the columns;
* :func:`pvn` is the residual PV over the mean removal depth;
* :func:`ripple_amplitude` is the first-harmonic amplitude of a ripple of a
  given wavelength (the closed-form check of the simulation).

Everything is computed on one window: the mask (valid pixels), tapered to
zero over :func:`taper_width_mm` inside its edge (a raised cosine of the
distance to the edge), so a non-rectangular mask leaks no edge step into the
band. All spectra are power-normalised by ``sum(w^2)``, so Parseval holds:
over all frequencies the band power is the windowed variance.

Units: heights nm, lengths mm, frequencies 1/mm. See docs/simulation-metrics.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._version import __version__
from ..errors import ParameterError
from ..psd.core import PAPER_BAND_PER_MM
from .lattice import _BLOCK_ROWS, _check_freqs, _lattice_db, lattice_frequencies, nominal_frequencies, path_frequencies

__all__ = ["FairMetrics", "PAPER_BAND_PER_MM", "band_powers_nm2", "band_rms_nm", "detrend_residual", "fair_metrics",
           "lattice_frequencies", "lattice_peak_db", "nominal_frequencies", "path_frequencies", "pvn",
           "ripple_amplitude", "taper_width_mm", "time_density_peak_db"]



# --- inputs -------------------------------------------------------------------------------


def _as_map(map_nm, name: str = "map_nm") -> np.ndarray:
    z = np.asarray(map_nm, dtype=np.float64)
    if z.ndim != 2 or min(z.shape) < 8:
        raise ParameterError(f"{name} must be a 2D height map of at least 8 x 8 pixels, got shape {z.shape}.")
    return z


def _check_dx(dx_mm: float) -> float:
    if not (np.isfinite(dx_mm) and dx_mm > 0):
        raise ParameterError(f"dx_mm must be a positive pixel pitch in mm, got {dx_mm}.")
    return float(dx_mm)


def _check_band(band) -> tuple[float, float]:
    try:
        lo, hi = (float(b) for b in band)
    except (TypeError, ValueError):
        raise ParameterError(f"band must be a pair (f_lo, f_hi) in 1/mm, got {band!r}.") from None
    if not (0 <= lo < hi and np.isfinite(hi)):
        raise ParameterError(f"band must satisfy 0 <= f_lo < f_hi (1/mm), got ({lo}, {hi}).")
    return lo, hi


def _valid(z: np.ndarray, mask) -> np.ndarray:
    """Boolean (Ny, Nx): inside the mask and finite."""
    ok = np.isfinite(z)
    if mask is not None:
        m = np.asarray(mask)
        if m.shape != z.shape:
            raise ParameterError(f"mask has shape {m.shape} but the map has shape {z.shape}.",
                                 "Give a boolean mask of the map's shape (True = evaluate this pixel).")
        if m.dtype != bool:
            raise ParameterError(f"mask must be boolean (True = evaluate this pixel), got dtype {m.dtype}.")
        ok &= m
    if not ok.any():
        raise ParameterError("no valid pixel: the mask is empty or every pixel inside it is NaN.",
                             "Give a mask that covers part of the map, and a map with finite heights there.")
    return ok


def _bbox(ok: np.ndarray) -> tuple[slice, slice]:
    rows = np.flatnonzero(ok.any(axis=1))
    cols = np.flatnonzero(ok.any(axis=0))
    return slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1)


# --- detrending ---------------------------------------------------------------------------


def detrend_residual(map_nm, dx_mm: float, mask=None) -> np.ndarray:
    """Remove mean, tilt and power (least squares over the valid pixels), as ISO 10110-8 asks.

    Fits ``c0 + c1 x + c2 y + c3 (x^2 + y^2)`` over the pixels inside ``mask``
    that are finite, and subtracts it.

    Parameters
    ----------
    map_nm : (Ny, Nx) array_like
        Heights, nm; rows along y, columns along x.
    dx_mm : float
        Pixel pitch, mm.
    mask : (Ny, Nx) bool, optional
        True where the map is evaluated (default: every finite pixel).

    Returns
    -------
    (Ny, Nx) float64
        Residual, nm; NaN outside the mask and where the map is NaN.

    Raises
    ------
    ParameterError
        Bad shape or pitch, an empty mask, or fewer than 4 valid pixels spread
        over two dimensions (the four terms are then not determined).
    """
    z = _as_map(map_nm)
    dx = _check_dx(dx_mm)
    ok = _valid(z, mask)
    ny, nx = z.shape
    # centred, scaled coordinates (mm / half-size) keep the 4x4 normal equations well conditioned
    scale = 0.5 * max(nx, ny) * dx
    xs = (np.arange(nx) - (nx - 1) / 2) * dx / scale
    ys = (np.arange(ny) - (ny - 1) / 2) * dx / scale
    okf = ok.astype(np.float64)
    # the terms are 1, x, y, r2 = x^2 + y^2; every sum over the valid pixels is a moment
    # sum x^a y^b (weighted), computed as ys^b @ W @ xs^a without building the (N, 4) design matrix
    px = [xs**k for k in range(5)]
    py = [ys**k for k in range(5)]

    def moments(W, pairs):
        cols = {a: W @ px[a] for a in {a for a, _ in pairs}}
        return {(a, b): float(py[b] @ cols[a]) for a, b in pairs}

    # each term as {(a, b): coefficient} of x^a y^b
    terms = [{(0, 0): 1.0}, {(1, 0): 1.0}, {(0, 1): 1.0}, {(2, 0): 1.0, (0, 2): 1.0}]
    pairs = {(a1 + a2, b1 + b2) for t1 in terms for t2 in terms for a1, b1 in t1 for a2, b2 in t2}
    M = moments(okf, pairs)
    ata = np.array([[sum(c1 * c2 * M[(a1 + a2, b1 + b2)] for (a1, b1), c1 in t1.items() for (a2, b2), c2 in t2.items())
                     for t2 in terms] for t1 in terms])
    if np.linalg.matrix_rank(ata, tol=1e-10 * max(1.0, float(np.abs(ata).max()))) < 4:
        raise ParameterError(f"the {int(ok.sum())} valid pixels do not determine mean, tilt and power.",
                             "Give a mask that covers a 2D area of the map (not a single line or point).")
    lin = [(0, 0), (1, 0), (0, 1), (2, 0), (0, 2)]

    def fit(values):
        m = moments(values, lin)
        atz = np.array([sum(c * m[k] for k, c in t.items()) for t in terms])
        return np.linalg.solve(ata, atz)

    def subtract(values, c):
        values -= (c[0] + c[1] * xs + c[3] * px[2])[None, :]  # separable: a row part and a column part
        values -= (c[2] * ys + c[3] * py[2])[:, None]
        values[~ok] = 0.0
        return values

    res = subtract(np.where(ok, z, 0.0), fit(np.where(ok, z, 0.0)))
    res = subtract(res, fit(res))  # one step of iterative refinement: the fit is removed to round-off
    res[~ok] = np.nan
    return res


# --- the evaluation window ------------------------------------------------------------------


def taper_width_mm(band=PAPER_BAND_PER_MM) -> float:
    """Width of the window's edge taper, mm: two periods of the band's longest wavelength.

    A raised-cosine taper this wide moves the edge's leakage below the band;
    for ``f_lo = 0`` there is no longest wavelength and 2 mm is used.
    """
    lo, _ = _check_band(band)
    return 2.0 / lo if lo > 0 else 2.0


def _window(ok: np.ndarray, dx_mm: float, taper_mm: float) -> np.ndarray:
    """Edge-tapered window of the valid pixels: 1 inside, a raised cosine over ``taper_mm`` at the edge, 0 outside.

    A full rectangle gets the separable product of two Tukey-like tapers (each
    profile's window is then smooth, so its side lobes fall fast); any other
    mask gets the raised cosine of the Euclidean distance to the nearest
    invalid pixel. The taper is capped at half the largest inscribed distance
    so a small mask keeps a flat top.
    """
    ny, nx = ok.shape

    def ramp(d, t):
        return np.where(d >= t, 1.0, 0.5 - 0.5 * np.cos(np.pi * np.clip(d, 0, t) / t))

    if ok.all():
        dy = np.minimum(np.arange(ny) + 1, ny - np.arange(ny)) * dx_mm
        dxx = np.minimum(np.arange(nx) + 1, nx - np.arange(nx)) * dx_mm
        t = min(taper_mm, 0.5 * float(min(dy.max(), dxx.max())))
        return np.outer(ramp(dy, t), ramp(dxx, t))
    from scipy.ndimage import distance_transform_edt

    d = distance_transform_edt(np.pad(ok, 1))[1:-1, 1:-1] * dx_mm
    w = ramp(d, min(taper_mm, 0.5 * float(d.max())))
    w[~ok] = 0.0
    return w


def _prepared(map_nm, dx_mm, band, mask):
    """Crop to the valid pixels' bounding box; return (z with 0 outside, window, valid, band)."""
    z = _as_map(map_nm)
    dx = _check_dx(dx_mm)
    b = _check_band(band)
    ok = _valid(z, mask)
    sy, sx = _bbox(ok)
    z, ok = z[sy, sx], ok[sy, sx]
    if min(z.shape) < 8:
        raise ParameterError(f"the valid pixels span only {z.shape[0]} x {z.shape[1]} pixels.",
                             "Evaluate an area of at least 8 x 8 pixels.")
    w = _window(ok, dx, taper_width_mm(b))
    zz = np.where(ok, z, 0.0)
    zz = zz - float(np.sum(zz * w * w) / np.sum(w * w))  # the window-weighted mean carries no band power
    zz[~ok] = 0.0
    return zz, w, ok, b


# --- band RMS -----------------------------------------------------------------------------


def band_rms_nm(map_nm, dx_mm: float, band=PAPER_BAND_PER_MM, mask=None) -> float:
    """RMS (nm) of the map's content with spatial frequency ``f_lo <= |f| <= f_hi``.

    From the 2D PSD of the windowed map: ``sqrt(sum_{f in band} |Z(f)|^2 /
    (N sum w^2))`` with ``Z`` the DFT of ``z w`` over N pixels (Parseval: over
    all frequencies this is the window-weighted variance). The 2D PSD rather
    than profile PSDs because the band is then the same for a ripple of any
    orientation: a raster ripple counts fully whether its passes run along x,
    y or a diagonal, while the average of row and column profile PSDs would
    halve an axis-aligned ripple's power and fold a diagonal one to another
    frequency.

    Parameters
    ----------
    map_nm : (Ny, Nx) array_like
        Heights, nm (normally :func:`detrend_residual`'s output; only the
        window-weighted mean is removed here).
    dx_mm : float
        Pixel pitch, mm.
    band : (float, float)
        ``(f_lo, f_hi)``, 1/mm (default 1-100 1/mm = 10^3-10^5 1/m). Content above
        the map's Nyquist frequency ``1/(2 dx)`` is not resolved.
    mask : (Ny, Nx) bool, optional
        True where the map is evaluated; NaN pixels are left out as well.

    Returns
    -------
    float
        nm.
    """
    z, w, _, (lo, hi) = _prepared(map_nm, dx_mm, band, mask)
    return _band_rms(z, w, dx_mm, lo, hi)


def _spectrum_blocks(z: np.ndarray, w: np.ndarray, dx_mm: float):
    """The windowed map's one-sided power spectrum in blocks of rows: yields ``(|f|^2 (1/mm^2), power)`` per block.

    The half spectrum stands for both halves, except the columns without a twin (0 and Nyquist); in blocks of
    rows, so that no full-size frequency or mask array is made. The powers sum to the windowed map's squared
    sum times ``z.size`` (divide by ``z.size * sum(w^2)`` for nm^2)."""
    import scipy.fft as sfft

    ny, nx = z.shape
    Z = sfft.rfft2(z * w, workers=2)
    fx = sfft.rfftfreq(nx, d=dx_mm)
    fy = sfft.fftfreq(ny, d=dx_mm)
    mult = np.full(len(fx), 2.0)
    mult[0] = 1.0
    if nx % 2 == 0:
        mult[-1] = 1.0
    for r0 in range(0, ny, _BLOCK_ROWS):
        r1 = min(ny, r0 + _BLOCK_ROWS)
        blk = Z[r0:r1]
        yield fx[None, :] ** 2 + fy[r0:r1, None] ** 2, (blk.real ** 2 + blk.imag ** 2) * mult[None, :]


def _band_rms(z: np.ndarray, w: np.ndarray, dx_mm: float, lo: float, hi: float) -> float:
    """:func:`band_rms_nm` of a prepared map (0 outside the window) and its window."""
    power = 0.0
    for fr2, pw in _spectrum_blocks(z, w, dx_mm):
        power += float(np.sum(pw[(fr2 >= lo * lo) & (fr2 <= hi * hi)]))
    return float(np.sqrt(power / (z.size * np.sum(w * w))))


def band_powers_nm2(map_nm, dx_mm: float, edges, mask=None) -> np.ndarray:
    """The residual's power in rings of spatial frequency, nm^2: where in the band it sits.

    The same window and normalisation as :func:`band_rms_nm`: ring i holds the
    content with ``edges[i] <= |f| < edges[i + 1]`` (the last ring closed at
    ``edges[-1]``), so over rings that span a band their sum is that band's
    ``band_rms_nm ** 2`` (tested). Used to find which frequencies decide a
    path's band RMS (docs/simulation.md, "Where the walks' band RMS comes from").

    Parameters
    ----------
    map_nm : (Ny, Nx) array_like
        Heights, nm (normally :func:`detrend_residual`'s output).
    dx_mm : float
        Pixel pitch, mm.
    edges : (K + 1,) array_like
        Ring edges, 1/mm, increasing, ``edges[0] >= 0``.
    mask : (Ny, Nx) bool, optional
        True where the map is evaluated.

    Returns
    -------
    (K,) float64
        nm^2 per ring.
    """
    e = np.asarray(edges, dtype=np.float64).ravel()
    if e.size < 2 or not np.all(np.isfinite(e)) or e[0] < 0 or np.any(np.diff(e) <= 0):
        raise ParameterError(f"edges must be at least two increasing frequencies >= 0 (1/mm), got {edges!r}.",
                             "Give ring edges such as (1, 1.5, 2, 3, 100).")
    z, w, _, _ = _prepared(map_nm, dx_mm, (float(e[0]), float(e[-1])), mask)
    out = np.zeros(e.size - 1)
    for fr2, pw in _spectrum_blocks(z, w, dx_mm):
        f = np.sqrt(fr2).ravel()
        ring = np.searchsorted(e, f, side="right") - 1
        ring[f == e[-1]] = e.size - 2  # the last ring is closed
        ok = (ring >= 0) & (ring < e.size - 1)
        out += np.bincount(ring[ok], weights=pw.ravel()[ok], minlength=e.size - 1)
    return out / (z.size * np.sum(w * w))


# --- lattice peaks ------------------------------------------------------------------------


def lattice_peak_db(map_nm, dx_mm: float, spacing_mm: float, *, band=PAPER_BAND_PER_MM, mask=None,
                    n_harmonics: int = 3, frequencies=None) -> float:
    """The largest PSD peak at the path's own frequencies over the local background, dB.

    For each frequency of :func:`lattice_frequencies` inside ``band`` (and
    below 0.9 of the Nyquist frequency), in the profile PSD of the rows and in
    that of the columns: the largest PSD value within ``max(2 df, 2 %)`` of it,
    over the median PSD within ``max(25 %, 8 df)`` around it with every
    lattice peak zone left out (``df = 1 / profile length``); the result is the
    largest of these ratios, as ``10 log10(ratio)``. 0 dB = no peak; a peak
    ``k`` times the background is ``10 log10 k`` dB. Noise alone reads a few
    tenths of a dB above 0 on a small map (the maximum of a few bins over a
    median).

    Profile PSDs rather than the 2D PSD because each of their bins averages
    many profiles, so the background is smooth and a peak is read against it
    without the chi-square scatter of single 2D bins; rows and columns are
    kept apart (an axis-aligned ripple shows in one of them only) and the
    diagonal lattice vectors (1/s, +-1/s) show at 1/s in both.

    Parameters
    ----------
    map_nm : (Ny, Nx) array_like
        Heights, nm (normally :func:`detrend_residual`'s output).
    dx_mm : float
        Pixel pitch, mm.
    spacing_mm : float
        Path spacing, mm.
    band : (float, float)
        1/mm; only lattice frequencies inside it count.
    mask : (Ny, Nx) bool, optional
        True where the map is evaluated.
    n_harmonics : int
        Harmonics of ``1/spacing`` looked at.
    frequencies : (K,) array_like, optional
        Look at these frequencies (1/mm, e.g. :func:`path_frequencies`) instead
        of :func:`lattice_frequencies` of ``spacing_mm``.

    Returns
    -------
    float
        dB.

    Raises
    ------
    ParameterError
        No lattice frequency lies in the band, below Nyquist, with enough
        resolved background around it (the map is too small or too coarse).
    """
    z, w, _, (lo, hi) = _prepared(map_nm, dx_mm, band, mask)
    targets = lattice_frequencies(spacing_mm, n_harmonics) if frequencies is None else _check_freqs(frequencies)
    return _lattice_db(z, w, dx_mm, spacing_mm, lo, hi, targets)


# --- PV, ripple ---------------------------------------------------------------------------


def pvn(map_nm, depth_nm: float, mask=None) -> float:
    """Ripple PV normalised by the mean removal depth (dimensionless).

    Parameters
    ----------
    map_nm : (Ny, Nx) array_like
        Residual, nm (normally detrended).
    depth_nm : float
        Mean depth removed, nm (> 0).
    mask : (Ny, Nx) bool, optional
        True where the map is evaluated; NaN pixels are left out.

    Returns
    -------
    float
        ``(max - min) / depth_nm`` over the valid pixels.
    """
    z = _as_map(map_nm)
    if not (np.isfinite(depth_nm) and depth_nm > 0):
        raise ParameterError(f"depth_nm must be the positive mean removal depth in nm, got {depth_nm}.",
                             "PVn needs a run that removed material.")
    v = z[_valid(z, mask)]
    return float((v.max() - v.min()) / depth_nm)


def ripple_amplitude(map_nm, dx_mm: float, wavelength_mm: float, axis: int = 0) -> float:
    """First-harmonic amplitude of a ripple of wavelength ``wavelength_mm`` along ``axis`` (map units).

    The map is averaged across the other axis to one profile, its mean is
    removed, and the profile is projected onto cos and sin at ``1/wavelength``
    over the largest whole number of periods from its start:
    ``a = (2/M) sum z cos(2 pi x / wavelength)``, likewise ``b``, amplitude
    ``hypot(a, b)``. Exact for a ripple sampled with a whole number of pixels
    per period; otherwise the error is of order one pixel over the length used.

    Parameters
    ----------
    map_nm : (Ny, Nx) array_like
        Heights (no NaN), nm.
    dx_mm : float
        Pixel pitch, mm.
    wavelength_mm : float
        Ripple period, mm (at least 2 pixels, at most the map's length along ``axis``).
    axis : int
        The axis the ripple varies along: 0 = down the rows (y), 1 = along a row (x).

    Returns
    -------
    float
        Amplitude, nm.
    """
    z = _as_map(map_nm)
    dx = _check_dx(dx_mm)
    if axis not in (0, 1, -1, -2):
        raise ParameterError(f"axis must be 0 (y) or 1 (x), got {axis}.")
    if not np.isfinite(z).all():
        raise ParameterError("ripple_amplitude needs a map without NaN.", "Crop the map to its valid part.")
    prof = z.mean(axis=1 - (axis % 2))
    n = len(prof)
    if not (np.isfinite(wavelength_mm) and 2 * dx <= wavelength_mm <= n * dx):
        raise ParameterError(f"wavelength {wavelength_mm} mm must lie between 2 pixels ({2 * dx} mm) and the "
                             f"map's length along axis {axis} ({n * dx} mm).")
    periods = int(np.floor(n * dx / wavelength_mm + 1e-9))
    m = min(n, int(round(periods * wavelength_mm / dx)))
    p = prof[:m] - prof[:m].mean()
    ph = 2 * np.pi * np.arange(m) * dx / wavelength_mm
    return float(np.hypot(2.0 / m * np.dot(p, np.cos(ph)), 2.0 / m * np.dot(p, np.sin(ph))))


# --- time density ---------------------------------------------------------------------------


def time_density_peak_db(xy_mm, time_s, spacing_mm: float, bounds, *, dx_mm: float | None = None,
                         frequencies=None) -> float:
    """The peak the tool's time density shows at a dwell lattice's frequencies, dB (issue 26, Why 3).

    The machine samples come at a constant period, so where they fall is where
    the tool spends its time: a dwell set on a lattice, with a feed that changes
    at every dwell point, prints that lattice into the time density before any
    tool footprint smooths it. Here the samples (in the path's plane) are
    binned into a density map over ``bounds``, each weighted by its time; the
    map's mean is removed and it is tapered by a 2D Hann window; the profile
    PSDs of its rows and of its columns are read at ``frequencies`` (default
    :func:`nominal_frequencies` of ``spacing_mm``: ``1/(2h)``, ``1/h``,
    ``sqrt(2)/h``, ``2/h``) exactly like :func:`lattice_peak_db` (largest value
    near each over the median around it, other targets left out). 0 dB = no
    peak. It needs no removal model, so it judges a path's dwell set and timing
    alone.

    Parameters
    ----------
    xy_mm : (M, 2) array_like
        Sample positions in the path's plane, mm.
    time_s : (M,) array_like
        Time at each sample, s (constant-period samples: the period).
    spacing_mm : float
        The path's spacing ``h`` in that plane, mm.
    bounds : (xmin, ymin, xmax, ymax)
        The window, mm (a centre window well inside the path's region).
    dx_mm : float, optional
        Bin size, mm (default ``h / 8``: 2/h is read at a quarter of Nyquist).
    frequencies : (K,) array_like, optional
        Frequencies to read, 1/mm.

    Returns
    -------
    float
        dB.

    Raises
    ------
    ParameterError
        Shapes that do not match, a window with no sample or fewer than 16 bins a
        side, a bad spacing or bin size.
    """
    xy = np.asarray(xy_mm, dtype=np.float64)
    t = np.asarray(time_s, dtype=np.float64).ravel()
    if xy.ndim != 2 or xy.shape[1] != 2 or len(t) != len(xy):
        raise ParameterError(f"xy_mm must be (M, 2) and time_s (M,), got {xy.shape} and {t.shape}.",
                             "Pass the machine samples' positions and their times.")
    h = float(spacing_mm)
    targets = nominal_frequencies(h) if frequencies is None else _check_freqs(frequencies)
    dx = _check_dx(h / 8.0 if dx_mm is None else dx_mm)
    x0, y0, x1, y1 = (float(b) for b in bounds)
    nx, ny = int(np.floor((x1 - x0) / dx)), int(np.floor((y1 - y0) / dx))
    if min(nx, ny) < 16:
        raise ParameterError(f"the window {bounds} holds {nx} x {ny} bins of {dx:g} mm; at least 16 a side are needed.",
                             "Use a larger window (a few spacings a side at least) or a smaller dx_mm.")
    dens, _, _ = np.histogram2d(xy[:, 1], xy[:, 0], bins=(ny, nx), range=((y0, y0 + ny * dx), (x0, x0 + nx * dx)),
                                weights=t)
    if not dens.any():
        raise ParameterError(f"no sample with time lies in the window {bounds}.", "Give a window the path runs through.")
    w = np.outer(np.hanning(ny + 2)[1:-1], np.hanning(nx + 2)[1:-1])
    z = dens - float(np.sum(dens * w * w) / np.sum(w * w))  # the window-weighted mean carries no peak
    return _lattice_db(z, w, dx, h, 0.0, 0.45 / dx, targets)


# --- all figures ----------------------------------------------------------------------------


@dataclass(frozen=True)
class FairMetrics:
    """The fair figures of one residual (issue 18).

    Attributes
    ----------
    residual_band_rms_nm : float
        :func:`band_rms_nm` of the detrended residual, nm.
    lattice_peak_db : float
        :func:`lattice_peak_db` of the detrended residual, dB.
    pvn : float
        :func:`pvn` of the detrended residual (PV / mean depth).
    residual_rms_nm : float
        RMS of the detrended residual over the valid pixels, nm (all frequencies).
    residual_pv_nm : float
        PV of the detrended residual, nm.
    params : dict
        band, dx_mm, spacing_mm, depth_nm, number of valid pixels, taper width,
        the methods, polishpath version.
    """

    residual_band_rms_nm: float
    lattice_peak_db: float
    pvn: float
    residual_rms_nm: float
    residual_pv_nm: float
    params: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        return {"residual_band_rms_nm": self.residual_band_rms_nm, "lattice_peak_db": self.lattice_peak_db,
                "pvn": self.pvn, "residual_rms_nm": self.residual_rms_nm, "residual_pv_nm": self.residual_pv_nm,
                "params": dict(self.params)}


def fair_metrics(residual_nm, dx_mm: float, spacing_mm: float, depth_nm: float, *, band=PAPER_BAND_PER_MM,
                 mask=None, frequencies=None) -> FairMetrics:
    """Detrend a residual (start - removal) and compute its fair figures.

    Parameters
    ----------
    residual_nm : (Ny, Nx) array_like
        Surface after polishing, nm, *before* detrending (``start - removal``).
    dx_mm : float
        Pixel pitch, mm.
    spacing_mm : float
        Path spacing, mm (for the lattice frequencies).
    depth_nm : float
        Mean depth removed, nm (for PVn).
    band : (float, float)
        1/mm (default the paper's 1-100 1/mm).
    mask : (Ny, Nx) bool, optional
        True where the residual is evaluated (e.g. away from the patch edges).
    frequencies : (K,) array_like, optional
        The lattice frequencies to read, 1/mm (default :func:`lattice_frequencies`
        of ``spacing_mm``; a comparison passes each path's :func:`path_frequencies`).

    Returns
    -------
    FairMetrics
        ``params["lattice_frequencies_per_mm"]`` holds the frequencies read.
    """
    r = detrend_residual(residual_nm, dx_mm, mask)
    ok = np.isfinite(r)
    m = ok if mask is not None or not ok.all() else None
    v = r[ok]
    lo, hi = _check_band(band)
    targets = lattice_frequencies(spacing_mm) if frequencies is None else _check_freqs(frequencies)
    params = {"band_per_mm": [lo, hi], "dx_mm": float(dx_mm), "spacing_mm": float(spacing_mm),
              "depth_nm": float(depth_nm), "n_valid_pixels": int(ok.sum()), "taper_mm": taper_width_mm(band),
              "detrend": "mean+tilt+power (ISO 10110-8), least squares over the valid pixels",
              "band_rms": "2D PSD, |f| in band, window = mask with raised-cosine edge taper",
              "lattice_peak": "profile PSDs of rows and columns, max over the lattice frequencies "
                              "of peak / local median, dB",
              "lattice_frequencies_per_mm": targets.tolist(), "version": __version__}
    z, w, _, _ = _prepared(r, dx_mm, band, m)  # one window for both spectra
    return FairMetrics(residual_band_rms_nm=_band_rms(z, w, float(dx_mm), lo, hi),
                       lattice_peak_db=_lattice_db(z, w, float(dx_mm), spacing_mm, lo, hi, targets),
                       pvn=pvn(r, depth_nm, m), residual_rms_nm=float(np.sqrt(np.mean(v * v))),
                       residual_pv_nm=float(v.max() - v.min()), params=params)
