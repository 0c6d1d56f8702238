"""Periodic baseline paths on the same grid and region: raster, spiral, rectangular.

They exist to be compared with the pseudo-random path (paper Table 4), so they
are plain: a sequence over the whole grid's bounding box, clipped to the
region. Consecutive kept points stay joined when the straight segment between
them lies inside the region (a boundary chord may be longer than one grid
step); otherwise the tool lifts and a new piece starts.
"""

from __future__ import annotations

import numpy as np
import shapely

from .dwell import DwellGrid, grid_to_uv, uv_to_grid


def _dir_index(dij: np.ndarray) -> np.ndarray:
    """Direction number 0..7 of unit grid steps (k, 2), -1 when not an 8-neighbour step."""
    lut = np.full(9, -1, dtype=np.int64)
    # (dy+1)*3 + (dx+1) -> direction, DIRS order E NE N NW W SW S SE
    for d, (dx, dy) in enumerate([(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)]):
        lut[(dy + 1) * 3 + (dx + 1)] = d
    ok = (np.abs(dij) <= 1).all(axis=1)
    out = np.full(len(dij), -1, dtype=np.int64)
    out[ok] = lut[(dij[ok, 1] + 1) * 3 + (dij[ok, 0] + 1)]
    return out


def _pieces_from_uv(uv: np.ndarray, joined: np.ndarray) -> np.ndarray:
    """Piece offsets (K+1,) from a bool per consecutive pair saying 'stay joined'."""
    breaks = np.flatnonzero(~joined) + 1
    return np.concatenate([[0], breaks, [len(uv)]]).astype(np.int64)


def _join_inside(poly, uv: np.ndarray, known: np.ndarray) -> np.ndarray:
    """For consecutive points: True where ``known`` says so, else whether the segment lies in ``poly``."""
    joined = known.copy()
    todo = np.flatnonzero(~known)
    if len(todo):
        lines = shapely.linestrings(np.stack([uv[todo], uv[todo + 1]], axis=1))
        joined[todo] = shapely.covers(poly, lines)
    return joined


