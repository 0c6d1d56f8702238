"""The relaxed blue-noise set (``dwell_points="relaxed"``, issue 26 Build 4): Lloyd steps on the Poisson-disk set.

The same guarantees as the blue-noise set's (tests/test_plan_blue_noise.py),
recomputed from the raw output: each point once, no crossing, inside with the
margin, short steps in every direction, no two points closer than 0.7 h, the
grid's density, no structure-factor peak; and what the relaxation is for:
evener cells than the Poisson-disk set it starts from, with exact Voronoi
centroids (checked against shapely's Voronoi diagram).
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from scipy.spatial import cKDTree

from polishpath.errors import ParameterError
from polishpath.plan import count_crossings, dwell_grid, plan
from polishpath.plan.points import DWELL_POINT_SETS, blue_noise_points, relaxed_points
from polishpath.plan.points.blue_noise import LEAF_EDGE_FACTOR, neighbour_graph
from polishpath.plan.points.relaxed import MIN_DISTANCE_FACTOR, voronoi_centroids
from polishpath.types import Region

H = 1.0


def disc(r=10.0, n=180, c=(0.0, 0.0)):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.c_[c[0] + r * np.cos(t), c[1] + r * np.sin(t)]


def annulus(R=40.0, r=12.0):
    return Region(disc(R, 360), (disc(r)[::-1],))


@pytest.fixture(scope="module")
def ring_path():
    # about 4,500 dwell points on a part with a hole, with a margin
    return plan(annulus(), H, seed=5, margin=0.3, dwell_points="relaxed")


@pytest.fixture(scope="module")
def big_path():
    return plan(Region(disc(80.0, 720)), H, seed=11, dwell_points="relaxed")


def test_the_relaxed_set_is_registered_without_a_lattice():
    assert DWELL_POINT_SETS["relaxed"] is False


@pytest.mark.parametrize("name", ["ring_path", "big_path"])
def test_every_point_once_no_crossing_inside(name, request):
    path = request.getfixturevalue(name)
    n = path.n_points
    assert path.dwell_points == "relaxed" and path.lattice is None
    assert path.provenance.params["dwell_points"] == "relaxed"
    assert np.array_equal(np.sort(path.ij[:, 0]), np.arange(n)) and len(path.unreached) == 0
    assert len(np.unique(path.uv, axis=0)) == n
    assert count_crossings(path.uv, path.pieces) == 0


def test_points_and_steps_stay_inside_the_region_with_its_margin(ring_path):
    inner = shapely.Polygon(annulus().outer, list(annulus().holes)).buffer(-0.3).buffer(1e-9)
    uv = ring_path.uv
    assert shapely.intersects_xy(inner, uv[:, 0], uv[:, 1]).all()
    for a, b in zip(ring_path.pieces[:-1], ring_path.pieces[1:]):
        assert shapely.covers(inner, shapely.linestrings(np.stack([uv[a:b - 1], uv[a + 1:b]], axis=1))).all()


def test_steps_are_short_and_spread_over_every_direction(big_path):
    uv, pieces = big_path.uv, big_path.pieces
    d = np.concatenate([np.diff(uv[a:b], axis=0) for a, b in zip(pieces[:-1], pieces[1:])])
    steps, ang = np.hypot(*d.T), np.arctan2(d[:, 1], d[:, 0])
    assert steps.max() <= LEAF_EDGE_FACTOR * H * (1 + 1e-12) and LEAF_EDGE_FACTOR < 2.0
    sectors = np.bincount(((ang + np.pi) // (np.pi / 8)).astype(int) % 16, minlength=16) / len(ang)
    assert sectors.max() <= 1.5 / 16 and sectors.min() >= 0.5 / 16
    assert len(pieces) - 1 == 1  # a disc is one piece


def test_min_distance_density_and_no_structure_factor_peak():
    region = Region(disc(40.0, 360))
    pts = relaxed_points(region, H, seed=7)
    d, _ = cKDTree(pts.uv).query(pts.uv, k=2)
    assert d[:, 1].min() >= MIN_DISTANCE_FACTOR * H >= 0.7 * H
    assert pts.min_distance == pytest.approx(d[:, 1].min())
    assert abs(pts.n / dwell_grid(region, H).n - 1) < 0.03
    # no peak at the grid's Bragg frequencies, nor on rings through them, in any direction
    k = 2 * np.pi / H
    ang = np.linspace(0, np.pi, 90, endpoint=False)
    kv = np.concatenate([r * np.c_[np.cos(ang), np.sin(ang)] for r in k * np.array([0.5, 1, 2**0.5, 2])])
    ph = pts.uv @ kv.T
    s = (np.cos(ph).sum(axis=0) ** 2 + np.sin(ph).sum(axis=0) ** 2) / pts.n
    assert s.max() < 20.0


def test_the_cells_are_evener_than_the_poisson_disk_sets():
    region = Region(disc(30.0, 360))
    bn = blue_noise_points(region, H, seed=3)
    rx = relaxed_points(region, H, seed=3)
    inner_b = np.hypot(*bn.uv.T) < 25
    inner_r = np.hypot(*rx.uv.T) < 25
    cv_b = bn.cell_area[inner_b].std() / bn.cell_area[inner_b].mean()
    cv_r = rx.cell_area[inner_r].std() / rx.cell_area[inner_r].mean()
    assert cv_r < 0.75 * cv_b  # measured 0.07 against 0.12
    assert abs(rx.cell_area.sum() / region.area - 1) < 0.03
    # zero steps: the Poisson-disk set itself
    assert np.array_equal(relaxed_points(region, H, seed=3, steps=0).uv, bn.uv)


def test_voronoi_centroids_are_the_cells_centroids():
    pts = blue_noise_points(Region(disc(15.0)), H, seed=2)
    _, _, tris = neighbour_graph(pts.uv, H, pts.polygon)
    cen, closed = voronoi_centroids(pts.uv, tris)
    vor = shapely.voronoi_polygons(shapely.MultiPoint(pts.uv))
    checked = 0
    for g in vor.geoms:
        c = np.asarray(g.centroid.coords[0])
        if np.hypot(*c) > 10.0:
            continue
        k = int(np.argmin(np.hypot(*(pts.uv - np.asarray(g.representative_point().coords[0])).T)))
        assert closed[k]
        assert np.allclose(cen[k], c, atol=1e-9)
        checked += 1
    assert checked > 200


def test_same_seed_same_points_and_bad_steps_refused():
    region = Region(disc(12.0))
    a = plan(region, H, seed=4, dwell_points="relaxed")
    b = plan(region, H, seed=4, dwell_points="relaxed")
    assert a.uv.tobytes() == b.uv.tobytes() and a.ij.tobytes() == b.ij.tobytes()
    with pytest.raises(ParameterError, match="Lloyd steps"):
        relaxed_points(region, H, seed=1, steps=-1)
    with pytest.raises(ParameterError, match="square grid only"):
        plan(region, H, "raster", seed=1, dwell_points="relaxed")
