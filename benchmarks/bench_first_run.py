"""Where a fresh clone's first ``make demo`` and ``make test`` spend their time (issue 29, "First run").

Run: ``python3 benchmarks/bench_first_run.py [--repo .] [--what demo,test] [--plain] [--json FILE] [--keep DIR]``

Each measured command starts from a fresh clone (``git clone REPO``: no ``.venv``, no numba cache, every
source file's mtime the clone's) and runs the Makefile's own targets one after another, each timed from outside
(wall seconds, and the CPU seconds of the processes it waited for):

* ``make venv`` (``python3 -m venv``), then ``make install`` / ``make install-test``: pip, its output read line by
  line as it comes (``PIP_VERBOSE=1`` cancels the Makefile's ``-q``) and split at pip's own progress lines into
  the build environment (hatchling), the editable metadata, resolving and fetching the dependencies (how many
  wheels came from a local index or cache, how many were downloaded), building the editable wheel, and
  installing (unpacking and byte-compiling every package);
* ``make demo``: the job itself, with ``PYTHONPROFILEIMPORTTIME=1`` (``python -X importtime``: seconds of imports
  by top-level package) and ``benchmarks/numba_probe.py`` (numba's compile events: CPU seconds per kernel and
  signature, exclusive of the kernels it compiled as callees, the part under LLVM's lock, which kernel asked for
  it, and a census of the dispatchers the job loaded: compiled, from cache, or never called); the job's stages
  from ``summary.json`` (``timings_s``) and the report's time from the files' mtimes; the Makefile's helper
  job on the second core (``DEMO_HELPER``, ``--pattern raster``) is reported apart;
* ``make test``: ``make install-test``, ``make system-deps``, then pytest (the conftest's numba warm-up job, which
  ``tests/conftest.py`` reports in pytest's summary, and the workers), with the same probes in every Python
  process the suite starts, so the compile CPU is split into the warm-up's, the workers' and their subprocesses'.

``--plain`` also runs a second fresh clone's ``make demo`` with nothing attached (no probes), to show what the
probes cost. The issue's targets are printed as met or missed, and by how much. The machine is shared: the load
average is printed with each command; CPU seconds are steadier than wall seconds under load, so both are given.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from numba_probe import compile_summary, print_compile, read_probes, stage_split  # noqa: E402

# the targets (issue 29, "First run")
TARGET_DEMO_S = 60.0
TARGET_TEST_S = 240.0

# pip's progress lines (non-interactive output) that open each phase of an editable install
_PIP_PHASES = [
    ("build env (hatchling)", re.compile(r"^\s*Installing build dependencies: started")),
    ("editable metadata", re.compile(r"^\s*(Checking if build backend|Getting requirements to build|Preparing editable)"
                                     r".*: started")),
    ("resolve + fetch deps", re.compile(r"^\s*Collecting ")),
    ("build editable wheel", re.compile(r"^\s*(Building wheels for collected|Building editable for)")),
    ("install (unpack, byte-compile)", re.compile(r"^\s*Installing collected packages")),
    ("done", re.compile(r"^\s*Successfully installed")),
]

_SITECUSTOMIZE = f"""
import sys
sys.path.insert(0, {str(HERE)!r})
import numba_probe
numba_probe.install()
"""


def load_average() -> str:
    try:
        return " ".join(f"{x:.1f}" for x in os.getloadavg())
    except OSError:  # pragma: no cover
        return "?"


def run_timed(cmd: list[str], cwd: Path, env: dict, on_line=None) -> dict:
    """Run ``cmd``; return wall and CPU seconds (of the children it waited for), exit code and its output lines,
    each with the seconds since the start at which it arrived (stdout and stderr read as they come)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         errors="replace")
    lines: list[tuple[float, str, str]] = []
    lock = threading.Lock()

    def pump(stream, tag):
        for line in stream:
            t = time.perf_counter() - t0
            with lock:
                lines.append((t, tag, line.rstrip("\n")))
            if on_line is not None:
                on_line(t, tag, line)

    threads = [threading.Thread(target=pump, args=(p.stdout, "out")),
               threading.Thread(target=pump, args=(p.stderr, "err"))]
    for th in threads:
        th.start()
    rc = p.wait()
    for th in threads:
        th.join()
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"cmd": " ".join(cmd), "rc": rc, "wall_s": wall, "cpu_s": cpu, "lines": lines}


def check(step: dict, what: str) -> None:
    if step["rc"] != 0:
        tail = "\n".join(f"  {s}" for _, _, s in step["lines"][-30:])
        sys.exit(f"{what} failed (exit {step['rc']}): {step['cmd']}\n{tail}")


