"""Relaxed blue-noise dwell points: a Poisson-disk set after a few Lloyd steps (``--dwell-points relaxed``).

Why a second set without a lattice: the Poisson-disk set of :mod:`.blue_noise`
has no lattice peak, but its local density fluctuates (its Voronoi cells range
0.73-1.65 h^2, coefficient of variation about 0.11), and with the same time per
point that fluctuation is removal the tool prints as broadband error: on a flat
part the walk over it left a residual band RMS 12 % above the grid walk's
(docs/simulation.md, "The walk without a lattice: the verdict"). A few steps
of Lloyd's algorithm (every point moved to the centroid of its Voronoi cell;
Lloyd 1982, "Least squares quantization in PCM"; Du, Faber & Gunzburger 1999,
"Centroidal Voronoi tessellations") even the cells out (coefficient of variation
about 0.07 after five) long before the set orders itself into a crystal (that
takes hundreds of steps, and even then only in grains of random orientation), so
the set keeps its blue-noise spectrum and loses most of its low-frequency
density noise.

The centroids are exact for every point whose cell the kept triangles close
(:func:`voronoi_centroids`: the cell as a fan of signed triangles from the point
through the edge midpoints and the circumcentres); points on the rim of the
kept triangles, or closer than one spacing to the region's boundary, stay where
the sampler put them. A step that would bring two points closer than
``MIN_DISTANCE_FACTOR x h``, or a point out of the region, is not taken for
those points, so the set keeps the blue-noise set's guarantees (inside the
region with its margin, no two points closer than about 0.7 h) and the walk
(:func:`polishpath.plan.bluewalk.graph_walk_order`) runs on it unchanged: the
result is a :class:`~.blue_noise.BlueNoisePoints` with the relaxed points, their
neighbour graph and their cell areas. Written by hand (a numba loop over the
triangles) because scipy has no Voronoi centroids and its Voronoi diagram of
10^6-10^7 points costs far more memory than the kept triangles we already have.
"""

from __future__ import annotations

import numba
from ... import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np
import shapely
from scipy.spatial import cKDTree

from ...types import Region
from ..checks import check_count
from .blue_noise import BlueNoisePoints, blue_noise_points, cell_areas, neighbour_graph

#: Lloyd steps applied to the Poisson-disk set (docs/simulation.md says what each number gave).
LLOYD_STEPS = 5
#: No step brings two points closer than this multiple of the spacing (the issue's "about 0.7 spacing").
MIN_DISTANCE_FACTOR = 0.72


