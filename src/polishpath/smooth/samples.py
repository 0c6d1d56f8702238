"""The machine samples as a regenerable stream, and their figures accumulated chunk by chunk.

A 10^7-point path has ~1.5 x 10^8 samples (days of machine time): more than a job
should hold. The samples are a deterministic function of the curve and of a
:class:`~polishpath.types.SampleSchedule` (per piece the parameter range, the
dwell-region boundaries and feeds, the feed limit, the period, the chord
tolerance, the integrator), and the kernels are resumable (:mod:`.spans`: a call
that resumes from the state the previous one left gives the same samples as one
call over the piece), so the samples can be regenerated in chunks of bounded
size whenever they are needed:

* :class:`KernelRun` — one piece run by a kernel, chunk by chunk (or in one call);
* :class:`PieceFigures` — the interpolation figures of one piece (chord error,
  feed fluctuation, feed-limited share, feeds, the time at each dwell-region
  boundary ...) accumulated over the chunks in order, so that a job that keeps
  no sample reports the same figures as one that keeps them all;
* :func:`iter_sample_chunks` — a ToolPath's samples as
  :class:`~polishpath.types.SampleChunk` s, from its curve and schedule.

Units: mm, mm/s inside (mm/min in the chunks' ``feed_mm_min``), s.
"""

from __future__ import annotations

from typing import Callable, Iterator

import numpy as np

from ..errors import ParameterError, SmoothingError
from ..types import SampleChunk, ToolPath
from .spans import chord_errors_kernel, new_state

__all__ = ["KernelRun", "PieceFigures", "iter_sample_chunks", "DEFAULT_STREAM_SAMPLES"]

#: samples per chunk when a piece is run without holding its samples (about 10 MB of arrays)
DEFAULT_STREAM_SAMPLES = 1 << 18


class KernelRun:
    """One piece run by an integrator kernel, in chunks of at most ``size`` samples (None: one call).

    Iterating yields ``(params (m,), points (m, 3) mm, feeds (m,) mm/s)`` in path
    order; afterwards ``pred_max`` and ``fallbacks`` hold the kernel's figures
    over the whole piece.
    """

    def __init__(self, kernel, breaks, coeffs, u0, u1, region_b, region_feed, vmax, period_s, tol,
                 size: int | None = None, cap: int = 1024):
        self.args = (breaks, coeffs, float(u0), float(u1), np.ascontiguousarray(region_b, dtype=np.float64),
                     np.ascontiguousarray(region_feed, dtype=np.float64), float(vmax), float(period_s), float(tol))
        self.kernel = kernel
        self.size = size
        self.cap = cap
        self.pred_max = 0.0
        self.fallbacks = 0

    def __iter__(self) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        state = new_state()
        size = -1 if self.size is None else int(self.size)
        cap = self.cap if self.size is None else size
        while state[2] == 0.0:
            before = state[0]
            pu, pp, pv, pm, nfb = self.kernel(*self.args, cap, state, size)
            self.pred_max = max(self.pred_max, float(pm))
            self.fallbacks += int(nfb)
            if len(pu):
                yield pu, pp, pv
            elif state[0] == before:  # cannot happen (a kernel emits or finishes); never loop on it
                break


