"""The Sinumerik 840D and ABB RAPID posts (issue 27, items 3 and 4): read back, positions, orientations, times.

No open interpreter runs these programs, so each file is read back by the readers
in ``orient_helpers.py`` (written from the manuals' rules, not from the writers)
and checked against the plan: every planned sample of the tool point on the
written path within the chord tolerance, the tool axis at every block end equal
to the planned axis there within 0.01 degree, the time around every dwell point
within its 1 % tolerance and the whole path's within the feed resolution.
"""

from __future__ import annotations

import io

import numpy as np
import pytest
from scipy.spatial import cKDTree

from polishpath.errors import ParameterError
from polishpath.export import POSTS, get_post
from polishpath.export.chunks import sample_chunks
from polishpath.export.post.rapid import MAX_TILT_DEG, quaternion_angles_deg, tool_quaternions
from polishpath.mapping import map_to_surface
from polishpath.smooth import sample_normals, smooth
from gcode_helpers import dwell_moves
from orient_helpers import quat_matrix, read_rapid, read_sinumerik, rotation_angles_deg
from test_mapping_helpers import serpentine_path, spherical_cap

RES = 0.5e-4 + 1e-12  # half the coordinate resolution, mm
AXIS_TOL_DEG = 0.01
POST_NAMES = ("sinumerik", "abb")


