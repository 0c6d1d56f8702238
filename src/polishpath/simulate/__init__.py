"""polishpath.simulate — Preston removal along a tool path and the comparison of paths by PSD.

Units: lengths mm, heights nm, times s, removal rates nm/s, frequencies 1/mm.
"""

from .compare import (
    DEFAULT_NOISE,
    DEFAULT_SMOOTHING,
    PAPER_TABLE4,
    compare_paths,
    compare_patterns,
    default_tif,
    evaluate_result,
    format_table,
    plot_psds,
    profile_psd,
)
from .paths import random_walk_path, raster_path, rectangular_path, spiral_path
from .removal import (
    ProcessNoise,
    path_clock,
    path_motion_samples,
    SimulationResult,
    Smoothing,
    dwell_from_feed,
    path_time_samples,
    process_noise_factor,
    rasterize_time,
    simulate_removal,
    smooth_surface,
)
from .rotating import RotatingBasis, RotatingToolTIF, rotating_tool_tif
from .tif import TIF, DirectionalTIF, gaussian_tif, measured_tif, tilted_tool_tif
from .workpiece import Workpiece, flat_workpiece, synthetic_workpiece, workpiece_from_measurement

__all__ = [
    "DEFAULT_NOISE", "DEFAULT_SMOOTHING", "PAPER_TABLE4", "DirectionalTIF", "ProcessNoise", "SimulationResult",
    "Smoothing", "TIF", "Workpiece", "compare_paths", "compare_patterns", "default_tif", "dwell_from_feed", "evaluate_result",
    "flat_workpiece", "format_table", "gaussian_tif", "measured_tif", "path_time_samples", "plot_psds",
    "process_noise_factor", "profile_psd", "random_walk_path", "raster_path", "rasterize_time",
    "rectangular_path", "simulate_removal", "smooth_surface", "spiral_path", "synthetic_workpiece",
    "tilted_tool_tif", "workpiece_from_measurement", "RotatingBasis", "RotatingToolTIF", "rotating_tool_tif",
    "path_clock", "path_motion_samples",
]
