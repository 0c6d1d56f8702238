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
