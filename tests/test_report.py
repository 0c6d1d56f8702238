"""Tests of polishpath.report on a synthetic run folder (no other stage needed)."""

from __future__ import annotations

import base64
import gzip
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from polishpath.errors import InputError
from polishpath.meshops import corner_angles
from polishpath.report import (
    area_distortion,
    angle_error_deg,
    grid_directions,
    load_run,
    step_lengths,
    turn_angles_deg,
    write_report,
)

# the 8 neighbour moves, counter-clockwise from +i
MOVES = np.array([(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)])


def _height(x, y):
    return 0.015 * (x**2 + 0.5 * y**2)


def make_run(folder: Path, *, n_steps: int = 600, residuals: bool = True, seed: int = 3) -> Path:
    """Write a small, plausible run folder: a curved 20 x 20 mm patch, a random grid walk in 2 pieces."""
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True, exist_ok=True)
    n = 25
    x, y = np.meshgrid(np.linspace(-10, 10, n), np.linspace(-10, 10, n))
    x, y = x.ravel(), y.ravel()
    vertices = np.column_stack([x, y, _height(x, y)])
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    faces = np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    # a flattening that is not exact: a slight radial stretch
    r = np.hypot(x, y)
    uv = np.column_stack([x, y]) * (1 + 0.004 * r)[:, None]
    angles = corner_angles(uv, faces)
    spacing = 0.5
    # random walk on the grid (|i|, |j| <= 16), in two pieces
    ij = [np.array([0, 0])]
    for _ in range(n_steps):
        for _try in range(20):
            m = MOVES[rng.integers(8)]
            nxt = ij[-1] + m
            if np.abs(nxt).max() <= 16:
                break
        ij.append(nxt)
    ij = np.array(ij, dtype=np.int64)
    half = len(ij) // 2
    ij[half:] += np.array([2, 0])  # the second piece starts with a jump (a lift)
    plan_uv = ij * spacing
    xyz = np.column_stack([plan_uv, _height(plan_uv[:, 0], plan_uv[:, 1])])
    normals = np.tile([0.0, 0.0, 1.0], (len(xyz), 1))
    t = np.linspace(0, len(xyz) - 1, 5 * len(xyz))
    samples = np.column_stack([np.interp(t, np.arange(len(xyz)), xyz[:, k]) for k in range(3)])
    feed = 1000 + 30 * np.sin(t) + rng.normal(0, 5, len(t))
    arrays = dict(
        vertices=vertices, faces=faces, uv=uv, angles=angles, plan_uv=plan_uv, plan_ij=ij,
        plan_pieces=np.array([0, half, len(ij)]), plan_unreached=np.array([[7.5, 7.5], [8.0, 7.5]]),
        xyz=xyz, normals=normals, dwell_weight=np.ones(len(xyz)), samples=samples, feed_mm_min=feed,
        dwell_params=np.linspace(0, 1, len(xyz)), knots=np.r_[0, 0, 0, np.linspace(0, 1, 10), 1, 1, 1],
        control_points=xyz[:12],
        region_loop_0=np.array([[-10, -10], [10, -10], [10, 10], [-10, 10]], float) * 1.02,
        region_loop_1=np.array([[3, 3], [3, 5], [5, 5], [5, 3]], float),
    )
    if residuals:
        arrays["residual_triangle"] = rng.normal(0, 1e-9, len(faces))
        arrays["residual_vertex"] = rng.normal(0, 1e-8, 500)
        arrays["residual_wheel"] = rng.normal(0, 1e-7, 500)
    np.savez_compressed(folder / "run.npz", **arrays)
    summary = {
        "polishpath_version": "9.9.9-test",
        "config": {"surface": "paraboloid-test-patch", "method": "mabf", "pattern": "pseudorandom",
                   "spacing": spacing, "spacing_on": "surface", "seed": seed, "margin": 0.0,
                   "feed_mm_min": None, "report": True},
        "seed": seed,
        "surface": {"name": "patch", "source": "paraboloid-test-patch", "vertices": len(vertices),
                    "faces": len(faces), "boundary_loops": 1, "loop_vertices": [4 * (n - 1)],
                    "area_mm2": 412.5, "bbox_min": vertices.min(0).tolist(), "bbox_max": vertices.max(0).tolist(),
                    "findings": [{"code": "duplicate_vertices", "count": 0}]},
        "flattening": {"method": "mabf", "metrics": {"angle_error_mean_deg": 0.123456, "flips": 0},
                       "timings_s": {"angles": 0.1, "total": 0.2}, "provenance": {"stage": "flatten"}},
        "plan": {"pattern": "pseudorandom", "planar_spacing_mm": spacing, "surface_spacing_mm": spacing,
                 "step_reduction_factor": 1.0, "dwell_points": len(ij), "pieces": 2, "unreached": 2,
                 "metrics": {"direction_shares": [0.125] * 8, "crossings": 0,
                             "turn_histogram_deg": list(range(20)), "largest_empty_disc_mm": 1.2345678},
                 "stats": {"iterations": 17}, "provenance": {"seed": seed}},
        "map": {"stats": {"step_mean_mm": 0.6, "step_max_mm": 0.75, "share_in_normal_range": 0.97}},
        "smooth": {"stats": {"feed_fluctuation": 0.03, "chord_error_max_mm": 0.0007}, "samples": len(samples),
                   "period_ms": 2.0},
        "timings_s": {"surface": 0.01, "flatten": 0.2, "plan": 0.3},
    }
    (folder / "summary.json").write_text(json.dumps(summary), encoding="utf-8")
    return folder


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    return make_run(tmp_path_factory.mktemp("run") / "out")


