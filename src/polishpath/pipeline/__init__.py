"""The main job: surface -> flatten -> plan -> map -> smooth -> export: the one place stages are wired.

:func:`plan_on_surface` wires plan and map (with the step-reduction loop that
honours the spacing on the part); the job, the paper reproduction, the
simulation's pattern comparison and the benchmarks call it. :func:`run` takes
a :class:`~polishpath.config.JobConfig` (every option of ``polishpath plan``,
see :mod:`polishpath.config`) and returns a :class:`Job` holding each stage's
result; :meth:`Job.save` writes the machine files, the run-folder files
(:mod:`polishpath.runfolder`) and the report into a folder.

The package: ``job.py`` (:class:`Job`, :meth:`Job.save`, :func:`rebuild_report`),
``surfaceplan.py`` (:func:`plan_on_surface`), and here :func:`run`, the job's
stages in order, with the checks a user meets before any work.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from .. import progress, resources
from ..axes import with_tool_axes
from ..config import JobConfig, parse_job
from ..defaults import (DEFAULT_CHORD_TOL_MM, DEFAULT_FEED_MM_MIN, DEFAULT_PERIOD_MS, FIGURING_EXTENSION_WEIGHT, FIGURING_REGION_TOL,
                        FIGURING_SCHEDULE_PASSES, FIGURING_TMIN_HEADROOM, FIGURING_TURN_HEADROOM, MAX_FEED_FACTOR)
from ..errors import ParameterError, PlanningError
from ..provenance import resolve_seed
from ..types import Surface, SurfacePath
from . import job as _job
from .job import Job, machine_profile, post_name, rebuild_report
from .surfaceplan import AUTO_MARGIN_FACTOR, SurfacePlan, plan_on_surface
from .surfaceplan import _honour_surface_spacing  # noqa: F401  (tests/test_pipeline_wiring.py)

__all__ = ["run", "Job", "JobConfig", "SurfacePlan", "plan_on_surface", "rebuild_report", "check_machine_output",
           "figure_for_job", "least_times", "build_tif", "machine_profile", "post_name", "choose_samples_mode", "samples_held_for",
           "AUTO_MARGIN_FACTOR", "BOUNDARY_REPLANS"]

#: re-plans with a wider margin when the machine path still leaves the part by more than the tolerance
BOUNDARY_REPLANS = 3


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
    from ..flatten import boundary_region, flatten
    from ..plan import path_metrics
    from ..defaults import DEFAULT_FEED_MM_MIN, DEFAULT_PERIOD_MS
    from ..smooth import smooth
    from ..surfaces import load_surface
    from ..surfaces.remesh import conformal_warning, fit_for_flattening

    cfg = parse_job(base=config, **options)
    cfg = dataclasses.replace(cfg, seed=resolve_seed(cfg.seed))
    machine = check_machine_output(cfg)
    if (cfg.tif or cfg.error_map_options or cfg.error_units) and not cfg.error_map:
        raise ParameterError("--tif, --error-units and [error_map] options need --error-map (the measured error to remove).")
    if cfg.error_map and cfg.dwell_times:
        raise ParameterError("give --error-map (times solved from the error) or --dwell-times (times given), not both.")
    held_for = samples_held_for(cfg, machine)
    if cfg.samples == "stream" and held_for:
        raise ParameterError(f"--samples stream cannot be used here: {held_for}.",
                             "Use --samples memory (or auto, the default), or leave that option out.")
    timings: dict[str, float] = {}

    with progress.stage("reading surface", timings, "surface"):
        surface = load_surface(cfg.surface, units=cfg.units, scale=cfg.scale, component=cfg.component)
    est = resources.check_job(surface, cfg.spacing, feed_mm_min=cfg.feed_mm_min or DEFAULT_FEED_MM_MIN,
                              period_ms=cfg.period_ms or DEFAULT_PERIOD_MS, max_points=cfg.max_points,
                              samples="memory" if held_for else cfg.samples)
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
    samples_mode: dict[str, Any] = {}
    for replan in range(BOUNDARY_REPLANS + 1):
        with progress.stage(f"planning {cfg.pattern} path", timings, "plan"):
            sp = plan_on_surface(flat, region, cfg.spacing, pattern=cfg.pattern, seed=cfg.seed,
                                 dwell_points=cfg.dwell_points, spacing_on=cfg.spacing_on, start=cfg.start, margin=margin,
                                 max_points=cfg.max_points, max_oversampling=cfg.max_oversampling)
        planar, spath = sp.planar, with_tool_axes(sp.surface_path, cfg.tool_axis)
        check_reach(machine, spath)
        if cfg.dwell_times:
            from ..export import read_dwell_times

            smooth_kw["dwell_times"] = read_dwell_times(cfg.dwell_times, n_points=planar.n_points)
        fig = None
        if cfg.error_map:
            with progress.stage("figuring: dwell times from the error map", timings, "dwell"):
                fig, max_feed = figure_for_job(cfg, surface, spath, smooth_kw=smooth_kw)
            smooth_kw["dwell_times"] = fig.times_s
            smooth_kw["max_feed_mm_min"] = max_feed
            # every region's time delivered to the figuring's tolerance (docs/figuring.md, "Delivered by the path")
            smooth_kw["region_tol"] = FIGURING_REGION_TOL
            smooth_kw["schedule_passes"] = FIGURING_SCHEDULE_PASSES
        if not samples_mode:  # decided once, on the first plan (a re-plan with a wider margin is of the same size)
            samples_mode = choose_samples_mode(cfg, held_for, spath, smooth_kw, est)
            if samples_mode["mode"] == "stream":
                smooth_kw["keep_samples"] = False
                if _job.CHUNK_SAMPLES is not None:
                    smooth_kw["chunk_samples"] = _job.CHUNK_SAMPLES
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
    tool = dataclasses.replace(tool, stats={**tool.stats, **boundary})
    with progress.stage("path metrics", timings, "metrics"):
        pm = path_metrics(planar, region)
    prediction = None
    sched: dict[str, Any] = {}
    sample_s = None  # the time each sample stands for: one period, unless a machine's schedule slows it
    if machine is not None:
        from ..schedule import schedule_feeds

        planned_feed = tool.feed_mm_min
        with progress.stage(f"feed schedule under {machine.name}", timings, "schedule"):
            tool, sched = schedule_feeds(tool, machine)
        sample_s = tool.period_ms / 1000.0 * planned_feed / np.maximum(tool.feed_mm_min, 1e-300)
    if fig is not None:  # the residual of what the machine runs: the final (scheduled) samples
        from ..dwell import predict_residual, region_times

        with progress.stage("figuring: residual of the machine-timed path", timings, "dwell_residual"):
            prediction = predict_residual(fig, tool.samples, tool.period_ms, sample_s=sample_s,
                                          delivered_s=region_times(tool, sample_s))
        fig = _judge_figuring(cfg, fig, prediction)
    return Job(cfg, surface, flat, region, planar, spath, tool, sp.planar_spacing, timings, pm, schedule=sched,
               figuring=fig, figuring_prediction=prediction, samples_mode=samples_mode)


def _judge_figuring(cfg: JobConfig, fig, prediction: dict[str, Any]):
    """Refuse a figuring program predicted to leave the part worse (RMS or PV) unless ``cfg.force``; returns
    ``fig`` with the forced refusal recorded."""
    from ..dwell.verdict import refusal_for_prediction
    from ..errors import FiguringRefusedError

    st = fig.stats
    msg = refusal_for_prediction(fig.floor, st["initial_rms_nm"], st["initial_pv_nm"], prediction["residual_rms_nm"],
                                 prediction["residual_pv_nm"], uncorrectable_rms_nm=st["uncorrectable_rms_nm"],
                                 passband_per_mm=st["passband_cutoff_per_mm"], converged=fig.solution.converged,
                                 delivered_error_rms=prediction.get("delivered_time_error_rms"))
    if not msg:
        return fig
    if not cfg.force:
        raise FiguringRefusedError(msg, "Or give --force to write this program anyway.")
    progress.warn(msg + " Written anyway: --force.")
    fc = dataclasses.replace(fig.floor, forced=True, refusals=fig.floor.refusals + (msg,))
    return dataclasses.replace(fig, floor=fc)


def samples_held_for(cfg: JobConfig, machine) -> str:
    """Why this job must hold every machine sample in memory ('' when it need not)."""
    why = []
    if machine is not None:
        why.append(f"the feed schedule of --machine {cfg.machine} is a backward pass over every sample")
    if cfg.error_map:
        why.append("the figuring residual of --error-map is computed over every sample, and so are the least "
                   "times it solves with")
    return "; ".join(why)


def choose_samples_mode(cfg: JobConfig, held_for: str, spath: SurfacePath, smooth_kw: dict[str, Any],
                        est: resources.Estimate) -> dict[str, Any]:
    """``{"mode": "memory" | "stream", "requested": cfg.samples, "expected_samples", "reason"}`` for this path.

    ``--samples memory`` / ``stream`` as asked; ``auto`` streams when
    :func:`polishpath.resources.stream_samples` says so for the samples expected
    from the planned path (:func:`~polishpath.resources.expected_samples`), and
    holds them where ``held_for`` says the job needs them.
    """
    from ..pathops import step_lengths

    pieces = spath.planar.pieces if spath.planar is not None else None
    times = smooth_kw.get("dwell_times")
    expected = resources.expected_samples(
        float(step_lengths(spath.xyz, pieces).sum()), feed_mm_min=smooth_kw.get("feed_mm_min", DEFAULT_FEED_MM_MIN),
        period_ms=smooth_kw.get("period_ms", DEFAULT_PERIOD_MS),
        total_time_s=float(np.sum(times)) if times is not None else None)
    out = {"requested": cfg.samples, "expected_samples": float(expected)}
    if cfg.samples != "auto":
        return {**out, "mode": cfg.samples, "reason": f"--samples {cfg.samples} as asked"}
    if held_for:
        return {**out, "mode": "memory", "reason": f"held in memory: {held_for}"}
    stream, reason = resources.stream_samples(expected, est)
    return {**out, "mode": "stream" if stream else "memory", "reason": reason}



def check_machine_output(cfg: JobConfig):
    """Refuse, before any work, what the post or the machine cannot take; returns the machine profile (or None)."""
    from ..export import get_post, job_post_settings

    machine = machine_profile(cfg)
    post = get_post(post_name(cfg), job_post_settings(cfg), kinematics=machine.kinematics if machine else None)
    post.check(mode=cfg.gcode, tool_radius=cfg.tool_radius, tool_axes=cfg.tool_axis != "z")
    if machine is not None and post.filename in ("toolpath.xyz", "path.csv"):  # the files without feeds
        raise ParameterError(
            f"The {post.name} post cannot carry a machine profile's feed schedule: {post.filename} has no feeds "
            "(the xyz file runs at a constant period, path.csv holds dwell times).",
            "Use a post with timed blocks (--post linuxcnc, fanuc, sinumerik or abb) with --machine, or leave "
            "--machine out.")
    return machine


def check_reach(machine, spath: SurfacePath) -> None:
    """Refuse, before smoothing, a tool axis the machine's kinematics cannot reach at a dwell point
    (:class:`~polishpath.errors.ReachError` naming the dwell point and the limit)."""
    if machine is None or machine.kinematics is None or spath.tool_axes is None:
        return
    xyz = spath.xyz

    def where(i: int) -> str:
        return f"dwell point {i} at ({xyz[i, 0]:.3f}, {xyz[i, 1]:.3f}, {xyz[i, 2]:.3f}) mm"

    machine.kinematics.angles(spath.tool_axes, where=where)


def build_tif(spec: str | None):
    """The figuring TIF of a ``--tif`` spec; the rotating tool comes from the simulation's model."""
    from ..dwell import parse_tif_spec, tif_from_spec
    from ..simulate import rotating_tool_tif

    if spec is None:
        return rotating_tool_tif()
    kind, p = parse_tif_spec(spec)
    if kind != "rotating":
        return tif_from_spec(spec)
    kw = {"rpm": p.get("rpm"), "contact_radius_mm": p.get("radius"), "peak_rate_nm_s": p.get("peak_rate"),
          "pressure": p.get("pressure"), "feed_mm_min": p.get("feed")}
    return rotating_tool_tif(**{k: v for k, v in kw.items() if v is not None})


