"""5-axis motion blocks of one piece, streamed: G01 lines with the tool axis' words, inverse-time feed (issue 27, item 3).

The 5-axis twin of :class:`~polishpath.export.post.blocks.BlockMotion`, used by
a post whose :meth:`~polishpath.export.post.base.PostProcessor.orientation_letters`
are not empty (the rotary-words hook of the post base; LinuxCNC's A/C or B/C).
Each block is a straight move of the driven point (the contact point or the
tool centre) with the orientation words the controller interpolates linearly
along it (joint angles for LinuxCNC in its TCP kinematics), so

* blocks merge consecutive points (the machine samples, each dwell point
  inserted at its curve parameter) while (a) every replaced point lies within
  the chord tolerance of the block at the same share of the block's time, and
  (b) the tool axis the controller makes there from the interpolated words is
  within the orientation tolerance of the planned axis
  (:func:`polishpath.export.segment.rotary_block_ends`); no arcs (the axis
  changes along a block);
* every dwell point is a block end (its time, position and axis exact);
* G93 inverse time: ``F`` = 1 / minutes of the block on every block, so every
  block takes its planned time (the sum of the samples' times it replaces)
  whatever the rotary motion; the tool point's path length does not enter.
"""

from __future__ import annotations

import numpy as np

from ..segment import rotary_block_ends
from ..textfmt import KEEP_POINT, NO_TRAILING_ZEROS, fixed_text, format_fixed
from .blocks import round_feeds

__all__ = ["RotaryMotion"]


