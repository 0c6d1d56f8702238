"""MABF: the paper's angle problem (section 2.1, Eq. 1-5) solved in matrix form.

Minimise ``sum w (alpha - beta)^2`` over all corner angles subject to

* ``A alpha = pi``      (each triangle sums to pi),
* ``B alpha = 2 pi``    (each interior vertex sums to 2 pi),
* ``C ln sin alpha = 0`` (the sine-law wheel condition at each interior vertex).

The wheel condition is linearised at the current angles and the quadratic
programme with linear constraints is solved exactly: the stationarity condition
``alpha = beta + W^-1 J^T lambda`` is substituted into ``J alpha = t``; the
per-triangle block (``A W^-1 A^T`` is diagonal) is eliminated as in ABF++, so
the only sparse factorisation is of size ``2 * n_interior_vertices``. The
linear constraints hold after the first step; further steps run only while the
wheel residual exceeds the tolerance.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from .. import meshops
from ..errors import FlatteningError, ParameterError
from .linalg import factor_spd
from .topology import CornerTables, corner_tables, vertex_sum_matrix, wheel_pattern


def target_angles(vertices: np.ndarray, faces: np.ndarray, min_angle: float) -> np.ndarray:
    """3D corner angles clamped away from 0 and pi.

    Parameters
    ----------
    vertices : (V, 3) float
        mm.
    faces : (F, 3) int
    min_angle : float
        Smallest target angle, radians; the largest is ``pi - 2 * min_angle``.
        Slivers (angles near 0 or pi) would make ``ln sin`` and ``cot`` blow up
        in the wheel condition.

    Returns
    -------
    beta : (3F,) float64
        Clamped 3D angles, radians, corner order.
    """
    beta = meshops.corner_angles(vertices, faces).ravel()
    return np.clip(beta, min_angle, np.pi - 2.0 * min_angle)


def constraint_residuals(t: CornerTables, alpha: np.ndarray) -> dict[str, np.ndarray]:
    """Residuals of the three constraint families at corner angles ``alpha``.

    Parameters
    ----------
    t : CornerTables
    alpha : (3F,) float
        Corner angles, radians.

    Returns
    -------
    dict
        ``"triangle"`` (F,) rad, ``"vertex"`` (Vi,) rad, ``"wheel"`` (Vi,) in log-sine units.
    """
    a = np.asarray(alpha).reshape(-1, 3)
    tri = a.sum(axis=1) - np.pi
    B = vertex_sum_matrix(t)
    vert = B @ a.ravel() - 2.0 * np.pi
    rows, cols, signs = wheel_pattern(t)
    ls = np.log(np.sin(np.clip(a.ravel(), 1e-300, None)))
    wheel = np.bincount(rows, weights=signs * ls[cols], minlength=t.n_interior)
    return {"triangle": tri, "vertex": vert, "wheel": wheel}


def mabf_angles(
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    weights: str = "uniform",
    min_angle: float = np.radians(1.0),
    tol: float = 1e-10,
    max_iter: int = 50,
    refactor: int = 2,
    face_weight: np.ndarray | None = None,
    stop_on_damping: bool = False,
    solver: str = "auto",
) -> tuple[np.ndarray, dict[str, np.ndarray], dict]:
    """Solve the MABF angle problem.

    Parameters
    ----------
    vertices : (V, 3) float
        mm.
    faces : (F, 3) int
        A manifold disc (holes filled beforehand, see :func:`topology.fill_holes`).
    weights : {"uniform", "inverse_square"}
        ``"uniform"``: the paper's Eq. 4, ``||alpha - beta||^2``; ``"inverse_square"``:
        ABF's ``sum ((alpha - beta) / beta)^2``.
    min_angle : float
        Target angles are clamped to ``[min_angle, pi - 2 min_angle]``, radians.
    tol : float
        Stop when the largest residual of every constraint family is below ``tol``.
    max_iter : int
        Most linearisation steps.
    refactor : int
        The Schur matrix is refactorised at the first ``refactor`` steps; later steps
        reuse the last factor (a chord step: cheaper, converges linearly) unless a
        step reduced the largest residual by less than 4x.
    face_weight : (F,) float, optional
        Extra multiplier of each face's energy weight (small for virtual hole-filling faces).
    solver : {"auto", "cholmod", "superlu"}
        Sparse factorisation backend, see :func:`polishpath.flatten.linalg.factor_spd`.
    stop_on_damping : bool
        Return at once (``stats["stopped_on_damping"] = True``) when a step had to be
        shortened to keep an angle positive: with uniform weights that means slivers
        are being driven to zero and ``"inverse_square"`` weights should be used.

    Returns
    -------
    angles : (F, 3) float64
        Solved planar angles, radians.
    residuals : dict of str -> ndarray
        See :func:`constraint_residuals`.
    stats : dict
        ``iterations``, ``factorizations``, ``n_interior``, ``schur_size``, ``schur_nnz``,
        ``clamped_corners``, residual maxima and seconds spent.

    Raises
    ------
    FlatteningError
        When a solve fails or angles leave (0, pi).
    """
    t0 = time.perf_counter()
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    F = len(f)
    t = corner_tables(len(v), f)
    beta_raw = meshops.corner_angles(v, f).ravel()
    beta = np.clip(beta_raw, min_angle, np.pi - 2.0 * min_angle)
    n_clamped = int(np.count_nonzero(beta != beta_raw))
    if weights == "uniform":
        dinv = np.ones(3 * F)  # W^-1
    elif weights == "inverse_square":
        dinv = beta**2
    else:
        raise ParameterError(f"Unknown MABF weights {weights!r}.", "Use 'uniform' or 'inverse_square'.")
    if face_weight is not None:
        dinv = dinv / np.repeat(np.asarray(face_weight, dtype=np.float64), 3)

    Vi = t.n_interior
    alpha = beta.copy()
    stats: dict = {"n_interior": Vi, "schur_size": 2 * Vi, "clamped_corners": n_clamped, "factorizations": 0}
    if Vi == 0:
        # no interior vertex: only the triangle sums; exact projection
        alpha = beta + dinv * np.repeat((np.pi - beta.reshape(-1, 3).sum(1)) / dinv.reshape(-1, 3).sum(1), 3)
        res = constraint_residuals(t, alpha)
        stats.update(iterations=1, seconds=time.perf_counter() - t0)
        return alpha.reshape(F, 3), res, stats

    B = vertex_sum_matrix(t)
    wr, wc, ws = wheel_pattern(t)
    dsum = dinv.reshape(-1, 3).sum(axis=1)  # A W^-1 A^T, diagonal (F,)

    def a1t(y):  # A^T y : spread a per-face value to its corners
        return np.repeat(y, 3)

    def a1(x):  # A x : per-face sums
        return x.reshape(-1, 3).sum(axis=1)

    solve = None
    it = 0
    res = constraint_residuals(t, alpha)
    worst = np.inf
    ratio = 0.0
    for it in range(1, max_iter + 1):
        # refactorise for the first `refactor` steps, and whenever a chord step
        # reduced the residual by less than 4x (the frozen Jacobian went stale)
        fresh = solve is None or it <= refactor or ratio > 0.25
        if fresh:
            cot = 1.0 / np.tan(alpha)
            Jw = sp.csr_matrix((ws * cot[wc], (wr, wc)), shape=(Vi, 3 * F))
            J2 = sp.vstack([B, Jw], format="csr")
        # linearised targets: J2 x = J2 alpha - C2(alpha), A x = pi. On chord steps
        # J2 is the Jacobian of the last factorisation (consistent with its factor).
        t2 = J2 @ alpha - np.concatenate([res["vertex"], res["wheel"]])
        r1 = np.pi - a1(beta)
        r2 = t2 - J2 @ beta
        if fresh:
            # Schur complement S = J2 P J2^T, P = W^-1 - W^-1 A^T (A W^-1 A^T)^-1 A W^-1,
            # written as J2 W^-1 J2^T - G G^T with G = J2 W^-1 A^T diag(dsum)^-1/2.
            J2D = J2 @ sp.diags(dinv)
            G = J2D @ sp.csr_matrix(
                (np.repeat(1.0 / np.sqrt(dsum), 3), (np.arange(3 * F), np.arange(3 * F) // 3)), shape=(3 * F, F)
            )
            S = (J2D @ J2.T - G @ G.T).tocsc()
            stats["schur_nnz"] = int(S.nnz)
            solve = factor_spd(S, solver)
            stats["factorizations"] += 1
        rhs = r2 - J2 @ (dinv * a1t(r1 / dsum))
        lam2 = solve(rhs)
        jt2 = J2.T @ lam2
        lam1 = (r1 - a1(dinv * jt2)) / dsum
        new = beta + dinv * (a1t(lam1) + jt2)
        if not np.all(np.isfinite(new)):
            raise FlatteningError(
                "The MABF solve produced non-finite angles.",
                "The mesh may have degenerate faces; repair it or try method='lscm'.",
            )
        delta = new - alpha
        # damping: keep every angle inside (floor, pi - floor) so ln sin and cot stay
        # defined; the step is shortened, not clipped per corner, so the linear
        # constraints stay satisfied.
        floor = 0.25 * min_angle
        s_lo = np.where(delta < 0, (alpha - floor) / np.where(delta < 0, -delta, 1.0), np.inf)
        s_hi = np.where(delta > 0, (np.pi - floor - alpha) / np.where(delta > 0, delta, 1.0), np.inf)
        scale = float(min(1.0, s_lo.min(), s_hi.min()))
        if scale < 1.0:
            stats["damped_steps"] = stats.get("damped_steps", 0) + 1
            if stop_on_damping:
                stats["stopped_on_damping"] = True
            scale = max(scale * 0.9, 1e-3)
        step = float(np.abs(delta).max()) * scale
        alpha = alpha + scale * delta
        res = constraint_residuals(t, alpha)
        if stats.get("stopped_on_damping"):
            break
        prev, worst = worst, max(float(np.abs(r).max()) if len(r) else 0.0 for r in res.values())
        ratio = worst / prev if np.isfinite(prev) and prev > 0 else 0.0
        if worst < tol:
            break
    stats.update(
        iterations=it,
        last_step=step,
        max_triangle_residual=float(np.abs(res["triangle"]).max()),
        max_vertex_residual=float(np.abs(res["vertex"]).max()),
        max_wheel_residual=float(np.abs(res["wheel"]).max()),
        seconds=time.perf_counter() - t0,
    )
    return alpha.reshape(F, 3), res, stats
