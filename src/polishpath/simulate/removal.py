"""Preston removal along a tool path: time density rasterised, convolved with the TIF by FFT.

Model (see docs/simulation.md for what it includes and leaves out):

* Preston: removal rate = k_p * pressure * velocity, folded into the TIF
  (nm/s at each offset from the tool centre), so the depth removed at x is
  ``integral TIF(x - p(t)) dt`` along the path ``p(t)``.
* The time the tool spends is given per dwell point; dwell point k owns the
  path from the middle of the segment before it to the middle of the segment
  after it, and its time is spread uniformly along that stretch (the tool
  moves continuously; the machine changes feed to honour the dwell times).
* The time density (s/mm^2) is rasterised by bilinear splatting of fine path
  samples (exactly mass-conserving) and convolved with the TIF by FFT.
* Optional process noise multiplies the removal rate along the path by
  ``1 + rms * eps(s)``, ``eps`` a unit Gaussian process of arc length ``s``
  with a Gaussian correlation of length ``correlation_length_mm``.
* Optional smoothing (a compliant tool removes more from peaks than from
  valleys): error components shorter than the tool decay exponentially with
  the depth removed (a linearised form of the parametric smoothing model of
  Tuell, Burge & Anderson 2002).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..types import Provenance
from .rotating import RotatingToolTIF
from .motion import path_clock, path_motion_samples
from .tif import TIF, DirectionalTIF
from .workpiece import Workpiece


@dataclass(frozen=True)
class ProcessNoise:
    """Removal-rate fluctuation along the path.

    Attributes
    ----------
    rms : float
        Relative RMS of the removal rate (0.05 = 5 %).
    correlation_length_mm : float
        Arc length over which the fluctuation stays correlated, mm (standard
        deviation of its Gaussian autocorrelation). Used when
        ``correlation_time_s`` is None.
    correlation_time_s : float, optional
        Correlate the fluctuation in machining *time* instead (s): the rate
        drifts with the clock (slurry supply, pad wear), whatever the path does.

    Both are correlations along the path (in the order the tool runs it),
    never in space: two places polished at very different times get
    independent rates even when they are neighbours.
    """

    rms: float = 0.05
    correlation_length_mm: float = 2.0
    correlation_time_s: float | None = None

    def __post_init__(self):
        if not (0 <= self.rms < 1):
            raise ParameterError(f"noise rms must be a fraction in [0, 1), got {self.rms}.")
        if not self.correlation_length_mm > 0:
            raise ParameterError(f"noise correlation_length_mm must be > 0, got {self.correlation_length_mm}.")
        if self.correlation_time_s is not None and not self.correlation_time_s > 0:
            raise ParameterError(f"noise correlation_time_s must be > 0 s, got {self.correlation_time_s}.")


@dataclass(frozen=True)
class Smoothing:
    """Smoothing of existing error by a compliant tool.

    A component of spatial frequency f decays by ``exp(-D / depth_nm * H(f))``
    where D is the mean depth removed and ``H(f) = 1 - exp(-(f length_mm)^2)``
    (no smoothing of errors much longer than the tool, full rate for much
    shorter ones).

    Attributes
    ----------
    depth_nm : float
        Removal depth that reduces short-wavelength error by a factor e, nm.
    length_mm : float
        Smoothing length of the tool (about its contact size), mm.
    """

    depth_nm: float = 100.0
    length_mm: float = 1.0

    def __post_init__(self):
        if not (self.depth_nm > 0 and self.length_mm > 0):
            raise ParameterError("smoothing depth_nm and length_mm must be positive.")


@dataclass(frozen=True)
class SimulationResult:
    """Outcome of one simulated polishing run on a workpiece patch.

    Attributes
    ----------
    before_nm : (Ny, Nx) float32
        Initial surface error, nm.
    after_nm : (Ny, Nx) float32
        Surface error after polishing, nm (``smoothed(before) - removal``).
    removal_nm : (Ny, Nx) float32
        Depth removed, nm.
    time_density_s_mm2 : (Ny, Nx) float32
        Tool-centre time per area, s/mm^2.
    dx_mm : float
        Pixel pitch, mm.
    origin_mm : (2,) float64
        (x, y) of pixel [0, 0], mm.
    provenance : Provenance
        stage "simulate", method "preston-fft", all parameters and the seed.
    stats : dict
        ``total_time_s``, ``time_on_grid_s``, ``removed_volume_nm_mm2``,
        ``expected_volume_nm_mm2``, ``mean_depth_nm``, ``n_samples``, timings.
    """

    before_nm: np.ndarray
    after_nm: np.ndarray
    removal_nm: np.ndarray
    time_density_s_mm2: np.ndarray
    dx_mm: float
    origin_mm: np.ndarray
    provenance: Provenance
    stats: dict[str, Any] = field(default_factory=dict)


def process_noise_factor(arc_mm: np.ndarray, noise: ProcessNoise, seed: int, clock_s: np.ndarray | None = None
                         ) -> np.ndarray:
    """Removal-rate multiplier ``max(0, 1 + rms * eps)`` along the path.

    ``eps`` is Gaussian-filtered white noise on a grid of 1/8 of the correlation
    length along the arc (mm), or of the correlation time along the machining
    clock (s) when ``noise.correlation_time_s`` is set (then ``clock_s``, the
    time at each sample, is needed), scaled to unit variance, linearly interpolated.
    """
    from scipy.ndimage import gaussian_filter1d

    rng = np.random.default_rng(seed)
    if noise.correlation_time_s is not None:
        if clock_s is None:
            raise ParameterError("a noise correlated in time needs the machining clock (clock_s).")
        arc_mm, corr = np.asarray(clock_s, dtype=np.float64), noise.correlation_time_s
    else:
        corr = noise.correlation_length_mm
    h = corr / 8.0
    n = int(np.ceil((arc_mm.max() if arc_mm.size else 0.0) / h)) + 2
    sig = (corr / np.sqrt(2.0)) / h  # filter sigma, samples
    e = gaussian_filter1d(rng.standard_normal(n), sig, mode="wrap")
    delta = np.zeros(int(8 * sig) + 1)
    delta[len(delta) // 2] = 1.0
    e /= np.sqrt(np.sum(gaussian_filter1d(delta, sig, mode="constant") ** 2))
    eps = np.interp(arc_mm / h, np.arange(n), e)
    return np.maximum(0.0, 1.0 + noise.rms * eps)


def _bilinear_cells(xy: np.ndarray, origin_mm, dx_mm: float):
    """Lower-left pixel (i0, j0) of each point and its fractions (fx, fy) in [0, 1) inside that cell."""
    gx = (xy[:, 0] - origin_mm[0]) / dx_mm
    gy = (xy[:, 1] - origin_mm[1]) / dx_mm
    i0 = np.floor(gx).astype(np.int64)
    j0 = np.floor(gy).astype(np.int64)
    return i0, j0, gx - i0, gy - j0


def rasterize_time(xy: np.ndarray, t: np.ndarray, shape: tuple[int, int], origin_mm, dx_mm: float):
    """Bilinear splat of timed samples onto a grid: time density, s/mm^2.

    Parameters
    ----------
    xy : (M, 2) float64
        Sample positions, mm.
    t : (M,) float64
        Time per sample, s.
    shape : (Ny, Nx)
        Grid shape; pixel (i, j) is centred at ``origin + (j, i) * dx``.
    origin_mm : (2,) float
    dx_mm : float

    Returns
    -------
    density : (Ny, Nx) float64
        s/mm^2; ``density.sum() * dx^2`` is the time that fell on the grid.
    time_off_grid : float
        Time of samples whose splat left the grid, s.
    """
    ny, nx = shape
    i0, j0, fx, fy = _bilinear_cells(xy, origin_mm, dx_mm)
    idx, wts = [], []
    lost = 0.0
    for di, dj, w in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)), (0, 1, (1 - fx) * fy), (1, 1, fx * fy)):
        ii, jj = i0 + di, j0 + dj
        ok = (ii >= 0) & (ii < nx) & (jj >= 0) & (jj < ny)
        idx.append(jj[ok] * nx + ii[ok])
        wts.append((t * w)[ok])
        lost += float(np.sum((t * w)[~ok]))
    # one bincount over the four corners (one grid-sized sum instead of four)
    acc = np.bincount(np.concatenate(idx), weights=np.concatenate(wts), minlength=ny * nx)
    return acc.reshape(ny, nx) / (dx_mm * dx_mm), lost


def _convolve_sum(densities: list[np.ndarray], kernels: list[np.ndarray]) -> np.ndarray:
    """sum_k densities[k] * kernels[k] ('same' size), one inverse FFT for all terms.

    Written out instead of scipy.signal.fftconvolve so that the direction sectors of
    a DirectionalTIF are summed in the frequency domain (one inverse transform).
    """
    import scipy.fft as sfft

    ny, nx = densities[0].shape
    kmax = max(k.shape[0] for k in kernels)
    sy = sfft.next_fast_len(ny + kmax - 1, real=True)
    sx = sfft.next_fast_len(nx + kmax - 1, real=True)
    acc = None
    for d, k in zip(densities, kernels):
        pad = (kmax - k.shape[0]) // 2
        kk = np.pad(k, pad) if pad else k
        term = sfft.rfft2(d.astype(np.float32), s=(sy, sx), workers=-1) * sfft.rfft2(
            kk.astype(np.float32), s=(sy, sx), workers=-1)
        acc = term if acc is None else acc + term
    full = sfft.irfft2(acc, s=(sy, sx), workers=-1)
    h = kmax // 2
    return full[h:h + ny, h:h + nx]


#: the spectrum of the last few read-only height maps smoothed (a comparison smooths one start per path)
_SPECTRUM_CACHE: list = []
_SPECTRUM_CACHE_SIZE = 2


def _smoothing_spectrum(height_nm: np.ndarray, dx_mm: float, length_mm: float):
    """``(Z, H, (py, px))``: rfft2 of the reflect-padded map and ``H(f) = 1 - exp(-(f length)^2)`` on its grid.

    Cached for read-only maps (a :class:`Workpiece`'s), which cannot change under the cache.
    """
    import scipy.fft as sfft
    import weakref

    cacheable = isinstance(height_nm, np.ndarray) and not height_nm.flags.writeable
    key = (height_nm.shape, float(dx_mm), float(length_mm))
    if cacheable:
        for ref, k, val in _SPECTRUM_CACHE:
            if ref() is height_nm and k == key:
                return val
    ny, nx = height_nm.shape
    # pad by reflection to a fast FFT size (a patch of 4001 px is prime-sized)
    py = sfft.next_fast_len(ny, real=True)
    px = sfft.next_fast_len(nx, real=True)
    z = np.pad(np.asarray(height_nm, dtype=np.float32), ((0, py - ny), (0, px - nx)), mode="reflect")
    fx = sfft.rfftfreq(px, d=dx_mm).astype(np.float32)
    fy = sfft.fftfreq(py, d=dx_mm).astype(np.float32)
    f2 = fx[None, :] ** 2 + fy[:, None] ** 2
    H = -np.expm1(-f2 * np.float32(length_mm**2))
    del f2
    val = (sfft.rfft2(z, workers=2), H, (py, px))
    if cacheable:
        _SPECTRUM_CACHE.append((weakref.ref(height_nm), key, val))
        del _SPECTRUM_CACHE[:-_SPECTRUM_CACHE_SIZE]
    return val


def smooth_surface(height_nm: np.ndarray, dx_mm: float, mean_depth_nm: float, smoothing: Smoothing) -> np.ndarray:
    """Apply the linearised smoothing of :class:`Smoothing` for a removed depth (nm).

    Parameters
    ----------
    height_nm : (Ny, Nx) float
        Surface error, nm.
    dx_mm : float
        Pixel pitch, mm.
    mean_depth_nm : float
        Mean depth removed, nm.
    smoothing : Smoothing

    Returns
    -------
    (Ny, Nx) float32
    """
    import scipy.fft as sfft

    ny, nx = np.shape(height_nm)
    Z, H, (py, px) = _smoothing_spectrum(height_nm, dx_mm, smoothing.length_mm)
    gain = H * np.float32(-(mean_depth_nm / smoothing.depth_nm))
    np.exp(gain, out=gain)
    out = sfft.irfft2(Z * gain, s=(py, px), workers=2, overwrite_x=True)[:ny, :nx]  # Z itself stays cached
    return np.ascontiguousarray(out, dtype=np.float32)


def _splat_matrix(xy: np.ndarray, shape: tuple[int, int], origin_mm, dx_mm: float, weights=None, columns=None,
                  n_columns: int | None = None):
    """The bilinear splat of :func:`rasterize_time` as a sparse (Ny * Nx, n_columns) matrix.

    Without ``weights`` / ``columns``: (Ny * Nx, M), ``S @ t`` = time per pixel, s. With them, sample m's
    corner weights are multiplied by ``weights[m]`` and land in column ``columns[m]`` (duplicates summed),
    so ``S @ c`` splats ``weights * c[columns]``: many samples sharing one coefficient (the sub-samples of
    one move) cost one column. Corners off the grid are dropped, as :func:`rasterize_time` does.
    """
    from scipy.sparse import csr_matrix

    ny, nx = shape
    i0, j0, fx, fy = _bilinear_cells(xy, origin_mm, dx_mm)
    rows, cols, vals = [], [], []
    m = np.arange(len(xy)) if columns is None else np.asarray(columns)
    wt = 1.0 if weights is None else np.asarray(weights, dtype=np.float64)
    for di, dj, w in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)), (0, 1, (1 - fx) * fy), (1, 1, fx * fy)):
        ii, jj = i0 + di, j0 + dj
        ok = (ii >= 0) & (ii < nx) & (jj >= 0) & (jj < ny)
        rows.append(jj[ok] * nx + ii[ok])
        cols.append(m[ok])
        vals.append((w * wt)[ok])
    ncol = len(xy) if n_columns is None else int(n_columns)
    return csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(ny * nx, ncol))


def _touches_grid(xy: np.ndarray, shape: tuple[int, int], origin_mm, dx_mm: float, margin_px: float = 0.0
                  ) -> np.ndarray:
    """(M,) bool: the samples whose bilinear splat can put time on the grid (the others add nothing to it).

    ``margin_px`` widens the box by that many pixels each way (a cheap superset: the splat drops the extra
    samples' corners off the grid anyway).
    """
    ny, nx = shape
    x, y = xy[:, 0], xy[:, 1]
    if margin_px > 0:  # four comparisons, no floor
        m = (1.0 + margin_px) * dx_mm
        x0, y0 = float(origin_mm[0]), float(origin_mm[1])
        return (x >= x0 - m) & (x < x0 + nx * dx_mm + m) & (y >= y0 - m) & (y < y0 + ny * dx_mm + m)
    i0, j0, _, _ = _bilinear_cells(xy, origin_mm, dx_mm)
    return (i0 >= -1) & (i0 < nx) & (j0 >= -1) & (j0 < ny)


def _runs(*keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Runs of consecutive samples equal in every key: ``(run index (M,), first sample of each run (G,))``."""
    n = len(keys[0])
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    new = np.zeros(n, dtype=bool)
    new[0] = True
    for k in keys:
        new[1:] |= k[1:] != k[:-1]
    return np.cumsum(new) - 1, np.flatnonzero(new)


class _PaddedRfft2:
    """``rfft2(a, s=(sy, sx))`` of arrays of at most (ny, nx) in two passes, in reused zero-padded buffers.

    The padding rows are not transformed along x, and no padded copy is allocated per call.
    """

    def __init__(self, ny: int, nx: int, sy: int, sx: int):
        self.ny, self.nx, self.sy, self.sx = ny, nx, sy, sx
        self.real = np.zeros((ny, sx), dtype=np.float32)
        self.spec = np.zeros((sy, sx // 2 + 1), dtype=np.complex64)

    def __call__(self, a: np.ndarray) -> np.ndarray:
        import scipy.fft as sfft

        n, m = a.shape
        self.real[:n, :m] = a
        self.real[:n, m:] = 0.0
        self.spec[:n] = sfft.rfft(self.real[:n], axis=1, workers=2)
        self.spec[n:] = 0.0
        return sfft.fft(self.spec, axis=0, workers=2)


def _upsample_crop(acc: np.ndarray, sy: int, sx: int, q: int, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
    """Rows r0:r1, columns c0:c1 of ``irfft2`` of the half spectrum ``acc`` (sy, sx//2+1) zero-padded to (q sy, q sx).

    The same numbers as building the zero-padded (q sy, q sx // 2 + 1) spectrum and inverting it in 2D, but
    only the columns that carry the coarse spectrum are transformed along y, and only the rows kept along x
    (the padding is zeros, so most of the 2D transform's work is skipped).
    """
    import scipy.fft as sfft

    Sy, Sx = q * sy, q * sx
    ncol = sx // 2 + 1 if sx % 2 else sx // 2  # drop the Nyquist column / row
    npos = (sy + 1) // 2
    nneg = (sy - 1) // 2
    col = np.zeros((Sy, ncol), dtype=np.complex64)
    col[:npos] = acc[:npos, :ncol]
    if nneg:
        col[Sy - nneg:] = acc[sy - nneg:, :ncol]
    rows = sfft.ifft(col, axis=0, workers=2)[r0:r1]  # (r1 - r0, ncol): y done, rows outside the crop dropped
    del col
    # irfft along x zero-pads the missing columns; scale as one 2D inverse of size (Sy, Sx)
    full = sfft.irfft(rows, n=Sx, axis=1, workers=2)[:, c0:c1]
    return full


def _coarse_factor(tif: RotatingToolTIF, dx: float, removal_dx_mm: float | None) -> int:
    """q: a rotating tool's removal is convolved on a grid of pitch q dx (``removal_dx_mm`` rounded down to a
    multiple of the pixel; automatic: 1/100 of the contact radius, at most 20 um)."""
    if removal_dx_mm is None:
        removal_dx_mm = min(0.02, tif.contact_radius_mm / 100.0)
    return max(1, int(np.floor(removal_dx_mm / dx + 1e-9)))


def _rotating_removal(xy, t, speed, heading, shape, origin_mm, dx: float, tif: RotatingToolTIF,
                      removal_dx_mm: float | None, tol: float, basis_times=None, near=None):
    """Removal (nm) of a :class:`RotatingToolTIF` with each sample's own feed velocity.

    The TIF family is expanded in fixed kernels (:meth:`RotatingToolTIF.basis`);
    each kernel's weighted time density is splatted on a grid of pitch
    ``removal_dx_mm`` (an integer multiple q of ``dx``), all products are summed
    in the frequency domain and, for q > 1, brought to the fine grid by
    zero-padding the spectrum (exact for content below the coarse Nyquist
    frequency; the TIF passes nothing above it) with the bilinear splat's
    transfer function corrected to that of the fine grid. ``basis_times``
    (default ``t``) weights the speeds the basis has to reproduce best. ``near``
    (M,) bool, optional: a superset of the samples that reach the coarse grid
    (:func:`_touches_grid`); only they are splatted.
    """
    import scipy.fft as sfft

    ny, nx = shape
    q = _coarse_factor(tif, dx, removal_dx_mm)
    dxc = q * dx
    nyc, nxc = (ny - 1 + q - 1) // q + 1, (nx - 1 + q - 1) // q + 1
    on = t > 0
    sp = speed[on]
    s_lo, s_hi = (float(sp.min()), float(sp.max())) if sp.size else (0.0, 0.0)
    bt = t if basis_times is None else basis_times
    basis = tif.basis(dxc, (s_lo, s_hi), tol=tol, sample_speeds=sp, sample_times=bt[on])
    del on, sp, bt
    # Only the samples that reach the coarse grid (which covers the fine one) remove anything here: on a
    # patch of a large part most of the path is elsewhere. The basis above was fitted to the whole path.
    if near is None:
        near = _touches_grid(xy, (nyc, nxc), origin_mm, dxc)
    xy, t, speed, heading = xy[near], t[near], speed[near], heading[near]
    # A sample's coefficients depend only on its speed and heading, the same along each move (a run of
    # samples): the coefficients are computed once per run, the splat sums each run's time per pixel.
    run, first = _runs(speed, heading)
    C = basis.coefficients(speed[first], heading[first])  # (n_terms, runs)
    kmax = basis.kernels[0].shape[0]
    sy = sfft.next_fast_len(nyc + kmax - 1, real=True)
    sx = sfft.next_fast_len(nxc + kmax - 1, real=True)
    S = _splat_matrix(xy, (nyc, nxc), origin_mm, dxc, weights=t, columns=run, n_columns=len(first))
    del xy, t, speed, heading, run, first
    acc = np.zeros((sy, sx // 2 + 1), dtype=np.complex64)
    fft_d = _PaddedRfft2(nyc, nxc, sy, sx)
    fft_k = _PaddedRfft2(kmax, kmax, sy, sx)
    chunk = 8  # terms splatted per sparse product (bounds the dense block to 8 coarse grids)
    for j0 in range(0, len(basis.kernels), chunk):
        j1 = min(len(basis.kernels), j0 + chunk)
        D = (S @ C[j0:j1].T).astype(np.float32)  # (nyc * nxc, j1 - j0), s per coarse pixel
        for j in range(j0, j1):
            term = fft_d(D[:, j - j0].reshape(nyc, nxc))
            term *= fft_k(basis.kernels[j])
            acc += term
        del D
    acc *= np.float32(1.0 / (dxc * dxc))  # time per pixel -> time density, s/mm^2
    h = kmax // 2
    if q == 1:
        full = sfft.irfft2(acc, s=(sy, sx), workers=2)
        return (full[h:h + ny, h:h + nx] * dx * dx).astype(np.float32), basis, q
    fy = sfft.fftfreq(sy, d=dxc)
    fx = sfft.rfftfreq(sx, d=dxc)
    corr_y = (np.sinc(fy * dx) / np.sinc(fy * dxc)) ** 2
    corr_x = (np.sinc(fx * dx) / np.sinc(fx * dxc)) ** 2
    acc *= (corr_y[:, None] * corr_x[None, :]).astype(np.float32)
    H = h * q
    full = _upsample_crop(acc, sy, sx, q, H, H + ny, H, H + nx)
    full *= np.float32(q * q * dxc * dxc)
    return np.ascontiguousarray(full, dtype=np.float32), basis, q


def simulate_removal(path_xy, dwell_s, workpiece: Workpiece, tif: TIF | DirectionalTIF | RotatingToolTIF, *,
                     noise: ProcessNoise | None = None, smoothing: Smoothing | None = None, seed: int = 0,
                     pieces=None, sample_step_mm: float | None = None,
                     time_model: str = "segments", machine: dict | None = None,
                     removal_dx_mm: float | None = None, basis_tol: float = 2e-3) -> SimulationResult:
    """Simulate polishing a workpiece patch along a path (Preston removal, FFT convolution).

    Parameters
    ----------
    path_xy : (N, 2) float
        Dwell points in path order, mm, in the workpiece's plane.
    dwell_s : (N,) float
        Time per dwell point, s (see :func:`dwell_from_feed` for constant feed).
    workpiece : Workpiece
        Initial surface error and the grid.
    tif : TIF, DirectionalTIF or RotatingToolTIF
        Removal rate around the tool, nm/s; a DirectionalTIF splits the path
        by direction of travel; a RotatingToolTIF removes with each path
        sample's own feed velocity (direction and speed).
    noise : ProcessNoise, optional
        Removal-rate fluctuation along the path (seeded by ``seed``).
    smoothing : Smoothing, optional
        Decay of the initial error with the depth removed; None = pure Preston removal.
    seed : int
        Seed of the process noise (recorded even when unused).
    pieces : (K+1,) int, optional
        Continuous pieces of the path (tool lifts in between).
    sample_step_mm : float, optional
        Path sampling step, mm (default half a pixel).
    time_model : {"segments", "points", "machine"}
        Continuous motion (time spread along the path, default),
        stop-and-dwell at the points, or the NURBS-smoothed path at a constant
        interpolation period; see :func:`path_motion_samples`.
    machine : dict, optional
        Options of the ``"machine"`` time model (period_ms, chord_tol_mm, max_feed_factor).
    removal_dx_mm : float, optional
        RotatingToolTIF only: pitch of the grid the removal is convolved on, mm
        (rounded down to a multiple of the pixel; default min(20 um, contact
        radius / 100)); the result is brought to the pixel grid spectrally.
    basis_tol : float
        RotatingToolTIF only: relative L2 truncation error of its kernel expansion.

    Returns
    -------
    SimulationResult
    """
    t0 = time.perf_counter()
    dx = workpiece.dx_mm
    step = sample_step_mm or dx / 2
    xy, t, heading, arc, length, motion = path_motion_samples(path_xy, dwell_s, step, pieces, time_model, machine)
    with np.errstate(divide="ignore", invalid="ignore"):
        speed = np.where(t > 0, length / t, 0.0)  # mm/s, before the rate noise (it is not a speed change)
    t_motion = t  # the time at each speed, before the rate noise: what the kernel basis must reproduce
    if noise is not None and noise.rms > 0:
        t = t * process_noise_factor(arc, noise, seed, clock_s=path_clock(arc, t))
    t1 = time.perf_counter()
    shape = workpiece.shape
    rot_info = None
    if isinstance(tif, RotatingToolTIF):
        # the samples near the patch (a box wide enough to hold all that reach the fine or the coarse grid):
        # the rest put no time on it
        # (the coarse grid of q pixels reaches at most 2 q - 2 pixels beyond the fine one)
        near = _touches_grid(xy, shape, workpiece.origin_mm, dx,
                             margin_px=2.0 * _coarse_factor(tif, dx, removal_dx_mm) + 1.0)
        total_density, lost = rasterize_time(xy[near], t[near], shape, workpiece.origin_mm, dx)
        lost += float(t[~near].sum())
        on_grid = total_density.sum() * dx * dx
        # expected volume: exact volume rate at each sample's speed (table over the speeds present)
        on = t > 0
        tab = np.linspace(speed[on].min(), speed[on].max(), 17) if on.any() else np.zeros(1)
        vr = np.interp(speed, tab, np.atleast_1d(tif.volume_rate_at(tab))) if len(tab) > 1 else \
            np.full(len(t), tif.volume_rate_at(float(tab[0])))
        tt = float(t.sum())
        expected = float(np.sum(t * vr)) * (on_grid / tt if tt > 0 else 0.0)
        t2 = time.perf_counter()
        removal, basis, q = _rotating_removal(xy, t, speed, heading, shape, workpiece.origin_mm, dx, tif,
                                              removal_dx_mm, basis_tol, basis_times=t_motion, near=near)
        del near
        rot_info = {"n_terms": basis.params["n_terms"], "harmonics": basis.params["harmonics"],
                    "truncation_rel_error": basis.rel_error, "removal_dx_mm": q * dx,
                    "speed_range_mm_s": basis.params["speed_range_mm_s"],
                    "mean_speed_mm_s": float(np.sum(t * speed) / tt) if tt > 0 else 0.0}
        groups = [None] * basis.params["n_terms"]
        t3 = time.perf_counter()
    elif isinstance(tif, DirectionalTIF):
        sec = tif.sector(heading)
        groups = [(tif.tifs[k], sec == k) for k in range(len(tif.tifs)) if np.any(sec == k)]
    elif isinstance(tif, TIF):
        groups = [(tif, slice(None))]
    else:
        raise ParameterError(f"tif must be a TIF, DirectionalTIF or RotatingToolTIF, got {type(tif).__name__}.",
                             "Build one with gaussian_tif(), measured_tif(), tilted_tool_tif() or rotating_tool_tif().")
    if rot_info is None:
        densities, kernels = [], []
        lost = 0.0
        expected = 0.0
        total_density = np.zeros(shape)
        for g, m in groups:
            d, l = rasterize_time(xy[m], t[m], shape, workpiece.origin_mm, dx)
            lost += l
            densities.append(d)
            kernels.append(g.kernel(dx))
            expected += g.volume_rate * float(d.sum() * dx * dx)
            total_density += d
        t2 = time.perf_counter()
        removal = (_convolve_sum(densities, kernels) * (dx * dx)).astype(np.float32)
        t3 = time.perf_counter()
    effective_time, n_samples = float(np.sum(t)), int(len(t))
    del xy, t, heading, arc, length, speed, t_motion  # the path samples: not needed from here on
    sub = removal[::4, ::4]  # a quarter of the pixels each way is plenty for these statistics
    thr = 0.5 * float(np.percentile(sub, 99.5))
    mean_depth = float(np.median(sub[sub > thr])) if thr > 0 else 0.0
    before = np.asarray(workpiece.height_nm, dtype=np.float32)
    base = smooth_surface(before, dx, mean_depth, smoothing) if smoothing is not None else before
    after = np.subtract(base, removal, dtype=np.float32)
    t4 = time.perf_counter()
    tif_params = ({"kind": "directional", **tif.params} if isinstance(tif, DirectionalTIF)
                  else {"kind": tif.kind, **{k: v for k, v in tif.params.items()}})
    if machine:
        params_machine = dict(machine)
    else:
        params_machine = None
    params = {
        "tif": tif_params, "noise": None if noise is None else vars(noise).copy(),
        "smoothing": None if smoothing is None else vars(smoothing).copy(),
        "time_model": time_model, "machine": params_machine, "removal_dx_mm": removal_dx_mm, "basis_tol": basis_tol,
        "dx_mm": dx, "grid_shape": list(shape), "origin_mm": workpiece.origin_mm.tolist(), "sample_step_mm": step,
        "n_path_points": int(len(np.asarray(path_xy))), "workpiece": workpiece.provenance.to_dict(),
    }
    stats = {
        "total_time_s": float(np.sum(dwell_s)), "effective_time_s": effective_time, "time_on_grid_s": float(total_density.sum() * dx * dx),
        "time_off_grid_s": lost, "removed_volume_nm_mm2": float(removal.sum(dtype=np.float64) * dx * dx),
        "expected_volume_nm_mm2": expected, "mean_depth_nm": mean_depth, "n_samples": n_samples,
        "n_direction_groups": len(groups), "rotating": rot_info, "motion": motion,
        "timings_s": {"sample": t1 - t0, "rasterize": t2 - t1, "convolve": t3 - t2, "smooth": t4 - t3,
                      "total": t4 - t0},
    }
    return SimulationResult(before, after, removal, total_density.astype(np.float32), dx, workpiece.origin_mm.copy(),
                            Provenance("simulate", "preston-fft", params, seed=seed), stats)
