"""Benchmark of the whole job (issues 15, 29): ``polishpath plan`` on flat disks of 10^5 and 10^6 dwell points.

Run: ``PYTHONPATH=src python benchmarks/bench_job.py [--sizes 1e5,1e6] [--huge] [--no-report] [--keep DIR]``

For each size the benchmark writes a flat disk mesh (OBJ, about 20,000
triangles, its radius chosen so that a 0.5 mm grid holds the wanted number of
dwell points), then runs ``polishpath plan disk.obj --spacing 0.5 --seed 7``
in a child process, as a user would, and prints:

* the seconds of every stage (``summary.json`` ``timings_s``, the job's own
  clock) and the child's wall time, from start to exit;
* machine samples per second (the samples over the smoothing stage's time,
  and over the interpolation kernels' own time);
* each file written: size, seconds in its writer, MB/s, lines and bytes per
  dwell point (the writer's time is measured around
  :func:`polishpath.fileio.atomic_open`, through which every output goes:
  the child wraps it before the stages load);
* the child's peak RSS (``os.wait4``'s resource usage of that child alone), and the peak while
  each stage and each file's writing ran (the child samples its RSS every 50 ms);
* issue 29's targets (item 2), met or missed and by how much, beside the figures measured before
  (:data:`BEFORE`): the whole job in CPU seconds (the job runs on one core, so on a quiet machine its
  wall time is about its CPU time plus the files' writing to disk; a loaded machine inflates the wall
  time 3-10x and the CPU time much less), the wall time at the load of the moment, and the peak RSS;
  and issue 15's rates (samples/s, writers' MB/s) for reference.

``--huge`` adds 10^7 dwell points (minutes, and many GB of memory and disk).
The machine is shared: the load average is printed with each run, so
figures from a loaded machine are read as such. A warm-up job on a tiny disk
runs first so that numba's compile (or cache load) is not in the figures.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.spatial import Delaunay

SPACING_MM = 0.5
SEED = 7

# issue 29's targets (item 2): the 10^6 job whole in 30 s at 2 GB, 10^7 in 2.5 min at 4 GB, 60 B of G-code per point
TARGET_1E6_S = 30.0
TARGET_1E6_RSS_GB = 2.0
TARGET_1E7_S = 150.0
TARGET_1E7_RSS_GB = 4.0
TARGET_GCODE_BYTES_PER_POINT = 60.0
# issue 15's rates, kept for reference
TARGET_SAMPLES_PER_S = 2e6
TARGET_WRITER_MB_S = 50.0
#: the figures before issue 29's work (main at 53a14a2, this script, load average 10 on 2 cores; 10^7: the
#: issue's own measurement): CPU s of the job's process, wall s at that load, peak RSS GB, G-code B per point
BEFORE = {1e6: {"cpu": 28.5, "wall": 90.9, "load": 10.0, "rss_gb": 1.50, "gcode_b": 80.6},
          1e7: {"cpu": None, "wall": 292.0, "load": None, "rss_gb": 5.9, "gcode_b": 79.5}}

# Runs inside the child: time every atomic write (the outputs all go through
# polishpath.fileio.atomic_open), then run the command line as a user would.
# The stages import atomic_open when they load, after the wrapper is in place.
_CHILD = r"""
import contextlib, json, os, sys, time
import polishpath.fileio as fileio

_records = []
_stage = ["outside the stages"]
_inner = fileio.atomic_open
_t00 = time.perf_counter()

@contextlib.contextmanager
def _timed(path, mode="w"):
    t0 = time.perf_counter()
    prev = _stage[0]
    _stage[0] = f"{prev}: {os.path.basename(str(path))}"  # the peak RSS of each file's writing, too
    try:
        with _inner(path, mode) as fh:
            yield fh
    finally:
        _stage[0] = prev
    t1 = time.perf_counter()
    _records.append({"file": os.path.abspath(str(path)), "start": t0 - _t00, "end": t1 - _t00})

fileio.atomic_open = _timed

