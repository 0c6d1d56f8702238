"""Compare tool paths by simulated polishing, fairly: the paper's Table 4, for your part and tool.

Every path removes the same mean depth from the same start with the same
tool; each residual is judged by the fair metrics of
:mod:`polishpath.simulate.fair` (band RMS, lattice peak, PVn) beside the
paper's before/after suppression ratio, over N seeds (mean and range). The
machine timing is :mod:`~polishpath.simulate.machinetime`, the switchable
effects :mod:`~polishpath.simulate.mechanisms`, the spread and ties
:mod:`~polishpath.simulate.spread`, the files :mod:`~polishpath.simulate.comparefiles`.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

import numpy as np

from ..errors import ParameterError, PatchTooSmallError
from ..psd.core import PAPER_BAND_PER_MM, PSD, band_average, band_rms, find_peaks, suppression_ratio
from ..pathops import split_by_pieces
from ..types import PlanarPath
from .cases import Case, CaseResult, CaseRunner, Start, TimingCase, run_cases, run_timing
from .motion import dwell_from_feed
from .comparefiles import format_table, plot_psds, write_outputs
from .machinetime import COMPARE_TIMINGS, machine_timed_path
from .mechanisms import Mechanisms, tool_with
from .removal import ProcessNoise, SimulationResult, Smoothing, simulate_removal, smooth_surface
from .profile import profile_psd
from .rotating import RotatingToolTIF, default_tif
from .spread import FAIR_KEYS, aggregate_rows, rank, spread
from .tif import TIF, DirectionalTIF
from .workpiece import DEFAULT_DX_MM, Workpiece, flat_workpiece, synthetic_workpiece

__all__ = ["DEFAULT_NOISE", "DEFAULT_SMOOTHING", "MODES", "PAPER_TABLE4", "compare_paths", "compare_planned",
           "default_tif", "evaluate_result", "format_table", "plot_psds", "profile_psd"]

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


#: default smoothing of a compliant sponge
DEFAULT_SMOOTHING = Smoothing(depth_nm=100.0, length_mm=1.0)


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
        band averages (nm^2 mm), ``suppression_ratio`` (None when the start has
        no power in the band), band RMS (nm),
        ``peaks_after``.
    """
    a = _crop(result.after_nm, result.origin_mm, result.dx_mm, eval_bounds)
    pb = psd_before or profile_psd(_crop(result.before_nm, result.origin_mm, result.dx_mm, eval_bounds), result.dx_mm)
    pa = profile_psd(a, result.dx_mm)
    before = band_average(pb, *band)
    return {
        "psd_before": pb, "psd_after": pa, "before": before, "after": band_average(pa, *band),
        # undefined from a start with no power in the band (a flat start)
        "suppression_ratio": suppression_ratio(pb, pa, band) if before > 0 else None,
        "band_rms_before_nm": band_rms(pb, *band),
        "band_rms_after_nm": band_rms(pa, *band), "peaks_after": find_peaks(pa, spacing_mm, band=band),
    }


#: the modes of a comparison (docs/simulation.md, "Comparing paths")
MODES = ("process", "interference-free")
#: the most seeds a comparison runs
MAX_SEEDS = 100


def _reach(tif) -> float:
    """How far the tool removes from its centre, mm."""
    if isinstance(tif, RotatingToolTIF):
        return tif.radius_mm  # the footprint ends at the contact edge
    tifs = tif.tifs if isinstance(tif, DirectionalTIF) else (tif,)
    return max(4.5 * t.params["sigma_mm"] if t.kind == "gaussian" else t.radius_mm for t in tifs)


def _residual_picture(z: np.ndarray, x0: float, y0: float, dx: float, seed: int, max_px: int = 400) -> dict:
    step = max(1, int(np.ceil(max(z.shape) / max_px)))
    zz = np.asarray(z[::step, ::step], dtype=np.float32)
    return {"map_nm": zz, "extent_mm": [x0, x0 + zz.shape[1] * step * dx, y0, y0 + zz.shape[0] * step * dx],
            "seed": seed}


