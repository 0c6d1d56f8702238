"""A small job's machine files against reference files written once, within stated tolerances.

The reference was written by ``tests/data/reference/make_reference.py``: a
refactoring must not change the job's outputs. They are compared as numbers,
not bytes, because another processor (or another BLAS/LAPACK kernel, another
numpy build) adds floating-point operations in another order and moves the
14th significant digit (issue 25: 1e-13 mm on an AMD EPYC). What must hold on
any x86-64 machine, and is checked here:

* the discrete path exactly: the number of rows and blocks, the order of the
  dwell points, the integer fields (``index``, ``i``, ``j``), the G-code's words;
* coordinates (mm) and unit normals to :data:`COORD_TOL_MM` (1e-9) where the file
  holds full precision (``path.csv``); times to :data:`TIME_RTOL` (1e-9 relative);
* numbers a file writes rounded (``toolpath.nc`` at 1e-4 mm and F to
  ``2 feed_resolution``) to one unit of the written resolution plus 1e-9 mm: a
  value within 1e-13 of a rounding boundary may round either way on another machine;
* the machine samples (``toolpath.xyz``): the same count, each within
  :data:`SAMPLE_TOL_MM` (1e-5 mm, 1 % of the 1 um chord tolerance). They are placed
  in time by a feed schedule solved to a tolerance: a region whose feed is decided
  at a threshold (the scheduling kernel runs a region again when it is off by more
  than 2 %) can move a run of samples along the path by nanometres. Measured: the
  reference job under ``OPENBLAS_CORETYPE=Prescott`` moves 46 consecutive samples
  by up to 5.4e-6 mm along the path (1e-4 of a sample step), every other sample
  within the 1e-6 mm it is written to; ``Sandybridge`` stays within 1e-6 mm.

Byte identity is a promise only on one machine with the same versions: the same
job twice (:func:`test_cli_plan.test_rerun_from_job_toml_is_bit_identical`), a
streamed job against one held in memory
(:func:`test_stream_job.test_a_streamed_job_writes_the_same_bytes`) and the
writers fed in chunks against one go
(:func:`test_post.test_chunked_samples_write_the_same_bytes`,
:func:`test_post.test_chunked_flat_samples_write_the_same_bytes`).
A change that is *meant* to alter the outputs regenerates the references with
the script and says so in its commit message.
"""

from __future__ import annotations

import csv
import gzip
import io
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REF = Path(__file__).resolve().parent / "data" / "reference"
sys.path.insert(0, str(REF))
from make_reference import ARGS, FILES  # noqa: E402

#: coordinates (mm) and unit-vector components, absolute, where the file holds full precision
COORD_TOL_MM = 1e-9
#: times (s), relative
TIME_RTOL = 1e-9
#: path.csv's columns compared exactly (integers: the discrete path)
EXACT_COLUMNS = ("index", "i", "j")
#: path.csv's time columns (relative tolerance)
TIME_COLUMNS = ("dwell_time",)
#: toolpath.xyz's machine samples across machines, mm (written to 1e-6 mm; see the module's docstring)
SAMPLE_TOL_MM = 1e-5
#: toolpath.nc: the resolution of each word as written (linuxcnc post: 4 decimals; F within 2 feed_resolution)
GCODE_RESOLUTION = {"X": 1e-4, "Y": 1e-4, "Z": 1e-4, "I": 1e-4, "J": 1e-4, "K": 1e-4, "R": 1e-4, "P": 1e-6}
GCODE_FEED_RTOL = 2e-3


class Mismatch(AssertionError):
    """A reference comparison failed; the message names the file, the line and the values."""


def _fail(name: str, line: int, got, expected, why: str):
    raise Mismatch(f"{name} differs from the reference at line {line}: {why}; got {got!r}, expected {expected!r}. "
                   "A refactoring must not change the job's outputs; if the change is meant to, run "
                   "tests/data/reference/make_reference.py and say why in the commit.")


