"""Blue-noise dwell points: a Poisson-disk set with no lattice, and the planar graph a walk may use.

Sampling (:func:`blue_noise_points`): Bridson's Poisson-disk algorithm
(Bridson 2007, "Fast Poisson disk sampling in arbitrary dimensions") with
Roberts' candidate rule (the k candidates around an active point sit at the
disk radius ``r`` (1 + 1e-7), at evenly spaced angles from a random start,
instead of uniformly in the annulus ``[r, 2 r]``): about 7x fewer rejected
candidates, a denser, near-maximal set (measured 0.81 / r^2 points per mm^2 on a
large square), no two points closer than ``r``. The radius is chosen so that the
density is that of the square grid of the same spacing ``h`` (1 / h^2):
``r = sqrt(DENSITY_R2) h`` = 0.90 h. The points are sampled over the squares
(``SQUARE_CELL`` spacings) that hold a point of the region and the squares around
them, not over its whole bounding box (a disc: 1.03x the points kept instead of
1.27x), and the ones inside the region (shrunk by the margin) are kept, so the
density is the same up to the boundary; a part of the region the front cannot reach
gets a front of its own. They are then numbered by square cell of one
spacing, row by row, so that neighbours sit near each other in memory (the graph's
construction and the walk read them about 1.5x faster). Written by hand (numba) because
``scipy.stats.qmc.PoissonDisk`` takes about 1 ms per point, far too slow for
10^6-10^7 dwell points; the loop is the textbook one.

Neighbour graph (:func:`neighbour_graph`): the edges of the points' Delaunay
triangulation that are at most ``EDGE_FACTOR x h`` long (``LEAF_EDGE_FACTOR x h``
at a point that would otherwise have one neighbour) and stay inside the
region (exact shapely test for the edges near the boundary). Each edge is
decided locally (``_local_delaunay``: an edge is kept when a circle of radius at
most ``EMPTY_CIRCLE_FACTOR x h`` through its ends holds no other point, a
Delaunay edge by definition; the sampler leaves almost no empty circle larger
than about 0.9 h, so inside the part no short Delaunay edge is lost, and at the
rim about one in a few thousand: tested against ``scipy.spatial.Delaunay``; each
point is tested first with circles up to ``SMALL_CIRCLE_FACTOR x h`` and again
with the full radius only where that cannot decide: the same edges). The edges of a triangulation never cross, so a
path along kept edges cannot cross itself and never leaves the region.

Dwell weights (:func:`cell_areas`): each point stands for its Voronoi cell:
the signed circumcentric share of every kept triangle around it
(``(|AB|^2 cot C + |AC|^2 cot B) / 8`` at A, summing exactly to the Voronoi
cell's area around an interior point); a point on the rim of the kept
triangles (whose cell the triangulation cuts) gets the interior cells' mean.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
from ... import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np
import shapely

from ...errors import ParameterError, SpacingTooLargeError
from ...types import Region
from ..checks import check_number, check_region, check_seed
from ..dwell import region_polygon

#: Points per r^2 of the sampler (Roberts' rule, k = SAMPLER_K, ACTIVE_WINDOW), measured on a 1000 r square.
DENSITY_R2 = 0.8115
#: Candidates tried around an active point before it retires.
SAMPLER_K = 12
#: The sampler grows from a random one of this many most recent active points.
ACTIVE_WINDOW = 64
#: Longest edge of the neighbour graph, as a multiple of the spacing h (the sampler's largest empty
#: circle is about r = 0.90 h, so a Delaunay edge between neighbours is at most about 1.8 h; longer
#: ones span a gap or a notch of the boundary).
EDGE_FACTOR = 1.7
#: Longest edge of the neighbour graph at a point that the EDGE_FACTOR rule leaves with one neighbour (a leaf:
#: a path can only end there, so two of them at the rim cost a tool lift): its inside Delaunay edges up to
#: this multiple of h join the graph too (still under the issue's 2 h). The longest step of the walk.
LEAF_EDGE_FACTOR = 1.9
#: Side of the squares (spacings) over which the sampler keeps to the region (it samples the squares that hold a
#: point of the region and the squares around them, not the whole bounding box: on a disc 0.79 of the box) and by
#: which the sampled points are found inside it (``_inside``).
SQUARE_CELL = 4.0
#: The sampler's largest set (points); beyond it the region is refused with a message.
MAX_POINTS = 60_000_000


@dataclass(frozen=True, eq=False)
class BlueNoisePoints:
    """Dwell points without a lattice inside a region, with their planar neighbour graph.

    Attributes
    ----------
    uv : (n, 2) float64
        Dwell points, mm, numbered by square cell of one spacing, row by row (see :func:`cell_lists`).
    spacing : float
        The spacing ``h`` whose square grid has the same density, mm.
    min_distance : float
        No two points are closer than this, mm (``sqrt(DENSITY_R2) h``).
    margin : float
        Distance the points and steps keep from the region's boundary, mm.
    indptr, indices : int64 arrays
        The neighbour graph in CSR form (symmetric): the neighbours of point
        ``k`` are ``indices[indptr[k]:indptr[k+1]]``.
    cell_area : (n,) float64
        Area each point stands for (its Voronoi cell), mm^2.
    seed : int
        Seed of the sampler.
    polygon : shapely geometry
        The (shrunk) region in mm.
    """

    uv: np.ndarray
    spacing: float
    min_distance: float
    margin: float
    indptr: np.ndarray
    indices: np.ndarray
    cell_area: np.ndarray
    seed: int
    polygon: object = field(repr=False)

    @property
    def n(self) -> int:
        """Number of dwell points."""
        return int(self.uv.shape[0])

    def edges(self) -> np.ndarray:
        """Undirected edges (E, 2) int64 of the neighbour graph, each once (``a < b``)."""
        a = np.repeat(np.arange(self.n), np.diff(self.indptr))
        keep = a < self.indices
        return np.stack([a[keep], self.indices[keep]], axis=1)


def _neighbour_cells() -> tuple[np.ndarray, np.ndarray]:
    """Offsets (di, dj) of the sampler's cells (side r / sqrt(2)) that can hold a point closer than r, nearest first.

    The 5 x 5 block without its corners (a corner cell is at least r away), sorted by the distance between cells.
    """
    d = [(i, j) for j in range(-2, 3) for i in range(-2, 3) if abs(i) + abs(j) < 4]
    d.sort(key=lambda t: (t[0] ** 2 + t[1] ** 2, t[1], t[0]))
    return np.array([t[0] for t in d], np.int64), np.array([t[1] for t in d], np.int64)


NBR_DI, NBR_DJ = _neighbour_cells()


@numba.njit(cache=True)
def _free(cx, cy, g, grid, off, r2):  # pragma: no cover - numba
    # whether no point of the sampler's grid is closer than sqrt(r2) to (cx, cy) in cell g: the 21 cells that can
    # hold one (g + off), nearest first (a rejection ends early). The grid holds each cell's point (x, y), inf
    # where none, and 2 empty cells around: no bounds and no point number to look up (0.91x the sampler's time at
    # 10^6 points, the same points)
    for o in range(off.shape[0]):
        c = 2 * (g + off[o])
        dx = grid[c] - cx
        dy = grid[c + 1] - cy
        if dx * dx + dy * dy < r2:
            return False
    return True


@numba.njit(cache=True)
def _holds_point(mcell, mc, mw, grid, gw, gh, cell):  # pragma: no cover - numba
    # whether the sampler's grid (cells of side cell, gw a row, padded: see _free) holds a point in the square
    # mcell (side mc, mw a row)
    i0 = int((mcell % mw) * mc / cell)
    j0 = int((mcell // mw) * mc / cell)
    for jj in range(max(j0, 0), min(int(((mcell // mw) + 1) * mc / cell) + 1, gh)):
        for ii in range(max(i0, 0), min(int(((mcell % mw) + 1) * mc / cell) + 1, gw)):
            if grid[2 * ((jj + 2) * (gw + 4) + ii + 2)] < np.inf:
                return True
    return False


@numba.njit(cache=True)
def _poisson_disk(w, hgt, r, k, seed, mask, mc, mw):  # pragma: no cover - numba
    # Bridson's algorithm with Roberts' candidates (see the module docstring), on the cells of [0, w) x [0, hgt)
    # (squares of side mc, mw a row) where mask is 1. A front that dies leaves the cells it cannot reach (another
    # part of the region) empty: a point drawn in the next empty cell starts a new front there.
    np.random.seed(seed)
    cell = r / np.sqrt(2.0)
    gw = int(np.ceil(w / cell)) + 1
    gh = int(np.ceil(hgt / cell)) + 1
    gp = gw + 4  # a row of the grid with its padding (see _free)
    grid = np.full(2 * gp * (gh + 4), np.inf)
    off = NBR_DJ * gp + NBR_DI
    inv_cell = 1.0 / cell  # a candidate's cells by multiplication (a division per candidate and axis cost 0.1 s)
    inv_mc = 1.0 / mc
    cap = int(1.2 * w * hgt / (r * r)) + 16  # the densest packing at distance r holds 1.155 / r^2
    xs = np.empty(cap)
    ys = np.empty(cap)
    active = np.empty(cap, np.int64)
    na = 0
    n = 0
    r2 = r * r
    rho = r * (1.0 + 1e-7)
    ck = np.cos(2.0 * np.pi * np.arange(k) / k)
    sk = np.sin(2.0 * np.pi * np.arange(k) / k)
    seed_cell = 0  # the next masked cell to look at for a new front
    while True:
        if na == 0:
            # a new front: a random point of the next masked cell that holds none (tried a few times)
            while seed_cell < mask.shape[0] and na == 0:
                mcell = seed_cell
                seed_cell += 1
                if mask[mcell] == 0 or _holds_point(mcell, mc, mw, grid, gw, gh, cell):
                    continue
                for _ in range(32):
                    cx = ((mcell % mw) + np.random.random()) * mc
                    cy = ((mcell // mw) + np.random.random()) * mc
                    if cx >= w or cy >= hgt:
                        continue
                    gi = int(cx * inv_cell)
                    gj = int(cy * inv_cell)
                    if not _free(cx, cy, (gj + 2) * gp + gi + 2, grid, off, r2):
                        continue
                    xs[n] = cx
                    ys[n] = cy
                    grid[2 * ((gj + 2) * gp + gi + 2)] = cx
                    grid[2 * ((gj + 2) * gp + gi + 2) + 1] = cy
                    active[0] = n
                    na = 1
                    n += 1
                    break
            if na == 0:
                break
        # a random one of the most recent active points: the front stays in cache (a random one of all
        # of them: about 2x slower at 10^6 points, no difference in the points' statistics measured)
        ia = na - 1 - np.random.randint(min(na, ACTIVE_WINDOW))
        p = active[ia]
        px = xs[p]
        py = ys[p]
        ok = False
        th0 = 2.0 * np.pi * np.random.random()
        c0 = rho * np.cos(th0)
        s0 = rho * np.sin(th0)
        for t in range(k):
            cx = px + c0 * ck[t] - s0 * sk[t]
            cy = py + s0 * ck[t] + c0 * sk[t]
            if cx < 0 or cy < 0 or cx >= w or cy >= hgt:
                continue
            if mask[int(cy * inv_mc) * mw + int(cx * inv_mc)] == 0:
                continue
            gi = int(cx * inv_cell)
            gj = int(cy * inv_cell)
            if _free(cx, cy, (gj + 2) * gp + gi + 2, grid, off, r2):
                xs[n] = cx
                ys[n] = cy
                grid[2 * ((gj + 2) * gp + gi + 2)] = cx
                grid[2 * ((gj + 2) * gp + gi + 2) + 1] = cy
                active[na] = n
                na += 1
                n += 1
                ok = True
                break
        if not ok:  # retire it, keeping the others in order (the window is the most recent ones)
            na -= 1
            for j in range(ia, na):
                active[j] = active[j + 1]
    return xs[:n].copy(), ys[:n].copy()


def blue_noise_points(region: Region, spacing: float, *, seed: int, margin: float = 0.0) -> BlueNoisePoints:
    """A Poisson-disk dwell-point set inside a region, at the density of the square grid of ``spacing``.

    Parameters
    ----------
    region : Region
        Planar region (outer loop and holes), mm.
    spacing : float
        Spacing ``h`` of the square grid of the same density (1 / h^2 points per mm^2), mm.
    seed : int
        Seed of the sampler (0 <= seed < 2**63); same seed, same points.
    margin : float
        Keep the points and the graph's edges this far inside the boundary, mm.

    Returns
    -------
    BlueNoisePoints

    Raises
    ------
    ParameterError
        Not a Region; spacing or margin not a number in range; bad seed; more points than
        :data:`MAX_POINTS`.
    SpacingTooLargeError
        Fewer than two points fit.
    """
    check_region(region)
    spacing = check_number(spacing, "The dwell-point spacing", positive=True, unit="mm")
    margin = check_number(margin, "The margin", low=0.0, unit="mm")
    seed = check_seed(seed)
    poly = region_polygon(region, margin)
    x0, y0, x1, y1 = poly.bounds
    r = float(np.sqrt(DENSITY_R2) * spacing)
    w, hgt = max(x1 - x0, 1e-12), max(y1 - y0, 1e-12)
    expect = w * hgt / spacing**2
    if expect > MAX_POINTS:
        raise ParameterError(
            f"Spacing {spacing:.4g} mm on a {w:.4g} x {hgt:.4g} mm region needs about {expect:.3g} blue-noise "
            f"points over its bounding box, more than polishpath handles ({MAX_POINTS:.0e}).",
            "Use a larger spacing, or --dwell-points grid.")
    # numba's generator takes a 32-bit seed: one drawn from the seed's sequence
    s32 = int(np.random.SeedSequence(seed).generate_state(1, dtype=np.uint32)[0])
    shapely.prepare(poly)
    mc = SQUARE_CELL * spacing
    squares = _squares(poly, mc)
    mask = _grow(squares[0] | squares[1]).ravel().astype(np.uint8)
    xs, ys = _poisson_disk(w, hgt, r, SAMPLER_K, s32, mask, mc, squares[0].shape[1])
    xs += x0
    ys += y0
    inside = _inside(poly, xs, ys, mc, squares)
    uv = np.stack([xs[inside], ys[inside]], axis=1)
    if len(uv) < 2:
        rx0, ry0, rx1, ry1 = region.bounds
        raise SpacingTooLargeError(
            f"Only {len(uv)} blue-noise dwell point(s) of spacing {spacing:.4g} mm fit in the region "
            f"({rx1 - rx0:.4g} x {ry1 - ry0:.4g} mm, area {region.area:.4g} mm^2"
            + (f", margin {margin:.4g} mm" if margin else "") + ").",
            "Use a smaller spacing (at most about half the region's width).")
    # numbered by cell of one spacing, row by row: neighbours sit near in memory for the graph and the walk
    cells, cstart, cx0, cy0, W, H = cell_lists(uv, spacing)
    uv = np.ascontiguousarray(uv[cells])
    # the renumbered points' cell lists: the same cells, each one's points now numbered in a row
    indptr, indices, triangles = neighbour_graph(uv, spacing, poly,
                                                 cells=(np.arange(len(uv)), cstart, cx0, cy0, W, H))
    area = cell_areas(uv, triangles, spacing)
    return BlueNoisePoints(uv=uv, spacing=spacing, min_distance=r, margin=margin, indptr=indptr, indices=indices,
                           cell_area=area, seed=seed, polygon=poly)


def _grow(a: np.ndarray) -> np.ndarray:
    """The (H, W) bool raster ``a`` grown by one cell (its 8 neighbours)."""
    g = a.copy()
    g[1:, :] |= a[:-1, :]
    g[:-1, :] |= a[1:, :]
    g[:, 1:] |= a[:, :-1]
    g[:, :-1] |= a[:, 1:]
    g[1:, 1:] |= a[:-1, :-1]
    g[:-1, :-1] |= a[1:, 1:]
    g[1:, :-1] |= a[:-1, 1:]
    g[:-1, 1:] |= a[1:, :-1]
    return g


def _squares(poly, mc: float) -> tuple[np.ndarray, np.ndarray]:
    """The polygon's bounding box in squares of side ``mc`` mm (from its lower left corner): ``bnd`` (H, W) bool,
    the squares that hold a sample of the boundary (every ``mc / 4``), and ``centre_in`` (H, W) bool, the squares
    whose centre is inside."""
    x0, y0, x1, y1 = poly.bounds
    mw = int(np.ceil((x1 - x0) / mc)) + 1
    mh = int(np.ceil((y1 - y0) / mc)) + 1
    bnd = np.zeros((mh, mw), dtype=bool)
    for ring in (np.asarray(g.coords) for p in getattr(poly, "geoms", [poly]) for g in [p.exterior, *p.interiors]):
        a, b = ring[:-1], ring[1:]
        nsub = np.maximum(1, np.ceil(np.hypot(*(b - a).T) / (0.25 * mc)).astype(np.int64))
        rep = np.repeat(np.arange(len(a)), nsub + 1)
        t = np.arange(len(rep)) - np.repeat(np.cumsum(nsub + 1) - (nsub + 1), nsub + 1)
        pts = a[rep] + (t / np.repeat(nsub, nsub + 1))[:, None] * (b - a)[rep]
        ci = np.clip(np.floor((pts[:, 0] - x0) / mc).astype(np.int64), 0, mw - 1)
        cj = np.clip(np.floor((pts[:, 1] - y0) / mc).astype(np.int64), 0, mh - 1)
        bnd[cj, ci] = True
    gx, gy = np.meshgrid(x0 + (np.arange(mw) + 0.5) * mc, y0 + (np.arange(mh) + 0.5) * mc)
    return bnd, shapely.contains_xy(poly, gx, gy)


def _inside(poly, xs: np.ndarray, ys: np.ndarray, mc: float, squares=None) -> np.ndarray:
    """(n,) bool: the points ``(xs, ys)`` (mm) inside the prepared polygon, as ``shapely.contains_xy``.

    The polygon's squares (:func:`_squares`, given or made here): a square whose centre is inside (outside) and
    that no sample of the boundary lies in or next to is wholly inside (outside): its points are decided without
    shapely (a ring that clips a square's corner leaves a sample in a square next to it, and a ring inside a
    square leaves its vertices there). shapely tests the points of the other squares only: the same answer,
    0.08 -> 0.01 s for the 1.27 M points of a 10^6-point disc's box.
    """
    bnd, centre_in = _squares(poly, mc) if squares is None else squares
    x0, y0 = poly.bounds[:2]
    mh, mw = bnd.shape
    clear = ~_grow(bnd)
    state = np.where(clear & centre_in, 1, np.where(clear, 0, 2)).astype(np.int8).ravel()  # in, out, test
    return _classify(xs, ys, x0, y0, mc, mw, mh, state, poly)


def _classify(xs, ys, x0, y0, mc, mw, mh, state, poly) -> np.ndarray:
    """The points' answers from their squares' ``state`` (1 in, 0 out, 2 shapely's test)."""
    inside, test = _square_states(xs, ys, float(x0), float(y0), float(mc), mw, mh, state)
    inside[test] = shapely.contains_xy(poly, xs[test], ys[test])
    return inside


@numba.njit(cache=True)
def _square_states(xs, ys, x0, y0, mc, mw, mh, state):  # pragma: no cover - numba
    # each point's square's state: inside (1) as a bool, and the numbers of the points to test (state 2)
    n = xs.shape[0]
    inside = np.zeros(n, np.bool_)
    test = np.empty(n, np.int64)
    m = 0
    for i in range(n):
        ci = min(max(int(np.floor((xs[i] - x0) / mc)), 0), mw - 1)
        cj = min(max(int(np.floor((ys[i] - y0) / mc)), 0), mh - 1)
        st = state[cj * mw + ci]
        inside[i] = st == 1
        test[m] = i
        m += st == 2
    return inside, test[:m]


def _near_boundary(poly, uv: np.ndarray, reach: float) -> np.ndarray:
    """(n,) bool: points that may lie within ``reach`` mm of the polygon's boundary (a cell raster, conservative)."""
    x0, y0, x1, y1 = poly.bounds
    c = reach
    W = int(np.ceil((x1 - x0) / c)) + 3
    H = int(np.ceil((y1 - y0) / c)) + 3
    rings = [np.asarray(g.coords) for p in getattr(poly, "geoms", [poly]) for g in [p.exterior, *p.interiors]]
    near = np.zeros((H, W), dtype=bool)
    for ring in rings:
        a, b = ring[:-1], ring[1:]
        nsub = np.maximum(1, np.ceil(np.hypot(*(b - a).T) / (0.25 * c)).astype(np.int64))
        rep = np.repeat(np.arange(len(a)), nsub + 1)
        t = np.arange(len(rep)) - np.repeat(np.cumsum(nsub + 1) - (nsub + 1), nsub + 1)
        t = t / np.repeat(nsub, nsub + 1)
        pts = a[rep] + t[:, None] * (b - a)[rep]
        ci = np.floor((pts[:, 0] - x0) / c).astype(np.int64) + 1
        cj = np.floor((pts[:, 1] - y0) / c).astype(np.int64) + 1
        near[np.clip(cj, 0, H - 1), np.clip(ci, 0, W - 1)] = True
    # grow by 2 cells: a point two cells away from every boundary cell is more than ``reach`` from the boundary
    grown = near.copy()
    for _ in range(2):
        g = grown.copy()
        g[1:, :] |= grown[:-1, :]
        g[:-1, :] |= grown[1:, :]
        g[:, 1:] |= grown[:, :-1]
        g[:, :-1] |= grown[:, 1:]
        g[1:, 1:] |= grown[:-1, :-1]
        g[:-1, :-1] |= grown[1:, 1:]
        g[1:, :-1] |= grown[:-1, 1:]
        g[:-1, 1:] |= grown[1:, :-1]
        grown = g
    ci = np.floor((uv[:, 0] - x0) / c).astype(np.int64) + 1
    cj = np.floor((uv[:, 1] - y0) / c).astype(np.int64) + 1
    return grown[np.clip(cj, 0, H - 1), np.clip(ci, 0, W - 1)]


# error_model="numpy": three exactly collinear points make a circle-centre divisor 0 (a point on the line of p and q:
# its bound is never used, `bad` decides it); numba's default would raise ZeroDivisionError there (measured: no cost)
@numba.njit(cache=True, error_model="numpy")
def _local_delaunay(xy, cells, cstart, x0, y0, cw, W, H, cw_order, W_order, lmax, rho, eps,
                    rho_small):  # pragma: no cover - numba
    # Edges (p < q) of length <= lmax that have an empty circle of radius <= rho through p and q, and the
    # triangles (a < b < c) beside them whose circle is the interval's end. Such edges are Delaunay edges, so
    # they never cross (a width below eps, a near-cocircular quad, drops both diagonals). Written by hand: the
    # set's empty circles are nearly all smaller than rho (a near-maximal Poisson-disk set), so a local test over
    # the points within 2 rho decides each edge exactly and in O(1), about 20x faster than Qhull's
    # triangulation of the whole set (scipy.spatial.Delaunay: 25 s for 10^6 points on this machine).
    # The candidates of p: the points within 2 rho, from the rows of cells (side cw, listed by cells / cstart)
    # around it, each row's cells one run of cstart. The circle test runs without branches (a point on either
    # side of the edge bounds the interval of centres from below or from above; a branch per point was
    # mispredicted half the time: 1.4 -> 0.7 s at 10^6 points). The edges of p are written in the order of
    # the cells of side cw_order (W_order a row) and then by number, so the output does not depend on cw.
    #
    # Two reaches, the same answer (0.78x the time at 10^6 points): each point is first tested with the
    # circles of radius <= rho_small (its candidates within 2 rho_small: about 0.55x the pairs and points of
    # rho's). An edge whose interval of centres ends at points strictly inside that small window (by delta) has
    # the same interval, ends and end points with rho: no circle of radius <= rho_small holds a point farther
    # than 2 rho_small from p, and the points that bound it lie inside such circles. An edge not decided so
    # (an end at the window: a large empty circle, the rim) marks both its ends, and a marked point is tested
    # again with rho, as before. That is every point whose answer can differ: an edge (p, q) kept with rho but
    # out of the small reach has an empty circle wider than rho_small, so p's Voronoi cell reaches beyond
    # rho_small, and walking its boundary out from the midpoint of p's nearest neighbour (a point with no
    # neighbour within 2 rho_small is marked) passes an undecided edge of p, tested at its smaller end, which
    # comes first in point order: the marks reach p before p is tested, and the output keeps its order.
    # An edge that no interval could keep with rho (its upper bound minus its lower bound, each a point's or
    # rho's window end, at most eps) is decided too.
    n = xy.shape[0]
    reach_full = int(np.ceil(2.0 * rho / cw))
    reach_small = int(np.ceil(2.0 * rho_small / cw))
    delta = 1e-6 * rho_small
    cap = 4 * n + 16
    ea = np.empty(cap, np.int64)
    eb = np.empty(cap, np.int64)
    tcap = 3 * n + 16
    ta = np.empty((tcap, 3), np.int64)
    ne = 0
    nt = 0
    loc = np.empty(512, np.int64)
    lx = np.empty(512)  # candidates relative to p, and their squared distances
    ly = np.empty(512)
    ls = np.empty(512)
    va = np.empty(512)
    kq = np.empty(64, np.int64)  # the kept edges of p: far end, order key, the triangles' third points
    kk = np.empty(64, np.int64)
    klo = np.empty(64, np.int64)
    khi = np.empty(64, np.int64)
    l2 = lmax * lmax
    marked = np.zeros(n, np.bool_)  # to be tested with rho (an undecided edge of the small reach ends there)
    n_again = 0
    for p in range(n):
        px = xy[p, 0]
        py = xy[p, 1]
        hx = int((px - x0) / cw)
        hy = int((py - y0) / cw)
        for again in range(2):  # the small reach, then (a marked point) rho's
            small = again == 0
            rr = rho_small if small else rho
            reach = reach_small if small else reach_full
            r2 = 4.0 * rr * rr
            m = 0
            ca = max(hx - reach, 0)
            cb = min(hx + reach, W - 1)
            for cy in range(max(hy - reach, 0), min(hy + reach + 1, H)):
                for t in range(cstart[cy * W + ca], cstart[cy * W + cb + 1]):
                    x = cells[t]
                    dx = xy[x, 0] - px
                    dy = xy[x, 1] - py
                    s2 = dx * dx + dy * dy
                    loc[m] = x
                    lx[m] = dx
                    ly[m] = dy
                    ls[m] = s2
                    m += (s2 <= r2) & (x != p)
                    if m == 511:
                        break
            nk = 0
            undecided = m == 0
            for i in range(m):
                q = loc[i]
                if q < p:
                    continue
                d2 = ls[i]
                if d2 > l2:
                    continue
                cap_t = rr * rr - 0.25 * d2
                if cap_t <= 0:
                    if small:
                        undecided = True
                        marked[q] = True
                    continue
                cap_t = np.sqrt(cap_t)
                dl = np.sqrt(d2)
                qx = lx[i]
                qy = ly[i]
                nx = -qy / dl
                ny = qx / dl
                # the centres m + t n (m the midpoint) of the empty circles through p and q: t in [lo, hi]; a point
                # j (u = m - x_j) excludes the t with a t > b: a = 2 n.u, b = |q - p|^2 / 4 - |u|^2
                lo = -cap_t
                hi = cap_t
                bad = False
                for j in range(m):
                    a = -2.0 * (nx * lx[j] + ny * ly[j])
                    b = qx * lx[j] + qy * ly[j] - ls[j]
                    if j == i:
                        a = 1.0
                        b = -1e300
                    v = b / a
                    va[j] = v
                    lo = max(lo, v if a > 0 else -np.inf)
                    hi = min(hi, v if a < 0 else np.inf)
                    bad |= (a == 0.0) & (b > 0.0)  # on the segment itself
                if small:  # decided: ends at points inside the window, or too narrow even with rho's window
                    lob = lo > delta - cap_t
                    hib = hi < cap_t - delta
                    cap_f = np.sqrt(rho * rho - 0.25 * d2)
                    u = (hi if hib else cap_f) - (lo if lob else -cap_f) > eps
                    u &= not (bad | (lob & hib))
                    undecided |= u
                    marked[q] |= u
                if bad or hi - lo <= eps:
                    continue
                xlo = -1  # the points whose circles end the interval (the first one, on a tie)
                xhi = -1
                for j in range(m):
                    if j != i:
                        if xlo < 0 and va[j] == lo and -2.0 * (nx * lx[j] + ny * ly[j]) > 0:
                            xlo = loc[j]
                        if xhi < 0 and va[j] == hi and -2.0 * (nx * lx[j] + ny * ly[j]) < 0:
                            xhi = loc[j]
                if nk < 64:
                    key = (int((xy[q, 1] - y0) / cw_order) * W_order + int((xy[q, 0] - x0) / cw_order)) * n + q
                    j = nk
                    while j > 0 and kk[j - 1] > key:
                        kk[j] = kk[j - 1]
                        kq[j] = kq[j - 1]
                        klo[j] = klo[j - 1]
                        khi[j] = khi[j - 1]
                        j -= 1
                    kk[j] = key
                    kq[j] = q
                    klo[j] = xlo
                    khi[j] = xhi
                    nk += 1
            if not (undecided or marked[p]):
                break
            n_again += small
        for e in range(nk):
            q = kq[e]
            if ne == cap:
                cap *= 2
                na_ = np.empty(cap, np.int64)
                nb_ = np.empty(cap, np.int64)
                na_[:ne] = ea[:ne]
                nb_[:ne] = eb[:ne]
                ea, eb = na_, nb_
            ea[ne] = p
            eb[ne] = q
            ne += 1
            for x in (klo[e], khi[e]):
                if x > q:  # each triangle once: from its edge of the two smaller numbers
                    if nt == tcap:
                        tcap *= 2
                        nt_ = np.empty((tcap, 3), np.int64)
                        nt_[:nt] = ta[:nt]
                        ta = nt_
                    ta[nt, 0] = p
                    ta[nt, 1] = q
                    ta[nt, 2] = x
                    nt += 1
    return ea[:ne].copy(), eb[:ne].copy(), ta[:nt].copy(), n_again


def cell_lists(uv: np.ndarray, cw: float) -> tuple[np.ndarray, np.ndarray, float, float, int, int]:
    """Points by square cell of side ``cw`` mm: ``(cells, cstart, x0, y0, W, H)``.

    The points of cell ``(cx, cy)`` (corner ``(x0 + cx cw, y0 + cy cw)``) are
    ``cells[cstart[c]:cstart[c + 1]]`` with ``c = cy * W + cx``.
    """
    cells, cstart, x0, y0, W, H = _cell_lists(np.ascontiguousarray(uv, dtype=np.float64), float(cw))
    return cells, cstart, float(x0), float(y0), int(W), int(H)


@numba.njit(cache=True)
def _cell_lists(uv, cw):  # pragma: no cover - numba
    # cell_lists in one kernel (the corner, each point's cell, then _counting_sort's order and starts)
    n = uv.shape[0]
    x0 = uv[0, 0]
    y0 = uv[0, 1]
    for i in range(1, n):
        x0 = min(x0, uv[i, 0])
        y0 = min(y0, uv[i, 1])
    cid = np.empty(n, np.int64)
    W = 1
    H = 1
    for i in range(n):
        cx = int((uv[i, 0] - x0) / cw)
        cy = int((uv[i, 1] - y0) / cw)
        W = max(W, cx + 1)
        H = max(H, cy + 1)
        cid[i] = cx
    for i in range(n):
        cid[i] += int((uv[i, 1] - y0) / cw) * W
    cells, cstart = _counting_sort(cid, W * H)
    return cells, cstart, x0, y0, W, H


@numba.njit(cache=True)
def _counting_sort(cid, ncell):  # pragma: no cover - numba
    # the stable order of the points by cell number (np.argsort(cid, kind="stable")) and each cell's start: O(n)
    cstart = np.zeros(ncell + 1, np.int64)
    for i in range(cid.shape[0]):
        cstart[cid[i] + 1] += 1
    for c in range(ncell):
        cstart[c + 1] += cstart[c]
    fill = cstart[:-1].copy()
    cells = np.empty(cid.shape[0], np.int64)
    for i in range(cid.shape[0]):
        cells[fill[cid[i]]] = i
        fill[cid[i]] += 1
    return cells, cstart


#: Longest Delaunay edge looked for (the triangles around a gap, for the cell areas), as a multiple of the
#: spacing: a longer edge's circle is wider than 1.1 h, and the sampler leaves none wider than about 0.9 h.
TRIANGLE_EDGE_FACTOR = 2.2  # = 2 x EMPTY_CIRCLE_FACTOR: no longer edge has a small enough circle
#: Largest empty circle an edge of the graph may have, as a multiple of the spacing (see _local_delaunay).
EMPTY_CIRCLE_FACTOR = 1.1
#: The first, smaller reach of _local_delaunay (circles of radius at most this multiple of the spacing, candidates
#: within twice it): the same edges and triangles as EMPTY_CIRCLE_FACTOR's, the points it cannot decide (a larger
#: empty circle nearby, the rim: 1.4 % at 10^6 points) tested again with EMPTY_CIRCLE_FACTOR.
SMALL_CIRCLE_FACTOR = 0.95


def neighbour_graph(uv: np.ndarray, spacing: float, poly,
                    cells: tuple | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The kept Delaunay edges of ``uv`` (n, 2) mm inside ``poly``, and the kept triangles.

    An edge is kept when it is at most ``EDGE_FACTOR x spacing`` long (``LEAF_EDGE_FACTOR x spacing`` at a
    point that would otherwise have one neighbour), has an empty circle of radius at most
    ``EMPTY_CIRCLE_FACTOR x spacing`` (every Delaunay edge of a near-maximal Poisson-disk set has) and its
    segment stays inside ``poly``. ``cells``: ``cell_lists(uv, spacing)`` when the caller has it (made here
    otherwise).

    Returns
    -------
    indptr : (n+1,) int64
    indices : (E2,) int64
        Symmetric CSR adjacency of the kept edges (each undirected edge twice, rows sorted).
    triangles : (T, 3) int64
        Delaunay triangles whose three edges stay inside ``poly`` (edges up to ``TRIANGLE_EDGE_FACTOR x
        spacing``; the cells of :func:`cell_areas`).
    """
    n = len(uv)
    lmax = EDGE_FACTOR * spacing
    # cells of one spacing (the set's own numbering: a row of cells is one run of points); each point's edges
    # are written in the order of the cells as wide as the reach of an empty circle (2 x its radius), as when
    # the candidates came from those (same bytes)
    cells, cstart, x0, y0, W, H = cell_lists(uv, spacing) if cells is None else cells
    cw_order = 2 * EMPTY_CIRCLE_FACTOR * spacing
    W_order = int((float(uv[:, 0].max()) - x0) / cw_order) + 1
    # edges up to TRIANGLE_EDGE_FACTOR x spacing are found so that the triangles around a gap count in the
    # cell areas; only those up to EDGE_FACTOR x spacing join the walk's graph
    ea, eb, tris, _ = _local_delaunay(uv, cells, cstart, x0, y0, float(spacing), W, H, float(cw_order), W_order,
                                      TRIANGLE_EDGE_FACTOR * spacing, EMPTY_CIRCLE_FACTOR * spacing, 1e-9 * spacing,
                                      SMALL_CIRCLE_FACTOR * spacing)
    # the exact inside test for the edges that may leave the region: an edge (at most TRIANGLE_EDGE_FACTOR x
    # spacing long, both ends inside) that crosses the boundary has an end within half its length of it
    near = _near_boundary(poly, uv, 0.5 * TRIANGLE_EDGE_FACTOR * spacing)
    k = _edges_at(ea, eb, near)
    keep = np.ones(len(ea), dtype=np.bool_)
    if len(k):
        lines = shapely.linestrings(np.stack([uv[ea[k]], uv[eb[k]]], axis=1))
        keep[k] = shapely.covers(poly, lines)
    # the triangles whose three edges are inside the region; the walk's graph: the inside edges up to lmax
    tris = _triangles_inside(tris, ea, eb, keep, n)
    # a point left with one neighbour (at the rim, or a sharp corner) gets its inside Delaunay edges up to
    # LEAF_EDGE_FACTOR x spacing: a leaf can only end a path
    short = _walk_edges(uv, ea, eb, keep, lmax, LEAF_EDGE_FACTOR * spacing)
    indptr, indices = _csr(ea, eb, short, n)
    return indptr, indices, tris


@numba.njit(cache=True)
def _edges_at(ea, eb, near):  # pragma: no cover - numba
    # the numbers of the edges (ea[i], eb[i]) with an end where near is True (np.flatnonzero(near[ea] | near[eb]))
    out = np.empty(ea.shape[0], np.int64)
    m = 0
    for i in range(ea.shape[0]):
        out[m] = i
        m += near[ea[i]] | near[eb[i]]
    return out[:m].copy()


@numba.njit(cache=True)
def _walk_edges(uv, ea, eb, keep, lmax, lleaf):  # pragma: no cover - numba
    # (E,) bool: the kept edges up to lmax, and up to lleaf at a point those leave with at most one neighbour
    n = uv.shape[0]
    d2 = np.empty(ea.shape[0])
    short = np.zeros(ea.shape[0], np.bool_)
    deg = np.zeros(n, np.int64)
    for i in range(ea.shape[0]):
        dx = uv[ea[i], 0] - uv[eb[i], 0]
        dy = uv[ea[i], 1] - uv[eb[i], 1]
        d2[i] = dx * dx + dy * dy
        if keep[i] and d2[i] <= lmax * lmax:
            short[i] = True
            deg[ea[i]] += 1
            deg[eb[i]] += 1
    for i in range(ea.shape[0]):
        if keep[i] and not short[i] and d2[i] <= lleaf * lleaf and (deg[ea[i]] <= 1 or deg[eb[i]] <= 1):
            short[i] = True
    return short


@numba.njit(cache=True)
def _csr(ea, eb, keep, n):  # pragma: no cover - numba
    # symmetric CSR adjacency (rows sorted) of the undirected edges (ea[i], eb[i]) with keep[i]: a counting sort
    indptr = np.zeros(n + 1, np.int64)
    for i in range(ea.shape[0]):
        if keep[i]:
            indptr[ea[i] + 1] += 1
            indptr[eb[i] + 1] += 1
    for p in range(n):
        indptr[p + 1] += indptr[p]
    fill = indptr[:-1].copy()
    indices = np.empty(indptr[n], np.int64)
    for i in range(ea.shape[0]):
        if keep[i]:
            indices[fill[ea[i]]] = eb[i]
            fill[ea[i]] += 1
            indices[fill[eb[i]]] = ea[i]
            fill[eb[i]] += 1
    for p in range(n):  # rows are short (about 6): an insertion sort
        for j in range(indptr[p] + 1, indptr[p + 1]):
            v = indices[j]
            i = j - 1
            while i >= indptr[p] and indices[i] > v:
                indices[i + 1] = indices[i]
                i -= 1
            indices[i + 1] = v
    return indptr, indices


@numba.njit(cache=True)
def _triangles_inside(tris, ea, eb, keep, n):  # pragma: no cover - numba
    # the triangles (rows (a < b < c) of tris, in order) whose three edges are kept: the edges (ea[i] < eb[i]) come
    # grouped by their first end in ascending order (as _local_delaunay writes them), so each edge is looked for
    # among the few of its first end, read whole (fewer mispredicted branches than stopping at the match)
    estart = np.zeros(n + 1, np.int64)
    for i in range(ea.shape[0]):
        estart[ea[i] + 1] += 1
    for p in range(n):
        estart[p + 1] += estart[p]
    out = np.empty_like(tris)
    m = 0
    for t in range(tris.shape[0]):
        ok = True
        for e in range(3):
            a = tris[t, 0] if e < 2 else tris[t, 1]
            b = tris[t, 1] if e == 0 else tris[t, 2]
            found = False
            for j in range(estart[a], estart[a + 1]):
                found |= (eb[j] == b) & keep[j]
            ok &= found
        out[m] = tris[t]
        m += ok
    return out[:m]


@numba.njit(cache=True)
def _cell_shares(uv, tri, n):  # pragma: no cover - numba
    # each triangle's circumcentric share at each corner, (|AB|^2 cot C + |AC|^2 cot B) / 8, and its angle
    area = np.zeros(n)
    angle = np.zeros(n)
    for t in range(tri.shape[0]):
        for i in range(3):
            a, b, c = tri[t, i], tri[t, (i + 1) % 3], tri[t, (i + 2) % 3]
            abx, aby = uv[b, 0] - uv[a, 0], uv[b, 1] - uv[a, 1]
            acx, acy = uv[c, 0] - uv[a, 0], uv[c, 1] - uv[a, 1]
            bcx, bcy = uv[c, 0] - uv[b, 0], uv[c, 1] - uv[b, 1]
            cross = abs(abx * acy - aby * acx)
            cot_b = (-abx * bcx - aby * bcy) / cross  # angle at B between BA and BC
            cot_c = (acx * bcx + acy * bcy) / cross  # angle at C between CA and CB
            area[a] += ((abx * abx + aby * aby) * cot_c + (acx * acx + acy * acy) * cot_b) / 8.0
            angle[a] += np.arctan2(cross, abx * acx + aby * acy)
    return area, angle


def cell_areas(uv: np.ndarray, triangles: np.ndarray, spacing: float) -> np.ndarray:
    """Voronoi cell area of each point within the kept triangles, mm^2 (rim points: the interior mean).

    Parameters
    ----------
    uv : (n, 2) float64
        Points, mm.
    triangles : (T, 3) int64
        Kept triangles of their Delaunay triangulation.
    spacing : float
        Spacing h, mm: the cell area when no point is interior (h^2).

    Returns
    -------
    (n,) float64
        Area each point stands for, mm^2.
    """
    area, angle = _cell_shares(np.ascontiguousarray(uv, dtype=np.float64),
                               np.ascontiguousarray(triangles, dtype=np.int64), len(uv))
    interior = np.abs(angle - 2 * np.pi) < 1e-6
    fill = float(area[interior].mean()) if interior.any() else spacing**2
    return np.where(interior, area, fill)