@pytest.fixture(scope="module")
def written(run_dir) -> dict[str, Path]:
    return write_report(run_dir)


def _pixels(path: Path) -> np.ndarray:
    import matplotlib.image as mpimg

    return np.asarray(mpimg.imread(path), dtype=float)


# --- the derived quantities -------------------------------------------------------


def test_step_lengths_leave_out_lifts():
    p = np.array([[0, 0, 0], [1, 0, 0], [1, 2, 0], [10, 2, 0], [10, 3, 0]], float)
    np.testing.assert_allclose(step_lengths(p), [1, 2, 9, 1])
    np.testing.assert_allclose(step_lengths(p, np.array([0, 3, 5])), [1, 2, 1])


def test_grid_directions_and_turns():
    # E, E, NE, N, W, SW, then a lift, then S
    ij = np.array([(0, 0), (1, 0), (2, 0), (3, 1), (3, 2), (2, 2), (1, 1), (5, 5), (5, 4)])
    counts, other = grid_directions(ij, np.array([0, 7, 9]))
    assert counts.tolist() == [2, 1, 1, 0, 1, 1, 1, 0] and other == 0
    counts, other = grid_directions(ij)  # without pieces the lift is a non-neighbour step
    assert other == 1 and counts.sum() == 7
    t = turn_angles_deg(ij, np.array([0, 7, 9]))
    # E->E 0, E->NE +45, NE->N +45, N->W +90, W->SW +45
    assert t.tolist() == [0, 45, 45, 90, 45]
    # a right turn is negative; a reversal is 180
    assert turn_angles_deg(np.array([(0, 0), (1, 0), (1, -1), (1, 0)])).tolist() == [-90, 180]


def test_flattening_distortion_zero_for_a_similarity():
    rng = np.random.default_rng(0)
    v2 = rng.uniform(-5, 5, (30, 2))
    from scipy.spatial import Delaunay

    f = Delaunay(v2).simplices
    v3 = np.column_stack([v2, np.zeros(len(v2))])
    uv = 3.0 * v2 @ np.array([[0.0, -1.0], [1.0, 0.0]])  # rotated and scaled
    ang = corner_angles(uv, f)
    assert np.nanmax(np.abs(area_distortion(v3, f, uv))) < 1e-9
    assert angle_error_deg(v3, f, ang).max() < 1e-9
    # a stretch is seen
    uv2 = v2 * np.array([1.5, 1.0])
    assert angle_error_deg(v3, f, corner_angles(uv2, f)).max() > 1.0


# --- the report ---------------------------------------------------------------------


