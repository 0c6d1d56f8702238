"""Plan path patterns in a planar region and compare them fairly (the Table 4 analogue on a plane).

:func:`compare_patterns` plans each pattern with the planning stage
(:func:`polishpath.plan.plan`; a random pattern once per seed) and hands the
plans to :func:`~polishpath.simulate.compare.compare_planned`.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from ..defaults import DEFAULT_SPACING_MM
from ..errors import ParameterError
from ..types import Region
from .compare import check_comparison, compare_planned

__all__ = ["compare_patterns", "patch_bounds_at_centre", "square_region"]


def square_region(size_mm: float) -> Region:
    """A centred square of side ``size_mm`` (mm)."""
    h = size_mm / 2
    return Region(np.array([[-h, -h], [h, -h], [h, h], [-h, h]]))


def patch_bounds_at_centre(region: Region, patch_mm: float | None):
    """Bounds of a centred square of side ``patch_mm`` at the region's centroid (None: the region's bounds)."""
    if patch_mm is None:
        return tuple(map(float, region.bounds))
    if not patch_mm > 0:
        raise ParameterError(f"the patch side must be > 0 mm, got {patch_mm}.")
    cx, cy = region.centroid
    return (cx - patch_mm / 2, cy - patch_mm / 2, cx + patch_mm / 2, cy + patch_mm / 2)


def compare_patterns(region_or_size: Region | float = 20.0,
                     patterns=("pseudorandom", "raster", "spiral", "rectangular"), spacing: float = DEFAULT_SPACING_MM,
                     seed: int = 0, *, seeds: int = 5, patch_mm: float | None = None, **kw) -> dict[str, Any]:
    """Plan each pattern in a planar region, then :func:`compare_planned` (the Table 4 analogue on a plane).

    A random pattern (:data:`polishpath.plan.RANDOM_PATTERNS`: the pseudo-random
    planner, the Table 3 peers) is planned once per seed (``seed + i``), a
    deterministic one once. For a part, plan on it through
    :func:`polishpath.pipeline.plan_on_surface` (spacing on the part) and call
    :func:`compare_planned`, as ``polishpath simulate SURFACE`` does.

    Parameters
    ----------
    region_or_size : Region or float
        Planar region (mm) or the side of a centred square, mm.
    patterns : sequence of str
        Planner pattern names (:data:`polishpath.plan.PATTERNS`).
    spacing : float
        Dwell-point spacing in the plane, mm.
    seed : int
        Base seed of the planner, the initial surface and the process noise.
    seeds : int
        Number of seeds.
    patch_mm : float, optional
        Simulate only a centred square of this side (mm) at the region's
        centroid while planning over the whole region.
    **kw :
        Everything else of :func:`compare_planned` (mode, timing, tif, noise, dx_mm ...).

    Returns
    -------
    dict
        As :func:`compare_planned`; ``params["plans"]`` has each plan's provenance (first seed).
    """
    from ..plan import RANDOM_PATTERNS, plan  # the planning stage, looked up at call time

    check_comparison(seeds=seeds, mode=kw.get("mode", "process"), timing=kw.get("timing", "machine"))
    region = region_or_size if isinstance(region_or_size, Region) else square_region(float(region_or_size))
    planned, info = {}, {}
    for pat in patterns:
        tp = time.perf_counter()
        random = pat in RANDOM_PATTERNS
        pps = [plan(region, spacing, pat, seed=seed + i) for i in range(seeds if random else 1)]
        planned[pat] = pps if random else pps[0]
        info[pat] = {"n_points": int(pps[0].n_points), "n_unreached": int(len(pps[0].unreached)),
                     "random": random, "seeds": [seed + i for i in range(len(pps))],
                     "provenance": pps[0].provenance.to_dict(), "seconds": time.perf_counter() - tp}
    return compare_planned(planned, seed=seed, seeds=seeds, patch_bounds=patch_bounds_at_centre(region, patch_mm),
                           plan_info=info, **kw)
