"""Post-processors: the file each controller runs, from one base (``base.py``) and one small class per controller.

========== ==================================================================
``--post``  writes
========== ==================================================================
linuxcnc   ``toolpath.nc``: LinuxCNC G-code (default), G01 moves, G64 blending,
           G93 inverse-time feed with a tool-radius offset
fanuc      ``toolpath.nc``: Fanuc 15i/30i-class G06.2 NURBS blocks (or G01)
xyz        ``toolpath.xyz``: the paper's constant-period X Y Z file
csv        ``path.csv``: dwell points with their times
========== ==================================================================

:func:`get_post` returns a post with its settings (:class:`PostSettings`, also
from a ``[post]`` table in job.toml); :func:`write_program` writes its file into
a run folder. See ``docs/machine-output.md``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Iterable

from ...errors import ParameterError
from ...types import Surface, ToolPath
from ..chunks import SampleChunk
from ..files import xyz_writer
from .base import GcodePost, PostProcessor, PostSettings, offset_along_normals, planned_segment_times
from .fanuc import FanucPost
from .files import CsvPost, XyzPost
from .linuxcnc import LinuxCNCPost
from .rapid import RapidPost
from .sinumerik import SinumerikPost

__all__ = ["POSTS", "DEFAULT_POST", "get_post", "write_program", "post_help", "job_post_settings", "PostProcessor",
           "GcodePost",
           "PostSettings", "LinuxCNCPost", "FanucPost", "XyzPost", "CsvPost", "offset_along_normals",
           "planned_segment_times"]

POSTS: dict[str, type[PostProcessor]] = {p.name: p for p in (LinuxCNCPost, FanucPost, XyzPost, CsvPost,
                                                              SinumerikPost, RapidPost)}
DEFAULT_POST = "linuxcnc"


def get_post(name: str = DEFAULT_POST, settings: PostSettings | dict[str, Any] | None = None,
             kinematics=None) -> PostProcessor:
    """The post-processor registered as ``name``, with ``settings`` over its defaults and the machine's
    ``kinematics`` (:class:`polishpath.schedule.Kinematics`, for a 5-axis post's words; None: none)."""
    cls = POSTS.get(name)
    if cls is None:
        raise ParameterError(f"Unknown post-processor {name!r}.", f"Use one of: {', '.join(POSTS)}.")
    return cls(settings, kinematics=kinematics)


#: job options (:class:`polishpath.config.JobConfig` fields, their flags) that set a post setting
JOB_POST_OPTIONS = {"segment_tol_mm": ("chord_tol_mm", "--segment-tol"),
                    "segment_time_tol": ("time_tol", "--segment-time-tol"), "arcs": ("arcs", "--arcs")}


def job_post_settings(cfg) -> dict[str, Any] | None:
    """The post settings of a job: its ``[post]`` table with the job's own G-code options over it.

    ``cfg`` is a :class:`polishpath.config.JobConfig` (checked: types and signs); an option left out
    (None) leaves the table's setting, or the post's default.
    """
    out = dict(cfg.post_settings or {})
    for opt, (setting, flag) in JOB_POST_OPTIONS.items():
        v = getattr(cfg, opt, None)
        if v is None:
            continue
        if opt == "segment_time_tol" and not 0 < v < 1:
            raise ParameterError(f"{opt} ({flag}) must be a fraction between 0 and 1, got {v!r}.",
                                 "E.g. 0.01: each dwell point's time within 1 % of its schedule.")
        out[setting] = v
    return out or None


def post_help() -> str:
    """One line per post, for ``--help``."""
    return "; ".join(f"{n}: {c.description}" for n, c in POSTS.items())


def write_program(tool_path: ToolPath, out_dir: str | Path, *, post: str = DEFAULT_POST,
                  settings: dict[str, Any] | None = None, mode: str | None = None, tool_radius: float = 0.0,
                  header: dict | None = None, surface: Surface | None = None,
                  chunks: Iterable[SampleChunk] | None = None, xyz: bool = False, kinematics=None) -> dict[str, Any]:
    """Write the post's file into ``out_dir`` (atomically); returns what it wrote (see :meth:`PostProcessor.write`).

    ``surface``: the part's mesh, for the gouge check of a tool radius (``info["warnings"]``).
    ``chunks``: the machine samples as an iterable of :class:`~polishpath.export.chunks.SampleChunk`
    (a streamed job: ``tool_path``'s own sample arrays are then not read), consumed once.
    ``xyz``: also write ``toolpath.xyz`` in the same pass over the samples (``info["xyz_path"]``);
    the bytes are those of :func:`polishpath.export.write_xyz`. ``kinematics``: the machine's, for a
    5-axis post (:func:`get_post`).
    """
    p = get_post(post, settings, kinematics=kinematics)
    out = Path(out_dir)
    if xyz and p.filename != "toolpath.xyz":
        with xyz_writer(out / "toolpath.xyz") as add:
            info = p.write(tool_path, out / p.filename, mode=mode, tool_radius=tool_radius, header=header,
                           surface=surface, chunks=chunks, also=(add,))
        info["xyz_path"] = str(out / "toolpath.xyz")
    else:
        info = p.write(tool_path, out / p.filename, mode=mode, tool_radius=tool_radius, header=header,
                       surface=surface, chunks=chunks)
        if xyz:
            info["xyz_path"] = str(out / p.filename)
    info["path"] = str(out / p.filename)
    return info
