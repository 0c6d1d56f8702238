"""Modal motion blocks of one piece, streamed: G01 lines and G02/G03 helical arcs, feeds (G94 or G93), words.

The piece's samples arrive chunk by chunk (:class:`~polishpath.export.chunks.SampleChunk`);
:class:`~polishpath.export.segment.PieceSegmenter` turns them into block ends
(chord-tolerance segmenting, every dwell point a block end or on a block; lines, or
arcs with their incremental centre), and this module writes them as modal blocks:

* coordinates rounded to ``decimals`` (4: 0.1 um); a straight block whose
  written point equals the previous one is merged into the next (its time goes
  with it); an arc is never that short (:data:`~polishpath.export.blockfit.MIN_ARC_MM`);
* the motion word (``G1``, ``G2`` clockwise, ``G3`` counter-clockwise, XY plane
  G17) only where it changes (the approach move's ``G01`` is in force at the
  start), the axis words that changed only (``X Y Z`` are modal);
* an arc in **radius form** (``R``, one word; ``radius_arcs``) where the centre the controller derives
  from the written end points and R puts the written arc within one resolution (beyond the end points'
  own rounding) of the fitted one at 1/4, 1/2 and 3/4 of it, and the arc turns less than a half circle
  (a positive R is the shorter arc: LinuxCNC's and Fanuc's rule); else its centre ``I J`` from its start
  (incremental, LinuxCNC's and Fanuc's default; not modal) as the segmenter rounded and checked it;
* **incremental words** (``incremental``): inside a piece the axis words are G91 distances from the
  previous block's written end, each the difference of two positions rounded to the resolution (so no
  rounding accumulates: the absolute position after any block is the rounded planned one), with a G90
  block of absolute words every ``anchor_blocks`` blocks and as the piece's last block (the approach and
  retract moves around a piece are absolute): a program restarted at a G90 block starts from a known
  position. ``G90`` / ``G91`` (modal group 3) are written only where they change, in the block itself;
* G94: ``F`` (the written block's length -- a line's, or the helix's -- over
  its planned time, mm/min) only where it differs from the F in force by more
  than ``feed_resolution`` of it; a block without F runs at the F in force, so
  its time is off by at most that fraction. G93 (inverse time): ``F`` = 1 /
  minutes of the block on every block (F is not modal in G93).
"""

from __future__ import annotations

import math

import numba
from ... import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

from ..blockfit import CCW, LINE, written_arc_lengths
from ..segment import PieceSegmenter
from ..textfmt import KEEP_POINT, NO_TRAILING_ZEROS, format_fixed

__all__ = ["BlockMotion", "modal_feed_words", "round_feeds", "radius_form"]


def round_feeds(feed: np.ndarray, decimals: int | None, resolution: float) -> np.ndarray:
    """F as written: to ``decimals`` digits, or (None) to the digits ``resolution`` needs.

    None: each F is rounded to the largest power of ten ``q`` with ``q / 2 <= resolution x F``
    (``q = 10^floor(log10(2 resolution F))``: at 0.1 %, F300.4, F577, F5430), so the F the controller reads
    is within ``resolution`` of the block's own feed. ``feed`` (k,) > 0, mm/min (or 1/min in G93).
    """
    f = np.asarray(feed, dtype=np.float64)
    if decimals is not None:
        return np.round(f, decimals) + 0.0
    e = np.floor(np.log10(np.maximum(2.0 * resolution * f, 1e-300)))
    up = 10.0 ** np.maximum(-e, 0.0)  # as np.round: rint(f * 10^d) / 10^d (the double nearest the decimal)
    down = 10.0 ** np.maximum(e, 0.0)
    return np.rint(f * up / down) * down / up + 0.0


