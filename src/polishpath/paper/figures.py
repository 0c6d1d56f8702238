"""The reproduction's figures: a stamped figure set and the surface / path drawings the sections share.

matplotlib is imported only when a figure is drawn (Agg canvas, no display).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..pathops import step_mask
from .common import stamp_text

__all__ = ["FigureSet", "draw_path2d", "draw_path3d", "draw_surface", "limits3d"]


class FigureSet:
    """Creates, stamps (machine / version / seed, lower right) and saves the figures as PNG.

    Parameters
    ----------
    out : Path
        Output folder of the document.
    figdir : str
        Folder for the PNGs, relative to ``out`` (created).
    machine : dict
        :func:`~polishpath.paper.common.machine_info`.
    seed : int
        The run's seed, printed in the stamp.
    """

    def __init__(self, out: Path, figdir: str, machine: dict, seed: int):
        self.out, self.figdir, self.stamp = out, figdir, stamp_text(machine, seed)
        (out / figdir).mkdir(parents=True, exist_ok=True)
        self.written: dict[str, Path] = {}

    @staticmethod
    def new(w: float, h: float):
        """A blank figure of ``w`` x ``h`` inches at 110 dpi."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        fig = Figure(figsize=(w, h), dpi=110)
        FigureCanvasAgg(fig)
        return fig

    def save(self, fig, name: str) -> str:
        """Stamp and write ``figdir/name.png``; returns that path relative to ``out`` (for the document)."""
        fig.text(0.995, 0.005, self.stamp, ha="right", va="bottom", fontsize=6.5, color="0.35")
        path = self.out / self.figdir / f"{name}.png"
        fig.savefig(path, format="png", dpi=110)
        self.written[name] = path
        return f"{self.figdir}/{name}.png"


def limits3d(ax, pts: np.ndarray) -> None:
    """Axis limits, box aspect and labels (mm) of a 3D axes around the (N, 3) points ``pts``."""
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(np.maximum(hi - lo, 0.25 * (hi - lo).max()))  # flat parts: relief stretched to show
    from matplotlib.ticker import MaxNLocator

    ax.zaxis.set_major_locator(MaxNLocator(3))
    ax.set_xlabel("x (mm)", fontsize=7)
    ax.set_ylabel("y (mm)", fontsize=7)
    ax.set_zlabel("z (mm)", fontsize=7)
    ax.tick_params(labelsize=6)


def draw_surface(ax, surface, max_faces: int = 6000, alpha: float = 0.3, color: str = "0.75") -> None:
    """The surface as a shaded triangle mesh (clustered down to ``max_faces`` faces)."""
    v, f = surface.vertices, surface.faces
    if len(f) > max_faces:
        from ..report.rundata import cluster_mesh

        v, f, _ = cluster_mesh(v, f, max_faces)
    ax.plot_trisurf(v[:, 0], v[:, 1], v[:, 2], triangles=f, color=color, alpha=alpha, linewidth=0,
                    antialiased=False, shade=True, zorder=1)


def _segments(points: np.ndarray, pieces) -> tuple[np.ndarray, np.ndarray]:
    """The steps within pieces as (S, 2, D) segments, and each one's position along the path in [0, 1]."""
    n = len(points)
    same = step_mask(n, pieces)
    return np.stack([points[:-1], points[1:]], axis=1)[same], np.arange(n - 1)[same] / max(n - 1, 1)


def _line_width(n: int) -> float:
    return float(np.clip(120.0 / math.sqrt(max(n, 1)), 0.15, 1.2))


def draw_path3d(ax, surface, xyz: np.ndarray, pieces, title: str) -> None:
    """The path (N, 3) on the surface, coloured by path order, no line across a tool lift."""
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    ax.computed_zorder = False
    draw_surface(ax, surface)
    seg, order = _segments(xyz, pieces)
    ax.add_collection3d(Line3DCollection(seg, array=order, cmap="viridis", linewidths=_line_width(len(xyz)), zorder=2))
    limits3d(ax, np.vstack([xyz, surface.vertices]))
    ax.set_title(title, fontsize=8)


def draw_path2d(ax, uv: np.ndarray, pieces, region=None, title: str = "") -> None:
    """The planar path (N, 2), coloured by path order, with the region's loops in black."""
    from matplotlib.collections import LineCollection

    if region is not None:
        for loop in region.loops:
            lp = np.vstack([loop, loop[:1]])
            ax.plot(lp[:, 0], lp[:, 1], color="k", lw=0.8)
    seg, order = _segments(uv, pieces)
    ax.add_collection(LineCollection(seg, array=order, cmap="viridis", linewidths=_line_width(len(uv))))
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_title(title, fontsize=8)
    ax.tick_params(labelsize=6)
