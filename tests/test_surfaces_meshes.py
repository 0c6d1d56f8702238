"""Mesh files in: formats, units, every bad input named, repairs reported, the shared real meshes."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import trimesh
from typer.testing import CliRunner

from polishpath import meshops
from polishpath.cli import app
from polishpath.errors import (
    ClosedMeshError,
    MeshFileError,
    MultipleComponentsError,
    NonFiniteError,
    NonManifoldError,
    PolishPathError,
)
from polishpath.surfaces import describe_surface, from_arrays, load_surface

runner = CliRunner()


def grid_patch(n=6, size=10.0, z=lambda x, y: 0.02 * (x * x + y * y)):
    """An open, curved, consistently oriented grid patch: (V, 3), (F, 3)."""
    g = np.linspace(-size / 2, size / 2, n)
    X, Y = np.meshgrid(g, g, indexing="ij")
    v = np.c_[X.ravel(), Y.ravel(), z(X.ravel(), Y.ravel())]
    f = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1
            f += [[a, b, c], [a, c, d]]
    return v, np.array(f)


def write_obj(path, v, f):
    with open(path, "w") as fh:
        for p in v:
            fh.write("v " + " ".join(repr(float(c)) for c in p) + "\n")
        for t in f:
            fh.write("f " + " ".join(str(int(i) + 1) for i in t) + "\n")
    return path


# --- formats and units -------------------------------------------------------------


@pytest.mark.parametrize("ext", ["stl", "obj", "ply", "off"])
def test_formats_round_trip(tmp_path, ext):
    v, f = grid_patch()
    p = tmp_path / f"patch.{ext}"
    trimesh.Trimesh(v, f, process=False).export(p)
    s = load_surface(p)
    assert s.n_faces == len(f)
    assert s.n_vertices == len(v)  # STL stores corners per face: duplicates must be merged back
    np.testing.assert_allclose(meshops.surface_area(s.vertices, s.faces), meshops.surface_area(v, f), rtol=1e-6)


def test_ascii_and_binary_stl(tmp_path):
    v, f = grid_patch()
    m = trimesh.Trimesh(v, f, process=False)
    (tmp_path / "a.stl").write_bytes(trimesh.exchange.stl.export_stl_ascii(m).encode())
    (tmp_path / "b.stl").write_bytes(trimesh.exchange.stl.export_stl(m))
    assert (tmp_path / "a.stl").read_bytes()[:5] == b"solid"
    for name in ("a.stl", "b.stl"):
        s = load_surface(tmp_path / name)
        assert s.n_faces == len(f) and s.n_vertices == len(v)


@pytest.mark.parametrize("units, factor", [("m", 1000.0), ("in", 25.4), ("mm", 1.0), ("cm", 10.0)])
def test_units_scale_to_mm(tmp_path, units, factor):
    v, f = grid_patch()
    p = write_obj(tmp_path / "p.obj", v, f)
    s = load_surface(p, units=units)
    np.testing.assert_allclose(np.ptp(s.vertices[:, 0]), 10.0 * factor)
    s2 = load_surface(p, scale=2.0)
    np.testing.assert_allclose(np.ptp(s2.vertices[:, 0]), 20.0)


# --- repairs, reported ----------------------------------------------------------


def codes(s):
    return {x.code: x for x in s.findings}


def test_duplicate_vertices_are_merged_and_reported():
    v, f = grid_patch()
    v2 = np.vstack([v, v[7:9]])  # two copies
    f2 = f.copy()
    f2[f2 == 7] = len(v)
    f2[f2 == 8] = len(v) + 1
    s = from_arrays(v2, f2)
    c = codes(s)
    assert c["duplicate_vertices"].count == 2 and c["duplicate_vertices"].repaired
    assert s.n_vertices == len(v)


def test_unreferenced_vertices_are_dropped_and_reported():
    v, f = grid_patch()
    s = from_arrays(np.vstack([v, [[100, 100, 100], [200, 0, 0]]]), f)
    assert codes(s)["unreferenced_vertices"].count == 2
    assert s.n_vertices == len(v)


def test_zero_area_faces_are_repaired_and_reported():
    v, f = grid_patch()
    # a needle: vertex 7 moved onto vertex 8 makes faces around that edge zero-area
    v2 = v.copy()
    v2[7] = v2[8] + 1e-15
    s = from_arrays(v2, f)
    c = codes(s)
    assert "degenerate_faces" in c and c["degenerate_faces"].count >= 1
    assert meshops.face_areas(s.vertices, s.faces).min() > 0
    assert len(meshops.boundary_loops(s.faces)) == 1


def test_inconsistent_orientation_is_repaired_and_reported():
    v, f = grid_patch()
    f2 = f.copy()
    f2[[3, 10, 11]] = f2[[3, 10, 11]][:, ::-1]
    s = from_arrays(v, f2)
    assert codes(s)["orientation"].count == 3
    fn = meshops.face_normals(s.vertices, s.faces)
    assert np.all(fn[:, 2] > 0) or np.all(fn[:, 2] < 0)


def test_several_components_refused_or_largest_kept():
    v, f = grid_patch()
    v2 = np.vstack([v, [[50, 50, 0], [51, 50, 0], [50, 51, 0]]])
    f2 = np.vstack([f, [[len(v), len(v) + 1, len(v) + 2]]])
    with pytest.raises(MultipleComponentsError, match="2 separate pieces.*--component largest"):
        from_arrays(v2, f2)
    s = from_arrays(v2, f2, component="largest")
    assert s.n_faces == len(f)
    assert codes(s)["components"].count == 1


# --- refusals, named ---------------------------------------------------------------


def test_nan_refused():
    v, f = grid_patch()
    v[4, 1] = np.nan
    with pytest.raises(NonFiniteError, match="1 vertices with NaN"):
        from_arrays(v, f)


def test_non_manifold_edge_refused():
    v, f = grid_patch()
    a, b = f[0, 0], f[0, 2]  # the diagonal, shared by faces 0 and 1
    v2 = np.vstack([v, [[0, 0, 30.0]]])
    f2 = np.vstack([f, [[a, b, len(v)]]])  # a third face on edge (a, b)
    with pytest.raises(NonManifoldError, match=r"1 non-manifold edges.*at \("):
        from_arrays(v2, f2)


def test_non_manifold_vertex_refused():
    v, f = grid_patch(n=3)
    corner = 8  # (+x, +y) corner of the patch
    v2 = np.vstack([v, [[20, 10, 0], [10, 20, 0]]])
    f2 = np.vstack([f, [[corner, len(v), len(v) + 1]]])  # touches only at one vertex
    with pytest.raises(NonManifoldError, match="1 non-manifold vertices"):
        from_arrays(v2, f2)


def test_closed_mesh_refused():
    m = trimesh.creation.icosphere(2)
    with pytest.raises(ClosedMeshError, match="closed.*Cut the part"):
        from_arrays(m.vertices, m.faces)


def test_empty_and_unreadable_and_unknown(tmp_path):
    (tmp_path / "empty.stl").write_bytes(b"")
    with pytest.raises(MeshFileError, match="empty"):
        load_surface(tmp_path / "empty.stl")
    (tmp_path / "junk.ply").write_bytes(b"this is not a ply file\x00\x01")
    with pytest.raises(MeshFileError):
        load_surface(tmp_path / "junk.ply")
    (tmp_path / "part.step").write_text("ISO-10303-21;")
    with pytest.raises(MeshFileError, match="unknown mesh format '.step'"):
        load_surface(tmp_path / "part.step")
    with pytest.raises(MeshFileError, match="does not exist"):
        load_surface(tmp_path / "missing.obj")


def bad_files(tmp_path):
    """Each bad input as a file, with words its message must contain."""
    out = []
    (tmp_path / "empty.stl").write_bytes(b"")
    out.append((tmp_path / "empty.stl", "empty"))
    (tmp_path / "junk.off").write_text("OFF\n3 1 0\n0 0 0\n")
    out.append((tmp_path / "junk.off", "junk.off"))
    (tmp_path / "part.step").write_text("x")
    out.append((tmp_path / "part.step", "unknown mesh format"))
    v, f = grid_patch()
    v[3, 0] = np.nan
    out.append((write_obj(tmp_path / "nan.obj", v, f), "NaN"))
    v, f = grid_patch()
    out.append((write_obj(tmp_path / "nme.obj", np.vstack([v, [[0, 0, 9]]]), np.vstack([f, [[f[0, 0], f[0, 2], len(v)]]])), "non-manifold edges"))
    m = trimesh.creation.icosphere(1)
    out.append((write_obj(tmp_path / "closed.obj", m.vertices, m.faces), "closed"))
    v2 = np.vstack([v, [[50, 50, 0], [51, 50, 0], [50, 51, 0]]])
    out.append((write_obj(tmp_path / "two.obj", v2, np.vstack([f, [[len(v), len(v) + 1, len(v) + 2]]])), "separate pieces"))
    return out


def test_bad_files_through_the_command_line(tmp_path):
    for path, words in bad_files(tmp_path):
        for cmd in (["info", str(path)], ["info", str(path), "--json"]):
            r = runner.invoke(app, cmd)
            assert r.exit_code == 2, (path, r.output)
            assert words in r.output, (path, r.output)
            assert "Traceback" not in r.output
            assert isinstance(r.exception, SystemExit)


def test_bad_file_real_process_no_traceback(tmp_path):
    m = trimesh.creation.icosphere(1)
    p = write_obj(tmp_path / "closed.obj", m.vertices, m.faces)
    r = subprocess.run([sys.executable, "-m", "polishpath", "info", str(p)], capture_output=True, text=True)
    assert r.returncode == 2
    assert "closed" in r.stderr and "Traceback" not in r.stderr + r.stdout


def test_errors_share_one_base_class():
    for cls in (MeshFileError, NonFiniteError, NonManifoldError, ClosedMeshError, MultipleComponentsError):
        assert issubclass(cls, PolishPathError)


# --- the shared real meshes -------------------------------------------------------


@pytest.mark.parametrize(
    "name, loops",
    [("camelhead.off", 1), ("beetle.off", 11), ("stanford-bunny.obj", 5), ("lilium.obj", 1), ("face.obj", 1), ("lion.off", 1)],
)
def test_shared_meshes_load_with_their_boundary_loops(shared_mesh, name, loops):
    s = load_surface(shared_mesh(name))
    d = describe_surface(s)
    assert d["boundary_loops"] == loops


def test_bunny_unreferenced_vertices_reported(shared_mesh):
    s = load_surface(shared_mesh("stanford-bunny.obj"))
    c = codes(s)
    assert c["unreferenced_vertices"].count == 1113
    assert s.n_vertices == 35947 - 1113
    assert sorted(len(lp) for lp in meshops.boundary_loops(s.faces)) == [22, 39, 40, 42, 80]


def test_info_json_on_shared_mesh(shared_mesh):
    import json

    r = runner.invoke(app, ["info", str(shared_mesh("beetle.off")), "--json"])
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    assert d["boundary_loops"] == 11 and d["faces"] == 38656
    assert d["loop_vertices"][:3] == [512, 96, 80]