def test_every_png_written_and_not_blank(written):
    pngs = {k: p for k, p in written.items() if k.startswith("figure_")}
    expected = {"surface_path", "angle_error", "area_distortion", "residuals", "planar_path",
                "step_lengths", "directions", "turn_angles", "feed_rate"}
    assert {k[len("figure_"):] for k in pngs} == expected
    for name, p in pngs.items():
        assert p.parent.name == "figures" and p.suffix == ".png"
        assert p.stat().st_size > 5000, name
        px = _pixels(p)
        assert px.ndim == 3 and px.shape[0] > 200 and px.shape[1] > 200, name
        assert px[..., :3].var() > 1e-3, f"{name} looks blank"


def test_report_is_self_contained(written):
    html = written["report"].read_text(encoding="utf-8")
    assert written["report"].name == "report.html"
    # nothing loaded from the network: no script/link/img/iframe source on http(s)
    for tag, attr in (("script", "src"), ("link", "href"), ("img", "src"), ("iframe", "src")):
        bad = re.findall(rf"<{tag}\b[^>]*\b{attr}\s*=\s*[\"']?\s*(?:https?:)?//", html, flags=re.I)
        assert not bad, f"{tag} {attr} from the network: {bad[:2]}"
    assert "cdn.plot.ly" not in html
    # plotly.js is embedded, once, and unpacks to the real bundle
    m = re.findall(r'<script type="application/octet-stream" id="plotly-gz">([^<]+)</script>', html)
    assert len(m) == 1
    js = gzip.decompress(base64.b64decode(m[0])).decode("utf-8")
    assert len(js) > 1_000_000 and "newPlot" in js
    # both interactive views have their data; every static figure is inline
    assert html.count('class="plot" data-fig=') == 2
    for key in ("figdata-surface_3d", "figdata-planar_2d"):
        m = re.search(rf'<script type="application/json" id="{key}">(.*?)</script>', html, flags=re.S)
        spec = json.loads(m.group(1).replace("<\\/", "</"))
        assert spec["data"] and "layout" in spec
    assert html.count("data:image/png;base64,") >= 7


def test_report_shows_header_parameters_and_every_figure(written, run_dir):
    html = written["report"].read_text(encoding="utf-8")
    summary = json.loads((run_dir / "summary.json").read_text())
    assert "9.9.9-test" in html and "paraboloid-test-patch" in html
    assert re.search(r"<b>seed</b>\s*3\b", html)
    # every leaf of summary.json has a row
    from polishpath.report.html import flatten_items

    import html as _html

    from polishpath.report.html import fmt_value

    for key, value in flatten_items(summary):
        section, _, rest = key.partition(".")
        row = rest if isinstance(summary[section.split("[")[0]], dict) else key
        cell = _html.escape(fmt_value(value), quote=True)
        th = f"<tr><th>{_html.escape(row)}</th><td>"
        assert th + cell in html or th + f"<details><summary>{cell}" in html, key
    # long lists are shortened in the row but kept whole underneath
    assert _html.escape(json.dumps(list(range(20)))) in html
    assert "1.23457" in html  # largest_empty_disc_mm to 6 significant digits
    # the normal range and the smoothed-curve switch are there
    assert "Smoothed curve" in html and "Dwell points" in html


def test_interactive_3d_colours_by_order_and_toggles(run_dir):
    from polishpath.report.interactive import plot_surface_3d

    fig, notes = plot_surface_3d(load_run(run_dir))
    names = [t.name for t in fig.data]
    assert names[0] == "surface" and any("smoothed" in n for n in names)
    path = fig.data[1]
    order = np.asarray(path.line.color, dtype=float)
    assert order.min() == 0.0 and order.max() == pytest.approx(1.0) and np.all(np.diff(order) >= 0)
    assert np.isnan(np.asarray(path.x, dtype=float)).sum() == 1  # one lift between the two pieces
    vis = [b.args[0]["visible"] for b in fig.layout.updatemenus[0].buttons]
    assert vis[0] != vis[1] and len({len(v) for v in vis}) == 1
    assert notes == []  # nothing decimated at this size


