"""Flattening benchmark: MABF vs classic ABF vs libigl LSCM, measured in the same run.

Usage::

    PYTHONPATH=src .venv/bin/python benchmarks/bench_flatten.py          # < ~3 min
    PYTHONPATH=src .venv/bin/python benchmarks/bench_flatten.py --big    # + 1M triangles
    PYTHONPATH=src .venv/bin/python benchmarks/bench_flatten.py --quick  # Table 1 only

Prints one table: case, triangles, MABF time (angles + layout), ABF time, LSCM
time, ratio MABF/LSCM, mean angle error of each, flips, and the paper's MATLAB
times (Table 1) beside ours. Times are the best of ``--repeat`` runs (default 1;
the machine is shared, so figures are noisy; ratios are measured in the same run).
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from polishpath.flatten import flatten  # noqa: E402
from polishpath.types import Surface  # noqa: E402

SHARED = ROOT.parent / "shared" / "data" / "meshes"
PAPER = {  # Table 1 of the paper, MATLAB R2021a, seconds
    "hemisphere": (5.56, 351.89),
    "pentagram": (69.33, 1059.16),
    "airfoil": (158.54, 3456.26),
    "saddle": (178.70, 8432.58),
}


def load_shared(name: str, upsample: int = 0) -> Surface | None:
    p = SHARED / name
    if not p.exists():
        return None
    import trimesh

    m = trimesh.load(p, process=False)
    v, f = np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64)
    if upsample:
        import igl

        for _ in range(upsample):
            v, f = igl.upsample(v, f)
    return Surface(v, f, name=p.stem + (f"x{4**upsample}" if upsample else ""), source=str(p))


def builtin(spec: str) -> Surface:
    from polishpath.surfaces import load_surface

    return load_surface(spec)


def run(surface: Surface, method: str, repeat: int, **kw):
    best, flat = np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        flat = flatten(surface, method, check=False, **kw)
        best = min(best, time.perf_counter() - t - 0.0)
    solve = sum(v for k, v in flat.timings.items() if k in ("angles", "layout", "solve"))
    return flat, best, solve  # whole call (with checks and metrics), core (angles + layout, or igl.lscm)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--big", action="store_true", help="also the 1M-triangle case (MABF + LSCM)")
    ap.add_argument("--quick", action="store_true", help="only the paper's Table 1 cases")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--abf-max", type=int, default=25000, help="skip classic ABF above this many triangles")
    ap.add_argument("--layouts", action="store_true", help="also compare the midpoint and least-squares layouts")
    args = ap.parse_args(argv)

    cases: list[tuple[str, Surface]] = []
    for spec in ("hemisphere:R=30,triangles=1119", "pentagram", "airfoil", "saddle"):
        cases.append((spec.split(":")[0], builtin(spec)))
    if not args.quick:
        for name in ("lilium.obj", "lion.off", "camelhead.off", "face.obj"):
            s = load_shared(name)
            if s is not None:
                cases.append((s.name, s))
        cases.append(("hemisphere-100k", builtin("hemisphere:R=30,triangles=100220")))
        s = load_shared("face.obj", upsample=1)
        if s is not None:
            cases.append((s.name, s))
    if args.big:
        # the issue's 1M case: the Table 2 hemisphere at 1,000,000 triangles, and the
        # shared face upsampled x16 (827k triangles, a harder, almost closed shape)
        cases.append(("hemisphere-1M", builtin("hemisphere:R=30,triangles=1000000")))
        s = load_shared("face.obj", upsample=2)
        if s is not None:
            cases.append((s.name, s))

    # warm up numba (compile or load its cache) outside the timings
    flatten(cases[0][1], "mabf")

    hdr = (
        f"{'case':<16}{'tris':>9} | {'MABF s':>8}{'ABF s':>9}{'LSCM s':>8}{'M/L':>6} | "
        f"{'err MABF':>9}{'ABF':>7}{'LSCM':>7} (deg) | {'flips M/A/L':>11} | {'it':>3} {'w':>3} | {'GB':>4} | paper MABF / ABF s"
    )
    print(hdr)
    print("-" * len(hdr))
    for name, s in cases:
        fm, _, tm = run(s, "mabf", args.repeat)
        peak_m = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2  # after MABF, before LSCM
        if s.n_faces <= args.abf_max:
            fa, _, ta = run(s, "abf", 1)
            ea, flA, tA = fa.metrics["angle_error_mean_deg"], int(fa.metrics["flipped_faces"]), f"{ta:9.3f}"
        else:
            ea, flA, tA = float("nan"), -1, f"{'-':>9}"
        try:
            fl, _, tl = run(s, "lscm", args.repeat)
            el, flL = fl.metrics["angle_error_mean_deg"], int(fl.metrics["flipped_faces"])
        except ImportError:
            tl, el, flL = float("nan"), float("nan"), -1
        paper = PAPER.get(name)
        ptxt = f"{paper[0]:.2f} / {paper[1]:.2f}" if paper else ""
        w = "u" if fm.provenance.params.get("weights") == "uniform" else "1/b2"
        print(
            f"{name:<16}{s.n_faces:>9} | {tm:8.3f}{tA}{tl:8.3f}{tm / tl:6.2f} | "
            f"{fm.metrics['angle_error_mean_deg']:9.3f}{ea:7.3f}{el:7.3f}       | "
            f"{int(fm.metrics['flipped_faces']):>3}/{flA:>2}/{flL:>2}    | {int(fm.metrics['iterations']):>3} {w:>4}| {peak_m:4.2f} | {ptxt}",
            flush=True,
        )
        if args.layouts:
            for lay in ("midpoint", "least_squares", "midpoint_area"):
                f2 = flatten(s, "mabf", layout=lay, check=False)
                print(
                    f"    layout {lay:<14} layout {f2.timings['layout']:.3f} s  err {f2.metrics['angle_error_mean_deg']:.4f} deg"
                    f"  area {f2.metrics['area_distortion_mean']:.4f}  flips {int(f2.metrics['flipped_faces'])}"
                )
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2
    print(f"peak memory (RSS) of the whole run {peak:.2f} GB")
    print("times: MABF and ABF = angles + layout; LSCM = the igl.lscm call; M/L = MABF / LSCM in this run."
          " Mesh checks, scaling and metrics (same for all) are excluded. GB = peak RSS of the process"
          " right after that row's MABF (before its LSCM), an upper bound of MABF's own peak.")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
