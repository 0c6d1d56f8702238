"""The other pseudo-random paths of the paper's Table 3, built on our dwell grid (issue 8).

Four patterns, each ``fn(grid, region, *, seed, start, **options) -> PatternResult``
and registered with :func:`register_peers`; this module is their one public door,
and each is described where it is built:

``unicursal``, ``maze``
    Dunn & Walker's unicursal path and Zhang et al.'s maze path, both walking the
    walls of a random perfect maze: :mod:`polishpath.plan._mazes`.
``fractal``, ``hilbert``
    Dong et al.'s random fractal-like path and the Hilbert curve on the bounding
    square, clipped to the region: :mod:`polishpath.plan._curves`.

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
