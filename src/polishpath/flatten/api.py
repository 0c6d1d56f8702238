"""``flatten(surface, method)``: one entry point for MABF, classic ABF, LSCM and the projection baseline."""

from __future__ import annotations

import time

import numpy as np

from .. import meshops
from ..defaults import DEFAULT_FLATTEN_METHOD
from ..errors import FlatteningError, ParameterError
from ..types import Flattening, Provenance, Region, Surface
from .metrics import flattening_metrics
from .topology import corner_tables, disc_topology, fill_holes, outer_loop_index

METHODS = ("mabf", "abf", "lscm", "projection")
LAYOUTS = ("midpoint", "least_squares", "midpoint_area")


def _layout(name: str, v, f, angles, solver: str, twins=None) -> np.ndarray:
    from .layout import least_squares_layout, midpoint_layout

    if name == "midpoint":
        return midpoint_layout(v, f, angles, sizes="propagate", twins=twins)
    if name == "midpoint_area":
        return midpoint_layout(v, f, angles, sizes="area")
    return least_squares_layout(v, f, angles, solver=solver)


def normalize_uv(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Scale planar coordinates so the planar area equals the 3D area, orient faces
    counter-clockwise (mirror if needed) and put the area centroid at the origin.

    Parameters
    ----------
    vertices : (V, 3) float
        mm.
    faces : (F, 3) int
    uv : (V, 2) float

    Returns
    -------
    (V, 2) float64
        mm.
    """
    uv = np.array(uv, dtype=np.float64)
    sa = meshops.face_areas(uv, faces, signed=True)
    if sa.sum() < 0:
        uv[:, 0] = -uv[:, 0]
        sa = -sa
    a3 = meshops.surface_area(vertices, faces)
    a2 = float(np.abs(sa).sum())
    if not np.isfinite(a2) or a2 <= 0:
        raise FlatteningError("The flattening collapsed to zero area.", "Try another method (--method lscm).")
    uv *= np.sqrt(a3 / a2)
    sa = meshops.face_areas(uv, faces, signed=True)
    cent = (uv[faces].mean(axis=1) * sa[:, None]).sum(axis=0) / sa.sum()
    return uv - cent


def flatten(
    surface: Surface,
    method: str = DEFAULT_FLATTEN_METHOD,
    *,
    layout: str | None = None,
    check: bool = True,
    **options,
) -> Flattening:
    """Flatten a disc-like surface (holes allowed) into the plane.

    Parameters
    ----------
    surface : Surface
        Manifold, one component, at least one boundary loop, no handles.
    method : {"mabf", "abf", "lscm", "projection"}
        ``"mabf"``: the paper's angle problem solved in matrix form (default);
        ``"abf"``: classic ABF by Lagrange-Newton (slow baseline);
        ``"lscm"``: libigl's least-squares conformal map (needs ``libigl``);
        ``"projection"``: the paper's projection baseline, orthogonal projection
        onto the best-fit plane (:func:`polishpath.flatten.projection.projection_flattening`:
        no disc check, no rescaling, takes no layout or option; its folds are the
        point of the baseline, so ``check`` does not apply).
    layout : {"midpoint", "least_squares", "midpoint_area"}, optional
        Angle-to-plane step for "mabf" / "abf". Default ``"midpoint"`` (the
        paper's breadth-first midpoint layout, sizes propagated from the parent
        edge; as accurate as the least-squares layout on converged angles and
        many times faster). ``"midpoint_area"`` keeps each triangle's 3D area
        (the paper's literal wording; measurably worse, kept for comparison).
    check : bool
        Raise :class:`FlatteningError` when the result has flipped triangles or a
        self-overlapping boundary; with False the result is returned and the
        counts are in ``metrics``.
    **options
        ``weights`` ("auto", "uniform", "inverse_square"; MABF, default "auto":
        uniform as in the paper, switching to ABF's 1/beta^2 weights if uniform
        weights drive a sliver towards zero), ``min_angle`` (radians, default 1
        degree), ``tol`` (default 1e-8: largest constraint residual, radians /
        log-sine units; below the ~1e-7 rad precision of angles from float32 STL
        coordinates), ``opt_tol`` (MABF, default 1e-4 rad: how close to the exact
        optimum the angles must be before the last steps only restore the
        constraints; 0 optimises to the end), ``max_iter``, ``solver`` ("auto",
        "cholmod", "superlu"), ``hole_weight`` (energy weight of the virtual
        faces filling holes, default 0.01).

    Returns
    -------
    Flattening
        ``uv`` in mm, planar area equal to the 3D area, area centroid at the origin,
        faces counter-clockwise.

    Raises
    ------
    ParameterError
        Unknown method, layout or option.
    MeshError subclasses
        The mesh is closed, non-manifold, in several pieces or has handles.
    FlatteningError
        The solve failed, or (with ``check``) the result flips or overlaps.
    """
    if method not in METHODS:
        raise ParameterError(f"Unknown flattening method {method!r}.", f"Use one of: {', '.join(METHODS)}.")
    if layout is not None and layout not in LAYOUTS:
        raise ParameterError(f"Unknown layout {layout!r}.", f"Use one of: {', '.join(LAYOUTS)}.")
    known = {"weights", "min_angle", "tol", "opt_tol", "max_iter", "solver", "hole_weight"}
    bad = set(options) - known
    if bad:
        raise ParameterError(f"Unknown flatten option(s): {', '.join(sorted(bad))}.", f"Known options: {', '.join(sorted(known))}.")
    if method == "projection":
        if layout is not None or options:
            raise ParameterError("method='projection' projects the vertices and takes no layout or option.",
                                 "Drop the layout and options.")
        from .projection import projection_flattening

        return projection_flattening(surface)
    t_start = time.perf_counter()
    v = surface.vertices
    f = surface.faces
    topo = disc_topology(v, f)
    loops = topo.loops
    F, V = len(f), len(v)
    solver = options.get("solver", "auto")
    min_angle = float(options.get("min_angle", np.radians(1.0)))
    tol = float(options.get("tol", 1e-8))
    params: dict = {"min_angle": min_angle, "tol": tol}
    timings: dict[str, float] = {}
    residuals: dict[str, np.ndarray] = {}
    extra: dict[str, float] = {}

    if method == "lscm":
        from .lscm import lscm_uv

        if layout is not None:
            raise ParameterError("the lscm method computes positions directly and takes no layout.", "Drop the layout option.")
        t0 = time.perf_counter()
        uv = lscm_uv(v, f, loops[outer_loop_index(v, loops)])
        timings["solve"] = time.perf_counter() - t0
        params = {}
    else:
        layout = layout or "midpoint"
        hole_weight = float(options.get("hole_weight", 0.01))
        vf, ff, n_virtual = fill_holes(v, f, loops)
        fw = None
        if n_virtual:
            fw = np.ones(len(ff))
            fw[F:] = hole_weight
        # the filled mesh's boundary is the outer loop (the hole rims became interior)
        bmask = topo.boundary_mask
        if n_virtual:
            bmask = np.zeros(len(vf), dtype=bool)
            bmask[loops[outer_loop_index(v, loops)]] = True
        t0 = time.perf_counter()
        tables = corner_tables(len(vf), ff, boundary_mask=bmask)
        if method == "mabf":
            from .mabf import mabf_angles

            weights = options.get("weights", "auto")
            if weights not in ("auto", "uniform", "inverse_square"):
                raise ParameterError(f"Unknown MABF weights {weights!r}.", "Use 'auto', 'uniform' or 'inverse_square'.")
            opt_tol = float(options.get("opt_tol", 1e-4))
            # "auto": uniform, inverse-square from the start again if a step drives a sliver to zero
            try:
                angles, res, st = mabf_angles(vf, ff, weights=weights, tables=tables, min_angle=min_angle, tol=tol,
                                              max_iter=int(options.get("max_iter", 50)), face_weight=fw, solver=solver,
                                              opt_tol=opt_tol)
            except FlatteningError as exc:
                if n_virtual:
                    raise _hole_fan_error(surface, vf, ff, tables, loops, exc.message) from exc
                raise
            params.update(weights=st["weights"], solver=solver, linear=st.get("linear", "none"))
            if st.get("linear") == "pcg":
                params["opt_tol"] = opt_tol  # the direct solve (filled holes) optimises to the end
            extra["factorizations"] = float(st["factorizations"])
        else:
            from .abf import abf_angles

            angles, res, st = abf_angles(vf, ff, min_angle=min_angle, tol=tol, max_iter=int(options.get("max_iter", 50)), face_weight=fw)
            params.update(weights="inverse_square")
        timings["angles"] = time.perf_counter() - t0
        extra["iterations"] = int(st["iterations"])
        extra["converged"] = bool(st.get("converged", True))
        worst = max(st["max_triangle_residual"], st["max_vertex_residual"], st["max_wheel_residual"])
        if not np.isfinite(worst) or worst > 1e-3:
            if n_virtual:
                raise _hole_fan_error(surface, vf, ff, tables, loops,
                                      f"The {method.upper()} angles did not converge (largest constraint residual "
                                      f"{worst:.2g} after {st['iterations']} steps).")
            raise FlatteningError(
                f"The {method.upper()} angles did not converge (largest constraint residual {worst:.2g} after {st['iterations']} steps).",
                "Try weights='inverse_square', a larger min_angle, more max_iter, or the lscm method (--method lscm).",
            )
        t0 = time.perf_counter()
        uvf = _layout(layout, vf, ff, angles, solver, twins=None if n_virtual else (topo.twin_face, topo.twin_slot))
        timings["layout"] = time.perf_counter() - t0
        uv = uvf[:V]
        angles = angles[:F]
        n_int_real = int(np.count_nonzero(tables.interior[:V]))
        residuals = {
            "triangle": res["triangle"][:F],
            "vertex": res["vertex"][:n_int_real],
            "wheel": res["wheel"][:n_int_real],
        }
        params.update(layout=layout, holes_filled=int(len(loops) - 1))
        if n_virtual:
            # the weight the solve ended with (MABF's "auto" stiffens fans that cannot hold their angles)
            params["hole_weight"] = max(hole_weight, 1.0) if st.get("hole_fans_stiffened") else hole_weight
            if st.get("hole_fans_stiffened"):
                params["hole_fans_stiffened"] = True
    uv = normalize_uv(v, f, uv)
    if method == "lscm":
        angles = meshops.corner_angles(uv, f)
    timings["total"] = time.perf_counter() - t_start
    metrics = flattening_metrics(surface, uv, boundary_edges=topo.boundary_edges)
    for k, r in residuals.items():
        metrics[f"max_{k}_residual"] = float(np.abs(r).max()) if len(r) else 0.0
    metrics.update(extra)
    metrics["seconds"] = timings["total"]
    flat = Flattening(
        surface=surface,
        uv=uv,
        angles=angles,
        residuals=residuals,
        metrics=metrics,
        timings=timings,
        provenance=Provenance("flatten", method, params=params, seed=None),
    )
    if check:
        nflip = int(metrics["flipped_faces"])
        nover = int(metrics["boundary_self_overlap"])
        if nflip or nover:
            raise FlatteningError(
                f"The {method.upper()} flattening of {surface.name!r} has {nflip} flipped triangle(s) and "
                f"{nover} crossing boundary-edge pair(s).",
                "Try another method or layout (--method abf, or layout='least_squares' in Python), cut the surface into "
                "less curved pieces, or pass check=False to inspect the result.",
            )
    return flat


def _hole_fan_error(surface: Surface, vf, ff, tables, loops, what: str) -> FlatteningError:
    """The error of an angle solve that failed on a mesh with holes: what the fans that
    close the holes do to their rims (the usual cause), measured, and what to do."""
    from .mabf import FOLD_EXCESS, _corner_angles

    rim = np.concatenate([lp for i, lp in enumerate(loops) if i != outer_loop_index(surface.vertices, loops)])
    sums = np.bincount(tables.corner_vertex, weights=_corner_angles(vf, ff), minlength=len(vf))[rim]
    excess = sums - 2.0 * np.pi  # 0 at a rim vertex whose fan lies flat beside its real faces
    folded = int(np.count_nonzero(excess > FOLD_EXCESS))
    return FlatteningError(
        f"{what} {surface.name!r} has {len(loops) - 1} hole(s), which the solve closes with fans of virtual "
        f"triangles around each hole's centroid; at {folded} rim vertex(es) those fans fold over the real faces "
        f"(3D angle sums up to 2 pi + {max(float(excess.max()), 0.0):.2f} rad), a ragged or strongly curved rim "
        f"that the angles cannot close around.",
        "Fill the holes in the mesh (a mesh-repair tool) or cut it so they open onto the outer boundary, or use "
        "--method lscm.",
    )


def boundary_region(flat: Flattening) -> Region:
    """The planar region covered by a flattening: outer loop and holes.

    Parameters
    ----------
    flat : Flattening

    Returns
    -------
    Region
        ``outer``: the boundary loop of largest enclosed |area| (counter-clockwise),
        ``holes``: the other loops (clockwise), in mm.
    """
    loops = meshops.boundary_loops(flat.surface.faces)
    if not loops:
        raise FlatteningError("The flattened mesh has no boundary loop.", "Flatten an open surface.")
    polys = [flat.uv[lp] for lp in loops]

    def area(p):
        x, y = p[:, 0], p[:, 1]
        return abs(0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)))

    i = int(np.argmax([area(p) for p in polys]))
    return Region(outer=polys[i], holes=tuple(p for k, p in enumerate(polys) if k != i))