def compare_paths(paths: dict[str, Any], workpiece: Workpiece, tif: TIF | DirectionalTIF, *,
                  noise: ProcessNoise | None = DEFAULT_NOISE, smoothing: Smoothing | None = DEFAULT_SMOOTHING,
                  seed: int = 0, band=PAPER_BAND_PER_MM, spacing_mm: float | None = None,
                  eval_bounds=None, eval_inset_mm: float | None = None, out_dir=None,
                  keep_results: bool = False, time_model: str = "segments", machine: dict | None = None,
                  removal_dx_mm: float | None = None, depth_nm: float | None = None,
                  path_spacings_mm: dict[str, float] | None = None,
                  path_lattices: dict[str, bool] | None = None) -> dict[str, Any]:
    """Run the same removal on several paths (one seed) and judge each residual by the fair metrics.

    Parameters
    ----------
    paths : dict of name -> (path_xy (N, 2) mm, dwell_s (N,) s[, pieces[, time_model]])
        The paths to compare, in the workpiece's plane; a fourth item overrides
        ``time_model`` for that path (``"moves"`` for machine samples).
    workpiece : Workpiece
        Initial surface (the same for every path).
    tif : TIF, DirectionalTIF or RotatingToolTIF
    noise : ProcessNoise or None
        Process noise; each path gets the same seed.
    smoothing : Smoothing or None
    seed : int
    band : (float, float)
        1/mm (default 1-100 = 10^3-10^5 1/m).
    spacing_mm : float, optional
        Path spacing, mm, of every path not in ``path_spacings_mm``: its lattice frequencies for
        :func:`~polishpath.simulate.fair.lattice_peak_db` and the names of spectral peaks (default 0.5).
    eval_bounds : (xmin, ymin, xmax, ymax), optional
        Where to measure, mm. Default: the patch inset by ``eval_inset_mm``.
    eval_inset_mm : float, optional
        Default: the tool's reach + the spacing.
    out_dir : str or Path, optional
        Write ``table.txt``, ``results.json``, ``psd.png``, ``residuals.png`` and ``residual_<name>.png`` here.
    keep_results : bool
        Put the full :class:`SimulationResult` of each path in the output.
    time_model : {"segments", "points", "machine", "moves"}
        See :func:`simulate_removal`.
    machine : dict, optional
        Options of the ``"machine"`` time model.
    removal_dx_mm : float, optional
        Convolution pitch for a RotatingToolTIF (see :func:`simulate_removal`).
    depth_nm : float, optional
        Make every path remove exactly this mean depth inside the evaluation
        window (nm): its removal is scaled (exact: the model is linear in the
        rate) and the smoothing applied for this depth. None: as simulated.
    path_spacings_mm : dict of name -> float, optional
        Each path's own spacing in the workpiece's plane, mm: its lattice peak is
        looked for at its own frequencies (:func:`~polishpath.simulate.fair.path_frequencies`).
    path_lattices : dict of name -> bool, optional
        False for a path whose dwell points have no lattice: it is read at the
        nominal frequencies of its spacing (default True).

    Returns
    -------
    dict
        ``rows`` (per path: ``residual_band_rms_nm``, ``lattice_peak_db``,
        ``pvn``, ``residual_rms_nm``, ``residual_pv_nm`` (the fair metrics of
        the residual), ``before`` / ``after`` band averages, ``suppression_ratio``
        (None from a flat start), band RMS, peaks, times, ``lattice_spacing_mm``,
        ``lattice_frequencies_per_mm`` and ``lattice_basis``: where its lattice
        peak was read, ``time_density_peak_db``: the peak of the machine samples'
        time density at the nominal frequencies of its spacing in the evaluation
        window, :func:`~polishpath.simulate.fair.time_density_peak_db`; None
        unless the path is given as machine samples, ``"moves"``), ``params``, ``psds``
        (name -> PSD of the residual, plus ``"before"``), ``residuals`` (name ->
        downsampled residual map for the figures), ``table``.
    """
    from .fair import detrend_residual, fair_metrics, path_frequencies

    if not paths:
        raise ParameterError("no path to compare.", "Give at least one (path_xy, dwell_s) pair.")
    if eval_bounds is None:
        inset = eval_inset_mm if eval_inset_mm is not None else _reach(tif) + (spacing_mm or 0.5)
        x0, y0, x1, y1 = workpiece.bounds
        eval_bounds = (x0 + inset, y0 + inset, x1 - inset, y1 - inset)
    flat_start = not np.any(np.asarray(workpiece.height_nm))
    rows, psds, results, pictures = [], {}, {}, {}
    dx = workpiece.dx_mm
    for name, spec in paths.items():
        xy, dwell = spec[0], spec[1]
        pieces = spec[2] if len(spec) > 2 else None
        tm = spec[3] if len(spec) > 3 else time_model
        t0 = time.perf_counter()
        res = simulate_removal(xy, dwell, workpiece, tif, noise=noise, smoothing=smoothing, seed=seed, pieces=pieces,
                               time_model=tm, machine=machine, removal_dx_mm=removal_dx_mm)
        scale = None
        if depth_nm is not None:  # the same mean depth for every path, inside the evaluation window
            m = float(_crop(res.removal_nm, res.origin_mm, dx, eval_bounds).astype(np.float64).mean())
            scale = depth_nm / m if m > 0 else 1.0
            removal = (res.removal_nm * np.float32(scale)).astype(np.float32)
            base = (smooth_surface(res.before_nm, dx, depth_nm, smoothing) if smoothing is not None
                    else res.before_nm)
            res = replace(res, removal_nm=removal, after_nm=(base - removal).astype(np.float32),
                          stats={**res.stats, "depth_scale": scale})
        h = float((path_spacings_mm or {}).get(name) or spacing_mm or 0.5)  # this path's own spacing
        has_lattice = bool((path_lattices or {}).get(name, True))
        freqs = path_frequencies(h, lattice=has_lattice)
        ev = evaluate_result(res, eval_bounds, band=band, spacing_mm=h, psd_before=psds.get("before"))
        after = _crop(res.after_nm, res.origin_mm, dx, eval_bounds).astype(np.float64)
        depth = depth_nm if depth_nm is not None else float(
            _crop(res.removal_nm, res.origin_mm, dx, eval_bounds).astype(np.float64).mean())
        fm = fair_metrics(after, dx, h, depth, band=band, frequencies=freqs)
        dt = time.perf_counter() - t0
        psds.setdefault("before", ev["psd_before"])
        psds[name] = ev["psd_after"]
        row = {"name": name, "residual_band_rms_nm": fm.residual_band_rms_nm, "lattice_peak_db": fm.lattice_peak_db,
               "lattice_spacing_mm": h, "lattice_frequencies_per_mm": [float(f) for f in freqs],
               "lattice_basis": "lattice" if has_lattice else "nominal spacing (no lattice)",
               # the tool's time density from the machine's constant-period samples (none with ideal timing)
               "time_density_peak_db": _time_density(xy, dwell, h, eval_bounds) if tm == "moves" else None,
               "pvn": fm.pvn, "residual_rms_nm": fm.residual_rms_nm, "residual_pv_nm": fm.residual_pv_nm,
               "before": ev["before"], "after": ev["after"],
               "suppression_ratio": None if flat_start else ev["suppression_ratio"],
               "band_rms_before_nm": ev["band_rms_before_nm"], "band_rms_after_nm": ev["band_rms_after_nm"],
               "peaks": ev["peaks_after"], "n_points": int(len(xy)), "time_model": tm,
               "mean_depth_nm": depth if depth_nm is not None else res.stats["mean_depth_nm"],
               "depth_scale": scale, "total_time_s": res.stats["total_time_s"],
               "effective_time_s": res.stats["effective_time_s"], "time_off_grid_s": res.stats["time_off_grid_s"],
               "rotating": res.stats.get("rotating"), "motion": res.stats.get("motion") or None, "seconds": dt}
        rows.append(row)
        i0, j0 = _crop_origin(res.origin_mm, dx, eval_bounds)
        pictures[name] = _residual_picture(detrend_residual(after, dx), res.origin_mm[0] + i0 * dx,
                                           res.origin_mm[1] + j0 * dx, dx, seed)
        if keep_results:
            results[name] = res
        del res
    if flat_start:
        psds.pop("before", None)
    units = next(iter(psds.values())).units
    params = {"time_model": time_model, "machine": machine, "band_per_mm": list(band),
              "eval_bounds_mm": [float(v) for v in eval_bounds], "seed": seed, "seeds": [seed],
              "spacing_mm": spacing_mm, "tif": _tif_params(tif), "noise": None if noise is None else vars(noise).copy(),
              "smoothing": None if smoothing is None else vars(smoothing).copy(), "dx_mm": workpiece.dx_mm,
              "workpiece": workpiece.provenance.to_dict(), "flat_start": flat_start, "removal_depth_nm": depth_nm,
              "psd": "1D profiles, rows+columns averaged, hann, tilt removed", "units": units,
              "fair": "polishpath.simulate.fair.fair_metrics of the residual in the evaluation window"}
    rankings = {k: rank(rows, k) for k in FAIR_KEYS}
    out = {"rows": rows, "params": params, "psds": psds, "residuals": pictures, "rankings": rankings,
           "table": format_table(rows, units, params=params, rankings=rankings)}
    if keep_results:
        out["results"] = results
    if out_dir is not None:
        write_outputs(out, out_dir)
    return out