def pip_phases(step: dict) -> dict:
    """Seconds of each phase of one ``pip install -e`` from its progress lines, and where the wheels came from."""
    marks: list[tuple[float, str]] = []
    got = collections.Counter()
    for t, _, s in step["lines"]:
        for label, rx in _PIP_PHASES:
            if rx.search(s) and label not in {m[1] for m in marks}:
                marks.append((t, label))
        if re.match(r"^\s*Downloading ", s):
            got["downloaded" if "file://" not in s else "local index"] += 1
        elif re.match(r"^\s*(Using cached|File was already downloaded|Processing /)", s):
            got["cached or local"] += 1
        elif re.match(r"^\s*Collecting ", s):
            got["requirements collected"] += 1
    phases: dict[str, float] = {}
    start = 0.0
    label = "start-up"
    for t, lab in marks:
        phases[label] = phases.get(label, 0.0) + (t - start)
        start, label = t, lab
    phases[label] = phases.get(label, 0.0) + (step["wall_s"] - start)
    if "done" in phases:
        phases["after pip's last line"] = phases.pop("done")
    return {"phases_s": phases, "wheels": dict(got)}


def import_times(lines: list[tuple[float, str, str]]) -> dict:
    """Seconds of imports (``-X importtime``'s self times) by top-level package, from one process's stderr."""
    by_pkg: collections.Counter = collections.Counter()
    n = 0
    for _, tag, s in lines:
        m = re.match(r"import time:\s+(\d+)\s*\|\s*(\d+)\s*\|(\s*)(\S+)", s)
        if tag != "err" or not m:
            continue
        n += 1
        by_pkg[m.group(4).split(".")[0]] += int(m.group(1)) / 1e6
    return {"total_s": sum(by_pkg.values()), "modules": n, "by_package_s": dict(by_pkg.most_common())}


def stages_of(out_dir: Path) -> dict:
    """The job's stage seconds (``summary.json``) and the report's (mtime of report.html after summary.json)."""
    try:
        summary = json.loads((out_dir / "summary.json").read_text())
    except (OSError, json.JSONDecodeError):
        return {}
    st = dict(summary.get("timings_s", {}))
    rep = out_dir / "report.html"
    if rep.exists():
        st["report (mtime)"] = rep.stat().st_mtime - (out_dir / "summary.json").stat().st_mtime
    return st


def fresh_clone(repo: Path, work: Path, name: str) -> tuple[Path, dict]:
    dest = work / name
    step = run_timed(["git", "clone", "-q", str(repo), str(dest)], cwd=work, env=dict(os.environ))
    check(step, "git clone")
    commit = subprocess.run(["git", "-C", str(dest), "log", "-1", "--format=%h %s"], capture_output=True,
                            text=True).stdout.strip()
    step["commit"] = commit[:100]
    return dest, step


def base_env() -> dict:
    env = dict(os.environ)
    for k in ("VIRTUAL_ENV", "PYTHONPATH", "PYTHONPROFILEIMPORTTIME", "POLISHPATH_PROBE_DIR", "NUMBA_CACHE_DIR",
              "NUMBA_DISABLE_JIT"):
        env.pop(k, None)
    env["PIP_VERBOSE"] = "1"  # cancels the Makefile's -q: pip then prints its progress lines
    return env


def probed_env(env: dict, site: Path, probe_dir: Path) -> dict:
    e = dict(env, PYTHONPATH=str(site), POLISHPATH_PROBE_DIR=str(probe_dir), PYTHONPROFILEIMPORTTIME="1")
    return e


def install_steps(repo: Path, work: Path, name: str, targets: tuple[str, ...]) -> tuple[Path, dict, dict, Path]:
    """A fresh clone and the Makefile's install targets in it, timed: (clone, env, result so far, probe folder)."""
    clone, cl = fresh_clone(repo, work, name)
    env = base_env()
    res = {"what": f"make {name}", "commit": cl["commit"], "load_before": load_average(), "steps": {}}
    for target in targets:
        st = run_timed(["make", target], cwd=clone, env=env)
        check(st, f"make {target}")
        res["steps"][f"make {target}"] = st
    res["pip"] = pip_phases(res["steps"][f"make {targets[1]}"])
    probe_dir = work / f"probe-{name}"
    probe_dir.mkdir()
    return clone, env, res, probe_dir


