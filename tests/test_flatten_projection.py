"""The projection baseline is a flattening method like mabf / abf / lscm (no caller special-cases it)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from polishpath.cli import app
from polishpath.errors import ParameterError
from polishpath.flatten import METHODS, flatten
from polishpath.surfaces import load_surface

SMALL = "hemisphere:R=10,triangles=600"


def test_projection_is_listed_and_reached_through_flatten():
    assert "projection" in METHODS
    s = load_surface(SMALL)
    pf = flatten(s, "projection")
    assert pf.provenance.stage == "flatten" and pf.provenance.method == "projection"
    n = np.asarray(pf.provenance.params["plane_normal"])
    # orthogonal projection: moving a vertex along the plane normal does not move its planar point
    axes = np.asarray(pf.provenance.params["plane_axes"])
    origin = np.asarray(pf.provenance.params["plane_origin"])
    np.testing.assert_allclose(pf.uv, (s.vertices - origin) @ axes.T, atol=1e-9)
    np.testing.assert_allclose(axes @ n, 0, atol=1e-12)
    # a hemisphere seen from above projects onto a disc of its diameter; only rim triangles fold
    np.testing.assert_allclose(np.ptp(pf.uv, axis=0), 20, rtol=1e-2)
    assert pf.metrics["folded_triangles"] < 0.05 * s.n_faces


def test_projection_takes_no_layout_or_option():
    s = load_surface(SMALL)
    with pytest.raises(ParameterError, match="projection"):
        flatten(s, "projection", layout="midpoint")
    with pytest.raises(ParameterError, match="projection"):
        flatten(s, "projection", tol=1e-6)
    with pytest.raises(ParameterError, match="projection"):
        flatten(s, "conformal")  # the unknown-method message lists it


def test_flatten_command_with_projection(tmp_path):
    r = CliRunner().invoke(app, ["flatten", SMALL, "--method", "projection", "--json", "-o", str(tmp_path / "f.obj")])
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    assert d["method"] == "projection" and "folded_triangles" in d["metrics"]
    assert (tmp_path / "f.obj").stat().st_size > 0
