"""Checking and repairing a triangle mesh on its way in.

What cannot be repaired safely is refused with a specific error naming the
problem, how many and where, and what to do: NaN / infinite coordinates,
non-manifold edges or vertices, several components (unless the caller asks for
the largest), a closed mesh. What can be repaired is repaired and reported as a
:class:`~polishpath.types.Finding`: duplicate vertices (merged), unreferenced
vertices (dropped), zero-area faces (collapsed), duplicate faces (dropped),
inconsistent orientation (faces flipped to agree). Slivers are reported.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .. import meshops
from ..errors import (
    ClosedMeshError,
    DegenerateMeshError,
    MeshError,
    MultipleComponentsError,
    NonFiniteError,
    NonManifoldError,
    ParameterError,
)
from ..types import Finding

SLIVER_ANGLE_DEG = 1.0
MERGE_TOLERANCE = 1e-6  # relative to the median edge length (not the box: one far vertex must not merge the rest)
ZERO_AREA = 1e-10  # face area relative to the squared median edge length
#: an edge this many times the median edge length means a corrupt coordinate, not a part
OUTLIER_EDGE_RATIO = 1e5


def _fmt_pts(p: np.ndarray, k: int = 3) -> str:
    return ", ".join("(" + ", ".join(f"{c:.4g}" for c in row) + ")" for row in np.asarray(p)[:k])


def _compact(vertices, faces):
    used = np.zeros(len(vertices), dtype=bool)
    used[faces.ravel()] = True
    remap = -np.ones(len(vertices), dtype=np.int64)
    remap[used] = np.arange(int(used.sum()))
    return vertices[used], remap[faces], int((~used).sum())


def _merge_vertices_safely(vertices, faces, tol):
    """Merge vertices closer than ``tol``, but not where that creates non-manifold geometry.

    Returns
    -------
    vertices, faces, n_merged, n_kept_apart
    """
    key = np.round(vertices / tol).astype(np.int64) if tol > 0 else vertices
    _, first, inv, _ = meshops.unique_rows(key)
    if len(first) == len(vertices):
        return vertices, faces, 0, 0
    merged_faces = inv[faces]
    counts = np.bincount(inv, minlength=len(first))
    # new vertices that join several old ones and end up non-manifold
    nv = len(first)
    bad = np.zeros(nv, dtype=bool)
    fr = merged_faces[(merged_faces[:, 0] != merged_faces[:, 1]) & (merged_faces[:, 1] != merged_faces[:, 2])
                      & (merged_faces[:, 0] != merged_faces[:, 2])]
    edges, ecount = meshops.edge_face_counts(fr)
    bad[edges[ecount > 2].ravel()] = True
    bad |= _vertex_fan_counts(nv, fr) > 1
    bad &= counts > 1
    if bad.any():
        # keep the original (unmerged) vertex for every old vertex mapping to a bad one
        old_bad = bad[inv]
        new_index = inv.copy()
        extra = np.nonzero(old_bad)[0]
        new_index[extra] = nv + np.arange(len(extra))
        # drop only the merged slots that no face uses any more
        keep = np.r_[~bad, np.ones(len(extra), dtype=bool)]
        remap = np.cumsum(keep) - 1
        verts = np.vstack([vertices[first], vertices[extra]])[keep]
        faces_out = remap[new_index[faces]]
        n_kept = int(old_bad.sum())
    else:
        verts, faces_out, n_kept = vertices[first], merged_faces, 0
    n_merged = len(vertices) - len(verts)
    return verts, faces_out, int(n_merged), n_kept


def _edge_scale(v: np.ndarray, f: np.ndarray) -> float:
    """Median length of the mesh's non-zero edges, mm (1.0 when every edge has zero length)."""
    e = np.concatenate([np.linalg.norm(v[f[:, (k + 1) % 3]] - v[f[:, k]], axis=1) for k in range(3)])
    e = e[e > 0]
    return float(np.median(e)) if len(e) else 1.0


