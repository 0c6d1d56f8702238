"""Inverse mapping, projection baseline and the step bound (issue 5, items 1-3; the re-planning loop is
tested with the pipeline's wiring in test_pipeline_wiring.py)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from polishpath.errors import MappingError, ParameterError
from polishpath.mapping import (
    jacobian_singular_values,
    locate_points,
    map_to_surface,
    planar_spacing_for_surface,
    surface_step_stats,
)
from polishpath.flatten import flatten
from polishpath.types import Flattening, PlanarPath, Surface
from test_mapping_helpers import cylinder_patch, grid_faces, serpentine_path, spherical_cap

SQ2 = 2**0.5


@pytest.fixture(scope="module")
def cyl():
    return cylinder_patch()


@pytest.fixture(scope="module")
def cap():
    return spherical_cap()


def _mesh_distance(surface: Surface, pts: np.ndarray) -> np.ndarray:
    m = trimesh.Trimesh(np.array(surface.vertices), np.array(surface.faces), process=False)
    _, d, _ = trimesh.proximity.closest_point(m, pts)
    return d


def test_mapped_points_lie_on_the_mesh(cap):
    path = serpentine_path(cap, 1.3)
    sp = map_to_surface(cap, path)
    assert len(sp.xyz) == path.n_points > 100
    assert _mesh_distance(cap.surface, sp.xyz).max() <= 1e-9
    # area coordinates: non-negative, sum 1, and they reproduce the planar point (Eq. 9)
    assert sp.bary.min() >= 0 and np.allclose(sp.bary.sum(1), 1, atol=1e-12)
    uv_back = np.einsum("nk,nkd->nd", sp.bary, cap.uv[cap.surface.faces[sp.face_ids]])
    assert np.abs(uv_back - path.uv).max() <= 1e-9
    # Eq. 8: same area coordinates in the 3D triangle
    xyz = np.einsum("nk,nkd->nd", sp.bary, cap.surface.vertices[cap.surface.faces[sp.face_ids]])
    assert np.abs(xyz - sp.xyz).max() <= 1e-12
    assert sp.provenance.stage == "map" and sp.provenance.seed == path.provenance.seed


def test_normals_are_unit_and_close_to_the_sphere_normal(cap):
    sp = map_to_surface(cap, serpentine_path(cap, 2.0))
    assert np.allclose(np.linalg.norm(sp.normals, axis=1), 1, atol=1e-12)
    radial = sp.xyz / np.linalg.norm(sp.xyz, axis=1, keepdims=True)
    cosang = np.einsum("ij,ij->i", radial, sp.normals)
    assert cosang.min() > np.cos(np.radians(3))  # outward and within a few degrees


def test_developable_surface_keeps_planar_steps(cyl):
    path = serpentine_path(cyl, 0.5)
    sp = map_to_surface(cyl, path)
    d3 = np.linalg.norm(np.diff(sp.xyz, axis=0), axis=1)
    d2 = np.linalg.norm(np.diff(path.uv, axis=0), axis=1)
    # along the rulings (same developed column) the step is kept exactly
    along = np.abs(np.diff(path.uv[:, 0])) < 1e-12
    assert along.sum() > 100
    assert np.abs(d3[along] - d2[along]).max() <= 1e-9
    # across the fold lines a chord can only be shorter than the developed length
    assert np.all(d3 <= d2 + 1e-9)
    # ... and the mapped segment itself keeps the length (isometry): sample one densely
    k = int(np.flatnonzero(~along)[0])
    t = np.linspace(0, 1, 4001)[:, None]
    seg = path.uv[k] + t * (path.uv[k + 1] - path.uv[k])
    dense = map_to_surface(cyl, PlanarPath(seg, np.zeros((len(seg), 2), np.int64), 0.5))
    assert abs(np.linalg.norm(np.diff(dense.xyz, axis=0), axis=1).sum() - d2[k]) < 1e-6
    # uniform density on an isometric map: every dwell weight is 1
    assert np.allclose(sp.dwell_weight, 1, atol=1e-12) and sp.stats["density_cv"] < 1e-12


def test_dwell_weight_follows_the_area_ratio(cap):
    sp = map_to_surface(cap, serpentine_path(cap, 1.5))
    assert abs(sp.dwell_weight.mean() - 1) < 1e-12
    # azimuthal-equidistant map: area ratio 3D/2D = sin(t)/t at polar angle t
    t = np.arccos(np.clip(sp.xyz[:, 2] / 30.0, -1, 1))
    expect = np.where(t > 1e-9, np.sin(t) / np.maximum(t, 1e-12), 1.0)
    expect /= expect.mean()
    assert np.abs(sp.dwell_weight - expect).max() < 0.02
    assert sp.stats["density_cv"] > 0.02  # the cap's density does vary


def test_locate_matches_brute_force():
    rng = np.random.default_rng(3)
    uv = rng.random((200, 2)) * 10
    from scipy.spatial import Delaunay

    faces = Delaunay(uv).simplices
    pts = rng.random((3000, 2)) * 10
    fid, bary, _ = locate_points(uv, faces, pts)
    inside = Delaunay(uv).find_simplex(pts) >= 0
    assert np.array_equal(fid >= 0, inside)
    ok = fid >= 0
    back = np.einsum("nk,nkd->nd", bary[ok], uv[faces[fid[ok]]])
    assert np.abs(back - pts[ok]).max() < 1e-9 and bary[ok].min() >= 0


def test_boundary_points_snap_and_outside_points_raise(cyl):
    lo = cyl.uv.min(0)
    on_vertex = cyl.uv[:3]
    just_out = np.array([[lo[0] - 1e-11, lo[1] + 1.0]])
    pts = np.concatenate([on_vertex, just_out])
    sp = map_to_surface(cyl, PlanarPath(pts, np.zeros((len(pts), 2), np.int64), 0.5))
    assert np.abs(sp.xyz[:3] - cyl.surface.vertices[:3]).max() < 1e-12
    assert sp.stats["n_snapped"] == 1
    far = np.array([[lo[0] - 1e-3, lo[1] + 1.0]])
    with pytest.raises(MappingError, match="outside the flattened mesh"):
        map_to_surface(cyl, PlanarPath(far, np.zeros((1, 2), np.int64), 0.5))


def test_mapping_rejects_a_flattening_of_another_surface(cyl, cap):
    bad = Flattening(cap.surface, cyl.uv[: 10], np.zeros((cap.surface.n_faces, 3)))
    with pytest.raises(MappingError, match="planar vertices"):
        map_to_surface(bad, serpentine_path(cyl, 2.0))


def test_step_statistics_count_the_normal_range():
    s = 0.5
    pts = np.cumsum(np.array([[0, 0, 0], [s, 0, 0], [1.2 * s, 0, 0], [1.5 * s, 0, 0], [0.5 * s, 0, 0],
                              [9.0, 0, 0]]), axis=0)
    st = surface_step_stats(pts, np.array([0, 5, 6]), s)
    assert st["n_steps"] == 4  # the jump to the last piece is a lift, not a step
    assert st["share_normal"] == 0.5 and st["share_long"] == 0.25 and st["share_short"] == 0.25
    assert st["step_max"] == pytest.approx(1.5 * s) and st["step_mean"] == pytest.approx(s * 4.2 / 4)


def test_projection_flattening_is_an_orthogonal_projection(cap):
    pf = flatten(cap.surface, "projection")
    assert pf.metrics["folded_triangles"] == 0
    n = np.array(pf.provenance.params["plane_normal"])
    assert abs(abs(n[2]) - 1) < 1e-9  # the cap's best-fit plane is horizontal
    # pairwise planar distances equal the distances of the xy shadows
    i, j = np.arange(0, 200), np.arange(200, 400)
    d_uv = np.linalg.norm(pf.uv[i] - pf.uv[j], axis=1)
    d_xy = np.linalg.norm(cap.surface.vertices[i, :2] - cap.surface.vertices[j, :2], axis=1)
    assert np.abs(d_uv - d_xy).max() < 1e-9
    # mapping through it lifts the planar points along the plane normal
    path = serpentine_path(pf, 1.7)
    sp = map_to_surface(pf, path)
    c = np.array(pf.provenance.params["plane_origin"])
    axes = np.array(pf.provenance.params["plane_axes"])
    assert np.abs((sp.xyz - c) @ axes.T - path.uv).max() < 1e-9


def test_projection_counts_folds():
    # a cylinder patch bent through 300 degrees overhangs its best-fit plane
    th = np.linspace(0, np.radians(300), 61)
    x = np.linspace(0, 60, 6)  # long axis: the best-fit plane contains it and cuts the arc
    T, X = np.meshgrid(th, x, indexing="ij")
    xyz = np.stack([X, 10 * np.cos(T), 10 * np.sin(T)], -1).reshape(-1, 3)
    pf = flatten(Surface(xyz, grid_faces(61, 6)), "projection")
    assert pf.metrics["folded_triangles"] > 0


def test_planar_spacing_bounds_every_3d_step(cap):
    s = 1.0
    squeezed = Flattening(cap.surface, cap.uv * 0.6, cap.angles)  # 3D lengths ~1.67x planar
    plain = map_to_surface(squeezed, serpentine_path(squeezed, s), surface_spacing=s)
    assert plain.stats["step_max"] > SQ2 * s  # without the reduction factor steps are too long
    h = planar_spacing_for_surface(squeezed, s)
    assert h < s
    sig = jacobian_singular_values(squeezed)[:, 0]
    assert h == pytest.approx(s / sig.max())
    mapped = map_to_surface(squeezed, serpentine_path(squeezed, h), surface_spacing=s)
    assert mapped.stats["step_max"] <= SQ2 * s
    # an isometric map needs no reduction
    assert planar_spacing_for_surface(cylinder_patch(), 0.5) == pytest.approx(0.5, rel=1e-9)
    with pytest.raises(ParameterError):
        planar_spacing_for_surface(cap, -1.0)


def test_overlapping_layers_pick_the_highest():
    # two triangles covering the same planar spot (a fold): the one higher along the normal wins
    uv = np.array([[0, 0], [4, 0], [0, 4], [0, 0], [4, 0], [0, 4.0]])
    faces = np.array([[0, 1, 2], [3, 4, 5]])
    heights = np.array([0, 0, 0, 5, 5, 5.0])
    fid, bary, _ = locate_points(uv, faces, np.array([[1.0, 1.0]]), heights=heights)
    assert fid[0] == 1
    fid, _, _ = locate_points(uv, faces, np.array([[1.0, 1.0]]), heights=-heights)
    assert fid[0] == 0
    # and through the projection baseline: the lifted point is the top layer of a folded surface
    th = np.linspace(0, np.radians(300), 61)
    x = np.linspace(0, 60, 6)
    T, X = np.meshgrid(th, x, indexing="ij")
    xyz = np.stack([X, 10 * np.cos(T), 10 * np.sin(T)], -1).reshape(-1, 3)
    pf = flatten(Surface(xyz, grid_faces(61, 6)), "projection")
    n = np.array(pf.provenance.params["plane_normal"])
    pts = pf.uv[grid_faces(61, 6)].mean(axis=1)  # triangle centroids, some under overhangs
    sp = map_to_surface(pf, PlanarPath(pts, np.zeros((len(pts), 2), np.int64), 1.0))
    fid_all, _, _ = locate_points(pf.uv, pf.surface.faces, pts)  # first found, no preference
    h_top = sp.xyz @ n
    # compare with every layer: lift each centroid onto every triangle containing it
    tri = pf.uv[pf.surface.faces]
    for k in range(0, len(pts), 7):
        best = -np.inf
        for f_, t in enumerate(tri):
            m = np.array([[t[1, 0] - t[0, 0], t[2, 0] - t[0, 0]], [t[1, 1] - t[0, 1], t[2, 1] - t[0, 1]]])
            if abs(np.linalg.det(m)) < 1e-12:
                continue
            b1, b2 = np.linalg.solve(m, pts[k] - t[0])
            if min(b1, b2, 1 - b1 - b2) >= -1e-12:
                p3 = pf.surface.vertices[pf.surface.faces[f_]]
                best = max(best, ((1 - b1 - b2) * p3[0] + b1 * p3[1] + b2 * p3[2]) @ n)
        assert h_top[k] == pytest.approx(best, abs=1e-9)


def test_projection_method_stretches_steps_at_the_rim():
    # the Table 2 effect on a near-hemisphere: the projection path's steps blow up at the steep rim,
    # the (length-preserving along meridians) flattened path's do not
    cap = spherical_cap(radius=30.0, max_polar=1.45, n_r=30, n_phi=72)
    s = 1.5
    proj = flatten(cap.surface, "projection")
    p_proj = map_to_surface(proj, serpentine_path(proj, s), surface_spacing=s)
    p_flat = map_to_surface(cap, serpentine_path(cap, s), surface_spacing=s)
    assert p_proj.stats["step_max"] > 3 * s
    assert p_flat.stats["step_max"] <= SQ2 * s
    assert p_proj.stats["step_mean"] > p_flat.stats["step_mean"]
