"""Bad input through the command line, in a subprocess: exit code 2, no traceback, the cause named.

Every case runs ``python -m polishpath ...`` as a user would and checks that
the run is refused (exit 2) with a message naming the cause, without a Python
traceback and without calling the user's mistake a bug.
"""

from __future__ import annotations

import json
import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(REPO / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")}
ENV.pop("POLISHPATH_DEBUG", None)
ENV.pop("POLISHPATH_MAX_MEMORY", None)


def _limit_memory(limit_bytes: int):
    def pre():
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (limit_bytes, limit_bytes))

    return pre


def cli(*args: str, cwd: Path | None = None, memory: int | None = None, timeout: float = 120, env=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "polishpath", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, env=env or ENV, timeout=timeout,
                          preexec_fn=_limit_memory(memory) if memory else None)


def refused(r: subprocess.CompletedProcess, *needles: str) -> str:
    """Assert a clean refusal (exit 2, no traceback, not 'a bug') whose message holds every needle."""
    err = r.stderr
    assert r.returncode == 2, f"exit {r.returncode}\nstdout: {r.stdout[-2000:]}\nstderr: {err[-2000:]}"
    assert "Traceback" not in err and "Traceback" not in r.stdout, err
    assert "This is a bug" not in err, err
    assert "polishpath: error:" in err, err
    for n in needles:
        assert n.lower() in err.lower(), f"{n!r} not in: {err}"
    return err


# --- 1. resources and built-in ranges ---------------------------------------------------------------

GB = 1024**3


@pytest.mark.parametrize("cmd", ["info", "plan"])
def test_huge_hemisphere_refused_in_seconds_under_a_memory_limit(cmd, tmp_path):
    extra = ["-o", tmp_path / "out", "-q"] if cmd == "plan" else []
    r = cli(cmd, "hemisphere:R=1e9", *extra, memory=3 * GB, timeout=60)
    refused(r, "R=1e+09", "outside the range", "mm")
    assert not (tmp_path / "out").exists()


def test_plan_whose_dwell_points_cannot_fit_is_refused_before_flattening(tmp_path):
    # R = 300 mm at 0.5 mm: about 2.3 million dwell points on a uniform grid, ~4.5 million planned:
    # under max_points, but tens of GB: refused from the estimate, long before any flattening.
    r = cli("plan", "hemisphere:R=300,triangles=2000", "--spacing", "0.5", "-o", tmp_path / "out", "-q",
            memory=3 * GB, timeout=60)
    err = refused(r, "dwell points", "memory", "larger --spacing", "POLISHPATH_MAX_MEMORY")
    assert "flattening" not in r.stderr.split("polishpath: error:")[0].lower() or "GB" in err
    assert not (tmp_path / "out").exists()


def test_memory_limit_is_settable(tmp_path):
    env = {**ENV, "POLISHPATH_MAX_MEMORY": "100M"}
    r = cli("info", "hemisphere:triangles=5000", env=env)
    refused(r, "triangles", "more than this job may use", "100 MB", "POLISHPATH_MAX_MEMORY")
    r = cli("info", "hemisphere:triangles=5000", env={**ENV, "POLISHPATH_MAX_MEMORY": "lots"})
    refused(r, "'lots'", "4G")


def test_too_many_triangles_refused_from_the_estimate():
    r = cli("info", "hemisphere:triangles=19000000", memory=3 * GB, timeout=60)
    refused(r, "19,000,000 triangles", "memory", "fewer triangles")


def test_more_points_than_max_points_refused_early(tmp_path):
    r = cli("plan", "hemisphere:R=10000", "--spacing", "0.01", "-o", tmp_path / "out", "-q", timeout=60)
    refused(r, "dwell points", "max_points")


@pytest.mark.parametrize("spec, needle", [
    ("saddle:size=0", "size must be > 0"),
    ("saddle:size=1e7", "outside the range"),
    ("airfoil:thickness=3", "fraction of the chord"),
    ("sinusoidal:amplitude=1e9", "larger than"),
    ("hemisphere:R=inf", "finite"),
    ("hemisphere:R=nan", "finite"),
    ("hemisphere:angle=120", "angle"),
])
def test_builtin_parameters_in_a_sane_range(spec, needle):
    refused(cli("info", spec), needle)


def test_mesher_area_switch_is_plain_decimal():
    from polishpath.surfaces.mesher import area_switch

    for a in (1.05e13, 3.3e-7, 0.25, 12345.678):
        text = area_switch(a)
        assert set(text) <= set("0123456789."), text
        assert float(text) == pytest.approx(a, rel=1e-11)


