"""The G-code checked by LinuxCNC's own interpreter, rs274 (issue 16, item 4).

rs274 comes from Debian's linuxcnc-uspace, fetched and unpacked by
``scripts/get-linuxcnc.sh`` (``make test`` runs it); where it cannot be had these
tests skip with that reason.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from polishpath.export import read_xyz
from rs274_helpers import parse_canon, rs274  # noqa: F401  (fixture)

RES = 0.5e-4 + 1e-9  # the file's and the canonical output's 4-decimal resolution, mm


def _plan(out, *args):
    cmd = [sys.executable, "-m", "polishpath", "plan", *args, "--no-report", "--quiet", "-o", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.fixture(scope="module")
def small_job(tmp_path_factory):
    return _plan(tmp_path_factory.mktemp("job") / "run", "hemisphere:R=12,triangles=3000", "--spacing", "1.5",
                 "--seed", "11")


def test_canonical_parser_reads_moves_feeds_and_modes():
    text = "\n".join([
        "    1 N..... SET_FEED_RATE(600.0000)",
        "    2 N..... STRAIGHT_TRAVERSE(0.0000, 0.0000, 10.0000, 0.0000, 0.0000, 0.0000)",
        "    3 N..... STRAIGHT_FEED(3.0000, 4.0000, 10.0000, 0.0000, 0.0000, 0.0000)",
        '    4 N..... COMMENT("interpreter: feed mode set to inverse time")',
        "    5 N..... SET_FEED_RATE(6000.0000)",
        "    6 N..... STRAIGHT_FEED(3.0000, 4.0000, 11.0000, 0.0000, 0.0000, 0.0000)",
    ])
    c = parse_canon(text)
    assert c.names()[:3] == ["SET_FEED_RATE", "STRAIGHT_TRAVERSE", "STRAIGHT_FEED"]
    assert np.array_equal(c.feeds, [[3, 4, 10], [3, 4, 11]])
    assert np.array_equal(c.starts, [[0, 0, 10], [3, 4, 10]])
    assert list(c.inverse_time) == [False, True]
    assert np.allclose(c.segment_times(), [60 * 5 / 600, 60 / 6000])
    bad = parse_canon("", 1, "executing\nUnknown g code used\nG06.2 P4")
    assert not bad.ok and bad.errors[0] == "Unknown g code used"


def test_rs274_reads_the_linear_gcode_of_a_small_job(rs274, small_job):
    canon = rs274(small_job / "toolpath.nc")
    assert canon.ok, canon.errors[:5]
    samples = read_xyz(small_job / "toolpath.xyz")
    # every machine sample is the end point of one feed move, in order, to the file's resolution
    assert canon.feeds.shape == samples.shape
    assert np.abs(canon.feeds - samples).max() <= RES
