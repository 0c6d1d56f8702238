"""Fitting G-code blocks to the machine samples: straight (G01) and helical-arc (G02/G03) blocks, compiled.

The segmenter looks for the fewest blocks, each a straight move or a helical
arc (an XY arc in G17 with Z linear along it, as LinuxCNC and Fanuc run
G02/G03 with a Z word), such that

* **chord**: every sample the block replaces, and the curve at 1/4, 1/2, 3/4 of
  the parameter between each two of them, is within ``tol`` of the block *in
  3D* (for an arc: the distance to the helix point at the same angle, an upper
  bound of the distance to the helix);
* **time**: the controller, moving uniformly along the block (a line's length,
  a helix's length, at the block's F) in the block's planned time, passes
  each region boundary inside the block within its limit of the schedule;
* **dwell points**: each is a block end, or (``through``) the one dwell point
  inside a block, on it to :data:`ON_PATH_MM` (1e-9 mm) before rounding and
  within the resolution as written; an arc is then the circle through the
  block's start, the dwell point and its end, and its helix must have the
  dwell point's Z at the dwell point's angle (on a flat part it does);
* **arc shape**: the XY arc through the block's start, middle and end points
  turns at most :data:`MAX_SWEEP`, its radius is between :data:`MIN_ARC_MM`
  and :data:`MAX_RADIUS_MM`, its XY chord at least :data:`MIN_ARC_MM`; written
  with the end points and the incremental centre (I, J) rounded to the
  coordinate resolution, the radii to start and end differ by at most
  :data:`RADIUS_MATCH_RES` resolutions (LinuxCNC refuses more than 0.028 mm
  *and* 0.1 %, or more than 2.8 mm) and the written arc is within one
  resolution (beyond the end points' own rounding) of the fitted one at 1/4,
  1/2 and 3/4 of it. Where no arc fits (straight or steep stretches, tiny or
  near-full turns) the block is a line; where a line fits it is preferred
  (fewer words).

The curve between two samples that the smoothing stage itself stepped is
within its chord tolerance ``e_s`` of their chord at the check points, so the
check points of such an interval are evaluated only where ``e_s`` + the
larger distance of its two ends from the block (+ the arc's sagitta over the
interval) does not already prove them within ``tol`` (the distance to a segment
is convex; a helix chord is within ``R (1 - cos(dphi / 2))`` of the helix at
the same fraction). Elsewhere (intervals split by an inserted dwell point,
tool-centre paths) they are evaluated, once each, from the curve's span
polynomials.

Each block's end is searched by bisection between its start and the next
dwell point (the whole interval first; the fit is checked at the end found, so
every block written fits), and a block that reaches the dwell point is
extended through it towards the next the same way: O(L log L) point checks
for a dwell interval of L samples, not O(L^2).

Written by hand: this is the project's segmenting (no library fits G-code
arcs under a time constraint).
"""

from __future__ import annotations

import math

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

__all__ = ["LINE", "CW", "CCW", "MAX_SWEEP", "MIN_ARC_MM", "MAX_RADIUS_MM", "RADIUS_MATCH_RES", "ON_PATH_MM",
           "segment_intervals", "written_arc_lengths", "CHECK_FRACTIONS", "NCOL", "NBCOL"]

#: block kinds: the G word of the block
LINE, CW, CCW = 1, 2, 3
#: largest turn of one arc block, rad (a near-full circle is ambiguous to write and to read)
MAX_SWEEP = 1.5 * math.pi
#: smallest arc radius and XY chord, mm (a smaller turn is written as lines)
MIN_ARC_MM = 0.01
#: largest arc radius, mm (a flatter arc is within the tolerance of a line, written as one)
MAX_RADIUS_MM = 1000.0
#: largest radius of an arc through a dwell point, mm: a nearly straight stretch through it (a line passes a
#: dwell point only where the curve is straight to 1e-9 mm)
MAX_THROUGH_RADIUS_MM = 1e5
#: most the written radii to the start and the end may differ, in coordinate resolutions
RADIUS_MATCH_RES = 2.0
#: where between two points the curve is checked against a block (as the smoothing stage checks its chords)
CHECK_FRACTIONS = np.array([0.25, 0.5, 0.75])

_TWO_PI = 2.0 * math.pi