class PieceFigures:
    """The interpolation figures of one piece, accumulated over its samples chunk after chunk.

    ``add`` takes consecutive chunks of the piece in order; the step between two
    chunks is measured with the previous chunk's last sample. The figures are
    the same, bit for bit, whatever the chunks, except the sums (the RMS
    fluctuation, a curve length measured from the steps), whose order changes
    (equal to about 1e-15 relative).

    Parameters
    ----------
    breaks, coeffs
        The curve's spans (:func:`.interpolate._kernel_coeffs`).
    region_b : (R + 1,) float
        Dwell-region boundaries of the piece.
    region_feed : (R,) float
        Scheduled feed of each region, mm/s.
    vmax : float
        Machine feed limit, mm/s.
    period_s : float
        Interpolation period, s.
    on_chunk : callable, optional
        Called with each chunk's points (m, 3) (e.g. the boundary check).
    """

    def __init__(self, breaks, coeffs, region_b, region_feed, vmax, period_s,
                 on_chunk: Callable[[np.ndarray], None] | None = None):
        self.breaks, self.coeffs = breaks, coeffs
        self.rb = np.asarray(region_b, dtype=np.float64)
        self.rfeed = np.asarray(region_feed, dtype=np.float64)
        self.vmax, self.T = float(vmax), float(period_s)
        self.on_chunk = on_chunk
        self.n = 0
        self.last: tuple[float, np.ndarray, float] | None = None
        self.ce_max = 0.0
        self.fl_max = 0.0
        self.fl_sq = 0.0
        self.fl_n = 0
        self.pending: np.ndarray | None = None
        self.limited = 0
        self.v_min = np.inf
        self.v_max = -np.inf
        self.length = 0.0
        self.tb = np.zeros(len(self.rb))
        self.jb = 0

    def add(self, pu: np.ndarray, pp: np.ndarray, pv: np.ndarray) -> None:
        """Take the next chunk: params (m,), points (m, 3) mm, feeds (m,) mm/s."""
        if len(pu) == 0:
            return
        if self.last is None:
            eu, ep, ev, base = pu, pp, pv, 0
        else:
            lu, lp, lv = self.last
            eu = np.concatenate([[lu], pu])
            ep = np.concatenate([lp[None, :], pp])
            ev = np.concatenate([[lv], pv])
            base = self.n - 1
        m = len(eu)
        if m >= 2:
            steps = np.linalg.norm(np.diff(ep, axis=0), axis=1)
            cmd = ev[1:] * self.T
            fl = (steps - cmd) / cmd
            # the piece's last step is excluded (it ends where the curve does): hold each chunk's last back
            done = fl[:-1] if self.pending is None else np.concatenate([self.pending, fl[:-1]])
            self.pending = fl[-1:]
            if len(done):
                self.fl_max = max(self.fl_max, float(np.abs(done).max()))
                self.fl_sq += float(np.sum(done**2))
                self.fl_n += len(done)
            ce = chord_errors_kernel(self.breaks, self.coeffs, eu, np.ascontiguousarray(ep), 3)
            self.ce_max = max(self.ce_max, float(ce.max()))
            r = np.clip(np.searchsorted(self.rb, eu[:-1], side="right") - 1, 0, len(self.rfeed) - 1)
            sched = np.minimum(self.rfeed[r], self.vmax)
            self.limited += int(np.count_nonzero(ev[1:] < sched * (1 - 1e-9)))
            self.length += float(steps.sum())
        self.v_min = min(self.v_min, float(pv.min()))
        self.v_max = max(self.v_max, float(pv.max()))
        # time at each region boundary, the time a piecewise-linear function of the parameter
        j1 = int(np.searchsorted(self.rb, eu[-1], side="right"))
        if j1 > self.jb:
            self.tb[self.jb:j1] = np.interp(self.rb[self.jb:j1], eu, (base + np.arange(m)) * self.T)
            self.jb = j1
        if self.on_chunk is not None:
            self.on_chunk(pp)
        self.n += len(pu)
        self.last = (float(pu[-1]), np.array(pp[-1]), float(pv[-1]))

    def boundary_times(self) -> np.ndarray:
        """(R + 1,) time at each dwell-region boundary, s (past the last sample: the last sample's)."""
        out = self.tb.copy()
        out[self.jb:] = max(self.n - 1, 0) * self.T
        return out

    def stats(self) -> dict:
        """The piece's figures (the keys of ``interpolate_constant_period``'s stats that depend on the samples)."""
        n = self.n
        return {
            "n_samples": int(n),
            "chord_error_max": float(self.ce_max),
            "feed_fluctuation_max": float(self.fl_max),
            "feed_fluctuation_rms": float(np.sqrt(self.fl_sq / self.fl_n)) if self.fl_n else 0.0,
            "feed_limited_share": float(self.limited / (n - 1)) if n > 1 else 0.0,
            "duration_s": float((n - 1) * self.T),
            "feed_min_mm_min": float(self.v_min * 60.0),
            "feed_max_mm_min": float(self.v_max * 60.0),
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
    from .interpolate import _kernel_coeffs, integrator_kernel

    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 1:
        raise ParameterError(f"chunk size must be a whole number of samples >= 1, got {size!r}.",
                             "Give e.g. size=262144.")
    sch = _schedule_of(tool_path)
    kernel = integrator_kernel(sch.integrator)
    breaks, cf, _ = _kernel_coeffs(tool_path.curve)
    T = sch.period_ms / 1000.0
    for k in range(sch.n_pieces):
        u0, u1, rb, rf = sch.piece(k)
        for pu, pp, pv in KernelRun(kernel, breaks, cf, u0, u1, rb, rf, sch.max_feed_mm_s, T, sch.chord_tol_mm,
                                    size=int(size)):
            yield SampleChunk(pp, pu, pv * 60.0, k)
