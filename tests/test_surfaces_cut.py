"""``polishpath.surfaces.cut.geodesic_disc``: a disc of faces within a geodesic radius, checked."""

from __future__ import annotations

import numpy as np
import pytest

from polishpath import meshops
from polishpath.errors import InputError, ParameterError
from polishpath.surfaces import load_surface
from polishpath.surfaces.cut import geodesic_disc


def _grid(n=21, h=1.0):
    x, y = np.meshgrid(np.arange(n) * h, np.arange(n) * h)
    v = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    f = []
    for i in range(n - 1):
        for j in range(n - 1):
            a = i * n + j
            f += [[a, a + 1, a + n + 1], [a, a + n + 1, a + n]]
    return v, np.asarray(f)


def test_disc_on_a_plane_keeps_the_faces_within_the_radius():
    v, f = _grid()
    centre = 10 * 21 + 10
    s = geodesic_disc(v, f, centre, 5.0, name="p", source="grid")
    assert len(meshops.boundary_loops(s.faces)) == 1
    # every kept vertex lies within the radius along the edges, so within it in the plane too
    assert np.linalg.norm(s.vertices[:, :2] - v[centre, :2], axis=1).max() <= 5.0 + 1e-9
    # and it holds the faces well inside: on this grid a path along the edges is at most sqrt(2) x too long
    assert s.n_faces > 0.8 * np.pi * (5.0 / np.sqrt(2)) ** 2 * 2
    assert s.n_faces < np.pi * 5.0**2 * 2
    assert "geodesic patch r=5 mm" in s.source and s.name == "p"


def test_geodesic_not_euclidean_on_a_hemisphere():
    s0 = load_surface("hemisphere:R=30,triangles=3000")
    top = int(np.argmax(s0.vertices[:, 2]))
    s = geodesic_disc(s0.vertices, s0.faces, top, 20.0)
    # along the sphere, 20 mm from the pole is an angle of 20/30 rad: the patch's lowest point is there
    assert s.vertices[:, 2].min() >= 30 * np.cos(20 / 30) - 1.0


def test_a_hole_within_the_radius_is_refused():
    v, f = _grid()
    centre = 10 * 21 + 10
    keep = ~np.any(f == centre, axis=1)  # a hole around the centre vertex
    with pytest.raises(InputError, match="boundary loops"):
        geodesic_disc(v, f[keep], centre + 3, 8.0)


def test_bad_arguments():
    v, f = _grid(5)
    with pytest.raises(ParameterError):
        geodesic_disc(v, f, 99, 1.0)
    with pytest.raises(ParameterError):
        geodesic_disc(v, f, 0, -1.0)
    with pytest.raises(ParameterError):
        geodesic_disc(v, f, 0, float("nan"))
