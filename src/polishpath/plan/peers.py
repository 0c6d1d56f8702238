"""The other pseudo-random paths of the paper's Table 3, built on our dwell grid (issue 8).

Four patterns, each ``fn(grid, region, *, seed, start, **options) -> PatternResult``
and registered with :func:`register_peers`:

``unicursal``
    Dunn & Walker (Optics Express 16, 18942, 2008) / Beaucamp line: a perfect
    maze (random spanning tree) on a coarse grid whose cells are 2 x 2 dwell
    points; walking along the maze walls (spanning-tree coverage) gives one
    closed, non-crossing path through every dwell point of the maze's cells.
    A coarse cell is used only when its 4 dwell points are inside and joined
    by inside steps, and two cells are joined only when both fine steps
    between them are inside, so holes and concave boundaries are respected.
    Dwell points in no usable cell are left out by design (``stats["left_out"]``).
``maze``
    Zhang et al.'s pseudo-random path based on a perfect maze, with its
    boundary handling as published: one scan line per maze row; the first
    boundary crossing enters the region, the second leaves it, and every maze
    cell touching that interval is used. Whatever lies after the second
    crossing (the far arm of a star, the far side of a hole) is left out, and
    cells sticking over the boundary put path points outside the region
    (``stats["outside_points"]``, ``"outside_steps"``, ``"area_outside_mm2"``).
    The maze is a depth-first ("recursive backtracker") perfect maze. Steps are
    along the two grid axes only.
``fractal``
    Dong et al.'s random fractal-like path: the grid's bounding square
    (side 2^k dwell points) is divided recursively into 4 quadrants, visited in
    a random order with random entry / exit corners (8-neighbour links between
    quadrants, so diagonals appear); the curve is clipped to the region and
    split where a link would leave it. Its published smoothing is an
    approximating spline that does not pass through the dwell points: the
    pattern measures that deviation with :func:`bspline_deviation` (uniform
    cubic B-spline with the dwell points as control points), ``stats
    ["smoothing_dev_max"]`` (mm).
``hilbert``
    The classic Hilbert curve on the bounding square, clipped to the region
    the same way; ``seed % 8`` picks one of its 8 symmetric orientations.

Every pattern is reproducible with its seed (numpy ``SeedSequence``; numba's
generator seeded inside the kernel for the depth-first maze).
"""

from __future__ import annotations

import numba
import numpy as np
import shapely
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import minimum_spanning_tree

from ..errors import InvariantError, ParameterError
from ..types import Region
from .api import PATTERNS, PatternResult, register_pattern
from .baselines import clip_grid_sequence
from .checks import check_count, check_index, check_options, check_points, check_seed
from .dwell import DwellGrid, check_grid, uv_to_grid

__all__ = [
    "PEER_PATTERNS",
    "bspline_deviation",
    "fractal_sequence",
    "hilbert_sequence",
    "pattern_fractal",
    "pattern_hilbert",
    "pattern_maze",
    "pattern_unicursal",
    "register_peers",
]

# bit of DwellGrid.dirmask for the steps used here
_E, _N = 0, 2


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------


def _lookup(grid: DwellGrid, ij: np.ndarray) -> np.ndarray:
    """Dwell-point number of grid indices ``ij`` (k, 2), or -1 (outside the region or the grid)."""
    H, W = (int(x) for x in grid.dense_shape)
    i0, j0 = (int(x) for x in grid.dense_offset)
    rel = np.asarray(ij, dtype=np.int64) - np.array([i0, j0])
    inb = (rel[:, 0] >= 0) & (rel[:, 0] < W) & (rel[:, 1] >= 0) & (rel[:, 1] < H)
    out = np.full(len(rel), -1, dtype=np.int64)
    if inb.any():
        dense = rel[inb, 1] * W + rel[inb, 0]
        pos = np.minimum(np.searchsorted(grid.dense_id, dense), grid.n - 1)
        hit = grid.dense_id[pos] == dense
        tmp = np.full(len(dense), -1, dtype=np.int64)
        tmp[hit] = pos[hit]
        out[inb] = tmp
    return out


def _has(grid: DwellGrid, k: np.ndarray, bit: int) -> np.ndarray:
    """True where dwell point ``k`` (may be -1) exists and has the step ``bit`` inside the region."""
    ok = k >= 0
    out = np.zeros(len(k), dtype=bool)
    out[ok] = (grid.dirmask[k[ok]] >> bit) & 1 == 1
    return out


