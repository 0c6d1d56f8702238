"""A sweep: the fair comparison over a grid of parts x patterns x seeds x tools, one table (issue 29, item 3).

A sweep is a TOML file (``polishpath sweep job.toml``; the same as
:func:`run_sweep` on :func:`read_sweep`'s :class:`Sweep`)::

    parts = ["hemisphere", "saddle:size=12"]      # built-in surfaces or mesh files
    patterns = ["pseudorandom", "raster", "spiral"]
    seeds = 5                                       # seed i = seed + i
    spacing = 0.5                                   # mm on the part
    [[tool]]                                        # one table per TIF (default: the rotating sponge)
    name = "sponge"
    rpm = 230
    [[tool]]
    name = "gauss-1mm"
    fwhm = 1.0                                      # a Gaussian TIF of this FWHM, mm

Each part is flattened once and every pattern planned on it once per seed
(a deterministic pattern once) through :func:`~polishpath.pipeline.plan_on_surface`;
each (part, tool) is then one :func:`~polishpath.simulate.compare_planned`, whose
independent cases (pattern x seed) run where the :class:`~polishpath.simulate.cases.CaseRunner`
says (local cores, or a Dask cluster). The rows of every comparison make one
table, ``sweep.csv`` and ``sweep.json``, in grid order: the same bytes whatever
the spread. A TOML file rather than flags: a grid is a document to keep beside its results and to
re-run (on a cluster's login node as on a laptop), and a Python API underneath it for notebooks.
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from .. import progress
from .._version import __version__
from ..defaults import (DEFAULT_CONTACT_RADIUS_MM, DEFAULT_FEED_MM_MIN, DEFAULT_FLATTEN_METHOD, DEFAULT_PATCH_MM,
                        DEFAULT_PEAK_RATE_NM_S, DEFAULT_PRESSURE, DEFAULT_REMOVAL_DEPTH_NM, DEFAULT_RPM,
                        DEFAULT_SEEDS, DEFAULT_SPACING_MM)
from ..errors import ParameterError, SpecError
from ..simulate.workpiece import DEFAULT_DX_MM
from .surfaceplan import plan_on_surface

__all__ = ["SWEEP_COLUMNS", "Sweep", "ToolSpec", "is_sweep_folder", "plan_patterns", "read_sweep", "run_sweep"]

#: the files a sweep folder holds
SWEEP_FILES = ("sweep.csv", "sweep.json")
#: the table's columns, in order: the grid's coordinates, then each comparison row's figures
SWEEP_COLUMNS = ("part", "tool", "pattern", "random", "n_points", "planar_spacing_mm", "n_seeds",
                 "residual_band_rms_nm", "residual_band_rms_nm_min", "residual_band_rms_nm_max",
                 "lattice_peak_db", "lattice_peak_db_min", "lattice_peak_db_max", "pvn", "pvn_min", "pvn_max",
                 "suppression_ratio", "suppression_ratio_min", "suppression_ratio_max", "time_density_peak_db",
                 "total_time_s", "machine_time_s")


@dataclass(frozen=True)
class ToolSpec:
    """One tool of a sweep: the rotating sponge (rpm, contact radius mm, pressure, feed mm/min), or with
    ``fwhm_mm`` a Gaussian TIF of that FWHM (mm) and peak rate (nm/s)."""

    name: str = "sponge"
    rpm: float = DEFAULT_RPM
    radius_mm: float = DEFAULT_CONTACT_RADIUS_MM
    pressure: str = DEFAULT_PRESSURE
    feed_mm_min: float = DEFAULT_FEED_MM_MIN
    fwhm_mm: float | None = None
    rate_nm_s: float = DEFAULT_PEAK_RATE_NM_S

    def tif(self):
        """The TIF (:func:`~polishpath.simulate.gaussian_tif` or :func:`~polishpath.simulate.rotating_tool_tif`)."""
        from ..simulate import gaussian_tif, rotating_tool_tif

        if self.fwhm_mm is not None:
            return gaussian_tif(self.rate_nm_s, fwhm_mm=self.fwhm_mm)
        return rotating_tool_tif(self.rpm, self.radius_mm, self.pressure, feed_mm_min=self.feed_mm_min)


@dataclass(frozen=True)
class Sweep:
    """The grid: ``parts`` (surface specs or mesh files) x ``patterns`` x ``seeds`` seeds x ``tools``, and the
    comparison's settings shared by every cell (as ``polishpath simulate SURFACE``'s options)."""

    parts: tuple[str, ...]
    patterns: tuple[str, ...] = ("pseudorandom", "raster", "spiral", "rectangular")
    tools: tuple[ToolSpec, ...] = (ToolSpec(),)
    seed: int = 0
    seeds: int = DEFAULT_SEEDS
    spacing_mm: float = DEFAULT_SPACING_MM
    spacing_on: str = "surface"
    patch_mm: float = DEFAULT_PATCH_MM
    dx_mm: float = DEFAULT_DX_MM
    depth_nm: float = DEFAULT_REMOVAL_DEPTH_NM
    mode: str = "process"
    timing: str = "machine"
    machine: str | None = None
    method: str = DEFAULT_FLATTEN_METHOD
    units: str | None = None

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "parts": list(self.parts), "patterns": list(self.patterns),
                "tools": [asdict(t) for t in self.tools]}


#: the TOML keys of a sweep and of a [[tool]] table, and the field each sets
_KEYS = {"parts": "parts", "patterns": "patterns", "seed": "seed", "seeds": "seeds", "spacing": "spacing_mm",
         "spacing_on": "spacing_on", "patch": "patch_mm", "dx": "dx_mm", "depth": "depth_nm", "mode": "mode",
         "timing": "timing", "machine": "machine", "method": "method", "units": "units"}
_TOOL_KEYS = {"name": "name", "rpm": "rpm", "radius": "radius_mm", "pressure": "pressure", "feed": "feed_mm_min",
              "fwhm": "fwhm_mm", "rate": "rate_nm_s"}


def _unknown(got, known, where: str) -> None:
    bad = sorted(set(got) - set(known))
    if bad:
        raise SpecError(f"{where}: unknown key(s) {', '.join(map(repr, bad))}.",
                        f"Use: {', '.join(known)} (docs/simulation.md, 'Sweeps').")


def read_sweep(path: str | Path) -> Sweep:
    """Read a sweep's TOML file (module docstring); an unknown key, an empty grid or a bad value: SpecError."""
    from ..fileio import read_toml
    from ..simulate.compare import check_comparison

    d = read_toml(path, "sweep file", SpecError)
    _unknown(d, [*_KEYS, "tool"], Path(path).name)
    kw = {_KEYS[k]: v for k, v in d.items() if k in _KEYS}
    for k in ("parts", "patterns"):
        v = kw.get(k, getattr(Sweep, k, None) if k == "patterns" else None)
        if not isinstance(v, (list, tuple)) or not v or not all(isinstance(x, str) and x.strip() for x in v):
            raise SpecError(f"{Path(path).name}: {k!r} must be a non-empty list of names, got {v!r}.",
                            f'Write e.g. {k} = ["hemisphere"]' if k == "parts" else f'Write e.g. {k} = ["raster"]')
        kw[k] = tuple(v)
    tools = d.get("tool", [{}])
    if not isinstance(tools, list) or not tools or not all(isinstance(t, dict) for t in tools):
        raise SpecError(f"{Path(path).name}: 'tool' must be [[tool]] tables.", "Write [[tool]] then its keys.")
    specs = []
    for i, t in enumerate(tools):
        _unknown(t, _TOOL_KEYS, f"{Path(path).name}, tool {i + 1}")
        specs.append(ToolSpec(**{_TOOL_KEYS[k]: v for k, v in t.items()}))
    names = [t.name for t in specs]
    if len(set(names)) != len(names):
        raise SpecError(f"{Path(path).name}: two tools share a name ({names}).", "Give each [[tool]] its own name.")
    try:
        sweep = Sweep(tools=tuple(specs), **kw)
    except TypeError as exc:  # pragma: no cover - every key is mapped above
        raise SpecError(f"{Path(path).name}: {exc}.") from None
    check_comparison(seeds=sweep.seeds, mode=sweep.mode, timing=sweep.timing)
    for name in ("spacing_mm", "patch_mm", "dx_mm", "depth_nm"):
        v = getattr(sweep, name)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0:
            raise ParameterError(f"{Path(path).name}: {name} must be a number > 0, got {v!r}.")
    return sweep


