"""From planar angles to planar vertex positions.

Two layouts:

* :func:`midpoint_layout` - the paper's section 2.2: start at the triangle at
  the centre of the mesh, walk breadth-first over neighbours, place each
  triangle so the midpoint and direction of the edge it shares with the
  already-placed parent coincide, then put every vertex at the mean of its
  copies. O(F), no linear solve.
* :func:`least_squares_layout` - the angle-based least-squares layout of ABF++
  (Sheffer et al. 2005): every triangle's angles give
  ``p2 - p0 = sin(a1)/sin(a2) R(a0) (p1 - p0)``; these 2F equations are solved
  in the least-squares sense for all vertices at once (one sparse SPD solve).
"""

from __future__ import annotations

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np
import scipy.sparse as sp

from .. import meshops
from ..errors import MultipleComponentsError, ParameterError
from .linalg import factor_spd
from .topology import bfs_faces, half_edge_twin_slots


def centre_face(faces: np.ndarray, twin_face: np.ndarray | None = None) -> int:
    """The face farthest from the boundary in face-adjacency hops (the mesh's centre).

    Parameters
    ----------
    faces : (F, 3) int
    twin_face : (F, 3) int, optional
        Face across each edge (-1 on the boundary), see :func:`topology.half_edge_twin_slots`.

    Returns
    -------
    int
        Face index. Starting the layout there makes the breadth-first tree
        shallowest, so placement errors accumulate over the fewest steps.
    """
    f = np.asarray(faces)
    if twin_face is None:
        twin_face = half_edge_twin_slots(f)[0]
    twin_face = np.ascontiguousarray(twin_face, dtype=np.int64)
    boundary = np.nonzero((twin_face < 0).any(axis=1))[0]
    if len(boundary) == 0:
        return 0
    # multi-source BFS from every boundary face: the last face reached is the farthest
    order, _ = bfs_faces(twin_face, boundary.astype(np.int64))
    return int(order[-1])


@numba.njit(cache=True)
def _place_triangles(faces, angles, area3d, order, pred, twin_face, twin_slot, propagate):  # pragma: no cover - numba
    # Sequential by nature (each triangle is placed from its parent), hence numba.
    F = faces.shape[0]
    pos = np.zeros((F, 3, 2))
    for i in range(order.shape[0]):
        f = order[i]
        a = angles[f]
        s_area = np.sqrt(2.0 * area3d[f] / max(np.sin(a[0]) * np.sin(a[1]) * np.sin(a[2]), 1e-300))
        if i == 0:
            k = 0
            mx, my = 0.0, 0.0
            dx, dy = 1.0, 0.0
            s = s_area
        else:
            p = pred[f]
            k = -1
            for kk in range(3):
                if twin_face[f, kk] == p:
                    k = kk
            m = twin_slot[f, k]
            # parent's edge m runs b -> a, ours runs a -> b
            bx, by = pos[p, m, 0], pos[p, m, 1]
            ax, ay = pos[p, (m + 1) % 3, 0], pos[p, (m + 1) % 3, 1]
            mx, my = 0.5 * (ax + bx), 0.5 * (ay + by)
            dx, dy = bx - ax, by - ay
            L = np.sqrt(dx * dx + dy * dy)
            dx /= L
            dy /= L
            if propagate:
                s = L / np.sin(a[(k + 2) % 3])
            else:
                s = s_area
        k1 = (k + 1) % 3
        k2 = (k + 2) % 3
        lab = s * np.sin(a[k2])  # edge k -> k+1
        lac = s * np.sin(a[k1])  # edge k -> k+2
        Ax = mx - 0.5 * lab * dx
        Ay = my - 0.5 * lab * dy
        c, sn = np.cos(a[k]), np.sin(a[k])
        pos[f, k, 0] = Ax
        pos[f, k, 1] = Ay
        pos[f, k1, 0] = mx + 0.5 * lab * dx
        pos[f, k1, 1] = my + 0.5 * lab * dy
        pos[f, k2, 0] = Ax + lac * (c * dx - sn * dy)
        pos[f, k2, 1] = Ay + lac * (sn * dx + c * dy)
    return pos


