"""What makes a comparison case fast and small gives the same numbers (issue 29 item 3: memory and time).

* a rotating tool's removal splats only the samples that reach the patch and one coefficient column per run
  of equal speed and heading (simulate/removal.py);
* a process keeps the last start it drew and the PSD of a read-only window (simulate/cases.py, profile.py);
* the default worker count is capped by the memory available (simulate/cases.py).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from polishpath.simulate import profile as profile_mod
from polishpath.simulate.cases import Case, CaseRunner, Start, workers_for_memory
from polishpath.simulate.profile import profile_psd
from polishpath.simulate.removal import _runs, _splat_matrix, _touches_grid, rasterize_time

SHAPE = (40, 50)
ORIGIN = np.array([1.0, -2.0])
DX = 0.1


def _samples(n=20_000, seed=0):
    rng = np.random.default_rng(seed)
    # positions from well outside the grid to well inside, and some exactly on its edges
    xy = np.column_stack([rng.uniform(-1.0, 8.0, n), rng.uniform(-4.0, 4.0, n)])
    xy[:150, 1] = ORIGIN[1] + 1.0  # rows inside the grid
    xy[:50, 0] = ORIGIN[0] - DX / 2  # half a pixel left of the first column: its right corners are on the grid
    xy[50:100, 0] = ORIGIN[0] - DX - 1e-9  # just beyond a pixel: nothing on the grid
    xy[100:150, 1] = ORIGIN[1] + SHAPE[0] * DX  # a pixel above the last row: nothing on the grid
    return xy, rng.uniform(0.0, 1.0, n)


def test_samples_that_do_not_reach_the_grid_add_nothing_to_it():
    xy, t = _samples()
    keep = _touches_grid(xy, SHAPE, ORIGIN, DX)
    assert 0 < keep.sum() < len(keep)
    assert keep[:50].all() and not keep[50:150].any()
    full, lost_full = rasterize_time(xy, t, SHAPE, ORIGIN, DX)
    kept, lost_kept = rasterize_time(xy[keep], t[keep], SHAPE, ORIGIN, DX)
    np.testing.assert_array_equal(kept, full)  # the same sums, pixel by pixel
    assert lost_kept + t[~keep].sum() == pytest.approx(lost_full, rel=1e-12)


def test_a_run_of_equal_coefficients_splats_as_its_samples_do():
    xy, t = _samples(5000, seed=1)
    speed = np.repeat(np.arange(250) % 7, 20).astype(float)  # runs of 20 samples (some neighbours equal)
    heading = np.repeat(np.arange(250) % 5, 20).astype(float)
    run, first = _runs(speed, heading)
    assert run[0] == 0 and np.all(np.diff(run) >= 0) and len(first) == run[-1] + 1
    assert np.all(speed == speed[first][run]) and np.all(heading == heading[first][run])
    c = np.random.default_rng(2).standard_normal((3, len(first)))  # coefficients per run
    grouped = _splat_matrix(xy, SHAPE, ORIGIN, DX, weights=t, columns=run, n_columns=len(first)) @ c.T
    per_sample = _splat_matrix(xy, SHAPE, ORIGIN, DX) @ (c[:, run] * t[None, :]).T
    np.testing.assert_allclose(grouped, per_sample, rtol=1e-12, atol=1e-12 * np.abs(per_sample).max())


def test_a_start_drawn_again_is_the_same_object_and_another_seed_is_not():
    a = Start("synthetic", (0.0, 0.0, 1.0, 1.0), 0.05, 2.0, 2.5, (0.2, 100.0), 4)
    w1, w2 = a.build(), a.build()
    assert w1 is w2 and not w1.height_nm.flags.writeable
    b = Start("synthetic", (0.0, 0.0, 1.0, 1.0), 0.05, 2.0, 2.5, (0.2, 100.0), 5)
    w3 = b.build()
    assert w3 is not w1 and not np.array_equal(w3.height_nm, w1.height_nm)
    assert np.array_equal(a.build().height_nm, w1.height_nm)  # drawn again from its seed: the same map


def test_the_psd_of_a_read_only_window_is_reused_and_a_writeable_map_is_not():
    z = np.random.default_rng(3).standard_normal((64, 64))
    z.setflags(write=False)
    profile_mod._PSD_CACHE.clear()
    p1 = profile_psd(z[2:34, 3:35], 0.01)
    p2 = profile_psd(z[2:34, 3:35], 0.01)
    assert p2 is p1
    p3 = profile_psd(z[2:34, 4:36], 0.01)  # another window of the same map
    assert p3 is not p1 and not np.array_equal(p3.psd, p1.psd)
    w = np.array(z)  # writeable: could change under a cache
    q1 = profile_psd(w[2:34, 3:35], 0.01)
    assert q1 is not p1 and np.array_equal(q1.psd, p1.psd)
    w[5, 5] += 1.0
    assert not np.array_equal(profile_psd(w[2:34, 3:35], 0.01).psd, p1.psd)


def _case(patch_mm=20.0, dx=0.005, path_mm=20_000.0):
    xy = np.column_stack([np.linspace(0, path_mm, 1001), np.zeros(1001)])
    return Case("p", 0, (xy, np.ones(1001), np.array([0, 1001]), "moves"),
                Start("synthetic", (0.0, 0.0, patch_mm, patch_mm), dx), None, None, None)


def test_a_case_estimates_its_peak_memory_from_its_pixels_and_its_path_samples():
    big = _case().peak_bytes()
    assert 1.0e9 < big < 4.0e9  # the hemisphere comparison's case: 16 M pixels, 8 M samples (measured 1.4 GB)
    assert _case(patch_mm=10.0).peak_bytes() < big and _case(path_mm=5000.0).peak_bytes() < big


def test_the_default_workers_are_capped_by_the_memory_available(monkeypatch, capsys):
    import polishpath.simulate.cases as cases

    monkeypatch.setattr(cases, "available_cores", lambda: 8)
    monkeypatch.setattr(cases, "available_memory", lambda: 10 * 2**30)
    case_bytes = 3 * 2**30
    assert workers_for_memory(case_bytes) == 2  # 75 % of 10 GB holds two cases of 3 GB
    assert workers_for_memory(case_bytes, available=2**30) == 1  # never fewer than one
    assert CaseRunner().n_workers(20, case_bytes) == 2
    err = capsys.readouterr().err
    assert "instead of 8" in err and "3.0 GB" in err and "--workers" in err
    assert CaseRunner().n_workers(20, 2**20) == 8  # small cases: every core, no note
    assert CaseRunner().n_workers(3, 2**20) == 3  # never more than the cases
    assert CaseRunner(workers=6).n_workers(20, case_bytes) == 6  # asked for: as asked
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("q", [1, 4, 7])
def test_the_wide_box_holds_every_sample_that_reaches_the_coarse_grid(q):
    from polishpath.simulate.removal import _coarse_factor

    class Tool:
        contact_radius_mm = 2.0

    assert _coarse_factor(Tool(), DX, q * DX) == q
    ny, nx = SHAPE
    nyc, nxc = (ny - 1 + q - 1) // q + 1, (nx - 1 + q - 1) // q + 1  # as _rotating_removal
    xy, _ = _samples(50_000, seed=q)
    coarse = _touches_grid(xy, (nyc, nxc), ORIGIN, q * DX)
    fine = _touches_grid(xy, SHAPE, ORIGIN, DX)
    box = _touches_grid(xy, SHAPE, ORIGIN, DX, margin_px=2.0 * q + 1.0)
    assert np.all(box[coarse]) and np.all(box[fine])
    assert box.sum() < len(box)


def test_a_rotating_tool_comparison_is_the_same_bytes_with_one_and_two_workers(tmp_path):
    """The rotating tool's removal (the patch's samples, one column per run) as a pure function of each case."""
    from typer.testing import CliRunner

    from polishpath.cli import app

    args = ["simulate", "hemisphere:R=12,triangles=700", "--patterns", "pseudorandom,raster", "--spacing", "1",
            "--patch", "8", "--dx", "0.05", "--seed", "2", "--seeds", "2", "-q"]
    outs = []
    for w in (1, 2):
        out = tmp_path / f"w{w}"
        r = CliRunner().invoke(app, [*args, "--workers", str(w), "-o", str(out)])
        assert r.exit_code == 0, r.output
        outs.append(((out / "results.json").read_bytes(), (out / "table.txt").read_bytes()))
    assert outs[0] == outs[1]
    js = json.loads(outs[0][0])
    assert js["params"]["tif"]["kind"] == "rotating"  # the rotating tool (the default), not a Gaussian TIF
