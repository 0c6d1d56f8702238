"""The one place that wires plan and map: pipeline.plan_on_surface and its step-reduction loop."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from polishpath.errors import MappingError, ParameterError, PlanningError, SpacingTooLargeError
from polishpath.flatten import boundary_region
from polishpath.mapping import map_to_surface, planar_spacing_for_surface
from polishpath.pipeline import SurfacePlan, _honour_surface_spacing, plan_on_surface
from polishpath.types import Flattening
from test_mapping_helpers import serpentine_path, spherical_cap

SQ2 = 2**0.5


@pytest.fixture(scope="module")
def squeezed():
    # a cap whose planar map shrinks lengths by 0.6: a planar grid of spacing s maps to steps up to ~1.7 s
    cap = spherical_cap()
    return Flattening(cap.surface, cap.uv * 0.6, cap.angles)


def test_replanning_loop_reduces_the_planar_spacing_until_steps_fit(squeezed):
    s = 1.0
    calls = []

    def planner(h):
        calls.append(h)
        return serpentine_path(squeezed, h)

    planar, mapped, h = _honour_surface_spacing(squeezed, s, planner, start_quantile=0.3)
    assert mapped.stats["step_max"] <= SQ2 * s * (1 + 1e-9)
    assert h == calls[-1] and planar.spacing == h
    assert mapped.stats["replans"] == len(calls) <= 8
    assert mapped.stats["step_reduction_factor"] == pytest.approx(h / s)
    assert mapped.stats["spacing"] == s
    # neighbouring dwell points (and rows) at most s apart on the part, the largest within 2 % of s: on this
    # evenly squeezed cap that is about the strict bound (the chord is a little shorter than the arc)
    assert s / 1.0201 < mapped.stats["neighbour_spacing_max"] <= s * (1 + 1e-9)
    assert h == pytest.approx(planar_spacing_for_surface(squeezed, s), rel=0.03)


def test_plan_on_surface_honours_the_spacing_on_the_part(squeezed):
    s = 1.5
    region = boundary_region(squeezed)
    res = plan_on_surface(squeezed, region, s, seed=3)
    assert isinstance(res, SurfacePlan)
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.planar_spacing = 1.0
    assert res.planar_spacing < s  # the squeeze is undone by a finer planar grid
    assert res.planar.spacing == res.planar_spacing and res.planar.provenance.seed == 3
    assert res.surface_path.planar is res.planar
    assert res.surface_path.stats["grid_step_max"] <= SQ2 * s * (1 + 1e-9)
    assert res.surface_path.stats["neighbour_spacing_max"] <= s * (1 + 1e-9)
    assert res.surface_path.stats["step_reduction_factor"] == pytest.approx(res.planar_spacing / s)
    # same inputs, same path
    again = plan_on_surface(squeezed, region, s, seed=3)
    np.testing.assert_array_equal(again.planar.uv, res.planar.uv)


def test_plan_on_surface_in_the_plane_is_the_plain_grid(squeezed):
    from polishpath.plan import plan

    region = boundary_region(squeezed)
    res = plan_on_surface(squeezed, region, 1.5, seed=3, spacing_on="plane", pattern="raster")
    assert res.planar_spacing == 1.5
    direct = plan(region, 1.5, "raster", seed=3)
    np.testing.assert_array_equal(res.planar.uv, direct.uv)
    np.testing.assert_array_equal(res.surface_path.xyz, map_to_surface(squeezed, direct).xyz)
    # on the squeezed map the plain grid's steps on the part are longer than sqrt(2) s
    assert res.surface_path.stats["step_max"] > SQ2 * 1.5


def test_plan_on_surface_refusals(squeezed):
    region = boundary_region(squeezed)
    with pytest.raises(ParameterError, match="spacing_on"):
        plan_on_surface(squeezed, region, 1.0, seed=0, spacing_on="part")
    with pytest.raises(ParameterError, match="spacing"):
        plan_on_surface(squeezed, region, -1.0, seed=0)
    with pytest.raises(PlanningError, match="dwell points where a uniform grid") as e:
        plan_on_surface(squeezed, region, 1.0, seed=0, max_oversampling=1.0)
    assert "--spacing-on plane" in str(e.value)
    with pytest.raises(PlanningError, match="dwell points"):
        plan_on_surface(squeezed, region, 1.0, seed=0, max_points=100)
    with pytest.raises(SpacingTooLargeError, match="flattened region is") as e:
        plan_on_surface(squeezed, region, 500.0, seed=0, spacing_on="plane")
    assert "smaller --spacing" in str(e.value)


def test_a_pattern_off_the_part_is_refused_with_its_name():
    from polishpath.flatten import flatten
    from polishpath.surfaces import load_surface
    from polishpath.types import Region

    flat = flatten(load_surface("hemisphere:R=10,triangles=600"), "mabf")
    region = boundary_region(flat)
    # a region larger than the flattened part: grid points outside it cannot be mapped
    big = Region(region.outer * 1.3)
    with pytest.raises(MappingError, match="the raster pattern places dwell points outside the part"):
        plan_on_surface(flat, big, 1.0, seed=0, pattern="raster", spacing_on="plane")
    with pytest.raises(MappingError, match="outside the flattened mesh") as e:
        plan_on_surface(flat, big, 1.0, seed=0, spacing_on="plane")
    assert "pattern places" not in str(e.value)
