"""The two space-filling-curve peers of the paper's Table 3: ``fractal`` and ``hilbert`` (registered by :mod:`.peers`).

``fractal``
    Dong et al.'s random fractal-like path: the grid's bounding square
    (side 2^k dwell points) is divided recursively into 4 quadrants, visited in
    a random order with random entry / exit corners (8-neighbour links between
    quadrants, so diagonals appear); the curve is clipped to the region and
    split where a link would leave it. Its published smoothing is an
    approximating spline that does not pass through the dwell points: the
    pattern measures that deviation with :func:`bspline_deviation` (uniform
    cubic B-spline with the dwell points as control points), ``stats
    ["smoothing_dev_max"]`` (mm).
``hilbert``
    The classic Hilbert curve on the bounding square, clipped to the region
    the same way; ``seed % 8`` picks one of its 8 symmetric orientations.

Both are reproducible with the seed (numpy ``SeedSequence``).
"""

from __future__ import annotations

import numpy as np
import shapely

from ..errors import ParameterError
from ..types import Region
from .api import PatternResult, check_pattern_call
from .baselines import clip_grid_sequence
from .checks import check_count, check_options, check_points, check_seed
from .dwell import DwellGrid

_CORNER = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.int64)  # SW SE NE NW
#: Largest square of a space-filling curve: 2**15 points a side (4**15, about 1e9 points).
_MAX_SIDE_LOG2 = 15


def _seg_cross(p1, p2, q1, q2) -> bool:
    """Whether closed segments p1p2 and q1q2 share a point (integer 2D points)."""
    return shapely.intersects(shapely.LineString([p1, p2]), shapely.LineString([q1, q2]))


def _fractal_table(h: int) -> list[list[list[tuple]]]:
    """Valid ways to split a block of side 2h entered at corner e and left at corner x.

    Returns ``T[e][x]`` = list of ``(order (4,), entry (4,), exit (4,))``: the
    quadrants in visiting order and each one's entry / exit corner, such that
    consecutive quadrants are joined by an 8-neighbour step, a quadrant of side
    >= 2 is not entered and left at the same corner, and the three joining
    steps do not cross each other.
    """
    import itertools

    def pos(q, c):
        return _CORNER[q] * h + _CORNER[c] * (h - 1)

    T = [[[] for _ in range(4)] for _ in range(4)]
    for e in range(4):
        for x in range(4):
            if e == x:
                continue
            others = [q for q in range(4) if q not in (e, x)]
            for mid in itertools.permutations(others):
                order = (e, *mid, x)
                links = []
                for t in range(3):
                    qa, qb = order[t], order[t + 1]
                    opts = [(ca, cb) for ca in range(4) for cb in range(4)
                            if np.abs(pos(qa, ca) - pos(qb, cb)).max() == 1]
                    if h == 1:
                        opts = [(0, 0)]
                    links.append(opts)
                for combo in itertools.product(*links):
                    entry = [e] + [combo[t][1] for t in range(3)]
                    exit_ = [combo[t][0] for t in range(3)] + [x]
                    if h == 1:
                        entry, exit_ = [0, 0, 0, 0], [0, 0, 0, 0]
                    elif any(entry[t] == exit_[t] for t in range(4)):
                        continue
                    segs = [(pos(order[t], exit_[t]), pos(order[t + 1], entry[t + 1])) for t in range(3)]
                    bad = False
                    for s1, s2 in itertools.combinations(range(3), 2):
                        a, b = segs[s1], segs[s2]
                        if s2 == s1 + 1 and h == 1:
                            continue  # consecutive joins meet at the one-point quadrant
                        if _seg_cross(a[0], a[1], b[0], b[1]):
                            bad = True
                    if not bad:
                        T[e][x].append((order, tuple(entry), tuple(exit_)))
    return T


_TABLES: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def _table_arrays(h: int):
    """``(opts (4, 4, M, 12) int64, count (4, 4))``: :func:`_fractal_table` packed (h >= 3 share one)."""
    key = min(h, 3)
    if key not in _TABLES:
        T = _fractal_table(key)
        M = max(len(T[e][x]) for e in range(4) for x in range(4) if e != x)
        opts = np.zeros((4, 4, M, 12), dtype=np.int64)
        cnt = np.zeros((4, 4), dtype=np.int64)
        for e in range(4):
            for x in range(4):
                for m, (o, en, ex) in enumerate(T[e][x] if e != x else []):
                    opts[e, x, m] = [*o, *en, *ex]
                cnt[e, x] = len(T[e][x]) if e != x else 0
        _TABLES[key] = (opts, cnt)
    return _TABLES[key]