@numba.njit(cache=True)
def modal_feed_words(feed, written, in_force, resolution):  # pragma: no cover - numba
    """Which blocks write their F, and the F each block runs at.

    Parameters
    ----------
    feed : (k,) float64
        Each block's own feed, mm/min (its written length over its planned time).
    written : (k,) float64
        The same as F would write it (rounded, :func:`round_feeds`).
    in_force : float
        The F in force before the first block (0: none).
    resolution : float
        A block writes its F when it differs from the F in force by more than this fraction of it.

    Returns
    -------
    write : (k,) bool
    runs_at : (k,) float64
        The F in force during each block.
    """
    k = feed.shape[0]
    write = np.zeros(k, np.bool_)
    runs = np.empty(k)
    f = in_force
    for i in range(k):
        if f <= 0.0 or abs(feed[i] - f) > resolution * f:
            f = written[i]
            write[i] = True
        runs[i] = f
    return write, runs


#: most an arc in radius form may turn, rad: a positive R is the shorter arc, and the centre the controller
#: derives from R moves by 1 / cos(sweep / 2) per unit of R near a half circle (the check below decides)
MAX_RADIUS_FORM_SWEEP = 0.95 * math.pi


@numba.njit(cache=True)
def _turn(sgn, ax, ay, bx, by):  # pragma: no cover - numba
    ph = math.atan2(sgn * (ax * by - ay * bx), ax * bx + ay * by)
    if ph <= 0.0:
        ph += 2.0 * math.pi
    return ph


@numba.njit(cache=True)
def radius_form(prev, W, p0, p1, kinds, centres, ij, dw, res):  # pragma: no cover - numba
    """Which arcs to write with ``R`` instead of ``I J``, their R and the centre the controller then uses.

    Parameters
    ----------
    prev, W : (k, 3) float64
        Each block's written start and end (rounded to ``res``), mm.
    p0, p1 : (k, 3) float64
        The same before rounding (the fitted arc's ends), mm.
    kinds : (k,) int64
        ``LINE``, ``CW`` or ``CCW``.
    centres : (k, 2) float64
        An arc's fitted centre (NaN: a line), mm.
    ij : (k, 2) float64
        An arc's written incremental centre (the I J form), mm.
    dw : (k, 3) float64
        The dwell point a block passes through (NaN: none): the arc as written must pass it within ``res``
        (at its angle's fraction of the fitted arc), as the I J form was checked to.
    res : float
        Coordinate resolution, mm.

    Returns
    -------
    use_r : (k,) bool
        The arc is written ``R`` (it turns less than :data:`MAX_RADIUS_FORM_SWEEP`, and the arc the
        controller runs from the written ends and R is within ``res`` -- beyond the end points' own
        rounding -- of the fitted arc at 1/4, 1/2 and 3/4 of it, the check the I J form passed).
    r : (k,) float64
        R as written (rounded to ``res``), mm.
    ij_run : (k, 2) float64
        The centre the controller runs each arc about, from its written start (``ij``, or the one R gives).
    """
    k = W.shape[0]
    use_r = np.zeros(k, np.bool_)
    r = np.zeros(k)
    ij_run = ij.copy()
    for i in range(k):
        if kinds[i] == LINE or not centres[i, 0] == centres[i, 0]:
            continue
        sgn = 1.0 if kinds[i] == CCW else -1.0
        ox, oy = centres[i, 0], centres[i, 1]
        R = math.sqrt((p1[i, 0] - ox) ** 2 + (p1[i, 1] - oy) ** 2)
        D = _turn(sgn, p0[i, 0] - ox, p0[i, 1] - oy, p1[i, 0] - ox, p1[i, 1] - oy)
        if not D < MAX_RADIUS_FORM_SWEEP:
            continue
        Rw = np.rint(R / res) * res
        dx, dy = W[i, 0] - prev[i, 0], W[i, 1] - prev[i, 1]
        c = math.sqrt(dx * dx + dy * dy)
        if not (c > 0.0 and 0.5 * c < Rw):
            continue
        h = math.sqrt(Rw * Rw - 0.25 * c * c)
        # the shorter arc turning sgn: its centre lies to that side of the chord
        wox = 0.5 * (prev[i, 0] + W[i, 0]) - sgn * h * dy / c
        woy = 0.5 * (prev[i, 1] + W[i, 1]) + sgn * h * dx / c
        wsx, wsy = prev[i, 0] - wox, prev[i, 1] - woy
        Dw = _turn(sgn, wsx, wsy, W[i, 0] - wox, W[i, 1] - woy)
        shift = max(math.sqrt((prev[i, 0] - p0[i, 0]) ** 2 + (prev[i, 1] - p0[i, 1]) ** 2
                              + (prev[i, 2] - p0[i, 2]) ** 2),
                    math.sqrt((W[i, 0] - p1[i, 0]) ** 2 + (W[i, 1] - p1[i, 1]) ** 2 + (W[i, 2] - p1[i, 2]) ** 2))
        th0 = math.atan2(p0[i, 1] - oy, p0[i, 0] - ox)
        thw = math.atan2(wsy, wsx)
        ok = True
        for q in range(1, 4):
            lam = 0.25 * q
            th = th0 + sgn * lam * D
            tw = thw + sgn * lam * Dw
            e0 = wox + Rw * math.cos(tw) - (ox + R * math.cos(th))
            e1 = woy + Rw * math.sin(tw) - (oy + R * math.sin(th))
            e2 = prev[i, 2] + lam * (W[i, 2] - prev[i, 2]) - (p0[i, 2] + lam * (p1[i, 2] - p0[i, 2]))
            if math.sqrt(e0 * e0 + e1 * e1 + e2 * e2) > shift + res:
                ok = False
                break
        if ok and dw[i, 0] == dw[i, 0]:
            lam = _turn(sgn, p0[i, 0] - ox, p0[i, 1] - oy, dw[i, 0] - ox, dw[i, 1] - oy) / D
            tw = thw + sgn * lam * Dw
            e0 = wox + Rw * math.cos(tw) - dw[i, 0]
            e1 = woy + Rw * math.sin(tw) - dw[i, 1]
            e2 = prev[i, 2] + lam * (W[i, 2] - prev[i, 2]) - dw[i, 2]
            ok = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2) <= res
        if ok:
            use_r[i] = True
            r[i] = Rw
            ij_run[i, 0] = wox - prev[i, 0]
            ij_run[i, 1] = woy - prev[i, 1]
    return use_r, r, ij_run