@pytest.fixture(scope="module")
def tool_path():
    cap = spherical_cap(n_r=10, n_phi=36)
    n = serpentine_path(cap, 2.0, seed=5).n_points
    sp = map_to_surface(cap, serpentine_path(cap, 2.0, seed=5, pieces_at=[n // 2]))
    return smooth(sp, feed_mm_min=3000.0, period_ms=8.0, chord_tol_mm=5e-3)


def write(tool_path, post, tool_radius=0.0, chunks=None, **settings):
    buf = io.StringIO()
    info = get_post(post, settings or None).write(tool_path, buf, tool_radius=tool_radius, chunks=chunks)
    return buf.getvalue(), info


def read(text, post, rotary=None):
    return read_sinumerik(text, rotary) if post == "sinumerik" else read_rapid(text)[0]


def planned_axes(tool_path):
    """(M,) planned tool axes of the samples and (N,) of the dwell points (vertical for a 3-axis job)."""
    sa = getattr(tool_path, "sample_axes", None)
    da = getattr(tool_path.surface_path, "tool_axes", None)
    up = np.array([0.0, 0.0, 1.0])
    return (np.tile(up, (len(tool_path.samples), 1)) if sa is None else np.asarray(sa),
            np.tile(up, (len(tool_path.surface_path.xyz), 1)) if da is None else np.asarray(da))


def _held(tool_path):
    """The ToolPath with its machine samples held (a run folder keeps what regenerates them)."""
    import dataclasses

    from polishpath.smooth import iter_sample_chunks

    if len(tool_path.samples):
        return tool_path
    cs = list(iter_sample_chunks(tool_path))
    pieces = np.array([sum(len(c) for c in cs if c.piece < k) for k in range(cs[-1].piece + 2)])
    return dataclasses.replace(
        tool_path, samples=np.vstack([c.samples for c in cs]), sample_params=np.concatenate([c.sample_params for c in cs]),
        feed_mm_min=np.concatenate([c.feed_mm_min for c in cs]),
        sample_axes=None if cs[0].axes is None else np.vstack([c.axes for c in cs]), sample_pieces=pieces)


def _dist_by_time(q, tq, pts, cum):
    """Distance of points ``q`` (m, 3), planned at times ``tq`` from the piece's start, to the written path
    ``pts`` (k + 1, 3) whose ends are planned at times ``cum`` (k + 1,): the blocks around the one at that time."""
    k = len(cum) - 1
    i = np.clip(np.searchsorted(cum, tq) - 1, 0, k - 1)
    best = np.full(len(q), np.inf)
    for off in range(-1, 2):
        j = np.clip(i + off, 0, k - 1)
        a, b = pts[j], pts[j + 1]
        e = b - a
        ll = np.einsum("ij,ij->i", e, e)
        t = np.clip(np.einsum("ij,ij->i", q - a, e) / np.maximum(ll, 1e-300), 0, 1)
        best = np.minimum(best, np.linalg.norm(a + t[:, None] * e - q, axis=1))
    return best


def _slerp(a, b, f):
    """Rows of unit vectors (3 or 4 components) ``a`` to ``b`` at fractions ``f`` along their great circle."""
    b = np.where(np.einsum("ij,ij->i", a, b)[:, None] < 0, -b, b) if a.shape[1] == 4 else b  # q and -q: one frame
    om = np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1, 1))
    so = np.where(om > 1e-12, np.sin(om), 1.0)
    wa = np.where(om > 1e-12, np.sin((1 - f) * om) / so, 1 - f)
    wb = np.where(om > 1e-12, np.sin(f * om) / so, f)
    g = wa[:, None] * a + wb[:, None] * b
    return g / np.linalg.norm(g, axis=1, keepdims=True)


def _axis_by_time(tq, orient, cum):
    """The tool axis at times ``tq`` along blocks whose ends have orientations ``orient`` (k + 1, 3) axes or
    (k + 1, 4) RAPID quaternions, planned at times ``cum`` (k + 1,), at the share of the block's time (a uniform
    pace): the great circle between the end axes (Sinumerik's ORIVECT), or the robot's rotation between the end
    frames (the quaternions' great circle), whose z axis is not on the axes' great circle when the frame twists."""
    i = np.clip(np.searchsorted(cum, tq, side="right") - 1, 0, len(cum) - 2)
    f = np.clip((tq - cum[i]) / np.maximum(cum[i + 1] - cum[i], 1e-300), 0, 1)
    g = _slerp(orient[i], orient[i + 1], f)
    return g if g.shape[1] == 3 else -quat_matrix(g)[:, :, 2]


def check_program(tool_path, post, text, info, radius, time_tol=0.01, rotary=None):
    """Positions, orientations and times of the program as read back, against the plan (see the module doc)."""
    m = read(text, post, rotary)
    sp = tool_path.surface_path
    s_axes, d_axes = planned_axes(tool_path)
    driven = tool_path.samples + radius * sample_normals(tool_path)
    dw_all = sp.xyz + radius * sp.normals / np.linalg.norm(sp.normals, axis=1, keepdims=True)
    off = tool_path.sample_pieces
    runs = m.runs()
    assert len(runs) == len(off) - 1
    total = 0.0
    for k, run in enumerate(runs):
        sa, sb = off[k], off[k + 1]
        da, db = sp.planar.pieces[k], sp.planar.pieces[k + 1]
        pts, times = m.ends[run[:-1]], m.times[run[1:-1]]
        # approach and retract along the tool axis, at the piece's first and last points
        assert np.allclose(m.ends[run[0]], driven[sa], atol=RES)
        assert np.allclose(m.starts[run[0]] - m.ends[run[0]], 2.0 * s_axes[sa], atol=2 * RES)
        assert np.allclose(m.ends[run[-1]] - m.starts[run[-1]], 2.0 * s_axes[sb - 1], atol=2 * RES)
        u = tool_path.sample_params[sa:sb]
        steps = np.linalg.norm(np.diff(tool_path.samples[sa:sb], axis=0), axis=1) * 60 / tool_path.feed_mm_min[sa + 1:sb]
        tq = np.concatenate([[0.0], np.cumsum(steps)])
        dwu = tool_path.dwell_params[da:db]
        # each block end is a planned sample or dwell point (a dwell point's time linear in the parameter
        # between samples, as the schedule has it): its planned time and axis
        planned = np.concatenate([tq, np.interp(dwu, u, tq)])
        pd, pidx = cKDTree(np.vstack([driven[sa:sb], dw_all[da:db]])).query(pts)
        assert pd.max() <= 2 * RES, pd.max()
        cum_plan = planned[pidx]
        # orientations: the written axis at each block end is the planned one there
        ang = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", m.axes[run[1:-1]],
                                                     np.vstack([s_axes[sa:sb], d_axes[da:db]])[pidx[1:]]), -1, 1)))
        assert ang.max() <= AXIS_TOL_DEG, ang.max()
        # positions: every planned sample on the written path, in the block running at its planned time
        dist = _dist_by_time(driven[sa:sb], tq, pts, cum_plan)
        assert dist.max() <= info["segment_chord_tol_mm"] + 2 * RES, dist.max()
        # ... and its axis within 0.01 degree of the one the control makes there (the great circle between the
        # block ends' axes at the share of the block's time)
        got = _axis_by_time(tq, (m.axes if m.quats is None else m.quats)[run[:-1]], cum_plan)
        ang = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", got, s_axes[sa:sb]), -1, 1)))
        assert ang.max() <= AXIS_TOL_DEG, ang.max()
        # times: each block's time (as the reader derives it) is the planned time between its ends, within 1 %
        rel = np.abs(times / np.diff(cum_plan) - 1)
        assert rel.max() <= time_tol, rel.max()
        # every dwell point a block end: the time from one to the next is the schedule's
        first, last, dd = dwell_moves(pts, dw_all[da:db], 2e-4)
        assert dd.max() <= 1e-4 and (first == last + 1).all()  # a block end: (i, i - 1)
        cum = np.concatenate([[0.0], np.cumsum(times)])
        got = np.diff(cum[first])
        sched = np.diff(np.interp(dwu, u, tq))
        assert np.abs(got / sched - 1).max() <= time_tol
        assert cum[-1] == pytest.approx(tq[-1], rel=1.5e-3)
        total += times.sum()
    assert total == pytest.approx(info["path_time_s"], rel=1e-6)
    return m


