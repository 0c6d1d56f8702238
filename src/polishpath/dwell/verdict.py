"""Whether a figuring program may be written: its minimum-removal floor and its predicted residual.

A dwell point can never get less than the time the path takes through its
region at the machine's top feed, so the minimum times alone remove a *floor*
(nm) everywhere: top feed x TIF x spacing. When that floor is larger than the
whole error (its PV, the deepest removal it needs), the program spends its time
removing material uniformly and its unevenness (the part's edge, the path's
turns, each time delivered a few % off) ends in the residual: a metre-class
mirror at 30 nm/s came out predicted 40 nm RMS from 25.9 nm (issue 28). The
job refuses such a program, and one predicted to leave the part worse, unless
forced (:func:`refusal_for_floor`, :func:`refusal_for_prediction`); the message
gives the floor, its cause and the parameters that would work, computed by
re-solving (:class:`FloorAdvice`).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..defaults import FIGURING_FLOOR_ADVICE_SHARE, FIGURING_FLOOR_MAX_SHARE


@dataclass(frozen=True)
class FloorAdvice:
    """Parameters with which the floor falls to :data:`~polishpath.defaults.FIGURING_FLOOR_ADVICE_SHARE` of the
    error's PV.

    Attributes
    ----------
    scale : float
        The advised floor over today's (< 1).
    floor_nm : float
        The advised floor, nm.
    peak_rate_nm_s : float
        Largest TIF peak rate, nm/s: exact (the removal is proportional to the rate).
    max_feed_mm_min : float
        Least top feed, mm/min: about (the minimum times go as 1 / feed where the path's turns do not slow it;
        that part alone is scaled), NaN when the turns' part of the floor is already above the advised floor.
    spacing_mm : float
        Least spacing, mm: about (the floor goes as 1 / spacing), or NaN when that spacing would no longer
        resolve the TIF (above a third of its reach).
    model_residual_rms_nm, model_residual_pv_nm : float
        The solver's model's residual with the advised peak rate (re-solved), nm over the clear aperture.
    """

    scale: float
    floor_nm: float
    peak_rate_nm_s: float
    max_feed_mm_min: float
    spacing_mm: float
    model_residual_rms_nm: float
    model_residual_pv_nm: float

    def to_dict(self) -> dict:
        """JSON-ready (NaN: None)."""
        return {k: (None if v != v else v) for k, v in self.__dict__.items()}

    def text(self, initial_rms_nm: float) -> str:
        alts = []
        if self.max_feed_mm_min == self.max_feed_mm_min:  # not NaN
            alts.append(f"a top feed of at least {self.max_feed_mm_min:.4g} mm/min ([error_map] max_feed_mm_min)")
        if self.spacing_mm == self.spacing_mm:
            alts.append(f"a spacing of at least {self.spacing_mm:.3g} mm")
        alt = (", or about " + " or ".join(alts)) if alts else ""
        return (f"Parameters that would work (a floor of {self.floor_nm:.3g} nm): a TIF peak rate of at most "
                f"{self.peak_rate_nm_s:.3g} nm/s (re-solved: the solver's model then leaves "
                f"{self.model_residual_rms_nm:.3g} nm RMS, {self.model_residual_pv_nm:.3g} nm PV, from "
                f"{initial_rms_nm:.3g} nm RMS){alt}.")


@dataclass(frozen=True)
class FloorCheck:
    """The minimum-removal floor against the error, and what was decided.

    Attributes
    ----------
    floor_nm : float
        Mean removal of the minimum times alone over the clear aperture, nm.
    error_pv_nm, error_rms_nm : float
        The error over the clear aperture, nm (RMS about the mean).
    peak_rate_nm_s, max_feed_mm_min, spacing_mm : float
        The parameters that make the floor.
    turn_share : float
        Share of the minimum time that the path's turns add over its steps at the top feed (the chord
        tolerance at the interpolation period slows the feed there; no top feed changes that part).
    exceeds : bool
        ``floor_nm > FIGURING_FLOOR_MAX_SHARE x error_pv_nm``: refused unless forced.
    advice : FloorAdvice or None
        Computed when the floor is above the advised share of the PV.
    forced : bool
        Figuring went on past a refusal (``--force``).
    refusals : tuple of str
        The refusal messages passed by with ``--force`` (empty otherwise).
    """

    floor_nm: float
    error_pv_nm: float
    error_rms_nm: float
    peak_rate_nm_s: float
    max_feed_mm_min: float
    spacing_mm: float
    turn_share: float
    exceeds: bool
    advice: FloorAdvice | None = None
    forced: bool = False
    refusals: tuple[str, ...] = ()

    @property
    def ratio(self) -> float:
        """Floor over the error's PV."""
        return self.floor_nm / max(self.error_pv_nm, 1e-300)

    def cause(self) -> str:
        return (f"every dwell point gets at least the time the path takes through its region at the top feed "
                f"{self.max_feed_mm_min:.4g} mm/min, and with those times alone this TIF (peak "
                f"{self.peak_rate_nm_s:.3g} nm/s) at {self.spacing_mm:.3g} mm spacing removes {self.floor_nm:.4g} nm "
                f"on average ({100 * self.turn_share:.0f} % of that minimum time is the path's turns, where the chord "
                "tolerance slows the feed); its unevenness (the part's edge, the path's turns, each time delivered a little off) "
                "stays in the residual")


