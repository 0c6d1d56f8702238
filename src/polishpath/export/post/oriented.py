"""Posts whose blocks carry the tool's orientation: one skeleton for a 5-axis control and a robot.

A block of these posts is a straight move of the tool point to a position with
a tool orientation, in a planned time: (point (3,) mm, tool axis (3,) unit,
seconds). :class:`OrientedPost` writes the program every such post shares:

    header comments (generator, parameters, the tool point, the orientation mode)
    the subclass's opening lines (e.g. TRAORI, CYCLE832; a robot's declarations)
    per piece:  to the clearance height above the approach point, tool oriented as at the first sample;
                down to the approach point, ``approach_mm`` up the tool axis from the first point;
                onto the path at the approach feed; the piece's blocks;
                back ``approach_mm`` up the tool axis at the approach feed; up to the clearance height
    the subclass's closing lines

Blocks come from the G-code's own segmenter (:class:`~polishpath.export.segment.PieceSegmenter`,
straight blocks only: every dwell point a block end or on a block, the chord and
region-time tolerances of the linear G-code); the tool axis of a block end is
the planned axis at its curve parameter (:func:`~polishpath.export.chunks.axes_at`;
vertical for a 3-axis job). The segmenter has no orientation tolerance, so a
block's orientation is exact at its ends and interpolated by the controller in
between; ``info["max_axis_dev_deg"]`` reports how far the planned axis turns
off that interpolation (the great circle between the ends, by time) at the
samples a block replaces. Approach and retract run along the tool axis (the
spindle's own direction: clear of the part whatever the tilt).

A subclass writes the words: :meth:`OrientedPost.opening`, ``closing``,
``rapid``, ``feed_move`` (approach/retract) and ``path_blocks`` (the piece's
blocks, vectorised), and says what its orientation words mean in ``orientation_lines``.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar, Iterable

import numpy as np

from ..._version import __version__
from ...errors import ExportError, ParameterError
from ...types import Surface, ToolPath
from ..chunks import SampleChunk, axes_at, checked_chunks, dwell_offsets, sample_chunks
from ..files import _bytes_out
from ..textfmt import format_fixed
from .base import GcodePost, PostSettings, _flatten_header
from .gouge import gouge_check

__all__ = ["OrientedPost", "OrientedMotion", "unit_rows", "fixed_columns", "great_circle_dev_deg",
           "VERTICAL", "AXIS_DECIMALS"]

VERTICAL = np.array([0.0, 0.0, 1.0])
#: digits after the point of a written unit vector or quaternion component (1e-6: 6e-5 degree)
AXIS_DECIMALS = 6


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


def great_circle_dev_deg(a0: np.ndarray, a1: np.ndarray, frac: np.ndarray, planned: np.ndarray) -> np.ndarray:
    """Angle, degrees, between ``planned`` (m, 3) axes and the great circle from ``a0`` to ``a1`` (m, 3 unit) at
    fractions ``frac`` (m,) of the way (a controller's vector interpolation of the orientation)."""
    c = np.clip(np.einsum("ij,ij->i", a0, a1), -1.0, 1.0)
    om = np.arccos(c)
    s = np.sin(om)
    small = s < 1e-12
    w0 = np.where(small, 1.0 - frac, np.sin((1.0 - frac) * om) / np.where(small, 1.0, s))
    w1 = np.where(small, frac, np.sin(frac * om) / np.where(small, 1.0, s))
    g = unit_rows(w0[:, None] * a0 + w1[:, None] * a1)
    return np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", g, unit_rows(planned)), -1.0, 1.0)))


class OrientedMotion:
    """The blocks of one piece: ``start``, ``add`` per chunk, ``finish`` -> (controller seconds, blocks).

    A block end whose written point and written axis both equal the previous one is merged into the next
    block (its time goes with it); the last block is held until the next is known (or the piece ends).
    """

    def __init__(self, post: "OrientedPost", segmenter, axes_fn, write):
        self.post, self.seg, self.axes_fn, self.write = post, segmenter, axes_fn, write
        self.d = post.settings.decimals
        self.w_prev = self.a_prev = None  # last written point and axis (rounded)
        self.w_seen = self.a_seen = None
        self.t_written, self.t_latest = 0.0, 0.0
        self.held = None
        self.state: dict[str, Any] = {}  # the subclass's modal state (e.g. the orientation in force)
        self.seconds, self.blocks = 0.0, 0
        self.buf_u = np.zeros(0)  # the samples since the last block end: params, planned times, axes
        self.buf_t = np.zeros(0)
        self.buf_a = np.zeros((0, 3))
        self.t_samples = 0.0
        self.last_contact = None
        self.a_end_prev = None  # the planned (unrounded) axis, parameter and time at the previous block end
        self.u_end_prev = None
        self.t_end_prev = 0.0
        self.max_dev = 0.0

    def start(self, first_point: np.ndarray, first_axis: np.ndarray) -> None:
        self.w_prev = self.w_seen = np.round(np.asarray(first_point, dtype=np.float64), self.d) + 0.0
        self.a_prev = self.a_seen = np.round(first_axis, AXIS_DECIMALS) + 0.0
        self.state = self.post.motion_state(self.w_prev, first_axis)

    def add(self, contact, driven, params, feed_mm_min, axes) -> None:
        # the planned time at each sample (as the segmenter sums it), for the orientation report
        pc = contact if self.last_contact is None else np.vstack([self.last_contact[None, :], contact])
        steps = np.linalg.norm(np.diff(pc, axis=0), axis=1) * 60.0 / np.maximum(feed_mm_min[len(contact) - len(pc) + 1:],
                                                                              1e-300)
        t = self.t_samples + np.concatenate([np.zeros(len(contact) - len(steps)), np.cumsum(steps)])
        self.t_samples, self.last_contact = float(t[-1]), contact[-1].copy()
        self.buf_u = np.concatenate([self.buf_u, params])
        self.buf_t = np.concatenate([self.buf_t, t])
        self.buf_a = np.vstack([self.buf_a, axes])
        if self.u_end_prev is None:
            self.u_end_prev, self.a_end_prev = float(params[0]), unit_rows(axes[:1])[0]
        self._ends(*self.seg.add(contact, driven, params, feed_mm_min)[:3])

    def finish(self) -> tuple[float, int]:
        self._ends(*self.seg.finish()[:3])
        if self.held is not None:
            w, a, _ = self.held
            self._emit(w[None, :], a[None, :], np.array([self.t_latest]))
            self.held = None
        return self.seconds, self.blocks

    def _report(self, U: np.ndarray, T: np.ndarray, A: np.ndarray) -> None:
        """The largest angle between the planned axes of the samples inside each block and the great circle."""
        if len(U) == 0:
            return
        inside = self.buf_u < U[-1]
        u, t, ax = self.buf_u[inside], self.buf_t[inside], self.buf_a[inside]
        self.buf_u, self.buf_t, self.buf_a = self.buf_u[~inside], self.buf_t[~inside], self.buf_a[~inside]
        ue = np.concatenate([[self.u_end_prev], U])
        te = np.concatenate([[self.t_end_prev], T])
        ae = np.vstack([self.a_end_prev[None, :], A])
        self.u_end_prev, self.t_end_prev, self.a_end_prev = float(U[-1]), float(T[-1]), A[-1]
        keep = u > ue[0]
        u, t, ax = u[keep], t[keep], ax[keep]
        if len(u) == 0:
            return
        i = np.clip(np.searchsorted(ue, u, side="left") - 1, 0, len(U) - 1)
        span = np.maximum(te[i + 1] - te[i], 1e-300)
        frac = np.clip((t - te[i]) / span, 0.0, 1.0)
        self.max_dev = max(self.max_dev, float(great_circle_dev_deg(ae[i], ae[i + 1], frac, ax).max()))

    def _ends(self, P: np.ndarray, T: np.ndarray, U: np.ndarray) -> None:
        if len(P) == 0:
            return
        A = self.axes_fn(U)
        self._report(U, T, A)
        W = np.round(P, self.d) + 0.0
        Ar = np.round(A, AXIS_DECIMALS) + 0.0
        moved = np.any(W != np.vstack([self.w_seen[None, :], W[:-1]]), axis=1) | \
            np.any(Ar != np.vstack([self.a_seen[None, :], Ar[:-1]]), axis=1)
        self.w_seen, self.a_seen = W[-1], Ar[-1]
        self.t_latest = float(T[-1])
        kw, ka, kt = W[moved], A[moved], T[moved]
        if len(kw) == 0:
            return
        if self.held is not None:
            hw, ha, ht = self.held
            kw, ka, kt = np.vstack([hw[None, :], kw]), np.vstack([ha[None, :], ka]), np.concatenate([[ht], kt])
        self.held = (kw[-1], ka[-1], float(kt[-1]))
        if len(kw) > 1:
            self._emit(kw[:-1], ka[:-1], kt[:-1])

    def _emit(self, W: np.ndarray, A: np.ndarray, T: np.ndarray) -> None:
        prev = np.vstack([self.w_prev[None, :], W[:-1]])
        dt = np.diff(np.concatenate([[self.t_written], T]))
        text, secs = self.post.path_blocks(prev, W, A, dt, self.state)
        self.write(text.encode("ascii"))
        self.seconds += secs
        self.blocks += len(W)
        self.w_prev, self.t_written = W[-1], float(T[-1])


class OrientedPost(GcodePost):
    """The skeleton of the posts whose blocks carry the tool's orientation (see the module docstring).

    Subclasses set ``own_settings`` (a frozen dataclass with ``check(where)``: the controller's own settings,
    beside :class:`~polishpath.export.post.base.PostSettings`, from the same ``[post]`` table).
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
        own = {k: v for k, v in opts.items() if k in own_names}
        self.own = dataclasses.replace(self.own_settings(), **own)
        self.own.check(f"[post] for {self.name}")

    def uses_arcs(self) -> bool:
        return False  # straight blocks: an orientation is interpolated along a line the same way by every control

    # ---------------------------------------------------------------- what a subclass writes
    def comment(self, text: str) -> str:
        clean = "".join(ch if 32 <= ord(ch) < 127 else "?" for ch in str(text))
        return f"{self.comment_mark} {clean}"

    def orientation_lines(self, three_axis: bool) -> list[str]:
        return []

    def preface(self) -> list[str]:
        """Lines before the header comments (e.g. a robot module's first line); none here."""
        return []

    def opening(self, tool_path: ToolPath, ctx: dict) -> list[str]:
        raise NotImplementedError

    def closing(self, ctx: dict) -> list[str]:
        raise NotImplementedError

    def rapid(self, point: np.ndarray, axis: np.ndarray, near_part: bool = False) -> str:
        """A positioning move (``near_part``: the straight move down to the approach point)."""
        raise NotImplementedError

    def lift(self, safe_z: float) -> str:
        """Before the first piece: straight up to the clearance height from wherever the tool is; none here."""
        return ""

    def feed_move(self, point: np.ndarray, axis: np.ndarray, feed_mm_min: float, path_follows: bool) -> str:
        """A straight move at ``feed_mm_min`` (approach: ``path_follows`` True, the path's blocks come next)."""
        raise NotImplementedError

    def motion_state(self, first_point: np.ndarray, first_axis: np.ndarray) -> dict:
        """The modal state a piece's blocks start from (after the approach move)."""
        return {}

    def path_blocks(self, prev: np.ndarray, W: np.ndarray, A: np.ndarray, dt: np.ndarray,
                    state: dict) -> tuple[str, float]:
        """The text of blocks to ``W`` (k, 3) mm with axes ``A`` (k, 3) in ``dt`` (k,) planned s, from ``prev``
        (k, 3), and the seconds the controller takes for them (from the values as written)."""
        raise NotImplementedError

    # ---------------------------------------------------------------- the file
    def axes_fn(self, tool_path: ToolPath):
        """``fn(params) -> (k, 3)`` unit tool axes: the planned axes, or vertical for a 3-axis job."""
        if axes_at(tool_path, np.zeros(0)) is None:
            return lambda u: np.tile(VERTICAL, (len(u), 1))
        return lambda u: unit_rows(axes_at(tool_path, u))

    def header(self, tool_path: ToolPath, header: dict | None, feed_mode: str, tool_radius: float, safe: float,
               n_pieces: int, ctx: dict) -> list[str]:
        sp = tool_path.surface_path
        s = self.settings
        hdr: list[tuple[str, Any]] = [("generator", f"polishpath {__version__}"), ("post", self.name)]
        hdr += _flatten_header(header or {})
        hdr += _flatten_header(tool_path.provenance.to_dict(), "smooth.")
        if sp.provenance is not None:
            hdr += _flatten_header(sp.provenance.to_dict(), "map.")
        hdr += [("tool_axis", ctx["tool_axis"]), ("dwell_points", len(sp.xyz)), ("pieces", n_pieces),
                ("tool_radius_mm", float(tool_radius)), ("safe_z_mm", safe),
                ("coordinate_resolution_mm", 10.0 ** -s.decimals), ("segment_chord_tol_mm", ctx["segment_tol_mm"]),
                ("segment_time_tol", s.time_tol), ("feed_resolution", s.feed_resolution)]
        hdr += [(k, v) for k, v in dataclasses.asdict(self.own).items()]
        lines = [self.comment(f"{k}: {v}") for k, v in hdr]
        if self.label:
            lines.append(self.comment(self.label))
        point = (f"TOOL POINT: the centre of the ball/sponge tool, {tool_radius:g} mm from the contact point along "
                 "the surface normal; set the tool length to that centre" if tool_radius > 0 else
                 "TOOL POINT: the tool-part contact point; set the tool length to the tool's contact point")
        lines.append(self.comment(point))
        lines += [self.comment(t) for t in self.orientation_lines(ctx["three_axis"])]
        lines.append(self.comment("BLOCKS: straight moves, every dwell point a block end or on a block within "
                                  f"{ctx['segment_tol_mm']:g} mm; no orientation tolerance: the tool axis is exact at "
                                  "block ends and interpolated by the control between them"))
        return lines

    def write(self, tool_path: ToolPath, file, *, mode: str | None = None, tool_radius: float = 0.0,
              header: dict | None = None, surface: Surface | None = None, chunks: Iterable[SampleChunk] | None = None,
              also: tuple = ()) -> dict[str, Any]:
        mode = self.check(mode=mode, tool_radius=tool_radius)
        tool_radius = float(tool_radius)
        feed_mode = self.feed_mode(tool_radius)
        s = self.settings
        sp = tool_path.surface_path
        doff = dwell_offsets(tool_path)
        n_pieces = len(doff) - 1
        axes_fn = self.axes_fn(tool_path)
        three_axis = axes_at(tool_path, np.zeros(0)) is None
        ctx = {"dwell_offsets": doff, "segment_tol_mm": self.segment_tol(tool_path), "three_axis": three_axis,
               "tool_axis": getattr(sp, "tool_axis", "z"), "chord_tol_mm": self.chord_tol(tool_path)}
        a = s.approach_mm
        ends = np.concatenate([doff[:-1], doff[1:] - 1])
        up = unit_rows(sp.normals[ends]) * tool_radius + a * axes_fn(tool_path.dwell_params[ends])
        zmax = max(self.reach_z(tool_path, tool_radius, ctx), float(np.max((sp.xyz[ends] + up)[:, 2]))
                   if len(ends) else 0.0, 0.0)
        safe = zmax + s.clearance_mm
        at = self.driven(tool_path, tool_radius)
        chunks = sample_chunks(tool_path) if chunks is None else chunks
        counts = {"bytes": 0, "samples": 0, "blocks": 0, "path_s": 0.0, "pieces": 0, "dev": 0.0}
        with _bytes_out(file) as raw:

            def write(b: bytes) -> None:
                counts["bytes"] += len(b)
                raw(b)

            def text(t: str) -> None:
                if t:
                    write((t.rstrip("\n") + "\n").encode("ascii"))

            text("\n".join(self.preface()))
            if s.comments:
                text("\n".join(self.header(tool_path, header, feed_mode, tool_radius, safe, n_pieces, ctx)))
            text("\n".join(self.opening(tool_path, ctx)))
            state: dict[str, Any] = {"motion": None, "last": None}

            def end_piece() -> None:
                m, (p1, a1) = state["motion"], state["last"]
                secs, blocks = m.finish()
                q1 = p1 + a * a1
                text(self.feed_move(q1, a1, s.approach_feed_mm_min, False))
                text(self.rapid(np.array([q1[0], q1[1], safe]), a1))
                counts["path_s"] += secs
                counts["blocks"] += blocks
                counts["pieces"] += 1
                counts["dev"] = max(counts["dev"], m.max_dev)

            for starts, chunk in checked_chunks(chunks, n_pieces):
                for sink in also:
                    sink(chunk)
                pts = at(chunk.samples, chunk.sample_params)
                ax = axes_fn(chunk.sample_params)
                if starts:
                    if state["motion"] is not None:
                        end_piece()
                    else:
                        text(self.lift(safe))
                    p0, a0 = pts[0], ax[0]
                    q0 = p0 + a * a0
                    text("\n".join([self.rapid(np.array([q0[0], q0[1], safe]), a0), self.rapid(q0, a0, near_part=True),
                                    self.feed_move(p0, a0, s.approach_feed_mm_min, True)]))
                    seg = GcodePost.motion(self, tool_path, chunk.piece, None, feed_mode, "linear", tool_radius,
                                           ctx).seg
                    state["motion"] = OrientedMotion(self, seg, axes_fn, write)
                    state["motion"].start(p0, a0)
                state["motion"].add(chunk.samples, pts, chunk.sample_params, chunk.feed_mm_min, ax)
                state["last"] = (pts[-1], ax[-1])
                counts["samples"] += len(chunk)
            if state["motion"] is not None:
                end_piece()
            n_dwell = max(len(sp.xyz), 1)
            if s.comments:
                text(self.comment(f"motion blocks: {counts['blocks']} for {len(sp.xyz)} dwell points and "
                                  f"{counts['samples']} machine samples; largest angle of the planned tool axis off "
                                  f"the control's interpolation inside a block {counts['dev']:.4f} deg"))
            text("\n".join(self.closing(ctx)))
        if counts["pieces"] == 0:
            raise ExportError(f"The {self.name} post got no machine samples to write.",
                              "Give the tool path's samples (or its chunks).")
        gouge = gouge_check(tool_path, tool_radius, surface) if tool_radius > 0 else None
        appr_s = counts["pieces"] * 2 * a * 60.0 / self.approach_feed_written()
        return {"post": self.name, "file": self.filename, "mode": mode, "feed_mode": feed_mode,
                "gouge": gouge, "warnings": list(gouge["warnings"]) if gouge else [],
                "coordinates": "tool centre" if tool_radius > 0 else "contact point", "tool_radius_mm": tool_radius,
                "tool_axis": ctx["tool_axis"], "three_axis": three_axis,
                "clearance_z_mm": safe, "approach_mm": a, "approach_feed_mm_min": s.approach_feed_mm_min,
                "segmenting": "chord", "segment_chord_tol_mm": ctx["segment_tol_mm"], "arcs": False,
                "time_tol": s.time_tol, "feed_resolution": s.feed_resolution,
                "coordinate_resolution_mm": 10.0 ** -s.decimals, "max_axis_dev_deg": counts["dev"],
                "path_time_s": counts["path_s"], "machining_time_s": counts["path_s"] + appr_s,
                "motion_blocks": counts["blocks"], "samples": counts["samples"], "bytes": counts["bytes"],
                "lines_per_dwell_point": counts["blocks"] / n_dwell, "bytes_per_dwell_point": counts["bytes"] / n_dwell,
                "pieces": counts["pieces"], "settings": {**dataclasses.asdict(s), **dataclasses.asdict(self.own)}}
