"""The paper's Table 3, measured: every pseudo-random path on the same surfaces at the same spacing.

The measuring is ``polishpath.paper.table3.measure_surface`` (the same
function the paper's reproduction, ``polishpath paper``, calls) and the Y/N
columns are its ``verdict``; this script runs it on more surfaces (the shared
``face.obj`` too) and writes every column it measures.

Patterns: ``mabf`` (the paper's pseudo-random path on the MABF flattening;
``pseudorandom`` is accepted for it), the peers ``unicursal`` (Dunn & Walker),
``maze`` (Zhang et al.), ``fractal`` (Dong et al.), ``hilbert`` (classic
space-filling reference), all planned on the MABF flattening, and
``projection`` (the pseudo-random planner on the orthogonal projection onto
the best-fit plane).

Spacing: 0.5 mm on the part. Default (``--spacing-mode plain``, the paper's
set-up): every MABF pattern plans the plain planar grid at 0.5 mm (MABF keeps
the part's area on average, so the mean spacing on the part is about 0.5 mm;
stretched triangles show as long 3D steps). ``--spacing-mode honour``: the
planar spacing is found once per surface for the pseudo-random path (largest
3D step <= sqrt(2) x 0.5 mm) and shared by every MABF pattern (on face.obj one
badly stretched spot drives it to 0.03 mm and the run takes minutes). The
projection method always plans the plain planar grid at 0.5 mm on the
projection (that is the method).

Per pattern and surface it prints: directions with >= 5 % of the steps (n/8),
share of the region's dwell points visited and of the part's area within one
spacing of a dwell point, dwell points outside the part and the area they
stand for, 3D step mean / max / CV, the largest gap (largest distance from a
vertex or face centroid more than one spacing from the boundary to its
nearest dwell point), how far the smoothed curve passes from the dwell points
(for the fractal path also its published approximating spline), crossings,
pieces, and time; the paper's n/8 and Y/N beside ours.

    PYTHONPATH=src python benchmarks/table3.py [--out docs/table3.md] [--seed 0]
        [--hemisphere hemisphere:R=30,triangles=20000] [--surfaces hemisphere,pentagram,face]
        [--smooth full|curve] [--spacing-mode plain|honour] [--meshes DIR]

``--smooth full`` (default) runs the smoothing stage (``smooth(surface_path,
surface=surface)``) and reads ``dwell_through_max``; ``--smooth curve`` builds
only the cubic NURBS through every dwell point (per piece), skipping the
constant-period sampling, which does not change that figure. ``--meshes``
(default ``$POLISHPATH_MESHES``, else ``../shared/data/meshes`` beside the
checkout) is the folder holding ``face.obj``; without it the face is skipped.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from polishpath.paper import PAPER
from polishpath.paper.table3 import ACCURACY_TOL_MM, measure_surface, verdict
from polishpath.surfaces import load_surface

REPO = Path(__file__).resolve().parents[1]

PATTERNS = ["mabf", "unicursal", "maze", "fractal", "hilbert", "projection"]
LABEL = {
    "mabf": "pseudo-random, MABF (paper)",
    "unicursal": "unicursal (Dunn-Walker)",
    "maze": "perfect maze (Zhang)",
    "fractal": "fractal-like (Dong)",
    "hilbert": "Hilbert (reference)",
    "projection": "pseudo-random, projection",
}
#: the paper's Table 3 (directional DOF, boundary, surface, uniformity, accuracy); Hilbert is not in it
PAPER_T3 = {**PAPER["table3"], "hilbert": ("-", "-", "-", "-", "-")}


def _line(r):
    if "error" in r:
        return f"{r['pattern']:<12} failed: {r['error']}"
    return (f"{r['pattern']:<12} dirs {r['directions']}/8  visited {100 * r['visited']:.1f}%  "
            f"area {100 * r['area_within_s']:.1f}%  out {r['outside_points']}  "
            f"step {r['step_mean_mm']:.3f}/{r['step_max_mm']:.3f} cv {r['step_cv']:.2f}  gap {r['inner_gap_mm']:.2f}  "
            f"through {r['through_mm']:.1e}"
            + (f" own {r['own_spline_mm']:.3f}" if r["own_spline_mm"] is not None else "")
            + f"  X {r['crossings']}  pieces {r['pieces']}  {r['seconds']:.2f}/{r['seconds_total']:.1f} s")


HEAD = ("| path | dirs ours (paper) | dwell pts visited | area within s | outside: pts / mm² | "
        "3D step mean / max mm | step CV | largest inner gap mm | through max mm | crossings | pieces | "
        "plan / total s | boundary | surface | uniform | accuracy |")


def _md_row(r, spacing):
    paper = PAPER_T3[r["pattern"]]
    if "error" in r:
        return f"| {LABEL[r['pattern']]} | failed: {r['error']} |" + " |" * 14
    through = f"{r['through_mm']:.1e}"
    if r["own_spline_mm"] is not None:
        through += f" (own spline {r['own_spline_mm']:.3f})"
    _, boundary, surface, uniform, accurate = verdict(r)
    return (f"| {LABEL[r['pattern']]} | {r['directions']}/8 ({paper[0]}) | "
            f"{100 * r['visited']:.1f} % ({r['left_out']} left) | {100 * r['area_within_s']:.1f} % | "
            f"{r['outside_points']} / {r['outside_points'] * spacing**2:.1f} | "
            f"{r['step_mean_mm']:.3f} / {r['step_max_mm']:.3f} | {r['step_cv']:.2f} | {r['inner_gap_mm']:.2f} | "
            f"{through} | {r['crossings']} | {r['pieces']} | {r['seconds']:.2f} / {r['seconds_total']:.1f} | "
            f"{boundary} ({paper[1]}) | {surface} ({paper[2]}) | {uniform} ({paper[3]}) | {accurate} ({paper[4]}) |")


def to_markdown(results, args, seconds):
    out = [
        "# Table 3, measured",
        "",
        (f"Produced by `benchmarks/table3.py` (seed {args.seed}, {args.spacing} mm on the part, "
         f"smoothing check `--smooth {args.smooth}`), {seconds:.0f} s in all on a shared 2-core machine. "
         "The measuring and the Y/N are `polishpath.paper.table3` (`measure_surface`, `verdict`), the same as in "
         "`polishpath paper` (docs/paper.md)."),
        (f"Spacing mode `{args.spacing_mode}`. Paper's value in brackets. Y/N rules (ours): boundary = distinct "
         "dwell points visited >= 95 % of the region's (`path_metrics` coverage) and no dwell point off the part; surface = every dwell point on "
         "the part once mapped back; uniform = mean 3D step <= √2 s and largest <= 2 s; accuracy = the smoothed "
         f"curve passes within {ACCURACY_TOL_MM * 1000:.0f} µm of every dwell point (fractal: its published "
         "approximating spline; all others: our NURBS through every point)."),
        "",
    ]
    for res in results:
        out += [f"## {res['surface']} (`{res['spec']}`), planar spacing {res['planar_spacing']:.4f} mm (MABF)", "",
                HEAD, "|" + "---|" * 16]
        out += [_md_row(r, args.spacing) for r in res["rows"]]
        out.append("")
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(REPO / "docs" / "table3.md"), help="markdown output file")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--spacing", type=float, default=0.5, help="dwell-point spacing on the part, mm")
    ap.add_argument("--hemisphere", default="hemisphere:R=30,triangles=20000")
    ap.add_argument("--surfaces", default="hemisphere,pentagram,face")
    ap.add_argument("--patterns", default=",".join(PATTERNS))
    ap.add_argument("--smooth", choices=["curve", "full"], default="full")
    ap.add_argument("--spacing-mode", choices=["plain", "honour"], default="plain",
                    help="plain: planar grid at the part spacing on the MABF flattening (the paper's set-up); "
                         "honour: spacing honoured on the part for the pseudo-random path, shared by all MABF patterns")
    ap.add_argument("--meshes", default=os.environ.get("POLISHPATH_MESHES") or str(REPO.parent / "shared" / "data" / "meshes"),
                    help="folder holding face.obj (default $POLISHPATH_MESHES, else ../shared/data/meshes)")
    args = ap.parse_args(argv)
    patterns = ["mabf" if p.strip() == "pseudorandom" else p.strip() for p in args.patterns.split(",") if p.strip()]
    face = Path(args.meshes) / "face.obj"
    t0 = time.perf_counter()
    specs = {"hemisphere": args.hemisphere, "pentagram": "pentagram", "face": str(face)}
    results = []
    for key in [s.strip() for s in args.surfaces.split(",") if s.strip()]:
        if key == "face" and not face.exists():
            print(f"\n== face: skipped, {face} not found (the shared meshes are absent; --meshes DIR)", flush=True)
            continue
        spec = specs.get(key, key)
        print(f"\n== {key}: {spec}", flush=True)
        res = measure_surface(load_surface(spec), args.spacing, seed=args.seed, patterns=patterns, label=key,
                              spacing_on="plane" if args.spacing_mode == "plain" else "surface",
                              accuracy="smooth" if args.smooth == "full" else "curve", errors="row")
        print(f"   MABF {res['flatten_s']:.1f} s, planar spacing {res['planar_spacing']:.4f} mm", flush=True)
        for r in res["rows"]:
            print("   " + _line(r), flush=True)
        results.append({**res, "spec": spec})
    secs = time.perf_counter() - t0
    md = to_markdown(results, args, secs)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(md)
    print(f"\nwrote {args.out} ({secs:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
