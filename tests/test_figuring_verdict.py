"""Figuring a shop can trust (issue 28): never a program that makes the part worse without saying so
(item 1), residuals near what the TIF allows, checked against an independent removal sum (item 2).

A disc R 20 mm figured with a Gaussian TIF 5 mm FWHM at 1 mm spacing: at 200 nm/s the minimum times alone
remove about 280 nm everywhere, three times the 95 nm PV of the error (the floor effect that made a metre-class
mirror worse); at 2 nm/s the floor is 3 nm and figuring works.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from typer.testing import CliRunner

from polishpath.cli import app

PART = "xy-polynomial:radius=20,triangles=3000"


def _write_map(path, z_of_xy, R=20.0, pitch=0.25):
    x = np.arange(-1.05 * R, 1.05 * R + 1e-9, pitch)
    X, Y = np.meshgrid(x, x)
    Z = z_of_xy(X, Y)
    with open(path, "w") as f:
        f.write("# lateral_unit: mm\n# height_unit: nm\n")
        np.savetxt(f, np.column_stack([X.ravel(), Y.ravel(), Z.ravel()]), fmt="%.5f")
    return path


def _low_order(X, Y, R=20.0):
    r, th = np.hypot(X, Y) / R, np.arctan2(Y, X)
    return 20.0 * (2 * r**2 - 1) + 12.0 * r**2 * np.cos(2 * th) + 8.0 * (3 * r**3 - 2 * r) * np.cos(th)


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    d = tmp_path_factory.mktemp("verdict")
    low = _write_map(d / "low.xyz", _low_order)
    # a ripple of 1.2 mm wavelength: far above what a 5 mm TIF at 1 mm spacing can correct
    ripple = _write_map(d / "ripple.xyz", lambda X, Y: 20.0 * np.sin(2 * np.pi * X / 1.2) * np.sin(2 * np.pi * Y / 1.2),
                        pitch=0.1)
    return d, low, ripple


def _plan(out, error_map, peak_rate, *extra):
    return CliRunner().invoke(app, ["plan", PART, "--spacing", "1", "--seed", "1", "--error-map", str(error_map),
                                    "--tif", f"gaussian:fwhm=5,peak_rate={peak_rate}", "--no-report", "-q",
                                    "-o", str(out), *extra])


def test_floor_above_the_error_is_refused_with_the_floor_and_a_rate_that_works(maps):
    d, low, _ = maps
    r = _plan(d / "refused", low, 200)
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output
    assert not (d / "refused").exists()  # no run folder, not even a partial one
    msg = " ".join(r.output.split())
    m = re.search(r"minimum-removal floor is ([0-9.e+]+) nm, ([0-9.]+) x the ([0-9.]+) nm PV", msg)
    assert m, msg
    floor, pv = float(m.group(1)), float(m.group(3))
    assert floor > pv and 150 < floor < 500  # ~ top feed x TIF x spacing: 200 nm/s at 1 mm and 3000 mm/min
    assert "top feed 3000 mm/min" in msg and "--force" in msg
    rate = float(re.search(r"peak rate of at most ([0-9.]+) nm/s", msg).group(1))
    # the floor is proportional to the peak rate: the advised rate brings it to a fifth of the PV
    assert rate == pytest.approx(200 * 0.2 * pv / floor, rel=0.02)
    # ... and that rate works: no refusal, the part improves, the floor is what the message said
    r2 = _plan(d / "advised", low, f"{rate:.4g}")
    assert r2.exit_code == 0, r2.output
    fg = json.loads((d / "advised" / "summary.json").read_text())["figuring"]
    assert fg["floor_nm"] <= 0.21 * fg["initial_pv_nm"]
    assert fg["residual_rms_nm"] < 0.25 * fg["initial_rms_nm"] and not fg["forced"]


def test_force_writes_the_refused_program_and_the_summary_says_so(maps):
    d, low, _ = maps
    r = _plan(d / "forced", low, 200, "--force")
    assert r.exit_code == 0, r.output
    fg = json.loads((d / "forced" / "summary.json").read_text())["figuring"]
    assert fg["forced"] is True
    assert any("minimum-removal floor" in m for m in fg["refusals"])
    assert list(fg)[0] == "verdict" and "written with --force" in fg["verdict"]
    assert fg["floor_nm"] > fg["initial_pv_nm"]
    from polishpath.report import write_report

    write_report(d / "forced")
    page = (d / "forced" / "report.html").read_text()
    sec = page[page.index('id="figuring"'):]
    assert sec.index("-&gt; predicted") < sec.index("The dwell times")  # the figuring section leads with it
    assert "Refused, written with --force" in sec and "minimum-removal floor" in sec


def test_a_program_predicted_to_leave_the_part_worse_is_refused(maps):
    d, _, ripple = maps
    r = _plan(d / "worse", ripple, 2)
    assert r.exit_code == 2, r.output
    msg = " ".join(r.output.split())
    assert "would leave the part worse" in msg and "-> predicted" in msg and "lies above" in msg
    assert not (d / "worse").exists()


def test_a_program_that_improves_the_part_passes_and_leads_with_initial_to_predicted(maps):
    d, low, _ = maps
    r = _plan(d / "good", low, 2)
    assert r.exit_code == 0, r.output
    fg = json.loads((d / "good" / "summary.json").read_text())["figuring"]
    assert list(fg)[:2] == ["verdict", "floor_nm"]
    assert fg["verdict"].startswith(f"initial {fg['initial_rms_nm']:.3g} nm RMS")
    assert f"-> predicted {fg['residual_rms_nm']:.3g} nm RMS" in fg["verdict"]
    assert fg["forced"] is False and fg["refusals"] == []
    assert fg["floor_nm"] < 0.2 * fg["initial_pv_nm"]  # below the share where a refusal's advice starts
    assert fg["residual_rms_nm"] < 0.2 * fg["initial_rms_nm"]


SIGMA_5MM = 5.0 / (2.0 * np.sqrt(2.0 * np.log(2.0)))


def _independent_removal(samples_xy, sample_s, pixels_xy, peak_rate, sigma):
    """Removal (nm) at each pixel: the Gaussian TIF summed directly over every machine sample (its time)."""
    out = np.zeros(len(pixels_xy))
    for a in range(0, len(pixels_xy), 64):
        p = pixels_xy[a:a + 64]
        d2 = (p[:, None, 0] - samples_xy[None, :, 0]) ** 2 + (p[:, None, 1] - samples_xy[None, :, 1]) ** 2
        out[a:a + 64] = peak_rate * (np.exp(-d2 / (2 * sigma * sigma)) @ sample_s)
    return out


@pytest.fixture(scope="module")
def figured_r20(maps):
    """Disc R 20 mm, defocus + astigmatism + coma, TIF 5 mm FWHM at 2 nm/s, 1 mm spacing (issue 28's case),
    through the whole job as a user gives it: no clear aperture, so the default one (the part inset by one TIF
    FWHM, r <= 15 mm)."""
    import warnings

    from polishpath.pipeline import JobConfig, run

    _, low, _ = maps
    cfg = JobConfig(surface=PART, spacing=1.0, seed=1, error_map=str(low), tif="gaussian:fwhm=5,peak_rate=2",
                    report=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return run(cfg)


def test_low_order_map_is_figured_to_2_percent_inside_the_aperture_by_an_independent_sum(figured_r20):
    """The reported residual is <= 2 % of the initial RMS and a removal summed here over the machine samples
    (not simulate/, not dwell/) agrees with it to 1 % of the initial RMS."""
    job = figured_r20
    fg = job.summary()["figuring"]
    init, res = fg["initial_rms_nm"], fg["residual_rms_nm"]
    assert res <= 0.02 * init, fg["verdict"]
    # no clear aperture given: the default, the part inset by one FWHM, said in the summary and its verdict line
    assert fg["clear_aperture"]["source"] == "default"
    assert fg["clear_aperture"]["margin_mm"] == pytest.approx(5.0, rel=1e-9)
    assert "the part inset by 5 mm (by default" in fg["verdict"]
    # ... and the whole part's figures beside it: the band next to the edge is worse, which is why it is left out
    assert fg["part_residual_rms_nm"] > 2 * res and fg["part_initial_rms_nm"] > init
    # pixels of the clear aperture on a 1 mm grid; the error from its formula, not from the map read
    r_ca = 20.0 - fg["clear_aperture"]["margin_mm"]
    g = np.arange(-r_ca, r_ca + 1e-9, 1.0)
    X, Y = np.meshgrid(g, g)
    inside = np.hypot(X, Y) <= r_ca - 1e-9
    px = np.column_stack([X[inside], Y[inside]])
    err = _low_order(px[:, 0], px[:, 1])
    tp = job.tool_path
    removal = _independent_removal(np.asarray(tp.samples)[:, :2], np.full(len(tp.samples), tp.period_ms / 1000.0),
                                   px, 2.0, SIGMA_5MM)
    resid = err - err.min() - removal
    indep = float(np.std(resid))
    assert float(np.std(err)) == pytest.approx(init, rel=0.02)  # the same aperture and error as reported
    assert abs(indep - res) <= 0.01 * init, (indep, res, init)
    assert indep <= 0.02 * init


def test_every_dwell_time_is_delivered_within_the_feed_and_chord_limits(figured_r20):
    """Issue 28, item 3: each dwell region gets its solved time to 0.5 % RMS and 5 % at worst (was 2.5 % and
    44 %), measured here from the samples' parameters (not the stage's own figure), with every sample's feed
    at most the machine's and the chord error within the tolerance."""
    job = figured_r20
    tp = job.tool_path
    want = job.figuring.times_s
    T = tp.period_ms / 1000.0
    got = np.zeros(len(want))
    sp, dp = np.asarray(tp.sample_params), np.asarray(tp.dwell_params)
    pieces, pp = np.asarray(tp.sample_pieces), np.asarray(tp.piece_params)
    pts, feed = np.asarray(tp.samples), np.asarray(tp.feed_mm_min) / 60.0
    for k in range(len(pieces) - 1):  # the time at a parameter: linear over the samples, one period apart
        a, b = pieces[k], pieces[k + 1]
        s = sp[a:b]
        idx = np.flatnonzero((dp >= pp[k]) & ((dp < pp[k + 1]) if k < len(pieces) - 2 else True))
        d = dp[idx]
        ends = np.concatenate([[s[0]], 0.5 * (d[1:] + d[:-1]), [s[-1]]])
        tt = np.arange(len(s)) * T
        # ... but the piece's last step, cut short at its end, is a block the controller runs at its feed
        tt[-1] = tt[-2] + min(T, np.linalg.norm(pts[b - 1] - pts[b - 2]) / feed[b - 1])
        got[idx] = np.diff(np.interp(ends, s, tt))
    rel = got / want - 1.0
    assert np.sqrt(np.mean(rel**2)) <= 0.005, np.sqrt(np.mean(rel**2))
    assert np.abs(rel).max() <= 0.05, np.abs(rel).max()
    fg = job.summary()["figuring"]
    assert fg["delivered_time_error_rms"] == pytest.approx(np.sqrt(np.mean(rel**2)), rel=1e-6)
    assert tp.feed_mm_min.max() <= 3000.0 * (1 + 1e-9)  # the top feed (5 x 600 mm/min)
    assert tp.stats["chord_error_max"] <= 0.001 * (1 + 1e-6)
