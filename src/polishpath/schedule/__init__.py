"""polishpath.schedule — the feed schedule under a machine profile (between smoothing and export).

* :class:`MachineProfile`, :func:`load_machine` (``--machine machine.toml`` or
  the built-in ``generic-3axis``): feed, per-axis velocity and acceleration
  limits, interpolation period, post-processor.
* :class:`Kinematics` (:mod:`.kinematics`): a 5-axis profile's table-tilting
  kinematics (LinuxCNC's ``xyzac-trt``, ``xyzbc-trt``), inverse kinematics with a
  continuous branch, rotary ranges and limits.
* :func:`schedule_feeds`: the fastest speeds along the sampled path that keep
  every limit (backward and forward pass), the delivered time of every dwell
  point against its planned time.

See ``docs/machine-output.md``.
"""

from .feeds import dwell_point_times, schedule_feeds, segment_limits
from .kinematics import BUILTIN_KINEMATICS, KINEMATICS_TYPES, Kinematics
from .machine import BUILTIN_MACHINES, MachineProfile, load_machine

__all__ = ["MachineProfile", "BUILTIN_MACHINES", "load_machine", "schedule_feeds", "segment_limits",
           "dwell_point_times", "Kinematics", "KINEMATICS_TYPES", "BUILTIN_KINEMATICS"]
