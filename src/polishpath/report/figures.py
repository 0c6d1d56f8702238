"""The report's static figures, drawn with matplotlib (PNG, for papers and slides).

Each ``fig_*`` function takes a :class:`~polishpath.report.rundata.RunData` and
returns a matplotlib :class:`~matplotlib.figure.Figure`, or a string saying why
it cannot be drawn (a missing array). No pyplot state is used, so the functions
are safe to call from any thread and under any backend.

Every figure draws at most a fixed amount, whatever the size of the run: the
path figures an evenly spaced subset of the dwell points
(:data:`MAX_PATH_POINTS_PNG`, :data:`MAX_PATH_POINTS_PNG_3D`), the mesh figures
a coarsened mesh, the feed a min/max/mean envelope of :data:`FEED_BINS` bins,
the histograms their bins. A figure that drew less than the run holds says so
in its ``display_note`` (:func:`display_note`), which the report prints under it.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..pathops import DIRECTION_NAMES, direction_counts, piece_index, step_lengths, turn_angles_deg
from .digest import FEED_BINS, run_digest  # noqa: F401  (FEED_BINS: the display limits, as before)
from .rundata import RunData, angle_error_deg, area_distortion, cluster_mesh, decimate_indices

#: display limits (the files keep every point)
MAX_PATH_POINTS_PNG = 20_000
MAX_PATH_POINTS_PNG_3D = 20_000
MAX_FACES_PNG_3D = 6_000
MAX_FACES_PNG_2D = 400_000
DPI = 130


def display_note(fig) -> str | None:
    """What a figure left out to stay fast and small (None: it drew everything)."""
    return getattr(fig, "display_note", None)


def _say(fig, note: str | None):
    if note:
        fig.display_note = note
    return fig


def _points_note(shown: int, total: int, what: str = "dwell points") -> str | None:
    if shown >= total:
        return None
    return (f"Drawn: {shown:,} of {total:,} {what}, evenly spaced along the path (display only: "
            "the path files hold every point).")


def _figure(w: float = 6.4, h: float = 4.8):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(w, h), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _missing(*names: str) -> str:
    return "not in this run (missing " + ", ".join(names) + " in run.npz)"


def _path_segments(points: np.ndarray, pieces: np.ndarray | None, max_points: int):
    """Segments (S, 2, d) between consecutive displayed points of the same piece, and their order 0..1."""
    n = len(points)
    idx = decimate_indices(n, max_points)
    p = points[idx]
    piece_of = piece_index(pieces, n, idx)
    same = piece_of[1:] == piece_of[:-1]
    seg = np.stack([p[:-1], p[1:]], axis=1)[same]
    order = (idx[:-1][same] / max(n - 1, 1)).astype(float)
    return seg, order, len(idx)


def fig_planar_path(run: RunData):
    """The planar path coloured by path order, the region boundary and unreached points (paper Fig. 5b)."""
    from matplotlib.collections import LineCollection

    uv = run.get("plan_uv")
    if uv is None:
        return _missing("plan_uv")
    fig = _figure(6.4, 6.0)
    ax = fig.add_subplot()
    seg, order, shown = _path_segments(uv, run.get("plan_pieces"), MAX_PATH_POINTS_PNG)
    dec = shown < len(uv)
    lw = float(np.clip(300.0 / math.sqrt(max(len(uv), 1)), 0.15, 1.5))
    lc = LineCollection(seg, array=order, cmap="viridis", linewidths=lw)
    ax.add_collection(lc)
    for k, loop in enumerate(run.region_loops):
        c = np.vstack([loop, loop[:1]])
        ax.plot(c[:, 0], c[:, 1], color="k" if k == 0 else "0.35", lw=1.2,
                label="region boundary" if k == 0 else ("holes" if k == 1 else None))
    un = run.get("plan_unreached")
    if un is not None:
        ax.plot(un[:, 0], un[:, 1], "x", color="crimson", ms=4, label=f"unreached ({len(un)})")
    ax.plot(*uv[0], "o", color="tab:green", ms=6, label="start")
    ax.plot(*uv[-1], "s", color="tab:red", ms=6, label="end")
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_xlabel("u (mm)")
    ax.set_ylabel("v (mm)")
    title = f"Planar path: {len(uv):,} dwell points"
    if dec:
        title += " (display decimated)"
    ax.set_title(title)
    ax.legend(loc="upper right", fontsize=7, framealpha=0.8)
    cb = fig.colorbar(lc, ax=ax, shrink=0.7)
    cb.set_label("path order (0 = start, 1 = end)")
    return _say(fig, _points_note(shown, len(uv)))


def _flat_mesh(run: RunData, values: np.ndarray, label: str, title: str, cmap: str, vlim):
    from matplotlib.tri import Triangulation

    uv, faces = run.get("uv"), run.get("faces")
    uvd, fd, vals = cluster_mesh(uv, faces, MAX_FACES_PNG_2D, values)
    fig = _figure(6.4, 5.6)
    ax = fig.add_subplot()
    tri = Triangulation(uvd[:, 0], uvd[:, 1], fd)
    vals = np.where(np.isfinite(vals), vals, 0.0)
    pc = ax.tripcolor(tri, facecolors=vals, cmap=cmap, vmin=vlim[0], vmax=vlim[1],
                      edgecolors="none", rasterized=True)
    for loop in run.region_loops:
        c = np.vstack([loop, loop[:1]])
        ax.plot(c[:, 0], c[:, 1], color="k", lw=0.8)
    ax.set_aspect("equal")
    ax.set_xlabel("u (mm)")
    ax.set_ylabel("v (mm)")
    if len(fd) < len(faces):
        title += " (display coarsened)"
    ax.set_title(title)
    cb = fig.colorbar(pc, ax=ax, shrink=0.8)
    cb.set_label(label)
    return _say(fig, f"Drawn on a coarsened mesh: {len(fd):,} of {len(faces):,} faces (display only)."
                if len(fd) < len(faces) else None)


def fig_angle_error(run: RunData):
    """Flattened mesh coloured by the mean absolute corner-angle error per face, degrees (paper Fig. 3)."""
    need = [k for k in ("vertices", "faces", "uv", "angles") if run.get(k) is None]
    if need:
        return _missing(*need)
    err = angle_error_deg(run.get("vertices"), run.get("faces"), run.get("angles"))
    hi = float(np.nanpercentile(err, 99)) if np.isfinite(err).any() else 1.0
    return _flat_mesh(run, err, "mean |angle error| per face (deg)",
                      f"Angle error: mean {np.nanmean(err):.3g} deg, max {np.nanmax(err):.3g} deg",
                      "magma_r", (0.0, max(hi, 1e-9)))


def fig_area_distortion(run: RunData):
    """Flattened mesh coloured by log area ratio plane / part per face (0: area kept)."""
    need = [k for k in ("vertices", "faces", "uv") if run.get(k) is None]
    if need:
        return _missing(*need)
    dist = area_distortion(run.get("vertices"), run.get("faces"), run.get("uv"))
    lim = float(np.nanpercentile(np.abs(dist), 99)) if np.isfinite(dist).any() else 1.0
    lim = max(lim, 1e-6)
    return _flat_mesh(run, dist, "log(area share in plane / area share on part)",
                      f"Area distortion: mean |log ratio| {np.nanmean(np.abs(dist)):.3g}",
                      "RdBu_r", (-lim, lim))


def fig_residuals(run: RunData):
    """Histograms of the angle-constraint residuals of the flattening (paper Fig. 2)."""
    res = run.residuals
    if not res:
        method = run.section("flattening").get("method") or run.section("config").get("method") or "this method"
        return f"not in this run ({method} solves no angle constraints, so there are no residuals)"
    units = {"triangle": "rad", "vertex": "rad", "wheel": "log-sine units"}
    titles = {"triangle": "triangle angle sum", "vertex": "angle sum around vertices",
              "wheel": "wheel (sine) condition"}
    fig = _figure(4.0 * len(res), 3.6)
    axes = fig.subplots(1, len(res), squeeze=False)[0]
    for ax, (name, r) in zip(axes, res.items()):
        r = r[np.isfinite(r)]
        ax.hist(r, bins=60, color="tab:blue", alpha=0.85)
        ax.set_yscale("log")
        ax.set_xlabel(f"residual ({units.get(name, 'rad')})")
        ax.set_ylabel("count")
        mx = float(np.abs(r).max()) if len(r) else float("nan")
        ax.set_title(f"{titles.get(name, name)}\n{len(r):,} values, max |r| {mx:.2g}", fontsize=9)
        ax.ticklabel_format(axis="x", style="sci", scilimits=(-3, 3))
    return fig


def fig_surface_path(run: RunData):
    """The part and the dwell-point path on it, coloured by path order (paper Figs. 6 and 9)."""
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    xyz = run.get("xyz")
    if xyz is None:
        return _missing("xyz")
    fig = _figure(6.4, 5.6)
    ax = fig.add_subplot(projection="3d")
    ax.computed_zorder = False  # mplot3d sorts whole collections: keep the path drawn over the surface
    v, f = run.get("vertices"), run.get("faces")
    if v is not None and f is not None:
        vd, fd, _ = cluster_mesh(v, f, MAX_FACES_PNG_3D)
        ax.plot_trisurf(vd[:, 0], vd[:, 1], vd[:, 2], triangles=fd, color="0.8", alpha=0.35,
                        linewidth=0, antialiased=False, shade=True, zorder=1)
    seg, order, shown = _path_segments(xyz, run.get("plan_pieces"), MAX_PATH_POINTS_PNG_3D)
    dec = shown < len(xyz)
    lw = float(np.clip(200.0 / math.sqrt(max(len(xyz), 1)), 0.2, 1.5))
    lc = Line3DCollection(seg, array=order, cmap="viridis", linewidths=lw, zorder=2)
    ax.add_collection3d(lc)
    lo, hi = xyz.min(axis=0), xyz.max(axis=0)
    if v is not None:
        lo, hi = np.minimum(lo, v.min(axis=0)), np.maximum(hi, v.max(axis=0))
    flat = 0.005 * max(float((hi - lo).max()), 1e-9)  # a flat part: a thin slab, not a singular axis (a warning)
    lo, hi = np.where(hi - lo > 0, lo, lo - flat), np.where(hi - lo > 0, hi, hi + flat)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(np.maximum(hi - lo, 1e-9 + 0.02 * (hi - lo).max()))
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    title = f"Path on the part: {len(xyz):,} dwell points"
    if dec:
        title += " (display decimated)"
    ax.set_title(title)
    cb = fig.colorbar(lc, ax=ax, shrink=0.6, pad=0.1)
    cb.set_label("path order (0 = start, 1 = end)")
    note = _points_note(shown, len(xyz))
    if v is not None and f is not None and len(fd) < len(f):
        note = (note or "") + f" The part is drawn with {len(fd):,} of its {len(f):,} triangles."
    return _say(fig, note.strip() if note else None)


def fig_step_lengths(run: RunData):
    """Histogram of the 3D steps between dwell points, with the normal range [s, sqrt(2) s] marked."""
    xyz = run.get("xyz")
    if xyz is None:
        return _missing("xyz")
    steps = step_lengths(xyz, run.get("plan_pieces"))
    if len(steps) == 0:
        return "not drawn: the path has fewer than two dwell points"
    s = run.spacing
    fig = _figure(6.4, 4.0)
    ax = fig.add_subplot()
    hi = max(float(steps.max()), (s or 0) * 1.6)
    ax.hist(steps, bins=np.linspace(0, hi, 80), color="tab:blue", alpha=0.85)
    ax.set_yscale("log")
    if s:
        ax.axvspan(s, math.sqrt(2) * s, color="tab:green", alpha=0.15,
                   label=f"normal range [s, √2 s] = [{s:.3g}, {math.sqrt(2) * s:.3g}] mm")
        for x in (s, math.sqrt(2) * s):
            ax.axvline(x, color="tab:green", lw=1)
        inside = np.mean((steps >= s * (1 - 1e-6)) & (steps <= math.sqrt(2) * s * (1 + 1e-6)))
        above = np.mean(steps > math.sqrt(2) * s * (1 + 1e-6))
        note = f"; {100 * inside:.1f}% in range, {100 * above:.2f}% above"
    else:
        note = ""
    ax.axvline(steps.mean(), color="tab:orange", lw=1.2, ls="--", label=f"mean {steps.mean():.4g} mm")
    ax.set_xlabel("step on the part (mm)")
    ax.set_ylabel("steps")
    ax.set_title(f"Step lengths: {len(steps):,} steps, max {steps.max():.4g} mm{note}", fontsize=9)
    ax.legend(fontsize=8)
    return fig


def _continuous_steps(run: RunData):
    """Planar steps (M, 2) mm within pieces of a path over a set without a lattice (blue noise), else None."""
    if run.get("plan_cell_area") is None or run.get("plan_uv") is None:
        return None
    uv = run.get("plan_uv")
    pieces = run.get("plan_pieces")
    pieces = np.array([0, len(uv)]) if pieces is None else pieces
    return np.concatenate([np.diff(uv[a:b], axis=0) for a, b in zip(pieces[:-1], pieces[1:])] + [np.zeros((0, 2))])


def _fig_directions_continuous(d: np.ndarray):
    """Rose of the step directions of a path without a lattice: 16 sectors of 22.5 degrees."""
    if len(d) == 0:
        return "not drawn: the path has no steps"
    ang = np.arctan2(d[:, 1], d[:, 0])
    share = np.bincount(np.round(ang / (np.pi / 8)).astype(int) % 16, minlength=16) / len(ang)
    return _direction_rose(share, f"Step directions (no lattice, 16 sectors): {share.min() * 16:.2f}-"
                                  f"{share.max() * 16:.2f} x an even share")


def _direction_rose(share: np.ndarray, title: str):
    """Polar bars of the share of steps per direction sector, ``share`` (n,) for n = 8 or 16 sectors from E
    counter-clockwise, with the even share 1/n as a ring and the 8 compass directions labelled."""
    n = len(share)
    fig = _figure(4.8, 4.8)
    ax = fig.add_subplot(projection="polar")
    theta = np.arange(n) * 2 * np.pi / n
    ax.bar(theta, share, width=2 * np.pi / n * 0.8, color="tab:blue", alpha=0.8, edgecolor="k")
    ring = np.linspace(0, 2 * np.pi, 200)
    ax.plot(ring, np.full_like(ring, 1 / n), color="tab:red", lw=1, ls="--", label=f"uniform (1/{n})")
    every = n // len(DIRECTION_NAMES)
    ax.set_xticks(theta[::every])
    ax.set_xticklabels([f"{name}\n{100 * x:.1f}%" for name, x in zip(DIRECTION_NAMES, share[::every])], fontsize=7)
    ax.set_yticklabels([])
    ax.set_title(title, fontsize=9)
    ax.legend(loc="lower left", bbox_to_anchor=(-0.1, -0.12), fontsize=7)
    return fig


def fig_directions(run: RunData):
    """Rose of the 8 grid directions of the planar steps (share of steps per direction); a path without a
    lattice (blue noise): its steps' directions in 16 sectors."""
    d = _continuous_steps(run)
    if d is not None:
        return _fig_directions_continuous(d)
    ij = run.get("plan_ij")
    if ij is None:
        return _missing("plan_ij")
    counts, other = direction_counts(ij, run.get("plan_pieces"))
    total = counts.sum()
    if total == 0:
        return "not drawn: the path has no grid steps"
    used = int(np.count_nonzero(counts))
    t = f"Step directions (grid frame): {used} of 8 used"
    if other:
        t += f", {other} other steps"
    return _direction_rose(counts / total, t)