def _atan_polynomial(terms: int = 9) -> tuple[np.ndarray, float]:
    """Coefficients of atan(t) ~ t * sum_k c_k t^(2k) on [0, 1] (least squares on a dense grid) and twice the
    largest error measured there, rad: the samples' angles on an arc need no libm atan2 per point."""
    t = np.linspace(0.0, 1.0, 100001)
    A = np.column_stack([t ** (2 * k + 1) for k in range(terms)])
    c = np.linalg.lstsq(A, np.arctan(t), rcond=None)[0]
    return c, 2.0 * float(np.abs(A @ c - np.arctan(t)).max())


#: the polynomial of :func:`_fast_atan2` and its error bound (rad, ~4e-8)
_ATAN_C, ATAN_ERR = _atan_polynomial()
_AC = tuple(float(v) for v in _ATAN_C)


@numba.njit(cache=True)
def _fast_atan2(y, x):  # pragma: no cover - numba
    """atan2(y, x) to within :data:`ATAN_ERR` rad: octant reduction and an odd polynomial."""
    ax = abs(x)
    ay = abs(y)
    hi = max(ax, ay)
    if hi == 0.0:
        return 0.0
    a = min(ax, ay) / hi
    q = a * a
    r = _AC[8]
    for k in range(7, -1, -1):
        r = r * q + _AC[k]
    r *= a
    if ay > ax:
        r = 0.5 * math.pi - r
    if x < 0.0:
        r = math.pi - r
    return -r if y < 0.0 else r


# Every per-point quantity of a piece's buffer lives in one float array F (n, NCOL) and one bool array B
# (n, 3): a compiled function taking two arrays keeps its reference counting out of the hot loops, and the
# helpers that take arrays and allocate nothing are compiled without it (``_nrt=False``: no atomic
# reference count per call; the block fitter 10 % faster, the same blocks).
#: F columns: the driven point (P), the same rounded as written (W), planned time, curve parameter, the
#: region boundary in the interval from this point to the next (fraction, planned time, limit), the curve
#: at the interval's check fractions (3 x 3)
PX, WX, TT, UU, BFRAC, BTIME, BLIM, MX = 0, 3, 6, 7, 8, 9, 10, 11
NCOL = 20
#: B columns: the point must end a block (a dwell point, or the piece's end: the search stops there), the
#: point is an inserted dwell point (not a sample), the interval's check points are evaluated, the point is a
#: dwell point (which a block may pass through where it lies on the block)
MUST, INS, MDONE, DWELL = 0, 1, 2, 3
NBCOL = 4
#: how near a dwell point a block passing through it must come (before rounding), mm
ON_PATH_MM = 1e-9


@numba.njit(cache=True, _nrt=False)
def _span(breaks, s, u):  # pragma: no cover - numba
    """The span holding u (breaks[s] <= u < breaks[s + 1], the last span beyond), walking from span s: the
    span ``smooth.evaluate``'s binary search finds, a step or two from the previous one along the path."""
    ns = breaks.shape[0] - 1
    if s < 0:  # no hint yet: bisection
        lo = 0
        hi = ns
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if u >= breaks[mid]:
                lo = mid
            else:
                hi = mid
        return lo
    while s < ns - 1 and u >= breaks[s + 1]:
        s += 1
    while s > 0 and u < breaks[s]:
        s -= 1
    return s


