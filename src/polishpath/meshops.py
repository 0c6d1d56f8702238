"""Mesh maths shared by every stage: angles, areas, normals, edges, boundary loops, map stretch.

The one place for these formulas (prysm's "maths in one place"). All functions
are vectorised numpy and take plain ``(V, 3)`` / ``(V, 2)`` vertex arrays and
``(F, 3)`` int face arrays.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .errors import ParameterError


def corner_angles(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Interior angle at each triangle corner.

    Parameters
    ----------
    vertices : (V, 2) or (V, 3) float
        Vertex positions, mm.
    faces : (F, 3) int
        Triangles.

    Returns
    -------
    angles : (F, 3) float64
        Angle in radians at corner ``faces[:, k]``. Computed with ``atan2`` of
        the cross and dot products, so slivers stay accurate.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    p = v[f]  # (F, 3, d)
    out = np.empty(f.shape, dtype=np.float64)
    # |a x b| is twice the triangle's area at every corner: computed once
    e1 = p[:, 1] - p[:, 0]
    e2 = p[:, 2] - p[:, 0]
    if v.shape[1] == 2:
        cr = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    else:
        cr = np.linalg.norm(np.cross(e1, e2), axis=1)
    for k in range(3):
        a = p[:, (k + 1) % 3] - p[:, k]
        b = p[:, (k + 2) % 3] - p[:, k]
        out[:, k] = np.arctan2(cr, np.einsum("ij,ij->i", a, b))
    return out


def face_areas(vertices: np.ndarray, faces: np.ndarray, signed: bool = False) -> np.ndarray:
    """Triangle areas, mm^2, shape (F,). ``signed`` only for 2D vertices (counter-clockwise positive)."""
    v = np.asarray(vertices, dtype=np.float64)
    p = v[np.asarray(faces)]
    a = p[:, 1] - p[:, 0]
    b = p[:, 2] - p[:, 0]
    if v.shape[1] == 2:
        cr = 0.5 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
        return cr if signed else np.abs(cr)
    if signed:
        raise ParameterError(f"Signed areas need 2-D (V, 2) vertices, got shape {v.shape}.",
                             "Pass signed=False for 3-D vertices (areas are then unsigned).")
    return 0.5 * np.linalg.norm(np.cross(a, b), axis=1)


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit face normals, (F, 3), following the face winding (zero for degenerate faces)."""
    p = np.asarray(vertices, dtype=np.float64)[np.asarray(faces)]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, ln, out=np.zeros_like(n), where=ln > 0)


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit vertex normals, (V, 3): corner-angle-weighted mean of the face normals."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    fn = face_normals(v, f)
    ang = corner_angles(v, f)
    vn = np.zeros_like(v)
    for k in range(3):
        np.add.at(vn, f[:, k], fn * ang[:, k : k + 1])
    ln = np.linalg.norm(vn, axis=1, keepdims=True)
    return np.divide(vn, ln, out=np.zeros_like(vn), where=ln > 0)


def directed_edges(faces: np.ndarray) -> np.ndarray:
    """Directed half-edges ``(F*3, 2)``: row ``3*f + k`` is ``faces[f, k] -> faces[f, (k+1)%3]``."""
    f = np.asarray(faces, dtype=np.int64)
    return np.stack([f, np.roll(f, -1, axis=1)], axis=2).reshape(-1, 2)


def unique_rows(a: np.ndarray):
    """Unique rows of a 2D array, much faster than ``np.unique(axis=0)``.

    Returns
    -------
    rows : (U, k) unique rows, lexicographically sorted
    index : (U,) first occurrence of each unique row in ``a``
    inverse : (n,) index into ``rows`` of each row of ``a``
    counts : (U,) occurrences of each unique row
    """
    a = np.asarray(a)
    n = len(a)
    if n == 0:
        z = np.zeros(0, dtype=np.int64)
        return a.copy(), z, z, z
    order = np.lexsort(a.T[::-1])
    sa = a[order]
    new = np.ones(n, dtype=bool)
    new[1:] = np.any(sa[1:] != sa[:-1], axis=1)
    group = np.cumsum(new) - 1
    inverse = np.empty(n, dtype=np.int64)
    inverse[order] = group
    starts = np.nonzero(new)[0]
    counts = np.diff(np.r_[starts, n])
    # first occurrence: smallest original index within each group
    index = np.full(len(starts), n, dtype=np.int64)
    np.minimum.at(index, group, order)
    return sa[starts], index, inverse, counts


