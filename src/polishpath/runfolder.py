"""The run folder as a format: what ``polishpath plan -o DIR`` leaves for later readers.

One module writes and reads the three files that describe a run (the machine
files ``path.csv``, ``toolpath.xyz``, ``toolpath.nc`` and ``flat.obj`` are the
export stage's):

* ``run.npz``: every stage's arrays (:data:`ARRAY_KEYS`, units in docs/run-folder.md);
* ``summary.json``: every figure and parameter of the run, with the format's
  version under :data:`SCHEMA_KEY`;
* ``job.toml``: the job's options (``[job]`` table), to re-run it exactly.

:func:`write_run` writes them (atomically, file by file) and :func:`read_run`
reads them back into a :class:`RunData`, which gives the raw arrays and the
stages' dataclasses rebuilt from them (``run.surface``, ``run.planar``,
``run.surface_path``, ``run.tool_path`` ...). The report and ``polishpath
simulate RUN_DIR`` read run folders through this module only.

Adding a key: write it in :func:`write_run`, list it in :data:`ARRAY_KEYS` (or
under the summary's sections) and in docs/run-folder.md; bump
:data:`SCHEMA_VERSION` only when a reader of the old format would misread the
new one (a renamed or re-meant key), not for an added key.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from ._version import __version__
from .errors import InputError, ParameterError
from .fileio import atomic_open, jsonable, read_toml  # read_toml: job.toml, job configs (re-exported)
from .types import (Flattening, Lattice, NurbsCurve, PlanarPath, Provenance, Region, SampleSchedule, Surface,
                    SurfacePath, ToolPath)

#: version of the run-folder format written by this polishpath (3: the pieces of the samples and the planar
#: path's lattice are arrays, no longer figures of summary.json; 2: the machine samples are not stored where
#: their schedule regenerates them; 1 stored every sample)
SCHEMA_VERSION = 3
#: top-level key of ``summary.json`` holding the format version (absent: a folder from before the format had one, 0)
SCHEMA_KEY = "run_folder_schema"

ARRAYS_FILE = "run.npz"
SUMMARY_FILE = "summary.json"
JOB_FILE = "job.toml"
SIMULATION_DIR = "simulation"

#: every fixed key of ``run.npz`` (plus ``residual_<name>`` per flattening residual,
#: ``region_loop_<i>`` per boundary loop of the planning region, outer first, and the tool path's
#: samples as :data:`SCHEDULE_ARRAY_KEYS` or :data:`SAMPLE_ARRAY_KEYS`)
ARRAY_KEYS = (
    "vertices", "faces",                                   # surface
    "uv", "angles",                                        # flattening
    "plan_uv", "plan_ij", "plan_pieces", "plan_unreached",  # planar path
    "plan_spacing", "plan_origin", "plan_rotation",
    "plan_lattice_basis", "plan_lattice_origin", "plan_lattice_steps", "plan_dwell_points_only", "plan_cell_area",
    "xyz", "normals", "dwell_weight", "face_ids", "bary",  # path on the part
    "dwell_params", "dwell_times", "sample_pieces", "piece_params",  # tool path
    "knots", "control_points", "curve_weights", "curve_degree",
    "display_sample_index", "display_samples", "feed_bins", "feed_envelope",  # what the report draws of the samples
)

#: the machine samples' schedule (:class:`~polishpath.types.SampleSchedule`, one key per field): with the
#: curve, it regenerates every sample bit for bit (``polishpath.smooth.iter_sample_chunks``), so the
#: samples themselves are not stored (format 2)
SCHEDULE_ARRAY_KEYS = tuple(f"schedule_{f.name}" for f in dataclasses.fields(SampleSchedule))
#: the samples themselves: stored only for a path without a schedule (feeds rescheduled under a machine
#: profile, ``--machine``), and in every format-1 folder
SAMPLE_ARRAY_KEYS = ("samples", "sample_params", "feed_mm_min")

#: the dwell points' tool axes (N, 3) of a 5-axis run (``--tool-axis`` not ``z``; :mod:`polishpath.axes`):
#: absent from a 3-axis run (the vertical tool), whose folder is byte for byte what it was
TOOL_AXES_KEY = "tool_axes"

#: arrays of a figuring run (``--error-map``), on the analysis grid ``figuring_grid`` = (x0, y0, pitch) mm
FIGURING_ARRAY_KEYS = (
    "figuring_error_nm", "figuring_inside", "figuring_target_nm", "figuring_weight", "figuring_removal_nm",
    "figuring_ideal_removal_nm", "figuring_residual_nm", "figuring_grid", "figuring_times_s", "figuring_t_min_s",
)


#: every top-level entry a run folder may hold (the export stage's machine files, this module's
#: files, the report, a simulation): a folder holding only these is a run folder to replace whole
RUN_FOLDER_ENTRIES = frozenset({
    "path.csv", "toolpath.xyz", "toolpath.nc", "toolpath.mpf", "toolpath.mod", "flat.obj", ARRAYS_FILE, SUMMARY_FILE, JOB_FILE,
    "report.html", "figures", SIMULATION_DIR,
})


def is_run_folder(folder: str | Path) -> bool:
    """True when ``folder`` holds a polishpath run: its ``summary.json`` carries :data:`SCHEMA_KEY`,
    or every entry is a run folder's own (:data:`RUN_FOLDER_ENTRIES`, leftover ``.*.tmp`` files),
    as an older or interrupted run leaves it."""
    d = Path(folder)
    if not d.is_dir():
        return False
    try:
        summary = json.loads((d / SUMMARY_FILE).read_text(encoding="utf-8"))
        if isinstance(summary, dict) and SCHEMA_KEY in summary:
            return True
    except (OSError, UnicodeDecodeError, ValueError):
        pass
    names = [p.name for p in d.iterdir()]
    return bool(names) and all(n in RUN_FOLDER_ENTRIES or (n.startswith(".") and n.endswith(".tmp")) for n in names)


def estimate_run_bytes(n_points: int, n_samples: int, n_vertices: int, n_faces: int, *, report: bool) -> int:
    """Rough upper estimate of a run folder's size on disk, bytes.

    Per dwell point (path.csv row, run.npz arrays) about 400 bytes, per machine
    sample (the toolpath.xyz line, 31 bytes, and the G-code's share) about 100
    (run.npz no longer stores samples that their schedule regenerates), per
    vertex / face (flat.obj, run.npz) about 150, and 12 MB for the report
    (plotly.js, the figures): a generous figure, on purpose.
    """
    size = 400 * n_points + 100 * n_samples + 150 * (n_vertices + n_faces)
    return int(size + (12 * 2**20 if report else 0))


def write_run(
    out_dir: str | Path,
    *,
    surface: Surface,
    flattening: Flattening,
    region: Region,
    planar: PlanarPath,
    surface_path: SurfacePath,
    tool_path: ToolPath,
    summary: dict[str, Any],
    config: dict[str, Any],
    extra_arrays: dict[str, Any] | None = None,
) -> dict[str, Path]:
    """Write ``run.npz``, ``summary.json`` and ``job.toml`` of a run into ``out_dir``.

    Parameters
    ----------
    out_dir : path
        The run folder (created if missing).
    surface, flattening, region, planar, surface_path, tool_path
        The stages' results.
    summary : dict
        Figures of the run (JSON-ready values or numpy scalars); :data:`SCHEMA_KEY` is added.
    config : dict
        The job's options (``None`` values are left out of ``job.toml``).
    extra_arrays : dict, optional
        Arrays of optional stages (figuring: :data:`FIGURING_ARRAY_KEYS`).

    Returns
    -------
    dict of str -> Path
        ``arrays``, ``summary``, ``job``.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    tp, sp, pp, fl = tool_path, surface_path, planar, flattening
    arrays: dict[str, Any] = {
        "vertices": surface.vertices, "faces": surface.faces, "uv": fl.uv, "angles": fl.angles,
        "plan_uv": pp.uv, "plan_ij": pp.ij, "plan_pieces": pp.pieces, "plan_unreached": pp.unreached,
        "plan_spacing": np.float64(pp.spacing), "plan_origin": pp.origin, "plan_rotation": np.float64(pp.rotation),
        **_lattice_arrays(pp.lattice), "plan_dwell_points_only": np.bool_(pp.dwell_points_only),
        "plan_cell_area": pp.cell_area if pp.cell_area is not None else np.zeros(0),
        "xyz": sp.xyz, "normals": sp.normals, "dwell_weight": sp.dwell_weight,
        "face_ids": sp.face_ids, "bary": sp.bary,
        "dwell_params": tp.dwell_params,
        "dwell_times": tp.dwell_times if tp.dwell_times is not None else np.zeros(0),
        "sample_pieces": tp.sample_pieces, "piece_params": tp.piece_params,
        "knots": tp.curve.knots, "control_points": tp.curve.control_points,
        "curve_weights": tp.curve.weights, "curve_degree": np.int64(tp.curve.degree),
    }
    if sp.tool_axes is not None:  # a 5-axis run: the axes travel (the samples' are interpolated from them)
        arrays[TOOL_AXES_KEY] = sp.tool_axes
    if tp.schedule is not None:  # the samples are regenerable: their schedule, not the samples
        arrays.update(schedule_arrays(tp.schedule))
    else:
        arrays.update(samples=tp.samples, sample_params=tp.sample_params, feed_mm_min=tp.feed_mm_min)
    for k, v in fl.residuals.items():
        arrays[f"residual_{k}"] = np.asarray(v)
    for i, loop in enumerate(region.loops):
        arrays[f"region_loop_{i}"] = loop
    arrays.update(extra_arrays or {})
    written = {"arrays": out / ARRAYS_FILE, "summary": out / SUMMARY_FILE, "job": out / JOB_FILE}
    with atomic_open(written["arrays"], "wb") as fh:
        write_npz(fh, arrays)
    with atomic_open(written["summary"], "w") as fh:
        json.dump(jsonable({SCHEMA_KEY: SCHEMA_VERSION, **summary}), fh, indent=2, sort_keys=False, allow_nan=False)
        fh.write("\n")
    with atomic_open(written["job"], "w") as fh:
        fh.write(job_toml(config))
    return written


def _lattice_arrays(lattice: Lattice | None) -> dict[str, np.ndarray]:
    """The planar path's lattice as ``run.npz`` arrays (empty arrays: the dwell points have none)."""
    if lattice is None:
        return {"plan_lattice_basis": np.zeros((0, 2)), "plan_lattice_origin": np.zeros(0),
                "plan_lattice_steps": np.zeros((0, 2), np.int64)}
    return {"plan_lattice_basis": lattice.basis, "plan_lattice_origin": lattice.origin,
            "plan_lattice_steps": lattice.neighbour_offsets}


def schedule_arrays(schedule: SampleSchedule) -> dict[str, np.ndarray]:
    """A :class:`~polishpath.types.SampleSchedule` as ``run.npz`` arrays (:data:`SCHEDULE_ARRAY_KEYS`)."""
    return {f"schedule_{f.name}": np.asarray(getattr(schedule, f.name)) for f in dataclasses.fields(SampleSchedule)}


def schedule_from_arrays(arrays: Mapping[str, np.ndarray]) -> SampleSchedule:
    """The :class:`~polishpath.types.SampleSchedule` of :func:`schedule_arrays` (0-d arrays back to scalars)."""
    kw = {}
    for f in dataclasses.fields(SampleSchedule):
        a = np.asarray(arrays[f"schedule_{f.name}"])
        kw[f.name] = a.item() if a.ndim == 0 else a
    return SampleSchedule(**kw)


#: bytes of an array probed to decide whether compressing it pays (:func:`write_npz`)
COMPRESS_PROBE_BYTES = 1 << 18
#: compress an array when deflate (level 1) shrinks the probe below this share of its size
COMPRESS_WORTH = 0.6


def write_npz(fh, arrays: dict[str, Any]) -> None:
    """Write ``arrays`` as an ``.npz`` (a zip of ``.npy`` files, read by :func:`numpy.load`) into ``fh``.

    Each array is deflated (zlib level 1, about 40-90 MB/s here) only where that
    pays: when a probe of its first :data:`COMPRESS_PROBE_BYTES` shrinks below
    :data:`COMPRESS_WORTH` of its size (the feeds, mostly constant, shrink
    3x), else it is stored as it is (the machine samples and their parameters,
    float noise in the low bits, shrink only to 0.6-0.7 and cost more time to
    deflate than to write: measured on the 10^5-point disk, 2.9 s deflating
    against 0.5 s writing them). ``numpy.load`` reads both kinds of entry.
    """
    import zipfile
    import zlib

    with zipfile.ZipFile(fh, "w", allowZip64=True) as zf:
        for name, value in arrays.items():
            a = np.asanyarray(value)
            raw = a.tobytes()[:COMPRESS_PROBE_BYTES] if a.nbytes <= COMPRESS_PROBE_BYTES else \
                np.ascontiguousarray(a).reshape(-1).view(np.uint8)[:COMPRESS_PROBE_BYTES].tobytes()
            small = len(raw) == 0 or len(zlib.compress(raw, 1)) < COMPRESS_WORTH * len(raw)
            info = zipfile.ZipInfo(name + ".npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED if small else zipfile.ZIP_STORED
            if small:
                info._compresslevel = 1  # the level field of ZipInfo (Python 3.11+, public as compress_level in 3.13)
            with zf.open(info, "w", force_zip64=a.nbytes > 2**31 - 2**20) as out:
                np.lib.format.write_array(out, a, allow_pickle=False)


def job_toml(config: dict[str, Any]) -> str:
    """The job's options as the text of ``job.toml`` (``[job]`` table, ``None`` options left out)."""
    import tomli_w

    d = {k: (list(v) if isinstance(v, tuple) else v) for k, v in config.items() if v is not None}
    doc: dict[str, Any] = {"job": d}
    em = d.pop("error_map_options", None)
    if em:  # figuring options: their own [error_map] table
        doc["error_map"] = em
    head = f"# polishpath {__version__} job: re-run exactly with `polishpath plan --config job.toml`\n"
    return head + tomli_w.dumps(doc)


class NpzArrays(Mapping):
    """The arrays of a ``run.npz``, read on first use (a read-only mapping name -> ndarray).

    Opening reads the zip's directory only (and refuses a broken file with an
    :class:`InputError`); an array is read when first asked for and kept. A
    large array stored without compression (:func:`write_npz`) is mapped from
    the file instead of read (copy-on-write: the caller may change its copy),
    so a report that draws 20,000 of 10^7 machine samples reads only their
    pages. A broken entry, met when read, is an :class:`InputError` too.
    """

    #: stored entries at least this large are memory-mapped rather than read, bytes
    MAP_BYTES = 16 * 2**20

    def __init__(self, path: Path) -> None:
        import zipfile

        self.path = Path(path)
        self._cache: dict[str, np.ndarray] = {}
        try:
            with zipfile.ZipFile(self.path) as zf:
                self._entries = {i.filename[:-4]: i for i in zf.infolist() if i.filename.endswith(".npy")}
        except Exception as e:  # zipfile.BadZipFile / OSError / ValueError: all mean a broken file
            raise self._broken(e) from e

    def _broken(self, e: Exception) -> InputError:
        return InputError(f"{self.path} cannot be read ({e}).",
                          "The run may have been interrupted; run `polishpath plan` again.")

    def __getitem__(self, name: str) -> np.ndarray:
        if name in self._cache:
            return self._cache[name]
        info = self._entries[name]  # KeyError for a missing key, as a dict
        try:
            a = self._read(info)
        except Exception as e:  # a truncated or corrupt entry
            raise self._broken(e) from e
        self._cache[name] = a
        return a

    def _read(self, info) -> np.ndarray:
        import zipfile

        with zipfile.ZipFile(self.path) as zf:
            if info.compress_type == zipfile.ZIP_STORED and info.file_size >= self.MAP_BYTES:
                with open(self.path, "rb") as fh:  # the entry's bytes: after its local header (30 bytes + name + extra)
                    fh.seek(info.header_offset)
                    head = fh.read(30)
                    if head[:4] != b"PK\x03\x04":
                        raise ValueError(f"bad local header of {info.filename}")
                    start = info.header_offset + 30 + int.from_bytes(head[26:28], "little") + \
                        int.from_bytes(head[28:30], "little")
                    fh.seek(start)
                    fmt = np.lib.format
                    version = fmt.read_magic(fh)
                    header = {(1, 0): fmt.read_array_header_1_0, (2, 0): fmt.read_array_header_2_0}.get(version)
                    if header is not None:
                        shape, fortran, dtype = header(fh)
                        if not dtype.hasobject:
                            return np.asarray(np.memmap(self.path, dtype=dtype, mode="c", offset=fh.tell(),
                                                        shape=shape, order="F" if fortran else "C"))
            with zf.open(info) as fh:
                return np.lib.format.read_array(fh, allow_pickle=False)

    def __iter__(self):
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def __contains__(self, name: object) -> bool:
        return name in self._entries


@dataclass(frozen=True)
class RunData:
    """A run folder read back (:func:`read_run`).

    Attributes
    ----------
    folder : Path
        The run folder.
    summary : dict
        Contents of ``summary.json``.
    arrays : mapping of str -> ndarray
        Contents of ``run.npz`` (keys in :data:`ARRAY_KEYS`; any may be missing in an old folder),
        each read on first use (:class:`NpzArrays`).
    config : dict
        The ``[job]`` table of ``job.toml`` (empty when the folder has none).
    schema : int
        Format version of the folder (0: written before the format had one).
    simulation : dict
        ``{"folder": Path, "summary": dict or None, "table": str or None,
        "images": [Path, ...]}`` when ``folder/simulation`` holds a
        ``polishpath simulate`` result, else empty.

    The stages' results, rebuilt on first use (``InputError`` when the folder
    lacks an array they need): :attr:`surface`, :attr:`flattening`,
    :attr:`region`, :attr:`planar`, :attr:`surface_path`, :attr:`tool_path`.
    """

    folder: Path
    summary: dict[str, Any]
    arrays: Mapping[str, np.ndarray] = field(default_factory=dict)
    config: dict[str, Any] = field(default_factory=dict)
    schema: int = SCHEMA_VERSION
    simulation: dict[str, Any] = field(default_factory=dict)

    # --- raw access -------------------------------------------------------------------

    def get(self, name: str) -> np.ndarray | None:
        """Array ``name`` or None when the run did not save it (or it is empty)."""
        a = self.arrays.get(name)
        if a is None or a.size == 0:
            return None
        return a

    def section(self, *keys: str) -> dict[str, Any]:
        """Nested dict of ``summary.json`` (empty dict where absent or not a dict)."""
        d: Any = self.summary
        for k in keys:
            d = d.get(k) if isinstance(d, dict) else None
        return d if isinstance(d, dict) else {}

    @property
    def spacing(self) -> float | None:
        """Intended dwell-point spacing on the part, mm (the ``s`` of the normal range [s, sqrt(2) s])."""
        for v in (self.section("plan").get("surface_spacing_mm"), self.section("config").get("spacing")):
            if isinstance(v, (int, float)) and math.isfinite(v) and v > 0:
                return float(v)
        return None

    @property
    def region_loops(self) -> list[np.ndarray]:
        """Planar boundary loops, outer first, each (L, 2) mm."""
        loops = []
        i = 0
        while f"region_loop_{i}" in self.arrays:
            loops.append(np.asarray(self.arrays[f"region_loop_{i}"], dtype=float))
            i += 1
        return loops

    @property
    def residuals(self) -> dict[str, np.ndarray]:
        """Constraint residuals present in the run (``triangle``, ``vertex``, ``wheel``), any shape flattened."""
        out = {}
        for k in sorted(self.arrays):
            if k.startswith("residual_") and self.arrays[k].size:
                out[k[len("residual_"):]] = np.asarray(self.arrays[k], dtype=float).ravel()
        return out

    # --- the stages' results ------------------------------------------------------------

    def _need(self, *names: str) -> list[np.ndarray]:
        missing = [n for n in names if n not in self.arrays]
        if missing:
            raise InputError(
                f"{self.folder / ARRAYS_FILE} lacks {', '.join(missing)} (written by an older polishpath, "
                f"run-folder format {self.schema}).",
                "Run the job again with `polishpath plan --config DIR/job.toml -o DIR`.",
            )
        return [self.arrays[n] for n in names]

    def _provenance(self, section: str, stage: str) -> Provenance:
        d = self.section(section, "provenance")
        return Provenance(d.get("stage", stage), d.get("method", "unknown"), dict(d.get("params") or {}),
                          d.get("seed"), d.get("version", "unknown"))

    @cached_property
    def surface(self) -> Surface:
        """The part, (V, 3) vertices in mm."""
        v, f = self._need("vertices", "faces")
        s = self.section("surface")
        return Surface(v, f, name=str(s.get("name") or "surface"), source=str(s.get("source") or ""))

    @cached_property
    def flattening(self) -> Flattening:
        """The flattening, ``uv`` (V, 2) mm."""
        uv, angles = self._need("uv", "angles")
        fl = self.section("flattening")
        return Flattening(self.surface, uv, angles, residuals=self.residuals, metrics=dict(fl.get("metrics") or {}),
                          timings=dict(fl.get("timings_s") or {}), provenance=self._provenance("flattening", "flatten"))

    @cached_property
    def region(self) -> Region:
        """The planning region in the plane of the flattening, mm."""
        loops = self.region_loops
        if not loops:
            self._need("region_loop_0")
        return Region(loops[0], tuple(loops[1:]))

    @cached_property
    def planar(self) -> PlanarPath:
        """The planar path: dwell points ``uv`` (N, 2) mm in path order."""
        uv, ij, pieces, unreached, h, origin, rot = self._need(
            "plan_uv", "plan_ij", "plan_pieces", "plan_unreached", "plan_spacing", "plan_origin", "plan_rotation")
        p = self.section("plan")
        stats = dict(p.get("stats") or {})
        if self.schema < 3:  # every planner of formats 0-2 planned on the square grid; on_grid was a figure
            lattice, only = Lattice.square(float(h), origin, float(rot)), bool(stats.pop("on_grid", True))
        else:
            basis, lorigin, steps, only = self._need(
                "plan_lattice_basis", "plan_lattice_origin", "plan_lattice_steps", "plan_dwell_points_only")
            lattice = Lattice(basis, lorigin, steps) if basis.size else None
        prov = self._provenance("plan", "plan")
        # a set without a lattice: its cells (an older folder, or a grid run, has none: each point spacing^2)
        cell = self.arrays["plan_cell_area"] if "plan_cell_area" in self.arrays else np.zeros(0)
        return PlanarPath(uv, ij, float(h), origin=origin, rotation=float(rot), pattern=str(p.get("pattern", "unknown")),
                          pieces=pieces, unreached=unreached.reshape(-1, 2),
                          n_inside=int(len(uv) + len(unreached.reshape(-1, 2))),
                          provenance=prov, stats=stats, lattice=lattice, dwell_points_only=bool(only),
                          dwell_points=str(prov.params.get("dwell_points", "grid")),
                          cell_area=cell if len(cell) == len(uv) and len(uv) else None)

    @cached_property
    def surface_path(self) -> SurfacePath:
        """The dwell points on the part, ``xyz`` (N, 3) mm, with normals and dwell weights."""
        xyz, nrm, fid, bary, w = self._need("xyz", "normals", "face_ids", "bary", "dwell_weight")
        m = self.section("map")
        axes = self.arrays[TOOL_AXES_KEY] if TOOL_AXES_KEY in self.arrays else None
        law = (self.summary.get("config") or {}).get("tool_axis") or ("normal" if axes is not None else "z")
        return SurfacePath(xyz, nrm, fid, bary, w, self.planar, provenance=self._provenance("map", "map"),
                           stats=dict(m.get("stats") or {}), tool_axes=axes, tool_axis=str(law))

    @property
    def samples_stored(self) -> bool:
        """True when ``run.npz`` holds the machine samples (a format-1 folder, or a path without a schedule);
        False when it holds their schedule (:data:`SCHEDULE_ARRAY_KEYS`) and they are regenerated on demand."""
        return not all(k in self.arrays for k in SCHEDULE_ARRAY_KEYS)

    @cached_property
    def tool_path(self) -> ToolPath:
        """The machine path: ``samples`` (M, 3) mm at ``period_ms``, ``feed_mm_min`` (M,) mm/min.

        A folder that stores the samples' schedule rather than the samples
        (:attr:`samples_stored` False) gives a ToolPath with empty sample arrays
        and its ``schedule``: ``polishpath.smooth.iter_sample_chunks`` regenerates
        the samples from it bit for bit (what ``polishpath simulate RUN_DIR`` does).
        """
        knots, cp, w, deg, dp, dt = self._need(
            "knots", "control_points", "curve_weights", "curve_degree", "dwell_params", "dwell_times")
        schedule = None
        if self.samples_stored:
            smp, spar, feed = self._need(*SAMPLE_ARRAY_KEYS)
        else:
            try:
                schedule = schedule_from_arrays(self.arrays)
            except (ValueError, TypeError) as e:  # a malformed schedule: the folder is broken
                raise InputError(f"{self.folder / ARRAYS_FILE} holds a malformed sample schedule ({e}).",
                                 "Run the job again with `polishpath plan --config DIR/job.toml -o DIR`.") from e
            smp, spar, feed = np.zeros((0, 3)), np.zeros(0), np.zeros(0)
        sm = self.section("smooth")
        period = sm.get("period_ms")
        if not isinstance(period, (int, float)):
            raise InputError(f"{self.folder / SUMMARY_FILE} lacks smooth.period_ms.",
                             "Run the job again with `polishpath plan --config DIR/job.toml -o DIR`.")
        stats = dict(sm.get("stats") or {})
        if self.schema < 3 and "sample_pieces" not in self.arrays:  # formats 0-2: figures of summary.json
            spieces, pparams = stats.pop("sample_pieces", None), stats.pop("piece_params", None)
            if spieces is None or pparams is None:
                self._need("sample_pieces", "piece_params")
        else:
            spieces, pparams = self._need("sample_pieces", "piece_params")
        try:
            return ToolPath(NurbsCurve(int(deg), knots, cp, w), dp, smp, spar, feed, float(period), self.surface_path,
                            provenance=self._provenance("smooth", "smooth"), stats=stats,
                            dwell_times=dt if dt.size else None, schedule=schedule, sample_pieces=spieces,
                            piece_params=pparams)
        except ParameterError as e:  # pieces that do not fit the samples: the folder is broken
            raise InputError(f"{self.folder} holds a tool path whose pieces do not fit it ({e.message})",
                             "Run the job again with `polishpath plan --config DIR/job.toml -o DIR`.") from e


def read_run(folder: str | Path) -> RunData:
    """Read a run folder written by ``polishpath plan ... -o DIR`` (:func:`write_run`).

    Parameters
    ----------
    folder : path
        The run folder; must hold ``summary.json`` and ``run.npz`` (``job.toml`` optional).

    Returns
    -------
    RunData

    Raises
    ------
    InputError
        The folder does not exist, is not a polishpath run, was written by a newer
        format, or its files are unreadable.
    """
    d = Path(folder)
    if not d.is_dir():
        raise InputError(f"{d} is not a folder.",
                         "Give the output folder of a finished run (`polishpath plan SURFACE -o DIR`).")
    sp = d / SUMMARY_FILE
    if not sp.is_file():
        raise InputError(f"{d} is not a polishpath run folder: it has no {SUMMARY_FILE}.",
                         "Give the folder written by `polishpath plan SURFACE -o DIR`, "
                         "or run the plan again to write it.")
    try:
        summary = json.loads(sp.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise InputError(f"{sp} cannot be read as JSON ({e}).",
                         "The run may have been interrupted; run `polishpath plan` again.") from e
    if not isinstance(summary, dict):
        raise InputError(f"{sp} does not hold a JSON object.", "Run `polishpath plan` again to rewrite it.")
    schema = summary.get(SCHEMA_KEY, 0)
    if not isinstance(schema, int) or isinstance(schema, bool) or schema < 0:
        raise InputError(f"{sp}: {SCHEMA_KEY} must be a whole number, got {schema!r}.",
                         "Run `polishpath plan` again to rewrite it.")
    if schema > SCHEMA_VERSION:
        raise InputError(f"{d} was written in run-folder format {schema}; this polishpath {__version__} reads up to "
                         f"{SCHEMA_VERSION}.", "Upgrade polishpath to read it.")
    npz = d / ARRAYS_FILE
    if not npz.is_file():
        raise InputError(f"{d} has no {ARRAYS_FILE} (the arrays of the run).",
                         "Run `polishpath plan` again with this version of polishpath to write it.")
    arrays = NpzArrays(npz)
    config: dict[str, Any] = {}
    if (d / JOB_FILE).is_file():
        table = read_toml(d / JOB_FILE).get("job", {})
        config = table if isinstance(table, dict) else {}
    return RunData(d, summary, arrays, config, schema, _read_simulation(d / SIMULATION_DIR))


def _read_simulation(sim: Path) -> dict[str, Any]:
    """What a ``polishpath simulate`` run left in ``sim`` (defensive: any file may be missing)."""
    if not sim.is_dir():
        return {}
    out: dict[str, Any] = {"folder": sim, "summary": None, "table": None, "images": []}
    for name in ("summary.json", "results.json"):
        p = sim / name
        if p.is_file():
            try:
                data = json.loads(p.read_text(encoding="utf-8"))
            except (OSError, UnicodeDecodeError, json.JSONDecodeError):
                continue
            out["summary"] = data
            break
    t = sim / "table.txt"
    if t.is_file():
        try:
            out["table"] = t.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):
            pass
    imgs = sorted(sim.glob("*.png"))
    # PSD curves first, then the residual maps, then anything else
    imgs.sort(key=lambda p: (0 if "psd" in p.stem.lower() else 1 if "resid" in p.stem.lower() else 2, p.name))
    out["images"] = imgs
    if out["summary"] is None and out["table"] is None and not imgs:
        return {}
    return out
