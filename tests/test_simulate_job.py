"""simulate takes what the job made: SurfacePath / ToolPath inputs, the machine's own timing, a whole job."""

from __future__ import annotations

import numpy as np
import pytest

from polishpath.errors import ParameterError, PolishPathError
from polishpath.simulate import (
    TimedPath,
    flat_workpiece,
    gaussian_tif,
    path_motion_samples,
    simulate_job,
    simulate_path,
    timed_path,
)
from polishpath.types import ToolPath


@pytest.fixture(scope="module")
def shallow_job():
    from polishpath.pipeline import run

    return run(surface="hemisphere:R=20,angle=25,triangles=700", spacing=1.0, seed=2, report=False)


@pytest.fixture(scope="module")
def dome_job():
    from polishpath.pipeline import run

    return run(surface="hemisphere:R=12,triangles=700", spacing=1.0, seed=1, report=False)


def test_machine_timing_runs_the_samples_one_period_per_move(shallow_job):
    tp = shallow_job.tool_path
    t = timed_path(tp)
    m = len(tp.samples)
    k = len(tp.sample_pieces) - 1
    assert t.time_model == "moves" and t.timing == "machine" and t.plane == "xy"
    assert np.array_equal(t.xy, tp.samples[:, :2])
    assert np.array_equal(t.pieces, tp.sample_pieces)
    T = tp.period_ms / 1000
    assert t.time_s.sum() == pytest.approx((m - k) * T, rel=1e-12)
    assert t.time_s.sum() == pytest.approx(tp.stats["duration_s"], rel=1e-9)  # the job's machine time
    assert (t.time_s[t.pieces[1:] - 1] == 0).all()


def test_dwell_timing_uses_the_dwell_points_and_their_times(shallow_job):
    tp, sp = shallow_job.tool_path, shallow_job.surface_path
    t = timed_path(tp, timing="dwell")
    assert t.time_model == "segments" and np.array_equal(t.xy, sp.xyz[:, :2])
    assert np.array_equal(t.time_s, tp.dwell_times)
    u = timed_path(sp, timing="dwell", plane="unrolled", dwell_s=np.full(len(sp.xyz), 0.1))
    assert np.array_equal(u.xy, sp.planar.uv) and u.time_s.sum() == pytest.approx(0.1 * len(sp.xyz))
    assert np.array_equal(u.pieces, sp.planar.pieces)


def test_unrolled_machine_samples_follow_the_planar_path(shallow_job):
    tp, sp = shallow_job.tool_path, shallow_job.surface_path
    # a tool path whose samples are its dwell points lands exactly on the planar path
    at_dwell = ToolPath(tp.curve, tp.dwell_params, sp.xyz, tp.dwell_params, np.full(len(sp.xyz), 600.0), 4.0, sp,
                        sample_pieces=sp.planar.pieces, piece_params=tp.piece_params)
    assert np.allclose(timed_path(at_dwell, plane="unrolled").xy, sp.planar.uv, atol=1e-12)
    # the real samples stay within one planar step of the planar path
    u = timed_path(tp, plane="unrolled").xy
    from scipy.spatial import cKDTree

    d, _ = cKDTree(sp.planar.uv).query(u)
    assert d.max() <= np.sqrt(2) * sp.planar.spacing / 2 + 1e-9


def test_bad_path_inputs_raise_polishpath_errors(shallow_job):
    tp, sp = shallow_job.tool_path, shallow_job.surface_path
    cases = [
        lambda: timed_path(sp),  # a SurfacePath has no machine samples
        lambda: timed_path(sp, timing="dwell"),  # and no times of its own
        lambda: timed_path(sp, timing="dwell", dwell_s=np.ones(3)),
        lambda: timed_path(sp, timing="dwell", dwell_s=-np.ones(len(sp.xyz))),
        lambda: timed_path(tp, timing="teleport"),
        lambda: timed_path(tp, plane="polar"),
        lambda: timed_path(np.zeros((4, 2))),
        lambda: TimedPath(np.zeros((3, 2)), np.zeros(2), None, "moves", "xy", "machine"),
        lambda: simulate_path(tp, flat_workpiece((0, 0, 1, 1), 0.1), gaussian_tif(), pieces=[0, 1]),
    ]
    for f in cases:
        with pytest.raises(PolishPathError):
            f()


