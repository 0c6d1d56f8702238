"""The plain data that flows between the stages.

``Surface --flatten--> Flattening --plan--> PlanarPath --map--> SurfacePath --smooth--> ToolPath``

Every box is a frozen dataclass of numpy arrays plus the parameters that made
it (:class:`Provenance`). Stages import these types and nothing of each other's
internals, so a stage can be swapped (MABF / ABF / LSCM; pseudo-random / raster
/ spiral ...) without touching the others. ``tests/test_architecture.py``
guards that rule.

Units: millimetres for lengths, radians for angles, seconds for times, unless a
field name says otherwise (``feed_mm_min``, ``period_ms``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._version import __version__
from .errors import ExportError, ParameterError
from .pathops import DIRECTION_STEPS


def _is_frozen(a, dtype) -> bool:
    """True when ``a`` is a read-only array of ``dtype`` that no writeable array shares memory with.

    Such an array cannot change under the dataclass (only its owner could make it writeable
    again, deliberately), so it is taken as it is: a stage hands over the arrays it just made
    by marking them read-only (``smooth()``'s 15 M machine samples at 10^6 dwell points are
    480 MB: the copy took 0.5 s), and dataclasses built from another's arrays share them.
    """
    if not isinstance(a, np.ndarray) or a.flags.writeable or (dtype is not None and a.dtype != np.dtype(dtype)):
        return False
    base = a.base
    while isinstance(base, np.ndarray):
        if base.flags.writeable:
            return False
        base = base.base
    return base is None or not isinstance(base, (bytearray, memoryview))


def _frozen_array(a, dtype=None, ndim: int | None = None, cols: int | None = None, name: str = "array"):
    """A read-only copy of ``a`` (``a`` itself when it is already frozen, :func:`_is_frozen`);
    :class:`ParameterError` when it cannot be one of the shape asked for."""
    want = f"(n, {cols})" if cols is not None else ("(n,)" if ndim == 1 else f"{ndim}-D")
    try:
        arr = a if _is_frozen(a, dtype) else np.array(a, dtype=dtype, copy=True)
    except (TypeError, ValueError) as exc:
        raise ParameterError(
            f"{name} must be an array of numbers of shape {want}, got {type(a).__name__} ({exc}).",
            f"Pass a numpy array of shape {want} (or nested lists of equal length).",
        ) from None
    if ndim is not None and arr.ndim != ndim:
        raise ParameterError(f"{name} must be an array of shape {want}, got shape {arr.shape}.",
                             f"Pass an array of shape {want}.")
    if cols is not None and (arr.ndim < 2 or arr.shape[1] != cols):
        raise ParameterError(f"{name} must have shape (n, {cols}), got {arr.shape}.",
                             f"Pass an (n, {cols}) array: one row of {cols} values per item.")
    arr.setflags(write=False)
    return arr


def _loop(a, name: str) -> np.ndarray:
    """A boundary loop as an (n >= 3, 2) float64 array of finite points, mm."""
    try:
        loop = np.array(a, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be an (n, 2) array of numbers (mm), got {type(a).__name__} ({exc}).",
                             "Pass the polygon's corners as an (n, 2) array, n >= 3.") from None
    if loop.ndim != 2 or loop.shape[1] != 2 or len(loop) < 3:
        raise ParameterError(f"{name} must be an (n >= 3, 2) array, got shape {loop.shape}.",
                             "Pass the polygon's corners as an (n, 2) array of (u, v) in mm, n >= 3, "
                             "not repeating the first corner at the end.")
    if not np.isfinite(loop).all():
        raise ParameterError(f"{name} has {int((~np.isfinite(loop)).any(axis=1).sum())} corner(s) with NaN "
                             "or infinite coordinates.", "Remove or fix those corners.")
    return loop


@dataclass(frozen=True)
class Provenance:
    """What produced a result: the stage, its method, its parameters, seed and version.

    Attributes
    ----------
    stage : str
        ``"surface"``, ``"flatten"``, ``"plan"``, ``"map"``, ``"smooth"``, ``"simulate"``.
    method : str
        Algorithm name within the stage (``"mabf"``, ``"pseudorandom"`` ...).
    params : dict
        Every parameter that influenced the result (JSON-serialisable values).
    seed : int or None
        Seed of the random generator, for random stages.
    version : str
        polishpath version.
    """

    stage: str
    method: str
    params: dict[str, Any] = field(default_factory=dict)
    seed: int | None = None
    version: str = __version__

    def to_dict(self) -> dict[str, Any]:
        return {
            "stage": self.stage,
            "method": self.method,
            "params": dict(self.params),
            "seed": self.seed,
            "version": self.version,
        }


@dataclass(frozen=True)
class Finding:
    """One observation made while validating or repairing a mesh.

    Attributes
    ----------
    code : str
        Stable machine-readable code, e.g. ``"duplicate_vertices"``.
    message : str
        Human-readable sentence.
    count : int
        How many items were affected (vertices, faces, edges ...).
    repaired : bool
        True when polishpath fixed it on the way in.
    severity : str
        ``"info"``, ``"warning"`` or ``"error"``.
    """

    code: str
    message: str
    count: int = 0
    repaired: bool = False
    severity: str = "info"

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class Surface:
    """A triangle mesh of the part to polish, in millimetres.

    Attributes
    ----------
    vertices : (V, 3) float64
        Vertex positions, mm.
    faces : (F, 3) int64
        Vertex indices of each triangle, consistently oriented.
    name : str
        Short name (file stem or built-in name).
    source : str
        Where it came from: a file path, a built-in spec such as
        ``"hemisphere:R=30,triangles=1119"`` or a TOML spec path.
    params : dict
        Parameters that generated it (analytic surfaces) or load options.
    findings : tuple of Finding
        What validation found and repaired on the way in.
    sag : callable or None
        For analytic surfaces, ``sag(x, y) -> z`` in mm (vectorised), used to
        check that points lie on the true surface; None for meshes.
    """

    vertices: np.ndarray
    faces: np.ndarray
    name: str = "surface"
    source: str = ""
    params: dict[str, Any] = field(default_factory=dict)
    findings: tuple[Finding, ...] = ()
    sag: Any = field(default=None, compare=False, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "vertices", _frozen_array(self.vertices, np.float64, 2, 3, "vertices"))
        object.__setattr__(self, "faces", _frozen_array(self.faces, np.int64, 2, 3, "faces"))

    @property
    def n_vertices(self) -> int:
        return int(self.vertices.shape[0])

    @property
    def n_faces(self) -> int:
        return int(self.faces.shape[0])

    def to_trimesh(self):
        """The mesh as a :class:`trimesh.Trimesh` (no processing)."""
        import trimesh

        return trimesh.Trimesh(np.array(self.vertices), np.array(self.faces), process=False)


@dataclass(frozen=True)
class Region:
    """A planar region: one outer boundary loop and any number of holes, in mm.

    Attributes
    ----------
    outer : (n, 2) float64
        Outer boundary polygon, counter-clockwise, not repeated at the end.
    holes : tuple of (m, 2) float64
        Hole polygons, clockwise, not repeated at the end.
    """

    outer: np.ndarray
    holes: tuple[np.ndarray, ...] = ()

    def __post_init__(self):
        outer = _orient(_loop(self.outer, "The outer boundary"), ccw=True)
        one_array = isinstance(self.holes, np.ndarray) and self.holes.ndim == 2
        if one_array or isinstance(self.holes, (str, bytes)) or not hasattr(self.holes, "__iter__"):
            raise ParameterError(f"Region holes must be a sequence of (m, 2) arrays, got {type(self.holes).__name__}"
                                 + (" (one 2-D array)" if one_array else "") + ".",
                                 "Pass a tuple of hole polygons, e.g. Region(outer, (hole,)) for one hole.")
        holes = []
        for k, h in enumerate(self.holes):
            holes.append(_frozen_array(_orient(_loop(h, f"Hole {k}"), ccw=False)))
        object.__setattr__(self, "outer", _frozen_array(outer))
        object.__setattr__(self, "holes", tuple(holes))

    @property
    def loops(self) -> tuple[np.ndarray, ...]:
        """All boundary loops, outer first."""
        return (self.outer, *self.holes)

    @property
    def area(self) -> float:
        """Enclosed area in mm^2 (outer minus holes)."""
        return float(_signed_area(self.outer) + sum(_signed_area(h) for h in self.holes))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)`` in mm."""
        lo = self.outer.min(axis=0)
        hi = self.outer.max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])

    @property
    def centroid(self) -> np.ndarray:
        """Area centroid of the region, (2,) mm."""
        tot_a = 0.0
        c = np.zeros(2)
        for loop in self.loops:
            x, y = loop[:, 0], loop[:, 1]
            xn, yn = np.roll(x, -1), np.roll(y, -1)
            cr = x * yn - xn * y
            tot_a += cr.sum() / 2.0
            c += np.array([((x + xn) * cr).sum(), ((y + yn) * cr).sum()]) / 6.0
        return c / tot_a if tot_a != 0 else self.outer.mean(axis=0)