def test_large_paths_are_decimated_for_display_and_say_so(tmp_path):
    from polishpath.report import interactive

    run = load_run(make_run(tmp_path / "big", n_steps=300))
    old = interactive.MAX_POINTS_3D, interactive.MAX_FACES_3D
    interactive.MAX_POINTS_3D, interactive.MAX_FACES_3D = 100, 300
    try:
        fig, notes = interactive.plot_surface_3d(run)
    finally:
        interactive.MAX_POINTS_3D, interactive.MAX_FACES_3D = old
    assert len(fig.data[1].x) <= 101 and len(fig.data[0].i) <= 300
    assert any("100 of 301 dwell points" in n for n in notes)
    assert any("triangles" in n for n in notes)


def test_report_without_optional_arrays(tmp_path, written, run_dir, monkeypatch):
    # a rebuild of a copied run whose flattening solved no angles (LSCM): no residuals, no samples
    from polishpath.report.figures import FIGURES

    for name, (fn, cap) in list(FIGURES.items()):  # keep the test fast: the figures at stake only
        if name not in ("residuals", "planar_path", "feed_rate"):
            monkeypatch.setitem(FIGURES, name, (lambda run: "skipped in this test", cap))
    d = tmp_path / "lscm"
    shutil.copytree(run_dir, d)
    assert (d / "figures" / "residuals.png").exists()
    with np.load(d / "run.npz") as z:
        arrays = {k: z[k] for k in z.files if not k.startswith("residual_") and k not in ("samples", "plan_unreached")}
    arrays["plan_unreached"] = np.zeros((0, 2))
    np.savez(d / "run.npz", **arrays)
    s = json.loads((d / "summary.json").read_text())
    s["flattening"]["method"] = "lscm"
    (d / "summary.json").write_text(json.dumps(s))
    out = write_report(d)
    assert out["report"] == d / "report.html"
    assert set(out) == {"report", "figure_planar_path", "figure_feed_rate"}
    # the stale PNG of the earlier report is gone, not left to mislead
    assert "figure_residuals" not in out and not (d / "figures" / "residuals.png").exists()
    assert "figure_planar_path" in out
    html = out["report"].read_text(encoding="utf-8")
    assert "lscm solves no angle constraints" in html
    assert "No simulation in this run folder" in html
    assert "Smoothed curve" not in html  # no samples: nothing to toggle
    assert not list(d.glob(".*.tmp")) and not list((d / "figures").glob(".*.tmp"))


def test_simulation_results_are_embedded(tmp_path):
    from polishpath.report import build_html
    from polishpath.report.figures import _figure

    d = make_run(tmp_path / "sim", n_steps=80)
    sim = d / "simulation"
    sim.mkdir()
    fig = _figure(3, 2)
    ax = fig.add_subplot()
    ax.loglog([1, 2, 3], [3, 2, 1])
    fig.savefig(sim / "psd.png")
    (sim / "table.txt").write_text("path        PSD mean   suppression\nrandom-TABLE  1.0e-3   61%\n")
    (sim / "results.json").write_text(json.dumps({"rows": [{"name": "pseudorandom", "psd_mean": 0.00123}]}))
    (sim / "broken.png").write_bytes(b"")  # defensive: an empty file must not break the report
    html = build_html(load_run(d), {})  # the page alone, without drawing the PNGs
    assert "random-TABLE" in html and "psd_mean" in html and "psd.png" in html
    assert "No simulation in this run folder" not in html
    assert html.count("data:image/png;base64,") == 1  # psd.png; the empty broken.png is left out
    # without a simulation the section says how to get one
    shutil.rmtree(sim)
    assert "No simulation in this run folder" in build_html(load_run(d), {})


def test_not_a_run_folder(tmp_path):
    with pytest.raises(InputError, match=r"no summary\.json.*polishpath plan"):
        write_report(tmp_path)
    with pytest.raises(InputError, match="not a folder"):
        write_report(tmp_path / "nope")
    (tmp_path / "summary.json").write_text("{not json")
    with pytest.raises(InputError, match="cannot be read"):
        write_report(tmp_path)
    (tmp_path / "summary.json").write_text("{}")
    with pytest.raises(InputError, match="run.npz"):
        write_report(tmp_path)


