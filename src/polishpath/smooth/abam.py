"""Adams integrator: Adams-Bashforth predictor, Adams-Moulton corrector (numba).

The paper (section 4.2) densifies the NURBS parameter "with the Adams-Bashforth
and Adams-Moulton methods" at an equal interpolation period. This module is that
method, for du/dt = V / |C'(u)|, written in arc length s so that the feed
schedule does not enter the differential equation::

    du/ds = g(u) = 1 / |C'(u)|,      step k:  s_{k+1} - s_k = L_k = V_k T

* **Feed.** ``V_k`` is fixed at the start of step k exactly as in the Taylor
  integrator (:func:`.spans.step_feed`): the scheduled feed of the dwell region
  holding ``u_k`` (the dwell-time schedule), capped by the machine limit and cut
  by the chord-error limit of the local curvature. A step whose measured chord
  error (:func:`.spans.chord_deviation`) exceeds the tolerance is shortened and
  redone. So the schedule and the limits only set the step lengths ``L_k``; the
  right-hand side ``g`` is pure geometry, smooth along a span and C1 across a
  knot, and a feed change does not invalidate the history.
* **Predictor.** Adams-Bashforth of order 4 (4 steps): ``u_P = u_k + int_0^L p(s) ds``
  with ``p`` the cubic through ``g`` at the last four samples.
* **Corrector.** Adams-Moulton of order 4 (3 steps, one evaluation at the
  predicted point, PECE): ``p`` through ``g(u_P)`` and ``g`` at the last three samples.
  Because the ``L_k`` differ, both use variable-step coefficients (the integral of
  the Lagrange basis over the step, :func:`adams_weights`); at equal steps they
  are the textbook (55, -59, 37, -9)/24 and (9, 19, -5, 1)/24.
* **Start.** The first three steps of a piece (and after every restart) are
  classical Runge-Kutta 4 steps, also of order 4, so the history starts accurate.
  The history restarts where a step is more than twice the previous one (a cubic
  fitted on short steps extrapolates badly over a long one) and after a safeguard step.
* **Safeguard.** A step is redone by the shared chord corrector
  (:func:`.spans.chord_step`, the chord solved to ``L``) and the history
  restarted when the predictor and the corrector disagree by more than
  :data:`GUARD` of the step (Milne's device), or when the chord reached misses
  that of a circular arc of length ``L`` at the start's curvature by more than
  :data:`CHORD_GUARD` (or ``L kappa >= 2``). That happens where ``1/|C'|`` changes on
  the scale of the history (the sharp turns and near-cusps of a pseudo-random
  path); ``fallback_share`` counts those steps.

Order: 4 on a span; across a knot of a cubic spline ``g`` has a jumping second
derivative, so on a spline the global error falls as the third power of the
period once the knots dominate (tests/test_integrator.py measures both).

The samples then run the step's arc length ``V T`` along the curve; the machine
moves along the chord, which is shorter by about ``(L kappa)^2 / 24`` of the step;
where the chord-error limit binds that is ``tol / (3 rho)``: 0.17 % on a 0.2 mm
radius at 1 um, 3 % on a 0.01 mm one. This integrator, unlike the Taylor one,
does not correct for it (it is the feed fluctuation it reports).
"""

from __future__ import annotations

# numba's cache checks this file's own stamp only: the kernels here inline spans.record_step, so a change
# there (delivery's, issue 29: a piece's last step timed as its length over its feed) needs this file's
# stamp to change too, or an older cache of these kernels is loaded (this comment changed it)

import math

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

from .spans import (DIM, ST_CE_MAX, ST_COUNT, ST_DONE, ST_FALLBACKS, ST_G, ST_H, ST_NH, ST_PRED_MAX, ST_U,
                    chord_deviation, chord_step, figure_error, nudge, record_step, region_at, safe_tolerance, span_at,
                    span_derivs, span_of, span_point, start_piece, step_error, step_feed)

__all__ = ["abam_kernel", "adams_weights", "GUARD", "CHORD_GUARD"]

GUARD = 1e-2
"""Largest predictor-corrector disagreement, relative to the step, before the safeguard step."""
CHORD_GUARD = 0.02
"""Largest relative miss of a Runge-Kutta step's chord before the safeguard step."""


