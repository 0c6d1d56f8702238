"""Benchmark: simulate polishing a 20 mm x 20 mm patch at 5 um with the four paths.

Prints the time per path (target: all four under a minute on a 2-core machine)
and the Table 4 analogue beside the paper's numbers. Default tool: the paper's
sponge at 230 rpm (rotating_tool_tif: 2 mm contact radius, parabolic pressure,
600 mm/min); ``--fwhm`` switches to the old direction-independent Gaussian TIF.

    PYTHONPATH=src python benchmarks/bench_simulate.py [--dx 0.005] [--size 20] [--seed 0]
        [--rpm 230] [--radius 2] [--pressure parabolic] [--feed 600] [--fwhm F]
        [--time-model segments|points|machine] [--out DIR]
"""

from __future__ import annotations

import argparse
import time

from polishpath.simulate import compare_patterns, gaussian_tif, rotating_tool_tif


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--size", type=float, default=20.0, help="patch side, mm")
    ap.add_argument("--dx", type=float, default=0.005, help="pixel pitch, mm")
    ap.add_argument("--spacing", type=float, default=0.5, help="path spacing, mm")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--rpm", type=float, default=230.0, help="tool spin, 1/min")
    ap.add_argument("--radius", type=float, default=2.0, help="contact radius, mm")
    ap.add_argument("--pressure", default="parabolic")
    ap.add_argument("--feed", type=float, default=600.0, help="feed, mm/min")
    ap.add_argument("--fwhm", type=float, default=None, help="use a Gaussian TIF of this FWHM (mm) instead")
    ap.add_argument("--time-model", default="segments", choices=["segments", "points", "machine"])
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    if a.fwhm:
        tif = gaussian_tif(fwhm_mm=a.fwhm)
        desc = f"Gaussian TIF FWHM {a.fwhm} mm"
    else:
        tif = rotating_tool_tif(a.rpm, a.radius, a.pressure, feed_mm_min=a.feed)
        desc = f"rotating tool {a.rpm:g} rpm, contact radius {a.radius:g} mm ({a.pressure}), feed {a.feed:g} mm/min"
    t0 = time.perf_counter()
    out = compare_patterns(a.size, spacing=a.spacing, seed=a.seed, dx_mm=a.dx, out_dir=a.out,
                           tif=tif, time_model=a.time_model)
    total = time.perf_counter() - t0
    n = int(round(a.size / a.dx)) + 1
    print(f"patch {a.size:g} mm x {a.size:g} mm at {1000 * a.dx:g} um = {n} x {n} px, spacing {a.spacing} mm, "
          f"planner: polishpath.plan.plan, seed {a.seed}, {desc}, time model {a.time_model}")
    plans = out["params"]["plans"]
    for r in out["rows"]:
        rot = r.get("rotating") or {}
        print(f"  {r['name']:<13} {r['n_points']:>6} points  plan {plans[r['name']]['seconds']:6.2f} s  "
              f"simulate+PSD {r['seconds']:6.2f} s   mean depth {r['mean_depth_nm']:.0f} nm"
              + (f"   kernel terms {rot['n_terms']}, mean feed {60 * rot['mean_speed_mm_s']:.0f} mm/min" if rot else ""))
    print(f"  total (incl. initial surface, planning, PSDs): {total:.1f} s  (target < 60 s)")
    print()
    print(out["table"])


if __name__ == "__main__":
    main()
