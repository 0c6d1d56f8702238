"""A comparison's independent cases spread over processes or a Dask cluster give the same bytes (issue 29, item 3)."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from polishpath.cli import app
from polishpath.errors import ParameterError
from polishpath.simulate.cases import CaseRunner, run_cases

runner = CliRunner()
DOME = "hemisphere:R=12,triangles=700"
#: two patterns (one random: planned per seed, one deterministic: timed once) x 2 seeds, machine timing
ARGS = ["simulate", DOME, "--patterns", "pseudorandom,raster", "--spacing", "1", "--patch", "8", "--dx", "0.05",
        "--fwhm", "1", "--seed", "2", "--seeds", "2", "-q"]


def _square(x: int) -> int:
    return x * x


def _files(folder) -> tuple[bytes, bytes]:
    return (folder / "results.json").read_bytes(), (folder / "table.txt").read_bytes()


@pytest.fixture(scope="module")
def one_worker(tmp_path_factory):
    out = tmp_path_factory.mktemp("cases") / "w1"
    r = runner.invoke(app, [*ARGS, "--workers", "1", "-o", str(out)])
    assert r.exit_code == 0, r.output
    return out


def test_two_workers_write_the_same_bytes_as_one(one_worker, tmp_path):
    out = tmp_path / "w2"
    r = runner.invoke(app, [*ARGS, "--workers", "2", "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert _files(out) == _files(one_worker)
    js = json.loads((out / "results.json").read_text())
    assert [r["name"] for r in js["rows"]] == ["pseudorandom", "raster"]  # case order, not finishing order
    assert [p["seed"] for p in js["rows"][0]["per_seed"]] == [2, 3]
    # the two seeds of the random path differ (each case's seed is its own, not a shared global state)
    assert js["rows"][0]["per_seed"][0]["residual_band_rms_nm"] != js["rows"][0]["per_seed"][1]["residual_band_rms_nm"]


def test_a_dask_local_cluster_writes_the_same_bytes(one_worker, tmp_path):
    distributed = pytest.importorskip("distributed", reason="dask[distributed] (the test extra) is not installed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cl:
        out = tmp_path / "dask"
        r = runner.invoke(app, [*ARGS, "--scheduler", cl.scheduler_address, "-o", str(out)])
        assert r.exit_code == 0, r.output
    assert _files(out) == _files(one_worker)


def test_results_json_holds_no_wall_clock(one_worker):
    text = (one_worker / "results.json").read_text()
    assert '"seconds"' not in text and '_seconds"' not in text


def test_run_cases_keeps_the_case_order_in_every_spread():
    cases = list(range(7, 0, -1))
    want = [c * c for c in cases]
    assert run_cases(_square, cases, CaseRunner(1)) == want
    assert run_cases(_square, cases, CaseRunner(2)) == want


@pytest.mark.parametrize("workers", [0, -1, 1.5, True])
def test_case_runner_refuses_bad_workers(workers):
    with pytest.raises(ParameterError, match="workers"):
        CaseRunner(workers)


@pytest.mark.parametrize("args, word", [(["--workers", "0"], "workers"), (["--workers", "-2"], "workers"),
                                        (["--scheduler", "tcp://127.0.0.1:9"], "scheduler")])
def test_bad_workers_or_unreachable_scheduler_exit_2(tmp_path, args, word):
    pytest.importorskip("distributed", reason="dask[distributed] (the test extra) is not installed")
    r = runner.invoke(app, ["simulate", DOME, "--patterns", "raster", "--spacing", "1", "--patch", "8", "--dx", "0.05",
                            "--fwhm", "1", "--seeds", "1", "-q", "-o", str(tmp_path / "x"), *args])
    assert r.exit_code == 2, r.output
    assert word in r.output.lower() and "Traceback" not in r.output
    assert not (tmp_path / "x").exists()


def test_an_error_in_a_worker_process_exits_2_with_its_message(tmp_path):
    # the evaluation window does not fit a 3 mm patch: raised inside each case, in the worker processes
    r = runner.invoke(app, ["simulate", DOME, "--patterns", "raster,pseudorandom", "--spacing", "1", "--patch", "3",
                            "--dx", "0.05", "--fwhm", "1", "--seeds", "2", "--workers", "2", "-q",
                            "-o", str(tmp_path / "x")])
    assert r.exit_code == 2, r.output
    assert "--patch" in r.output and "Traceback" not in r.output
    assert not (tmp_path / "x").exists()
