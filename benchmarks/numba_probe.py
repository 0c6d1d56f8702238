"""Record what numba compiles in one Python process, kernel by kernel (for ``bench_first_run.py``).

``bench_first_run.py`` puts a ``sitecustomize.py`` that imports this module first on ``PYTHONPATH`` and sets
``POLISHPATH_PROBE_DIR``: every Python process of the measured command (``polishpath plan``, pytest, its
xdist workers, the command-line subprocesses the tests start) then writes ``probe-<pid>.json`` there at exit.
Nothing here changes what the process computes: it listens to numba's own compile events
(``numba.core.event``, "numba:compile" and "numba:llvm_lock") once ``numba`` is imported.

Per compile event (one kernel, one signature): CPU seconds (``time.process_time``) and wall seconds, inclusive
(with the kernels it compiled as callees) and exclusive (without them), the exclusive part spent holding LLVM's
lock (optimisation and machine code), which kernel's compile asked for it (None: called from Python), and
whether it ran while a module was being imported (an eager compile through a signature). At exit, a census of
every numba dispatcher in the loaded ``polishpath`` modules: its ``inline`` option, how many signatures it
holds, and the on-disk cache's hits and misses.
"""

from __future__ import annotations

import atexit
import collections
import contextlib
import importlib.machinery
import json
import os
import sys
import time
from pathlib import Path

_T0 = time.time()
_CPU0 = time.process_time()
_records: list[dict] = []
_stages: list[dict] = []
_done: set[str] = set()
_out_dir: list[str] = []
_last_dump = [time.perf_counter()]
DUMP_EVERY_S = 5.0
_stack: list[dict] = []
_llvm_depth = [0, 0.0, 0.0]  # depth, cpu at the outermost acquire, wall at the outermost acquire


def _name(disp) -> str:
    f = disp.py_func
    return f"{f.__module__}.{f.__qualname__}"


def _importing() -> bool:
    """Whether a module import is on the stack (a compile then runs at import: an eager signature)."""
    f = sys._getframe(2)
    while f is not None:
        if f.f_code.co_name in ("exec_module", "_load_unlocked") and "importlib" in f.f_code.co_filename:
            return True
        f = f.f_back
    return False


def _register() -> None:
    from numba.core import event as ev

    class Compiles(ev.Listener):
        def on_start(self, event):
            d = event.data
            _stack.append({"kernel": _name(d["dispatcher"]), "sig": str(tuple(d["args"])),
                           "parent": _stack[-1]["kernel"] if _stack else None, "at_import": _importing(),
                           "start_s": time.time() - _T0, "_cpu0": time.process_time(),
                           "_wall0": time.perf_counter(), "_child_cpu": 0.0, "_child_wall": 0.0, "llvm_cpu_s": 0.0,
                           "failed": False})

        def on_end(self, event):
            r = _stack.pop()
            r["cpu_incl_s"] = time.process_time() - r.pop("_cpu0")
            r["wall_incl_s"] = time.perf_counter() - r.pop("_wall0")
            r["cpu_excl_s"] = r["cpu_incl_s"] - r.pop("_child_cpu")
            r["wall_excl_s"] = r["wall_incl_s"] - r.pop("_child_wall")
            exc = getattr(event, "_exc_details", None)
            r["failed"] = exc is not None and exc[0] is not None
            if _stack:
                _stack[-1]["_child_cpu"] += r["cpu_incl_s"]
                _stack[-1]["_child_wall"] += r["wall_incl_s"]
            _records.append(r)
            # xdist workers leave through os._exit and a timed-out job is killed: neither runs atexit, so the
            # record is also written between compiles, at most every few seconds
            if not _stack and _out_dir and time.perf_counter() - _last_dump[0] > DUMP_EVERY_S:
                _dump(_out_dir[0])

    class Llvm(ev.Listener):  # LLVM's lock: optimisation passes and machine code of the kernel on top
        def on_start(self, event):
            if _llvm_depth[0] == 0:
                _llvm_depth[1] = time.process_time()
            _llvm_depth[0] += 1

        def on_end(self, event):
            _llvm_depth[0] -= 1
            if _llvm_depth[0] == 0 and _stack:
                _stack[-1]["llvm_cpu_s"] += time.process_time() - _llvm_depth[1]

    ev.register("numba:compile", Compiles())
    ev.register("numba:llvm_lock", Llvm())


def _wrap_stage(progress) -> None:
    """Record each stage of the job (``polishpath.progress.stage``: its key, start, end, CPU seconds)."""
    orig = progress.stage

    @contextlib.contextmanager
    def stage(label, timings=None, key=None):
        t, c = time.time() - _T0, time.process_time()
        try:
            with orig(label, timings, key):
                yield
        finally:
            _stages.append({"key": key or label, "start_s": t, "end_s": time.time() - _T0,
                            "cpu_s": time.process_time() - c})

    progress.stage = stage


