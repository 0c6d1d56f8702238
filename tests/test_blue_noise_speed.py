"""The blue-noise walk's speed-ups keep its answers (issue 26 Build 3, the 2x target): checked against plain code.

Not timed (the times are benchmarks/bench_plan.py's): each fast path is compared with a brute-force reference
on random states, where a wrong skip or a wrong order would give another answer.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from polishpath.plan._graphwalk import BLOCK, nearest_unvisited_pt
from polishpath.plan.bluewalk import _blocks
from polishpath.plan.points.blue_noise import cell_lists


def _reference(h, xy, vis, lab, comp, x0, y0, cw, rmax, deg):
    """The steering search's rule, by brute force over every point: the nearest non-leaf unvisited point of
    ``comp`` among the cell rings up to one past the first ring that holds one (rings up to ``rmax``), else the
    nearest leaf within ``rmax`` rings, else -1."""
    cx = ((xy[:, 0] - x0) / cw).astype(np.int64)
    cy = ((xy[:, 1] - y0) / cw).astype(np.int64)
    hx, hy = int((xy[h, 0] - x0) / cw), int((xy[h, 1] - y0) / cw)
    ring = np.maximum(np.abs(cx - hx), np.abs(cy - hy))
    d = (xy[:, 0] - xy[h, 0]) ** 2 + (xy[:, 1] - xy[h, 1]) ** 2
    ok = (vis == 0) & (lab == comp) & (ring <= rmax)
    inner = ok & (deg != 1)
    if inner.any():
        r0 = ring[inner].min()
        pool = np.flatnonzero(inner & (ring <= r0 + 1))
        return int(pool[np.argmin(d[pool])])
    leaves = np.flatnonzero(ok & (deg == 1))
    return int(leaves[np.argmin(d[leaves])]) if len(leaves) else -1


def test_steering_search_skips_only_empty_blocks():
    rng = np.random.default_rng(5)
    n = 6000
    xy = rng.uniform(0.0, 70.0, (n, 2))
    cells, cstart, x0, y0, W, H = cell_lists(xy, 1.0)
    lab = (xy[:, 0] > 60.0).astype(np.int64)  # a second component on one side
    deg = rng.integers(1, 7, n)
    indptr = np.concatenate([[0], np.cumsum(deg)]).astype(np.int64)  # only the degrees are read
    checked = 0
    for trial in range(300):
        # visited: all but a few random discs of unvisited points (the walk leaves holes behind it)
        vis = np.ones(n, np.uint8)
        for _ in range(rng.integers(0, 4)):
            c, r = rng.uniform(0, 70, 2), rng.uniform(0.5, 6.0)
            vis[np.hypot(*(xy - c).T) < r] = 0
        blk, ucnt, WB = _blocks(xy, x0, y0, 1.0, W, H)
        # the counts as the walk keeps them: exact or too large (never too small)
        for b in range(len(ucnt)):
            ucnt[b] = np.count_nonzero(vis[blk == b] == 0) + (rng.integers(0, 3) if trial % 2 else 0)
        h = int(rng.integers(n))
        rmax = int(rng.choice([2, 8, 32, 80]))
        got = nearest_unvisited_pt(h, xy, vis, lab, np.int64(lab[h]), cells, cstart, x0, y0, 1.0, W, H, rmax,
                                   indptr, ucnt, WB)
        assert got == _reference(h, xy, vis, lab, lab[h], x0, y0, 1.0, rmax, deg), trial
        checked += got >= 0
    assert checked > 100  # most searches found a point (not a test of -1 only)
    assert BLOCK > 1


def test_components_are_scipys():
    """The walk's one-pass components (labels, the points by label, offsets) equal scipy's labels and a stable sort."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from polishpath.plan.bluewalk import _components

    rng = np.random.default_rng(2)
    n = 3000
    a = rng.integers(0, n, 1800)
    b = np.clip(a + rng.integers(-40, 40, a.size), 0, n - 1)  # short-range edges: many components
    g = coo_matrix((np.ones(a.size), (a, b)), shape=(n, n)).tocsr()
    g = ((g + g.T) > 0).astype(np.int8).tocsr()
    g.sort_indices()
    ncomp, lab = connected_components(g, directed=False)
    got_n, got_lab, order, bounds = _components(g.indptr.astype(np.int64), g.indices.astype(np.int64))
    assert ncomp > 100 and got_n == ncomp
    np.testing.assert_array_equal(got_lab, lab)
    np.testing.assert_array_equal(order, np.argsort(lab, kind="stable"))
    np.testing.assert_array_equal(bounds, np.searchsorted(lab[order], np.arange(ncomp + 1)))


