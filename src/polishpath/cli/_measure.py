"""Commands that measure or reproduce: simulate, sweep, psd, paper."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..defaults import (DEFAULT_CONTACT_RADIUS_MM, DEFAULT_FEED_MM_MIN, DEFAULT_PATCH_MM, DEFAULT_PEAK_RATE_NM_S,
                        DEFAULT_PRESSURE, DEFAULT_REMOVAL_DEPTH_NM, DEFAULT_RPM, DEFAULT_SEEDS)

from ._common import COMPONENT_OPT, SCALE_OPT, UNITS_OPT, _guard, _print_json, _quiet, app, job_default

#: where a comparison's independent cases run (polishpath.simulate.cases.CaseRunner)
WORKERS_OPT = typer.Option(None, "--workers", "-j", help="SURFACE: local worker processes for the independent cases (pattern x seed); default every core, 1 = one after another in this process. The results are the same bytes either way.")
SCHEDULER_OPT = typer.Option(None, "--scheduler", help="SURFACE: run the cases on a Dask cluster, the scheduler's address (e.g. tcp://host:8786; needs pip install 'polishpath[dask]', docs/simulation.md).")


@app.command("simulate")
def simulate_cmd(
    target: str = typer.Argument(..., metavar="SURFACE_OR_RUN_DIR", help="A surface (compare the path patterns on it), or the folder of a finished `polishpath plan ... -o DIR` run (simulate that run's own path on its part)."),
    patterns: str = typer.Option("pseudorandom,raster,spiral,rectangular", "--patterns", help="SURFACE: comma-separated path patterns to compare; PATTERN:SET on a dwell-point set (pseudorandom:blue-noise: no lattice)."),
    spacing: float = typer.Option(job_default("spacing"), "--spacing", "-s", help="SURFACE: dwell-point spacing, mm, on the part as in `plan` (with --spacing-on plane: in the flattened plane). A run keeps its own."),
    spacing_on: str = typer.Option(job_default("spacing_on"), "--spacing-on", help="SURFACE: where --spacing holds, 'surface' (the part, as in `plan`) or 'plane' (the flattened plane)."),
    seed: Optional[int] = typer.Option(None, "--seed", help="Base seed of the planner, the initial surface and the process noise (default 0; RUN_DIR: the run's seed)."),
    seeds: int = typer.Option(DEFAULT_SEEDS, "--seeds", help="SURFACE: run the random inputs (the pseudo-random path, the initial surface, the noise) over N seeds, seed i = base seed + i; figures are mean [min, max]."),
    mode: str = typer.Option("process", "--mode", help="SURFACE: 'process' (rough start, process noise, pad smoothing) or 'interference-free' (flat start, no noise: only the path's own marks)."),
    machine: Optional[str] = typer.Option(None, "--machine", help="SURFACE, machine timing: a machine profile (TOML file, see examples/machine-*.toml, or generic-3axis) whose axis limits slow the tool down at turns."),
    without: Optional[str] = typer.Option(None, "--without", help="SURFACE: switch mechanisms off, comma-separated: footprint (zero-feed footprint), edge (smooth pressure), smoothing, noise, slowdown (ideal timing)."),
    treatment: str = typer.Option("none", "--treatment", help="SURFACE: what every path gets alike before it is simulated: 'none' (as planned), 'density-fit' (dwell points moved <= 0.3 spacing so the machine's time density is flat where the tool passes it) or 'ripple-fit' (moved within the same bounds so the removal, as the tool's own kernels compute it from the machine's samples, is flat over 0.95-3 1/mm); docs/simulation.md. The job's own G-code gets no such fit."),
    output: Optional[Path] = typer.Option(None, "-o", "--output", help="Output folder (default: out-simulate; RUN_DIR: RUN_DIR/simulation). A run folder gets a simulation/ subfolder and its report is rebuilt."),
    patch: float = typer.Option(DEFAULT_PATCH_MM, "--patch", help="SURFACE: side of the simulated square patch at the region's centre, mm."),
    dx: Optional[float] = typer.Option(None, "--dx", help="Simulation pixel pitch, mm (SURFACE default 0.005: 5 um resolves 100 1/mm; RUN_DIR default: the finest of 5 um that keeps the whole part within 4 M pixels)."),
    plane: str = typer.Option("auto", "--plane", help="RUN_DIR: 'xy' (the part's projected x, y), 'unrolled' (the flattening's plane, depth corrected by its area ratio) or 'auto' (xy for a height field with slopes <= 30 deg, else unrolled)."),
    timing: str = typer.Option("machine", "--timing", help="'machine' (default: the constant-period samples the job's smoothing and feed schedule run, slow-downs included) or 'ideal' (each dwell point's time exactly as asked; RUN_DIR also calls it 'dwell')."),
    rpm: float = typer.Option(DEFAULT_RPM, "--rpm", help=f"Tool spin, 1/min (the paper's sponge: {DEFAULT_RPM:g})."),
    radius: float = typer.Option(DEFAULT_CONTACT_RADIUS_MM, "--radius", help="Tool contact radius, mm."),
    pressure: str = typer.Option(DEFAULT_PRESSURE, "--pressure", help="Contact pressure profile: parabolic, hertz, uniform, gaussian."),
    feed: float = typer.Option(DEFAULT_FEED_MM_MIN, "--feed", help="Nominal feed of the tool model, mm/min (RUN_DIR: the run's own feed schedule moves the tool)."),
    fwhm: Optional[float] = typer.Option(None, "--fwhm", help="Use a plain Gaussian tool influence function of this FWHM (mm) instead of the rotating tool."),
    rate: float = typer.Option(DEFAULT_PEAK_RATE_NM_S, "--rate", help="Peak removal rate of the Gaussian TIF (with --fwhm), nm/s."),
    depth: float = typer.Option(DEFAULT_REMOVAL_DEPTH_NM, "--depth", help="Mean depth to remove, nm (SURFACE: sets the dwell time per point; RUN_DIR: scales the tool's rate)."),
    time_model: Optional[str] = typer.Option(None, "--time-model", help="SURFACE: override --timing with a time model: 'segments' (continuous motion), 'points' (stop and dwell) or 'machine' (NURBS at the interpolation period, the simulation's own)."),
    method: str = typer.Option(job_default("method"), "--method", "-m", help="SURFACE: flattening, mabf (default), abf, lscm, projection."),
    units: Optional[str] = UNITS_OPT,
    scale: Optional[float] = SCALE_OPT,
    component: str = COMPONENT_OPT,
    workers: Optional[int] = WORKERS_OPT,
    scheduler: Optional[str] = SCHEDULER_OPT,
    json_out: bool = typer.Option(False, "--json", help="Print the figures as JSON."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress display."),
):
    """Simulate polishing: compare the path patterns on a surface (the paper's Table 4), or a finished run's own path.

    SURFACE: plans every pattern on the part through the job's own wiring
    (spacing on the part, as in `plan`), simulates Preston removal with the same
    tool and process on a patch of the flattened plane (by default a sponge
    spinning at 230 rpm whose footprint leans with the feed direction), each
    path removing the same mean depth from the same start, over --seeds seeds;
    prints the fair figures of each residual (band RMS 1e3-1e5 1/m, the PSD
    peak at the path's lattice frequencies, PV / depth) and the paper's
    before / after suppression ratio, each as mean [min, max], and the
    rankings (ties where the ranges overlap); writes psd.png, residuals.png,
    table.txt and results.json.

    RUN_DIR: simulates the run's own path (its machine samples, or its dwell
    points) over its whole part from a flat start, and prints the depth's mean,
    RMS and PV inside the part and the PSD and fair figures of its centre;
    writes RUN_DIR/simulation/ and rebuilds the run's report. The model's
    assumptions are in docs/simulation.md.

    Examples: polishpath simulate hemisphere --spacing 0.5 --seed 1 -o out-sim ;
    polishpath simulate plane --mode interference-free --without footprint ;
    polishpath simulate out-run
    """
    from ..simulate import gaussian_tif, rotating_tool_tif
    from ..simulate.cases import CaseRunner

    _quiet(quiet, json_out)
    run_mode = Path(target).is_dir()
    with _guard((output or Path(target) / "simulation") if run_mode else (output or Path("out-simulate"))):
        runner = CaseRunner(workers, scheduler)  # a bad --workers / --scheduler: exit 2 before any work
        tif = (gaussian_tif(rate, fwhm_mm=fwhm) if fwhm is not None
               else rotating_tool_tif(rpm, radius, pressure, feed_mm_min=feed))
        if run_mode:
            _simulate_run(Path(target), output, tif, plane=plane, timing="dwell" if timing == "ideal" else timing,
                          dx=dx, depth=depth, seed=seed, json_out=json_out)
        else:
            from ..simulate.compare import check_comparison
            from ..simulate.mechanisms import parse_mechanisms

            check_comparison(seeds=seeds, mode=mode, timing=timing, time_model=time_model,
                             treatment=treatment)  # before any work
            mech = parse_mechanisms(without)
            prof = None
            if machine is not None:
                from ..schedule import load_machine

                prof = load_machine(machine)
            _simulate_patterns(target, output or Path("out-simulate"), tif, patterns=patterns, spacing=spacing,
                               spacing_on=spacing_on, seed=0 if seed is None else seed, patch=patch,
                               dx=0.005 if dx is None else dx, depth=depth, time_model=time_model, method=method,
                               units=units, scale=scale, component=component, json_out=json_out, seeds=seeds,
                               mode=mode, timing=timing, machine=prof, mechanisms=mech, runner=runner,
                               treatment=treatment)


def _simulate_run(run_dir: Path, output: Optional[Path], tif, *, plane, timing, dx, depth, seed, json_out) -> None:
    """``polishpath simulate RUN_DIR``: the run's own path on its part (read through polishpath.runfolder)."""
    from .. import progress
    from ..runfolder import SIMULATION_DIR, read_run
    from ..simulate import simulate_job
    from ..simulate.jobfiles import format_job_table, write_job_outputs

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
            from ..report import write_report

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
                       time_model, method, units, scale, component, json_out, seeds, mode, timing, machine,
                       mechanisms, runner, treatment="none") -> None:
    """``polishpath simulate SURFACE``: plan each pattern through pipeline.plan_on_surface, compare in the plane."""
    from .. import progress
    from ..errors import ParameterError
    from ..flatten import boundary_region, flatten
    from ..errors import PatchTooSmallError
    from ..simulate import compare_planned
    from ..simulate.patterns import patch_bounds_at_centre
    from ..surfaces import load_surface

    pats = [p.strip() for p in patterns.split(",") if p.strip()]
    if not pats:
        raise ParameterError("--patterns is empty.", "Name at least one pattern, e.g. pseudorandom,raster.")
    from ..runfolder import is_run_folder

    into_run = is_run_folder(output) and (output / "summary.json").exists()
    staged = _simulation_staging(output, into_run)
    with progress.stage("reading surface"):
        s = load_surface(surface, units=units, scale=scale, component=component)
    with progress.stage(f"flattening ({method})"):
        flat = flatten(s, method)
        region = boundary_region(flat)
    from ..pipeline.sweep import plan_patterns

    planned, info = plan_patterns(flat, region, pats, spacing, seed=seed, seeds=seeds, spacing_on=spacing_on)
    sim_dir = output / "simulation" if into_run else output
    with staged as stage, progress.stage(f"simulating {len(pats)} paths x {seeds} seeds on a {patch:g} mm patch at "
                                         f"{dx * 1000:g} um ({mode}, {timing} timing)"):
        try:
            bounds = patch_bounds_at_centre(region, patch)
            res = compare_planned(planned, seed=seed, seeds=seeds, mode=mode, timing=timing, machine=machine,
                                  mechanisms=mechanisms, dx_mm=dx, tif=tif, removal_depth_nm=depth,
                                  time_model=time_model, patch_bounds=bounds,
                                  out_dir=stage / "simulation" if into_run else stage, plan_info=info,
                                  runner=runner, treatment=treatment)
        except PatchTooSmallError:
            raise PatchTooSmallError(f"--patch {patch:g} mm is too small for this tool: the PSD is evaluated "
                                     "inside the patch, away from its edges by the tool's reach.",
                                     "Use --patch 10 or larger.") from None
        if into_run:
            from ..report import write_report

            with progress.stage("rebuilding the run's report"):
                write_report(stage, shown_as=output)
    if json_out:
        _print_json({"surface": s.source or s.name, "output": str(sim_dir), "rows": res["rows"],
                     "rankings": res["rankings"], "params": res["params"]})
        return
    typer.echo(res["table"])
    typer.echo(f"spacing {spacing:g} mm on the {'part' if spacing_on == 'surface' else 'flattened plane'}; "
               "simulated in the flattened plane at each pattern's planar spacing ("
               + ", ".join(f"{k} {v['planar_spacing_mm']:.3g} mm" for k, v in info.items()) + ")")
    typer.echo(f"wrote {sim_dir}/ (table.txt, results.json, psd.png, residuals.png, residual maps)")


