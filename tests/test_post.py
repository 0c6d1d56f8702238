"""Post-processors (issue 16, items 1 and 2): registry, settings, the program skeleton, feeds with a tool offset.

LinuxCNC's own interpreter reads these files in test_linuxcnc.py; here the files
are parsed by two third-party G-code parsers and by a Fanuc-format check written
from the Fanuc G06.2 NURBS interpolation format.
"""

from __future__ import annotations

import io
import re

import numpy as np
import pytest

from polishpath._version import __version__ as VERSION
from polishpath.errors import ParameterError
from polishpath.export import POSTS, get_post, read_path_csv, read_xyz, write_gcode, write_path_csv, write_program, write_xyz
from polishpath.export.post import PostSettings, planned_segment_times, post_help
from polishpath.mapping import map_to_surface
from polishpath.smooth import dwell_regions, evaluate, sample_normals, smooth
from polishpath.types import NurbsCurve
from gcode_helpers import arc_points, moves_gcodeparser, moves_pygcode
from test_mapping_helpers import serpentine_path, spherical_cap

RES = 0.5e-4 + 1e-12  # half the 4-decimal coordinate resolution, mm
FEED_RES = 1e-3  # the default feed_resolution: a block without F runs at most this far off its planned time


@pytest.fixture(scope="module")
def tool_path():
    cap = spherical_cap(n_r=10, n_phi=36)
    path = serpentine_path(cap, 2.0, seed=5)
    n = path.n_points
    # two pieces, so the lift between them is written too
    path = serpentine_path(cap, 2.0, seed=5, pieces_at=[n // 2])
    sp = map_to_surface(cap, path)
    return smooth(sp, feed_mm_min=3000.0, period_ms=8.0, chord_tol_mm=5e-3)


def _words(line: str) -> dict[str, float]:
    """The address words of one block (with or without spaces between them), letter -> value."""
    return {L: float(v) for L, v in re.findall(r"([A-Z])([-+]?\d*\.?\d*)", line)}


@pytest.fixture(scope="module")
def flat_path():
    """A pseudo-random path on a flat square (z = 0): where blocks may pass through dwell points."""
    from polishpath.pipeline import run

    return run(surface="sinusoidal:amplitude=0,size=14,triangles=800", spacing=0.5, seed=3, report=False).tool_path


def _lines(text: str) -> list[str]:
    return [ln for ln in text.splitlines() if ln and not ln.startswith("(") and ln != "%"]


def _gcode(tool_path, **kw) -> str:
    buf = io.StringIO()
    write_gcode(tool_path, buf, **kw)
    return buf.getvalue()


def _path_runs(text: str):
    """Per piece, by gcodeparser: the path's points (approach end, then every path block's end) and the
    path blocks' F, G93 flags and times as the controller derives them (approach and retract left out)."""
    m = moves_gcodeparser(text)
    t = m.times()
    out = []
    for run in m.runs():
        out.append((m.ends[run[:-1]], m.feed[run[1:-1]], m.inverse[run[1:-1]], t[run[1:-1]]))
    return out


def _path_arcs(text: str):
    """Per piece, by gcodeparser: the path blocks' arc centres (NaN: straight) and turns (0 straight, +1 G03,
    -1 G02), as :func:`_path_runs` orders them."""
    m = moves_gcodeparser(text)
    return [(m.centres[run[1:-1]], m.turns[run[1:-1]]) for run in m.runs()]


def _pieces_of(tool_path):
    off = np.asarray(tool_path.sample_pieces)
    return list(zip(off[:-1], off[1:]))


# --------------------------------------------------------------------------- registry and settings


def test_registry_lists_every_post_with_its_help():
    assert set(POSTS) == {"linuxcnc", "fanuc", "xyz", "csv", "sinumerik", "abb"}
    h = post_help()
    assert "Fanuc 15i/30i" in h and "NURBS" in h and "LinuxCNC" in h
    with pytest.raises(ParameterError, match="linuxcnc, fanuc, xyz, csv, sinumerik, abb"):
        get_post("heidenhain")
    assert get_post().name == "linuxcnc" and get_post("fanuc").modes[0] == "nurbs"


@pytest.mark.parametrize("bad, words", [
    ({"spindle": 3}, "unknown post setting"),
    ({"clearance_mm": -1.0}, "clearance_mm must be a number >= 0"),
    ({"approach_feed_mm_min": 0.0}, "approach_feed_mm_min must be > 0"),
    ({"feed_mode": "fast"}, "feed_mode must be one of auto, inverse-time, per-minute"),
    ({"decimals": 12}, "decimals must be a whole number"),
    ({"program_number": 0}, "program_number"),
    ({"preamble": 5}, "preamble must be text"),
    ({"anchor_blocks": 0}, "anchor_blocks must be a whole number of blocks >= 1"),
    ({"incremental": "yes"}, "incremental must be true or false"),
    ({"radius_arcs": 1}, "radius_arcs must be true or false"),
])
def test_bad_settings_are_refused_by_name(bad, words):
    with pytest.raises(ParameterError, match=words):
        get_post("linuxcnc", bad)


def test_settings_override_the_controller_defaults(tool_path):
    s = get_post("linuxcnc", {"spindle_rpm": 120, "coolant_on": "M7", "clearance_mm": 9.0}).settings
    assert s.spindle_rpm == 120 and s.blending == "G64 P{tol}" and s.safety_block == "G40 G49 G80 G54"
    assert get_post("fanuc").settings.blending == "" and get_post("fanuc").settings.program_number == 1
    text = _gcode(tool_path, spindle_rpm=120, coolant_on="M7", clearance_mm=9.0)
    assert "M3 S120\n" in text and "M7\n" in text and "M8" not in text
    none = _gcode(tool_path, spindle_rpm=0, coolant_on="", comments=False)
    assert "\nM3 S" not in none and "\nM8\n" not in none and "(" not in none
    assert set(PostSettings.names()) >= {"preamble", "safety_block", "spindle_rpm", "clearance_mm", "feed_mode"}


# --------------------------------------------------------------------------- linuxcnc skeleton


def test_linuxcnc_program_in_order(tool_path):
    text = _gcode(tool_path, header={"surface": "cap", "seed": 5, "params": {"pattern": "raster"}})
    assert text.startswith("%\n") and text.endswith("M5 M9\nM30\n%\n")
    assert f"polishpath {VERSION}" in text and "(seed: 5)" in text and "params.pattern: raster" in text
    assert "COORDINATES: TOOL-PART CONTACT POINT" in text and "FEED: G94" in text
    assert "(segmenting: chord)" in text and "(coordinate_resolution_mm: 0.0001)" in text and "(arcs: True)" in text
    assert max(len(ln) for ln in text.splitlines()) <= 256  # LinuxCNC reads at most 256 characters a line
    body = _lines(text)
    assert body[:5] == ["G21 G90 G17 G94", "G40 G49 G80 G54", "G64 P0.005000", "M3 S230", "M8"]
    pieces = _pieces_of(tool_path)
    normals = sample_normals(tool_path)
    i = 5
    for a, b in pieces:
        # clearance plane, above the approach point, down to it, then along the normal onto the part
        assert body[i].startswith("G00Z") and body[i + 1].startswith("G00X") and body[i + 2].startswith("G00Z")
        safe = _words(body[i])["Z"]
        w1, w2 = _words(body[i + 1]), _words(body[i + 2])
        q0 = np.array([w1["X"], w1["Y"], w2["Z"]])
        p0 = tool_path.samples[a]
        assert np.abs(q0 - (p0 + 2.0 * normals[a])).max() <= 1e-4
        assert body[i + 3].startswith("G01X") and body[i + 3].endswith("F300")
        # the path's blocks: modal words only (G01 is in force from the approach), no separator between words;
        # G91 from the first, the last G90 (absolute, as the retract after it)
        j = i + 4
        assert body[j].startswith("G91")
        while not body[j].startswith("G01"):
            assert body[j][0] in "XYZF" or body[j][:2] in ("G1", "G2", "G3") or body[j][:3] in ("G90", "G91"), body[j]
            assert " " not in body[j] and re.fullmatch(r"(?:[GXYZIJRF]-?\d*\.?\d+)+", body[j]), body[j]
            j += 1
        assert body[j - 1].startswith("G90")
        assert j - (i + 4) < b - a - 1  # fewer blocks than samples: merged within the tolerances
        # retract along the end normal at the approach feed, back to the clearance plane
        w = _words(body[j])
        q1 = np.array([w["X"], w["Y"], w["Z"]])
        assert np.abs(q1 - (tool_path.samples[b - 1] + 2.0 * normals[b - 1])).max() <= 1e-4
        assert body[j].endswith("F300") and _words(body[j + 1]) == {"G": 0.0, "Z": safe}
        assert safe >= tool_path.samples[:, 2].max() + 5.0 - 1e-9
        i = j + 2
    assert body[i:] == ["M5 M9", "M30"]

def test_fixed_period_moves_are_the_samples_with_their_planned_times(tool_path):
    text = _gcode(tool_path, segmenting="period")
    dt = planned_segment_times(tool_path)
    runs = _path_runs(text)
    assert len(runs) == len(_pieces_of(tool_path))
    for (a, b), (pts, feed, inv, t) in zip(_pieces_of(tool_path), runs):
        assert np.abs(pts - tool_path.samples[a:b]).max() <= RES  # the approach ends on the first sample
        assert not inv.any()
        # G94: each block's time, length / F in force, is the planned one (F left out where within 0.1 %)
        assert np.abs(t / dt[a + 1 : b] - 1).max() <= FEED_RES + 1e-4

def test_tool_radius_writes_the_centre_with_inverse_time_feeds(tool_path):
    r = 3.0
    text = _gcode(tool_path, tool_radius=r, segmenting="period")
    assert "G93\n" in text and "COORDINATES: TOOL CENTRE" in text and "3.0 mm" in text and "FEED: G93" in text
    normals = sample_normals(tool_path)
    dt = planned_segment_times(tool_path)
    for (a, b), (pts, feed, inv, t) in zip(_pieces_of(tool_path), _path_runs(text)):
        centre = tool_path.samples[a:b] + r * normals[a:b]
        assert np.abs(pts - centre).max() <= RES
        assert np.abs(np.linalg.norm(pts - tool_path.samples[a:b], axis=1) - r).max() <= 1e-4
        # inverse time: F = 1 / minutes of the block, the planned time whatever the offset
        # (F rounded to the digits feed_resolution needs: within 0.1 %)
        assert inv.all() and np.abs(60.0 / feed / dt[a + 1 : b] - 1).max() <= FEED_RES * (1 + 1e-9)
    body = _lines(text)
    g93 = [i for i, ln in enumerate(body) if ln == "G93"]
    # G93 only around the path moves: the approach and retract are in mm/min; F on every block in G93
    assert all(body[i - 1].endswith("F300") and body[i - 1].startswith("G01") for i in g93)
    for i in g93:
        j = i + 1
        while body[j] != "G94":
            assert "F" in body[j], body[j]
            j += 1

def test_per_minute_feed_is_rescaled_to_the_driven_point(tool_path):
    r = 3.0
    text = _gcode(tool_path, tool_radius=r, feed_mode="per-minute", segmenting="period")
    assert "G93" not in text
    contact = _path_runs(_gcode(tool_path, segmenting="period"))
    dt = planned_segment_times(tool_path)
    ratios = []
    for (a, b), (pts, feed, inv, t), (_, cfeed, _, _) in zip(_pieces_of(tool_path), _path_runs(text), contact):
        assert np.abs(t / dt[a + 1 : b] - 1).max() <= FEED_RES + 1e-4
        ratios.append(feed / cfeed)
    ratios = np.concatenate(ratios)
    # on a convex cap the centre runs a longer path than the contact point: every F is raised
    assert np.median(ratios) > 1.0 + 0.5 * r / 30.0

def test_linuxcnc_refuses_nurbs_and_bad_modes(tool_path):
    with pytest.raises(ParameterError, match="LinuxCNC cannot run G06.2") as e:
        _gcode(tool_path, mode="nurbs")
    assert "--post fanuc" in e.value.hint if hasattr(e.value, "hint") else "--post fanuc" in str(e.value)
    with pytest.raises(ParameterError, match="Unknown G-code mode"):
        _gcode(tool_path, mode="spline")
    with pytest.raises(ParameterError, match="no inverse-time"):
        _gcode(tool_path, post="fanuc", feed_mode="inverse-time")
    with pytest.raises(ParameterError, match="writes toolpath.xyz, not G-code"):
        _gcode(tool_path, post="xyz")


# --------------------------------------------------------------------------- fanuc


_WORD = re.compile(r"([A-Z])([-+]?(?:\d+\.?\d*|\.\d+))")  # Fanuc reads X10. X.5 X-.5


def fanuc_check(text: str) -> list[dict]:
    """Check a Fanuc program and return its G06.2 NURBS blocks, one dict per curve.

    Written from the Fanuc NURBS interpolation format (15i/30i): the first block
    ``G06.2 P<rank> K<knot> X Y Z [R<weight>] [F<feed>]``, then ``K X Y Z [R]`` per
    further control point, then ``rank`` blocks of ``K`` alone; the rank is 2..4;
    the knots never decrease; the first and the last ``rank`` knots are equal
    (the curve starts at the current position); the NURBS mode ends with the
    next group-01 G code. Every block is address words (letter + number) or a
    comment; the program starts with ``%`` and an O number and ends with M30 and ``%``.
    """
    lines = text.splitlines()
    assert lines[0] == "%" and lines[-1] == "%", "tape delimiters"
    assert re.fullmatch(r"O\d{4}", lines[1]), "program number"
    curves, cur, pos, tail = [], None, None, 0
    for raw in lines[2:-1]:
        if raw.startswith("("):
            assert raw.endswith(")") and raw.count("(") == 1, raw
            continue
        assert _WORD.sub("", raw).strip() == "", f"not address words: {raw!r}"
        words = _WORD.findall(raw)
        letters = [w[0] for w in words]
        d = {}
        for L, v in words:
            if L != "G" and L != "M":
                d[L] = float(v)
        gs = [v for L, v in words if L == "G"]
        if cur is not None and (tail == cur["P"] or letters[:1] != ["K"]):
            # the curve ends here (its knot count is checked below): a G01/G00 (group 01) must end NURBS mode
            assert any(g in ("00", "01", "0", "1") for g in gs), f"NURBS mode not ended before {raw!r}"
            curves.append(cur)
            cur = None
        if "06.2" in gs:
            assert cur is None and {"P", "K", "X", "Y", "Z", "F"} <= set(d), raw
            assert 2 <= d["P"] <= 4 and d["F"] > 0
            cur = {"P": int(d["P"]), "K": [d["K"]], "C": [(d["X"], d["Y"], d["Z"])], "R": [d.get("R", 1.0)],
                   "F": d["F"], "start": pos}
            tail = 0
        elif cur is not None:
            assert letters[0] == "K" and gs == [], f"inside G06.2: {raw!r}"
            if set(d) == {"K"}:
                tail += 1
                cur["K"].append(d["K"])
            else:
                assert tail == 0 and {"K", "X", "Y", "Z"} <= set(d), f"control block after the trailing knots: {raw!r}"
                cur["K"].append(d["K"])
                cur["C"].append((d["X"], d["Y"], d["Z"]))
                cur["R"].append(d.get("R", 1.0))
        if cur is None and {"X", "Y", "Z"} & set(d):
            pos = tuple(d.get(a, (pos or (0, 0, 0))["XYZ".index(a)]) for a in "XYZ")
    assert cur is None, "program ends inside a NURBS curve"
    for c in curves:
        kn, p = np.array(c["K"]), c["P"]
        assert len(kn) == len(c["C"]) + p, "knots = control points + rank"
        assert np.all(np.diff(kn) >= 0), "knots never decrease"
        assert np.all(kn[:p] == kn[0]) and np.all(kn[-p:] == kn[-1]), "clamped knots"
        assert all(w > 0 for w in c["R"])
        assert np.allclose(c["start"], c["C"][0], atol=1e-4), "the curve starts at the current position"
    assert "M30" in text
    return curves


def test_fanuc_nurbs_program_passes_the_format_check_and_rebuilds_the_curve(tool_path):
    text = _gcode(tool_path, post="fanuc", header={"seed": 5})
    assert "FANUC 15i/30i-CLASS CONTROLS WITH THE NURBS INTERPOLATION OPTION" in text and "not for LinuxCNC" in text
    assert "G64" not in text and "\nO0001\n" in text
    curves = fanuc_check(text)
    sp = tool_path.surface_path
    assert len(curves) == len(sp.planar.pieces) - 1
    pp = tool_path.piece_params
    dt = planned_segment_times(tool_path)
    for k, c in enumerate(curves):
        kn, cp = np.array(c["K"]), np.array(c["C"])
        assert c["P"] == 4
        curve = NurbsCurve(c["P"] - 1, (kn - kn[0]) / (kn[-1] - kn[0]), cp)
        a, b = sp.planar.pieces[k], sp.planar.pieces[k + 1]
        u = np.clip((tool_path.dwell_params[a:b] - pp[k]) / (pp[k + 1] - pp[k]), 0, 1)
        assert np.abs(evaluate(curve, u) - sp.xyz[a:b]).max() < 5e-4
        # one feed per piece: the piece's length over its planned time
        sa, sb = _pieces_of(tool_path)[k]
        length = np.linalg.norm(np.diff(tool_path.samples[sa:sb], axis=0), axis=1).sum()
        assert length * 60.0 / c["F"] == pytest.approx(dt[sa:sb].sum(), rel=1e-3)


def test_fanuc_check_catches_a_broken_program(tool_path):
    text = _gcode(tool_path, post="fanuc")
    lines = text.splitlines()
    last_k = max(i for i, ln in enumerate(lines) if re.fullmatch(r"K[\d.]+", ln))
    with pytest.raises(AssertionError, match="knots = control points"):
        fanuc_check("\n".join(lines[:last_k] + lines[last_k + 1:]))
    with pytest.raises(AssertionError, match="address words"):
        fanuc_check(text.replace("G06.2P4", "G06.2P4#1", 1))


def test_fanuc_with_tool_radius_offsets_the_dwell_points(tool_path):
    r = 2.0
    curves = fanuc_check(_gcode(tool_path, post="fanuc", tool_radius=r))
    sp = tool_path.surface_path
    for k, c in enumerate(curves):
        a, b = sp.planar.pieces[k], sp.planar.pieces[k + 1]
        cp = np.array(c["C"])
        # clamped interpolating curve: it starts and ends at the offset end dwell points
        assert np.abs(cp[0] - (sp.xyz[a] + r * sp.normals[a])).max() <= 1e-4
        assert np.abs(cp[-1] - (sp.xyz[b - 1] + r * sp.normals[b - 1])).max() <= 1e-4
    lin = _gcode(tool_path, post="fanuc", mode="linear", tool_radius=r)
    assert "\nG06.2" not in lin and "\nG93" not in lin and "FEED: G94" in lin


# --------------------------------------------------------------------------- xyz and csv


def test_xyz_and_csv_posts_write_the_record_files(tool_path, tmp_path):
    info = write_program(tool_path, tmp_path, post="xyz")
    assert info["file"] == "toolpath.xyz" and info["coordinates"] == "contact point"
    ref = io.StringIO()
    write_xyz(tool_path, ref)
    assert (tmp_path / "toolpath.xyz").read_text() == ref.getvalue()
    assert read_xyz(tmp_path / "toolpath.xyz").shape == tool_path.samples.shape
    info = write_program(tool_path, tmp_path, post="csv")
    ref = io.StringIO()
    write_path_csv(tool_path, ref)
    assert (tmp_path / "path.csv").read_text() == ref.getvalue()
    assert np.array_equal(read_path_csv(tmp_path / "path.csv")["dwell_time"], tool_path.dwell_times)
    assert info["machining_time_s"] == pytest.approx(tool_path.dwell_times.sum())
    with pytest.raises(ParameterError, match="cannot offset them by a tool radius"):
        write_program(tool_path, tmp_path, post="xyz", tool_radius=1.0)


def test_machining_time_is_the_feed_moves_of_the_file(tool_path, tmp_path):
    info = write_program(tool_path, tmp_path, post="linuxcnc")
    n_pieces = len(_pieces_of(tool_path))
    # the blocks keep the planned time, but where F is left out (within 0.1 %)
    assert info["path_time_s"] == pytest.approx(planned_segment_times(tool_path).sum(), rel=FEED_RES)
    assert info["segmenting"] == "chord" and info["motion_blocks"] < len(tool_path.samples)
    assert info["lines_per_dwell_point"] == pytest.approx(info["motion_blocks"] / len(tool_path.surface_path.xyz))
    assert info["machining_time_s"] == pytest.approx(info["path_time_s"] + n_pieces * 2 * 2.0 * 60 / 300.0)
    assert (tmp_path / "toolpath.nc").read_text().count("\nG00Z") == 3 * n_pieces


# --------------------------------------------------------------------------- the job's options


def test_post_options_from_the_command_line_and_a_post_table(tmp_path):
    import json
    import subprocess
    import sys

    job = tmp_path / "job.toml"
    job.write_text('[job]\nsurface = "hemisphere:R=12,triangles=700"\nspacing = 2.0\nseed = 4\ntool_radius = 1.5\n\n'
                   '[post]\nspindle_rpm = 100\nclearance_mm = 8.0\nfeed_mode = "per-minute"\n')
    base = [sys.executable, "-m", "polishpath", "plan", "--no-report", "-q"]
    r = subprocess.run([*base, "--config", str(job), "-o", str(tmp_path / "a")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    nc = (tmp_path / "a" / "toolpath.nc").read_text()
    assert "\nM3 S100\n" in nc and "\nG93\n" not in nc and "COORDINATES: TOOL CENTRE" in nc
    s = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert s["post"]["post"] == "linuxcnc" and s["post"]["feed_mode"] == "per-minute"
    assert s["machining_time_s"] == pytest.approx(s["post"]["machining_time_s"]) and s["machining_time_s"] > 0
    from gcodeparser import parse_gcode_lines

    safe = s["post"]["clearance_z_mm"]
    zs = [ln.params["Z"] for ln in parse_gcode_lines(nc) if "Z" in ln.params and abs(ln.params["Z"] - safe) > 1e-4]
    # 8 mm over the highest point the tool can reach (a bound from the curve's control points)
    assert max(zs) + 8.0 - 1e-4 <= safe <= max(zs) + 8.0 + 0.5
    from polishpath.export.textfmt import fixed_text

    assert f"\nG00Z{fixed_text(s['post']['clearance_z_mm'], 4, 3)}\n" in nc
    # the run's own job.toml keeps the [post] table: re-running it writes the same G-code
    r = subprocess.run([*base, "--config", str(tmp_path / "a" / "job.toml"), "-o", str(tmp_path / "b")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "b" / "toolpath.nc").read_text() == nc
    # --post on the command line wins over the file; a bad [post] setting is named
    r = subprocess.run([*base, "--config", str(job), "--post", "fanuc", "-o", str(tmp_path / "c")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "\nG06.2P4" in (tmp_path / "c" / "toolpath.nc").read_text()
    job.write_text(job.read_text().replace("spindle_rpm = 100", "spindle = 100"))
    r = subprocess.run([*base, "--config", str(job), "-o", str(tmp_path / "d")], capture_output=True, text=True)
    assert r.returncode == 2 and "unknown post setting(s) spindle" in r.stderr and "Traceback" not in r.stderr
    r = subprocess.run([*base, "hemisphere:R=12,triangles=700", "--spacing", "2", "--post", "xyz", "-o",
                        str(tmp_path / "e")], capture_output=True, text=True)
    assert r.returncode == 0 and not (tmp_path / "e" / "toolpath.nc").exists()
    assert json.loads((tmp_path / "e" / "summary.json").read_text())["post"]["file"] == "toolpath.xyz"


def test_segment_options_from_the_command_line_and_a_job_file(tmp_path):
    import json
    import subprocess
    import sys

    base = [sys.executable, "-m", "polishpath", "plan", "--no-report", "-q"]
    part = ["hemisphere:R=12,triangles=700", "--spacing", "2", "--seed", "4"]
    r = subprocess.run([*base, *part, "-o", str(tmp_path / "a")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    post = json.loads((tmp_path / "a" / "summary.json").read_text())["post"]
    # the defaults: arcs, 1 % of the 2 mm spacing, 1 % of the time
    assert post["arcs"] and post["arc_blocks"] > 0 and post["segment_chord_tol_mm"] == pytest.approx(0.02)
    assert post["time_tol"] == 0.01
    r = subprocess.run([*base, *part, "--segment-tol", "0.005", "--segment-time-tol", "0.02", "--no-arcs", "-o",
                        str(tmp_path / "b")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    s = json.loads((tmp_path / "b" / "summary.json").read_text())
    post = s["post"]
    assert not post["arcs"] and post["arc_blocks"] == 0 and post["segment_chord_tol_mm"] == 0.005
    assert post["time_tol"] == 0.02 and post["motion_blocks"] > json.loads(
        (tmp_path / "a" / "summary.json").read_text())["post"]["motion_blocks"]
    nc = (tmp_path / "b" / "toolpath.nc").read_text()
    assert "(segment_chord_tol_mm: 0.005)" in nc and re.search(r"\nG[23][XY]", nc) is None
    # the run's job.toml keeps them: re-running it writes the same G-code
    r = subprocess.run([*base, "--config", str(tmp_path / "b" / "job.toml"), "-o", str(tmp_path / "c")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "c" / "toolpath.nc").read_text() == nc
    # the job option wins over a [post] table's setting
    job = tmp_path / "job.toml"
    job.write_text('[job]\nsurface = "hemisphere:R=12,triangles=700"\nspacing = 2.0\nseed = 4\nsegment_tol_mm = 0.01\n'
                   '\n[post]\nchord_tol_mm = 0.003\narcs = false\n')
    r = subprocess.run([*base, "--config", str(job), "-o", str(tmp_path / "d")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    post = json.loads((tmp_path / "d" / "summary.json").read_text())["post"]
    assert post["segment_chord_tol_mm"] == 0.01 and not post["arcs"]
    # bad values: a clear message, exit 2, before any work
    for bad, words in ((["--segment-time-tol", "1.5"], "segment_time_tol (--segment-time-tol) must be a fraction"),
                       (["--segment-tol", "0"], "segment_tol_mm must be a positive number"),
                       (["--segment-time-tol", "0.0005"], "feed_resolution (0.001) must be smaller than time_tol")):
        r = subprocess.run([*base, *part, *bad, "-o", str(tmp_path / "e")], capture_output=True, text=True)
        assert r.returncode == 2 and words in r.stderr and "Traceback" not in r.stderr, r.stderr
        assert not (tmp_path / "e").exists()


# --------------------------------------------------------------------------- gouge


def test_concave_radius_is_exact_on_a_sphere_and_inf_on_a_convex_part():
    from polishpath.export.post.gouge import concave_radii

    t = np.linspace(0.1, 1.2, 30)
    R = 40.0
    # the inside of a sphere (a bowl): normals point to the centre, towards the tool
    p = np.column_stack([R * np.sin(t), np.zeros_like(t), R - R * np.cos(t)])
    n = (np.array([0.0, 0.0, R]) - p) / R
    r = concave_radii(p, n, np.array([0, len(t)]))
    assert np.allclose(r, R, rtol=1e-12)
    assert np.all(np.isinf(concave_radii(p, -n, np.array([0, len(t)]))))  # seen from outside: convex
    # a lift between pieces is not a step
    assert len(concave_radii(p, n, np.array([0, 10, len(t)]))) == len(t) - 2


def test_a_tool_larger_than_the_concave_radius_is_warned(tmp_path):
    import subprocess
    import sys

    base = [sys.executable, "-m", "polishpath", "plan", "saddle", "--spacing", "2", "--seed", "2", "--no-report", "-q"]
    r = subprocess.run([*base, "--tool-radius", "100", "-o", str(tmp_path / "a")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "warning: tool radius 100 mm exceeds the part's smallest concave radius" in r.stderr
    assert "the ball is inside the part" in r.stderr
    import json

    g = json.loads((tmp_path / "a" / "summary.json").read_text())["post"]["gouge"]
    assert 40 < g["min_concave_radius_mm"] < 60  # the saddle's R = 50 mm, from the dwell normals
    assert g["interference_mm"] > 1.0
    r = subprocess.run([*base, "--tool-radius", "5", "-o", str(tmp_path / "b")], capture_output=True, text=True)
    assert r.returncode == 0 and "warning" not in r.stderr, r.stderr


# --------------------------------------------------------------------------- chord-tolerance segmenting (issue 15)


def _dist_to_segment(q, a, b):
    e = b - a
    ll = float(e @ e)
    t = np.clip((q - a) @ e / ll, 0, 1) if ll > 0 else np.zeros(len(q))
    return np.linalg.norm(a + t[:, None] * e - q, axis=1)


def _scheduled_region_times(tp, k):
    """The schedule's time per dwell region of piece k (time linear in the parameter between samples)."""
    a, b = _pieces_of(tp)[k]
    t = np.cumsum(planned_segment_times(tp)[a:b])
    u = tp.sample_params[a:b]
    da, db = tp.surface_path.planar.pieces[k], tp.surface_path.planar.pieces[k + 1]
    rb = dwell_regions(tp.dwell_params[da:db], u[0], u[-1])
    return np.diff(np.interp(rb, u, t)), rb


def _driven_curve(tool_path, u, radius):
    q = evaluate(tool_path.curve, u)
    if radius:
        from polishpath.export.chunks import normals_at

        q = q + radius * normals_at(tool_path, u)
    return q


def _circle_through(a, m, c):
    """Centre (2,) and radius of the XY circle through three points, and the turn (+1 counter-clockwise)."""
    b, e = m[:2] - a[:2], c[:2] - a[:2]
    den = 2 * (b[0] * e[1] - b[1] * e[0])
    ux = (e[1] * (b @ b) - b[1] * (e @ e)) / den
    uy = (b[0] * (e @ e) - e[0] * (b @ b)) / den
    return a[:2] + [ux, uy], float(np.hypot(ux, uy)), (1 if den > 0 else -1)


def _dist_same_angle(q, start, end, centre, turn):
    """Distance of one point q (3,) from the move's point at q's angle about the centre (a straight move: from
    the segment): an upper bound of its distance to the move, exact for a point on it."""
    if turn == 0:
        return float(_dist_to_segment(q[None, :], start, end)[0])
    va, vb, vq = start[:2] - centre, end[:2] - centre, q[:2] - centre

    def sweep(a, b):
        ph = np.arctan2(turn * (a[0] * b[1] - a[1] * b[0]), a @ b)
        return ph + 2 * np.pi if ph <= 0 else ph

    lam = sweep(va, vq) / sweep(va, vb)
    assert 0 < lam < 1, lam
    return float(np.linalg.norm(arc_points(start, end, centre, turn, np.array([lam]))[0] - q))


def _dist_to_move(q, start, end, centre, turn):
    """Distance of points q (m, 3) from a move (straight, or the helix of gcode_helpers.arc_points): dense
    points along it, refined around the nearest (a bound from above of the true distance, to ~1e-9 mm)."""
    if turn == 0:
        return _dist_to_segment(q, start, end)
    lam = np.linspace(0, 1, 4001)
    pts = arc_points(start, end, centre, turn, lam)
    out = []
    for p in q:
        i = int(np.argmin(np.linalg.norm(pts - p, axis=1)))
        fine = np.clip(np.linspace(lam[i] - 3e-4, lam[i] + 3e-4, 601), 0, 1)
        out.append(np.linalg.norm(arc_points(start, end, centre, turn, fine) - p, axis=1).min())
    return np.array(out)


@pytest.mark.parametrize("part, radius, arcs, ends", [("cap", 0.0, True, False), ("cap", 3.0, True, False),
                                                      ("cap", 0.0, False, False), ("flat", 0.0, True, False),
                                                      ("flat", 0.0, True, True), ("flat", 2.0, True, False)])
def test_segmenting_keeps_dwell_points_on_the_path_and_the_chord_within_tolerance(tool_path, flat_path, part, radius,
                                                                                  arcs, ends):
    from polishpath.export.blockfit import CCW, CW, LINE

    tool_path = tool_path if part == "cap" else flat_path
    post = get_post("linuxcnc", {"arcs": arcs, "dwell_block_ends": ends})
    blocks = post.segment_blocks(tool_path, radius)
    sp = tool_path.surface_path
    tol = post.segment_tol(tool_path)  # the default: 1 % of the spacing, over the smoothing stage's chord tolerance
    if part == "cap":
        assert tol == pytest.approx(0.02) and tool_path.provenance.params["chord_tol_mm"] == 0.005
    else:
        assert tol == pytest.approx(0.005)
    assert len(blocks) == len(_pieces_of(tool_path))
    normals = sample_normals(tool_path)
    worst, n_arcs, n_blocks, passed, passed_w = 0.0, 0, 0, 0, 0.0
    for k, (P, T, U, kinds, ij, centres) in enumerate(blocks):
        a, b = sp.planar.pieces[k], sp.planar.pieces[k + 1]
        dw = sp.xyz[a:b] + radius * sp.normals[a:b]
        du = tool_path.dwell_params[a:b]
        assert np.all(np.diff(U) > 0) and np.all(np.diff(T) > 0)
        assert set(kinds[1:]) <= ({LINE, CW, CCW} if arcs else {LINE})
        sa, sb = _pieces_of(tool_path)[k]
        assert len(P) < (sb - sa) + (b - a)  # merged: fewer block ends than samples + dwell points
        u, s = tool_path.sample_params[sa:sb], tool_path.samples[sa:sb] + radius * normals[sa:sb]
        W = np.round(P, 4) + 0.0  # as written
        # every dwell point is a block end, or lies inside one block (at most one per block), on it to 1e-9 mm
        at_end = np.isin(du, U)
        blk = np.searchsorted(U, du, side="left")  # dwell point j inside block blk[j] (from U[blk-1] to U[blk])
        if np.linalg.norm(P[-1] - dw[-1]) <= 1e-9:  # the piece ends at its last sample, at the last dwell point
            at_end[-1], blk[-1] = True, len(P) - 1
        assert np.all(np.abs(P[np.minimum(blk, len(P) - 1)][at_end] - dw[at_end]) <= 1e-9)
        if ends:
            assert at_end.all()
        assert len(np.unique(blk[~at_end])) == np.count_nonzero(~at_end)
        inner_dwell = dict(zip(blk[~at_end] - 1, np.flatnonzero(~at_end)))
        for i in range(len(P) - 1):
            inner = (u > U[i]) & (u < U[i + 1])
            n_blocks += 1
            j = inner_dwell.get(i)
            if j is not None:
                passed += 1
                turn = 0 if kinds[i + 1] == LINE else (1 if kinds[i + 1] == CCW else -1)
                c = centres[i + 1]
                # on the block before rounding (the helix about the fitted centre, Z linear along it) ...
                assert _dist_same_angle(dw[j], P[i], P[i + 1], c, turn) <= 1e-9
                # ... and on the block as written (ends and incremental centre rounded) within the resolution
                d_w = _dist_same_angle(dw[j], W[i], W[i + 1], W[i, :2] + ij[i + 1], turn)
                assert d_w <= 1e-4 + 1e-9
                passed_w = max(passed_w, d_w)
            if not inner.any():
                continue
            # the samples the block replaces and the curve at 1/4, 1/2, 3/4 between them (where the smoothing
            # stage checks its own chords) are within the tolerance of the block: a segment, or the helix
            # about the fitted centre (XY arc through the block's start, middle point -- or the dwell point
            # inside -- and end, Z linear along it)
            ui = np.concatenate([[U[i]], u[inner], [U[i + 1]]])
            if j is not None:
                ui = np.sort(np.concatenate([ui, [du[j]]]))
            uq = (ui[:-1, None] + np.array([0.25, 0.5, 0.75]) * np.diff(ui)[:, None]).ravel()
            q = np.vstack([s[inner], _driven_curve(tool_path, uq, radius)])
            if kinds[i + 1] == LINE:
                assert np.isnan(centres[i + 1]).all()
                worst = max(worst, _dist_to_segment(q, P[i], P[i + 1]).max())
                continue
            n_arcs += 1
            turn = 1 if kinds[i + 1] == CCW else -1
            if j is None:  # the circle through the start, the middle point and the end
                pts = np.vstack([P[i], s[inner], P[i + 1]])
                centre, r, tr = _circle_through(pts[0], pts[(len(pts) - 1) // 2], pts[-1])
                assert tr == turn and np.allclose(centre, centres[i + 1], rtol=0, atol=1e-9 * max(1.0, r))
            centre = centres[i + 1]
            r = float(np.linalg.norm(P[i, :2] - centre))
            assert abs(np.linalg.norm(P[i + 1, :2] - centre) - r) <= 1e-9 * max(1.0, r)
            worst = max(worst, _dist_to_move(q, P[i], P[i + 1], centre, turn).max())
            # the arc as written (ends and incremental centre at 0.1 um): LinuxCNC's radius rule well kept,
            # within one resolution (beyond the ends' own rounding) of the fitted arc
            wc = W[i, :2] + ij[i + 1]
            assert np.allclose(ij[i + 1], np.round(ij[i + 1], 4), atol=1e-12, rtol=0)
            rs, re = np.linalg.norm(W[i, :2] - wc), np.linalg.norm(W[i + 1, :2] - wc)
            assert abs(rs - re) <= 2e-4 + 1e-12
            lam = np.array([0.25, 0.5, 0.75])
            shift = max(np.linalg.norm(W[i] - P[i]), np.linalg.norm(W[i + 1] - P[i + 1]))
            off = np.linalg.norm(arc_points(W[i], W[i + 1], wc, turn, lam) - arc_points(P[i], P[i + 1], centre, turn,
                                                                                       lam), axis=1)
            assert off.max() <= shift + 1e-4 + 1e-12
    assert 0.3 * tol < worst <= tol * (1 + 1e-9)
    if part == "flat" and not ends and radius == 0:
        # on a flat part blocks pass through dwell points: fewer blocks than with every dwell point a block end
        assert passed > 0.2 * len(sp.xyz)
        assert n_blocks < sum(len(x[0]) - 1 for x in get_post("linuxcnc", {"dwell_block_ends": True}).segment_blocks(
            tool_path))
    if ends:
        assert passed == 0
    if arcs:
        assert n_arcs > 0  # the serpentine's turns
        if part == "cap":
            lines_only = get_post("linuxcnc", {"arcs": False}).segment_blocks(tool_path, radius)
            assert n_blocks < sum(len(x[0]) - 1 for x in lines_only)
    else:
        assert n_arcs == 0


@pytest.mark.parametrize("part, radius", [("cap", 0.0), ("cap", 3.0), ("flat", 0.0), ("flat", 2.0)])
def test_delivered_time_around_every_dwell_point_is_within_its_tolerance(tool_path, flat_path, part, radius):
    """Each region's time as the controller derives it from the written blocks and F (rounded), dwell points at
    block ends or (on the flat part) passed through on a block, by gcodeparser: within the time tolerance."""
    from gcode_helpers import delivered_region_times, dwell_moves, points_at_params

    tool_path = tool_path if part == "cap" else flat_path
    time_tol = 0.01
    text = _gcode(tool_path, tool_radius=radius)
    assert ("G93" in text) == (radius > 0)
    sp = tool_path.surface_path
    driven = tool_path.samples + radius * sample_normals(tool_path)
    arcs = _path_arcs(text)
    assert sum(int(np.count_nonzero(tr)) for _, tr in arcs) > 0  # arcs among the blocks
    for k, (pts, feed, inv, t) in enumerate(_path_runs(text)):
        sched, rb = _scheduled_region_times(tool_path, k)
        a, b = sp.planar.pieces[k], sp.planar.pieces[k + 1]
        sa, sb = _pieces_of(tool_path)[k]
        # each region boundary where the schedule places it: on the sampled path, linear in the parameter
        bq = points_at_params(driven[sa:sb], tool_path.sample_params[sa:sb], rb[1:-1])
        dw = sp.xyz[a:b] + radius * sp.normals[a:b]
        got = delivered_region_times(pts, t, dw, bq, centres=arcs[k][0], turns=arcs[k][1])
        rel = np.abs(got / sched - 1)
        assert rel.max() <= time_tol, rel.max()
        assert got.sum() == pytest.approx(sched.sum(), rel=FEED_RES)
        # every dwell point on the path as the parser reads it, to the coordinate resolution
        first, last, dist = dwell_moves(pts, dw, 2e-4, arcs[k][0], arcs[k][1])
        assert dist.max() <= 1e-4
        if part == "flat" and radius == 0:
            assert np.count_nonzero(first == last) > 0.2 * len(dw)  # passed through on a block


def test_modal_words_parse_back_with_both_parsers_to_the_same_points(tool_path, flat_path):
    cases = [(tool_path, kw) for kw in ({}, {"tool_radius": 3.0}, {"segmenting": "period"}, {"arcs": False})]
    cases += [(flat_path, {}), (flat_path, {"dwell_block_ends": True})]
    for tp, kw in cases:
        text = _gcode(tp, **kw)
        a, b = moves_gcodeparser(text), moves_pygcode(text)
        assert len(a.ends) == len(b.ends) > (0.5 if tp is flat_path and not kw else 1) * len(tp.surface_path.xyz)
        assert np.array_equal(a.ends, b.ends) and np.array_equal(a.feed, b.feed)
        assert np.array_equal(a.inverse, b.inverse) and np.array_equal(a.rapid, b.rapid)
        assert np.array_equal(a.turns, b.turns) and np.array_equal(a.centres, b.centres, equal_nan=True)
        assert (np.count_nonzero(a.turns) > 0) == (kw.get("segmenting") != "period" and kw.get("arcs", True))
        # the blocks' end points are the unrounded segmenting's, to the coordinate resolution
        blocks = get_post("linuxcnc", {k: v for k, v in kw.items() if k != "tool_radius"}).segment_blocks(
            tp, kw.get("tool_radius", 0.0))
        for (pts, *_), (P, *_) in zip(_path_runs(text), blocks):
            assert pts.shape == P.shape and np.abs(pts - P).max() <= RES
    # no path block repeats a word that did not change (I J or R are not modal: every arc has them, R where
    # it is exact to the resolution); the motion word only where the motion changes; G91 (incremental) and
    # G90 only where they change, each incremental word nonzero; G94's F changes by more than its resolution
    text = _gcode(tool_path)
    pos, f, mode, inc = {}, None, None, False
    n_r = n_ij = n_abs = 0
    anchor = False  # the block before was a G90 block: this one repeats its motion word and F (a restart point)
    for ln in _lines(text):
        words = {k: v for k, v in _words(ln).items() if k in "XYZFIJR"}
        gs = [int(g) for g in re.findall(r"G(\d+)", ln)]
        if ln.startswith(("G01", "G00")):
            mode = "G01" if ln.startswith("G01") else None
            assert not inc, ln  # the approach and retract are absolute
            pos.update({k: v for k, v in words.items() if k in "XYZ"})
            anchor = False
        elif ln[0] in "XYZF" or re.match(r"(G9[01])?G[123][XYZF]|G9[01][XYZF]", ln):
            for g in gs:
                if g in (90, 91):
                    assert (g == 91) != inc, ln  # written only where it changes
                    inc = g == 91
                    n_abs += g == 90
                else:
                    assert g in (1, 2, 3) and (f"G{g}" != {"G01": "G1"}.get(mode, mode) or anchor), ln
                    mode = f"G{g}"
            if anchor:
                assert 91 in gs and len(gs) == 2 and "F" in words, ln
            arc = mode in ("G2", "G3")
            assert (("I" in words and "J" in words) != ("R" in words)) if arc else not set("IJR") & set(words), ln
            n_r += "R" in words
            n_ij += "I" in words
            if 90 in gs:
                assert set("XYZ") <= set(words), ln  # a G90 block's position is whole
            for axis in "XYZ":
                if axis in words:
                    assert (words[axis] != 0) if inc else (words[axis] != pos.get(axis) or 90 in gs), ln
                    pos[axis] = pos[axis] + words[axis] if inc else words[axis]
            if "F" in words and not anchor:  # the block's own feed was off the F in force by more than FEED_RES;
                step = 10.0 ** np.floor(np.log10(2 * FEED_RES * words["F"]))  # F rounded to the digits it needs
                assert abs(words["F"] - f) > FEED_RES * f - 0.5 * step and words["F"] != f, ln
            anchor = 90 in gs
        f = words.get("F", f)
    assert n_r > n_ij > 0 and n_abs >= len(_pieces_of(tool_path))  # radius form mostly; a G90 block per piece
    body = _lines(text)
    assert sum(ln.startswith("G01") for ln in body) == 2 * len(_pieces_of(tool_path))  # the approach, the retract
    assert any(re.match("G2X", ln) for ln in body) and any(re.match("G3X", ln) for ln in body)


def test_a_coarser_tolerance_writes_fewer_blocks_and_the_counts_are_reported(tool_path):
    fine = write_gcode(tool_path, io.StringIO())
    coarse = write_gcode(tool_path, io.StringIO(), chord_tol_mm=0.05, time_tol=0.05)
    period = write_gcode(tool_path, io.StringIO(), segmenting="period")
    assert coarse["motion_blocks"] < fine["motion_blocks"] < period["motion_blocks"]
    assert coarse["bytes_per_dwell_point"] < fine["bytes_per_dwell_point"] < period["bytes_per_dwell_point"]
    n = len(tool_path.surface_path.xyz)
    assert fine["lines_per_dwell_point"] == pytest.approx(fine["motion_blocks"] / n)
    text = _gcode(tool_path)
    assert f"motion blocks: {fine['motion_blocks']} for {n} dwell points" in text
    assert "bytes per dwell point" in text and "(segment_time_tol: 0.01)" in text and "(arcs: True)" in text
    lines = write_gcode(tool_path, io.StringIO(), arcs=False)
    assert fine["arc_blocks"] > 0 and lines["arc_blocks"] == 0 and fine["arcs"] and not lines["arcs"]
    assert fine["motion_blocks"] < lines["motion_blocks"] and fine["bytes"] < lines["bytes"]


@pytest.mark.parametrize("bad, words", [
    ({"segmenting": "arcs"}, "segmenting must be one of chord, period"),
    ({"chord_tol_mm": 0.0}, "chord_tol_mm must be a number of mm > 0"),
    ({"time_tol": 1.5}, "time_tol must be a fraction"),
    ({"feed_resolution": 0.02}, "feed_resolution .* must be smaller than time_tol"),
    ({"arcs": "yes"}, "arcs must be true or false"),
])
def test_bad_segmenting_settings_are_refused_by_name(bad, words):
    with pytest.raises(ParameterError, match=words):
        get_post("linuxcnc", bad)


# --------------------------------------------------------------------------- streamed writers (issue 15, item 4)


def test_chunked_flat_samples_write_the_same_bytes(flat_path):
    """Blocks through dwell points wait for the interval after the dwell point: the same bytes whatever the chunks."""
    from polishpath.export import sample_chunks

    whole = _gcode(flat_path)
    for size in (1, 7, 333):
        buf = io.StringIO()
        write_gcode(flat_path, buf, chunks=sample_chunks(flat_path, size))
        assert buf.getvalue() == whole, size


@pytest.mark.parametrize("post, kw", [("linuxcnc", {}), ("linuxcnc", {"tool_radius": 3.0}),
                                      ("linuxcnc", {"segmenting": "period"}), ("linuxcnc", {"arcs": False}),
                                      ("fanuc", {}),
                                      ("fanuc", {"mode": "linear", "tool_radius": 2.0})])
def test_chunked_samples_write_the_same_bytes(tool_path, post, kw):
    from polishpath.export import sample_chunks

    whole = _gcode(tool_path, post=post, **kw)
    for size in (1, 7, 333):
        buf = io.StringIO()
        write_gcode(tool_path, buf, post=post, chunks=sample_chunks(tool_path, size), **kw)
        assert buf.getvalue() == whole, size


def test_streamed_run_folder_files_equal_the_in_memory_ones(tool_path, tmp_path):
    import dataclasses

    from polishpath.errors import ExportError
    from polishpath.export import SampleChunk, sample_chunks

    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    write_program(tool_path, a)
    write_xyz(tool_path, a / "toolpath.xyz")
    # a streamed job: the ToolPath without its samples, the samples as chunks of odd sizes
    bare = dataclasses.replace(tool_path, samples=np.zeros((0, 3)), sample_params=np.zeros(0),
                               feed_mm_min=np.zeros(0))
    sizes = iter([5, 1, 77, 1000, 3] * 1000)

    def chunks():
        for c in sample_chunks(tool_path, 1 << 30):
            i = 0
            while i < len(c):
                n = next(sizes)
                yield SampleChunk(c.samples[i:i + n], c.sample_params[i:i + n], c.feed_mm_min[i:i + n], c.piece)
                i += n

    info = write_program(bare, b, chunks=chunks(), xyz=True)
    assert info["xyz_path"] == str(b / "toolpath.xyz") and info["samples"] == len(tool_path.samples)
    for name in ("toolpath.nc", "toolpath.xyz"):
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    info = write_program(bare, b, post="xyz", chunks=chunks())
    assert (a / "toolpath.xyz").read_bytes() == (b / "toolpath.xyz").read_bytes()
    assert info["path_time_s"] == pytest.approx(planned_segment_times(tool_path).sum(), rel=1e-12)
    # the gouge check of a streamed job measures the curve itself (no samples held)
    cap = spherical_cap(n_r=10, n_phi=36).surface
    g_mem = write_gcode(tool_path, io.StringIO(), tool_radius=3.0, surface=cap)["gouge"]
    g_str = write_gcode(bare, io.StringIO(), tool_radius=3.0, surface=cap, chunks=chunks())["gouge"]
    assert g_str["centres_measured"] > len(tool_path.surface_path.xyz)
    assert g_str["min_centre_distance_mm"] == pytest.approx(g_mem["min_centre_distance_mm"], abs=0.02)
    # chunks out of order are refused by name
    bad = list(sample_chunks(tool_path, 500))[::-1]
    with pytest.raises(ExportError, match="pieces must come in order"):
        write_program(bare, b, chunks=bad)
    with pytest.raises(ExportError, match=r"\(m >= 1, 3\)"):
        SampleChunk(np.zeros((0, 3)), np.zeros(0), np.zeros(0), 0)


# --------------------------------------------------------------------------- compact words (issue 15)


def test_compact_words_read_back_as_the_spaced_layout(tool_path):
    """No separator, no leading zero, no trailing zeros (the defaults): both parsers read the same moves as from
    the old layout (spaces, X0.5000), and F carries only the digits its 0.1 % resolution needs."""
    compact = _gcode(tool_path)
    spaced = _gcode(tool_path, word_separator=" ", leading_zero=True, trailing_zeros=True)
    assert len(compact) < 0.9 * len(spaced)
    body = [ln for ln in _lines(compact) if ln[0] in "XYZFG" and not ln.startswith(("G00", "G01", "G2", "G4", "G6"))]
    assert not any(" " in ln for ln in body)
    assert any(re.search(r"[XYIJ]-?\.\d", ln) for ln in body)  # X.5, I-.0924
    assert not any(re.search(r"[XYZIJ]-?\d*\.\d*0(?![\d])", ln) for ln in body)  # no trailing zero
    assert any(" X0." in ln or "X0." in ln for ln in _lines(spaced))
    for parse in (moves_gcodeparser, moves_pygcode):
        a, b = parse(compact), parse(spaced)
        assert np.array_equal(a.ends, b.ends) and np.array_equal(a.feed, b.feed)
        assert np.array_equal(a.centres, b.centres, equal_nan=True) and np.array_equal(a.turns, b.turns)
    # F: within FEED_RES of its value at the old 3 decimals, with at most the digits FEED_RES needs
    fs = [float(m) for m in re.findall(r"F(\d*\.?\d*)", "\n".join(body))]
    decimals = [len(m) for m in re.findall(r"F\d*\.?(\d*)", "\n".join(body))]
    assert fs and all(d <= max(0, -np.floor(np.log10(2 * FEED_RES * f))) for f, d in zip(fs, decimals))
    old = _gcode(tool_path, feed_decimals=3)
    assert re.search(r"F\d+\.\d{3}\n", old)


def test_rounded_feeds_keep_their_resolution():
    from polishpath.export.post.blocks import round_feeds

    f = np.exp(np.random.default_rng(3).uniform(np.log(1.0), np.log(1e5), 20000))
    r = round_feeds(f, None, 1e-3)
    assert np.abs(r / f - 1).max() <= 1e-3 * (1 + 1e-12)
    assert np.abs(r / f - 1).max() > 2e-4  # not more digits than needed
    assert list(round_feeds(np.array([300.403, 577.298, 5432.1, 49.87]), None, 1e-3)) == [300.4, 577.0, 5430.0, 49.87]
    assert list(round_feeds(np.array([300.4031]), 3, 1e-3)) == [300.403]


@pytest.mark.parametrize("bad, words", [
    ({"word_separator": ","}, "word_separator must be"),
    ({"leading_zero": "no"}, "leading_zero must be true or false"),
    ({"feed_decimals": -1}, "feed_decimals must be a whole number 0..9 .or left out"),
])
def test_bad_word_settings_are_refused_by_name(bad, words):
    with pytest.raises(ParameterError, match=words):
        get_post("linuxcnc", bad)


def test_fanuc_keeps_the_point_of_whole_numbers(tool_path):
    text = _gcode(tool_path, post="fanuc", mode="linear", approach_mm=3.0, clearance_mm=4.0)
    assert "(integer_point: True)" in text
    assert re.search(r"\nG00Z\d+\.\d*\n", text)
    words = re.findall(r"[XYZIJ](-?\d*\.?\d*)", "\n".join(_lines(text)))
    assert words and all("." in w or float(w) == 0 for w in words)


@pytest.mark.parametrize("post", ["linuxcnc", "fanuc"])
def test_incremental_words_and_radius_arcs_run_the_same_path_as_absolute_centre_words(flat_path, tool_path, post):
    """G91 words with G90 anchors and arcs in radius form (the defaults, issue 29's 60 bytes per dwell point):
    both parsers read the same block ends as the absolute I J program (to float sums of the rounded words:
    no rounding accumulates), the arcs' centres within the written resolution's effect, the same times; a
    G90 block every anchor_blocks blocks and as each piece's last; read from any G90 block on (a restart
    there), the positions are the same."""
    from gcode_helpers import radius_centre

    mode = {"mode": "linear"} if post == "fanuc" else {}
    # gcodeparser reads no Fanuc whole number with its point ("Z7.")
    parsers = (moves_pygcode,) if post == "fanuc" else (moves_gcodeparser, moves_pygcode)
    for tp in (flat_path, tool_path):
        new = io.StringIO()
        info = write_gcode(tp, new, post=post, anchor_blocks=40, **mode)
        old = io.StringIO()
        ref = write_gcode(tp, old, post=post, incremental=False, radius_arcs=False, **mode)
        new, old = new.getvalue(), old.getvalue()
        assert "G91" not in old and "R" not in "".join(_lines(old)[5:]) and "G91" in new
        assert info["incremental"] and not ref["incremental"]
        assert 0 < info["radius_arc_blocks"] <= info["arc_blocks"] == ref["arc_blocks"] and ref["radius_arc_blocks"] == 0
        assert info["motion_blocks"] == ref["motion_blocks"] and info["bytes"] < 0.9 * ref["bytes"]
        assert info["path_time_s"] == pytest.approx(ref["path_time_s"], rel=1e-5)
        for parse in parsers:
            a, b = parse(new), parse(old)
            assert np.abs(a.ends - b.ends).max() <= 1e-9 and np.array_equal(a.turns, b.turns)
            arc = a.turns != 0
            # the radius form's centre moves by what the rounding of R and the ends allow: a few resolutions
            # on a short arc; the path between the ends (checked against the fitted arc when written) is the same
            assert np.abs(a.centres[arc] - b.centres[arc]).max() < 0.05
            assert np.allclose(a.times()[~a.rapid], b.times()[~b.rapid], rtol=2e-3, atol=1e-9)
        # the G90 anchors: every 40 blocks of a piece and its last block; the path blocks between are G91
        body = _lines(new)
        path = [ln for ln in body if re.match(r"G9[01]|[XYZF]|G[123][XYZ]", ln)]
        k = 0
        for ln in path:
            k += 1
            if ln.startswith("G90"):
                k = 0
            assert k < 40
        # a restart after a G90 block in the middle, the tool moved to that block's end (its X Y Z are absolute
        # and whole; the next block writes its G91, motion word and F): the same positions from there on
        starts = [i for i, ln in enumerate(body) if ln.startswith("G90") and i + 1 < len(body)
                  and body[i + 1].startswith("G91")]
        cut = starts[len(starts) // 2]
        w = _words(body[cut])
        assert re.match(r"G91G[123]", body[cut + 1]) and "F" in body[cut + 1]
        restart = "\n".join(body[:5]) + f"\nG00X{w['X']}Y{w['Y']}Z{w['Z']}\n" + "\n".join(body[cut + 1:])
        tail, full = parsers[0](restart), parsers[0](new)
        n = len(tail.ends) - 1
        assert np.abs(tail.ends[-n:] - full.ends[-n:]).max() <= 1e-9 and np.array_equal(tail.feed[-n:], full.feed[-n:])
    # the radius form's centre: the shorter arc's, on the side the arc turns to
    c = radius_centre(np.array([0.0, 0.0, 0.0]), np.array([2.0, 0.0, 0.0]), 1.25, 1)
    assert np.allclose(c, [1.0, 0.75])
    assert np.allclose(radius_centre(np.array([0.0, 0.0, 0.0]), np.array([2.0, 0.0, 0.0]), 1.25, -1), [1.0, -0.75])
