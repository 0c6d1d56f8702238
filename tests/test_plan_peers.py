"""Peer patterns of the paper's Table 3 (issue 8): unicursal, maze, fractal, hilbert.

Every check recomputes what it needs from the raw output (uv, ij, pieces) with
shapely / numpy and the independent ``count_crossings``, never from the
pattern's own bookkeeping, except to compare its reported counts with ours.
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from polishpath.errors import ParameterError
from polishpath.plan import (
    PATTERNS,
    count_crossings,
    dwell_grid,
    plan,
    register_pattern,
)
from polishpath.plan.peers import (
    PEER_PATTERNS,
    bspline_deviation,
    fractal_sequence,
    hilbert_sequence,
    register_peers,
)
from polishpath.types import Region

register_peers()


def disc(r=10.0, n=96, c=(0.0, 0.0)):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.c_[c[0] + r * np.cos(t), c[1] + r * np.sin(t)]


def star(R=12.0, r=5.0, k=5, phase=0.3):
    t = np.linspace(0, 2 * np.pi, 2 * k, endpoint=False) + phase
    rad = np.where(np.arange(2 * k) % 2 == 0, R, r)
    return np.c_[rad * np.cos(t), rad * np.sin(t)]


REGIONS = {
    "disc": lambda: Region(disc()),
    "star": lambda: Region(star()),
    "annulus": lambda: Region(disc(10.0), (disc(4.0)[::-1],)),
}
SPACING = 0.6
PEERS = list(PEER_PATTERNS)


def _same_piece_steps(n, pieces):
    same = np.ones(max(n - 1, 0), dtype=bool)
    same[np.asarray(pieces)[1:-1] - 1] = False
    return np.flatnonzero(same)


@pytest.fixture(scope="module")
def paths():
    out = {}
    for rname, mk in REGIONS.items():
        reg = mk()
        for pat in PEERS:
            out[rname, pat] = (reg, plan(reg, SPACING, pat, seed=5, rotation=0.1))
    return out


@pytest.mark.parametrize("rname", list(REGIONS))
@pytest.mark.parametrize("pat", PEERS)
def test_peer_guarantees(paths, rname, pat):
    region, path = paths[rname, pat]
    uv, ij, pieces = np.asarray(path.uv), np.asarray(path.ij), np.asarray(path.pieces)
    assert len(uv) > 100
    assert pieces[0] == 0 and pieces[-1] == len(uv) and np.all(np.diff(pieces) > 0)
    # positions are grid positions
    grid = dwell_grid(region, SPACING, origin=path.origin, rotation=path.rotation)
    np.testing.assert_allclose(uv, grid.to_uv(ij), atol=1e-9)
    # each point once; consecutive points of a piece are 8-neighbours
    keys = ij[:, 0] * 1_000_003 + ij[:, 1]
    assert len(np.unique(keys)) == len(keys)
    k = _same_piece_steps(len(uv), pieces)
    assert np.all(np.abs(ij[k + 1] - ij[k]).max(axis=1) == 1)
    # no crossing (independent checker)
    assert count_crossings(uv, pieces) == 0
    # visited + left out = every dwell point; the count left out is reported
    gk = set((grid.ij[:, 0] * 1_000_003 + grid.ij[:, 1]).tolist())
    visited = gk & set(keys.tolist())
    assert len(visited) + len(path.unreached) == grid.n
    assert path.stats["left_out"] == len(path.unreached)
    # inside the region: points and steps (the maze pattern counts what leaves it)
    poly = shapely.Polygon(region.outer, list(region.holes))
    inside = shapely.intersects_xy(poly, uv[:, 0], uv[:, 1])
    lines = shapely.linestrings(np.stack([uv[k], uv[k + 1]], axis=1))
    covered = shapely.covers(poly, lines)
    if pat == "maze":
        assert path.stats["outside_points"] == int((~inside).sum()) > 0
        assert path.stats["outside_steps"] == int((~covered).sum()) > 0
        assert path.stats["area_outside_mm2"] == pytest.approx((~inside).sum() * SPACING**2)
    else:
        assert inside.all(), "a point lies outside the region"
        assert covered.all(), "a step leaves the region"
    if pat in ("fractal", "hilbert"):
        assert len(path.unreached) == 0  # clipped space-filling curves visit every dwell point
    if pat == "unicursal":
        assert len(path.unreached) < 0.2 * grid.n


@pytest.mark.parametrize("pat", PEERS)
def test_reproducible_with_seed_and_seed_matters(pat):
    reg = REGIONS["star"]()
    a = plan(reg, 0.7, pat, seed=0)
    b = plan(reg, 0.7, pat, seed=0)
    c = plan(reg, 0.7, pat, seed=1)
    assert np.array_equal(a.uv, b.uv) and np.array_equal(a.pieces, b.pieces)
    assert a.uv.shape != c.uv.shape or not np.array_equal(a.uv, c.uv)
    assert a.provenance.seed == 0


def test_unicursal_is_one_loop_per_maze_component_and_axis_steps_only():
    reg = REGIONS["annulus"]()
    p = plan(reg, 0.5, "unicursal", seed=2)
    assert len(p.pieces) - 1 == p.stats["maze_components"] == 1
    d = np.abs(np.diff(p.ij, axis=0)).sum(axis=1)
    assert np.all(d == 1)  # wall follower: along the two grid axes
    # the loop closes: last point is next to the first
    assert np.abs(p.ij[-1] - p.ij[0]).sum() == 1


def test_maze_shows_its_published_limits_on_an_annulus():
    p = plan(REGIONS["annulus"](), 0.5, "maze", seed=2)
    # scan lines cross the boundary 4 times across the hole: the far side is dropped
    assert p.stats["rows_clipped"] > 0
    assert p.stats["left_out"] > 0.1 * p.n_inside
    assert p.stats["outside_points"] > 0 and p.stats["outside_length_mm"] > 0


def test_fractal_sequence_is_a_noncrossing_hamiltonian_path():
    for k in (1, 2, 3, 5):
        for seed in range(3):
            s = fractal_sequence(k, seed)
            n = 2**k
            assert len(s) == n * n and len(np.unique(s[:, 0] * n + s[:, 1])) == n * n
            assert s.min() == 0 and s.max() == n - 1
            assert np.all(np.abs(np.diff(s, axis=0)).max(axis=1) == 1)
            assert count_crossings(s.astype(float)) == 0
    s = fractal_sequence(5, 0)
    diag = (np.abs(np.diff(s, axis=0)) == 1).all(axis=1)
    assert diag.any()  # 8-neighbour links: diagonals appear


def test_hilbert_sequence_is_the_hilbert_curve():
    s = hilbert_sequence(3)
    assert len(np.unique(s[:, 0] * 8 + s[:, 1])) == 64
    assert np.all(np.abs(np.diff(s, axis=0)).sum(axis=1) == 1)
    assert list(s[:4].tolist()) == [[0, 0], [0, 1], [1, 1], [1, 0]]
    assert not np.array_equal(hilbert_sequence(3, 5), s)


def test_bspline_deviation():
    line = np.c_[np.arange(10.0), np.zeros(10)]
    assert bspline_deviation(line)["dev_max"] == pytest.approx(0.0, abs=1e-12)
    zig = np.c_[np.arange(10.0), np.arange(10) % 2]
    d = bspline_deviation(zig)
    assert d["dev_max"] > 0.2  # the curve cuts every corner of a zig-zag
    p = plan(REGIONS["disc"](), 0.5, "fractal", seed=1)
    assert p.stats["smoothing_dev_max"] > 0.05 * 0.5


def test_register_peers_is_idempotent_and_leaves_others_alone():
    before = dict(PATTERNS)
    assert all(register_peers().values())
    assert all(register_peers().values())
    assert PATTERNS == before

    def other(grid, region, *, seed, start, **options):  # pragma: no cover - never called
        raise AssertionError

    register_pattern("hilbert", other)
    try:
        assert register_peers()["hilbert"] is False
        assert PATTERNS["hilbert"] is other
    finally:
        register_pattern("hilbert", PEER_PATTERNS["hilbert"], random=True)


def test_unknown_option_says_what_to_do():
    with pytest.raises(ParameterError, match="takes no option"):
        plan(REGIONS["disc"](), 1.0, "hilbert", seed=0, bogus=1)
    with pytest.raises(ParameterError, match="kruskal"):
        plan(REGIONS["disc"](), 1.0, "unicursal", seed=0, tree="prim")
