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


def test_every_stage_of_a_job_shows_what_it_counted(capsys, monkeypatch, tmp_path):
    """On a terminal each stage ends with a line holding its count: dwell points, samples, outputs, figures."""
    import re

    import polishpath

    monkeypatch.setattr(progress, "SHOW_AFTER_S", 0.0)
    progress.set_enabled(True)
    try:
        job = polishpath.run(surface="hemisphere:R=10,triangles=600", spacing=1.5, seed=3)
        job.save(tmp_path / "out")
    finally:
        progress.set_enabled(None)
    err = capsys.readouterr().err
    n, m = job.planar.n_points, len(job.tool_path.samples)
    ends = [line for line in err.splitlines() if "✓" in line]

    class Done(dict):
        def __missing__(self, label):  # the stage's closing line: "✓ label (seconds, count)"
            return next(line for line in ends if line.split("✓", 1)[1].strip().startswith(label + " ("))

    done = Done()
    assert re.search(rf"{n:,} dwell points in plan \d", done["planning pseudorandom path"])
    assert f"{m:,} samples" in done["smoothing (NURBS) and interpolation"]
    assert f"{n:,} dwell points" in done["path metrics"]
    assert f"4 of 4 outputs of {m:,} samples" in done["writing machine files"]
    assert re.search(r"(\d+) of \1 figures", done["writing report"])


def test_a_piped_job_prints_no_progress(capsys, tmp_path):
    """stderr is not a terminal under pytest: the job's stages print nothing at all."""
    import polishpath

    progress.set_enabled(None)
    polishpath.run(surface="hemisphere:R=10,triangles=600", spacing=1.5, seed=3).save(tmp_path / "out", report=False)
    assert capsys.readouterr().err == ""
