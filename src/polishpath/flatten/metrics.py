"""Distortion figures of any planar map of a surface."""

from __future__ import annotations

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

from .. import meshops
from ..errors import ParameterError
from ..types import Surface


def flipped_faces(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Faces whose planar orientation disagrees with the majority, or that have zero area.

    Parameters
    ----------
    uv : (V, 2) float
        mm.
    faces : (F, 3) int

    Returns
    -------
    (F,) bool
    """
    sa = meshops.face_areas(uv, faces, signed=True)
    sign = 1.0 if (sa > 0).sum() >= (sa < 0).sum() else -1.0
    return sa * sign <= 0


def boundary_self_overlap(uv: np.ndarray, faces: np.ndarray, boundary_edges: np.ndarray | None = None) -> int:
    """Number of pairs of boundary edges that cross in the plane (not sharing a vertex).

    Parameters
    ----------
    uv : (V, 2) float
    faces : (F, 3) int
    boundary_edges : (B, 2) int, optional
        Boundary half-edges of ``faces`` when the caller has them.

    Returns
    -------
    int
        0 for an embedding whose boundary loops are simple and disjoint.
    """
    import shapely

    be = meshops.boundary_edges(faces) if boundary_edges is None else np.asarray(boundary_edges)
    if len(be) == 0:
        return 0
    p = np.asarray(uv, dtype=np.float64)
    segs = shapely.linestrings(np.stack([p[be[:, 0]], p[be[:, 1]]], axis=1))
    tree = shapely.STRtree(segs)
    i, j = tree.query(segs, predicate="intersects")
    keep = i < j
    i, j = i[keep], j[keep]
    share = (
        (be[i, 0] == be[j, 0]) | (be[i, 0] == be[j, 1]) | (be[i, 1] == be[j, 0]) | (be[i, 1] == be[j, 1])
    )
    return int(np.count_nonzero(~share))


def flattening_metrics(surface: Surface, uv: np.ndarray, boundary_edges: np.ndarray | None = None) -> dict[str, float]:
    """Distortion of a planar map of ``surface``.

    Parameters
    ----------
    surface : Surface
        The 3D mesh.
    uv : (V, 2) float
        Planar vertex positions, mm, same indexing.
    boundary_edges : (B, 2) int, optional
        The mesh's boundary half-edges when the caller has them
        (:func:`polishpath.meshops.boundary_edges` otherwise).

    Returns
    -------
    dict of str -> float
        ``angle_error_mean_deg``, ``angle_error_max_deg`` (|alpha - beta| per corner),
        ``area_distortion_mean`` (3D-area weighted mean of |ln(A2/A3)| after scaling
        the total planar area to the 3D area), ``area_distortion_max``,
        ``conformal_ratio_mean`` (area-weighted sigma1/sigma2, 1 is conformal),
        ``conformal_ratio_max``, ``l2_stretch`` (Sander, area-normalised, 1 is optimal),
        ``flipped_faces``, ``boundary_self_overlap`` (crossing boundary-edge pairs),
        ``area_3d`` and ``area_2d`` (mm^2).
    """
    v = np.ascontiguousarray(surface.vertices, dtype=np.float64)
    f = np.ascontiguousarray(surface.faces, dtype=np.int64)
    uv = np.ascontiguousarray(uv, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 3 or uv.shape != (len(v), 2):
        raise ParameterError(f"Metrics need (V, 3) part vertices and (V, 2) planar ones, got {v.shape} and {uv.shape}.",
                             "Pass the surface and its flattening's uv (one planar point per vertex).")
    # one pass over the faces instead of meshops' corner_angles (x2), face_areas (x2) and
    # jacobian_singular_values (numpy's batched SVD alone took 0.07-0.19 s at 100k faces):
    # the same formulas, checked against meshops in tests/test_flatten.py
    err_rad, a3, a2s, sv = _kernel_face_metrics(v, uv, f)
    a2 = np.abs(a2s)
    A3, A2 = a3.sum(), a2.sum()
    scale = A3 / A2 if A2 > 0 else np.nan
    sv *= np.sqrt(scale)
    err = np.degrees(err_rad)
    sign = 1.0 if (a2s > 0).sum() >= (a2s < 0).sum() else -1.0
    n_flipped = int(np.count_nonzero(a2s * sign <= 0))
    return _summary(err, a3, a2, A3, A2, scale, sv, n_flipped, boundary_self_overlap(uv, f, boundary_edges))


@numba.njit(cache=True)
def _kernel_face_metrics(v, uv, f):  # pragma: no cover - numba
    # per corner |alpha - beta| (rad); per face 3D area, signed planar area and the
    # singular values of the part -> plane map (inf for a face of zero 3D area).
    # Formulas as meshops.corner_angles (atan2(|e1 x e2|, a.b)), meshops.face_areas and
    # meshops.jacobian_singular_values (the 3D triangle in its own frame, x along its
    # first edge); the 2x2 singular values in closed form: for J = [[a, b], [c, d]],
    # q = |(a + d, c - b)|, r = |(a - d, b + c)|, sigma = (q + r) / 2, |q - r| / 2.
    F = f.shape[0]
    err = np.empty(3 * F)
    a3 = np.empty(F)
    a2 = np.empty(F)
    sv = np.empty((F, 2))
    for i in range(F):
        i0, i1, i2 = f[i, 0], f[i, 1], f[i, 2]
        ex = v[i1, 0] - v[i0, 0]
        ey = v[i1, 1] - v[i0, 1]
        ez = v[i1, 2] - v[i0, 2]
        gx = v[i2, 0] - v[i0, 0]
        gy = v[i2, 1] - v[i0, 1]
        gz = v[i2, 2] - v[i0, 2]
        cx = ey * gz - ez * gy
        cy = ez * gx - ex * gz
        cz = ex * gy - ey * gx
        cr3 = np.sqrt(cx * cx + cy * cy + cz * cz)
        ux = uv[i1, 0] - uv[i0, 0]
        uy = uv[i1, 1] - uv[i0, 1]
        wx = uv[i2, 0] - uv[i0, 0]
        wy = uv[i2, 1] - uv[i0, 1]
        cr2 = ux * wy - uy * wx
        acr2 = abs(cr2)
        a3[i] = 0.5 * cr3
        a2[i] = 0.5 * cr2
        for k in range(3):
            p = f[i, k]
            q = f[i, (k + 1) % 3]
            r = f[i, (k + 2) % 3]
            d3 = ((v[q, 0] - v[p, 0]) * (v[r, 0] - v[p, 0]) + (v[q, 1] - v[p, 1]) * (v[r, 1] - v[p, 1])
                  + (v[q, 2] - v[p, 2]) * (v[r, 2] - v[p, 2]))
            d2 = (uv[q, 0] - uv[p, 0]) * (uv[r, 0] - uv[p, 0]) + (uv[q, 1] - uv[p, 1]) * (uv[r, 1] - uv[p, 1])
            err[3 * i + k] = abs(np.arctan2(acr2, d2) - np.arctan2(cr3, d3))
        # the 3D triangle in its frame: e = (l1, 0), g = (g.x, g.y) with y in the plane
        l1 = np.sqrt(ex * ex + ey * ey + ez * ez)
        if l1 > 0:
            gxf = (gx * ex + gy * ey + gz * ez) / l1
        else:
            gxf = 0.0
        # y = (e x g) x e / |..|: g.y = |e x g| / |e|
        gyf = cr3 / l1 if l1 > 0 else 0.0
        det = l1 * gyf
        if not abs(det) > 1e-300:
            sv[i, 0] = np.inf
            sv[i, 1] = np.inf
            continue
        # inverse of [[l1, gxf], [0, gyf]]
        i00 = gyf / det
        i01 = -gxf / det
        i11 = l1 / det
        ja = ux * i00
        jb = ux * i01 + wx * i11
        jc = uy * i00
        jd = uy * i01 + wy * i11
        qn = np.sqrt((ja + jd) ** 2 + (jc - jb) ** 2)
        rn = np.sqrt((ja - jd) ** 2 + (jb + jc) ** 2)
        sv[i, 0] = 0.5 * (qn + rn)
        sv[i, 1] = 0.5 * abs(qn - rn)
    return err, a3, a2, sv


def _summary(err, a3, a2, A3, A2, scale, sv, n_flipped, n_overlap) -> dict[str, float]:
    with np.errstate(divide="ignore", invalid="ignore"):
        la = np.abs(np.log(a2 * scale / a3))
    la = np.where(np.isfinite(la), la, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        qc = sv[:, 0] / sv[:, 1]
    w = a3 / A3
    finite = np.isfinite(qc)
    # a face of zero area on the part has no stretch (weight 0, singular values inf)
    with np.errstate(invalid="ignore"):
        l2 = np.sqrt(np.sum(np.where(w > 0, w * 0.5 * (sv[:, 0] ** 2 + sv[:, 1] ** 2), 0.0)))
    return {
        "angle_error_mean_deg": float(err.mean()),
        "angle_error_max_deg": float(err.max()),
        "area_distortion_mean": float(np.nansum(w * la)),
        "area_distortion_max": float(np.nanmax(la)) if np.any(np.isfinite(la)) else float("inf"),
        "conformal_ratio_mean": float(np.sum(w[finite] * qc[finite]) / max(w[finite].sum(), 1e-300)),
        "conformal_ratio_max": float(qc[finite].max()) if finite.any() else float("inf"),
        "l2_stretch": float(l2),
        "flipped_faces": n_flipped,
        "boundary_self_overlap": int(n_overlap),
        "area_3d": float(A3),
        "area_2d": float(A2),
    }
