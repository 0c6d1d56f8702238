"""NURBS interpolation, evaluation and constant-period interpolation (issue 5, items 4-5)."""

from __future__ import annotations

import numpy as np
import pytest

from polishpath.errors import ParameterError, SmoothingError
from polishpath.mapping import map_to_surface
from polishpath.smooth import (
    chord_errors,
    evaluate,
    interpolate_constant_period,
    interpolate_nurbs,
    join_curves,
    piece_curves,
    sample_normals,
    smooth,
)
from polishpath.types import NurbsCurve
from test_mapping_helpers import polyline_surface_path, serpentine_path, spherical_cap


def _walk(n, seed=0, d=3):
    """A self-avoiding 8-direction walk on a 0.5 mm grid (like the planner's paths), on a gentle dome (mm)."""
    rng = np.random.default_rng(seed)
    dirs = np.array([[1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1]])
    cur, seen, out = (0, 0), {(0, 0)}, [(0, 0)]
    while len(out) < n:
        free = [(cur[0] + a, cur[1] + b) for a, b in dirs if (cur[0] + a, cur[1] + b) not in seen]
        if not free:
            break
        cur = free[rng.integers(len(free))]
        seen.add(cur)
        out.append(cur)
    xy = np.array(out, dtype=np.float64) * 0.5
    if d == 2:
        return xy
    return np.column_stack([xy, 0.01 * (xy**2).sum(1) ** 0.5])


@pytest.mark.parametrize("centripetal", [False, True])
@pytest.mark.parametrize("n", [5, 12, 40])
def test_interpolation_matches_geomdl(n, centripetal):
    fitting = pytest.importorskip("geomdl.fitting")
    pts = _walk(n, seed=n)
    curve, u = interpolate_nurbs(pts, 3, "centripetal" if centripetal else "chord")
    ref = fitting.interpolate_curve(pts.tolist(), 3, centripetal=centripetal)
    assert np.allclose(curve.knots, ref.knotvector, atol=1e-12)
    assert np.allclose(curve.control_points, np.array(ref.ctrlpts), atol=1e-9)
    uu = np.linspace(0, 1, 97)
    assert np.abs(evaluate(curve, uu) - np.array(ref.evaluate_list(uu.tolist()))).max() < 1e-9


def test_curve_passes_through_every_point_and_knots_are_clamped():
    pts = _walk(3000, seed=1)
    curve, u = interpolate_nurbs(pts)
    n, p = len(pts), curve.degree
    assert p == 3 and len(curve.control_points) == n and len(curve.knots) == n + p + 1
    assert np.all(np.diff(curve.knots) >= 0)
    assert np.all(curve.knots[: p + 1] == 0) and np.all(curve.knots[-(p + 1):] == 1)
    assert np.all(np.diff(u) > 0) and u[0] == 0 and u[-1] == 1
    assert np.abs(evaluate(curve, u) - pts).max() <= 1e-9
    assert np.all(curve.weights == 1)


def test_centripetal_parameters_follow_square_root_of_chords():
    pts = _walk(50, seed=5)
    _, u = interpolate_nurbs(pts, parametrization="centripetal")
    d = np.sqrt(np.linalg.norm(np.diff(pts, axis=0), axis=1))
    assert np.allclose(np.diff(u), d / d.sum(), atol=1e-14)
    with pytest.raises(ParameterError):
        interpolate_nurbs(pts, parametrization="uniformish")


@pytest.mark.parametrize("n", [2, 3])
def test_short_inputs_lower_the_degree(n):
    pts = _walk(10, seed=2)[:n]
    curve, u = interpolate_nurbs(pts, 3)
    assert curve.degree == n - 1
    assert np.abs(evaluate(curve, u) - pts).max() <= 1e-12


def test_bad_inputs_raise_clear_errors():
    pts = _walk(10, seed=3)
    rep = np.insert(pts, 4, pts[4], axis=0)
    with pytest.raises(SmoothingError, match="coincide"):
        interpolate_nurbs(rep)
    with pytest.raises(SmoothingError, match="at least 2"):
        interpolate_nurbs(pts[:1])
    bad = pts.copy()
    bad[2, 0] = np.nan
    with pytest.raises(SmoothingError, match="NaN"):
        interpolate_nurbs(bad)


