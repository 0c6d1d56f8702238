"""Files of a job's own simulation (:func:`~polishpath.simulate.jobpath.simulate_job`): table, JSON, maps, PSD.

Written into a run folder's ``simulation/`` by ``polishpath simulate RUN_DIR``;
the run's report shows them (its simulation section reads ``table.txt``,
``results.json`` and the PNGs).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from ..fileio import jsonable

#: what a ``polishpath simulate`` run writes into a simulation folder (either kind), cleared before writing
OUTPUT_GLOBS = ("table.txt", "results.json", "psd.png", "residual*.png", "removal.png")


def is_simulation_folder(folder) -> bool:
    """True when ``folder`` holds nothing but a ``polishpath simulate`` output (:data:`OUTPUT_GLOBS`,
    ``results.json`` among them): a previous ``simulate -o`` folder, which may be replaced whole."""
    from fnmatch import fnmatch

    d = Path(folder)
    if not d.is_dir():
        return False
    names = [p.name for p in d.iterdir()]
    return "results.json" in names and all(any(fnmatch(n, g) for g in OUTPUT_GLOBS) for n in names)


def clear_outputs(folder) -> None:
    """Remove the files a previous ``polishpath simulate`` left in ``folder`` (nothing else)."""
    d = Path(folder)
    if not d.is_dir():
        return
    for pat in OUTPUT_GLOBS:
        for p in d.glob(pat):
            if p.is_file():
                p.unlink()


def format_job_table(summary: dict[str, Any], run_name: str = "") -> str:
    """The job simulation's figures as text (what the CLI prints and ``table.txt`` holds)."""
    s = summary
    p = s["path"]
    if s["timing"] == "machine":
        what = (f"machine timing: {p['n_points']:,} samples at {p['period_ms']:g} ms, {p['total_time_s']:.1f} s "
                f"(the feed schedule the job runs, slow-downs at turns included)")
    else:
        what = f"dwell timing: {p['n_points']:,} dwell points, {p['total_time_s']:.1f} s (the times the schedule aimed at)"
    ny, nx = s["grid_shape"]
    lines = [
        f"simulated path: {run_name or 'the job'}'s own, {what}",
        f"plane: {s['plane_reason']}",
        f"grid: {nx} x {ny} px at {1000 * s['dx_mm']:.3g} um over x {s['grid_bounds_mm'][0]:.2f}..{s['grid_bounds_mm'][2]:.2f}, "
        f"y {s['grid_bounds_mm'][1]:.2f}..{s['grid_bounds_mm'][3]:.2f} mm; flat start, "
        + ("no process noise" if s["noise"] is None else f"process noise {100 * s['noise']['rms']:g} %"),
        f"tool: {s['tif'].get('kind')}; rate scaled (x {s['tif_rate_scale']:.4g}) to a mean depth of "
        f"{s['depth_mean_nm']:.4g} nm inside the part",
        f"depth inside the part (>= {s['edge_inset_mm']:g} mm from its edge): mean {s['depth_mean_nm']:.4g} nm, "
        f"RMS {s['depth_rms_nm']:.4g} nm ({100 * s['depth_rms_rel']:.2f} % of the mean), PV {s['depth_pv_nm']:.4g} nm",
    ]
    if s["time_off_grid_s"] > 0:
        lines.append(f"time off the grid: {s['time_off_grid_s']:.3g} s")
    if s["centre_square_mm"] is not None:
        x0, y0, x1, y1 = s["centre_square_mm"]
        lo, hi = s["band_per_mm"]
        pk = ", ".join(f"{d['freq_per_mm']:.3g}/mm{(' ' + d['label']) if d['label'] else ''}" for d in s["peaks"][:3])
        lines.append(f"centre square {x1 - x0:.1f} x {y1 - y0:.1f} mm: band RMS ({lo:g}-{hi:g} 1/mm) "
                     f"{s['band_rms_nm']:.4g} nm; PSD peaks: {pk or 'none'}")
        f = s.get("fair")
        if f is not None:
            lines.append(f"fair figures of its residual (mean / tilt / power removed): band RMS "
                         f"{f['residual_band_rms_nm']:.4g} nm, lattice peak {f['lattice_peak_db']:.3g} dB over the "
                         f"background (spacing {f['spacing_mm']:g} mm), PVn {f['pvn']:.3g} (PV / depth)")
    else:
        lines.append("centre square: too small for a PSD (under 64 px)")
    return "\n".join(lines) + "\n"


