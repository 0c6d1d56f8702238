"""The main job: surface -> flatten -> plan -> map -> smooth -> export: the one place stages are wired.

:func:`plan_on_surface` wires plan and map (with the step-reduction loop that
honours the spacing on the part); the job, the paper reproduction, the
simulation's pattern comparison and the benchmarks call it. :func:`run` takes
a :class:`~polishpath.config.JobConfig` (every option of ``polishpath plan``,
see :mod:`polishpath.config`) and returns a :class:`Job` holding each stage's
result; :meth:`Job.save` writes the machine files, the run-folder files
(:mod:`polishpath.runfolder`) and the report into a folder.
"""

from __future__ import annotations

import dataclasses
import datetime
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from . import progress, resources
from ._version import __version__
from .config import JobConfig, parse_job
from .defaults import DEFAULT_CHORD_TOL_MM, DEFAULT_FEED_MM_MIN, DEFAULT_PERIOD_MS
from .errors import MappingError, ParameterError, PlanningError, SpacingTooLargeError
from .fileio import atomic_open, jsonable
from .pathops import step_mask
from .provenance import machine_info, resolve_seed
from .types import Flattening, PlanarPath, Region, Surface, SurfacePath, ToolPath

SQRT2 = 2.0**0.5
#: margin planned inside the boundary when none is given, as a fraction of the planar spacing: the
#: cubic through the dwell points swings out by up to ~0.4 x the step at a sharp turn, but a turn right
#: at the boundary that swings outward is rare; measured on the annulus asphere and the hemisphere,
#: 0.2 x the spacing kept every sample within 3 um of the part (docs/machine-output.md)
AUTO_MARGIN_FACTOR = 0.25
#: re-plans with a wider margin when the machine path still leaves the part by more than the tolerance
BOUNDARY_REPLANS = 3


