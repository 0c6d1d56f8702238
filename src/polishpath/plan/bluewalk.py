"""The pseudo-random walk over a dwell-point set without a lattice (``--dwell-points blue-noise``).

:func:`graph_walk_order` orders the points of a
:class:`~polishpath.plan.points.BlueNoisePoints` set along a random path of
its neighbour graph (``_graphwalk``): every point once, short steps (graph
edges of at most ``EDGE_FACTOR x h``, ``LEAF_EDGE_FACTOR x h`` at a rim point
that would otherwise have one neighbour), random turns, never crossing itself
(the edges of a triangulation do not cross), never leaving the region (the
kept edges are inside it). Graph components that are not connected at all (a
neck narrower than about 1.7 spacings) are planned one after the other as
separate pieces, as the grid walk does.
"""

from __future__ import annotations

import time

import numba
import numpy as np

from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
from ..errors import ParameterError
from ._graphendgame import plan_graph_component
from ._steps import N_STATS
from ._graphwalk import BLOCK, N_GRAPH_STATS, ST_FLIP
from ._component import collect_pieces
from .checks import check_count, check_index, check_number, check_seed
from .points.blue_noise import BlueNoisePoints, cell_lists
from .pseudorandom import walk_stats

#: The options of :func:`graph_walk_order` that ``plan(..., dwell_points="blue-noise", **options)`` passes on.
GRAPH_WALK_OPTIONS = ("max_blind", "steer", "backtrack", "backtrack_budget")


def check_points_set(points) -> BlueNoisePoints:
    """``points`` when it is a :class:`BlueNoisePoints`, else :class:`~polishpath.errors.ParameterError`."""
    if not isinstance(points, BlueNoisePoints):
        raise ParameterError(
            f"The dwell points must be a polishpath.plan.points.BlueNoisePoints, got {type(points).__name__}.",
            "Build them with polishpath.plan.points.blue_noise_points(region, spacing, seed=...).")
    return points


