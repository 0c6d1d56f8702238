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
from polishpath.smooth import dwell_regions, sample_normals, smooth
from gcode_helpers import delivered_region_times, dwell_moves, points_at_params
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


def read(text, post):
    return read_sinumerik(text) if post == "sinumerik" else read_rapid(text)[0]


def planned_axes(tool_path):
    """(M,) planned tool axes of the samples and (N,) of the dwell points (vertical for a 3-axis job)."""
    sa = getattr(tool_path, "sample_axes", None)
    da = getattr(tool_path.surface_path, "tool_axes", None)
    up = np.array([0.0, 0.0, 1.0])
    return (np.tile(up, (len(tool_path.samples), 1)) if sa is None else np.asarray(sa),
            np.tile(up, (len(tool_path.surface_path.xyz), 1)) if da is None else np.asarray(da))


def _dist_by_time(q, tq, pts, times):
    """Distance of points ``q`` (m, 3), planned at times ``tq`` from the piece's start, to the written path
    ``pts`` (k + 1, 3) run in ``times`` (k,): the blocks around the one running at that time."""
    cum = np.concatenate([[0.0], np.cumsum(times)])
    i = np.clip(np.searchsorted(cum, tq) - 1, 0, len(times) - 1)
    best = np.full(len(q), np.inf)
    for off in range(-3, 4):
        j = np.clip(i + off, 0, len(times) - 1)
        a, b = pts[j], pts[j + 1]
        e = b - a
        ll = np.einsum("ij,ij->i", e, e)
        t = np.clip(np.einsum("ij,ij->i", q - a, e) / np.maximum(ll, 1e-300), 0, 1)
        best = np.minimum(best, np.linalg.norm(a + t[:, None] * e - q, axis=1))
    return best


def check_program(tool_path, post, text, info, radius, time_tol=0.01):
    """Positions, orientations and times of the program as read back, against the plan (see the module doc)."""
    m = read(text, post)
    sp = tool_path.surface_path
    s_axes, d_axes = planned_axes(tool_path)
    driven = tool_path.samples + radius * sample_normals(tool_path)
    dw_all = sp.xyz + radius * sp.normals / np.linalg.norm(sp.normals, axis=1, keepdims=True)
    off = np.asarray(tool_path.sample_pieces)
    runs = m.runs()
    assert len(runs) == len(off) - 1
    # the planned points a block may end at (samples and dwell points) with their planned axes
    tree = cKDTree(np.vstack([driven, dw_all]))
    all_axes = np.vstack([s_axes, d_axes])
    total = 0.0
    for k, run in enumerate(runs):
        sa, sb = off[k], off[k + 1]
        da, db = sp.planar.pieces[k], sp.planar.pieces[k + 1]
        pts, times = m.ends[run[:-1]], m.times[run[1:-1]]
        # approach and retract along the tool axis, at the piece's first and last points
        assert np.allclose(m.ends[run[0]], driven[sa], atol=RES)
        assert np.allclose(m.starts[run[0]] - m.ends[run[0]], 2.0 * s_axes[sa], atol=2 * RES)
        assert np.allclose(m.ends[run[-1]] - m.starts[run[-1]], 2.0 * s_axes[sb - 1], atol=2 * RES)
        # positions: every planned sample on the written path, in time
        u = tool_path.sample_params[sa:sb]
        steps = np.linalg.norm(np.diff(tool_path.samples[sa:sb], axis=0), axis=1) * 60 / tool_path.feed_mm_min[sa + 1:sb]
        tq = np.concatenate([[0.0], np.cumsum(steps)])
        dist = _dist_by_time(driven[sa:sb], tq, pts, times)
        assert dist.max() <= info["segment_chord_tol_mm"] + 2 * RES, dist.max()
        # orientations: each block end is a planned sample or dwell point; its axis is the planned one there
        d, idx = tree.query(pts[1:])
        assert d.max() <= 2 * RES, d.max()
        ang = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", m.axes[run[1:-1]], all_axes[idx]), -1, 1)))
        assert ang.max() <= AXIS_TOL_DEG, ang.max()
        # times: around every dwell point within its tolerance (its region, as the schedule cuts them)
        t = np.cumsum(np.concatenate([[0.0], steps]))
        rb = dwell_regions(tool_path.dwell_params[da:db], u[0], u[-1])
        sched = np.diff(np.interp(rb, u, t))
        bq = points_at_params(driven[sa:sb], u, rb[1:-1])
        got = delivered_region_times(pts, times, dw_all[da:db], bq)
        rel = np.abs(got / sched - 1)
        assert rel.max() <= time_tol, rel.max()
        assert got.sum() == pytest.approx(sched.sum(), rel=1.5e-3)
        first, last, dd = dwell_moves(pts, dw_all[da:db], 2e-4)
        assert dd.max() <= 1e-4
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
    assert info["three_axis"] and info["max_axis_dev_deg"] == 0.0
    m = check_program(tool_path, post, text, info, radius)
    assert np.allclose(m.axes, [0, 0, 1], atol=1e-9)
    assert "3-AXIS JOB: the tool axis is vertical" in text
    assert ("TOOL POINT: the centre of the ball/sponge tool, 1.5 mm" in text) == (radius > 0)


def test_sinumerik_program_in_order(tool_path):
    text, info = write(tool_path, "sinumerik")
    code = [ln for ln in text.splitlines() if not ln.startswith(";")]
    assert code[:8] == ["G90 G71 G17 G94", "G40 G54", "TRAORI", "ORIWKS", "ORIVECT", "CYCLE832(0.005, 11, 0.01)",
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
    text2, _ = write(tool_path, "sinumerik", contour_tol_mm=0.002, ori_tol_deg=0.05, cycle832_mode=14)
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
    ("sinumerik", {"ori_tol_deg": -1.0}, "ori_tol_deg must be an angle"),
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