@dataclass(frozen=True)
class Job:
    """Results of every stage of one run, and what produced them."""

    config: JobConfig
    surface: Surface
    flattening: Flattening
    region: Region
    planar: PlanarPath
    surface_path: SurfacePath
    tool_path: ToolPath
    planar_spacing: float
    timings: dict[str, float] = field(default_factory=dict)
    plan_metrics: dict[str, Any] = field(default_factory=dict)
    program: dict[str, Any] = field(default_factory=dict)  # what the post wrote (Job.save)
    schedule: dict[str, Any] = field(default_factory=dict)  # the feed schedule under the machine profile
    figuring: Any = None
    figuring_prediction: dict[str, Any] | None = None

    @property
    def seed(self) -> int | None:
        return self.planar.provenance.seed

    def summary(self) -> dict[str, Any]:
        """Every figure of the run, JSON-ready (what ``summary.json`` holds)."""
        from .surfaces import describe_surface

        cfg = self.config.to_dict()
        cfg["seed"] = self.seed
        s = {
            "polishpath_version": __version__,
            "created": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
            "machine": machine_info(),
            "config": cfg,
            "seed": self.seed,
            "surface": describe_surface(self.surface),
            "flattening": {
                "method": self.flattening.provenance.method,
                "metrics": self.flattening.metrics,
                "timings_s": self.flattening.timings,
                "provenance": self.flattening.provenance.to_dict(),
            },
            "plan": {
                "pattern": self.planar.pattern,
                "planar_spacing_mm": self.planar_spacing,
                "surface_spacing_mm": self.config.spacing,
                "step_reduction_factor": self.planar_spacing / self.config.spacing,
                "dwell_points": self.planar.n_points,
                "pieces": int(len(self.planar.pieces) - 1),
                "unreached": int(len(self.planar.unreached)),
                "metrics": self.plan_metrics,
                "stats": self.planar.stats,
                "provenance": self.planar.provenance.to_dict(),
            },
            "map": {"stats": self.surface_path.stats, "provenance": self.surface_path.provenance.to_dict()},
            "smooth": {
                "stats": self.tool_path.stats,
                "samples": int(len(self.tool_path.samples)),
                "period_ms": self.tool_path.period_ms,
                "provenance": self.tool_path.provenance.to_dict(),
            },
            "dwell_time_note": (
                "Each dwell point's time is scaled by the surface area it stands for "
                "(dwell_weight, mean 1, from the map's local area ratio), so a uniform "
                "removal on the part stays uniform where the planar grid is denser or sparser."
            ),
            "timings_s": self.timings,
        }
        if self.schedule:
            s["schedule"] = self.schedule
        if self.program:
            s["post"] = self.program
            s["machining_time_s"] = self.program.get("machining_time_s")
        if self.figuring is not None:
            from .dwell import figuring_summary

            s["figuring"] = figuring_summary(self.figuring, self.figuring_prediction)
            s["dwell_time_note"] = ("Dwell times solved from the measured error map and the TIF (docs/figuring.md); "
                                    "summary.figuring holds the predicted residual of the machine-timed path.")
        return jsonable(s)

    def save(self, out_dir: str | Path, *, report: bool | None = None) -> dict[str, Path]:
        """Write every output into ``out_dir``, whole or not at all.

        The files are written into a staging folder beside ``out_dir`` and renamed
        into place at the end (:func:`polishpath.fileio.staged_folder`): a
        previous run in ``out_dir`` is replaced whole (no stale file stays), a
        folder of other files is refused, and an interrupted or failed write
        leaves ``out_dir`` as it was.

        Returns
        -------
        dict of str -> Path
            What was written: ``program`` (the post's file), ``path_csv``, ``toolpath_xyz``,
            ``gcode`` (G-code posts), ``flat_obj``, the run-folder files ``arrays``, ``summary``, ``job``
            (:func:`polishpath.runfolder.write_run`), and ``report`` when made.

        Raises
        ------
        OutputLocationError
            ``out_dir`` is a file, a folder of other files, not writable, or on a
            disk without room for the run (estimated).
        ExportError
            The disk filled up while writing (nothing is left).
        """
        from . import export
        from .fileio import staged_folder
        from .flatten import save_obj
        from .runfolder import estimate_run_bytes, is_run_folder, write_run

        target = Path(out_dir)
        with_report = report if report is not None else self.config.report
        need = estimate_run_bytes(self.planar.n_points, len(self.tool_path.samples), self.surface.n_vertices,
                                  self.surface.n_faces, report=with_report)
        written: dict[str, Path] = {}
        header = self.gcode_header()
        with staged_folder(target, is_run_folder, need_bytes=need, kind="polishpath run folder") as out:
            with progress.stage("writing machine files", self.timings, "write"):
                cfg = self.config
                info = export.write_program(self.tool_path, out, post=post_name(cfg), settings=cfg.post_settings,
                                            mode=cfg.gcode, tool_radius=cfg.tool_radius, header=header,
                                            surface=self.surface)
                if info.get("path"):  # the summary names the file where it will be, not in the staging folder
                    info["path"] = str(target / Path(info["path"]).relative_to(out))
                self.program.clear()  # the record of what the post wrote fills as the files are written (like timings)
                self.program.update(info)
                written["program"] = out / Path(self.program["path"]).relative_to(target)
                n_samples = len(self.tool_path.samples)

                def done(k: int, name: str) -> None:  # name: what was just written (for a reader of the code)
                    progress.update(k, 5, f"outputs of {n_samples:,} samples")

                done(1, self.program["file"])
                if self.program["file"] != "path.csv":
                    export.write_path_csv(self.tool_path, out / "path.csv")
                written["path_csv"] = out / "path.csv"
                done(2, "path.csv")
                if self.program["file"] != "toolpath.xyz":
                    export.write_xyz(self.tool_path, out / "toolpath.xyz")
                written["toolpath_xyz"] = out / "toolpath.xyz"
                done(3, "toolpath.xyz")
                if self.program["file"] == "toolpath.nc":
                    written["gcode"] = out / "toolpath.nc"
                with atomic_open(out / "flat.obj", "w") as fh:
                    save_obj(self.flattening, fh)
                written["flat_obj"] = out / "flat.obj"
                done(4, "flat.obj")
                written.update(write_run(out, surface=self.surface, flattening=self.flattening, region=self.region,
                                         planar=self.planar, surface_path=self.surface_path,
                                         tool_path=self.tool_path, summary=self.summary(),
                                         config=self._job_config_with_seed().to_dict(),
                                         extra_arrays=self._figuring_arrays()))
                done(5, "run.npz, summary.json, job.toml")
            if with_report:
                from .report import write_report
                from .report.figures import FIGURES

                with progress.stage("writing report", self.timings, "report"):
                    written.update(write_report(out, shown_as=target))
                    progress.update(len(FIGURES), len(FIGURES), "figures")  # it counts those begun
        return {k: target / Path(v).relative_to(out) for k, v in written.items()}

    def _figuring_arrays(self) -> dict[str, Any]:
        """The figuring maps for ``run.npz`` (runfolder.FIGURING_ARRAY_KEYS); empty without figuring."""
        if self.figuring is None:
            return {}
        t, pr = self.figuring.target, self.figuring_prediction
        g = t.grid
        return {"figuring_error_nm": t.error_nm, "figuring_inside": t.inside, "figuring_target_nm": t.removal_nm,
                "figuring_weight": t.weight, "figuring_removal_nm": pr["removal_nm"],
                "figuring_ideal_removal_nm": self.figuring.ideal_removal_nm, "figuring_residual_nm": pr["residual_nm"],
                "figuring_grid": np.array([g.origin_mm[0], g.origin_mm[1], g.pitch_mm]),
                "figuring_times_s": self.figuring.times_s, "figuring_t_min_s": self.figuring.solution.t_min_s}

    def _job_config_with_seed(self) -> JobConfig:
        return dataclasses.replace(self.config, seed=self.seed)

    def gcode_header(self) -> dict[str, Any]:
        return {
            "polishpath": __version__,
            "surface": self.surface.source or self.surface.name,
            "method": self.flattening.provenance.method,
            "pattern": self.planar.pattern,
            "spacing_mm": self.config.spacing,
            "planar_spacing_mm": round(self.planar_spacing, 6),
            "seed": self.seed,
            "dwell_points": self.planar.n_points,
            **{k: v for k, v in self.config.to_dict().items()
               if k not in ("surface", "seed", "post_settings") and v is not None},
        }


