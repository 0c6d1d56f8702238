"""polishpath.simulate — Preston removal along a tool path and the comparison of paths by PSD.

Units: lengths mm, heights nm, times s, removal rates nm/s, frequencies 1/mm.
"""

from .compare import (
    DEFAULT_NOISE,
    DEFAULT_SMOOTHING,
    MODES,
    PAPER_TABLE4,
    compare_paths,
    compare_planned,
    default_tif,
    evaluate_result,
    format_table,
    plot_psds,
    profile_psd,
)
from .fair import (
    FairMetrics,
    band_rms_nm,
    detrend_residual,
    fair_metrics,
    lattice_frequencies,
    lattice_peak_db,
    pvn,
    ripple_amplitude,
)
from .motion import TIME_MODELS, dwell_from_feed, path_clock, path_motion_samples, path_time_samples
from .removal import (
    ProcessNoise,
    SimulationResult,
    Smoothing,
    process_noise_factor,
    rasterize_time,
    simulate_removal,
    smooth_surface,
)
from .rotating import RotatingBasis, RotatingToolTIF, rotating_tool_tif
from .tif import TIF, DirectionalTIF, gaussian_tif, measured_tif, tilted_tool_tif
from .jobfiles import format_job_table, write_job_outputs
from .jobpath import PLANES, TIMINGS, TimedPath, choose_plane, simulate_job, simulate_path, timed_path
from .jobfiles import is_simulation_folder
from .machinetime import machine_timed_path
from .patterns import compare_patterns
from .mechanisms import MECHANISMS, Mechanisms, parse_mechanisms
from .spread import FAIR_KEYS, rank
from .workpiece import Workpiece, flat_workpiece, synthetic_workpiece, workpiece_from_measurement

__all__ = [
    "DEFAULT_NOISE", "DEFAULT_SMOOTHING", "PAPER_TABLE4", "DirectionalTIF", "ProcessNoise", "SimulationResult",
    "Smoothing", "TIF", "Workpiece", "compare_paths", "compare_patterns", "compare_planned", "default_tif", "dwell_from_feed", "evaluate_result",
    "flat_workpiece", "format_table", "gaussian_tif", "is_simulation_folder", "measured_tif", "path_time_samples", "plot_psds",
    "process_noise_factor", "profile_psd", "rasterize_time",
    "simulate_removal", "smooth_surface", "synthetic_workpiece",
    "tilted_tool_tif", "workpiece_from_measurement", "RotatingBasis", "RotatingToolTIF", "rotating_tool_tif",
    "path_clock", "path_motion_samples", "TIME_MODELS", "PLANES", "TIMINGS", "TimedPath", "choose_plane",
    "simulate_job", "simulate_path", "timed_path", "format_job_table", "write_job_outputs",
    "FairMetrics", "band_rms_nm", "detrend_residual", "fair_metrics", "lattice_frequencies", "lattice_peak_db",
    "pvn", "ripple_amplitude",
    "MODES", "MECHANISMS", "Mechanisms", "parse_mechanisms", "machine_timed_path", "FAIR_KEYS", "rank",
]
