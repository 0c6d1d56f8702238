"""How the machine delivers a dwell time: where along the path it is spent and how long it really takes.

The machine never stops at a dwell point: the smoothing stage runs a cubic
through the points at a constant feed per *region* (from half-way to the
previous point to half-way to the next, in curve parameter) so that the region
takes the point's time. Two consequences for the dwell-time solver:

* **where** — a point's time is spread along its region, whose time centroid is
  off the point wherever the path turns (by about a quarter step at a U-turn,
  always so at the part's edge, where the path must turn back and where the
  times are longest). :func:`region_centroids` gives each region's centroid
  along a chord-length cubic through the points (uniform in arc length: the
  constant feed), and the solver places each time there.
* **how long** — the feed is cut where the curve turns tighter than the chord
  tolerance allows, so a region's least time is what a run at the maximum feed
  takes (:func:`region_times` of such a run), not its length over the feed.
"""

from __future__ import annotations

import numpy as np

#: sub-intervals per region for the arc-length centroid (Gauss-Legendre nodes)
_NODES = 8
#: regions whose nodes are evaluated at once
_BLOCK = 65536


def region_centroids(points_xyz: np.ndarray, pieces: np.ndarray) -> np.ndarray:
    """Time centroid (x, y) of each dwell point's region at constant feed, mm (N, 2).

    Along each continuous piece a cubic interpolating spline through the points,
    parametrised by chord length (``scipy.interpolate.make_interp_spline``; the
    smoothing stage's NURBS is the same kind of curve), is split at the half-way
    parameters; the centroid of each region weighted by arc length (a constant
    feed spends equal time on equal lengths) is integrated with Gauss-Legendre
    nodes. Pieces of 2 or 3 points use a line or a parabola; a piece with a
    repeated point uses the straight half-steps.

    Parameters
    ----------
    points_xyz : (N, 3) float
        Dwell points in path order, mm.
    pieces : (K + 1,) int
        Offsets of the continuous pieces.
    """
    from scipy.interpolate import make_interp_spline

    p = np.asarray(points_xyz, dtype=np.float64)
    out = p[:, :2].copy()
    gx, gw = np.polynomial.legendre.leggauss(_NODES)
    gx, gw = 0.5 * (gx + 1.0), 0.5 * gw
    pcs = np.asarray(pieces, dtype=np.int64)
    for a, b in zip(pcs[:-1], pcs[1:]):
        q = p[a:b]
        m = len(q)
        if m < 2:
            continue
        step = np.linalg.norm(np.diff(q, axis=0), axis=1)
        if not np.all(step > 1e-12 * max(float(step.max()), 1e-300)):
            out[a:b] = _polyline_centroids(q)
            continue
        d = np.concatenate([[0.0], np.cumsum(step)])
        spl = make_interp_spline(d, q, k=min(3, m - 1))
        der = spl.derivative()
        rb = np.concatenate([[d[0]], 0.5 * (d[1:] + d[:-1]), [d[-1]]])
        # in blocks of regions: the nodes of a 10^6-point piece made about 600 MB of temporaries at once
        for c in range(0, m, _BLOCK):
            e = min(m, c + _BLOCK)
            lo, hi = rb[c:e], rb[c + 1:e + 1]
            u = lo[:, None] + (hi - lo)[:, None] * gx[None, :]  # (regions, nodes)
            w = np.linalg.norm(der(u.ravel()), axis=1).reshape(u.shape) * (hi - lo)[:, None] * gw[None, :]
            xy = spl(u.ravel())[:, :2].reshape(e - c, _NODES, 2)
            out[a + c:a + e] = (xy * w[..., None]).sum(axis=1) / np.maximum(w.sum(axis=1), 1e-300)[:, None]
    return out


def _polyline_centroids(q: np.ndarray) -> np.ndarray:
    """Centroids of the straight half-steps around each point (uniform in length), (m, 2)."""
    half = 0.5 * np.linalg.norm(np.diff(q, axis=0), axis=1)
    la = np.concatenate([[0.0], half])  # towards the previous point
    lb = np.concatenate([half, [0.0]])  # towards the next point
    ma = np.concatenate([q[:1], 0.5 * (q[1:] + q[:-1])])
    mb = np.concatenate([0.5 * (q[1:] + q[:-1]), q[-1:]])
    tot = np.where(la + lb > 0, la + lb, 1.0)
    c = q + (la[:, None] * (ma - q) + lb[:, None] * (mb - q)) / (2.0 * tot[:, None])
    return c[:, :2]


