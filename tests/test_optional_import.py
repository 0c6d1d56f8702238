"""Optional native modules are imported whole even when Ctrl-C / SIGTERM comes during their import.

A signal turned into an exception inside an extension's module set-up left libigl's nanobind types
registered but the module absent from ``sys.modules``; the next import aborted the process (exit -6)
in tests/test_output_folders.py's SIGINT-at-2 s case. ``errors.optional`` / ``errors.require`` hold
SIGINT and SIGTERM until the import is done.
"""

from __future__ import annotations

import os
import signal
import sys
import textwrap

import pytest

from polishpath.errors import MissingDependencyError, optional, require

# the module signals its own process in the middle of its set-up, then finishes it
_SELF_SIGNALLING = textwrap.dedent("""
    import os, signal
    STARTED = True
    os.kill(os.getpid(), signal.SIG)
    total = 0
    for k in range(20000):  # bytecodes after the signal: a plain import would be interrupted here
        total += k
    FINISHED = True
""")


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
@pytest.mark.parametrize("importer", [optional, lambda name: require(name, "a test feature")])
def test_a_signal_during_an_optional_import_comes_after_the_module_is_whole(tmp_path, monkeypatch, sig, importer):
    name = f"pp_selfsignal_{sig.lower()}_{id(importer) % 10_000}"
    (tmp_path / f"{name}.py").write_text(_SELF_SIGNALLING.replace("signal.SIG)", f"signal.{sig})"))
    monkeypatch.syspath_prepend(str(tmp_path))

    class Interrupted(Exception):
        pass

    def handler(signum, frame):
        raise Interrupted(signum)

    old = signal.signal(getattr(signal, sig), handler)
    try:
        with pytest.raises(Interrupted):
            importer(name)
            for _ in range(1000):  # the held signal is delivered within a few bytecodes of the import's end
                pass
            os.getpid()
        assert signal.getsignal(getattr(signal, sig)) is handler, "the import did not give the handler back"
    finally:
        signal.signal(getattr(signal, sig), old)
    mod = sys.modules.pop(name, None)
    assert mod is not None and getattr(mod, "FINISHED", False), "the signal interrupted the module's set-up"


def test_optional_gives_none_for_a_missing_module_and_require_names_the_extra():
    assert optional("pp_no_such_module_here") is None
    with pytest.raises(MissingDependencyError, match="pp_no_such_module_here"):
        require("pp_no_such_module_here", "a test feature", extra="peers")