@numba.njit(cache=True, inline="always")
def _driven_point(breaks, coeffs, dp, dn, radius, u, s):  # pragma: no cover - numba
    """The driven point at curve parameter u, (x, y, z, span): the curve (homogeneous Horner, as
    ``smooth.evaluate``; ``s`` the span to walk from, -1: none), moved ``radius`` along the normal
    interpolated between the dwell normals (as ``export.chunks.normals_at`` and ``offset_along_normals``).
    No allocation: the compiled callers keep it inlined."""
    s = _span(breaks, s, u)
    h = breaks[s + 1] - breaks[s]
    t = (u - breaks[s]) / h
    p = coeffs.shape[1] - 1
    x = coeffs[s, p, 0]
    y = coeffs[s, p, 1]
    z = coeffs[s, p, 2]
    w = coeffs[s, p, 3]
    for k in range(p - 1, -1, -1):
        x = x * t + coeffs[s, k, 0]
        y = y * t + coeffs[s, k, 1]
        z = z * t + coeffs[s, k, 2]
        w = w * t + coeffs[s, k, 3]
    x, y, z = x / w, y / w, z / w
    if radius == 0.0:
        return x, y, z, s
    q = dp.shape[0]
    if u <= dp[0]:
        n0, n1, n2 = dn[0, 0], dn[0, 1], dn[0, 2]
    elif u >= dp[q - 1]:
        n0, n1, n2 = dn[q - 1, 0], dn[q - 1, 1], dn[q - 1, 2]
    else:
        lo = 0
        hi = q - 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if u >= dp[mid]:
                lo = mid
            else:
                hi = mid
        n0 = (dn[lo + 1, 0] - dn[lo, 0]) / (dp[lo + 1] - dp[lo]) * (u - dp[lo]) + dn[lo, 0]
        n1 = (dn[lo + 1, 1] - dn[lo, 1]) / (dp[lo + 1] - dp[lo]) * (u - dp[lo]) + dn[lo, 1]
        n2 = (dn[lo + 1, 2] - dn[lo, 2]) / (dp[lo + 1] - dp[lo]) * (u - dp[lo]) + dn[lo, 2]
    ln = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    if not ln > 1e-9:
        lo = 0
        hi = q
        while lo < hi:  # searchsorted(dp, u, "left")
            mid = (lo + hi) // 2
            if dp[mid] < u:
                lo = mid + 1
            else:
                hi = mid
        j = min(lo, q - 1)
        n0, n1, n2 = dn[j, 0], dn[j, 1], dn[j, 2]
        ln = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    ln = max(ln, 1e-300)
    return x + radius * (n0 / ln), y + radius * (n1 / ln), z + radius * (n2 / ln), s


@numba.njit(cache=True, inline="always")
def _check_points(F, B, i, breaks, coeffs, dp, dn, radius, s):  # pragma: no cover - numba
    """The curve at the check fractions of interval i into F[i, MX:MX + 9]; returns the span reached."""
    for q in range(3):
        u = F[i, UU] + (0.25 * (q + 1)) * (F[i + 1, UU] - F[i, UU])
        x, y, z, s = _driven_point(breaks, coeffs, dp, dn, radius, u, s)
        F[i, MX + 3 * q] = x
        F[i, MX + 3 * q + 1] = y
        F[i, MX + 3 * q + 2] = z
    B[i, MDONE] = True
    return s


@numba.njit(cache=True, _nrt=False)
def _seg_dist(x, y, z, F, a, c):  # pragma: no cover - numba
    """Distance of (x, y, z) from segment P[a]-P[c] and the projection's fraction along it (0..1)."""
    e0, e1, e2 = F[c, 0] - F[a, 0], F[c, 1] - F[a, 1], F[c, 2] - F[a, 2]
    q0, q1, q2 = x - F[a, 0], y - F[a, 1], z - F[a, 2]
    ll = e0 * e0 + e1 * e1 + e2 * e2
    t = 0.0
    if ll > 0.0:
        t = (q0 * e0 + q1 * e1 + q2 * e2) / ll
        t = min(max(t, 0.0), 1.0)
    d0, d1, d2 = q0 - t * e0, q1 - t * e1, q2 - t * e2
    return math.sqrt(d0 * d0 + d1 * d1 + d2 * d2), t


@numba.njit(cache=True, _nrt=False)
def _bounded(B, i):  # pragma: no cover - numba
    """Whether interval i is a step of the smoothing stage (both ends samples)."""
    return not (B[i, INS] or B[i + 1, INS])


@numba.njit(cache=True, inline="always")
def _line_fits(F, B, s, c, tol, e_s, dw):  # pragma: no cover - numba
    """1: one straight block P[s]-P[c] holds the chord and time limits; 0: not; -(i + 1): interval i's
    check points are needed first. ``dw`` >= 0: the dwell point P[dw] inside the block must lie on it
    (within :data:`ON_PATH_MM`)."""
    if dw >= 0:
        dd, _ = _seg_dist(F[dw, 0], F[dw, 1], F[dw, 2], F, s, c)
        if dd > ON_PATH_MM:
            return 0
    # the middle point first: on a turn the farthest from the chord, so most misfits are found without the
    # walk to it (the same answer: a point off by more than tol fails the block wherever it is found; only
    # check points the walk would have evaluated first are left for later, and they are the same when made)
    m = (s + c) // 2
    if s < m < c:
        dd, _ = _seg_dist(F[m, 0], F[m, 1], F[m, 2], F, s, c)
        if dd > tol:
            return 0
    d_prev = 0.0
    for i in range(s, c):
        d_next = 0.0
        if i + 1 < c:
            d_next, _ = _seg_dist(F[i + 1, 0], F[i + 1, 1], F[i + 1, 2], F, s, c)
            if d_next > tol:
                return 0
        if not (_bounded(B, i) and e_s + max(d_prev, d_next) <= tol):
            if not B[i, MDONE]:
                return -(i + 1)
            for q in range(3):
                d, _ = _seg_dist(F[i, MX + 3 * q], F[i, MX + 3 * q + 1], F[i, MX + 3 * q + 2], F, s, c)
                if d > tol:
                    return 0
        f = F[i, BFRAC]
        if f == f:  # a region boundary inside interval i: where the block's uniform motion passes it
            _, lam = _seg_dist(F[i, 0] + f * (F[i + 1, 0] - F[i, 0]), F[i, 1] + f * (F[i + 1, 1] - F[i, 1]),
                               F[i, 2] + f * (F[i + 1, 2] - F[i, 2]), F, s, c)
            if abs(F[s, TT] + lam * (F[c, TT] - F[s, TT]) - F[i, BTIME]) > F[i, BLIM]:
                return 0
        d_prev = d_next
    return 1


