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
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

from .spans import (DIM, STATE_SIZE, ST_CE_MAX, ST_COUNT, ST_DONE, ST_FALLBACKS, ST_PRED_MAX, ST_RERUN_REGIONS,
                    ST_RERUN_SAMPLES, ST_RSTART, ST_RUNS_MAX, ST_SR, ST_U, chord_deviation, chord_newton, figure_error, nudge,
                    record_step, region_at, safe_tolerance, span_at, span_derivs, span_of, span_point, start_piece,
                    step_error, step_feed)
from .timing import feed_for_time, next_region_feed, region_nodes, sort_nodes, time_at

__all__ = ["taylor_kernel", "taylor_schedule_kernel", "RERUN_MAX_SAMPLES"]

RERUN_MAX_SAMPLES = 4096
"""Most samples of a dwell region the scheduling kernel runs again (16 s at 4 ms; a longer region
keeps its first run): what a kernel call's output holds beyond its ``limit``."""


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
    none = np.empty(0)
    return _taylor_run(breaks, coeffs, bends, size, u0, u1, region_b, region_feed, vmax, period_s, tol, state, limit,
                       region_times, none, none, none, none, 1, 0.0)


@numba.njit(cache=True)
def taylor_schedule_kernel(breaks, coeffs, bends, size, u0, u1, region_b, region_feed, vmax, period_s, tol, state,
                           limit, region_times, region_want, dwell_params, gx, gw, max_runs,
                           rel_tol):  # pragma: no cover
    """:func:`taylor_kernel` that finds each dwell region's feed as it runs, so one run meets the times.

    Entering region ``j`` (the first step that starts in it), the time the
    step across its start already spent in it is known, so the feed is solved
    for the rest of the region from what is left of its wanted time
    ``region_want[j]`` (the quadrature model of :mod:`.timing` over the rest:
    ``ds / min(f, v_c(s))``, ``gx``, ``gw`` nodes on each side of
    ``dwell_params[j]``) and written into ``region_feed[j]``. When the region
    is done (its end boundary timed) and its time is off by more than
    ``rel_tol`` (and a faster feed could help where it is slow), the region is
    run again from its first step (the kernel's state, the buffers and the
    output rewound) at the feed the model gives for the time less this run's
    own miss, up to ``max_runs`` runs; when the last run is worse than an
    earlier one, that run is made again. So the samples are those of
    :func:`taylor_kernel` at the final ``region_feed`` bit for bit (what
    regenerates them), made in one pass over the path plus the regions run
    again (``state[ST_RERUN_REGIONS]``, ``state[ST_RERUN_SAMPLES]``).

    A call stops (to be resumed) only when a region is done and ``limit``
    samples are out, or inside a region of more than :data:`RERUN_MAX_SAMPLES`
    samples (never run again), so the output holds up to ``limit +
    RERUN_MAX_SAMPLES + 1`` samples and chunked calls give the samples of one.
    """
    return _taylor_run(breaks, coeffs, bends, size, u0, u1, region_b, region_feed, vmax, period_s, tol, state, limit,
                       region_times, region_want, dwell_params, gx, gw, max_runs, rel_tol)


@numba.njit(cache=True, _nrt=False)
def _rest_feed(breaks, coeffs, region_b, dwell_params, region_want, r, u, already, gx, gw, period_s, tol, vmax,
               lim, wt, c0, c1, c2):  # pragma: no cover - numba
    """Region ``r`` entered at ``u`` having spent ``already`` s in it: ``(left, length, feed)``, the time it
    still wants (s), the model's length of the rest (mm) and the feed that makes the rest take ``left``
    (mm/s; the nodes of the rest, sorted, left in ``lim``, ``wt``)."""
    left = region_want[r] - already
    m = max(dwell_params[r], u)
    b = max(region_b[r + 1], u)
    region_nodes(breaks, coeffs, u, m, b, gx, gw, period_s, tol, lim, wt, c0, c1, c2)
    length = sort_nodes(lim, wt)
    return left, length, feed_for_time(lim, wt, length, max(left, 0.1 * region_want[r]), vmax)


