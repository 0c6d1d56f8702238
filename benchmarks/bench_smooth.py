"""Benchmark of the smoothing stage (issues 5, 15): NURBS interpolation, the dwell-time schedule, constant-period samples.

Run: ``PYTHONPATH=src python benchmarks/bench_smooth.py [--sizes 1e5,1e6] [--e2e-triangles 0]``

For each size, the benchmark's flat disk (``bench_job.disk_obj``: the mesh the
whole-job benchmark uses, 0.5 mm spacing, seed 7) is flattened and planned once,
then ``smooth()`` runs as the job runs it (area-weighted dwell times, 600 mm/min,
4 ms, 1 um, the mesh for the boundary check). Printed: the stage's wall and CPU
seconds and machine samples per CPU second, the kernels' own seconds and the
samples they made per second (the regions run again included), the most runs
of a region, the regions corrected and the share of samples made again, the
dwell-time errors (max / p99 / RMS), the chord error and feed fluctuation, and
the same stage with ``keep_samples=False`` (the figures must be equal), and the
issue's 2 M samples/s over the stage met or missed (by how much, and where the
time went). The
machine is shared: CPU seconds are the steadier figure; the load average is
printed. Then the interpolation of a dome serpentine (U-turns) against geomdl's
dense interpolation on small N, and an end-to-end hemisphere run.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from polishpath.smooth import evaluate, interpolate_constant_period, interpolate_nurbs, smooth

TARGET_SAMPLES_PER_S = 2e6  # issue 15: the smoothing stage


def disk_job(n: float, work: Path):
    """(surface, surface path) of the benchmark disk with about ``n`` dwell points."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_job import SEED, SPACING_MM, disk_obj

    from polishpath.flatten import boundary_region, flatten
    from polishpath.pipeline import plan_on_surface
    from polishpath.surfaces import load_surface

    mesh = work / f"disk-{n:.0e}.obj"
    disk_obj(mesh, math.sqrt(n * SPACING_MM**2 / math.pi))
    surf = load_surface(str(mesh))
    flat = flatten(surf, "mabf")
    plan = plan_on_surface(flat, boundary_region(flat), SPACING_MM, seed=SEED, margin=None,
                           max_points=int(4 * n) + 1000)
    return surf, plan.surface_path


def stage(n: float, work: Path) -> None:
    t = time.perf_counter()
    surf, sp = disk_job(n, work)
    print(f"\n== disk, {len(sp.xyz):,} dwell points (planned in {time.perf_counter() - t:.1f} s; "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores) ==")
    runs = {}
    for keep in (True, False):
        w, c = time.perf_counter(), time.process_time()
        tp = smooth(sp, surface=surf, keep_samples=keep)
        w, c = time.perf_counter() - w, time.process_time() - c
        runs[keep] = tp.stats
        st = tp.stats
        m = st["n_samples"]
        ip = st["interpolation_s"]
        passes = st["schedule_passes"]
        rate = m / c
        verdict = ("met" if rate >= TARGET_SAMPLES_PER_S else
                   f"missed by {TARGET_SAMPLES_PER_S / rate:.2f}x: of the {w:.2f} s wall the kernels take {ip:.2f} s "
                   f"(the path once and the regions run again), the rest (the curve fit and its spans, the boundary "
                   f"check, the figures) {max(w - ip, 0.0):.2f} s")
        print(f"  keep_samples={keep!s:<5}: smooth() {w:.2f} s wall, {c:.2f} s CPU -> {m:,} samples, "
              f"{rate / 1e6:.2f} M samples per CPU second over the stage ({m / w / 1e6:.2f} M/s wall); target "
              f"{TARGET_SAMPLES_PER_S / 1e6:.0f} M/s: {verdict}")
        made = m + st["schedule_rerun_samples"] if passes == 1 or st["schedule_rerun_samples"] else m * passes
        print(f"    kernels {ip:.2f} s wall, {made / ip / 1e6:.2f} M samples made per second: most runs of a region "
              f"{passes}, {st['schedule_corrected_regions']:,} regions corrected, "
              f"{st['schedule_rerun_samples'] / m:.1%} of the samples made again; dwell-time error max "
              f"{st['dwell_time_error_max']:.4f} p99 {st['dwell_time_error_p99']:.4f} "
              f"RMS {st['dwell_time_error_rms']:.4f}; chord error max {st['chord_error_max'] * 1e3:.4f} um; "
              f"feed fluctuation max {st['feed_fluctuation_max']:.1e}; feed-limited share "
              f"{st['feed_limited_share']:.3f}; boundary excursion {st['boundary_excursion_max_mm']:.4f} mm")
        del tp
    same = all(runs[True][k] == runs[False][k] for k in runs[True] if k not in ("seconds", "interpolation_s"))
    print(f"  figures with and without the samples held: {'equal' if same else 'DIFFERENT'}")


def dome_path(n: int, seed: int = 0, spacing: float = 0.5) -> np.ndarray:
    """n dwell points: serpentine rows of a square grid (U-turns at the row ends), on a sphere z = sqrt(R^2 - r^2)."""
    side = int(np.ceil(np.sqrt(n)))
    i = np.arange(side * side) // side
    j = np.arange(side * side) % side
    j = np.where(i % 2 == 0, j, side - 1 - j)
    xy = np.column_stack([i, j]).astype(float) * spacing
    xy = xy[:n] - xy[:n].mean(0)
    r2 = (xy**2).sum(1)
    big = 2.0 * np.sqrt(r2.max()) + 10.0
    return np.column_stack([xy, np.sqrt(big**2 - r2)])


