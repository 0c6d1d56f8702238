"""Chord-tolerance segmenting: the G-code's blocks (lines and helical arcs) from the constant-period samples.

The smoothing stage samples the curve at a constant period (4 ms: 0.04 mm at
600 mm/min); one G01 block per sample is ~610 bytes per dwell point. A
controller needs a block only where one straight move or one helical arc
would leave the curve or run the time around a dwell point off its schedule,
so consecutive samples are merged into one block while

(a) **chord**: every replaced sample, and the curve at 1/4, 1/2 and 3/4 of the
    parameter between each two of them (where the smoothing stage checks its own
    chords), stays within ``chord_tol_mm`` of the block in 3D;
(b) **time**: at each region boundary inside the block (the parameter midpoint
    between two dwell points, where one dwell point's stretch ends and the next
    begins, as the smoothing stage defines it) the controller, moving at a
    uniform speed along the block in the block's planned time, passes the
    boundary within ``limit`` seconds of the schedule; ``limit`` is half the
    time tolerance of the shorter of the two regions, so each region's time
    (the difference of its two boundary times) stays within its tolerance;
(c) **dwell points**: every dwell point is on the path (inserted between the
    samples at its curve parameter, exactly the dwell point): a block end, or
    (unless ``dwell_block_ends``) the one dwell point inside a block that lies
    on it to 1e-9 mm (:mod:`.blockfit`).

The fit itself (lines, arcs, the search for the fewest blocks per dwell
interval) is :mod:`polishpath.export.blockfit`. The planned time is linear in
the curve parameter between two samples (the smoothing stage's own measure of
the time spent per region, ``np.interp(boundaries, sample_params, times)``),
and a block's time is the sum of the planned times of the samples it replaces,
so the block ends keep the schedule exactly and only the boundaries inside
blocks can move.

:class:`PieceSegmenter` feeds one piece's samples to it chunk by chunk
(streamed writers) and gives the same blocks whatever the chunk sizes: a
dwell interval is segmented once all of its samples (and the time limits of
the boundaries in it) are known; the rest waits for the next chunk.
"""

from __future__ import annotations

import math

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

from .blockfit import (BFRAC, BLIM, BTIME, CHECK_FRACTIONS, DWELL, INS, MDONE, MUST, NBCOL, NCOL, PX, TT, UU, WX,
                       segment_intervals)

__all__ = ["PieceSegmenter", "CHECK_FRACTIONS", "merge_dwell_points", "rotary_block_ends"]


@numba.njit(cache=True)
def merge_dwell_points(F0, B0, contact, driven, params, feed, last_contact, dwell_u, dwell_pts, j0, merge,
                       scale):  # pragma: no cover - numba
    """The buffer's points then the chunk's, its dwell points inserted, with their planned times.

    Parameters
    ----------
    F0, B0 : (n0, NCOL) float64 and (n0, NBCOL) bool
        The points kept from before (the open dwell interval; see :mod:`.blockfit` for the columns).
    contact, driven : (m, 3) float64
        Contact points (for the times) and driven points (written) of the chunk's samples, mm.
    params, feed : (m,) float64
        Curve parameters and feeds (mm/min) of the samples.
    last_contact : (3,) float64
        The piece's previous contact sample (when ``n0 > 0``).
    dwell_u, dwell_pts : (q,) and (q, 3) float64
        The piece's dwell parameters (ascending) and driven dwell points; ``j0`` the first not yet placed.
    merge : bool
        False: no dwell point is inserted (the fixed period).
    scale : float
        10^decimals: the written (rounded) coordinates are ``rint(x * scale) / scale``, as ``np.round``.

    Returns
    -------
    F, B : (n0 + m', NCOL) and (n0 + m', NBCOL)
        Every column set but the region boundaries' (BFRAC NaN, BTIME and BLIM 0); a dwell point at a
        sample's parameter marks that sample (or the previous point) as a block end.
    j1 : int
        The first dwell point not yet placed (at or after the chunk's last parameter).
    """
    m = params.shape[0]
    n0 = F0.shape[0]
    q = dwell_u.shape[0]
    j1 = j0
    if merge:
        while j1 < q and dwell_u[j1] < params[m - 1]:
            j1 += 1
    cap = n0 + m + (j1 - j0)
    F = np.empty((cap, NCOL))
    B = np.zeros((cap, NBCOL), np.bool_)
    F[:n0] = F0
    B[:n0] = B0
    has_prev = n0 > 0
    t = F0[n0 - 1, TT] if has_prev else 0.0
    if has_prev:
        px, py, pz = last_contact[0], last_contact[1], last_contact[2]
    else:
        px, py, pz = contact[0, 0], contact[0, 1], contact[0, 2]
    ua = F0[n0 - 1, UU] if has_prev else 0.0
    ta = t
    j = j0
    o = n0
    for i in range(m):
        dx, dy, dz = contact[i, 0] - px, contact[i, 1] - py, contact[i, 2] - pz
        t += math.sqrt(dx * dx + dy * dy + dz * dz) * 60.0 / max(feed[i], 1e-300)
        px, py, pz = contact[i, 0], contact[i, 1], contact[i, 2]
        here = False
        while j < j1 and dwell_u[j] <= params[i]:
            d = dwell_u[j]
            j += 1
            if d == params[i] or (i == 0 and not has_prev):
                here = True  # a sample at the dwell parameter (or the piece's first point) marks it
            elif i == 0 and d <= ua:
                B[n0 - 1, MUST] = True
                B[n0 - 1, DWELL] = True
            else:
                f = (d - ua) / (params[i] - ua)
                _put(F, B, o, dwell_pts[j - 1, 0], dwell_pts[j - 1, 1], dwell_pts[j - 1, 2], ta + f * (t - ta), d,
                     True, True, scale)
                o += 1
        _put(F, B, o, driven[i, 0], driven[i, 1], driven[i, 2], t, params[i], here, False, scale)
        B[o, DWELL] = here and (i > 0 or has_prev)  # a dwell point at a sample (not the piece's first point)
        o += 1
        ua, ta = params[i], t
    return F[:o], B[:o], j1


