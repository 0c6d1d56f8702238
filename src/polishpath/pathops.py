"""Path maths shared by every stage: pieces, steps, grid directions, turns.

The path twin of :mod:`polishpath.meshops`. A path is ``N`` points in order
(dwell points, mm; or grid indices) cut into ``K`` continuous pieces by the
offsets ``pieces`` (``(K+1,)`` int, ``pieces[0] == 0``, ``pieces[-1] == N``,
non-decreasing; ``None`` means one piece ``[0, N]``). Piece ``k`` is
``points[pieces[k]:pieces[k+1]]``; the tool lifts between pieces, so the move
from the last point of one piece to the first of the next is a *lift*, not a
*step*. Step ``a`` joins points ``a`` and ``a + 1``.

Every stage that needs "the steps within pieces" (mapping, planner metrics,
simulation, report, paper) calls these functions, so the rule that a lift is
not a step lives in one place. All functions are vectorised numpy.
"""

from __future__ import annotations

import numpy as np

from .errors import ParameterError

#: The 8 grid directions in index space, counter-clockwise from +i (east);
#: direction ``d`` and ``(d + 4) % 8`` are opposite. Shape (8, 2) int64.
DIRECTION_STEPS = np.array([[1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1]], dtype=np.int64)
DIRECTION_STEPS.setflags(write=False)

#: Names of the 8 directions, in :data:`DIRECTION_STEPS` order (E = +i, N = +j).
DIRECTION_NAMES = ("E", "NE", "N", "NW", "W", "SW", "S", "SE")

#: Direction code of a step that is not a single move to one of the 8 grid neighbours.
OTHER_MOVE = -1
#: Direction code of the lift between two pieces (not a step).
LIFT = -2


def piece_offsets(pieces, n_points: int) -> np.ndarray:
    """Checked piece offsets of a path of ``n_points`` points.

    Parameters
    ----------
    pieces : (K+1,) int or None
        Piece offsets; None means one piece.
    n_points : int
        Number of points N.

    Returns
    -------
    (K+1,) int64
        ``[0, N]`` for None, else ``pieces`` as int64.

    Raises
    ------
    ParameterError
        If the offsets are not 1-D integers that start at 0, end at N and never decrease.
    """
    n = int(n_points)
    if pieces is None:
        return np.array([0, n], dtype=np.int64)
    raw = np.asarray(pieces)
    integral = raw.dtype.kind in "iu" or (raw.dtype.kind == "f" and bool(np.all(raw == np.round(raw))))
    if raw.ndim != 1 or len(raw) < 2 or not integral:
        raise ParameterError(
            f"pieces must be a 1-D list of at least 2 integer offsets, got shape {raw.shape} ({raw.dtype}).",
            f"Give the offsets of the continuous pieces, e.g. [0, {n}] for one piece.",
        )
    p = raw.astype(np.int64)
    if p[0] != 0 or p[-1] != n or np.any(np.diff(p) < 0):
        raise ParameterError(
            f"pieces must start at 0, end at the number of points ({n}) and never decrease; "
            f"got {p[:3].tolist()}...{p[-2:].tolist()}.",
            "Use the offsets the planner wrote with this path (PlanarPath.pieces).",
        )
    return p


def piece_index(pieces, n_points: int, idx=None) -> np.ndarray:
    """Which piece each point belongs to.

    Parameters
    ----------
    pieces : (K+1,) int or None
        Piece offsets.
    n_points : int
        Number of points N.
    idx : (M,) int, optional
        Point indices in ``[0, N)`` to look up (default all N points).

    Returns
    -------
    (N,) or (M,) int64
        Piece number ``k`` with ``pieces[k] <= i < pieces[k+1]``.
    """
    p = piece_offsets(pieces, n_points)
    i = np.arange(int(n_points)) if idx is None else np.asarray(idx, dtype=np.int64)
    return np.searchsorted(p, i, side="right") - 1


