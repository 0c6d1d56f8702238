"""5-axis kinematics of a machine profile: LinuxCNC's table-tilting ``xyzac-trt`` and ``xyzbc-trt`` (issue 27, item 2).

Conventions are LinuxCNC's trt kinematics modules (``xyzac-trt-kins``,
``xyzbc-trt-kins``, src/emc/kinematics/trtfuncs.c; docs "Switchable
Kinematics", "5-Axis Kinematics"):

* the tool is fixed and vertical; the table tilts (A about X, or B about Y)
  and carries the rotary table C (about Z) on top, which carries the part;
* with the kinematics on (TCP, the module's switchkins type 0, ``M428`` where
  remapped) the program's X Y Z are the tool point in the part's (table's)
  frame and A/B, C the rotary angles; the module moves the joints so the tool
  point follows. The joints are ``R_tilt (R_C (p - rot_point) - offset) +
  offset + rot_point`` with ``R_tilt = R_x(A)`` or ``R_y(B)``, ``R_C = R_z(C)``
  (right-handed rotations of the table, the module's inverse transform),
  ``rot_point`` the module's ``x/y/z-rot-point`` pins (where the C axis
  crosses the tilt axis' plane), ``offset`` the tilt axis' offset from it
  (``y-offset, z-offset`` for A, ``x-offset, z-offset`` for B; the tool
  offset adds to z);
* the tool axis in the part's frame (from the tip up the spindle, the
  convention of :mod:`polishpath.axes`) is the third row of ``R_tilt R_C``:
  ``xyzac``: ``(sin A sin C, sin A cos C, cos A)``; ``xyzbc``: ``(-cos C sin B, sin C sin B, cos B)``.
  (The module's own note says its rotary directions are the opposite of the
  conventional ones; these formulas are what it computes.)

Inverse kinematics (:meth:`Kinematics.angles`): each axis has two solutions
(``(t, C)`` and ``(-t, C + 180)``) and C is defined only up to turns; the
solver walks the samples in order and takes the solution nearest the previous
one (the branch and the turn chosen for continuity, so C never spins round
a whole turn, and a path through the pole passes it on the other branch with
C still). Inside a cone of ``singular_deg`` around the C axis (the singular
direction, where C is free) C holds its previous value and the tilt is the
axis' component on C's plane (the axis error there is at most the cone's
angle). Off the cone C turns as fast as the geometry needs: a path passing
near the pole makes C swing, and the feed schedule slows the tool there to
keep the rotary limits. An orientation whose tilt is outside the tilt range
on both branches, or a C outside its range, is refused, naming the dwell
point and the limit.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np

from ..defaults import DEFAULT_SINGULAR_CONE_DEG
from ..errors import ReachError, SpecError

__all__ = ["Kinematics", "KINEMATICS_TYPES", "BUILTIN_KINEMATICS", "axes_from_angles", "kinematics_from_table"]

KINEMATICS_TYPES = ("xyzac-trt", "xyzbc-trt")


@dataclass(frozen=True)
class Kinematics:
    """A table-tilting 5-axis machine (LinuxCNC ``xyzac-trt-kins`` / ``xyzbc-trt-kins``).

    Attributes
    ----------
    type : {"xyzac-trt", "xyzbc-trt"}
        LinuxCNC's module name (without ``-kins``): A (about X) or B (about Y) tilting, C on top.
    rot_point_mm : (3,) float
        The module's ``x-rot-point, y-rot-point, z-rot-point``: the C axis' centre, mm, machine frame.
    offset_mm : (2,) float
        ``xyzac``: ``y-offset, z-offset``; ``xyzbc``: ``x-offset, z-offset``: the tilt axis from the rot point, mm.
    tool_offset_mm : float
        The module's ``tool-offset`` (the tool length to the controlled point), mm.
    tilt_range_deg : (2,) float
        Range of A (or B), degrees.
    c_range_deg : (2,) float or None
        Range of C, degrees; None: a continuous rotary table (no limit).
    max_velocity_deg_min : (2,) float
        Largest velocity of A (or B) and C, degrees/min.
    max_acceleration_deg_s2 : (2,) float
        Largest acceleration of A (or B) and C, degrees/s^2.
    singular_deg : float
        Cone around the C axis where C holds (see the module docstring), degrees.
    """

    type: str = "xyzac-trt"
    rot_point_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    offset_mm: tuple[float, float] = (0.0, 0.0)
    tool_offset_mm: float = 0.0
    tilt_range_deg: tuple[float, float] = (-120.0, 120.0)
    c_range_deg: tuple[float, float] | None = None
    max_velocity_deg_min: tuple[float, float] = (5400.0, 10800.0)
    max_acceleration_deg_s2: tuple[float, float] = (360.0, 720.0)
    singular_deg: float = DEFAULT_SINGULAR_CONE_DEG

    def __post_init__(self):
        where = f"kinematics {self.type!r}"
        if self.type not in KINEMATICS_TYPES:
            raise SpecError(f"unknown kinematics {self.type!r}.",
                            f"Use one of {', '.join(KINEMATICS_TYPES)} (LinuxCNC's trt module names).")
        _numbers(self, "rot_point_mm", 3, where)
        _numbers(self, "offset_mm", 2, where)
        _numbers(self, "tilt_range_deg", 2, where)
        _numbers(self, "max_velocity_deg_min", 2, where, positive=True)
        _numbers(self, "max_acceleration_deg_s2", 2, where, positive=True)
        if self.c_range_deg is not None:
            _numbers(self, "c_range_deg", 2, where)
            lo, hi = self.c_range_deg
            if not hi - lo >= 360.0:
                raise SpecError(f"{where}: c_range_deg {list(self.c_range_deg)} must span at least one turn.",
                                "Give e.g. [-360, 360], or leave it out for a continuous C.")
        lo, hi = self.tilt_range_deg
        if not lo < hi:
            raise SpecError(f"{where}: tilt_range_deg must be [low, high], low < high, got {list(self.tilt_range_deg)}.")
        for name in ("tool_offset_mm", "singular_deg"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or \
                    (name == "singular_deg" and not 0 < v < 1):
                raise SpecError(f"{where}: {name} must be a number" + (" of degrees in (0, 1)" if
                                name == "singular_deg" else "") + f", got {v!r}.")
            object.__setattr__(self, name, float(v))

    @property
    def tilt_letter(self) -> str:
        """``"A"`` or ``"B"``."""
        return "A" if self.type == "xyzac-trt" else "B"

    @property
    def letters(self) -> tuple[str, str]:
        return (self.tilt_letter, "C")

    @property
    def linuxcnc_module(self) -> str:
        return f"{self.type}-kins"

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    def axes(self, angles: np.ndarray) -> np.ndarray:
        """Unit tool axes (m, 3), part frame, of rotary ``angles`` (m, 2): (tilt, C) degrees."""
        return axes_from_angles(self.type, angles)

    def angles(self, axes: np.ndarray, previous: np.ndarray | None = None, *, where=None) -> np.ndarray:
        """Rotary angles (m, 2): (A or B, C) degrees for unit tool ``axes`` (m, 3), continuous from ``previous``.

        Parameters
        ----------
        axes : (m, 3) float
            Tool axes in the part's frame (tip to spindle), in path order.
        previous : (2,) float, optional
            The angles of the sample before (None: the path's start: the solution nearest the middle of the
            tilt range, C in (-180, 180]).
        where : callable, optional
            ``where(i) -> str`` naming sample ``i`` for the message of an unreachable orientation.

        Raises
        ------
        ReachError
            An axis needs a tilt outside ``tilt_range_deg`` (on both branches), or C outside ``c_range_deg``.
        """
        ax = np.ascontiguousarray(np.asarray(axes, dtype=np.float64).reshape(-1, 3))
        prev = np.zeros(2) if previous is None else np.asarray(previous, dtype=np.float64).reshape(2)
        c_lo, c_hi = self.c_range_deg if self.c_range_deg is not None else (-np.inf, np.inf)
        out, bad, why = _solve(ax, int(self.type == "xyzbc-trt"), prev, previous is not None,
                               float(self.tilt_range_deg[0]), float(self.tilt_range_deg[1]), float(c_lo), float(c_hi),
                               math.sin(math.radians(self.singular_deg)))
        if bad >= 0:
            name = where(int(bad)) if where is not None else f"sample {int(bad)}"
            v = ax[bad] / max(float(np.linalg.norm(ax[bad])), 1e-300)
            tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(v[2])))))
            if why == 1:
                raise ReachError(
                    f"{name}: the tool axis ({v[0]:.4f}, {v[1]:.4f}, {v[2]:.4f}) needs {self.tilt_letter} = +-{tilt:.3f} "
                    f"degrees, outside the {self.type} machine's range {self.tilt_letter} "
                    f"[{self.tilt_range_deg[0]:g}, {self.tilt_range_deg[1]:g}] degrees.",
                    "Use a tool-axis law that tilts less from vertical there (--tool-axis z, or a smaller tilted "
                    "angle), a machine with a wider tilt range, or fix the part at another angle.")
            raise ReachError(
                f"{name}: the path winds C to {out[bad, 1]:.3f} degrees, outside the {self.type} machine's range C "
                f"[{c_lo:g}, {c_hi:g}] degrees.",
                "Use a machine profile with a continuous C (leave c_range_deg out) or a wider C range.")
        return out

    def joints(self, points: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """Machine joint positions X Y Z (m, 3) mm (LinuxCNC's inverse transform) of tool points ``points``
        (m, 3) mm in the part's frame at rotary ``angles`` (m, 2) degrees."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3) - np.asarray(self.rot_point_mm)
        t, c = np.radians(angles[:, 0]), np.radians(angles[:, 1])
        ct, st, cc, sc = np.cos(t), np.sin(t), np.cos(c), np.sin(c)
        q = np.column_stack([cc * p[:, 0] - sc * p[:, 1], sc * p[:, 0] + cc * p[:, 1], p[:, 2]])
        if self.type == "xyzac-trt":
            d = np.array([0.0, self.offset_mm[0], self.offset_mm[1] + self.tool_offset_mm])
            q = q - d
            j = np.column_stack([q[:, 0], ct * q[:, 1] - st * q[:, 2], st * q[:, 1] + ct * q[:, 2]])
        else:
            d = np.array([self.offset_mm[0], 0.0, self.offset_mm[1] + self.tool_offset_mm])
            q = q - d
            j = np.column_stack([ct * q[:, 0] + st * q[:, 2], q[:, 1], -st * q[:, 0] + ct * q[:, 2]])
        return j + d + np.asarray(self.rot_point_mm)


def _numbers(obj, name: str, n: int, where: str, positive: bool = False) -> None:
    v = getattr(obj, name)
    ok = isinstance(v, (list, tuple)) and len(v) == n and all(
        isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and (x > 0 or not positive)
        for x in v)
    if not ok:
        raise SpecError(f"{where}: {name} must be {n} {'positive ' if positive else ''}numbers, got {v!r}.")
    object.__setattr__(obj, name, tuple(float(x) for x in v))


def axes_from_angles(kind: str, angles: np.ndarray) -> np.ndarray:
    """Unit tool axes (m, 3) in the part's frame of rotary angles (m, 2) (tilt, C) degrees of ``kind``."""
    a = np.radians(np.asarray(angles, dtype=np.float64).reshape(-1, 2))
    t, c = a[:, 0], a[:, 1]
    if kind == "xyzac-trt":
        return np.column_stack([np.sin(t) * np.sin(c), np.sin(t) * np.cos(c), np.cos(t)])
    if kind == "xyzbc-trt":
        return np.column_stack([-np.cos(c) * np.sin(t), np.sin(c) * np.sin(t), np.cos(t)])
    raise SpecError(f"unknown kinematics {kind!r}.", f"Use one of {', '.join(KINEMATICS_TYPES)}.")


@numba.njit(cache=True)
def _solve(axes, bc, prev, has_prev, t_lo, t_hi, c_lo, c_hi, sin_cone):  # pragma: no cover - numba
    # the two solutions of each axis, the branch and the turn of C nearest the previous sample's angles;
    # (angles, first bad sample or -1, why: 1 tilt out of range, 2 C out of range)
    m = axes.shape[0]
    out = np.empty((m, 2))
    pa, pc = prev[0], prev[1]
    have = has_prev
    for i in range(m):
        x, y, z = axes[i, 0], axes[i, 1], axes[i, 2]
        ln = math.sqrt(x * x + y * y + z * z)
        x, y, z = x / ln, y / ln, z / ln
        r = math.sqrt(x * x + y * y)  # sin of the tilt
        if bc == 0:  # (sin t sin c, sin t cos c, cos t)
            sx, sy = x, y
        else:  # (-cos c sin t, sin c sin t, cos t): (y, -x) = sin t (sin c, cos c)
            sx, sy = y, -x
        mag = math.degrees(math.atan2(r, z))
        if have and r <= sin_cone:
            # the singular cone: C holds; the tilt is the axis' component along C's direction (signed)
            cr = math.radians(pc)
            comp = sx * math.sin(cr) + sy * math.cos(cr)
            t = math.degrees(math.atan2(comp, z))
            if t < t_lo or t > t_hi:
                out[i, 0], out[i, 1] = t, pc
                return out, i, 1
            out[i, 0], out[i, 1] = t, pc
            pa = t
            continue
        c0 = math.degrees(math.atan2(sx, sy)) if r > 0.0 else (pc if have else 0.0)
        best_t, best_c, best = 0.0, 0.0, -1.0
        for br in range(2):
            t = mag if br == 0 else -mag
            c = c0 if br == 0 else c0 + 180.0
            if t < t_lo or t > t_hi:
                continue
            if have:
                c = c + 360.0 * math.floor((pc - c) / 360.0 + 0.5)  # the turn nearest the previous C
                cost = abs(t - pa) + abs(c - pc)
            else:
                c = c - 360.0 * math.floor((c + 180.0) / 360.0)  # (-180, 180]
                if c == -180.0:
                    c = 180.0
                cost = abs(t - 0.5 * (t_lo + t_hi)) + 1e-9 * br
            if best < 0.0 or cost < best:
                best, best_t, best_c = cost, t, c
        if best < 0.0:
            out[i, 0], out[i, 1] = mag, c0
            return out, i, 1
        if best_c < c_lo or best_c > c_hi:
            # another turn within the range, if the range has one (a rewind only at a path's start)
            k = math.ceil((c_lo - best_c) / 360.0) if best_c < c_lo else -math.ceil((best_c - c_hi) / 360.0)
            cand = best_c + 360.0 * k
            if have or cand < c_lo or cand > c_hi:
                out[i, 0], out[i, 1] = best_t, best_c
                return out, i, 2
            best_c = cand
        out[i, 0], out[i, 1] = best_t, best_c
        pa, pc = best_t, best_c
        have = True
    return out, -1, 0


def settings_from_table(cls, table: Any, where: str, what: str):
    """``cls(**table)`` for a TOML table of a dataclass' fields (a machine profile, its kinematics), unknown
    keys refused naming them (``where``: the file; ``what``: e.g. ``"machine"``)."""
    if not isinstance(table, dict):
        raise SpecError(f"{where}: [{what}] must be a table of settings.")
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(table) - names)
    if unknown:
        raise SpecError(f"{where}: unknown {what.split('.')[-1]} setting(s) {', '.join(unknown)}.",
                        f"Settings: {', '.join(sorted(names))}.")
    return cls(**table)


def kinematics_from_table(table: Any, where: str) -> Kinematics:
    """A :class:`Kinematics` from a machine TOML's ``[machine.kinematics]`` table (keys: its field names)."""
    return settings_from_table(Kinematics, table, where, "machine.kinematics")


#: built-in kinematics of the built-in 5-axis profiles: a small trunnion table (pivot 50 mm below the
#: table top for A/B, tilt -120..+120 degrees, continuous C; 15 and 30 rev/min, 1 and 2 rev/s^2 over 360)
BUILTIN_KINEMATICS: dict[str, Kinematics] = {
    "xyzac-trt": Kinematics("xyzac-trt", offset_mm=(0.0, -50.0)),
    "xyzbc-trt": Kinematics("xyzbc-trt", offset_mm=(0.0, -50.0)),
}
