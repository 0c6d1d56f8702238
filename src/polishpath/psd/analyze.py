"""File-level PSD analysis for the ``polishpath psd`` command."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import progress
from ..errors import MeasurementFileError, MeasurementUnitsError
from .core import PAPER_BAND_PER_MM, PSD, band_average, band_coverage, band_rms, find_peaks, psd_1d, radial_psd, suppression_ratio
from .io import _TO_NM, Measurement, _unit_factor, read_measurement

#: RMS heights outside this range (nm) are not a polished or ground surface read in the right units
PLAUSIBLE_RMS_NM = (1e-3, 1e6)


def measurement_psd(m: Measurement, *, window: str = "hann", detrend="tilt", nan: str | None = None) -> PSD:
    """Profile PSD of a measurement: the profile itself, or the average over the rows of a map.

    Parameters
    ----------
    m : Measurement
    window, detrend :
        As in :func:`polishpath.psd.psd_1d`.
    nan : {"drop", "interpolate", "raise"}, optional
        Default: interpolate for profiles (one profile cannot be dropped),
        drop rows for maps (when some rows are complete; else interpolate).

    Returns
    -------
    PSD
        ``kind="1d"`` in nm^2 mm — the same quantity for profilometer and
        interferometer data, so before/after measurements stay comparable.
    """
    if nan is None:
        if m.kind == "map" and np.isfinite(m.z_nm).all(axis=1).sum() >= max(8, m.z_nm.shape[0] // 2):
            nan = "drop"
        else:
            nan = "interpolate"
    return psd_1d(m.z_nm, m.dx_mm, window=window, detrend=detrend, nan=nan)


def check_plausible_rms(rms_nm: float, m: Measurement) -> None:
    """Refuse (units assumed) or warn (units stated) when the RMS height is implausible, naming the likely units.

    Parameters
    ----------
    rms_nm : float
        RMS height of the measurement as read, nm.
    m : Measurement
        The measurement (its params say the height unit used and whether it was assumed).

    Raises
    ------
    MeasurementUnitsError
        When the height unit was assumed and the RMS lies outside :data:`PLAUSIBLE_RMS_NM`.
    """
    lo, hi = PLAUSIBLE_RMS_NM
    if not (np.isfinite(rms_nm) and rms_nm > 0) or lo <= rms_nm <= hi:
        return
    used = m.params.get("height_unit") or m.params.get("z_unit_in_file") or "nm"
    try:
        k_used = _unit_factor(str(used), _TO_NM, "height")
    except MeasurementFileError:
        k_used = 1.0
    cands = {u: rms_nm / k_used * _TO_NM[u] for u in ("m", "mm", "um", "nm")}
    good = {u: r for u, r in cands.items() if lo <= r <= hi}
    name = m.source.rsplit("/", 1)[-1] or "the measurement"
    msg = (f"{name}: RMS height {rms_nm:.3g} nm is implausible for a measured surface (expected {lo:g} to {hi:g} nm) "
           f"with heights read in {used}.")
    if good:
        u = min(good, key=lambda k: abs(np.log10(good[k]) - 1.0))  # nearest to ~10 nm
        hint = f"The heights are probably in {u}: pass --height-unit {u} (RMS {good[u]:.3g} nm)."
    else:
        hint = "Check the file's height unit (--height-unit m, mm, um or nm) and its content."
    assumed = any("height" in a for a in m.params.get("units_assumed") or [])
    if assumed:
        raise MeasurementUnitsError(msg, hint)
    progress.warn(f"{msg} {hint}")


def analyze_file(file, band: tuple[float, float] = PAPER_BAND_PER_MM, *, spacing_mm: float | None = None,
                 window: str = "hann", detrend="tilt", nan: str | None = None, **read_kwargs) -> dict[str, Any]:
    """PSD, band RMS, band-average PSD and peaks of a measured profile or map.

    Parameters
    ----------
    file : str or Path
        Any format :func:`read_measurement` reads.
    band : (float, float)
        Band in 1/mm (default 1-100 1/mm = 10^3-10^5 1/m).
    spacing_mm : float, optional
        Path spacing, mm, to name peaks at 1/spacing and harmonics.
    window, detrend :
        PSD options.
    nan : {"drop", "interpolate", "raise"}, optional
        Missing samples (see :func:`measurement_psd`).
    **read_kwargs :
        Passed to :func:`read_measurement` (``lateral_unit``, ``height_unit``, ``dx_mm`` ...).

    Raises
    ------
    MeasurementUnitsError
        The height unit was assumed and the RMS is implausible (see :func:`check_plausible_rms`).

    Returns
    -------
    dict
        ``file``, ``kind``, ``shape``, ``dx_mm``, ``n_nan``, ``band_per_mm``,
        ``band_covered_per_mm`` (the part of the band the data resolves),
        ``band_rms_nm``, ``band_average`` and ``units``, ``rms_nm`` (all
        frequencies), ``peaks``, ``psd`` (:class:`PSD`), ``psd_radial``
        (maps only) and ``measurement_params``.
    """
    m = read_measurement(file, **read_kwargs)
    p = measurement_psd(m, window=window, detrend=detrend, nan=nan)
    check_plausible_rms(float(np.sqrt(p.params["variance_nm2"])), m)
    brms = band_rms(p, *band)
    peaks = find_peaks(p, spacing_mm, band=band)
    for pk in peaks:  # what each peak holds, so a tall but negligible one reads as such
        pk["rms_nm"] = float(np.sqrt(pk["psd"] * p.df))
    out: dict[str, Any] = {
        "file": str(file), "kind": m.kind, "shape": list(np.shape(m.z_nm)), "dx_mm": m.dx_mm, "n_nan": m.n_nan,
        "band_per_mm": list(band), "band_covered_per_mm": list(band_coverage(p, *band)),
        "band_rms_nm": brms, "band_average": band_average(p, *band), "units": p.units,
        "rms_nm": float(np.sqrt(p.params["variance_nm2"])), "peaks": peaks,
        "resolved_per_mm": [float(p.freq[0]), float(p.freq[-1])],
        "band_variance_fraction": band_variance_fraction(p, band),
        "strongest_per_mm": strongest_frequency(p),
        "psd": p, "measurement_params": dict(m.params), "psd_params": dict(p.params),
    }
    if m.kind == "map":
        radial, note = aperture_radial_psd(m.z_nm, m.dx_mm, m.dy_mm, window=window, detrend=detrend)
        if radial is not None:
            out["psd_radial"] = radial
        out["psd_radial_note"] = note
    return out


#: The share of missing pixels *inside* the measured aperture (holes, dropouts) up to which the radial PSD fills
#: them; the frame outside a round aperture is not missing data and does not count.
MAX_HOLE_FRACTION = 0.2


def aperture_radial_psd(z_nm, dx_mm: float, dy_mm: float, *, window: str = "hann", detrend="tilt",
                        max_hole_fraction: float = MAX_HOLE_FRACTION):
    """The radial PSD of an interferometer map whose aperture does not fill its frame.

    A round part measured full aperture leaves at least 21.5 % of its square frame without data (4D, Zygo GPI
    files: 26 % on a real 4Sight map), which :func:`~polishpath.psd.core.radial_psd` would refuse as missing
    pixels. Here the map is cropped to the box of its valid pixels, and only the holes *inside* the aperture (the
    missing pixels that the valid ones enclose, ``scipy.ndimage.binary_fill_holes``) count against
    ``max_hole_fraction``; the frame outside is filled by the same row interpolation and then tapered by the
    window.

    Parameters
    ----------
    z_nm : (Ny, Nx) array
        Heights, nm; NaN where there is no data.
    dx_mm, dy_mm : float
        Pixel spacing, mm.

    Returns
    -------
    (PSD or None, str)
        The radial PSD, or None when the aperture's holes exceed the limit, and a sentence saying what was done.
    """
    from scipy.ndimage import binary_fill_holes

    z = np.asarray(z_nm, dtype=np.float64)
    valid = np.isfinite(z)
    if not valid.any():
        return None, "no valid pixel: no radial PSD"
    rows, cols = np.flatnonzero(valid.any(axis=1)), np.flatnonzero(valid.any(axis=0))
    box = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
    z, valid = z[box], valid[box]
    aperture = binary_fill_holes(valid)
    holes = float((aperture & ~valid).sum() / aperture.sum())
    outside = float((~aperture).sum() / aperture.size)
    if holes > max_hole_fraction:
        return None, (f"no radial PSD: {100 * holes:.1f} % of the aperture's pixels have no data, more than "
                      f"{100 * max_hole_fraction:.0f} %; the row-profile PSD above does not need them filled")
    if min(z.shape) < 8:
        return None, f"no radial PSD: the valid pixels span only {z.shape[0]} x {z.shape[1]}"
    radial = radial_psd(z, dx_mm, dy_mm, window=window, detrend=detrend, max_nan_fraction=1.0)
    return radial, (f"radial PSD over the {z.shape[0]} x {z.shape[1]} pixels that hold the aperture: "
                    f"{100 * holes:.1f} % holes inside it and {100 * outside:.1f} % of the box outside it filled "
                    "along rows and tapered by the window")


def band_variance_fraction(p: PSD, band: tuple[float, float]) -> float:
    """Share of the PSD's variance (all its frequencies) that lies in ``band`` (1/mm), 0..1."""
    w = p.psd * (2 * np.pi * p.freq if p.kind == "2d-radial" else 1.0)
    total = float(np.sum(w))
    if not total > 0:
        return float("nan")
    m = (p.freq >= band[0]) & (p.freq <= band[1])
    return float(np.sum(w[m]) / total)


