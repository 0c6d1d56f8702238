"""Posts whose blocks carry the tool's orientation in their own words: one skeleton for a 5-axis control and a robot.

A block of these posts is a straight move of the tool point to a position with
orientation words (a tool vector, a quaternion), in a planned time.
:class:`OrientedPost` writes the program every such post shares:

    header comments (generator, parameters, the tool point, the orientation mode)
    the subclass's opening lines (e.g. TRAORI, CYCLE832; a robot's declarations)
    per piece:  to the clearance height above the approach point, tool oriented as at the first sample;
                straight down to the approach point, ``approach_mm`` up the tool axis from the first point;
                onto the path at the approach feed; the piece's blocks;
                back ``approach_mm`` up the tool axis at the approach feed; up to the clearance height
    the subclass's closing lines

The blocks are the 5-axis segmenting of the post base's rotary-words hook
(:class:`~polishpath.export.post.rotary.RotaryMotion`: straight blocks, every
dwell point a block end, merged while every replaced point stays within the
chord tolerance and the tool axis the control interpolates from the words within
``orientation_tol_deg`` of the planned axis); :class:`OrientedMotion` hands each
run of blocks to the post's :meth:`OrientedPost.path_blocks`, which writes them
(a robot's move is not a G-code line) and says how long the controller takes.
The tool axes are the path's (``--tool-axis``; vertical for a 3-axis job).
Approach and retract run along the tool axis (the spindle's own direction:
clear of the part whatever the tilt).
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar, Iterable

import numpy as np

from ...errors import ExportError, ParameterError
from ...types import Surface, ToolPath
from ..chunks import SampleChunk, axes_at, checked_chunks, dwell_offsets, sample_chunks
from ..files import _bytes_out
from ..textfmt import format_fixed
from .base import GcodePost, PostSettings, offset_along_normals, provenance_header
from .gouge import gouge_check
from .rotary import RotaryMotion

__all__ = ["OrientedPost", "OrientedMotion", "unit_rows", "fixed_columns", "VERTICAL"]

VERTICAL = np.array([0.0, 0.0, 1.0])


def unit_rows(v: np.ndarray) -> np.ndarray:
    """Rows of ``v`` (k, 3) scaled to unit length."""
    v = np.asarray(v, dtype=np.float64)
    return v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-300)


def fixed_columns(values: np.ndarray, decimals: int, style: int = 0) -> list[list[str]]:
    """Each column of ``values`` (k, c) as its k texts (:func:`~polishpath.export.textfmt.format_fixed`:
    compiled, as Python's ``%.{decimals}f`` with the number style bits)."""
    v = np.atleast_2d(np.asarray(values, dtype=np.float64))
    if len(v) == 0:
        return [[] for _ in range(v.shape[1])]
    return [format_fixed(v[:, c:c + 1], [decimals], styles=[style]).decode("ascii").split("\n")[:-1]
            for c in range(v.shape[1])]


class OrientedMotion(RotaryMotion):
    """The 5-axis blocks of one piece (:class:`~polishpath.export.post.rotary.RotaryMotion`: straight blocks under
    the chord and orientation tolerances, every dwell point a block end), written by the post's
    :meth:`OrientedPost.path_blocks` (a robot's move is not a G-code line).

    A block whose written point and orientation words both equal the previous one's is merged into the next
    (its time goes with it).
    """

    def __init__(self, post: "OrientedPost", write, **kw):
        super().__init__(post, write, **kw)
        self.state: dict[str, Any] = {}

    def start(self, first_point: np.ndarray, first_coords: np.ndarray) -> None:
        super().start(first_point, first_coords)
        self.state = {"coords": self.q_prev}

    def _emit(self, P: np.ndarray, T: np.ndarray, Q: np.ndarray, V: np.ndarray) -> None:
        W = np.round(P, self.d) + 0.0
        R = np.round(Q, self.od) + 0.0
        moved = np.any(W != np.vstack([self.w_prev[None, :], W[:-1]]), axis=1) | \
            np.any(R != np.vstack([self.q_prev[None, :], R[:-1]]), axis=1)
        W, R, T, V = W[moved], R[moved], T[moved], V[moved]
        if len(W) == 0:
            return
        rebuilt = self.post.axes_from_coords(R)
        cosang = np.clip(np.einsum("ij,ij->i", rebuilt, unit_rows(V)), -1.0, 1.0)
        self.max_axis_error_deg = max(self.max_axis_error_deg, float(np.degrees(np.arccos(cosang)).max()))
        prev = np.vstack([self.w_prev[None, :], W[:-1]])
        dt = np.diff(np.concatenate([[self.t_written], T]))
        text, secs = self.post.path_blocks(prev, W, R, dt, self.state)
        if self.write is not None:
            self.write(text.encode("ascii"))
        self.seconds += secs
        self.blocks += len(W)
        self.w_prev, self.q_prev, self.t_written = W[-1], R[-1], float(T[-1])
        self.state["coords"] = R[-1]


class OrientedPost(GcodePost):
    """The skeleton of the posts whose blocks carry the tool's orientation (see the module docstring).

    A subclass gives the rotary-words hook of the post base (:meth:`orientation_letters`,
    :meth:`orientation_coords`, :meth:`axes_from_coords`: its orientation words, e.g. a tool vector or a
    quaternion) and writes the lines (:meth:`opening`, :meth:`closing`, :meth:`rapid`, :meth:`feed_move`,
    :meth:`path_blocks`). ``own_settings``: a frozen dataclass with ``check(where)``, the controller's own
    settings beside :class:`~polishpath.export.post.base.PostSettings`, from the same ``[post]`` table.
    """

    own_settings: ClassVar[type] = type(None)
    comment_mark: ClassVar[str] = ";"
    writes_axes: ClassVar[bool] = True

    def __init__(self, settings: PostSettings | dict[str, Any] | None = None, kinematics=None):
        opts = {} if settings is None or isinstance(settings, PostSettings) else settings
        if not isinstance(opts, dict):
            raise ParameterError(f"[post] for {self.name} must be a table of settings, got {type(opts).__name__}.")
        own_names = [f.name for f in dataclasses.fields(self.own_settings)]
        unknown = sorted(set(opts) - set(PostSettings.names()) - set(own_names))
        if unknown:
            raise ParameterError(f"[post] for {self.name}: unknown post setting(s) {', '.join(unknown)}.",
                                 f"Settings: {', '.join(PostSettings.names() + own_names)}.")
        super().__init__(settings if isinstance(settings, PostSettings) else
                         {k: v for k, v in opts.items() if k not in own_names}, kinematics=kinematics)
        self.own = dataclasses.replace(self.own_settings(), **{k: v for k, v in opts.items() if k in own_names})
        self.own.check(f"[post] for {self.name}")

    def uses_arcs(self) -> bool:
        return False  # straight blocks: the orientation changes along them

    def feed_mode(self, tool_radius: float, rotary: bool = False) -> str:
        return "inverse-time"  # a subclass refuses what it cannot write in its __init__

    # ---------------------------------------------------------------- what a subclass writes
    def comment(self, text: str) -> str:
        clean = "".join(ch if 32 <= ord(ch) < 127 else "?" for ch in str(text))
        return f"{self.comment_mark} {clean}"

    def orientation_lines(self, three_axis: bool) -> list[str]:
        """Header lines saying what the orientation words mean and how the time is kept."""
        return []

    def preface(self) -> list[str]:
        """Lines before the header comments (e.g. a robot module's first line); none here."""
        return []

    def opening(self, tool_path: ToolPath, ctx: dict) -> list[str]:
        raise NotImplementedError

    def closing(self, ctx: dict) -> list[str]:
        raise NotImplementedError

    def rapid(self, point: np.ndarray, coords: np.ndarray, near_part: bool = False) -> str:
        """A positioning move to ``point`` with orientation words ``coords`` (``near_part``: the straight move
        down to the approach point)."""
        raise NotImplementedError

    def lift(self, safe_z: float) -> str:
        """Before the first piece: straight up to the clearance height from wherever the tool is; none here."""
        return ""

    def feed_move(self, point: np.ndarray, coords: np.ndarray, feed_mm_min: float, path_follows: bool) -> str:
        """A straight move at ``feed_mm_min`` (approach: ``path_follows`` True, the path's blocks come next)."""
        raise NotImplementedError

    def path_blocks(self, prev: np.ndarray, W: np.ndarray, R: np.ndarray, dt: np.ndarray,
                    state: dict) -> tuple[str, float]:
        """The text of blocks to ``W`` (k, 3) mm with orientation words ``R`` (k, r) (rounded, as written) in
        ``dt`` (k,) planned s, from ``prev`` (k, 3) and ``state["coords"]`` (the words in force), and the
        seconds the controller takes for them (from the values as written)."""
        raise NotImplementedError

    # ---------------------------------------------------------------- the file
    def axes_fn(self, tool_path: ToolPath):
        """``fn(params) -> (k, 3)`` unit tool axes: the planned axes, or vertical for a 3-axis job."""
        if tool_path.surface_path.tool_axes is None:
            return lambda u: np.tile(VERTICAL, (len(u), 1))
        return lambda u: unit_rows(axes_at(tool_path, u))

    def header(self, tool_path: ToolPath, header: dict | None, tool_radius: float, safe: float, n_pieces: int,
               ctx: dict) -> list[str]:
        sp = tool_path.surface_path
        s = self.settings
        hdr = provenance_header(self.name, tool_path, header)
        hdr += [("tool_axis", sp.tool_axis), ("dwell_points", len(sp.xyz)), ("pieces", n_pieces),
                ("tool_radius_mm", float(tool_radius)), ("safe_z_mm", safe),
                ("coordinate_resolution_mm", 10.0 ** -s.decimals), ("segment_chord_tol_mm", ctx["segment_tol_mm"]),
                ("orientation_tol_deg", s.orientation_tol_deg), ("orientation_decimals", s.orientation_decimals),
                ("feed_resolution", s.feed_resolution)]
        hdr += list(dataclasses.asdict(self.own).items())
        lines = [self.comment(f"{k}: {v}") for k, v in hdr]
        if self.label:
            lines.append(self.comment(self.label))
        lines.append(self.comment(
            f"TOOL POINT: the centre of the ball/sponge tool, {tool_radius:g} mm from the contact point along the "
            "surface normal; set the tool length to that centre" if tool_radius > 0 else
            "TOOL POINT: the tool-part contact point; set the tool length to the tool's contact point"))
        lines += [self.comment(t) for t in self.orientation_lines(ctx["three_axis"])]
        lines.append(self.comment(
            f"BLOCKS: straight moves, every dwell point a block end; between block ends the path within "
            f"{ctx['segment_tol_mm']:g} mm and the tool axis the control interpolates within "
            f"{s.orientation_tol_deg:g} deg of the plan"))
        return lines

    def write(self, tool_path: ToolPath, file, *, mode: str | None = None, tool_radius: float = 0.0,
              header: dict | None = None, surface: Surface | None = None, chunks: Iterable[SampleChunk] | None = None,
              also: tuple = ()) -> dict[str, Any]:
        sp = tool_path.surface_path
        three_axis = sp.tool_axes is None
        mode = self.check(mode=mode, tool_radius=tool_radius, tool_axes=not three_axis)
        tool_radius = float(tool_radius)
        s = self.settings
        doff = dwell_offsets(tool_path)
        n_pieces = len(doff) - 1
        axes_fn = self.axes_fn(tool_path)
        dwell_axes = axes_fn(tool_path.dwell_params) if three_axis else unit_rows(sp.tool_axes)
        ctx = {"segment_tol_mm": self.segment_tol(tool_path), "three_axis": three_axis,
               "chord_tol_mm": self.chord_tol(tool_path)}
        a = s.approach_mm
        ends = np.concatenate([doff[:-1], doff[1:] - 1])
        up = unit_rows(sp.normals[ends]) * tool_radius + a * dwell_axes[ends]
        zmax = max(self.reach_z(tool_path, tool_radius, ctx), float(np.max((sp.xyz[ends] + up)[:, 2]))
                   if len(ends) else 0.0, 0.0)
        safe = zmax + s.clearance_mm
        at = self.driven(tool_path, tool_radius)
        chunks = sample_chunks(tool_path) if chunks is None else chunks
        counts = {"bytes": 0, "samples": 0, "blocks": 0, "path_s": 0.0, "pieces": 0, "axis_error_deg": 0.0}
        with _bytes_out(file) as raw:

            def write(b: bytes) -> None:
                counts["bytes"] += len(b)
                raw(b)

            def text(t: str) -> None:
                if t:
                    write((t.rstrip("\n") + "\n").encode("ascii"))

            text("\n".join(self.preface()))
            if s.comments:
                text("\n".join(self.header(tool_path, header, tool_radius, safe, n_pieces, ctx)))
            text("\n".join(self.opening(tool_path, ctx)))
            state: dict[str, Any] = {"motion": None, "last": None, "coords": None}

            def end_piece() -> None:
                m, (p1, a1) = state["motion"], state["last"]
                secs, blocks = m.finish()
                q1 = p1 + a * a1
                text(self.feed_move(q1, m.q_prev, s.approach_feed_mm_min, False))
                text(self.rapid(np.array([q1[0], q1[1], safe]), m.q_prev))
                state["coords"] = m.prev_coords
                counts["path_s"] += secs
                counts["blocks"] += blocks
                counts["pieces"] += 1
                counts["axis_error_deg"] = max(counts["axis_error_deg"], m.max_axis_error_deg)

            for starts, chunk in checked_chunks(chunks, n_pieces):
                for sink in also:
                    sink(chunk)
                pts = at(chunk.samples, chunk.sample_params)
                ax = axes_fn(chunk.sample_params) if three_axis or chunk.axes is None else unit_rows(chunk.axes)
                if starts:
                    if state["motion"] is not None:
                        end_piece()
                    else:
                        text(self.lift(safe))
                    p0 = pts[0]
                    q0 = p0 + a * ax[0]
                    o0 = self.orientation_coords(ax[:1], state["coords"])[0]
                    text("\n".join([self.rapid(np.array([q0[0], q0[1], safe]), o0),
                                    self.rapid(q0, o0, near_part=True),
                                    self.feed_move(p0, o0, s.approach_feed_mm_min, True)]))
                    da, db = doff[chunk.piece], doff[chunk.piece + 1]
                    dpts = sp.xyz[da:db] if tool_radius == 0 else offset_along_normals(sp.xyz[da:db], sp.normals[da:db],
                                                                                       tool_radius)
                    m = OrientedMotion(self, write, dwell_params=tool_path.dwell_params[da:db], dwell_points=dpts,
                                       dwell_axes=dwell_axes[da:db], chord_tol_mm=ctx["segment_tol_mm"],
                                       orientation_tol_deg=s.orientation_tol_deg, decimals=s.decimals,
                                       orientation_decimals=s.orientation_decimals, feed_decimals=s.feed_decimals,
                                       feed_resolution=s.feed_resolution, styles=self.styles())
                    m.start(p0, o0)
                    state["motion"] = m
                state["motion"].add(chunk.samples, pts, chunk.sample_params, chunk.feed_mm_min, ax)
                state["last"] = (pts[-1], ax[-1])
                counts["samples"] += len(chunk)
            if state["motion"] is not None:
                end_piece()
            n_dwell = max(len(sp.xyz), 1)
            if s.comments:
                text(self.comment(f"motion blocks: {counts['blocks']} for {len(sp.xyz)} dwell points and "
                                  f"{counts['samples']} machine samples; largest angle between the planned and "
                                  f"the written tool axis at a block end {counts['axis_error_deg']:.5f} deg"))
            text("\n".join(self.closing(ctx)))
        if counts["pieces"] == 0:
            raise ExportError(f"The {self.name} post got no machine samples to write.",
                              "Give the tool path's samples (or its chunks).")
        gouge = gouge_check(tool_path, tool_radius, surface) if tool_radius > 0 else None
        appr_s = counts["pieces"] * 2 * a * 60.0 / self.approach_feed_written()
        return {"post": self.name, "file": self.filename, "mode": mode, "feed_mode": self.feed_mode(tool_radius),
                "gouge": gouge, "warnings": list(gouge["warnings"]) if gouge else [],
                "coordinates": "tool centre" if tool_radius > 0 else "contact point", "tool_radius_mm": tool_radius,
                "tool_axis": sp.tool_axis, "three_axis": three_axis,
                "clearance_z_mm": safe, "approach_mm": a, "approach_feed_mm_min": s.approach_feed_mm_min,
                "segmenting": "chord", "segment_chord_tol_mm": ctx["segment_tol_mm"], "arcs": False,
                "feed_resolution": s.feed_resolution, "coordinate_resolution_mm": 10.0 ** -s.decimals,
                "orientation_words": list(self.orientation_letters()), "orientation_tol_deg": s.orientation_tol_deg,
                "axis_error_at_block_ends_deg": counts["axis_error_deg"],
                "path_time_s": counts["path_s"], "machining_time_s": counts["path_s"] + appr_s,
                "motion_blocks": counts["blocks"], "samples": counts["samples"], "bytes": counts["bytes"],
                "lines_per_dwell_point": counts["blocks"] / n_dwell, "bytes_per_dwell_point": counts["bytes"] / n_dwell,
                "pieces": counts["pieces"], "settings": {**dataclasses.asdict(s), **dataclasses.asdict(self.own)}}
