"""Chord-tolerance segmenting: the G-code's straight blocks from the constant-period machine samples.

The smoothing stage samples the curve at a constant period (4 ms: 0.04 mm at
600 mm/min); one G01 block per sample is ~610 bytes per dwell point. A
controller needs a block only where a straight move would leave the curve or
run the time around a dwell point off its schedule, so consecutive samples are
merged into one block while

(a) **chord**: every replaced sample, and the curve at 1/4, 1/2 and 3/4 of the
    parameter between each two of them (where the smoothing stage checks its own
    chords), stays within ``chord_tol_mm`` of the block's straight move;
(b) **time**: at each region boundary inside the block (the parameter midpoint
    between two dwell points, where one dwell point's stretch ends and the next
    begins, as the smoothing stage defines it) the controller, moving at a
    uniform speed along the block in the block's planned time, passes the
    boundary within ``limit`` seconds of the schedule; ``limit`` is half the
    time tolerance of the shorter of the two regions, so each region's time
    (the difference of its two boundary times) stays within its tolerance;
(c) **dwell points**: every dwell point is a block end (inserted between the
    samples at its curve parameter, exactly the dwell point).

The planned time is linear in the curve parameter between two samples (the
smoothing stage's own measure of the time spent per region,
``np.interp(boundaries, sample_params, times)``), and a block's time is the
sum of the planned times of the samples it replaces, so the block ends keep
the schedule exactly and only the boundaries inside blocks can move.

:func:`block_ends_within_tolerances` is the greedy merge (compiled: it visits
every sample once per block extension); :class:`PieceSegmenter` feeds it one
piece's samples chunk by chunk (streamed writers) and gives the same blocks
whatever the chunk sizes: a block is only closed where the samples after it are
known, the rest waits for the next chunk.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["block_ends_within_tolerances", "PieceSegmenter", "CHECK_FRACTIONS"]

#: where between two samples the curve is checked against a merged block (as the smoothing stage checks its chords)
CHECK_FRACTIONS = np.array([0.25, 0.5, 0.75])


@numba.njit(cache=True)
def _dist_frac(x, y, z, P, a, c):  # pragma: no cover - numba
    """Distance of (x, y, z) from segment P[a]-P[c] and the projection's fraction along it (0..1)."""
    e0, e1, e2 = P[c, 0] - P[a, 0], P[c, 1] - P[a, 1], P[c, 2] - P[a, 2]
    q0, q1, q2 = x - P[a, 0], y - P[a, 1], z - P[a, 2]
    ll = e0 * e0 + e1 * e1 + e2 * e2
    t = 0.0
    if ll > 0.0:
        t = (q0 * e0 + q1 * e1 + q2 * e2) / ll
        t = min(max(t, 0.0), 1.0)
    d0, d1, d2 = q0 - t * e0, q1 - t * e1, q2 - t * e2
    return np.sqrt(d0 * d0 + d1 * d1 + d2 * d2), t


@numba.njit(cache=True)
def _block_fits(P, T, M, bfrac, btime, blim, a, c, tol):  # pragma: no cover - numba
    for i in range(a, c):
        if i > a:
            d, _ = _dist_frac(P[i, 0], P[i, 1], P[i, 2], P, a, c)
            if d > tol:
                return False
        for q in range(M.shape[1]):
            d, _ = _dist_frac(M[i, q, 0], M[i, q, 1], M[i, q, 2], P, a, c)
            if d > tol:
                return False
        f = bfrac[i]
        if f == f:  # a region boundary inside interval i: where the block's uniform motion passes it
            _, lam = _dist_frac(P[i, 0] + f * (P[i + 1, 0] - P[i, 0]), P[i, 1] + f * (P[i + 1, 1] - P[i, 1]),
                                P[i, 2] + f * (P[i + 1, 2] - P[i, 2]), P, a, c)
            if abs(T[a] + lam * (T[c] - T[a]) - btime[i]) > blim[i]:
                return False
    return True


