"""The end-game (ours) of the pseudo-random walk: every point the walk left out goes into the path (numba).

After the walk the path is a doubly linked list (``nxt`` / ``prv``), so that
points are inserted in O(1): a splice between two consecutive path points next
to the point (or after a path end); a 2-opt insertion (``.. a a' .. c c' ..``
-> ``.. a u c .. a' c' ..``, the middle reversed on the list); a kick (a short
stretch rerouted through the point, its inner points spliced in again); last, a
sub-walk from the point, joined to a piece end to end or spliced in whole.
Every move keeps the no-crossing rule of ``_steps``. The project's own method,
so written here by hand.
"""

from __future__ import annotations

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

from ._steps import ST_APPEND, ST_JOIN, ST_KICK, ST_SPLICE, ST_SUBWALK, ST_TWOOPT, can_use, dir_between, link_path, mark_step
from ._walk import walk


@numba.njit(cache=True)
def _push_unvisited_nbrs(p, adj, vis, off, inq, queue, qt, cap):
    """Queue the unvisited, not yet queued neighbours of ``p`` for splicing; returns the new queue tail."""
    m = adj[p]
    for d in range(8):
        if (m >> d) & 1:
            q = p + off[d]
            if vis[q] == 0 and inq[q] == 0:
                inq[q] = 1
                queue[qt % cap] = q
                qt += 1
    return qt


@numba.njit(cache=True)
def _try_splice(u, adj, vis, diag, nxt, prv, off, W, stats):
    """End-game: put unvisited ``u`` between two consecutive path points next to it, or after a path end."""
    m = adj[u]
    ca = np.empty(16, dtype=np.int64)
    cb = np.empty(16, dtype=np.int64)
    nc = 0
    for d in range(8):
        if not (m >> d) & 1:
            continue
        a = u + off[d]
        if vis[a] == 0 or not can_use(u, d, W, diag):
            continue
        if nxt[a] == -1:
            ca[nc] = a
            cb[nc] = -1
            nc += 1
        for s in range(2):
            b = nxt[a] if s == 0 else prv[a]
            if b < 0:
                continue
            e = dir_between(u, b, W)
            # (u,a), (u,b), (a,b) pairwise share an end: they cannot be the two
            # diagonals of one cell, so checking each new step alone is exact.
            if e >= 0 and (m >> e) & 1 and can_use(u, e, W, diag):
                ca[nc] = a
                cb[nc] = b
                nc += 1
    if nc == 0:
        return False
    r = np.random.randint(nc)
    a, b = ca[r], cb[r]
    mark_step(u, dir_between(u, a, W), W, diag, True)
    vis[u] = 1
    if b < 0:
        nxt[a] = u
        prv[u] = a
        nxt[u] = -1
        stats[ST_APPEND] += 1
        return True
    mark_step(a, dir_between(a, b, W), W, diag, False)
    mark_step(u, dir_between(u, b, W), W, diag, True)
    if b == nxt[a]:
        x, y = a, b
    else:
        x, y = b, a
    nxt[x] = u
    prv[u] = x
    nxt[u] = y
    prv[y] = u
    stats[ST_SPLICE] += 1
    return True


@numba.njit(cache=True)
def _splice_loop(adj, vis, diag, nxt, prv, off, W, inq, queue, qh, qt, cap, stats):
    """Splice in the queued points (after each success, queue its unvisited neighbours); returns (head, tail)."""
    while qh < qt:
        u = queue[qh % cap]
        qh += 1
        inq[u] = 0
        if vis[u] == 1:
            continue
        if _try_splice(u, adj, vis, diag, nxt, prv, off, W, stats):
            qt = _push_unvisited_nbrs(u, adj, vis, off, inq, queue, qt, cap)
    return qh, qt


@numba.njit(cache=True)
def _reverse_piece(s0, nxt, prv):
    """Reverse the piece that starts at ``s0`` in the linked list; returns its new start."""
    p = s0
    last = s0
    while p >= 0:
        x = nxt[p]
        nxt[p] = prv[p]
        prv[p] = x
        last = p
        p = x
    return last  # new start


