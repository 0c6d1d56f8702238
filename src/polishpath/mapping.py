"""Inverse mapping: carry a planar path back onto the 3D surface (paper section 4.1).

Each planar dwell point is located in its triangle of the flattened mesh, turned
into area coordinates (Eq. 6-9) and carried to the same area coordinates of the
matching 3D triangle. The module also holds

* step control on the part: the planar spacing that keeps every 3D step under
  ``max_step_factor x spacing`` (:func:`planar_spacing_for_surface`, the paper's
  "step reduction factor" as a bound; the re-planning loop that checks it on an
  actual path is :func:`polishpath.pipeline.plan_on_surface`, which wires the
  planner and this stage);
* the 3D step statistics every path reports (:func:`surface_step_stats`).

Units: mm.
"""

from __future__ import annotations

import math
import time

import numba
from . import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

from . import meshops
from .errors import MappingError, ParameterError
from .pathops import piece_offsets, step_lengths
from .types import Flattening, PlanarPath, Provenance, Surface, SurfacePath

__all__ = [
    "locate_points",
    "map_to_surface",
    "planar_spacing_for_surface",
    "surface_step_stats",
    "jacobian_singular_values",
]

SQRT2 = 2.0**0.5


# --------------------------------------------------------------------------------------
# point location: uniform bucket grid over the planar triangles
# --------------------------------------------------------------------------------------
# Written by hand (numba) because no well-kept library offers a vectorised
# "which triangle contains this 2D point" for 10^6 queries against 10^5
# triangles: trimesh/rtree answer one point at a time in Python, and a kd-tree on
# centroids still needs the containment test and the boundary snap below.


@numba.njit(cache=True)
def _grid_fill(lo, hi, x0, y0, h, nx, ny):  # pragma: no cover - numba
    f = lo.shape[0]
    counts = np.zeros(nx * ny + 1, dtype=np.int64)
    for t in range(f):
        ix0 = max(int((lo[t, 0] - x0) / h), 0)
        iy0 = max(int((lo[t, 1] - y0) / h), 0)
        ix1 = min(int((hi[t, 0] - x0) / h), nx - 1)
        iy1 = min(int((hi[t, 1] - y0) / h), ny - 1)
        for iy in range(iy0, iy1 + 1):
            for ix in range(ix0, ix1 + 1):
                counts[iy * nx + ix + 1] += 1
    start = np.cumsum(counts)
    fill = start[:-1].copy()
    tris = np.empty(start[-1], dtype=np.int64)
    for t in range(f):
        ix0 = max(int((lo[t, 0] - x0) / h), 0)
        iy0 = max(int((lo[t, 1] - y0) / h), 0)
        ix1 = min(int((hi[t, 0] - x0) / h), nx - 1)
        iy1 = min(int((hi[t, 1] - y0) / h), ny - 1)
        for iy in range(iy0, iy1 + 1):
            for ix in range(ix0, ix1 + 1):
                c = iy * nx + ix
                tris[fill[c]] = t
                fill[c] += 1
    return start, tris


@numba.njit(cache=True)
def _seg_dist2(px, py, ax, ay, bx, by):  # pragma: no cover - numba
    ex = bx - ax
    ey = by - ay
    ll = ex * ex + ey * ey
    t = 0.0
    if ll > 0.0:
        t = ((px - ax) * ex + (py - ay) * ey) / ll
        t = min(max(t, 0.0), 1.0)
    dx = ax + t * ex - px
    dy = ay + t * ey - py
    return dx * dx + dy * dy, t


