"""The dwell stage's door: a surface path and an error map in, dwell times and the predicted residual out.

:func:`figure_dwell_times` solves the times at the path's own dwell points;
:func:`predict_residual` takes the machine-timed samples of the smoothed path
(what the CNC will run, at its interpolation period) and returns the residual
the summary and the report show.
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..defaults import FIGURING_CA_MARGIN_FWHMS, FIGURING_CA_MIN_AREA_SHARE, FIGURING_EXTENSION_WEIGHT
from ..errors import FiguringError, FiguringRefusedError
from ..types import Provenance, Surface, SurfacePath
from .delivery import region_centroids
from .errormap import Alignment, ErrorMap
from .solver import (
    DEFAULT_SMOOTHNESS,
    DwellSolution,
    minimum_times,
    passband_cutoff_per_mm,
    removal_map,
    solve_dwell,
    split_by_frequency,
    tif_rate,
    tif_fwhm_mm,
    tif_reach_mm,
)
from .target import Target, aperture_geometry, build_target, default_ca_margin_mm, rms_pv
from .verdict import FloorAdvice, FloorCheck, advice_scale, floor_exceeds, refusal_for_floor


@dataclass(frozen=True)
class Figuring:
    """Dwell times solved for a measured error.

    Attributes
    ----------
    times_s : (N,) float64
        Dwell time per point of the path, s.
    target : Target
        Error, aperture, target removal on the analysis grid.
    solution : DwellSolution
    tif : TIF
    provenance : Provenance
    ideal_removal_nm : (ny, nx) float64
        The solver's model of the removal of ``times_s``: each time at its region's centroid
        (:func:`~polishpath.dwell.delivery.region_centroids`), on ``target.grid``.
    stats : dict
        ``initial_rms_nm``, ``initial_pv_nm``, ``uncorrectable_rms_nm`` (the
        target's part above the passband), ``passband_cutoff_per_mm``,
        ``min_time_excess_nm`` (infeasibility: most the minimum times remove
        beyond the target, before the bias), ``ideal_residual_rms_nm`` (the
        residual of that model), solver figures.
    floor : FloorCheck or None
        The minimum-removal floor against the error, the advice and whether a refusal was forced.
    """

    times_s: np.ndarray
    target: Target
    solution: DwellSolution
    tif: Any
    provenance: Provenance
    stats: dict[str, Any] = field(default_factory=dict)
    ideal_removal_nm: np.ndarray | None = None
    floor: FloorCheck | None = None


def figure_dwell_times(surface: Surface, surface_path: SurfacePath, error_map: ErrorMap, tif, *,
                       max_feed_mm_min: float, alignment: Alignment | None = None, bias_nm: float | str = "auto",
                       method: str = "auto", smoothness: float = DEFAULT_SMOOTHNESS, extension_weight: float = FIGURING_EXTENSION_WEIGHT,
                       max_uncovered: float = 0.02, solve_pitch_mm: float | None = None, max_iter: int = 3000,
                       spacing_mm: float | None = None, ca_margin_mm: float | None = None, period_ms: float | None = None,
                       chord_tol_mm: float | None = None, t_min_s: np.ndarray | None = None,
                       force: bool = False) -> Figuring:
    """Solve the dwell times that remove ``error_map`` along ``surface_path``.

    Parameters
    ----------
    surface : Surface
        The part (its boundary seen along z is the clear aperture).
    surface_path : SurfacePath
        Dwell points (N, 3) mm in path order; each reads the map at its x, y.
    error_map : ErrorMap
    tif : TIF or RotatingToolTIF
        Removal rate, nm/s.
    max_feed_mm_min : float
        The machine's maximum feed: each time is at least the point's step at this feed.
    alignment : Alignment, optional
    bias_nm : float or "auto"
        Uniform extra removal, nm. ``"auto"``: the least bias with which the
        minimum times remove no more than the target anywhere (0 when they already fit).
    method : {"auto", "lsq", "fft"}
    smoothness, extension_weight, max_uncovered, solve_pitch_mm, max_iter
        See :func:`~polishpath.dwell.solver.solve_dwell` and :func:`~polishpath.dwell.target.build_target`.
    spacing_mm : float, optional
        Typical step, mm (default: the median step of the path).
    ca_margin_mm : float, optional
        Clear aperture = the part's outline shrunk by this, mm (see :func:`build_target`). Default
        (None): :data:`~polishpath.defaults.FIGURING_CA_MARGIN_FWHMS` TIF widths (FWHM), the band next to
        the edge that a TIF this wide cannot figure (:func:`~polishpath.dwell.target.default_ca_margin_mm`);
        the summary says which was used.
    period_ms, chord_tol_mm : float, optional
        The machine interpolation (lowers the minimum-time feed where the path turns, see
        :func:`~polishpath.dwell.solver.minimum_times`).
    t_min_s : (N,) float, optional
        Minimum times to use instead (e.g. raised where the machine-timed path could not go faster).
    force : bool
        Go on when the minimum-removal floor exceeds the error's PV (recorded in ``Figuring.floor``);
        otherwise that raises :class:`~polishpath.errors.FiguringRefusedError` with the floor, its cause
        and the parameters that would work (:mod:`polishpath.dwell.verdict`).

    Returns
    -------
    Figuring
    """
    xyz = np.asarray(surface_path.xyz)
    n = len(xyz)
    if n == 0:
        raise FiguringError("the path has no dwell point to give a time to.")
    pieces = np.asarray(surface_path.planar.pieces) if surface_path.planar is not None else np.array([0, n])
    steps = np.linalg.norm(np.diff(xyz, axis=0), axis=1)
    spacing = float(spacing_mm if spacing_mm is not None else (np.median(steps[steps > 0]) if (steps > 0).any() else 1.0))
    reach = tif_reach_mm(tif)
    geom = aperture_geometry(surface.vertices, surface.faces)
    auto_bias = bias_nm == "auto"
    if not auto_bias and not isinstance(bias_nm, (int, float)):
        raise FiguringError(f"bias must be a number of nm or 'auto', got {bias_nm!r}.")
    fwhm = tif_fwhm_mm(tif)
    ca_given = ca_margin_mm is not None
    if not ca_given:
        ca_margin_mm = default_ca_margin_mm(geom, fwhm, fwhms=FIGURING_CA_MARGIN_FWHMS,
                                            min_area_share=FIGURING_CA_MIN_AREA_SHARE)
    target = build_target(error_map, geom, alignment=alignment, band_mm=reach, bias_nm=0.0 if auto_bias else float(bias_nm),
                          extension_weight=extension_weight, max_uncovered=max_uncovered,
                          ca_margin_mm=ca_margin_mm)
    ca = {"margin_mm": float(ca_margin_mm), "source": "given" if ca_given else "default", "tif_fwhm_mm": fwhm,
          "text": _ca_text(float(ca_margin_mm), ca_given, fwhm)}
    tmin = minimum_times(xyz, pieces, max_feed_mm_min, period_ms=period_ms, chord_tol_mm=chord_tol_mm)
    if t_min_s is not None:
        tmin = np.maximum(tmin, np.asarray(t_min_s, dtype=np.float64))
    pts = xyz[:, :2]
    # each time is spent along the point's region of the path, not at the point: model it at the region's centroid
    cen = region_centroids(xyz, pieces)
    # infeasibility: what the minimum times alone remove, against the target (at zero bias)
    rmin = removal_map(target.grid, cen, tmin, tif)
    valid = target.valid
    target0 = target
    excess = float(np.max((rmin - target.removal_nm)[valid])) if valid.any() else 0.0
    if auto_bias and excess > 0:
        target = target.with_bias(excess)
    elif excess > 0:
        warnings.warn(
            f"the error needs less removal than the minimum dwell gives: the minimum times (each point's step at "
            f"{max_feed_mm_min:g} mm/min) remove up to {excess:.3g} nm more than the target; that part stays as "
            "over-removal. Use bias = 'auto' (or >= that), a faster maximum feed or a lower TIF rate.",
            UserWarning, stacklevel=2)
    grid_ij = surface_path.planar.ij if surface_path.planar is not None and len(surface_path.planar.ij) == n else None
    solve_kw = dict(spacing_mm=spacing, method=method, grid_ij=grid_ij, smoothness=smoothness,
                    solve_pitch_mm=solve_pitch_mm, max_iter=max_iter, centres_xy=cen)
    init_rms, init_pv = rms_pv(target.error_nm[valid])
    part_rms, part_pv = rms_pv(target.error_nm[target.part_valid])
    floor = float(np.mean(rmin[valid])) if valid.any() else 0.0
    straight = minimum_times(xyz, pieces, max_feed_mm_min)  # the steps at the top feed, no turn
    turn_share = float(np.clip(1.0 - straight.sum() / max(float(tmin.sum()), 1e-300), 0.0, 1.0))
    fc = FloorCheck(floor, init_pv, init_rms, tif_peak_rate(tif), float(max_feed_mm_min), spacing, turn_share,
                    floor_exceeds(floor, init_pv))
    scale = advice_scale(floor, init_pv)
    if scale < 1.0:  # the floor is above the advised share: the parameters that bring it there, re-solved
        fc = _with_advice(fc, scale, pts, target0, rmin, tmin, tif, auto_bias, solve_kw, reach)
    if fc.exceeds:
        msg = refusal_for_floor(fc)
        if not force:
            raise FiguringRefusedError(msg, "Or give --force to write this program anyway.")
        warnings.warn(msg + " Going on: --force.", UserWarning, stacklevel=2)
        fc = dataclasses.replace(fc, forced=True, refusals=(msg,))
    grid_ij = surface_path.planar.ij if surface_path.planar is not None and len(surface_path.planar.ij) == n else None
    sol = solve_dwell(pts, target, tif, tmin, **solve_kw)
    if not sol.converged:
        warnings.warn(f"the dwell-time solver ({sol.solver}) did not converge in {sol.stats.get('iterations')} "
                      f"iterations ({sol.stats.get('message')}); the residual shown is that of the last iterate.",
                      UserWarning, stacklevel=2)
    f_cut = passband_cutoff_per_mm(tif, spacing)
    _, high = split_by_frequency(target.grid, target.removal_nm, f_cut)
    unc_rms, _ = rms_pv(high[valid])
    ideal = removal_map(target.grid, cen, sol.times_s, tif)
    ideal_rms, ideal_pv = rms_pv((target.removal_nm - ideal)[valid])
    stats = {
        "initial_rms_nm": init_rms, "initial_pv_nm": init_pv, "part_initial_rms_nm": part_rms,
        "part_initial_pv_nm": part_pv,
        "uncorrectable_rms_nm": unc_rms, "passband_cutoff_per_mm": f_cut,
        "ideal_residual_rms_nm": ideal_rms, "ideal_residual_pv_nm": ideal_pv,
        "min_time_excess_nm": max(excess, 0.0), "floor_nm": floor, "bias_nm": target.params["bias_nm"],
        "bias_mode": "auto" if auto_bias else "given",
        "uncovered_fraction": target.params["uncovered_fraction"],
        "solver": sol.solver, "solver_converged": sol.converged, "solver_stats": sol.stats,
        "total_time_s": sol.total_time_s, "t_min_total_s": float(tmin.sum()),
        "spacing_mm": spacing, "error_map": error_map.source, "clear_aperture": ca,
    }
    if unc_rms > 0.05 * max(init_rms, 1e-300):  # worth saying: more than the 5 % a good figuring run leaves
        stats["uncorrectable_note"] = (
            f"{unc_rms:.3g} nm RMS of the error lies above {f_cut:.3g} 1/mm, beyond what this TIF at "
            f"{spacing:.3g} mm spacing can correct; it stays in the residual.")
    prov = Provenance("dwell", sol.solver, {
        "max_feed_mm_min": float(max_feed_mm_min), "bias_nm": target.params["bias_nm"], "method": method,
        "smoothness": float(smoothness), "extension_weight": float(extension_weight),
        "max_uncovered": float(max_uncovered), "ca_margin_mm": float(ca_margin_mm),
        "ca_margin_source": ca["source"], "alignment": (alignment or Alignment()).to_dict(),
        "tif": _tif_params(tif), "error_map": error_map.source}, seed=surface_path.provenance.seed)
    return Figuring(sol.times_s, target, sol, tif, prov, stats, ideal, fc)


def _ca_text(margin_mm: float, given: bool, fwhm_mm: float) -> str:
    """How the clear aperture was chosen, for the verdict line."""
    if margin_mm <= 0:
        return "over the whole part" + ("" if given else f" (a TIF {fwhm_mm:.3g} mm wide leaves no room for a margin)")
    how = "as given" if given else f"by default, {margin_mm / fwhm_mm:.2g} TIF FWHM; set [error_map] ca_margin_mm"
    return f"over the clear aperture: the part inset by {margin_mm:.3g} mm ({how})"


def tif_peak_rate(tif) -> float:
    """The TIF's highest removal rate, nm/s."""
    if getattr(tif, "kind", None) == "gaussian":
        return float(tif.params["peak_rate_nm_s"])
    r = tif_reach_mm(tif)
    g = np.linspace(-r, r, 121)
    X, Y = np.meshgrid(g, g)
    return float(np.max(tif_rate(tif, X.ravel(), Y.ravel())))


def _with_advice(fc: FloorCheck, scale: float, pts, target0: Target, rmin, tmin, tif, auto_bias: bool,
                 solve_kw: dict, reach: float) -> FloorCheck:
    """``fc`` with the parameters that scale the floor by ``scale``: the peak rate is exact (the removal is
    proportional to it), checked by solving again with every removal scaled (the same as the minimum times
    scaled, in units of today's TIF); top feed and spacing are the same scale in proportion."""
    valid = target0.valid
    t = target0
    if auto_bias:
        ex = float(np.max((scale * rmin - target0.removal_nm)[valid])) if valid.any() else 0.0
        t = target0.with_bias(max(ex, 0.0))
    # an estimate for the message: where the fft solver has coarse levels (a wide TIF, a large job), the coarsest
    # level's solve and its own model's residual (a fine solve would cost as much as the job's own)
    sol = solve_dwell(pts, t, tif, scale * tmin, **solve_kw, coarse_only=True)
    xy_e, t_e = sol.stats.get("estimate_xy", solve_kw["centres_xy"]), sol.stats.get("estimate_times_s", sol.times_s)
    res = (t.removal_nm - removal_map(t.grid, xy_e, t_e, tif))[valid]
    rr, rp = rms_pv(res)
    sp = fc.spacing_mm / scale
    # only the straight part of the minimum time goes as 1 / feed: it must bring the floor down alone
    feed_part = 1.0 - fc.turn_share
    feed_scale = (scale - fc.turn_share) / feed_part if feed_part > 0 else -1.0
    feed = fc.max_feed_mm_min / feed_scale if feed_scale > 0 else float("nan")
    adv = FloorAdvice(scale, fc.floor_nm * scale, fc.peak_rate_nm_s * scale, feed,
                      sp if sp <= reach / 3.0 else float("nan"), rr, rp)
    return dataclasses.replace(fc, advice=adv)


def _tif_params(tif) -> dict[str, Any]:
    p = getattr(tif, "params", None)
    if isinstance(p, dict):
        return {"kind": getattr(tif, "kind", type(tif).__name__), **{k: v for k, v in p.items() if k != "shape"}}
    return {"kind": type(tif).__name__}


def predict_residual(fig: Figuring, samples_xyz: np.ndarray, period_ms: float,
                     delivered_s: np.ndarray | None = None,
                     sample_s: np.ndarray | None = None) -> dict[str, Any]:
    """Removal and residual of the machine-timed path: each sample stands for one interpolation period
    (or its own time, ``sample_s``, where a machine's schedule slowed it).

    Parameters
    ----------
    fig : Figuring
    samples_xyz : (M, 3) float
        The smoothed path's samples at the constant period (``ToolPath.samples``), mm.
    period_ms : float
    delivered_s : (N,) float, optional
        The time the samples spend in each point's region (:func:`~polishpath.dwell.delivery.region_times`):
        its relative difference from the solved times is reported.
    sample_s : (M,) float, optional
        The time each sample stands for, s; default one period each. After a
        machine profile's schedule: the period stretched by planned / scheduled feed.

    Returns
    -------
    dict
        ``removal_nm`` and ``residual_nm`` (ny, nx) maps on ``fig.target.grid``
        (residual NaN outside the measured aperture) and the figures
        ``residual_rms_nm``, ``residual_pv_nm``, ``removal_rms_nm``, ``machine_time_s`` and with
        ``delivered_s`` ``delivered_time_error_rms`` / ``_max`` (relative to the solved times).
    """
    s = np.asarray(samples_xyz, dtype=np.float64)
    if sample_s is None:  # one period each: no array of the samples' size (3.3e7 of them in a 10^6-point job)
        sample_s = np.broadcast_to(np.float64(period_ms / 1000.0), (len(s),))
    sample_s = np.asarray(sample_s, dtype=np.float64)
    removal = removal_map(fig.target.grid, s[:, :2], sample_s, fig.tif)
    valid = fig.target.valid
    residual = np.where(valid, fig.target.removal_nm - removal, np.nan)
    rr, rp = rms_pv(residual[valid])
    mr, _ = rms_pv(removal[valid])
    part = fig.target.part_valid
    prr, prp = rms_pv((fig.target.removal_nm - removal)[part])
    out = {"removal_nm": removal, "residual_nm": residual, "residual_rms_nm": rr, "residual_pv_nm": rp,
           "part_residual_rms_nm": prr, "part_residual_pv_nm": prp,
           "removal_rms_nm": mr, "removal_mean_nm": float(np.mean(removal[valid])), "machine_time_s": float(sample_s.sum())}
    if delivered_s is not None:
        rel = (np.asarray(delivered_s, dtype=np.float64) - fig.times_s) / fig.times_s
        out["delivered_time_error_rms"] = float(np.sqrt(np.mean(rel**2)))
        out["delivered_time_error_max"] = float(np.abs(rel).max())
    return out


def figuring_summary(fig: Figuring, predicted: dict[str, Any]) -> dict[str, Any]:
    """The ``figuring`` block of ``summary.json``."""
    st = fig.stats
    fc = fig.floor
    lead = (f"initial {st['initial_rms_nm']:.3g} nm RMS ({st['initial_pv_nm']:.3g} nm PV) -> predicted "
            f"{predicted['residual_rms_nm']:.3g} nm RMS ({predicted['residual_pv_nm']:.3g} nm PV); minimum-removal "
            f"floor {st['floor_nm']:.3g} nm")
    ca = st.get("clear_aperture")
    if ca:
        lead += f"; {ca['text']}"
    if fc is not None and fc.forced:
        lead += " (refused, written with --force)"
    return {
        "verdict": lead, "floor_nm": st["floor_nm"],
        "floor_share_of_error_pv": fc.ratio if fc is not None else None,
        "floor_turn_share": fc.turn_share if fc is not None else None,
        "forced": bool(fc is not None and fc.forced), "refusals": list(fc.refusals) if fc is not None else [],
        "floor_advice": fc.advice.to_dict() if fc is not None and fc.advice is not None else None,
        "initial_rms_nm": st["initial_rms_nm"], "initial_pv_nm": st["initial_pv_nm"],
        "residual_rms_nm": predicted["residual_rms_nm"], "residual_pv_nm": predicted["residual_pv_nm"],
        "clear_aperture": ca,
        "part_initial_rms_nm": st.get("part_initial_rms_nm"), "part_initial_pv_nm": st.get("part_initial_pv_nm"),
        "part_residual_rms_nm": predicted.get("part_residual_rms_nm"),
        "part_residual_pv_nm": predicted.get("part_residual_pv_nm"),
        "residual_model": "machine-timed: the smoothed path's samples at the interpolation period",
        "ideal_residual_rms_nm": st["ideal_residual_rms_nm"],
        "uncorrectable_rms_nm": st["uncorrectable_rms_nm"], "passband_cutoff_per_mm": st["passband_cutoff_per_mm"],
        **({"uncorrectable_note": st["uncorrectable_note"]} if "uncorrectable_note" in st else {}),
        "total_time_s": float(fig.times_s.sum()), "machine_time_s": predicted["machine_time_s"],
        "delivered_time_error_rms": predicted.get("delivered_time_error_rms"),
        "delivered_time_error_max": predicted.get("delivered_time_error_max"),
        "solver": fig.solution.solver, "solver_converged": fig.solution.converged,
        "solver_detail": fig.solution.stats.get("method_detail"), "solver_iterations": fig.solution.stats.get("iterations"),
        "solver_message": fig.solution.stats.get("message"),
        "solver_relative_residual": fig.solution.stats.get("relative_residual"),
        "solve_seconds": fig.solution.stats.get("seconds"), "solve_cpu_seconds": fig.solution.stats.get("cpu_seconds"),
        "solver_coarse_levels": fig.solution.stats.get("coarse_levels"),
        "bias_nm": st["bias_nm"], "bias_mode": st["bias_mode"], "min_time_excess_nm": st["min_time_excess_nm"],
        "t_min_total_s": st["t_min_total_s"], "points_at_minimum_share": fig.solution.stats.get("bound_active_share"),
        "uncovered_fraction": st["uncovered_fraction"], "error_map": st["error_map"],
        "grid": fig.target.grid.to_dict(), "provenance": fig.provenance.to_dict(),
    }
