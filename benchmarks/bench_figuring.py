"""Dwell-time solver speed and residual: 10^4 and 10^5 dwell points against 10^6-pixel error maps.

A disc part sized so that a 0.5 mm lattice holds the wanted number of dwell
points, a 1000 x 1000 pixel Zernike error map over it (defocus, astigmatism,
coma, spherical: what a 2 mm FWHM Gaussian TIF can correct) plus 0.3 nm RMS of
random mid-spatial texture, minimum times from a 3000 mm/min maximum feed.
Prints seconds per solve (wall and CPU time of the solver alone, and wall
time with the target and the residual map: on a shared machine the CPU time is
the fairer figure), the residual RMS over the clear aperture and the published
anchors of issue 17 beside them: those are other parts, tools and machines,
quoted for scale only.

Usage: python benchmarks/bench_figuring.py [--points 10000,100000] [--lsq-max 20000] [--smoothness 0.1]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
import shapely

from polishpath.dwell import ErrorMap, build_target, gaussian_tif, minimum_times, removal_map, rms_pv, solve_dwell
from polishpath.dwell import DEFAULT_SMOOTHNESS, zernike_surface

ANCHORS = [
    ("RIFTA, IBF (Wang et al., Sci. Rep. 10:8135)", "5 x 50 mm", "3.4 -> 1.1 nm RMS, one run"),
    ("UDO (Opt. Express 29:38737)", "92.3 x 15.7 mm", "6.32 -> 0.20 nm RMS predicted"),
    ("multi-tool bonnet (Opt. Express 30:16957)", "60 x 60 mm", "45.42 -> 11.18 nm RMS in 13.3 min"),
]


def case(n_points: int, method: str, seed: int = 0, spacing: float = 0.5, map_px: int = 1000,
         smoothness: float = DEFAULT_SMOOTHNESS):
    radius = math.sqrt(n_points * spacing * spacing / math.pi)
    h = int(math.ceil(radius / spacing))
    I, J = np.mgrid[-h:h + 1, -h:h + 1]
    ij = np.column_stack([I.ravel(), J.ravel()])
    xy = ij[:, ::-1] * spacing
    keep = np.hypot(xy[:, 0], xy[:, 1]) <= radius
    ij, xy = ij[keep], xy[keep]
    pix = 2 * (radius + 3) / (map_px - 1)
    z = zernike_surface([0, 0, 0, 40.0, 12.0, -8.0, 6.0, 5.0, 15.0], radius + 3, "fringe", pix)
    rng = np.random.default_rng(seed)
    from scipy import ndimage

    tex = ndimage.gaussian_filter(rng.standard_normal(z.shape), 2.0 / pix)
    z = z + 0.3 * tex / tex.std()
    emap = ErrorMap.centred(z, pix)
    tif = gaussian_tif(20.0, fwhm_mm=2.0)
    ap = shapely.Point(0, 0).buffer(radius + 0.25 * spacing, 256)
    t0 = time.perf_counter()
    target = build_target(emap, ap, band_mm=3.0, ca_margin_mm=1.0)
    tmin = minimum_times(np.column_stack([xy, np.zeros(len(xy))]), np.array([0, len(xy)]), 3000.0)
    rmin = removal_map(target.grid, xy, tmin, tif)
    excess = float(np.max((rmin - target.removal_nm)[target.valid]))
    target = target.with_bias(max(excess, 0.0))
    t1, c1 = time.perf_counter(), time.process_time()
    sol = solve_dwell(xy, target, tif, tmin, spacing_mm=spacing, method=method, grid_ij=ij, smoothness=smoothness)
    t2, c2 = time.perf_counter(), time.process_time()
    res = target.removal_nm - removal_map(target.grid, xy, sol.times_s, tif)
    t3 = time.perf_counter()
    return {"points": len(xy), "map_pixels": int(z.size), "grid_pixels": int(np.prod(target.grid.shape)),
            "method": sol.solver, "solve_s": t2 - t1, "solve_cpu_s": c2 - c1, "total_s": t3 - t0, "initial_rms": rms_pv(target.error_nm[target.valid])[0],
            "residual_rms": rms_pv(res[target.valid])[0], "iterations": sol.stats.get("iterations"),
            "converged": sol.converged, "dwell_min": float(sol.times_s.sum()) / 60, "smoothness": smoothness,
            "message": sol.stats.get("message")}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", default="10000,100000")
    ap.add_argument("--lsq-max", type=int, default=20000, help="largest case also solved with the sparse-matrix solver")
    ap.add_argument("--smoothness", type=float, default=DEFAULT_SMOOTHNESS, help="time-smoothness weight (0: none)")
    a = ap.parse_args(argv)
    rows = []
    for n in (int(v) for v in a.points.split(",")):
        methods = ["fft"] + (["lsq"] if n <= a.lsq_max else [])
        for m in methods:
            r = case(n, m, smoothness=a.smoothness)
            rows.append(r)
            print(f"{r['points']:>7} pts  {r['map_pixels']:>8} map px  {r['method']:>3}  solve {r['solve_s']:7.1f} s  "
                  f"(CPU {r['solve_cpu_s']:6.1f} s)  total {r['total_s']:7.1f} s  {r['initial_rms']:6.2f} -> {r['residual_rms']:5.2f} nm RMS  "
                  f"iter {r['iterations']}  converged {r['converged']}  dwell {r['dwell_min']:.1f} min  "
                  f"smoothness {r['smoothness']:g}", flush=True)
    print("\nPublished anchors (other parts, tools and machines: for scale only):")
    for name, size, fig in ANCHORS:
        print(f"  {name:45s} {size:16s} {fig}")
    return rows


if __name__ == "__main__":
    main()
