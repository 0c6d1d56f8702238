"""The dwell-time feed schedule solved before interpolating (numba).

Each dwell region must take its wanted time ``t_j``. Where the curvature is
high, the interpolator cuts the feed to the chord-error limit
``v_c(u) = 2 sqrt(2 rho delta - delta^2) / T`` (``rho = 1 / kappa``,
:func:`.spans.step_feed`), so a region run at the feed ``f`` takes

    t_j(f) = integral over the region of ds / min(f, v_c(s))

which is known before any sample is made: this module computes it by
Gauss-Legendre quadrature (``ds = |C'(u)| du``, ``order`` nodes on each side
of the dwell point) and solves ``t_j(f) = t_j`` for every region at once
(:func:`solve_region_feeds`): ``t_j(f)`` is piecewise ``A + B / f`` between
the sorted node limits, so the root is exact on the quadrature. One
interpolation run then meets the times to the discretisation (a step keeps
the feed of its start over the period; where the chord-error check shortens a
step beyond the circle's estimate); :func:`corrected_targets` folds a run's
measured region times back into the targets for a corrective run.

Hand-written: the project's own schedule (no library solves a dwell-time
schedule under a chord-error feed limit). Units: mm, mm/s, s.
"""

from __future__ import annotations

import math

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

from .spans import DIM, chord_feed_limit, span_at, span_derivs, span_of

__all__ = ["solve_region_feeds", "corrected_targets", "DEFAULT_ORDER", "KERNEL_ORDER",
           "region_nodes", "next_region_feed", "PROBE_STEP", "SEARCH_STRIDE",
           "sort_nodes", "feed_for_time", "time_at"]

DEFAULT_ORDER = 4
"""Gauss-Legendre nodes on each side of a dwell point (the schedule solved before interpolating)."""

KERNEL_ORDER = 2
"""Nodes on each side of a dwell point in the Taylor kernel's own region model
(:func:`.taylor.taylor_schedule_kernel`). Measured on the benchmark disk (10^5 points):
with 4 nodes (8 and 16 give the same) one run misses the region times by RMS 0.053
and 32 % of the samples are run again; with 2 nodes by RMS 0.036, and 14 % are (the
quadrature converges to ``ds / min(f, v_c)``, which the kernel does not run on a
tight turn: a step holds its start's feed over the period and is shortened where its
chord error is over the tolerance, so it runs slower there; the two-node rule weighs
the slow flanks of the turn more); and it costs half the curve evaluations."""


@numba.njit(cache=True, _nrt=False)
def region_nodes(breaks, coeffs, a, m, b, gx, gw, period_s, tol, lim, wt, c0, c1, c2):  # pragma: no cover - numba
    """Arc-length weights ``wt`` (2Q,) mm and feed limits ``lim`` (2Q,) mm/s at the nodes of ``[a, m]``, ``[m, b]``
    (``c0``, ``c1``, ``c2``: (3,) scratch)."""
    q = gx.shape[0]
    s = span_at(breaks, a)
    k = 0
    for half in range(2):
        lo = a if half == 0 else m
        hi = m if half == 0 else b
        mid = 0.5 * (lo + hi)
        h = 0.5 * (hi - lo)
        for i in range(q):
            u = mid + h * gx[i]
            s = span_of(breaks, s, u)
            span_derivs(breaks, coeffs, s, u, c0, c1, c2)
            sp2 = 0.0
            acc2 = 0.0
            dot = 0.0
            for j in range(DIM):
                sp2 += c1[j] * c1[j]
                acc2 += c2[j] * c2[j]
                dot += c1[j] * c2[j]
            wt[k] = h * gw[i] * math.sqrt(sp2)
            lim[k] = chord_feed_limit(sp2, acc2, dot, period_s, tol) if sp2 > 0.0 else math.inf
            k += 1


@numba.njit(cache=True, _nrt=False)
def time_at(lim, wt, f):  # pragma: no cover - numba
    """The modelled time of nodes ``lim``, ``wt`` run at the feed ``f``, s."""
    t = 0.0
    for i in range(lim.shape[0]):
        if wt[i] > 0.0:
            t += wt[i] / min(f, lim[i])
    return t


@numba.njit(cache=True, _nrt=False)
def sort_nodes(lim, wt):  # pragma: no cover - numba
    """Sort a region's nodes by their feed limit in place (insertion sort of a few values); their length, mm."""
    q2 = lim.shape[0]
    for i in range(1, q2):
        x = lim[i]
        y = wt[i]
        k = i - 1
        while k >= 0 and lim[k] > x:
            lim[k + 1] = lim[k]
            wt[k + 1] = wt[k]
            k -= 1
        lim[k + 1] = x
        wt[k + 1] = y
    total = 0.0
    for i in range(q2):
        total += wt[i]
    return total


@numba.njit(cache=True, _nrt=False)
def feed_for_time(lim, wt, total, want, vmax):  # pragma: no cover - numba
    """The feed (mm/s, at most ``vmax``) at which nodes sorted by :func:`sort_nodes` (length ``total``)
    take ``want`` seconds; ``vmax`` where even ``vmax`` cannot make the time."""
    q2 = lim.shape[0]
    # t(f) = A_k + B_k / f for f between the k-th and (k+1)-th smallest limit:
    # A_k the time of the nodes already limited, B_k the length of the others
    f = math.inf
    a_k = 0.0
    b_k = total
    for k in range(q2 + 1):
        if want <= a_k:
            break  # the limited nodes alone take longer than wanted: no feed makes it
        cand = b_k / (want - a_k) if b_k > 0.0 else 0.0
        if k == q2 or cand <= lim[k]:
            f = cand if b_k > 0.0 else math.inf
            break
        if wt[k] > 0.0:
            a_k += wt[k] / lim[k]
            b_k -= wt[k]
    f = min(f, vmax)
    if not (f > 0.0):
        f = min(total / want, vmax) if total > 0.0 else vmax
    return f


