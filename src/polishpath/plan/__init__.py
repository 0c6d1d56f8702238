"""polishpath.plan: dwell points in a planar region and tool paths through them.

Public API
----------
dwell_grid(region, spacing, *, margin, origin, rotation) -> DwellGrid
plan(region, spacing, pattern="pseudorandom", *, seed, start, margin, origin, rotation) -> PlanarPath
path_metrics(path, region=None) -> dict
count_crossings(uv, pieces=None) -> int
PATTERNS, register_pattern(name, fn)
"""

from .api import PATTERNS, RANDOM_PATTERNS, PatternResult, nearest_dwell_point, plan, register_pattern
from .dwell import DIR_NAMES, DIRS, DwellGrid, dwell_grid, grid_to_uv, region_polygon, uv_to_grid
from .metrics import count_crossings, direction_shares, largest_empty_disc, path_metrics
from .pseudorandom import pseudorandom_order

__all__ = [
    "DIRS",
    "DIR_NAMES",
    "DwellGrid",
    "PATTERNS",
    "PatternResult",
    "RANDOM_PATTERNS",
    "count_crossings",
    "direction_shares",
    "dwell_grid",
    "grid_to_uv",
    "largest_empty_disc",
    "nearest_dwell_point",
    "path_metrics",
    "plan",
    "pseudorandom_order",
    "region_polygon",
    "register_pattern",
    "uv_to_grid",
]


# the peers of the paper's Table 3 (unicursal, maze, fractal, hilbert) register themselves
from . import peers as _peers  # noqa: E402

_peers.register_peers()
