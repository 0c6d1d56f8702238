"""Sparse symmetric positive-definite solves for the flattening methods.

CHOLMOD (through the small ``cholespy`` wheel) is used when installed; otherwise
scipy's SuperLU with a COLAMD ordering, which measured faster than its
minimum-degree orderings on these Laplacian-like systems
(benchmarks/bench_flatten.py prints both).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import FlatteningError

BACKENDS = ("auto", "cholmod", "superlu")


def spd_backend(backend: str = "auto") -> str:
    """The backend :func:`factor_spd` will use: ``"cholmod"`` or ``"superlu"``."""
    if backend not in BACKENDS:
        from ..errors import ParameterError

        raise ParameterError(f"Unknown sparse solver {backend!r}.", f"Use one of {', '.join(BACKENDS)}.")
    if backend == "auto":
        try:
            import cholespy  # noqa: F401

            return "cholmod"
        except ImportError:
            return "superlu"
    return backend


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
    if which == "cholmod":
        from cholespy import CholeskySolverD, MatrixType

        C = S.tocsr()
        C.sort_indices()
        try:
            solver = CholeskySolverD(n, C.indptr.astype(np.int32), C.indices.astype(np.int32), C.data, MatrixType.CSR)
        except (ValueError, RuntimeError) as exc:
            raise FlatteningError(
                f"The sparse system is singular or not positive definite ({exc}).",
                "The mesh probably has degenerate faces; repair it or try method='lscm'.",
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
            "The mesh probably has degenerate or duplicate faces; repair it or try method='lscm'.",
        ) from exc
    return lu.solve
