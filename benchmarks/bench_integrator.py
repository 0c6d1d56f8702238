"""The two constant-period integrators side by side (issue 19): Taylor + chord corrector vs the paper's
Adams-Bashforth / Adams-Moulton.

Run: ``PYTHONPATH=src python benchmarks/bench_integrator.py [--quick] [--markdown]``

For the demo job (``hemisphere --spacing 0.5 --seed 1``) and the paper's cases
(built-ins ``saddle``, ``pentagram``, ``sinusoidal`` at 0.5 mm, ``bicycle-seat``
at 2 mm, seed 1) the dwell points are planned once (``polishpath.run``), then
smoothed by each integrator at the defaults (600 mm/min, 4 ms, 1 um,
area-weighted dwell times, the default schedule passes). Printed per case and integrator:

* feed fluctuation max / RMS: ``|chord / (V T) - 1|`` of every step against its
  commanded feed ``V`` (the machine moves along the chord in one period);
* the integrator's own step before any correction (``predictor_fluctuation_max``)
  and the share of Adams steps left to the safeguard (``fallback_share``);
* the chord error reached (tolerance 1 um);
* the dwell-time error max / p99 / RMS (time spent around each dwell point
  against its schedule);
* samples per second of the interpolation (all schedule passes included;
  best of ``--repeat`` runs, after a warm-up).

``--quick`` runs the demo on a coarser mesh and spacing only (for a smoke test).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from polishpath import pipeline
from polishpath.smooth import INTEGRATORS, smooth

CASES = [
    ("demo: hemisphere 0.5 mm", "hemisphere", 0.5),
    ("saddle 0.5 mm", "saddle", 0.5),
    ("pentagram 0.5 mm", "pentagram", 0.5),
    ("sinusoidal 0.5 mm", "sinusoidal", 0.5),
    ("bicycle-seat 2 mm", "bicycle-seat", 2.0),
]
QUICK = [("hemisphere:triangles=4000 1 mm", "hemisphere:triangles=4000", 1.0)]


def measure(surface_path, integrator: str, repeat: int) -> dict:
    best = None
    for _ in range(repeat):
        tp = smooth(surface_path, integrator=integrator)
        if best is None or tp.stats["interpolation_s"] < best.stats["interpolation_s"]:
            best = tp
    st = best.stats
    return {
        "n": st["n_samples"], "dwell": st["n_dwell_points"],
        "fl_max": st["feed_fluctuation_max"], "fl_rms": st["feed_fluctuation_rms"],
        "pred": st["predictor_fluctuation_max"], "fb": st["fallback_share"],
        "chord_um": st["chord_error_max"] * 1e3,
        "dt_max": st["dwell_time_error_max"], "dt_p99": st["dwell_time_error_p99"],
        "dt_rms": st["dwell_time_error_rms"],
        "msps": st["n_samples"] / st["interpolation_s"] / 1e6, "secs": st["interpolation_s"],
        "dur": st["duration_s"],
    }


def main(quick: bool, repeat: int, markdown: bool) -> None:
    cases = QUICK if quick else CASES
    rows = []
    warm = True
    for label, spec, spacing in cases:
        t = time.perf_counter()
        job = pipeline.run(surface=spec, spacing=spacing, seed=1, report=False)
        print(f"{label}: {len(job.surface_path.xyz)} dwell points planned in {time.perf_counter() - t:.1f} s",
              flush=True)
        if warm:  # numba compile or cache load of both kernels
            for name in INTEGRATORS:
                smooth(job.surface_path, integrator=name)
            warm = False
        for name in INTEGRATORS:
            r = measure(job.surface_path, name, repeat)
            rows.append((label, name, r))
            print(f"  {name:6s} {r['n']:>8d} samples  feed fluct. max {r['fl_max']:.1e} rms {r['fl_rms']:.1e}"
                  f"  predictor {r['pred']:.1e}  fallback {r['fb']:.3f}  chord {r['chord_um']:.4f} um"
                  f"  dwell-time err max {r['dt_max']:.3f} p99 {r['dt_p99']:.3f} rms {r['dt_rms']:.4f}"
                  f"  {r['msps']:.3f} M samples/s ({r['secs']:.2f} s)  job {r['dur']:.1f} s", flush=True)
    if markdown:
        print("\n| case (dwell points) | integrator | feed fluctuation max / RMS | fallback share | chord error max "
              "(um) | dwell-time error max / p99 / RMS | M samples/s |")
        print("|---|---|---|---|---|---|---|")
        for label, name, r in rows:
            print(f"| {label} ({r['dwell']:,}) | {name} | {r['fl_max']:.1e} / {r['fl_rms']:.1e} | {r['fb']:.3f} | "
                  f"{r['chord_um']:.4f} | {r['dt_max']:.3f} / {r['dt_p99']:.3f} / {r['dt_rms']:.4f} | "
                  f"{r['msps']:.3f} |")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the demo on a small mesh only")
    ap.add_argument("--repeat", type=int, default=2, help="runs per integrator (best interpolation time)")
    ap.add_argument("--markdown", action="store_true", help="also print the table as Markdown")
    args = ap.parse_args()
    main(args.quick, args.repeat, args.markdown)