def _outside_figures(grid: DwellGrid, uv: np.ndarray, pieces: np.ndarray) -> dict:
    """Points and steps of a path that leave the grid's (shrunk) region.

    Returns
    -------
    dict
        ``outside_points`` (count), ``outside_steps`` (steps whose segment is not
        covered by the region), ``outside_length_mm`` (length of the path
        outside the region, mm), ``area_outside_mm2`` (outside points x
        spacing^2: the area those dwell points stand for, mm^2).
    """
    poly = grid.polygon
    shapely.prepare(poly)
    n = len(uv)
    if n == 0:
        return {"outside_points": 0, "outside_steps": 0, "outside_length_mm": 0.0, "area_outside_mm2": 0.0}
    inside = shapely.intersects_xy(poly, uv[:, 0], uv[:, 1])
    same = np.ones(max(n - 1, 0), dtype=bool)
    same[np.asarray(pieces)[1:-1] - 1] = False
    k = np.flatnonzero(same)
    n_out_steps, out_len = 0, 0.0
    if len(k):
        lines = shapely.linestrings(np.stack([uv[k], uv[k + 1]], axis=1))
        cov = shapely.covers(poly, lines)
        n_out_steps = int((~cov).sum())
        if n_out_steps:
            out_len = float(shapely.length(shapely.difference(lines[~cov], poly)).sum())
    n_out = int((~inside).sum())
    return {
        "outside_points": n_out,
        "outside_steps": n_out_steps,
        "outside_length_mm": out_len,
        "area_outside_mm2": float(n_out * grid.spacing**2),
    }


def _check_call(grid: DwellGrid, seed, start, tree: str | None = None) -> tuple[int, int]:
    """Checked ``(seed, start)`` of a direct call of a peer pattern (``plan()`` has checked them already)."""
    check_grid(grid)
    if tree is not None and tree not in ("kruskal", "dfs"):
        raise ParameterError(f"Unknown maze generator {tree!r}.", "Use tree='kruskal' or tree='dfs'.")
    return check_seed(seed), check_index(start, "The start", grid.n)


# --------------------------------------------------------------------------------------
# perfect maze + wall follower (spanning-tree coverage): unicursal and maze
# --------------------------------------------------------------------------------------


@numba.njit(cache=True)
def _dfs_maze(cnb, order, seed):  # pragma: no cover - numba
    # Recursive-backtracker perfect maze on cells with neighbour table cnb (C, 4):
    # returns tree edges (cell, neighbour). One tree per connected component,
    # grown from the cells in ``order`` (first unvisited one).
    np.random.seed(seed)
    C = cnb.shape[0]
    vis = np.zeros(C, dtype=np.uint8)
    stack = np.empty(C, dtype=np.int64)
    ea = np.empty(C, dtype=np.int64)
    eb = np.empty(C, dtype=np.int64)
    ne = 0
    cand = np.empty(4, dtype=np.int64)
    for r in range(C):
        s = order[r]
        if vis[s]:
            continue
        vis[s] = 1
        top = 0
        stack[0] = s
        while top >= 0:
            c = stack[top]
            m = 0
            for d in range(4):
                q = cnb[c, d]
                if q >= 0 and vis[q] == 0:
                    cand[m] = q
                    m += 1
            if m == 0:
                top -= 1
                continue
            q = cand[np.random.randint(0, m)]
            vis[q] = 1
            ea[ne] = c
            eb[ne] = q
            ne += 1
            top += 1
            stack[top] = q
    return ea[:ne], eb[:ne]


@numba.njit(cache=True)
def _walk_cycles(nb, starts, out, comp_off):  # pragma: no cover - numba
    # Walk the closed loops of a 2-regular graph nb (M, 2), one from each start
    # node (skipping loops already walked). out: nodes in order; comp_off: offsets.
    M = nb.shape[0]
    seen = np.zeros(M, dtype=np.uint8)
    n = 0
    k = 0
    comp_off[0] = 0
    for t in range(starts.shape[0]):
        s = starts[t]
        if seen[s]:
            continue
        prev = -1
        cur = s
        while True:
            seen[cur] = 1
            out[n] = cur
            n += 1
            a = nb[cur, 0]
            b = nb[cur, 1]
            nxt = a if a != prev else b
            prev = cur
            cur = nxt
            if cur == s or seen[cur]:
                break
        k += 1
        comp_off[k] = n
    return n, k


def _spanning_tree(n_cells: int, ea: np.ndarray, eb: np.ndarray, method: str, seed: int, order: np.ndarray):
    """Random spanning forest of the cell graph: (tree_a, tree_b) cell pairs.

    ``"kruskal"``: minimum spanning forest for independent uniform random
    weights (randomised Kruskal). ``"dfs"``: recursive backtracker (long corridors).
    """
    if len(ea) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    if method == "kruskal":
        rng = np.random.default_rng(np.random.SeedSequence([int(seed), 1]))
        w = rng.random(len(ea)) + 1.0
        t = minimum_spanning_tree(coo_matrix((w, (ea, eb)), shape=(n_cells, n_cells)).tocsr()).tocoo()
        return t.row.astype(np.int64), t.col.astype(np.int64)
    if method == "dfs":
        cnb = np.full((n_cells, 4), -1, dtype=np.int64)
        # up to 4 neighbours per cell (E, N, W, S in some order)
        deg = np.zeros(n_cells, dtype=np.int64)
        for a, b in ((ea, eb), (eb, ea)):
            for x, y in zip(a.tolist(), b.tolist()):
                cnb[x, deg[x]] = y
                deg[x] += 1
        s32 = int(np.random.SeedSequence([int(seed), 2]).generate_state(1)[0])
        return _dfs_maze(cnb, np.ascontiguousarray(order, dtype=np.int64), s32)
    raise InvariantError(f"_spanning_tree: unknown maze generator {method!r} (the pattern checks tree first; a bug)")