def midpoint_layout(
    vertices: np.ndarray,
    faces: np.ndarray,
    angles: np.ndarray,
    *,
    sizes: str = "propagate",
    seed_face: int | None = None,
    twins: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """The paper's midpoint layout (section 2.2).

    Parameters
    ----------
    vertices : (V, 3) float
        3D positions, mm (for the triangle sizes).
    faces : (F, 3) int
        A connected manifold mesh.
    angles : (F, 3) float
        Planar corner angles, radians (each row summing to pi).
    sizes : {"propagate", "area"}
        ``"area"``: every triangle keeps its 3D area (the paper: "the geometric
        parameters of triangles remain the same") and shared edges meet at their
        midpoints; ``"propagate"``: a triangle's size is set so its shared edge
        equals the parent's copy (exact when the angles are consistent).
    seed_face : int, optional
        First triangle; default :func:`centre_face`.
    twins : (twin_face, twin_slot), optional
        The half-edge twins of ``faces`` when the caller has them
        (:func:`topology.half_edge_twin_slots` otherwise).

    Returns
    -------
    uv : (V, 2) float64
        Mean of the copies of each vertex, mm (not yet scaled or centred).
    """
    if sizes not in ("propagate", "area"):
        raise ParameterError(f"Unknown midpoint layout sizes {sizes!r}.", "Use 'propagate' or 'area'.")
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    F = len(f)
    twin_face, twin_slot = half_edge_twin_slots(f) if twins is None else twins
    seed = centre_face(f, twin_face) if seed_face is None else int(seed_face)
    if not 0 <= seed < F:
        raise ParameterError(f"seed_face {seed} is not a face index (the mesh has {F} faces).",
                             "Pass an index in [0, number of faces) or leave seed_face out.")
    order, pred = bfs_faces(twin_face, np.array([seed], dtype=np.int64))
    if len(order) < F:
        raise MultipleComponentsError("The mesh is in several pieces; the midpoint layout needs one connected patch.",
                                      "Flatten each component separately (load_surface(..., component='largest')).")
    # "propagate" needs the 3D area of the seed triangle only (it fixes the scale)
    area3d = meshops.face_areas(v, f) if sizes == "area" else np.zeros(F)
    if sizes != "area":
        area3d[seed] = meshops.face_areas(v, f[seed : seed + 1])[0]
    pos = _place_triangles(
        f, np.ascontiguousarray(angles, dtype=np.float64), area3d, order, pred, twin_face, twin_slot,
        sizes == "propagate",
    )
    nv = len(v)
    cv = f.ravel()
    cnt = np.bincount(cv, minlength=nv).astype(np.float64)
    cnt[cnt == 0] = 1.0
    P = pos.reshape(-1, 2)
    return np.stack([np.bincount(cv, weights=P[:, 0], minlength=nv), np.bincount(cv, weights=P[:, 1], minlength=nv)], axis=1) / cnt[:, None]


def least_squares_layout(
    vertices: np.ndarray,
    faces: np.ndarray,
    angles: np.ndarray,
    *,
    solver: str = "auto",
) -> np.ndarray:
    """Angle-based least-squares layout (ABF++).

    Parameters
    ----------
    vertices : (V, 3) float
        3D positions, mm (the two pinned vertices get their 3D distance).
    faces : (F, 3) int
    angles : (F, 3) float
        Planar corner angles, radians.
    solver : {"auto", "cholmod", "superlu"}

    Returns
    -------
    uv : (V, 2) float64
        mm, not yet scaled or centred. Two vertices of the centre face's first edge are pinned.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    a = np.asarray(angles, dtype=np.float64)
    nv, F = len(v), len(f)
    ratio = np.sin(a[:, 1]) / np.sin(a[:, 2])
    c, s = ratio * np.cos(a[:, 0]), ratio * np.sin(a[:, 0])
    p0, p1, p2 = f[:, 0], f[:, 1], f[:, 2]
    # unknowns: x = [u_0..u_{V-1}, v_0..v_{V-1}]
    # eq x: u2 - u0 - c (u1 - u0) + s (v1 - v0) = 0
    # eq y: v2 - v0 - s (u1 - u0) - c (v1 - v0) = 0
    r = np.arange(F)
    ry = r + F
    rows = np.concatenate([r, r, r, r, r, ry, ry, ry, ry, ry])
    cols = np.concatenate([p2, p0, p1, p1 + nv, p0 + nv, p2 + nv, p0 + nv, p1, p0, p1 + nv])
    one = np.ones(F)
    vals = np.concatenate([one, c - 1.0, -c, s, -s, one, c - 1.0, -s, s, -c])
    A = sp.csr_matrix((vals, (rows, cols)), shape=(2 * F, 2 * nv))
    seed = centre_face(f)
    i0, i1 = int(f[seed, 0]), int(f[seed, 1])
    L = float(np.linalg.norm(v[i1] - v[i0]))
    fixed = np.array([i0, i1, i0 + nv, i1 + nv])
    fixed_val = np.array([0.0, L, 0.0, 0.0])
    free = np.ones(2 * nv, dtype=bool)
    free[fixed] = False
    Af = A[:, free]
    b = -(A[:, fixed] @ fixed_val)
    solve = factor_spd((Af.T @ Af).tocsc(), solver)
    x = np.empty(2 * nv)
    x[fixed] = fixed_val
    x[free] = solve(Af.T @ b)
    return np.stack([x[:nv], x[nv:]], axis=1)
