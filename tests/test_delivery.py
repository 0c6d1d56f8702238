"""Every dwell time delivered (issue 28, item 3): the time the machine spends in each dwell region is the
G-code's, a piece's last region is delivered like the others, and the search for a region's feed finds one
between the jumps a tight turn makes in its time."""

from __future__ import annotations

import math

import numpy as np
import pytest

from polishpath.dwell import region_times
from polishpath.export.post import planned_segment_times
from polishpath.schedule import MachineProfile, schedule_feeds
from polishpath.smooth import smooth
from polishpath.smooth.timing import PROBE_STEP, SEARCH_STRIDE, next_region_feed


@pytest.fixture(scope="module")
def mapped():
    """A mapped serpentine path of several pieces on a spherical cap."""
    from polishpath.mapping import map_to_surface
    from test_mapping_helpers import serpentine_path, spherical_cap

    cap = spherical_cap(n_r=10, n_phi=32)
    path = serpentine_path(cap, 1.5, seed=11)
    assert len(path.pieces) > 3
    return map_to_surface(cap, path)


@pytest.fixture(scope="module")
def tp(mapped):
    return smooth(mapped, feed_mm_min=1200.0, period_ms=4.0, chord_tol_mm=1e-3)


def _gcode_region_times(tp, dt):
    """Each dwell region's time from the G-code's per-sample move times ``dt`` (M,) s (the move arriving at
    each sample), cumulated per piece and read at the region boundaries linearly over the sample parameters."""
    sp, dp = np.asarray(tp.sample_params), np.asarray(tp.dwell_params)
    pieces, pp = np.asarray(tp.sample_pieces), np.asarray(tp.piece_params)
    got = np.zeros(len(dp))
    for k in range(len(pieces) - 1):
        a, b = pieces[k], pieces[k + 1]
        idx = np.flatnonzero((dp >= pp[k]) & ((dp < pp[k + 1]) if k < len(pieces) - 2 else True))
        d = dp[idx]
        ends = np.concatenate([[sp[a]], 0.5 * (d[1:] + d[:-1]), [sp[b - 1]]])
        got[idx] = np.diff(np.interp(ends, sp[a:b], np.concatenate([[0.0], np.cumsum(dt[a + 1:b])])))
    return got


def _moving(tp):
    """The dwell points of pieces with more than one point (a piece of one point is a stop at it: its
    samples stand still, and a move's length over its ~0 feed is rounding)."""
    pieces = np.asarray(tp.surface_path.planar.pieces)
    n = np.diff(pieces)
    return np.repeat(n > 1, n)


def test_region_times_are_the_gcode_times(tp):
    """The delivered times reported are those of the G-code's feeds (length over feed per move): the piece's
    last move, cut short at its end, takes less than a period (it took a whole one in the report before)."""
    T = tp.period_ms / 1000.0
    dt = planned_segment_times(tp)
    assert np.any(dt[np.asarray(tp.sample_pieces[1:]) - 1] < 0.9 * T)  # last moves really cut short
    moving = _moving(tp)
    assert moving.sum() > 0.9 * len(moving)
    np.testing.assert_allclose(region_times(tp)[moving], _gcode_region_times(tp, dt)[moving], rtol=1e-5, atol=1e-9)


def test_region_times_under_a_machine_schedule_are_the_gcode_times(tp):
    """Under a machine profile's schedule the move to a sample runs at that sample's (scheduled) feed: the
    region times are read from the same moves as the G-code's (one sample later than before)."""
    m = MachineProfile(name="t", max_feed_mm_min=3000.0, max_velocity_mm_min=(3000.0, 3000.0, 1500.0),
                       max_acceleration_mm_s2=(200.0, 200.0, 100.0), max_tangential_acceleration_mm_s2=None)
    tp0 = tp
    tp, _ = schedule_feeds(tp0, m)
    assert np.any(tp.feed_mm_min < tp0.feed_mm_min * (1 - 1e-3))  # the schedule does slow it down
    sample_s = tp.period_ms / 1000.0 * tp0.feed_mm_min / np.maximum(tp.feed_mm_min, 1e-300)
    got = region_times(tp, sample_s)
    want = _gcode_region_times(tp, planned_segment_times(tp))
    moving = _moving(tp)
    np.testing.assert_allclose(got[moving], want[moving], rtol=1e-5, atol=1e-9)