def compare_path_csv(got: bytes, expected: bytes, name: str = "path.csv") -> None:
    """Same header, rows and integer fields exactly; coordinates to 1e-9 mm, times to 1e-9 relative."""
    a = list(csv.reader(io.StringIO(got.decode())))
    b = list(csv.reader(io.StringIO(expected.decode())))
    if a[0] != b[0]:
        _fail(name, 1, a[0], b[0], "another header")
    if len(a) != len(b):
        _fail(name, min(len(a), len(b)) + 1, f"{len(a)} lines", f"{len(b)} lines", "another number of dwell points")
    cols = b[0]
    for k, (ra, rb) in enumerate(zip(a[1:], b[1:]), start=2):
        if len(ra) != len(rb):
            _fail(name, k, ra, rb, "another number of fields")
        for c, x, y in zip(cols, ra, rb):
            if c in EXACT_COLUMNS:
                if x != y:
                    _fail(name, k, x, y, f"column {c} (the discrete path) differs")
                continue
            fx, fy = float(x), float(y)
            tol = TIME_RTOL * abs(fy) if c in TIME_COLUMNS else COORD_TOL_MM
            if not abs(fx - fy) <= tol:
                _fail(name, k, x, y, f"column {c} off by {abs(fx - fy):.3g} (tolerance {tol:.3g})")


def compare_xyz(got: bytes, expected: bytes, name: str = "toolpath.xyz") -> None:
    """The same number of samples, each coordinate within :data:`SAMPLE_TOL_MM`."""
    a, b = got.decode().splitlines(), expected.decode().splitlines()
    if len(a) != len(b):
        _fail(name, min(len(a), len(b)) + 1, f"{len(a)} lines", f"{len(b)} lines", "another number of samples")
    xa = np.loadtxt(a, ndmin=2)
    xb = np.loadtxt(b, ndmin=2)
    if xa.shape != xb.shape:
        _fail(name, 1, xa.shape, xb.shape, "another number of columns")
    d = np.abs(xa - xb).max(axis=1)
    bad = np.flatnonzero(~(d <= SAMPLE_TOL_MM + COORD_TOL_MM))
    if len(bad):
        k = int(bad[0])
        _fail(name, k + 1, a[k], b[k], f"off by {d[k]:.3g} mm (tolerance {SAMPLE_TOL_MM:g} mm)")


_WORD = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")


def _blocks(text: str) -> list[tuple[int, list[tuple[str, float]]]]:
    """(line number, words) of every block that is not only a comment; comments (version, paths) dropped."""
    out = []
    for k, ln in enumerate(text.splitlines(), start=1):
        s = re.sub(r"\([^)]*\)|;.*$", "", ln).strip()
        if s and s != "%":
            words = [(m.group(1), float(m.group(2))) for m in _WORD.finditer(s.upper())]
            out.append((k, words))
    return out


def compare_gcode(got: bytes, expected: bytes, name: str = "toolpath.nc") -> None:
    """Same blocks with the same words in the same order; numbers within their written resolution.

    G and M codes, and the letters of each block, must match exactly (the program's structure);
    axis, arc-centre and dwell words within one unit of their resolution; F within 2e-3
    relative (the post writes F to the power of ten within twice its feed resolution).
    """
    a, b = _blocks(got.decode()), _blocks(expected.decode())
    if len(a) != len(b):
        _fail(name, min(len(a), len(b)) + 1, f"{len(a)} blocks", f"{len(b)} blocks", "another number of blocks")
    for (ka, wa), (kb, wb) in zip(a, b):
        if [w for w, _ in wa] != [w for w, _ in wb]:
            _fail(name, kb, wa, wb, "other words in the block")
        for (w, x), (_, y) in zip(wa, wb):
            if w in "GMTSNO":
                ok = x == y
            elif w == "F":
                ok = abs(x - y) <= GCODE_FEED_RTOL * abs(y)
            else:
                ok = abs(x - y) <= GCODE_RESOLUTION.get(w, 1e-4) + COORD_TOL_MM
            if not ok:
                _fail(name, kb, f"{w}{x:g}", f"{w}{y:g}", f"word {w} beyond its resolution")


