"""The 5-axis LinuxCNC file checked by LinuxCNC's own interpreter, rs274 (issue 27, items 2-4).

``--tool-axis normal`` / ``tilted:angle=20`` with the built-in table-tilting profiles (``xyzac-trt``,
``xyzbc-trt``): rs274 reads the file without error, its canonical moves carry the rotary words, the tool
axis rebuilt from the A/C (B/C) angles of every path move's end (LinuxCNC's trt transforms,
:mod:`polishpath.schedule.kinematics`) is the planned axis within 0.01 degree (the pole included), the
tilted tool keeps its 20 degrees from the normal, and the time rs274 executes (its G93 feed rates)
is the planned machining time within 1 %.
"""

from __future__ import annotations

import re
import subprocess
import sys

import numpy as np
import pytest
from scipy.spatial import cKDTree

from polishpath.axes import axis_angles_deg
from polishpath.export.chunks import axes_at, normals_at
from polishpath.pipeline import run
from polishpath.schedule import BUILTIN_MACHINES, schedule_feeds, segment_limits
from polishpath.schedule.kinematics import Kinematics, axes_from_angles
from rs274_helpers import rs274  # noqa: F401  (fixture)

CASES = {
    "hemisphere-ac-normal": dict(surface="hemisphere:R=12,triangles=3000", spacing=1.5, seed=11,
                                 tool_axis="normal", machine="xyzac-trt"),
    "hemisphere-bc-tilted": dict(surface="hemisphere:R=12,triangles=3000", spacing=1.5, seed=5,
                                 tool_axis="tilted:angle=20,azimuth=30", machine="xyzbc-trt", tool_radius=2.0),
    "seat-ac-normal": dict(surface="bicycle-seat:length=135,width=75,triangles=2000", spacing=3.0, seed=3,
                           tool_axis="normal", machine="xyzac-trt"),
    "seat-bc-tilted": dict(surface="bicycle-seat:length=135,width=75,triangles=2000", spacing=3.0, seed=3,
                           tool_axis="tilted:angle=20", machine="xyzbc-trt"),
}


@pytest.fixture(scope="module", params=list(CASES))
def five(request, tmp_path_factory):
    kw = CASES[request.param]
    job = run(report=False, **kw)
    out = tmp_path_factory.mktemp(request.param) / "run"
    job.save(out)
    return request.param, job, out


def _path_moves(canon):
    """The G93 path moves (approach and retract, G94, left out): ends (K, 3), rotary ends (K, 3), seconds (K,)."""
    m = canon.inverse_time
    xyz = np.linalg.norm(canon.feeds[m] - canon.starts[m], axis=1)
    rot = np.linalg.norm(canon.rotary[m] - canon.rotary_starts[m], axis=1)
    length = np.where(xyz > 0, xyz, rot)  # rs274's length of a move: its XYZ, else its rotary, distance
    return canon.feeds[m], canon.rotary[m], 60.0 * length / canon.feed_rate[m]


def _planned(job):
    """Every planned point a block may end at (the driven samples and dwell points), its axis and normal."""
    tp, sp = job.tool_path, job.surface_path
    r = job.config.tool_radius
    u = np.concatenate([tp.sample_params, tp.dwell_params])
    nrm = normals_at(tp, u)
    pts = np.vstack([tp.samples, sp.xyz]) + r * nrm
    return pts, axes_at(tp, u), nrm


