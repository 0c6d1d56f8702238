"""MABF: the paper's angle problem (section 2.1, Eq. 1-5) solved in matrix form.

Minimise ``sum w (alpha - beta)^2`` over all corner angles subject to

* ``A alpha = pi``      (each triangle sums to pi),
* ``B alpha = 2 pi``    (each interior vertex sums to 2 pi),
* ``C ln sin alpha = 0`` (the sine-law wheel condition at each interior vertex).

The wheel condition is linearised at the current angles and the quadratic
programme with linear constraints is solved exactly: the stationarity condition
``alpha = beta + W^-1 J^T lambda`` is substituted into ``J alpha = t``; the
per-triangle block (``A W^-1 A^T`` is diagonal) is eliminated as in ABF++, which
leaves a ``2 * n_interior_vertices`` system ``S``. By default ``S`` is never
formed: it is applied face by face (numba), its vertex-sum block is eliminated
exactly and conjugate gradients run on the rest, preconditioned by the wheel
block; both blocks are scalar 1-ring matrices factorised once (see
:class:`polishpath.flatten.schur._Schur`, with its numba product kernels).
Steps run only while a residual exceeds the tolerance.

This module holds the targets, the residuals and the outer iterations: the
direct solve in :func:`mabf_angles` and the inexact Newton ``_mabf_pcg`` over
the matrix-free operator.
"""

from __future__ import annotations

import time

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

from .. import meshops
from ..errors import FlatteningError, ParameterError
from .schur import _Coupled, _Schur, _SchurPattern
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
    beta = _corner_angles(vertices, faces)
    return np.clip(beta, min_angle, np.pi - 2.0 * min_angle)


