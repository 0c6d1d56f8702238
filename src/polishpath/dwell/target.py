"""Target removal on a grid over the part: error - min + bias, extended past the clear aperture.

The grid is axis-aligned in the part's projected x, y (mm). Pixels inside
the part's clear aperture with measured data are the fit; pixels without data
(masked, or up to one TIF radius outside the aperture) get the **surface
extension**: each takes the value of the nearest measured pixel
(``scipy.ndimage.distance_transform_edt``), then the extension is blended
with a Gaussian of the TIF's width (normalised convolution) so it continues
the surface without a kink. Those pixels enter the fit with a small weight
(``extension_weight``), so a dwell point near the edge is neither pushed to
zero (a zero target beyond the edge) nor to huge times (nothing beyond it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..defaults import FIGURING_EXTENSION_WEIGHT
from ..errors import FiguringError
from .errormap import Alignment, ErrorMap, check_coverage, sample_error

#: largest analysis grid (pixels); a finer map is read at a coarser pitch
MAX_GRID_PIXELS = 4_000_000


@dataclass(frozen=True)
class Grid:
    """An axis-aligned grid in the part's x, y: pixel ``[i, j]`` at ``origin + (j, i) * pitch`` (mm)."""

    origin_mm: tuple[float, float]
    pitch_mm: float
    shape: tuple[int, int]

    def xy(self) -> np.ndarray:
        """(ny * nx, 2) pixel centres, mm (row-major)."""
        ny, nx = self.shape
        X, Y = np.meshgrid(self.origin_mm[0] + np.arange(nx) * self.pitch_mm,
                           self.origin_mm[1] + np.arange(ny) * self.pitch_mm)
        return np.column_stack([X.ravel(), Y.ravel()])

    def to_dict(self) -> dict[str, Any]:
        return {"origin_mm": list(self.origin_mm), "pitch_mm": self.pitch_mm, "shape": list(self.shape)}


@dataclass(frozen=True)
class Target:
    """What the dwell times must remove.

    Attributes
    ----------
    grid : Grid
    error_nm : (ny, nx) float64
        The measured error read at the grid's pixels (NaN: no data).
    inside : (ny, nx) bool
        Pixels inside the part's clear aperture.
    removal_nm : (ny, nx) float64
        Target removal (error - min + bias on measured pixels, the extension
        elsewhere within one TIF radius of the aperture; NaN beyond).
    weight : (ny, nx) float64
        Fit weight: 1 on measured aperture pixels, ``extension_weight`` on the
        extension, 0 elsewhere.
    params : dict
        ``min_error_nm``, ``bias_nm``, ``uncovered_fraction``, ``extension``, ``ca_margin_mm``.
    on_part : (ny, nx) bool, optional
        Pixels on the part (its outline seen along z, before the clear-aperture margin).
    """

    grid: Grid
    error_nm: np.ndarray
    inside: np.ndarray
    removal_nm: np.ndarray
    weight: np.ndarray
    params: dict[str, Any] = field(default_factory=dict)
    on_part: np.ndarray | None = None

    @property
    def valid(self) -> np.ndarray:
        """Measured pixels inside the clear aperture: where residual figures are taken."""
        return self.inside & np.isfinite(self.error_nm)

    def with_bias(self, extra_nm: float) -> Target:
        """The same target with ``extra_nm`` more uniform removal."""
        p = dict(self.params, bias_nm=self.params.get("bias_nm", 0.0) + extra_nm)
        return Target(self.grid, self.error_nm, self.inside, self.removal_nm + extra_nm, self.weight, p, self.on_part)

    @property
    def part_valid(self) -> np.ndarray:
        """Measured pixels on the whole part (the clear aperture and the margin around it)."""
        part = self.inside if self.on_part is None else (self.on_part | self.inside)
        return part & np.isfinite(self.error_nm)


