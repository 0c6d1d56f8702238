"""Shared test fixtures.

Real meshes live in ``../shared/data/meshes`` (see its SOURCES.md). Tests that
need them use the ``shared_mesh`` fixture and skip with a clear reason where
``../shared`` is absent (a user's clone).

Also the hooks that let the suite run on several cores (``make test``: pytest-xdist);
see the end of this file.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_MESHES = Path(os.environ.get("POLISHPATH_SHARED", REPO.parent / "shared")) / "data" / "meshes"
SHARED_MEASUREMENTS = SHARED_MESHES.parent / "measurements"


def shared_mesh_path(name: str) -> Path:
    """Path of a shared mesh, or skip the test with the reason."""
    p = SHARED_MESHES / name
    if not p.exists():
        pytest.skip(f"shared mesh {name} not found at {SHARED_MESHES} (../shared is absent in a user's clone)")
    return p


def shared_measurement_path(name: str) -> Path:
    """Path of a real instrument file in ``../shared/data/measurements``, or skip the test with the reason.

    Files brought from public repositories are data of the workplace's shared folder, not of this
    repository (tests/data/measurements/SOURCES.md lists them, their sources and licences).
    """
    p = SHARED_MEASUREMENTS / name
    if not p.exists():
        pytest.skip(f"real instrument file {name} not found at {SHARED_MEASUREMENTS} (../shared is absent in a "
                    "user's clone, or does not hold it)")
    return p


@pytest.fixture
def shared_mesh():
    """``shared_mesh("lilium.obj") -> Path`` (skips when ../shared is absent)."""
    return shared_mesh_path


# --- running the suite on several cores (pytest-xdist, `make test`) ---------------------------------
#
# `make test` runs ``pytest -n auto --dist loadfile``: each test file runs whole on one worker, so a
# module-scoped fixture (a planned job, a paper run) is built once, not once per worker. (``loadgroup``
# with per-test groups would balance finer, but with pytest 9.2 xdist 3.8 silently ignores the groups:
# pytest-xdist issue 1386.) Below: numba's kernels are compiled once, before the workers start,
# instead of by every worker, and every command-line subprocess, at once on a fresh checkout.

_WARM_UP = [sys.executable, "-m", "polishpath", "plan", "hemisphere:R=12,triangles=700", "--spacing", "1",
            "--seed", "8", "--no-report", "-q", "-o"]
# the warm-up jobs run through this script, which also writes the census of the kernels' signatures that
# tests/test_kernel_signatures.py checks (when the warm-up compiled them all, as on a fresh checkout; it then
# need not compile them again on a cold cache of its own). The folder is named in POLISHPATH_WARM_UP_CENSUS.
_CENSUS_SCRIPT = Path(__file__).resolve().parent / "_kernel_census.py"
# The same job with the raster pattern, at the same time on the second core (which idles while the
# first job compiles, one kernel after another): it is through the planner in a few seconds and
# compiles the smoothing, metrics and writer kernels while the first is still in the pseudo-random
# planner's, which then loads them from the cache. Measured on a cold cache (docs/performance.md,
# CPU seconds): the first job's compile 81 -> 60 s, the second's 65 s on the other core.
_WARM_UP_SECOND = [*_WARM_UP[:-3], "--pattern", "raster", *_WARM_UP[-3:]]

# wall seconds of the warm-up jobs (empty when they did not run), said in pytest's summary: pytest's own
# "in N s" starts after them (benchmarks/bench_first_run.py reads the line)
_WARM_UP_SECONDS: list[float] = []


def _workers(config: pytest.Config) -> int:
    """How many xdist workers this run starts (0 in one process, and inside a worker)."""
    if hasattr(config, "workerinput"):
        return 0
    n = getattr(config.option, "numprocesses", None)
    return n if isinstance(n, int) else 0


@pytest.hookimpl(tryfirst=True)
def pytest_sessionstart(session: pytest.Session) -> None:
    """Before xdist starts its workers: two small jobs, one per core, compile (or load) numba's on-disk cache.

    Without them every worker compiles the same kernels at the same time on a fresh checkout (about a
    minute of CPU each), and so does every command-line subprocess a test starts meanwhile. The jobs
    run in subprocesses with this checkout's sources first, so they warm the cache the tests use. A
    failure here only skips the warm-up: the tests that run the same code report it.
    """
    if _workers(session.config) < 2 or session.config.option.collectonly:
        return
    env = dict(os.environ, PYTHONPATH=str(REPO / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""))
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="polishpath-warm-up-") as d:
        census = Path(tempfile.mkdtemp(prefix="polishpath-warm-up-census-"))
        os.environ["POLISHPATH_WARM_UP_CENSUS"] = str(census)  # before the workers start: they inherit it
        jobs = [subprocess.Popen([sys.executable, str(_CENSUS_SCRIPT), str(census / f"census{i}.json"), *cmd[3:],
                                  str(Path(d) / f"out{i}")], stdout=subprocess.DEVNULL,
                                 stderr=subprocess.PIPE, text=True, env=env)
                for i, cmd in enumerate((_WARM_UP, _WARM_UP_SECOND))]
        for job in jobs:
            try:
                _, err = job.communicate(timeout=max(1.0, 900 - (time.perf_counter() - t0)))
            except subprocess.TimeoutExpired:
                job.kill()
                job.communicate()
                print("\nnote: a numba warm-up job took over 900 s; the workers compile what it missed",
                      file=sys.stderr)
                continue
            if job.returncode != 0:
                print(f"\nnote: a numba warm-up job failed (exit {job.returncode}); the tests will say why\n"
                      f"{err[-2000:]}", file=sys.stderr)
    _WARM_UP_SECONDS.append(time.perf_counter() - t0)


def pytest_terminal_summary(terminalreporter, exitstatus, config) -> None:
    """Say how long the numba warm-up jobs took before the workers started (not in pytest's "in N s")."""
    if _WARM_UP_SECONDS:
        terminalreporter.write_line(f"numba warm-up jobs before the workers: {_WARM_UP_SECONDS[0]:.1f} s")


def pytest_unconfigure(config) -> None:
    """The warm-up jobs' census folder goes when the run that made it ends (not in a worker)."""
    census = os.environ.get("POLISHPATH_WARM_UP_CENSUS")
    if census and not hasattr(config, "workerinput") and _WARM_UP_SECONDS:
        import shutil

        shutil.rmtree(census, ignore_errors=True)
