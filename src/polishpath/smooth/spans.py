"""Shared compiled core of the constant-period integrators (numba).

Every integrator (:mod:`.taylor`, :mod:`.abam`) advances the curve parameter one
interpolation period at a time with the same building blocks, kept here so an
integrator is only its own rule for the next parameter:

* :func:`span_point` / :func:`span_derivs` — the point (and the first and
  second derivative) of one polynomial span (the per-span form of
  :func:`polishpath.smooth.nurbs.span_polynomials`, paper Eq. 13), by Horner's
  rule, written into buffers the kernel owns;
* :func:`span_of` — the span holding a parameter, walked from a nearby span;
* :func:`step_feed` — the feed of one step: the schedule, cut by the chord-error
  limit of the local curvature, with a floor so the tool never stalls;
* :func:`chord_step` — the parameter step whose chord is a given length
  (bracketed secant / bisection), the exact corrector of the Taylor integrator
  and the safeguard of the Adams integrator;
* :func:`chord_deviation` — the measured chord error of a step, which every
  integrator holds under the tolerance by shortening the step;
* :func:`span_bend_bounds` / :func:`chord_error_within` — a bound of a step's
  chord error from the largest ``|C''|`` of its spans, which spares the three
  curve evaluations of :func:`chord_deviation` where it already proves the step
  under the tolerance (most steps: only the tight turns need the measurement);
  the step taken, and so every sample, is the same as with the measurement;
* :func:`nudge` — a tiny step over a point where the curve has no speed;
* :func:`chord_errors_kernel` — the chord error of every step of a finished run
  (the independent check the stats report);
* :func:`grow` — the output buffers, doubled when full;
* :func:`span_at` / :func:`region_at` and the kernels' ``state`` (:data:`STATE_SIZE`
  floats: samples emitted, the last one's parameter, whether the piece is done,
  the integrator's history) — what makes a kernel resumable: a call that starts
  where the previous one stopped and emits at most ``limit`` samples gives, call
  after call, exactly the samples of one call over the whole piece (a step
  depends only on the parameter it starts from, and for the Adams integrator on
  the history the state carries).

No function here allocates: every point and derivative goes into a (d,) buffer
the caller passes (``out``, ``pb``, ``scratch``) and the curves have
:data:`DIM` = 3 coordinates, so the loops unroll, so a kernel step costs a few
dozen multiply-adds per curve evaluation and no heap traffic (allocating three
small arrays per evaluation made the kernels several times slower). The
arithmetic, and so every sample, is the same as with allocated arrays.

Hand-written: the hot loops of the project's own interpolator (no well-kept
library offers constant-period NURBS interpolation with a dwell-time schedule).
Units: mm, mm/s, s.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["DIM", "span_point", "span_derivs", "span_of", "step_feed", "chord_step", "chord_deviation", "nudge",
           "chord_errors_kernel", "grow", "span_bend_bounds", "chord_error_within", "checked_deviation",
           "safe_tolerance", "span_at", "region_at", "STATE_SIZE", "new_state"]


DIM = 3
"""Coordinates of the curves the kernels run (a compile-time constant, so the loops over
coordinates unroll; :func:`~polishpath.smooth.interpolate.interpolate_constant_period`
pads a planar curve with a zero coordinate)."""


STATE_SIZE = 11
"""Floats of a kernel's resumable state: ``[0]`` samples emitted so far in the piece (0: the
piece has not started), ``[1]`` the parameter of the last sample emitted, ``[2]`` 1 once the
piece is done, ``[3:7]`` / ``[7:10]`` / ``[10]`` the Adams integrator's history of ``1/|C'|``,
of step lengths and its length (unused by the Taylor integrator)."""


def new_state() -> np.ndarray:
    """A kernel state at the start of a piece, (:data:`STATE_SIZE`,) float64."""
    return np.zeros(STATE_SIZE)


@numba.njit(cache=True)
def span_at(breaks, u):  # pragma: no cover - numba
    """Index of the span holding ``u`` by bisection (the same span :func:`span_of` walks to: the breaks are distinct)."""
    ns = breaks.shape[0] - 1
    s = np.searchsorted(breaks, u, side="right") - 1
    return min(max(s, 0), ns - 1)


@numba.njit(cache=True)
def region_at(region_b, nreg, u):  # pragma: no cover - numba
    """Index of the dwell region holding ``u``: the region the kernels' forward walk from region 0 reaches."""
    r = np.searchsorted(region_b, u, side="right") - 1
    return min(max(r, 0), nreg - 1)


