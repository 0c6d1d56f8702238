"""Benchmark of the planner: points per second on a disc, a five-pointed star and an annulus.

``--sets``: the two dwell-point sets side by side in the same run (issue 26): the
grid walk and the blue-noise walk (no lattice) on one disc at 1e5, 1e6 and 1e7
points (``--set-sizes``), each case in its own process so that its peak RSS is
its own: CPU seconds (plan end to end; the set alone), points per second, pieces (tool lifts), steps (mean
and largest, in spacings; the step histogram), the share of the busiest and the
emptiest of 16 direction sectors (x 16: 1 is an even share), and, at
``--density-size`` points, the time-density peaks: the machine samples at a
constant period (4 ms, 600 mm/min) on the flat disc, binned at h/8 in a centre
window of 40 h, the rows' and columns' PSD (Hann) at 1/(2h), 1/h, sqrt(2)/h and
2/h in dB over the median of +-35 % around each; up to ``--check-size`` points the guarantees
(each point once, no crossing, inside, no step over 2 spacings within a piece, no 22.5-degree
sector over 1.5x its share), checked from the raw path. The target (issue 26): 10^6
blue-noise points planned in at most 2x the grid walk's time; 10^7 completes. The wall seconds
of the plan are printed beside its CPU seconds (the planner is single-threaded: they agree on
a quiet machine).

Figures (2026-12-02, 2-core machine shared by three engineers, CPU s; RSS peak), before the speed
commits (cd8487a) and after them (939da85), run one after the other at load 3.0-3.2: 10^5 grid
0.14 / blue-noise 0.50 (3.6x) -> 0.15 / 0.30 (2.0x); 10^6 1.89 / 6.24 s (3.3x) -> 1.51 / 3.14 s
(2.1x; 2.0x wall), 571 -> 482 MB against the grid walk's 342 MB; another run at load 3.5 gave 2.8x.
10^7 (under the big-memory lock): 73.9 s, 3.79 GB (3.7x) -> 42.9 s, 2.68 GB against the grid walk's
20.4 s (2.1x), one piece, every guarantee held. The second pass at the set (dd4b7d3 -> f996880: the
Delaunay step's two reaches, the sampler's (x, y) grid, the cell lists made once; the same bytes), 5
alternated rounds of ``--case grid / blue-noise 1000000`` at load 1.9-4.1, medians: grid walk 3.38
s, blue-noise 6.23 s (set 3.73) -> 5.34 s (set 3.16), 1.84x -> 1.58x (median of the rounds' ratios
1.88x -> 1.71x; 5 rounds before the cell-list commit at load 1.7-2.4: 1.93x -> 1.79x), RSS 476 ->
486 MB; one ``--sets`` run at load 4.3 gave 2.11x -> 2.10x at 10^6 (grid walks 2.87 / 2.50 s) and
1.64x -> 1.54x at 10^5. 15 rounds in all (three sessions): 1.88x -> 1.72x, over 2x in 3 -> 2 of them: the
ratio is under 2x in the medians, not yet in every run. docs/planning.md
("Speed") says where the time goes and what was tried.

    PYTHONPATH=src python benchmarks/bench_plan.py --sets [--set-sizes 1e5,1e6,1e7] [--density-size 1e5] [--check-size 1e6]

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
import json
import resource
import subprocess
import sys
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


def time_density_peaks(path, window_h: float = 40.0, pix: int = 8, feed: float = 600.0,
                       period_ms: float = 4.0) -> dict:
    """Peaks (dB over the local median) of the machine samples' time density at the lattice frequencies.

    The path is taken as a flat part (z = 0), smoothed at a constant period, its samples binned at
    ``h / pix`` in a centre window of ``window_h x h``; the rows' and columns' PSD (Hann window) at
    1/(2h), 1/h, sqrt(2)/h and 2/h over the median of the band within 35 % of each frequency.
    """
    from polishpath.smooth import smooth
    from polishpath.types import Provenance, SurfacePath

    n, h = path.n_points, path.spacing
    uv = np.asarray(path.uv)
    w = np.ones(n) if path.cell_area is None else path.cell_area / path.cell_area.mean()
    sp = SurfacePath(xyz=np.column_stack([uv, np.zeros(n)]), normals=np.tile([0.0, 0.0, 1.0], (n, 1)),
                     face_ids=np.zeros(n, dtype=np.int64), bary=np.tile([1.0, 0.0, 0.0], (n, 1)),
                     dwell_weight=w, planar=path, provenance=Provenance("map", "plane z = 0"))
    s = np.asarray(smooth(sp, feed_mm_min=feed, period_ms=period_ms, deviation_samples=1).samples)[:, :2]
    c, half, dx = uv.mean(axis=0), window_h * h / 2, h / pix
    nb = int(round(2 * half / dx))
    img = np.histogram2d(s[:, 0], s[:, 1], bins=nb, range=[[c[0] - half, c[0] + half], [c[1] - half, c[1] + half]])[0]
    img -= img.mean()
    win = np.hanning(nb)
    psd = (np.abs(np.fft.rfft(img * win[None, :], axis=1)) ** 2).mean(axis=0) \
        + (np.abs(np.fft.rfft(img * win[:, None], axis=0)) ** 2).mean(axis=1)
    f = np.fft.rfftfreq(nb, dx)
    out = {}
    for name, f0 in (("1/2h", 0.5 / h), ("1/h", 1 / h), ("sqrt2/h", 2**0.5 / h), ("2/h", 2 / h)):
        near = np.abs(f - f0) <= 0.03 * f0 + 1.5 / (2 * half)
        band = (np.abs(f - f0) <= 0.35 * f0) & ~near
        out[name] = float(10 * np.log10(psd[near].max() / np.median(psd[band])))
    return out


def guarantees(p, region: Region, margin: float) -> dict:
    """The walk's guarantees (issue 26), checked from the raw path: each a bool, and the figures behind them.

    Each dwell point once (the set's numbers, or the grid's indices, a permutation; none unreached); no
    crossing (the metrics' independent segment test); every point and step inside the region shrunk by the
    margin (shapely); within a piece no step over 2 spacings; no 22.5-degree direction sector over 1.5x its
    share (for the lattice-free walk; the grid walk's 8 directions hold 2.24x by construction).
    """
    import shapely

    from polishpath.plan import count_crossings
    from polishpath.plan.dwell import region_polygon

    uv, h = np.asarray(p.uv), p.spacing
    key = p.ij[:, 0] if p.dwell_points == "blue-noise" else p.ij[:, 0].astype(np.int64) * (1 << 32) + p.ij[:, 1]
    once = bool(len(p.unreached) == 0 and len(np.unique(key)) == p.n_points == p.n_inside)
    crossings = int(count_crossings(uv, p.pieces))
    poly = region_polygon(region, margin).buffer(1e-9)
    shapely.prepare(poly)
    segs = [np.stack([uv[a:b - 1], uv[a + 1:b]], axis=1) for a, b in zip(p.pieces[:-1], p.pieces[1:]) if b - a > 1]
    inside = bool(shapely.contains_xy(poly, uv[:, 0], uv[:, 1]).all()
                  and all(shapely.covers(poly, shapely.linestrings(sg)).all() for sg in segs))
    steps = np.concatenate([np.hypot(*np.diff(uv[a:b], axis=0).T) for a, b in zip(p.pieces[:-1], p.pieces[1:])])
    d = np.concatenate([np.diff(uv[a:b], axis=0) for a, b in zip(p.pieces[:-1], p.pieces[1:])])
    sectors = np.bincount(((np.arctan2(d[:, 1], d[:, 0]) + np.pi) // (np.pi / 8)).astype(int) % 16, minlength=16)
    share_max = float(sectors.max() / sectors.sum() * 16)
    return {"each_once": once, "crossings": crossings, "inside": inside, "step_max_h": float(steps.max() / h),
            "sector_max_share": share_max,
            # the sector rule is the lattice-free walk's (the grid walk steps in its 8 directions only)
            "ok": bool(once and crossings == 0 and inside and steps.max() <= 2 * h
                       and (share_max <= 1.5 or p.dwell_points == "grid"))}


def run_case(dwell_points: str, n: int, seed: int, density: bool, check: bool = False) -> dict:
    """One planning case (in its own process): figures as a dict (printed as JSON by ``--case``).

    Times are CPU seconds of this process (the planner is single-threaded, so they do not depend on the
    machine's load the way wall-clock seconds do): ``total_s`` is ``plan`` end to end, ``set_s`` a second,
    separate build of the dwell-point set alone.
    """
    from polishpath.plan import dwell_grid
    from polishpath.plan.points import blue_noise_points

    region = disc_region(float(n))
    plan(disc_region(400.0), 1.0, seed=0, dwell_points=dwell_points)  # numba compile or cache load
    t, tw = time.process_time(), time.perf_counter()
    p = plan(region, 1.0, seed=seed, dwell_points=dwell_points)
    total, wall = time.process_time() - t, time.perf_counter() - tw
    t = time.process_time()
    if dwell_points == "grid":
        dwell_grid(region, 1.0)
    else:
        blue_noise_points(region, 1.0, seed=seed)
    set_s = time.process_time() - t
    steps = np.concatenate([np.hypot(*np.diff(p.uv[a:b], axis=0).T) for a, b in zip(p.pieces[:-1], p.pieces[1:])])
    d = np.concatenate([np.diff(p.uv[a:b], axis=0) for a, b in zip(p.pieces[:-1], p.pieces[1:])])
    sectors = np.bincount(((np.arctan2(d[:, 1], d[:, 0]) + np.pi) // (np.pi / 8)).astype(int) % 16, minlength=16)
    share = sectors / sectors.sum() * 16
    out = {"set": dwell_points, "points": p.n_points, "set_s": set_s,
           "walk_s": total - set_s, "total_s": total, "wall_s": wall, "pieces": len(p.pieces) - 1,
           "extra_pieces": p.stats["extra_pieces"], "walk_fraction": p.stats["walk_fraction"],
           "step_mean": float(steps.mean()), "step_max": float(steps.max()),
           "step_hist": np.histogram(steps, bins=[0, 0.95, 1.05, 1.2, 1.35, 1.45, 1.55, 1.7, 10])[0].tolist(),
           "sector_min": float(share.min()), "sector_max": float(share.max()), "rss_mb": peak_rss_mb()}
    if density:
        out["density_db"] = time_density_peaks(p)
    if check:
        out["guarantees"] = guarantees(p, region, 0.0)
    return out


def compare_sets(sizes: list[int], seed: int, density_size: int, check_size: int) -> None:
    """The grid walk and the blue-noise walk side by side, each case in its own process."""
    print(f"{'set':10s} {'points':>9s} {'set cpu':>7s} {'rest':>7s} {'cpu s':>8s} {'wall s':>7s} {'pts/s':>9s} "
          f"{'pieces':>6s} "
          f"{'extra':>5s} {'walk%':>6s} {'step mean/max':>13s} {'sector min..max':>15s} {'RSS MB':>7s}  "
          "time density dB (1/2h, 1/h, sqrt2/h, 2/h)")
    results: dict[tuple[str, int], dict] = {}
    for n in sizes:
        for dp in ("grid", "blue-noise"):
            cmd = [sys.executable, __file__, "--case", dp, str(n), "--seed", str(seed)]
            if n == density_size:
                cmd.append("--density")
            if n <= check_size:
                cmd.append("--check")
            r = subprocess.run(cmd, capture_output=True, text=True)
            if r.returncode != 0:
                print(f"{dp:10s} {n:9d} FAILED: {r.stderr.strip().splitlines()[-1] if r.stderr else r.returncode}")
                continue
            c = json.loads(r.stdout.strip().splitlines()[-1])
            results[(dp, n)] = c
            dens = " ".join(f"{v:5.2f}" for v in c["density_db"].values()) if "density_db" in c else ""
            print(f"{dp:10s} {c['points']:9d} {c['set_s']:7.2f} {c['walk_s']:7.2f} {c['total_s']:8.2f} "
                  f"{c['wall_s']:7.2f} "
                  f"{c['points'] / c['total_s']:9.0f} {c['pieces']:6d} {c['extra_pieces']:5d} "
                  f"{100 * c['walk_fraction']:6.1f} {c['step_mean']:6.2f}/{c['step_max']:5.2f} "
                  f"{c['sector_min']:7.2f}..{c['sector_max']:5.2f} {c['rss_mb']:7.0f}  {dens}", flush=True)
    print("guarantees (each point once, crossings, inside, largest step / h, busiest sector / its share; ok):")
    for (dp, n), c in results.items():
        if "guarantees" in c:
            g = c["guarantees"]
            print(f"  {dp:10s} {c['points']:9d} once={g['each_once']} crossings={g['crossings']} inside={g['inside']} "
                  f"step_max={g['step_max_h']:.3f} sector_max={g['sector_max_share']:.3f} -> "
                  f"{'ok' if g['ok'] else 'FAILED'}")
    print("step histogram (spacings: <0.95, -1.05, -1.2, -1.35, -1.45, -1.55, -1.7, more):")
    for (dp, n), c in results.items():
        print(f"  {dp:10s} {c['points']:9d} " + " ".join(f"{x / max(sum(c['step_hist']), 1):.3f}" for x in c["step_hist"]))
    for n in sizes:
        g, b = results.get(("grid", n)), results.get(("blue-noise", n))
        if g and b:
            ratio = b["total_s"] / g["total_s"]
            verdict = "met" if ratio <= 2.0 else f"missed by {ratio / 2.0:.2f}x"
            print(f"{n:.0e} points: blue-noise / grid time {ratio:.2f} CPU (target <= 2: {verdict}), "
                  f"{b['wall_s'] / g['wall_s']:.2f} wall")
        elif n >= 10_000_000:
            print(f"{n:.0e} points: blue-noise {'completed' if b else 'did NOT complete'}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", action="store_true", help="grid walk beside the blue-noise walk (issue 26)")
    ap.add_argument("--set-sizes", type=str, default="1e5,1e6,1e7")
    ap.add_argument("--density-size", type=float, default=1e5, help="size at which the time density is measured")
    ap.add_argument("--case", nargs=2, metavar=("SET", "N"), help=argparse.SUPPRESS)
    ap.add_argument("--density", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--check", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--check-size", type=float, default=1e6,
                    help="check the guarantees (each point once, no crossing, inside, steps, sectors) up to this size")
    ap.add_argument("--big", action="store_true", help="also 1e7 dwell points")
    ap.add_argument("--metrics", action="store_true", help="also time path_metrics (crossings checked independently)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sizes", type=str, default="", help="comma separated point counts (overrides)")
    ap.add_argument("--shapes", type=str, default="disc,star,annulus")
    args = ap.parse_args()
    if args.case:
        print(json.dumps(run_case(args.case[0], int(float(args.case[1])), args.seed, args.density, args.check)))
        return
    if args.sets:
        compare_sets([int(float(x)) for x in args.set_sizes.split(",")], args.seed, int(args.density_size),
                     int(args.check_size))
        return

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