def sample_times(tool_path, sample_s: np.ndarray | None = None) -> np.ndarray:
    """Time at each machine sample from the start of its piece, s (M,): what the G-code's blocks take.

    One period per step (``sample_s``, the time each sample stands for, where a
    machine's schedule stretched it: the step arriving at a sample takes that
    sample's time, as the G-code's block to it runs at its feed), except each
    piece's last step: cut short at
    the piece's end, it is run at its sample's feed (the controller's time for
    a block is its length over its feed, :mod:`polishpath.export.segment`), so
    it takes its length over that feed, less than a period. The smoothing
    stage times its dwell regions the same way
    (:func:`polishpath.smooth.spans.record_step`).
    """
    sp = np.asarray(tool_path.sample_params, dtype=np.float64)
    T = float(tool_path.period_ms) / 1000.0
    spieces = np.asarray(tool_path.sample_pieces, dtype=np.int64)
    out = np.zeros(len(sp))
    for k in range(len(spieces) - 1):
        a, b = int(spieces[k]), int(spieces[k + 1])
        if b <= a:
            continue
        if sample_s is None:
            w = np.full(b - a, T)
        else:
            w = np.asarray(sample_s, dtype=np.float64)[a:b]
        # the step arriving at a sample runs at that sample's feed (as the G-code's block to it does)
        tt = np.concatenate([[0.0], np.cumsum(w[1:])])
        last = _last_step_s(tool_path, b) if b - a >= 2 else None
        if last is not None:
            tt[-1] = tt[-2] + min(w[-1], last)  # at most its whole time
        out[a:b] = tt
    return out


def _last_step_s(tool_path, b: int) -> float | None:
    """The step that ends a piece at sample ``b - 1`` (cut short at the piece's end) over its feed, s; None where
    the samples or the feed do not say (the step then takes its whole time). The callers keep it at most that
    time; the kernel aims every other step's chord at feed x period, to 1e-6: those keep their period exactly."""
    pts, feed = tool_path.samples, tool_path.feed_mm_min
    if len(pts) != len(tool_path.sample_params) or not feed[b - 1] > 0.0:
        return None
    step = float(np.linalg.norm(np.asarray(pts[b - 1], dtype=np.float64) - np.asarray(pts[b - 2], dtype=np.float64)))
    return step / (float(feed[b - 1]) / 60.0)


def region_times(tool_path, sample_s: np.ndarray | None = None) -> np.ndarray:
    """Time the machine-timed path spends in each dwell point's region, s (N,).

    ``tool_path`` is a :class:`~polishpath.types.ToolPath` (read through its
    fields only: this stage does not import the smoothing stage). The time at a
    curve parameter is the piecewise-linear interpolation of the samples' times
    (:func:`sample_times`: one period per step, the piece's last step its length
    over its feed) over the sample parameters; a region's time is the difference
    at its ends (the regions of the smoothing stage: half-way between dwell
    parameters, the piece's ends for its first and last point). Not a count of
    samples, which would be off by up to one period per region. ``sample_s`` (M,)
    s: the time each sample stands for where it is not one period (a machine's
    schedule).
    """
    dp = np.asarray(tool_path.dwell_params, dtype=np.float64)
    sp = np.asarray(tool_path.sample_params, dtype=np.float64)
    spieces, ppar = tool_path.sample_pieces, tool_path.piece_params
    # one period per step: the time at a sample is its index x the period (the piece's last step apart), read at
    # the region boundaries only; no array of the samples' size is made (the 10^6-point figuring job's 3.3e7
    # samples made four of 260 MB each). With a machine's schedule the times are summed (sample_times)
    times = None if sample_s is None else sample_times(tool_path, sample_s)
    T = float(tool_path.period_ms) / 1000.0
    out = np.zeros(len(dp))
    for k in range(len(spieces) - 1):
        a, b = int(spieces[k]), int(spieces[k + 1])
        s = sp[a:b]
        if len(s) == 0:
            continue
        lo, hi = ppar[k], ppar[k + 1]
        idx = np.flatnonzero((dp >= lo) & (dp < hi)) if k < len(spieces) - 2 else np.flatnonzero(dp >= lo)
        if len(idx) == 0:
            continue
        d = dp[idx]
        rb = np.concatenate([[s[0]], 0.5 * (d[1:] + d[:-1]), [s[-1]]])
        if times is not None:
            out[idx] = np.diff(np.interp(rb, s, times[a:b]))
            continue
        m = b - a
        if m < 2:
            continue
        # the time at the piece's last sample: its last step at its length over its feed, at most a period
        step = _last_step_s(tool_path, b)
        last = (m - 1) * T if step is None else (m - 2) * T + min(T, step)
        j = np.clip(np.searchsorted(s, rb, side="right") - 1, 0, m - 2)
        frac = np.clip((rb - s[j]) / np.where(s[j + 1] > s[j], s[j + 1] - s[j], 1.0), 0.0, 1.0)
        t0 = j * T
        t1 = np.where(j + 1 == m - 1, last, (j + 1) * T)
        out[idx] = np.diff(t0 + frac * (t1 - t0))
    return out
