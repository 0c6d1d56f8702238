"""Making CAD tessellations fit for flattening, without moving the surface.

CAD exporters tessellate for display: a cylinder patch comes out as a few
hundred full-length strips whose triangles are 300:1 slivers with 0.2 degree
corners. Angle-based flattening (MABF, ABF) cannot lay such corners out: the
300-strip cylinder flattens to 16 x 59 mm instead of 30 x 30 mm, while its
mean angle error reads a harmless 0.36 degrees.

:func:`refine_exact` re-triangulates such a mesh so that the piecewise-linear
surface stays exactly the same: coplanar neighbouring triangles are merged
into planar facets (a CAD strip is a planar quad), every edge between facets
is split into equal pieces no longer than the target edge, and each facet is
re-triangulated in its own plane by Shewchuk's Triangle (quality Delaunay, no
new points on the facet's edges, so neighbouring facets stay conforming).
New vertices lie on the old edges or inside the old planar facets; the area
and the boundary are unchanged to rounding.

Why by hand: the well-kept remeshers (isotropic remeshing in MeshLab, CGAL,
gpytoolbox) move vertices and project them back, which changes the surface
between the old vertices; the polishing path must follow the part's surface
as given, so only this exact split-and-retriangulate is the project's own.

:func:`fit_for_flattening` decides (``--remesh auto``): it refines only a
mesh whose sliver triangles (a corner under :data:`SLIVER_DEG`) cover more
than :data:`SLIVER_AREA_SHARE` of the area, so the meshes polishpath makes
itself (30 degree minimum angle) and ordinary scans are left as they are.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .. import meshops
from ..errors import ParameterError
from ..types import Finding, Surface

#: a triangle with a corner under this many degrees is a sliver
SLIVER_DEG = 2.0
#: ``auto`` refines when slivers cover more than this share of the area
SLIVER_AREA_SHARE = 0.05
#: ``auto`` target edge, in units of the slivers' median smallest height
#: (measured: 20 x the strip width flattens the 300-strip cylinder exactly)
EDGE_PER_SLIVER_HEIGHT = 20.0
#: the refinement never makes more triangles than this (the target edge grows instead)
MAX_REMESH_FACES = 400_000
#: a facet's far vertex may lie this far from the plane of its neighbour (x median edge) to count as coplanar
PLANE_TOL = 1e-9
#: after flattening, a mean conformal ratio above this is reported as high distortion
HIGH_CONFORMAL_RATIO = 1.2


def parse_remesh(value) -> tuple[str, float | None]:
    """``"auto"``, ``"off"`` or an edge length in mm, as ``(mode, edge_mm)``.

    Raises
    ------
    ParameterError
        For anything else, naming the choices.
    """
    if isinstance(value, bool):
        value = "auto" if value else "off"
    text = str(value).strip().lower()
    if text in ("auto", "off"):
        return text, None
    try:
        edge = float(text)
    except ValueError:
        edge = float("nan")
    if not (math.isfinite(edge) and edge > 0):
        raise ParameterError(f"--remesh must be auto, off or an edge length in mm, got {value!r}.",
                             "auto (default) refines CAD-style sliver meshes only; off keeps the mesh; "
                             "a number (e.g. 0.5) refines every edge longer than that many mm.")
    return "edge", edge


def sliver_report(surface: Surface) -> dict[str, float]:
    """How much of the surface is covered by slivers.

    Returns
    -------
    dict
        ``sliver_faces`` (count), ``sliver_area_share`` (0-1), ``sliver_height_mm`` (median
        smallest height of the slivers, 0 when none), ``min_angle_deg``.
    """
    v, f = surface.vertices, surface.faces
    ang = np.degrees(meshops.corner_angles(v, f)).min(axis=1)
    area = meshops.face_areas(v, f)
    bad = ang < SLIVER_DEG
    el = np.stack([np.linalg.norm(v[f[:, (k + 1) % 3]] - v[f[:, k]], axis=1) for k in range(3)], axis=1)
    height = 2.0 * area / np.maximum(el.max(axis=1), 1e-300)
    return {
        "sliver_faces": int(bad.sum()),
        "sliver_area_share": float(area[bad].sum() / max(area.sum(), 1e-300)),
        "sliver_height_mm": float(np.median(height[bad])) if bad.any() else 0.0,
        "min_angle_deg": float(ang.min()),
    }


def fit_for_flattening(surface: Surface, remesh="auto") -> Surface:
    """The surface, refined exactly (:func:`refine_exact`) when its tessellation would flatten badly.

    Parameters
    ----------
    surface : Surface
        Checked surface, mm.
    remesh : {"auto", "off"} or float
        ``auto``: refine only when slivers cover more than 5 % of the area, to
        20 x their median height; ``off``: never; a number: refine every edge
        longer than that many mm.

    Returns
    -------
    Surface
        The same surface, or its refinement with ``params["remesh"]`` (mode,
        target edge, faces before and after, why) and a ``remeshed`` finding.
    """
    mode, edge = parse_remesh(remesh)
    if mode == "off":
        return surface
    rep = sliver_report(surface)
    if mode == "auto":
        if rep["sliver_area_share"] <= SLIVER_AREA_SHARE:
            return surface
        edge = EDGE_PER_SLIVER_HEIGHT * rep["sliver_height_mm"]
        why = (f"{rep['sliver_faces']} sliver triangles (a corner under {SLIVER_DEG:g} deg, smallest "
               f"{rep['min_angle_deg']:.2g} deg) cover {100 * rep['sliver_area_share']:.0f} % of the area")
    else:
        why = f"--remesh {edge:g}"
    area = meshops.surface_area(surface.vertices, surface.faces)
    floor = math.sqrt(4.0 * 2.0 * area / (math.sqrt(3.0) * MAX_REMESH_FACES))
    if edge < floor:
        if mode == "edge":
            raise ParameterError(
                f"--remesh {edge:g} mm would make more than {MAX_REMESH_FACES:,} triangles on {area:.4g} mm^2.",
                f"Use --remesh {floor:.3g} or larger, or --remesh auto.")
        edge = floor
    v, f = refine_exact(surface.vertices, surface.faces, edge)
    from .validate import validate_mesh

    v, f, findings = validate_mesh(v, f, name=surface.name)
    info = {"applied": True, "mode": mode, "edge_mm": float(edge), "faces_before": int(surface.n_faces), "faces_after": int(len(f)),
            "reason": why, **{k: rep[k] for k in ("sliver_faces", "sliver_area_share", "min_angle_deg")}}
    note = Finding("remeshed", f"refined to edges <= {edge:.3g} mm ({surface.n_faces} -> {len(f)} triangles, same "
                   f"surface) because {why}", int(len(f)), True, "warning")
    keep = tuple(x for x in surface.findings if x.code != "slivers")
    return dataclasses.replace(surface, vertices=v, faces=f, params={**surface.params, "remesh": info},
                               findings=keep + tuple(x for x in findings if x.code != "slivers") + (note,), sag=surface.sag)


def _edges(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique undirected edges ``(E, 2)`` (low index first) and each face's edge ids ``(F, 3)`` (edge k: corner k to k+1)."""
    he = np.stack([f, np.roll(f, -1, axis=1)], axis=2).reshape(-1, 2)
    uniq, inv = np.unique(np.sort(he, axis=1), axis=0, return_inverse=True)
    return uniq, inv.reshape(-1, 3)


