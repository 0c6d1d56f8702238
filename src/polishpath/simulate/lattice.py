"""A path's own lattice frequencies and the peak a residual shows there (issue 18; issue 26: each path its own).

* :func:`lattice_frequencies`: ``1/(2 s)`` and ``n/s`` of a path on a lattice of spacing ``s``;
* :func:`nominal_frequencies`: where a path without a lattice is read (``1/(2 h)``, ``1/h``,
  ``sqrt(2)/h``, ``2/h`` of its nominal spacing ``h``), the same yardstick;
* :func:`path_frequencies`: the one a comparison row uses;
* the peak over the local background in the profile PSDs of rows and columns, which
  :func:`polishpath.simulate.fair.lattice_peak_db` and :func:`~polishpath.simulate.fair.fair_metrics` read.

Units: heights nm, lengths mm, frequencies 1/mm. See docs/simulation-metrics.md.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError

__all__ = ["lattice_frequencies", "nominal_frequencies", "path_frequencies"]

#: rows per block when a map is processed in pieces (bounds the temporary memory)
_BLOCK_ROWS = 256


def lattice_frequencies(spacing_mm: float, n_harmonics: int = 3) -> np.ndarray:
    """The path's own frequencies in a profile, 1/mm: ``1/(2 s)`` and ``n/s`` for ``n = 1..n_harmonics``.

    ``1/(2 s)`` is the period of a bidirectional raster (every other pass runs
    the same way); ``n/s`` are the pass spacing and its harmonics (a profile
    across the lattice vectors (1/s, 0), (0, 1/s), (1/s, +-1/s) of the 2D PSD
    sees them at these frequencies).

    Parameters
    ----------
    spacing_mm : float
        Path spacing s, mm.
    n_harmonics : int
        Number of harmonics of ``1/s``.

    Returns
    -------
    (n_harmonics + 1,) float64
        Increasing, 1/mm.
    """
    if not (np.isfinite(spacing_mm) and spacing_mm > 0):
        raise ParameterError(f"spacing_mm must be a positive path spacing in mm, got {spacing_mm}.")
    if int(n_harmonics) != n_harmonics or n_harmonics < 1:
        raise ParameterError(f"n_harmonics must be a positive integer, got {n_harmonics}.")
    return np.concatenate([[0.5 / spacing_mm], np.arange(1, int(n_harmonics) + 1) / spacing_mm])


def nominal_frequencies(spacing_mm: float) -> np.ndarray:
    """Where a path without a lattice is judged, 1/mm: ``1/(2 h)``, ``1/h``, ``sqrt(2)/h``, ``2/h``.

    A dwell set with no lattice (a blue-noise set) has no frequencies of its
    own; it is read where a square lattice of its nominal spacing ``h`` would
    print (the pass period and its half, the diagonal, the second harmonic),
    so it is compared with the paths that have one by the same yardstick.

    Parameters
    ----------
    spacing_mm : float
        Nominal spacing ``h`` of the dwell points in the plane of the residual, mm.

    Returns
    -------
    (4,) float64
        Increasing, 1/mm.
    """
    if not (np.isfinite(spacing_mm) and spacing_mm > 0):
        raise ParameterError(f"spacing_mm must be a positive path spacing in mm, got {spacing_mm}.")
    return np.array([0.5, 1.0, np.sqrt(2.0), 2.0]) / spacing_mm


def path_frequencies(spacing_mm: float, *, lattice: bool = True) -> np.ndarray:
    """The frequencies (1/mm) a path's lattice peak is looked for at: its own.

    ``spacing_mm`` is the path's period where its residual is evaluated: the
    comparison simulates in the plane the paths were planned in, so that is
    each path's own planar spacing (not another path's, nor the spacing asked
    on the part). ``lattice``: :func:`lattice_frequencies` of it; a path whose
    dwell points have no lattice: :func:`nominal_frequencies`.

    Returns
    -------
    (K,) float64
        Increasing, 1/mm.
    """
    return lattice_frequencies(spacing_mm) if lattice else nominal_frequencies(spacing_mm)


def _profile_psds(z: np.ndarray, w: np.ndarray, dx_mm: float, pad: int = 2):
    """One-sided profile PSDs (nm^2 mm) of the rows and of the columns of the windowed map.

    ``P(f) = 2 dx sum_profiles |DFT(z w)|^2 / sum w^2`` on a grid zero-padded
    ``pad`` times (the spectrum interpolated, so a peak between two bins of the
    profile length loses little), so ``sum P df`` is the windowed variance.

    Returns
    -------
    list of (freq (K,) 1/mm, psd (K,) nm^2 mm, df_profile 1/mm)
    """
    import scipy.fft as sfft

    out = []
    norm = float(np.sum(w * w))
    for a, b in ((z, w), (z.T, w.T)):
        n = a.shape[1]
        m = sfft.next_fast_len(pad * n, real=True)
        acc = np.zeros(m // 2 + 1)
        for r0 in range(0, a.shape[0], _BLOCK_ROWS):
            r1 = r0 + _BLOCK_ROWS
            acc += np.sum(np.abs(sfft.rfft(a[r0:r1] * b[r0:r1], n=m, axis=1, workers=2)) ** 2, axis=0)
        p = acc * dx_mm / norm  # |DFT|^2 dx / sum w^2 (two-sided) ...
        p[1:] *= 2.0  # ... folded to one side
        if m % 2 == 0:
            p[-1] /= 2.0
        out.append((sfft.rfftfreq(m, d=dx_mm), p, 1.0 / (n * dx_mm)))
    return out


def _peak_db(freq, psd, df_profile, f_target, all_targets, min_background_bins: int = 6):
    """10 log10(max PSD near ``f_target`` / median PSD around it, peak zones excluded); None if not evaluable."""
    tol = max(2.0 * df_profile, 0.02 * f_target)  # the window's main lobe: +-2 bins
    near = np.abs(freq - f_target) <= tol
    if not near.any():
        return None
    half = max(0.25 * f_target, 8 * df_profile)
    around = (np.abs(freq - f_target) <= half) & (freq > 0)
    for g in all_targets:  # keep every lattice peak (and the DC end) out of the background
        around &= np.abs(freq - g) > max(2.0 * df_profile, 0.02 * g) + 2 * df_profile
    around &= freq > 2 * df_profile
    if around.sum() < min_background_bins:
        return None
    bg = float(np.median(psd[around]))
    pk = float(psd[near].max())
    if bg <= 0:
        return None if pk <= 0 else float("inf")
    return 10.0 * np.log10(max(pk, np.finfo(float).tiny) / bg)


def _check_freqs(frequencies) -> np.ndarray:
    f = np.sort(np.asarray(frequencies, dtype=np.float64).ravel())
    if len(f) == 0 or not (np.isfinite(f).all() and (f > 0).all()):
        raise ParameterError(f"frequencies must be positive numbers in 1/mm, got {frequencies!r}.",
                             "Give the path's lattice frequencies, e.g. path_frequencies(spacing_mm).")
    return f


def _lattice_db(z: np.ndarray, w: np.ndarray, dx_mm: float, spacing_mm: float, lo: float, hi: float,
                targets: np.ndarray) -> float:
    """:func:`lattice_peak_db` of a prepared map and its window, at the frequencies ``targets`` (1/mm)."""
    nyq = 0.5 / dx_mm
    use = [f for f in targets if lo <= f <= hi and f <= 0.9 * nyq]
    best = None
    for freq, psd, dfp in _profile_psds(z, w, dx_mm):
        for f in use:
            v = _peak_db(freq, psd, dfp, f, targets)
            if v is not None and (best is None or v > best):
                best = v
    if best is None:
        raise ParameterError(
            f"no lattice frequency of spacing {spacing_mm} mm ({', '.join(f'{f:.4g}' for f in targets)} 1/mm) can "
            f"be read in the band {lo:g}-{hi:g} 1/mm of a {z.shape[1] * dx_mm:.3g} x {z.shape[0] * dx_mm:.3g} mm "
            f"map at {dx_mm} mm pitch.",
            "Evaluate a larger area (a few spacings at least), a finer pitch, or a band holding 1/spacing.")
    return float(best)
