"""The two constant-period integrators (issue 19): Taylor + chord corrector, and the paper's Adams-Bashforth /
Adams-Moulton, on curves whose arc length is known, their order, and the job's dwell points."""

from __future__ import annotations

import numpy as np
import pytest

from polishpath.errors import ParameterError
from polishpath.mapping import map_to_surface
from polishpath.smooth import (
    INTEGRATORS,
    chord_errors,
    evaluate,
    interpolate_constant_period,
    interpolate_nurbs,
    smooth,
)
from polishpath.smooth.abam import adams_weights
from polishpath.types import NurbsCurve
from test_mapping_helpers import serpentine_path, spherical_cap

BOTH = sorted(INTEGRATORS)


def exact_arc(curve: NurbsCurve, us: np.ndarray) -> np.ndarray:
    """Arc length from ``us[0]`` to each of ``us`` (increasing), mm: 10-point Gauss-Legendre on every
    interval between consecutive parameters and knots (so no interval straddles a knot: exact to rounding)."""
    kn = np.unique(curve.knots)
    nodes = np.union1d(us, kn[(kn > us[0]) & (kn < us[-1])])
    gx, gw = np.polynomial.legendre.leggauss(10)
    a, b = nodes[:-1], nodes[1:]
    uu = (0.5 * (a + b))[:, None] + (0.5 * (b - a))[:, None] * gx[None, :]
    sp = np.linalg.norm(evaluate(curve, uu.ravel(), 1)[1], axis=1).reshape(uu.shape)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (b - a) * (sp * gw).sum(axis=1))])
    return np.interp(us, nodes, cum)


def circle_or_helix(kind: str, radius: float = 10.0, n: int = 129, seed: int = 3):
    """Cubic spline through n points at uneven angles on one turn of a circle or a helix (pitch 5 mm), so |C'|
    varies along the curve; returns the curve and the true arc length of the circle / helix turn."""
    rng = np.random.default_rng(seed)
    th = np.sort(np.concatenate([[0.0, 2 * np.pi], rng.uniform(0, 2 * np.pi, n - 2)]))
    pitch = 5.0 if kind == "helix" else 0.0
    pts = np.column_stack([radius * np.cos(th), radius * np.sin(th), pitch * th / (2 * np.pi)])
    curve, _ = interpolate_nurbs(pts)
    return curve, float(np.hypot(2 * np.pi * radius, pitch))


def test_adams_weights_are_the_textbook_ones_and_integrate_cubics_exactly():
    assert np.allclose(adams_weights(np.array([0.0, -1, -2, -3])) * 24, [55, -59, 37, -9], atol=1e-12)
    assert np.allclose(adams_weights(np.array([1.0, 0, -1, -2])) * 24, [9, 19, -5, 1], atol=1e-12)
    # uneven steps: the weights integrate every cubic over [0, 1] exactly
    nodes = np.array([0.0, -0.7, -1.9, -2.2])
    w = adams_weights(nodes)
    for k in range(4):
        assert w @ nodes**k == pytest.approx(1.0 / (k + 1), abs=1e-12)


@pytest.mark.parametrize("kind", ["circle", "helix"])
@pytest.mark.parametrize("integrator", BOTH)
def test_both_hold_the_feed_and_the_chord_tolerance_on_a_circle_and_a_helix(kind, integrator):
    curve, true_length = circle_or_helix(kind)
    feed, period, tol = 600.0, 4.0, 1e-3
    res = interpolate_constant_period(curve, feed, period, tol, integrator=integrator)
    u, pts, st = res["params"], res["samples"], res["stats"]
    L = feed / 60 * period / 1000  # 0.04 mm per period
    assert st["integrator"] == integrator and st["feed_limited_share"] == 0.0 and st["fallback_share"] == 0.0
    assert np.all(res["feed_mm_min"] == feed)
    chords = np.linalg.norm(np.diff(pts, axis=0), axis=1)[:-1]
    arcs = np.diff(exact_arc(curve, u))[:-1]
    if integrator == "taylor":
        # the corrector solves every chord to V T within 1e-6
        feed_tol = 1e-6
    else:
        # each Adams step runs V T of arc length within 1e-5 (its local error is largest where the stencil
        # straddles a knot); the chord is shorter than the arc by (L/R)^2/24 = 6.7e-7 more
        feed_tol = 1e-5
        assert np.abs(arcs / L - 1).max() <= feed_tol
    assert np.abs(chords / L - 1).max() <= feed_tol
    assert st["feed_fluctuation_max"] <= feed_tol
    assert chord_errors(curve, u, pts, n_check=9).max() <= tol
    # the spline's length is the circle's / helix's to 1e-6, and the path takes length / feed
    assert exact_arc(curve, u)[-1] == pytest.approx(true_length, rel=1e-6)
    assert st["duration_s"] == pytest.approx(true_length / (feed / 60), abs=period / 1000 + 1e-9)


