"""The record files of a run: ``path.csv``, ``toolpath.xyz``, ``summary.json``.

Also the small helpers every writer shares (atomic write to a path or an open
file, text or binary; fixed-point numbers without ``-0``); the bulk formatting
of rows is :mod:`polishpath.export.textfmt`.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
from pathlib import Path
from typing import Iterator

import numpy as np

from ..fileio import atomic_open, jsonable
from ..errors import ExportError, ParameterError
from ..types import SurfacePath, ToolPath
from .textfmt import format_csv, format_fixed

__all__ = ["write_path_csv", "read_path_csv", "write_xyz", "xyz_writer", "read_xyz", "write_summary_json", "read_dwell_times",
           "PATH_CSV_COLUMNS", "PATH_CSV_AXIS_COLUMNS"]

PATH_CSV_COLUMNS = ("index", "i", "j", "u", "v", "x", "y", "z", "nx", "ny", "nz", "dwell_time")
#: the columns a 5-axis path's ``path.csv`` adds at the end (``--tool-axis`` not ``z``): the unit tool axis
#: (part frame, tip to spindle; :mod:`polishpath.axes`); a 3-axis path.csv has none (its bytes as before)
PATH_CSV_AXIS_COLUMNS = ("axis_x", "axis_y", "axis_z")


def _writable_path(file) -> Path:
    """``file`` as a Path whose folder exists (else an ExportError naming it)."""
    path = Path(file)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise ExportError(f"Cannot write {path}: folder {folder} does not exist.", "Create the folder first.")
    return path


@contextlib.contextmanager
def _text_out(file) -> Iterator[io.TextIOBase]:
    """Yield a text stream; for a path, write a temp file and rename it on success."""
    if hasattr(file, "write"):
        yield file
        return
    with atomic_open(_writable_path(file), "w") as fh:
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


#: rows formatted per write: ~6 MB of text per chunk
CHUNK_ROWS = 65536


def _is_binary(fh) -> bool:
    return isinstance(fh, (io.RawIOBase, io.BufferedIOBase)) or "b" in str(getattr(fh, "mode", ""))


@contextlib.contextmanager
def _bytes_out(file) -> Iterator:
    """Yield ``write(data: bytes)``; a path is written atomically in binary, an open text file gets ASCII text."""
    if hasattr(file, "write"):
        yield file.write if _is_binary(file) else (lambda b: file.write(b.decode("ascii")))
        return
    with atomic_open(_writable_path(file), "wb") as fh:
        yield fh.write


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
    ``x, y, z`` (mm), ``nx, ny, nz`` (unit normal), ``dwell_time`` (s), and for a
    5-axis path (``tool_axes`` set) ``axis_x, axis_y, axis_z`` (unit tool axis). Numbers
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
    # %d of the float table the columns once were: truncation toward zero
    ints = np.column_stack([np.arange(n), np.trunc(np.asarray(ij, dtype=np.float64))]).astype(np.int64)
    cols = [uv, sp.xyz, sp.normals, times] + ([] if sp.tool_axes is None else [sp.tool_axes])
    floats = np.column_stack(cols).astype(np.float64)
    header = PATH_CSV_COLUMNS + (() if sp.tool_axes is None else PATH_CSV_AXIS_COLUMNS)
    with _bytes_out(file) as write:
        write((",".join(header) + "\n").encode())
        for a in range(0, n, CHUNK_ROWS):
            write(format_csv(ints[a : a + CHUNK_ROWS], floats[a : a + CHUNK_ROWS]))


def read_path_csv(file) -> dict[str, np.ndarray]:
    """Read a ``path.csv`` back: a dict of column name -> (N,) array (``index``, ``i``, ``j`` int64)."""
    with _text_in(file) as fh:
        rows = list(csv.reader(fh))
    names = tuple(rows[0]) if rows else ()
    if names not in (PATH_CSV_COLUMNS, PATH_CSV_COLUMNS + PATH_CSV_AXIS_COLUMNS):
        raise ExportError(f"Not a polishpath path.csv: expected header {','.join(PATH_CSV_COLUMNS)} "
                          f"(and {','.join(PATH_CSV_AXIS_COLUMNS)} for a 5-axis path).")
    data = np.array(rows[1:], dtype=np.float64).reshape(-1, len(names))
    out = {c: data[:, k] for k, c in enumerate(names)}
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
    bad = ~(np.isfinite(t) & (t > 0))
    if bad.any():
        k = int(np.argmax(bad))
        name = f"{Path(file).name}: " if isinstance(file, (str, Path)) else ""
        raise ParameterError(f"{name}{int(bad.sum())} of {len(t)} dwell times are not positive finite numbers of "
                             f"seconds (the first is time {k + 1}: {float(t[k])!r}).",
                             "Every dwell point needs a time > 0 s, in path order (see path.csv).")
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
    with _bytes_out(file) as write:
        for a in range(0, len(pts), CHUNK_ROWS):
            write(format_fixed(pts[a : a + CHUNK_ROWS], decimals))


@contextlib.contextmanager
def xyz_writer(file, *, decimals: int = 6) -> Iterator:
    """Yield ``add(chunk)``: each :class:`~polishpath.export.chunks.SampleChunk`'s samples as ``X Y Z`` lines.

    The streamed form of :func:`write_xyz` (same bytes for the same samples, whatever the chunks).
    """
    with _bytes_out(file) as write:

        def add(chunk) -> None:
            pts = chunk.samples
            if not np.all(np.isfinite(pts)):
                raise ExportError("write_xyz needs finite points; a chunk holds NaN or inf.")
            for a in range(0, len(pts), CHUNK_ROWS):
                write(format_fixed(pts[a : a + CHUNK_ROWS], decimals))

        yield add


def read_xyz(file) -> np.ndarray:
    """Read ``X Y Z`` lines back, (M, 3) float64 (blank lines and ``#``/``;`` comments skipped)."""
    with _text_in(file) as fh:
        text = fh.read()
    lines = [ln.split() for ln in text.splitlines() if ln.strip() and ln.strip()[0] not in "#;("]
    if any(len(ln) != 3 for ln in lines):
        raise ExportError("An .xyz line does not hold exactly three numbers X Y Z.")
    return np.array(lines, dtype=np.float64).reshape(-1, 3)


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
