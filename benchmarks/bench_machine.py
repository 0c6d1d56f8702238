"""Benchmark (issue 16): what a machine with limited axes delivers of the planned dwell times.

Run: ``PYTHONPATH=src python benchmarks/bench_machine.py [--surface hemisphere] [--spacing 0.5] [--seed 1]``

For the demo job (``make demo``: the built-in hemisphere at 0.5 mm, seed 1) with
the pseudo-random path and with a raster path, the feed schedule under three
machine profiles (examples/machine-gentle.toml 0.2 m/s^2, -typical 1 m/s^2,
-stiff 5 m/s^2 on X and Y, half on Z; 10 m/min) is computed and printed as a
table: machining time of the path moves, its increase on the plan, the share of
segments the limits slow, the dwell-time error (delivered / planned - 1 over
the dwell points: max, p99, RMS), the dwell points more than 1 % late, and the
schedule's own seconds. So the cost of the pseudo-random path's turns on a real
machine is a measured number.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
PROFILES = ("gentle", "typical", "stiff")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--surface", default="hemisphere")
    ap.add_argument("--spacing", type=float, default=0.5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--patterns", default="pseudorandom,raster")
    args = ap.parse_args()

    from polishpath.pipeline import run
    from polishpath.schedule import load_machine, schedule_feeds

    machines = {p: load_machine(EXAMPLES / f"machine-{p}.toml") for p in PROFILES}
    head = (f"{'path':13s} {'machine':8s} {'acc m/s2':>8s} {'time s':>9s} {'vs plan':>8s} {'limited':>8s} "
            f"{'err max':>8s} {'err p99':>8s} {'err rms':>8s} {'>1% late':>9s} {'sched s':>7s}")
    rows = []
    for pattern in args.patterns.split(","):
        t0 = time.perf_counter()
        job = run(surface=args.surface, spacing=args.spacing, seed=args.seed, pattern=pattern, report=False)
        n = job.planar.n_points
        print(f"{pattern}: {n} dwell points, {len(job.tool_path.samples)} samples, planned "
              f"{job.tool_path.stats['duration_s']:.1f} s (job {time.perf_counter() - t0:.1f} s)", flush=True)
        for name, m in machines.items():
            t = time.perf_counter()
            _, r = schedule_feeds(job.tool_path, m)
            secs = time.perf_counter() - t
            e = r["dwell_time_error"]
            rows.append(f"{pattern:13s} {name:8s} {m.max_acceleration_mm_s2[0] / 1000:8.1f} "
                        f"{r['machining_time_s']:9.1f} {100 * r['time_increase']:+7.1f}% "
                        f"{100 * r['limited_share']:7.1f}% {e['max']:8.3f} {e['p99']:8.3f} {e['rms']:8.3f} "
                        f"{r['points_over_1pct']:4d}/{n:<4d} {secs:7.2f}")
    print()
    print(head)
    print("\n".join(rows))


if __name__ == "__main__":
    main()
