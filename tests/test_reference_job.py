"""A small job's machine files against reference files written once, within stated tolerances.

The reference was written by ``tests/data/reference/make_reference.py``: a
refactoring must not change the job's outputs. They are compared as numbers,
not bytes, because another processor (or another BLAS/LAPACK kernel, another
numpy build) adds floating-point operations in another order and moves the
14th significant digit (issue 25: 1e-13 mm on an AMD EPYC). What must hold on
any x86-64 machine, and is checked here:

* the discrete path exactly: the number of dwell points, their order, the
  integer fields (``index``, ``i``, ``j``);
* coordinates (mm) and unit normals to :data:`COORD_TOL_MM` (1e-9) where the file
  holds full precision (``path.csv``); times to :data:`TIME_RTOL` (1e-9 relative);
* the machine samples (``toolpath.xyz``): the same curve, not the same samples.
  They are placed in time by a feed schedule solved to tolerances: a region whose
  feed is decided at a threshold (the scheduling kernel runs a region again when
  it is off by more than 2 %) moves the later samples along the path by up to a
  period. Checked: the first and last sample within the written 1e-6 mm, the
  count within 0.1 %, every written sample within :data:`CURVE_TOL_MM` (the job's
  1 um chord tolerance) of the reference's polyline but at most 0.1 % of them,
  at corners where the curve turns within a step and the reference's chord cuts
  it, within :data:`CORNER_TOL_MM`. Measured on the reference job under
  ``OPENBLAS_CORETYPE=Prescott``: 23,914 samples against 23,913, the samples
  after number 20,166 shifted along the path (up to 0.26 mm, one period at the
  feed), every one within 0.98 um of the reference's polyline (and one reference
  sample 17 um from the written polyline, at such a corner); ``Sandybridge``: one
  written sample 12 um from the reference's polyline, at a corner;
* the G-code (``toolpath.nc``): the blocks without axis words (units, modes,
  spindle, coolant, end) with the same numbers, the feed moves as many within
  2 % (the block fitter decides at its tolerances: the same job under Prescott
  writes 3,015 blocks against 3,009), every feed move but the retract ending
  within :data:`GCODE_CURVE_TOL_MM` (1e-4 mm rounding of each axis plus the 1 um)
  of the reference samples' curve.

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
#: toolpath.xyz across machines: every sample within this of the other's polyline, mm (the job's 1 um
#: chord tolerance plus the written 1e-6 mm; see the module's docstring)
CURVE_TOL_MM = 1e-3 + 1e-6
#: ... except at corners where the curve turns within a sample step (a lift's start), where the reference's
#: chord cuts the corner: at most this share of the samples, within this distance, mm
CORNER_SHARE = 1e-3
CORNER_TOL_MM = 0.05
#: toolpath.xyz across machines: sample counts within this share (a period more or less per flip)
SAMPLE_COUNT_TOL = 1e-3
#: toolpath.nc across machines: feed-move counts within this share
GCODE_BLOCK_RTOL = 0.02
#: toolpath.nc across machines: a feed move's end within this of the reference curve, mm (1e-4 mm
#: rounding of each axis, the curve's 1 um)
GCODE_CURVE_TOL_MM = 0.5e-4 * 3**0.5 + CURVE_TOL_MM
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


def _polyline_distance(p: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """(K,) distance of points ``p`` (K, 3) to the polyline through ``ref`` (M, 3), mm.

    Through the two segments beside the nearest vertex (the samples are dense: a step is far
    shorter than the distance between passes of the path).
    """
    from scipy.spatial import cKDTree

    _, i = cKDTree(ref).query(p)
    best = np.full(len(p), np.inf)
    for lo in (np.clip(i - 1, 0, len(ref) - 2), np.clip(i, 0, len(ref) - 2)):
        a, ab = ref[lo], ref[lo + 1] - ref[lo]
        t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(a + t[:, None] * ab - p, axis=1))
    return best


def compare_xyz(got: bytes, expected: bytes, name: str = "toolpath.xyz") -> None:
    """The same curve: first and last sample within the written 1e-6 mm, the count within
    :data:`SAMPLE_COUNT_TOL`, every written sample within :data:`CURVE_TOL_MM` of the reference's polyline."""
    a, b = got.decode().splitlines(), expected.decode().splitlines()
    xa, xb = np.loadtxt(a, ndmin=2), np.loadtxt(b, ndmin=2)
    if xa.shape[1:] != xb.shape[1:]:
        _fail(name, 1, xa.shape, xb.shape, "another number of columns")
    if abs(len(xa) - len(xb)) > max(SAMPLE_COUNT_TOL * len(xb), 2):
        _fail(name, min(len(a), len(b)) + 1, f"{len(a)} lines", f"{len(b)} lines", "another number of samples")
    for k in (0, -1):
        if not np.abs(xa[k] - xb[k]).max() <= 1e-6 + COORD_TOL_MM:
            _fail(name, k % len(a) + 1, a[k], b[k], "the path starts or ends elsewhere")
    d = _polyline_distance(xa, xb)
    far = np.flatnonzero(~(d <= CURVE_TOL_MM))
    bad = np.flatnonzero(~(d <= CORNER_TOL_MM))
    if len(bad) or len(far) > CORNER_SHARE * len(xa):
        k = int(bad[0] if len(bad) else far[0])
        _fail(name, k + 1, a[k], f"within {CURVE_TOL_MM:g} mm ({CORNER_TOL_MM:g} mm at corners)",
              f"{len(far)} written samples are off the reference's curve by more than {CURVE_TOL_MM:g} mm, this one "
              f"by {d[k]:.3g} mm")


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


