"""Plan and map, wired: :func:`plan_on_surface` with the step-reduction loop that honours the spacing on the part.

Part of the one wiring place (the :mod:`polishpath.pipeline` package); the job,
the paper reproduction, the simulation's pattern comparison and the benchmarks call it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from .. import progress, resources
from ..defaults import DEFAULT_MAX_OVERSAMPLING, DEFAULT_MAX_POINTS
from ..errors import MappingError, ParameterError, PlanningError, SpacingTooLargeError
from ..pathops import step_mask
from ..plan.points.blue_noise import EDGE_FACTOR
from ..types import Flattening, PlanarPath, Region, SurfacePath

SQRT2 = 2.0**0.5
#: margin planned inside the boundary when none is given, as a fraction of the planar spacing: the
#: cubic through the dwell points swings out by up to ~0.4 x the step at a sharp turn, but a turn right
#: at the boundary that swings outward is rare; measured on the annulus asphere and the hemisphere,
#: 0.2 x the spacing kept every sample within 3 um of the part (docs/machine-output.md)
AUTO_MARGIN_FACTOR = 0.25


@dataclass(frozen=True)
class SurfacePlan:
    """A path planned in the plane and carried onto the part (:func:`plan_on_surface`).

    Attributes
    ----------
    planar : PlanarPath
        Dwell points in the plane, ``uv`` (N, 2) mm, in path order.
    surface_path : SurfacePath
        The same points on the part, ``xyz`` (N, 3) mm; with ``spacing_on="surface"``
        its ``stats`` also hold ``planar_spacing``, ``step_reduction_factor``,
        ``replans`` and ``grid_step_max`` (mm).
    planar_spacing : float
        The planar grid spacing used, mm (the spacing itself with ``spacing_on="plane"``).
    """

    planar: PlanarPath
    surface_path: SurfacePath
    planar_spacing: float


def plan_on_surface(
    flat: Flattening,
    region: Region,
    spacing: float,
    *,
    pattern: str = "pseudorandom",
    seed: int | None,
    dwell_points: str = "grid",
    spacing_on: str = "surface",
    start: tuple[float, float] | None = None,
    margin: float | None = 0.0,
    max_points: int = DEFAULT_MAX_POINTS,
    max_oversampling: float = DEFAULT_MAX_OVERSAMPLING,
) -> SurfacePlan:
    """Plan a path on a flattened part and map it back: the one place plan and map are wired.

    Parameters
    ----------
    flat : Flattening
        The flattening of the part (``flat.uv`` (V, 2) mm).
    region : Region
        Where to plan, in the plane of ``flat`` (usually ``boundary_region(flat)``), mm.
    spacing : float
        Dwell-point spacing, mm: on the part with ``spacing_on="surface"``, in the
        plane with ``"plane"``.
    pattern : str
        A pattern of :data:`polishpath.plan.PATTERNS`.
    seed : int or None
        Seed of the pattern's random choices (None only for patterns without any).
    dwell_points : {"grid", "blue-noise"}
        The dwell-point set (see :func:`polishpath.plan.plan`). A blue-noise set's steps are its graph's
        edges, at most ``EDGE_FACTOR`` x its planar spacing: with ``spacing_on="surface"`` no step on the
        part exceeds ``EDGE_FACTOR`` x ``spacing`` (instead of the grid's sqrt(2)).
    spacing_on : {"surface", "plane"}
        ``surface``: the planar spacing is reduced (re-planning up to 7 times)
        until no grid step on the part exceeds sqrt(2) x ``spacing``; ``plane``:
        one plain planar grid of ``spacing``.
    start : (u, v) or None
        Planar start point, mm; None: the dwell point nearest the region's centre.
    margin : float or None
        Keep dwell points at least this far inside the boundary (in the plane), mm;
        None: :data:`AUTO_MARGIN_FACTOR` x the planar spacing (of each re-plan).
    max_points : int
        Refuse to plan more dwell points than this.
    max_oversampling : float
        Refuse when honouring the spacing on the part needs more than this many
        times the dwell points of a uniform grid on the part (area / spacing^2).

    Returns
    -------
    SurfacePlan

    Raises
    ------
    ParameterError
        ``spacing_on`` unknown or ``spacing`` not a positive number.
    PlanningError
        The plan would need more dwell points than ``max_points`` / ``max_oversampling`` allow.
    SpacingTooLargeError
        Fewer than two dwell points fit (the message gives the region's size).
    MappingError
        A pattern other than the pseudo-random walk placed points outside the part.
    """
    from ..mapping import map_to_surface
    from ..plan import plan

    if spacing_on not in ("surface", "plane"):
        raise ParameterError(f"spacing_on must be 'surface' or 'plane', got {spacing_on!r}.")
    if not (isinstance(spacing, (int, float)) and math.isfinite(spacing) and spacing > 0):
        raise ParameterError(f"spacing must be a positive number of mm, got {spacing!r}.")
    surface = flat.surface
    surface_area = float(flat.metrics.get("area_3d") or region.area)

    def planner(planar_spacing: float) -> PlanarPath:
        estimate = region.area / planar_spacing**2
        uniform = surface_area / spacing**2
        if estimate > max_points or estimate > max_oversampling * uniform:
            raise PlanningError(
                f"keeping steps under sqrt(2) x {spacing:g} mm on the part needs a planar spacing of "
                f"{planar_spacing:.3g} mm, about {estimate:.3g} dwell points where a uniform grid on the part "
                f"would have {uniform:.3g}: the {flat.provenance.method} flattening of {surface.name} stretches "
                f"part of it {spacing / planar_spacing:.3g} times (mean |log area ratio| "
                f"{flat.metrics.get('area_distortion_mean', float('nan')):.3g}).",
                "Use --spacing-on plane (plain planar grid: larger steps where it stretches), or cut the part into "
                "less closed patches; raise --max-oversampling / --max-points to go on anyway.",
            )
        m = AUTO_MARGIN_FACTOR * planar_spacing if margin is None else margin
        return plan(region, planar_spacing, pattern, seed=seed, start=start, margin=m, dwell_points=dwell_points)

    try:
        if spacing_on == "surface":
            factor = SQRT2 if dwell_points == "grid" else EDGE_FACTOR
            planar, spath, planar_spacing = _honour_surface_spacing(flat, spacing, planner, max_step_factor=factor,
                                                                    first_factor=SQRT2)
        else:
            planar_spacing = spacing
            planar = planner(planar_spacing)
            spath = map_to_surface(flat, planar)
    except MappingError as exc:
        if pattern == "pseudorandom":
            raise
        raise MappingError(
            f"the {pattern} pattern places dwell points outside the part: {exc.message}",
            f"That is how the {pattern} path is built (see docs/peer-paths.md); it cannot be run on this part. "
            "Compare it with benchmarks/table3.py, or choose another --pattern.",
        ) from None
    except SpacingTooLargeError as exc:
        x0, y0, x1, y1 = region.bounds
        raise SpacingTooLargeError(
            f"spacing {spacing:g} mm is too large for {surface.name} "
            f"(its flattened region is {x1 - x0:.4g} x {y1 - y0:.4g} mm): {exc.message}",
            resources.units_hint(surface) or "Use a smaller --spacing (at most about half the part's width).",
        ) from None
    return SurfacePlan(planar, spath, float(planar_spacing))


def _grid_step_max(planar: PlanarPath, mapped: SurfacePath) -> float:
    """Largest 3D step between consecutive dwell points that are grid neighbours, mm.

    Moves that are not grid steps (a raster's connecting chord along the
    boundary, the jump between pieces) are transit moves of the pattern, not
    dwell steps, so they do not set the spacing: where every path point is a
    dwell point of a lattice, only the lattice's neighbour steps count; else
    (the spiral's points off the grid) every step within a piece counts. A
    dwell-point set without a lattice (blue noise): the longest edge its graph
    may have (``EDGE_FACTOR`` x the planar spacing) times the largest 3D /
    planar length ratio of the path's steps.
    """
    d = np.linalg.norm(np.diff(mapped.xyz, axis=0), axis=1)
    if len(d) == 0:
        return 0.0
    valid = step_mask(len(mapped.xyz), planar.pieces)
    if planar.dwell_points != "grid":
        # a set without a lattice: its graph's longest possible edge (EDGE_FACTOR x the planar spacing) at
        # the largest stretch measured along the path's steps, so that a flat part keeps the spacing asked
        d2 = np.hypot(*np.diff(planar.uv, axis=0).T)
        ok = valid & (d2 > 0)
        return float(EDGE_FACTOR * planar.spacing * (d[ok] / d2[ok]).max()) if ok.any() else 0.0
    if planar.lattice is not None and planar.dwell_points_only:
        valid &= planar.lattice.is_step(np.diff(planar.ij, axis=0))
    return float(d[valid].max()) if valid.any() else 0.0


def _honour_surface_spacing(
    flat: Flattening,
    spacing: float,
    planner: Callable[[float], PlanarPath],
    *,
    max_step_factor: float = SQRT2,
    first_factor: float | None = None,
    start_quantile: float = 0.99,
    max_iter: int = 6,
) -> tuple[PlanarPath, SurfacePath, float]:
    """Plan and map so that no 3D grid step exceeds ``max_step_factor x spacing``.

    The paper's "step reduction factor" found on the actual path. Starts from
    the planar spacing given by an area-weighted quantile of the map's stretch
    (:func:`polishpath.mapping.planar_spacing_for_surface`), maps the planned
    path and measures its largest 3D grid step, then rescales the planar spacing
    by ``limit / largest step`` (up or down: a pattern that makes few diagonal
    steps may allow a larger spacing) and re-plans, keeping the largest spacing
    whose path fits. It stops when a fitting path's largest step is within 2 %
    of the limit, or after ``max_iter`` plans; if none fitted it falls back to
    the strict bound (quantile 1), which holds for every 8-neighbour step inside
    the mesh.

    Parameters
    ----------
    flat : Flattening
    spacing : float
        Wanted spacing on the part, mm.
    planner : callable
        ``planner(planar_spacing_mm) -> PlanarPath``.
    max_step_factor : float
        Allowed largest 3D step / spacing.
    first_factor : float or None
        The step factor of the first try's planar spacing (None: ``max_step_factor``; a blue-noise set
        starts where the grid does, sqrt(2)).
    start_quantile : float
        Quantile of the stretch used for the first try.
    max_iter : int
        Most plans before the strict fallback.

    Returns
    -------
    planar : PlanarPath
    mapped : SurfacePath
        ``stats`` also hold ``planar_spacing``, ``step_reduction_factor``
        (planar / surface spacing), ``replans`` (plans made) and ``grid_step_max`` (mm).
    h : float
        The planar spacing used, mm.
    """
    from ..mapping import map_to_surface, planar_spacing_for_surface

    limit = max_step_factor * spacing
    h = planar_spacing_for_surface(flat, spacing, first_factor or max_step_factor, quantile=start_quantile)
    best = None
    tries = 0
    for _ in range(max(1, max_iter)):
        planar = planner(h)
        mapped = map_to_surface(flat, planar, surface_spacing=spacing)
        tries += 1
        progress.update(planar.n_points, None, f"dwell points in plan {tries}")
        m = _grid_step_max(planar, mapped)
        fits = m <= limit * (1 + 1e-9)
        if fits and (best is None or h > best[2]):
            best = (planar, mapped, h)
        ratio = limit / m if m > 0 else 2.0
        if fits and ratio < 1.02:
            break
        h_next = h * min(ratio, 2.0) * 0.999
        if best is not None and h_next <= best[2] * 1.0001:
            break
        h = h_next
    if best is None:
        h = planar_spacing_for_surface(flat, spacing, first_factor or max_step_factor, quantile=1.0)
        planar = planner(h)
        best = (planar, map_to_surface(flat, planar, surface_spacing=spacing), h)
        tries += 1
    planar, mapped, h = best
    figures = {"planar_spacing": float(h), "step_reduction_factor": float(h / spacing), "replans": tries,
               "grid_step_max": _grid_step_max(planar, mapped)}
    mapped = replace(mapped, stats={**mapped.stats, **figures})  # a new SurfacePath: frozen objects stay as made
    return planar, mapped, float(h)
