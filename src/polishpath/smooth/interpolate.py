"""Interpolation at a constant period (the paper's "equal-periodic interpolation").

The machine's interpolator emits one point per period T. Along the curve C(u)
the parameter advances by one of two integrators of du/dt = V / |C'(u)|
(``integrator=``, :data:`INTEGRATORS`):

* ``"taylor"`` (default, :func:`.taylor.taylor_kernel`): a second-order Taylor
  predictor, then a corrector (bracketed secant on du) until the chord travelled
  is V T to 1e-6;
* ``"ab-am"`` (:func:`.abam.abam_kernel`): the paper's Adams-Bashforth predictor
  and Adams-Moulton corrector (order 4, variable step in arc length, started by
  Runge-Kutta 4), with a safeguard step where it misses.

Both share the span evaluation, the feed of a step and the chord-error check
(:mod:`.spans`). The feed V is the wanted feed, cut where the curvature kappa
would make the chord error ``rho - sqrt(rho^2 - (L/2)^2)`` (rho = 1/kappa,
L = V T) exceed the tolerance delta: ``V <= 2 sqrt(2 rho delta - delta^2) / T``;
and since the curvature changes within a step, every step is checked at 1/4,
1/2 and 3/4 of its parameter range and shortened until the measured chord error
is under ``delta`` — so the tolerance holds where it is measured, not only as
an estimate.

A per-dwell-point time becomes a feed schedule: the region of dwell point k runs
from the parameter midpoint of the previous interval to that of the next one,
and its feed makes it take the time wanted under the curvature limit (the
Taylor kernel finds it as it runs, :func:`.taylor.taylor_schedule_kernel`;
the others solve it before, :mod:`.timing`).

Units: mm, mm/min for feeds, ms for the period, s for dwell times.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .. import progress
from ..defaults import DEFAULT_INTEGRATOR
from ..errors import ParameterError, SmoothingError
from ..types import NurbsCurve
from .samples import DEFAULT_STREAM_SAMPLES, KernelRun
from .kernels import INTEGRATORS, SCHEDULING_KERNELS, KernelCurve, _kernel_coeffs, integrator_kernel, kernel_curve
from .spans import DIM, STATE_SIZE, chord_errors_kernel
from .timing import DEFAULT_ORDER, KERNEL_ORDER, corrected_targets, solve_region_feeds
from .nurbs import evaluate

__all__ = ["arc_lengths", "dwell_regions", "interpolate_constant_period", "chord_errors", "INTEGRATORS",
           "DEFAULT_INTEGRATOR", "integrator_kernel", "kernel_curve", "KernelCurve", "DWELL_TIME_TOL"]

DWELL_TIME_TOL = 0.01
"""Relative miss of a region's time beyond which a corrective schedule pass runs (where a faster feed is possible)."""

REGION_RERUN_TOL = 0.02
"""Relative miss of a region's time beyond which the Taylor kernel runs the region again at a corrected feed
(:func:`.taylor.taylor_schedule_kernel`). Measured on the benchmark disk (10^5 points, 2 runs at most): at
0.01, 35 % of the samples are run again for dwell-time errors max / p99 / RMS 0.285 / 0.093 / 0.018; at 0.02,
20 % for 0.333 / 0.093 / 0.019; at 0.03, 14 % for 0.317 / 0.091 / 0.019 (the whole corrective pass before:
0.353 / 0.140 / 0.026). 0.02 because at 0.03 the mapped cap of tests/test_smooth.py missed by up to 0.029
(p99 0.016), more than the corrective pass (0.027, 0.013); at 0.02 by 0.023 (p99 0.011)."""


