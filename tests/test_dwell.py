"""Deterministic figuring (issue 17): dwell times from a measured error map and a TIF."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from polishpath.dwell import (
    Alignment,
    ErrorMap,
    figure_dwell_times,
    gaussian_tif,
    parse_tif_spec,
    read_error_map,
    sample_error,
    tif_from_spec,
    zernike_surface,
)
from polishpath.errors import CoverageError, ParameterError

# error the TIF can correct: defocus, astigmatism, coma-free spherical (Fringe Z4, Z5, Z6, Z9), nm
ZERNIKE = [0, 0, 0, 160.0, 40.0, -32.0, 0, 0, 60.0]
TIF_SPEC = "gaussian:fwhm=3,peak_rate=15"


@pytest.fixture(scope="module")
def figured_job(tmp_path_factory):
    """A flat disc (radius 15 mm) figured from a Zernike map made here, through the whole job."""
    from polishpath.pipeline import JobConfig, run

    d = tmp_path_factory.mktemp("figuring")
    (d / "err.toml").write_text(
        "[zernike]\nordering = \"fringe\"\nradius_mm = 16.0\nunits = \"nm\"\n"
        f"coefficients = {ZERNIKE}\npixel_mm = 0.05\n")
    cfg = JobConfig(surface="xy-polynomial:radius=15,triangles=3000", spacing=0.5, seed=1, error_map=str(d / "err.toml"),
                    tif=TIF_SPEC, chord_tol_mm=0.005, report=False, error_map_options={"ca_margin_mm": 1.5})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        job = run(cfg)
    out = d / "out"
    job.save(out)
    return job, out


def test_zernike_error_is_removed_to_5_percent(figured_job):
    job, out = figured_job
    import json

    fg = json.loads((out / "summary.json").read_text())["figuring"]
    for key in ("initial_rms_nm", "residual_rms_nm", "residual_pv_nm", "total_time_s", "solver"):
        assert key in fg
    assert fg["initial_rms_nm"] > 40
    assert fg["residual_rms_nm"] <= 0.05 * fg["initial_rms_nm"], fg
    assert fg["solver"] == "fft"  # a flat part's lattice path takes the FFT solver
    assert fg["total_time_s"] == pytest.approx(float(job.tool_path.dwell_times.sum()), rel=1e-9)


def test_demo_delivers_every_dwell_time(figured_job):
    # issue 28, item 3 on the figuring example (examples/figuring/job.toml): 0.21 % RMS, 4.4 % worst (was
    # 0.28 % and 6.7 %: a region whose turn, at the 5 um chord limit, makes its time jump by up to 66 % from
    # one feed to a nearby one; the search of smooth/timing.next_region_feed finds a feed between the jumps),
    # within the top feed
    job, out = figured_job
    import json

    fg = json.loads((out / "summary.json").read_text())["figuring"]
    assert fg["delivered_time_error_rms"] <= 0.005
    assert fg["delivered_time_error_max"] <= 0.05
    assert job.tool_path.feed_mm_min.max() <= 3000.0 * (1 + 1e-9)


def test_times_at_least_the_minimum_and_in_path_csv(figured_job):
    job, out = figured_job
    from polishpath.export import read_path_csv

    csv = read_path_csv(out / "path.csv")
    arr = np.load(out / "run.npz")
    tmin = arr["figuring_t_min_s"]
    assert np.all(csv["dwell_time"] >= tmin * (1 - 1e-12))
    assert np.all(tmin > 0)
    np.testing.assert_allclose(csv["dwell_time"], job.figuring.times_s, rtol=1e-15)


def _pieces_of_csv(csv, spacing):
    """Continuous pieces of path.csv: a step longer than 1.5 diagonals is a lift."""
    steps = np.hypot(np.diff(csv["x"]), np.diff(csv["y"]))
    cuts = np.flatnonzero(steps > 1.5 * np.sqrt(2) * spacing) + 1
    return np.concatenate([[0], cuts, [len(csv["x"])]])


def _removal_along_cubic(csv, times, px, py, sigma, peak, spacing, nodes=4):
    """Removal (nm) at pixels (px, py) of a tool that runs a cubic through path.csv's points and spends each point's
    time at a constant feed over its region (half-way to the previous point .. half-way to the next, by chord
    length): scipy's CubicSpline, Gauss-Legendre nodes, the Gaussian summed directly. Independent of polishpath."""
    from scipy.interpolate import CubicSpline

    xyz = np.column_stack([csv["x"], csv["y"], csv["z"]])
    gx, gw = np.polynomial.legendre.leggauss(nodes)
    gx, gw = 0.5 * (gx + 1), 0.5 * gw
    src, wts = [], []
    pcs = _pieces_of_csv(csv, spacing)
    for a, b in zip(pcs[:-1], pcs[1:]):
        q, t = xyz[a:b], times[a:b]
        d = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
        cs = CubicSpline(d, q)
        rb = np.concatenate([[0.0], 0.5 * (d[1:] + d[:-1]), [d[-1]]])
        u = rb[:-1, None] + (rb[1:] - rb[:-1])[:, None] * gx
        ds = np.linalg.norm(cs(u, 1), axis=2) * (rb[1:] - rb[:-1])[:, None] * gw  # arc length per node
        src.append(cs(u)[..., :2].reshape(-1, 2))
        wts.append((t[:, None] * ds / ds.sum(axis=1, keepdims=True)).ravel())
    src, wts = np.concatenate(src), np.concatenate(wts)
    out = np.zeros(len(px))
    for a in range(0, len(src), 2000):
        dx = px[:, None] - src[None, a:a + 2000, 0]
        dy = py[:, None] - src[None, a:a + 2000, 1]
        out += (peak * np.exp(-(dx * dx + dy * dy) / (2 * sigma**2)) * wts[None, a:a + 2000]).sum(axis=1)
    return out