def graph_walk_order(points: BlueNoisePoints, *, seed: int, start: int = 0, pin_start: bool = False,
                     max_blind: int = 10, steer: int = 32, backtrack: int = 5,
                     backtrack_budget: float = 0.05) -> tuple[np.ndarray, np.ndarray, dict]:
    """Order of the dwell points along a pseudo-random path of their neighbour graph.

    Parameters
    ----------
    points : BlueNoisePoints
        Dwell points and their neighbour graph.
    seed : int
        Seed (0 <= seed < 2**63); same seed, same path. Each component gets its own numba seed drawn from it.
    start : int
        Point number where the walk starts.
    pin_start : bool
        The path's first point must be ``start`` (a start point the user asked for). Without it the walk
        grows from ``start`` but may turn the whole path round (at a rim point of one neighbour, or where
        only the other end can move on: fewer tool lifts), so the path begins at another point. With it
        the walk never does; should the end-game still leave ``start`` inside its piece, the piece is cut
        there (one tool lift more, counted in ``start_cut``) so that the path begins at ``start``.
    max_blind : int
        Turnarounds in a row that do not free the head before the walk hands over to the end-game.
    steer : int
        Radius (cells of one spacing) of the search for the nearest unvisited point that blind turnarounds
        steer toward.
    backtrack : int
        Points given back when no turnaround exists (the paper's step 7 uses 5); 0 disables it.
    backtrack_budget : float
        Total points given back, as a fraction of the component's size (in [0, 1]).

    Returns
    -------
    order : (n,) int64
        Point numbers in path order (each exactly once).
    pieces : (K+1,) int64
        Offsets of the continuous pieces in ``order`` (one per graph component, plus ``extra_pieces``).
    stats : dict
        ``components``, ``extra_pieces``, ``steps``, ``turnarounds``, ``blind``, ``stuck``, ``deleted``
        (given back by step 7), ``escapes``, ``spliced``, ``appended``, ``two_opt``, ``kicks``,
        ``subwalks``, ``joins``, ``reversed_points``, ``walk_fraction``, ``turnarounds_by_tenth``,
        ``seconds``.

    Raises
    ------
    ParameterError
        Not a BlueNoisePoints; seed or start out of range; ``max_blind`` not a whole number >= 0.
    """
    check_points_set(points)
    seed = check_seed(seed)
    start = check_index(start, "The start", points.n)
    max_blind = check_count(max_blind, "max_blind")
    steer = check_count(steer, "steer", high=2**20)
    backtrack = check_count(backtrack, "backtrack")
    backtrack_budget = check_number(backtrack_budget, "backtrack_budget", low=0.0)
    if backtrack_budget > 1:
        raise ParameterError(f"backtrack_budget is a fraction of the points, at most 1, got {backtrack_budget!r}.",
                             "Pass a number in [0, 1] (default 0.05).")
    t0 = time.perf_counter()
    n = points.n
    indptr, indices = points.indptr, points.indices
    # the graph's components (labelled in the order of their smallest point, as scipy's connected_components
    # does), their points in order, and where each begins: one pass over the graph
    ncomp, lab, sort, bounds = _components(indptr, indices)
    d_start = np.hypot(*(points.uv - points.uv[start]).T)
    comp_dist = np.minimum.reduceat(d_start[sort], bounds[:-1])
    comp_order = np.argsort(comp_dist, kind="stable")
    seeds = np.random.SeedSequence(seed).generate_state(max(ncomp, 1), dtype=np.uint32)

    vis = np.zeros(n, dtype=np.uint8)
    wid = np.full(n, -1, dtype=np.int32)
    nxt = np.full(n, -1, dtype=np.int32)
    prv = np.full(n, -1, dtype=np.int32)
    T = np.empty((n, 6), dtype=np.int32)
    m = int(np.diff(bounds).max())
    stack = np.empty(m + 2, dtype=np.int32)
    P = np.empty(m + 1, dtype=np.int32)
    inq = np.zeros(n, dtype=np.uint8)
    queue = np.empty(m + 1, dtype=np.int32)
    mark = np.zeros(n, dtype=np.uint8)
    buf = np.empty(m + 1, dtype=np.int64)

    # cell lists (side one spacing) for the steering search
    cells, cstart, x0, y0, W, H = cell_lists(points.uv, points.spacing)
    cw = points.spacing
    lab64 = lab
    # the steering search's blocks of BLOCK x BLOCK cells and their counts of unvisited points (all, at first)
    blk, ucnt, WB = _blocks(points.uv, float(x0), float(y0), float(cw), W, H)

    tot = np.zeros(N_GRAPH_STATS, dtype=np.int64)
    orders, piece_offs = [], [np.zeros(1, dtype=np.int64)]
    n_done = 0
    prev_end = points.uv[start]
    walk_id = 1
    start_cut = 0
    for rank, c in enumerate(comp_order):
        members = np.ascontiguousarray(sort[bounds[c]:bounds[c + 1]], dtype=np.int64)
        s = start if rank == 0 else int(members[np.argmin(np.hypot(*(points.uv[members] - prev_end).T))])
        tot += plan_graph_component(members, s, int(seeds[c]), walk_id, indptr, indices, vis, wid, nxt, prv, T,
                                    stack, P, inq, queue, mark, buf, max_blind,
                                    (points.uv, lab64, int(c), cells, cstart, float(x0), float(y0), float(cw), W, H,
                                     steer, backtrack, int(backtrack_budget * len(members)), blk, ucnt, WB),
                                    np.int64(bool(pin_start) and rank == 0))
        walk_id = int(wid.max()) + 1
        ordc, offc = collect_pieces(members, s, vis, nxt, prv)
        if pin_start and rank == 0 and ordc[0] != s:
            ordc, offc, cut = _begin_at(ordc, offc, s)
            start_cut += cut
        orders.append(ordc)
        piece_offs.append(offc[1:] + n_done)
        n_done += len(ordc)
        prev_end = points.uv[ordc[-1]]
    order = np.concatenate(orders).astype(np.int64)
    pieces = np.concatenate(piece_offs)
    stats = walk_stats(tot[:N_STATS], int(ncomp), len(pieces) - 1, n, time.perf_counter() - t0)
    stats["reversals"] = int(tot[ST_FLIP])
    stats["start_cut"] = start_cut
    return order, pieces, stats


