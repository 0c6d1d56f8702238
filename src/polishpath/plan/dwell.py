"""Dwell points: a square grid of spacing ``s`` inside a planar region.

The grid is ``uv = origin + R(rotation) @ (ij * spacing)``. A grid point is a
dwell point when it lies inside the region (closed, after shrinking the region
by ``margin``). Two dwell points are joined in the 8-neighbour adjacency only
when the straight segment between them stays inside the region, so a step never
cuts a concave corner or crosses a hole.

How it is computed (near-linear in the number of grid points):

* the region is shrunk by ``margin`` with shapely and carried into grid
  coordinates (``(uv - origin) / spacing`` rotated back);
* an even-odd scanline (numba) classifies every grid point of the bounding box;
* the grid cells that the boundary passes through (plus one cell around them)
  are marked "near the boundary"; only the points and 8-neighbour segments that
  touch such cells are decided exactly by shapely (vectorised ``intersects_xy``
  / ``covers``), in millimetres, so what the tests check with shapely is what
  the grid uses. Far from the boundary a segment between two inside points is
  inside (it is shorter than its distance to the boundary).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np
import shapely

from ..errors import ParameterError, SpacingTooLargeError
from ..pathops import DIRECTION_NAMES, DIRECTION_STEPS
from ..types import Lattice, Region
from .checks import check_number, check_point, check_points, check_region

#: 8 directions in grid index space, counter-clockwise from +i (east).
#: Direction ``d`` and ``(d + 4) % 8`` are opposite.
DIRS = DIRECTION_STEPS
DIR_NAMES = DIRECTION_NAMES

# Largest dense bounding-box grid we are willing to allocate (points).
_MAX_DENSE = 600_000_000


@dataclass(frozen=True, eq=False)
class DwellGrid:
    """Dwell points of a square grid inside a region, with their 8-neighbour adjacency.

    Attributes
    ----------
    ij : (n, 2) int64
        Integer grid indices of the dwell points.
    uv : (n, 2) float64
        Dwell point positions, mm: ``origin + R(rotation) @ (ij * spacing)``.
    spacing : float
        Grid spacing, mm.
    origin : (2,) float64
        Plane position of grid index (0, 0), mm.
    rotation : float
        Grid rotation, radians (counter-clockwise).
    margin : float
        Distance the dwell points keep from the region boundary, mm.
    dirmask : (n,) uint8
        Bit ``d`` set when the step from point k in direction ``DIRS[d]`` goes to
        another dwell point and the segment stays inside the (shrunk) region.
        Symmetric: bit d of k is set iff bit (d+4)%8 of its neighbour is set.
    dense_shape : (2,) int64
        ``(H, W)`` of the padded dense bounding-box grid used by the planners.
    dense_offset : (2,) int64
        Grid index ``(i0, j0)`` of dense cell ``(0, 0)``.
    dense_id : (n,) int64
        Position of each dwell point in the flattened dense grid
        (``(j - j0) * W + (i - i0)``).
    polygon : shapely geometry
        The (shrunk) region in mm that the grid was built for.
    """

    ij: np.ndarray
    uv: np.ndarray
    spacing: float
    origin: np.ndarray
    rotation: float
    margin: float
    dirmask: np.ndarray
    dense_shape: np.ndarray
    dense_offset: np.ndarray
    dense_id: np.ndarray
    polygon: object = field(repr=False)

    @property
    def n(self) -> int:
        """Number of dwell points."""
        return int(self.ij.shape[0])

    @property
    def lattice(self) -> Lattice:
        """The grid as a :class:`~polishpath.types.Lattice` (its 8 neighbours are the walks' steps)."""
        return Lattice.square(self.spacing, self.origin, self.rotation)

    def to_uv(self, ij: np.ndarray) -> np.ndarray:
        """Plane positions (k, 2) mm of grid indices ``ij`` (k, 2)."""
        return grid_to_uv(ij, self.spacing, self.origin, self.rotation)

    def dense_index(self) -> np.ndarray:
        """Dense lookup ``(H*W,) int64``: dwell-point number at each dense cell, or -1."""
        idx = np.full(int(self.dense_shape[0] * self.dense_shape[1]), -1, dtype=np.int64)
        idx[self.dense_id] = np.arange(self.n)
        return idx

    def neighbors(self) -> np.ndarray:
        """Neighbour table (n, 8) int64: dwell-point number in direction ``DIRS[d]``, or -1.

        Only steps allowed by :attr:`dirmask` (inside the region) are listed.
        """
        idx = self.dense_index()
        W = int(self.dense_shape[1])
        out = np.full((self.n, 8), -1, dtype=np.int64)
        for d in range(8):
            ok = (self.dirmask >> d) & 1 == 1
            out[ok, d] = idx[self.dense_id[ok] + DIRS[d, 0] + DIRS[d, 1] * W]
        return out

    def edges(self) -> np.ndarray:
        """Undirected adjacency edges (E, 2) int64 of dwell-point numbers, each once."""
        nb = self.neighbors()
        rows = []
        for d in range(4):  # E, NE, N, NW: each undirected edge once
            k = np.flatnonzero(nb[:, d] >= 0)
            rows.append(np.stack([k, nb[k, d]], axis=1))
        return np.concatenate(rows) if rows else np.zeros((0, 2), np.int64)


def check_grid(grid) -> DwellGrid:
    """``grid`` when it is a :class:`DwellGrid`, else :class:`~polishpath.errors.ParameterError`."""
    if not isinstance(grid, DwellGrid):
        raise ParameterError(
            f"The dwell grid must be a polishpath.plan.DwellGrid, got {type(grid).__name__}.",
            "Build one with polishpath.plan.dwell_grid(region, spacing).",
        )
    return grid


def _frame(spacing, origin, rotation) -> tuple[float, np.ndarray, float]:
    """Checked grid frame: spacing (> 0, mm), origin (2,) mm, rotation (radians)."""
    return (check_number(spacing, "spacing", positive=True, unit="mm"), check_point(origin, "origin"),
            check_number(rotation, "rotation", unit="radians"))


def grid_to_uv(ij, spacing: float, origin, rotation: float) -> np.ndarray:
    """Plane positions of grid indices.

    Parameters
    ----------
    ij : (k, 2) array_like
        Grid indices (integers or fractional grid coordinates).
    spacing : float
        Grid spacing, mm.
    origin : (2,) array_like
        Position of index (0, 0), mm.
    rotation : float
        Grid rotation, radians.

    Returns
    -------
    (k, 2) float64
        Positions, mm.
    """
    spacing, origin, rotation = _frame(spacing, origin, rotation)
    g = check_points(ij, "ij") * spacing
    c, s = np.cos(rotation), np.sin(rotation)
    return np.stack([origin[0] + c * g[:, 0] - s * g[:, 1], origin[1] + s * g[:, 0] + c * g[:, 1]], axis=1)


def uv_to_grid(uv, spacing: float, origin, rotation: float) -> np.ndarray:
    """Fractional grid coordinates (k, 2) of plane points ``uv`` (k, 2) mm (inverse of :func:`grid_to_uv`)."""
    spacing, origin, rotation = _frame(spacing, origin, rotation)
    p = check_points(uv, "uv") - origin
    c, s = np.cos(rotation), np.sin(rotation)
    return np.stack([c * p[:, 0] + s * p[:, 1], -s * p[:, 0] + c * p[:, 1]], axis=1) / spacing


def region_polygon(region: Region, margin: float = 0.0):
    """The region as a shapely (Multi)Polygon in mm, shrunk by ``margin`` mm.

    Raises
    ------
    ParameterError
        When the region is not a valid polygon (self-intersecting, hole outside),
        or the margin is not a number >= 0.
    SpacingTooLargeError
        When nothing is left after shrinking by the margin.
    """
    check_region(region)
    margin = check_number(margin, "The margin", low=0.0, unit="mm")
    poly = shapely.Polygon(np.asarray(region.outer), [np.asarray(h) for h in region.holes])
    if not poly.is_valid:
        # a flattened mesh boundary may touch itself within round-off: accept the
        # repair only when it does not change the area (else it is a real error)
        fixed = shapely.make_valid(poly)
        parts = [g for g in getattr(fixed, "geoms", [fixed]) if g.geom_type == "Polygon" and g.area > 0]
        fixed = shapely.MultiPolygon(parts) if len(parts) > 1 else (parts[0] if parts else None)
        if fixed is not None and abs(fixed.area - abs(region.area)) <= 1e-9 * max(abs(region.area), 1e-300):
            poly = fixed
    if not poly.is_valid:
        raise ParameterError(
            f"The region is not a valid polygon: {shapely.is_valid_reason(poly)}.",
            "Check that the boundary does not cross itself and that every hole lies inside the outer "
            "boundary without touching another hole (shapely.make_valid can repair a polygon).",
        )
    if margin > 0:
        poly = poly.buffer(-margin)
    if poly.is_empty or poly.area <= 0:
        xmin, ymin, xmax, ymax = region.bounds
        raise SpacingTooLargeError(
            f"Nothing of the region ({xmax - xmin:.4g} x {ymax - ymin:.4g} mm) is left after keeping a "
            f"margin of {margin:.4g} mm from its boundary.",
            "Use a smaller --margin.",
        )
    return poly


def _rings(poly) -> list[np.ndarray]:
    rings = []
    for g in getattr(poly, "geoms", [poly]):
        if g.geom_type != "Polygon":
            continue
        rings.append(np.asarray(g.exterior.coords)[:-1])
        rings.extend(np.asarray(r.coords)[:-1] for r in g.interiors)
    return rings


@numba.njit(cache=True)
def _scanline_inside(x0, y0, x1, y1, i0, j0, H, W, eps):  # pragma: no cover - numba
    # Even-odd scanline fill in grid coordinates. Written by hand because it is
    # the exact classification rule of the grid (half-open rows, eps inside).
    inside = np.zeros(H * W, dtype=np.uint8)
    nseg = x0.shape[0]
    counts = np.zeros(H + 1, dtype=np.int64)
    for k in range(nseg):
        ya, yb = y0[k], y1[k]
        if ya == yb:
            continue
        lo, hi = min(ya, yb), max(ya, yb)
        ra = int(np.ceil(lo)) - j0
        rb = int(np.ceil(hi)) - j0  # rows r with lo <= r+j0 < hi
        ra = max(ra, 0)
        rb = min(rb, H)
        for r in range(ra, rb):
            counts[r + 1] += 1
    for r in range(H):
        counts[r + 1] += counts[r]
    xs = np.empty(counts[H], dtype=np.float64)
    fill = counts[:H].copy()
    for k in range(nseg):
        ya, yb = y0[k], y1[k]
        if ya == yb:
            continue
        lo, hi = min(ya, yb), max(ya, yb)
        ra = max(int(np.ceil(lo)) - j0, 0)
        rb = min(int(np.ceil(hi)) - j0, H)
        for r in range(ra, rb):
            y = r + j0
            xs[fill[r]] = x0[k] + (y - ya) * (x1[k] - x0[k]) / (yb - ya)
            fill[r] += 1
    for r in range(H):
        a, b = counts[r], counts[r + 1]
        row = np.sort(xs[a:b])
        for m in range(0, b - a - 1, 2):
            ia = int(np.ceil(row[m] + eps)) - i0
            ib = int(np.floor(row[m + 1] - eps)) - i0
            ia = max(ia, 0)
            ib = min(ib, W - 1)
            for c in range(ia, ib + 1):
                inside[r * W + c] = 1
    return inside


@numba.njit(cache=True)
def _edge_pass(inside, near_cell, H, W):  # pragma: no cover - numba
    # Directions 0..3 (E, NE, N, NW) from each inside point: decide the edge when
    # no boundary cell touches it, else list it for the exact test.
    mask = np.zeros(H * W, dtype=np.uint8)
    offs = np.array([1, 1 + W, W, -1 + W])
    n_c = 0
    cap = 1024
    cand_node = np.empty(cap, dtype=np.int64)
    cand_dir = np.empty(cap, dtype=np.int64)
    for p in range(H * W):
        if inside[p] == 0:
            continue
        for d in range(4):
            q = p + offs[d]
            if q < 0 or q >= H * W or inside[q] == 0:
                continue
            # cells touched by the segment (cell id = its lower-left corner)
            if d == 0:
                near = near_cell[p] or (p - W >= 0 and near_cell[p - W])
            elif d == 1:
                near = near_cell[p]
            elif d == 2:
                near = near_cell[p] or near_cell[p - 1]
            else:
                near = near_cell[p - 1]
            if near:
                if n_c == cap:
                    cap *= 2
                    nn = np.empty(cap, dtype=np.int64)
                    nd = np.empty(cap, dtype=np.int64)
                    nn[:n_c] = cand_node[:n_c]
                    nd[:n_c] = cand_dir[:n_c]
                    cand_node, cand_dir = nn, nd
                cand_node[n_c] = p
                cand_dir[n_c] = d
                n_c += 1
            else:
                mask[p] |= np.uint8(1 << d)
                mask[q] |= np.uint8(1 << (d + 4))
    return mask, cand_node[:n_c], cand_dir[:n_c]


def dwell_grid(region: Region, spacing: float, *, margin: float = 0.0, origin=None, rotation: float = 0.0) -> DwellGrid:
    """Dwell points of a square grid inside a region, with their 8-neighbour adjacency.

    Parameters
    ----------
    region : Region
        Planar region (outer loop and holes), mm.
    spacing : float
        Grid spacing, mm (> 0).
    margin : float, optional
        Keep dwell points and steps at least this far inside the boundary, mm.
    origin : (2,) array_like, optional
        Plane position of grid index (0, 0), mm. Default: the centre of the
        region's bounding box in the grid frame, so the grid sits symmetrically.
    rotation : float, optional
        Grid rotation, radians (counter-clockwise).

    Returns
    -------
    DwellGrid
        Dwell points ordered by dense id (row by row) and their adjacency: a
        step is allowed only when the segment stays inside the region.

    Raises
    ------
    ParameterError
        Not a Region; spacing not a positive number; margin not a number >= 0;
        origin not two numbers; rotation not a number.
    SpacingTooLargeError
        Fewer than two dwell points fit.
    """
    check_region(region)
    spacing = check_number(spacing, "The dwell-point spacing", positive=True, unit="mm")
    margin = check_number(margin, "The margin", low=0.0, unit="mm")
    rotation = check_number(rotation, "The rotation", unit="radians")
    if origin is not None:
        origin = check_point(origin, "The origin")
    poly = region_polygon(region, margin)
    rings = _rings(poly)
    if origin is None:
        allp = np.concatenate(rings)
        g = uv_to_grid(allp, 1.0, np.zeros(2), rotation)
        centre_g = 0.5 * (g.min(axis=0) + g.max(axis=0))
        origin = grid_to_uv(centre_g[None, :], 1.0, np.zeros(2), rotation)[0]
    origin = np.asarray(origin, dtype=np.float64).reshape(2)

    gr = [uv_to_grid(r, spacing, origin, rotation) for r in rings]
    allg = np.concatenate(gr)
    lo = np.floor(allg.min(axis=0)).astype(np.int64) - 2
    hi = np.ceil(allg.max(axis=0)).astype(np.int64) + 2
    i0, j0 = int(lo[0]), int(lo[1])
    W, H = int(hi[0] - lo[0] + 1), int(hi[1] - lo[1] + 1)
    xmin, ymin, xmax, ymax = region.bounds
    if W * H > _MAX_DENSE:
        raise ParameterError(
            f"Spacing {spacing:.4g} mm on a {xmax - xmin:.4g} x {ymax - ymin:.4g} mm region needs a "
            f"{W} x {H} grid, more than polishpath handles ({_MAX_DENSE:.0e} points).",
            "Use a larger spacing.",
        )
    segs = np.concatenate([np.concatenate([r, np.roll(r, -1, axis=0)], axis=1) for r in gr])
    x0, y0, x1, y1 = (np.ascontiguousarray(segs[:, k]) for k in range(4))
    inside = _scanline_inside(x0, y0, x1, y1, i0, j0, H, W, 1e-6)

    # cells near the boundary: sample every segment at <= 0.5 cell and mark the 3x3 cells around
    seglen = np.hypot(x1 - x0, y1 - y0)
    nsub = np.maximum(1, np.ceil(seglen / 0.5).astype(np.int64))
    rep = np.repeat(np.arange(len(segs)), nsub + 1)
    t = _lin_params(nsub)
    sx = x0[rep] + t * (x1 - x0)[rep]
    sy = y0[rep] + t * (y1 - y0)[rep]
    ci = np.floor(sx).astype(np.int64) - i0
    cj = np.floor(sy).astype(np.int64) - j0
    near = np.zeros(H * W, dtype=np.bool_)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            near[np.clip(cj + dj, 0, H - 1) * W + np.clip(ci + di, 0, W - 1)] = True

    # exact (shapely, mm) decision for points at corners of near cells
    near_pt = near.copy()
    near2 = near.reshape(H, W)
    np2 = near_pt.reshape(H, W)
    np2[:, 1:] |= near2[:, :-1]
    np2[1:, :] |= near2[:-1, :]
    np2[1:, 1:] |= near2[:-1, :-1]
    cand = np.flatnonzero(near_pt)
    cij = np.stack([cand % W + i0, cand // W + j0], axis=1)
    cuv = grid_to_uv(cij, spacing, origin, rotation)
    shapely.prepare(poly)
    inside[cand] = shapely.intersects_xy(poly, cuv[:, 0], cuv[:, 1]).astype(np.uint8)

    mask, cn, cd = _edge_pass(inside, near.astype(np.uint8), H, W)
    if len(cn):
        offs = np.array([1, 1 + W, W, -1 + W])
        cq = cn + offs[cd]
        pa = grid_to_uv(np.stack([cn % W + i0, cn // W + j0], axis=1), spacing, origin, rotation)
        pb = grid_to_uv(np.stack([cq % W + i0, cq // W + j0], axis=1), spacing, origin, rotation)
        lines = shapely.linestrings(np.stack([pa, pb], axis=1))
        ok = shapely.covers(poly, lines)
        np.bitwise_or.at(mask, cn[ok], (1 << cd[ok]).astype(np.uint8))
        np.bitwise_or.at(mask, cq[ok], (1 << (cd[ok] + 4)).astype(np.uint8))

    ids = np.flatnonzero(inside)
    if len(ids) < 2:
        raise SpacingTooLargeError(
            f"Only {len(ids)} dwell point(s) of spacing {spacing:.4g} mm fit in the region "
            f"({xmax - xmin:.4g} x {ymax - ymin:.4g} mm, area {region.area:.4g} mm^2"
            + (f", margin {margin:.4g} mm" if margin else "")
            + ").",
            "Use a smaller spacing (at most about half the region's width).",
        )
    ij = np.stack([ids % W + i0, ids // W + j0], axis=1).astype(np.int64)
    return DwellGrid(
        ij=ij,
        uv=grid_to_uv(ij, spacing, origin, rotation),
        spacing=spacing,
        origin=origin,
        rotation=rotation,
        margin=margin,
        dirmask=mask[ids],
        dense_shape=np.array([H, W], dtype=np.int64),
        dense_offset=np.array([i0, j0], dtype=np.int64),
        dense_id=ids.astype(np.int64),
        polygon=poly,
    )


def _lin_params(nsub: np.ndarray) -> np.ndarray:
    """Concatenated ``linspace(0, 1, k + 1)`` for every k of ``nsub`` (vectorised)."""
    starts = np.repeat(np.cumsum(nsub + 1) - (nsub + 1), nsub + 1)
    pos = np.arange(int((nsub + 1).sum())) - starts
    return pos / np.repeat(nsub, nsub + 1)
