"""Benchmark of the compiled walk alone: ``pseudorandom_order`` on a disc's dwell grid, best of N.

The dwell grid is built once per size and not timed, so the figure is the
planner's own time (walk, end-game, piece collection): wall-clock and CPU
seconds (the walk is single-threaded, so on a loaded machine the CPU time is
the steadier figure). Numba is compiled (or
loaded from its cache) by a warm-up run first. Used to check that a change to
the walk's code structure keeps its speed (issue 13: the split of
``plan/_walk.py``).

    PYTHONPATH=src python benchmarks/bench_plan_walk.py [--sizes 1e5,1e6] [--repeat 3] [--seed 0] [--endgame]

``--endgame`` plans with ``backtrack=0, max_blind=2, steer=4``, so that a good
share of the points is placed by the end-game (splices, 2-opt moves) rather
than by the walk; the "walk%" column says how much.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from polishpath.plan import dwell_grid, pseudorandom_order
from polishpath.types import Region


def disc_region(area: float) -> Region:
    r = np.sqrt(area / np.pi)
    t = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    return Region(np.c_[r * np.cos(t), r * np.sin(t)])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=str, default="1e5,1e6", help="comma separated point counts (spacing 1 mm)")
    ap.add_argument("--repeat", type=int, default=3, help="runs per size; the best is reported")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--endgame", action="store_true", help="options that leave much to the end-game")
    args = ap.parse_args()

    options = {"backtrack": 0, "max_blind": 2, "steer": 4} if args.endgame else {}
    t0 = time.perf_counter()
    pseudorandom_order(dwell_grid(disc_region(400.0), 1.0), seed=0)
    print(f"warm-up (compile or cache load): {time.perf_counter() - t0:.2f} s")
    print(f"{'points':>9s} {'best s':>7s} {'median s':>8s} {'best cpu s':>10s} {'pts/s':>10s} {'pieces':>6s} {'walk%':>6s}")
    for n in (int(float(s)) for s in args.sizes.split(",")):
        grid = dwell_grid(disc_region(float(n)), 1.0)
        times, cpu = [], []
        for _ in range(args.repeat):
            t, c = time.perf_counter(), time.process_time()
            order, pieces, stats = pseudorandom_order(grid, seed=args.seed, **options)
            times.append(time.perf_counter() - t)
            cpu.append(time.process_time() - c)
        best = min(times)
        print(f"{grid.n:9d} {best:7.3f} {float(np.median(times)):8.3f} {min(cpu):10.3f} {grid.n / best:10.0f} "
              f"{len(pieces) - 1:6d} {100 * stats['walk_fraction']:6.1f}", flush=True)


if __name__ == "__main__":
    main()