def _stc_path(cells: np.ndarray, phase: np.ndarray, ea: np.ndarray, eb: np.ndarray, kind: np.ndarray,
              tree: str, seed: int, start_ij: np.ndarray):
    """Spanning-tree coverage: the wall-follower loop around a random perfect maze.

    Parameters
    ----------
    cells : (C, 2) int64
        Coarse cell indices ``(a, b)``; cell (a, b) holds the fine grid points
        ``(2a + p + {0,1}, 2b + q + {0,1})`` with ``phase = (p, q)``.
    phase : (2,) int64
    ea, eb : (E,) int64
        Candidate maze passages between cells ``ea -> eb``.
    kind : (E,) int64
        0 when ``eb`` is the east neighbour of ``ea``, 1 when the north one.
    tree : {"kruskal", "dfs"}
        Maze generator.
    seed : int
    start_ij : (2,) int64
        Fine grid index to start at (the nearest fine point of the maze is used).

    Returns
    -------
    ij : (4C, 2) int64
        Fine grid indices in path order.
    pieces : (K+1,) int64
        One piece per maze component (each a loop opened at its start).
    n_tree : int
        Number of maze passages.
    """
    C = len(cells)
    # fine points of a cell: 0 SW, 1 SE, 2 NE, 3 NW
    cor = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.int64)
    fine = (2 * cells[:, None, :] + phase[None, None, :] + cor[None, :, :]).reshape(-1, 2)
    # the 4 sides of each cell's small square loop: bottom(0-1), right(1-2), top(2-3), left(3-0)
    side = np.ones((C, 4), dtype=bool)
    order = np.argsort(np.hypot(*(cells * 2 + phase - start_ij).T), kind="stable")
    ta, tb = _spanning_tree(C, ea, eb, tree, seed, order)
    # orient every tree edge as (west/south cell, east/north cell)
    if len(ea):
        # look up the kind of each tree edge from the candidate list
        code = np.minimum(ea, eb) * (C + 1) + np.maximum(ea, eb)
        srt = np.argsort(code)
        tcode = np.minimum(ta, tb) * (C + 1) + np.maximum(ta, tb)
        pos = srt[np.searchsorted(code[srt], tcode)]
        ta, tb, tk = ea[pos], eb[pos], kind[pos]
    else:
        tk = np.zeros(0, np.int64)
    extra_a, extra_b = [], []
    h = tk == 0  # east: remove right of a, left of b; join SE_a-SW_b and NE_a-NW_b
    side[ta[h], 1] = False
    side[tb[h], 3] = False
    extra_a += [4 * ta[h] + 1, 4 * ta[h] + 2]
    extra_b += [4 * tb[h] + 0, 4 * tb[h] + 3]
    v = tk == 1  # north: remove top of a, bottom of b; join NW_a-SW_b and NE_a-SE_b
    side[ta[v], 2] = False
    side[tb[v], 0] = False
    extra_a += [4 * ta[v] + 3, 4 * ta[v] + 2]
    extra_b += [4 * tb[v] + 0, 4 * tb[v] + 1]
    sa = np.array([0, 1, 2, 3])
    sb = np.array([1, 2, 3, 0])
    cc, ss = np.nonzero(side)
    A = np.concatenate([4 * cc + sa[ss], *extra_a])
    B = np.concatenate([4 * cc + sb[ss], *extra_b])
    x = np.concatenate([A, B])
    y = np.concatenate([B, A])
    o = np.argsort(x, kind="stable")
    if not np.array_equal(np.bincount(x, minlength=4 * C), np.full(4 * C, 2)):  # pragma: no cover - invariant
        raise InvariantError("spanning-tree coverage: a node does not have degree 2 (a bug, whatever the input)")
    nb = np.ascontiguousarray(y[o].reshape(4 * C, 2))
    # start nodes: the fine point nearest the start first, then one node of each cell by distance
    d = np.hypot(*(fine - start_ij).T)
    starts = np.argsort(d, kind="stable")
    out = np.empty(4 * C, dtype=np.int64)
    offs = np.empty(4 * C + 1, dtype=np.int64)
    n, k = _walk_cycles(nb, starts, out, offs)
    return fine[out[:n]], offs[: k + 1].copy(), len(ta)


