"""Cubic NURBS interpolation through every dwell point (paper section 4.2, Eq. 10-13).

* :func:`interpolate_nurbs` — global interpolation (Piegl & Tiller, *The NURBS
  Book*, sect. 9.2.1): chord-length or centripetal parameters, knots by
  averaging (Eq. 9.8, the paper's Eq. 12), collocation system solved as a banded
  system with :func:`scipy.linalg.solve_banded` in O(N).
* :func:`span_polynomials` / :func:`evaluate` — the per-span polynomial form of
  Eq. 13 (numerator and denominator cubic in the local parameter), evaluated
  with Horner's rule, vectorised, derivatives up to 2.
* :func:`join_curves` — several curves (the tool lifts between path pieces) as
  one B-spline with full-multiplicity knots at the joins.

Units: mm for control points; the curve parameter is dimensionless in [0, 1].
"""

from __future__ import annotations

import weakref

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np
from scipy.linalg import solve_banded

from ..errors import ParameterError, SmoothingError
from ..types import NurbsCurve

__all__ = [
    "interpolation_params",
    "averaged_knots",
    "find_spans",
    "basis_functions",
    "interpolate_nurbs",
    "bezier_cubic_through",
    "span_polynomials",
    "evaluate",
    "join_curves",
]


def interpolation_params(points: np.ndarray, parametrization: str = "chord") -> np.ndarray:
    """Curve parameter of each data point (P&T Eq. 9.5 / 9.6).

    Parameters
    ----------
    points : (N, d) float
        Data points, mm, N >= 2.
    parametrization : {"chord", "centripetal"}
        Chord length (parameter steps proportional to the distances) or
        centripetal (proportional to their square roots).

    Returns
    -------
    params : (N,) float64
        Non-decreasing, from 0 to 1.

    Raises
    ------
    SmoothingError
        If two consecutive points coincide (the parameter would not advance).
    """
    p = np.asarray(points, dtype=np.float64)
    d = np.linalg.norm(np.diff(p, axis=0), axis=1)
    scale = float(np.abs(p).max()) if p.size else 1.0
    rep = np.flatnonzero(d <= 1e-12 * max(scale, 1.0))
    if len(rep):
        k = int(rep[0])
        raise SmoothingError(
            f"{len(rep)} pair(s) of consecutive dwell points coincide (first: points {k} and {k + 1} "
            f"at {p[k].tolist()}), so the curve parameter cannot advance between them.",
            "Remove repeated points from the path before smoothing.",
        )
    if parametrization == "chord":
        step = d
    elif parametrization == "centripetal":
        step = np.sqrt(d)
    else:
        raise ParameterError(
            f"Unknown parametrization {parametrization!r}.", "Use 'chord' or 'centripetal'."
        )
    u = np.concatenate([[0.0], np.cumsum(step)])
    u /= u[-1]
    u[-1] = 1.0
    return u


def averaged_knots(params: np.ndarray, degree: int) -> np.ndarray:
    """Clamped knot vector by averaging (P&T Eq. 9.8; the paper's Eq. 12).

    Parameters
    ----------
    params : (N,) float
        Data-point parameters from :func:`interpolation_params`.
    degree : int
        p, with N >= p + 1.

    Returns
    -------
    knots : (N + p + 1,) float64
        ``p + 1`` zeros, ``u_{j+p} = (1/p) sum_{i=j}^{j+p-1} params_i`` for
        ``j = 1 .. N-p-1``, ``p + 1`` ones.
    """
    u = np.asarray(params, dtype=np.float64)
    n = len(u) - 1
    p = int(degree)
    cs = np.concatenate([[0.0], np.cumsum(u)])
    j = np.arange(1, n - p + 1)
    inner = (cs[j + p] - cs[j]) / p if p > 0 else u[1:-1]
    return np.concatenate([np.zeros(p + 1), inner, np.ones(p + 1)])


