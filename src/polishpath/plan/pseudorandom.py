"""The pseudo-random planner (paper section 3) with a near-linear end-game.

1. Walk: from the start, step to a random unvisited 8-neighbour (the step must
   stay inside the region and must not cross a diagonal already used in its
   grid cell).
2. Dead end: the paper's local turnaround (a Posa rotation). Among the path
   points next to the head, pick one whose successor can move on (the most
   recent such one); break there, reverse the tail, reconnect. The path is a
   treap, so a reversal costs O(log n) whatever its length.
3. No such point: rotate anyway, toward the nearest unvisited point (found by
   a ring search of radius ``steer``; 3 times in 4, else at random), at most
   ``max_blind`` times in a row.
4. Still stuck: the paper's step 7, give back the last ``backtrack`` points
   (at most ``backtrack_budget`` x n in total) and walk on. Budget spent: an
   escape, steered rotations toward an unvisited point up to 8 x ``steer``
   cells away (a bounded number of times); else the walk stops.
5. End-game (ours): every point still unvisited is inserted between two
   consecutive path points that are both its neighbours (or after the end of
   the path), in random order, as soon as one of its neighbours is on the path.
   Each insertion is O(1) on a linked list, so the whole end-game is linear.
6. A point no splice takes gets a 2-opt insertion (``.. a a' .. c c' ..`` ->
   ``.. a u c .. a' c' ..``, the middle reversed on the linked list), or else a
   kick: the short stretch between two of its path neighbours is replaced by a
   detour through it and the stretch's inner points are spliced in elsewhere.
7. Whatever is left is walked as a sub-path and joined to a piece end to end
   or spliced in whole; if no join exists the sub-path stays its own piece and
   is reported (``stats["extra_pieces"]``): never a silent gap.

Grid components that are not connected at all (a neck narrower than the
spacing) are planned one after the other as separate pieces.
"""

from __future__ import annotations

import time

import numpy as np

from ..errors import ParameterError
from ._component import collect_pieces, plan_component
from ._steps import (
    N_STATS,
    ST_APPEND,
    ST_BLIND,
    ST_DEL,
    ST_ESCAPE,
    ST_JOIN,
    ST_KICK,
    ST_PHASE1,
    ST_REV,
    ST_ROT,
    ST_SPLICE,
    ST_STEPS,
    ST_STUCK,
    ST_SUBWALK,
    ST_TENTHS,
    ST_TWOOPT,
    WalkOptions,
    label_components,
    walk_grid,
    walk_work,
)
from .checks import check_count, check_index, check_number, check_seed
from .dwell import DwellGrid, check_grid

#: The options of :func:`pseudorandom_order` that ``plan(..., "pseudorandom", **options)`` passes on.
PSEUDORANDOM_OPTIONS = ("window", "backtrack", "backtrack_budget", "max_blind", "shortest", "steer", "max_kicks")