@numba.njit(cache=True)
def _try_join(s0, fixed, adj, vis, diag, nxt, prv, off, W, mark, buf, stats):
    """Join the piece starting at ``s0`` to another piece: end to end, or spliced whole between two consecutive points.

    ``fixed`` (the planned start) never gets a predecessor. ``buf`` is scratch
    space for the piece's members.
    """
    L = 0
    se = s0
    p = s0
    while p >= 0:
        mark[p] = 1
        buf[L] = p
        L += 1
        se = p
        p = nxt[p]
    ok = False
    # end to end. case 0: te -> s0 ; 1: se -> t0 ; 2: te -> se..s0 ; 3: se..s0 -> t0
    for case in range(4):
        if ok:
            break
        e = s0 if (case == 0 or case == 3) else se
        m = adj[e]
        for d in range(8):
            if not (m >> d) & 1:
                continue
            q = e + off[d]
            if vis[q] == 0 or mark[q] == 1 or not can_use(e, d, W, diag):
                continue
            if case == 0 and nxt[q] == -1:
                nxt[q] = s0
                prv[s0] = q
            elif case == 1 and prv[q] == -1 and q != fixed:
                nxt[se] = q
                prv[q] = se
            elif case == 2 and nxt[q] == -1:
                ns = _reverse_piece(s0, nxt, prv)
                nxt[q] = ns
                prv[ns] = q
            elif case == 3 and prv[q] == -1 and q != fixed:
                _reverse_piece(s0, nxt, prv)
                nxt[s0] = q
                prv[q] = s0
            else:
                continue
            mark_step(e, d, W, diag, True)
            ok = True
            break
    if not ok:
        # the whole piece between consecutive a, b: a next to s0 and b next to se
        m = adj[s0]
        for d in range(8):
            if ok:
                break
            if not (m >> d) & 1:
                continue
            a = s0 + off[d]
            if vis[a] == 0 or mark[a] == 1 or not can_use(s0, d, W, diag):
                continue
            for s in range(2):
                b = nxt[a] if s == 0 else prv[a]
                if b < 0:
                    continue
                e = dir_between(se, b, W)
                if e < 0 or not (adj[se] >> e) & 1:
                    continue
                # the two new steps may be the two diagonals of one cell when
                # s0 != se: check the second with the first in place
                mark_step(s0, d, W, diag, True)
                if not can_use(se, e, W, diag):
                    mark_step(s0, d, W, diag, False)
                    continue
                mark_step(a, dir_between(a, b, W), W, diag, False)
                mark_step(se, e, W, diag, True)
                if b == nxt[a]:  # a -> s0 ... se -> b
                    nxt[a] = s0
                    prv[s0] = a
                    nxt[se] = b
                    prv[b] = se
                else:  # b -> a in path order: b -> se ... s0 -> a
                    ns = _reverse_piece(s0, nxt, prv)
                    nxt[b] = ns
                    prv[ns] = b
                    nxt[s0] = a
                    prv[a] = s0
                ok = True
                break
    for i in range(L):
        mark[buf[i]] = 0
    if ok:
        stats[ST_JOIN] += 1
    return ok


@numba.njit(cache=True)
def _rank_main(start, nxt, rk):
    """Order key of every point of the piece from ``start`` (others keep -1)."""
    p = start
    i = 0.0
    while p >= 0:
        rk[p] = i
        i += 1.0
        p = nxt[p]