_HOOKS = {"numba": lambda module: _register(), "polishpath.progress": _wrap_stage}


class _AfterImport:
    """A meta-path finder that runs ``_HOOKS[name](module)`` as soon as that module has run."""

    def find_spec(self, name, path=None, target=None):
        if name not in _HOOKS or name in _done:
            return None
        _done.add(name)
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        run = spec.loader.exec_module

        def exec_module(module):
            run(module)
            try:
                _HOOKS[name](module)
            except Exception as exc:  # pragma: no cover - e.g. a numba without the event API: say so
                _records.append({"error": f"probe hook for {name} failed: {exc!r}"})

        spec.loader.exec_module = exec_module
        return spec


def _census() -> list[dict]:
    disp_type = None
    if "numba" in sys.modules:
        try:
            from numba.core.dispatcher import Dispatcher as disp_type
        except ImportError:  # pragma: no cover
            return []
    if disp_type is None:
        return []
    seen: dict[str, dict] = {}
    for mod_name, mod in list(sys.modules.items()):
        if not mod_name.startswith("polishpath") or mod is None:
            continue
        for v in list(vars(mod).values()):
            if not isinstance(v, disp_type):
                continue
            name = _name(v)
            if name in seen:
                continue
            hits = sum(getattr(v, "_cache_hits", {}).values())
            misses = sum(getattr(v, "_cache_misses", {}).values())
            seen[name] = {"kernel": name, "inline": str(v.targetoptions.get("inline", "never")),
                          "cache": bool(v.targetoptions.get("cache", False)), "signatures": len(v.overloads),
                          "cache_hits": int(hits), "cache_misses": int(misses)}
    return sorted(seen.values(), key=lambda r: r["kernel"])


def _dump(out_dir: str) -> None:
    try:
        import resource

        ru = resource.getrusage(resource.RUSAGE_SELF)
        rss_mb = ru.ru_maxrss / 1024
    except Exception:  # pragma: no cover
        rss_mb = None
    doc = {"pid": os.getpid(), "argv": sys.argv, "wall_s": time.time() - _T0, "cpu_s": time.process_time() - _CPU0,
           "max_rss_mb": rss_mb, "stages": _stages, "compiles": _records, "dispatchers": _census()}
    _last_dump[0] = time.perf_counter()
    path = os.path.join(out_dir, f"probe-{os.getpid()}.json")
    with open(path + ".part", "w") as fh:
        json.dump(doc, fh)
    os.replace(path + ".part", path)


def read_probes(probe_dir: Path) -> list[dict]:
    out = []
    for p in sorted(probe_dir.glob("probe-*.json")):
        try:
            out.append(json.loads(p.read_text()))
        except (OSError, json.JSONDecodeError):  # pragma: no cover - a process killed while writing
            continue
    return out


def compile_summary(probes: list[dict]) -> dict:
    """The compile events of some processes: totals, by kernel (exclusive CPU), by subpackage, and the census."""
    recs = [r for p in probes for r in p["compiles"] if "kernel" in r]
    kernels: dict[str, dict] = {}
    for r in recs:
        k = kernels.setdefault(r["kernel"], {"kernel": r["kernel"], "compiles": 0, "cpu_excl_s": 0.0,
                                             "wall_excl_s": 0.0, "llvm_cpu_s": 0.0, "from_python": 0,
                                             "callers": set(), "at_import": 0, "sigs": set()})
        k["compiles"] += 1
        k["cpu_excl_s"] += r["cpu_excl_s"]
        k["wall_excl_s"] += r["wall_excl_s"]
        k["llvm_cpu_s"] += r["llvm_cpu_s"]
        k["from_python"] += r["parent"] is None
        k["at_import"] += r["at_import"]
        k["sigs"].add(r["sig"])
        if r["parent"] is not None:
            k["callers"].add(r["parent"])
    census: dict[str, dict] = {}
    for p in probes:
        for d in p.get("dispatchers", []):
            c = census.setdefault(d["kernel"], dict(d, cache_hits=0, cache_misses=0, signatures=0))
            c["cache_hits"] += d["cache_hits"]
            c["cache_misses"] += d["cache_misses"]
            c["signatures"] = max(c["signatures"], d["signatures"])
    for k in kernels.values():
        k["inline"] = census.get(k["kernel"], {}).get("inline", "?")
        k["callers"] = sorted(k["callers"])
        k["sigs"] = sorted(k["sigs"])
    by_sub: collections.Counter = collections.Counter()
    for k in kernels.values():
        parts = k["kernel"].split(".")
        by_sub[parts[1] if parts[0] == "polishpath" and len(parts) > 2 else parts[0]] += k["cpu_excl_s"]
    top = [r for r in recs if r["parent"] is None]
    never = sorted(n for n, c in census.items() if c["signatures"] == 0 and n not in kernels)
    loaded = sorted(n for n, c in census.items() if c["cache_hits"] and n not in kernels)
    return {"cpu_s": sum(r["cpu_excl_s"] for r in recs), "wall_s": sum(r["wall_incl_s"] for r in top),
            "llvm_cpu_s": sum(r["llvm_cpu_s"] for r in recs), "events": len(recs),
            "kernels": sorted(kernels.values(), key=lambda k: -k["cpu_excl_s"]),
            "by_subpackage_cpu_s": dict(by_sub.most_common()), "census": census,
            "never_compiled": never, "loaded_from_cache": loaded}