@numba.njit(cache=True)
def _locate_kernel(pts, uv, faces, valid, heights, start, tris, x0, y0, h, nx, ny, tol, eps):  # pragma: no cover
    n = pts.shape[0]
    fid = np.full(n, -1, dtype=np.int64)
    bary = np.zeros((n, 3))
    dist = np.full(n, np.inf)
    for k in range(n):
        px = pts[k, 0]
        py = pts[k, 1]
        ixf = (px - x0) / h
        iyf = (py - y0) / h
        if ixf < 0.0 or iyf < 0.0 or ixf >= nx or iyf >= ny:
            continue
        c = int(iyf) * nx + int(ixf)
        best_h = -np.inf
        best_snap = np.inf
        snap_t = -1
        for q in range(start[c], start[c + 1]):
            t = tris[q]
            if not valid[t]:
                continue
            i0 = faces[t, 0]
            i1 = faces[t, 1]
            i2 = faces[t, 2]
            xi, yi = uv[i0, 0], uv[i0, 1]
            xj, yj = uv[i1, 0], uv[i1, 1]
            xm, ym = uv[i2, 0], uv[i2, 1]
            # Eq. 7: twice the signed area; Eq. 6: area coordinates
            a2 = (xi * yj - xj * yi) + (yi - yj) * xm + (xj - xi) * ym
            li = ((xj * ym - xm * yj) + (yj - ym) * px + (xm - xj) * py) / a2
            lj = ((xm * yi - xi * ym) + (ym - yi) * px + (xi - xm) * py) / a2
            lm = 1.0 - li - lj
            if li >= -eps and lj >= -eps and lm >= -eps:
                hh = li * heights[i0] + lj * heights[i1] + lm * heights[i2]
                if hh > best_h:
                    best_h = hh
                    fid[k] = t
                    bary[k, 0] = li
                    bary[k, 1] = lj
                    bary[k, 2] = lm
                    dist[k] = 0.0
                continue
            if fid[k] >= 0:
                continue
            # outside this triangle: a cheap lower bound of the distance first
            # (distance to the supporting line of each violated edge)
            lb = 0.0
            aa = abs(a2)
            if li < 0.0:
                e = math.sqrt((xm - xj) ** 2 + (ym - yj) ** 2)
                lb = max(lb, -li * aa / e)
            if lj < 0.0:
                e = math.sqrt((xm - xi) ** 2 + (ym - yi) ** 2)
                lb = max(lb, -lj * aa / e)
            if lm < 0.0:
                e = math.sqrt((xj - xi) ** 2 + (yj - yi) ** 2)
                lb = max(lb, -lm * aa / e)
            if lb > tol or lb >= best_snap:
                continue
            d0, t0 = _seg_dist2(px, py, xi, yi, xj, yj)
            d1, t1 = _seg_dist2(px, py, xj, yj, xm, ym)
            d2, t2 = _seg_dist2(px, py, xm, ym, xi, yi)
            d = math.sqrt(min(d0, d1, d2))
            if d < best_snap:
                best_snap = d
                snap_t = t
                # area coordinates of the closest boundary point
                if d0 <= d1 and d0 <= d2:
                    bary[k, 0], bary[k, 1], bary[k, 2] = 1.0 - t0, t0, 0.0
                elif d1 <= d2:
                    bary[k, 0], bary[k, 1], bary[k, 2] = 0.0, 1.0 - t1, t1
                else:
                    bary[k, 0], bary[k, 1], bary[k, 2] = t2, 0.0, 1.0 - t2
        if fid[k] < 0 and snap_t >= 0 and best_snap <= tol:
            fid[k] = snap_t
            dist[k] = best_snap
        elif fid[k] < 0:
            bary[k, 0] = 0.0
            bary[k, 1] = 0.0
            bary[k, 2] = 0.0
    return fid, bary, dist


