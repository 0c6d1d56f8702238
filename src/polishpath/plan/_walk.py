"""Compiled kernels of the pseudo-random walk (numba).

Everything works on a padded dense grid of ``H x W`` cells flattened row by
row: node ``p`` has grid index ``(p % W, p // W)`` (relative), and its
neighbour in direction ``d`` is ``p + off[d]``. ``adj[p]`` is the bitmask of
allowed steps (0 outside the region). The walk, the turnaround and the
end-game are the project's own method (paper section 3 plus our end-game), so
they are written here by hand.

No-crossing bookkeeping: the only way two steps between 8-neighbours can cross
is two diagonals of the same grid cell. ``diag[c]`` records which diagonal of
cell ``c`` (its lower-left corner's id) is in use: 0 none, 1 "/", 2 "\\".
A diagonal step is allowed only when the other diagonal of its cell is free.

While walking, the path is an implicit treap (a balanced tree keyed by
position, with lazy "reversed" flags): the paper's turnaround reverses the
tail after any path point in O(log n), so the walk may turn around at any
distance. After the walk the path is a doubly linked list (``nxt`` / ``prv``)
so that the end-game inserts points in O(1).
"""

from __future__ import annotations

import numba
import numpy as np

# stats slots returned by walk_component
ST_STEPS, ST_ROT, ST_DEL, ST_SPLICE, ST_APPEND, ST_SUBWALK, ST_JOIN, ST_PHASE1, ST_REV, ST_BLIND, ST_STUCK, ST_TWOOPT, ST_KICK, ST_ESCAPE = range(14)
# slots 14..23: turnarounds per tenth of the walk
N_STATS = 24


@numba.njit(cache=True)
def _dir_between(p, q, W):
    dx = q % W - p % W
    dy = q // W - p // W
    if dx < -1 or dx > 1 or dy < -1 or dy > 1 or (dx == 0 and dy == 0):
        return -1
    # DIRS order: E NE N NW W SW S SE
    if dy == 0:
        return 0 if dx == 1 else 4
    if dy == 1:
        return 1 - dx + 1  # dx=1 ->1, 0 ->2, -1 ->3
    return 5 + dx + 1  # dx=-1 ->5, 0 ->6, 1 ->7


@numba.njit(cache=True)
def _cell_of(p, d, W):
    # (cell id, diagonal type) of a diagonal step from p in direction d (odd)
    if d == 1:
        return p, 1
    if d == 3:
        return p - 1, 2
    if d == 5:
        return p - 1 - W, 1
    return p - W, 2


@numba.njit(cache=True)
def _can_use(p, d, W, diag):
    if d % 2 == 0:
        return True
    c, t = _cell_of(p, d, W)
    return diag[c] == 0


@numba.njit(cache=True)
def _mark(p, d, W, diag, value):
    if d % 2 == 1:
        c, t = _cell_of(p, d, W)
        diag[c] = t if value else 0


@numba.njit(cache=True)
def label_components(adj, nodes, W):  # pragma: no cover - numba
    """Connected-component label (dense int32, -1 outside) of every node; BFS."""
    lab = np.full(adj.shape[0], -1, dtype=np.int32)
    off = np.array([1, 1 + W, W, -1 + W, -1, -1 - W, -W, 1 - W])
    queue = np.empty(nodes.shape[0], dtype=np.int64)
    nlab = 0
    for s in nodes:
        if lab[s] >= 0:
            continue
        lab[s] = nlab
        qh, qt = 0, 0
        queue[qt] = s
        qt += 1
        while qh < qt:
            p = queue[qh]
            qh += 1
            m = adj[p]
            for d in range(8):
                if (m >> d) & 1:
                    q = p + off[d]
                    if lab[q] < 0:
                        lab[q] = nlab
                        queue[qt] = q
                        qt += 1
        nlab += 1
    return lab, nlab


