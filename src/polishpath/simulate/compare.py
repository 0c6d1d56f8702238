"""Compare tool paths by simulated polishing: the paper's Table 4, for your part and tool."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError, PatchTooSmallError
from ..psd.core import PAPER_BAND_PER_MM, PSD, band_average, band_rms, find_peaks, psd_1d, suppression_ratio
from ..pathops import split_by_pieces
from ..types import PlanarPath, Region
from .motion import dwell_from_feed
from .removal import ProcessNoise, SimulationResult, Smoothing, simulate_removal
from .rotating import RotatingToolTIF, rotating_tool_tif
from .tif import TIF, DirectionalTIF
from .workpiece import DEFAULT_DX_MM, Workpiece, synthetic_workpiece

#: The paper's Table 4: (before, after, suppression ratio) of the band-average PSD, 10^3-10^5 1/m.
PAPER_TABLE4: dict[str, tuple[float, float, float]] = {
    "raster": (0.596, 0.393, 0.3406),
    "spiral": (0.527, 0.280, 0.4686),
    "rectangular": (0.816, 0.383, 0.5306),
    "pseudorandom": (0.566, 0.019, 0.9664),
}

#: default process noise: 5 % removal-rate fluctuation correlated over 1 s of machining time
#: (slurry supply and sponge condition drift on the scale of seconds; faster changes
#: average out over the tool's 0.26 s revolution at 230 rpm) -- an assumption, see docs/simulation.md
DEFAULT_NOISE = ProcessNoise(rms=0.05, correlation_length_mm=2.0, correlation_time_s=1.0)


def default_tif() -> RotatingToolTIF:
    """The default tool of :func:`compare_patterns`: the paper's sponge at 230 rpm (docs/simulation.md).

    Parabolic (Winkler-foam) pressure over a 2 mm contact radius, nominal feed 600 mm/min; its
    Preston coefficient is rescaled by :func:`compare_patterns` to remove the depth asked for.
    """
    return rotating_tool_tif()
#: default smoothing of a compliant sponge
DEFAULT_SMOOTHING = Smoothing(depth_nm=100.0, length_mm=1.0)


def profile_psd(map_nm: np.ndarray, dx_mm: float, *, window: str = "hann", detrend="tilt") -> PSD:
    """Profilometer-style PSD of a map: 1D PSDs of all rows and all columns, averaged.

    Averaging both directions makes the figure independent of how the
    profilometer would have been aligned to a directional (raster) texture.

    Parameters
    ----------
    map_nm : (n, n) float
        Square height map, nm.
    dx_mm : float
        Pixel pitch, mm.

    Returns
    -------
    PSD
        ``kind="1d"``, nm^2 mm; ``params["directions"] = "rows+columns"``.
    """
    z = np.asarray(map_nm, dtype=np.float64)
    if z.shape[0] != z.shape[1]:
        n = min(z.shape)
        z = z[:n, :n]
    a = psd_1d(z, dx_mm, window=window, detrend=detrend, nan="raise")
    b = psd_1d(z.T, dx_mm, window=window, detrend=detrend, nan="raise")
    params = dict(a.params)
    params.update({"directions": "rows+columns", "n_profiles": a.params["n_profiles"] + b.params["n_profiles"],
                   "variance_nm2": 0.5 * (a.params["variance_nm2"] + b.params["variance_nm2"])})
    return PSD(a.freq, 0.5 * (a.psd + b.psd), kind="1d", units=a.units, params=params)


def _crop(res_map: np.ndarray, origin, dx, bounds) -> np.ndarray:
    xmin, ymin, xmax, ymax = bounds
    i0 = int(np.ceil((xmin - origin[0]) / dx - 1e-9))
    j0 = int(np.ceil((ymin - origin[1]) / dx - 1e-9))
    n = int(np.floor((min(xmax - xmin, ymax - ymin)) / dx + 1e-9))
    if i0 < 0 or j0 < 0 or j0 + n > res_map.shape[0] or i0 + n > res_map.shape[1] or n < 16:
        raise PatchTooSmallError(f"evaluation window {bounds} does not fit in the simulated patch.",
                                 "Use a smaller eval_inset_mm or a larger patch.")
    return res_map[j0:j0 + n, i0:i0 + n]


def evaluate_result(result: SimulationResult, eval_bounds, *, band=PAPER_BAND_PER_MM,
                    spacing_mm: float | None = None, psd_before: PSD | None = None) -> dict[str, Any]:
    """Before/after profile PSDs of a simulation over a square evaluation window.

    Parameters
    ----------
    result : SimulationResult
    eval_bounds : (xmin, ymin, xmax, ymax)
        Window, mm (the largest square inside it from its lower-left corner is used).
    band : (float, float)
        1/mm.
    spacing_mm : float, optional
        Path spacing, to name peaks.
    psd_before : PSD, optional
        Already computed PSD of the same initial surface over the same window (reused).

    Returns
    -------
    dict
        ``psd_before``, ``psd_after`` (:class:`PSD`), ``before``/``after``
        band averages (nm^2 mm), ``suppression_ratio``, band RMS (nm),
        ``peaks_after``.
    """
    a = _crop(result.after_nm, result.origin_mm, result.dx_mm, eval_bounds)
    pb = psd_before or profile_psd(_crop(result.before_nm, result.origin_mm, result.dx_mm, eval_bounds), result.dx_mm)
    pa = profile_psd(a, result.dx_mm)
    return {
        "psd_before": pb, "psd_after": pa, "before": band_average(pb, *band), "after": band_average(pa, *band),
        "suppression_ratio": suppression_ratio(pb, pa, band), "band_rms_before_nm": band_rms(pb, *band),
        "band_rms_after_nm": band_rms(pa, *band), "peaks_after": find_peaks(pa, spacing_mm, band=band),
    }


def compare_paths(paths: dict[str, Any], workpiece: Workpiece, tif: TIF | DirectionalTIF, *,
                  noise: ProcessNoise | None = DEFAULT_NOISE, smoothing: Smoothing | None = DEFAULT_SMOOTHING,
                  seed: int = 0, band=PAPER_BAND_PER_MM, spacing_mm: float | None = None,
                  eval_bounds=None, eval_inset_mm: float | None = None, out_dir=None,
                  keep_results: bool = False, time_model: str = "segments", machine: dict | None = None,
                  removal_dx_mm: float | None = None) -> dict[str, Any]:
    """Run the same removal on several paths and tabulate the band-average PSD before and after.

    Parameters
    ----------
    paths : dict of name -> (path_xy (N, 2) mm, dwell_s (N,) s) or (path_xy, dwell_s, pieces)
        The paths to compare, in the workpiece's plane.
    workpiece : Workpiece
        Initial surface (the same for every path).
    tif : TIF or DirectionalTIF
    noise : ProcessNoise or None
        Process noise; each path gets the same seed.
    smoothing : Smoothing or None
    seed : int
    band : (float, float)
        1/mm (default 1-100 = 10^3-10^5 1/m).
    spacing_mm : float, optional
        Path spacing, to name spectral peaks.
    eval_bounds : (xmin, ymin, xmax, ymax), optional
        Where to measure, mm. Default: the patch inset by ``eval_inset_mm``.
    eval_inset_mm : float, optional
        Default ``2 * TIF radius``-ish: ``4.5 sigma + spacing``.
    out_dir : str or Path, optional
        Write ``table.txt``, ``results.json``, ``psd.png`` and ``residual_<name>.png`` here.
    keep_results : bool
        Put the full :class:`SimulationResult` of each path in the output.
    time_model : {"segments", "points", "machine"}
        Continuous motion, stop-and-dwell, or the NURBS-smoothed path at a
        constant interpolation period (see :func:`simulate_removal`).
    machine : dict, optional
        Options of the ``"machine"`` time model.
    removal_dx_mm : float, optional
        Convolution pitch for a RotatingToolTIF (see :func:`simulate_removal`).

    Returns
    -------
    dict
        ``rows`` (list of dicts: name, before, after, suppression_ratio,
        band RMS, peaks, timings), ``table`` (text), ``params`` (everything
        needed to reproduce), ``psds`` (name -> PSD, plus ``"before"``).
    """
    if not paths:
        raise ParameterError("no path to compare.", "Give at least one (path_xy, dwell_s) pair.")
    if eval_bounds is None:
        if isinstance(tif, RotatingToolTIF):
            reach = tif.radius_mm  # the footprint ends at the contact edge
        else:
            reach = 4.5 * max((t.params.get("sigma_mm", 0.5)
                               for t in (tif.tifs if isinstance(tif, DirectionalTIF) else (tif,))))
        inset = eval_inset_mm if eval_inset_mm is not None else reach + (spacing_mm or 0.5)
        x0, y0, x1, y1 = workpiece.bounds
        eval_bounds = (x0 + inset, y0 + inset, x1 - inset, y1 - inset)
    rows, psds, results = [], {}, {}
    if out_dir is not None:
        Path(out_dir).mkdir(parents=True, exist_ok=True)
    for name, spec in paths.items():
        xy, dwell = spec[0], spec[1]
        pieces = spec[2] if len(spec) > 2 else None
        t0 = time.perf_counter()
        res = simulate_removal(xy, dwell, workpiece, tif, noise=noise, smoothing=smoothing, seed=seed, pieces=pieces,
                               time_model=time_model, machine=machine, removal_dx_mm=removal_dx_mm)
        ev = evaluate_result(res, eval_bounds, band=band, spacing_mm=spacing_mm, psd_before=psds.get("before"))
        dt = time.perf_counter() - t0
        psds.setdefault("before", ev["psd_before"])
        psds[name] = ev["psd_after"]
        row = {"name": name, "before": ev["before"], "after": ev["after"], "suppression_ratio": ev["suppression_ratio"],
               "band_rms_before_nm": ev["band_rms_before_nm"], "band_rms_after_nm": ev["band_rms_after_nm"],
               "peaks": ev["peaks_after"], "n_points": int(len(xy)), "mean_depth_nm": res.stats["mean_depth_nm"],
               "total_time_s": res.stats["total_time_s"], "effective_time_s": res.stats["effective_time_s"],
               "time_off_grid_s": res.stats["time_off_grid_s"], "rotating": res.stats.get("rotating"),
               "motion": res.stats.get("motion") or None, "seconds": dt}
        rows.append(row)
        if out_dir is not None:
            _plot_residual(res, eval_bounds, Path(out_dir) / f"residual_{name}.png", name)
        if keep_results:
            results[name] = res
        del res
    units = psds["before"].units
    params = {"time_model": time_model, "machine": machine, "band_per_mm": list(band), "eval_bounds_mm": [float(v) for v in eval_bounds], "seed": seed,
              "spacing_mm": spacing_mm, "tif": _tif_params(tif), "noise": None if noise is None else vars(noise).copy(),
              "smoothing": None if smoothing is None else vars(smoothing).copy(), "dx_mm": workpiece.dx_mm,
              "workpiece": workpiece.provenance.to_dict(), "psd": "1D profiles, rows+columns averaged, hann, tilt removed",
              "units": units}
    out = {"rows": rows, "params": params, "psds": psds, "table": format_table(rows, units)}
    if keep_results:
        out["results"] = results
    if out_dir is not None:
        write_outputs(out, out_dir)
    return out


def _tif_params(tif) -> dict[str, Any]:
    if isinstance(tif, DirectionalTIF):
        return {"kind": "directional", **tif.params}
    return {"kind": tif.kind, **tif.params}


def format_table(rows: list[dict[str, Any]], units: str = "nm^2 mm") -> str:
    """Table 4 analogue as text, with the paper's numbers beside the simulated ones."""
    head = (f"{'path':<14}{'before':>12}{'after':>12}{'suppr.':>9}   |  paper: {'before':>7}{'after':>7}{'suppr.':>8}"
            f"   peaks (after)\n")
    lines = [f"band-average PSD, {units} (simulated) / paper's own units\n", head, "-" * (len(head) + 10) + "\n"]
    for r in rows:
        p = PAPER_TABLE4.get(r["name"])
        paper = f"{p[0]:>7.3f}{p[1]:>7.3f}{100 * p[2]:>7.2f}%" if p else f"{'':>7}{'':>7}{'':>8}"
        pk = ", ".join(f"{d['freq_per_mm']:.2f}/mm{(' ' + d['label']) if d['label'] else ''}" for d in r["peaks"][:3])
        lines.append(f"{r['name']:<14}{r['before']:>12.4g}{r['after']:>12.4g}{100 * r['suppression_ratio']:>8.2f}%"
                     f"   |         {paper}   {pk or '-'}\n")
    return "".join(lines)


