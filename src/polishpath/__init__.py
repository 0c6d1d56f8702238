"""polishpath: pseudo-random polishing tool paths on free-form surfaces.

The data flows one way, one subpackage per stage::

    surfaces -> flatten -> plan -> mapping -> smooth -> export / simulate / report

>>> import polishpath
>>> job = polishpath.run(surface="hemisphere:triangles=5000", spacing=1.0, seed=7)  # doctest: +SKIP
>>> job.save("out")  # doctest: +SKIP

``polishpath.run(...) -> polishpath.Job`` runs the whole job like the
``polishpath plan`` command (options: :class:`polishpath.JobConfig`). The
stages are importable one by one (``polishpath.surfaces``, ``.flatten``,
``.plan`` (the planar planning stage: ``polishpath.plan.plan(region, spacing)``),
``.mapping``, ``.smooth``, ``.export``, ``.simulate``, ``.psd``, ``.report``).
"""

import importlib as _importlib

from ._version import __version__
from .errors import PolishPathError
from .types import Flattening, PlanarPath, Provenance, Region, Surface, SurfacePath, ToolPath


def run(config=None, **options):
    """Run the whole job and return a :class:`Job` (see :func:`polishpath.pipeline.run`)."""
    from .pipeline import run as _run

    return _run(config, **options)


def load_surface(spec, **kw):
    """Load a surface (see :func:`polishpath.surfaces.load_surface`)."""
    from .surfaces import load_surface as _load

    return _load(spec, **kw)


_STAGES = ("surfaces", "flatten", "plan", "mapping", "smooth", "export", "simulate", "psd", "report", "pipeline")
# the job's classes, loaded with the pipeline on first use
_JOB_NAMES = ("Job", "JobConfig")


def __getattr__(name):
    # stages load on first use, so `import polishpath` stays light
    if name in _STAGES:
        return _importlib.import_module(f".{name}", __name__)
    if name in _JOB_NAMES:
        return getattr(_importlib.import_module(".pipeline", __name__), name)
    raise AttributeError(f"module 'polishpath' has no attribute {name!r}")


__all__ = [
    "Flattening",
    "Job",
    "JobConfig",
    "PlanarPath",
    "PolishPathError",
    "Provenance",
    "Region",
    "Surface",
    "SurfacePath",
    "ToolPath",
    "__version__",
    "load_surface",
    "run",
]