def fig_turn_angles(run: RunData):
    """Histogram of the turn angles between consecutive grid steps (0 = straight on); a path without a
    lattice (blue noise): the continuous turn angles in bins of 22.5 degrees."""
    d = _continuous_steps(run)
    if d is not None:
        return _fig_turns_continuous(d, run.get("plan_pieces"))
    ij = run.get("plan_ij")
    if ij is None:
        return _missing("plan_ij")
    t = turn_angles_deg(ij, run.get("plan_pieces"))
    if len(t) == 0:
        return "not drawn: the path has fewer than two grid steps"
    bins = np.arange(-135, 181, 45)
    counts = np.array([(t == b).sum() for b in bins])
    fig = _figure(6.4, 3.8)
    ax = fig.add_subplot()
    ax.bar(bins, 100 * counts / len(t), width=36, color="tab:purple", alpha=0.85)
    ax.set_xticks(bins)
    ax.set_xlabel("turn angle (deg, counter-clockwise positive)")
    ax.set_ylabel("share of turns (%)")
    ax.set_title(f"Turn angles: {len(t):,} turns, {100 * np.mean(t != 0):.1f}% turning", fontsize=9)
    for b, c in zip(bins, counts):
        ax.annotate(f"{100 * c / len(t):.1f}", (b, 100 * c / len(t)), ha="center", va="bottom", fontsize=7)
    return fig


