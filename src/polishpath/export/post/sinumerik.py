"""Siemens Sinumerik 840D sl: TRAORI, the tool orientation as A3/B3/C3 vectors, CYCLE832, G93 inverse-time feed.

The program (``toolpath.mpf``), each part after the Sinumerik 840D sl Programming
Manual Job Planning (section "Three, four and five axis transformation (TRAORI)":
orientation programming with direction vectors A3, B3, C3, ORIWKS, ORIVECT) and the
cycle's parameter list (CYCLE832, "High-speed settings")::

    ; header: generator, parameters, the tool point and the orientation mode
    G90 G71 G17 G94             absolute, metric, XY plane, feed per minute
    G40 G54                     no cutter compensation, work offset G54
    TRAORI                      5-axis transformation on: X Y Z are the tool point
    ORIWKS                      orientation in the workpiece frame
    ORIVECT                     the vector interpolated on the great circle between blocks
    CYCLE832(<tol>, 11, <ori tol>)   finishing (units 1) with an orientation tolerance (tens 1)
    M3 S230 / M8                spindle (sponge), slurry
    per piece: G0 above the approach point (oriented), G0 down to it, G94 G1 onto the path, G93,
               G1 X Y Z A3= B3= C3= F<1/min> ..., G94 G1 back up the tool axis, G0 up
    CYCLE832(0, 0, 1)           high-speed settings off
    TRAFOOF                     transformation off
    M5 M9 / M30

A3/B3/C3 are the tool's direction vector in the workpiece frame, pointing from the
tool tip towards the tool holder (the project's tool-axis convention); a block
that writes one of them sets the others to zero, so all three are written
whenever the orientation changes and none where it does not. Feed: G93 on every
path block, F = 1 / minutes of the block (rounded to ``feed_resolution``), so
each block keeps its planned time whatever the tool offset and the orientation
change; the approach and retract moves run at ``approach_feed_mm_min`` in G94.

With ``orientation = "angles"`` and a machine profile with kinematics
(``--machine xyzac-trt`` / ``xyzbc-trt``) the blocks carry the rotary axes'
positions instead (A C or B C, the kinematics' continuous branch; modal words),
interpolated linearly (``ORIAXES`` in place of ``ORIVECT``), TRAORI still on.
The blocks are the post base's 5-axis segmenting (every dwell point a block
end, the chord and orientation tolerances; :mod:`.oriented`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ...errors import ParameterError
from ..files import _fmt
from ..textfmt import KEEP_POINT, NO_TRAILING_ZEROS, fixed_text
from .blocks import round_feeds
from .oriented import OrientedPost, fixed_columns, unit_rows

__all__ = ["SinumerikPost", "SinumerikSettings"]


@dataclass(frozen=True)
class SinumerikSettings:
    """The Sinumerik post's own settings (in the same ``[post]`` table as :class:`~.base.PostSettings`).

    Attributes
    ----------
    orientation : {"vector", "angles"}
        ``vector`` (default): A3/B3/C3, the tool's direction vector (ORIVECT), for any 5-axis kinematics the
        control knows; ``angles``: the rotary axes' positions of the machine's kinematics (``--machine
        xyzac-trt`` / ``xyzbc-trt``: A and C, or B and C), interpolated linearly (ORIAXES).
    contour_tol_mm : float or None
        CYCLE832's contour tolerance, mm; None (default): the smoothing stage's chord tolerance (1 um by default,
        the tolerance LinuxCNC's ``G64 P`` gets). Its orientation tolerance is ``orientation_tol_deg``.
    cycle832_mode : int
        CYCLE832's machining type: units 1 finishing, 4 smooth finishing; tens 1 = the orientation tolerance is
        given (default 11).
    """

    orientation: str = "vector"
    contour_tol_mm: float | None = None
    cycle832_mode: int = 11

    def check(self, where: str) -> None:
        if self.orientation not in ("vector", "angles"):
            raise ParameterError(f"{where}: orientation must be 'vector' (A3/B3/C3) or 'angles' (the rotary axes of "
                                 f"the machine's kinematics), got {self.orientation!r}.")
        c = self.contour_tol_mm
        if c is not None and (isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c)
                              or not 0 < c <= 1):
            raise ParameterError(f"{where}: contour_tol_mm must be a tolerance in mm, 0 < tol <= 1 (or left out), "
                                 f"got {c!r}.", "E.g. contour_tol_mm = 0.001 (1 um).")
        m = self.cycle832_mode
        if isinstance(m, bool) or not isinstance(m, int) or m % 10 not in (1, 2, 3, 4) or m // 10 not in (0, 1):
            raise ParameterError(f"{where}: cycle832_mode must be CYCLE832's machining type 1-4 (finishing, "
                                 f"semi-finishing, roughing, smooth finishing), plus 10 with an orientation "
                                 f"tolerance, got {m!r}.", "E.g. cycle832_mode = 11 (finishing, orientation "
                                 "tolerance given).")


class SinumerikPost(OrientedPost):
    name: ClassVar[str] = "sinumerik"
    description: ClassVar[str] = ("Siemens Sinumerik 840D sl: TRAORI 5-axis transformation, tool orientation as "
                                  "A3/B3/C3 vectors (or rotary angles), CYCLE832, G93 inverse-time feed "
                                  "(toolpath.mpf)")
    filename: ClassVar[str] = "toolpath.mpf"
    inverse_time: ClassVar[bool] = True
    label: ClassVar[str] = ("for SIEMENS SINUMERIK 840D sl WITH 5-AXIS TRANSFORMATION TRAORI; "
                            "not for LinuxCNC or Fanuc")
    defaults: ClassVar[dict[str, Any]] = {"preamble": "G90 G71 G17", "safety_block": "G40 G54", "arcs": False,
                                          "word_separator": " ", "leading_zero": True, "orientation_decimals": 6}
    own_settings: ClassVar[type] = SinumerikSettings

    def __init__(self, settings=None, kinematics=None):
        super().__init__(settings, kinematics=kinematics)
        s = self.settings
        where = f"[post] for {self.name}"
        if s.arcs:
            raise ParameterError(f"{where}: arcs must be false: the post writes straight blocks (the orientation "
                                 "changes along them).", "Leave arcs out (or false).")
        if s.word_separator != " ":
            raise ParameterError(f"{where}: word_separator must be \" \": Sinumerik needs a blank after a word "
                                 "such as A3=0.5.", "Leave word_separator out.")
        if s.blending:
            raise ParameterError(f"{where}: blending must be empty: CYCLE832 sets the contour tolerance.",
                                 "Set contour_tol_mm instead.")
        if s.feed_mode == "per-minute":
            raise ParameterError("The sinumerik post writes G93 inverse-time feed only: with the orientation "
                                 "changing, a feed per minute of the tool point does not give each block its "
                                 "planned time.", "Leave feed_mode out (or 'auto' / 'inverse-time').")

    def check(self, *, mode=None, tool_radius=0.0, tool_axes=False) -> str:
        if self.own.orientation == "angles" and self.kinematics is None:
            raise ParameterError("The sinumerik post's orientation = 'angles' writes the rotary axes of the machine's "
                                 "kinematics, and no machine profile with kinematics was given.",
                                 "Add --machine xyzac-trt or --machine xyzbc-trt, or leave orientation at 'vector' "
                                 "(A3/B3/C3, for any kinematics the control knows).")
        return super().check(mode=mode, tool_radius=tool_radius, tool_axes=tool_axes)

    # ---------------------------------------------------------------- the rotary-words hook
    def angles(self) -> bool:
        return self.own.orientation == "angles"

    def orientation_letters(self) -> tuple[str, ...]:
        return tuple(self.kinematics.letters) if self.angles() else ("A3=", "B3=", "C3=")

    def orientation_coords(self, axes: np.ndarray, previous: np.ndarray | None) -> np.ndarray:
        return self.kinematics.angles(axes, previous) if self.angles() else unit_rows(axes)

    def axes_from_coords(self, coords: np.ndarray) -> np.ndarray:
        return self.kinematics.axes(coords) if self.angles() else unit_rows(coords)

    # ---------------------------------------------------------------- the lines
    def orientation_lines(self, three_axis: bool) -> list[str]:
        if self.angles():
            k = self.kinematics
            out = [f"ORIENTATION: {' '.join(k.letters)} = the rotary axes' positions of the machine's kinematics "
                   f"[{k.linuxcnc_module}], interpolated linearly [ORIAXES]; X Y Z: the tool point with TRAORI on"]
        else:
            out = ["ORIENTATION: A3 B3 C3 = the tool's direction vector in the workpiece frame [ORIWKS], from the "
                   "tool tip towards the tool holder, interpolated on the great circle [ORIVECT]; X Y Z: the tool "
                   "point with TRAORI on"]
        out.append("FEED: G93 inverse time on every path block, F = 1/minutes of the block: each block takes its "
                   "planned time; approach and retract in G94 mm/min")
        if three_axis:
            out.append("3-AXIS JOB: the tool axis is vertical throughout")
        return out

    def contour_tol(self, ctx: dict) -> float:
        return float(self.own.contour_tol_mm) if self.own.contour_tol_mm else float(ctx["chord_tol_mm"])

    def opening(self, tool_path, ctx: dict) -> list[str]:
        s, o = self.settings, self.own
        lines = [f"{s.preamble} G94".strip()]
        if s.safety_block:
            lines.append(s.safety_block)
        tol = fixed_text(self.contour_tol(ctx), 6, NO_TRAILING_ZEROS)
        otol = fixed_text(s.orientation_tol_deg, 6, NO_TRAILING_ZEROS)
        lines += ["TRAORI", "ORIWKS", "ORIAXES" if self.angles() else "ORIVECT",
                  f"CYCLE832({tol}, {o.cycle832_mode}, {otol})"]
        if s.spindle_rpm > 0:
            lines.append(f"M3 S{_fmt(s.spindle_rpm, 0)}")
        if s.coolant_on:
            lines.append(s.coolant_on)
        return lines

    def closing(self, ctx: dict) -> list[str]:
        return ["CYCLE832(0, 0, 1)", "TRAFOOF"] + self.settings.postamble.rstrip("\n").splitlines()

    def _words(self, coords: np.ndarray) -> list[str]:
        return [f"{n}{self.fo(v)}" for n, v in zip(self.orientation_letters(), coords)]

    def lift(self, safe_z: float) -> str:
        return self.words("G0", f"Z{self.f(safe_z)}")

    def rapid(self, point, coords, near_part=False) -> str:
        f = self.f
        return self.words("G0", f"X{f(point[0])}", f"Y{f(point[1])}", f"Z{f(point[2])}", *self._words(coords))

    def feed_move(self, point, coords, feed_mm_min, path_follows) -> str:
        f = self.f
        line = self.words("G94", "G1", f"X{f(point[0])}", f"Y{f(point[1])}", f"Z{f(point[2])}",
                          *self._words(coords), f"F{self.ff(feed_mm_min)}")
        return line + ("\nG93" if path_follows else "")

    def path_blocks(self, prev, W, R, dt, state) -> tuple[str, float]:
        s = self.settings
        feed = round_feeds(60.0 / np.maximum(dt, 1e-12), s.feed_decimals, s.feed_resolution)  # 1/min
        fstyle = (self.styles() & ~KEEP_POINT) | (NO_TRAILING_ZEROS if s.feed_decimals is None else 0)
        xyz = fixed_columns(W, s.decimals, self.styles())
        ori = fixed_columns(R, s.orientation_decimals, self.styles())
        fcol = fixed_columns(feed[:, None], 9 if s.feed_decimals is None else s.feed_decimals, fstyle)[0]
        moved = W != prev
        changed = R != np.vstack([state["coords"][None, :], R[:-1]])
        # A3/B3/C3: a component left out of a block that writes another is zero, so all three or none;
        # rotary axes are modal, each written where it changes
        turned = changed if self.angles() else np.repeat(changed.any(axis=1)[:, None], R.shape[1], axis=1)
        names = self.orientation_letters()
        lines = []
        for i in range(len(W)):
            words = [L + xyz[j][i] for j, L in enumerate("XYZ") if moved[i, j]]
            words += [names[j] + ori[j][i] for j in range(len(names)) if turned[i, j]]
            words.append("F" + fcol[i])
            lines.append(" ".join(words))
        return "\n".join(lines) + "\n", float(np.sum(60.0 / feed))
