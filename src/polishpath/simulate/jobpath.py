"""Simulate what a job made: its dwell points with their times, or the machine's own samples.

:func:`timed_path` turns a :class:`~polishpath.types.SurfacePath` (dwell points
on the part; their times given) or a :class:`~polishpath.types.ToolPath` (the
constant-period samples the machine runs, or its dwell points with the times
the schedule was built for) into points in a simulation plane with the tool's
time along them; :func:`simulate_path` runs the removal model on it, and
:func:`simulate_job` simulates a whole finished job over its part (what
``polishpath simulate RUN_DIR`` runs).

Two simulation planes (docs/simulation.md, "The job's own path"):

* ``"xy"``: the part seen along z, the height map over the projected x, y
  (what an interferometer looking down the axis measures). To first order the
  z-height removed there equals the removal of the planar model, but the tool
  footprint is not foreshortened on slopes, so it is right for gently curved
  parts only.
* ``"unrolled"``: the flattening's plane, where the path was planned. The
  flattening keeps angles (MABF), so footprints keep their shape; the time per
  plane area differs from that per part area by the local area ratio of the
  flattening, which :func:`simulate_job` corrects (depth on the part = depth in
  the plane x the local plane area / part area, see :func:`area_ratio_map`).

``"auto"`` (the default of :func:`simulate_job`) takes ``"xy"`` when the part
is a height field over x, y whose slopes stay under :data:`AUTO_XY_MAX_SLOPE_DEG`
and ``"unrolled"`` otherwise (a hemisphere's rim is vertical: its projection
squeezes the last millimetres of the part into nothing).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from .. import meshops
from ..errors import ParameterError
from ..pathops import piece_offsets
from ..types import Flattening, Region, Surface, SurfacePath, ToolPath
from .removal import ProcessNoise, SimulationResult, simulate_removal
from .tif import TIF, DirectionalTIF
from .workpiece import flat_workpiece

#: the simulation planes of :func:`timed_path`
PLANES = ("xy", "unrolled")
#: the timings of :func:`timed_path`
TIMINGS = ("machine", "dwell")
#: ``plane="auto"`` keeps the projection up to this slope of the part, degrees (1/cos 30 deg = 1.15)
AUTO_XY_MAX_SLOPE_DEG = 30.0


@dataclass(frozen=True)
class TimedPath:
    """A path in the simulation plane with the tool's time along it.

    Attributes
    ----------
    xy : (N, 2) float64
        Points in path order, mm, in the simulation plane.
    time_s : (N,) float64
        Time per point, s, in the sense of ``time_model``.
    pieces : (K+1,) int64
        Piece offsets (the tool lifts between pieces).
    time_model : str
        ``"moves"`` (machine samples: ``time_s[k]`` is the move k -> k+1) or
        ``"segments"`` (dwell points: each point's time spread around it);
        see :func:`~polishpath.simulate.motion.path_motion_samples`.
    plane : str
        ``"xy"`` or ``"unrolled"``.
    timing : str
        ``"machine"`` or ``"dwell"``.
    info : dict
        What was taken from the job: point count, total time (s), period (ms).
    """

    xy: np.ndarray
    time_s: np.ndarray
    pieces: np.ndarray
    time_model: str
    plane: str
    timing: str
    info: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        xy = np.asarray(self.xy, dtype=np.float64)
        t = np.asarray(self.time_s, dtype=np.float64)
        if xy.ndim != 2 or xy.shape[1] != 2 or t.shape != (len(xy),):
            raise ParameterError(f"a TimedPath needs (N, 2) points and (N,) times, got {xy.shape} and {t.shape}.")
        object.__setattr__(self, "xy", xy)
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "pieces", piece_offsets(self.pieces, len(xy)))


def _check_choice(name: str, value: str, allowed) -> None:
    if value not in allowed:
        raise ParameterError(f"unknown {name} {value!r}.", f"Use one of: {', '.join(allowed)}.")


def _dwell_plane_points(sp: SurfacePath, plane: str) -> np.ndarray:
    if plane == "xy":
        return np.asarray(sp.xyz)[:, :2]
    uv = np.asarray(sp.planar.uv) if sp.planar is not None else np.zeros((0, 2))
    if uv.shape != (len(sp.xyz), 2):
        raise ParameterError("the unrolled plane needs the planar path the dwell points were mapped from "
                             "(SurfacePath.planar with one uv per dwell point).", "Use plane='xy'.")
    return uv


def _sample_pieces(tp: ToolPath) -> np.ndarray:
    """Offsets of the machine samples of each piece (``ToolPath.sample_pieces``, checked against the samples)."""
    return piece_offsets(tp.sample_pieces, len(tp.samples))


def with_samples(tool_path: ToolPath) -> ToolPath:
    """The ToolPath with its machine samples held: itself when it holds them, else the samples regenerated
    from its curve and schedule (a streamed job's, or one read from a run folder that stores the schedule only:
    :func:`polishpath.smooth.iter_sample_chunks`, bit for bit the samples the job wrote).

    The simulation needs every sample at once (about 40 bytes each: 6 GB for the 1.5 x 10^8 samples of a
    10^7-point path).
    """
    if len(tool_path.samples) or tool_path.schedule is None or tool_path.schedule.n_samples == 0:
        return tool_path
    from ..smooth import iter_sample_chunks

    n = tool_path.schedule.n_samples
    s, u, f = np.empty((n, 3)), np.empty(n), np.empty(n)
    a = 0
    for c in iter_sample_chunks(tool_path):
        b = a + len(c)
        s[a:b], u[a:b], f[a:b] = c.samples, c.sample_params, c.feed_mm_min
        a = b
    if a != n:
        raise ParameterError(f"the tool path's schedule promises {n} samples; its regeneration gave {a}.",
                             "The run folder may be damaged: run the job again.")
    return replace(tool_path, samples=s, sample_params=u, feed_mm_min=f)


def timed_path(path: SurfacePath | ToolPath, *, timing: str = "machine", plane: str = "xy",
               dwell_s: np.ndarray | None = None) -> TimedPath:
    """Where the tool is and for how long, in a simulation plane, from what a job made.

    Parameters
    ----------
    path : SurfacePath or ToolPath
        The job's dwell points on the part, or its machine path.
    timing : {"machine", "dwell"}
        ``"machine"`` (ToolPath only): the constant-period samples, each move
        one interpolation period long, so the slow-downs the feed schedule
        needs at turns are in (a path scheduled under a machine profile,
        ``stats["machine_schedule"]``: each move at its scheduled speed, so the
        machine's acceleration slow-downs are in too). ``"dwell"``: the dwell points, each with its
        time spread along the path around it (``dwell_s``, or the ToolPath's
        ``dwell_times``, the times the schedule aimed at).
    plane : {"xy", "unrolled"}
        Projected x, y of the part, or the planar path's plane (module docstring).
        Machine samples are carried to the unrolled plane by their curve
        parameter between the two dwell points they lie between.
    dwell_s : (N,) float, optional
        Time per dwell point, s; needed for a SurfacePath, overrides the ToolPath's.

    Returns
    -------
    TimedPath

    Raises
    ------
    ParameterError
        Unknown timing or plane, machine timing of a SurfacePath, missing or
        malformed dwell times.
    """
    _check_choice("timing", timing, TIMINGS)
    _check_choice("plane", plane, PLANES)
    if isinstance(path, ToolPath):
        tp, sp = path, path.surface_path
    elif isinstance(path, SurfacePath):
        tp, sp = None, path
    else:
        raise ParameterError(f"path must be a SurfacePath or a ToolPath, got {type(path).__name__}.",
                             "Pass Job.surface_path or Job.tool_path (or RunData.tool_path).")
    if timing == "machine":
        if tp is None:
            raise ParameterError("machine timing needs the ToolPath (a SurfacePath has no machine samples).",
                                 "Pass the ToolPath, or use timing='dwell' with dwell_s.")
        tp = with_samples(tp)
        m = len(tp.samples)
        if m == 0:
            raise ParameterError("the tool path has no samples.", "Smooth the path first (polishpath.smooth).")
        pieces = _sample_pieces(tp)
        T = float(tp.period_ms) / 1000.0
        if not T > 0:
            raise ParameterError(f"the tool path's period must be > 0 ms, got {tp.period_ms}.")
        t = np.full(m, T)
        scheduled = "machine_schedule" in tp.stats
        if scheduled:  # a machine profile's feeds: move k -> k+1 runs at the speed arriving at sample k+1
            s = np.asarray(tp.samples, dtype=np.float64)
            v = np.asarray(tp.feed_mm_min, dtype=np.float64)[1:] / 60.0
            ln = np.linalg.norm(np.diff(s, axis=0), axis=1)
            t[:-1] = np.where(v > 0, ln / np.maximum(v, 1e-300), 0.0)
        t[pieces[1:] - 1] = 0.0  # the last sample of a piece starts no move
        if plane == "xy":
            xy = np.asarray(tp.samples)[:, :2]
        else:
            uv = _dwell_plane_points(sp, plane)
            dp = np.asarray(tp.dwell_params)
            u = np.asarray(tp.sample_params)
            if len(u) != m or len(dp) != len(uv):
                raise ParameterError("the tool path's sample_params / dwell_params do not match its samples / "
                                     "dwell points.", "Use plane='xy', or pass the ToolPath the job made.")
            xy = np.column_stack([np.interp(u, dp, uv[:, 0]), np.interp(u, dp, uv[:, 1])])
        info = {"source": "ToolPath.samples", "n_points": int(m), "period_ms": float(tp.period_ms),
                "scheduled": scheduled,
                "total_time_s": float(t.sum()), "n_pieces": int(len(pieces) - 1)}
        return TimedPath(xy, t, pieces, "moves", plane, timing, info)
    n = len(sp.xyz)
    if dwell_s is None:
        if tp is None or tp.dwell_times is None:
            raise ParameterError("dwell timing needs a time per dwell point.",
                                 "Give dwell_s (s, one per dwell point), or pass the ToolPath (its dwell_times).")
        dwell_s = tp.dwell_times
    t = np.asarray(dwell_s, dtype=np.float64)
    if t.shape != (n,) or not np.isfinite(t).all() or (t < 0).any():
        raise ParameterError(f"dwell_s must be {n} finite times >= 0 s (one per dwell point), got shape {t.shape}.")
    pieces = piece_offsets(sp.planar.pieces if sp.planar is not None else None, n)
    info = {"source": "dwell points", "n_points": int(n), "total_time_s": float(t.sum()),
            "n_pieces": int(len(pieces) - 1)}
    return TimedPath(_dwell_plane_points(sp, plane), t, pieces, "segments", plane, timing, info)


def simulate_path(path: SurfacePath | ToolPath | TimedPath, workpiece, tif, *, timing: str = "machine",
                  plane: str = "xy", dwell_s: np.ndarray | None = None, **removal_kw) -> SimulationResult:
    """Simulate the removal of a job's own path (:func:`timed_path` then :func:`simulate_removal`).

    Parameters
    ----------
    path : SurfacePath, ToolPath or TimedPath
    workpiece : Workpiece
        Grid and initial surface, in the simulation plane, mm / nm.
    tif : TIF, DirectionalTIF or RotatingToolTIF
    timing, plane, dwell_s :
        As :func:`timed_path` (ignored for a TimedPath).
    **removal_kw :
        ``noise``, ``smoothing``, ``seed``, ``sample_step_mm``, ``removal_dx_mm``,
        ``basis_tol`` of :func:`simulate_removal`.

    Returns
    -------
    SimulationResult
        ``stats["path"]``: the :attr:`TimedPath.info` plus plane, timing and time model.
    """
    tp = path if isinstance(path, TimedPath) else timed_path(path, timing=timing, plane=plane, dwell_s=dwell_s)
    for bad in ("pieces", "time_model", "machine"):
        if bad in removal_kw:
            raise ParameterError(f"simulate_path sets {bad} from the path; do not pass it.")
    res = simulate_removal(tp.xy, tp.time_s, workpiece, tif, pieces=tp.pieces, time_model=tp.time_model, **removal_kw)
    info = {**tp.info, "plane": tp.plane, "timing": tp.timing, "time_model": tp.time_model}
    prov = replace(res.provenance, params={**res.provenance.params, "path": info})
    return replace(res, provenance=prov, stats={**res.stats, "path": info})


# --- a whole job over its part ----------------------------------------------------------------


def part_slope_deg(surface: Surface) -> tuple[float, bool]:
    """Largest slope of the part against the x, y plane and whether it is a height field over x, y.

    Returns
    -------
    slope : float
        Largest angle between a face normal and the z axis, degrees (0 for a flat part).
    height_field : bool
        True when every face faces the same side of z (no fold over x, y).
    """
    n = meshops.face_normals(surface.vertices, surface.faces)
    a = meshops.face_areas(surface.vertices, surface.faces)
    nz = n[:, 2] * (1.0 if np.sum(a * n[:, 2]) >= 0 else -1.0)
    ok = a > 0
    return float(np.degrees(np.arccos(np.clip(nz[ok].min(), -1, 1)))) if ok.any() else 0.0, bool((nz[ok] > 0).all())


def choose_plane(surface: Surface, plane: str = "auto", flattening: Flattening | None = None) -> tuple[str, str]:
    """The simulation plane for a part and the reason, for ``plane="auto"`` (module docstring).

    Returns
    -------
    plane : {"xy", "unrolled"}
    reason : str
        One sentence for the output.
    """
    _check_choice("plane", plane, ("auto",) + PLANES)
    slope, hf = part_slope_deg(surface)
    if plane == "unrolled" and flattening is None:
        raise ParameterError("the unrolled plane needs the job's flattening.", "Use plane='xy'.")
    if plane != "auto":
        return plane, f"plane {plane} as asked (largest slope of the part {slope:.1f} deg)"
    if hf and slope <= AUTO_XY_MAX_SLOPE_DEG:
        return "xy", (f"projected x, y: the part is a height field with slopes up to {slope:.1f} deg "
                      f"(<= {AUTO_XY_MAX_SLOPE_DEG:g}), so the projection keeps footprints and areas within "
                      f"{100 * (1 / np.cos(np.radians(slope)) - 1):.0f} %")
    if flattening is None:
        return "xy", (f"projected x, y although the part slopes up to {slope:.1f} deg: no flattening was given "
                      "for the unrolled plane")
    why = (f"slopes up to {slope:.1f} deg (> {AUTO_XY_MAX_SLOPE_DEG:g})"
           + ("" if hf else " and folds over x, y"))
    return "unrolled", (f"unrolled (the flattening's plane): the part {why}, so its projection would squeeze "
                        "the steep parts; the depth is corrected by the flattening's local area ratio")


def part_region(surface: Surface, plane: str, flattening: Flattening | None = None) -> Region:
    """Outline of the part in the simulation plane: its boundary loops, outer = largest, mm."""
    pts = np.asarray(surface.vertices)[:, :2] if plane == "xy" else np.asarray(flattening.uv)
    loops = [pts[lp] for lp in meshops.boundary_loops(surface.faces)]
    if not loops:
        raise ParameterError("the part has no boundary, so it has no outline to simulate over.",
                             "Simulate an open (disc-like) part.")

    def area(p):
        return abs(0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))

    loops.sort(key=area, reverse=True)
    return Region(loops[0], tuple(loops[1:]))


def _pixel_centres(shape, origin, dx):
    ny, nx = shape
    return np.meshgrid(origin[0] + dx * np.arange(nx), origin[1] + dx * np.arange(ny))


def area_ratio_map(flattening: Flattening, shape, origin, dx: float, coarse_mm: float = 0.25) -> np.ndarray:
    """Plane area / part area of the flattening at each pixel of the unrolled plane, a smooth field.

    The ratio of each vertex (plane area / part area of the triangles around
    it) is interpolated linearly over the triangles on a grid of about
    ``coarse_mm`` and bilinearly from there to the pixels, so neither the
    triangles nor the coarse grid print a pattern into the depth; beyond the
    part's edge the values of the nearest grid point on it continue.
    """
    from scipy.ndimage import distance_transform_edt, map_coordinates

    from ..mapping import locate_points

    uv, xyz, f = flattening.uv, flattening.surface.vertices, flattening.surface.faces
    inc = meshops.vertex_face_incidence(len(uv), f)
    with np.errstate(divide="ignore", invalid="ignore"):
        vr = (inc @ meshops.face_areas(uv, f)) / (inc @ meshops.face_areas(xyz, f))
    vr = np.where(np.isfinite(vr) & (vr > 0), vr, 1.0)
    c = max(1, int(round(coarse_mm / dx)))
    ny, nx = shape
    X, Y = _pixel_centres(((ny - 1) // c + 2, (nx - 1) // c + 2), origin, dx * c)
    fid, bary, _ = locate_points(uv, f, np.column_stack([X.ravel(), Y.ravel()]), tol=0.0)
    coarse = np.einsum("ij,ij->i", bary, vr[f[np.maximum(fid, 0)]]).reshape(X.shape)
    out = (fid < 0).reshape(X.shape)
    if out.all():
        return np.ones(shape)
    if out.any():  # beyond the edge: the value of the nearest grid point on the part
        near = distance_transform_edt(out, return_distances=False, return_indices=True)
        coarse = coarse[near[0], near[1]]
    jj, ii = np.mgrid[0:ny, 0:nx]
    return map_coordinates(coarse, [jj / c, ii / c], order=1, mode="nearest")


def _region_mask(region: Region, shape, origin, dx, inset: float) -> np.ndarray:
    import shapely

    poly = shapely.Polygon(region.outer, [h for h in region.holes]).buffer(-inset)
    X, Y = _pixel_centres(shape, origin, dx)
    if poly.is_empty:
        return np.zeros(shape, bool)
    shapely.prepare(poly)
    return shapely.contains_xy(poly, X, Y)


def _tool_reach(tif) -> float:
    from .rotating import RotatingToolTIF

    if isinstance(tif, RotatingToolTIF):
        return float(tif.radius_mm)
    tifs = tif.tifs if isinstance(tif, DirectionalTIF) else (tif,)
    return 4.5 * max(t.params.get("sigma_mm", 0.5) for t in tifs)


def simulate_job(tool_path: ToolPath, surface: Surface, *, flattening: Flattening | None = None,
                 plane: str = "auto", timing: str = "machine", tif: TIF | DirectionalTIF | None = None,
                 dx_mm: float | None = None, max_pixels: int = 4_000_000, depth_nm: float = 200.0,
                 noise: ProcessNoise | None = None, seed: int = 0, spacing_mm: float | None = None,
                 band=None) -> dict[str, Any]:
    """Simulate a finished job's own path over its whole part, from a flat start.

    The start is flat, so what remains is what the path itself prints (its
    ripple and any non-uniform dwell); the removal is linear in the tool's
    rate, so it is scaled to remove ``depth_nm`` on average inside the part.

    Parameters
    ----------
    tool_path : ToolPath
        The job's machine path (its surface path and planar path inside).
    surface : Surface
        The part, mm.
    flattening : Flattening, optional
        The job's flattening (needed for the unrolled plane).
    plane : {"auto", "xy", "unrolled"}
        See :func:`choose_plane`.
    timing : {"machine", "dwell"}
        See :func:`timed_path`.
    tif : TIF, DirectionalTIF or RotatingToolTIF, optional
        Default: the paper's sponge at 230 rpm (:func:`~polishpath.simulate.rotating.default_tif`).
    dx_mm : float, optional
        Pixel pitch, mm; default the finest of 5 um that keeps the part within ``max_pixels``.
    max_pixels : int
        Refuse a grid larger than this (memory: about 40 bytes per pixel).
    depth_nm : float
        Mean depth removed inside the part (the tool's rate is scaled to it), nm.
    noise : ProcessNoise, optional
        Removal-rate fluctuation along the path (default none: the path's own marks only).
    seed : int
        Seed of the noise (recorded).
    spacing_mm : float, optional
        Dwell-point spacing on the part, mm, to name PSD peaks.
    band : (float, float), optional
        PSD band, 1/mm (default the paper's 1-100).

    Returns
    -------
    dict
        ``result`` (:class:`SimulationResult`, depth on the part), ``mask``
        ((Ny, Nx) bool: inside the part, away from its edge by the tool's
        reach), ``region``, ``plane``, ``plane_reason``, ``summary`` (JSON-ready
        figures: time, depth mean / RMS / PV inside, band RMS and peaks of the
        centre square, ``fair``: the fair figures of its residual (band RMS,
        lattice peak, PVn; :func:`~polishpath.simulate.fair.fair_metrics`; None
        when it is too small), all parameters) and ``psd`` (PSD of the centre square or None).
    """
    from ..psd.core import PAPER_BAND_PER_MM, band_rms, find_peaks
    from .profile import profile_psd
    from .rotating import default_tif

    band = PAPER_BAND_PER_MM if band is None else band
    if not (depth_nm > 0 and np.isfinite(depth_nm)):
        raise ParameterError(f"depth_nm must be a positive number of nm, got {depth_nm}.")
    tif = tif or default_tif()
    plane, reason = choose_plane(surface, plane, flattening)
    region = part_region(surface, plane, flattening)
    tpath = timed_path(tool_path, timing=timing, plane=plane)
    reach = _tool_reach(tif)
    x0, y0, x1, y1 = region.bounds
    x0, y0, x1, y1 = x0 - reach, y0 - reach, x1 + reach, y1 + reach
    area = (x1 - x0) * (y1 - y0)
    if dx_mm is None:
        dx_mm = max(0.005, float(np.sqrt(area / max_pixels)) * 1.0001)
    if not dx_mm > 0:
        raise ParameterError(f"dx_mm must be > 0 mm, got {dx_mm}.")
    if area / dx_mm**2 > max_pixels:
        raise ParameterError(f"a {x1 - x0:.1f} x {y1 - y0:.1f} mm grid at {1000 * dx_mm:g} um is "
                             f"{area / dx_mm ** 2 / 1e6:.1f} M pixels (limit {max_pixels / 1e6:g} M).",
                             f"Use a coarser pixel (dx >= {1000 * np.sqrt(area / max_pixels):.0f} um) or leave it automatic.")
    wp = flat_workpiece((x0, y0, x1, y1), dx_mm)
    res = simulate_path(tpath, wp, tif, noise=noise, seed=seed)
    removal = res.removal_nm.astype(np.float64)
    if plane == "unrolled":
        removal *= area_ratio_map(flattening, wp.shape, wp.origin_mm, dx_mm)
    mask = _region_mask(region, wp.shape, wp.origin_mm, dx_mm, reach)
    if mask.sum() < 16:
        raise ParameterError(f"the part is too small for this tool: nothing of it lies {reach:g} mm (the tool's "
                             "reach) inside its edge.", "Use a smaller tool.")
    mean = float(removal[mask].mean())
    scale = depth_nm / mean if mean > 0 else 1.0
    removal = (removal * scale).astype(np.float32)
    res = replace(res, removal_nm=removal, after_nm=(np.asarray(wp.height_nm, np.float32) - removal),
                  stats={**res.stats, "tif_rate_scale": scale})
    inside = removal[mask].astype(np.float64)
    psd, peaks, brms, square, zc = _centre_square_psd(res, mask, band, spacing_mm, profile_psd, band_rms, find_peaks)
    fair = None
    if zc is not None:  # the fair figures of the centre square's residual (polishpath.simulate.fair)
        from .fair import fair_metrics

        fm = fair_metrics(np.asarray(zc, dtype=np.float64), dx_mm, spacing_mm or 0.5, depth_nm, band=band)
        fair = {"residual_band_rms_nm": fm.residual_band_rms_nm, "lattice_peak_db": fm.lattice_peak_db,
                "pvn": fm.pvn, "residual_rms_nm": fm.residual_rms_nm, "residual_pv_nm": fm.residual_pv_nm,
                "spacing_mm": spacing_mm or 0.5}
    summary = {
        "plane": plane, "plane_reason": reason, "timing": timing, "time_model": tpath.time_model,
        "path": tpath.info, "total_time_s": res.stats["total_time_s"],
        "time_off_grid_s": res.stats["time_off_grid_s"], "dx_mm": dx_mm, "grid_shape": list(wp.shape),
        "grid_bounds_mm": [x0, y0, x1, y1], "edge_inset_mm": reach,
        "depth_mean_nm": float(inside.mean()), "depth_rms_nm": float(inside.std()),
        "depth_pv_nm": float(inside.max() - inside.min()),
        "depth_rms_rel": float(inside.std() / inside.mean()) if inside.mean() > 0 else 0.0,
        "centre_square_mm": square, "band_per_mm": list(band), "band_rms_nm": brms, "peaks": peaks, "fair": fair,
        "tif_rate_scale": scale, "seed": seed, "noise": None if noise is None else vars(noise).copy(),
        "tif": {"kind": tif.kind, **tif.params} if not isinstance(tif, DirectionalTIF)
        else {"kind": "directional", **tif.params},
        "motion": res.stats.get("motion") or None, "rotating": res.stats.get("rotating"),
    }
    return {"result": res, "mask": mask, "region": region, "plane": plane, "plane_reason": reason,
            "summary": summary, "psd": psd}


def _centre_square_psd(res, mask, band, spacing_mm, profile_psd, band_rms, find_peaks):
    """Profile PSD of the largest square inside the mask centred on its centroid (None when under 64 px)."""
    jj, ii = np.nonzero(mask)
    cj, ci = int(round(jj.mean())), int(round(ii.mean()))
    h = 0
    ny, nx = mask.shape
    lo, hi = 1, min(cj, ci, ny - 1 - cj, nx - 1 - ci)
    while lo <= hi:  # largest half-side whose square lies inside the mask
        mid = (lo + hi) // 2
        if mask[cj - mid:cj + mid + 1, ci - mid:ci + mid + 1].all():
            h, lo = mid, mid + 1
        else:
            hi = mid - 1
    if 2 * h + 1 < 64:
        return None, [], None, None, None
    z = res.after_nm[cj - h:cj + h + 1, ci - h:ci + h + 1]
    psd = profile_psd(z, res.dx_mm)
    o, dx = res.origin_mm, res.dx_mm
    square = [float(o[0] + (ci - h) * dx), float(o[1] + (cj - h) * dx), float(o[0] + (ci + h) * dx),
              float(o[1] + (cj + h) * dx)]
    peaks = find_peaks(psd, spacing_mm, band=band)
    return psd, peaks, float(band_rms(psd, *band)), square, z
