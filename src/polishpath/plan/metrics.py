"""Figures of merit of a planar path, and an independent crossing checker.

:func:`count_crossings` does not trust any planner's bookkeeping: it tests
every pair of path segments whose bounding boxes overlap (found on a uniform
grid of cells about one step wide) with exact orientation predicates.
"""

from __future__ import annotations

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np
import shapely
from scipy.spatial import cKDTree

from .. import progress
from ..pathops import DIRECTION_NAMES, sector_codes, step_starts
from ..types import PlanarPath, Region
from .dwell import uv_to_grid


# --------------------------------------------------------------- crossings
# Written by hand, not shapely's STRtree + intersects (what this was): at 10^6
# steps the tree query alone took 3.6 s and building the segments 1.2 s, while
# path steps are short and alike, which a uniform grid of cells about one step
# wide suits: each step lands in 1-4 cells and meets a handful of neighbours
# there (0.1-0.2 s for 10^6 steps). The predicates stay exact: a float
# orientation whose sign the rounding could flip (Shewchuk's error bound) is
# recomputed exactly with error-free products and sums.

_EPS = 2.0**-53
_CCW_ERR = (3.0 + 16.0 * _EPS) * _EPS  # Shewchuk's ccwerrboundA
_SPLIT = 134217729.0  # 2^27 + 1, Dekker's splitter


@numba.njit(cache=True, inline="always")
def _two_sum(a, b):
    x = a + b
    bv = x - a
    av = x - bv
    return x, (a - av) + (b - bv)


@numba.njit(cache=True, inline="always")
def _two_prod(a, b):
    x = a * b
    c = _SPLIT * a
    ah = c - (c - a)
    al = a - ah
    c = _SPLIT * b
    bh = c - (c - b)
    bl = b - bh
    return x, al * bl - (((x - ah * bh) - al * bh) - ah * bl)


@numba.njit(cache=True)
def _orient_exact(ax, ay, bx, by, cx, cy, terms, expansion):
    """Exact sign of (b - a) x (c - a): the four differences as two-term sums, the
    16 partial products exactly, summed into a nonoverlapping expansion whose
    largest (last non-zero) component has the sign of the whole."""
    s1, e1 = _two_sum(bx, -ax)
    s2, e2 = _two_sum(cy, -ay)
    s3, e3 = _two_sum(by, -ay)
    s4, e4 = _two_sum(cx, -ax)
    u = (s1, e1)
    v = (s2, e2)
    k = 0
    for i in range(2):
        for j in range(2):
            p, q = _two_prod(u[i], v[j])
            terms[k] = p
            terms[k + 1] = q
            k += 2
    u = (s3, e3)
    v = (s4, e4)
    for i in range(2):
        for j in range(2):
            p, q = _two_prod(u[i], v[j])
            terms[k] = -p
            terms[k + 1] = -q
            k += 2
    m = 0  # grow the expansion one term at a time (Shewchuk's Grow-Expansion)
    for t in range(16):
        q = terms[t]
        for i in range(m):
            q, expansion[i] = _two_sum(q, expansion[i])
        expansion[m] = q
        m += 1
    for i in range(m - 1, -1, -1):
        if expansion[i] > 0.0:
            return 1
        if expansion[i] < 0.0:
            return -1
    return 0


@numba.njit(cache=True)
def _orient(ax, ay, bx, by, cx, cy, terms, expansion):
    """Sign of (b - a) x (c - a): -1, 0 or 1, exact."""
    left = (bx - ax) * (cy - ay)
    right = (by - ay) * (cx - ax)
    det = left - right
    if (left > 0.0 and right <= 0.0) or (left < 0.0 and right >= 0.0) or left == 0.0:
        # no cancellation: the sign of the rounded terms is the sign of the exact ones
        return (det > 0.0) - (det < 0.0)
    bound = _CCW_ERR * (abs(left) + abs(right))
    if det > bound:
        return 1
    if -det > bound:
        return -1
    return _orient_exact(ax, ay, bx, by, cx, cy, terms, expansion)


@numba.njit(cache=True, inline="always")
def _within(p, q, r):
    return min(p, q) <= r <= max(p, q)