def find_spans(knots: np.ndarray, degree: int, n_ctrl: int, u: np.ndarray) -> np.ndarray:
    """Knot span index of each parameter (``knots[s] <= u < knots[s+1]``; u = end -> last span), (M,) int64."""
    s = np.searchsorted(knots, u, side="right") - 1
    return np.clip(s, degree, n_ctrl - 1).astype(np.int64)


def basis_functions(knots: np.ndarray, degree: int, spans: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The ``p + 1`` non-zero B-spline basis functions at each parameter (P&T A2.2, vectorised).

    Parameters
    ----------
    knots : (m + 1,) float
    degree : int
    spans : (M,) int
        From :func:`find_spans`.
    u : (M,) float

    Returns
    -------
    N : (M, p + 1) float64
        ``N[k, j] = N_{spans[k] - p + j, p}(u[k])``.
    """
    p = int(degree)
    u = np.asarray(u, dtype=np.float64)
    m = len(u)
    out = np.zeros((m, p + 1))
    out[:, 0] = 1.0
    left = np.zeros((m, p + 1))
    right = np.zeros((m, p + 1))
    for j in range(1, p + 1):
        left[:, j] = u - knots[spans + 1 - j]
        right[:, j] = knots[spans + j] - u
        saved = np.zeros(m)
        for r in range(j):
            den = right[:, r + 1] + left[:, j - r]
            temp = np.divide(out[:, r], den, out=np.zeros(m), where=den != 0)
            out[:, r] = saved + right[:, r + 1] * temp
            saved = left[:, j - r] * temp
        out[:, j] = saved
    return out


def bezier_cubic_through(points: np.ndarray) -> tuple[NurbsCurve, np.ndarray]:
    """A single-span cubic through 1, 2 or 3 points (too few for a cubic interpolation).

    One point: a constant curve; two: the straight segment; three: the
    interpolating quadratic (chord parameters) raised to degree 3.

    Returns
    -------
    curve : NurbsCurve
        Degree 3, knots ``[0,0,0,0,1,1,1,1]``.
    params : (n,) float64
        Parameter of each point.
    """
    p = np.asarray(points, dtype=np.float64)
    if len(p) == 1:
        ctrl = np.repeat(p, 4, axis=0)
        prm = np.array([0.0])
    elif len(p) == 2:
        ctrl = np.stack([p[0], p[0] + (p[1] - p[0]) / 3, p[0] + 2 * (p[1] - p[0]) / 3, p[1]])
        prm = np.array([0.0, 1.0])
    elif len(p) == 3:
        prm = interpolation_params(p, "chord")
        t = prm[1]
        # quadratic Bezier Q0, Q1, Q2 through p0, p1 (at t), p2
        q1 = (p[1] - (1 - t) ** 2 * p[0] - t**2 * p[2]) / (2 * t * (1 - t))
        ctrl = np.stack([p[0], (p[0] + 2 * q1) / 3, (2 * q1 + p[2]) / 3, p[2]])
    else:
        raise SmoothingError(f"bezier_cubic_through takes 1 to 3 points, got {len(p)}.")
    return NurbsCurve(3, np.array([0, 0, 0, 0, 1, 1, 1, 1.0]), ctrl), prm


def interpolate_nurbs(
    points: np.ndarray, degree: int = 3, parametrization: str = "chord"
) -> tuple[NurbsCurve, np.ndarray]:
    """Global B-spline interpolation through every point, solved as a banded system.

    Parameters
    ----------
    points : (N, d) float
        Data points (dwell points), mm, in path order; N >= 2.
    degree : int
        Wanted degree p (3: the paper's cubic, order 4). Lowered to N - 1 when
        there are fewer than p + 1 points.
    parametrization : {"chord", "centripetal"}

    Returns
    -------
    curve : NurbsCurve
        ``N`` control points (d columns), clamped averaged knots, weights 1.
        ``curve(params[k]) == points[k]`` to rounding.
    params : (N,) float64
        Parameter of each data point.

    Raises
    ------
    SmoothingError
        Fewer than 2 points, non-finite points, or consecutive repeated points.

    Notes
    -----
    Row k of the collocation matrix holds the p + 1 basis functions non-zero at
    ``params[k]`` (columns ``span-p .. span``); with averaged knots it is banded
    with semi-bandwidths below p, so LAPACK ``gbsv`` solves it in O(N p^2).
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or len(pts) < 2:
        raise SmoothingError(
            f"Need at least 2 points of shape (N, d) to interpolate, got shape {pts.shape}.",
            "Give a path with two or more dwell points.",
        )
    if not np.all(np.isfinite(pts)):
        raise SmoothingError("The points contain NaN or infinity.", "Check the mapped path.")
    if int(degree) < 1:
        raise ParameterError(f"degree must be >= 1, got {degree}.")
    n_pts = len(pts)
    p = min(int(degree), n_pts - 1)
    u = interpolation_params(pts, parametrization)
    knots = averaged_knots(u, p)
    spans = find_spans(knots, p, n_pts, u)
    ab, lo, up = _collocation_band(np.ascontiguousarray(knots), p, spans, u)
    try:
        ctrl = solve_banded((lo, up), ab, pts, check_finite=False)
    except np.linalg.LinAlgError as exc:  # pragma: no cover - averaged knots keep it regular
        raise SmoothingError(f"The interpolation system is singular ({exc}).", "Check for repeated points.") from exc
    return NurbsCurve(p, knots, ctrl), u


# --------------------------------------------------------------------------------------
# per-span polynomial form (Eq. 13) and evaluation
# --------------------------------------------------------------------------------------

_POLY_CACHE: dict[int, tuple] = {}


@numba.njit(cache=True)
def _basis_one(U, p, s, u, out, left, right):  # pragma: no cover - numba
    # P&T A2.2 for one parameter (the hot loop of the coefficient conversion)
    out[0] = 1.0
    for j in range(1, p + 1):
        left[j] = u - U[s + 1 - j]
        right[j] = U[s + j] - u
        saved = 0.0
        for r in range(j):
            den = right[r + 1] + left[j - r]
            temp = out[r] / den if den != 0.0 else 0.0
            out[r] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        out[j] = saved


@numba.njit(cache=True)
def _collocation_band(U, p, spans, u):  # pragma: no cover - numba
    """The collocation matrix of :func:`interpolate_nurbs` in LAPACK's banded storage, and its (lo, up) bandwidths.

    Row k holds the ``p + 1`` basis functions at ``u[k]`` (:func:`_basis_one`, the arithmetic of
    :func:`basis_functions`) in columns ``spans[k] - p ..``; only the non-zero ones set the bandwidths.
    A compiled loop: the vectorised basis and scatter took 0.8 s at 10^6 points.
    """
    n = u.shape[0]
    bas = np.zeros((n, p + 1))
    b = np.zeros(p + 1)
    left = np.zeros(p + 1)
    right = np.zeros(p + 1)
    lo = 0
    up = 0
    for k in range(n):
        _basis_one(U, p, spans[k], u[k], b, left, right)
        for j in range(p + 1):
            bas[k, j] = b[j]
            if b[j] != 0.0:
                c = spans[k] - p + j
                lo = max(lo, k - c)
                up = max(up, c - k)
    ab = np.zeros((lo + up + 1, n))
    for k in range(n):
        for j in range(p + 1):
            if bas[k, j] != 0.0:
                c = spans[k] - p + j
                ab[up + k - c, c] = bas[k, j]
    return ab, lo, up


@numba.njit(cache=True)
def _span_coeffs_kernel(U, p, idx, hom, t, vinv):  # pragma: no cover - numba
    ns = idx.shape[0]
    dd = hom.shape[1]
    coeffs = np.zeros((ns, p + 1, dd))
    vals = np.zeros((p + 1, dd))
    bas = np.zeros(p + 1)
    left = np.zeros(p + 1)
    right = np.zeros(p + 1)
    for q in range(ns):
        s = idx[q]
        a = U[s]
        h = U[s + 1] - a
        for m in range(p + 1):
            _basis_one(U, p, s, a + h * t[m], bas, left, right)
            for c in range(dd):
                acc = 0.0
                for j in range(p + 1):
                    acc += bas[j] * hom[s - p + j, c]
                vals[m, c] = acc
        for k in range(p + 1):
            for c in range(dd):
                acc = 0.0
                for m in range(p + 1):
                    acc += vinv[k, m] * vals[m, c]
                coeffs[q, k, c] = acc
    return coeffs


@numba.njit(cache=True)
def _eval_kernel(breaks, coeffs, u, nder):  # pragma: no cover - numba
    m = u.shape[0]
    ns = coeffs.shape[0]
    p = coeffs.shape[1] - 1
    dd = coeffs.shape[2]
    out = np.empty((3, m, dd))
    for i in range(m):
        x = u[i]
        # binary search of the span (breaks ascending)
        lo = 0
        hi = ns
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if x >= breaks[mid]:
                lo = mid
            else:
                hi = mid
        h = breaks[lo + 1] - breaks[lo]
        t = (x - breaks[lo]) / h
        for c in range(dd):
            v = coeffs[lo, p, c]
            d1 = 0.0
            d2 = 0.0
            for k in range(p - 1, -1, -1):
                d2 = d2 * t + 2.0 * d1
                d1 = d1 * t + v
                v = v * t + coeffs[lo, k, c]
            out[0, i, c] = v
            out[1, i, c] = d1 / h
            out[2, i, c] = d2 / (h * h)
    return out


def span_polynomials(curve: NurbsCurve) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Power-basis coefficients of every non-empty knot span (Eq. 13).

    Parameters
    ----------
    curve : NurbsCurve

    Returns
    -------
    breaks : (S + 1,) float64
        Span boundaries (distinct knot values in use).
    coeffs : (S, p + 1, d + 1) float64
        ``coeffs[s, k]`` is the coefficient of ``t**k``, ``t = (u - breaks[s]) /
        (breaks[s+1] - breaks[s])`` in [0, 1], of the homogeneous curve
        ``(w * P, w)``: columns ``:d`` are the numerator ``a_k``, the last the
        denominator ``b_k`` of Eq. 13.
    span_index : (S,) int64
        Knot index of each span's start.

    Notes
    -----
    The coefficients are found by sampling each span at ``p + 1`` equally spaced
    local parameters and inverting the (fixed, well-conditioned on [0, 1])
    Vandermonde matrix; results are cached per curve object.
    """
    key = id(curve)
    hit = _POLY_CACHE.get(key)
    if hit is not None and hit[0]() is curve:
        return hit[1]
    p = curve.degree
    U = curve.knots
    n_ctrl = len(curve.control_points)
    idx = np.flatnonzero(np.diff(U) > 0)
    idx = idx[(idx >= p) & (idx <= n_ctrl - 1)]
    if len(idx) == 0:
        raise SmoothingError("The curve has no knot span of positive length.", "Check the knot vector.")
    a, b = U[idx], U[idx + 1]
    hom = np.concatenate([curve.control_points * curve.weights[:, None], curve.weights[:, None]], axis=1)
    t = np.linspace(0.0, 1.0, p + 1)
    vinv = np.linalg.inv(np.vander(t, p + 1, increasing=True))
    # a writable knot array, as _collocation_band gets: one compiled signature of _basis_one, not two
    coeffs = _span_coeffs_kernel(np.require(U, np.float64, ("C", "W")), p, idx.astype(np.int64),
                                 np.ascontiguousarray(hom), t, vinv)
    breaks = np.concatenate([a, b[-1:]])
    # breaks must be contiguous: with joined pieces every span start equals the previous end
    out = (breaks, coeffs, idx.astype(np.int64))
    _POLY_CACHE[key] = (weakref.ref(curve), out)
    # dropped with the curve; not at exit (a signal then would print a traceback from the finalizer)
    weakref.finalize(curve, _POLY_CACHE.pop, key, None).atexit = False
    return out


def evaluate(curve: NurbsCurve, u, derivatives: int = 0) -> np.ndarray:
    """Points (and derivatives) of the curve, vectorised through Eq. 13.

    Parameters
    ----------
    curve : NurbsCurve
    u : (M,) float or float
        Parameters in ``[knots[0], knots[-1]]``.
    derivatives : {0, 1, 2}
        Highest derivative wanted (with respect to u).

    Returns
    -------
    out : (M, d) float64 if ``derivatives == 0`` else (derivatives + 1, M, d)
        ``out[k]`` is the k-th derivative, mm / unit parameter^k.
    """
    if derivatives not in (0, 1, 2):
        raise ParameterError(f"derivatives must be 0, 1 or 2, got {derivatives}.")
    uu = np.atleast_1d(np.asarray(u, dtype=np.float64))
    breaks, coeffs, _ = span_polynomials(curve)
    if np.any(uu < breaks[0] - 1e-12) or np.any(uu > breaks[-1] + 1e-12) or not np.all(np.isfinite(uu)):
        raise ParameterError(
            f"Curve parameters must lie in [{breaks[0]}, {breaks[-1]}], got [{uu.min()}, {uu.max()}]."
        )
    allv = _eval_kernel(breaks, coeffs, np.ascontiguousarray(uu), derivatives)
    val, d1, d2 = allv[0], allv[1], allv[2]
    rational = not np.all(curve.weights == 1.0)
    if rational:
        w, w1, w2 = val[:, -1:], d1[:, -1:], d2[:, -1:]
        c0 = val[:, :-1] / w
        c1 = (d1[:, :-1] - w1 * c0) / w
        c2 = (d2[:, :-1] - 2 * w1 * c1 - w2 * c0) / w
    else:
        c0, c1, c2 = val[:, :-1], d1[:, :-1], d2[:, :-1]
    res = [c0, c1, c2][: derivatives + 1]
    if derivatives == 0:
        return c0
    return np.stack(res)


def join_curves(curves: list[NurbsCurve], lengths: np.ndarray) -> tuple[NurbsCurve, np.ndarray]:
    """One B-spline made of several curves of the same degree (discontinuous at the joins).

    Curve k is re-parametrised onto ``[a_k, a_{k+1}]`` with ``a`` the normalised
    cumulative ``lengths``; its clamped end knots merge with the next curve's
    start knots into one knot of multiplicity p + 1, so each piece keeps its own
    shape (the tool lifts between pieces). A parameter equal to a join value
    evaluates the *next* piece; the last point of a piece is at
    ``numpy.nextafter(a_{k+1}, -inf)``.

    Parameters
    ----------
    curves : list of NurbsCurve
        Each clamped on [0, 1], all of one degree.
    lengths : (K,) float
        Positive parameter share of each curve (e.g. its chord length).

    Returns
    -------
    curve : NurbsCurve
    offsets : (K + 1,) float64
        Parameter range ``[offsets[k], offsets[k+1]]`` of curve k.
    """
    if not curves:
        raise SmoothingError("No curve to join.")
    p = curves[0].degree
    if any(c.degree != p for c in curves):
        raise SmoothingError("Curves of different degrees cannot be joined.")
    ln = np.asarray(lengths, dtype=np.float64)
    off = np.concatenate([[0.0], np.cumsum(ln)])
    off /= off[-1]
    off[-1] = 1.0
    knots, ctrl, wts = [], [], []
    for k, c in enumerate(curves):
        kk = off[k] + (off[k + 1] - off[k]) * c.knots
        kk[: p + 1] = off[k]
        kk[-(p + 1):] = off[k + 1]
        knots.append(kk if k == len(curves) - 1 else kk[: -(p + 1)])
        ctrl.append(c.control_points)
        wts.append(c.weights)
    return NurbsCurve(p, np.concatenate(knots), np.concatenate(ctrl), np.concatenate(wts)), off