def test_rs274_runs_the_5_axis_file_with_the_planned_axes_and_time(rs274, five):
    name, job, out = five
    kin = BUILTIN_MACHINES[job.config.machine].kinematics
    canon = rs274(out / "toolpath.nc")
    assert canon.ok, canon.errors[:5]
    ends, rot, secs = _path_moves(canon)
    assert len(ends) > 100
    # the rotary words are there: the tilt axis and C move, the other rotary word stays 0
    tilt = 0 if kin.tilt_letter == "A" else 1
    assert np.ptp(rot[:, tilt]) > 5.0 and np.ptp(rot[:, 2]) > 5.0 and np.all(rot[:, 1 - tilt] == 0.0)
    # every path move's end is a planned point (4 decimals), and the axis its A/C (B/C) make is the planned one
    pts, axes, nrm = _planned(job)
    dist, idx = cKDTree(pts).query(ends)
    assert dist.max() < 2e-4
    rebuilt = axes_from_angles(kin.type, rot[:, [tilt, 2]])
    err = axis_angles_deg(rebuilt, axes[idx])
    assert err.max() <= 0.01, f"{name}: axis off by {err.max():.4g} deg"
    if job.config.tool_axis == "normal" and name.startswith("hemisphere"):
        pole = axis_angles_deg(axes[idx], np.array([[0.0, 0.0, 1.0]]))
        assert pole.min() < 1.0  # the path passes the pole (the singular direction), and holds there too
        assert err[pole < 2.0].max() <= 0.01
    if job.config.tool_axis.startswith("tilted"):  # 20 degrees from the normal at every move's end
        assert np.abs(axis_angles_deg(rebuilt, nrm[idx]) - 20.0).max() <= 0.01
    # the time rs274 executes (G93: 1/F minutes per move) is the planned machining time
    planned = job.schedule["machining_time_s"]
    assert abs(secs.sum() / planned - 1.0) < 0.01, (secs.sum(), planned)
    assert abs(secs.sum() / job.program["path_time_s"] - 1.0) < 0.002


def test_the_5_axis_header_says_which_tool_point_and_kinematics(five):
    name, job, out = five
    text = (out / "toolpath.nc").read_text()
    kin = BUILTIN_MACHINES[job.config.machine].kinematics
    assert f"KINEMATICS: LinuxCNC {kin.type}-kins with the tool-centre-point kinematics on" in text
    assert "TOOL AXIS: " + job.surface_path.tool_axis in text
    assert ("the tool centre" if job.config.tool_radius > 0 else "the tool-part contact point") in text
    code = [ln for ln in text.splitlines() if not ln.startswith("(")]
    assert "G93" in code
    assert not [ln for ln in code if re.search(r"G0?[23](?!\d)", ln)]  # lines only: the tool turns along them


def test_the_feed_schedule_keeps_the_rotary_limits(five):
    """The scheduled samples move every rotary axis and joint within its velocity and acceleration limits."""
    name, job, _ = five
    kin = BUILTIN_MACHINES[job.config.machine].kinematics
    tp = job.tool_path
    ang = kin.angles(tp.sample_axes)
    joints = kin.joints(tp.samples, ang)
    dt = np.linalg.norm(np.diff(tp.samples, axis=0), axis=1) * 60.0 / tp.feed_mm_min[1:]
    sp = tp.sample_pieces
    vmax = np.concatenate([BUILTIN_MACHINES[job.config.machine].max_velocity_mm_min, kin.max_velocity_deg_min]) / 60
    amax = np.concatenate([BUILTIN_MACHINES[job.config.machine].max_acceleration_mm_s2, kin.max_acceleration_deg_s2])
    for a, b in zip(sp[:-1], sp[1:]):
        lim = segment_limits(np.column_stack([joints[a:b], ang[a:b]]), dt[a : b - 1])
        assert np.all(np.abs(lim["velocity"]) <= vmax * (1 + 1e-6))
        assert np.all(np.abs(lim["acceleration"]) <= amax * (1 + 1e-6))


def test_without_the_rotary_limits_the_rotary_axes_would_exceed_them(five):
    """The check above can fail: the planned feeds (before the schedule) turn C faster than its limit."""
    name, job, _ = five
    if not name.startswith("seat-ac"):
        pytest.skip("one case shows it")
    machine = BUILTIN_MACHINES[job.config.machine]
    slow = Kinematics(machine.kinematics.type, max_velocity_deg_min=(600.0, 600.0),
                      max_acceleration_deg_s2=(50.0, 50.0))
    m = type(machine)(name="slow", kinematics=slow)
    tp = job.tool_path
    before = tp.feed_mm_min
    after, rep = schedule_feeds(tp, m)
    assert np.all(after.feed_mm_min <= before + 1e-9) and rep["rotary_velocity_max_deg_min"][1] <= 600.0 * (1 + 1e-6)
    assert rep["limited_share"] > 0 and rep["machining_time_s"] > rep["planned_time_s"]