def edge_face_counts(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Undirected edges and how many faces use each.

    Returns
    -------
    edges : (E, 2) int64
        Unique undirected edges, sorted vertex pair.
    counts : (E,) int64
        Number of faces sharing each edge (1: boundary, 2: interior, >2: non-manifold).
    """
    he = np.sort(directed_edges(faces), axis=1)
    edges, _, _, counts = unique_rows(he)
    return edges, counts


def boundary_edges(faces: np.ndarray) -> np.ndarray:
    """Directed boundary half-edges (B, 2), oriented as in their face."""
    he = directed_edges(faces)
    if len(he) == 0:
        return he
    # one int64 key per undirected edge: a 1-D sort, several times faster than unique_rows
    n = np.int64(he.max()) + 1
    key = np.minimum(he[:, 0], he[:, 1]).astype(np.int64) * n + np.maximum(he[:, 0], he[:, 1])
    _, inv, counts = np.unique(key, return_inverse=True, return_counts=True)
    return he[counts[inv] == 1]


def boundary_loops(faces: np.ndarray) -> list[np.ndarray]:
    """Boundary loops of a manifold-with-boundary mesh, longest first.

    Each loop is an int64 array of vertex indices, ordered along the face
    winding (counter-clockwise seen from the normal side for the outer loop of
    a disc), not repeated at the end. Assumes every boundary vertex has one
    outgoing boundary half-edge (checked by the surface validation).
    """
    be = boundary_edges(faces)
    if len(be) == 0:
        return []
    nxt = {int(a): int(b) for a, b in be}
    seen: set[int] = set()
    loops = []
    for start in be[:, 0]:
        start = int(start)
        if start in seen:
            continue
        loop = [start]
        seen.add(start)
        cur = nxt[start]
        guard = 0
        while cur != start and guard <= len(be):
            if cur in seen:  # figure-eight boundary; stop this walk
                break
            loop.append(cur)
            seen.add(cur)
            cur = nxt.get(cur, start)
            guard += 1
        loops.append(np.array(loop, dtype=np.int64))
    loops.sort(key=len, reverse=True)
    return loops


def boundary_vertex_mask(n_vertices: int, faces: np.ndarray) -> np.ndarray:
    """Boolean (V,) mask, True on boundary vertices."""
    mask = np.zeros(n_vertices, dtype=bool)
    be = boundary_edges(faces)
    mask[be.ravel()] = True
    return mask


def vertex_face_incidence(n_vertices: int, faces: np.ndarray) -> sp.csr_matrix:
    """Sparse (V, F) incidence matrix, 1 where vertex v is a corner of face f."""
    f = np.asarray(faces, dtype=np.int64)
    rows = f.ravel()
    cols = np.repeat(np.arange(len(f)), 3)
    return sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n_vertices, len(f)))


def face_adjacency(faces: np.ndarray) -> np.ndarray:
    """Pairs of faces sharing an edge, (P, 2) int64 (manifold edges only)."""
    f = np.asarray(faces, dtype=np.int64)
    he = np.sort(directed_edges(f), axis=1)
    fid = np.repeat(np.arange(len(f)), 3)
    order = np.lexsort((he[:, 1], he[:, 0]))
    he, fid = he[order], fid[order]
    same = np.all(he[1:] == he[:-1], axis=1)
    return np.stack([fid[:-1][same], fid[1:][same]], axis=1)


def connected_components(faces: np.ndarray) -> np.ndarray:
    """Component label of each face (faces connected through shared edges), (F,) int64."""
    from scipy.sparse.csgraph import connected_components as cc

    f = np.asarray(faces)
    adj = face_adjacency(f)
    n = len(f)
    g = sp.coo_matrix((np.ones(len(adj)), (adj[:, 0], adj[:, 1])), shape=(n, n))
    _, labels = cc(g, directed=False)
    return labels.astype(np.int64)


def surface_area(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Total area, mm^2."""
    return float(face_areas(vertices, faces).sum())


def jacobian_singular_values(src: np.ndarray, dst: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Singular values of the per-triangle linear map that carries a mesh from ``src`` to ``dst``.

    On each triangle the map is the linear ``J`` with ``J (s1 - s0, s2 - s0) =
    (d1 - d0, d2 - d0)``; its singular values are the largest and smallest
    factor by which it stretches a length in the triangle. A 3D source
    triangle is first laid in its own plane (an orthonormal frame along its
    first edge), so ``src`` and ``dst`` may each be the part (3D) or the plane
    (2D): ``jacobian_singular_values(uv, xyz, f)`` is the plane -> part
    stretch, ``jacobian_singular_values(xyz, uv, f)`` the part -> plane one.

    Parameters
    ----------
    src : (V, 2) or (V, 3) float
        Vertex positions the map starts from, mm.
    dst : (V, 2) or (V, 3) float
        Vertex positions it carries them to, mm (same indexing).
    faces : (F, 3) int
        Triangles.

    Returns
    -------
    (F, 2) float64
        ``sigma1 >= sigma2 >= 0`` per triangle (dimensionless); ``inf`` for
        triangles of zero area in ``src``.
    """
    f = np.asarray(faces)
    ps = np.asarray(src, dtype=np.float64)[f]
    pd = np.asarray(dst, dtype=np.float64)[f]
    es = np.stack([ps[:, 1] - ps[:, 0], ps[:, 2] - ps[:, 0]], axis=2)  # (F, ds, 2) columns = edges
    if es.shape[1] == 3:
        # coordinates of the two edges in the triangle's own orthonormal frame (x along the first edge)
        e1, e2 = es[:, :, 0], es[:, :, 1]
        l1 = np.linalg.norm(e1, axis=1)
        x = e1 / np.where(l1 > 0, l1, 1.0)[:, None]
        y = np.cross(np.cross(e1, e2), e1)
        ly = np.linalg.norm(y, axis=1)
        y = y / np.where(ly > 0, ly, 1.0)[:, None]
        es = np.stack([np.stack([l1, np.zeros_like(l1)], 1), np.stack([(e2 * x).sum(1), (e2 * y).sum(1)], 1)], axis=2)
    elif es.shape[1] != 2:
        raise ParameterError(f"src must be (V, 2) or (V, 3) vertex positions in mm, got shape {np.asarray(src).shape}.")
    ed = np.stack([pd[:, 1] - pd[:, 0], pd[:, 2] - pd[:, 0]], axis=2)  # (F, dd, 2)
    det = es[:, 0, 0] * es[:, 1, 1] - es[:, 0, 1] * es[:, 1, 0]
    ok = np.abs(det) > 1e-300
    d = np.where(ok, det, 1.0)
    inv = np.empty_like(es)
    inv[:, 0, 0] = es[:, 1, 1] / d
    inv[:, 1, 1] = es[:, 0, 0] / d
    inv[:, 0, 1] = -es[:, 0, 1] / d
    inv[:, 1, 0] = -es[:, 1, 0] / d
    sv = np.linalg.svd(ed @ inv, compute_uv=False)
    sv[~ok] = np.inf
    return sv
