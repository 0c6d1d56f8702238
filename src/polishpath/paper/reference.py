"""The paper's published numbers (its Tables 1-4), in its units, and the names of its path types.

Wang et al., *A mid-high spatial frequency error suppression method based on
the pseudo-random path with space MABF mapping for complex surface*. Nothing
here is measured: these are the values the reproduction is printed beside.
"""

from __future__ import annotations

from typing import Any

__all__ = ["PAPER", "TABLE3_NAMES"]

#: The paper's reference figures (its Tables 1-4), in its units.
PAPER: dict[str, Any] = {
    # Table 1, MATLAB R2021a, seconds: case -> (triangles, MABF s, ABF s)
    "table1": {
        "hemisphere": (1119, 5.56, 351.89),
        "pentagram": (3559, 69.33, 1059.16),
        "airfoil": (4563, 158.54, 3456.26),
        "saddle": (5000, 178.70, 8432.58),
    },
    # Table 2, hemisphere R = 30 mm, 100,220 triangles, 0.5 mm: (average step mm, dwell points, maximum step mm)
    "table2": {"projection": (0.85325, 2836, 3.6189), "mabf": (0.5283, 7017, 0.8592)},
    # Table 3: (directional DOF, boundary, surface, uniformity, accuracy)
    "table3": {
        "unicursal": ("6/8", "Y", "N", "Y", "N"),
        "maze": ("4/8", "N", "N", "Y", "Y"),
        "fractal": ("8/8", "Y", "N", "Y", "N"),
        "projection": ("8/8", "Y", "Y", "N", "Y"),
        "mabf": ("8/8", "Y", "Y", "Y", "Y"),
    },
    # Table 4: average PSD before, after (paper's units), suppression ratio
    "table4": {
        "raster": (0.596, 0.393, 0.3406),
        "spiral": (0.527, 0.280, 0.4686),
        "rectangular": (0.816, 0.383, 0.5306),
        "pseudorandom": (0.566, 0.019, 0.9664),
    },
}

#: The row names of the paper's Table 3, by our pattern key.
TABLE3_NAMES = {
    "unicursal": "Unicursal random tool-path (Dunn & Walker)",
    "maze": "Pseudo-random path based on perfect maze (Zhang et al.)",
    "fractal": "Random fractal-like path (Dong et al.)",
    "projection": "Pseudo-random path, projection method",
    "mabf": "Pseudo-random path, space MABF mapping (ours)",
}