def stage_split(probe: dict) -> list[dict]:
    """The job process's stages (wall, CPU) with numba's compile CPU inside each, and what is outside them."""
    top = [r for r in probe["compiles"] if "kernel" in r and r["parent"] is None]
    rows = []
    for st in probe.get("stages", []):
        c = [r for r in top if st["start_s"] <= r["start_s"] < st["end_s"]]
        rows.append({"stage": st["key"], "wall_s": st["end_s"] - st["start_s"], "cpu_s": st["cpu_s"],
                     "compile_cpu_s": sum(r["cpu_incl_s"] for r in c), "kernels": len(c)})
    if probe.get("stages"):
        first = probe["stages"][0]["start_s"]
        c = [r for r in top if r["start_s"] < first]
        rows.insert(0, {"stage": "start-up (interpreter, imports, CLI)", "wall_s": first, "cpu_s": None,
                        "compile_cpu_s": sum(r["cpu_incl_s"] for r in c), "kernels": len(c)})
        last = max(st["end_s"] for st in probe["stages"])
        rows.append({"stage": "after the last stage (exit)", "wall_s": probe["wall_s"] - last, "cpu_s": None,
                     "compile_cpu_s": 0.0, "kernels": 0})
    return rows


def print_compile(c: dict, top: int) -> None:
    print(f"  numba: {c['events']} compiles, {c['cpu_s']:.1f} s CPU ({c['llvm_cpu_s']:.1f} s under LLVM's lock), "
          f"{c['wall_s']:.1f} s wall from Python's calls")
    print("    by subpackage (CPU s): " + ", ".join(f"{k} {v:.1f}" for k, v in c["by_subpackage_cpu_s"].items()))
    print(f"    {'kernel':<52} {'n':>3} {'CPU s':>6} {'LLVM':>5}  inline  asked by")
    for k in c["kernels"][:top]:
        who = "python" if k["from_python"] else ""
        if k["callers"]:
            who = (who + " + " if who else "") + ", ".join(x.rsplit(".", 1)[-1] for x in k["callers"][:3])
        name = k["kernel"].replace("polishpath.", "")
        print(f"    {name[:52]:<52} {k['compiles']:>3} {k['cpu_excl_s']:6.2f} {k['llvm_cpu_s']:5.2f}  "
              f"{k['inline'][:6]:<6}  {who[:60]}")
    rest = c["kernels"][top:]
    if rest:
        print(f"    ... {len(rest)} more kernels, {sum(k['cpu_excl_s'] for k in rest):.1f} s CPU")
    eager = [k["kernel"] for k in c["kernels"] if k["at_import"]]
    print(f"    compiled at import (eager signatures): {len(eager)} {eager[:5]}")
    print(f"    dispatchers loaded but never compiled nor called: {len(c['never_compiled'])}; "
          f"loaded from the on-disk cache: {len(c['loaded_from_cache'])}")


def install() -> None:
    """Start listening (when ``POLISHPATH_PROBE_DIR`` is set); called by the benchmark's ``sitecustomize``."""
    out_dir = os.environ.get("POLISHPATH_PROBE_DIR")
    if not out_dir:
        return
    _out_dir.append(out_dir)
    if "numba" in sys.modules:
        _done.add("numba")
        _register()
    sys.meta_path.insert(0, _AfterImport())
    atexit.register(_dump, out_dir)


if __name__ == "__main__":
    # python benchmarks/numba_probe.py PROBE_DIR [TOP]: the compile table of the processes recorded there
    _probes = read_probes(Path(sys.argv[1]))
    print_compile(compile_summary(_probes), int(sys.argv[2]) if len(sys.argv) > 2 else 30)
    for _p in _probes:
        for _row in stage_split(_p):
            _cpu = "" if _row["cpu_s"] is None else f"{_row['cpu_s']:7.1f}"
            print(f"  {_row['stage']:<38} {_row['wall_s']:7.1f} {_cpu:>7} {_row['compile_cpu_s']:7.1f} compile")
