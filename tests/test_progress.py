"""Progress on a terminal: each stage's label and the count done; nothing when off (issue 15 item 7)."""

from __future__ import annotations

import time

from polishpath import progress


def test_a_stage_shows_its_count_and_time_on_a_terminal(capsys, monkeypatch):
    monkeypatch.setattr(progress, "SHOW_AFTER_S", 0.0)
    progress.set_enabled(True)
    timings: dict = {}
    try:
        with progress.stage("counting", timings, "count"):
            progress.update(5, 10, "points")
            time.sleep(0.2)
            progress.update(10, 10, "points")
    finally:
        progress.set_enabled(None)
    err = capsys.readouterr().err
    assert "counting" in err and "10 of 10 points" in err
    assert timings["count"] >= 0.2


def test_nothing_is_printed_when_progress_is_off(capsys):
    progress.set_enabled(False)
    try:
        with progress.stage("quiet", None):
            progress.update(1, 2, "points")
    finally:
        progress.set_enabled(None)
    progress.update(3)  # outside any stage: a no-op
    assert capsys.readouterr().err == ""


def test_a_failing_stage_stops_its_display_and_records_no_time(capsys, monkeypatch):
    monkeypatch.setattr(progress, "SHOW_AFTER_S", 0.0)
    progress.set_enabled(True)
    timings: dict = {}
    try:
        try:
            with progress.stage("failing", timings, "f"):
                time.sleep(0.05)
                raise KeyError("x")
        except KeyError:
            pass
    finally:
        progress.set_enabled(None)
    assert "f" not in timings and progress._active == []
    assert "✓ failing" not in capsys.readouterr().err
