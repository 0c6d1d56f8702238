"""Reproduce the paper in one command: its four tables and its figures, beside ours.

:func:`reproduce` re-runs, on this machine, every experiment of Wang et al.,
*A mid-high spatial frequency error suppression method based on the
pseudo-random path with space MABF mapping for complex surface* that software
can repeat, and writes

* ``OUT/paper.md`` — the tables (ours beside the paper's numbers) and the
  figures, linked relatively (``figures/*.png``);
* ``OUT/paper.html`` — the same, one self-contained file (figures embedded as
  PNG data URIs, nothing fetched from the network);
* ``OUT/figures/*.png`` — every figure, each stamped with the machine
  (``platform.node()``, processor, CPU count), the polishpath version and the seed.

What is reproduced: Table 1 (ABF vs MABF time and angle error, LSCM as the
peer), Figs. 2-3 (constraint residuals, flattened hemisphere), Table 2 and
Fig. 9 (projection vs MABF mapping on the hemisphere), Table 3 and Fig. 8
(the peer pseudo-random paths, measured), Table 4 and Fig. 13 (simulated
suppression ratios; the paper's are measured on glass), Figs. 5-7 (bicycle
seat) and Fig. 10 (the paper's cases, including a patch of the shared
Stanford bunny). Units: mm, s, degrees.

``quick=True`` is the reduced setting used in CI (small meshes, coarse
spacing, small simulation patch, ABF only on the smallest case).

Modules: :mod:`.reference` (the paper's published numbers), :mod:`.settings`
(sizes of every experiment, the shared meshes folder), one module per table
(:mod:`.table1` ... :mod:`.table4`; :mod:`.table3` is also where
``benchmarks/table3.py`` measures), :mod:`.cases` (Figs. 5-7 and 10),
:mod:`.figures` (stamped figures, path drawings), :mod:`.run` (the document,
written through :class:`polishpath.report.html.Document`).
"""

from __future__ import annotations

from .common import machine_info
from .reference import PAPER, TABLE3_NAMES
from .run import is_paper_folder, reproduce
from .settings import MESHES_ENV, Settings, meshes_folder, settings_for

__all__ = ["MESHES_ENV", "PAPER", "TABLE3_NAMES", "Settings", "is_paper_folder", "machine_info", "meshes_folder", "reproduce",
           "settings_for"]
