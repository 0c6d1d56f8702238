"""`polishpath simulate SURFACE --treatment density-fit`: the comparison's density fit, given every path alike, from
the command line (issue 26 Build 4: the verdict as the tool prints it); a bad name is refused before any work."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from polishpath.cli import app


def test_the_density_fit_from_the_command_line(tmp_path):
    out = tmp_path / "sim"
    r = CliRunner().invoke(app, ["simulate", "hemisphere:R=15,triangles=800", "--patterns",
                                 "pseudorandom:relaxed,rectangular", "--spacing", "1.0", "--seeds", "1",
                                 "--patch", "10", "--dx", "0.02", "--mode", "interference-free",
                                 "--treatment", "density-fit", "-o", str(out), "--json", "-q"])
    assert r.exit_code == 0, r.output
    res = json.loads((out / "results.json").read_text())
    assert res["params"]["treatment"] == "density-fit"
    assert {row["name"] for row in res["rows"]} == {"pseudorandom:relaxed", "rectangular"}
    assert all(row.get("treatment") for row in res["rows"])  # each row records its fit's figures


def test_an_unknown_treatment_is_refused_with_the_choices(tmp_path):
    r = CliRunner().invoke(app, ["simulate", "hemisphere:R=15,triangles=800", "--patterns", "raster",
                                 "--treatment", "polish-harder", "-o", str(tmp_path / "x")])
    assert r.exit_code == 2, r.output
    assert "unknown treatment 'polish-harder'" in r.output and "density-fit" in r.output and "ripple-fit" in r.output
    assert "Traceback" not in r.output and not (tmp_path / "x").exists()
