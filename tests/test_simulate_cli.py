"""`polishpath simulate RUN_DIR` simulates that run's own path; `simulate SURFACE` plans through the job's wiring."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from polishpath.cli import app

runner = CliRunner()
DOME = "hemisphere:R=12,triangles=700"


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    r = runner.invoke(app, ["plan", DOME, "--spacing", "1", "--seed", "3", "-o", str(out), "--json"])
    assert r.exit_code == 0, r.output
    return out, json.loads((out / "summary.json").read_text())


def test_simulate_run_dir_uses_the_runs_own_path(small_run):
    out, summary = small_run
    r = runner.invoke(app, ["simulate", str(out), "--dx", "0.1", "-q"])
    assert r.exit_code == 0, r.output
    assert f"run: {out.name}" in r.output and "machine timing" in r.output
    assert "plane: unrolled" in r.output  # the dome's rim is vertical: auto takes the flattening's plane
    sim = out / "simulation"
    for f in ("table.txt", "results.json", "removal.png", "residual.png"):
        assert (sim / f).stat().st_size > 0, f
    res = json.loads((sim / "results.json").read_text())
    smooth = summary["smooth"]["stats"]
    # the removal ran on the run's own machine samples: their count and the run's machine time
    assert res["path"]["n_points"] == smooth["n_samples"]
    assert res["total_time_s"] == pytest.approx(smooth["duration_s"], rel=1e-9)
    assert res["depth_mean_nm"] == pytest.approx(200.0, rel=1e-6)
    html = (out / "report.html").read_text()  # the run's report shows the simulation
    assert "removal.png" in html and "depth inside the part" in html
    # the fair figures of the centre square's residual (issue 18, item 4)
    assert "fair figures of its residual" in r.output and "Fair figures of the centre square" in html
    assert res["fair"]["residual_band_rms_nm"] > 0 and res["fair"]["pvn"] > 0


def test_simulate_run_dir_dwell_timing_and_json(small_run):
    out, summary = small_run
    r = runner.invoke(app, ["simulate", str(out), "--dx", "0.1", "--timing", "dwell", "--plane", "xy", "--json",
                            "-o", str(out / "sim-dwell")])
    assert r.exit_code == 0, r.output
    js = json.loads(r.output)
    s = js["summary"]
    assert js["run"] == str(out) and s["plane"] == "xy" and s["timing"] == "dwell"
    # the run's dwell points with the run's dwell times
    assert s["path"]["n_points"] == summary["plan"]["dwell_points"]
    assert s["total_time_s"] == pytest.approx(summary["smooth"]["stats"]["dwell_time_total_s"], rel=1e-9)
    assert s["seed"] == 3  # the run's seed


def test_simulate_bad_input_exits_2_with_a_message(small_run, tmp_path):
    out, _ = small_run
    r = runner.invoke(app, ["simulate", str(out), "--plane", "polar"])
    assert r.exit_code == 2 and "plane" in r.output and "Traceback" not in r.output
    r = runner.invoke(app, ["simulate", str(out), "--timing", "sometimes"])
    assert r.exit_code == 2 and "timing" in r.output
    r = runner.invoke(app, ["simulate", str(tmp_path)])  # a folder that is not a run
    assert r.exit_code == 2 and "run folder" in r.output
    r = runner.invoke(app, ["simulate", DOME, "--patterns", "raster", "--spacing", "1", "--patch", "3",
                            "--dx", "0.05", "-o", str(tmp_path / "tiny")])
    assert r.exit_code == 2 and "--patch" in r.output


def test_simulate_surface_plans_with_the_spacing_on_the_part(tmp_path):
    args = ["simulate", DOME, "--patterns", "raster,pseudorandom", "--spacing", "1", "--patch", "8", "--dx", "0.05",
            "--fwhm", "1", "--seed", "2", "--seeds", "2", "-o", str(tmp_path / "cmp"), "--json"]
    r = runner.invoke(app, args)
    assert r.exit_code == 0, r.output
    js = json.loads(r.output)
    plans = js["params"]["plans"]
    for pat in ("raster", "pseudorandom"):
        assert plans[pat]["spacing_on"] == "surface" and plans[pat]["spacing_mm"] == 1.0
        # on a dome the plane's grid is finer than the spacing on the part (the step reduction of `plan`)
        assert plans[pat]["planar_spacing_mm"] < 1.0
    rows = {row["name"]: row for row in js["rows"]}
    assert rows["raster"]["planar_spacing_mm"] == pytest.approx(plans["raster"]["planar_spacing_mm"])
    # the same spacing as `plan`: the job at this spacing plans the same planar grid
    r2 = runner.invoke(app, ["plan", DOME, "--spacing", "1", "--pattern", "raster", "--seed", "2", "--json",
                             "--no-report", "-o", str(tmp_path / "job")])
    assert r2.exit_code == 0, r2.output
    job = json.loads(r2.output)
    h_job, h_sim = job["plan"]["planar_spacing_mm"], plans["raster"]["planar_spacing_mm"]
    if job["plan"]["provenance"]["params"]["margin"] == pytest.approx(0.25 * h_job):  # the automatic margin
        assert h_job == pytest.approx(h_sim, rel=1e-12)
    else:  # the job widened its margin after its boundary check: a re-plan at the same spacing on the part
        assert h_job == pytest.approx(h_sim, rel=0.03)
    # --spacing-on plane keeps the planar grid as given
    r3 = runner.invoke(app, args[:-3] + ["--spacing-on", "plane", "-o", str(tmp_path / "cmp2"), "--json"])
    assert r3.exit_code == 0, r3.output
    assert json.loads(r3.output)["params"]["plans"]["raster"]["planar_spacing_mm"] == 1.0
    assert np.isfinite([row["suppression_ratio"] for row in json.loads(r3.output)["rows"]]).all()
    # the fair figures with their spread over the seeds (issue 18: the json keys)
    assert js["params"]["seeds"] == [2, 3] and js["params"]["mode"] == "process"
    assert js["params"]["timing"] == "machine"  # the default: the job's own samples
    assert plans["pseudorandom"]["seeds"] == [2, 3] and plans["raster"]["seeds"] == [2]
    for row in js["rows"]:
        for k in ("residual_band_rms_nm", "lattice_peak_db", "pvn", "suppression_ratio"):
            assert row[f"{k}_min"] <= row[k] <= row[f"{k}_max"], (row["name"], k)
        assert [p["seed"] for p in row["per_seed"]] == [2, 3]
    assert set(js["rankings"]) == {"residual_band_rms_nm", "lattice_peak_db", "pvn", "suppression_ratio"}
    assert (tmp_path / "cmp" / "residuals.png").stat().st_size > 0


def test_simulate_surface_interference_free_without_mechanisms(tmp_path):
    r = runner.invoke(app, ["simulate", "saddle:size=12,R=1000,triangles=400", "--patterns", "raster",
                            "--spacing-on", "plane", "--patch", "8", "--dx", "0.04", "--fwhm", "0.6", "--seeds", "3",
                            "--mode", "interference-free", "--timing", "ideal", "--without", "smoothing",
                            "-o", str(tmp_path / "cmp"), "--json"])
    assert r.exit_code == 0, r.output
    js = json.loads(r.output)
    row = js["rows"][0]
    assert js["params"]["mode"] == "interference-free" and js["params"]["noise"] is None
    assert js["params"]["mechanisms"]["off"] == ["smoothing"]
    # a deterministic path from a flat start without noise: the same figures for every seed, no suppression
    assert row["residual_band_rms_nm_min"] == row["residual_band_rms_nm_max"] and row["suppression_ratio"] is None


@pytest.mark.parametrize("args, word", [
    (["--seeds", "0"], "seeds"), (["--seeds", "500"], "seeds"), (["--mode", "vacuum"], "mode"),
    (["--timing", "soon"], "timing"), (["--without", "gravity"], "mechanism"),
    (["--machine", "no-such-machine.toml"], "machine"), (["--time-model", "teleport"], "time model")])
def test_simulate_surface_bad_options_exit_2_before_work(tmp_path, args, word):
    r = runner.invoke(app, ["simulate", DOME, "--patterns", "raster", "-o", str(tmp_path / "x"), *args])
    assert r.exit_code == 2, r.output
    assert word in r.output and "Traceback" not in r.output
    assert not (tmp_path / "x").exists()


def test_report_of_a_run_with_a_comparison_shows_both_figures(small_run, tmp_path):
    import shutil

    run = tmp_path / "run"
    shutil.copytree(small_run[0], run)
    r = runner.invoke(app, ["simulate", DOME, "--patterns", "raster,pseudorandom", "--spacing", "1", "--patch", "8",
                            "--dx", "0.05", "--fwhm", "1", "--seeds", "2", "--timing", "ideal", "-o", str(run), "-q"])
    assert r.exit_code == 0, r.output
    for f in ("residuals.png", "psd.png", "results.json"):
        assert (run / "simulation" / f).stat().st_size > 0, f
    html = (run / "report.html").read_text()
    # the residual maps side by side and the PSDs with the lattice frequencies marked, and the fair table
    assert "Residual maps side by side" in html and "lattice frequencies marked" in html
    assert "Fair figures of each path" in html and "not distinguishable" in html
    # each row's lattice peak read at its own frequencies, and the report says where (issue 26)
    js = json.loads((run / "simulation" / "results.json").read_text())
    assert "lattice peak read at (1/mm)" in html and "each path at its own lattice frequencies" in html
    for row in js["rows"]:
        assert ", ".join(f"{f:.3g}" for f in row["lattice_frequencies_per_mm"]) in html