def _signed_area(loop: np.ndarray) -> float:
    x, y = loop[:, 0], loop[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _orient(loop: np.ndarray, ccw: bool) -> np.ndarray:
    a = _signed_area(loop)
    if (a > 0) != ccw:
        return loop[::-1].copy()
    return loop


@dataclass(frozen=True)
class Flattening:
    """A planar parameterisation of a :class:`Surface`.

    Attributes
    ----------
    surface : Surface
        The 3D mesh that was flattened (same vertex and face indexing).
    uv : (V, 2) float64
        Planar vertex positions, mm; scaled so that the planar area equals the
        3D surface area, centred on the origin.
    angles : (F, 3) float64
        Planar triangle angles (radians) at the corners ``faces[:, k]``; for
        angle-based methods, the solved angles (before layout).
    residuals : dict of str -> ndarray
        Constraint residuals of the solved angles: ``"triangle"`` (F,), ``"vertex"``
        (interior vertices,), ``"wheel"`` (interior vertices,), in radians (wheel:
        log-sine units). Empty for methods that do not solve angles.
    metrics : dict of str -> float
        Distortion figures (see :func:`polishpath.flatten.metrics`).
    timings : dict of str -> float
        Seconds spent per step (``"angles"``, ``"layout"``, ``"total"``).
    provenance : Provenance
    """

    surface: Surface
    uv: np.ndarray
    angles: np.ndarray
    residuals: dict[str, np.ndarray] = field(default_factory=dict)
    metrics: dict[str, float] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)
    provenance: Provenance = field(default_factory=lambda: Provenance("flatten", "unknown"))

    def __post_init__(self):
        object.__setattr__(self, "uv", _frozen_array(self.uv, np.float64, 2, 2, "uv"))
        object.__setattr__(self, "angles", _frozen_array(self.angles, np.float64, 2, 3, "angles"))


