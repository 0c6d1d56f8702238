"""Header counts and sizes of mesh files checked against their content, before and after reading.

trimesh reads what it can: a PLY whose header promises more vertices than it
holds, or an OFF cut short, come back as a smaller mesh that then fails later
with a symptom ("51 non-manifold vertices"), or not at all. These checks read
the header's promise and compare it with the file's size or data lines, so a
truncated or inconsistent file is reported as such.
"""

from __future__ import annotations

import re
import struct
from pathlib import Path

from ..errors import MeshFileError

_PLY_SIZES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
              "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8}
_PLURAL = {"vertex": "vertices", "face": "faces"}
_CHECK = "Export the mesh again, or check that the copy is complete."


def check_before_reading(path: Path, ext: str) -> dict:
    """Check a mesh file's declared counts against its size / data lines.

    Parameters
    ----------
    path : Path
        Mesh file (exists, not empty).
    ext : str
        ``stl``, ``ply``, ``off`` or ``obj`` (OBJ has no counts: nothing checked).

    Returns
    -------
    dict
        What the header declared: ``vertices`` and ``faces`` when known (empty for OBJ and ASCII STL).

    Raises
    ------
    MeshFileError
        Naming the truncation or the mismatch and what was found instead.
    """
    if ext == "stl":
        return _check_stl(path)
    if ext == "ply":
        return _check_ply(path)
    if ext == "off":
        return _check_off(path)
    return {}


def check_after_reading(path: Path, declared: dict, n_vertices: int, n_faces: int) -> None:
    """Compare what trimesh read with what the header declared.

    Polygons are triangulated on reading, so a file of ``F`` polygons gives at
    least ``F`` triangles; vertices must match exactly.
    """
    nv, nf = declared.get("vertices"), declared.get("faces")
    if nv is not None and n_vertices != nv:
        raise MeshFileError(
            f"{path.name}: the header declares {nv} vertices but {n_vertices} were read: the file is truncated or "
            "its header is wrong.", _CHECK)
    if nf is not None and n_faces < nf:
        raise MeshFileError(
            f"{path.name}: the header declares {nf} faces but only {n_faces} were read: the file is truncated or "
            "its header is wrong.", _CHECK)


def _looks_like_text(head: bytes) -> bool:
    return b"\x00" not in head and head.lstrip().lower().startswith(b"solid")


def _check_stl(path: Path) -> dict:
    size = path.stat().st_size
    with path.open("rb") as fh:
        head = fh.read(84)
        if size >= 84:
            n = struct.unpack("<I", head[80:84])[0]
            expected = 84 + 50 * n
            if size == expected:
                return {"faces": n}
        # an ASCII STL starts with 'solid' (a binary one may too: size decides, above)
        fh.seek(0)
        sample = fh.read(4096)
    if _looks_like_text(sample):
        return _check_ascii_stl(path, size)
    if size < 84:
        raise MeshFileError(f"{path.name} is {size} bytes: too short for a binary STL (84-byte header) and not ASCII STL.",
                            _CHECK)
    n_complete = (size - 84) // 50
    if size < expected:
        raise MeshFileError(
            f"{path.name} is a truncated binary STL: its header declares {n:,} triangles ({expected:,} bytes) but the "
            f"file has {size:,} bytes ({n_complete:,} complete triangles).", _CHECK)
    extra = size - expected
    if extra >= 50:
        raise MeshFileError(
            f"{path.name}: binary STL header declares {n:,} triangles ({expected:,} bytes) but the file has {size:,} "
            f"bytes, {extra:,} more: the header's count is wrong or data was appended.", _CHECK)
    return {"faces": n}


def _check_ascii_stl(path: Path, size: int) -> dict:
    with path.open("rb") as fh:
        fh.seek(max(size - 2048, 0))
        tail = fh.read().decode("latin-1").strip().lower()
    last = tail.splitlines()[-1] if tail else ""
    if "endsolid" not in last:
        raise MeshFileError(f"{path.name} is an ASCII STL that does not end with 'endsolid': it is truncated.", _CHECK)
    text = path.read_bytes().decode("latin-1").lower()
    n_facet = len(re.findall(r"\bfacet\b", text))
    n_end = len(re.findall(r"\bendfacet\b", text))
    n_vertex = len(re.findall(r"\bvertex\b", text))
    if n_facet != n_end or n_vertex != 3 * n_end:
        raise MeshFileError(
            f"{path.name}: ASCII STL with {n_end} complete facets but {n_facet} facet starts and {n_vertex} vertex lines "
            "(3 per facet expected): the file is damaged.", _CHECK)
    return {"faces": n_end}


