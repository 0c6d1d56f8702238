"""Resource guards (core: no stage imports): estimate what a job will need before building anything, refuse what cannot fit.

A single parameter can ask for more than a machine has (``hemisphere:R=1e9``
with a 0.5 mm spacing is 10^19 dwell points). The guards here estimate, from
the inputs alone, the triangles, dwell points, machine samples and peak memory
of a job, and refuse with the numbers and the way out when the estimate exceeds
a share of the memory this process may use.

The memory model is measured, not derived (peak resident size of ``polishpath
plan``): about 300 MB of libraries, 2 KB per triangle (meshing, checks,
flattening; the hemisphere at 5,000-80,000 triangles), 1.2 KB per dwell point
(planning, mapping, smoothing, metrics, writing, report: 0.92 KB measured on the
10^6-point disk of ``benchmarks/bench_job.py`` with its samples streamed) and
0.1 KB per machine sample held (81 B measured on the same disk holding its
15 M samples; a streamed job's samples cost :data:`STREAMED_SAMPLES_BYTES`
whatever their count). The refusal before flattening counts the fewest dwell
points the spacing can give (a uniform grid on the part: the planar grid is up
to 2x denser where the flattening shrinks the part) and generous bytes for
each: a refusal must mean "this cannot fit", never "this might not fit".

Settings (environment)
----------------------
``POLISHPATH_MAX_MEMORY``
    Memory the job may use, e.g. ``4G``, ``512M``, ``1500000000`` (bytes):
    replaces the default budget.
``POLISHPATH_MEMORY_SHARE``
    Share of the available memory the job may use when no explicit limit is
    set (default 0.8).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

from .errors import ParameterError, ResourceError

BASE_BYTES = 300e6
BYTES_PER_TRIANGLE = 2e3
BYTES_PER_DWELL_POINT = 1.2e3
BYTES_PER_SAMPLE = 100.0
#: dwell points per (area / spacing^2): the planar grid is denser than a uniform
#: grid on the part where the flattening shrinks it (measured 2.0 on the hemisphere)
DWELL_POINTS_PER_CELL = 2.0
#: machine path length per dwell point, in spacings (steps are in [s, sqrt(2) s])
PATH_PER_DWELL_POINT = 1.3
DEFAULT_SHARE = 0.8
#: ``--samples auto`` streams the machine samples above this many expected (about 2.6 x the 15 M samples
#: of a 10^6-point path at the default feed and period; held, they cost about 0.1 KB each, 4 GB at this count)
STREAM_ABOVE_SAMPLES = 40e6
#: peak memory of a streamed job's samples, bytes: the chunks in flight and the writers' buffers, whatever
#: the path's length (measured: see ``BYTES_PER_SAMPLE``)
STREAMED_SAMPLES_BYTES = 300e6

_SIZE = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([kKmMgGtT]?)[iI]?[bB]?\s*$")
_FACTOR = {"": 1.0, "k": 1e3, "m": 1e6, "g": 1e9, "t": 1e12}


@dataclass(frozen=True)
class Estimate:
    """What a job is expected to need.

    Attributes
    ----------
    triangles : int
        Mesh triangles.
    dwell_points : float
        Dwell points of the plan (0 when no plan is made).
    samples : float
        Machine samples of the interpolated path (0 when none).
    peak_bytes : float
        Peak memory, bytes.
    """

    triangles: int
    dwell_points: float = 0.0
    samples: float = 0.0
    peak_bytes: float = 0.0

    def describe(self) -> str:
        parts = [f"{self.triangles:,} triangles"]
        if self.dwell_points:
            parts.append(f"about {self.dwell_points:.3g} dwell points")
        if self.samples:
            parts.append(f"{self.samples:.3g} machine samples")
        return f"about {format_bytes(self.peak_bytes)} of memory ({', '.join(parts)})"


def format_bytes(n: float) -> str:
    """``1.5e9 -> '1.5 GB'`` (decimal units)."""
    if not math.isfinite(n):
        return "an unbounded amount"
    for unit, f in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("KB", 1e3)):
        if abs(n) >= f:
            return f"{n / f:.3g} {unit}"
    return f"{n:.0f} B"


def parse_size(text: str) -> float:
    """Bytes from ``'4G'``, ``'512M'``, ``'2.5GB'``, ``'1500000000'``.

    Raises
    ------
    ParameterError
        For text that is not a positive size.
    """
    m = _SIZE.match(str(text))
    if not m or float(m.group(1)) <= 0:
        raise ParameterError(f"memory limit {text!r} is not a size.", "Write it like 4G, 512M or 1500000000 (bytes).")
    return float(m.group(1)) * _FACTOR[m.group(2).lower()]


def _meminfo_available() -> float | None:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    return None


def _address_space_left() -> float | None:
    """Room left under this process's address-space limit (``ulimit -v``), bytes."""
    try:
        import resource
    except ImportError:  # pragma: no cover - not on Windows
        return None
    out = None
    for name in ("RLIMIT_AS", "RLIMIT_DATA"):
        lim = getattr(resource, name, None)
        if lim is None:
            continue
        soft, _ = resource.getrlimit(lim)
        if soft == resource.RLIM_INFINITY or soft <= 0:
            continue
        used = 0.0
        try:
            for line in Path("/proc/self/status").read_text().splitlines():
                if line.startswith("VmSize:" if name == "RLIMIT_AS" else "VmData:"):
                    used = float(line.split()[1]) * 1024.0
        except OSError:
            pass
        left = max(float(soft) - used, 0.0)
        out = left if out is None else min(out, left)
    return out


