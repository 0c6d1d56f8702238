"""Independent cases of a comparison, run in process, on a local process pool or on a Dask cluster.

A comparison of paths (:func:`~polishpath.simulate.compare.compare_planned`)
is a grid of independent cases: every (path, seed) pair is one simulated
removal judged by the fair metrics, and every distinct planned path needs its
machine timing once. Each case here is a frozen, picklable description of all
it needs (the path's arrays, the recipe of the seed's initial surface, the tool,
the process, its own seed); running it is a pure function of it, so a case gives
the same bytes wherever it runs. :func:`run_cases` maps such a function over the
cases and hands the results back **in case order**, whatever the spread:

* ``workers=1``: one after another in this process;
* ``workers=N`` (default: every core this process may use): a
  :class:`concurrent.futures.ProcessPoolExecutor` (no server; forked
  workers on Linux, spawned elsewhere);
* ``scheduler="tcp://host:8786"``: the workers of a running Dask cluster
  (``dask scheduler`` / ``dask worker``, docs/simulation.md), through
  ``dask.distributed`` (the optional extra ``dask``, imported only then).

Why not a home-made queue: the local pool is the standard library's, and the
cluster is Dask's; only the case descriptions and their order are ours.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence, TypeVar

import numpy as np

from ..defaults import DEFAULT_CASE_WORKERS, SCHEDULER_TIMEOUT_S
from ..errors import ParameterError, SchedulerError, require

__all__ = ["Case", "CaseRunner", "CaseResult", "Start", "TimingCase", "available_cores", "available_memory",
           "run_cases", "run_timing", "workers_for_memory"]

T = TypeVar("T")
R = TypeVar("R")


def available_cores() -> int:
    """How many cores this process may run on (its CPU affinity where the system tells it)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def available_memory() -> int:
    """Bytes of memory available to new processes now (``MemAvailable`` of /proc/meminfo on Linux: free memory
    plus the caches the kernel can drop; elsewhere the free pages ``os.sysconf`` reports)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:  # pragma: no cover - not Linux
        pass
    try:  # pragma: no cover - not Linux
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):  # pragma: no cover
        return 2**62  # unknown: no cap


def workers_for_memory(case_bytes: int, available: int | None = None) -> int:
    """How many cases of ``case_bytes`` peak bytes each fit at once in ``available`` bytes (default
    :func:`available_memory`), keeping :data:`~polishpath.defaults.CASE_MEMORY_RESERVE` of it for the calling
    process and the rest of the machine; at least 1."""
    from ..defaults import CASE_MEMORY_RESERVE

    avail = available_memory() if available is None else int(available)
    return max(1, int((avail * (1.0 - CASE_MEMORY_RESERVE)) // max(int(case_bytes), 1)))


@dataclass(frozen=True)
class CaseRunner:
    """Where the cases of a comparison run.

    Parameters
    ----------
    workers : int, optional
        Local worker processes; 1 runs every case in this process; None: every
        available core (:func:`available_cores`). Ignored with ``scheduler``.
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:8786``, or a LocalCluster's
        ``scheduler_address``): the cases run on its workers.
    """

    workers: int | None = DEFAULT_CASE_WORKERS
    scheduler: str | None = None

    def __post_init__(self):
        w = self.workers
        if w is not None and (isinstance(w, bool) or not isinstance(w, (int, np.integer)) or w < 1):
            raise ParameterError(f"the number of workers must be a whole number >= 1, got {w!r}.",
                                 "Use e.g. --workers 2 (1 runs every case in this process; leave it out for "
                                 "every core).")
        s = self.scheduler
        if s is not None and (not isinstance(s, str) or not s.strip()):
            raise ParameterError(f"the scheduler address must be a non-empty string, got {s!r}.",
                                 "Give the Dask scheduler's address, e.g. --scheduler tcp://host:8786.")

    def n_workers(self, n_cases: int, case_bytes: int | None = None) -> int:
        """Local processes used for ``n_cases`` cases (at most one per case).

        With the default (``workers=None``: every core) and an estimate of one case's peak memory
        ``case_bytes``, no more workers than the memory available now holds
        (:func:`workers_for_memory`; a note on stderr says so when that is fewer than the cores).
        """
        n = max(1, min(int(self.workers or available_cores()), n_cases))
        if self.workers is None and case_bytes and n > 1:
            fit = workers_for_memory(case_bytes)
            if fit < n:
                from ..progress import warn

                warn(f"running {fit} case(s) at a time instead of {n} (one per core): one case needs about "
                     f"{case_bytes / 2**30:.1f} GB and {available_memory() / 2**30:.1f} GB of memory is available. "
                     "Use --workers N to choose.")
                n = fit
        return n

    def describe(self) -> str:
        return f"Dask scheduler {self.scheduler}" if self.scheduler else (
            f"{self.workers or available_cores()} local worker(s)")


def run_cases(fn: Callable[[T], R], cases: Sequence[T], runner: CaseRunner | None = None) -> list[R]:
    """``[fn(c) for c in cases]``, spread as ``runner`` says, the results in case order.

    Parameters
    ----------
    fn : callable
        A module-level (picklable) pure function of one case.
    cases : sequence
        Picklable case descriptions.
    runner : CaseRunner, optional
        Default: every available core.

    Returns
    -------
    list
        ``fn(case)`` for each case, in the order of ``cases``.

    Raises
    ------
    SchedulerError
        The Dask scheduler cannot be reached (exit 2 on the command line).
    """
    runner = runner or CaseRunner()
    cases = list(cases)
    if runner.scheduler:
        return _run_dask(fn, cases, runner.scheduler)
    n = runner.n_workers(len(cases), max((_peak_bytes(c) for c in cases), default=0))
    if n == 1:
        return [fn(c) for c in cases]
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    # fork where the system has it: the workers start with polishpath imported and its numba kernels compiled,
    # and a caller's script is not imported again (spawn / forkserver re-run an unguarded __main__). No
    # numba kernel of polishpath is parallel and pocketfft resets its threads at fork, so nothing forks a lock.
    ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
    with ProcessPoolExecutor(max_workers=n, mp_context=ctx) as ex:
        return list(ex.map(fn, cases))  # map keeps the order of its input


def _peak_bytes(case) -> int:
    """A case's estimate of its peak memory (its ``peak_bytes()``), 0 when it has none."""
    est = getattr(case, "peak_bytes", None)
    return int(est()) if callable(est) else 0