# --------------------------------------------------------------------------- registry, skeleton, settings


def test_registry_has_both_posts_with_their_files():
    assert POSTS["sinumerik"].filename == "toolpath.mpf" and POSTS["abb"].filename == "toolpath.mod"
    assert "TRAORI" in POSTS["sinumerik"].description and "MoveL" in POSTS["abb"].description


@pytest.mark.parametrize("radius", [0.0, 1.5])
@pytest.mark.parametrize("post", POST_NAMES)
def test_three_axis_job_reads_back_with_a_vertical_tool(tool_path, post, radius):
    """A 3-axis job (no tool axes) is written with the tool vertical; positions, axes and times hold."""
    text, info = write(tool_path, post, radius)
    assert info["three_axis"] and info["axis_error_at_block_ends_deg"] == 0.0
    m = check_program(tool_path, post, text, info, radius)
    assert np.allclose(m.axes, [0, 0, 1], atol=1e-9)
    assert "3-AXIS JOB: the tool axis is vertical" in text
    assert ("TOOL POINT: the centre of the ball/sponge tool, 1.5 mm" in text) == (radius > 0)


def test_sinumerik_program_in_order(tool_path):
    text, info = write(tool_path, "sinumerik")
    code = [ln for ln in text.splitlines() if not ln.startswith(";")]
    assert code[:8] == ["G90 G71 G17 G94", "G40 G54", "TRAORI", "ORIWKS", "ORIVECT", "CYCLE832(0.005, 11, 0.005)",
                        "M3 S230", "M8"]
    assert code[8].startswith("G0 Z") and code[9].startswith("G0 X") and " A3=0 B3=0 C3=1" in code[9]
    assert code[-4:] == ["CYCLE832(0, 0, 1)", "TRAFOOF", "M5 M9", "M30"]
    # G93 on the path, every block with its F; G94 with the approach feed around it
    g93 = [i for i, ln in enumerate(code) if ln == "G93"]
    assert len(g93) == info["pieces"] == 2
    assert all(code[i - 1].startswith("G94 G1 ") and code[i - 1].endswith(" F300") for i in g93)
    path = [ln for ln in code if ln[0] in "XYZA"]
    assert len(path) == info["motion_blocks"] and all(" F" in ln or ln.startswith("F") for ln in path)
    # tolerance and orientation tolerance from the settings
    text2, _ = write(tool_path, "sinumerik", contour_tol_mm=0.002, orientation_tol_deg=0.05, cycle832_mode=14)
    assert "\nCYCLE832(0.002, 14, 0.05)\n" in text2
    assert "; ORIENTATION: A3 B3 C3 = the tool's direction vector" in text and "FEED: G93 inverse time" in text


def test_rapid_module_in_order(tool_path):
    text, info = write(tool_path, "abb", tool="tSponge", wobj="wobjLens", module="lens1", io_on="SetDO doSpin, 1;",
                       io_off="SetDO doSpin, 0;")
    m, got = read_rapid(text)
    assert got["module"] == "lens1" and got["tools"] == {"tSponge"} and got["wobjs"] == {"wobjLens"}
    name, z = got["zonedata"]
    assert name == "zPolish" and z[0] == pytest.approx(info["segment_chord_tol_mm"])
    assert got["zones"] == {"zPolish", "fine"}
    code = [ln.strip() for ln in text.splitlines() if not ln.strip().startswith("!")]
    assert code[2:5] == ["PROC main()", "ConfL\\Off;", "SingArea\\Wrist;"] and code[5] == "SetDO doSpin, 1;"
    assert code[-3:] == ["SetDO doSpin, 0;", "ENDPROC", "ENDMODULE"]
    assert int(np.count_nonzero(m.rapid)) == 3 * info["pieces"]  # above the approach point, down to it, up
    assert text.count("    MoveJ ") == 2 * info["pieces"]  # at the clearance height only
    assert "0.0009" in text and ",.0" not in text and "[.0" not in text  # RAPID numbers keep their leading zero