def test_moves_time_model_spreads_each_move_time_along_it():
    xy = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    s, t, head, arc, length, _ = path_motion_samples(xy, np.array([2.0, 3.0, 0.0]), 0.01, time_model="moves")
    assert t.sum() == pytest.approx(5.0, rel=1e-12)
    first = np.isclose(s[:, 1], 0.0)
    assert t[first].sum() == pytest.approx(2.0) and t[~first].sum() == pytest.approx(3.0)
    assert np.allclose(length / t, np.where(first, 0.5, 1 / 3))  # feed = move length / move time
    assert arc.max() < 2.0 and np.allclose(head[first], 0.0) and np.allclose(head[~first], np.pi / 2)
    # time left at the last point of a piece is spent standing there; a lift between pieces takes none
    s2, t2, *_ = path_motion_samples(xy, np.array([2.0, 1.0, 4.0]), 0.01, pieces=[0, 2, 3], time_model="moves")
    assert t2.sum() == pytest.approx(7.0)
    assert t2[np.all(s2 == [1.0, 0.0], axis=1)].sum() == pytest.approx(1.0)
    assert t2[np.all(s2 == [1.0, 1.0], axis=1)].sum() == pytest.approx(4.0)


def test_simulate_path_removes_with_the_runs_own_time(shallow_job):
    tp = shallow_job.tool_path
    wp = flat_workpiece((-12, -12, 12, 12), 0.05)
    tif = gaussian_tif(5.0, fwhm_mm=1.0)
    machine = simulate_path(tp, wp, tif)
    assert machine.stats["total_time_s"] == pytest.approx(tp.stats["duration_s"], rel=1e-9)
    assert machine.stats["time_off_grid_s"] == 0.0
    assert machine.stats["path"]["timing"] == "machine" and machine.provenance.params["path"]["time_model"] == "moves"
    assert machine.stats["removed_volume_nm_mm2"] == pytest.approx(tif.volume_rate * tp.stats["duration_s"], rel=1e-4)
    dwell = simulate_path(tp, wp, tif, timing="dwell")
    assert dwell.stats["total_time_s"] == pytest.approx(tp.dwell_times.sum(), rel=1e-12)
    same = simulate_path(shallow_job.surface_path, wp, tif, timing="dwell", dwell_s=tp.dwell_times)
    assert np.array_equal(same.removal_nm, dwell.removal_nm)


def test_simulate_job_picks_the_plane_and_removes_the_depth(shallow_job, dome_job):
    a = simulate_job(shallow_job.tool_path, shallow_job.surface, flattening=shallow_job.flattening, dx_mm=0.1)
    s = a["summary"]
    assert a["plane"] == "xy" and "height field" in a["plane_reason"]
    assert s["depth_mean_nm"] == pytest.approx(200.0, rel=1e-6)
    assert s["total_time_s"] == pytest.approx(shallow_job.tool_path.stats["duration_s"], rel=1e-9)
    assert 0 < s["depth_rms_rel"] < 0.5 and a["mask"].sum() > 1000
    b = simulate_job(dome_job.tool_path, dome_job.surface, flattening=dome_job.flattening, dx_mm=0.1)
    assert b["plane"] == "unrolled"
    # on the dome the projection piles the rim up; the unrolled plane, corrected by the area ratio, stays flatter
    c = simulate_job(dome_job.tool_path, dome_job.surface, flattening=dome_job.flattening, dx_mm=0.1, plane="xy")
    assert b["summary"]["depth_rms_rel"] < c["summary"]["depth_rms_rel"]
    with pytest.raises(ParameterError, match="pixels"):
        simulate_job(dome_job.tool_path, dome_job.surface, dx_mm=0.001, plane="xy")
    with pytest.raises(ParameterError, match="flattening"):
        simulate_job(dome_job.tool_path, dome_job.surface, plane="unrolled")


def test_area_ratio_map_is_smooth_and_follows_the_flattening(dome_job):
    from polishpath import meshops
    from polishpath.simulate.jobpath import area_ratio_map

    fl = dome_job.flattening
    dx = 0.05
    lo = fl.uv.min(axis=0)
    shape = (int(np.ptp(fl.uv[:, 1]) / dx) + 1, int(np.ptp(fl.uv[:, 0]) / dx) + 1)
    r = area_ratio_map(fl, shape, lo, dx)
    assert r.shape == shape and np.isfinite(r).all()
    face = meshops.face_areas(fl.uv, fl.surface.faces) / meshops.face_areas(fl.surface.vertices, fl.surface.faces)
    # no steps from the coarse grid or the triangles: neighbouring pixels differ by a small part of the range
    span = face.max() - face.min()
    assert np.abs(np.diff(r, axis=0)).max() < 0.05 * span and np.abs(np.diff(r, axis=1)).max() < 0.05 * span
    # and the field follows the triangles' own ratio (at their centroids)
    c = fl.uv[fl.surface.faces].mean(axis=1)
    ij = np.rint((c - lo) / dx).astype(int)
    at = r[ij[:, 1], ij[:, 0]]
    assert np.corrcoef(at, face)[0, 1] > 0.9
    assert np.median(np.abs(at / face - 1)) < 0.05