def clip_grid_sequence(grid: DwellGrid, seq_ij: np.ndarray, chords: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Keep the dwell points of a grid-index sequence and split it where a move would leave the region.

    Parameters
    ----------
    grid : DwellGrid
        The dwell grid.
    seq_ij : (M, 2) int64
        Grid indices in path order, possibly outside the region.
    chords : bool
        Keep a longer move between consecutive kept points when its segment
        lies inside the region (raster row changes); False breaks the piece at
        every move that is not a step to an 8-neighbour.

    Returns
    -------
    order : (N,) int64
        Dwell-point numbers kept, in order.
    pieces : (K+1,) int64
        Offsets of continuous pieces.
    """
    H, W = (int(x) for x in grid.dense_shape)
    i0, j0 = (int(x) for x in grid.dense_offset)
    rel = seq_ij - np.array([i0, j0])
    inb = (rel[:, 0] >= 0) & (rel[:, 0] < W) & (rel[:, 1] >= 0) & (rel[:, 1] < H)
    dense = rel[inb, 1] * W + rel[inb, 0]
    pos = np.searchsorted(grid.dense_id, dense)
    pos = np.minimum(pos, grid.n - 1)
    hit = grid.dense_id[pos] == dense
    order = pos[hit]
    if len(order) == 0:
        return order, np.array([0, 0], dtype=np.int64)
    dij = np.diff(grid.ij[order], axis=0)
    d = _dir_index(dij)
    known = np.zeros(len(dij), dtype=bool)
    ok = d >= 0
    known[ok] = (grid.dirmask[order[:-1][ok]] >> d[ok]) & 1 == 1
    # a neighbour step not in the adjacency leaves the region: break. A longer
    # jump (row change, boundary chord) stays joined when it lies inside.
    joined = known.copy()
    idx = np.flatnonzero(~ok) if chords else np.zeros(0, dtype=np.int64)
    if len(idx):
        uv = grid.uv[order]
        lines = shapely.linestrings(np.stack([uv[idx], uv[idx + 1]], axis=1))
        joined[idx] = shapely.covers(grid.polygon, lines)
    return order, _pieces_from_uv(order, joined)


def raster_sequence(grid: DwellGrid) -> np.ndarray:
    """Zig-zag (boustrophedon) over the grid's rows: (M, 2) int64 grid indices.

    Rows run along the grid's i axis; every other row is reversed.
    """
    lo = grid.ij.min(axis=0)
    hi = grid.ij.max(axis=0)
    i = np.arange(lo[0], hi[0] + 1)
    rows = []
    for r, j in enumerate(range(lo[1], hi[1] + 1)):
        ii = i if r % 2 == 0 else i[::-1]
        rows.append(np.stack([ii, np.full_like(ii, j)], axis=1))
    return np.concatenate(rows)


def rectangular_sequence(grid: DwellGrid, centre_ij) -> np.ndarray:
    """Square spiral of grid indices around ``centre_ij``: (M, 2) int64.

    Legs E 1, N 1, W 2, S 2, E 3, N 3 ... : concentric rectangles joined by one
    step, every grid point of the bounding box exactly once (the paper's
    rectangular path).
    """
    lo = grid.ij.min(axis=0)
    hi = grid.ij.max(axis=0)
    c = np.asarray(centre_ij, dtype=np.int64)
    reach = int(max(np.abs(lo - c).max(), np.abs(hi - c).max()))
    legs = []
    dirs = np.array([[1, 0], [0, 1], [-1, 0], [0, -1]])
    n = 1
    k = 0
    while n <= 2 * reach + 1:
        for _ in range(2):
            legs.append(np.repeat(dirs[k % 4][None, :], n, axis=0))
            k += 1
        n += 1
    steps = np.concatenate(legs)
    seq = np.concatenate([c[None, :], c + np.cumsum(steps, axis=0)])
    inbox = (seq >= lo).all(axis=1) & (seq <= hi).all(axis=1)
    # keep the bounding-box points only (the spiral overshoots on its last turns)
    return seq[inbox]


def archimedean_spiral(grid: DwellGrid, centre_uv, max_radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Points of an Archimedean spiral of pitch ``spacing``, ``spacing`` apart along it, inside the region.

    Parameters
    ----------
    grid : DwellGrid
        Supplies spacing, frame and the (shrunk) region polygon.
    centre_uv : (2,) float
        Spiral centre, mm.
    max_radius : float
        Spiral extent, mm.

    Returns
    -------
    uv : (N, 2) float64
        Kept points in order, mm.
    pieces : (K+1,) int64
        Continuous pieces (a new piece where the spiral leaves the region).
    """
    s = grid.spacing
    a = s / (2 * np.pi)  # r = a * theta: one pitch per turn
    theta_max = max_radius / a + 2 * np.pi

    def arc(t):
        return 0.5 * a * (t * np.sqrt(1 + t * t) + np.arcsinh(t))

    total = arc(theta_max)
    sk = np.arange(0.0, total, s)
    t = np.sqrt(2 * sk / a)  # asymptotic inverse, then Newton on the exact arc length
    for _ in range(30):
        t = np.maximum(t - (arc(t) - sk) / (a * np.sqrt(1 + t * t)), 0.0)
    r = a * t
    uv = np.stack([centre_uv[0] + r * np.cos(t + grid.rotation), centre_uv[1] + r * np.sin(t + grid.rotation)], axis=1)
    poly = grid.polygon
    shapely.prepare(poly)
    keep = shapely.intersects_xy(poly, uv[:, 0], uv[:, 1])
    idx = np.flatnonzero(keep)
    uv = uv[idx]
    if len(uv) == 0:
        return uv, np.array([0, 0], dtype=np.int64)
    consecutive = np.diff(idx) == 1
    joined = _join_inside(poly, uv, np.zeros(len(uv) - 1, dtype=bool)) & consecutive
    return uv, _pieces_from_uv(uv, joined)


def nearest_ij(grid: DwellGrid, uv: np.ndarray) -> np.ndarray:
    """Nearest grid index (k, 2) int64 of plane points (k, 2) mm."""
    return np.rint(uv_to_grid(uv, grid.spacing, grid.origin, grid.rotation)).astype(np.int64)


__all__ = [
    "archimedean_spiral",
    "clip_grid_sequence",
    "grid_to_uv",
    "nearest_ij",
    "raster_sequence",
    "rectangular_sequence",
]
