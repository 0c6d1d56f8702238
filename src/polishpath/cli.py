"""The ``polishpath`` command line.

Every command catches :class:`~polishpath.errors.PolishPathError`, prints its
message (what is wrong, what to do) and exits non-zero; no traceback is shown
for bad input. ``--json`` prints one JSON object of figures on stdout.

Exit codes: 0 success, 1 unexpected internal error, 2 bad input or a stage
that could not complete (the message says which), 130 interrupted (SIGINT,
Ctrl-C), 143 terminated (SIGTERM). A command that writes a folder writes it
whole or not at all (:func:`polishpath.fileio.staged_folder`): after an
interrupt the folder is absent or as it was before, and the message says which.
"""

from __future__ import annotations

import contextlib
import inspect
import json
import os
import signal
import sys
import threading
import typing
from pathlib import Path
from typing import Any, Callable, Optional

import typer

from ._version import __version__
from .defaults import DEFAULT_FEED_MM_MIN
from .errors import PolishPathError

app = typer.Typer(
    name="polishpath",
    help=(
        "Pseudo-random polishing tool paths on free-form surfaces.\n\n"
        "SURFACE is a mesh file (.stl .obj .ply .off), a built-in shape with optional "
        "parameters (hemisphere:R=30,triangles=5000 — see `polishpath surfaces`), an "
        "analytic surface (asphere:R=80,k=-1,radius=20) or a .toml spec.\n\n"
        "Examples:\n\n"
        "  polishpath plan hemisphere --spacing 0.5 --seed 1 -o out\n\n"
        "  polishpath info part.stl --units m\n\n"
        "  polishpath flatten lilium.obj --method mabf -o flat.obj --json"
    ),
    no_args_is_help=True,
    add_completion=False,
    rich_markup_mode=None,
    pretty_exceptions_enable=False,
)


def _version_cb(value: bool):
    if value:
        typer.echo(f"polishpath {__version__}")
        raise typer.Exit(0)


@app.callback()
def _main(
    version: bool = typer.Option(False, "--version", callback=_version_cb, is_eager=True, help="Print the version and exit."),
):
    """polishpath command line."""


def _fail(msg: str, code: int) -> None:
    typer.echo(f"polishpath: error: {msg}", err=True)
    raise typer.Exit(code)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C's KeyboardInterrupt so the same clean-up runs (exit 143)."""


#: the SIGINTs / SIGTERMs this process received, in order (empty: none)
_SIGNALLED: list[int] = []


def _raise_on_signal(signum, frame):
    _SIGNALLED.append(signum)
    raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