def _time_density(xy, time_s, spacing_mm: float, bounds) -> float | None:
    """:func:`~polishpath.simulate.fair.time_density_peak_db` of a path's machine samples, None when the
    window is too small to read it (a figure of its own: the residual's figures do not depend on it)."""
    from .fair import time_density_peak_db

    try:
        return time_density_peak_db(xy, time_s, spacing_mm, bounds)
    except ParameterError:
        return None


def run_case(case: Case) -> CaseResult:
    """Simulate one case of :func:`compare_planned` (a path under a seed) and judge it: a pure function of ``case``."""
    o = compare_paths({case.name: case.path}, case.start.build(), case.tif, noise=case.noise,
                      smoothing=case.smoothing, seed=case.seed, **case.options)
    return CaseResult(row=o["rows"][0], psds=o["psds"], picture=o["residuals"][case.name], params=o["params"])


def _crop_origin(origin, dx, bounds) -> tuple[int, int]:
    return (int(np.ceil((bounds[0] - origin[0]) / dx - 1e-9)), int(np.ceil((bounds[1] - origin[1]) / dx - 1e-9)))


def _tif_params(tif) -> dict[str, Any]:
    if isinstance(tif, DirectionalTIF):
        return {"kind": "directional", **tif.params}
    return {"kind": tif.kind, **tif.params}


