"""The Python API mirrors the command line: polishpath.run(...) -> polishpath.Job with the stages' results and .save();
polishpath.plan is only the planning stage."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

import polishpath
from polishpath.types import Flattening, PlanarPath, Surface, SurfacePath, ToolPath


def test_run_api_runs_the_job_and_saves(tmp_path):
    job = polishpath.run(surface="hemisphere:R=12,triangles=700", spacing=1.0, seed=8, report=False)
    assert isinstance(job, polishpath.Job)
    assert isinstance(job.surface, Surface) and isinstance(job.flattening, Flattening)
    assert isinstance(job.planar, PlanarPath) and isinstance(job.surface_path, SurfacePath)
    assert isinstance(job.tool_path, ToolPath)
    assert job.seed == 8
    written = job.save(tmp_path)
    for key in ("path_csv", "toolpath_xyz", "gcode", "summary", "job"):
        assert written[key].exists()
    # the API and the command line give the same path for the same options
    out = tmp_path / "cli"
    r = subprocess.run([sys.executable, "-m", "polishpath", "plan", "hemisphere:R=12,triangles=700", "--spacing", "1",
                        "--seed", "8", "-o", str(out), "--no-report"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert (out / "path.csv").read_bytes() == written["path_csv"].read_bytes()


def test_plan_is_only_the_planning_stage():
    import types

    from polishpath.types import Region

    assert isinstance(polishpath.plan, types.ModuleType) and not callable(polishpath.plan)
    t = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    p = polishpath.plan.plan(Region(np.c_[5 * np.cos(t), 5 * np.sin(t)]), 1.0, seed=1)
    assert p.n_points > 50


def test_job_classes_are_the_pipelines():
    from polishpath import pipeline

    assert polishpath.Job is pipeline.Job and polishpath.JobConfig is pipeline.JobConfig


def test_import_is_light():
    r = subprocess.run([sys.executable, "-c", "import polishpath, sys; print('numba' in sys.modules)"],
                       capture_output=True, text=True)
    assert r.stdout.strip() == "False"
