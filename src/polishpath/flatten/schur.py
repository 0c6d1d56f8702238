"""The MABF reduced system, matrix-free: ``S = J2 P J2^T`` over the interior vertices.

Eliminating the per-triangle block of the linearised angle problem (see
:mod:`polishpath.flatten.mabf`) leaves ``S`` (``2 Vi x 2 Vi``, ``J2 = [B; Jw]``:
vertex-sum and wheel rows). :class:`_Schur` applies it face by face through the
numba product kernels below, assembles its two scalar 1-ring blocks
(``K = B P B^T``, ``M = Jw P Jw^T``) on a pattern built in linear time and
factorises them, and solves ``S y = rhs`` by conjugate gradients on the wheel
block's Schur complement (:meth:`_Schur.pcg`). The inexact Newton iteration
that uses it is ``_mabf_pcg`` in :mod:`polishpath.flatten.mabf`.
"""

from __future__ import annotations

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np
import scipy.sparse as sp

from .linalg import SpdFactorizer
from .topology import CornerTables


@numba.njit(cache=True)
def _kernel_s_wheel(x, rows, cot, dinv, dsum, out1, out2):  # pragma: no cover - numba
    # out1 += C x, out2 += M x, face by face (C = B P Jw^T, M = Jw P Jw^T). Corner a
    # of a face gets +cot_a * x of the vertex at corner a-1 (a is that vertex's "next"
    # corner) and -cot_a * x of the vertex at corner a+1. The project-and-scatter tail
    # is repeated in _kernel_s_vertex on purpose: moving it into a shared njit helper
    # made both kernels 7-10x slower (not inlined: one call with array arguments per
    # face; measured on face.obj x4, 3.5 -> 28 ms)
    z = np.empty(3)
    for f in range(rows.shape[0]):
        for a in range(3):
            v = 0.0
            r = rows[f, (a + 2) % 3]
            if r >= 0:
                v += x[r]
            r = rows[f, (a + 1) % 3]
            if r >= 0:
                v -= x[r]
            z[a] = v * cot[3 * f + a] * dinv[3 * f + a]
        m = (z[0] + z[1] + z[2]) / dsum[f]
        for a in range(3):
            z[a] -= dinv[3 * f + a] * m
        for a in range(3):
            r = rows[f, a]
            if r >= 0:
                out1[r] += z[a]
                out2[r] += cot[3 * f + (a + 1) % 3] * z[(a + 1) % 3] - cot[3 * f + (a + 2) % 3] * z[(a + 2) % 3]


@numba.njit(cache=True)
def _kernel_s_vertex(y, rows, cot, dinv, dsum, out2):  # pragma: no cover - numba
    # out2 += C^T y: corner a of a face gets y of its own vertex, then the same tail
    z = np.empty(3)
    for f in range(rows.shape[0]):
        for a in range(3):
            r = rows[f, a]
            z[a] = y[r] * dinv[3 * f + a] if r >= 0 else 0.0
        m = (z[0] + z[1] + z[2]) / dsum[f]
        for a in range(3):
            z[a] -= dinv[3 * f + a] * m
        for a in range(3):
            r = rows[f, a]
            if r >= 0:
                out2[r] += cot[3 * f + (a + 1) % 3] * z[(a + 1) % 3] - cot[3 * f + (a + 2) % 3] * z[(a + 2) % 3]


@numba.njit(cache=True)
def _kernel_j(x, rows, cot, out1, out2):  # pragma: no cover - numba
    # out += J2 x for a corner vector x
    for f in range(rows.shape[0]):
        for a in range(3):
            r = rows[f, a]
            if r >= 0:
                a1 = (a + 1) % 3
                a2 = (a + 2) % 3
                out1[r] += x[3 * f + a]
                out2[r] += cot[3 * f + a1] * x[3 * f + a1] - cot[3 * f + a2] * x[3 * f + a2]