def locate_points(
    uv: np.ndarray,
    faces: np.ndarray,
    points: np.ndarray,
    *,
    tol: float = 1e-9,
    heights: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Triangle and area coordinates of planar points (Eq. 6-7).

    Parameters
    ----------
    uv : (V, 2) float
        Planar vertex positions, mm.
    faces : (F, 3) int
        Triangles.
    points : (N, 2) float
        Query points, mm.
    tol : float
        Points outside every triangle but within ``tol`` mm of one are snapped
        to the closest point of the nearest triangle.
    heights : (V,) float, optional
        Where triangles overlap in the plane (folds of a projection), the one
        whose interpolated height is largest wins, a point on the edge of a
        triangle counting as inside it (area coordinates >= -1e-12), so that
        round-off cannot hand a point on the edge of the top layer to the layer
        below; None: the first triangle found that contains the point exactly.

    Returns
    -------
    face_ids : (N,) int64
        Containing triangle, -1 for points farther than ``tol`` from every triangle.
    bary : (N, 3) float64
        Area coordinates ``(L_i, L_j, L_m)`` for the corners ``faces[f]`` (zeros where -1).
    snap_distance : (N,) float64
        Planar distance moved by the snap, mm (0 inside, inf where not found).
    """
    uv = np.ascontiguousarray(uv, dtype=np.float64)
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
    if len(faces) == 0:
        raise MappingError("The flattening has no triangles.", "Flatten a non-empty surface first.")
    p = uv[faces]
    lo = p.min(axis=1) - tol
    hi = p.max(axis=1) + tol
    a2 = meshops.face_areas(uv, faces, signed=True) * 2.0
    ext = hi.max(axis=0) - lo.min(axis=0)
    scale = float(max(ext.max(), 1e-300))
    valid = np.abs(a2) > 1e-14 * scale * scale
    # cell about one mean triangle across: ~1 cell per triangle, few candidates per cell
    mean_area = float(np.abs(a2[valid]).sum() / 2 / max(valid.sum(), 1)) if valid.any() else scale * scale
    h = max(math.sqrt(mean_area) * 1.5, scale / 4096.0)
    x0, y0 = lo.min(axis=0)
    nx = int(ext[0] / h) + 1
    ny = int(ext[1] / h) + 1
    start, tris = _grid_fill(lo, hi, float(x0), float(y0), h, nx, ny)
    hts = np.zeros(len(uv)) if heights is None else np.ascontiguousarray(heights, dtype=np.float64)
    eps = 0.0 if heights is None else 1e-12
    return _locate_kernel(pts, uv, faces, valid, hts, start, tris, float(x0), float(y0), h, nx, ny, float(tol), eps)


# --------------------------------------------------------------------------------------
# statistics of a path on the part
# --------------------------------------------------------------------------------------


def surface_step_stats(xyz: np.ndarray, pieces: np.ndarray | None, spacing: float, dwell_weight=None) -> dict:
    """3D step statistics of a dwell-point path.

    Parameters
    ----------
    xyz : (N, 3) float
        Dwell points in path order, mm.
    pieces : (K+1,) int or None
        Offsets of the continuous pieces (no step is counted across a lift).
    spacing : float
        Nominal dwell-point spacing on the part ``s``, mm.
    dwell_weight : (N,) float, optional
        Area each point stands for (mean 1), for the density variation.

    Returns
    -------
    stats : dict
        ``step_mean``, ``step_max``, ``step_min``, ``step_std`` (mm), ``n_steps``,
        ``share_normal`` (share of steps in the paper's normal range
        ``[s, sqrt(2) s]``, 1e-6 relative slack), ``share_short`` (< s),
        ``share_long`` (> sqrt(2) s), ``path_length`` (mm), ``spacing`` (s), and
        where ``dwell_weight`` is given ``density_cv`` (coefficient of variation of
        the dwell-point density on the part) and ``density_ratio`` (largest /
        smallest density).
    """
    xyz = np.asarray(xyz, dtype=np.float64)
    n = len(xyz)
    pieces = piece_offsets(pieces, n)
    steps = step_lengths(xyz, pieces)
    s = float(spacing)
    out: dict = {"spacing": s, "n_points": int(n), "n_steps": int(len(steps)), "n_pieces": int(len(pieces) - 1)}
    if len(steps):
        lo, hi = s * (1 - 1e-6), SQRT2 * s * (1 + 1e-6)
        out.update(
            step_mean=float(steps.mean()),
            step_max=float(steps.max()),
            step_min=float(steps.min()),
            step_std=float(steps.std()),
            share_normal=float(np.mean((steps >= lo) & (steps <= hi))),
            share_short=float(np.mean(steps < lo)),
            share_long=float(np.mean(steps > hi)),
            path_length=float(steps.sum()),
        )
    else:
        out.update(step_mean=0.0, step_max=0.0, step_min=0.0, step_std=0.0, share_normal=0.0,
                   share_short=0.0, share_long=0.0, path_length=0.0)
    if dwell_weight is not None and len(dwell_weight):
        w = np.asarray(dwell_weight, dtype=np.float64)
        dens = 1.0 / w
        out["density_cv"] = float(dens.std() / dens.mean())
        out["density_ratio"] = float(dens.max() / dens.min())
    return out


# --------------------------------------------------------------------------------------
# the inverse map
# --------------------------------------------------------------------------------------


def _vertex_area_ratio(surface: Surface, uv: np.ndarray) -> np.ndarray:
    """Local area ratio 3D / 2D at each vertex, (V,): one-ring 3D area over one-ring planar area."""
    f = surface.faces
    a3 = meshops.face_areas(surface.vertices, f)
    a2 = np.abs(meshops.face_areas(uv, f, signed=True))
    nv = surface.n_vertices
    s3 = np.bincount(f.ravel(), weights=np.repeat(a3, 3), minlength=nv)
    s2 = np.bincount(f.ravel(), weights=np.repeat(a2, 3), minlength=nv)
    return np.divide(s3, s2, out=np.full_like(s3, np.nan), where=s2 > 0)


def _layer_heights(flat: Flattening) -> np.ndarray | None:
    """Vertex heights along the plane normal of a flattening that can fold over itself, (V,) mm.

    A flattening whose layers may overlap in the plane (the projection method's)
    records the normal of its plane as ``provenance.params["plane_normal"]``;
    where layers overlap, the highest one along it is the one a point lifts to.
    None for flattenings without one (they do not overlap).
    """
    nrm = flat.provenance.params.get("plane_normal")
    if nrm is None:
        return None
    return flat.surface.vertices @ np.asarray(nrm, dtype=np.float64)


def map_to_surface(
    flat: Flattening,
    path: PlanarPath,
    *,
    surface_spacing: float | None = None,
    tol: float = 1e-9,
) -> SurfacePath:
    """Carry a planar path onto the surface with area coordinates (Eq. 6-9).

    Parameters
    ----------
    flat : Flattening
        The flattening the path was planned on (``flat.uv`` (V, 2) mm).
    path : PlanarPath
        Dwell points ``path.uv`` (N, 2) mm, in path order.
    surface_spacing : float, optional
        Nominal spacing on the part ``s`` (mm) for the step statistics; default
        ``path.stats["surface_spacing"]`` if present, else ``path.spacing``.
    tol : float
        Points outside every triangle by at most ``tol`` mm snap onto the nearest one.

    Returns
    -------
    SurfacePath
        ``xyz`` (N, 3) on the mesh, ``normals`` (N, 3) unit interpolated vertex
        normals, ``face_ids`` (N,), ``bary`` (N, 3), ``dwell_weight`` (N,) the
        part area each point stands for (the local 3D/2D area ratio interpolated
        from the vertices, times the point's planar cell ``path.cell_area`` when
        the set has no lattice, normalised to mean 1) and ``stats``
        (:func:`surface_step_stats` plus ``n_snapped`` and ``seconds``).

    Raises
    ------
    MappingError
        If a point lies farther than ``tol`` outside every triangle.
    """
    t0 = time.perf_counter()
    surf = flat.surface
    if flat.uv.shape[0] != surf.n_vertices:
        raise MappingError(
            f"The flattening has {flat.uv.shape[0]} planar vertices but the surface has {surf.n_vertices}.",
            "Map with the flattening made from this surface.",
        )
    pts = path.uv
    if len(pts) == 0:
        raise MappingError("The planar path has no dwell point.", "Plan with a smaller spacing or a larger region.")
    fid, bary, snap = locate_points(flat.uv, surf.faces, pts, tol=tol, heights=_layer_heights(flat))
    bad = np.flatnonzero(fid < 0)
    if len(bad):
        k = int(bad[0])
        raise MappingError(
            f"{len(bad)} of {len(pts)} planar points lie outside the flattened mesh "
            f"(first: index {k} at uv=({pts[k, 0]:.6g}, {pts[k, 1]:.6g}) mm).",
            "Plan the path inside the region of this flattening (polishpath.plan on the "
            "flattening's boundary), or flatten the surface the path was planned for.",
        )
    tri = surf.faces[fid]  # (N, 3)
    # Eq. 8: same area coordinates in the 3D triangle
    xyz = np.einsum("nk,nkd->nd", bary, surf.vertices[tri])
    vn = meshops.vertex_normals(surf.vertices, surf.faces)
    nrm = np.einsum("nk,nkd->nd", bary, vn[tri])
    ln = np.linalg.norm(nrm, axis=1, keepdims=True)
    fn = meshops.face_normals(surf.vertices, surf.faces)[fid]
    nrm = np.where(ln > 1e-12, nrm / np.maximum(ln, 1e-300), fn)
    ratio_v = _vertex_area_ratio(surf, flat.uv)
    ratio_v = np.where(np.isfinite(ratio_v), ratio_v, np.nanmedian(ratio_v) if np.isfinite(ratio_v).any() else 1.0)
    w = np.einsum("nk,nk->n", bary, ratio_v[tri])
    if path.cell_area is not None:  # a set without a lattice: each point's own planar cell (Voronoi), mm^2
        w = w * path.cell_area
    w = w / w.mean() if len(w) and w.mean() > 0 else np.ones(len(pts))
    s = surface_spacing if surface_spacing is not None else path.stats.get("surface_spacing", path.spacing)
    stats = surface_step_stats(xyz, path.pieces, float(s), w)
    stats["n_snapped"] = int(np.count_nonzero(snap > 0))
    stats["seconds"] = time.perf_counter() - t0
    prov = Provenance(
        "map",
        "area_coordinates",
        {"flatten_method": flat.provenance.method, "tol": tol, "surface_spacing": float(s),
         "planar_spacing": float(path.spacing)},
        seed=path.provenance.seed,
    )
    return SurfacePath(xyz=xyz, normals=nrm, face_ids=fid, bary=bary, dwell_weight=w, planar=path,
                       provenance=prov, stats=stats)


# --------------------------------------------------------------------------------------
# step control on the part
# --------------------------------------------------------------------------------------


def jacobian_singular_values(flat: Flattening) -> np.ndarray:
    """Singular values of the per-triangle 2D -> 3D Jacobian.

    Parameters
    ----------
    flat : Flattening

    Returns
    -------
    sigma : (F, 2) float64
        ``(largest, smallest)`` stretch of a planar length when carried to the
        part, per triangle (dimensionless); ``inf`` for triangles of zero planar area.
    """
    return meshops.jacobian_singular_values(flat.uv, flat.surface.vertices, flat.surface.faces)


def planar_spacing_for_surface(
    flat: Flattening,
    spacing: float,
    max_step_factor: float = SQRT2,
    quantile: float = 1.0,
) -> float:
    """Planar grid spacing so that no 3D step exceeds ``max_step_factor x spacing``.

    The longest planar step of the 8-direction grid is the diagonal ``sqrt(2) h``;
    a planar segment of length ``l`` maps to a 3D chord no longer than
    ``sigma_max l`` (the chord is at most the mapped polyline, each piece
    stretched at most by its triangle's largest singular value). Hence
    ``h = max_step_factor * spacing / (sqrt(2) * sigma_max)``: the paper's
    "step reduction factor" ``1 / sigma_max`` found from the map.

    Parameters
    ----------
    flat : Flattening
    spacing : float
        Wanted dwell-point spacing on the part, mm.
    max_step_factor : float
        Largest allowed 3D step as a multiple of ``spacing`` (default sqrt(2), the
        top of the paper's normal range).
    quantile : float
        Use this area-weighted quantile of the largest singular value instead of
        the maximum (1.0: strict bound; lower values give a larger spacing that
        :func:`polishpath.pipeline.plan_on_surface` then checks on the actual path).

    Returns
    -------
    h : float
        Planar spacing, mm.
    """
    if not spacing > 0 or not math.isfinite(spacing):
        raise ParameterError(f"spacing must be a positive number of mm, got {spacing}.")
    if not max_step_factor > 0:
        raise ParameterError(f"max_step_factor must be positive, got {max_step_factor}.")
    sig = jacobian_singular_values(flat)[:, 0]
    area2 = np.abs(meshops.face_areas(flat.uv, flat.surface.faces, signed=True))
    used = area2 > 0
    if not used.any():
        raise MappingError("Every triangle of the flattening has zero planar area.", "Check the flattening.")
    if quantile >= 1.0:
        smax = float(sig[used].max())
    else:
        order = np.argsort(sig[used])
        cw = np.cumsum(area2[used][order])
        smax = float(sig[used][order][np.searchsorted(cw, quantile * cw[-1])])
    if not math.isfinite(smax) or smax <= 0:
        raise MappingError(
            "The flattening stretches some triangle without bound (zero planar area), so no planar "
            "spacing keeps the 3D steps bounded.",
            "Use a flattening without degenerate triangles (e.g. MABF), or keep the plain planar grid.",
        )
    return float(max_step_factor * spacing / (SQRT2 * smax))
