"""``polishpath.paper.reproduce`` (issue 9): the paper's tables and figures, regenerated, beside its numbers.

One reduced run (``quick=True``) is shared by all checks. Nothing here asserts on
time: the machine is shared. The shared meshes folder is ``$POLISHPATH_MESHES``,
else the one of conftest.py (``$POLISHPATH_SHARED/data/meshes``, default
``../shared/data/meshes`` beside the checkout); the checks that need it skip when
it is absent.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest

from polishpath.errors import InputError, ParameterError
from polishpath.paper import MESHES_ENV, PAPER, meshes_folder, reproduce

_MESHES = Path(os.environ.get(MESHES_ENV)
               or Path(os.environ.get("POLISHPATH_SHARED", Path(__file__).resolve().parents[1].parent / "shared"))
               / "data" / "meshes")
MESHES = _MESHES if _MESHES.is_dir() else None

FIGURES = ["fig02_residuals", "fig03_flattening", "fig05_seat_plane", "fig06_seat_path", "fig07_seat_nurbs",
           "fig08_peer_paths", "fig09_hemisphere_paths", "fig10_cases", "fig13_psd"]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper")
    res = reproduce(out, quick=True, seed=0, meshes=MESHES)
    return out, res, (out / "paper.md").read_text(encoding="utf-8"), (out / "paper.html").read_text(encoding="utf-8")


def test_no_section_failed(run):
    _, res, md, _ = run
    assert res["errors"] == {}, res["errors"]
    assert "failed on this run" not in md


def test_every_table_is_there(run):
    _, res, md, _ = run
    for title in ("## Table 1", "## Table 2", "## Table 3", "## Table 4", "## Fig. 10", "## Figs. 5-7"):
        assert title in md
    assert {r["case"] for r in res["table1"]} == set(PAPER["table1"])
    assert {r["method"] for r in res["table2"]} == {"projection", "mabf_plain", "mabf_honoured"}
    assert {r["pattern"] for r in res["table3"]["rows"]} >= set(PAPER["table3"])
    assert {r["path"] for r in res["table4"]["rows"]} == set(PAPER["table4"])


def test_measured_numbers_are_sane(run):
    _, res, _, _ = run
    for r in res["table1"]:
        assert r["mabf_s"] > 0 and np.isfinite(r["err_mabf_deg"]) and r["flips_mabf"] == 0
    hemi = next(r for r in res["table1"] if r["case"] == "hemisphere")
    assert np.isfinite(hemi["abf_s"]) and abs(hemi["err_abf_deg"] - hemi["err_mabf_deg"]) < 0.1
    hon = next(r for r in res["table2"] if r["method"] == "mabf_honoured")
    assert hon["step_max"] <= np.sqrt(2) * res["settings"]["table2_spacing"] * (1 + 1e-6)
    for r in res["table3"]["rows"]:
        assert r["crossings"] == 0
    for r in res["table4"]["rows"]:
        assert np.isfinite(r["suppression"])
    for r in res["fig10"]:
        assert r["nurbs_dev_mm"] < 1e-6 and r["step_max_over_s"] <= np.sqrt(2) + 1e-6


def test_paper_reference_numbers_printed_beside_ours(run):
    _, _, md, _ = run
    # Table 1: the paper's MATLAB times
    for _, pm, pa in PAPER["table1"].values():
        assert f"{pm:.2f}" in md and f"{pa:.2f}" in md
    # Table 2
    assert "0.85325 / 2,836 / 3.6189" in md and "0.5283 / 7,017 / 0.8592" in md
    assert "Why the dwell-point counts differ" in md
    # Table 3: the paper's claims in brackets, e.g. "(6/8)" and "(N)"
    for dof in ("(6/8)", "(4/8)", "(8/8)"):
        assert dof in md
    # Table 4: the paper's measured ratios, and the model's assumptions
    for v in ("34.06 %", "46.86 %", "53.06 %", "96.64 %"):
        assert v in md
    assert "Model assumptions" in md


def test_figures_written_and_linked(run):
    out, res, md, _ = run
    for name in FIGURES:
        p = out / "figures" / f"{name}.png"
        assert p.exists() and p.stat().st_size > 10_000, name
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert f"](figures/{name}.png)" in md
        assert res["figures"][name] == p


def test_machine_and_version_stated(run):
    _, res, md, html = run
    m = res["machine"]
    for doc in (md, html):
        assert m["node"] in doc and f"polishpath {m['polishpath']}" in doc and f"{m['cpus']} CPUs" in doc


def test_html_is_self_contained(run):
    _, _, md, html = run
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", html, flags=re.I)
    assert not re.search(r"""\]\(\s*https?://""", md)
    assert html.count("src='data:image/png;base64,") == len(FIGURES)
    assert "<table>" in html and "96.64 %" in html


def test_bunny_patch(run):
    if MESHES is None or not (MESHES / "stanford-bunny.obj").exists():
        pytest.skip(f"the shared meshes ({_MESHES}) are not on this machine; set ${MESHES_ENV} to run this check")
    _, res, md, _ = run
    assert res["bunny"]["boundary_loops"] == 1 and res["bunny"]["faces"] > 100
    assert any("rabbit" in r["case"] for r in res["fig10"])
    assert "geodesic" in md


def test_no_meshes_folder_skips_the_rabbit_with_a_note(tmp_path, monkeypatch):
    from polishpath.paper.cases import figures_cases
    from polishpath.paper.figures import FigureSet
    from polishpath.paper.settings import settings_for
    from polishpath.report.html import Document

    monkeypatch.delenv(MESHES_ENV, raising=False)
    assert meshes_folder(None) is None
    st = settings_for(True, None)
    doc, res = Document(), {}
    figures_cases(doc, FigureSet(tmp_path, "figures", {"polishpath": "x", "node": "n", "processor": "p", "cpus": 1}, 0),
                  st, res, 0)
    md = doc.markdown()
    assert "The rabbit (f) was skipped: no shared meshes folder was given" in md and MESHES_ENV in md
    assert "bunny" not in res and not any("rabbit" in r["case"] for r in res["fig10"])


def test_missing_meshes_folder_is_an_input_error(tmp_path, monkeypatch):
    with pytest.raises(InputError, match="does not exist"):
        meshes_folder(tmp_path / "nowhere")
    monkeypatch.setenv(MESHES_ENV, str(tmp_path / "nowhere"))
    with pytest.raises(InputError, match=MESHES_ENV):
        meshes_folder(None)
    assert meshes_folder(tmp_path) == tmp_path


def test_bad_seed():
    with pytest.raises(ParameterError):
        reproduce(Path("unused"), quick=True, seed=-1)


def test_table3_is_measured_in_one_place():
    """The benchmark imports the package's measuring (no second copy), and the paper's rows come from it."""
    import ast

    bench = Path(__file__).resolve().parents[1] / "benchmarks" / "table3.py"
    tree = ast.parse(bench.read_text(encoding="utf-8"))
    imported = {(n.module, a.name) for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) for a in n.names}
    assert ("polishpath.paper.table3", "measure_surface") in imported
    assert ("polishpath.paper.table3", "verdict") in imported
    called = {n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)}
    assert "measure_surface" in called
    for banned in ("plan", "map_to_surface", "honour_surface_spacing", "flatten"):
        assert banned not in called, banned


