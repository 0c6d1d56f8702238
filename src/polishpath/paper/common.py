"""Small helpers every section of the reproduction uses: the machine, surfaces, number formatting, NURBS check."""

from __future__ import annotations

import datetime
import math
from typing import Any

import numpy as np

from .._version import __version__

__all__ = ["fmt", "load", "machine_info", "nurbs_deviation", "spacing_for", "stamp_text"]


def machine_info() -> dict[str, Any]:
    """The machine and version that made the figures.

    Returns
    -------
    dict
        ``node``, ``processor``, ``cpus``, ``python``, ``polishpath``, ``date``.
    """
    from ..provenance import machine_info as _machine

    return {**_machine(), "polishpath": __version__,
            "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds")}


def stamp_text(machine: dict, seed: int) -> str:
    """The one-line stamp of every figure: version, machine, CPUs, seed."""
    m = machine
    return f"polishpath {m['polishpath']} | {m['node']} | {m['processor']} | {m['cpus']} CPUs | seed {seed}"


def load(spec: str, scale: float = 1.0):
    """A surface from a spec or mesh path (``load_surface``), ``scale`` to mm (1: as the spec says)."""
    from ..surfaces import load_surface

    return load_surface(spec, scale=None if scale == 1.0 else scale)


def fmt(x, nd: int = 3) -> str:
    """A table cell: '–' for missing / not finite, thousands separators for integers, ``nd`` decimals otherwise."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    if isinstance(x, (int, np.integer)):
        return f"{int(x):,}"
    return f"{x:.{nd}f}"


def spacing_for(surface, n_points: int) -> float:
    """The spacing (mm, two significant digits) that puts about ``n_points`` dwell points on the surface."""
    from .. import meshops

    a = meshops.surface_area(surface.vertices, surface.faces)
    return float(f"{math.sqrt(a / n_points):.2g}")


def nurbs_deviation(xyz: np.ndarray, pieces) -> float:
    """Largest distance between the dwell points and our cubic NURBS through them, per piece.

    Parameters
    ----------
    xyz : (N, 3) float
        Dwell points on the part, mm.
    pieces : (P + 1,) int or None
        Piece starts and the end (None: one piece).

    Returns
    -------
    float
        mm (repeated points are dropped first; a piece of one point counts 0).
    """
    from ..pathops import split_by_pieces
    from ..smooth import evaluate, interpolate_nurbs

    dev = 0.0
    for q in split_by_pieces(xyz, pieces):
        if len(q) < 2:
            continue
        keep = np.ones(len(q), bool)
        keep[1:] = np.linalg.norm(np.diff(q, axis=0), axis=1) > 0
        q = q[keep]
        if len(q) < 2:
            continue
        curve, u = interpolate_nurbs(q)
        dev = max(dev, float(np.linalg.norm(evaluate(curve, u) - q, axis=1).max()))
    return dev
