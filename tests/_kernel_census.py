"""Run one ``polishpath`` command in this process, then write every polishpath numba dispatcher's signatures.

``python tests/_kernel_census.py OUT.json plan ...``: the command's own exit code is kept (a failed job exits with
it, after writing the census). OUT.json maps ``module.kernel`` to ``{"signatures": [...], "compiled": n,
"loaded": n}`` (compiled: signatures numba compiled in this process, a cache miss; loaded: read from the on-disk
cache). tests/conftest.py runs its warm-up jobs through this; tests/test_kernel_signatures.py reads the census.
"""

from __future__ import annotations

import json
import runpy
import sys


def census() -> dict[str, dict]:
    """Every numba dispatcher in the loaded polishpath modules: its signatures and where they came from."""
    from numba.core.dispatcher import Dispatcher

    out: dict[str, dict] = {}
    for name, mod in list(sys.modules.items()):
        if not name.startswith("polishpath") or mod is None:
            continue
        for v in list(vars(mod).values()):
            if isinstance(v, Dispatcher):
                f = v.py_func
                out[f"{f.__module__}.{f.__qualname__}"] = {
                    "signatures": [str(s) for s in v.signatures],
                    "compiled": int(sum(getattr(v, "_cache_misses", {}).values())),
                    "loaded": int(sum(getattr(v, "_cache_hits", {}).values())),
                }
    return out


def main() -> int:
    out, argv = sys.argv[1], sys.argv[2:]
    sys.argv = ["polishpath", *argv]
    code = 0
    try:
        runpy.run_module("polishpath", run_name="__main__", alter_sys=True)
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
    with open(out, "w") as f:
        json.dump(census(), f, indent=1)
    return code


if __name__ == "__main__":
    sys.exit(main())