def _global_arc_error(curve, integrator, periods, feed=3000.0):
    out = []
    for T in periods:
        res = interpolate_constant_period(curve, feed, T, 0.5, integrator=integrator)
        assert res["stats"]["fallback_share"] == 0.0 and res["stats"]["feed_limited_share"] == 0.0
        u = res["params"][:-1]
        out.append(np.abs(exact_arc(curve, u) - feed / 60 * T / 1000 * np.arange(len(u))).max())
    return np.asarray(out)


def test_adams_error_falls_with_the_fourth_power_of_the_period_on_a_span():
    # one cubic span (no knot inside): order 4
    ctrl = np.array([[10, 0, 0], [10, 8, 1], [3, 12, 2.5], [-5, 10, 4.0]])
    curve = NurbsCurve(3, np.array([0, 0, 0, 0, 1, 1, 1, 1.0]), ctrl)
    periods = np.array([8.0, 4.0, 2.0, 1.0])
    err = _global_arc_error(curve, "ab-am", periods)
    slope = np.polyfit(np.log(periods), np.log(err), 1)[0]
    assert 3.8 <= slope <= 4.3, (slope, err)


@pytest.mark.parametrize("kind", ["circle", "helix"])
def test_adams_error_falls_with_the_third_power_of_the_period_across_knots(kind):
    # a cubic spline: 1/|C'| has a jumping second derivative at each knot, so the global order is 3
    curve, _ = circle_or_helix(kind)
    periods = np.array([4.0, 2.0, 1.0, 0.5])
    err = _global_arc_error(curve, "ab-am", periods)
    slope = np.polyfit(np.log(periods), np.log(err), 1)[0]
    assert 2.7 <= slope <= 3.8, (slope, err)
    assert err[-1] < 1e-7  # 1e-7 mm behind after 63 mm at 0.5 ms


@pytest.mark.parametrize("integrator", BOTH)
def test_the_job_with_each_integrator_passes_through_every_dwell_point(integrator):
    cap = spherical_cap(n_r=12, n_phi=40)
    path = serpentine_path(cap, 1.5, seed=11)
    sp = map_to_surface(cap, path)
    tol = 1e-3
    tp = smooth(sp, feed_mm_min=1200.0, period_ms=4.0, chord_tol_mm=tol, integrator=integrator)
    assert tp.provenance.params["integrator"] == integrator and tp.stats["integrator"] == integrator
    # the curve passes through every dwell point, and every piece starts and ends on one
    assert np.abs(evaluate(tp.curve, tp.dwell_params) - sp.xyz).max() <= 1e-9
    assert tp.stats["dwell_through_max"] <= 1e-9
    off = tp.sample_pieces
    for k in range(len(path.pieces) - 1):
        assert np.linalg.norm(tp.samples[off[k]] - sp.xyz[path.pieces[k]]) <= 1e-9
        assert np.linalg.norm(tp.samples[off[k + 1] - 1] - sp.xyz[path.pieces[k + 1] - 1]) <= 1e-9
    # each dwell point lies on the straight move of the step holding its parameter, within the chord tolerance
    u, s = tp.sample_params, tp.samples
    k = np.clip(np.searchsorted(u, tp.dwell_params, side="right") - 1, 0, len(u) - 2)
    a, e = s[k], s[k + 1] - s[k]
    t = np.clip(np.einsum("ij,ij->i", sp.xyz - a, e) / np.einsum("ij,ij->i", e, e), 0, 1)
    assert np.linalg.norm(a + t[:, None] * e - sp.xyz, axis=1).max() <= tol * 1.01
    assert tp.stats["chord_error_max"] <= tol


