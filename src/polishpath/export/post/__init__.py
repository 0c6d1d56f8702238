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

__all__ = ["POSTS", "DEFAULT_POST", "get_post", "write_program", "post_help", "PostProcessor", "GcodePost",
           "PostSettings", "LinuxCNCPost", "FanucPost", "XyzPost", "CsvPost", "offset_along_normals",
           "planned_segment_times"]

POSTS: dict[str, type[PostProcessor]] = {p.name: p for p in (LinuxCNCPost, FanucPost, XyzPost, CsvPost)}
DEFAULT_POST = "linuxcnc"


def get_post(name: str = DEFAULT_POST, settings: PostSettings | dict[str, Any] | None = None) -> PostProcessor:
    """The post-processor registered as ``name``, with ``settings`` over its defaults."""
    cls = POSTS.get(name)
    if cls is None:
        raise ParameterError(f"Unknown post-processor {name!r}.", f"Use one of: {', '.join(POSTS)}.")
    return cls(settings)


def post_help() -> str:
    """One line per post, for ``--help``."""
    return "; ".join(f"{n}: {c.description}" for n, c in POSTS.items())


def write_program(tool_path: ToolPath, out_dir: str | Path, *, post: str = DEFAULT_POST,
                  settings: dict[str, Any] | None = None, mode: str | None = None, tool_radius: float = 0.0,
                  header: dict | None = None, surface: Surface | None = None,
                  chunks: Iterable[SampleChunk] | None = None, xyz: bool = False) -> dict[str, Any]:
    """Write the post's file into ``out_dir`` (atomically); returns what it wrote (see :meth:`PostProcessor.write`).

    ``surface``: the part's mesh, for the gouge check of a tool radius (``info["warnings"]``).
    ``chunks``: the machine samples as an iterable of :class:`~polishpath.export.chunks.SampleChunk`
    (a streamed job: ``tool_path``'s own sample arrays are then not read), consumed once.
    ``xyz``: also write ``toolpath.xyz`` in the same pass over the samples (``info["xyz_path"]``);
    the bytes are those of :func:`polishpath.export.write_xyz`.
    """
    p = get_post(post, settings)
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