COMPARE = {"path.csv": compare_path_csv, "toolpath.xyz": compare_xyz, "toolpath.nc": compare_gcode}


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("reference") / "run"
    proc = subprocess.run([sys.executable, "-m", "polishpath", *ARGS, "-o", str(out)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return out


def _reference(name: str) -> bytes:
    return gzip.decompress((REF / f"{name}.gz").read_bytes())


@pytest.mark.parametrize("name", FILES)
def test_job_output_matches_the_reference_within_tolerance(run_dir, name):
    COMPARE[name]((run_dir / name).read_bytes(), _reference(name), name)


# --- the comparisons themselves: a processor's last digits pass, a real change fails ----------------------


def _perturb_numbers(text: str, rel: float, skip_cols: int = 0) -> str:
    """Every decimal number (with a '.') of ``text`` times ``1 + rel``, written with 17 significant digits."""
    return re.sub(r"(?<![\w.])(-?\d*\.\d+(?:[eE][-+]?\d+)?)",
                  lambda m: repr(float(m.group(1)) * (1 + rel)), text)


def test_path_csv_comparison_passes_another_processors_last_digits_and_fails_a_real_change():
    ref = _reference("path.csv")
    compare_path_csv(_perturb_numbers(ref.decode(), 1e-13).encode(), ref)  # the 14th digit: passes
    assert _perturb_numbers(ref.decode(), 1e-13).encode() != ref  # (which a byte comparison refused)
    with pytest.raises(Mismatch, match="off by"):
        compare_path_csv(_perturb_numbers(ref.decode(), 1e-6).encode(), ref)
    lines = ref.decode().splitlines(keepends=True)
    swapped = "".join(lines[:5] + [lines[6], lines[5]] + lines[7:]).encode()  # two dwell points in another order
    with pytest.raises(Mismatch, match="discrete path"):
        compare_path_csv(swapped, ref)
    with pytest.raises(Mismatch, match="number of dwell points"):
        compare_path_csv("".join(lines[:-1]).encode(), ref)


def test_xyz_comparison_allows_its_tolerance_and_no_more():
    ref = _reference("toolpath.xyz")
    lines = ref.decode().splitlines(keepends=True)
    x = np.loadtxt(lines[:50])
    compare_xyz("".join(f"{a:.6f} {b:.6f} {c:.6f}\n" for a, b, c in x + 6e-6).encode(), "".join(lines[:50]).encode())
    with pytest.raises(Mismatch, match="off by"):
        compare_xyz("".join(f"{a:.6f} {b:.6f} {c:.6f}\n" for a, b, c in x + 2e-5).encode(),
                    "".join(lines[:50]).encode())
    with pytest.raises(Mismatch, match="number of samples"):
        compare_xyz("".join(lines[:49]).encode(), "".join(lines[:50]).encode())


def test_gcode_comparison_checks_words_and_resolution():
    ref = ("%\n(polishpath: 0.1.0)\nG21 G90 G17 G94\nG01X-.2031Y-.1287Z11.9868F300\n"
           "G2X-.2745Y.105Z12.027I.1701J.1797F129.4\nX.0313Y1.3504Z11.9108F495.8\nM30\n%\n")
    compare_gcode(ref.replace("(polishpath: 0.1.0)", "(polishpath: 9.9)").replace("X.0313", "X.0314")
                  .replace("F495.8", "F495.9").encode(), ref.encode())
    for changed, why in ((ref.replace("X.0313", "X.0316"), "beyond its resolution"),
                         (ref.replace("G2X", "G3X"), "beyond its resolution"),
                         (ref.replace("I.1701J.1797", "I.1701"), "other words"),
                         (ref.replace("M30\n", ""), "number of blocks"),
                         (ref.replace("F129.4", "F131"), "beyond its resolution")):
        with pytest.raises(Mismatch, match=why):
            compare_gcode(changed.encode(), ref.encode())