def test_derivatives_match_finite_differences():
    curve, _ = interpolate_nurbs(_walk(30, seed=4))
    u = np.linspace(0.01, 0.99, 57)
    c, d1, d2 = evaluate(curve, u, 2)
    e = 1e-6
    fd1 = (evaluate(curve, u + e) - evaluate(curve, u - e)) / (2 * e)
    fd2 = (evaluate(curve, u + e, 1)[1] - evaluate(curve, u - e, 1)[1]) / (2 * e)
    assert np.abs(fd1 - d1).max() <= 1e-6 * np.abs(d1).max()
    assert np.abs(fd2 - d2).max() <= 1e-5 * np.abs(d2).max()


def test_rational_evaluation_draws_an_exact_circle():
    # quarter circle: weights 1, sqrt(2)/2, 1 (Eq. 10 with non-unit weights)
    w = np.array([1, 2**-0.5, 1])
    quarter = NurbsCurve(2, np.array([0, 0, 0, 1, 1, 1.0]), np.array([[1, 0], [1, 1], [0, 1.0]]), w)
    u = np.linspace(0, 1, 101)
    c, d1, _ = evaluate(quarter, u, 2)
    assert np.abs(np.linalg.norm(c, axis=1) - 1).max() < 1e-12
    assert np.abs(np.einsum("ij,ij->i", c, d1)).max() < 1e-9  # tangent perpendicular to the radius


def test_joined_pieces_keep_their_own_shapes():
    a, b = _walk(20, seed=6), _walk(9, seed=7) + 50.0
    ca, ua = interpolate_nurbs(a)
    cb, ub = interpolate_nurbs(b)
    joined, off = join_curves([ca, cb], [1.0, 3.0])
    assert off.tolist() == [0.0, 0.25, 1.0]
    assert np.abs(evaluate(joined, 0.25 * ua[:-1]) - a[:-1]).max() < 1e-9
    assert np.abs(evaluate(joined, 0.25 + 0.75 * ub) - b).max() < 1e-9
    parts = piece_curves(joined, off)
    assert [len(p.control_points) for p in parts] == [20, 9]
    assert np.allclose(parts[1].control_points, cb.control_points)


def test_constant_period_keeps_the_chord_error_under_tolerance():
    curve, _ = interpolate_nurbs(_walk(120, seed=8))
    tol = 2e-4
    res = interpolate_constant_period(curve, 1200.0, 2.0, tol)
    u, pts, feed = res["params"], res["samples"], res["feed_mm_min"]
    assert u[0] == 0 and u[-1] == 1 and np.all(np.diff(u) > 0)
    assert np.abs(pts - evaluate(curve, u)).max() < 1e-12
    # independent, finer check of the chord error than the interpolator's own
    assert chord_errors(curve, u, pts, n_check=9).max() <= tol * 1.001
    assert res["stats"]["chord_error_max"] <= tol
    # the feed is cut on the tight turns of the walk, never raised above the wish
    assert feed.max() <= 1200.0 + 1e-9
    assert res["stats"]["feed_limited_share"] > 0
    # each step travels the commanded V*T (second-order Taylor step): fluctuation small
    steps = np.linalg.norm(np.diff(pts, axis=0), axis=1)[:-1]
    assert np.abs(steps / (feed[1:-1] / 60 * 0.002) - 1).max() < 0.02


