"""Table 1 and Figs. 2-3: ABF vs MABF (and LSCM), time and angle error; constraint residuals; the flattened hemisphere.

Times are the flattening's angles + layout (LSCM: the igl.lscm call), mesh
checks and metrics excluded, in s; angle errors in degrees.
"""

from __future__ import annotations

import time

import numpy as np

from ..errors import PolishPathError
from ..report.html import Document
from .common import fmt, load
from .figures import FigureSet, draw_surface, limits3d
from .reference import PAPER
from .settings import Settings

__all__ = ["table1"]


def _face_angle_error_deg(flat) -> np.ndarray:
    """(F,) mean over the 3 corners of |planar - 3D| corner angle, degrees."""
    from .. import meshops

    a3 = meshops.corner_angles(flat.surface.vertices, flat.surface.faces)
    a2 = meshops.corner_angles(flat.uv, flat.surface.faces)
    return np.degrees(np.abs(a2 - a3)).mean(axis=1)


def _time_flatten(surface, method: str):
    """(Flattening, core seconds: angles + layout + solve, wall seconds)."""
    from ..flatten import flatten

    t = time.perf_counter()
    flat = flatten(surface, method, check=False)
    wall = time.perf_counter() - t
    core = sum(v for k, v in flat.timings.items() if k in ("angles", "layout", "solve"))
    return flat, core, wall


