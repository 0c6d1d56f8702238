"""The clear aperture when none is given (issue 28, item 2): the part inset by one TIF width, so that the
residual figured and reported is the one a shop quotes, not the edge band a TIF this wide cannot correct."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from polishpath.dwell import gaussian_tif, measured_tif
from polishpath.dwell.solver import tif_fwhm_mm
from polishpath.dwell.target import default_ca_margin_mm


def test_tif_width_is_the_fwhm_for_a_gaussian_and_for_the_same_gaussian_measured():
    g = gaussian_tif(3.0, fwhm_mm=5.0)
    assert tif_fwhm_mm(g) == pytest.approx(5.0, rel=1e-12)
    h = 0.1
    o = np.arange(-60, 61) * h
    X, Y = np.meshgrid(o, o)
    m = measured_tif(3.0 * np.exp(-(X**2 + Y**2) / (2 * g.params["sigma_mm"] ** 2)), h)
    assert tif_fwhm_mm(m) == pytest.approx(5.0, rel=0.03)  # sampled: the half-maximum area's disc


def test_default_margin_is_one_fwhm_and_shrinks_on_a_part_not_much_wider_than_the_tif():
    disc = shapely.Point(0, 0).buffer(20.0, 256)
    assert default_ca_margin_mm(disc, 5.0) == pytest.approx(5.0)
    assert default_ca_margin_mm(disc, 5.0, fwhms=0.5) == pytest.approx(2.5)
    # a 16 mm TIF on an R 20 mm disc would leave 4 % of it: halved until a quarter of the area is left
    m = default_ca_margin_mm(disc, 16.0)
    assert m == pytest.approx(8.0)
    assert disc.buffer(-m).area >= 0.25 * disc.area
    assert default_ca_margin_mm(disc, 32.0) == pytest.approx(8.0)
