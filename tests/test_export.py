"""Record files: CSV, XYZ and JSON writers and their round trips (issue 5, item 6). G-code: test_post.py."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest

from polishpath.errors import ExportError, ParameterError
from polishpath.export import (
    read_dwell_times,
    read_path_csv,
    read_xyz,
    write_path_csv,
    write_summary_json,
    write_xyz,
)
from polishpath.mapping import map_to_surface
from polishpath.smooth import smooth
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


def test_bulk_formatting_prints_exactly_what_python_prints():
    from polishpath.export.textfmt import format_csv, format_fixed

    rng = np.random.default_rng(7)
    tricky = np.concatenate([
        rng.normal(size=4000), rng.uniform(-300, 300, 4000),
        rng.normal(size=4000) * 10.0 ** rng.integers(-300, 300, 4000),  # every exponent, and outside 1e+-280
        np.ldexp(rng.integers(1, 2**53, 2000).astype(float), rng.integers(-1074, 971, 2000)),  # subnormals too
        10.0 ** np.arange(-300, 300), 10.0 ** np.arange(-300, 300) * (1 + 2**-52),  # powers of ten, neighbours
        np.arange(1, 3000) / 1024.0, [(2.0**53 - 1) / 4, 0.5, 1e16, 1e17, 99999999999999999.0, 5e-324, 0.0, -0.0,
                                      np.inf, -np.inf, np.nan, 0.1, 1e-5, 123456.789],  # a tie, zeros, non-finite
    ])
    tricky = np.concatenate([tricky, -tricky])
    got = format_csv(np.zeros((len(tricky), 1), np.int64), tricky[:, None]).decode().splitlines()
    assert got == ["0,%.17g" % x for x in tricky]
    ints = rng.integers(-5, 10**12, (50, 3))
    assert format_csv(ints, np.zeros((50, 0))).decode() == "".join("%d,%d,%d\n" % tuple(r) for r in ints)
    for d in (0, 3, 4, 6, 9):
        v = np.concatenate([rng.uniform(-300, 300, 3000), rng.normal(scale=10.0**-d, size=3000),
                            np.round(rng.uniform(-10, 10, 3000), d) + 0.5 * 10.0**-d, [-0.0, -1e-12, 1e5]])
        v = v.reshape(-1, 3)
        want = "".join(" ".join(f"{np.round(x, d) + 0.0:.{d}f}" for x in row) + "\n" for row in v)
        assert format_fixed(v, d).decode() == want
    # huge values: the exact fallback; letters and words left out
    assert format_fixed(np.array([[1e300, 2.0]]), 4, letters="XY").decode() == f"X{1e300:.4f} Y2.0000\n"
    assert format_fixed(np.array([[1.0, 2.0]]), 4, letters="XY", present=np.array([[False, True]])) == b"Y2.0000\n"


def test_compact_fixed_point_styles():
    """G-code's compact numbers (no leading zero, no trailing zeros, a kept point on whole numbers), compiled and
    Python's alike, and read back to the same value."""
    from polishpath.export.textfmt import KEEP_POINT, NO_LEADING_ZERO, NO_TRAILING_ZEROS, fixed_text, format_fixed

    rng = np.random.default_rng(11)
    v = np.concatenate([rng.normal(size=3000) * 10.0 ** rng.integers(-5, 4, 3000), [0.0, -0.0, 4e-5, -4e-5, 5e-5,
                                                                                     10.0, -10.0, 0.5, -0.5, 100.0]])
    v = np.array([np.round(x, int(k)) for x, k in zip(v, rng.integers(0, 6, len(v)))])
    for style in range(8):
        for d in (0, 2, 4):
            got = format_fixed(v[:, None], d, letters="X", styles=style, sep="").decode().split()
            assert got == ["X" + fixed_text(x, d, style) for x in v]
            assert np.array_equal([float(w[1:]) for w in got], np.round(v, d) + 0.0)
    row = np.array([[1.0, 0.5, -0.25, 0.0, 10.0, 12.5]])
    assert format_fixed(row, 4, letters="GXYZIJ", sep="", styles=NO_LEADING_ZERO | NO_TRAILING_ZEROS) == \
        b"G1X.5Y-.25Z0I10J12.5\n"
    assert format_fixed(row, 4, letters="GXYZIJ", sep=" ", styles=NO_TRAILING_ZEROS | KEEP_POINT) == \
        b"G1. X0.5 Y-0.25 Z0 I10. J12.5\n"
    assert format_fixed(row, 4, letters="GXYZIJ", styles=0) == b"G1.0000 X0.5000 Y-0.2500 Z0.0000 I10.0000 J12.5000\n"
