"""The local Delaunay step's two reaches give the same bytes as its one reach (issue 26 Build 3, the 2x target).

``_local_delaunay`` tests each point first with the circles of radius at most ``SMALL_CIRCLE_FACTOR x h`` and
again with ``EMPTY_CIRCLE_FACTOR x h`` where that cannot decide. The kernel as it was before (one reach, every
point with ``EMPTY_CIRCLE_FACTOR x h``) is kept here as the reference: the edges, the triangles and their order
must be equal on blue-noise and relaxed sets of several shapes, seeds and margins, and on sets with many large
empty circles (uniform random points, clusters with gaps, a strip one point wide), where most points need the
second test and a missed mark gives another answer. Not timed (benchmarks/bench_plan.py is).
"""

from __future__ import annotations

import numba
import numpy as np
import pytest

from polishpath.plan.points import blue_noise_points, relaxed_points
from polishpath.plan.points.blue_noise import (
    EMPTY_CIRCLE_FACTOR,
    SMALL_CIRCLE_FACTOR,
    TRIANGLE_EDGE_FACTOR,
    _local_delaunay,
    cell_lists,
)
from polishpath.types import Region

H = 1.0


@numba.njit
def _reference_local_delaunay(xy, cells, cstart, x0, y0, cw, W, H, cw_order, W_order, lmax, rho, eps):
    # Edges (p < q) of length <= lmax that have an empty circle of radius <= rho through p and q, and the
    # triangles (a < b < c) beside them whose circle is the interval's end. Such edges are Delaunay edges, so
    # they never cross (a width below eps, a near-cocircular quad, drops both diagonals). Written by hand: the
    # set's empty circles are nearly all smaller than rho (a near-maximal Poisson-disk set), so a local test over
    # the points within 2 rho decides each edge exactly and in O(1), about 20x faster than Qhull's
    # triangulation of the whole set (scipy.spatial.Delaunay: 25 s for 10^6 points on this machine).
    # The candidates of p: the points within 2 rho, from the rows of cells (side cw, listed by cells / cstart)
    # around it, each row's cells one run of cstart. The circle test runs without branches (a point on either
    # side of the edge bounds the interval of centres from below or from above; a branch per point was
    # mispredicted half the time: 1.4 -> 0.7 s at 10^6 points). The edges of p are written in the order of
    # the cells of side cw_order (W_order a row) and then by number, so the output does not depend on cw.
    n = xy.shape[0]
    reach = int(np.ceil(2.0 * rho / cw))
    cap = 4 * n + 16
    ea = np.empty(cap, np.int64)
    eb = np.empty(cap, np.int64)
    tcap = 3 * n + 16
    ta = np.empty((tcap, 3), np.int64)
    ne = 0
    nt = 0
    loc = np.empty(512, np.int64)
    lx = np.empty(512)  # candidates relative to p, and their squared distances
    ly = np.empty(512)
    ls = np.empty(512)
    va = np.empty(512)
    kq = np.empty(64, np.int64)  # the kept edges of p: far end, order key, the triangles' third points
    kk = np.empty(64, np.int64)
    klo = np.empty(64, np.int64)
    khi = np.empty(64, np.int64)
    l2 = lmax * lmax
    r2 = 4.0 * rho * rho
    for p in range(n):
        px = xy[p, 0]
        py = xy[p, 1]
        hx = int((px - x0) / cw)
        hy = int((py - y0) / cw)
        m = 0
        ca = max(hx - reach, 0)
        cb = min(hx + reach, W - 1)
        for cy in range(max(hy - reach, 0), min(hy + reach + 1, H)):
            for t in range(cstart[cy * W + ca], cstart[cy * W + cb + 1]):
                x = cells[t]
                dx = xy[x, 0] - px
                dy = xy[x, 1] - py
                s2 = dx * dx + dy * dy
                loc[m] = x
                lx[m] = dx
                ly[m] = dy
                ls[m] = s2
                m += (s2 <= r2) & (x != p)
                if m == 511:
                    break
        nk = 0
        for i in range(m):
            q = loc[i]
            if q < p:
                continue
            d2 = ls[i]
            if d2 > l2:
                continue
            cap_t = rho * rho - 0.25 * d2
            if cap_t <= 0:
                continue
            cap_t = np.sqrt(cap_t)
            dl = np.sqrt(d2)
            qx = lx[i]
            qy = ly[i]
            nx = -qy / dl
            ny = qx / dl
            # the centres m + t n (m the midpoint) of the empty circles through p and q: t in [lo, hi]; a point j
            # (u = m - x_j) excludes the t with a t > b: a = 2 n.u, b = |q - p|^2 / 4 - |u|^2
            lo = -cap_t
            hi = cap_t
            bad = False
            for j in range(m):
                a = -2.0 * (nx * lx[j] + ny * ly[j])
                b = qx * lx[j] + qy * ly[j] - ls[j]
                if j == i:
                    a = 1.0
                    b = -1e300
                v = b / a
                va[j] = v
                lo = max(lo, v if a > 0 else -np.inf)
                hi = min(hi, v if a < 0 else np.inf)
                bad |= (a == 0.0) & (b > 0.0)  # on the segment itself
            if bad or hi - lo <= eps:
                continue
            xlo = -1  # the points whose circles end the interval (the first one, on a tie)
            xhi = -1
            for j in range(m):
                if j != i:
                    if xlo < 0 and va[j] == lo and -2.0 * (nx * lx[j] + ny * ly[j]) > 0:
                        xlo = loc[j]
                    if xhi < 0 and va[j] == hi and -2.0 * (nx * lx[j] + ny * ly[j]) < 0:
                        xhi = loc[j]
            if nk < 64:
                key = (int((xy[q, 1] - y0) / cw_order) * W_order + int((xy[q, 0] - x0) / cw_order)) * n + q
                j = nk
                while j > 0 and kk[j - 1] > key:
                    kk[j] = kk[j - 1]
                    kq[j] = kq[j - 1]
                    klo[j] = klo[j - 1]
                    khi[j] = khi[j - 1]
                    j -= 1
                kk[j] = key
                kq[j] = q
                klo[j] = xlo
                khi[j] = xhi
                nk += 1
        for e in range(nk):
            q = kq[e]
            if ne == cap:
                cap *= 2
                na_ = np.empty(cap, np.int64)
                nb_ = np.empty(cap, np.int64)
                na_[:ne] = ea[:ne]
                nb_[:ne] = eb[:ne]
                ea, eb = na_, nb_
            ea[ne] = p
            eb[ne] = q
            ne += 1
            for x in (klo[e], khi[e]):
                if x > q:  # each triangle once: from its edge of the two smaller numbers
                    if nt == tcap:
                        tcap *= 2
                        nt_ = np.empty((tcap, 3), np.int64)
                        nt_[:nt] = ta[:nt]
                        ta = nt_
                    ta[nt, 0] = p
                    ta[nt, 1] = q
                    ta[nt, 2] = x
                    nt += 1
    return ea[:ne].copy(), eb[:ne].copy(), ta[:nt].copy()


