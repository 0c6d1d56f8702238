"""The fair comparison of paths (issue 18): seeds and spread, modes, mechanisms, machine timing, rankings."""

from __future__ import annotations

import json

import numpy as np
import pytest

from polishpath.errors import ParameterError, SpecError
from polishpath.plan import plan
from polishpath.simulate import compare_planned, gaussian_tif, rotating_tool_tif
from polishpath.simulate.compare import check_comparison
from polishpath.simulate.patterns import square_region
from polishpath.simulate.machinetime import machine_timed_path
from polishpath.simulate.mechanisms import Mechanisms, parse_mechanisms, smooth_edge_tif, zero_feed_tif
from polishpath.simulate.spread import aggregate_rows, rank

SIZE, DX, H = 6.0, 0.02, 0.5  # a 6 mm patch at 20 um: small and fast
TIF = gaussian_tif(5.0, fwhm_mm=0.5)
FAIR = ("residual_band_rms_nm", "lattice_peak_db", "pvn", "suppression_ratio")


def _plans(pattern, seeds, seed=0):
    region = square_region(SIZE)
    return [plan(region, H, pattern, seed=seed + i) for i in range(seeds)]


def test_interference_free_deterministic_path_is_the_same_for_every_seed():
    from polishpath.simulate import compare_paths, flat_workpiece

    xy = _plans("raster", 1)[0].uv
    wp = flat_workpiece((-3, -3, 3, 3), DX)
    runs = [compare_paths({"raster": (xy, np.full(len(xy), 0.1))}, wp, TIF, noise=None, seed=s, spacing_mm=H,
                          depth_nm=100.0, keep_results=True) for s in (0, 1, 2)]
    maps = [r["results"]["raster"].after_nm for r in runs]
    assert np.abs(maps[1] - maps[0]).max() == 0 and np.abs(maps[2] - maps[0]).max() == 0  # zero difference
    # compare_planned relies on this: a deterministic path in interference-free mode is simulated once
    out = compare_planned({"raster": _plans("raster", 1)[0]}, seed=4, seeds=3, mode="interference-free",
                          timing="ideal", tif=TIF, dx_mm=DX)
    r = out["rows"][0]
    assert r["seeds"] == [4, 5, 6] and not r["random"]
    vals = {k: [ps[k] for ps in r["per_seed"]] for k in FAIR[:3]}
    for k, v in vals.items():  # flat start, no noise, the same path: exactly the same residual
        assert v[0] == v[1] == v[2], k
        assert r[f"{k}_min"] == r[f"{k}_max"] == r[k]
    assert r["suppression_ratio"] is None  # nothing to suppress from a flat start
    assert out["params"]["noise"] is None and out["params"]["flat_start"]
    assert r["lattice_peak_db"] > 3  # the raster prints its lattice


def test_seeds_give_different_random_paths_and_a_spread():
    plans = _plans("pseudorandom", 3, seed=7)
    assert len({p.uv.tobytes() for p in plans}) == 3  # three different paths
    out = compare_planned({"pseudorandom": plans, "raster": _plans("raster", 1)[0]}, seed=7, seeds=3,
                          mode="interference-free", timing="ideal", tif=TIF, dx_mm=DX)
    pr, ra = out["rows"]
    assert pr["random"] and out["params"]["random_patterns"] == ["pseudorandom"]
    band = [ps["residual_band_rms_nm"] for ps in pr["per_seed"]]
    assert len(set(band)) == 3
    assert pr["residual_band_rms_nm_min"] == min(band) < pr["residual_band_rms_nm_max"] == max(band)
    assert pr["residual_band_rms_nm"] == pytest.approx(np.mean(band))
    assert ra["residual_band_rms_nm_min"] == ra["residual_band_rms_nm_max"]
    assert "[" in out["table"] and "3 seeds (7, 8, 9)" in out["table"]


def test_process_mode_every_path_removes_the_same_depth_and_suppression_is_a_column():
    out = compare_planned({"raster": _plans("raster", 1)[0], "spiral": _plans("spiral", 1)[0]}, seed=1, seeds=2,
                          timing="ideal", tif=TIF, dx_mm=DX, removal_depth_nm=150.0)
    for r in out["rows"]:
        assert r["mean_depth_nm"] == 150.0 and r["depth_scale"] > 0
        for k in FAIR:  # the spread of every figure, the process noise and the start change with the seed
            assert r[f"{k}_min"] <= r[k] <= r[f"{k}_max"]
        assert r["suppression_ratio_min"] < r["suppression_ratio_max"]
    assert out["params"]["workpiece"]["seeds"] == [1, 2]
    assert "paper-style suppr." in out["table"] and "34.06 %" in out["table"]  # the paper's raster beside


def test_equal_depth_is_exact_inside_the_evaluation_window():
    from polishpath.simulate import compare_paths, flat_workpiece
    from polishpath.simulate.compare import _crop

    xy = _plans("raster", 1)[0].uv
    wp = flat_workpiece((-3, -3, 3, 3), DX)
    out = compare_paths({"a": (xy, np.full(len(xy), 0.1)), "b": (xy, np.full(len(xy), 0.37))}, wp, TIF,
                        noise=None, spacing_mm=H, depth_nm=80.0, keep_results=True)
    for name, res in out["results"].items():
        m = _crop(res.removal_nm, res.origin_mm, DX, out["params"]["eval_bounds_mm"]).astype(np.float64).mean()
        assert m == pytest.approx(80.0, rel=1e-5), name
    a, b = out["rows"]  # the same path at another time scale: the same residual once the depth is equal
    assert a["residual_band_rms_nm"] == pytest.approx(b["residual_band_rms_nm"], rel=1e-4)