class RotaryMotion:
    """The motion blocks of one piece of a 5-axis path; ``start``, ``add`` per chunk, ``finish``.

    Parameters
    ----------
    post : PostProcessor
        Its orientation hook (:meth:`orientation_coords`, :meth:`axes_from_coords`, :meth:`orientation_letters`)
        and number formats.
    write : callable or None
        ``write(bytes)`` into the program (None: only count).
    dwell_params : (q,) float
        The piece's dwell-point parameters (ascending).
    dwell_points, dwell_axes : (q, 3) float
        The driven dwell points (mm) and their planned tool axes.
    chord_tol_mm, orientation_tol_deg : float
        The segmenting's tolerances.
    decimals, orientation_decimals : int
        Digits of the coordinates and of the orientation words.
    feed_decimals : int or None
        Digits of F (None: the digits ``feed_resolution`` needs).
    feed_resolution : float
    sep : str
    styles : int
    """

    def __init__(self, post, write, *, dwell_params, dwell_points, dwell_axes, chord_tol_mm: float,
                 orientation_tol_deg: float, decimals: int, orientation_decimals: int, feed_decimals,
                 feed_resolution: float, sep: str = "", styles: int = 0, previous: np.ndarray | None = None):
        self.post, self.write = post, write
        self.du = np.asarray(dwell_params, dtype=np.float64)
        self.dp = np.asarray(dwell_points, dtype=np.float64)
        self.da = np.asarray(dwell_axes, dtype=np.float64)
        self.j = 0  # first dwell point not yet placed
        self.tol, self.otol = float(chord_tol_mm), float(orientation_tol_deg)
        self.d, self.od = int(decimals), int(orientation_decimals)
        self.fd, self.res = feed_decimals, float(feed_resolution)
        self.sep, self.styles = sep, int(styles)
        self.letters = tuple(post.orientation_letters())
        self.prev_coords = previous  # orientation words of the point before (continuity)
        # the open dwell interval: driven points, times (s, from the piece's start), axes, orientation words
        self.P = np.zeros((0, 3))
        self.T = np.zeros(0)
        self.V = np.zeros((0, 3))
        self.Q = np.zeros((0, len(self.letters)))
        self.M = np.zeros(0, bool)  # which buffered points are dwell points (block ends)
        self.last = None  # (contact point, param, time) of the last sample seen
        self.w_prev = None  # the last written position and words
        self.q_prev = None
        self.t_written = 0.0
        self.seconds = 0.0
        self.blocks = 0
        self.arcs = 0
        self.max_axis_error_deg = 0.0  # at the block ends as written (rounded words), planned vs rebuilt

    # ---------------------------------------------------------------- the piece
    def start(self, first_point: np.ndarray, first_coords: np.ndarray) -> None:
        """The piece's first driven point and its orientation words (the approach's end)."""
        self.w_prev = np.round(np.asarray(first_point, dtype=np.float64), self.d) + 0.0
        self.q_prev = np.round(np.asarray(first_coords, dtype=np.float64), self.od) + 0.0
        self.prev_coords = np.asarray(first_coords, dtype=np.float64)

    def coords(self, axes: np.ndarray) -> np.ndarray:
        """Orientation words of ``axes`` (m, 3), continuous from the last point seen."""
        q = self.post.orientation_coords(axes, self.prev_coords)
        if len(q):
            self.prev_coords = q[-1]
        return q

    def add(self, contact, driven, params, feed_mm_min, axes) -> None:
        contact = np.asarray(contact, dtype=np.float64)
        u = np.asarray(params, dtype=np.float64)
        first = self.last is None
        pc, pu, pt = (contact[0], u[0], 0.0) if first else self.last
        seg = np.linalg.norm(np.diff(np.vstack([pc[None, :], contact]), axis=0), axis=1)
        t = pt + np.cumsum(seg * 60.0 / np.maximum(np.asarray(feed_mm_min, dtype=np.float64), 1e-300))
        self.last = (contact[-1], u[-1], float(t[-1]))
        # the dwell points up to the chunk's last parameter: inserted at their parameter, time linear in it
        k = self.j
        while k < len(self.du) and self.du[k] <= u[-1]:
            k += 1
        ins_u = self.du[self.j:k]
        P = np.vstack([np.asarray(driven, dtype=np.float64), self.dp[self.j:k]])
        T = np.concatenate([t, np.interp(ins_u, np.concatenate([[pu], u]), np.concatenate([[pt], t]))])
        V = np.vstack([np.asarray(axes, dtype=np.float64), self.da[self.j:k]])
        must = np.concatenate([np.zeros(len(u), bool), np.ones(len(ins_u), bool)])
        # each dwell point just before the first sample at or after its parameter
        order = np.argsort(np.concatenate([np.arange(len(u)) * 2 + 1, np.searchsorted(u, ins_u) * 2]), kind="stable")
        self.j = k
        P, T, V, must = P[order], T[order], V[order], must[order]
        if first:  # the piece's start point (its first sample, its first dwell point) is where the approach ends
            keep = T > 0.0
            P, T, V, must = P[keep], T[keep], V[keep], must[keep]
        if len(T) == 0:
            return
        Q = self.coords(V)
        self.P = np.vstack([self.P, P])
        self.T = np.concatenate([self.T, T])
        self.V = np.vstack([self.V, V])
        self.Q = np.vstack([self.Q, Q])
        self.M = np.concatenate([self.M, must])
        ends = np.flatnonzero(must)
        if len(ends):
            self._segment(len(self.T) - len(T) + int(ends[-1]) + 1)

    def finish(self) -> tuple[float, int]:
        """Write the rest; returns (seconds the controller takes, blocks written)."""
        self._segment(len(self.T))
        return self.seconds, self.blocks

    # ---------------------------------------------------------------- blocks
    def _segment(self, n: int) -> None:
        """Segment the first ``n`` buffered points (ending on a dwell point, or the piece's end) and write them."""
        if n == 0:
            return
        # the block start: the last written point (its planned position and words)
        P0 = np.vstack([self._start_p(), self.P[:n]])
        T0 = np.concatenate([[self.t_written], self.T[:n]])
        V0 = np.vstack([self._start_v(), self.V[:n]])
        Q0 = np.vstack([self._start_q(), self.Q[:n]])
        must = np.concatenate([[False], self.M[:n]])
        must[-1] = True
        ends = rotary_block_ends(P0, T0, V0, Q0, must, self.tol, self.otol, self.post.axes_from_coords)
        self._emit(P0[ends], T0[ends], Q0[ends], V0[ends])
        self._keep = (P0[-1], V0[-1], Q0[-1])
        self.P, self.T, self.V, self.Q, self.M = self.P[n:], self.T[n:], self.V[n:], self.Q[n:], self.M[n:]

    def _start_p(self):
        return self._keep[0][None, :] if hasattr(self, "_keep") else self.w_prev[None, :]

    def _start_v(self):
        if hasattr(self, "_keep"):
            return self._keep[1][None, :]
        return self.post.axes_from_coords(self.q_prev[None, :])

    def _start_q(self):
        return self._keep[2][None, :] if hasattr(self, "_keep") else self.q_prev[None, :]

    def _emit(self, P: np.ndarray, T: np.ndarray, Q: np.ndarray, V: np.ndarray) -> None:
        W = np.round(P, self.d) + 0.0
        R = np.round(Q, self.od) + 0.0
        dt = np.diff(np.concatenate([[self.t_written], T]))
        prev_w = np.vstack([self.w_prev[None, :], W[:-1]])
        prev_r = np.vstack([self.q_prev[None, :], R[:-1]])
        moved = np.any(W != prev_w, axis=1) | np.any(R != prev_r, axis=1)
        if not moved.all():  # a block that writes nothing new: its time goes to the next one
            keep = np.flatnonzero(moved)
            if len(keep) == 0:
                return
            W, R, T, V = W[keep], R[keep], T[keep], V[keep]
            dt = np.diff(np.concatenate([[self.t_written], T]))
            prev_w = np.vstack([self.w_prev[None, :], W[:-1]])
            prev_r = np.vstack([self.q_prev[None, :], R[:-1]])
        rebuilt = self.post.axes_from_coords(R)
        cosang = np.clip(np.sum(rebuilt * V, axis=1) / np.maximum(np.linalg.norm(V, axis=1), 1e-300), -1.0, 1.0)
        self.max_axis_error_deg = max(self.max_axis_error_deg, float(np.degrees(np.arccos(cosang)).max()))
        feed = round_feeds(60.0 / np.maximum(dt, 1e-12), self.fd, self.res)  # 1/min: the block takes 1/F minutes
        self.seconds += float(np.sum(60.0 / feed))
        if self.write is not None:
            r = len(self.letters)
            present = np.column_stack([W != prev_w, R != prev_r, np.ones(len(W), bool)])
            values = np.column_stack([W, R, feed])
            fd = self.fd if self.fd is not None else 9
            fstyle = (self.styles & ~KEEP_POINT) | (NO_TRAILING_ZEROS if self.fd is None else 0)
            decs = [self.d] * 3 + [self.od] * r + [fd]
            styles = [self.styles] * (3 + r) + [fstyle]
            letters = "XYZ" + "".join(self.letters) + "F"
            if len(letters) == 4 + r:
                self.write(format_fixed(values, decs, letters=letters, present=present, sep=self.sep, styles=styles))
            else:  # multi-letter words (e.g. A3=): Python's formatting
                names = ["X", "Y", "Z", *self.letters, "F"]
                self.write("".join(self.sep.join(names[c] + fixed_text(values[i, c], decs[c], styles[c])
                                                 for c in range(values.shape[1]) if present[i, c]) + "\n"
                                   for i in range(len(W))).encode("ascii"))
        self.w_prev, self.q_prev, self.t_written = W[-1], R[-1], float(T[-1])
        self.blocks += len(W)