@dataclass(frozen=True)
class SurfacePlan:
    """A path planned in the plane and carried onto the part (:func:`plan_on_surface`).

    Attributes
    ----------
    planar : PlanarPath
        Dwell points in the plane, ``uv`` (N, 2) mm, in path order.
    surface_path : SurfacePath
        The same points on the part, ``xyz`` (N, 3) mm; with ``spacing_on="surface"``
        its ``stats`` also hold ``planar_spacing``, ``step_reduction_factor``,
        ``replans`` and ``grid_step_max`` (mm).
    planar_spacing : float
        The planar grid spacing used, mm (the spacing itself with ``spacing_on="plane"``).
    """

    planar: PlanarPath
    surface_path: SurfacePath
    planar_spacing: float


def plan_on_surface(
    flat: Flattening,
    region: Region,
    spacing: float,
    *,
    pattern: str = "pseudorandom",
    seed: int | None,
    spacing_on: str = "surface",
    start: tuple[float, float] | None = None,
    margin: float | None = 0.0,
    max_points: int = 5_000_000,
    max_oversampling: float = 16.0,
) -> SurfacePlan:
    """Plan a path on a flattened part and map it back: the one place plan and map are wired.

    Parameters
    ----------
    flat : Flattening
        The flattening of the part (``flat.uv`` (V, 2) mm).
    region : Region
        Where to plan, in the plane of ``flat`` (usually ``boundary_region(flat)``), mm.
    spacing : float
        Dwell-point spacing, mm: on the part with ``spacing_on="surface"``, in the
        plane with ``"plane"``.
    pattern : str
        A pattern of :data:`polishpath.plan.PATTERNS`.
    seed : int or None
        Seed of the pattern's random choices (None only for patterns without any).
    spacing_on : {"surface", "plane"}
        ``surface``: the planar spacing is reduced (re-planning up to 7 times)
        until no grid step on the part exceeds sqrt(2) x ``spacing``; ``plane``:
        one plain planar grid of ``spacing``.
    start : (u, v) or None
        Planar start point, mm; None: the dwell point nearest the region's centre.
    margin : float or None
        Keep dwell points at least this far inside the boundary (in the plane), mm;
        None: :data:`AUTO_MARGIN_FACTOR` x the planar spacing (of each re-plan).
    max_points : int
        Refuse to plan more dwell points than this.
    max_oversampling : float
        Refuse when honouring the spacing on the part needs more than this many
        times the dwell points of a uniform grid on the part (area / spacing^2).

    Returns
    -------
    SurfacePlan

    Raises
    ------
    ParameterError
        ``spacing_on`` unknown or ``spacing`` not a positive number.
    PlanningError
        The plan would need more dwell points than ``max_points`` / ``max_oversampling`` allow.
    SpacingTooLargeError
        Fewer than two dwell points fit (the message gives the region's size).
    MappingError
        A pattern other than the pseudo-random walk placed points outside the part.
    """
    from .mapping import map_to_surface
    from .plan import plan

    if spacing_on not in ("surface", "plane"):
        raise ParameterError(f"spacing_on must be 'surface' or 'plane', got {spacing_on!r}.")
    if not (isinstance(spacing, (int, float)) and math.isfinite(spacing) and spacing > 0):
        raise ParameterError(f"spacing must be a positive number of mm, got {spacing!r}.")
    surface = flat.surface
    surface_area = float(flat.metrics.get("area_3d") or region.area)

    def planner(planar_spacing: float) -> PlanarPath:
        estimate = region.area / planar_spacing**2
        uniform = surface_area / spacing**2
        if estimate > max_points or estimate > max_oversampling * uniform:
            raise PlanningError(
                f"keeping steps under sqrt(2) x {spacing:g} mm on the part needs a planar spacing of "
                f"{planar_spacing:.3g} mm, about {estimate:.3g} dwell points where a uniform grid on the part "
                f"would have {uniform:.3g}: the {flat.provenance.method} flattening of {surface.name} stretches "
                f"part of it {spacing / planar_spacing:.3g} times (mean |log area ratio| "
                f"{flat.metrics.get('area_distortion_mean', float('nan')):.3g}).",
                "Use --spacing-on plane (plain planar grid: larger steps where it stretches), or cut the part into "
                "less closed patches; raise --max-oversampling / --max-points to go on anyway.",
            )
        m = AUTO_MARGIN_FACTOR * planar_spacing if margin is None else margin
        return plan(region, planar_spacing, pattern, seed=seed, start=start, margin=m)

    try:
        if spacing_on == "surface":
            planar, spath, planar_spacing = _honour_surface_spacing(flat, spacing, planner)
        else:
            planar_spacing = spacing
            planar = planner(planar_spacing)
            spath = map_to_surface(flat, planar)
    except MappingError as exc:
        if pattern == "pseudorandom":
            raise
        raise MappingError(
            f"the {pattern} pattern places dwell points outside the part: {exc.message}",
            f"That is how the {pattern} path is built (see docs/peer-paths.md); it cannot be run on this part. "
            "Compare it with benchmarks/table3.py, or choose another --pattern.",
        ) from None
    except SpacingTooLargeError as exc:
        x0, y0, x1, y1 = region.bounds
        raise SpacingTooLargeError(
            f"spacing {spacing:g} mm is too large for {surface.name} "
            f"(its flattened region is {x1 - x0:.4g} x {y1 - y0:.4g} mm): {exc.message}",
            resources.units_hint(surface) or "Use a smaller --spacing (at most about half the part's width).",
        ) from None
    return SurfacePlan(planar, spath, float(planar_spacing))