@dataclass(frozen=True)
class Lattice:
    """The lattice of a set of dwell points: ``uv = origin + basis @ ij`` for integer indices ``ij``.

    A planner that walks index steps (the paper's square grid and its 8
    neighbours) has one; a set of points without one (a blue-noise set) has
    none, and its :class:`PlanarPath` says so with ``lattice=None``.

    Attributes
    ----------
    basis : (2, 2) float64
        The two lattice vectors in the plane as columns, mm (the square grid's:
        ``spacing * R(rotation)``).
    origin : (2,) float64
        Plane position of index (0, 0), mm.
    neighbour_offsets : (K, 2) int64
        The index steps a walk over the lattice may take, none (0, 0) (the square
        grid's 8 neighbours in ``pathops.DIRECTION_STEPS`` order).
    """

    basis: np.ndarray
    origin: np.ndarray
    neighbour_offsets: np.ndarray

    def __post_init__(self):
        basis = _frozen_array(self.basis, np.float64, 2, 2, "Lattice.basis")
        origin = _frozen_array(self.origin, np.float64, 1, None, "Lattice.origin")
        steps = _frozen_array(self.neighbour_offsets, np.int64, 2, 2, "Lattice.neighbour_offsets")
        hint = "Build the square grid's with Lattice.square(spacing, origin, rotation)."
        if basis.shape != (2, 2) or origin.shape != (2,) or not (np.isfinite(basis).all() and np.isfinite(origin).all()):
            raise ParameterError(f"Lattice: basis must be a finite (2, 2) array and origin a finite (2,) one, got "
                                 f"{basis.shape} and {origin.shape}.", hint)
        if not abs(np.linalg.det(basis)) > 0:
            raise ParameterError("Lattice: the basis vectors are parallel (determinant 0): they span no plane.", hint)
        if len(steps) == 0 or (steps == 0).all(axis=1).any() or len(np.unique(steps, axis=0)) != len(steps):
            raise ParameterError(f"Lattice: neighbour_offsets must be distinct non-zero index steps, got "
                                 f"{steps.tolist()}.", hint)
        object.__setattr__(self, "basis", basis)
        object.__setattr__(self, "origin", origin)
        object.__setattr__(self, "neighbour_offsets", steps)

    @classmethod
    def square(cls, spacing: float, origin=(0.0, 0.0), rotation: float = 0.0) -> Lattice:
        """The square grid of ``spacing`` mm, turned by ``rotation`` radians (counter-clockwise), with index
        (0, 0) at ``origin`` (2,) mm, and its 8 neighbours (``uv = origin + R(rotation) @ (ij * spacing)``)."""
        c, s = np.cos(rotation), np.sin(rotation)
        return cls(float(spacing) * np.array([[c, -s], [s, c]]), origin, DIRECTION_STEPS)

    def to_uv(self, ij: np.ndarray) -> np.ndarray:
        """Plane positions (n, 2) mm of the indices ``ij`` (n, 2)."""
        return self.origin + np.asarray(ij, dtype=np.float64) @ self.basis.T

    def is_step(self, dij: np.ndarray) -> np.ndarray:
        """(n,) bool: which index steps ``dij`` (n, 2) are among the neighbour offsets."""
        d = np.asarray(dij, dtype=np.int64).reshape(-1, 2)
        out = np.zeros(len(d), dtype=bool)
        for a, b in self.neighbour_offsets:  # K passes over n steps: no (n, K) temporary at 10^7 steps
            out |= (d[:, 0] == a) & (d[:, 1] == b)
        return out


