"""The ``polishpath`` command line (see :mod:`polishpath.cli._common` for exit codes and signals).

One package: ``_common`` (the typer app, the guard that turns errors and signals into messages and exit codes,
shared options), ``_job`` (surfaces, info, flatten, plan, report), ``_measure`` (simulate, psd, paper).
"""

from __future__ import annotations

import contextlib
import os
import sys

import typer

from . import _job, _measure  # noqa: F401  (register the commands)
from ._common import _handle_signals, _interrupt_message, app


def main() -> None:
    """Console-script entry point."""
    try:
        # inside the try: a signal that lands while the handlers are being installed raises here too
        _handle_signals()
        app()
    except BrokenPipeError:  # pragma: no cover - output closed while typer printed help
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        sys.exit(141)
    except KeyboardInterrupt as exc:  # outside typer (it turns the rest into a silent exit 130)
        msg, code = _interrupt_message(type(exc), None)
        typer.echo(f"polishpath: {msg}", err=True)
        sys.exit(code)
    except SystemExit as exc:
        # a signal before a command's guard (while the command line is parsed): typer ends it with a silent
        # exit 130 raised *from* the interrupt; say so, with SIGTERM's own code (the guard's exits are not from one)
        ctx = exc.__context__
        if isinstance(ctx, typer.Exit) and isinstance(ctx.__cause__, KeyboardInterrupt):
            msg, code = _interrupt_message(type(ctx.__cause__), None)
            typer.echo(f"polishpath: {msg}", err=True)
            sys.exit(code)
        raise


if __name__ == "__main__":  # pragma: no cover
    main()
