"""polishpath.report — a self-contained HTML report and PNG figures of a finished run.

:func:`write_report` reads a run folder (``summary.json``, ``run.npz``, and
``simulation/`` when present) and writes ``report.html`` (one file, opens
offline: plotly.js and every image embedded) and ``figures/*.png``
(matplotlib, for papers and slides). It needs no in-memory job, so
``polishpath report DIR`` rebuilds the report of any past run.

The helpers that derive the plotted quantities from the arrays are public too:
:func:`step_lengths`, :func:`grid_directions`, :func:`turn_angles_deg`,
:func:`angle_error_deg`, :func:`area_distortion`.
"""

from .html import build_html, write_report
from .rundata import (
    DIRECTION_NAMES,
    RunData,
    angle_error_deg,
    area_distortion,
    grid_directions,
    load_run,
    step_lengths,
    turn_angles_deg,
)

__all__ = [
    "DIRECTION_NAMES", "RunData", "angle_error_deg", "area_distortion", "build_html", "grid_directions",
    "load_run", "step_lengths", "turn_angles_deg", "write_report",
]