def floor_exceeds(floor_nm: float, error_pv_nm: float) -> bool:
    """Whether the floor is more than the error needs (refused unless forced)."""
    return floor_nm > FIGURING_FLOOR_MAX_SHARE * error_pv_nm


def advice_scale(floor_nm: float, error_pv_nm: float) -> float:
    """The factor that brings the floor to the advised share of the PV (1 when it is already there)."""
    return min(1.0, FIGURING_FLOOR_ADVICE_SHARE * error_pv_nm / max(floor_nm, 1e-300))


def refusal_for_floor(fc: FloorCheck) -> str:
    """The message of a refusal because the floor exceeds what the error needs."""
    msg = (f"figuring refused: the minimum-removal floor is {fc.floor_nm:.4g} nm, {fc.ratio:.2g} x the "
           f"{fc.error_pv_nm:.3g} nm PV the error needs ({fc.error_rms_nm:.3g} nm RMS): {fc.cause()}.")
    return msg + (" " + fc.advice.text(fc.error_rms_nm) if fc.advice is not None else "")


def refusal_for_prediction(fc: FloorCheck, initial_rms_nm: float, initial_pv_nm: float, residual_rms_nm: float,
                           residual_pv_nm: float, *, uncorrectable_rms_nm: float, passband_per_mm: float,
                           converged: bool, delivered_error_rms: float | None) -> str:
    """The message when the predicted residual is no better than the error ('' when it is better, RMS and PV)."""
    if residual_rms_nm < initial_rms_nm and residual_pv_nm < initial_pv_nm:
        return ""
    msg = (f"figuring refused: the program would leave the part worse: initial {initial_rms_nm:.3g} nm RMS "
           f"({initial_pv_nm:.3g} nm PV) -> predicted {residual_rms_nm:.3g} nm RMS ({residual_pv_nm:.3g} nm PV) "
           f"over the clear aperture; the minimum-removal floor is {fc.floor_nm:.4g} nm.")
    if fc.advice is not None:
        return msg + f" Cause: {fc.cause()}. " + fc.advice.text(initial_rms_nm)
    if uncorrectable_rms_nm > 0.5 * initial_rms_nm:
        return msg + (f" Cause: {uncorrectable_rms_nm:.3g} nm RMS of the error lies above {passband_per_mm:.3g} 1/mm, "
                      "beyond this TIF and spacing. Use a narrower TIF and a finer spacing.")
    if not converged:
        return msg + " Cause: the dwell-time solver did not converge. Raise its iteration limit or the smoothness."
    return msg + (f" Cause: the times the path delivers are off by {100 * (delivered_error_rms or 0):.3g} % RMS. "
                  "Use a lower feed or a larger chord tolerance.")
