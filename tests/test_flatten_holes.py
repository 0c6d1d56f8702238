"""MABF on meshes with holes: which weights "auto" starts from."""

from __future__ import annotations

import numpy as np

from polishpath import meshops
from polishpath.flatten import flatten
from test_flatten import sphere_with_slot, surface


def test_folded_fans_are_stiffened_without_a_light_fan_attempt(monkeypatch):
    # folded fans are found from the 3D angle sums, so "auto" goes straight to the stiff
    # fans (the light-fan attempt, a direct solve of the coupled system, was thrown away)
    from polishpath.flatten import mabf
    from polishpath.flatten.topology import corner_tables, fill_holes

    def folded(s):
        vf, ff, _ = fill_holes(s.vertices, s.faces, meshops.boundary_loops(s.faces))
        fw = np.ones(len(ff))
        fw[len(s.faces):] = 0.01
        return mabf.folded_fan_vertices(corner_tables(len(vf), ff), mabf._corner_angles(vf, ff), fw)

    assert folded(sphere_with_slot(3000)) > 0
    assert folded(surface("cap", n_rings=8, hole=3.0)) == 0  # a round hole: its fan lies flat
    calls = []
    solve = mabf._mabf_solve
    monkeypatch.setattr(mabf, "_mabf_solve", lambda *a, **k: calls.append(a[2]) or solve(*a, **k))
    fl = flatten(sphere_with_slot(3000), "mabf")
    assert calls == ["inverse_square"] and fl.provenance.params["hole_fans_stiffened"]
    calls.clear()
    flatten(surface("cap", n_rings=8, hole=3.0), "mabf")
    assert calls == ["uniform"]
