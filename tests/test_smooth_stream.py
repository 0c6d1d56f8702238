"""The machine samples as a regenerable stream (issue 15 item 4).

The kernels are resumable (calls resumed from the state the previous one left
give the samples of one call, bit for bit), ``smooth.iter_sample_chunks``
regenerates a ToolPath's samples from its curve and ``SampleSchedule`` in
chunks, and ``smooth(..., keep_samples=False)`` holds no sample yet reports the
same figures as ``keep_samples=True``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import polishpath.smooth.interpolate as interp
from polishpath.errors import ParameterError, SmoothingError
from polishpath.mapping import map_to_surface
from polishpath.smooth import iter_sample_chunks, smooth
from polishpath.smooth.samples import KernelRun
from polishpath.smooth.spans import ST_CE_MAX, ST_DONE, ST_FALLBACKS, chord_errors_kernel, new_state
from polishpath.types import SampleChunk, SampleSchedule, ToolPath
from test_mapping_helpers import serpentine_path, spherical_cap

INTEGRATORS = ("taylor", "ab-am")


@pytest.fixture(scope="module")
def mapped():
    """A mapped serpentine path of several pieces on a spherical cap (the mesh for the boundary check)."""
    cap = spherical_cap(n_r=10, n_phi=32)
    path = serpentine_path(cap, 1.5, seed=11)
    assert len(path.pieces) > 2
    return cap, map_to_surface(cap, path)


@pytest.fixture(scope="module", params=INTEGRATORS)
def kept(request, mapped):
    cap, sp = mapped
    return smooth(sp, surface=cap.surface, feed_mm_min=1200.0, period_ms=4.0, chord_tol_mm=1e-3,
                  integrator=request.param)


def _joined(chunks):
    chunks = list(chunks)
    return (np.concatenate([c.samples for c in chunks]), np.concatenate([c.sample_params for c in chunks]),
            np.concatenate([c.feed_mm_min for c in chunks]), chunks)


@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("size", [1, 2, 7, 101, 10**7])
def test_resumed_kernel_calls_give_the_samples_of_one_call(integrator, size):
    """Chunks of 1, 2, a prime, more than the piece: the same params, points and feeds, bit for bit."""
    rng = np.random.default_rng(5)
    pts = np.cumsum(rng.normal(scale=0.5, size=(40, 3)), axis=0)
    curve, u = interp_nurbs(pts)
    kc = interp.kernel_curve(curve)
    u0, u1 = float(curve.knots[0]), float(curve.knots[-1])
    rb = interp.dwell_regions(u, u0, u1)
    rfeed = rng.uniform(5.0, 40.0, size=len(u))
    kernel = interp.integrator_kernel(integrator)
    state, times = new_state(), np.zeros(len(rb))
    whole = kernel(kc.breaks, kc.coeffs, kc.bends, kc.size, u0, u1, rb, rfeed, 50.0, 0.002, 1e-3, state, 10**6, times)
    assert state[ST_DONE] == 1.0
    run = KernelRun(kernel, kc, u0, u1, rb, rfeed, 50.0, 0.002, 1e-3, size=size)
    parts = list(run)
    assert all(1 <= len(p[0]) <= size for p in parts)
    for j in range(3):
        assert np.array_equal(np.concatenate([p[j] for p in parts]), whole[j])
    # the figures the kernel accumulates are the same, bit for bit, whatever the chunks
    assert np.array_equal(run.state, state) and np.array_equal(run.times, times)
    # ... and the figures are those of the samples: the chord errors and the region times measured afterwards
    assert state[ST_CE_MAX] == chord_errors_kernel(kc.breaks, kc.coeffs, whole[0], whole[1], 3).max()
    tt = np.arange(len(whole[0])) * 0.002
    # the piece's last step, cut short at its end, takes its length over its feed (the G-code's block time)
    tt[-1] = tt[-2] + 0.002 * min(1.0, np.linalg.norm(whole[1][-1] - whole[1][-2]) / (whole[2][-1] * 0.002))
    assert np.allclose(run.boundary_times(), np.interp(rb, whole[0], tt), rtol=1e-13, atol=1e-15)
    assert np.array_equal(run.boundary_times()[:-1], np.interp(rb, whole[0], np.arange(len(whole[0])) * 0.002)[:-1])
    if integrator == "ab-am":
        assert state[ST_FALLBACKS] < len(whole[0]) - 1  # the multistep history is used (and carried), not restarted


@pytest.mark.parametrize("size", [1, 7, 101, None])
def test_the_scheduling_kernel_in_chunks_gives_one_call_and_the_plain_kernel_at_its_feeds(size):
    """taylor_schedule_kernel finds each region's feed as it runs and runs regions again: in chunks of 1, 7,
    101 or in one go it gives the same samples, feeds found and figures, and they are, bit for bit, those of
    the plain kernel run at the feeds it found (what regenerates them) - also with a region too long to be
    run again (more than RERUN_MAX_SAMPLES samples, a call then stops inside it)."""
    from polishpath.smooth.taylor import RERUN_MAX_SAMPLES
    from polishpath.smooth.timing import KERNEL_ORDER

    rng = np.random.default_rng(8)
    pts = np.cumsum(rng.normal(scale=0.4, size=(60, 3)), axis=0)
    curve, u = interp_nurbs(pts)
    kc = interp.kernel_curve(curve)
    u0, u1 = float(curve.knots[0]), float(curve.knots[-1])
    rb = interp.dwell_regions(u, u0, u1)
    want = rng.uniform(0.02, 0.06, size=len(u))
    want[20] = 1.5 * RERUN_MAX_SAMPLES * 0.002  # a region of about 6,000 samples
    gx, gw = np.polynomial.legendre.leggauss(KERNEL_ORDER)
    sched = (interp.SCHEDULING_KERNELS["taylor"], want, u, gx, gw, 2, 0.01)

    def scheduled(chunk):
        kr = KernelRun(interp.INTEGRATORS["taylor"], kc, u0, u1, rb, np.ones(len(u)), 50.0, 0.002, 1e-3,
                       size=chunk, cap=1024, schedule=sched)
        parts = list(kr)
        return kr, [np.concatenate([p[j] for p in parts]) for j in range(3)], parts

    one, whole, _ = scheduled(None)
    regions, rerun, most = one.reruns()
    assert regions > 0 and rerun > 0 and most == 2  # some regions were run again
    spent = np.diff(one.boundary_times())
    assert spent[20] > RERUN_MAX_SAMPLES * 0.002
    if size is not None:
        kr, got, parts = scheduled(size)
        assert max(len(p[0]) for p in parts) <= size + RERUN_MAX_SAMPLES + 1 and len(parts) > 3
        for j in range(3):
            assert np.array_equal(got[j], whole[j])
        assert np.array_equal(kr.region_feed, one.region_feed) and np.array_equal(kr.state, one.state)
        assert np.array_equal(kr.times, one.times)
        return
    plain = KernelRun(interp.INTEGRATORS["taylor"], kc, u0, u1, rb, one.region_feed, 50.0, 0.002, 1e-3, cap=10)
    parts = list(plain)
    for j in range(3):
        assert np.array_equal(np.concatenate([p[j] for p in parts]), whole[j])
    assert np.array_equal(plain.times, one.times) and plain.figures() == one.figures()
    # and the regions are nearer their times than the plain kernel at the feeds solved before interpolating
    # (the median: the largest misses are the tight turns that even the feed limit cannot run in time)
    from polishpath.smooth.timing import DEFAULT_ORDER, solve_region_feeds

    qx, qw = np.polynomial.legendre.leggauss(DEFAULT_ORDER)
    feeds, _, _ = solve_region_feeds(kc.breaks, kc.coeffs, rb, u, want, 50.0, 0.002, 1e-3, qx, qw)
    before = KernelRun(interp.INTEGRATORS["taylor"], kc, u0, u1, rb, feeds, 50.0, 0.002, 1e-3, cap=10)
    list(before)
    miss = [float(np.median(np.abs(np.diff(k.boundary_times()) / want - 1))) for k in (before, one)]
    assert miss[1] < 0.5 * miss[0]


def interp_nurbs(pts):
    from polishpath.smooth import interpolate_nurbs

    return interpolate_nurbs(pts)


@pytest.mark.parametrize("size", [1, 13, 997, 10**8])
def test_streamed_chunks_equal_the_kept_samples(kept, size):
    """iter_sample_chunks: the kept arrays bit for bit, every chunk within one piece and at most `size` long."""
    if size == 1 and kept.provenance.params["integrator"] == "ab-am":
        size = 3  # (1 is run with the Taylor integrator; keeps the suite fast)
    smp, par, feed, chunks = _joined(iter_sample_chunks(kept, size=size))
    assert np.array_equal(smp, kept.samples) and np.array_equal(par, kept.sample_params)
    assert np.array_equal(feed, kept.feed_mm_min)
    assert all(isinstance(c, SampleChunk) and 1 <= len(c) <= size for c in chunks)
    off = kept.sample_pieces
    assert kept.schedule.n_samples == off[-1] == len(kept.samples)
    start = 0
    for c in chunks:  # each chunk lies within its piece's sample range
        assert off[c.piece] <= start and start + len(c) <= off[c.piece + 1]
        start += len(c)
    assert sorted({c.piece for c in chunks}) == list(range(len(off) - 1))


def _same_stats(a: dict, b: dict):
    assert a.keys() == b.keys()
    for k in a:
        if k == "seconds" or k.endswith("interpolation_s"):
            continue
        va, vb = a[k], b[k]
        if isinstance(va, float) and isinstance(vb, float):
            assert va == pytest.approx(vb, rel=1e-12, abs=1e-300), k
        else:
            assert va == vb, k


@pytest.mark.parametrize("size", [5, 4096])
def test_keep_samples_false_holds_no_sample_and_reports_the_same_figures(mapped, kept, size):
    cap, sp = mapped
    lean = smooth(sp, surface=cap.surface, feed_mm_min=1200.0, period_ms=4.0, chord_tol_mm=1e-3,
                  integrator=kept.provenance.params["integrator"], keep_samples=False, chunk_samples=size)
    assert lean.samples.shape == (0, 3) and lean.sample_params.shape == (0,) and lean.feed_mm_min.shape == (0,)
    _same_stats(lean.stats, kept.stats)
    assert lean.stats["boundary_excursion_samples"] > 0  # the check saw samples beyond the rim, chunk by chunk
    assert lean.stats["schedule_passes"] > 1  # the passes themselves ran chunk by chunk
    assert np.array_equal(lean.dwell_times, kept.dwell_times)
    for f in dataclasses.fields(SampleSchedule):
        assert np.array_equal(getattr(lean.schedule, f.name), getattr(kept.schedule, f.name)), f.name
    smp, par, feed, _ = _joined(iter_sample_chunks(lean, size=size * 3 + 1))
    assert np.array_equal(smp, kept.samples) and np.array_equal(par, kept.sample_params)
    assert np.array_equal(feed, kept.feed_mm_min)


def test_keep_samples_false_runs_the_kernel_in_bounded_chunks(mapped, monkeypatch):
    """Memory bounded by the chunk size: no kernel call returns more than chunk_samples samples."""
    from polishpath.smooth.taylor import RERUN_MAX_SAMPLES

    cap, sp = mapped
    for table, integrator, most in ((interp.SCHEDULING_KERNELS, "taylor", 64 + RERUN_MAX_SAMPLES + 1),
                                    (interp.INTEGRATORS, "ab-am", 64)):
        real = table[integrator]
        longest = []

        def recording(*args, real=real, longest=longest):
            out = real(*args)
            longest.append(len(out[0]))
            return out

        monkeypatch.setitem(table, integrator, recording)
        tp = smooth(sp, feed_mm_min=1200.0, period_ms=4.0, keep_samples=False, chunk_samples=64,
                    integrator=integrator)
        # the scheduling kernel stops only between regions (or inside one too long to run again)
        assert max(longest) <= most and tp.stats["n_samples"] > 64 * 10 and len(longest) > 10


def test_the_schedule_is_what_the_samples_were_made_with(kept):
    sch = kept.schedule
    n, k = len(kept.dwell_params), len(kept.piece_params) - 1
    assert sch.n_pieces == k and len(sch.region_feeds) == n and len(sch.region_bounds) == n + k
    assert sch.integrator == kept.provenance.params["integrator"] and sch.period_ms == kept.period_ms
    assert sch.max_feed_mm_s == pytest.approx(kept.provenance.params["max_feed_mm_min"] / 60.0)
    for j in range(k):
        u0, u1, rb, rf = sch.piece(j)
        a = kept.sample_pieces[j]
        assert kept.sample_params[a] == u0 and rb[0] == u0 and rb[-1] == u1 and np.all(np.diff(rb) >= 0)
        assert np.all(rf > 0) and np.all(rf <= sch.max_feed_mm_s)


def test_streaming_needs_a_schedule_and_a_good_chunk_size(kept):
    bare = dataclasses.replace(kept, schedule=None)
    with pytest.raises(SmoothingError, match="no sample schedule"):
        next(iter_sample_chunks(bare))
    for bad in (0, -3, 2.5, True):
        with pytest.raises(ParameterError):
            next(iter_sample_chunks(kept, size=bad))
    with pytest.raises(ParameterError):
        smooth(kept.surface_path, keep_samples=False, chunk_samples=0)
    with pytest.raises(ParameterError, match="SampleSchedule"):
        ToolPath(kept.curve, kept.dwell_params, kept.samples, kept.sample_params, kept.feed_mm_min, kept.period_ms,
                 kept.surface_path, schedule={"piece_params": []}, sample_pieces=kept.sample_pieces,
                 piece_params=kept.piece_params)


def test_sample_schedule_refuses_inconsistent_arrays(kept):
    sch = kept.schedule
    with pytest.raises(ParameterError, match="increasing offsets"):
        dataclasses.replace(sch, region_feeds=sch.region_feeds[:-1])
    with pytest.raises(ParameterError, match="increasing offsets"):
        dataclasses.replace(sch, sample_pieces=sch.sample_pieces[:-1])
    with pytest.raises(ParameterError, match="positive"):
        dataclasses.replace(sch, period_ms=0.0)
    assert sch.region_feeds.flags.writeable is False


def test_sample_chunk_moved_to_the_core_and_still_exported():
    from polishpath.export import SampleChunk as ExportedChunk
    from polishpath.export.chunks import SampleChunk as ChunksChunk

    assert ExportedChunk is SampleChunk and ChunksChunk is SampleChunk


def test_a_piece_run_in_one_go_continues_in_resumed_calls_when_it_is_long(monkeypatch, kept):
    """A piece longer than one kernel call (samples.MAX_CALL_SAMPLES) or than the room expected is run in
    resumed calls and joined: the same samples and figures as one call."""
    import polishpath.smooth.samples as samples_mod

    sp = kept.surface_path
    integrator = kept.provenance.params["integrator"]
    from polishpath.smooth.taylor import RERUN_MAX_SAMPLES

    monkeypatch.setattr(samples_mod, "MAX_CALL_SAMPLES", 1000)
    calls = []
    table = interp.SCHEDULING_KERNELS if integrator in interp.SCHEDULING_KERNELS else interp.INTEGRATORS
    real = table[integrator]

    def counting(*args):
        out = real(*args)
        calls.append(len(out[0]))
        return out

    monkeypatch.setitem(table, integrator, counting)
    short = smooth(sp, surface=None, feed_mm_min=1200.0, period_ms=4.0, chord_tol_mm=1e-3, integrator=integrator)
    most = 1000 + (RERUN_MAX_SAMPLES + 1 if table is interp.SCHEDULING_KERNELS else 0)
    assert max(calls) <= most and len(calls) > len(kept.sample_pieces)
    assert np.array_equal(short.samples, kept.samples) and np.array_equal(short.feed_mm_min, kept.feed_mm_min)
    assert np.array_equal(short.sample_params, kept.sample_params)
    for key in ("chord_error_max", "feed_fluctuation_rms", "dwell_time_error_max", "dwell_time_error_rms"):
        assert short.stats[key] == kept.stats[key], key