def step_mask(n_points: int, pieces=None) -> np.ndarray:
    """Which of the ``N - 1`` moves between consecutive points are steps within a piece.

    Parameters
    ----------
    n_points : int
        Number of points N.
    pieces : (K+1,) int or None
        Piece offsets.

    Returns
    -------
    (N-1,) bool
        False for the lifts between pieces.
    """
    n = int(n_points)
    p = piece_offsets(pieces, n)
    m = np.ones(max(n - 1, 0), dtype=bool)
    starts = p[1:-1]
    starts = starts[(starts >= 1) & (starts < n)]
    m[starts - 1] = False
    return m


def step_starts(n_points: int, pieces=None) -> tuple[np.ndarray, np.ndarray]:
    """Index and piece of every step within a piece.

    Parameters
    ----------
    n_points : int
        Number of points N.
    pieces : (K+1,) int or None
        Piece offsets.

    Returns
    -------
    start : (S,) int64
        Step ``start[s]`` joins points ``start[s]`` and ``start[s] + 1``.
    piece : (S,) int64
        The piece it lies in.
    """
    n = int(n_points)
    a = np.flatnonzero(step_mask(n, pieces)).astype(np.int64)
    return a, piece_index(pieces, n, a)


def step_vectors(points: np.ndarray, pieces=None) -> np.ndarray:
    """Vectors of the steps within pieces.

    Parameters
    ----------
    points : (N, d) float
        Points in path order, mm (or grid indices).
    pieces : (K+1,) int or None
        Piece offsets.

    Returns
    -------
    (S, d)
        ``points[a + 1] - points[a]`` for every step ``a`` within a piece.
    """
    p = np.asarray(points)
    if len(p) < 2:
        return np.zeros((0,) + p.shape[1:], dtype=p.dtype)
    return np.diff(p, axis=0)[step_mask(len(p), pieces)]


def step_lengths(points: np.ndarray, pieces=None) -> np.ndarray:
    """Lengths of the steps within pieces (lifts left out).

    Parameters
    ----------
    points : (N, d) float
        Points in path order, mm.
    pieces : (K+1,) int or None
        Piece offsets.

    Returns
    -------
    (S,) float64
        Step lengths, mm.
    """
    p = np.asarray(points, dtype=np.float64)
    if len(p) < 2:
        piece_offsets(pieces, len(p))
        return np.zeros(0)
    return np.linalg.norm(np.diff(p, axis=0), axis=1)[step_mask(len(p), pieces)]


def piece_slices(pieces, n_points: int) -> list[slice]:
    """One ``slice`` per piece, ``slice(pieces[k], pieces[k+1])`` (empty pieces included).

    Parameters
    ----------
    pieces : (K+1,) int or None
        Piece offsets.
    n_points : int
        Number of points N.

    Returns
    -------
    list of K slices
    """
    p = piece_offsets(pieces, n_points)
    return [slice(int(a), int(b)) for a, b in zip(p[:-1], p[1:])]


def split_by_pieces(array: np.ndarray, pieces=None) -> list[np.ndarray]:
    """Split a per-point array into its pieces.

    Parameters
    ----------
    array : (N, ...) array
        Per-point values (points, times, normals...).
    pieces : (K+1,) int or None
        Piece offsets.

    Returns
    -------
    list of K arrays
        Views ``array[pieces[k]:pieces[k+1]]``.
    """
    a = np.asarray(array)
    return [a[s] for s in piece_slices(pieces, len(a))]


def pieces_after_keep(pieces, keep: np.ndarray) -> np.ndarray:
    """Piece offsets of the path left when only the points ``keep`` remain.

    A piece is cut where points were dropped (the tool cannot step over a
    dropped point), and pieces that lose every point vanish.

    Parameters
    ----------
    pieces : (K+1,) int or None
        Piece offsets of the whole path.
    keep : (N,) bool
        Points that remain.

    Returns
    -------
    (K'+1,) int64
        Offsets into the kept points ``points[keep]``.
    """
    k = np.asarray(keep, dtype=bool)
    if k.ndim != 1:
        raise ParameterError(f"keep must be a 1-D boolean mask, got shape {k.shape}.")
    kept = np.flatnonzero(k)
    if len(kept) == 0:
        return np.zeros(1, dtype=np.int64)
    pc = piece_index(pieces, len(k), kept)
    brk = np.ones(len(kept), dtype=bool)
    brk[1:] = (np.diff(kept) != 1) | (np.diff(pc) != 0)
    return np.append(np.flatnonzero(brk), len(kept)).astype(np.int64)


