"""Benchmark: the issue's comparison `polishpath simulate hemisphere` (4 paths x 5 seeds) in CPU seconds and memory.

Target (issue 29, item 3): the whole comparison in at most 2 minutes on the 2-core machine, one case's memory
bounded. On a shared machine a wall-clock figure cannot be read directly, so this prints, for each run:

* CPU seconds of the calling process (planning, flattening, the files) and of its worker processes (the cases);
* the wall time at the load of the moment and the load average;
* the peak memory of the process tree (the sum of the proportional set sizes of the process and its workers,
  sampled every 0.2 s: the pages a forked worker shares with its parent counted once);
* a **quiet-machine wall estimate** = CPU of the calling process + CPU of the workers / workers (the cases
  spread evenly over idle cores), against the 120 s target: met, or missed by how much.

``--case`` instead profiles one case (the first seed of ``--pattern``) stage by stage: CPU seconds and peak RSS of
sampling the path, the noise, rasterising, the rotating tool's removal, the smoothing, the PSDs and the fair
figures, and the case's memory estimate (:meth:`polishpath.simulate.cases.Case.peak_bytes`) beside its measured
peak.

    PYTHONPATH=src python benchmarks/bench_simulate_speed.py [--workers 1,2] [--seeds 5] [--src DIR]
    PYTHONPATH=src python benchmarks/bench_simulate_speed.py --case [--pattern pseudorandom] [--src DIR]

``--src DIR`` runs another checkout's ``src`` (e.g. the commit before a change, from ``git archive``) in the
subprocess. A run whose tree may pass 3 GB belongs under ``flock /work/lead/bigmem.lock`` on the shared machine.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

TARGET_S = 120.0
SURFACE = "hemisphere"
PATTERNS = "pseudorandom,raster,spiral,rectangular"

# the comparison, run in the subprocess: CPU of this process and of its (reaped) workers, wall
_RUN = r"""
import json, resource, sys, time
from typer.testing import CliRunner
from polishpath.cli import app
args = json.loads(sys.argv[1])
w0, c0 = time.perf_counter(), time.process_time()
r = CliRunner().invoke(app, args)
ch = resource.getrusage(resource.RUSAGE_CHILDREN)
print("BENCH " + json.dumps({"exit": r.exit_code, "wall_s": time.perf_counter() - w0, "parent_cpu_s": time.process_time() - c0,
                             "workers_cpu_s": ch.ru_utime + ch.ru_stime, "output": r.output[-2000:]}))
"""

# one case, stage by stage (the stages are wrapped where compare_paths and simulate_removal call them)
_CASE = r"""
import json, sys, time, threading, resource
pattern, seeds = sys.argv[1], int(sys.argv[2])
peak = [0]
def rss():
    with open("/proc/self/status") as f:
        return next(int(l.split()[1]) * 1024 for l in f if l.startswith("VmRSS"))
def sample():
    while True:
        peak[0] = max(peak[0], rss()); time.sleep(0.01)
threading.Thread(target=sample, daemon=True).start()
from polishpath.surfaces import load_surface
from polishpath.flatten import flatten, boundary_region
from polishpath.pipeline.sweep import plan_patterns
from polishpath.simulate.patterns import patch_bounds_at_centre
from polishpath.simulate import rotating_tool_tif
import polishpath.simulate.compare as C
import polishpath.simulate.removal as R
import polishpath.simulate.fair as F
flat = flatten(load_surface("hemisphere"), "mabf")
region = boundary_region(flat)
planned, _ = plan_patterns(flat, region, [pattern], 0.5, seed=0, seeds=seeds, spacing_on="surface")
got = {}
def capture(fn, cases, runner=None):
    if fn.__name__ == "run_case":
        got["cases"] = list(cases)
        raise KeyboardInterrupt
    return [fn(c) for c in cases]
C.run_cases = capture
try:
    C.compare_planned(planned, seed=0, seeds=seeds, timing="machine", tif=rotating_tool_tif(),
                      patch_bounds=patch_bounds_at_centre(region, 20.0))
except KeyboardInterrupt:
    pass
case = got["cases"][0]
stages = []
def wrap(mod, name, label):
    f = getattr(mod, name)
    def w(*a, **k):
        c0 = time.process_time(); p0 = peak[0]; peak[0] = rss()
        out = f(*a, **k)
        stages.append((label, time.process_time() - c0, peak[0])); peak[0] = max(p0, peak[0])
        return out
    setattr(mod, name, w)
for mod, name, label in [(R, "path_motion_samples", "path samples"), (R, "process_noise_factor", "process noise"),
                         (R, "rasterize_time", "rasterise"), (R, "_rotating_removal", "rotating removal"),
                         (R, "smooth_surface", "smoothing"), (C, "smooth_surface", "smoothing (depth)"),
                         (C, "evaluate_result", "PSDs before/after"), (F, "fair_metrics", "fair figures")]:
    wrap(mod, name, label)
import polishpath.simulate.cases as K
build = K.Start.build
def timed_build(self):
    c0 = time.process_time(); p0 = peak[0]; peak[0] = rss()
    out = build(self); stages.append(("initial surface", time.process_time() - c0, peak[0])); peak[0] = max(p0, peak[0])
    return out
