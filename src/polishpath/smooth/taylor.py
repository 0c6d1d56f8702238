"""Taylor integrator: second-order Taylor predictor, Newton chord corrector (numba).

The parameter advances by the second-order Taylor step of du/dt = V / |C'(u)|
at a constant feed over the period (the standard step of parametric
interpolators, e.g. Yeh & Hsu 1999), aimed at the arc whose chord is ``V T``::

    L  = V T (1 + (V T kappa)^2 / 24)
    du = L / |C'| - L^2 (C' . C'') / (2 |C'|^4)

then the corrector (:func:`.spans.chord_newton`) moves ``du`` by Newton's
method until the chord travelled is ``V T`` to 1e-6 (one or two iterates from
this guess; the bracketed :func:`.spans.chord_step` where it does not
converge, counted in ``fallback_share``): the Taylor step alone drifts where
``|C'|`` changes fast, near the sharp turns of a pseudo-random path. ``V`` is
the scheduled feed of the dwell region holding ``u``, cut by the chord-error
limit (:func:`.spans.step_feed`); a step whose chord error exceeds the
tolerance is shortened to just under it and redone.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .spans import (DIM, ST_CE_MAX, ST_COUNT, ST_DONE, ST_FALLBACKS, ST_PRED_MAX, ST_U, chord_deviation, chord_newton,
                    figure_error, nudge, record_step, region_at, safe_tolerance, span_at,
                    span_derivs, span_of, span_point, start_piece, step_error, step_feed)

__all__ = ["taylor_kernel"]


@numba.njit(cache=True)
def taylor_kernel(breaks, coeffs, bends, size, u0, u1, region_b, region_feed, vmax, period_s, tol, state, limit,
                  region_times):  # pragma: no cover
    """Constant-period samples of ``[u0, u1]`` by the Taylor predictor and the chord corrector.

    Parameters
    ----------
    breaks : (S + 1,) float
        Span boundaries of the curve parameter.
    coeffs : (S, p + 1, 4) float
        Per-span polynomial coefficients (:func:`~polishpath.smooth.nurbs.span_polynomials`, 3 coordinates).
    bends, size : (S,) float, float
        :func:`.spans.span_bend_bounds` of the curve (computed once per curve).
    u0, u1 : float
        Parameter range of the piece.
    region_b : (R + 1,) float
        Parameter boundaries of the dwell regions.
    region_feed : (R,) float
        Scheduled feed of each region, mm/s.
    vmax : float
        Machine feed limit, mm/s.
    period_s : float
        Interpolation period T, s.
    tol : float
        Chord tolerance, mm.
    state : (STATE_SIZE,) float
        Where the piece stands and the figures of its samples so far
        (:data:`.spans.STATE_SIZE`, from :func:`.spans.new_state`), read and
        updated in place: a fresh state starts the piece at ``u0`` (its first
        sample is emitted); otherwise the call resumes after the last sample
        emitted.
    limit : int
        Most samples this call emits (>= 1; the size of the output arrays).
        Calls that resume with the same state give, one after the other,
        exactly the samples and figures of one call over the whole piece: a
        step depends only on the parameter it starts from.
    region_times : (R + 1,) float
        Filled with the time at each region boundary the samples pass, s
        (the first ``state[ST_JB]``).

    Returns
    -------
    params : (M,) float
    points : (M, 3) float
        mm.
    feeds : (M,) float
        Commanded feed arriving at each sample, mm/s (first: start feed).

    The figures (chord error, feed fluctuation, the Taylor step's own error,
    steps left to the bracketing corrector ...) accumulate in ``state``.
    """
    d = DIM
    safe = safe_tolerance(tol, size)
    margin = 1e-9 * max(size, 1.0)
    cap = max(int(limit), 1)
    out_u = np.empty(cap)
    out_p = np.empty((cap, d))
    out_v = np.empty(cap)
    # the kernel's own buffers (no allocation per step, and no array rebound in the loop,
    # which would cost atomic reference counts): C, C', C'' at the step's start, the
    # step's end point and its derivatives, a scratch point
    pa = np.empty(d)
    pb = np.empty(d)
    c0 = np.empty(d)
    c1 = np.empty(d)
    c2 = np.empty(d)
    n1 = np.empty(d)
    n2 = np.empty(d)
    pm = np.empty(d)
    nreg = region_feed.shape[0]
    fresh = state[ST_COUNT] == 0.0
    u = u0 if fresh else state[ST_U]
    s = span_at(breaks, u)
    r = region_at(region_b, nreg, u)
    span_point(breaks, coeffs, s, u, pa)
    k0 = int(state[ST_COUNT])  # samples before this call
    n = 0
    if fresh:
        out_u[0] = u
        for j in range(d):
            out_p[0, j] = pa[j]
        out_v[0] = min(region_feed[r], vmax)
        state[ST_U] = u
        start_piece(state, region_b, region_times, out_v[0])
        n = 1
    have = False  # C', C'' at u known from the last step's corrector
    guard = 0
    more = False
    while u < u1:
        if n >= cap:
            more = True
            break
        guard += 1
        if guard > 200_000_000:
            break
        while r < nreg - 1 and u >= region_b[r + 1]:
            r += 1
        s = span_of(breaks, s, u)
        if not have:
            span_derivs(breaks, coeffs, s, u, c0, c1, c2)
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
        sched = min(region_feed[r], vmax)
        v = step_feed(sched, sp2, acc2, dot, period_s, tol)
        # the chord of an arc of length a at curvature kappa is a (1 - (a kappa)^2 / 24): aim
        # the Taylor step at the arc whose chord is V T
        kap2 = max(sp2 * acc2 - dot * dot, 0.0) / (sp2 * sp2 * sp2)
        ln = v * period_s
        last = False
        un = u
        have = False
        err = 0.0
        measured = False
        for _ in range(60):
            a = ln * (1.0 + ln * ln * kap2 / 24.0)
            du = a / sp - a * a * dot / (2.0 * sp2 * sp2)
            if du <= 0.0:
                du = a / sp
            un, pred, have = chord_newton(breaks, coeffs, s, u, u1, pa, ln, du, pb, n1, n2)
            if pred > state[ST_PRED_MAX]:
                state[ST_PRED_MAX] = pred
            last = un >= u1
            err, measured = step_error(breaks, coeffs, bends, safe, s, u, un, pa, pb, pm)
            if err <= tol:
                break
            # shorten: the chord error grows with the square of the step (aim just under the tolerance)
            f = math.sqrt(0.98 * tol / err)
            ln *= min(f, 0.99)
            v = ln / period_s
            last = False
        if not have:
            state[ST_FALLBACKS] += 1.0
        if un <= u:
            un = nudge(breaks, coeffs, s, u, u0, u1, pb)
            last = un >= u1
            have = False
            err, measured = chord_deviation(breaks, coeffs, s, u, un, pa, pb, pm), True
        ce = figure_error(breaks, coeffs, s, u, un, pa, pb, pm, err, measured, state[ST_CE_MAX], margin)
        out_u[n] = un
        for j in range(d):
            out_p[n, j] = pb[j]
        out_v[n] = v
        record_step(state, region_b, region_times, k0 + n, u, un, pa, pb, v, sched, period_s, ce)
        n += 1
        u = un
        # the step's end is the next step's start
        for j in range(d):
            pa[j] = pb[j]
        if have:
            for j in range(d):
                c1[j] = n1[j]
                c2[j] = n2[j]
        if last:
            break
    state[ST_COUNT] += n
    state[ST_U] = u
    state[ST_DONE] = 0.0 if more else 1.0
    return out_u[:n], out_p[:n], out_v[:n]
