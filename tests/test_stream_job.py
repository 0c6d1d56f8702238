"""A job whose machine samples stream (issue 15, item 4): what it keeps of them, and the files it writes."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from polishpath.report import digest as dg


def _chunks(samples, feed, sizes):
    a, k = 0, 0
    while a < len(samples):
        b = min(a + sizes[k % len(sizes)], len(samples))
        yield SimpleNamespace(samples=samples[a:b], feed_mm_min=feed[a:b])
        a, k = b, k + 1


@pytest.mark.parametrize("n", [1, 7, 4000, 4001, 30_011])
def test_the_digest_does_not_depend_on_the_chunks(n):
    rng = np.random.default_rng(n)
    s = rng.normal(size=(n, 3))
    f = 600 + rng.normal(scale=40, size=n)
    ref = dg.digest_of(s, f, size=n)
    for sizes in ([1], [3, 1, 17], [997], [n + 5]):
        d = dg.SampleDigest(n)
        for _ in d.observe(_chunks(s, f, sizes)):
            pass
        got = d.arrays()
        assert set(got) == set(dg.DIGEST_KEYS)
        for k in dg.DIGEST_KEYS:
            np.testing.assert_array_equal(got[k], ref[k], err_msg=f"{k} with chunks {sizes}")


def test_the_digest_holds_what_the_report_draws():
    n = 50_000
    rng = np.random.default_rng(1)
    s = rng.normal(size=(n, 3))
    f = 600 + rng.normal(scale=40, size=n)
    d = dg.digest_of(s, f)
    idx = d["display_sample_index"]
    assert len(idx) <= dg.MAX_SAMPLES_SHOWN and idx[0] == 0 and idx[-1] == n - 1 and np.all(np.diff(idx) > 0)
    np.testing.assert_array_equal(d["display_samples"], s[idx])
    e, env = d["feed_bins"], d["feed_envelope"]
    assert e[0] == 0 and e[-1] == n and len(env) == dg.FEED_BINS
    for k in (0, 17, len(env) - 1):
        part = f[e[k]:e[k + 1]]
        assert env[k, 0] == part.min() and env[k, 1] == part.max()
        assert env[k, 2] == pytest.approx(part.mean(), abs=1e-5)


def test_a_short_path_keeps_every_feed():
    f = np.array([600.0, 590.0, 610.5])
    d = dg.digest_of(np.zeros((3, 3)), f)
    np.testing.assert_array_equal(d["feed_bins"], [0, 1, 2, 3])
    np.testing.assert_array_equal(d["feed_envelope"][:, 0], f)
    np.testing.assert_array_equal(d["feed_envelope"][:, 1], f)


def test_a_digest_short_of_its_samples_is_refused():
    d = dg.SampleDigest(10)
    d.add(SimpleNamespace(samples=np.zeros((4, 3)), feed_mm_min=np.ones(4)))
    with pytest.raises(ValueError, match="4 of its 10"):
        d.arrays()
    with pytest.raises(ValueError, match="more came"):
        d.add(SimpleNamespace(samples=np.zeros((7, 3)), feed_mm_min=np.ones(7)))


# --- held or streamed: the job's choice ---------------------------------------------------------------


@pytest.fixture(scope="module")
def small_job():
    import polishpath

    return polishpath.run(surface="hemisphere:R=12,triangles=700", spacing=1.5, seed=5, report=False)


def test_a_small_job_holds_its_samples_and_says_why(small_job):
    from polishpath import resources

    m = small_job.samples_mode
    assert m["mode"] == "memory" and m["requested"] == "auto" and "held in memory" in m["reason"]
    # the estimate the choice is made from is close to the samples the path got
    assert m["expected_samples"] == pytest.approx(small_job.n_samples, rel=0.3)
    assert m["expected_samples"] < resources.STREAM_ABOVE_SAMPLES
    s = small_job.summary()["smooth"]
    assert s["samples_mode"] == "memory" and s["samples"] == len(small_job.tool_path.samples) > 0


def test_auto_streams_above_the_threshold_or_the_budget(small_job, monkeypatch):
    from polishpath import resources
    from polishpath.config import parse_job
    from polishpath.pipeline import choose_samples_mode

    cfg = parse_job(surface="hemisphere", samples="auto")
    est = resources.Estimate(700, 500.0, 1e4, 400e6)
    kw = {}
    monkeypatch.setenv("POLISHPATH_MAX_MEMORY", "64G")
    m = choose_samples_mode(cfg, "", small_job.surface_path, kw, est)
    assert m["mode"] == "memory"
    rest = est.peak_bytes - resources.BYTES_PER_SAMPLE * est.samples
    tight = int(rest + 0.5 * resources.BYTES_PER_SAMPLE * m["expected_samples"])
    monkeypatch.setattr(resources, "STREAM_ABOVE_SAMPLES", 100.0)
    m = choose_samples_mode(cfg, "", small_job.surface_path, kw, est)
    assert m["mode"] == "stream" and "STREAM_ABOVE_SAMPLES" in m["reason"]
    # what the job needs held stays held, whatever the count
    m = choose_samples_mode(cfg, "the feed schedule needs them", small_job.surface_path, kw, est)
    assert m["mode"] == "memory" and "the feed schedule needs them" in m["reason"]
    monkeypatch.setattr(resources, "STREAM_ABOVE_SAMPLES", 1e12)
    monkeypatch.setenv("POLISHPATH_MAX_MEMORY", str(tight))  # the rest of the job fits, the samples held would not
    m = choose_samples_mode(cfg, "", small_job.surface_path, kw, est)
    assert m["mode"] == "stream" and "more than this job may use" in m["reason"]
    for asked in ("memory", "stream"):
        m = choose_samples_mode(parse_job(surface="hemisphere", samples=asked), "", small_job.surface_path, kw, est)
        assert m["mode"] == asked and "as asked" in m["reason"]


@pytest.mark.parametrize("extra, says", [
    (["--machine", "generic-3axis"], "feed schedule of --machine"),
    (["--error-map", "ERR"], "figuring residual of --error-map"),
])
def test_what_needs_the_samples_held_refuses_to_stream(tmp_path, extra, says):
    import subprocess
    import sys

    err = tmp_path / "err.toml"
    err.write_text("[zernike]\nradius_mm = 11.0\nunits = \"nm\"\ncoefficients = { 4 = 20.0 }\n")
    extra = [str(err) if x == "ERR" else x for x in extra]
    proc = subprocess.run([sys.executable, "-m", "polishpath", "plan", "hemisphere:R=12,triangles=700",
                           "--spacing", "1.5", "--seed", "1", "--samples", "stream", *extra, "-o", str(tmp_path / "o"),
                           "--quiet"], capture_output=True, text=True)
    assert proc.returncode == 2, proc.stderr
    assert says in proc.stderr and "--samples memory" in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "o").exists()


def test_the_memory_check_counts_streamed_samples_as_bounded(monkeypatch):
    from polishpath import resources
    from polishpath.errors import ResourceError
    from polishpath.surfaces import load_surface

    surf = load_surface("hemisphere:R=100,triangles=2000")
    kw = dict(feed_mm_min=600.0, period_ms=4.0, max_points=10**8)
    est = resources.check_job(surf, 0.5, **kw, samples="stream")  # no budget set: fits on this machine
    monkeypatch.setenv("POLISHPATH_MAX_MEMORY", str(int(est.peak_bytes * 1.05)))
    resources.check_job(surf, 0.5, **kw, samples="stream")
    resources.check_job(surf, 0.5, **kw, samples="auto")
    with pytest.raises(ResourceError, match="POLISHPATH_MAX_MEMORY"):
        resources.check_job(surf, 0.5, **kw, samples="memory")


# --- the test: a streamed job and an in-memory job write the same bytes -----------------------------


def _strip_volatile(summary: dict) -> dict:
    s = dict(summary)
    for k in ("created", "timings_s", "machine"):
        s.pop(k, None)
    s["config"] = {k: v for k, v in s["config"].items() if k != "samples"}
    s["smooth"] = {k: v for k, v in s["smooth"].items() if not k.startswith("samples_mode")}
    s["post"] = {k: v for k, v in s["post"].items() if k != "path"}  # the folder's own name
    return s


#: wall-clock figures, which no two runs share
CLOCKS = {"seconds", "timings_s", "interpolation_s", "created"}


def _close(a, b, path="summary"):
    """Equal JSON values, floats to 1e-12 relative (a sum accumulated chunk by chunk adds in another order)."""
    if isinstance(a, dict):
        assert set(a) == set(b), f"{path}: keys {sorted(set(a) ^ set(b))}"
        for k in (k for k in a if k not in CLOCKS and not k.endswith("_seconds")):
            _close(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            _close(x, y, f"{path}[{i}]")
    elif isinstance(a, float) and isinstance(b, float):
        assert a == pytest.approx(b, rel=1e-12, abs=1e-15), path
    else:
        assert a == b, path


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    import polishpath
    from polishpath.pipeline import job as job_module

    out = tmp_path_factory.mktemp("stream")
    spec = dict(surface="pentagram:triangles=1500", spacing=1.5, seed=3)  # three pieces
    held = polishpath.run(**spec, samples="memory")
    held.save(out / "memory")
    old = job_module.CHUNK_SAMPLES
    job_module.CHUNK_SAMPLES = 97  # a prime: chunks cut pieces and bins anywhere
    try:
        streamed = polishpath.run(**spec, samples="stream")
        streamed.save(out / "stream")
    finally:
        job_module.CHUNK_SAMPLES = old
    return held, streamed, out / "memory", out / "stream"


def test_a_streamed_job_holds_no_sample(two_runs):
    held, streamed, _, _ = two_runs
    assert len(held.planar.pieces) - 1 >= 3
    assert held.samples_mode["mode"] == "memory" and streamed.samples_mode["mode"] == "stream"
    assert len(streamed.tool_path.samples) == 0 and streamed.n_samples == len(held.tool_path.samples) > 10_000


@pytest.mark.parametrize("name", ["toolpath.nc", "toolpath.xyz", "path.csv", "flat.obj", "run.npz",
                                  "figures/feed_rate.png", "figures/surface_path.png", "figures/planar_path.png"])
def test_a_streamed_job_writes_the_same_bytes(two_runs, name):
    _, _, a, b = two_runs
    assert (a / name).read_bytes() == (b / name).read_bytes(), name


def test_a_streamed_job_records_the_same_run(two_runs):
    import json

    _, _, a, b = two_runs
    sa, sb = (json.loads((d / "summary.json").read_text()) for d in (a, b))
    assert sa["smooth"]["samples_mode"] == "memory" and sb["smooth"]["samples_mode"] == "stream"
    _close(_strip_volatile(sa), _strip_volatile(sb))
    ja, jb = ((d / "job.toml").read_text().splitlines() for d in (a, b))
    assert [x for x in ja if not x.startswith("samples")] == [x for x in jb if not x.startswith("samples")]
    assert 'samples = "stream"' in jb


def test_a_streamed_run_folder_simulates_the_samples_it_wrote(two_runs):
    from polishpath.export import read_xyz
    from polishpath.runfolder import read_run
    from polishpath.simulate.jobpath import with_samples

    held, _, _, b = two_runs
    run = read_run(b)
    assert not run.samples_stored
    tp = with_samples(run.tool_path)
    for name in ("samples", "sample_params", "feed_mm_min"):
        np.testing.assert_array_equal(getattr(tp, name), getattr(held.tool_path, name))
    np.testing.assert_allclose(read_xyz(b / "toolpath.xyz"), tp.samples, atol=5e-7)


@pytest.mark.parametrize("post", ["fanuc", "xyz", "csv"])
def test_every_post_writes_the_same_file_streamed(tmp_path, post, monkeypatch):
    import polishpath
    from polishpath.pipeline import job as job_module

    spec = dict(surface="hemisphere:R=12,triangles=700", spacing=1.5, seed=5, post=post, report=False)
    polishpath.run(**spec, samples="memory").save(tmp_path / "memory")
    monkeypatch.setattr(job_module, "CHUNK_SAMPLES", 101)
    polishpath.run(**spec, samples="stream").save(tmp_path / "stream")
    for name in ("toolpath.nc" if post == "fanuc" else "toolpath.xyz", "toolpath.xyz", "path.csv", "run.npz"):
        assert (tmp_path / "memory" / name).read_bytes() == (tmp_path / "stream" / name).read_bytes(), name
