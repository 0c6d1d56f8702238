"""The report's figuring section: what the dwell times were solved for and what they leave.

Drawn from a run folder's ``summary.json`` (``figuring``) and ``run.npz``
(``figuring_*`` arrays): measured error, target removal, dwell-time map on
the part, predicted removal of the machine-timed path, predicted residual
(each with RMS and PV over the clear aperture) and the radial PSD of the
error before and of the residual after. The PNG goes to
``figures/figuring.png`` and is embedded in the page.
"""

from __future__ import annotations

import html
import io
from pathlib import Path

import numpy as np

from .rundata import RunData


def _rms_pv(v: np.ndarray) -> tuple[float, float]:
    v = v[np.isfinite(v)]
    if v.size == 0:
        return float("nan"), float("nan")
    return float(np.sqrt(np.mean((v - v.mean()) ** 2))), float(v.max() - v.min())


def _psd(grid_map: np.ndarray, mask: np.ndarray, pitch: float):
    from ..psd import radial_psd

    z = np.where(mask, grid_map, np.nan)
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    z = z[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1]
    z = np.where(np.isfinite(z), z - np.nanmean(z), 0.0)  # outside the aperture: zero (after the mean)
    return radial_psd(z, pitch, window="hann", detrend="none")


def figuring_png(run: RunData) -> bytes | None:
    """The six-panel figuring figure as PNG bytes (None when the run has no figuring)."""
    err = run.get("figuring_error_nm")
    if err is None:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    inside = run.get("figuring_inside").astype(bool)
    valid = inside & np.isfinite(err)
    x0, y0, h = run.get("figuring_grid")
    ny, nx = err.shape
    ext = (x0 - h / 2, x0 + (nx - 0.5) * h, y0 - h / 2, y0 + (ny - 0.5) * h)
    target = run.get("figuring_target_nm")
    removal = run.get("figuring_removal_nm")
    residual = run.get("figuring_residual_nm")
    xyz = run.get("xyz")
    times = run.get("figuring_times_s")
    fig, axes = plt.subplots(2, 3, figsize=(14, 8.6))
    panels = [("measured error", err), ("target removal", target), (None, None),
              ("predicted removal (machine-timed)", removal), ("predicted residual", residual)]
    for ax, (name, m) in zip(axes.ravel(), panels):
        if name is None:
            sc = ax.scatter(xyz[:, 0], xyz[:, 1], c=times, s=3, cmap="magma", vmax=float(np.percentile(times, 99)))
            ax.set_title(f"dwell time per point, total {times.sum() / 60:.1f} min")
            ax.set_aspect("equal")
            fig.colorbar(sc, ax=ax, label="s")
            continue
        shown = np.where(valid, m, np.nan)
        rms, pv = _rms_pv(shown)
        im = ax.imshow(shown, origin="lower", extent=ext, cmap="RdBu_r" if "residual" in name or "error" in name else "viridis")
        ax.set_title(f"{name}\nRMS {rms:.3g} nm, PV {pv:.3g} nm")
        fig.colorbar(im, ax=ax, label="nm")
    ax = axes.ravel()[5]
    try:
        before = _psd(err, valid, h)
        after = _psd(residual, valid, h)
        ax.loglog(before.freq, before.psd, label="error (before)")
        ax.loglog(after.freq, after.psd, label="predicted residual (after)")
        cut = run.section("figuring").get("passband_cutoff_per_mm")
        if cut:
            ax.axvline(cut, color="k", ls=":", label=f"TIF / spacing passband {cut:.3g} 1/mm")
        ax.set_xlabel("spatial frequency, 1/mm")
        ax.set_ylabel(f"PSD, {before.units}")
        ax.legend(fontsize=8)
        ax.set_title("radial PSD over the clear aperture")
    except Exception as exc:  # noqa: BLE001 - a PSD that cannot be drawn must not lose the maps
        ax.text(0.5, 0.5, f"PSD not drawn: {exc}", ha="center", transform=ax.transAxes)
    for a in axes.ravel()[:5]:
        a.set_xlabel("x, mm")
        a.set_ylabel("y, mm")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    plt.close(fig)
    return buf.getvalue()


def figuring_section(run: RunData, png_uri) -> str:
    """HTML of the figuring section ('' when the run has no figuring).

    ``png_uri`` turns PNG bytes into an ``<img>`` source (the page embeds every image).
    """
    fg = run.section("figuring")
    if not fg:
        return ""
    png = figuring_png(run)
    if png is not None:
        out = Path(run.folder) / "figures"
        out.mkdir(parents=True, exist_ok=True)
        (out / "figuring.png").write_bytes(png)
    rows = [("error map", fg.get("error_map")), ("solver", f"{fg.get('solver')} ({fg.get('solver_detail')})"),
            ("converged", fg.get("solver_converged")), ("initial RMS / PV, nm", f"{fg['initial_rms_nm']:.4g} / {fg['initial_pv_nm']:.4g}"),
            ("predicted residual RMS / PV, nm (machine-timed)", f"{fg['residual_rms_nm']:.4g} / {fg['residual_pv_nm']:.4g}"),
            ("solver's model residual RMS, nm (each time at its region's centroid)",
             f"{fg['ideal_residual_rms_nm']:.4g}"),
            ("delivered time error RMS / max (machine vs solved, per point)",
             f"{fg['delivered_time_error_rms']:.2%} / {fg['delivered_time_error_max']:.2%}"
             if fg.get("delivered_time_error_rms") is not None else "n/a"),
            ("solver message", fg.get("solver_message")),
            ("above the passband (uncorrectable) RMS, nm", f"{fg['uncorrectable_rms_nm']:.4g}"),
            ("total dwell time, min", f"{fg['total_time_s'] / 60:.4g}"),
            ("minimum-removal floor, nm (the minimum times alone, mean)",
             f"{fg['floor_nm']:.4g}" if fg.get("floor_nm") is not None else "n/a"),
            ("uniform bias, nm", f"{fg['bias_nm']:.4g} ({fg['bias_mode']})"),
            ("points at their minimum time", f"{100 * (fg.get('points_at_minimum_share') or 0):.1f} %"),
            ("uncovered share of the aperture", f"{100 * fg['uncovered_fraction']:.2f} %")]
    table = "<table class=\"kv\">" + "".join(f"<tr><th>{html.escape(str(k))}</th><td>{html.escape(str(v))}</td></tr>"
                                            for k, v in rows) + "</table>"
    note = f'<p class="note warn">{html.escape(fg["uncorrectable_note"])}</p>' if fg.get("uncorrectable_note") else ""
    lead = ""
    if fg.get("verdict"):  # initial -> predicted and the floor, first (runs before issue 28 lack it)
        lead = f'<p class="lead"><b>{html.escape(fg["verdict"])}</b></p>'
        lead += "".join(f'<p class="note warn">Refused, written with --force: {html.escape(m)}</p>'
                        for m in fg.get("refusals") or [])
    img = f'<figure><img src="{png_uri(png)}" alt="figuring maps" style="max-width:100%"></figure>' if png else ""
    return ('<section id="figuring"><h2>Figuring: dwell times from the measured error</h2>'
            + lead + '<p class="note">The dwell times in path.csv and the machine files were solved from the error map and '
            "the TIF (docs/figuring.md). Removal and residual are those of the machine-timed path (the samples "
            "at the interpolation period), over the clear aperture.</p>" + note + table + img + "</section>")
