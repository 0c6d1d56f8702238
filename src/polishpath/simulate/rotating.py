"""Rotating-tool TIF whose shape depends on the feed velocity (Preston with the true relative velocity).

A tool spinning at angular velocity omega about its axis while its centre moves
at the feed velocity v removes, at an offset x from its centre (tool frame),

    R(x; v) = c * p(|x|) * | omega z x x + v |          (nm/s)

(Preston: rate = k_p * pressure * relative speed; ``c`` folds k_p in). The
relative speed is ``sqrt(omega^2 r^2 + s^2 - 2 omega r s sin(theta - phi))``
with ``s = |v|``, ``phi`` the heading and ``theta`` the polar angle of x, so
the footprint is asymmetric *across* the direction of travel: the side where
the spin runs against the feed removes more. To first order in
``s / (omega r)`` the centroid of removal moves ``s / (2 omega)`` sideways
(independent of the pressure profile), e.g. 0.21 mm at 600 mm/min and 230 rpm.

For simulation the family of kernels over all headings and speeds is written
as a short sum of fixed kernels with per-sample coefficients (low rank),

    R(x; s, phi) = c p(r) sum_m Re[ gamma_m(r, s) e^{i m theta} e^{-i m phi} ],
    gamma_m(r, s) ~ sum_l u_ml(r) w_ml(s)      (SVD over the speed range),

so a path with any mix of directions and speeds costs one FFT per term
(typically 7-15) instead of one per direction/speed bin.

Units: mm, nm, s; rpm for the spin, mm/min for feeds.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

# feed, mm/min: the job's default (middle of the 100-2000 mm/min range of small-tool polishing)
# the paper's tool (rpm), its contact radius and pressure profile: polishpath.defaults says why
from ..defaults import DEFAULT_CONTACT_RADIUS_MM, DEFAULT_FEED_MM_MIN, DEFAULT_PRESSURE, DEFAULT_RPM
from ..errors import ParameterError

#: peak removal rate at zero feed, nm/s (sets the time scale only; compare_patterns rescales it to the depth wanted)
DEFAULT_ROTATING_PEAK_RATE_NM_S = 100.0

_PRESSURES = ("parabolic", "hertz", "uniform", "gaussian")

#: bases already built, keyed by the tool, the grid, the speed table and its weights (a deterministic path
#: polished over several seeds, or the same path under several options, needs the same basis every time)
_BASIS_CACHE: "OrderedDict[tuple, RotatingBasis]" = OrderedDict()
_BASIS_CACHE_SIZE = 8


def _pressure(r: np.ndarray, R: float, kind: str) -> np.ndarray:
    """Relative contact pressure at radius r (mm) of a contact of radius R (mm); 1 at the centre."""
    if kind == "parabolic":  # Winkler foundation: a foam pressed onto the part, p ~ local compression
        return np.clip(1.0 - (r / R) ** 2, 0.0, None)
    if kind == "hertz":
        return np.sqrt(np.clip(1.0 - (r / R) ** 2, 0.0, None))
    if kind == "uniform":
        return (r <= R).astype(np.float64)
    if kind == "gaussian":  # 1/e^2 radius R, cut at 2.2 R (p < 1e-4)
        return np.where(r <= 2.2 * R, np.exp(-2.0 * (r / R) ** 2), 0.0)
    raise ParameterError(f"unknown pressure profile {kind!r}.", f"Use one of {_PRESSURES}.")


@dataclass(frozen=True)
class RotatingToolTIF:
    """TIF of a rotating tool: ``c p(r) |omega z x x + v|``, depending on the feed velocity v.

    Build with :func:`rotating_tool_tif`.

    Attributes
    ----------
    rpm : float
        Spin, revolutions per minute; positive = counter-clockwise seen from the tool side (+z).
    contact_radius_mm : float
        Radius of the contact (Hertz, uniform) or 1/e^2 radius of the pressure (Gaussian), mm.
    pressure : {"parabolic", "hertz", "uniform", "gaussian"}
        Pressure profile: ``1 - r^2/R^2`` (Winkler foundation: a foam tip
        pressed onto the part), ``sqrt(1 - r^2/R^2)`` (elastic sphere on a
        flat, Hertz), flat punch, or ``exp(-2 r^2 / R^2)``.
    peak_rate_nm_s : float
        Largest removal rate of the footprint at zero feed, nm/s.
    feed_mm_min : float
        Nominal feed, mm/min: used for :meth:`kernel` and :attr:`volume_rate`
        when the velocity is not known from a path.
    params : dict
        Everything above plus derived figures (``omega_rad_s``, ``lateral_shift_mm``).
    """

    rpm: float
    contact_radius_mm: float
    pressure: str
    peak_rate_nm_s: float
    feed_mm_min: float
    params: dict[str, Any] = field(default_factory=dict)
    kind: str = "rotating"

    # ------------------------------------------------------------------ basics
    @property
    def omega_rad_s(self) -> float:
        """Signed angular velocity, rad/s."""
        return float(self.rpm) * 2.0 * np.pi / 60.0

    @property
    def radius_mm(self) -> float:
        """Support radius of the footprint, mm."""
        return float(self.contact_radius_mm * (2.2 if self.pressure == "gaussian" else 1.0))

    @property
    def _c(self) -> float:
        """Preston factor: c p(r) |omega| r peaks at ``peak_rate_nm_s`` (zero feed)."""
        r = np.linspace(0.0, self.radius_mm, 4001)
        m = float(np.max(_pressure(r, self.contact_radius_mm, self.pressure) * abs(self.omega_rad_s) * r))
        return self.peak_rate_nm_s / m if m > 0 else 0.0

    def rate(self, x_mm, y_mm, velocity_mm_s=(0.0, 0.0)) -> np.ndarray:
        """Removal rate (nm/s) at offsets (x, y) mm from the tool centre for a feed velocity (vx, vy) mm/s."""
        x = np.asarray(x_mm, dtype=np.float64)
        y = np.asarray(y_mm, dtype=np.float64)
        w = self.omega_rad_s
        vx, vy = velocity_mm_s
        rel = np.hypot(vx - w * y, vy + w * x)
        return self._c * _pressure(np.hypot(x, y), self.contact_radius_mm, self.pressure) * rel

    def kernel_at(self, dx_mm: float, velocity_mm_s=(0.0, 0.0), oversample: int = 5) -> np.ndarray:
        """The exact TIF for one feed velocity on a grid of pitch ``dx_mm`` (odd, centred), nm/s.

        Each pixel is the mean of ``oversample^2`` sub-samples (the contact edge is sharp).
        """
        h = max(1, int(np.ceil(self.radius_mm / dx_mm)))
        sub = (np.arange(oversample) + 0.5) / oversample - 0.5
        o = (np.arange(-h, h + 1)[:, None] + sub[None, :]).ravel() * dx_mm
        X, Y = np.meshgrid(o, o)
        k = self.rate(X, Y, velocity_mm_s)
        n = 2 * h + 1
        return k.reshape(n, oversample, n, oversample).mean(axis=(1, 3))

    def kernel(self, dx_mm: float) -> np.ndarray:
        """TIF at the nominal feed travelling along +x, nm/s (see :meth:`kernel_at`)."""
        return self.kernel_at(dx_mm, (self.feed_mm_min / 60.0, 0.0))

    def volume_rate_at(self, speed_mm_s) -> np.ndarray:
        """Removed volume per second at feed speed(s) ``speed_mm_s`` (mm/s), nm mm^2/s (any heading)."""
        s = np.atleast_1d(np.asarray(speed_mm_s, dtype=np.float64))
        r, wr = _radial_grid(self.radius_mm, 1500)
        psi = np.linspace(0, 2 * np.pi, 128, endpoint=False)
        p = _pressure(r, self.contact_radius_mm, self.pressure)
        w = self.omega_rad_s
        out = np.empty(s.shape)
        for i, si in enumerate(s.ravel()):
            g = np.sqrt(np.maximum(w * w * r[:, None] ** 2 + si * si - 2 * w * r[:, None] * si * np.sin(psi)[None, :], 0))
            out.ravel()[i] = self._c * np.sum(wr * p * r * g.mean(axis=1)) * 2 * np.pi
        return out if np.ndim(speed_mm_s) else float(out[0])

    @property
    def volume_rate(self) -> float:
        """Removed volume per second at the nominal feed, nm mm^2/s."""
        return float(self.volume_rate_at(self.feed_mm_min / 60.0))

    def scaled(self, factor: float) -> "RotatingToolTIF":
        """The same tool with the Preston coefficient (all rates) multiplied by ``factor``."""
        return replace(self, peak_rate_nm_s=self.peak_rate_nm_s * float(factor),
                       params={**self.params, "peak_rate_nm_s": self.peak_rate_nm_s * float(factor)})

    def at_feed(self, feed_mm_min: float) -> "RotatingToolTIF":
        """The same tool with another nominal feed (mm/min)."""
        return rotating_tool_tif(self.rpm, self.contact_radius_mm, self.pressure, peak_rate_nm_s=self.peak_rate_nm_s,
                                 feed_mm_min=feed_mm_min)

    # ------------------------------------------------------------------ low-rank basis
    def basis(self, dx_mm: float, speed_range_mm_s: tuple[float, float], *, tol: float = 2e-3,
              sample_speeds=None, sample_times=None, max_harmonic: int = 24, n_speeds: int = 33,
              n_radii: int = 600) -> "RotatingBasis":
        """Fixed kernels and per-sample coefficient functions reproducing the TIF for any heading and speed in a range.

        Parameters
        ----------
        dx_mm : float
            Grid pitch of the kernels, mm.
        speed_range_mm_s : (float, float)
            Feed speeds to cover, mm/s.
        tol : float
            Relative L2 error of the truncation (over the footprint, RMS over the speed range,
            weighted by the time spent at each speed when ``sample_speeds`` is given).
        sample_speeds, sample_times : (M,) float, optional
            Speeds (mm/s) and times (s) of the path samples: the truncation then
            favours the speeds the path actually runs at (a grid path has only a few).
        max_harmonic : int
            Highest angular harmonic considered.
        n_speeds, n_radii : int
            Resolution of the speed and radius tables.

        Returns
        -------
        RotatingBasis
        """
        s_lo, s_hi = (float(v) for v in speed_range_mm_s)
        if not (np.isfinite(s_lo) and np.isfinite(s_hi) and 0 <= s_lo <= s_hi):
            raise ParameterError(f"bad speed range {speed_range_mm_s} mm/s.")
        speeds = np.linspace(s_lo, s_hi, n_speeds) if s_hi > s_lo else np.array([s_lo])
        ws = np.ones(len(speeds))
        if sample_speeds is not None and len(speeds) > 1:
            st = np.ones(len(sample_speeds)) if sample_times is None else np.asarray(sample_times, dtype=np.float64)
            idx = np.clip(np.rint((np.asarray(sample_speeds) - s_lo) / (speeds[1] - speeds[0])), 0, len(speeds) - 1)
            ws = np.bincount(idx.astype(np.int64), weights=st, minlength=len(speeds))
            ws = ws / max(ws.sum(), 1e-300) + 1e-2 / len(speeds)  # floor: speeds between nodes stay usable
        ws = np.sqrt(ws / ws.sum())
        key = (self.rpm, self.contact_radius_mm, self.pressure, self.peak_rate_nm_s, float(dx_mm), s_lo, s_hi,
               float(tol), int(max_harmonic), int(n_radii), speeds.tobytes(), ws.tobytes())
        hit = _BASIS_CACHE.get(key)
        if hit is not None:
            _BASIS_CACHE.move_to_end(key)
            return hit
        from threadpoolctl import threadpool_limits

        # dozens of tiny eigen-decompositions (n_speeds^2): BLAS threads only add their start-up and
        # synchronisation (measured 70x slower than one thread on a busy 2-core machine)
        with threadpool_limits(limits=1, user_api="blas"):
            out = self._basis_for_weights(dx_mm, speeds, ws, s_lo, s_hi, tol, max_harmonic, n_radii)
        _BASIS_CACHE[key] = out
        while len(_BASIS_CACHE) > _BASIS_CACHE_SIZE:
            _BASIS_CACHE.popitem(last=False)
        return out

    def _basis_for_weights(self, dx_mm, speeds, ws, s_lo, s_hi, tol, max_harmonic, n_radii) -> "RotatingBasis":
        """:meth:`basis` for a speed table and its weights (the expensive part, cached by :meth:`basis`)."""
        r, wr = _radial_grid(self.radius_mm, n_radii)
        p = _pressure(r, self.contact_radius_mm, self.pressure)
        w = self.omega_rad_s
        n_psi = 4 * (max_harmonic + 1)
        psi = np.arange(n_psi) * 2 * np.pi / n_psi
        # relative speed h(r, psi; s), psi = theta - phi; gamma_m = 2/N sum h e^{-i m psi} (m >= 1), 1/N (m = 0)
        g = np.sqrt(np.maximum(w * w * r[:, None, None] ** 2 + speeds[None, :, None] ** 2
                               - 2 * w * r[:, None, None] * speeds[None, :, None] * np.sin(psi)[None, None, :], 0.0))
        G = np.fft.rfft(g, axis=2) / n_psi  # (r, s, m)
        G[:, :, 1:] *= 2.0
        G = G[:, :, : max_harmonic + 1]
        c = self._c
        # area-weighted L2 of the kernel: |K|^2 = sum_m a_m |c p gamma_m|^2 r dr, a_0 = 2 pi, a_m = pi
        wt = c * p * np.sqrt(wr * r)
        terms = []  # (energy, m, u(r), w(s))
        Aw = wt[:, None, None] * G * ws[None, :, None]  # (r, s, m), area- and time-weighted
        energy_m = np.sum(np.abs(Aw) ** 2, axis=(0, 1)) * np.where(np.arange(Aw.shape[2]) == 0, 2 * np.pi, np.pi)
        for m in range(max_harmonic + 1):
            if energy_m[m] < 1e-2 * tol**2 * energy_m.sum():
                continue  # a whole harmonic below 1/100 of the error budget
            Gm = G[:, :, m].real if m == 0 else G[:, :, m]  # gamma_0 is real
            A = wt[:, None] * Gm * ws[None, :]
            if not np.any(A):
                continue
            # right singular vectors from the small Gram matrix (n_speeds^2; LAPACK's SVD of the tall
            # matrix is needlessly slow on a busy machine)
            lam, V = np.linalg.eigh(np.einsum("ri,rj->ij", A.conj(), A))
            order = np.argsort(lam)[::-1]
            S = np.sqrt(np.clip(lam[order], 0.0, None))
            Vh = V[:, order].conj().T
            am = 2 * np.pi if m == 0 else np.pi
            for l, sig in enumerate(S):
                if sig <= S[0] * 1e-6:
                    break
                v = Vh[l]  # A ~ sum U S Vh: row space in s
                u = Gm @ (ws * np.conj(v))  # unweighted radial function: gamma ~ sum_l u_l(r) v_l(s) / ws(s)
                terms.append((am * sig**2, m, u, v / ws))
        total = sum(t[0] for t in terms)
        terms.sort(key=lambda t: -t[0])
        kept, dropped = [], total
        for t in terms:
            if dropped <= (tol**2) * total:
                break
            kept.append(t)
            dropped -= t[0]
        h = max(1, int(np.ceil(self.radius_mm / dx_mm)))
        n = 2 * h + 1
        ov = 3  # each pixel is the mean of 3 x 3 sub-samples (the contact edge is sharp)
        sub = (np.arange(ov) + 0.5) / ov - 0.5
        o = (np.arange(-h, h + 1)[:, None] + sub[None, :]).ravel() * dx_mm
        X, Y = np.meshgrid(o, o)
        R = np.hypot(X, Y)
        TH = np.arctan2(Y, X)
        P = c * _pressure(R, self.contact_radius_mm, self.pressure)
        inside = P > 0
        Ri, THi, Pi = R[inside], TH[inside], P[inside]
        kernels, coefs = [], []

        def pix(vals):
            full = np.zeros(R.shape)
            full[inside] = vals
            return full.reshape(n, ov, n, ov).mean(axis=(1, 3))

        e1 = np.exp(1j * THi)
        e_m = {0: np.ones_like(e1)}  # e^{i m theta} by repeated multiplication, once per harmonic
        for m in range(1, max((t[1] for t in kept), default=0) + 1):
            e_m[m] = e_m[m - 1] * e1
        for _, m, u, v in kept:
            ur = np.interp(Ri, r, u.real) + 1j * np.interp(Ri, r, u.imag)
            B = Pi * ur * e_m[m]
            # kernel(x; s, phi) = Re[B(x) W], W = v(s) e^{-i m phi} = Re B Re W - Im B Im W
            kernels.append(pix(B.real))
            coefs.append((m, v, "re"))
            if m > 0:
                kernels.append(pix(-B.imag))
                coefs.append((m, v, "im"))
        # exact discrete volume per speed (for the volume check): sum over the m = 0 kernels
        return RotatingBasis(kernels, coefs, speeds, float(dropped / total) ** 0.5 if total > 0 else 0.0,
                             {"dx_mm": dx_mm, "speed_range_mm_s": [s_lo, s_hi], "tol": tol, "n_terms": len(kernels),
                              "harmonics": sorted({t[1] for t in kept})})


@dataclass
class RotatingBasis:
    """Low-rank form of a :class:`RotatingToolTIF` over headings and a speed range.

    ``TIF(x; s, phi) ~ sum_j kernels[j](x) * coefficient_j(s, phi)``.
    """

    kernels: list
    coefs: list
    speeds: np.ndarray
    rel_error: float
    params: dict

    def coefficients(self, speed_mm_s: np.ndarray, heading_rad: np.ndarray) -> np.ndarray:
        """Coefficients (n_terms, M) of the kernels for samples with speeds (M,) mm/s and headings (M,) rad."""
        s = np.clip(np.asarray(speed_mm_s, dtype=np.float64), self.speeds[0], self.speeds[-1])
        phi = np.asarray(heading_rad, dtype=np.float64)
        out = np.empty((len(self.kernels), len(s)))
        # cos(m phi), sin(m phi) for every harmonic by the angle-addition recurrence (no complex exp per term)
        m_max = max((m for m, _, _ in self.coefs), default=0)
        c1, s1 = np.cos(phi), np.sin(phi)
        cos_m, sin_m = [np.ones_like(phi)], [np.zeros_like(phi)]
        for _ in range(m_max):
            cos_m.append(cos_m[-1] * c1 - sin_m[-1] * s1)
            sin_m.append(sin_m[-1] * c1 + cos_m[-2] * s1)
        last = None  # the "re" and "im" kernels of one term share W = v(s) e^{-i m phi}
        for j, (m, wv, part) in enumerate(self.coefs):
            if last is None or last[0] is not wv:
                if len(self.speeds) > 1:
                    a = np.interp(s, self.speeds, wv.real)
                    b = np.interp(s, self.speeds, wv.imag)
                else:
                    a, b = np.full(len(s), wv[0].real), np.full(len(s), wv[0].imag)
                # W = (a + i b)(cos m phi - i sin m phi)
                last = (wv, a * cos_m[m] + b * sin_m[m], b * cos_m[m] - a * sin_m[m])
            out[j] = last[1] if part == "re" else last[2]
        return out


def _radial_grid(R: float, n: int):
    """Midpoint radii (n,) mm on [0, R] and their widths dr (n,)."""
    edges = np.linspace(0.0, R, n + 1)
    return 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)


def rotating_tool_tif(rpm: float = DEFAULT_RPM, contact_radius_mm: float = DEFAULT_CONTACT_RADIUS_MM,
                      pressure: str = DEFAULT_PRESSURE, *, peak_rate_nm_s: float = DEFAULT_ROTATING_PEAK_RATE_NM_S,
                      feed_mm_min: float = DEFAULT_FEED_MM_MIN) -> RotatingToolTIF:
    """TIF of a tool spinning at ``rpm`` whose footprint depends on the feed velocity.

    Preston removal ``c p(r) |omega z x x + v|`` (nm/s): pressure profile p over
    a contact of radius ``contact_radius_mm`` times the speed of the tool
    surface relative to the part, spin plus feed. At zero feed the footprint
    is axisymmetric (``c p(r) |omega| r``, zero at the centre); with feed it
    leans to the side where the spin runs against the feed, by about
    ``feed / (2 omega)`` mm.

    Parameters
    ----------
    rpm : float
        Spin, 1/min (the paper: 230); negative = clockwise.
    contact_radius_mm : float
        Contact radius, mm (Gaussian: 1/e^2 radius of the pressure).
    pressure : {"parabolic", "hertz", "uniform", "gaussian"}
        Pressure profile over the contact (default parabolic, a foam sponge).
    peak_rate_nm_s : float
        Largest removal rate at zero feed, nm/s.
    feed_mm_min : float
        Nominal feed, mm/min (the feed actually used in a simulation comes from
        the path and its dwell times).

    Returns
    -------
    RotatingToolTIF
    """
    if not (np.isfinite(rpm) and rpm != 0):
        raise ParameterError(f"rpm must be a non-zero number, got {rpm}.", "A tool that does not spin: use gaussian_tif.")
    if not (np.isfinite(contact_radius_mm) and contact_radius_mm > 0):
        raise ParameterError(f"contact_radius_mm must be positive, got {contact_radius_mm}.")
    if pressure not in _PRESSURES:
        raise ParameterError(f"unknown pressure profile {pressure!r}.", f"Use one of {_PRESSURES}.")
    if not (np.isfinite(peak_rate_nm_s) and peak_rate_nm_s >= 0):
        raise ParameterError(f"peak_rate_nm_s must be >= 0 nm/s, got {peak_rate_nm_s}.")
    if not (np.isfinite(feed_mm_min) and feed_mm_min >= 0):
        raise ParameterError(f"feed_mm_min must be >= 0, got {feed_mm_min}.")
    w = rpm * 2 * np.pi / 60.0
    v = feed_mm_min / 60.0
    params = {"kind": "rotating", "rpm": float(rpm), "contact_radius_mm": float(contact_radius_mm),
              "pressure": pressure, "peak_rate_nm_s": float(peak_rate_nm_s), "feed_mm_min": float(feed_mm_min),
              "omega_rad_s": float(w), "feed_over_rim_speed": float(v / (abs(w) * contact_radius_mm)),
              "lateral_shift_mm": float(v / (2 * abs(w)))}
    return RotatingToolTIF(float(rpm), float(contact_radius_mm), pressure, float(peak_rate_nm_s), float(feed_mm_min),
                           params)


def default_tif() -> RotatingToolTIF:
    """The default tool of the path comparison and of a job's simulation: the paper's sponge at 230 rpm
    (docs/simulation.md).

    Parabolic (Winkler-foam) pressure over a 2 mm contact radius, nominal feed 600 mm/min; its Preston
    coefficient is rescaled by ``polishpath.simulate.compare_patterns`` to remove the depth asked for.
    """
    return rotating_tool_tif()