def dome(max_n: int) -> None:
    """The interpolation alone on a dome serpentine (its U-turns are where the feed is cut)."""
    t = time.perf_counter()
    c, _ = interpolate_nurbs(dome_path(50))
    interpolate_constant_period(c, 600.0, 4.0, 1e-3)
    print(f"\nwarm-up (numba compile or cache load): {time.perf_counter() - t:.2f} s")
    for n in (10**5, 10**6):
        if n > max_n:
            continue
        pts = dome_path(n)
        t = time.perf_counter()
        curve, u = interpolate_nurbs(pts)
        t_fit = time.perf_counter() - t
        t = time.perf_counter()
        err = np.abs(evaluate(curve, u) - pts).max()
        t_eval = time.perf_counter() - t
        t = time.perf_counter()
        res = interpolate_constant_period(curve, 3000.0, 4.0, 1e-3)
        t_ip = time.perf_counter() - t
        st = res["stats"]
        print(f"dome {n:>8d} points: interpolate_nurbs {t_fit:.2f} s, evaluate at the N dwell params {t_eval:.2f} s"
              f" (through-point error {err:.1e} mm), constant-period 3000 mm/min x 4 ms {t_ip:.2f} s ->"
              f" {st['n_samples']} samples, chord error max {st['chord_error_max'] * 1e3:.3f} um,"
              f" feed fluctuation max {st['feed_fluctuation_max']:.1e} (Taylor predictor alone"
              f" {st['predictor_fluctuation_max']:.1e})")
    try:
        from geomdl import fitting
    except ImportError:
        print("geomdl not installed: no peer ratio")
        return
    for n in (100, 200, 400):
        pts = dome_path(n)
        t = time.perf_counter()
        for _ in range(3):
            interpolate_nurbs(pts)
        ours = (time.perf_counter() - t) / 3
        t = time.perf_counter()
        fitting.interpolate_curve(pts.tolist(), 3)
        theirs = time.perf_counter() - t
        print(f"peer geomdl.fitting.interpolate_curve N={n}: {theirs:.3f} s vs ours {ours * 1e3:.2f} ms"
              f" (ratio {theirs / ours:.0f}x)")


def hemisphere_end_to_end(triangles: int, spacing: float = 0.5, seed: int = 1) -> None:
    """Plan -> map -> smooth -> export on the built-in hemisphere (needs the flatten and plan stages)."""
    print(f"\nend to end: hemisphere R = 30 mm, {triangles} triangles, {spacing} mm, MABF, pseudo-random")
    try:
        from polishpath.flatten import boundary_region, flatten
        from polishpath.plan import plan
        from polishpath.surfaces import load_surface
    except ImportError as exc:
        print(f"  skipped: a stage is not available yet ({exc})")
        return
    import tempfile
    from pathlib import Path

    from polishpath.export import write_gcode, write_path_csv, write_xyz
    from polishpath.mapping import map_to_surface

    surf = load_surface(f"hemisphere:R=30,triangles={triangles}")
    flat = flatten(surf, "mabf")
    path = plan(boundary_region(flat), spacing, "pseudorandom", seed=seed)
    sp = map_to_surface(flat, path, surface_spacing=spacing)
    t = time.perf_counter()
    tp = smooth(sp, surface=surf)
    t_s = time.perf_counter() - t
    st = tp.stats
    print(f"  {len(sp.xyz)} dwell points, {len(path.pieces) - 1} piece(s); smooth() {t_s:.2f} s -> {st['n_samples']}"
          f" samples at 600 mm/min x 4 ms; through-point error {st['dwell_through_max']:.1e} mm;"
          f" chord error max {st['chord_error_max'] * 1e3:.3f} um (tol 1 um)")
    print(f"  curve vs mesh between dwell points: max {st['surface_deviation_max'] * 1e3:.2f} um,"
          f" mean {st['surface_deviation_mean'] * 1e3:.2f} um; lateral overshoot max"
          f" {st['lateral_overshoot_max'] * 1e3:.1f} um; feed {st['feed_min_mm_min']:.0f}-{st['feed_max_mm_min']:.0f}"
          f" mm/min, fluctuation max {st['feed_fluctuation_max']:.1e}; dwell-time error max"
          f" {st['dwell_time_error_max']:.3f}; density cv {sp.stats['density_cv']:.3f}")
    with tempfile.TemporaryDirectory() as d:
        t = time.perf_counter()
        out = [Path(d) / n for n in ("path.csv", "toolpath.xyz", "toolpath.nc")]
        write_path_csv(tp, out[0])
        write_xyz(tp, out[1])
        write_gcode(tp, out[2], header={"surface": surf.source, "spacing": spacing, "seed": seed})
        sizes = ", ".join(f"{p.name} {p.stat().st_size / 1e6:.1f} MB" for p in out)
        print(f"  writers {time.perf_counter() - t:.2f} s: {sizes}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="1e5,1e6", help="dwell points of the disks, comma-separated")
    ap.add_argument("--max-n", type=int, default=10**6, help="largest dome serpentine (0 skips it)")
    ap.add_argument("--e2e-triangles", type=int, default=100220, help="0 skips the end-to-end run")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        smooth(disk_job(2000, Path(tmp))[1], keep_samples=False)  # numba's compile or cache load, not in the figures
        print(f"warm-up (numba compile or cache load): {time.perf_counter() - t:.2f} s")
        for size in args.sizes.split(","):
            if size.strip():
                stage(float(size), Path(tmp))
    if args.max_n:
        dome(args.max_n)
    if args.e2e_triangles:
        hemisphere_end_to_end(args.e2e_triangles)