@dataclass(frozen=True)
class PlanarPath:
    """A tool path through dwell points in the plane (today on a square grid).

    Attributes
    ----------
    uv : (N, 2) float64
        Path points in path order, mm, in the plane of the region.
    ij : (N, 2) int64
        Integer grid indices of each dwell point: ``uv = origin + R(rotation) @ (ij * spacing)``
        (a pattern off the grid: the nearest index). For a dwell-point set without a lattice
        (``dwell_points="blue-noise"``) there are no grid indices: ``ij[:, 0]`` is the point's
        number in its set (each once) and ``ij[:, 1]`` is 0.
    spacing : float
        Grid spacing in the plane, mm (a set without a lattice: the spacing of the square grid of
        the same density, 1 / spacing^2 points per mm^2).
    origin : (2,) float64
        Plane position of grid index (0, 0), mm.
    rotation : float
        Grid rotation, radians (counter-clockwise).
    pattern : str
        ``"pseudorandom"``, ``"raster"``, ``"spiral"``, ``"rectangular"`` ...
    pieces : (K+1,) int64
        Offsets into ``uv`` of the K continuous pieces: piece k is
        ``uv[pieces[k]:pieces[k+1]]``. One piece is ``[0, N]``. Between pieces the
        tool lifts (the region was split by the grid into unconnected parts).
    unreached : (M, 2) float64
        Dwell points inside the region that the path does not visit (should be
        empty for the pseudo-random planner), mm.
    n_inside : int
        Number of grid points inside the region (visited + unreached).
    provenance : Provenance
    stats : dict
        Figures the planner measured (iterations, turnarounds, time ...).
    lattice : Lattice or None
        The lattice of the dwell points (the planners' square grid: ``Lattice.square(spacing,
        origin, rotation)``), whose neighbour steps are the walk's own moves; None: the dwell
        points have no lattice (and every step within a piece is a move of the walk).
    dwell_points_only : bool
        True when every path point is a dwell point of the set; False for a path that also
        runs through other points (the spiral's points off the grid, a maze's points over
        the boundary).
    dwell_points : str
        The dwell-point set walked: ``"grid"`` (the square grid) or ``"blue-noise"`` (no lattice).
    cell_area : (N,) float64 or None
        Planar area each dwell point stands for, mm^2 (its Voronoi cell), in path order; None: each
        point of the grid stands for ``spacing**2``.
    """

    uv: np.ndarray
    ij: np.ndarray
    spacing: float
    origin: np.ndarray = field(default_factory=lambda: np.zeros(2))
    rotation: float = 0.0
    pattern: str = "pseudorandom"
    pieces: np.ndarray | None = None
    unreached: np.ndarray | None = None
    n_inside: int = -1
    provenance: Provenance = field(default_factory=lambda: Provenance("plan", "unknown"))
    stats: dict[str, Any] = field(default_factory=dict)
    lattice: Lattice | None = None
    dwell_points_only: bool = True
    dwell_points: str = "grid"
    cell_area: np.ndarray | None = None

    def __post_init__(self):
        if self.lattice is not None and not isinstance(self.lattice, Lattice):
            raise ParameterError(f"PlanarPath.lattice must be a Lattice or None, got {type(self.lattice).__name__}.",
                                 "Pass Lattice.square(spacing, origin, rotation) for the square grid, None for none.")
        if not isinstance(self.dwell_points_only, (bool, np.bool_)):
            raise ParameterError(f"PlanarPath.dwell_points_only must be True or False, got {self.dwell_points_only!r}.",
                                 "Say whether every path point is a dwell point.")
        object.__setattr__(self, "dwell_points_only", bool(self.dwell_points_only))
        uv = _frozen_array(self.uv, np.float64, 2, 2, "uv")
        if self.cell_area is not None:
            ca = _frozen_array(self.cell_area, np.float64, 1, None, "cell_area")
            if len(ca) != len(uv):
                raise ParameterError(f"cell_area has {len(ca)} values for {len(uv)} dwell points.",
                                     "Pass one area (mm^2) per dwell point, in path order, or None.")
            object.__setattr__(self, "cell_area", ca)
        object.__setattr__(self, "uv", uv)
        object.__setattr__(self, "ij", _frozen_array(self.ij, np.int64, 2, 2, "ij"))
        object.__setattr__(self, "origin", _frozen_array(self.origin, np.float64, 1, None, "origin"))
        pieces = self.pieces if self.pieces is not None else [0, len(uv)]
        object.__setattr__(self, "pieces", _frozen_array(pieces, np.int64, 1, None, "pieces"))
        unreached = self.unreached if self.unreached is not None else np.zeros((0, 2))
        object.__setattr__(self, "unreached", _frozen_array(unreached, np.float64, 2, 2, "unreached"))
        if self.n_inside < 0:
            object.__setattr__(self, "n_inside", int(len(uv) + len(unreached)))

    @property
    def n_points(self) -> int:
        return int(self.uv.shape[0])