def _cells_and_passages(cell_ok: np.ndarray, lo: np.ndarray, east_ok: np.ndarray, north_ok: np.ndarray):
    """Cells (C, 2) and candidate passages from dense boolean maps over coarse cells (Hc, Wc)."""
    Hc, Wc = cell_ok.shape
    cid = np.full(Hc * Wc, -1, dtype=np.int64)
    flat = np.flatnonzero(cell_ok.ravel())
    cid[flat] = np.arange(len(flat))
    bb, aa = np.divmod(flat, Wc)
    cells = np.stack([aa + lo[0], bb + lo[1]], axis=1).astype(np.int64)
    e = np.flatnonzero((east_ok & cell_ok).ravel())
    e = e[(e % Wc) < Wc - 1]
    e = e[cid[e + 1] >= 0]
    nn = np.flatnonzero((north_ok & cell_ok).ravel())
    nn = nn[(nn // Wc) < Hc - 1]
    nn = nn[cid[nn + Wc] >= 0]
    ea = np.concatenate([cid[e], cid[nn]])
    eb = np.concatenate([cid[e + 1], cid[nn + Wc]])
    kind = np.concatenate([np.zeros(len(e), np.int64), np.ones(len(nn), np.int64)])
    return cells, ea, eb, kind


def _unicursal_cells(grid: DwellGrid, phase: np.ndarray):
    """Usable coarse cells of the grid for ``phase``: all 4 dwell points in, the square's sides inside."""
    lo_f = grid.ij.min(axis=0)
    hi_f = grid.ij.max(axis=0)
    lo = (lo_f - phase) // 2 - 1
    hi = (hi_f - phase) // 2 + 1
    Wc, Hc = int(hi[0] - lo[0] + 1), int(hi[1] - lo[1] + 1)
    A, B = np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1))
    base = np.stack([2 * A.ravel() + phase[0], 2 * B.ravel() + phase[1]], axis=1)
    sw = _lookup(grid, base)
    se = _lookup(grid, base + [1, 0])
    nw = _lookup(grid, base + [0, 1])
    ne = _lookup(grid, base + [1, 1])
    ok = (sw >= 0) & (se >= 0) & (nw >= 0) & (ne >= 0)
    ok &= _has(grid, sw, _E) & _has(grid, nw, _E) & _has(grid, sw, _N) & _has(grid, se, _N)
    east = _has(grid, se, _E) & _has(grid, ne, _E)  # SE->SW and NE->NW of the east cell
    north = _has(grid, nw, _N) & _has(grid, ne, _N)  # NW->SW and NE->SE of the north cell
    shape = (Hc, Wc)
    return ok.reshape(shape), lo, east.reshape(shape), north.reshape(shape)


def pattern_unicursal(grid: DwellGrid, region: Region, *, seed: int, start: int, tree: str = "kruskal",
                      phase=None, **options) -> PatternResult:
    """Unicursal random path (Dunn & Walker 2008): wall follower of a random perfect maze.

    Parameters
    ----------
    grid : DwellGrid
        Dwell points (spacing ``s`` mm) and their inside adjacency.
    region : Region
        The planar region, mm (the grid already holds its shrunk polygon).
    seed : int
        Seed of the maze.
    start : int
        Dwell-point number to start near.
    tree : {"kruskal", "dfs"}
        Maze generator: randomised Kruskal (default; many short dead ends, the
        look of Dunn & Walker's figures) or recursive backtracker.
    phase : (2,) int, optional
        Alignment of the 2 x 2 cells on the fine grid (0 or 1 each); default:
        the one of the four that leaves the fewest dwell points out.

    Returns
    -------
    PatternResult
        ``uv`` (N, 2) mm, dwell points only (``on_grid``); one piece per maze
        component; ``stats``: ``left_out`` (dwell points in no usable cell, by
        design), ``maze_cells``, ``maze_components``, ``passages``, ``phase``.
    """
    check_options("unicursal", options, ("tree", "phase"))
    seed, start = _check_call(grid, seed, start, tree)
    if phase is not None:
        ok_phase = np.shape(phase) == (2,) and all(
            isinstance(x, (int, np.integer)) and not isinstance(x, bool) and x in (0, 1) for x in phase)
        if not ok_phase:
            raise ParameterError(f"phase must be two whole numbers, each 0 or 1, got {phase!r}.",
                                 "Pass e.g. phase=(0, 1), or leave it out to take the best of the four.")
    best = None
    phases = [np.array(phase, dtype=np.int64) % 2] if phase is not None else [
        np.array(p, dtype=np.int64) for p in ((0, 0), (1, 0), (0, 1), (1, 1))]
    for ph in phases:
        ok, lo, east, north = _unicursal_cells(grid, ph)
        cnt = int(ok.sum())
        if best is None or cnt > best[0]:
            best = (cnt, ph, ok, lo, east, north)
    cnt, ph, ok, lo, east, north = best
    if cnt == 0:
        return PatternResult(np.zeros((0, 2)), np.zeros((0, 2), np.int64), np.array([0, 0], np.int64), True,
                             {"left_out": grid.n, "maze_cells": 0, "maze_components": 0, "passages": 0,
                              "phase": [int(x) for x in ph]})
    cells, ea, eb, kind = _cells_and_passages(ok, lo, east, north)
    ij, pieces, n_tree = _stc_path(cells, ph, ea, eb, kind, tree, seed, grid.ij[start])
    order = _lookup(grid, ij)
    if np.any(order < 0):  # pragma: no cover - invariant: every cell's 4 points were checked to be dwell points
        raise InvariantError("unicursal: a path point is not a dwell point (a bug, whatever the input)")
    stats = {"left_out": int(grid.n - len(order)), "maze_cells": len(cells),
             "maze_components": int(len(pieces) - 1), "passages": n_tree, "phase": [int(x) for x in ph],
             "tree": tree}
    return PatternResult(grid.uv[order], grid.ij[order], pieces.astype(np.int64), True, stats)


