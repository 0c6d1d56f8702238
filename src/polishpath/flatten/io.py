"""Write a flattening as an OBJ that any mesh tool reads."""

from __future__ import annotations

import io as _io
import os

import numpy as np

from ..errors import ExportError, MeshFileError
from ..types import Flattening


def save_obj(flat: Flattening, file) -> None:
    """Write the 3D mesh with its planar coordinates as texture coordinates.

    Parameters
    ----------
    flat : Flattening
    file : str, os.PathLike or text file object
        ``v x y z`` (3D, mm), ``vt u v`` (planar, mm) with the same numbering,
        and ``f a/a b/b c/c`` (1-based).

    Raises
    ------
    ExportError
        When the file cannot be written.
    """
    v = flat.surface.vertices
    f = flat.surface.faces + 1
    buf = _io.StringIO()
    buf.write(f"# polishpath flattening: method={flat.provenance.method} version={flat.provenance.version}\n")
    buf.write("# v: 3D vertices (mm); vt: planar coordinates (mm), same indices\n")
    np.savetxt(buf, v, fmt="v %.17g %.17g %.17g")
    np.savetxt(buf, flat.uv, fmt="vt %.17g %.17g")
    np.savetxt(buf, np.repeat(f, 2, axis=1), fmt="f %d/%d %d/%d %d/%d")
    text = buf.getvalue()
    if isinstance(file, (str, os.PathLike)):
        try:
            with open(file, "w", encoding="utf-8") as fh:
                fh.write(text)
        except OSError as exc:
            raise ExportError(f"Cannot write {os.fspath(file)!r}: {exc.strerror}.", "Check the path and permissions.") from exc
    else:
        file.write(text)


def load_obj_uv(file) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read back what :func:`save_obj` wrote.

    Returns
    -------
    vertices : (V, 3) float64
    uv : (V, 2) float64
    faces : (F, 3) int64
        0-based; the ``vt`` indices must equal the ``v`` indices.
    """
    name = os.fspath(file) if isinstance(file, (str, os.PathLike)) else getattr(file, "name", "the OBJ")
    try:
        text = open(file, encoding="utf-8").read() if isinstance(file, (str, os.PathLike)) else file.read()
    except (OSError, UnicodeDecodeError) as exc:
        raise MeshFileError(f"Cannot read {name!r}: {exc}.", "Give a flat.obj written by polishpath.") from None
    vs, vts, fs = [], [], []
    for k, line in enumerate(text.splitlines(), 1):
        parts = line.split()
        if not parts:
            continue
        try:
            if parts[0] == "v":
                vs.append([float(x) for x in parts[1:4]])
            elif parts[0] == "vt":
                vts.append([float(x) for x in parts[1:3]])
            elif parts[0] == "f":
                pairs = [p.split("/") for p in parts[1:4]]
                if any(len(p) < 2 or p[0] != p[1] for p in pairs):
                    raise MeshFileError(f"{name}, line {k}: texture indices differ from vertex indices.",
                                        "Read only OBJ files written by polishpath's save_obj (v and vt one to one).")
                fs.append([int(p[0]) - 1 for p in pairs])
        except ValueError:
            raise MeshFileError(f"{name}, line {k}: {line.strip()!r} is not a valid OBJ line.",
                                "Give a flat.obj written by polishpath.") from None
    return np.array(vs), np.array(vts), np.array(fs, dtype=np.int64)
