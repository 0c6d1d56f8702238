"""Run LinuxCNC's standalone interpreter ``rs274`` on a G-code file and parse its canonical output.

``scripts/get-linuxcnc.sh`` (called by ``make test``) unpacks Debian's
``linuxcnc-uspace`` into a cache folder and writes a wrapper ``rs274`` there.
The ``rs274`` fixture finds it (``$POLISHPATH_RS274``, that cache, or ``rs274``
on PATH) and skips the test with the reason where it cannot be had.

rs274 prints one canonical machining call per line, e.g.::

       25 N..... STRAIGHT_FEED(1.0000, 2.0000, 0.0000, 0.0000, 0.0000, 0.0000)
       26 N..... ARC_FEED(2.0000, 1.0000, 1.0000, 1.0000, 1, 0.5000, 0.0000, 0.0000, 0.0000)

(an arc in the XY plane: end X, end Y, centre X, centre Y, turns -- positive
counter-clockwise, negative clockwise --, end Z, then the rotary axes) with
every number at 4 decimals; errors go to stderr and end the run (exit 1) in
batch mode (``-g``).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from gcode_helpers import helix_lengths

REPO = Path(__file__).resolve().parents[1]
CACHE = Path(os.environ.get("POLISHPATH_CACHE", Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "polishpath"))
TOOL_TABLE = "T1 P1 D0.0 Z0.0 ;\n"
_CALL = re.compile(r"^\s*\d+\s+N\S*\s+([A-Z_0-9]+)\((.*)\)\s*$")


def find_rs274() -> str | None:
    cands = [os.environ.get("POLISHPATH_RS274"), str(CACHE / "linuxcnc" / "rs274"), shutil.which("rs274")]
    return next((c for c in cands if c and Path(c).is_file() and os.access(c, os.X_OK)), None)


@dataclass
class Canon:
    """rs274's reading of one file.

    ``calls``: every canonical call, (name, raw argument text), in order.
    ``feeds``: (K, 3) end points of the feed moves (STRAIGHT_FEED and ARC_FEED), mm;
    ``feed_rate``: (K,) the F in force for each (mm/min, or 1/min in inverse time);
    ``inverse_time``: (K,) bool, G93 in force; ``starts``: (K, 3) where each feed
    move began; ``centres`` (K, 2) an arc's centre (NaN: straight), ``turns`` (K,)
    its turn count (0: straight); ``group``: (K,) index of the run of feed moves
    between rapid moves; ``rotary`` (K, 3) the A B C each feed move ends at (degrees) and
    ``rotary_starts`` (K, 3) where it began.
    """

    returncode: int
    stderr: str
    calls: list[tuple[str, str]] = field(default_factory=list)
    feeds: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    starts: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    feed_rate: np.ndarray = field(default_factory=lambda: np.zeros(0))
    inverse_time: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    group: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    centres: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    turns: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    rotary: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    rotary_starts: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    @property
    def ok(self) -> bool:
        return self.returncode == 0 and not self.errors

    @property
    def errors(self) -> list[str]:
        """Error lines rs274 printed (anything on stderr but its 'executing' chatter)."""
        return [ln for ln in self.stderr.replace("executing", "\n").splitlines() if ln.strip()]

    def names(self) -> list[str]:
        return [c[0] for c in self.calls]

    def args(self, name: str) -> list[list[float]]:
        out = []
        for n, a in self.calls:
            if n == name:
                out.append([float(v) for v in re.findall(r"-?\d+(?:\.\d+)?", a)])
        return out

    def segment_times(self) -> np.ndarray:
        """(K,) seconds per feed move: 60 x length / rate (an arc's length: its helix's).

        In inverse time (G93) rs274 itself turns each block's F (1/min) into the
        equivalent rate, length x F in mm/min, so one formula serves both modes.
        """
        length = helix_lengths(self.starts, self.feeds, self.centres, self.turns)
        with np.errstate(divide="ignore"):
            return 60.0 * length / self.feed_rate


def parse_canon(text: str, returncode: int = 0, stderr: str = "") -> Canon:
    calls = []
    for ln in text.splitlines():
        m = _CALL.match(ln)
        if m:
            calls.append((m.group(1), m.group(2)))
    pos = np.zeros(3)
    rot = np.zeros(3)
    rate, inv = 0.0, False
    ends, starts, rates, invs, groups, centres, turns = [], [], [], [], [], [], []
    rots, rot_starts = [], []
    g, last = -1, "STRAIGHT_TRAVERSE"
    for name, a in calls:
        if name == "COMMENT" and "feed mode set to" in a:
            inv = "inverse time" in a
        elif name == "SET_FEED_RATE":
            rate = float(a)
        elif name in ("STRAIGHT_FEED", "STRAIGHT_TRAVERSE", "ARC_FEED"):
            v = [float(x) for x in a.split(",")]
            arc = name == "ARC_FEED"
            p = np.array([v[0], v[1], v[5]] if arc else v[:3])
            r = np.array(v[6:9] if arc else v[3:6])
            if name != "STRAIGHT_TRAVERSE":
                centres.append(v[2:4] if arc else [np.nan, np.nan])
                turns.append(int(v[4]) if arc else 0)
                if last == "STRAIGHT_TRAVERSE":
                    g += 1
                groups.append(g)
                starts.append(pos)
                ends.append(p)
                rates.append(rate)
                invs.append(inv)
                rots.append(r)
                rot_starts.append(rot)
            pos = p
            rot = r
            last = name
    c = Canon(returncode, stderr, calls)
    if ends:
        c.feeds, c.starts = np.array(ends), np.array(starts)
        c.feed_rate, c.inverse_time = np.array(rates), np.array(invs, bool)
        c.group = np.array(groups, np.int64)
        c.centres, c.turns = np.array(centres, float), np.array(turns, np.int64)
        c.rotary, c.rotary_starts = np.array(rots), np.array(rot_starts)
    return c


def run_rs274(exe: str, ngc: Path, workdir: Path) -> Canon:
    """rs274 in batch mode on ``ngc`` with a one-tool table; the parsed canonical output."""
    workdir.mkdir(parents=True, exist_ok=True)
    tbl = workdir / "tool.tbl"
    tbl.write_text(TOOL_TABLE)
    out = workdir / (Path(ngc).stem + ".canon")
    proc = subprocess.run([exe, "-t", str(tbl), "-g", str(ngc), str(out)], capture_output=True, text=True,
                          timeout=600)
    text = out.read_text() if out.exists() else ""
    return parse_canon(text, proc.returncode, proc.stderr + proc.stdout)


@pytest.fixture(scope="session")
def rs274(tmp_path_factory):
    """``rs274(path_to_ngc) -> Canon``; skips when LinuxCNC's interpreter is not available."""
    exe = find_rs274()
    if exe is None:
        pytest.skip("LinuxCNC's rs274 not found: run scripts/get-linuxcnc.sh (make test does; it needs apt-get "
                    "and network to fetch Debian's linuxcnc-uspace)")
    work = tmp_path_factory.mktemp("rs274")
    return lambda ngc: run_rs274(exe, Path(ngc), work)
