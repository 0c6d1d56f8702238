"""The pseudo-random walk over a planar neighbour graph (a dwell-point set without a lattice), numba.

The grid walk (``_walk``, ``_endgame``) steps between 8-neighbours of a square
grid and must keep two diagonals of one cell from crossing. Here the dwell
points are joined by the edges of a planar graph (the Delaunay triangulation of
the points, long edges and edges that leave the region dropped:
:mod:`polishpath.plan.points.blue_noise`), so two of its edges never cross and
**any** path along its edges cannot cross itself: the no-crossing rule is the
graph's, not the walk's.

1. Walk: from the start, step to a random unvisited neighbour.
2. Dead end: the paper's turnaround (a Posa rotation): among the path points
   next to the head, take the most recent one whose successor can move on;
   break after it, reverse the tail, join it to the head. The path is an
   implicit treap (``_treap``), so a reversal costs O(log n).
3. No freeing turnaround: rotate toward the nearest unvisited point (a cell
   search of radius ``steer``; 3 times in 4, else at random), at most
   ``max_blind`` times in a row; then the paper's step 7 (give back the last
   ``backtrack`` points, within a budget), then an escape (steered rotations
   toward a point up to 8 x ``steer`` cells away, a bounded number of times);
   then the walk ends.
4. End-game: every point still unvisited is spliced between two consecutive
   path points that are both its neighbours, or after / before a piece end
   (O(1) each on a doubly linked list); else a 2-opt insertion
   (``.. a a' .. c c' ..`` -> ``.. a u c .. a' c' ..``, ``(a', c')`` an edge,
   the middle reversed); else a kick (a stretch ``a x .. c`` of up to
   ``KICK_MAX`` inner points between two of its neighbours becomes ``a u c``, and
   the inner points are placed again).
5. What is left is walked as a sub-path from a leftover point and joined to a
   piece end to end or spliced in whole; a sub-path that nothing takes stays a
   piece of its own (a tool lift), counted as ``extra_pieces``: never a gap.

Every new step is a graph edge, so the finished path never crosses itself and
never leaves the region. The walk and its end-game are the project's own
method, so they are written here by hand.
"""

from __future__ import annotations

import numba
import numpy as np

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
    link_path,
)
from ._endgame import _reverse_piece
from ._treap import TV, tinorder, tmerge, tnew, trank, tsplit, tsucc


#: Longest stretch (inner points) a kick takes out of the path to make room for a leftover point.
KICK_MAX = 6


@numba.njit(cache=True)
def _has_free(p, indptr, indices, vis):
    """Whether node ``p`` has an unvisited neighbour."""
    for e in range(indptr[p], indptr[p + 1]):
        if vis[indices[e]] == 0:
            return True
    return False


@numba.njit(cache=True)
def _adjacent(p, q, indptr, indices):
    """Whether ``p`` and ``q`` are joined by an edge."""
    for e in range(indptr[p], indptr[p + 1]):
        if indices[e] == q:
            return True
    return False


@numba.njit(cache=True)
def nearest_unvisited_pt(h, xy, vis, lab, comp, cells, cstart, x0, y0, cw, W, H, rmax):
    """Nearest unvisited point of component ``comp`` in the cell rings around point ``h`` (up to ``rmax`` rings), or -1.

    ``cells`` / ``cstart`` list the points of each cell of side ``cw`` mm (cell ``(cx, cy)`` is
    ``cy * W + cx``, corner ``(x0, y0)``); the first ring that holds one decides (then the nearer of
    that ring and the next, by distance).
    """
    hx = int((xy[h, 0] - x0) / cw)
    hy = int((xy[h, 1] - y0) / cw)
    best = -1
    bestd = 1e300
    found_ring = -1
    for r in range(0, rmax + 1):
        if found_ring >= 0 and r > found_ring + 1:
            break
        for cy in range(hy - r, hy + r + 1):
            if cy < 0 or cy >= H:
                continue
            step = 1 if (cy == hy - r or cy == hy + r) else 2 * r
            if step == 0:
                step = 1
            cx = hx - r
            while cx <= hx + r:
                if 0 <= cx < W:
                    c = cy * W + cx
                    for t in range(cstart[c], cstart[c + 1]):
                        q = cells[t]
                        if vis[q] == 0 and lab[q] == comp:
                            dx = xy[q, 0] - xy[h, 0]
                            dy = xy[q, 1] - xy[h, 1]
                            d = dx * dx + dy * dy
                            if d < bestd:
                                bestd = d
                                best = q
                                if found_ring < 0:
                                    found_ring = r
                cx += step
    return best


