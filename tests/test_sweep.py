"""polishpath sweep: a grid of parts x patterns x seeds x tools, one table, the same bytes however spread."""

from __future__ import annotations

import csv
import io
import json

import pytest
from typer.testing import CliRunner

from polishpath.cli import app
from polishpath.errors import SpecError
from polishpath.pipeline.sweep import SWEEP_COLUMNS, read_sweep

runner = CliRunner()
DOME = "hemisphere:R=12,triangles=700"
SADDLE = "saddle:size=12,R=1000,triangles=400"
SWEEP = f"""
parts = ["{DOME}", "{SADDLE}"]
patterns = ["pseudorandom", "raster"]
seeds = 2
seed = 2
spacing = 1.0
patch = 10.0
dx = 0.05
[[tool]]
name = "g1"
fwhm = 1.0
[[tool]]
name = "g12"
fwhm = 1.2
"""


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    d = tmp_path_factory.mktemp("sweep")
    (d / "job.toml").write_text(SWEEP)
    r = runner.invoke(app, ["sweep", str(d / "job.toml"), "-o", str(d / "w1"), "--workers", "1", "-q"])
    assert r.exit_code == 0, r.output
    return d


def test_sweep_writes_one_row_per_part_tool_pattern_in_grid_order(swept):
    rows = list(csv.DictReader(io.StringIO((swept / "w1" / "sweep.csv").read_text())))
    assert list(rows[0]) == list(SWEEP_COLUMNS)
    assert [(r["part"], r["tool"], r["pattern"]) for r in rows] == [
        (p, t, pat) for p in (DOME, SADDLE) for t in ("g1", "g12") for pat in ("pseudorandom", "raster")]
    js = json.loads((swept / "w1" / "sweep.json").read_text())
    assert [s["seed"] for s in js["rows"][0]["per_seed"]] == [2, 3]
    # a wider tool leaves another residual: the tool is really swept (and so is the part)
    band = {(r["part"], r["tool"], r["pattern"]): float(r["residual_band_rms_nm"]) for r in rows}
    assert band[(DOME, "g1", "raster")] != band[(DOME, "g12", "raster")]
    assert band[(DOME, "g1", "raster")] != band[(SADDLE, "g1", "raster")]


def test_a_sweep_cell_is_the_simulate_comparison_of_that_part_and_tool(swept, tmp_path):
    r = runner.invoke(app, ["simulate", SADDLE, "--patterns", "pseudorandom,raster", "--spacing", "1", "--patch", "10",
                            "--dx", "0.05", "--fwhm", "1.2", "--seed", "2", "--seeds", "2", "--workers", "1",
                            "-o", str(tmp_path / "sim"), "--json"])
    assert r.exit_code == 0, r.output
    sim = {row["name"]: row for row in json.loads(r.output)["rows"]}
    for row in json.loads((swept / "w1" / "sweep.json").read_text())["rows"]:
        if row["part"] == SADDLE and row["tool"] == "g12":
            for k in ("residual_band_rms_nm", "lattice_peak_db_max", "pvn_min", "n_points"):
                assert row[k] == pytest.approx(sim[row["pattern"]][k], rel=1e-12), k


def test_sweep_with_two_workers_writes_the_same_bytes(swept):
    r = runner.invoke(app, ["sweep", str(swept / "job.toml"), "-o", str(swept / "w2"), "--workers", "2", "-q"])
    assert r.exit_code == 0, r.output
    for f in ("sweep.csv", "sweep.json"):
        assert (swept / "w2" / f).read_bytes() == (swept / "w1" / f).read_bytes()


@pytest.mark.parametrize("text, word", [
    ('patterns = ["raster"]', "parts"), ('parts = []', "parts"), (f'parts = ["{DOME}"]\ncolour = 3', "colour"),
    (f'parts = ["{DOME}"]\n[[tool]]\nname = "a"\nsize = 2', "size"),
    (f'parts = ["{DOME}"]\nseeds = 0', "seeds"), (f'parts = ["{DOME}"]\ndx = -1', "dx"),
    (f'parts = ["{DOME}"]\n[[tool]]\nname = "a"\n[[tool]]\nname = "a"', "name")])
def test_bad_sweep_files_exit_2_with_a_message(tmp_path, text, word):
    (tmp_path / "job.toml").write_text(text)
    r = runner.invoke(app, ["sweep", str(tmp_path / "job.toml"), "-o", str(tmp_path / "out")])
    assert r.exit_code == 2, r.output
    assert word in r.output and "Traceback" not in r.output
    assert not (tmp_path / "out").exists()


def test_the_example_sweep_file_reads():
    sw = read_sweep("examples/sweep.toml")
    assert len(sw.parts) == 2 and [t.name for t in sw.tools] == ["sponge", "gauss-1mm"]
    with pytest.raises(SpecError):
        read_sweep("examples/no-such-sweep.toml")
