"""Analytic surfaces meshed over an aperture, and the paper's built-in shapes.

Every built-in is a function ``shape(**params) -> Surface`` registered in
:data:`BUILTINS` with its parameters, defaults (mm) and a one-line description;
``polishpath surfaces`` lists them. All meshes come from
:func:`~polishpath.surfaces.mesher.triangulate_domain`, so triangles are well
shaped (30 degree minimum angle in the domain) and the count is met within 1 %.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, SpecError
from ..types import Surface
from .aperture import Aperture
from .mesher import triangulate_domain
from .sag import BSplineSurface, EvenAsphere, FunctionSag, SagSurface


def mesh_sag_surface(
    sag: SagSurface,
    aperture: Aperture,
    triangles: int,
    *,
    name: str,
    source: str,
    params: dict,
) -> Surface:
    """Mesh a height field ``z = sag(x, y)`` over an aperture.

    Parameters
    ----------
    sag : SagSurface
        Height function, mm.
    aperture : Aperture
        Outline in the x-y plane, mm.
    triangles : int
        Requested triangle count.

    Returns
    -------
    Surface
        Vertices exactly on the sag surface; ``Surface.sag`` is ``sag``.
    """

    def area_scale(p):
        gx, gy = sag.gradient(p[:, 0], p[:, 1])
        return np.sqrt(1.0 + gx * gx + gy * gy)

    uv, faces = triangulate_domain(aperture, triangles, area_scale)
    z = sag(uv[:, 0], uv[:, 1])
    if not np.all(np.isfinite(z)):
        raise ParameterError(f"the surface {name} is not defined over the whole aperture (NaN sag).", "Use a smaller aperture.")
    return Surface(np.c_[uv, z], faces, name=name, source=source, params=params, sag=sag)


def mesh_bspline_surface(
    bs: BSplineSurface, aperture: Aperture, triangles: int, *, name: str, source: str, params: dict
) -> tuple[Surface, np.ndarray]:
    """Mesh a tensor-product B-spline surface over an aperture in its (u, v) unit square.

    Returns
    -------
    surface : Surface
    uv : (V, 2) float64
        Parameters of each vertex (so ``bs.evaluate(u, v)`` reproduces it).
    """
    uv, faces = triangulate_domain(aperture, triangles, lambda p: bs.area_scale(p[:, 0], p[:, 1]))
    if uv.min() < -1e-12 or uv.max() > 1 + 1e-12:
        raise ParameterError("a B-spline aperture must lie inside the unit parameter square [0, 1] x [0, 1].")
    xyz = bs.evaluate(uv[:, 0], uv[:, 1])
    # keep the orientation so normals point to +z where the net is z-up
    return Surface(xyz, faces, name=name, source=source, params=params), uv


def hemisphere_surface(R: float = 30.0, angle: float = 90.0, triangles: int = 20000, *, source: str = "") -> Surface:
    """Spherical dome of radius ``R`` mm up to polar angle ``angle`` degrees (90: a hemisphere).

    The dome ``z = sqrt(R^2 - x^2 - y^2)`` is meshed in its stereographic
    domain: the map is conformal, so triangles stay well shaped to the rim
    where a lifted height field would have vertical slope.
    """
    if not R > 0:
        raise ParameterError(f"hemisphere radius R must be > 0 mm, got {R}.")
    if not 0 < angle <= 90:
        raise ParameterError(f"hemisphere angle must be in (0, 90] degrees, got {angle}.")
    rho_max = R * math.tan(math.radians(angle) / 2)

    def area_scale(p):
        r2 = (p * p).sum(axis=1)
        return (2 * R * R / (R * R + r2)) ** 2

    uv, faces = triangulate_domain(Aperture("circle", radius=rho_max), int(triangles), area_scale)
    r2 = (uv * uv).sum(axis=1)
    s = 2 * R * R / (R * R + r2)
    xyz = np.c_[uv[:, 0] * s, uv[:, 1] * s, R * (R * R - r2) / (R * R + r2)]
    if angle == 90:  # rim exactly on z = 0
        rim = np.isclose(r2, R * R, rtol=1e-12)
        xyz[rim, 2] = 0.0
    sag = FunctionSag(lambda x, y: np.sqrt(np.maximum(R * R - x * x - y * y, 0.0)), "sphere-dome", {"R": R})
    return Surface(xyz, faces, name="hemisphere", source=source, params={"R": R, "angle": angle, "triangles": int(triangles)}, sag=sag)


# ---- the paper's demo shapes ---------------------------------------------------------


def _saddle(size=40.0, R=50.0, triangles=5000, *, source=""):
    sag = FunctionSag(lambda x, y: (x * x - y * y) / (2 * R), "saddle", {"R": R})
    return mesh_sag_surface(sag, Aperture("rectangle", width=size, height=size), triangles,
                            name="saddle", source=source, params={"size": size, "R": R, "triangles": triangles})


def _sinusoidal(size=40.0, amplitude=2.0, wavelength=20.0, triangles=5000, *, source=""):
    k = 2 * math.pi / wavelength
    sag = FunctionSag(lambda x, y: amplitude * np.sin(k * x) * np.sin(k * y), "sinusoidal",
                      {"amplitude": amplitude, "wavelength": wavelength})
    return mesh_sag_surface(sag, Aperture("rectangle", width=size, height=size), triangles, name="sinusoidal",
                            source=source, params={"size": size, "amplitude": amplitude, "wavelength": wavelength, "triangles": triangles})


def _concave_convex(radius=20.0, amplitude=4.0, offset=9.0, width=6.0, triangles=5000, *, source=""):
    def f(x, y):
        g1 = np.exp(-((x - offset) ** 2 + y * y) / (2 * width**2))
        g2 = np.exp(-((x + offset) ** 2 + y * y) / (2 * width**2))
        return amplitude * (g1 - g2)

    sag = FunctionSag(f, "concave-convex", {"amplitude": amplitude, "offset": offset, "width": width})
    return mesh_sag_surface(sag, Aperture("circle", radius=radius), triangles, name="concave-convex", source=source,
                            params={"radius": radius, "amplitude": amplitude, "offset": offset, "width": width, "triangles": triangles})


def _pentagram(radius=25.0, inner_radius=None, R=60.0, triangles=3559, *, source=""):
    # a regular pentagram's notch radius is radius * sin(18 deg) / sin(126 deg)
    ir = radius * math.sin(math.radians(18)) / math.sin(math.radians(126)) if inner_radius is None else inner_radius
    sag = EvenAsphere(c=-1.0 / R, k=0.0)  # convex dome
    return mesh_sag_surface(sag, Aperture("star", radius=radius, inner_radius=ir, n_points=5), triangles, name="pentagram",
                            source=source, params={"radius": radius, "inner_radius": ir, "R": R, "triangles": triangles})


def _airfoil(chord=60.0, span=60.0, thickness=0.12, triangles=4563, *, source=""):
    # NACA 4-digit symmetric thickness (closed trailing edge), upper surface;
    # the leading 2 % of chord is left out (its slope is vertical at the nose).
    x0 = 0.02 * chord

    def f(x, y):
        xi = np.clip(x / chord, 0.0, 1.0)
        return 5 * thickness * chord * (0.2969 * np.sqrt(xi) - 0.1260 * xi - 0.3516 * xi**2 + 0.2843 * xi**3 - 0.1036 * xi**4)

    sag = FunctionSag(f, "naca-00xx", {"chord": chord, "thickness": thickness})
    ap = Aperture("polygon", points=((x0, -span / 2), (chord, -span / 2), (chord, span / 2), (x0, span / 2)))
    return mesh_sag_surface(sag, ap, triangles, name="airfoil", source=source,
                            params={"chord": chord, "span": span, "thickness": thickness, "triangles": triangles})


def default_bspline_net(size=40.0, height=6.0) -> np.ndarray:
    """The built-in bicubic surface's 5 x 5 control net: a free-form bump and dip."""
    g = np.linspace(-size / 2, size / 2, 5)
    X, Y = np.meshgrid(g, g, indexing="ij")
    Z = height * np.array(
        [[0.0, 0.2, 0.3, 0.2, 0.0],
         [0.1, 0.6, 0.4, -0.2, -0.3],
         [0.2, 0.9, 0.3, -0.5, -0.6],
         [0.1, 0.5, 0.0, -0.4, -0.2],
         [0.0, 0.1, -0.1, -0.1, 0.0]]
    )
    return np.stack([X, Y, Z], axis=2)