@numba.njit(cache=True, _nrt=False)
def _helix_dist(qx, qy, qz, ox, oy, R, sgn, D, vsx, vsy, z0, dz, F, s, c):  # pragma: no cover - numba
    """Distance of q from the helix point at q's angle (from the start, in the arc's direction), and that
    angle's fraction of the arc; beyond the arc's ends: the distance to the end point."""
    vx = qx - ox
    vy = qy - oy
    phi = _fast_atan2(sgn * (vsx * vy - vsy * vx), vsx * vx + vsy * vy)
    if phi < 0.0 and phi + _TWO_PI <= D:
        phi += _TWO_PI
    lam = phi / D
    if lam < 0.0 or lam > 1.0:
        k = s if lam < 0.0 else c
        e0, e1, e2 = qx - F[k, 0], qy - F[k, 1], qz - F[k, 2]
        return math.sqrt(e0 * e0 + e1 * e1 + e2 * e2), (0.0 if lam < 0.0 else 1.0)
    dr = math.sqrt(vx * vx + vy * vy) - R
    dzq = qz - (z0 + lam * dz)
    # the angle is known to ATAN_ERR: the helix's z at it to |dz| ATAN_ERR / D (added: still a bound)
    return math.sqrt(dr * dr + dzq * dzq) + abs(dz) * ATAN_ERR / D, lam


@numba.njit(cache=True)
def _helix_nearest(qx, qy, qz, ox, oy, R, sgn, D, th0, z0, dz, lam):  # pragma: no cover - numba
    """Fraction of the helix (0..1) at the point nearest to q: Newton's method on (H - q) . H' = 0 from
    ``lam`` (the same-angle fraction; on a steep helix the nearest point is elsewhere), clamped to the arc."""
    for _ in range(8):
        th = th0 + sgn * lam * D
        c, s = math.cos(th), math.sin(th)
        hx, hy, hz = ox + R * c - qx, oy + R * s - qy, z0 + lam * dz - qz
        d1x, d1y = -R * s * sgn * D, R * c * sgn * D
        d2x, d2y = -R * c * D * D, -R * s * D * D
        g = hx * d1x + hy * d1y + hz * dz
        gp = d1x * d1x + d1y * d1y + dz * dz + hx * d2x + hy * d2y
        if not gp > 0.0:
            break
        step = g / gp
        lam = min(max(lam - step, 0.0), 1.0)
        if abs(step) < 1e-12:
            break
    return lam


@numba.njit(cache=True)
def _sweep(sgn, ax, ay, bx, by):  # pragma: no cover - numba
    """Angle from vector a to vector b turning in direction sgn (+1: counter-clockwise), in (0, 2 pi]."""
    ph = math.atan2(sgn * (ax * by - ay * bx), ax * bx + ay * by)
    if ph <= 0.0:
        ph += _TWO_PI
    return ph