def test_large_hemisphere_meshes_to_the_count_asked():
    # R = 1e5 mm: the area bound is about 3e6 mm^2 (written 1e6-ish with an exponent before the fix)
    r = cli("info", "hemisphere:R=1e5,triangles=3000", "--json", timeout=60)
    assert r.returncode == 0, r.stderr
    assert abs(json.loads(r.stdout)["faces"] - 3000) <= 30


# --- 7. smaller ones --------------------------------------------------------------------------------


def test_duplicate_surface_parameter_refused():
    refused(cli("info", "hemisphere:R=30,R=40"), "R is given twice", "30", "40")


def test_triangle_count_the_outline_cannot_meet_is_refused():
    refused(cli("info", "hemisphere:triangles=2"), "asked for 2 triangles", "18")


def test_units_on_a_builtin_refused():
    refused(cli("info", "hemisphere", "--units", "m"), "--units", "mesh files only")
    refused(cli("info", "hemisphere", "--scale", "2"), "--scale", "mesh files only")


@pytest.mark.parametrize("cmd", ["info", "flatten"])
def test_unknown_component_choice_refused(cmd):
    refused(cli(cmd, "hemisphere:triangles=500", "--component", "foo"), "'foo'", "refuse", "largest")


def test_component_choice_refused_by_plan(tmp_path):
    refused(cli("plan", "hemisphere:triangles=500", "--component", "foo", "-o", tmp_path / "o"), "'foo'", "largest")