def test_an_orientation_the_machine_cannot_reach_is_refused_naming_the_dwell_point(tmp_path):
    m = tmp_path / "narrow.toml"
    m.write_text('[machine]\nname = "narrow"\n[machine.kinematics]\ntype = "xyzac-trt"\ntilt_range_deg = [-10, 10]\n')
    proc = subprocess.run([sys.executable, "-m", "polishpath", "plan", "hemisphere:R=12,triangles=700",
                           "--spacing", "1.5", "--tool-axis", "normal", "--machine", str(m), "-q", "--no-report",
                           "-o", str(tmp_path / "r")], capture_output=True, text=True)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "dwell point" in proc.stderr and "A [-10, 10]" in proc.stderr and not (tmp_path / "r").exists()


def test_the_linuxcnc_post_needs_kinematics_for_a_path_with_axes(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "polishpath", "plan", "hemisphere:R=12,triangles=700",
                           "--tool-axis", "normal", "-q", "--no-report", "-o", str(tmp_path / "r")],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "--machine xyzac-trt" in proc.stderr and not (tmp_path / "r").exists()


@pytest.mark.parametrize("kind", ["xyzac-trt", "xyzbc-trt"])
def test_inverse_kinematics_is_continuous_and_exact(kind):
    """Random axes round-trip; a path through the pole keeps C and passes on the other branch; no C spin."""
    kin = Kinematics(kind)
    rng = np.random.default_rng(2)
    v = rng.normal(size=(3000, 3))
    v[:, 2] = np.abs(v[:, 2])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    assert axis_angles_deg(kin.axes(kin.angles(v)), v).max() < 1e-9
    t = np.linspace(-0.4, 0.4, 801)
    for phi in (0.0, 1.0, 2.5):
        path = np.column_stack([np.sin(t) * np.cos(phi), np.sin(t) * np.sin(phi), np.cos(t)])
        ang = kin.angles(path)
        assert axis_angles_deg(kin.axes(ang), path).max() < 1e-9
        assert np.ptp(ang[:, 1]) < 1e-9  # C still through the pole
        assert np.abs(np.diff(ang[:, 0])).max() < 0.06  # the tilt passes zero (the other branch)
    # a circle round the pole: C turns on and on (unwound: no jump of 360)
    s = np.linspace(0, 6 * np.pi, 3000)
    ring = np.column_stack([0.3 * np.cos(s), 0.3 * np.sin(s), np.ones_like(s)])
    ang = kin.angles(ring)
    assert np.abs(np.diff(ang[:, 1])).max() < 1.0 and np.ptp(ang[:, 1]) > 1000.0


def test_joints_follow_linuxcnc_trt_transforms():
    """Spot values of the modules' inverse transforms (A = C = 0: identity; pure C; pure A about the pivot)."""
    k = Kinematics("xyzac-trt", rot_point_mm=(0.0, 0.0, 0.0), offset_mm=(0.0, 0.0))
    assert np.allclose(k.joints(np.array([[7.0, -3.0, 11.0]]), np.array([[0.0, 0.0]])), [[7.0, -3.0, 11.0]])
    assert np.allclose(k.joints(np.array([[10.0, 0.0, 0.0]]), np.array([[0.0, 90.0]])), [[0.0, 10.0, 0.0]])
    assert np.allclose(k.joints(np.array([[0.0, 10.0, 0.0]]), np.array([[90.0, 0.0]])), [[0.0, 0.0, 10.0]])
    b = Kinematics("xyzbc-trt", offset_mm=(0.0, -50.0))
    # B = 90 about the pivot 50 mm below: the point at the pivot's height stays, one above it swings to +X
    assert np.allclose(b.joints(np.array([[0.0, 0.0, -50.0]]), np.array([[90.0, 0.0]])), [[0.0, 0.0, -50.0]])
    assert np.allclose(b.joints(np.array([[0.0, 0.0, -40.0]]), np.array([[90.0, 0.0]])), [[10.0, 0.0, -50.0]])