@numba.njit(cache=True)
def span_point(breaks, coeffs, s, u, out):  # pragma: no cover - numba
    """C(u) on span ``s`` into ``out`` (3,), mm (the same Horner sums as :func:`span_derivs`)."""
    h = breaks[s + 1] - breaks[s]
    t = (u - breaks[s]) / h
    p = coeffs.shape[1] - 1
    x = coeffs[s, p, 0]
    y = coeffs[s, p, 1]
    z = coeffs[s, p, 2]
    for k in range(p - 1, -1, -1):
        x = x * t + coeffs[s, k, 0]
        y = y * t + coeffs[s, k, 1]
        z = z * t + coeffs[s, k, 2]
    out[0] = x
    out[1] = y
    out[2] = z


@numba.njit(cache=True)
def span_derivs(breaks, coeffs, s, u, val, d1, d2):  # pragma: no cover - numba
    """C(u), C'(u), C''(u) on span ``s`` into the (3,) buffers ``val``, ``d1``, ``d2`` (mm, mm per unit u, ...)."""
    h = breaks[s + 1] - breaks[s]
    t = (u - breaks[s]) / h
    p = coeffs.shape[1] - 1
    x = coeffs[s, p, 0]
    y = coeffs[s, p, 1]
    z = coeffs[s, p, 2]
    x1 = 0.0
    y1 = 0.0
    z1 = 0.0
    x2 = 0.0
    y2 = 0.0
    z2 = 0.0
    for k in range(p - 1, -1, -1):
        x2 = x2 * t + 2.0 * x1
        x1 = x1 * t + x
        x = x * t + coeffs[s, k, 0]
        y2 = y2 * t + 2.0 * y1
        y1 = y1 * t + y
        y = y * t + coeffs[s, k, 1]
        z2 = z2 * t + 2.0 * z1
        z1 = z1 * t + z
        z = z * t + coeffs[s, k, 2]
    val[0] = x
    val[1] = y
    val[2] = z
    d1[0] = x1 / h
    d1[1] = y1 / h
    d1[2] = z1 / h
    hh = h * h
    d2[0] = x2 / hh
    d2[1] = y2 / hh
    d2[2] = z2 / hh


@numba.njit(cache=True)
def span_of(breaks, s, u):  # pragma: no cover - numba
    """Index of the span holding ``u``, walking from span ``s`` (steps move a span at a time)."""
    ns = breaks.shape[0] - 1
    while s < ns - 1 and u >= breaks[s + 1]:
        s += 1
    while s > 0 and u < breaks[s]:
        s -= 1
    return s


@numba.njit(cache=True)
def step_feed(sched, sp2, acc2, dot, period_s, tol):  # pragma: no cover - numba
    """Feed of one step, mm/s.

    ``sched`` is the scheduled feed (the dwell region's, capped by the machine
    limit); ``sp2 = |C'|^2``, ``acc2 = |C''|^2``, ``dot = C'.C''`` at the step's
    start give the curvature kappa. The feed is cut so that the chord error of
    a step of length ``V T`` on a circle of radius ``rho = 1/kappa`` stays under
    ``tol``: ``V <= 2 sqrt(2 rho tol - tol^2) / T``; never under 0.1 % of the
    schedule.
    """
    sp = math.sqrt(sp2)
    kap = math.sqrt(max(sp2 * acc2 - dot * dot, 0.0)) / (sp2 * sp)
    v = sched
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
    return max(v, 1e-3 * sched)


@numba.njit(cache=True)
def chord_step(breaks, coeffs, s, u, u1, pa, ln, du, pb):  # pragma: no cover - numba
    """Parameter after ``u`` whose chord from ``pa = C(u)`` is ``ln`` (to 1e-6 relative).

    Starts from the guess ``u + du``, brackets the root of ``|C(u + du) - pa| = ln``
    and closes it by safeguarded secant / bisection; stops at ``u1`` when the
    curve ends within the step. ``C`` at the parameter reached is left in ``pb``
    (d,), a buffer other than ``pa``.

    Returns
    -------
    un : float
        The parameter reached (``<= u1``).
    guess_error : float
        ``|chord(u + du) / ln - 1|`` of the starting guess (how far the predictor
        was off), or -1 when not measured (the guess reached ``u1``).
    """
    d = DIM
    lo_du = 0.0
    lo_c = 0.0
    hi_du = -1.0
    hi_c = 0.0
    guess_error = -1.0
    un = u
    for j in range(d):
        pb[j] = pa[j]
    for it in range(60):
        un = u + du
        if un >= u1:
            un = u1
            du = u1 - u
        sn = span_of(breaks, s, un)
        span_point(breaks, coeffs, sn, un, pb)
        act = 0.0
        for j in range(d):
            act += (pb[j] - pa[j]) ** 2
        act = math.sqrt(act)
        if it == 0 and un < u1 and act > 0.0:
            guess_error = abs(act / ln - 1.0)
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
    return un, guess_error