def _dwell_s_per_point(tif, spacing_mm: float, removal_depth_nm: float):
    """Equal dwell time per point (s) that removes ``removal_depth_nm`` on a grid of ``spacing_mm``, and the tool.

    The tool moves at a feed a machine runs: a RotatingToolTIF's nominal feed,
    else the job's default feed (:data:`polishpath.defaults.DEFAULT_FEED_MM_MIN`),
    so ``t = spacing / feed`` (the machine timing and a noise correlated in time
    see real speeds). The rate is scaled to the depth: a RotatingToolTIF's
    Preston coefficient, for any other TIF by the comparison's exact rescaling
    of the removal (``depth_nm`` of :func:`compare_paths`; the scale is only
    recorded). Returns ``(t, tif, scale)``.
    """
    from ..defaults import DEFAULT_FEED_MM_MIN

    if isinstance(tif, RotatingToolTIF):
        if not tif.feed_mm_min > 0:
            raise ParameterError("a rotating tool for the comparison needs a nominal feed > 0 mm/min.")
        t_point = spacing_mm / (tif.feed_mm_min / 60.0)
        scale = removal_depth_nm * spacing_mm**2 / (tif.volume_rate * t_point)
        return t_point, tif.scaled(scale), scale
    vol = tif.tifs[0].volume_rate if isinstance(tif, DirectionalTIF) else tif.volume_rate
    t_point = spacing_mm / (DEFAULT_FEED_MM_MIN / 60.0)
    return t_point, tif, removal_depth_nm * spacing_mm**2 / (vol * t_point)


#: the treatments a comparison gives every path alike (docs/simulation.md, "Where the walks' band RMS comes from")
TREATMENTS = ("none", "density-fit", "ripple-fit")


