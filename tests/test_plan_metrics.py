"""count_crossings against a brute-force exact checker; path_metrics on hand-built paths; baselines."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from polishpath.plan import count_crossings, path_metrics, plan
from polishpath.types import PlanarPath, Region


def _orient(a, b, c):
    return int(np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])))


def _on_seg(a, b, p):
    return min(a[0], b[0]) <= p[0] <= max(a[0], b[0]) and min(a[1], b[1]) <= p[1] <= max(a[1], b[1])


def _intersect(p1, p2, p3, p4):
    """Closed segments p1p2 and p3p4 share a point (exact on integers)."""
    d1, d2 = _orient(p3, p4, p1), _orient(p3, p4, p2)
    d3, d4 = _orient(p1, p2, p3), _orient(p1, p2, p4)
    if d1 * d2 < 0 and d3 * d4 < 0:
        return True
    return (
        (d1 == 0 and _on_seg(p3, p4, p1))
        or (d2 == 0 and _on_seg(p3, p4, p2))
        or (d3 == 0 and _on_seg(p1, p2, p3))
        or (d4 == 0 and _on_seg(p1, p2, p4))
    )


def brute_crossings(pts, pieces):
    segs = []
    for k in range(len(pieces) - 1):
        for i in range(pieces[k], pieces[k + 1] - 1):
            segs.append((k, i))
    n = 0
    for x in range(len(segs)):
        for y in range(x + 1, len(segs)):
            (ka, i), (kb, j) = segs[x], segs[y]
            a, b, c, d = pts[i], pts[i + 1], pts[j], pts[j + 1]
            if ka == kb and j == i + 1:
                # consecutive: only a collinear step back overlaps beyond the shared vertex
                if _orient(a, b, d) == 0 and np.dot(np.subtract(b, a), np.subtract(d, c)) < 0:
                    n += 1
                continue
            n += _intersect(a, b, c, d)
    return n


@settings(max_examples=50, deadline=None)
@given(
    pts=st.lists(st.tuples(st.integers(0, 5), st.integers(0, 5)), min_size=2, max_size=14),
    cut=st.integers(0, 13),
)
def test_count_crossings_matches_brute_force(pts, cut):
    pts = [p for i, p in enumerate(pts) if i == 0 or p != pts[i - 1]]  # no zero-length steps
    if len(pts) < 2:
        return
    cut = min(cut, len(pts) - 1)
    pieces = [0, cut, len(pts)] if 0 < cut < len(pts) else [0, len(pts)]
    arr = np.array(pts, dtype=float)
    assert count_crossings(arr, pieces) == brute_crossings(pts, pieces)


def test_count_crossings_simple_cases():
    x = np.array([[0, 0], [1, 1], [1, 0], [0, 1]], float)  # the two diagonals of one cell
    assert count_crossings(x) == 1
    assert count_crossings(x, [0, 2, 4]) == 1  # pieces cross too
    assert count_crossings(x, [0, 2, 3, 4]) == 0  # single points: nothing to cross
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    assert count_crossings(square) == 0
    back = np.array([[0, 0], [1, 0], [0.5, 0]], float)  # step straight back
    assert count_crossings(back) == 1
    revisit = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0, 0], [-1, 0]], float)
    assert count_crossings(revisit) >= 1


def test_path_metrics_hand_made():
    ij = np.array([[0, 0], [1, 0], [2, 0], [2, 1], [1, 1]])
    p = PlanarPath(uv=ij * 2.0, ij=ij, spacing=2.0, n_inside=6)
    m = path_metrics(p)
    assert m["n_points"] == 5 and m["n_pieces"] == 1
    assert m["coverage"] == pytest.approx(5 / 6)
    assert m["step_mean"] == pytest.approx(2.0) and m["step_max"] == pytest.approx(2.0)
    assert m["direction_shares"]["E"] == pytest.approx(0.5)
    assert m["direction_shares"]["N"] == pytest.approx(0.25)
    assert m["direction_shares"]["W"] == pytest.approx(0.25)
    assert m["directions_used"] == 3
    assert m["turn_histogram"]["0"] == pytest.approx(1 / 3)
    assert m["turn_histogram"]["90"] == pytest.approx(2 / 3)
    assert m["longest_straight_run"] == 2 and m["longest_straight_mm"] == pytest.approx(4.0)
    assert m["crossings"] == 0


def test_largest_empty_disc_sees_a_gap():
    t = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    region = Region(np.c_[10 * np.cos(t), 10 * np.sin(t)])
    full = plan(region, 0.5, seed=1)
    m = path_metrics(full, region)
    assert m["largest_empty_disc"] <= 0.5 * np.sqrt(2)  # full coverage: no gap wider than a cell
    keep = np.hypot(*full.uv.T) > 3.0  # drop the points near the centre: a 3 mm hole
    holed = PlanarPath(uv=full.uv[keep], ij=full.ij[keep], spacing=0.5, pieces=[0, int(keep.sum())])
    m2 = path_metrics(holed, region)
    assert m2["largest_empty_disc"] >= 2.9


# ---------------------------------------------------------------- baselines


@pytest.fixture(scope="module")
def star_region():
    t = np.linspace(0, 2 * np.pi, 10, endpoint=False)
    rad = np.where(np.arange(10) % 2 == 0, 12.0, 5.0)
    return Region(np.c_[rad * np.cos(t), rad * np.sin(t)], (np.c_[np.cos(t[::-1]), np.sin(t[::-1])] * 1.5,))


def _steps_inside(path, region):
    poly = shapely.Polygon(region.outer, list(region.holes))
    same = np.ones(path.n_points - 1, dtype=bool)
    same[np.asarray(path.pieces[1:-1]) - 1] = False
    k = np.flatnonzero(same)
    lines = shapely.linestrings(np.stack([path.uv[k], path.uv[k + 1]], axis=1))
    assert shapely.intersects_xy(poly, path.uv[:, 0], path.uv[:, 1]).all()
    assert shapely.covers(poly, lines).all()
    return same


def test_raster_baseline(star_region):
    p = plan(star_region, 0.5, "raster", rotation=0.4)
    m = path_metrics(p)
    assert m["coverage"] == 1.0 and len(p.unreached) == 0 and m["n_points"] == p.n_inside
    assert m["crossings"] == 0
    sh = m["direction_shares"]
    assert sh["E"] + sh["W"] > 0.8 and m["directions_used"] <= 4  # periodic: two directions
    _steps_inside(p, star_region)
    assert p.provenance.seed is None and p.dwell_points_only


def test_rectangular_baseline(star_region):
    p = plan(star_region, 0.5, "rectangular")
    m = path_metrics(p)
    assert m["coverage"] == 1.0 and m["crossings"] == 0
    same = _steps_inside(p, star_region)
    assert np.abs(np.diff(p.ij, axis=0))[same].max() == 1  # 8-neighbour steps only
    sh = m["direction_shares"]
    assert sh["E"] + sh["N"] + sh["W"] + sh["S"] > 0.9  # four directions


def test_spiral_baseline(star_region):
    p = plan(star_region, 0.5, "spiral")
    m = path_metrics(p)
    assert p.dwell_points_only is False
    same = _steps_inside(p, star_region)
    steps = np.hypot(*np.diff(p.uv, axis=0).T)[same]
    # constant arc step = spacing: chords are a little shorter on the first tight turn
    assert steps.max() <= 0.5 + 1e-9 and np.mean(np.abs(steps - 0.5) < 0.01) > 0.95
    assert m["crossings"] == 0
    i, j = np.array(p.stats["start_index"]) * p.spacing
    c, s = np.cos(p.rotation), np.sin(p.rotation)
    centre = p.origin + np.array([c * i - s * j, s * i + c * j])
    r = np.hypot(*(p.uv - centre).T)
    assert np.all(np.diff(r) > 0)  # an Archimedean spiral runs outward from its centre
    assert 0.6 < m["coverage"] <= 1.0


# ------------------------------------------- the grid-cell crossing counter


def shapely_crossings(uv, pieces):
    """The counter this one replaced: every pair of segments whose boxes overlap
    (shapely's STRtree) tested with shapely's exact predicates."""
    uv = np.asarray(uv, float)
    segs = [(k, i) for k in range(len(pieces) - 1) for i in range(pieces[k], pieces[k + 1] - 1)]
    if len(segs) < 2:
        return 0
    piece = np.array([k for k, _ in segs])
    start = np.array([i for _, i in segs])
    lines = shapely.linestrings(np.stack([uv[start], uv[start + 1]], axis=1))
    left, right = shapely.STRtree(lines).query(lines, predicate="intersects")
    sel = left < right
    left, right = left[sel], right[sel]
    cons = (piece[left] == piece[right]) & (start[left] + 1 == start[right])
    d1 = uv[start[left] + 1] - uv[start[left]]
    d2 = uv[start[right] + 1] - uv[start[right]]
    cross = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    back = (np.abs(cross) <= 1e-12 * np.hypot(*d1.T) * np.hypot(*d2.T)) & ((d1 * d2).sum(axis=1) < 0)
    return int((~cons).sum() + (cons & back).sum())


@settings(max_examples=60, deadline=None)
@given(
    steps=st.lists(st.tuples(st.integers(-1, 1), st.integers(-1, 1)), min_size=1, max_size=60),
    rotation=st.floats(0.0, 3.0),
    scale=st.floats(0.05, 7.0),
    cut=st.integers(0, 60),
)
def test_count_crossings_matches_shapely_on_rotated_grid_walks(steps, rotation, scale, cut):
    # rotated grid points are collinear in exact arithmetic but not in floats: the
    # cases where the float orientation's sign is uncertain and the exact one decides
    ij = np.concatenate([[[0, 0]], np.cumsum(steps, axis=0)])
    c, s = np.cos(rotation), np.sin(rotation)
    uv = scale * ij @ np.array([[c, s], [-s, c]]) + [0.1, -3.3]
    n = len(uv)
    pieces = [0, cut, n] if 0 < cut < n else [0, n]
    assert count_crossings(uv, pieces) == shapely_crossings(uv, pieces)


def test_count_crossings_matches_shapely_on_random_segments():
    rng = np.random.default_rng(5)
    for n in (2, 3, 10, 200):
        uv = rng.random((n, 2)) * 3
        assert count_crossings(uv) == shapely_crossings(uv, [0, n])
    # long steps across many cells next to many short ones
    uv = np.concatenate([rng.random((300, 2)) * 0.2, [[-50, -50], [50, 50], [50, -50], [-50, 50]]])
    assert count_crossings(uv) == shapely_crossings(uv, [0, len(uv)])


def test_orientation_is_exact_where_floats_round():
    from fractions import Fraction

    from polishpath.plan.metrics import _orient

    terms, expansion = np.empty(16), np.empty(16)
    rng = np.random.default_rng(11)
    uncertain = 0
    for _ in range(3000):
        a = rng.random(2) * 10
        b = a + rng.random(2) * 10
        t = rng.random()
        c = a + t * (b - a) + rng.choice([0.0, 1e-15, -1e-15, 3e-16]) * rng.random(2)  # on or next to the line
        exact = (Fraction(b[0]) - Fraction(a[0])) * (Fraction(c[1]) - Fraction(a[1])) - (
            Fraction(b[1]) - Fraction(a[1])) * (Fraction(c[0]) - Fraction(a[0]))
        want = (exact > 0) - (exact < 0)
        naive = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        uncertain += int(np.sign(naive)) != want
        assert _orient(a[0], a[1], b[0], b[1], c[0], c[1], terms, expansion) == want
    assert uncertain > 50  # the plain float determinant gets many of these wrong


def test_path_metrics_of_a_planned_path_match_direct_formulas():
    t = np.linspace(0, 2 * np.pi, 90, endpoint=False)
    region = Region(np.c_[14 * np.cos(t), 9 * np.sin(t)], (np.c_[np.cos(t[::-1]), np.sin(t[::-1])] * 3.0,))
    for path in (plan(region, 0.5, seed=4), plan(region, 0.5, "raster", rotation=0.3)):
        m = path_metrics(path, region)
        same = np.ones(path.n_points - 1, dtype=bool)
        same[np.asarray(path.pieces[1:-1]) - 1] = False
        d = np.diff(path.uv, axis=0)[same]
        c, s = np.cos(path.rotation), np.sin(path.rotation)
        g = d @ np.array([[c, -s], [s, c]])  # grid frame
        ang = np.arctan2(g[:, 1], g[:, 0])
        keep = same[:-1] & same[1:]  # turns: consecutive steps of one piece
        first = np.cumsum(same)[:-1][keep] - 1
        turn = np.abs(np.angle(np.exp(1j * (ang[first + 1] - ang[first]))))
        hist = np.bincount(np.round(np.degrees(turn) / 45).astype(int), minlength=5)[:5] / len(turn)
        assert [m["turn_histogram"][str(45 * k)] for k in range(5)] == pytest.approx(hist, abs=1e-15)
        distinct = len(np.unique(path.ij, axis=0))
        assert m["coverage"] == pytest.approx(min(distinct, path.n_inside) / path.n_inside, abs=1e-15)
        assert m["step_mean"] == pytest.approx(np.hypot(*d.T).mean(), rel=1e-12)
        assert m["crossings"] == shapely_crossings(path.uv, path.pieces)


def test_farthest_sample_matches_a_kd_tree_query_of_every_sample():
    # the grid search (rings of cells, a KD-tree for the samples it leaves open) must
    # give the KD-tree's farthest sample exactly: same distance, same first index
    from scipy.spatial import cKDTree

    from polishpath.plan.metrics import _farthest_sample

    rng = np.random.default_rng(1)
    for trial in range(120):
        uv = rng.random((int(rng.integers(1, 300)), 2)) * rng.choice([1, 10, 100])
        samples = rng.random((int(rng.integers(1, 500)), 2)) * 120 - 10  # many far outside the points
        if trial % 3 == 0:  # ties and repeated points
            uv, samples = np.round(uv), np.round(samples)
        dist, _ = cKDTree(uv).query(samples)
        k, d = _farthest_sample(uv, samples)
        assert k == int(np.argmax(dist)) and d == dist.max()