def _run_dask(fn, cases: list, address: str) -> list:
    distributed = require("distributed", "--scheduler (running the cases on a Dask cluster)", extra="dask")
    try:
        client = distributed.Client(address, timeout=SCHEDULER_TIMEOUT_S, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise SchedulerError(f"cannot reach the Dask scheduler at {address!r} ({type(exc).__name__}: {exc}).",
                             "Start one with `dask scheduler` (and `dask worker ADDRESS` on each machine), check "
                             "the address (tcp://host:8786), or leave --scheduler out to run on this machine's "
                             "cores.") from None
    try:
        futures = client.map(fn, cases, pure=False)
        return client.gather(futures)  # in the order of the futures, i.e. of the cases
    finally:
        client.close()


# --- the cases of a comparison -------------------------------------------------------------------


@dataclass(frozen=True)
class Start:
    """The initial surface of one seed, as a recipe (built where the case runs, not shipped as pixels).

    ``kind`` ``"flat"``: zero heights over ``bounds``; ``"synthetic"``: the
    power-law surface of :func:`~polishpath.simulate.workpiece.synthetic_workpiece`
    drawn with ``seed``; ``"given"``: ``workpiece`` as it is.
    """

    kind: str
    bounds: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    dx_mm: float = 0.0
    rms_nm: float = 0.0
    exponent: float = 0.0
    band_per_mm: tuple[float, float] = (0.2, 100.0)
    seed: int = 0
    workpiece: Any = None

    def build(self):
        """The :class:`~polishpath.simulate.workpiece.Workpiece` (heights nm on a dx_mm grid).

        The last recipe built in this process is kept: the paths of one seed share their start, so a worker
        that runs two of them draws it once (a Workpiece is read-only, so sharing it is safe), and what is
        derived from it and cached by identity (the smoothing spectrum, the PSD before) is reused too.
        """
        from .workpiece import flat_workpiece, synthetic_workpiece

        if self.kind not in ("flat", "synthetic"):
            return self.workpiece
        key = (self.kind, tuple(map(float, self.bounds)), float(self.dx_mm), float(self.rms_nm),
               float(self.exponent), tuple(map(float, self.band_per_mm)), int(self.seed))
        if _LAST_START and _LAST_START[0] == key:
            return _LAST_START[1]
        _LAST_START.clear()  # let the previous start go before drawing the next one
        if self.kind == "flat":
            wp = flat_workpiece(self.bounds, self.dx_mm)
        else:
            wp = synthetic_workpiece(self.bounds, self.dx_mm, rms_nm=self.rms_nm, exponent=self.exponent,
                                     band_per_mm=self.band_per_mm, seed=self.seed)
        _LAST_START[:] = [key, wp]
        return wp


#: the recipe and Workpiece of the last :meth:`Start.build` in this process
_LAST_START: list = []


@dataclass(frozen=True, eq=False)
class Case:
    """One path under one seed: everything :func:`~polishpath.simulate.compare.compare_paths` needs.

    Attributes
    ----------
    name : str
        The path's name (its row).
    seed : int
        The seed of this case's process noise (its start's recipe carries its own).
    path : tuple
        ``(xy (N, 2) mm, time_s (N,) s, pieces, time_model)`` as :func:`compare_paths` takes a path.
    start : Start
    tif, noise, smoothing :
        The tool and the process.
    options : dict
        The remaining keyword arguments of :func:`compare_paths` (band, eval_bounds, depth_nm ...).
    """

    name: str
    seed: int
    path: tuple
    start: Start
    tif: Any
    noise: Any
    smoothing: Any
    options: dict = field(default_factory=dict)


    def peak_bytes(self) -> int:
        """Estimated peak memory of running this case, bytes: a fixed part, a part per pixel of its patch and
        a part per fine path sample (half a pixel apart along the path), with the coefficients of
        :data:`polishpath.defaults.CASE_MEMORY_MODEL`, measured (benchmarks/bench_simulate_speed.py)."""
        from ..defaults import CASE_MEMORY_MODEL

        base, per_pixel, per_sample = CASE_MEMORY_MODEL
        st = self.start
        if st.kind in ("flat", "synthetic"):
            x0, y0, x1, y1 = map(float, st.bounds)
            dx = float(st.dx_mm)
            pixels = (np.floor((x1 - x0) / dx + 1e-9) + 1) * (np.floor((y1 - y0) / dx + 1e-9) + 1)
        else:
            dx = float(st.workpiece.dx_mm)
            pixels = float(np.prod(st.workpiece.shape))
        xy = np.asarray(self.path[0], dtype=np.float64)
        length = float(np.hypot(*np.diff(xy, axis=0).T).sum()) if len(xy) > 1 else 0.0
        samples = length / (dx / 2.0) + 2 * len(xy)
        return int(base + per_pixel * pixels + per_sample * samples)


@dataclass(frozen=True)
class CaseResult:
    """What one case gives back: its row, its PSDs (``"before"`` unless a flat start), its residual picture
    and the comparison's parameters as :func:`compare_paths` recorded them
    (:func:`polishpath.simulate.compare.run_case`)."""

    row: dict
    psds: dict
    picture: dict
    params: dict


@dataclass(frozen=True, eq=False)
class TimingCase:
    """One planned path's machine timing: ``xy`` (N, 2) mm, ``time_s`` (N,) s, ``pieces``, spacing mm, profile."""

    xy: np.ndarray
    time_s: np.ndarray
    pieces: np.ndarray
    spacing_mm: float
    machine: Any = None


def run_timing(case: TimingCase):
    """:func:`~polishpath.simulate.machinetime.machine_timed_path` of one path (a pure function of ``case``)."""
    from .machinetime import machine_timed_path

    return machine_timed_path(case.xy, case.time_s, case.pieces, spacing_mm=case.spacing_mm, machine=case.machine)
