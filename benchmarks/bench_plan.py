"""Benchmark of the planner: points per second on a disc, a five-pointed star and an annulus.

Prints, for 1e4, 1e5 and 1e6 dwell points (1e7 with ``--big``): grid time,
planning time, points per second end to end, pieces, walk fraction, direction
share range, and (``--metrics``) the seconds of ``path_metrics`` (the job's
"metrics" stage: every figure of the path, crossings checked independently,
largest empty disc) and the crossings it counted. The raster
baseline on the same grid is the peer: its end-to-end time is printed and the
ratio pseudo-random / raster.

    PYTHONPATH=src python benchmarks/bench_plan.py [--big] [--metrics] [--seed 0]

Numba compiles once (cached on disk); a warm-up run on a small disc is done
first so the table shows the steady state.
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np

from polishpath.plan import direction_shares, path_metrics, plan
from polishpath.types import Region


def disc_region(area: float) -> Region:
    r = np.sqrt(area / np.pi)
    t = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    return Region(np.c_[r * np.cos(t), r * np.sin(t)])


def star_region(area: float) -> Region:
    t = np.linspace(0, 2 * np.pi, 10, endpoint=False) + np.pi / 2
    rad = np.where(np.arange(10) % 2 == 0, 1.0, 0.45)
    pts = np.c_[rad * np.cos(t), rad * np.sin(t)]
    a0 = Region(pts).area
    return Region(pts * np.sqrt(area / a0))


def annulus_region(area: float) -> Region:
    # inner radius 0.4 R
    R = np.sqrt(area / (np.pi * (1 - 0.16)))
    t = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    c = np.c_[np.cos(t), np.sin(t)]
    return Region(c * R, (c[::-1] * 0.4 * R,))


SHAPES = {"disc": disc_region, "star": star_region, "annulus": annulus_region}


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--big", action="store_true", help="also 1e7 dwell points")
    ap.add_argument("--metrics", action="store_true", help="also time path_metrics (crossings checked independently)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sizes", type=str, default="", help="comma separated point counts (overrides)")
    ap.add_argument("--shapes", type=str, default="disc,star,annulus")
    args = ap.parse_args()

    sizes = [10_000, 100_000, 1_000_000] + ([10_000_000] if args.big else [])
    if args.sizes:
        sizes = [int(float(s)) for s in args.sizes.split(",")]
    t0 = time.perf_counter()
    path_metrics(plan(disc_region(400.0), 1.0, seed=0), disc_region(400.0))  # warm-up: numba compile or cache load
    print(f"warm-up (compile or cache load): {time.perf_counter() - t0:.2f} s")
    hdr = (
        f"{'shape':8s} {'points':>9s} {'grid s':>7s} {'plan s':>7s} {'total s':>8s} {'pts/s':>10s} "
        f"{'pieces':>6s} {'walk%':>6s} {'dir min..max %':>15s} {'raster s':>8s} {'ratio':>6s} {'RSS MB':>7s}"
        + (f" {'metrics s':>9s} {'cross':>5s}" if args.metrics else "")
    )
    print(hdr)
    for n in sizes:
        for shape in args.shapes.split(","):
            region = SHAPES[shape](float(n))  # spacing 1 mm: about n points
            t = time.perf_counter()
            p = plan(region, 1.0, seed=args.seed)
            total = time.perf_counter() - t
            t = time.perf_counter()
            r = plan(region, 1.0, "raster")
            t_r = time.perf_counter() - t
            sh = direction_shares(p.uv, p.pieces) * 100
            line = (
                f"{shape:8s} {p.n_points:9d} {p.stats['grid_seconds']:7.2f} "
                f"{total - p.stats['grid_seconds']:7.2f} {total:8.2f} {p.n_points / total:10.0f} "
                f"{len(p.pieces) - 1:6d} {100 * p.stats['walk_fraction']:6.1f} "
                f"{sh.min():7.1f}..{sh.max():5.1f}  {t_r:8.2f} {total / t_r:6.1f} {peak_rss_mb():7.0f}"
            )
            if args.metrics:
                t = time.perf_counter()
                m = path_metrics(p, region)
                line += f" {time.perf_counter() - t:9.2f} {m['crossings']:5d}"
            print(line, flush=True)
            assert r.n_points == p.n_inside


if __name__ == "__main__":
    main()