@numba.njit(cache=True)
def _kernel_jt_proj(y1, y2, rows, cot, dinv, dsum, out):  # pragma: no cover - numba
    # out = P J2^T y (corner vector)
    for f in range(rows.shape[0]):
        s = 0.0
        for a in range(3):
            v = 0.0
            r = rows[f, a]
            if r >= 0:
                v += y1[r]
            r = rows[f, (a + 2) % 3]
            if r >= 0:
                v += cot[3 * f + a] * y2[r]
            r = rows[f, (a + 1) % 3]
            if r >= 0:
                v -= cot[3 * f + a] * y2[r]
            v *= dinv[3 * f + a]
            out[3 * f + a] = v
            s += v
        s /= dsum[f]
        for a in range(3):
            out[3 * f + a] -= dinv[3 * f + a] * s


@numba.njit(cache=True)
def _kernel_blocks3(rows, cot, dinv, dsum, outk, outc, outm):  # pragma: no cover - numba
    # per-face 3x3 blocks of K = B P B^T, C = B P Jw^T and M = Jw P Jw^T, row-major (F, 9):
    # the blocks of S (linear="direct" assembles all three in one pass; pcg uses K and M)
    P = np.empty((3, 3))
    J = np.zeros((3, 3))
    JP = np.empty((3, 3))
    for f in range(rows.shape[0]):
        for a in range(3):
            for b in range(3):
                P[a, b] = -dinv[3 * f + a] * dinv[3 * f + b] / dsum[f]
            P[a, a] += dinv[3 * f + a]
        for a in range(3):
            a1 = (a + 1) % 3
            a2 = (a + 2) % 3
            J[a, a] = 0.0
            J[a, a1] = cot[3 * f + a1]
            J[a, a2] = -cot[3 * f + a2]
        for a in range(3):
            for b in range(3):
                JP[a, b] = J[a, 0] * P[0, b] + J[a, 1] * P[1, b] + J[a, 2] * P[2, b]
        for a in range(3):
            for b in range(3):
                outk[f, 3 * a + b] = P[a, b]
                outc[f, 3 * a + b] = JP[b, a]  # (P J^T)[a, b], P symmetric
                outm[f, 3 * a + b] = JP[a, 0] * J[b, 0] + JP[a, 1] * J[b, 1] + JP[a, 2] * J[b, 2]


@numba.njit(cache=True)
def _kernel_residuals(alpha, rows, n_interior, tri, vert, wheel):  # pragma: no cover - numba
    for i in range(n_interior):
        vert[i] = -2.0 * np.pi
        wheel[i] = 0.0
    ls = np.empty(3)
    for f in range(rows.shape[0]):
        tri[f] = alpha[3 * f] + alpha[3 * f + 1] + alpha[3 * f + 2] - np.pi
        for a in range(3):
            ls[a] = np.log(np.sin(alpha[3 * f + a]))
        for a in range(3):
            r = rows[f, a]
            if r >= 0:
                vert[r] += alpha[3 * f + a]
                wheel[r] += ls[(a + 1) % 3] - ls[(a + 2) % 3]


def _dot(x: np.ndarray, y: np.ndarray) -> float:
    # not x @ y: numpy's threaded BLAS ddot is 10-40x slower than this on a loaded machine
    return float(np.multiply(x, y).sum())


@numba.njit(cache=True)
def _kernel_pattern(rows, n):  # pragma: no cover - numba
    # CSC pattern of sum_f (3x3 block of face f over its interior vertices), sorted rows,
    # and the slot of each of the 9F local entries (local a*3+b = row a, column b; -1
    # where either vertex is on the boundary). Counting sort by column, then a marker
    # array removes the duplicates: linear time (np.unique on the 9F keys sorts).
    F = rows.shape[0]
    start = np.zeros(n + 1, np.int64)
    for f in range(F):
        for b in range(3):
            c = rows[f, b]
            if c >= 0:
                for a in range(3):
                    if rows[f, a] >= 0:
                        start[c + 1] += 1
    for j in range(n):
        start[j + 1] += start[j]
    fill = start[:-1].copy()
    ent_row = np.empty(start[n], np.int64)
    ent_id = np.empty(start[n], np.int64)
    slot = np.full(9 * F, -1, np.int64)
    for f in range(F):
        for b in range(3):
            c = rows[f, b]
            if c >= 0:
                for a in range(3):
                    r = rows[f, a]
                    if r >= 0:
                        k = fill[c]
                        ent_row[k] = r
                        ent_id[k] = 9 * f + 3 * a + b
                        fill[c] = k + 1
    mark = np.full(n, -1, np.int64)
    pos = np.empty(n, np.int64)
    indptr = np.zeros(n + 1, np.int64)
    indices = np.empty(start[n], np.int64)
    nnz = 0
    for j in range(n):
        first = nnz
        for k in range(start[j], start[j + 1]):
            r = ent_row[k]
            if mark[r] != j:
                mark[r] = j
                # insertion into the sorted rows of column j (a handful of entries)
                i = nnz
                while i > first and indices[i - 1] > r:
                    indices[i] = indices[i - 1]
                    i -= 1
                indices[i] = r
                nnz += 1
        for i in range(first, nnz):
            pos[indices[i]] = i
        for k in range(start[j], start[j + 1]):
            slot[ent_id[k]] = pos[ent_row[k]]
        indptr[j + 1] = nnz
    return indptr, indices[:nnz].copy(), slot


