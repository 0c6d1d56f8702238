"""pathops: pieces, steps, directions and turns of hand-made paths with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from polishpath import pathops as po
from polishpath.errors import ParameterError, PolishPathError

# 7 points in 3 pieces: [0, 3) [3, 5) [5, 7); lifts after points 2 and 4
PTS = np.array([[0, 0], [1, 0], [1, 1], [5, 5], [5, 7], [9, 0], [9, 3]], dtype=float)
PIECES = np.array([0, 3, 5, 7])


def test_piece_offsets_default_and_checks():
    assert po.piece_offsets(None, 4).tolist() == [0, 4]
    assert po.piece_offsets([0, 2, 4], 4).dtype == np.int64
    for bad in ([1, 4], [0, 3], [0, 3, 2, 4], [[0, 4]], [0], [0.5, 4]):
        with pytest.raises(ParameterError) as e:
            po.piece_offsets(bad, 4)
        assert isinstance(e.value, PolishPathError) and "pieces" in str(e.value)


def test_piece_index_and_slices():
    assert po.piece_index(PIECES, 7).tolist() == [0, 0, 0, 1, 1, 2, 2]
    assert po.piece_index(PIECES, 7, [6, 3, 2]).tolist() == [2, 1, 0]
    # an empty piece owns no point
    assert po.piece_index([0, 2, 2, 3], 3).tolist() == [0, 0, 2]
    assert po.piece_slices(PIECES, 7) == [slice(0, 3), slice(3, 5), slice(5, 7)]
    parts = po.split_by_pieces(PTS, PIECES)
    assert [len(p) for p in parts] == [3, 2, 2]
    assert np.array_equal(parts[1], PTS[3:5])


def test_step_mask_starts_vectors_lengths():
    assert po.step_mask(7, PIECES).tolist() == [True, True, False, True, False, True]
    assert po.step_mask(7, None).all() and len(po.step_mask(7, None)) == 6
    assert len(po.step_mask(1, None)) == 0 and len(po.step_mask(0, None)) == 0
    a, pc = po.step_starts(7, PIECES)
    assert a.tolist() == [0, 1, 3, 5] and pc.tolist() == [0, 0, 1, 2]
    assert po.step_vectors(PTS, PIECES).tolist() == [[1, 0], [0, 1], [0, 2], [0, 3]]
    assert np.allclose(po.step_lengths(PTS, PIECES), [1, 1, 2, 3])
    # one piece: the lifts become steps
    assert np.allclose(po.step_lengths(PTS), np.linalg.norm(np.diff(PTS, axis=0), axis=1))
    assert po.step_lengths(PTS[:1]).shape == (0,)
    with pytest.raises(ParameterError):
        po.step_lengths(PTS, [0, 3, 6])


def test_pieces_after_keep_cuts_where_points_were_dropped():
    keep = np.array([True, False, True, True, True, False, False])
    # 0 | 2 (cut: point 1 dropped) | 3 4 (own piece) ; piece 2 vanishes
    assert po.pieces_after_keep(PIECES, keep).tolist() == [0, 1, 2, 4]
    assert po.pieces_after_keep(PIECES, np.ones(7, bool)).tolist() == PIECES.tolist()
    assert po.pieces_after_keep(None, np.zeros(3, bool)).tolist() == [0]


def test_direction_codes_counts_and_names():
    assert po.DIRECTION_NAMES[0] == "E" and len(po.DIRECTION_NAMES) == 8
    # each direction step has the code of its index
    for k, d in enumerate(po.DIRECTION_STEPS):
        assert po.direction_codes(np.array([[0, 0], d]))[0] == k
    ij = np.array([[0, 0], [1, 0], [1, 1], [3, 1], [3, 1], [9, 9], [8, 8]])
    codes = po.direction_codes(ij, [0, 5, 7])
    assert codes.tolist() == [0, 2, po.OTHER_MOVE, po.OTHER_MOVE, po.LIFT, 5]
    counts, other = po.direction_counts(ij, [0, 5, 7])
    assert counts.tolist() == [1, 0, 1, 0, 0, 1, 0, 0] and other == 2
    assert po.sector_codes(np.array([[1.0, 0.1], [-1.0, -1.1]])).tolist() == [0, 5]
    # a frame turned by 90 degrees: +y is its east
    assert po.sector_codes(np.array([[0.0, 1.0]]), rotation=np.pi / 2).tolist() == [0]


def test_turn_angles_only_within_pieces():
    # E, N (left turn), a lift, then W, SW, E
    ij = np.array([[0, 0], [1, 0], [1, 1], [5, 5], [4, 5], [3, 4], [4, 4]])
    t = po.turn_angles_deg(ij, [0, 3, 7])
    # E->N +90; W->SW +45; SW->E: (0 - 5) mod 8 = 3 -> +135
    assert t.tolist() == [90.0, 45.0, 135.0]
    straight = np.array([[0, 0], [1, 1], [2, 2], [2, 1]])
    assert po.turn_angles_deg(straight).tolist() == [0.0, -135.0]