def test_measure_surface_rows_and_errors():
    from polishpath.paper.table3 import measure_surface, verdict
    from polishpath.surfaces import load_surface

    s = load_surface("hemisphere:R=30,triangles=600")
    m = measure_surface(s, 4.0, seed=1, patterns=("mabf", "hilbert"), spacing_on="plane", label="h")
    assert m["planar_spacing"] == 4.0 and [r["pattern"] for r in m["rows"]] == ["mabf", "hilbert"]
    for r in m["rows"]:
        assert r["surface"] == "h" and r["crossings"] == 0 and 0 < r["coverage"] <= 1
        assert r["through_mm"] < 1e-6 and r["accuracy_dev_mm"] == r["through_mm"]
        assert 0 < r["area_within_s"] <= 1 and r["inner_gap_mm"] >= 0
        assert verdict(r)[4] == "Y"
    with pytest.raises(ParameterError, match="unknown Table 3 pattern"):
        measure_surface(s, 4.0, seed=1, patterns=("spiralz",))
    with pytest.raises(ParameterError, match="spacing_on"):
        measure_surface(s, 4.0, seed=1, spacing_on="part")
    # a pattern that cannot plan becomes an error row when asked to, and raises otherwise
    rows = measure_surface(s, 500.0, seed=1, patterns=("unicursal",), spacing_on="plane", errors="row")["rows"]
    assert "error" in rows[0]


def test_cli_names_a_missing_meshes_folder(tmp_path):
    from typer.testing import CliRunner

    from polishpath.cli import app

    r = CliRunner().invoke(app, ["paper", "-o", str(tmp_path / "out"), "--quick", "-q", "--meshes",
                                 str(tmp_path / "nowhere")])
    assert r.exit_code == 2
    assert "does not exist" in r.output and "--meshes" in r.output and "Traceback" not in r.output


def test_measure_surface_error_rows_when_the_paper_path_fails():
    from polishpath.paper.table3 import measure_surface
    from polishpath.surfaces import load_surface

    s = load_surface("hemisphere:R=30,triangles=600")
    m = measure_surface(s, 500.0, seed=1, patterns=("mabf", "maze"), errors="row")
    assert [r["pattern"] for r in m["rows"]] == ["mabf", "maze"] and all("too large" in r["error"] for r in m["rows"])
    with pytest.raises(ParameterError, match="too large"):
        measure_surface(s, 500.0, seed=1, patterns=("mabf",), spacing_on="plane")
