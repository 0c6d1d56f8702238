"""One config path: flags, TOML and keyword arguments become a JobConfig through polishpath.config.parse_job."""

from __future__ import annotations

import dataclasses

import pytest
from typer.testing import CliRunner

import polishpath
from polishpath.cli import app
from polishpath.config import CLI_OPTIONS, FIELDS, JobConfig, parse_job
from polishpath.errors import ParameterError, PatchTooSmallError, SpecError
from polishpath.provenance import DRAWN_SEED_LIMIT, resolve_seed

runner = CliRunner()


def test_every_flagged_option_is_a_plan_flag():
    help_text = runner.invoke(app, ["plan", "--help"], terminal_width=200).output
    assert CLI_OPTIONS, "no job option has a flag"
    for f in CLI_OPTIONS:
        for flag in f.metadata["flags"]:
            for one in flag.split("/"):
                assert one in help_text, f"{f.name}: {one} missing from `polishpath plan --help`"


def test_flags_reach_the_config_unchanged(monkeypatch, tmp_path):
    seen = {}

    def fake_run(cfg):
        seen["cfg"] = cfg
        raise SystemExit(0)

    monkeypatch.setattr("polishpath.pipeline.run", fake_run)
    r = runner.invoke(app, ["plan", "saddle", "--spacing", "0.7", "--seed", "3", "--start", "1,2", "--gcode", "nurbs",
                            "--no-report", "--max-points", "1000", "--feed", "900", "-o", str(tmp_path)])
    assert r.exit_code == 0, r.output
    want = JobConfig(surface="saddle", spacing=0.7, seed=3, start=(1.0, 2.0), gcode="nurbs", report=False,
                     max_points=1000, feed_mm_min=900.0)
    assert seen["cfg"] == want


def test_toml_keywords_and_flags_meet_in_one_parser(tmp_path):
    p = tmp_path / "job.toml"
    p.write_text('[job]\nsurface = "saddle"\nspacing = 0.8\nseed = 4\nstart = [1, 2]\n')
    cfg = parse_job(toml=p, spacing=0.6)  # the later source wins
    assert (cfg.surface, cfg.spacing, cfg.seed, cfg.start) == ("saddle", 0.6, 4, (1.0, 2.0))
    assert parse_job(toml=p, seed=None).seed == 4  # None: not given
    assert JobConfig.from_toml(p) == parse_job(toml=p)
    assert parse_job(base=cfg, margin=0.1) == dataclasses.replace(cfg, margin=0.1)
    with pytest.raises(dataclasses.FrozenInstanceError):
        cfg.spacing = 1.0


@pytest.mark.parametrize("options, words", [
    ({"spacing": -1.0}, "spacing must be a positive"),
    ({"spacing": "1"}, "spacing (--spacing) must be a number"),
    ({"spacing_on": "part"}, "spacing_on must be 'surface' or 'plane'"),
    ({"gcode": "fancy"}, "gcode must be 'linear' or 'nurbs'"),
    ({"margin": -0.1}, "margin must be >= 0"),
    ({"report": "yes"}, "report (--report) must be true or false"),
    ({"max_points": 2.5}, "max_points (--max-points) must be a whole number"),
    ({"start": (1.0,)}, "start (--start) must be two numbers"),
    ({"start": "1;2"}, "--start takes two numbers"),
    ({"seed": -1}, "seed must be a whole number"),
    ({"seed": 1.5}, "seed must be a whole number"),
    ({"seed": True}, "seed must be a whole number"),
    ({"sped": 1.0}, "unknown job option(s) sped"),
])
def test_bad_options_are_parameter_errors_naming_the_option(options, words):
    with pytest.raises(ParameterError) as e:
        parse_job(**options)
    assert words in str(e.value)
    with pytest.raises(ParameterError):  # polishpath.run goes through the same parser
        polishpath.run(**options)


def test_bad_toml_options(tmp_path):
    p = tmp_path / "job.toml"
    p.write_text("[job]\nspeling = 3\n")
    with pytest.raises(SpecError, match="unknown job option"):
        parse_job(toml=p)
    p.write_text("[job]\nspacing = 'half a mm'\n")
    with pytest.raises(ParameterError, match="spacing"):
        parse_job(toml=p)
    p.write_text("job = 3\n")
    with pytest.raises(SpecError, match="must be a table"):
        parse_job(toml=p)


def test_the_seed_is_checked_and_drawn_in_one_place():
    assert resolve_seed(7) == 7
    drawn = {resolve_seed(None) for _ in range(20)}
    assert all(0 <= s < DRAWN_SEED_LIMIT for s in drawn) and len(drawn) > 1
    for bad in (-1, 2**63, 1.0, "3", True):
        with pytest.raises(ParameterError, match="seed must be a whole number"):
            resolve_seed(bad)
    # the planner says the same thing as the job
    import numpy as np

    from polishpath.plan import plan
    from polishpath.types import Region

    t = np.linspace(0, 2 * np.pi, 30, endpoint=False)
    with pytest.raises(ParameterError, match="seed must be a whole number"):
        plan(Region(np.c_[5 * np.cos(t), 5 * np.sin(t)]), 1.0, seed=-2)


def test_every_field_is_documented_in_the_class_docstring():
    doc = JobConfig.__doc__
    for name in FIELDS:
        assert name in doc, f"JobConfig docstring does not describe {name}"


def test_a_too_small_patch_is_named_by_its_class_not_its_text(tmp_path):
    r = runner.invoke(app, ["simulate", "hemisphere:R=10,triangles=400", "--patterns", "raster", "--spacing", "1",
                            "--patch", "3", "--dx", "0.05", "-o", str(tmp_path), "-q"])
    assert r.exit_code == 2, r.output
    assert "--patch 3 mm is too small" in r.output and "Traceback" not in r.output
    assert issubclass(PatchTooSmallError, ParameterError)
