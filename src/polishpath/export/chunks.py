"""Machine samples in chunks: what a streamed job hands the writers (issue 15, item 4).

A job that cannot hold every machine sample of a multi-day path (10^7 dwell
points: ~1.5 x 10^8 samples) gives the writers its samples as an iterable of
:class:`SampleChunk` s, each a run of consecutive samples of one piece, and a
:class:`~polishpath.types.ToolPath` whose sample arrays are not read (they may
be empty): the writers take the curve, the dwell points and their parameters,
the pieces and the provenance from it. The writers produce the same bytes
whatever the chunk sizes; :func:`sample_chunks` cuts an in-memory ToolPath into
chunks (the in-memory writers use it).

Contract of the iterable: chunks in path order; each chunk within one piece;
pieces in order (``piece`` 0, 1, ...; a piece without samples may be left
out), each piece's first chunk starting at its first sample (a new ``piece``
value starts a new piece); every chunk at least one sample.
"""

from __future__ import annotations

from typing import Iterable, Iterator

import numpy as np

from ..axes import axes_at_params, interpolate_units
from ..errors import ExportError
from ..types import SampleChunk, ToolPath  # SampleChunk lives in the core; re-exported here

__all__ = ["SampleChunk", "sample_chunks", "piece_offsets", "dwell_offsets", "normals_at", "axes_at",
           "DEFAULT_CHUNK_SAMPLES"]

#: samples per chunk when the in-memory writers cut a ToolPath (about 12 MB of arrays)
DEFAULT_CHUNK_SAMPLES = 1 << 18


def piece_offsets(tool_path: ToolPath) -> np.ndarray:
    """(P + 1,) sample offsets of the pieces (``ToolPath.sample_pieces``)."""
    return tool_path.sample_pieces


def dwell_offsets(tool_path: ToolPath) -> np.ndarray:
    """(P + 1,) dwell-point offsets of the pieces (the planar path's pieces, else one piece)."""
    sp = tool_path.surface_path
    n = len(sp.xyz)
    if sp.planar is not None and len(sp.planar.pieces) >= 2 and sp.planar.pieces[-1] == n:
        return np.asarray(sp.planar.pieces, dtype=np.int64)
    return np.array([0, n], dtype=np.int64)


def sample_chunks(tool_path: ToolPath, size: int = DEFAULT_CHUNK_SAMPLES) -> Iterator[SampleChunk]:
    """The ToolPath's samples as chunks of at most ``size`` samples, cut at every piece."""
    if size < 1:
        raise ExportError(f"chunk size must be >= 1 sample, got {size}.")
    off = piece_offsets(tool_path)
    ax = tool_path.sample_axes
    for k, (a, b) in enumerate(zip(off[:-1], off[1:])):
        for c in range(int(a), int(b), size):
            e = min(c + size, int(b))
            yield SampleChunk(tool_path.samples[c:e], tool_path.sample_params[c:e], tool_path.feed_mm_min[c:e], k,
                              None if ax is None else ax[c:e])


def checked_chunks(chunks: Iterable[SampleChunk], n_pieces: int) -> Iterator[tuple[bool, SampleChunk]]:
    """``(starts_piece, chunk)`` for each chunk, refusing an iterable that breaks the contract."""
    current = -1
    for c in chunks:
        if not isinstance(c, SampleChunk):
            raise ExportError(f"The writers take SampleChunk objects, got {type(c).__name__}.")
        if c.piece != current:
            if c.piece < current or c.piece >= n_pieces:  # a piece without samples may be left out
                raise ExportError(f"Chunk of piece {c.piece} after piece {current}: pieces must come in order "
                                  f"0..{n_pieces - 1}, each once.")
            current = c.piece
            yield True, c
        else:
            yield False, c


def normals_at(tool_path: ToolPath, params: np.ndarray) -> np.ndarray:
    """Unit surface normals at curve parameters, (m, 3): as :func:`polishpath.smooth.sample_normals` does for samples.

    Linear in the parameter between the two neighbouring dwell points' normals, then normalised.
    """
    return interpolate_units(params, tool_path.dwell_params, tool_path.surface_path.normals)


def axes_at(tool_path: ToolPath, params: np.ndarray) -> np.ndarray | None:
    """Unit tool axes at curve parameters, (m, 3): the path's tool-axis law at the normals :func:`normals_at`
    interpolates (:func:`polishpath.axes.axes_at_params`); None for a 3-axis job."""
    return axes_at_params(tool_path.surface_path, tool_path.dwell_params, params)
