"""Analytic surfaces: sag values against closed forms, vertices on the surface, triangle counts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from polishpath import meshops
from polishpath.errors import ParameterError, SpecError
from polishpath.surfaces import BUILTINS, Aperture, load_surface
from polishpath.surfaces.analytic import default_bspline_net, mesh_bspline_surface
from polishpath.surfaces.sag import (
    BSplineSurface,
    EvenAsphere,
    Sphere,
    XYPolynomial,
    ZernikeSag,
    fringe_nm,
    noll_nm,
    xy_term_exponents,
)

rng = np.random.default_rng(0)
X = rng.uniform(-10, 10, 200)
Y = rng.uniform(-10, 10, 200)


def test_sphere_sag_is_the_circle():
    R = 50.0
    z = Sphere(R)(X, Y)
    r2 = X**2 + Y**2
    np.testing.assert_allclose(z, R - np.sqrt(R * R - r2), rtol=0, atol=1e-12)


def test_even_asphere_matches_closed_form():
    c, k, a4, a6 = 1 / 80.0, -0.7, 2e-6, -3e-9
    s = EvenAsphere(c=c, k=k, a=(a4, a6))
    r2 = X**2 + Y**2
    want = c * r2 / (1 + np.sqrt(1 - (1 + k) * c * c * r2)) + a4 * r2**2 + a6 * r2**3
    np.testing.assert_allclose(s(X, Y), want, rtol=1e-13, atol=1e-13)


def test_paraboloid_is_r2_over_2R():
    R = 100.0
    np.testing.assert_allclose(EvenAsphere(c=1 / R, k=-1)(X, Y), (X**2 + Y**2) / (2 * R), atol=1e-12)


def test_xy_polynomial_code_v_order():
    assert xy_term_exponents(9) == [(1, 0), (0, 1), (2, 0), (1, 1), (0, 2), (3, 0), (2, 1), (1, 2), (0, 3)]
    co = (0.0, 0.0, 1e-3, 2e-3, 3e-3, 0, 4e-5)
    s = XYPolynomial(coeffs=co, norm_radius=2.0)
    xn, yn = X / 2, Y / 2
    want = 1e-3 * xn**2 + 2e-3 * xn * yn + 3e-3 * yn**2 + 4e-5 * xn**2 * yn
    np.testing.assert_allclose(s(X, Y), want, atol=1e-14)


def test_zernike_index_orders():
    fringe = [fringe_nm(j) for j in range(1, 17)]
    assert fringe == [(0, 0), (1, 1), (1, -1), (2, 0), (2, 2), (2, -2), (3, 1), (3, -1), (4, 0),
                      (3, 3), (3, -3), (4, 2), (4, -2), (5, 1), (5, -1), (6, 0)]
    noll = [noll_nm(j) for j in range(1, 12)]
    assert noll == [(0, 0), (1, 1), (1, -1), (2, 0), (2, -2), (2, 2), (3, -1), (3, 1), (3, -3), (3, 3), (4, 0)]


def test_zernike_sag_closed_forms():
    rn = 10.0
    rho = np.hypot(X, Y) / rn
    th = np.arctan2(Y, X)
    # Fringe Z4 (defocus) = 2 rho^2 - 1, Z9 (spherical) = 6 rho^4 - 6 rho^2 + 1, Z5 = rho^2 cos 2t
    s = ZernikeSag(coeffs=(0, 0, 0, 1e-3, 2e-3, 0, 0, 0, 3e-3), norm_radius=rn, order="fringe")
    want = 1e-3 * (2 * rho**2 - 1) + 2e-3 * rho**2 * np.cos(2 * th) + 3e-3 * (6 * rho**4 - 6 * rho**2 + 1)
    np.testing.assert_allclose(s(X, Y), want, atol=1e-14)
    # Standard (Noll) Z4 = sqrt(3) (2 rho^2 - 1), Z7 = sqrt(8) (3 rho^3 - 2 rho) sin t
    s = ZernikeSag(coeffs=(0, 0, 0, 1e-3, 0, 0, 2e-3), norm_radius=rn, order="standard")
    want = 1e-3 * math.sqrt(3) * (2 * rho**2 - 1) + 2e-3 * math.sqrt(8) * (3 * rho**3 - 2 * rho) * np.sin(th)
    np.testing.assert_allclose(s(X, Y), want, atol=1e-14)


def test_bspline_reproduces_a_bilinear_net_exactly():
    # a B-spline surface reproduces a linear function of its control grid exactly
    g = np.linspace(0, 30, 6)
    Xg, Yg = np.meshgrid(g, g, indexing="ij")
    net = np.stack([Xg, Yg, 0.1 * Xg + 0.2 * Yg + 1], axis=2)
    bs = BSplineSurface(net, 3)
    u = rng.uniform(0, 1, 50)
    v = rng.uniform(0, 1, 50)
    p = bs.evaluate(u, v)
    np.testing.assert_allclose(p[:, 2], 0.1 * p[:, 0] + 0.2 * p[:, 1] + 1, atol=1e-12)
    # corners interpolate the corner control points (clamped knots)
    np.testing.assert_allclose(bs.evaluate([0, 1], [0, 1]), net[[0, -1], [0, -1]], atol=1e-12)


@pytest.mark.parametrize("name", list(BUILTINS))
@pytest.mark.parametrize("triangles", [1119, 5000])
def test_builtin_counts_and_vertices_on_surface(name, triangles):
    s = load_surface(f"{name}:triangles={triangles}")
    assert abs(s.n_faces - triangles) <= 0.02 * triangles
    if name == "hemisphere":  # sag is ill-conditioned at the vertical rim: use the distance to the sphere
        assert np.max(np.abs(np.linalg.norm(s.vertices, axis=1) - s.params["R"])) < 1e-9
    elif name == "bspline":  # parametric: checked against its (u, v) in test_bspline_mesh_vertices_on_surface
        assert s.sag is None
    else:
        z = s.sag(s.vertices[:, 0], s.vertices[:, 1])
        assert np.max(np.abs(z - s.vertices[:, 2])) < 1e-9
    # well shaped and one boundary loop, consistently oriented (no face flipped against its neighbours)
    assert np.degrees(meshops.corner_angles(s.vertices, s.faces)).min() > 10
    assert len(meshops.boundary_loops(s.faces)) == 1
    fn = meshops.face_normals(s.vertices, s.faces)
    adj = meshops.face_adjacency(s.faces)
    assert np.min(np.einsum("ij,ij->i", fn[adj[:, 0]], fn[adj[:, 1]])) > 0


def test_hemisphere_vertices_on_sphere_and_paper_count():
    s = load_surface("hemisphere:R=30,triangles=100220")
    assert abs(s.n_faces - 100220) <= 0.02 * 100220
    r = np.linalg.norm(s.vertices, axis=1)
    assert np.max(np.abs(r - 30.0)) < 1e-9
    assert s.vertices[:, 2].min() >= -1e-12
    area = meshops.surface_area(s.vertices, s.faces)
    assert abs(area - 2 * math.pi * 30**2) / (2 * math.pi * 30**2) < 2e-3


def test_bspline_mesh_vertices_on_surface():
    bs = BSplineSurface(default_bspline_net(), 3)
    surf, uv = mesh_bspline_surface(bs, Aperture("rectangle", width=1, height=1, center=(0.5, 0.5)), 2000,
                                    name="b", source="t", params={})
    np.testing.assert_allclose(surf.vertices, bs.evaluate(uv[:, 0], uv[:, 1]), atol=1e-9)
    assert abs(surf.n_faces - 2000) <= 40


@pytest.mark.parametrize(
    "spec",
    [
        "sphere:R=100,radius=20,triangles=2000",
        "asphere:R=80,k=-1,a4=1e-7,aperture=annulus,radius=25,inner_radius=6,triangles=3000",
        "xy-polynomial:C4=0.01,C6=-0.01,norm_radius=20,aperture=rectangle,width=40,height=30,triangles=2000",
        "zernike:R=200,Z4=0.05,Z9=0.02,norm_radius=25,aperture=star,radius=25,inner_radius=10,triangles=2500",
    ],
)
def test_inline_analytic_specs(spec):
    s = load_surface(spec)
    want = int(spec.rsplit("triangles=", 1)[1])
    assert abs(s.n_faces - want) <= 0.02 * want
    z = s.sag(s.vertices[:, 0], s.vertices[:, 1])
    assert np.max(np.abs(z - s.vertices[:, 2])) < 1e-9


def test_annulus_has_a_hole():
    s = load_surface("asphere:R=80,k=-1,aperture=annulus,radius=25,inner_radius=6,triangles=3000")
    loops = meshops.boundary_loops(s.faces)
    assert len(loops) == 2
    r_inner = np.hypot(*s.vertices[loops[1]][:, :2].T)
    np.testing.assert_allclose(r_inner, 6.0, rtol=1e-9)


def test_toml_spec(tmp_path):
    p = tmp_path / "z.toml"
    p.write_text(
        '[surface]\ntype = "zernike"\nR = 200.0\norder = "standard"\nnorm_radius = 25.0\n'
        'coeffs = [0, 0, 0, 0.01, 0.002]\ntriangles = 1500\n[aperture]\ntype = "annulus"\nradius = 25.0\ninner_radius = 5.0\n'
    )
    s = load_surface(p)
    assert abs(s.n_faces - 1500) <= 30
    zs = ZernikeSag(c=1 / 200, coeffs=(0, 0, 0, 0.01, 0.002), norm_radius=25.0, order="standard")
    np.testing.assert_allclose(s.vertices[:, 2], zs(s.vertices[:, 0], s.vertices[:, 1]), atol=1e-9)


def test_examples_spec_files_load():
    from pathlib import Path

    ex = Path(__file__).resolve().parents[1] / "examples"
    specs = sorted(ex.glob("surface-*.toml"))
    assert specs, "examples/ must hold at least one surface spec"
    for p in specs:
        assert load_surface(p).n_faces > 0


@pytest.mark.parametrize(
    "spec, words",
    [
        ("hemisphere:R=-3", "R must be > 0"),
        ("hemisphere:colour=red", "no parameter colour"),
        ("hemisphere:R", "has no value"),
        ("saddle:triangles=1", "at least 2 triangles"),
        ("asphere:R=10,radius=20", "not defined out to"),
        ("zernike:order=weird", "fringe"),
        ("sphere:R=50,aperture=annulus,radius=10,inner_radius=12", "inner radius"),
        ("hemisphree", "Did you mean 'hemisphere'"),
    ],
)
def test_bad_specs_are_named(spec, words):
    with pytest.raises((SpecError, ParameterError)) as e:
        load_surface(spec)
    assert words in str(e.value)
