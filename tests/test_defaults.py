"""Each default is written once (issue 25, item 5), and the command line and the API agree on it.

A default lives in ``polishpath/defaults.py`` (what the stages share) or in
``config.JobConfig`` (the job's options, built on those); the command line's
options and the API functions read it from there. These tests compare every
command's option defaults with the job's and with the API functions they call,
and check (AST) that no command-line option retypes one as a literal.
"""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import pytest
import typer

from polishpath import defaults
from polishpath.cli import app
from polishpath.config import CLI_OPTIONS, FIELDS
from polishpath.export.post import PostSettings
from polishpath.flatten import flatten
from polishpath.paper.run import reproduce
from polishpath.pipeline.surfaceplan import plan_on_surface
from polishpath.simulate import compare_planned, gaussian_tif, rotating_tool_tif, simulate_job
from polishpath.simulate.machinetime import machine_timed_path
from polishpath.simulate.motion import _machine_samples
from polishpath.simulate.patterns import compare_patterns

CLI = Path(__file__).resolve().parents[1] / "src" / "polishpath" / "cli"
#: job option of each of the job's flags ("--spacing" -> "spacing"); --seed means another thing per command (the
#: job draws one, the comparison and the paper start from 0: their API's own defaults, compared below)
JOB_FLAGS = {flag.split("/")[0]: f.name for f in CLI_OPTIONS for flag in f.metadata["flags"] if flag != "--seed"}
#: flags of other commands whose default is a polishpath.defaults value (the tool model's)
DEFAULTS_FLAGS = {"--rpm": "DEFAULT_RPM", "--radius": "DEFAULT_CONTACT_RADIUS_MM", "--pressure": "DEFAULT_PRESSURE",
                  "--rate": "DEFAULT_PEAK_RATE_NM_S", "--feed": "DEFAULT_FEED_MM_MIN"}


def _default(fn, name):
    return inspect.signature(fn).parameters[name].default


def cli_defaults() -> dict[tuple[str, str], object]:
    """``(command, --flag) -> default`` of every option of every command of the ``polishpath`` app."""
    out = {}
    for cmd in app.registered_commands:
        for p in inspect.signature(cmd.callback).parameters.values():
            info = p.default
            if isinstance(info, typer.models.OptionInfo):
                flags = [d.split("/")[0] for d in (info.param_decls or ()) if d.startswith("--")]
                for flag in flags:
                    out[(cmd.name, flag)] = info.default
    return out


def disagreements(cli: dict, want: dict) -> list[str]:
    """``command --flag: X, API: Y`` for each option whose default is given and differs from ``want[flag]``."""
    return [f"polishpath {cmd} {flag}: {value!r}, API: {want[flag]!r}" for (cmd, flag), value in sorted(cli.items())
            if flag in want and value is not None and value != want[flag]]


def test_options_named_like_job_options_start_from_the_jobs_defaults():
    cli = cli_defaults()
    job = {flag: FIELDS[name].default for flag, name in JOB_FLAGS.items()}
    job["--feed"] = defaults.DEFAULT_FEED_MM_MIN  # the job's None: the smoothing stage's default feed
    assert {("flatten", "--method"), ("simulate", "--method"), ("simulate", "--spacing")} <= set(cli)
    bad = disagreements(cli, job)
    assert not bad, "command-line defaults that differ from config.JobConfig's: " + "; ".join(bad)


def test_the_rule_catches_a_disagreement():
    cli = {("flatten", "--method"): "abf", ("simulate", "--spacing"): 0.5, ("plan", "--spacing"): None}
    assert disagreements(cli, {"--method": "mabf", "--spacing": 0.5}) == [
        "polishpath flatten --method: 'abf', API: 'mabf'"]