def _corner_angles(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    # meshops.corner_angles in one numba pass (the same atan2(|a x b|, a.b) formula):
    # ~8x faster on big meshes, and this is on MABF's clock
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    if v.shape[1] != 3:
        return meshops.corner_angles(v, faces).ravel()
    return _kernel_corner_angles(v, np.ascontiguousarray(faces, dtype=np.int64))


@numba.njit(cache=True)
def _kernel_corner_angles(v, f):  # pragma: no cover - numba
    out = np.empty(3 * f.shape[0])
    e = np.empty((3, 3))  # e[k] = edge from corner k to corner k+1
    for i in range(f.shape[0]):
        for k in range(3):
            a = f[i, k]
            b = f[i, (k + 1) % 3]
            for j in range(3):
                e[k, j] = v[b, j] - v[a, j]
        cx = e[0, 1] * e[2, 2] - e[0, 2] * e[2, 1]
        cy = e[0, 2] * e[2, 0] - e[0, 0] * e[2, 2]
        cz = e[0, 0] * e[2, 1] - e[0, 1] * e[2, 0]
        cr = np.sqrt(cx * cx + cy * cy + cz * cz)
        for k in range(3):
            # angle at corner k between e[k] and -e[k-1]
            km = (k + 2) % 3
            d = -(e[k, 0] * e[km, 0] + e[k, 1] * e[km, 1] + e[k, 2] * e[km, 2])
            out[3 * i + k] = np.arctan2(cr, d)
    return out


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
    with np.errstate(invalid="ignore"):  # angles past pi (a diverged step): NaN, caught by the caller
        ls = np.log(np.sin(np.clip(a.ravel(), 1e-300, None)))
    wheel = np.bincount(rows, weights=signs * ls[cols], minlength=t.n_interior)
    return {"triangle": tri, "vertex": vert, "wheel": wheel}


class _PcgStalled(Exception):
    """A PCG solve needed more iterations than allowed (weak preconditioner)."""


def mabf_angles(
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    weights: str = "uniform",
    tables: CornerTables | None = None,
    min_angle: float = np.radians(1.0),
    tol: float = 1e-8,
    max_iter: int = 50,
    refactor: int = 2,
    face_weight: np.ndarray | None = None,
    stop_on_damping: bool = False,
    solver: str = "auto",
    linear: str = "auto",
    stall: int = 100,
    opt_tol: float = 1e-4,
) -> tuple[np.ndarray, dict[str, np.ndarray], dict]:
    """Solve the MABF angle problem.

    Parameters
    ----------
    vertices : (V, 3) float
        mm.
    faces : (F, 3) int
        A manifold disc (holes filled beforehand, see :func:`topology.fill_holes`).
    weights : {"uniform", "inverse_square", "auto"}
        ``"uniform"``: the paper's Eq. 4, ``||alpha - beta||^2``; ``"inverse_square"``:
        ABF's ``sum ((alpha - beta) / beta)^2``; ``"auto"``: uniform, and
        inverse-square from the start again as soon as a uniform step would drive an
        angle to zero (slivers); the second attempt reuses the first one's corner
        tables, 1-ring pattern and fill-reducing ordering. ``stats["weights"]`` says
        which were used. With light faces (``face_weight`` < 1: hole fans), a uniform
        step that would drive a light corner to zero, or an inverse-square one that
        would drive any corner to zero, starts an inverse-square attempt with those
        faces weighted 1 (``stats["hole_fans_stiffened"]``).
    tables : CornerTables, optional
        :func:`topology.corner_tables` of ``(vertices, faces)`` when the caller has them.
    min_angle : float
        Target angles are clamped to ``[min_angle, pi - 2 min_angle]``, radians.
    tol : float
        Stop when the largest residual of every constraint family is below ``tol``
        (radians for the sums, log-sine units for the wheel). The default 1e-8 is
        below the ~1e-7 rad precision of angles computed from float32 (STL)
        coordinates and makes the layout consistent to 1e-8 relative (1 nm on a
        100 mm part).
    max_iter : int
        Most linearisation steps.
    refactor : int
        ``linear="direct"`` only: the Schur matrix is refactorised at the first
        ``refactor`` steps; later steps reuse the last factor (a chord step) unless a
        step reduced the largest residual by less than 4x.
    face_weight : (F,) float, optional
        Extra multiplier of each face's energy weight (small for virtual hole-filling faces).
    solver : {"auto", "sksparse", "cholmod", "superlu"}
        Sparse factorisation backend, see :mod:`polishpath.flatten.linalg`.
    linear : {"auto", "pcg", "direct"}
        How each linearised step's interior-vertex system ``S`` (2 Vi x 2 Vi) is solved.
        ``"auto"`` (default): ``"direct"`` when ``face_weight`` is not all ones (filled
        holes), else ``"pcg"``, falling back to ``"direct"`` when one PCG solve needs
        more than ``stall`` iterations. ``"pcg"``: ``S`` is applied face by face
        (numba); the vertex-sum multipliers are eliminated exactly with the constant
        block ``B P B^T`` (factorised once) and conjugate gradients run on the wheel
        block's Schur complement, preconditioned by ``Jw P Jw^T`` at the 3D angles
        (factorised once, same symbolic analysis); warm-started from the previous
        multipliers and stopped at the accuracy the Newton step needs. ``"direct"``
        forms and factorises ``S`` itself (2 Vi x 2 Vi, 2x2-coupled: ~8x the cost of
        one scalar factorisation).
    opt_tol : float
        ``linear="pcg"`` only. Optimality tolerance, radians: once the next
        optimisation step is predicted (from the last two) to move no angle by more
        than ``opt_tol`` in all (the next step times the geometric sum of the observed
        contraction), the remaining steps only restore the constraints
        (minimum-norm projection onto the linearised constraints, the multipliers
        kept), which converges quadratically and skips the re-solve for the
        multipliers after each relinearisation (most of the late steps' work). The
        angles then differ from the exact optimum by about ``opt_tol`` at most (the
        mean angle error agrees to 5 digits on every shared mesh; face.obj x4: 26
        instead of 33 CG iterations, 1.2-1.4x faster on lion and camelhead); ``0`` keeps optimising
        until the constraints converge.
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
        ``weights`` (used), ``iterations``, ``converged`` (largest residual below ``tol``),
        ``factorizations``, ``n_interior``, ``schur_size``, ``schur_nnz`` (direct),
        ``pcg_iterations``, ``projection_steps``, ``trace`` (per step: largest
        residual, CG tolerance, CG iterations, ``"optimise"`` or ``"project"``) and
        ``backend`` (pcg), ``pcg_stalled`` (pcg fell back to direct),
        ``clamped_corners``, ``last_step`` (largest angle change of the last step,
        rad), residual maxima and seconds spent.

    Raises
    ------
    FlatteningError
        When a solve fails or angles leave (0, pi).
    """
    t0 = time.perf_counter()
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if weights not in ("uniform", "inverse_square", "auto"):
        raise ParameterError(f"Unknown MABF weights {weights!r}.", "Use 'uniform', 'inverse_square' or 'auto'.")
    t = corner_tables(len(v), f) if tables is None else tables
    beta_raw = _corner_angles(v, f)
    kw = dict(min_angle=min_angle, tol=tol, max_iter=max_iter, refactor=refactor, face_weight=face_weight, solver=solver,
              linear=linear, stall=stall, opt_tol=opt_tol, t0=t0, reuse={})
    light = face_weight is not None and bool(np.any(np.asarray(face_weight) < 1.0))
    if weights != "auto":
        angles, res, stats = _mabf_solve(t, beta_raw, weights, stop_on_damping=stop_on_damping, **kw)
        stats["weights"] = weights
        return angles, res, stats
    n_folded = folded_fan_vertices(t, beta_raw, face_weight) if light else 0
    if n_folded:
        # fans that fold over the real faces: the uniform attempt with light fans is
        # damped at a fan corner at its first step (stanford-bunny.obj: rim vertices up
        # to 2 pi + 1.7 rad; its direct solve of the coupled 70k-row system, 1.2 CPU s,
        # was thrown away), so the stiff fans below come first
        fan = True
        stats = {}
    else:
        angles, res, stats = _mabf_solve(t, beta_raw, "uniform", stop_on_damping=True, **kw)
        if not stats.get("stopped_on_damping"):
            stats["weights"] = "uniform"
            return angles, res, stats
        # a light (fan) corner driven to zero: inverse-square weights with light fans fail
        # the same way (the bunny), so go straight to the stiff fans below
        fan = light and float(np.asarray(face_weight)[stats["damped_corner"] // 3]) < 1.0
    if not fan:
        angles, res, stats = _mabf_solve(t, beta_raw, "inverse_square", stop_on_damping=light, **kw)
        stats["weights"] = "inverse_square"
    if light and (fan or stats.get("stopped_on_damping")):
        # Hole fans too light to hold their angles (stanford-bunny.obj: ragged,
        # non-planar rims whose fan triangles fold over the real faces give rim
        # vertices 3D angle sums up to 2 pi + 1.7 rad): the cheapest way to close such
        # a vertex is through a fan corner, and the QP drives it through zero with
        # either weight, every step damped, until the solve breaks down. Weighted like
        # the real faces, the fans share the correction with the real faces; the bunny
        # then converges in 9 steps without a flipped triangle.
        kw["face_weight"] = np.maximum(np.asarray(face_weight, dtype=np.float64), 1.0)
        angles, res, stats = _mabf_solve(t, beta_raw, "inverse_square", stop_on_damping=False, **kw)
        stats.update(weights="inverse_square", hole_fans_stiffened=True, folded_fan_vertices=n_folded)
    return angles, res, stats


# A rim vertex whose 3D angle sum (real and fan corners) exceeds 2 pi by more than this
# (radians) has a fan that folds over the real faces. The shared meshes are far from it
# on both sides: beetle.off's ten holes at most 0.047, stanford-bunny.obj's four 0.45-1.7.
FOLD_EXCESS = 0.1


def folded_fan_vertices(t: CornerTables, beta_raw: np.ndarray, face_weight: np.ndarray) -> int:
    """How many vertices of hole rims have light fans (``face_weight`` < 1) folded over
    the real faces: their 3D angle sum exceeds 2 pi by more than :data:`FOLD_EXCESS`.

    Parameters
    ----------
    t : CornerTables
        Of the filled mesh.
    beta_raw : (3F,) float
        Its 3D corner angles, radians.
    face_weight : (F,) float
        Energy multiplier of each face (< 1 on the fans).

    Returns
    -------
    int
    """
    light = np.repeat(np.asarray(face_weight) < 1.0, 3)
    n = len(t.interior)
    sums = np.bincount(t.corner_vertex, weights=beta_raw, minlength=n)
    rim = np.zeros(n, dtype=bool)
    rim[t.corner_vertex[light]] = True
    real = np.zeros(n, dtype=bool)
    real[t.corner_vertex[~light]] = True  # the fans' centres have fan corners only
    return int(np.count_nonzero(rim & real & (sums - 2.0 * np.pi > FOLD_EXCESS)))


def _mabf_solve(t, beta_raw, weights, *, min_angle, tol, max_iter, refactor, face_weight, stop_on_damping, solver,
                linear, stall, opt_tol, t0, reuse):
    """:func:`mabf_angles` for one choice of weights; ``reuse`` keeps what a second
    attempt with other weights can use again (the pcg solve's pattern and ordering)."""
    F = t.n_faces
    beta = np.clip(beta_raw, min_angle, np.pi - 2.0 * min_angle)
    n_clamped = int(np.count_nonzero(beta != beta_raw))
    if weights == "uniform":
        dinv = np.ones(3 * F)  # W^-1
    else:
        dinv = beta**2
    if face_weight is not None:
        dinv = dinv / np.repeat(np.asarray(face_weight, dtype=np.float64), 3)

    Vi = t.n_interior
    alpha = beta.copy()
    stats: dict = {"n_interior": Vi, "schur_size": 2 * Vi, "clamped_corners": n_clamped, "factorizations": 0}
    if Vi == 0:
        # no interior vertex: only the triangle sums; exact projection
        alpha = beta + dinv * np.repeat((np.pi - beta.reshape(-1, 3).sum(1)) / dinv.reshape(-1, 3).sum(1), 3)
        res = constraint_residuals(t, alpha)
        stats.update(iterations=1, last_step=float(np.abs(alpha - beta).max()), **_residual_stats(res, tol),
                     seconds=time.perf_counter() - t0)
        return alpha.reshape(F, 3), res, stats

    if linear not in ("auto", "pcg", "direct"):
        raise ParameterError(f"Unknown MABF linear solver {linear!r}.", "Use 'auto', 'pcg' or 'direct'.")
    if linear == "auto":
        # hole-filling fans (small weights around a high-valence virtual vertex) couple
        # the two blocks strongly: beetle.off needs ~560 PCG iterations with uniform
        # weights (4 s) against 1.2 s direct. Without holes PCG is 1.5-3x faster than
        # the direct solve at every size measured (1k to 800k triangles).
        holes = face_weight is not None and np.any(np.asarray(face_weight) != 1.0)
        linear = "direct" if holes else "pcg"
    if linear == "pcg":
        try:
            return _mabf_pcg(t, beta, dinv, alpha, dict(stats), tol=tol, max_iter=max_iter, min_angle=min_angle,
                             stop_on_damping=stop_on_damping, solver=solver, t0=t0, stall=stall, opt_tol=opt_tol,
                             reuse=reuse)
        except _PcgStalled:
            stats["pcg_stalled"] = True  # fall back to the direct solve below, from the start
    stats["linear"] = "direct"
    return _mabf_direct(t, beta, dinv, alpha, stats, tol=tol, max_iter=max_iter, min_angle=min_angle,
                        refactor=refactor, stop_on_damping=stop_on_damping, solver=solver, t0=t0, reuse=reuse)


def _mabf_direct(t, beta, dinv, alpha, stats, *, tol, max_iter, min_angle, refactor, stop_on_damping, solver, t0,
                 reuse):
    """Newton steps on the assembled, factorised ``S`` (:class:`_Coupled`): the first
    ``refactor`` steps refactorise, later ones reuse the factor (chord steps) unless a
    step reduced the largest residual by less than 4x. Each step solves the linearised
    QP exactly: ``S lam = J2 (alpha - x0) - c(alpha)``, ``alpha' = x0 + P J2^T lam`` with
    ``x0`` the triangle-sum projection of ``beta``; on chord steps ``J2`` is the
    Jacobian of the last factorisation (consistent with its factor)."""
    F = t.n_faces
    if "pattern" not in reuse:
        reuse["pattern"] = _SchurPattern(t, solver)
    cs = _Coupled(t, dinv, solver, reuse["pattern"])
    if "coupled" in reuse:
        cs.factorizer = reuse["coupled"]  # an earlier attempt's: same pattern, its ordering
    x0 = beta + dinv * np.repeat((np.pi - beta.reshape(-1, 3).sum(axis=1)) / cs.dsum, 3)
    it = 0
    step = 0.0
    res = cs.residuals(alpha)
    worst = np.inf
    ratio = 0.0
    for it in range(1, max_iter + 1):
        if cs.solve is None or it <= refactor or ratio > 0.25:
            cs.set_jacobian(1.0 / np.tan(alpha))
            reuse["coupled"] = cs.factorizer
            stats["schur_nnz"] = cs.nnz
            stats["factorizations"] += 1
        lam = cs.solve(cs.j(alpha - x0) - np.concatenate([res["vertex"], res["wheel"]]))
        alpha, _, step = _take_step(alpha, x0 + cs.jt_proj(lam), min_angle, stop_on_damping, stats)
        res = cs.residuals(alpha)
        if stats.get("stopped_on_damping"):
            break
        prev, worst = worst, max(float(np.abs(r).max()) if len(r) else 0.0 for r in res.values())
        ratio = worst / prev if np.isfinite(prev) and prev > 0 else 0.0
        if worst < tol:
            break
    stats.update(iterations=it, last_step=step, **_residual_stats(res, tol), seconds=time.perf_counter() - t0)
    return alpha.reshape(F, 3), res, stats


def _damped(alpha: np.ndarray, delta: np.ndarray, min_angle: float) -> float:
    """Largest step length <= 1 keeping every angle inside (floor, pi - floor), floor = min_angle / 4."""
    return float(_kernel_damped(np.ascontiguousarray(alpha), np.ascontiguousarray(delta), 0.25 * min_angle))


def _take_step(alpha: np.ndarray, new: np.ndarray, min_angle: float, stop_on_damping: bool,
               stats: dict) -> tuple[np.ndarray, float, float]:
    """Move from ``alpha`` toward the solved angles ``new``, damped so every angle stays
    inside (floor, pi - floor) and ln sin and cot stay defined. The step is shortened,
    not clipped per corner, so the linear constraints stay satisfied. Returns the new
    angles, the step length used (<= 1) and the largest angle change (rad); counts
    damped steps in ``stats`` (and flags ``stopped_on_damping`` if asked)."""
    if not np.all(np.isfinite(new)):
        raise FlatteningError(
            "The MABF solve produced non-finite angles.",
            "The mesh may have degenerate faces; repair it or try --method lscm.",
        )
    delta = new - alpha
    scale = _damped(alpha, delta, min_angle)
    if scale < 1.0:
        if "damped_corner" not in stats:  # the corner that limited the first damped step
            floor = 0.25 * min_angle
            with np.errstate(divide="ignore", invalid="ignore"):
                room = np.where(delta < 0, (alpha - floor) / -delta, np.where(delta > 0, (np.pi - floor - alpha) / delta, np.inf))
            stats["damped_corner"] = int(np.argmin(room))
        stats["damped_steps"] = stats.get("damped_steps", 0) + 1
        if stop_on_damping:
            stats["stopped_on_damping"] = True
        scale = max(scale * 0.9, 1e-3)
    return alpha + scale * delta, scale, float(np.abs(delta).max()) * scale


def _residual_stats(res: dict[str, np.ndarray], tol: float) -> dict:
    """Largest residual of each constraint family, and whether all are below ``tol``."""
    out = {f"max_{k}_residual": float(np.abs(r).max()) if len(r) else 0.0 for k, r in res.items()}
    out["converged"] = bool(max(out.values()) < tol)
    return out


@numba.njit(cache=True)
def _kernel_damped(alpha, delta, floor):  # pragma: no cover - numba
    s = 1.0
    hi = np.pi - floor
    for i in range(alpha.shape[0]):
        d = delta[i]
        if d < 0.0:
            s = min(s, (alpha[i] - floor) / -d)
        elif d > 0.0:
            s = min(s, (hi - alpha[i]) / d)
    return s


def _mabf_pcg(t, beta, dinv, alpha, stats, *, tol, max_iter, min_angle, stop_on_damping, solver, t0, stall, opt_tol,
              reuse):
    """Inexact Newton on the wheel condition; each linearised QP's interior-vertex
    system ``S = J2 P J2^T`` is solved matrix-free by :meth:`_Schur.pcg` (exact
    elimination with ``B P B^T``, constant; CG preconditioned by ``Jw P Jw^T`` at the
    3D angles). The multipliers of the previous step warm-start the next solve, and
    each solve stops at the accuracy the Newton step needs.

    Why the projection steps (see ``opt_tol``): after a relinearisation the
    warm-started system's residual is ``|J_k - J_(k-1)| |lambda|``, set by the
    multipliers' size, not by the constraint residual (face.obj x4, last step:
    1.2e-3 against 8.1e-7), so a late optimisation step costs ~6 decades of CG to
    move the angles by ~1e-5 rad; a projection starts from the constraint residual."""
    F, Vi = t.n_faces, t.n_interior
    ts = time.perf_counter()
    if "pattern" not in reuse:
        reuse["pattern"] = _SchurPattern(t, solver)
    sch = _Schur(t, dinv, solver, reuse["pattern"])
    stats["backend"] = sch.factorizer.backend
    stats["linear"] = "pcg"
    stats["factorizations"] = 1
    dsum = sch.dsum
    x0 = beta + dinv * np.repeat((np.pi - beta.reshape(-1, 3).sum(axis=1)) / dsum, 3)
    lam = np.zeros(2 * Vi)
    res = sch.residuals(alpha)
    worst = max(float(np.abs(r).max()) for r in res.values())
    pcg_total = 0
    stats["trace"] = []  # (largest residual before the step, PCG tolerance, PCG iterations, kind)
    stats["seconds_setup"] = time.perf_counter() - ts
    it = 0
    step = 0.0
    k_r1 = None
    rate = None
    project = False  # optimality reached: only restore the constraints
    sizes: list[float] = []  # largest angle change of each optimisation step
    for it in range(1, max_iter + 1):
        cot = 1.0 / np.tan(alpha)
        sch.set_jacobian(cot, refactor_m=(it == 1))
        if it == 1:
            stats["factorizations"] += 1
        if project:
            # minimum-norm correction onto the linearised constraints: S mu = -c(alpha);
            # the next residual is second order in the correction
            rhs = -np.concatenate([res["vertex"], res["wheel"]])
            atol = max(0.25 * tol, min(0.1 * worst, 0.1 * worst * worst))
            mu, k, err = sch.pcg(rhs, np.zeros(2 * Vi), atol, maxiter=stall)
            if err > atol:
                # a projection CG that stalls: go back to optimisation steps, which
                # warm-start from the multipliers (and fall back to "direct" if they stall)
                pcg_total += k
                stats["trace"].append((worst, atol, k, "project (stalled)"))
                project = False
                continue
            new = alpha + sch.jt_proj(mu)
        else:
            rhs = sch.j(alpha - x0) - np.concatenate([res["vertex"], res["wheel"]])
            if k_r1 is None:
                # rhs[:Vi] = 2 pi - B x0 whatever alpha is: its K solve is made once
                k_r1 = sch.solve_K(rhs[:Vi])
            # forcing term: the linear residual adds to the next constraint residual, so
            # ask for about what the next one will be anyway: worst^2 (Newton's rate) or
            # a third of rate * worst (the contraction the last step showed), whichever
            # is larger (solving further is wasted: the step's own error dominates),
            # never more than worst / 10, and tol / 4 when the step will finish.
            # (a tenth instead of a third: 29 instead of 26 CG iterations on face x4,
            # 80 instead of 76 on lion; the whole rate: 25 and 70, but closer to an
            # extra step)
            guess = worst * worst if rate is None else max(worst * worst, 0.3 * rate * worst)
            if rate is not None and rate * worst < tol:
                guess = 0.0
            atol = max(0.25 * tol, min(0.1 * worst, guess))
            lam, k, err = sch.pcg(rhs, lam, atol, maxiter=stall, k_r1=k_r1)
            if err > atol:
                raise _PcgStalled()
            new = x0 + sch.jt_proj(lam)
        pcg_total += k
        stats["trace"].append((worst, atol, k, "project" if project else "optimise"))
        alpha, scale, step = _take_step(alpha, new, min_angle, stop_on_damping, stats)
        res = sch.residuals(alpha)
        if stats.get("stopped_on_damping"):
            break
        prev, worst = worst, max(float(np.abs(r).max()) for r in res.values())
        rate = min(1.0, worst / prev) if prev > 0 else None
        if worst < tol:
            break
        if project:
            project = worst < 0.5 * prev  # a projection that does not converge: optimise again
        else:
            sizes.append(step)
            # what further optimisation steps would still move the angles: the next step
            # predicted from the contraction of the last two, summed geometrically
            if len(sizes) >= 2 and scale == 1.0 and sizes[-2] > 0:
                q = step / sizes[-2]
                project = q < 0.5 and step * q / (1.0 - q) < opt_tol
    stats["projection_steps"] = sum(1 for tr in stats["trace"] if tr[3] == "project")
    stats.update(iterations=it, pcg_iterations=pcg_total, last_step=step, **_residual_stats(res, tol),
                 seconds=time.perf_counter() - t0)
    return alpha.reshape(F, 3), res, stats
