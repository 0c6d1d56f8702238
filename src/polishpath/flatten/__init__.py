"""polishpath.flatten: surface -> plane.

``flatten(surface, method="mabf" | "abf" | "lscm" | "projection") -> Flattening``

* MABF (the paper, section 2): angles solved in matrix form with the
  per-triangle block eliminated, then the breadth-first midpoint layout.
* ABF (Sheffer & de Sturler 2001): the classic Lagrange-Newton baseline.
* LSCM (libigl): the peer, optional dependency ``libigl``.
* projection: the paper's projection baseline (orthogonal projection onto the
  best-fit plane; the mapping lifts a point to the highest folded layer).
"""

from .abf import abf_angles
from .api import LAYOUTS, METHODS, boundary_region, flatten, normalize_uv
from .io import load_obj_uv, save_obj
from .layout import centre_face, least_squares_layout, midpoint_layout
from .mabf import constraint_residuals, mabf_angles
from .metrics import boundary_self_overlap, flattening_metrics, flipped_faces
from .projection import projection_flattening

__all__ = [
    "LAYOUTS",
    "METHODS",
    "abf_angles",
    "boundary_region",
    "boundary_self_overlap",
    "centre_face",
    "constraint_residuals",
    "flatten",
    "flattening_metrics",
    "flipped_faces",
    "least_squares_layout",
    "load_obj_uv",
    "mabf_angles",
    "midpoint_layout",
    "normalize_uv",
    "projection_flattening",
    "save_obj",
]
