"""polishpath.export — files a machine (and a person) reads.

* ``path.csv``      :func:`write_path_csv` — one row per dwell point;
* ``toolpath.xyz``  :func:`write_xyz` — dense "X Y Z" samples in path order (the
  format the paper's 3-axis machine reads);
* ``toolpath.nc``   :func:`write_gcode` — G21/G90/G17 G-code, dense G01 moves or
  Fanuc-style G06.2 NURBS blocks, optional tool-radius offset;
* ``summary.json``  :func:`write_summary_json` (:func:`build_summary` collects it).

Every writer takes a path or an open text file. Given a path it writes to a
temporary file in the same folder and renames it into place, so an interrupted
run (Ctrl-C) never leaves a half-written file. :func:`read_xyz`,
:func:`read_path_csv` read the files back. See ``docs/machine-output.md``.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import math
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from .._version import __version__
from ..fileio import atomic_open, jsonable
from ..errors import ExportError, ParameterError
from ..types import SurfacePath, ToolPath

__all__ = [
    "write_path_csv",
    "read_path_csv",
    "write_xyz",
    "read_xyz",
    "write_gcode",
    "write_summary_json",
    "build_summary",
    "offset_along_normals",
    "read_dwell_times",
    "write_outputs",
    "PATH_CSV_COLUMNS",
]

PATH_CSV_COLUMNS = ("index", "i", "j", "u", "v", "x", "y", "z", "nx", "ny", "nz", "dwell_time")


@contextlib.contextmanager
def _text_out(file) -> Iterator[io.TextIOBase]:
    """Yield a text stream; for a path, write a temp file and rename it on success."""
    if hasattr(file, "write"):
        yield file
        return
    path = Path(file)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise ExportError(f"Cannot write {path}: folder {folder} does not exist.", "Create the folder first.")
    with atomic_open(path, "w") as fh:
        yield fh


@contextlib.contextmanager
def _text_in(file) -> Iterator[io.TextIOBase]:
    if hasattr(file, "read"):
        yield file
        return
    path = Path(file)
    if not path.is_file():
        raise ExportError(f"Cannot read {path}: no such file.")
    with open(path, encoding="utf-8", newline="") as fh:
        yield fh


def _write_rows(fh, row_fmt: str, table: np.ndarray, chunk: int = 65536) -> None:
    """Write ``row_fmt % row`` for every row of a 2D float table, in large chunks.

    One ``%`` over a chunk-sized format string runs in C, ~5x faster than
    ``numpy.savetxt``'s per-row Python loop (hand-written for that reason).
    """
    n, m = table.shape
    for a in range(0, n, chunk):
        part = table[a : a + chunk]
        fh.write((row_fmt * len(part)) % tuple(part.ravel().tolist()))


def _rounded(a: np.ndarray, decimals: int) -> np.ndarray:
    # round, then add +0.0 so that tiny negatives print as 0.0000, not -0.0000
    return np.round(np.asarray(a, dtype=np.float64), decimals) + 0.0


def _fmt(v: float, decimals: int) -> str:
    s = f"{v:.{decimals}f}"
    if s.startswith("-") and float(s) == 0.0:
        s = s[1:]
    return s


# --------------------------------------------------------------------------------------
# path.csv
# --------------------------------------------------------------------------------------


def write_path_csv(path_data: ToolPath | SurfacePath, file, *, dwell_times: np.ndarray | None = None) -> None:
    """One CSV row per dwell point, in path order.

    Parameters
    ----------
    path_data : ToolPath or SurfacePath
        Dwell points (N of them).
    file : str, Path or text file
    dwell_times : (N,) float, optional
        Dwell time per point, s. Default: ``ToolPath.dwell_times``; for a
        bare SurfacePath, its relative ``dwell_weight`` (mean 1).

    Notes
    -----
    Columns: ``index, i, j`` (grid indices), ``u, v`` (planar position, mm),
    ``x, y, z`` (mm), ``nx, ny, nz`` (unit normal), ``dwell_time`` (s). Numbers
    are written with 17 significant digits (exact round trip).
    """
    if isinstance(path_data, ToolPath):
        sp = path_data.surface_path
        times = dwell_times if dwell_times is not None else path_data.dwell_times
    elif isinstance(path_data, SurfacePath):
        sp = path_data
        times = dwell_times
    else:
        raise ExportError(f"write_path_csv needs a ToolPath or SurfacePath, got {type(path_data).__name__}.")
    n = len(sp.xyz)
    times = np.asarray(sp.dwell_weight if times is None else times, dtype=np.float64)
    if times.shape != (n,):
        raise ParameterError(f"dwell_times has shape {times.shape}, expected ({n},).")
    ij = sp.planar.ij if sp.planar is not None and len(sp.planar.ij) == n else np.zeros((n, 2), np.int64)
    uv = sp.planar.uv if sp.planar is not None and len(sp.planar.uv) == n else np.full((n, 2), np.nan)
    table = np.column_stack([np.arange(n), ij, uv, sp.xyz, sp.normals, times]).astype(np.float64)
    with _text_out(file) as fh:
        fh.write(",".join(PATH_CSV_COLUMNS) + "\n")
        _write_rows(fh, "%d,%d,%d" + ",%.17g" * 9 + "\n", table)


def read_path_csv(file) -> dict[str, np.ndarray]:
    """Read a ``path.csv`` back: a dict of column name -> (N,) array (``index``, ``i``, ``j`` int64)."""
    with _text_in(file) as fh:
        rows = list(csv.reader(fh))
    if not rows or tuple(rows[0]) != PATH_CSV_COLUMNS:
        raise ExportError(f"Not a polishpath path.csv: expected header {','.join(PATH_CSV_COLUMNS)}.")
    data = np.array(rows[1:], dtype=np.float64).reshape(-1, len(PATH_CSV_COLUMNS))
    out = {c: data[:, k] for k, c in enumerate(PATH_CSV_COLUMNS)}
    for c in ("index", "i", "j"):
        out[c] = out[c].astype(np.int64)
    return out


def read_dwell_times(file, n_points: int | None = None) -> np.ndarray:
    """Per-dwell-point times from a CSV, (N,) s.

    Accepts a file with a header holding a ``dwell_time`` column (e.g. an edited
    ``path.csv``), or one number per line (no header). Rows are in path order.

    Raises
    ------
    ParameterError
        If a time is not a positive finite number, or the count differs from
        ``n_points``.
    """
    with _text_in(file) as fh:
        rows = [r for r in csv.reader(fh) if r and any(c.strip() for c in r)]
    if not rows:
        raise ParameterError("The dwell-time file is empty.", "Give one time (s) per dwell point.")
    head = [c.strip().lower() for c in rows[0]]
    try:
        if "dwell_time" in head:
            k = head.index("dwell_time")
            t = np.array([float(r[k]) for r in rows[1:]])
        else:
            t = np.array([float(r[0]) for r in rows])
    except (ValueError, IndexError) as exc:
        raise ParameterError(f"The dwell-time file holds a value that is not a number ({exc}).",
                             "Write one time in seconds per row.") from exc
    if not np.all(np.isfinite(t)) or np.any(t <= 0):
        raise ParameterError("Every dwell time must be a positive number of seconds.")
    if n_points is not None and len(t) != n_points:
        raise ParameterError(f"The dwell-time file has {len(t)} times but the path has {n_points} dwell points.",
                             "Give one time per dwell point, in path order (see path.csv).")
    return t


# --------------------------------------------------------------------------------------
# toolpath.xyz
# --------------------------------------------------------------------------------------


def write_xyz(tool_path: ToolPath | np.ndarray, file, *, decimals: int = 6) -> None:
    """Dense samples, one ``X Y Z`` line each, in path order (mm, fixed point).

    Parameters
    ----------
    tool_path : ToolPath or (M, 3) array
        ``ToolPath.samples`` are written.
    file : str, Path or text file
    decimals : int
        Digits after the decimal point (6: 1 nm).
    """
    pts = tool_path.samples if isinstance(tool_path, ToolPath) else np.asarray(tool_path, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3 or not np.all(np.isfinite(pts)):
        raise ExportError(f"write_xyz needs finite (M, 3) points, got shape {pts.shape}.")
    with _text_out(file) as fh:
        _write_rows(fh, f"%.{decimals}f %.{decimals}f %.{decimals}f\n", _rounded(pts, decimals))


def read_xyz(file) -> np.ndarray:
    """Read ``X Y Z`` lines back, (M, 3) float64 (blank lines and ``#``/``;`` comments skipped)."""
    with _text_in(file) as fh:
        text = fh.read()
    lines = [ln.split() for ln in text.splitlines() if ln.strip() and ln.strip()[0] not in "#;("]
    if any(len(ln) != 3 for ln in lines):
        raise ExportError("An .xyz line does not hold exactly three numbers X Y Z.")
    return np.array(lines, dtype=np.float64).reshape(-1, 3)


# --------------------------------------------------------------------------------------
# toolpath.nc
# --------------------------------------------------------------------------------------


def offset_along_normals(points: np.ndarray, normals: np.ndarray, radius: float) -> np.ndarray:
    """Tool-centre positions: contact ``points`` (M, 3) moved by ``radius`` mm along unit ``normals`` (M, 3)."""
    n = np.asarray(normals, dtype=np.float64)
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    return np.asarray(points, dtype=np.float64) + float(radius) * n


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


def write_gcode(
    tool_path: ToolPath,
    file,
    *,
    mode: str = "linear",
    tool_radius: float = 0.0,
    header: dict | None = None,
    clearance: float = 5.0,
    decimals: int = 4,
    knot_decimals: int = 6,
) -> None:
    """G-code for a 3-axis machine (G21 mm, G90 absolute, G17 XY plane).

    Parameters
    ----------
    tool_path : ToolPath
    file : str, Path or text file
    mode : {"linear", "nurbs"}
        ``"linear"``: one ``G01 X Y Z F`` per constant-period sample (the feed
        schedule is kept sample by sample). ``"nurbs"``: Fanuc-style ``G06.2``
        blocks (order P4, one knot K and control point X Y Z R per block, then
        P trailing knots) per continuous piece, knots scaled to mm of the
        piece's chord length; one feed per piece (its mean feed).
    tool_radius : float
        Tool (ball / sponge) radius, mm: contact points are moved by this much
        along the surface normal to the tool centre (normals are taken to point
        from the part towards the tool). In ``"nurbs"`` mode the dwell points are
        offset and a new curve is interpolated through them. Stated in the header.
    header : dict, optional
        Everything to record in the header comment (surface, spacing, seed, all
        parameters); the tool path's provenance is always added.
    clearance : float
        Retract height above the highest point, mm, for lifts between pieces
        (along +Z: the tool approaches from +Z).
    decimals, knot_decimals : int
        Digits after the decimal point for coordinates and knots.
    """
    if mode not in ("linear", "nurbs"):
        raise ParameterError(f"Unknown G-code mode {mode!r}.", "Use 'linear' or 'nurbs'.")
    if not math.isfinite(tool_radius):
        raise ParameterError(f"tool_radius must be a finite number of mm, got {tool_radius}.")
    from ..smooth import interpolate_nurbs, piece_curves, sample_normals

    st = tool_path.stats
    sp = tool_path.surface_path
    n = len(sp.xyz)
    pieces = np.asarray(sp.planar.pieces if sp.planar is not None else [0, n])
    piece_params = np.asarray(st.get("piece_params", [tool_path.curve.knots[0], tool_path.curve.knots[-1]]))
    spieces = np.asarray(st.get("sample_pieces", [0, len(tool_path.samples)]))
    f = lambda v: _fmt(v, decimals)  # noqa: E731

    blocks: list = []  # per piece, the motion lines after the approach (linear: a table of X Y Z F)
    starts: list[np.ndarray] = []
    if mode == "linear":
        pts = tool_path.samples
        if tool_radius != 0.0:
            pts = offset_along_normals(pts, sample_normals(tool_path), tool_radius)
        feeds = tool_path.feed_mm_min
        for k in range(len(spieces) - 1):
            a, b = spieces[k], spieces[k + 1]
            starts.append(pts[a])
            table = np.column_stack([_rounded(pts[a + 1 : b], decimals), _rounded(feeds[a + 1 : b], 1)])
            blocks.append(table)
    else:
        curves = piece_curves(tool_path.curve, piece_params)
        for k, c in enumerate(curves):
            a, b = pieces[k], pieces[k + 1]
            if tool_radius != 0.0:
                dw = offset_along_normals(sp.xyz[a:b], sp.normals[a:b], tool_radius)
                if len(dw) >= 4:
                    c, _ = interpolate_nurbs(dw, c.degree)
                else:
                    from ..smooth.nurbs import bezier_cubic_through

                    c, _ = bezier_cubic_through(dw)
            kn = c.knots
            lo, hi = kn[0], kn[-1]
            chord = float(np.linalg.norm(np.diff(c.control_points, axis=0), axis=1).sum()) or 1.0
            ks = (kn - lo) / (hi - lo) * chord
            fk = lambda v: _fmt(v, knot_decimals)  # noqa: E731
            sa, sb = spieces[k], spieces[k + 1]
            feed = float(np.mean(tool_path.feed_mm_min[sa:sb])) if sb > sa else float(tool_path.feed_mm_min.mean())
            cp = c.control_points
            lines = [f"G06.2 P{c.degree + 1} K{fk(ks[0])} X{f(cp[0, 0])} Y{f(cp[0, 1])} Z{f(cp[0, 2])} R1.0 F{_fmt(feed, 1)}"]
            lines += [f"K{fk(ks[i])} X{f(cp[i, 0])} Y{f(cp[i, 1])} Z{f(cp[i, 2])} R1.0" for i in range(1, len(cp))]
            lines += [f"K{fk(v)}" for v in ks[len(cp):]]
            starts.append(cp[0])
            blocks.append(lines)

    all_z = np.concatenate([np.atleast_2d(s) for s in starts])[:, 2]
    zmax = float(max(all_z.max(), (tool_path.samples[:, 2].max() + abs(tool_radius)))) if len(all_z) else 0.0
    safe = zmax + float(clearance)
    hdr: list[tuple[str, Any]] = [("generator", f"polishpath {__version__}")]
    hdr += _flatten_header(header or {})
    hdr += _flatten_header(tool_path.provenance.to_dict(), "smooth.")
    if sp.provenance is not None:
        hdr += _flatten_header(sp.provenance.to_dict(), "map.")
    hdr += [("mode", mode), ("dwell_points", n), ("samples", len(tool_path.samples)),
            ("pieces", len(pieces) - 1), ("period_ms", tool_path.period_ms),
            ("tool_radius_mm", float(tool_radius)), ("safe_z_mm", safe)]
    with _text_out(file) as fh:
        fh.write("%\n")
        for k, v in hdr:
            fh.write(_comment(f"{k}: {v}") + "\n")
        if tool_radius != 0.0:
            fh.write(_comment(f"TOOL RADIUS OFFSET: contact points moved {tool_radius} mm along the surface "
                              "normal to the tool centre") + "\n")
        else:
            fh.write(_comment("no tool radius offset: coordinates are the tool-part contact points") + "\n")
        if mode == "nurbs":
            fh.write(_comment("G06.2 NURBS: one feed per piece; use linear mode to keep the dwell-time feed schedule") + "\n")
        fh.write("G21 G90 G17\nG94\n")
        for k, lines in enumerate(blocks):
            p0 = starts[k]
            fh.write(f"G00 Z{f(safe)}\n")
            fh.write(f"G00 X{f(p0[0])} Y{f(p0[1])}\n")
            feed0 = float(tool_path.feed_mm_min[spieces[k]]) if len(tool_path.feed_mm_min) else 100.0
            fh.write(f"G01 Z{f(p0[2])} F{_fmt(feed0, 1)}\n")
            if isinstance(lines, np.ndarray):
                d = decimals
                _write_rows(fh, f"G01 X%.{d}f Y%.{d}f Z%.{d}f F%.1f\n", lines)
            else:
                fh.write("\n".join(lines) + ("\n" if lines else ""))
        fh.write(f"G00 Z{f(safe)}\nM30\n%\n")


# --------------------------------------------------------------------------------------
# summary.json
# --------------------------------------------------------------------------------------


def write_summary_json(summary: dict, file) -> None:
    """Write a summary dict as indented JSON (numpy values converted; NaN / inf -> null)."""
    if not isinstance(summary, dict):
        raise ExportError(f"write_summary_json needs a dict, got {type(summary).__name__}.")
    with _text_out(file) as fh:
        json.dump(jsonable(summary), fh, indent=2, sort_keys=False, allow_nan=False)
        fh.write("\n")


def build_summary(tool_path: ToolPath | None = None, surface_path: SurfacePath | None = None,
                  extra: dict | None = None) -> dict:
    """The summary of a run: parameters, seed, version and every statistic.

    Parameters
    ----------
    tool_path : ToolPath, optional
    surface_path : SurfacePath, optional
        Default: ``tool_path.surface_path``.
    extra : dict, optional
        Added at the top level (surface, flattening, planner figures ...).

    Returns
    -------
    dict
        ``version``, ``seed``, ``provenance`` (per stage), ``surface_path``
        (3D step statistics, density variation), ``tool_path`` (interpolation
        and deviation figures; per-point arrays left out) and ``dwell_time_note``.
    """
    sp = surface_path if surface_path is not None else (tool_path.surface_path if tool_path is not None else None)
    out: dict[str, Any] = {"version": __version__}
    prov = {}
    if sp is not None:
        out["seed"] = sp.planar.provenance.seed if sp.planar is not None else sp.provenance.seed
        prov["plan"] = sp.planar.provenance.to_dict() if sp.planar is not None else None
        prov["map"] = sp.provenance.to_dict()
        out["surface_path"] = dict(sp.stats)
    if tool_path is not None:
        prov["smooth"] = tool_path.provenance.to_dict()
        out["tool_path"] = {k: v for k, v in tool_path.stats.items() if k not in ("dwell_times",)}
        src = tool_path.stats.get("dwell_time_source", "")
        if src == "uniform x area weight":
            out["dwell_time_note"] = (
                "Dwell times are uniform scaled by the part area each dwell point stands for "
                "(the flattening's local area ratio), so a uniform removal stays uniform on the part."
            )
        else:
            out["dwell_time_note"] = f"Dwell times: {src}."
    out["provenance"] = prov
    if extra:
        out.update(extra)
    return out


def write_outputs(
    directory,
    tool_path: ToolPath,
    *,
    header: dict | None = None,
    gcode_mode: str = "linear",
    tool_radius: float = 0.0,
    summary_extra: dict | None = None,
) -> dict[str, Path]:
    """Write ``path.csv``, ``toolpath.xyz``, ``toolpath.nc`` and ``summary.json`` into a folder.

    Parameters
    ----------
    directory : str or Path
        Created if missing.
    tool_path : ToolPath
    header : dict, optional
        For the G-code header and the summary (surface, spacing, seed, parameters).
    gcode_mode : {"linear", "nurbs"}
    tool_radius : float
        Tool radius offset for the G-code, mm.
    summary_extra : dict, optional
        Added to the summary.

    Returns
    -------
    dict
        File role -> path written.
    """
    d = Path(directory)
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ExportError(f"Cannot create the output folder {d}: {exc}.", "Choose a writable folder.") from exc
    out = {"path_csv": d / "path.csv", "xyz": d / "toolpath.xyz", "gcode": d / "toolpath.nc",
           "summary": d / "summary.json"}
    write_path_csv(tool_path, out["path_csv"])
    write_xyz(tool_path, out["xyz"])
    write_gcode(tool_path, out["gcode"], mode=gcode_mode, tool_radius=tool_radius, header=header)
    extra = {"parameters": header or {}, "gcode": {"mode": gcode_mode, "tool_radius_mm": float(tool_radius)}}
    extra.update(summary_extra or {})
    write_summary_json(build_summary(tool_path, extra=extra), out["summary"])
    return out
