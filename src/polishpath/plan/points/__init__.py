"""Dwell-point sets: where the tool dwells, before a walk orders them.

* ``grid``: the paper's square grid (:func:`polishpath.plan.dwell_grid`,
  :class:`~polishpath.plan.DwellGrid`): a lattice with integer indices i, j and
  8-neighbour steps;
* ``blue-noise``: a Poisson-disk set with no lattice at all
  (:func:`blue_noise_points`, :class:`BlueNoisePoints`), at the grid's density,
  with a planar neighbour graph (kept Delaunay edges) for the walk;
* ``relaxed``: the blue-noise set after a few Lloyd steps (:func:`relaxed_points`): no lattice, evener
  cells (less density noise), walked the same way.

:data:`DWELL_POINT_SETS` names them; ``plan(..., dwell_points=...)`` and
``--dwell-points`` choose one.
"""

from ..dwell import DwellGrid, dwell_grid
from .blue_noise import BlueNoisePoints, blue_noise_points
from .relaxed import relaxed_points

#: The dwell-point sets by name, and whether each has a lattice.
DWELL_POINT_SETS = {"grid": True, "blue-noise": False, "relaxed": False}

__all__ = ["BlueNoisePoints", "DWELL_POINT_SETS", "DwellGrid", "blue_noise_points", "dwell_grid", "relaxed_points"]
