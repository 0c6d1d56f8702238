"""Where the tool centre is and for how long: fine timed samples along a path.

The simulation needs the tool's time density; these functions turn a path
(dwell points with times, or the machine's constant-period samples) into fine
samples, each carrying the time it stands for, its heading and the path
length it covers. Units: mm, s.
"""

from __future__ import annotations

import numpy as np

from ..defaults import MAX_FEED_FACTOR
from ..errors import ParameterError
from ..pathops import piece_offsets, piece_slices

#: the time models of :func:`path_motion_samples`
TIME_MODELS = ("segments", "points", "machine", "moves")


def dwell_from_feed(path_xy, feed_mm_min: float) -> np.ndarray:
    """Dwell times (N,) s that make the tool move at a constant feed.

    Point k gets half of each adjacent segment length divided by the feed.

    Parameters
    ----------
    path_xy : (N, 2) mm
    feed_mm_min : float
        Feed, mm/min.
    """
    p = np.asarray(path_xy, dtype=np.float64)
    if not feed_mm_min > 0:
        raise ParameterError(f"feed_mm_min must be positive, got {feed_mm_min}.")
    L = np.hypot(*np.diff(p, axis=0).T)
    own = np.zeros(len(p))
    own[:-1] += L / 2
    own[1:] += L / 2
    return own / (feed_mm_min / 60.0)


def path_time_samples(path_xy, dwell_s, step_mm: float, pieces=None, time_model: str = "segments"):
    """Fine samples along a path, each carrying the tool time it stands for.

    See :func:`path_motion_samples` (which also returns each sample's length);
    this returns ``(xy, t, heading, arc)``.
    """
    return path_motion_samples(path_xy, dwell_s, step_mm, pieces, time_model)[:4]


