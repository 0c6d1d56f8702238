"""Surfaces in: mesh files, analytic optical surfaces, the paper's built-in shapes.

The one entry point is :func:`load_surface`, which takes whatever a user
types as SURFACE on the command line (a mesh path, a built-in name with
``:key=value`` parameters, an inline analytic spec, or a ``.toml`` spec) and
returns a checked :class:`~polishpath.types.Surface` in millimetres.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError, SpecError
from ..types import Surface
from .analytic import BUILTINS, builtin_surface, hemisphere_surface, mesh_bspline_surface, mesh_sag_surface
from .aperture import Aperture
from .io import MESH_FORMATS, UNITS, read_mesh_file, unit_scale
from .sag import BSplineSurface, EvenAsphere, Sphere, XYPolynomial, ZernikeSag
from .spec import ANALYTIC_TYPES, analytic_from_dict, parse_inline, read_toml, split_inline_aperture
from .validate import validate_mesh

__all__ = [
    "ANALYTIC_TYPES",
    "Aperture",
    "BSplineSurface",
    "BUILTINS",
    "EvenAsphere",
    "MESH_FORMATS",
    "Sphere",
    "UNITS",
    "XYPolynomial",
    "ZernikeSag",
    "builtin_surface",
    "describe_surface",
    "from_arrays",
    "hemisphere_surface",
    "load_mesh",
    "load_surface",
    "mesh_bspline_surface",
    "mesh_sag_surface",
    "validate_mesh",
]


def from_arrays(
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    name: str = "mesh",
    source: str = "arrays",
    component: str = "refuse",
    scale: float = 1.0,
) -> Surface:
    """A checked :class:`Surface` from vertex and face arrays.

    Parameters
    ----------
    vertices : (V, 3) float
        Vertex positions (multiplied by ``scale`` to give mm).
    faces : (F, 3) int
        Triangles.
    component : {"refuse", "largest"}
        What to do with several disconnected pieces.

    Raises
    ------
    polishpath.errors.MeshError
        (a subclass naming the problem) for input that cannot be repaired.
    """
    v = np.asarray(vertices, dtype=np.float64) * float(scale)
    v, f, findings = validate_mesh(v, faces, component=component, name=name)
    return Surface(v, f, name=name, source=source, params={"scale": float(scale), "component": component}, findings=findings)


def load_mesh(path: str | Path, *, units: str | None = None, scale: float | None = None, component: str = "refuse") -> Surface:
    """Read, check and repair a mesh file (STL, OBJ, PLY, OFF).

    Parameters
    ----------
    path : str or Path
        Mesh file.
    units : str, optional
        Units of the file (``mm`` default, ``m``, ``cm``, ``um``, ``in``).
    scale : float, optional
        Extra factor to millimetres.
    component : {"refuse", "largest"}
        What to do with several disconnected pieces.
    """
    p = Path(path)
    v, f = read_mesh_file(p)
    factor = unit_scale(units, scale)
    surf = from_arrays(v, f, name=p.stem, source=str(p), component=component, scale=factor)
    params = dict(surf.params, units=units or "mm", file_vertices=int(len(v)), file_faces=int(len(f)))
    out = Surface(surf.vertices, surf.faces, name=surf.name, source=surf.source, params=params, findings=surf.findings)
    from ..resources import units_hint

    hint = units_hint(out) if units is None and scale is None else ""
    if hint:
        from ..types import Finding

        out = dataclasses.replace(out, findings=out.findings + (Finding("units", hint, 0, False, "warning"),))
    return out


def load_surface(
    spec: str | Path | Surface,
    *,
    units: str | None = None,
    scale: float | None = None,
    component: str = "refuse",
) -> Surface:
    """Whatever the user calls SURFACE, as a checked :class:`Surface` in mm.

    Parameters
    ----------
    spec : str, Path or Surface
        A mesh file (``.stl .obj .ply .off``), a ``.toml`` spec, a built-in
        name with optional ``:key=value,...`` parameters (``polishpath surfaces``
        lists them), or an analytic surface ``sphere|asphere|xy-polynomial|zernike:...``.
    units, scale, component
        For mesh files: see :func:`load_mesh`.

    Examples
    --------
    >>> s = load_surface("hemisphere:R=30,triangles=1119")  # doctest: +SKIP
    >>> s = load_surface("part.stl", units="m")  # doctest: +SKIP
    """
    if component not in COMPONENT_CHOICES:
        raise ParameterError(f"--component must be 'refuse' or 'largest', got {component!r}.",
                             "'refuse' (default) stops at a mesh of several pieces; 'largest' keeps the largest piece.")
    if isinstance(spec, Surface):
        return spec
    text = str(spec)
    p = Path(text)
    suffix = p.suffix.lower().lstrip(".")
    if suffix == "toml":
        return load_toml_surface(p, units=units, scale=scale, component=component)
    if suffix in MESH_FORMATS or p.exists() or "/" in text or "\\" in text:
        return load_mesh(p, units=units, scale=scale, component=component)
    name, params = parse_inline(text)
    if (name in BUILTINS or name in ANALYTIC_TYPES) and (units is not None or scale is not None):
        _refuse_mesh_options(text, units, scale)
    if name in BUILTINS:
        return builtin_surface(name, params, source=text)
    if name in ANALYTIC_TYPES:
        surf, ap = split_inline_aperture(params)
        return analytic_from_dict({"type": name, **surf}, ap, source=text)
    import difflib

    close = difflib.get_close_matches(name, list(BUILTINS) + list(ANALYTIC_TYPES), n=1)
    raise SpecError(
        f"{text!r} is neither a mesh file that exists, nor a built-in surface, nor an analytic surface type.",
        (f"Did you mean {close[0]!r}? " if close else "")
        + f"Built-ins: {', '.join(BUILTINS)}; analytic: {', '.join(ANALYTIC_TYPES)}; "
        f"mesh files: {', '.join('.' + e for e in MESH_FORMATS)}.",
    )


COMPONENT_CHOICES = ("refuse", "largest")


def _refuse_mesh_options(what: str, units: str | None, scale: float | None) -> None:
    given = " and ".join(x for x, v in (("--units", units), ("--scale", scale)) if v is not None)
    raise ParameterError(
        f"{given} applies to mesh files only, and {what!r} is not one: built-in and analytic surfaces are in mm.",
        "Drop the option, or give the sizes in mm (e.g. hemisphere:R=30).",
    )


def load_toml_surface(path: Path, **kw: Any) -> Surface:
    """A surface from a TOML spec file (see :mod:`polishpath.surfaces.spec`)."""
    data = read_toml(path)
    if "surface" not in data or not isinstance(data["surface"], dict):
        raise SpecError(f"{path.name} has no [surface] table.", 
                        'A surface spec starts with a [surface] table, e.g. [surface] type = "sphere", R = 100, '
                        'triangles = 5000, then [aperture] type = "circle", radius = 25 (examples/surface-asphere.toml '
                        "in the source tree).")
    s = dict(data["surface"])
    if "mesh" in s:
        mesh = Path(s.pop("mesh"))
        if not mesh.is_absolute():
            mesh = path.parent / mesh
        return load_mesh(mesh, units=s.pop("units", kw.get("units")), scale=s.pop("scale", kw.get("scale")),
                         component=s.pop("component", kw.get("component", "refuse")))
    if kw.get("units") is not None or kw.get("scale") is not None:
        _refuse_mesh_options(str(path), kw.get("units"), kw.get("scale"))
    if "builtin" in s:
        name = s.pop("builtin")
        return builtin_surface(name, s, source=str(path))
    if "type" not in s:
        raise SpecError(f"{path.name}: [surface] needs one of type = ..., builtin = ... or mesh = ....")
    return analytic_from_dict(s, data.get("aperture"), source=str(path))


def describe_surface(surface: Surface) -> dict[str, Any]:
    """Figures ``polishpath info`` prints: counts, boundary loops, area, bounds, findings.

    Returns
    -------
    dict
        ``vertices``, ``faces``, ``boundary_loops`` (count), ``loop_vertices``
        (list, longest first), ``loop_lengths_mm``, ``area_mm2``, ``bbox_min``,
        ``bbox_max``, ``edge_length_mm`` (min/mean/max), ``min_angle_deg``,
        ``euler_characteristic``, ``findings``.
    """
    from .. import meshops

    v, f = surface.vertices, surface.faces
    loops = meshops.boundary_loops(f)
    lengths = [float(np.linalg.norm(v[lp] - v[np.roll(lp, -1)], axis=1).sum()) for lp in loops]
    edges, _ = meshops.edge_face_counts(f)
    el = np.linalg.norm(v[edges[:, 0]] - v[edges[:, 1]], axis=1)
    ang = np.degrees(meshops.corner_angles(v, f))
    return {
        "name": surface.name,
        "source": surface.source,
        "vertices": surface.n_vertices,
        "faces": surface.n_faces,
        "boundary_loops": len(loops),
        "loop_vertices": [int(len(lp)) for lp in loops],
        "loop_lengths_mm": lengths,
        "area_mm2": meshops.surface_area(v, f),
        "bbox_min": v.min(axis=0).tolist(),
        "bbox_max": v.max(axis=0).tolist(),
        "edge_length_mm": {"min": float(el.min()), "mean": float(el.mean()), "max": float(el.max())},
        "min_angle_deg": float(ang.min()),
        "euler_characteristic": int(len(v) - len(edges) + len(f)),
        "disc_like": len(loops) == 1 and (len(v) - len(edges) + len(f)) == 1,
        "findings": [x.to_dict() for x in surface.findings],
        "remesh": surface.params.get("remesh", {"applied": False}),
        "params": surface.params,
    }