def _grid_step_max(planar: PlanarPath, mapped: SurfacePath) -> float:
    """Largest 3D step between consecutive dwell points that are grid neighbours, mm.

    Moves that are not grid steps (a raster's connecting chord along the
    boundary, the jump between pieces) are transit moves of the pattern, not
    dwell steps, so they do not set the spacing. Off-grid patterns (spiral):
    every step within a piece counts.
    """
    d = np.linalg.norm(np.diff(mapped.xyz, axis=0), axis=1)
    if len(d) == 0:
        return 0.0
    valid = step_mask(len(mapped.xyz), planar.pieces)
    if planar.stats.get("on_grid", True):
        valid &= np.abs(np.diff(planar.ij, axis=0)).max(axis=1) <= 1
    return float(d[valid].max()) if valid.any() else 0.0


def _honour_surface_spacing(
    flat: Flattening,
    spacing: float,
    planner: Callable[[float], PlanarPath],
    *,
    max_step_factor: float = SQRT2,
    start_quantile: float = 0.99,
    max_iter: int = 6,
) -> tuple[PlanarPath, SurfacePath, float]:
    """Plan and map so that no 3D grid step exceeds ``max_step_factor x spacing``.

    The paper's "step reduction factor" found on the actual path. Starts from
    the planar spacing given by an area-weighted quantile of the map's stretch
    (:func:`polishpath.mapping.planar_spacing_for_surface`), maps the planned
    path and measures its largest 3D grid step, then rescales the planar spacing
    by ``limit / largest step`` (up or down: a pattern that makes few diagonal
    steps may allow a larger spacing) and re-plans, keeping the largest spacing
    whose path fits. It stops when a fitting path's largest step is within 2 %
    of the limit, or after ``max_iter`` plans; if none fitted it falls back to
    the strict bound (quantile 1), which holds for every 8-neighbour step inside
    the mesh.

    Parameters
    ----------
    flat : Flattening
    spacing : float
        Wanted spacing on the part, mm.
    planner : callable
        ``planner(planar_spacing_mm) -> PlanarPath``.
    max_step_factor : float
        Allowed largest 3D step / spacing.
    start_quantile : float
        Quantile of the stretch used for the first try.
    max_iter : int
        Most plans before the strict fallback.

    Returns
    -------
    planar : PlanarPath
    mapped : SurfacePath
        ``stats`` also hold ``planar_spacing``, ``step_reduction_factor``
        (planar / surface spacing), ``replans`` (plans made) and ``grid_step_max`` (mm).
    h : float
        The planar spacing used, mm.
    """
    from .mapping import map_to_surface, planar_spacing_for_surface

    limit = max_step_factor * spacing
    h = planar_spacing_for_surface(flat, spacing, max_step_factor, quantile=start_quantile)
    best = None
    tries = 0
    for _ in range(max(1, max_iter)):
        planar = planner(h)
        mapped = map_to_surface(flat, planar, surface_spacing=spacing)
        tries += 1
        progress.update(planar.n_points, None, f"dwell points in plan {tries}")
        m = _grid_step_max(planar, mapped)
        fits = m <= limit * (1 + 1e-9)
        if fits and (best is None or h > best[2]):
            best = (planar, mapped, h)
        ratio = limit / m if m > 0 else 2.0
        if fits and ratio < 1.02:
            break
        h_next = h * min(ratio, 2.0) * 0.999
        if best is not None and h_next <= best[2] * 1.0001:
            break
        h = h_next
    if best is None:
        h = planar_spacing_for_surface(flat, spacing, max_step_factor, quantile=1.0)
        planar = planner(h)
        best = (planar, map_to_surface(flat, planar, surface_spacing=spacing), h)
        tries += 1
    planar, mapped, h = best
    mapped.stats.update(planar_spacing=float(h), step_reduction_factor=float(h / spacing), replans=tries,
                        grid_step_max=_grid_step_max(planar, mapped))
    return planar, mapped, float(h)