@numba.njit(cache=True)
def _kernel_scatter(slot, vals, nnz):  # pragma: no cover - numba
    out = np.zeros(nnz)
    for k in range(slot.shape[0]):
        s = slot[k]
        if s >= 0:
            out[s] += vals[k]
    return out


class _SchurPattern:
    """What :class:`_Schur` needs that depends on the mesh only, not on the weights: the
    interior-vertex row of each face corner, the 1-ring CSC pattern of ``K`` and ``M``
    (numba counting sort, with the slot of each face's 9 local entries) and the sparse
    factoriser with its fill-reducing analysis of that pattern."""

    def __init__(self, t: CornerTables, solver: str):
        self.rows = np.ascontiguousarray(t.interior_index[t.faces])  # (F, 3), -1 on boundary vertices
        n = t.n_interior
        self.indptr, self.indices, self.slot = _kernel_pattern(self.rows, n)
        self.nnz = len(self.indices)
        self.n_faces = t.n_faces
        self._solver = solver
        self._factorizer = None

    @property
    def factorizer(self) -> SpdFactorizer:
        """The factoriser of ``K`` and ``M`` (made at first use: ``linear="direct"`` needs none)."""
        if self._factorizer is None:
            n = len(self.indptr) - 1
            ones = sp.csc_matrix((_kernel_scatter(self.slot, np.ones(9 * self.n_faces), self.nnz), self.indices,
                                  self.indptr), shape=(n, n))
            # AMD: METIS orders 25-30 % less fill on these 2D-mesh patterns, but its
            # analysis costs 7x AMD's (0.75 vs 0.1 s at 100k rows, 3.4 vs 0.5 s at 400k),
            # more than its cheaper factorisations and solves save in a run
            self._factorizer = SpdFactorizer(ones, self._solver, ordering="amd")
        return self._factorizer


