"""Read modal G-code back with two third-party parsers: gcodeparser and pygcode.

Both give the moves as a controller runs them: the end point of every move
(axis words are modal: a word left out keeps its value; G90 absolute or G91
incremental, modal), whether it was a feed (G01, or a G02 / G03 arc in the XY
plane with its centre from I J, incremental, or from its radius R: the shorter
arc for R > 0) or a rapid (G00) move, the F in force and whether G93 (inverse time) was in
force. ``Moves.times()`` is each feed move's time as the controller derives it:
``60 x length / F`` in G94 (an arc's length: the helix's, :func:`helix_lengths`),
``60 / F`` in G93.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def helix_lengths(starts, ends, centres, turns) -> np.ndarray:
    """(K,) length of each move, mm: straight where ``turns`` is 0, else the helical arc in the XY plane about
    ``centres`` (K, 2) from ``starts`` to ``ends`` (K, 3), counter-clockwise for turns > 0 (G03), clockwise
    for turns < 0 (G02), ``|turns| - 1`` extra full turns; the radius linear from start to end (LinuxCNC's
    spiral; the mean is used), Z linear along the arc: ``sqrt((r_mean * sweep)^2 + dz^2)``."""
    starts, ends = np.asarray(starts, float), np.asarray(ends, float)
    turns = np.asarray(turns)
    out = np.linalg.norm(ends - starts, axis=1)
    arc = turns != 0
    if arc.any():
        c = np.asarray(centres, float)[arc]
        a, b, t = starts[arc], ends[arc], turns[arc]
        sgn = np.sign(t)
        va, vb = a[:, :2] - c, b[:, :2] - c
        ph = np.arctan2(sgn * (va[:, 0] * vb[:, 1] - va[:, 1] * vb[:, 0]), np.einsum("ij,ij->i", va, vb))
        ph = np.where(ph <= 0, ph + 2 * np.pi, ph) + (np.abs(t) - 1) * 2 * np.pi
        r = 0.5 * (np.linalg.norm(va, axis=1) + np.linalg.norm(vb, axis=1))
        out[arc] = np.hypot(r * ph, b[:, 2] - a[:, 2])
    return out


def arc_points(start, end, centre, turn, lam) -> np.ndarray:
    """Points (m, 3) at fractions ``lam`` (m,) of one move's length (straight, or a helical arc as in
    :func:`helix_lengths`): where the controller, moving uniformly, is at those fractions of its time."""
    start, end, lam = np.asarray(start, float), np.asarray(end, float), np.asarray(lam, float)
    if turn == 0:
        return start + lam[:, None] * (end - start)
    sgn = np.sign(turn)
    va, vb = start[:2] - centre, end[:2] - centre
    ph = np.arctan2(sgn * (va[0] * vb[1] - va[1] * vb[0]), va @ vb)
    ph = (ph + 2 * np.pi if ph <= 0 else ph) + (abs(turn) - 1) * 2 * np.pi
    th = np.arctan2(va[1], va[0]) + sgn * lam * ph
    ra, rb = np.linalg.norm(va), np.linalg.norm(vb)
    r = ra + lam * (rb - ra)
    return np.column_stack([centre[0] + r * np.cos(th), centre[1] + r * np.sin(th),
                            start[2] + lam * (end[2] - start[2])])


@dataclass
class Moves:
    ends: np.ndarray  # (K, 3) mm
    starts: np.ndarray  # (K, 3)
    feed: np.ndarray  # (K,) F in force (mm/min, or 1/min in G93)
    inverse: np.ndarray  # (K,) bool
    rapid: np.ndarray  # (K,) bool
    centres: np.ndarray = None  # (K, 2) an arc's centre (NaN: a straight move)
    turns: np.ndarray = None  # (K,) +1 G03, -1 G02, 0 straight

    def __post_init__(self):
        if self.centres is None:
            self.centres = np.full((len(self.ends), 2), np.nan)
        if self.turns is None:
            self.turns = np.zeros(len(self.ends), np.int64)

    def lengths(self) -> np.ndarray:
        return helix_lengths(self.starts, self.ends, self.centres, self.turns)

    def times(self) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):  # rapid moves: F 0
            return np.where(self.inverse, 60.0 / self.feed, 60.0 * self.lengths() / self.feed)

    def runs(self) -> list[np.ndarray]:
        """Indices of each run of feed moves between rapid moves (one piece: approach, path, retract)."""
        idx = np.flatnonzero(~self.rapid)
        if len(idx) == 0:
            return []
        cuts = np.flatnonzero(np.diff(idx) > 1) + 1
        return np.split(idx, cuts)


def radius_centre(start, end, r: float, turn: int) -> np.ndarray:
    """The XY centre of an arc in radius form from ``start`` to ``end`` (3,) with radius ``r`` (> 0: the
    shorter arc, < 0: the longer), turning counter-clockwise for ``turn`` > 0 (G03), as LinuxCNC and Fanuc
    place it."""
    d = np.asarray(end, float)[:2] - np.asarray(start, float)[:2]
    c = float(np.hypot(*d))
    h = np.sqrt(max(r * r - 0.25 * c * c, 0.0)) * np.sign(r) * np.sign(turn)
    return 0.5 * (np.asarray(start, float)[:2] + np.asarray(end, float)[:2]) + h * np.array([-d[1], d[0]]) / c


def _body(text: str) -> list[str]:
    return [ln.strip() for ln in text.splitlines() if ln.strip() and not ln.startswith("(") and ln.strip() != "%"]


def _moves(rows) -> Moves:
    ends, starts, feeds, invs, rapids, centres, turns = [], [], [], [], [], [], []
    pos = np.zeros(3)
    motion, feed, inv, incremental = None, 0.0, False, False
    for gs, words in rows:
        for g in gs:
            if g in (0, 1, 2, 3):
                motion = g
            elif g == 93:
                inv = True
            elif g == 94:
                inv = False
            elif g in (90, 91):
                incremental = g == 91
        if "F" in words:
            feed = float(words["F"])
        if any(a in words for a in "XYZ"):
            if incremental:
                new = pos + np.array([float(words.get(a, 0.0)) for a in "XYZ"])
            else:
                new = np.array([float(words.get(a, pos[i])) for i, a in enumerate("XYZ")])
            starts.append(pos)
            ends.append(new)
            feeds.append(feed)
            invs.append(inv)
            rapids.append(motion == 0)
            arc = motion in (2, 3)
            turn = {2: -1, 3: 1}.get(motion, 0)
            if arc and "R" in words:
                centres.append(radius_centre(pos, new, float(words["R"]), turn))
            else:
                centres.append(pos[:2] + [float(words.get("I", 0.0)), float(words.get("J", 0.0))] if arc
                               else [np.nan] * 2)
            turns.append(turn)
            pos = new
    return Moves(np.array(ends), np.array(starts), np.array(feeds), np.array(invs, bool), np.array(rapids, bool),
                 np.array(centres, float).reshape(-1, 2), np.array(turns, np.int64))


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
                words.update({k: v for k, v in c.params.items() if k in "XYZFIJR"})
        else:
            gs, words = [], {k: v for k, v in parse_parameters(ln).items() if k in "XYZFIJR"}
        rows.append((gs, words))
    return _moves(rows)


def moves_pygcode(text: str) -> Moves:
    """The moves by pygcode's virtual machine (modal groups, G93/G94, positions)."""
    from pygcode import Line, Machine

    m = Machine()
    ends, starts, feeds, invs, rapids, centres, turns = [], [], [], [], [], [], []
    for ln in _body(text):
        line = Line(ln)
        before = np.array([m.pos.values[a] for a in "XYZ"])
        m.process_block(line.block)
        after = np.array([m.pos.values[a] for a in "XYZ"])
        words = {w.letter: float(w.value) for w in line.block.words}
        if any(a in words for a in "XYZ"):
            starts.append(before)
            ends.append(after)
            feeds.append(float(m.mode.feed_rate.word.value) if m.mode.feed_rate is not None else 0.0)
            invs.append(str(m.mode.feed_rate_mode) == "G93")
            motion = str(m.mode.motion)
            rapids.append(motion.startswith("G00"))
            turn = -1 if motion.startswith("G02") else (1 if motion.startswith("G03") else 0)
            turns.append(turn)
            if turn and "R" in words:
                centres.append(radius_centre(before, after, words["R"], turn))
            else:
                centres.append(before[:2] + [words.get("I", 0.0), words.get("J", 0.0)] if turn else [np.nan] * 2)
    return Moves(np.array(ends), np.array(starts), np.array(feeds), np.array(invs, bool), np.array(rapids, bool),
                 np.array(centres, float).reshape(-1, 2), np.array(turns, np.int64))


