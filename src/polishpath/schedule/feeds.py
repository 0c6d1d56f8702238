"""The feed schedule under a machine's limits: time-optimal speeds along the sampled path.

The smoothing stage samples the curve at the interpolation period with the
dwell-time feed schedule (the *planned* speeds). A machine with limited axes
cannot always follow it: where the path turns, the per-axis accelerations of the
planned speeds exceed the axes' limits and the controller lags. This module
finds, for the same samples, the fastest speeds that never exceed

* the planned speed of each segment (the samples are one interpolation period
  apart at the planned speed, so a segment cannot run faster than planned
  without being shorter than the controller's period),
* the tangential feed limit and each axis's velocity limit,
* each axis's acceleration limit (and the tangential one, if set), measured the
  way a controller and the tests measure them from the samples: the change of
  the velocity vector between consecutive segments over the mean of their
  times, from rest at the start of each piece and to rest at its end,

by a backward pass (the speed each segment may have and still stop in time)
and a forward pass (accelerate as fast as the limits allow, never above the
backward pass), each junction solved by bisection on the speed. The passes are
the project's own (numba-compiled, hand-written: no library does the discrete
junction form the test checks); the idea is the classical phase-plane
forward-backward integration of time-optimal path parametrisation.

Where no limit binds the result is exactly the planned schedule; where limits
bind the dwell points there take longer, and the delivered time of every dwell
point is compared with its planned time.

A 5-axis path (tool axes) on a machine with kinematics
(:mod:`polishpath.schedule.kinematics`) is scheduled the same way over five
axes: the machine's joints X Y Z (the table's rotations move them: LinuxCNC's
inverse transform of the tool point) and the rotary axes (degrees, from the
continuous inverse kinematics of the samples' axes), each with its velocity
and acceleration limit; the tangential feed limit stays the tool point's.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

from .. import progress
from ..types import ToolPath
from .machine import MachineProfile

__all__ = ["schedule_feeds", "segment_limits", "dwell_point_times"]

_REL = 1e-9  # slack of the limit checks (floating point)


@numba.njit(cache=True)
def _ok(s1, l1, d1, s2, l2, d2, amax, at):  # pragma: no cover - numba
    # junction between a segment of speed s1, length l1, direction d1 and the next (s2, l2, d2);
    # a speed of 0 with length 0 is rest
    t1 = l1 / s1 if s1 > 0.0 else 0.0
    t2 = l2 / s2 if s2 > 0.0 else 0.0
    half = 0.5 * (t1 + t2)
    for a in range(amax.shape[0]):
        if abs(s2 * d2[a] - s1 * d1[a]) > amax[a] * half * (1.0 + 1e-12):
            return False
    if at > 0.0 and abs(s2 - s1) > at * half * (1.0 + 1e-12):
        return False
    return True


@numba.njit(cache=True)
def _best(c, other, l, d, o_s, o_l, o_d, amax, at, before):  # pragma: no cover - numba
    # the largest speed x <= c of a segment (length l, direction d) that keeps the junction with its
    # neighbour (speed o_s, length o_l, direction o_d; ``before``: the neighbour comes first) within
    # the limits. Feasible speeds form an interval around the neighbour's speed (and a sliver near 0),
    # so: c itself; else bisect between the neighbour's speed and c; else walk down from there.
    def ok(x):
        if before:
            return _ok(o_s, o_l, o_d, x, l, d, amax, at)
        return _ok(x, l, d, o_s, o_l, o_d, amax, at)

    if ok(c):
        return c
    lo = min(c, o_s)
    hi = c
    if not (lo > 0.0 and ok(lo)):
        hi = lo if lo > 0.0 else c
        lo = hi
        found = False
        for _ in range(800):
            lo *= 0.98
            if ok(lo):
                found = True
                break
            hi = lo
        if not found:
            return lo
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if ok(mid):
            lo = mid
        else:
            hi = mid
    return lo


@numba.njit(cache=True)
def _passes(length, dirs, cap, amax, at):  # pragma: no cover - numba
    # one piece: segments (n,) lengths > 0, (n, k) axis moves per mm of path (the unit direction's
    # three; a 5-axis machine's joints and rotary degrees per mm beside them), (n,) speed caps, mm/s.
    # backward: every segment can still slow to its successor, the last one to rest; forward: from
    # rest, as fast as the limits allow and never above the backward pass.
    n = length.shape[0]
    zero = np.zeros(dirs.shape[1])
    bwd = np.empty(n)
    for k in range(n - 1, -1, -1):
        if k == n - 1:
            bwd[k] = _best(cap[k], 0.0, length[k], dirs[k], 0.0, 0.0, zero, amax, at, False)
        else:
            bwd[k] = _best(cap[k], bwd[k + 1], length[k], dirs[k], bwd[k + 1], length[k + 1], dirs[k + 1],
                           amax, at, False)
    out = np.empty(n)
    for k in range(n):
        if k == 0:
            out[k] = _best(bwd[k], 0.0, length[k], dirs[k], 0.0, 0.0, zero, amax, at, True)
        else:
            out[k] = _best(bwd[k], out[k - 1], length[k], dirs[k], out[k - 1], length[k - 1], dirs[k - 1],
                           amax, at, True)
    return out, bwd


def segment_limits(points: np.ndarray, times: np.ndarray) -> dict[str, np.ndarray]:
    """Speeds, axis velocities and accelerations of a timed piece, as measured from its samples.

    Parameters
    ----------
    points : (m, k) float
        Samples of one piece, mm (k = 3; a 5-axis machine's joints and rotary angles: k = 5, degrees).
    times : (m - 1,) float
        Seconds of each segment (> 0 where the segment has length).

    Returns
    -------
    dict
        ``speed`` (m - 1,) mm/s; ``velocity`` (m - 1, 3) mm/s; ``acceleration``
        (m, 3) mm/s^2 at every junction, from rest before the first segment and
        to rest after the last: the change of velocity over the mean time of the
        two segments; ``tangential`` (m,) mm/s^2 the same for the speed.
    """
    dp = np.diff(points, axis=0)
    t = np.asarray(times, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.where(t[:, None] > 0, dp / t[:, None], 0.0)
    keep = np.linalg.norm(dp, axis=1) > 0  # segments that move no axis take no time and join nothing
    v, t = v[keep], t[keep]
    speed = np.linalg.norm(v, axis=1)
    vv = np.vstack([np.zeros((1, v.shape[1])), v, np.zeros((1, v.shape[1]))])
    ss = np.concatenate([[0.0], speed, [0.0]])
    tt = np.concatenate([[0.0], t, [0.0]])
    half = 0.5 * (tt[:-1] + tt[1:])
    with np.errstate(divide="ignore", invalid="ignore"):
        acc = np.where(half[:, None] > 0, np.diff(vv, axis=0) / half[:, None], 0.0)
        tan = np.where(half > 0, np.diff(ss) / half, 0.0)
    return {"speed": speed, "velocity": v, "acceleration": acc, "tangential": tan}


def dwell_point_times(tool_path: ToolPath, seg_times: np.ndarray) -> np.ndarray:
    """(N,) seconds the tool spends in each dwell point's region, given the (M,) time arriving at each sample.

    A dwell point's region runs from the parameter midpoint of the previous
    interval to that of the next (as in the smoothing stage); time is linear in
    the parameter within a segment.
    """
    from ..smooth.interpolate import dwell_regions

    sp = tool_path.surface_path
    n = len(sp.xyz)
    dpieces = np.asarray(sp.planar.pieces if sp.planar is not None else [0, n])
    spieces = tool_path.sample_pieces
    u = tool_path.sample_params
    out = np.empty(n)
    for k in range(len(dpieces) - 1):
        a, b = dpieces[k], dpieces[k + 1]
        sa, sb = spieces[k], spieces[k + 1]
        tt = np.cumsum(np.where(np.arange(sa, sb) == sa, 0.0, seg_times[sa:sb]))
        rb = dwell_regions(tool_path.dwell_params[a:b], u[sa], u[sb - 1])
        out[a:b] = np.diff(np.interp(rb, u[sa:sb], tt))
    return out


def _rotary_peaks(angles: np.ndarray, seg_t: np.ndarray, spieces: np.ndarray) -> list[float]:
    """The largest velocity of each rotary axis, degrees/min, over the timed samples (``seg_t``: (M,) s)."""
    peak = np.zeros(angles.shape[1])
    for a, b in zip(spieces[:-1], spieces[1:]):
        t = seg_t[a + 1 : b]
        if b - a < 2 or not np.any(t > 0):
            continue
        v = np.abs(np.diff(angles[a:b], axis=0))[t > 0] / t[t > 0, None]
        peak = np.maximum(peak, v.max(axis=0))
    return [float(x) * 60.0 for x in peak]


def _errors(delivered: np.ndarray, wanted: np.ndarray) -> dict[str, float]:
    rel = delivered / wanted - 1.0
    a = np.abs(rel)
    return {"max": float(a.max()), "p99": float(np.percentile(a, 99)), "rms": float(np.sqrt(np.mean(rel**2))),
            "mean": float(rel.mean())}


def schedule_feeds(tool_path: ToolPath, machine: MachineProfile) -> tuple[ToolPath, dict[str, Any]]:
    """The tool path's feeds under a machine's limits, and what they deliver.

    Parameters
    ----------
    tool_path : ToolPath
        From :func:`polishpath.smooth.smooth` (samples at the planned schedule).
    machine : MachineProfile

    Returns
    -------
    tool_path : ToolPath
        The same samples with ``feed_mm_min`` the machine can follow (the speed
        arriving at each sample) and ``stats["machine_schedule"]``.
    report : dict
        ``machine`` (the profile), ``machining_time_s`` (the path moves),
        ``planned_time_s``, ``limited_share`` (segments slower than planned),
        ``limited_by`` (shares bound by a velocity cap / by acceleration),
        ``dwell_time_error`` (max, p99, RMS, mean of delivered / planned - 1 over
        the dwell points), ``dwell_time_error_vs_wish`` (the same against the
        wanted dwell times, beside ``schedule_error_vs_wish`` of the plan alone),
        ``points_over_1pct`` (dwell points taking more than 1 % longer than planned)
        and ``worst_points`` (their indices and errors, worst first, at most 10).
    """
    s = tool_path.samples
    feed = tool_path.feed_mm_min
    spieces = tool_path.sample_pieces
    amax = np.asarray(machine.max_acceleration_mm_s2, dtype=np.float64)
    vmax = np.asarray(machine.max_velocity_mm_min, dtype=np.float64) / 60.0
    kin = machine.kinematics if tool_path.sample_axes is not None else None
    if kin is not None:  # 5-axis: the joints' and rotary axes' limits (degrees/s, degrees/s^2)
        angles_all = kin.angles(tool_path.sample_axes)
        joints_all = kin.joints(s, angles_all)
        amax = np.concatenate([amax, kin.max_acceleration_deg_s2])
        vmax = np.concatenate([vmax, np.asarray(kin.max_velocity_deg_min) / 60.0])
    at = float(machine.max_tangential_acceleration_mm_s2 or 0.0)
    fmax = machine.max_feed_mm_min / 60.0
    new_speed = feed / 60.0  # (M,) speed arriving at each sample, mm/s (a new array)
    plan_t = np.zeros(len(s))
    new_t = np.zeros(len(s))
    n_seg = n_lim = n_cap = 0
    for a, b in zip(spieces[:-1], spieces[1:]):
        if b - a < 2:
            continue
        dp = np.diff(s[a:b], axis=0)
        ln = np.linalg.norm(dp, axis=1)
        plan = feed[a + 1 : b] / 60.0
        plan_t[a + 1 : b] = ln / plan
        nz = ln > 0
        if not nz.any():
            continue
        if kin is not None:  # the five axes' moves per mm of the tool point's path
            dp = np.column_stack([np.diff(joints_all[a:b], axis=0), np.diff(angles_all[a:b], axis=0)])
        L, D, P = ln[nz], dp[nz] / ln[nz, None], plan[nz]
        with np.errstate(divide="ignore"):
            axis_cap = np.min(np.where(np.abs(D) > 0, vmax / np.abs(D), np.inf), axis=1)
        cap = np.minimum(np.minimum(P, fmax), axis_cap)
        sig, _ = _passes(np.ascontiguousarray(L), np.ascontiguousarray(D), cap, amax, at)
        full = plan.copy()
        full[nz] = sig
        new_speed[a + 1 : b] = full
        new_t[a + 1 : b] = np.where(nz, ln / np.maximum(full, 1e-300), 0.0)
        lim = sig < P * (1 - _REL)
        n_seg += int(nz.sum())
        progress.update(int(b), len(s), "samples scheduled")
        n_lim += int(lim.sum())
        n_cap += int(np.sum(lim & (cap < P * (1 - _REL)) & (sig >= cap * (1 - _REL))))
    wish = tool_path.dwell_times
    planned = dwell_point_times(tool_path, plan_t)
    delivered = dwell_point_times(tool_path, new_t)
    rel = delivered / planned - 1.0
    order = np.argsort(-np.abs(rel))[:10]
    report: dict[str, Any] = {
        "machine": machine.to_dict(),
        "jerk_enforced": False,
        "machining_time_s": float(new_t.sum()),
        "planned_time_s": float(plan_t.sum()),
        "time_increase": float(new_t.sum() / plan_t.sum() - 1.0) if plan_t.sum() > 0 else 0.0,
        "segments": n_seg,
        "limited_share": n_lim / n_seg if n_seg else 0.0,
        "limited_by": {"velocity": n_cap / n_seg if n_seg else 0.0,
                       "acceleration": (n_lim - n_cap) / n_seg if n_seg else 0.0},
        "dwell_time_error": _errors(delivered, planned),
        "points_over_1pct": int(np.sum(rel > 0.01)),
        "worst_points": [{"index": int(i), "error": float(rel[i])} for i in order if abs(rel[i]) > 1e-9],
    }
    if kin is not None:
        report["kinematics"] = kin.type
        report["rotary_velocity_max_deg_min"] = _rotary_peaks(angles_all, new_t, spieces)
    if wish is not None:
        report["dwell_time_error_vs_wish"] = _errors(delivered, wish)
        report["schedule_error_vs_wish"] = _errors(planned, wish)
    stats = dict(tool_path.stats)
    stats["machine_schedule"] = {k: v for k, v in report.items() if k not in ("machine", "worst_points")}
    stats["machine_schedule"]["machine"] = machine.name
    # the smoothing schedule regenerates the interpolator's feeds, not these: a streamed job cannot rerun it
    out = dataclasses.replace(tool_path, feed_mm_min=new_speed * 60.0, stats=stats, schedule=None)
    return out, report
