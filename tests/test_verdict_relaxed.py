"""The claims of issue 26's verdict (docs/simulation.md, "The walk without a lattice: the verdict") on a reduced case.

A flat 18 mm square, a 14 mm patch at 10 um (the band's upper half, 50-100
1/mm, is not resolved at this pitch; the docs' table uses 5 um), one seed,
interference-free, machine timing: what the verdict relies on, each check able
to fail:

* the relaxed walk (``pseudorandom:relaxed``) has a lower lattice peak than every
  path with a lattice, the grid walk included, each read at its own frequencies
  (the walk over the Poisson-disk set ties it);
* its time density shows no peak (<= 2 dB) at 1/(2h), 1/h, sqrt(2)/h, 2/h where
  the grid walk's shows one, in a window large enough to read it (30 mm);
* what keeps the verdict from being met: the periodic paths' band RMS stays
  well below the walks'.

Not checked here: that the Lloyd steps lower the walk's band RMS. Over seeds the
gain is about 3 % (9 % with the footprint at zero feed), smaller than one seed's
spread, so a reduced case cannot show it reliably (docs/simulation.md).
"""

from __future__ import annotations

import numpy as np
import pytest

from polishpath.plan import plan
from polishpath.simulate.compare import compare_planned
from polishpath.simulate.fair import time_density_peak_db
from polishpath.simulate.machinetime import machine_timed_path
from polishpath.simulate.patterns import patch_bounds_at_centre, square_region

H = 0.5
PATHS = (("pseudorandom", "grid"), ("pseudorandom", "relaxed"), ("pseudorandom", "blue-noise"),
         ("rectangular", "grid"), ("spiral", "grid"))


@pytest.fixture(scope="module")
def rows():
    region = square_region(18.0)
    planned = {f"{p}:{d}": plan(region, H, p, seed=0, dwell_points=d) for p, d in PATHS}
    out = compare_planned(planned, seed=0, seeds=1, mode="interference-free", timing="machine", dx_mm=0.01,
                          patch_bounds=patch_bounds_at_centre(region, 14.0))
    return {r["name"]: r for r in out["rows"]}


@pytest.mark.slow
def test_the_relaxed_walk_has_a_lower_lattice_peak_than_every_path_with_a_lattice(rows):
    mine = rows["pseudorandom:relaxed"]["lattice_peak_db"]
    others = {k: r["lattice_peak_db"] for k, r in rows.items() if k != "pseudorandom:relaxed"}
    assert mine < min(v for k, v in others.items() if "blue-noise" not in k), (mine, others)
    assert mine < rows["pseudorandom:grid"]["lattice_peak_db"] - 6.0  # far below the grid walk's


@pytest.mark.slow
def test_the_periodic_paths_keep_the_lower_band_rms_while_the_footprint_leans(rows):
    # the verdict's second condition is not met: rectangular below every walk (measured 0.83-0.89 against 1.1)
    walks = [rows[k]["residual_band_rms_nm"] for k in ("pseudorandom:grid", "pseudorandom:relaxed")]
    assert rows["rectangular:grid"]["residual_band_rms_nm"] < 0.9 * min(walks)


def test_the_relaxed_walks_time_density_has_no_peak_where_the_grid_walks_has():
    region = square_region(40.0)
    window = (-15.0, -15.0, 15.0, 15.0)
    peaks = {}
    for dset in ("grid", "relaxed"):
        p = plan(region, H, "pseudorandom", seed=1, dwell_points=dset)
        timed, _ = machine_timed_path(p.uv, np.full(p.n_points, 0.05), p.pieces, spacing_mm=H)
        peaks[dset] = time_density_peak_db(timed.xy, timed.time_s, H, window)
    assert peaks["relaxed"] <= 2.0, peaks  # measured 0.77 (seed 1), 1.28 (seed 0)
    assert peaks["grid"] > 8.0, peaks  # measured 12.1