@dataclass(frozen=True)
class SurfacePath:
    """A planar path carried onto the 3D surface.

    Attributes
    ----------
    xyz : (N, 3) float64
        Dwell points on the surface, mm, in path order.
    normals : (N, 3) float64
        Unit surface normals at the dwell points (interpolated vertex normals).
    face_ids : (N,) int64
        Triangle containing each point.
    bary : (N, 3) float64
        Area (barycentric) coordinates of each point in its triangle.
    dwell_weight : (N,) float64
        Relative dwell time per point (mean 1): the surface area each point
        stands for, so that uniform removal stays uniform on the part.
    planar : PlanarPath
        The path this was mapped from.
    provenance : Provenance
    stats : dict
        3D step statistics and density variation.
    tool_axes : (N, 3) float64 or None
        Unit tool axes at the dwell points, part frame, from the tool tip up the spindle
        (:mod:`polishpath.axes`); None: the vertical tool of a 3-axis job (the ``z`` law).
    tool_axis : str
        The tool-axis law that made ``tool_axes`` (``--tool-axis`` text: ``z``, ``normal``,
        ``tilted:angle=20,azimuth=0``).
    """

    xyz: np.ndarray
    normals: np.ndarray
    face_ids: np.ndarray
    bary: np.ndarray
    dwell_weight: np.ndarray
    planar: PlanarPath
    provenance: Provenance = field(default_factory=lambda: Provenance("map", "unknown"))
    stats: dict[str, Any] = field(default_factory=dict)
    tool_axes: np.ndarray | None = None
    tool_axis: str = "z"

    def __post_init__(self):
        object.__setattr__(self, "xyz", _frozen_array(self.xyz, np.float64, 2, 3, "xyz"))
        object.__setattr__(self, "normals", _frozen_array(self.normals, np.float64, 2, 3, "normals"))
        if self.tool_axes is not None:
            ax = _frozen_array(self.tool_axes, np.float64, 2, 3, "tool_axes")
            if len(ax) != len(self.xyz):
                raise ParameterError(f"SurfacePath.tool_axes has {len(ax)} rows for {len(self.xyz)} dwell points.",
                                     "Give one tool axis per dwell point (polishpath.axes.tool_axes).")
            object.__setattr__(self, "tool_axes", ax)
        object.__setattr__(self, "face_ids", _frozen_array(self.face_ids, np.int64, 1, None, "face_ids"))
        object.__setattr__(self, "bary", _frozen_array(self.bary, np.float64, 2, 3, "bary"))
        object.__setattr__(self, "dwell_weight", _frozen_array(self.dwell_weight, np.float64, 1, None, "dwell_weight"))


@dataclass(frozen=True)
class NurbsCurve:
    """A NURBS curve (all weights 1 for interpolation: a non-rational B-spline).

    Attributes
    ----------
    degree : int
        Polynomial degree p (3 for the paper's cubic, order K = p + 1 = 4).
    knots : (n + p + 2,) float64
        Clamped, non-decreasing knot vector on [0, 1].
    control_points : (n + 1, d) float64
        Control points, mm.
    weights : (n + 1,) float64
        Weights (ones for a B-spline).
    """

    degree: int
    knots: np.ndarray
    control_points: np.ndarray
    weights: np.ndarray | None = None

    def __post_init__(self):
        object.__setattr__(self, "knots", _frozen_array(self.knots, np.float64, 1, None, "knots"))
        cp = _frozen_array(self.control_points, np.float64, 2, None, "control_points")
        object.__setattr__(self, "control_points", cp)
        w = self.weights if self.weights is not None else np.ones(len(cp))
        object.__setattr__(self, "weights", _frozen_array(w, np.float64, 1, None, "weights"))


