"""polishpath.smooth — NURBS through every dwell point, then constant-period samples.

Stage function :func:`smooth` turns a :class:`~polishpath.types.SurfacePath` into a
:class:`~polishpath.types.ToolPath` (paper section 4.2):

1. one cubic B-spline (a NURBS with weights 1) through all dwell points of each
   continuous piece (:func:`interpolate_nurbs`, banded O(N) solve), the pieces
   joined into one curve with full-multiplicity knots where the tool lifts;
2. a dwell time per point (uniform, scaled by the part area each point stands
   for, or given) turned into a feed schedule;
3. samples at a constant interpolation period with a curvature-limited feed
   (:func:`interpolate_constant_period`), the parameter advanced by one of two
   integrators (``integrator="taylor"``, the default, or ``"ab-am"``, the
   paper's Adams-Bashforth / Adams-Moulton; see ``docs/machine-output.md``).

Defaults (see ``docs/machine-output.md``): feed 600 mm/min (10 mm/s, the middle
of the 100-2000 mm/min range of small-tool sub-aperture polishing), period 4 ms
(CNC interpolation periods are 1-8 ms), chord tolerance 1 um (well under the
form tolerance of polished optics, so the straight moves do not show).
"""

from __future__ import annotations

import time

import numpy as np

from .. import progress
from ..defaults import DEFAULT_CHORD_TOL_MM, DEFAULT_FEED_MM_MIN, DEFAULT_PERIOD_MS, MAX_FEED_FACTOR
from ..errors import ParameterError, SmoothingError, optional
from ..pathops import step_mask
from ..types import NurbsCurve, Provenance, SampleSchedule, SurfacePath, ToolPath
from .interpolate import (
    DEFAULT_INTEGRATOR,
    INTEGRATORS,
    arc_lengths,
    chord_errors,
    dwell_regions,
    integrator_kernel,
    interpolate_constant_period,
)
from .boundary import BoundaryCheck, boundary_excursion
from .samples import DEFAULT_STREAM_SAMPLES, iter_sample_chunks
from .nurbs import (
    averaged_knots,
    basis_functions,
    bezier_cubic_through,
    evaluate,
    find_spans,
    interpolate_nurbs,
    interpolation_params,
    join_curves,
    span_polynomials,
)

__all__ = [
    "smooth",
    "iter_sample_chunks",
    "DEFAULT_STREAM_SAMPLES",
    "interpolate_nurbs",
    "evaluate",
    "interpolate_constant_period",
    "interpolation_params",
    "averaged_knots",
    "find_spans",
    "basis_functions",
    "span_polynomials",
    "join_curves",
    "arc_lengths",
    "chord_errors",
    "dwell_regions",
    "sample_normals",
    "curve_deviation",
    "boundary_excursion",
    "point_mesh_distance",
    "piece_curves",
    "DEFAULT_FEED_MM_MIN",
    "DEFAULT_PERIOD_MS",
    "DEFAULT_CHORD_TOL_MM",
    "DEFAULT_INTEGRATOR",
    "INTEGRATORS",
]


def _pieces_of(sp: SurfacePath) -> np.ndarray:
    n = len(sp.xyz)
    pieces = np.asarray(sp.planar.pieces, dtype=np.int64) if sp.planar is not None else np.array([0, n])
    if len(pieces) < 2 or pieces[0] != 0 or pieces[-1] != n or np.any(np.diff(pieces) <= 0):
        raise SmoothingError(
            f"The path's piece offsets {pieces.tolist()[:6]}... do not cover its {n} points in order.",
            "Give PlanarPath.pieces as increasing offsets from 0 to the number of points.",
        )
    return pieces


def _piece_curve(pts: np.ndarray, degree: int, parametrization: str) -> tuple[NurbsCurve, np.ndarray]:
    if len(pts) >= degree + 1:
        return interpolate_nurbs(pts, degree, parametrization)
    if degree != 3:
        raise SmoothingError(f"A piece of {len(pts)} points is too short for degree {degree}.")
    if len(pts) >= 2:
        interpolation_params(pts, parametrization)  # same repeated-point check
    return bezier_cubic_through(pts)