def _fig_turns_continuous(d: np.ndarray, pieces):
    """Histogram of the signed turn angles (deg) between consecutive steps of a path without a lattice."""
    a = np.arctan2(d[:, 1], d[:, 0])
    turn = np.degrees((np.diff(a) + np.pi) % (2 * np.pi) - np.pi)
    if pieces is not None and len(pieces) > 2:  # no turn across a lift: steps are concatenated piece by piece
        ends = np.cumsum(np.diff(pieces) - 1)[:-1] - 1
        turn = np.delete(turn, ends[(ends >= 0) & (ends < len(turn))])
    if len(turn) == 0:
        return "not drawn: the path has fewer than two steps"
    fig = _figure(6.4, 3.8)
    ax = fig.add_subplot()
    ax.hist(turn, bins=np.linspace(-180, 180, 17), weights=np.full(len(turn), 100.0 / len(turn)),
            color="tab:purple", alpha=0.85, edgecolor="k")
    ax.set_xticks(np.arange(-180, 181, 45))
    ax.set_xlabel("turn angle (deg, counter-clockwise positive)")
    ax.set_ylabel("share of turns (%)")
    ax.set_title(f"Turn angles (no lattice): {len(turn):,} turns, median |turn| {np.median(np.abs(turn)):.0f} deg",
                 fontsize=9)
    return fig


