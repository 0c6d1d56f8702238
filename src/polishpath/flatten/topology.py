"""Mesh topology the flattening methods share: checks, corner tables, hole filling.

A *corner* is one (face, k) slot, flattened to ``c = 3 * f + k``; all angle
vectors in this subpackage are indexed by corner (the paper's Eq. 2 order).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np
import scipy.sparse as sp

from .. import meshops
from ..errors import (
    ClosedMeshError,
    DegenerateMeshError,
    MultipleComponentsError,
    NonFiniteError,
    NonManifoldError,
)


@dataclass(frozen=True)
class DiscTopology:
    """What :func:`disc_topology` finds out about a valid disc mesh (with holes), kept so
    the later stages (corner tables, layout, metrics) do not find it again.

    Attributes
    ----------
    loops : list of (n,) int64
        Boundary loops, longest first (as :func:`polishpath.meshops.boundary_loops`).
    twin_face, twin_slot : (F, 3) int64
        Face and local edge index across each half-edge, -1 on the boundary
        (as :func:`half_edge_twin_slots`).
    boundary_edges : (B, 2) int64
        Boundary half-edges in half-edge order (as :func:`polishpath.meshops.boundary_edges`).
    boundary_mask : (V,) bool
        True on boundary vertices.
    """

    loops: list
    twin_face: np.ndarray
    twin_slot: np.ndarray
    boundary_edges: np.ndarray
    boundary_mask: np.ndarray


def check_disc_mesh(vertices: np.ndarray, faces: np.ndarray) -> list[np.ndarray]:
    """Refuse meshes no flattening can handle; return the boundary loops.

    Parameters
    ----------
    vertices : (V, 3) float
        Vertex positions, mm.
    faces : (F, 3) int
        Triangles.

    Returns
    -------
    loops : list of (n,) int64
        Boundary loops, longest first (the outer boundary of a disc first).

    Raises
    ------
    NonFiniteError, DegenerateMeshError, NonManifoldError, ClosedMeshError,
    MultipleComponentsError
        With a message saying what is wrong and what to do.
    """
    return disc_topology(vertices, faces).loops


def disc_topology(vertices: np.ndarray, faces: np.ndarray) -> DiscTopology:
    """:func:`check_disc_mesh`, returning the half-edge structure it builds as well.

    One sort of the undirected edge keys gives the edge counts (non-manifold edges),
    the pairs of half-edges (orientation, twins), the boundary and the edge count for
    the Euler characteristic (before: four ``np.unique`` calls and a second sort).

    Returns
    -------
    DiscTopology

    Raises
    ------
    NonFiniteError, DegenerateMeshError, NonManifoldError, ClosedMeshError,
    MultipleComponentsError
        As :func:`check_disc_mesh`.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if len(f) == 0:
        raise DegenerateMeshError("The mesh has no triangles.", "Give a surface with at least one face.")
    if not np.all(np.isfinite(v)):
        raise NonFiniteError(
            f"{int((~np.isfinite(v)).any(axis=1).sum())} vertices have NaN or infinite coordinates.",
            "Repair or remove them before flattening.",
        )
    if f.min() < 0 or f.max() >= len(v):
        raise DegenerateMeshError("Face indices point outside the vertex array.", "Check the mesh file.")
    if np.any((f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 2] == f[:, 0])):
        raise DegenerateMeshError(
            "Some faces repeat a vertex (zero-area triangles).",
            "Load the mesh with polishpath.surfaces.load_surface, which removes them.",
        )
    F = len(f)
    nv = np.int64(len(v))
    a = f.ravel()
    b = np.roll(f, -1, axis=1).ravel()
    ukey = np.minimum(a, b) * nv + np.maximum(a, b)
    order = np.argsort(ukey)
    sk = ukey[order]
    new = np.empty(len(sk), dtype=bool)
    new[0] = True
    np.not_equal(sk[1:], sk[:-1], out=new[1:])
    starts = np.flatnonzero(new)
    counts = np.diff(np.append(starts, len(sk)))
    if np.any(counts > 2):
        raise NonManifoldError(
            f"{int((counts > 2).sum())} edges are shared by more than two faces; a flattening needs a manifold patch.",
            "Repair the mesh (remove the extra faces) or cut it into manifold pieces.",
        )
    # every edge now has one or two half-edges; two must run in opposite directions
    i = starts[counts == 2]
    h1, h2 = order[i], order[i + 1]
    same = a[h1] == a[h2]
    if np.any(same):
        raise NonManifoldError(
            f"{int(same.sum())} edges are traversed twice in the same direction: the faces are not consistently oriented.",
            "Fix the winding (trimesh.repair.fix_winding) or load the mesh with polishpath.surfaces.load_surface.",
        )
    he = np.full(3 * F, -1, dtype=np.int64)
    he[h1] = h2
    he[h2] = h1
    twin_face = np.where(he >= 0, he // 3, -1).reshape(F, 3)
    twin_slot = np.where(he >= 0, he % 3, -1).reshape(F, 3)
    reached = len(bfs_faces(twin_face, np.zeros(1, dtype=np.int64))[0])
    if reached < F:
        from scipy.sparse.csgraph import connected_components

        src = np.repeat(np.arange(F), 3)
        m = he >= 0
        g = sp.csr_matrix((np.ones(int(m.sum())), (src[m], twin_face.ravel()[m])), shape=(F, F))
        n_comp = int(connected_components(g, directed=False)[0])
        raise MultipleComponentsError(
            f"The mesh has {n_comp} disconnected pieces; a flattening maps one piece.",
            "Flatten each piece separately (trimesh split) or keep the largest.",
        )
    loops = meshops.boundary_loops(f)
    if not loops:
        raise ClosedMeshError(
            "The mesh is closed (it has no boundary), so it cannot be flattened without cuts.",
            "Cut it open along a seam, or give only the patch to be polished.",
        )
    bhe = np.flatnonzero(he < 0)
    if sum(len(lp) for lp in loops) != len(bhe):
        raise NonManifoldError(
            "A boundary vertex is shared by two boundary loops (a pinched, non-manifold vertex).",
            "Repair the mesh so every vertex fan is one disc.",
        )
    # Euler characteristic of a disc with h holes: V - E + F = 2 - (h + 1) ... = 1 - h
    n_used = int(np.count_nonzero(np.bincount(a, minlength=len(v))))
    chi = n_used - len(starts) + F
    if chi != 2 - len(loops):
        raise NonManifoldError(
            f"The mesh has Euler characteristic {chi} with {len(loops)} boundary loop(s): it has handles (genus > 0), "
            "so it is not a disc with holes.",
            "Cut the handles open before flattening.",
        )
    be = np.stack([a[bhe], b[bhe]], axis=1)
    mask = np.zeros(len(v), dtype=bool)
    mask[be.ravel()] = True
    return DiscTopology(loops, twin_face, twin_slot, be, mask)


@numba.njit(cache=True)
def bfs_faces(twin_face, sources):  # pragma: no cover - numba
    """Breadth-first order over face adjacency from one or several sources, with each
    face's parent (-1 for a source): ``(order, pred)``, int64 arrays. A plain queue in
    numba: ~10x faster than building a scipy graph for
    ``scipy.sparse.csgraph.breadth_first_order``."""
    F = twin_face.shape[0]
    pred = np.full(F, -2, np.int64)
    order = np.empty(F, np.int64)
    tail = 0
    for s in sources:
        if pred[s] == -2:
            pred[s] = -1
            order[tail] = s
            tail += 1
    head = 0
    while head < tail:
        f = order[head]
        head += 1
        for k in range(3):
            g = twin_face[f, k]
            if g >= 0 and pred[g] == -2:
                pred[g] = f
                order[tail] = g
                tail += 1
    return order[:tail], pred


@dataclass(frozen=True)
class CornerTables:
    """Index tables over corners ``c = 3 f + k`` for a mesh.

    Attributes
    ----------
    faces : (F, 3) int64
    corner_vertex : (3F,) int64
        Vertex of each corner.
    interior : (V,) bool
        True on interior (non-boundary) vertices.
    interior_index : (V,) int64
        Row of each interior vertex in the vertex / wheel constraints, -1 elsewhere.
    n_interior : int
    """

    faces: np.ndarray
    corner_vertex: np.ndarray
    interior: np.ndarray
    interior_index: np.ndarray
    n_interior: int

    @property
    def n_faces(self) -> int:
        return int(len(self.faces))


def corner_tables(n_vertices: int, faces: np.ndarray, boundary_mask: np.ndarray | None = None) -> CornerTables:
    """Build the :class:`CornerTables` of a mesh (vectorised, no loops over faces).

    ``boundary_mask`` (V,) bool: the boundary vertices when the caller knows them
    (see :class:`DiscTopology`), else found from ``faces``."""
    f = np.asarray(faces, dtype=np.int64)
    cv = f.ravel()
    if boundary_mask is None:
        boundary_mask = meshops.boundary_vertex_mask(n_vertices, f)
    interior = ~np.asarray(boundary_mask, dtype=bool)
    used = np.zeros(n_vertices, dtype=bool)
    used[cv] = True
    interior &= used
    idx = np.full(n_vertices, -1, dtype=np.int64)
    idx[interior] = np.arange(int(interior.sum()))
    return CornerTables(f, cv, interior, idx, int(interior.sum()))


def vertex_sum_matrix(t: CornerTables) -> sp.csr_matrix:
    """B of the paper's Eq. 1: (Vi, 3F), 1 where the corner sits at the interior vertex of that row."""
    rows = t.interior_index[t.corner_vertex]
    m = rows >= 0
    cols = np.nonzero(m)[0]
    return sp.csr_matrix((np.ones(len(cols)), (rows[m], cols)), shape=(t.n_interior, 3 * t.n_faces))


def wheel_pattern(t: CornerTables) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sparsity of C in the paper's Eq. 1 (the sine-law wheel condition).

    For corner ``(f, k)`` at interior vertex v, the opposite-side angles are the
    next corner ``(f, k+1)`` (sign +1) and the previous corner ``(f, k+2)`` (sign -1):
    ``sum(+ln sin) - sum(ln sin) = 0`` around v.

    Returns
    -------
    rows, cols : (n,) int64
        Interior-vertex row and corner column of each entry.
    signs : (n,) float64
        +1 or -1.
    """
    F = t.n_faces
    rows_all = t.interior_index[t.corner_vertex]
    m = rows_all >= 0
    c = np.nonzero(m)[0]
    f, k = c // 3, c % 3
    nxt = 3 * f + (k + 1) % 3
    prv = 3 * f + (k + 2) % 3
    rows = np.concatenate([rows_all[m], rows_all[m]])
    cols = np.concatenate([nxt, prv])
    signs = np.concatenate([np.ones(len(c)), -np.ones(len(c))])
    del F
    return rows, cols, signs


def fill_holes(vertices: np.ndarray, faces: np.ndarray, loops: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, int]:
    """Close every hole (all boundary loops but the outer) with a fan around a virtual centre vertex.

    Why: the angle constraints of ABF / MABF only hold at interior vertices, so
    around a hole nothing forces the development to close up; the solved angles
    would carry the curvature enclosed by the hole and the layout would tear.
    Filling the hole makes its rim interior (closure is then implied by the
    vertex and wheel conditions); the virtual faces get a small weight and are
    dropped after the solve.

    Parameters
    ----------
    vertices : (V, 3) float
    faces : (F, 3) int
    loops : list of (n,) int
        Boundary loops; the one with the largest 3D enclosed extent is kept as the outer boundary.

    Returns
    -------
    vertices : (V + H, 3) float64
    faces : (F + sum(n_h), 3) int64
        Original faces first, then the fan faces.
    n_virtual_faces : int
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if len(loops) <= 1:
        return v, f, 0
    outer = outer_loop_index(v, loops)
    new_v = [v]
    new_f = [f]
    nv = len(v)
    nvf = 0
    for i, lp in enumerate(loops):
        if i == outer:
            continue
        centre = v[lp].mean(axis=0)
        new_v.append(centre[None])
        # boundary loops run along the face winding; the fan must run the other way
        a = lp
        b = np.roll(lp, -1)
        fan = np.stack([b, a, np.full(len(lp), nv)], axis=1)
        new_f.append(fan)
        nvf += len(lp)
        nv += 1
    return np.vstack(new_v), np.vstack(new_f), nvf


def outer_loop_index(vertices: np.ndarray, loops: list[np.ndarray]) -> int:
    """Index of the loop taken as the outer boundary in 3D: the longest one (perimeter, mm)."""
    v = np.asarray(vertices)
    per = [float(np.linalg.norm(v[lp] - v[np.roll(lp, -1)], axis=1).sum()) for lp in loops]
    return int(np.argmax(per))


def half_edge_twins(faces: np.ndarray) -> np.ndarray:
    """Face across each edge: ``(F, 3)`` int64, entry ``[f, k]`` is the face sharing edge
    ``faces[f, k] -> faces[f, (k+1) % 3]``, or -1 on the boundary. Also returns nothing else;
    the twin's local edge index is found by :func:`half_edge_twin_slots`."""
    return half_edge_twin_slots(faces)[0]


def half_edge_twin_slots(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Face and local edge index across each half-edge.

    Returns
    -------
    twin_face : (F, 3) int64
        Face across edge k of face f, -1 on the boundary.
    twin_slot : (F, 3) int64
        Local edge index of the same edge in ``twin_face``, -1 on the boundary.
    """
    f = np.asarray(faces, dtype=np.int64)
    F = len(f)
    a = f.ravel()
    b = np.roll(f, -1, axis=1).ravel()
    n = int(f.max()) + 1
    # one sort of the undirected edge keys puts the two half-edges of an edge side
    # by side (about 2x faster than a sort plus a binary search for every reverse key)
    ukey = np.minimum(a, b) * n + np.maximum(a, b)
    order = np.argsort(ukey, kind="stable")
    sk = ukey[order]
    i = np.nonzero(sk[1:] == sk[:-1])[0]
    h1, h2 = order[i], order[i + 1]
    ok = a[h1] == b[h2]  # opposite directions only (a consistently oriented pair)
    he = np.full(3 * F, -1, dtype=np.int64)
    he[h1[ok]] = h2[ok]
    he[h2[ok]] = h1[ok]
    twin_face = np.where(he >= 0, he // 3, -1).reshape(F, 3)
    twin_slot = np.where(he >= 0, he % 3, -1).reshape(F, 3)
    return twin_face, twin_slot
