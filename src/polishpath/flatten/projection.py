"""The projection method's "flattening" (the paper's baseline of Table 2).

Orthogonal projection of the vertices onto the part's best-fit plane: no angle
problem, no rescaling, and no disc check (any mesh with a boundary projects).
The surface may fold over the plane; the folded layers overlap in the plane and
:func:`polishpath.mapping.map_to_surface` lifts a point to the highest one along
the recorded ``plane_normal``. Reached as ``flatten(surface, "projection")``.
"""

from __future__ import annotations

import time

import numpy as np

from .. import meshops
from ..types import Flattening, Provenance, Surface


def projection_flattening(surface: Surface) -> Flattening:
    """The projection method's "flattening": orthogonal projection onto the best-fit plane.

    Parameters
    ----------
    surface : Surface
        The part, (V, 3) vertices in mm.

    Returns
    -------
    Flattening
        ``uv`` (V, 2) mm = coordinates in the plane through the vertex centroid
        spanned by the two leading principal axes (no rescaling: the projection
        method plans with the true spacing on the projection). The plane normal
        is chosen so that most of the area projects counter-clockwise; lifting a
        planar point back with :func:`polishpath.mapping.map_to_surface` is then
        lifting it along that normal. ``metrics``: ``folded_triangles`` (project clockwise: the
        surface folds over the plane; where layers overlap the highest one is
        taken), ``degenerate_triangles`` (project to zero area, e.g. vertical
        walls), ``area_ratio`` (projected / true area). ``provenance.params``
        holds ``plane_normal`` and ``plane_origin``.
    """
    t0 = time.perf_counter()
    v = surface.vertices
    c = v.mean(axis=0)
    # PCA: the right singular vectors of the centred vertices
    _, _, vt = np.linalg.svd(v - c, full_matrices=False)
    e1, e2 = vt[0], vt[1]
    nrm = np.cross(e1, e2)
    uv = (v - c) @ np.stack([e1, e2], axis=1)
    sa = meshops.face_areas(uv, surface.faces, signed=True)
    if sa.sum() < 0:  # flip so that the surface projects counter-clockwise
        e2 = -e2
        nrm = -nrm
        uv[:, 1] = -uv[:, 1]
        sa = -sa
    a3 = meshops.face_areas(v, surface.faces)
    eps = 1e-12 * max(float(np.ptp(uv, axis=0).max()), 1e-300) ** 2
    metrics = {
        "folded_triangles": float(np.count_nonzero(sa < -eps)),
        "degenerate_triangles": float(np.count_nonzero(np.abs(sa) <= eps)),
        "area_ratio": float(np.abs(sa).sum() / a3.sum()) if a3.sum() > 0 else float("nan"),
    }
    prov = Provenance("flatten", "projection",
                      {"plane_normal": nrm.tolist(), "plane_origin": c.tolist(), "plane_axes": [e1.tolist(), e2.tolist()]})
    return Flattening(surface=surface, uv=uv, angles=meshops.corner_angles(uv, surface.faces),
                      metrics=metrics, timings={"total": time.perf_counter() - t0}, provenance=prov)