def arc_lengths(curve: NurbsCurve, u0: np.ndarray, u1: np.ndarray, split: np.ndarray | None = None,
                order: int = 4) -> np.ndarray:
    """Arc length of the curve between parameter pairs, (M,) mm.

    Gauss-Legendre quadrature of ``|C'(u)|`` with ``order`` nodes on each of the two
    halves ``[u0, split]`` and ``[split, u1]`` (``split`` defaults to the midpoint;
    pass the dwell parameters so no half straddles a dwell point).
    """
    gx, gw = np.polynomial.legendre.leggauss(DEFAULT_ORDER)
    u0 = np.asarray(u0, dtype=np.float64)
    u1 = np.asarray(u1, dtype=np.float64)
    sp_ = 0.5 * (u0 + u1) if split is None else np.asarray(split, dtype=np.float64)
    out = np.zeros(len(u0))
    for a, b in ((u0, sp_), (sp_, u1)):
        mid, half = 0.5 * (a + b), 0.5 * (b - a)
        uu = (mid[:, None] + half[:, None] * gx[None, :]).ravel()
        uu = np.clip(uu, curve.knots[0], curve.knots[-1])
        sp = np.linalg.norm(evaluate(curve, uu, 1)[1], axis=1).reshape(len(u0), -1)
        out += half * (sp * gw[None, :]).sum(axis=1)
    return out


def dwell_regions(dwell_params: np.ndarray, u_start: float, u_end: float) -> np.ndarray:
    """Parameter boundaries of the region around each dwell point, (N + 1,).

    Region k is ``[b[k], b[k+1]]``: from the midpoint between dwell params k-1 and k
    to the midpoint between k and k+1 (the piece ends for the first and last point).
    """
    d = np.asarray(dwell_params, dtype=np.float64)
    return np.concatenate([[u_start], 0.5 * (d[1:] + d[:-1]), [u_end]])


def _padded(points: np.ndarray) -> np.ndarray:
    """(M, d) points as (M, 3), zero coordinates appended."""
    d = points.shape[1]
    if d == DIM:
        return np.ascontiguousarray(points, dtype=np.float64)
    return np.ascontiguousarray(np.concatenate([points, np.zeros((len(points), DIM - d))], axis=1), dtype=np.float64)


def chord_errors(curve: NurbsCurve, sample_params: np.ndarray, samples: np.ndarray, n_check: int = 3) -> np.ndarray:
    """Largest distance of the curve from each chord between consecutive samples.

    Parameters
    ----------
    curve : NurbsCurve
    sample_params : (M,) float
        Ascending.
    samples : (M, d) float
        Consecutive samples joined by straight moves.
    n_check : int
        Interior parameters checked per step (equally spaced).

    Returns
    -------
    err : (M - 1,) float64
        mm.

    Notes
    -----
    A compiled loop over the steps (:func:`.spans.chord_errors_kernel`) for
    non-rational curves in up to 3 dimensions, else vectorised evaluation.
    """
    params = np.ascontiguousarray(sample_params, dtype=np.float64)
    if np.all(curve.weights == 1.0) and np.asarray(samples).shape[1] <= DIM and len(params) > 0:
        breaks, coeffs, _ = _kernel_coeffs(curve)
        return chord_errors_kernel(breaks, coeffs, params, _padded(np.asarray(samples)), int(n_check))
    ua, ub = params[:-1], params[1:]
    pa, pb = samples[:-1], samples[1:]
    e = pb - pa
    ll = np.einsum("ij,ij->i", e, e)
    out = np.zeros(len(ua))
    for f in (np.arange(1, n_check + 1) / (n_check + 1)):
        pm = evaluate(curve, ua + f * (ub - ua))
        t = np.divide(np.einsum("ij,ij->i", pm - pa, e), ll, out=np.zeros(len(ll)), where=ll > 0)
        t = np.clip(t, 0.0, 1.0)
        out = np.maximum(out, np.linalg.norm(pa + t[:, None] * e - pm, axis=1))
    return out