@pytest.mark.parametrize("post, bad, words", [
    ("sinumerik", {"spindle": 3}, "unknown post setting"),
    ("sinumerik", {"orientation_tol_deg": -1.0}, "orientation_tol_deg must be a number of degrees"),
    ("sinumerik", {"orientation": "euler"}, "orientation must be 'vector'"),
    ("sinumerik", {"orientation": "angles"}, "no machine profile with kinematics"),
    ("sinumerik", {"cycle832_mode": 7}, "cycle832_mode must be"),
    ("sinumerik", {"contour_tol_mm": 0.0}, "contour_tol_mm must be a tolerance"),
    ("sinumerik", {"arcs": True}, "arcs must be false"),
    ("sinumerik", {"feed_mode": "per-minute"}, None),
    ("sinumerik", {"word_separator": ""}, "word_separator must be"),
    ("abb", {"tool": "1tool"}, "tool must be a RAPID name"),
    ("abb", {"wobj": "wobj part"}, "wobj must be a RAPID name"),
    ("abb", {"spindle_rpm": 100.0}, "spindle_rpm is a G-code setting"),
    ("abb", {"feed_mode": "inverse-time"}, "no inverse-time feed"),
    ("abb", {"zone_ori_deg": 0}, "zone_ori_deg must be a number > 0"),
    ("abb", {"decimals": 12}, "decimals must be a whole number"),
])
def test_bad_settings_are_refused_by_name(tool_path, post, bad, words):
    with pytest.raises(ParameterError, match=words or "G93 inverse-time feed only"):
        write(tool_path, post, **bad)


@pytest.mark.parametrize("post", POST_NAMES)
def test_chunked_samples_write_the_same_bytes(tool_path, post):
    text, _ = write(tool_path, post, 1.5)
    assert write(tool_path, post, 1.5, chunks=sample_chunks(tool_path, 97))[0] == text


# --------------------------------------------------------------------------- the robot's tool frame


def _axes_walk(n=4000, seed=2):
    """A smooth random walk of unit axes over the upper half-sphere and past the rim (tilt up to ~100 deg)."""
    rng = np.random.default_rng(seed)
    th = np.radians(50 + 50 * np.sin(np.cumsum(rng.normal(0, 0.02, n))))
    ph = np.cumsum(rng.normal(0, 0.05, n))
    return np.column_stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])


def test_tool_frame_points_down_the_axis_and_turns_continuously():
    a = np.vstack([_axes_walk(), [[0, 0, 1], [1, 0, 0], [0, -1, 0], [0.6, 0, -0.8]]])
    q = tool_quaternions(a)
    assert np.allclose(np.linalg.norm(q, axis=1), 1, atol=1e-12) and (q[:, 1] > 0).all()
    R = quat_matrix(q)
    assert np.allclose(-R[:, :, 2], a, atol=1e-12)  # the frame's z axis points from the spindle into the part
    assert np.allclose(R[-4], np.diag([1, -1, -1]), atol=1e-12)  # vertical tool: x along X, pointing down
    walk = _axes_walk()
    R = quat_matrix(tool_quaternions(walk))
    turn = rotation_angles_deg(R[:-1], R[1:])
    axis_turn = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", walk[:-1], walk[1:]), -1, 1)))
    # no flips: the frame turns by at most 1 / cos(tilt / 2) of the axis' own turn (up to ~1.6x at 100 deg)
    assert (turn <= 1.7 * axis_turn + 1e-9).all(), (turn / np.maximum(axis_turn, 1e-12)).max()
    assert np.allclose(quaternion_angles_deg(q[:-4][:-1], q[:-4][1:]), turn, atol=1e-6)


def test_a_tool_axis_pointing_down_is_refused(tool_path):
    post = get_post("abb")
    down = np.array([[np.sin(np.radians(MAX_TILT_DEG + 1)), 0, np.cos(np.radians(MAX_TILT_DEG + 1))]])
    with pytest.raises(ParameterError, match="120 degrees or more from the part's Z"):
        post.check_axes(down)
    post.check_axes(np.array([[1.0, 0, 0]]))


# --------------------------------------------------------------------------- from the command line


