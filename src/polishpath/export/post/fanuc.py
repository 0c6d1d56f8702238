"""Fanuc 15i/30i-class controls with the NURBS interpolation option: G06.2 blocks (default) or G01.

A G06.2 block sequence, per the Fanuc format (one control point per block)::

    G06.2 P<rank> K<knot> X Y Z R<weight> F<feed>
    K<knot> X Y Z R<weight>          (one per further control point)
    K<knot>                          (rank more knots)

``P`` is the rank (order = degree + 1: 4 for the cubic), the number of knots is
the number of control points + rank, the first and last ``rank`` knots are
equal (clamped: the curve starts at the tool's position, the first control
point, and ends at the last), ``R`` is the weight (1: the curve is a B-spline).
The next G01/G00 ends the NURBS mode. Knots are written in mm of the control
polygon's length (the curve does not depend on the knot scale).

NURBS blocks carry one feed per piece: F is the piece's driven length over its
planned time, so each piece takes its planned time, but the dwell times within a
piece are not kept; ``--gcode linear`` keeps them block by block (G94, F rescaled).
The piece's blocks are written when its last samples have arrived (F needs them).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from ...types import NurbsCurve, ToolPath
from ..chunks import dwell_offsets
from ..files import _fmt
from .base import GcodePost, offset_along_normals


class NurbsMotion:
    """The G06.2 blocks of one piece: the piece's time and driven length summed over its chunks, written at the end."""

    def __init__(self, post: "FanucPost", curve: NurbsCurve, write):
        self.post, self.curve, self.write = post, curve, write
        self.secs, self.length = 0.0, 0.0
        self.last_contact = None
        self.last_driven = None

    def start(self, first_point) -> None:
        pass

    def add(self, contact, driven, params, feed_mm_min) -> None:
        pc = contact if self.last_contact is None else np.vstack([self.last_contact[None, :], contact])
        pd = driven if self.last_driven is None else np.vstack([self.last_driven[None, :], driven])
        steps = np.linalg.norm(np.diff(pc, axis=0), axis=1)  # the moves arriving at this chunk's samples
        f = np.asarray(feed_mm_min, dtype=np.float64)[len(feed_mm_min) - len(steps):]
        self.secs += float(np.sum(steps * 60.0 / np.maximum(f, 1e-300)))
        self.length += float(np.linalg.norm(np.diff(pd, axis=0), axis=1).sum())
        self.last_contact, self.last_driven = contact[-1].copy(), driven[-1].copy()

    def finish(self) -> tuple[float, int]:
        post, c = self.post, self.curve
        feed = self.length * 60.0 / self.secs if self.secs > 0 else post.settings.approach_feed_mm_min
        kn = c.knots
        chord = float(np.linalg.norm(np.diff(c.control_points, axis=0), axis=1).sum()) or 1.0
        ks = (kn - kn[0]) / (kn[-1] - kn[0]) * chord
        f, fk = post.f, (lambda v: _fmt(v, post.knot_decimals))
        cp, w = c.control_points, c.weights
        rank = c.degree + 1
        j = post.words
        lines = [j("G06.2", f"P{rank}", f"K{fk(ks[0])}", f"X{f(cp[0, 0])}", f"Y{f(cp[0, 1])}", f"Z{f(cp[0, 2])}",
                   f"R{_fmt(w[0], 4)}", f"F{post.ff(feed)}")]
        lines += [j(f"K{fk(ks[i])}", f"X{f(cp[i, 0])}", f"Y{f(cp[i, 1])}", f"Z{f(cp[i, 2])}", f"R{_fmt(w[i], 4)}")
                  for i in range(1, len(cp))]
        lines += [f"K{fk(v)}" for v in ks[len(cp):]]
        self.write(("\n".join(lines) + "\n").encode("ascii"))
        return self.secs, len(lines)


class FanucPost(GcodePost):
    name: ClassVar[str] = "fanuc"
    description: ClassVar[str] = ("Fanuc 15i/30i-class controls with the NURBS interpolation option: G06.2 "
                                  "NURBS blocks (one feed per piece), or --gcode linear")
    modes: ClassVar[tuple[str, ...]] = ("nurbs", "linear")
    inverse_time: ClassVar[bool] = False
    label: ClassVar[str] = ("for FANUC 15i/30i-CLASS CONTROLS WITH THE NURBS INTERPOLATION OPTION [G06.2]; "
                            "not for LinuxCNC")
    # whole-number coordinates keep their point: X10 is 10 increments on a Fanuc without calculator-type input
    defaults: ClassVar[dict[str, Any]] = {"program_number": 1, "integer_point": True}
    knot_decimals: ClassVar[int] = 6

    def prepare(self, tool_path: ToolPath, mode: str, tool_radius: float) -> dict:
        if mode != "nurbs":
            return {}
        from ...smooth import interpolate_nurbs, piece_curves
        from ...smooth.nurbs import bezier_cubic_through

        sp = tool_path.surface_path
        dpieces = dwell_offsets(tool_path)
        curves = piece_curves(tool_path.curve, tool_path.piece_params)
        out = []
        for k, c in enumerate(curves):
            a, b = dpieces[k], dpieces[k + 1]
            if tool_radius > 0:
                dw = offset_along_normals(sp.xyz[a:b], sp.normals[a:b], tool_radius)
                c = interpolate_nurbs(dw, c.degree)[0] if len(dw) >= 4 else bezier_cubic_through(dw)[0]
            out.append(c)
        return {"curves": out}

    def reach_z(self, tool_path: ToolPath, tool_radius: float, ctx: dict) -> float:
        z = super().reach_z(tool_path, tool_radius, ctx)
        return max([z] + [float(np.max(c.control_points[:, 2])) for c in ctx.get("curves", [])])

    def motion(self, tool_path, k, write, feed_mode, mode, tool_radius, ctx):
        if mode != "nurbs":
            return super().motion(tool_path, k, write, feed_mode, mode, tool_radius, ctx)
        return NurbsMotion(self, ctx["curves"][k], write)