def run(config: JobConfig | None = None, **options: Any) -> Job:
    """Run the whole job.

    Parameters
    ----------
    config : JobConfig, optional
        All options; keyword ``options`` (the :class:`~polishpath.config.JobConfig`
        field names) override its fields, or build one from the defaults.

    Returns
    -------
    Job
        Every stage's result; ``job.save(dir)`` writes the outputs.

    Examples
    --------
    >>> job = run(surface="hemisphere:triangles=5000", spacing=1.0, seed=7)  # doctest: +SKIP
    >>> job.save("out")  # doctest: +SKIP
    """
    from .flatten import boundary_region, flatten
    from .plan import path_metrics
    from .defaults import DEFAULT_FEED_MM_MIN, DEFAULT_PERIOD_MS
    from .smooth import smooth
    from .surfaces import load_surface
    from .surfaces.remesh import conformal_warning, fit_for_flattening

    cfg = parse_job(base=config, **options)
    cfg = dataclasses.replace(cfg, seed=resolve_seed(cfg.seed))
    machine = check_machine_output(cfg)
    if (cfg.tif or cfg.error_map_options or cfg.error_units) and not cfg.error_map:
        raise ParameterError("--tif, --error-units and [error_map] options need --error-map (the measured error to remove).")
    if cfg.error_map and cfg.dwell_times:
        raise ParameterError("give --error-map (times solved from the error) or --dwell-times (times given), not both.")
    timings: dict[str, float] = {}

    with progress.stage("reading surface", timings, "surface"):
        surface = load_surface(cfg.surface, units=cfg.units, scale=cfg.scale, component=cfg.component)
    resources.check_job(surface, cfg.spacing, feed_mm_min=cfg.feed_mm_min or DEFAULT_FEED_MM_MIN,
                        period_ms=cfg.period_ms or DEFAULT_PERIOD_MS, max_points=cfg.max_points)
    with progress.stage(f"flattening ({cfg.method})", timings, "flatten"):
        surface = fit_for_flattening(surface, cfg.remesh)
        flat = flatten(surface, cfg.method)
        region = boundary_region(flat)
    if warning := conformal_warning(surface, flat.metrics):
        progress.warn(warning)
    smooth_kw = {k: getattr(cfg, k) for k in ("feed_mm_min", "period_ms", "chord_tol_mm") if getattr(cfg, k) is not None}
    smooth_kw["integrator"] = cfg.integrator
    if machine is not None:
        smooth_kw.setdefault("period_ms", machine.period_ms)
    margin = cfg.margin  # None: automatic, widened below until the machine path stays on the part
    for replan in range(BOUNDARY_REPLANS + 1):
        with progress.stage(f"planning {cfg.pattern} path", timings, "plan"):
            sp = plan_on_surface(flat, region, cfg.spacing, pattern=cfg.pattern, seed=cfg.seed,
                                 spacing_on=cfg.spacing_on, start=cfg.start, margin=margin,
                                 max_points=cfg.max_points, max_oversampling=cfg.max_oversampling)
        planar, spath = sp.planar, sp.surface_path
        if cfg.dwell_times:
            from .export import read_dwell_times

            smooth_kw["dwell_times"] = read_dwell_times(cfg.dwell_times, n_points=planar.n_points)
        fig = None
        if cfg.error_map:
            with progress.stage("figuring: dwell times from the error map", timings, "dwell"):
                fig, max_feed = figure_for_job(cfg, surface, spath, smooth_kw=smooth_kw)
            smooth_kw["dwell_times"] = fig.times_s
            smooth_kw["max_feed_mm_min"] = max_feed
        with progress.stage("smoothing (NURBS) and interpolation", timings, "smooth"):
            tool = smooth(spath, surface=surface, **smooth_kw)
        used = float(planar.provenance.params.get("margin", 0.0))
        excursion = float(tool.stats.get("boundary_excursion_max_mm") or 0.0)
        if cfg.margin is not None or excursion <= cfg.boundary_tol_mm:
            break
        if replan == BOUNDARY_REPLANS:
            raise PlanningError(
                f"the machine path still leaves {surface.name} by {excursion:.3g} mm over its boundary with a "
                f"margin of {used:.3g} mm ({replan} re-plans with a wider margin), more than --boundary-tol "
                f"{cfg.boundary_tol_mm:g} mm.",
                "Give a wider --margin (mm, in the plane), a smaller --spacing, or a larger --boundary-tol.")
        # widen by the excursion, carried into the plane conservatively (the plane may be larger than the part)
        margin = used + 1.5 * excursion * max(1.0, sp.planar_spacing / cfg.spacing)
    boundary = dict(boundary_margin_mm=used, boundary_tol_mm=float(cfg.boundary_tol_mm),
                    boundary_margin_auto=cfg.margin is None, boundary_replans=replan)
    tool.stats.update(boundary)
    with progress.stage("path metrics", timings, "metrics"):
        pm = path_metrics(planar, region)
    prediction = None
    sched: dict[str, Any] = {}
    sample_s = None  # the time each sample stands for: one period, unless a machine's schedule slows it
    if machine is not None:
        from .schedule import schedule_feeds

        planned_feed = tool.feed_mm_min
        with progress.stage(f"feed schedule under {machine.name}", timings, "schedule"):
            tool, sched = schedule_feeds(tool, machine)
        sample_s = tool.period_ms / 1000.0 * planned_feed / np.maximum(tool.feed_mm_min, 1e-300)
    if fig is not None:  # the residual of what the machine runs: the final (scheduled) samples
        from .dwell import predict_residual, region_times

        with progress.stage("figuring: residual of the machine-timed path", timings, "dwell_residual"):
            prediction = predict_residual(fig, tool.samples, tool.period_ms, sample_s=sample_s,
                                          delivered_s=region_times(tool, sample_s))
    return Job(cfg, surface, flat, region, planar, spath, tool, sp.planar_spacing, timings, pm, schedule=sched,
               figuring=fig, figuring_prediction=prediction)


