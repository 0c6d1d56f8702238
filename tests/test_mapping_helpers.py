"""Inputs built by the tests themselves (no dependency on flatten / plan).

Imported by test_mapping*.py, test_smooth*.py and test_export*.py; holds no test.
"""

from __future__ import annotations

import numpy as np

from polishpath.types import Flattening, PlanarPath, Provenance, Surface


def grid_faces(n_a: int, n_b: int) -> np.ndarray:
    """Two triangles per cell of an n_a x n_b vertex grid (vertex index a * n_b + b), counter-clockwise in (a, b)."""
    idx = np.arange(n_a * n_b).reshape(n_a, n_b)
    a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def cylinder_patch(radius=20.0, n_theta=30, n_z=20, dtheta=0.05, dz=0.8) -> Flattening:
    """A triangulated cylinder patch and its exact development.

    Each column of quads is a planar rectangle of width equal to the chord
    ``2 R sin(dtheta/2)``; laying the columns side by side is an exact isometry
    of the mesh (not of the smooth cylinder), so planar lengths are kept in 3D.
    """
    th = np.arange(n_theta) * dtheta
    z = np.arange(n_z) * dz
    T, Z = np.meshgrid(th, z, indexing="ij")
    xyz = np.stack([radius * np.cos(T), radius * np.sin(T), Z], -1).reshape(-1, 3)
    chord = 2 * radius * np.sin(dtheta / 2)
    A = np.arange(n_theta)[:, None] * chord + 0 * Z
    uv = np.stack([A, Z], -1).reshape(-1, 2)
    f = grid_faces(n_theta, n_z)
    s = Surface(xyz, f, name="cylinder_patch")
    return Flattening(s, uv, np.zeros((len(f), 3)), provenance=Provenance("flatten", "exact_development"))


def spherical_cap(radius=30.0, max_polar=1.0, n_r=24, n_phi=64) -> Flattening:
    """A spherical cap (polar angle <= max_polar rad) with its azimuthal-equidistant map.

    Polar grid of rings; uv = R * polar * (cos phi, sin phi) (lengths along the
    meridians kept, along the parallels stretched by polar / sin(polar)).
    """
    rings = np.linspace(0, max_polar, n_r + 1)[1:]
    phi = np.linspace(0, 2 * np.pi, n_phi, endpoint=False)
    P, F = np.meshgrid(rings, phi, indexing="ij")
    xyz = np.concatenate([[[0, 0, radius]], np.stack([radius * np.sin(P) * np.cos(F), radius * np.sin(P) * np.sin(F),
                                                       radius * np.cos(P)], -1).reshape(-1, 3)])
    uv = np.concatenate([[[0, 0]], np.stack([radius * P * np.cos(F), radius * P * np.sin(F)], -1).reshape(-1, 2)])
    faces = []
    for j in range(n_phi):  # central fan
        faces.append([0, 1 + j, 1 + (j + 1) % n_phi])
    for i in range(n_r - 1):
        for j in range(n_phi):
            a = 1 + i * n_phi + j
            b = 1 + i * n_phi + (j + 1) % n_phi
            c = 1 + (i + 1) * n_phi + (j + 1) % n_phi
            d = 1 + (i + 1) * n_phi + j
            faces += [[a, d, c], [a, c, b]]
    s = Surface(xyz, np.array(faces), name="spherical_cap")
    return Flattening(s, uv, np.zeros((len(faces), 3)), provenance=Provenance("flatten", "azimuthal_equidistant"))


def inside_uv(flat: Flattening, pts: np.ndarray, eps: float = 1e-9) -> np.ndarray:
    """Mask of planar points inside the flattened mesh (brute force over all triangles; for building inputs)."""
    p = flat.uv[flat.surface.faces]  # (F, 3, 2)
    a, b, c = p[:, 0], p[:, 1], p[:, 2]
    inside = np.zeros(len(pts), dtype=bool)
    for s in range(0, len(pts), 256):
        q = pts[s : s + 256, None, :]

        def cr(u, v, w):
            return (v[..., 0] - u[..., 0]) * (w[..., 1] - u[..., 1]) - (v[..., 1] - u[..., 1]) * (w[..., 0] - u[..., 0])

        d1, d2, d3 = cr(a, b, q), cr(b, c, q), cr(c, a, q)
        neg = (d1 < -eps) | (d2 < -eps) | (d3 < -eps)
        pos = (d1 > eps) | (d2 > eps) | (d3 > eps)
        inside[s : s + 256] = np.any(~(neg & pos), axis=1)
    return inside


def serpentine_path(flat: Flattening, spacing: float, *, margin: float = 1e-3, pieces_at=None,
                    rotation: float = 0.0, seed: int | None = None) -> PlanarPath:
    """Boustrophedon over the grid points strictly inside the flattened mesh's bounding box.

    Points are kept only where inside the mesh (checked against the uv bounding
    box shrunk by ``margin`` for the rectangle-like cylinder, by triangle test otherwise).
    """
    lo = flat.uv.min(0) + margin
    hi = flat.uv.max(0) - margin
    xs = np.arange(lo[0], hi[0] + 1e-12, spacing)
    ys = np.arange(lo[1], hi[1] + 1e-12, spacing)
    pts, ij = [], []
    for i, x in enumerate(xs):
        order = range(len(ys)) if i % 2 == 0 else range(len(ys) - 1, -1, -1)
        for j in order:
            pts.append((x, ys[j]))
            ij.append((i, j))
    pts = np.array(pts)
    ij = np.array(ij)
    keep = inside_uv(flat, pts)
    pts, ij = pts[keep], ij[keep]
    if pieces_at is None:  # the tool lifts wherever consecutive points are not grid neighbours
        jump = np.linalg.norm(np.diff(pts, axis=0), axis=1) > 2**0.5 * spacing * (1 + 1e-9)
        pieces_at = (np.flatnonzero(jump) + 1).tolist()
    pieces = [0, *pieces_at, len(pts)]
    return PlanarPath(pts, ij, spacing, origin=lo, rotation=rotation, pattern="raster", pieces=pieces,
                      provenance=Provenance("plan", "test_serpentine", {"spacing": spacing}, seed=seed))


def polyline_surface_path(points: np.ndarray, normals: np.ndarray | None = None, pieces=None):
    """A SurfacePath directly from 3D points (for smoothing / export tests)."""
    from polishpath.types import SurfacePath

    n = len(points)
    if normals is None:
        normals = np.tile([0.0, 0.0, 1.0], (n, 1))
    planar = PlanarPath(points[:, :2], np.zeros((n, 2), np.int64), 0.5, pieces=pieces,
                        provenance=Provenance("plan", "test", seed=7))
    return SurfacePath(points, normals, np.zeros(n, np.int64), np.tile([1.0, 0, 0], (n, 1)), np.ones(n), planar,
                       provenance=Provenance("map", "test", seed=7))
