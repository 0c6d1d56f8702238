"""Modal G01 blocks of one piece, streamed: segmenting, written coordinates, feeds (G94 or G93), words.

The piece's samples arrive chunk by chunk (:class:`~polishpath.export.chunks.SampleChunk`);
:class:`~polishpath.export.segment.PieceSegmenter` turns them into block end
points (chord-tolerance segmenting, every dwell point a block end), and this
module writes them as modal blocks:

* coordinates rounded to ``decimals`` (4: 0.1 um); a block whose written point
  equals the previous one is merged into the next (its time goes with it);
* the axis words that changed only (``X Y Z`` are modal), no ``G01`` (the
  approach move's ``G01`` is in force);
* G94: ``F`` (the written block's length over its planned time, mm/min) only
  where it differs from the F in force by more than ``feed_resolution`` of
  it; a block without F runs at the F in force, so its time is off by at most
  that fraction. G93 (inverse time): ``F`` = 1 / minutes of the block on
  every block (F is not modal in G93).
"""

from __future__ import annotations

import numba
import numpy as np

from ..segment import PieceSegmenter
from ..textfmt import format_fixed

__all__ = ["LinearMotion", "modal_feed_words"]


@numba.njit(cache=True)
def modal_feed_words(feed, in_force, resolution):  # pragma: no cover - numba
    """Which blocks write their F, and the F each block runs at.

    Parameters
    ----------
    feed : (k,) float64
        Each block's own feed, mm/min (as written, rounded).
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
            f = feed[i]
            write[i] = True
        runs[i] = f
    return write, runs


class LinearMotion:
    """The G01 blocks of one piece; ``start``, ``add`` per chunk, ``finish``.

    Parameters
    ----------
    segmenter : PieceSegmenter
    write : callable
        ``write(bytes)`` into the program.
    decimals, feed_decimals : int
    inverse_time : bool
        G93 (F = 1/minutes on every block) or G94 (F in mm/min, modal).
    feed_resolution : float
        G94: fraction by which F may differ from the F in force before it is written again.
    feed_in_force : float
        F in force before the first block (the approach feed), mm/min.
    """

    def __init__(self, segmenter: PieceSegmenter, write, *, decimals: int, feed_decimals: int, inverse_time: bool,
                 feed_resolution: float, feed_in_force: float):
        self.seg, self.write = segmenter, write
        self.d, self.fd = int(decimals), int(feed_decimals)
        self.inverse_time, self.res = bool(inverse_time), float(feed_resolution)
        self.f_force = float(feed_in_force)
        self.w_prev = None  # last written point (rounded), mm
        self.w_seen = None  # rounded last block end seen (written or merged)
        self.t_written = 0.0  # planned time at the last written point, s
        self.t_latest = 0.0
        self.held = None  # (w, t) the last kept point, written once the next is known (or at the end)
        self.seconds = 0.0  # the controller's time of the written blocks, s
        self.blocks = 0

    def start(self, first_point: np.ndarray) -> None:
        """The piece's first driven point (where the approach move ends)."""
        self.w_prev = np.round(np.asarray(first_point, dtype=np.float64), self.d) + 0.0
        self.w_seen = self.w_prev

    def add(self, contact, driven, params, feed_mm_min) -> None:
        self._ends(*self.seg.add(contact, driven, params, feed_mm_min)[:2])

    def finish(self) -> tuple[float, int]:
        """Write the rest; returns (seconds the controller takes, blocks written)."""
        self._ends(*self.seg.finish()[:2])
        if self.held is not None:
            w, _ = self.held
            self._emit(w[None, :], np.array([self.t_latest]))  # merged trailing points' time goes to the last block
            self.held = None
        return self.seconds, self.blocks

    def _ends(self, P: np.ndarray, T: np.ndarray) -> None:
        if len(P) == 0:
            return
        W = np.round(P, self.d) + 0.0
        moved = np.any(W != np.vstack([self.w_seen[None, :], W[:-1]]), axis=1)
        self.w_seen = W[-1]
        self.t_latest = float(T[-1])
        kw, kt = W[moved], T[moved]
        if len(kw) == 0:
            return
        if self.held is not None:
            kw = np.vstack([self.held[0][None, :], kw])
            kt = np.concatenate([[self.held[1]], kt])
        self.held = (kw[-1], float(kt[-1]))
        if len(kw) > 1:
            self._emit(kw[:-1], kt[:-1])

    def _emit(self, W: np.ndarray, T: np.ndarray) -> None:
        prev = np.vstack([self.w_prev[None, :], W[:-1]])
        dt = np.diff(np.concatenate([[self.t_written], T]))
        length = np.linalg.norm(W - prev, axis=1)
        if self.inverse_time:
            feed = np.round(60.0 / np.maximum(dt, 1e-12), self.fd) + 0.0  # 1/min: the block takes 1/F minutes
            words = np.ones(len(W), bool)
            self.seconds += float(np.sum(60.0 / feed))
        else:
            feed = np.round(length * 60.0 / np.maximum(dt, 1e-12), self.fd) + 0.0
            words, runs = modal_feed_words(feed, self.f_force, self.res)
            self.f_force = float(runs[-1])
            self.seconds += float(np.sum(length * 60.0 / runs))
        present = np.column_stack([W != prev, words])
        self.write(format_fixed(np.column_stack([W, feed]), [self.d, self.d, self.d, self.fd], letters="XYZF",
                                present=present))
        self.w_prev, self.t_written = W[-1], float(T[-1])
        self.blocks += len(W)
