"""The mechanisms of the removal model, each switched off on its own (issue 18, item 5).

A path comparison rests on five modelled effects; :class:`Mechanisms` says
which are on, so a reader can see which assumption decides a ranking
(docs/simulation.md, "Which mechanism decides"):

=============  ==========================================  ===========================================
name           on                                          off
=============  ==========================================  ===========================================
``footprint``  the rotating tool's footprint leans with    the footprint at zero feed (axisymmetric,
               each sample's feed velocity                 the same for every heading and speed)
``edge``       the tool's pressure profile as given        a smooth Gaussian pressure with the same
               (parabolic: a slope step at the rim)        pressure-weighted RMS radius
``smoothing``  the pad smooths existing error              pure Preston removal (``Smoothing`` None)
``noise``      process drift of the removal rate           no rate noise (``ProcessNoise`` None)
``slowdown``   the machine's timing (slow-downs at turns)  ideal timing (each dwell point's time spread
                                                           along the path at the asked feed)
=============  ==========================================  ===========================================

Nothing here changes the removal model itself: each switch swaps an input of
:func:`~polishpath.simulate.removal.simulate_removal` (the TIF, the noise, the
smoothing, the time model) for its neutral form.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Iterable

import numpy as np

from ..errors import ParameterError
from .rotating import RotatingToolTIF, rotating_tool_tif
from .tif import measured_tif

__all__ = ["MECHANISMS", "Mechanisms", "parse_mechanisms", "tool_with", "zero_feed_tif"]

#: the switchable mechanisms, in the order of the docs' table
MECHANISMS = ("footprint", "edge", "smoothing", "noise", "slowdown")

#: a smooth pressure profile's 1/e^2 radius per contact radius: exp(-2 r^2/a^2) has <r^2> = a^2/2, the
#: parabolic 1 - r^2/R^2 has <r^2> = R^2/3 (pressure-weighted), equal for a = R sqrt(2/3)
_GAUSSIAN_PER_CONTACT = float(np.sqrt(2.0 / 3.0))


@dataclass(frozen=True)
class Mechanisms:
    """Which effects of the removal model are on (all by default).

    Attributes
    ----------
    footprint : bool
        Feed-dependent rotating footprint (off: the footprint at zero feed).
    edge : bool
        The pressure profile as given (off: a smooth Gaussian pressure).
    smoothing : bool
        Pad smoothing of existing error.
    noise : bool
        Process drift (removal-rate noise).
    slowdown : bool
        Kinematic slow-down: the machine's own timing (off: ideal timing).
    """

    footprint: bool = True
    edge: bool = True
    smoothing: bool = True
    noise: bool = True
    slowdown: bool = True

    @property
    def off(self) -> tuple[str, ...]:
        """Names of the mechanisms switched off, in :data:`MECHANISMS` order."""
        return tuple(n for n in MECHANISMS if not getattr(self, n))

    def without(self, names: Iterable[str]) -> "Mechanisms":
        """These mechanisms with ``names`` switched off."""
        names = list(names)
        bad = [n for n in names if n not in MECHANISMS]
        if bad:
            raise ParameterError(f"unknown mechanism(s) {', '.join(map(repr, bad))}.",
                                 f"Switch off any of: {', '.join(MECHANISMS)}.")
        return dataclasses.replace(self, **{n: False for n in names})

    def to_dict(self) -> dict[str, Any]:
        return {"on": [n for n in MECHANISMS if getattr(self, n)], "off": list(self.off)}


def parse_mechanisms(text: str | None) -> Mechanisms:
    """Mechanisms from a comma-separated list of those to switch off (``--without smoothing,noise``)."""
    if text is None or not text.strip():
        return Mechanisms()
    return Mechanisms().without(n.strip() for n in text.split(",") if n.strip())


def zero_feed_tif(tif: RotatingToolTIF, dx_mm: float):
    """The rotating tool's footprint at zero feed as a plain TIF on a grid of ``dx_mm``, same volume rate.

    Its rate is scaled so it removes the volume per second the tool removes at its
    nominal feed: only the shape of the footprint changes, not the time scale.
    """
    k = tif.kernel_at(dx_mm, (0.0, 0.0))
    vol = float(k.sum()) * dx_mm * dx_mm
    if not vol > 0:
        raise ParameterError("the tool's footprint at zero feed removes nothing.", "Use a tool with a rate > 0.")
    out = measured_tif(k * (tif.volume_rate / vol), dx_mm)
    return dataclasses.replace(out, params={**out.params, "from": "rotating tool at zero feed",
                                             "rotating": dict(tif.params)})


def smooth_edge_tif(tif: RotatingToolTIF) -> RotatingToolTIF:
    """The same rotating tool with a Gaussian pressure of the same pressure-weighted RMS radius (no edge)."""
    if tif.pressure == "gaussian":
        return tif
    a = tif.contact_radius_mm * _GAUSSIAN_PER_CONTACT
    new = rotating_tool_tif(tif.rpm, a, "gaussian", peak_rate_nm_s=tif.peak_rate_nm_s, feed_mm_min=tif.feed_mm_min)
    return new.scaled(tif.volume_rate / new.volume_rate)


def tool_with(tif, mechanisms: Mechanisms, dx_mm: float):
    """The tool of a comparison with ``edge`` / ``footprint`` switched off as ``mechanisms`` says.

    Other TIFs than a :class:`RotatingToolTIF` have neither a feed-dependent
    footprint nor a modelled pressure edge and are returned as they are.
    """
    if not isinstance(tif, RotatingToolTIF):
        return tif
    if not mechanisms.edge:
        tif = smooth_edge_tif(tif)
    if not mechanisms.footprint:
        return zero_feed_tif(tif, dx_mm)
    return tif
