"""The machine's own timing of a planar path: what the job's smoothing and feed schedule would run.

A comparison of paths (:func:`~polishpath.simulate.compare.compare_planned`)
can time each path two ways (``timing=``):

* ``"ideal"``: every dwell point's time is spread along the path around it
  at whatever feed that takes (``time_model="segments"``): the dwell times
  exactly as asked, however sharply the path turns.
* ``"machine"`` (the default): the path as the job runs it. The planar dwell
  points (z = 0) go through the job's own smoothing stage
  (:func:`polishpath.smooth.smooth`: the cubic NURBS through every dwell
  point, sampled at the constant interpolation period with the feed schedule
  that honours the dwell times within the chord limit and the feed cap), and,
  with a machine profile, through its feed schedule
  (:func:`polishpath.schedule.schedule_feeds`: the axes' acceleration and
  velocity limits, the slow-downs at turns). The simulation then runs those
  samples with the time of every move (``time_model="moves"``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..defaults import DEFAULT_SPACING_MM, MAX_FEED_FACTOR
from ..errors import ParameterError
from ..pathops import piece_offsets
from ..types import PlanarPath, Provenance, SurfacePath
from .jobpath import TimedPath, timed_path

__all__ = ["COMPARE_TIMINGS", "machine_timed_path", "machine_tool_path"]

#: the timings of a comparison
COMPARE_TIMINGS = ("machine", "ideal")


def machine_timed_path(xy, dwell_s, pieces=None, *, spacing_mm: float = DEFAULT_SPACING_MM, machine=None,
                       period_ms: float | None = None, chord_tol_mm: float | None = None,
                       max_feed_factor: float = MAX_FEED_FACTOR) -> tuple[TimedPath, dict[str, Any]]:
    """The constant-period samples the job would run along planar dwell points, with each move's time.

    :func:`machine_tool_path` without the ToolPath (the same arguments); returns ``(timed, info)``.
    """
    _, timed, info = machine_tool_path(xy, dwell_s, pieces, spacing_mm=spacing_mm, machine=machine, period_ms=period_ms,
                                       chord_tol_mm=chord_tol_mm, max_feed_factor=max_feed_factor)
    return timed, info


def machine_tool_path(xy, dwell_s, pieces=None, *, spacing_mm: float = DEFAULT_SPACING_MM, machine=None,
                      period_ms: float | None = None, chord_tol_mm: float | None = None,
                      max_feed_factor: float = MAX_FEED_FACTOR):
    """The ToolPath the job would run along planar dwell points, and its constant-period samples with their times.

    Parameters
    ----------
    xy : (N, 2) float
        Dwell points in path order, mm (a plane: z = 0).
    dwell_s : (N,) float
        Time wished at each dwell point, s.
    pieces : (K+1,) int, optional
        Piece offsets (tool lifts between pieces).
    spacing_mm : float
        Grid spacing of the path, mm (recorded on the planar path only).
    machine : MachineProfile, str or None
        A machine profile (or its name / TOML file, :func:`polishpath.schedule.load_machine`):
        the feeds are scheduled under its limits and its interpolation period is used.
        None: the smoothing stage's schedule alone (chord limit, feed cap).
    period_ms, chord_tol_mm : float, optional
        Interpolation period (ms) and chord tolerance (mm); default the job's.
    max_feed_factor : float
        Feed cap of the smoothing stage as a multiple of the mean feed.

    Returns
    -------
    tool_path : ToolPath
        The smoothing stage's output (its ``dwell_params`` and ``sample_params`` say which
        samples run through which dwell point's region).
    timed : TimedPath
        ``time_model="moves"``: the samples and the seconds of each move.
    info : dict
        ``wanted_time_s``, ``machine_time_s``, ``time_increase``, the feed range
        (mm/min), the profile and its schedule figures (``limited_share`` ...).
    """
    from ..defaults import DEFAULT_CHORD_TOL_MM, DEFAULT_PERIOD_MS
    from ..smooth import smooth

    p = np.asarray(xy, dtype=np.float64)
    t = np.asarray(dwell_s, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or t.shape != (len(p),) or len(p) < 2:
        raise ParameterError(f"machine timing needs (N, 2) dwell points (N >= 2) and N times, got {p.shape}, "
                             f"{t.shape}.")
    prof = None
    if machine is not None:
        from ..schedule import load_machine

        prof = load_machine(machine)
    if period_ms is None:
        period_ms = prof.period_ms if prof is not None else DEFAULT_PERIOD_MS
    chord_tol_mm = DEFAULT_CHORD_TOL_MM if chord_tol_mm is None else float(chord_tol_mm)
    pieces = piece_offsets(pieces, len(p))
    n = len(p)
    planar = PlanarPath(uv=p, ij=np.zeros((n, 2), dtype=np.int64), spacing=float(spacing_mm), pattern="given",
                        pieces=pieces, provenance=Provenance("plan", "given"))
    sp = SurfacePath(xyz=np.column_stack([p, np.zeros(n)]), normals=np.tile([0.0, 0.0, 1.0], (n, 1)),
                     face_ids=np.zeros(n, dtype=np.int64), bary=np.tile([1.0, 0.0, 0.0], (n, 1)),
                     dwell_weight=np.ones(n), planar=planar, provenance=Provenance("map", "plane z = 0"))
    length = sum(float(np.hypot(*np.diff(p[a:b], axis=0).T).sum()) for a, b in zip(pieces[:-1], pieces[1:]))
    if not (t.sum() > 0 and length > 0):
        raise ParameterError("machine timing needs a path that moves and dwell times that add up to > 0 s.")
    mean_feed = 60.0 * length / float(t.sum())
    tp = smooth(sp, feed_mm_min=mean_feed, period_ms=period_ms, chord_tol_mm=chord_tol_mm, dwell_times=t,
                max_feed_mm_min=max_feed_factor * mean_feed, deviation_samples=1)
    sched = None
    if prof is not None:
        from ..schedule import schedule_feeds

        tp, sched = schedule_feeds(tp, prof)
    timed = timed_path(tp, timing="machine", plane="xy")
    feeds = np.asarray(tp.feed_mm_min)
    info = {"machine": None if prof is None else prof.name, "period_ms": float(period_ms),
            "chord_tol_mm": chord_tol_mm, "max_feed_factor": float(max_feed_factor),
            "mean_feed_mm_min": mean_feed, "wanted_time_s": float(t.sum()),
            "machine_time_s": float(timed.time_s.sum()),
            "time_increase": float(timed.time_s.sum() / t.sum() - 1.0),
            "feed_min_mm_min": float(feeds[feeds > 0].min()) if (feeds > 0).any() else 0.0,
            "feed_max_mm_min": float(feeds.max()), "n_samples": int(len(tp.samples))}
    if sched is not None:
        keep = ("machining_time_s", "limited_share", "limited_by", "time_increase", "dwell_time_error")
        info["schedule"] = {k: sched[k] for k in keep}
    return tp, timed, info
