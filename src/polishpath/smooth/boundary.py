"""How far the machine path leaves the part over its boundary (issue 14: "inside the part").

The smooth curve passes through every dwell point, all of which lie on the
part, but between two of them a cubic can swing out by up to ~0.4 x the step
at a sharp turn: near the rim or a hole that swing leaves the part. This module
measures it; the pipeline keeps it under a tolerance by planning the dwell
points a margin inside the boundary (see docs/machine-output.md).

A sample's *boundary excursion* is its distance to the part when the closest
point of the part lies on the part's boundary (the sample is beyond the rim or
over a hole), and 0 when the closest point is inside (the sample is over the
part; its small offset along the normal is the curve's surface deviation,
reported separately).
"""

from __future__ import annotations

import math

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np
from scipy.spatial import cKDTree

from ..errors import optional
from ..meshops import boundary_edges


def _closest_points(points: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance (M,) mm and closest point (M, 3) on the mesh of each point (libigl's AABB tree, else trimesh)."""
    igl = optional("igl")
    if igl is not None:
        d2, _, c = igl.point_mesh_squared_distance(points, vertices, faces)
        return np.sqrt(np.maximum(d2, 0.0)), np.asarray(c)
    import trimesh

    mesh = trimesh.Trimesh(vertices, faces, process=False)
    c, dist, _ = trimesh.proximity.closest_point(mesh, points)
    return np.asarray(dist), np.asarray(c)


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from points ``p`` (..., 3) to segments ``a``-``b`` (..., 3), (...)."""
    e = b - a
    ll = np.einsum("...j,...j->...", e, e)
    t = np.clip(np.divide(np.einsum("...j,...j->...", p - a, e), ll, out=np.zeros_like(ll), where=ll > 0), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * e), axis=-1)

#: points measured at once (memory: a few hundred bytes each while measured)
QUERY_BLOCK = 1 << 18


@numba.njit(cache=True)
def _maybe_near(pts, d_anchor, stride, limit):  # pragma: no cover - numba
    """Indices of the points the triangle inequality does not rule out (a compiled loop: no (M, 3) temporaries)."""
    m = pts.shape[0]
    out = np.empty(m, np.int64)
    k = 0
    lim = limit * (1 + 1e-9) + 1e-9
    for i in range(m):
        a = (i // stride) * stride
        g = 0.0
        for j in range(3):
            g += (pts[i, j] - pts[a, j]) * (pts[i, j] - pts[a, j])
        if d_anchor[i // stride] - math.sqrt(g) <= lim:
            out[k] = i
            k += 1
    return out[:k]


@numba.njit(cache=True)
def _edge_distance(p, a, b, near):  # pragma: no cover - numba
    """Distance from each point ``p`` (M, 3) to the nearest of its edges ``near`` (M, k) (ends ``a``, ``b``), (M,)."""
    m, kk = near.shape
    out = np.empty(m)
    for i in range(m):
        best = np.inf
        for q in range(kk):
            e = near[i, q]
            ll = 0.0
            tt = 0.0
            for j in range(3):
                d = b[e, j] - a[e, j]
                ll += d * d
                tt += (p[i, j] - a[e, j]) * d
            t = min(max(tt / ll, 0.0), 1.0) if ll > 0 else 0.0
            r = 0.0
            for j in range(3):
                x = p[i, j] - (a[e, j] + t * (b[e, j] - a[e, j]))
                r += x * x
            best = min(best, math.sqrt(r))
        out[i] = best
    return out


def _near_boundary(pts: np.ndarray, tree: cKDTree, limit: float, stride: int = 64) -> np.ndarray:
    """Indices of the points within ``limit`` of a point of ``tree``, ascending.

    The same set as querying every point, found by querying every ``stride``-th
    point (an anchor) and only the points that the triangle inequality
    (distance >= the anchor's distance - the distance to the anchor) does not
    already rule out: machine samples are consecutive along the path, so most
    of them lie far from the boundary with their anchor.
    """
    pts = np.ascontiguousarray(pts, dtype=np.float64)
    if len(pts) == 0:
        return np.zeros(0, np.int64)
    d_anchor, _ = tree.query(pts[::stride])
    maybe = _maybe_near(pts, np.ascontiguousarray(d_anchor, dtype=np.float64), int(stride), float(limit))
    if len(maybe) == 0:
        return maybe
    keep = np.zeros(len(maybe), dtype=bool)
    for a in range(0, len(maybe), QUERY_BLOCK):  # in blocks: a figuring job's samples crowd the rim
        d, _ = tree.query(pts[maybe[a:a + QUERY_BLOCK]])
        keep[a:a + QUERY_BLOCK] = d <= limit
    return maybe[keep]


class BoundaryCheck:
    """A part's boundary prepared once, measuring the excursion of points given in any number of chunks.

    :meth:`excursion` is :func:`boundary_excursion` of the points (each point's
    figure is its own, so chunks give the same figures as all points at once);
    :meth:`tally` returns a callable that takes chunk after chunk and keeps
    ``max_mm`` and ``count`` (points beyond the boundary at all).
    """

    def __init__(self, surface, reach: float):
        self.v = np.ascontiguousarray(surface.vertices, dtype=np.float64)
        self.f = np.ascontiguousarray(surface.faces, dtype=np.int64)
        self.be = boundary_edges(self.f)
        self.reach = float(reach)
        if len(self.be):
            self.a = np.ascontiguousarray(self.v[self.be[:, 0]])
            self.b = np.ascontiguousarray(self.v[self.be[:, 1]])
            self.half = 0.5 * float(np.linalg.norm(self.b - self.a, axis=1).max())
            self.tree = cKDTree(0.5 * (self.a + self.b))
        self.scale = float(np.linalg.norm(self.v.max(axis=0) - self.v.min(axis=0)))

    def excursion(self, points: np.ndarray) -> np.ndarray:
        """Distance by which each point (M, 3) lies beyond the part's boundary, (M,) mm (0 over the part)."""
        out = np.zeros(len(points))
        cand, exc = self.near_excursion(points)
        out[cand] = exc
        return out

    def near_excursion(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`excursion` at the points that can be beyond the boundary only: their indices (k,), ascending,
        and their excursions (k,) mm (every other point's is 0; no array of the points' size is made)."""
        pts = np.ascontiguousarray(points, dtype=np.float64)
        none = (np.zeros(0, np.int64), np.zeros(0))
        if len(pts) == 0 or len(self.be) == 0:
            return none
        cand = _near_boundary(pts, self.tree, self.reach + self.half)
        if len(cand) == 0:
            return none
        exc = np.empty(len(cand))
        k = min(16, len(self.be))
        # in blocks of candidates: the 16 nearest edges of each are 256 bytes, and a figuring job's samples crowd
        # the rim, where the times are longest (the 10^6-point job: about 1 GB of these at once)
        for a in range(0, len(cand), QUERY_BLOCK):
            c = cand[a:a + QUERY_BLOCK]
            dist, closest = _closest_points(pts[c], self.v, self.f)
            # is the closest point on a boundary edge? check the edges whose midpoints are near it
            _, near = self.tree.query(closest, k=k)
            near = np.asarray(near).reshape(len(c), k)
            d_edge = _edge_distance(np.ascontiguousarray(closest, dtype=np.float64), self.a, self.b,
                                    np.ascontiguousarray(near, dtype=np.int64))
            on_boundary = d_edge <= 1e-9 * max(self.scale, 1.0)
            exc[a:a + len(c)] = np.where(on_boundary, dist, 0.0)
        return cand, exc

    def tally(self) -> "BoundaryTally":
        """A fresh accumulator of the excursion over chunks of points."""
        return BoundaryTally(self)


class BoundaryTally:
    """Largest excursion (``max_mm``) and how many points lie beyond the boundary (``count``), chunk by chunk."""

    def __init__(self, check: BoundaryCheck):
        self.check = check
        self.max_mm = 0.0
        self.count = 0

    def __call__(self, points: np.ndarray) -> None:
        _, exc = self.check.near_excursion(points)
        if len(exc):
            self.max_mm = max(self.max_mm, float(exc.max()))
            self.count += int(np.count_nonzero(exc > 0.0))


def boundary_excursion(points: np.ndarray, surface, reach: float) -> np.ndarray:
    """Distance by which each point lies beyond the part's boundary, (M,) mm (0 over the part).

    Parameters
    ----------
    points : (M, 3) float
        Machine samples, mm.
    surface : Surface
        The part, ``vertices`` (V, 3) mm, ``faces`` (F, 3).
    reach : float
        Only points within this distance of a boundary edge's midpoint plus half
        the longest boundary edge are measured (farther ones cannot be beyond
        the boundary by less than ``reach``), mm; give the longest step of the
        path, which bounds how far the curve strays from its dwell points.

    Returns
    -------
    (M,) float
        Distance to the part where its closest point is on the boundary (within
        1e-9 of the part's size), else 0.
    """
    return BoundaryCheck(surface, reach).excursion(points)
