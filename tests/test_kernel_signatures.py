"""Each numba kernel compiled once per argument type a job really passes, not once per literal (issue 29).

numba compiles a kernel called from another kernel once for every distinct argument *type* its caller's type
inference sees; a literal (``0``, ``-1``, ``LINE``) is its own type, ``Literal[int](0)``, until a loop's phi
widens the variable to ``int64``. So ``s = 0 ... _farthest(s, ...)`` compiled ``export.blockfit._farthest``
four times on a fresh checkout (15 s of the first run's compile: docs/performance.md). The callers now pass
int64 from the start; this test keeps it so: a small job on a cold cache (an empty ``NUMBA_CACHE_DIR``:
loaded from a warm cache, a caller brings its callees' code with it and their dispatchers stay empty) in a
subprocess, then a census of every polishpath dispatcher's signatures. Not a timed test: it counts compiles.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

_JOB = ["plan", "hemisphere:R=12,triangles=700", "--spacing", "1", "--seed", "8", "--no-report", "-q"]

_CENSUS_SCRIPT = Path(__file__).resolve().parent / "_kernel_census.py"

# kernels that were compiled more than once for literal arguments, and must hold one signature after the job
ONE_SIGNATURE = [
    "polishpath.export.blockfit.segment_intervals",
    "polishpath.export.blockfit._farthest",
    "polishpath.export.blockfit._written_arc",
    "polishpath.export.blockfit._circle",
    "polishpath.export.blockfit._seg_dist",
    "polishpath.export.blockfit._span",
    "polishpath.export.blockfit._helix_dist",
    "polishpath.plan._walk.walk",
    "polishpath.plan._endgame.finish_component",
    "polishpath.plan._endgame._splice_loop",
]


def _merged(files: list[Path]) -> dict[str, dict]:
    """The census of several processes: each kernel's signatures (union, in order) and compile counts summed."""
    out: dict[str, dict] = {}
    for f in files:
        for name, c in json.loads(f.read_text()).items():
            m = out.setdefault(name, {"signatures": [], "compiled": 0, "loaded": 0})
            m["signatures"] += [s for s in c["signatures"] if s not in m["signatures"]]
            m["compiled"] += c["compiled"]
            m["loaded"] += c["loaded"]
    return out


def _complete(census: dict[str, dict]) -> bool:
    """Whether every kernel that holds a signature was compiled in these processes (none came only from a warm
    cache, which brings a kernel's callees inside its own code and leaves their signatures unseen)."""
    used = {k: c for k, c in census.items() if c["signatures"]}
    return all(census.get(k, {}).get("signatures") for k in ONE_SIGNATURE) and all(c["compiled"] for c in used.values())


@pytest.fixture(scope="module")
def signatures(tmp_path_factory) -> dict[str, list[str]]:
    """Signatures per kernel after the small job on a cold cache: the conftest's warm-up jobs' census when they
    compiled everything (a fresh checkout's ``make test``), else the job run here on an empty cache."""
    warm_up = os.environ.get("POLISHPATH_WARM_UP_CENSUS")
    files = sorted(Path(warm_up).glob("census*.json")) if warm_up else []
    if files:
        census = _merged(files)
        if _complete(census):
            return {k: c["signatures"] for k, c in census.items()}
    d = tmp_path_factory.mktemp("kernel-signatures")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(d / "numba-cache"),
               PYTHONPATH=str(REPO / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""),
               # the signatures do not depend on LLVM's optimisation level; -O0 compiles faster
               NUMBA_OPT="0")
    out = d / "census.json"
    r = subprocess.run([sys.executable, str(_CENSUS_SCRIPT), str(out), *_JOB, "-o", str(d / "job")], env=env,
                       capture_output=True, text=True, timeout=1800)
    assert r.returncode == 0, r.stderr[-3000:]
    census = _merged([out])
    assert _complete(census), "the job on an empty cache loaded kernels it did not compile"
    return {k: c["signatures"] for k, c in census.items()}


@pytest.mark.slow
def test_the_job_compiled_its_kernels(signatures):
    """The census saw the job's kernels compiled (else the checks below would pass on nothing)."""
    compiled = [k for k, s in signatures.items() if s]
    assert len(compiled) >= 50, compiled
    for name in ONE_SIGNATURE:
        assert signatures.get(name), f"{name} was not compiled by the small job (renamed? then update this list)"


@pytest.mark.slow
@pytest.mark.parametrize("name", ONE_SIGNATURE)
def test_kernel_compiled_once(signatures, name):
    assert len(signatures[name]) == 1, f"{name} compiled {len(signatures[name])} times: {signatures[name]}"


def _widened(sig: str) -> str:
    """A signature with every literal int replaced by int64 (``Literal[int](0)`` -> ``int64``). Literal bools are
    left: a kernel specialised for ``True`` and ``False`` (``plan._steps.mark_step``) is two kernels on purpose."""
    return re.sub(r"Literal\[int\]\(-?\d+\)", "int64", sig)


@pytest.mark.slow
def test_no_kernel_compiled_again_for_a_literal(signatures):
    """No polishpath kernel holds two signatures that are the same once literals are widened: a caller passed a
    literal where another call (or the same call, once its loop widened the variable) passed int64. Fix: pass
    ``np.int64(...)`` (a single literal call site compiles once and is left alone)."""
    again = {}
    for name, sigs in signatures.items():
        widened = [_widened(s) for s in sigs]
        dup = [s for s, w in zip(sigs, widened) if widened.count(w) > 1]
        if dup:
            again[name] = dup
    assert not again, json.dumps(again, indent=1)
