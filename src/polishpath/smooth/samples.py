"""The machine samples as a regenerable stream, and their figures accumulated chunk by chunk.

A 10^7-point path has ~1.5 x 10^8 samples (days of machine time): more than a job
should hold. The samples are a deterministic function of the curve and of a
:class:`~polishpath.types.SampleSchedule` (per piece the parameter range, the
dwell-region boundaries and feeds, the feed limit, the period, the chord
tolerance, the integrator), and the kernels are resumable (:mod:`.spans`: a call
that resumes from the state the previous one left gives the same samples as one
call over the piece), so the samples can be regenerated in chunks of bounded
size whenever they are needed:

* :class:`KernelRun` — one piece run by a kernel, chunk by chunk (or in one
  go), with the interpolation figures of the piece (chord error, feed
  fluctuation, feed-limited share, feeds, the time at each dwell-region
  boundary ...) that the kernel accumulates in its state as it goes, so that a
  job that keeps no sample reports the same figures as one that keeps them all;
* :func:`iter_sample_chunks` — a ToolPath's samples as
  :class:`~polishpath.types.SampleChunk` s, from its curve and schedule.

Units: mm, mm/s inside (mm/min in the chunks' ``feed_mm_min``), s.
"""

from __future__ import annotations

from typing import Iterator

import numpy as np

from ..axes import axes_at_params
from ..errors import ParameterError, SmoothingError
from ..types import SampleChunk, ToolPath
from .kernels import integrator_kernel, kernel_curve
from .spans import (ST_CE_MAX, ST_COUNT, ST_DONE, ST_FALLBACKS, ST_FL_MAX, ST_FL_N, ST_FL_SQ, ST_JB, ST_LENGTH,
                    ST_LIMITED, ST_PRED_MAX, ST_RERUN_REGIONS, ST_RERUN_SAMPLES, ST_RUNS_MAX, ST_V_MAX, ST_V_MIN, new_state)

__all__ = ["KernelRun", "iter_sample_chunks", "DEFAULT_STREAM_SAMPLES"]

#: samples per chunk when a piece is run without holding its samples (about 10 MB of arrays)
DEFAULT_STREAM_SAMPLES = 1 << 18

#: most samples one kernel call emits when a piece is run in one go (longer pieces continue in resumed
#: calls): under the kernels' own guard of 2 x 10^8 iterations per call, which ends a call's loop
MAX_CALL_SAMPLES = 10**8


