"""LinuxCNC (2.8 / 2.9): G01 moves, G64 P<chord tol> blending, inverse-time feed with a tool offset.

Checked by LinuxCNC's own interpreter ``rs274`` in ``tests/test_linuxcnc.py``.
LinuxCNC cannot run the G06.2 NURBS blocks (its G5.2 is XY-only, takes no knot
vector and drops Z), so this post refuses ``--gcode nurbs``.
"""

from __future__ import annotations

from typing import Any, ClassVar

from .base import GcodePost


class LinuxCNCPost(GcodePost):
    name: ClassVar[str] = "linuxcnc"
    description: ClassVar[str] = ("LinuxCNC 2.8/2.9 (default): G21 G90 G17, G64 P<chord tol>, G01 moves; "
                                  "G93 inverse-time feed with --tool-radius")
    modes: ClassVar[tuple[str, ...]] = ("linear",)
    inverse_time: ClassVar[bool] = True
    label: ClassVar[str] = "for LinuxCNC 2.8/2.9 [checked with its rs274 interpreter]"
    defaults: ClassVar[dict[str, Any]] = {"blending": "G64 P{tol}"}

    def refuse_mode(self, mode: str) -> tuple[str, str]:
        return ("LinuxCNC cannot run G06.2 NURBS blocks: it stops at the first one (its own G5.2 is XY-only, "
                "takes no knot vector and would drop Z).",
                "Use --gcode linear for LinuxCNC, or --post fanuc --gcode nurbs for a Fanuc 15i/30i-class "
                "control with the NURBS interpolation option.")
