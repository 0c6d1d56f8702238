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
