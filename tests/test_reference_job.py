"""A small job's machine files, byte for byte, against reference files written once.

The reference was written by ``tests/data/reference/make_reference.py`` from the
code before the architecture redesign: a refactoring must not change one byte.
A change that is *meant* to alter the outputs regenerates them with that script
and says so in its commit message.
"""

from __future__ import annotations

import gzip
import subprocess
import sys
from pathlib import Path

import pytest

REF = Path(__file__).resolve().parent / "data" / "reference"
sys.path.insert(0, str(REF))
from make_reference import ARGS, FILES  # noqa: E402


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("reference") / "run"
    proc = subprocess.run([sys.executable, "-m", "polishpath", *ARGS, "-o", str(out)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.mark.parametrize("name", FILES)
def test_job_output_is_byte_identical_to_reference(run_dir, name):
    expected = gzip.decompress((REF / f"{name}.gz").read_bytes())
    got = (run_dir / name).read_bytes()
    if got != expected:
        a, b = got.splitlines(), expected.splitlines()
        first = next((i for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))
        pytest.fail(
            f"{name} differs from the reference at line {first + 1} ({len(a)} lines written, {len(b)} expected): "
            f"got {a[first] if first < len(a) else b'<end>'!r}, expected {b[first] if first < len(b) else b'<end>'!r}. "
            "A refactoring must not change the job's outputs; if the change is meant to, run "
            "tests/data/reference/make_reference.py and say why in the commit."
        )