def fractal_sequence(side_log2: int, seed: int) -> np.ndarray:
    """Random fractal-like Hamiltonian path of a square of ``2**side_log2`` grid points a side.

    Parameters
    ----------
    side_log2 : int
        k, the square has side ``2**k`` points (k >= 1).
    seed : int
        Seed of the random choices.

    Returns
    -------
    (4**k, 2) int64
        Grid indices ``(i, j)`` in ``[0, 2**k)``, each once, consecutive ones
        8-neighbours, the polyline without self-intersection.

    Raises
    ------
    ParameterError
        k not a whole number from 1 to 15 (4**15 points), or a bad seed.
    """
    side_log2 = check_count(side_log2, "side_log2", low=1, high=_MAX_SIDE_LOG2)
    rng = np.random.default_rng(np.random.SeedSequence([check_seed(seed), 3]))
    e0 = int(rng.integers(4))
    x0 = int((e0 + rng.integers(1, 4)) % 4)
    bx = np.zeros(1, np.int64)
    by = np.zeros(1, np.int64)
    be = np.array([e0])
    bxit = np.array([x0])
    side = 2**side_log2
    while side > 1:
        h = side // 2
        opts, cnt = _table_arrays(h)
        c = cnt[be, bxit]
        pick = (rng.random(len(be)) * c).astype(np.int64)
        o = opts[be, bxit, pick]  # (n, 12)
        order, entry, exit_ = o[:, 0:4], o[:, 4:8], o[:, 8:12]
        bx = (bx[:, None] + _CORNER[order, 0] * h).ravel()
        by = (by[:, None] + _CORNER[order, 1] * h).ravel()
        be = entry.ravel()
        bxit = exit_.ravel()
        side = h
    return np.stack([bx, by], axis=1)


