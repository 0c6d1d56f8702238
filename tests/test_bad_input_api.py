"""Every public function of the wiring, mapping, flattening and run-folder modules that takes user input
raises a PolishPathError subclass (never a bare ValueError / RuntimeError) on bad input."""

from __future__ import annotations

import io

import numpy as np
import pytest

from polishpath.config import parse_job
from polishpath.errors import PolishPathError
from polishpath.flatten import boundary_region, flatten, load_obj_uv
from polishpath.mapping import locate_points, map_to_surface, planar_spacing_for_surface
from polishpath.pipeline import plan_on_surface
from polishpath.provenance import resolve_seed
from polishpath.runfolder import read_run, read_toml
from polishpath.surfaces import load_surface
from polishpath.types import PlanarPath


@pytest.fixture(scope="module")
def flat():
    return flatten(load_surface("hemisphere:R=10,triangles=400"), "mabf")


CASES = {
    "flatten: unknown method": lambda f: flatten(f.surface, "conformal"),
    "flatten: unknown layout": lambda f: flatten(f.surface, "mabf", layout="spring"),
    "flatten: unknown option": lambda f: flatten(f.surface, "mabf", speed=3),
    "flatten: projection with options": lambda f: flatten(f.surface, "projection", tol=1e-3),
    "plan_on_surface: spacing_on": lambda f: plan_on_surface(f, boundary_region(f), 1.0, seed=0, spacing_on="x"),
    "plan_on_surface: negative spacing": lambda f: plan_on_surface(f, boundary_region(f), -1.0, seed=0),
    "plan_on_surface: NaN spacing": lambda f: plan_on_surface(f, boundary_region(f), float("nan"), seed=0),
    "plan_on_surface: bad seed": lambda f: plan_on_surface(f, boundary_region(f), 1.0, seed=-3),
    "plan_on_surface: huge spacing": lambda f: plan_on_surface(f, boundary_region(f), 1e4, seed=0, spacing_on="plane"),
    "plan_on_surface: unknown pattern": lambda f: plan_on_surface(f, boundary_region(f), 1.0, seed=0, pattern="zigzag"),
    "map_to_surface: points outside": lambda f: map_to_surface(f, PlanarPath(np.array([[1e3, 1e3]]), np.zeros((1, 2)), 1.0)),
    "map_to_surface: no points": lambda f: map_to_surface(f, PlanarPath(np.zeros((0, 2)), np.zeros((0, 2)), 1.0)),
    "planar_spacing_for_surface: spacing": lambda f: planar_spacing_for_surface(f, 0.0),
    "planar_spacing_for_surface: factor": lambda f: planar_spacing_for_surface(f, 1.0, max_step_factor=-1),
    "locate_points: no triangles": lambda f: locate_points(f.uv, np.zeros((0, 3), int), np.zeros((1, 2))),
    "parse_job: unknown option": lambda f: parse_job(spacnig=1.0),
    "parse_job: wrong type": lambda f: parse_job(margin="wide"),
    "resolve_seed: float": lambda f: resolve_seed(2.5),
    "read_run: missing folder": lambda f: read_run("/nonexistent/run"),
    "read_toml: missing file": lambda f: read_toml("/nonexistent/job.toml"),
    "load_obj_uv: mismatched indices": lambda f: load_obj_uv(io.StringIO("v 0 0 0\nvt 0 0\nf 1/2 1/2 1/2\n")),
    "load_obj_uv: not a number": lambda f: load_obj_uv(io.StringIO("v zero 0 0\n")),
}


@pytest.mark.parametrize("name", list(CASES))
def test_bad_input_is_a_polishpath_error(flat, name):
    with pytest.raises(PolishPathError) as e:
        CASES[name](flat)
    assert str(e.value).strip(), "the error has no message"