PROBE_STEP = 0.07
"""How much slower each probe of a region runs when even the top feed was too slow (:func:`next_region_feed`)."""

SEARCH_STRIDE = 1.25
"""Most a region's feed changes from one run to the next before the runs bracket its time
(:func:`next_region_feed`, searching jobs): measured on the figuring example (12 runs), worst region 3.5 %
with it against 4.0 % without (the model's step from a region 30 % too slow went to the top feed, among turns
whose time jumps by up to 66 % from one feed to the next)."""


@numba.njit(cache=True, _nrt=False)
def next_region_feed(fn, f, rel, f_lo, rel_lo, f_hi, rel_hi, vmax, probe):  # pragma: no cover - numba
    """The feed to run a dwell region at next, mm/s; ``f`` (the feed just run) when no other feed can help.

    A region's time is ``a + b / f`` only between the feeds where a step lands on
    another side of a tight turn: the chord-error limit of a step is read at its
    start, so where the steps fall decides how many slow steps the turn takes,
    and the time jumps by a period or more from one feed to a nearby one (on the
    figuring example, a 6-period region through a 5 um turn takes 14 % less at
    21.6 mm/s than it wants and 46 % more at 22.9). So:

    * ``fn``, the model's proposal (:func:`feed_for_time` of the time less the
      last run's miss), while the runs do not bracket the time;
    * once a run was too slow (``f_lo``, by the share ``rel_lo`` > 0) and one too
      fast (``f_hi``, ``rel_hi`` < 0; ``f_lo = 0`` / ``f_hi = inf``: none yet),
      the false-position point in 1 / f, kept to the middle 60 % of the bracket
      so that it shrinks by at least a fifth each run (the model does not see the
      jumps: near one it proposes the same feed run after run);
    * with ``probe`` (a searching job: more than two runs), when the top feed
      ``vmax`` was run and was too slow: a feed :data:`PROBE_STEP` slower than
      the one just run (where the steps fall otherwise, a slower feed may take
      less time); without it ``f`` (stop, as a job of two runs always did);
    * with ``probe``, the model's proposal is kept within a factor
      :data:`SEARCH_STRIDE` of ``f`` (near a jump, a large step lands among other
      jumps).
    """
    if f_lo > 0.0 and f_hi < math.inf:
        x_lo = 1.0 / f_lo
        x_hi = 1.0 / f_hi
        x = x_lo + rel_lo * (x_hi - x_lo) / (rel_lo - rel_hi)
        a = min(x_lo, x_hi)
        b = max(x_lo, x_hi)
        return 1.0 / min(max(x, a + 0.2 * (b - a)), b - 0.2 * (b - a))
    if rel > 0.0 and f_lo >= vmax * (1.0 - 1e-12):
        return f * (1.0 - PROBE_STEP) if probe else f
    if probe:
        return min(max(fn, f / SEARCH_STRIDE), f * SEARCH_STRIDE)
    return fn


@numba.njit(cache=True)
def solve_region_feeds(breaks, coeffs, region_b, dwell_params, times, vmax, period_s, tol, gx, gw):  # pragma: no cover
    """The feed of every dwell region that makes its modelled time its wanted time.

    Parameters
    ----------
    breaks, coeffs
        The curve's spans (3 coordinates).
    region_b : (R + 1,) float
        Region boundaries; region j holds ``dwell_params[j]``.
    dwell_params : (R,) float
    times : (R,) float
        Wanted time of each region, s (> 0).
    vmax : float
        Machine feed limit, mm/s.
    period_s, tol : float
        Interpolation period (s) and chord tolerance (mm).
    gx, gw : (Q,) float
        Gauss-Legendre nodes and weights on [-1, 1].

    Returns
    -------
    feeds : (R,) float
        mm/s, at most ``vmax`` (where even ``vmax`` cannot make the time, ``vmax``).
    model : (R,) float
        The modelled time of each region at that feed, s.
    lengths : (R,) float
        Arc length of each region (the same quadrature), mm.
    """
    nr = times.shape[0]
    q2 = 2 * gx.shape[0]
    feeds = np.empty(nr)
    model = np.empty(nr)
    lengths = np.empty(nr)
    lim = np.empty(q2)
    wt = np.empty(q2)
    c0 = np.empty(DIM)
    c1 = np.empty(DIM)
    c2 = np.empty(DIM)
    for j in range(nr):
        region_nodes(breaks, coeffs, region_b[j], dwell_params[j], region_b[j + 1], gx, gw, period_s, tol, lim, wt,
                      c0, c1, c2)
        lengths[j] = sort_nodes(lim, wt)
        f = feed_for_time(lim, wt, lengths[j], times[j], vmax)
        feeds[j] = f
        model[j] = time_at(lim, wt, f)
    return feeds, model, lengths


def corrected_targets(times: np.ndarray, spent: np.ndarray, model: np.ndarray) -> np.ndarray:
    """Targets for the model that make the next run's regions take ``times``, (R,) s.

    A run spends ``spent`` where the model said ``model``; the difference (the
    discretisation, the chord-error check's extra shortening) is taken to stay
    the same at a nearby feed, so the model is asked for ``times - (spent - model)``
    (kept above a tenth of the wanted time).
    """
    return np.maximum(times - (spent - model), 0.1 * times)
