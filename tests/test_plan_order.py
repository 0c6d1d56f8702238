"""The pseudo-random planner's order, point for point, against orders stored from the code before the walk's split.

``tests/data/plan_order/orders.json`` was written once by ``make_plan_order.py``
from the planner as it was before ``plan/_walk.py`` was split into treap, walk
and end-game modules. The cases cover one and two grid components, holes,
random turnarounds, no backtracking, an end-game kick and a leftover walked as
its own piece. A change that is *meant* to alter the walk regenerates the file
and says so in its commit message.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent / "data" / "plan_order"
sys.path.insert(0, str(HERE))
from make_plan_order import CASES, plan_case  # noqa: E402

STORED = json.loads((HERE / "orders.json").read_text())


def test_every_case_is_stored():
    assert sorted(STORED) == sorted(CASES)


@pytest.mark.parametrize("name", sorted(CASES))
def test_planner_order_is_unchanged(name):
    got = plan_case(name)
    want = STORED[name]
    assert got["n"] == want["n"], "the dwell grid changed, not only the walk"
    assert got["order_head"] == want["order_head"]
    assert got["pieces"] == want["pieces"]
    assert got["order_sha256"] == want["order_sha256"]
    assert got["stats"] == want["stats"]
