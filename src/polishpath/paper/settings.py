"""Sizes of every experiment of the reproduction: the full run (the paper's sizes) or the reduced CI run."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError
from .reference import PAPER

__all__ = ["MESHES_ENV", "Settings", "meshes_folder", "settings_for"]

#: Environment variable naming the shared meshes folder (``lilium.obj``, ``stanford-bunny.obj``, ...).
MESHES_ENV = "POLISHPATH_MESHES"


@dataclass(frozen=True)
class Settings:
    """Sizes of every experiment. Lengths in mm.

    Attributes
    ----------
    quick : bool
        The reduced CI setting.
    table1 : tuple of (name, spec, run_abf)
        Flattening cases (built-in surface specs).
    table2_triangles, table2_spacing : int, float
        Hemisphere (R = 30 mm) mesh size and dwell spacing on the part, mm.
    table3_surfaces : tuple of (name, spec, scale)
        Surfaces of Table 3 (a spec or a mesh path; ``scale`` to mm).
    table3_spacing : float
        Dwell spacing on the part for Table 3, mm.
    sim_size, sim_dx : float
        Table 4 simulation: square patch side and pixel pitch, mm.
    fig_triangles : int
        Triangles of the Fig. 10 / Figs. 5-7 meshes.
    fig_points : int
        Aimed number of dwell points per Fig. 10 path (sets the spacing).
    bunny_radius : float
        Geodesic radius of the bunny patch, mm.
    meshes : str or None
        The shared meshes folder (``lilium.obj``, ``stanford-bunny.obj``), or
        None when it was not given: the cases that need it are skipped.
    """

    quick: bool
    table1: tuple = ()
    table2_triangles: int = 100_220
    table2_spacing: float = 0.5
    table3_surfaces: tuple = ()
    table3_spacing: float = 1.0
    sim_size: float = 20.0
    sim_dx: float = 0.005
    fig_triangles: int = 5000
    fig_points: int = 2500
    bunny_radius: float = 45.0
    meshes: str | None = None


def meshes_folder(meshes: str | Path | None) -> Path | None:
    """The shared meshes folder, checked: the argument, else ``$POLISHPATH_MESHES``, else None.

    Parameters
    ----------
    meshes : path or None
        Folder holding the shared meshes; None reads the environment variable.

    Returns
    -------
    Path or None
        None when neither names a folder (the cases that need the meshes are skipped).

    Raises
    ------
    InputError
        The folder named does not exist.
    """
    import os

    how = "given"
    if meshes is None or str(meshes) == "":
        meshes, how = os.environ.get(MESHES_ENV) or None, f"named by ${MESHES_ENV}"
    if meshes is None:
        return None
    p = Path(meshes).expanduser()
    if not p.is_dir():
        raise InputError(f"the shared meshes folder {how} ({p}) does not exist.",
                         f"Pass the folder holding lilium.obj and stanford-bunny.obj (--meshes DIR or ${MESHES_ENV}), "
                         "or leave both unset to skip the cases that need them.")
    return p


def settings_for(quick: bool, meshes: Path | None = None) -> Settings:
    """The full run (the paper's sizes) or the reduced CI run.

    Parameters
    ----------
    quick : bool
        Reduced setting (small meshes, coarse spacing, small simulation patch).
    meshes : Path, optional
        The shared meshes folder (see :func:`meshes_folder`); the full run adds
        ``lilium.obj`` to Table 3 when it is there.

    Returns
    -------
    Settings
    """
    where = None if meshes is None else str(meshes)
    if quick:
        return Settings(
            quick=True,
            table1=(("hemisphere", "hemisphere:R=30,triangles=1119", True),
                    ("pentagram", "pentagram:triangles=1500", False),
                    ("airfoil", "airfoil:triangles=1500", False),
                    ("saddle", "saddle:triangles=1500", False)),
            table2_triangles=3000, table2_spacing=1.5,
            table3_surfaces=(("hemisphere", "hemisphere:R=30,triangles=2000", 1.0),
                             ("pentagram", "pentagram:triangles=1500", 1.0)),
            table3_spacing=2.0, sim_size=8.0, sim_dx=0.01, fig_triangles=1200, fig_points=350, bunny_radius=22.0,
            meshes=where,
        )
    t3 = [("hemisphere", "hemisphere:R=30,triangles=20000", 1.0), ("pentagram", "pentagram", 1.0)]
    lilium = None if meshes is None else Path(meshes) / "lilium.obj"
    if lilium is not None and lilium.exists():
        t3.append(("lilium (shared, x20)", str(lilium), 20.0))
    return Settings(
        quick=False,
        table1=tuple((n, f"{n}:triangles={t}" if n != "hemisphere" else f"hemisphere:R=30,triangles={t}", True)
                     for n, (t, _, _) in PAPER["table1"].items()),
        table3_surfaces=tuple(t3),
        table3_spacing=0.5,
        meshes=where,
    )
