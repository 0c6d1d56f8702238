"""ABB RAPID (IRC5 / OmniCore robots): one module of ``MoveL`` instructions with quaternion targets and speeddata.

Why ABB RAPID rather than KUKA KRL: a RAPID target's orientation is a quaternion,
which has no singular orientation, where KRL's A B C (ZYX Euler angles) lose one
angle when the tool frame's x axis points along the part's Z (B = +-90 degrees:
on the hemisphere's rim with the tool along the normal, A and C then jump while
the tool barely turns); and RAPID's speeddata carries the tool point's speed and
the reorientation speed in the instruction, so a block keeps its planned time
whether it moves or mostly turns the tool (KRL's $VEL.CP is the path speed
alone, the orientation speeds being separate system variables).

The module (``toolpath.mod``), after ABB's Technical reference manual RAPID
Instructions, Functions and Data types (MoveL, MoveJ, robtarget, orient,
speeddata, zonedata, ConfL, SingArea)::

    MODULE polishpath
      ! header: generator, parameters, the tool point, the tool frame
      CONST zonedata zPolish := [FALSE, tol, tol, tol, ori, tol, ori];
      PROC main()
        ConfL\\Off;                    the robot picks its configuration along linear moves
        SingArea\\Wrist;               wrist singularities passed by a small reorientation
        per piece: MoveJ above the approach point, MoveL down to it (rapid_speed, fine), onto the path,
                   MoveL [[x,y,z],[q1,q2,q3,q4],[0,0,0,0],[9E9,...]], [v_tcp,v_ori,v_leax,v_reax], zPolish,
                         tool\\WObj:=wobj; ...  back up the tool axis, up to the clearance height
      ENDPROC
    ENDMODULE

Positions are the tool point (the TCP of ``tool``) in the work object ``wobj``,
mm; both are the cell's own (calibrated) data, named by the settings. The tool
frame's z axis points from the spindle into the part (the robot convention, the
opposite of the tool axis), and its rotation about that axis is chosen as the
shortest rotation taking the part's Z to the tool axis applied to a tool frame
pointing straight down (x along the part's X): a function of the axis alone, so
it is continuous wherever the axis is (no flip between blocks, no drift along a
long path) and the same whenever the tool axis comes back; it is undefined only for
a tool axis pointing straight down, and axes more than :data:`MAX_TILT_DEG` from
the part's Z are refused. In quaternions ``(q1, q2, q3, q4) = (ay / 2c, c, 0,
-ax / 2c)`` with ``c = sqrt((1 + az) / 2)``: q2 > 0 throughout, so consecutive
targets never change sign either.

Times: a linear move's time is the longest of ``length / v_tcp`` and ``angle /
v_ori`` (the controller slows the other motions so they finish together); each
block writes ``v_tcp`` = its length over its planned time and ``v_ori`` = its
rotation angle over the same time (both rounded to ``feed_resolution``), so the
move takes its planned time whichever limits it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ...errors import ParameterError
from ..textfmt import KEEP_POINT, NO_TRAILING_ZEROS, fixed_text
from .blocks import round_feeds
from .oriented import OrientedPost, fixed_columns, unit_rows

__all__ = ["RapidPost", "RapidSettings", "tool_quaternions", "quaternion_angles_deg", "MAX_TILT_DEG"]

#: the largest angle of the tool axis from the part's Z the robot post writes (its tool frame turns about
#: the axis by at most tan(angle / 2) times the axis' own turn: 1.7x at 120 degrees)
MAX_TILT_DEG = 120.0
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,31}$")


def tool_quaternions(axes: np.ndarray) -> np.ndarray:
    """RAPID ``orient`` quaternions (k, 4) ``(q1, q2, q3, q4)`` (scalar first) of the tool frames of unit tool
    ``axes`` (k, 3) (tool tip to spindle): frame z = -axis, frame = shortest rotation from Z to the axis applied
    to (x, -y, -z). Unit quaternions, q2 > 0 (no sign changes between neighbouring axes)."""
    a = unit_rows(axes)
    c = np.sqrt(np.maximum(0.5 * (1.0 + a[:, 2]), 1e-300))
    return np.column_stack([a[:, 1] / (2 * c), c, np.zeros(len(a)), -a[:, 0] / (2 * c)])


def quaternion_angles_deg(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """Rotation angle, degrees, from orientation ``q0`` (k, 4) to ``q1`` (k, 4) (unit quaternions up to sign):
    ``4 atan2(|q1 - q0|, |q1 + q0|)`` with the sign giving the shorter way (exact for small angles)."""
    q0, q1 = np.asarray(q0, float), np.asarray(q1, float)
    q0 = q0 / np.linalg.norm(q0, axis=1, keepdims=True)
    q1 = q1 / np.linalg.norm(q1, axis=1, keepdims=True)
    q1 = np.where(np.einsum("ij,ij->i", q0, q1)[:, None] < 0, -q1, q1)
    return np.degrees(4 * np.arctan2(np.linalg.norm(q1 - q0, axis=1), np.linalg.norm(q1 + q0, axis=1)))


@dataclass(frozen=True)
class RapidSettings:
    """The RAPID post's own settings (in the same ``[post]`` table).

    Attributes
    ----------
    tool : str
        The ``tooldata`` whose TCP is the tool point (the cell's calibrated tool), default ``tPolish``.
    wobj : str
        The ``wobjdata`` of the part's frame (the frame of the coordinates), default ``wobjPart``.
    module : str
        The module's name.
    rapid_speed : str
        The speeddata of the moves at the clearance height (``MoveJ``), default ``v200``.
    zone_ori_deg : float
        The zonedata's reorientation zone, degrees (its path zones are the chord tolerance).
    leax_mm_s, reax_deg_s : float
        The speeddata's external-axis speeds (not limiting), mm/s and degrees/s.
    io_on, io_off : str
        Instructions that start and stop the tool (spindle, slurry), e.g. ``SetDO doSpindle, 1;``; empty: none.
    """

    tool: str = "tPolish"
    wobj: str = "wobjPart"
    module: str = "polishpath"
    rapid_speed: str = "v200"
    zone_ori_deg: float = 0.01
    leax_mm_s: float = 5000.0
    reax_deg_s: float = 1000.0
    io_on: str = ""
    io_off: str = ""

    def check(self, where: str) -> None:
        for name in ("tool", "wobj", "module", "rapid_speed"):
            v = getattr(self, name)
            if not isinstance(v, str) or not _NAME.match(v):
                raise ParameterError(f"{where}: {name} must be a RAPID name (a letter, then letters, digits or _; "
                                     f"at most 32), got {v!r}.", f"E.g. {name} = {getattr(RapidSettings, name)!r}.")
        for name in ("zone_ori_deg", "leax_mm_s", "reax_deg_s"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ParameterError(f"{where}: {name} must be a number > 0, got {v!r}.")
        for name in ("io_on", "io_off"):
            v = getattr(self, name)
            if not isinstance(v, str) or any(not 32 <= ord(ch) < 127 for ch in v.replace("\n", " ")):
                raise ParameterError(f"{where}: {name} must be RAPID text (printable ASCII), got {v!r}.")


class RapidPost(OrientedPost):
    name: ClassVar[str] = "abb"
    description: ClassVar[str] = ("ABB RAPID robots (IRC5/OmniCore): MoveL with quaternion targets and speeddata "
                                  "per block keeping its time (toolpath.mod)")
    filename: ClassVar[str] = "toolpath.mod"
    inverse_time: ClassVar[bool] = False
    label: ClassVar[str] = "for ABB ROBOTS [RAPID, IRC5/OmniCore]; not a G-code file"
    comment_mark: ClassVar[str] = "!"
    #: the G-code settings a RAPID module has no place for (left at these values)
    no_gcode: ClassVar[dict[str, Any]] = {"preamble": "", "safety_block": "", "blending": "", "spindle_rpm": 0.0,
                                          "coolant_on": "", "postamble": "", "program_number": None, "arcs": False}
    defaults: ClassVar[dict[str, Any]] = {**no_gcode, "leading_zero": True,  # RAPID: 0.5, not .5
                                          "orientation_decimals": 6}
    own_settings: ClassVar[type] = RapidSettings

    def __init__(self, settings=None, kinematics=None):
        super().__init__(settings, kinematics=kinematics)
        for k, v in self.no_gcode.items():
            if getattr(self.settings, k) != v:
                raise ParameterError(f"[post] for {self.name}: {k} is a G-code setting; a RAPID module has no "
                                     f"place for it (got {getattr(self.settings, k)!r}).",
                                     "Leave it out; start and stop the tool with io_on / io_off.")
        if self.settings.feed_mode == "inverse-time":
            raise ParameterError(f"[post] for {self.name}: a robot has no inverse-time feed; each MoveL's speeddata "
                                 "keeps its block's time.", "Leave feed_mode out.")

    def feed_mode(self, tool_radius: float, rotary: bool = False) -> str:
        return "speeddata"

    def orientation_lines(self, three_axis: bool) -> list[str]:
        out = ["ORIENTATION: quaternion [q1 scalar] of the tool frame in the work object; the frame's z axis points "
               "from the spindle into the part [minus the tool axis]; its rotation about z is the shortest rotation "
               "taking the part's Z to the tool axis applied to a frame pointing straight down with x along the "
               "part's X: continuous, no flips",
               "SPEED: each MoveL's v_tcp = its length / its planned time and v_ori = its rotation / the same time: "
               "the move takes its planned time whichever limits it",
               f"TOOL: {self.own.tool}, WORK OBJECT: {self.own.wobj} [the cell's calibrated data]"]
        if three_axis:
            out.append("3-AXIS JOB: the tool axis is vertical throughout [q = 0 1 0 0]")
        return out

    def comment(self, text: str) -> str:
        return "  " + super().comment(text)

    def preface(self) -> list[str]:
        return [f"MODULE {self.own.module}"]

    def _zone(self) -> str:
        return "zPolish"

    def opening(self, tool_path, ctx: dict) -> list[str]:
        o = self.own
        tol = fixed_text(ctx["segment_tol_mm"], 6, NO_TRAILING_ZEROS)
        ori = fixed_text(o.zone_ori_deg, 6, NO_TRAILING_ZEROS)
        lines = [f"  CONST zonedata {self._zone()} := [FALSE, {tol}, {tol}, {tol}, {ori}, {tol}, {ori}];",
                 "  PROC main()", "    ConfL\\Off;", "    SingArea\\Wrist;"]
        lines += ["    " + ln for ln in o.io_on.splitlines() if ln.strip()]
        return lines

    def closing(self, ctx: dict) -> list[str]:
        return ["    " + ln for ln in self.own.io_off.splitlines() if ln.strip()] + ["  ENDPROC", "ENDMODULE"]

    def check_axes(self, A: np.ndarray) -> None:
        bad = np.flatnonzero(A[:, 2] < math.cos(math.radians(MAX_TILT_DEG)) - 1e-12)
        if len(bad):
            raise ParameterError(f"The abb post cannot write a tool axis {MAX_TILT_DEG:g} degrees or more from the "
                                 f"part's Z (got {A[bad[0]].round(4).tolist()}): the tool frame about it is "
                                 "undefined for a tool pointing straight down the part.",
                                 "Turn the part (its Z towards the tool) or use a tool-axis law nearer the Z.")

    # ---------------------------------------------------------------- the rotary-words hook: quaternions
    def orientation_letters(self) -> tuple[str, ...]:
        return ("q1", "q2", "q3", "q4")

    def orientation_coords(self, axes: np.ndarray, previous: np.ndarray | None) -> np.ndarray:
        a = unit_rows(axes)
        self.check_axes(a)
        return tool_quaternions(a)  # a function of the axis: continuous, q2 > 0 (no sign to carry over)

    def axes_from_coords(self, coords: np.ndarray) -> np.ndarray:
        q = np.asarray(coords, dtype=np.float64)
        w, x, y, z = (q / np.maximum(np.linalg.norm(q, axis=1, keepdims=True), 1e-300)).T
        # minus the z column of the rotation: the frame's z points from the spindle into the part
        return -np.column_stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])

    # ---------------------------------------------------------------- the lines
    def _target(self, point, coords) -> str:
        p = ",".join(self.f(v) for v in point)
        return f"[[{p}],[{','.join(self.fo(v) for v in coords)}],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]"

    def _tail(self) -> str:
        return f"{self.own.tool}\\WObj:={self.own.wobj};"

    def _speed(self, v_tcp: str, v_ori: str) -> str:
        o = self.own
        return f"[{v_tcp},{v_ori},{fixed_text(o.leax_mm_s, 3, NO_TRAILING_ZEROS)}," \
               f"{fixed_text(o.reax_deg_s, 3, NO_TRAILING_ZEROS)}]"

    def rapid(self, point, coords, near_part=False) -> str:
        move = "MoveL" if near_part else "MoveJ"  # straight down to the approach point
        return f"    {move} {self._target(point, coords)}, {self.own.rapid_speed}, fine, {self._tail()}"

    def feed_move(self, point, coords, feed_mm_min, path_follows) -> str:
        v = self.ff(feed_mm_min / 60.0)
        return f"    MoveL {self._target(point, coords)}, {self._speed(v, self.ff(100.0))}, fine, {self._tail()}"

    def path_blocks(self, prev, W, R, dt, state) -> tuple[str, float]:
        s = self.settings
        length = np.linalg.norm(W - prev, axis=1)
        angle = quaternion_angles_deg(np.vstack([state["coords"][None, :], R[:-1]]), R)
        dt = np.maximum(dt, 1e-12)
        # a zero length (or angle) leaves the other to set the time: its speed is any positive number
        v_tcp = round_feeds(np.where(length > 0, length / dt, 1e-3), s.feed_decimals, s.feed_resolution)
        v_ori = round_feeds(np.where(angle > 0, angle / dt, 1e-3), s.feed_decimals, s.feed_resolution)
        secs = float(np.sum(np.maximum(length / v_tcp, angle / v_ori)))
        fd = 9 if s.feed_decimals is None else s.feed_decimals
        fstyle = (self.styles() & ~KEEP_POINT) | (NO_TRAILING_ZEROS if s.feed_decimals is None else 0)
        pos = fixed_columns(W, s.decimals, self.styles())
        qs = fixed_columns(R, s.orientation_decimals, self.styles())
        vt, vo = (fixed_columns(v[:, None], fd, fstyle)[0] for v in (v_tcp, v_ori))
        tail = f"{self._zone()}, {self._tail()}"
        lines = [f"    MoveL [[{pos[0][i]},{pos[1][i]},{pos[2][i]}],[{qs[0][i]},{qs[1][i]},{qs[2][i]},{qs[3][i]}],"
                 f"[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], {self._speed(vt[i], vo[i])}, {tail}" for i in range(len(W))]
        return "\n".join(lines) + "\n", secs
