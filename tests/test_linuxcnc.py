"""The G-code checked by LinuxCNC's own interpreter, rs274 (issue 16, item 4).

rs274 comes from Debian's linuxcnc-uspace, fetched and unpacked by
``scripts/get-linuxcnc.sh`` (``make test`` runs it); where it cannot be had these
tests skip with that reason.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from conftest import shared_mesh_path
from polishpath.export import read_path_csv, read_xyz, write_gcode
from polishpath.export.post import planned_segment_times
from polishpath.smooth import sample_normals
from rs274_helpers import parse_canon, rs274  # noqa: F401  (fixture)

RES = 0.5e-4 + 1e-9  # the file's and the canonical output's 4-decimal resolution, mm


def _plan(out, *args):
    cmd = [sys.executable, "-m", "polishpath", "plan", *args, "--no-report", "--quiet", "-o", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.fixture(scope="module")
def small_job(tmp_path_factory):
    return _plan(tmp_path_factory.mktemp("job") / "run", "hemisphere:R=12,triangles=3000", "--spacing", "1.5",
                 "--seed", "11")


def test_canonical_parser_reads_moves_feeds_and_modes():
    text = "\n".join([
        "    1 N..... SET_FEED_RATE(600.0000)",
        "    2 N..... STRAIGHT_TRAVERSE(0.0000, 0.0000, 10.0000, 0.0000, 0.0000, 0.0000)",
        "    3 N..... STRAIGHT_FEED(3.0000, 4.0000, 10.0000, 0.0000, 0.0000, 0.0000)",
        '    4 N..... COMMENT("interpreter: feed mode set to inverse time")',
        "    5 N..... SET_FEED_RATE(60.0000)",
        "    6 N..... STRAIGHT_FEED(3.0000, 4.0000, 11.0000, 0.0000, 0.0000, 0.0000)",
    ])
    c = parse_canon(text)
    assert c.names()[:3] == ["SET_FEED_RATE", "STRAIGHT_TRAVERSE", "STRAIGHT_FEED"]
    assert np.array_equal(c.feeds, [[3, 4, 10], [3, 4, 11]])
    assert np.array_equal(c.starts, [[0, 0, 10], [3, 4, 10]])
    assert list(c.inverse_time) == [False, True]
    assert np.allclose(c.segment_times(), [60 * 5 / 600, 60 * 1 / 60])
    bad = parse_canon("", 1, "executing\nUnknown g code used\nG06.2 P4")
    assert not bad.ok and bad.errors[0] == "Unknown g code used"


def _path_moves(canon, arcs: bool = False):
    """Per run of feed moves (one piece): the path points (approach end = first sample ... last sample)
    and the times of the moves between them; the approach and retract moves themselves left out.
    ``arcs``: also the moves' arc centres and turns (NaN and 0 for straight moves)."""
    pts, times, centres, turns = [], [], [], []
    t = canon.segment_times()
    for g in np.unique(canon.group):
        idx = np.flatnonzero(canon.group == g)
        pts.append(canon.feeds[idx[:-1]])  # the last move of a run is the retract
        times.append(t[idx[1:-1]])
        centres.append(canon.centres[idx[1:-1]])
        turns.append(canon.turns[idx[1:-1]])
    return (pts, times, centres, turns) if arcs else (pts, times)


