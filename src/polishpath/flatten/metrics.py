"""Distortion figures of any planar map of a surface."""

from __future__ import annotations

import numpy as np

from .. import meshops
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


def boundary_self_overlap(uv: np.ndarray, faces: np.ndarray) -> int:
    """Number of pairs of boundary edges that cross in the plane (not sharing a vertex).

    Parameters
    ----------
    uv : (V, 2) float
    faces : (F, 3) int

    Returns
    -------
    int
        0 for an embedding whose boundary loops are simple and disjoint.
    """
    import shapely

    be = meshops.boundary_edges(faces)
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


def flattening_metrics(surface: Surface, uv: np.ndarray) -> dict[str, float]:
    """Distortion of a planar map of ``surface``.

    Parameters
    ----------
    surface : Surface
        The 3D mesh.
    uv : (V, 2) float
        Planar vertex positions, mm, same indexing.

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
    v = surface.vertices
    f = surface.faces
    uv = np.asarray(uv, dtype=np.float64)
    beta = meshops.corner_angles(v, f)
    alpha = meshops.corner_angles(uv, f)
    err = np.degrees(np.abs(alpha - beta))
    a3 = meshops.face_areas(v, f)
    a2 = meshops.face_areas(uv, f)
    A3, A2 = a3.sum(), a2.sum()
    scale = A3 / A2 if A2 > 0 else np.nan
    with np.errstate(divide="ignore", invalid="ignore"):
        la = np.abs(np.log(a2 * scale / a3))
    la = np.where(np.isfinite(la), la, np.nan)
    sv = meshops.jacobian_singular_values(v, uv * np.sqrt(scale), f)  # part -> plane
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
        "flipped_faces": int(np.count_nonzero(flipped_faces(uv, f))),
        "boundary_self_overlap": int(boundary_self_overlap(uv, f)),
        "area_3d": float(A3),
        "area_2d": float(A2),
    }