def default_ca_margin_mm(aperture, tif_fwhm_mm: float, *, fwhms: float = 1.0, min_area_share: float = 0.25) -> float:
    """The clear-aperture margin used when none is given, mm: ``fwhms`` TIF widths (FWHM) inside the part's edge.

    Within about one FWHM of the edge a dwell point has part of its footprint off the part, and that band
    cannot be figured like the inside (docs/figuring.md, "Where the residual comes from"); a shop quotes the
    residual over the clear aperture, which the part exceeds by such a margin. On a part so small that the
    margin would leave less than ``min_area_share`` of its area, the margin is halved until it leaves that much.

    Parameters
    ----------
    aperture : shapely geometry
        The part's outline in x, y (:func:`aperture_geometry`).
    tif_fwhm_mm : float
        The TIF's full width at half maximum, mm.
    """
    area = float(aperture.area)
    m = fwhms * float(tif_fwhm_mm)
    while m > 1e-3 * math.sqrt(area) and float(aperture.buffer(-m).area) < min_area_share * area:
        m *= 0.5
    return m if m > 1e-3 * math.sqrt(area) else 0.0


def aperture_geometry(vertices: np.ndarray, faces: np.ndarray):
    """The part's clear aperture as seen along z: its boundary loops projected to x, y (shapely geometry).

    Loops combine by the even-odd rule (an annulus's inner loop is a hole).
    """
    import shapely

    from ..meshops import boundary_loops

    loops = boundary_loops(np.asarray(faces))
    if not loops:
        raise FiguringError("the part is a closed mesh: it has no clear aperture seen from above.",
                            "Figure an open part (a cut patch), as the interferometer sees it.")
    geom = None
    for lp in loops:
        xy = np.asarray(vertices)[lp][:, :2]
        if len(xy) < 3:
            continue
        poly = shapely.make_valid(shapely.Polygon(xy))
        geom = poly if geom is None else shapely.symmetric_difference(geom, poly)
    if geom is None or geom.area <= 0:
        raise FiguringError("the part's boundary encloses no area seen from above (x, y).",
                            "Orient the part so the optical axis is z.")
    return geom


def inside_geometry(geom, xy: np.ndarray) -> np.ndarray:
    """(K,) bool: which points ``xy`` (K, 2) lie in ``geom`` (boundary included)."""
    import shapely

    shapely.prepare(geom)
    return shapely.intersects_xy(geom, xy[:, 0], xy[:, 1])