def plan_patterns(flat, region, patterns, spacing_mm: float, *, seed: int, seeds: int, spacing_on: str = "surface"):
    """Plan each pattern on a flattened part: a random one once per seed (``seed + i``), a deterministic one once.

    ``PATTERN:SET`` plans the pattern on a dwell-point set (``pseudorandom:blue-noise``).
    Returns ``(planned, info)``: name -> PlanarPath (or a list, one per seed) for
    :func:`~polishpath.simulate.compare_planned`, and name -> the plan's figures.
    """
    from ..plan import RANDOM_PATTERNS
    from ..plan.points import DWELL_POINT_SETS

    planned, info = {}, {}
    for pat in patterns:
        base, _, dset = pat.partition(":")
        dset = dset or "grid"
        if dset not in DWELL_POINT_SETS:
            raise ParameterError(f"--patterns: {pat!r} names the dwell-point set {dset!r}.",
                                 f"Write PATTERN or PATTERN:SET with SET one of {', '.join(DWELL_POINT_SETS)} "
                                 "(e.g. pseudorandom:blue-noise).")
        n_plans = seeds if base in RANDOM_PATTERNS else 1  # a deterministic path is planned once
        plans = []
        for i in range(n_plans):
            with progress.stage(f"planning {pat} ({spacing_mm:g} mm on the "
                                f"{'part' if spacing_on == 'surface' else 'plane'}"
                                + (f", seed {seed + i})" if n_plans > 1 else ")")):
                # margin=None: the job's own automatic margin, so `plan` at this spacing plans the same grid
                plans.append(plan_on_surface(flat, region, spacing_mm, pattern=base, seed=seed + i,
                                             spacing_on=spacing_on, margin=None, dwell_points=dset))
        sp = plans[0]
        planned[pat] = [p.planar for p in plans] if base in RANDOM_PATTERNS else sp.planar
        info[pat] = {"n_points": int(sp.planar.n_points), "planar_spacing_mm": float(sp.planar_spacing),
                     "spacing_mm": float(spacing_mm), "spacing_on": spacing_on, "random": base in RANDOM_PATTERNS,
                     "dwell_points": dset, "seeds": [seed + i for i in range(n_plans)],
                     "provenance": sp.planar.provenance.to_dict()}
    return planned, info


