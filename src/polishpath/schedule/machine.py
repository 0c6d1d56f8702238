"""Machine profiles: the limits of the axes a feed schedule must respect.

A profile is a ``[machine]`` table in a TOML file (``--machine machine.toml``)
or a built-in name (``generic-3axis``). Units: feeds and velocities in mm/min
(as on a controller), accelerations in mm/s^2 (1 m/s^2 = 1000 mm/s^2), jerk in
mm/s^3, the interpolation period in ms::

    [machine]
    name = "my-mill"
    post = "linuxcnc"                          # post-processor for this controller
    max_feed_mm_min = 10000                    # tangential feed limit
    max_velocity_mm_min = [10000, 10000, 5000] # X, Y, Z
    max_acceleration_mm_s2 = [1000, 1000, 500] # X, Y, Z
    max_tangential_acceleration_mm_s2 = 1000   # optional
    max_jerk_mm_s3 = [20000, 20000, 10000]     # optional: recorded, not enforced
    period_ms = 4.0                            # interpolation period

    [machine.kinematics]                       # optional: a 5-axis machine (schedule/kinematics.py)
    type = "xyzac-trt"                         # LinuxCNC's module: xyzac-trt or xyzbc-trt
    rot_point_mm = [0, 0, 0]                   # x/y/z-rot-point: the C axis' centre
    offset_mm = [0, -50]                       # y-offset, z-offset (xyzbc: x-offset, z-offset)
    tilt_range_deg = [-120, 120]               # A (or B)
    c_range_deg = [-360, 360]                  # optional; left out: continuous C
    max_velocity_deg_min = [5400, 10800]       # A (or B), C
    max_acceleration_deg_s2 = [360, 720]       # A (or B), C
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import SpecError
from .kinematics import BUILTIN_KINEMATICS, Kinematics, kinematics_from_table, settings_from_table

__all__ = ["MachineProfile", "BUILTIN_MACHINES", "load_machine"]


@dataclass(frozen=True)
class MachineProfile:
    """Limits of a 3-axis machine.

    Attributes
    ----------
    name : str
    post : str
        Post-processor (``polishpath.export.post``) for this machine's controller.
    max_feed_mm_min : float
        Largest tangential feed, mm/min.
    max_velocity_mm_min : (3,) tuple of float
        Largest velocity of each axis X, Y, Z, mm/min.
    max_acceleration_mm_s2 : (3,) tuple of float
        Largest acceleration of each axis, mm/s^2.
    max_tangential_acceleration_mm_s2 : float or None
        Largest acceleration along the path, mm/s^2 (None: only the per-axis limits).
    max_jerk_mm_s3 : (3,) tuple of float or None
        Per-axis jerk, mm/s^3, where known. Recorded in the summary; the schedule
        does not enforce it (a controller's own jerk limit smooths within the
        acceleration envelope).
    period_ms : float
        Interpolation period, ms: the job samples the path at this period, so no
        block is shorter in time than the controller can run.
    kinematics : Kinematics or None
        A 5-axis machine's kinematics (:mod:`polishpath.schedule.kinematics`: LinuxCNC's
        ``xyzac-trt`` / ``xyzbc-trt``, rotary ranges and limits); None: a 3-axis machine. With
        kinematics, the X Y Z limits are the joints' (the machine's axes, not the tool point's).
    """

    name: str = "generic-3axis"
    post: str = "linuxcnc"
    max_feed_mm_min: float = 10_000.0
    max_velocity_mm_min: tuple[float, float, float] = (10_000.0, 10_000.0, 5_000.0)
    max_acceleration_mm_s2: tuple[float, float, float] = (1_000.0, 1_000.0, 500.0)
    max_tangential_acceleration_mm_s2: float | None = None
    max_jerk_mm_s3: tuple[float, float, float] | None = None
    period_ms: float = 4.0
    kinematics: Kinematics | None = None

    def __post_init__(self):
        where = f"machine profile {self.name!r}"
        if self.kinematics is not None and not isinstance(self.kinematics, Kinematics):
            object.__setattr__(self, "kinematics", kinematics_from_table(self.kinematics, where))
        if not isinstance(self.name, str) or not isinstance(self.post, str):
            raise SpecError(f"{where}: name and post must be text.")
        for key in ("max_feed_mm_min", "period_ms"):
            _positive(getattr(self, key), f"{where}: {key}")
        if self.max_tangential_acceleration_mm_s2 is not None:
            _positive(self.max_tangential_acceleration_mm_s2, f"{where}: max_tangential_acceleration_mm_s2")
        for key in ("max_velocity_mm_min", "max_acceleration_mm_s2", "max_jerk_mm_s3"):
            v = getattr(self, key)
            if v is None and key == "max_jerk_mm_s3":
                continue
            if not isinstance(v, (list, tuple)) or len(v) != 3:
                raise SpecError(f"{where}: {key} must be three numbers (X, Y, Z), got {v!r}.")
            for x in v:
                _positive(x, f"{where}: {key}")
            object.__setattr__(self, key, tuple(float(x) for x in v))

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def _positive(v, what: str) -> None:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
        raise SpecError(f"{what} must be a positive number, got {v!r}.")


#: built-in profiles. ``generic-3axis``: a small 3-axis polishing machine as commonly set up
#: (1 m/s^2 on X and Y, half that on the heavier Z, 10 m/min), the middle of the 0.2-5 m/s^2
#: range the benchmark compares (benchmarks/bench_machine.py).
#: ``xyzac-trt`` / ``xyzbc-trt``: the same linear axes with a trunnion table of LinuxCNC's trt kinematics
#: (:data:`polishpath.schedule.kinematics.BUILTIN_KINEMATICS`).
BUILTIN_MACHINES: dict[str, MachineProfile] = {
    "generic-3axis": MachineProfile(),
    **{k: MachineProfile(name=k, kinematics=kin) for k, kin in BUILTIN_KINEMATICS.items()},
}


def load_machine(spec: str | Path | MachineProfile) -> MachineProfile:
    """A profile from a built-in name or a TOML file (``[machine]`` table, or top-level keys)."""
    if isinstance(spec, MachineProfile):
        return spec
    if str(spec) in BUILTIN_MACHINES:
        return BUILTIN_MACHINES[str(spec)]
    p = Path(spec)
    if not p.is_file():
        raise SpecError(f"machine profile {spec!s} is neither a built-in ({', '.join(BUILTIN_MACHINES)}) nor a file.",
                        "Give a machine TOML file (see examples/machine-*.toml) or --machine generic-3axis.")
    from ..runfolder import read_toml

    data = read_toml(p, "machine profile")
    table = data.get("machine", data)
    if not isinstance(table, dict):
        raise SpecError(f"{p.name}: [machine] must be a table of limits.")
    return settings_from_table(MachineProfile, {"name": p.stem, **table}, p.name, "machine")
