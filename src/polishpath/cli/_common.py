"""The ``polishpath`` command line: the app, its error guard and signals, shared options.

Every command catches :class:`~polishpath.errors.PolishPathError`, prints its
message (what is wrong, what to do) and exits non-zero; no traceback is shown
for bad input. ``--json`` prints one JSON object of figures on stdout.

Exit codes: 0 success, 1 unexpected internal error, 2 bad input or a stage
that could not complete (the message says which), 130 interrupted (SIGINT,
Ctrl-C), 143 terminated (SIGTERM). A command that writes a folder writes it
whole or not at all (:func:`polishpath.fileio.staged_folder`): after an
interrupt the folder is absent or as it was before, and the message says which.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import sys
import threading
from pathlib import Path
from typing import Any

import typer

from .._version import __version__
from ..errors import PolishPathError

app = typer.Typer(
    name="polishpath",
    help=(
        "Pseudo-random polishing tool paths on free-form surfaces.\n\n"
        "SURFACE is a mesh file (.stl .obj .ply .off), a built-in shape with optional "
        "parameters (hemisphere:R=30,triangles=5000 — see `polishpath surfaces`), an "
        "analytic surface (asphere:R=80,k=-1,radius=20) or a .toml spec.\n\n"
        "Examples:\n\n"
        "  polishpath plan hemisphere --spacing 0.5 --seed 1 -o out\n\n"
        "  polishpath info part.stl --units m\n\n"
        "  polishpath flatten lilium.obj --method mabf -o flat.obj --json"
    ),
    no_args_is_help=True,
    add_completion=False,
    rich_markup_mode=None,
    pretty_exceptions_enable=False,
)


def _version_cb(value: bool):
    if value:
        typer.echo(f"polishpath {__version__}")
        raise typer.Exit(0)


@app.callback()
def _main(
    version: bool = typer.Option(False, "--version", callback=_version_cb, is_eager=True, help="Print the version and exit."),
):
    """polishpath command line."""


def _fail(msg: str, code: int) -> None:
    typer.echo(f"polishpath: error: {msg}", err=True)
    raise typer.Exit(code)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C's KeyboardInterrupt so the same clean-up runs (exit 143)."""


#: the SIGINTs / SIGTERMs this process received, in order (empty: none)
_SIGNALLED: list[int] = []


def _raise_on_signal(signum, frame):
    _SIGNALLED.append(signum)
    raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