def interpolate_constant_period(
    curve: NurbsCurve,
    feed_mm_min: float,
    period_ms: float,
    chord_tol_mm: float,
    *,
    dwell_params: np.ndarray | None = None,
    dwell_times: np.ndarray | None = None,
    max_feed_mm_min: float | None = None,
    u_range: tuple[float, float] | None = None,
    schedule_passes: int = 2,
    integrator: str = DEFAULT_INTEGRATOR,
    keep_samples: bool = True,
    chunk_samples: int = DEFAULT_STREAM_SAMPLES,
    chunk_check=None,
    region_tol: float | None = None,
) -> dict:
    """Samples of the curve at a constant interpolation period.

    Parameters
    ----------
    curve : NurbsCurve
        Non-rational curve (weights 1), mm.
    feed_mm_min : float
        Wanted feed, mm/min (used where no dwell times are given).
    period_ms : float
        Interpolation period T, ms.
    chord_tol_mm : float
        Largest allowed distance between the curve and the straight move joining
        two samples, mm.
    dwell_params : (N,) float, optional
        Curve parameters of the dwell points (needed with ``dwell_times``).
    dwell_times : (N,) float, optional
        Time to spend around each dwell point, s; turned into a feed schedule.
    max_feed_mm_min : float, optional
        Machine feed limit, mm/min (default: no limit beyond the schedule).
    u_range : (float, float), optional
        Part of the curve to run (default: all of it).
    schedule_passes : int
        With dwell times: most runs of a dwell region. The Taylor integrator
        (:data:`SCHEDULING_KERNELS`) runs the path once and finds each region's
        feed as it enters it, from the time the region still wants under the
        curvature limit; a region still off its time by more than
        :data:`REGION_RERUN_TOL` is run again at once at the feed corrected by
        its own miss, up to this many runs (the nearest run is kept;
        :func:`.taylor.taylor_schedule_kernel`). Other integrators run whole
        passes: the first at the feeds solved from each region's time
        (:func:`.timing.solve_region_feeds`), each further one correcting the
        regions still off by more than :data:`DWELL_TIME_TOL` by the previous
        run's miss, the run with the smallest RMS relative miss kept. The stats
        say how many runs a region took at most (``schedule_passes``), how many
        regions were corrected (``schedule_corrected_regions``) and, for the
        Taylor kernel, how many samples the runs made again
        (``schedule_rerun_samples``; 0 for whole passes).
    integrator : {"taylor", "ab-am"}
        How the parameter advances each period (:data:`INTEGRATORS`).
    region_tol : float, optional
        The miss above which a region (Taylor) or a pass (others) is run again: default
        :data:`REGION_RERUN_TOL` / :data:`DWELL_TIME_TOL`.
    keep_samples : bool
        False: hold no sample; the kernel runs in chunks of ``chunk_samples``
        and every figure is accumulated chunk by chunk (the same figures;
        ``samples`` / ``params`` / ``feed_mm_min`` come back empty).
    chunk_samples : int
        Samples per chunk without ``keep_samples`` (the Taylor kernel's up to
        :data:`.taylor.RERUN_MAX_SAMPLES` more).
    chunk_check : callable, optional
        A factory of a further check of the samples: ``chunk_check()`` returns a
        callable that is given each chunk's points (m, 3) in order (one per
        run; the kept run's comes back as ``result["chunk_check"]``).

    Returns
    -------
    result : dict
        ``samples`` (M, d) mm, ``params`` (M,), ``feed_mm_min`` (M,) commanded
        feed arriving at each sample (first: start feed), and ``stats``:
        ``n_samples``, ``chord_error_max`` (mm, at 3 interior points per step,
        the same points the interpolator holds under the tolerance), ``feed_fluctuation_max`` / ``feed_fluctuation_rms`` (relative
        difference between the step actually travelled and V T, last step
        excluded, after the corrector), ``predictor_fluctuation_max`` (the same for
        the integrator's own step before any correction or safeguard: the Taylor
        predictor, or the Adams / Runge-Kutta step), ``fallback_share`` (share of
        steps the Adams integrator left to the safeguard; 0 for Taylor),
        ``integrator``, ``feed_limited_share`` (share of steps slowed below the
        schedule by curvature or the limit), ``duration_s``, and with dwell
        times ``dwell_time_error_max`` (largest relative difference between the
        time spent in a region and the time wanted), ``interpolation_s`` (wall
        time of the kernel runs, every schedule pass included); with dwell times
        also ``dwell_time_error`` (N,): the signed relative difference per dwell point;
        ``region_bounds`` (R + 1,), ``region_feed`` (R,) mm/s and ``u_range``: the
        schedule the samples were made with (what regenerates them).
    """
    if not (feed_mm_min > 0 and math.isfinite(feed_mm_min)):
        raise ParameterError(f"feed_mm_min must be a positive number, got {feed_mm_min}.")
    if not (period_ms > 0 and math.isfinite(period_ms)):
        raise ParameterError(f"period_ms must be a positive number of milliseconds, got {period_ms}.")
    if not (chord_tol_mm > 0 and math.isfinite(chord_tol_mm)):
        raise ParameterError(f"chord_tol_mm must be a positive number of mm, got {chord_tol_mm}.")
    kernel = integrator_kernel(integrator)
    if not np.all(curve.weights == 1.0):
        raise SmoothingError("Constant-period interpolation supports non-rational curves (weights 1) only.")
    kc = kernel_curve(curve)
    d = kc.d
    u0, u1 = (float(curve.knots[0]), float(curve.knots[-1])) if u_range is None else map(float, u_range)
    T = period_ms / 1000.0
    vmax = (max_feed_mm_min if max_feed_mm_min is not None else np.inf) / 60.0
    gx, gw = np.polynomial.legendre.leggauss(DEFAULT_ORDER)
    if dwell_times is not None:
        if dwell_params is None:
            raise ParameterError("dwell_times need dwell_params (the curve parameter of each dwell point).")
        dt = np.asarray(dwell_times, dtype=np.float64)
        dp = np.ascontiguousarray(dwell_params, dtype=np.float64)
        if dt.shape != dp.shape:
            raise ParameterError(f"dwell_times has shape {dt.shape} but there are {dp.shape} dwell points.")
        if not np.all(dt > 0) or not np.all(np.isfinite(dt)):
            raise ParameterError("Every dwell time must be a positive number of seconds.")
        rb = dwell_regions(dp, u0, u1)
        in_kernel = integrator in SCHEDULING_KERNELS
        if in_kernel:
            # the kernel finds each region's feed as it enters it (room here, never used as a feed)
            rfeed, model = np.full(len(dp), 1.0), None
        else:
            # each region's feed from its time under the curvature limit, before any sample (timing.py)
            rfeed, model, _ = solve_region_feeds(kc.breaks, kc.coeffs, rb, dp, dt, vmax, T, chord_tol_mm, gx, gw)
    else:
        rb = np.array([u0, u1])
        rfeed = np.array([feed_mm_min / 60.0])
    t_start = time.perf_counter()
    # room for the expected samples (the time wanted over the period; the curvature limit adds some)
    expect = (float(dt.sum()) if dwell_times is not None else float(arc_lengths(curve, [u0], [u1])[0]) / rfeed[0]) / T
    cap = int(min(max(1.05 * expect, 0.0), 4e9)) + 1024
    chunked = not keep_samples
    size = int(chunk_samples) if chunked else None

    def run(feed, room, schedule=None):
        """One interpolation run: (kernel run with its figures, samples or None, its check or None)."""
        kr = KernelRun(kernel, kc, u0, u1, rb, feed, vmax, T, chord_tol_mm, size=size, cap=room, schedule=schedule)
        check = chunk_check() if (chunk_check is not None and chunked) else None
        held = None
        for chunk in kr:
            if check is not None:
                check(chunk[1])
            if not chunked:
                held = chunk
        if held is None and not chunked:
            held = (np.zeros(0), np.zeros((0, DIM)), np.zeros(0))
        return kr, held, check

    in_kernel = dwell_times is not None and in_kernel
    if in_kernel:
        kx, kw = np.polynomial.legendre.leggauss(KERNEL_ORDER)
        kr, held, check = run(rfeed, cap, (SCHEDULING_KERNELS[integrator], dt, dp, kx, kw,
                                           max(1, int(schedule_passes)),
                                           REGION_RERUN_TOL if region_tol is None else float(region_tol)))
        rfeed = kr.region_feed
    else:
        kr, held, check = run(rfeed, cap)
    corrected, _, passes = kr.reruns()
    progress.update(kr.n, None, "samples in schedule pass 1")
    best = (kr, held, check, rfeed)
    if dwell_times is not None and not in_kernel:
        # The model leaves what it does not see: a step keeps its start's feed over the period,
        # the chord-error check shortens steps the circle's estimate let through. Where a run's
        # region times are off by more than DWELL_TIME_TOL (and a faster feed is possible), the
        # targets are corrected by the run's own miss and the run made again; the run whose
        # region times are nearest (RMS) is kept. Only one run's samples are held at a time:
        # the best run is run again at the end when a later one was worse (the kernel is
        # deterministic: the same samples, bit for bit); without samples its figures are kept.
        def misses(kr_):
            spent_ = np.diff(kr_.boundary_times())
            return spent_, spent_ / dt - 1.0

        spent, rel = misses(kr)
        best_rms = float(np.sqrt(np.mean(rel**2)))
        feeds_now, model_now = rfeed, model
        for _ in range(max(0, int(schedule_passes) - 1)):
            off = (np.abs(rel) > (DWELL_TIME_TOL if region_tol is None else region_tol)) & ~((rel > 0) & (feeds_now >= vmax * (1 - 1e-12)))
            if not off.any():
                break
            f_new, m_new, _ = solve_region_feeds(kc.breaks, kc.coeffs, rb, dp, corrected_targets(dt, spent, model_now),
                                                 vmax, T, chord_tol_mm, gx, gw)
            feeds_now = np.where(off, f_new, feeds_now)
            model_now = np.where(off, m_new, model_now)
            corrected = int(np.count_nonzero(off))
            kr, held, check = None, None, None  # one run's samples at a time: the best's go too
            best = (best[0], None, best[2], best[3])
            kr, held, check = run(feeds_now, int(1.02 * best[0].n) + 1024)
            passes += 1
            progress.update(kr.n, None, f"samples in schedule pass {passes}")
            spent, rel = misses(kr)
            rms = float(np.sqrt(np.mean(rel**2)))
            if rms < best_rms:
                best_rms, best = rms, (kr, held, check, feeds_now)
        if not chunked and best[1] is None:
            held = None
            kr, held, _ = run(best[3], int(1.02 * best[0].n) + 1024)
            best = (kr, held, None, best[3])
            progress.update(kr.n, None, "samples of the best schedule pass, run again")
    t_interp = time.perf_counter() - t_start
    kr, held, check, best_feed = best
    if chunked:
        pu, pp, pv = np.zeros(0), np.zeros((0, DIM)), np.zeros(0)
    else:
        pu, pp, pv = held
        if chunk_check is not None:
            check = chunk_check()
            check(pp)
    figs = kr.figures()
    length = figs.pop("steps_length_mm")
    stats = {"n_samples": figs.pop("n_samples"), "chord_tol_mm": float(chord_tol_mm), "integrator": integrator,
             "schedule_passes": passes, "schedule_corrected_regions": corrected,
             "schedule_rerun_samples": kr.reruns()[1], "interpolation_s": float(t_interp)}
    stats.update(figs)
    stats["curve_length"] = length
    # mm/s -> mm/min in place: the run's own buffer (a 10^6-point figuring job's 3.3e7 feeds are 260 MB)
    out = {"samples": pp[:, :d], "params": pu, "feed_mm_min": np.multiply(pv, 60.0, out=pv), "stats": stats,
           "region_bounds": rb, "region_feed": np.asarray(best_feed, dtype=np.float64), "u_range": (u0, u1),
           "chunk_check": check}
    if dwell_times is not None:
        spent = np.diff(kr.boundary_times())
        rel = (spent - dt) / dt
        stats["dwell_time_error_max"] = float(np.max(np.abs(rel)))
        out["dwell_time_error"] = rel
    return out
