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
and the feed there is its arc length divided by the time wanted.

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
from .abam import abam_kernel
from .samples import DEFAULT_STREAM_SAMPLES, KernelRun, PieceFigures
from .spans import DIM, STATE_SIZE, chord_errors_kernel
from .nurbs import evaluate, span_polynomials
from .taylor import taylor_kernel

__all__ = ["arc_lengths", "dwell_regions", "interpolate_constant_period", "chord_errors", "INTEGRATORS",
           "DEFAULT_INTEGRATOR", "integrator_kernel"]

INTEGRATORS = {"taylor": taylor_kernel, "ab-am": abam_kernel}
"""Name -> compiled kernel; every kernel takes and returns the same arrays (see :func:`.taylor.taylor_kernel`).
The job's option lists the same names (``polishpath.defaults.INTEGRATOR_NAMES``, checked by a test)."""


def integrator_kernel(name: str):
    """The compiled kernel of an integrator name; :class:`ParameterError` naming the choices otherwise."""
    if name not in INTEGRATORS:
        raise ParameterError(f"integrator must be one of {', '.join(map(repr, INTEGRATORS))}, got {name!r}.",
                             "Use 'taylor' (Taylor predictor + exact chord corrector) or 'ab-am' "
                             "(the paper's Adams-Bashforth / Adams-Moulton).")
    return INTEGRATORS[name]


def arc_lengths(curve: NurbsCurve, u0: np.ndarray, u1: np.ndarray, split: np.ndarray | None = None,
                order: int = 4) -> np.ndarray:
    """Arc length of the curve between parameter pairs, (M,) mm.

    Gauss-Legendre quadrature of ``|C'(u)|`` with ``order`` nodes on each of the two
    halves ``[u0, split]`` and ``[split, u1]`` (``split`` defaults to the midpoint;
    pass the dwell parameters so no half straddles a dwell point).
    """
    gx, gw = np.polynomial.legendre.leggauss(order)
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


