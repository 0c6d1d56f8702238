"""Read modal G-code back with two third-party parsers: gcodeparser and pygcode.

Both give the moves as a controller runs them: the end point of every move
(axis words are modal: a word left out keeps its value), whether it was a feed
(G01) or a rapid (G00) move, the F in force and whether G93 (inverse time) was
in force. ``Moves.times()`` is each feed move's time as the controller derives
it: ``60 x length / F`` in G94, ``60 / F`` in G93.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Moves:
    ends: np.ndarray  # (K, 3) mm
    starts: np.ndarray  # (K, 3)
    feed: np.ndarray  # (K,) F in force (mm/min, or 1/min in G93)
    inverse: np.ndarray  # (K,) bool
    rapid: np.ndarray  # (K,) bool

    def times(self) -> np.ndarray:
        length = np.linalg.norm(self.ends - self.starts, axis=1)
        with np.errstate(divide="ignore"):
            return np.where(self.inverse, 60.0 / self.feed, 60.0 * length / self.feed)

    def runs(self) -> list[np.ndarray]:
        """Indices of each run of feed moves between rapid moves (one piece: approach, path, retract)."""
        idx = np.flatnonzero(~self.rapid)
        if len(idx) == 0:
            return []
        cuts = np.flatnonzero(np.diff(idx) > 1) + 1
        return np.split(idx, cuts)


def _body(text: str) -> list[str]:
    return [ln.strip() for ln in text.splitlines() if ln.strip() and not ln.startswith("(") and ln.strip() != "%"]


def _moves(rows) -> Moves:
    ends, starts, feeds, invs, rapids = [], [], [], [], []
    pos = np.zeros(3)
    motion, feed, inv = None, 0.0, False
    for gs, words in rows:
        for g in gs:
            if g in (0, 1):
                motion = g
            elif g == 93:
                inv = True
            elif g == 94:
                inv = False
        if "F" in words:
            feed = float(words["F"])
        if any(a in words for a in "XYZ"):
            new = np.array([float(words.get(a, pos[i])) for i, a in enumerate("XYZ")])
            starts.append(pos)
            ends.append(new)
            feeds.append(feed)
            invs.append(inv)
            rapids.append(motion == 0)
            pos = new
    return Moves(np.array(ends), np.array(starts), np.array(feeds), np.array(invs, bool), np.array(rapids, bool))


def moves_gcodeparser(text: str) -> Moves:
    """The moves by gcodeparser (its lines need a G/M word; a modal line of axis words is read by its
    ``parse_parameters``)."""
    from gcodeparser import parse_gcode_lines, parse_parameters

    rows = []
    for ln in _body(text):
        if ln[0] in "GMT":
            parsed = list(parse_gcode_lines(ln))
            gs = [c.command[1] for c in parsed if c.command[0] == "G"]
            words = {}
            for c in parsed:
                words.update({k: v for k, v in c.params.items() if k in "XYZF"})
        else:
            gs, words = [], {k: v for k, v in parse_parameters(ln).items() if k in "XYZF"}
        rows.append((gs, words))
    return _moves(rows)


def moves_pygcode(text: str) -> Moves:
    """The moves by pygcode's virtual machine (modal groups, G93/G94, positions)."""
    from pygcode import Line, Machine

    m = Machine()
    ends, starts, feeds, invs, rapids = [], [], [], [], []
    for ln in _body(text):
        line = Line(ln)
        before = np.array([m.pos.values[a] for a in "XYZ"])
        m.process_block(line.block)
        after = np.array([m.pos.values[a] for a in "XYZ"])
        if any(w.letter in "XYZ" for w in list(line.block.words)):
            starts.append(before)
            ends.append(after)
            feeds.append(float(m.mode.feed_rate.word.value) if m.mode.feed_rate is not None else 0.0)
            invs.append(str(m.mode.feed_rate_mode) == "G93")
            rapids.append(str(m.mode.motion).startswith("G00"))
    return Moves(np.array(ends), np.array(starts), np.array(feeds), np.array(invs, bool), np.array(rapids, bool))


def _seg_proj(q, a, b):
    """Distances of points q (m, 3) from segments a-b (k, 3) each, and the projections' fractions: (m, k)."""
    e = b - a
    ll = np.einsum("ij,ij->i", e, e)
    t = np.einsum("mkj,kj->mk", q[:, None, :] - a[None, :, :], e) / np.where(ll > 0, ll, 1.0)
    t = np.clip(t, 0.0, 1.0)
    d = np.linalg.norm(a[None] + t[..., None] * e[None] - q[:, None, :], axis=2)
    return d, t


def delivered_region_times(points: np.ndarray, times: np.ndarray, dwell_points: np.ndarray,
                           boundary_points: np.ndarray, match: float = 2e-4) -> np.ndarray:
    """Time the controller spends in each dwell point's region of one piece, s.

    ``points`` (k + 1, 3): the piece's path as run (approach end, then every block's
    end); ``times`` (k,): each block's time as the controller derives it;
    ``dwell_points`` (q, 3) in order, each a block end (found within ``match`` mm);
    ``boundary_points`` (q - 1, 3): the curve at the region boundaries (the parameter
    midpoints between dwell points). Each boundary is projected onto the nearest
    block between its two dwell points; the controller passes it at that block's
    start time plus the projection's fraction of the block's time.
    """
    cum = np.concatenate([[0.0], np.cumsum(times)])
    idx, start = [], 0
    for d in dwell_points:
        dist = np.linalg.norm(points[start:] - d, axis=1)
        hit = np.flatnonzero(dist <= match)
        assert len(hit), f"dwell point {d} is not a block end"
        idx.append(start + int(hit[0]))
        start = idx[-1]
    tb = []
    for j, q in enumerate(boundary_points):
        a, b = idx[j], idx[j + 1]
        d, t = _seg_proj(q[None, :], points[a:b], points[a + 1 : b + 1])
        i = int(np.argmin(d[0]))
        tb.append(cum[a + i] + t[0, i] * (cum[a + i + 1] - cum[a + i]))
    edges = np.concatenate([[0.0], tb, [cum[-1]]])
    return np.diff(edges)


def points_at_params(samples: np.ndarray, params: np.ndarray, at: np.ndarray) -> np.ndarray:
    """The sampled path (straight between samples) at curve parameters ``at``: linear in the parameter between
    the two samples around each, where the schedule (time linear in the parameter between samples) places them."""
    i = np.clip(np.searchsorted(params, at, side="right") - 1, 0, len(params) - 2)
    f = (at - params[i]) / (params[i + 1] - params[i])
    return samples[i] + f[:, None] * (samples[i + 1] - samples[i])