@numba.njit(cache=True)
def block_ends_within_tolerances(P, T, M, must_end, bfrac, btime, blim, tol, horizon, final):  # pragma: no cover
    """Greedy merge of consecutive points into straight blocks within the chord and time tolerances.

    Parameters
    ----------
    P : (n, 3) float64
        Points in path order (samples with the dwell points inserted), mm; ``P[0]`` is a block end.
    T : (n,) float64
        Planned time at each point, s (ascending).
    M : (n - 1, q, 3) float64
        Points of the curve inside each interval ``P[i] - P[i+1]`` (at 1/4, 1/2, 3/4 of its parameter), mm.
    must_end : (n,) bool
        Points that must end a block (dwell points).
    bfrac, btime, blim : (n - 1,) float64
        Per interval: the region boundary inside it, as the fraction of the
        interval (NaN: none), its planned time (s) and how far the block may
        move it (s).
    tol : float
        Chord tolerance, mm.
    horizon : int
        Intervals ``0 .. horizon-1`` are complete (the limits of later ones are
        not known yet); no block is extended past it.
    final : bool
        Whether ``P[-1]`` is the piece's last point (then it ends the last block).

    Returns
    -------
    ends : (k,) int64
        Indices of the block ends after ``P[0]``, ascending. When ``final`` is
        false the last block (from ``ends[-1]``, or 0, onwards) is still open:
        the caller keeps those points and calls again with more.
    """
    n = P.shape[0]
    ends = np.empty(n, np.int64)
    ne = 0
    a = 0
    while a < n - 1:
        if a >= horizon:
            break
        b = a + 1
        open_block = False
        while not must_end[b]:
            if b + 1 > n - 1 or b >= horizon:
                open_block = True
                break
            if not _block_fits(P, T, M, bfrac, btime, blim, a, b + 1, tol):
                break
            b += 1
        if open_block and not final:
            break
        ends[ne] = b
        ne += 1
        a = b
    return ends[:ne]