@numba.njit(cache=True, _nrt=False)
def adams_weights_into(nodes, w, c):  # pragma: no cover - numba
    """:func:`adams_weights` into the (4,) buffer ``w`` (``c``: (4,) scratch), allocating nothing."""
    for j in range(4):
        for k in range(4):
            c[k] = 0.0
        c[0] = 1.0
        den = 1.0
        deg = 0
        for m in range(4):
            if m == j:
                continue
            a = nodes[m]
            # c <- c * (t - a)
            for k in range(deg + 1, 0, -1):
                c[k] = c[k - 1] - a * c[k]
            c[0] = -a * c[0]
            deg += 1
            den *= nodes[j] - a
        w[j] = (c[0] + c[1] / 2.0 + c[2] / 3.0 + c[3] / 4.0) / den


@numba.njit(cache=True)
def adams_weights(nodes):  # pragma: no cover - numba
    """Integral over [0, 1] of each Lagrange basis polynomial on four nodes, (4,).

    ``nodes`` are the sample positions in units of the step (0 is the current
    sample; the earlier ones negative; 1 the predicted end for the corrector).
    The Adams step is ``L * sum_j w_j g_j``.
    """
    w = np.empty(4)
    adams_weights_into(nodes, w, np.empty(4))
    return w


@numba.njit(cache=True, _nrt=False)
def _inv_speed(breaks, coeffs, s, u, u1, w0, c1, w2):  # pragma: no cover - numba
    # g(u) = 1 / |C'(u)| at u (clamped to the end of the piece); inf where the curve has no speed;
    # w0, c1, w2: (d,) scratch buffers
    uu = min(u, u1)
    span_derivs(breaks, coeffs, span_of(breaks, s, uu), uu, w0, c1, w2)
    sp = 0.0
    for j in range(DIM):
        sp += c1[j] * c1[j]
    return 1.0 / math.sqrt(sp) if sp > 0.0 else math.inf