# --- the browser test -----------------------------------------------------------------

CHROMIUM = shutil.which("chromium") or ("/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else None)


@pytest.mark.browser
@pytest.mark.skipif(CHROMIUM is None, reason="headless chromium not installed (apt-get install chromium)")
def test_report_opens_in_headless_chromium(written, tmp_path):
    playwright = pytest.importorskip("playwright.sync_api", reason="the playwright python package is not installed")
    errors: list[str] = []
    shot = tmp_path / "report.png"
    with playwright.sync_playwright() as p:
        browser = p.chromium.launch(
            executable_path=CHROMIUM, headless=True,
            args=["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--use-angle=swiftshader", "--enable-unsafe-swiftshader"],
        )
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 2000})
            page.on("console", lambda m: errors.append(f"console.{m.type}: {m.text}") if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(f"page error: {e}"))
            requests: list[str] = []
            page.on("request", lambda r: requests.append(r.url))
            page.goto(written["report"].resolve().as_uri(), wait_until="load")
            page.wait_for_selector("body[data-plots-ready='2']", timeout=60_000)
            n_plots = page.locator("div.plot .main-svg").count()
            page.screenshot(path=str(shot), full_page=False)
        finally:
            browser.close()
    assert not errors, errors
    assert n_plots >= 2
    assert all(u.startswith(("file:", "data:", "blob:", "about:")) for u in requests), requests
    px = _pixels(shot)
    assert px[..., :3].var() > 1e-3, "screenshot is blank"


def test_a_malformed_array_costs_one_figure_not_the_report(tmp_path, monkeypatch):
    from polishpath.report.figures import FIGURES

    d = make_run(tmp_path / "bad", n_steps=60)
    with np.load(d / "run.npz") as z:
        arrays = {k: z[k] for k in z.files}
    arrays["feed_mm_min"] = np.ones((3, 3, 3))  # nonsense shape
    arrays["xyz"] = np.ones(5)  # and no usable 3D path
    np.savez(d / "run.npz", **arrays)
    for name, (fn, cap) in list(FIGURES.items()):  # keep the test fast: draw only two figures
        if name not in ("feed_rate", "turn_angles"):
            monkeypatch.setitem(FIGURES, name, (lambda run: "skipped in this test", cap))
    with pytest.warns(RuntimeWarning) as rec:
        out = write_report(d)
    said = " ".join(str(w.message) for w in rec)
    assert "'feed_rate'" in said and "'surface_3d'" in said
    assert set(out) == {"report", "figure_turn_angles"}
    html = out["report"].read_text(encoding="utf-8")
    assert "Not shown: could not be drawn from this run" in html
    assert "Interactive view could not be drawn" in html  # the 3D view, from the broken xyz
    assert 'data-fig="figdata-planar_2d"' in html  # the planar view is unharmed


def test_every_figure_of_a_large_path_is_decimated_and_the_page_says_so(tmp_path, monkeypatch):
    from polishpath.report import figures

    d = make_run(tmp_path / "big", n_steps=300)
    run = load_run(d)
    monkeypatch.setattr(figures, "MAX_PATH_POINTS_PNG", 100)
    monkeypatch.setattr(figures, "MAX_PATH_POINTS_PNG_3D", 50)
    monkeypatch.setattr("polishpath.report.digest.FEED_BINS", 10)
    planar = figures.fig_planar_path(run)
    assert "100 of 301 dwell points" in figures.display_note(planar)
    assert len(planar.axes[0].collections[0].get_segments()) <= 100
    assert "50 of 301 dwell points" in figures.display_note(figures.fig_surface_path(run))
    n = len(run.get("feed_mm_min"))
    if n > 20:
        assert "10 bins" in figures.display_note(figures.fig_feed_rate(run))
    out = write_report(d)
    page = out["report"].read_text()
    assert "Drawn: 100 of 301 dwell points" in page and "Drawn: 50 of 301 dwell points" in page


def test_a_small_path_is_drawn_whole_without_a_note(run_dir):
    from polishpath.report import figures

    run = load_run(run_dir)
    assert figures.display_note(figures.fig_planar_path(run)) is None
