"""Read a finished run folder and derive what the report draws.

Everything here works from the files alone, read through the run-folder
format (:mod:`polishpath.runfolder`: ``summary.json``, ``run.npz``, ``job.toml``
and a ``simulation/`` subfolder), so a report can be rebuilt long after the job
ran. Units: mm, radians inside, degrees where a name says so.
"""

from __future__ import annotations

import math

import numpy as np

# the path maths of the report, re-exported for its public API
from ..pathops import DIRECTION_NAMES, step_lengths, step_mask, turn_angles_deg  # noqa: F401
from ..pathops import direction_counts as grid_directions  # noqa: F401
from ..runfolder import RunData, read_run  # noqa: F401  (RunData: the report's figures take it)

#: the report's name for :func:`polishpath.runfolder.read_run` (part of its public API)
load_run = read_run


# --- derived quantities -------------------------------------------------------------


def angle_error_deg(vertices: np.ndarray, faces: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Mean absolute angle error of each face between the plane and the part.

    Parameters
    ----------
    vertices : (V, 3) float
        Part mesh, mm.
    faces : (F, 3) int
    angles : (F, 3) float
        Planar corner angles, radians.

    Returns
    -------
    (F,) float64
        Mean over the 3 corners of ``|angles - corner_angles(part)|``, degrees.
    """
    from ..meshops import corner_angles

    a3 = corner_angles(vertices, faces)
    return np.degrees(np.abs(np.asarray(angles, dtype=float) - a3).mean(axis=1))


def area_distortion(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Log area ratio of each face, ``log((A_plane / sum A_plane) / (A_part / sum A_part))``.

    Returns
    -------
    (F,) float64
        0 where the face keeps its share of the area; NaN for degenerate faces.
    """
    from ..meshops import face_areas

    a2 = face_areas(uv, faces)
    a3 = face_areas(vertices, faces)
    r2 = a2 / max(a2.sum(), 1e-300)
    r3 = a3 / max(a3.sum(), 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.log(r2 / r3)
    out[~np.isfinite(out)] = np.nan
    return out


def decimate_indices(n: int, max_points: int) -> np.ndarray:
    """Indices of at most ``max_points`` evenly spread points out of ``n`` (first and last kept).

    Returns
    -------
    (n',) int64
        ``arange(n)`` when ``n <= max_points``.
    """
    if n <= max_points:
        return np.arange(n, dtype=np.int64)
    idx = np.unique(np.linspace(0, n - 1, max_points).round().astype(np.int64))
    return idx


def cluster_mesh(vertices: np.ndarray, faces: np.ndarray, max_faces: int,
                 values: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Coarsen a mesh for display by vertex clustering on a regular grid.

    Parameters
    ----------
    vertices : (V, d) float
    faces : (F, 3) int
    max_faces : int
        Aim for at most about this many faces.
    values : (F,) float, optional
        Per-face values carried along (faces that survive keep theirs).

    Returns
    -------
    vertices : (V', d) float64
    faces : (F', 3) int64
    values : (F',) float or None
        The input itself when ``F <= max_faces``. Display only: the result may
        have small holes or folds.
    """
    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces, dtype=np.int64)
    if len(f) <= max_faces:
        return v, f, values
    from ..meshops import face_areas

    lo = v.min(axis=0)
    dim = v.shape[1]
    area = float(face_areas(v, f).sum())
    # a surface of area A in cells of size h occupies about A / h^2 cells (= new vertices, ~ F'/2)
    h = math.sqrt(max(area, 1e-300) / (max_faces / 2.0))
    for _ in range(12):
        key = np.floor((v - lo) / h).astype(np.int64)
        flat = key[:, 0]
        for k in range(1, dim):
            flat = flat * (int(key[:, k].max()) + 1) + key[:, k]
        uniq, inv = np.unique(flat, return_inverse=True)
        inv = inv.ravel()
        nf = inv[f]
        keep = (nf[:, 0] != nf[:, 1]) & (nf[:, 1] != nf[:, 2]) & (nf[:, 0] != nf[:, 2])
        if keep.sum() <= max_faces:
            break
        h *= math.sqrt(keep.sum() / max_faces) * 1.05
    nf = nf[keep]
    # drop duplicate faces that differ only by order
    srt = np.sort(nf, axis=1)
    _, first = np.unique(srt, axis=0, return_index=True)
    first.sort()
    nf = nf[first]
    counts = np.bincount(inv, minlength=len(uniq)).astype(float)
    nv = np.zeros((len(uniq), dim))
    for k in range(dim):
        nv[:, k] = np.bincount(inv, weights=v[:, k], minlength=len(uniq)) / np.maximum(counts, 1)
    vals = None if values is None else np.asarray(values)[keep][first]
    return nv, nf, vals
