"""polishpath.psd — power spectral density of profiles and maps (ISO 10110-8), measured-data readers.

Units: heights nm, lengths mm, spatial frequency 1/mm (the paper's band
10^3-10^5 1/m is ``PAPER_BAND_PER_MM = (1, 100)``).
"""

from .analyze import analyze_file, compare_files, measurement_psd
from .core import (
    PAPER_BAND_PER_MM,
    PSD,
    PSD2D,
    band_average,
    band_coverage,
    band_rms,
    detrend_map,
    detrend_profiles,
    find_peaks,
    psd_1d,
    psd_2d,
    radial_psd,
    suppression_ratio,
    window_1d,
)
from .io import Measurement, MeasurementFileError, read_measurement, write_datx_like

__all__ = [
    "PAPER_BAND_PER_MM", "PSD", "PSD2D", "Measurement", "MeasurementFileError", "analyze_file", "band_average",
    "band_coverage", "band_rms", "compare_files", "detrend_map", "detrend_profiles", "find_peaks",
    "measurement_psd", "psd_1d", "psd_2d", "radial_psd", "read_measurement", "suppression_ratio", "window_1d",
    "write_datx_like",
]