@numba.njit(cache=True)
def abam_kernel(breaks, coeffs, bends, size, u0, u1, region_b, region_feed, vmax, period_s, tol, state, limit,
                region_times):  # pragma: no cover
    """Constant-period samples of ``[u0, u1]`` by the Adams-Bashforth-Moulton integrator.

    Same arguments and returns as :func:`.taylor.taylor_kernel`; the state's
    predictor figure is the largest ``|chord / (V T) - 1|`` of the Adams (or
    starting) step before any safeguard, its fallbacks the safeguard steps. A multistep
    method: ``state`` carries its history (the last ``1/|C'|`` values and step
    lengths) from one call to the next, so resumed calls give the samples of
    one call bit for bit.
    """
    d = DIM
    safe = safe_tolerance(tol, size)
    margin = 1e-9 * max(size, 1.0)
    cap = max(int(limit), 1)
    out_u = np.empty(cap)
    out_p = np.empty((cap, d))
    out_v = np.empty(cap)
    # the kernel's own buffers (no allocation per step): the step's start and end points,
    # C' and C'' at the start, scratch
    pa = np.empty(d)
    pb = np.empty(d)
    c1 = np.empty(d)
    c2 = np.empty(d)
    w0 = np.empty(d)
    w1 = np.empty(d)
    w2 = np.empty(d)
    nreg = region_feed.shape[0]
    fresh = state[ST_COUNT] == 0.0
    u = u0 if fresh else state[ST_U]
    s = span_at(breaks, u)
    r = region_at(region_b, nreg, u)
    # history, newest first: g at the last four samples, arc length of the last three steps
    G = np.zeros(4)
    H = np.zeros(3)
    nh = 0
    n = 0
    k0 = int(state[ST_COUNT])  # samples before this call
    if fresh:
        span_derivs(breaks, coeffs, s, u, pa, c1, c2)
        out_u[0] = u
        for j in range(d):
            out_p[0, j] = pa[j]
        out_v[0] = min(region_feed[r], vmax)
        state[ST_U] = u
        start_piece(state, region_b, region_times, out_v[0])
        n = 1
    else:
        # as the previous call left it: C(u) as its last step computed it, C' and C'' there, the history
        span_point(breaks, coeffs, s, u, pa)
        span_derivs(breaks, coeffs, s, u, w0, c1, c2)
        for k in range(4):
            G[k] = state[ST_G + k]
        for k in range(3):
            H[k] = state[ST_H + k]
        nh = int(state[ST_NH])
    guard = 0
    ab_nodes = np.zeros(4)
    am_nodes = np.zeros(4)
    w = np.zeros(4)
    wc = np.zeros(4)
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
        if nh == 0:
            G[0] = 1.0 / sp
            nh = 1
        sched = min(region_feed[r], vmax)
        v = step_feed(sched, sp2, acc2, dot, period_s, tol)
        ln = v * period_s
        if nh >= 4 and ln > 2.0 * H[0]:
            G[0] = 1.0 / sp
            nh = 1
        last = False
        restart = False
        un = u
        err = 0.0
        measured = False
        for _ in range(60):
            if nh >= 4:
                ab_nodes[0] = 0.0
                ab_nodes[1] = -H[0] / ln
                ab_nodes[2] = ab_nodes[1] - H[1] / ln
                ab_nodes[3] = ab_nodes[2] - H[2] / ln
                adams_weights_into(ab_nodes, w, wc)
                up = u + ln * (w[0] * G[0] + w[1] * G[1] + w[2] * G[2] + w[3] * G[3])
                gp = _inv_speed(breaks, coeffs, s, up, u1, w0, w1, w2)
                am_nodes[0] = 1.0
                am_nodes[1] = 0.0
                am_nodes[2] = ab_nodes[1]
                am_nodes[3] = ab_nodes[2]
                adams_weights_into(am_nodes, w, wc)
                un = u + ln * (w[0] * gp + w[1] * G[0] + w[2] * G[1] + w[3] * G[2])
                # predictor-corrector gap as a share of the step (Milne's device)
                gap = abs(un - up) * sp / ln
            else:
                k1 = G[0]
                k2 = _inv_speed(breaks, coeffs, s, u + 0.5 * ln * k1, u1, w0, w1, w2)
                k3 = _inv_speed(breaks, coeffs, s, u + 0.5 * ln * k2, u1, w0, w1, w2)
                k4 = _inv_speed(breaks, coeffs, s, u + ln * k3, u1, w0, w1, w2)
                un = u + ln * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
                gap = 0.0
            ok = math.isfinite(un) and un > u and gap <= GUARD
            if ok:
                if un >= u1:
                    un = u1
                sn = span_of(breaks, s, un)
                span_point(breaks, coeffs, sn, un, pb)
                act = 0.0
                for j in range(d):
                    act += (pb[j] - pa[j]) ** 2
                act = math.sqrt(act)
                if un < u1:
                    miss = abs(act / ln - 1.0)
                    if miss > state[ST_PRED_MAX]:
                        state[ST_PRED_MAX] = miss
                    # compare with the chord of a circular arc of length L at the start's curvature
                    lk = ln * kap
                    if lk >= 2.0:
                        ok = False
                    elif lk > 1e-6:
                        ok = abs(act * kap / (2.0 * math.sin(0.5 * lk)) - 1.0) <= CHORD_GUARD
                    else:
                        ok = miss <= CHORD_GUARD
            if not ok:
                un, _ = chord_step(breaks, coeffs, s, u, u1, pa, ln, ln / sp, pb)
                restart = True
            last = un >= u1
            err, measured = step_error(breaks, coeffs, bends, safe, s, u, un, pa, pb, w0)
            if err <= tol:
                break
            # shorten: the chord error grows with the square of the step (aim just under the tolerance)
            f = math.sqrt(0.98 * tol / err)
            ln *= min(f, 0.99)
            v = ln / period_s
            last = False
            restart = False
        if un <= u:
            un = nudge(breaks, coeffs, s, u, u0, u1, pb)
            last = un >= u1
            restart = True
            err, measured = chord_deviation(breaks, coeffs, s, u, un, pa, pb, w0), True
        if restart:
            state[ST_FALLBACKS] += 1.0
        ce = figure_error(breaks, coeffs, s, u, un, pa, pb, w0, err, measured, state[ST_CE_MAX], margin)
        out_u[n] = un
        for j in range(d):
            out_p[n, j] = pb[j]
        out_v[n] = v
        record_step(state, region_b, region_times, k0 + n, u, un, pa, pb, v, sched, period_s, ce)
        n += 1
        sn = span_of(breaks, s, un)
        span_derivs(breaks, coeffs, sn, un, w0, c1, c2)
        g_new = 0.0
        for j in range(d):
            g_new += c1[j] * c1[j]
        if restart or g_new <= 0.0:
            nh = 0
        else:
            G[3] = G[2]
            G[2] = G[1]
            G[1] = G[0]
            G[0] = 1.0 / math.sqrt(g_new)
            H[2] = H[1]
            H[1] = H[0]
            H[0] = ln
            nh = min(nh + 1, 4)
        u = un
        # the step's end is the next step's start (copied: rebinding arrays costs atomic refcounts)
        for j in range(d):
            pa[j] = pb[j]
        if last:
            break
    state[ST_COUNT] += n
    state[ST_U] = u
    state[ST_DONE] = 0.0 if more else 1.0
    for k in range(4):
        state[ST_G + k] = G[k]
    for k in range(3):
        state[ST_H + k] = H[k]
    state[ST_NH] = nh
    return out_u[:n], out_p[:n], out_v[:n]