def _both(uv, h=H):
    """The kernel's edges and triangles with its two reaches and the reference's, as neighbour_graph calls them;
    asserts they are equal (bytes and order) and returns how many points were tested again and the edge count."""
    uv = np.ascontiguousarray(uv, dtype=np.float64)
    cells, cstart, x0, y0, W, H_ = cell_lists(uv, h)
    cw_order = 2 * EMPTY_CIRCLE_FACTOR * h
    W_order = int((float(uv[:, 0].max()) - x0) / cw_order) + 1
    args = (uv, cells, cstart, x0, y0, float(h), W, H_, float(cw_order), W_order, TRIANGLE_EDGE_FACTOR * h,
            EMPTY_CIRCLE_FACTOR * h, 1e-9 * h)
    ea, eb, tris, again = _local_delaunay(*args, SMALL_CIRCLE_FACTOR * h)
    ra, rb, rtris = _reference_local_delaunay(*args)
    np.testing.assert_array_equal(ea, ra)
    np.testing.assert_array_equal(eb, rb)
    np.testing.assert_array_equal(tris, rtris)
    return int(again), len(ea)


def _disc(r, n=360, c=(0.0, 0.0)):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.c_[c[0] + r * np.cos(t), c[1] + r * np.sin(t)]


def _star(R=40.0):
    t = np.linspace(0, 2 * np.pi, 10, endpoint=False) + np.pi / 2
    rad = np.where(np.arange(10) % 2 == 0, R, 0.45 * R)
    return Region(np.c_[rad * np.cos(t), rad * np.sin(t)])