def bench_demo(repo: Path, work: Path, site: Path) -> dict:
    clone, env, res, probe_dir = install_steps(repo, work, "demo", ("venv", "install"))
    st = run_timed(["make", "demo"], cwd=clone, env=probed_env(env, site, probe_dir))
    check(st, "make demo")
    res["steps"]["make demo (the job)"] = st
    res["imports"] = import_times(st["lines"])
    probes = read_probes(probe_dir)
    # the demo job, and the Makefile's helper job on the second core (--pattern raster) when it ran
    job = [p for p in probes if "plan" in p["argv"] and "raster" not in p["argv"]]
    helper = [p for p in probes if "raster" in p["argv"]]
    res["job_process"] = [{k: p[k] for k in ("argv", "wall_s", "cpu_s", "max_rss_mb")} for p in job + helper]
    res["compile"] = compile_summary(job)
    res["helper_compile_cpu_s"] = compile_summary(helper)["cpu_s"] if helper else None
    res["stages_s"] = stages_of(clone / "out")
    res["stage_split"] = stage_split(job[0]) if job else []
    res["load_after"] = load_average()
    res["total_wall_s"] = sum(s["wall_s"] for s in res["steps"].values())
    res["total_cpu_s"] = sum(s["cpu_s"] for s in res["steps"].values())
    return res


def bench_plain_demo(repo: Path, work: Path) -> dict:
    clone, cl = fresh_clone(repo, work, "demo-plain")
    env = base_env()
    env.pop("PIP_VERBOSE")
    st = run_timed(["make", "demo"], cwd=clone, env=env)
    check(st, "make demo (plain)")
    return {"what": "make demo, nothing attached", "commit": cl["commit"], "load_before": load_average(),
            "wall_s": st["wall_s"], "cpu_s": st["cpu_s"], "stages_s": stages_of(clone / "out")}


def bench_test(repo: Path, work: Path, site: Path, workers: str | None) -> dict:
    clone, env, res, probe_dir = install_steps(repo, work, "test", ("venv", "install-test", "system-deps"))
    penv = probed_env(env, site, probe_dir)
    penv.pop("PYTHONPROFILEIMPORTTIME")  # thousands of import lines from every worker: not wanted here
    penv["PYTEST_ADDOPTS"] = (penv.get("PYTEST_ADDOPTS", "") + " --durations=15").strip()
    cmd = ["make", "test"] + ([f"TEST_WORKERS={workers}"] if workers else [])
    st = run_timed(cmd, cwd=clone, env=penv)
    res["steps"]["make test (pytest)"] = st
    res["rc"] = st["rc"]
    text = [s for _, _, s in st["lines"]]
    res["pytest_tail"] = [s for s in text if re.search(r"(passed|failed|error)", s) and " in " in s][-1:]
    res["warm_up"] = [s for s in text if "numba warm-up" in s]
    res["slowest"] = [s for s in text if re.match(r"^\d+\.\d+s (call|setup|teardown) ", s)][:15]
    probes = read_probes(probe_dir)
    groups: dict[str, list[dict]] = collections.defaultdict(list)
    for p in probes:
        argv = " ".join(p["argv"])
        if "polishpath-warm-up-" in argv:
            groups["conftest warm-up job"].append(p)
        elif p["argv"][:1] == ["-c"] or "execnet" in argv or "xdist" in argv:
            groups["xdist workers"].append(p)
        elif "pytest" in argv:
            groups["pytest controller"].append(p)
        else:
            groups["subprocesses of the tests"].append(p)
    res["processes"] = {g: {"n": len(ps), "cpu_s": sum(p["cpu_s"] for p in ps),
                            "compile_cpu_s": compile_summary(ps)["cpu_s"]} for g, ps in groups.items()}
    res["compile"] = compile_summary(probes)
    res["load_after"] = load_average()
    res["total_wall_s"] = sum(s["wall_s"] for s in res["steps"].values())
    return res


def verdict(seconds: float, target: float) -> str:
    if seconds <= target:
        return f"MET ({seconds:.0f} s <= {target:.0f} s)"
    return f"MISSED by {seconds - target:.0f} s ({seconds / target:.2f}x the {target:.0f} s target)"


def print_steps(res: dict) -> None:
    for name, st in res["steps"].items():
        print(f"  {name:<28} {st['wall_s']:7.1f} s wall  {st['cpu_s']:7.1f} s CPU")