@dataclass(frozen=True)
class SampleChunk:
    """A run of consecutive machine samples of one piece.

    Attributes
    ----------
    samples : (m, 3) float64
        Contact points at the constant period, mm (``ToolPath.samples`` rows).
    sample_params : (m,) float64
        Curve parameter of each sample (``ToolPath.sample_params``).
    feed_mm_min : (m,) float64
        Commanded feed at each sample, mm/min (``ToolPath.feed_mm_min``): the
        planned time of the move arriving at sample k is ``|s_k - s_(k-1)| / feed_k``.
    piece : int
        Index of the continuous piece (tool on the part) the samples belong to.
    axes : (m, 3) float64 or None
        Unit tool axes at the samples (``ToolPath.sample_axes`` rows); None: a 3-axis job.
    """

    samples: np.ndarray
    sample_params: np.ndarray
    feed_mm_min: np.ndarray
    piece: int
    axes: np.ndarray | None = None

    def __post_init__(self):
        s = np.asarray(self.samples, dtype=np.float64)
        u = np.asarray(self.sample_params, dtype=np.float64)
        f = np.asarray(self.feed_mm_min, dtype=np.float64)
        hint = "Give consecutive samples of one piece: points (m, 3) mm, their params (m,) and feeds (m,) mm/min."
        if s.ndim != 2 or s.shape[1] != 3 or len(s) == 0:
            raise ExportError(f"SampleChunk.samples must be (m >= 1, 3) points, got shape {s.shape}.", hint)
        if u.shape != (len(s),) or f.shape != (len(s),):
            raise ExportError(f"SampleChunk: sample_params {u.shape} and feed_mm_min {f.shape} must be "
                              f"({len(s)},) like the samples.", hint)
        if isinstance(self.piece, bool) or not isinstance(self.piece, (int, np.integer)) or self.piece < 0:
            raise ExportError(f"SampleChunk.piece must be a piece index >= 0, got {self.piece!r}.",
                              "Number the pieces 0, 1, ... in path order.")
        if self.axes is not None:
            ax = np.asarray(self.axes, dtype=np.float64)
            if ax.shape != s.shape:
                raise ExportError(f"SampleChunk.axes {ax.shape} must be ({len(s)}, 3) like the samples.", hint)
            object.__setattr__(self, "axes", ax)
        object.__setattr__(self, "samples", s)
        object.__setattr__(self, "sample_params", u)
        object.__setattr__(self, "feed_mm_min", f)
        object.__setattr__(self, "piece", int(self.piece))

    def __len__(self) -> int:
        return len(self.samples)


