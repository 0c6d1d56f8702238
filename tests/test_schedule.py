"""The feed schedule under a machine profile (issue 16, item 3): limits checked from the samples."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from polishpath.errors import ParameterError, SpecError
from polishpath.export.post import planned_segment_times
from polishpath.schedule import BUILTIN_MACHINES, MachineProfile, load_machine, schedule_feeds, segment_limits
from polishpath.schedule import dwell_point_times

SLACK = 1 + 1e-6


@pytest.fixture(scope="module")
def job():
    from polishpath.pipeline import run

    return run(surface="hemisphere:R=12,triangles=3000", spacing=1.5, seed=11, report=False)


def _limits_of(tp):
    """Measured from the timed samples, piece by piece."""
    dt = planned_segment_times(tp)
    off = tp.sample_pieces
    return [segment_limits(tp.samples[a:b], dt[a + 1 : b]) for a, b in zip(off[:-1], off[1:])]


def test_segment_limits_of_a_known_motion():
    # 1 mm segments at 1, 2, 3 mm/s along X, then a right-angle turn at 3 mm/s
    p = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0], [3, 1, 0]], float)
    t = np.array([1.0, 0.5, 1 / 3, 1 / 3])
    m = segment_limits(p, t)
    assert np.allclose(m["speed"], [1, 2, 3, 3])
    assert np.allclose(m["acceleration"][0], [1 / 0.5, 0, 0])  # from rest over half the first segment
    assert np.allclose(m["acceleration"][1], [(2 - 1) / 0.75, 0, 0])
    assert np.allclose(m["acceleration"][3], [-3 / (1 / 3), 3 / (1 / 3), 0])  # the turn
    assert np.allclose(m["acceleration"][4], [0, -3 / (1 / 6), 0])  # to rest
    assert np.allclose(m["tangential"][:3], [2, 1 / 0.75, 1 / (5 / 12)])


@pytest.mark.parametrize("acc, vel, feed, tan", [
    (200.0, 1e7, 1e7, None),           # gentle 0.2 m/s^2
    (1000.0, 1e7, 1e7, None),          # typical
    (5000.0, 1e7, 1e7, None),          # stiff
    (1000.0, 400.0, 700.0, 300.0),     # slow axes, a feed limit and a tangential limit
])
def test_schedule_never_exceeds_its_limits(job, acc, vel, feed, tan):
    m = MachineProfile(name="t", max_feed_mm_min=feed, max_velocity_mm_min=(vel, vel, vel / 2),
                       max_acceleration_mm_s2=(acc, acc, acc / 2), max_tangential_acceleration_mm_s2=tan)
    tp, rep = schedule_feeds(job.tool_path, m)
    assert np.array_equal(tp.samples, job.tool_path.samples)  # same path, new times
    plan = _limits_of(job.tool_path)
    for got, was in zip(_limits_of(tp), plan):
        assert np.all(np.abs(got["acceleration"]) <= np.array([acc, acc, acc / 2]) * SLACK + 1e-9)
        assert np.all(np.abs(got["velocity"]) <= np.array([vel, vel, vel / 2]) / 60 * SLACK)
        assert np.all(got["speed"] <= feed / 60 * SLACK)
        assert np.all(got["speed"] <= was["speed"] * SLACK)  # never faster than planned
        if tan is not None:
            assert np.all(np.abs(got["tangential"]) <= tan * SLACK + 1e-9)
    # the planned schedule did exceed these limits (so the test means something)
    assert max(np.abs(w["acceleration"]).max() for w in plan) > acc
    assert rep["machining_time_s"] > rep["planned_time_s"] and rep["limited_share"] > 0
    assert rep["machining_time_s"] == pytest.approx(planned_segment_times(tp).sum(), rel=1e-9)


def test_gentler_machines_take_longer_and_miss_more(job):
    out = []
    for acc in (200.0, 1000.0, 5000.0):
        m = MachineProfile(max_acceleration_mm_s2=(acc,) * 3, max_velocity_mm_min=(1e7,) * 3, max_feed_mm_min=1e7)
        out.append(schedule_feeds(job.tool_path, m)[1])
    times = [r["machining_time_s"] for r in out]
    errs = [r["dwell_time_error"]["rms"] for r in out]
    assert times[0] > times[1] > times[2] and errs[0] > errs[1] > errs[2]
    # the delivered times of the dwell points add up to the path's time, and the report's worst point is worst
    r = out[1]
    assert r["worst_points"][0]["error"] == pytest.approx(r["dwell_time_error"]["max"])
    assert r["points_over_1pct"] > 0 and 0 < r["dwell_time_error"]["p99"] <= r["dwell_time_error"]["max"]


def test_no_active_limit_gives_todays_schedule(job):
    m = MachineProfile(name="unlimited", max_feed_mm_min=1e9, max_velocity_mm_min=(1e9,) * 3,
                       max_acceleration_mm_s2=(1e12,) * 3)
    tp, rep = schedule_feeds(job.tool_path, m)
    assert np.array_equal(tp.feed_mm_min, job.tool_path.feed_mm_min)
    # the smoothing schedule regenerates the interpolator's feeds, not a machine schedule's: dropped
    assert job.tool_path.schedule is not None and tp.schedule is None
    assert rep["limited_share"] == 0 and rep["dwell_time_error"]["max"] == 0.0 and rep["points_over_1pct"] == 0
    assert rep["machining_time_s"] == rep["planned_time_s"]
    # the delivered time of each dwell point is the schedule's own (its error against the wish is the plan's)
    t = dwell_point_times(tp, planned_segment_times(tp))
    assert t.sum() == pytest.approx(rep["planned_time_s"], rel=1e-9)
    assert rep["dwell_time_error_vs_wish"] == rep["schedule_error_vs_wish"]


def test_machine_profiles_load_and_refuse_bad_ones(tmp_path):
    g = load_machine("generic-3axis")
    assert g is BUILTIN_MACHINES["generic-3axis"] and g.post == "linuxcnc" and g.max_acceleration_mm_s2[0] == 1000
    f = tmp_path / "mill.toml"
    f.write_text('[machine]\npost = "fanuc"\nmax_feed_mm_min = 6000\nmax_velocity_mm_min = [6000, 6000, 3000]\n'
                 'max_acceleration_mm_s2 = [200, 200, 100]\nmax_jerk_mm_s3 = [5000, 5000, 2000]\nperiod_ms = 2\n')
    m = load_machine(f)
    assert m.name == "mill" and m.post == "fanuc" and m.period_ms == 2.0 and m.max_jerk_mm_s3 == (5000, 5000, 2000)
    for text, words in [("max_feed_mm_min = -1\n", "max_feed_mm_min must be a positive"),
                        ("max_acceleration_mm_s2 = [1, 2]\n", "three numbers"),
                        ("max_speed = 3\n", "unknown machine setting"),]:
        f.write_text("[machine]\n" + text)
        with pytest.raises(SpecError, match=words):
            load_machine(f)
    with pytest.raises(SpecError, match="neither a built-in"):
        load_machine(tmp_path / "nope.toml")


def _plan(out, *args):
    proc = subprocess.run([sys.executable, "-m", "polishpath", "plan", *args, "--no-report", "-q", "-o", str(out)],
                          capture_output=True, text=True)
    return proc


def test_plan_with_machine_writes_the_schedule_and_refuses_files_without_feeds(tmp_path):
    from conftest import REPO

    prof = REPO / "examples" / "machine-gentle.toml"
    r = _plan(tmp_path / "a", "hemisphere:R=12,triangles=700", "--spacing", "2", "--seed", "4", "--machine", str(prof))
    assert r.returncode == 0, r.stderr
    s = json.loads((tmp_path / "a" / "summary.json").read_text())
    sc = s["schedule"]
    assert sc["machine"]["name"] == "machine-gentle" and sc["machine"]["max_acceleration_mm_s2"][0] == 200
    assert sc["machining_time_s"] > sc["planned_time_s"] and set(sc["dwell_time_error"]) >= {"max", "p99", "rms"}
    assert s["machining_time_s"] > sc["machining_time_s"]  # + approach and retract moves
    assert s["config"]["machine"] == str(prof) and s["post"]["post"] == "linuxcnc"
    r = _plan(tmp_path / "b", "hemisphere:R=12,triangles=700", "--spacing", "2", "--machine", "generic-3axis",
              "--post", "xyz")
    assert r.returncode == 2 and "cannot carry a machine profile's feed schedule" in r.stderr
    r = _plan(tmp_path / "c", "hemisphere:R=12,triangles=700", "--spacing", "2", "--machine", "no-such-mill")
    assert r.returncode == 2 and "neither a built-in" in r.stderr and "Traceback" not in r.stderr
    from polishpath.config import JobConfig
    from polishpath.pipeline import check_machine_output

    with pytest.raises(ParameterError, match="cannot carry"):
        check_machine_output(JobConfig(machine="generic-3axis", post="csv"))
    assert check_machine_output(JobConfig(machine="generic-3axis")).name == "generic-3axis"