def _ply_header(path: Path) -> tuple[str, list[tuple[str, int, list[list[str]]]], int]:
    with path.open("rb") as fh:
        raw = fh.read(65536)
    end = raw.find(b"end_header")
    if not raw.startswith(b"ply") or end < 0:
        raise MeshFileError(f"{path.name} has no complete PLY header ('ply' ... 'end_header').", _CHECK)
    nl = raw.find(b"\n", end)
    header_len = (nl + 1) if nl >= 0 else len(raw)
    fmt = "ascii"
    elements: list[tuple[str, int, list[list[str]]]] = []
    for line in raw[:end].decode("latin-1").splitlines():
        w = line.split()
        if not w:
            continue
        if w[0] == "format" and len(w) > 1:
            fmt = w[1]
        elif w[0] == "element" and len(w) >= 3:
            try:
                elements.append((w[1], int(w[2]), []))
            except ValueError:
                raise MeshFileError(f"{path.name}: PLY header line {line.strip()!r} has no whole-number count.", _CHECK) from None
        elif w[0] == "property" and elements:
            elements[-1][2].append(w[1:])
    return fmt, elements, header_len


def _count(n: int, name: str) -> str:
    return f"{n:,} {name if n == 1 else _PLURAL.get(name, name + 's')}"


def _check_ply(path: Path) -> dict:
    fmt, elements, header_len = _ply_header(path)
    counts = {name: n for name, n, _ in elements}
    declared = {k: counts[e] for k, e in (("vertices", "vertex"), ("faces", "face")) if e in counts}
    size = path.stat().st_size
    if fmt == "ascii":
        with path.open("rb") as fh:
            fh.seek(header_len)
            lines = sum(1 for ln in fh if ln.strip())
        want = sum(n for _, n, _ in elements)
        if lines != want:
            what = "fewer" if lines < want else "more"
            raise MeshFileError(
                f"{path.name}: the PLY header declares "
                + ", ".join(_count(n, name) for name, n, _ in elements)
                + f" ({want} data lines) but the file holds {lines}, {what}: "
                + ("it is truncated or its header is wrong." if lines < want else "its header is wrong."), _CHECK)
        return declared
    # binary: the size is at least the fixed-size rows plus the smallest list rows (triangles)
    least = header_len
    for name, n, props in elements:
        row = 0
        for p in props:
            if p and p[0] == "list" and len(p) >= 3:
                row += _PLY_SIZES.get(p[1], 1) + 3 * _PLY_SIZES.get(p[2], 4)
            elif p:
                row += _PLY_SIZES.get(p[0], 4)
        least += n * row
    if size < least:
        raise MeshFileError(
            f"{path.name} is a truncated binary PLY: its header declares "
            + ", ".join(_count(n, name) for name, n, _ in elements)
            + f", at least {least:,} bytes, but the file has {size:,}.", _CHECK)
    return declared


def _check_off(path: Path) -> dict:
    text = path.read_bytes().decode("latin-1")
    rows = [ln.split("#", 1)[0].split() for ln in text.splitlines()]
    rows = [r for r in rows if r]
    if not rows or not rows[0][0].upper().endswith("OFF"):
        raise MeshFileError(f"{path.name} does not start with 'OFF'.", "Is it an OFF file?")
    head = rows[0][1:] if len(rows[0]) > 1 else rows[1] if len(rows) > 1 else []
    body = rows[1:] if len(rows[0]) > 1 else rows[2:]
    try:
        nv, nf = int(head[0]), int(head[1])
    except (IndexError, ValueError):
        raise MeshFileError(f"{path.name}: the OFF header has no vertex and face counts.", _CHECK) from None
    have_v = min(len(body), nv)
    have_f = max(len(body) - nv, 0)
    if len(body) < nv + nf:
        raise MeshFileError(
            f"{path.name} is truncated: its OFF header declares {nv} vertices and {nf} faces but the file holds "
            f"{have_v} vertex lines and {have_f} face lines.", _CHECK)
    short = [i for i, r in enumerate(body[:nv]) if len(r) < 3]
    if short:
        raise MeshFileError(f"{path.name}: vertex line {short[0] + 1} has fewer than 3 coordinates.", _CHECK)
    bad = [i for i, r in enumerate(body[nv:nv + nf]) if len(r) < 1 or not r[0].isdigit() or len(r) < 1 + int(r[0])]
    if bad:
        raise MeshFileError(f"{path.name}: face line {bad[0] + 1} lists fewer vertex indices than its count says "
                            "(a truncated or damaged file).", _CHECK)
    if len(body) > nv + nf:
        raise MeshFileError(
            f"{path.name}: its OFF header declares {nv} vertices and {nf} faces but the file holds "
            f"{len(body) - nv - nf} more data lines: the header is wrong.", _CHECK)
    return {"vertices": nv, "faces": nf}