@dataclass(frozen=True)
class SampleSchedule:
    """Everything that determines a ToolPath's machine samples bit for bit, given its curve.

    The interpolator (``polishpath.smooth``) runs each piece's parameter range
    ``[u0, u1]`` at the constant period, the feed of the dwell region holding
    the parameter (cut by the chord-error limit and the machine limit);
    rerunning it with these values gives the same samples, params and feeds.

    Attributes
    ----------
    piece_params : (K, 2) float64
        Parameter range ``(u0, u1)`` run for each piece (``u1`` just below the next piece's start).
    dwell_pieces : (K + 1,) int64
        Dwell-point offsets of the pieces: piece k has regions ``dwell_pieces[k]:dwell_pieces[k + 1]``.
    region_bounds : (N + K,) float64
        Each piece's dwell-region boundaries (its ``n_k + 1`` values) one piece after the other.
    region_feeds : (N,) float64
        Feed of each dwell region after the schedule passes, mm/s.
    max_feed_mm_s : float
        Machine feed limit, mm/s (inf: none).
    period_ms : float
        Interpolation period, ms.
    chord_tol_mm : float
        Chord tolerance, mm.
    integrator : str
        Integrator name (``"taylor"`` or ``"ab-am"``).
    sample_pieces : (K + 1,) int64
        Sample offsets of the pieces; ``sample_pieces[-1]`` is the sample count.
    """

    piece_params: np.ndarray
    dwell_pieces: np.ndarray
    region_bounds: np.ndarray
    region_feeds: np.ndarray
    max_feed_mm_s: float
    period_ms: float
    chord_tol_mm: float
    integrator: str
    sample_pieces: np.ndarray

    def __post_init__(self):
        pp = _frozen_array(self.piece_params, np.float64, 2, 2, "piece_params")
        dp = _frozen_array(self.dwell_pieces, np.int64, 1, None, "dwell_pieces")
        rb = _frozen_array(self.region_bounds, np.float64, 1, None, "region_bounds")
        rf = _frozen_array(self.region_feeds, np.float64, 1, None, "region_feeds")
        sp = _frozen_array(self.sample_pieces, np.int64, 1, None, "sample_pieces")
        k = len(pp)
        if (len(dp) != k + 1 or len(sp) != k + 1 or dp[0] != 0 or sp[0] != 0 or np.any(np.diff(dp) < 1)
                or np.any(np.diff(sp) < 0) or len(rf) != dp[-1] or len(rb) != dp[-1] + k):
            raise ParameterError(
                f"SampleSchedule: {k} piece(s) need dwell_pieces and sample_pieces of {k + 1} increasing offsets "
                f"from 0, region_feeds of dwell_pieces[-1] and region_bounds of dwell_pieces[-1] + {k} values; got "
                f"{len(dp)}, {len(sp)}, {len(rf)}, {len(rb)}.", "Build the schedule with polishpath.smooth.smooth().")
        if not (np.all(rf > 0) and self.max_feed_mm_s > 0 and self.period_ms > 0 and self.chord_tol_mm > 0):
            raise ParameterError("SampleSchedule: feeds, the feed limit, the period and the chord tolerance must "
                                 "be positive.", "Build the schedule with polishpath.smooth.smooth().")
        for name, val in (("piece_params", pp), ("dwell_pieces", dp), ("region_bounds", rb),
                          ("region_feeds", rf), ("sample_pieces", sp)):
            object.__setattr__(self, name, val)
        for name in ("max_feed_mm_s", "period_ms", "chord_tol_mm"):
            object.__setattr__(self, name, float(getattr(self, name)))

    @property
    def n_pieces(self) -> int:
        return len(self.piece_params)

    @property
    def n_samples(self) -> int:
        return int(self.sample_pieces[-1])

    def piece(self, k: int) -> tuple[float, float, np.ndarray, np.ndarray]:
        """``(u0, u1, region_bounds (n_k + 1,), region_feeds (n_k,) mm/s)`` of piece ``k``."""
        a, b = int(self.dwell_pieces[k]), int(self.dwell_pieces[k + 1])
        return (float(self.piece_params[k, 0]), float(self.piece_params[k, 1]),
                self.region_bounds[a + k : b + k + 1], self.region_feeds[a:b])


