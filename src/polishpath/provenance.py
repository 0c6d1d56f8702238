"""What every output records about how it was made: the seed and the machine.

* :func:`resolve_seed`: the one place a seed is checked and, when none was
  given, drawn (the job, ``polishpath.plan.plan`` and every random stage use it).
* :func:`machine_info`: the computer a run or a benchmark ran on.

The version is :data:`polishpath.__version__`; the parameters are each stage's
:class:`~polishpath.types.Provenance`.
"""

from __future__ import annotations

import os
import platform
import random
from pathlib import Path

import numpy as np

from .errors import ParameterError

#: seeds are whole numbers 0 <= seed < SEED_LIMIT (what the walk's 64-bit generator and TOML hold)
SEED_LIMIT = 2**63
#: a seed drawn for the user is below this: short to read back from summary.json and to type
DRAWN_SEED_LIMIT = 2**31


def resolve_seed(seed: int | None) -> int:
    """The seed to use: ``seed`` checked, or a fresh one drawn when it is None.

    Parameters
    ----------
    seed : int or None
        A whole number ``0 <= seed < 2**63``; None draws one in ``[0, 2**31)``
        from the operating system's entropy (record it to re-run).

    Returns
    -------
    int

    Raises
    ------
    ParameterError
        ``seed`` is not a whole number in range (a bool, a float, negative, too large).
    """
    if seed is None:
        return random.SystemRandom().randrange(DRAWN_SEED_LIMIT)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= int(seed) < SEED_LIMIT:
        raise ParameterError(f"seed must be a whole number 0 <= seed < 2**63, got {seed!r}.",
                             "Give a non-negative integer such as --seed 1, or leave it out to draw one.")
    return int(seed)


def machine_info() -> dict[str, object]:
    """The computer this runs on: ``node``, ``processor`` (model name where the system tells it), ``python``, ``cpus``."""
    proc = platform.processor() or platform.machine()
    try:  # platform.processor() is often empty or just the architecture on Linux
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                proc = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"node": platform.node(), "processor": proc, "python": platform.python_version(), "cpus": os.cpu_count()}
