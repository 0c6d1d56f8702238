"""The ripple fit: dwell points moved a little so the rotating tool's removal has the least power in the band.

A path prints its removal's ripple through two things the dwell points decide: where the machine's
time goes (each point's region of the smoothing stage's curve, run at its own feed) and which way the
tool is moving there (a rotating footprint leans to one side of its feed and stretches along it,
:mod:`polishpath.simulate.rotating`). :func:`fit_removal_ripple` moves the points, within bounds that
keep every guarantee of the path, so that the removal those samples leave, as the tool's own kernels
compute it, is as flat as it can make it over the spatial frequencies where the tool passes the most
(``band``: from just below the band's lower edge, 1 1/mm, up to 3 1/mm, above a 0.5 mm path's own
line frequency).

It is the same treatment for every path: a walk that turns at every point gains most (its time
centroids sit inside its turns and its footprint leans a new way at every point); a periodic path
whose passes are already even gains little. What it is for, and what it gives on the verdict's parts,
is in docs/simulation.md ("The ripple fit"). It is a treatment of the comparison
(``compare_planned(..., treatment="ripple-fit")``, ``polishpath simulate --treatment ripple-fit``), not
yet a stage of the job.

How (written here because it is the project's own: no library fits a tool path's removal):

1. Run the path through the machine (:func:`~polishpath.simulate.machinetime.machine_tool_path`:
   the job's smoothing stage and feed schedule) and compute the removal of its samples with the
   tool's kernel basis (:meth:`RotatingToolTIF.basis`; one kernel for a tool without a feed
   dependence), each sample's speed and heading as the machine runs it.
2. Linearise: the samples' positions are the smoothing stage's interpolating cubic through the
   points evaluated at the samples' curve parameters, ``X = B N^-1 q`` per piece (``N`` the
   collocation matrix, ``B`` the basis at the samples), with the parameters, the samples' times and
   their kernels' coefficients held at this run's.
3. Minimise the band power of the modelled removal over the part's fully covered interior (or the
   given bounds), windowed as :mod:`polishpath.simulate.fair` windows the map it judges, with
   L-BFGS-B, each coordinate within ``trust_mm`` of where it is and ``max_shift_mm`` of its planned
   place; the model's gap to the machine's removal at the current points is held as a fixed field.
4. Keep the guarantees (no point nearer than ``min_distance_mm`` to another, no step over
   ``max_step_mm``, no piece crossing itself: a move that would break one is taken back), run the
   machine again, and repeat; the step with the lowest band power as the machine runs it is kept.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from .densityfit import DensityFit, _fit_inputs, _Guard
from .machinetime import machine_tool_path

__all__ = ["RIPPLE_FIT_BAND_PER_MM", "fit_removal_ripple"]

#: the frequencies whose removal power the fit lowers, 1/mm: from just below the band's lower edge (1 1/mm)
#: up to 3 1/mm, above a 0.5 mm path's line frequency (2 1/mm); the rotating 2 mm tool passes little above it
RIPPLE_FIT_BAND_PER_MM = (0.95, 3.0)


def _motion(timed) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Samples (M, 2) mm, their move times (M,) s, speeds (M,) mm/s and headings (M,) rad."""
    s = np.asarray(timed.xy, dtype=np.float64)
    w = np.asarray(timed.time_s, dtype=np.float64)
    v = np.zeros_like(s)
    if len(s) > 1:
        v[:-1] = np.diff(s, axis=0) / np.maximum(w[:-1], 1e-12)[:, None]
        ends = np.asarray(timed.pieces, dtype=np.int64)[1:] - 1  # a piece's last sample: its last move's heading
        v[ends] = v[np.maximum(ends - 1, 0)]
    return s, w, np.hypot(v[:, 0], v[:, 1]), np.arctan2(v[:, 1], v[:, 0])