class BlockMotion:
    """The motion blocks of one piece; ``start``, ``add`` per chunk, ``finish``.

    Parameters
    ----------
    segmenter : PieceSegmenter
    write : callable
        ``write(bytes)`` into the program.
    decimals : int
    feed_decimals : int or None
        Digits of F; None: the digits ``feed_resolution`` needs (:func:`round_feeds`).
    inverse_time : bool
        G93 (F = 1/minutes on every block) or G94 (F in mm/min, modal).
    feed_resolution : float
        G94: fraction by which F may differ from the F in force before it is written again.
    feed_in_force : float
        F in force before the first block (the approach feed), mm/min.
    sep : str
        Between the words of a block ("" or " ").
    styles : int
        :mod:`~polishpath.export.textfmt` number style bits of the axis words (X Y Z I J R); F drops its
        trailing zeros when ``feed_decimals`` is None.
    radius_arcs : bool
        Arcs in radius form (``R``) where it is exact to the resolution (:func:`radius_form`), else ``I J``.
    incremental : bool
        G91 axis words inside the piece, a G90 block every ``anchor_blocks`` blocks and as the last one.
    anchor_blocks : int
        Blocks from one G90 (absolute) block to the next, with ``incremental``.
    """

    def __init__(self, segmenter: PieceSegmenter, write, *, decimals: int, feed_decimals: int, inverse_time: bool,
                 feed_resolution: float, feed_in_force: float, sep: str = " ", styles: int = 0,
                 radius_arcs: bool = False, incremental: bool = False, anchor_blocks: int = 500):
        self.seg, self.write = segmenter, write
        self.d, self.fd = int(decimals), (None if feed_decimals is None else int(feed_decimals))
        self.sep, self.styles = sep, int(styles)
        self.inverse_time, self.res = bool(inverse_time), float(feed_resolution)
        self.f_force = float(feed_in_force)
        self.radius_arcs, self.incremental, self.anchor = bool(radius_arcs), bool(incremental), int(anchor_blocks)
        self.mode = LINE  # the approach's G01 is in force
        self.distance = 90  # G90 is in force (the approach's absolute words)
        self.w_prev = None  # last written point (rounded), mm
        self.p_prev = None  # the same before rounding (the fitted blocks' end), mm
        self.w_seen = None  # rounded last block end seen (written or merged)
        self.p_seen = None
        self.u_seen = None  # the curve parameter there
        self.t_written = 0.0  # planned time at the last written point, s
        self.t_latest = 0.0
        self.held = None  # (w, t, kind, ij, centre, p, p_start, u_start, u): the last kept block, written once the
        # next is known
        self.seconds = 0.0  # the controller's time of the written blocks, s
        self.blocks = 0
        self.arcs = 0
        self.radius_arc_blocks = 0
        self.anchors = 0
        self.after_anchor = False  # the last block written was a G90 anchor

    def start(self, first_point: np.ndarray) -> None:
        """The piece's first driven point (where the approach move ends)."""
        p = np.asarray(first_point, dtype=np.float64)
        self.w_prev = np.round(p, self.d) + 0.0
        self.w_seen = self.w_prev
        self.p_prev = self.p_seen = p.copy()
        dp = getattr(self.seg, "dp", np.zeros(0))
        self.u_seen = float(dp[0]) if len(dp) else -math.inf  # the approach's end: the piece's first dwell point

    def add(self, contact, driven, params, feed_mm_min) -> None:
        self._ends(*self.seg.add(contact, driven, params, feed_mm_min))

    def finish(self) -> tuple[float, int]:
        """Write the rest; returns (seconds the controller takes, blocks written)."""
        self._ends(*self.seg.finish())
        if self.held is not None:
            w, _, kind, ij, c, p, p0, u0, u = self.held
            # merged trailing points' time goes to the last block
            self._emit(w[None, :], np.array([self.t_latest]), np.array([kind]), ij[None, :], c[None, :], p[None, :],
                       p0[None, :], np.array([u0]), np.array([u]), last=True)
            self.held = None
        return self.seconds, self.blocks

    def _ends(self, P: np.ndarray, T: np.ndarray, U: np.ndarray, kinds: np.ndarray, ij: np.ndarray,
              centres: np.ndarray | None = None) -> None:
        if len(P) == 0:
            return
        if centres is None:
            centres = np.full((len(P), 2), np.nan)
        W = np.round(P, self.d) + 0.0
        moved = np.any(W != np.vstack([self.w_seen[None, :], W[:-1]]), axis=1)
        P0 = np.vstack([self.p_seen[None, :], P[:-1]])  # each block's fitted start: the block end before it
        U0 = np.concatenate([[self.u_seen], U[:-1]])
        self.w_seen, self.p_seen, self.u_seen = W[-1], P[-1], float(U[-1])
        self.t_latest = float(T[-1])
        kw, kt, kk, kij, kc, kp, kp0 = W[moved], T[moved], kinds[moved], ij[moved], centres[moved], P[moved], P0[moved]
        ku0, ku = U0[moved], U[moved]
        if len(kw) == 0:
            return
        if self.held is not None:
            hw, ht, hk, hij, hc, hp, hp0, hu0, hu = self.held
            kw, kt = np.vstack([hw[None, :], kw]), np.concatenate([[ht], kt])
            kk, kij = np.concatenate([[hk], kk]), np.vstack([hij[None, :], kij])
            kc, kp, kp0 = np.vstack([hc[None, :], kc]), np.vstack([hp[None, :], kp]), np.vstack([hp0[None, :], kp0])
            ku0, ku = np.concatenate([[hu0], ku0]), np.concatenate([[hu], ku])
        self.held = (kw[-1], float(kt[-1]), int(kk[-1]), kij[-1], kc[-1], kp[-1], kp0[-1], float(ku0[-1]), float(ku[-1]))
        if len(kw) > 1:
            self._emit(kw[:-1], kt[:-1], kk[:-1], kij[:-1], kc[:-1], kp[:-1], kp0[:-1], ku0[:-1], ku[:-1])

    def _emit(self, W: np.ndarray, T: np.ndarray, kinds: np.ndarray, ij: np.ndarray, centres: np.ndarray,
              P: np.ndarray, P0: np.ndarray, U0: np.ndarray, U: np.ndarray, last: bool = False) -> None:
        m = len(W)
        prev = np.vstack([self.w_prev[None, :], W[:-1]])
        dt = np.diff(np.concatenate([[self.t_written], T]))
        kinds = kinds.astype(np.int64)
        arc = kinds != LINE
        if self.radius_arcs and arc.any():
            # the dwell point a block passes through (a block's start and end parameters enclose it)
            dp = self.seg.dp
            j = np.minimum(np.searchsorted(dp, U0, side="right"), len(dp) - 1)
            inside = (dp[j] > U0) & (dp[j] < U) & arc
            dw = np.where(inside[:, None], self.seg.dpts[j], np.nan)
            use_r, rw, ij_run = radius_form(np.ascontiguousarray(prev), np.ascontiguousarray(W),
                                            np.ascontiguousarray(P0), np.ascontiguousarray(P), kinds,
                                            np.ascontiguousarray(centres, dtype=np.float64),
                                            np.ascontiguousarray(ij, dtype=np.float64), np.ascontiguousarray(dw),
                                            10.0 ** -self.d)
        else:
            use_r, rw, ij_run = np.zeros(m, bool), np.zeros(m), ij
        length = written_arc_lengths(np.ascontiguousarray(prev), np.ascontiguousarray(W), kinds,
                                     np.ascontiguousarray(ij_run, dtype=np.float64))
        if self.inverse_time:
            # 1/min: the block takes 1/F minutes (F as written)
            feed = round_feeds(60.0 / np.maximum(dt, 1e-12), self.fd, self.res)
            words = np.ones(m, bool)
            self.seconds += float(np.sum(60.0 / feed))
        else:
            exact = length * 60.0 / np.maximum(dt, 1e-12)
            words, runs = modal_feed_words(exact, round_feeds(exact, self.fd, self.res), self.f_force, self.res)
            feed = runs
            self.f_force = float(runs[-1])
            self.seconds += float(np.sum(length * 60.0 / runs))
        gword = kinds != np.concatenate([[self.mode], kinds[:-1]])
        if self.incremental:
            absolute = (self.blocks + np.arange(1, m + 1)) % self.anchor == 0
            if last:
                absolute[-1] = True
            dist = np.where(absolute, 90, 91)
            dword = dist != np.concatenate([[self.distance], dist[:-1]])
            # G91 words: differences of the rounded positions, in whole resolutions (no rounding accumulates)
            scale = 10.0 ** self.d
            xyz = np.where(absolute[:, None], W, (np.rint(W * scale) - np.rint(prev * scale)) / scale)
            self.distance = int(dist[-1])
            self.anchors += int(np.count_nonzero(absolute))
        else:
            dist, dword, xyz = np.zeros(m), np.zeros(m, bool), W
        moved = W != prev
        if self.incremental:
            # a G90 block carries X Y Z whole, and the block after it its motion word and F (the F in force):
            # the program can be restarted after a G90 block with the tool at that block's end
            after = np.concatenate([[self.after_anchor], absolute[:-1]])
            self.after_anchor = bool(absolute[-1])
            moved = moved | absolute[:, None]
            gword = gword | after
            words = words | after
        ij_w = arc & ~use_r
        present = np.column_stack([dword, gword, moved, ij_w, ij_w, use_r, words])  # an arc always moves in XY
        values = np.column_stack([dist.astype(np.float64), kinds.astype(np.float64), xyz, ij, rw, feed])
        fd = self.fd if self.fd is not None else 9  # F rounded to its resolution's digits, trailing zeros dropped
        fstyle = (self.styles & ~KEEP_POINT) | (NO_TRAILING_ZEROS if self.fd is None else 0)  # F577: mm/min anyway
        self.write(format_fixed(values, [0, 0, self.d, self.d, self.d, self.d, self.d, self.d, fd], letters="GGXYZIJRF",
                                present=present, sep=self.sep, styles=[0, 0] + [self.styles] * 6 + [fstyle]))
        self.mode = int(kinds[-1])
        self.w_prev, self.p_prev, self.t_written = W[-1], P[-1], float(T[-1])
        self.blocks += m
        self.arcs += int(np.count_nonzero(arc))
        self.radius_arc_blocks += int(np.count_nonzero(use_r))
