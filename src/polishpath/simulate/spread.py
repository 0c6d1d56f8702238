"""Figures over seeds: mean and range of each path's metrics, and rankings that say when paths tie.

A comparison of paths runs every random input (the pseudo-random planner's
seed, the initial surface, the process noise) over N seeds; a figure is then
its mean with its range [min, max] over the seeds, and two paths whose ranges
overlap are *not distinguishable* by that figure: the ranking groups them.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

__all__ = ["FAIR_KEYS", "LOWER_IS_BETTER", "aggregate_rows", "rank", "spread"]

#: the per-row figures reported with their spread (``<key>``, ``<key>_min``, ``<key>_max``)
FAIR_KEYS = ("residual_band_rms_nm", "lattice_peak_db", "pvn", "suppression_ratio")
#: further per-row figures averaged over the seeds (no spread columns)
MEAN_KEYS = ("residual_rms_nm", "residual_pv_nm", "before", "after", "band_rms_before_nm", "band_rms_after_nm",
             "mean_depth_nm", "total_time_s", "machine_time_s", "effective_time_s", "time_off_grid_s", "n_points",
             "time_density_peak_db")
#: which way is better for each ranked figure
LOWER_IS_BETTER = {"residual_band_rms_nm": True, "lattice_peak_db": True, "pvn": True, "suppression_ratio": False}


def spread(values: Sequence[float | None]) -> tuple[float | None, float | None, float | None]:
    """(mean, min, max) of the values; all None when any is None (a figure undefined for a seed)."""
    if not len(values) or any(v is None for v in values):
        return None, None, None
    a = np.asarray(values, dtype=np.float64)
    return float(a.mean()), float(a.min()), float(a.max())


def aggregate_rows(per_seed: list[list[dict[str, Any]]], seeds: Sequence[int]) -> list[dict[str, Any]]:
    """One row per path from the rows of every seed (the same paths, in the same order, in each).

    Each :data:`FAIR_KEYS` figure becomes ``<key>`` (the mean), ``<key>_min`` and
    ``<key>_max``; :data:`MEAN_KEYS` are averaged; everything else is the
    first seed's. ``seeds`` and ``per_seed`` (the rows' fair figures per seed)
    are recorded.
    """
    out = []
    for j, first in enumerate(per_seed[0]):
        rows = [ps[j] for ps in per_seed]
        row = dict(first)
        for k in FAIR_KEYS:
            m, lo, hi = spread([r.get(k) for r in rows])
            row[k], row[f"{k}_min"], row[f"{k}_max"] = m, lo, hi
        for k in MEAN_KEYS:
            if k in first:
                row[k] = spread([r.get(k) for r in rows])[0]
        row["seconds"] = float(sum(r.get("seconds", 0.0) for r in rows))
        row["seeds"] = list(seeds)
        row["per_seed"] = [{"seed": s, **{k: r.get(k) for k in FAIR_KEYS}} for s, r in zip(seeds, rows)]
        out.append(row)
    return out


def rank(rows: list[dict[str, Any]], key: str) -> dict[str, Any]:
    """Rank paths by a figure's mean, grouping those whose [min, max] ranges overlap.

    Returns
    -------
    dict
        ``key``, ``better`` ("lower" / "higher"), ``order`` (names, best first),
        ``groups`` (lists of names; paths in one group are not distinguishable:
        each one's range overlaps the group's), ``text`` (e.g. ``spiral >
        [rectangular ~ pseudorandom] > raster``) or None when the figure is
        undefined (``text`` says so).
    """
    low = LOWER_IS_BETTER.get(key, True)
    have = [r for r in rows if r.get(key) is not None]
    if not have:
        return {"key": key, "better": "lower" if low else "higher", "order": [], "groups": [],
                "text": "undefined (no value)"}
    sign = 1.0 if low else -1.0
    srt = sorted(have, key=lambda r: sign * r[key])
    groups: list[list[dict]] = []
    for r in srt:
        lo, hi = r.get(f"{key}_min", r[key]), r.get(f"{key}_max", r[key])
        if groups:
            g = groups[-1]
            # ranges overlap the group's envelope: not distinguishable from it
            if lo <= max(x.get(f"{key}_max", x[key]) for x in g) and hi >= min(x.get(f"{key}_min", x[key]) for x in g):
                g.append(r)
                continue
        groups.append([r])
    names = [[r["name"] for r in g] for g in groups]
    text = " > ".join(g[0] if len(g) == 1 else "[" + " ~ ".join(g) + "]" for g in names)
    return {"key": key, "better": "lower" if low else "higher", "order": [r["name"] for r in srt], "groups": names,
            "text": text}