def _refuse_outliers(v: np.ndarray, f: np.ndarray, scale: float, name: str) -> None:
    """Refuse vertices whose every edge is enormous next to the median edge (a corrupt coordinate)."""
    e = np.stack([np.linalg.norm(v[f[:, (k + 1) % 3]] - v[f[:, k]], axis=1) for k in range(3)], axis=1)
    long = e > OUTLIER_EDGE_RATIO * scale
    if not long.any():
        return
    n = len(v)
    touched = np.zeros(n, bool)
    short_at = np.zeros(n, bool)
    for k in range(3):
        for a in (f[:, k], f[:, (k + 1) % 3]):
            touched[a[long[:, k]]] = True
            short_at[a[~long[:, k]]] = True
    far = np.nonzero(touched & ~short_at)[0]
    if len(far) == 0:  # long edges between ordinary vertices: a long sliver, not a stray coordinate
        return
    raise MeshError(
        f"{name} has {len(far)} vertices far from every neighbour (edges up to {e.max():.4g} mm where the median "
        f"edge is {scale:.4g} mm), e.g. vertex {far[0]} at {_fmt_pts(v[far])} mm: a corrupt coordinate.",
        "Fix or remove that vertex in the exporting program or a mesh editor.",
    )


def _orient_consistently(faces: np.ndarray) -> tuple[np.ndarray, int]:
    """Flip faces so that every interior edge is traversed in opposite directions.

    Breadth-first over the face adjacency from face 0 of each component; a
    face's orientation is forced by its already-oriented neighbour. Raises
    :class:`MeshError` for a non-orientable surface.
    """
    nf = len(faces)
    he = meshops.directed_edges(faces)
    fid = np.repeat(np.arange(nf), 3)
    key = np.sort(he, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    ks, hs, fs = key[order], he[order], fid[order]
    same = np.all(ks[1:] == ks[:-1], axis=1)
    i = np.nonzero(same)[0]
    f1, f2 = fs[i], fs[i + 1]
    # same direction on both sides -> the two faces disagree
    disagree = np.all(hs[i] == hs[i + 1], axis=1)
    if not disagree.any():
        return faces, 0
    # parity propagation: flip[f2] = flip[f1] xor disagree
    g = sp.coo_matrix((np.ones(len(f1)), (f1, f2)), shape=(nf, nf)).tocsr()
    g = g + g.T
    w = {}
    for a, b, d in zip(f1.tolist(), f2.tolist(), disagree.tolist()):
        w[(a, b)] = d
        w[(b, a)] = d
    flip = -np.ones(nf, dtype=np.int8)
    indptr, indices = g.indptr, g.indices
    for root in range(nf):
        if flip[root] >= 0:
            continue
        flip[root] = 0
        stack = [root]
        while stack:
            a = stack.pop()
            for b in indices[indptr[a] : indptr[a + 1]]:
                want = flip[a] ^ int(w[(a, b)])
                if flip[b] < 0:
                    flip[b] = want
                    stack.append(int(b))
                elif flip[b] != want:
                    raise MeshError(
                        "the surface is not orientable (like a Moebius strip): its faces cannot all be given one side.",
                        "polishpath needs a two-sided patch; check the mesh in a mesh editor.",
                    )
    # keep the majority orientation
    if (flip == 1).sum() > nf / 2:
        flip = 1 - flip
    out = faces.copy()
    m = flip == 1
    out[m] = out[m][:, ::-1]
    return out, int(m.sum())


def _vertex_fan_counts(n_vertices: int, faces: np.ndarray) -> np.ndarray:
    """Number of separate face fans around each vertex (1 for a manifold vertex)."""
    nf = len(faces)
    corner_v = faces.ravel()  # corner c = 3 f + k
    he = meshops.directed_edges(faces)
    key = np.sort(he, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    ks = key[order]
    same = np.nonzero(np.all(ks[1:] == ks[:-1], axis=1))[0]
    ha, hb = order[same], order[same + 1]  # half-edge ids of the two sides
    fa, fb = ha // 3, hb // 3
    rows, cols = [], []
    for v_col in (0, 1):
        v = key[ha, v_col]
        # corner of vertex v in face fa and in face fb
        ca = 3 * fa + np.argmax(faces[fa] == v[:, None], axis=1)
        cb = 3 * fb + np.argmax(faces[fb] == v[:, None], axis=1)
        rows.append(ca)
        cols.append(cb)
    rows = np.concatenate(rows)
    cols = np.concatenate(cols)
    n = 3 * nf
    g = sp.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    pairs, _, _, _ = meshops.unique_rows(np.c_[corner_v, lab])
    return np.bincount(pairs[:, 0], minlength=n_vertices)


def validate_mesh(
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    component: str = "refuse",
    allow_closed: bool = False,
    name: str = "mesh",
) -> tuple[np.ndarray, np.ndarray, tuple[Finding, ...]]:
    """Check a mesh, repair what is safe to repair, refuse the rest.

    Parameters
    ----------
    vertices : (V, 3) float
        Vertex positions, mm.
    faces : (F, 3) int
        Triangles.
    component : {"refuse", "largest"}
        What to do with a mesh of several connected pieces.
    allow_closed : bool
        Accept a mesh without boundary (only for ``info``-like inspection).
    name : str
        Name used in messages.

    Returns
    -------
    vertices : (V', 3) float64
    faces : (F', 3) int64
    findings : tuple of Finding
        What was found and repaired.

    Raises
    ------
    NonFiniteError, NonManifoldError, MultipleComponentsError, ClosedMeshError,
    DegenerateMeshError, MeshError
    """
    if component not in ("refuse", "largest"):
        raise ParameterError(f"component must be 'refuse' or 'largest', got {component!r}.")
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    findings: list[Finding] = []
    if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0:
        raise DegenerateMeshError(f"{name} has no vertices (or they are not 3D points).", "Check the file.")
    if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
        raise DegenerateMeshError(f"{name} has no triangles.", "Check the file: polishpath needs a triangle mesh.")
    if not np.issubdtype(f.dtype, np.integer):
        raise MeshError(f"{name}: face indices are not integers.")
    f = f.astype(np.int64)
    if f.min() < 0 or f.max() >= len(v):
        raise MeshError(
            f"{name}: faces refer to vertex indices outside 0..{len(v) - 1} (found {f.min()}..{f.max()}).",
            "The file is corrupt or truncated.",
        )
    bad = ~np.all(np.isfinite(v), axis=1)
    if bad.any():
        idx = np.nonzero(bad)[0]
        raise NonFiniteError(
            f"{name} has {len(idx)} vertices with NaN or infinite coordinates (first at index {idx[0]}).",
            "Fix or remove them in the exporting program; polishpath will not guess positions.",
        )
    # 0. the length scale of the mesh: its median edge (the bounding box would
    #    let one far-off vertex set the tolerance for all the others)
    scale = _edge_scale(v, f)
    _refuse_outliers(v, f, scale, name)
    # 1. duplicate vertices: merge, except where the merge would join two sheets
    #    that only touch (a bow-tie or a non-manifold seam): those stay apart
    tol = max(MERGE_TOLERANCE * scale, 4.0 * np.finfo(np.float64).eps * float(np.abs(v).max()))
    v, f, n_dup, n_kept = _merge_vertices_safely(v, f, tol)
    if n_dup:
        findings.append(Finding("duplicate_vertices", f"merged {n_dup} duplicate vertices", n_dup, True, "warning"))
    if n_kept:
        findings.append(Finding("touching_vertices", f"kept {n_kept} coincident vertices apart (merging them would make the mesh non-manifold)", n_kept, False, "info"))

    # 2. degenerate faces: repeated indices, then zero area (collapse shortest edge)
    n_degen = 0
    for _ in range(10):
        rep = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])
        if rep.any():
            n_degen += int(rep.sum())
            f = f[~rep]
        if len(f) == 0:
            break
        area = meshops.face_areas(v, f)
        zero = area <= ZERO_AREA * scale * scale
        if not zero.any():
            break
        p = v[f[zero]]
        el = np.stack([np.linalg.norm(p[:, (k + 1) % 3] - p[:, k], axis=1) for k in range(3)], axis=1)
        k = np.argmin(el, axis=1)
        a = f[zero][np.arange(len(k)), k]
        b = f[zero][np.arange(len(k)), (k + 1) % 3]
        # collapse b onto a (one collapse per vertex per round)
        target = np.arange(len(v))
        _, first = np.unique(b, return_index=True)
        target[b[first]] = a[first]
        # resolve chains
        for _ in range(5):
            target = target[target]
        f = target[f]
    if n_degen:
        findings.append(Finding("degenerate_faces", f"removed {n_degen} zero-area faces (collapsed their shortest edge)", n_degen, True, "warning"))
    if len(f) == 0:
        raise DegenerateMeshError(f"{name}: every face has zero area.", "Check the file's units and content.")

    # duplicate faces (same vertex set)
    _, keep, _, _ = meshops.unique_rows(np.sort(f, axis=1))
    n_dupf = len(f) - len(keep)
    if n_dupf:
        f = f[np.sort(keep)]
        findings.append(Finding("duplicate_faces", f"removed {n_dupf} duplicate faces", n_dupf, True, "warning"))

    # 3. unreferenced vertices
    v, f, n_unref = _compact(v, f)
    if n_unref:
        findings.append(Finding("unreferenced_vertices", f"dropped {n_unref} unreferenced vertices", n_unref, True, "warning"))

    # 4. non-manifold edges
    edges, counts = meshops.edge_face_counts(f)
    nm = counts > 2
    if nm.any():
        where = v[edges[nm]].mean(axis=1)
        raise NonManifoldError(
            f"{name} has {int(nm.sum())} non-manifold edges (shared by more than two faces), e.g. at {_fmt_pts(where)} mm.",
            "Separate or remove the extra faces in a mesh editor (e.g. MeshLab: Select non-manifold edges, then delete).",
        )

    # 4b. non-manifold vertices (bow-ties)
    fans = _vertex_fan_counts(len(v), f)
    bow = fans > 1
    if bow.any():
        raise NonManifoldError(
            f"{name} has {int(bow.sum())} non-manifold vertices (two or more face fans meet at one point), "
            f"e.g. at {_fmt_pts(v[bow])} mm.",
            "Split those vertices or remove the touching faces in a mesh editor.",
        )

    # 5. components
    labels = meshops.connected_components(f)
    ncomp = int(labels.max()) + 1
    if ncomp > 1:
        sizes = np.bincount(labels)
        if component == "refuse":
            raise MultipleComponentsError(
                f"{name} has {ncomp} separate pieces (face counts {', '.join(map(str, sorted(sizes, reverse=True)[:5]))}"
                f"{', ...' if ncomp > 5 else ''}).",
                "Plan each piece separately, or pass --component largest to keep the largest piece.",
            )
        big = int(np.argmax(sizes))
        f = f[labels == big]
        v, f, _ = _compact(v, f)
        findings.append(Finding("components", f"kept the largest of {ncomp} pieces ({sizes[big]} faces)", ncomp - 1, True, "warning"))

    # 6. orientation
    f, n_flip = _orient_consistently(f)
    if n_flip:
        findings.append(Finding("orientation", f"flipped {n_flip} faces to a consistent orientation", n_flip, True, "warning"))

    # 8. boundary
    loops = meshops.boundary_loops(f)
    if not loops and not allow_closed:
        raise ClosedMeshError(
            f"{name} is closed (it has no boundary edge): the method flattens an open patch.",
            "Cut the part's surface to polish out of the closed mesh (e.g. select the optical face in a mesh editor) and save it alone.",
        )

    # 9. slivers (reported)
    ang = np.degrees(meshops.corner_angles(v, f))
    sl = ang.min(axis=1) < SLIVER_ANGLE_DEG
    if sl.any():
        findings.append(
            Finding(
                "slivers",
                f"{int(sl.sum())} sliver faces with an angle under {SLIVER_ANGLE_DEG:g} degrees (smallest {ang.min():.3g} degrees); kept",
                int(sl.sum()),
                False,
                "info",
            )
        )
    return v, f, tuple(findings)
