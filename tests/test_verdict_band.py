"""Where a path's residual band RMS sits (issue 26 Build 4, docs/simulation.md "Where the walks' band RMS comes from").

:func:`polishpath.simulate.fair.band_powers_nm2` splits the band power over
rings of spatial frequency; on a reduced case (a flat 18 mm square, a 14 mm
patch at 10 um, one seed, interference-free, machine timing, as
tests/test_verdict_relaxed.py) it shows the account the docs give for the
verdict's unmet second condition, each check able to fail:

* the relaxed walk's excess band power over the rectangular path's sits in the
  ring 1-1.5 1/mm, just above the band's lower edge, where the 2 mm tool passes
  most; the rectangular path's power sits at its line frequency 1/h (2-2.5 1/mm);
* the machine samples' time density carries that ring: the walk's several times
  the rectangular path's (its segments run in every direction).
"""

from __future__ import annotations

import numpy as np
import pytest

from polishpath.errors import ParameterError
from polishpath.plan import plan
from polishpath.simulate.compare import _crop, _dwell_s_per_point, compare_paths
from polishpath.simulate.fair import band_powers_nm2, band_rms_nm, detrend_residual
from polishpath.simulate.machinetime import machine_timed_path
from polishpath.simulate.patterns import patch_bounds_at_centre, square_region
from polishpath.simulate.removal import rasterize_time
from polishpath.simulate.rotating import default_tif
from polishpath.simulate.workpiece import flat_workpiece

H = 0.5
EDGES = (1.0, 1.5, 2.0, 2.5, 3.0, 50.0)


def test_the_rings_add_up_to_the_band_rms_and_a_ripple_sits_in_its_ring():
    rng = np.random.default_rng(3)
    dx = 0.02
    z = rng.normal(size=(256, 320))
    x = np.arange(320) * dx
    z = z + 4.0 * np.sin(2 * np.pi * 2.2 * x)[None, :]  # a ripple at 2.2 1/mm
    rings = band_powers_nm2(z, dx, EDGES)
    assert rings.shape == (len(EDGES) - 1,)
    assert rings.sum() == pytest.approx(band_rms_nm(z, dx, (EDGES[0], EDGES[-1])) ** 2, rel=1e-9)
    assert int(np.argmax(rings)) == 2  # 2-2.5 1/mm
    assert rings[2] > 0.8 * 4.0**2 / 2  # the ripple's power (amplitude^2 / 2) minus the window's leakage


@pytest.mark.parametrize("edges", [(1.0,), (2.0, 1.0), (-1.0, 2.0), (1.0, np.nan)])
def test_bad_ring_edges_are_refused(edges):
    with pytest.raises(ParameterError, match="edges"):
        band_powers_nm2(np.zeros((32, 32)), 0.02, edges)


@pytest.fixture(scope="module")
def rings():
    region = square_region(18.0)
    pb = patch_bounds_at_centre(region, 14.0)
    dx = 0.01
    t_point, tif, _ = _dwell_s_per_point(default_tif(), H, 200.0)
    wp = flat_workpiece(pb, dx)
    inset = tif.radius_mm + H
    ev = (pb[0] + inset, pb[1] + inset, pb[2] - inset, pb[3] - inset)
    out = {}
    for pattern, dset in (("pseudorandom", "relaxed"), ("rectangular", "grid")):
        p = plan(region, H, pattern, seed=0, dwell_points=dset)
        timed, _ = machine_timed_path(p.uv, np.full(p.n_points, t_point), p.pieces, spacing_mm=H)
        o = compare_paths({pattern: (timed.xy, timed.time_s, timed.pieces, "moves")}, wp, tif, noise=None,
                          smoothing=None, spacing_mm=H, eval_bounds=ev, keep_results=True, depth_nm=200.0)
        res = o["results"][pattern]
        z = detrend_residual(_crop(res.after_nm, res.origin_mm, dx, ev).astype(np.float64), dx)
        rho = _crop(rasterize_time(timed.xy, timed.time_s, res.after_nm.shape, res.origin_mm, dx)[0],
                    res.origin_mm, dx, ev)
        out[pattern] = (band_powers_nm2(z, dx, EDGES), band_powers_nm2(rho / rho.mean(), dx, EDGES))
    return out


@pytest.mark.slow
def test_the_walks_excess_band_power_sits_just_above_the_bands_lower_edge(rings):
    walk, rect = rings["pseudorandom"][0], rings["rectangular"][0]
    assert walk.sum() > rect.sum()  # the verdict's unmet condition, on this case
    # measured on the 22 mm square (benchmarks/verdict_spectrum.py): 0.75 against 0.05 nm^2 in 1-1.5 1/mm
    assert walk[0] > 5.0 * rect[0], (walk, rect)
    assert walk[0] - rect[0] > 0.5 * (walk.sum() - rect.sum()), (walk, rect)
    assert int(np.argmax(rect)) == 2, rect  # the rectangular path's line at 1/h = 2 1/mm


@pytest.mark.slow
def test_the_walks_time_density_carries_that_ring(rings):
    walk, rect = rings["pseudorandom"][1], rings["rectangular"][1]
    # measured on the 22 mm square: 0.20 against 0.041 (relative power, 1-1.5 1/mm)
    assert walk[0] > 3.0 * rect[0], (walk, rect)
