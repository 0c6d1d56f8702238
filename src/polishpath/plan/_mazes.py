"""The two maze peers of the paper's Table 3: ``unicursal`` and ``maze`` (registered by :mod:`.peers`).

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

Both walk the walls of a random perfect maze (spanning-tree coverage). The
random choices are reproducible with the seed (numpy ``SeedSequence``; numba's
generator seeded inside the kernel for the depth-first maze).
"""

from __future__ import annotations

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np
import shapely
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import minimum_spanning_tree

from ..errors import InvariantError, ParameterError
from ..types import Region
from .api import PatternResult, check_pattern_call
from .checks import check_options
from .dwell import DwellGrid, uv_to_grid

# bit of DwellGrid.dirmask for the steps used here
_E, _N = 0, 2




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


def _check_tree(tree) -> None:
    if tree not in ("kruskal", "dfs"):
        raise ParameterError(f"Unknown maze generator {tree!r}.", "Use tree='kruskal' or tree='dfs'.")


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
        ``uv`` (N, 2) mm, dwell points only (``dwell_points_only``); one piece per maze
        component; ``stats``: ``left_out`` (dwell points in no usable cell, by
        design), ``maze_cells``, ``maze_components``, ``passages``, ``phase``.
    """
    check_options("unicursal", options, ("tree", "phase"))
    seed, start = check_pattern_call(grid, seed, start)
    _check_tree(tree)
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
                              "phase": [int(x) for x in ph]}, lattice=grid.lattice)
    cells, ea, eb, kind = _cells_and_passages(ok, lo, east, north)
    ij, pieces, n_tree = _stc_path(cells, ph, ea, eb, kind, tree, seed, grid.ij[start])
    order = _lookup(grid, ij)
    if np.any(order < 0):  # pragma: no cover - invariant: every cell's 4 points were checked to be dwell points
        raise InvariantError("unicursal: a path point is not a dwell point (a bug, whatever the input)")
    stats = {"left_out": int(grid.n - len(order)), "maze_cells": len(cells),
             "maze_components": int(len(pieces) - 1), "passages": n_tree, "phase": [int(x) for x in ph],
             "tree": tree}
    return PatternResult(grid.uv[order], grid.ij[order], pieces.astype(np.int64), True, stats, lattice=grid.lattice)


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
        (``dwell_points_only`` False: not every point is a dwell point); ``ij`` (N, 2);
        one piece per maze component (the path goes on over the boundary,
        it does not lift there). ``stats``: ``left_out`` (dwell points inside
        the region the path never visits), ``outside_points``,
        ``outside_steps``, ``outside_length_mm``, ``area_outside_mm2``,
        ``rows_clipped`` (maze rows with more than two crossings, where part
        of the region was dropped), ``maze_cells``, ``maze_components``.
    """
    check_options("maze", options, ("tree",))
    seed, start = check_pattern_call(grid, seed, start)
    _check_tree(tree)
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
                              "maze_cells": 0, "maze_components": 0}, lattice=grid.lattice)
    allt = np.ones_like(ok)
    cells, ea, eb, kind = _cells_and_passages(ok, lo, allt, allt)
    ij, pieces, n_tree = _stc_path(cells, ph, ea, eb, kind, tree, seed, grid.ij[start])
    uv = grid.to_uv(ij)
    k = _lookup(grid, ij)
    stats = {"left_out": int(grid.n - np.count_nonzero(k >= 0)), **_outside_figures(grid, uv, pieces),
             "rows_clipped": int(clipped), "maze_cells": len(cells), "maze_components": int(len(pieces) - 1),
             "passages": n_tree, "tree": tree}
    return PatternResult(uv, ij, pieces.astype(np.int64), False, stats, lattice=grid.lattice)
