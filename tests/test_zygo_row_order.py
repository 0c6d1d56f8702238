"""The row order of Zygo's files, checked on real instrument files (issue 28 item 5).

The readers take a Zygo file's first stored row as the top of the map (the camera's first line, the largest y)
and the error map reverses the rows. A real MetroPro ``.dat`` carries the camera's intensity frame beside the
phase, and the phase window's origin inside that frame in its header: a feature of the part shows in both. If
the phase is read in the order the reader assumes, the feature lands where the camera saw it; read the other way
up it does not. The intensity frame and the header's fields are read here independently of the reader (numpy and
``struct`` at the offsets of the MetroPro Reference Guide), so the checks fail if the reader's row order is wrong.

The files live in ``../shared/data/measurements`` (tests/data/measurements/SOURCES.md gives their sources and
licences); each test skips with the reason where the file is absent.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from polishpath.dwell import read_error_map
from polishpath.psd import read_measurement

from conftest import shared_measurement_path

# a Zygo interferometer's MetroPro .dat with the camera frame and a dirt speck on the part
# (prysm's sample_files/valid_zygo_dat_file.dat, MIT)
PRYSM_DAT = "prysm_valid_zygo_dat_file.dat"
# a Zygo NewView MetroPro .dat, camera frame and phase the same 640 x 480 window (SurfaceTopography's
# metropro-1.dat, MIT)
NEWVIEW_DAT = "metropro-1.dat"


def _camera_frame(path: Path) -> tuple[np.ndarray, tuple[int, int], tuple[int, int]]:
    """The first intensity frame (rows as stored), the intensity and the phase windows' origins (x, y), pixels.

    MetroPro header (big-endian): header size int32 at 6; intensity origin x, y, width, height, buckets uint16 at
    48, 50, 52, 54, 56; phase origin x, y uint16 at 64, 66. The frame follows the header as uint16.
    """
    raw = path.read_bytes()
    hsize = struct.unpack_from(">i", raw, 6)[0]
    ax, ay, iw, ih = struct.unpack_from(">HHHH", raw, 48)
    ox, oy = struct.unpack_from(">HH", raw, 64)
    frame = np.frombuffer(raw, dtype=">u2", count=iw * ih, offset=hsize).reshape(ih, iw).astype(float)
    return frame, (ax, ay), (ox, oy)


def _largest_inner_hole(z: np.ndarray) -> np.ndarray:
    """The largest region without data that does not touch the map's border (a speck on the part)."""
    lab, n = ndimage.label(np.isnan(z))
    border = set(np.unique(np.concatenate([lab[0], lab[-1], lab[:, 0], lab[:, -1]]))) | {0}
    inner = [k for k in range(1, n + 1) if k not in border]
    assert inner, "the file's map has no region without data inside the part"
    sizes = ndimage.sum(np.ones_like(lab), lab, inner)
    return lab == inner[int(np.argmax(sizes))]


def _dark_pixels_around(hole: np.ndarray, highpass: np.ndarray, level: float = -30.0) -> np.ndarray:
    """(n, 2) row, column of the camera pixels darker than their surroundings by more than ``level`` counts, in
    the hole's bounding box grown by 10 pixels."""
    r, c = np.nonzero(hole)
    box = (slice(max(r.min() - 10, 0), r.max() + 11), slice(max(c.min() - 10, 0), c.max() + 11))
    dark = np.zeros_like(hole)
    dark[box] = highpass[box] < level
    return np.argwhere(dark)


def test_a_speck_on_the_part_is_where_the_camera_saw_it(recwarn):
    """prysm's sample MetroPro file (a Zygo interferometer, "Sm Aperture", 632.8 nm, 2010): a 640 x 480 camera
    frame and 425 x 432 phase pixels whose window starts at camera pixel (139, 38). A dirt speck on the part
    leaves a hole of 363 pixels without data in the phase, centred on phase row 309.5, column 130.6; the camera
    frame, read top line first, shows the same hooked speck there (76 pixels at least 30 counts darker than their
    surroundings, centred within 1.3 pixels of the hole). Read bottom row first, the hole would sit on row 121.5,
    where the camera shows no speck at all (0 such pixels)."""
    p = shared_measurement_path(PRYSM_DAT)
    m = read_measurement(p)
    assert m.params["format"] == "metropro-dat" and m.params["rows"].startswith("top first")
    z = m.z_nm
    assert z.shape == (432, 425) and m.n_nan == 47241

    frame, (ax, ay), (ox, oy) = _camera_frame(p)
    assert frame.shape == (480, 640) and (ax, ay, ox, oy) == (0, 0, 139, 38)
    window = frame[oy - ay:oy - ay + z.shape[0], ox - ax:ox - ax + z.shape[1]]
    highpass = window - ndimage.gaussian_filter(window, 8.0)  # the speck against its smooth surroundings

    hole = _largest_inner_hole(z)
    centre = np.argwhere(hole).mean(axis=0)
    assert hole.sum() == 363
    np.testing.assert_allclose(centre, [309.45, 130.62], atol=0.05)

    # as the reader orders the rows: the camera's speck is on the hole
    dark = _dark_pixels_around(hole, highpass)
    assert len(dark) >= 50
    np.testing.assert_allclose(dark.mean(axis=0), centre, atol=3.0)
    # the other way up: the hole would be on clean, bright camera pixels
    assert len(_dark_pixels_around(hole[::-1], highpass)) <= 2

    # the error map turns the rows over: the speck, in the lower part of the camera's picture (frame row 347 of
    # 480), is at the error map's small y (its row 121 of 432 counted upward)
    e = read_error_map(p)
    e_hole = _largest_inner_hole(e.z_nm)
    assert np.argwhere(e_hole).mean(axis=0)[0] == pytest.approx(z.shape[0] - 1 - centre[0], abs=0.05)


def test_the_newview_map_has_the_camera_frame_row_order(recwarn):
    """SurfaceTopography's NewView MetroPro file: the camera frame and the phase share one 640 x 480 window at
    (0, 0). The camera's small-scale detail (dust, pits: |intensity - its Gaussian-smoothed self, sigma 4 px|)
    and the heights' (the same of the height map) agree pixel for pixel in the reader's row order (correlation
    0.166) and not at all with the rows reversed (-0.001)."""
    p = shared_measurement_path(NEWVIEW_DAT)
    m = read_measurement(p)
    frame, (ax, ay), (ox, oy) = _camera_frame(p)
    assert frame.shape == m.z_nm.shape == (480, 640) and (ax, ay, ox, oy) == (0, 0, 0, 0)

    def detail(a: np.ndarray) -> np.ndarray:
        return np.abs(a - ndimage.gaussian_filter(a, 4.0)).ravel()

    as_read = np.corrcoef(detail(frame), detail(m.z_nm))[0, 1]
    reversed_rows = np.corrcoef(detail(frame), detail(m.z_nm[::-1]))[0, 1]
    assert as_read > 0.12
    assert abs(reversed_rows) < 0.03