# peak RSS while each stage runs (progress.stage labels the stages even when progress is not shown)
import threading
import polishpath.progress as progress
_peaks = {}
_cpu = {}
_stage_cm = progress.stage

@contextlib.contextmanager
def _labelled(label, timings=None, key=None):
    prev, _stage[0] = _stage[0], key or label
    c0 = time.process_time()
    try:
        with _stage_cm(label, timings, key):
            yield
    finally:
        _stage[0] = prev
        _cpu[key or label] = _cpu.get(key or label, 0.0) + time.process_time() - c0

progress.stage = _labelled

def _poll():
    while True:
        with open("/proc/self/status") as fh:
            kb = next((int(l.split()[1]) for l in fh if l.startswith("VmRSS")), 0)
        _peaks[_stage[0]] = max(_peaks.get(_stage[0], 0), kb * 1024)
        time.sleep(0.05)

threading.Thread(target=_poll, daemon=True).start()
record_path, args = sys.argv[1], sys.argv[2:]
sys.argv = ["polishpath"] + args
from polishpath.cli import main
try:
    main()
finally:
    with open(record_path, "w") as fh:
        json.dump({"writers": _records, "rss_peaks": _peaks, "cpu_s": _cpu,
                   "cpu_total_s": time.process_time()}, fh)
