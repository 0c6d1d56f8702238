"""LinuxCNC (2.8 / 2.9): G01 moves, G64 P<chord tol> blending, inverse-time feed with a tool offset; 5-axis A/C or B/C.

Checked by LinuxCNC's own interpreter ``rs274`` in ``tests/test_linuxcnc.py``
(3-axis) and ``tests/test_linuxcnc_5axis.py`` (5-axis). LinuxCNC cannot run the
G06.2 NURBS blocks (its G5.2 is XY-only, takes no knot vector and drops Z), so
this post refuses ``--gcode nurbs``.

5-axis (a path with tool axes, ``--tool-axis`` not ``z``, and a machine
profile with LinuxCNC trt kinematics, ``--machine xyzac-trt`` or
``xyzbc-trt``): the rotary-words hook of the post base writes A and C (or B
and C), the joint angles of the table (:mod:`polishpath.schedule.kinematics`,
the branch and turn chosen for continuity), on every G01 block beside the
tool point's X Y Z in the part's frame, with the machine in its
tool-centre-point kinematics (``xyzac-trt-kins`` / ``xyzbc-trt-kins``,
switchkins type 0, ``M428`` where the config remaps it), in inverse time
(G93). rs274 reads and prints them (six values per STRAIGHT_FEED).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from ...errors import ParameterError
from .base import GcodePost


class LinuxCNCPost(GcodePost):
    name: ClassVar[str] = "linuxcnc"
    description: ClassVar[str] = ("LinuxCNC 2.8/2.9 (default): G21 G90 G17, G64 P<chord tol>, G01 moves; "
                                  "G93 inverse-time feed with --tool-radius; 5-axis A/C or B/C with --tool-axis "
                                  "and --machine xyzac-trt / xyzbc-trt")
    modes: ClassVar[tuple[str, ...]] = ("linear",)
    inverse_time: ClassVar[bool] = True
    writes_axes: ClassVar[bool] = True
    label: ClassVar[str] = "for LinuxCNC 2.8/2.9 [checked with its rs274 interpreter]"
    defaults: ClassVar[dict[str, Any]] = {"blending": "G64 P{tol}"}

    def refuse_mode(self, mode: str) -> tuple[str, str]:
        return ("LinuxCNC cannot run G06.2 NURBS blocks: it stops at the first one (its own G5.2 is XY-only, "
                "takes no knot vector and would drop Z).",
                "Use --gcode linear for LinuxCNC, or --post fanuc --gcode nurbs for a Fanuc 15i/30i-class "
                "control with the NURBS interpolation option.")

    def check(self, *, mode: str | None = None, tool_radius: float = 0.0, tool_axes: bool = False) -> str:
        if tool_axes and self.kinematics is None:
            raise ParameterError(
                "The linuxcnc post writes a path with tool axes (--tool-axis other than z) as A/C or B/C angles of "
                "the machine's kinematics, and no machine profile with kinematics was given.",
                "Add --machine xyzac-trt or --machine xyzbc-trt (or a machine TOML with a [machine.kinematics] "
                "table), or use --tool-axis z.")
        return super().check(mode=mode, tool_radius=tool_radius, tool_axes=tool_axes)

    # ---------------------------------------------------------------- the rotary-words hook
    def orientation_letters(self) -> tuple[str, ...]:
        return self.kinematics.letters if self.kinematics is not None else ()

    def orientation_coords(self, axes: np.ndarray, previous: np.ndarray | None) -> np.ndarray:
        return self.kinematics.angles(axes, previous)

    def axes_from_coords(self, coords: np.ndarray) -> np.ndarray:
        return self.kinematics.axes(coords)

    def rotary_header(self, tool_path, tool_radius: float) -> list[str]:
        k = self.kinematics
        t = k.tilt_letter
        form = ("[sin A sin C, sin A cos C, cos A]" if t == "A" else "[-cos C sin B, sin C sin B, cos B]")
        return super().rotary_header(tool_path, tool_radius) + [
            f"KINEMATICS: LinuxCNC {k.linuxcnc_module} with the tool-centre-point kinematics on [switchkins type 0; "
            "M428 where remapped]: X Y Z are the tool point in the part's frame, the module moves the joints",
            f"ROTARY: {t} tilts the table [{t} range {k.tilt_range_deg[0]:g}..{k.tilt_range_deg[1]:g} deg], C turns it"
            + (" [continuous]" if k.c_range_deg is None else f" [{k.c_range_deg[0]:g}..{k.c_range_deg[1]:g} deg]")
            + f"; tool axis in the part frame = {form}",
            f"PIVOT: rot-point {list(k.rot_point_mm)} mm, offsets {list(k.offset_mm)} mm, tool-offset "
            f"{k.tool_offset_mm:g} mm [the module's pins; the joints, not this file, depend on them]"]
