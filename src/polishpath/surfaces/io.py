"""Reading mesh files (STL ascii/binary, OBJ, PLY, OFF) through trimesh.

The counts a file declares (binary STL triangle count, PLY elements, OFF
header) are checked against its size and data before and after reading
(:mod:`polishpath.surfaces.integrity`), so a truncated file is reported as
truncated instead of loading as a smaller mesh.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import MeshFileError, ParameterError
from .integrity import check_after_reading, check_before_reading

MESH_FORMATS = ("stl", "obj", "ply", "off")

#: millimetres per unit
UNITS = {"mm": 1.0, "m": 1000.0, "cm": 10.0, "um": 1e-3, "in": 25.4, "inch": 25.4}


def unit_scale(units: str | None = None, scale: float | None = None) -> float:
    """Factor that turns file coordinates into millimetres.

    Parameters
    ----------
    units : str, optional
        Units of the file: ``mm`` (default), ``m``, ``cm``, ``um``, ``in``.
    scale : float, optional
        Explicit factor (multiplies the units factor).
    """
    if units is None:
        f = 1.0
    else:
        key = units.strip().lower()
        if key not in UNITS:
            raise ParameterError(f"unknown units {units!r}.", f"Use one of: {', '.join(sorted(set(UNITS) - {'inch'}))}.")
        f = UNITS[key]
    if scale is not None:
        if not (np.isfinite(scale) and scale > 0):
            raise ParameterError(f"scale must be a positive number, got {scale}.")
        f *= float(scale)
    return f


def read_mesh_file(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces of a mesh file, exactly as stored (no merging, no repair).

    Parameters
    ----------
    path : str or Path
        ``.stl``, ``.obj``, ``.ply`` or ``.off`` file.

    Returns
    -------
    vertices : (V, 3) float64
        In the file's units.
    faces : (F, 3) int64
        Triangles (polygons are triangulated by trimesh).

    Raises
    ------
    MeshFileError
        Missing, empty, unreadable file or unknown format.
    """
    import trimesh

    p = Path(path)
    if not p.exists():
        raise MeshFileError(f"mesh file {str(p)!r} does not exist.", "Check the path.")
    if p.is_dir():
        raise MeshFileError(f"{str(p)!r} is a folder, not a mesh file.")
    ext = p.suffix.lower().lstrip(".")
    if ext not in MESH_FORMATS:
        raise MeshFileError(
            f"unknown mesh format {p.suffix or '(no extension)'!r} for {p.name}.",
            f"polishpath reads {', '.join('.' + e for e in MESH_FORMATS)} meshes, "
            "or a built-in surface name (see `polishpath surfaces`) or a .toml surface spec.",
        )
    if p.stat().st_size == 0:
        raise MeshFileError(f"mesh file {p.name} is empty.", "Export the mesh again.")
    declared = check_before_reading(p, ext)
    if declared.get("faces"):
        from .. import resources

        nf = int(declared["faces"])
        resources.check(resources.estimate(nf), f"{p.name} ({nf:,} faces)",
                        "Decimate the mesh (e.g. MeshLab: Quadric Edge Collapse Decimation) or cut out the part to polish.")
    kwargs = {"maintain_order": True} if ext == "obj" else {}
    try:
        mesh = trimesh.load(str(p), file_type=ext, process=False, force="mesh", **kwargs)
    except ImportError as exc:  # a reader fell through to an optional decoder (trimesh's text guess)
        raise MeshFileError(f"could not read {p.name} as {ext.upper()}: it is neither a complete binary file nor "
                            f"plain text ({exc}).", "Is the file complete and of that format?") from None
    except Exception as exc:  # trimesh raises many kinds; all mean "unreadable"
        raise MeshFileError(f"could not read {p.name} as {ext.upper()}: {exc}", "Is the file complete and of that format?") from None
    v = np.asarray(getattr(mesh, "vertices", np.zeros((0, 3))), dtype=np.float64)
    f = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))), dtype=np.int64)
    if len(v) == 0 or len(f) == 0:
        raise MeshFileError(
            f"{p.name} holds no triangles ({len(v)} vertices, {len(f)} faces).",
            "Is it a point cloud or an empty export? polishpath needs a triangle mesh.",
        )
    f = f.reshape(-1, 3)
    check_after_reading(p, declared, len(v), len(f))
    return v, f
