"""Two figuring iterations on a synthetic part: plan, 'polish', measure, plan again.

Iteration 1 solves dwell times for error-1.toml. The part is then "polished"
with a process that differs from the model the way a real one does (the
removal rate 5 % low, plus 0.5 nm RMS of random mid-spatial texture), and the
result is "measured" into after-1.xyz (x y z text, nm). Iteration 2 is the same
job with --error-map after-1.xyz and a gentler tool (FINISH_TIF: a lower pressure,
2 nm/s at the peak): at iteration 1's 15 nm/s the minimum times alone would
remove about 20 nm everywhere, more than the few nm the part still needs, and
polishpath refuses such a program (docs/figuring.md, "Never worse").

Usage: python examples/figuring/run_two_iterations.py [OUT_DIR]
"""

from __future__ import annotations

import dataclasses
import json
import sys
import warnings
from pathlib import Path

import numpy as np
from scipy import ndimage

from polishpath.errors import FiguringRefusedError
from polishpath.pipeline import JobConfig, run

HERE = Path(__file__).resolve().parent
#: the finishing iteration's TIF: the same spot at a lower pressure
FINISH_TIF = "gaussian:fwhm=3,peak_rate=2"


def polish_and_measure(run_dir: Path, out_file: Path, rate_error: float = -0.05, texture_nm: float = 0.5, seed: int = 0):
    """The error left by the run's machine-timed removal with a process off by `rate_error`, as x y z text."""
    a = np.load(run_dir / "run.npz")
    x0, y0, h = a["figuring_grid"]
    err = a["figuring_error_nm"]
    removal = a["figuring_removal_nm"] * (1 + rate_error)
    rng = np.random.default_rng(seed)
    tex = ndimage.gaussian_filter(rng.standard_normal(err.shape), 1.0 / h)
    after = err - removal + texture_nm * tex / tex.std()
    after = np.where(np.isfinite(err), after, np.nan)
    ny, nx = err.shape
    X, Y = np.meshgrid(x0 + np.arange(nx) * h, y0 + np.arange(ny) * h)
    step = 4  # a coarser "instrument": 0.2 mm pixels
    rows = [f"{x:.6f} {y:.6f} {z:.6f}" for x, y, z in
            zip(X[::step, ::step].ravel(), Y[::step, ::step].ravel(), after[::step, ::step].ravel())]
    out_file.write_text("# lateral_unit: mm\n# height_unit: nm\n" + "\n".join(rows) + "\n")
    return out_file


def main(out: Path, **overrides):
    """Both iterations into ``out`` (it1/, after-1.xyz, it2/); ``overrides`` replace job.toml keys (a test runs a
    smaller part). Returns the two summaries' ``figuring`` blocks."""
    out.mkdir(parents=True, exist_ok=True)
    figures = []
    cfg = JobConfig.from_toml(HERE / "job.toml", **overrides)
    for it in (1, 2):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            try:
                job = run(cfg)
            except FiguringRefusedError as exc:
                # e.g. the second pass halves the RMS but its PV grows (the texture is beyond the TIF): the
                # shop decides; here it goes on, and the summary records the refusal it went past
                print(f"iteration {it}: {exc}\n  -> written anyway (force = true)", flush=True)
                cfg = dataclasses.replace(cfg, force=True)
                job = run(cfg)
        d = out / f"it{it}"
        job.save(d)
        fg = json.loads((d / "summary.json").read_text())["figuring"]
        figures.append(fg)
        print(f"iteration {it}: error {fg['initial_rms_nm']:.3g} nm RMS ({fg['initial_pv_nm']:.3g} PV) -> predicted "
              f"{fg['residual_rms_nm']:.3g} nm RMS ({fg['residual_pv_nm']:.3g} PV), dwell {fg['total_time_s'] / 60:.1f} min, "
              f"solver {fg['solver']}", flush=True)
        if it == 1:
            after = polish_and_measure(d, out / "after-1.xyz")
            cfg = JobConfig.from_toml(HERE / "job.toml", **{**overrides, "error_map": str(after), "tif": FINISH_TIF})
    return figures


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("out-figuring"))
