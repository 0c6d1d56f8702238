"""The run folder as a format: polishpath.runfolder writes and reads run.npz, summary.json and job.toml."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import polishpath
from polishpath.errors import InputError
from polishpath.runfolder import ARRAY_KEYS, SCHEMA_KEY, SCHEMA_VERSION, read_run

DOC = Path(__file__).resolve().parents[1] / "docs" / "run-folder.md"


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    job = polishpath.run(surface="hemisphere:R=12,triangles=700", spacing=1.5, seed=5, report=False)
    job.save(out)
    return job, out


def test_the_stages_come_back_from_the_files(saved):
    job, out = saved
    run = read_run(out)
    assert run.schema == SCHEMA_VERSION and run.summary[SCHEMA_KEY] == SCHEMA_VERSION
    np.testing.assert_array_equal(run.surface.vertices, job.surface.vertices)
    np.testing.assert_array_equal(run.surface.faces, job.surface.faces)
    assert run.surface.name == job.surface.name
    np.testing.assert_array_equal(run.flattening.uv, job.flattening.uv)
    assert run.flattening.provenance.method == "mabf"
    for a, b in zip(run.region.loops, job.region.loops):
        np.testing.assert_array_equal(a, b)
    p, q = run.planar, job.planar
    np.testing.assert_array_equal(p.uv, q.uv)
    np.testing.assert_array_equal(p.ij, q.ij)
    np.testing.assert_array_equal(p.pieces, q.pieces)
    np.testing.assert_array_equal(p.origin, q.origin)
    assert (p.spacing, p.rotation, p.pattern, p.provenance.seed) == (q.spacing, q.rotation, q.pattern, 5)
    s, t = run.surface_path, job.surface_path
    for name in ("xyz", "normals", "face_ids", "bary", "dwell_weight"):
        np.testing.assert_array_equal(getattr(s, name), getattr(t, name))
    assert s.stats["step_max"] == pytest.approx(t.stats["step_max"])
    a, b = run.tool_path, job.tool_path
    # format 2: the samples' schedule, not the samples; regenerated, they are the job's bit for bit
    assert not run.samples_stored and len(a.samples) == 0 and a.schedule is not None
    from polishpath.simulate.jobpath import with_samples

    held = with_samples(a)
    for name in ("samples", "sample_params", "feed_mm_min"):
        np.testing.assert_array_equal(getattr(held, name), getattr(b, name))
    np.testing.assert_array_equal(a.dwell_params, b.dwell_params)
    np.testing.assert_array_equal(a.curve.knots, b.curve.knots)
    np.testing.assert_array_equal(a.curve.control_points, b.curve.control_points)
    assert a.curve.degree == b.curve.degree and a.period_ms == b.period_ms
    np.testing.assert_array_equal(a.dwell_times, b.dwell_times)
    assert run.config["seed"] == 5 and run.config["spacing"] == 1.5


def test_the_document_lists_every_key(saved):
    _, out = saved
    doc = DOC.read_text()
    documented = set(re.findall(r"^\| `([a-z_<>0-9]+)` \|", doc, flags=re.M))
    with np.load(out / "run.npz") as z:
        keys = set(z.files)
    generic = {re.sub(r"^(residual_|region_loop_).*", lambda m: m.group(1) + ("<name>" if m.group(1) == "residual_" else "<i>"), k)
               for k in keys}
    assert generic <= documented, f"run.npz keys missing in docs/run-folder.md: {sorted(generic - documented)}"
    assert set(ARRAY_KEYS) <= keys
    top = set(json.loads((out / "summary.json").read_text()))
    assert top <= documented, f"summary.json keys missing in docs/run-folder.md: {sorted(top - documented)}"


def _copy(src: Path, dst: Path) -> Path:
    dst.mkdir()
    for name in ("summary.json", "run.npz", "job.toml"):
        (dst / name).write_bytes((src / name).read_bytes())
    return dst


def test_a_newer_format_is_refused(saved, tmp_path):
    _, out = saved
    d = _copy(out, tmp_path / "newer")
    s = json.loads((d / "summary.json").read_text())
    s[SCHEMA_KEY] = SCHEMA_VERSION + 1
    (d / "summary.json").write_text(json.dumps(s))
    with pytest.raises(InputError, match="Upgrade polishpath"):
        read_run(d)


def test_a_folder_from_before_the_format_reads_but_says_what_it_lacks(saved, tmp_path):
    _, out = saved
    d = _copy(out, tmp_path / "old")
    s = json.loads((d / "summary.json").read_text())
    del s[SCHEMA_KEY]
    (d / "summary.json").write_text(json.dumps(s))
    with np.load(out / "run.npz") as z:
        arrays = {k: z[k] for k in z.files if k not in ("face_ids", "bary", "schedule_region_feeds")}
    np.savez(d / "run.npz", **arrays)
    run = read_run(d)
    assert run.schema == 0 and run.surface.n_faces > 0
    with pytest.raises(InputError, match="lacks face_ids, bary") as e:
        run.surface_path
    assert "polishpath plan --config" in str(e.value)
    with pytest.raises(InputError, match="lacks samples, sample_params"):  # neither the samples nor their schedule
        run.tool_path


@pytest.mark.parametrize("breakage, message", [
    ("missing", "is not a folder"),
    ("no_summary", "has no summary.json"),
    ("bad_json", "cannot be read as JSON"),
    ("no_npz", "has no run.npz"),
    ("bad_npz", "cannot be read"),
    ("bad_schema", "must be a whole number"),
    ("bad_toml", "not valid TOML"),
])
def test_broken_folders_are_input_errors(saved, tmp_path, breakage, message):
    _, out = saved
    d = tmp_path / "missing" if breakage == "missing" else _copy(out, tmp_path / "r")
    if breakage == "no_summary":
        (d / "summary.json").unlink()
    elif breakage == "bad_json":
        (d / "summary.json").write_text("{")
    elif breakage == "no_npz":
        (d / "run.npz").unlink()
    elif breakage == "bad_npz":
        (d / "run.npz").write_bytes(b"not a zip")
    elif breakage == "bad_schema":
        (d / "summary.json").write_text(json.dumps({SCHEMA_KEY: "one"}))
    elif breakage == "bad_toml":
        (d / "job.toml").write_text("[job\n")
    with pytest.raises(InputError, match=message):
        read_run(d)


def test_run_npz_deflates_only_what_shrinks(tmp_path):
    """write_npz: compressible arrays deflated, float noise stored; numpy.load reads every array back exactly."""
    import zipfile

    from polishpath.runfolder import write_npz

    rng = np.random.default_rng(0)
    arrays = {"noise": rng.normal(size=(100_000, 3)), "flat": np.full(200_000, 600.0), "ints": np.arange(10, dtype=np.int32),
              "scalar": np.float64(0.5), "empty": np.zeros(0)}
    with open(tmp_path / "a.npz", "wb") as fh:
        write_npz(fh, arrays)
    kinds = {i.filename: i.compress_type for i in zipfile.ZipFile(tmp_path / "a.npz").infolist()}
    assert kinds["noise.npy"] == zipfile.ZIP_STORED and kinds["flat.npy"] == zipfile.ZIP_DEFLATED
    with np.load(tmp_path / "a.npz", allow_pickle=False) as z:
        for k, v in arrays.items():
            assert z[k].dtype == np.asarray(v).dtype and np.array_equal(z[k], v)


def test_run_arrays_are_read_on_first_use_and_large_stored_ones_mapped(saved, monkeypatch):
    """read_run reads run.npz's directory only; a large stored array is mapped (copy-on-write), equal to the job's."""
    from polishpath.runfolder import NpzArrays

    job, out = saved
    monkeypatch.setattr(NpzArrays, "MAP_BYTES", 1024)
    run = read_run(out)
    assert isinstance(run.arrays, NpzArrays) and run.arrays._cache == {}
    xyz = run.arrays["xyz"]
    assert isinstance(xyz.base, np.memmap) and np.array_equal(xyz, job.surface_path.xyz)
    xyz[0, 0] += 1.0  # the caller's copy only
    assert np.array_equal(read_run(out).arrays["xyz"], job.surface_path.xyz)
    assert list(run.arrays._cache) == ["xyz"] and "plan_uv" in run.arrays and "nothing" not in run.arrays