"""


def disk_obj(path: Path, radius: float, triangles: int = 20000) -> None:
    """Write a flat disk of ``radius`` mm in the plane z = 0 as an OBJ, about ``triangles`` triangles.

    Concentric rings of points (about equal spacing), Delaunay-triangulated.
    """
    h = radius * math.sqrt(math.pi / (triangles / 2.0))  # vertex spacing: ~2 triangles per vertex
    pts = [np.zeros((1, 2))]
    for k in range(1, int(math.ceil(radius / h)) + 1):
        r = min(k * h, radius)
        m = max(6, int(round(2 * math.pi * r / h)))
        t = np.arange(m) * 2 * math.pi / m + 0.5 * k
        pts.append(np.column_stack([r * np.cos(t), r * np.sin(t)]))
    xy = np.concatenate(pts)
    tri = Delaunay(xy).simplices
    # counter-clockwise triangles (normal +z)
    a, b, c = xy[tri[:, 0]], xy[tri[:, 1]], xy[tri[:, 2]]
    cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
    tri[cw] = tri[cw][:, [0, 2, 1]]
    with open(path, "w") as fh:
        fh.write("".join(f"v {x:.6f} {y:.6f} 0\n" for x, y in xy))
        fh.write("".join(f"f {i + 1} {j + 1} {k + 1}\n" for i, j, k in tri))


def count_lines(path: Path) -> int:
    n = 0
    with open(path, "rb") as fh:
        while True:
            block = fh.read(1 << 24)
            if not block:
                return n
            n += block.count(b"\n")


def run_job(n_points: float, work: Path, extra: list[str]) -> dict:
    """Run ``polishpath plan`` on a disk of about ``n_points`` dwell points in a child; its figures."""
    radius = math.sqrt(n_points * SPACING_MM**2 / math.pi)
    mesh = work / f"disk-{n_points:.0e}.obj"
    disk_obj(mesh, radius)
    out = work / f"out-{n_points:.0e}"
    rec = work / f"writers-{n_points:.0e}.json"
    args = ["plan", str(mesh), "--spacing", str(SPACING_MM), "--seed", str(SEED), "-o", str(out), "--quiet",
            "--max-points", str(int(4 * n_points) + 1000), *extra]
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-c", _CHILD, str(rec), *args], stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"polishpath plan exited {proc.returncode} for {n_points:.0e} points")
    summary = json.loads((out / "summary.json").read_text())
    record = json.loads(rec.read_text())
    writers = record["writers"]
    for w in writers:  # the job writes into a staging folder beside out (fileio.staged_folder), renamed at the end
        rel = Path(w["file"]).relative_to(os.path.abspath(work))
        if rel.parts[0].startswith(f".{out.name}.staging"):
            w["file"] = str(out / Path(*rel.parts[1:]))
    return {"n_target": n_points, "radius": radius, "wall": wall, "load": load, "out": out, "summary": summary,
            "writers": writers, "rss_gb": usage.ru_maxrss * 1024 / 1e9, "cpu": usage.ru_utime + usage.ru_stime,
            "rss_peaks": {k: v / 1e9 for k, v in record.get("rss_peaks", {}).items()},
            "stage_cpu": record.get("cpu_s", {})}


def show(r: dict) -> list[str]:
    """Print one run's figures; return the targets it missed (empty if met)."""
    s = r["summary"]
    n = int(s["plan"]["dwell_points"])
    samples = int(s["smooth"]["samples"])
    tim = s["timings_s"]
    print(f"\n== {n:,} dwell points (disk radius {r['radius']:.0f} mm, spacing {SPACING_MM} mm, "
          f"load average {r['load']:.1f} on {os.cpu_count()} cores) ==")
    print(f"  whole job {r['wall']:.1f} s (child wall time, Python start-up and imports included), "
          f"{r['cpu']:.1f} s of CPU (what a loaded machine does not inflate as much); peak RSS {r['rss_gb']:.2f} GB")
    print("  stages (wall): " + ", ".join(f"{k} {v:.2f} s" for k, v in tim.items()))
    cpu = r.get("stage_cpu") or {}
    if cpu:
        rest = r["cpu"] - sum(cpu.values())
        print("  stages (CPU of the job's process): " + ", ".join(f"{k} {v:.2f} s" for k, v in cpu.items())
              + f"; outside the stages (start-up, imports, the CLI) {rest:.2f} s")
    peaks = r.get("rss_peaks") or {}
    if peaks:
        print("  peak RSS by stage (sampled every 50 ms): " + ", ".join(f"{k} {v:.2f} GB" for k, v in peaks.items()))
    top = max(peaks.items(), key=lambda kv: kv[1]) if peaks else ("?", 0.0)
    sm = tim.get("smooth", float("nan"))
    ip = float(s["smooth"]["stats"].get("interpolation_s", float("nan")))
    passes = s["smooth"]["stats"].get("schedule_passes", 1)
    rerun = s["smooth"]["stats"].get("schedule_rerun_samples")
    # samples the kernels made: the Taylor kernel runs the path once plus the regions it runs again
    made = samples + rerun if (rerun or passes == 1) and rerun is not None else samples * passes
    print(f"  machine samples {s['smooth'].get('samples_mode', 'memory')}: {s['smooth'].get('samples_mode_reason')}")
    print(f"  machine samples: {samples:,} ({samples / n:.1f} per dwell point), {samples / sm / 1e6:.2f} M/s "
          f"over the smoothing stage, {samples / ip / 1e6:.2f} M/s over the interpolation kernels "
          f"({made / samples:.2f} samples made per sample kept: {made / ip / 1e6:.2f} M samples made per s)")
    print(f"  {'file':<14s} {'MB':>9s} {'s':>7s} {'MB/s':>7s} {'lines':>11s} {'lines/pt':>9s} {'B/pt':>8s}")
    sizes = {}
    pngs = [0, 0.0, 0]
    for w in r["writers"]:
        p = Path(w["file"])
        if not p.is_file():
            continue
        size = p.stat().st_size
        sec = w["end"] - w["start"]
        if p.suffix == ".png":  # the figures: one line for them all
            pngs = [pngs[0] + size, pngs[1] + sec, pngs[2] + 1]
            continue
        sizes[p.name] = size
        text = p.suffix in (".csv", ".xyz", ".nc", ".obj", ".json", ".toml", ".html")
        lines = count_lines(p) if text else None
        rate = size / 1e6 / sec if sec > 0 else float("inf")
        print(f"  {p.name:<14s} {size / 1e6:9.2f} {sec:7.2f} {rate:7.1f} "
              f"{lines if lines is not None else '-':>11} "
              f"{(f'{lines / n:.2f}' if lines is not None else '-'):>9s} {size / n:8.1f}")
    if pngs[2]:
        print(f"  {str(pngs[2]) + ' PNGs':<14s} {pngs[0] / 1e6:9.2f} {pngs[1]:7.2f} {'':>7s} {'-':>11} {'-':>9s} "
              f"{pngs[0] / n:8.1f}  (savefig only)")
    files = [w for w in r["writers"] if Path(w["file"]).suffix != ".png" and Path(w["file"]).name != "report.html"]
    if files:  # the machine and run-folder files, in whatever order the job writes them
        first, last = min(w["start"] for w in files), max(w["end"] for w in files)
        line = f"  writing machine and run-folder files {last - first:.2f} s"
        report = [w["end"] for w in r["writers"] if Path(w["file"]).name == "report.html"]
        if report:
            line += f", report {report[-1] - last:.2f} s (drawing included)"
        print(line + " (from the writers' clocks)")
    missed, met = [], []

    def target(ok: bool, text: str, why: str = "") -> None:
        (met if ok else missed).append(text if ok or not why else f"{text}: {why}")

    post = s.get("post") or {}
    gcode = sizes.get("toolpath.nc")
    if gcode is not None:
        lpp = float(post.get("lines_per_dwell_point") or 0.0)
        seg = post.get("segmenting")
        tol = post.get("segment_chord_tol_mm")
        how = (f"{seg} segmenting at a chord tolerance of {1000 * tol:g} um" if seg and tol
               else f"{post.get('mode', '?')} mode")
        if post.get("arcs"):
            how += f", {int(post.get('arc_blocks') or 0) / max(lpp * n, 1):.0%} of the blocks arcs"
        elif post.get("arcs") is False:
            how += ", straight blocks only (--no-arcs)"
        target(gcode / n <= TARGET_GCODE_BYTES_PER_POINT,
               f"G-code {gcode / n:.0f} B per dwell point (target <= {TARGET_GCODE_BYTES_PER_POINT:.0f}, "
               f"{gcode / n / TARGET_GCODE_BYTES_PER_POINT:.1f}x)",
               f"{lpp:.2f} blocks per dwell point ({how}) of about {gcode / max(lpp * n, 1):.0f} B each; the target "
               f"allows about {TARGET_GCODE_BYTES_PER_POINT * max(lpp * n, 1) / gcode:.1f} of them per point "
               "(docs/machine-output.md: blocks per dwell point at each tolerance)")
    rate = samples / sm if sm > 0 else 0.0
    outside = sm - ip if math.isfinite(ip) else float("nan")
    target(rate >= TARGET_SAMPLES_PER_S,
           f"smoothing stage {rate / 1e6:.2f} M samples/s (target >= {TARGET_SAMPLES_PER_S / 1e6:.0f} M/s, "
           f"{rate / TARGET_SAMPLES_PER_S:.2f}x of it)",
           f"the kernels made {made / samples:.2f} samples per sample kept (regions run again to meet their "
           f"times) at {made / ip / 1e6:.2f} M samples/s ({ip:.1f} s), and the stage spent {outside:.1f} s outside them "
           "(the curve, its checks, the figures)")
    # the writers: files written in the same pass over the samples (their clocks overlap) count as one
    spans = sorted((w["start"], w["end"], Path(w["file"]).name) for w in r["writers"]
                   if Path(w["file"]).name in ("toolpath.nc", "toolpath.xyz", "path.csv") and Path(w["file"]).is_file())
    groups: list[list] = []
    for a, b, name in spans:
        if groups and a < groups[-1][1]:
            groups[-1][1] = max(groups[-1][1], b)
            groups[-1][2].append(name)
        else:
            groups.append([a, b, [name]])
    for a, b, names in groups:
        mb = sum(sizes.get(x, 0) for x in names) / 1e6
        wr = mb / (b - a) if b > a else float("inf")
        what = " + ".join(names) + (" (one pass over the samples)" if len(names) > 1 else "")
        regen = ""
        if len(names) > 1 and s["smooth"].get("samples_mode") == "stream" and math.isfinite(ip):
            regen = (f"; the samples streamed, so the pass also regenerated them, about {ip * samples / made:.0f} s "
                     "at the kernels' rate")
        target(wr >= TARGET_WRITER_MB_S, f"writer {what} {wr:.0f} MB/s (target >= {TARGET_WRITER_MB_S:.0f} MB/s)",
               f"{mb:.0f} MB in {b - a:.1f} s{regen}")
    big = sorted(((v, k) for k, v in tim.items()), reverse=True)[:3]
    mode = s["smooth"].get("samples_mode", "memory")
    held = (f"the job held every machine sample ({samples:,} x 40 B of arrays and their copies: "
            f"{s['smooth'].get('samples_mode_reason') or '--samples memory'})" if mode == "memory" else
            "the samples streamed (regenerated in chunks for the writers), so the peak is the stage's own "
            "O(dwell points) data")
    for size, t_s, t_gb in ((6, TARGET_1E6_S, TARGET_1E6_RSS_GB), (7, TARGET_1E7_S, TARGET_1E7_RSS_GB)):
        if abs(math.log10(r["n_target"]) - size) >= 0.01:
            continue
        b = BEFORE.get(10.0**size, {})
        before = (f"; before: {b['cpu']:.1f} s CPU, " if b.get("cpu") else "; before: ") + (
            f"{b['wall']:.0f} s wall" + (f" at load {b['load']:.0f}" if b.get("load") else "") if b else "")
        # the job runs on one core: quiet, its wall time is about its CPU time (+ the disk's own writing)
        target(r["cpu"] <= t_s, f"10^{size} whole job {r['cpu']:.1f} s of CPU, the estimate of its quiet wall time "
               f"(target <= {t_s:.0f} s, by {r['cpu'] - t_s:+.1f} s); {r['wall']:.0f} s wall at load "
               f"{r['load']:.1f}{before}", "the largest stages (CPU): " + ", ".join(
                   f"{k} {v:.1f} s" for k, v in sorted((r.get("stage_cpu") or tim).items(), key=lambda kv: -kv[1])[:4]))
        target(r["rss_gb"] <= t_gb, f"10^{size} peak RSS {r['rss_gb']:.2f} GB (target <= {t_gb:.0f} GB"
               + (f"; before {b['rss_gb']:.2f} GB)" if b else ")"),
               f"the peak is in the stage '{top[0]}' ({top[1]:.2f} GB); {held}")
        if b.get("gcode_b") and gcode is not None:
            print(f"  G-code before: {b['gcode_b']:.1f} B per dwell point; now {gcode / n:.1f}")
    for t in met:
        print(f"  target met: {t}")
    for t in missed:
        print(f"  target MISSED: {t}")
    return missed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="1e5,1e6", help="dwell-point counts, comma-separated (default 1e5,1e6)")
    ap.add_argument("--huge", action="store_true", help="also 10^7 dwell points")
    ap.add_argument("--no-report", action="store_true", help="pass --no-report (no HTML report)")
    ap.add_argument("--keep", type=Path, help="keep meshes and outputs in this folder")
    args = ap.parse_args()
    sizes = [float(x) for x in args.sizes.split(",") if x]
    if args.huge:
        sizes.append(1e7)
    extra = ["--no-report"] if args.no_report else []
    ctx = tempfile.TemporaryDirectory(prefix="bench_job-") if args.keep is None else None
    work = Path(ctx.name) if ctx else args.keep
    work.mkdir(parents=True, exist_ok=True)
    try:
        t = time.perf_counter()
        run_job(2e3, work, ["--no-report"])  # warm-up: numba's compile or cache load, imports
        print(f"warm-up job (2,000 points): {time.perf_counter() - t:.1f} s")
        missed = {}
        for n in sizes:
            missed[n] = show(run_job(n, work, extra))
        print("\nsummary: " + "; ".join(f"{n:.0e}: {'targets met' if not m else 'missed ' + str(len(m))}"
                                       for n, m in missed.items()))
    finally:
        if ctx:
            ctx.cleanup()


if __name__ == "__main__":
    main()
