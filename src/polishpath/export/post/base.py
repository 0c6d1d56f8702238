"""The post-processor base: one settings schema and one program skeleton for every controller.

A post-processor turns a :class:`~polishpath.types.ToolPath` into the file a
controller runs. Every G-code post shares the same skeleton, written here once:

    header comments (generator, parameters, which tool point the coordinates are)
    preamble            e.g. G21 G90 G17 G94   (mm, absolute, XY plane, feed per minute)
    safety block        G40 G49 G80 G54       (no cutter comp., no length offset, no canned cycle, G54)
    blending            e.g. G64 P<chord tol> (LinuxCNC)
    spindle, slurry     M3 S<rpm>, M8
    per piece:          rapid to the clearance plane, down to the approach point,
                        approach along the surface normal at the approach feed,
                        the piece's motion (the subclass's), retract along the normal
    postamble           M5 M9 / M30

Each controller is a small subclass that sets its defaults and writes its motion
blocks (:meth:`GcodePost.motion`), the way FreeCAD CAM's post-processors share one
base class and differ by a table of values.

Feeds keep the planned time of every segment. The planned time of the segment
arriving at sample k is ``|s_k - s_(k-1)| / feed_k`` on the contact path (the
schedule the smoothing stage made). A controller's F is the speed of the point it
drives, so with a tool-radius offset (tool centre = contact + r n) the post either
writes inverse-time feed (G93: F = 1 / minutes per block, exact whatever the
offset) or rescales every F to the driven segment's length over its planned time.
F is computed from the coordinates as written (rounded), so the times the
controller derives equal the planned ones to the F's own resolution.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..._version import __version__
from ...errors import ParameterError
from ...types import Surface, ToolPath
from ..files import _fmt, _rounded, _text_out
from ..textfmt import format_fixed
from .gouge import gouge_check

__all__ = ["PostSettings", "PostProcessor", "GcodePost", "Piece", "offset_along_normals", "planned_segment_times"]

FEED_MODES = ("auto", "inverse-time", "per-minute")


@dataclass(frozen=True)
class PostSettings:
    """What a machinist sets per controller; every field can come from a ``[post]`` table.

    Attributes
    ----------
    preamble : str
        First modal words, e.g. ``"G21 G90 G17"`` (mm, absolute, XY plane). The feed
        mode word (G93 / G94) is written by the post.
    safety_block : str
        ``"G40 G49 G80 G54"``: cutter compensation off, tool length offset off,
        canned cycle off, work offset G54.
    blending : str
        Path-blending word with ``{tol}`` for the chord tolerance, mm
        (LinuxCNC: ``"G64 P{tol}"``); empty: none.
    spindle_rpm : float
        Tool (sponge) speed, rev/min: ``M3 S<rpm>``; 0 writes no spindle words.
        Default 230 rpm, the paper's sponge.
    coolant_on : str
        Slurry on (``"M8"``, flood); empty: none.
    clearance_mm : float
        Height of the clearance plane above the highest point the tool reaches, mm.
    approach_mm : float
        The tool approaches and retracts along the surface normal over this distance, mm.
    approach_feed_mm_min : float
        Feed of the approach and retract moves, mm/min.
    feed_mode : {"auto", "inverse-time", "per-minute"}
        ``auto``: inverse time (G93) where the controller has it and a tool-radius
        offset is set, else feed per minute (G94) with F rescaled to the driven point.
    decimals, feed_decimals : int
        Digits after the decimal point of coordinates (mm) and of F.
    postamble : str
        Last lines (``"M5 M9\\nM30"``: spindle and slurry off, end of program).
    program_number : int or None
        ``O`` number after the leading ``%`` (Fanuc), None: none.
    comments : bool
        Write the header comments.
    """

    preamble: str = "G21 G90 G17"
    safety_block: str = "G40 G49 G80 G54"
    blending: str = ""
    spindle_rpm: float = 230.0
    coolant_on: str = "M8"
    clearance_mm: float = 5.0
    approach_mm: float = 2.0
    approach_feed_mm_min: float = 300.0
    feed_mode: str = "auto"
    decimals: int = 4
    feed_decimals: int = 3
    postamble: str = "M5 M9\nM30"
    program_number: int | None = None
    comments: bool = True

    @classmethod
    def names(cls) -> list[str]:
        return [f.name for f in dataclasses.fields(cls)]

    def replace(self, options: dict[str, Any] | None, where: str = "post options") -> PostSettings:
        """A copy with ``options`` applied, each checked (unknown names and bad values refused)."""
        if not options:
            return self
        if not isinstance(options, dict):
            raise ParameterError(f"{where} must be a table of settings, got {type(options).__name__}.")
        unknown = sorted(set(options) - set(self.names()))
        if unknown:
            raise ParameterError(f"{where}: unknown post setting(s) {', '.join(unknown)}.",
                                 f"Settings: {', '.join(self.names())}.")
        out = dataclasses.replace(self, **options)
        out.check(where)
        return out

    def check(self, where: str = "post options") -> None:
        for name in ("preamble", "safety_block", "blending", "coolant_on", "postamble", "feed_mode"):
            if not isinstance(getattr(self, name), str):
                raise ParameterError(f"{where}: {name} must be text, got {getattr(self, name)!r}.")
        for name in ("spindle_rpm", "clearance_mm", "approach_mm", "approach_feed_mm_min"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise ParameterError(f"{where}: {name} must be a number >= 0, got {v!r}.")
        if self.approach_feed_mm_min <= 0:
            raise ParameterError(f"{where}: approach_feed_mm_min must be > 0 mm/min, got {self.approach_feed_mm_min!r}.")
        for name in ("decimals", "feed_decimals"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= 9:
                raise ParameterError(f"{where}: {name} must be a whole number 0..9, got {v!r}.")
        if self.feed_mode not in FEED_MODES:
            raise ParameterError(f"{where}: feed_mode must be one of {', '.join(FEED_MODES)}, got {self.feed_mode!r}.")
        if self.program_number is not None and (isinstance(self.program_number, bool) or
                                                not isinstance(self.program_number, int) or
                                                not 1 <= self.program_number <= 9999):
            raise ParameterError(f"{where}: program_number must be 1..9999, got {self.program_number!r}.")
        if not isinstance(self.comments, bool):
            raise ParameterError(f"{where}: comments must be true or false, got {self.comments!r}.")


def offset_along_normals(points: np.ndarray, normals: np.ndarray, radius: float) -> np.ndarray:
    """Tool-centre positions: contact ``points`` (M, 3) moved by ``radius`` mm along unit ``normals`` (M, 3)."""
    n = np.asarray(normals, dtype=np.float64)
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    return np.asarray(points, dtype=np.float64) + float(radius) * n


def planned_segment_times(tool_path: ToolPath) -> np.ndarray:
    """(M,) planned seconds of the move arriving at each sample (0 at each piece's first sample).

    ``|s_k - s_(k-1)| / feed_k`` on the contact path: one period per sample
    except the last, shorter step of a piece.
    """
    s = tool_path.samples
    dt = np.zeros(len(s))
    if len(s) > 1:
        dt[1:] = np.linalg.norm(np.diff(s, axis=0), axis=1) * 60.0 / np.maximum(tool_path.feed_mm_min[1:], 1e-300)
    dt[np.asarray(tool_path.stats.get("sample_pieces", [0, len(s)]))[:-1]] = 0.0
    return dt


@dataclass(frozen=True)
class Piece:
    """One continuous run of the tool on the part, as the post writes it.

    ``points`` (m, 3) driven point (tool centre or contact point), mm;
    ``normals`` (m, 3) unit surface normals; ``dt`` (m,) planned seconds of the
    move arriving at each point (``dt[0] = 0``).
    """

    points: np.ndarray
    normals: np.ndarray
    dt: np.ndarray


class PostProcessor:
    """A writer of one controller's file. Subclasses set the class attributes.

    Attributes
    ----------
    name : str
        Registry name (``--post NAME``).
    description : str
        One line for ``--help`` and the docs.
    filename : str
        The file it writes in a run folder.
    modes : tuple of str
        G-code flavours it can write (``"linear"``, ``"nurbs"``); first is its default.
    tool_offset : bool
        Whether it can write tool-centre coordinates (``tool_radius > 0``).
    """

    name: ClassVar[str] = ""
    description: ClassVar[str] = ""
    filename: ClassVar[str] = ""
    modes: ClassVar[tuple[str, ...]] = ("linear",)
    tool_offset: ClassVar[bool] = False
    defaults: ClassVar[dict[str, Any]] = {}

    def __init__(self, settings: PostSettings | dict[str, Any] | None = None):
        base = PostSettings().replace(self.defaults, f"{self.name} defaults")
        self.settings = settings if isinstance(settings, PostSettings) else base.replace(settings, f"[post] for {self.name}")

    def check(self, *, mode: str | None = None, tool_radius: float = 0.0) -> str:
        """The mode to write (``mode`` or the post's default), refusing what this controller cannot take."""
        mode = mode or self.modes[0]
        if mode not in ("linear", "nurbs"):
            raise ParameterError(f"Unknown G-code mode {mode!r}.", "Use 'linear' or 'nurbs'.")
        if mode not in self.modes:
            raise ParameterError(*self.refuse_mode(mode))
        if not (isinstance(tool_radius, (int, float)) and math.isfinite(tool_radius) and tool_radius >= 0):
            raise ParameterError(f"tool_radius must be a number of mm >= 0, got {tool_radius!r}.")
        if tool_radius > 0 and not self.tool_offset:
            raise ParameterError(
                f"The {self.name} post writes the tool-part contact points; it cannot offset them by a tool radius.",
                "Use a G-code post (--post linuxcnc or --post fanuc) with --tool-radius, or leave --tool-radius out.")
        return mode

    def refuse_mode(self, mode: str) -> tuple[str, str]:
        return (f"The {self.name} post cannot write {mode} moves.", f"Use --gcode {self.modes[0]}.")

    def write(self, tool_path: ToolPath, file, *, mode: str | None = None, tool_radius: float = 0.0,
              header: dict | None = None, surface: Surface | None = None) -> dict[str, Any]:
        """Write the file; returns what it wrote (post, mode, feed mode, coordinates, times, lines).

        ``surface`` (the part's mesh), when given with a tool radius, is used for the
        gouge check (:func:`polishpath.export.post.gouge.gouge_check`).
        """
        raise NotImplementedError


def _comment(text: str) -> str:
    # parentheses end a G-code comment early; keep the text printable ASCII
    clean = "".join(ch if 32 <= ord(ch) < 127 else "?" for ch in str(text)).replace("(", "[").replace(")", "]")
    return f"({clean})"


def _flatten_header(d: dict, prefix: str = "") -> list[tuple[str, Any]]:
    out = []
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out += _flatten_header(v, key + ".")
        elif isinstance(v, np.ndarray):
            if v.size <= 8:
                out.append((key, v.tolist()))
        elif isinstance(v, (list, tuple)) and len(v) > 8:
            continue
        else:
            out.append((key, v))
    return out


class GcodePost(PostProcessor):
    """The G-code skeleton shared by every G-code controller (see the module docstring)."""

    filename: ClassVar[str] = "toolpath.nc"
    tool_offset: ClassVar[bool] = True
    inverse_time: ClassVar[bool] = False  # the controller has G93
    label: ClassVar[str] = ""  # a header line saying which controllers the file is for

    # ---------------------------------------------------------------- the pieces
    def pieces(self, tool_path: ToolPath, tool_radius: float) -> list[Piece]:
        """The sampled path per piece, offset to the tool centre when ``tool_radius > 0``."""
        from ...smooth import sample_normals

        normals = sample_normals(tool_path)
        pts = tool_path.samples if tool_radius == 0 else offset_along_normals(tool_path.samples, normals, tool_radius)
        dt = planned_segment_times(tool_path)
        off = np.asarray(tool_path.stats.get("sample_pieces", [0, len(pts)]))
        return [Piece(pts[a:b], normals[a:b], dt[a:b]) for a, b in zip(off[:-1], off[1:]) if b > a]

    def feed_mode(self, tool_radius: float) -> str:
        fm = self.settings.feed_mode
        if fm == "auto":
            return "inverse-time" if (self.inverse_time and tool_radius > 0) else "per-minute"
        if fm == "inverse-time" and not self.inverse_time:
            raise ParameterError(f"The {self.name} post has no inverse-time feed (G93).",
                                 "Set feed_mode = 'per-minute' (F is then rescaled to the driven point).")
        return fm

    # ---------------------------------------------------------------- numbers
    def f(self, v: float) -> str:
        return _fmt(v, self.settings.decimals)

    def ff(self, v: float) -> str:
        return _fmt(v, self.settings.feed_decimals)

    def linear_rows(self, piece: Piece, feed_mode: str) -> tuple[np.ndarray, float]:
        """``G01`` rows (X, Y, Z, F) for the piece's moves after its first point, and their time, s.

        Consecutive samples that round to the same written point are merged (their
        time goes to the next written move), so no zero-length block is written
        and the piece's time is kept.
        """
        d = self.settings.decimals
        w = _rounded(piece.points, d)
        if len(w) < 2:
            return np.zeros((0, 4)), 0.0
        moved = np.any(w[1:] != w[:-1], axis=1)
        keep = np.concatenate([[0], 1 + np.flatnonzero(moved)])
        t = np.cumsum(piece.dt)
        tk = t[keep]
        tk[-1] = t[-1]  # time of trailing merged samples goes to the last written move
        dtw = np.diff(tk)
        pw = w[keep]
        if len(pw) < 2:
            return np.zeros((0, 4)), 0.0
        if feed_mode == "inverse-time":
            feed = 60.0 / np.maximum(dtw, 1e-12)  # 1/min: the block takes 1/F minutes
        else:
            feed = np.linalg.norm(np.diff(pw, axis=0), axis=1) * 60.0 / np.maximum(dtw, 1e-12)
        feed = np.round(feed, self.settings.feed_decimals) + 0.0
        return np.column_stack([pw[1:], feed]), float(dtw.sum())

    def motion(self, fh, piece: Piece, index: int, feed_mode: str, mode: str, ctx: dict) -> tuple[float, int]:
        """Write the piece's moves after its first point; returns (seconds, lines). Linear G01 here."""
        rows, secs = self.linear_rows(piece, feed_mode)
        d, fd = self.settings.decimals, self.settings.feed_decimals
        fh.write(format_fixed(rows, [d, d, d, fd], letters="XYZF").decode().replace("\nX", "\nG01 X").join(["G01 ", ""]) if len(rows) else "")
        return secs, len(rows)

    def motion_bounds(self, piece: Piece, mode: str, ctx: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Start point, start normal, end point, end normal of the piece's motion."""
        return piece.points[0], piece.normals[0], piece.points[-1], piece.normals[-1]

    def prepare(self, tool_path: ToolPath, pieces: list[Piece], mode: str, tool_radius: float) -> dict:
        """Per-file data a subclass's motion needs (e.g. the NURBS curves); {} here."""
        return {}

    # ---------------------------------------------------------------- the file
    def header_lines(self, tool_path: ToolPath, header: dict | None, mode: str, feed_mode: str,
                     tool_radius: float, safe: float, n_pieces: int) -> list[str]:
        sp = tool_path.surface_path
        hdr: list[tuple[str, Any]] = [("generator", f"polishpath {__version__}"), ("post", self.name)]
        hdr += _flatten_header(header or {})
        hdr += _flatten_header(tool_path.provenance.to_dict(), "smooth.")
        if sp.provenance is not None:
            hdr += _flatten_header(sp.provenance.to_dict(), "map.")
        hdr += [("mode", mode), ("feed_mode", feed_mode), ("dwell_points", len(sp.xyz)),
                ("samples", len(tool_path.samples)), ("pieces", n_pieces), ("period_ms", tool_path.period_ms),
                ("tool_radius_mm", float(tool_radius)), ("safe_z_mm", safe)]
        lines = [_comment(f"{k}: {v}") for k, v in hdr]
        if self.label:
            lines.append(_comment(self.label))
        if tool_radius > 0:
            lines.append(_comment(f"COORDINATES: TOOL CENTRE. TOOL RADIUS OFFSET: contact points moved {tool_radius} mm "
                                  "along the surface normal to the centre of the ball/sponge tool; run with no "
                                  "cutter compensation and the tool length set to that centre"))
        else:
            lines.append(_comment("COORDINATES: TOOL-PART CONTACT POINT [no tool radius offset]; the controlled "
                                  "point must be the tool's contact point"))
        if feed_mode == "inverse-time":
            lines.append(_comment("FEED: G93 inverse time, F = 1/minutes of each block: every block takes its "
                                  "planned time whatever the offset"))
        else:
            lines.append(_comment("FEED: G94 mm/min of the driven point, each F set so the block takes its "
                                  "planned time"))
        return lines

    def write(self, tool_path: ToolPath, file, *, mode: str | None = None, tool_radius: float = 0.0,
              header: dict | None = None, surface: Surface | None = None) -> dict[str, Any]:
        mode = self.check(mode=mode, tool_radius=tool_radius)
        tool_radius = float(tool_radius)
        feed_mode = self.feed_mode(tool_radius)
        s = self.settings
        pieces = self.pieces(tool_path, tool_radius)
        ctx = self.prepare(tool_path, pieces, mode, tool_radius)
        bounds = [self.motion_bounds(p, mode, ctx) for p in pieces]
        a = s.approach_mm
        reach = [np.vstack([p0, p0 + a * n0, p1, p1 + a * n1]) for p0, n0, p1, n1 in bounds]
        zmax = max([float(np.max(r[:, 2])) for r in reach] + [float(np.max(p.points[:, 2])) for p in pieces] + [0.0])
        safe = zmax + s.clearance_mm
        tol = float(tool_path.provenance.params.get("chord_tol_mm", tool_path.stats.get("chord_tol_mm", 0.001)))
        f, ff = self.f, self.ff
        g9x = "G93" if feed_mode == "inverse-time" else "G94"
        path_s, appr_s, n_moves = 0.0, 0.0, 0
        with _text_out(file) as fh:
            fh.write("%\n")
            if s.program_number is not None:
                fh.write(f"O{s.program_number:04d}\n")
            if s.comments:
                fh.write("\n".join(self.header_lines(tool_path, header, mode, feed_mode, tool_radius, safe,
                                                     len(pieces))) + "\n")
            fh.write(f"{s.preamble} G94\n".lstrip())
            if s.safety_block:
                fh.write(s.safety_block + "\n")
            if s.blending:
                fh.write(s.blending.format(tol=_fmt(tol, max(4, s.decimals + 2))) + "\n")
            if s.spindle_rpm > 0:
                fh.write(f"M3 S{_fmt(s.spindle_rpm, 0)}\n")
            if s.coolant_on:
                fh.write(s.coolant_on + "\n")
            for k, (piece, (p0, n0, p1, n1)) in enumerate(zip(pieces, bounds)):
                q0, q1 = p0 + a * n0, p1 + a * n1
                fh.write(f"G00 Z{f(safe)}\nG00 X{f(q0[0])} Y{f(q0[1])}\nG00 Z{f(q0[2])}\n")
                fh.write(f"G01 X{f(p0[0])} Y{f(p0[1])} Z{f(p0[2])} F{ff(s.approach_feed_mm_min)}\n")
                if g9x == "G93":
                    fh.write("G93\n")
                secs, lines = self.motion(fh, piece, k, feed_mode, mode, ctx)
                if g9x == "G93":
                    fh.write("G94\n")
                fh.write(f"G01 X{f(q1[0])} Y{f(q1[1])} Z{f(q1[2])} F{ff(s.approach_feed_mm_min)}\n")
                fh.write(f"G00 Z{f(safe)}\n")
                path_s += secs
                n_moves += lines
                appr_s += 2 * a * 60.0 / s.approach_feed_mm_min
            fh.write(s.postamble.rstrip("\n") + "\n%\n")
        gouge = gouge_check(tool_path, tool_radius, surface) if tool_radius > 0 else None
        return {"post": self.name, "file": self.filename, "mode": mode, "feed_mode": feed_mode,
                "gouge": gouge, "warnings": list(gouge["warnings"]) if gouge else [],
                "coordinates": "tool centre" if tool_radius > 0 else "contact point", "tool_radius_mm": tool_radius,
                "blending_tol_mm": tol if s.blending else None, "spindle_rpm": s.spindle_rpm,
                "clearance_z_mm": safe, "approach_mm": a, "approach_feed_mm_min": s.approach_feed_mm_min,
                "path_time_s": path_s, "machining_time_s": path_s + appr_s, "motion_blocks": n_moves,
                "pieces": len(pieces), "settings": dataclasses.asdict(s)}