def _cgroup_left() -> float | None:
    try:
        mx = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        if mx == "max":
            return None
        cur = float(Path("/sys/fs/cgroup/memory.current").read_text().strip())
        return max(float(mx) - cur, 0.0)
    except (OSError, ValueError):
        return None


def memory_budget() -> tuple[float, str]:
    """Memory a job may use, bytes, and where that figure comes from.

    ``POLISHPATH_MAX_MEMORY`` when set; otherwise ``POLISHPATH_MEMORY_SHARE``
    (default 0.8) of the smallest of the available memory, the room under the
    process's address-space limit and the room in its cgroup.
    """
    env = os.environ.get("POLISHPATH_MAX_MEMORY")
    if env:
        return parse_size(env), "POLISHPATH_MAX_MEMORY"
    share_text = os.environ.get("POLISHPATH_MEMORY_SHARE", str(DEFAULT_SHARE))
    try:
        share = float(share_text)
    except ValueError:
        share = -1.0
    if not 0 < share <= 1:
        raise ParameterError(f"POLISHPATH_MEMORY_SHARE must be a number in (0, 1], got {share_text!r}.")
    found = [(v, what) for v, what in ((_meminfo_available(), "available memory"),
                                       (_address_space_left(), "the process's address-space limit"),
                                       (_cgroup_left(), "the cgroup's memory limit")) if v is not None]
    if not found:
        return math.inf, "no known limit"
    v, what = min(found)
    return share * v, f"{share:g} of {what} ({format_bytes(v)})"


def estimate(triangles: int, *, area_mm2: float = 0.0, spacing_mm: float | None = None,
             feed_mm_min: float = 600.0, period_ms: float = 4.0,
             points_per_cell: float = DWELL_POINTS_PER_CELL) -> Estimate:
    """Estimate a job's size and peak memory from its inputs.

    Parameters
    ----------
    triangles : int
        Triangles of the mesh (requested or read).
    area_mm2 : float
        Area of the part, mm^2 (for the dwell points).
    spacing_mm : float, optional
        Dwell-point spacing, mm. None: no plan (``info``, ``flatten``).
    feed_mm_min, period_ms : float
        Machine feed (mm/min) and interpolation period (ms), for the samples.
    points_per_cell : float
        Dwell points per ``spacing^2`` of the part's area (1: a uniform grid on the
        part, the fewest; :data:`DWELL_POINTS_PER_CELL`: the hemisphere's measured density).
    """
    n = max(int(triangles), 0)
    dwell = samples = 0.0
    if spacing_mm is not None and spacing_mm > 0 and area_mm2 > 0:
        with _no_overflow():
            dwell = points_per_cell * area_mm2 / (spacing_mm * spacing_mm)
            step = feed_mm_min / 60.0 * period_ms / 1000.0
            samples = dwell * PATH_PER_DWELL_POINT * spacing_mm / step if step > 0 else math.inf
    peak = BASE_BYTES + BYTES_PER_TRIANGLE * n + BYTES_PER_DWELL_POINT * dwell + BYTES_PER_SAMPLE * samples
    return Estimate(n, dwell, samples, peak)


