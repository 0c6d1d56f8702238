"""Interpolation at a constant period (the paper's "equal-periodic interpolation").

The machine's interpolator emits one point per period T. Along the curve C(u)
the parameter advances by a second-order Taylor step (the standard one for
parametric interpolators, e.g. Yeh & Hsu 1999)::

    L  = V T
    du = L / |C'| - L^2 (C' . C'') / (2 |C'|^4)

The feed V is the wanted feed, cut where the curvature kappa would make the chord
error ``rho - sqrt(rho^2 - (L/2)^2)`` (rho = 1/kappa) exceed the tolerance
delta: ``V <= 2 sqrt(2 rho delta - delta^2) / T``. The Taylor step is then
corrected (bracketed secant on du) until the chord travelled is V T, and since
the curvature changes within a step, every step is checked at 1/4, 1/2 and 3/4
of its parameter range and shortened until the measured chord error is under
``delta`` — so the tolerance holds where it is measured, not only as an estimate.

The hot loop is hand-written (numba): it is the project's own interpolator; no
well-kept library offers constant-period NURBS interpolation.

A per-dwell-point time becomes a feed schedule: the region of dwell point k runs
from the parameter midpoint of the previous interval to that of the next one,
and the feed there is its arc length divided by the time wanted.

Units: mm, mm/min for feeds, ms for the period, s for dwell times.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..errors import ParameterError, SmoothingError
from ..types import NurbsCurve
from .nurbs import evaluate, span_polynomials

__all__ = ["arc_lengths", "dwell_regions", "interpolate_constant_period", "chord_errors"]

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


@numba.njit(cache=True)
def _eval3(breaks, coeffs, s, u):  # pragma: no cover - numba
    h = breaks[s + 1] - breaks[s]
    t = (u - breaks[s]) / h
    p = coeffs.shape[1] - 1
    d = coeffs.shape[2] - 1
    val = np.empty(d)
    d1 = np.zeros(d)
    d2 = np.zeros(d)
    for j in range(d):
        val[j] = coeffs[s, p, j]
    for k in range(p - 1, -1, -1):
        for j in range(d):
            d2[j] = d2[j] * t + 2.0 * d1[j]
            d1[j] = d1[j] * t + val[j]
            val[j] = val[j] * t + coeffs[s, k, j]
    for j in range(d):
        d1[j] /= h
        d2[j] /= h * h
    return val, d1, d2


@numba.njit(cache=True)
def _span_of(breaks, s, u):  # pragma: no cover - numba
    ns = breaks.shape[0] - 1
    while s < ns - 1 and u >= breaks[s + 1]:
        s += 1
    while s > 0 and u < breaks[s]:
        s -= 1
    return s


@numba.njit(cache=True)
def _mid_error(breaks, coeffs, s0, ua, ub, pa, pb):  # pragma: no cover - numba
    # largest distance from the chord [pa, pb] of the curve at 1/4, 1/2, 3/4 of the step
    d = pa.shape[0]
    ll = 0.0
    for j in range(d):
        ll += (pb[j] - pa[j]) ** 2
    worst = 0.0
    for q in range(1, 4):
        um = ua + 0.25 * q * (ub - ua)
        sm = _span_of(breaks, s0, um)
        pm, _, _ = _eval3(breaks, coeffs, sm, um)
        tt = 0.0
        for j in range(d):
            tt += (pm[j] - pa[j]) * (pb[j] - pa[j])
        t = tt / ll if ll > 0 else 0.0
        t = min(max(t, 0.0), 1.0)
        r = 0.0
        for j in range(d):
            r += (pa[j] + t * (pb[j] - pa[j]) - pm[j]) ** 2
        worst = max(worst, math.sqrt(r))
    return worst


@numba.njit(cache=True)
def _interp_kernel(breaks, coeffs, u0, u1, region_b, region_feed, vmax, period_s, tol):  # pragma: no cover
    d = coeffs.shape[2] - 1
    cap = 1024
    out_u = np.empty(cap)
    out_p = np.empty((cap, d))
    out_v = np.empty(cap)
    u = u0
    s = _span_of(breaks, 0, u)
    r = 0
    nreg = region_feed.shape[0]
    pa, _, _ = _eval3(breaks, coeffs, s, u)
    n = 0
    out_u[0] = u
    for j in range(d):
        out_p[0, j] = pa[j]
    while r < nreg - 1 and u >= region_b[r + 1]:
        r += 1
    out_v[0] = min(region_feed[r], vmax)
    n = 1
    guard = 0
    pred_max = 0.0
    while u < u1:
        guard += 1
        if guard > 200_000_000:
            break
        while r < nreg - 1 and u >= region_b[r + 1]:
            r += 1
        s = _span_of(breaks, s, u)
        c0, c1, c2 = _eval3(breaks, coeffs, s, u)
        sp2 = 0.0
        acc2 = 0.0
        dot = 0.0
        for j in range(d):
            sp2 += c1[j] * c1[j]
            acc2 += c2[j] * c2[j]
            dot += c1[j] * c2[j]
        sp = math.sqrt(sp2)
        if sp <= 0.0:
            break
        kap = math.sqrt(max(sp2 * acc2 - dot * dot, 0.0)) / (sp2 * sp)
        v = min(region_feed[r], vmax)
        if kap > 0.0:
            rho = 1.0 / kap
            if tol < rho:
                vlim = 2.0 * math.sqrt(2.0 * rho * tol - tol * tol) / period_s
                v = min(v, vlim)
            else:
                # radius under the tolerance (a near-cusp where the path doubles back): the
                # whole turn fits inside one chord, so the curvature limit says nothing
                # useful; crawl at the feed floor instead of stalling at zero speed
                v = min(v, tol / period_s)
        # feed floor: 0.1 % of the schedule, so the tool never stalls where |C'| -> 0
        v = max(v, 1e-3 * min(region_feed[r], vmax))
        ln = v * period_s
        last = False
        for _ in range(60):
            du = ln / sp - ln * ln * dot / (2.0 * sp2 * sp2)
            if du <= 0.0:
                du = ln / sp
            # corrector: solve |C(u + du) - C(u)| = V T for du, starting from the Taylor
            # predictor (which alone drifts where |C'| changes fast, e.g. near cusps):
            # bracket the root, then safeguarded secant / bisection
            lo_du = 0.0
            lo_c = 0.0
            hi_du = -1.0
            hi_c = 0.0
            for it in range(60):
                un = u + du
                if un >= u1:
                    un = u1
                    du = u1 - u
                sn = _span_of(breaks, s, un)
                pb, _, _ = _eval3(breaks, coeffs, sn, un)
                act = 0.0
                for j in range(d):
                    act += (pb[j] - pa[j]) ** 2
                act = math.sqrt(act)
                if it == 0 and un < u1 and act > 0.0:
                    pred = abs(act / ln - 1.0)
                    if pred > pred_max:
                        pred_max = pred
                if abs(act / ln - 1.0) < 1e-6:
                    break
                if act < ln:
                    if un >= u1:
                        break  # the curve ends within this step
                    lo_du = du
                    lo_c = act
                else:
                    hi_du = du
                    hi_c = act
                if hi_du < 0.0:
                    du = du * 2.0 if act <= 0.0 else du * min(ln / act, 2.0) * 1.01
                    if du <= lo_du:
                        du = lo_du * 1.5
                else:
                    # secant between the bracket ends, kept inside the bracket
                    cand = lo_du + (ln - lo_c) * (hi_du - lo_du) / (hi_c - lo_c) if hi_c > lo_c else -1.0
                    width = hi_du - lo_du
                    if cand <= lo_du + 0.01 * width or cand >= hi_du - 0.01 * width:
                        cand = 0.5 * (lo_du + hi_du)
                    du = cand
            last = un >= u1
            err = _mid_error(breaks, coeffs, s, u, un, pa, pb)
            if err <= tol:
                break
            # shorten: the chord error grows with the square of the step
            f = 0.9 * math.sqrt(tol / err)
            ln *= min(f, 0.9)
            v = ln / period_s
            last = False
        if un <= u:
            # no progress in floating point (|C'| ~ 0 at a cusp): step over it by a
            # parameter increment that is tiny on the curve's scale
            un = min(u + 1e-9 * (u1 - u0), u1)
            sn = _span_of(breaks, s, un)
            pb, _, _ = _eval3(breaks, coeffs, sn, un)
            last = un >= u1
        if n >= cap:
            cap *= 2
            nu = np.empty(cap)
            nu[:n] = out_u[:n]
            out_u = nu
            np_ = np.empty((cap, d))
            np_[:n] = out_p[:n]
            out_p = np_
            nv = np.empty(cap)
            nv[:n] = out_v[:n]
            out_v = nv
        out_u[n] = un
        for j in range(d):
            out_p[n, j] = pb[j]
        out_v[n] = v
        n += 1
        u = un
        pa = pb
        if last:
            break
    return out_u[:n], out_p[:n], out_v[:n], pred_max


def chord_errors(curve: NurbsCurve, sample_params: np.ndarray, samples: np.ndarray, n_check: int = 3) -> np.ndarray:
    """Largest distance of the curve from each chord between consecutive samples.

    Parameters
    ----------
    curve : NurbsCurve
    sample_params : (M,) float
    samples : (M, d) float
        Consecutive samples joined by straight moves.
    n_check : int
        Interior parameters checked per step (equally spaced).

    Returns
    -------
    err : (M - 1,) float64
        mm.
    """
    ua, ub = sample_params[:-1], sample_params[1:]
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

    Returns
    -------
    result : dict
        ``samples`` (M, d) mm, ``params`` (M,), ``feed_mm_min`` (M,) commanded
        feed arriving at each sample (first: start feed), and ``stats``:
        ``n_samples``, ``chord_error_max`` (mm, at 3 interior points per step,
        the same points the interpolator holds under the tolerance), ``feed_fluctuation_max`` / ``feed_fluctuation_rms`` (relative
        difference between the step actually travelled and V T, last step
        excluded, after the corrector), ``taylor_fluctuation_max`` (the same for
        the second-order Taylor predictor alone), ``feed_limited_share`` (share of steps slowed below the
        schedule by curvature or the limit), ``duration_s``, and with dwell
        times ``dwell_time_error_max`` (largest relative difference between the
        time spent in a region and the time wanted).
    """
    if not (feed_mm_min > 0 and math.isfinite(feed_mm_min)):
        raise ParameterError(f"feed_mm_min must be a positive number, got {feed_mm_min}.")
    if not (period_ms > 0 and math.isfinite(period_ms)):
        raise ParameterError(f"period_ms must be a positive number of milliseconds, got {period_ms}.")
    if not (chord_tol_mm > 0 and math.isfinite(chord_tol_mm)):
        raise ParameterError(f"chord_tol_mm must be a positive number of mm, got {chord_tol_mm}.")
    if not np.all(curve.weights == 1.0):
        raise SmoothingError("Constant-period interpolation supports non-rational curves (weights 1) only.")
    breaks, coeffs, _ = span_polynomials(curve)
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
    cf = np.ascontiguousarray(coeffs)
    pu, pp, pv, pred_max = _interp_kernel(breaks, cf, u0, u1, rb, rfeed, vmax, T, chord_tol_mm)
    passes = 1
    if dwell_times is not None:
        # Where the curvature limit slows the tool, a region takes longer than wanted; raise
        # that region's feed on its unconstrained part (damped fixed point
        # f <- f * (spent / wanted)^0.7, capped by the machine limit) and run again; keep
        # the run whose worst region is best.
        def worst(pu_):
            spent_ = np.diff(np.interp(rb, pu_, np.arange(len(pu_)) * T))
            return spent_ / dt, float(np.max(np.abs(spent_ / dt - 1)))

        rel, err = worst(pu)
        best = (err, pu, pp, pv)
        for _ in range(max(0, int(schedule_passes) - 1)):
            if err < 0.01:
                break
            new_feed = np.minimum(rfeed * np.clip(rel, 0.5, 2.0) ** 0.7, vmax)
            if np.allclose(new_feed, rfeed, rtol=1e-3):
                break
            rfeed = new_feed
            pu, pp, pv, pm = _interp_kernel(breaks, cf, u0, u1, rb, rfeed, vmax, T, chord_tol_mm)
            pred_max = max(pred_max, pm)
            passes += 1
            rel, err = worst(pu)
            if err < best[0]:
                best = (err, pu, pp, pv)
        _, pu, pp, pv = best
    steps = np.linalg.norm(np.diff(pp, axis=0), axis=1)
    cmd = pv[1:] * T
    fl = (steps[:-1] - cmd[:-1]) / cmd[:-1] if len(steps) > 1 else np.zeros(0)
    ce = chord_errors(curve, pu, pp) if len(pu) > 1 else np.zeros(0)
    sched = np.minimum(rfeed[np.clip(np.searchsorted(rb, pu[:-1], side="right") - 1, 0, len(rfeed) - 1)], vmax)
    stats = {
        "n_samples": int(len(pu)),
        "chord_error_max": float(ce.max()) if len(ce) else 0.0,
        "chord_tol_mm": float(chord_tol_mm),
        "feed_fluctuation_max": float(np.abs(fl).max()) if len(fl) else 0.0,
        "feed_fluctuation_rms": float(np.sqrt(np.mean(fl**2))) if len(fl) else 0.0,
        "taylor_fluctuation_max": float(pred_max),
        "feed_limited_share": float(np.mean(pv[1:] < sched * (1 - 1e-9))) if len(pv) > 1 else 0.0,
        "duration_s": float((len(pu) - 1) * T),
        "feed_min_mm_min": float(pv.min() * 60.0),
        "feed_max_mm_min": float(pv.max() * 60.0),
        "schedule_passes": passes,
    }
    stats["curve_length"] = float(rl.sum()) if dwell_times is not None else float(steps.sum())
    if dwell_times is not None:
        # time as a piecewise-linear function of the parameter (one period per step)
        tt = np.arange(len(pu)) * T
        spent = np.diff(np.interp(rb, pu, tt))
        stats["dwell_time_error_max"] = float(np.max(np.abs(spent - dt) / dt))
    return {"samples": pp, "params": pu, "feed_mm_min": pv * 60.0, "stats": stats}
