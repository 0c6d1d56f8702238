"""The pseudo-random walk (paper section 3), compiled with numba.

From the start, step to a random unvisited neighbour; at a dead end, the
paper's turnaround (a Posa rotation: break after a path point next to the head,
reverse the tail, join); when no turnaround frees the head, steered rotations,
then the paper's step 7 (give back the last points) and our escape. The path
is an implicit treap (``_treap``) while walking, so a turnaround at any
distance costs O(log n). The walk and its turnaround rules are the project's
own method, so they are written here by hand. The grid, the no-crossing rule
and the structures passed in are in ``_steps``.
"""

from __future__ import annotations

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

from ._steps import (
    ST_BLIND,
    ST_DEL,
    ST_ESCAPE,
    ST_REV,
    ST_ROT,
    ST_STEPS,
    ST_STUCK,
    ST_TENTHS,
    can_use,
    dir_between,
    has_move,
    mark_step,
    nearest_unvisited,
)
from ._treap import TV, tgive_back, tinorder, tmerge, tnew, trank, tsplit, tsucc


@numba.njit(cache=True)
def walk(start, walk_id, comp, backtrack, budget, nodes_n, g, o, w, stats):  # pragma: no cover - numba
    """Random self-avoiding walk from ``start`` with the paper's turnaround at any distance.

    Parameters
    ----------
    start : int
        Dense id of the first node (unvisited).
    walk_id : int
        Number written to ``w.wid`` of every node this walk places.
    comp : int
        Component label of ``start`` (the steering search stays in it).
    backtrack, budget : int
        Points given back at a time when stuck, and in total (0, 0: never).
    nodes_n : int
        Size of the component (scales the escapes and the per-tenth counters).
    g : WalkGrid
    o : WalkOptions
    w : WalkWork
        ``vis``, ``diag``, ``wid``, ``T`` are updated; the path is left in ``w.P``.
    stats : (N_STATS,) int64
        Counters, incremented.

    Returns
    -------
    int
        Length k of the walk: its nodes in order are ``w.P[:k]``.
    """
    adj, W, off, lab = g.adj, g.W, g.off, g.lab
    window, max_blind, shortest, steer = o.window, o.max_blind, o.shortest, o.steer
    vis, diag, wid, P, T, stack = w.vis, w.diag, w.wid, w.P, w.T, w.stack
    tnew(start, T)
    root = start
    head = start
    wid[start] = walk_id
    vis[start] = 1
    k = np.int64(1)  # int64 from the start: a literal 1 compiled tgive_back a second time
    deleted = 0
    blind = 0
    tgt = -1
    blind_limit = max_blind
    radius = steer
    escapes = 0
    max_escapes = 16 + nodes_n // 100000
    cand = np.empty(8, dtype=np.int64)
    cand_t = np.empty(8, dtype=np.int64)
    cand_s = np.empty(8, dtype=np.int64)
    anyc = np.empty(8, dtype=np.int64)
    any_t = np.empty(8, dtype=np.int64)
    any_s = np.empty(8, dtype=np.int64)
    while True:
        h = head
        m = adj[h]
        nav = 0
        for d in range(8):
            if (m >> d) & 1:
                q = h + off[d]
                if vis[q] == 0 and can_use(h, d, W, diag):
                    cand[nav] = d
                    nav += 1
        if nav > 0:  # paper step 2: a random unvisited neighbour
            d = cand[np.random.randint(nav)]
            q = h + off[d]
            mark_step(h, d, W, diag, True)
            tnew(q, T)
            root = tmerge(root, q, T, stack)
            head = q
            wid[q] = walk_id
            vis[q] = 1
            k += 1
            blind = 0
            tgt = -1
            blind_limit = max_blind
            radius = steer
            stats[ST_STEPS] += 1
            continue
        # dead end -> turnaround (paper steps 4-6, a Posa rotation): a path point
        # q next to the head; break after it, reverse the tail, join head to q.
        # Prefer the q whose successor (the new head) can move on at once.
        nrc = 0
        nany = 0
        if blind == 0:
            stats[ST_STUCK] += 1
        for d in range(8):
            if (m >> d) & 1:
                q = h + off[d]
                if vis[q] == 1 and wid[q] == walk_id and can_use(h, d, W, diag):
                    t = trank(q, T, stack)
                    if t <= k - 3 and t >= k - 1 - window:
                        sq = tsucc(q, T)
                        if has_move(sq, adj, vis, diag, off, W):
                            cand[nrc] = d
                            cand_t[nrc] = t
                            cand_s[nrc] = sq
                            nrc += 1
                        else:
                            anyc[nany] = d
                            any_t[nany] = t
                            any_s[nany] = sq
                            nany += 1
        r = -1
        if nrc > 0:
            if shortest:
                best = -1
                for i in range(nrc):
                    if cand_t[i] > best:
                        best = cand_t[i]
                        r = i
            else:
                r = np.random.randint(nrc)
            d, t, sq = cand[r], cand_t[r], cand_s[r]
        elif nany > 0 and blind < blind_limit:
            # no rotation frees the head at once: rotate toward the nearest
            # unvisited point (each rotation moves the head by <= 2 cells) and
            # look again; at random when none is near.
            blind += 1
            stats[ST_BLIND] += 1
            if tgt < 0 or vis[tgt] == 1:
                tgt = nearest_unvisited(h, adj, vis, lab, comp, W, radius)
            if tgt >= 0 and np.random.random() < 0.75:
                tx, ty = tgt % W, tgt // W
                bestd = 1 << 62
                nb = 0
                for i in range(nany):
                    dx = any_s[i] % W - tx
                    dy = any_s[i] // W - ty
                    dd = dx * dx + dy * dy
                    if dd < bestd:
                        bestd = dd
                        nb = 1
                        r = i
                    elif dd == bestd:
                        nb += 1
                        if np.random.randint(nb) == 0:
                            r = i
            else:
                r = np.random.randint(nany)
            d, t, sq = anyc[r], any_t[r], any_s[r]
        if r >= 0:
            q = h + off[d]
            stats[ST_REV] += k - 1 - t
            stats[ST_TENTHS + (10 * k) // (nodes_n + 1)] += 1
            mark_step(q, dir_between(q, sq, W), W, diag, False)
            mark_step(h, d, W, diag, True)
            A, B = tsplit(root, t + 1, T, stack)
            T[B, TV] ^= 1
            root = tmerge(A, B, T, stack)
            head = sq
            stats[ST_ROT] += 1
            continue
        # paper step 7: give back the last points and walk on (budgeted)
        if backtrack > 0 and deleted + backtrack <= budget and k > backtrack + 1:
            root, c = tgive_back(root, k, backtrack, T, stack, P, vis, wid)
            for i in range(1, c):
                mark_step(P[i - 1], dir_between(P[i - 1], P[i], W), W, diag, False)
            head = P[0]
            k -= backtrack
            deleted += backtrack
            stats[ST_DEL] += backtrack
            continue
        # escape (ours): walk the head by steered rotations toward an unvisited
        # point up to 8 x steer cells away, a bounded number of times
        if escapes < max_escapes and blind_limit == max_blind:
            t2 = nearest_unvisited(h, adj, vis, lab, comp, W, 8 * steer)
            if t2 >= 0:
                escapes += 1
                stats[ST_ESCAPE] += 1
                tgt = t2
                radius = 8 * steer
                blind_limit = max_blind + 4 * 8 * steer
                continue
        break
    return tinorder(root, T, P, stack)
