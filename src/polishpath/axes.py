"""Tool-axis laws: which way the tool points at every dwell point and machine sample (issue 27, item 1).

Convention: the tool axis is a unit vector in the part's frame pointing from
the tool tip up the spindle, away from the surface (Sinumerik's A3/B3/C3
convention); the ``z`` law is (0, 0, 1), the 3-axis machine's vertical tool.

Laws (``--tool-axis``):

* ``z`` (default): (0, 0, 1) everywhere; a 3-axis job (no axes travel, the
  3-axis outputs stay byte for byte what they were);
* ``normal``: the unit surface normal (the interpolated vertex normals of the map stage);
* ``tilted:angle=DEG[,azimuth=DEG]``: ``cos(angle) n + sin(angle) t``, the
  normal ``n`` tilted by ``angle`` degrees toward ``t``, the azimuth direction
  ``d = (cos azimuth, sin azimuth, 0)`` of the part's frame projected on the
  tangent plane (``d - (d.n) n``, normalised): the axis keeps exactly
  ``angle`` from the normal everywhere, in the plane of the normal and the
  fixed azimuth, as a precessed bonnet runs. At the pole (vertical normal)
  ``t = d``: defined and continuous there. Undefined only where the normal is
  horizontal and faces +-d exactly (a vertical wall facing the azimuth): there
  the tilt goes toward +Z.

Between dwell points (machine samples, streamed or held) the normals are
interpolated linearly in the curve parameter between the two neighbouring
dwell points' normals and normalised (:func:`interpolate_units`, as
``export.chunks.normals_at`` does), and the law is applied to the sample's
normal (:func:`axes_at_params`): a sample's axis keeps the law exactly (the
tilt from the sample's normal) and turns between two samples as the normal
does (``normal``: the same angle; ``tilted``: at most ``cos a + sin a / |t|``
times it, ~1.4x at the pole).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import ParameterError

__all__ = ["ToolAxisLaw", "TOOL_AXIS_KINDS", "parse_tool_axis", "tool_axes", "interpolate_units", "axes_at_params",
           "axis_angles_deg", "with_tool_axes", "MAX_TILT_DEG"]

TOOL_AXIS_KINDS = ("z", "normal", "tilted")
#: the largest tilt from the normal ``tilted`` takes, degrees (at 90 the tool would lie on the surface)
MAX_TILT_DEG = 80.0
_HINT = ("Give --tool-axis z (vertical tool, 3-axis), normal (along the surface normal) or "
         "tilted:angle=DEG[,azimuth=DEG] (e.g. tilted:angle=20,azimuth=0: 20 degrees from the normal toward +X).")


@dataclass(frozen=True)
class ToolAxisLaw:
    """One tool-axis law.

    Attributes
    ----------
    kind : {"z", "normal", "tilted"}
    angle_deg : float
        ``tilted``: the tilt from the normal, degrees, 0 <= angle <= :data:`MAX_TILT_DEG` (0 otherwise).
    azimuth_deg : float
        ``tilted``: the direction of the tilt in the part's XY plane, degrees from +X toward +Y (0 otherwise).
    """

    kind: str = "z"
    angle_deg: float = 0.0
    azimuth_deg: float = 0.0

    def __post_init__(self):
        if self.kind not in TOOL_AXIS_KINDS:
            raise ParameterError(f"unknown tool-axis law {self.kind!r}.", _HINT)
        for name in ("angle_deg", "azimuth_deg"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ParameterError(f"--tool-axis {name.split('_')[0]} must be a number of degrees, got {v!r}.",
                                     _HINT)
            object.__setattr__(self, name, float(v))
        if not 0.0 <= self.angle_deg <= MAX_TILT_DEG:
            raise ParameterError(f"--tool-axis tilted: angle must be 0..{MAX_TILT_DEG:g} degrees from the normal, "
                                 f"got {self.angle_deg:g}.", "E.g. tilted:angle=20.")

    @property
    def spec(self) -> str:
        """The law as ``--tool-axis`` text (what job.toml and the run folder record)."""
        if self.kind != "tilted":
            return self.kind
        return f"tilted:angle={self.angle_deg:g},azimuth={self.azimuth_deg:g}"

    @property
    def is_vertical(self) -> bool:
        """True for the ``z`` law (a 3-axis job)."""
        return self.kind == "z"


def parse_tool_axis(text: str | ToolAxisLaw) -> ToolAxisLaw:
    """A :class:`ToolAxisLaw` from ``--tool-axis`` text: ``z``, ``normal``, ``tilted:angle=DEG[,azimuth=DEG]``.

    Raises
    ------
    ParameterError
        Unknown law, unknown or repeated key, a value that is not a number, an angle outside 0..80.
    """
    if isinstance(text, ToolAxisLaw):
        return text
    if not isinstance(text, str):
        raise ParameterError(f"--tool-axis must be text, got {text!r}.", _HINT)
    kind, _, rest = text.strip().partition(":")
    kind = kind.strip().lower()
    if kind not in TOOL_AXIS_KINDS:
        raise ParameterError(f"unknown --tool-axis law {kind!r} in {text!r}.", _HINT)
    if kind != "tilted":
        if rest.strip():
            raise ParameterError(f"--tool-axis {kind} takes no parameters, got {text!r}.", _HINT)
        return ToolAxisLaw(kind)
    vals: dict[str, float] = {}
    for item in filter(None, (s.strip() for s in rest.split(","))):
        key, eq, val = item.partition("=")
        key = key.strip().lower()
        if not eq or key not in ("angle", "azimuth") or key in vals:
            raise ParameterError(f"--tool-axis {text!r}: {'repeated' if key in vals else 'unknown'} item {item!r}.",
                                 _HINT)
        try:
            vals[key] = float(val)
        except ValueError:
            raise ParameterError(f"--tool-axis {text!r}: {key} must be a number of degrees, got {val!r}.",
                                 _HINT) from None
    if "angle" not in vals:
        raise ParameterError(f"--tool-axis {text!r}: tilted needs angle=DEG.", _HINT)
    return ToolAxisLaw("tilted", vals["angle"], vals.get("azimuth", 0.0))


def _unit(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)


def tool_axes(law: ToolAxisLaw | str, normals: np.ndarray) -> np.ndarray:
    """The tool axes of ``law`` at points of unit surface ``normals`` (N, 3): (N, 3) unit vectors, part frame."""
    law = parse_tool_axis(law)
    n = _unit(np.asarray(normals, dtype=np.float64).reshape(-1, 3))
    if law.kind == "z":
        return np.tile([0.0, 0.0, 1.0], (len(n), 1))
    if law.kind == "normal" or law.angle_deg == 0.0:
        return n
    th, az = math.radians(law.angle_deg), math.radians(law.azimuth_deg)
    d = np.array([math.cos(az), math.sin(az), 0.0])
    t = d[None, :] - np.outer(n @ d, 1.0) * n
    ln = np.linalg.norm(t, axis=1, keepdims=True)
    up = np.array([0.0, 0.0, 1.0])
    t_up = up[None, :] - n[:, 2:3] * n  # a wall facing +-d exactly: toward +Z (see the module docstring)
    t = np.where(ln > 1e-9, t / np.maximum(ln, 1e-300), _unit(t_up))
    return _unit(math.cos(th) * n + math.sin(th) * t)


def interpolate_units(params: np.ndarray, knots: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Unit vectors at curve ``params`` (m,): linear in the parameter between the two neighbouring
    ``knots`` (N,) ascending (the dwell parameters) of ``vectors`` (N, 3), normalised; where the
    interpolated vector vanishes (two opposite neighbours), the neighbour's own vector. (m, 3)."""
    u = np.asarray(params, dtype=np.float64)
    vec = np.asarray(vectors, dtype=np.float64)
    out = np.stack([np.interp(u, knots, vec[:, j]) for j in range(3)], axis=1)
    ln = np.linalg.norm(out, axis=1, keepdims=True)
    near = vec[np.clip(np.searchsorted(knots, u), 0, len(knots) - 1)]
    return np.where(ln > 1e-9, out / np.maximum(ln, 1e-300), near)