def test_the_last_region_of_each_piece_gets_its_time(tp):
    """A piece's last region was timed in whole periods (its last sample one period after the one before),
    so its time could only be met to within half a period; its last move now takes its length over its feed,
    and the region's feed is found like any other's (the figuring's 0.4 %)."""
    tp0 = tp
    times = 1.3 * np.asarray(tp0.dwell_times)
    tp = smooth(tp0.surface_path, dwell_times=times, feed_mm_min=1200.0, period_ms=4.0, chord_tol_mm=1e-3,
                region_tol=0.004, schedule_passes=12)
    rel = region_times(tp) / times - 1.0
    last = np.asarray(tp.surface_path.planar.pieces[1:]) - 1
    assert len(last) >= 3
    assert np.abs(rel[last]).max() <= 0.005, rel[last]
    assert np.sqrt(np.mean(rel**2)) <= 0.005
    assert tp.stats["chord_error_max"] <= tp.provenance.params["chord_tol_mm"] * (1 + 1e-6)


def test_next_feed_false_position_stays_inside_the_bracket():
    # too slow by 10 % at 10 mm/s, too fast by 30 % at 20 mm/s: the point in 1 / f where the miss is 0 ...
    f = next_region_feed(15.0, 20.0, -0.3, 10.0, 0.1, 20.0, -0.3, 50.0, True)
    x = 0.1 + 0.1 * (0.05 - 0.1) / (0.1 + 0.3)
    assert f == pytest.approx(1.0 / x)
    # ... kept to the middle 60 % of the bracket (in 1 / f), whatever the misses, so it shrinks each run
    for rel_lo, rel_hi in ((1e-6, -5.0), (5.0, -1e-6), (0.2, -0.2)):
        f = next_region_feed(15.0, 20.0, rel_hi, 10.0, rel_lo, 20.0, rel_hi, 50.0, True)
        x = 1.0 / f
        assert 0.05 + 0.2 * 0.05 - 1e-15 <= x <= 0.1 - 0.2 * 0.05 + 1e-15
    # a bracket the other way round (a faster feed too slow, a slower one too fast: a jump between) too
    f = next_region_feed(15.0, 10.0, -0.2, 20.0, 0.2, 10.0, -0.2, 50.0, True)
    assert 1.0 / 20.0 < 1.0 / f < 1.0 / 10.0


def test_next_feed_probes_slower_when_the_top_feed_was_too_slow():
    # the top feed (50 mm/s) ran 20 % too slow: a searching job tries a slower feed, where the steps fall
    # elsewhere on the turn; a job of two runs stops (the feed just run)
    assert next_region_feed(50.0, 50.0, 0.2, 50.0, 0.2, math.inf, 0.0, 50.0, True) == pytest.approx(
        50.0 * (1 - PROBE_STEP))
    assert next_region_feed(50.0, 50.0, 0.2, 50.0, 0.2, math.inf, 0.0, 50.0, False) == 50.0
    assert next_region_feed(50.0, 40.0, 0.1, 50.0, 0.2, math.inf, 0.0, 50.0, True) == pytest.approx(
        40.0 * (1 - PROBE_STEP))


def test_next_feed_model_step_is_bounded_while_searching():
    # no bracket yet: the model's proposal, within a factor SEARCH_STRIDE of the feed just run when searching
    assert next_region_feed(49.0, 20.0, 0.3, 20.0, 0.3, math.inf, 0.0, 50.0, True) == pytest.approx(
        20.0 * SEARCH_STRIDE)
    assert next_region_feed(5.0, 20.0, -0.3, 0.0, 0.0, 20.0, -0.3, 50.0, True) == pytest.approx(20.0 / SEARCH_STRIDE)
    assert next_region_feed(21.0, 20.0, 0.03, 20.0, 0.03, math.inf, 0.0, 50.0, True) == 21.0
    assert next_region_feed(49.0, 20.0, 0.3, 20.0, 0.3, math.inf, 0.0, 50.0, False) == 49.0
