"""The report's interactive figures (plotly): the path on the part in 3D, the planar path.

Each ``plot_*`` function returns ``(figure, notes)`` where ``notes`` is a list of
sentences for the report (what was decimated for display), or ``(None, reason)``.
Arrays go in as float32 so plotly stores them as compact base64 typed arrays.
"""

from __future__ import annotations

import numpy as np

from ..pathops import piece_index
from .digest import run_digest
from .rundata import RunData, cluster_mesh, decimate_indices

#: display limits of the interactive views (the files keep every point)
MAX_POINTS_3D = 20_000
MAX_FACES_3D = 20_000
MAX_POINTS_2D = 20_000

COLORSCALE = "Viridis"


def _f32(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float32)


def _broken(points: np.ndarray, idx: np.ndarray, pieces: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Displayed points with a NaN row between pieces (a pen-up), and their path order in [0, 1]."""
    n = len(points)
    p = points[idx].astype(float)
    order = idx / max(n - 1, 1)
    if pieces is None or len(pieces) <= 2:
        return p, order
    piece_of = piece_index(pieces, n, idx)
    cut = np.flatnonzero(np.diff(piece_of) != 0) + 1
    p = np.insert(p, cut, np.nan, axis=0)
    order = np.insert(order.astype(float), cut, np.nan)
    return p, order


def _ffill(a: np.ndarray) -> np.ndarray:
    """Replace NaNs by the previous value (colour of a pen-up gap)."""
    a = np.asarray(a, dtype=float).copy()
    bad = np.isnan(a)
    if bad.any():
        idx = np.where(~bad, np.arange(len(a)), 0)
        np.maximum.accumulate(idx, out=idx)
        a = a[idx]
    return np.nan_to_num(a)


def _decimation_note(what: str, shown: int, total: int) -> str | None:
    if shown >= total:
        return None
    return (f"The interactive view shows {shown:,} of {total:,} {what} (evenly spaced along the path) "
            "to stay responsive; this is for display only, the path files hold every point.")


def plot_surface_3d(run: RunData):
    """Part surface (semi-transparent) with the dwell-point path coloured by path order
    and the smoothed machine curve, switchable with buttons.

    Returns
    -------
    (plotly.graph_objects.Figure, list of str) or (None, str)
    """
    import plotly.colors as pc
    import plotly.graph_objects as go

    xyz = run.get("xyz")
    if xyz is None:
        return None, "The 3D view needs the dwell points on the part (xyz in run.npz), which this run lacks."
    notes: list[str] = []
    traces = []
    v, f = run.get("vertices"), run.get("faces")
    if v is not None and f is not None:
        vd, fd, _ = cluster_mesh(v, f, MAX_FACES_3D)
        if len(fd) < len(f):
            notes.append(f"The surface is drawn coarsened to {len(fd):,} of {len(f):,} triangles (display only).")
        traces.append(go.Mesh3d(
            x=_f32(vd[:, 0]), y=_f32(vd[:, 1]), z=_f32(vd[:, 2]),
            i=fd[:, 0].astype(np.int32), j=fd[:, 1].astype(np.int32), k=fd[:, 2].astype(np.int32),
            color="#b8c2cc", opacity=0.45, name="surface", showlegend=True, hoverinfo="skip",
            flatshading=False, lighting=dict(ambient=0.6, diffuse=0.6, specular=0.1),
        ))
    n = len(xyz)
    idx = decimate_indices(n, MAX_POINTS_3D)
    p, order = _broken(xyz, idx, run.get("plan_pieces"))
    note = _decimation_note("dwell points", len(idx), n)
    if note:
        notes.append(note)
    traces.append(go.Scatter3d(
        x=_f32(p[:, 0]), y=_f32(p[:, 1]), z=_f32(p[:, 2]), mode="lines",
        line=dict(color=np.round(_ffill(order), 4).tolist(), colorscale=COLORSCALE, width=3,
                  colorbar=dict(title=dict(text="path order"), thickness=12, len=0.6, x=1.0)),
        name="dwell-point path (path order)", hovertemplate="x %{x:.3f}<br>y %{y:.3f}<br>z %{z:.3f}<extra></extra>",
        legendgroup="dwell", showlegend=False,
    ))
    # plotly.js cannot draw a legend entry for a line with a colour array (it warns);
    # a one-point stand-in of the same legend group carries the entry and toggles both
    traces.append(go.Scatter3d(
        x=_f32(p[:1, 0]), y=_f32(p[:1, 1]), z=_f32(p[:1, 2]), mode="lines",
        line=dict(color=pc.sample_colorscale(COLORSCALE, [0.35])[0], width=3),
        name="dwell-point path (path order)", legendgroup="dwell", showlegend=True, hoverinfo="skip",
    ))
    has_samples = False
    dg = run_digest(run)  # at most digest.MAX_SAMPLES_SHOWN samples, stored by the job (or made from old arrays)
    if dg is not None and len(dg["display_samples"]):
        shown, total = dg["display_samples"], int(dg["feed_bins"][-1])
        s = shown[decimate_indices(len(shown), MAX_POINTS_3D)]
        note = _decimation_note("interpolated samples", len(s), total)
        if note:
            notes.append(note)
        traces.append(go.Scatter3d(
            x=_f32(s[:, 0]), y=_f32(s[:, 1]), z=_f32(s[:, 2]), mode="lines",
            line=dict(color="#d62728", width=3), name="smoothed curve (NURBS samples)", visible=False,
            hovertemplate="x %{x:.3f}<br>y %{y:.3f}<br>z %{z:.3f}<extra>curve</extra>",
        ))
        has_samples = True
    fig = go.Figure(traces)
    has_mesh = v is not None and f is not None
    if has_samples:
        base = [True] if has_mesh else []
        fig.update_layout(updatemenus=[dict(
            type="buttons", direction="right", x=0.0, y=1.06, xanchor="left", yanchor="bottom",
            showactive=True, active=0, pad=dict(r=4, t=2),
            buttons=[
                dict(label="Dwell points", method="restyle", args=[{"visible": base + [True, True, False]}]),
                dict(label="Smoothed curve", method="restyle", args=[{"visible": base + [False, False, True]}]),
                dict(label="Both", method="restyle", args=[{"visible": base + [True, True, True]}]),
            ],
        )])
    fig.update_layout(
        height=640, margin=dict(l=0, r=0, t=40, b=0),
        scene=dict(aspectmode="data", xaxis_title="x (mm)", yaxis_title="y (mm)", zaxis_title="z (mm)",
                   camera=dict(eye=dict(x=1.05, y=-1.05, z=0.85))),
        legend=dict(x=0.0, y=0.0, bgcolor="rgba(255,255,255,0.7)"),
        uirevision="keep",
    )
    return fig, notes


def plot_planar_2d(run: RunData, chunks: int = 12):
    """Planar path in the flattened region, coloured by path order in ``chunks`` bands.

    Returns
    -------
    (plotly.graph_objects.Figure, list of str) or (None, str)
    """
    import plotly.colors as pc
    import plotly.graph_objects as go

    uv = run.get("plan_uv")
    if uv is None:
        return None, "The planar view needs the planar path (plan_uv in run.npz), which this run lacks."
    notes: list[str] = []
    n = len(uv)
    idx = decimate_indices(n, MAX_POINTS_2D)
    note = _decimation_note("dwell points", len(idx), n)
    if note:
        notes.append(note)
    traces = []
    for k, loop in enumerate(run.region_loops):
        c = np.vstack([loop, loop[:1]])
        traces.append(go.Scatter(x=_f32(c[:, 0]), y=_f32(c[:, 1]), mode="lines", line=dict(color="black", width=1.5),
                                 name="region boundary" if k == 0 else f"hole {k}", hoverinfo="skip",
                                 showlegend=k <= 1))
    colors = pc.sample_colorscale(COLORSCALE, np.linspace(0, 1, chunks))
    bounds = np.linspace(0, len(idx), chunks + 1).astype(int)
    pieces = run.get("plan_pieces")
    for c in range(chunks):
        a, b = bounds[c], min(bounds[c + 1] + 1, len(idx))  # overlap one point so bands join
        if b - a < 2:
            continue
        p, _ = _broken(uv, idx[a:b], pieces)
        traces.append(go.Scatter(
            x=_f32(p[:, 0]), y=_f32(p[:, 1]), mode="lines", line=dict(color=colors[c], width=1),
            name=f"path {100 * c // chunks}-{100 * (c + 1) // chunks}%", showlegend=False,
            hovertemplate="u %{x:.3f}<br>v %{y:.3f}<extra>" + f"{100 * c // chunks}-{100 * (c + 1) // chunks}% of path</extra>",
        ))
    traces.append(go.Scatter(x=[float(uv[0, 0])], y=[float(uv[0, 1])], mode="markers",
                             marker=dict(color="green", size=9, symbol="circle"), name="start"))
    traces.append(go.Scatter(x=[float(uv[-1, 0])], y=[float(uv[-1, 1])], mode="markers",
                             marker=dict(color="red", size=9, symbol="square"), name="end"))
    un = run.get("plan_unreached")
    if un is not None:
        traces.append(go.Scatter(x=_f32(un[:, 0]), y=_f32(un[:, 1]), mode="markers",
                                 marker=dict(color="crimson", size=6, symbol="x"), name=f"unreached ({len(un)})"))
    # an invisible trace that carries the colour bar of path order
    traces.append(go.Scatter(x=[None], y=[None], mode="markers", showlegend=False, hoverinfo="skip",
                             marker=dict(colorscale=COLORSCALE, cmin=0, cmax=1, color=[0.5], showscale=True,
                                         colorbar=dict(title=dict(text="path order"), thickness=12, len=0.6))))
    fig = go.Figure(traces)
    fig.update_layout(
        height=620, margin=dict(l=50, r=10, t=20, b=40),
        xaxis=dict(title="u (mm)", scaleanchor="y", scaleratio=1, constrain="domain"),
        yaxis=dict(title="v (mm)"),
        legend=dict(x=0.0, y=1.0, bgcolor="rgba(255,255,255,0.7)"),
        plot_bgcolor="white",
    )
    return fig, notes


INTERACTIVE = {
    "surface_3d": plot_surface_3d,
    "planar_2d": plot_planar_2d,
}
