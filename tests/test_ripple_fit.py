"""The ripple fit (polishpath.simulate.ripplefit): dwell points moved so the tool's removal is flat in 0.95-3 1/mm.

Each check able to fail: the fit lowers what it fits (the removal's band power as the machine runs the
moved points, not as its model predicts), its linearised curve reproduces the machine's samples, it
keeps every guarantee it states (no point more than 0.3 h from its planned place, none nearer than
0.7 h to another or than the set already was, no step over 2 h, no piece crossing itself, the order
and the dwell times unchanged), it is the same bytes for the same input, it refuses bad settings,
it works for a tool without a feed dependence, and given to every path by ``compare_planned(...,
treatment="ripple-fit")`` it lowers every path's band RMS (docs/simulation.md).
"""

from __future__ import annotations

import numpy as np
import pytest

from fit_helpers import assert_fit_keeps_guarantees, relaxed_walk_case
from polishpath.errors import ParameterError
from polishpath.plan import plan
from polishpath.simulate.compare import TREATMENTS, compare_planned
from polishpath.simulate.machinetime import machine_tool_path
from polishpath.simulate.patterns import patch_bounds_at_centre, square_region
from polishpath.simulate.ripplefit import _curve_operators, fit_removal_ripple
from polishpath.simulate.rotating import default_tif
from polishpath.simulate.tif import gaussian_tif

H = 0.5


@pytest.fixture(scope="module")
def walk():
    p, times, tif = relaxed_walk_case(14.0, H)
    return p, times, tif, fit_removal_ripple(p.uv, times, p.pieces, tif, spacing_mm=H, steps=4)


def test_the_fit_lowers_the_removal_ripple_the_machine_leaves(walk):
    st = walk[3].stats
    # the loss is recomputed from a machine run of the kept points (measured 0.32 of the planned on this square;
    # 0.47 with the gradient 400x too small before 2026-12-02)
    assert st["loss"] < 0.5 * st["loss_planned"], st
    assert st["best_step"] >= 1 and st["moved_share"] > 0.2
    assert st["n_kernels"] > 1  # the rotating tool: its footprint depends on the feed's speed and heading


def test_the_fits_gradient_is_the_derivative_of_its_loss(monkeypatch):
    """The gradient L-BFGS-B is given equals central differences of the loss it is given (positions of points
    spread over the path): the splat is a time density (its adjoint carries the 1 / dx^2 too) and the loss is
    over the window's mean (its derivative counts)."""
    from scipy import optimize

    p, times, tif = relaxed_walk_case(10.0, H)
    seen = {}

    class Captured(Exception):
        pass

    def capture(fun, x0, **kw):
        seen["fun"], seen["x0"] = fun, np.asarray(x0, dtype=np.float64)
        raise Captured

    monkeypatch.setattr(optimize, "minimize", capture)
    with pytest.raises(Captured):
        fit_removal_ripple(p.uv, times, p.pieces, tif, spacing_mm=H, steps=1)
    fun, x0 = seen["fun"], seen["x0"]
    _, grad = fun(x0)
    ks = np.argsort(-np.abs(grad))[:4].tolist() + np.linspace(0, len(x0) - 1, 4).astype(int).tolist()
    for k in ks:
        e = 1e-5
        up, down = x0.copy(), x0.copy()
        up[k] += e
        down[k] -= e
        fd = (fun(up)[0] - fun(down)[0]) / (2 * e)
        assert abs(fd - grad[k]) <= 1e-4 * np.abs(grad).max() + 1e-3 * abs(fd), (k, fd, grad[k])


def test_the_linearised_curve_reproduces_the_machines_samples(walk):
    p, times, _, _ = walk
    xy = np.asarray(p.uv, dtype=np.float64)
    tp, timed, _ = machine_tool_path(xy, times, p.pieces, spacing_mm=H)
    ops = _curve_operators(xy, np.asarray(p.pieces), tp)
    assert ops, "a piece long enough for the cubic"
    samples = np.asarray(timed.xy)
    for rows, bmat, lu, a, b in ops:
        model = bmat @ lu.solve(xy[a:b])
        assert np.abs(model - samples[rows]).max() < 1e-6  # the same curve, to rounding
        moved = xy[a:b] + 0.01  # a rigid shift moves every sample with it (the map is affine-invariant)
        assert np.allclose(bmat @ lu.solve(moved), samples[rows] + 0.01, atol=1e-6)