def _program(text: str):
    """The blocks without axis words (setup, spindle, coolant, end) and the end points (K, 3) of the
    feed moves (G1/G2/G3, axis words modal; G90 absolute, G91 incremental), with their line numbers."""
    setup, ends, lines = [], [], []
    pos, mode, incremental = {"X": np.nan, "Y": np.nan, "Z": np.nan}, 0, False
    for k, words in _blocks(text):
        axes = False
        for w, v in words:
            if w == "G" and v in (0, 1, 2, 3):
                mode = int(v)
            elif w == "G" and v in (90, 91):
                incremental = v == 91
            elif w in pos:
                pos[w], axes = (pos[w] + v if incremental else v), True
        if not axes:
            setup.append((k, words))
        elif mode in (1, 2, 3):
            ends.append((pos["X"], pos["Y"], pos["Z"]))
            lines.append(k)
    return setup, np.array(ends, dtype=np.float64).reshape(-1, 3), lines


def compare_gcode(got: bytes, expected: bytes, name: str = "toolpath.nc", curve: np.ndarray | None = None) -> None:
    """The same program around the same curve.

    The blocks without axis words (units, modes, spindle, coolant, end) are the same words with the
    same numbers; the feed moves are as many within :data:`GCODE_BLOCK_RTOL` (the block fitter decides
    at its tolerances, so another processor may split a run of samples elsewhere), and every feed
    move but the retract ends within :data:`GCODE_CURVE_TOL_MM` of the reference machine samples'
    curve (``curve``, the reference toolpath.xyz).
    """
    sa, ea, la = _program(got.decode())
    sb, eb, lb = _program(expected.decode())
    if [[w for w, _ in ws] for _, ws in sa] != [[w for w, _ in ws] for _, ws in sb]:
        _fail(name, 1, [ws for _, ws in sa], [ws for _, ws in sb], "other setup or end blocks")
    for (ka, wa), (kb, wb) in zip(sa, sb):
        for (w, x), (_, y) in zip(wa, wb):
            if not abs(x - y) <= GCODE_RESOLUTION.get(w, 0.0) + COORD_TOL_MM:
                _fail(name, ka, f"{w}{x:g}", f"{w}{y:g}", f"word {w} of a setup block beyond its resolution")
    if abs(len(ea) - len(eb)) > GCODE_BLOCK_RTOL * len(eb):
        _fail(name, 1, f"{len(ea)} feed moves", f"{len(eb)} feed moves", "another number of blocks")
    if curve is None:
        curve = np.loadtxt(_reference("toolpath.xyz").decode().splitlines(), ndmin=2)
    d = _polyline_distance(ea[:-1], curve)  # the last feed move is the retract along the normal, off the curve
    bad = np.flatnonzero(~(d <= GCODE_CURVE_TOL_MM))
    if len(bad):
        k = int(bad[0])
        _fail(name, la[k], ea[k].tolist(), f"within {GCODE_CURVE_TOL_MM:g} mm of the reference curve",
              f"a move ends {d[k]:.3g} mm off the reference curve, beyond its resolution")


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


def test_xyz_comparison_allows_another_sampling_of_the_curve_and_no_more():
    t = np.linspace(0, 3, 3001)
    curve = np.column_stack([10 * np.cos(t), 10 * np.sin(t), 0.5 * t])
    ref = "".join(f"{a:.6f} {b:.6f} {c:.6f}\n" for a, b, c in curve).encode()
    shifted = np.column_stack([10 * np.cos(t + 3e-4), 10 * np.sin(t + 3e-4), 0.5 * (t + 3e-4)])  # later in time
    shifted[0], shifted[-1] = curve[0], curve[-1]
    compare_xyz("".join(f"{a:.6f} {b:.6f} {c:.6f}\n" for a, b, c in shifted).encode(), ref)
    for rows, dz in ((slice(1500, 1501), 0.1), (slice(1000, 1030), 0.005)):  # one sample 0.1 mm off; 1 % by 5 um
        off = curve.copy()
        off[rows, 2] += dz
        with pytest.raises(Mismatch, match="off the reference's curve"):
            compare_xyz("".join(f"{a:.6f} {b:.6f} {c:.6f}\n" for a, b, c in off).encode(), ref)
    with pytest.raises(Mismatch, match="number of samples"):
        compare_xyz(b"".join(ref.splitlines(keepends=True)[:2990]), ref)


def test_gcode_comparison_checks_the_setup_the_block_count_and_the_curve():
    t = np.linspace(0, 1, 201)
    curve = np.column_stack([t, t**2, np.zeros_like(t)])

    def program(ends, spindle="M3 S230"):
        moves = "".join(f"G1X{x:.4f}Y{y:.4f}Z{z:.4f}F300\n" for x, y, z in ends)
        return f"%\n(polishpath: 0.1.0)\nG21 G90 G17 G94\n{spindle}\n{moves}G1Z5.\nM30\n%\n".encode()

    ref = program(curve[::2])
    compare_gcode(program(curve[1::2]).replace(b"0.1.0", b"9.9"), ref, curve=curve)  # split elsewhere: passes
    with pytest.raises(Mismatch, match="setup block"):
        compare_gcode(program(curve[::2], "M3 S240"), ref, curve=curve)
    with pytest.raises(Mismatch, match="number of blocks"):
        compare_gcode(program(curve[::4]), ref, curve=curve)
    bent = curve[::2].copy()
    bent[50, 1] += 0.002
    with pytest.raises(Mismatch, match="off the reference curve"):
        compare_gcode(program(bent), ref, curve=curve)
