"""The grid the compiled walk works on: steps, the no-crossing rule, counters and work arrays (numba).

Everything works on a padded dense grid of ``H x W`` cells flattened row by
row: node ``p`` has grid index ``(p % W, p // W)`` (relative), and its
neighbour in direction ``d`` (``DIRS`` order: E NE N NW W SW S SE) is
``p + off[d]``. ``adj[p]`` is the bitmask of allowed steps (0 outside the
region).

No-crossing bookkeeping: the only way two steps between 8-neighbours can cross
is two diagonals of the same grid cell. ``diag[c]`` records which diagonal of
cell ``c`` (its lower-left corner's id) is in use: 0 none, 1 "/", 2 "\\".
A diagonal step is allowed only when the other diagonal of its cell is free.

The kernels that run once per component or sub-walk (``_component``, the walk
of ``_walk``, the end-game driver of ``_endgame``) share three structures,
built here in Python and passed to numba as named tuples, unpacked into locals
at the top of each kernel so that their loops run as fast as with separate
arguments. The end-game's helpers called once per point take the arrays one by
one: given the tuples, the end-game ran about a third slower
(``benchmarks/bench_plan_walk.py --endgame``).

* :class:`WalkGrid`: the region's grid (read only);
* :class:`WalkOptions`: the planner's options for one component;
* :class:`WalkWork`: the work arrays, allocated once and reused by every
  component (each component's nodes are disjoint, so no reset is needed).
"""

from __future__ import annotations

from typing import NamedTuple

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

#: Slots of the counters vector that the kernels fill (``stats``, (N_STATS,) int64).
(ST_STEPS, ST_ROT, ST_DEL, ST_SPLICE, ST_APPEND, ST_SUBWALK, ST_JOIN, ST_PHASE1, ST_REV, ST_BLIND, ST_STUCK,
 ST_TWOOPT, ST_KICK, ST_ESCAPE) = range(14)
#: First of the 10 slots counting turnarounds per tenth of the walk.
ST_TENTHS = 14
N_STATS = ST_TENTHS + 10


class WalkGrid(NamedTuple):
    """The region's dense grid as the kernels see it.

    Attributes
    ----------
    adj : (H*W,) uint8
        Bitmask of allowed steps of each dense node (0 outside the region).
    W : int
        Row length of the dense grid.
    off : (8,) int64
        Dense-id offset of a step in each direction.
    lab : (H*W,) int32
        Connected-component label of each node, -1 outside.
    """

    adj: np.ndarray
    W: int
    off: np.ndarray
    lab: np.ndarray


class WalkOptions(NamedTuple):
    """Options of the walk for one component (see :func:`polishpath.plan.pseudorandom_order`).

    Attributes
    ----------
    window : int
        Turn around only at path points at most this many positions back.
    backtrack : int
        Points given back when no turnaround exists (0: never).
    budget : int
        Total points the component's walk may give back.
    max_blind : int
        Rotations in a row that do not free the head before giving back points.
    shortest : bool
        Among freeing turnarounds take the most recent path point (else a random one).
    steer : int
        Radius (cells) of the search for an unvisited point to steer toward.
    max_kicks : int
        End-game reroutes allowed in the component.
    """

    window: int
    backtrack: int
    budget: int
    max_blind: int
    shortest: bool
    steer: int
    max_kicks: int


class WalkWork(NamedTuple):
    """Work arrays of the kernels: dense ones (H*W,) and ones sized by the largest component (m).

    Attributes
    ----------
    vis : (H*W,) uint8
        1 when the node is on the path.
    diag : (H*W,) uint8
        Diagonal in use in each grid cell (0 none, 1 "/", 2 "\\").
    wid : (H*W,) int32
        Number of the walk that placed the node (turnarounds stay within one walk).
    nxt, prv : (H*W,) int32
        The path as a doubly linked list after the walk (-1: none).
    P : (m + 1,) int32
        A walk's nodes in order (also scratch space of the end-game's joins).
    inq : (H*W,) uint8
        1 when the node is in the splice queue.
    queue : (m + 1,) int32
        Ring buffer of nodes to splice in.
    mark : (H*W,) uint8
        Members of the piece being joined.
    T : (H*W, 6) int32
        The treap of the walk's path (see ``_treap``).
    stack : (m + 2,) int32
        Scratch stack of the treap.
    rk : (H*W,) float64
        Order key of each node of the main piece (-1: not on it), kept by the 2-opt moves.
    """

    vis: np.ndarray
    diag: np.ndarray
    wid: np.ndarray
    nxt: np.ndarray
    prv: np.ndarray
    P: np.ndarray
    inq: np.ndarray
    queue: np.ndarray
    mark: np.ndarray
    T: np.ndarray
    stack: np.ndarray
    rk: np.ndarray


def walk_grid(adj: np.ndarray, W: int, lab: np.ndarray) -> WalkGrid:
    """The :class:`WalkGrid` of a dense bitmask ``adj`` (H*W,) uint8 with rows of ``W`` and labels ``lab``."""
    off = np.array([1, 1 + W, W, -1 + W, -1, -1 - W, -W, 1 - W], dtype=np.int64)
    return WalkGrid(adj, int(W), off, lab)


def walk_work(n_dense: int, max_component: int) -> WalkWork:
    """Fresh :class:`WalkWork` for a dense grid of ``n_dense`` nodes whose largest component has ``max_component``."""
    return WalkWork(
        vis=np.zeros(n_dense, dtype=np.uint8),
        diag=np.zeros(n_dense, dtype=np.uint8),
        wid=np.full(n_dense, -1, dtype=np.int32),
        nxt=np.full(n_dense, -1, dtype=np.int32),
        prv=np.full(n_dense, -1, dtype=np.int32),
        P=np.empty(max_component + 1, dtype=np.int32),
        inq=np.zeros(n_dense, dtype=np.uint8),
        queue=np.empty(max_component + 1, dtype=np.int32),
        mark=np.zeros(n_dense, dtype=np.uint8),
        T=np.empty((n_dense, 6), dtype=np.int32),
        stack=np.empty(max_component + 2, dtype=np.int32),
        rk=np.full(n_dense, -1.0),
    )


@numba.njit(cache=True)
def dir_between(p, q, W):
    """Direction number 0..7 (``DIRS`` order) of the step from ``p`` to ``q``, -1 when they are not 8-neighbours."""
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
def can_use(p, d, W, diag):
    """Whether the step from ``p`` in direction ``d`` crosses no step already on the path."""
    if d % 2 == 0:
        return True
    c, t = _cell_of(p, d, W)
    return diag[c] == 0


@numba.njit(cache=True)
def mark_step(p, d, W, diag, value):
    """Record (``value`` True) or clear the diagonal that the step from ``p`` in direction ``d`` uses."""
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
def has_move(h, adj, vis, diag, off, W):
    """Whether node ``h`` has an unvisited neighbour it may step to."""
    m = adj[h]
    for d in range(8):
        if (m >> d) & 1:
            if vis[h + off[d]] == 0 and can_use(h, d, W, diag):
                return True
    return False



@numba.njit(cache=True)
def nearest_unvisited(h, adj, vis, lab, comp, W, rmax):
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
def link_path(P, k, nxt, prv):
    """Link the nodes ``P[:k]`` (k >= 1) in order as one piece of the doubly linked list."""
    prv[P[0]] = -1
    for i in range(k - 1):
        nxt[P[i]] = P[i + 1]
        prv[P[i + 1]] = P[i]
    nxt[P[k - 1]] = -1