def _kernel_coeffs(curve: NurbsCurve) -> tuple[np.ndarray, np.ndarray, int]:
    """Span breaks and coefficients with :data:`.spans.DIM` = 3 coordinates (a planar curve gets z = 0), and d."""
    breaks, coeffs, _ = span_polynomials(curve)
    d = coeffs.shape[2] - 1
    if d > DIM:
        raise SmoothingError(f"Constant-period interpolation runs curves in up to {DIM} dimensions, got {d}.",
                             "Give the curve's x, y (and z) coordinates only.")
    if d < DIM:
        padded = np.zeros(coeffs.shape[:2] + (DIM + 1,))
        padded[:, :, :d] = coeffs[:, :, :d]
        padded[:, :, DIM] = coeffs[:, :, d]
        coeffs = padded
    return breaks, np.ascontiguousarray(coeffs), d


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
    schedule_passes: int = 3,
    integrator: str = DEFAULT_INTEGRATOR,
    keep_samples: bool = True,
    chunk_samples: int = DEFAULT_STREAM_SAMPLES,
    chunk_check=None,
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
        With dwell times: most interpolation runs; after each, the feed of every
        region that took too long (slowed by the curvature limit) is raised in
        proportion, so the time spent around each dwell point approaches the
        wish (within the machine feed limit).
    integrator : {"taylor", "ab-am"}
        How the parameter advances each period (:data:`INTEGRATORS`).
    keep_samples : bool
        False: hold no sample; the kernel runs in chunks of ``chunk_samples``
        and every figure is accumulated chunk by chunk (the same figures;
        ``samples`` / ``params`` / ``feed_mm_min`` come back empty).
    chunk_samples : int
        Samples per chunk without ``keep_samples``.
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
    breaks, cf, d = _kernel_coeffs(curve)
    u0, u1 = (float(curve.knots[0]), float(curve.knots[-1])) if u_range is None else map(float, u_range)
    T = period_ms / 1000.0
    vmax = (max_feed_mm_min if max_feed_mm_min is not None else np.inf) / 60.0
    if dwell_times is not None:
        if dwell_params is None:
            raise ParameterError("dwell_times need dwell_params (the curve parameter of each dwell point).")
        dt = np.asarray(dwell_times, dtype=np.float64)
        dp = np.asarray(dwell_params, dtype=np.float64)
        if dt.shape != dp.shape:
            raise ParameterError(f"dwell_times has shape {dt.shape} but there are {dp.shape} dwell points.")
        if not np.all(dt > 0) or not np.all(np.isfinite(dt)):
            raise ParameterError("Every dwell time must be a positive number of seconds.")
        rb = dwell_regions(dp, u0, u1)
        rl = arc_lengths(curve, rb[:-1], rb[1:], split=dp, order=3)
        rfeed = rl / dt  # mm/s
    else:
        rb = np.array([u0, u1])
        rfeed = np.array([feed_mm_min / 60.0])
    t_start = time.perf_counter()
    # room for the expected samples (the time wanted over the period; the curvature limit adds some)
    expect = (float(dt.sum()) if dwell_times is not None else float(arc_lengths(curve, [u0], [u1])[0]) / rfeed[0]) / T
    cap = int(min(max(1.05 * expect, 0.0), 4e9)) + 1024
    chunked = not keep_samples
    size = int(chunk_samples) if chunked else None

    def run(feed, room):
        """One interpolation run: (figures, samples or None, kernel run); figures accumulated chunk by
        chunk when no sample is kept (every run's: the best run's are the result), else after the run."""
        kr = KernelRun(kernel, breaks, cf, u0, u1, rb, feed, vmax, T, chord_tol_mm, size=size, cap=room)
        fig = PieceFigures(breaks, cf, rb, feed, vmax, T, on_chunk=chunk_check() if chunk_check else None)
        if chunked:
            for chunk in kr:
                fig.add(*chunk)
            return fig, None, kr
        ((pu_, pp_, pv_),) = list(kr)
        return fig, (pu_, pp_, pv_), kr

    fig, held_samples, kr = run(rfeed, cap)
    pred_max = kr.pred_max
    passes = 1

    def boundary_times(fig_, smp):
        if smp is None:
            return fig_.boundary_times()
        return np.interp(rb, smp[0], np.arange(len(smp[0])) * T)

    progress.update(fig.n if chunked else len(held_samples[0]), None, "samples in schedule pass 1")
    best_fig, best_run, best_feed = fig, kr, rfeed
    if dwell_times is not None:
        # Where the curvature limit slows the tool, a region takes longer than wanted; raise
        # that region's feed on its unconstrained part (damped fixed point
        # f <- f * (spent / wanted)^0.7, capped by the machine limit) and run again; keep
        # the run whose worst region is best.
        def worst(tb):
            spent_ = np.diff(tb)
            return spent_ / dt, float(np.max(np.abs(spent_ / dt - 1)))

        # Only one run's samples are held at a time: the best run's feeds are kept, and the
        # best run is run again at the end when a later one was worse (the kernel is
        # deterministic: the same samples, bit for bit). Without samples, the best run's figures are kept.
        rel, err = worst(boundary_times(fig, held_samples))
        best_err, best_pass, held = err, 1, True
        n_last = fig.n if chunked else len(held_samples[0])
        for _ in range(max(0, int(schedule_passes) - 1)):
            if err < 0.01:
                break
            new_feed = np.minimum(rfeed * np.clip(rel, 0.5, 2.0) ** 0.7, vmax)
            if np.allclose(new_feed, rfeed, rtol=1e-3):
                break
            rfeed = new_feed
            room = int(1.02 * n_last) + 1024
            held_samples = None
            fig, held_samples, kr = run(rfeed, room)
            pred_max = max(pred_max, kr.pred_max)
            passes += 1
            n_last = fig.n if chunked else len(held_samples[0])
            progress.update(n_last, None, f"samples in schedule pass {passes}")
            rel, err = worst(boundary_times(fig, held_samples))
            held = err < best_err
            if held:
                best_err, best_feed, best_pass, best_fig, best_run = err, rfeed, passes, fig, kr
        if not held and not chunked:
            room = int(1.02 * n_last) + 1024
            held_samples = None
            best_fig, held_samples, best_run = run(best_feed, room)
            progress.update(len(held_samples[0]), None, f"samples of schedule pass {best_pass} (the best), run again")
    t_interp = time.perf_counter() - t_start
    if not chunked:
        pu, pp, pv = held_samples
        best_fig.add(pu, pp, pv)
    else:
        pu, pp, pv = np.zeros(0), np.zeros((0, DIM)), np.zeros(0)
    n_fb = best_run.fallbacks
    n_smp = best_fig.n
    stats = {
        "n_samples": int(n_smp),
        "chord_tol_mm": float(chord_tol_mm),
        "predictor_fluctuation_max": float(pred_max),
        "fallback_share": float(n_fb / max(n_smp - 1, 1)),
        "integrator": integrator,
        "schedule_passes": passes,
        "interpolation_s": float(t_interp),
    }
    stats.update(best_fig.stats())
    stats["curve_length"] = float(rl.sum()) if dwell_times is not None else float(best_fig.length)
    out = {"samples": pp[:, :d], "params": pu, "feed_mm_min": pv * 60.0, "stats": stats,
           "region_bounds": rb, "region_feed": best_feed, "u_range": (u0, u1), "chunk_check": best_fig.on_chunk}
    if dwell_times is not None:
        spent = np.diff(best_fig.boundary_times())
        rel = (spent - dt) / dt
        stats["dwell_time_error_max"] = float(np.max(np.abs(rel)))
        out["dwell_time_error"] = rel
    return out