def build_target(emap: ErrorMap, aperture, *, alignment: Alignment | None = None, band_mm: float,
                 pitch_mm: float | None = None, bias_nm: float = 0.0, extension_weight: float = FIGURING_EXTENSION_WEIGHT,
                 blend_sigma_mm: float | None = None, max_uncovered: float = 0.02, ca_margin_mm: float = 0.0) -> Target:
    """Read the error map over the part and turn it into the removal wanted.

    Parameters
    ----------
    emap : ErrorMap
    aperture : shapely geometry
        The part's clear aperture in x, y (:func:`aperture_geometry`).
    alignment : Alignment, optional
    band_mm : float
        How far past the aperture the extension reaches (the TIF radius), mm.
    pitch_mm : float, optional
        Grid pitch, mm (default: the map's pixel on the part, coarsened to at most
        :data:`MAX_GRID_PIXELS` pixels).
    bias_nm : float
        Uniform extra removal, nm (>= 0).
    extension_weight : float
        Fit weight of extension pixels (0..1).
    blend_sigma_mm : float, optional
        Width of the extension's Gaussian blend (default band / 5), mm.
    max_uncovered : float
        Largest share of the aperture allowed without data.
    ca_margin_mm : float
        The clear aperture is the part's outline shrunk by this much, mm: the
        figures are taken inside it and the dwell points between it and the
        part's edge get the extended target (the usual CCOS set-up, a part a
        little larger than its clear aperture).

    Returns
    -------
    Target

    Raises
    ------
    CoverageError
        The map leaves more than ``max_uncovered`` of the aperture without data.
    """
    from scipy import ndimage

    al = alignment or Alignment()
    if not (bias_nm >= 0 and math.isfinite(bias_nm)):
        raise FiguringError(f"the uniform bias must be >= 0 nm, got {bias_nm!r}.")
    x0, y0, x1, y1 = aperture.bounds
    x0, y0, x1, y1 = x0 - band_mm, y0 - band_mm, x1 + band_mm, y1 + band_mm
    h = pitch_mm if pitch_mm is not None else min(emap.dx_mm, emap.dy_mm) * al.scale
    h = max(h, math.sqrt((x1 - x0) * (y1 - y0) / MAX_GRID_PIXELS))
    nx, ny = int(math.ceil((x1 - x0) / h)) + 1, int(math.ceil((y1 - y0) / h)) + 1
    grid = Grid((x0, y0), float(h), (ny, nx))
    xy = grid.xy()
    err = sample_error(emap, xy, al).reshape(ny, nx)
    if ca_margin_mm < 0 or not math.isfinite(ca_margin_mm):
        raise FiguringError(f"the clear-aperture margin must be >= 0 mm, got {ca_margin_mm!r}.")
    on_part = inside_geometry(aperture, xy).reshape(ny, nx)
    if ca_margin_mm > 0:
        aperture = aperture.buffer(-ca_margin_mm)
        if aperture.is_empty:
            raise FiguringError(f"a clear-aperture margin of {ca_margin_mm:g} mm leaves nothing of the part.",
                                "Use a smaller [error_map] ca_margin_mm.")
    inside = inside_geometry(aperture, xy).reshape(ny, nx)
    frac = check_coverage(err.ravel(), inside.ravel(), max_uncovered, f"the error map {emap.source!r}", h)
    valid = inside & np.isfinite(err)
    if not valid.any():  # pragma: no cover - check_coverage refuses first
        raise FiguringError("no measured pixel inside the part.")
    emin = float(err[valid].min())
    # past the clear aperture the map's own data is used where it has some (within reach), else the extension
    dist_in = ndimage.distance_transform_edt(~inside) * h
    reach = dist_in <= band_mm + ca_margin_mm
    known = reach & np.isfinite(err)
    removal = np.where(known, err - emin + bias_nm, np.nan)
    fill = reach & ~known
    if fill.any():
        _, (ii, jj) = ndimage.distance_transform_edt(~known, return_indices=True)
        nearest = removal[ii, jj]
        s = (blend_sigma_mm if blend_sigma_mm is not None else band_mm / 5.0) / h
        blended = ndimage.gaussian_filter(nearest, s, mode="nearest") if s > 0.5 else nearest
        removal = np.where(fill, blended, removal)
    removal = np.where(reach, removal, np.nan)
    # fit weights: 1 on the measured clear aperture, `extension_weight` on the rest of the part (the ring
    # between the clear aperture and the edge, masked pixels); nothing past the part's edge (no material there)
    reach = on_part & ~valid
    weight = np.where(valid, 1.0, np.where(reach, extension_weight, 0.0))
    params = {"min_error_nm": emin, "bias_nm": float(bias_nm), "uncovered_fraction": frac,
              "extension": {"method": "nearest measured value + Gaussian blend", "band_mm": float(band_mm),
                            "weight": float(extension_weight)}, "ca_margin_mm": float(ca_margin_mm),
              "alignment": al.to_dict(), "grid": grid.to_dict()}
    return Target(grid, err, inside, removal, weight, params, on_part)


def rms_pv(values: np.ndarray) -> tuple[float, float]:
    """RMS about the mean and peak-to-valley of the finite values, nm."""
    v = np.asarray(values)[np.isfinite(values)]
    if v.size == 0:
        return float("nan"), float("nan")
    return float(np.sqrt(np.mean((v - v.mean()) ** 2))), float(v.max() - v.min())
