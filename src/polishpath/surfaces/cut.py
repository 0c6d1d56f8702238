"""Cutting a disc-like patch out of a larger mesh (for example a scan that is not a disc itself).

A patch is the faces whose three vertices lie within a geodesic radius of a
centre vertex; distances are shortest paths along the mesh edges (Dijkstra,
``scipy.sparse.csgraph``), an upper bound of the true geodesic distance that
is close to it on a fine mesh.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError, ParameterError
from ..types import Surface

__all__ = ["geodesic_disc"]


def geodesic_disc(vertices: np.ndarray, faces: np.ndarray, centre: int, radius_mm: float, *,
                  name: str = "patch", source: str = "arrays") -> Surface:
    """The disc of faces within a geodesic radius of a vertex, checked as a :class:`Surface`.

    Parameters
    ----------
    vertices : (V, 3) float
        Vertex positions, mm.
    faces : (F, 3) int
        Triangles.
    centre : int
        Index of the centre vertex.
    radius_mm : float
        Geodesic radius (along the mesh edges), mm; > 0.
    name, source : str
        Recorded on the surface (``source`` gets the radius appended).

    Returns
    -------
    Surface
        The faces whose three vertices lie within ``radius_mm`` of ``centre``,
        largest connected component kept (``from_arrays(component="largest")``).

    Raises
    ------
    ParameterError
        ``centre`` is not a vertex index, or the radius is not a positive number.
    InputError
        The patch is not a disc (more or fewer than one boundary loop): a hole
        or a handle lies within the radius.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    from .. import meshops
    from . import from_arrays

    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if not (isinstance(centre, (int, np.integer)) and 0 <= int(centre) < len(v)):
        raise ParameterError(f"the centre vertex {centre!r} is not an index of the {len(v):,} vertices.",
                             "Pass an index in [0, V).")
    if not (isinstance(radius_mm, (int, float, np.floating)) and np.isfinite(radius_mm) and radius_mm > 0):
        raise ParameterError(f"the patch radius must be a positive number of mm, got {radius_mm!r}.")
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    w = np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1)
    g = coo_matrix((w, (e[:, 0], e[:, 1])), shape=(len(v), len(v))).tocsr()
    d = dijkstra(g.maximum(g.T), indices=int(centre), limit=radius_mm)
    ff = f[np.all(np.isfinite(d[f]), axis=1)]
    surf = from_arrays(v, ff, name=name, source=f"{source} (geodesic patch r={radius_mm:g} mm)", component="largest")
    loops = meshops.boundary_loops(surf.faces)
    if len(loops) != 1:
        raise InputError(f"the patch of radius {radius_mm:g} mm around vertex {int(centre)} has {len(loops)} boundary "
                         "loops, not 1.", "Use a smaller radius.")
    return surf
