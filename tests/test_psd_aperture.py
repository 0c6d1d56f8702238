"""`polishpath psd` on a full-aperture interferometer map: a round part leaves the square frame's corners empty.

Before: every such map was refused ("26.5 % of the pixels are NaN, more than max_nan_fraction=0.2"), a real
4Sight map included, since an inscribed disc alone leaves 21.5 % of its square without data. Now only the holes
*inside* the aperture count against the limit; the frame outside it is not missing data.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from polishpath.psd import analyze_file
from polishpath.psd.analyze import aperture_radial_psd
from polishpath.psd.core import radial_psd
from polishpath.psd.io import write_datx_like


def _surface(n=128, seed=3):
    """A random surface with a known radial spectrum (power law), nm."""
    rng = np.random.default_rng(seed)
    fx = np.fft.fftfreq(n)
    f = np.hypot(*np.meshgrid(fx, fx))
    f[0, 0] = 1.0
    spec = rng.normal(size=(n, n)) + 1j * rng.normal(size=(n, n))
    z = np.real(np.fft.ifft2(spec * f ** -1.2))
    return 5.0 * z / z.std()


def _disc(z):
    n = z.shape[0]
    i, j = np.mgrid[0:n, 0:n]
    out = z.copy()
    out[np.hypot(i - (n - 1) / 2, j - (n - 1) / 2) > n / 2 - 0.5] = np.nan
    return out


def test_a_round_aperture_in_its_frame_gives_the_surfaces_radial_psd(tmp_path):
    pytest.importorskip("h5py")
    z = _surface()
    d = _disc(z)
    assert np.isnan(d).mean() > 0.2  # more than the old limit: refused before
    f = write_datx_like(tmp_path / "disc.datx", d, 0.05)
    res = analyze_file(f)
    assert "psd_radial" in res, res["psd_radial_note"]
    assert "0.0 % holes" in res["psd_radial_note"]
    full = radial_psd(z, 0.05, 0.05)
    got = res["psd_radial"]
    # the same surface's spectrum, read through the aperture: within a factor 2 over the middle decade
    m = (got.freq > 4 * got.freq[0]) & (got.freq < 0.3 * got.freq[-1])
    ratio = np.interp(got.freq[m], full.freq, full.psd) / got.psd[m]
    assert 0.5 < np.median(ratio) < 2.0


def test_holes_inside_the_aperture_still_count():
    z = _disc(_surface())
    rng = np.random.default_rng(1)
    inside = np.isfinite(z)
    z[inside & (rng.random(z.shape) < 0.3)] = np.nan  # dropouts inside the part: 30 % of it
    radial, note = aperture_radial_psd(z, 0.05, 0.05)
    assert radial is None
    assert "of the aperture's pixels have no data" in note and "row-profile PSD" in note


def test_the_psd_command_reads_a_round_map(tmp_path):
    pytest.importorskip("h5py")
    from test_bad_input import cli

    f = write_datx_like(tmp_path / "disc.datx", _disc(_surface()), 0.05)
    r = cli("psd", f, "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["kind"] == "map" and "psd_radial" in out and "aperture" in out["psd_radial_note"]