@numba.njit(cache=True)
def chord_deviation(breaks, coeffs, s0, ua, ub, pa, pb, scratch):  # pragma: no cover - numba
    """Largest distance of the curve at 1/4, 1/2, 3/4 of ``[ua, ub]`` from the chord ``[pa, pb]``, mm.

    ``scratch`` is a (d,) buffer for the curve points.
    """
    d = DIM
    ll = 0.0
    for j in range(d):
        ll += (pb[j] - pa[j]) ** 2
    worst = 0.0
    pm = scratch
    for q in range(1, 4):
        um = ua + 0.25 * q * (ub - ua)
        sm = span_of(breaks, s0, um)
        span_point(breaks, coeffs, sm, um, pm)
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
def span_bend_bounds(breaks, coeffs):  # pragma: no cover - numba
    """Largest ``|C''(u)|`` over each span, (S,) mm per unit parameter squared, and the curve's size, mm.

    On a span ``C(t) = sum_k c_k t^k`` with ``t = (u - b_s) / h``, so
    ``C''(u) = sum_k k (k - 1) c_k t^(k-2) / h^2``: for a cubic that is linear in
    ``t`` and its norm (convex) is largest at an end of the span; for higher
    degrees the triangle inequality bounds it. The size (largest coordinate)
    sets the margin left for rounding in :func:`chord_error_within`.
    """
    ns = coeffs.shape[0]
    p = coeffs.shape[1] - 1
    out = np.zeros(ns)
    size = 0.0
    for s in range(ns):
        h = breaks[s + 1] - breaks[s]
        for j in range(DIM):
            size = max(size, abs(coeffs[s, 0, j]))
        if p < 2 or h <= 0.0:
            continue
        if p <= 3:
            a0 = 0.0
            a1 = 0.0
            for j in range(DIM):
                c2 = 2.0 * coeffs[s, 2, j]
                c3 = 6.0 * coeffs[s, 3, j] if p == 3 else 0.0
                a0 += c2 * c2
                a1 += (c2 + c3) * (c2 + c3)
            m = math.sqrt(max(a0, a1))
        else:
            m = 0.0
            for k in range(2, p + 1):
                a = 0.0
                for j in range(DIM):
                    a += coeffs[s, k, j] ** 2
                m += k * (k - 1) * math.sqrt(a)
        out[s] = m / (h * h)
    return out, size


@numba.njit(cache=True)
def _bend_at(breaks, coeffs, s, u):  # pragma: no cover - numba
    """``|C''(u)|`` on span ``s`` of a curve of degree <= 3 (linear in t there), mm per unit parameter squared."""
    h = breaks[s + 1] - breaks[s]
    t = (u - breaks[s]) / h
    p = coeffs.shape[1] - 1
    a = 0.0
    for j in range(DIM):
        c = 2.0 * coeffs[s, 2, j] + (6.0 * coeffs[s, 3, j] * t if p == 3 else 0.0)
        a += c * c
    return math.sqrt(a) / (h * h)