def test_the_command_line_and_the_api_functions_agree():
    cli = cli_defaults()
    sim = {k[1]: v for k, v in cli.items() if k[0] == "simulate"}
    pairs = {
        "flatten --method / flatten()": (cli[("flatten", "--method")], _default(flatten, "method")),
        "--method / JobConfig": (sim["--method"], FIELDS["method"].default),
        "--spacing / compare_patterns()": (sim["--spacing"], _default(compare_patterns, "spacing")),
        "--rpm / rotating_tool_tif()": (sim["--rpm"], _default(rotating_tool_tif, "rpm")),
        "--radius / rotating_tool_tif()": (sim["--radius"], _default(rotating_tool_tif, "contact_radius_mm")),
        "--pressure / rotating_tool_tif()": (sim["--pressure"], _default(rotating_tool_tif, "pressure")),
        "--feed / rotating_tool_tif()": (sim["--feed"], _default(rotating_tool_tif, "feed_mm_min")),
        "--rate / gaussian_tif()": (sim["--rate"], _default(gaussian_tif, "peak_rate_nm_s")),
        "--seeds / compare_planned()": (sim["--seeds"], _default(compare_planned, "seeds")),
        "--mode / compare_planned()": (sim["--mode"], _default(compare_planned, "mode")),
        "--timing / compare_planned()": (sim["--timing"], _default(compare_planned, "timing")),
        "--timing / simulate_job()": (sim["--timing"], _default(simulate_job, "timing")),
        "--depth / compare_planned()": (sim["--depth"], _default(compare_planned, "removal_depth_nm")),
        "--depth / simulate_job()": (sim["--depth"], _default(simulate_job, "depth_nm")),
        "--plane / simulate_job()": (sim["--plane"], _default(simulate_job, "plane")),
        "--seed / compare_planned()": (0, _default(compare_planned, "seed")),  # the command's None: 0
        "paper --seed / reproduce()": (cli[("paper", "--seed")], _default(reproduce, "seed")),
        "--patterns / compare_patterns()": (sim["--patterns"], ",".join(_default(compare_patterns, "patterns"))),
        "spindle / the simulated tool": (PostSettings().spindle_rpm, _default(rotating_tool_tif, "rpm")),
        "--max-points / plan_on_surface()": (FIELDS["max_points"].default, _default(plan_on_surface, "max_points")),
        "--max-oversampling / plan_on_surface()": (FIELDS["max_oversampling"].default,
                                                   _default(plan_on_surface, "max_oversampling")),
    }
    bad = [f"{k}: {a!r} != {b!r}" for k, (a, b) in pairs.items() if a != b]
    assert not bad, "; ".join(bad)


def test_the_feed_cap_is_one_factor():
    assert _default(machine_timed_path, "max_feed_factor") == defaults.MAX_FEED_FACTOR
    assert _default(_machine_samples, "max_feed_factor") == defaults.MAX_FEED_FACTOR
    # smooth() and the figuring's fastest pass take it from polishpath.defaults, by name (no 5.0 * feed left)
    src = Path(defaults.__file__).parent
    for name in ("smooth/__init__.py", "pipeline/__init__.py"):
        tree = ast.parse((src / name).read_text())
        uses = [n for n in ast.walk(tree) if isinstance(n, ast.Name) and n.id == "MAX_FEED_FACTOR"]
        five = [n.lineno for n in ast.walk(tree) if isinstance(n, ast.BinOp) and isinstance(n.op, ast.Mult)
                and any(isinstance(s, ast.Constant) and s.value == 5.0 for s in (n.left, n.right))]
        assert uses and not five, f"{name}: the feed cap as a literal at line(s) {five}"


@pytest.mark.parametrize("path", sorted(CLI.glob("*.py")), ids=lambda p: p.name)
def test_no_command_line_option_retypes_a_default(path):
    """A flag of a job option or of a tool default takes its default from config / defaults, not a literal."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "Option"
                and node.args and isinstance(node.args[0], ast.Constant) and node.args[0].value is not None):
            flags = {a.value.split("/")[0] for a in node.args[1:] if isinstance(a, ast.Constant)}
            hit = flags & (set(JOB_FLAGS) | set(DEFAULTS_FLAGS))
            if hit:
                found.append(f"line {node.lineno}: {sorted(hit)[0]} {node.args[0].value!r}")
    assert not found, (f"cli/{path.name} retypes defaults: " + "; ".join(found) + ". Read them from "
                       "config.JobConfig (cli._common.job_default(name)) or polishpath.defaults.")