def check_comparison(*, seeds: int, mode: str, timing: str, time_model: str | None = None,
                     treatment: str = "none") -> None:
    """Refuse a bad seed count, mode, timing, time model or treatment before any work (ParameterError naming the
    choices)."""
    if treatment not in TREATMENTS:
        raise ParameterError(f"unknown treatment {treatment!r}.", f"Use one of: {', '.join(TREATMENTS)}.")
    if isinstance(seeds, bool) or not isinstance(seeds, (int, np.integer)) or not 1 <= seeds <= MAX_SEEDS:
        raise ParameterError(f"the number of seeds must be a whole number from 1 to {MAX_SEEDS}, got {seeds!r}.",
                             "Use e.g. --seeds 5 (seed i is the base seed + i).")
    if mode not in MODES:
        raise ParameterError(f"unknown comparison mode {mode!r}.", f"Use one of: {', '.join(MODES)}.")
    if timing not in COMPARE_TIMINGS:
        raise ParameterError(f"unknown timing {timing!r}.", f"Use one of: {', '.join(COMPARE_TIMINGS)}.")
    if time_model is not None and time_model not in ("segments", "points", "machine"):
        raise ParameterError(f"unknown time model {time_model!r}.", "Use one of: segments, points, machine.")


def _per_seed(pp, i: int, name: str):
    if isinstance(pp, PlanarPath):
        return pp
    seq = list(pp)
    if i >= len(seq):
        raise ParameterError(f"{name!r} has {len(seq)} planned paths for more seeds.",
                             "Give one PlanarPath per seed, or one for every seed.")
    return seq[i]


def _mean_psd(psds: list[PSD]) -> PSD:
    p0 = psds[0]
    return PSD(p0.freq, np.mean([p.psd for p in psds], axis=0), kind=p0.kind, units=p0.units,
               params={**p0.params, "mean_over_seeds": len(psds)})