class KernelRun:
    """One piece run by an integrator kernel, in chunks of at most ``size`` samples (None: in one go; with
    ``schedule``, up to ``size + RERUN_MAX_SAMPLES + 1``: the scheduling kernel ends a call between regions).

    Iterating yields ``(params (m,), points (m, 3) mm, feeds (m,) mm/s)`` in path
    order (in one go: one chunk, unless the room ``cap`` was short, when the
    rest follows in further resumed calls). Afterwards :meth:`figures` and
    :meth:`boundary_times` give the run's figures, accumulated by the kernel in
    its state whatever the chunks (the same sums in the same order, so the same
    figures bit for bit).

    Parameters
    ----------
    kernel
        An integrator kernel (:data:`.kernels.INTEGRATORS`).
    kc : KernelCurve
        The curve's spans and bend bounds (:func:`.kernels.kernel_curve`).
    u0, u1, region_b, region_feed, vmax, period_s, tol
        The piece and its schedule (see :func:`.taylor.taylor_kernel`).
    schedule : tuple, optional
        ``(kernel, region_want, dwell_params, gx, gw, max_runs, rel_tol)``: run the
        scheduling kernel (:func:`.taylor.taylor_schedule_kernel`) instead, which
        finds each region's feed as it runs (``region_feed`` is then only room:
        :attr:`region_feed` holds the feeds found, which regenerate the samples).
    """

    def __init__(self, kernel, kc, u0, u1, region_b, region_feed, vmax, period_s, tol,
                 size: int | None = None, cap: int = 1024, schedule: tuple | None = None):
        self.region_b = np.ascontiguousarray(region_b, dtype=np.float64)
        # a copy: the scheduling kernel writes the feeds it finds into it
        self.region_feed = np.array(region_feed, dtype=np.float64)
        self.args = (kc.breaks, kc.coeffs, kc.bends, kc.size, float(u0), float(u1), self.region_b,
                     self.region_feed, float(vmax), float(period_s), float(tol))
        self.extra = ()
        if schedule is not None:
            kernel, want, dp, gx, gw, max_runs, rel_tol = schedule
            self.extra = (np.ascontiguousarray(want, dtype=np.float64), np.ascontiguousarray(dp, dtype=np.float64),
                          np.ascontiguousarray(gx, dtype=np.float64), np.ascontiguousarray(gw, dtype=np.float64),
                          int(max_runs), float(rel_tol))
        self.kernel = kernel
        self.size = size
        self.cap = max(int(cap), 16)
        self.T = float(period_s)
        self.state = new_state()
        self.times = np.zeros(len(self.region_b))

    def __iter__(self) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        state = self.state
        if self.size is not None:
            while state[ST_DONE] == 0.0:
                before = state[ST_COUNT]
                out = self.kernel(*self.args, state, int(self.size), self.times, *self.extra)
                if len(out[0]):
                    yield out
                elif state[ST_COUNT] == before:  # cannot happen (a kernel emits or finishes); never loop on it
                    break
            return
        parts = []
        room = min(self.cap, MAX_CALL_SAMPLES)
        while state[ST_DONE] == 0.0:
            before = state[ST_COUNT]
            parts.append(self.kernel(*self.args, state, room, self.times, *self.extra))
            if state[ST_COUNT] == before:
                break
            # the expected count was short (a little more at a time), or the piece is longer than one call
            room = min(max(room // 4, 1024), MAX_CALL_SAMPLES) if room < MAX_CALL_SAMPLES else room
        if len(parts) == 1:
            yield parts[0]
        elif parts:
            yield tuple(np.concatenate([p[j] for p in parts]) for j in range(3))

    @property
    def n(self) -> int:
        return int(self.state[ST_COUNT])

    def reruns(self) -> tuple[int, int, int]:
        """(regions the scheduling kernel ran again, samples those runs made and discarded, the most runs
        of one region); (0, 0, 1) otherwise."""
        return (int(self.state[ST_RERUN_REGIONS]), int(self.state[ST_RERUN_SAMPLES]),
                max(int(self.state[ST_RUNS_MAX]), 1))

    def boundary_times(self) -> np.ndarray:
        """(R + 1,) time at each dwell-region boundary, s (past the last sample: the last sample's)."""
        out = self.times.copy()
        out[int(self.state[ST_JB]):] = max(self.n - 1, 0) * self.T
        return out

    def figures(self) -> dict:
        """The run's figures (the keys of ``interpolate_constant_period``'s stats that depend on the samples)."""
        st, n = self.state, self.n
        return {
            "n_samples": n,
            "chord_error_max": float(st[ST_CE_MAX]),
            "feed_fluctuation_max": float(st[ST_FL_MAX]),
            "feed_fluctuation_rms": float(np.sqrt(st[ST_FL_SQ] / st[ST_FL_N])) if st[ST_FL_N] else 0.0,
            "predictor_fluctuation_max": float(st[ST_PRED_MAX]),
            "fallback_share": float(st[ST_FALLBACKS] / max(n - 1, 1)),
            "feed_limited_share": float(st[ST_LIMITED] / (n - 1)) if n > 1 else 0.0,
            "duration_s": float((n - 1) * self.T),
            "feed_min_mm_min": float(st[ST_V_MIN] * 60.0),
            "feed_max_mm_min": float(st[ST_V_MAX] * 60.0),
            "steps_length_mm": float(st[ST_LENGTH]),
        }


def _schedule_of(tool_path: ToolPath):
    sch = tool_path.schedule
    if sch is None:
        raise SmoothingError(
            "This ToolPath has no sample schedule, so its samples cannot be regenerated.",
            "Make it with polishpath.smooth.smooth() (and do not change its feeds afterwards), "
            "or use its sample arrays.")
    return sch


def iter_sample_chunks(tool_path: ToolPath, size: int = DEFAULT_STREAM_SAMPLES) -> Iterator[SampleChunk]:
    """The ToolPath's machine samples, regenerated from its curve and schedule, in chunks.

    Parameters
    ----------
    tool_path : ToolPath
        From :func:`polishpath.smooth.smooth` (``keep_samples`` either way):
        ``curve`` and ``schedule`` are read, the sample arrays are not.
    size : int
        Most samples per chunk (>= 1); memory is bounded by it.

    Yields
    ------
    SampleChunk
        Consecutive samples of one piece, pieces in order, each chunk within a
        piece (the contract of ``polishpath.export.chunks``): concatenated,
        ``samples``, ``sample_params`` and ``feed_mm_min`` equal, bit for bit,
        the arrays ``smooth(..., keep_samples=True)`` holds.
    """
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 1:
        raise ParameterError(f"chunk size must be a whole number of samples >= 1, got {size!r}.",
                             "Give e.g. size=262144.")
    sch = _schedule_of(tool_path)
    kernel = integrator_kernel(sch.integrator)
    kc = kernel_curve(tool_path.curve)
    T = sch.period_ms / 1000.0
    axes = tool_path.surface_path.tool_axes  # the tool axes of a 5-axis job travel with the samples
    for k in range(sch.n_pieces):
        u0, u1, rb, rf = sch.piece(k)
        for pu, pp, pv in KernelRun(kernel, kc, u0, u1, rb, rf, sch.max_feed_mm_s, T, sch.chord_tol_mm,
                                    size=int(size)):
            ax = None if axes is None else axes_at_params(tool_path.surface_path, tool_path.dwell_params, pu)
            yield SampleChunk(pp, pu, pv * 60.0, k, ax)