def write_job_outputs(out: dict[str, Any], folder, run_name: str = "") -> dict[str, Path]:
    """Write ``table.txt``, ``results.json``, ``removal.png``, ``residual.png`` and ``psd.png`` (when there is one).

    Parameters
    ----------
    out : dict
        What :func:`~polishpath.simulate.jobpath.simulate_job` returned.
    folder : path
        Output folder (created).
    run_name : str
        Name of the run, for the table and titles.

    Returns
    -------
    dict of name -> Path
    """
    d = Path(folder)
    d.mkdir(parents=True, exist_ok=True)
    written = {"table": d / "table.txt", "results": d / "results.json"}
    written["table"].write_text(format_job_table(out["summary"], run_name), encoding="utf-8")
    js = dict(out["summary"])
    if out["psd"] is not None:
        js["psd"] = {"freq_per_mm": out["psd"].freq, "psd": out["psd"].psd, "units": out["psd"].units}
    written["results"].write_text(json.dumps(jsonable({"kind": "job", "run": run_name, **js}), indent=1),
                                  encoding="utf-8")
    written["removal"] = _map_png(out, d / "removal.png", residual=False, run_name=run_name)
    written["residual"] = _map_png(out, d / "residual.png", residual=True, run_name=run_name)
    if out["psd"] is not None:
        from .comparefiles import plot_psds

        lo, hi = out["summary"]["band_per_mm"]
        sp = (out["summary"].get("fair") or {}).get("spacing_mm")
        written["psd"] = plot_psds({"after (centre square)": out["psd"]}, d / "psd.png", band=(lo, hi),
                                   title=f"Simulated profile PSD, {run_name or 'the job'}'s own path",
                                   spacings={"after (centre square)": sp})
    return written


def _map_png(out: dict[str, Any], file: Path, *, residual: bool, run_name: str, max_px: int = 800) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    res, mask, s = out["result"], out["mask"], out["summary"]
    step = max(1, int(np.ceil(max(res.removal_nm.shape) / max_px)))
    z = res.removal_nm[::step, ::step].astype(np.float64)
    m = mask[::step, ::step]
    x0, y0 = res.origin_mm
    ext = [x0, x0 + z.shape[1] * step * res.dx_mm, y0, y0 + z.shape[0] * step * res.dx_mm]
    fig, ax = plt.subplots(figsize=(6, 5))
    if residual:
        z = np.where(m, z - s["depth_mean_nm"], np.nan)
        lim = float(np.nanmax(np.abs(z))) if np.isfinite(z).any() else 1.0
        im = ax.imshow(z, origin="lower", extent=ext, cmap="RdBu_r", vmin=-lim, vmax=lim)
        label = "depth - mean depth (nm), inside the part"
        title = f"Removal non-uniformity: RMS {s['depth_rms_nm']:.3g} nm ({100 * s['depth_rms_rel']:.1f} %)"
    else:
        im = ax.imshow(z, origin="lower", extent=ext, cmap="viridis")
        label = "depth removed (nm)"
        title = f"Removal, mean {s['depth_mean_nm']:.3g} nm inside the part"
    for loop in out["region"].loops:
        c = np.vstack([loop, loop[:1]])
        ax.plot(c[:, 0], c[:, 1], color="k", lw=0.8)
    fig.colorbar(im, ax=ax, label=label)
    names = {"xy": ("x (mm)", "y (mm)"), "unrolled": ("u (mm, unrolled)", "v (mm, unrolled)")}[s["plane"]]
    ax.set_xlabel(names[0])
    ax.set_ylabel(names[1])
    ax.set_aspect("equal")
    ax.set_title(f"{run_name}: {title}" if run_name else title, fontsize=9)
    fig.tight_layout()
    fig.savefig(file, dpi=100)
    plt.close(fig)
    return file
