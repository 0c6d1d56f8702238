"""Output folders are whole or absent (issue 14 item 4).

Every command that writes a folder writes a staging folder beside it and
renames it into place at the end; a previous run is replaced whole, a folder of
other files is refused; SIGINT / SIGTERM leave no partial run (exit 130 / 143)
and say what was left; an output location that cannot work is refused before
the work with exit 2.

Read-only locations: the tests run as root, where ``chmod`` does not stop a
write and ``os.access`` says yes. polishpath probes a location by creating a
folder in it, so the tests use places where that fails even for root: a path
under a file (ENOTDIR), ``/proc`` (no new entries) and ``/sys`` (a read-only
mount in most containers; skipped where it is writable).
"""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from polishpath.errors import ExportError, OutputLocationError
from polishpath.fileio import atomic_open, check_output_folder, staged_folder
from polishpath.runfolder import is_run_folder

SRC = Path(__file__).resolve().parents[1] / "src"
JOB = ["hemisphere:triangles=2000", "--spacing", "2", "--seed", "1", "--no-report", "-q"]


def _env() -> dict:
    return {**os.environ, "PYTHONPATH": str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", "")}


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "polishpath", *args], capture_output=True, text=True, cwd=cwd,
                          env=_env())


def _digest(folder: Path) -> dict[str, str]:
    """Relative path -> sha256 of every file under ``folder``."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _leftovers(parent: Path, name: str) -> list[str]:
    return sorted(p.name for p in parent.iterdir() if p.name.startswith(f".{name}."))


@pytest.fixture(scope="module")
def job():
    from polishpath import run

    return run(surface="hemisphere:triangles=2000", spacing=2.0, seed=1, report=False)


@pytest.fixture(scope="module")
def previous_run(job, tmp_path_factory) -> Path:
    """A whole run folder (no report) to copy as 'the previous run'."""
    d = tmp_path_factory.mktemp("prev") / "run"
    job.save(d, report=False)
    return d


# --- the staging folder itself ------------------------------------------------------


def test_staged_folder_renames_into_place_and_leaves_nothing_beside(tmp_path):
    target = tmp_path / "out"
    with staged_folder(target, lambda p: False) as stage:
        assert stage.parent == tmp_path and stage.name.startswith(".out.staging-")
        assert not target.exists()
        (stage / "a.txt").write_text("new")
    assert (target / "a.txt").read_text() == "new"
    assert _leftovers(tmp_path, "out") == []


def test_failure_inside_keeps_the_previous_folder_whole(tmp_path):
    target = tmp_path / "out"
    target.mkdir()
    (target / "a.txt").write_text("old")
    for exc in (RuntimeError("boom"), KeyboardInterrupt()):
        with pytest.raises(type(exc)):
            with staged_folder(target, lambda p: True) as stage:
                (stage / "a.txt").write_text("new")
                (stage / "b.txt").write_text("new")
                raise exc
        assert sorted(os.listdir(target)) == ["a.txt"] and (target / "a.txt").read_text() == "old"
        assert _leftovers(tmp_path, "out") == []


def test_a_full_disk_while_writing_is_an_export_error_and_leaves_nothing(tmp_path):
    import errno

    target = tmp_path / "out"
    with pytest.raises(ExportError, match="No space left.*Nothing was left"):
        with staged_folder(target, lambda p: False) as stage:
            (stage / "path.csv").write_text("partial")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(stage / "toolpath.xyz"))
    assert not target.exists() and _leftovers(tmp_path, "out") == []


def test_keep_copies_only_the_kept_entries(tmp_path):
    target = tmp_path / "out"
    (target / "figures").mkdir(parents=True)
    (target / "figures" / "x.png").write_text("old figure")
    (target / "report.html").write_text("old report")
    (target / "summary.json").write_text("{}")
    with staged_folder(target, lambda p: True, keep=lambda n: n not in ("report.html", "figures")) as stage:
        assert sorted(os.listdir(stage)) == ["summary.json"]
        (stage / "report.html").write_text("new report")
    assert sorted(os.listdir(target)) == ["report.html", "summary.json"]
    assert (target / "report.html").read_text() == "new report"


def test_kept_entries_are_linked_and_a_failed_rewrite_leaves_them_as_they_were(tmp_path):
    # a kept file costs no copy (a hard link, same inode), and replacing it in the
    # staging folder through atomic_open (how every writer writes) never reaches
    # the previous folder's file, even when the run then fails
    target = tmp_path / "out"
    (target / "simulation").mkdir(parents=True)
    (target / "run.npz").write_bytes(b"x" * 1000)
    (target / "simulation" / "table.txt").write_text("old table")
    (target / "summary.json").write_text("old summary")
    with pytest.raises(RuntimeError, match="late failure"):
        with staged_folder(target, lambda p: True, keep=lambda n: True) as stage:
            assert os.stat(stage / "run.npz").st_ino == os.stat(target / "run.npz").st_ino
            assert os.stat(stage / "simulation" / "table.txt").st_ino == \
                os.stat(target / "simulation" / "table.txt").st_ino
            with atomic_open(stage / "summary.json") as fh:
                fh.write("new summary")
            assert (stage / "summary.json").read_text() == "new summary"
            raise RuntimeError("late failure")
    assert (target / "summary.json").read_text() == "old summary"
    assert (target / "run.npz").read_bytes() == b"x" * 1000
    assert (target / "simulation" / "table.txt").read_text() == "old table"


def test_refusals_before_any_work(tmp_path):
    (tmp_path / "afile").write_text("x")
    with pytest.raises(OutputLocationError, match="is an existing file"):
        check_output_folder(tmp_path / "afile", is_run_folder)
    with pytest.raises(OutputLocationError, match="afile is a file, not a folder"):
        check_output_folder(tmp_path / "afile" / "sub" / "out", is_run_folder)
    with pytest.raises(OutputLocationError, match="not writable"):
        check_output_folder(Path("/proc/polishpath-out"), is_run_folder)
    with pytest.raises(OutputLocationError, match=r"needs about .* MB .* has only .* MB free"):
        check_output_folder(tmp_path / "new", is_run_folder, need_bytes=2**62)
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "thesis.tex").write_text("mine")
    with pytest.raises(OutputLocationError, match="not a polishpath run folder"):
        check_output_folder(foreign, is_run_folder, kind="polishpath run folder")
    (tmp_path / "empty").mkdir()
    check_output_folder(tmp_path / "empty", is_run_folder)  # an empty folder is fine
    check_output_folder(tmp_path / "not" / "yet", is_run_folder)  # so are folders still to be made


def test_a_read_only_mount_is_refused():
    probe = Path("/sys/polishpath-probe")
    try:
        probe.mkdir()
    except OSError:
        pass
    else:  # pragma: no cover - a writable /sys
        probe.rmdir()
        pytest.skip("/sys is writable here")
    with pytest.raises(OutputLocationError, match="not writable"):
        check_output_folder(probe / "out", is_run_folder)


def test_run_folder_recognition(tmp_path, previous_run):
    assert is_run_folder(previous_run)
    partial = tmp_path / "partial"  # what an interrupted older version left: machine files only
    partial.mkdir()
    (partial / "path.csv").write_text("x")
    (partial / "toolpath.xyz").write_text("x")
    assert is_run_folder(partial)
    (partial / "notes.txt").write_text("mine")
    assert not is_run_folder(partial)


# --- the job's folder ---------------------------------------------------------------


def test_a_reused_run_folder_keeps_no_stale_file(job, tmp_path):
    d = tmp_path / "out"
    written = job.save(d, report=True)
    assert (d / "report.html").is_file() and (d / "figures").is_dir()
    assert all(p.parent.name in ("out", "figures") and p.exists() for p in written.values())
    assert str(d.resolve()) in (d / "report.html").read_text()  # the report names the folder, not the staging one
    job.save(d, report=False)
    assert sorted(os.listdir(d)) == sorted(["flat.obj", "job.toml", "path.csv", "run.npz", "summary.json",
                                            "toolpath.nc", "toolpath.xyz"])
    assert _leftovers(tmp_path, "out") == []


def test_report_rebuild_is_staged_and_keeps_the_run(previous_run, tmp_path):
    import shutil

    from polishpath.pipeline import rebuild_report

    d = tmp_path / "run"
    shutil.copytree(previous_run, d)
    before = _digest(d)
    (d / "figures").mkdir()
    (d / "figures" / "stale.png").write_text("from an earlier report")
    written = rebuild_report(d)
    assert written["report"] == d / "report.html" and written["report"].is_file()
    assert not (d / "figures" / "stale.png").exists()
    after = _digest(d)
    assert {k: v for k, v in after.items() if k in before} == before  # the run's own files untouched
    assert _leftovers(tmp_path, "run") == []


def test_foreign_folder_refused_by_the_cli_before_the_work(tmp_path):
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "thesis.tex").write_text("mine")
    # --spacing 1000 would fail in planning, after the flattening: the output check comes first
    r = _cli("plan", "hemisphere:triangles=2000", "--spacing", "1000", "-o", str(foreign), cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    assert "holds files that are not a polishpath run folder" in r.stderr and "Traceback" not in r.stderr
    assert os.listdir(foreign) == ["thesis.tex"]


@pytest.mark.parametrize("where", ["existing_file", "under_file", "proc"])
def test_unusable_output_fails_before_the_work(tmp_path, where):
    (tmp_path / "afile").write_text("x")
    out = {"existing_file": str(tmp_path / "afile"), "under_file": str(tmp_path / "afile" / "out"),
           "proc": "/proc/polishpath-out"}[where]
    expect = {"existing_file": "is an existing file", "under_file": "is a file, not a folder",
              "proc": "is not writable"}[where]
    r = _cli("plan", "hemisphere:triangles=2000", "--spacing", "1000", "-o", out, cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    assert expect in r.stderr and "This is a bug" not in r.stderr and "Traceback" not in r.stderr
    assert "spacing 1000" not in r.stderr  # refused before the planning could fail
    assert (tmp_path / "afile").read_text() == "x"


def test_other_commands_refuse_unusable_outputs(tmp_path):
    (tmp_path / "afile").write_text("x")
    r = _cli("simulate", "hemisphere:triangles=2000", "-o", str(tmp_path / "afile"), cwd=tmp_path)
    assert r.returncode == 2 and "is an existing file" in r.stderr, r.stderr
    r = _cli("paper", "--quick", "-o", str(tmp_path / "afile" / "p"), cwd=tmp_path)
    assert r.returncode == 2 and "is a file, not a folder" in r.stderr, r.stderr
    (tmp_path / "d").mkdir()
    r = _cli("flatten", "hemisphere:triangles=2000", "-o", str(tmp_path / "d"), cwd=tmp_path)
    assert r.returncode == 2 and "is a folder" in r.stderr, r.stderr
    r = _cli("flatten", "hemisphere:triangles=2000", "-o", "/proc/polishpath.obj", cwd=tmp_path)
    assert r.returncode == 2 and "not writable" in r.stderr, r.stderr


# --- signals --------------------------------------------------------------------------

# The child imports the command line, says "ready", then runs it: the delays count from a
# loaded program (before that, nothing is written and Python's own start-up handles the signal).
_CHILD = ("import sys; import polishpath.cli as c; print('ready', flush=True); "
          "sys.argv = ['polishpath'] + sys.argv[1:]; c.main()")


def _interrupt(tmp_path: Path, sig: int, when: float | str, previous: Path | None):
    out = tmp_path / "out"
    if previous is not None:
        import shutil

        shutil.copytree(previous, out)
    before = _digest(out) if previous is not None else None
    p = subprocess.Popen([sys.executable, "-c", _CHILD, "plan", *JOB, "-o", str(out)], cwd=tmp_path, env=_env(),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "ready"
    if when == "writing":  # the staging folder appears: the machine files are being written
        deadline = time.monotonic() + 600
        while (not any(n.startswith(".out.staging-") for n in _leftovers(tmp_path, "out"))
               and p.poll() is None and time.monotonic() < deadline):
            time.sleep(0.005)
    else:
        time.sleep(when)
    p.send_signal(sig)
    stdout, stderr = p.communicate(timeout=600)
    return p.returncode, stderr, out, before


@pytest.mark.parametrize("sig,when,reuse", [
    (signal.SIGTERM, 0.0, True), (signal.SIGINT, 0.5, False), (signal.SIGTERM, 0.5, True),
    (signal.SIGINT, 2.0, True), (signal.SIGTERM, 2.0, False),
    (signal.SIGTERM, 4.0, True), (signal.SIGINT, 4.0, False),
    (signal.SIGINT, "writing", True), (signal.SIGTERM, "writing", False),
])
def test_a_signal_leaves_no_partial_run(tmp_path, previous_run, sig, when, reuse):
    code, stderr, out, before = _interrupt(tmp_path, sig, when, previous_run if reuse else None)
    assert "Traceback" not in stderr and "This is a bug" not in stderr
    assert _leftovers(tmp_path, "out") == []
    if code == 0:  # the job finished before the signal came: then it is the new whole run
        assert is_run_folder(out) and (out / "toolpath.xyz").is_file()
        return
    if code == -sig:  # killed by the signal's default action: before main() set its handlers (nothing
        # started) or during the interpreter's exit after the command finished (the new run is whole)
        assert stderr == ""
        if (out / "summary.json").is_file() and (not reuse or _digest(out) != before):
            assert is_run_folder(out) and (out / "toolpath.xyz").is_file()
        else:
            assert _digest(out) == before if reuse else not out.exists()
        return
    assert code == (130 if sig == signal.SIGINT else 143), stderr
    assert ("interrupted (SIGINT)" if sig == signal.SIGINT else "terminated (SIGTERM)") in stderr
    if "had been written whole" in stderr:  # the signal came during the final rename: held till it was done
        assert is_run_folder(out) and (out / "toolpath.xyz").is_file()
        return
    # "nothing was written": the signal came while the command line was still being parsed
    if reuse:
        assert "is as it was before this command" in stderr or "nothing was written" in stderr, stderr
        assert _digest(out) == before
    else:
        assert "was not created" in stderr or "nothing was written" in stderr, stderr
        assert not out.exists()
