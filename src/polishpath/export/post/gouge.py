"""Does a ball (sponge) tool of radius r fit the part along the path? The gouge check of a tool offset.

A ball whose centre runs at ``r`` along the normal touches the part at the
contact point only where the part's concave radius of curvature, in every
direction, is at least ``r``; where it is smaller the ball cuts into the part
beside the contact point (a gouge), and the dwell there polishes the wrong place.

Two figures, both computed here because no library does this for a dwell path:

* the smallest concave radius of curvature along the path, from consecutive
  dwell points and their normals (``|dp|^2 / -(dn . dp)`` where ``dn . dp < 0``;
  exact on a sphere, where ``dn = dp / R``). The pseudo-random path steps in all
  eight directions, so it samples the curvature across as well as along;
* with the mesh: the distance from the tool centres to the part (libigl's AABB
  tree or trimesh); a centre nearer than ``r`` means the ball is inside the part.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...types import Surface, ToolPath

__all__ = ["concave_radii", "gouge_check"]


def concave_radii(xyz: np.ndarray, normals: np.ndarray, pieces: np.ndarray) -> np.ndarray:
    """Concave radius of curvature of each step between consecutive dwell points, mm.

    Parameters
    ----------
    xyz, normals : (N, 3) float
        Dwell points (mm) and unit normals pointing from the part to the tool.
    pieces : (K + 1,) int
        Piece offsets; steps across a lift are left out.

    Returns
    -------
    (S,) float
        One radius per step within a piece; ``inf`` where the step is flat or convex.
    """
    dp = np.diff(xyz, axis=0)
    dn = np.diff(normals, axis=0)
    inside = np.ones(len(dp), bool)
    inside[np.asarray(pieces)[1:-1] - 1] = False
    dp, dn = dp[inside], dn[inside]
    s = np.einsum("ij,ij->i", dn, dp)
    l2 = np.einsum("ij,ij->i", dp, dp)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(s < -1e-15 * np.maximum(l2, 1e-300), l2 / np.maximum(-s, 1e-300), np.inf)


def gouge_check(tool_path: ToolPath, tool_radius: float, surface: Surface | None = None, *,
                max_points: int = 50_000) -> dict[str, Any]:
    """The gouge figures of a tool-radius offset, and a warning when the ball does not fit.

    Parameters
    ----------
    tool_path : ToolPath
    tool_radius : float
        Ball radius, mm (> 0).
    surface : Surface, optional
        The part's mesh: also measure how near the tool centres come to it.
    max_points : int
        Most tool centres measured against the mesh (evenly spread over the samples; for a
        ToolPath without samples, a streamed job's, over 8 curve points per dwell interval).

    Returns
    -------
    dict
        ``min_concave_radius_mm`` (inf on a convex part), ``concave_steps_under_radius``
        (steps whose concave radius is under ``tool_radius``), ``min_centre_distance_mm``
        and ``interference_mm`` (radius minus that distance, > 0: the ball is inside
        the part; a gouge when over ``interference_floor_mm``, the larger of 1 % of
        the radius and the curve's deviation from the faceted mesh + 0.01 mm) with a
        mesh, and ``warnings`` (list of sentences).
    """
    sp = tool_path.surface_path
    n = len(sp.xyz)
    pieces = np.asarray(sp.planar.pieces if sp.planar is not None else [0, n])
    radii = concave_radii(sp.xyz, sp.normals, pieces)
    rmin = float(radii.min()) if len(radii) else float("inf")
    under = int(np.sum(radii < tool_radius))
    out: dict[str, Any] = {"tool_radius_mm": float(tool_radius), "min_concave_radius_mm": rmin,
                           "concave_steps_under_radius": under, "steps": int(len(radii))}
    warnings = []
    if under:
        warnings.append(
            f"tool radius {tool_radius:g} mm exceeds the part's smallest concave radius of curvature along the "
            f"path, {rmin:.4g} mm ({under} of {len(radii)} steps are more tightly concave than the tool): the ball "
            f"cuts into the part beside the contact point there. Use a tool radius under {rmin:.4g} mm.")
    if surface is not None:
        from ...smooth import evaluate, point_mesh_distance
        from ..chunks import normals_at

        if len(tool_path.samples):
            step = max(1, -(-len(tool_path.samples) // max_points))
            u = tool_path.sample_params[::step]
            pts = tool_path.samples[::step]
        else:  # a streamed job's ToolPath holds no samples: the curve, 8 points per dwell interval
            dp = tool_path.dwell_params
            u = np.append((dp[:-1, None] + np.diff(dp)[:, None] * (np.arange(8) / 8.0)).ravel(), dp[-1:])
            u = u[:: max(1, -(-len(u) // max_points))]
            pts = evaluate(tool_path.curve, u)
        centres = pts + tool_radius * normals_at(tool_path, u)
        d = point_mesh_distance(centres, surface)
        dmin = float(d.min()) if len(d) else float("inf")
        out["min_centre_distance_mm"] = dmin
        out["interference_mm"] = float(tool_radius - dmin)
        out["centres_measured"] = int(len(d))
        # the smooth curve runs up to surface_deviation_max off the faceted mesh, so a true contact can
        # measure that much nearer than r: only a deeper interference (and over 1 % of r) is a gouge
        floor = max(0.01 * tool_radius, float(tool_path.stats.get("surface_deviation_max") or 0.0) + 0.01)
        out["interference_floor_mm"] = floor
        if tool_radius - dmin > floor:
            k = int(np.sum(d < tool_radius - floor))
            warnings.append(
                f"the tool centre comes within {dmin:.4g} mm of the part, {tool_radius - dmin:.3g} mm less than the "
                f"tool radius ({k} of {len(d)} measured centres): the ball is inside the part there (a gouge). "
                "Use a smaller tool radius.")
    out["warnings"] = warnings
    return out