def compare_planned(planned: dict[str, Any], *, seed: int = 0, seeds: int = 5, mode: str = "process",
                    timing: str = "machine", machine=None, mechanisms: Mechanisms | None = None,
                    dx_mm: float = DEFAULT_DX_MM, tif: TIF | DirectionalTIF | None = None,
                    noise: ProcessNoise | None = DEFAULT_NOISE, smoothing: Smoothing | None = DEFAULT_SMOOTHING,
                    workpiece: Workpiece | None = None, initial_rms_nm: float = 2.0, initial_exponent: float = 2.5,
                    removal_depth_nm: float = 200.0, band=PAPER_BAND_PER_MM, time_model: str | None = None,
                    dwell: str = "equal", patch_bounds=None, out_dir=None, removal_dx_mm: float | None = None,
                    plan_info: dict | None = None, runner: CaseRunner | None = None,
                    treatment: str = "none") -> dict[str, Any]:
    """The fair comparison of already planned paths over seeds (the Table 4 analogue, docs/simulation.md).

    Every path removes the same mean depth (``removal_depth_nm``, inside the
    evaluation window) from the same start with the same tool; its residual is
    judged by :func:`~polishpath.simulate.fair.fair_metrics` (band RMS, lattice
    peak, PVn) beside the paper's before/after suppression ratio. Seed i is
    ``seed + i``: it plans the random paths (given per seed), draws the initial
    surface and the process noise; a deterministic path is the same for every seed.

    Parameters
    ----------
    planned : dict of name -> PlanarPath or sequence of PlanarPath
        The paths (``uv`` (N, 2) mm, ``pieces``, ``spacing`` the planar grid
        spacing, mm): one for all seeds (deterministic), or one per seed.
    seed : int
        Base seed.
    seeds : int
        Number of seeds (1..100).
    mode : {"process", "interference-free"}
        ``"process"``: a synthetic rough start, process noise and pad smoothing
        (the defaults in docs/simulation.md). ``"interference-free"``: a flat
        start and no noise, so only the path's own marks remain.
    timing : {"machine", "ideal"}
        ``"machine"``: the samples the job's smoothing stage (and, with
        ``machine``, its feed schedule) would run, slow-downs included
        (:func:`~polishpath.simulate.machinetime.machine_timed_path`);
        ``"ideal"``: every dwell point's time spread along the path as asked.
    machine : MachineProfile, str or dict, optional
        A machine profile (or its name / TOML file) whose limits the machine
        timing keeps; a dict is the legacy option set of ``time_model="machine"``.
    mechanisms : Mechanisms, optional
        Which effects are on (:mod:`polishpath.simulate.mechanisms`; default all).
    dx_mm : float
        Simulation pixel pitch, mm (5 um resolves 100 1/mm).
    tif : TIF, DirectionalTIF or RotatingToolTIF, optional
        Default :func:`default_tif`. The dwell time per point follows from
        ``removal_depth_nm`` and each path's planar spacing.
    noise, smoothing :
        Process noise and smoothing of the process mode.
    workpiece : Workpiece, optional
        Initial surface for every seed (process mode); default a synthetic
        power-law surface drawn with each seed.
    initial_rms_nm, initial_exponent : float
        Synthetic initial surface: RMS (nm) and 2D PSD exponent, band 0.2-100 1/mm.
    removal_depth_nm : float
        Mean depth every path removes, nm.
    band : (float, float)
        1/mm.
    time_model : {"segments", "points", "machine"}, optional
        Overrides ``timing`` with a time model of :func:`simulate_removal`.
    dwell : {"equal", "feed"}
        ``"equal"``: every dwell point gets the same time; ``"feed"``: constant
        feed along each path, scaled to the same total time per point.
    patch_bounds : (xmin, ymin, xmax, ymax), optional
        Simulated patch, mm (default: the bounds of all paths).
    out_dir : str or Path, optional
        Where to write the table, JSON and figures (:mod:`polishpath.simulate.comparefiles`).
    removal_dx_mm :
        As :func:`compare_paths`.
    plan_info : dict, optional
        Per-path planning figures to record in ``params["plans"]``.
    runner : CaseRunner, optional
        Where the independent cases (path x seed, each path's machine timing) run: every core by
        default, one process, or a Dask cluster (:mod:`polishpath.simulate.cases`); the same result
        whatever the spread.
    treatment : {"none", "density-fit", "ripple-fit"}
        ``"density-fit"``: every path's dwell points are first moved by
        :func:`~polishpath.simulate.densityfit.fit_time_density` (its time centroids centred, then its
        machine time density flattened as the tool passes it into 0.95-2 1/mm, within 0.3 h of the planned
        points), the same for every path; each row records the fit's figures (``treatment``).
        ``"ripple-fit"``: moved by :func:`~polishpath.simulate.ripplefit.fit_removal_ripple` instead (the
        removal of the machine's samples, as the tool's own kernels compute it, made flat over 0.95-3 1/mm
        in the evaluation window, within the same bounds).

    Returns
    -------
    dict
        ``rows`` (per path: each of ``residual_band_rms_nm``, ``lattice_peak_db``,
        ``pvn``, ``suppression_ratio`` as the mean and ``<key>_min`` / ``<key>_max``
        over the seeds, ``per_seed``, ``random``, ``pattern``,
        ``planar_spacing_mm``, ``lattice_frequencies_per_mm`` (where its lattice peak
        was read: its own planar spacing's, see :func:`~polishpath.simulate.fair.path_frequencies`),
        timing figures), ``rankings`` (per figure, ties
        where ranges overlap), ``params``, ``psds`` (mean over seeds),
        ``residuals`` (first seed's maps), ``table``.
    """
    check_comparison(seeds=seeds, mode=mode, timing=timing, time_model=time_model, treatment=treatment)
    if not planned:
        raise ParameterError("no planned path to compare.", "Give at least one pattern.")
    mech = mechanisms or Mechanisms()
    if not mech.slowdown:
        timing = "ideal"
    legacy_machine = machine if isinstance(machine, dict) else None
    profile = None if isinstance(machine, dict) else machine
    if profile is not None:
        from ..schedule import load_machine

        profile = load_machine(profile)
    first = {name: _per_seed(pp, 0, name) for name, pp in planned.items()}
    if patch_bounds is None:
        allp = np.concatenate([np.asarray(p.uv) for p in first.values()])
        patch_bounds = (*allp.min(axis=0), *allp.max(axis=0))
    xmin, ymin, xmax, ymax = map(float, patch_bounds)
    spacings = {name: float(p.spacing) for name, p in first.items()}
    lattices = {name: _has_lattice(p) for name, p in first.items()}
    h0 = next(iter(spacings.values()))
    base_tif = tif or default_tif()
    t0_point, tif_scaled, tif_scale = _dwell_s_per_point(base_tif, h0, removal_depth_nm)
    tif_used = tool_with(tif_scaled, mech, dx_mm)
    interference_free = mode == "interference-free"
    noise_used = None if (interference_free or not mech.noise) else noise
    smooth_used = None if not mech.smoothing else smoothing
    # the same window whatever mechanism is off: inset by the reach of the tool as given + the spacing (the
    # smooth-edge tool's Gaussian tail beyond it, on one side of a straight edge, is 0.3 % of its volume)
    inset = _reach(tif_scaled) + h0
    eval_bounds = (xmin + inset, ymin + inset, xmax - inset, ymax - inset)
    tm_all = time_model or ("segments" if timing == "ideal" else "moves")
    seed_list = [seed + i for i in range(seeds)]
    # the independent cases (path x seed; each distinct path's machine timing once), run by polishpath.simulate.cases
    specs, wished = [], {}
    fitted, fit_stats = {}, {}
    for i, s_i in enumerate(seed_list):
        for name, pp in planned.items():
            if i > 0 and interference_free and isinstance(pp, PlanarPath):
                continue  # flat start, no noise, the same path: the seed changes nothing (tested), reuse seed 0
            p = _per_seed(pp, i, name)
            xy, pieces = np.asarray(p.uv), np.asarray(p.pieces)
            times = _dwell_times(xy, pieces, t0_point * (float(p.spacing) / h0) ** 2, dwell)
            if treatment != "none":
                if id(p) not in fitted:  # a deterministic path is fitted once
                    from .densityfit import fit_time_density
                    from .ripplefit import fit_removal_ripple

                    if treatment == "density-fit":
                        fitted[id(p)] = fit_time_density(xy, times, pieces, tif_used, spacing_mm=float(p.spacing),
                                                         machine=profile)
                    else:  # the removal where the figures judge it: the evaluation window (a patch of a large
                        # part then costs what the patch costs)
                        fitted[id(p)] = fit_removal_ripple(xy, times, pieces, tif_used, spacing_mm=float(p.spacing),
                                                           machine=profile, bounds=eval_bounds)
                fit = fitted[id(p)]
                xy = fit.xy
                fit_stats.setdefault(name, []).append(fit.stats)
            wished[(i, name)] = float(times.sum())
            specs.append((i, s_i, name, p, xy, pieces, times))
    timed, timing_info = {}, {}
    if tm_all == "moves":
        todo = {}
        for _, _, _, p, xy, pieces, times in specs:
            todo.setdefault(id(p), TimingCase(xy, times, pieces, float(p.spacing), profile))
        timed = dict(zip(todo, run_cases(run_timing, list(todo.values()), runner)))
    opts = dict(band=band, spacing_mm=h0, eval_bounds=eval_bounds, time_model=tm_all, machine=legacy_machine,
                removal_dx_mm=removal_dx_mm, depth_nm=removal_depth_nm, path_spacings_mm=spacings,
                path_lattices=lattices)
    cases = []
    for i, s_i, name, p, xy, pieces, times in specs:
        if tm_all == "moves":
            tp, info = timed[id(p)]
            path = (tp.xy, tp.time_s, tp.pieces, "moves")
            timing_info.setdefault(name, []).append(info)
        else:
            path = (xy, times, pieces, tm_all)
        start = (Start("flat", (xmin, ymin, xmax, ymax), dx_mm) if interference_free
                 else Start("given", workpiece=workpiece) if workpiece is not None
                 else Start("synthetic", (xmin, ymin, xmax, ymax), dx_mm, initial_rms_nm, initial_exponent,
                            (0.2, 100.0), s_i))
        cases.append(Case(name, s_i, path, start, tif_used, noise_used, smooth_used, opts))
    done = {(i, name): r for (i, _, name, *_), r in zip(specs, run_cases(run_case, cases, runner))}
    per_seed, psd_lists, first_rows = [], {}, {}
    for i in range(seeds):
        got, psds = {}, {}
        for name in planned:
            r = done.get((i, name))
            if r is None:  # not run: the first seed's row (and below its PSD) reused
                got[name] = {**first_rows[name], "seconds": 0.0, "reused_seed": seed_list[0]}
                continue
            row = dict(r.row)  # total_time_s: the dwell times asked; the machine's own time beside it
            row["machine_time_s"] = row["total_time_s"] if row["time_model"] == "moves" else None
            row["total_time_s"] = wished[(i, name)]
            got[name] = row
            psds.update({"before": r.psds["before"]} if "before" in r.psds and "before" not in psds else {})
            psds[name] = r.psds[name]
        if i == 0:
            first_rows = got
        else:
            psds = {k: psds.get(k, psd_lists[k][0]) for k in psd_lists}
        per_seed.append([got[name] for name in planned])
        for k, v in psds.items():
            psd_lists.setdefault(k, []).append(v)
    out1 = {"params": done[(0, next(iter(planned)))].params,
            "residuals": {name: done[(0, name)].picture for name in planned}}
    rows = aggregate_rows(per_seed, seed_list)
    for r in rows:
        p0 = first[r["name"]]
        r["pattern"] = r["name"]
        r["random"] = not isinstance(planned[r["name"]], PlanarPath)
        r["planar_spacing_mm"] = spacings[r["name"]]
        r["dwell_s_per_point"] = t0_point * (spacings[r["name"]] / h0) ** 2
        r["n_points"] = int(p0.n_points)
        if r["name"] in fit_stats:
            r["treatment"] = fit_stats[r["name"]][0] if len(fit_stats[r["name"]]) == 1 else fit_stats[r["name"]]
        if r["name"] in timing_info:
            infos = timing_info[r["name"]]
            r["machine_timing"] = infos[0] if len(infos) == 1 or not r["random"] else {
                **infos[0], "time_increase": spread([x["time_increase"] for x in infos])[0]}
    rankings = {k: rank(rows, k) for k in FAIR_KEYS}
    params = dict(out1["params"])
    params.update({"mode": mode, "timing": time_model or timing, "time_model": tm_all, "seeds": seed_list,
                   "seed": seed, "n_seeds": seeds, "machine_profile": None if profile is None else profile.name,
                   "machine": profile.to_dict() if profile is not None else legacy_machine,
                   "mechanisms": mech.to_dict(), "dwell": dwell, "treatment": treatment, "patterns": list(planned), "spacing_mm": h0,
                   "lattice_peak_at": "each path's own frequencies: 1/(2h), n/h (n = 1..3) of its planar spacing h "
                                      "(the comparison simulates in the plane the paths were planned in); a path "
                                      "without a lattice at 1/(2h), 1/h, sqrt(2)/h, 2/h of its nominal spacing",
                   "dwell_s_per_point": t0_point, "removal_depth_nm": removal_depth_nm, "plans": plan_info or {},
                   "tif_rate_scale": tif_scale, "region_bounds_mm": [xmin, ymin, xmax, ymax],
                   "random_patterns": [r["name"] for r in rows if r["random"]],
                   "workpiece": out1["params"]["workpiece"] if workpiece is not None or interference_free
                   else {**out1["params"]["workpiece"], "seeds": seed_list}})
    units = params["units"]
    out = {"rows": rows, "rankings": rankings, "params": params,
           "psds": {k: _mean_psd(v) for k, v in psd_lists.items()}, "residuals": out1["residuals"],
           "table": format_table(rows, units, params=params, rankings=rankings)}
    if out_dir is not None:
        write_outputs(out, out_dir)
    return out


def _has_lattice(p: PlanarPath) -> bool:
    """Whether a planned path has a lattice whose frequencies it prints (``PlanarPath.lattice``: the grid
    patterns', and the spiral's, whose pitch is the grid spacing) or none (a blue-noise set)."""
    return p.lattice is not None


def _dwell_times(xy: np.ndarray, pieces: np.ndarray, t_point: float, dwell: str) -> np.ndarray:
    if dwell == "equal":
        return np.full(len(xy), t_point)
    if dwell == "feed":
        times = np.concatenate([dwell_from_feed(part, 60.0) if len(part) > 1 else np.ones(len(part))
                                for part in split_by_pieces(xy, pieces)])
        return times * (t_point * len(xy) / times.sum())
    raise ParameterError(f"unknown dwell mode {dwell!r}.", "Use 'equal' or 'feed'.")