REGIONS = {
    "disc": Region(_disc(45.0)),
    "star": _star(),
    "annulus": Region(_disc(40.0), (_disc(12.0)[::-1],)),
    "small": Region(np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 2.2], [0.0, 2.2]])),
    "narrow": Region(np.array([[0.0, 0.0], [60.0, 0.0], [60.0, 1.6], [0.0, 1.6]])),
    "bent strip": Region(np.r_[_disc(30.0, 180)[:91], _disc(27.5, 180)[:91][::-1]]),
}


@pytest.mark.parametrize("name", list(REGIONS))
@pytest.mark.parametrize("seed, margin", [(0, 0.0), (3, 0.5), (7, 1.3)])
def test_blue_noise_sets_give_the_reference_edges_and_triangles(name, seed, margin):
    if name in ("small", "narrow", "bent strip"):
        margin *= 0.3  # the thin regions keep a few rows of points
    pts = blue_noise_points(REGIONS[name], H, seed=seed, margin=margin)
    again, ne = _both(pts.uv)
    assert ne >= len(pts.uv) - 1
    if name in ("disc", "star", "annulus"):
        # the rim is tested again, little else (a near-maximal set has few empty circles wider than 0.95 h)
        assert 0 < again < 0.25 * len(pts.uv)


@pytest.mark.parametrize("seed", [1, 2])
def test_relaxed_sets_give_the_reference_edges_and_triangles(seed):
    pts = relaxed_points(REGIONS["annulus"], H, seed=seed, margin=0.3)
    _both(pts.uv)


def test_a_large_set_gives_the_reference_edges_and_triangles():
    pts = blue_noise_points(Region(_disc(130.0, 720)), H, seed=4)
    again, _ = _both(pts.uv)
    assert again < 0.05 * len(pts.uv)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_uniform_random_points_with_large_empty_circles(seed):
    """Points of a Poisson process at the grid's density: empty circles of every size, most points tested again,
    long Delaunay edges (beyond the small reach) kept; the same answer as the reference."""
    rng = np.random.default_rng(seed)
    uv = rng.uniform(0.0, 40.0, (1600, 2))
    again, _ = _both(uv)
    assert again > 0.3 * len(uv)
    # sparser (empty circles up to the full reach) and denser (few) sets
    _both(rng.uniform(0.0, 60.0, (1600, 2)))
    _both(rng.uniform(0.0, 25.0, (1600, 2)))


def test_clusters_with_gaps_and_a_line_of_points():
    """Blue-noise clusters apart by gaps near the reach (edges across a gap need the second test), a row of points
    a little off a line (cells that reach far to both sides) and a slightly jittered square grid (near-cocircular
    quads, both diagonals dropped)."""
    rng = np.random.default_rng(9)
    pts = blue_noise_points(Region(_disc(6.0, 120)), H, seed=2).uv
    for gap in (1.7, 1.95, 2.15, 2.4):
        shift = 12.0 + gap - 1.0
        uv = np.concatenate([pts, pts + [shift, 0.0], pts + [0.0, shift], pts + [shift, shift]])
        again, _ = _both(uv)
        assert again > 0
    line = np.c_[np.arange(60) * 1.05, 1e-3 * rng.standard_normal(60)]
    _both(line)
    g = np.stack(np.meshgrid(np.arange(30.0), np.arange(30.0)), -1).reshape(-1, 2) * 0.9
    _both(g + 1e-7 * rng.standard_normal(g.shape))


def test_the_renumbered_sets_cell_lists_are_the_first_ones_in_a_row():
    """blue_noise_points hands neighbour_graph the cell lists of the points before their renumbering (the same
    cells, each cell's points now numbered in a row) instead of making them again: equal to cell_lists of the
    renumbered points, and the same graph as neighbour_graph makes with its own."""
    from polishpath.plan.points.blue_noise import neighbour_graph

    rng = np.random.default_rng(4)
    for region in (REGIONS["star"], REGIONS["annulus"], REGIONS["narrow"]):
        pts = blue_noise_points(region, H, seed=int(rng.integers(100)), margin=0.2)
        shuffled = pts.uv[rng.permutation(len(pts.uv))]
        first = cell_lists(shuffled, H)
        uv = shuffled[first[0]]
        again = cell_lists(uv, H)
        np.testing.assert_array_equal(again[0], np.arange(len(uv)))
        np.testing.assert_array_equal(again[1], first[1])
        assert again[2:] == first[2:]
        got = neighbour_graph(uv, H, pts.polygon, cells=(np.arange(len(uv)),) + first[1:])
        for a, b in zip(got, neighbour_graph(uv, H, pts.polygon)):
            np.testing.assert_array_equal(a, b)