def _region_times_of_run(out, period_ms):
    """Time the run's machine samples spend in each dwell point's region (one piece), from the run folder
    (run.npz holds the samples' schedule: their parameters regenerated from it)."""
    from polishpath.runfolder import read_run
    from polishpath.simulate.jobpath import with_samples

    tp = with_samples(read_run(out).tool_path)
    dp, sp = tp.dwell_params, tp.sample_params
    rb = np.concatenate([[sp[0]], 0.5 * (dp[1:] + dp[:-1]), [sp[-1]]])
    T = period_ms / 1000.0
    tt = np.arange(len(sp)) * T
    # the last step, cut short at the piece's end, is a block the controller runs at its feed: length / feed
    last = np.linalg.norm(tp.samples[-1] - tp.samples[-2]) / (tp.feed_mm_min[-1] / 60.0)
    tt[-1] = tt[-2] + min(T, last)
    return np.diff(np.interp(rb, sp, tt))


def test_independent_removal_from_path_csv_agrees(figured_job):
    """The removal computed here from path.csv (x, y, z, time) with the same Gaussian TIF vs the reported residual.

    "Agrees" (issue 17, 1 %), over the clear aperture: (a) the residual map computed here and the reported
    (machine-timed) one differ by <= 1 % of the initial error RMS, RMS over the pixels, and (b) their RMS figures
    by <= 1 % of it. The tool runs a cubic through path.csv's points and spends each point's time at a constant
    feed over its region (half-way to its neighbours); the time is the one the machine samples really spend in the
    region. path.csv's own (solved) times are delivered by the smoothing stage only to ~9 % RMS per point (a step
    from a fast region runs its whole length into a slow one; the summary reports it as delivered_time_error_rms,
    docs/figuring.md): with them the residual figure still agrees to 1 %, the maps to 3 %.
    """
    job, out = figured_job
    import json

    from polishpath.export import read_path_csv

    csv = read_path_csv(out / "path.csv")
    arr = np.load(out / "run.npz")
    summary = json.loads((out / "summary.json").read_text())
    fg = summary["figuring"]
    assert len(_pieces_of_csv(csv, 0.5)) == 2  # one piece: the run's samples are one interpolation run
    x0, y0, h = arr["figuring_grid"]
    target = arr["figuring_target_nm"]
    valid = arr["figuring_inside"] & np.isfinite(arr["figuring_error_nm"])
    ii, jj = np.nonzero(valid)
    ii, jj = ii[::50], jj[::50]  # a fiftieth of the clear aperture's pixels (about 4,600)
    px, py = x0 + jj * h, y0 + ii * h
    sigma, init = 3.0 / (2 * np.sqrt(2 * np.log(2))), fg["initial_rms_nm"]
    reported = arr["figuring_residual_nm"][ii, jj]
    assert np.isfinite(reported).all()
    assert abs(np.std(reported) - fg["residual_rms_nm"]) <= 0.005 * init  # the subset stands for the whole
    got = _region_times_of_run(out, summary["smooth"]["period_ms"])
    mine = _removal_along_cubic(csv, got, px, py, sigma, 15.0, 0.5)
    diff = (target[ii, jj] - mine) - reported
    assert np.sqrt(np.mean(diff**2)) <= 0.01 * init  # (a), measured 0.35 %
    assert abs(np.std(target[ii, jj] - mine) - fg["residual_rms_nm"]) <= 0.01 * init  # (b), measured 0.04 %
    # the point-dwell sum (no motion between points) is the cruder model, several times further off
    sd = np.zeros(len(px))
    for a in range(0, len(csv["x"]), 500):
        dx, dy = px[:, None] - csv["x"][None, a:a + 500], py[:, None] - csv["y"][None, a:a + 500]
        sd += (15.0 * np.exp(-(dx * dx + dy * dy) / (2 * sigma**2)) * got[None, a:a + 500]).sum(axis=1)
    assert np.sqrt(np.mean((target[ii, jj] - sd - reported) ** 2)) > 3 * np.sqrt(np.mean(diff**2))
    # what the smoothing stage delivers of path.csv's times is reported, and the summary's figure is this one
    rel = (got - csv["dwell_time"]) / csv["dwell_time"]
    assert fg["delivered_time_error_rms"] == pytest.approx(np.sqrt(np.mean(rel**2)), rel=1e-6)
    assert fg["delivered_time_error_max"] == pytest.approx(np.abs(rel).max(), rel=1e-6)
    # with path.csv's own times: the residual figure to 1 % (measured 0.14 %), the map to 3 % (measured 1.4 %)
    with_csv = _removal_along_cubic(csv, csv["dwell_time"], px, py, sigma, 15.0, 0.5)
    assert abs(np.std(target[ii, jj] - with_csv) - fg["residual_rms_nm"]) <= 0.01 * init
    assert np.sqrt(np.mean(((target[ii, jj] - with_csv) - reported) ** 2)) <= 0.03 * init


