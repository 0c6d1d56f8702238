"""The job's result and its outputs: :class:`Job` (every stage's result) and :meth:`Job.save`.

Part of the one wiring place (the :mod:`polishpath.pipeline` package): ``run`` in
``pipeline/__init__.py`` makes a Job, :meth:`Job.save` writes it (machine files,
run folder, report), :func:`rebuild_report` rewrites a finished run's report.
"""

from __future__ import annotations

import dataclasses
import datetime
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from .. import progress
from .._version import __version__
from ..config import JobConfig
from ..fileio import atomic_open, jsonable
from ..provenance import machine_info
from ..types import Flattening, PlanarPath, Region, SampleChunk, Surface, SurfacePath, ToolPath


#: samples per chunk when the job streams them (the smoothing passes, the writers' pass); None: the
#: stages' own defaults (a quarter of a million samples, about 10 MB). Tests set it small.
CHUNK_SAMPLES: int | None = None


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
    samples_mode: dict[str, Any] = field(default_factory=dict)  # held or streamed, and why (pipeline.choose_samples_mode)

    @property
    def seed(self) -> int | None:
        return self.planar.provenance.seed

    def summary(self) -> dict[str, Any]:
        """Every figure of the run, JSON-ready (what ``summary.json`` holds)."""
        from ..surfaces import describe_surface

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
                "samples": self.n_samples,
                "samples_mode": self.samples_mode.get("mode", "memory"),
                "samples_mode_reason": self.samples_mode.get("reason"),
                "expected_samples": self.samples_mode.get("expected_samples"),
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
            from ..dwell import figuring_summary

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
        from .. import export
        from ..fileio import staged_folder
        from ..flatten import save_obj
        from ..report.digest import SampleDigest
        from ..runfolder import estimate_run_bytes, is_run_folder, write_run

        target = Path(out_dir)
        with_report = report if report is not None else self.config.report
        n_samples = self.n_samples
        need = estimate_run_bytes(self.planar.n_points, n_samples, self.surface.n_vertices,
                                  self.surface.n_faces, report=with_report)
        written: dict[str, Path] = {}
        header = self.gcode_header()
        with staged_folder(target, is_run_folder, need_bytes=need, kind="polishpath run folder") as out:
            with progress.stage("writing machine files", self.timings, "write"):
                cfg = self.config
                # ONE pass over the samples (held, or regenerated chunk by chunk): the post's file, toolpath.xyz
                # and the report's digest of them (run.npz) all take the same chunks
                digest = SampleDigest(n_samples)

                def counted(chunks):  # the pass's progress: samples written so far
                    for c in chunks:
                        yield c
                        progress.update(digest.done, n_samples, "samples written")

                info = export.write_program(self.tool_path, out, post=post_name(cfg),
                                            settings=export.job_post_settings(cfg), mode=cfg.gcode,
                                            tool_radius=cfg.tool_radius, header=header, surface=self.surface,
                                            xyz=True, chunks=counted(digest.observe(self.sample_chunks())),
                                            kinematics=machine_kinematics(cfg))
                info.pop("xyz_path", None)
                if info.get("path"):  # the summary names the file where it will be, not in the staging folder
                    info["path"] = str(target / Path(info["path"]).relative_to(out))
                self.program.clear()  # the record of what the post wrote fills as the files are written (like timings)
                self.program.update(info)
                written["program"] = out / Path(self.program["path"]).relative_to(target)
                written["toolpath_xyz"] = out / "toolpath.xyz"
                if self.program["file"] == "toolpath.nc":
                    written["gcode"] = out / "toolpath.nc"

                def done(k: int, name: str) -> None:  # name: what was just written (for a reader of the code)
                    progress.update(k, 4, f"outputs of {n_samples:,} samples")

                done(1, f"{self.program['file']}, toolpath.xyz")
                if self.program["file"] != "path.csv":
                    export.write_path_csv(self.tool_path, out / "path.csv")
                written["path_csv"] = out / "path.csv"
                done(2, "path.csv")
                with atomic_open(out / "flat.obj", "w") as fh:
                    save_obj(self.flattening, fh)
                written["flat_obj"] = out / "flat.obj"
                done(3, "flat.obj")
                written.update(write_run(out, surface=self.surface, flattening=self.flattening, region=self.region,
                                         planar=self.planar, surface_path=self.surface_path,
                                         tool_path=self.tool_path, summary=self.summary(),
                                         config=self._job_config_with_seed().to_dict(),
                                         extra_arrays={**digest.arrays(), **self._figuring_arrays()}))
                done(4, "run.npz, summary.json, job.toml")
            if with_report:
                from ..report import write_report
                from ..report.figures import FIGURES

                with progress.stage("writing report", self.timings, "report"):
                    written.update(write_report(out, shown_as=target))
                    progress.update(len(FIGURES), len(FIGURES), "figures")  # it counts those begun
        return {k: target / Path(v).relative_to(out) for k, v in written.items()}

    @property
    def n_samples(self) -> int:
        """Machine samples of the path (held in ``tool_path.samples``, or counted by the smoothing stage when streamed)."""
        m = len(self.tool_path.samples)
        return m if m else int(self.tool_path.stats.get("n_samples", 0))

    def sample_chunks(self, size: int | None = None) -> Iterator[SampleChunk]:
        """The machine samples in path order as :class:`~polishpath.types.SampleChunk` s: cut from the held
        arrays, or regenerated from the curve and its schedule when the job streamed them."""
        size = CHUNK_SAMPLES if size is None else size
        kw = {} if size is None else {"size": size}
        if len(self.tool_path.samples) or self.n_samples == 0:
            from ..export import sample_chunks

            return sample_chunks(self.tool_path, **kw)
        from ..smooth import iter_sample_chunks

        return iter_sample_chunks(self.tool_path, **kw)

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
               if k not in ("surface", "seed", "post_settings", "samples") and v is not None  # samples: how, not what
               and not (k == "tool_axis" and v == "z")},  # a 3-axis job's header as before the tool-axis laws
        }



def machine_profile(cfg: JobConfig):
    """The :class:`~polishpath.schedule.MachineProfile` of ``cfg.machine`` (None without one)."""
    if cfg.machine is None:
        return None
    from ..schedule import load_machine

    return load_machine(cfg.machine)


def machine_kinematics(cfg: JobConfig):
    """The 5-axis kinematics of ``cfg.machine`` (:class:`~polishpath.schedule.Kinematics`; None: none)."""
    m = machine_profile(cfg)
    return m.kinematics if m is not None else None


def post_name(cfg: JobConfig) -> str:
    """``cfg.post``, else the machine profile's post, else ``linuxcnc``."""
    if cfg.post is not None:
        return cfg.post
    m = machine_profile(cfg)
    return m.post if m is not None else "linuxcnc"



def rebuild_report(out_dir: str | Path) -> dict[str, Path]:
    """Rebuild ``report.html`` and the PNGs of a finished run from its files, whole or not at all.

    The run's other files are copied into a staging folder, the report written
    there, and the folder renamed into place (:func:`polishpath.fileio.staged_folder`).
    """
    from ..fileio import staged_folder
    from ..report import write_report
    from ..runfolder import is_run_folder, read_run

    target = Path(out_dir)
    read_run(target)  # refuses what is not a run folder, with its message
    with staged_folder(target, is_run_folder, keep=lambda name: name not in ("report.html", "figures"),
                       need_bytes=_folder_bytes(target) + 12 * 2**20, kind="polishpath run folder") as out:
        written = write_report(out, shown_as=target)
    return {k: target / Path(v).relative_to(out) for k, v in written.items()}


def _folder_bytes(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())