def _seg_distance(q, a, b) -> float:
    e = b - a
    ll = float(e @ e)
    t = min(max(float((q - a) @ e) / ll, 0.0), 1.0) if ll > 0 else 0.0
    return float(np.linalg.norm(a + t * e - q))


def _move_fraction(q, start, end, centre, turn):
    """Distance of point q (3,) from one move and the fraction of the move's length at its nearest point
    (a straight move: the projection; an arc: 2001 points along it, then 2001 more around the nearest)."""
    if turn == 0:
        e = end - start
        ll = float(e @ e)
        t = min(max(float((q - start) @ e) / ll, 0.0), 1.0) if ll > 0 else 0.0
        return float(np.linalg.norm(start + t * e - q)), t
    lam = np.linspace(0.0, 1.0, 2001)
    for _ in range(2):
        d = np.linalg.norm(arc_points(start, end, centre, turn, lam) - q, axis=1)
        i = int(np.argmin(d))
        best = float(d[i]), float(lam[i])
        lam = np.clip(np.linspace(lam[i] - 5e-4, lam[i] + 5e-4, 2001), 0.0, 1.0)
    return best


def dwell_moves(points: np.ndarray, dwell_points: np.ndarray, match: float = 2e-4, centres: np.ndarray | None = None,
                turns: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each dwell point is on one piece's path: (first, last, distance).

    ``points`` (k + 1, 3): the path as run (approach end, then every block's end); ``centres`` / ``turns``:
    the blocks' arcs (:func:`helix_lengths`; None: straight). A dwell point is a block end (within
    ``match`` mm; ``first`` is then the move starting there, ``last`` the move ending there) or lies on one
    move (``first`` = ``last`` = that move), found in path order; ``distance``: from the path, mm.
    """
    k = len(points) - 1
    centres = np.full((k, 2), np.nan) if centres is None else np.asarray(centres, float)
    turns = np.zeros(k, np.int64) if turns is None else np.asarray(turns)
    first, last, dist = [], [], []
    start = 0
    for d in dwell_points:
        found = None
        for i in range(start, k + 1):  # in path order: the first block end or move the dwell point is on
            e = float(np.linalg.norm(points[i] - d))
            if e <= match:
                found = (i, i - 1, e)
                break
            if i == k:
                break
            if float(np.linalg.norm(points[i + 1] - d)) <= match:
                continue  # the move ends there: a block end, found next
            if turns[i] != 0:  # cheap rejections first: off the circle, or far from the chord
                r = np.linalg.norm(points[i, :2] - centres[i])
                if abs(np.linalg.norm(d[:2] - centres[i]) - r) > match:
                    continue
            elif _seg_distance(d, points[i], points[i + 1]) > match:
                continue
            di, _ = _move_fraction(d, points[i], points[i + 1], centres[i], turns[i])
            if di <= match:
                found = (i, i, di)
                break
        assert found is not None, f"dwell point {d} is not on the path after block {start}"
        first.append(found[0])
        last.append(found[1])
        dist.append(found[2])
        start = found[0]
    return np.array(first), np.array(last), np.array(dist)


def delivered_region_times(points: np.ndarray, times: np.ndarray, dwell_points: np.ndarray,
                           boundary_points: np.ndarray, match: float = 2e-4, centres: np.ndarray | None = None,
                           turns: np.ndarray | None = None) -> np.ndarray:
    """Time the controller spends in each dwell point's region of one piece, s.

    ``points`` (k + 1, 3): the piece's path as run (approach end, then every block's
    end); ``times`` (k,): each block's time as the controller derives it;
    ``centres`` (k, 2) and ``turns`` (k,): the blocks' arcs (see :func:`helix_lengths`; None: straight);
    ``dwell_points`` (q, 3) in order, each a block end or on a block (within ``match`` mm, :func:`dwell_moves`);
    ``boundary_points`` (q - 1, 3): the curve at the region boundaries (the parameter
    midpoints between dwell points). Each boundary is projected onto the nearest
    block between its two dwell points; the controller passes it at that block's
    start time plus the projection's fraction (of the block's length) of the block's time.
    """
    k = len(times)
    centres = np.full((k, 2), np.nan) if centres is None else np.asarray(centres, float)
    turns = np.zeros(k, np.int64) if turns is None else np.asarray(turns)
    cum = np.concatenate([[0.0], np.cumsum(times)])
    first, last, _ = dwell_moves(points, dwell_points, match, centres, turns)
    tb = []
    for j, q in enumerate(boundary_points):
        a, b = first[j], max(last[j + 1], first[j])
        best = min((_move_fraction(q, points[i], points[i + 1], centres[i], turns[i]) + (i,) for i in range(a, b + 1)))
        _, lam, i = best
        tb.append(cum[i] + lam * (cum[i + 1] - cum[i]))
    edges = np.concatenate([[0.0], tb, [cum[-1]]])
    return np.diff(edges)


def points_at_params(samples: np.ndarray, params: np.ndarray, at: np.ndarray) -> np.ndarray:
    """The sampled path (straight between samples) at curve parameters ``at``: linear in the parameter between
    the two samples around each, where the schedule (time linear in the parameter between samples) places them."""
    i = np.clip(np.searchsorted(params, at, side="right") - 1, 0, len(params) - 2)
    f = (at - params[i]) / (params[i + 1] - params[i])
    return samples[i] + f[:, None] * (samples[i + 1] - samples[i])
