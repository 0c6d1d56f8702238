"""Classic ABF (Sheffer & de Sturler 2001): Lagrange-Newton on the full nonlinear problem.

The baseline the paper's MABF replaces. Unknowns are all corner angles and all
Lagrange multipliers (triangle, vertex, wheel); each Newton step solves the
whole indefinite KKT system ``[[H, J^T], [J, 0]]`` (size ``4F + 2 Vi``) with a
sparse LU, where ``H`` includes the second derivatives of the wheel condition.
No elimination, no reuse: that is the point of the comparison.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .. import meshops
from ..errors import FlatteningError
from .mabf import constraint_residuals
from .topology import corner_tables, vertex_sum_matrix, wheel_pattern


def abf_angles(
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    min_angle: float = np.radians(1.0),
    tol: float = 1e-8,
    max_iter: int = 50,
    face_weight: np.ndarray | None = None,
) -> tuple[np.ndarray, dict[str, np.ndarray], dict]:
    """Solve the ABF angle problem by Lagrange-Newton.

    Parameters
    ----------
    vertices : (V, 3) float
        mm.
    faces : (F, 3) int
        A manifold disc (holes filled beforehand).
    min_angle : float
        Targets are clamped to ``[min_angle, pi - 2 min_angle]``, radians.
    tol : float
        Stop when every constraint residual and the scaled gradient of the
        Lagrangian are below ``tol``.
    max_iter : int
    face_weight : (F,) float, optional
        Extra multiplier of each face's energy weight.

    Returns
    -------
    angles : (F, 3) float64
        radians.
    residuals : dict of str -> ndarray
        ``"triangle"``, ``"vertex"``, ``"wheel"``.
    stats : dict
        ``iterations``, ``kkt_size``, residual maxima, ``seconds``.

    Notes
    -----
    Energy: ``sum ((alpha - phi) / phi)^2`` with ``phi`` the 3D angles scaled at
    interior vertices to sum to 2 pi (ABF's optimal angles).
    """
    t0 = time.perf_counter()
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    F = len(f)
    n = 3 * F
    t = corner_tables(len(v), f)
    beta = np.clip(meshops.corner_angles(v, f).ravel(), min_angle, np.pi - 2.0 * min_angle)
    B = vertex_sum_matrix(t)
    vsum = B @ beta
    rows = t.interior_index[t.corner_vertex]
    phi = beta.copy()
    m = rows >= 0
    phi[m] *= 2.0 * np.pi / vsum[rows[m]]
    w = 1.0 / phi**2
    if face_weight is not None:
        w = w * np.repeat(np.asarray(face_weight, dtype=np.float64), 3)
    Vi = t.n_interior
    A = sp.csr_matrix((np.ones(n), (np.arange(n) // 3, np.arange(n))), shape=(F, n))
    wr, wc, ws = wheel_pattern(t)
    alpha = phi.copy()
    lam = np.zeros(F + 2 * Vi)
    it = 0
    for it in range(1, max_iter + 1):
        cot = 1.0 / np.tan(alpha)
        Jw = sp.csr_matrix((ws * cot[wc], (wr, wc)), shape=(Vi, n))
        J = sp.vstack([A, B, Jw], format="csr")
        res = constraint_residuals(t, alpha)
        C = np.concatenate([res["triangle"], res["vertex"], res["wheel"]])
        grad = 2.0 * w * (alpha - phi) + J.T @ lam
        gscale = float(np.abs(grad / (2.0 * w)).max())
        if max(float(np.abs(C).max()), gscale) < tol:
            break
        # Hessian of the Lagrangian: energy + lambda_wheel * d2(sign ln sin)/d alpha2
        lw = lam[F + Vi :]
        hw = np.bincount(wc, weights=-ws * lw[wr] / np.sin(alpha[wc]) ** 2, minlength=n)
        H = sp.diags(2.0 * w + hw)
        K = sp.bmat([[H, J.T], [J, None]], format="csc")
        try:
            d = spla.spsolve(K, -np.concatenate([grad, C]))
        except RuntimeError as exc:
            raise FlatteningError(f"The ABF Newton system is singular ({exc}).", "Try --method mabf or --method lscm.") from exc
        if not np.all(np.isfinite(d)):
            raise FlatteningError("The ABF Newton step is not finite.", "Try --method mabf or --method lscm.")
        da, dl = d[:n], d[n:]
        step = 1.0
        while step > 1e-4 and (np.any(alpha + step * da <= 0) or np.any(alpha + step * da >= np.pi)):
            step *= 0.5
        alpha = alpha + step * da
        lam = lam + step * dl
    res = constraint_residuals(t, alpha)
    stats = {
        "iterations": it,
        "kkt_size": int(n + F + 2 * Vi),
        "n_interior": Vi,
        "max_triangle_residual": float(np.abs(res["triangle"]).max()),
        "max_vertex_residual": float(np.abs(res["vertex"]).max()) if Vi else 0.0,
        "max_wheel_residual": float(np.abs(res["wheel"]).max()) if Vi else 0.0,
        "seconds": time.perf_counter() - t0,
    }
    return alpha.reshape(F, 3), res, stats
