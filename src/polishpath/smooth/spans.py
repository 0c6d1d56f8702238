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
* :func:`chord_newton` — the parameter step whose chord is a given length, by
  Newton's method from the Taylor step (one or two iterates; its last iterate's
  derivatives start the next step), the Taylor integrator's corrector;
  :func:`chord_step` (bracketed secant / bisection) finishes where Newton does
  not converge and is the Adams integrator's safeguard;
* :func:`chord_deviation` — the measured chord error of a step, which every
  integrator holds under the tolerance by shortening the step;
* :func:`span_bend_bounds` / :func:`chord_error_within` / :func:`step_error` — a
  bound of a step's chord error from the largest ``|C''|`` of its spans, which
  spares the three curve evaluations of :func:`chord_deviation` where it already
  proves the step under the tolerance (most steps: only the tight turns need the
  measurement); the step taken is the same as with the measurement;
* :func:`nudge` — a tiny step over a point where the curve has no speed;
* the kernels' ``state`` (:data:`STATE_SIZE` floats, ``ST_*`` indices): where
  the piece stands (samples emitted, the last parameter, done), the Adams
  integrator's history, and the figures of the samples so far
  (:func:`record_step`: chord error, feed fluctuation, feed-limited steps,
  feeds, the time at each dwell-region boundary; :func:`figure_error` measures
  a step's chord error only where it can raise the largest so far, so the
  figure is the measured one at no cost on most steps) — what makes a kernel
  resumable: a call that starts where the previous one stopped and emits at
  most ``limit`` samples gives, call after call, exactly the samples and the
  figures of one call over the whole piece (a step depends only on the
  parameter it starts from, and for the Adams integrator on the history the
  state carries); :func:`span_at` / :func:`region_at` find where to resume;
* :func:`chord_errors_kernel` — the chord error of every step of a finished run
  (an independent check, used by the tests).

No function here allocates: every point and derivative goes into a (d,) buffer
the caller passes (``out``, ``pb``, ``scratch``) and the curves have
:data:`DIM` = 3 coordinates, so the loops unroll, so a kernel step costs a few
dozen multiply-adds per curve evaluation and no heap traffic (allocating three
small arrays per evaluation made the kernels several times slower). The helpers
are compiled without numba's reference counting (``_nrt=False``: they take
arrays but never allocate), and the kernels never rebind an array in their
loop: every array argument of a call otherwise costs an atomic increment and
decrement, which took half of the kernel's time (measured with ``perf``).

