"""What every fit of the dwell points (polishpath.simulate.densityfit, .ripplefit) promises, checked one way."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree
from shapely.geometry import LineString

from polishpath.plan import plan
from polishpath.simulate.compare import _dwell_s_per_point
from polishpath.simulate.patterns import square_region
from polishpath.simulate.rotating import default_tif


def relaxed_walk_case(size_mm: float = 14.0, h: float = 0.5, seed: int = 0):
    """The fits' test case: the relaxed walk over a square, the comparison's tool (scaled for 200 nm) and its
    equal dwell time per point: ``(planned PlanarPath, times (N,) s, tif)``."""
    p = plan(square_region(size_mm), h, "pseudorandom", seed=seed, dwell_points="relaxed")
    t0, tif, _ = _dwell_s_per_point(default_tif(), h, 200.0)
    return p, np.full(p.n_points, t0), tif


def assert_fit_keeps_guarantees(planned_xy, pieces, fitted_xy, h: float) -> None:
    """No point more than 0.3 h from its planned place, none nearer than 0.7 h to another (or than the planned
    set already was), no step over 2 h within a piece, no piece crossing itself; the same shape (order kept)."""
    q, p0 = np.asarray(fitted_xy), np.asarray(planned_xy)
    assert q.shape == p0.shape
    assert np.hypot(*(q - p0).T).max() <= 0.3 * h + 1e-12
    nn0 = cKDTree(p0).query(p0, 2)[0][:, 1]
    nn = cKDTree(q).query(q, 2)[0][:, 1]
    assert nn.min() >= min(0.7 * h, nn0.min()) - 1e-12
    pcs = np.asarray(pieces)
    for a, b in zip(pcs[:-1], pcs[1:]):
        assert np.hypot(*np.diff(q[a:b], axis=0).T).max() <= 2 * h + 1e-12
        assert LineString(q[a:b]).is_simple