@numba.njit(cache=True)
def _has_move(h, adj, vis, diag, off, W):
    m = adj[h]
    for d in range(8):
        if (m >> d) & 1:
            if vis[h + off[d]] == 0 and _can_use(h, d, W, diag):
                return True
    return False


# --- implicit treap: the walk's path with O(log n) tail reversal --------------------
# T[x] = (left, right, parent, size, reversed flag, priority). The sequence is
# the in-order of the tree; a reversed flag means "this subtree is mirrored"
# and is pushed down lazily. Written by hand: no numba-compatible sequence
# with cheap reversal exists in the dependencies, and the paper's turnaround
# needs "reverse the tail after point q" on paths of millions of points.
TL, TR, TP, TS, TV, TPR = range(6)


@numba.njit(cache=True)
def _tpush(x, T):
    if T[x, TV]:
        l = T[x, TL]
        r = T[x, TR]
        T[x, TL] = r
        T[x, TR] = l
        if l >= 0:
            T[l, TV] ^= 1
        if r >= 0:
            T[r, TV] ^= 1
        T[x, TV] = 0


@numba.njit(cache=True)
def _tpull(x, T):
    s = 1
    l = T[x, TL]
    r = T[x, TR]
    if l >= 0:
        s += T[l, TS]
        T[l, TP] = x
    if r >= 0:
        s += T[r, TS]
        T[r, TP] = x
    T[x, TS] = s


@numba.njit(cache=True)
def _tsplit(root, k, T, stack):
    """Split into the first ``k`` elements and the rest; returns both roots."""
    ra, rb, la, lb = -1, -1, -1, -1
    n = 0
    x = root
    while x >= 0:
        _tpush(x, T)
        stack[n] = x
        n += 1
        l = T[x, TL]
        ls = T[l, TS] if l >= 0 else 0
        if k <= ls:
            if lb < 0:
                rb = x
            else:
                T[lb, TL] = x
            lb = x
            x = l
        else:
            k -= ls + 1
            if la < 0:
                ra = x
            else:
                T[la, TR] = x
            la = x
            x = T[x, TR]
    if lb >= 0:
        T[lb, TL] = -1
    if la >= 0:
        T[la, TR] = -1
    for i in range(n - 1, -1, -1):
        _tpull(stack[i], T)
    if ra >= 0:
        T[ra, TP] = -1
    if rb >= 0:
        T[rb, TP] = -1
    return ra, rb


@numba.njit(cache=True)
def _tmerge(a, b, T, stack):
    """Concatenate sequence ``a`` then ``b``; returns the root."""
    if a < 0:
        return b
    if b < 0:
        return a
    root = -1
    p = -1
    side = 0
    n = 0
    while a >= 0 and b >= 0:
        if T[a, TPR] > T[b, TPR]:
            _tpush(a, T)
            x = a
            a = T[a, TR]
            nside = 1
        else:
            _tpush(b, T)
            x = b
            b = T[b, TL]
            nside = 0
        if p < 0:
            root = x
        elif side == 1:
            T[p, TR] = x
        else:
            T[p, TL] = x
        stack[n] = x
        n += 1
        p = x
        side = nside
    rest = a if a >= 0 else b
    if side == 1:
        T[p, TR] = rest
    else:
        T[p, TL] = rest
    for i in range(n - 1, -1, -1):
        _tpull(stack[i], T)
    T[root, TP] = -1
    return root


@numba.njit(cache=True)
def _trank(x, T, stack):
    """Position of ``x`` in its sequence (pushes the flags on its root path)."""
    n = 0
    y = x
    while y >= 0:
        stack[n] = y
        n += 1
        y = T[y, TP]
    for i in range(n - 1, -1, -1):
        _tpush(stack[i], T)
    l = T[x, TL]
    r = T[l, TS] if l >= 0 else 0
    y = x
    while T[y, TP] >= 0:
        p = T[y, TP]
        if T[p, TR] == y:
            l = T[p, TL]
            r += 1 + (T[l, TS] if l >= 0 else 0)
        y = p
    return r