def expected_samples(path_length_mm: float, *, feed_mm_min: float, period_ms: float,
                     total_time_s: float | None = None) -> float:
    """Machine samples a path is expected to have, before it is smoothed.

    Parameters
    ----------
    path_length_mm : float
        Length of the path through its dwell points, mm (the steps within pieces).
    feed_mm_min, period_ms : float
        Feed (mm/min) and interpolation period (ms).
    total_time_s : float, optional
        The dwell times' sum, s, when they are given or solved (the path then lasts that long).

    Returns
    -------
    float
        One sample per period over the path's time: ``max(length / feed, total time) / period``
        (the curvature slow-downs at turns add some 10-20 % on a pseudo-random path).
    """
    t = path_length_mm / (feed_mm_min / 60.0) if feed_mm_min > 0 else math.inf
    if total_time_s is not None:
        t = max(t, float(total_time_s))
    return t / (period_ms / 1000.0) if period_ms > 0 else math.inf


def stream_samples(expected: float, est: Estimate | None = None) -> tuple[bool, str]:
    """Whether ``--samples auto`` streams a path of ``expected`` machine samples, and why (one sentence).

    It streams above :data:`STREAM_ABOVE_SAMPLES`, and when holding them
    (:data:`BYTES_PER_SAMPLE` each, on top of the rest of the job's estimate
    ``est``) would exceed the memory budget.
    """
    held = BYTES_PER_SAMPLE * expected
    rest = (est.peak_bytes - BYTES_PER_SAMPLE * est.samples) if est is not None else BASE_BYTES
    budget, source = memory_budget()
    if expected > STREAM_ABOVE_SAMPLES:
        return True, (f"about {expected:.3g} machine samples expected, more than {STREAM_ABOVE_SAMPLES:.3g} "
                      "(resources.STREAM_ABOVE_SAMPLES): streamed")
    if rest + held > budget:
        return True, (f"holding about {expected:.3g} machine samples needs about {format_bytes(rest + held)}, more "
                      f"than this job may use ({format_bytes(budget)}: {source}): streamed")
    return False, (f"about {expected:.3g} machine samples expected, at most {STREAM_ABOVE_SAMPLES:.3g}: held in memory")


class _no_overflow:
    """Turn float overflow into infinity (huge estimates are still estimates)."""

    def __enter__(self):
        return self

    def __exit__(self, et, ev, tb):
        return et is OverflowError


def check(est: Estimate, what: str, way_out: str) -> None:
    """Refuse a job whose estimate exceeds the memory budget.

    Parameters
    ----------
    est : Estimate
        From :func:`estimate`.
    what : str
        The job in the user's terms (``"hemisphere:R=1e4 with spacing 0.01 mm"``).
    way_out : str
        What to change (fewer triangles, a larger spacing...).

    Raises
    ------
    ResourceError
        With the estimate, the budget and the way out.
    """
    budget, source = memory_budget()
    if est.peak_bytes > budget or not math.isfinite(est.peak_bytes):
        raise ResourceError(
            f"{what} needs {est.describe()}, more than this job may use ({format_bytes(budget)}: {source}).",
            f"{way_out} To allow more, set POLISHPATH_MAX_MEMORY (e.g. POLISHPATH_MAX_MEMORY=16G).",
        )