def write_outputs(out: dict[str, Any], out_dir) -> None:
    """Write ``table.txt``, ``results.json`` and ``psd.png`` of a comparison into ``out_dir``."""
    d = Path(out_dir)
    d.mkdir(parents=True, exist_ok=True)
    (d / "table.txt").write_text(out["table"])
    js = {"rows": out["rows"], "params": out["params"],
          "psds": {k: {"freq_per_mm": v.freq.tolist(), "psd": v.psd.tolist(), "units": v.units} for k, v in out["psds"].items()}}
    (d / "results.json").write_text(json.dumps(js, indent=1, default=_json_default))
    plot_psds(out["psds"], d / "psd.png", band=tuple(out["params"]["band_per_mm"]))


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)


def plot_psds(psds: dict[str, PSD], file, *, band=PAPER_BAND_PER_MM, title: str = "Simulated profile PSD") -> Path:
    """Log-log PSD plot, one curve per path, the band shaded, units on the axes.

    Parameters
    ----------
    psds : dict of name -> PSD
    file : str or Path
        PNG to write.
    band : (float, float)
        1/mm, shaded.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for name, p in psds.items():
        ax.loglog(p.freq, p.psd, lw=1.0 if name != "before" else 1.6, color="k" if name == "before" else None,
                  ls="--" if name == "before" else "-", label=name)
    ax.axvspan(band[0], band[1], color="0.9", zorder=0, label=f"band {band[0]:g}-{band[1]:g} 1/mm")
    units = next(iter(psds.values())).units
    ax.set_xlabel("spatial frequency f (1/mm)")
    ax.set_ylabel(f"PSD ({units})")
    ax.set_title(title)
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(file, dpi=110)
    plt.close(fig)
    return Path(file)


def _plot_residual(res: SimulationResult, eval_bounds, file, name: str, max_px: int = 600) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    z = _crop(res.after_nm, res.origin_mm, res.dx_mm, eval_bounds).astype(np.float64)
    step = max(1, int(np.ceil(z.shape[0] / max_px)))
    z = z[::step, ::step]
    z = z - z.mean()
    lim = 3 * z.std() if z.std() > 0 else 1
    fig, ax = plt.subplots(figsize=(5, 4.3))
    ext = [eval_bounds[0], eval_bounds[0] + z.shape[1] * step * res.dx_mm,
           eval_bounds[1], eval_bounds[1] + z.shape[0] * step * res.dx_mm]
    im = ax.imshow(z, origin="lower", extent=ext, cmap="RdBu_r", vmin=-lim, vmax=lim)
    fig.colorbar(im, ax=ax, label="residual height (nm), piston removed")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(f"after polishing: {name}")
    fig.tight_layout()
    fig.savefig(file, dpi=100)
    plt.close(fig)
    return Path(file)


def _square_region(size_mm: float) -> Region:
    h = size_mm / 2
    return Region(np.array([[-h, -h], [h, -h], [h, h], [-h, h]]))


def _dwell_s_per_point(tif, spacing_mm: float, removal_depth_nm: float):
    """Equal dwell time per point (s) that removes ``removal_depth_nm`` on a grid of ``spacing_mm``, and the tool.

    A RotatingToolTIF keeps its nominal feed (``t = spacing / feed``) and has its
    Preston coefficient rescaled to the depth; any other TIF keeps its rate and
    gets ``t = depth * spacing^2 / volume rate``. Returns ``(t, tif, scale)``.
    """
    if isinstance(tif, RotatingToolTIF):
        if not tif.feed_mm_min > 0:
            raise ParameterError("a rotating tool for the comparison needs a nominal feed > 0 mm/min.")
        t_point = spacing_mm / (tif.feed_mm_min / 60.0)
        scale = removal_depth_nm * spacing_mm**2 / (tif.volume_rate * t_point)
        return t_point, tif.scaled(scale), scale
    vol = tif.tifs[0].volume_rate if isinstance(tif, DirectionalTIF) else tif.volume_rate
    return removal_depth_nm * spacing_mm**2 / vol, tif, None


def compare_planned(planned: dict[str, PlanarPath], *, seed: int = 0, dx_mm: float = DEFAULT_DX_MM,
                    tif: TIF | DirectionalTIF | None = None, noise: ProcessNoise | None = DEFAULT_NOISE,
                    smoothing: Smoothing | None = DEFAULT_SMOOTHING, workpiece: Workpiece | None = None,
                    initial_rms_nm: float = 2.0, initial_exponent: float = 2.5, removal_depth_nm: float = 200.0,
                    band=PAPER_BAND_PER_MM, time_model: str = "segments", dwell: str = "equal",
                    patch_bounds=None, out_dir=None, machine: dict | None = None,
                    removal_dx_mm: float | None = None, plan_info: dict | None = None) -> dict[str, Any]:
    """Simulate the same polishing along already planned paths and tabulate (Table 4 analogue).

    The paths are simulated in their own plane (the plane they were planned
    in: for a part, its flattening). Every path gets the same tool, initial
    surface, noise seed and mean depth.

    Parameters
    ----------
    planned : dict of name -> PlanarPath
        The paths (``uv`` (N, 2) mm, ``pieces``, ``spacing`` the planar grid spacing, mm).
    seed : int
        Seed of the initial surface and the process noise.
    dx_mm : float
        Simulation pixel pitch, mm (5 um resolves 100 1/mm).
    tif : TIF, DirectionalTIF or RotatingToolTIF, optional
        Default :func:`default_tif`: the paper's sponge spinning at 230 rpm
        (parabolic pressure, 2 mm contact radius, feed 600 mm/min). The dwell
        time per point follows from ``removal_depth_nm`` and each path's planar
        spacing (:func:`_dwell_s_per_point`).
    noise, smoothing :
        Process noise and smoothing (defaults in docs/simulation.md).
    workpiece : Workpiece, optional
        Initial surface; default a synthetic power-law surface over ``patch_bounds``.
    initial_rms_nm, initial_exponent : float
        Synthetic initial surface: RMS (nm) and 2D PSD exponent, band 0.2-100 1/mm.
    removal_depth_nm : float
        Mean depth to remove, nm.
    band : (float, float)
        1/mm.
    time_model : {"segments", "points", "machine"}
        Continuous motion, stop-and-dwell, or the machine's constant-period
        samples of the NURBS through the dwell points (:mod:`polishpath.smooth`).
    dwell : {"equal", "feed"}
        ``"equal"``: every dwell point gets the same time (the paper's dwell
        points); ``"feed"``: constant feed along each path (time proportional to
        path length, so diagonal steps get more), scaled to the same total
        time per point as ``"equal"``.
    patch_bounds : (xmin, ymin, xmax, ymax), optional
        Simulated patch, mm (default: the bounds of all paths). Path outside it
        is dropped (counted in the per-path ``time_off_grid_s``).
    out_dir : str or Path, optional
        Where to write the table, JSON, PSD plot and residual maps.
    machine, removal_dx_mm :
        As :func:`compare_paths`.
    plan_info : dict, optional
        Per-path planning figures to record in ``params["plans"]``.

    Returns
    -------
    dict
        As :func:`compare_paths`, plus per-row ``pattern`` and ``planar_spacing_mm``.
    """
    if not planned:
        raise ParameterError("no planned path to compare.", "Give at least one pattern.")
    base_tif = tif or default_tif()
    if patch_bounds is None:
        allp = np.concatenate([np.asarray(p.uv) for p in planned.values()])
        patch_bounds = (*allp.min(axis=0), *allp.max(axis=0))
    xmin, ymin, xmax, ymax = map(float, patch_bounds)
    if workpiece is None:
        workpiece = synthetic_workpiece((xmin, ymin, xmax, ymax), dx_mm, rms_nm=initial_rms_nm,
                                        exponent=initial_exponent, band_per_mm=(0.2, 100.0), seed=seed)
    spacings = {name: float(p.spacing) for name, p in planned.items()}
    # one tool for every path: its rate is set by the first path's spacing (equal on a plane; on a part the
    # planar spacings differ a little, and each path's dwell time keeps its depth)
    h0 = next(iter(spacings.values()))
    t0_point, tif_used, tif_scale = _dwell_s_per_point(base_tif, h0, removal_depth_nm)
    paths, t_points = {}, {}
    for name, pp in planned.items():
        xy, pieces = np.asarray(pp.uv), np.asarray(pp.pieces)
        t_point = t0_point * (spacings[name] / h0) ** 2
        if dwell == "equal":
            times = np.full(len(xy), t_point)
        elif dwell == "feed":
            times = np.concatenate([dwell_from_feed(part, 60.0) if len(part) > 1 else np.ones(len(part))
                                    for part in split_by_pieces(xy, pieces)])
            times *= t_point * len(xy) / times.sum()
        else:
            raise ParameterError(f"unknown dwell mode {dwell!r}.", "Use 'equal' or 'feed'.")
        paths[name] = (xy, times, pieces)
        t_points[name] = t_point
    out = compare_paths(paths, workpiece, tif_used, noise=noise, smoothing=smoothing, seed=seed, band=band,
                        spacing_mm=h0, out_dir=out_dir, time_model=time_model, machine=machine,
                        removal_dx_mm=removal_dx_mm)
    for r in out["rows"]:
        r["pattern"] = r["name"]
        r["planar_spacing_mm"] = spacings[r["name"]]
        r["dwell_s_per_point"] = t_points[r["name"]]
    out["params"].update({"dwell": dwell, "patterns": list(planned), "spacing_mm": h0,
                          "dwell_s_per_point": t0_point, "removal_depth_nm": removal_depth_nm,
                          "plans": plan_info or {}, "tif_rate_scale": tif_scale,
                          "region_bounds_mm": [xmin, ymin, xmax, ymax]})
    if out_dir is not None:
        write_outputs(out, out_dir)  # again, now with the planning parameters
    return out


def patch_bounds_at_centre(region: Region, patch_mm: float | None):
    """Bounds of a centred square of side ``patch_mm`` at the region's centroid (None: the region's bounds)."""
    if patch_mm is None:
        return tuple(map(float, region.bounds))
    if not patch_mm > 0:
        raise ParameterError(f"the patch side must be > 0 mm, got {patch_mm}.")
    cx, cy = region.centroid
    return (cx - patch_mm / 2, cy - patch_mm / 2, cx + patch_mm / 2, cy + patch_mm / 2)


def compare_patterns(region_or_size: Region | float = 20.0,
                     patterns=("pseudorandom", "raster", "spiral", "rectangular"), spacing: float = 0.5,
                     seed: int = 0, *, patch_mm: float | None = None, **kw) -> dict[str, Any]:
    """Plan each pattern in a planar region, then :func:`compare_planned` (the Table 4 analogue on a plane).

    For a part, plan on it through :func:`polishpath.pipeline.plan_on_surface`
    (spacing on the part) and call :func:`compare_planned`, as
    ``polishpath simulate SURFACE`` does.

    Parameters
    ----------
    region_or_size : Region or float
        Planar region (mm) or the side of a centred square, mm.
    patterns : sequence of str
        Planner pattern names (:data:`polishpath.plan.PATTERNS`).
    spacing : float
        Dwell-point spacing in the plane, mm.
    seed : int
        Seed of the planner, the initial surface and the process noise.
    patch_mm : float, optional
        Simulate only a centred square of this side (mm) at the region's
        centroid while planning over the whole region.
    **kw :
        Everything else of :func:`compare_planned` (tif, noise, dx_mm, time_model ...).

    Returns
    -------
    dict
        As :func:`compare_planned`; ``params["plans"]`` has each plan's provenance.
    """
    from ..plan import plan  # the planning stage, looked up at call time

    region = region_or_size if isinstance(region_or_size, Region) else _square_region(float(region_or_size))
    planned, info = {}, {}
    for pat in patterns:
        tp = time.perf_counter()
        pp = plan(region, spacing, pat, seed=seed)
        planned[pat] = pp
        info[pat] = {"n_points": int(pp.n_points), "n_unreached": int(len(pp.unreached)),
                     "provenance": pp.provenance.to_dict(), "seconds": time.perf_counter() - tp}
    return compare_planned(planned, seed=seed, patch_bounds=patch_bounds_at_centre(region, patch_mm),
                           plan_info=info, **kw)
