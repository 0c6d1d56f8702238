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
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from ...types import ToolPath
from ..files import _fmt
from .base import GcodePost, Piece, offset_along_normals


class FanucPost(GcodePost):
    name: ClassVar[str] = "fanuc"
    description: ClassVar[str] = ("Fanuc 15i/30i-class controls with the NURBS interpolation option: G06.2 "
                                  "NURBS blocks (one feed per piece), or --gcode linear")
    modes: ClassVar[tuple[str, ...]] = ("nurbs", "linear")
    inverse_time: ClassVar[bool] = False
    label: ClassVar[str] = ("for FANUC 15i/30i-CLASS CONTROLS WITH THE NURBS INTERPOLATION OPTION [G06.2]; "
                            "not for LinuxCNC")
    defaults: ClassVar[dict[str, Any]] = {"program_number": 1}
    knot_decimals: ClassVar[int] = 6

    def prepare(self, tool_path: ToolPath, pieces: list[Piece], mode: str, tool_radius: float) -> dict:
        if mode != "nurbs":
            return {}
        from ...smooth import interpolate_nurbs, piece_curves
        from ...smooth.nurbs import bezier_cubic_through

        sp = tool_path.surface_path
        n = len(sp.xyz)
        dpieces = np.asarray(sp.planar.pieces if sp.planar is not None else [0, n])
        pp = np.asarray(tool_path.stats.get("piece_params", [tool_path.curve.knots[0], tool_path.curve.knots[-1]]))
        curves = piece_curves(tool_path.curve, pp)
        out = []
        for k, c in enumerate(curves):
            a, b = dpieces[k], dpieces[k + 1]
            if tool_radius > 0:
                dw = offset_along_normals(sp.xyz[a:b], sp.normals[a:b], tool_radius)
                c = interpolate_nurbs(dw, c.degree)[0] if len(dw) >= 4 else bezier_cubic_through(dw)[0]
            out.append(c)
        return {"curves": out}

    def motion(self, fh, piece: Piece, index: int, feed_mode: str, mode: str, ctx: dict) -> tuple[float, int]:
        if mode != "nurbs":
            return super().motion(fh, piece, index, feed_mode, mode, ctx)
        c = ctx["curves"][index]
        secs = float(piece.dt.sum())
        length = float(np.linalg.norm(np.diff(piece.points, axis=0), axis=1).sum())
        feed = length * 60.0 / secs if secs > 0 else self.settings.approach_feed_mm_min
        kn = c.knots
        chord = float(np.linalg.norm(np.diff(c.control_points, axis=0), axis=1).sum()) or 1.0
        ks = (kn - kn[0]) / (kn[-1] - kn[0]) * chord
        f, fk = self.f, (lambda v: _fmt(v, self.knot_decimals))
        cp, w = c.control_points, c.weights
        rank = c.degree + 1
        lines = [f"G06.2 P{rank} K{fk(ks[0])} X{f(cp[0, 0])} Y{f(cp[0, 1])} Z{f(cp[0, 2])} R{_fmt(w[0], 4)} "
                 f"F{self.ff(feed)}"]
        lines += [f"K{fk(ks[i])} X{f(cp[i, 0])} Y{f(cp[i, 1])} Z{f(cp[i, 2])} R{_fmt(w[i], 4)}" for i in range(1, len(cp))]
        lines += [f"K{fk(v)}" for v in ks[len(cp):]]
        fh.write("\n".join(lines) + "\n")
        return secs, len(lines)