def units_hint(surface) -> str:
    """A hint about the file's units when a mesh read as mm is implausibly small or large ('' otherwise).

    Parameters
    ----------
    surface : polishpath.types.Surface
        A surface read from a mesh file (``params["units"]`` records the units it was read in).
    """
    import numpy as np

    if surface.params.get("units") not in ("mm",) or surface.params.get("scale", 1.0) != 1.0:
        return ""
    ext = float(np.linalg.norm(surface.vertices.max(axis=0) - surface.vertices.min(axis=0)))
    if ext < SMALL_PART_MM:
        return (f"The part read as {ext:.3g} mm across: if the file is in metres (or inches, cm), say so with "
                "--units m (or --units in, --units cm).")
    if ext > LARGE_PART_MM:
        return f"The part read as {ext:.3g} mm across: if the file is in micrometres, say so with --units um."
    return ""


#: a mesh file read in mm that is smaller (bounding-box diagonal) than this is probably in metres
SMALL_PART_MM = 5.0
#: ... and larger than this probably in micrometres
LARGE_PART_MM = 1e5


def check_job(surface, spacing_mm: float, *, feed_mm_min: float, period_ms: float, max_points: int,
              samples: str = "memory") -> Estimate:
    """Refuse a planning job that cannot fit, from the surface and the options alone (before flattening).

    Parameters
    ----------
    surface : polishpath.types.Surface
        The part, mm.
    spacing_mm : float
        Dwell-point spacing on the part, mm.
    feed_mm_min, period_ms : float
        Machine feed (mm/min) and interpolation period (ms).
    max_points : int
        The job's dwell-point limit.
    samples : {"memory", "stream", "auto"}
        How the job will keep its machine samples (``JobConfig.samples``, or
        ``memory`` where the job needs them held): a streamed job's samples cost
        :data:`STREAMED_SAMPLES_BYTES` whatever their count, and ``auto`` streams
        what would not fit held.

    Raises
    ------
    SpacingTooLargeError
        The spacing is larger than half the part (fewer than two dwell points fit).
    ResourceError
        More dwell points than ``max_points`` on a uniform grid, or more memory than the budget.
    """
    import numpy as np

    from . import meshops
    from .errors import SpacingTooLargeError

    v = surface.vertices
    ext = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    if spacing_mm > ext / 2:
        hint = units_hint(surface) or f"Use a smaller --spacing (at most about {ext / 4:.3g} mm for this part)."
        raise SpacingTooLargeError(
            f"spacing {spacing_mm:g} mm is too large for {surface.name}, which is {ext:.4g} mm across: "
            "fewer than two dwell points fit.", hint)
    area = meshops.surface_area(v, surface.faces)
    # the fewest dwell points the spacing gives (a uniform grid on the part): a refusal means even they cannot fit
    est = estimate(surface.n_faces, area_mm2=area, spacing_mm=spacing_mm,
                   feed_mm_min=feed_mm_min, period_ms=period_ms, points_per_cell=1.0)
    uniform = est.dwell_points
    way_out = (f"Use a larger --spacing (the count goes with 1 / spacing^2), or plan part of the surface. "
               + units_hint(surface))
    if uniform > max_points:
        raise ResourceError(
            f"spacing {spacing_mm:g} mm on {surface.name} ({area:.4g} mm^2) needs at least {uniform:.3g} dwell points, "
            f"more than max_points = {max_points:,}.",
            way_out.strip() + " Raise max_points in a --config file to go on anyway.")
    if samples != "memory":  # streamed (or auto, which streams what would not fit held): the chunks only
        est = Estimate(est.triangles, est.dwell_points, est.samples,
                       est.peak_bytes - BYTES_PER_SAMPLE * est.samples + STREAMED_SAMPLES_BYTES)
    elif est.samples > STREAM_ABOVE_SAMPLES:
        way_out += " Or let the samples stream (--samples stream; --machine and --error-map need them held)."
    check(est, f"spacing {spacing_mm:g} mm on {surface.name} ({area:.4g} mm^2)", way_out.strip())
    return est
