"""Benchmark of the text writers (issue 15, item 2): MB/s of path.csv, toolpath.xyz and G-code, against peers.

Run: ``PYTHONPATH=src python benchmarks/bench_writers.py [--rows 1e5,1e6,1e7] [--job]``

On synthetic arrays (seeded) of each row count it times, writing to a file in
a temporary folder (atomically, through the writers' own path):

* ``path.csv``: :func:`polishpath.export.write_path_csv` rows (3 integers, 9
  floats at ``%.17g``) -- through :func:`polishpath.export.textfmt.format_csv`;
* ``toolpath.xyz``: :func:`polishpath.export.write_xyz` (3 fixed-point numbers);
* G-code words: :func:`polishpath.export.textfmt.format_fixed` on ``X Y Z F``
  rows with letters, every word present (the G-code writer's formatting);

and, in the same run on the same rows, the peers: ``numpy.savetxt`` with the
same format, and Python's ``%`` over a chunk-sized format string (how these
writers formatted before; about 5x faster than savetxt). Peers run on at most
10^6 rows (their MB/s does not depend on the count). Each line prints MB/s and
the ratio to savetxt. ``--job`` adds a real job (hemisphere R = 12 mm at
0.5 mm; ``--toolpath FILE``: a pickled ToolPath): the whole G-code writer
(segmenting + formatting) in samples/s and MB/s, lines and bytes per dwell
point: the fixed period, straight blocks, helical arcs with every dwell point a
block end (``dwell_block_ends``, the layout before) and arcs that may pass
through dwell points (the default) at chord tolerances of 1, 2, 5 and 10 um
(1 % time tolerance), the default (1 % of the spacing) with the spaced words of
before (``G3 X0.3731 ... F388.702``) and compact, and with a tool radius (G93);
``--gcode-cases default`` only the default and the layout before (for 10^6
points). The share of dwell points passed through by a block is printed. The
machine is shared (load average printed).
"""

from __future__ import annotations

import argparse
import io
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

PEER_ROWS = 10**6
TARGET_MB_S = 50.0