def strongest_frequency(p: PSD) -> float:
    """The frequency (1/mm) of the bin holding the most variance, whatever the band."""
    w = p.psd * (2 * np.pi * p.freq if p.kind == "2d-radial" else 1.0)
    return float(p.freq[int(np.argmax(w))])


def summary_lines(r: dict[str, Any], band: tuple[float, float]) -> list[str]:
    """What ``polishpath psd`` prints for one file's :func:`analyze_file` result (units in every figure).

    The total RMS and the band RMS are different quantities: a surface whose height lies at wavelengths
    outside the band (a figure error, a ripple longer than 1 mm for the default 1-100 1/mm) has a small band
    RMS however large its RMS is. The lines say what part of the band the sampling resolves, what share of
    the variance the band holds and, when the band holds little of it, where the strongest component is and
    which ``--band`` would take it in.
    """
    lo, hi = band
    flo, fhi = r["resolved_per_mm"]
    clo, chi = r["band_covered_per_mm"]
    frac = r["band_variance_fraction"]
    out = [f"  RMS {r['rms_nm']:.4g} nm over all the wavelengths the data resolves ({1 / fhi:.3g}-{1 / flo:.3g} mm; "
           f"each profile's tilt removed)"]
    covered = "" if (clo <= lo and chi >= hi) else f", of which the data resolves {clo:.3g}-{chi:.3g} 1/mm"
    share = f"{100 * frac:.3g} % of the variance" if np.isfinite(frac) else "no variance"
    out.append(f"  band {lo:g}-{hi:g} 1/mm (wavelengths {1 / hi:.3g}-{1 / lo:.3g} mm{covered}): band RMS "
               f"{r['band_rms_nm']:.4g} nm ({share}), average PSD {r['band_average']:.4g} {r['units']}")
    fs = r["strongest_per_mm"]
    where = "below" if fs < lo else "above" if fs > hi else "inside"
    out.append(f"  strongest component: {fs:.4g} 1/mm (wavelength {1 / fs:.4g} mm), {where} the band")
    if np.isfinite(frac) and frac < 0.5:
        sugg_lo, sugg_hi = max(flo, fs / 3), min(fhi, fs * 3)
        out.append("  note: the band holds little of this surface's height, so its band RMS is small however large "
                   "the RMS is (it is right for the band, not a reading error); to measure the strongest component "
                   f"pass e.g. --band {sugg_lo:.3g},{sugg_hi:.3g}")
    # peaks holding under 1 % of the band RMS (e.g. the harmonics of the heights' quantisation) are left out here
    for pk in [pk for pk in r.get("peaks", []) if pk["rms_nm"] >= 0.01 * r["band_rms_nm"]][:8]:
        out.append(f"  peak at {pk['freq_per_mm']:.4g} 1/mm (wavelength {pk['wavelength_mm']:.4g} mm): "
                   f"{pk['rms_nm']:.3g} nm RMS, {pk['excess_decades']:.2f} decades above the local PSD"
                   + (f", {pk['label']}" if pk.get("label") else ""))
    return out


