"""The post-processors' settings: one schema, every field from a ``[post]`` table (:class:`PostSettings`).

Split from :mod:`polishpath.export.post.base` (which re-exports it) to keep that module small.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from ...defaults import DEFAULT_ORIENTATION_TOL_DEG, DEFAULT_RPM
from ...errors import ParameterError

__all__ = ["PostSettings", "FEED_MODES", "SEGMENT_TOL_OF_SPACING", "SEGMENTINGS"]

FEED_MODES = ("auto", "inverse-time", "per-minute")
#: the G-code's default segment tolerance: this fraction of the dwell-point spacing on the part (and never
#: below the smoothing stage's chord tolerance; docs/machine-output.md says why)
SEGMENT_TOL_OF_SPACING = 0.01
SEGMENTINGS = ("chord", "period")


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
    decimals : int
        Digits after the decimal point of coordinates (mm; 4: a coordinate resolution of 0.1 um).
    feed_decimals : int or None
        Digits after the decimal point of F; None (default): the digits ``feed_resolution``
        needs, F rounded to the largest power of ten within twice ``feed_resolution`` of it
        (F300.4, F577; :func:`~polishpath.export.post.blocks.round_feeds`), trailing zeros dropped.
        The blocks' times are computed from the F as written.
    word_separator : str
        Between the words of a motion block: "" (default, ``G3X1.2Y-3.4I.5J.1F300.4``:
        LinuxCNC and Fanuc read it) or " ".
    leading_zero : bool
        Write the zero before the point of a number below 1 (``X0.5``; default false: ``X.5``).
    trailing_zeros : bool
        Write every decimal of a coordinate (``X1.2000``; default false: ``X1.2``).
    integer_point : bool
        With trailing zeros dropped, a whole-number coordinate keeps its point (``X10.``): a Fanuc
        control without calculator-type decimal input reads ``X10`` as 10 increments (0.01 mm).
        Default false (LinuxCNC; a zero is written ``0``); the fanuc post's default true.
    segmenting : {"chord", "period"}
        ``chord`` (default): blocks merge consecutive machine samples while the
        chord and time tolerances hold, every dwell point a block end
        (:mod:`polishpath.export.segment`); ``period``: one G01 block per sample at
        the constant interpolation period.
    arcs : bool
        With ``chord`` segmenting: helical arcs (G02/G03 in G17, Z linear along
        them, centre as incremental I J) where one fits, else G01 (default: true);
        false: G01 only.
    radius_arcs : bool
        Write an arc in radius form (``G2 X Y R``, one word for the two of ``I J``) where the centre the
        controller derives from the written end points and R keeps the written arc within one resolution of
        the fitted one (beyond the end points' own rounding) and it turns less than 171 degrees (a positive R
        is the shorter arc, LinuxCNC's and Fanuc's rule); else ``I J`` (default: true).
    incremental : bool
        Inside a piece, write the axis words as G91 distances from the previous block's end (each the
        difference of two positions rounded to the resolution: no rounding accumulates), with a G90 block of
        absolute words every ``anchor_blocks`` blocks and as the piece's last block (default: true). A
        program restarted mid-way must start at a G90 block; false: G90 throughout.
    anchor_blocks : int
        With ``incremental``: blocks from one absolute (G90) block to the next (default 500).
    dwell_block_ends : bool
        With ``chord`` segmenting: true ends a block at every dwell point; false (default) lets a block
        pass through a dwell point that lies on it (1e-9 mm before rounding, within the coordinate
        resolution as written: an arc through its start, the dwell point and its end, Z linear along it),
        so a block may run from one region boundary to the next.
    chord_tol_mm : float or None
        Largest distance of the smooth curve from a merged block, mm; None (default):
        :data:`SEGMENT_TOL_OF_SPACING` (1 %) of the dwell-point spacing on the part
        (5 um at 0.5 mm), at least the smoothing stage's chord tolerance (1 um by default).
    time_tol : float
        Largest relative difference between the time the G-code spends around a
        dwell point (its region) and the schedule, 0.01 = 1 %.
    feed_resolution : float
        G94: F is written again only when a block's feed differs from the F in
        force by more than this fraction of it (0.001 = 0.1 %; its share of
        ``time_tol`` is kept free for it). G93 writes F on every block.
    orientation_tol_deg : float
        5-axis: most the tool axis the controller makes along a merged block (from its
        interpolated rotary words) may leave the planned axis, degrees (default 0.005).
    orientation_decimals : int
        5-axis: digits after the point of the orientation words (degrees; 4: 0.0001 degree).
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
    spindle_rpm: float = DEFAULT_RPM
    coolant_on: str = "M8"
    clearance_mm: float = 5.0
    approach_mm: float = 2.0
    approach_feed_mm_min: float = 300.0
    feed_mode: str = "auto"
    decimals: int = 4
    feed_decimals: int | None = None
    word_separator: str = ""
    leading_zero: bool = False
    trailing_zeros: bool = False
    integer_point: bool = False
    segmenting: str = "chord"
    arcs: bool = True
    radius_arcs: bool = True
    incremental: bool = True
    anchor_blocks: int = 500
    dwell_block_ends: bool = False
    chord_tol_mm: float | None = None
    time_tol: float = 0.01
    feed_resolution: float = 0.001
    orientation_tol_deg: float = DEFAULT_ORIENTATION_TOL_DEG
    orientation_decimals: int = 4
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
        for name in ("preamble", "safety_block", "blending", "coolant_on", "postamble", "feed_mode", "word_separator"):
            if not isinstance(getattr(self, name), str):
                raise ParameterError(f"{where}: {name} must be text, got {getattr(self, name)!r}.")
        for name in ("spindle_rpm", "clearance_mm", "approach_mm", "approach_feed_mm_min"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise ParameterError(f"{where}: {name} must be a number >= 0, got {v!r}.")
        if self.approach_feed_mm_min <= 0:
            raise ParameterError(f"{where}: approach_feed_mm_min must be > 0 mm/min, got {self.approach_feed_mm_min!r}.")
        o = self.orientation_tol_deg
        if isinstance(o, bool) or not isinstance(o, (int, float)) or not math.isfinite(o) or not 0 < o < 10:
            raise ParameterError(f"{where}: orientation_tol_deg must be a number of degrees in (0, 10), got {o!r}.")
        for name in ("decimals", "feed_decimals", "orientation_decimals"):
            v = getattr(self, name)
            if v is None and name == "feed_decimals":
                continue
            if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= 9:
                raise ParameterError(f"{where}: {name} must be a whole number 0..9"
                                     + (" (or left out: the digits feed_resolution needs)" if name == "feed_decimals"
                                        else "") + f", got {v!r}.")
        if self.word_separator not in ("", " "):
            raise ParameterError(f"{where}: word_separator must be \"\" (none) or \" \" (a space), "
                                 f"got {self.word_separator!r}.")
        for name in ("leading_zero", "trailing_zeros", "integer_point"):
            if not isinstance(getattr(self, name), bool):
                raise ParameterError(f"{where}: {name} must be true or false, got {getattr(self, name)!r}.")
        if self.segmenting not in SEGMENTINGS:
            raise ParameterError(f"{where}: segmenting must be one of {', '.join(SEGMENTINGS)}, got {self.segmenting!r}.")
        c = self.chord_tol_mm
        if c is not None and (isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c) or c <= 0):
            raise ParameterError(f"{where}: chord_tol_mm must be a number of mm > 0 (or left out), got {c!r}.")
        for name in ("time_tol", "feed_resolution"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not 0 < v < 1:
                raise ParameterError(f"{where}: {name} must be a fraction between 0 and 1, got {v!r}.")
        if self.feed_resolution >= self.time_tol:
            raise ParameterError(f"{where}: feed_resolution ({self.feed_resolution}) must be smaller than time_tol "
                                 f"({self.time_tol}): a block may run off its time by feed_resolution.",
                                 "Lower feed_resolution or raise time_tol.")
        if self.feed_mode not in FEED_MODES:
            raise ParameterError(f"{where}: feed_mode must be one of {', '.join(FEED_MODES)}, got {self.feed_mode!r}.")
        if self.program_number is not None and (isinstance(self.program_number, bool) or
                                                not isinstance(self.program_number, int) or
                                                not 1 <= self.program_number <= 9999):
            raise ParameterError(f"{where}: program_number must be 1..9999, got {self.program_number!r}.")
        a = self.anchor_blocks
        if isinstance(a, bool) or not isinstance(a, int) or not 1 <= a <= 10**9:
            raise ParameterError(f"{where}: anchor_blocks must be a whole number of blocks >= 1, got {a!r}.")
        for name in ("arcs", "dwell_block_ends", "radius_arcs", "incremental"):
            if not isinstance(getattr(self, name), bool):
                raise ParameterError(f"{where}: {name} must be true or false, got {getattr(self, name)!r}.")
        if not isinstance(self.comments, bool):
            raise ParameterError(f"{where}: comments must be true or false, got {self.comments!r}.")
