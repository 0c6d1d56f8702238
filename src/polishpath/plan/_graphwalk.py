"""The pseudo-random walk over a planar neighbour graph (a dwell-point set without a lattice), numba.

The grid walk (``_walk``, ``_endgame``) steps between 8-neighbours of a square
grid and must keep two diagonals of one cell from crossing. Here the dwell
points are joined by the edges of a planar graph (the Delaunay triangulation of
the points, long edges and edges that leave the region dropped:
:mod:`polishpath.plan.points.blue_noise`), so two of its edges never cross and
**any** path along its edges cannot cross itself: the no-crossing rule is the
graph's, not the walk's.

1. Walk: from the start, step to a random unvisited neighbour (but to one that
   would be left with no other unvisited neighbour, when there is one: else it
   is stranded inside the path). A leaf of the graph (a point of one neighbour:
   a path can only end there) is stepped into only to become the path's first
   point (the path is reversed at once, the walk goes on from its other end) or
   its last; otherwise it waits, and the steering below looks past it.
2. Dead end: the paper's turnaround (a Posa rotation): among the path points
   next to the head, take the most recent one whose successor can move on;
   break after it, reverse the tail, join it to the head. The path is an
   implicit treap (``_treap``), so a reversal costs O(log n).
3. No freeing turnaround: when the path's other end can move on, reverse the
   whole path (O(1): the root's flag) and walk on from there; else rotate toward the nearest unvisited point (a cell
   search of radius ``steer``; 3 times in 4, else at random), at most
   ``max_blind`` times in a row; then the paper's step 7 (give back the last
   ``backtrack`` points, within a budget), then an escape (steered rotations
   toward a point up to 8 x ``steer`` cells away, up to 16 + n / 100 times);
   then the walk ends.
4. End-game: every point still unvisited is spliced between two consecutive
   path points that are both its neighbours, or after / before a piece end
   (O(1) each on a doubly linked list); else a 2-opt insertion
   (``.. a a' .. c c' ..`` -> ``.. a u c .. a' c' ..``, ``(a', c')`` an edge,
   the middle reversed); else an or-opt move (a path neighbour ``a`` of the
   point, taken out where its two path neighbours are joined by an edge, goes
   beside another neighbour ``c`` with the point between: ``.. a u c ..``; this
   places the points a 2-opt cannot: one ringed by path points that the path
   passes crosswise, or a rim point with two neighbours); else a kick (a stretch
   ``a x .. c`` of up to ``KICK_MAX`` inner points between two of its neighbours
   becomes ``a u c``, and the inner points are placed again).
5. What is left is walked as a sub-path from a leftover point and joined to a
   piece end to end or spliced in whole; a sub-path that nothing takes stays a
   piece of its own (a tool lift), counted as ``extra_pieces``: never a gap.

Every new step is a graph edge, so the finished path never crosses itself and
never leaves the region. The walk (here) and its end-game (steps 4-5,
``_graphendgame``) are the project's own method, so they are written by hand.
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
)
from ._steps import N_STATS as _N_GRID_STATS
from ._treap import TV, tgive_back, tinorder, tmerge, tnew, trank, tsplit, tsucc

#: The graph walk's own counter after the grid walk's (``_steps``) slots: whole-path reversals.
ST_FLIP = _N_GRID_STATS
#: Length of the graph walk's counters vector.
N_GRAPH_STATS = _N_GRID_STATS + 1


@numba.njit(cache=True)
def _has_neighbour(p, indptr, indices, vis, value):
    """Whether node ``p`` has a neighbour with ``vis`` equal to ``value`` (0: unvisited, 1: on a path)."""
    for e in range(indptr[p], indptr[p + 1]):
        if vis[indices[e]] == value:
            return True
    return False


@numba.njit(cache=True)
def _has_free(p, indptr, indices, vis):
    """Whether node ``p`` has an unvisited neighbour."""
    return _has_neighbour(p, indptr, indices, vis, 0)


@numba.njit(cache=True)
def _has_free_except(p, h, indptr, indices, vis):
    """Whether node ``p`` has an unvisited neighbour other than ``h``."""
    for e in range(indptr[p], indptr[p + 1]):
        q = indices[e]
        if vis[q] == 0 and q != h:
            return True
    return False


@numba.njit(cache=True)
def _adjacent(p, q, indptr, indices):
    """Whether ``p`` and ``q`` are joined by an edge."""
    for e in range(indptr[p], indptr[p + 1]):
        if indices[e] == q:
            return True
    return False


#: Side of the steering search's blocks, in cells: the search skips a block that holds no unvisited point.
BLOCK = 8


@numba.njit(cache=True)
def _scan_run(cx, cy, dx, dy, m, xy, h, vis, lab, comp, cells, cstart, W, H, indptr, ucnt, WB, best, bestd, leaf,
              leafd):
    """The cells ``(cx + i dx, cy + i dy)``, ``i < m``, of the steering search (inside the grid), skipping the
    blocks (``BLOCK`` x ``BLOCK`` cells) whose count ``ucnt`` of unvisited points is 0; returns the nearest
    non-leaf and the nearest leaf so far, with their squared distances."""
    if dx > 0:  # a row: the part of it inside the grid
        if cy < 0 or cy >= H:
            return best, bestd, leaf, leafd
        i = max(0, -cx)
        m = min(m, W - cx)
    else:  # a column
        if cx < 0 or cx >= W:
            return best, bestd, leaf, leafd
        i = max(0, -cy)
        m = min(m, H - cy)
    while i < m:
        x = cx + i * dx
        y = cy + i * dy
        if ucnt[(y // BLOCK) * WB + x // BLOCK] == 0:
            # jump to the first cell of the run past this block
            if dx > 0:
                i += BLOCK - x % BLOCK
            else:
                i += BLOCK - y % BLOCK
            continue
        c = y * W + x
        for t in range(cstart[c], cstart[c + 1]):
            q = cells[t]
            if vis[q] == 0 and lab[q] == comp:
                ex = xy[q, 0] - xy[h, 0]
                ey = xy[q, 1] - xy[h, 1]
                d = ex * ex + ey * ey
                if indptr[q + 1] - indptr[q] == 1:
                    if d < leafd:
                        leafd = d
                        leaf = q
                elif d < bestd:
                    bestd = d
                    best = q
        i += 1
    return best, bestd, leaf, leafd


@numba.njit(cache=True)
def nearest_unvisited_pt(h, xy, vis, lab, comp, cells, cstart, x0, y0, cw, W, H, rmax, indptr, ucnt, WB):
    """Nearest unvisited point of component ``comp`` in the cell rings around point ``h`` (up to ``rmax`` rings), or -1.

    ``cells`` / ``cstart`` list the points of each cell of side ``cw`` mm (cell ``(cx, cy)`` is
    ``cy * W + cx``, corner ``(x0, y0)``); the first ring that holds one decides (then the nearer of
    that ring and the next, by distance). A leaf of the graph (one neighbour, ``indptr``: a path can only
    end there) is the answer only when no other unvisited point is within reach. ``ucnt`` counts at least the
    unvisited points of each block of ``BLOCK`` x ``BLOCK`` cells (``WB`` blocks a row): a block counted 0 is
    skipped (most of the area around a stuck head is visited already).
    """
    hx = int((xy[h, 0] - x0) / cw)
    hy = int((xy[h, 1] - y0) / cw)
    best = -1
    bestd = 1e300
    leaf = -1  # the nearest leaf, the answer when no other point is within reach
    leafd = 1e300
    found_ring = -1
    for r in range(0, rmax + 1):
        if found_ring >= 0 and r > found_ring + 1:
            break
        if r == 0:
            best, bestd, leaf, leafd = _scan_run(hx, hy, 1, 0, 1, xy, h, vis, lab, comp, cells, cstart, W, H, indptr,
                                                 ucnt, WB, best, bestd, leaf, leafd)
        else:
            # the ring's rows (top and bottom, whole) and columns (left and right, between the rows)
            best, bestd, leaf, leafd = _scan_run(hx - r, hy - r, 1, 0, 2 * r + 1, xy, h, vis, lab, comp, cells,
                                                 cstart, W, H, indptr, ucnt, WB, best, bestd, leaf, leafd)
            best, bestd, leaf, leafd = _scan_run(hx - r, hy + r, 1, 0, 2 * r + 1, xy, h, vis, lab, comp, cells,
                                                 cstart, W, H, indptr, ucnt, WB, best, bestd, leaf, leafd)
            best, bestd, leaf, leafd = _scan_run(hx - r, hy - r + 1, 0, 1, 2 * r - 1, xy, h, vis, lab, comp, cells,
                                                 cstart, W, H, indptr, ucnt, WB, best, bestd, leaf, leafd)
            best, bestd, leaf, leafd = _scan_run(hx + r, hy - r + 1, 0, 1, 2 * r - 1, xy, h, vis, lab, comp, cells,
                                                 cstart, W, H, indptr, ucnt, WB, best, bestd, leaf, leafd)
        if best >= 0 and found_ring < 0:
            found_ring = r
    return best if best >= 0 else leaf


@numba.njit(cache=True)
def graph_walk(start, walk_id, n_comp, indptr, indices, vis, wid, T, stack, P, max_blind, stats, sp,
               pin):  # pragma: no cover
    """Random self-avoiding walk along graph edges from ``start`` with Posa turnarounds at any distance.

    Parameters
    ----------
    start : int
        First node (unvisited).
    walk_id : int
        Number written to ``wid`` of every node this walk places (turnarounds stay within one walk).
    n_comp : int
        Size of the component (scales the per-tenth counters).
    indptr, indices : int64 arrays
        The graph in CSR form (symmetric).
    vis : (n,) uint8
        1 when a node is on a path; updated.
    wid : (n,) int32
    T : (n, 6) int32
        Treap table (``_treap``).
    stack : int32 array
        Treap scratch space.
    P : int32 array
        Receives the walk's nodes in order.
    max_blind : int
        Rotations in a row that do not free the head before the walk ends.
    stats : (N_GRAPH_STATS,) int64
        Counters, incremented.
    pin : int64
        1: keep ``start`` the path's first point (a start the user asked for): no whole-path reversal, and a point
        of one neighbour is stepped into only as the last point.
    sp : tuple
        ``(xy, lab, comp, cells, cstart, x0, y0, cw, W, H, steer)``: the points (n, 2) mm, their component
        labels, this component, the cell lists of :func:`nearest_unvisited_pt` and the steering radius
        (cells): blind turnarounds move the head toward the nearest unvisited point 3 times in 4.

    Returns
    -------
    int
        Length k of the walk: its nodes are ``P[:k]``.
    """
    xy, lab, comp, cells, cstart, x0, y0, cw, W, H, steer, backtrack, budget, blk, ucnt, WB = sp
    tgt = -1
    blind_limit = max_blind
    radius = steer
    deleted = 0
    escapes = 0
    max_escapes = 16 + n_comp // 100
    tnew(start, T)
    root = start
    head = start
    first = start  # the path's other end (a turnaround or a give-back keeps it; a reversal swaps the two)
    wid[start] = walk_id
    vis[start] = 1
    ucnt[blk[start]] -= 1
    k = np.int64(1)  # int64 from the start: a literal 1 compiled tgive_back a second time
    blind = 0
    cap = 64
    cand = np.empty(cap, dtype=np.int64)
    cand_t = np.empty(cap, dtype=np.int64)
    cand_s = np.empty(cap, dtype=np.int64)
    anyc = np.empty(cap, dtype=np.int64)
    any_t = np.empty(cap, dtype=np.int64)
    any_s = np.empty(cap, dtype=np.int64)
    while True:
        h = head
        nav = 0
        leaf = -1
        for e in range(indptr[h], indptr[h + 1]):
            q = indices[e]
            if vis[q] == 0:
                if indptr[q + 1] - indptr[q] == 1:
                    leaf = q  # a point with no other neighbour: a path can only end there
                elif nav < cap:
                    cand[nav] = q
                    nav += 1
        if leaf >= 0 and (k + 1 == n_comp or (not pin and first != h and indptr[first + 1] - indptr[first] != 1)):
            # step into the leaf and make it the path's first point (reverse the path): the walk goes on from
            # the other end (turning around there if it cannot move on); or the leaf is the last point. When
            # the first point is a leaf already, the leaf waits: a head that stepped in would be stuck for good
            # (no turnaround from a point of one neighbour); the walk comes back for it at the end
            tnew(leaf, T)
            root = tmerge(root, leaf, T, stack)
            wid[leaf] = walk_id
            vis[leaf] = 1
            ucnt[blk[leaf]] -= 1
            k += 1
            stats[ST_STEPS] += 1
            T[root, TV] ^= 1
            head, first = first, leaf
            stats[ST_FLIP] += 1
            blind = 0
            tgt = -1
            blind_limit = max_blind
            radius = steer
            continue
        if nav > 0:
            # a neighbour that would be left with no unvisited neighbour is taken now (else it is stranded:
            # at the rim, where points have few neighbours, the end-game cannot always place it)
            q = -1
            for i in range(nav):
                if not _has_free_except(cand[i], h, indptr, indices, vis):
                    q = cand[i]
                    break
            if q < 0:
                q = cand[np.random.randint(nav)]
            tnew(q, T)
            root = tmerge(root, q, T, stack)
            head = q
            wid[q] = walk_id
            vis[q] = 1
            ucnt[blk[q]] -= 1
            k += 1
            blind = 0
            tgt = -1
            blind_limit = max_blind
            radius = steer
            stats[ST_STEPS] += 1
            continue
        if blind == 0:
            stats[ST_STUCK] += 1
        nrc = 0
        nany = 0
        for e in range(indptr[h], indptr[h + 1]):
            q = indices[e]
            if vis[q] == 1 and wid[q] == walk_id:
                t = trank(q, T, stack)
                if t <= k - 3 and nrc < cap and nany < cap:
                    sq = tsucc(q, T)
                    if _has_free(sq, indptr, indices, vis):
                        cand[nrc] = q
                        cand_t[nrc] = t
                        cand_s[nrc] = sq
                        nrc += 1
                    else:
                        anyc[nany] = q
                        any_t[nany] = t
                        any_s[nany] = sq
                        nany += 1
        r = -1
        if nrc > 0:
            best = -1
            for i in range(nrc):
                if cand_t[i] > best:
                    best = cand_t[i]
                    r = i
            t, sq = cand_t[r], cand_s[r]
        elif not pin and k > 1 and _has_free(first, indptr, indices, vis):
            # the other end of the path can move on: reverse the whole path (O(1): the root's flag), so that
            # it is the head; the walk goes on there instead of wandering blind or giving points back (a head
            # at a rim point of one neighbour has no turnaround at all)
            T[root, TV] ^= 1
            head, first = first, head
            blind = 0
            tgt = -1
            blind_limit = max_blind
            radius = steer
            stats[ST_FLIP] += 1
            continue
        elif nany > 0 and blind < blind_limit:
            # no turnaround frees the head: rotate toward the nearest unvisited point (3 times in 4,
            # else at random) and look again
            blind += 1
            stats[ST_BLIND] += 1
            if tgt < 0 or vis[tgt] == 1:
                tgt = nearest_unvisited_pt(h, xy, vis, lab, comp, cells, cstart, x0, y0, cw, W, H, radius, indptr, ucnt, WB)
            if tgt >= 0 and np.random.random() < 0.75:
                bestd = 1e300
                for i in range(nany):
                    dx = xy[any_s[i], 0] - xy[tgt, 0]
                    dy = xy[any_s[i], 1] - xy[tgt, 1]
                    dd = dx * dx + dy * dy
                    if dd < bestd:
                        bestd = dd
                        r = i
            else:
                r = np.random.randint(nany)
            t, sq = any_t[r], any_s[r]
        if r < 0:
            # the paper's step 7: give back the last points and walk on (budgeted)
            if backtrack > 0 and deleted + backtrack <= budget and k > backtrack + 1:
                root, c = tgive_back(root, k, backtrack, T, stack, P, vis, wid)
                for i in range(1, c):
                    ucnt[blk[P[i]]] += 1
                head = P[0]  # (the path's first point stays: k > backtrack + 1)
                k -= backtrack
                deleted += backtrack
                stats[ST_DEL] += backtrack
                continue
            # escape: steered rotations toward an unvisited point up to 8 x steer cells away, a bounded
            # number of times; an escape whose rotations ran out (the target too far round the visited area,
            # with no give-back left) is followed by another, as the first was (the walk used to end there:
            # a 10^7 disc stopped at 61 % and left 9 extra pieces)
            if escapes < max_escapes and (blind_limit == max_blind or blind >= blind_limit):
                t2 = nearest_unvisited_pt(h, xy, vis, lab, comp, cells, cstart, x0, y0, cw, W, H, 8 * steer, indptr, ucnt, WB)
                radius = 8 * steer
                if t2 < 0:
                    # nothing left near: the nearest unvisited point anywhere (the blocks make it cheap), as the
                    # next target, rather than ending the walk and leaving that part to the end-game
                    radius = W + H
                    t2 = nearest_unvisited_pt(h, xy, vis, lab, comp, cells, cstart, x0, y0, cw, W, H, radius, indptr, ucnt,
                                              WB)
                if t2 >= 0:
                    escapes += 1
                    stats[ST_ESCAPE] += 1
                    tgt = t2
                    blind_limit = max_blind + 4 * 8 * steer
                    blind = min(blind, max_blind)
                    continue
            break
        stats[ST_REV] += k - 1 - t
        stats[ST_TENTHS + (10 * k) // (n_comp + 1)] += 1
        A, B = tsplit(root, t + 1, T, stack)
        T[B, TV] ^= 1
        root = tmerge(A, B, T, stack)
        head = sq
        stats[ST_ROT] += 1
    return tinorder(root, T, P, stack)