def test_the_fit_keeps_the_paths_guarantees(walk):
    p, _, _, fit = walk
    assert_fit_keeps_guarantees(p.uv, p.pieces, fit.xy, H)


def test_the_fit_is_the_same_bytes_for_the_same_input(walk):
    p, times, tif, fit = walk
    again = fit_removal_ripple(p.uv, times, p.pieces, tif, spacing_mm=H, steps=4)
    assert again.xy.tobytes() == fit.xy.tobytes()


def test_a_tool_without_a_feed_dependence_is_fitted_with_its_one_kernel():
    p = plan(square_region(12.0), H, "pseudorandom", seed=1, dwell_points="relaxed")
    fit = fit_removal_ripple(p.uv, np.full(p.n_points, 0.05), p.pieces, gaussian_tif(fwhm_mm=1.5), spacing_mm=H,
                             steps=2)
    assert fit.stats["n_kernels"] == 1
    assert fit.stats["loss"] < fit.stats["loss_planned"]


@pytest.mark.parametrize("kw, match", [({"spacing_mm": 0.0}, "spacing_mm"), ({"band": (3.0, 1.0)}, "band"),
                                       ({"trust_mm": -1.0}, "trust_mm"), ({"steps": -1}, "steps")])
def test_bad_fit_settings_are_refused(kw, match):
    xy = np.column_stack([np.arange(12) * H, np.zeros(12)])
    args = {"spacing_mm": H, **kw}
    with pytest.raises(ParameterError, match=match):
        fit_removal_ripple(xy, np.full(12, 0.05), None, default_tif(), **args)


def test_a_path_without_a_covered_interior_is_refused():
    xy = np.column_stack([np.arange(12) * H, np.zeros(12)])  # one line: nothing is covered fully
    with pytest.raises(ParameterError, match="interior"):
        fit_removal_ripple(xy, np.full(12, 0.05), None, default_tif(), spacing_mm=H, steps=1)


def test_the_comparison_offers_the_ripple_fit():
    assert "ripple-fit" in TREATMENTS


@pytest.mark.slow
def test_given_to_every_path_the_fit_lowers_every_paths_band_rms():
    region = square_region(18.0)
    planned = {"relaxed": plan(region, H, "pseudorandom", seed=0, dwell_points="relaxed"),
               "rectangular": plan(region, H, "rectangular"), "spiral": plan(region, H, "spiral")}
    kw = dict(seed=0, seeds=1, mode="interference-free", timing="machine", dx_mm=0.01,
              patch_bounds=patch_bounds_at_centre(region, 14.0))
    before = {r["name"]: r for r in compare_planned(planned, **kw)["rows"]}
    out = compare_planned(planned, treatment="ripple-fit", **kw)
    after = {r["name"]: r for r in out["rows"]}
    assert out["params"]["treatment"] == "ripple-fit"
    # measured on this square: relaxed 1.080 -> 0.585 nm, rectangular 0.889 -> 0.804, spiral 0.922 -> 0.629: the fit
    # judges what the figures judge (the evaluation window, tapered alike), so it lowers every path's band RMS
    for name in planned:
        assert after[name]["treatment"]["loss"] < after[name]["treatment"]["loss_planned"]
        assert after[name]["residual_band_rms_nm"] < 0.97 * before[name]["residual_band_rms_nm"], (name, before, after)
    assert after["relaxed"]["residual_band_rms_nm"] < 0.7 * before["relaxed"]["residual_band_rms_nm"], (before, after)
    assert after["relaxed"]["lattice_peak_db"] < after["rectangular"]["lattice_peak_db"] - 6.0