class _Schur:
    """The reduced (interior-vertex) system ``S = J2 P J2^T``, ``J2 = [B; Jw]``, applied
    matrix-free face by face; ``P`` is the per-face projection
    ``W^-1 - W^-1 1 1^T W^-1 / sum(W^-1)`` left by eliminating the triangle sums.

    In blocks, ``S = [[K, C], [C^T, M]]`` with ``K = B P B^T`` (vertex sums: constant,
    factorised once), ``M = Jw P Jw^T`` (wheel, factorised at the first Jacobian) and
    the coupling ``C = B P Jw^T``. :meth:`pcg` eliminates the vertex-sum multipliers
    exactly (one ``K`` solve per product) and runs conjugate gradients on the wheel
    block's Schur complement ``M - C^T K^-1 C`` preconditioned by ``M``: about half
    the iterations of CG on ``S`` with the block-diagonal preconditioner at the same
    cost per iteration, because the complement's spectrum relative to ``M`` lies in
    (0, 1] instead of pairing around 1. ``K`` and ``M`` share the 1-ring pattern and
    one symbolic analysis."""

    def __init__(self, t: CornerTables, dinv: np.ndarray, solver: str, pattern: _SchurPattern | None = None):
        F = t.n_faces
        self.F, self.Vi = F, t.n_interior
        self.dinv = np.ascontiguousarray(dinv, dtype=np.float64)
        self.dsum = self.dinv.reshape(-1, 3).sum(axis=1)
        pat = _SchurPattern(t, solver) if pattern is None else pattern
        self.pattern = pat
        self.rows = pat.rows
        self._indptr, self._indices, self._slot, self._nnz = pat.indptr, pat.indices, pat.slot, pat.nnz
        self.cot = np.zeros(3 * F)
        self.solve_M = None
        self._init_blocks()

    def _init_blocks(self) -> None:
        self.factorizer = self.pattern.factorizer
        self.K = self._block(None)
        # refactor: a second attempt with other weights (MABF's "auto") reuses the first
        # attempt's orderings; K and M keep a factor each
        self.solve_K = self.factorizer.refactor(self.K, slot="K")

    def _csc(self, vals: np.ndarray) -> sp.csc_matrix:
        data = _kernel_scatter(self._slot, vals, self._nnz)
        return sp.csc_matrix((data, self._indices, self._indptr), shape=(self.Vi, self.Vi))

    def _block(self, cot: np.ndarray | None) -> sp.csc_matrix:
        # K (cot None: it does not depend on the Jacobian) or M at ``cot``
        outk, outc, outm = (np.empty((self.F, 9)) for _ in range(3))
        _kernel_blocks3(self.rows, self.cot if cot is None else cot, self.dinv, self.dsum, outk, outc, outm)
        return self._csc((outk if cot is None else outm).ravel())

    def set_jacobian(self, cot: np.ndarray, refactor_m: bool) -> None:
        self.cot = np.ascontiguousarray(cot)
        if refactor_m or self.solve_M is None:
            self.M = self._block(self.cot)
            self.solve_M = self.factorizer.refactor(self.M, slot="M")

    def jt_proj(self, y: np.ndarray) -> np.ndarray:
        """``P J2^T y`` (corner vector)."""
        out = np.empty(3 * self.F)
        _kernel_jt_proj(y[: self.Vi], y[self.Vi :], self.rows, self.cot, self.dinv, self.dsum, out)
        return out

    def j(self, x: np.ndarray) -> np.ndarray:
        out = np.zeros(2 * self.Vi)
        _kernel_j(np.ascontiguousarray(x), self.rows, self.cot, out[: self.Vi], out[self.Vi :])
        return out

    def matvec(self, y: np.ndarray) -> np.ndarray:
        """``S y`` from the products :meth:`pcg` uses (for checking them; CG itself
        only needs the Schur complement)."""
        y1, y2 = y[: self.Vi], y[self.Vi :]
        cy2, my2 = self._wheel(y2)
        return np.concatenate([self.K @ y1 + cy2, self._ct(y1) + my2])

    def residuals(self, alpha: np.ndarray) -> dict[str, np.ndarray]:
        tri = np.empty(self.F)
        vert = np.empty(self.Vi)
        wheel = np.empty(self.Vi)
        _kernel_residuals(np.ascontiguousarray(alpha), self.rows, self.Vi, tri, vert, wheel)
        return {"triangle": tri, "vertex": vert, "wheel": wheel}

    def _wheel(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # (C x, M x)
        cx = np.zeros(self.Vi)
        mx = np.zeros(self.Vi)
        _kernel_s_wheel(x, self.rows, self.cot, self.dinv, self.dsum, cx, mx)
        return cx, mx

    def _ct(self, y: np.ndarray) -> np.ndarray:
        # C^T y
        out = np.zeros(self.Vi)
        _kernel_s_vertex(y, self.rows, self.cot, self.dinv, self.dsum, out)
        return out

    def pcg(
        self, rhs: np.ndarray, x0: np.ndarray, atol: float, maxiter: int, k_r1: np.ndarray | None = None
    ) -> tuple[np.ndarray, int, float]:
        """Solve ``S y = rhs`` from ``x0`` until ``max|S y - rhs| <= atol``.

        Conjugate gradients on the wheel multipliers (Schur complement of ``K``,
        preconditioned by ``M``); the vertex-sum multipliers follow as
        ``K^-1 (r1 - C x)``, with ``K^-1 C x`` accumulated from the products CG
        already made, so the first block's residual stays at round-off and the
        second block's is the one CG drives down. ``k_r1``: ``K^-1 rhs[:Vi]`` when
        the caller has it (it is constant over the Newton steps)."""
        Vi = self.Vi
        k1 = self.solve_K(rhs[:Vi]) if k_r1 is None else k_r1
        b = rhs[Vi:] - self._ct(k1)
        x = x0[Vi:].copy()
        cx, mx = self._wheel(x)
        u = self.solve_K(cx)  # K^-1 C x, kept up to date with x
        r = b - (mx - self._ct(u))
        err = float(np.abs(r).max())
        k = 0
        if err > atol:
            z = self.solve_M(r)
            p = z.copy()
            rz = _dot(r, z)
            for k in range(1, maxiter + 1):
                cp, mp = self._wheel(p)
                kp = self.solve_K(cp)
                q = mp - self._ct(kp)
                a = rz / _dot(p, q)
                x += a * p
                u += a * kp
                r -= a * q
                err = float(np.abs(r).max())
                if err <= atol:
                    break
                z = self.solve_M(r)
                rz_new = _dot(r, z)
                p = z + (rz_new / rz) * p
                rz = rz_new
        return np.concatenate([k1 - u, x]), k, err


class _Coupled(_Schur):
    """``S = J2 P J2^T`` assembled, for ``linear="direct"``: ``[[K, C], [C^T, M]]`` (2 Vi x
    2 Vi) on the 1-ring pattern tiled 2 x 2, its three blocks from one numba pass over the
    faces (:func:`_kernel_blocks3`) gathered into one CSC matrix with index arrays made
    once; factorised at :meth:`set_jacobian` with the ordering and elimination tree of
    the first factorisation (``SpdFactorizer.refactor``). The products ``J2 x``,
    ``P J2^T y`` and the residuals are :class:`_Schur`'s (face by face)."""

    def _init_blocks(self) -> None:
        n, nnz = self.Vi, self._nnz
        indptr, indices = self._indptr, self._indices
        lens = np.diff(indptr)
        pos = np.arange(nnz)
        col = np.repeat(np.arange(n), lens)
        first = indptr[col] + pos  # entry k of column j of a block, in S's column j (or n + j)
        second = first + lens[col]
        # C^T on the same (symmetric) pattern: the entry of C at the mirrored position
        tr = sp.csc_matrix((pos + 1.0, indices, indptr), shape=(n, n)).T.tocsc()
        tr.sort_indices()
        transpose = tr.data.astype(np.int64) - 1
        g = np.empty(4 * nnz, np.int64)
        ind = np.empty(4 * nnz, np.int64)
        for half, (top, bottom) in enumerate(((pos, nnz + transpose), (nnz + pos, 2 * nnz + pos))):
            # sources: [K, C, M] data; C read at the mirrored entries for C^T
            g[2 * nnz * half + first] = top
            g[2 * nnz * half + second] = bottom
            ind[2 * nnz * half + first] = indices
            ind[2 * nnz * half + second] = indices + n
        self._gather = g
        self._s_indices = ind
        self._s_indptr = np.concatenate([[0], np.cumsum(np.concatenate([2 * lens, 2 * lens]))])
        self.factorizer = None
        self.solve = None

    def matrix(self, cot: np.ndarray) -> sp.csc_matrix:
        """``S`` at the Jacobian given by the corner cotangents ``cot`` (3F,)."""
        outk, outc, outm = (np.empty((self.F, 9)) for _ in range(3))
        _kernel_blocks3(self.rows, np.ascontiguousarray(cot), self.dinv, self.dsum, outk, outc, outm)
        kd, cd, md = (_kernel_scatter(self._slot, o.ravel(), self._nnz) for o in (outk, outc, outm))
        data = np.concatenate([kd, cd, md])
        return sp.csc_matrix((data[self._gather], self._s_indices, self._s_indptr), shape=(2 * self.Vi, 2 * self.Vi))

    def set_jacobian(self, cot: np.ndarray, refactor_m: bool = True) -> None:
        """Linearise at ``cot`` and factorise ``S`` there (the chord steps in between keep both)."""
        self.cot = np.ascontiguousarray(cot)
        S = self.matrix(self.cot)
        self.nnz = int(S.nnz)
        if self.factorizer is None:
            self.factorizer = SpdFactorizer(S, self.pattern._solver)
        # S is only solved with (no CG on it): its pivots need no check, see refactor
        self.solve = self.factorizer.refactor(S, slot="S", check_pivots=False)