@numba.njit(cache=True)
def _taylor_run(breaks, coeffs, bends, size, u0, u1, region_b, region_feed, vmax, period_s, tol, state, limit,
                region_times, region_want, dwell_params, gx, gw, max_runs, rel_tol):  # pragma: no cover
    d = DIM
    safe = safe_tolerance(tol, size)
    margin = 1e-9 * max(size, 1.0)
    sched = region_want.shape[0] > 0
    soft = max(int(limit), 1)
    cap = soft + RERUN_MAX_SAMPLES + 1 if sched else soft
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
    # the scheduling kernel's region model (its nodes' limits and weights) and the rewind point
    q2 = 2 * gx.shape[0]
    lim = np.empty(q2)
    wt = np.empty(q2)
    snap = np.empty(STATE_SIZE)
    snap_pa = np.empty(d)
    snap_c1 = np.empty(d)
    snap_c2 = np.empty(d)
    snap_u = 0.0
    snap_s = 0
    snap_n = 0
    snap_have = False
    snap_fresh = False  # the rewind point is the piece's start, before its first sample
    left = 0.0      # time the region still wants from its first step, s
    length = 0.0    # model length of the rest of the region, mm
    runs = 0
    best_err = math.inf
    best_f = 0.0
    replay = False
    f_lo = 0.0        # fastest feed run in this region that was too slow (its relative miss rel_lo > 0)
    rel_lo = 0.0
    f_hi = math.inf   # slowest feed run in this region that was too fast (rel_hi < 0)
    rel_hi = 0.0
    nreg = region_feed.shape[0]
    fresh = state[ST_COUNT] == 0.0
    u = u0 if fresh else state[ST_U]
    s = span_at(breaks, u)
    r = region_at(region_b, nreg, u)
    span_point(breaks, coeffs, s, u, pa)
    k0 = int(state[ST_COUNT])  # samples before this call
    n = 0
    have = False  # C', C'' at u known from the last step's corrector
    if fresh and sched:
        # the first region's feed before the first sample (which carries it); its rewind point is the start
        left, length, f0 = _rest_feed(breaks, coeffs, region_b, dwell_params, region_want, r, u, 0.0,
                                      gx, gw, period_s, tol, vmax, lim, wt, c0, n1, n2)
        region_feed[r] = f0
        state[ST_SR] = r
        state[ST_RSTART] = 0.0
        runs = 1
        snap_fresh = True
        snap_u = u
        snap_s = s
        for j in range(STATE_SIZE):
            snap[j] = state[j]
        for j in range(d):
            snap_pa[j] = pa[j]
    if fresh:
        out_u[0] = u
        for j in range(d):
            out_p[0, j] = pa[j]
        out_v[0] = min(region_feed[r], vmax)
        state[ST_U] = u
        start_piece(state, region_b, region_times, out_v[0])
        n = 1
    guard = 0
    rerun = 0
    more = False
    while u < u1 or state[ST_DONE] == 2.0:
        if sched:
            while r < nreg - 1 and u >= region_b[r + 1]:
                r += 1
            cur = int(state[ST_SR])
            if cur >= 0 and (r != cur or state[ST_DONE] == 2.0):
                # region cur is done: its time against the wanted one; run it again or go on
                state[ST_DONE] = 0.0
                count = k0 + n - state[ST_RSTART]
                f = region_feed[cur]
                again = False
                if count <= RERUN_MAX_SAMPLES and left > 0.0:
                    want = region_want[cur]
                    spent = region_times[cur + 1] - region_times[cur]
                    rel = spent / want - 1.0
                    if abs(rel) < best_err:
                        best_err = abs(rel)
                        best_f = f
                    # the feeds run so far bracket the wanted time (f_lo too slow, f_hi too fast); once they do,
                    # a run replaces the end of its sign (the time jumps with the feed: timing.next_region_feed)
                    bracketed = f_lo > 0.0 and f_hi < math.inf
                    if rel > 0.0 and (f > f_lo or bracketed):
                        f_lo = f
                        rel_lo = rel
                    elif rel < 0.0 and (f < f_hi or bracketed):
                        f_hi = f
                        rel_hi = rel
                    if not replay and abs(rel) > rel_tol and runs < max_runs:
                        # the model asked for the time less this run's own miss; once bracketed, or too slow at
                        # the top feed, the search of timing.next_region_feed
                        miss = (spent - (want - left)) - time_at(lim, wt, f)
                        fn = feed_for_time(lim, wt, length, max(left - miss, 0.1 * left), vmax)
                        fn = next_region_feed(fn, f, rel, f_lo, rel_lo, f_hi, rel_hi, vmax, max_runs > 2)
                        if fn != f:
                            region_feed[cur] = fn
                            again = True
                    if not (again or replay) and abs(rel) > best_err and best_f != f:
                        region_feed[cur] = best_f  # an earlier run was nearer: make it again
                        replay = True
                        again = True
                if again:
                    runs += 1
                    if runs == 2:
                        state[ST_RERUN_REGIONS] += 1.0
                    rerun += n - snap_n
                    # rewind to the region's first step, keeping the counts of the runs run again
                    reruns = state[ST_RERUN_REGIONS]
                    rsamples = state[ST_RERUN_SAMPLES] + (n - snap_n)
                    most = max(state[ST_RUNS_MAX], runs - 1 if replay else runs)  # a replay is no new run
                    for j in range(STATE_SIZE):
                        state[j] = snap[j]
                    state[ST_RERUN_REGIONS] = reruns
                    state[ST_RERUN_SAMPLES] = rsamples
                    state[ST_RUNS_MAX] = most
                    n = snap_n
                    u = snap_u
                    s = snap_s
                    r = cur
                    have = snap_have
                    for j in range(d):
                        pa[j] = snap_pa[j]
                        c1[j] = snap_c1[j]
                        c2[j] = snap_c2[j]
                    if snap_fresh:  # the piece's first region: its first sample again, at the new feed
                        out_u[0] = u
                        for j in range(d):
                            out_p[0, j] = pa[j]
                        out_v[0] = min(region_feed[r], vmax)
                        state[ST_U] = u
                        start_piece(state, region_b, region_times, out_v[0])
                        n = 1
                else:
                    state[ST_SR] = -1.0
                    for j in range(cur + 1, nreg if u >= u1 else r):
                        region_feed[j] = f  # regions a step jumped over ran at its feed
                    if u >= u1:
                        break
            if state[ST_SR] < 0.0:
                if n >= soft:
                    more = True
                    break
                # entering region r: its feed for the rest of it, from the time it still wants
                state[ST_SR] = r
                state[ST_RSTART] = k0 + n
                left, length, f0 = _rest_feed(
                    breaks, coeffs, region_b, dwell_params, region_want, r, u,
                    (k0 + n - 1) * period_s - region_times[r], gx, gw, period_s, tol, vmax, lim, wt, c0, n1, n2)
                region_feed[r] = f0
                runs = 1
                best_err = math.inf
                replay = False
                f_lo = 0.0
                f_hi = math.inf
                snap_fresh = False
                snap_n = n
                snap_u = u
                snap_s = s
                snap_have = have
                for j in range(STATE_SIZE):
                    snap[j] = state[j]
                for j in range(d):
                    snap_pa[j] = pa[j]
                    snap_c1[j] = c1[j]
                    snap_c2[j] = c2[j]
        if n >= cap or u >= u1:
            more = n >= cap
            break
        guard += 1
        if guard - rerun > 200_000_000:
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
        sched_v = min(region_feed[r], vmax)
        v = step_feed(sched_v, sp2, acc2, dot, period_s, tol)
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
        record_step(state, region_b, region_times, k0 + n, u, un, pa, pb, v, sched_v, period_s, ce)
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
            if sched and state[ST_SR] >= 0.0:
                state[ST_DONE] = 2.0  # the last region's check is still to come (the loop's top)
                continue
            break
    if sched and state[ST_SR] >= 0.0 and not more:
        # the piece ended inside a region that is not checked (a stall)
        for j in range(int(state[ST_SR]) + 1, nreg):
            region_feed[j] = region_feed[int(state[ST_SR])]
        state[ST_SR] = -1.0
    state[ST_COUNT] += n
    state[ST_U] = u
    state[ST_DONE] = 0.0 if more else 1.0
    return out_u[:n], out_p[:n], out_v[:n]
