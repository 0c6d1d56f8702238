"""The tool-axis laws and the axes through the data flow (issue 27, item 1).

``--tool-axis z | normal | tilted:angle=DEG[,azimuth=DEG]`` (:mod:`polishpath.axes`): the axes at the
dwell points (``SurfacePath.tool_axes``), at the machine samples held (``ToolPath.sample_axes``) and
streamed (``SampleChunk.axes``), in the run folder and path.csv; a 3-axis job carries none.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

from polishpath.axes import (MAX_TILT_DEG, ToolAxisLaw, axes_at_params, axis_angles_deg, interpolate_units,
                             parse_tool_axis, tool_axes, with_tool_axes)
from polishpath.errors import ParameterError
from polishpath.export import read_path_csv, sample_chunks
from polishpath.mapping import map_to_surface
from polishpath.smooth import iter_sample_chunks, sample_normals, smooth
from polishpath.types import SampleChunk
from test_mapping_helpers import serpentine_path, spherical_cap


def _sphere_normals(n=2000, seed=3):
    """Unit normals of the upper hemisphere, the pole itself and the rim included."""
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    v = np.vstack([v, [[0, 0, 1.0], [1.0, 0, 0], [0, -1.0, 0], [-1.0, 0, 0]]])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.parametrize("text, law", [
    ("z", ToolAxisLaw("z")), ("normal", ToolAxisLaw("normal")), (" Normal ", ToolAxisLaw("normal")),
    ("tilted:angle=20", ToolAxisLaw("tilted", 20.0, 0.0)),
    ("tilted:angle=15.5,azimuth=-90", ToolAxisLaw("tilted", 15.5, -90.0)),
    ("tilted: azimuth=45 , angle=0", ToolAxisLaw("tilted", 0.0, 45.0)),
])
def test_tool_axis_specs_parse(text, law):
    got = parse_tool_axis(text)
    assert got == law
    assert parse_tool_axis(got.spec) == law  # the spec written to job.toml reads back


@pytest.mark.parametrize("text, words", [
    ("x", "unknown --tool-axis law"), ("normal:angle=3", "takes no parameters"),
    ("tilted", "needs angle"), ("tilted:angle=abc", "must be a number"), ("tilted:angle=10,tilt=3", "unknown item"),
    ("tilted:angle=10,angle=20", "repeated"), (f"tilted:angle={MAX_TILT_DEG + 1}", "0..80 degrees"),
    ("tilted:angle=-5", "0..80 degrees"), ("tilted:angle=nan", "must be a number"),
])
def test_bad_tool_axis_specs_are_refused_naming_the_cause(text, words):
    with pytest.raises(ParameterError) as e:
        parse_tool_axis(text)
    assert words in str(e.value) and "--tool-axis" in str(e.value)


def test_bad_tool_axis_on_the_command_line_is_exit_2_not_a_traceback(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "polishpath", "plan", "hemisphere:R=12,triangles=700",
                           "--tool-axis", "tilted:angle=95", "-q", "--no-report", "-o", str(tmp_path / "r")],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "0..80 degrees" in proc.stderr and not (tmp_path / "r").exists()


def test_z_and_normal_laws():
    n = _sphere_normals()
    assert np.array_equal(tool_axes("z", n), np.tile([0.0, 0.0, 1.0], (len(n), 1)))
    assert np.allclose(tool_axes("normal", n * 3.0), n, atol=1e-15)  # unit whatever the input's length


@pytest.mark.parametrize("angle, azimuth", [(20.0, 0.0), (20.0, 90.0), (35.0, -30.0), (5.0, 200.0)])
def test_tilted_keeps_its_angle_from_the_normal_everywhere_pole_and_rim_included(angle, azimuth):
    n = _sphere_normals()
    ax = tool_axes(f"tilted:angle={angle},azimuth={azimuth}", n)
    assert np.allclose(np.linalg.norm(ax, axis=1), 1.0, atol=1e-14)
    assert np.max(np.abs(axis_angles_deg(ax, n) - angle)) < 1e-9
    # at the pole: the tilt toward the azimuth of the part's frame
    az = np.radians(azimuth)
    th = np.radians(angle)
    pole = np.array([np.sin(th) * np.cos(az), np.sin(th) * np.sin(az), np.cos(th)])
    assert np.allclose(ax[-4], pole, atol=1e-14)
    # in the plane of the normal and the azimuth direction (the tilt's side is the azimuth's)
    d = np.array([np.cos(az), np.sin(az), 0.0])
    side = np.einsum("ij,ij->i", np.cross(n, ax), np.cross(n, np.broadcast_to(d, n.shape)))
    assert np.all(side >= -1e-12)


def test_tilted_is_continuous_through_the_pole():
    """Paths over the pole: consecutive axes turn at most sqrt(2) times as much as the normals (no flip)."""
    t = np.linspace(-0.3, 0.3, 601)
    for phi in (0.0, 0.7, np.pi / 2, 2.0):
        n = np.column_stack([np.sin(t) * np.cos(phi), np.sin(t) * np.sin(phi), np.cos(t)])
        ax = tool_axes("tilted:angle=20,azimuth=0", n)
        step_n = axis_angles_deg(n[1:], n[:-1])
        assert np.max(axis_angles_deg(ax[1:], ax[:-1]) / step_n) < np.sqrt(2.0)


def test_sample_axes_are_the_law_at_the_interpolated_normal():
    """Between dwell points a sample's axis keeps the law (tilted: the angle from the sample's normal)."""
    n = _sphere_normals(50)
    knots = np.linspace(0.0, 1.0, len(n))
    u = np.linspace(0.0, 1.0, 997)
    law = "tilted:angle=20,azimuth=30"

    class _SP:  # the two fields axes_at_params reads
        tool_axes, tool_axis, normals = tool_axes(law, n), law, n

    ax = axes_at_params(_SP, knots, u)
    assert np.allclose(ax, tool_axes(law, interpolate_units(u, knots, n)), atol=1e-15)
    assert np.max(np.abs(axis_angles_deg(ax, interpolate_units(u, knots, n)) - 20.0)) < 1e-9


@pytest.fixture(scope="module")
def mapped():
    cap = spherical_cap(n_r=10, n_phi=32)
    path = serpentine_path(cap, 1.5, seed=11)
    return cap, map_to_surface(cap, path)


@pytest.mark.parametrize("law", ["normal", "tilted:angle=20,azimuth=45"])
def test_samples_held_and_streamed_carry_the_axes(mapped, law):
    cap, sp0 = mapped
    sp = with_tool_axes(sp0, law)
    assert sp.tool_axis == parse_tool_axis(law).spec and sp.tool_axes.shape == sp.xyz.shape
    kw = dict(surface=cap.surface, feed_mm_min=1200.0, period_ms=4.0, chord_tol_mm=1e-3)
    held = smooth(sp, **kw)
    assert held.sample_axes.shape == held.samples.shape
    # each sample's axis is the law applied to the sample's normal
    assert np.allclose(held.sample_axes, tool_axes(law, sample_normals(held)), atol=1e-12)
    chunks = list(sample_chunks(held, size=333))
    assert np.array_equal(np.concatenate([c.axes for c in chunks]), held.sample_axes)
    streamed = list(iter_sample_chunks(smooth(sp, keep_samples=False, **kw), size=257))
    assert np.array_equal(np.concatenate([c.axes for c in streamed]), held.sample_axes)
    # the axes survive a copy of the tool path with other feeds (the machine schedule's replace)
    again = dataclasses.replace(held, feed_mm_min=held.feed_mm_min * 0.5)
    assert np.array_equal(again.sample_axes, held.sample_axes)


def test_a_3_axis_path_carries_no_axes(mapped):
    cap, sp0 = mapped
    sp = with_tool_axes(sp0, "z")
    assert sp.tool_axes is None and sp.tool_axis == "z"
    held = smooth(sp, surface=cap.surface, feed_mm_min=1200.0, period_ms=4.0, chord_tol_mm=1e-3)
    assert held.sample_axes is None
    assert all(c.axes is None for c in sample_chunks(held))


def test_a_chunk_refuses_axes_of_another_shape():
    with pytest.raises(Exception, match="axes"):
        SampleChunk(np.zeros((3, 3)), np.zeros(3), np.ones(3), 0, np.zeros((2, 3)))


def _plan(out, *args):
    proc = subprocess.run([sys.executable, "-m", "polishpath", "plan", "hemisphere:R=12,triangles=1500",
                           "--spacing", "1.5", "--seed", "4", "--no-report", "-q", "-o", str(out), *args],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return out


def test_run_folder_and_path_csv_keep_the_axes_and_a_3_axis_run_has_none(tmp_path):
    from polishpath.runfolder import read_run

    five = _plan(tmp_path / "five", "--tool-axis", "tilted:angle=20", "--post", "csv")
    three = _plan(tmp_path / "three", "--post", "csv")
    run5, run3 = read_run(five), read_run(three)
    sp5 = run5.surface_path
    assert sp5.tool_axis == "tilted:angle=20,azimuth=0"
    assert np.allclose(axis_angles_deg(sp5.tool_axes, sp5.normals), 20.0, atol=1e-9)
    assert run5.tool_path.sample_axes is not None
    csv5 = read_path_csv(five / "path.csv")
    assert np.array_equal(np.column_stack([csv5["axis_x"], csv5["axis_y"], csv5["axis_z"]]), sp5.tool_axes)
    assert "tool_axes" not in run3.arrays and run3.surface_path.tool_axes is None
    assert "axis_x" not in read_path_csv(three / "path.csv")
    assert (three / "path.csv").read_text().splitlines()[0] == "index,i,j,u,v,x,y,z,nx,ny,nz,dwell_time"
    # the report draws the tool axes of the 5-axis run only (the 3-axis report has no such section)
    from polishpath.report import write_report

    w5, w3 = write_report(five), write_report(three)
    assert "figure_tool_axes" in w5 and w5["figure_tool_axes"].stat().st_size > 5000
    assert "figure_tool_axes" not in w3 and not (three / "figures" / "tool_axes.png").exists()
    assert 'id="tool-axes"' in (five / "report.html").read_text()
    assert 'id="tool-axes"' not in (three / "report.html").read_text()


def test_a_3_axis_post_refuses_a_path_with_axes(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "polishpath", "plan", "hemisphere:R=12,triangles=700",
                           "--tool-axis", "normal", "--post", "xyz", "-q", "--no-report", "-o", str(tmp_path / "r")],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "cannot carry the tool axes" in proc.stderr and not (tmp_path / "r").exists()
