"""MABF's ``linear="direct"`` solve: the assembled S factorised with one analysis."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from polishpath.flatten import flatten, linalg


def _spd(n: int, seed: int) -> sp.csc_matrix:
    rng = np.random.default_rng(seed)
    A = sp.random(n, n, density=0.05, random_state=rng, format="csc")
    A = A + A.T
    return (A + sp.diags(np.abs(A).sum(axis=1).A1 + 1.0)).tocsc()


def test_qdldl_refactor_reuses_the_first_analysis_and_solves_the_new_matrix(monkeypatch):
    qdldl = pytest.importorskip("qdldl")
    made = []
    Solver = qdldl.Solver

    class Counting(Solver):
        def __init__(self, *a, **k):
            made.append(1)
            super().__init__(*a, **k)

    monkeypatch.setattr(qdldl, "Solver", Counting)
    A = _spd(300, 1)
    B = A.copy()
    B.data = B.data * np.random.default_rng(2).uniform(0.5, 2.0, B.nnz)
    B = ((B + B.T) / 2 + sp.diags(np.abs(B).sum(axis=1).A1)).tocsc()  # same pattern, other values
    fz = linalg.SpdFactorizer(A, "qdldl")
    assert fz.backend == "qdldl"
    b = np.arange(300.0)
    sa = fz.refactor(A)
    assert np.allclose(A @ sa(b), b, atol=1e-9)
    sb = fz.refactor(B)
    assert len(made) == 1  # the second factorisation reused the first one's ordering
    assert np.allclose(B @ sb(b), b, atol=1e-9)
    # another slot keeps its own factor (MABF's pcg holds K's and M's at once)
    sk = fz.refactor(A, slot="K")
    assert len(made) == 2
    assert np.allclose(A @ sk(b), b, atol=1e-9) and np.allclose(B @ sb(b), b, atol=1e-9)
    fz.refactor(B, slot="K")
    assert len(made) == 2 and np.allclose(B @ sk(b), b, atol=1e-9)
    # a matrix whose pivots are not all positive is refused after a refactorisation too
    with pytest.raises(linalg.FlatteningError, match="not positive definite"):
        fz.refactor((A - sp.diags(np.full(300, 1e3))).tocsc())


def test_direct_solve_matches_pcg_on_a_mesh_with_holes():
    """The assembled S (linear="direct", the default with holes) and the matrix-free PCG
    converge to the same angles."""
    from test_flatten import surface

    s = surface("cap", n_rings=8, hole=3.0)
    fd = flatten(s, "mabf", tol=1e-11)
    assert fd.provenance.params["linear"] == "direct"
    from polishpath.flatten import mabf
    from polishpath.flatten.topology import corner_tables, disc_topology, fill_holes

    topo = disc_topology(s.vertices, s.faces)
    vf, ff, _ = fill_holes(s.vertices, s.faces, topo.loops)
    fw = np.ones(len(ff))
    fw[len(s.faces):] = 0.01
    bmask = np.zeros(len(vf), dtype=bool)
    bmask[topo.loops[0]] = True
    t = corner_tables(len(vf), ff, boundary_mask=bmask)
    ang_d, res_d, st_d = mabf.mabf_angles(vf, ff, tables=t, face_weight=fw, tol=1e-11, linear="direct")
    ang_p, res_p, st_p = mabf.mabf_angles(vf, ff, tables=t, face_weight=fw, tol=1e-11, linear="pcg", opt_tol=0.0,
                                          stall=2000)
    assert st_d["linear"] == "direct" and st_p["linear"] == "pcg"
    assert st_d["converged"] and st_p["converged"]
    assert np.abs(ang_d - ang_p).max() < 1e-7
    assert np.allclose(ang_d[: len(s.faces)], fd.angles, atol=1e-12)


def test_refactor_without_the_pivot_check_still_solves_exactly():
    """linear="direct" only solves with its factor: LDL' solves a nonsingular symmetric
    matrix whatever the signs of its pivots, so the check (which copies L) is skipped."""
    pytest.importorskip("qdldl")
    A = _spd(200, 3)
    Ind = (A - sp.diags(np.full(200, 0.5 * A.diagonal().max()))).tocsc()  # symmetric, indefinite
    fz = linalg.SpdFactorizer(Ind, "qdldl")
    b = np.linspace(-1.0, 1.0, 200)
    x = fz.refactor(Ind, slot="S", check_pivots=False)(b)
    from scipy.sparse.linalg import spsolve

    ref = spsolve(Ind, b)
    assert np.abs(x - ref).max() < 1e-9 * np.abs(ref).max()
    with pytest.raises(linalg.FlatteningError, match="not positive definite"):
        fz.refactor(Ind, slot="other")
