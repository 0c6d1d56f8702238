"""A pseudo-random path whose dwell points have no lattice (issue 26 Build 3: ``dwell_points="blue-noise"``).

Every check recomputes what it needs from the raw output (uv, ij, pieces) with
numpy / scipy / shapely, never from the planner's bookkeeping: each point once,
no crossing (the metrics' independent segment test), inside the region with its
margin, the points' minimum distance and density, no structure-factor peak
where the grid has one, the pieces, the seed, a curved part and a part with a hole.
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from scipy.spatial import Delaunay, cKDTree

from polishpath.errors import ParameterError
from polishpath.flatten import boundary_region, flatten
from polishpath.plan import count_crossings, dwell_grid, plan
from polishpath.plan.bluewalk import graph_walk_order
from polishpath.plan.points import DWELL_POINT_SETS, BlueNoisePoints, blue_noise_points
from polishpath.plan.points.blue_noise import EDGE_FACTOR, LEAF_EDGE_FACTOR
from polishpath.types import Region

H = 1.0


def disc(r=10.0, n=180, c=(0.0, 0.0)):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.c_[c[0] + r * np.cos(t), c[1] + r * np.sin(t)]


def annulus(R=40.0, r=12.0):
    return Region(disc(R), (disc(r)[::-1],))


def poly_of(region: Region, margin=0.0):
    p = shapely.Polygon(region.outer, list(region.holes))
    return p.buffer(-margin) if margin else p


@pytest.fixture(scope="module")
def ring_path():
    # about 4,500 dwell points on a part with a hole, with a margin
    return plan(annulus(), H, seed=5, margin=0.3, dwell_points="blue-noise")


@pytest.fixture(scope="module")
def big_path():
    # about 30,000 points: the guarantees at a size where a wrong walk shows
    return plan(Region(disc(100.0, 720)), H, seed=11, dwell_points="blue-noise")


def test_the_dwell_point_sets_are_named():
    assert DWELL_POINT_SETS == {"grid": True, "blue-noise": False, "relaxed": False}


@pytest.mark.parametrize("name", ["ring_path", "big_path"])
def test_every_dwell_point_is_visited_exactly_once(name, request):
    path = request.getfixturevalue(name)
    n = path.n_points
    assert path.dwell_points == "blue-noise" and path.lattice is None and path.dwell_points_only
    # ij[:, 0] is each point's number in its set: a permutation, every point once
    assert np.array_equal(np.sort(path.ij[:, 0]), np.arange(n)) and not path.ij[:, 1].any()
    assert len(path.unreached) == 0 and path.n_inside == n
    # no two path points at the same place
    assert len(np.unique(path.uv, axis=0)) == n


@pytest.mark.parametrize("name", ["ring_path", "big_path"])
def test_the_path_never_crosses_itself(name, request):
    path = request.getfixturevalue(name)
    assert count_crossings(path.uv, path.pieces) == 0


def test_count_crossings_sees_a_crossing_of_the_walk():
    # the check above is not vacuous: swapping two points of the walk makes it cross itself
    path = plan(Region(disc(15.0)), H, seed=2, dwell_points="blue-noise")
    uv = np.array(path.uv)
    uv[[100, 400]] = uv[[400, 100]]
    assert count_crossings(uv, path.pieces) > 0


def test_points_and_steps_stay_inside_the_region_with_its_margin(ring_path):
    inner = poly_of(annulus(), 0.3)
    shapely.prepare(inner)
    uv = ring_path.uv
    assert shapely.intersects_xy(inner.buffer(1e-9), uv[:, 0], uv[:, 1]).all()
    for a, b in zip(ring_path.pieces[:-1], ring_path.pieces[1:]):
        seg = np.stack([uv[a:b - 1], uv[a + 1:b]], axis=1)
        assert shapely.covers(inner.buffer(1e-9), shapely.linestrings(seg)).all()


def test_no_two_points_closer_than_0_7_spacing_and_the_density_of_the_grid():
    region = Region(disc(60.0, 360))
    pts = blue_noise_points(region, 0.8, seed=4)
    d, _ = cKDTree(pts.uv).query(pts.uv, k=2)
    assert d[:, 1].min() >= 0.7 * 0.8
    assert d[:, 1].min() >= pts.min_distance * (1 - 1e-9)
    grid = dwell_grid(region, 0.8)
    expect = region.area / 0.8**2
    assert abs(pts.n / expect - 1) < 0.03
    assert abs(pts.n / grid.n - 1) < 0.03


def _structure_factor(uv, kvecs):
    ph = uv @ kvecs.T
    return (np.cos(ph).sum(axis=0) ** 2 + np.sin(ph).sum(axis=0) ** 2) / len(uv)


def test_no_structure_factor_peak_where_the_grid_has_one():
    region = Region(disc(40.0, 360))
    bn = blue_noise_points(region, H, seed=7).uv
    gr = dwell_grid(region, H).uv
    # the grid's Bragg peaks (1/h, sqrt(2)/h, 2/h along and across) and a ring of directions at those radii
    two_pi = 2 * np.pi / H
    peaks = two_pi * np.array([[1, 0], [0, 1], [1, 1], [1, -1], [2, 0], [0, 2]], dtype=float)
    ang = np.linspace(0, np.pi, 90, endpoint=False)
    ring = np.concatenate([r * np.c_[np.cos(ang), np.sin(ang)] for r in two_pi * np.array([0.5, 1, 2**0.5, 2])])
    s_grid = _structure_factor(gr, peaks)
    s_bn = _structure_factor(bn, np.concatenate([peaks, ring]))
    assert s_grid.min() > 0.5 * len(gr)  # a lattice: S ~ N at its frequencies
    assert s_bn.max() < 20.0  # no peak at any of them, in any direction (S ~ 1 for an uncorrelated set)


def test_steps_are_short_and_turn_in_every_direction(big_path):
    uv = big_path.uv
    steps, ang = [], []
    for a, b in zip(big_path.pieces[:-1], big_path.pieces[1:]):
        d = np.diff(uv[a:b], axis=0)
        steps.append(np.hypot(*d.T))
        ang.append(np.arctan2(d[:, 1], d[:, 0]))
    steps, ang = np.concatenate(steps), np.concatenate(ang)
    assert steps.max() <= LEAF_EDGE_FACTOR * H * (1 + 1e-12) and LEAF_EDGE_FACTOR < 2.0
    assert np.median(steps) < 1.2 * H
    sectors = np.bincount(((ang + np.pi) // (np.pi / 8)).astype(int) % 16, minlength=16) / len(ang)
    assert sectors.max() <= 1.5 / 16 and sectors.min() >= 0.5 / 16
    # turns: every 45-degree class is taken
    turn = np.abs((np.diff(ang) + np.pi) % (2 * np.pi) - np.pi)
    classes = np.bincount(np.minimum((turn // (np.pi / 4)).astype(int), 3), minlength=4) / len(turn)
    assert classes.min() > 0.05


def test_pieces_follow_the_grid_walks_rules():
    # two discs joined by a channel far narrower than the spacing: two components, planned one after the other
    left, right = disc(8.0, 90, (-13.0, 0.0)), disc(8.0, 90, (13.0, 0.0))
    region = Region(np.asarray(shapely.union(shapely.Polygon(left), shapely.Polygon(right))
                               .union(shapely.box(-5.5, -0.02, 5.5, 0.02)).exterior.coords)[:-1])
    path = plan(region, H, seed=3, dwell_points="blue-noise")
    st = path.stats
    assert st["components"] >= 2  # the two discs (and any point that fell into the channel alone)
    assert len(path.pieces) - 1 == st["components"] + st["extra_pieces"]
    piece_of = np.repeat(np.arange(len(path.pieces) - 1), np.diff(path.pieces))
    assert not set(piece_of[path.uv[:, 0] < -5.5]) & set(piece_of[path.uv[:, 0] > 5.5])
    # within a piece every step is a graph edge (short); the only long moves are the lifts between pieces
    d = np.hypot(*np.diff(path.uv, axis=0).T)
    inner = np.ones(len(d), dtype=bool)
    inner[path.pieces[1:-1] - 1] = False
    assert d[inner].max() <= LEAF_EDGE_FACTOR * H
    assert path.pieces[0] == 0 and path.pieces[-1] == path.n_points


def test_the_walk_uses_only_edges_of_the_points_delaunay_triangulation():
    pts = blue_noise_points(Region(disc(20.0)), H, seed=9)
    tri = Delaunay(pts.uv)
    ip, ix = tri.vertex_neighbor_vertices
    dl = set(zip(np.repeat(np.arange(pts.n), np.diff(ip)).tolist(), ix.tolist()))
    e = pts.edges()
    assert all((a, b) in dl for a, b in e.tolist())
    # and nearly every Delaunay edge short enough and inside is kept (one whose every empty circle is wider
    # than EMPTY_CIRCLE_FACTOR x h, at the rim, may be left out)
    src = np.repeat(np.arange(pts.n), np.diff(ip))
    ln = np.hypot(*(pts.uv[src] - pts.uv[ix]).T)
    ok = shapely.covers(pts.polygon, shapely.linestrings(np.stack([pts.uv[src], pts.uv[ix]], axis=1)))
    assert 2 * len(e) >= 0.998 * int(((ln <= EDGE_FACTOR * H) & ok).sum())
    order, pieces, _ = graph_walk_order(pts, seed=1)
    steps = set()
    for a, b in zip(pieces[:-1], pieces[1:]):
        steps.update(zip(order[a:b - 1].tolist(), order[a + 1:b].tolist()))
    assert all((a, b) in dl for a, b in steps)


def test_exactly_collinear_points_give_the_delaunay_edges():
    """Three or more points exactly on one line (a row at y = 5 of a jittered grid; measured: ZeroDivisionError before
    2026-12-02) build the graph, and its edges are Delaunay edges of the points, every short inside one kept."""
    from polishpath.plan.points.blue_noise import neighbour_graph

    rng = np.random.default_rng(0)
    g = np.stack(np.meshgrid(np.arange(12.0), np.arange(12.0)), -1).reshape(-1, 2)
    uv = g + rng.uniform(-0.2, 0.2, g.shape)
    uv[g[:, 1] == 5, 1] = 5.0
    indptr, indices, _ = neighbour_graph(uv, H, shapely.box(-1.0, -1.0, 13.0, 13.0))
    ip, ix = Delaunay(uv).vertex_neighbor_vertices
    dl = set(zip(np.repeat(np.arange(len(uv)), np.diff(ip)).tolist(), ix.tolist()))
    mine = set(zip(np.repeat(np.arange(len(uv)), np.diff(indptr)).tolist(), indices.tolist()))
    assert mine <= dl
    src = np.repeat(np.arange(len(uv)), np.diff(ip))
    short = {(a, b) for a, b, ln in zip(src.tolist(), ix.tolist(), np.hypot(*(uv[src] - uv[ix]).T)) if ln <= 1.4 * H}
    assert short <= mine
    assert any(uv[a, 1] == uv[b, 1] == 5.0 for a, b in mine)  # the row's own edges are there


def test_same_seed_same_path_and_another_seed_another():
    region = Region(disc(15.0))
    a = plan(region, H, seed=21, dwell_points="blue-noise")
    b = plan(region, H, seed=21, dwell_points="blue-noise")
    c = plan(region, H, seed=22, dwell_points="blue-noise")
    assert a.uv.tobytes() == b.uv.tobytes() and a.ij.tobytes() == b.ij.tobytes()
    assert a.provenance.seed == 21 and a.provenance.params["dwell_points"] == "blue-noise"
    assert c.n_points != a.n_points or not np.array_equal(c.uv, a.uv)


def test_cell_areas_are_the_voronoi_cells_and_sum_to_the_region():
    region = Region(disc(25.0, 360))
    pts = blue_noise_points(region, H, seed=3)
    assert isinstance(pts, BlueNoisePoints) and (pts.cell_area > 0).all()
    assert abs(pts.cell_area.sum() / region.area - 1) < 0.03
    # an interior point's cell, against shapely's Voronoi diagram
    vor = shapely.voronoi_polygons(shapely.MultiPoint(pts.uv))
    cells = {int(np.argmin(np.hypot(*(pts.uv - np.asarray(g.representative_point().coords[0])).T))): g.area
             for g in vor.geoms if g.within(shapely.Point(0, 0).buffer(15.0))}
    k = np.array(list(cells))
    assert np.allclose(pts.cell_area[k], [cells[i] for i in k], rtol=1e-6)
    path = plan(region, H, seed=3, dwell_points="blue-noise")
    assert np.allclose(path.cell_area, pts.cell_area[path.ij[:, 0]])


def test_other_patterns_and_bad_names_are_refused():
    region = Region(disc(10.0))
    with pytest.raises(ParameterError, match="square grid only"):
        plan(region, H, "raster", seed=1, dwell_points="blue-noise")
    with pytest.raises(ParameterError, match="dwell-point set"):
        plan(region, H, seed=1, dwell_points="hexagonal")
    with pytest.raises(ParameterError, match="takes no option"):
        plan(region, H, seed=1, dwell_points="blue-noise", window=3)


@pytest.fixture(scope="module")
def hemisphere_flat():
    from polishpath.surfaces.analytic import hemisphere_surface

    return flatten(hemisphere_surface(20.0, 90.0, 3000), "mabf")


def test_a_curved_part_keeps_the_spacing_on_the_part(hemisphere_flat):
    from polishpath.pipeline import plan_on_surface

    s = 1.0
    res = plan_on_surface(hemisphere_flat, boundary_region(hemisphere_flat), s, seed=2, dwell_points="blue-noise",
                          margin=None)
    planar, sp = res.planar, res.surface_path
    assert planar.dwell_points == "blue-noise" and res.planar_spacing < s  # the stretch undone by finer points
    d3 = np.linalg.norm(np.diff(sp.xyz, axis=0), axis=1)
    inner = np.ones(len(d3), dtype=bool)
    inner[planar.pieces[1:-1] - 1] = False
    assert d3[inner].max() <= LEAF_EDGE_FACTOR * s * (1 + 1e-6)
    assert np.array_equal(np.sort(planar.ij[:, 0]), np.arange(planar.n_points))
    assert count_crossings(planar.uv, planar.pieces) == 0
    # the dwell weight is each point's planar cell times the local area ratio: divided by the cell, it is the
    # area ratio, a function of the radius on this part, as the grid path's weights (equal cells) are
    ratio = sp.dwell_weight / planar.cell_area
    grid = plan_on_surface(hemisphere_flat, boundary_region(hemisphere_flat), s, seed=2, margin=None)
    rg = np.hypot(*grid.planar.uv.T)
    k = np.argsort(rg)
    on_grid = np.interp(np.hypot(*planar.uv.T), rg[k], grid.surface_path.dwell_weight[k])
    assert np.corrcoef(ratio, on_grid)[0, 1] > 0.9
    assert abs(planar.n_points / grid.planar.n_points - 1) < 0.25


def test_the_job_runs_from_the_command_line_with_its_report(tmp_path):
    import json

    from typer.testing import CliRunner

    from polishpath.cli import app
    from polishpath.runfolder import read_run

    out = tmp_path / "bn"
    r = CliRunner().invoke(app, ["plan", "hemisphere:R=15,triangles=800", "--spacing", "1.0", "--seed", "4",
                                 "--dwell-points", "blue-noise", "-o", str(out), "--json"])
    assert r.exit_code == 0, r.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["config"]["dwell_points"] == "blue-noise"
    assert summary["plan"]["metrics"]["coverage"] == 1.0 and summary["plan"]["metrics"]["crossings"] == 0
    assert (out / "report.html").exists() and "dwell_points = \"blue-noise\"" in (out / "job.toml").read_text()
    rows = np.loadtxt(out / "path.csv", delimiter=",", skiprows=1)
    n = summary["plan"]["dwell_points"]
    assert np.array_equal(np.sort(rows[:, 1]), np.arange(n))  # column i: each point's number in its set, once
    run = read_run(out)  # the run folder gives the same path back, with its cells and its set's name
    assert run.planar.dwell_points == "blue-noise" and run.planar.cell_area is not None
    assert np.array_equal(run.planar.uv, run.surface_path.planar.uv) and len(run.planar.cell_area) == n
    # the report draws the steps' own directions and turns (the grid's 8 directions mean nothing here)
    from polishpath.report.figures import fig_directions, fig_turn_angles

    rose, turns = fig_directions(run), fig_turn_angles(run)
    assert "16 sectors" in rose.axes[0].get_title() and "no lattice" in turns.axes[0].get_title()
    shares = [p.get_height() for p in rose.axes[0].patches]
    assert len(shares) == 16 and abs(sum(shares) - 1) < 1e-9 and max(shares) < 1.5 / 16
    bad = CliRunner().invoke(app, ["plan", "hemisphere:R=15,triangles=800", "--pattern", "raster",
                                   "--dwell-points", "blue-noise", "-o", str(tmp_path / "x"), "--no-report"])
    assert bad.exit_code == 2 and "square grid only" in bad.output and "Traceback" not in bad.output
    assert not (tmp_path / "x").exists()


@pytest.mark.slow
def test_simulate_compares_the_walk_on_a_set_named_after_its_pattern(tmp_path):
    import json

    from typer.testing import CliRunner

    from polishpath.cli import app

    out = tmp_path / "sim"
    r = CliRunner().invoke(app, ["simulate", "hemisphere:R=15,triangles=800", "--patterns",
                                 "pseudorandom,pseudorandom:blue-noise", "--spacing", "1.0", "--seeds", "1",
                                 "--patch", "8", "--mode", "interference-free", "-o", str(out), "--json"])
    assert r.exit_code == 0, r.output
    res = json.loads((out / "results.json").read_text())
    rows = {row["name"]: row for row in res["rows"]}
    assert set(rows) == {"pseudorandom", "pseudorandom:blue-noise"}
    assert res["params"]["plans"]["pseudorandom:blue-noise"]["dwell_points"] == "blue-noise"
    assert rows["pseudorandom:blue-noise"]["lattice_basis"].startswith("nominal")
    bad = CliRunner().invoke(app, ["simulate", "hemisphere:R=15,triangles=800", "--patterns",
                                   "pseudorandom:hexagonal", "-o", str(tmp_path / "x")])
    assert bad.exit_code == 2 and "dwell-point set 'hexagonal'" in bad.output and "Traceback" not in bad.output


def test_a_disc_and_the_hemisphere_are_one_piece_as_on_the_grid(hemisphere_flat):
    # the grid walk's rule: a convex or simply connected region is one continuous piece (no tool lift). The
    # walk's end-game places every point it left (a leftover point ringed by path points passed crosswise,
    # or a rim point with two neighbours, is placed by moving a neighbour beside another with it between);
    # before that, seed 8 on this disc left 6 pieces
    from polishpath.pipeline import plan_on_surface

    region = Region(disc(100.0, 720))
    for seed in range(1, 9):
        path = plan(region, H, seed=seed, dwell_points="blue-noise")
        assert len(path.pieces) - 1 == 1 and path.stats["extra_pieces"] == 0, seed
        assert np.array_equal(np.sort(path.ij[:, 0]), np.arange(path.n_points))
        assert count_crossings(path.uv, path.pieces) == 0
    reg = boundary_region(hemisphere_flat)
    for seed in (1, 2, 3):
        bn = plan_on_surface(hemisphere_flat, reg, 0.7, seed=seed, dwell_points="blue-noise", margin=None).planar
        grid = plan_on_surface(hemisphere_flat, reg, 0.7, seed=seed, margin=None).planar
        assert len(bn.pieces) - 1 == len(grid.pieces) - 1 == 1, seed
        assert count_crossings(bn.uv, bn.pieces) == 0 and len(bn.unreached) == 0
