"""The two posts that are plain files: ``xyz`` (the paper's machine file) and ``csv`` (path.csv)."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from ...types import ToolPath
from ..chunks import checked_chunks, dwell_offsets, sample_chunks
from ..files import write_path_csv, write_xyz, xyz_writer
from .base import PostProcessor, planned_segment_times


class XyzPost(PostProcessor):
    """``X Y Z`` per line at the constant interpolation period (the file the paper's 3-axis machine reads)."""

    name: ClassVar[str] = "xyz"
    description: ClassVar[str] = ("the paper's file: X Y Z of the tool-part contact point per line at the "
                                  "constant period (toolpath.xyz)")
    filename: ClassVar[str] = "toolpath.xyz"

    def write(self, tool_path: ToolPath, file, *, mode: str | None = None, tool_radius: float = 0.0,
              header: dict | None = None, surface=None, chunks=None, also: tuple = ()) -> dict[str, Any]:
        self.check(mode=mode, tool_radius=tool_radius, tool_axes=tool_path.surface_path.tool_axes is not None)
        if chunks is None and not also:
            write_xyz(tool_path, file)
            t = float(planned_segment_times(tool_path).sum())
            n = len(tool_path.samples)
        else:
            t, n, prev = 0.0, 0, None
            with xyz_writer(file) as add:
                for starts, c in checked_chunks(chunks if chunks is not None else sample_chunks(tool_path),
                                                len(dwell_offsets(tool_path)) - 1):
                    add(c)
                    for sink in also:
                        sink(c)
                    # planned time of the moves arriving at the chunk's samples (none at a piece's first)
                    pts = c.samples if starts else np.vstack([prev[None, :], c.samples])
                    f = c.feed_mm_min[len(c) - (len(pts) - 1):]
                    t += float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1) * 60.0 / np.maximum(f, 1e-300)))
                    n, prev = n + len(c), c.samples[-1]
        return {"post": self.name, "file": self.filename, "mode": "linear", "feed_mode": "constant period",
                "coordinates": "contact point", "tool_radius_mm": 0.0, "period_ms": tool_path.period_ms,
                "path_time_s": t, "machining_time_s": t, "motion_blocks": int(n)}


class CsvPost(PostProcessor):
    """One row per dwell point with its time (``path.csv``), for a controller that schedules dwell itself."""

    name: ClassVar[str] = "csv"
    description: ClassVar[str] = ("path.csv: one row per dwell point (position, normal, dwell time in s; "
                                  "the tool axis with --tool-axis)")
    filename: ClassVar[str] = "path.csv"
    writes_axes: ClassVar[bool] = True  # a 5-axis path's path.csv has the axis_x, axis_y, axis_z columns

    def write(self, tool_path: ToolPath, file, *, mode: str | None = None, tool_radius: float = 0.0,
              header: dict | None = None, surface=None, chunks=None, also: tuple = ()) -> dict[str, Any]:
        self.check(mode=mode, tool_radius=tool_radius, tool_axes=tool_path.surface_path.tool_axes is not None)
        write_path_csv(tool_path, file)
        if also:  # the samples are not in path.csv; the other writers of the pass still get them
            for c in (chunks if chunks is not None else sample_chunks(tool_path)):
                for sink in also:
                    sink(c)
        t = float(tool_path.dwell_times.sum()) if tool_path.dwell_times is not None else None
        return {"post": self.name, "file": self.filename, "mode": "dwell points", "feed_mode": "dwell times",
                "coordinates": "contact point", "tool_radius_mm": 0.0, "path_time_s": t, "machining_time_s": t,
                "motion_blocks": int(len(tool_path.surface_path.xyz))}
