"""Bad input to the planning stage and the core data types: a PolishPathError subclass that says what to do.

Every public function of ``polishpath.plan`` (and its peers module) and every
data type of ``polishpath.types`` that takes user input is called here with bad
input; each must raise a :class:`~polishpath.errors.PolishPathError` subclass
with a hint, never a bare ValueError / TypeError / IndexError from numpy or
numba. ``test_every_public_function_is_covered`` keeps the list complete.
"""

from __future__ import annotations

import inspect

import numpy as np
import pytest

import polishpath.plan as P
from polishpath import meshops, types
from polishpath.errors import InvariantError, PolishPathError, SpacingTooLargeError
from polishpath.plan import peers
from polishpath.plan.checks import check_seed
from polishpath.types import Region


def _disc(r=5.0, n=48):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.c_[r * np.cos(t), r * np.sin(t)]


R = Region(_disc())
G = P.dwell_grid(R, 1.0)
SQ = [[0, 0], [1, 0], [1, 1]]
ij = np.zeros((3, 2))


def _surface():
    return types.Surface([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])


#: (function covered, call with bad input)
CASES = [
    # types
    ("Region", lambda: Region([[0, 0], [1, 0]])),
    ("Region", lambda: Region("abc")),
    ("Region", lambda: Region([[0, 0], [1, 0], [np.nan, 1]])),
    ("Region", lambda: Region(SQ, np.zeros((3, 2)))),
    ("Region", lambda: Region(SQ, 5)),
    ("Region", lambda: Region(SQ, ([[0, 0], [1, 1]],))),
    ("Surface", lambda: types.Surface(np.zeros((3, 2)), [[0, 1, 2]])),
    ("Surface", lambda: types.Surface([[0, 0, "a"]], [[0, 1, 2]])),
    ("Surface", lambda: types.Surface([[0, 0, 0], [1, 0]], [[0, 1, 2]])),
    ("Flattening", lambda: types.Flattening(_surface(), np.zeros((3, 3)), np.zeros((1, 3)))),
    ("PlanarPath", lambda: types.PlanarPath(np.zeros((3, 3)), np.zeros((3, 2)), 1.0)),
    ("PlanarPath", lambda: types.PlanarPath(np.zeros((3, 2)), np.zeros((3, 2)), 1.0, pieces=[[0, 3]])),
    ("SurfacePath", lambda: types.SurfacePath(np.zeros((2, 2)), np.zeros((2, 3)), [0, 0], np.zeros((2, 3)),
                                              np.ones(2), types.PlanarPath(np.zeros((2, 2)), np.zeros((2, 2)), 1.0))),
    ("NurbsCurve", lambda: types.NurbsCurve(3, np.zeros((2, 2)), np.zeros((4, 3)))),
    ("ToolPath", lambda: types.ToolPath(None, np.zeros((2, 2)), np.zeros((2, 3)), np.zeros(2), np.zeros(2), 1.0, None,
                                        sample_pieces=[0, 2], piece_params=[0.0, 1.0])),
    ("ToolPath", lambda: types.ToolPath(None, np.zeros(2), np.zeros((2, 3)), np.zeros(2), np.zeros(2), 1.0, None,
                                        sample_pieces=[0, 3], piece_params=[0.0, 1.0])),
    ("Lattice", lambda: types.Lattice([[1.0, 2.0], [2.0, 4.0]], [0.0, 0.0], [[1, 0]])),
    ("Lattice", lambda: types.Lattice(np.eye(2), [0.0, 0.0], [[1, 0], [0, 0]])),
    ("SampleChunk", lambda: types.SampleChunk(np.zeros((0, 3)), np.zeros(0), np.zeros(0), 0)),
    ("SampleChunk", lambda: types.SampleChunk(np.zeros((2, 3)), np.zeros(2), np.zeros(2), -1)),
    ("SampleSchedule", lambda: types.SampleSchedule(np.zeros((1, 2)), [0, 2], np.zeros(3), np.ones(1), 1.0, 4.0,
                                                    1e-3, "taylor", [0, 10])),
    ("SampleSchedule", lambda: types.SampleSchedule(np.zeros((1, 2)), [0, 1], np.zeros(2), np.ones(1), 0.0, 4.0,
                                                    1e-3, "taylor", [0, 10])),
    # meshops
    ("face_areas", lambda: meshops.face_areas(np.zeros((3, 3)), [[0, 1, 2]], signed=True)),
    # plan: the dwell grid
    ("dwell_grid", lambda: P.dwell_grid(_disc(), 1.0)),
    ("dwell_grid", lambda: P.dwell_grid(R, 0.0)),
    ("dwell_grid", lambda: P.dwell_grid(R, -1.0)),
    ("dwell_grid", lambda: P.dwell_grid(R, np.nan)),
    ("dwell_grid", lambda: P.dwell_grid(R, "1")),
    ("dwell_grid", lambda: P.dwell_grid(R, None)),
    ("dwell_grid", lambda: P.dwell_grid(R, 1.0, margin=-1.0)),
    ("dwell_grid", lambda: P.dwell_grid(R, 1.0, margin="a")),
    ("dwell_grid", lambda: P.dwell_grid(R, 1.0, origin=(1, 2, 3))),
    ("dwell_grid", lambda: P.dwell_grid(R, 1.0, rotation=np.inf)),
    ("dwell_grid", lambda: P.dwell_grid(R, 100.0)),
    ("region_polygon", lambda: P.region_polygon("disc")),
    ("region_polygon", lambda: P.region_polygon(R, margin=-0.5)),
    ("region_polygon", lambda: P.region_polygon(Region([[0, 0], [2, 2], [2, 0], [0, 2]]))),
    ("grid_to_uv", lambda: P.grid_to_uv(np.zeros((3, 3)), 1.0, (0, 0), 0.0)),
    ("grid_to_uv", lambda: P.grid_to_uv(ij, 0.0, (0, 0), 0.0)),
    ("grid_to_uv", lambda: P.grid_to_uv(ij, 1.0, (0,), 0.0)),
    ("grid_to_uv", lambda: P.grid_to_uv("ij", 1.0, (0, 0), 0.0)),
    ("uv_to_grid", lambda: P.uv_to_grid(np.zeros(3), 1.0, (0, 0), 0.0)),
    ("uv_to_grid", lambda: P.uv_to_grid(ij, 1.0, (0, 0), "x")),
    ("nearest_dwell_point", lambda: P.nearest_dwell_point(G, (1, 2, 3))),
    ("nearest_dwell_point", lambda: P.nearest_dwell_point("grid", (0, 0))),
    # plan: the planner
    ("plan", lambda: P.plan(_disc(), 1.0)),
    ("plan", lambda: P.plan(R, 1.0, "nope")),
    ("plan", lambda: P.plan(R, 1.0, ["raster"])),
    ("plan", lambda: P.plan(R, 1.0, seed=-1)),
    ("plan", lambda: P.plan(R, 1.0, seed=2**63)),
    ("plan", lambda: P.plan(R, 1.0, seed=1.5)),
    ("plan", lambda: P.plan(R, 1.0, seed=True)),
    ("plan", lambda: P.plan(R, 1.0, seed="3")),
    ("plan", lambda: P.plan(R, 1.0, start=(1,))),
    ("plan", lambda: P.plan(R, 1.0, start=("a", "b"))),
    ("plan", lambda: P.plan(R, 1.0, foo=1)),
    ("plan", lambda: P.plan(R, 1.0, "raster", backtrack=3)),
    ("plan", lambda: P.plan(R, 1.0, "spiral", steer=3)),
    ("plan", lambda: P.plan(R, 1.0, "rectangular", window=3)),
    ("plan", lambda: P.plan(R, 1.0, window=-1)),
    ("plan", lambda: P.plan(R, 1.0, backtrack_budget=2.0)),
    ("plan", lambda: P.plan(R, 1.0, shortest="yes")),
    ("plan", lambda: P.plan(R, 1.0, max_kicks=1.5)),
    ("plan", lambda: P.plan(R, 1.0, "unicursal", tree="prim")),
    ("plan", lambda: P.plan(R, 1.0, "unicursal", phase=(2, 0))),
    ("plan", lambda: P.plan(R, 1.0, "maze", tree="x")),
    ("plan", lambda: P.plan(R, 1.0, "hilbert", tree="dfs")),
    ("pseudorandom_order", lambda: P.pseudorandom_order("grid", seed=0)),
    ("pseudorandom_order", lambda: P.pseudorandom_order(G, seed=-1)),
    ("pseudorandom_order", lambda: P.pseudorandom_order(G, seed=0, start=G.n)),
    ("pseudorandom_order", lambda: P.pseudorandom_order(G, seed=0, start=-1)),
    ("pseudorandom_order", lambda: P.pseudorandom_order(G, seed=0, steer=-2)),
    ("register_pattern", lambda: P.register_pattern("", lambda *a, **k: None)),
    ("register_pattern", lambda: P.register_pattern("x", 3)),
    ("pseudorandom_order", lambda: P.pseudorandom_order(G, seed=None)),
    ("pseudorandom_order", lambda: P.pseudorandom_order(G, seed=2.0)),
    # plan: the Table 3 peers, called directly
    ("pattern_unicursal", lambda: peers.pattern_unicursal(G, R, seed=-1, start=0)),
    ("pattern_unicursal", lambda: peers.pattern_unicursal(G, R, seed=0, start=0, phase=(0, 1, 0))),
    ("pattern_maze", lambda: peers.pattern_maze(G, R, seed=0, start=G.n)),
    ("pattern_maze", lambda: peers.pattern_maze(G, R, seed=0, start=0, tree="prim")),
    ("pattern_fractal", lambda: peers.pattern_fractal("grid", R, seed=0, start=0)),
    ("pattern_hilbert", lambda: peers.pattern_hilbert(G, R, seed=0, start=0, foo=1)),
    ("fractal_sequence", lambda: peers.fractal_sequence(0, 0)),
    ("fractal_sequence", lambda: peers.fractal_sequence(16, 0)),
    ("fractal_sequence", lambda: peers.fractal_sequence(2, -1)),
    ("hilbert_sequence", lambda: peers.hilbert_sequence(-1)),
    ("hilbert_sequence", lambda: peers.hilbert_sequence(2, 8)),
    ("bspline_deviation", lambda: peers.bspline_deviation(np.zeros((3, 4)))),
    ("bspline_deviation", lambda: peers.bspline_deviation(np.zeros((5, 2)), pieces=[0, 3])),
    ("bspline_deviation", lambda: peers.bspline_deviation(np.zeros((5, 2)), pieces=[0.0, 5.0])),
    ("bspline_deviation", lambda: peers.bspline_deviation(np.zeros((5, 2)), samples_per_span=0)),
]