@dataclass(frozen=True)
class ToolPath:
    """The smoothed path, densified for the machine.

    Attributes
    ----------
    curve : NurbsCurve
        Cubic curve through every dwell point (3D, mm).
    dwell_params : (N,) float64
        Curve parameter of each dwell point (``curve(dwell_params[k]) == dwell xyz[k]``).
    samples : (M, 3) float64
        Points at a constant interpolation period, mm (what the machine runs).
    sample_params : (M,) float64
        Curve parameter of each sample.
    feed_mm_min : (M,) float64
        Commanded feed at each sample, mm/min.
    period_ms : float
        Interpolation period, ms.
    surface_path : SurfacePath
        The dwell points this curve passes through.
    provenance : Provenance
    stats : dict
        Feed fluctuation, chord error, deviation from the surface ... (scalars and
        short lists only; per-point data lives in the array fields).
    dwell_times : (N,) float64 or None
        Time the schedule spends around each dwell point, s.
    sample_pieces : (K + 1,) int64, keyword, required
        Sample offsets of the K continuous pieces (the planar path's pieces): piece k is
        ``samples[sample_pieces[k]:sample_pieces[k + 1]]``; the tool lifts between pieces.
        ``sample_pieces[-1]`` is the sample count (also where the sample arrays are empty
        and the schedule regenerates them).
    piece_params : (K + 1,) float64, keyword, required
        Curve parameter where each piece starts, the curve's end last: piece k runs
        ``[piece_params[k], piece_params[k + 1])`` (``SampleSchedule.piece_params`` holds the
        ranges the interpolator runs, just below the next start).
    schedule : SampleSchedule or None
        What regenerates the samples bit for bit from ``curve`` (set by
        ``smooth``; ``polishpath.smooth.iter_sample_chunks`` streams them);
        None where the samples cannot be regenerated (built by hand, or feeds
        changed afterwards, e.g. by the machine schedule). With
        ``smooth(..., keep_samples=False)`` the sample arrays are empty and
        the schedule is the only way to the samples.
    sample_axes : (M, 3) float64 or None
        Unit tool axes at the samples (part frame, :mod:`polishpath.axes`): the law of
        ``surface_path.tool_axis`` at the normals interpolated in the curve parameter; filled when not given;
        None for a 3-axis job (``surface_path.tool_axes`` None).
    """

    curve: NurbsCurve
    dwell_params: np.ndarray
    samples: np.ndarray
    sample_params: np.ndarray
    feed_mm_min: np.ndarray
    period_ms: float
    surface_path: SurfacePath
    provenance: Provenance = field(default_factory=lambda: Provenance("smooth", "unknown"))
    stats: dict[str, Any] = field(default_factory=dict)
    dwell_times: np.ndarray | None = None
    schedule: SampleSchedule | None = None
    sample_pieces: np.ndarray = field(kw_only=True)
    piece_params: np.ndarray = field(kw_only=True)
    sample_axes: np.ndarray | None = None

    def __post_init__(self):
        if self.schedule is not None and not isinstance(self.schedule, SampleSchedule):
            raise ParameterError(f"ToolPath.schedule must be a SampleSchedule or None, got "
                                 f"{type(self.schedule).__name__}.", "Leave it None or pass smooth()'s schedule.")
        if self.dwell_times is not None:
            object.__setattr__(self, "dwell_times", _frozen_array(self.dwell_times, np.float64, 1, None, "dwell_times"))
        object.__setattr__(self, "dwell_params", _frozen_array(self.dwell_params, np.float64, 1, None, "dwell_params"))
        object.__setattr__(self, "samples", _frozen_array(self.samples, np.float64, 2, 3, "samples"))
        object.__setattr__(self, "sample_params", _frozen_array(self.sample_params, np.float64, 1, None, "sample_params"))
        object.__setattr__(self, "feed_mm_min", _frozen_array(self.feed_mm_min, np.float64, 1, None, "feed_mm_min"))
        self._set_pieces()
        ax = self.surface_path.tool_axes if self.surface_path is not None else None
        if ax is None:
            object.__setattr__(self, "sample_axes", None)
        else:
            if self.sample_axes is None:
                from .axes import axes_at_params

                sa = axes_at_params(self.surface_path, self.dwell_params, self.sample_params)
            else:
                sa = self.sample_axes
            sa = _frozen_array(sa, np.float64, 2, 3, "sample_axes")
            if len(sa) != len(self.samples):
                raise ParameterError(f"ToolPath.sample_axes has {len(sa)} rows for {len(self.samples)} samples.",
                                     "Leave it out: it is interpolated from the dwell points' tool axes.")
            object.__setattr__(self, "sample_axes", sa)

    def _set_pieces(self) -> None:
        """Check and freeze ``sample_pieces`` / ``piece_params`` against the samples, schedule and dwell pieces."""
        sp = _frozen_array(self.sample_pieces, np.int64, 1, None, "ToolPath.sample_pieces")
        pp = _frozen_array(self.piece_params, np.float64, 1, None, "ToolPath.piece_params")
        m = len(self.samples)
        planar = getattr(self.surface_path, "planar", None)
        k = len(planar.pieces) - 1 if planar is not None else len(sp) - 1
        sch = self.schedule
        problem = None
        if len(sp) < 2 or sp[0] != 0 or np.any(np.diff(sp) < 0):
            problem = f"sample_pieces must be increasing offsets from 0, at least [0, M]; got {sp.tolist()[:6]}"
        elif len(sp) != k + 1 or len(pp) != k + 1:
            problem = (f"the path has {k} piece(s): sample_pieces and piece_params need {k + 1} values each, got "
                       f"{len(sp)} and {len(pp)}")
        elif m and sp[-1] != m:
            problem = f"sample_pieces ends at {sp[-1]}, but the path holds {m} samples"
        elif sch is not None and not np.array_equal(sp, sch.sample_pieces):
            problem = "sample_pieces differ from the schedule's"
        elif not (np.isfinite(pp).all() and np.all(np.diff(pp) > 0)):
            problem = f"piece_params must be increasing curve parameters, got {pp.tolist()[:6]}"
        if problem is not None:
            raise ParameterError(f"ToolPath: {problem}.", "Build the ToolPath with polishpath.smooth.smooth() (or give "
                                 "one sample offset and one start parameter per piece, the totals last).")
        object.__setattr__(self, "sample_pieces", sp)
        object.__setattr__(self, "piece_params", pp)
