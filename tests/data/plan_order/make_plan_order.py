"""Write ``orders.json``: the pseudo-random planner's order on a few regions, from today's code.

``tests/test_plan_order.py`` plans the same cases and compares the dwell-point
order, the piece offsets and every counter of the walk (all but ``seconds``)
with this file, so a refactoring of the compiled walk (``plan/_walk.py`` and
friends) is checked to give the same path, point for point. A change that is
*meant* to alter the walk regenerates the file on purpose and says so in its
commit message:

    PYTHONPATH=src python tests/data/plan_order/make_plan_order.py
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from polishpath.plan import dwell_grid, pseudorandom_order
from polishpath.types import Region

HERE = Path(__file__).resolve().parent
OUT = HERE / "orders.json"


def _disc(r, n=96, c=(0.0, 0.0)):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.c_[c[0] + r * np.cos(t), c[1] + r * np.sin(t)]


def _star(R=12.0, r=5.0, k=5, phase=0.3):
    t = np.linspace(0, 2 * np.pi, 2 * k, endpoint=False) + phase
    rad = np.where(np.arange(2 * k) % 2 == 0, R, r)
    return np.c_[rad * np.cos(t), rad * np.sin(t)]


def _dumbbell():
    # two discs joined by a neck between two grid rows (spacing 0.5): two grid components
    import shapely

    a = _disc(6.0, 64, (-8.0, 0.0))
    b = _disc(6.0, 64, (8.0, 0.0))
    neck = shapely.box(-3.0, 0.1, 3.0, 0.4)
    poly = shapely.unary_union([shapely.Polygon(a), shapely.Polygon(b), neck])
    return np.asarray(poly.exterior.coords)[:-1]


#: name -> (region maker, spacing mm, seed, planner options)
CASES = {
    "disc": (lambda: Region(_disc(10.0)), 0.5, 0, {}),
    "disc_seed7": (lambda: Region(_disc(10.0)), 0.5, 7, {}),
    "star": (lambda: Region(_star()), 0.4, 3, {}),
    "annulus": (lambda: Region(_disc(10.0), (_disc(4.0)[::-1],)), 0.4, 1, {}),
    "two_holes": (lambda: Region(_disc(12.0), (_disc(3.0, 24, (-5, 0))[::-1], _disc(2.5, 24, (5, 1))[::-1])),
                  0.5, 2, {}),
    "dumbbell": (lambda: Region(_dumbbell()), 0.5, 4, {}),
    "random_turns": (lambda: Region(_star()), 0.4, 5, {"shortest": False, "window": 50}),
    "no_backtrack": (lambda: Region(_disc(10.0)), 0.3, 6, {"backtrack": 0, "max_blind": 2, "steer": 4}),
    # the end-game's last resorts: a kick, and a leftover walked as its own sub-path
    "kick": (lambda: Region(_star()), 0.4, 1, {"window": 8, "max_blind": 0, "steer": 1, "backtrack": 0,
                                               "shortest": False}),
    "subwalk": (lambda: Region(_disc(10.0), (_disc(4.0)[::-1],)), 0.4, 1, {"window": 8, "max_blind": 0,
                                                                          "steer": 1, "backtrack": 0}),
    "subwalk_no_kicks": (lambda: Region(_star()), 0.4, 2, {"max_blind": 0, "steer": 4, "backtrack": 0,
                                                          "max_kicks": 0}),
    "big_disc": (lambda: Region(_disc(40.0, 360)), 0.5, 11, {}),
}


def plan_case(name: str) -> dict:
    """Order hash, piece offsets and walk counters of one case."""
    make, spacing, seed, options = CASES[name]
    grid = dwell_grid(make(), spacing)
    order, pieces, stats = pseudorandom_order(grid, seed=seed, **options)
    stats = {k: v for k, v in stats.items() if k != "seconds"}
    return {
        "n": int(grid.n),
        "order_sha256": hashlib.sha256(np.ascontiguousarray(order, dtype="<i8").tobytes()).hexdigest(),
        "order_head": [int(x) for x in order[:20]],
        "pieces": [int(x) for x in pieces],
        "stats": stats,
    }


def main() -> None:
    data = {name: plan_case(name) for name in CASES}
    OUT.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    for name, d in data.items():
        print(name, d["n"], len(d["pieces"]) - 1, {k: d["stats"][k] for k in ("turnarounds", "deleted", "spliced",
              "two_opt", "kicks", "subwalks", "joins", "escapes", "blind", "components", "extra_pieces")})


if __name__ == "__main__":
    main()
