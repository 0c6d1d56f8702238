"""CAD-style tessellations made fit for flattening, with the surface kept exactly (issue 14, item 3)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from polishpath import meshops
from polishpath.errors import ParameterError
from polishpath.surfaces import from_arrays, load_surface
from polishpath.surfaces.remesh import fit_for_flattening, parse_remesh, refine_exact, sliver_report

REPO = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(REPO / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")}
R, ARC, LENGTH, STRIPS = 30.0, 30.0, 30.0, 300


def strip_cylinder(n=STRIPS):
    """A 30 x 30 mm patch of a radius-30 cylinder as a CAD exporter writes it: n full-length strips (300:1 triangles)."""
    t = np.linspace(0.0, ARC / R, n + 1)
    bottom = np.c_[R * np.sin(t), np.zeros(n + 1), R * np.cos(t)]
    v = np.vstack([bottom, bottom + [0.0, LENGTH, 0.0]])
    f = [[i, i + 1, n + 2 + i] for i in range(n)] + [[i, n + 2 + i, n + 1 + i] for i in range(n)]
    return v, np.array(f)


def _extent(uv):
    c = uv - uv.mean(axis=0)
    _, U = np.linalg.eigh(c.T @ c)
    p = c @ U
    return np.sort(p.max(axis=0) - p.min(axis=0))


def test_strip_cylinder_is_detected_and_flattens_to_its_true_size():
    from polishpath.flatten import flatten

    s0 = from_arrays(*strip_cylinder())
    rep = sliver_report(s0)
    assert rep["sliver_area_share"] == pytest.approx(1.0) and rep["min_angle_deg"] < 0.2
    bad = _extent(flatten(s0, "mabf").uv)
    assert abs(bad[0] - 30) > 3 or abs(bad[1] - 30) > 3, bad  # without the remesh it is far off (16 x 59 mm)
    s = fit_for_flattening(s0, "auto")
    info = s.params["remesh"]
    assert info["applied"] and info["mode"] == "auto" and info["faces_before"] == 600 and info["faces_after"] > 600
    assert any(x.code == "remeshed" for x in s.findings)
    size = _extent(flatten(s, "mabf").uv)
    np.testing.assert_allclose(size, [30.0, 30.0], rtol=0.01)


def test_refinement_keeps_the_surface_exactly():
    v0, f0 = strip_cylinder()
    v, f = refine_exact(v0, f0, 2.0)
    assert meshops.surface_area(v, f) == pytest.approx(meshops.surface_area(v0, f0), rel=1e-12)
    assert len(meshops.boundary_loops(f)) == 1
    lb = lambda vv, ff: sum(np.linalg.norm(vv[lp] - vv[np.roll(lp, -1)], axis=1).sum() for lp in meshops.boundary_loops(ff))
    assert lb(v, f) == pytest.approx(lb(v0, f0), rel=1e-12)
    # every vertex lies on the chord plane of the strip it falls in (the polyhedral surface, not the cylinder)
    phi = np.arctan2(v[:, 0], v[:, 2])
    t = np.linspace(0.0, ARC / R, STRIPS + 1)
    i = np.clip(np.searchsorted(t, phi) - 1, 0, STRIPS - 1)
    a = np.c_[R * np.sin(t[i]), R * np.cos(t[i])]
    b = np.c_[R * np.sin(t[i + 1]), R * np.cos(t[i + 1])]
    d = b - a
    p = np.c_[v[:, 0], v[:, 2]] - a
    dist = np.abs(d[:, 0] * p[:, 1] - d[:, 1] * p[:, 0]) / np.linalg.norm(d, axis=1)
    assert dist.max() < 1e-9, dist.max()
    # orientation kept: normals point the same way as the strips'
    cr = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    cr0 = np.cross(v0[f0[:, 1]] - v0[f0[:, 0]], v0[f0[:, 2]] - v0[f0[:, 0]]).sum(axis=0)
    assert np.all(cr @ cr0 > 0)
    # edges between facets no longer than asked; inside a strip, a diagonal of a 2 x 0.1 mm cell
    el = np.linalg.norm(v[f] - v[np.roll(f, -1, axis=1)], axis=2)
    assert el.max() <= np.hypot(2.0, ARC / STRIPS) * (1 + 1e-9)


def test_planar_facet_with_a_hole_keeps_the_hole():
    import triangle as tr

    outer = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    hole = np.array([[4, 4], [6, 4], [6, 6], [4, 6]], float)
    pts = np.vstack([outer, hole])
    seg = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4]])
    res = tr.triangulate({"vertices": pts, "segments": seg, "holes": [[5.0, 5.0]]}, "p")
    v0 = np.c_[res["vertices"], np.zeros(len(res["vertices"]))]
    f0 = np.asarray(res["triangles"])
    v, f = refine_exact(v0, f0, 0.5)
    assert meshops.surface_area(v, f) == pytest.approx(96.0, rel=1e-12)
    assert len(meshops.boundary_loops(f)) == 2
    c = v[f].mean(axis=1)
    assert not np.any((np.abs(c[:, 0] - 5) < 1) & (np.abs(c[:, 1] - 5) < 1))


@pytest.mark.parametrize("spec", ["hemisphere:R=12,triangles=700", "saddle:triangles=800", "bicycle-seat:triangles=800"])
def test_auto_leaves_good_meshes_alone(spec):
    s = load_surface(spec)
    assert fit_for_flattening(s, "auto") is s


def test_shared_meshes_are_left_alone(shared_mesh):
    for name in ("lilium.obj", "lion.off", "camelhead.off"):
        s = load_surface(shared_mesh(name), component="largest")
        assert fit_for_flattening(s, "auto") is s, name


def test_explicit_edge_refines_and_off_keeps():
    s = load_surface("hemisphere:R=12,triangles=700")
    assert fit_for_flattening(s, "off") is s
    r = fit_for_flattening(s, 0.4)
    assert r.params["remesh"]["mode"] == "edge" and r.n_faces > s.n_faces
    assert meshops.surface_area(r.vertices, r.faces) == pytest.approx(meshops.surface_area(s.vertices, s.faces), rel=1e-9)


@pytest.mark.parametrize("bad", ["sometimes", "-1", "0", "nan", "inf"])
def test_bad_remesh_value_refused(bad):
    with pytest.raises(ParameterError, match="auto, off or an edge length"):
        parse_remesh(bad)


def test_too_fine_edge_refused():
    s = load_surface("hemisphere:R=12,triangles=700")
    with pytest.raises(ParameterError, match="more than"):
        fit_for_flattening(s, 0.001)


def _write_obj(path: Path, v, f):
    path.write_text("".join(f"v {x:.17g} {y:.17g} {z:.17g}\n" for x, y, z in v)
                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f))


def test_flatten_command_remeshes_and_reports(tmp_path):
    p = tmp_path / "strips.obj"
    _write_obj(p, *strip_cylinder())
    r = subprocess.run([sys.executable, "-m", "polishpath", "flatten", str(p), "--json", "-o", str(tmp_path / "flat.obj")],
                       capture_output=True, text=True, env=ENV, timeout=300)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["remesh"]["applied"] and d["remesh"]["faces_before"] == 600
    assert d["metrics"]["conformal_ratio_mean"] < 1.01
    assert "warning" not in r.stderr
    # off: the strips flatten badly, and the user is told
    r = subprocess.run([sys.executable, "-m", "polishpath", "flatten", str(p), "--remesh", "off", "--json"],
                       capture_output=True, text=True, env=ENV, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "polishpath: warning:" in r.stderr and "conformal" in r.stderr and "--remesh" in r.stderr
    assert json.loads(r.stdout)["remesh"]["applied"] is False
    r = subprocess.run([sys.executable, "-m", "polishpath", "flatten", str(p), "--remesh", "sometimes"],
                       capture_output=True, text=True, env=ENV, timeout=300)
    assert r.returncode == 2 and "Traceback" not in r.stderr and "auto, off or an edge length" in r.stderr


def test_plan_summary_records_the_remesh(tmp_path):
    p = tmp_path / "strips.obj"
    _write_obj(p, *strip_cylinder())
    out = tmp_path / "run"
    r = subprocess.run([sys.executable, "-m", "polishpath", "plan", str(p), "--spacing", "2", "--seed", "1", "--no-report",
                        "-q", "-o", str(out)], capture_output=True, text=True, env=ENV, timeout=600)
    assert r.returncode == 0, r.stderr
    s = json.loads((out / "summary.json").read_text())
    assert s["surface"]["remesh"]["applied"] is True and s["config"]["remesh"] == "auto"
    assert s["flattening"]["metrics"]["conformal_ratio_mean"] < 1.01