class _Kernels:
    """The tool's removal as fixed kernels times per-sample coefficients, in the frequency domain of one grid."""

    def __init__(self, tif, dx: float, shape: tuple[int, int], speeds: np.ndarray, times: np.ndarray):
        import scipy.fft as sfft

        from .densityfit import _zero_feed_kernel
        from .rotating import RotatingToolTIF

        self.basis = None
        if isinstance(tif, RotatingToolTIF):
            on = times > 0
            sp = speeds[on] if on.any() else np.zeros(1)
            self.basis = tif.basis(dx, (float(sp.min()), float(sp.max())), tol=1e-2, sample_speeds=sp,
                                   sample_times=times[on] if on.any() else None)
            kernels = self.basis.kernels
        else:
            kernels = [_zero_feed_kernel(tif, dx)]
        ny, nx = shape
        self.spectra = []
        for k in kernels:
            ky, kx = k.shape
            if ky > ny or kx > nx:
                raise ParameterError("the tool is larger than the fit's grid.", "Fit a path over a larger region.")
            grid = np.zeros(shape)
            grid[:ky, :kx] = k
            self.spectra.append(sfft.rfft2(np.roll(grid, (-(ky // 2), -(kx // 2)), axis=(0, 1))))

    def coefficients(self, speeds: np.ndarray, headings: np.ndarray) -> np.ndarray:
        """(n_kernels, M) coefficients of the samples' kernels."""
        if self.basis is None:
            return np.ones((1, len(speeds)))
        s = np.clip(speeds, self.basis.speeds[0], self.basis.speeds[-1])
        return self.basis.coefficients(s, headings)


def _curve_operators(q: np.ndarray, pieces: np.ndarray, tool_path, keep: np.ndarray | None = None, degree: int = 3):
    """Per piece of at least ``degree + 1`` points: (sample rows, B, LU of N, first, end) with samples = B N^-1 q.

    ``keep`` (M',) int, optional: the samples to model (rows index into it); default all.

    The smoothing stage's curve (:func:`polishpath.smooth.nurbs.interpolate_nurbs`, chord parameters,
    averaged knots) with its parameters held; each sample's parameter on its piece is read from the
    ToolPath's (the joined curve maps each piece's [0, 1] linearly onto its share).
    """
    import scipy.sparse as sp
    import scipy.sparse.linalg as spl

    from ..smooth.nurbs import averaged_knots, basis_functions, find_spans, interpolation_params

    sparams = np.asarray(tool_path.sample_params, dtype=np.float64)
    if keep is not None:
        sparams = sparams[keep]
    dparams = np.asarray(tool_path.dwell_params, dtype=np.float64)
    ops = []
    for a, b in zip(pieces[:-1], pieces[1:]):
        n = int(b - a)
        if n < degree + 1:
            continue  # a piece too short for the cubic: its points stay where they are
        u = interpolation_params(q[a:b], "chord")
        knots = averaged_knots(u, degree)
        cols = np.arange(degree + 1)
        span = find_spans(knots, degree, n, u)
        coll = sp.csc_matrix((basis_functions(knots, degree, span, u).ravel(),
                              (np.repeat(np.arange(n), degree + 1), (span[:, None] - degree + cols).ravel())),
                             shape=(n, n))
        rows = np.flatnonzero((sparams >= dparams[a]) & (sparams <= dparams[b - 1]))
        if not len(rows):
            continue  # a piece off the grid
        us = np.interp(sparams[rows], dparams[a:b], u)
        span_s = find_spans(knots, degree, n, us)
        bmat = sp.csr_matrix((basis_functions(knots, degree, span_s, us).ravel(),
                              (np.repeat(np.arange(len(rows)), degree + 1), (span_s[:, None] - degree + cols).ravel())),
                             shape=(len(rows), n))
        ops.append((rows, bmat, spl.splu(coll), int(a), int(b)))
    return ops


def _bilinear_gradient(field: np.ndarray, pts: np.ndarray, origin, dx: float) -> np.ndarray:
    """(M, 2): the gradient of the bilinear interpolation of ``field`` at ``pts`` (the splat's adjoint derivative)."""
    ny, nx = field.shape
    fx = (pts[:, 0] - origin[0]) / dx
    fy = (pts[:, 1] - origin[1]) / dx
    j = np.clip(np.floor(fx).astype(np.int64), 0, nx - 2)
    i = np.clip(np.floor(fy).astype(np.int64), 0, ny - 2)
    ax, ay = fx - j, fy - i
    a00, a01, a10, a11 = field[i, j], field[i, j + 1], field[i + 1, j], field[i + 1, j + 1]
    return np.column_stack([((1 - ay) * (a01 - a00) + ay * (a11 - a10)) / dx,
                            ((1 - ax) * (a10 - a00) + ax * (a11 - a01)) / dx])


def fit_removal_ripple(xy, dwell_s, pieces, tif, *, spacing_mm: float, band=RIPPLE_FIT_BAND_PER_MM, steps: int = 10,
                       trust_mm: float | None = None, max_shift_mm: float | None = None,
                       min_distance_mm: float | None = None, max_step_mm: float | None = None,
                       dx_mm: float = 0.05, inner_iterations: int = 10, machine=None, bounds=None) -> DensityFit:
    """Move planar dwell points so the removal the machine's samples leave has the least power in ``band``.

    Parameters
    ----------
    xy : (N, 2) float
        Planar dwell points in path order, mm.
    dwell_s : (N,) float
        Their dwell times, s (kept).
    pieces : (K + 1,) int or None
        Piece offsets (tool lifts between pieces).
    tif : RotatingToolTIF, TIF or DirectionalTIF
        The tool; a rotating one with its feed-dependent footprint (its kernel basis).
    spacing_mm : float
        The path's spacing h, mm: the default bounds are set from it.
    band : (float, float)
        Frequencies whose removal power the fit lowers, 1/mm.
    steps : int
        Linearise-and-minimise steps (each one machine run).
    trust_mm : float, optional
        How far a coordinate may move in one step (default 0.05 h).
    max_shift_mm, min_distance_mm, max_step_mm : float, optional
        The guarantees (default 0.3 h, 0.7 h, 2 h), as :func:`~polishpath.simulate.densityfit.fit_time_density`.
    dx_mm : float
        Grid of the removal, mm (the band ends far below its Nyquist frequency).
    inner_iterations : int
        L-BFGS-B iterations per step at most (10: on the tests' 14 mm square, 4 steps of 10 take the loss to 0.324
        of the planned in 20 s CPU, 4 steps of 80 to 0.321 in 174 s).
    machine : MachineProfile, str or None
        As :func:`~polishpath.simulate.machinetime.machine_tool_path`.
    bounds : (4,) float, optional
        ``(xmin, ymin, xmax, ymax)``, mm: fit the removal inside this rectangle only (a comparison's
        patch); only the points within the tool's reach of it move, and the removal is computed on a grid
        around it alone, so a patch of a large part costs what the patch costs. Default: the whole path.

    Returns
    -------
    DensityFit
        ``xy`` the moved points; ``stats``: ``loss_planned`` and ``loss`` (the band power of the removal over
        its mean in the covered interior, or in ``bounds``, tapered at its edge as the fair figures taper
        their map; as planned and kept), ``steps``,
        ``best_step``, ``shift_rms_mm``, ``shift_max_mm``, ``moved_share``, ``reverted``, ``n_kernels``
        and the bounds used.

    Raises
    ------
    ParameterError
        Bad shapes, band, bounds or counts; a path without an interior the tool covers fully.
    """
    import scipy.fft as sfft
    from scipy import ndimage, optimize

    from ..pathops import piece_offsets
    from .fair import _window, taper_width_mm
    from .removal import rasterize_time

    p, t, h, (lo_f, hi_f), limits = _fit_inputs("ripple fit", xy, dwell_s, spacing_mm, band, dx_mm, 4,
                                                (max_shift_mm, min_distance_mm, max_step_mm))
    trust = 0.05 * h if trust_mm is None else float(trust_mm)
    if not (trust > 0 and all(v > 0 for v in limits)):
        raise ParameterError("trust_mm, max_shift_mm, min_distance_mm and max_step_mm must be > 0 mm.")
    if int(steps) < 0 or int(inner_iterations) < 1:
        raise ParameterError(f"steps must be >= 0 and inner_iterations >= 1, got {steps}, {inner_iterations}.")
    pcs = np.asarray(piece_offsets(pieces, len(p)), dtype=np.int64)
    guard = _Guard(p, pcs, *limits)
    reach = float(getattr(tif, "radius_mm", 0.0)) or 3.0
    x0, y0 = p.min(axis=0) - reach - 2 * h
    x1, y1 = p.max(axis=0) + reach + 2 * h
    if bounds is not None:
        bx0, by0, bx1, by1 = (float(v) for v in bounds)
        if not (bx0 < bx1 and by0 < by1):
            raise ParameterError(f"bounds must be (xmin, ymin, xmax, ymax) with xmin < xmax, ymin < ymax, got {bounds!r}.")
        # the grid: the rectangle and twice the reach around it (a sample's kernel wraps round the grid's edge
        # no further than one reach, so nothing wraps into the rectangle or the points that move)
        x0, y0 = max(x0, bx0 - 2 * reach - 2 * h), max(y0, by0 - 2 * reach - 2 * h)
        x1, y1 = min(x1, bx1 + 2 * reach + 2 * h), min(y1, by1 + 2 * reach + 2 * h)
    shape = (int(np.ceil((y1 - y0) / dx_mm)) + 1, int(np.ceil((x1 - x0) / dx_mm)) + 1)
    origin = (float(x0), float(y0))
    f = np.hypot(sfft.rfftfreq(shape[1], dx_mm)[None, :], sfft.fftfreq(shape[0], dx_mm)[:, None])
    in_band = ((f >= lo_f) & (f <= hi_f)).astype(np.float64)

    def machine_run(q):
        """The ToolPath, the kept samples' indices (those on the grid) and their positions, times, speeds, headings."""
        tp, timed, _ = machine_tool_path(q, t, pcs, spacing_mm=h, machine=machine)
        s, w, speed, heading = _motion(timed)
        keep = np.flatnonzero((s[:, 0] >= x0) & (s[:, 0] <= x1) & (s[:, 1] >= y0) & (s[:, 1] <= y1))
        return tp, keep, (s[keep], w[keep], speed[keep], heading[keep])

    tp, keep, (s, w, speed, heading) = machine_run(p)
    kern = _Kernels(tif, dx_mm, shape, speed, w)

    def removal(pts, wc):
        acc = 0.0
        for j, spec in enumerate(kern.spectra):
            acc = acc + sfft.rfft2(rasterize_time(pts, wc[j], shape, origin, dx_mm)[0]) * spec
        return sfft.irfft2(acc, s=shape)

    wc = kern.coefficients(speed, heading) * w[None, :]
    r0 = removal(s, wc)
    # where the fit looks: the fully covered interior (removal within 10 % of the median), eroded by the reach
    full = r0 >= 0.9 * np.median(r0[r0 > 0.5 * r0.max()])
    rr = int(np.ceil(reach / dx_mm))
    yy, xx = np.mgrid[-rr:rr + 1, -rr:rr + 1]
    inner = ndimage.binary_erosion(full, structure=(xx * xx + yy * yy) <= rr * rr)
    near = inner
    if bounds is not None:
        gy, gx = np.mgrid[0:shape[0], 0:shape[1]]
        gx, gy = origin[0] + gx * dx_mm, origin[1] + gy * dx_mm
        inner_rect = (gx >= bx0) & (gx <= bx1) & (gy >= by0) & (gy <= by1)
        inner = inner & inner_rect
        near = near & (gx >= bx0 - reach) & (gx <= bx1 + reach) & (gy >= by0 - reach) & (gy <= by1 + reach)
        del gx, gy
    if not inner.any():
        raise ParameterError("the path has no interior the tool covers fully; the ripple fit needs a larger region.",
                             "Fit a path over a region at least a few tool diameters wide.")
    at = ndimage.map_coordinates(near.astype(np.float64), [(p[:, 1] - origin[1]) / dx_mm, (p[:, 0] - origin[0]) / dx_mm],
                                 order=1)  # 0 off the grid
    idx = np.flatnonzero(at > 0.5)  # the points that move: those inside the interior (within reach of the bounds)

    # the loss is the fair figures' own: the band power of the removal over its mean, tapered at the edge of
    # where it is judged as polishpath.simulate.fair tapers the map it judges (a raised cosine 2 mm wide), so
    # that neither the rim's error outside nor the band filter's ringing from there counts
    if bounds is None:
        win = _window(inner, dx_mm, taper_width_mm())
    else:  # the rectangle itself, as the comparison crops and tapers it (whatever the coverage inside)
        rows = np.flatnonzero(inner_rect.any(axis=1))
        cols = np.flatnonzero(inner_rect.any(axis=0))
        win = np.zeros(shape)
        win[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1] = _window(
            np.ones((len(rows), len(cols)), dtype=bool), dx_mm, taper_width_mm())
    win_sum = float(win.sum())

    def band_power(r):
        mean = float(np.sum(win * r)) / win_sum
        g = sfft.irfft2(sfft.rfft2(win * (r / mean - 1.0)) * in_band, s=shape)
        return float(np.sum(g * g)), g, mean

    q, r_cur = p.copy(), r0
    loss_planned = band_power(r0)[0]
    scale = max(loss_planned, 1e-300)
    best_q, best_loss, best_step = p, loss_planned, 0
    for step in range(1, int(steps) + 1):
        ops = _curve_operators(q, pcs, tp, keep)

        def positions(qq, ops=ops, s=s):
            out = s.copy()
            for rows, bmat, lu, a, b in ops:
                out[rows] = bmat @ lu.solve(qq[a:b])
            return out

        gap = r_cur - removal(positions(q), wc)  # the model's gap to the machine's removal, held

        def objective(z, q=q, positions=positions, gap=gap, wc=wc, ops=ops):
            qq = q.copy()
            qq[idx] = z.reshape(-1, 2)
            pts = positions(qq)
            r = removal(pts, wc) + gap
            loss, g, mean = band_power(r)
            # d loss / d r: the band filter is a projection (its adjoint on g is g), and the mean is the window's
            # mean of r: 2 win g / mean - 2 win sum(g win r) / (mean^2 sum(win))
            adj = sfft.rfft2(win * (2.0 * g / mean - 2.0 * float(np.sum(g * win * r)) / (mean * mean * win_sum)))
            grad_pts = np.zeros_like(pts)
            for j, spec in enumerate(kern.spectra):
                # the splat is a time density (divided by the pixel's area), and so is its adjoint
                back = sfft.irfft2(adj * np.conj(spec), s=shape) / (dx_mm * dx_mm)
                grad_pts += wc[j][:, None] * _bilinear_gradient(back, pts, origin, dx_mm)
            grad = np.zeros_like(qq)
            for rows, bmat, lu, a, b in ops:
                grad[a:b] = lu.solve(bmat.T @ grad_pts[rows], trans="T")
            return loss / scale, grad[idx].ravel() / scale  # in units of the planned loss: L-BFGS-B's tolerances

        lo = np.maximum(p[idx] - limits[0], q[idx] - trust).ravel()
        hi = np.minimum(p[idx] + limits[0], q[idx] + trust).ravel()
        res = optimize.minimize(objective, np.clip(q[idx].ravel(), lo, hi), jac=True, method="L-BFGS-B",
                                bounds=list(zip(lo, hi)), options={"maxiter": int(inner_iterations)})
        moved = q.copy()
        moved[idx] = res.x.reshape(-1, 2)
        q = guard.apply(moved, q)
        tp, keep, (s, w, speed, heading) = machine_run(q)
        wc = kern.coefficients(speed, heading) * w[None, :]
        r_cur = removal(s, wc)
        loss = band_power(r_cur)[0]
        if loss < best_loss:
            best_q, best_loss, best_step = q, loss, step
    d = np.hypot(*(best_q - p).T)
    stats = {"loss_planned": loss_planned, "loss": best_loss, "steps": int(steps), "best_step": best_step,
             "shift_rms_mm": float(np.sqrt(np.mean(d * d))), "shift_max_mm": float(d.max()),
             "moved_share": float(np.mean(d > 0)), "reverted": guard.reverted, "n_kernels": len(kern.spectra),
             "band_per_mm": [lo_f, hi_f], "trust_mm": trust, "max_shift_mm": limits[0],
             "min_distance_mm": limits[1], "max_step_mm": limits[2], "dx_mm": float(dx_mm)}
    return DensityFit(best_q, stats)