def machine_profile(cfg: JobConfig):
    """The :class:`~polishpath.schedule.MachineProfile` of ``cfg.machine`` (None without one)."""
    if cfg.machine is None:
        return None
    from .schedule import load_machine

    return load_machine(cfg.machine)


def post_name(cfg: JobConfig) -> str:
    """``cfg.post``, else the machine profile's post, else ``linuxcnc``."""
    if cfg.post is not None:
        return cfg.post
    m = machine_profile(cfg)
    return m.post if m is not None else "linuxcnc"


def check_machine_output(cfg: JobConfig):
    """Refuse, before any work, what the post or the machine cannot take; returns the machine profile (or None)."""
    from .export import get_post

    machine = machine_profile(cfg)
    post = get_post(post_name(cfg), cfg.post_settings)
    post.check(mode=cfg.gcode, tool_radius=cfg.tool_radius)
    if machine is not None and post.filename != "toolpath.nc":
        raise ParameterError(
            f"The {post.name} post cannot carry a machine profile's feed schedule: {post.filename} has no feeds "
            "(the xyz file runs at a constant period, path.csv holds dwell times).",
            "Use a G-code post (--post linuxcnc or fanuc) with --machine, or leave --machine out.")
    return machine


def build_tif(spec: str | None):
    """The figuring TIF of a ``--tif`` spec; the rotating tool comes from the simulation's model."""
    from .dwell import parse_tif_spec, tif_from_spec
    from .simulate import rotating_tool_tif

    if spec is None:
        return rotating_tool_tif()
    kind, p = parse_tif_spec(spec)
    if kind != "rotating":
        return tif_from_spec(spec)
    kw = {"rpm": p.get("rpm"), "contact_radius_mm": p.get("radius"), "peak_rate_nm_s": p.get("peak_rate"),
          "pressure": p.get("pressure"), "feed_mm_min": p.get("feed")}
    return rotating_tool_tif(**{k: v for k, v in kw.items() if v is not None})


