"""Surface specs: ``name:key=value,...`` strings and TOML files.

A SURFACE argument is one of

* a mesh file: ``part.stl``, ``part.obj``, ``part.ply``, ``part.off``;
* a built-in shape with optional parameters: ``hemisphere``,
  ``hemisphere:R=30,triangles=100220``;
* an analytic surface with scalar parameters:
  ``asphere:R=80,k=-1,a4=1e-7,aperture=annulus,radius=25,inner_radius=6``;
* a ``.toml`` spec file (see ``examples/surface-zernike-annulus.toml``):

  .. code-block:: toml

     [surface]
     type = "zernike"          # sphere | asphere | xy-polynomial | zernike | bspline
     R = 200.0                 # base radius of curvature, mm (or c = 1/R in 1/mm)
     k = 0.0
     order = "fringe"          # or "standard" (Noll)
     norm_radius = 25.0
     coeffs = [0, 0, 0, 0.002, 0.001]
     triangles = 8000

     [aperture]
     type = "annulus"          # circle | rectangle | polygon | annulus | star
     radius = 25.0
     inner_radius = 6.0

  A TOML spec may instead name a built-in (``builtin = "hemisphere"`` with
  its parameters) or a mesh file (``mesh = "part.stl"``, ``units = "m"``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from .. import fileio
from ..errors import ParameterError, SpecError
from .aperture import APERTURE_TYPES, Aperture
from .sag import BSplineSurface, EvenAsphere, XYPolynomial, ZernikeSag

ANALYTIC_TYPES = ("sphere", "asphere", "xy-polynomial", "zernike", "bspline")
_APERTURE_KEYS = {"radius", "inner_radius", "width", "height", "points", "n_points", "rotation", "center", "holes"}


def parse_inline(spec: str) -> tuple[str, dict[str, Any]]:
    """Split ``"name:key=value,key=value"`` into the name and a dict of values.

    Values are parsed as int, float, or left as strings.
    """
    name, _, rest = spec.partition(":")
    name = name.strip()
    params: dict[str, Any] = {}
    if rest.strip():
        for item in rest.split(","):
            if not item.strip():
                continue
            if "=" not in item:
                raise SpecError(
                    f"surface parameter {item.strip()!r} in {spec!r} has no value.",
                    "Write parameters as name:key=value,key=value, e.g. hemisphere:R=30,triangles=5000.",
                )
            k, _, v = item.partition("=")
            k = k.strip()
            if k in params:
                raise SpecError(
                    f"surface parameter {k} is given twice in {spec!r} ({params[k]!r} and {_number(v.strip())!r}).",
                    f"Give {k} once.",
                )
            params[k] = _number(v.strip())
    return name, params


def _number(v: str):
    try:
        return int(v)
    except ValueError:
        pass
    try:
        return float(v)
    except ValueError:
        return v


def read_toml(path: str | Path) -> dict[str, Any]:
    """Read a surface spec TOML file, its problems raised as :class:`SpecError`."""
    return fileio.read_toml(path, "spec file", SpecError)


def aperture_from_dict(d: dict[str, Any]) -> Aperture:
    """Build an :class:`Aperture` from ``{"type": ..., "radius": ..., ...}``."""
    d = dict(d)
    kind = d.pop("type", d.pop("aperture", "circle"))
    if kind not in APERTURE_TYPES:
        raise SpecError(f"unknown aperture type {kind!r}.", f"Choose one of: {', '.join(APERTURE_TYPES)}.")
    unknown = set(d) - _APERTURE_KEYS
    if unknown:
        raise SpecError(f"unknown aperture parameter(s) {', '.join(sorted(unknown))}.",
                        f"Aperture parameters: {', '.join(sorted(_APERTURE_KEYS))}.")
    kw: dict[str, Any] = {"kind": kind}
    for k, v in d.items():
        try:
            kw[k] = _aperture_value(k, v)
        except (TypeError, ValueError):
            raise SpecError(f"aperture parameter {k} must be {'a list of points' if k in ('points', 'holes', 'center') else 'a number'}"
                            f", got {v!r}.", "e.g. radius = 25.0 (mm).") from None
    return Aperture(**kw)


def _aperture_value(k: str, v: Any) -> Any:
    """One aperture parameter as its type; TypeError / ValueError for a wrong value."""
    if isinstance(v, bool):
        raise TypeError(k)
    if k == "points":
        return tuple(tuple(map(float, p)) for p in v)
    if k == "holes":
        return tuple(tuple(tuple(map(float, p)) for p in h) for h in v)
    if k == "center":
        return tuple(map(float, v))
    if k == "n_points":
        if float(v) != int(float(v)):
            raise ValueError(k)
        return int(v)
    out = float(v)
    if not math.isfinite(out):
        raise ValueError(k)
    return out


def _curvature(d: dict[str, Any]) -> float:
    if "c" in d and "R" in d:
        raise SpecError("give either the curvature c or the radius R, not both.")
    if "c" in d:
        return float(d.pop("c"))
    if "R" in d:
        R = float(d.pop("R"))
        if R == 0:
            raise SpecError("radius of curvature R = 0 is not a surface.", "Use R = inf (or c = 0) for a plane.")
        return 0.0 if math.isinf(R) else 1.0 / R
    return 0.0


def _indexed(d: dict[str, Any], prefix: str, start: int, step: int = 1) -> list[float]:
    """Collect scalar keys like a4, a6 ... or Z1, Z2 ... into a list (inline specs)."""
    found = {}
    for k in list(d):
        if k.startswith(prefix) and k[len(prefix):].isdigit():
            found[int(k[len(prefix):])] = float(d.pop(k))
    if not found:
        return []
    out = []
    for idx in range(start, max(found) + 1, step):
        out.append(found.pop(idx, 0.0))
    if found:
        raise SpecError(f"coefficient name(s) {', '.join(prefix + str(i) for i in found)} are not valid.")
    return out


def _refuse_non_finite(kind: str, d: dict[str, Any]) -> None:
    """Every number of a surface spec finite (``R = inf``, a plane, the one infinity allowed); SpecError names it."""
    for key, v in d.items():
        if isinstance(v, (bool, str)) or v is None:
            continue
        try:
            a = np.asarray(v, dtype=np.float64)
        except (TypeError, ValueError):
            continue  # not numbers: the type checks below name it
        bad = np.isnan(a) if key == "R" else ~np.isfinite(a)
        if bad.any():
            raise SpecError(f"{kind} surface: {key} has {int(bad.sum())} NaN or infinite value(s) of {a.size}.",
                            "Every coefficient must be a finite number (R = inf, a plane, is the one infinity).")


def analytic_from_dict(surface: dict[str, Any], aperture: dict[str, Any] | None, source: str):
    """Build and mesh an analytic surface from spec dictionaries.

    Parameters
    ----------
    surface : dict
        ``type`` (sphere | asphere | xy-polynomial | zernike | bspline), its
        coefficients and ``triangles``.
    aperture : dict or None
        Aperture spec; defaults to a 25 mm radius circle (the unit square in
        (u, v) for a B-spline).
    """
    from ..types import Surface
    from .analytic import mesh_bspline_surface, mesh_sag_surface

    d = dict(surface)
    kind = d.pop("type")
    if kind not in ANALYTIC_TYPES:
        raise SpecError(f"unknown analytic surface type {kind!r}.", f"Choose one of: {', '.join(ANALYTIC_TYPES)}.")
    _refuse_non_finite(kind, d)
    triangles = d.pop("triangles", 5000)
    if isinstance(triangles, bool) or not isinstance(triangles, (int, float)) or float(triangles) != int(triangles):
        raise SpecError(f"{kind} surface: triangles must be a whole number, got {triangles!r}.", "e.g. triangles = 8000.")
    triangles = int(triangles)
    d.pop("units", None)
    params = {"type": kind, **{k: v for k, v in surface.items() if k != "type"}}
    try:
        if kind == "bspline":
            net = np.asarray(d.pop("control_net"), dtype=np.float64)
            deg = int(d.pop("degree", 3))
            sag_obj = BSplineSurface(net, deg)
        else:
            c = _curvature(d)
            k = float(d.pop("k", 0.0))
            if kind == "sphere":
                sag_obj = EvenAsphere(c=c, k=0.0)
            elif kind == "asphere":
                a = d.pop("a", None)
                a = [float(x) for x in a] if a is not None else _indexed(d, "a", 4, 2)
                sag_obj = EvenAsphere(c=c, k=k, a=tuple(a))
            elif kind == "xy-polynomial":
                co = d.pop("coeffs", None)
                co = [float(x) for x in co] if co is not None else _indexed(d, "C", 2)
                sag_obj = XYPolynomial(c=c, k=k, coeffs=tuple(co), norm_radius=float(d.pop("norm_radius", 1.0)))
            else:
                co = d.pop("coeffs", None)
                co = [float(x) for x in co] if co is not None else _indexed(d, "Z", 1)
                sag_obj = ZernikeSag(c=c, k=k, coeffs=tuple(co), norm_radius=float(d.pop("norm_radius", 25.0)),
                                     order=str(d.pop("order", "fringe")))
    except KeyError as exc:
        raise SpecError(f"{kind} surface spec is missing {exc.args[0]!r}.") from None
    except (TypeError, ValueError) as exc:
        if isinstance(exc, ParameterError):
            raise
        raise SpecError(f"{kind} surface spec has a bad value: {exc}.") from None
    if d:
        raise SpecError(f"unknown parameter(s) for a {kind} surface: {', '.join(sorted(d))}.")
    if kind == "bspline":
        ap = aperture_from_dict(aperture) if aperture else Aperture("rectangle", width=1.0, height=1.0, center=(0.5, 0.5))
        surf, _ = mesh_bspline_surface(sag_obj, ap, triangles, name="bspline", source=source,
                                       params={**params, "aperture": ap.params()})
        return surf
    ap = aperture_from_dict(aperture) if aperture else Aperture("circle", radius=25.0)
    surf = mesh_sag_surface(sag_obj, ap, triangles, name=kind, source=source, params={**params, "aperture": ap.params()})
    assert isinstance(surf, Surface)
    return surf


def split_inline_aperture(params: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """Separate aperture keys (``aperture=annulus,radius=..``) from surface keys in an inline spec."""
    p = dict(params)
    if "aperture" not in p and not (_APERTURE_KEYS & set(p)):
        return p, None
    ap = {"type": p.pop("aperture", "circle")}
    for k in list(p):
        if k in _APERTURE_KEYS:
            ap[k] = p.pop(k)
    return p, ap
