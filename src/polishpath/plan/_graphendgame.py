"""The end-game of the pseudo-random walk over a planar neighbour graph (numba): every point the walk left goes in.

After the walk (``_graphwalk.graph_walk``) the path is a doubly linked list
(``nxt`` / ``prv``), so points are inserted in O(1): splices, 2-opt insertions,
or-opt moves, kicks, then sub-walks joined to a piece (see ``_graphwalk``'s
module docstring, steps 4-5). Every new step is a graph edge, so the path
never crosses itself and never leaves the region. The project's own method, so
written here by hand.
"""

from __future__ import annotations

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

from ._endgame import _reverse_piece
from ._graphwalk import N_GRAPH_STATS, _adjacent, _has_free, _has_neighbour, graph_walk
from ._steps import (
    ST_APPEND,
    ST_JOIN,
    ST_KICK,
    ST_PHASE1,
    ST_SPLICE,
    ST_SUBWALK,
    ST_TWOOPT,
    link_path,
)

@numba.njit(cache=True)
def _put_between(a, u, b, nx, pv):
    """Link ``u`` between ``a`` and ``b`` (``b`` after ``a`` along ``nx``); with ``(prv, nxt)``, the other way."""
    nx[a] = u
    pv[u] = a
    nx[u] = b
    pv[b] = u


#: Longest stretch (inner points) a kick takes out of the path to make room for a leftover point.
KICK_MAX = 6
#: Largest block of path points an or-opt move carries beside another neighbour of a leftover point.
MOVE_MAX = 4


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
                _put_between(a, u, b, nxt, prv)
            else:
                _put_between(a, u, b, prv, nxt)
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
                    _put_between(a, u, c, nxt, prv)
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
                    _put_between(a, u, c, nxt, prv)
                else:
                    _put_between(a, u, c, prv, nxt)
                vis[u] = 1
                for i in range(length):
                    vis[out[i]] = 0
                    nxt[out[i]] = -1
                    prv[out[i]] = -1
                return length
    return 0


@numba.njit(cache=True)
def _splice_loop(queue, qh, qt, inq, indptr, indices, vis, nxt, prv, stats, max_kicks, blk, ucnt):
    """Splice queued points until the queue is empty (a placed point queues its unvisited neighbours).

    A kick gives points back (``vis`` 0): their blocks' counts ``ucnt[blk[.]]`` of unvisited points (the steering
    search's, :func:`._graphwalk.nearest_unvisited_pt`) go up, so that the counts never fall short.
    """
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
            elif _try_move_beside(u, indptr, indices, vis, nxt, prv):
                res = 3
            elif stats[ST_KICK] < max_kicks:
                m = _try_kick(u, indptr, indices, vis, nxt, prv, kicked)
                if m == 0:
                    continue
                stats[ST_KICK] += 1
                for i in range(m):
                    z = kicked[i]
                    ucnt[blk[z]] += 1
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
def _try_move_beside(u, indptr, indices, vis, nxt, prv):
    """Or-opt for unvisited ``u``: move a path neighbour ``a`` of ``u`` beside another, ``c``, with ``u`` between.

    ``.. a- a a+ .. c- c ..`` -> ``.. a- a+ .. c- a u c ..`` (or ``.. c u a c+ ..``): needs ``(a-, a+)``
    an edge (or ``a`` a piece end) and ``(c-, a)`` (or ``(a, c+)``) an edge (or ``c`` a piece end). When
    no such move exists, ``a`` moves with up to ``MOVE_MAX - 1`` of its path neighbours on one side, as one
    block ``a .. z`` (``.. c- z .. a u c ..``): the block's two outer path neighbours must share an edge,
    and ``z`` must be next to ``c``'s other path neighbour. The point the walk leaves inside a ring of path
    points it passes crosswise (no splice, no 2-opt) usually has such a move. Every new step is a graph
    edge. Returns success.
    """
    for L in range(1, MOVE_MAX + 1):
        for way in range(2):
            nx, pv = (nxt, prv) if way == 0 else (prv, nxt)
            if _move_block(u, L, indptr, indices, vis, nx, pv):
                vis[u] = 1
                return True
            if L == 1:
                break  # a block of one point is the same either way
    return False


@numba.njit(cache=True)
def _move_block(u, L, indptr, indices, vis, nx, pv):
    """The move of :func:`_try_move_beside` for blocks of ``L`` points ``a = b_0 .. b_{L-1} = z`` along ``nx``."""
    for e in range(indptr[u], indptr[u + 1]):
        a = indices[e]
        if vis[a] == 0:
            continue
        z = a
        ok = True
        for _ in range(L - 1):
            z = nx[z]
            if z < 0 or z == u:
                ok = False
                break
        if not ok:
            continue
        am = pv[a]
        zp = nx[z]
        if am < 0 and zp < 0:
            continue  # the block is a whole piece
        if am >= 0 and zp >= 0 and not _adjacent(am, zp, indptr, indices):
            continue
        for f in range(indptr[u], indptr[u + 1]):
            c = indices[f]
            if c == a or vis[c] == 0 or c == am or c == zp or _in_block(c, a, L, nx):
                continue
            for side in range(2):
                cn = pv[c] if side == 0 else nx[c]  # the block goes between cn and c
                if cn >= 0 and (cn == am or cn == zp or _in_block(cn, a, L, nx)
                                or not _adjacent(cn, z, indptr, indices)):
                    continue
                # take the block out
                if am >= 0:
                    nx[am] = zp
                if zp >= 0:
                    pv[zp] = am
                if side == 0:  # cn z .. a u c: the block reversed
                    p = a
                    for _ in range(L):
                        q = nx[p]
                        nx[p] = pv[p]
                        pv[p] = q
                        p = q
                    if cn >= 0:
                        nx[cn] = z
                    pv[z] = cn
                    _put_between(a, u, c, nx, pv)
                else:  # c u a .. z cn
                    _put_between(c, u, a, nx, pv)
                    nx[z] = cn
                    if cn >= 0:
                        pv[cn] = z
                return True
    return False