@numba.njit(cache=True)
def _try_reverse_insert(u, adj, vis, diag, nxt, prv, off, W, rk, stats):
    """End-game for a point that no splice takes: a 2-opt move.

    ``u`` sits next to two path points ``a`` before ``c`` (not consecutive).
    Forward: ``.. a a' .. c c' ..`` becomes ``.. a u c .. a' c' ..`` (needs
    ``a'`` next to ``c'``, or ``c`` at the end). Backward: ``.. a- a .. c- c ..``
    becomes ``.. a- c- .. a u c ..``. The middle is reversed on the linked list
    (cost: its length); order keys ``rk`` of the main piece are kept valid.
    """
    m = adj[u]
    nb = np.empty(8, dtype=np.int64)
    nn = 0
    for d in range(8):
        if (m >> d) & 1:
            a = u + off[d]
            if vis[a] == 1 and rk[a] >= 0 and can_use(u, d, W, diag):
                nb[nn] = a
                nn += 1
    if nn < 2:
        return False
    s0 = np.random.randint(nn)
    for ii in range(nn):
        for jj in range(nn):
            a = nb[(ii + s0) % nn]
            c = nb[(jj + s0) % nn]
            if rk[a] >= rk[c]:
                continue
            for variant in range(2):
                if variant == 0:
                    x, y = nxt[a], nxt[c]
                    if x == c or x < 0:
                        continue
                else:
                    x, y = prv[a], prv[c]
                    if y == a or x < 0 or y < 0:
                        continue
                e = -1
                if y >= 0:
                    e = dir_between(x, y, W)
                    if e < 0 or not (adj[x] >> e) & 1:
                        continue
                # remove the two broken steps, then add the three new ones one by one
                if variant == 0:
                    r1a, r1b, r2a, r2b = a, x, c, y
                else:
                    r1a, r1b, r2a, r2b = x, a, y, c
                mark_step(r1a, dir_between(r1a, r1b, W), W, diag, False)
                if r2b >= 0:
                    mark_step(r2a, dir_between(r2a, r2b, W), W, diag, False)
                da = dir_between(u, a, W)
                dc = dir_between(u, c, W)
                ok = can_use(u, da, W, diag)
                if ok:
                    mark_step(u, da, W, diag, True)
                    ok = can_use(u, dc, W, diag)
                    if ok:
                        mark_step(u, dc, W, diag, True)
                        if e >= 0:
                            ok = can_use(x, e, W, diag)
                            if not ok:
                                mark_step(u, dc, W, diag, False)
                    if not ok:
                        mark_step(u, da, W, diag, False)
                if not ok:
                    mark_step(r1a, dir_between(r1a, r1b, W), W, diag, True)
                    if r2b >= 0:
                        mark_step(r2a, dir_between(r2a, r2b, W), W, diag, True)
                    continue
                if e >= 0:
                    mark_step(x, e, W, diag, True)
                # relink
                if variant == 0:
                    lo, hi = rk[x], rk[c]
                    p = x
                    while True:
                        nx = nxt[p]
                        nxt[p] = prv[p]
                        prv[p] = nx
                        if rk[p] >= 0:
                            rk[p] = lo + hi - rk[p]
                        if p == c:
                            break
                        p = nx
                    nxt[a] = u
                    prv[u] = a
                    nxt[u] = c
                    prv[c] = u
                    nxt[x] = y
                    if y >= 0:
                        prv[y] = x
                    rk[u] = 0.5 * (rk[a] + rk[c])
                else:
                    lo, hi = rk[a], rk[y]
                    p = a
                    while True:
                        nx = nxt[p]
                        nxt[p] = prv[p]
                        prv[p] = nx
                        if rk[p] >= 0:
                            rk[p] = lo + hi - rk[p]
                        if p == y:
                            break
                        p = nx
                    nxt[x] = y
                    prv[y] = x
                    nxt[a] = u
                    prv[u] = a
                    nxt[u] = c
                    prv[c] = u
                    rk[u] = 0.5 * (rk[a] + rk[c])
                vis[u] = 1
                stats[ST_TWOOPT] += 1
                return True
    return False


@numba.njit(cache=True)
def _try_kick(u, adj, vis, diag, nxt, prv, off, W, rk, maxlen, inq, queue, qt, cap, stats):
    """Last resort for a point nothing else takes: reroute a short stretch through it.

    ``u`` is next to path points ``a`` and ``c`` that are 2..``maxlen`` steps
    apart along the path. The stretch between them is replaced by
    ``a -> u -> c`` and its (at most ``maxlen - 1``) inner points go back to
    the splice queue, which usually takes them elsewhere. Returns the new
    queue tail, or -1 when no such move exists.
    """
    m = adj[u]
    s0 = np.random.randint(8)
    for dd in range(8):
        d = (dd + s0) % 8
        if not (m >> d) & 1:
            continue
        a = u + off[d]
        if vis[a] == 0 or not can_use(u, d, W, diag):
            continue
        x = nxt[a]
        for step in range(2, maxlen + 1):
            if x < 0:
                break
            x = nxt[x]
            if x < 0:
                break
            e = dir_between(u, x, W)
            if e < 0 or not (m >> e) & 1:
                continue
            c = x
            # unmark the stretch a .. c, then try the two new steps
            y = a
            while y != c:
                mark_step(y, dir_between(y, nxt[y], W), W, diag, False)
                y = nxt[y]
            ok = can_use(u, d, W, diag)
            if ok:
                mark_step(u, d, W, diag, True)
                ok = can_use(u, e, W, diag)
                if not ok:
                    mark_step(u, d, W, diag, False)
            if not ok:
                y = a
                while y != c:
                    mark_step(y, dir_between(y, nxt[y], W), W, diag, True)
                    y = nxt[y]
                continue
            mark_step(u, e, W, diag, True)
            y = nxt[a]
            while y != c:
                z = nxt[y]
                vis[y] = 0
                rk[y] = -1.0
                nxt[y] = -1
                prv[y] = -1
                if inq[y] == 0:
                    inq[y] = 1
                    queue[qt % cap] = y
                    qt += 1
                y = z
            nxt[a] = u
            prv[u] = a
            nxt[u] = c
            prv[c] = u
            vis[u] = 1
            rk[u] = 0.5 * (rk[a] + rk[c]) if rk[a] >= 0 and rk[c] >= 0 else -1.0
            stats[ST_KICK] += 1
            return qt
    return -1


