"""``polishpath.paper.reproduce`` (issue 9): the paper's tables and figures, regenerated, beside its numbers.

One reduced run (``quick=True``) is shared by all checks. Nothing here asserts on
time: the machine is shared.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from polishpath.errors import ParameterError
from polishpath.paper import PAPER, SHARED_MESHES, reproduce

FIGURES = ["fig02_residuals", "fig03_flattening", "fig05_seat_plane", "fig06_seat_path", "fig07_seat_nurbs",
           "fig08_peer_paths", "fig09_hemisphere_paths", "fig10_cases", "fig13_psd"]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper")
    res = reproduce(out, quick=True, seed=0)
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


def test_bunny_patch_or_note(run):
    _, res, md, _ = run
    if (SHARED_MESHES / "stanford-bunny.obj").exists():
        assert res["bunny"]["boundary_loops"] == 1 and res["bunny"]["faces"] > 100
        assert any("rabbit" in r["case"] for r in res["fig10"])
        assert "geodesic" in md
    else:
        assert "was skipped" in md


def test_bad_seed():
    with pytest.raises(ParameterError):
        reproduce(Path("unused"), quick=True, seed=-1)
