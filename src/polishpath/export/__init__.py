"""polishpath.export — files a machine (and a person) reads.

* ``path.csv``      :func:`write_path_csv` — one row per dwell point;
* ``toolpath.xyz``  :func:`write_xyz` — dense "X Y Z" samples in path order (the
  format the paper's 3-axis machine reads);
* ``toolpath.nc``   a post-processor's G-code (:mod:`polishpath.export.post`:
  ``linuxcnc`` by default, ``fanuc`` for G06.2 NURBS), :func:`write_gcode`;
* ``summary.json``  :func:`write_summary_json`.

A streamed job hands the machine samples to the writers as an iterable of
:class:`SampleChunk` (``write_program(..., chunks=..., xyz=True)`` writes the
post's file and ``toolpath.xyz`` in one pass; :func:`sample_chunks` cuts an
in-memory ToolPath the same way); the bytes do not depend on the chunks.

Every writer takes a path or an open text file. Given a path it writes to a
temporary file in the same folder and renames it into place, so an interrupted
run (Ctrl-C) never leaves a half-written file. :func:`read_xyz`,
:func:`read_path_csv` read the files back. See ``docs/machine-output.md``.
"""

from __future__ import annotations

from typing import Any

from ..errors import ParameterError
from ..types import Surface, ToolPath
from .chunks import SampleChunk, sample_chunks
from .files import (
    PATH_CSV_COLUMNS,
    read_dwell_times,
    read_path_csv,
    read_xyz,
    write_path_csv,
    write_summary_json,
    write_xyz,
    xyz_writer,
)
from .post import DEFAULT_POST, POSTS, PostSettings, get_post, job_post_settings, offset_along_normals, write_program

__all__ = [
    "write_path_csv",
    "read_path_csv",
    "write_xyz",
    "read_xyz",
    "write_gcode",
    "write_program",
    "write_summary_json",
    "offset_along_normals",
    "read_dwell_times",
    "get_post",
    "job_post_settings",
    "POSTS",
    "DEFAULT_POST",
    "PostSettings",
    "PATH_CSV_COLUMNS",
    "SampleChunk",
    "sample_chunks",
    "xyz_writer",
]


def write_gcode(tool_path: ToolPath, file, *, post: str = DEFAULT_POST, mode: str | None = None,
                tool_radius: float = 0.0, header: dict | None = None, surface: Surface | None = None,
                chunks=None, **settings: Any) -> dict[str, Any]:
    """G-code of a G-code post (``linuxcnc`` or ``fanuc``) into ``file`` (path or text file).

    Parameters
    ----------
    tool_path : ToolPath
    file : str, Path or text file
    post : {"linuxcnc", "fanuc"}
    mode : {"linear", "nurbs"}, optional
        Default: the post's (linuxcnc: linear; fanuc: nurbs).
    tool_radius : float
        Ball / sponge radius, mm: coordinates are the tool centre, the contact
        point moved this far along the surface normal (0: the contact point).
    header : dict, optional
        Everything to record in the header comment (surface, spacing, seed, parameters).
    surface : Surface, optional
        The part's mesh, for the gouge check of a tool radius (``warnings`` in the result).
    chunks : iterable of SampleChunk, optional
        The machine samples in chunks (a streamed job); default: the ToolPath's own.
    **settings
        :class:`PostSettings` fields (clearance_mm, spindle_rpm, feed_mode, segmenting, time_tol ...).

    Returns
    -------
    dict
        What was written: post, mode, feed mode, coordinates, ``machining_time_s`` ...
    """
    p = get_post(post, settings or None)
    if p.filename != "toolpath.nc":
        raise ParameterError(f"The {post} post writes {p.filename}, not G-code.", "Use post='linuxcnc' or 'fanuc'.")
    return p.write(tool_path, file, mode=mode, tool_radius=tool_radius, header=header, surface=surface, chunks=chunks)