@numba.njit(cache=True)
def _tsucc(x, T):
    """Next element after ``x``; call right after ``_trank(x)``."""
    y = T[x, TR]
    if y >= 0:
        _tpush(y, T)
        while T[y, TL] >= 0:
            y = T[y, TL]
            _tpush(y, T)
        return y
    y = x
    while T[y, TP] >= 0 and T[T[y, TP], TR] == y:
        y = T[y, TP]
    return T[y, TP]


@numba.njit(cache=True)
def _tinorder(root, T, out, stack):
    n = 0
    c = 0
    x = root
    while n > 0 or x >= 0:
        while x >= 0:
            _tpush(x, T)
            stack[n] = x
            n += 1
            x = T[x, TL]
        n -= 1
        x = stack[n]
        out[c] = x
        c += 1
        x = T[x, TR]
    return c


@numba.njit(cache=True)
def _tnew(x, T):
    T[x, TL] = -1
    T[x, TR] = -1
    T[x, TP] = -1
    T[x, TS] = 1
    T[x, TV] = 0
    T[x, TPR] = np.random.randint(0, 2147483647)


@numba.njit(cache=True)
def _nearest_unvisited(h, adj, vis, lab, comp, W, rmax):
    """Nearest (Chebyshev rings) unvisited node of component ``comp`` within ``rmax`` cells of ``h``, or -1."""
    N = adj.shape[0]
    hx, hy = h % W, h // W
    H = N // W
    for r in range(1, rmax + 1):
        for side in range(4):
            for k in range(-r, r):
                if side == 0:
                    x, y = hx + k, hy - r
                elif side == 1:
                    x, y = hx + r, hy + k
                elif side == 2:
                    x, y = hx - k, hy + r
                else:
                    x, y = hx - r, hy - k
                if x < 0 or y < 0 or x >= W or y >= H:
                    continue
                q = y * W + x
                if adj[q] != 0 and vis[q] == 0 and lab[q] == comp:
                    return q
    return -1


