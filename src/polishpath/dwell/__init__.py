"""polishpath.dwell — deterministic figuring: dwell times from a measured surface error.

Stage between map and smooth: ``SurfacePath --dwell--> times`` for its dwell
points, solved from a measured error map and a tool influence function (TIF),
so that the removal the path delivers cancels the error (see docs/figuring.md).

Units: lengths mm, heights nm, times s, removal rates nm/s.
"""

from .api import Figuring, figure_dwell_times, figuring_summary, predict_residual
from .delivery import region_centroids, region_times
from .errormap import Alignment, ErrorMap, read_error_map, sample_error, zernike_error_map, zernike_surface
from .solver import DEFAULT_SMOOTHNESS, DwellSolution, minimum_times, removal_map, solve_dwell
from .target import Grid, Target, aperture_geometry, build_target, rms_pv
from .tif import (
    DEFAULT_FWHM_MM,
    DEFAULT_PEAK_RATE_NM_S,
    FWHM_PER_SIGMA,
    TIF,
    gaussian_tif,
    measured_tif,
    parse_tif_spec,
    tif_from_spec,
)

__all__ = [
    "TIF", "gaussian_tif", "measured_tif", "parse_tif_spec", "tif_from_spec",
    "DEFAULT_FWHM_MM", "DEFAULT_PEAK_RATE_NM_S", "FWHM_PER_SIGMA",
    "ErrorMap", "Alignment", "read_error_map", "sample_error", "zernike_error_map", "zernike_surface",
    "Grid", "Target", "aperture_geometry", "build_target", "rms_pv",
    "DEFAULT_SMOOTHNESS", "DwellSolution", "minimum_times", "removal_map", "solve_dwell",
    "Figuring", "region_centroids", "region_times", "figure_dwell_times", "predict_residual", "figuring_summary",
]