@numba.njit(cache=True, inline="always")
def _put(F, B, o, x, y, z, t, u, must, inserted, scale):  # pragma: no cover - numba
    F[o, PX] = x
    F[o, PX + 1] = y
    F[o, PX + 2] = z
    F[o, WX] = np.rint(x * scale) / scale + 0.0
    F[o, WX + 1] = np.rint(y * scale) / scale + 0.0
    F[o, WX + 2] = np.rint(z * scale) / scale + 0.0
    F[o, TT] = t
    F[o, UU] = u
    F[o, BFRAC] = np.nan
    F[o, BTIME] = 0.0
    F[o, BLIM] = 0.0
    B[o, MUST] = must
    B[o, INS] = inserted
    B[o, MDONE] = False
    B[o, DWELL] = inserted


class PieceSegmenter:
    """One piece's samples, chunk by chunk, to block ends (see the module docstring).

    Parameters
    ----------
    dwell_params : (q,) float
        Curve parameters of the piece's dwell points, ascending.
    dwell_points : (q, 3) float
        The driven dwell points (contact point, or tool centre), mm.
    curve : tuple
        ``(breaks, coeffs, all_dwell_params, all_dwell_normals, radius)``: the curve's span polynomials
        (:func:`polishpath.smooth.nurbs.span_polynomials`), every dwell parameter and unit normal of the
        path and the tool radius (mm): the driven curve at a parameter is the curve moved ``radius``
        along the interpolated normal.
    chord_tol_mm : float
    time_tol : float
        Fraction of each region's planned time its delivered time may be off by
        merging (the feed resolution's share already taken off by the caller).
    merge : bool
        False: every sample is a block end and no dwell point is inserted (the
        fixed-period G-code).
    arcs : bool
        Whether helical arcs (G02/G03) may be used beside straight blocks.
    resolution_mm : float
        The coordinate resolution the blocks are written at (the arcs' rounding check).
    smooth_tol_mm : float or None
        The smoothing stage's chord tolerance: the curve between two of its samples is within it of their
        chord at the check fractions (None, or a tool radius: not known, every check point is evaluated).
    dwell_block_ends : bool
        True: every dwell point ends a block. False (default): a block may pass through a dwell point that
        lies on it to :data:`~polishpath.export.blockfit.ON_PATH_MM` (1e-9 mm) before rounding and within
        the coordinate resolution as written (:mod:`.blockfit`).
    """

    def __init__(self, dwell_params, dwell_points, curve, chord_tol_mm: float, time_tol: float, merge: bool = True,
                 arcs: bool = False, resolution_mm: float = 1e-4, smooth_tol_mm: float | None = None,
                 dwell_block_ends: bool = True):
        self.dp = np.ascontiguousarray(dwell_params, dtype=np.float64)
        self.dpts = np.ascontiguousarray(dwell_points, dtype=np.float64)
        self.bu = 0.5 * (self.dp[1:] + self.dp[:-1])  # region boundaries inside the piece
        self.curve, self.radius = tuple(curve[:4]), float(curve[4])
        self.tol, self.time_tol, self.merge = float(chord_tol_mm), float(time_tol), bool(merge)
        self.arcs, self.res = bool(arcs) and self.merge, float(resolution_mm)
        self.through = self.merge and not dwell_block_ends
        self.decimals = int(round(-math.log10(self.res)))
        self.e_s = (float(smooth_tol_mm) * (1 + 1e-6) + 1e-12) if smooth_tol_mm and self.radius == 0 else math.inf
        self.next_dwell = 0
        self.next_bnd = 0
        self.bt = np.full(len(self.bu), np.nan)  # planned times of the boundaries (located: the first n_bt)
        self.lim = np.full(len(self.bu), np.nan)  # their limits (known: the first n_lim)
        self.n_bt = 0
        self.n_lim = 0
        self.last_contact = np.zeros(3)
        self.F = np.zeros((0, NCOL))  # per point: see blockfit (driven point, as written, time, parameter, ...)
        self.B = np.zeros((0, NBCOL), bool)  # per point: a block end, inserted, check points evaluated, a dwell point
        self.bidx = np.zeros(0, np.int64)  # per interval (row of its first point): the boundary in it (-1: none)

    # ------------------------------------------------------------------ samples in
    def add(self, contact: np.ndarray, driven: np.ndarray, params: np.ndarray, feed_mm_min: np.ndarray):
        """Take the next samples of the piece; returns the block ends now final: (points, times, params, kinds, ij,
        centres) (centres: an arc's fitted centre before rounding, NaN for a line)."""
        contact = np.ascontiguousarray(contact, dtype=np.float64)
        if len(contact) == 0:
            return self._empty()
        n0 = len(self.F)
        self.F, self.B, self.next_dwell = merge_dwell_points(
            self.F, self.B, contact, np.ascontiguousarray(driven, dtype=np.float64),
            np.ascontiguousarray(params, dtype=np.float64), np.ascontiguousarray(feed_mm_min, dtype=np.float64),
            self.last_contact, self.dp, self.dpts, self.next_dwell, self.merge, 10.0 ** self.decimals)
        self.last_contact = contact[-1].copy()
        self._boundaries(n0)
        return self._run(final=False)

    def finish(self):
        """The piece's last block ends (its last point ends a block)."""
        if len(self.F) == 0:
            return self._empty()
        self.B[-1, MUST] = True
        self.next_dwell = len(self.dp)
        if self.merge:
            # the last region ends at the piece's end: the last boundary's limit is known now
            self._limits(end_time=float(self.F[-1, TT]))
        return self._run(final=True)

    # ------------------------------------------------------------------ internals
    @staticmethod
    def _empty():
        return np.zeros((0, 3)), np.zeros(0), np.zeros(0), np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros((0, 2))

    def _boundaries(self, n0: int):
        """Place the region boundaries in the intervals from point n0 - 1 on (fraction, planned time)."""
        self.bidx = np.concatenate([self.bidx, np.full(len(self.F) - n0, -1, np.int64)])
        a = max(n0 - 1, 0)  # first new interval
        if not self.merge or len(self.F) - 1 - a <= 0:
            return
        U = self.F[:, UU]
        j0 = self.next_bnd
        j1 = j0 + int(np.searchsorted(self.bu[j0:], U[-1], side="left"))
        self.next_bnd = j1
        if j1 > j0:
            m = self.bu[j0:j1]
            i = np.clip(np.searchsorted(U, m, side="right") - 1, a, len(U) - 2)
            f = (m - U[i]) / (U[i + 1] - U[i])
            T = self.F[:, TT]
            tb = T[i] + f * (T[i + 1] - T[i])
            self.bidx[i] = np.arange(j0, j1)
            self.F[i, BFRAC] = f
            self.F[i, BTIME] = tb
            self.bt[j0:j1] = tb
            self.n_bt = j1
            self._limits()

    def _limits(self, end_time: float | None = None):
        """Limits of the boundaries whose two regions' planned times are known (region k: boundary k-1 to k)."""
        j0, j1 = self.n_lim, (self.n_bt - 1 if end_time is None else self.n_bt)
        if j1 <= j0:
            return
        bt = self.bt
        j = np.arange(j0, j1)
        before = bt[j] - np.where(j > 0, bt[np.maximum(j - 1, 0)], 0.0)
        after = (bt[np.minimum(j + 1, len(bt) - 1)] if end_time is None else
                 np.where(j + 1 < self.n_bt, bt[np.minimum(j + 1, len(bt) - 1)], end_time)) - bt[j]
        self.lim[j0:j1] = 0.5 * self.time_tol * np.minimum(before, after)
        self.n_lim = j1

    def _run(self, final: bool):
        n = len(self.F)
        if self.merge:
            has = self.bidx >= 0
            blim = np.zeros(n)
            blim[has] = self.lim[self.bidx[has]]  # NaN where not known yet
            self.F[:, BLIM] = blim
            unknown = np.flatnonzero(np.isnan(blim[:-1]))
            horizon = int(unknown[0]) if len(unknown) else n - 1
            ends, kinds, ij, centres = segment_intervals(self.F, self.B, self.curve, float(self.radius), self.tol,
                                                         self.e_s, self.res, self.arcs, horizon, final, self.through)
        else:
            ends = np.arange(1, n, dtype=np.int64)
            kinds, ij, centres = np.ones(n - 1, np.int64), np.zeros((n - 1, 2)), np.full((n - 1, 2), np.nan)
        out = self.F[ends, PX:PX + 3], self.F[ends, TT], self.F[ends, UU], kinds, ij, centres
        last = int(ends[-1]) if len(ends) else 0
        if final:
            last = n - 1
        self._drop(last)
        return out

    def _drop(self, k: int):
        """Keep the points from index k (the last block end) on."""
        if k <= 0:
            return
        self.F, self.B, self.bidx = self.F[k:], self.B[k:], self.bidx[k:]