@numba.njit(cache=True)
def _cell_moments(uv, tri, n):  # pragma: no cover - numba
    # per corner a of each triangle (a, b, c) with circumcentre o: the signed triangles (a, m_ab, o) and
    # (a, o, m_ac), oriented as (a, b, c) is, summed: area, first moments and the corner angle
    area = np.zeros(n)
    mx = np.zeros(n)
    my = np.zeros(n)
    angle = np.zeros(n)
    for t in range(tri.shape[0]):
        ax, ay = uv[tri[t, 0], 0], uv[tri[t, 0], 1]
        bx, by = uv[tri[t, 1], 0], uv[tri[t, 1], 1]
        cx, cy = uv[tri[t, 2], 0], uv[tri[t, 2], 1]
        d = 2.0 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
        if d == 0.0:
            continue
        sgn = 1.0 if d > 0 else -1.0
        a2, b2, c2 = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
        ox = (a2 * (by - cy) + b2 * (cy - ay) + c2 * (ay - by)) / d
        oy = (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / d
        for i in range(3):
            p, q, r = tri[t, i], tri[t, (i + 1) % 3], tri[t, (i + 2) % 3]
            px, py = uv[p, 0], uv[p, 1]
            qx, qy = 0.5 * (px + uv[q, 0]), 0.5 * (py + uv[q, 1])  # midpoint of pq
            rx, ry = 0.5 * (px + uv[r, 0]), 0.5 * (py + uv[r, 1])  # midpoint of pr
            # (p, m_pq, o) and (p, o, m_pr): orientation of (p, q, r) is that of (a, b, c) (a cyclic shift)
            s1 = 0.5 * sgn * ((qx - px) * (oy - py) - (qy - py) * (ox - px))
            s2 = 0.5 * sgn * ((ox - px) * (ry - py) - (oy - py) * (rx - px))
            area[p] += s1 + s2
            mx[p] += s1 * (px + qx + ox) / 3.0 + s2 * (px + ox + rx) / 3.0
            my[p] += s1 * (py + qy + oy) / 3.0 + s2 * (py + oy + ry) / 3.0
            ex, ey = uv[q, 0] - px, uv[q, 1] - py
            fx, fy = uv[r, 0] - px, uv[r, 1] - py
            angle[p] += np.arctan2(abs(ex * fy - ey * fx), ex * fx + ey * fy)
    return area, mx, my, angle


def voronoi_centroids(uv: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centroid of each point's Voronoi cell, for the points the triangles surround.

    Parameters
    ----------
    uv : (n, 2) float64
        Points, mm.
    triangles : (T, 3) int64
        Delaunay triangles of the points (all of them around every point to be moved).

    Returns
    -------
    centroid : (n, 2) float64
        Centroid of the Voronoi cell, mm (the point itself where the triangles do not close its cell).
    closed : (n,) bool
        True where the triangles around the point close a full turn (its cell is exact).
    """
    uv = np.ascontiguousarray(uv, dtype=np.float64)
    area, mx, my, angle = _cell_moments(uv, np.ascontiguousarray(triangles, dtype=np.int64), len(uv))
    closed = (np.abs(angle - 2 * np.pi) < 1e-6) & (area > 0)
    safe = np.where(closed, area, 1.0)
    cen = np.where(closed[:, None], np.stack([mx / safe, my / safe], axis=1), uv)
    return cen, closed


def _too_close(uv: np.ndarray, dmin: float) -> np.ndarray:
    """(n,) bool: points with another point closer than ``dmin``."""
    pairs = cKDTree(uv).query_pairs(dmin, output_type="ndarray")
    bad = np.zeros(len(uv), dtype=bool)
    bad[pairs.ravel()] = True
    return bad


def lloyd_step(uv: np.ndarray, spacing: float, poly) -> np.ndarray:
    """One Lloyd step: the points whose cell is closed and that lie at least one spacing inside ``poly`` move
    to their cell's centroid, unless the move leaves ``poly`` or brings two points closer than
    ``MIN_DISTANCE_FACTOR x spacing`` (those stay). Returns the new (n, 2) points, mm."""
    _, _, tris = neighbour_graph(uv, spacing, poly)
    cen, closed = voronoi_centroids(uv, tris)
    far = shapely.distance(poly.boundary, shapely.points(uv)) >= spacing
    move = closed & far & shapely.contains_xy(poly, cen[:, 0], cen[:, 1])
    new = np.where(move[:, None], cen, uv)
    dmin = MIN_DISTANCE_FACTOR * spacing
    for _ in range(50):  # give moves back until no pair is too close (at worst all: the old set was fine)
        bad = _too_close(new, dmin) & move
        if not bad.any():
            break
        move &= ~bad
        new = np.where(move[:, None], cen, uv)
    else:
        new = uv
    return np.ascontiguousarray(new)


def relaxed_points(region: Region, spacing: float, *, seed: int, margin: float = 0.0,
                   steps: int = LLOYD_STEPS) -> BlueNoisePoints:
    """The blue-noise dwell-point set (:func:`blue_noise_points`) after ``steps`` Lloyd steps.

    Parameters
    ----------
    region : Region
        Planar region, mm.
    spacing : float
        Spacing ``h`` of the square grid of the same density, mm.
    seed : int
        Seed of the sampler; same seed, same points.
    margin : float
        Keep the points and the graph's edges this far inside the boundary, mm.
    steps : int
        Lloyd steps (0: the Poisson-disk set itself).

    Returns
    -------
    BlueNoisePoints
        The relaxed points, their neighbour graph (kept Delaunay edges), cell areas; ``min_distance`` is
        the closest pair's distance (at least ``MIN_DISTANCE_FACTOR x spacing``).

    Raises
    ------
    ParameterError
        As :func:`blue_noise_points`; ``steps`` not a whole number >= 0.
    """
    steps = check_count(steps, "The number of Lloyd steps", high=1000)
    pts = blue_noise_points(region, spacing, seed=seed, margin=margin)
    uv, poly = pts.uv, pts.polygon
    for _ in range(steps):
        uv = lloyd_step(uv, pts.spacing, poly)
    indptr, indices, tris = neighbour_graph(uv, pts.spacing, poly)
    dist, _ = cKDTree(uv).query(uv, 2)
    return BlueNoisePoints(uv=uv, spacing=pts.spacing, min_distance=float(dist[:, 1].min()), margin=pts.margin,
                           indptr=indptr, indices=indices, cell_area=cell_areas(uv, tris, pts.spacing),
                           seed=pts.seed, polygon=poly)
