"""Errors raised by polishpath.

One base class, :class:`PolishPathError`, and a specific subclass per problem,
in the style of shapely: every message says what is wrong *and* what to do.
The command line catches :class:`PolishPathError`, prints its message and exits
with :attr:`PolishPathError.exit_code`; it never shows a traceback for bad input.
"""

from __future__ import annotations


class PolishPathError(Exception):
    """Base class of every error polishpath raises on purpose.

    Parameters
    ----------
    message
        What went wrong, in the user's terms.
    hint
        What to do about it (optional). Appended to the message.
    """

    #: process exit code used by the command line for this error
    exit_code: int = 2

    def __init__(self, message: str, hint: str | None = None):
        self.message = message
        self.hint = hint
        super().__init__(message if not hint else f"{message} {hint}")

    def __reduce__(self):
        # An error raised in a worker process (simulate's process pool, a Dask worker) is pickled back to
        # the parent. Exception's own reduce calls ``cls(*args)`` with the joined text, which fails for a
        # subclass whose constructor takes other arguments (MissingDependencyError: TypeError in the parent
        # instead of the install hint); this rebuilds the same object, every attribute included, without
        # calling the constructor.
        return (_rebuild_error, (type(self), self.args, self.__dict__))


def _rebuild_error(cls: type, args: tuple, state: dict) -> PolishPathError:
    """The error ``cls`` with ``args`` and attributes ``state`` (the unpickling half of ``__reduce__``)."""
    err = cls.__new__(cls)
    err.args = args
    err.__dict__.update(state)
    return err


# --- input: files and specs ---------------------------------------------------------


class InputError(PolishPathError):
    """Something the user gave us cannot be used (file, spec, option)."""


class MeshFileError(InputError):
    """A mesh file is missing, empty, unreadable or of an unknown format."""


class MeasurementFileError(InputError):
    """A measurement file is missing, unreadable or not in a layout polishpath knows."""


class SpecError(InputError):
    """A surface spec (built-in name with parameters, or a TOML file) is invalid."""


class ParameterError(InputError, ValueError):
    """A numeric or named parameter is out of range or inconsistent."""


class ReachError(ParameterError):
    """The machine cannot reach an orientation the path asks for (a rotary axis' range)."""


class ResourceError(InputError):
    """The inputs ask for more than the machine has (memory), found before the work starts."""


class MeasurementUnitsError(MeasurementFileError):
    """A measurement's figures are implausible for the units it was read in."""


# --- input: mesh validity -----------------------------------------------------------


class MeshError(InputError):
    """The mesh is readable but not usable as it is."""


class NonFiniteError(MeshError):
    """Vertex coordinates contain NaN or infinity."""


class NonManifoldError(MeshError):
    """Edges shared by more than two faces, or vertices whose fan is not one disc."""


class ClosedMeshError(MeshError):
    """The mesh has no boundary; the method needs an open patch (a disc, maybe with holes)."""


class MultipleComponentsError(MeshError):
    """The mesh is made of several disconnected pieces."""


class DegenerateMeshError(MeshError):
    """Too many zero-area faces, or nothing left after repair."""


# --- stages ---------------------------------------------------------------------------


class FlatteningError(PolishPathError):
    """A flattening failed, or produced flipped / overlapping triangles."""


class PlanningError(PolishPathError):
    """A path could not be planned (region too small for the spacing, no dwell point...)."""


class SpacingTooLargeError(PlanningError, ParameterError):
    """The dwell-point spacing is too large for the region: fewer than two dwell points fit."""


class PatchTooSmallError(ParameterError):
    """A simulated patch is too small for its evaluation window (the tool's reach from its edges)."""


class MappingError(PolishPathError):
    """A planar point could not be carried back to the surface."""


class FiguringError(PolishPathError):
    """Dwell times could not be solved from the error map and TIF (infeasible, not converged)."""


class FiguringRefusedError(FiguringError):
    """The figuring program would leave the part worse, or its minimum-removal floor exceeds what the error needs."""


class CoverageError(FiguringError, InputError):
    """The measured error map does not cover the part's clear aperture."""


class SmoothingError(PolishPathError):
    """The smoothing curve could not be built or interpolated."""


class SchedulerError(PolishPathError):
    """The Dask scheduler a comparison was sent to (``--scheduler``) cannot be reached."""


class ExportError(PolishPathError):
    """An output file could not be written."""


class InvariantError(RuntimeError):
    """An internal check failed: a bug in polishpath, not a problem with the input.

    Deliberately *not* a :class:`PolishPathError`: the command line reports it
    as an internal error asking for a bug report (exit 1), never as the user's
    mistake. Raise it only where no input can make the check fail.
    """


class OutputLocationError(InputError, ExportError):
    """The output location cannot take the output (a file, a folder of other files, read-only, too little space)."""


class MissingDependencyError(PolishPathError, ImportError):
    """An optional dependency is needed for the feature that was asked for."""

    def __init__(self, package: str, feature: str, extra: str | None = None):
        how = f"pip install 'polishpath[{extra}]'" if extra else f"pip install {package}"
        super().__init__(
            f"{feature} needs the optional package '{package}', which is not installed.",
            f"Install it with: {how}",
        )


def require(module: str, feature: str, extra: str | None = None, package: str | None = None):
    """Import an optional dependency or raise :class:`MissingDependencyError`.

    Optional dependencies fail only when the feature that needs them is used
    (the trimesh way), never at import time of polishpath.
    """
    try:
        return _import_whole(module)
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise MissingDependencyError(package or module, feature, extra) from exc


def optional(module: str):
    """The optional module ``module`` when it is installed, else None (imported whole, :func:`_import_whole`)."""
    try:
        return _import_whole(module)
    except ImportError:
        return None


def _import_whole(module: str):
    """``importlib.import_module(module)`` with SIGINT and SIGTERM held until the import has finished.

    A Ctrl-C or SIGTERM is turned into an exception by the command line's handlers, wherever the
    interpreter is. Raised inside a compiled extension's module set-up (libigl's nanobind types),
    it leaves the extension registered in C but absent from ``sys.modules``; the next import then
    aborts the whole process (nanobind: "refusing to add duplicate key", exit -6) instead of
    ending with the interrupt's message. So the handlers are swapped for ones that only note the
    signal, and a noted signal is raised again as soon as the import is done. (Blocking the
    signals with ``pthread_sigmask`` is not enough: a process-directed signal then goes to another
    thread, OpenBLAS's or numba's, and Python still runs the handler in the main thread.)
    """
    import importlib
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return importlib.import_module(module)
    noted: list[int] = []
    held = (signal.SIGINT, signal.SIGTERM)
    before = {s: signal.signal(s, lambda signum, frame: noted.append(signum)) for s in held}
    try:
        return importlib.import_module(module)
    finally:
        for s, h in before.items():
            signal.signal(s, h)
        for signum in dict.fromkeys(noted):
            signal.raise_signal(signum)