def test_the_points_inside_by_squares_are_shapelys():
    """The sampled points inside the region, found square by square (shapely only near the boundary), are exactly
    shapely's: a star, a ring, two parts, a hole smaller than a square, and points on the squares' corners."""
    import shapely

    from polishpath.plan.points.blue_noise import _inside

    t = np.linspace(0, 2 * np.pi, 10, endpoint=False) + np.pi / 2
    rad = np.where(np.arange(10) % 2 == 0, 40.0, 18.0)
    star = shapely.Polygon(np.c_[rad * np.cos(t), rad * np.sin(t)])
    disc = shapely.Point(0, 0).buffer(30.0, 64)
    polys = [star, disc.difference(shapely.Point(0, 0).buffer(12.0, 64)),
             shapely.union(shapely.Point(-40, 0).buffer(10.0), shapely.Point(40, 0).buffer(10.0)),
             disc.difference(shapely.box(5.2, 5.2, 5.9, 5.9))]  # a hole inside one square of 4 mm
    rng = np.random.default_rng(3)
    for poly in polys:
        shapely.prepare(poly)
        x0, y0, x1, y1 = poly.bounds
        xs = np.concatenate([rng.uniform(x0, x1, 40000), x0 + 4.0 * rng.integers(0, int((x1 - x0) / 4), 500)])
        ys = np.concatenate([rng.uniform(y0, y1, 40000), y0 + 4.0 * rng.integers(0, int((y1 - y0) / 4), 500)])
        xs = np.concatenate([xs, rng.uniform(5.2, 5.9, 300)])
        ys = np.concatenate([ys, rng.uniform(5.2, 5.9, 300)])
        got = _inside(poly, xs, ys, 4.0)
        np.testing.assert_array_equal(got, shapely.contains_xy(poly, xs, ys))
        assert got.any() and not got.all()


def _disc(r, n, c):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.c_[c[0] + r * np.cos(t), c[1] + r * np.sin(t)]


def test_the_sampler_keeps_to_the_region_and_reaches_every_part_of_it():
    """The sampler places points only over the cells around the region (not its whole bounding box), so each part
    of a region split apart by its margin needs a front of its own: both discs of a dumbbell whose neck the margin
    cuts get the grid's density, up to their boundary, and nothing is sampled far outside."""
    import shapely

    from polishpath.plan.dwell import region_polygon
    from polishpath.plan.points import blue_noise_points
    from polishpath.plan.points.blue_noise import SQUARE_CELL, _grow, _poisson_disk, _squares
    from polishpath.types import Region

    h, R = 1.0, 15.0
    left, right = shapely.Polygon(_disc(R, 180, (-40.0, 0.0))), shapely.Polygon(_disc(R, 180, (40.0, 0.0)))
    outline = shapely.union_all([left, right, shapely.box(-30.0, -0.3, 30.0, 0.3)])
    region = Region(np.asarray(outline.exterior.coords)[:-1])
    pts = blue_noise_points(region, h, seed=11, margin=0.5)
    assert pts.polygon.geom_type == "MultiPolygon"  # the margin cut the neck
    area_part = np.pi * (R - 0.5) ** 2
    for side in (-1, 1):
        mine = pts.uv[np.sign(pts.uv[:, 0]) == side]
        assert abs(len(mine) / (area_part / h**2) - 1) < 0.04, side
        # up to the boundary: the points within 2 h of the rim hold their band's share
        rim = np.hypot(mine[:, 0] - 40.0 * side, mine[:, 1]) > R - 0.5 - 2 * h
        band = np.pi * ((R - 0.5) ** 2 - (R - 2.5) ** 2)
        assert abs(rim.sum() / (band / h**2) - 1) < 0.08, side
    d, _ = cKDTree(pts.uv).query(pts.uv, k=2)
    assert d[:, 1].min() >= pts.min_distance * (1 - 1e-9)
    # the sampler itself places nothing in the cells far from the region (the middle of the box)
    poly = region_polygon(region, 0.5)
    x0, y0, x1, y1 = poly.bounds
    mc = SQUARE_CELL * h
    bnd, centre_in = _squares(poly, mc)
    mask = _grow(bnd | centre_in).ravel().astype(np.uint8)
    xs, ys = _poisson_disk(x1 - x0, y1 - y0, pts.min_distance, 12, 5, mask, mc, bnd.shape[1])
    far = shapely.distance(poly, shapely.points(xs + x0, ys + y0)) > 2.0 * mc * np.sqrt(2.0)
    assert not far.any()
    assert mask.mean() < 0.9
