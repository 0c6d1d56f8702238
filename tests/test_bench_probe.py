"""benchmarks/numba_probe.py: the per-kernel compile figures that docs/performance.md quotes.

One child process compiles a kernel that calls another (and, through a literal argument, a second variant
of it) with a cold cache; the probe's record must name each compile, who asked for it, and split the CPU
seconds so that a caller's exclusive time leaves its callees' out.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BENCH = REPO / "benchmarks"

_CHILD = textwrap.dedent("""
    import numba

    @numba.njit
    def callee(x, k):
        s = 0.0
        for i in range(k):
            s += x * i
        return s

    @numba.njit
    def caller(x, k):
        j = 0
        for i in range(k):
            j = i
        return callee(x, k) + callee(x, j)

    print(caller(1.5, 4))
""")


def test_probe_records_each_compile_with_its_caller_and_exclusive_time(tmp_path):
    site = tmp_path / "site"
    site.mkdir()
    (site / "sitecustomize.py").write_text(
        f"import sys\nsys.path.insert(0, {str(BENCH)!r})\nimport numba_probe\nnumba_probe.install()\n")
    probes = tmp_path / "probes"
    probes.mkdir()
    env = dict(os.environ, PYTHONPATH=str(site), POLISHPATH_PROBE_DIR=str(probes),
               NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    r = subprocess.run([sys.executable, "-c", _CHILD], env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "13.5"

    sys.path.insert(0, str(BENCH))
    try:
        import numba_probe
    finally:
        sys.path.remove(str(BENCH))
    recs = numba_probe.read_probes(probes)
    assert len(recs) == 1
    compiles = {(c["kernel"].rsplit(".", 1)[-1], c["parent"] and c["parent"].rsplit(".", 1)[-1]): c
                for c in recs[0]["compiles"] if c["kernel"].startswith("__main__")}
    assert ("caller", None) in compiles and ("callee", "__main__.caller".rsplit(".", 1)[-1]) in compiles
    top = compiles[("caller", None)]
    inner = [c for c in recs[0]["compiles"] if c["parent"] == top["kernel"]]
    assert inner, "the callee's compile is not attributed to its caller"
    # the caller's exclusive CPU is its inclusive CPU less its direct callees' inclusive CPU
    assert abs(top["cpu_excl_s"] - (top["cpu_incl_s"] - sum(c["cpu_incl_s"] for c in inner))) < 1e-6
    assert 0 <= top["cpu_excl_s"] < top["cpu_incl_s"]
    summary = numba_probe.compile_summary(recs)
    by_name = {k["kernel"]: k for k in summary["kernels"]}
    assert by_name["__main__.callee"]["callers"] == ["__main__.caller"]
    assert by_name["__main__.caller"]["from_python"] == 1
    assert abs(summary["cpu_s"] - sum(c["cpu_excl_s"] for c in recs[0]["compiles"])) < 1e-6
