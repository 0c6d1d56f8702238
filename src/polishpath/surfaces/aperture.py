"""Apertures: the outline of the part in the plane of its parameter domain (mm).

An aperture is an outer loop and optional holes. Curved outlines (circle,
annulus) are sampled at the edge length the mesher asks for, so the boundary
vertices lie exactly on the circle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import ParameterError

APERTURE_TYPES = ("circle", "rectangle", "polygon", "annulus", "star")


@dataclass(frozen=True)
class Aperture:
    """Outline of the region to mesh.

    Parameters
    ----------
    kind : str
        One of ``circle``, ``rectangle``, ``polygon``, ``annulus``, ``star``.
    radius : float
        Circle / annulus outer radius, star outer (tip) radius, mm.
    inner_radius : float
        Annulus hole radius, or star inner (notch) radius, mm.
    width, height : float
        Rectangle size, mm.
    points : (n, 2) array
        Polygon vertices, mm (for ``polygon``).
    n_points : int
        Number of star tips (5: a pentagram).
    rotation : float
        Rotation of the outline, degrees.
    center : (2,) float
        Centre of the outline, mm.
    holes : tuple of (m, 2) arrays
        Extra hole polygons, mm.
    smooth : bool
        The polygon samples a smooth curve: resample it at the mesh edge length
        instead of keeping every given point as a corner.
    """

    kind: str = "circle"
    radius: float = 25.0
    inner_radius: float = 0.0
    width: float = 50.0
    height: float = 50.0
    points: tuple = ()
    n_points: int = 5
    rotation: float = 0.0
    center: tuple[float, float] = (0.0, 0.0)
    holes: tuple = field(default=())
    smooth: bool = False

    def __post_init__(self):
        if self.kind not in APERTURE_TYPES:
            raise ParameterError(f"unknown aperture {self.kind!r}.", f"Choose one of: {', '.join(APERTURE_TYPES)}.")
        if self.kind in ("circle", "annulus", "star") and not self.radius > 0:
            raise ParameterError(f"{self.kind} aperture radius must be > 0 mm, got {self.radius}.")
        if self.kind == "annulus" and not 0 < self.inner_radius < self.radius:
            raise ParameterError(
                f"annulus inner radius must be between 0 and the outer radius {self.radius} mm, got {self.inner_radius}."
            )
        if self.kind == "star" and not 0 < self.inner_radius < self.radius:
            raise ParameterError(
                f"star inner (notch) radius must be between 0 and the tip radius {self.radius} mm, got {self.inner_radius}."
            )
        if self.kind == "star" and self.n_points < 3:
            raise ParameterError(f"a star needs at least 3 tips, got {self.n_points}.")
        if self.kind == "rectangle" and not (self.width > 0 and self.height > 0):
            raise ParameterError(f"rectangle size must be > 0 mm, got {self.width} x {self.height}.")
        if self.kind == "polygon":
            pts = np.asarray(self.points, dtype=np.float64)
            if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
                raise ParameterError("polygon aperture needs at least 3 points given as [[x, y], ...] in mm.")
            if not np.all(np.isfinite(pts)):
                raise ParameterError("polygon aperture has NaN or infinite coordinates.")
            if abs(_area(pts)) <= 0:
                raise ParameterError("polygon aperture has zero area.")

    # -- geometry ---------------------------------------------------------------------
    def loops(self, edge: float) -> list[np.ndarray]:
        """Boundary loops (outer counter-clockwise, holes clockwise) sampled at about ``edge`` mm."""
        c = np.asarray(self.center, dtype=np.float64)
        rot = math.radians(self.rotation)
        out: list[np.ndarray] = []
        if self.kind in ("circle", "annulus"):
            out.append(_circle(self.radius, edge))
            if self.kind == "annulus":
                out.append(_circle(self.inner_radius, edge)[::-1])
        elif self.kind == "rectangle":
            w, h = self.width / 2, self.height / 2
            out.append(_densify(np.array([[-w, -h], [w, -h], [w, h], [-w, h]]), edge))
        elif self.kind == "star":
            k = self.n_points
            ang = np.pi / 2 + np.arange(2 * k) * np.pi / k
            r = np.where(np.arange(2 * k) % 2 == 0, self.radius, self.inner_radius)
            out.append(_densify(np.c_[r * np.cos(ang), r * np.sin(ang)], edge))
        else:
            pts = np.asarray(self.points, dtype=np.float64)
            if _area(pts) < 0:
                pts = pts[::-1]
            out.append(_resample(pts, edge) if self.smooth else _densify(pts, edge))
        for hole in self.holes:
            hp = np.asarray(hole, dtype=np.float64)
            if _area(hp) > 0:
                hp = hp[::-1]
            out.append(_densify(hp, edge))
        rm = np.array([[math.cos(rot), -math.sin(rot)], [math.sin(rot), math.cos(rot)]])
        return [loop @ rm.T + c for loop in out]

    def area(self) -> float:
        """Exact area of the outline (mm^2; circles exactly, not as polygons)."""
        if self.kind == "circle":
            a = math.pi * self.radius**2
        elif self.kind == "annulus":
            a = math.pi * (self.radius**2 - self.inner_radius**2)
        elif self.kind == "rectangle":
            a = self.width * self.height
        else:
            a = abs(_area(self.loops(1e9)[0]))
        return a - sum(abs(_area(np.asarray(h, dtype=float))) for h in self.holes)

    def params(self) -> dict:
        d = {"type": self.kind}
        if self.kind in ("circle", "annulus", "star"):
            d["radius"] = self.radius
        if self.kind in ("annulus", "star"):
            d["inner_radius"] = self.inner_radius
        if self.kind == "star":
            d["n_points"] = self.n_points
        if self.kind == "rectangle":
            d["width"], d["height"] = self.width, self.height
        if self.kind == "polygon":
            d["points"] = np.asarray(self.points).tolist()
        if self.rotation:
            d["rotation"] = self.rotation
        if any(self.center):
            d["center"] = list(self.center)
        return d


def _area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _circle(r: float, edge: float) -> np.ndarray:
    n = max(12, int(math.ceil(2 * math.pi * r / max(edge, 1e-12))))
    t = np.arange(n) * (2 * math.pi / n)
    return np.c_[r * np.cos(t), r * np.sin(t)]


def _resample(poly: np.ndarray, edge: float) -> np.ndarray:
    """Points at equal arc length about ``edge`` apart along a closed polyline."""
    closed = np.vstack([poly, poly[:1]])
    seg = np.hypot(*np.diff(closed, axis=0).T)
    s = np.r_[0.0, np.cumsum(seg)]
    n = max(8, int(math.ceil(s[-1] / max(edge, 1e-12))))
    t = np.arange(n) * (s[-1] / n)
    return np.c_[np.interp(t, s, closed[:, 0]), np.interp(t, s, closed[:, 1])]


def _densify(poly: np.ndarray, edge: float) -> np.ndarray:
    """Split polygon sides so no piece is longer than ``edge``; keeps the corners."""
    out = []
    n = len(poly)
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        L = float(np.hypot(*(b - a)))
        k = max(1, int(math.ceil(L / max(edge, 1e-12))))
        t = np.arange(k)[:, None] / k
        out.append(a + t * (b - a))
    return np.vstack(out)
