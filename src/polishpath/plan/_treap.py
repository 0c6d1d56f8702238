"""Implicit treap: the walk's path, with O(log n) reversal of any tail (numba).

A path of dense node ids is the in-order of a balanced tree keyed by position
(an implicit treap with random priorities). ``T[x]`` is the row of node ``x``:
``(left, right, parent, size, reversed flag, priority)`` at the columns
``TL, TR, TP, TS, TV, TPR``; a reversed flag means "this subtree is mirrored"
and is pushed down lazily. ``stack`` is scratch space of at least the tree's
height plus one.

Written by hand: no numba-compatible sequence with cheap reversal exists in the
dependencies, and the paper's turnaround needs "reverse the tail after point
q" on paths of millions of points. The priorities are drawn from numba's
generator (seeded by the caller), so a walk is reproducible with its seed.
"""

from __future__ import annotations

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

#: Columns of the treap table ``T`` (n, 6) int32.
TL, TR, TP, TS, TV, TPR = range(6)


@numba.njit(cache=True)
def _tpush(x, T):
    """Push the reversed flag of ``x`` down to its children."""
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
    """Recompute the size of ``x`` and its children's parent links."""
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
def tsplit(root, k, T, stack):
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
def tmerge(a, b, T, stack):
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
def trank(x, T, stack):
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
def tsucc(x, T):
    """Next element after ``x``; call right after ``trank(x)``."""
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
def tinorder(root, T, out, stack):
    """Write the sequence of the tree ``root`` into ``out``; returns its length."""
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
def tnew(x, T):
    """Make ``x`` a tree of one node with a random priority."""
    T[x, TL] = -1
    T[x, TR] = -1
    T[x, TP] = -1
    T[x, TS] = 1
    T[x, TV] = 0
    T[x, TPR] = np.random.randint(0, 2147483647)


@numba.njit(cache=True)
def tgive_back(root, k, m, T, stack, P, vis, wid):
    """The paper's step 7 on a walk's path of ``k`` nodes: give back its last ``m`` nodes.

    They leave the path (``vis`` and ``wid`` 0); the node before them is the new head. ``P`` receives the
    ``m + 1`` last nodes in path order (the new head first), so that a caller can undo what it marked for
    their steps. Returns the new root and ``m + 1``.
    """
    A, B = tsplit(root, k - m - 1, T, stack)
    c = tinorder(B, T, P, stack)
    for i in range(1, c):
        vis[P[i]] = 0
        wid[P[i]] = 0
    tnew(P[0], T)  # P[0] is the new head: put it back
    return tmerge(A, P[0], T, stack), c