def fig_feed_rate(run: RunData):
    """Commanded feed along the interpolated path against machine time (min/max/mean envelope when dense).

    Drawn from the run's sample digest (:mod:`polishpath.report.digest`: at most
    :data:`FEED_BINS` bins, stored in ``run.npz`` or made from a format-1 run's samples).
    """
    dg = run_digest(run)
    if dg is None:
        return _missing("feed_mm_min")
    edges, env = dg["feed_bins"], dg["feed_envelope"]
    n = int(edges[-1])
    if n == 0:
        return "not drawn: the path has no machine samples"
    period = run.section("smooth").get("period_ms")
    if not (isinstance(period, (int, float)) and period > 0):
        period = run.section("config").get("period_ms")
    fig = _figure(7.2, 3.6)
    ax = fig.add_subplot()
    timed = isinstance(period, (int, float)) and period > 0
    xs = edges[:-1] * (float(period) / 1000.0 if timed else 1.0)
    xlabel = "machine time (s)" if timed else "interpolation sample"
    lo, hi, mid = env[:, 0], env[:, 1], env[:, 2]
    note = None
    if len(env) < n:
        note = (f"Drawn: the min, max and mean of {len(env):,} bins of about {n // len(env):,} samples each "
                f"({n:,} samples in all; display only: the machine files hold every sample).")
        ax.fill_between(xs, lo, hi, color="tab:blue", alpha=0.3, lw=0, label="min..max per bin")
        ax.plot(xs, mid, color="tab:blue", lw=0.8, label="mean per bin")
        ax.legend(fontsize=8)
    else:
        ax.plot(xs, lo, color="tab:blue", lw=0.8)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("feed (mm/min)")
    m = float(np.sum(mid * np.diff(edges)) / n)
    fmin, fmax = float(lo.min()), float(hi.max())
    fl = (fmax - fmin) / m * 100 if m else float("nan")
    ax.set_title(f"Feed rate: mean {m:.4g} mm/min, range {fmin:.4g}..{fmax:.4g} "
                 f"({fl:.3g}% of mean), {n:,} samples", fontsize=9)
    return _say(fig, note)