Hand-written: the hot loops of the project's own interpolator (no well-kept
library offers constant-period NURBS interpolation with a dwell-time schedule).
Units: mm, mm/s, s.
"""

from __future__ import annotations

import math

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

__all__ = ["DIM", "span_point", "span_derivs", "span_of", "chord_feed_limit", "step_feed", "chord_step", "chord_deviation", "nudge",
           "chord_errors_kernel", "span_bend_bounds", "chord_error_within",
           "safe_tolerance", "span_at", "region_at", "STATE_SIZE", "new_state", "chord_newton", "record_step",
           "start_piece", "step_error", "figure_error"]


DIM = 3
"""Coordinates of the curves the kernels run (a compile-time constant, so the loops over
coordinates unroll; :func:`~polishpath.smooth.interpolate.interpolate_constant_period`
pads a planar curve with a zero coordinate)."""


# The kernels' resumable state, one float64 array (the indices are compile-time constants).
ST_COUNT = 0       # samples emitted so far in the piece (0: the piece has not started)
ST_U = 1           # parameter of the last sample emitted
ST_DONE = 2        # 1 once the piece is done
ST_G = 3           # [3:7] the Adams integrator's 1/|C'| at the last four samples, newest first
ST_H = 7           # [7:10] its last three step lengths, mm
ST_NH = 10         # how much of that history is valid
ST_CE_MAX = 11     # largest chord error of a step, measured at 1/4, 1/2, 3/4 of it, mm
ST_FL_MAX = 12     # largest |chord / (V T) - 1| of a step (the piece's last step excluded)
ST_FL_SQ = 13      # sum of its squares
ST_FL_N = 14       # steps counted in it
ST_LIMITED = 15    # steps whose feed is under the region's schedule (curvature or chord limit)
ST_V_MIN = 16      # least and largest feed of a sample, mm/s
ST_V_MAX = 17
ST_FL_LAST = 18    # the last step's fluctuation, counted once a further step follows
ST_HAS_LAST = 19
ST_LENGTH = 20     # sum of the chords, mm
ST_PRED_MAX = 21   # largest |chord / (V T) - 1| of the integrator's own step before any correction
ST_FALLBACKS = 22  # steps left to the safeguard (Adams) / to the bracketing corrector (Taylor)
ST_JB = 23         # dwell-region boundaries already timed
ST_SR = 24         # scheduling kernel: the region run now, whose time is still to be checked (-1: none)
ST_RSTART = 25     # scheduling kernel: samples emitted when that region was entered
ST_RERUN_REGIONS = 26  # scheduling kernel: regions run again with a corrected feed
ST_RERUN_SAMPLES = 27  # scheduling kernel: samples made by the runs that were run again (discarded)
ST_RUNS_MAX = 28   # scheduling kernel: the most runs of one region
STATE_SIZE = 29
"""Floats of a kernel's resumable state (``ST_*`` indices): where the piece stands (samples
emitted, the last parameter, done), the Adams integrator's history, the scheduling kernel's
region under way, and the figures of the samples so far, so that chunked calls and one call
report the same figures."""


def new_state() -> np.ndarray:
    """A kernel state at the start of a piece, (:data:`STATE_SIZE`,) float64."""
    st = np.zeros(STATE_SIZE)
    st[ST_V_MIN] = np.inf
    st[ST_V_MAX] = -np.inf
    st[ST_SR] = -1.0
    return st


@numba.njit(cache=True, _nrt=False)
def start_piece(state, region_b, region_times, v0):  # pragma: no cover - numba
    """The figures of a piece's first sample (feed ``v0``): boundaries at or before it at time 0."""
    state[ST_V_MIN] = min(state[ST_V_MIN], v0)
    state[ST_V_MAX] = max(state[ST_V_MAX], v0)
    u = state[ST_U]
    j = int(state[ST_JB])
    while j < region_b.shape[0] and region_b[j] <= u:
        region_times[j] = 0.0
        j += 1
    state[ST_JB] = j


@numba.njit(cache=True, _nrt=False)
def record_step(state, region_b, region_times, k, u, un, pa, pb, v, sched, period_s, ce):  # pragma: no cover
    """Add the step from sample ``k - 1`` (``u``, ``pa``) to sample ``k`` (``un``, ``pb``) at feed ``v``
    (scheduled ``sched``, chord error ``ce``) to the piece's figures in ``state``; time the
    dwell-region boundaries it passes (``region_times``, s; the time is linear in the parameter
    over a step, as ``numpy.interp`` over the samples would give it, to the bit; the piece's last
    step, cut short at the piece's end, takes its length over ``v``, as
    :func:`polishpath.dwell.delivery.sample_times` gives it)."""
    act = 0.0
    for j in range(DIM):
        act += (pb[j] - pa[j]) * (pb[j] - pa[j])
    act = math.sqrt(act)
    cmd = v * period_s
    fl = (act - cmd) / cmd
    if state[ST_HAS_LAST] != 0.0:
        last = state[ST_FL_LAST]
        state[ST_FL_MAX] = max(state[ST_FL_MAX], abs(last))
        state[ST_FL_SQ] += last * last
        state[ST_FL_N] += 1.0
    state[ST_FL_LAST] = fl
    state[ST_HAS_LAST] = 1.0
    if v < sched * (1 - 1e-9):
        state[ST_LIMITED] += 1.0
    state[ST_V_MIN] = min(state[ST_V_MIN], v)
    state[ST_V_MAX] = max(state[ST_V_MAX], v)
    state[ST_LENGTH] += act
    state[ST_CE_MAX] = max(state[ST_CE_MAX], ce)
    j = int(state[ST_JB])
    nb = region_b.shape[0]
    if j < nb and region_b[j] <= un:
        t0 = (k - 1) * period_s
        t1 = k * period_s
        if un >= region_b[nb - 1] and act < cmd:
            # the piece's last step, cut short at its end: the controller runs its block at the feed ``v``
            # (the G-code's time is the block's length over its feed), so it takes its length over ``v``,
            # not a whole period (the last region's time is then continuous in its feed)
            t1 = t0 + period_s * (act / cmd)
        slope = (t1 - t0) / (un - u)
        while j < nb and region_b[j] <= un:
            x = region_b[j]
            if x == un:
                region_times[j] = t1
            elif x <= u:
                region_times[j] = t0
            else:
                region_times[j] = slope * (x - u) + t0
            j += 1
        state[ST_JB] = j


