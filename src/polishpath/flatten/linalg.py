"""Sparse symmetric positive-definite solves for the flattening methods.

Backends, best first (``"auto"`` takes the first one installed):

* ``"sksparse"`` - CHOLMOD through scikit-sparse (supernodal, METIS/AMD, the
  symbolic analysis can be reused for several matrices of one pattern); needs
  the Debian package ``libsuitesparse-dev`` to build.
* ``"cvxopt"`` - CHOLMOD through cvxopt (``pip install 'polishpath[cholmod]'``:
  wheels for every platform, SuiteSparse bundled; opt-in because it is GPL-3). One AMD ordering per pattern, a cheap symbolic
  step per matrix with that ordering, supernodal numeric factorisations on big
  systems and simplicial ones below :data:`SUPERNODAL_ROWS` rows (see there).
* ``"qdldl"`` - QDLDL (OSQP's simplicial LDL' with SuiteSparse's AMD; Apache-2.0,
  wheels for every platform): a core dependency, so the default of a plain
  ``pip install``. Against SuperLU on MABF's 1-ring matrices: factorisations
  1.3-4x and single-vector solves 1.3-10x faster (face.obj, 25.8k rows: 0.2 s and
  1.4 ms against 0.94 s and 14.5 ms). Its ``D`` is checked (LDL' does not stop at
  a pivot <= 0).
* ``"cholmod"`` - CHOLMOD through the small ``cholespy`` wheel (no reuse of the
  analysis; slower than the two above here).
* ``"superlu"`` - scipy's SuperLU; always there.

:func:`factor_spd` factorises one matrix; :class:`SpdFactorizer` analyses a
pattern once and factorises several matrices with it (the MABF
preconditioner's two blocks share the vertex 1-ring pattern).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import FlatteningError

BACKENDS = ("auto", "sksparse", "cvxopt", "qdldl", "cholmod", "superlu")

# cvxopt's CHOLMOD: supernodal numeric factorisations are 3-4x faster than simplicial
# ones on these 1-ring matrices, but each supernodal solve (one right-hand side, many
# small supernodes) costs about 2x a simplicial one. MABF's Schur CG makes 25-160 solves
# for its two factorisations; measured (2-core machine): 49.6k rows, 27 solves:
# supernodal 0.33 s, simplicial 0.67 s; 8.3k rows (lion), 159 solves: supernodal 0.15 s,
# simplicial 0.10 s; 25.8k rows (face) a tie.
SUPERNODAL_ROWS = 30000

# "auto" keeps scipy's SuperLU below this many rows. There fixed costs dominate and
# CHOLMOD is only 5-20 % faster (a whole MABF flattening of 1-5k triangles: 8-35 ms);
# the threshold keeps the outputs of small jobs identical to the releases before CHOLMOD
# became the default (a different factorisation changes the last digits of the layout,
# ~1e-13 mm), among them the byte-for-byte reference job of the tests (1.5k rows).
SMALL_ROWS = 2000


def _have(module: str) -> bool:
    try:
        __import__(module)
    except ImportError:
        return False
    return True


def spd_backend(backend: str = "auto", n: int | None = None) -> str:
    """The backend :func:`factor_spd` will use: ``"sksparse"``, ``"cvxopt"``, ``"qdldl"``, ``"cholmod"`` or ``"superlu"``.

    ``"auto"`` takes the first installed in that order, and ``"superlu"`` for
    systems of fewer than :data:`SMALL_ROWS` rows ``n``. An explicitly requested
    backend that is not installed falls back like ``"auto"``.
    """
    if backend not in BACKENDS:
        from ..errors import ParameterError

        raise ParameterError(f"Unknown sparse solver {backend!r}.", f"Use one of {', '.join(BACKENDS)}.")
    if backend == "superlu" or (backend == "auto" and n is not None and n < SMALL_ROWS):
        return "superlu"
    if backend in ("auto", "sksparse") and _have("sksparse.cholmod"):
        return "sksparse"
    if backend in ("auto", "sksparse", "cvxopt") and _have("cvxopt.cholmod"):
        return "cvxopt"
    if backend in ("auto", "sksparse", "cvxopt", "qdldl") and _have("qdldl"):
        return "qdldl"
    if backend in ("auto", "sksparse", "cholmod") and _have("cholespy"):
        return "cholmod"
    if backend == "cholmod" and _have("sksparse.cholmod"):
        return "sksparse"
    return "superlu"


def _singular(exc: Exception) -> FlatteningError:
    return FlatteningError(
        f"The sparse system is singular or not positive definite ({exc}).",
        "The mesh probably has degenerate or duplicate faces; repair it or try --method lscm.",
    )


def factor_spd(S: sp.spmatrix, backend: str = "auto") -> Callable[[np.ndarray], np.ndarray]:
    """Factorise a sparse symmetric positive-definite matrix.

    Parameters
    ----------
    S : (n, n) sparse
        Symmetric positive definite (both triangles stored).
    backend : {"auto", "sksparse", "cvxopt", "qdldl", "cholmod", "superlu"}

    Returns
    -------
    solve : callable
        ``solve(b)`` with ``b`` of shape (n,) returns ``S^-1 b``, shape (n,).

    Raises
    ------
    FlatteningError
        When the matrix is singular.
    """
    n = S.shape[0]
    which = spd_backend(backend, n)
    if which in ("sksparse", "cvxopt", "qdldl"):
        return SpdFactorizer(S, which).factor(S)
    if which == "cholmod":
        from cholespy import CholeskySolverD, MatrixType

        C = S.tocsr()
        C.sort_indices()
        try:
            solver = CholeskySolverD(n, C.indptr.astype(np.int32), C.indices.astype(np.int32), C.data, MatrixType.CSR)
        except (ValueError, RuntimeError) as exc:
            raise FlatteningError(
                f"The sparse system is singular or not positive definite ({exc}).",
                "The mesh probably has degenerate faces; repair it or try --method lscm.",
            ) from exc

        def solve(b: np.ndarray) -> np.ndarray:
            b = np.ascontiguousarray(np.ravel(b), dtype=np.float64)
            x = np.zeros(n)
            solver.solve(b, x)
            return x

        return solve
    try:
        lu = spla.splu(S.tocsc(), permc_spec="COLAMD")
    except RuntimeError as exc:
        raise FlatteningError(
            f"The sparse system is singular ({exc}).",
            "The mesh probably has degenerate or duplicate faces; repair it or try --method lscm.",
        ) from exc
    return lu.solve


class SpdFactorizer:
    """Factorise several SPD matrices that share one sparsity pattern.

    The symbolic analysis (fill-reducing ordering, elimination tree) is done
    once, in the constructor, when the backend allows it (scikit-sparse; with
    cvxopt the AMD ordering is computed once and each :meth:`factor` makes a
    symbolic step with it, since cvxopt factorises in place);
    other backends analyse at every :meth:`factor`.

    Parameters
    ----------
    pattern : (n, n) sparse
        A matrix with the common pattern (both triangles stored).
    backend : {"auto", "sksparse", "cvxopt", "qdldl", "cholmod", "superlu"}
    ordering : {"amd", "metis", "nesdis"}
        Fill-reducing ordering (scikit-sparse only; cvxopt always uses AMD).
    """

    def __init__(self, pattern: sp.spmatrix, backend: str = "auto", ordering: str = "amd"):
        self.n = pattern.shape[0]
        self.backend = spd_backend(backend, self.n)
        self._analysis = None
        if self.backend == "sksparse":
            from sksparse.cholmod import analyze

            # AMD, or METIS on big meshes: METIS orders ~20-50% less fill on these
            # 2D-mesh patterns, but its analysis costs more than that saves below ~30k rows
            self._analysis = analyze(sp.csc_matrix(pattern), mode="supernodal", ordering_method=ordering)
        elif self.backend == "cvxopt":
            import cvxopt.amd

            self._lower = _CvxLower(pattern)
            self._perm = cvxopt.amd.order(self._lower.matrix(pattern))
            self._supernodal = 2 if self.n >= SUPERNODAL_ROWS else 0
        elif self.backend == "qdldl":
            self._upper = _Upper(pattern)

    def factor(self, S: sp.spmatrix) -> Callable[[np.ndarray], np.ndarray]:
        """``solve(b) -> S^-1 b`` for a matrix ``S`` with the constructor's pattern."""
        if self.backend == "sksparse":
            from sksparse.cholmod import CholmodNotPositiveDefiniteError

            try:
                fac = self._analysis.cholesky(sp.csc_matrix(S))
            except CholmodNotPositiveDefiniteError as exc:
                raise _singular(exc) from exc
            return fac.solve_A
        if self.backend == "cvxopt":
            return self._factor_cvxopt(S)
        if self.backend == "qdldl":
            return self._factor_qdldl(S)
        if self.backend == "superlu":
            # SPD: no pivoting needed; symmetric mode with a minimum-degree ordering
            # of A + A^T (about 2x faster than COLAMD on these matrices)
            try:
                lu = spla.splu(
                    sp.csc_matrix(S), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                    options={"SymmetricMode": True},
                )
            except RuntimeError as exc:
                raise _singular(exc) from exc
            return lu.solve
        return factor_spd(S, self.backend)

    def refactor(self, S: sp.spmatrix, slot: str = "", check_pivots: bool = True) -> Callable[[np.ndarray], np.ndarray]:
        """As :meth:`factor`, for a sequence of matrices of which only the last one's
        factor is needed in each ``slot`` (``solve`` of an earlier ``refactor`` in the same
        slot then solves with the new one; other slots keep theirs). With QDLDL the
        second and later calls of a slot refactorise numerically with its first one's AMD
        ordering and elimination tree (``qdldl.Solver.update``, the same factor bit for
        bit): AMD and the symbolic step are 30-55 % of a QDLDL factorisation of MABF's
        matrices (lion 8.3k rows: 11.8 ms fresh, 5.1 ms update; face.obj 25.8k rows:
        46 / 27 ms). Other backends factorise anew (scikit-sparse with its one analysis).

        ``check_pivots=False`` skips QDLDL's check that ``D > 0`` (reading ``D`` copies
        all of ``L``: 0.03-0.07 s on beetle.off's 38.8k-row coupled MABF system, a third
        of its numeric refactorisation), for a caller that only solves with the factor:
        LDL' solves a nonsingular symmetric matrix exactly whatever the signs of its
        pivots (a zero pivot still raises). A preconditioner for CG must keep the check."""
        if self.backend != "qdldl":
            return self.factor(S)
        if not hasattr(self, "_slots"):
            self._slots = {}
        if slot not in self._slots:
            return self._factor_qdldl(S, keep=slot, check_pivots=check_pivots)
        fac, pattern = self._slots[slot]
        U = self._upper.matrix(S)
        if not (np.array_equal(U.indptr, pattern[0]) and np.array_equal(U.indices, pattern[1])):
            return self._factor_qdldl(S, keep=slot, check_pivots=check_pivots)  # another pattern: a fresh analysis
        try:
            fac.update(U, upper=True)
        except (RuntimeError, ValueError) as exc:
            raise _singular(exc) from exc
        return self._checked(fac, check_pivots)

    def _factor_qdldl(self, S: sp.spmatrix, keep: str | None = None,
                      check_pivots: bool = True) -> Callable[[np.ndarray], np.ndarray]:
        import qdldl

        # one solver per matrix (MABF's pcg keeps the factors of K and M at once); its
        # AMD ordering and symbolic step are 30-55 % of the factorisation (see refactor)
        U = self._upper.matrix(S)
        try:
            fac = qdldl.Solver(U, upper=True)
        except (RuntimeError, ValueError) as exc:
            raise _singular(exc) from exc
        if keep is not None:
            self._slots[keep] = (fac, (U.indptr.copy(), U.indices.copy()))
        return self._checked(fac, check_pivots)

    def _checked(self, fac, check_pivots: bool = True) -> Callable[[np.ndarray], np.ndarray]:
        if check_pivots:
            d = fac.factors()[1]  # LDL' does not stop at a pivot <= 0
            if not np.all(np.isfinite(d) & (d > 0)):
                raise _singular(ValueError(f"{int(np.count_nonzero(~(d > 0)))} pivots <= 0"))

        def solve(b: np.ndarray) -> np.ndarray:
            return fac.solve(np.ascontiguousarray(np.ravel(b), dtype=np.float64))

        return solve

    def _factor_cvxopt(self, S: sp.spmatrix) -> Callable[[np.ndarray], np.ndarray]:
        import cvxopt
        from cvxopt import cholmod

        A = self._lower.matrix(S)
        saved = dict(cholmod.options)
        # nmethods=1: the given AMD ordering only (CHOLMOD would otherwise also run its
        # own AMD and keep the better one: twice the symbolic cost for the same order)
        cholmod.options.update(supernodal=self._supernodal, nmethods=1, postorder=True)
        try:
            fac = cholmod.symbolic(A, p=self._perm, uplo="L")
            cholmod.numeric(A, fac)
        except ArithmeticError as exc:
            raise _singular(exc) from exc
        finally:
            cholmod.options.clear()
            cholmod.options.update(saved)
        if not self._supernodal:
            # the simplicial form is LDL', which does not stop at a pivot <= 0: check D
            dinv = cvxopt.matrix(np.ones(self.n))
            cholmod.solve(fac, dinv, sys=6)
            d = np.asarray(dinv).ravel()
            if not np.all(np.isfinite(d) & (d > 0)):
                raise _singular(ValueError(f"{int(np.count_nonzero(~(d > 0)))} pivots <= 0"))

        def solve(b: np.ndarray) -> np.ndarray:
            x = cvxopt.matrix(np.ascontiguousarray(np.ravel(b), dtype=np.float64))
            cholmod.solve(fac, x)
            return np.asarray(x).ravel()

        return solve