@numba.njit(cache=True, _nrt=False)
def _circle(F, s, c, m, through_dwell):  # pragma: no cover - numba
    """The XY circle through P[s], P[m], P[c]: (ok, centre x, y, radius, direction, sweep); ``through_dwell``
    (1: P[m] is a dwell point) allows radii up to :data:`MAX_THROUGH_RADIUS_MM`."""
    ax, ay = F[s, 0], F[s, 1]
    bx, by = F[m, 0] - ax, F[m, 1] - ay
    cx, cy = F[c, 0] - ax, F[c, 1] - ay
    if math.sqrt(cx * cx + cy * cy) < MIN_ARC_MM:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    den = 2.0 * (bx * cy - by * cx)
    if den == 0.0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    b2 = bx * bx + by * by
    c2 = cx * cx + cy * cy
    ux = (cy * b2 - by * c2) / den
    uy = (bx * c2 - cx * b2) / den
    R = math.sqrt(ux * ux + uy * uy)
    if not (MIN_ARC_MM <= R <= (MAX_RADIUS_MM if through_dwell == 0 else MAX_THROUGH_RADIUS_MM)):
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    sgn = 1.0 if den > 0.0 else -1.0  # a left turn start -> middle -> end runs counter-clockwise
    ox, oy = ax + ux, ay + uy
    D = _sweep(sgn, -ux, -uy, F[c, 0] - ox, F[c, 1] - oy)
    if D > MAX_SWEEP:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    return True, ox, oy, R, sgn, D


@numba.njit(cache=True, _nrt=False)
def _written_arc(F, s, c, ox, oy, R, sgn, D, res, dw):  # pragma: no cover - numba
    """The arc as written (end points and incremental centre at the resolution ``res``): (ok, I, J).

    ok: its radii to start and end differ by at most RADIUS_MATCH_RES resolutions and it is within one
    resolution (beyond the end points' own rounding) of the fitted arc at 1/4, 1/2, 3/4 of it; and, with a
    dwell point P[dw] inside it (``dw`` >= 0), the written helix passes within one resolution of it (at the
    dwell point's fraction of the arc)."""
    sc = 1.0 / res
    Iw = np.rint((ox - F[s, WX]) * sc) / sc
    Jw = np.rint((oy - F[s, WX + 1]) * sc) / sc
    wox, woy = F[s, WX] + Iw, F[s, WX + 1] + Jw
    wsx, wsy = F[s, WX] - wox, F[s, WX + 1] - woy
    wex, wey = F[c, WX] - wox, F[c, WX + 1] - woy
    rs = math.sqrt(wsx * wsx + wsy * wsy)
    re = math.sqrt(wex * wex + wey * wey)
    if abs(rs - re) > RADIUS_MATCH_RES * res or rs < MIN_ARC_MM:
        return False, Iw, Jw
    Dw = _sweep(sgn, wsx, wsy, wex, wey)
    e0, e1, e2 = F[s, WX] - F[s, 0], F[s, WX + 1] - F[s, 1], F[s, WX + 2] - F[s, 2]
    f0, f1, f2 = F[c, WX] - F[c, 0], F[c, WX + 1] - F[c, 1], F[c, WX + 2] - F[c, 2]
    shift = max(math.sqrt(e0 * e0 + e1 * e1 + e2 * e2), math.sqrt(f0 * f0 + f1 * f1 + f2 * f2))
    th0 = math.atan2(F[s, 1] - oy, F[s, 0] - ox)
    thw = math.atan2(wsy, wsx)
    z0 = F[s, 2]
    dz = F[c, 2] - z0
    for q in range(1, 4):
        lam = 0.25 * q
        th = th0 + sgn * lam * D
        tw = thw + sgn * lam * Dw
        rw = rs + lam * (re - rs)
        e0 = wox + rw * math.cos(tw) - (ox + R * math.cos(th))
        e1 = woy + rw * math.sin(tw) - (oy + R * math.sin(th))
        e2 = F[s, WX + 2] + lam * (F[c, WX + 2] - F[s, WX + 2]) - (z0 + lam * dz)
        if math.sqrt(e0 * e0 + e1 * e1 + e2 * e2) > shift + res:
            return False, Iw, Jw
    if dw >= 0:
        lam = _sweep(sgn, F[s, 0] - ox, F[s, 1] - oy, F[dw, 0] - ox, F[dw, 1] - oy) / D
        tw = thw + sgn * lam * Dw
        rw = rs + lam * (re - rs)
        e0 = wox + rw * math.cos(tw) - F[dw, 0]
        e1 = woy + rw * math.sin(tw) - F[dw, 1]
        e2 = F[s, WX + 2] + lam * (F[c, WX + 2] - F[s, WX + 2]) - F[dw, 2]
        if math.sqrt(e0 * e0 + e1 * e1 + e2 * e2) > res:
            return False, Iw, Jw
    return True, Iw, Jw


