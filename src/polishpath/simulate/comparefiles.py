"""What a path comparison writes: the fair table as text, ``results.json`` and its figures.

* ``table.txt``: the fair figures (residual band RMS, lattice peak, PVn) and the
  paper-style suppression ratio, each as mean [min, max] over the seeds,
  beside the paper's Table 4, and the rankings (ties where ranges overlap);
* ``results.json``: every row, the rankings, all parameters and the PSDs;
* ``residuals.png``: the residual maps of all paths side by side (first seed,
  mean / tilt / power removed, one colour scale);
* ``psd.png``: the profile PSDs (mean over seeds) with each path's own lattice
  frequencies marked (those its lattice peak was read at); ``residual_<name>.png``:
  each residual map on its own.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from ..psd.core import PAPER_BAND_PER_MM, PSD
from .spread import FAIR_KEYS

__all__ = ["format_table", "plot_psds", "plot_residuals", "write_outputs"]

#: the paper's Table 4 suppression ratios (measured on glass), shown beside the simulated ones
_PAPER_SUPPRESSION = {"raster": 0.3406, "spiral": 0.4686, "rectangular": 0.5306, "pseudorandom": 0.9664}

_COLUMNS = (("residual_band_rms_nm", "band RMS (nm)", 1.0, "{:.3g}"),
            ("lattice_peak_db", "lattice peak (dB)", 1.0, "{:.3g}"),
            ("pvn", "PVn", 1.0, "{:.3g}"),
            ("suppression_ratio", "paper-style suppr. (%)", 100.0, "{:.3g}"))


def _cell(r: dict[str, Any], key: str, f: float, fmt: str) -> str:
    if r.get(key) is None:
        return "-"
    m, lo, hi = (r[key] * f, r.get(f"{key}_min", r[key]) * f, r.get(f"{key}_max", r[key]) * f)
    if lo == hi:
        return fmt.format(m)
    return f"{fmt.format(m)} [{fmt.format(lo)}, {fmt.format(hi)}]"


def format_table(rows: list[dict[str, Any]], units: str = "nm^2 mm", *, params: dict | None = None,
                 rankings: dict | None = None) -> str:
    """The comparison as text: fair figures and suppression, mean [min, max] over the seeds, and the rankings."""
    p = params or {}
    seeds = p.get("seeds") or [p.get("seed", 0)]
    mode = p.get("mode", "process")
    timing = p.get("timing", p.get("time_model", "?"))
    mach = p.get("machine_profile")
    lines = [f"fair comparison: mode {mode}, timing {timing}{f' ({mach})' if mach else ''}, "
             f"{len(seeds)} seed{'s' if len(seeds) != 1 else ''} ({', '.join(map(str, seeds))}); every path removes "
             f"the same mean depth ({p.get('removal_depth_nm', '?')} nm) from the same start"
             + (f"; mechanisms off: {', '.join(p['mechanisms']['off'])}" if (p.get("mechanisms") or {}).get("off")
                else ""),
             "figures: mean [min, max] over the seeds of the residual (after polishing, mean / tilt / power "
             "removed): band RMS over the band, the largest PSD peak at the path's own lattice frequencies over "
             "the local background (each path at its own, listed below), PVn = PV / depth; the paper-style "
             "suppression (before/after band-average PSD) is a separate column"]
    w = [14] + [max(len(c[1]), 22) + 2 for c in _COLUMNS] + [15]
    head = f"{'path':<{w[0]}}" + "".join(f"{c[1]:>{wi}}" for c, wi in zip(_COLUMNS, w[1:])) + f"{'paper suppr.':>{w[-1]}}"
    lines += [head, "-" * len(head)]
    for r in rows:
        ps = _PAPER_SUPPRESSION.get(r["name"])
        lines.append(f"{r['name']:<{w[0]}}" + "".join(f"{_cell(r, *c[0:1], c[2], c[3]):>{wi}}"
                                                     for c, wi in zip(_COLUMNS, w[1:]))
                     + f"{(f'{100 * ps:.2f} %' if ps is not None else '-'):>{w[-1]}}")
    for r in rows:
        if r.get("lattice_frequencies_per_mm"):
            fs = ", ".join(f"{f:.3g}" for f in r["lattice_frequencies_per_mm"])
            basis = r.get("lattice_basis", "lattice")
            lines.append(f"lattice peak of {r['name']} read at {fs} 1/mm "
                         + (f"(its lattice, planar spacing h = {r['lattice_spacing_mm']:.4g} mm)" if basis == "lattice"
                            else f"({basis}, h = {r['lattice_spacing_mm']:.4g} mm)"))
    td = [r for r in rows if r.get("time_density_peak_db") is not None]
    if td:
        lines.append("time-density peak (the machine samples' time density in the evaluation window, at 1/(2h), 1/h, "
                     "sqrt(2)/h, 2/h of each path's spacing, dB; mean over the seeds): "
                     + ", ".join(f"{r['name']} {r['time_density_peak_db']:.3g}" for r in td))
    if mode == "interference-free":
        lines.append("paper-style suppression: undefined in interference-free mode (flat start: nothing to suppress)")
    else:
        lines.append(f"paper-style suppression: 1 - after/before of the band-average profile PSD ({units}); it mixes "
                     "the start's roughness the pad smooths, the process noise and the path's own marks")
    for k, rk in (rankings or {}).items():
        own = " (each path at its own lattice frequencies)" if k == "lattice_peak_db" else ""
        lines.append(f"ranking by {k}{own} (best first; [a ~ b]: ranges overlap, not distinguishable): {rk['text']}")
    return "\n".join(lines) + "\n"


def write_outputs(out: dict[str, Any], out_dir) -> None:
    """Write ``table.txt``, ``results.json``, ``psd.png``, ``residuals.png`` and ``residual_<name>.png``."""
    d = Path(out_dir)
    d.mkdir(parents=True, exist_ok=True)
    (d / "table.txt").write_text(out["table"])
    js = {"rows": _without_clocks(out["rows"]), "rankings": out.get("rankings", {}),
          "params": _without_clocks(out["params"]),
          "psds": {k: {"freq_per_mm": v.freq.tolist(), "psd": v.psd.tolist(), "units": v.units}
                   for k, v in out["psds"].items()}}
    (d / "results.json").write_text(json.dumps(js, indent=1, default=_json_default))
    prm = out["params"]
    plot_psds(out["psds"], d / "psd.png", band=tuple(prm["band_per_mm"]),
              spacings={r["name"]: r.get("planar_spacing_mm") or prm.get("spacing_mm") for r in out["rows"]},
              frequencies={r["name"]: r["lattice_frequencies_per_mm"] for r in out["rows"]
                           if r.get("lattice_frequencies_per_mm")},
              title="Simulated profile PSD of the residual (mean over seeds), each path's lattice frequencies marked")
    res = out.get("residuals") or {}
    if res:
        plot_residuals(res, d / "residuals.png")
        for name, item in res.items():
            plot_residuals({name: item}, d / f"residual_{name}.png")


def _without_clocks(o):
    """``o`` without its wall-clock readings (keys ``seconds`` / ``*_seconds``): results.json is then the same
    bytes however the cases were spread over processes or a cluster (the clocks stay in the returned dict)."""
    if isinstance(o, dict):
        return {k: _without_clocks(v) for k, v in o.items()
                if not (isinstance(k, str) and (k == "seconds" or k.endswith("_seconds")))}
    if isinstance(o, list):
        return [_without_clocks(v) for v in o]
    return o


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)


def plot_psds(psds: dict[str, PSD], file, *, band=PAPER_BAND_PER_MM, title: str = "Simulated profile PSD",
              spacings: dict[str, float | None] | None = None,
              frequencies: dict[str, Any] | None = None) -> Path:
    """Log-log PSD plot, one curve per path, the band shaded, units on the axes.

    Parameters
    ----------
    psds : dict of name -> PSD
    file : str or Path
        PNG to write.
    band : (float, float)
        1/mm, shaded.
    spacings : dict of name -> spacing (mm), optional
        Mark each path's lattice frequencies (1/spacing and harmonics, 1/(2 spacing))
        on its curve.
    frequencies : dict of name -> (K,) 1/mm, optional
        Mark these frequencies on a path's curve instead (a comparison's
        ``lattice_frequencies_per_mm``: where its lattice peak was read).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for name, p in psds.items():
        (line,) = ax.loglog(p.freq, p.psd, lw=1.0 if name != "before" else 1.6,
                            color="k" if name == "before" else None, ls="--" if name == "before" else "-", label=name)
        h = (spacings or {}).get(name)
        f = (frequencies or {}).get(name)
        if f is None and h:
            from .fair import lattice_frequencies

            f = lattice_frequencies(h)
        if f is not None:
            f = np.asarray(f, dtype=np.float64)
            f = f[(f >= p.freq[1]) & (f <= p.freq[-1])] if len(p.freq) > 1 else f[:0]
            ax.plot(f, np.interp(f, p.freq, p.psd), ls="none", marker="v", ms=5, color=line.get_color())
    ax.axvspan(band[0], band[1], color="0.9", zorder=0, label=f"band {band[0]:g}-{band[1]:g} 1/mm")
    if spacings or frequencies:
        ax.plot([], [], ls="none", marker="v", color="0.3", label="each path's lattice frequencies")
    units = next(iter(psds.values())).units
    ax.set_xlabel("spatial frequency f (1/mm)")
    ax.set_ylabel(f"PSD ({units})")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(file, dpi=110)
    plt.close(fig)
    return Path(file)