@pytest.fixture(scope="module")
def small_part():
    from polishpath.pipeline import run

    job = run(surface="xy-polynomial:radius=8,triangles=1500", spacing=0.5, seed=3, report=False)
    return job.surface, job.surface_path


def _solve(small_part, z, pix=0.05, **kw):
    surface, spath = small_part
    kw.setdefault("max_feed_mm_min", 3000.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return figure_dwell_times(surface, spath, ErrorMap.centred(z, pix), gaussian_tif(15.0, fwhm_mm=3.0),
                                  ca_margin_mm=1.0, **kw)


def test_component_above_the_passband_is_reported_uncorrectable(small_part):
    low = zernike_surface([0, 0, 0, 60.0, 20.0], 9.0, "fringe", 0.05)
    h = (low.shape[0] - 1) // 2
    X, Y = np.meshgrid(np.arange(-h, h + 1) * 0.05, np.arange(-h, h + 1) * 0.05)
    ripple = 4.0 * np.sin(2 * np.pi * X / 0.4)  # 2.5 1/mm: far above a 3 mm FWHM TIF's passband
    base = _solve(small_part, low)
    fig = _solve(small_part, low + ripple)
    st = fig.stats
    assert st["passband_cutoff_per_mm"] < 1.0
    assert st["uncorrectable_rms_nm"] == pytest.approx(4.0 / np.sqrt(2), rel=0.25)
    assert "uncorrectable_note" in st
    # the ripple stays in the residual ...
    assert st["ideal_residual_rms_nm"] >= 0.8 * st["uncorrectable_rms_nm"]
    # ... and is not fitted by wild times
    assert fig.times_s.max() <= 1.5 * base.times_s.max()
    assert fig.times_s.sum() <= 1.2 * base.times_s.sum()


def test_nan_pixels_are_ignored(small_part):
    z = zernike_surface([0, 0, 0, 60.0, 20.0], 9.0, "fringe", 0.05)
    base = _solve(small_part, z)
    holed = z.copy()
    c = (z.shape[0] - 1) // 2
    holed[c - 10:c + 10, c + 20:c + 40] = np.nan  # a 1 x 1 mm drop-out inside the aperture
    holed[c + 30, :] = 1e6  # a wild row...
    holed[c + 30, :] = np.nan  # ...masked: NaN is a mask, never a value
    fig = _solve(small_part, holed)
    t = fig.target
    assert np.isfinite(t.removal_nm[t.weight > 0]).all()
    assert not t.valid[np.isnan(sample_error(ErrorMap.centred(holed, 0.05), t.grid.xy()).reshape(t.grid.shape))].any()
    assert 0 < fig.stats["uncovered_fraction"] < 0.02
    assert np.isfinite(fig.times_s).all()
    assert fig.stats["ideal_residual_rms_nm"] <= 2 * base.stats["ideal_residual_rms_nm"] + 0.05
    np.testing.assert_allclose(fig.times_s.sum(), base.times_s.sum(), rtol=0.05)


def test_map_not_covering_the_part_is_refused_with_the_fraction(small_part):
    z = zernike_surface([0, 0, 0, 60.0], 5.0, "fringe", 0.05)  # a 5 mm disc on a part whose CA is 7 mm
    with pytest.raises(CoverageError) as exc:
        _solve(small_part, z)
    msg = str(exc.value)
    frac = 1 - (5.0 / 7.0) ** 2
    import re

    got = float(re.search(r"([0-9.]+) % of the part's clear aperture", msg).group(1))
    assert got == pytest.approx(100 * frac, abs=2.0)
    assert "alignment" in msg


def test_error_units_round_trip(tmp_path):
    z = zernike_surface([0, 0, 0, 50.0, 10.0], 5.0, "fringe", 0.1)
    f = tmp_path / "map.txt"
    body = "\n".join(" ".join("nan" if not np.isfinite(v) else f"{v / 1000:.12g}" for v in row) for row in z)
    f.write_text("# height_unit: um\n# lateral_unit: mm\n# dx: 0.1 mm\n" + body + "\n")
    m = read_error_map(f)
    np.testing.assert_allclose(m.z_nm, z, rtol=1e-9, equal_nan=True)
    assert m.dx_mm == pytest.approx(0.1)
    # a file that does not say: --error-units gives the unit; without it nm is assumed, with a warning
    g = tmp_path / "bare.txt"
    g.write_text("# lateral_unit: mm\n# dx: 0.1 mm\n" + body + "\n")
    np.testing.assert_allclose(read_error_map(g, height_unit="um").z_nm, z, rtol=1e-9, equal_nan=True)
    with pytest.warns(UserWarning, match="assumed"):
        np.testing.assert_allclose(read_error_map(g).z_nm, z / 1000, rtol=1e-9, equal_nan=True)
    # Zernike TOML in um
    t = tmp_path / "z.toml"
    t.write_text("[zernike]\nordering = \"fringe\"\nradius_mm = 5.0\nunits = \"um\"\n"
                 "coefficients = [0, 0, 0, 0.05, 0.01]\npixel_mm = 0.1\n")
    np.testing.assert_allclose(read_error_map(t).z_nm, z, rtol=1e-9, equal_nan=True)


def test_alignment_translation_rotation_flip_scale():
    z = np.add.outer(np.arange(40.0), 100 * np.arange(50.0))  # z = row + 100 col
    m = ErrorMap(z, 0.1, 0.1, (0.0, 0.0))
    p = np.array([[1.2, 2.3]])
    base = sample_error(m, p)[0]
    al = Alignment(offset_mm=(3.0, -1.0), rotation_deg=30.0, flip="none", scale=1.0)
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    q = np.array([[c * 1.2 - s * 2.3 + 3.0, s * 1.2 + c * 2.3 - 1.0]])
    assert sample_error(m, q, al)[0] == pytest.approx(base)
    assert sample_error(m, np.array([[-1.2, 2.3]]), Alignment(flip="x"))[0] == pytest.approx(base)
    assert sample_error(m, np.array([[2.4, 4.6]]), Alignment(scale=2.0))[0] == pytest.approx(base)
    assert np.isnan(sample_error(m, np.array([[-5.0, 0.0]]))[0])
    with pytest.raises(ParameterError):
        Alignment(flip="z")


def test_tif_specs_and_one_tif_type():
    import polishpath.dwell as dwell
    import polishpath.simulate as simulate

    assert simulate.TIF is dwell.TIF and simulate.gaussian_tif is dwell.gaussian_tif
    t = tif_from_spec("gaussian:fwhm=2,peak_rate=40")
    assert t.params["fwhm_mm"] == pytest.approx(2.0) and t.params["peak_rate_nm_s"] == 40.0
    assert parse_tif_spec("rotating:rpm=230,radius=2")[1] == {"rpm": 230.0, "radius": 2.0}
    for bad in ("gauss:fwhm=1", "gaussian:fwhm=1", "gaussian:fwhm=x,peak_rate=1", "gaussian:fwhm=1,peak_rate=2,k=3"):
        with pytest.raises(ParameterError):
            tif_from_spec(bad)


def test_lsq_solver_matches_fft_on_a_lattice(small_part):
    z = zernike_surface([0, 0, 0, 60.0, 20.0], 9.0, "fringe", 0.05)
    a = _solve(small_part, z, method="fft")
    b = _solve(small_part, z, method="lsq")
    assert a.solution.solver == "fft" and b.solution.solver == "lsq"
    assert np.all(b.times_s >= b.solution.t_min_s)
    ra, rb = a.stats["ideal_residual_rms_nm"], b.stats["ideal_residual_rms_nm"]
    assert rb <= 0.1 * b.stats["initial_rms_nm"]
    assert abs(ra - rb) <= 0.05 * a.stats["initial_rms_nm"]


def test_cli_refuses_an_uncovered_map_with_exit_2(tmp_path):
    from typer.testing import CliRunner

    from polishpath.cli import app

    (tmp_path / "small.toml").write_text("[zernike]\nordering = \"fringe\"\nradius_mm = 4.0\nunits = \"nm\"\n"
                                         "coefficients = [0, 0, 0, 50.0]\npixel_mm = 0.1\n")
    r = CliRunner().invoke(app, ["plan", "xy-polynomial:radius=8,triangles=1500", "--spacing", "0.5", "--seed", "1",
                                 "--error-map", str(tmp_path / "small.toml"), "--tif", "gaussian:fwhm=3,peak_rate=15",
                                 "--no-report", "-q", "-o", str(tmp_path / "out")])
    assert r.exit_code == 2, r.output
    assert "does not cover the part" in r.output and "Traceback" not in r.output
    r = CliRunner().invoke(app, ["plan", "hemisphere:triangles=2000", "--tif", "gaussian:fwhm=3,peak_rate=15",
                                 "--no-report", "-q", "-o", str(tmp_path / "out2")])
    assert r.exit_code == 2 and "--error-map" in r.output


def test_xyz_map_keeps_its_coordinates(tmp_path):
    x, y = np.meshgrid(np.arange(10) * 0.5 + 3.0, np.arange(12) * 0.5 - 2.0)
    z = 2.0 * x + y
    f = tmp_path / "m.xyz"
    f.write_text("# lateral_unit: mm\n# height_unit: nm\n" + "\n".join(f"{a} {b} {c}" for a, b, c in
                                                                     zip(x.ravel(), y.ravel(), z.ravel())))
    m = read_error_map(f)
    assert m.origin_mm == (3.0, -2.0)
    assert sample_error(m, np.array([[4.25, 0.25]]))[0] == pytest.approx(2 * 4.25 + 0.25)


def test_report_has_the_figuring_section(figured_job):
    _, out = figured_job
    from polishpath.report import write_report

    write_report(out)
    page = (out / "report.html").read_text()
    assert 'id="figuring"' in page and "predicted residual" in page
    assert (out / "figures" / "figuring.png").stat().st_size > 10_000


def test_residual_under_a_machine_schedule_counts_its_slow_downs(tmp_path):
    # with --machine the feed schedule slows the samples; the predicted residual and the delivered
    # times are of that schedule (each sample's period stretched by planned / scheduled feed), so the
    # figuring's machine time is the schedule's machining time, not samples x period
    from pathlib import Path

    from polishpath.pipeline import JobConfig, run

    (tmp_path / "err.toml").write_text(
        "[zernike]\nordering = \"fringe\"\nradius_mm = 9.0\nunits = \"nm\"\n"
        f"coefficients = {ZERNIKE}\npixel_mm = 0.1\n")
    gentle = Path(__file__).resolve().parents[1] / "examples" / "machine-gentle.toml"
    cfg = JobConfig(surface="xy-polynomial:radius=8,triangles=1500", spacing=0.5, seed=3,
                    error_map=str(tmp_path / "err.toml"), tif=TIF_SPEC, report=False, machine=str(gentle),
                    error_map_options={"ca_margin_mm": 1.0})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        job = run(cfg)
    sched = job.schedule
    assert sched["time_increase"] > 0.001  # the gentle machine does slow this path
    pred = job.figuring_prediction
    tool = job.tool_path
    assert pred["machine_time_s"] == pytest.approx(sched["machining_time_s"], rel=0.01)
    assert pred["machine_time_s"] > len(tool.samples) * tool.period_ms / 1000.0 * (1 + 0.5 * sched["time_increase"])
