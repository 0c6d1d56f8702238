"""Progress display for long stages: a line per stage on a terminal, silence otherwise.

Stages call :func:`stage` as a context manager; a stage that runs longer than
:data:`SHOW_AFTER_S` shows a spinner with its label and, when the work inside
reports it through :func:`update`, the count of points or samples done (and
of the total when known). Every stage ends with one line: its label, the last
count and the seconds it took. Nothing is printed when progress is off
(``--quiet``, or stderr is not a terminal), so piped output and ``--json``
stay clean, and :func:`update` then costs one function call.
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from collections.abc import Iterator

SHOW_AFTER_S = 1.0
"""A stage shows its spinner (and counts) once it has run this long, s."""

_enabled: bool | None = None
_active: list["_Stage"] = []


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


def _count(done: int, total: int | None, unit: str) -> str:
    if total is None:
        return f"{done:,} {unit}".strip()
    return f"{done:,} of {total:,} {unit}".strip()


class _Stage:
    """One running stage on a terminal: its spinner (started after SHOW_AFTER_S) and its last count."""

    def __init__(self, label: str) -> None:
        self.label = label
        self.count = ""
        self.status = None
        self.stopped = False
        self._lock = threading.Lock()
        self._timer = threading.Timer(SHOW_AFTER_S, self._show)
        self._timer.daemon = True

    def text(self) -> str:
        return f"[bold]{self.label}[/bold]… {self.count}" if self.count else f"[bold]{self.label}[/bold]…"

    def _show(self) -> None:
        from rich.console import Console

        with self._lock:
            # one spinner at a time: an inner stage shows only while no outer one does
            if self.stopped or self.status is not None or any(s.status is not None for s in _active if s is not self):
                return
            self.status = Console(stderr=True).status(self.text(), spinner="dots")
            self.status.start()

    def set(self, count: str) -> None:
        with self._lock:
            self.count = count
            if self.status is not None:
                self.status.update(self.text())

    def stop(self) -> None:
        self._timer.cancel()
        with self._lock:
            self.stopped = True
            if self.status is not None:
                self.status.stop()
                self.status = None


def update(done: int, total: int | None = None, unit: str = "") -> None:
    """Report the count done in the innermost running stage (no-op when progress is off).

    Parameters
    ----------
    done : int
        Points, samples, figures... done so far.
    total : int, optional
        How many there will be, when known.
    unit : str
        What is counted ("dwell points", "samples").
    """
    if _active:
        _active[-1].set(_count(int(done), None if total is None else int(total), unit))


@contextlib.contextmanager
def stage(label: str, timings: dict | None = None, key: str | None = None) -> Iterator[None]:
    """Show ``label`` (and the counts reported by :func:`update`) while the block runs; record its time.

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

        st = _Stage(label)
        _active.append(st)
        st._timer.start()
        try:
            yield
        finally:
            st.stop()
            _active.remove(st)
        dt = time.perf_counter() - t0
        done = f", {st.count}" if st.count else ""
        Console(stderr=True).print(f"[green]✓[/green] {label} [dim]({dt:.2f} s{done})[/dim]")
    else:
        yield
        dt = time.perf_counter() - t0
    if timings is not None:
        timings[key or label] = dt


def warn(message: str) -> None:
    """Print ``polishpath: warning: message`` on stderr, whether or not progress is shown.

    Warnings say that something was assumed or stays doubtful (a unit taken as
    a default, a flattening far from conformal); they never go to stdout, so
    ``--json`` output stays clean.
    """
    print(f"polishpath: warning: {message}", file=sys.stderr, flush=True)
