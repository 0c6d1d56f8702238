"""A start point the user gives is where a lattice-free path begins (``--start`` with ``--dwell-points blue-noise``
or ``relaxed``).

The walk over a neighbour graph turns the whole path round to avoid tool lifts (at a rim point of one neighbour,
or where only the other end can move on), so its first point was almost never the start asked for: on discs of
2x10^4 points, seeds 1-6, the start ended up 98 to 18,282 points into the path. With a start given the walk keeps it
first; without one it grows from the point nearest the centre and the path may begin elsewhere (reported as
``stats["first_point"]``).
"""

from __future__ import annotations

import numpy as np
import pytest

from polishpath.plan import plan
from polishpath.plan.bluewalk import _begin_at
from polishpath.plan.metrics import count_crossings
from polishpath.types import Region


def _disc(r=40.0):
    t = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    return Region(np.c_[r * np.cos(t), r * np.sin(t)])


@pytest.mark.parametrize("dwell_points", ["blue-noise", "relaxed"])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_given_start_is_the_first_point(dwell_points, seed):
    region = _disc()
    start = (5.0, -3.0)
    p = plan(region, 1.0, seed=seed, dwell_points=dwell_points, start=start)
    nearest = np.argmin(np.hypot(*(p.uv - np.array(start)).T))
    assert np.hypot(*(p.uv[0] - start)) == pytest.approx(np.hypot(*(p.uv[nearest] - start)))
    assert p.stats["first_point"] == p.stats["start_point"]
    assert len(np.unique(p.ij[:, 0])) == len(p.uv)  # every point once
    assert p.stats["n_pieces"] == 1 and p.stats["start_cut"] == 0  # a disc stays one piece
    assert count_crossings(p.uv, p.pieces) == 0


def test_without_a_start_the_first_point_is_reported():
    p = plan(_disc(), 1.0, seed=1, dwell_points="blue-noise")
    assert p.stats["first_point"] == int(p.ij[0, 0])
    assert p.provenance.params["start"] == pytest.approx([0.0, 0.0], abs=1e-9)


def test_begin_at_reverses_or_cuts_the_first_piece():
    order = np.array([4, 7, 1, 9, 3, 8])
    offs = np.array([0, 4, 6])
    out, o, cut = _begin_at(order, offs, 9)  # the far end of the first piece: reversed, no lift
    assert out.tolist() == [9, 1, 7, 4, 3, 8] and o.tolist() == [0, 4, 6] and cut == 0
    out, o, cut = _begin_at(order, offs, 1)  # inside it: cut there, one piece more
    assert out.tolist() == [1, 9, 4, 7, 3, 8] and o.tolist() == [0, 2, 4, 6] and cut == 1
