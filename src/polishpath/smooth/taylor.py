"""Taylor integrator: second-order Taylor predictor, exact chord corrector (numba).

The parameter advances by the second-order Taylor step of du/dt = V / |C'(u)|
at a constant feed over the period (the standard step of parametric
interpolators, e.g. Yeh & Hsu 1999)::

    L  = V T
    du = L / |C'| - L^2 (C' . C'') / (2 |C'|^4)

then the shared corrector (:func:`.spans.chord_step`) moves ``du`` until the
chord travelled is ``V T`` to 1e-6: the Taylor step is its starting guess (it
alone drifts where ``|C'|`` changes fast, near the sharp turns of a
pseudo-random path). ``V`` is the scheduled feed of the dwell region holding
``u``, cut by the chord-error limit (:func:`.spans.step_feed`); a step whose
measured chord error exceeds the tolerance is shortened and redone.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .spans import (DIM, checked_deviation, chord_step, grow, nudge, region_at, safe_tolerance, span_at,
                    span_bend_bounds, span_derivs, span_of, span_point, step_feed)

__all__ = ["taylor_kernel"]


@numba.njit(cache=True)
def taylor_kernel(breaks, coeffs, u0, u1, region_b, region_feed, vmax, period_s, tol, cap, state, limit):  # pragma: no cover
    """Constant-period samples of ``[u0, u1]`` by the Taylor predictor and the chord corrector.

    Parameters
    ----------
    breaks : (S + 1,) float
        Span boundaries of the curve parameter.
    coeffs : (S, p + 1, d + 1) float
        Per-span polynomial coefficients (:func:`~polishpath.smooth.nurbs.span_polynomials`).
    u0, u1 : float
        Parameter range to run.
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
    cap : int
        Samples the output buffers first hold (doubled when full): the expected
        count, so that a run of 10^8 samples neither grows its buffers many
        times nor keeps up to twice the room it needs.
    state : (STATE_SIZE,) float
        Where the piece stands (:data:`.spans.STATE_SIZE`), read and updated in
        place: all zeros starts the piece at ``u0`` (its first sample is
        emitted); otherwise the call resumes after the last sample emitted.
    limit : int
        Most samples this call emits (-1: run to the end of the piece). Calls
        that resume with the same state give, one after the other, exactly the
        samples of one call with ``limit=-1``: a step depends only on the
        parameter it starts from.

    Returns
    -------
    params : (M,) float
    points : (M, d) float
        mm.
    feeds : (M,) float
        Commanded feed arriving at each sample, mm/s (first: start feed).
    predictor_max : float
        Largest ``|chord / (V T) - 1|`` of the Taylor step alone.
    fallbacks : int
        Always 0 (the corrector is this integrator's own step).
    """
    d = DIM
    bends, size = span_bend_bounds(breaks, coeffs)  # proves most steps under the tolerance unmeasured
    safe = safe_tolerance(tol, size)
    cap = max(int(cap), 16)
    out_u = np.empty(cap)
    out_p = np.empty((cap, d))
    out_v = np.empty(cap)
    # the kernel's own buffers (no allocation per step): C, C', C'' at the step's start,
    # the step's end point, a scratch point
    pa = np.empty(d)
    pb = np.empty(d)
    c0 = np.empty(d)
    c1 = np.empty(d)
    c2 = np.empty(d)
    pm = np.empty(d)
    nreg = region_feed.shape[0]
    fresh = state[0] == 0.0
    u = u0 if fresh else state[1]
    s = span_at(breaks, u)
    r = region_at(region_b, nreg, u)
    span_point(breaks, coeffs, s, u, pa)
    n = 0
    if fresh:
        out_u[0] = u
        for j in range(d):
            out_p[0, j] = pa[j]
        out_v[0] = min(region_feed[r], vmax)
        n = 1
    guard = 0
    pred_max = 0.0
    more = False
    while u < u1:
        if limit >= 0 and n >= limit:
            more = True
            break
        guard += 1
        if guard > 200_000_000:
            break
        while r < nreg - 1 and u >= region_b[r + 1]:
            r += 1
        s = span_of(breaks, s, u)
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
        v = step_feed(min(region_feed[r], vmax), sp2, acc2, dot, period_s, tol)
        ln = v * period_s
        last = False
        un = u
        for _ in range(60):
            du = ln / sp - ln * ln * dot / (2.0 * sp2 * sp2)
            if du <= 0.0:
                du = ln / sp
            un, pred = chord_step(breaks, coeffs, s, u, u1, pa, ln, du, pb)
            if pred > pred_max:
                pred_max = pred
            last = un >= u1
            err = checked_deviation(breaks, coeffs, bends, safe, s, u, un, pa, pb, pm)
            if err <= tol:
                break
            # shorten: the chord error grows with the square of the step
            f = 0.9 * math.sqrt(tol / err)
            ln *= min(f, 0.9)
            v = ln / period_s
            last = False
        if un <= u:
            un = nudge(breaks, coeffs, s, u, u0, u1, pb)
            last = un >= u1
        if n >= out_u.shape[0]:
            out_u, out_p, out_v = grow(out_u, out_p, out_v, n)
        out_u[n] = un
        for j in range(d):
            out_p[n, j] = pb[j]
        out_v[n] = v
        n += 1
        u = un
        pa, pb = pb, pa  # the step's end is the next step's start
        if last:
            break
    state[0] += n
    state[1] = u
    state[2] = 0.0 if more else 1.0
    return out_u[:n], out_p[:n], out_v[:n], pred_max, 0