@numba.njit(cache=True, _nrt=False)
def span_at(breaks, u):  # pragma: no cover - numba
    """Index of the span holding ``u`` by bisection (the same span :func:`span_of` walks to: the breaks are distinct)."""
    ns = breaks.shape[0] - 1
    s = np.searchsorted(breaks, u, side="right") - 1
    return min(max(s, 0), ns - 1)


@numba.njit(cache=True, _nrt=False)
def region_at(region_b, nreg, u):  # pragma: no cover - numba
    """Index of the dwell region holding ``u``: the region the kernels' forward walk from region 0 reaches."""
    r = np.searchsorted(region_b, u, side="right") - 1
    return min(max(r, 0), nreg - 1)


@numba.njit(cache=True, _nrt=False)
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


@numba.njit(cache=True, _nrt=False)
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


@numba.njit(cache=True, _nrt=False)
def span_of(breaks, s, u):  # pragma: no cover - numba
    """Index of the span holding ``u``, walking from span ``s`` (steps move a span at a time)."""
    ns = breaks.shape[0] - 1
    while s < ns - 1 and u >= breaks[s + 1]:
        s += 1
    while s > 0 and u < breaks[s]:
        s -= 1
    return s


@numba.njit(cache=True, _nrt=False)
def chord_feed_limit(sp2, acc2, dot, period_s, tol):  # pragma: no cover - numba
    """The chord-error feed limit at a curve point, mm/s (inf where the curve is straight).

    ``sp2 = |C'|^2``, ``acc2 = |C''|^2``, ``dot = C'.C''`` give the curvature
    kappa; a step of length ``V T`` on a circle of radius ``rho = 1/kappa`` keeps
    its chord error under ``tol`` while ``V <= 2 sqrt(2 rho tol - tol^2) / T``.
    Where the radius is under the tolerance (a near-cusp where the path doubles
    back) the whole turn fits inside one chord and the curvature says nothing
    useful: the limit is ``tol / T``, a crawl instead of a stall at zero speed.
    The interpolation kernels (:func:`step_feed`) and the schedule's region
    model (:mod:`.timing`) both use it, so the model slows where the kernels do.
    """
    sp = math.sqrt(sp2)
    kap = math.sqrt(max(sp2 * acc2 - dot * dot, 0.0)) / (sp2 * sp)
    if kap > 0.0:
        rho = 1.0 / kap
        if tol < rho:
            return 2.0 * math.sqrt(2.0 * rho * tol - tol * tol) / period_s
        return tol / period_s
    return math.inf


@numba.njit(cache=True, _nrt=False)
def step_feed(sched, sp2, acc2, dot, period_s, tol):  # pragma: no cover - numba
    """Feed of one step, mm/s: the scheduled feed ``sched`` (the dwell region's,
    capped by the machine limit) cut by :func:`chord_feed_limit` at the step's
    start; never under 0.1 % of the schedule (so the tool never stalls where
    ``|C'| -> 0``).
    """
    return max(min(sched, chord_feed_limit(sp2, acc2, dot, period_s, tol)), 1e-3 * sched)


@numba.njit(cache=True, _nrt=False)
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


