"""Write the reference outputs that ``tests/test_reference_job.py`` compares within stated tolerances.

Run deliberately, only when a change is *meant* to alter the job's outputs
(say so in the commit message); a refactoring must leave them unchanged:

    python tests/data/reference/make_reference.py

The job is small on purpose (about 300 dwell points, 0.7 MB of machine path),
and the files are stored gzip-compressed.
"""

from __future__ import annotations

import gzip
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
# the job every reference file comes from (the test runs the same arguments)
ARGS = ["plan", "hemisphere:R=12,triangles=3000", "--spacing", "1.5", "--seed", "11", "--no-report", "--quiet"]
FILES = ("path.csv", "toolpath.xyz", "toolpath.nc")


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        subprocess.run([sys.executable, "-m", "polishpath", *ARGS, "-o", str(out)], check=True)
        for name in FILES:
            with open(out / name, "rb") as src, gzip.GzipFile(HERE / f"{name}.gz", "wb", mtime=0) as dst:
                shutil.copyfileobj(src, dst)
            print(f"wrote {HERE / name}.gz")


if __name__ == "__main__":
    main()