def _bspline(size=40.0, height=6.0, triangles=5000, *, source=""):
    bs = BSplineSurface(default_bspline_net(size, height), 3)
    surf, _ = mesh_bspline_surface(bs, Aperture("rectangle", width=1.0, height=1.0, center=(0.5, 0.5)), triangles,
                                   name="bspline", source=source, params={"size": size, "height": height, "triangles": triangles})
    return surf


def seat_outline(length: float, width: float, n: int = 400) -> np.ndarray:
    """Outline of a bicycle seat (rear at x = 0, nose at x = length), (n, 2) mm, counter-clockwise."""
    t = 0.5 * (1 - np.cos(np.linspace(0, math.pi, n // 2)))  # denser at the ends
    xi = t
    smooth = np.clip((xi - 0.3) / 0.45, 0, 1)
    smooth = smooth * smooth * (3 - 2 * smooth)
    h = 0.5 * width * np.sqrt(np.clip(1 - (2 * xi - 1) ** 2, 0, 1)) ** 0.6 * (1 - 0.68 * smooth)
    # lower edge rear -> nose, then upper edge nose -> rear (counter-clockwise);
    # each edge drops its last point, which the other edge starts with
    lower = np.c_[xi * length, -h][:-1]
    upper = np.c_[xi[::-1] * length, h[::-1]][:-1]
    return np.vstack([lower, upper])


def _bicycle_seat(length=270.0, width=150.0, Rx=400.0, Ry=120.0, triangles=5000, *, source=""):
    def f(x, y):
        return (x - 0.35 * length) ** 2 / (2 * Rx) - y * y / (2 * Ry)

    sag = FunctionSag(f, "bicycle-seat", {"Rx": Rx, "Ry": Ry})
    pts = seat_outline(length, width)
    ap = Aperture("polygon", points=tuple(map(tuple, pts)), smooth=True)
    return mesh_sag_surface(sag, ap, triangles, name="bicycle-seat", source=source,
                            params={"length": length, "width": width, "Rx": Rx, "Ry": Ry, "triangles": triangles})


@dataclass(frozen=True)
class Builtin:
    name: str
    make: Callable[..., Surface]
    defaults: dict
    description: str


def _defaults(fn) -> dict:
    import inspect

    return {k: p.default for k, p in inspect.signature(fn).parameters.items() if k != "source" and p.kind is p.POSITIONAL_OR_KEYWORD}


BUILTINS: dict[str, Builtin] = {
    b.name: b
    for b in [
        Builtin("hemisphere", hemisphere_surface, _defaults(hemisphere_surface),
                "spherical dome, radius R mm up to polar angle `angle` deg (the paper's Table 1 / Table 2 case)"),
        Builtin("saddle", _saddle, _defaults(_saddle), "z = (x^2 - y^2) / 2R over a size x size square (Table 1)"),
        Builtin("sinusoidal", _sinusoidal, _defaults(_sinusoidal), "z = A sin(2 pi x / L) sin(2 pi y / L) over a square (Fig. 10a)"),
        Builtin("concave-convex", _concave_convex, _defaults(_concave_convex), "a bump beside a dimple over a disc (Fig. 10c)"),
        Builtin("pentagram", _pentagram, _defaults(_pentagram), "five-pointed-star outline on a convex sphere of radius R (Table 1, Fig. 10b)"),
        Builtin("airfoil", _airfoil, _defaults(_airfoil), "upper surface of a NACA 00xx wing section, chord x span (Table 1, Fig. 10e)"),
        Builtin("bspline", _bspline, _defaults(_bspline), "bicubic B-spline surface from a 5 x 5 control net (Fig. 10d)"),
        Builtin("bicycle-seat", _bicycle_seat, _defaults(_bicycle_seat), "a bicycle seat, saddle-shaped, rear at x = 0 (Figs. 5-7)"),
    ]
}


#: sane range of a built-in's size-like parameters (extents), mm: a micrometre to 100 m
EXTENT_RANGE_MM = (1e-3, 1e5)
_EXTENTS = {"size", "radius", "chord", "span", "length", "width", "wavelength", "inner_radius"}
_CURVATURE_RADII = {"R", "Rx", "Ry"}  # signed; any size (a large radius is a nearly flat part)
_SIGNED_HEIGHTS = {"amplitude", "height", "offset"}


def check_builtin_parameter(name: str, key: str, value: float) -> None:
    """Refuse a built-in parameter outside its sane range, naming the range.

    Extents (sizes, radii of the outline, the hemisphere's R) must lie in
    :data:`EXTENT_RANGE_MM`; curvature radii must be at least 1 um in size;
    heights at most 100 m; the airfoil's thickness is a fraction of the chord.
    Infinite and NaN values are refused everywhere.
    """
    lo, hi = EXTENT_RANGE_MM
    if not math.isfinite(value):
        raise SpecError(f"parameter {key} of {name!r} must be finite, got {value!r}.")
    if key == "triangles":
        return  # the mesher checks the count and the memory it needs
    extent = key in _EXTENTS or (name == "hemisphere" and key == "R")
    if extent and value <= 0:
        raise SpecError(f"{name} parameter {key} must be > 0 mm, got {value:g}.")
    if extent and not lo <= value <= hi:
        raise SpecError(
            f"{name} parameter {key}={value:g} mm is outside the range polishpath meshes ({lo:g} to {hi:g} mm).",
            "Built-in sizes are in millimetres: e.g. hemisphere:R=30 is a 30 mm dome.",
        )
    if not extent and key in _CURVATURE_RADII and abs(value) < lo:
        raise SpecError(f"{name} parameter {key}={value:g} mm is a radius of curvature under {lo:g} mm.",
                        "Radii of curvature are in millimetres.")
    if key in _SIGNED_HEIGHTS and abs(value) > hi:
        raise SpecError(f"{name} parameter {key}={value:g} mm is larger than {hi:g} mm.", "Heights are in millimetres.")
    if key == "thickness" and not 0 < value <= 1:
        raise SpecError(f"airfoil thickness is a fraction of the chord in (0, 1], got {value:g}.", "e.g. thickness=0.12.")


def builtin_surface(name: str, params: dict | None = None, source: str | None = None) -> Surface:
    """Make a built-in surface by name with optional parameters.

    Parameters
    ----------
    name : str
        One of :data:`BUILTINS` (``polishpath surfaces`` lists them).
    params : dict, optional
        Parameters overriding the defaults (mm, degrees, ``triangles``).
    """
    if name not in BUILTINS:
        import difflib

        close = difflib.get_close_matches(name, list(BUILTINS), n=1)
        hint = f"Did you mean {close[0]!r}? " if close else ""
        raise SpecError(f"unknown built-in surface {name!r}.", f"{hint}Built-ins: {', '.join(BUILTINS)}.")
    b = BUILTINS[name]
    params = dict(params or {})
    unknown = set(params) - set(b.defaults)
    if unknown:
        raise SpecError(
            f"built-in {name!r} has no parameter {', '.join(sorted(unknown))}.",
            f"Its parameters: {', '.join(f'{k}={v}' for k, v in b.defaults.items())}.",
        )
    kw = {}
    for k, v in params.items():
        try:
            kw[k] = int(v) if k == "triangles" else (float(v) if v is not None else None)
        except (TypeError, ValueError):
            raise SpecError(f"parameter {k} of {name!r} must be a number, got {v!r}.") from None
        if k == "triangles" and float(v) != int(float(v)):
            raise SpecError(f"triangles must be a whole number, got {v!r}.")
        if kw[k] is not None:
            check_builtin_parameter(name, k, kw[k])
    src = source or (name + (":" + ",".join(f"{k}={v}" for k, v in params.items()) if params else ""))
    return b.make(**kw, source=src)