def _scan_crossings(grid: DwellGrid, y: float) -> np.ndarray:
    """Sorted x (grid units) where the horizontal line ``j = y`` crosses the region boundary."""
    xs = []
    for g in getattr(grid.polygon, "geoms", [grid.polygon]):
        for ring in [g.exterior, *g.interiors]:
            p = uv_to_grid(np.asarray(ring.coords), grid.spacing, grid.origin, grid.rotation)
            a, b = p[:-1], p[1:]
            ya, yb = a[:, 1], b[:, 1]
            hit = (np.minimum(ya, yb) <= y) & (np.maximum(ya, yb) > y) & (ya != yb)
            t = (y - ya[hit]) / (yb[hit] - ya[hit])
            xs.append(a[hit, 0] + t * (b[hit, 0] - a[hit, 0]))
    return np.sort(np.concatenate(xs)) if xs else np.zeros(0)


def pattern_maze(grid: DwellGrid, region: Region, *, seed: int, start: int, tree: str = "dfs",
                 **options) -> PatternResult:
    """Zhang et al.'s perfect-maze path, with the published scan-line boundary handling.

    For each maze row (cells of 2 x 2 grid points, phase 0) a scan line through
    the row's centre crosses the boundary; the first crossing is taken as
    entering the polished region and the second as leaving it. Every cell whose
    area (its 4 points' +-0.5 spacing squares) overlaps that interval is a maze
    cell, so cells stick out over the boundary, and anything after the second
    crossing is not polished. The path is the wall follower of a perfect maze
    on those cells (steps along the two grid axes only).

    Parameters
    ----------
    grid : DwellGrid
    region : Region
    seed : int
    start : int
    tree : {"dfs", "kruskal"}
        Maze generator (default recursive backtracker).

    Returns
    -------
    PatternResult
        ``uv`` (N, 2) mm on grid positions, some of them outside the region
        (``on_grid`` False: not every point is a dwell point); ``ij`` (N, 2);
        one piece per maze component (the path goes on over the boundary,
        it does not lift there). ``stats``: ``left_out`` (dwell points inside
        the region the path never visits), ``outside_points``,
        ``outside_steps``, ``outside_length_mm``, ``area_outside_mm2``,
        ``rows_clipped`` (maze rows with more than two crossings, where part
        of the region was dropped), ``maze_cells``, ``maze_components``.
    """
    check_options("maze", options, ("tree",))
    seed, start = _check_call(grid, seed, start, tree)
    ph = np.zeros(2, dtype=np.int64)
    lo_f = grid.ij.min(axis=0) - 2
    hi_f = grid.ij.max(axis=0) + 2
    lo = (lo_f - ph) // 2
    hi = (hi_f - ph) // 2
    Wc, Hc = int(hi[0] - lo[0] + 1), int(hi[1] - lo[1] + 1)
    ok = np.zeros((Hc, Wc), dtype=bool)
    clipped = 0
    for r in range(Hc):
        b = lo[1] + r
        yc = 2 * b + ph[1] + 0.5
        xs = _scan_crossings(grid, yc)
        if len(xs) < 2:
            continue
        if len(xs) > 2:
            clipped += 1
        x_in, x_out = xs[0], xs[1]
        # cell a covers grid x in [2a + p - 0.5, 2a + p + 1.5]
        a_lo = int(np.floor((x_in - ph[0] - 1.5) / 2.0)) + 1
        a_hi = int(np.ceil((x_out - ph[0] + 0.5) / 2.0)) - 1
        a_lo, a_hi = max(a_lo, int(lo[0])), min(a_hi, int(hi[0]))
        if a_hi >= a_lo:
            ok[r, a_lo - lo[0] : a_hi - lo[0] + 1] = True
    if not ok.any():
        return PatternResult(np.zeros((0, 2)), np.zeros((0, 2), np.int64), np.array([0, 0], np.int64), False,
                             {"left_out": grid.n, "outside_points": 0, "outside_steps": 0,
                              "outside_length_mm": 0.0, "area_outside_mm2": 0.0, "rows_clipped": clipped,
                              "maze_cells": 0, "maze_components": 0})
    allt = np.ones_like(ok)
    cells, ea, eb, kind = _cells_and_passages(ok, lo, allt, allt)
    ij, pieces, n_tree = _stc_path(cells, ph, ea, eb, kind, tree, seed, grid.ij[start])
    uv = grid.to_uv(ij)
    k = _lookup(grid, ij)
    stats = {"left_out": int(grid.n - np.count_nonzero(k >= 0)), **_outside_figures(grid, uv, pieces),
             "rows_clipped": int(clipped), "maze_cells": len(cells), "maze_components": int(len(pieces) - 1),
             "passages": n_tree, "tree": tree}
    return PatternResult(uv, ij, pieces.astype(np.int64), False, stats)