@numba.njit(cache=True)
def finish_component(nodes, start, comp, walk_id, g, o, w, stats):  # pragma: no cover - numba
    """End-game of one component whose walk left unvisited points.

    Every unvisited point, in random order, is spliced in when it can be; the
    ones no splice takes get a 2-opt insertion into the main piece or else a
    kick (at most ``o.max_kicks``); whatever is left is walked as a sub-path
    (walk numbers from ``walk_id`` on), spliced around and joined to a piece
    when a join exists (else it stays its own piece).

    Parameters
    ----------
    nodes : (n,) int64
        Dense ids of the component's nodes.
    start : int
        Dense id of the planned start (on the main piece).
    comp : int
        Component label.
    walk_id : int
        Next unused walk number.
    g : WalkGrid
    o : WalkOptions
    w : WalkWork
        The path, linked in ``w.nxt`` / ``w.prv``, is completed in place.
    stats : (N_STATS,) int64
        Counters, incremented.
    """
    # The helpers called once per point take their arrays one by one: passing
    # the WalkGrid / WalkWork tuples to them made the end-game about a third
    # slower (benchmarks/bench_plan_walk.py --endgame, 1e6 points).
    adj, W, off = g.adj, g.W, g.off
    vis, diag, nxt, prv, P, inq, queue, mark, rk = w.vis, w.diag, w.nxt, w.prv, w.P, w.inq, w.queue, w.mark, w.rk
    n = nodes.shape[0]
    cap = queue.shape[0]
    order = nodes.copy()
    np.random.shuffle(order)
    # int64, not literal zeros: numba compiles a callee once more for each Literal[int] argument
    qh, qt = np.int64(0), np.int64(0)
    for u in order:
        if vis[u] == 0:
            inq[u] = 1
            queue[qt % cap] = u
            qt += 1
    qh, qt = _splice_loop(adj, vis, diag, nxt, prv, off, W, inq, queue, qh, qt, cap, stats)
    # points no splice takes: 2-opt insertion into the main piece
    _rank_main(start, nxt, rk)
    progress = True
    kicks = 0
    while progress:
        progress = False
        for u in order:
            if vis[u] == 1:
                continue
            if _try_reverse_insert(u, adj, vis, diag, nxt, prv, off, W, rk, stats):
                progress = True
                qt = _push_unvisited_nbrs(u, adj, vis, off, inq, queue, qt, cap)
                qh, qt = _splice_loop(adj, vis, diag, nxt, prv, off, W, inq, queue, qh, qt, cap, stats)
            elif kicks < o.max_kicks:
                q2 = _try_kick(u, adj, vis, diag, nxt, prv, off, W, rk, 6, inq, queue, qt, cap, stats)
                if q2 >= 0:
                    kicks += 1
                    progress = True
                    qt = _push_unvisited_nbrs(u, adj, vis, off, inq, queue, q2, cap)
                    qh, qt = _splice_loop(adj, vis, diag, nxt, prv, off, W, inq, queue, qh, qt, cap, stats)
    # leftovers: walk them as sub-paths, splice around them, join them to a piece
    for s in order:
        if vis[s] == 1:
            continue
        k = walk(s, walk_id, comp, np.int64(0), np.int64(0), n, g, o, w, stats)
        walk_id += 1
        stats[ST_SUBWALK] += 1
        link_path(P, k, nxt, prv)
        for i in range(k):
            qt = _push_unvisited_nbrs(np.int64(P[i]), adj, vis, off, inq, queue, qt, cap)
        qh, qt = _splice_loop(adj, vis, diag, nxt, prv, off, W, inq, queue, qh, qt, cap, stats)
        # joining before the start is allowed: one continuous path beats starting exactly there
        _try_join(s, -1, adj, vis, diag, nxt, prv, off, W, mark, P, stats)