def rotary_block_ends(P: np.ndarray, T: np.ndarray, V: np.ndarray, Q: np.ndarray, must: np.ndarray, chord_tol_mm: float,
                      orientation_tol_deg: float, axes_from_coords) -> np.ndarray:
    """The block ends of a 5-axis stretch: straight blocks under a chord and an orientation tolerance.

    Point 0 is where the stretch starts (the last block end written); a block from point i to point j
    replaces the points between them when each point k lies within ``chord_tol_mm`` of the block at the
    share ``(T_k - T_i) / (T_j - T_i)`` of its time (the controller runs a block at a uniform pace), and
    the tool axis the controller makes there from the orientation words interpolated linearly at that
    share (``axes_from_coords``) is within ``orientation_tol_deg`` of the planned axis ``V_k``. Greedy:
    each block is the longest that holds (doubling, then bisection, on the end), never passing a
    ``must`` point (a dwell point). Vectorised per trial (the orientation words are the post's: the
    hook of :meth:`polishpath.export.post.base.PostProcessor.axes_from_coords`), not compiled.

    Parameters
    ----------
    P : (n, 3) float
        Driven points, mm.
    T : (n,) float
        Planned times, s, non-decreasing.
    V : (n, 3) float
        Planned unit tool axes.
    Q : (n, r) float
        Orientation words (what the controller interpolates linearly).
    must : (n,) bool
        Points that must be block ends (the last point always is).

    Returns
    -------
    (b,) int64
        Indices of the block ends, ascending, the last point last (point 0 not included).
    """
    n = len(T)
    cos_tol = math.cos(math.radians(orientation_tol_deg))
    musts = np.flatnonzero(np.asarray(must, bool)[1:]) + 1
    if n < 2:
        return np.zeros(0, np.int64)
    if not len(musts) or musts[-1] != n - 1:
        musts = np.append(musts, n - 1)

    def holds(i: int, j: int) -> bool:
        if j <= i + 1:
            return True
        k = slice(i + 1, j)
        span = T[j] - T[i]
        s = (T[k] - T[i]) / span if span > 0 else np.zeros(j - i - 1)
        pos = P[i] + s[:, None] * (P[j] - P[i])
        if np.any(np.sum((pos - P[k]) ** 2, axis=1) > chord_tol_mm * chord_tol_mm):
            return False
        ax = axes_from_coords(Q[i] + s[:, None] * (Q[j] - Q[i]))
        return bool(np.all(np.sum(ax * V[k], axis=1) >= cos_tol * np.linalg.norm(V[k], axis=1)))

    ends = []
    i = 0
    while i < n - 1:
        lim = int(musts[np.searchsorted(musts, i, side="right")])
        good, step = i + 1, 1
        bad = None
        while good < lim:
            cand = min(good + step, lim)
            if holds(i, cand):
                good, step = cand, step * 2
            else:
                bad = cand
                break
        if bad is not None:
            while bad - good > 1:
                mid = (good + bad) // 2
                if holds(i, mid):
                    good = mid
                else:
                    bad = mid
        ends.append(good)
        i = good
    return np.asarray(ends, np.int64)
