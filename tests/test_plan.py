"""Dwell grid and pseudo-random planner: the guarantees of issue 4, checked independently.

Every check here recomputes what it needs with shapely / numpy from the raw
output (uv, ij, pieces), never from the planner's own bookkeeping.
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from polishpath.errors import ParameterError, SpacingTooLargeError
from polishpath.plan import PATTERNS, count_crossings, dwell_grid, path_metrics, plan, register_pattern
from polishpath.types import Region

# ---------------------------------------------------------------- region makers


def disc(r=10.0, n=96, c=(0.0, 0.0)):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.c_[c[0] + r * np.cos(t), c[1] + r * np.sin(t)]


def star(R=12.0, r=5.0, k=5, phase=0.3):
    t = np.linspace(0, 2 * np.pi, 2 * k, endpoint=False) + phase
    rad = np.where(np.arange(2 * k) % 2 == 0, R, r)
    return np.c_[rad * np.cos(t), rad * np.sin(t)]


def L_shape(a=10.0, b=5.0):
    return np.array([[0, 0], [a, 0], [a, b], [b, b], [b, a], [0, a]], dtype=float)


def shapely_region(region: Region, margin: float = 0.0):
    poly = shapely.Polygon(region.outer, list(region.holes))
    return poly.buffer(-margin) if margin else poly


REGIONS = {
    "disc": lambda: Region(disc()),
    "star": lambda: Region(star()),
    "annulus": lambda: Region(disc(10.0), (disc(4.0)[::-1],)),
    "L": lambda: Region(L_shape()),
    "strip": lambda: Region(np.array([[0, 0], [30, 0], [30, 1.6], [0, 1.6]], dtype=float)),
    "two_holes": lambda: Region(disc(12.0), (disc(3.0, 24, (-5, 0))[::-1], disc(2.5, 24, (5, 1))[::-1])),
}


@st.composite
def random_regions(draw):
    """Random star-shaped polygons (always simple), sometimes with a hole, or a named region."""
    kind = draw(st.sampled_from(["poly", "poly_hole", *REGIONS]))
    if kind in REGIONS:
        return REGIONS[kind]()
    n = draw(st.integers(5, 14))
    jitter = np.array(draw(st.lists(st.floats(0.0, 0.9), min_size=n, max_size=n)))
    ang = (np.arange(n) + jitter) * 2 * np.pi / n  # increasing, gaps < pi: star-shaped around 0
    rad = np.array(draw(st.lists(st.floats(4.0, 12.0), min_size=n, max_size=n)))
    outer = np.c_[rad * np.cos(ang), rad * np.sin(ang)]
    holes = ()
    if kind == "poly_hole":
        # inside the outer loop: its edges come no closer to 0 than 4 cos(1.9 pi / 5) ~ 1.47 mm
        # (radius >= 4, angular gap < 1.9 * 2 pi / 5), so the hole must stay under that
        holes = (disc(1.0, 12, (0.0, 0.0))[::-1],)
    return Region(outer, holes)


# ---------------------------------------------------------------- independent checks


def check_path(path, region: Region, margin: float = 0.0, expect_all: bool = True):
    uv, ij, pieces = np.asarray(path.uv), np.asarray(path.ij), np.asarray(path.pieces)
    grid = dwell_grid(region, path.spacing, margin=margin, origin=path.origin, rotation=path.rotation)
    # each dwell point exactly once
    keys = ij[:, 0] * 1_000_003 + ij[:, 1]
    assert len(np.unique(keys)) == len(keys), "a dwell point is visited twice"
    if expect_all:
        gk = grid.ij[:, 0] * 1_000_003 + grid.ij[:, 1]
        assert set(keys.tolist()) == set(gk.tolist()), "visited set differs from the dwell points"
        assert len(path.unreached) == 0
    # positions agree with the grid indices
    c, s = np.cos(path.rotation), np.sin(path.rotation)
    g = ij * path.spacing
    exp = np.c_[path.origin[0] + c * g[:, 0] - s * g[:, 1], path.origin[1] + s * g[:, 0] + c * g[:, 1]]
    np.testing.assert_allclose(uv, exp, atol=1e-9)
    # pieces partition the path
    assert pieces[0] == 0 and pieces[-1] == len(uv) and np.all(np.diff(pieces) > 0)
    # consecutive points inside a piece are 8-neighbours
    same = np.ones(len(uv) - 1, dtype=bool)
    same[pieces[1:-1] - 1] = False
    step = np.abs(np.diff(ij, axis=0))[same]
    assert np.all(step.max(axis=1) == 1), "a step is not to an 8-neighbour"
    # no crossing (independent checker)
    assert count_crossings(uv, pieces) == 0
    # inside the region: every point and every step segment
    poly = shapely_region(region, margin)
    assert shapely.intersects_xy(poly, uv[:, 0], uv[:, 1]).all(), "a dwell point lies outside"
    k = np.flatnonzero(same)
    lines = shapely.linestrings(np.stack([uv[k], uv[k + 1]], axis=1))
    assert shapely.covers(poly, lines).all(), "a step leaves the region"
    return grid


# ---------------------------------------------------------------- dwell grid


def test_dwell_grid_is_complete_and_inside():
    region = REGIONS["two_holes"]()
    grid = dwell_grid(region, 0.7, rotation=0.3)
    poly = shapely_region(region)
    # every lattice point of the bounding box: inside <=> dwell point (away from the boundary by 1e-7)
    lo, hi = grid.ij.min(axis=0) - 3, grid.ij.max(axis=0) + 3
    I, J = np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1))
    ij = np.c_[I.ravel(), J.ravel()]
    uv = grid.to_uv(ij)
    inside = shapely.intersects_xy(poly, uv[:, 0], uv[:, 1])
    clear = shapely.distance(poly.boundary, shapely.points(uv)) > 1e-7
    gk = set((grid.ij[:, 0] * 100_003 + grid.ij[:, 1]).tolist())
    member = np.array([(a * 100_003 + b) in gk for a, b in ij])
    assert np.array_equal(member[clear], inside[clear])


def test_adjacency_is_exactly_the_inside_segments():
    region = REGIONS["star"]()
    grid = dwell_grid(region, 0.8, rotation=0.2)
    poly = shapely_region(region)
    nb = grid.neighbors()
    idx = grid.dense_index()
    W = int(grid.dense_shape[1])
    from polishpath.plan import DIRS

    for d in range(8):
        q = idx[grid.dense_id + DIRS[d, 0] + DIRS[d, 1] * W]
        both = q >= 0
        lines = shapely.linestrings(np.stack([grid.uv[both], grid.uv[q[both]]], axis=1))
        ok = shapely.covers(poly, lines)
        assert np.array_equal(nb[both, d] >= 0, ok), f"direction {d}"
        assert np.all(nb[~both, d] < 0)
    # symmetric
    e = grid.edges()
    assert len(e) == int(sum(bin(int(m)).count("1") for m in grid.dirmask)) // 2


def test_no_step_across_a_concave_corner_or_a_hole():
    # L-shape, inner corner (5, 5); grid points (5.7, 4.7) and (4.7, 5.7) are both inside,
    # but the diagonal between them passes through the cut-out square.
    grid = dwell_grid(Region(L_shape()), 1.0, origin=(0.7, 0.7))
    k = {tuple(x): n for n, x in enumerate(grid.ij.tolist())}
    a, b = k[(5, 4)], k[(4, 5)]
    assert grid.neighbors()[a, 3] == -1 and grid.neighbors()[b, 7] == -1
    # a small hole on the diagonal between (0, 0) and (1, 1)
    hole = np.array([[0.4, 0.4], [0.4, 0.6], [0.6, 0.6], [0.6, 0.4]])
    region = Region(np.array([[-3, -3], [4, -3], [4, 4], [-3, 4]], dtype=float), (hole,))
    grid = dwell_grid(region, 1.0, origin=(0, 0))
    k = {tuple(x): n for n, x in enumerate(grid.ij.tolist())}
    nb = grid.neighbors()
    assert nb[k[(0, 0)], 1] == -1  # NE across the hole: forbidden
    assert nb[k[(0, 0)], 0] == k[(1, 0)]  # E along its side: fine


def test_margin_keeps_distance_from_boundary():
    region = REGIONS["annulus"]()
    grid = dwell_grid(region, 0.5, margin=1.2)
    d = shapely.distance(shapely_region(region).boundary, shapely.points(grid.uv))
    assert d.min() >= 1.2 - 1e-6
    assert grid.n < dwell_grid(region, 0.5).n


def test_spacing_too_large_and_bad_parameters():
    with pytest.raises(SpacingTooLargeError, match="spacing"):
        dwell_grid(Region(disc(1.0)), 5.0)
    with pytest.raises(SpacingTooLargeError):
        plan(Region(disc(1.0)), 5.0)
    with pytest.raises(ParameterError):
        dwell_grid(Region(disc()), -1.0)
    with pytest.raises(ParameterError):
        dwell_grid(Region(disc()), 1.0, margin=-2)
    with pytest.raises(ParameterError, match="pattern"):
        plan(Region(disc()), 1.0, "zigzagzag")
    with pytest.raises(ParameterError):
        plan(Region(disc()), 1.0, seed=-3)
    bowtie = np.array([[0, 0], [4, 4], [4, 0], [0, 4]], dtype=float)
    with pytest.raises(ParameterError, match="not a valid polygon"):
        dwell_grid(Region(bowtie), 0.5)


# ---------------------------------------------------------------- pseudo-random path


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    region=random_regions(),
    spacing=st.sampled_from([0.5, 0.7, 1.0]),
    seed=st.integers(0, 2**31),
    rotation=st.floats(0, np.pi / 2),
    margin=st.sampled_from([0.0, 0.0, 0.3]),
)
def test_pseudorandom_guarantees_hypothesis(region, spacing, seed, rotation, margin):
    try:
        path = plan(region, spacing, seed=seed, rotation=rotation, margin=margin)
    except SpacingTooLargeError:
        return
    grid = check_path(path, region, margin)
    st_ = path.stats
    assert st_["components"] >= 1
    assert len(path.pieces) - 1 == st_["components"] + st_["extra_pieces"]
    assert path.n_inside == grid.n


@pytest.mark.parametrize("name", sorted(REGIONS))
def test_pseudorandom_each_region_one_piece_per_component(name):
    region = REGIONS[name]()
    for seed in (0, 1, 2):
        path = plan(region, 0.5, seed=seed)
        check_path(path, region)
        if name == "star":
            # the spike tips are dead-end corridors one dwell point wide at this
            # spacing: no single path can enter and leave them all. Leftover
            # tips become their own (tiny) pieces, reported, never dropped.
            sizes = np.diff(path.pieces)
            assert sizes[0] >= 0.98 * path.n_points and sizes[1:].max(initial=0) <= 5
        else:
            assert path.stats["extra_pieces"] == 0, path.stats


def test_reproducible_bit_for_bit_and_seed_matters():
    region = REGIONS["star"]()
    a = plan(region, 0.4, seed=7)
    b = plan(region, 0.4, seed=7)
    c = plan(region, 0.4, seed=8)
    assert np.array_equal(a.uv, b.uv) and np.array_equal(a.ij, b.ij) and np.array_equal(a.pieces, b.pieces)
    assert not np.array_equal(a.ij, c.ij)
    assert a.provenance.seed == 7 and a.provenance.stage == "plan" and a.provenance.method == "pseudorandom"
    d = plan(region, 0.4, seed=None)
    assert isinstance(d.provenance.seed, int)
    e = plan(region, 0.4, seed=d.provenance.seed)
    assert np.array_equal(d.ij, e.ij)


def test_direction_shares_100x100_disc():
    region = Region(disc(50.0, 256))
    for seed in (0, 1):
        path = plan(region, 1.0, seed=seed)
        assert path.n_points > 7500
        m = path_metrics(path)
        shares = np.array(list(m["direction_shares"].values()))
        assert shares.min() >= 0.08 and shares.max() <= 0.17, m["direction_shares"]
        assert m["directions_used"] == 8
        assert m["crossings"] == 0 and m["coverage"] == 1.0


def test_start_point_is_first():
    region = REGIONS["disc"]()
    path = plan(region, 0.5, seed=3)
    assert np.hypot(*path.uv[0]) <= 0.5 * np.sqrt(0.5)  # nearest dwell point to the centroid
    path = plan(region, 0.5, seed=3, start=(6.0, -2.0))
    assert np.hypot(path.uv[0, 0] - 6.0, path.uv[0, 1] + 2.0) <= 0.5 * np.sqrt(0.5) + 1e-12


def test_split_region_is_planned_piece_by_piece():
    # two discs joined by a neck narrower than the spacing: two grid components
    left = shapely.Point(-8, 0).buffer(5, 32)
    right = shapely.Point(8, 0).buffer(5, 32)
    neck = shapely.box(-4, -0.2, 4, 0.2)
    poly = shapely.union_all([left, right, neck])
    region = Region(np.asarray(poly.exterior.coords)[:-1])
    path = plan(region, 1.0, seed=5, origin=(0.5, 0.5))
    check_path(path, region)
    assert path.stats["components"] == 2
    assert len(path.pieces) - 1 >= 2
    # each piece lies in one disc
    for k in range(len(path.pieces) - 1):
        xs = path.uv[path.pieces[k] : path.pieces[k + 1], 0]
        assert (xs < 0).all() or (xs > 0).all()


def test_one_point_wide_strip_is_one_piece():
    # the walk starts mid-strip and can only go one way; the other side is
    # joined before the start rather than left as a second piece
    region = Region(np.array([[0, 0], [6, 0], [6, 0.4], [0, 0.4]], dtype=float))
    for seed in range(4):
        path = plan(region, 1.0, seed=seed, origin=(0.5, 0.2))
        check_path(path, region)
        assert path.n_points == 6 and len(path.pieces) == 2


def test_isolated_dwell_points_are_reported_pieces():
    # a comb: teeth one point wide hanging off a spine; a tooth tip that no
    # path can enter and leave becomes its own piece, never a silent gap
    outer = [[0, 0], [9, 0], [9, 1.4]]
    for x in range(8, -1, -2):
        outer += [[x + 1, 1.4], [x + 1, 5], [x + 0.2, 5], [x + 0.2, 1.4]] if x < 8 else [[x + 0.2 + 0.6, 5], [x + 0.2, 5], [x + 0.2, 1.4]]
    outer += [[0, 1.4]]
    region = Region(np.array(outer, dtype=float))
    path = plan(region, 1.0, seed=1, origin=(0.5, 0.5))
    check_path(path, region)
    assert len(path.pieces) - 1 == path.stats["components"] + path.stats["extra_pieces"]


def test_pattern_registry_allows_peers():
    from polishpath.plan import PatternResult

    def reverse_raster(grid, region, *, seed, start, **opt):
        base = PATTERNS["raster"](grid, region, seed=seed, start=start)
        return PatternResult(base.uv[::-1], base.ij[::-1], base.pieces[-1] - base.pieces[::-1], True, {},
                             lattice=grid.lattice)

    register_pattern("test_reverse_raster", reverse_raster)
    try:
        p = plan(REGIONS["disc"](), 1.0, "test_reverse_raster")
        assert p.pattern == "test_reverse_raster" and p.provenance.seed is None
        q = plan(REGIONS["disc"](), 1.0, "raster")
        assert np.array_equal(p.ij, q.ij[::-1])
    finally:
        PATTERNS.pop("test_reverse_raster")