class _SampleSink:
    """The pieces' samples, params and feeds one after the other, copied as each piece ends into arrays sized for
    the whole path (``expect`` samples, grown by a quarter when short), so that the pieces' own arrays and their
    concatenation are never held at once (a 10^6-point figuring job's 3.3e7 samples: 1.4 GB, held twice at the end
    of the stage before). A path of one piece keeps that piece's arrays (no copy)."""

    def __init__(self, expect: float):
        self.expect = max(int(expect), 1024)
        self.first: tuple | None = None
        self.buf: tuple | None = None
        self.n = 0

    def add(self, pp: np.ndarray, pu: np.ndarray, pv: np.ndarray) -> None:
        if self.first is None and self.buf is None:
            self.first, self.n = (pp, pu, pv), len(pu)
            return
        if self.buf is None:  # a second piece: from here on, the buffer
            f, self.first = self.first, None
            self.buf = tuple(np.empty((max(self.expect, self.n + len(pu)),) + a.shape[1:], a.dtype) for a in f)
            for b, a in zip(self.buf, f):
                b[:self.n] = a
            del f
        m = len(pu)
        if self.n + m > len(self.buf[1]):
            cap = max(int(1.25 * (self.n + m)), self.n + m + 1024)
            grown = tuple(np.empty((cap,) + b.shape[1:], b.dtype) for b in self.buf)
            for g, b in zip(grown, self.buf):
                g[:self.n] = b[:self.n]
            self.buf = grown
        for b, a in zip(self.buf, (pp, pu, pv)):
            b[self.n:self.n + m] = a
        self.n += m

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(samples (M, 3), params (M,), feeds (M,)) of every piece in order."""
        if self.buf is not None:
            return tuple(b[:self.n] for b in self.buf)
        if self.first is not None:
            return tuple(np.ascontiguousarray(a) for a in self.first)
        return np.zeros((0, 3)), np.zeros(0), np.zeros(0)


def _handed_over(a: np.ndarray) -> np.ndarray:
    """``a`` marked read-only with every array it is a view of, so the ToolPath takes it without a copy
    (``types._is_frozen``: nothing else holds these arrays the stage just made)."""
    b = a
    while isinstance(b, np.ndarray):
        b.setflags(write=False)
        b = b.base
    return a


def piece_curves(curve: NurbsCurve, piece_params: np.ndarray) -> list[NurbsCurve]:
    """Split a joined curve back into its pieces (each clamped, parameter kept).

    Parameters
    ----------
    curve : NurbsCurve
        From :func:`smooth` (``ToolPath.curve``).
    piece_params : (K + 1,) float
        ``ToolPath.piece_params``: where each piece starts, the curve's end last.

    Returns
    -------
    list of NurbsCurve
        Control points and knots of each continuous piece (what one G06.2 block
        sequence runs).
    """
    p = curve.degree
    U = curve.knots
    out = []
    start_ctrl = 0
    for k in range(len(piece_params) - 1):
        a, b = piece_params[k], piece_params[k + 1]
        # knots of piece k: p+1 copies of a, the interior knots in (a, b), p+1 copies of b
        inner = U[(U > a) & (U < b)]
        n_ctrl = len(inner) + p + 1
        kn = np.concatenate([np.full(p + 1, a), inner, np.full(p + 1, b)])
        out.append(NurbsCurve(p, kn, curve.control_points[start_ctrl : start_ctrl + n_ctrl],
                              curve.weights[start_ctrl : start_ctrl + n_ctrl]))
        start_ctrl += n_ctrl
    return out


def sample_normals(tool_path: ToolPath) -> np.ndarray:
    """Unit surface normal at each sample, (M, 3).

    Interpolated linearly in the curve parameter between the normals of the two
    neighbouring dwell points (of the same piece), then normalised.
    """
    sp = tool_path.surface_path
    dp = tool_path.dwell_params
    u = tool_path.sample_params
    nrm = np.stack([np.interp(u, dp, sp.normals[:, j]) for j in range(3)], axis=1)
    ln = np.linalg.norm(nrm, axis=1, keepdims=True)
    near = sp.normals[np.clip(np.searchsorted(dp, u), 0, len(dp) - 1)]
    return np.where(ln > 1e-9, nrm / np.maximum(ln, 1e-300), near)


def point_mesh_distance(points: np.ndarray, surface) -> np.ndarray:
    """Distance from each point (M, 3) to a triangle mesh (Surface or trimesh.Trimesh), (M,) mm.

    libigl's AABB tree (``igl.point_mesh_squared_distance``) when installed
    (about 7x faster), else ``trimesh.proximity.closest_point``.
    """
    v = np.ascontiguousarray(surface.vertices, dtype=np.float64)
    f = np.ascontiguousarray(surface.faces, dtype=np.int64)
    igl = optional("igl")
    if igl is not None:
        d2, _, _ = igl.point_mesh_squared_distance(np.ascontiguousarray(points, dtype=np.float64), v, f)
        return np.sqrt(np.maximum(d2, 0.0))
    import trimesh

    mesh = trimesh.Trimesh(v, f, process=False)
    _, dist, _ = trimesh.proximity.closest_point(mesh, points)
    return np.asarray(dist)


def curve_deviation(
    curve: NurbsCurve,
    dwell_params: np.ndarray,
    xyz: np.ndarray,
    normals: np.ndarray,
    pieces: np.ndarray,
    surface=None,
    max_samples: int = 20000,
) -> dict:
    """How far the smooth curve strays between dwell points.

    At the parameter midpoint of (up to ``max_samples``, evenly chosen)
    dwell-point intervals, the curve point is compared with the straight step
    between the two dwell points: the *lateral overshoot* is its distance from
    that segment within the tangent plane (normal component removed, normal =
    mean of the two dwell normals); the *deviation from the surface* is its
    distance to the mesh (:func:`point_mesh_distance`), when ``surface`` is given.

    Returns
    -------
    dict
        ``lateral_overshoot_max`` (mm), ``normal_offset_max`` (mm, off the chord
        along the normal), ``surface_deviation_max`` / ``surface_deviation_mean``
        (mm, or None without surface), ``deviation_samples``.
    """
    idx = np.flatnonzero(step_mask(len(xyz), pieces))
    if len(idx) == 0:
        return {"lateral_overshoot_max": 0.0, "normal_offset_max": 0.0, "surface_deviation_max": None,
                "surface_deviation_mean": None, "deviation_samples": 0}
    if len(idx) > max_samples:
        idx = idx[np.linspace(0, len(idx) - 1, max_samples).astype(np.int64)]
    um = 0.5 * (dwell_params[idx] + dwell_params[idx + 1])
    pm = evaluate(curve, um)
    a, b = xyz[idx], xyz[idx + 1]
    e = b - a
    ll = np.einsum("ij,ij->i", e, e)
    t = np.clip(np.divide(np.einsum("ij,ij->i", pm - a, e), ll, out=np.zeros(len(ll)), where=ll > 0), 0, 1)
    dv = pm - (a + t[:, None] * e)
    n = normals[idx] + normals[idx + 1]
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    dn = np.einsum("ij,ij->i", dv, n)
    lat = np.linalg.norm(dv - dn[:, None] * n, axis=1)
    out = {"lateral_overshoot_max": float(lat.max()), "normal_offset_max": float(np.abs(dn).max()),
           "surface_deviation_max": None, "surface_deviation_mean": None, "deviation_samples": int(len(idx))}
    if surface is not None:
        dist = point_mesh_distance(pm, surface)
        out["surface_deviation_max"] = float(dist.max())
        out["surface_deviation_mean"] = float(dist.mean())
    return out


def smooth(
    surface_path: SurfacePath,
    *,
    feed_mm_min: float = DEFAULT_FEED_MM_MIN,
    period_ms: float = DEFAULT_PERIOD_MS,
    chord_tol_mm: float = DEFAULT_CHORD_TOL_MM,
    dwell_times: np.ndarray | None = None,
    area_weighted: bool = True,
    max_feed_mm_min: float | None = None,
    surface=None,
    degree: int = 3,
    parametrization: str = "chord",
    deviation_samples: int = 20000,
    schedule_passes: int = 2,
    integrator: str = DEFAULT_INTEGRATOR,
    keep_samples: bool = True,
    chunk_samples: int = DEFAULT_STREAM_SAMPLES,
    region_tol: float | None = None,
) -> ToolPath:
    """Smooth a surface path with a NURBS through every dwell point and sample it.

    Parameters
    ----------
    surface_path : SurfacePath
        Dwell points ``xyz`` (N, 3) mm, normals, ``dwell_weight`` (N,), pieces.
    feed_mm_min : float
        Mean feed, mm/min: the uniform dwell time is ``path length / (N F)``.
    period_ms : float
        Interpolation period, ms.
    chord_tol_mm : float
        Largest distance between the curve and the straight move between two samples, mm.
    dwell_times : (N,) float, optional
        Time around each dwell point, s (e.g. from a dwell-time CSV). Default:
        uniform, times ``dwell_weight`` when ``area_weighted``.
    area_weighted : bool
        Scale the default uniform dwell time by the part area each point stands
        for (``SurfacePath.dwell_weight``), so uniform removal stays uniform.
    max_feed_mm_min : float, optional
        Machine feed limit, mm/min (default ``defaults.MAX_FEED_FACTOR`` = 5 x ``feed_mm_min``).
    surface : Surface, optional
        The mesh, to measure the curve's deviation from it between dwell points
        and how far samples leave it over its boundary.
    degree : int
        Curve degree (3, the paper's cubic).
    parametrization : {"chord", "centripetal"}
    deviation_samples : int
        Most dwell intervals checked for the deviation figures.
    schedule_passes : int
        Most interpolation runs per piece: the first at the feeds solved from
        each region's time under the curvature limit, a further one only
        where regions are still off their time (see
        :func:`interpolate_constant_period`).
    region_tol : float, optional
        A dwell region off its time by more than this share is run again (up to ``schedule_passes`` runs);
        default :data:`~.interpolate.REGION_RERUN_TOL` (Taylor) / :data:`~.interpolate.DWELL_TIME_TOL`
        (whole passes). Figuring asks for less (``defaults.FIGURING_REGION_TOL``).
    integrator : {"taylor", "ab-am"}
        How the parameter advances each period: second-order Taylor predictor
        with an exact chord corrector (default), or the paper's Adams-Bashforth /
        Adams-Moulton (order 4); recorded in the provenance.
    keep_samples : bool
        False: hold no machine sample (a 10^7-point path has ~1.5e8): the
        ToolPath's sample arrays are empty ((0, 3) / (0,)), every figure is
        accumulated chunk by chunk of ``chunk_samples`` while the kernel runs
        (the same figures as with True, sums to about 1e-15 relative), and
        :func:`iter_sample_chunks` regenerates the samples from
        ``ToolPath.schedule``.
    chunk_samples : int
        Samples per chunk without ``keep_samples`` (memory is bounded by it; the Taylor kernel's chunks
        may hold up to 4,096 samples more, as it ends a chunk between dwell regions).

    Returns
    -------
    ToolPath
        ``curve`` (joined over pieces), ``dwell_params`` (N,), ``samples`` (M, 3),
        ``sample_params`` (M,), ``feed_mm_min`` (M,), ``stats``: the
        interpolation figures (over all pieces; ``dwell_time_error_p99`` /
        ``dwell_time_error_rms`` of the relative dwell-time errors beside
        ``dwell_time_error_max``), ``dwell_through_max`` (largest distance between
        the curve at a dwell parameter and its dwell point, mm), the deviation
        figures of :func:`curve_deviation`, ``boundary_excursion_max_mm`` (how far
        the farthest sample lies beyond the part's rim or over a hole, mm,
        :func:`boundary_excursion`; None without ``surface``) and
        ``boundary_excursion_samples`` (how many lie beyond it at all); the pieces are
        ``ToolPath.sample_pieces`` (K+1,) sample offsets and ``ToolPath.piece_params`` (K+1,) curve
        parameters; the times per dwell point are ``ToolPath.dwell_times``;
        ``schedule``: the :class:`~polishpath.types.SampleSchedule` that regenerates the samples.
    """
    t0 = time.perf_counter()
    xyz = np.asarray(surface_path.xyz)
    n = len(xyz)
    if n < 1:
        raise SmoothingError("The surface path has no dwell point.", "Plan a path with at least one point.")
    integrator_kernel(integrator)  # a bad name fails before the curve is fitted
    if isinstance(chunk_samples, bool) or not isinstance(chunk_samples, (int, np.integer)) or chunk_samples < 1:
        raise ParameterError(f"chunk_samples must be a whole number of samples >= 1, got {chunk_samples!r}.",
                             "Give e.g. chunk_samples=262144.")
    if max_feed_mm_min is None:
        max_feed_mm_min = MAX_FEED_FACTOR * feed_mm_min
    pieces = _pieces_of(surface_path)
    curves, params, lens = [], [], []
    for k in range(len(pieces) - 1):
        pts = xyz[pieces[k] : pieces[k + 1]]
        c, u = _piece_curve(pts, degree, parametrization)
        curves.append(c)
        params.append(u)
        lens.append(float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()))
    lens = np.asarray(lens)
    pos = lens[lens > 0]
    lens = np.where(lens > 0, lens, pos.mean() if len(pos) else 1.0)
    curve, off = join_curves(curves, lens)
    dwell_params = np.concatenate(
        [off[k] + (off[k + 1] - off[k]) * params[k] for k in range(len(curves))]
    )
    # the last dwell point of a piece sits just below the join (the join value is the next piece)
    ends = pieces[1:-1] - 1
    dwell_params[ends] = np.nextafter(off[1:-1], -np.inf)
    through = float(np.abs(evaluate(curve, dwell_params) - xyz).max())

    total_len = float(lens.sum())
    if dwell_times is None:
        w = np.asarray(surface_path.dwell_weight) if area_weighted else np.ones(n)
        base = total_len / (n * feed_mm_min / 60.0) if total_len > 0 else 1.0
        times = base * w
        time_source = "uniform x area weight" if area_weighted else "uniform"
    else:
        times = np.asarray(dwell_times, dtype=np.float64)
        if times.shape != (n,):
            raise ParameterError(
                f"dwell_times has shape {times.shape} but the path has {n} dwell points.",
                "Give one time (s) per dwell point, in path order.",
            )
        time_source = "given"
    check = None
    if surface is not None:
        steps = np.linalg.norm(np.diff(xyz, axis=0), axis=1)
        steps[pieces[1:-1] - 1] = 0.0  # the lifts between pieces are not on the curve
        check = BoundaryCheck(surface, reach=float(steps.max()) if len(steps) else 0.0)
    sink = _SampleSink(1.05 * float(times.sum()) / (period_ms / 1000.0) + 1024 * len(curves)) if keep_samples else None
    spieces, dwell_err = [0], []
    ranges, bounds, rfeeds = [], [], []
    exc_max, exc_n = 0.0, 0
    agg: dict = {}
    for k in range(len(curves)):
        sl = slice(pieces[k], pieces[k + 1])
        res = interpolate_constant_period(
            curve, feed_mm_min, period_ms, chord_tol_mm,
            dwell_params=dwell_params[sl], dwell_times=times[sl],
            max_feed_mm_min=max_feed_mm_min, u_range=(off[k], np.nextafter(off[k + 1], -np.inf)),
            schedule_passes=schedule_passes, integrator=integrator, region_tol=region_tol,
            keep_samples=keep_samples, chunk_samples=int(chunk_samples),
            chunk_check=check.tally if check is not None else None,
        )
        if keep_samples:
            sink.add(res["samples"], res["params"], res["feed_mm_min"])
        if check is not None:
            exc_max = max(exc_max, res["chunk_check"].max_mm)
            exc_n += res["chunk_check"].count
        ranges.append(res["u_range"])
        bounds.append(res["region_bounds"])
        rfeeds.append(res["region_feed"])
        dwell_err.append(res["dwell_time_error"])
        spieces.append(spieces[-1] + res["stats"]["n_samples"])
        if len(curves) > 1:
            progress.update(int(pieces[k + 1]), n, f"dwell points ({spieces[-1]:,} samples)")
        for key, val in res["stats"].items():
            if key in ("n_samples", "duration_s", "curve_length", "interpolation_s", "schedule_corrected_regions",
                       "schedule_rerun_samples"):
                agg[key] = agg.get(key, 0) + val
            elif key.endswith("_min_mm_min"):
                agg[key] = min(agg.get(key, np.inf), val)
            elif key == "integrator":
                agg[key] = val
            elif key in ("feed_fluctuation_rms", "feed_limited_share", "fallback_share"):
                agg.setdefault(key + "_pieces", []).append(val)
            else:
                agg[key] = max(agg.get(key, -np.inf), val)
        res = None  # the piece's samples are in the sink: its own arrays go before the next piece runs
    for key in ("feed_fluctuation_rms", "feed_limited_share", "fallback_share"):
        vals = np.asarray(agg.pop(key + "_pieces"))
        if key.endswith("_rms"):  # root of the sample-weighted mean square over the pieces
            agg[key] = float(np.sqrt(np.average(vals**2, weights=np.diff(spieces))))
        else:
            agg[key] = float(np.average(vals, weights=np.diff(spieces)))
    stats = dict(agg)
    derr = np.abs(np.concatenate(dwell_err))
    stats.update(dwell_time_error_p99=float(np.percentile(derr, 99)),
                 dwell_time_error_rms=float(np.sqrt(np.mean(derr**2))))
    stats.update(curve_deviation(curve, dwell_params, xyz, surface_path.normals, pieces, surface, deviation_samples))
    progress.update(spieces[-1], None, "samples; checking the curve and the boundary")
    if check is not None:
        stats.update(boundary_excursion_max_mm=float(exc_max), boundary_excursion_samples=int(exc_n))
    else:
        stats.update(boundary_excursion_max_mm=None, boundary_excursion_samples=None)
    schedule = SampleSchedule(
        piece_params=np.asarray(ranges, dtype=np.float64).reshape(-1, 2), dwell_pieces=pieces,
        region_bounds=np.concatenate(bounds), region_feeds=np.concatenate(rfeeds),
        max_feed_mm_s=max_feed_mm_min / 60.0, period_ms=float(period_ms), chord_tol_mm=float(chord_tol_mm),
        integrator=integrator, sample_pieces=np.asarray(spieces, dtype=np.int64))
    stats.update(
        dwell_through_max=through,
        n_dwell_points=int(n),
        n_control_points=int(len(curve.control_points)),
        dwell_time_source=time_source,
        dwell_time_total_s=float(times.sum()),
        seconds=time.perf_counter() - t0,
    )
    prov = Provenance(
        "smooth",
        f"nurbs{degree}_{parametrization}+constant_period",
        {"feed_mm_min": float(feed_mm_min), "period_ms": float(period_ms), "chord_tol_mm": float(chord_tol_mm),
         "max_feed_mm_min": float(max_feed_mm_min), "degree": int(degree), "parametrization": parametrization,
         "area_weighted": bool(area_weighted), "dwell_times": time_source,
         "schedule_passes": int(schedule_passes), "integrator": integrator,
         **({"region_tol": float(region_tol)} if region_tol is not None else {})},
        seed=surface_path.provenance.seed,
    )
    if keep_samples:
        all_samples, all_params, all_feeds = (_handed_over(a) for a in sink.arrays())
    else:
        all_samples, all_params, all_feeds = np.zeros((0, 3)), np.zeros(0), np.zeros(0)
    return ToolPath(curve=curve, dwell_params=dwell_params, samples=all_samples,
                    sample_params=all_params, feed_mm_min=all_feeds,
                    period_ms=float(period_ms), surface_path=surface_path, provenance=prov, stats=stats,
                    dwell_times=times, schedule=schedule, sample_pieces=schedule.sample_pieces, piece_params=off)
