"""Checks of what callers hand to the planning stage.

Every public function of :mod:`polishpath.plan` checks its input with these
helpers, so bad input is a :class:`~polishpath.errors.ParameterError` whose
message names the argument and says what to pass, never a numpy or numba
error from deep inside. Seeds follow the program's one rule,
:func:`polishpath.provenance.resolve_seed`.
"""

from __future__ import annotations

import numbers

import numpy as np

from ..errors import ParameterError
from ..provenance import SEED_LIMIT, resolve_seed
from ..types import Region


def check_seed(seed) -> int:
    """``seed`` checked by :func:`polishpath.provenance.resolve_seed`, which must not be None here.

    For the functions that take a seed but record no provenance (the order
    functions and sequences): drawing one there would give a path that cannot
    be reproduced, so None is refused; :func:`polishpath.plan.plan` draws and
    records one.
    """
    if seed is None:
        raise ParameterError("seed must be a whole number 0 <= seed < 2**63, got None.",
                             "Pass a seed (polishpath.plan.plan draws and records one when it is left out).")
    return resolve_seed(seed)


def check_region(region) -> Region:
    """``region`` when it is a :class:`~polishpath.types.Region`, else :class:`ParameterError`."""
    if not isinstance(region, Region):
        raise ParameterError(
            f"The region must be a polishpath.types.Region, got {type(region).__name__}.",
            "Build one with Region(outer, holes) from the boundary polygon(s) in mm, or take "
            "polishpath.flatten.boundary_region(flattening).",
        )
    return region


def check_number(value, name: str, *, low: float | None = None, positive: bool = False, unit: str = "") -> float:
    """``value`` as a finite float, at least ``low`` (or > 0 when ``positive``), else :class:`ParameterError`."""
    what = f"{name} must be a finite number" + (f" of {unit}" if unit else "")
    if positive:
        what += " > 0"
    elif low is not None:
        what += f" >= {low:g}"
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = float("nan")
    if isinstance(value, (bool, np.bool_, str)) or not np.isfinite(x) or (positive and x <= 0) or (
            low is not None and x < low):
        bound = " > 0" if positive else (f" >= {low:g}" if low is not None else "")
        raise ParameterError(f"{what}, got {value!r}.", f"Pass a number{bound}{' in ' + unit if unit else ''}.")
    return x


def check_count(value, name: str, *, low: int = 0, high: int = SEED_LIMIT - 1) -> int:
    """``value`` as an int in [low, high], else :class:`ParameterError`."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) or not low <= value <= high:
        raise ParameterError(f"{name} must be a whole number from {low} to {high}, got {value!r}.",
                             "Pass an integer in that range.")
    return int(value)


def check_point(value, name: str) -> np.ndarray:
    """``value`` as a finite (2,) float64 point (mm), else :class:`ParameterError`."""
    try:
        p = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        p = np.zeros(0)
    if p.size != 2 or not np.isfinite(p).all():
        raise ParameterError(f"{name} must be a point (u, v) of two finite numbers in mm, got {value!r}.",
                             "Pass two numbers, e.g. (0.0, 0.0).")
    return p.reshape(2)


def check_points(value, name: str, cols: int | tuple[int, ...] = 2) -> np.ndarray:
    """``value`` as a finite (k, cols) float64 array, else :class:`ParameterError`."""
    allowed = (cols,) if isinstance(cols, int) else cols
    shape = " or ".join(f"(k, {c})" for c in allowed)
    try:
        p = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a {shape} array of numbers, got {type(value).__name__}.",
                             f"Pass one row per point, {shape}.") from None
    if p.ndim != 2 or p.shape[1] not in allowed or not np.isfinite(p).all():
        got = f"shape {p.shape}" if p.ndim != 2 or p.shape[1] not in allowed else "NaN or infinite values"
        raise ParameterError(f"{name} must be a {shape} array of finite numbers, got {got}.",
                             f"Pass one row per point, {shape}.")
    return p


def check_index(value, name: str, n: int) -> int:
    """``value`` as a dwell-point number in [0, n), else :class:`ParameterError`."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) or not 0 <= value < n:
        raise ParameterError(f"{name} must be a dwell-point number from 0 to {n - 1}, got {value!r}.",
                             "Use polishpath.plan.nearest_dwell_point(grid, point) to find one.")
    return int(value)


def check_options(pattern: str, options: dict, accepted) -> None:
    """:class:`ParameterError` when ``options`` holds a name the pattern does not take."""
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        takes = f"it takes {', '.join(sorted(accepted))}" if accepted else "it takes none"
        raise ParameterError(f"Pattern {pattern!r} takes no option(s) {', '.join(unknown)}.",
                             f"Remove them ({takes}).")