def pseudorandom_order(
    grid: DwellGrid,
    *,
    seed: int,
    start: int = 0,
    window: int = 2**62,
    backtrack: int = 5,
    backtrack_budget: float = 0.05,
    max_blind: int = 10,
    shortest: bool = True,
    steer: int = 32,
    max_kicks: int = 1000,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """Order of the dwell points along a pseudo-random path.

    Parameters
    ----------
    grid : DwellGrid
        Dwell points and their adjacency.
    seed : int
        Seed of the random generator (0 <= seed < 2**63); same seed, same path.
        Each grid component gets its own numba seed drawn from it.
    start : int
        Dwell-point number where the path starts.
    window : int
        Turn around only at path points at most this many positions back
        (default: any).
    backtrack : int
        Points given back when no turnaround exists (the paper's step 7 uses 5);
        0 disables it.
    backtrack_budget : float
        Total points given back, as a fraction of the component size.
    max_blind : int
        Rotations in a row that do not free the head before giving back points.
    shortest : bool
        Among freeing turnarounds take the most recent path point (True) or a
        random one.
    steer : int
        Radius (grid cells) of the search for the nearest unvisited point that
        blind rotations steer toward.
    max_kicks : int
        End-game reroutes per component (a short stretch between two neighbours
        of a leftover point is replaced by a detour through it, and its inner
        points are spliced in again elsewhere).

    Returns
    -------
    order : (N,) int64
        Dwell-point numbers in path order (each at most once).
    pieces : (K+1,) int64
        Offsets of the continuous pieces in ``order``.
    stats : dict
        ``components``, ``extra_pieces``, ``steps``, ``turnarounds``,
        ``blind`` (turnarounds that did not free the head), ``stuck`` (dead
        ends), ``deleted``, ``escapes``, ``kicks``, ``spliced``, ``appended``, ``two_opt``,
        ``subwalks``, ``joins``, ``reversed_points`` (total length of the
        reversed tails), ``walk_fraction`` (share of points placed by the walk
        itself), ``turnarounds_by_tenth``, ``seconds``.

    Raises
    ------
    ParameterError
        Not a DwellGrid; seed or start out of range; an option that is not a
        whole number >= 0 (``backtrack_budget``: a number in [0, 1];
        ``shortest``: a bool).
    """
    check_grid(grid)
    seed = check_seed(seed)
    start = check_index(start, "The start", grid.n)
    window = check_count(window, "window")
    backtrack = check_count(backtrack, "backtrack")
    backtrack_budget = check_number(backtrack_budget, "backtrack_budget", low=0.0)
    if backtrack_budget > 1:
        raise ParameterError(f"backtrack_budget is a fraction of the points, at most 1, got {backtrack_budget!r}.",
                             "Pass a number in [0, 1] (default 0.05).")
    max_blind = check_count(max_blind, "max_blind")
    steer = check_count(steer, "steer", high=2**20)
    max_kicks = check_count(max_kicks, "max_kicks")
    if not isinstance(shortest, (bool, np.bool_)):
        raise ParameterError(f"shortest must be True or False, got {shortest!r}.", "Pass a bool.")
    t0 = time.perf_counter()
    H, W = (int(x) for x in grid.dense_shape)
    nodes = np.ascontiguousarray(grid.dense_id, dtype=np.int64)
    adj = np.zeros(H * W, dtype=np.uint8)
    adj[nodes] = grid.dirmask
    lab_dense, ncomp = label_components(adj, nodes, W)
    lab = lab_dense[nodes]
    # components: the start's first, the others by distance from the start
    sort = np.argsort(lab, kind="stable")
    bounds = np.searchsorted(lab[sort], np.arange(ncomp + 1))
    d_start = np.hypot(*(grid.uv - grid.uv[start]).T)
    comp_dist = np.minimum.reduceat(d_start[sort], bounds[:-1]) if ncomp else np.zeros(0)
    comp_order = np.argsort(comp_dist, kind="stable")
    seeds = np.random.SeedSequence(seed).generate_state(max(ncomp, 1), dtype=np.uint32)

    g = walk_grid(adj, W, lab_dense)
    work = walk_work(H * W, int(np.diff(bounds).max()) if ncomp else 0)
    options = WalkOptions(window, backtrack, 0, max_blind, bool(shortest), steer, max_kicks)

    tot = np.zeros(N_STATS, dtype=np.int64)
    orders, piece_offs = [], [np.zeros(1, dtype=np.int64)]
    n_done = 0
    prev_end = grid.uv[start]
    for rank, c in enumerate(comp_order):
        members = sort[bounds[c] : bounds[c + 1]]
        if rank == 0:
            s_local = start
        else:
            s_local = members[np.argmin(np.hypot(*(grid.uv[members] - prev_end).T))]
        cn = nodes[members]
        s_dense = int(nodes[s_local])
        opts = options._replace(budget=int(backtrack_budget * len(members)))
        tot += plan_component(cn, s_dense, int(seeds[c]), int(c), 1 + n_done, g, opts, work)
        ordc, offc = collect_pieces(cn, s_dense, work.vis, work.nxt, work.prv)
        orders.append(ordc)
        piece_offs.append(offc[1:] + n_done)
        n_done += len(ordc)
        prev_end = grid.uv[np.searchsorted(nodes, ordc[-1])]
    order_dense = np.concatenate(orders) if orders else np.zeros(0, np.int64)
    order = np.searchsorted(nodes, order_dense)
    pieces = np.concatenate(piece_offs)
    stats = walk_stats(tot, int(ncomp), len(pieces) - 1, grid.n, time.perf_counter() - t0)
    return order, pieces, stats


def walk_stats(tot: np.ndarray, ncomp: int, npieces: int, n: int, seconds: float) -> dict:
    """The walk's figures from its counters ``tot`` (N_STATS,) (the keys of :func:`pseudorandom_order`'s stats).

    Shared by the grid walk and the walk over a set without a lattice
    (:func:`polishpath.plan.bluewalk.graph_walk_order`).
    """
    return {
        "components": int(ncomp),
        "extra_pieces": int(npieces - ncomp),
        "steps": int(tot[ST_STEPS]),
        "turnarounds": int(tot[ST_ROT]),
        "deleted": int(tot[ST_DEL]),
        "spliced": int(tot[ST_SPLICE]),
        "appended": int(tot[ST_APPEND]),
        "subwalks": int(tot[ST_SUBWALK]),
        "joins": int(tot[ST_JOIN]),
        "reversed_points": int(tot[ST_REV]),
        "blind": int(tot[ST_BLIND]),
        "stuck": int(tot[ST_STUCK]),
        "two_opt": int(tot[ST_TWOOPT]),
        "kicks": int(tot[ST_KICK]),
        "escapes": int(tot[ST_ESCAPE]),
        "turnarounds_by_tenth": tot[ST_TENTHS:N_STATS].tolist(),
        "walk_fraction": float(tot[ST_PHASE1]) / max(n, 1),
        "seconds": seconds,
    }
