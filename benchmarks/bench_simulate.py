"""Benchmark: the fair comparison of the four paths (and the Table 3 peers) on a 20 mm x 20 mm patch at 5 um.

For each timing (ideal, machine) and mode (process, interference-free) it runs
:func:`polishpath.simulate.compare_patterns` over N seeds and prints, per path,
the fair figures of the residual (band RMS, lattice peak over the background,
PVn) and the paper-style suppression, each as mean [min, max], beside the
paper's Table 4, the rankings (ties where ranges overlap), how much the ranking
moves between ideal and machine timing, and the time each run took (target:
four paths x 5 seeds in 5 minutes on the 2-core machine). ``--markdown`` prints
the tables for docs/simulation.md.

    PYTHONPATH=src python benchmarks/bench_simulate.py [--size 20] [--dx 0.005] [--seeds 5] [--seed 0]
        [--patterns pseudorandom,raster,spiral,rectangular] [--peers] [--timings ideal,machine]
        [--modes process,interference-free] [--machine PROFILE] [--fwhm F] [--markdown] [--out DIR]
"""

from __future__ import annotations

import argparse
import time

from polishpath.simulate import PAPER_TABLE4, compare_patterns, gaussian_tif, rotating_tool_tif

FAIR = (("residual_band_rms_nm", "band RMS nm", 1.0), ("lattice_peak_db", "lattice peak dB", 1.0),
        ("pvn", "PVn", 1.0), ("suppression_ratio", "suppression %", 100.0))
PEERS = ("unicursal", "maze", "fractal", "hilbert")


def _cell(r, k, f):
    if r.get(k) is None:
        return "–"
    return f"{f * r[k]:.3g} [{f * r[k + '_min']:.3g}, {f * r[k + '_max']:.3g}]"


def markdown(out, title: str) -> str:
    lines = [f"**{title}**", "", "| path | " + " | ".join(lab for _, lab, _ in FAIR) + " | paper suppression |",
             "|---|" + "---|" * (len(FAIR) + 1)]
    for r in out["rows"]:
        p = PAPER_TABLE4.get(r["name"])
        lines.append(f"| {r['name']} | " + " | ".join(_cell(r, k, f) for k, _, f in FAIR)
                     + f" | {f'{100 * p[2]:.2f} %' if p else '–'} |")
    lines.append("")
    for k, rk in out["rankings"].items():
        lines.append(f"* ranking by {k}: {rk['text']}")
    return "\n".join(lines)


def moved(a: dict, b: dict) -> str:
    """How the ranking by each figure moves from run a to run b (positions that change)."""
    out = []
    for k in a["rankings"]:
        ra, rb = a["rankings"][k]["order"], b["rankings"][k]["order"]
        if not ra:
            continue
        ch = [f"{n} {ra.index(n) + 1}->{rb.index(n) + 1}" for n in ra if n in rb and ra.index(n) != rb.index(n)]
        ta, tb = a["rankings"][k]["text"], b["rankings"][k]["text"]
        out.append(f"  {k}: {'unchanged' if not ch and ta == tb else ', '.join(ch) or 'same order, other ties'}"
                   f"  ({ta}  ->  {tb})")
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=float, default=20.0, help="patch side, mm")
    ap.add_argument("--dx", type=float, default=0.005, help="pixel pitch, mm")
    ap.add_argument("--spacing", type=float, default=0.5, help="path spacing, mm")
    ap.add_argument("--seed", type=int, default=0, help="base seed")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--patterns", default="pseudorandom,raster,spiral,rectangular")
    ap.add_argument("--peers", action="store_true", help="add the Table 3 peers (unicursal, maze, fractal, hilbert)")
    ap.add_argument("--timings", default="ideal,machine")
    ap.add_argument("--modes", default="process,interference-free")
    ap.add_argument("--machine", default=None, help="machine profile for the machine timing")
    ap.add_argument("--fwhm", type=float, default=None, help="use a Gaussian TIF of this FWHM (mm) instead")
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    pats = [p for p in a.patterns.split(",") if p]
    if a.peers:
        from polishpath.plan.peers import register_peers

        register_peers()
        pats += list(PEERS)
    tif = gaussian_tif(fwhm_mm=a.fwhm) if a.fwhm else rotating_tool_tif()
    n = int(round(a.size / a.dx)) + 1
    print(f"patch {a.size:g} mm x {a.size:g} mm at {1000 * a.dx:g} um = {n} x {n} px, spacing {a.spacing} mm, "
          f"{a.seeds} seeds from {a.seed}, tool {tif.kind}, paths {', '.join(pats)}", flush=True)
    runs, md = {}, []
    for mode in a.modes.split(","):
        for timing in a.timings.split(","):
            t0 = time.perf_counter()
            out = compare_patterns(a.size, pats, a.spacing, a.seed, seeds=a.seeds, dx_mm=a.dx, tif=tif, mode=mode,
                                   timing=timing, machine=a.machine if timing == "machine" else None,
                                   out_dir=None if a.out is None else f"{a.out}/{mode}-{timing}")
            secs = time.perf_counter() - t0
            runs[(mode, timing)] = out
            print(f"\n== {mode}, {timing} timing: {secs:.0f} s for {len(pats)} paths x {a.seeds} seeds "
                  f"(sum of the simulations {sum(r['seconds'] for r in out['rows']):.0f} s)", flush=True)
            for r in out["rows"]:
                mt = r.get("machine_timing") or {}
                print(f"  {r['name']:<13} {r['n_points']:>6} points, {r['seconds']:6.1f} s"
                      + (f", machine time +{100 * mt['time_increase']:.1f} %" if mt else ""))
            print(out["table"], flush=True)
            md.append(markdown(out, f"{mode}, {timing} timing ({a.seeds} seeds, {secs:.0f} s)"))
        if ("ideal" in a.timings and "machine" in a.timings and (mode, "ideal") in runs
                and (mode, "machine") in runs):
            print(f"\nranking, {mode}: ideal -> machine timing", flush=True)
            print(moved(runs[(mode, "ideal")], runs[(mode, "machine")]), flush=True)
    if a.markdown:
        print("\n\n" + "\n\n".join(md))


if __name__ == "__main__":
    main()