@numba.njit(cache=True, inline="always")
def _arc_fits(F, B, s, c, tol, e_s, res, rounding, dw):  # pragma: no cover - numba
    """As :func:`_line_fits` for one helical arc through P[s], P[(s+c)//2], P[c]: (result, kind, I, J).

    ``dw`` >= 0: through P[s], the dwell point P[dw] inside the block and P[c] instead, and the helix (Z
    linear along the arc) must pass the dwell point within :data:`ON_PATH_MM`. ``rounding``: also check the
    arc as written (:func:`_written_arc`); the search leaves it to the end."""
    ok, ox, oy, R, sgn, D = _circle(F, s, c, dw if dw >= 0 else (s + c) // 2, 1 if dw >= 0 else 0)
    if not ok:
        return 0, LINE, 0.0, 0.0
    vsx, vsy = F[s, 0] - ox, F[s, 1] - oy
    z0 = F[s, 2]
    dz = F[c, 2] - z0
    if dw >= 0:  # the helix at the dwell point's angle (exact atan2): its XY is on the circle by construction
        lam = _sweep(sgn, vsx, vsy, F[dw, 0] - ox, F[dw, 1] - oy) / D
        if lam > 1.0:
            return 0, LINE, 0.0, 0.0
        er = math.sqrt((F[dw, 0] - ox) ** 2 + (F[dw, 1] - oy) ** 2) - R
        ez = z0 + lam * dz - F[dw, 2]
        if math.sqrt(er * er + ez * ez) > ON_PATH_MM:
            return 0, LINE, 0.0, 0.0
    # the points at a quarter and three quarters first: the circle passes through the start, middle and end,
    # so a misfit is likeliest there (the same answer as the walk below, found sooner; as in _line_fits)
    for q in (s + (c - s) // 4, s + (3 * (c - s)) // 4):
        if s < q < c:
            dq, _ = _helix_dist(F[q, 0], F[q, 1], F[q, 2], ox, oy, R, sgn, D, vsx, vsy, z0, dz, F, s, c)
            if dq > tol:
                return 0, LINE, 0.0, 0.0
    Iw, Jw = 0.0, 0.0
    if rounding:
        ok, Iw, Jw = _written_arc(F, s, c, ox, oy, R, sgn, D, res, dw)
        if not ok:
            return 0, LINE, 0.0, 0.0
    # every replaced sample, the check points, the region boundaries
    d_prev = 0.0
    l_prev = 0.0
    for i in range(s, c):
        d_next = 0.0
        l_next = 1.0
        if i + 1 < c:
            d_next, l_next = _helix_dist(F[i + 1, 0], F[i + 1, 1], F[i + 1, 2], ox, oy, R, sgn, D, vsx, vsy, z0, dz,
                                         F, s, c)
            if d_next > tol:
                return 0, LINE, 0.0, 0.0
        sag = R * (1.0 - math.cos(0.5 * abs(l_next - l_prev) * D)) + R * ATAN_ERR
        if not (_bounded(B, i) and e_s + max(d_prev, d_next) + sag <= tol):
            if not B[i, MDONE]:
                return -(i + 1), LINE, 0.0, 0.0
            for q in range(3):
                d, _ = _helix_dist(F[i, MX + 3 * q], F[i, MX + 3 * q + 1], F[i, MX + 3 * q + 2], ox, oy, R, sgn, D,
                                   vsx, vsy, z0, dz, F, s, c)
                if d > tol:
                    return 0, LINE, 0.0, 0.0
        f = F[i, BFRAC]
        if f == f:  # where the uniform motion along the helix passes the boundary's nearest point
            bx = F[i, 0] + f * (F[i + 1, 0] - F[i, 0])
            by = F[i, 1] + f * (F[i + 1, 1] - F[i, 1])
            bz = F[i, 2] + f * (F[i + 1, 2] - F[i, 2])
            _, lam = _helix_dist(bx, by, bz, ox, oy, R, sgn, D, vsx, vsy, z0, dz, F, s, c)
            if dz != 0.0:  # flat: the same-angle point is the nearest
                lam = _helix_nearest(bx, by, bz, ox, oy, R, sgn, D, math.atan2(vsy, vsx), z0, dz, lam)
            if abs(F[s, TT] + lam * (F[c, TT] - F[s, TT]) - F[i, BTIME]) > F[i, BLIM]:
                return 0, LINE, 0.0, 0.0
        d_prev = d_next
        l_prev = l_next
    return 1, (CCW if sgn > 0 else CW), Iw, Jw


@numba.njit(cache=True, inline="always")
def _fits(F, B, s, c, tol, e_s, res, arcs, rounding, dw):  # pragma: no cover - numba
    """A line, else an arc (when ``arcs``) from P[s] to P[c]: (result, kind, I, J) as :func:`_arc_fits`
    (``dw`` >= 0: the dwell point inside the block, on it)."""
    r = _line_fits(F, B, s, c, tol, e_s, dw)
    if r != 0 or not arcs or c - s < 2:
        return r, LINE, 0.0, 0.0
    return _arc_fits(F, B, s, c, tol, e_s, res, rounding, dw)


@numba.njit(cache=True, _nrt=False)
def _farthest(F, B, s, lo0, k0, i0, j0, e, dw, breaks, coeffs, dp, dn, radius, span, tol, e_s, res,
              arcs):  # pragma: no cover - numba
    """The farthest block end c in (lo0, e] from P[s] (c = e tried first, then bisection; P[lo0] is known to
    fit, as kind k0 with centre (i0, j0)): (end, kind, I, J, span). ``dw`` >= 0: a dwell point the blocks
    beyond it pass through. The arc as written (its rounding) is checked at the end found; where it is off
    (rarely), the search runs again with it."""
    lo, kind, gi, gj = lo0, k0, i0, j0
    for attempt in range(2):
        rounding = attempt == 1
        lo, kind, gi, gj = lo0, k0, i0, j0
        hi = e + 1
        c = e if lo0 < e else -1
        while c > 0:
            inside = dw if (dw >= 0 and c > dw) else -1
            # one call site of the inlined fit (two sites doubled the kernel's compile time on a fresh checkout)
            while True:
                r, k, fi, fj = _fits(F, B, s, c, tol, e_s, res, arcs, rounding, inside)
                if r >= 0:
                    break
                span = _check_points(F, B, -r - 1, breaks, coeffs, dp, dn, radius, span)  # what the fit needs
            if r == 1:
                lo = c
                kind, gi, gj = k, fi, fj
            else:
                hi = c
            c = (lo + hi) // 2 if hi - lo > 1 else -1
        if kind == LINE or rounding or lo == lo0:
            break
        inside = dw if (dw >= 0 and lo > dw) else -1
        ok, ox, oy, R, sgn, D = _circle(F, s, lo, inside if inside >= 0 else (s + lo) // 2, 1 if inside >= 0 else 0)
        ok, gi, gj = _written_arc(F, s, lo, ox, oy, R, sgn, D, res, inside)
        if ok:
            break
    return lo, kind, gi, gj, span


@numba.njit(cache=True)
def segment_intervals(F, B, curve, radius, tol, e_s, res, arcs, horizon, final, through):  # pragma: no cover - numba
    """Blocks of every complete dwell interval of the buffer, fewest first (see the module docstring).

    Parameters
    ----------
    F : (n, NCOL) float64
        Per point (columns :data:`PX` ...): the driven point in path order (samples with the dwell points
        inserted), mm, and the same rounded as written; its planned time (s, ascending) and curve
        parameter; of the interval to the next point: the region boundary inside it as the interval's
        fraction (NaN: none), its planned time (s), how far a block may move it (s), and the curve at its
        check fractions (filled where needed). ``P[0]`` is a block end.
    B : (n, NBCOL) bool
        Per point: the search stops there (dwell points, the piece's last point); it is an inserted dwell
        point; the interval's check points are evaluated; it is a dwell point.
    curve : tuple
        ``(breaks, coeffs, dwell_params, dwell_normals)``: the curve's span polynomials
        (``smooth.nurbs.span_polynomials``, homogeneous) and every dwell parameter and normal (the
        tool-centre offset; unused when ``radius`` is 0).
    radius : float
        Tool radius, mm (0: the contact point is driven).
    tol, e_s, res : float
        Chord tolerance, the smoothing stage's chord tolerance (inf: none known) and the coordinate
        resolution, mm.
    arcs : bool
        Whether arc blocks may be used.
    horizon : int
        Intervals ``0 .. horizon-1`` are complete (later boundary limits are not known yet).
    final : bool
        Whether ``P[-1]`` is the piece's last point.
    through : bool
        Whether a block may pass through a dwell point (one per block) that lies on it: a block that
        reaches the next dwell point is extended towards the one after while it fits with the dwell point
        on it (:data:`ON_PATH_MM`; an arc is then the circle through its start, the dwell point and its
        end). False: every dwell point ends a block.

    Returns
    -------
    ends : (k,) int64
        Indices of the block ends after ``P[0]``, ascending; the points after the last one wait for
        more samples.
    kinds : (k,) int64
        :data:`LINE`, :data:`CW` or :data:`CCW`.
    ij : (k, 2) float64
        An arc's incremental centre from its (rounded) start, rounded to the resolution, mm.
    centres : (k, 2) float64
        An arc's fitted centre (before rounding; NaN: a line), mm.
    """
    breaks, coeffs, dp, dn = curve
    n = F.shape[0]
    ends = np.empty(n, np.int64)
    kinds = np.empty(n, np.int64)
    ij = np.zeros((n, 2))
    centres = np.full((n, 2), np.nan)
    # int64 from the start, not literals: a callee typed while its argument is still Literal[int] is compiled
    # once more for it (docs/performance.md: _farthest compiled 4 times, 15 s of a fresh checkout's compile)
    span = np.int64(-1)
    ne = 0
    s = np.int64(0)
    while s < n - 1:
        e = s + 1
        while e < n - 1 and not B[e, MUST]:
            e += 1
        if not B[e, MUST] or e > horizon:
            break  # the interval is not complete yet
        e2 = -1
        if through and B[e, DWELL] and e < n - 1:
            e2 = e + 1
            while e2 < n - 1 and not B[e2, MUST]:
                e2 += 1
            if not B[e2, MUST] or e2 > horizon:
                break  # a block may pass the dwell point e: wait until the interval after it is complete
        # check points no bound can spare: intervals beside an inserted point, or a bound never below tol
        for i in range(s, e2 if e2 > 0 else e):
            if not B[i, MDONE] and (not _bounded(B, i) or not e_s < tol):
                span = _check_points(F, B, i, breaks, coeffs, dp, dn, radius, span)
        # the block's end: the dwell point e if one block reaches it, else bisection between the always-kept
        # s+1 and the first misfit (fewer fits than galloping up from s+2, blocks being a third to a half of
        # a dwell interval); reaching e, the block is extended through it towards e2 the same way
        lo, kind, gi, gj, span = _farthest(F, B, s, s + 1, np.int64(LINE), 0.0, 0.0, e, np.int64(-1), breaks, coeffs,
                                           dp, dn, radius, span, tol, e_s, res, arcs)
        if lo == e and e2 > 0:
            lo, kind, gi, gj, span = _farthest(F, B, s, e, kind, gi, gj, e2, e, breaks, coeffs, dp, dn, radius,
                                               span, tol, e_s, res, arcs)
        ends[ne] = lo
        kinds[ne] = kind
        ij[ne, 0] = gi
        ij[ne, 1] = gj
        if kind != LINE:  # the fitted (unrounded) centre, for checks
            inside = e if (e2 > 0 and lo > e) else -1
            ok, ox, oy, R, sgn, D = _circle(F, s, lo, inside if inside >= 0 else (s + lo) // 2, 1 if inside >= 0 else 0)
            centres[ne, 0] = ox
            centres[ne, 1] = oy
        ne += 1
        s = lo
    return ends[:ne], kinds[:ne], ij[:ne], centres[:ne]


@numba.njit(cache=True)
def written_arc_lengths(prev, W, kinds, ij):  # pragma: no cover - numba
    """Length of each written block, mm: a line's, or the helix's from its written start, end and centre.

    prev, W : (k, 3) start and end points (rounded); kinds : (k,); ij : (k, 2). The helix length
    ``sqrt((r_mean * sweep)^2 + dz^2)``, as the controller runs it (and as tests/rs274_helpers.py
    measures LinuxCNC's ARC_FEED).
    """
    k = W.shape[0]
    out = np.empty(k)
    for i in range(k):
        e0, e1, e2 = W[i, 0] - prev[i, 0], W[i, 1] - prev[i, 1], W[i, 2] - prev[i, 2]
        if kinds[i] == LINE:
            out[i] = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
            continue
        sgn = 1.0 if kinds[i] == CCW else -1.0
        sx, sy = -ij[i, 0], -ij[i, 1]
        ex, ey = sx + e0, sy + e1
        D = _sweep(sgn, sx, sy, ex, ey)
        r = 0.5 * (math.sqrt(sx * sx + sy * sy) + math.sqrt(ex * ex + ey * ey))
        out[i] = math.sqrt((r * D) ** 2 + e2 * e2)
    return out
