"""One connected component of the dwell grid, planned: the walk, then the end-game (numba).

:func:`plan_component` is what :func:`polishpath.plan.pseudorandom_order`
calls for each component; :func:`collect_pieces` reads the finished path back
from the linked list.
"""

from __future__ import annotations

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

from ._endgame import finish_component
from ._steps import N_STATS, ST_PHASE1, link_path
from ._walk import walk


@numba.njit(cache=True)
def plan_component(nodes, start, seed, comp, walk_id, g, o, w):  # pragma: no cover - numba
    """Plan one connected component; leaves its pieces linked in ``w.nxt`` / ``w.prv``.

    Parameters
    ----------
    nodes : (n,) int64
        Dense ids of the component's nodes, ascending.
    start : int
        Dense id where the path starts.
    seed : int
        Seed of numba's generator for this component (0 <= seed < 2**32).
    comp : int
        Component label (``g.lab`` of its nodes).
    walk_id : int
        First walk number to use (larger than any used before in ``w``).
    g : WalkGrid
    o : WalkOptions
    w : WalkWork

    Returns
    -------
    stats : (N_STATS,) int64
        Counters (see the ``ST_*`` slots of ``_steps``).
    """
    np.random.seed(seed)
    stats = np.zeros(N_STATS, dtype=np.int64)
    n = nodes.shape[0]
    k = walk(start, walk_id, comp, o.backtrack, o.budget, n, g, o, w, stats)
    stats[ST_PHASE1] = k
    link_path(w.P, k, w.nxt, w.prv)
    if k < n:
        finish_component(nodes, start, comp, walk_id + 1, g, o, w, stats)
    return stats


@numba.njit(cache=True)
def collect_pieces(nodes, start, vis, nxt, prv):  # pragma: no cover - numba
    """Path order (dense ids) and piece offsets of one component, the piece holding ``start`` first."""
    n = nodes.shape[0]
    out = np.empty(n, dtype=np.int64)
    offs = np.empty(n + 1, dtype=np.int64)
    k = 0
    npc = 0
    heads = np.empty(n, dtype=np.int64)
    nh = 0
    h0 = start
    while prv[h0] >= 0:
        h0 = prv[h0]
    heads[nh] = h0
    nh += 1
    for p in nodes:
        if vis[p] == 1 and prv[p] == -1 and p != h0:
            heads[nh] = p
            nh += 1
    for h in heads[:nh]:
        offs[npc] = k
        npc += 1
        p = h
        while p >= 0:
            out[k] = p
            k += 1
            p = nxt[p]
    offs[npc] = k
    return out[:k], offs[: npc + 1]