def test_compiled_chord_errors_match_a_direct_computation():
    curve, _ = interpolate_nurbs(_walk(80, seed=4))
    res = interpolate_constant_period(curve, 1200.0, 2.0, 5e-4)
    u, pts = res["params"], res["samples"]
    for n_check in (1, 3, 7):
        f = np.arange(1, n_check + 1) / (n_check + 1)
        pm = evaluate(curve, (u[:-1, None] + f[None, :] * (u[1:] - u[:-1])[:, None]).ravel()).reshape(len(u) - 1,
                                                                                                    n_check, 3)
        a, e = pts[:-1, None, :], (pts[1:] - pts[:-1])[:, None, :]
        t = np.clip(((pm - a) * e).sum(-1) / (e * e).sum(-1), 0, 1)
        want = np.linalg.norm(a + t[..., None] * e - pm, axis=-1).max(axis=1)
        assert np.allclose(chord_errors(curve, u, pts, n_check=n_check), want, rtol=1e-9, atol=1e-15)
    assert res["stats"]["chord_error_max"] == pytest.approx(chord_errors(curve, u, pts).max(), rel=1e-12)


def test_planar_curve_runs_as_a_3d_one_with_z_zero():
    xy = _walk(60, seed=6, d=2)
    c2, _ = interpolate_nurbs(xy)
    c3, _ = interpolate_nurbs(np.column_stack([xy, np.zeros(len(xy))]))
    r2 = interpolate_constant_period(c2, 900.0, 2.0, 1e-3)
    r3 = interpolate_constant_period(c3, 900.0, 2.0, 1e-3)
    assert r2["samples"].shape[1] == 2
    assert np.array_equal(r2["samples"], r3["samples"][:, :2]) and np.array_equal(r2["params"], r3["params"])
    c4 = NurbsCurve(3, c2.knots, np.column_stack([c2.control_points, np.zeros((len(xy), 2))]), c2.weights)
    with pytest.raises(SmoothingError, match="up to 3 dimensions"):
        interpolate_constant_period(c4, 900.0, 2.0, 1e-3)


def test_constant_period_without_curvature_limit_runs_at_the_feed():
    line = NurbsCurve(3, np.array([0, 0, 0, 0, 1, 1, 1, 1.0]), np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0.0]]))
    res = interpolate_constant_period(line, 600.0, 4.0, 1e-3)
    steps = np.linalg.norm(np.diff(res["samples"], axis=0), axis=1)
    assert np.allclose(steps[:-1], 600 / 60 * 0.004, rtol=1e-9)
    assert res["stats"]["duration_s"] == pytest.approx(3.0 / 10.0, abs=0.004 + 1e-12)
    with pytest.raises(ParameterError):
        interpolate_constant_period(line, -1.0, 4.0, 1e-3)


def test_dwell_times_become_a_feed_schedule():
    pts = _walk(60, seed=9)
    curve, u = interpolate_nurbs(pts)
    rng = np.random.default_rng(1)
    times = rng.uniform(0.2, 0.8, len(pts))
    res = interpolate_constant_period(curve, 600.0, 1.0, 1e-2, dwell_params=u, dwell_times=times)
    assert res["stats"]["dwell_time_error_max"] < 0.03
    assert res["stats"]["duration_s"] == pytest.approx(times.sum(), rel=0.01)


def _rms(rel):
    return float(np.sqrt(np.mean(np.asarray(rel) ** 2)))