def fig_tool_axes(run: RunData):
    """A 5-axis run's tool axes (issue 27): top view of the dwell points coloured by the axis' tilt from
    vertical, arrows of the axes' horizontal part; the tilt from vertical and the angle from the normal
    along the path. A 3-axis run (no ``tool_axes``) has none."""
    from ..axes import axis_angles_deg

    ax3, xyz, nrm = run.get("tool_axes"), run.get("xyz"), run.get("normals")
    if ax3 is None or xyz is None or nrm is None:
        return "not in this run (a 3-axis run: --tool-axis z, the vertical tool)"
    n = len(xyz)
    idx = decimate_indices(n, MAX_PATH_POINTS_PNG)
    tilt = axis_angles_deg(ax3, np.array([[0.0, 0.0, 1.0]]))
    from_normal = axis_angles_deg(ax3, nrm)
    fig = _figure(11.0, 4.8)
    left, right = fig.subplots(1, 2, width_ratios=[1.1, 1.0])
    sc = left.scatter(xyz[idx, 0], xyz[idx, 1], c=tilt[idx], s=max(1.0, 4000.0 / max(len(idx), 1)), cmap="viridis")
    arrows = decimate_indices(n, 400)
    span = float(np.ptp(xyz[:, :2], axis=0).max()) or 1.0
    left.quiver(xyz[arrows, 0], xyz[arrows, 1], ax3[arrows, 0], ax3[arrows, 1], angles="xy", scale_units="xy",
                scale=1.0 / (0.08 * span), width=0.003, color="k", alpha=0.7)
    left.set_aspect("equal")
    left.set_xlabel("x (mm)")
    left.set_ylabel("y (mm)")
    left.set_title("Tool axes seen from above (arrows: horizontal part)")
    fig.colorbar(sc, ax=left, shrink=0.8).set_label("tilt from vertical (deg)")
    order = idx / max(n - 1, 1)
    right.plot(order, tilt[idx], lw=0.6, label="tilt from vertical")
    right.plot(order, from_normal[idx], lw=0.6, label="angle from the surface normal")
    right.set_xlabel("path order (0 = start, 1 = end)")
    right.set_ylabel("degrees")
    right.legend(loc="best", fontsize=8)
    law = (run.summary.get("config") or {}).get("tool_axis", "?")
    right.set_title(f"{law}: at most {float(tilt.max()):.1f} deg from vertical", fontsize=10)
    return _say(fig, _points_note(len(idx), n))


#: name -> (function, caption); the order is the order in the report
FIGURES: dict[str, tuple[Callable, str]] = {
    "surface_path": (fig_surface_path, "The path on the part, coloured by path order."),
    "angle_error": (fig_angle_error, "Flattened mesh coloured by the angle error of each face (plane vs part)."),
    "area_distortion": (fig_area_distortion, "Flattened mesh coloured by area distortion (log of the area-share ratio)."),
    "residuals": (fig_residuals, "Residuals of the angle constraints the flattening solved."),
    "planar_path": (fig_planar_path, "The planar path in the flattened region (paper Fig. 5b)."),
    "step_lengths": (fig_step_lengths, "Steps between dwell points on the part."),
    "directions": (fig_directions, "The 8 step directions of the planar grid walk."),
    "turn_angles": (fig_turn_angles, "Turns between consecutive grid steps."),
    "feed_rate": (fig_feed_rate, "Commanded feed along the interpolated path."),
    "tool_axes": (fig_tool_axes, "The tool axes of a 5-axis run: tilt from vertical and from the normal."),
}


def save_png(fig, path) -> None:
    """Write a figure as PNG atomically (temp file renamed into place)."""
    from ..fileio import atomic_open

    with atomic_open(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=DPI)