def _handle_signals() -> dict | None:
    """Make SIGTERM raise :class:`Terminated` and SIGINT KeyboardInterrupt, remembering which came
    (main thread only: Python runs handlers there). Returns the handlers replaced (None: not installed)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    return {sig: signal.signal(sig, _raise_on_signal) for sig in (signal.SIGTERM, signal.SIGINT)}


def _redeliver_lost_interrupt(unraisable) -> None:
    """``sys.unraisablehook`` while the guard is on: an interrupt raised inside a finalizer is raised again.

    Python runs a signal's handler between any two bytecodes, also inside a
    ``__del__`` (llvmlite frees its objects that way while numba compiles, on a
    first run with an empty cache). An exception cannot leave a finalizer:
    Python prints it as "Exception ignored ... Traceback" and carries on, so the
    user's Ctrl-C or SIGTERM would be lost and a traceback shown. Here the
    signal is sent again, from a timer thread 10 ms later (sent from the hook
    itself, its handler would run inside the hook, where an exception is lost
    too), so that the handler raises in ordinary code; should it land in a
    finalizer again, this hook sends it once more. Any other unraisable
    exception goes to the previous hook.
    """
    if isinstance(unraisable.exc_value, KeyboardInterrupt) and _SIGNALLED:
        resend = threading.Timer(0.01, os.kill, (os.getpid(), _SIGNALLED[-1]))
        resend.daemon = True
        resend.start()
        return
    _PREVIOUS_UNRAISABLEHOOK[-1](unraisable)


_PREVIOUS_UNRAISABLEHOOK: list = []


def _interrupt_message(et: type, out: Path | None) -> tuple[str, int]:
    """What an interrupt left, said truthfully, and its exit code (130 SIGINT, 143 SIGTERM)."""
    from ..fileio import COMMITTED

    code, name = (143, "terminated (SIGTERM)") if issubclass(et, Terminated) else (130, "interrupted (SIGINT)")
    if out is None:
        return f"{name}; nothing was written.", code
    if out.absolute() in COMMITTED:
        return f"{name} after {out} had been written whole.", code
    if out.exists():
        return f"{name}; {out} is as it was before this command (nothing of this run was written).", code
    return f"{name}; {out} was not created (no partial output left).", code


def _interrupt_in(exc: BaseException | None) -> BaseException | None:
    """The KeyboardInterrupt (SIGINT) or :class:`Terminated` (SIGTERM) that ``exc`` is or came from.

    A signal handled while compiled code runs (numba's dispatcher) surfaces as a
    ``SystemError`` "returned a result with an exception set" whose context is
    the interrupt: that is an interrupt too, not a bug.
    """
    first, seen = exc, 0
    while exc is not None and seen < 20:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        exc = exc.__cause__ or exc.__context__
        seen += 1
    if _SIGNALLED and isinstance(first, SystemError):  # the context was lost on the way out
        return Terminated() if _SIGNALLED[-1] == signal.SIGTERM else KeyboardInterrupt()
    return None


class _guard:
    """Turn polishpath errors into a message and exit code; SIGINT into exit 130, SIGTERM into 143.

    ``out_dir``: the output this command writes, named in the interrupt message.
    """

    def __init__(self, out_dir: Path | None = None):
        self.out_dir = out_dir

    def __enter__(self):
        self._handlers = _handle_signals()
        if self._handlers is not None:
            _PREVIOUS_UNRAISABLEHOOK.append(sys.unraisablehook)
            sys.unraisablehook = _redeliver_lost_interrupt
        return self

    def __exit__(self, et, ev, tb):
        for sig, handler in (self._handlers or {}).items():
            signal.signal(sig, handler)
        if self._handlers is not None:
            sys.unraisablehook = _PREVIOUS_UNRAISABLEHOOK.pop()
        if et is None or issubclass(et, (typer.Exit, SystemExit)):
            return False
        if issubclass(et, PolishPathError):
            _fail(str(ev), ev.exit_code)
        if issubclass(et, BrokenPipeError):
            _quiet_broken_pipe()
        interrupt = _interrupt_in(ev)
        if interrupt is not None:
            _fail(*_interrupt_message(type(interrupt), self.out_dir))
        if issubclass(et, MemoryError):
            _fail("ran out of memory. Try fewer triangles, a larger spacing, or a smaller part.", 2)
        if os.environ.get("POLISHPATH_DEBUG"):
            return False  # show the traceback
        _fail(
            f"internal error: {et.__name__}: {ev}. This is a bug in polishpath; please report it with the "
            "command you ran (set POLISHPATH_DEBUG=1 to see the traceback).",
            1,
        )


def _quiet_broken_pipe() -> None:
    """The reader of our output went away (``polishpath info X | head``): stop quietly, like other Unix tools.

    stdout is pointed at /dev/null so that Python's own flush at exit does not
    raise again; the exit code is the shell's for a SIGPIPE death (128 + 13).
    """
    with contextlib.suppress(OSError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    raise typer.Exit(141)


def _print_json(obj: Any) -> None:
    from ..fileio import jsonable

    typer.echo(json.dumps(jsonable(obj), indent=2))


def _quiet(quiet: bool, json_out: bool) -> None:
    from .. import progress

    if quiet or json_out:
        progress.set_enabled(False)


SURFACE_ARG = typer.Argument(..., metavar="SURFACE", help="Mesh file, built-in name[:key=value,...], analytic spec, or .toml spec.")
UNITS_OPT = typer.Option(None, "--units", help="Units of a mesh file: mm (default), m, cm, um, in.")
SCALE_OPT = typer.Option(None, "--scale", help="Extra scale factor for a mesh file, to millimetres.")
def _remesh_help() -> str:
    from ..config import FIELDS

    return FIELDS["remesh"].metadata["help"]


def job_default(name: str) -> Any:
    """The default of job option ``name`` (``config.JobConfig``): what a command's flag of the same name starts
    from, so the command line and the API never disagree (tests/test_defaults.py)."""
    from ..config import FIELDS

    return FIELDS[name].default


REMESH_HELP = _remesh_help()
COMPONENT_OPT = typer.Option(job_default("component"), "--component",
                             help="Several pieces in the mesh: 'refuse' (default) or 'largest'.")


