"""Machine output: CSV, XYZ, G-code and JSON writers and their round trips (issue 5, item 6)."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest

from polishpath._version import __version__ as VERSION
from polishpath.errors import ExportError, ParameterError
from polishpath.export import (
    build_summary,
    read_dwell_times,
    read_path_csv,
    read_xyz,
    write_gcode,
    write_path_csv,
    write_summary_json,
    write_outputs,
    write_xyz,
)
from polishpath.mapping import map_to_surface
from polishpath.smooth import evaluate, sample_normals, smooth
from polishpath.types import NurbsCurve
from test_mapping_helpers import serpentine_path, spherical_cap


@pytest.fixture(scope="module")
def tool_path():
    cap = spherical_cap(n_r=10, n_phi=36)
    path = serpentine_path(cap, 2.0, seed=5)
    sp = map_to_surface(cap, path)
    return smooth(sp, feed_mm_min=3000.0, period_ms=8.0, chord_tol_mm=5e-3)


def test_path_csv_round_trip(tool_path, tmp_path):
    f = tmp_path / "path.csv"
    write_path_csv(tool_path, f)
    back = read_path_csv(f)
    sp = tool_path.surface_path
    assert np.array_equal(back["index"], np.arange(len(sp.xyz)))
    assert np.array_equal(np.column_stack([back["i"], back["j"]]), sp.planar.ij)
    assert np.array_equal(np.column_stack([back["x"], back["y"], back["z"]]), sp.xyz)  # 17 digits: exact
    assert np.array_equal(np.column_stack([back["u"], back["v"]]), sp.planar.uv)
    assert np.array_equal(np.column_stack([back["nx"], back["ny"], back["nz"]]), sp.normals)
    assert np.array_equal(back["dwell_time"], tool_path.dwell_times)
    with pytest.raises(ExportError, match="header"):
        read_path_csv(io.StringIO("a,b\n1,2\n"))


def test_xyz_round_trip_and_open_file(tool_path, tmp_path):
    f = tmp_path / "toolpath.xyz"
    write_xyz(tool_path, f)
    back = read_xyz(f)
    assert back.shape == tool_path.samples.shape
    assert np.abs(back - tool_path.samples).max() <= 0.5e-6 + 1e-12
    lines = f.read_text().splitlines()
    assert len(lines) == len(tool_path.samples) and all(len(ln.split()) == 3 for ln in lines)
    assert "e" not in f.read_text().lower() and "-0.000000" not in f.read_text()
    buf = io.StringIO()
    write_xyz(tool_path, buf, decimals=3)
    assert np.abs(read_xyz(io.StringIO(buf.getvalue())) - tool_path.samples).max() <= 0.5e-3 + 1e-12


def _gcode_moves(text: str) -> np.ndarray:
    from gcodeparser import parse_gcode_lines

    lines = parse_gcode_lines(text)
    pts = [(ln.params["X"], ln.params["Y"], ln.params["Z"]) for ln in lines
           if ln.command == ("G", 1) and {"X", "Y", "Z"} <= set(ln.params)]
    return np.array(pts, dtype=np.float64)


def test_gcode_linear_parses_back_to_the_samples(tool_path, tmp_path):
    f = tmp_path / "toolpath.nc"
    hdr = {"surface": "cap", "spacing": 2.0, "seed": 5, "params": {"pattern": "raster", "flatten": "test"}}
    write_gcode(tool_path, f, header=hdr)
    text = f.read_text()
    assert "G21 G90 G17" in text and "M30" in text
    assert f"polishpath {VERSION}" in text and "(seed: 5)" in text and "params.pattern: raster" in text
    assert "period_ms" in text and "no tool radius offset" in text
    moves = _gcode_moves(text)
    off = tool_path.stats["sample_pieces"]
    # every sample is a G01 X Y Z target, except the first of each piece (reached by G00 + a Z plunge)
    expected = np.delete(tool_path.samples, off[:-1], axis=0)
    assert moves.shape == expected.shape
    assert np.abs(moves - expected).max() <= 0.5e-4 + 1e-12
    assert text.count("G00 X") == len(off) - 1
    from gcodeparser import parse_gcode_lines

    feeds = [ln.params["F"] for ln in parse_gcode_lines(text) if ln.command == ("G", 1) and "X" in ln.params]
    assert np.allclose(feeds, np.delete(tool_path.feed_mm_min, off[:-1]), atol=0.05 + 1e-9)


def test_tool_radius_moves_every_point_along_its_normal(tool_path):
    r = 3.0
    plain, offset = io.StringIO(), io.StringIO()
    write_gcode(tool_path, plain)
    write_gcode(tool_path, offset, tool_radius=r)
    a, b = _gcode_moves(plain.getvalue()), _gcode_moves(offset.getvalue())
    d = b - a
    assert np.abs(np.linalg.norm(d, axis=1) - r).max() <= 2e-4
    off = tool_path.stats["sample_pieces"]
    n = np.delete(sample_normals(tool_path), off[:-1], axis=0)
    assert np.abs(a - np.delete(tool_path.samples, off[:-1], axis=0)).max() <= 0.5e-4 + 1e-12
    assert np.abs(d - r * n).max() <= 2e-4
    assert "TOOL RADIUS OFFSET" in offset.getvalue() and "3.0 mm" in offset.getvalue()


def test_gcode_nurbs_blocks_rebuild_the_curve(tool_path):
    from pygcode import Line

    buf = io.StringIO()
    write_gcode(tool_path, buf, mode="nurbs")
    text = buf.getvalue()
    pieces, cur = [], None
    for raw in text.splitlines():
        if not raw.strip() or raw.startswith("%") or raw.startswith("("):
            continue
        line = Line(raw)
        words = {w.letter: w.value for w in line.block.words}
        if "G06.2" in raw:
            cur = {"P": int(words["P"]), "K": [], "C": []}
            pieces.append(cur)
        if cur is None:
            continue
        if "K" in words:
            cur["K"].append(float(words["K"]))
            if "X" in words:
                cur["C"].append((float(words["X"]), float(words["Y"]), float(words["Z"])))
        elif raw.startswith("G0"):
            cur = None
    sp = tool_path.surface_path
    assert len(pieces) == len(sp.planar.pieces) - 1
    for k, pc in enumerate(pieces):
        kn, cp = np.array(pc["K"]), np.array(pc["C"])
        p = pc["P"] - 1
        assert pc["P"] == 4 and len(kn) == len(cp) + pc["P"]  # Fanuc: knots = control points + order
        assert np.all(np.diff(kn) >= 0) and np.all(kn[:4] == kn[0]) and np.all(kn[-4:] == kn[-1])
        curve = NurbsCurve(p, (kn - kn[0]) / (kn[-1] - kn[0]), cp)
        a, b = sp.planar.pieces[k], sp.planar.pieces[k + 1]
        # the rebuilt curve passes through the piece's dwell points (to the written precision)
        pp = tool_path.stats["piece_params"]
        u = np.clip((tool_path.dwell_params[a:b] - pp[k]) / (pp[k + 1] - pp[k]), 0, 1)
        assert np.abs(evaluate(curve, u) - sp.xyz[a:b]).max() < 5e-4


def test_writers_are_atomic(tmp_path):
    f = tmp_path / "summary.json"
    write_summary_json({"a": np.float64(1.5), "b": np.arange(3), "c": float("nan")}, f)
    assert json.loads(f.read_text()) == {"a": 1.5, "b": [0, 1, 2], "c": None}

    class Boom:
        def to_dict(self):
            raise KeyboardInterrupt  # as if Ctrl-C arrived mid-write

    with pytest.raises(KeyboardInterrupt):
        write_summary_json({"a": 1, "z": Boom()}, f)
    assert json.loads(f.read_text())["a"] == 1.5  # the old file is intact
    assert sorted(p.name for p in tmp_path.iterdir()) == ["summary.json"]  # no temp file left
    with pytest.raises(ExportError, match="does not exist"):
        write_xyz(np.zeros((2, 3)), tmp_path / "nope" / "x.xyz")


def test_summary_collects_stats_and_notes_area_weighting(tool_path, tmp_path):
    s = build_summary(tool_path, extra={"surface": {"name": "cap"}})
    assert s["version"] == VERSION and s["seed"] == 5
    assert "step_max" in s["surface_path"] and "chord_error_max" in s["tool_path"]
    assert "area" in s["dwell_time_note"]
    f = tmp_path / "summary.json"
    write_summary_json(s, f)
    back = json.loads(f.read_text())
    assert back["provenance"]["smooth"]["params"]["period_ms"] == 8.0
    with pytest.raises(ParameterError):
        write_gcode(tool_path, io.StringIO(), mode="spline")


def test_write_outputs_writes_four_files_that_parse_back(tool_path, tmp_path):
    out = write_outputs(tmp_path / "run", tool_path, header={"surface": "cap", "seed": 5}, gcode_mode="nurbs")
    assert sorted(p.name for p in (tmp_path / "run").iterdir()) == ["path.csv", "summary.json", "toolpath.nc",
                                                                     "toolpath.xyz"]
    assert len(read_path_csv(out["path_csv"])["x"]) == len(tool_path.surface_path.xyz)
    assert read_xyz(out["xyz"]).shape == tool_path.samples.shape
    assert "G06.2 P4" in out["gcode"].read_text()
    s = json.loads(out["summary"].read_text())
    assert s["parameters"]["surface"] == "cap" and s["gcode"]["mode"] == "nurbs"


def test_dwell_time_csv(tool_path, tmp_path):
    f = tmp_path / "path.csv"
    write_path_csv(tool_path, f)
    t = read_dwell_times(f, len(tool_path.surface_path.xyz))
    assert np.array_equal(t, tool_path.dwell_times)
    assert np.array_equal(read_dwell_times(io.StringIO("0.5\n0.25\n")), [0.5, 0.25])
    with pytest.raises(ParameterError, match="2 times but the path has 3"):
        read_dwell_times(io.StringIO("0.5\n0.25\n"), 3)
    with pytest.raises(ParameterError, match="positive"):
        read_dwell_times(io.StringIO("0.5\n-1\n"))