class PieceSegmenter:
    """One piece's samples, chunk by chunk, to block end points (see the module docstring).

    Parameters
    ----------
    dwell_params : (q,) float
        Curve parameters of the piece's dwell points, ascending.
    dwell_points : (q, 3) float
        The driven dwell points (contact point, or tool centre), mm.
    driven_at : callable
        ``driven_at(u) -> (len(u), 3)``: the driven point of the smooth curve at parameters ``u``.
    chord_tol_mm : float
    time_tol : float
        Fraction of each region's planned time its delivered time may be off by
        merging (the feed resolution's share already taken off by the caller).
    merge : bool
        False: every sample is a block end and no dwell point is inserted (the
        fixed-period G-code).
    """

    def __init__(self, dwell_params, dwell_points, driven_at, chord_tol_mm: float, time_tol: float, merge: bool = True):
        self.dp = np.asarray(dwell_params, dtype=np.float64)
        self.dpts = np.asarray(dwell_points, dtype=np.float64)
        self.bu = 0.5 * (self.dp[1:] + self.dp[:-1])  # region boundaries inside the piece
        self.driven_at = driven_at
        self.tol, self.time_tol, self.merge = float(chord_tol_mm), float(time_tol), bool(merge)
        self.next_dwell = 0
        self.next_bnd = 0
        self.bt = np.zeros(0)  # planned times of the boundaries located so far
        self.lim = np.zeros(0)  # their limits, as far as known
        self.last_contact = None
        self.P = np.zeros((0, 3))
        self.T = np.zeros(0)
        self.U = np.zeros(0)
        self.must = np.zeros(0, bool)
        self.M = np.zeros((0, len(CHECK_FRACTIONS), 3))
        self.bidx = np.zeros(0, np.int64)  # per interval: the boundary in it (-1: none)
        self.bfrac = np.zeros(0)
        self.btime = np.zeros(0)

    # ------------------------------------------------------------------ samples in
    def add(self, contact: np.ndarray, driven: np.ndarray, params: np.ndarray, feed_mm_min: np.ndarray):
        """Take the next samples of the piece; returns the block ends now final: (points, times, params)."""
        contact = np.asarray(contact, dtype=np.float64)
        if len(contact) == 0:
            return self._empty()
        prev = contact[:1] if self.last_contact is None else self.last_contact[None, :]
        steps = np.linalg.norm(np.diff(np.vstack([prev, contact]), axis=0), axis=1)
        dt = steps * 60.0 / np.maximum(np.asarray(feed_mm_min, dtype=np.float64), 1e-300)
        t0 = self.T[-1] if len(self.T) else 0.0
        times = np.cumsum(np.concatenate([[t0], dt]))[1:]
        self.last_contact = contact[-1].copy()
        P, T, U = np.asarray(driven, dtype=np.float64), times, np.asarray(params, dtype=np.float64)
        must = np.zeros(len(P), bool)
        if self.merge:
            P, T, U, must = self._insert_dwell_points(P, T, U, must)
        self._append(P, T, U, must)
        return self._run(final=False)

    def finish(self):
        """The piece's last block ends (its last point ends a block)."""
        if len(self.P) == 0:
            return self._empty()
        self.must[-1] = True
        self.next_dwell = len(self.dp)
        if self.merge:
            # the last region ends at the piece's end: the last boundary's limit is known now
            self._limits(end_time=float(self.T[-1]))
        return self._run(final=True)

    # ------------------------------------------------------------------ internals
    @staticmethod
    def _empty():
        return np.zeros((0, 3)), np.zeros(0), np.zeros(0)

    def _insert_dwell_points(self, P, T, U, must):
        has_prev = len(self.U) > 0
        us = np.concatenate([self.U[-1:], U]) if has_prev else U
        ts = np.concatenate([self.T[-1:], T]) if has_prev else T
        j0 = self.next_dwell
        j1 = j0
        while j1 < len(self.dp) and self.dp[j1] < us[-1]:
            j1 += 1
        self.next_dwell = j1
        if j1 == j0:
            return P, T, U, must
        d = self.dp[j0:j1]
        k = np.searchsorted(us, d, side="right") - 1  # interval of us holding each dwell param
        at_sample = (k < 0) | (us[np.maximum(k, 0)] == d)
        off = 1 if has_prev else 0
        # a dwell point at (or before) a sample's parameter marks that sample; the others are inserted
        hit = np.maximum(k[at_sample], 0) - off
        if np.any(hit < 0):  # the buffer's last point (a sample already there)
            self.must[-1] = True
        must[hit[hit >= 0]] = True
        ins = ~at_sample
        if np.any(ins):
            ki = k[ins]
            f = (d[ins] - us[ki]) / (us[ki + 1] - us[ki])
            ti = ts[ki] + f * (ts[ki + 1] - ts[ki])
            pos = ki + 1 - off  # insert before this index of the new arrays
            P = np.insert(P, pos, self.dpts[j0:j1][ins], axis=0)
            T = np.insert(T, pos, ti)
            U = np.insert(U, pos, d[ins])
            must = np.insert(must, pos, True)
        return P, T, U, must

    def _append(self, P, T, U, must):
        n0 = len(self.P)
        self.P = np.concatenate([self.P, P])
        self.T = np.concatenate([self.T, T])
        self.U = np.concatenate([self.U, U])
        self.must = np.concatenate([self.must, must])
        a = max(n0 - 1, 0)  # first new interval
        ua, ub = self.U[a:-1], self.U[a + 1:]
        if len(ua) == 0:
            return
        q = len(CHECK_FRACTIONS)
        if self.merge:
            uq = (ua[:, None] + CHECK_FRACTIONS[None, :] * (ub - ua)[:, None]).ravel()
            mids = self.driven_at(uq).reshape(len(ua), q, 3)
        else:
            mids = np.zeros((len(ua), q, 3))
        bidx = np.full(len(ua), -1, np.int64)
        bfrac = np.full(len(ua), np.nan)
        btime = np.zeros(len(ua))
        if self.merge:
            j0 = self.next_bnd
            j1 = j0 + int(np.searchsorted(self.bu[j0:], self.U[-1], side="left"))
            self.next_bnd = j1
            if j1 > j0:
                m = self.bu[j0:j1]
                i = np.clip(np.searchsorted(self.U, m, side="right") - 1, a, len(self.U) - 2)
                f = (m - self.U[i]) / (self.U[i + 1] - self.U[i])
                tb = self.T[i] + f * (self.T[i + 1] - self.T[i])
                bidx[i - a] = np.arange(j0, j1)
                bfrac[i - a] = f
                btime[i - a] = tb
                self.bt = np.concatenate([self.bt, tb])
                self._limits()
        self.M = np.concatenate([self.M, mids])
        self.bidx = np.concatenate([self.bidx, bidx])
        self.bfrac = np.concatenate([self.bfrac, bfrac])
        self.btime = np.concatenate([self.btime, btime])

    def _limits(self, end_time: float | None = None):
        """Limits of the boundaries whose two regions' planned times are known."""
        bt = self.bt
        j0, j1 = len(self.lim), (len(bt) - 1 if end_time is None else len(bt))
        if j1 <= j0:
            return
        edges = np.concatenate([[0.0], bt, [] if end_time is None else [end_time]])  # region k: edges[k]..edges[k+1]
        region = np.diff(edges)
        j = np.arange(j0, j1)
        self.lim = np.concatenate([self.lim, 0.5 * self.time_tol * np.minimum(region[j], region[j + 1])])

    def _run(self, final: bool):
        n = len(self.P)
        if self.merge:
            lim = np.concatenate([self.lim, np.full(len(self.bu) - len(self.lim), np.nan)])
            blim = np.where(self.bidx >= 0, lim[np.maximum(self.bidx, 0)] if len(lim) else np.nan, 0.0)
            unknown = np.flatnonzero(np.isnan(blim))
            horizon = int(unknown[0]) if len(unknown) else n - 1
            ends = block_ends_within_tolerances(self.P, self.T, self.M, self.must, self.bfrac, self.btime, blim,
                                                self.tol, horizon, final)
        else:
            ends = np.arange(1, n, dtype=np.int64)
        out = self.P[ends], self.T[ends], self.U[ends]
        last = int(ends[-1]) if len(ends) else 0
        if final:
            last = n - 1
        self._drop(last)
        return out

    def _drop(self, k: int):
        """Keep the points from index k (the last block end) on."""
        if k <= 0:
            return
        self.P, self.T, self.U, self.must = self.P[k:], self.T[k:], self.U[k:], self.must[k:]
        self.M, self.bidx, self.bfrac, self.btime = self.M[k:], self.bidx[k:], self.bfrac[k:], self.btime[k:]