def _time(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def _percent_rows(fmt: str, table: np.ndarray, path: Path) -> None:
    with open(path, "w") as fh:
        for a in range(0, len(table), 65536):
            part = table[a : a + 65536]
            fh.write((fmt * len(part)) % tuple(part.ravel().tolist()))


def bench_rows(n: int, work: Path) -> list[tuple[str, float, float, float, float]]:
    from polishpath.export.files import _bytes_out
    from polishpath.export.textfmt import format_csv, format_fixed

    rng = np.random.default_rng(1)
    out = []
    # path.csv rows: index, i, j, u, v, x, y, z, nx, ny, nz, dwell_time
    ints = np.column_stack([np.arange(n), rng.integers(0, 4000, (n, 2))])
    floats = np.column_stack([rng.uniform(-250, 250, (n, 5)), rng.normal(size=(n, 3)), rng.uniform(0.01, 0.1, n)])
    xyz = rng.uniform(-250, 250, (n, 3))
    xyzf = np.column_stack([xyz, rng.uniform(100, 2000, n)])
    m = min(n, PEER_ROWS)

    def csv_ours():
        with _bytes_out(work / "path.csv") as w:
            for a in range(0, n, 65536):
                w(format_csv(ints[a : a + 65536], floats[a : a + 65536]))

    def xyz_ours():
        with _bytes_out(work / "toolpath.xyz") as w:
            for a in range(0, n, 65536):
                w(format_fixed(xyz[a : a + 65536], 6))

    def gcode_ours():
        with _bytes_out(work / "toolpath.nc") as w:
            for a in range(0, n, 65536):
                w(format_fixed(xyzf[a : a + 65536], [4, 4, 4, 3], letters="XYZF"))

    csv_fmt = ",".join(["%d"] * 3 + ["%.17g"] * 9)
    table = np.column_stack([ints, floats]).astype(np.float64)
    cases = [
        ("path.csv", csv_ours, work / "path.csv", lambda: np.savetxt(work / "p.csv", table[:m], fmt=csv_fmt),
         lambda: _percent_rows(csv_fmt + "\n", table[:m], work / "q.csv")),
        ("toolpath.xyz", xyz_ours, work / "toolpath.xyz",
         lambda: np.savetxt(work / "p.xyz", np.round(xyz[:m], 6) + 0.0, fmt="%.6f"),
         lambda: _percent_rows("%.6f %.6f %.6f\n", np.round(xyz[:m], 6) + 0.0, work / "q.xyz")),
        ("G-code words", gcode_ours, work / "toolpath.nc",
         lambda: np.savetxt(work / "p.nc", xyzf[:m], fmt="X%.4f Y%.4f Z%.4f F%.3f"),
         lambda: _percent_rows("X%.4f Y%.4f Z%.4f F%.3f\n", xyzf[:m], work / "q.nc")),
    ]
    for name, ours, path, savetxt, percent in cases:
        t = _time(ours)
        mb = os.path.getsize(path) / 1e6
        ts = _time(savetxt)
        mbs = os.path.getsize(next(work.glob("p.*"))) / 1e6
        tp = _time(percent)
        mbp = os.path.getsize(next(work.glob("q.*"))) / 1e6
        for f in list(work.glob("p.*")) + list(work.glob("q.*")):
            f.unlink()
        out.append((name, mb, mb / t, mbs / ts, mbp / tp))
    return out


SPACED = {"word_separator": " ", "leading_zero": True, "trailing_zeros": True, "feed_decimals": 3}


def bench_job(pickled: str | None = None, which: str = "all") -> None:
    """The whole G-code writer on a real job: MB/s, lines and bytes per dwell point, lines against arcs."""
    from polishpath.export import write_gcode
    from polishpath.pipeline import run

    if pickled:
        import pickle

        with open(pickled, "rb") as fh:
            tp = pickle.load(fh)
        label = f"ToolPath from {pickled}"
    else:
        tp = run(surface="hemisphere:R=12,triangles=3000", spacing=0.5, seed=11, report=False).tool_path
        label = "hemisphere R=12 mm, 0.5 mm, seed 11"
    n, m = len(tp.dwell_params), len(tp.samples)
    write_gcode(tp, io.BytesIO())  # compile / load the kernels
    print(f"\njob: {label}: {n:,} dwell points, {m:,} samples; load average {os.getloadavg()[0]:.2f}")
    print("| G-code | chord tol | time tol | s | M samples/s | MB | MB/s | lines / dwell point | "
          "bytes / dwell point | arcs | dwell points passed |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    cases = []
    if which == "all":
        cases.append(("fixed period", {"segmenting": "period"}))
        for label, kw in (("lines", {"arcs": False}), ("arcs, dwell points block ends", {"dwell_block_ends": True}),
                          ("arcs through dwell points", {})):
            for tol in (0.001, 0.002, 0.005, 0.01):
                cases.append((label, {"chord_tol_mm": tol, **kw}))
    cases += [("before: spaced words, dwell points block ends", {**SPACED, "dwell_block_ends": True}),
              ("spaced words, through dwell points", SPACED),
              ("default", {})]
    if which == "all":
        cases.append(("default, G93 r = 5 mm", {"tool_radius": 5.0}))
    for label, kw in cases:
        buf = io.BytesIO()
        t0 = time.perf_counter()
        info = write_gcode(tp, buf, **kw)
        t = time.perf_counter() - t0
        mb = len(buf.getvalue()) / 1e6
        tol = "" if label == "fixed period" else f"{info['segment_chord_tol_mm'] * 1000:g} um"
        tt = "" if label == "fixed period" else f"{info['time_tol']:g}"
        share = info["arc_blocks"] / max(info["motion_blocks"], 1)
        passed = _passed_share(tp, kw) if label != "fixed period" and which == "all" else float("nan")
        print(f"| {label} | {tol} | {tt} | {t:.2f} | {m / t / 1e6:.2f} | {mb:.1f} | {mb / t:.1f} | "
              f"{info['lines_per_dwell_point']:.2f} | {info['bytes_per_dwell_point']:.1f} | {share:.0%} | "
              f"{passed:.0%} |", flush=True)


def _passed_share(tp, kw: dict) -> float:
    """Share of the dwell points that lie inside a block (not a block end)."""
    from polishpath.export import get_post

    kw = {k: v for k, v in kw.items() if k != "tool_radius"}
    inside = 0
    for P, T, U, *_ in get_post("linuxcnc", kw).segment_blocks(tp):
        d = tp.dwell_params[(tp.dwell_params > U[0]) & (tp.dwell_params < U[-1])]
        inside += int(np.count_nonzero(~np.isin(d, U)))
    return inside / max(len(tp.dwell_params), 1)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", default="1e5,1e6", help="row counts, comma-separated (e.g. 1e5,1e6,1e7)")
    ap.add_argument("--job", action="store_true", help="also the whole G-code writer on a real job")
    ap.add_argument("--gcode-cases", choices=("all", "default"), default="all",
                    help="with --job: every G-code case, or only the default and the layout before")
    ap.add_argument("--toolpath", default=None,
                    help="with --job: a pickled ToolPath (e.g. of a benchmarks/bench_job.py disk) instead of the "
                         "hemisphere job")
    args = ap.parse_args(argv)
    from polishpath.export.textfmt import HAVE_STRFROMD, format_csv, format_fixed

    format_csv(np.zeros((1, 1), np.int64), np.zeros((1, 1)))  # compile / load the kernels
    format_fixed(np.zeros((1, 1)), 4)
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores; strfromd: {HAVE_STRFROMD}; "
          f"python {sys.version.split()[0]}, numpy {np.__version__}")
    print("| file | rows | MB | MB/s | savetxt MB/s | Python % MB/s | x savetxt | x % | target 50 MB/s |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as d:
        for n in [int(float(v)) for v in args.rows.split(",")]:
            for name, mb, ours, sav, pct in bench_rows(n, Path(d)):
                ok = "met" if ours >= TARGET_MB_S else f"missed by {TARGET_MB_S / ours:.1f}x"
                print(f"| {name} | {n:.0e} | {mb:.0f} | {ours:.1f} | {sav:.1f} | {pct:.1f} | {ours / sav:.1f} | "
                      f"{ours / pct:.1f} | {ok} |", flush=True)
    if args.job:
        bench_job(args.toolpath, args.gcode_cases)
    return 0


if __name__ == "__main__":
    sys.exit(main())