def table1(doc: Document, figs: FigureSet, st: Settings, res: dict) -> None:
    """Write Table 1 and Figs. 2-3 into ``doc``; the measured rows go to ``res["table1"]``."""
    from ..flatten import flatten

    doc.h(2, "Table 1 — ABF vs MABF (and LSCM): time and angle error")
    t = time.perf_counter()
    flatten(load("hemisphere:R=30,triangles=300"), "mabf", check=False)  # numba compile / cache load
    warm = time.perf_counter() - t
    rows, data, keep = [], [], {}
    for name, spec, do_abf in st.table1:
        s = load(spec)
        fm, tm, _ = _time_flatten(s, "mabf")
        fa, ta = (None, float("nan"))
        if do_abf:
            fa, ta, _ = _time_flatten(s, "abf")
        try:
            fl, tl, _ = _time_flatten(s, "lscm")
            el = fl.metrics["angle_error_mean_deg"]
        except (ImportError, PolishPathError):
            tl, el = float("nan"), float("nan")
        ea = fa.metrics["angle_error_mean_deg"] if fa is not None else float("nan")
        ptri, pm, pa = PAPER["table1"][name]
        row = {"case": name, "triangles": s.n_faces, "paper_triangles": ptri, "mabf_s": tm, "abf_s": ta, "lscm_s": tl,
               "abf_over_mabf": ta / tm, "mabf_over_lscm": tm / tl, "err_mabf_deg": fm.metrics["angle_error_mean_deg"],
               "err_abf_deg": ea, "err_lscm_deg": el, "flips_mabf": int(fm.metrics["flipped_faces"]),
               "paper_mabf_s": pm, "paper_abf_s": pa, "paper_abf_over_mabf": pa / pm}
        data.append(row)
        rows.append([name, f"{s.n_faces:,} ({ptri:,})", fmt(tm), fmt(ta), fmt(tl), fmt(ta / tm, 1),
                     fmt(tm / tl, 2), fmt(row["err_mabf_deg"], 4), fmt(ea, 4), fmt(el, 4),
                     f"{pm:.2f}", f"{pa:.2f}", f"{pa / pm:.1f}"])
        if name == "hemisphere":
            keep = {"surface": s, "mabf": fm, "abf": fa}
    doc.table(["case", "triangles (paper)", "MABF s", "ABF s", "LSCM s", "ABF/MABF", "MABF/LSCM",
               "angle err MABF °", "ABF °", "LSCM °", "paper MABF s", "paper ABF s", "paper ABF/MABF"], rows,
              f"Ours: Python, this machine (see the footer); the paper: MATLAB R2021a. Times are angles + layout "
              f"(LSCM: the igl.lscm call), mesh checks and metrics excluded; ratios are measured in the same run. "
              f"Numba compile / cache load before timing: {warm:.2f} s. Angle error: mean |planar - 3D| corner "
              f"angle. '–': not run{' (quick setting: ABF only on the smallest case)' if st.quick else ''} or LSCM "
              f"(libigl, optional extra) not installed.")
    doc.p("The absolute times are not comparable (MATLAB on the authors' PC against our Python/numba with a "
          "sparse Cholesky on a shared 2-core machine); the ratios are. The paper's ABF/MABF ratio is 15-63x; "
          f"ours is measured in the same run. Both solve the same angle constraints to "
          f"{keep['mabf'].provenance.params['tol'] if keep else 1e-8:g} (largest residual); ABF's Newton "
          "iteration optimises to the end, our MABF stops optimising once no angle would move by more than "
          f"{keep['mabf'].provenance.params.get('opt_tol', 1e-4) if keep else 1e-4:g} rad and then only restores "
          "the constraints. Their angle errors agree to the digits shown: MABF is faster, not more accurate, on "
          "these well-shaped meshes. "
          "Our built-in meshes match the paper's triangle counts to 1 % (the mesher meets the count within 1 %).")
    res["table1"] = data

    if not keep or keep.get("abf") is None:
        return
    s, fm, fa = keep["surface"], keep["mabf"], keep["abf"]
    # Fig. 2: constraint residuals
    fig = figs.new(11, 5.6)
    axes = fig.subplots(2, 3)
    labels = {"triangle": ("triangle angle sum − π", "triangle", "rad"),
              "vertex": ("angle sum around interior vertices − 2π", "interior vertex", "rad"),
              "wheel": ("wheel (sine) condition", "interior vertex", "log-sine")}
    for r, (meth, fl) in enumerate((("ABF", fa), ("MABF", fm))):
        for c, key in enumerate(("triangle", "vertex", "wheel")):
            ax = axes[r, c]
            v = np.asarray(fl.residuals.get(key, np.zeros(0)))
            ax.plot(np.arange(len(v)), v, ".", ms=1.5)
            ax.set_title(f"{'abcdef'[3 * r + c]}  {meth}: {labels[key][0]}\nmax |r| = {np.abs(v).max() if len(v) else 0:.2e}",
                         fontsize=8)
            ax.set_xlabel(labels[key][1], fontsize=7)
            ax.set_ylabel(f"residual ({labels[key][2]})", fontsize=7)
            ax.ticklabel_format(axis="y", style="sci", scilimits=(-2, 2))
            ax.tick_params(labelsize=6)
    fig.subplots_adjust(hspace=0.55, wspace=0.35, bottom=0.1)
    rel = figs.save(fig, "fig02_residuals")
    doc.h(3, "Fig. 2 — constraint residuals, hemisphere")
    doc.fig(rel, f"Fig. 2: residuals of the three angle constraints after ABF (top) and MABF (bottom) on the "
                 f"hemisphere ({s.n_faces:,} triangles). The paper plots (a, c) the triangle sums and (b, d) the "
                 f"vertex sums; we add the wheel condition.")
    # Fig. 3: flattened hemisphere and angle errors
    fig = figs.new(13, 5.2)
    ax = fig.add_subplot(1, 5, 1, projection="3d")
    draw_surface(ax, s, alpha=0.9, color="0.7")
    limits3d(ax, s.vertices)
    ax.set_title("a  hemisphere", fontsize=8)
    errs = {"ABF": _face_angle_error_deg(fa), "MABF": _face_angle_error_deg(fm)}
    vmax = max(float(np.quantile(e, 0.99)) for e in errs.values())
    for k, (meth, fl) in enumerate((("ABF", fa), ("MABF", fm))):
        ax = fig.add_subplot(1, 5, 2 + k)
        ax.triplot(fl.uv[:, 0], fl.uv[:, 1], fl.surface.faces, lw=0.2, color="k")
        ax.set_aspect("equal")
        ax.set_title(f"{'bc'[k]}  {meth} flattening\nflipped {int(fl.metrics['flipped_faces'])}", fontsize=8)
        ax.tick_params(labelsize=6)
    for k, (meth, fl) in enumerate((("ABF", fa), ("MABF", fm))):
        ax = fig.add_subplot(1, 5, 4 + k)
        tc = ax.tripcolor(fl.uv[:, 0], fl.uv[:, 1], fl.surface.faces, facecolors=errs[meth], cmap="magma",
                          vmin=0, vmax=vmax)
        ax.set_aspect("equal")
        ax.set_title(f"{'de'[k]}  {meth} angle error (°)\nmean {fl.metrics['angle_error_mean_deg']:.3f}, "
                     f"max {fl.metrics['angle_error_max_deg']:.2f}", fontsize=8)
        ax.tick_params(labelsize=6)
        fig.colorbar(tc, ax=ax, shrink=0.6, orientation="horizontal", pad=0.12)
    fig.subplots_adjust(left=0.02, right=0.99, wspace=0.3, bottom=0.12)
    rel = figs.save(fig, "fig03_flattening")
    doc.h(3, "Fig. 3 — the flattened hemisphere, ABF and MABF")
    doc.fig(rel, f"Fig. 3: (a) the hemisphere, (b, c) its ABF and MABF flattenings (midpoint layout), (d, e) the "
                 f"per-triangle angle error (mean over the 3 corners of |planar - 3D| angle). Mean angle error: "
                 f"ABF {fa.metrics['angle_error_mean_deg']:.4f}°, MABF {fm.metrics['angle_error_mean_deg']:.4f}°.")

