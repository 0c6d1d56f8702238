"""Meshing an analytic surface over an aperture to a requested triangle count.

The surface is given as a map from a 2D parameter domain to 3D (a sag surface
lifts ``(x, y) -> (x, y, sag)``; the hemisphere uses the inverse stereographic
map, which is conformal and so keeps triangles well shaped up to the rim).
The domain is triangulated by Shewchuk's Triangle (quality Delaunay, minimum
angle 30 degrees) with a per-triangle area bound divided by the local 3D area
scale, so the 3D triangles come out near-uniform in size. The bound is scaled
until the triangle count is within 1 % of the request.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..errors import ParameterError
from .aperture import Aperture

MIN_ANGLE_DEG = 30.0
COUNT_TOLERANCE = 0.01
#: refuse when the count reached is further than this from the request (small counts the outline cannot meet)
COUNT_REFUSE = 0.10
MAX_TRIANGLES = 20_000_000


def area_switch(area: float) -> str:
    """Triangle's ``a`` switch value: plain decimal digits, never an exponent.

    Triangle reads the number after ``a`` as digits and ``.`` only, so
    ``1.05e+13`` would be read as area 1.05 followed by the ``e`` switch (a
    fine mesh of a huge domain that exhausts memory).

    Parameters
    ----------
    area : float
        Maximum triangle area (> 0, finite), in the domain's units squared.
    """
    if not (math.isfinite(area) and area > 0):
        raise ParameterError(f"the mesher's triangle area bound must be a positive number, got {area!r}.")
    text = np.format_float_positional(float(area), precision=12, unique=False, fractional=False, trim="-")
    if float(text) <= 0:  # pragma: no cover - precision=12 significant digits keeps tiny areas non-zero
        raise ParameterError(f"triangle area bound {area!r} is too small to write.")
    return text


def _hole_points(loops: list[np.ndarray]) -> np.ndarray:
    import shapely

    pts = []
    for h in loops[1:]:
        poly = shapely.Polygon(h)
        p = poly.representative_point()
        pts.append([p.x, p.y])
    return np.array(pts, dtype=np.float64).reshape(-1, 2)


def _pslg(loops: list[np.ndarray]) -> dict:
    verts = np.vstack(loops)
    segs = []
    off = 0
    for loop in loops:
        n = len(loop)
        idx = np.arange(n) + off
        segs.append(np.c_[idx, np.roll(idx, -1)])
        off += n
    d = {"vertices": verts, "segments": np.vstack(segs)}
    holes = _hole_points(loops)
    if len(holes):
        d["holes"] = holes
    return d


def triangulate_domain(
    aperture: Aperture,
    triangles: int,
    area_scale: Callable[[np.ndarray], np.ndarray] | None = None,
    *,
    min_angle: float = MIN_ANGLE_DEG,
    max_iter: int = 12,
) -> tuple[np.ndarray, np.ndarray]:
    """Quality triangulation of an aperture with about ``triangles`` faces of equal 3D area.

    Parameters
    ----------
    aperture : Aperture
        Outline (outer loop and holes) in the parameter domain.
    triangles : int
        Requested number of triangles (met within 1 %, or as close as the
        outline allows for very small counts).
    area_scale : callable, optional
        ``J(points (n, 2)) -> (n,)``: 3D area per unit domain area. None: 1.
    min_angle : float
        Minimum angle of the domain triangulation, degrees.

    Returns
    -------
    uv : (V, 2) float64
        Domain vertex positions.
    faces : (F, 3) int64
        Counter-clockwise triangles.
    """
    import triangle as tr

    from .. import resources

    if triangles < 2:
        raise ParameterError(f"a surface needs at least 2 triangles, got {triangles}.")
    if triangles > MAX_TRIANGLES:
        raise ParameterError(f"{triangles} triangles is more than polishpath meshes (20 million).",
                             "Ask for fewer triangles (triangles=...).")
    resources.check(resources.estimate(triangles), "this mesh",
                    "Ask for fewer triangles (triangles=...).")
    J = area_scale if area_scale is not None else (lambda p: np.ones(len(p)))

    # estimate the 3D area from a fine sampling of the domain
    base = _pslg(aperture.loops(math.sqrt(aperture.area()) / 40))
    coarse = tr.triangulate(base, f"pq{min_angle}a{area_switch(aperture.area() / 3000)}")
    cv, cf = coarse["vertices"], coarse["triangles"]
    cen = cv[cf].mean(axis=1)
    carea = _areas(cv, cf)
    jc = np.maximum(J(cen), 1e-12)
    area3d = float((carea * jc).sum())
    jmin, jmax = float(jc.min()), float(jc.max())
    # 3D length per domain length along the boundary sets the boundary sampling
    jbnd = float(np.median(np.maximum(J(np.vstack(base["vertices"])), 1e-12)))

    scale = 1.0
    best = None
    for _ in range(max_iter):
        a3 = scale * area3d / triangles  # target 3D triangle area
        edge3 = math.sqrt(4.0 * a3 / math.sqrt(3.0))
        # boundary spacing in the domain at the local scale of the boundary
        pslg = _pslg(aperture.loops(edge3 / math.sqrt(jbnd)))
        first = tr.triangulate(pslg, f"pq{min_angle}a{area_switch(a3 / jmin)}")
        if jmax / jmin > 1.01:
            cen = first["vertices"][first["triangles"]].mean(axis=1)
            first["triangle_max_area"] = (a3 / np.maximum(J(cen), 1e-12)).reshape(-1, 1)
            res = tr.triangulate(first, f"rpq{min_angle}a")
        else:
            res = first
        nf = len(res["triangles"])
        err = (nf - triangles) / triangles
        if best is None or abs(err) < abs(best[0]):
            best = (err, res)
        if abs(err) <= COUNT_TOLERANCE:
            break
        scale *= (nf / triangles) ** 1.0
    err, res = best
    if abs(err) > COUNT_REFUSE:
        n_got = len(res["triangles"])
        raise ParameterError(
            f"asked for {triangles} triangles; the closest quality mesh of this outline has {n_got} "
            f"({100 * err:+.0f} %).",
            f"Ask for at least {max(int(math.ceil(n_got * 1.2)), 2 * triangles)} triangles." if err > 0
            else f"Ask for {n_got} triangles or fewer.",
        )
    uv = np.asarray(res["vertices"], dtype=np.float64)
    faces = np.asarray(res["triangles"], dtype=np.int64)
    # Triangle keeps input vertices even when unused (never here, but be safe)
    used = np.zeros(len(uv), bool)
    used[faces.ravel()] = True
    if not used.all():
        remap = -np.ones(len(uv), np.int64)
        remap[used] = np.arange(used.sum())
        uv, faces = uv[used], remap[faces]
    sa = 0.5 * ((uv[faces[:, 1], 0] - uv[faces[:, 0], 0]) * (uv[faces[:, 2], 1] - uv[faces[:, 0], 1])
                - (uv[faces[:, 2], 0] - uv[faces[:, 0], 0]) * (uv[faces[:, 1], 1] - uv[faces[:, 0], 1]))
    faces[sa < 0] = faces[sa < 0][:, ::-1]
    return uv, faces


def _areas(v, f):
    a = v[f[:, 1]] - v[f[:, 0]]
    b = v[f[:, 2]] - v[f[:, 0]]
    return 0.5 * np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
