"""Issue 28 item 4's memory: the smoothing stage copies each piece's samples into one set of arrays as it ends
(never the pieces and their concatenation at once), and the delivered region times read the samples' times at
the region boundaries only; the same figures as before."""

from __future__ import annotations

import numpy as np
import pytest

from polishpath.dwell.delivery import region_times, sample_times
from polishpath.smooth import _SampleSink


def _pieces(rng, sizes):
    return [(rng.random((m, 3)), np.sort(rng.random(m)), rng.random(m)) for m in sizes]


@pytest.mark.parametrize("expect", [10, 1000, 10**5])  # short (grown), about right, ample
def test_sink_holds_the_pieces_one_after_the_other(expect):
    rng = np.random.default_rng(0)
    parts = _pieces(rng, [700, 1, 0, 2500, 333])
    sink = _SampleSink(expect)
    for p in parts:
        sink.add(*p)
    got = sink.arrays()
    for j in range(3):
        np.testing.assert_array_equal(got[j], np.concatenate([p[j] for p in parts]))
    assert got[0].shape == (sum(len(p[1]) for p in parts), 3)


def test_sink_of_one_piece_keeps_its_arrays():
    rng = np.random.default_rng(1)
    (pp, pu, pv), = _pieces(rng, [500])
    sink = _SampleSink(10)
    sink.add(pp, pu, pv)
    got = sink.arrays()
    assert got[0] is pp and got[1] is pu and got[2] is pv


def _region_times_summed(tp):
    """region_times as it was: every sample's time summed (sample_times), interpolated at the boundaries."""
    dp, sp = np.asarray(tp.dwell_params), np.asarray(tp.sample_params)
    times = sample_times(tp)
    out = np.zeros(len(dp))
    spieces, ppar = tp.sample_pieces, tp.piece_params
    for k in range(len(spieces) - 1):
        s = sp[spieces[k]:spieces[k + 1]]
        lo, hi = ppar[k], ppar[k + 1]
        idx = np.flatnonzero((dp >= lo) & (dp < hi)) if k < len(spieces) - 2 else np.flatnonzero(dp >= lo)
        d = dp[idx]
        rb = np.concatenate([[s[0]], 0.5 * (d[1:] + d[:-1]), [s[-1]]])
        out[idx] = np.diff(np.interp(rb, s, times[spieces[k]:spieces[k + 1]]))
    return out


def test_region_times_at_the_boundaries_are_the_summed_ones():
    from polishpath.mapping import map_to_surface
    from polishpath.smooth import smooth
    from test_mapping_helpers import serpentine_path, spherical_cap

    cap = spherical_cap(n_r=10, n_phi=32)
    path = serpentine_path(cap, 1.5, seed=11)
    sp = map_to_surface(cap, path)
    times = 0.05 + 0.1 * np.random.default_rng(4).random(len(sp.xyz))
    tp = smooth(sp, feed_mm_min=1200.0, period_ms=4.0, chord_tol_mm=1e-3, dwell_times=times)
    assert len(tp.sample_pieces) > 3  # several pieces: the sink's copies and each piece's last step
    want, got = _region_times_summed(tp), region_times(tp)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)
    assert np.median(np.abs(got / times - 1.0)) < 0.02  # and they are (near) the times asked for


def test_boundary_check_in_blocks_is_the_same(monkeypatch):
    import polishpath.smooth.boundary as bd
    from test_mapping_helpers import spherical_cap

    cap = spherical_cap(n_r=10, n_phi=32)
    v = np.asarray(cap.surface.vertices)
    rng = np.random.default_rng(5)
    pts = v[rng.integers(0, len(v), 3000)] * np.array([1.01, 1.01, 1.0]) + 0.05 * rng.standard_normal((3000, 3))
    whole = bd.BoundaryCheck(cap.surface, reach=1.0).near_excursion(pts)
    monkeypatch.setattr(bd, "QUERY_BLOCK", 7)
    blocks = bd.BoundaryCheck(cap.surface, reach=1.0).near_excursion(pts)
    np.testing.assert_array_equal(whole[0], blocks[0])
    np.testing.assert_array_equal(whole[1], blocks[1])
    assert len(whole[0]) > 20 and (whole[1] > 0).sum() > 10  # blocks of 7 over many candidates, some beyond