@pytest.mark.parametrize("integrator", ["taylor", "ab-am"])
def test_the_schedule_model_and_a_corrective_pass_make_up_for_curvature_slowdowns(integrator):
    """Feeds solved from each region's time under the curvature limit meet the times far better than
    length / time; correcting the regions still off (a corrective pass; the Taylor kernel runs such a
    region again at once) brings them nearer still."""
    import polishpath.smooth.interpolate as interp
    from polishpath.smooth.samples import KernelRun

    pts = _walk(80, seed=12)
    curve, u = interpolate_nurbs(pts)
    times = np.full(len(pts), 0.03)  # ~1000 mm/min wanted: the tight turns must be run slower
    one = interpolate_constant_period(curve, 600.0, 2.0, 1e-3, dwell_params=u, dwell_times=times,
                                      max_feed_mm_min=6000.0, schedule_passes=1, integrator=integrator)
    more = interpolate_constant_period(curve, 600.0, 2.0, 1e-3, dwell_params=u, dwell_times=times,
                                       max_feed_mm_min=6000.0, schedule_passes=4, integrator=integrator)
    # the nominal schedule: each region's length over its time, as if the curvature limit did not slow it
    u0, u1 = float(curve.knots[0]), float(curve.knots[-1])
    rb = interp.dwell_regions(u, u0, u1)
    nominal_feed = interp.arc_lengths(curve, rb[:-1], rb[1:], split=u) / times
    kr = KernelRun(interp.INTEGRATORS["taylor"], interp.kernel_curve(curve), u0, u1, rb, nominal_feed, 100.0, 0.002,
                   1e-3, cap=100_000)
    list(kr)
    nominal = np.diff(kr.boundary_times()) / times - 1
    assert np.abs(nominal).max() > 0.2 and kr.figures()["feed_limited_share"] > 0.05
    assert one["stats"]["schedule_passes"] == 1
    assert one["stats"]["dwell_time_error_max"] < 0.5 * np.abs(nominal).max()
    assert _rms(one["dwell_time_error"]) < 0.5 * _rms(nominal)
    assert 2 <= more["stats"]["schedule_passes"] <= 4 and more["stats"]["schedule_corrected_regions"] > 0
    assert _rms(more["dwell_time_error"]) < _rms(one["dwell_time_error"])
    for res in (one, more):
        assert res["stats"]["chord_error_max"] <= 1e-3 and res["stats"]["feed_max_mm_min"] <= 6000.0 + 1e-9


def test_smooth_stage_on_a_mapped_path():
    cap = spherical_cap(n_r=12, n_phi=40)
    path = serpentine_path(cap, 1.5, seed=11)
    sp = map_to_surface(cap, path)
    assert len(path.pieces) > 2  # several pieces: the tool lifts between them
    tp = smooth(sp, surface=cap.surface, feed_mm_min=1200.0, period_ms=4.0, chord_tol_mm=1e-3)
    # through every dwell point
    assert np.abs(evaluate(tp.curve, tp.dwell_params) - sp.xyz).max() <= 1e-9
    assert tp.stats["dwell_through_max"] <= 1e-9
    assert np.all(np.diff(tp.dwell_params) > 0) and np.all(np.diff(tp.curve.knots) >= 0)
    # samples: per piece, start and end on its first and last dwell point
    sp_off = tp.sample_pieces
    for k in range(len(path.pieces) - 1):
        s0, s1 = tp.samples[sp_off[k]], tp.samples[sp_off[k + 1] - 1]
        assert np.linalg.norm(s0 - sp.xyz[path.pieces[k]]) < 1e-9
        assert np.linalg.norm(s1 - sp.xyz[path.pieces[k + 1] - 1]) < 1e-9
    assert tp.stats["chord_error_max"] <= 1e-3
    # deviation figures measured against the mesh
    assert 0 < tp.stats["surface_deviation_max"] < 0.5
    assert tp.stats["lateral_overshoot_max"] >= 0
    # default dwell times: uniform times the area weight
    t = tp.dwell_times
    assert np.allclose(t / t.mean(), sp.dwell_weight / sp.dwell_weight.mean())
    assert tp.provenance.seed == 11 and tp.provenance.params["period_ms"] == 4.0
    n = sample_normals(tp)
    assert n.shape == tp.samples.shape and np.allclose(np.linalg.norm(n, axis=1), 1)


def test_smooth_short_pieces_and_given_times():
    pts = np.concatenate([_walk(8, seed=1), _walk(3, seed=2) + 20, _walk(2, seed=3) - 20])
    sp = polyline_surface_path(pts, pieces=[0, 8, 11, 13])
    times = np.full(len(pts), 0.05)
    tp = smooth(sp, dwell_times=times, period_ms=1.0)
    assert np.abs(evaluate(tp.curve, tp.dwell_params) - pts).max() <= 1e-9
    assert tp.stats["dwell_time_source"] == "given"
    with pytest.raises(ParameterError):
        smooth(sp, dwell_times=times[:-1])


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 40), d=st.sampled_from([2, 3]), seed=st.integers(0, 10**6),
       centripetal=st.booleans())