K.Start.build = timed_build
peak[0] = rss(); c0 = time.process_time()
r = C.run_case(case)
cpu = time.process_time() - c0
est = case.peak_bytes() if hasattr(case, "peak_bytes") else None
print("BENCH " + json.dumps({"cpu_s": cpu, "peak_rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
                             "estimate": est, "stages": stages, "n_path_points": int(len(case.path[0])),
                             "figures": {k: r.row[k] for k in ("residual_band_rms_nm", "lattice_peak_db", "pvn",
                                                              "suppression_ratio")}}))
"""


def _pss(pid: int) -> int:
    """Proportional set size of a process, bytes (pages shared with its forked workers counted once overall)."""
    try:
        with open(f"/proc/{pid}/smaps_rollup") as f:
            return next(int(ln.split()[1]) * 1024 for ln in f if ln.startswith("Pss:"))
    except (OSError, StopIteration, ValueError):
        return 0


def _tree(pid: int) -> list[int]:
    """``pid`` and its descendants."""
    kids: dict[int, list[int]] = {}
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/stat") as f:
                kids.setdefault(int(f.read().rsplit(")", 1)[1].split()[1]), []).append(int(d))
        except (OSError, IndexError, ValueError):
            continue
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo.extend(kids.get(p, []))
    return out


def _run(code: str, argv: list[str], src: str | None) -> tuple[dict, int, float]:
    env = dict(os.environ)
    if src:
        env["PYTHONPATH"] = src
    load0 = os.getloadavg()[0]
    proc = subprocess.Popen([sys.executable, "-c", code, *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=env)
    peak = [0]

    def watch():  # the process list is read once a second (reading /proc costs CPU the run should get)
        pids, last = [proc.pid], 0.0
        while proc.poll() is None:
            if time.monotonic() - last > 1.0:
                pids, last = _tree(proc.pid), time.monotonic()
            peak[0] = max(peak[0], sum(_pss(p) for p in pids))
            time.sleep(0.2)

    th = threading.Thread(target=watch, daemon=True)
    th.start()
    out, err = proc.communicate()
    th.join()
    line = next((ln for ln in out.splitlines() if ln.startswith("BENCH ")), None)
    if line is None:
        raise SystemExit(f"the run failed (exit {proc.returncode}):\n{err[-3000:]}")
    return json.loads(line[6:]), peak[0], 0.5 * (load0 + os.getloadavg()[0])


def bench_comparison(a) -> None:
    print(f"polishpath simulate {SURFACE} --patterns {PATTERNS} --spacing 0.5 --seeds {a.seeds} "
          f"(src {a.src or 'installed'}); target {TARGET_S:.0f} s on 2 quiet cores", flush=True)
    for w in [int(x) for x in a.workers.split(",")]:
        with tempfile.TemporaryDirectory() as tmp:
            args = ["simulate", SURFACE, "--patterns", PATTERNS, "--spacing", "0.5", "--seeds", str(a.seeds),
                    "--workers", str(w), "-q", "-o", str(Path(tmp) / "out")]
            r, peak, load = _run(_RUN, [json.dumps(args)], a.src)
        if r["exit"] != 0:
            raise SystemExit(f"exit {r['exit']}: {r['output']}")
        cpu = r["parent_cpu_s"] + r["workers_cpu_s"]
        quiet = r["parent_cpu_s"] + r["workers_cpu_s"] / w
        verdict = "met" if quiet <= TARGET_S else f"missed by {quiet - TARGET_S:.0f} s ({quiet / TARGET_S:.2f}x)"
        print(f"  {w} worker(s): CPU {cpu:.0f} s (calling process {r['parent_cpu_s']:.0f} s, workers "
              f"{r['workers_cpu_s']:.0f} s), wall {r['wall_s']:.0f} s at load {load:.1f} (wall/CPU "
              f"{r['wall_s'] / cpu:.2f}), peak memory of the process tree (sum of PSS) {peak / 2**30:.2f} GB; quiet-machine wall estimate "
              f"{quiet:.0f} s: {verdict}", flush=True)


def bench_case(a) -> None:
    r, peak, load = _run(_CASE, [a.pattern, str(a.seeds)], a.src)
    print(f"one case: {SURFACE}, {a.pattern}, seed 0 of {a.seeds}, machine timing, 20 mm patch at 5 um "
          f"({r['n_path_points']:,} machine samples; src {a.src or 'installed'}; load {load:.1f})")
    for label, cpu, pk in r["stages"]:
        print(f"  {label:<20} CPU {cpu:6.1f} s   peak RSS {pk / 2**30:5.2f} GB")
    est = r["estimate"]
    print(f"  whole case           CPU {r['cpu_s']:6.1f} s   peak RSS {r['peak_rss'] / 2**30:5.2f} GB"
          + (f" (estimate {est / 2**30:.2f} GB)" if est else ""))
    print("  figures: " + ", ".join(f"{k} {v!r}" for k, v in r["figures"].items()))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--workers", default="1,2", help="worker counts to run, comma-separated")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--case", action="store_true", help="profile one case stage by stage instead")
    ap.add_argument("--pattern", default="pseudorandom")
    ap.add_argument("--src", default=None, help="run this src folder (PYTHONPATH) instead of the installed package")
    a = ap.parse_args(argv)
    bench_case(a) if a.case else bench_comparison(a)


if __name__ == "__main__":
    main()