def axes_at_params(surface_path, dwell_params: np.ndarray, params: np.ndarray) -> np.ndarray | None:
    """Tool axes (m, 3) at curve ``params`` (m,) of a path through ``surface_path`` 's dwell points at
    ``dwell_params`` (N,): its law (``surface_path.tool_axis``) applied to the normals interpolated there
    (:func:`interpolate_units`); None for a 3-axis path (``tool_axes`` None)."""
    if surface_path.tool_axes is None:
        return None
    nrm = interpolate_units(params, dwell_params, surface_path.normals)
    return tool_axes(surface_path.tool_axis, nrm)


def axis_angles_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles between unit vectors ``a`` and ``b`` (m, 3), degrees (atan2 of cross and dot: exact near 0)."""
    a, b = _unit(a), _unit(b)
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1)))


def with_tool_axes(surface_path, law: ToolAxisLaw | str):
    """``surface_path`` (a :class:`~polishpath.types.SurfacePath`) with the tool axes of ``law`` at its dwell
    points (``tool_axes`` None for the ``z`` law: a 3-axis job) and ``tool_axis`` its spec."""
    import dataclasses

    law = parse_tool_axis(law)
    axes = None if law.is_vertical else tool_axes(law, surface_path.normals)
    return dataclasses.replace(surface_path, tool_axes=axes, tool_axis=law.spec)
