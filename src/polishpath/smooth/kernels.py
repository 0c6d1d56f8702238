"""The integrator kernels by name and a curve as the kernels take it: what the interpolator and the sample
stream share.

:mod:`.interpolate` (the interpolation of a piece, with its schedule passes) and :mod:`.samples` (the
samples regenerated chunk by chunk from a :class:`~polishpath.types.SampleSchedule`) both look a kernel up
by its integrator name and hand it the curve's spans and bend bounds; both take them from here, below
them, so neither imports the other (no import circle, ``tests/test_architecture.py``).

Units: mm (the curve's coordinates).
"""

from __future__ import annotations

import weakref
from typing import NamedTuple

import numpy as np

from ..errors import ParameterError, SmoothingError
from ..types import NurbsCurve
from .abam import abam_kernel
from .nurbs import span_polynomials
from .spans import DIM, span_bend_bounds
from .taylor import taylor_kernel, taylor_schedule_kernel

__all__ = ["INTEGRATORS", "SCHEDULING_KERNELS", "integrator_kernel", "KernelCurve", "kernel_curve"]

INTEGRATORS = {"taylor": taylor_kernel, "ab-am": abam_kernel}
"""Name -> compiled kernel; every kernel takes and returns the same arrays (see :func:`.taylor.taylor_kernel`).
The job's option lists the same names (``polishpath.defaults.INTEGRATOR_NAMES``, checked by a test)."""

SCHEDULING_KERNELS = {"taylor": taylor_schedule_kernel}
"""Integrators whose kernel also finds the dwell regions' feeds as it runs (one pass over the path plus
the regions it runs again, :func:`.taylor.taylor_schedule_kernel`); the others run whole schedule passes."""


def integrator_kernel(name: str):
    """The compiled kernel of an integrator name; :class:`ParameterError` naming the choices otherwise."""
    if name not in INTEGRATORS:
        raise ParameterError(f"integrator must be one of {', '.join(map(repr, INTEGRATORS))}, got {name!r}.",
                             "Use 'taylor' (Taylor predictor + exact chord corrector) or 'ab-am' "
                             "(the paper's Adams-Bashforth / Adams-Moulton).")
    return INTEGRATORS[name]


def _kernel_coeffs(curve: NurbsCurve) -> tuple[np.ndarray, np.ndarray, int]:
    """Span breaks and coefficients with :data:`.spans.DIM` = 3 coordinates (a planar curve gets z = 0), and d."""
    breaks, coeffs, _ = span_polynomials(curve)
    d = coeffs.shape[2] - 1
    if d > DIM:
        raise SmoothingError(f"Constant-period interpolation runs curves in up to {DIM} dimensions, got {d}.",
                             "Give the curve's x, y (and z) coordinates only.")
    if d < DIM:
        padded = np.zeros(coeffs.shape[:2] + (DIM + 1,))
        padded[:, :, :d] = coeffs[:, :, :d]
        padded[:, :, DIM] = coeffs[:, :, d]
        coeffs = padded
    return breaks, np.ascontiguousarray(coeffs), d


class KernelCurve(NamedTuple):
    """A curve as the kernels take it: spans, 3-coordinate coefficients, bend bounds, size; ``d`` its own coordinates."""

    breaks: np.ndarray
    coeffs: np.ndarray
    bends: np.ndarray
    size: float
    d: int


def kernel_curve(curve: NurbsCurve) -> KernelCurve:
    """The curve's spans and their bend bounds for the kernels (:func:`.spans.span_bend_bounds`), once per curve."""
    hit = _KC_CACHE.get(id(curve))
    if hit is not None and hit[0]() is curve:
        return hit[1]
    breaks, coeffs, d = _kernel_coeffs(curve)
    bends, size = span_bend_bounds(breaks, coeffs)
    kc = KernelCurve(breaks, coeffs, bends, float(size), d)
    _KC_CACHE[id(curve)] = (weakref.ref(curve), kc)
    # dropped with the curve; not at exit (a signal then would print a traceback from the finalizer)
    weakref.finalize(curve, _KC_CACHE.pop, id(curve), None).atexit = False
    return kc


_KC_CACHE: dict = {}