@numba.njit(cache=True)
def _segments_meet(ax, ay, bx, by, cx, cy, dx, dy, terms, expansion):
    """Closed segments ab and cd share a point (zero-length segments are points)."""
    d1 = _orient(cx, cy, dx, dy, ax, ay, terms, expansion)
    d2 = _orient(cx, cy, dx, dy, bx, by, terms, expansion)
    if d1 * d2 > 0:
        return False
    d3 = _orient(ax, ay, bx, by, cx, cy, terms, expansion)
    d4 = _orient(ax, ay, bx, by, dx, dy, terms, expansion)
    if d3 * d4 > 0:
        return False
    if d1 * d2 < 0 and d3 * d4 < 0:
        return True
    return (
        (d1 == 0 and _within(cx, dx, ax) and _within(cy, dy, ay))
        or (d2 == 0 and _within(cx, dx, bx) and _within(cy, dy, by))
        or (d3 == 0 and _within(ax, bx, cx) and _within(ay, by, cy))
        or (d4 == 0 and _within(ax, bx, dx) and _within(ay, by, dy))
    )


@numba.njit(cache=True)
def _cell_span(lo, hi, origin, h):
    return np.int64(np.floor((lo - origin) / h)), np.int64(np.floor((hi - origin) / h))


@numba.njit(cache=True)
def _meeting_pairs(p, q, piece, h):
    """Pairs of segments ``p[s] -> q[s]`` that share a point, consecutive steps of
    one piece (``t == s + 1``) left out; each pair is tested in the one grid cell
    (side ``h``) that holds the lower-left corner of the overlap of their boxes."""
    n = len(p)
    xlo = np.minimum(p[:, 0], q[:, 0])
    xhi = np.maximum(p[:, 0], q[:, 0])
    ylo = np.minimum(p[:, 1], q[:, 1])
    yhi = np.maximum(p[:, 1], q[:, 1])
    x0, y0 = xlo.min(), ylo.min()
    nx = np.int64(np.floor((xhi.max() - x0) / h)) + 1
    ny = np.int64(np.floor((yhi.max() - y0) / h)) + 1
    start = np.zeros(nx * ny + 1, np.int64)
    for s in range(n):  # count, then fill (a CSR list of the segments of each cell)
        i0, i1 = _cell_span(xlo[s], xhi[s], x0, h)
        j0, j1 = _cell_span(ylo[s], yhi[s], y0, h)
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                start[j * nx + i + 1] += 1
    for c in range(nx * ny):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    members = np.empty(start[-1], np.int64)
    for s in range(n):
        i0, i1 = _cell_span(xlo[s], xhi[s], x0, h)
        j0, j1 = _cell_span(ylo[s], yhi[s], y0, h)
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                c = j * nx + i
                members[fill[c]] = s
                fill[c] += 1
    terms = np.empty(16)
    expansion = np.empty(16)
    count = 0
    for c in range(nx * ny):
        for u in range(start[c], start[c + 1]):
            s = members[u]
            for w in range(u + 1, start[c + 1]):
                t = members[w]  # s < t: segments enter the cells in index order
                if t == s + 1 and piece[t] == piece[s]:
                    continue
                bx0, bx1 = max(xlo[s], xlo[t]), min(xhi[s], xhi[t])
                by0, by1 = max(ylo[s], ylo[t]), min(yhi[s], yhi[t])
                if bx0 > bx1 or by0 > by1:
                    continue
                i, _ = _cell_span(bx0, bx0, x0, h)
                j, _ = _cell_span(by0, by0, y0, h)
                if j * nx + i != c:
                    continue  # tested in the cell of the overlap's corner
                if _segments_meet(p[s, 0], p[s, 1], q[s, 0], q[s, 1], p[t, 0], p[t, 1], q[t, 0], q[t, 1],
                                  terms, expansion):
                    count += 1
    return count


@numba.njit(cache=True)
def _cells_covered(p, q, h):
    """Number of (segment, cell) entries a grid of side ``h`` would hold."""
    x0 = min(p[:, 0].min(), q[:, 0].min())
    y0 = min(p[:, 1].min(), q[:, 1].min())
    total = 0
    for s in range(len(p)):
        i0, i1 = _cell_span(min(p[s, 0], q[s, 0]), max(p[s, 0], q[s, 0]), x0, h)
        j0, j1 = _cell_span(min(p[s, 1], q[s, 1]), max(p[s, 1], q[s, 1]), y0, h)
        total += (i1 - i0 + 1) * (j1 - j0 + 1)
    return total