@numba.njit(cache=True, _nrt=False)
def chord_newton(breaks, coeffs, s, u, u1, pa, ln, du, pb, d1, d2):  # pragma: no cover - numba
    """Parameter after ``u`` whose chord from ``pa = C(u)`` is ``ln`` (to 1e-6 relative), by Newton's method.

    From the guess ``u + du``: each iterate's point and derivatives
    (:func:`span_derivs`, into ``pb``, ``d1``, ``d2``) give the next,
    ``du <- du - (|chord| - ln) |chord| / (chord . C')``; a good guess (the
    Taylor step) converges in one or two iterates. Where it does not (a
    near-cusp, a chord that is not monotonic in the step), the bracketed
    :func:`chord_step` finishes from the guess.

    Returns
    -------
    un : float
        The parameter reached (``<= u1``).
    guess_error : float
        ``|chord(u + du) / ln - 1|`` of the guess, or -1 when not measured.
    derivs : bool
        True when ``d1``, ``d2`` hold ``C'``, ``C''`` at ``un`` (Newton converged; the
        next step starts from them).
    """
    d = DIM
    guess_error = -1.0
    du0 = du
    for it in range(4):
        un = u + du
        if un >= u1:
            un = u1
        sn = span_of(breaks, s, un)
        span_derivs(breaks, coeffs, sn, un, pb, d1, d2)
        act2 = 0.0
        slope = 0.0
        for j in range(d):
            e = pb[j] - pa[j]
            act2 += e * e
            slope += e * d1[j]
        act = math.sqrt(act2)
        if it == 0 and un < u1 and act > 0.0:
            guess_error = abs(act / ln - 1.0)
        if abs(act / ln - 1.0) < 1e-6:
            return un, guess_error, True
        if un >= u1 and act < ln:
            return un, guess_error, True  # the curve ends within this step
        if act <= 0.0 or slope <= 0.0:
            break
        nxt = (un - u) - (act - ln) * act / slope
        if not (nxt > 0.0) or not math.isfinite(nxt):
            break
        du = nxt
    un, g = chord_step(breaks, coeffs, s, u, u1, pa, ln, du0, pb)
    return un, (guess_error if guess_error >= 0.0 else g), False


@numba.njit(cache=True, _nrt=False)
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


@numba.njit(cache=True, _nrt=False)
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


@numba.njit(cache=True, _nrt=False)
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


@numba.njit(cache=True, _nrt=False)
def step_error(breaks, coeffs, bends, safe, s0, ua, ub, pa, pb, scratch):  # pragma: no cover - numba
    """``(error, measured)``: :func:`checked_deviation` and whether it measured (else it is the bound)."""
    b = chord_error_within(breaks, coeffs, bends, s0, ua, ub)
    if b <= safe:
        return b, False
    return chord_deviation(breaks, coeffs, s0, ua, ub, pa, pb, scratch), True


@numba.njit(cache=True, _nrt=False)
def figure_error(breaks, coeffs, s0, ua, ub, pa, pb, scratch, err, measured, ce_max, margin):  # pragma: no cover
    """The accepted step's chord error for the figures: measured at 1/4, 1/2, 3/4 (as
    :func:`chord_errors_kernel` measures it) when that can raise the largest so far, else 0.

    ``err`` is the kernel's check (``measured``: the measurement itself, else the bound,
    which no measurement exceeds by more than the rounding ``margin``): a step whose
    bound is under the largest measured so far cannot change the largest, so most
    steps cost nothing here and the figure is exact.
    """
    if measured:
        return err
    if err + margin > ce_max:
        return chord_deviation(breaks, coeffs, s0, ua, ub, pa, pb, scratch)
    return 0.0


@numba.njit(cache=True, _nrt=False)
def safe_tolerance(tol, size):  # pragma: no cover - numba
    """The tolerance less a margin for the rounding of the measured chord error (1e-9 of the curve's size, far above the 1e-15 rounding)."""
    return 0.99 * tol - 1e-9 * max(size, 1.0)


@numba.njit(cache=True, _nrt=False)
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


