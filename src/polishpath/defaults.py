"""One place for each default the stages share.

The stages, the simulation, the job's options (``config.JobConfig``) and the
command line import these, so a default is changed here and nowhere else
(``tests/test_defaults.py`` checks that the command line's options and the
API functions agree with them).
"""

#: nominal feed of the tool along the path, mm/min
DEFAULT_FEED_MM_MIN = 600.0
#: the machine's feed limit where none is given, as a multiple of the nominal feed (smoothing, the
#: simulation's machine timing, the figuring's fastest pass)
MAX_FEED_FACTOR = 5.0
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
#: figuring without [error_map] ca_margin_mm: the clear aperture (where the residual is figured and reported) is
#: the part inset by this many TIF widths (FWHM); next to the edge a dwell point's footprint is partly off the part
#: and that band cannot be figured like the inside (issue 28 item 2: 5.6 % inside r <= 16 mm when it is fitted at
#: full weight, 1.6 % when not). See docs/figuring.md, "The clear aperture by default"
FIGURING_CA_MARGIN_FWHMS = 1.0
#: ... halved until the clear aperture keeps at least this share of the part's area (a part not much wider
#: than the TIF)
FIGURING_CA_MIN_AREA_SHARE = 0.25
#: figuring: the fit weight of the part outside the clear aperture (and of masked pixels) against 1 inside it: the
#: band next to the edge is fitted only lightly, so that what a TIF cannot reach there does not pull the clear
#: aperture (disc R 20 mm, TIF 5 mm, clear aperture r <= 15 mm: 2.1 % of the initial RMS left at 0.2, 1.0 % at
#: 0.05, 0.89 % at 0.02, 2.0 % at 0: nothing then holds the edge points' times; the figuring example 2.9 -> 0.8 %)
FIGURING_EXTENSION_WEIGHT = 0.05
#: the parameters a refusal suggests bring the floor down to this share of the error's PV
FIGURING_FLOOR_ADVICE_SHARE = 0.2
#: flattening method (the paper's MABF)
DEFAULT_FLATTEN_METHOD = "mabf"
#: dwell-point spacing on the part, mm
DEFAULT_SPACING_MM = 0.5
#: dwell-point set (--dwell-points): the paper's square grid. Issue 26's verdict (docs/simulation.md, "The walk
#: without a lattice: the verdict") chose it: the lattice-free walks ('relaxed', 'blue-noise') print far lower
#: lattice peaks (2-5 dB against the grid walk's 13-18 dB) but leave a residual band RMS up to 8 % above the grid
#: walk's and 21-71 % above the rectangular path's, so the verdict's second condition is not met. The excess sits at
#: 1-1.5 1/mm (a walk turning at every point spreads its time density there); centring each point's time centroid
#: narrows it to 11-14 % on a flat square ("Where the walks' band RMS comes from"); the density fit given to every
#: path (compare_planned(treatment="density-fit"), not a stage of the job) meets it on the saddle, not on the flat
#: disc (+5 % over the fitted grid walk) nor the hemisphere (+26-37 % over the rectangular path); the ripple fit,
#: which fits every path its own removal (treatment="ripple-fit"), meets it on none of the three (the raster best
#: on the flat disc and the saddle, the spiral on the hemisphere; the relaxed walk 23-52 % above): the grid stays
DEFAULT_DWELL_POINTS = "grid"
#: the job refuses to plan more dwell points than this (memory and time: about 1 KB and 50 us each)
DEFAULT_MAX_POINTS = 5_000_000
#: ... or, to honour the spacing on the part, more than this many times a uniform grid's dwell points
DEFAULT_MAX_OVERSAMPLING = 16.0
#: the paper's tool: polishing sponge rotating at 230 rpm (section 6), 1/min; also the program's spindle speed
DEFAULT_RPM = 230.0
#: contact radius of the sponge on the part, mm (assumption: the paper gives no size; see docs/simulation.md)
DEFAULT_CONTACT_RADIUS_MM = 2.0
#: pressure profile of the contact: a sponge (open-cell foam) acts as a bed of springs (Winkler
#: foundation), so the pressure follows the local compression of a rounded tip, 1 - r^2/R^2
DEFAULT_PRESSURE = "parabolic"
#: default Gaussian TIF of a small sponge tool: peak removal rate, nm/s
DEFAULT_PEAK_RATE_NM_S = 5.0
#: figuring: each minimum dwell time is the time a run at the top feed spends in the point's region, times
#: (1 + this), plus one interpolation period: where the chord tolerance slows the feed (the path's turns) a
#: region's time at the top feed depends on where the steps fall, up to tens of % between two runs, and a time
#: only the top feed could reach would be missed (issue 28: delivered 2.5 % RMS, 44 % worst without it)
FIGURING_TMIN_HEADROOM = 0.1
#: ... and this share more of the part of that time the path's turns add over its straight steps at the top feed
FIGURING_TURN_HEADROOM = 0.5
#: figuring: the smoothing stage runs a dwell region again while its time is off by more than this share ...
FIGURING_REGION_TOL = 0.004
#: ... up to this many runs (docs/machine-output.md section 3; docs/figuring.md "Delivered by the path": on the
#: figuring example 8 runs leave a region 4.3 % off, 12 runs 3.5 % on the machine that measured it but 6.1 % on
#: an AMD EPYC, where a turn's steps fall otherwise; 20 runs 3.8 % there. The first 12 runs are those of 12 and
#: the nearest run is kept, so more runs never leave a region further off)
FIGURING_SCHEDULE_PASSES = 20

#: local worker processes of a comparison's independent cases (pattern x seed): None = every core
#: this process may use (polishpath.simulate.cases.available_cores); 1 = one after another in process
DEFAULT_CASE_WORKERS = None
#: a case's peak memory, bytes = base + per pixel of its patch x pixels + per fine path sample x samples
#: (polishpath.simulate.cases.Case.peak_bytes; measured with benchmarks/bench_simulate_speed.py)
CASE_MEMORY_MODEL = (400e6, 40.0, 120.0)
#: the share of the available memory the default worker count leaves to the calling process and the machine
CASE_MEMORY_RESERVE = 0.25
#: seconds to wait for a Dask scheduler (--scheduler) to answer before giving up with exit 2
SCHEDULER_TIMEOUT_S = 10.0
#: a comparison of paths (polishpath simulate SURFACE, a sweep): seeds, the simulated patch's side (mm) and the
#: mean depth every path removes (nm)
DEFAULT_SEEDS = 5
DEFAULT_PATCH_MM = 20.0
DEFAULT_REMOVAL_DEPTH_NM = 200.0
#: 5-axis (issue 27): most the tool axis along a merged G-code block may leave the planned axis, degrees; and the
#: cone around a table's C axis where the inverse kinematics holds C (any C puts the axis within it), degrees:
#: both half the 0.01 degree the rs274 check allows
DEFAULT_ORIENTATION_TOL_DEG = 0.005
DEFAULT_SINGULAR_CONE_DEG = 0.005