def path_motion_samples(path_xy, dwell_s, step_mm: float, pieces=None, time_model: str = "segments",
                        machine: dict | None = None):
    """Fine samples along a path, each carrying the tool time it stands for.

    Dwell point k owns the path from the middle of segment (k-1, k) to the
    middle of segment (k, k+1); its time ``dwell_s[k]`` is spread uniformly
    along that stretch. A point owning no length (a lone point) is one sample.

    Parameters
    ----------
    path_xy : (N, 2) float
        Dwell points in path order, mm.
    dwell_s : (N,) float
        Time per dwell point, s.
    step_mm : float
        Largest distance between samples, mm (half a pixel is plenty).
    pieces : (K+1,) int, optional
        Offsets of continuous pieces (the tool lifts between them); default one piece.
    time_model : {"segments", "points", "machine", "moves"}
        ``"segments"``: the time is spread along the path as described above
        (continuous motion). ``"points"``: all the time is spent at the dwell
        points themselves (stop-and-dwell; the moves take no time).
        ``"moves"``: the points are already the machine's samples and
        ``dwell_s[k]`` is the time of the straight move from point k to
        point k + 1 (one interpolation period for a
        :class:`~polishpath.types.ToolPath`), spread uniformly along it; the
        time of the last point of a piece is spent standing at it (0 for a
        ToolPath).
        ``"machine"``: the path the machine runs: a cubic NURBS through the
        dwell points of each piece, sampled at a constant interpolation period
        with the feed schedule that honours the dwell times within the
        curvature (chord-error) limit (:mod:`polishpath.smooth`); every
        period is one sample interval of equal time.
    machine : dict, optional
        ``"machine"`` options: ``period_ms`` (4), ``chord_tol_mm`` (0.001),
        ``max_feed_factor`` (5: machine feed limit as a multiple of the mean feed),
        ``schedule_passes`` (3).

    Returns
    -------
    xy : (M, 2) float64
        Sample positions, mm.
    t : (M,) float64
        Time of each sample, s (``t.sum() == dwell_s.sum()``; ``"machine"``:
        the time the interpolator takes, which exceeds the wish where the
        curvature limit slows the tool).
    heading : (M,) float64
        Direction of travel, radians from +x.
    arc : (M,) float64
        Arc length along the whole path, mm.
    length : (M,) float64
        Path length each sample stands for, mm (``length / t`` is the feed speed; 0 when the tool stands still).
    info : dict
        ``"machine"``: the interpolator's figures; else empty.
    """
    p = np.asarray(path_xy, dtype=np.float64)
    t = np.asarray(dwell_s, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) == 0:
        raise ParameterError(f"path_xy must be an (N, 2) array in mm, got shape {p.shape}.")
    if t.shape != (len(p),):
        raise ParameterError(f"dwell_s must have one time per path point ({len(p)}), got shape {t.shape}.")
    if not (np.isfinite(p).all() and np.isfinite(t).all()) or (t < 0).any():
        raise ParameterError("path_xy and dwell_s must be finite and dwell times >= 0 s.")
    if not step_mm > 0:
        raise ParameterError(f"step_mm must be positive, got {step_mm}.")
    pieces = piece_offsets(pieces, len(p))
    if time_model not in TIME_MODELS:
        raise ParameterError(f"unknown time_model {time_model!r}.", "Use one of " + ", ".join(TIME_MODELS) + ".")
    if time_model == "points":
        d = np.diff(p, axis=0)
        L = np.hypot(d[:, 0], d[:, 1])
        head = np.append(np.arctan2(d[:, 1], d[:, 0]), 0.0) if len(p) > 1 else np.zeros(1)
        return p.copy(), t.copy(), head, np.concatenate([[0.0], np.cumsum(L)]), np.zeros(len(p)), {}
    if time_model == "machine":
        return _machine_samples(p, t, step_mm, pieces, **(machine or {}))
    if time_model == "moves":
        return _timed_moves(p, t, step_mm, pieces)
    out_xy, out_t, out_h, out_s, out_l = [], [], [], [], []
    s0 = 0.0
    for sl in piece_slices(pieces, len(p)):
        P, T = p[sl], t[sl]
        if len(P) == 0:
            continue
        d = np.diff(P, axis=0)
        L = np.hypot(d[:, 0], d[:, 1])
        own = np.zeros(len(P))
        own[:-1] += L / 2
        own[1:] += L / 2
        lone = own <= 0
        if lone.any():
            out_xy.append(P[lone])
            out_t.append(T[lone])
            out_h.append(np.zeros(lone.sum()))
            out_s.append(np.full(lone.sum(), s0))
            out_l.append(np.zeros(lone.sum()))
        if len(L):
            cum = np.concatenate([[0.0], np.cumsum(L)])
            head = np.arctan2(d[:, 1], d[:, 0])
            m = np.maximum(1, np.ceil(L / 2 / step_mm).astype(np.int64))
            seg = np.repeat(np.arange(len(L)), m)
            i = np.arange(seg.size) - np.repeat(np.cumsum(m) - m, m)
            frac = (i + 0.5) / np.repeat(m, m) * 0.5
            with np.errstate(invalid="ignore", divide="ignore"):
                w_first = np.where(own[:-1] > 0, T[:-1] * L / (2 * m * own[:-1]), 0.0)
                w_second = np.where(own[1:] > 0, T[1:] * L / (2 * m * own[1:]), 0.0)
            for u, w in ((frac, w_first), (0.5 + frac, w_second)):
                out_xy.append(P[seg] + u[:, None] * d[seg])
                out_t.append(w[seg])
                out_h.append(head[seg])
                out_s.append(s0 + cum[seg] + u * L[seg])
                out_l.append((L / (2 * m))[seg])
            s0 += cum[-1]
    return (np.concatenate(out_xy), np.concatenate(out_t), np.concatenate(out_h), np.concatenate(out_s),
            np.concatenate(out_l), {})