def is_sweep_folder(folder) -> bool:
    """True when ``folder`` holds nothing but a previous sweep's files (then it may be replaced whole)."""
    d = Path(folder)
    return d.is_dir() and (d / "sweep.json").exists() and all(p.name in SWEEP_FILES for p in d.iterdir())


def run_sweep(sweep: Sweep, *, runner=None, out_dir=None) -> dict[str, Any]:
    """Run every cell of the grid and gather one table.

    Parameters
    ----------
    sweep : Sweep
    runner : CaseRunner, optional
        Where each comparison's cases run (default every local core; a Dask scheduler's address).
    out_dir : str or Path, optional
        Write ``sweep.csv`` and ``sweep.json`` here, whole or not at all.

    Returns
    -------
    dict
        ``rows`` (one per part x tool x pattern, in that order: :data:`SWEEP_COLUMNS` and
        ``per_seed``), ``params`` (the sweep, the version), ``csv`` (the table's text).
    """
    from ..fileio import check_output_folder, staged_folder
    from ..flatten import boundary_region, flatten
    from ..schedule import load_machine
    from ..simulate import compare_planned
    from ..simulate.patterns import patch_bounds_at_centre
    from ..surfaces import load_surface

    if out_dir is not None:
        check_output_folder(out_dir, is_sweep_folder, kind="polishpath sweep folder")
    machine = load_machine(sweep.machine) if sweep.machine is not None else None
    tifs = [(t.name, t.tif()) for t in sweep.tools]  # a bad tool is refused before any work
    rows = []
    for part in sweep.parts:
        with progress.stage(f"reading and flattening {part} ({sweep.method})"):
            s = load_surface(part, units=sweep.units)
            flat = flatten(s, sweep.method)
            region = boundary_region(flat)
        planned, info = plan_patterns(flat, region, sweep.patterns, sweep.spacing_mm, seed=sweep.seed,
                                      seeds=sweep.seeds, spacing_on=sweep.spacing_on)
        bounds = patch_bounds_at_centre(region, sweep.patch_mm)
        for name, tif in tifs:
            with progress.stage(f"comparing {len(planned)} patterns x {sweep.seeds} seeds on {part} with {name}"):
                res = compare_planned(planned, seed=sweep.seed, seeds=sweep.seeds, mode=sweep.mode,
                                      timing=sweep.timing, machine=machine, dx_mm=sweep.dx_mm, tif=tif,
                                      removal_depth_nm=sweep.depth_nm, patch_bounds=bounds, plan_info=info,
                                      runner=runner)
            for r in res["rows"]:
                row = {"part": part, "tool": name, "pattern": r["name"], "n_seeds": len(r["seeds"]),
                       **{k: r.get(k) for k in SWEEP_COLUMNS[3:] if k != "n_seeds"}}
                rows.append({**row, "per_seed": r["per_seed"]})
    out = {"rows": rows, "params": {"sweep": sweep.to_dict(), "seeds": [sweep.seed + i for i in range(sweep.seeds)],
                                    "version": __version__, "columns": list(SWEEP_COLUMNS)}}
    out["csv"] = _csv(rows)
    if out_dir is not None:
        with staged_folder(out_dir, is_sweep_folder, kind="polishpath sweep folder") as stage:
            (stage / "sweep.csv").write_text(out["csv"])
            (stage / "sweep.json").write_text(json.dumps({"rows": rows, "params": out["params"]}, indent=1))
    return out


def _csv(rows: list[dict[str, Any]]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(SWEEP_COLUMNS)
    for r in rows:
        w.writerow(["" if r.get(k) is None else repr(r[k]) if isinstance(r[k], float) else r[k]
                    for k in SWEEP_COLUMNS])
    return buf.getvalue()
