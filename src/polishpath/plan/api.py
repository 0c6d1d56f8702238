"""``plan()``: dwell grid + a registered pattern -> :class:`~polishpath.types.PlanarPath`."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from .._version import __version__
from ..errors import ParameterError
from ..provenance import resolve_seed
from ..types import Lattice, PlanarPath, Provenance, Region
from . import baselines
from .checks import check_index, check_options, check_point, check_region, check_seed
from .bluewalk import GRAPH_WALK_OPTIONS, graph_walk_order
from .dwell import DwellGrid, check_grid, dwell_grid
from .points import DWELL_POINT_SETS, blue_noise_points, relaxed_points
from .pseudorandom import PSEUDORANDOM_OPTIONS, pseudorandom_order


@dataclass(frozen=True)
class PatternResult:
    """What a pattern function returns.

    Attributes
    ----------
    uv : (N, 2) float64
        Path points in order, mm.
    ij : (N, 2) int64
        Grid index of each point (nearest index when ``dwell_points_only`` is False).
    pieces : (K+1,) int64
        Offsets of the continuous pieces.
    dwell_points_only : bool
        True when every point is a dwell point (of the grid); False for a path through
        other points too (``PlanarPath.dwell_points_only``).
    stats : dict
        Pattern-specific figures.
    lattice : Lattice or None, keyword, required
        The dwell points' lattice (``grid.lattice`` for the grid), None for a set without one
        (``PlanarPath.lattice``).
    """

    uv: np.ndarray
    ij: np.ndarray
    pieces: np.ndarray
    dwell_points_only: bool = True
    stats: dict[str, Any] = field(default_factory=dict)
    lattice: Lattice | None = field(kw_only=True)


#: A pattern: ``fn(grid, region, *, seed, start) -> PatternResult`` where
#: ``start`` is the dwell-point number to begin with.
PatternFn = Callable[..., PatternResult]


def check_pattern_call(grid: DwellGrid, seed, start) -> tuple[int, int]:
    """Checked ``(seed, start)`` of a pattern function called directly (:func:`plan` has checked them already).

    Raises
    ------
    ParameterError
        Not a DwellGrid, a bad seed, or ``start`` not a dwell-point number.
    """
    check_grid(grid)
    return check_seed(seed), check_index(start, "The start", grid.n)


def _on_grid(grid: DwellGrid, order: np.ndarray, pieces: np.ndarray, stats: dict) -> PatternResult:
    return PatternResult(grid.uv[order], grid.ij[order], pieces, True, stats, lattice=grid.lattice)


def _pattern_pseudorandom(grid: DwellGrid, region: Region, *, seed: int, start: int, **options) -> PatternResult:
    check_options("pseudorandom", options, PSEUDORANDOM_OPTIONS)
    order, pieces, stats = pseudorandom_order(grid, seed=seed, start=start, **options)
    return _on_grid(grid, order, pieces, stats)


def _pattern_raster(grid: DwellGrid, region: Region, *, seed: int, start: int, **options) -> PatternResult:
    check_options("raster", options, ())
    order, pieces = baselines.clip_grid_sequence(grid, baselines.raster_sequence(grid))
    return _on_grid(grid, order, pieces, {})


def _pattern_rectangular(grid: DwellGrid, region: Region, *, seed: int, start: int, **options) -> PatternResult:
    check_options("rectangular", options, ())
    order, pieces = baselines.clip_grid_sequence(grid, baselines.rectangular_sequence(grid, grid.ij[start]), chords=False)
    return _on_grid(grid, order, pieces, {})


def _pattern_spiral(grid: DwellGrid, region: Region, *, seed: int, start: int, **options) -> PatternResult:
    check_options("spiral", options, ())
    centre = grid.uv[start]
    rmax = float(np.hypot(*(np.asarray(region.outer) - centre).T).max())
    uv, pieces = baselines.archimedean_spiral(grid, centre, rmax)
    return PatternResult(uv, baselines.nearest_ij(grid, uv), pieces, False, {}, lattice=grid.lattice)


#: Registered patterns by name. Add a peer with :func:`register_pattern`.
PATTERNS: dict[str, PatternFn] = {
    "pseudorandom": _pattern_pseudorandom,
    "raster": _pattern_raster,
    "spiral": _pattern_spiral,
    "rectangular": _pattern_rectangular,
}

#: Patterns that use the random seed.
RANDOM_PATTERNS = {"pseudorandom"}


def register_pattern(name: str, fn: PatternFn, *, random: bool = False) -> None:
    """Register a path pattern under ``name`` (the Table 3 peers in :mod:`polishpath.plan.peers` register this way).

    Parameters
    ----------
    name : str
        Pattern name used by :func:`plan` and ``--pattern``.
    fn : callable
        ``fn(grid, region, *, seed, start, **options) -> PatternResult``.
    random : bool
        Whether the pattern uses ``seed`` (recorded in the provenance).

    Raises
    ------
    ParameterError
        ``name`` is not a non-empty string or ``fn`` is not callable.
    """
    if not isinstance(name, str) or not name.strip():
        raise ParameterError(f"A pattern name must be a non-empty string, got {name!r}.",
                             "Pass the name used with plan(..., pattern=name) and --pattern.")
    if not callable(fn):
        raise ParameterError(f"Pattern {name!r}: fn must be callable, got {type(fn).__name__}.",
                             "Pass a function fn(grid, region, *, seed, start, **options) -> PatternResult.")
    PATTERNS[name] = fn
    if random:
        RANDOM_PATTERNS.add(name)


def nearest_dwell_point(grid: DwellGrid, point) -> int:
    """Number of the dwell point nearest ``point`` (2,) mm (:class:`ParameterError` for a bad grid or point)."""
    check_grid(grid)
    p = check_point(point, "The point")
    return int(np.argmin(np.hypot(grid.uv[:, 0] - p[0], grid.uv[:, 1] - p[1])))


def plan(
    region: Region,
    spacing: float,
    pattern: str = "pseudorandom",
    *,
    seed: int | None = 0,
    start=None,
    margin: float = 0.0,
    origin=None,
    rotation: float = 0.0,
    dwell_points: str = "grid",
    **options,
) -> PlanarPath:
    """Plan a tool path through the dwell points of a region.

    Parameters
    ----------
    region : Region
        Planar region (the flattened surface's domain, or a polygon), mm.
    spacing : float
        Dwell-point spacing, mm.
    pattern : str
        One of :data:`PATTERNS`: ``"pseudorandom"`` (default), ``"raster"``,
        ``"spiral"``, ``"rectangular"``, and the Table 3 peers ``"unicursal"``,
        ``"maze"``, ``"fractal"``, ``"hilbert"`` (:mod:`polishpath.plan.peers`).
    seed : int or None
        Random seed (random patterns), ``0 <= seed < 2**63``; None draws one
        (see :func:`polishpath.provenance.resolve_seed`), which is recorded in
        the provenance. Same seed, same path, bit for bit.
    start : (2,) array_like, optional
        Start near this point, mm; default the region's area centroid. The path
        starts at the dwell point nearest to it.
    margin : float
        Keep dwell points and steps this far inside the boundary, mm.
    origin : (2,) array_like, optional
        Plane position of grid index (0, 0), mm; default centres the grid.
    rotation : float
        Grid rotation, radians.
    dwell_points : {"grid", "blue-noise"}
        The dwell-point set (:data:`polishpath.plan.points.DWELL_POINT_SETS`): ``"grid"``, the paper's
        square grid; ``"blue-noise"``, a Poisson-disk set with no lattice at the grid's density, walked
        along its planar neighbour graph (:func:`_plan_blue_noise`; pattern ``"pseudorandom"`` only, whose
        options are then ``max_blind``, ``steer``, ``backtrack``, ``backtrack_budget``).
    **options
        Passed to the pattern (pseudo-random: ``window``, ``backtrack``,
        ``backtrack_budget``, ``max_blind``, ``shortest``, ``steer``,
        ``max_kicks``, see
        :func:`~polishpath.plan.pseudorandom.pseudorandom_order`; unicursal:
        ``tree``, ``phase``; maze: ``tree``; the others take none). An option
        the pattern does not take is refused.

    Returns
    -------
    PlanarPath
        ``uv`` (N, 2) mm, ``ij`` (N, 2), ``pieces``, ``unreached`` (dwell points
        not visited, mm), ``n_inside``, provenance and ``stats`` (including
        ``seconds``, ``grid_seconds``); ``lattice`` (the grid's) and ``dwell_points_only``.

    Raises
    ------
    ParameterError
        Not a Region; unknown pattern or option; bad spacing / margin / seed / start.
    SpacingTooLargeError
        Fewer than two dwell points fit.
    """
    check_region(region)
    if not isinstance(pattern, str) or pattern not in PATTERNS:
        raise ParameterError(
            f"Unknown path pattern {pattern!r}.", f"Choose one of: {', '.join(sorted(PATTERNS))}."
        )
    if not isinstance(dwell_points, str) or dwell_points not in DWELL_POINT_SETS:
        raise ParameterError(f"Unknown dwell-point set {dwell_points!r}.",
                             f"Choose one of: {', '.join(DWELL_POINT_SETS)}.")
    seed = resolve_seed(seed)  # checked, or drawn when None: the one place (polishpath.provenance)
    start_pt = region.centroid if start is None else check_point(start, "The start point")
    if dwell_points != "grid":
        return _plan_blue_noise(region, spacing, pattern, seed=seed, start_pt=start_pt, pin_start=start is not None,
                                margin=margin,
                                origin=origin, rotation=rotation, options=options, dwell_points=dwell_points)
    t0 = time.perf_counter()
    grid = dwell_grid(region, spacing, margin=margin, origin=origin, rotation=rotation)
    t1 = time.perf_counter()
    start_idx = nearest_dwell_point(grid, start_pt)
    res = PATTERNS[pattern](grid, region, seed=seed, start=start_idx, **options)
    t2 = time.perf_counter()

    # dwell points not visited: by grid index (nearest index for off-grid patterns)
    visited = np.zeros(grid.n, dtype=bool)
    if len(res.ij):
        H, W = (int(x) for x in grid.dense_shape)
        i0, j0 = (int(x) for x in grid.dense_offset)
        rel = res.ij - np.array([i0, j0])
        inb = (rel[:, 0] >= 0) & (rel[:, 0] < W) & (rel[:, 1] >= 0) & (rel[:, 1] < H)
        dense = rel[inb, 1] * W + rel[inb, 0]
        pos = np.minimum(np.searchsorted(grid.dense_id, dense), grid.n - 1)
        visited[pos[grid.dense_id[pos] == dense]] = True
    stats = dict(res.stats)
    stats.update(
        n_pieces=int(len(res.pieces) - 1),
        start_index=[int(x) for x in grid.ij[start_idx]],
        grid_seconds=t1 - t0,
        seconds=t2 - t0,
    )
    params = {
        "spacing": float(spacing),
        "margin": float(margin),
        "origin": [float(x) for x in grid.origin],
        "rotation": float(rotation),
        "start": [float(x) for x in start_pt],
        **{k: (v if isinstance(v, (int, float, str, bool)) else repr(v)) for k, v in options.items()},
    }
    return PlanarPath(
        uv=res.uv,
        ij=res.ij,
        spacing=float(spacing),
        origin=grid.origin,
        rotation=float(rotation),
        pattern=pattern,
        pieces=res.pieces,
        unreached=grid.uv[~visited],
        n_inside=grid.n,
        provenance=Provenance(
            "plan", pattern, params, seed if pattern in RANDOM_PATTERNS else None, __version__
        ),
        stats=stats,
        lattice=res.lattice,
        dwell_points_only=bool(res.dwell_points_only),
    )


def _plan_blue_noise(region: Region, spacing: float, pattern: str, *, seed: int, start_pt: np.ndarray,
                     pin_start: bool = False, margin: float,
                     origin, rotation: float, options: dict, dwell_points: str = "blue-noise") -> PlanarPath:
    """:func:`plan` on a blue-noise set (no lattice): the pseudo-random walk along its neighbour graph.

    The path's ``ij`` holds each point's number in the set and 0 (there are no grid indices),
    ``cell_area`` each point's Voronoi cell (mm^2), ``lattice`` is None.
    """
    if pattern != "pseudorandom":
        raise ParameterError(
            f"The {pattern} pattern runs on the square grid only; --dwell-points blue-noise is walked by the "
            "pseudo-random path.", "Use --dwell-points grid with this pattern, or --pattern pseudorandom.")
    if origin is not None or rotation:
        raise ParameterError("origin and rotation place a grid; a blue-noise set has none.",
                             "Leave origin and rotation out with dwell_points='blue-noise'.")
    check_options("pseudorandom", options, GRAPH_WALK_OPTIONS)
    t0 = time.perf_counter()
    build = relaxed_points if dwell_points == "relaxed" else blue_noise_points
    pts = build(region, spacing, seed=seed, margin=margin)
    t1 = time.perf_counter()
    start_idx = int(np.argmin(np.hypot(pts.uv[:, 0] - start_pt[0], pts.uv[:, 1] - start_pt[1])))
    # a start the user gave is the path's first point; the default (nearest the centre) is where the walk grows
    # from, and the path may begin elsewhere (stats["first_point"])
    order, pieces, stats = graph_walk_order(pts, seed=seed, start=start_idx, pin_start=pin_start, **options)
    t2 = time.perf_counter()
    visited = np.zeros(pts.n, dtype=bool)
    visited[order] = True
    stats.update(n_pieces=int(len(pieces) - 1), start_point=start_idx, first_point=int(order[0]),
                 points_seconds=t1 - t0,
                 grid_seconds=t1 - t0, seconds=t2 - t0, min_distance=pts.min_distance,
                 edges=int(len(pts.indices) // 2))
    params = {
        "spacing": float(spacing),
        "margin": float(margin),
        "dwell_points": dwell_points,
        "start": [float(x) for x in start_pt],
        **{k: (v if isinstance(v, (int, float, str, bool)) else repr(v)) for k, v in options.items()},
    }
    ij = np.stack([order, np.zeros_like(order)], axis=1)
    return PlanarPath(
        uv=pts.uv[order], ij=ij, spacing=float(spacing), origin=np.zeros(2), rotation=0.0, pattern=pattern,
        pieces=pieces, unreached=pts.uv[~visited], n_inside=pts.n,
        provenance=Provenance("plan", pattern, params, seed, __version__), stats=stats,
        lattice=None, dwell_points_only=True, dwell_points=dwell_points, cell_area=pts.cell_area[order])
