"""Read a finished run folder and derive what the report draws.

Everything here works from the files alone (``summary.json`` and ``run.npz``
written by :meth:`polishpath.pipeline.Job.save`), so a report can be rebuilt
long after the job ran. Units: mm, radians inside, degrees where a name says so.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
# the path maths of the report, re-exported for its public API
from ..pathops import DIRECTION_NAMES, step_lengths, step_mask, turn_angles_deg  # noqa: F401
from ..pathops import direction_counts as grid_directions  # noqa: F401

#: names of the 8 grid directions, counter-clockwise from +i (grid frame)


@dataclass
class RunData:
    """The files of one run folder.

    Attributes
    ----------
    folder : Path
        The run folder.
    summary : dict
        Contents of ``summary.json``.
    arrays : dict of str -> ndarray
        Contents of ``run.npz`` (any array may be missing).
    simulation : dict
        ``{"folder": Path, "summary": dict or None, "table": str or None,
        "images": [Path, ...]}`` when ``folder/simulation`` exists, else empty.
    """

    folder: Path
    summary: dict[str, Any]
    arrays: dict[str, np.ndarray] = field(default_factory=dict)
    simulation: dict[str, Any] = field(default_factory=dict)

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


def load_run(folder: str | Path) -> RunData:
    """Read a run folder written by ``polishpath plan ... -o DIR``.

    Parameters
    ----------
    folder : path
        The run folder; must hold ``summary.json`` and ``run.npz``.

    Returns
    -------
    RunData

    Raises
    ------
    InputError
        The folder does not exist, is not a polishpath run, or its files are unreadable.
    """
    d = Path(folder)
    if not d.is_dir():
        raise InputError(f"{d} is not a folder.",
                         "Give the output folder of a finished run (`polishpath plan SURFACE -o DIR`).")
    sp = d / "summary.json"
    if not sp.is_file():
        raise InputError(f"{d} is not a polishpath run folder: it has no summary.json.",
                         "Give the folder written by `polishpath plan SURFACE -o DIR`, "
                         "or run the plan again to write it.")
    try:
        summary = json.loads(sp.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise InputError(f"{sp} cannot be read as JSON ({e}).",
                         "The run may have been interrupted; run `polishpath plan` again.") from e
    if not isinstance(summary, dict):
        raise InputError(f"{sp} does not hold a JSON object.", "Run `polishpath plan` again to rewrite it.")
    npz = d / "run.npz"
    if not npz.is_file():
        raise InputError(f"{d} has no run.npz (the arrays the report draws).",
                         "Run `polishpath plan` again with this version of polishpath to write it.")
    try:
        with np.load(npz, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except Exception as e:  # zipfile / ValueError / OSError: all mean a broken file
        raise InputError(f"{npz} cannot be read ({e}).",
                         "The run may have been interrupted; run `polishpath plan` again.") from e
    return RunData(d, summary, arrays, _load_simulation(d / "simulation"))


def _load_simulation(sim: Path) -> dict[str, Any]:
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


# --- derived quantities -------------------------------------------------------------


def angle_error_deg(vertices: np.ndarray, faces: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Mean absolute angle error of each face between the plane and the part.

    Parameters
    ----------
    vertices : (V, 3) float
        Part mesh, mm.
    faces : (F, 3) int
    angles : (F, 3) float
        Planar corner angles, radians.

    Returns
    -------
    (F,) float64
        Mean over the 3 corners of ``|angles - corner_angles(part)|``, degrees.
    """
    from ..meshops import corner_angles

    a3 = corner_angles(vertices, faces)
    return np.degrees(np.abs(np.asarray(angles, dtype=float) - a3).mean(axis=1))


def area_distortion(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Log area ratio of each face, ``log((A_plane / sum A_plane) / (A_part / sum A_part))``.

    Returns
    -------
    (F,) float64
        0 where the face keeps its share of the area; NaN for degenerate faces.
    """
    from ..meshops import face_areas

    a2 = face_areas(uv, faces)
    a3 = face_areas(vertices, faces)
    r2 = a2 / max(a2.sum(), 1e-300)
    r3 = a3 / max(a3.sum(), 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.log(r2 / r3)
    out[~np.isfinite(out)] = np.nan
    return out


def decimate_indices(n: int, max_points: int) -> np.ndarray:
    """Indices of at most ``max_points`` evenly spread points out of ``n`` (first and last kept).

    Returns
    -------
    (n',) int64
        ``arange(n)`` when ``n <= max_points``.
    """
    if n <= max_points:
        return np.arange(n, dtype=np.int64)
    idx = np.unique(np.linspace(0, n - 1, max_points).round().astype(np.int64))
    return idx


def cluster_mesh(vertices: np.ndarray, faces: np.ndarray, max_faces: int,
                 values: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Coarsen a mesh for display by vertex clustering on a regular grid.

    Parameters
    ----------
    vertices : (V, d) float
    faces : (F, 3) int
    max_faces : int
        Aim for at most about this many faces.
    values : (F,) float, optional
        Per-face values carried along (faces that survive keep theirs).

    Returns
    -------
    vertices : (V', d) float64
    faces : (F', 3) int64
    values : (F',) float or None
        The input itself when ``F <= max_faces``. Display only: the result may
        have small holes or folds.
    """
    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces, dtype=np.int64)
    if len(f) <= max_faces:
        return v, f, values
    from ..meshops import face_areas

    lo = v.min(axis=0)
    dim = v.shape[1]
    area = float(face_areas(v, f).sum())
    # a surface of area A in cells of size h occupies about A / h^2 cells (= new vertices, ~ F'/2)
    h = math.sqrt(max(area, 1e-300) / (max_faces / 2.0))
    for _ in range(12):
        key = np.floor((v - lo) / h).astype(np.int64)
        flat = key[:, 0]
        for k in range(1, dim):
            flat = flat * (int(key[:, k].max()) + 1) + key[:, k]
        uniq, inv = np.unique(flat, return_inverse=True)
        inv = inv.ravel()
        nf = inv[f]
        keep = (nf[:, 0] != nf[:, 1]) & (nf[:, 1] != nf[:, 2]) & (nf[:, 0] != nf[:, 2])
        if keep.sum() <= max_faces:
            break
        h *= math.sqrt(keep.sum() / max_faces) * 1.05
    nf = nf[keep]
    # drop duplicate faces that differ only by order
    srt = np.sort(nf, axis=1)
    _, first = np.unique(srt, axis=0, return_index=True)
    first.sort()
    nf = nf[first]
    counts = np.bincount(inv, minlength=len(uniq)).astype(float)
    nv = np.zeros((len(uniq), dim))
    for k in range(dim):
        nv[:, k] = np.bincount(inv, weights=v[:, k], minlength=len(uniq)) / np.maximum(counts, 1)
    vals = None if values is None else np.asarray(values)[keep][first]
    return nv, nf, vals
