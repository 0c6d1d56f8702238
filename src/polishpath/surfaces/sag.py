"""Analytic optical surfaces: sag functions ``z = f(x, y)`` in millimetres.

Conventions (those of the optical design programs, so a prescription can be
typed in as it is):

* the surface vertex is at the origin, the optical axis is +z, and a positive
  curvature ``c = 1/R`` bends the surface toward +z;
* ``conic_sag`` is the standard conic ``c r^2 / (1 + sqrt(1 - (1 + k) c^2 r^2))``
  (k = 0 sphere, k = -1 paraboloid, k < -1 hyperboloid, -1 < k < 0 ellipsoid);
* even asphere adds ``a4 r^4 + a6 r^6 + ... + a20 r^20``;
* XY polynomial adds ``sum C_j x^p y^q`` in CODE V term order (C2 = x, C3 = y,
  C4 = x^2, C5 = xy, C6 = y^2, C7 = x^3, ...; CODE V's C1 is the conic constant,
  which we take as ``k``), optionally over a normalisation radius;
* Zernike sag adds ``sum c_j Z_j(rho, theta)``, ``rho = r / norm_radius``, in
  Fringe order (unnormalised, 37-term convention) or Standard order (Noll,
  RMS-normalised).

Every class is a small callable dataclass: ``surf(x, y) -> z`` (vectorised) and
``surf.gradient(x, y) -> (dz/dx, dz/dy)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from ..errors import ParameterError

_EPS_GRAD = 1e-6


class SagSurface:
    """Base: a height field ``z = sag(x, y)`` (mm) with a numerical gradient."""

    kind = "sag"

    def __call__(self, x, y):  # pragma: no cover - abstract
        raise NotImplementedError

    def gradient(self, x, y):
        """``(dz/dx, dz/dy)`` by central differences (analytic where overridden)."""
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        h = _EPS_GRAD * max(1.0, float(np.max(np.abs(np.r_[x.ravel(), y.ravel(), 1.0]))))
        gx = (self(x + h, y) - self(x - h, y)) / (2 * h)
        gy = (self(x, y + h) - self(x, y - h)) / (2 * h)
        return gx, gy

    def params(self) -> dict:
        return {}


def conic_sag(r2, c: float, k: float):
    """Conic sag for squared radius ``r2`` (mm^2), curvature ``c`` (1/mm), conic ``k``."""
    r2 = np.asarray(r2, dtype=np.float64)
    arg = 1.0 - (1.0 + k) * c * c * r2
    if np.any(arg < 0):
        rmax = math.sqrt(float(np.max(r2)))
        raise ParameterError(
            f"the conic (c={c:g}/mm, k={k:g}) is not defined out to r = {rmax:.4g} mm "
            "(the square root goes negative).",
            "Use a smaller aperture or a flatter curvature.",
        )
    return c * r2 / (1.0 + np.sqrt(arg))


@dataclass(frozen=True)
class EvenAsphere(SagSurface):
    """Conic plus even polynomial: ``z = conic(r) + sum_i a[i] r^(4 + 2 i)``.

    Parameters
    ----------
    c : float
        Vertex curvature, 1/mm (``1/R``; 0 for a plane).
    k : float
        Conic constant.
    a : tuple of float
        Coefficients a4, a6, ..., a20 (mm^-3, mm^-5, ...), at most 9.
    """

    c: float = 0.0
    k: float = 0.0
    a: tuple[float, ...] = ()
    kind = "asphere"

    def __post_init__(self):
        if len(self.a) > 9:
            raise ParameterError(f"even asphere takes at most 9 coefficients (a4..a20), got {len(self.a)}.")
        for name, v in (("c", self.c), ("k", self.k), *((f"a{4 + 2 * i}", v) for i, v in enumerate(self.a))):
            if not np.isfinite(v):
                raise ParameterError(f"asphere coefficient {name} is not finite ({v}).")

    def __call__(self, x, y):
        r2 = np.asarray(x, dtype=np.float64) ** 2 + np.asarray(y, dtype=np.float64) ** 2
        z = conic_sag(r2, self.c, self.k)
        p = r2 * r2
        for ai in self.a:
            z = z + ai * p
            p = p * r2
        return z

    def params(self):
        return {"c": self.c, "k": self.k, "a": list(self.a)}


def Sphere(R: float) -> EvenAsphere:
    """A sphere of radius ``R`` mm (positive: centre on +z). ``R = inf`` gives a plane."""
    if R == 0 or not np.isfinite(R) and not np.isinf(R):
        raise ParameterError(f"sphere radius must be non-zero, got {R}.")
    return EvenAsphere(c=0.0 if np.isinf(R) else 1.0 / R, k=0.0)


def xy_term_exponents(n_terms: int) -> list[tuple[int, int]]:
    """Exponents ``(p, q)`` of ``x^p y^q`` for CODE V XY-polynomial terms C2, C3, ...

    Order: x, y, x^2, xy, y^2, x^3, x^2 y, x y^2, y^3, ...
    """
    out = []
    d = 1
    while len(out) < n_terms:
        for q in range(d + 1):
            out.append((d - q, q))
        d += 1
    return out[:n_terms]


@dataclass(frozen=True)
class XYPolynomial(SagSurface):
    """Conic base plus ``sum_j C_j (x/R0)^p (y/R0)^q`` in CODE V term order.

    Parameters
    ----------
    c, k : float
        Base conic curvature (1/mm) and conic constant.
    coeffs : tuple of float
        C2, C3, C4, ... (mm, for the normalised monomials).
    norm_radius : float
        Normalisation radius R0, mm (1 for raw monomials in mm).
    """

    c: float = 0.0
    k: float = 0.0
    coeffs: tuple[float, ...] = ()
    norm_radius: float = 1.0
    kind = "xy-polynomial"

    def __post_init__(self):
        if self.norm_radius <= 0:
            raise ParameterError(f"XY polynomial normalisation radius must be > 0, got {self.norm_radius}.")

    def __call__(self, x, y):
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        z = conic_sag(x * x + y * y, self.c, self.k)
        xn, yn = x / self.norm_radius, y / self.norm_radius
        for cj, (p, q) in zip(self.coeffs, xy_term_exponents(len(self.coeffs))):
            if cj:
                z = z + cj * xn**p * yn**q
        return z

    def params(self):
        return {"c": self.c, "k": self.k, "coeffs": list(self.coeffs), "norm_radius": self.norm_radius}


@lru_cache(maxsize=None)
def fringe_nm(j: int) -> tuple[int, int]:
    """Radial order n and signed azimuthal order m of Fringe Zernike term ``j`` (1-based)."""
    if j < 1:
        raise ParameterError(f"Zernike index must be >= 1, got {j}.")
    count = 0
    kk = 0
    while True:
        for m in range(kk, -1, -1):
            n = 2 * kk - m
            for s in ((1, -1) if m > 0 else (1,)):
                count += 1
                if count == j:
                    return n, s * m
        kk += 1


@lru_cache(maxsize=None)
def noll_nm(j: int) -> tuple[int, int]:
    """Radial order n and signed azimuthal order m of Noll (Standard) Zernike term ``j``."""
    if j < 1:
        raise ParameterError(f"Zernike index must be >= 1, got {j}.")
    count = 0
    n = 0
    while True:
        for mabs in range(n % 2, n + 1, 2):
            reps = 1 if mabs == 0 else 2
            for _ in range(reps):
                count += 1
                if count == j:
                    if mabs == 0:
                        return n, 0
                    return n, (mabs if count % 2 == 0 else -mabs)
        n += 1


def zernike_radial(n: int, m: int, rho):
    """Radial polynomial ``R_n^|m|(rho)``."""
    m = abs(m)
    rho = np.asarray(rho, dtype=np.float64)
    out = np.zeros_like(rho)
    for s in range((n - m) // 2 + 1):
        coef = (-1) ** s * math.factorial(n - s) / (
            math.factorial(s) * math.factorial((n + m) // 2 - s) * math.factorial((n - m) // 2 - s)
        )
        out = out + coef * rho ** (n - 2 * s)
    return out


def zernike_term(n: int, m: int, rho, theta, normalized: bool):
    """Zernike polynomial ``Z_n^m(rho, theta)``; cos for m >= 0, sin for m < 0."""
    r = zernike_radial(n, m, rho)
    if m > 0:
        z = r * np.cos(m * theta)
    elif m < 0:
        z = r * np.sin(-m * theta)
    else:
        z = r
    if normalized:
        z = z * math.sqrt((n + 1) if m == 0 else 2 * (n + 1))
    return z


@dataclass(frozen=True)
class ZernikeSag(SagSurface):
    """Conic base plus Zernike terms over a normalisation radius.

    Parameters
    ----------
    c, k : float
        Base conic curvature (1/mm) and conic constant.
    coeffs : tuple of float
        Z1, Z2, ... coefficients in mm.
    norm_radius : float
        Normalisation radius, mm.
    order : {"fringe", "standard"}
        Fringe (University of Arizona, unnormalised) or Standard (Noll, normalised).
    """

    c: float = 0.0
    k: float = 0.0
    coeffs: tuple[float, ...] = ()
    norm_radius: float = 1.0
    order: str = "fringe"
    kind = "zernike"

    def __post_init__(self):
        if self.order not in ("fringe", "standard"):
            raise ParameterError(f"Zernike order must be 'fringe' or 'standard', got {self.order!r}.")
        if self.norm_radius <= 0:
            raise ParameterError(f"Zernike normalisation radius must be > 0, got {self.norm_radius}.")

    def __call__(self, x, y):
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        z = conic_sag(x * x + y * y, self.c, self.k)
        rho = np.hypot(x, y) / self.norm_radius
        th = np.arctan2(y, x)
        nm = fringe_nm if self.order == "fringe" else noll_nm
        for j, cj in enumerate(self.coeffs, start=1):
            if cj:
                n, m = nm(j)
                z = z + cj * zernike_term(n, m, rho, th, normalized=self.order == "standard")
        return z

    def params(self):
        return {"c": self.c, "k": self.k, "coeffs": list(self.coeffs), "norm_radius": self.norm_radius, "order": self.order}


@dataclass(frozen=True)
class FunctionSag(SagSurface):
    """A sag given by a Python function (used by the built-in demo shapes)."""

    func: object = None
    kind_name: str = "function"
    info: dict = field(default_factory=dict)

    @property
    def kind(self):  # type: ignore[override]
        return self.kind_name

    def __call__(self, x, y):
        return self.func(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))

    def params(self):
        return dict(self.info)


@dataclass(frozen=True)
class BSplineSurface:
    """A tensor-product B-spline surface ``S(u, v)`` from a control net.

    Parameters
    ----------
    control_net : (m, n, 3) float
        Control points, mm.
    degree : int
        Degree in both directions (3: bicubic).

    Uses clamped uniform knot vectors on [0, 1] in both directions; evaluation
    goes through :class:`scipy.interpolate.BSpline` design matrices.
    """

    control_net: np.ndarray
    degree: int = 3
    kind = "bspline"

    def __post_init__(self):
        net = np.asarray(self.control_net, dtype=np.float64)
        if net.ndim != 3 or net.shape[2] != 3:
            raise ParameterError(f"B-spline control net must have shape (m, n, 3), got {net.shape}.")
        if min(net.shape[:2]) < self.degree + 1:
            raise ParameterError(
                f"a degree-{self.degree} B-spline needs at least {self.degree + 1} control points "
                f"in each direction, got {net.shape[0]} x {net.shape[1]}."
            )
        if not np.all(np.isfinite(net)):
            raise ParameterError("B-spline control net contains NaN or infinite values.")
        object.__setattr__(self, "control_net", net)

    def knots(self, count: int) -> np.ndarray:
        p = self.degree
        inner = np.linspace(0.0, 1.0, count - p + 1)
        return np.r_[np.zeros(p), inner, np.ones(p)]

    def _basis(self, t, count, deriv=0):
        from scipy.interpolate import BSpline

        t = np.clip(np.asarray(t, dtype=np.float64), 0.0, 1.0)
        kn = self.knots(count)
        if deriv == 0:
            return BSpline.design_matrix(t, kn, self.degree).toarray()
        # derivative basis: differentiate each basis function
        eye = np.eye(count)
        return np.stack([BSpline(kn, eye[i], self.degree).derivative(deriv)(t) for i in range(count)], axis=1)

    def evaluate(self, u, v, du: int = 0, dv: int = 0) -> np.ndarray:
        """Points (or partial derivatives) at parameters ``u, v`` in [0, 1], shape (N, 3)."""
        m, n, _ = self.control_net.shape
        bu = self._basis(u, m, du)
        bv = self._basis(v, n, dv)
        return np.einsum("ia,ib,abk->ik", bu, bv, self.control_net)

    def area_scale(self, u, v) -> np.ndarray:
        """``|S_u x S_v|``: 3D area per unit parameter area, shape (N,)."""
        su = self.evaluate(u, v, du=1)
        sv = self.evaluate(u, v, dv=1)
        return np.linalg.norm(np.cross(su, sv), axis=1)

    def params(self):
        return {"control_net": self.control_net.tolist(), "degree": self.degree}
