"""What a later stage needs travels in typed fields (issue 25, item 3), never in a ``stats`` dict.

The pieces of the machine samples (``ToolPath.sample_pieces`` / ``piece_params``) and the dwell
points' lattice (``PlanarPath.lattice`` / ``dwell_points_only``) are required, checked fields: a
ToolPath cannot be built without its pieces, every reader of the samples keeps the tool's lift
between pieces with no figure in ``stats`` at all, and the run folder writes and reads them (and
still reads a format-2 folder, where they were figures of summary.json). tests/test_architecture.py
checks that no module reads them from ``stats`` and that no frozen object's ``stats`` is changed.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

import polishpath
from polishpath.dwell.delivery import region_times
from polishpath.errors import InputError, ParameterError
from polishpath.export import write_gcode
from polishpath.export.chunks import sample_chunks
from polishpath.export.post import get_post, planned_segment_times
from polishpath.mapping import map_to_surface
from polishpath.pathops import step_mask
from polishpath.pipeline.surfaceplan import _grid_step_max
from polishpath.plan import plan
from polishpath.runfolder import read_run
from polishpath.simulate.jobpath import timed_path
from polishpath.smooth import smooth
from polishpath.types import Lattice, Region, ToolPath
from test_mapping_helpers import serpentine_path, spherical_cap


@pytest.fixture(scope="module")
def two_pieces() -> ToolPath:
    """A two-piece path on a spherical cap, its figures dropped: nothing of the pieces may come from ``stats``."""
    cap = spherical_cap(n_r=10, n_phi=36)
    n = serpentine_path(cap, 2.0, seed=5).n_points
    sp = map_to_surface(cap, serpentine_path(cap, 2.0, seed=5, pieces_at=[n // 2]))
    tp = smooth(sp, feed_mm_min=3000.0, period_ms=8.0, chord_tol_mm=5e-3)
    assert len(tp.sample_pieces) == 3 and len(tp.piece_params) == 3
    return dataclasses.replace(tp, stats={})


def _args(tp: ToolPath) -> tuple:
    return (tp.curve, tp.dwell_params, tp.samples, tp.sample_params, tp.feed_mm_min, tp.period_ms, tp.surface_path)


def test_a_tool_path_cannot_be_built_without_its_pieces(two_pieces):
    tp = two_pieces
    with pytest.raises(TypeError, match="sample_pieces"):
        ToolPath(*_args(tp))  # no silent "one piece"
    m = len(tp.samples)
    k0, k1 = tp.curve.knots[0], tp.curve.knots[-1]
    with pytest.raises(ParameterError, match="2 piece"):  # one piece for a path of two
        ToolPath(*_args(tp), sample_pieces=[0, m], piece_params=[k0, k1])
    with pytest.raises(ParameterError, match=f"holds {m} samples"):
        ToolPath(*_args(tp), sample_pieces=[0, 10, m - 1], piece_params=tp.piece_params)
    with pytest.raises(ParameterError, match="increasing curve parameters"):
        ToolPath(*_args(tp), sample_pieces=tp.sample_pieces, piece_params=tp.piece_params[::-1])
    with pytest.raises(ParameterError, match="differ from the schedule"):
        ToolPath(*_args(tp), schedule=tp.schedule, sample_pieces=[0, 10, m], piece_params=tp.piece_params)
    same = ToolPath(*_args(tp), sample_pieces=list(tp.sample_pieces), piece_params=list(tp.piece_params))
    assert same.sample_pieces.dtype == np.int64 and not same.sample_pieces.flags.writeable


def test_every_reader_keeps_the_lift_between_pieces(two_pieces):
    tp = two_pieces
    off = tp.sample_pieces
    # export: chunks cut at the lift, the lift's move has no planned time, the program lifts twice
    chunks = list(sample_chunks(tp, size=1000))
    starts = np.cumsum([0] + [len(c) for c in chunks])
    assert {c.piece for c in chunks} == {0, 1} and off[1] in starts
    assert all(c.piece == (0 if a < off[1] else 1) for a, c in zip(starts, chunks))
    dt = planned_segment_times(tp)
    assert dt[off[0]] == 0.0 and dt[off[1]] == 0.0 and np.all(dt[off[1] - 5 : off[1]] > 0)
    import io

    buf = io.StringIO()
    write_gcode(tp, buf)
    body = [ln for ln in buf.getvalue().splitlines() if ln and not ln.startswith(("(", "%"))]
    assert sum(ln.startswith("G00X") for ln in body) == 2  # one approach per piece
    assert len(get_post("fanuc").prepare(tp, "nurbs", 0.0)["curves"]) == 2  # one NURBS per piece
    # dwell: each piece's regions add up to its own samples' time (one period apart), not across the lift
    rt = region_times(tp)
    T = tp.period_ms / 1000.0
    doff = tp.surface_path.planar.pieces
    for k in range(2):
        # one period per step but the piece's last, cut short at its end: its length over its feed (the G-code's)
        last = np.linalg.norm(tp.samples[off[k + 1] - 1] - tp.samples[off[k + 1] - 2]) / (tp.feed_mm_min[off[k + 1] - 1] / 60.0)
        want = (off[k + 1] - off[k] - 2) * T + min(T, last)
        assert rt[doff[k]:doff[k + 1]].sum() == pytest.approx(want, rel=1e-9)
    # simulate: the timed path's pieces are the samples'
    assert np.array_equal(timed_path(tp).pieces, off)


def test_the_planners_lattice_is_typed():
    region = Region([[0, 0], [12, 0], [12, 9], [0, 9]])
    p = plan(region, 0.7, "pseudorandom", seed=3, rotation=0.3)
    assert isinstance(p.lattice, Lattice) and p.dwell_points_only and "on_grid" not in p.stats
    assert np.allclose(p.lattice.to_uv(p.ij), p.uv, atol=1e-12, rtol=0)
    assert np.allclose(np.linalg.norm(p.lattice.basis, axis=0), 0.7) and np.allclose(p.lattice.origin, p.origin)
    within = np.ones(len(p.uv) - 1, bool)
    within[p.pieces[1:-1] - 1] = False
    assert p.lattice.is_step(np.diff(p.ij, axis=0))[within].all()  # the walk takes the lattice's steps only
    assert not p.lattice.is_step([[0, 0], [2, 0], [1, 2]]).any()
    spiral = plan(region, 0.7, "spiral")
    assert spiral.lattice is not None and spiral.dwell_points_only is False
    with pytest.raises(ParameterError, match="Lattice or None"):
        dataclasses.replace(p, lattice="square")


def test_the_step_reduction_counts_the_lattice_steps_only_where_there_is_a_lattice():
    cap = spherical_cap(n_r=10, n_phi=36)
    t = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    raster = plan(Region(12.0 * np.c_[np.cos(t), np.sin(t)]), 1.0, "raster")  # chords along the rim between rows
    sp = map_to_surface(cap, raster)
    steps = np.linalg.norm(np.diff(sp.xyz, axis=0), axis=1)
    within = step_mask(len(sp.xyz), raster.pieces)
    neighbour = np.abs(np.diff(raster.ij, axis=0)).max(axis=1) == 1
    assert (within & ~neighbour).any()
    assert _grid_step_max(raster, sp) == steps[within & neighbour].max()
    no_lattice = dataclasses.replace(raster, lattice=None)  # a set without a lattice: every step counts
    assert _grid_step_max(no_lattice, sp) == steps[within].max() > steps[within & neighbour].max()


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    out = tmp_path_factory.mktemp("typed") / "run"
    job = polishpath.run(surface="hemisphere:R=12,triangles=700", spacing=1.5, seed=5, report=False)
    job.save(out)
    return job, out


def _folder_as_format_2(src: Path, dst: Path, job) -> Path:
    """A copy of the run folder as format 2 wrote it: the pieces and ``on_grid`` were figures of summary.json."""
    dst.mkdir()
    s = json.loads((src / "summary.json").read_text())
    s["run_folder_schema"] = 2
    s["smooth"]["stats"].update(sample_pieces=job.tool_path.sample_pieces.tolist(),
                                piece_params=job.tool_path.piece_params.tolist())
    s["plan"]["stats"]["on_grid"] = True
    (dst / "summary.json").write_text(json.dumps(s))
    with np.load(src / "run.npz") as z:
        new = {"sample_pieces", "piece_params", "plan_lattice_basis", "plan_lattice_origin", "plan_lattice_steps",
               "plan_dwell_points_only"}
        assert new <= set(z.files)
        np.savez(dst / "run.npz", **{k: z[k] for k in z.files if k not in new})
    (dst / "job.toml").write_bytes((src / "job.toml").read_bytes())
    return dst


def test_the_run_folder_keeps_the_pieces_and_the_lattice(saved, tmp_path):
    job, out = saved
    run = read_run(out)
    tp, planar = run.tool_path, run.planar
    assert "sample_pieces" not in run.section("smooth", "stats") and "on_grid" not in run.section("plan", "stats")
    assert np.array_equal(tp.sample_pieces, job.tool_path.sample_pieces)
    assert np.array_equal(tp.piece_params, job.tool_path.piece_params)
    assert np.array_equal(planar.lattice.basis, job.planar.lattice.basis) and planar.dwell_points_only
    assert np.array_equal(planar.lattice.neighbour_offsets, job.planar.lattice.neighbour_offsets)
    # a format-2 folder reads the same
    old = read_run(_folder_as_format_2(out, tmp_path / "format2", job))
    assert old.schema == 2
    assert np.array_equal(old.tool_path.sample_pieces, tp.sample_pieces)
    assert np.array_equal(old.tool_path.piece_params, tp.piece_params)
    assert np.allclose(old.planar.lattice.basis, planar.lattice.basis, rtol=0, atol=1e-15)
    assert old.planar.dwell_points_only and "sample_pieces" not in old.tool_path.stats
    # a format-3 folder without them is refused, saying what it lacks
    broken = tmp_path / "broken"
    broken.mkdir()
    for name in ("summary.json", "job.toml"):
        (broken / name).write_bytes((out / name).read_bytes())
    with np.load(out / "run.npz") as z:
        np.savez(broken / "run.npz", **{k: z[k] for k in z.files if k not in ("sample_pieces", "piece_params")})
    with pytest.raises(InputError, match="lacks sample_pieces, piece_params"):
        read_run(broken).tool_path
