"""libigl's least-squares conformal map, the peer the benchmarks compare against."""

from __future__ import annotations

import numpy as np

from ..errors import require


def lscm_uv(vertices: np.ndarray, faces: np.ndarray, outer_loop: np.ndarray) -> np.ndarray:
    """LSCM through ``igl.lscm`` with two pinned boundary vertices.

    Parameters
    ----------
    vertices : (V, 3) float
        mm.
    faces : (F, 3) int
    outer_loop : (n,) int
        Vertex indices of the outer boundary loop.

    Returns
    -------
    uv : (V, 2) float64
        Not yet scaled or centred. The pins are the pair of outer-boundary
        vertices farthest apart in 3D (of a subsample of the loop), placed at
        their 3D distance on the x axis.
    """
    igl = require("igl", "LSCM flattening", extra="peers")
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    loop = np.asarray(outer_loop, dtype=np.int64)
    sub = loop[:: max(1, len(loop) // 200)]
    d = np.linalg.norm(v[sub][:, None] - v[sub][None], axis=2)
    i, j = np.unravel_index(np.argmax(d), d.shape)
    b = np.array([sub[i], sub[j]], dtype=np.int64)
    bc = np.array([[0.0, 0.0], [float(d[i, j]), 0.0]])
    out = igl.lscm(v, f, b, bc)
    uv = out[0] if isinstance(out, tuple) else out
    return np.asarray(uv, dtype=np.float64)[:, :2]
