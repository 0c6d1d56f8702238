"""Progress display for long stages: a spinner per stage on a terminal, silence otherwise.

Stages call :func:`stage` as a context manager; nothing is printed when
progress is off (``--quiet``, or stderr is not a terminal), so piped output
and ``--json`` stay clean.
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Iterator

_enabled: bool | None = None


def set_enabled(flag: bool | None) -> None:
    """Force progress on (True) or off (False); None: on only when stderr is a TTY."""
    global _enabled
    _enabled = flag


def enabled() -> bool:
    if _enabled is not None:
        return _enabled
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


@contextlib.contextmanager
def stage(label: str, timings: dict | None = None, key: str | None = None) -> Iterator[None]:
    """Show a spinner labelled ``label`` while the block runs; record its time in ``timings[key]``.

    Parameters
    ----------
    label : str
        What is being done (shown on the terminal).
    timings : dict, optional
        Where to store the elapsed seconds.
    key : str, optional
        Key in ``timings`` (default: ``label``).
    """
    t0 = time.perf_counter()
    if enabled():
        from rich.console import Console

        console = Console(stderr=True)
        with console.status(f"[bold]{label}[/bold]…", spinner="dots"):
            yield
        dt = time.perf_counter() - t0
        console.print(f"[green]✓[/green] {label} [dim]({dt:.2f} s)[/dim]")
    else:
        yield
        dt = time.perf_counter() - t0
    if timings is not None:
        timings[key or label] = dt
