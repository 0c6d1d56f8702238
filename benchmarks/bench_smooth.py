"""Benchmark of the smoothing stage (issue 5): NURBS interpolation, evaluation, constant-period samples.

Run: ``PYTHONPATH=src python benchmarks/bench_smooth.py [--max-n 1000000]``

Prints seconds for 10^5 and 10^6 dwell points (a boustrophedon on a 0.5 mm grid
lifted onto a dome; its U-turns are where the feed is cut), the sample count and chord
error reached, and the ratio against geomdl's dense O(N^3) interpolation
(``geomdl.fitting.interpolate_curve``) measured in the same run on small N.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from polishpath.smooth import evaluate, interpolate_constant_period, interpolate_nurbs, smooth
from polishpath.types import PlanarPath, Provenance, SurfacePath


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


def surface_path_of(pts: np.ndarray) -> SurfacePath:
    n = len(pts)
    nrm = pts - np.array([0, 0, 0.0])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    planar = PlanarPath(pts[:, :2], np.zeros((n, 2), np.int64), 0.5, provenance=Provenance("plan", "bench", seed=0))
    return SurfacePath(pts, nrm, np.zeros(n, np.int64), np.tile([1.0, 0, 0], (n, 1)), np.ones(n), planar)


def main(max_n: int) -> None:
    # warm-up: numba compile / cache load
    t = time.perf_counter()
    c, _ = interpolate_nurbs(dome_path(50))
    interpolate_constant_period(c, 600.0, 4.0, 1e-3)
    print(f"warm-up (numba compile or cache load): {time.perf_counter() - t:.2f} s")
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
        print(f"{n:>8d} points: interpolate_nurbs {t_fit:.2f} s, evaluate at the N dwell params {t_eval:.2f} s"
              f" (through-point error {err:.1e} mm), constant-period 3000 mm/min x 4 ms {t_ip:.2f} s ->"
              f" {st['n_samples']} samples, chord error max {st['chord_error_max'] * 1e3:.3f} um,"
              f" feed fluctuation max {st['feed_fluctuation_max']:.1e} (Taylor predictor alone"
              f" {st['predictor_fluctuation_max']:.1e})")
        t = time.perf_counter()
        tp = smooth(surface_path_of(pts), feed_mm_min=3000.0, period_ms=4.0)
        print(f"{'':>8s}         smooth() stage (fit + area-weighted dwell schedule + samples + overshoot):"
              f" {time.perf_counter() - t:.2f} s, {len(tp.samples)} samples,"
              f" lateral overshoot max {tp.stats['lateral_overshoot_max']:.4f} mm,"
              f" dwell-time error max {tp.stats['dwell_time_error_max']:.3f}")
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
    ap.add_argument("--max-n", type=int, default=10**6)
    ap.add_argument("--e2e-triangles", type=int, default=100220, help="0 skips the end-to-end run")
    args = ap.parse_args()
    main(args.max_n)
    if args.e2e_triangles:
        hemisphere_end_to_end(args.e2e_triangles)
