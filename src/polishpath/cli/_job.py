"""Commands about a part and its job: surfaces, info, flatten, plan, report."""

from __future__ import annotations

import inspect
import typing
from pathlib import Path
from typing import Callable, Optional

import typer


from ._common import (
    COMPONENT_OPT,
    REMESH_HELP,
    SCALE_OPT,
    SURFACE_ARG,
    UNITS_OPT,
    _guard,
    _print_json,
    _quiet,
    app,
    job_default,
)


@app.command("surfaces")
def surfaces_cmd(json_out: bool = typer.Option(False, "--json", help="Print JSON.")):
    """List the built-in shapes and their parameters (mm, degrees).

    Example: polishpath surfaces
    """
    from ..surfaces import ANALYTIC_TYPES, BUILTINS

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
    from ..surfaces import describe_surface, load_surface

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
    method: str = typer.Option(job_default("method"), "--method", "-m", help="mabf (default), abf, lscm, projection."),
    output: Optional[Path] = typer.Option(None, "-o", "--output", help="Write an OBJ: v = 3D, vt = planar (mm)."),
    remesh: str = typer.Option(job_default("remesh"), "--remesh", help=REMESH_HELP),
    json_out: bool = typer.Option(False, "--json", help="Print the distortion metrics as JSON."),
    units: Optional[str] = UNITS_OPT,
    scale: Optional[float] = SCALE_OPT,
    component: str = COMPONENT_OPT,
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress display."),
):
    """Flatten a surface to the plane and report its distortion.

    Example: polishpath flatten lilium.obj --method mabf -o flat.obj --json
    """
    from .. import progress
    from ..fileio import atomic_open
    from ..flatten import flatten
    from ..surfaces import load_surface
    from ..surfaces.remesh import conformal_warning, fit_for_flattening, parse_remesh

    _quiet(quiet, json_out)
    with _guard(output):
        if output is not None:
            from ..fileio import check_output_file

            check_output_file(output, what="-o")
        if output is not None and output.suffix.lower() != ".obj":
            from ..errors import ParameterError

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
            from ..flatten import save_obj

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
    from ..config import CLI_OPTIONS, value_type

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
        from ..config import parse_job
        from ..fileio import check_output_folder
        from ..pipeline import run
        from ..runfolder import is_run_folder

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
    from .. import progress
    from ..pipeline import rebuild_report

    _quiet(quiet, json_out)
    with _guard(run_dir):
        with progress.stage("writing report"):
            written = rebuild_report(run_dir)
        if json_out:
            _print_json({k: str(v) for k, v in written.items()})
            return
        typer.echo(f"report: {written['report']}")



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
        typer.echo(f"  figuring ({fg['solver']}): {fg['verdict']}, dwell total {fg['total_time_s'] / 60:.1f} min")
        for m in fg.get("refusals") or []:
            typer.echo(f"polishpath: warning: refused, written with --force: {m}", err=True)
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