def print_pip(pip: dict) -> None:
    for k, v in pip["phases_s"].items():
        print(f"      pip: {k:<32} {v:6.1f} s")
    print(f"      wheels: {pip['wheels']}")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repo", default=str(HERE.parent), help="the repository to clone (default: this checkout)")
    ap.add_argument("--what", default="demo,test", help="demo, test or both (default demo,test)")
    ap.add_argument("--plain", action="store_true", help="also a fresh make demo with no probes attached")
    ap.add_argument("--workers", default=None, help="TEST_WORKERS for make test (default: the Makefile's)")
    ap.add_argument("--top", type=int, default=25, help="kernels listed (default 25)")
    ap.add_argument("--json", default=None, help="write every figure to this JSON file")
    ap.add_argument("--keep", default=None, help="work in this folder and keep it (default: a temporary one)")
    args = ap.parse_args(argv)
    what = {w.strip() for w in args.what.split(",") if w.strip()}
    work = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="polishpath-first-run-"))
    work.mkdir(parents=True, exist_ok=True)
    site = work / "site"
    site.mkdir(exist_ok=True)
    (site / "sitecustomize.py").write_text(_SITECUSTOMIZE)
    print(f"bench_first_run: {os.cpu_count()} CPUs, load {load_average()}, PYTHONDONTWRITEBYTECODE="
          f"{os.environ.get('PYTHONDONTWRITEBYTECODE', '(unset)')}, work folder {work}")
    results: dict = {}
    try:
        if "demo" in what:
            r = results["demo"] = bench_demo(Path(args.repo), work, site)
            print(f"\n== make demo from a fresh clone of {r['commit']}  (load {r['load_before']} -> "
                  f"{r['load_after']})")
            print_steps(r)
            print_pip(r["pip"])
            im = r["imports"]
            print(f"  imports in the job: {im['total_s']:.2f} s, {im['modules']} modules: " + ", ".join(
                f"{k} {v:.2f}" for k, v in list(im["by_package_s"].items())[:8]))
            print(f"  {'job stage':<38} {'wall s':>7} {'CPU s':>7} {'numba compile CPU s':>20}")
            for row in r["stage_split"]:
                cpu = "" if row["cpu_s"] is None else f"{row['cpu_s']:7.1f}"
                print(f"  {row['stage']:<38} {row['wall_s']:7.1f} {cpu:>7} {row['compile_cpu_s']:14.1f} "
                      f"({row['kernels']} kernels)")
            for p in r["job_process"]:
                who = "helper (second core)" if "raster" in p["argv"] else "job"
                print(f"  {who} process: {p['wall_s']:.1f} s wall, {p['cpu_s']:.1f} s CPU, {p['max_rss_mb']:.0f} MB")
            if r["helper_compile_cpu_s"] is not None:
                print(f"  the helper's numba compile: {r['helper_compile_cpu_s']:.1f} s CPU (on the second core)")
            print_compile(r["compile"], args.top)
            print(f"  make demo total (venv + install + job): {r['total_wall_s']:.1f} s wall, {r['total_cpu_s']:.1f} s "
                  f"CPU -> target {verdict(r['total_wall_s'], TARGET_DEMO_S)}")
        if args.plain and "demo" in what:
            r = results["demo_plain"] = bench_plain_demo(Path(args.repo), work)
            print(f"\n== make demo, nothing attached: {r['wall_s']:.1f} s wall, {r['cpu_s']:.1f} s CPU "
                  f"(load {r['load_before']}) -> {verdict(r['wall_s'], TARGET_DEMO_S)}")
        if "test" in what:
            r = results["test"] = bench_test(Path(args.repo), work, site, args.workers)
            print(f"\n== make test from a fresh clone of {r['commit']}  (load {r['load_before']} -> "
                  f"{r['load_after']}), pytest exit {r['rc']}")
            print_steps(r)
            print_pip(r["pip"])
            for s in r["warm_up"] + r["pytest_tail"]:
                print(f"  {s.strip()}")
            for g, v in r["processes"].items():
                print(f"  {g:<28} {v['n']:4d} processes, {v['cpu_s']:7.1f} s CPU, of which numba compile "
                      f"{v['compile_cpu_s']:6.1f} s")
            print_compile(r["compile"], min(args.top, 12))
            print("  slowest tests:\n" + "\n".join(f"    {s}" for s in r["slowest"][:10]))
            print(f"  make test total: {r['total_wall_s']:.1f} s -> target {verdict(r['total_wall_s'], TARGET_TEST_S)}")
    finally:
        if args.json:
            def strip(o):
                if isinstance(o, dict):
                    return {k: strip(v) for k, v in o.items() if k != "lines"}
                if isinstance(o, list):
                    return [strip(v) for v in o]
                if isinstance(o, set):
                    return sorted(o)
                return o
            Path(args.json).write_text(json.dumps(strip(results), indent=1))
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
