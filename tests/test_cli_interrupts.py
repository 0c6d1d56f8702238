"""An interrupt that Python's signal handler raises inside a finalizer is not lost.

Python runs a signal handler between any two bytecodes, also inside a ``__del__``
(llvmlite frees its objects that way while numba compiles on a first run). An
exception cannot leave a finalizer: without the guard's ``sys.unraisablehook``
the SIGTERM / Ctrl-C is printed as "Exception ignored ... Traceback" and the job
runs on. The child below raises the signal inside a finalizer, under the
command line's guard, as deterministically as a test can.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"

_CHILD = r"""
import signal, sys, time
import typer
from polishpath.cli._common import _guard

SIG = getattr(signal, sys.argv[1])
KIND = sys.argv[2]

class InFinalizer:
    def __del__(self):
        if KIND == "signal":
            signal.raise_signal(SIG)
            spare = [1] * 3  # bytecodes after the signal: its handler runs here, inside the finalizer
        else:
            raise ValueError("a finalizer's own error")

try:
    with _guard(None):
        InFinalizer()
        # the guard sends a lost interrupt again from a timer thread 10 ms later; on a loaded machine that
        # thread may start seconds late, so wait up to 30 s for it (a passing run ends at the interrupt)
        deadline = time.monotonic() + (30.0 if KIND == "signal" else 0.3)
        while time.monotonic() < deadline:
            time.sleep(0.001)
        print("ran on")
except typer.Exit as e:
    sys.exit(e.exit_code)
"""


def _child(sig: str, kind: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-c", _CHILD, sig, kind], capture_output=True, text=True, env=env,
                          timeout=120)


@pytest.mark.parametrize("sig,code,words", [("SIGTERM", 143, "terminated (SIGTERM)"),
                                            ("SIGINT", 130, "interrupted (SIGINT)")])
def test_an_interrupt_raised_in_a_finalizer_still_stops_the_command(sig, code, words):
    r = _child(sig, "signal")
    assert r.returncode == code, (r.returncode, r.stdout, r.stderr)
    assert words in r.stderr
    assert "Traceback" not in r.stderr and "Exception ignored" not in r.stderr, r.stderr
    assert "ran on" not in r.stdout


def test_another_finalizer_error_is_still_reported_as_python_reports_it():
    r = _child("SIGTERM", "error")
    assert r.returncode == 0, r.stderr
    assert "ran on" in r.stdout
    assert "Exception ignored" in r.stderr and "a finalizer's own error" in r.stderr


def test_the_guard_puts_back_the_hook_it_replaced():
    from polishpath.cli import _common

    before = sys.unraisablehook
    with pytest.raises(Exception):
        with _common._guard(None):
            assert sys.unraisablehook is _common._redeliver_lost_interrupt
            raise ValueError("boom")  # the guard reports it as an internal error (typer.Exit)
    assert sys.unraisablehook is before
    assert signal.getsignal(signal.SIGTERM) is not _common._raise_on_signal


_EARLY_CHILD = r"""
import signal, sys
import polishpath.cli as c
from polishpath.cli import _common

real = _common._handle_signals

def lands_while_installing():
    # the SIGTERM handler is in place and the signal arrives before the next line runs
    signal.signal(signal.SIGTERM, _common._raise_on_signal)
    signal.raise_signal(signal.SIGTERM)
    return real()

c._handle_signals = lands_while_installing
sys.argv = ["polishpath", "surfaces"]
c.main()
"""


def test_a_signal_while_the_handlers_are_installed_is_a_clean_exit():
    """A SIGTERM that lands while main() installs its handlers ends with exit 143 and a message, not a traceback
    (it used to escape main() from before its try: tests/test_output_folders.py's SIGTERM at 0 s saw it under load)."""
    env = {**os.environ, "PYTHONPATH": str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    r = subprocess.run([sys.executable, "-c", _EARLY_CHILD], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 143, r.stderr
    assert "terminated (SIGTERM)" in r.stderr and "Traceback" not in r.stderr, r.stderr