@numba.njit(cache=True)
def graph_walk(start, walk_id, n_comp, indptr, indices, vis, wid, T, stack, P, max_blind, stats, sp):  # pragma: no cover
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
    stats : (N_STATS,) int64
        Counters, incremented.
    sp : tuple
        ``(xy, lab, comp, cells, cstart, x0, y0, cw, W, H, steer)``: the points (n, 2) mm, their component
        labels, this component, the cell lists of :func:`nearest_unvisited_pt` and the steering radius
        (cells): blind turnarounds move the head toward the nearest unvisited point 3 times in 4.

    Returns
    -------
    int
        Length k of the walk: its nodes are ``P[:k]``.
    """
    xy, lab, comp, cells, cstart, x0, y0, cw, W, H, steer, backtrack, budget = sp
    tgt = -1
    blind_limit = max_blind
    radius = steer
    deleted = 0
    escapes = 0
    max_escapes = 16 + n_comp // 10000
    tnew(start, T)
    root = start
    head = start
    wid[start] = walk_id
    vis[start] = 1
    k = 1
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
        for e in range(indptr[h], indptr[h + 1]):
            q = indices[e]
            if vis[q] == 0 and nav < cap:
                cand[nav] = q
                nav += 1
        if nav > 0:
            q = cand[np.random.randint(nav)]
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
        elif nany > 0 and blind < blind_limit:
            # no turnaround frees the head: rotate toward the nearest unvisited point (3 times in 4,
            # else at random) and look again
            blind += 1
            stats[ST_BLIND] += 1
            if tgt < 0 or vis[tgt] == 1:
                tgt = nearest_unvisited_pt(h, xy, vis, lab, comp, cells, cstart, x0, y0, cw, W, H, radius)
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
                A, B = tsplit(root, k - backtrack - 1, T, stack)
                c = tinorder(B, T, P, stack)
                for i in range(1, c):
                    vis[P[i]] = 0
                    wid[P[i]] = 0
                tnew(P[0], T)
                root = tmerge(A, P[0], T, stack)
                head = P[0]
                k -= backtrack
                deleted += backtrack
                stats[ST_DEL] += backtrack
                continue
            # escape: steered rotations toward an unvisited point up to 8 x steer cells away, a bounded
            # number of times
            if escapes < max_escapes and blind_limit == max_blind:
                t2 = nearest_unvisited_pt(h, xy, vis, lab, comp, cells, cstart, x0, y0, cw, W, H, 8 * steer)
                if t2 >= 0:
                    escapes += 1
                    stats[ST_ESCAPE] += 1
                    tgt = t2
                    radius = 8 * steer
                    blind_limit = max_blind + 4 * 8 * steer
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


@numba.njit(cache=True)
def _try_splice(u, indptr, indices, vis, nxt, prv):
    """Put unvisited ``u`` between two consecutive path points next to it, or at a piece end; 0 none, 1 splice, 2 end."""
    for e in range(indptr[u], indptr[u + 1]):
        a = indices[e]
        if vis[a] == 0:
            continue
        for s in range(2):
            b = nxt[a] if s == 0 else prv[a]
            if b < 0 or not _adjacent(u, b, indptr, indices):
                continue
            if s == 0:
                nxt[a] = u
                prv[u] = a
                nxt[u] = b
                prv[b] = u
            else:
                prv[a] = u
                nxt[u] = a
                prv[u] = b
                nxt[b] = u
            vis[u] = 1
            return 1
    for e in range(indptr[u], indptr[u + 1]):
        a = indices[e]
        if vis[a] == 0:
            continue
        if nxt[a] == -1:
            nxt[a] = u
            prv[u] = a
            nxt[u] = -1
            vis[u] = 1
            return 2
        if prv[a] == -1:
            prv[a] = u
            nxt[u] = a
            prv[u] = -1
            vis[u] = 1
            return 2
    return 0


@numba.njit(cache=True)
def _try_two_opt(u, indptr, indices, vis, nxt, prv, maxlen):
    """A 2-opt insertion of unvisited ``u``: ``.. a a' .. c c' ..`` -> ``.. a u c .. a' c' ..`` (the middle reversed).

    ``a`` and ``c`` are neighbours of ``u`` at most ``maxlen`` points apart along one piece and
    ``(a', c')`` is an edge (or ``c`` ends the piece). Every new step is a graph edge. Returns success.
    """
    for e in range(indptr[u], indptr[u + 1]):
        a = indices[e]
        if vis[a] == 0 or nxt[a] < 0:
            continue
        a1 = nxt[a]
        c = a1
        steps = 0
        while c >= 0 and steps < maxlen:
            if c != a1 and _adjacent(u, c, indptr, indices):
                c1 = nxt[c]
                if c1 < 0 or _adjacent(a1, c1, indptr, indices):
                    # reverse a1 .. c in place, then a -> u -> c .. a1 -> c1
                    p = a1
                    while True:
                        q = nxt[p]
                        nxt[p] = prv[p]
                        prv[p] = q
                        if p == c:
                            break
                        p = q
                    nxt[a] = u
                    prv[u] = a
                    nxt[u] = c
                    prv[c] = u
                    nxt[a1] = c1
                    if c1 >= 0:
                        prv[c1] = a1
                    vis[u] = 1
                    return True
            c = nxt[c]
            steps += 1
    return False


@numba.njit(cache=True)
def _try_kick(u, indptr, indices, vis, nxt, prv, out):
    """A kick: a stretch ``a x .. c`` (1 to ``KICK_MAX`` inner points) with ``a``, ``c`` neighbours of
    unvisited ``u`` becomes ``a u c``; the shortest such stretch is taken.

    The stretch's inner points leave the path (``vis`` 0) to be placed again elsewhere; they are written to
    ``out``. Returns how many (0: no kick).
    """
    deg = indptr[u + 1] - indptr[u]
    off = np.random.randint(deg) if deg > 0 else 0
    for length in range(1, KICK_MAX + 1):
        for kk in range(deg):
            a = indices[indptr[u] + (kk + off) % deg]
            if vis[a] == 0:
                continue
            for side in range(2):
                c = a
                for _ in range(length + 1):
                    c = nxt[c] if side == 0 else prv[c]
                    if c < 0 or c == u:
                        break
                if c < 0 or c == u or not _adjacent(u, c, indptr, indices):
                    continue
                x = nxt[a] if side == 0 else prv[a]
                for i in range(length):
                    out[i] = x
                    x = nxt[x] if side == 0 else prv[x]
                if side == 0:
                    nxt[a] = u
                    prv[u] = a
                    nxt[u] = c
                    prv[c] = u
                else:
                    prv[a] = u
                    nxt[u] = a
                    prv[u] = c
                    nxt[c] = u
                vis[u] = 1
                for i in range(length):
                    vis[out[i]] = 0
                    nxt[out[i]] = -1
                    prv[out[i]] = -1
                return length
    return 0


@numba.njit(cache=True)
def _splice_loop(queue, qh, qt, inq, indptr, indices, vis, nxt, prv, stats, max_kicks):
    """Splice queued points until the queue is empty (a placed point queues its unvisited neighbours)."""
    cap = queue.shape[0]
    kicked = np.empty(KICK_MAX, dtype=np.int64)
    while qh < qt:
        u = queue[qh % cap]
        qh += 1
        inq[u] = 0
        if vis[u] == 1:
            continue
        res = _try_splice(u, indptr, indices, vis, nxt, prv)
        if res == 0:
            if (_try_two_opt(u, indptr, indices, vis, nxt, prv, 2000)
                                                           or _try_two_opt(u, indptr, indices, vis, prv, nxt, 2000)):
                res = 3
            elif stats[ST_KICK] < max_kicks:
                m = _try_kick(u, indptr, indices, vis, nxt, prv, kicked)
                if m == 0:
                    continue
                stats[ST_KICK] += 1
                for i in range(m):
                    z = kicked[i]
                    if inq[z] == 0:
                        inq[z] = 1
                        queue[qt % cap] = z
                        qt += 1
                res = 4
            else:
                continue
        if res < 4:
            stats[ST_SPLICE if res == 1 else (ST_APPEND if res == 2 else ST_TWOOPT)] += 1
        for e in range(indptr[u], indptr[u + 1]):
            q = indices[e]
            if vis[q] == 0 and inq[q] == 0:
                inq[q] = 1
                queue[qt % cap] = q
                qt += 1
    return qh, qt


@numba.njit(cache=True)
def _try_join(s0, indptr, indices, vis, nxt, prv, mark, buf):
    """Join the piece headed by ``s0`` to another piece end to end, or splice it whole between two points.

    ``buf`` (n,) is scratch space for the piece's nodes (marked while it is joined).
    """
    m = 0
    p = s0
    while p >= 0:
        mark[p] = 1
        buf[m] = p
        m += 1
        p = nxt[p]
    done = False
    for rev in range(2):
        if rev == 1:
            s0 = _reverse_piece(s0, nxt, prv)
        e0 = buf[m - 1] if rev == 0 else buf[0]
        # our tail -> another piece's head; another piece's tail -> our head
        for e in range(indptr[e0], indptr[e0 + 1]):
            x = indices[e]
            if vis[x] == 1 and mark[x] == 0 and prv[x] == -1:
                nxt[e0] = x
                prv[x] = e0
                done = True
                break
        if done:
            break
        for e in range(indptr[s0], indptr[s0 + 1]):
            x = indices[e]
            if vis[x] == 1 and mark[x] == 0 and nxt[x] == -1:
                nxt[x] = s0
                prv[s0] = x
                done = True
                break
        if done:
            break
        # the whole piece between consecutive points a, b = nxt[a] of another piece
        for e in range(indptr[s0], indptr[s0 + 1]):
            a = indices[e]
            if vis[a] == 0 or mark[a] == 1 or nxt[a] < 0:
                continue
            b = nxt[a]
            if _adjacent(e0, b, indptr, indices):
                nxt[a] = s0
                prv[s0] = a
                nxt[e0] = b
                prv[b] = e0
                done = True
                break
        if done:
            break
    for i in range(m):
        mark[buf[i]] = 0
    return done


@numba.njit(cache=True)
def plan_graph_component(nodes, start, seed, walk_id, indptr, indices, vis, wid, nxt, prv, T, stack, P, inq, queue,
                         mark, buf, max_blind, sp):  # pragma: no cover - numba
    """Plan one connected component of the graph; leaves its pieces linked in ``nxt`` / ``prv``.

    Returns
    -------
    stats : (N_STATS,) int64
        Counters (the ``ST_*`` slots of ``_steps``).
    """
    np.random.seed(seed)
    stats = np.zeros(N_STATS, dtype=np.int64)
    n = nodes.shape[0]
    max_kicks = 1000 + n // 20
    k = graph_walk(start, walk_id, n, indptr, indices, vis, wid, T, stack, P, max_blind, stats, sp)
    stats[ST_PHASE1] = k
    link_path(P, k, nxt, prv)
    placed = k
    if placed == n:
        return stats
    cap = queue.shape[0]
    qh, qt = 0, 0
    for i in range(n):
        u = nodes[i]
        if vis[u] == 0 and _has_free_visited(u, indptr, indices, vis) and inq[u] == 0:
            inq[u] = 1
            queue[qt % cap] = u
            qt += 1
    qh, qt = _splice_loop(queue, qh, qt, inq, indptr, indices, vis, nxt, prv, stats, max_kicks)
    # again over what is left while that places points (a 2-opt move changes the path near other leftovers)
    while True:
        before = qt
        for i in range(n):
            u = nodes[i]
            if vis[u] == 0 and inq[u] == 0 and _has_free_visited(u, indptr, indices, vis):
                inq[u] = 1
                queue[qt % cap] = u
                qt += 1
        if qt == before:
            break
        placed0 = stats[ST_SPLICE] + stats[ST_APPEND] + stats[ST_TWOOPT] + stats[ST_KICK]
        qh, qt = _splice_loop(queue, qh, qt, inq, indptr, indices, vis, nxt, prv, stats, max_kicks)
        if stats[ST_SPLICE] + stats[ST_APPEND] + stats[ST_TWOOPT] + stats[ST_KICK] == placed0:
            break
    wk = walk_id + 1
    for i in range(n):
        u = nodes[i]
        if vis[u] == 1:
            continue
        # a sub-walk from the leftover point: a piece of its own, then joined if it can be
        m = graph_walk(u, wk, n, indptr, indices, vis, wid, T, stack, P, max_blind, stats, sp)
        wk += 1
        stats[ST_SUBWALK] += 1
        link_path(P, m, nxt, prv)
        for j in range(m):
            for e in range(indptr[P[j]], indptr[P[j] + 1]):
                q = indices[e]
                if vis[q] == 0 and inq[q] == 0:
                    inq[q] = 1
                    queue[qt % cap] = q
                    qt += 1
        qh, qt = _splice_loop(queue, qh, qt, inq, indptr, indices, vis, nxt, prv, stats, max_kicks)
        s0 = P[0]
        while prv[s0] >= 0:
            s0 = prv[s0]
        if _try_join(s0, indptr, indices, vis, nxt, prv, mark, buf):
            stats[ST_JOIN] += 1
    return stats


@numba.njit(cache=True)
def _has_free_visited(u, indptr, indices, vis):
    """Whether ``u`` has a neighbour on the path."""
    for e in range(indptr[u], indptr[u + 1]):
        if vis[indices[e]] == 1:
            return True
    return False
