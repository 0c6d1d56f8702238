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
from typing import Any, ClassVar, Iterable

import numpy as np

from ..._version import __version__
from ...errors import ParameterError
from ...types import Surface, ToolPath
from ..chunks import SampleChunk, axes_at, checked_chunks, dwell_offsets, normals_at, sample_chunks
from ..files import _bytes_out, _fmt
from ..segment import PieceSegmenter
from ..textfmt import KEEP_POINT, NO_LEADING_ZERO, NO_TRAILING_ZEROS, fixed_text
from .gouge import gouge_check
from .blocks import BlockMotion, round_feeds
from .settings import SEGMENT_TOL_OF_SPACING, PostSettings

__all__ = ["PostSettings", "PostProcessor", "GcodePost", "offset_along_normals", "planned_segment_times"]


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
    dt[tool_path.sample_pieces[:-1]] = 0.0
    return dt


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
    writes_axes : bool
        Whether it writes the tool axis (a 5-axis or robot post: the rotary-words hook,
        :meth:`orientation_letters`); a 3-axis post refuses a path with tool axes.

    A 5-axis post is made with the machine's kinematics (``kinematics``, a
    :class:`polishpath.schedule.kinematics.Kinematics` or None) where its words need them
    (LinuxCNC's A/C or B/C angles); a post writing tool vectors (A3/B3/C3) needs none.
    """

    name: ClassVar[str] = ""
    description: ClassVar[str] = ""
    filename: ClassVar[str] = ""
    modes: ClassVar[tuple[str, ...]] = ("linear",)
    tool_offset: ClassVar[bool] = False
    writes_axes: ClassVar[bool] = False
    defaults: ClassVar[dict[str, Any]] = {}

    def __init__(self, settings: PostSettings | dict[str, Any] | None = None, kinematics=None):
        base = PostSettings().replace(self.defaults, f"{self.name} defaults")
        self.settings = settings if isinstance(settings, PostSettings) else base.replace(settings, f"[post] for {self.name}")
        self.kinematics = kinematics

    # ---------------------------------------------------------------- the rotary-words hook (5-axis posts)
    def orientation_letters(self) -> tuple[str, ...]:
        """The letters of the words that carry the tool axis on every motion block (``("A", "C")`` for
        LinuxCNC's xyzac-trt); () for a 3-axis post."""
        return ()

    def orientation_coords(self, axes: np.ndarray, previous: np.ndarray | None) -> np.ndarray:
        """The values of :meth:`orientation_letters` for unit tool ``axes`` (m, 3) (part frame, tip to spindle),
        (m, r): what the controller interpolates linearly between two blocks. ``previous`` (r,): the values
        of the sample before (continuity: a branch and unwinding chosen from it), None at a piece's start."""
        raise NotImplementedError(f"the {self.name} post writes no tool axis")

    def axes_from_coords(self, coords: np.ndarray) -> np.ndarray:
        """Unit tool axes (m, 3) of orientation values ``coords`` (m, r): the inverse of :meth:`orientation_coords`
        (the segmenter checks the controller's interpolation against the planned axes with it)."""
        raise NotImplementedError(f"the {self.name} post writes no tool axis")

    def check(self, *, mode: str | None = None, tool_radius: float = 0.0, tool_axes: bool = False) -> str:
        """The mode to write (``mode`` or the post's default), refusing what this controller cannot take
        (``tool_axes``: the path carries tool axes, a 5-axis job)."""
        if tool_axes and not self.writes_axes:
            raise ParameterError(
                f"The {self.name} post writes a 3-axis file (vertical tool): it cannot carry the tool axes of "
                "--tool-axis other than z.",
                "Use a 5-axis post and machine (--post linuxcnc --machine xyzac-trt or xyzbc-trt), or --tool-axis z.")
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
              header: dict | None = None, surface: Surface | None = None, chunks: Iterable[SampleChunk] | None = None,
              also: tuple = ()) -> dict[str, Any]:
        """Write the file; returns what it wrote (post, mode, feed mode, coordinates, times, lines).

        ``surface`` (the part's mesh), when given with a tool radius, is used for the
        gouge check (:func:`polishpath.export.post.gouge.gouge_check`). ``chunks``: the
        machine samples as :class:`~polishpath.export.chunks.SampleChunk` s (a streamed
        job; default: the ToolPath's own, cut into chunks), read once; each chunk is
        also passed to every callable in ``also`` (e.g. the xyz writer of the same pass).
        """
        raise NotImplementedError


def _comment(text: str) -> str:
    # parentheses end a G-code comment early; keep the text printable ASCII
    clean = "".join(ch if 32 <= ord(ch) < 127 else "?" for ch in str(text)).replace("(", "[").replace(")", "]")
    return f"({clean})"


def provenance_header(post_name: str, tool_path: ToolPath, header: dict | None) -> list[tuple[str, Any]]:
    """The header's first entries, every post's: generator, post, the job's ``header`` and the smoothing
    and mapping provenance (``smooth.`` / ``map.`` keys), as (key, value) pairs."""
    hdr: list[tuple[str, Any]] = [("generator", f"polishpath {__version__}"), ("post", post_name)]
    hdr += _flatten_header(header or {})
    hdr += _flatten_header(tool_path.provenance.to_dict(), "smooth.")
    if tool_path.surface_path.provenance is not None:
        hdr += _flatten_header(tool_path.surface_path.provenance.to_dict(), "map.")
    return hdr


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

    def feed_mode(self, tool_radius: float, rotary: bool = False) -> str:
        fm = self.settings.feed_mode
        if rotary:  # a 5-axis block's time cannot be set by a feed per minute of the tool point alone
            if fm == "per-minute" or not self.inverse_time:
                raise ParameterError(f"The {self.name} post writes 5-axis blocks in inverse time (G93) only.",
                                     "Leave feed_mode at auto (or inverse-time) for a path with tool axes.")
            return "inverse-time"
        if fm == "auto":
            return "inverse-time" if (self.inverse_time and tool_radius > 0) else "per-minute"
        if fm == "inverse-time" and not self.inverse_time:
            raise ParameterError(f"The {self.name} post has no inverse-time feed (G93).",
                                 "Set feed_mode = 'per-minute' (F is then rescaled to the driven point).")
        return fm

    # ---------------------------------------------------------------- numbers
    def styles(self) -> int:
        """The coordinates' number style (:mod:`~polishpath.export.textfmt` bits) from the settings."""
        s = self.settings
        return ((0 if s.leading_zero else NO_LEADING_ZERO) | (0 if s.trailing_zeros else NO_TRAILING_ZEROS)
                | (KEEP_POINT if s.integer_point else 0))

    def f(self, v: float) -> str:
        """A coordinate as the motion blocks write it."""
        return fixed_text(v, self.settings.decimals, self.styles())

    def ff(self, v: float) -> str:
        """An F as the motion blocks write it (rounded as :func:`~polishpath.export.post.blocks.round_feeds`)."""
        s = self.settings
        v = float(round_feeds(np.array([float(v)]), s.feed_decimals, s.feed_resolution)[0])
        style = (self.styles() & ~KEEP_POINT) | (NO_TRAILING_ZEROS if s.feed_decimals is None else 0)
        return fixed_text(v, 9 if s.feed_decimals is None else s.feed_decimals, style)

    def words(self, *words: str) -> str:
        """Words of one block joined by ``word_separator``."""
        return self.settings.word_separator.join(w for w in words if w)

    def chord_tol(self, tool_path: ToolPath) -> float:
        """The smoothing stage's chord tolerance, mm (the blending's)."""
        return float(tool_path.provenance.params.get("chord_tol_mm", tool_path.stats.get("chord_tol_mm", 0.001)))

    def segment_tol(self, tool_path: ToolPath) -> float:
        """The segmenting's chord tolerance, mm: ``chord_tol_mm``, else :data:`SEGMENT_TOL_OF_SPACING` of the
        dwell-point spacing on the part (the path's ``spacing``, else its shortest step), at least the
        smoothing stage's chord tolerance."""
        if self.settings.chord_tol_mm:
            return float(self.settings.chord_tol_mm)
        st = tool_path.surface_path.stats
        spacing = st.get("spacing") or st.get("step_min") or 0.0
        return max(self.chord_tol(tool_path), SEGMENT_TOL_OF_SPACING * float(spacing))

    # ---------------------------------------------------------------- per piece
    def driven(self, tool_path: ToolPath, tool_radius: float):
        """``driven(points, params) -> driven points``: contact points moved ``tool_radius`` along the normal."""

        def at(points, params):
            if tool_radius == 0:
                return points
            return offset_along_normals(points, normals_at(tool_path, params), tool_radius)

        return at

    def motion(self, tool_path: ToolPath, k: int, write, feed_mode: str, mode: str, tool_radius: float,
               ctx: dict) -> BlockMotion:
        """The writer of piece ``k``'s moves (``start``, ``add`` per chunk, ``finish``): G01 / G02 / G03 blocks."""
        from ...smooth.nurbs import span_polynomials

        s = self.settings
        sp = tool_path.surface_path
        a, b = ctx["dwell_offsets"][k], ctx["dwell_offsets"][k + 1]
        # every dwell point a block end: the contact point, or the tool centre along its own normal
        dpts = sp.xyz[a:b] if tool_radius == 0 else offset_along_normals(sp.xyz[a:b], sp.normals[a:b], tool_radius)
        inverse = feed_mode == "inverse-time"
        if "curve_polys" not in ctx:
            breaks, coeffs, _ = span_polynomials(tool_path.curve)
            ctx["curve_polys"] = (np.ascontiguousarray(breaks), np.ascontiguousarray(coeffs),
                                  np.ascontiguousarray(tool_path.dwell_params, dtype=np.float64),
                                  np.ascontiguousarray(sp.normals, dtype=np.float64))
        seg = PieceSegmenter(tool_path.dwell_params[a:b], dpts, ctx["curve_polys"] + (float(tool_radius),),
                             ctx["segment_tol_mm"], s.time_tol - self.feed_share(inverse),
                             merge=s.segmenting == "chord", arcs=self.uses_arcs(), resolution_mm=10.0 ** -s.decimals,
                             smooth_tol_mm=tool_path.provenance.params.get("chord_tol_mm"),
                             dwell_block_ends=s.dwell_block_ends)
        return BlockMotion(seg, write, decimals=s.decimals, feed_decimals=s.feed_decimals, inverse_time=inverse,
                           feed_resolution=s.feed_resolution, feed_in_force=self.approach_feed_written(),
                           sep=s.word_separator, styles=self.styles(), radius_arcs=s.radius_arcs and self.uses_arcs(),
                           incremental=s.incremental, anchor_blocks=s.anchor_blocks)

    # ---------------------------------------------------------------- 5-axis (the rotary-words hook)
    def fo(self, v: float) -> str:
        """An orientation word's number as the motion blocks write it (``orientation_decimals``)."""
        return fixed_text(v, self.settings.orientation_decimals, self.styles())

    def rotary_motion(self, tool_path: ToolPath, k: int, write, tool_radius: float, ctx: dict):
        """The writer of piece ``k``'s 5-axis moves (:class:`~polishpath.export.post.rotary.RotaryMotion`)."""
        from .rotary import RotaryMotion

        s = self.settings
        sp = tool_path.surface_path
        a, b = ctx["dwell_offsets"][k], ctx["dwell_offsets"][k + 1]
        dpts = sp.xyz[a:b] if tool_radius == 0 else offset_along_normals(sp.xyz[a:b], sp.normals[a:b], tool_radius)
        return RotaryMotion(self, write, dwell_params=tool_path.dwell_params[a:b], dwell_points=dpts,
                            dwell_axes=sp.tool_axes[a:b], chord_tol_mm=ctx["segment_tol_mm"],
                            orientation_tol_deg=s.orientation_tol_deg, decimals=s.decimals,
                            orientation_decimals=s.orientation_decimals, feed_decimals=s.feed_decimals,
                            feed_resolution=s.feed_resolution, sep=s.word_separator, styles=self.styles())

    def rotary_header(self, tool_path: ToolPath, tool_radius: float) -> list[str]:
        """Header lines of a 5-axis file: which tool point, which kinematics the coordinates are for."""
        point = (f"the tool centre [contact point + {tool_radius:g} mm along the surface normal]" if tool_radius > 0
                 else "the tool-part contact point")
        return [f"TOOL AXIS: {tool_path.surface_path.tool_axis} [part frame, tool tip to spindle]",
                f"COORDINATES: X Y Z = {point} in the part's frame; "
                f"{' '.join(self.orientation_letters())} = the tool axis' words",
                "FEED: G93 inverse time, F = 1/minutes of each block: every block takes its planned time"]

    def rotary_info(self, counts: dict) -> dict[str, Any]:
        """What a 5-axis file's summary adds: the orientation words, tolerance and the largest axis error."""
        return {"orientation_words": list(self.orientation_letters()),
                "orientation_tol_deg": self.settings.orientation_tol_deg,
                "axis_error_at_block_ends_deg": counts["axis_error_deg"]}

    def feed_share(self, inverse: bool) -> float:
        """The share of ``time_tol`` kept for F's resolution: ``feed_resolution`` where a block's F may be off
        its own feed by that much (G94's modal F, or F rounded to that resolution), else 0."""
        s = self.settings
        return s.feed_resolution if (not inverse or s.feed_decimals is None) else 0.0

    def approach_feed_written(self) -> float:
        """The approach feed as written, mm/min (the F in force when a piece's motion starts)."""
        return float(self.ff(self.settings.approach_feed_mm_min))

    def uses_arcs(self) -> bool:
        """Whether the linear mode writes helical arcs beside lines (``arcs`` with ``chord`` segmenting)."""
        return self.settings.arcs and self.settings.segmenting == "chord"

    def segment_blocks(self, tool_path: ToolPath, tool_radius: float = 0.0,
                       chunks: Iterable[SampleChunk] | None = None) -> list[tuple[np.ndarray, ...]]:
        """The blocks before rounding, per piece: (points (k, 3) mm, planned times (k,) s, params (k,), kinds (k,),
        ij (k, 2) mm, centres (k, 2) mm).

        ``kinds``: :data:`~polishpath.export.blockfit.LINE`, ``CW`` or ``CCW``; ``ij``: an arc's centre from
        its rounded start, rounded (as written); ``centres``: an arc's fitted centre (before rounding; NaN: a
        line). The piece's first point (the approach's end, kind 0) first,
        then every block end, as
        :meth:`write` segments them (for checks and benchmarks; the file rounds them).
        """
        feed_mode = self.feed_mode(float(tool_radius))
        ctx = {"dwell_offsets": dwell_offsets(tool_path),
               "segment_tol_mm": self.segment_tol(tool_path)}
        at = self.driven(tool_path, float(tool_radius))
        out, seg, parts = [], None, None

        def close():
            if seg is not None:
                parts.append(seg.finish())
                out.append(tuple(np.concatenate(x) for x in zip(*parts)))

        for starts, c in checked_chunks(sample_chunks(tool_path) if chunks is None else chunks,
                                        len(ctx["dwell_offsets"]) - 1):
            pts = at(c.samples, c.sample_params)
            if starts:
                close()
                seg = self.motion(tool_path, c.piece, None, feed_mode, "linear", float(tool_radius), ctx).seg
                parts = [(pts[:1], np.zeros(1), c.sample_params[:1], np.zeros(1, np.int64), np.zeros((1, 2)),
                          np.full((1, 2), np.nan))]
            parts.append(seg.add(c.samples, pts, c.sample_params, c.feed_mm_min))
        close()
        return out

    def prepare(self, tool_path: ToolPath, mode: str, tool_radius: float) -> dict:
        """Per-file data a subclass's motion needs (e.g. the NURBS curves); {} here."""
        return {}

    def reach_z(self, tool_path: ToolPath, tool_radius: float, ctx: dict) -> float:
        """Highest z the tool reaches on the path (a bound): the curve's control points (+ the radius)."""
        return float(np.max(tool_path.curve.control_points[:, 2])) + tool_radius

    # ---------------------------------------------------------------- the file
    def header_lines(self, tool_path: ToolPath, header: dict | None, mode: str, feed_mode: str,
                     tool_radius: float, safe: float, n_pieces: int, ctx: dict) -> list[str]:
        sp = tool_path.surface_path
        s = self.settings
        hdr = provenance_header(self.name, tool_path, header)
        hdr += [("mode", mode), ("feed_mode", feed_mode), ("dwell_points", len(sp.xyz)), ("pieces", n_pieces),
                ("period_ms", tool_path.period_ms), ("tool_radius_mm", float(tool_radius)), ("safe_z_mm", safe),
                ("coordinate_resolution_mm", 10.0 ** -s.decimals),
                ("feed_decimals", "by feed_resolution" if s.feed_decimals is None else s.feed_decimals),
                ("word_separator", repr(s.word_separator)), ("leading_zero", s.leading_zero),
                ("trailing_zeros", s.trailing_zeros), ("integer_point", s.integer_point)]
        if mode == "linear":
            hdr += [("segmenting", s.segmenting)]
            if s.segmenting == "chord" and sp.tool_axes is not None:  # 5-axis: lines, every dwell point an end
                hdr += [("segment_chord_tol_mm", ctx["segment_tol_mm"]),
                        ("segment_orientation_tol_deg", s.orientation_tol_deg), ("arcs", False),
                        ("dwell_block_ends", True)]
            elif s.segmenting == "chord":
                hdr += [("segment_chord_tol_mm", ctx["segment_tol_mm"]), ("segment_time_tol", s.time_tol),
                        ("arcs", self.uses_arcs()), ("dwell_block_ends", s.dwell_block_ends)]
            if sp.tool_axes is None:
                hdr += [("radius_arcs", s.radius_arcs and self.uses_arcs()), ("incremental", s.incremental)]
                if s.incremental:
                    hdr += [("anchor_blocks", s.anchor_blocks)]
            if feed_mode != "inverse-time":
                hdr += [("feed_resolution", s.feed_resolution)]
        lines = [_comment(f"{k}: {v}") for k, v in hdr]
        if self.label:
            lines.append(_comment(self.label))
        if sp.tool_axes is not None:
            lines += [_comment(x) for x in self.rotary_header(tool_path, tool_radius)]
        elif tool_radius > 0:
            lines.append(_comment(f"COORDINATES: TOOL CENTRE. TOOL RADIUS OFFSET: contact points moved {tool_radius} mm "
                                  "along the surface normal to the centre of the ball/sponge tool; run with no "
                                  "cutter compensation and the tool length set to that centre"))
        else:
            lines.append(_comment("COORDINATES: TOOL-PART CONTACT POINT [no tool radius offset]; the controlled "
                                  "point must be the tool's contact point"))
        if sp.tool_axes is not None:
            pass  # the 5-axis header said it
        elif feed_mode == "inverse-time":
            lines.append(_comment("FEED: G93 inverse time, F = 1/minutes of each block: every block takes its "
                                  "planned time whatever the offset"))
        else:
            lines.append(_comment("FEED: G94 mm/min of the driven point, each F set so the block takes its "
                                  "planned time"))
        if mode == "linear" and sp.tool_axes is None:
            if self.uses_arcs():  # LinuxCNC reads at most 256 characters a line
                lines.append(_comment("ARCS: G2/G3 helical arcs in the XY plane [G17], Z linear along the arc, "
                                      + ("radius R [under a half circle] where exact to the resolution, else "
                                         if s.radius_arcs else "")
                                      + "centre I J incremental from the arc's start; G1/G2/G3 only where the "
                                      "motion changes"))
            if s.incremental:
                lines.append(_comment(f"DISTANCE MODE: G91 incremental axis words inside each piece, a G90 block "
                                      f"of absolute words every {s.anchor_blocks} blocks and at each piece's end; "
                                      "RESTART THE PROGRAM ONLY AT A G90 BLOCK or an approach"))
            lines.append(_comment("MODAL WORDS: G01 once per piece [the approach], axis words only when they change"
                                  + ("" if feed_mode == "inverse-time" else ", F only when the feed changes by more "
                                     f"than {s.feed_resolution:g} of the F in force")))
        return lines

    def write(self, tool_path: ToolPath, file, *, mode: str | None = None, tool_radius: float = 0.0,
              header: dict | None = None, surface: Surface | None = None, chunks: Iterable[SampleChunk] | None = None,
              also: tuple = ()) -> dict[str, Any]:
        rotary = tool_path.surface_path.tool_axes is not None
        mode = self.check(mode=mode, tool_radius=tool_radius, tool_axes=rotary)
        tool_radius = float(tool_radius)
        feed_mode = self.feed_mode(tool_radius, rotary)
        s = self.settings
        sp = tool_path.surface_path
        doff = dwell_offsets(tool_path)
        n_pieces = len(doff) - 1
        ctx = {"dwell_offsets": doff, "segment_tol_mm": self.segment_tol(tool_path)}
        ctx.update(self.prepare(tool_path, mode, tool_radius))
        a = s.approach_mm
        # the clearance plane from what is known before the samples: a bound of the curve, the approach points
        ends = np.concatenate([doff[:-1], doff[1:] - 1])
        away = sp.normals if not rotary else sp.tool_axes  # the approach and retract: along the tool axis (5-axis)
        nrm = away[ends] / np.maximum(np.linalg.norm(away[ends], axis=1, keepdims=True), 1e-300)
        reach = sp.xyz[ends] + (tool_radius + a) * nrm
        zmax = max(self.reach_z(tool_path, tool_radius, ctx), float(np.max(reach[:, 2])) if len(reach) else 0.0, 0.0)
        safe = zmax + s.clearance_mm
        tol = self.chord_tol(tool_path)
        f, ff, w = self.f, self.ff, self.words
        inverse = feed_mode == "inverse-time"
        chunks = sample_chunks(tool_path) if chunks is None else chunks
        at = self.driven(tool_path, tool_radius)
        counts = {"bytes": 0, "samples": 0, "blocks": 0, "arcs": 0, "radius_arcs": 0, "anchors": 0, "path_s": 0.0,
                  "pieces": 0, "axis_error_deg": 0.0}
        with _bytes_out(file) as raw:

            def write(b: bytes) -> None:
                counts["bytes"] += len(b)
                raw(b)

            def text(t: str) -> None:
                write(t.encode("ascii"))

            text("%\n")
            if s.program_number is not None:
                text(f"O{s.program_number:04d}\n")
            if s.comments:
                text("\n".join(self.header_lines(tool_path, header, mode, feed_mode, tool_radius, safe, n_pieces,
                                                 ctx)) + "\n")
            text(f"{s.preamble} G94\n".lstrip())
            if s.safety_block:
                text(s.safety_block + "\n")
            if s.blending:
                text(s.blending.format(tol=_fmt(tol, max(4, s.decimals + 2))) + "\n")
            if s.spindle_rpm > 0:
                text(f"M3 S{_fmt(s.spindle_rpm, 0)}\n")
            if s.coolant_on:
                text(s.coolant_on + "\n")
            state = {"motion": None, "last": None}

            def end_piece() -> None:
                m, (p1, u1) = state["motion"], state["last"]
                n1 = (axes_at if rotary else normals_at)(tool_path, np.array([u1]))[0]
                secs, blocks = m.finish()
                q1 = p1 + a * n1
                text(("G94\n" if inverse else "") + w("G01", f"X{f(q1[0])}", f"Y{f(q1[1])}", f"Z{f(q1[2])}",
                                                      f"F{ff(s.approach_feed_mm_min)}") + "\n"
                     + w("G00", f"Z{f(safe)}") + "\n")
                counts["path_s"] += secs
                counts["blocks"] += blocks
                counts["axis_error_deg"] = max(counts["axis_error_deg"], getattr(m, "max_axis_error_deg", 0.0))
                counts["arcs"] += getattr(m, "arcs", 0)
                counts["radius_arcs"] += getattr(m, "radius_arc_blocks", 0)
                counts["anchors"] += getattr(m, "anchors", 0)
                counts["pieces"] += 1

            for starts, chunk in checked_chunks(chunks, n_pieces):
                for sink in also:
                    sink(chunk)
                pts = at(chunk.samples, chunk.sample_params)
                if starts:
                    if state["motion"] is not None:
                        end_piece()
                    p0, n0 = pts[0], (axes_at if rotary else normals_at)(tool_path, chunk.sample_params[:1])[0]
                    q0 = p0 + a * n0
                    turn = ()
                    if rotary:  # the table turns to the piece's first orientation at the clearance height
                        prev = state["motion"].prev_coords if state["motion"] is not None else None
                        o0 = self.orientation_coords(chunk.axes[:1], prev)[0]
                        turn = tuple(f"{k}{self.fo(v)}" for k, v in zip(self.orientation_letters(), o0))
                    text(w("G00", f"Z{f(safe)}") + "\n" + w("G00", f"X{f(q0[0])}", f"Y{f(q0[1])}", *turn) + "\n"
                         + w("G00", f"Z{f(q0[2])}") + "\n"
                         + w("G01", f"X{f(p0[0])}", f"Y{f(p0[1])}", f"Z{f(p0[2])}", f"F{ff(s.approach_feed_mm_min)}")
                         + "\n"
                         + ("G93\n" if inverse else ""))
                    if rotary:
                        state["motion"] = self.rotary_motion(tool_path, chunk.piece, write, tool_radius, ctx)
                        state["motion"].start(p0, o0)
                    else:
                        state["motion"] = self.motion(tool_path, chunk.piece, write, feed_mode, mode, tool_radius,
                                                      ctx)
                        state["motion"].start(p0)
                if rotary:
                    state["motion"].add(chunk.samples, pts, chunk.sample_params, chunk.feed_mm_min, chunk.axes)
                else:
                    state["motion"].add(chunk.samples, pts, chunk.sample_params, chunk.feed_mm_min)
                state["last"] = (pts[-1], chunk.sample_params[-1])
                counts["samples"] += len(chunk)
            if state["motion"] is not None:
                end_piece()
            n_dwell = max(len(sp.xyz), 1)
            if s.comments:
                text(_comment(f"motion blocks: {counts['blocks']} for {len(sp.xyz)} dwell points and "
                              f"{counts['samples']} machine samples; lines per dwell point "
                              f"{counts['blocks'] / n_dwell:.3f}; bytes per dwell point before this line "
                              f"{counts['bytes'] / n_dwell:.1f}") + "\n")
            text(s.postamble.rstrip("\n") + "\n%\n")
        gouge = gouge_check(tool_path, tool_radius, surface) if tool_radius > 0 else None
        appr_s = counts["pieces"] * 2 * a * 60.0 / self.approach_feed_written()
        return {"post": self.name, "file": self.filename, "mode": mode, "feed_mode": feed_mode,
                "gouge": gouge, "warnings": list(gouge["warnings"]) if gouge else [],
                "coordinates": "tool centre" if tool_radius > 0 else "contact point", "tool_radius_mm": tool_radius,
                "blending_tol_mm": tol if s.blending else None, "spindle_rpm": s.spindle_rpm,
                "clearance_z_mm": safe, "approach_mm": a, "approach_feed_mm_min": s.approach_feed_mm_min,
                "segmenting": s.segmenting if mode == "linear" else None,
                "segment_chord_tol_mm": ctx["segment_tol_mm"] if mode == "linear" else None,
                "arcs": self.uses_arcs() if mode == "linear" else None, "arc_blocks": counts["arcs"],
                "radius_arc_blocks": counts["radius_arcs"],
                "incremental": bool(s.incremental and mode == "linear" and not rotary),
                "absolute_blocks": counts["anchors"],
                "time_tol": s.time_tol, "feed_resolution": s.feed_resolution,
                "coordinate_resolution_mm": 10.0 ** -s.decimals,
                "path_time_s": counts["path_s"], "machining_time_s": counts["path_s"] + appr_s,
                "motion_blocks": counts["blocks"], "samples": counts["samples"], "bytes": counts["bytes"],
                "lines_per_dwell_point": counts["blocks"] / n_dwell, "bytes_per_dwell_point": counts["bytes"] / n_dwell,
                "pieces": counts["pieces"], "settings": dataclasses.asdict(s),
                **(self.rotary_info(counts) if rotary else {})}