def least_times(spath: SurfacePath, fastest, max_feed: float, period_s: float) -> np.ndarray:
    """Each dwell point's least time, s (N,): what ``fastest`` (the smoothed path at the top feed) spends in its
    region, with the headroom of :data:`~polishpath.defaults.FIGURING_TMIN_HEADROOM` on the whole, of
    :data:`~polishpath.defaults.FIGURING_TURN_HEADROOM` on the part the path's turns add over the straight
    steps (where the chord tolerance slows the feed, the time depends on where the steps fall), and one period."""
    from ..dwell import minimum_times, region_times

    fast = region_times(fastest)
    pieces = spath.planar.pieces if spath.planar is not None else np.array([0, len(spath.xyz)])
    turn = np.maximum(fast - minimum_times(spath.xyz, pieces, max_feed), 0.0)
    return fast * (1.0 + FIGURING_TMIN_HEADROOM) + FIGURING_TURN_HEADROOM * turn + period_s


def figure_for_job(cfg: JobConfig, surface: Surface, spath: SurfacePath, smooth_kw: dict[str, Any] | None = None):
    """Solve the job's dwell times from its error map (the dwell stage, wired); returns (Figuring, max feed).

    Each point's least time is what a run of the smoothed path at the maximum feed spends in its region (the
    curve's turns slow it below that feed), so every solved time is one the machine can run.
    """
    from ..dwell import DEFAULT_SMOOTHNESS, Alignment, figure_dwell_times, read_error_map, region_times
    from ..smooth import smooth

    o = dict(cfg.error_map_options or {})
    emap = read_error_map(cfg.error_map, height_unit=cfg.error_units, lateral_unit=o.get("lateral_unit"),
                          dx_mm=o.get("dx_mm"))
    feed = cfg.feed_mm_min or DEFAULT_FEED_MM_MIN
    machine = machine_profile(cfg)
    # the machine's feed limit: [error_map] max_feed_mm_min, else the profile's, else the smoothing stage's default
    default_max = min(MAX_FEED_FACTOR * feed, machine.max_feed_mm_min) if machine is not None else MAX_FEED_FACTOR * feed
    max_feed = float(o.get("max_feed_mm_min", default_max))
    kw = {k: v for k, v in (smooth_kw or {}).items() if k not in ("dwell_times", "feed_mm_min", "max_feed_mm_min", "region_tol",
                                                                   "schedule_passes")}
    fastest = smooth(spath, **kw, feed_mm_min=max_feed, max_feed_mm_min=max_feed)
    period_s = (cfg.period_ms or (machine.period_ms if machine is not None else DEFAULT_PERIOD_MS)) / 1000.0
    fig = figure_dwell_times(
        surface, spath, emap, build_tif(cfg.tif), max_feed_mm_min=max_feed, alignment=Alignment.from_dict(o),
        bias_nm=o.get("bias_nm", "auto"), method=o.get("method", "auto"), smoothness=float(o.get("smoothness", DEFAULT_SMOOTHNESS)),
        extension_weight=float(o.get("extension_weight", FIGURING_EXTENSION_WEIGHT)), max_uncovered=float(o.get("max_uncovered", 0.02)),
        ca_margin_mm=float(o["ca_margin_mm"]) if "ca_margin_mm" in o else None,  # None: the dwell stage's default
        period_ms=period_s * 1000.0,
        chord_tol_mm=cfg.chord_tol_mm or DEFAULT_CHORD_TOL_MM, t_min_s=least_times(spath, fastest, max_feed, period_s), force=cfg.force)
    return fig, max_feed