#: Public names that take no user input of their own, or whose checks live elsewhere.
NOT_INPUT = {
    # constants, registries and classes built by the functions above
    "DIRS", "DIR_NAMES", "PATTERNS", "RANDOM_PATTERNS", "PEER_PATTERNS", "DwellGrid", "PatternResult",
    "register_peers", "Provenance", "Finding",
    # plan/metrics.py: the path metrics, tested with the pathops core (tests/test_pathops.py, test_plan_metrics.py)
    "path_metrics", "count_crossings", "direction_shares", "largest_empty_disc",
}


@pytest.mark.parametrize("case", range(len(CASES)), ids=[f"{name}-{i}" for i, (name, _) in enumerate(CASES)])
def test_bad_input_raises_a_polishpath_error_with_a_hint(case):
    _, call = CASES[case]
    with pytest.raises(PolishPathError) as info:
        call()
    err = info.value
    assert err.message and err.hint, f"{type(err).__name__} without a message and a hint: {err}"
    assert "bug" not in str(err).lower()


def _public_names() -> set[str]:
    names = set(P.__all__) | set(peers.__all__)
    names |= {n for n, obj in vars(types).items()
              if inspect.isclass(obj) and obj.__module__ == types.__name__ and not n.startswith("_")}
    return names


def test_every_public_function_is_covered():
    covered = {name for name, _ in CASES}
    missing = _public_names() - covered - NOT_INPUT
    assert not missing, f"public functions without a bad-input case: {sorted(missing)}"
    assert not (covered - _public_names() - {"face_areas"}), "a case names a function that is not public"


def test_spacing_too_large_is_its_own_error():
    with pytest.raises(SpacingTooLargeError, match="smaller spacing"):
        P.dwell_grid(R, 100.0)


def test_the_planner_follows_the_programs_seed_rule():
    from polishpath.provenance import DRAWN_SEED_LIMIT, resolve_seed

    assert check_seed(np.int64(7)) == 7 and type(check_seed(np.int64(7))) is int
    assert check_seed(2**63 - 1) == 2**63 - 1
    path = P.plan(R, 1.0, seed=None)
    assert 0 <= path.provenance.seed < DRAWN_SEED_LIMIT
    assert P.plan(R, 1.0, seed=path.provenance.seed).uv.tobytes() == path.uv.tobytes()
    for bad in (-1, 2**63, 1.0, True, "1"):  # one message for the job and the planner
        with pytest.raises(PolishPathError) as a:
            resolve_seed(bad)
        with pytest.raises(PolishPathError) as b:
            P.plan(R, 1.0, seed=bad)
        assert a.value.message == b.value.message


def test_an_internal_check_is_not_reported_as_the_users_mistake():
    assert not issubclass(InvariantError, PolishPathError)
    assert issubclass(InvariantError, RuntimeError)
