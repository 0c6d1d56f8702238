"""One place for each default the stages share.

The smoothing stage, the simulation, the job's options and the command line
import these, so a default is changed here and nowhere else.
"""

#: nominal feed of the tool along the path, mm/min
DEFAULT_FEED_MM_MIN = 600.0
#: interpolation period of the machine's constant-period samples, ms
DEFAULT_PERIOD_MS = 4.0
#: largest allowed chord error between the samples and the NURBS, mm (1 um)
DEFAULT_CHORD_TOL_MM = 0.001
#: how the constant-period interpolation advances the curve parameter (smooth/interpolate.py: Taylor predictor
#: with an exact chord corrector, or the paper's Adams-Bashforth / Adams-Moulton); docs/machine-output.md says why
INTEGRATOR_NAMES = ("taylor", "ab-am")
DEFAULT_INTEGRATOR = "taylor"
#: figuring refuses (exit 2, unless --force) when the minimum-removal floor (what every dwell point's least time
#: removes, on average over the clear aperture) exceeds this share of the error's PV, the deepest removal it needs
FIGURING_FLOOR_MAX_SHARE = 1.0
#: the parameters a refusal suggests bring the floor down to this share of the error's PV
FIGURING_FLOOR_ADVICE_SHARE = 0.2
