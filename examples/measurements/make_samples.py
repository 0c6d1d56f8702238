"""Generate the small sample measurements in this folder (synthetic, seeded).

    PYTHONPATH=src python examples/measurements/make_samples.py

profile_before.txt / profile_after.txt : stylus-like profiles, 10 mm at 5 um,
    x in mm and z in nm (stated in the header); "after" is smoother but carries
    a 0.5 mm ripple, as a raster path at 0.5 mm spacing leaves.
profile_after.csv : the same "after" profile as CSV with units in the column names.
map_small.datx : a 96 x 96 Zygo-style HDF5 map at 10 um with a few missing pixels.
"""

from pathlib import Path

import numpy as np

from polishpath.psd import write_datx_like

HERE = Path(__file__).resolve().parent


def power_law_profile(n, dx, rms, exponent, seed):
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(n, d=dx)
    amp = np.zeros_like(f)
    amp[1:] = f[1:] ** (-exponent / 2)
    z = np.fft.irfft(amp * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)), n)
    return z * rms / z.std()


def main():
    n, dx = 2001, 0.005
    x = np.arange(n) * dx
    before = power_law_profile(n, dx, 3.0, 1.5, seed=1)
    after = 0.2 * before + 1.0 * np.sin(2 * np.pi * x / 0.5) + 0.02 * np.random.default_rng(2).normal(size=n)
    for name, z in (("profile_before.txt", before), ("profile_after.txt", after)):
        lines = ["# synthetic stylus profile (polishpath examples, seed-generated)", "# lateral_unit: mm",
                 "# height_unit: nm"] + [f"{a:.4f} {b:.5f}" for a, b in zip(x, z)]
        (HERE / name).write_text("\n".join(lines) + "\n")
    (HERE / "profile_after.csv").write_text("x_mm,z_nm\n" + "\n".join(f"{a:.4f},{b:.5f}" for a, b in zip(x, after)) + "\n")
    m = np.random.default_rng(3).normal(size=(96, 96)).cumsum(axis=1) * 0.2
    m[10, 20:23] = np.nan
    write_datx_like(HERE / "map_small.datx", m, 0.01)


if __name__ == "__main__":
    main()
