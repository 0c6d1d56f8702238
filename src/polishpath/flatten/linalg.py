"""Sparse symmetric positive-definite solves for the flattening methods.

Backends, best first (``"auto"`` takes the first one installed):

* ``"sksparse"`` - CHOLMOD through scikit-sparse (supernodal, METIS/AMD, the
  symbolic analysis can be reused for several matrices of one pattern); needs
  the Debian package ``libsuitesparse-dev`` to build.
* ``"cholmod"`` - CHOLMOD through the small ``cholespy`` wheel (no reuse of the
  analysis; slower than scikit-sparse here).
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

BACKENDS = ("auto", "sksparse", "cholmod", "superlu")


def _have(module: str) -> bool:
    try:
        __import__(module)
    except ImportError:
        return False
    return True


def spd_backend(backend: str = "auto") -> str:
    """The backend :func:`factor_spd` will use: ``"sksparse"``, ``"cholmod"`` or ``"superlu"``.

    An explicitly requested backend that is not installed falls back like ``"auto"``.
    """
    if backend not in BACKENDS:
        from ..errors import ParameterError

        raise ParameterError(f"Unknown sparse solver {backend!r}.", f"Use one of {', '.join(BACKENDS)}.")
    if backend == "superlu":
        return backend
    if backend in ("auto", "sksparse") and _have("sksparse.cholmod"):
        return "sksparse"
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
    backend : {"auto", "cholmod", "superlu"}

    Returns
    -------
    solve : callable
        ``solve(b)`` with ``b`` of shape (n,) returns ``S^-1 b``, shape (n,).

    Raises
    ------
    FlatteningError
        When the matrix is singular.
    """
    which = spd_backend(backend)
    n = S.shape[0]
    if which == "sksparse":
        return SpdFactorizer(S, "sksparse").factor(S)
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
    once, in the constructor, when the backend allows it (scikit-sparse);
    other backends analyse at every :meth:`factor`.

    Parameters
    ----------
    pattern : (n, n) sparse
        A matrix with the common pattern (both triangles stored).
    backend : {"auto", "sksparse", "cholmod", "superlu"}
    ordering : {"amd", "metis", "nesdis"}
        Fill-reducing ordering (scikit-sparse only).
    """

    def __init__(self, pattern: sp.spmatrix, backend: str = "auto", ordering: str = "amd"):
        self.backend = spd_backend(backend)
        self.n = pattern.shape[0]
        self._analysis = None
        if self.backend == "sksparse":
            from sksparse.cholmod import analyze

            # AMD, or METIS on big meshes: METIS orders ~20-50% less fill on these
            # 2D-mesh patterns, but its analysis costs more than that saves below ~30k rows
            self._analysis = analyze(sp.csc_matrix(pattern), mode="supernodal", ordering_method=ordering)

    def factor(self, S: sp.spmatrix) -> Callable[[np.ndarray], np.ndarray]:
        """``solve(b) -> S^-1 b`` for a matrix ``S`` with the constructor's pattern."""
        if self.backend == "sksparse":
            from sksparse.cholmod import CholmodNotPositiveDefiniteError

            try:
                fac = self._analysis.cholesky(sp.csc_matrix(S))
            except CholmodNotPositiveDefiniteError as exc:
                raise _singular(exc) from exc
            return fac.solve_A
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