def plot_residuals(residuals: dict[str, dict[str, Any]], file) -> Path:
    """Residual maps side by side on one colour scale (±3 RMS of all of them).

    ``residuals[name]`` holds ``map_nm`` (2D, nm), ``extent_mm`` ([x0, x1, y0, y1])
    and ``seed``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(residuals)
    n = len(names)
    allz = np.concatenate([np.ravel(residuals[k]["map_nm"]) for k in names])
    lim = 3 * float(allz.std()) if allz.std() > 0 else 1.0
    fig, axes = plt.subplots(1, n, figsize=(3.2 * n + 1.0, 3.4), squeeze=False)
    im = None
    for ax, name in zip(axes[0], names):
        it = residuals[name]
        im = ax.imshow(it["map_nm"], origin="lower", extent=it["extent_mm"], cmap="RdBu_r", vmin=-lim, vmax=lim)
        ax.set_title(f"{name} (seed {it.get('seed')})", fontsize=9)
        ax.set_xlabel("x (mm)")
        ax.set_aspect("equal")
    axes[0][0].set_ylabel("y (mm)")
    fig.colorbar(im, ax=list(axes[0]), label="residual (nm), mean/tilt/power removed", shrink=0.85)
    fig.savefig(file, dpi=100)
    plt.close(fig)
    return Path(file)


def fair_columns(row: dict[str, Any]) -> dict[str, Any]:
    """The JSON keys of one row's fair figures (``<key>``, ``<key>_min``, ``<key>_max`` of :data:`FAIR_KEYS`)."""
    return {k2: row.get(k2) for k in FAIR_KEYS for k2 in (k, f"{k}_min", f"{k}_max")}