@numba.njit(cache=True)
def _phase1_tree(start, walk_id, adj, vis, diag, wid, P, T, stack, off, W, window, backtrack, budget, max_blind, shortest, lab, comp, steer, nodes_n, stats):
    """Random self-avoiding walk with the paper's turnaround at any distance; returns its length in P."""
    _tnew(start, T)
    root = start
    head = start
    wid[start] = walk_id
    vis[start] = 1
    k = 1
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
                if vis[q] == 0 and _can_use(h, d, W, diag):
                    cand[nav] = d
                    nav += 1
        if nav > 0:  # paper step 2: a random unvisited neighbour
            d = cand[np.random.randint(nav)]
            q = h + off[d]
            _mark(h, d, W, diag, True)
            _tnew(q, T)
            root = _tmerge(root, q, T, stack)
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
                if vis[q] == 1 and wid[q] == walk_id and _can_use(h, d, W, diag):
                    t = _trank(q, T, stack)
                    if t <= k - 3 and t >= k - 1 - window:
                        sq = _tsucc(q, T)
                        if _has_move(sq, adj, vis, diag, off, W):
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
                tgt = _nearest_unvisited(h, adj, vis, lab, comp, W, radius)
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
            stats[14 + (10 * k) // (nodes_n + 1)] += 1
            _mark(q, _dir_between(q, sq, W), W, diag, False)
            _mark(h, d, W, diag, True)
            A, B = _tsplit(root, t + 1, T, stack)
            T[B, TV] ^= 1
            root = _tmerge(A, B, T, stack)
            head = sq
            stats[ST_ROT] += 1
            continue
        # paper step 7: give back the last points and walk on (budgeted)
        if backtrack > 0 and deleted + backtrack <= budget and k > backtrack + 1:
            A, B = _tsplit(root, k - backtrack - 1, T, stack)
            c = _tinorder(B, T, P, stack)
            for i in range(1, c):
                _mark(P[i - 1], _dir_between(P[i - 1], P[i], W), W, diag, False)
            for i in range(1, c):
                vis[P[i]] = 0
                wid[P[i]] = 0
            # P[0] is the new head: put it back
            _tnew(P[0], T)
            root = _tmerge(A, P[0], T, stack)
            head = P[0]
            k -= backtrack
            deleted += backtrack
            stats[ST_DEL] += backtrack
            continue
        # escape (ours): walk the head by steered rotations toward an unvisited
        # point up to 8 x steer cells away, a bounded number of times
        if escapes < max_escapes and blind_limit == max_blind:
            t2 = _nearest_unvisited(h, adj, vis, lab, comp, W, 8 * steer)
            if t2 >= 0:
                escapes += 1
                stats[ST_ESCAPE] += 1
                tgt = t2
                radius = 8 * steer
                blind_limit = max_blind + 4 * 8 * steer
                continue
        break
    return _tinorder(root, T, P, stack)


@numba.njit(cache=True)
def _push_unvisited_nbrs(p, adj, vis, off, inq, queue, qt, cap):
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
        if vis[a] == 0 or not _can_use(u, d, W, diag):
            continue
        if nxt[a] == -1:
            ca[nc] = a
            cb[nc] = -1
            nc += 1
        for s in range(2):
            b = nxt[a] if s == 0 else prv[a]
            if b < 0:
                continue
            e = _dir_between(u, b, W)
            # (u,a), (u,b), (a,b) pairwise share an end: they cannot be the two
            # diagonals of one cell, so checking each new step alone is exact.
            if e >= 0 and (m >> e) & 1 and _can_use(u, e, W, diag):
                ca[nc] = a
                cb[nc] = b
                nc += 1
    if nc == 0:
        return False
    r = np.random.randint(nc)
    a, b = ca[r], cb[r]
    _mark(u, _dir_between(u, a, W), W, diag, True)
    vis[u] = 1
    if b < 0:
        nxt[a] = u
        prv[u] = a
        nxt[u] = -1
        stats[ST_APPEND] += 1
        return True
    _mark(a, _dir_between(a, b, W), W, diag, False)
    _mark(u, _dir_between(u, b, W), W, diag, True)
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
            if vis[q] == 0 or mark[q] == 1 or not _can_use(e, d, W, diag):
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
            _mark(e, d, W, diag, True)
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
            if vis[a] == 0 or mark[a] == 1 or not _can_use(s0, d, W, diag):
                continue
            for s in range(2):
                b = nxt[a] if s == 0 else prv[a]
                if b < 0:
                    continue
                e = _dir_between(se, b, W)
                if e < 0 or not (adj[se] >> e) & 1:
                    continue
                # the two new steps may be the two diagonals of one cell when
                # s0 != se: check the second with the first in place
                _mark(s0, d, W, diag, True)
                if not _can_use(se, e, W, diag):
                    _mark(s0, d, W, diag, False)
                    continue
                _mark(a, _dir_between(a, b, W), W, diag, False)
                _mark(se, e, W, diag, True)
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
            if vis[a] == 1 and rk[a] >= 0 and _can_use(u, d, W, diag):
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
                    e = _dir_between(x, y, W)
                    if e < 0 or not (adj[x] >> e) & 1:
                        continue
                # remove the two broken steps, then add the three new ones one by one
                if variant == 0:
                    r1a, r1b, r2a, r2b = a, x, c, y
                else:
                    r1a, r1b, r2a, r2b = x, a, y, c
                _mark(r1a, _dir_between(r1a, r1b, W), W, diag, False)
                if r2b >= 0:
                    _mark(r2a, _dir_between(r2a, r2b, W), W, diag, False)
                da = _dir_between(u, a, W)
                dc = _dir_between(u, c, W)
                ok = _can_use(u, da, W, diag)
                if ok:
                    _mark(u, da, W, diag, True)
                    ok = _can_use(u, dc, W, diag)
                    if ok:
                        _mark(u, dc, W, diag, True)
                        if e >= 0:
                            ok = _can_use(x, e, W, diag)
                            if not ok:
                                _mark(u, dc, W, diag, False)
                    if not ok:
                        _mark(u, da, W, diag, False)
                if not ok:
                    _mark(r1a, _dir_between(r1a, r1b, W), W, diag, True)
                    if r2b >= 0:
                        _mark(r2a, _dir_between(r2a, r2b, W), W, diag, True)
                    continue
                if e >= 0:
                    _mark(x, e, W, diag, True)
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
        if vis[a] == 0 or not _can_use(u, d, W, diag):
            continue
        x = nxt[a]
        for step in range(2, maxlen + 1):
            if x < 0:
                break
            x = nxt[x]
            if x < 0:
                break
            e = _dir_between(u, x, W)
            if e < 0 or not (m >> e) & 1:
                continue
            c = x
            # unmark the stretch a .. c, then try the two new steps
            y = a
            while y != c:
                _mark(y, _dir_between(y, nxt[y], W), W, diag, False)
                y = nxt[y]
            ok = _can_use(u, d, W, diag)
            if ok:
                _mark(u, d, W, diag, True)
                ok = _can_use(u, e, W, diag)
                if not ok:
                    _mark(u, d, W, diag, False)
            if not ok:
                y = a
                while y != c:
                    _mark(y, _dir_between(y, nxt[y], W), W, diag, True)
                    y = nxt[y]
                continue
            _mark(u, e, W, diag, True)
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
def walk_component(adj, W, nodes, start, seed, window, backtrack, budget, max_blind, shortest, lab, comp, steer, vis, diag, nxt, prv, pos, P, inq, queue, mark, T, stack, walk_id, rk, max_kicks):  # pragma: no cover - numba
    """Plan one connected component; leaves the pieces linked in ``nxt``/``prv``.

    Returns the stats vector (see ``ST_*``).
    """
    np.random.seed(seed)
    stats = np.zeros(N_STATS, dtype=np.int64)
    off = np.array([1, 1 + W, W, -1 + W, -1, -1 - W, -W, 1 - W])
    n = nodes.shape[0]
    cap = queue.shape[0]
    k = _phase1_tree(start, walk_id, adj, vis, diag, pos, P, T, stack, off, W, window, backtrack, budget, max_blind, shortest, lab, comp, steer, n, stats)
    walk_id += 1
    stats[ST_PHASE1] = k
    prv[P[0]] = -1
    for i in range(k - 1):
        nxt[P[i]] = P[i + 1]
        prv[P[i + 1]] = P[i]
    nxt[P[k - 1]] = -1
    if k == n:
        return stats
    # end-game: every unvisited point, in random order, is spliced in when it can be
    order = nodes.copy()
    np.random.shuffle(order)
    qh, qt = 0, 0
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
            elif kicks < max_kicks:
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
        k = _phase1_tree(s, walk_id, adj, vis, diag, pos, P, T, stack, off, W, window, 0, 0, max_blind, shortest, lab, comp, steer, n, stats)
        walk_id += 1
        stats[ST_SUBWALK] += 1
        prv[P[0]] = -1
        for i in range(k - 1):
            nxt[P[i]] = P[i + 1]
            prv[P[i + 1]] = P[i]
        nxt[P[k - 1]] = -1
        for i in range(k):
            qt = _push_unvisited_nbrs(P[i], adj, vis, off, inq, queue, qt, cap)
        qh, qt = _splice_loop(adj, vis, diag, nxt, prv, off, W, inq, queue, qh, qt, cap, stats)
        # joining before the start is allowed: one continuous path beats starting exactly there
        _try_join(s, -1, adj, vis, diag, nxt, prv, off, W, mark, P, stats)
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