@numba.njit(cache=True)
def chord_error_within(breaks, coeffs, bends, s0, ua, ub):  # pragma: no cover - numba
    """Upper bound of the distance between the curve on ``[ua, ub]`` and its chord, mm.

    The linear interpolant's error ``|C(u) - L(u)| <= (u - ua)(ub - u) / 2 max|C''|``
    (the Peano kernel of linear interpolation is one-signed, so it holds for a
    vector-valued C), at most ``(ub - ua)^2 / 8 max|C''|``; ``L(u)`` lies on the
    chord, so the distance to the chord is no larger. ``max|C''|`` is over the
    part of each span the step covers: for a cubic (``C''`` linear in the span,
    its norm convex) the larger of the two ends, else the span's bound
    ``bends`` (:func:`span_bend_bounds`); the curve is C2 across simple knots,
    and a step never crosses a lift between pieces.
    """
    ns = breaks.shape[0] - 1
    p = coeffs.shape[1] - 1
    s = span_of(breaks, s0, ua)
    m = 0.0
    a = ua
    while True:
        b = ub if (s >= ns - 1 or ub <= breaks[s + 1]) else breaks[s + 1]
        if p < 2:
            pass
        elif p <= 3:
            m = max(m, _bend_at(breaks, coeffs, s, a), _bend_at(breaks, coeffs, s, b))
        else:
            m = max(m, bends[s])
        if b >= ub:
            break
        s += 1
        a = b
    du = ub - ua
    return 0.125 * du * du * m


@numba.njit(cache=True)
def checked_deviation(breaks, coeffs, bends, safe, s0, ua, ub, pa, pb, scratch):  # pragma: no cover - numba
    """The step's chord error as the kernels compare it with the tolerance, mm.

    The bound of :func:`chord_error_within` when it is at most ``safe`` (the
    tolerance less a rounding margin, so the measured error would be under the
    tolerance too and the kernel accepts the step either way), else the
    measured :func:`chord_deviation`.
    """
    b = chord_error_within(breaks, coeffs, bends, s0, ua, ub)
    if b <= safe:
        return b
    return chord_deviation(breaks, coeffs, s0, ua, ub, pa, pb, scratch)


@numba.njit(cache=True)
def safe_tolerance(tol, size):  # pragma: no cover - numba
    """The tolerance less a margin for the rounding of the measured chord error (1e-9 of the curve's size, far above the 1e-15 rounding)."""
    return 0.99 * tol - 1e-9 * max(size, 1.0)


@numba.njit(cache=True)
def nudge(breaks, coeffs, s, u, u0, u1, pb):  # pragma: no cover - numba
    """A step that made no progress in floating point (|C'| ~ 0 at a cusp): step over the
    point by a parameter increment tiny on the curve's scale. Returns ``un``; ``C(un)`` goes into ``pb``."""
    un = min(u + 1e-9 * (u1 - u0), u1)
    sn = span_of(breaks, s, un)
    span_point(breaks, coeffs, sn, un, pb)
    return un


@numba.njit(cache=True)
def chord_errors_kernel(breaks, coeffs, params, samples, n_check):  # pragma: no cover - numba
    """Largest distance of the curve from each chord between consecutive samples, (M - 1,) mm.

    At ``n_check`` equally spaced interior parameters of each step (the
    interpolator's own check points for ``n_check = 3``), walking the spans in
    sample order; ``samples`` (M, 3).
    """
    m = params.shape[0]
    out = np.zeros(max(m - 1, 0))
    pm = np.empty(DIM)
    s = span_of(breaks, 0, params[0]) if m else 0
    for i in range(m - 1):
        ua = params[i]
        ub = params[i + 1]
        ll = 0.0
        for j in range(DIM):
            ll += (samples[i + 1, j] - samples[i, j]) ** 2
        worst = 0.0
        for q in range(1, n_check + 1):
            um = ua + q / (n_check + 1) * (ub - ua)
            s = span_of(breaks, s, um)
            span_point(breaks, coeffs, s, um, pm)
            tt = 0.0
            for j in range(DIM):
                tt += (pm[j] - samples[i, j]) * (samples[i + 1, j] - samples[i, j])
            t = min(max(tt / ll, 0.0), 1.0) if ll > 0 else 0.0
            r = 0.0
            for j in range(DIM):
                r += (samples[i, j] + t * (samples[i + 1, j] - samples[i, j]) - pm[j]) ** 2
            worst = max(worst, math.sqrt(r))
        out[i] = worst
    return out


@numba.njit(cache=True)
def grow(out_u, out_p, out_v, n):  # pragma: no cover - numba
    """The three output buffers with twice the room, first ``n`` rows kept."""
    cap = 2 * out_u.shape[0]
    d = out_p.shape[1]
    nu = np.empty(cap)
    nu[:n] = out_u[:n]
    np_ = np.empty((cap, d))
    np_[:n] = out_p[:n]
    nv = np.empty(cap)
    nv[:n] = out_v[:n]
    return nu, np_, nv