@pytest.mark.parametrize("post, table, words", [
    ("sinumerik", "orientation_tol_deg = -1.0", "orientation_tol_deg must be a number of degrees"),
    ("sinumerik", 'orientation = "angles"', "no machine profile with kinematics"),
    ("sinumerik", 'feed_mode = "per-minute"', "G93 inverse-time feed only"),
    ("abb", 'tool = "1x"', "tool must be a RAPID name"),
    ("abb", "spindle_rpm = 100.0", "spindle_rpm is a G-code setting"),
    ("abb", "spindle = 1", "unknown post setting"),
])
def test_bad_settings_in_a_job_file_exit_2_naming_them(tmp_path, post, table, words):
    import subprocess
    import sys

    job = tmp_path / "job.toml"
    job.write_text(f'[job]\nsurface = "hemisphere:R=12,triangles=700"\nspacing = 2.0\nseed = 4\npost = "{post}"\n\n'
                   f"[post]\n{table}\n")
    r = subprocess.run([sys.executable, "-m", "polishpath", "plan", "--no-report", "-q", "--config", str(job), "-o",
                        str(tmp_path / "out")], capture_output=True, text=True)
    assert r.returncode == 2 and words in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("law, tilt", [("normal", 0.0), ("tilted:angle=20", 20.0)])
@pytest.mark.parametrize("post", POST_NAMES)
def test_hemisphere_with_tool_axes_reads_back(tmp_path, post, law, tilt):
    """The hemisphere through the command line with --tool-axis normal and tilted:angle=20: the files read back
    with every position, axis (within 0.01 degree of the plan, so ``tilt`` from the normal) and time."""
    import json
    import subprocess
    import sys

    from polishpath.runfolder import read_run

    out = tmp_path / "run"
    r = subprocess.run([sys.executable, "-m", "polishpath", "plan", "hemisphere", "--spacing", "3", "--seed", "1",
                        "--tool-axis", law, "--post", post, "--no-report", "-q", "-o", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    text = (out / POSTS[post].filename).read_text()
    info = json.loads((out / "summary.json").read_text())["post"]
    assert not info["three_axis"] and info["tool_axis"].startswith(law) and info["file"] == POSTS[post].filename
    tp = _held(read_run(out).tool_path)  # the run's own plan, as its folder records it
    assert tp.sample_axes is not None and tp.surface_path.tool_axes is not None
    m = check_program(tp, post, text, info, 0.0)
    # the written axes keep the law's angle from the surface normal at every block end
    sp = tp.surface_path
    normals = np.vstack([sample_normals(tp), sp.normals / np.linalg.norm(sp.normals, axis=1, keepdims=True)])
    path = np.concatenate([run[1:-1] for run in m.runs()])  # the path's block ends (approach, retract left out)
    _, idx = cKDTree(np.vstack([tp.samples, sp.xyz])).query(m.ends[path])
    ang = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", m.axes[path], normals[idx]), -1, 1)))
    assert np.abs(ang - tilt).max() <= AXIS_TOL_DEG + 1e-3, np.abs(ang - tilt).max()


@pytest.mark.parametrize("kind", ["xyzac-trt", "xyzbc-trt"])
def test_sinumerik_writes_the_rotary_axes_of_a_named_kinematics(tmp_path, kind):
    """orientation = "angles" with --machine (its kinematics, its feed schedule): the rotary axes' positions
    (ORIAXES), read back through the kinematics' own axis formula: positions, axes and times as for the vectors."""
    import json
    import subprocess
    import sys

    from polishpath.runfolder import read_run

    job = tmp_path / "job.toml"
    job.write_text('[job]\nsurface = "hemisphere"\nspacing = 4.0\nseed = 1\ntool_axis = "normal"\n'
                   f'machine = "{kind}"\npost = "sinumerik"\n\n[post]\norientation = "angles"\n')
    out = tmp_path / "run"
    r = subprocess.run([sys.executable, "-m", "polishpath", "plan", "--no-report", "-q", "--config", str(job),
                        "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    text = (out / "toolpath.mpf").read_text()
    info = json.loads((out / "summary.json").read_text())["post"]
    assert "\nORIAXES\n" in text and "ORIVECT" not in text and "A3=" not in text
    assert info["orientation_words"] == (["A", "C"] if kind == "xyzac-trt" else ["B", "C"])
    check_program(_held(read_run(out).tool_path), "sinumerik", text, info, 0.0, rotary=kind)


def test_sinumerik_angles_need_the_kinematics(tool_path):
    with pytest.raises(ParameterError, match="no machine profile with kinematics"):
        write(tool_path, "sinumerik", orientation="angles")