@app.command("sweep")
def sweep_cmd(
    job: Path = typer.Argument(..., metavar="SWEEP.toml", help="The grid: parts, patterns, seeds, [[tool]] tables and the comparison's settings (docs/simulation.md, 'Sweeps')."),
    output: Path = typer.Option(Path("out-sweep"), "-o", "--output", help="Output folder: sweep.csv and sweep.json."),
    workers: Optional[int] = WORKERS_OPT,
    scheduler: Optional[str] = SCHEDULER_OPT,
    json_out: bool = typer.Option(False, "--json", help="Print the rows as JSON."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress display."),
):
    """Run the fair comparison over a grid of parts x patterns x seeds x tools and write one table.

    Every (part, tool) is one comparison as `polishpath simulate SURFACE` runs it, its
    independent cases (pattern x seed) on every local core, or on a Dask cluster with
    --scheduler tcp://host:8786; the table is the same bytes either way.

    Example: polishpath sweep examples/sweep.toml -o out-sweep --workers 2
    """
    from ..pipeline.sweep import read_sweep, run_sweep
    from ..simulate.cases import CaseRunner

    _quiet(quiet, json_out)
    with _guard(output):
        runner = CaseRunner(workers, scheduler)
        res = run_sweep(read_sweep(job), runner=runner, out_dir=output)
        if json_out:
            _print_json({"output": str(output), "rows": res["rows"], "params": res["params"]})
            return
        typer.echo(res["csv"], nl=False)
        typer.echo(f"wrote {output}/ (sweep.csv, sweep.json)")


def _simulation_staging(folder: Path, into_run: bool):
    """The staged folder a simulation writes (checked now, before the work; entered to write).

    ``into_run``: ``folder`` is a run folder, which gets a fresh ``simulation/`` and
    report (its other files copied); else ``folder`` is a simulation folder of its own.
    """
    from ..fileio import check_output_folder, staged_folder
    from ..runfolder import SIMULATION_DIR, is_run_folder
    from ..simulate import is_simulation_folder

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
    from ..psd import analyze_file, compare_files

    with _guard():
        from ..config import parse_pair

        lo, hi = parse_pair(band, "--band", "'lo,hi' in 1/mm")
        kw = {"spacing_mm": spacing, "lateral_unit": lateral_unit, "height_unit": height_unit, "nan": nan}
        if after is None:
            res = analyze_file(file, (lo, hi), **kw)
            psds = {file.name: res["psd"]}
        else:
            res = compare_files(file, after, (lo, hi), allow_mixed=mixed, **kw)
            psds = {f"before ({file.name})": res["before"]["psd"], f"after ({after.name})": res["after"]["psd"]}
        if plot is not None:
            from ..simulate import plot_psds

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
    from .. import progress
    from ..fileio import check_output_folder, staged_folder
    from ..paper import is_paper_folder, reproduce

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
        from ..psd.analyze import summary_lines

        for line in summary_lines(r, (lo, hi)):  # total RMS, band RMS and its share, where the height lies
            typer.echo(line)

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


