"""Tiny reference paths on a square patch, for tests and as a fallback.

These are *not* the project's planners (``polishpath.plan`` is): they exist so
the simulator can be exercised on its own, and are deliberately simple.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError


def _grid(size_mm: float, spacing_mm: float, center=(0.0, 0.0)):
    if not (spacing_mm > 0 and size_mm >= spacing_mm):
        raise ParameterError(f"need 0 < spacing ({spacing_mm} mm) <= size ({size_mm} mm).")
    n = int(np.floor(size_mm / spacing_mm + 1e-9)) + 1
    o = np.asarray(center, dtype=float) - 0.5 * (n - 1) * spacing_mm
    return n, o


def raster_path(size_mm: float, spacing_mm: float, center=(0.0, 0.0)) -> np.ndarray:
    """Boustrophedon raster over a square grid: lines along x, stepping in y.

    Returns
    -------
    (n*n, 2) float64
        Dwell points, mm.
    """
    n, o = _grid(size_mm, spacing_mm, center)
    pts = []
    for j in range(n):
        cols = range(n) if j % 2 == 0 else range(n - 1, -1, -1)
        pts.extend((i, j) for i in cols)
    return o + np.array(pts, dtype=float) * spacing_mm


def rectangular_path(size_mm: float, spacing_mm: float, center=(0.0, 0.0)) -> np.ndarray:
    """Rectangular (square) spiral over the grid, from the outside in.

    Returns
    -------
    (n*n, 2) float64
        Dwell points, mm; every grid point once, unit steps.
    """
    n, o = _grid(size_mm, spacing_mm, center)
    lo_i, hi_i, lo_j, hi_j = 0, n - 1, 0, n - 1
    pts = []
    while lo_i <= hi_i and lo_j <= hi_j:
        pts += [(i, lo_j) for i in range(lo_i, hi_i + 1)]
        pts += [(hi_i, j) for j in range(lo_j + 1, hi_j + 1)]
        if lo_j < hi_j:
            pts += [(i, hi_j) for i in range(hi_i - 1, lo_i - 1, -1)]
        if lo_i < hi_i:
            pts += [(lo_i, j) for j in range(hi_j - 1, lo_j, -1)]
        lo_i, hi_i, lo_j, hi_j = lo_i + 1, hi_i - 1, lo_j + 1, hi_j - 1
    return o + np.array(pts, dtype=float) * spacing_mm


def spiral_path(size_mm: float, spacing_mm: float, center=(0.0, 0.0)):
    """Archimedean spiral of pitch ``spacing_mm`` with points every ``spacing_mm`` of arc, clipped to the square.

    Returns
    -------
    xy : (N, 2) float64
        Dwell points, mm.
    pieces : (K+1,) int64
        Offsets of the continuous pieces (the square cuts the outer turns).
    """
    r_max = size_mm / np.sqrt(2)
    b = spacing_mm / (2 * np.pi)
    # arc length of r = b theta is ~ b theta^2 / 2; place points at equal arc steps
    s_max = r_max**2 / (2 * b)
    s = np.arange(spacing_mm / 2, s_max, spacing_mm)
    theta = np.sqrt(2 * s / b)
    r = b * theta
    xy = np.stack([r * np.cos(theta), r * np.sin(theta)], axis=1)
    inside = np.all(np.abs(xy) <= size_mm / 2 + 1e-9, axis=1)
    idx = np.flatnonzero(inside)
    breaks = np.flatnonzero(np.diff(idx) > 1) + 1
    pieces = np.concatenate([[0], breaks, [len(idx)]]).astype(np.int64)
    return xy[idx] + np.asarray(center, dtype=float), pieces


def random_walk_path(size_mm: float, spacing_mm: float, seed: int = 0, center=(0.0, 0.0)) -> np.ndarray:
    """A simple pseudo-random 8-neighbour walk over the grid (fallback, not the paper's planner).

    From the centre, step to a random unvisited 8-neighbour; when there is none,
    jump to the nearest unvisited point (the paper's planner does a local
    turnaround instead). Diagonal crossings are not prevented.

    Returns
    -------
    (n*n, 2) float64
        Dwell points, mm.
    """
    n, o = _grid(size_mm, spacing_mm, center)
    rng = np.random.default_rng(seed)
    visited = np.zeros((n, n), bool)
    cur = (n // 2, n // 2)
    visited[cur] = True
    order = [cur]
    nb = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]
    remaining = n * n - 1
    while remaining:
        cand = [(cur[0] + a, cur[1] + b) for a, b in nb
                if 0 <= cur[0] + a < n and 0 <= cur[1] + b < n and not visited[cur[0] + a, cur[1] + b]]
        if cand:
            cur = cand[rng.integers(len(cand))]
        else:
            free = np.argwhere(~visited)
            d = np.abs(free - np.array(cur)).max(axis=1)
            near = free[d == d.min()]
            cur = tuple(near[rng.integers(len(near))])
        visited[cur] = True
        order.append(cur)
        remaining -= 1
    return o + np.array(order, dtype=float) * spacing_mm