@numba.njit(cache=True)
def _in_block(x, a, L, nx):
    """Whether ``x`` is one of the ``L`` points from ``a`` on along ``nx``."""
    p = a
    for _ in range(L):
        if p == x:
            return True
        p = nx[p]
        if p < 0:
            break
    return False


@numba.njit(cache=True)
def plan_graph_component(nodes, start, seed, walk_id, indptr, indices, vis, wid, nxt, prv, T, stack, P, inq, queue,
                         mark, buf, max_blind, sp, pin):  # pragma: no cover - numba
    """Plan one connected component of the graph; leaves its pieces linked in ``nxt`` / ``prv``.

    ``pin``: the walk keeps ``start`` its first point (:func:`._graphwalk.graph_walk`); the sub-walks of what is
    left do not need to.

    Returns
    -------
    stats : (N_GRAPH_STATS,) int64
        Counters (the ``ST_*`` slots of ``_steps``, then ``_graphwalk.ST_FLIP``).
    """
    np.random.seed(seed)
    stats = np.zeros(N_GRAPH_STATS, dtype=np.int64)
    blk = sp[13]
    ucnt = sp[14]
    n = nodes.shape[0]
    max_kicks = 1000 + n // 20
    k = graph_walk(start, walk_id, n, indptr, indices, vis, wid, T, stack, P, max_blind, stats, sp, pin)
    stats[ST_PHASE1] = k
    link_path(P, k, nxt, prv)
    placed = k
    if placed == n:
        return stats
    cap = queue.shape[0]
    qh, qt = 0, 0
    for i in range(n):
        u = nodes[i]
        if vis[u] == 0 and _has_neighbour(u, indptr, indices, vis, 1) and inq[u] == 0:
            inq[u] = 1
            queue[qt % cap] = u
            qt += 1
    qh, qt = _splice_loop(queue, qh, qt, inq, indptr, indices, vis, nxt, prv, stats, max_kicks, blk, ucnt)
    # again over what is left while that places points (a 2-opt move changes the path near other leftovers)
    while True:
        before = qt
        for i in range(n):
            u = nodes[i]
            if vis[u] == 0 and inq[u] == 0 and _has_neighbour(u, indptr, indices, vis, 1):
                inq[u] = 1
                queue[qt % cap] = u
                qt += 1
        if qt == before:
            break
        placed0 = stats[ST_SPLICE] + stats[ST_APPEND] + stats[ST_TWOOPT] + stats[ST_KICK]
        qh, qt = _splice_loop(queue, qh, qt, inq, indptr, indices, vis, nxt, prv, stats, max_kicks, blk, ucnt)
        if stats[ST_SPLICE] + stats[ST_APPEND] + stats[ST_TWOOPT] + stats[ST_KICK] == placed0:
            break
    # what is left: or-opt moves (a neighbour moved beside another with the point between), while that places
    # points
    progress = True
    while progress:
        progress = False
        for i in range(n):
            u = nodes[i]
            if vis[u] == 0 and _try_move_beside(u, indptr, indices, vis, nxt, prv):
                progress = True
                stats[ST_TWOOPT] += 1
                for e in range(indptr[u], indptr[u + 1]):
                    q = indices[e]
                    if vis[q] == 0 and inq[q] == 0:
                        inq[q] = 1
                        queue[qt % cap] = q
                        qt += 1
                qh, qt = _splice_loop(queue, qh, qt, inq, indptr, indices, vis, nxt, prv, stats, np.int64(0), blk, ucnt)
    wk = walk_id + 1
    for i in range(n):
        u = nodes[i]
        if vis[u] == 1:
            continue
        # a sub-walk from the leftover point: a piece of its own, then joined if it can be
        m = graph_walk(u, wk, n, indptr, indices, vis, wid, T, stack, P, max_blind, stats, sp, np.int64(0))
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
        qh, qt = _splice_loop(queue, qh, qt, inq, indptr, indices, vis, nxt, prv, stats, max_kicks, blk, ucnt)
        s0 = P[0]
        while prv[s0] >= 0:
            s0 = prv[s0]
        if _try_join(s0, indptr, indices, vis, nxt, prv, mark, buf):
            stats[ST_JOIN] += 1
    return stats