# --------------------------------------------------------------------------------------
# random fractal-like path and Hilbert curve
# --------------------------------------------------------------------------------------

_CORNER = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.int64)  # SW SE NE NW
#: Largest square of a space-filling curve: 2**15 points a side (4**15, about 1e9 points).
_MAX_SIDE_LOG2 = 15


def _seg_cross(p1, p2, q1, q2) -> bool:
    """Whether closed segments p1p2 and q1q2 share a point (integer 2D points)."""
    return shapely.intersects(shapely.LineString([p1, p2]), shapely.LineString([q1, q2]))


def _fractal_table(h: int) -> list[list[list[tuple]]]:
    """Valid ways to split a block of side 2h entered at corner e and left at corner x.

    Returns ``T[e][x]`` = list of ``(order (4,), entry (4,), exit (4,))``: the
    quadrants in visiting order and each one's entry / exit corner, such that
    consecutive quadrants are joined by an 8-neighbour step, a quadrant of side
    >= 2 is not entered and left at the same corner, and the three joining
    steps do not cross each other.
    """
    import itertools

    def pos(q, c):
        return _CORNER[q] * h + _CORNER[c] * (h - 1)

    T = [[[] for _ in range(4)] for _ in range(4)]
    for e in range(4):
        for x in range(4):
            if e == x:
                continue
            others = [q for q in range(4) if q not in (e, x)]
            for mid in itertools.permutations(others):
                order = (e, *mid, x)
                links = []
                for t in range(3):
                    qa, qb = order[t], order[t + 1]
                    opts = [(ca, cb) for ca in range(4) for cb in range(4)
                            if np.abs(pos(qa, ca) - pos(qb, cb)).max() == 1]
                    if h == 1:
                        opts = [(0, 0)]
                    links.append(opts)
                for combo in itertools.product(*links):
                    entry = [e] + [combo[t][1] for t in range(3)]
                    exit_ = [combo[t][0] for t in range(3)] + [x]
                    if h == 1:
                        entry, exit_ = [0, 0, 0, 0], [0, 0, 0, 0]
                    elif any(entry[t] == exit_[t] for t in range(4)):
                        continue
                    segs = [(pos(order[t], exit_[t]), pos(order[t + 1], entry[t + 1])) for t in range(3)]
                    bad = False
                    for s1, s2 in itertools.combinations(range(3), 2):
                        a, b = segs[s1], segs[s2]
                        if s2 == s1 + 1 and h == 1:
                            continue  # consecutive joins meet at the one-point quadrant
                        if _seg_cross(a[0], a[1], b[0], b[1]):
                            bad = True
                    if not bad:
                        T[e][x].append((order, tuple(entry), tuple(exit_)))
    return T


_TABLES: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def _table_arrays(h: int):
    """``(opts (4, 4, M, 12) int64, count (4, 4))``: :func:`_fractal_table` packed (h >= 3 share one)."""
    key = min(h, 3)
    if key not in _TABLES:
        T = _fractal_table(key)
        M = max(len(T[e][x]) for e in range(4) for x in range(4) if e != x)
        opts = np.zeros((4, 4, M, 12), dtype=np.int64)
        cnt = np.zeros((4, 4), dtype=np.int64)
        for e in range(4):
            for x in range(4):
                for m, (o, en, ex) in enumerate(T[e][x] if e != x else []):
                    opts[e, x, m] = [*o, *en, *ex]
                cnt[e, x] = len(T[e][x]) if e != x else 0
        _TABLES[key] = (opts, cnt)
    return _TABLES[key]


def fractal_sequence(side_log2: int, seed: int) -> np.ndarray:
    """Random fractal-like Hamiltonian path of a square of ``2**side_log2`` grid points a side.

    Parameters
    ----------
    side_log2 : int
        k, the square has side ``2**k`` points (k >= 1).
    seed : int
        Seed of the random choices.

    Returns
    -------
    (4**k, 2) int64
        Grid indices ``(i, j)`` in ``[0, 2**k)``, each once, consecutive ones
        8-neighbours, the polyline without self-intersection.

    Raises
    ------
    ParameterError
        k not a whole number from 1 to 15 (4**15 points), or a bad seed.
    """
    side_log2 = check_count(side_log2, "side_log2", low=1, high=_MAX_SIDE_LOG2)
    rng = np.random.default_rng(np.random.SeedSequence([check_seed(seed), 3]))
    e0 = int(rng.integers(4))
    x0 = int((e0 + rng.integers(1, 4)) % 4)
    bx = np.zeros(1, np.int64)
    by = np.zeros(1, np.int64)
    be = np.array([e0])
    bxit = np.array([x0])
    side = 2**side_log2
    while side > 1:
        h = side // 2
        opts, cnt = _table_arrays(h)
        c = cnt[be, bxit]
        pick = (rng.random(len(be)) * c).astype(np.int64)
        o = opts[be, bxit, pick]  # (n, 12)
        order, entry, exit_ = o[:, 0:4], o[:, 4:8], o[:, 8:12]
        bx = (bx[:, None] + _CORNER[order, 0] * h).ravel()
        by = (by[:, None] + _CORNER[order, 1] * h).ravel()
        be = entry.ravel()
        bxit = exit_.ravel()
        side = h
    return np.stack([bx, by], axis=1)


