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
  start), the axis words that changed only (``X Y Z`` are modal), and on every
  arc its centre ``I J`` from its start (incremental, LinuxCNC's and Fanuc's
  default; not modal);
* G94: ``F`` (the written block's length -- a line's, or the helix's -- over
  its planned time, mm/min) only where it differs from the F in force by more
  than ``feed_resolution`` of it; a block without F runs at the F in force, so
  its time is off by at most that fraction. G93 (inverse time): ``F`` = 1 /
  minutes of the block on every block (F is not modal in G93).
"""

from __future__ import annotations

import numba
import numpy as np

from ..blockfit import LINE, written_arc_lengths
from ..segment import PieceSegmenter
from ..textfmt import KEEP_POINT, NO_TRAILING_ZEROS, format_fixed

__all__ = ["BlockMotion", "modal_feed_words", "round_feeds"]


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
        :mod:`~polishpath.export.textfmt` number style bits of the axis words (X Y Z I J); F drops its
        trailing zeros when ``feed_decimals`` is None.
    """

    def __init__(self, segmenter: PieceSegmenter, write, *, decimals: int, feed_decimals: int, inverse_time: bool,
                 feed_resolution: float, feed_in_force: float, sep: str = " ", styles: int = 0):
        self.seg, self.write = segmenter, write
        self.d, self.fd = int(decimals), (None if feed_decimals is None else int(feed_decimals))
        self.sep, self.styles = sep, int(styles)
        self.inverse_time, self.res = bool(inverse_time), float(feed_resolution)
        self.f_force = float(feed_in_force)
        self.mode = LINE  # the approach's G01 is in force
        self.w_prev = None  # last written point (rounded), mm
        self.w_seen = None  # rounded last block end seen (written or merged)
        self.t_written = 0.0  # planned time at the last written point, s
        self.t_latest = 0.0
        self.held = None  # (w, t, kind, ij): the last kept block, written once the next is known (or at the end)
        self.seconds = 0.0  # the controller's time of the written blocks, s
        self.blocks = 0
        self.arcs = 0

    def start(self, first_point: np.ndarray) -> None:
        """The piece's first driven point (where the approach move ends)."""
        self.w_prev = np.round(np.asarray(first_point, dtype=np.float64), self.d) + 0.0
        self.w_seen = self.w_prev

    def add(self, contact, driven, params, feed_mm_min) -> None:
        self._ends(*self.seg.add(contact, driven, params, feed_mm_min))

    def finish(self) -> tuple[float, int]:
        """Write the rest; returns (seconds the controller takes, blocks written)."""
        self._ends(*self.seg.finish())
        if self.held is not None:
            w, _, kind, ij = self.held
            # merged trailing points' time goes to the last block
            self._emit(w[None, :], np.array([self.t_latest]), np.array([kind]), ij[None, :])
            self.held = None
        return self.seconds, self.blocks

    def _ends(self, P: np.ndarray, T: np.ndarray, U: np.ndarray, kinds: np.ndarray, ij: np.ndarray,
              centres: np.ndarray | None = None) -> None:
        if len(P) == 0:
            return
        W = np.round(P, self.d) + 0.0
        moved = np.any(W != np.vstack([self.w_seen[None, :], W[:-1]]), axis=1)
        self.w_seen = W[-1]
        self.t_latest = float(T[-1])
        kw, kt, kk, kij = W[moved], T[moved], kinds[moved], ij[moved]
        if len(kw) == 0:
            return
        if self.held is not None:
            hw, ht, hk, hij = self.held
            kw, kt = np.vstack([hw[None, :], kw]), np.concatenate([[ht], kt])
            kk, kij = np.concatenate([[hk], kk]), np.vstack([hij[None, :], kij])
        self.held = (kw[-1], float(kt[-1]), int(kk[-1]), kij[-1])
        if len(kw) > 1:
            self._emit(kw[:-1], kt[:-1], kk[:-1], kij[:-1])

    def _emit(self, W: np.ndarray, T: np.ndarray, kinds: np.ndarray, ij: np.ndarray) -> None:
        prev = np.vstack([self.w_prev[None, :], W[:-1]])
        dt = np.diff(np.concatenate([[self.t_written], T]))
        length = written_arc_lengths(np.ascontiguousarray(prev), np.ascontiguousarray(W), kinds.astype(np.int64),
                                     np.ascontiguousarray(ij, dtype=np.float64))
        if self.inverse_time:
            # 1/min: the block takes 1/F minutes (F as written)
            feed = round_feeds(60.0 / np.maximum(dt, 1e-12), self.fd, self.res)
            words = np.ones(len(W), bool)
            self.seconds += float(np.sum(60.0 / feed))
        else:
            exact = length * 60.0 / np.maximum(dt, 1e-12)
            words, runs = modal_feed_words(exact, round_feeds(exact, self.fd, self.res), self.f_force, self.res)
            feed = runs
            self.f_force = float(runs[-1])
            self.seconds += float(np.sum(length * 60.0 / runs))
        arc = kinds != LINE
        gword = kinds != np.concatenate([[self.mode], kinds[:-1]])
        present = np.column_stack([gword, W != prev, arc, arc, words])  # an arc always moves in XY
        values = np.column_stack([kinds.astype(np.float64), W, ij, feed])
        fd = self.fd if self.fd is not None else 9  # F rounded to its resolution's digits, trailing zeros dropped
        fstyle = (self.styles & ~KEEP_POINT) | (NO_TRAILING_ZEROS if self.fd is None else 0)  # F577: mm/min anyway
        self.write(format_fixed(values, [0, self.d, self.d, self.d, self.d, self.d, fd], letters="GXYZIJF",
                                present=present, sep=self.sep, styles=[0] + [self.styles] * 5 + [fstyle]))
        self.mode = int(kinds[-1])
        self.w_prev, self.t_written = W[-1], float(T[-1])
        self.blocks += len(W)
        self.arcs += int(np.count_nonzero(arc))
