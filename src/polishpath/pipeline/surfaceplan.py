"""Plan and map, wired: :func:`plan_on_surface` with the step-reduction loop that honours the spacing on the part.

Part of the one wiring place (the :mod:`polishpath.pipeline` package); the job,
the paper reproduction, the simulation's pattern comparison and the benchmarks call it.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from .. import progress, resources
from ..defaults import DEFAULT_MAX_OVERSAMPLING, DEFAULT_MAX_POINTS
from ..errors import MappingError, ParameterError, PlanningError, SpacingTooLargeError
from ..pathops import step_mask
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
        ``replans``, ``neighbour_spacing_max`` and ``grid_step_max`` (mm).
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
        edges, at most ``EDGE_FACTOR`` x its planar spacing (:mod:`polishpath.plan.points.blue_noise`):
        with ``spacing_on="surface"`` no step on the part then exceeds ``EDGE_FACTOR`` x ``spacing``.
    spacing_on : {"surface", "plane"}
        ``surface``: the planar spacing is adjusted (re-planning up to 7 times)
        until neighbouring dwell points, and neighbouring passes, are at most
        ``spacing`` apart on the part (diagonal neighbours ``sqrt(2) x spacing``),
        the same rule for every pattern (:func:`neighbour_spacing_max`);
        ``plane``: one plain planar grid of ``spacing``.
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
                f"keeping neighbouring dwell points within {spacing:g} mm on the part needs a planar spacing of "
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
            planar, spath, planar_spacing = _honour_surface_spacing(flat, spacing, planner, region=region)
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
    """Largest 3D step between consecutive dwell points that are grid neighbours, mm (a reported figure).

    Moves that are not grid steps (a raster's connecting chord along the
    boundary, the jump between pieces) are transit moves of the pattern, not
    dwell steps, so they do not set the spacing: where every path point is a
    dwell point of a lattice, only the lattice's neighbour steps count; else
    (the spiral's points off the grid, a set without a lattice) every step
    within a piece counts.
    """
    d = np.linalg.norm(np.diff(mapped.xyz, axis=0), axis=1)
    if len(d) == 0:
        return 0.0
    valid = step_mask(len(mapped.xyz), planar.pieces)
    if planar.lattice is not None and planar.dwell_points_only:
        valid &= planar.lattice.is_step(np.diff(planar.ij, axis=0))
    return float(d[valid].max()) if valid.any() else 0.0


#: points per block when neighbour pairs are measured (bounds the temporary memory at 10^7 points)
_PAIR_BLOCK = 1 << 20
#: the most stretched pairs of each block kept for the check that their segment stays on the part
_PAIR_CANDIDATES = 64


def _lattice_pairs(ij: np.ndarray, offsets: np.ndarray):
    """Blocks of (a, b) index arrays of the dwell points that are lattice neighbours (``offsets`` (K, 2) apart).

    Each pair once: of an offset and its opposite only the one pointing up (or right) is used.
    """
    half = [(int(a), int(b)) for a, b in offsets if a > 0 or (a == 0 and b > 0)]
    lo = ij.min(axis=0)
    W, H = (int(x) for x in ij.max(axis=0) - lo + 1)
    dense = np.full((H, W), -1, dtype=np.int64)  # the lattice's points by index: O(N) neighbour look-ups
    rel = ij - lo
    dense[rel[:, 1], rel[:, 0]] = np.arange(len(ij))
    for c0 in range(0, len(ij), _PAIR_BLOCK):
        r = rel[c0:c0 + _PAIR_BLOCK]
        a_all = np.arange(c0, c0 + len(r))
        for oi, oj in half:
            ii, jj = r[:, 0] + oi, r[:, 1] + oj
            ok = (ii >= 0) & (ii < W) & (jj >= 0) & (jj < H)
            b = dense[jj[ok], ii[ok]]
            yield a_all[ok][b >= 0], b[b >= 0]


def _near_pairs(uv: np.ndarray, radius: float):
    """Blocks of (a, b) index arrays (a < b) of the points at most ``radius`` apart in the plane (k-d tree)."""
    from scipy.spatial import cKDTree

    tree = cKDTree(uv)
    k = 13  # 8 lattice-like neighbours within sqrt(2) h with room for a denser, irregular set
    for c0 in range(0, len(uv), _PAIR_BLOCK // k):
        dist, nb = tree.query(uv[c0:c0 + _PAIR_BLOCK // k], k=k, distance_upper_bound=radius)
        a = np.repeat(np.arange(c0, c0 + len(nb)), k).reshape(nb.shape)
        ok = np.isfinite(dist) & (nb > a)
        yield a[ok], nb[ok]


def neighbour_spacing_max(planar: PlanarPath, mapped: SurfacePath, region: Region | None = None) -> float:
    """The largest spacing on the part between neighbouring dwell points, mm: what ``spacing`` bounds.

    One meaning for every pattern: two dwell points are neighbours when they
    are lattice neighbours (``planar.lattice.neighbour_offsets`` apart: axial or
    diagonal on the square grid) for a path through the dwell points of a
    lattice, or else (a spiral's points off the grid, a set without a lattice)
    when they lie at most ``sqrt(2) h`` apart in the plane (``h`` the planar
    spacing) or are consecutive in a piece of the path (a blue-noise walk's
    edges, up to ``EDGE_FACTOR x h``: no step then exceeds its planar length / h x
    the bound on the part). Each pair is scaled to an
    axial neighbour: its distance on the part x ``h`` / its distance in the
    plane. So a bound ``s`` on this figure says: no axial neighbours, and no
    neighbouring passes (a raster's rows, a spiral's turns), more than ``s``
    apart on the part, and no diagonal neighbours more than ``sqrt(2) s``.
    Measured on the dwell set, not on the path's own steps, so every pattern
    planned at the same ``h`` on the same flattening gets the same figure.

    Parameters
    ----------
    planar : PlanarPath
        Dwell points ``uv`` (N, 2) mm and grid indices ``ij`` (N, 2); ``spacing`` ``h`` mm.
    mapped : SurfacePath
        The same points on the part, ``xyz`` (N, 3) mm.
    region : Region, optional
        The planning region, mm: a pair whose planar segment leaves it (across a
        notch of the boundary) is not a pair of neighbours on the part.

    Returns
    -------
    float
        mm (0.0 for fewer than two points).
    """
    uv, xyz, h = planar.uv, mapped.xyz, float(planar.spacing)
    if len(uv) < 2:
        return 0.0
    lat = planar.lattice
    if lat is not None and planar.dwell_points_only:
        blocks = _lattice_pairs(planar.ij, lat.neighbour_offsets)
    else:  # near pairs, and the path's own steps (a blue-noise walk's edges reach EDGE_FACTOR x h)
        steps = np.flatnonzero(step_mask(len(uv), planar.pieces))
        blocks = itertools.chain(_near_pairs(uv, SQRT2 * h * (1 + 1e-6)), [(steps, steps + 1)])
    cand_r, cand_a, cand_b = [], [], []
    for a, b in blocks:
        if len(a) == 0:
            continue
        d2 = np.linalg.norm(uv[a] - uv[b], axis=1)
        keep = d2 > 1e-9 * h  # a point planned twice is not a pair
        a, b, d2 = a[keep], b[keep], d2[keep]
        ratio = np.linalg.norm(xyz[a] - xyz[b], axis=1) / d2
        top = np.argsort(ratio)[-_PAIR_CANDIDATES:]
        cand_r.append(ratio[top])
        cand_a.append(a[top])
        cand_b.append(b[top])
    if not cand_r:
        return 0.0
    r = np.concatenate(cand_r)
    order = np.argsort(r)[::-1]
    if region is not None:
        import shapely

        from ..plan.dwell import region_polygon

        a, b = np.concatenate(cand_a)[order], np.concatenate(cand_b)[order]
        inside = shapely.covers(region_polygon(region), shapely.linestrings(np.stack([uv[a], uv[b]], axis=1)))
        if inside.any():  # the most stretched pair that is a pair of neighbours on the part
            return float(h * r[order][np.argmax(inside)])
    return float(h * r[order[0]])


def _honour_surface_spacing(
    flat: Flattening,
    spacing: float,
    planner: Callable[[float], PlanarPath],
    *,
    region: Region | None = None,
    start_quantile: float = 0.99,
    max_iter: int = 6,
) -> tuple[PlanarPath, SurfacePath, float]:
    """Plan and map so that neighbouring dwell points are at most ``spacing`` apart on the part.

    The paper's "step reduction factor" found on the actual dwell set, with one
    meaning of spacing for every pattern (:func:`neighbour_spacing_max`): no
    axial neighbours and no neighbouring passes more than ``spacing`` apart on
    the part, no diagonal neighbours more than ``sqrt(2) x spacing``. Starts
    from the planar spacing given by an area-weighted quantile of the map's
    stretch (:func:`polishpath.mapping.planar_spacing_for_surface`), maps the
    planned set, measures its largest neighbour spacing on the part, rescales
    the planar spacing by ``spacing / largest`` (up or down) and re-plans,
    keeping the largest planar spacing whose set fits. It stops when a fitting
    set's largest neighbour spacing is within 2 % of ``spacing``, or after
    ``max_iter`` plans; if none fitted it falls back to the strict bound
    (quantile 1: the map stretches no planar segment inside the mesh by more).

    Parameters
    ----------
    flat : Flattening
    spacing : float
        Wanted spacing on the part, mm.
    planner : callable
        ``planner(planar_spacing_mm) -> PlanarPath``.
    region : Region, optional
        The planning region (see :func:`neighbour_spacing_max`).
    start_quantile : float
        Quantile of the stretch used for the first try.
    max_iter : int
        Most plans before the strict fallback.

    Returns
    -------
    planar : PlanarPath
    mapped : SurfacePath
        ``stats`` also hold ``planar_spacing``, ``step_reduction_factor``
        (planar / surface spacing), ``replans`` (plans made), ``neighbour_spacing_max``
        (mm, at most ``spacing``) and ``grid_step_max`` (mm).
    h : float
        The planar spacing used, mm.
    """
    from ..mapping import map_to_surface, planar_spacing_for_surface

    # the map stretches no planar segment by more than sigma: h = spacing / sigma keeps every neighbour
    # within the spacing (sqrt(2) x spacing over the diagonal sqrt(2) h is that same bound)
    h = planar_spacing_for_surface(flat, spacing, SQRT2, quantile=start_quantile)
    best = None
    tries = 0
    for _ in range(max(1, max_iter)):
        planar = planner(h)
        mapped = map_to_surface(flat, planar, surface_spacing=spacing)
        tries += 1
        progress.update(planar.n_points, None, f"dwell points in plan {tries}")
        m = neighbour_spacing_max(planar, mapped, region)
        fits = m <= spacing * (1 + 1e-9)
        if fits and (best is None or h > best[2]):
            best = (planar, mapped, h, m)
        ratio = spacing / m if m > 0 else 2.0
        if fits and ratio < 1.02:
            break
        h_next = h * min(ratio, 2.0) * 0.999
        if best is not None and h_next <= best[2] * 1.0001:
            break
        h = h_next
    if best is None:
        h = planar_spacing_for_surface(flat, spacing, SQRT2, quantile=1.0)
        planar = planner(h)
        mapped = map_to_surface(flat, planar, surface_spacing=spacing)
        best = (planar, mapped, h, neighbour_spacing_max(planar, mapped, region))
        tries += 1
    planar, mapped, h, m = best
    figures = {"planar_spacing": float(h), "step_reduction_factor": float(h / spacing), "replans": tries,
               "neighbour_spacing_max": float(m), "grid_step_max": _grid_step_max(planar, mapped)}
    mapped = replace(mapped, stats={**mapped.stats, **figures})  # a new SurfacePath: frozen objects stay as made
    return planar, mapped, float(h)