def _begin_at(order: np.ndarray, offs: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray, int]:
    """``order`` (its first piece holding ``s``) rearranged so that the path begins at ``s``.

    ``s`` at the far end of its piece: the piece reversed (the same edges). Inside it: the piece cut at ``s``,
    ``s`` to its end first and the part before it after (one piece more). Returns (order, offsets, pieces added).
    """
    a, b = int(offs[0]), int(offs[1])
    at = int(np.flatnonzero(order[a:b] == s)[0]) + a
    if at == b - 1:
        out = order.copy()
        out[a:b] = order[a:b][::-1]
        return out, offs, 0
    out = np.concatenate([order[at:b], order[a:at], order[b:]])
    return out, np.concatenate([[0, b - at], offs[1:]]).astype(offs.dtype), 1


@numba.njit(cache=True)
def _blocks(xy, x0, y0, cw, W, H):  # pragma: no cover - numba
    """Each point's block of ``BLOCK`` x ``BLOCK`` cells (cells of side ``cw`` mm from ``(x0, y0)``, ``W`` x ``H``
    of them, as :func:`~.points.blue_noise.cell_lists` numbers them), the points per block, and blocks per row."""
    WB = (W + BLOCK - 1) // BLOCK
    HB = (H + BLOCK - 1) // BLOCK
    blk = np.empty(xy.shape[0], np.int64)
    ucnt = np.zeros(WB * HB, np.int64)
    for p in range(xy.shape[0]):
        b = (int((xy[p, 1] - y0) / cw) // BLOCK) * WB + int((xy[p, 0] - x0) / cw) // BLOCK
        blk[p] = b
        ucnt[b] += 1
    return blk, ucnt, WB


@numba.njit(cache=True)
def _components(indptr, indices):  # pragma: no cover - numba
    """Connected components of the symmetric CSR graph: their number, each point's label (components numbered in
    the order of their smallest point, as scipy's ``connected_components`` numbers them), the points by label
    (ascending within each) and each label's first position in that order (ncomp + 1 offsets). Written by hand:
    scipy's ``connected_components`` and the sort after it took 0.25 s at 10^6 points; this is a union-find over
    the edges in the points' order (neighbours are near in number, so it stays in cache)."""
    n = indptr.shape[0] - 1
    parent = np.arange(n)
    for v in range(n):
        for e in range(indptr[v], indptr[v + 1]):
            w = indices[e]
            if w <= v:
                continue
            a = v
            while parent[a] != a:  # path halving
                parent[a] = parent[parent[a]]
                a = parent[a]
            b = w
            while parent[b] != b:
                parent[b] = parent[parent[b]]
                b = parent[b]
            if a < b:  # the root is the component's smallest point
                parent[b] = a
            elif b < a:
                parent[a] = b
    lab = np.empty(n, np.int64)
    ncomp = 0
    for v in range(n):
        a = v
        while parent[a] != a:
            a = parent[a]
        if a == v:
            lab[v] = ncomp
            ncomp += 1
        else:
            lab[v] = lab[a]
    bounds = np.zeros(ncomp + 1, np.int64)
    for v in range(n):
        bounds[lab[v] + 1] += 1
    for c in range(ncomp):
        bounds[c + 1] += bounds[c]
    fill = bounds[:-1].copy()
    order = np.empty(n, np.int64)
    for v in range(n):
        order[fill[lab[v]]] = v
        fill[lab[v]] += 1
    return ncomp, lab, order, bounds