def _handle_signals() -> dict | None:
    """Make SIGTERM raise :class:`Terminated` and SIGINT KeyboardInterrupt, remembering which came
    (main thread only: Python runs handlers there). Returns the handlers replaced (None: not installed)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    return {sig: signal.signal(sig, _raise_on_signal) for sig in (signal.SIGTERM, signal.SIGINT)}


def _interrupt_message(et: type, out: Path | None) -> tuple[str, int]:
    """What an interrupt left, said truthfully, and its exit code (130 SIGINT, 143 SIGTERM)."""
    from .fileio import COMMITTED

    code, name = (143, "terminated (SIGTERM)") if issubclass(et, Terminated) else (130, "interrupted (SIGINT)")
    if out is None:
        return f"{name}; nothing was written.", code
    if out.absolute() in COMMITTED:
        return f"{name} after {out} had been written whole.", code
    if out.exists():
        return f"{name}; {out} is as it was before this command (nothing of this run was written).", code
    return f"{name}; {out} was not created (no partial output left).", code


def _interrupt_in(exc: BaseException | None) -> BaseException | None:
    """The KeyboardInterrupt (SIGINT) or :class:`Terminated` (SIGTERM) that ``exc`` is or came from.

    A signal handled while compiled code runs (numba's dispatcher) surfaces as a
    ``SystemError`` "returned a result with an exception set" whose context is
    the interrupt: that is an interrupt too, not a bug.
    """
    first, seen = exc, 0
    while exc is not None and seen < 20:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        exc = exc.__cause__ or exc.__context__
        seen += 1
    if _SIGNALLED and isinstance(first, SystemError):  # the context was lost on the way out
        return Terminated() if _SIGNALLED[-1] == signal.SIGTERM else KeyboardInterrupt()
    return None


class _guard:
    """Turn polishpath errors into a message and exit code; SIGINT into exit 130, SIGTERM into 143.

    ``out_dir``: the output this command writes, named in the interrupt message.
    """

    def __init__(self, out_dir: Path | None = None):
        self.out_dir = out_dir

    def __enter__(self):
        self._handlers = _handle_signals()
        return self

    def __exit__(self, et, ev, tb):
        for sig, handler in (self._handlers or {}).items():
            signal.signal(sig, handler)
        if et is None or issubclass(et, (typer.Exit, SystemExit)):
            return False
        if issubclass(et, PolishPathError):
            _fail(str(ev), ev.exit_code)
        if issubclass(et, BrokenPipeError):
            _quiet_broken_pipe()
        interrupt = _interrupt_in(ev)
        if interrupt is not None:
            _fail(*_interrupt_message(type(interrupt), self.out_dir))
        if issubclass(et, MemoryError):
            _fail("ran out of memory. Try fewer triangles, a larger spacing, or a smaller part.", 2)
        if os.environ.get("POLISHPATH_DEBUG"):
            return False  # show the traceback
        _fail(
            f"internal error: {et.__name__}: {ev}. This is a bug in polishpath; please report it with the "
            "command you ran (set POLISHPATH_DEBUG=1 to see the traceback).",
            1,
        )


def _quiet_broken_pipe() -> None:
    """The reader of our output went away (``polishpath info X | head``): stop quietly, like other Unix tools.

    stdout is pointed at /dev/null so that Python's own flush at exit does not
    raise again; the exit code is the shell's for a SIGPIPE death (128 + 13).
    """
    with contextlib.suppress(OSError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    raise typer.Exit(141)


def _print_json(obj: Any) -> None:
    from .fileio import jsonable

    typer.echo(json.dumps(jsonable(obj), indent=2))


def _quiet(quiet: bool, json_out: bool) -> None:
    from . import progress

    if quiet or json_out:
        progress.set_enabled(False)


SURFACE_ARG = typer.Argument(..., metavar="SURFACE", help="Mesh file, built-in name[:key=value,...], analytic spec, or .toml spec.")
UNITS_OPT = typer.Option(None, "--units", help="Units of a mesh file: mm (default), m, cm, um, in.")
SCALE_OPT = typer.Option(None, "--scale", help="Extra scale factor for a mesh file, to millimetres.")
def _remesh_help() -> str:
    from .config import FIELDS

    return FIELDS["remesh"].metadata["help"]


REMESH_HELP = _remesh_help()
COMPONENT_OPT = typer.Option("refuse", "--component", help="Several pieces in the mesh: 'refuse' (default) or 'largest'.")


@app.command("surfaces")
def surfaces_cmd(json_out: bool = typer.Option(False, "--json", help="Print JSON.")):
    """List the built-in shapes and their parameters (mm, degrees).

    Example: polishpath surfaces
    """
    from .surfaces import ANALYTIC_TYPES, BUILTINS

    if json_out:
        _print_json({n: {"parameters": b.defaults, "description": b.description} for n, b in BUILTINS.items()}
                    | {"_analytic_types": list(ANALYTIC_TYPES)})
        return
    typer.echo("Built-in surfaces (use as NAME or NAME:key=value,...):\n")
    for n, b in BUILTINS.items():
        typer.echo(f"  {n:15s} {b.description}")
        typer.echo(f"  {'':15s} " + ", ".join(f"{k}={v}" for k, v in b.defaults.items()))
    typer.echo(f"\nAnalytic surfaces (inline or in a .toml spec): {', '.join(ANALYTIC_TYPES)}")
    typer.echo("  e.g. asphere:R=80,k=-1,a4=1e-7,aperture=annulus,radius=25,inner_radius=6")


@app.command("info")
def info_cmd(
    surface: str = SURFACE_ARG,
    json_out: bool = typer.Option(False, "--json", help="Print JSON."),
    units: Optional[str] = UNITS_OPT,
    scale: Optional[float] = SCALE_OPT,
    component: str = COMPONENT_OPT,
):
    """Describe a surface: vertices, faces, boundary loops, area, bounds, findings.

    Examples: polishpath info part.stl --units m ;  polishpath info hemisphere --json
    """
    from .surfaces import describe_surface, load_surface

    with _guard():
        s = load_surface(surface, units=units, scale=scale, component=component)
        d = describe_surface(s)
        if json_out:
            _print_json(d)
            return
        typer.echo(f"{d['name']}  ({d['source']})")
        typer.echo(f"  vertices        {d['vertices']}")
        typer.echo(f"  faces           {d['faces']}")
        loops = ", ".join(f"{n} vertices / {L:.2f} mm" for n, L in zip(d["loop_vertices"], d["loop_lengths_mm"]))
        typer.echo(f"  boundary loops  {d['boundary_loops']}" + (f"  ({loops})" if loops else ""))
        typer.echo(f"  area            {d['area_mm2']:.4f} mm^2")
        typer.echo("  bounding box    " + " .. ".join("(" + ", ".join(f"{c:.3f}" for c in b) + ")" for b in (d["bbox_min"], d["bbox_max"])) + " mm")
        el = d["edge_length_mm"]
        typer.echo(f"  edge length     min {el['min']:.4g}  mean {el['mean']:.4g}  max {el['max']:.4g} mm")
        typer.echo(f"  smallest angle  {d['min_angle_deg']:.3g} deg")
        typer.echo(f"  topology        Euler characteristic {d['euler_characteristic']}" + ("  (a disc)" if d["disc_like"] else ""))
        if d["findings"]:
            typer.echo("  findings:")
            for f in d["findings"]:
                typer.echo(f"    - [{f['severity']}] {f['message']}" + ("  (repaired)" if f["repaired"] else ""))
        else:
            typer.echo("  findings        none")


@app.command("flatten")
def flatten_cmd(
    surface: str = SURFACE_ARG,
    method: str = typer.Option("mabf", "--method", "-m", help="mabf (default), abf, lscm, projection."),
    output: Optional[Path] = typer.Option(None, "-o", "--output", help="Write an OBJ: v = 3D, vt = planar (mm)."),
    remesh: str = typer.Option("auto", "--remesh", help=REMESH_HELP),
    json_out: bool = typer.Option(False, "--json", help="Print the distortion metrics as JSON."),
    units: Optional[str] = UNITS_OPT,
    scale: Optional[float] = SCALE_OPT,
    component: str = COMPONENT_OPT,
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress display."),
):
    """Flatten a surface to the plane and report its distortion.

    Example: polishpath flatten lilium.obj --method mabf -o flat.obj --json
    """
    from . import progress
    from .fileio import atomic_open
    from .flatten import flatten
    from .surfaces import load_surface
    from .surfaces.remesh import conformal_warning, fit_for_flattening, parse_remesh

    _quiet(quiet, json_out)
    with _guard(output):
        if output is not None:
            from .fileio import check_output_file

            check_output_file(output, what="-o")
        if output is not None and output.suffix.lower() != ".obj":
            from .errors import ParameterError

            raise ParameterError(
                f"flatten -o writes an OBJ (3D vertices v and planar coordinates vt), not {output.suffix or 'a file without extension'}:"
                " a flattening needs its planar coordinates, which STL, PLY and OFF have no place for.",
                f"Name the output {output.with_suffix('.obj').name}.",
            )
        mode = parse_remesh(remesh)
        with progress.stage("reading surface"):
            s = load_surface(surface, units=units, scale=scale, component=component)
        with progress.stage(f"flattening ({method})"):
            s = fit_for_flattening(s, remesh)
            flat = flatten(s, method)
        if warning := conformal_warning(s, flat.metrics):
            progress.warn(warning)
        if output is not None:
            from .flatten import save_obj

            output.parent.mkdir(parents=True, exist_ok=True)
            with atomic_open(output, "w") as fh:
                save_obj(flat, fh)
        d = {"surface": s.source or s.name, "method": method, "vertices": s.n_vertices, "faces": s.n_faces,
             "remesh": s.params.get("remesh", {"mode": mode[0], "applied": False}),
             "metrics": flat.metrics, "timings_s": flat.timings, "output": str(output) if output else None}
        if json_out:
            _print_json(d)
            return
        typer.echo(f"{s.name}: {s.n_faces} faces flattened with {method}")
        if "remesh" in s.params:
            rm = s.params["remesh"]
            typer.echo(f"  remeshed: {rm['faces_before']} -> {rm['faces_after']} faces, edges <= {rm['edge_mm']:.3g} mm ({rm['reason']})")
        for k, v in flat.metrics.items():
            typer.echo(f"  {k:32s} {v:.6g}" if isinstance(v, float) else f"  {k:32s} {v}")
        for k, v in flat.timings.items():
            typer.echo(f"  time {k:27s} {v:.3f} s")
        if output:
            typer.echo(f"wrote {output}")


def _with_job_options(cmd: Callable) -> Callable:
    """Give ``cmd`` one command-line option per job option that has a flag.

    The options come from :data:`polishpath.config.CLI_OPTIONS` (the
    :class:`~polishpath.config.JobConfig` fields, their flags and help), so a
    new job option needs no edit here. ``cmd`` receives them, unparsed, as one
    dict ``job_options`` (``None``: not given), for :func:`polishpath.config.parse_job`.
    """
    from .config import CLI_OPTIONS, value_type

    hints = typing.get_type_hints(cmd)
    own = [p.replace(annotation=hints.get(p.name, p.annotation))
           for p in inspect.signature(cmd).parameters.values() if p.name != "job_options"]
    names = {p.name for p in own}
    extra = []
    for f in CLI_OPTIONS:
        t = f.metadata["cli_type"] or value_type(f.name)
        extra.append(inspect.Parameter(f.name, inspect.Parameter.KEYWORD_ONLY, annotation=Optional[t],
                                       default=typer.Option(None, *f.metadata["flags"], help=f.metadata["help"])))

    def command(**kw):
        job = {f.name: kw.pop(f.name) for f in CLI_OPTIONS}
        return cmd(**{k: v for k, v in kw.items() if k in names}, job_options=job)

    params = own + extra
    command.__signature__ = inspect.Signature(params)
    command.__annotations__ = {p.name: p.annotation for p in params}
    command.__name__, command.__qualname__, command.__doc__ = cmd.__name__, cmd.__qualname__, cmd.__doc__
    return command


@app.command("plan")
@_with_job_options
def plan_cmd(
    surface: Optional[str] = typer.Argument(None, metavar="SURFACE", help="Mesh file, built-in[:key=value,...], analytic spec or .toml spec (or set it in --config)."),
    output: Optional[Path] = typer.Option(None, "-o", "--output", help="Output folder (default: out)."),
    config: Optional[Path] = typer.Option(None, "--config", "-c", help="Job TOML holding any of these options (a run writes its own job.toml)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object of figures on stdout."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress display."),
    job_options: Optional[dict] = None,
):
    """Plan a pseudo-random polishing path on a surface and write the machine files.

    Writes into the output folder: path.csv (dwell points), toolpath.xyz (dense
    X Y Z), toolpath.nc (G-code), summary.json, job.toml, flat.obj, run.npz and
    report.html with PNG figures (docs/run-folder.md).

    Examples:

      polishpath plan hemisphere --spacing 0.5 --seed 1 -o out

      polishpath plan part.stl --units m --spacing 0.3 --pattern raster -o out-raster

      polishpath plan --config out/job.toml -o out-again
    """
    _quiet(quiet, json_out)
    out_dir = output or Path("out")
    with _guard(out_dir):
        from .config import parse_job
        from .fileio import check_output_folder
        from .pipeline import run
        from .runfolder import is_run_folder

        cfg = parse_job(toml=config, surface=surface, **(job_options or {}))
        check_output_folder(out_dir, is_run_folder, what="output folder", kind="polishpath run folder")
        job = run(cfg)
        written = job.save(out_dir)
        summary = job.summary()
        for w in (summary.get("post") or {}).get("warnings", []):
            typer.echo(f"polishpath: warning: {w}", err=True)
        if json_out:
            _print_json({"output": {k: str(v) for k, v in written.items()}, **summary})
            return
        _print_plan_summary(job, summary, written, out_dir)


@app.command("report")
def report_cmd(
    run_dir: Path = typer.Argument(..., metavar="DIR", help="Folder of a finished `polishpath plan` run."),
    json_out: bool = typer.Option(False, "--json", help="Print the written files as JSON."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress display."),
):
    """Rebuild report.html and the PNG figures of a finished run from its files.

    Example: polishpath report out
    """
    from . import progress
    from .pipeline import rebuild_report

    _quiet(quiet, json_out)
    with _guard(run_dir):
        with progress.stage("writing report"):
            written = rebuild_report(run_dir)
        if json_out:
            _print_json({k: str(v) for k, v in written.items()})
            return
        typer.echo(f"report: {written['report']}")


@app.command("simulate")
def simulate_cmd(
    target: str = typer.Argument(..., metavar="SURFACE_OR_RUN_DIR", help="A surface (compare the path patterns on it), or the folder of a finished `polishpath plan ... -o DIR` run (simulate that run's own path on its part)."),
    patterns: str = typer.Option("pseudorandom,raster,spiral,rectangular", "--patterns", help="SURFACE: comma-separated path patterns to compare."),
    spacing: float = typer.Option(0.5, "--spacing", "-s", help="SURFACE: dwell-point spacing, mm, on the part as in `plan` (with --spacing-on plane: in the flattened plane). A run keeps its own."),
    spacing_on: str = typer.Option("surface", "--spacing-on", help="SURFACE: where --spacing holds, 'surface' (the part, as in `plan`) or 'plane' (the flattened plane)."),
    seed: Optional[int] = typer.Option(None, "--seed", help="Seed of the planner, the initial surface and the process noise (default 0; RUN_DIR: the run's seed)."),
    output: Optional[Path] = typer.Option(None, "-o", "--output", help="Output folder (default: out-simulate; RUN_DIR: RUN_DIR/simulation). A run folder gets a simulation/ subfolder and its report is rebuilt."),
    patch: float = typer.Option(20.0, "--patch", help="SURFACE: side of the simulated square patch at the region's centre, mm."),
    dx: Optional[float] = typer.Option(None, "--dx", help="Simulation pixel pitch, mm (SURFACE default 0.005: 5 um resolves 100 1/mm; RUN_DIR default: the finest of 5 um that keeps the whole part within 4 M pixels)."),
    plane: str = typer.Option("auto", "--plane", help="RUN_DIR: 'xy' (the part's projected x, y), 'unrolled' (the flattening's plane, depth corrected by its area ratio) or 'auto' (xy for a height field with slopes <= 30 deg, else unrolled)."),
    timing: str = typer.Option("machine", "--timing", help="RUN_DIR: 'machine' (the constant-period samples the machine runs) or 'dwell' (the dwell points with the times the schedule aimed at)."),
    rpm: float = typer.Option(230.0, "--rpm", help="Tool spin, 1/min (the paper's sponge: 230)."),
    radius: float = typer.Option(2.0, "--radius", help="Tool contact radius, mm."),
    pressure: str = typer.Option("parabolic", "--pressure", help="Contact pressure profile: parabolic, hertz, uniform, gaussian."),
    feed: float = typer.Option(DEFAULT_FEED_MM_MIN, "--feed", help="Nominal feed of the tool model, mm/min (RUN_DIR: the run's own feed schedule moves the tool)."),
    fwhm: Optional[float] = typer.Option(None, "--fwhm", help="Use a plain Gaussian tool influence function of this FWHM (mm) instead of the rotating tool."),
    rate: float = typer.Option(5.0, "--rate", help="Peak removal rate of the Gaussian TIF (with --fwhm), nm/s."),
    depth: float = typer.Option(200.0, "--depth", help="Mean depth to remove, nm (SURFACE: sets the dwell time per point; RUN_DIR: scales the tool's rate)."),
    time_model: str = typer.Option("segments", "--time-model", help="SURFACE: 'segments' (continuous motion), 'points' (stop and dwell) or 'machine' (NURBS at the interpolation period)."),
    method: str = typer.Option("mabf", "--method", "-m", help="SURFACE: flattening, mabf (default), abf, lscm, projection."),
    units: Optional[str] = UNITS_OPT,
    scale: Optional[float] = SCALE_OPT,
    component: str = COMPONENT_OPT,
    json_out: bool = typer.Option(False, "--json", help="Print the figures as JSON."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress display."),
):
    """Simulate polishing: compare the path patterns on a surface (the paper's Table 4), or a finished run's own path.

    SURFACE: plans every pattern on the part through the job's own wiring
    (spacing on the part, as in `plan`), simulates Preston removal with the same
    tool and process on a patch of the flattened plane (by default a sponge
    spinning at 230 rpm whose footprint leans with the feed direction), and
    prints before / after band-average PSD (1e3-1e5 1/m) and the suppression
    ratio; writes psd.png, residual maps, table.txt and results.json.

    RUN_DIR: simulates the run's own path (its machine samples, or its dwell
    points) over its whole part from a flat start, and prints the depth's mean,
    RMS and PV inside the part and the PSD of its centre; writes
    RUN_DIR/simulation/ and rebuilds the run's report. The model's assumptions
    are in docs/simulation.md.

    Examples: polishpath simulate hemisphere --spacing 0.5 --seed 1 -o out-sim ;
    polishpath simulate out-run
    """
    from .simulate import gaussian_tif, rotating_tool_tif

    _quiet(quiet, json_out)
    run_mode = Path(target).is_dir()
    with _guard((output or Path(target) / "simulation") if run_mode else (output or Path("out-simulate"))):
        tif = (gaussian_tif(rate, fwhm_mm=fwhm) if fwhm is not None
               else rotating_tool_tif(rpm, radius, pressure, feed_mm_min=feed))
        if run_mode:
            _simulate_run(Path(target), output, tif, plane=plane, timing=timing, dx=dx, depth=depth, seed=seed,
                          json_out=json_out)
        else:
            _simulate_patterns(target, output or Path("out-simulate"), tif, patterns=patterns, spacing=spacing,
                               spacing_on=spacing_on, seed=0 if seed is None else seed, patch=patch,
                               dx=0.005 if dx is None else dx, depth=depth, time_model=time_model, method=method,
                               units=units, scale=scale, component=component, json_out=json_out)


def _simulate_run(run_dir: Path, output: Optional[Path], tif, *, plane, timing, dx, depth, seed, json_out) -> None:
    """``polishpath simulate RUN_DIR``: the run's own path on its part (read through polishpath.runfolder)."""
    from . import progress
    from .runfolder import SIMULATION_DIR, read_run
    from .simulate import simulate_job
    from .simulate.jobfiles import format_job_table, write_job_outputs

    with progress.stage("reading the run"):
        run = read_run(run_dir)
        tool_path, surface, flat = run.tool_path, run.surface, run.flattening
    run_seed = run.summary.get("seed")
    seed = seed if seed is not None else (run_seed if isinstance(run_seed, int) else 0)
    name = f"{run_dir.name} ({surface.source or surface.name}, {tool_path.surface_path.planar.pattern}, " \
           f"{len(tool_path.dwell_params):,} dwell points, seed {run_seed})"
    sim_dir = output if output is not None else run_dir / SIMULATION_DIR
    into_run = sim_dir.absolute() == (run_dir / SIMULATION_DIR).absolute()
    staged = _simulation_staging(run_dir if into_run else sim_dir, into_run)
    with progress.stage(f"simulating the run's own path ({timing} timing)"):
        out = simulate_job(tool_path, surface, flattening=flat, plane=plane, timing=timing, tif=tif, dx_mm=dx,
                           depth_nm=depth, seed=seed, spacing_mm=run.spacing)
    with staged as stage:
        write_job_outputs(out, stage / SIMULATION_DIR if into_run else stage, run_dir.name)
        if into_run:
            from .report import write_report

            with progress.stage("rebuilding the run's report"):
                write_report(stage, shown_as=run_dir)
    if json_out:
        _print_json({"run": str(run_dir), "output": str(sim_dir), "summary": out["summary"]})
        return
    typer.echo(f"run: {name}")
    typer.echo(format_job_table(out["summary"], run_dir.name), nl=False)
    typer.echo(f"wrote {sim_dir}/ (table.txt, results.json, removal.png, residual.png"
               + (", psd.png)" if out["psd"] is not None else ")"))


def _simulate_patterns(surface: str, output: Path, tif, *, patterns, spacing, spacing_on, seed, patch, dx, depth,
                       time_model, method, units, scale, component, json_out) -> None:
    """``polishpath simulate SURFACE``: plan each pattern through pipeline.plan_on_surface, compare in the plane."""
    from . import progress
    from .errors import ParameterError
    from .flatten import boundary_region, flatten
    from .pipeline import plan_on_surface
    from .errors import PatchTooSmallError
    from .simulate import compare_planned
    from .simulate.compare import patch_bounds_at_centre
    from .surfaces import load_surface

    pats = [p.strip() for p in patterns.split(",") if p.strip()]
    if not pats:
        raise ParameterError("--patterns is empty.", "Name at least one pattern, e.g. pseudorandom,raster.")
    from .runfolder import is_run_folder

    into_run = is_run_folder(output) and (output / "summary.json").exists()
    staged = _simulation_staging(output, into_run)
    with progress.stage("reading surface"):
        s = load_surface(surface, units=units, scale=scale, component=component)
    with progress.stage(f"flattening ({method})"):
        flat = flatten(s, method)
        region = boundary_region(flat)
    planned, info = {}, {}
    for pat in pats:
        with progress.stage(f"planning {pat} ({spacing:g} mm on the {'part' if spacing_on == 'surface' else 'plane'})"):
            # margin=None: the job's own automatic margin, so `plan` at this spacing plans the same grid
            sp = plan_on_surface(flat, region, spacing, pattern=pat, seed=seed, spacing_on=spacing_on, margin=None)
        planned[pat] = sp.planar
        info[pat] = {"n_points": int(sp.planar.n_points), "planar_spacing_mm": float(sp.planar_spacing),
                     "spacing_mm": float(spacing), "spacing_on": spacing_on,
                     "provenance": sp.planar.provenance.to_dict()}
    sim_dir = output / "simulation" if into_run else output
    with staged as stage, progress.stage(f"simulating {len(pats)} paths on a {patch:g} mm patch at {dx * 1000:g} um"):
        try:
            bounds = patch_bounds_at_centre(region, patch)
            res = compare_planned(planned, seed=seed, dx_mm=dx, tif=tif, removal_depth_nm=depth,
                                  time_model=time_model, patch_bounds=bounds,
                                  out_dir=stage / "simulation" if into_run else stage, plan_info=info)
        except PatchTooSmallError:
            raise PatchTooSmallError(f"--patch {patch:g} mm is too small for this tool: the PSD is evaluated "
                                     "inside the patch, away from its edges by the tool's reach.",
                                     "Use --patch 10 or larger.") from None
        if into_run:
            from .report import write_report

            with progress.stage("rebuilding the run's report"):
                write_report(stage, shown_as=output)
    if json_out:
        _print_json({"surface": s.source or s.name, "output": str(sim_dir), "rows": res["rows"], "params": res["params"]})
        return
    typer.echo(res["table"])
    typer.echo(f"spacing {spacing:g} mm on the {'part' if spacing_on == 'surface' else 'flattened plane'}; "
               "simulated in the flattened plane at each pattern's planar spacing ("
               + ", ".join(f"{k} {v['planar_spacing_mm']:.3g} mm" for k, v in info.items()) + ")")
    typer.echo(f"wrote {sim_dir}/ (table.txt, results.json, psd.png, residual maps)")


def _simulation_staging(folder: Path, into_run: bool):
    """The staged folder a simulation writes (checked now, before the work; entered to write).

    ``into_run``: ``folder`` is a run folder, which gets a fresh ``simulation/`` and
    report (its other files copied); else ``folder`` is a simulation folder of its own.
    """
    from .fileio import check_output_folder, staged_folder
    from .runfolder import SIMULATION_DIR, is_run_folder
    from .simulate import is_simulation_folder

    if into_run:
        kw = dict(recognise=is_run_folder, kind="polishpath run folder",
                  keep=lambda n: n not in (SIMULATION_DIR, "report.html", "figures"))
    else:
        kw = dict(recognise=is_simulation_folder, kind="polishpath simulation folder")
    check_output_folder(folder, kw["recognise"], kind=kw["kind"])
    return staged_folder(folder, **kw)


@app.command("psd")
def psd_cmd(
    file: Path = typer.Argument(..., metavar="FILE", help="Measured profile or map: text (x z, x y z, grid), CSV, or Zygo .datx."),
    after: Optional[Path] = typer.Argument(None, metavar="[AFTER]", help="A second measurement (after polishing) to compare with FILE."),
    band: str = typer.Option("1,100", "--band", help="Band 'lo,hi' in 1/mm (default 1,100 = 1e3-1e5 1/m)."),
    spacing: Optional[float] = typer.Option(None, "--spacing", help="Path spacing, mm: name peaks at 1/spacing and harmonics."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Write a log-log PSD plot (PNG)."),
    lateral_unit: Optional[str] = typer.Option(None, "--lateral-unit", help="Unit of x / y in the files: m, mm, um, nm (default: what the file says, else mm with a warning)."),
    height_unit: Optional[str] = typer.Option(None, "--height-unit", help="Unit of the heights in the files: m, mm, um, nm (default: what the file says, else nm with a warning)."),
    nan: Optional[str] = typer.Option(None, "--nan", help="Missing samples: interpolate, drop (profiles of a map) or raise (default: drop complete rows of a map, else interpolate)."),
    mixed: bool = typer.Option(False, "--mixed", help="Allow comparing a map with a profile (row-profile PSDs)."),
    json_out: bool = typer.Option(False, "--json", help="Print the figures as JSON."),
):
    """PSD and band RMS of a measured surface or profile; with AFTER, the suppression ratio.

    Examples: polishpath psd before.datx after.datx --band 1,100 ;  polishpath psd profile.txt --spacing 0.5
    """
    from .psd import analyze_file, compare_files

    with _guard():
        from .config import parse_pair

        lo, hi = parse_pair(band, "--band", "'lo,hi' in 1/mm")
        kw = {"spacing_mm": spacing, "lateral_unit": lateral_unit, "height_unit": height_unit, "nan": nan}
        if after is None:
            res = analyze_file(file, (lo, hi), **kw)
            psds = {file.name: res["psd"]}
        else:
            res = compare_files(file, after, (lo, hi), allow_mixed=mixed, **kw)
            psds = {f"before ({file.name})": res["before"]["psd"], f"after ({after.name})": res["after"]["psd"]}
        if plot is not None:
            from .simulate import plot_psds

            plot.parent.mkdir(parents=True, exist_ok=True)
            plot_psds(psds, plot, band=(lo, hi))
        if json_out:
            _print_json(_psd_json(res))
            return
        _print_psd(res, file, after, lo, hi)
        if plot is not None:
            typer.echo(f"wrote {plot}")


@app.command("paper")
def paper_cmd(
    output: Path = typer.Option(Path("out-paper"), "-o", "--output", help="Output folder for paper.md, paper.html and figures."),
    quick: bool = typer.Option(False, "--quick", help="Reduced setting (small meshes, coarse spacing): about a minute."),
    seed: int = typer.Option(0, "--seed", help="Seed of every random stage."),
    meshes: Path = typer.Option(None, "--meshes", envvar="POLISHPATH_MESHES", show_default=False,
                                help="The shared meshes folder (stanford-bunny.obj for the rabbit of Fig. 10, "
                                     "lilium.obj for the full Table 3); default $POLISHPATH_MESHES. Without it "
                                     "those cases are skipped and the document says so."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress display."),
):
    """Reproduce the paper's four tables and its figures from our own runs, beside the paper's numbers.

    Example: polishpath paper -o out-paper --meshes ../shared/data/meshes   (full run: a few minutes; --quick: about a minute)
    """
    from . import progress
    from .fileio import check_output_folder, staged_folder
    from .paper import is_paper_folder, reproduce

    _quiet(quiet, False)
    with _guard(output):
        check_output_folder(output, is_paper_folder, kind="polishpath paper folder")
        if meshes is None:
            typer.echo("polishpath: note: no shared meshes folder (--meshes DIR or $POLISHPATH_MESHES): the rabbit "
                       "of Fig. 10 and the lilium row of Table 3 are skipped.", err=True)
        with staged_folder(output, is_paper_folder, kind="polishpath paper folder") as stage:
            with progress.stage("reproducing the paper's tables and figures"):
                res = reproduce(stage, quick=quick, seed=seed, meshes=meshes)
        typer.echo(f"wrote {output / Path(res['markdown']).name}")
        if res.get("html"):
            typer.echo(f"wrote {output / Path(res['html']).name}")
        secs = res.get("seconds", {}).get("total")
        if secs is not None:
            typer.echo(f"took {secs:.1f} s")
        if res.get("errors"):
            for name, err in dict(res["errors"]).items():
                typer.echo(f"polishpath: error: section {name} failed: {err}", err=True)
            raise typer.Exit(2)


def _psd_json(res: dict) -> dict:
    out = {}
    for k, v in res.items():
        if hasattr(v, "to_dict"):
            out[k] = v.to_dict()
        elif isinstance(v, dict):
            out[k] = _psd_json(v)
        else:
            out[k] = v
    return out


def _print_psd(res: dict, file: Path, after: Optional[Path], lo: float, hi: float) -> None:
    def one(r, label):
        typer.echo(f"{label}: {r['kind']} {tuple(r['shape'])} at {r['dx_mm'] * 1000:.4g} um, {r['n_nan']} missing pixels")
        mp = r.get("measurement_params", {})
        if mp.get("units_assumed"):
            typer.echo(f"  units assumed: {', '.join(mp['units_assumed'])}")
        if mp.get("resampled"):
            typer.echo(f"  {mp['resampled']}")
        typer.echo(f"  RMS {r['rms_nm']:.4g} nm; band {lo:g}-{hi:g} 1/mm: RMS {r['band_rms_nm']:.4g} nm, "
                   f"average PSD {r['band_average']:.4g} {r['units']}")
        for pk in r.get("peaks", [])[:8]:
            typer.echo("  peak " + ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in pk.items()))

    if after is None:
        one(res, str(file))
    else:
        one(res["before"], f"before {file}")
        one(res["after"], f"after  {after}")
        if res.get("mixed"):
            typer.echo("  (a map compared with a profile: row-profile PSDs, --mixed)")
        sr = res.get("suppression_ratio")
        if sr is not None:
            typer.echo(f"suppression ratio (1 - after/before, band-average PSD): {sr * 100:.2f} %")


def _print_plan_summary(job, summary: dict, written: dict, out_dir: Path) -> None:
    p = summary["plan"]
    st = summary["map"]["stats"]
    typer.echo(f"{job.surface.name}: {job.surface.n_faces} faces, flattened with {job.flattening.provenance.method}")
    typer.echo(f"  {p['pattern']} path: {p['dwell_points']} dwell points, seed {summary['seed']}, "
               f"spacing {job.config.spacing:g} mm on the part (planar {p['planar_spacing_mm']:.4g} mm)")
    if "step_mean" in st:
        typer.echo(f"  steps on the part: mean {st['step_mean']:.4g} mm, max {st['step_max']:.4g} mm, "
                   f"{100 * st.get('share_normal', float('nan')):.1f} % in [s, sqrt(2) s]")
    sm = summary["smooth"]["stats"]
    if "duration_s" in sm:
        typer.echo(f"  machine path: {summary['smooth']['samples']} points at {summary['smooth']['period_ms']:g} ms, "
                   f"{sm['duration_s'] / 60:.1f} min, chord error <= {1000 * sm.get('chord_error_max', float('nan')):.3g} um")
    if sm.get("boundary_excursion_max_mm") is not None and "boundary_margin_mm" in sm:
        typer.echo(f"  inside the part: margin {sm['boundary_margin_mm']:.3g} mm"
                   f"{' (automatic)' if sm.get('boundary_margin_auto') else ''}, farthest sample beyond the "
                   f"boundary {1000 * sm['boundary_excursion_max_mm']:.3g} um")
    fg = summary.get("figuring")
    if fg:
        typer.echo(f"  figuring ({fg['solver']}): error {fg['initial_rms_nm']:.3g} nm RMS -> predicted residual "
                   f"{fg['residual_rms_nm']:.3g} nm RMS ({fg['residual_pv_nm']:.3g} nm PV), dwell total "
                   f"{fg['total_time_s'] / 60:.1f} min")
        if fg.get("uncorrectable_note"):
            typer.echo(f"  {fg['uncorrectable_note']}")
    m = p.get("metrics", {})
    for key in ("coverage", "directions_used", "crossings"):
        if key in m:
            typer.echo(f"  {key:28s} {m[key]}")
    sc = summary.get("schedule")
    if sc:
        e = sc["dwell_time_error"]
        typer.echo(f"  machine {sc['machine']['name']}: {sc['machining_time_s'] / 60:.1f} min of path moves "
                   f"({100 * sc['time_increase']:+.1f} % on the plan), limits slow {100 * sc['limited_share']:.1f} % "
                   f"of the segments; dwell-time error max {e['max']:.3g}, p99 {e['p99']:.3g}, rms {e['rms']:.3g}")
    pr = summary.get("post")
    if pr:
        typer.echo(f"  machine file: {pr['file']} ({pr['post']}, {pr['mode']}, {pr['feed_mode']} feed, "
                   f"{pr['coordinates']}), machining time {pr['machining_time_s'] / 60:.1f} min")
    typer.echo(f"wrote {len(set(written.values()))} files to {out_dir}/")
    if "report" in written:
        typer.echo(f"report: {written['report']}")


def main() -> None:
    """Console-script entry point."""
    _handle_signals()
    try:
        app()
    except BrokenPipeError:  # pragma: no cover - output closed while typer printed help
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        sys.exit(141)
    except KeyboardInterrupt as exc:  # outside typer (it turns the rest into a silent exit 130)
        msg, code = _interrupt_message(type(exc), None)
        typer.echo(f"polishpath: {msg}", err=True)
        sys.exit(code)
    except SystemExit as exc:
        # a signal before a command's guard (while the command line is parsed): typer ends it with a silent
        # exit 130 raised *from* the interrupt; say so, with SIGTERM's own code (the guard's exits are not from one)
        ctx = exc.__context__
        if isinstance(ctx, typer.Exit) and isinstance(ctx.__cause__, KeyboardInterrupt):
            msg, code = _interrupt_message(type(ctx.__cause__), None)
            typer.echo(f"polishpath: {msg}", err=True)
            sys.exit(code)
        raise


if __name__ == "__main__":  # pragma: no cover
    main()