def test_property_interpolation_passes_through_random_points(n, d, seed, centripetal):
    pts = np.random.default_rng(seed).normal(scale=5.0, size=(n, d))
    curve, u = interpolate_nurbs(pts, 3, "centripetal" if centripetal else "chord")
    p = curve.degree
    assert p == min(3, n - 1)
    assert np.all(np.diff(curve.knots) >= 0)
    assert np.all(curve.knots[: p + 1] == 0) and np.all(curve.knots[-(p + 1):] == 1)
    assert np.abs(evaluate(curve, u) - pts).max() <= 1e-9


def test_point_mesh_distance_on_a_plane():
    from polishpath.smooth import point_mesh_distance
    from polishpath.types import Surface
    from test_mapping_helpers import grid_faces

    x, y = np.meshgrid(np.linspace(0, 10, 11), np.linspace(0, 10, 11), indexing="ij")
    plane = Surface(np.column_stack([x.ravel(), y.ravel(), np.zeros(121)]), grid_faces(11, 11))
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(1, 9, 50), rng.uniform(1, 9, 50), rng.uniform(-2, 2, 50)])
    assert np.allclose(point_mesh_distance(pts, plane), np.abs(pts[:, 2]), atol=1e-12)


@pytest.mark.parametrize("integrator", ["taylor", "ab-am"])
def test_interpolation_does_not_stall_at_a_cusp(integrator):
    """Regression: a pseudo-random path on the pentagram whose spline has |C'| ~ 1e-13 at a
    doubling-back turn made the constant-period interpolator stall (zero feed, no progress).
    Run in a subprocess so a stall fails the test instead of hanging the suite."""
    import subprocess
    import sys

    code = (
        "from polishpath.surfaces import load_surface\n"
        "from polishpath.flatten import boundary_region, flatten\n"
        "from polishpath.pipeline import plan_on_surface\n"
        "from polishpath.smooth import smooth\n"
        "s = load_surface('pentagram:triangles=1200'); flat = flatten(s, 'mabf'); region = boundary_region(flat)\n"
        "sp = plan_on_surface(flat, region, 1.4, seed=0).surface_path\n"
        f"tp = smooth(sp, integrator={integrator!r})\n"
        "print(tp.stats['chord_error_max'], tp.stats['dwell_through_max'], len(tp.samples))\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    chord, through, n = r.stdout.split()
    assert float(chord) <= 1e-3 * (1 + 1e-6)
    assert float(through) < 1e-9
    assert int(n) > 1000


def test_chord_error_bound_holds_on_every_step_of_a_run():
    """The bound that spares the measurement (spans.chord_error_within) is never below the measured chord error."""
    from polishpath.smooth.interpolate import _kernel_coeffs
    from polishpath.smooth.spans import chord_error_within, span_bend_bounds

    curve, _ = interpolate_nurbs(_walk(150, seed=11))
    res = interpolate_constant_period(curve, 600.0, 4.0, 1e-3)
    u, pts = res["params"], res["samples"]
    breaks, coeffs, _ = _kernel_coeffs(curve)
    bends, size = span_bend_bounds(breaks, coeffs)
    assert size == pytest.approx(np.abs(coeffs[:, 0, :3]).max())
    bound = np.array([chord_error_within(breaks, coeffs, bends, 0, a, b) for a, b in zip(u[:-1], u[1:])])
    measured = chord_errors(curve, u, pts, n_check=15)
    assert np.all(measured <= bound * (1 + 1e-9) + 1e-15)
    # and it is tight enough to be useful: most steps of the walk are proven under the tolerance unmeasured
    assert np.mean(bound <= 0.99 * 1e-3) > 0.8
    # the span bound is the largest |C''| over the span (checked against dense sampling)
    uu = np.linspace(curve.knots[0], curve.knots[-1], 20001)[:-1]
    d2 = np.linalg.norm(evaluate(curve, uu, 2)[2], axis=1)
    span = np.clip(np.searchsorted(breaks, uu, side="right") - 1, 0, len(bends) - 1)
    assert np.all(d2 <= bends[span] * (1 + 1e-9) + 1e-12)


def test_samples_near_the_boundary_are_all_found():
    """The anchored search (boundary._near_boundary) finds the same points as querying every one."""
    from scipy.spatial import cKDTree

    from polishpath.smooth.boundary import _near_boundary

    rng = np.random.default_rng(3)
    steps = rng.normal(scale=0.05, size=(20000, 3))
    pts = np.cumsum(steps, axis=0)
    tree = cKDTree(rng.uniform(pts.min(0), pts.max(0), size=(300, 3)))
    for limit in (0.1, 0.7, 3.0):
        d, _ = tree.query(pts)
        want = np.flatnonzero(d <= limit)
        for stride in (1, 7, 64):
            assert np.array_equal(_near_boundary(pts, tree, limit, stride=stride), want)


def test_the_best_schedule_pass_is_run_again_when_a_later_one_is_worse(monkeypatch):
    """Only one pass's samples are held: when the last pass is worse, the best one's feeds are run again, same bytes
    (the whole schedule passes of an integrator without a scheduling kernel)."""
    import polishpath.smooth.interpolate as interp
    from polishpath.smooth.spans import new_state

    pts = _walk(80, seed=12)
    curve, u = interpolate_nurbs(pts)
    times = np.full(len(pts), 0.03)
    real = interp.INTEGRATORS["ab-am"]
    calls = []

    def spoiled(breaks, coeffs, bends, size, u0, u1, rb, rfeed, vmax, T, tol, state, limit, region_times):
        calls.append(np.array(rfeed))
        if len(calls) == 2:  # the corrective pass goes badly wrong
            rfeed = rfeed * 3.0
        return real(breaks, coeffs, bends, size, u0, u1, rb, rfeed, vmax, T, tol, state, limit, region_times)

    monkeypatch.setitem(interp.INTEGRATORS, "ab-am", spoiled)
    res = interpolate_constant_period(curve, 600.0, 2.0, 1e-3, dwell_params=u, dwell_times=times,
                                      max_feed_mm_min=6000.0, schedule_passes=2, integrator="ab-am")
    assert len(calls) == 3 and res["stats"]["schedule_passes"] == 2
    assert not np.array_equal(calls[1], calls[0]) and np.array_equal(calls[2], calls[0])  # pass 1 run again
    assert np.array_equal(res["region_feed"], calls[0])
    monkeypatch.setitem(interp.INTEGRATORS, "ab-am", real)
    kc = interp.kernel_curve(curve)
    u0, u1 = float(curve.knots[0]), float(curve.knots[-1])
    rb = interp.dwell_regions(u, u0, u1)
    want = real(kc.breaks, kc.coeffs, kc.bends, kc.size, u0, u1, rb, calls[0], 100.0, 0.002, 1e-3, new_state(),
                10**6, np.zeros(len(rb)))
    assert np.array_equal(res["params"], want[0]) and np.array_equal(res["samples"], want[1])
    one = interpolate_constant_period(curve, 600.0, 2.0, 1e-3, dwell_params=u, dwell_times=times,
                                      max_feed_mm_min=6000.0, schedule_passes=1, integrator="ab-am")
    assert np.array_equal(one["params"], res["params"]) and one["stats"]["dwell_time_error_max"] == \
        res["stats"]["dwell_time_error_max"]


def test_dwell_times_are_met_better_than_the_fixed_point_schedule_did():
    """The mapped cap path at 1200 mm/min, 4 ms, 1 um: before the schedule model (three fixed-point passes)
    the regions of its pieces missed their time by up to 12.9 % (p99 11.0 %, RMS 2.02 %); now by under 5 %.
    (A one-point piece has no length to run its time along: its region is left out of the largest.)"""
    cap = spherical_cap(n_r=12, n_phi=40)
    sp = map_to_surface(cap, serpentine_path(cap, 1.5, seed=11))
    tp = smooth(sp, feed_mm_min=1200.0, period_ms=4.0, chord_tol_mm=1e-3)
    st = tp.stats
    assert st["dwell_time_error_p99"] < 0.05 and st["dwell_time_error_rms"] < 0.0202
    assert st["schedule_passes"] <= 2 and st["chord_error_max"] <= 1e-3
    pieces, off = sp.planar.pieces, tp.piece_params
    worst = 0.0
    for k in range(len(pieces) - 1):
        sl = slice(pieces[k], pieces[k + 1])
        if pieces[k + 1] - pieces[k] < 2:
            continue
        res = interpolate_constant_period(tp.curve, 1200.0, 4.0, 1e-3, dwell_params=tp.dwell_params[sl],
                                          dwell_times=tp.dwell_times[sl], max_feed_mm_min=6000.0,
                                          u_range=(off[k], np.nextafter(off[k + 1], -np.inf)))
        assert np.array_equal(res["params"], tp.sample_params[tp.sample_pieces[k]:tp.sample_pieces[k + 1]])
        worst = max(worst, float(np.abs(res["dwell_time_error"]).max()))
    assert 0 < worst < 0.05


def test_compiled_edge_distance_matches_the_vectorised_one():
    """boundary._edge_distance (a compiled loop over each point's candidate edges) = _segment_distance's minimum."""
    from polishpath.smooth.boundary import _edge_distance, _segment_distance

    rng = np.random.default_rng(1)
    a = rng.normal(size=(300, 3))
    b = a + rng.normal(scale=0.1, size=(300, 3))
    b[7] = a[7]  # a zero-length edge
    p = rng.normal(size=(1000, 3))
    near = rng.integers(0, 300, size=(1000, 16))
    near[:, 0] = 7
    want = _segment_distance(p[:, None, :], a[near], b[near]).min(axis=1)
    assert np.allclose(_edge_distance(p, a, b, near), want, rtol=1e-14, atol=1e-15)


def test_the_tool_path_takes_the_stage_s_frozen_arrays_without_a_copy():
    """smooth() hands its sample arrays over read-only, so ToolPath keeps them (no copy of 15 M samples at
    10^6 dwell points); an array a writeable one shares memory with is still copied."""
    import dataclasses

    sp = polyline_surface_path(_walk(30, seed=4))
    tp = smooth(sp)
    assert not tp.samples.flags.writeable and not tp.sample_params.flags.writeable
    kept = dataclasses.replace(tp, feed_mm_min=tp.feed_mm_min)
    assert kept.samples is tp.samples and kept.feed_mm_min is tp.feed_mm_min  # frozen: taken as they are
    mine = np.array(tp.samples)  # writeable: copied
    view = mine[:]
    view.setflags(write=False)  # read-only, but its base can still change: copied
    for arr in (mine, view):
        other = dataclasses.replace(tp, samples=arr)
        assert not np.shares_memory(other.samples, mine) and np.array_equal(other.samples, mine)
        assert not other.samples.flags.writeable
    mine[0, 0] += 1.0
    assert other.samples[0, 0] == tp.samples[0, 0]


def test_the_compiled_collocation_band_is_the_vectorised_basis_scattered():
    """interpolate_nurbs assembles its banded system in one compiled loop: the same values, bit for bit, as
    basis_functions (P&T A2.2, vectorised) scattered into LAPACK's banded storage."""
    from polishpath.smooth.nurbs import _collocation_band, averaged_knots, basis_functions, find_spans, interpolation_params

    for n, p in ((200, 3), (7, 2), (4, 3)):
        pts = _walk(n, seed=n)
        n = len(pts)  # (the walk may stop early)
        u = interpolation_params(pts, "chord")
        knots = averaged_knots(u, p)
        spans = find_spans(knots, p, n, u)
        ab, lo, up = _collocation_band(knots, p, spans, u)
        basis = basis_functions(knots, p, spans, u)
        dense = np.zeros((n, n))
        for k in range(n):
            dense[k, spans[k] - p: spans[k] + 1] = basis[k]
        rows, cols = np.nonzero(dense)
        assert lo == max(0, (rows - cols).max()) and up == max(0, (cols - rows).max())
        want = np.zeros((lo + up + 1, n))
        want[up + rows - cols, cols] = dense[rows, cols]
        assert np.array_equal(ab, want)
