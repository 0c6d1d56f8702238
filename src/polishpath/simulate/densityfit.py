"""Dwell points moved a little so the tool's time density is flat where the tool passes it into the band.

Issue 26 Build 4's second condition (a lattice-free walk's band RMS no worse
than the best other path's) failed on one ring of spatial frequency: a walk
that turns at every point spreads its machine time density over 1-2 1/mm, just
above the band's lower edge, where the 2 mm tool passes it
(docs/simulation.md, "Where the walks' band RMS comes from"). This module is the
treatment that removes most of it, applied to every path alike:

1. **Centring** (``centre_iterations``): each dwell point ``p`` is moved so
   that the time the machine spends in its region (from the middle of the
   curve before it to the middle after it) has its centroid on ``p``:
   ``q <- q - (centroid(q) - p)``. A straight pass has its centroid on its
   point already; a turn has it inside the turn, about h/8 away.
2. **Fit** (``iterations``): gradient steps on the machine's time density
   ``rho`` (its samples splatted on a ``dx_mm`` grid, over its mean, in the
   fully covered interior): the loss is ``sum_f |T(f)|^2 |rho(f)|^2`` over
   ``band`` (the tool's transfer ``T`` at zero feed, normalised to 1 at f = 0),
   what the tool would print of the density in that band; each region's time
   is moved down the gradient of that filtered density at its time centroid,
   the largest move ``step_mm``. The machine is run again after every step
   (the smoothing stage's NURBS and feed schedule, :func:`machine_tool_path`),
   so the loss is measured, not modelled; the step with the lowest loss is kept.

Every move keeps the path's guarantees: no point further than ``max_shift_mm``
from its planned place (default 0.3 h), none nearer than ``min_distance_mm`` to
another (0.7 h, the blue-noise set's own bound), no step longer than
``max_step_mm`` (2 h), and no piece crossing itself (shapely); a point whose
move would break one stays where it was. The dwell times are not changed.

The project's own method (a planner-side fit of the machine time density), so
written by hand on numpy / scipy.fft / scipy.ndimage / shapely.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ParameterError
from .machinetime import machine_tool_path

__all__ = ["DENSITY_FIT_BAND_PER_MM", "DensityFit", "fit_time_density", "time_centroids"]

#: the rings the fit flattens, 1/mm: from just below the band's lower edge (1 1/mm) up to 1/h for h = 0.5 mm;
#: above it a path's own spacing (its points' structure) sets the density, and the tool passes little
DENSITY_FIT_BAND_PER_MM = (0.95, 2.0)


@dataclass(frozen=True)
class DensityFit:
    """The moved dwell points and what the fit did.

    Attributes
    ----------
    xy : (N, 2) float64
        The dwell points after the fit, mm, in the same order.
    stats : dict
        ``loss_planned``, ``loss_centred``, ``loss`` (the tool-filtered density's power over
        the band, dimensionless, as planned, after centring, kept), ``iterations`` run,
        ``best_iteration``, ``shift_rms_mm``, ``shift_max_mm``, ``moved_share``, ``reverted``
        (moves taken back to keep a guarantee), the bounds used.
    """

    xy: np.ndarray
    stats: dict[str, Any] = field(default_factory=dict)


def time_centroids(tool_path, timed) -> tuple[np.ndarray, np.ndarray]:
    """The centroid of the machine time spent in each dwell point's region, and that time.

    Parameters
    ----------
    tool_path : ToolPath
        Its ``dwell_params`` (N,) and ``sample_params`` (M,) assign every move
        to the region of a dwell point (between the midpoints of the dwell
        parameters, as the smoothing stage's feed schedule does).
    timed : TimedPath
        The same samples in the plane (``xy`` (M, 2) mm, ``time_s`` (M,) s: the
        move from sample k to k + 1).

    Returns
    -------
    centroids : (N, 2) float64
        mm (a moving region's centroid; a dwell point with no time keeps (0, 0)).
    time_s : (N,) float64
        s.
    """
    s = np.asarray(timed.xy, dtype=np.float64)
    ts = np.asarray(timed.time_s, dtype=np.float64)[:-1]
    mid = 0.5 * (s[:-1] + s[1:])
    par = 0.5 * (np.asarray(tool_path.sample_params)[:-1] + np.asarray(tool_path.sample_params)[1:])
    dp = np.asarray(tool_path.dwell_params, dtype=np.float64)
    n = len(dp)
    owner = np.searchsorted(0.5 * (dp[:-1] + dp[1:]), par)
    tot = np.bincount(owner, ts, n)
    c = np.stack([np.bincount(owner, ts * mid[:, i], n) for i in (0, 1)], axis=1)
    return c / np.maximum(tot, 1e-300)[:, None], tot


def _zero_feed_kernel(tif, dx: float) -> np.ndarray:
    from .mechanisms import zero_feed_tif
    from .rotating import RotatingToolTIF
    from .tif import DirectionalTIF

    if isinstance(tif, RotatingToolTIF):
        return np.asarray(zero_feed_tif(tif, dx).kernel(dx), dtype=np.float64)
    if isinstance(tif, DirectionalTIF):
        tif = tif.tifs[0]
    return np.asarray(tif.kernel(dx), dtype=np.float64)


def _fit_inputs(what: str, xy, dwell_s, spacing_mm, band, dx_mm, min_points: int, limits_mm) -> tuple:
    """A fit's points, times, spacing, band and guarantees, checked: ``(p (N, 2), t (N,), h, (lo, hi), limits)``.

    ``limits_mm`` is ``(max_shift_mm, min_distance_mm, max_step_mm)``, each None for its default
    (0.3 h, 0.7 h, 2 h); ``what`` names the fit in the messages.
    """
    p = np.asarray(xy, dtype=np.float64)
    t = np.asarray(dwell_s, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or t.shape != (len(p),) or len(p) < min_points:
        raise ParameterError(f"the {what} needs (N, 2) dwell points (N >= {min_points}) and N times, got {p.shape}, "
                             f"{t.shape}.")
    h = float(spacing_mm)
    if not (np.isfinite(h) and h > 0):
        raise ParameterError(f"spacing_mm must be > 0 mm, got {spacing_mm}.")
    lo, hi = (float(b) for b in band)
    if not (0 <= lo < hi < 0.5 / dx_mm):
        raise ParameterError(f"band must satisfy 0 <= f_lo < f_hi < 1/(2 dx) = {0.5 / dx_mm:g} 1/mm, got {band!r}.")
    limits = tuple(d * h if v is None else float(v) for v, d in zip(limits_mm, (0.3, 0.7, 2.0)))
    return p, t, h, (lo, hi), limits


class _Guard:
    """The guarantees every move keeps (see the module docstring); reverts the points that would break one."""

    def __init__(self, planned: np.ndarray, pieces: np.ndarray, max_shift: float, min_dist: float, max_step: float):
        self.p = planned
        self.pieces = pieces
        self.max_shift, self.min_dist, self.max_step = max_shift, min_dist, max_step
        same = np.zeros(len(planned) - 1, dtype=bool)  # steps inside a piece
        for a, b in zip(pieces[:-1], pieces[1:]):
            same[a:b - 1] = True
        self.inner_step = same
        self.reverted = 0

    def _simple(self, q: np.ndarray) -> bool:
        from shapely.geometry import LineString

        return all(LineString(q[a:b]).is_simple for a, b in zip(self.pieces[:-1], self.pieces[1:]) if b - a >= 2)

    def apply(self, new: np.ndarray, old: np.ndarray) -> np.ndarray:
        from scipy.spatial import cKDTree

        d = new - self.p
        far = np.hypot(d[:, 0], d[:, 1])
        scale = np.minimum(1.0, self.max_shift / np.maximum(far, 1e-300))
        new = self.p + d * scale[:, None]
        for _ in range(8):
            moved = np.any(new != old, axis=1)
            if not moved.any():
                break
            nn = cKDTree(new).query(new, 2)[0][:, 1]
            st = np.hypot(*np.diff(new, axis=0).T)
            long = (st > self.max_step) & self.inner_step
            bad = nn < self.min_dist
            bad[:-1] |= long
            bad[1:] |= long
            bad &= moved
            if not bad.any():
                break
            self.reverted += int(bad.sum())
            new = np.where(bad[:, None], old, new)
        if not self._simple(new):  # a crossing: this step is not taken
            self.reverted += int(np.any(new != old, axis=1).sum())
            return old
        return new


def fit_time_density(xy, dwell_s, pieces, tif, *, spacing_mm: float, band=DENSITY_FIT_BAND_PER_MM,
                     iterations: int = 40, centre_iterations: int = 3, step_mm: float | None = None,
                     max_shift_mm: float | None = None, min_distance_mm: float | None = None,
                     max_step_mm: float | None = None, dx_mm: float = 0.05, machine=None) -> DensityFit:
    """Move planar dwell points so the machine's time density, as the tool passes it in ``band``, is flat.

    Parameters
    ----------
    xy : (N, 2) float
        Planar dwell points in path order, mm.
    dwell_s : (N,) float
        Their dwell times, s (kept).
    pieces : (K + 1,) int
        Piece offsets (tool lifts between pieces).
    tif : RotatingToolTIF, TIF or DirectionalTIF
        The tool: its footprint at zero feed gives the transfer ``T``.
    spacing_mm : float
        The path's spacing h, mm: the default bounds are set from it.
    band : (float, float)
        Frequencies the fit flattens, 1/mm.
    iterations, centre_iterations : int
        Fit steps and centring steps (each one machine run).
    step_mm : float, optional
        Largest move of one fit step (default 0.02 h).
    max_shift_mm, min_distance_mm, max_step_mm : float, optional
        The guarantees (default 0.3 h, 0.7 h, 2 h); see the module docstring.
    dx_mm : float
        Grid of the density, mm (the band ends far below its Nyquist frequency).
    machine : MachineProfile, str or None
        As :func:`machine_tool_path`.

    Returns
    -------
    DensityFit

    Raises
    ------
    ParameterError
        Bad shapes, a bad band, bounds or step, a path without a covered interior.
    """
    import scipy.fft as sfft
    from scipy import ndimage

    from .removal import rasterize_time

    p, t, h, (lo, hi), guard_args = _fit_inputs("density fit", xy, dwell_s, spacing_mm, band, dx_mm, 3,
                                                (max_shift_mm, min_distance_mm, max_step_mm))
    step = 0.02 * h if step_mm is None else float(step_mm)
    if not (step > 0 and all(v > 0 for v in guard_args)):
        raise ParameterError("step_mm, max_shift_mm, min_distance_mm and max_step_mm must be > 0 mm.")
    from ..pathops import piece_offsets

    pcs = np.asarray(piece_offsets(pieces, len(p)), dtype=np.int64)
    guard = _Guard(p, pcs, *guard_args)
    # the grid: the points' bounds plus the tool's reach (its radius, else its kernel's half-width) and a margin
    k = _zero_feed_kernel(tif, dx_mm)
    reach = float(getattr(tif, "radius_mm", 0.5 * max(k.shape) * dx_mm))
    x0, y0 = p.min(axis=0) - reach - 2 * h
    x1, y1 = p.max(axis=0) + reach + 2 * h
    nx, ny = int(np.ceil((x1 - x0) / dx_mm)) + 1, int(np.ceil((y1 - y0) / dx_mm)) + 1
    origin = (float(x0), float(y0))
    K = np.zeros((ny, nx))
    ky, kx = k.shape
    K[:ky, :kx] = k
    K = np.roll(K, (-(ky // 2), -(kx // 2)), axis=(0, 1))
    Tf = sfft.rfft2(K)
    Tf = Tf / Tf[0, 0]
    F = np.hypot(sfft.rfftfreq(nx, dx_mm)[None, :], sfft.fftfreq(ny, dx_mm)[:, None])
    W = np.abs(Tf) ** 2 * ((F >= lo) & (F <= hi))

    last: list = [None, None]  # the last points run and their run: the planned points' run serves the cover
    # below and the first centring step (or the first fit step) alike, not a second machine run

    def run(q):
        if last[0] is not None and np.array_equal(last[0], q):
            return last[1]
        tp, timed, _ = machine_tool_path(q, t, pcs, spacing_mm=h, machine=machine)
        rho = rasterize_time(np.asarray(timed.xy), np.asarray(timed.time_s), (ny, nx), origin, dx_mm)[0]
        last[0], last[1] = q.copy(), (tp, timed, rho)
        return last[1]

    # where the fit holds: the fully covered interior of the planned path (its removal within 10 % of the median),
    # eroded by the tool's reach; only points inside it move
    _, _, rho0 = run(p)
    cover = sfft.irfft2(sfft.rfft2(rho0) * Tf, s=rho0.shape)
    full = cover >= 0.9 * np.median(cover[cover > 0.5 * cover.max()])
    r = int(np.ceil(reach / dx_mm))
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    inner = ndimage.binary_erosion(full, structure=(xx * xx + yy * yy) <= r * r)
    if not inner.any():
        raise ParameterError("the path has no interior the tool covers fully; the density fit needs a larger region.",
                             "Fit a path over a region at least a few tool diameters wide.")

    def sample(a, q):
        return ndimage.map_coordinates(a, [(q[:, 1] - origin[1]) / dx_mm, (q[:, 0] - origin[0]) / dx_mm], order=1)

    movable = sample(inner.astype(np.float64), p) > 0.5

    def loss_and_grad(tp, timed, rho):
        mean = float(rho[full].mean())
        e = np.where(full, rho / mean - 1.0, 0.0)
        g = sfft.irfft2(sfft.rfft2(e) * W, s=e.shape)
        c, _ = time_centroids(tp, timed)
        gy, gx = np.gradient(g, dx_mm)
        grad = np.column_stack([sample(gx, c), sample(gy, c)])
        grad[~movable] = 0.0
        return float(np.sum((e * g)[inner])), grad, c

    q = p.copy()
    loss_planned = None
    for _ in range(int(centre_iterations)):
        tp, timed, rho = run(q)
        loss, _, c = loss_and_grad(tp, timed, rho)
        loss_planned = loss if loss_planned is None else loss_planned
        shift = -(c - p)
        shift[~movable] = 0.0
        q = guard.apply(q + shift, q)
    best_q, best_loss, best_it = q, None, 0
    loss_centred = None
    for it in range(int(iterations) + 1):
        tp, timed, rho = run(q)
        loss, grad, _ = loss_and_grad(tp, timed, rho)
        if loss_planned is None:
            loss_planned = loss
        if loss_centred is None:
            loss_centred = loss
        if best_loss is None or loss < best_loss:
            best_q, best_loss, best_it = q, loss, it
        if it == int(iterations):
            break
        gmax = float(np.abs(grad).max())
        if gmax == 0.0:
            break
        q = guard.apply(q - grad / gmax * step, q)
    d = np.hypot(*(best_q - p).T)
    stats = {"loss_planned": loss_planned, "loss_centred": loss_centred, "loss": best_loss,
             "iterations": int(iterations), "centre_iterations": int(centre_iterations), "best_iteration": best_it,
             "shift_rms_mm": float(np.sqrt(np.mean(d * d))), "shift_max_mm": float(d.max()),
             "moved_share": float(np.mean(d > 0)), "reverted": guard.reverted, "band_per_mm": [lo, hi],
             "step_mm": step, "max_shift_mm": guard_args[0], "min_distance_mm": guard_args[1],
             "max_step_mm": guard_args[2], "dx_mm": float(dx_mm)}
    return DensityFit(best_q, stats)
