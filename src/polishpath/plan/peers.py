"""The other pseudo-random paths of the paper's Table 3, built on our dwell grid (issue 8).

Four patterns, each ``fn(grid, region, *, seed, start, **options) -> PatternResult``
and registered with :func:`register_peers` (the maze pair is in ``_mazes``, the
curve pair in ``_curves``; this module is their one public door):

``unicursal``
    Dunn & Walker (Optics Express 16, 18942, 2008) / Beaucamp line: a perfect
    maze (random spanning tree) on a coarse grid whose cells are 2 x 2 dwell
    points; walking along the maze walls (spanning-tree coverage) gives one
    closed, non-crossing path through every dwell point of the maze's cells.
    A coarse cell is used only when its 4 dwell points are inside and joined
    by inside steps, and two cells are joined only when both fine steps
    between them are inside, so holes and concave boundaries are respected.
    Dwell points in no usable cell are left out by design (``stats["left_out"]``).
``maze``
    Zhang et al.'s pseudo-random path based on a perfect maze, with its
    boundary handling as published: one scan line per maze row; the first
    boundary crossing enters the region, the second leaves it, and every maze
    cell touching that interval is used. Whatever lies after the second
    crossing (the far arm of a star, the far side of a hole) is left out, and
    cells sticking over the boundary put path points outside the region
    (``stats["outside_points"]``, ``"outside_steps"``, ``"area_outside_mm2"``).
    The maze is a depth-first ("recursive backtracker") perfect maze. Steps are
    along the two grid axes only.
``fractal``
    Dong et al.'s random fractal-like path: the grid's bounding square
    (side 2^k dwell points) is divided recursively into 4 quadrants, visited in
    a random order with random entry / exit corners (8-neighbour links between
    quadrants, so diagonals appear); the curve is clipped to the region and
    split where a link would leave it. Its published smoothing is an
    approximating spline that does not pass through the dwell points: the
    pattern measures that deviation with :func:`bspline_deviation` (uniform
    cubic B-spline with the dwell points as control points), ``stats
    ["smoothing_dev_max"]`` (mm).
``hilbert``
    The classic Hilbert curve on the bounding square, clipped to the region
    the same way; ``seed % 8`` picks one of its 8 symmetric orientations.

Every pattern is reproducible with its seed (numpy ``SeedSequence``; numba's
generator seeded inside the kernel for the depth-first maze).
"""

from __future__ import annotations

from ._curves import bspline_deviation, fractal_sequence, hilbert_sequence, pattern_fractal, pattern_hilbert
from ._mazes import pattern_maze, pattern_unicursal
from .api import PATTERNS, register_pattern

__all__ = [
    "PEER_PATTERNS",
    "bspline_deviation",
    "fractal_sequence",
    "hilbert_sequence",
    "pattern_fractal",
    "pattern_hilbert",
    "pattern_maze",
    "pattern_unicursal",
    "register_peers",
]


#: The peer patterns by name.
PEER_PATTERNS = {
    "unicursal": pattern_unicursal,
    "maze": pattern_maze,
    "fractal": pattern_fractal,
    "hilbert": pattern_hilbert,
}


def register_peers() -> dict[str, bool]:
    """Register the peer patterns with :func:`polishpath.plan.register_pattern` (idempotent).

    A name already registered to another function is left alone.

    Returns
    -------
    dict
        Pattern name -> True when it now refers to the peer defined here.
    """
    out = {}
    for name, fn in PEER_PATTERNS.items():
        cur = PATTERNS.get(name)
        if cur is None or cur is fn:
            register_pattern(name, fn, random=True)
        out[name] = PATTERNS.get(name) is fn
    return out
