"""The job's options: one dataclass, one parser, one table of command-line flags.

:class:`JobConfig` holds every option of the main job. Command-line flags, a
job TOML (``[job]`` table) and keyword arguments of :func:`polishpath.run`
all become a ``JobConfig`` through one parser, :func:`parse_job`, which checks
every value against its field (type, range, choices) and names the option in
its message.

Adding an option
----------------
Add one field to :class:`JobConfig` with :func:`option` (its default, its
command-line flag(s), its help text, and a check: ``positive``, ``nonnegative``
or ``choices``), then use ``cfg.<name>`` where the job needs it
(:func:`polishpath.pipeline.run`). Nothing else: ``polishpath plan`` gets the
flag (its options are built from :data:`CLI_OPTIONS`), ``job.toml`` writes and
reads the key, ``polishpath.run(name=...)`` takes it, and the summary records
it. An option without a flag (``flags=()``) is set in a job TOML or from
Python only.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from .defaults import (
    DEFAULT_CHORD_TOL_MM,
    DEFAULT_DWELL_POINTS,
    DEFAULT_FEED_MM_MIN,
    DEFAULT_FLATTEN_METHOD,
    DEFAULT_INTEGRATOR,
    DEFAULT_MAX_OVERSAMPLING,
    DEFAULT_MAX_POINTS,
    DEFAULT_PERIOD_MS,
    DEFAULT_SPACING_MM,
    INTEGRATOR_NAMES,
)
from .errors import ParameterError, SpecError
from .resources import STREAM_ABOVE_SAMPLES


def option(default: Any, *flags: str, help: str, positive: bool = False, nonnegative: bool = False,
           choices: tuple[str, ...] | None = None, parse: Callable[[str], Any] | None = None,
           cli_type: Any = None) -> Any:
    """A :class:`JobConfig` field with what the command line and the checks need.

    Parameters
    ----------
    default
        Value when not given.
    *flags
        Command-line flags (``"--spacing", "-s"``; a ``"--x/--no-x"`` pair for a
        switch); none: TOML / Python only.
    help
        One line for ``--help``, with the unit.
    positive, nonnegative, choices
        The check :func:`parse_job` applies to a given value.
    parse, cli_type
        For a value the command line gives as text of another shape: the flag's
        type (``str``) and the function turning the text into the value.
    """
    meta = {"flags": flags, "help": help, "positive": positive, "nonnegative": nonnegative,
            "choices": choices, "parse": parse, "cli_type": cli_type}
    return field(default=default, metadata=meta)


def parse_pair(text: str, opt: str = "--start", what: str = "'u,v' in mm") -> tuple[float, float]:
    """Two numbers ``'a,b'`` from the command line (``what`` says which, for the message)."""
    try:
        a, b = (float(x) for x in text.split(","))
    except ValueError:
        raise ParameterError(f"{opt} takes two numbers {what}, got {text!r}.") from None
    return a, b


def remesh_choice(text: str) -> str:
    """``--remesh`` text checked: ``auto``, ``off`` or a positive edge length in mm (as given)."""
    t = str(text).strip().lower()
    if t in ("auto", "off"):
        return t
    try:
        ok = math.isfinite(float(t)) and float(t) > 0
    except ValueError:
        ok = False
    if not ok:
        raise ParameterError(f"--remesh must be auto, off or an edge length in mm, got {text!r}.",
                             "auto (default) refines CAD-style sliver meshes only; off keeps the mesh; "
                             "a number (e.g. 0.5) refines every edge longer than that many mm.")
    return t


def tool_axis_choice(text: str) -> str:
    """``--tool-axis`` text checked (:func:`polishpath.axes.parse_tool_axis`), as its canonical spec."""
    from .axes import parse_tool_axis

    return parse_tool_axis(text).spec


@dataclass(frozen=True)
class JobConfig:
    """Every option of the main job. Lengths in mm, feed in mm/min, period in ms.

    Attributes
    ----------
    surface : str
        SURFACE as on the command line (mesh path, built-in spec, ``.toml``).
    units, scale, component
        Mesh-file options (see :func:`polishpath.surfaces.load_mesh`).
    method : str
        Flattening (:data:`polishpath.flatten.METHODS`): ``mabf`` (default), ``abf``, ``lscm``, ``projection``.
    pattern : str
        Path pattern (:data:`polishpath.plan.PATTERNS`): ``pseudorandom`` (default), ``raster``, ``spiral``,
        ``rectangular``, or a peer of the paper's Table 3: ``unicursal``, ``maze``, ``fractal``, ``hilbert``.
    dwell_points : {"grid", "blue-noise"}
        The dwell-point set (:data:`polishpath.plan.points.DWELL_POINT_SETS`): ``grid``, the paper's
        square grid (default); ``blue-noise``, a Poisson-disk set without a lattice at the same density,
        walked by the pseudo-random path along its planar neighbour graph.
    spacing : float
        Dwell-point spacing, mm. Honoured on the part by default (see ``spacing_on``).
    spacing_on : {"surface", "plane"}
        ``surface``: the planar spacing is reduced so that no step on the part
        exceeds sqrt(2) x spacing; ``plane``: plain planar grid of that spacing.
    seed : int or None
        Seed of the random walk; None draws one (and records it).
    start : (u, v) or None
        Planar start point, mm; None: the dwell point nearest the region's centre.
    margin : float or None
        Keep dwell points at least this far inside the boundary (in the plane), mm.
        None (default): a quarter of the planar spacing, widened until no
        machine sample lies more than ``boundary_tol_mm`` beyond the part
        (:func:`polishpath.pipeline.run`).
    boundary_tol_mm : float
        With the default margin, the most a machine sample may lie beyond the
        part's rim or over a hole, mm.
    feed_mm_min, period_ms, chord_tol_mm : float or None
        Machine interpolation; None uses the defaults of :mod:`polishpath.defaults`.
    integrator : {"taylor", "ab-am"}
        How the constant-period interpolation advances the curve parameter:
        Taylor predictor with an exact chord corrector (default) or the paper's
        Adams-Bashforth / Adams-Moulton (see docs/machine-output.md).
    post : str or None
        Post-processor writing the machine file (:mod:`polishpath.export.post`):
        ``linuxcnc`` (toolpath.nc), ``fanuc`` (G06.2 NURBS), ``xyz``, ``csv``, ``sinumerik``
        (toolpath.mpf), ``abb`` (toolpath.mod); None:
        the machine profile's, else ``linuxcnc``.
    machine : str or None
        Machine profile (a TOML file or a built-in name such as ``generic-3axis``):
        the feeds are scheduled under its limits (:mod:`polishpath.schedule`) and
        its interpolation period is the default ``period_ms``.
    post_settings : dict or None
        The ``[post]`` table of a job TOML: :class:`polishpath.export.PostSettings`
        fields (spindle_rpm, clearance_mm, approach_mm, feed_mode ...).
    gcode : {"linear", "nurbs"} or None
        G-code flavour: dense G01 moves or G06.2 NURBS blocks; None: the post's own
        (linuxcnc: linear, all LinuxCNC takes; fanuc: nurbs).
    segment_tol_mm, segment_time_tol, arcs
        The G-code's segmenting (the post settings ``chord_tol_mm``, ``time_tol``, ``arcs``, over a
        ``[post]`` table's; docs/machine-output.md): most the curve may leave a merged block, mm (None:
        1 % of the spacing, at least ``chord_tol_mm``); most a dwell point's time may differ from its
        schedule (None: 0.01); helical arcs where one fits (None: yes).
    tool_axis : str
        The tool-axis law (:mod:`polishpath.axes`): ``z`` (default: the vertical tool of a 3-axis
        machine), ``normal`` (along the surface normal) or ``tilted:angle=DEG[,azimuth=DEG]`` (a fixed
        tilt from the normal toward a fixed azimuth of the part's frame); anything but ``z`` needs a
        5-axis machine profile (``--machine xyzac-trt``) for the LinuxCNC post.
    tool_radius : float
        Offset contact points to the tool centre along the normal, mm (0: none);
        the feeds become those of the tool centre, so every segment keeps its planned time.
    dwell_times : str or None
        CSV of per-dwell-point times (s), in path order.
    error_map, error_units, tif : str or None
        Deterministic figuring (docs/figuring.md): the measured error to remove
        (a map the ``psd`` readers take, or a Zernike ``.toml``), its height unit
        when the file does not say, and the TIF spec; the dwell times are then solved.
    error_map_options : dict or None
        The ``[error_map]`` table of a job TOML (alignment, solver options; keys in
        :data:`ERROR_MAP_KEYS`).
    force : bool
        Write a figuring program that is refused (floor above the error's PV, or predicted worse); the summary
        records the refusal (docs/figuring.md).
    report : bool
        Write ``report.html`` and PNG figures.
    remesh : str
        ``auto`` (default): refine a CAD-style sliver tessellation exactly
        before flattening (see :mod:`polishpath.surfaces.remesh`); ``off``;
        or an edge length in mm (as text) to refine every longer edge to.
    max_points : int
        Refuse to plan more dwell points than this.
    samples : {"auto", "memory", "stream"}
        The machine samples: ``memory`` holds them all (the machine feed
        schedule of ``machine`` and the figuring residual of ``error_map`` need
        that); ``stream`` keeps only the curve and its schedule and regenerates
        the samples chunk by chunk for the writers (memory bounded by the chunk
        size, not the path); ``auto`` streams when the expected sample count
        exceeds :data:`polishpath.resources.STREAM_ABOVE_SAMPLES` or holding them
        would not fit the memory budget, unless ``machine`` or ``error_map`` needs them held.
    max_oversampling : float
        Refuse when honouring the spacing on the part needs more than this many
        times the dwell points a uniform grid of that spacing would put on the
        part (area / spacing^2): the flattening stretches the part too much for
        one planar grid (an almost closed mesh, say).
    """

    surface: str = option("hemisphere", help="Mesh file, built-in[:key=value,...], analytic spec or .toml spec.")
    units: str | None = option(None, "--units", help="Units of a mesh file: mm (default), m, cm, um, in.")
    scale: float | None = option(None, "--scale", help="Extra scale factor for a mesh file, to millimetres.",
                                 positive=True)
    component: str = option("refuse", "--component", help="Several pieces: 'refuse' (default) or 'largest'.")
    method: str = option(DEFAULT_FLATTEN_METHOD, "--method", "-m",
                         help=f"Flattening: mabf, abf, lscm, projection (default {DEFAULT_FLATTEN_METHOD}).")
    pattern: str = option("pseudorandom", "--pattern", "-p",
                          help="pseudorandom (default), raster, spiral, rectangular, or a peer: unicursal, maze, "
                               "fractal, hilbert.")
    dwell_points: str = option(DEFAULT_DWELL_POINTS, "--dwell-points", choices=("grid", "blue-noise", "relaxed"),
                               help="Dwell points: 'grid' (default: the paper's square grid), 'blue-noise' or "
                                    "'relaxed' (no lattice; pseudorandom pattern only).")
    spacing: float = option(DEFAULT_SPACING_MM, "--spacing", "-s",
                            help=f"Dwell-point spacing on the part, mm (default {DEFAULT_SPACING_MM:g}).",
                            positive=True)
    spacing_on: str = option("surface", "--spacing-on", choices=("surface", "plane"),
                             help="'surface' (default: no step on the part over sqrt(2) x spacing) or 'plane'.")
    seed: int | None = option(None, "--seed", help="Random seed (default: drawn and recorded).")
    start: tuple[float, float] | None = option(
        None, "--start", help="Planar start point 'u,v' in mm (default: nearest the centre).",
        parse=parse_pair, cli_type=str)
    margin: float | None = option(None, "--margin",
                                  help="Keep dwell points this far inside the boundary (in the plane), mm "
                                       "(default: chosen so the machine path stays on the part, see --boundary-tol).",
                                  nonnegative=True)
    boundary_tol_mm: float = option(0.01, "--boundary-tol",
                                    help="With the default margin: most a machine sample may lie beyond the part's "
                                         "rim or over a hole, mm (default 0.01).", positive=True)
    feed_mm_min: float | None = option(None, "--feed", help=f"Feed rate, mm/min (default {DEFAULT_FEED_MM_MIN:g}).",
                                       positive=True)
    period_ms: float | None = option(None, "--period", help=f"Interpolation period, ms (default {DEFAULT_PERIOD_MS:g}).",
                                     positive=True)
    chord_tol_mm: float | None = option(None, "--chord-tol",
                                        help=f"Chord error tolerance, mm (default {DEFAULT_CHORD_TOL_MM:g}).",
                                        positive=True)
    integrator: str = option(DEFAULT_INTEGRATOR, "--integrator", choices=INTEGRATOR_NAMES,
                             help="How the machine samples advance along the NURBS: 'taylor' (default: Taylor "
                                  "predictor, exact chord corrector) or 'ab-am' (the paper's Adams-Bashforth / "
                                  "Adams-Moulton).")
    post: str | None = option(
        None, "--post",
        help="Post-processor of the machine file: linuxcnc (default: LinuxCNC 2.8/2.9 G-code, toolpath.nc), fanuc "
             "(G06.2 NURBS for Fanuc 15i/30i-class controls with NURBS interpolation), xyz (the paper's X Y Z file), "
             "csv (path.csv), sinumerik (Sinumerik 840D TRAORI, toolpath.mpf), abb (ABB RAPID robot, toolpath.mod). "
             "Settings: a [post] table in --config.")
    machine: str | None = option(
        None, "--machine",
        help="Machine profile: a TOML file of axis limits (see examples/machine-*.toml) or the built-in "
             "generic-3axis; the feeds are scheduled so the axes can follow them, and its post and interpolation "
             "period are the defaults.")
    post_settings: dict[str, Any] | None = option(
        None, help="Post-processor settings ([post] table of a job TOML; see docs/machine-output.md).")
    gcode: str | None = option(None, "--gcode", choices=("linear", "nurbs"),
                               help="'linear' (G01; linuxcnc's, the only one LinuxCNC runs) or 'nurbs' (G06.2, "
                                    "--post fanuc's default).")
    segment_tol_mm: float | None = option(
        None, "--segment-tol", positive=True,
        help="G-code: most the smooth curve may leave a merged G01/G02/G03 block, mm (default: 1 % of the "
             "spacing, at least --chord-tol).")
    segment_time_tol: float | None = option(
        None, "--segment-time-tol", positive=True,
        help="G-code: most the time spent around a dwell point may differ from its schedule, a fraction below 1 "
             "(default 0.01).")
    arcs: bool | None = option(None, "--arcs/--no-arcs",
                               help="G-code: helical arcs (G02/G03) where one fits, else G01 (default), or G01 only.")
    tool_axis: str = option(
        "z", "--tool-axis", parse=tool_axis_choice, cli_type=str,
        help="Tool axis: z (default: vertical, 3-axis), normal (along the surface normal) or "
             "tilted:angle=DEG[,azimuth=DEG] (fixed tilt from the normal toward a fixed azimuth of the part); "
             "not z needs a 5-axis --machine (xyzac-trt, xyzbc-trt).")
    tool_radius: float = option(0.0, "--tool-radius",
                                help="Ball/sponge radius, mm: the G-code drives the tool centre (contact point + "
                                     "radius along the normal) with feeds that keep every segment's planned time.",
                                nonnegative=True)
    dwell_times: str | None = option(None, "--dwell-times", help="CSV of per-dwell-point times (s) in path order.")
    error_map: str | None = option(
        None, "--error-map",
        help="Measured surface error to remove (.datx, grid / x y z text, CSV, Zernike .toml): the dwell times are "
             "solved from it and the TIF (docs/figuring.md); alignment etc. in job.toml's [error_map] table.")
    error_units: str | None = option(None, "--error-units", choices=("nm", "um", "mm", "m", "angstrom"),
                                     help="Height unit of the error map when the file does not say: nm, um, mm, m, "
                                          "angstrom.")
    tif: str | None = option(
        None, "--tif",
        help="TIF for --error-map: gaussian:fwhm=MM,peak_rate=NM_PER_S | measured:file=PATH | "
             "rotating:rpm=RPM,radius=MM,peak_rate=NM_PER_S (default: the rotating sponge).")
    error_map_options: dict[str, Any] | None = option(
        None, help="The [error_map] table of a job TOML (docs/figuring.md).")
    force: bool = option(
        False, "--force/--no-force",
        help="Write a figuring program even when it is refused (its minimum-removal floor exceeds the error's PV, or "
             "it is predicted to leave the part worse); the summary says so.")
    report: bool = option(True, "--report/--no-report", help="Write report.html and the PNG figures (default: yes).")
    remesh: str = option("auto", "--remesh", parse=remesh_choice, cli_type=str,
                         help="Refine a CAD-style sliver mesh before flattening, keeping its surface exactly: 'auto' "
                              "(default: only when slivers cover > 5 % of the area), 'off', or an edge length in mm.")
    max_points: int = option(DEFAULT_MAX_POINTS, "--max-points", help="Refuse to plan more dwell points than this.",
                             positive=True)
    samples: str = option(
        "auto", "--samples", choices=("auto", "memory", "stream"),
        help="Machine samples held in memory ('memory') or regenerated chunk by chunk for the writers ('stream': "
             "memory bounded whatever the path's length); 'auto' (default) streams above "
             f"{STREAM_ABOVE_SAMPLES / 1e6:g} M expected samples or when holding them would not fit; --machine and "
             "--error-map need them held.")
    max_oversampling: float = option(
        DEFAULT_MAX_OVERSAMPLING, "--max-oversampling", positive=True,
        help="Refuse when honouring the spacing on the part needs more than this many times the dwell points of a "
             "uniform grid on the part.")

    def validate(self) -> None:
        """Check every field (type, range, choices); :class:`ParameterError` names the first bad one."""
        for f in dataclasses.fields(self):
            _check(f, getattr(self, f.name))

    def to_dict(self) -> dict[str, Any]:
        """The options as plain values (``start`` as a list), JSON- and TOML-ready."""
        d = dataclasses.asdict(self)
        if d["start"] is not None:
            d["start"] = list(d["start"])
        return d

    def to_toml(self) -> str:
        """The config as TOML (``None`` options left out): the text of ``job.toml``."""
        from .runfolder import job_toml

        return job_toml(self.to_dict())

    @classmethod
    def from_toml(cls, path: str | Path, **overrides: Any) -> JobConfig:
        """Read a job TOML (``[job]`` table, or top-level keys); ``overrides`` (not None) win."""
        return parse_job(toml=path, **overrides)


#: keys of the ``[error_map]`` table (docs/figuring.md)
ERROR_MAP_KEYS = frozenset({"offset_mm", "rotation_deg", "flip", "scale", "lateral_unit", "dx_mm", "bias_nm", "method",
                            "smoothness", "ca_margin_mm", "max_uncovered", "extension_weight", "max_feed_mm_min"})

#: the numbers of the ``[error_map]`` table and their range: (low, high, low included)
ERROR_MAP_RANGES = {"dx_mm": (0.0, math.inf, False), "scale": (0.0, math.inf, False),
                    "rotation_deg": (-math.inf, math.inf, True), "bias_nm": (0.0, math.inf, True),
                    "smoothness": (0.0, math.inf, True), "ca_margin_mm": (0.0, math.inf, True),
                    "max_uncovered": (0.0, 1.0, True), "extension_weight": (0.0, math.inf, True),
                    "max_feed_mm_min": (0.0, math.inf, False)}


def _check_error_map_numbers(table: dict[str, Any]) -> None:
    """Every number of an ``[error_map]`` table finite and in its range (NaN, inf, 0 spacing refused)."""
    for key, (lo, hi, lo_ok) in ERROR_MAP_RANGES.items():
        v = table.get(key)
        if v is None or (key == "bias_nm" and v == "auto"):
            continue
        ok = (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
              and (v >= lo if lo_ok else v > lo) and v <= hi)
        if not ok:
            rng = f"{'>=' if lo_ok else '>'} {lo:g}" + (f" and <= {hi:g}" if math.isfinite(hi) else "")
            rng = "a finite number" if not math.isfinite(lo) else rng
            raise ParameterError(f"[error_map] {key} must be {rng}, got {v!r}.",
                                 "Fix it in the job file's [error_map] table (docs/figuring.md).")
    off = table.get("offset_mm")
    if off is not None and not (isinstance(off, (list, tuple)) and len(off) == 2 and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in off)):
        raise ParameterError(f"[error_map] offset_mm must be two finite numbers [x, y] in mm, got {off!r}.",
                             "Fix it in the job file's [error_map] table (docs/figuring.md).")


#: the fields of :class:`JobConfig` by name
FIELDS: dict[str, dataclasses.Field] = {f.name: f for f in dataclasses.fields(JobConfig)}
#: the fields that have command-line flags, in declaration order: ``polishpath plan`` is built from these
CLI_OPTIONS: tuple[dataclasses.Field, ...] = tuple(f for f in FIELDS.values() if f.metadata["flags"])
_TYPES = typing.get_type_hints(JobConfig)


def value_type(name: str) -> Any:
    """The value type of option ``name`` without ``None`` (``float`` for ``float | None``)."""
    t = _TYPES[name]
    args = [a for a in typing.get_args(t) if a is not type(None)]
    return args[0] if typing.get_origin(t) in (typing.Union, types.UnionType) else t


def _where(f: dataclasses.Field) -> str:
    flags = f.metadata["flags"]
    return f"{f.name} ({flags[0].split('/')[0]})" if flags else f.name


def _check(f: dataclasses.Field, v: Any) -> Any:
    """``v`` checked for field ``f`` (and a list made a tuple for ``start``); raises ParameterError."""
    if v is None:
        if f.default is None:
            return None
        raise ParameterError(f"{f.name} must be given, got None.", f"Leave it out for the default {f.default!r}.")
    m, t = f.metadata, value_type(f.name)
    if m["parse"] is not None and isinstance(v, str):  # a flag's text, e.g. --start 'u,v'
        v = m["parse"](v)
    if f.name == "seed":  # checked here, drawn (when None) by the job: both through resolve_seed
        from .provenance import resolve_seed

        return resolve_seed(v)
    if t is float:
        ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
        kind = "a number"
    elif t is int:
        ok = isinstance(v, int) and not isinstance(v, bool)
        kind = "a whole number"
    elif t is bool:
        ok = isinstance(v, bool)
        kind = "true or false"
    elif t is str:
        ok = isinstance(v, str)
        kind = "text"
    elif typing.get_origin(t) is dict:
        ok = isinstance(v, dict) and all(isinstance(k, str) for k in v)
        if ok and f.name == "error_map_options" and set(v) - ERROR_MAP_KEYS:
            raise SpecError(f"unknown [error_map] option(s) {', '.join(sorted(set(v) - ERROR_MAP_KEYS))}.",
                            f"Options: {', '.join(sorted(ERROR_MAP_KEYS))}.")
        if ok and f.name == "error_map_options":
            _check_error_map_numbers(v)
        kind = "a table of settings"
        v = dict(v) if ok else v
    else:  # the (u, v) pair
        ok = (isinstance(v, (list, tuple)) and len(v) == 2
              and all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v))
        kind = "two numbers [u, v] in mm"
        v = tuple(float(x) for x in v) if ok else v
    if not ok:
        raise ParameterError(f"{_where(f)} must be {kind}, got {v!r}.", f"Default: {f.default!r}.")
    if m["positive"] and not v > 0:
        raise ParameterError(f"{f.name} must be a positive number, got {v!r}.")
    if m["nonnegative"] and not v >= 0:
        raise ParameterError(f"{f.name} must be >= 0, got {v!r}.")
    if m["choices"] and v not in m["choices"]:
        names = [repr(c) for c in m["choices"]]
        raise ParameterError(f"{f.name} must be {', '.join(names[:-1])} or {names[-1]}, got {v!r}.")
    return v


def parse_job(*, toml: str | Path | None = None, base: JobConfig | None = None, **options: Any) -> JobConfig:
    """The one way to a :class:`JobConfig`: defaults <- ``base`` <- TOML file <- ``options``.

    Parameters
    ----------
    toml : path, optional
        A job TOML: a ``[job]`` table (or top-level keys) of option names, and a
        ``[post]`` table of post-processor settings (``post_settings``). A
        relative ``surface``, ``dwell_times`` or ``machine`` path that exists
        beside the file is taken relative to it.
    base : JobConfig, optional
        Start from these options instead of the defaults.
    **options
        Option values; ``None`` means "not given" (the earlier source stays).

    Returns
    -------
    JobConfig
        Every value checked (the seed too, but not drawn: ``None`` stays None
        until :func:`polishpath.pipeline.run` draws it).

    Raises
    ------
    SpecError
        The TOML has unknown keys or is not a table of options.
    ParameterError
        An unknown keyword option, or a value of the wrong type or range.
    """
    values: dict[str, Any] = dataclasses.asdict(base) if base is not None else {}
    if toml is not None:
        values.update(_read_job_toml(Path(toml)))
    unknown = set(options) - set(FIELDS)
    if unknown:
        raise ParameterError(f"unknown job option(s) {', '.join(sorted(unknown))}.",
                             f"Options: {', '.join(FIELDS)}.")
    values.update({k: v for k, v in options.items() if v is not None})
    return JobConfig(**{k: _check(FIELDS[k], v) for k, v in values.items()})


def _read_job_toml(p: Path) -> dict[str, Any]:
    from .runfolder import read_toml

    data = read_toml(p, "job file")
    table = data.get("job", data)
    if not isinstance(table, dict):
        raise SpecError(f"{p.name}: [job] must be a table of options.")
    unknown = set(table) - set(FIELDS)
    if unknown:
        raise SpecError(f"{p.name}: unknown job option(s) {', '.join(sorted(unknown))}.",
                        f"Options: {', '.join(sorted(FIELDS))}.")
    kw = dict(table)
    post = data.get("post") if "job" in data else None  # a [post] table beside [job]: the post settings
    if post is not None:
        if not isinstance(post, dict):
            raise SpecError(f"{p.name}: [post] must be a table of post-processor settings.")
        kw["post_settings"] = {**post, **(kw.get("post_settings") or {})}
    if isinstance(data.get("error_map"), dict):  # the [error_map] table beside [job]
        kw["error_map_options"] = {**data["error_map"], **(kw.get("error_map_options") or {})}
    for key in ("surface", "dwell_times", "machine", "error_map"):  # a relative path beside the file is relative to it
        v = kw.get(key)
        if isinstance(v, str) and not Path(v).is_absolute() and (p.parent / v).exists():
            kw[key] = str(p.parent / v)
    return kw