class _Upper:
    """The upper triangle (CSC) of matrices with one pattern, the entries to keep found once."""

    def __init__(self, pattern: sp.spmatrix):
        C = sp.csc_matrix(pattern)
        C.sort_indices()
        n = C.shape[0]
        col = np.repeat(np.arange(n), np.diff(C.indptr))
        keep = C.indices <= col
        self._keep = np.nonzero(keep)[0]
        self._indices = C.indices[self._keep]
        self._indptr = np.concatenate([[0], np.cumsum(np.bincount(col[keep], minlength=n))])
        self._pattern = (C.indptr, C.indices)
        self.n = n

    def matrix(self, S: sp.spmatrix) -> sp.csc_matrix:
        C = sp.csc_matrix(S)
        if not C.has_sorted_indices:
            C.sort_indices()
        if C.nnz != len(self._pattern[1]) or not (np.array_equal(C.indptr, self._pattern[0])
                                                  and np.array_equal(C.indices, self._pattern[1])):
            return sp.triu(C, format="csc")  # another pattern (explicit zeros dropped)
        return sp.csc_matrix((C.data[self._keep], self._indices, self._indptr), shape=(self.n, self.n))


class _CvxLower:
    """The lower triangle of matrices with one pattern as cvxopt sparse matrices: the
    triplet indices are found once (cvxopt builds its matrices from triplets)."""

    def __init__(self, pattern: sp.spmatrix):
        C = sp.csc_matrix(pattern)
        C.sort_indices()
        n = C.shape[0]
        col = np.repeat(np.arange(n), np.diff(C.indptr))
        self._keep = np.nonzero(C.indices >= col)[0]
        self._rows = C.indices[self._keep].astype(np.int64)
        self._cols = col[self._keep]
        self._indptr = C.indptr
        self._indices = C.indices
        self.n = n

    def matrix(self, S: sp.spmatrix):
        import cvxopt

        C = sp.csc_matrix(S)
        if not C.has_sorted_indices:
            C.sort_indices()
        if C.nnz != len(self._indices) or not (np.array_equal(C.indptr, self._indptr)
                                               and np.array_equal(C.indices, self._indices)):
            # a matrix with another pattern (explicit zeros dropped): its own triplets
            col = np.repeat(np.arange(self.n), np.diff(C.indptr))
            keep = C.indices >= col
            return cvxopt.spmatrix(C.data[keep], C.indices[keep].astype(np.int64), col[keep], (self.n, self.n))
        return cvxopt.spmatrix(C.data[self._keep], self._rows, self._cols, (self.n, self.n))
