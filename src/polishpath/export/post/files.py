"""The two posts that are plain files: ``xyz`` (the paper's machine file) and ``csv`` (path.csv)."""

from __future__ import annotations

from typing import Any, ClassVar

from ...types import ToolPath
from ..files import write_path_csv, write_xyz
from .base import PostProcessor, planned_segment_times


class XyzPost(PostProcessor):
    """``X Y Z`` per line at the constant interpolation period (the file the paper's 3-axis machine reads)."""

    name: ClassVar[str] = "xyz"
    description: ClassVar[str] = ("the paper's file: X Y Z of the tool-part contact point per line at the "
                                  "constant period (toolpath.xyz)")
    filename: ClassVar[str] = "toolpath.xyz"

    def write(self, tool_path: ToolPath, file, *, mode: str | None = None, tool_radius: float = 0.0,
              header: dict | None = None, surface=None) -> dict[str, Any]:
        self.check(mode=mode, tool_radius=tool_radius)
        write_xyz(tool_path, file)
        t = float(planned_segment_times(tool_path).sum())
        return {"post": self.name, "file": self.filename, "mode": "linear", "feed_mode": "constant period",
                "coordinates": "contact point", "tool_radius_mm": 0.0, "period_ms": tool_path.period_ms,
                "path_time_s": t, "machining_time_s": t, "motion_blocks": int(len(tool_path.samples))}


class CsvPost(PostProcessor):
    """One row per dwell point with its time (``path.csv``), for a controller that schedules dwell itself."""

    name: ClassVar[str] = "csv"
    description: ClassVar[str] = "path.csv: one row per dwell point (position, normal, dwell time in s)"
    filename: ClassVar[str] = "path.csv"

    def write(self, tool_path: ToolPath, file, *, mode: str | None = None, tool_radius: float = 0.0,
              header: dict | None = None, surface=None) -> dict[str, Any]:
        self.check(mode=mode, tool_radius=tool_radius)
        write_path_csv(tool_path, file)
        t = float(tool_path.dwell_times.sum()) if tool_path.dwell_times is not None else None
        return {"post": self.name, "file": self.filename, "mode": "dwell points", "feed_mode": "dwell times",
                "coordinates": "contact point", "tool_radius_mm": 0.0, "path_time_s": t, "machining_time_s": t,
                "motion_blocks": int(len(tool_path.surface_path.xyz))}
