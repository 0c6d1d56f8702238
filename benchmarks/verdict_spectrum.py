"""Where each path's residual band RMS comes from, and what moving each dwell point's time centroid gains.

Issue 26 Build 4's second condition (a lattice-free walk's band RMS no worse
than the best other path's) is not met; this script gives the measured account
(docs/simulation.md, "Where the walks' band RMS comes from"). On a flat square
(interference-free: a flat start, no noise; machine timing, the comparison's
tool, dwell time and depth), for the grid walk, the relaxed walk and the raster,
spiral and rectangular paths, per seed:

* the residual's band power split over rings of spatial frequency
  (:func:`polishpath.simulate.fair.band_powers_nm2`), with the rotating
  footprint as modelled (``on``) and at zero feed (``zero-feed``:
  ``Mechanisms().without(["footprint"])``), so the footprint's lean is
  separated from the time density;
* the machine samples' time density over its mean, split over the same rings
  (dimensionless power): what the tool filters;
* the time density's first-order model (finer rings, ``MODEL_EDGES``): the
  dwell points at equal times, the machine's time per region placed at its
  time centroid, and the machine's samples themselves;
* ``--centre``: the same paths with each dwell point moved so that the time
  the machine spends around it (its dwell region, from the middle of the curve
  before it to the middle after it, :func:`polishpath.smooth.interpolate.dwell_regions`)
  has its centroid on the planned point: ``q <- q - (centroid(q) - p)``, three
  times. A treatment of every path alike (a path that turns at every point has
  its time centroid about h/8 inside each turn; a straight pass has it on the
  point), measured here, not a planner option;
* ``--fit``: the same paths after :func:`polishpath.simulate.densityfit.fit_time_density`
  (centring, then the machine time density flattened as the tool passes it
  into 0.95-2 1/mm, within 0.3 h of the planned points): what
  ``compare_planned(..., treatment="density-fit")`` gives every path.

    PYTHONPATH=src python benchmarks/verdict_spectrum.py [--size 22] [--patch 16] [--dx 0.01]
        [--seeds 0,1] [--centre] [--fit] [--json OUT]

Prints one line per (path, seed, variant): band RMS (nm), lattice peak (dB),
the ring powers (nm^2) and the time density's ring powers, and the CPU time.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from polishpath.plan import plan
from polishpath.simulate.compare import _crop, _dwell_s_per_point, compare_paths
from polishpath.simulate.fair import band_powers_nm2, detrend_residual
from polishpath.simulate.jobpath import timed_path
from polishpath.simulate.mechanisms import Mechanisms, tool_with
from polishpath.simulate.patterns import patch_bounds_at_centre, square_region
from polishpath.simulate.removal import rasterize_time
from polishpath.simulate.rotating import default_tif
from polishpath.simulate.workpiece import flat_workpiece
from polishpath.types import PlanarPath, Provenance, SurfacePath

H = 0.5
#: ring edges, 1/mm: below the band (0.2-1), then the band's low end where the tool passes most
EDGES = (0.2, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0, 10.0, 100.0)
#: finer rings for the time density's first-order model, 1/mm
MODEL_EDGES = (0.5, 1.0, 1.25, 1.5, 2.0, 2.5)
PATHS = {"grid walk": ("pseudorandom", "grid"), "relaxed walk": ("pseudorandom", "relaxed"),
         "raster": ("raster", "grid"), "spiral": ("spiral", "grid"), "rectangular": ("rectangular", "grid")}


def machine_samples(xy: np.ndarray, dwell_s: np.ndarray, pieces):
    """The job's smoothing stage on planar points (as :func:`~polishpath.simulate.machinetime.machine_timed_path`,
    default settings, no machine profile): the ToolPath (for its dwell parameters) and its timed samples."""
    from polishpath.defaults import DEFAULT_CHORD_TOL_MM, DEFAULT_PERIOD_MS, MAX_FEED_FACTOR
    from polishpath.smooth import smooth

    n = len(xy)
    planar = PlanarPath(uv=xy, ij=np.zeros((n, 2), dtype=np.int64), spacing=H, pattern="given",
                        pieces=np.asarray(pieces), provenance=Provenance("plan", "given"))
    sp = SurfacePath(xyz=np.column_stack([xy, np.zeros(n)]), normals=np.tile([0.0, 0.0, 1.0], (n, 1)),
                     face_ids=np.zeros(n, dtype=np.int64), bary=np.tile([1.0, 0.0, 0.0], (n, 1)),
                     dwell_weight=np.ones(n), planar=planar, provenance=Provenance("map", "plane z = 0"))
    p = np.asarray(pieces)
    length = sum(float(np.hypot(*np.diff(xy[a:b], axis=0).T).sum()) for a, b in zip(p[:-1], p[1:]))
    mean_feed = 60.0 * length / float(dwell_s.sum())
    tp = smooth(sp, feed_mm_min=mean_feed, period_ms=DEFAULT_PERIOD_MS, chord_tol_mm=DEFAULT_CHORD_TOL_MM,
                dwell_times=dwell_s, max_feed_mm_min=MAX_FEED_FACTOR * mean_feed, deviation_samples=1)
    return tp, timed_path(tp, timing="machine", plane="xy")


def time_centroids(tp, timed, n: int, with_times: bool = False):
    """(n, 2) mm: the centroid of the machine time spent in each dwell point's region (moves by their middle);
    with ``with_times`` also the (n,) time spent there, s."""
    s, ts = timed.xy, timed.time_s[:-1]
    mid = 0.5 * (s[:-1] + s[1:])
    par = 0.5 * (tp.sample_params[:-1] + tp.sample_params[1:])
    dp = np.asarray(tp.dwell_params)
    owner = np.searchsorted(0.5 * (dp[:-1] + dp[1:]), par)
    tot = np.bincount(owner, ts, n)
    c = np.stack([np.bincount(owner, ts * mid[:, i], n) for i in (0, 1)], 1) / np.maximum(tot, 1e-30)[:, None]
    return (c, tot) if with_times else c


def centred(xy: np.ndarray, dwell_s: np.ndarray, pieces, iterations: int = 3) -> np.ndarray:
    """The dwell points moved so that each one's machine time centroid lies on it (fixed-point iterations)."""
    q = xy.copy()
    for _ in range(iterations):
        tp, timed = machine_samples(q, dwell_s, pieces)
        q = q - (time_centroids(tp, timed, len(xy)) - xy)
    return q


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=float, default=22.0, help="square side, mm")
    ap.add_argument("--patch", type=float, default=16.0, help="simulated patch side, mm")
    ap.add_argument("--dx", type=float, default=0.01, help="pixel, mm")
    ap.add_argument("--seeds", default="0", help="comma-separated seeds")
    ap.add_argument("--centre", action="store_true", help="also each path with its time centroids centred")
    ap.add_argument("--fit", action="store_true", help="also each path after the density fit")
    ap.add_argument("--only", default=None, help="comma-separated path names (default all)")
    ap.add_argument("--json", default=None, help="write the figures here")
    a = ap.parse_args(argv)
    region = square_region(a.size)
    pb = patch_bounds_at_centre(region, a.patch)
    t_point, tif, _ = _dwell_s_per_point(default_tif(), H, 200.0)
    tools = {"on": tif, "zero-feed": tool_with(tif, Mechanisms().without(["footprint"]), a.dx)}
    wp = flat_workpiece(pb, a.dx)
    inset = tif.radius_mm + H
    ev = (pb[0] + inset, pb[1] + inset, pb[2] - inset, pb[3] - inset)
    names = a.only.split(",") if a.only else list(PATHS)
    print(f"flat {a.size:g} mm square, {a.patch:g} mm patch at {a.dx * 1000:g} um, evaluation window "
          f"{ev[2] - ev[0]:.1f} mm, interference-free, machine timing; rings (1/mm): {EDGES}")
    out = []
    for seed in map(int, a.seeds.split(",")):
        for name in names:
            pat, dset = PATHS[name]
            p = plan(region, H, pat, seed=seed, dwell_points=dset)
            xy, t = np.asarray(p.uv, dtype=np.float64), np.full(p.n_points, t_point)
            variants = {"as planned": xy}
            if a.centre:
                variants["centred"] = centred(xy, t, p.pieces)
            if a.fit:
                from polishpath.simulate.densityfit import fit_time_density

                variants["fitted"] = fit_time_density(xy, t, p.pieces, tif, spacing_mm=H).xy
            for vname, q in variants.items():
                c0 = time.process_time()
                tp, timed = machine_samples(q, t, p.pieces)
                spec = (timed.xy, timed.time_s, timed.pieces, "moves")
                row = {"path": name, "seed": seed, "variant": vname,
                       "shift_rms_mm": float(np.sqrt(np.mean(np.sum((q - xy) ** 2, axis=1))))}
                for tname, tool in tools.items():
                    o = compare_paths({name: spec}, wp, tool, noise=None, smoothing=None, seed=seed, spacing_mm=H,
                                      eval_bounds=ev, keep_results=True, depth_nm=200.0,
                                      path_lattices={name: dset == "grid"})
                    res, r0 = o["results"][name], o["rows"][0]
                    z = detrend_residual(_crop(res.after_nm, res.origin_mm, a.dx, ev).astype(np.float64), a.dx)
                    row[tname] = {"band_rms_nm": r0["residual_band_rms_nm"], "lattice_peak_db": r0["lattice_peak_db"],
                                  "rings_nm2": band_powers_nm2(z, a.dx, EDGES).tolist()}
                    if tname == "zero-feed":
                        rho = _crop(rasterize_time(timed.xy, timed.time_s, res.after_nm.shape, res.origin_mm,
                                                   a.dx)[0], res.origin_mm, a.dx, ev)
                        row["time_density_rings"] = band_powers_nm2(rho / rho.mean(), a.dx, EDGES).tolist()
                        row["time_density_peak_db"] = r0["time_density_peak_db"]
                        # first-order model: each region's time at its time centroid, beside the points and samples
                        c, tot = time_centroids(tp, timed, len(q), with_times=True)
                        model = {}
                        for mname, (mxy, mt) in {"points, equal times": (xy, t), "times at time centroids": (c, tot),
                                                 "machine samples": (timed.xy, timed.time_s)}.items():
                            d = _crop(rasterize_time(mxy, mt, res.after_nm.shape, res.origin_mm, a.dx)[0],
                                      res.origin_mm, a.dx, ev)
                            model[mname] = band_powers_nm2(d / d.mean(), a.dx, MODEL_EDGES).tolist()
                        row["time_density_model"] = model
                    del res, o
                row["cpu_s"] = time.process_time() - c0
                out.append(row)
                ring = lambda v: " ".join(f"{x:.3f}" for x in v)  # noqa: E731
                print(f"{name:13s} seed {seed} {vname:10s} shift {row['shift_rms_mm']:.3f} mm | on: "
                      f"{row['on']['band_rms_nm']:.3f} nm, {row['on']['lattice_peak_db']:.2f} dB, rings "
                      f"{ring(row['on']['rings_nm2'][2:7])} | zero-feed: {row['zero-feed']['band_rms_nm']:.3f} nm, "
                      f"rings {ring(row['zero-feed']['rings_nm2'][2:7])} | time density rings "
                      f"{ring(row['time_density_rings'][1:7])} | {row['cpu_s']:.1f} s CPU", flush=True)
                for mname, v in row["time_density_model"].items():
                    print(f"{'':13s} time density {MODEL_EDGES}: {mname:24s} {ring(v)}", flush=True)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump({"edges_per_mm": EDGES, "model_edges_per_mm": MODEL_EDGES, "rows": out}, fh, indent=1)


if __name__ == "__main__":
    main()