def _cell_size(p: np.ndarray, q: np.ndarray) -> float:
    """Side of the grid cells: about the median step, no more cells than ~4 per
    segment, and no more than ~8 (segment, cell) entries per segment on average."""
    n = len(p)
    # per column: numpy's axis-0 reductions of (N, 2) arrays are ~10x slower
    ext = np.array([max(p[:, c].max(), q[:, c].max()) - min(p[:, c].min(), q[:, c].min()) for c in (0, 1)])
    k = max(1, n // 20000)  # the median of a sample of at most ~20k steps
    h = float(np.median(np.abs(q[::k] - p[::k]).max(axis=1)))
    h = max(h, float(np.sqrt(ext[0] * ext[1] / (4.0 * n))), float(ext.max()) / (4.0 * n), 1e-300)
    while _cells_covered(p, q, h) > 8 * n + 64:
        h *= 2.0
    return h


def _segments(uv: np.ndarray, pieces) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start index, end index and piece id of every segment that lies within a piece."""
    a, piece = step_starts(len(uv), pieces)
    return a, a + 1, piece


def count_crossings(uv: np.ndarray, pieces=None) -> int:
    """Number of self-intersections of a polyline (or several pieces).

    Two segments count when they share any point, except consecutive segments
    of one piece meeting at their common vertex. So a crossing, a touch, a
    repeated point and a step straight back over the previous step all count.
    Exact orientation predicates on a uniform grid of cells (see
    :func:`_meeting_pairs`), independent of the planner's bookkeeping.

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
    uv = np.ascontiguousarray(uv, dtype=np.float64)
    a, b, pc = _segments(uv, pieces)
    return _crossings(uv[a], uv[b], pc)


def _crossings(p: np.ndarray, q: np.ndarray, pc: np.ndarray) -> int:
    """:func:`count_crossings` of the path steps ``p[s] -> q[s]`` in path order, in piece ``pc[s]``."""
    if len(p) < 2:
        return 0
    return int(_meeting_pairs(p, q, pc, _cell_size(p, q)) + _steps_back(p, q, pc))


@numba.njit(cache=True)
def _steps_back(p, q, piece):
    """Consecutive segments of one piece may only share their common vertex: count
    the steps straight back (collinear to 1e-12 relative, opposite) over the last one."""
    n = 0
    for s in range(len(p) - 1):
        if piece[s + 1] != piece[s]:
            continue
        ux, uy = q[s, 0] - p[s, 0], q[s, 1] - p[s, 1]
        vx, vy = q[s + 1, 0] - p[s + 1, 0], q[s + 1, 1] - p[s + 1, 1]
        if abs(ux * vy - uy * vx) <= 1e-12 * (np.hypot(ux, uy) * np.hypot(vx, vy)) and ux * vx + uy * vy < 0:
            n += 1
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
    k, d = _farthest_sample(np.ascontiguousarray(uv, dtype=np.float64), np.ascontiguousarray(samples))
    return d, samples[k]


def _farthest_sample(pts: np.ndarray, samples: np.ndarray) -> tuple[int, float]:
    """Index of the sample farthest from its nearest point (the first of equals) and
    that distance: a grid of cells (:func:`_grid_farthest`), with a KD-tree for the
    samples the grid leaves open (nearest point beyond its search rings)."""
    if len(pts) == 0:
        return 0, float("inf")
    lo = [min(pts[:, c].min(), samples[:, c].min()) for c in (0, 1)]  # per column: see _cell_size
    ext = [max(pts[:, c].max(), samples[:, c].max()) - lo[c] for c in (0, 1)]
    h = max(2.0 * float(np.sqrt(ext[0] * ext[1] / len(pts))), float(max(ext)) / (4.0 * len(pts)), 1e-300)
    k, d2, open_ = _grid_farthest(pts, samples, float(lo[0]), float(lo[1]), h, 6)
    best, d = int(k), float(np.sqrt(d2)) if k >= 0 else -1.0
    idx = np.flatnonzero(open_)
    if len(idx):
        # an unbalanced tree builds 2-3x faster, and the distances are the same
        dist, _ = cKDTree(pts, balanced_tree=False).query(samples[idx], workers=-1)
        j = int(np.argmax(dist))
        if dist[j] > d or (dist[j] == d and idx[j] < best):
            best, d = int(idx[j]), float(dist[j])
    return best, d


@numba.njit(cache=True)
def _grid_farthest(pts, samples, x0, y0, h, max_ring):
    """Largest nearest-point distance over the samples, by rings of grid cells.

    Written by hand, not a KD-tree query of every sample (what this was, 0.3-0.6 s
    at 10^6 points and 400k samples): only the farthest sample matters, and a
    sample with a point nearer than the farthest one found so far is done at its
    first ring of cells. Returns the index of the farthest resolved sample (the
    first of equals; -1 if none), its squared distance, and which samples were
    left open (no point within ``max_ring`` rings that settles them)."""
    nx = np.int64(np.floor((max(pts[:, 0].max(), samples[:, 0].max()) - x0) / h)) + 1
    ny = np.int64(np.floor((max(pts[:, 1].max(), samples[:, 1].max()) - y0) / h)) + 1
    start = np.zeros(nx * ny + 1, np.int64)
    cell = np.empty(len(pts), np.int64)
    for p in range(len(pts)):
        c = np.int64(np.floor((pts[p, 1] - y0) / h)) * nx + np.int64(np.floor((pts[p, 0] - x0) / h))
        cell[p] = c
        start[c + 1] += 1
    for c in range(nx * ny):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    px = np.empty(len(pts))
    py = np.empty(len(pts))
    for p in range(len(pts)):  # the points in cell order, coordinates side by side
        k = fill[cell[p]]
        px[k] = pts[p, 0]
        py[k] = pts[p, 1]
        fill[cell[p]] = k + 1
    open_ = np.zeros(len(samples), np.bool_)
    top, top_d2 = -1, -1.0
    for q in range(len(samples)):
        sx, sy = samples[q, 0], samples[q, 1]
        ci = np.int64(np.floor((sx - x0) / h))
        cj = np.int64(np.floor((sy - y0) / h))
        best = np.inf
        settled = False
        for r in range(max_ring + 1):
            for j in range(max(cj - r, 0), min(cj + r, ny - 1) + 1):
                edge = j == cj - r or j == cj + r
                i = max(ci - r, 0)
                while i <= min(ci + r, nx - 1):
                    c = j * nx + i
                    for k in range(start[c], start[c + 1]):
                        dx = px[k] - sx
                        dy = py[k] - sy
                        d2 = dx * dx + dy * dy
                        if d2 < best:
                            best = d2
                    if edge or i == ci + r:
                        i += 1
                    else:
                        i = ci + r  # the ring's inner rows: only its two end cells
            if best <= top_d2:
                settled = True  # a point nearer than the farthest so far: cannot win
                break
            whole = ci - r <= 0 and cj - r <= 0 and ci + r >= nx - 1 and cj + r >= ny - 1
            reach = r * h * (1.0 - 1e-9)  # every unscanned point is farther (rounding of the cells aside)
            if whole or best <= reach * reach:
                settled = True
                if best > top_d2:
                    top, top_d2 = q, best
                break
        if not settled:
            open_[q] = True
    return top, top_d2, open_


def _distinct_points(ij: np.ndarray) -> int:
    """Number of distinct rows of an (N, 2) integer array: one flat key per grid
    index, marked in a table when the grid's box is small (no sort), else sorted."""
    if len(ij) == 0:
        return 0
    ij = ij.astype(np.int64, copy=False)
    lo = np.array([ij[:, 0].min(), ij[:, 1].min()])
    span = np.array([ij[:, 0].max(), ij[:, 1].max()]) - lo + 1
    if float(span[0]) * float(span[1]) >= 2.0**62:  # no flat key fits in int64
        return int(len(np.unique(ij, axis=0)))
    key = (ij[:, 0] - lo[0]) * span[1] + (ij[:, 1] - lo[1])
    if span[0] * span[1] <= 16 * len(ij) + 1024:
        seen = np.zeros(int(span[0] * span[1]), dtype=bool)
        seen[key] = True
        return int(np.count_nonzero(seen))
    return int(len(np.unique(key)))


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
    # every figure below from one set of steps: their ends, vectors and angles once
    uv = np.ascontiguousarray(path.uv, dtype=np.float64)
    a, b, pc = _segments(uv, path.pieces)
    p, q = uv[a], uv[b]
    steps = np.hypot(*(q - p).T) if len(a) else np.zeros(0)
    g = uv_to_grid(uv, 1.0, np.zeros(2), path.rotation)  # grid frame, mm
    d = g[b] - g[a]
    ang = np.arctan2(d[:, 1], d[:, 0]) if len(a) else np.zeros(0)
    dk = sector_codes(d)
    shares = np.bincount(dk, minlength=8) / max(len(dk), 1)

    # turns between consecutive steps of the same piece
    cons = np.flatnonzero((b[:-1] == a[1:]) & (pc[:-1] == pc[1:])) if len(a) > 1 else np.zeros(0, np.int64)
    turn = np.abs((ang[cons + 1] - ang[cons] + np.pi) % (2 * np.pi) - np.pi) if len(cons) else np.zeros(0)
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

    distinct = _distinct_points(np.asarray(path.ij))
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
        "crossings": _crossings(p, q, pc),
    }
    progress.update(len(uv), None, "dwell points (crossings counted)")
    if region is not None:
        r, c = largest_empty_disc(uv, region)
        out["largest_empty_disc"] = r
        out["largest_empty_disc_centre"] = [float(c[0]), float(c[1])]
    return out
