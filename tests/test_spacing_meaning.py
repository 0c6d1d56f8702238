"""One meaning of spacing for every pattern (issue 26, Build 1).

``spacing`` is the distance between neighbouring dwell points and between
neighbouring passes on the part: on a flat part every pattern plans at the
spacing asked, with about area / spacing^2 dwell points; on a curved part the
spacing holds on the part for every pattern, measured here independently of
the pipeline's own figure.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from polishpath.errors import MappingError
from polishpath.flatten import boundary_region, flatten
from polishpath.pipeline import plan_on_surface
from polishpath.pipeline.surfaceplan import neighbour_spacing_max
from polishpath.plan import PATTERNS
from polishpath.plan.peers import register_peers
from polishpath.surfaces import load_surface

S = 0.5
SQ2 = math.sqrt(2.0)
register_peers()
ALL_PATTERNS = sorted(PATTERNS)


@pytest.fixture(scope="module")
def disk():
    # a flat disk of radius 6 mm (the built-in bump-and-dimple part with both at height 0)
    flat = flatten(load_surface("concave-convex:radius=6,amplitude=0,triangles=2000"), "mabf")
    return flat, boundary_region(flat)


@pytest.fixture(scope="module")
def dome():
    flat = flatten(load_surface("hemisphere:R=8,triangles=3000"), "mabf")
    return flat, boundary_region(flat)


def _plan(flat, region, pattern):
    try:
        return plan_on_surface(flat, region, S, pattern=pattern, seed=1, margin=None)
    except MappingError as exc:
        # a peer built as published may leave the part (the maze's overhang): refused, naming it
        assert pattern in str(exc)
        pytest.skip(f"{pattern} leaves this part by construction")


def _nearest_on_part(xyz: np.ndarray) -> np.ndarray:
    """Distance of every dwell point to its nearest other dwell point on the part, mm (N,)."""
    d, _ = cKDTree(xyz).query(xyz, k=2)
    return d[:, 1]


def _lattice_neighbour_distances(ij: np.ndarray, xyz: np.ndarray, offset) -> np.ndarray:
    """On-part distances of every pair of dwell points at grid offset ``offset`` (a python dict look-up)."""
    where = {tuple(k): n for n, k in enumerate(ij.tolist())}
    out = [np.linalg.norm(xyz[n] - xyz[where[(i + offset[0], j + offset[1])]])
           for n, (i, j) in enumerate(ij.tolist()) if (i + offset[0], j + offset[1]) in where]
    return np.asarray(out)


@pytest.mark.parametrize("pattern", ALL_PATTERNS)
def test_on_a_flat_part_every_pattern_plans_at_the_spacing_asked(disk, pattern):
    flat, region = disk
    res = _plan(flat, region, pattern)
    assert res.planar_spacing == pytest.approx(S, rel=2e-3)
    # about area / spacing^2 dwell points (the automatic margin of a quarter spacing trims the rim)
    expect = flat.metrics["area_3d"] / S**2
    assert 0.85 * expect <= res.planar.n_points <= 1.05 * expect
    # the dwell points' own neighbours are the spacing apart (a spiral's steps and turns included)
    near = _nearest_on_part(res.surface_path.xyz)
    assert np.median(near) == pytest.approx(S, rel=0.02)
    assert near.max() <= S * (1 + 1e-6)


@pytest.mark.parametrize("pattern", ALL_PATTERNS)
def test_on_a_curved_part_the_spacing_holds_on_the_part_for_every_pattern(dome, pattern):
    flat, region = dome
    res = _plan(flat, region, pattern)
    planar, xyz = res.planar, res.surface_path.xyz
    assert res.surface_path.stats["neighbour_spacing_max"] <= S * (1 + 1e-9)
    assert res.surface_path.stats["neighbour_spacing_max"] > S / 1.03  # tight: not a needlessly fine grid
    assert _nearest_on_part(xyz).max() <= S * (1 + 1e-6)
    if planar.lattice is not None and planar.dwell_points_only:
        # every lattice neighbour on the part: axial at most s (a raster's passes too), diagonal sqrt(2) s
        for off, bound in (((1, 0), S), ((0, 1), S), ((1, 1), SQ2 * S), ((1, -1), SQ2 * S)):
            d = _lattice_neighbour_distances(planar.ij, xyz, off)
            assert len(d) > 0 and d.max() <= bound * (1 + 1e-6), (off, d.max())
    else:
        steps = np.linalg.norm(np.diff(xyz, axis=0), axis=1)
        inside = np.ones(len(steps), dtype=bool)
        inside[planar.pieces[1:-1] - 1] = False
        assert steps[inside].max() <= S * (1 + 1e-6)


def test_every_grid_pattern_gets_the_same_planar_spacing_on_the_same_part(dome):
    flat, region = dome
    got = {p: _plan(flat, region, p).planar_spacing for p in ("pseudorandom", "raster", "rectangular", "spiral")}
    assert max(got.values()) / min(got.values()) < 1.03, got


def test_neighbour_spacing_counts_the_passes_a_path_does_not_step_between(disk):
    # a raster steps along its rows only; its rows are neighbours all the same: stretching the part 1.5
    # times across the rows (the plane's j axis as it lies on the part) raises the figure to 1.5 h although
    # no step of the path along its rows gets longer
    flat, region = disk
    res = plan_on_surface(flat, region, S, pattern="raster", seed=1, spacing_on="plane")
    sp = res.surface_path
    A, *_ = np.linalg.lstsq(np.c_[res.planar.uv, np.ones(res.planar.n_points)], sp.xyz, rcond=None)
    across = A[1] / np.linalg.norm(A[1])  # the part's direction of the plane's j axis (the raster's rows run along i)
    stretched = sp.xyz + 0.5 * np.outer(sp.xyz @ across, across)
    from dataclasses import replace

    assert neighbour_spacing_max(res.planar, sp) == pytest.approx(S, rel=1e-6)
    assert neighbour_spacing_max(res.planar, replace(sp, xyz=stretched)) == pytest.approx(1.5 * S, rel=1e-3)


@pytest.mark.parametrize("part", ["disk", "dome"])
def test_a_blue_noise_set_keeps_the_same_meaning_of_spacing(part, request):
    # no lattice: neighbours are the points within sqrt(2) h in the plane, and the walk's own edges
    flat, region = request.getfixturevalue(part)
    res = plan_on_surface(flat, region, S, seed=1, margin=None, dwell_points="blue-noise")
    assert res.planar.lattice is None
    if part == "disk":
        assert res.planar_spacing == pytest.approx(S, rel=2e-3)
    sp, uv = res.surface_path, res.planar.uv
    assert sp.stats["neighbour_spacing_max"] <= S * (1 + 1e-9)
    d3 = np.linalg.norm(np.diff(sp.xyz, axis=0), axis=1)
    d2 = np.linalg.norm(np.diff(uv, axis=0), axis=1)
    inside = np.ones(len(d3), dtype=bool)
    inside[res.planar.pieces[1:-1] - 1] = False
    # no step on the part longer than its planar length / h x the spacing
    assert (d3[inside] <= d2[inside] / res.planar_spacing * S * (1 + 1e-6)).all()