def test_ranking_says_when_paths_are_not_distinguishable():
    rows = [{"name": "a", "x": 1.0, "x_min": 0.8, "x_max": 1.2},
            {"name": "b", "x": 1.3, "x_min": 1.1, "x_max": 1.5},  # overlaps a
            {"name": "c", "x": 3.0, "x_min": 2.9, "x_max": 3.1}]
    import polishpath.simulate.spread as spread

    spread.LOWER_IS_BETTER["x"] = True
    try:
        rk = rank(rows, "x")
    finally:
        del spread.LOWER_IS_BETTER["x"]
    assert rk["groups"] == [["a", "b"], ["c"]] and rk["text"] == "[a ~ b] > c"
    rows[1].update(x_min=1.25)  # no overlap any more
    assert rank(rows, "x")["text"] == "a > b > c"
    # higher is better for the suppression ratio
    per_seed = [[{"name": "p", "suppression_ratio": 0.9}, {"name": "q", "suppression_ratio": 0.2}],
                [{"name": "p", "suppression_ratio": 0.7}, {"name": "q", "suppression_ratio": 0.8}]]
    agg = aggregate_rows(per_seed, [0, 1])
    assert agg[0]["suppression_ratio_min"] == 0.7 and agg[1]["suppression_ratio_max"] == 0.8
    assert rank(agg, "suppression_ratio")["text"] == "[p ~ q]"
    assert rank([{"name": "p", "suppression_ratio": None}], "suppression_ratio")["order"] == []


def test_mechanisms_switch_off_one_at_a_time():
    assert Mechanisms().off == () and parse_mechanisms("noise, slowdown").off == ("noise", "slowdown")
    with pytest.raises(ParameterError, match="footprint"):
        parse_mechanisms("noise,magic")
    tool = rotating_tool_tif(230, 2.0, "parabolic", feed_mm_min=600)
    z = zero_feed_tif(tool, 0.02)
    k = z.kernel(0.02)
    assert np.allclose(k, k.T, rtol=1e-6, atol=1e-9 * k.max()) and np.allclose(k, k[::-1, :], atol=1e-9 * k.max())
    assert z.volume_rate == pytest.approx(tool.volume_rate, rel=1e-3)  # the same time scale
    s = smooth_edge_tif(tool)
    assert s.pressure == "gaussian" and s.volume_rate == pytest.approx(tool.volume_rate, rel=1e-6)
    out = compare_planned({"raster": _plans("raster", 1)[0]}, seeds=1, tif=TIF, dx_mm=DX,
                          mechanisms=Mechanisms().without(["noise", "smoothing", "slowdown"]))
    p = out["params"]
    assert p["noise"] is None and p["smoothing"] is None and p["timing"] == "ideal"
    assert p["mechanisms"]["off"] == ["smoothing", "noise", "slowdown"]


def test_machine_timing_runs_the_jobs_samples_and_a_profile_slows_it_down():
    pp = _plans("pseudorandom", 1, seed=2)[0]
    t = np.full(pp.n_points, 0.05)
    free, fi = machine_timed_path(pp.uv, t, pp.pieces)
    slow, si = machine_timed_path(pp.uv, t, pp.pieces, machine="examples/machine-gentle.toml")
    assert free.time_model == "moves" and fi["machine"] is None
    assert fi["machine_time_s"] >= t.sum() * 0.999  # the chord limit only slows the tool
    # the gentle profile's accelerations slow every turn: its moves take longer, by the schedule's own figure
    assert si["machine_time_s"] > 1.5 * fi["machine_time_s"]
    assert si["machine_time_s"] == pytest.approx(si["schedule"]["machining_time_s"], rel=1e-9)
    with pytest.raises(SpecError):
        machine_timed_path(pp.uv, t, pp.pieces, machine="no-such-machine")
    out = compare_planned({"pseudorandom": [pp]}, seeds=1, tif=TIF, dx_mm=DX, machine="examples/machine-gentle.toml",
                          mode="interference-free")
    r = out["rows"][0]
    assert r["time_model"] == "moves" and r["machine_timing"]["machine"] == "machine-gentle"
    assert r["machine_time_s"] > r["total_time_s"] and out["params"]["machine_profile"] == "machine-gentle"


def test_bad_choices_are_refused_before_work():
    for kw, word in (({"seeds": 0}, "seeds"), ({"seeds": 101}, "seeds"), ({"seeds": 2.5}, "seeds"),
                     ({"mode": "vacuum"}, "mode"), ({"timing": "soon"}, "timing"),
                     ({"time_model": "teleport"}, "time model")):
        args = {"seeds": 1, "mode": "process", "timing": "machine", **kw}
        with pytest.raises(ParameterError, match=word):
            check_comparison(**args)


def test_outputs_written(tmp_path):
    out = compare_planned({"raster": _plans("raster", 1)[0], "pseudorandom": _plans("pseudorandom", 2)}, seeds=2,
                          tif=TIF, dx_mm=DX, timing="ideal", out_dir=tmp_path)
    for f in ("table.txt", "results.json", "psd.png", "residuals.png", "residual_raster.png"):
        assert (tmp_path / f).stat().st_size > 0, f
    js = json.loads((tmp_path / "results.json").read_text())
    for row in js["rows"]:
        for k in FAIR:
            assert {k, f"{k}_min", f"{k}_max"} <= set(row)
    assert set(js["rankings"]) == set(FAIR)
    assert out["psds"]["raster"].params["mean_over_seeds"] == 2
