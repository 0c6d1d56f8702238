"""File writing shared by every stage: atomic files, whole-or-absent folders, JSON-ready values.

A file is written to a temporary file beside the target and renamed into place
only when complete (:func:`atomic_open`). A folder of outputs (a run folder, a
simulation, the paper) is written into a staging folder beside the target and
renamed into place at the end (:func:`staged_folder`), so an interrupted or
failed run leaves either no folder or the previous run's whole folder, never a
mix. :func:`check_output_folder` / :func:`check_output_file` refuse an output
location that cannot work (a file where a folder is wanted, a folder of other
files, a read-only place, too little free space) before any work is done.
"""

from __future__ import annotations

import contextlib
import errno
import math
import os
import shutil
import signal
import tempfile
import tomllib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np

from .errors import ExportError, InputError, OutputLocationError

#: folders this process renamed into place (:func:`staged_folder`), resolved: the CLI's
#: interrupt message tells an interrupt after the commit from one before it
COMMITTED: set[Path] = set()
#: free space kept beyond an output's estimated size, bytes
SPACE_RESERVE = 16 * 2**20


@contextlib.contextmanager
def atomic_open(path: str | Path, mode: str = "w") -> Iterator[IO]:
    """Open ``path`` for writing through a temporary file renamed into place on success.

    Parameters
    ----------
    path : str or Path
        Target file; its folder must exist.
    mode : {"w", "wb"}
        Text (UTF-8, ``\\n`` line ends) or binary.

    The file gets the permissions a plain ``open()`` would give (``mkstemp``
    alone makes them 0600). On any exception, the temporary file is removed and
    the target is left as it was.
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_open writes only, mode 'w' or 'wb', got {mode!r}")
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(tmp, 0o666 & ~mask)
    try:
        kw = {"encoding": "utf-8", "newline": ""} if mode == "w" else {}
        with os.fdopen(fd, mode, **kw) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _nearest_existing(p: Path) -> Path:
    p = p.absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def _check_writable_place(target: Path, need_bytes: int, what: str) -> Path:
    """Refuse when the folder that will hold ``target`` cannot be created or written; return that place.

    Writability is probed by creating (and removing) a folder there, not with
    ``os.access``: as root ``os.access`` says yes to a read-only mount and to
    ``/proc``, where the write would still fail.
    """
    place = _nearest_existing(target.parent)
    if not place.is_dir():
        raise OutputLocationError(f"{what} {target} cannot be created: {place} is a file, not a folder.",
                                  "Give -o a path whose parent folders are folders (or can be created).")
    try:
        with _signals_held():  # an interrupt between the two calls would leave the probe behind
            probe = tempfile.mkdtemp(prefix=f".{target.name}.probe-", dir=place)
            os.rmdir(probe)
    except OSError as exc:
        raise OutputLocationError(f"{what} {target} cannot be written: {place} is not writable "
                                  f"({exc.strerror or exc}).",
                                  "Give -o a folder you can write to, or fix its permissions.") from None
    if need_bytes > 0:
        free = shutil.disk_usage(place).free
        if free < need_bytes + SPACE_RESERVE:
            raise OutputLocationError(
                f"{what} {target} needs about {need_bytes / 2**20:.3g} MB (estimated from the job's size) and "
                f"{SPACE_RESERVE / 2**20:.3g} MB to spare, but {place} has only {free / 2**20:.3g} MB free.",
                "Free some space there, give -o a place on another disk, or make the job smaller "
                "(a larger --spacing; --no-report saves the report's figures).")
    return place


def check_output_folder(target: str | Path, recognise: Callable[[Path], bool], *, need_bytes: int = 0,
                        what: str = "output folder", kind: str = "polishpath output") -> None:
    """Refuse an output folder that cannot be written whole, before any work.

    Parameters
    ----------
    target : path
        The folder to write (absent, empty, or holding a previous output of this kind).
    recognise : callable
        ``recognise(folder) -> bool``: the folder holds a previous output of this
        kind (then it is replaced whole).
    need_bytes : int
        Estimated size of the output, bytes (0: not checked).
    what, kind : str
        Words for the messages (``"output folder"``, ``"polishpath run folder"``).

    Raises
    ------
    OutputLocationError
        ``target`` is a file, a folder of other files, in a place that is not
        writable, or on a disk with too little free space.
    """
    t = Path(target)
    if t.exists() and not t.is_dir():
        raise OutputLocationError(f"{what} {t} is an existing file, not a folder.",
                                  "Give -o a new folder name (or the folder of a previous run to replace it).")
    if t.is_dir() and any(t.iterdir()) and not recognise(t):
        raise OutputLocationError(
            f"{what} {t} holds files that are not a {kind}; polishpath replaces a previous output whole and "
            "will not delete other files.",
            "Give -o a new or empty folder, or remove that folder's files yourself.")
    _check_writable_place(t, need_bytes, what)


def check_output_file(target: str | Path, *, need_bytes: int = 0, what: str = "output file") -> None:
    """Refuse an output file that cannot be written, before any work (:class:`OutputLocationError`)."""
    t = Path(target)
    if t.is_dir():
        raise OutputLocationError(f"{what} {t} is a folder.", "Give -o a file name.")
    _check_writable_place(t, need_bytes, what)


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM until the block ends (they are delivered then), so renames are not cut."""
    sigs = {signal.SIGINT, signal.SIGTERM}
    try:
        old = signal.pthread_sigmask(signal.SIG_BLOCK, sigs)
    except (AttributeError, OSError, ValueError):  # no pthread_sigmask on this platform
        yield
        return
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _fresh_name(folder: Path, prefix: str) -> Path:
    fd, name = tempfile.mkstemp(prefix=prefix, dir=folder)
    os.close(fd)
    os.unlink(name)
    return Path(name)


