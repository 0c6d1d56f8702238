"""Sensitivity of the simulated path ranking: which mechanism decides it, and the tool, timing, noise, spacing.

``--study mechanisms`` (default): the fair comparison with every mechanism on,
then with each one switched off on its own (:class:`polishpath.simulate.Mechanisms`:
footprint, edge, smoothing, noise, slowdown), and in interference-free mode,
over N seeds; prints a Markdown table per figure (residual band RMS, lattice
peak, PVn, paper-style suppression; mean per path) and the rankings, for
docs/simulation.md ("Which mechanism decides the ranking").

``--study tool``: the older sensitivity cases (tool size, pressure, feed, time
model, noise, spacing, the Gaussian tool), one seed each, now with the band RMS
ranking beside the suppression ratio. Plans are computed once per (spacing,
seed) and reused.

    PYTHONPATH=src python benchmarks/sensitivity_simulate.py [--study mechanisms|tool] [--size 10] [--dx 0.005]
        [--seeds 3] [--only N,M]
"""

from __future__ import annotations

import argparse
import functools
import time

from polishpath.simulate import ProcessNoise, compare_patterns, gaussian_tif, rotating_tool_tif

PATTERNS = ("pseudorandom", "raster", "spiral", "rectangular")


def configs():
    base = {"tif": {}, "gauss": None, "noise": "default", "spacing": 0.5, "seed": 0, "time_model": "segments"}
    yield "baseline: 230 rpm, R 2 mm parabolic, 600 mm/min, noise 5 %/1 s, segments", base
    yield "no process noise", {**base, "noise": None}
    yield "contact radius 1 mm", {**base, "tif": {"contact_radius_mm": 1.0}}
    yield "contact radius 4 mm", {**base, "tif": {"contact_radius_mm": 4.0}}
    yield "Hertz pressure (sharp edge)", {**base, "tif": {"pressure": "hertz"}}
    yield "feed 1800 mm/min (feed/rim speed 0.62)", {**base, "tif": {"feed_mm_min": 1800.0}}
    yield "feed 200 mm/min (feed/rim speed 0.07)", {**base, "tif": {"feed_mm_min": 200.0}}
    yield "time model: machine (NURBS, 4 ms period)", {**base, "time_model": "machine"}
    yield "stop-and-dwell (points: zero feed)", {**base, "time_model": "points"}
    yield "noise 15 %, 1 s", {**base, "noise": ProcessNoise(0.15, correlation_time_s=1.0)}
    yield "noise 5 %, 2 mm of path", {**base, "noise": ProcessNoise(0.05, 2.0)}
    yield "spacing 0.3 mm", {**base, "spacing": 0.3}
    yield "old model: Gaussian FWHM 1 mm, no spin", {**base, "gauss": 1.0}
    yield "seed 1", {**base, "seed": 1}
    yield "seed 2", {**base, "seed": 2}


def _memoize_planner():
    import polishpath.plan as P

    orig = P.plan
    cache = {}

    @functools.wraps(orig)
    def plan(region, spacing, pattern, seed=0, **kw):
        key = (tuple(map(float, region.bounds)), float(spacing), pattern, seed, tuple(sorted(kw.items())))
        if key not in cache:
            cache[key] = orig(region, spacing, pattern, seed=seed, **kw)
        return cache[key]

    P.plan = plan


MECH_CASES = (("all mechanisms on (process mode, machine timing)", (), "process"),
              ("footprint off (zero-feed footprint)", ("footprint",), "process"),
              ("edge off (smooth Gaussian pressure)", ("edge",), "process"),
              ("smoothing off", ("smoothing",), "process"),
              ("noise off (no process drift)", ("noise",), "process"),
              ("slowdown off (ideal timing)", ("slowdown",), "process"),
              ("interference-free (flat start, no noise)", (), "interference-free"))
FIGS = (("residual_band_rms_nm", "residual band RMS (nm)", 1.0), ("lattice_peak_db", "lattice peak (dB)", 1.0),
        ("pvn", "PVn", 1.0), ("suppression_ratio", "paper-style suppression (%)", 100.0))


def mechanisms_study(a, only) -> None:
    from polishpath.simulate import Mechanisms

    results = []
    t0 = time.perf_counter()
    for i, (name, off, mode) in enumerate(MECH_CASES):
        if only is not None and i not in only:
            continue
        tc = time.perf_counter()
        out = compare_patterns(a.size, PATTERNS, 0.5, 0, seeds=a.seeds, dx_mm=a.dx, mode=mode,
                               mechanisms=Mechanisms().without(off))
        results.append((name, out))
        print(f"{name}: {time.perf_counter() - tc:.0f} s; " + "; ".join(
            f"{k}: {rk['text']}" for k, rk in out["rankings"].items()), flush=True)
    print(f"\npatch {a.size:g} mm at {1000 * a.dx:g} um, {a.seeds} seeds, {time.perf_counter() - t0:.0f} s\n")
    for key, label, f in FIGS:
        print(f"**{label}** (mean over the seeds; ranking best first, [a ~ b]: ranges overlap)\n")
        print("| case | " + " | ".join(PATTERNS) + " | ranking |")
        print("|---|" + "---|" * (len(PATTERNS) + 1))
        for name, out in results:
            rows = {r["name"]: r for r in out["rows"]}
            cells = " | ".join("–" if rows[p].get(key) is None else f"{f * rows[p][key]:.3g}" for p in PATTERNS)
            print(f"| {name} | {cells} | {out['rankings'][key]['text']} |")
        print()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--study", default="mechanisms", choices=["mechanisms", "tool"])
    ap.add_argument("--size", type=float, default=10.0)
    ap.add_argument("--dx", type=float, default=0.005)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--only", default=None, help="comma-separated case numbers (0-based)")
    a = ap.parse_args(argv)
    _memoize_planner()
    only = None if a.only is None else {int(v) for v in a.only.split(",")}
    if a.study == "mechanisms":
        mechanisms_study(a, only)
        return
    head = "| case | " + " | ".join(PATTERNS) + " | ranking by suppression | ranking by band RMS |"
    print(f"patch {a.size:g} mm at {1000 * a.dx:g} um; suppression ratio 1 - after/before of the band-average "
          f"profile PSD in 1-100 1/mm", flush=True)
    lines = [head, "|" + "---|" * (len(PATTERNS) + 3)]
    t0 = time.perf_counter()
    for i, (name, c) in enumerate(configs()):
        if only is not None and i not in only:
            continue
        tif = gaussian_tif(fwhm_mm=c["gauss"]) if c["gauss"] else rotating_tool_tif(**c["tif"])
        kw = {} if c["noise"] == "default" else {"noise": c["noise"]}
        out = compare_patterns(a.size, PATTERNS, c["spacing"], c["seed"], seeds=1, dx_mm=a.dx, tif=tif,
                               time_model=c["time_model"], **kw)
        sr = {r["name"]: r["suppression_ratio"] for r in out["rows"]}
        rank = " > ".join(sorted(sr, key=lambda k: -sr[k]))
        lines.append(f"| {name} | " + " | ".join(f"{100 * sr[p]:.1f} %" for p in PATTERNS)
                     + f" | {rank} | {out['rankings']['residual_band_rms_nm']['text']} |")
        print(lines[-1], flush=True)
    print()
    print(f"planner: polishpath.plan.plan; {time.perf_counter() - t0:.0f} s")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