def test_integrators_agree_on_the_schedule():
    cap = spherical_cap(n_r=12, n_phi=40)
    sp = map_to_surface(cap, serpentine_path(cap, 1.5, seed=11))
    a = smooth(sp, integrator="taylor")
    b = smooth(sp, integrator="ab-am")
    assert b.stats["duration_s"] == pytest.approx(a.stats["duration_s"], rel=1e-3)
    assert len(b.samples) == pytest.approx(len(a.samples), rel=1e-3)
    # (the largest error is a one-point piece's, whose zero-length region is timed to the period: compared
    # through the RMS and the 99th percentile)
    for key in ("dwell_time_error_rms", "dwell_time_error_p99"):
        assert abs(b.stats[key] - a.stats[key]) < 0.05


def test_the_job_option_lists_every_integrator():
    from polishpath.defaults import DEFAULT_INTEGRATOR, INTEGRATOR_NAMES

    assert tuple(INTEGRATORS) == INTEGRATOR_NAMES and DEFAULT_INTEGRATOR == "taylor"


def test_a_bad_integrator_is_a_clear_error():
    curve, _ = circle_or_helix("circle")
    with pytest.raises(ParameterError, match="integrator must be one of 'taylor', 'ab-am'"):
        interpolate_constant_period(curve, 600.0, 4.0, 1e-3, integrator="rk45")
    cap = spherical_cap(n_r=6, n_phi=20)
    sp = map_to_surface(cap, serpentine_path(cap, 1.5, seed=1))
    with pytest.raises(ParameterError, match="ab-am"):
        smooth(sp, integrator="adams")


# --- the option on the command line and in job.toml ------------------------------------------------------------

SMALL = "hemisphere:R=15,triangles=800"


def _plan(args):
    from typer.testing import CliRunner

    from polishpath.cli import app

    return CliRunner().invoke(app, ["plan", *args])


def test_integrator_option_round_trips_through_job_toml(tmp_path):
    import json
    import tomllib

    first, again = tmp_path / "a", tmp_path / "b"
    r = _plan([SMALL, "--spacing", "1.5", "--seed", "4", "--integrator", "ab-am", "-o", str(first), "--no-report",
               "-q"])
    assert r.exit_code == 0, r.output
    summary = json.loads((first / "summary.json").read_text())
    assert summary["smooth"]["provenance"]["params"]["integrator"] == "ab-am"
    assert summary["smooth"]["stats"]["integrator"] == "ab-am"
    assert tomllib.loads((first / "job.toml").read_text())["job"]["integrator"] == "ab-am"
    r = _plan(["--config", str(first / "job.toml"), "-o", str(again), "--no-report", "-q"])
    assert r.exit_code == 0, r.output
    assert json.loads((again / "summary.json").read_text())["smooth"]["provenance"]["params"]["integrator"] == "ab-am"
    for name in ("path.csv", "toolpath.xyz"):
        assert (first / name).read_bytes() == (again / name).read_bytes(), name


def test_default_integrator_is_taylor_in_the_job(tmp_path):
    import json

    r = _plan([SMALL, "--spacing", "1.5", "--seed", "4", "-o", str(tmp_path), "--no-report", "-q"])
    assert r.exit_code == 0, r.output
    assert json.loads((tmp_path / "summary.json").read_text())["smooth"]["provenance"]["params"]["integrator"] == "taylor"


def test_bad_integrator_exits_2_with_the_choices(tmp_path):
    r = _plan([SMALL, "--spacing", "1.5", "--integrator", "rk45", "-o", str(tmp_path / "x"), "-q"])
    assert r.exit_code == 2
    assert "integrator" in r.output and "ab-am" in r.output and "Traceback" not in r.output
    bad = tmp_path / "job.toml"
    bad.write_text(f'[job]\nsurface = "{SMALL}"\nspacing = 1.5\nintegrator = "adams"\n')
    r = _plan(["--config", str(bad), "-o", str(tmp_path / "y"), "-q"])
    assert r.exit_code == 2
    assert "integrator" in r.output and "ab-am" in r.output and "Traceback" not in r.output
