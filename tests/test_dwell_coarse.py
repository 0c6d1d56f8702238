"""The fft solver's coarse-to-fine start (issue 28, item 4): under a TIF many spacings wide the times solved on
the lattice of twice the spacing start the fine solve, which then needs far fewer iterations for the same
residual."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

import polishpath.dwell.solver as solver
from polishpath.dwell import ErrorMap, build_target, gaussian_tif, minimum_times, removal_map, rms_pv, solve_dwell


def disc_problem(radius: float, tif, ca_margin_mm: float, spacing: float = 0.5):
    """A flat disc's square lattice of dwell points, a low-order map over it (defocus, astigmatism, coma), the
    target under ``tif`` with the bias the minimum times need: (xy, ij, target, tif, tmin). Also used by
    tests/test_dwell_enough.py."""
    h = int(math.ceil(radius / spacing))
    I, J = np.mgrid[-h:h + 1, -h:h + 1]
    ij = np.column_stack([I.ravel(), J.ravel()])
    xy = ij[:, ::-1] * spacing
    keep = np.hypot(xy[:, 0], xy[:, 1]) <= radius
    ij, xy = ij[keep], xy[keep]
    x = np.linspace(-1.05 * radius, 1.05 * radius, 301)
    X, Y = np.meshgrid(x, x)
    r, th = np.hypot(X, Y) / radius, np.arctan2(Y, X)
    z = 20 * (2 * r**2 - 1) + 12 * r**2 * np.cos(2 * th) + 8 * (3 * r**3 - 2 * r) * np.cos(th)
    target = build_target(ErrorMap.centred(z, x[1] - x[0]), shapely.Point(0, 0).buffer(radius + 0.1, 256),
                          band_mm=solver.tif_reach_mm(tif), ca_margin_mm=ca_margin_mm, extension_weight=0.05)
    tmin = minimum_times(np.column_stack([xy, np.zeros(len(xy))]), np.array([0, len(xy)]), 3000.0)
    target = target.with_bias(max(float(np.max((removal_map(target.grid, xy, tmin, tif) - target.removal_nm)[target.valid])), 0.0))
    return xy, ij, target, tif, tmin


@pytest.fixture(scope="module")
def problem():
    # a 10 mm TIF is 20 spacings: one coarse level (1 mm <= 10 / 8 < 2 mm)
    return disc_problem(22.0, gaussian_tif(10.0, fwhm_mm=10.0), 4.0)


def _residual(problem, sol):
    xy, _, target, tif, _ = problem
    return rms_pv((target.removal_nm - removal_map(target.grid, xy, sol.times_s, tif))[target.valid])[0]


def test_coarse_start_gives_the_same_residual_in_fewer_fine_iterations(problem, monkeypatch):
    xy, ij, target, tif, tmin = problem
    assert len(xy) >= solver.COARSE_MIN_POINTS
    with_coarse = solve_dwell(xy, target, tif, tmin, spacing_mm=0.5, method="fft", grid_ij=ij)
    monkeypatch.setattr(solver, "COARSE_MIN_POINTS", 10**12)
    without = solve_dwell(xy, target, tif, tmin, spacing_mm=0.5, method="fft", grid_ij=ij)
    assert [lv["lattice_spacing_mm"] for lv in with_coarse.stats["coarse_levels"]] == pytest.approx([1.0])
    assert without.stats["coarse_levels"] == []
    assert with_coarse.converged and without.converged
    assert with_coarse.stats["iterations"] < 0.7 * without.stats["iterations"]
    init = rms_pv(target.error_nm[target.valid])[0]
    a, b = _residual(problem, with_coarse), _residual(problem, without)
    assert a <= b + 0.002 * init, (a, b, init)
    assert (with_coarse.times_s >= tmin).all()


@pytest.mark.parametrize("per_fwhm, levels, tol", [(8.0, 1, 0.02), (4.0, 2, 0.05)])
def test_coarse_only_is_an_estimate_near_the_full_solve(problem, monkeypatch, per_fwhm, levels, tol):
    """The estimate (a refusal's advice) solves the coarsest level only; its own model's residual is near the
    full solve's, and its times spread onto the points keep the least times and the total."""
    xy, ij, target, tif, tmin = problem
    monkeypatch.setattr(solver, "COARSE_SPACINGS_PER_FWHM", per_fwhm)
    monkeypatch.setattr(solver, "COARSE_MIN_POINTS", 100)
    est = solve_dwell(xy, target, tif, tmin, spacing_mm=0.5, method="fft", grid_ij=ij, coarse_only=True)
    full = solve_dwell(xy, target, tif, tmin, spacing_mm=0.5, method="fft", grid_ij=ij)
    assert est.stats["iterations"] == 0 and est.stats["message"].startswith("estimate")
    assert len(est.stats["coarse_levels"]) == levels
    assert len(est.stats["estimate_times_s"]) < 0.3 ** levels * len(xy)  # the coarsest level's nodes
    assert (est.times_s >= tmin).all()
    init = rms_pv(target.error_nm[target.valid])[0]
    own = rms_pv((target.removal_nm - removal_map(target.grid, est.stats["estimate_xy"], est.stats["estimate_times_s"],
                                                  tif))[target.valid])[0]
    # within 2 % of the initial RMS at 10 spacings per FWHM (the default rule keeps >= 8), 5 % at 5
    assert abs(own - _residual(problem, full)) <= tol * init, (own, _residual(problem, full), init)
    assert est.total_time_s == pytest.approx(full.total_time_s, rel=0.05 * levels)


def test_removal_map_in_chunks_is_the_same_sum(monkeypatch):
    """The machine samples are splatted in chunks (memory of a 10^6-point job): the same removal map."""
    from polishpath.dwell.target import Grid

    rng = np.random.default_rng(0)
    g = Grid((-10.0, -10.0), 0.2, (101, 101))
    xy = rng.uniform(-11, 11, (50001, 2))  # some off the grid
    t = rng.uniform(0, 1, 50001)
    tif = gaussian_tif(5.0, fwhm_mm=2.0)
    whole = removal_map(g, xy, t, tif)
    monkeypatch.setattr(solver, "SPLAT_CHUNK", 7000)
    chunked = removal_map(g, xy, t, tif)
    assert np.abs(chunked - whole).max() <= 1e-12 * whole.max()
    assert whole.max() > 0