def test_toml_surface_with_a_word_for_a_number(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('[surface]\ntype = "sphere"\nR = 100\n[aperture]\ntype = "circle"\nradius = "twenty"\n')
    refused(cli("info", p), "radius", "'twenty'", "number")
    p.write_text('[surface]\ntype = "sphere"\nR = 100\ntriangles = "many"\n')
    refused(cli("info", p), "triangles", "'many'")


def test_toml_without_surface_table_names_a_format_that_exists(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text("[something]\nx = 1\n")
    err = refused(cli("info", p), "[surface]")
    for word in err.split():
        word = word.strip("().,;'\"`")
        if word.startswith("examples/") or word.startswith("docs/"):
            assert (REPO / word).exists(), f"the hint names {word}, which does not exist"


def test_huge_spacing_refused_not_overflow(tmp_path):
    refused(cli("plan", "hemisphere:R=12,triangles=700", "--spacing", "1e300", "-o", tmp_path / "o", "-q"),
            "too large", "smaller --spacing")


def test_info_into_a_closed_pipe_exits_quietly():
    r = subprocess.run(f"{sys.executable} -m polishpath info hemisphere:triangles=500 | head -c 10",
                       shell=True, capture_output=True, text=True, env=ENV, timeout=60,
                       executable="/bin/bash")
    assert "BrokenPipe" not in r.stderr and "internal error" not in r.stderr, r.stderr
    assert r.stderr.strip() == "", r.stderr


def test_flatten_refuses_an_output_that_cannot_hold_uv(tmp_path):
    err = refused(cli("flatten", "hemisphere:triangles=500", "-o", tmp_path / "x.stl", "-q"), ".stl", "planar", "x.obj")
    assert "vt" in err
    assert not (tmp_path / "x.stl").exists()


def test_flatten_json_flags_are_booleans_and_counts_integers():
    r = cli("flatten", "hemisphere:triangles=500", "--json", timeout=120)
    assert r.returncode == 0, r.stderr
    m = json.loads(r.stdout)["metrics"]
    assert m["converged"] is True
    assert isinstance(m["flipped_faces"], int) and isinstance(m["boundary_self_overlap"], int)
    assert isinstance(m["iterations"], int)


def _write_ascii_stl(path: Path, v: np.ndarray, f: np.ndarray) -> None:
    lines = ["solid part"]
    for t in f:
        lines += ["facet normal 0 0 1", " outer loop"] + [f"  vertex {x:.9g} {y:.9g} {z:.9g}" for x, y, z in v[t]] + [" endloop", "endfacet"]
    lines.append("endsolid part")
    path.write_text("\n".join(lines) + "\n")


def test_part_in_metres_without_units_is_asked_about_units(tmp_path):
    # a 30 mm hemisphere written in metres, read as mm: 0.06 mm across
    from polishpath.surfaces import load_surface

    s = load_surface("hemisphere:R=30,triangles=400")
    p = tmp_path / "part.stl"
    _write_ascii_stl(p, s.vertices / 1000.0, s.faces)
    refused(cli("plan", p, "-o", tmp_path / "o", "-q"), "--units m")
    r = cli("info", p)
    assert r.returncode == 0 and "--units m" in r.stdout, r.stdout
    r = cli("info", p, "--units", "m", "--json")
    assert r.returncode == 0 and "--units m" not in r.stdout


def test_every_file_a_message_or_docstring_names_exists():
    import re

    named = set()
    for p in (REPO / "src").rglob("*.py"):
        named |= {(m, p.name) for m in re.findall(r"\b(?:examples|docs|benchmarks|scripts)/[A-Za-z0-9_./-]+\.[a-z]+", p.read_text())}
    assert named, "the scan found nothing: the pattern is wrong"
    missing = sorted(f"{m} (named in {where})" for m, where in named if not (REPO / m).exists())
    assert not missing, missing


# --- 2. file integrity ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def mesh_files(tmp_path_factory):
    """A small hemisphere as good ASCII/binary PLY, binary STL and OFF, plus damaged copies."""
    import trimesh

    from polishpath.surfaces import load_surface

    d = tmp_path_factory.mktemp("meshes")
    s = load_surface("hemisphere:R=10,triangles=800")
    m = trimesh.Trimesh(s.vertices, s.faces, process=False)
    nv = len(s.vertices)
    (d / "ok.ply").write_bytes(m.export(file_type="ply", encoding="ascii"))
    (d / "okb.ply").write_bytes(m.export(file_type="ply", encoding="binary"))
    (d / "ok.stl").write_bytes(m.export(file_type="stl"))
    (d / "ok.off").write_text(m.export(file_type="off"))
    text = (d / "ok.ply").read_text()
    (d / "more-vertices.ply").write_text(text.replace(f"element vertex {nv}", f"element vertex {nv + 50}"))
    (d / "faces-short.ply").write_text("\n".join(text.splitlines()[:-100]) + "\n")
    b = (d / "ok.stl").read_bytes()
    (d / "trunc.stl").write_bytes(b[: len(b) // 2])
    (d / "appended.stl").write_bytes(b + b[84:84 + 500])
    t = m.export(file_type="stl_ascii")
    (d / "ok-ascii.stl").write_text(t)
    (d / "trunc-ascii.stl").write_text(t[: len(t) // 2])
    b = (d / "okb.ply").read_bytes()
    (d / "trunc-bin.ply").write_bytes(b[:-500])
    o = (d / "ok.off").read_text().splitlines()
    (d / "trunc.off").write_text("\n".join(o[:-60]) + "\n")
    v = s.vertices.copy()
    v[5, 0] = 1e9
    (d / "far.ply").write_bytes(trimesh.Trimesh(v, s.faces, process=False).export(file_type="ply", encoding="ascii"))
    (d / "offset.ply").write_bytes(trimesh.Trimesh(s.vertices + [1e6, 0, 0], s.faces, process=False)
                                   .export(file_type="ply", encoding="ascii"))
    return d, len(s.faces)


@pytest.mark.parametrize("name", ["ok.ply", "okb.ply", "ok.stl", "ok-ascii.stl", "ok.off", "offset.ply"])
def test_good_files_read_whole(mesh_files, name):
    d, nf = mesh_files
    r = cli("info", d / name, "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["faces"] == nf


@pytest.mark.parametrize("name, needles", [
    ("more-vertices.ply", ["header declares", "473 vertices", "fewer", "truncated"]),
    ("faces-short.ply", ["header declares", "804 faces", "fewer", "truncated"]),
    ("trunc.stl", ["truncated binary STL", "804 triangles", "401 complete"]),
    ("appended.stl", ["804 triangles", "more"]),
    ("trunc-ascii.stl", ["ASCII STL", "endsolid", "truncated"]),
    ("trunc-bin.ply", ["truncated binary PLY"]),
    ("trunc.off", ["truncated", "804 faces", "744 face lines"]),
    ("far.ply", ["far from every neighbour", "1e+09", "corrupt coordinate"]),
])
def test_damaged_files_named_as_damaged(mesh_files, name, needles, tmp_path):
    d, _ = mesh_files
    err = refused(cli("plan", d / name, "-o", tmp_path / "o", "-q"), *needles)
    assert "non-manifold" not in err and "charset" not in err
    assert not (tmp_path / "o").exists()


def test_merge_tolerance_follows_edge_lengths_not_the_box():
    # a 20 um dome (edges ~1.3 um) beside a copy 10 m away: the box-relative tolerance
    # (1e-9 x 1e4 mm = 10 um) merged every vertex of the dome; the edge-relative one merges none
    from polishpath.surfaces import load_surface
    from polishpath.surfaces.validate import validate_mesh

    s = load_surface("hemisphere:R=10,triangles=800")
    v = s.vertices * 1e-3
    v2 = np.vstack([v, v + [1e4, 0, 0]])
    f2 = np.vstack([s.faces, s.faces + len(v)])
    vv, ff, findings = validate_mesh(v2, f2, component="largest")
    assert not any(x.code in ("duplicate_vertices", "degenerate_faces") for x in findings), findings
    assert len(ff) == s.n_faces and len(vv) == len(v)


# --- 6. measurements ----------------------------------------------------------------------------


def _profile(path: Path, z, x=None, header: str = ""):
    x = np.arange(len(z)) * 0.01 if x is None else x
    path.write_text(header + "".join(f"{a:.9g} {b:.9g}\n" for a, b in zip(x, z)))
    return path


@pytest.fixture(scope="module")
def heights():
    rng = np.random.default_rng(3)
    x = np.arange(1024) * 0.01
    return 2.0 * np.sin(2 * np.pi * x / 0.5) + rng.normal(0, 0.5, len(x))  # nm


def test_profile_in_mm_read_as_nm_is_refused_with_the_likely_unit(tmp_path, heights):
    p = _profile(tmp_path / "prof.txt", heights * 1e-6)  # the same surface written in mm
    err = refused(cli("psd", p), "implausible", "assumed", "--height-unit mm")
    assert "warning" in err and "does not say its units" in err
    r = cli("psd", p, "--height-unit", "mm", "--json")
    assert r.returncode == 0, r.stderr
    rms = json.loads(r.stdout)["rms_nm"]
    assert 1.0 < rms < 3.0
    assert "height unit" not in r.stderr  # stated, not assumed: no warning for it


def test_assumed_units_are_warned_about(tmp_path, heights):
    r = cli("psd", _profile(tmp_path / "prof.txt", heights), "--json")
    assert r.returncode == 0, r.stderr
    assert "polishpath: warning:" in r.stderr and "lateral unit mm" in r.stderr and "height unit nm" in r.stderr
    assert "--height-unit" in r.stderr and "--lateral-unit" in r.stderr
    assert json.loads(r.stdout)["measurement_params"]["units_assumed"]
    r = cli("psd", _profile(tmp_path / "p2.txt", heights, header="# lateral_unit: mm\n# height_unit: nm\n"))
    assert r.returncode == 0 and "warning" not in r.stderr, r.stderr


def test_stated_but_implausible_units_warn(tmp_path, heights):
    p = _profile(tmp_path / "prof.txt", heights * 1e-6, header="# lateral_unit: mm\n# height_unit: nm\n")
    r = cli("psd", p)
    assert r.returncode == 0, r.stderr
    assert "implausible" in r.stderr and "--height-unit mm" in r.stderr


def test_unknown_unit_option_refused(tmp_path, heights):
    refused(cli("psd", _profile(tmp_path / "prof.txt", heights), "--height-unit", "furlong"), "'furlong'", "height")


def test_non_uniform_x_resampling_is_said(tmp_path, heights):
    x = np.arange(len(heights)) * 0.01
    x[1::2] += 0.003
    r = cli("psd", _profile(tmp_path / "prof.txt", heights, x=x, header="# lateral_unit: mm\n# height_unit: nm\n"))
    assert r.returncode == 0, r.stderr
    assert "warning" in r.stderr and "resampled" in r.stderr and "not uniformly spaced" in r.stderr
    assert "resampled" in r.stdout


def test_map_against_profile_refused_unless_mixed(tmp_path, heights):
    rng = np.random.default_rng(1)
    g = rng.normal(0, 2.0, (64, 64))
    m = tmp_path / "map.txt"
    m.write_text("# dx: 0.01 mm\n# height_unit: nm\n" + "".join(" ".join(f"{v:.6g}" for v in row) + "\n" for row in g))
    p = _profile(tmp_path / "prof.txt", heights, header="# lateral_unit: mm\n# height_unit: nm\n")
    refused(cli("psd", m, p), "map", "profile", "--mixed")
    r = cli("psd", m, p, "--mixed")
    assert r.returncode == 0, r.stderr
    assert "suppression ratio" in r.stdout and "--mixed" in r.stdout


def test_nan_hint_names_the_option(tmp_path, heights):
    z = heights.copy()
    z[10] = np.nan
    p = _profile(tmp_path / "prof.txt", z, header="# lateral_unit: mm\n# height_unit: nm\n")
    err = refused(cli("psd", p, "--nan", "raise"), "NaN", "--nan interpolate")
    assert "nan='" not in err.split("(")[0]
    assert cli("psd", p, "--nan", "interpolate").returncode == 0


def test_mesh_file_too_large_for_memory_refused_from_its_header(tmp_path):
    # a binary STL header declaring 50 million triangles with the bytes to match (a sparse file: no disk used)
    p = tmp_path / "huge.stl"
    n = 50_000_000
    with p.open("wb") as fh:
        fh.write(b"\0" * 80 + struct.pack("<I", n))
        fh.truncate(84 + 50 * n)
    r = cli("info", p, memory=3 * GB, timeout=60)
    refused(r, "huge.stl", "50,000,000 faces", "memory", "Decimate")