def _machine_samples(p: np.ndarray, t: np.ndarray, step_mm: float, pieces, *, period_ms: float | None = None,
                     chord_tol_mm: float | None = None, max_feed_factor: float = MAX_FEED_FACTOR,
                     schedule_passes: int = 3):
    """Samples of the NURBS-smoothed path at a constant interpolation period (see :func:`path_motion_samples`)."""
    from ..defaults import DEFAULT_CHORD_TOL_MM, DEFAULT_PERIOD_MS
    from ..smooth import interpolate_constant_period, interpolate_nurbs

    period_ms = DEFAULT_PERIOD_MS if period_ms is None else float(period_ms)
    chord_tol_mm = DEFAULT_CHORD_TOL_MM if chord_tol_mm is None else float(chord_tol_mm)
    T = period_ms / 1000.0
    pieces = piece_offsets(pieces, len(p))
    out_xy, out_t, out_h, out_s, out_l = [], [], [], [], []
    s0 = 0.0
    info = {"period_ms": period_ms, "chord_tol_mm": chord_tol_mm, "max_feed_factor": max_feed_factor,
            "wanted_time_s": float(t.sum()), "n_pieces": int(len(pieces) - 1), "dwell_time_error_max": 0.0,
            "feed_min_mm_min": np.inf, "feed_max_mm_min": 0.0, "chord_error_max_mm": 0.0, "n_interp_samples": 0}
    for sl in piece_slices(pieces, len(p)):
        P, Tw = p[sl], t[sl]
        keep = np.ones(len(P), bool)
        if len(P) > 1:  # merge repeated consecutive points (their times add up)
            same = np.all(np.diff(P, axis=0) == 0, axis=1)
            for i in np.flatnonzero(same)[::-1]:
                Tw = Tw.copy()
                Tw[i] += Tw[i + 1]
                keep[i + 1] = False
            P, Tw = P[keep], Tw[keep]
        if len(P) < 2 or Tw.sum() <= 0:
            out_xy.append(P)
            out_t.append(Tw)
            out_h.append(np.zeros(len(P)))
            out_s.append(np.full(len(P), s0))
            out_l.append(np.zeros(len(P)))
            continue
        curve, u = interpolate_nurbs(P, 3)
        Tw = np.maximum(Tw, 1e-9 * max(Tw.max(), 1e-12))
        L = float(np.hypot(*np.diff(P, axis=0).T).sum())
        mean_feed = 60.0 * L / Tw.sum()
        res = interpolate_constant_period(curve, mean_feed, period_ms, chord_tol_mm, dwell_params=u, dwell_times=Tw,
                                          max_feed_mm_min=max_feed_factor * mean_feed,
                                          schedule_passes=schedule_passes)
        q = np.asarray(res["samples"])[:, :2]
        st = res["stats"]
        info["dwell_time_error_max"] = max(info["dwell_time_error_max"], st.get("dwell_time_error_max", 0.0))
        info["feed_min_mm_min"] = min(info["feed_min_mm_min"], st["feed_min_mm_min"])
        info["feed_max_mm_min"] = max(info["feed_max_mm_min"], st["feed_max_mm_min"])
        info["chord_error_max_mm"] = max(info["chord_error_max_mm"], st["chord_error_max"])
        info["n_interp_samples"] += int(len(q))
        *parts, s0 = _move_samples(q, np.full(len(q) - 1, T), step_mm, s0)
        for acc, part in zip((out_xy, out_t, out_h, out_s, out_l), parts):
            acc.append(part)
    info["machine_time_s"] = float(sum(x.sum() for x in out_t))
    if not np.isfinite(info["feed_min_mm_min"]):
        info["feed_min_mm_min"] = 0.0
    return (np.concatenate(out_xy), np.concatenate(out_t), np.concatenate(out_h), np.concatenate(out_s),
            np.concatenate(out_l), info)


def path_clock(arc_mm: np.ndarray, t_s: np.ndarray) -> np.ndarray:
    """Machining time (s) at each sample: samples in path order (by arc length), time at the sample's middle."""
    order = np.argsort(arc_mm, kind="stable")
    c = np.empty(len(t_s))
    c[order] = np.cumsum(t_s[order]) - 0.5 * t_s[order]
    return c


def _move_samples(q: np.ndarray, t_move: np.ndarray, step_mm: float, s0: float):
    """Samples of the straight moves ``q[k] -> q[k+1]``, move k taking ``t_move[k]`` s spread uniformly along it.

    Returns ``(xy, t, heading, arc, length)`` as :func:`path_motion_samples`,
    the arc starting at ``s0`` mm, and the arc at the end of the last move.
    """
    d = np.diff(q, axis=0)
    Ls = np.hypot(d[:, 0], d[:, 1])
    m = np.maximum(1, np.ceil(Ls / step_mm).astype(np.int64))
    seg = np.repeat(np.arange(len(Ls)), m)
    i = np.arange(seg.size) - np.repeat(np.cumsum(m) - m, m)
    frac = (i + 0.5) / np.repeat(m, m)
    cum = np.concatenate([[0.0], np.cumsum(Ls)])
    return (q[seg] + frac[:, None] * d[seg], (t_move / m)[seg], np.arctan2(d[:, 1], d[:, 0])[seg],
            s0 + cum[seg] + frac * Ls[seg], (Ls / m)[seg], s0 + cum[-1])


def _timed_moves(p: np.ndarray, t: np.ndarray, step_mm: float, pieces: np.ndarray):
    """The ``"moves"`` time model of :func:`path_motion_samples` (the machine's own samples)."""
    out = [[], [], [], [], []]
    s0 = 0.0
    for sl in piece_slices(pieces, len(p)):
        P, T = p[sl], t[sl]
        if len(P) == 0:
            continue
        if len(P) > 1:
            *parts, s0 = _move_samples(P, T[:-1], step_mm, s0)
            for acc, part in zip(out, parts):
                acc.append(part)
        if T[-1] > 0 or len(P) == 1:  # standing at the piece's last point
            head = np.arctan2(*(P[-1] - P[-2])[::-1]) if len(P) > 1 else 0.0
            for acc, part in zip(out, (P[-1:], T[-1:], np.array([head]), np.array([s0]), np.zeros(1))):
                acc.append(part)
    return tuple(np.concatenate(a) for a in out) + ({},)
