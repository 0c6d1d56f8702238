"""meshops.jacobian_singular_values: the one per-triangle stretch of a map, checked on maps with known stretch."""

from __future__ import annotations

import numpy as np
import pytest

from polishpath import meshops
from polishpath.errors import PolishPathError


def _mesh(seed=0, n=40):
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(seed)
    uv = rng.uniform(-5, 5, (n, 2))
    return uv, Delaunay(uv).simplices


def test_affine_map_has_its_singular_values_on_every_triangle():
    uv, f = _mesh()
    # a rotation, a stretch by 3 and 0.5, another rotation, then lifted into a tilted plane in 3D
    c, s = np.cos(0.7), np.sin(0.7)
    A = np.array([[c, -s], [s, c]]) @ np.diag([3.0, 0.5]) @ np.array([[c, s], [-s, c]])
    q, _ = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))
    xyz = (uv @ A.T) @ q[:, :2].T + np.array([1.0, 2.0, 3.0])
    sv = meshops.jacobian_singular_values(uv, xyz, f)
    assert sv.shape == (len(f), 2)
    np.testing.assert_allclose(sv, np.tile([3.0, 0.5], (len(f), 1)), rtol=1e-10)
    # the other way round: the inverse map, whose stretch is 1/sigma in reverse order
    back = meshops.jacobian_singular_values(xyz, uv, f)
    np.testing.assert_allclose(back, np.tile([2.0, 1 / 3], (len(f), 1)), rtol=1e-10)
    # 2D -> 2D
    np.testing.assert_allclose(meshops.jacobian_singular_values(uv, uv @ A.T, f), sv, rtol=1e-10)


def test_curved_map_inverse_relation_and_isometry():
    uv, f = _mesh(2)
    xyz = np.column_stack([uv, 0.05 * (uv ** 2).sum(1)])  # a paraboloid over the plane
    fwd = meshops.jacobian_singular_values(uv, xyz, f)
    back = meshops.jacobian_singular_values(xyz, uv, f)
    np.testing.assert_allclose(back, 1.0 / fwd[:, ::-1], rtol=1e-9)
    assert (fwd[:, 0] >= fwd[:, 1]).all() and (fwd[:, 1] >= 1 - 1e-12).all()
    # a rigid motion of the part has no stretch
    np.testing.assert_allclose(meshops.jacobian_singular_values(xyz, xyz[:, ::-1] + 7.0, f), 1.0, rtol=1e-10)


def test_degenerate_source_triangle_is_inf_and_bad_shape_raises():
    uv = np.array([[0.0, 0], [1, 0], [2, 0], [0, 1]])
    f = np.array([[0, 1, 2], [0, 1, 3]])
    sv = meshops.jacobian_singular_values(uv, np.column_stack([uv, np.zeros(4)]), f)
    assert np.isinf(sv[0]).all() and np.allclose(sv[1], 1.0)
    with pytest.raises(PolishPathError):
        meshops.jacobian_singular_values(np.zeros((4, 4)), uv, f)