def sector_codes(vectors: np.ndarray, rotation: float = 0.0) -> np.ndarray:
    """Nearest of the 8 compass directions of each 2D vector.

    Parameters
    ----------
    vectors : (S, 2) float
        Step vectors (any length unit).
    rotation : float
        Frame rotation, radians: directions are measured from the +x axis
        turned by ``rotation``.

    Returns
    -------
    (S,) int64
        Code 0..7 in :data:`DIRECTION_NAMES` order (sectors of 45 degrees
        centred on each direction).
    """
    d = np.asarray(vectors, dtype=np.float64).reshape(-1, 2)
    ang = np.arctan2(d[:, 1], d[:, 0]) - rotation
    return np.round(ang / (np.pi / 4)).astype(np.int64) % 8


def direction_codes(ij: np.ndarray, pieces=None) -> np.ndarray:
    """Direction code of every move of a grid path.

    Parameters
    ----------
    ij : (N, 2) int
        Grid indices of the points in path order.
    pieces : (K+1,) int or None
        Piece offsets.

    Returns
    -------
    (N-1,) int64
        0..7 (:data:`DIRECTION_NAMES` order) for a move to one of the 8
        neighbours, :data:`OTHER_MOVE` for any other step within a piece
        (a longer chord, a repeated point), :data:`LIFT` between pieces.
    """
    g = np.asarray(ij, dtype=np.int64)
    if len(g) < 2:
        piece_offsets(pieces, len(g))
        return np.zeros(0, dtype=np.int64)
    d = np.diff(g, axis=0)
    unit = np.abs(d).max(axis=1) == 1
    code = np.where(unit, sector_codes(d), OTHER_MOVE)
    code[~step_mask(len(g), pieces)] = LIFT
    return code


def direction_counts(ij: np.ndarray, pieces=None) -> tuple[np.ndarray, int]:
    """Count the steps of a grid path in each of the 8 directions.

    Parameters
    ----------
    ij : (N, 2) int
        Grid indices of the points in path order.
    pieces : (K+1,) int or None
        Piece offsets; lifts are left out.

    Returns
    -------
    counts : (8,) int64
        Steps per direction, in :data:`DIRECTION_NAMES` order.
    other : int
        Steps within pieces that are not a single move to one of the 8 neighbours.
    """
    codes = direction_codes(ij, pieces)
    counts = np.bincount(codes[codes >= 0], minlength=8).astype(np.int64)
    return counts, int(np.count_nonzero(codes == OTHER_MOVE))


def turn_angles_deg(ij: np.ndarray, pieces=None) -> np.ndarray:
    """Signed turn angle between consecutive neighbour moves of a grid path.

    Only pairs of neighbour moves within one piece count. Positive turns are
    counter-clockwise in the grid frame; 0 is straight on.

    Parameters
    ----------
    ij : (N, 2) int
        Grid indices of the points in path order.
    pieces : (K+1,) int or None
        Piece offsets.

    Returns
    -------
    (T,) float64
        Degrees in (-180, 180], multiples of 45.
    """
    code = direction_codes(ij, pieces)
    if len(code) < 2:
        return np.zeros(0)
    a, b = code[:-1], code[1:]
    ok = (a >= 0) & (b >= 0)
    t = np.mod(b[ok] - a[ok], 8)  # 0..7 eighths of a turn
    t = np.where(t > 4, t - 8, t)
    return t.astype(float) * 45.0
