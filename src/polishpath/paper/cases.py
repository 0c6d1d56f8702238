"""Figs. 5-7 (the bicycle seat: plane, path, NURBS) and Fig. 10 (the path on the paper's cases, the rabbit included).

The rabbit is a geodesic disc cut from the shared Stanford bunny scan
(``polishpath.surfaces.cut.geodesic_disc``); it is skipped, with a note in the
document, when the shared meshes folder is not given.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..errors import PolishPathError
from ..report.html import Document
from .common import load, nurbs_deviation, spacing_for
from .figures import FigureSet, draw_path2d, draw_path3d, draw_surface, limits3d
from .settings import MESHES_ENV, Settings

__all__ = ["bunny_patch", "figures_cases"]


def bunny_patch(path: Path, radius_mm: float):
    """A disc-like patch of the Stanford bunny's back, checked as a :class:`Surface`.

    The scan (metres) is scaled to mm and turned so that its up axis (y)
    becomes z; the patch is the geodesic disc
    (:func:`polishpath.surfaces.cut.geodesic_disc`) around the vertex highest
    on the back (largest height among x > 10 mm).

    Parameters
    ----------
    path : Path
        ``stanford-bunny.obj``.
    radius_mm : float
        Geodesic radius of the patch, mm.

    Returns
    -------
    (Surface, dict)
        The patch and what was done (seed point, faces kept, boundary loops).

    Raises
    ------
    InputError
        When the patch is not a disc (more or fewer than one boundary loop).
    """
    from ..surfaces.cut import geodesic_disc
    from ..surfaces.io import read_mesh_file

    v, f = read_mesh_file(path)
    v = np.asarray(v, dtype=np.float64)[:, [0, 2, 1]] * np.array([1000.0, -1000.0, 1000.0])  # m -> mm, scan's y up -> z up
    f = np.asarray(f, dtype=np.int64)
    sel = np.flatnonzero(v[:, 0] > 10.0)
    seed_v = int(sel[np.argmax(v[sel, 2])])
    surf = geodesic_disc(v, f, seed_v, radius_mm, name="bunny-back", source=str(path))
    info = {"seed_point_mm": [float(x) for x in v[seed_v]], "radius_mm": radius_mm, "faces": int(surf.n_faces),
            "faces_in_scan": int(len(f)), "boundary_loops": 1}
    return surf, info


def _run_case(surface, spacing: float, seed: int):
    """The job's stages on an in-memory surface: flatten (MABF), plan, map, NURBS through the dwell points.

    The machine's constant-period interpolation (``polishpath.smooth.smooth``) is left out: the figures
    need only the curve, and it is the slow part of smoothing.
    """
    from ..flatten import boundary_region, flatten
    from ..pipeline import plan_on_surface

    flat = flatten(surface, "mabf")
    region = boundary_region(flat)
    hon = plan_on_surface(flat, region, spacing, seed=seed)
    planar, sp, h = hon.planar, hon.surface_path, hon.planar_spacing
    dev = nurbs_deviation(sp.xyz, planar.pieces)
    return {"surface": surface, "flat": flat, "region": region, "planar": planar, "sp": sp, "nurbs_dev": dev, "h": h}


def figures_cases(doc: Document, figs: FigureSet, st: Settings, res: dict, seed: int) -> None:
    """Write Figs. 5-7 and 10 and their table into ``doc``; the rows go to ``res["seat"]``, ``res["fig10"]``."""
    from ..smooth import evaluate, interpolate_nurbs

    info = []
    # Figs. 5-7: the bicycle seat
    doc.h(2, "Figs. 5-7 — the bicycle seat")
    seat = load(f"bicycle-seat:triangles={st.fig_triangles}")
    sp_seat = spacing_for(seat, st.fig_points)
    t = time.perf_counter()
    job = _run_case(seat, sp_seat, seed)
    secs = time.perf_counter() - t
    planar, spath = job["planar"], job["sp"]
    info.append(["bicycle seat (Figs. 5-7)", f"{seat.n_faces:,}", f"{sp_seat:g}", f"{planar.n_points:,}",
                 len(planar.pieces) - 1, f"{spath.stats['step_max'] / sp_seat:.2f}", f"{secs:.1f}"])
    fig = figs.new(11, 4.6)
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    draw_surface(ax, seat, alpha=0.9, color="0.7")
    limits3d(ax, seat.vertices)
    ax.set_title("a  the bicycle seat model", fontsize=8)
    ax = fig.add_subplot(1, 2, 2)
    draw_path2d(ax, np.asarray(planar.uv), planar.pieces, job["region"],
                 f"b  pseudo-random path in the MABF plane ({planar.n_points:,} points)")
    rel = figs.save(fig, "fig05_seat_plane")
    doc.fig(rel, "Fig. 5: (a) the bicycle seat, (b) the pseudo-random path planned in its MABF flattening.")
    fig = figs.new(8, 5.6)
    ax = fig.add_subplot(projection="3d")
    draw_path3d(ax, seat, spath.xyz, planar.pieces, f"Pseudo-random path on the seat, spacing {sp_seat:g} mm on the part")
    rel = figs.save(fig, "fig06_seat_path")
    doc.fig(rel, "Fig. 6: the path mapped onto the seat (area coordinates), coloured by path order.")
    p0, p1 = int(planar.pieces[0]), int(planar.pieces[1])
    curve, u = interpolate_nurbs(spath.xyz[p0:p1])
    k = min(80, len(u) - 1)
    cpts = evaluate(curve, np.linspace(u[0], u[k], 40 * k))
    pts = spath.xyz[p0:p0 + k + 1]
    fig = figs.new(8, 5.6)
    ax = fig.add_subplot(projection="3d")
    ax.plot(cpts[:, 0], cpts[:, 1], cpts[:, 2], color="tab:blue", lw=1.0, label="cubic NURBS")
    ax.plot(pts[:, 0], pts[:, 1], pts[:, 2], "o", color="tab:red", ms=2.5, label="dwell points")
    limits3d(ax, np.vstack([cpts, pts]))
    dev = job["nurbs_dev"]
    ax.set_title(f"NURBS through the first {k + 1} dwell points", fontsize=8)
    ax.legend(fontsize=7)
    rel = figs.save(fig, "fig07_seat_nurbs")
    doc.fig(rel, f"Fig. 7: the smoothed path (blue, cubic NURBS interpolation, paper Eq. 10-13) through the dwell "
                 f"points (red) on the seat (first {k + 1} points shown); it passes through every dwell point "
                 f"(max distance {dev:.1e} mm over all {planar.n_points:,}).")
    doc.p("The paper densifies the NURBS parameter for the machine with the Adams-Bashforth and Adams-Moulton "
          "methods at an equal period; polishpath has that integrator (`--integrator ab-am`: order-4 predictor "
          "and corrector in arc length, Runge-Kutta start) beside its default, a Taylor predictor with an exact "
          "chord corrector, which holds the commanded feed to 1e-6 where the Adams one reaches 1e-3 RMS on a "
          "pseudo-random path at the same speed and dwell-time error (docs/machine-output.md, the measured table).")
    res["seat"] = {"triangles": int(seat.n_faces), "spacing_mm": sp_seat, "dwell_points": int(planar.n_points),
                   "nurbs_dev_mm": dev, "seconds": secs}

    # Fig. 10
    doc.h(2, "Fig. 10 — the path on the paper's cases")
    cases = [("a  sinusoidal", f"sinusoidal:triangles={st.fig_triangles}"),
             ("b  pentagram", f"pentagram:triangles={st.fig_triangles}"),
             ("c  concave-convex", f"concave-convex:triangles={st.fig_triangles}"),
             ("d  bicubic B-spline", f"bspline:triangles={st.fig_triangles}"),
             ("e  airfoil", f"airfoil:triangles={st.fig_triangles}")]
    surfaces = [(ttl, load(spec)) for ttl, spec in cases]
    bunny = None if st.meshes is None else Path(st.meshes) / "stanford-bunny.obj"
    bunny_note = None
    if bunny is not None and bunny.exists():
        try:
            bs, binfo = bunny_patch(bunny, st.bunny_radius)
            surfaces.append(("f  rabbit (Stanford bunny, back patch)", bs))
            bunny_note = (f"The rabbit (f) is a patch of `stanford-bunny.obj` (the scan has 5 holes in its base, so it "
                          f"is not a disc): scaled from m to mm, the faces whose three vertices lie within a geodesic "
                          f"radius of {binfo['radius_mm']:g} mm (Dijkstra on the edge graph) of the highest point on "
                          f"the back (x > 10 mm; rotated so the scan's up axis is z; seed {', '.join(f'{c:.1f}' for c in binfo['seed_point_mm'])} mm), "
                          f"largest component kept and checked with `polishpath.surfaces.from_arrays`: "
                          f"{binfo['faces']:,} of {binfo['faces_in_scan']:,} faces, one boundary loop.")
            res["bunny"] = binfo
        except PolishPathError as exc:
            bunny_note = f"The rabbit (f) was skipped: {exc}"
    elif bunny is None:
        bunny_note = (f"The rabbit (f) was skipped: no shared meshes folder was given (`polishpath paper --meshes DIR` "
                      f"or ${MESHES_ENV}).")
    else:
        bunny_note = f"The rabbit (f) was skipped: {bunny} is not in the shared meshes folder."
    fig = figs.new(13, 8.2)
    for i, (ttl, s) in enumerate(surfaces):
        spc = spacing_for(s, st.fig_points)
        t = time.perf_counter()
        r = _run_case(s, spc, seed)
        secs = time.perf_counter() - t
        ax = fig.add_subplot(2, 3, 1 + i, projection="3d")
        draw_path3d(ax, s, r["sp"].xyz, r["planar"].pieces, f"{ttl}\n{r['planar'].n_points:,} points, s = {spc:g} mm")
        dev = r["nurbs_dev"]
        info.append([ttl[3:], f"{s.n_faces:,}", f"{spc:g}", f"{r['planar'].n_points:,}", len(r["planar"].pieces) - 1,
                     f"{r['sp'].stats['step_max'] / spc:.2f}", f"{secs:.1f}"])
        res.setdefault("fig10", []).append({"case": ttl[3:], "triangles": int(s.n_faces), "spacing_mm": spc,
                                           "dwell_points": int(r["planar"].n_points),
                                           "pieces": int(len(r["planar"].pieces) - 1),
                                           "step_max_over_s": float(r["sp"].stats["step_max"] / spc),
                                           "nurbs_dev_mm": dev,
                                           "flipped": int(r["flat"].metrics["flipped_faces"]), "seconds": secs})
    fig.subplots_adjust(left=0.02, right=0.98, top=0.93, bottom=0.04, wspace=0.1, hspace=0.2)
    rel = figs.save(fig, "fig10_cases")
    doc.fig(rel, "Fig. 10: the pseudo-random dwell-point path (MABF flattening, spacing honoured on the part; the "
                 "cubic NURBS through it passes every dwell point, see the table) on (a) sinusoidal, (b) pentagram, (c) concave-convex, (d) bicubic B-spline, (e) airfoil, "
                 "(f) rabbit surfaces; coloured by path order.")
    if bunny_note:
        doc.p(bunny_note)
    for row, r in zip(info[1:], res.get("fig10", [])):
        row.append(f"{r['nurbs_dev_mm']:.1e}")
    info[0].append(f"{res['seat']['nurbs_dev_mm']:.1e}")
    doc.table(["case", "triangles", "spacing s mm", "dwell points", "pieces", "max step / s", "seconds",
               "NURBS max dist. to dwell points mm"], info,
              "Spacing chosen per case for about the same number of dwell points, so the figures stay readable; "
              "max step on the part / s (≤ √2 = 1.41 by construction).")
