"""What the report draws of the machine samples, gathered in one pass over them, however they come.

A job of 10^7 dwell points has about 1.5 x 10^8 machine samples; the report
draws at most :data:`MAX_SAMPLES_SHOWN` of them (the 3D view's smoothed curve)
and the feed as a min / max / mean envelope of :data:`FEED_BINS` bins. The job
gathers exactly that while its writers stream the samples
(:class:`SampleDigest`, fed the same chunks as the writers, whether the samples
are held or regenerated) and stores it in ``run.npz`` (:data:`DIGEST_KEYS`),
so the report never needs the samples and a streamed run's report equals an
in-memory run's.

The digest does not depend on how the samples are cut into chunks: the shown
samples are picked by their index, the bins' extremes are exact, and the bins'
sums are accumulated in integers (each feed rounded to :data:`FEED_QUANTUM`
mm/min first), which add in any order to the same total. The means are for
display; the machine files hold every feed.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import Any

import numpy as np

from .rundata import decimate_indices

#: smoothed-curve samples the report's 3D view draws at most
MAX_SAMPLES_SHOWN = 20_000
#: bins of the feed envelope (a path of at most twice as many samples keeps every feed, one bin each)
FEED_BINS = 2000
#: fixed point of the bins' feed sums, mm/min: 2^-20 (1e-6 mm/min), sums exact up to 10^12 samples per bin
FEED_QUANTUM = 2.0**-20

#: the ``run.npz`` keys of a digest (docs/run-folder.md)
DIGEST_KEYS = ("display_sample_index", "display_samples", "feed_bins", "feed_envelope")


def feed_bin_edges(n_samples: int) -> np.ndarray:
    """(B + 1,) sample offsets of the feed bins: one sample each up to ``2 FEED_BINS`` samples, else ``FEED_BINS`` bins."""
    if n_samples <= 2 * FEED_BINS:
        return np.arange(n_samples + 1, dtype=np.int64)
    return np.linspace(0, n_samples, FEED_BINS + 1).astype(np.int64)


class SampleDigest:
    """The report's share of ``n_samples`` machine samples, added chunk by chunk in path order.

    Parameters
    ----------
    n_samples : int
        How many samples will come (the schedule's count).

    Use :meth:`observe` around the writers' chunk iterable (or :meth:`add` each
    chunk), then :meth:`arrays` for ``run.npz``.
    """

    def __init__(self, n_samples: int) -> None:
        self.n = int(n_samples)
        self.index = decimate_indices(self.n, MAX_SAMPLES_SHOWN)
        self.shown = np.full((len(self.index), 3), np.nan)
        self.edges = feed_bin_edges(self.n)
        nb = len(self.edges) - 1
        self.lo = np.full(nb, np.inf)
        self.hi = np.full(nb, -np.inf)
        self.qsum = np.zeros(nb, dtype=np.int64)
        self.done = 0

    def add(self, chunk) -> None:
        """Take the next ``chunk`` (``samples`` (m, 3) mm, ``feed_mm_min`` (m,) mm/min: a SampleChunk)."""
        a, m = self.done, len(chunk.samples)
        b = a + m
        if b > self.n:
            raise ValueError(f"the digest expected {self.n} samples; more came.")
        i0, i1 = np.searchsorted(self.index, [a, b])
        self.shown[i0:i1] = chunk.samples[self.index[i0:i1] - a]
        # the bins this chunk touches, and where in the chunk each begins
        k0 = int(np.searchsorted(self.edges, a, side="right")) - 1
        k1 = int(np.searchsorted(self.edges, b - 1, side="right")) - 1
        ks = np.arange(k0, k1 + 1)
        starts = np.maximum(self.edges[ks], a) - a
        f = np.asarray(chunk.feed_mm_min, dtype=np.float64)
        self.lo[ks] = np.minimum(self.lo[ks], np.minimum.reduceat(f, starts))
        self.hi[ks] = np.maximum(self.hi[ks], np.maximum.reduceat(f, starts))
        self.qsum[ks] += np.add.reduceat(np.rint(f / FEED_QUANTUM).astype(np.int64), starts)
        self.done = b

    def observe(self, chunks: Iterable) -> Iterator:
        """The chunks of ``chunks``, each added to the digest as it passes."""
        for c in chunks:
            self.add(c)
            yield c

    def arrays(self) -> dict[str, np.ndarray]:
        """The digest as ``run.npz`` arrays (:data:`DIGEST_KEYS`); refuses a digest short of its samples."""
        if self.done != self.n:
            raise ValueError(f"the digest has {self.done} of its {self.n} samples.")
        counts = np.diff(self.edges)
        mean = self.qsum.astype(np.float64) * FEED_QUANTUM / np.maximum(counts, 1)
        return {"display_sample_index": self.index, "display_samples": self.shown, "feed_bins": self.edges,
                "feed_envelope": np.column_stack([self.lo, self.hi, mean])}


def digest_of(samples: np.ndarray | None, feed_mm_min: np.ndarray, size: int = 1 << 20) -> dict[str, np.ndarray]:
    """The digest of samples held in memory (a run folder of format 1 stores them all); without
    ``samples`` (an old folder that lacks them) the feed only, and no sample shown."""
    from types import SimpleNamespace

    n = len(feed_mm_min)
    d = SampleDigest(n)
    if samples is None:
        d.index = d.index[:0]
        d.shown = d.shown[:0]
        samples = np.broadcast_to(np.zeros(3), (n, 3))  # no memory: none of it is picked
    for a in range(0, n, size):
        d.add(SimpleNamespace(samples=samples[a:a + size], feed_mm_min=feed_mm_min[a:a + size]))
    return d.arrays()


def run_digest(run) -> dict[str, Any] | None:
    """The digest of a run folder (a :class:`~polishpath.runfolder.RunData`): stored in its ``run.npz``
    (format 2), else made from its samples (format 1, once per RunData: kept on it), else None."""
    arrays = run.arrays
    if all(k in arrays for k in DIGEST_KEYS):
        return {k: np.asarray(arrays[k]) for k in DIGEST_KEYS}
    cached = run.__dict__.get("_sample_digest")  # RunData is frozen: a format-1 digest is kept beside its fields
    if cached is not None:
        return cached or None
    s, f = arrays.get("samples"), arrays.get("feed_mm_min")
    d = {}
    if f is not None and len(f) > 0:
        if np.ndim(f) != 1 or (s is not None and np.shape(s) != (len(f), 3)):
            raise ValueError(f"run.npz holds feed_mm_min of shape {np.shape(f)} and samples of shape "
                             f"{np.shape(s) if s is not None else None}: expected (M,) and (M, 3)")
        d = digest_of(None if s is None else np.asarray(s), np.asarray(f))
    object.__setattr__(run, "_sample_digest", d)
    return d or None