@contextlib.contextmanager
def staged_folder(target: str | Path, recognise: Callable[[Path], bool], *, keep: Callable[[str], bool] | None = None,
                  need_bytes: int = 0, what: str = "output folder",
                  kind: str = "polishpath output") -> Iterator[Path]:
    """Write a folder whole or not at all: yield a staging folder, rename it to ``target`` at the end.

    The staging folder ``.NAME.staging-XXXX`` lies beside ``target`` (same
    disk, so the rename is atomic). On success a previous ``target`` is moved
    aside, the staging folder renamed into place and the old one deleted, with
    SIGINT / SIGTERM held meanwhile; on any exception (Ctrl-C included) the
    staging folder is deleted and ``target`` is left exactly as it was.

    Parameters
    ----------
    target : path
        The output folder.
    recognise : callable
        ``recognise(folder) -> bool``: a previous output of this kind, which may
        be replaced (anything else non-empty is refused, see :func:`check_output_folder`).
    keep : callable, optional
        ``keep(name) -> bool`` for the top-level entries of an existing
        ``target`` to put into the staging folder first, as hard links where the
        file system allows (else copies): ``polishpath report`` keeps the run's
        files and rewrites only its report. A writer must replace a kept file
        (:func:`atomic_open`), never rewrite it in place. None: start empty.
    need_bytes, what, kind
        As in :func:`check_output_folder`.

    Yields
    ------
    Path
        The staging folder to write into.

    Raises
    ------
    OutputLocationError
        See :func:`check_output_folder`.
    ExportError
        The disk filled up or refused a write while writing (nothing is left).
    """
    t = Path(target)
    check_output_folder(t, recognise, need_bytes=need_bytes, what=what, kind=kind)
    t.parent.mkdir(parents=True, exist_ok=True)
    stage: Path | None = None
    try:
        with _signals_held():  # a signal held here is raised on leaving the block: stage is set by then
            stage = Path(tempfile.mkdtemp(prefix=f".{t.name}.staging-", dir=t.parent))
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(stage, 0o777 & ~mask)
        if keep is not None and t.is_dir():
            for entry in sorted(t.iterdir()):
                if keep(entry.name):
                    if entry.is_dir():
                        shutil.copytree(entry, stage / entry.name, copy_function=_link_or_copy)
                    else:
                        _link_or_copy(entry, stage / entry.name)
        try:
            yield stage
        except OSError as exc:
            if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM):
                raise ExportError(f"writing {what} {t} failed: {exc.strerror or exc} ({exc.filename or t}). "
                                  f"Nothing was left: {t} is as it was before the run.",
                                  "Free some space or give -o another place, then run again.") from None
            raise
        with _signals_held():
            old = None
            if t.exists():
                old = _fresh_name(t.parent, f".{t.name}.old-")
                os.rename(t, old)
            try:
                os.rename(stage, t)
            except BaseException:
                if old is not None:
                    os.rename(old, t)
                raise
            COMMITTED.add(t.absolute())
            if old is not None:
                shutil.rmtree(old, ignore_errors=True)
    finally:
        if stage is not None and stage.exists():
            with _signals_held():
                shutil.rmtree(stage, ignore_errors=True)


def _link_or_copy(src, dst) -> None:
    """Put ``src`` at ``dst`` as a hard link (no bytes copied), or a copy where links are refused.

    A kept entry of :func:`staged_folder` is linked, so rebuilding the report of
    a 2 GB run copies nothing. That is safe because every writer replaces a
    file (:func:`atomic_open`: a new file renamed over the name) instead of
    rewriting it in place, so the previous folder's inode is never changed.
    """
    try:
        os.link(src, dst)
    except OSError:  # another file system, no hard links (EXDEV, EPERM, EMLINK, ...)
        shutil.copy2(src, dst)


def jsonable(o: Any) -> Any:
    """``o`` with numpy values, paths and non-finite floats made JSON-safe (NaN/inf -> None)."""
    if isinstance(o, dict):
        return {str(k): jsonable(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [jsonable(v) for v in o]
    if isinstance(o, np.ndarray):
        return jsonable(o.tolist())
    if isinstance(o, np.bool_):
        return bool(o)
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, (float, np.floating)):
        v = float(o)
        return v if math.isfinite(v) else None
    if isinstance(o, Path):
        return str(o)
    if o is None or isinstance(o, (str, int, bool)):
        return o
    if hasattr(o, "to_dict"):
        return jsonable(o.to_dict())
    return None if callable(o) else str(o)


def read_toml(path: str | Path, what: str = "job file", error: type[InputError] = InputError) -> dict[str, Any]:
    """Read a TOML file (a job, a machine profile, a surface spec), its problems raised as ``error``.

    Parameters
    ----------
    path : str or Path
        The file.
    what : str
        What the file is, for the message ("job file", "spec file", ...).
    error : InputError subclass
        The error raised for a missing, unreadable or invalid file.
    """
    p = Path(path)
    if not p.is_file():
        raise error(f"{what} {str(p)!r} does not exist.", "Check the path.")
    try:
        with p.open("rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{p.name} is not valid TOML: {exc}.", "Fix the line it names.") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{p} cannot be read ({exc}).", "Check the file.") from None