def test_rs274_reads_the_linear_gcode_of_a_small_job(rs274, small_job):
    import json

    canon = rs274(small_job / "toolpath.nc")
    assert canon.ok, canon.errors[:5]
    samples = read_xyz(small_job / "toolpath.xyz")
    dwell = read_path_csv(small_job / "path.csv")
    dwell = np.column_stack([dwell["x"], dwell["y"], dwell["z"]])
    post = json.loads((small_job / "summary.json").read_text())["post"]
    pts, _ = _path_moves(canon)
    ends = np.vstack(pts)
    # chord-tolerance blocks: far fewer than the samples, every dwell point one of their end points, in order
    assert len(dwell) < len(ends) < 0.9 * len(samples) and post["motion_blocks"] == len(ends) - len(pts)
    # helical arcs among them (G02/G03: rs274's ARC_FEED), as the summary counts them
    assert 0 < post["arc_blocks"] == int(np.count_nonzero(canon.turns)) and post["arcs"]
    assert "ARC_FEED" in canon.names()
    hits = [int(np.argmin(np.linalg.norm(ends - d, axis=1))) for d in dwell]
    assert max(np.linalg.norm(ends[h] - d) for h, d in zip(hits, dwell)) <= RES * np.sqrt(3)
    assert np.all(np.diff(hits) > 0)
    # and every block end lies on the sampled path (within the chord tolerance + the resolution)
    a, b = samples[:-1], samples[1:]
    e = b - a
    ll = np.maximum(np.einsum("ij,ij->i", e, e), 1e-300)
    far = 0.0
    for q in ends[:: max(1, len(ends) // 400)]:
        t = np.clip(np.einsum("ij,ij->i", q - a, e) / ll, 0, 1)
        far = max(far, float(np.min(np.linalg.norm(a + t[:, None] * e - q, axis=1))))
    assert far <= 0.001 + RES * np.sqrt(3)


@pytest.fixture(scope="module", params=["hemisphere", "lilium", "flat"])
def job(request):
    """Small jobs: curved parts (every dwell point a block end) and a flat one (blocks pass through dwell points)."""
    from polishpath.pipeline import run

    if request.param == "hemisphere":
        return run(surface="hemisphere:R=12,triangles=3000", spacing=1.5, seed=11, report=False)
    if request.param == "flat":
        return run(surface="sinusoidal:amplitude=0,size=14,triangles=800", spacing=0.5, seed=3, report=False)
    mesh = shared_mesh_path("lilium.obj")
    return run(surface=str(mesh), scale=20.0, spacing=1.5, seed=3, report=False)


@pytest.mark.parametrize("radius, machine", [(0.0, None), (5.0, None), (0.0, "gentle"), (5.0, "gentle")])
def test_rs274_runs_every_move_with_its_planned_time_at_the_fixed_period(rs274, job, radius, machine, tmp_path):
    tp = job.tool_path
    if machine:
        from conftest import REPO
        from polishpath.schedule import load_machine, schedule_feeds

        tp = schedule_feeds(tp, load_machine(REPO / "examples" / f"machine-{machine}.toml"))[0]
        assert not np.array_equal(tp.feed_mm_min, job.tool_path.feed_mm_min)
    f = tmp_path / "toolpath.nc"
    info = write_gcode(tp, f, tool_radius=radius, segmenting="period")
    assert info["feed_mode"] == ("inverse-time" if radius else "per-minute")
    canon = rs274(f)
    assert canon.ok, canon.errors[:5]
    driven = tp.samples + radius * sample_normals(tp)  # tool centre (or contact point)
    off = tp.sample_pieces
    pts, times = _path_moves(canon)
    assert len(pts) == len(off) - 1
    dt = planned_segment_times(tp)
    for k, (a, b) in enumerate(zip(off[:-1], off[1:])):
        # STRAIGHT_FEED end points are the driven points, to the file's resolution ...
        assert pts[k].shape == (b - a, 3)
        assert np.abs(pts[k] - driven[a:b]).max() <= RES
        # ... and each move takes its planned time (from the contact-point schedule) to 0.1 % (+ 0.1 % in G94,
        # where F is left out while the feed is within feed_resolution of the F in force)
        assert np.abs(times[k] / dt[a + 1 : b] - 1).max() <= (1e-3 if radius else 2e-3)
    assert canon.segment_times().sum() == pytest.approx(info["machining_time_s"], rel=1e-4)


@pytest.mark.parametrize("radius, machine, arcs", [(0.0, None, True), (5.0, None, True), (0.0, "gentle", True),
                                                  (0.0, None, False)])
def test_rs274_spends_the_scheduled_time_around_every_dwell_point(rs274, job, radius, machine, arcs, tmp_path):
    """The chord-tolerance blocks (lines and helical arcs) as LinuxCNC reads them: each dwell point's region
    within 1 % of its schedule, every arc's time its helix's length at the F in force."""
    from gcode_helpers import delivered_region_times, dwell_moves, points_at_params
    from polishpath.smooth import dwell_regions

    tp = job.tool_path
    passed = 0
    if machine:
        from conftest import REPO
        from polishpath.schedule import load_machine, schedule_feeds

        tp = schedule_feeds(tp, load_machine(REPO / "examples" / f"machine-{machine}.toml"))[0]
    f = tmp_path / "toolpath.nc"
    info = write_gcode(tp, f, tool_radius=radius, arcs=arcs)
    assert info["segmenting"] == "chord" and info["motion_blocks"] < 0.9 * len(tp.samples)
    canon = rs274(f)
    assert canon.ok, canon.errors[:5]
    assert (info["arc_blocks"] > 0.1 * info["motion_blocks"]) == arcs
    assert info["arc_blocks"] == int(np.count_nonzero(canon.turns))
    pts, times, centres, turns = _path_moves(canon, arcs=True)
    sp = tp.surface_path
    off, doff = tp.sample_pieces, sp.planar.pieces
    dt = planned_segment_times(tp)
    driven = tp.samples + radius * sample_normals(tp)
    worst = 0.0
    for k, (a, b) in enumerate(zip(off[:-1], off[1:])):
        t = np.cumsum(dt[a:b])
        u = tp.sample_params[a:b]
        da, db = doff[k], doff[k + 1]
        rb = dwell_regions(tp.dwell_params[da:db], u[0], u[-1])
        sched = np.diff(np.interp(rb, u, t))
        bq = points_at_params(driven[a:b], u, rb[1:-1])  # where the schedule places each region boundary
        dw = sp.xyz[da:db] + radius * sp.normals[da:db]
        got = delivered_region_times(pts[k], times[k], dw, bq, centres=centres[k], turns=turns[k])
        worst = max(worst, float(np.abs(got / sched - 1).max()))
        first, last, dist = dwell_moves(pts[k], dw, 2e-4, centres[k], turns[k])
        assert dist.max() <= 1e-4 + RES  # every dwell point on the path as rs274 runs it (4 decimals)
        passed += int(np.count_nonzero(first == last))
    assert worst <= 0.01 + 2e-4  # time_tol; rs274 prints F to 4 decimals
    flat = np.ptp(tp.samples[:, 2]) == 0
    # blocks pass through dwell points on the flat part (arcs through them; helices on a curved part rarely)
    assert (passed > 0.2 * len(sp.xyz)) == (flat and arcs)
    # and the whole program's time as rs274 derives it is the post's machining time
    assert canon.segment_times().sum() == pytest.approx(info["machining_time_s"], rel=1e-4)


def test_rs274_sees_blending_spindle_slurry_approach_and_retract_in_order(rs274, job, tmp_path):
    tp = job.tool_path
    f = tmp_path / "toolpath.nc"
    write_gcode(tp, f, tool_radius=5.0, segmenting="period")  # one block per sample: counted below
    canon = rs274(f)
    names = canon.names()
    first_move = names.index("STRAIGHT_TRAVERSE")
    mcm = [a for n, a in canon.calls if n == "SET_MOTION_CONTROL_MODE"]
    assert mcm == ["CANON_CONTINUOUS, 0.001000"]  # G64 P<chord tol>, the smoothing stage's 1 um
    assert names.index("SET_MOTION_CONTROL_MODE") < first_move
    assert canon.args("SET_SPINDLE_SPEED") == [[0, 230]]
    assert names.index("SET_SPINDLE_SPEED") < names.index("START_SPINDLE_CLOCKWISE") < first_move
    assert names.index("FLOOD_ON") < first_move
    last_feed = len(names) - 1 - names[::-1].index("STRAIGHT_FEED")
    assert names.index("STOP_SPINDLE_TURNING", last_feed) > last_feed
    assert names.index("FLOOD_OFF", last_feed) > last_feed and "PROGRAM_END" in names[last_feed:]
    # per piece: rapid up to the clearance plane, across, down to the approach point; feed along the
    # normal onto the part at the approach feed; ... ; feed back along the normal; rapid up
    normals = sample_normals(tp)
    off = tp.sample_pieces
    moves = [(n, np.array([float(v) for v in a.split(",")[:3]])) for n, a in canon.calls
             if n in ("STRAIGHT_FEED", "STRAIGHT_TRAVERSE")]
    kinds = "".join("F" if n == "STRAIGHT_FEED" else "T" for n, _ in moves)
    runs = kinds.split("T")
    assert kinds.startswith("TTT") and kinds.endswith("FT") and kinds.count("TTT") == len(off) - 1
    assert [len(r) for r in runs if r] == [b - a + 1 for a, b in zip(off[:-1], off[1:])]
    safe = moves[0][1][2]
    pos = 0
    for a, b in zip(off[:-1], off[1:]):
        up, across, down = (m[1] for m in moves[pos : pos + 3])
        assert up[2] == safe and across[2] == safe and down[2] < safe
        approach_end = moves[pos + 3][1]
        d = approach_end - down
        assert np.linalg.norm(d) == pytest.approx(2.0, abs=2e-4)
        assert np.abs(-d / np.linalg.norm(d) - normals[a]).max() < 1e-3  # down along the normal
        retract_end = moves[pos + 3 + (b - a)][1]
        r = retract_end - moves[pos + 2 + (b - a)][1]
        assert np.abs(r / np.linalg.norm(r) - normals[b - 1]).max() < 1e-3  # back out along the normal
        assert moves[pos + 4 + (b - a)][0] == "STRAIGHT_TRAVERSE" and moves[pos + 4 + (b - a)][1][2] == safe
        pos += 5 + (b - a)
    rates = canon.args("SET_FEED_RATE")
    assert [300.0] in rates  # the approach feed


def test_linuxcnc_is_refused_nurbs_which_rs274_cannot_read(rs274, small_job, tmp_path):
    r = subprocess.run([sys.executable, "-m", "polishpath", "plan", "hemisphere:R=12,triangles=700", "--spacing", "2",
                        "--seed", "1", "--gcode", "nurbs", "--no-report", "-q", "-o", str(tmp_path / "o")],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "LinuxCNC cannot run G06.2" in r.stderr and "--post fanuc" in r.stderr
    assert "Traceback" not in r.stderr
    out = _plan(tmp_path / "fanuc", "hemisphere:R=12,triangles=700", "--spacing", "2", "--seed", "1", "--post", "fanuc")
    text = (out / "toolpath.nc").read_text()
    assert "\nG06.2P4K" in text and "FANUC 15i/30i-CLASS" in text
    # why: LinuxCNC's interpreter stops at the first G06.2 block
    canon = rs274(out / "toolpath.nc")
    assert not canon.ok and any("Unknown g code" in e for e in canon.errors)