def hilbert_sequence(side_log2: int, symmetry: int = 0) -> np.ndarray:
    """Hilbert curve through a square of ``2**side_log2`` grid points a side.

    Parameters
    ----------
    side_log2 : int
        k (>= 0).
    symmetry : int
        0..7: one of the square's symmetries applied to the curve
        (bit 0 mirror i, bit 1 mirror j, bit 2 swap i and j).

    Returns
    -------
    (4**k, 2) int64
        Grid indices in curve order.

    Raises
    ------
    ParameterError
        k not a whole number from 0 to 15, or symmetry not 0..7.
    """
    n = 2 ** check_count(side_log2, "side_log2", low=0, high=_MAX_SIDE_LOG2)
    symmetry = check_count(symmetry, "symmetry", low=0, high=7)
    d = np.arange(n * n, dtype=np.int64)
    x = np.zeros_like(d)
    y = np.zeros_like(d)
    t = d.copy()
    s = 1
    while s < n:
        rx = 1 & (t // 2)
        ry = 1 & (t ^ rx)
        # rotate
        flip = (ry == 0) & (rx == 1)
        x = np.where(flip, s - 1 - x, x)
        y = np.where(flip, s - 1 - y, y)
        swap = ry == 0
        x, y = np.where(swap, y, x), np.where(swap, x, y)
        x = x + s * rx
        y = y + s * ry
        t //= 4
        s *= 2
    if symmetry & 1:
        x = n - 1 - x
    if symmetry & 2:
        y = n - 1 - y
    if symmetry & 4:
        x, y = y, x
    return np.stack([x, y], axis=1)


def _square_fit(grid: DwellGrid) -> tuple[np.ndarray, int]:
    lo = grid.ij.min(axis=0)
    ext = int((grid.ij.max(axis=0) - lo).max()) + 1
    k = max(1, int(np.ceil(np.log2(max(ext, 2)))))
    if k > _MAX_SIDE_LOG2:
        raise ParameterError(
            f"The region needs a {2**k} x {2**k} square for a space-filling curve, too large.",
            "Use a larger spacing.",
        )
    return lo, k


def bspline_deviation(points: np.ndarray, pieces=None, samples_per_span: int = 16) -> dict:
    """How far an approximating cubic B-spline (control points = dwell points) stays from them.

    The smoothing of Dong et al.'s fractal-like path does not interpolate: the
    curve of a uniform cubic B-spline with the dwell points as control polygon
    (ends clamped by tripling the end points) passes at
    ``(P[i-1] + 4 P[i] + P[i+1]) / 6`` instead of ``P[i]``. Measured as the
    distance from each dwell point to the nearest point of the curve near it
    (the 4 spans it controls, sampled).

    Parameters
    ----------
    points : (N, d) float64
        Dwell points in path order, mm (d = 2 or 3).
    pieces : (K+1,) int64, optional
        Piece offsets; each piece is its own spline.
    samples_per_span : int
        Curve samples per span.

    Returns
    -------
    dict
        ``dev_max``, ``dev_mean``, ``dev_p95`` (mm), ``share_over_10pct``
        (share of dwell points farther than 10 % of the median step).

    Raises
    ------
    ParameterError
        Points not (N, 2) or (N, 3) finite numbers; pieces not offsets from 0
        to N, non-decreasing; samples_per_span not a whole number >= 1.
    """
    P = check_points(points, "points", cols=(2, 3))
    n = len(P)
    samples_per_span = check_count(samples_per_span, "samples_per_span", low=1, high=10_000)
    pieces = np.asarray([0, n] if pieces is None else pieces)
    if (pieces.ndim != 1 or len(pieces) < 2 or not np.issubdtype(pieces.dtype, np.integer) or pieces[0] != 0
            or pieces[-1] != n or np.any(np.diff(pieces) < 0)):
        raise ParameterError(f"pieces must be whole-number offsets from 0 to {n} (the number of points), "
                             f"non-decreasing, got {pieces!r}.",
                             "Pass the path's piece offsets (PlanarPath.pieces), or None for one piece.")
    pieces = pieces.astype(np.int64)
    devs = []
    steps = []
    t = (np.arange(samples_per_span + 1) / samples_per_span)[:, None]
    b0 = (1 - t) ** 3 / 6
    b1 = (3 * t**3 - 6 * t**2 + 4) / 6
    b2 = (-3 * t**3 + 3 * t**2 + 3 * t + 1) / 6
    b3 = t**3 / 6
    for k in range(len(pieces) - 1):
        Q = P[pieces[k] : pieces[k + 1]]
        m = len(Q)
        if m == 0:
            continue
        if m > 1:
            steps.append(np.linalg.norm(np.diff(Q, axis=0), axis=1))
        if m < 3:
            devs.append(np.zeros(m))
            continue
        C = np.concatenate([Q[:1], Q[:1], Q, Q[-1:], Q[-1:]])  # clamped: curve starts / ends at the ends
        S = len(C) - 3  # spans
        # samples (S, T, d)
        samp = (b0[None] * C[:-3, None] + b1[None] * C[1:-2, None] + b2[None] * C[2:-1, None]
                + b3[None] * C[3:, None])
        # dwell point i (C index i + 2) controls spans i-1 .. i+2 (clipped)
        best = np.full(m, np.inf)
        for off in (-1, 0, 1, 2):
            s_idx = np.arange(m) + off
            ok = (s_idx >= 0) & (s_idx < S)
            dd = np.linalg.norm(samp[s_idx[ok]] - Q[ok, None, :], axis=2).min(axis=1)
            best[ok] = np.minimum(best[ok], dd)
        devs.append(best)
    dev = np.concatenate(devs) if devs else np.zeros(0)
    med = float(np.median(np.concatenate(steps))) if steps else 0.0
    if len(dev) == 0:
        return {"dev_max": 0.0, "dev_mean": 0.0, "dev_p95": 0.0, "share_over_10pct": 0.0}
    return {"dev_max": float(dev.max()), "dev_mean": float(dev.mean()), "dev_p95": float(np.quantile(dev, 0.95)),
            "share_over_10pct": float(np.mean(dev > 0.1 * med)) if med > 0 else 0.0}


def pattern_fractal(grid: DwellGrid, region: Region, *, seed: int, start: int, **options) -> PatternResult:
    """Random fractal-like path (Dong et al.): recursive random quadrant order, clipped to the region.

    Parameters
    ----------
    grid : DwellGrid
    region : Region
    seed : int
    start : int
        Not used (the curve's ends are corners of the bounding square).

    Returns
    -------
    PatternResult
        Dwell points only; a new piece where the curve leaves the region (the
        tool lifts). ``stats``: ``left_out`` (0), ``curve_pieces``,
        ``square_side`` (points), ``smoothing_dev_max`` / ``_mean`` / ``_p95``
        (mm, the published approximating-spline smoothing, planar) and
        ``smoothing`` (what was measured).
    """
    check_options("fractal", options, ())
    seed, start = _check_call(grid, seed, start)
    lo, k = _square_fit(grid)
    seq = fractal_sequence(k, seed) + lo
    order, pieces = clip_grid_sequence(grid, seq, chords=False)
    uv = grid.uv[order]
    dev = bspline_deviation(uv, pieces)
    stats = {"left_out": int(grid.n - len(order)), "square_side": int(2**k),
             "curve_pieces": int(len(pieces) - 1),
             "smoothing": "uniform cubic B-spline, dwell points as control points",
             "smoothing_dev_max": dev["dev_max"], "smoothing_dev_mean": dev["dev_mean"],
             "smoothing_dev_p95": dev["dev_p95"]}
    return PatternResult(uv, grid.ij[order], pieces, True, stats)


def pattern_hilbert(grid: DwellGrid, region: Region, *, seed: int, start: int, **options) -> PatternResult:
    """Hilbert curve on the grid's bounding square, clipped to the region.

    Parameters
    ----------
    grid : DwellGrid
    region : Region
    seed : int
        ``seed % 8`` picks the curve's orientation (mirror / swap of the axes).
    start : int
        Not used.

    Returns
    -------
    PatternResult
        Dwell points only; a new piece wherever the curve leaves the region.
        ``stats``: ``left_out`` (0), ``square_side``, ``symmetry``.
    """
    check_options("hilbert", options, ())
    seed, start = _check_call(grid, seed, start)
    lo, k = _square_fit(grid)
    seq = hilbert_sequence(k, int(seed) % 8) + lo
    order, pieces = clip_grid_sequence(grid, seq, chords=False)
    stats = {"left_out": int(grid.n - len(order)), "square_side": int(2**k), "symmetry": int(seed) % 8}
    return PatternResult(grid.uv[order], grid.ij[order], pieces, True, stats)


#: The peer patterns by name.
PEER_PATTERNS = {
    "unicursal": pattern_unicursal,
    "maze": pattern_maze,
    "fractal": pattern_fractal,
    "hilbert": pattern_hilbert,
}


def register_peers() -> dict[str, bool]:
    """Register the peer patterns with :func:`polishpath.plan.register_pattern` (idempotent).

    A name already registered to another function is left alone.

    Returns
    -------
    dict
        Pattern name -> True when it now refers to the peer defined here.
    """
    out = {}
    for name, fn in PEER_PATTERNS.items():
        cur = PATTERNS.get(name)
        if cur is None or cur is fn:
            register_pattern(name, fn, random=True)
        out[name] = PATTERNS.get(name) is fn
    return out