def hilbert_sequence(side_log2: int, symmetry: int = 0) -> np.ndarray:
    """Hilbert curve through a square of ``2**side_log2`` grid points a side.

    Parameters
    ----------
    side_log2 : int
        k (>= 0).
    symmetry : int
        0..7: one of the square's symmetries applied to the curve
        (bit 0 mirror i, bit 1 mirror j, bit 2 swap i and j).

    Returns
    -------
    (4**k, 2) int64
        Grid indices in curve order.

    Raises
    ------
    ParameterError
        k not a whole number from 0 to 15, or symmetry not 0..7.
    """
    n = 2 ** check_count(side_log2, "side_log2", low=0, high=_MAX_SIDE_LOG2)
    symmetry = check_count(symmetry, "symmetry", low=0, high=7)
    d = np.arange(n * n, dtype=np.int64)
    x = np.zeros_like(d)
    y = np.zeros_like(d)
    t = d.copy()
    s = 1
    while s < n:
        rx = 1 & (t // 2)
        ry = 1 & (t ^ rx)
        # rotate
        flip = (ry == 0) & (rx == 1)
        x = np.where(flip, s - 1 - x, x)
        y = np.where(flip, s - 1 - y, y)
        swap = ry == 0
        x, y = np.where(swap, y, x), np.where(swap, x, y)
        x = x + s * rx
        y = y + s * ry
        t //= 4
        s *= 2
    if symmetry & 1:
        x = n - 1 - x
    if symmetry & 2:
        y = n - 1 - y
    if symmetry & 4:
        x, y = y, x
    return np.stack([x, y], axis=1)


def _square_fit(grid: DwellGrid) -> tuple[np.ndarray, int]:
    lo = grid.ij.min(axis=0)
    ext = int((grid.ij.max(axis=0) - lo).max()) + 1
    k = max(1, int(np.ceil(np.log2(max(ext, 2)))))
    if k > _MAX_SIDE_LOG2:
        raise ParameterError(
            f"The region needs a {2**k} x {2**k} square for a space-filling curve, too large.",
            "Use a larger spacing.",
        )
    return lo, k


def bspline_deviation(points: np.ndarray, pieces=None, samples_per_span: int = 16) -> dict:
    """How far an approximating cubic B-spline (control points = dwell points) stays from them.

    The smoothing of Dong et al.'s fractal-like path does not interpolate: the
    curve of a uniform cubic B-spline with the dwell points as control polygon
    (ends clamped by tripling the end points) passes at
    ``(P[i-1] + 4 P[i] + P[i+1]) / 6`` instead of ``P[i]``. Measured as the
    distance from each dwell point to the nearest point of the curve near it
    (the 4 spans it controls, sampled).

    Parameters
    ----------
    points : (N, d) float64
        Dwell points in path order, mm (d = 2 or 3).
    pieces : (K+1,) int64, optional
        Piece offsets; each piece is its own spline.
    samples_per_span : int
        Curve samples per span.

    Returns
    -------
    dict
        ``dev_max``, ``dev_mean``, ``dev_p95`` (mm), ``share_over_10pct``
        (share of dwell points farther than 10 % of the median step).

    Raises
    ------
    ParameterError
        Points not (N, 2) or (N, 3) finite numbers; pieces not offsets from 0
        to N, non-decreasing; samples_per_span not a whole number >= 1.
    """
    P = check_points(points, "points", cols=(2, 3))
    n = len(P)
    samples_per_span = check_count(samples_per_span, "samples_per_span", low=1, high=10_000)
    pieces = np.asarray([0, n] if pieces is None else pieces)
    if (pieces.ndim != 1 or len(pieces) < 2 or not np.issubdtype(pieces.dtype, np.integer) or pieces[0] != 0
            or pieces[-1] != n or np.any(np.diff(pieces) < 0)):
        raise ParameterError(f"pieces must be whole-number offsets from 0 to {n} (the number of points), "
                             f"non-decreasing, got {pieces!r}.",
                             "Pass the path's piece offsets (PlanarPath.pieces), or None for one piece.")
    pieces = pieces.astype(np.int64)
    devs = []
    steps = []
    t = (np.arange(samples_per_span + 1) / samples_per_span)[:, None]
    b0 = (1 - t) ** 3 / 6
    b1 = (3 * t**3 - 6 * t**2 + 4) / 6
    b2 = (-3 * t**3 + 3 * t**2 + 3 * t + 1) / 6
    b3 = t**3 / 6
    for k in range(len(pieces) - 1):
        Q = P[pieces[k] : pieces[k + 1]]
        m = len(Q)
        if m == 0:
            continue
        if m > 1:
            steps.append(np.linalg.norm(np.diff(Q, axis=0), axis=1))
        if m < 3:
            devs.append(np.zeros(m))
            continue
        C = np.concatenate([Q[:1], Q[:1], Q, Q[-1:], Q[-1:]])  # clamped: curve starts / ends at the ends
        S = len(C) - 3  # spans
        # samples (S, T, d)
        samp = (b0[None] * C[:-3, None] + b1[None] * C[1:-2, None] + b2[None] * C[2:-1, None]
                + b3[None] * C[3:, None])
        # dwell point i (C index i + 2) controls spans i-1 .. i+2 (clipped)
        best = np.full(m, np.inf)
        for off in (-1, 0, 1, 2):
            s_idx = np.arange(m) + off
            ok = (s_idx >= 0) & (s_idx < S)
            dd = np.linalg.norm(samp[s_idx[ok]] - Q[ok, None, :], axis=2).min(axis=1)
            best[ok] = np.minimum(best[ok], dd)
        devs.append(best)
    dev = np.concatenate(devs) if devs else np.zeros(0)
    med = float(np.median(np.concatenate(steps))) if steps else 0.0
    if len(dev) == 0:
        return {"dev_max": 0.0, "dev_mean": 0.0, "dev_p95": 0.0, "share_over_10pct": 0.0}
    return {"dev_max": float(dev.max()), "dev_mean": float(dev.mean()), "dev_p95": float(np.quantile(dev, 0.95)),
            "share_over_10pct": float(np.mean(dev > 0.1 * med)) if med > 0 else 0.0}


def pattern_fractal(grid: DwellGrid, region: Region, *, seed: int, start: int, **options) -> PatternResult:
    """Random fractal-like path (Dong et al.): recursive random quadrant order, clipped to the region.

    Parameters
    ----------
    grid : DwellGrid
    region : Region
    seed : int
    start : int
        Not used (the curve's ends are corners of the bounding square).

    Returns
    -------
    PatternResult
        Dwell points only; a new piece where the curve leaves the region (the
        tool lifts). ``stats``: ``left_out`` (0), ``curve_pieces``,
        ``square_side`` (points), ``smoothing_dev_max`` / ``_mean`` / ``_p95``
        (mm, the published approximating-spline smoothing, planar) and
        ``smoothing`` (what was measured).
    """
    check_options("fractal", options, ())
    seed, start = check_pattern_call(grid, seed, start)
    lo, k = _square_fit(grid)
    seq = fractal_sequence(k, seed) + lo
    order, pieces = clip_grid_sequence(grid, seq, chords=False)
    uv = grid.uv[order]
    dev = bspline_deviation(uv, pieces)
    stats = {"left_out": int(grid.n - len(order)), "square_side": int(2**k),
             "curve_pieces": int(len(pieces) - 1),
             "smoothing": "uniform cubic B-spline, dwell points as control points",
             "smoothing_dev_max": dev["dev_max"], "smoothing_dev_mean": dev["dev_mean"],
             "smoothing_dev_p95": dev["dev_p95"]}
    return PatternResult(uv, grid.ij[order], pieces, True, stats, lattice=grid.lattice)


def pattern_hilbert(grid: DwellGrid, region: Region, *, seed: int, start: int, **options) -> PatternResult:
    """Hilbert curve on the grid's bounding square, clipped to the region.

    Parameters
    ----------
    grid : DwellGrid
    region : Region
    seed : int
        ``seed % 8`` picks the curve's orientation (mirror / swap of the axes).
    start : int
        Not used.

    Returns
    -------
    PatternResult
        Dwell points only; a new piece wherever the curve leaves the region.
        ``stats``: ``left_out`` (0), ``square_side``, ``symmetry``.
    """
    check_options("hilbert", options, ())
    seed, start = check_pattern_call(grid, seed, start)
    lo, k = _square_fit(grid)
    seq = hilbert_sequence(k, int(seed) % 8) + lo
    order, pieces = clip_grid_sequence(grid, seq, chords=False)
    stats = {"left_out": int(grid.n - len(order)), "square_side": int(2**k), "symmetry": int(seed) % 8}
    return PatternResult(grid.uv[order], grid.ij[order], pieces, True, stats, lattice=grid.lattice)