def compare_files(before, after, band: tuple[float, float] = PAPER_BAND_PER_MM, *, allow_mixed: bool = False,
                  **kwargs) -> dict[str, Any]:
    """Suppression ratio between two measurements (before / after polishing).

    Parameters
    ----------
    before, after : str or Path
        Measurement files (same kind of measurement is advisable).
    band : (float, float)
        Band in 1/mm.
    allow_mixed : bool
        Compare a map with a profile (the map's row-profile PSD against the
        profile's); refused by default, since the two instruments see
        different bandwidths and directions.
    **kwargs :
        Passed to :func:`analyze_file`.

    Returns
    -------
    dict
        ``before`` and ``after`` (as from :func:`analyze_file`),
        ``suppression_ratio`` (1 - after/before band-average PSD) and
        ``band_rms_ratio`` (after/before band RMS).
    """
    a = analyze_file(before, band, **kwargs)
    b = analyze_file(after, band, **kwargs)
    if a["kind"] != b["kind"] and not allow_mixed:
        raise MeasurementFileError(
            f"{a['file']} is a {a['kind']} and {b['file']} a {b['kind']}: their PSDs come from different "
            "instruments, bandwidths and directions, so the suppression ratio would compare unlike things.",
            "Measure before and after the same way, or pass --mixed to compare the map's row-profile PSD "
            "with the profile's anyway (allow_mixed=True in Python).")
    return {"before": a, "after": b, "band_per_mm": list(band),
            "suppression_ratio": suppression_ratio(a["psd"], b["psd"], band),
            "band_rms_ratio": b["band_rms_nm"] / a["band_rms_nm"] if a["band_rms_nm"] > 0 else float("nan"),
            "mixed": a["kind"] != b["kind"]}