def figure_for_job(cfg: JobConfig, surface: Surface, spath: SurfacePath, smooth_kw: dict[str, Any] | None = None):
    """Solve the job's dwell times from its error map (the dwell stage, wired); returns (Figuring, max feed).

    Each point's least time is what a run of the smoothed path at the maximum feed spends in its region (the
    curve's turns slow it below that feed), so every solved time is one the machine can run.
    """
    from .dwell import DEFAULT_SMOOTHNESS, Alignment, figure_dwell_times, read_error_map, region_times
    from .smooth import smooth

    o = dict(cfg.error_map_options or {})
    emap = read_error_map(cfg.error_map, height_unit=cfg.error_units, lateral_unit=o.get("lateral_unit"),
                          dx_mm=o.get("dx_mm"))
    feed = cfg.feed_mm_min or DEFAULT_FEED_MM_MIN
    machine = machine_profile(cfg)
    # the machine's feed limit: [error_map] max_feed_mm_min, else the profile's, else the smoothing stage's default
    default_max = min(5.0 * feed, machine.max_feed_mm_min) if machine is not None else 5.0 * feed
    max_feed = float(o.get("max_feed_mm_min", default_max))
    kw = {k: v for k, v in (smooth_kw or {}).items() if k not in ("dwell_times", "feed_mm_min", "max_feed_mm_min")}
    fastest = smooth(spath, **kw, feed_mm_min=max_feed, max_feed_mm_min=max_feed)
    fig = figure_dwell_times(
        surface, spath, emap, build_tif(cfg.tif), max_feed_mm_min=max_feed, alignment=Alignment.from_dict(o),
        bias_nm=o.get("bias_nm", "auto"), method=o.get("method", "auto"), smoothness=float(o.get("smoothness", DEFAULT_SMOOTHNESS)),
        extension_weight=float(o.get("extension_weight", 0.2)), max_uncovered=float(o.get("max_uncovered", 0.02)),
        ca_margin_mm=float(o.get("ca_margin_mm", 0.0)),
        period_ms=cfg.period_ms or (machine.period_ms if machine is not None else DEFAULT_PERIOD_MS),
        chord_tol_mm=cfg.chord_tol_mm or DEFAULT_CHORD_TOL_MM, t_min_s=region_times(fastest))
    return fig, max_feed


def rebuild_report(out_dir: str | Path) -> dict[str, Path]:
    """Rebuild ``report.html`` and the PNGs of a finished run from its files, whole or not at all.

    The run's other files are copied into a staging folder, the report written
    there, and the folder renamed into place (:func:`polishpath.fileio.staged_folder`).
    """
    from .fileio import staged_folder
    from .report import write_report
    from .runfolder import is_run_folder, read_run

    target = Path(out_dir)
    read_run(target)  # refuses what is not a run folder, with its message
    with staged_folder(target, is_run_folder, keep=lambda name: name not in ("report.html", "figures"),
                       need_bytes=_folder_bytes(target) + 12 * 2**20, kind="polishpath run folder") as out:
        written = write_report(out, shown_as=target)
    return {k: target / Path(v).relative_to(out) for k, v in written.items()}


def _folder_bytes(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())
