"""Figures of merit of a planar path, and an independent crossing checker.

:func:`count_crossings` does not trust any planner's bookkeeping: it tests
every pair of path segments whose bounding boxes overlap (shapely's STRtree)
with shapely's exact predicates.
"""

from __future__ import annotations

import numpy as np
import shapely
from scipy.spatial import cKDTree

from .. import progress
from ..pathops import DIRECTION_NAMES, sector_codes, step_starts
from ..types import PlanarPath, Region
from .dwell import uv_to_grid


def _segments(uv: np.ndarray, pieces) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start index, end index and piece id of every segment that lies within a piece."""
    a, piece = step_starts(len(uv), pieces)
    return a, a + 1, piece


def count_crossings(uv: np.ndarray, pieces=None) -> int:
    """Number of self-intersections of a polyline (or several pieces).

    Two segments count when they share any point, except consecutive segments
    of one piece meeting at their common vertex. So a crossing, a touch, a
    repeated point and a step straight back over the previous step all count.

    Parameters
    ----------
    uv : (N, 2) float64
        Points in path order, mm.
    pieces : (K+1,) int64, optional
        Offsets of the continuous pieces (no segment between pieces); default
        one piece.

    Returns
    -------
    int
        Number of intersecting segment pairs (0 for a simple path).
    """
    uv = np.asarray(uv, dtype=np.float64)
    a, b, pc = _segments(uv, pieces)
    if len(a) < 2:
        return 0
    lines = shapely.linestrings(np.stack([uv[a], uv[b]], axis=1))
    tree = shapely.STRtree(lines)
    left, right = tree.query(lines, predicate="intersects")
    sel = left < right
    left, right = left[sel], right[sel]
    consecutive = (pc[left] == pc[right]) & (b[left] == a[right])
    n = int((~consecutive).sum())
    if consecutive.any():
        # consecutive segments may only share their common vertex: a step
        # straight back (collinear, opposite) overlaps the previous one
        l, r = left[consecutive], right[consecutive]
        d1 = uv[b[l]] - uv[a[l]]
        d2 = uv[b[r]] - uv[a[r]]
        cross = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
        dot = (d1 * d2).sum(axis=1)
        scale = np.hypot(*d1.T) * np.hypot(*d2.T)
        n += int(((np.abs(cross) <= 1e-12 * scale) & (dot < 0)).sum())
    return n


def direction_shares(uv: np.ndarray, pieces=None, rotation: float = 0.0) -> np.ndarray:
    """Share of the path steps in each of the 8 compass directions of the grid.

    Parameters
    ----------
    uv : (N, 2) float64
        Points in path order, mm.
    pieces : (K+1,) int64, optional
        Piece offsets (steps between pieces are not counted).
    rotation : float
        Grid rotation, radians; directions are measured in the grid frame.

    Returns
    -------
    (8,) float64
        Shares of E, NE, N, NW, W, SW, S, SE (sectors of 45 degrees centred on
        each direction); they sum to 1 (zeros for a path without steps).
    """
    a, b, _ = _segments(np.asarray(uv, dtype=np.float64), pieces)
    if len(a) == 0:
        return np.zeros(8)
    k = sector_codes(uv[b] - uv[a], rotation)
    return np.bincount(k, minlength=8) / len(k)


def largest_empty_disc(uv: np.ndarray, region: Region, resolution: float | None = None, max_samples: int = 400_000):
    """Largest disc centred in the region that holds no path point (the biggest gap a tool would miss).

    The region is sampled on a square lattice; the answer is exact to within
    the sampling ``resolution``.

    Parameters
    ----------
    uv : (N, 2) float64
        Path points, mm.
    region : Region
        Region whose points should all be near the path, mm.
    resolution : float, optional
        Sampling step, mm. Default: as fine as ``max_samples`` allows.
    max_samples : int
        Cap on the number of sample points.

    Returns
    -------
    radius : float
        Radius of the largest empty disc, mm.
    centre : (2,) float64
        Its centre, mm.
    """
    from .dwell import region_polygon

    poly = region_polygon(region)
    xmin, ymin, xmax, ymax = region.bounds
    if resolution is None:
        resolution = np.sqrt((xmax - xmin) * (ymax - ymin) / max_samples)
    xs = np.arange(xmin, xmax + resolution, resolution)
    ys = np.arange(ymin, ymax + resolution, resolution)
    X, Y = np.meshgrid(xs, ys)
    shapely.prepare(poly)
    inside = shapely.intersects_xy(poly, X.ravel(), Y.ravel())
    samples = np.stack([X.ravel()[inside], Y.ravel()[inside]], axis=1)
    # include the boundary vertices: the gap there matters to the tool too
    samples = np.concatenate([samples, np.concatenate(region.loops)])
    dist, _ = cKDTree(np.asarray(uv)).query(samples)
    k = int(np.argmax(dist))
    return float(dist[k]), samples[k]


def path_metrics(path: PlanarPath, region: Region | None = None) -> dict:
    """Figures of merit of a planar path (paper section 5 and issue 4, item 6).

    Parameters
    ----------
    path : PlanarPath
        The path.
    region : Region, optional
        The region it was planned in; needed for the largest empty disc.

    Returns
    -------
    dict
        ``n_points``; ``n_inside``; ``coverage`` (distinct dwell points visited /
        dwell points inside); ``n_pieces``; ``step_mean``, ``step_max`` (mm, steps
        within pieces); ``step_mean_spacings``, ``step_max_spacings``;
        ``direction_shares`` (dict name -> share of the 8 grid directions);
        ``directions_used`` (how many of the 8 have >= 5 % share, the paper's
        directional degree of freedom); ``turn_histogram`` (dict turn angle in
        degrees 0/45/90/135/180 -> share, turn angles binned to the nearest 45
        degrees); ``longest_straight_run`` (steps in a row in the same one of the
        8 direction sectors) and
        ``longest_straight_mm``; ``crossings``; ``largest_empty_disc`` (radius,
        mm) and ``largest_empty_disc_centre`` when ``region`` is given.
    """
    uv = np.asarray(path.uv)
    a, b, pc = _segments(uv, path.pieces)
    steps = np.hypot(*(uv[b] - uv[a]).T) if len(a) else np.zeros(0)
    g = uv_to_grid(uv, 1.0, np.zeros(2), path.rotation)  # grid frame, mm
    d = g[b] - g[a]
    ang = np.arctan2(d[:, 1], d[:, 0]) if len(a) else np.zeros(0)
    dk = sector_codes(d)
    shares = np.bincount(dk, minlength=8) / max(len(dk), 1)

    # turns between consecutive steps of the same piece
    cons = np.flatnonzero((b[:-1] == a[1:]) & (pc[:-1] == pc[1:])) if len(a) > 1 else np.zeros(0, np.int64)
    turn = np.abs(np.angle(np.exp(1j * (ang[cons + 1] - ang[cons])))) if len(cons) else np.zeros(0)
    tk = np.round(np.degrees(turn) / 45).astype(np.int64)
    turn_hist = np.bincount(tk, minlength=5)[:5] / max(len(tk), 1)

    # longest run of steps with the same direction, within a piece
    straight = np.zeros(len(a), dtype=bool)
    if len(cons):
        straight[cons + 1] = dk[cons + 1] == dk[cons]
    best = 1 if len(a) else 0
    best_mm = float(steps.max()) if len(a) else 0.0
    if straight.any():
        # run id increases at every step that is not a straight continuation
        run = np.cumsum(~straight)
        counts = np.bincount(run)
        lens = np.bincount(run, weights=steps)
        best = int(counts.max())
        best_mm = float(lens.max())

    ij = np.asarray(path.ij)
    distinct = len(np.unique(ij, axis=0)) if len(ij) else 0
    out = {
        "n_points": int(len(uv)),
        "n_inside": int(path.n_inside),
        "coverage": float(min(distinct, path.n_inside) / max(path.n_inside, 1)),
        "n_pieces": int(len(path.pieces) - 1),
        "step_mean": float(steps.mean()) if len(steps) else 0.0,
        "step_max": float(steps.max()) if len(steps) else 0.0,
        "step_mean_spacings": float(steps.mean() / path.spacing) if len(steps) else 0.0,
        "step_max_spacings": float(steps.max() / path.spacing) if len(steps) else 0.0,
        "direction_shares": {name: float(s) for name, s in zip(DIRECTION_NAMES, shares)},
        "directions_used": int((shares >= 0.05).sum()),
        "turn_histogram": {str(45 * k): float(s) for k, s in enumerate(turn_hist)},
        "longest_straight_run": int(best),
        "longest_straight_mm": float(best_mm),
        "crossings": count_crossings(uv, path.pieces),
    }
    progress.update(len(uv), None, "dwell points (crossings counted)")
    if region is not None:
        r, c = largest_empty_disc(uv, region)
        out["largest_empty_disc"] = r
        out["largest_empty_disc_centre"] = [float(c[0]), float(c[1])]
    return out