def planar_facets(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Group coplanar neighbouring triangles into facets.

    Returns
    -------
    labels : (F,) int
        Facet of each face.
    edges : (E, 2) int
        Unique edges.
    face_edges : (F, 3) int
        Edge ids of each face.
    inner : (E,) bool
        Edges inside a facet (both faces in one plane, same side up).
    """
    nf = len(f)
    E, fe = _edges(f)
    ne = len(E)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    nu = n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    ids = fe.ravel()
    owner = np.repeat(np.arange(nf), 3)
    order = np.argsort(ids, kind="stable")
    cnt = np.bincount(ids, minlength=ne)
    start = np.r_[0, np.cumsum(cnt)[:-1]]
    two = np.nonzero(cnt == 2)[0]
    fa, fb = owner[order][start[two]], owner[order][start[two] + 1]
    scale = float(np.median(np.linalg.norm(v[E[:, 1]] - v[E[:, 0]], axis=1)))
    ca, cb = v[f[fa]].mean(axis=1), v[f[fb]].mean(axis=1)
    off = np.maximum(np.abs(np.einsum("ij,ij->i", nu[fa], cb - ca)), np.abs(np.einsum("ij,ij->i", nu[fb], ca - cb)))
    flat = (off <= PLANE_TOL * scale) & (np.einsum("ij,ij->i", nu[fa], nu[fb]) > 0)
    inner = np.zeros(ne, bool)
    inner[two[flat]] = True
    g = sp.coo_matrix((np.ones(int(flat.sum())), (fa[flat], fb[flat])), shape=(nf, nf))
    _, labels = connected_components(g, directed=False)
    return labels, E, fe, inner


def refine_exact(vertices: np.ndarray, faces: np.ndarray, edge_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Refine a mesh to edges no longer than ``edge_mm`` without changing its surface.

    Parameters
    ----------
    vertices : (V, 3) float
        mm.
    faces : (F, 3) int
        Consistently oriented triangles.
    edge_mm : float
        Target edge length, mm.

    Returns
    -------
    vertices : (V', 3) float64
        The old vertices that are still used, then new ones on old edges and
        inside old planar facets.
    faces : (F', 3) int64
        Same orientation as the input.
    """
    import triangle as tr

    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    labels, E, fe, inner = planar_facets(v, f)
    length = np.linalg.norm(v[E[:, 1]] - v[E[:, 0]], axis=1)
    k = np.maximum(np.ceil(length / edge_mm - 1e-9).astype(np.int64), 1)
    k[inner] = 1
    # the split points of every outer edge, numbered after the old vertices
    first = np.full(len(E), -1, dtype=np.int64)
    split = np.nonzero(k > 1)[0]
    counts = k[split] - 1
    first[split] = len(v) + np.r_[0, np.cumsum(counts)[:-1]]
    t = np.concatenate([np.arange(1, kk) / kk for kk in k[split]]) if len(split) else np.zeros(0)
    which = np.repeat(split, counts)
    pts = v[E[which, 0]] + (v[E[which, 1]] - v[E[which, 0]]) * t[:, None]
    base = np.vstack([v, pts])
    verts = [base]
    n_next = len(base)
    # facets to re-triangulate: those with a split edge or more than one triangle
    nfac = int(labels.max()) + 1
    size = np.bincount(labels, minlength=nfac)
    touched = np.zeros(nfac, bool)
    for c in range(3):
        touched[labels[k[fe[:, c]] > 1]] = True
    redo = touched | ((size > 1) & _any_sliver(v, f, labels, nfac))
    out = [f[~redo[labels]]]
    order = np.argsort(labels, kind="stable")
    bounds = np.r_[0, np.cumsum(size)]
    area_bound = edge_mm * edge_mm * math.sqrt(3.0) / 4.0 * 1.5
    for lab in np.nonzero(redo)[0]:
        fi = order[bounds[lab]:bounds[lab + 1]]
        segs = []
        for c in range(3):
            ff = fi[~inner[fe[fi, c]]]
            for i in ff:
                e = fe[i, c]
                a, b = int(f[i, c]), int(f[i, (c + 1) % 3])
                if k[e] > 1:
                    mid = first[e] + np.arange(k[e] - 1)
                    chain = [a, *(mid if a == E[e, 0] else mid[::-1]).tolist(), b]
                else:
                    chain = [a, b]
                segs.extend(zip(chain[:-1], chain[1:]))
        seg = np.array(segs, dtype=np.int64)
        gv, local = np.unique(seg, return_inverse=True)
        local = local.reshape(-1, 2)
        nrm = np.cross(v[f[fi, 1]] - v[f[fi, 0]], v[f[fi, 2]] - v[f[fi, 0]]).sum(axis=0)
        nrm /= np.linalg.norm(nrm)
        e1 = np.cross(nrm, [1.0, 0.0, 0.0] if abs(nrm[0]) < 0.9 else [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(nrm, e1)  # (e1, e2, nrm) right-handed: counter-clockwise in 2D is the facet's side
        o = v[f[fi[0], 0]]
        p3 = base[gv] - o
        xy = np.c_[p3 @ e1, p3 @ e2]
        res = tr.triangulate({"vertices": xy, "segments": local}, f"pq20Ya{_decimal(area_bound)}Q")
        tv, tt = np.asarray(res["vertices"]), np.asarray(res["triangles"], dtype=np.int64)
        loops = meshops.boundary_loops(f[fi])
        if len(loops) > 1:  # a facet with holes: keep the triangles inside its old triangles
            old2d = np.stack([(v[f[fi]] - o) @ e1, (v[f[fi]] - o) @ e2], axis=2)  # (m, 3, 2)
            tt = tt[_inside(tv[tt].mean(axis=1), old2d)]
        m = len(gv)
        glob = np.r_[gv, n_next + np.arange(len(tv) - m)]
        if len(tv) > m:
            verts.append(o + tv[m:, :1] * e1 + tv[m:, 1:2] * e2)
            n_next += len(tv) - m
        out.append(glob[tt])
    V = np.vstack(verts)
    F = np.vstack(out)
    used = np.zeros(len(V), bool)
    used[F.ravel()] = True
    remap = -np.ones(len(V), dtype=np.int64)
    remap[used] = np.arange(int(used.sum()))
    return V[used], remap[F]


def _any_sliver(v, f, labels, nfac) -> np.ndarray:
    ang = np.degrees(meshops.corner_angles(v, f)).min(axis=1)
    out = np.zeros(nfac, bool)
    out[labels[ang < SLIVER_DEG]] = True
    return out


def _inside(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Which points ``(n, 2)`` lie inside any triangle ``(m, 3, 2)``."""
    inside = np.zeros(len(p), bool)
    for a, b, c in tri:
        d1 = (b[0] - a[0]) * (p[:, 1] - a[1]) - (b[1] - a[1]) * (p[:, 0] - a[0])
        d2 = (c[0] - b[0]) * (p[:, 1] - b[1]) - (c[1] - b[1]) * (p[:, 0] - b[0])
        d3 = (a[0] - c[0]) * (p[:, 1] - c[1]) - (a[1] - c[1]) * (p[:, 0] - c[0])
        inside |= ((d1 >= 0) & (d2 >= 0) & (d3 >= 0)) | ((d1 <= 0) & (d2 <= 0) & (d3 <= 0))
    return inside


def _decimal(x: float) -> str:
    from .mesher import area_switch

    return area_switch(x)


def conformal_warning(surface: Surface, metrics: dict) -> str:
    """A warning sentence when a flattening stays far from conformal ('' otherwise)."""
    q = float(metrics.get("conformal_ratio_mean", 1.0))
    if not q > HIGH_CONFORMAL_RATIO:
        return ""
    rep = sliver_report(surface)
    why = (f"; {rep['sliver_faces']} sliver triangles cover {100 * rep['sliver_area_share']:.0f} % of the area "
           "(try --remesh with an edge length in mm)" if rep["sliver_faces"] else
           "; the part is far from developable (cut it into less curved patches for less distortion)")
    return (f"the flattening of {surface.name} is far from conformal (mean conformal ratio {q:.3g}, 1 is "
            f"angle-true){why}: dwell points will be unevenly spaced on the part.")
