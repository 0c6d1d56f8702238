"""Benchmark of the inverse mapping (issue 5) and the paper's Table 2 comparison.

Run: ``PYTHONPATH=src python benchmarks/bench_mapping.py [--skip-table2] [--seed 1]``

Prints
1. seconds to map 10^5 and 10^6 planar points onto a ~100k-triangle mesh
   (point location with the bucket grid + area coordinates + normals + stats);
2. the Table 2 case — hemisphere R = 30 mm, 100,220 triangles, 0.5 mm spacing —
   for the projection method and the MABF mapping (plain planar grid, as in the
   paper, and with the spacing honoured on the part), beside the paper's figures.
   Needs ``polishpath.surfaces.load_surface``, ``polishpath.flatten.flatten`` and
   ``polishpath.plan.plan``; says so and skips when they are not there.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from polishpath import meshops
from polishpath.mapping import locate_points, map_to_surface
from polishpath.pipeline import plan_on_surface
from polishpath.types import Flattening, PlanarPath, Provenance, Region, Surface

PAPER = {
    "projection": (0.85325, 2836, 3.6189),
    "mabf": (0.5283, 7017, 0.8592),
}


def cap_flattening(radius=30.0, max_polar=np.pi / 2 * 0.98, n_r=158, n_phi=320) -> Flattening:
    """A near-hemisphere (polar grid, ~100k triangles) with its azimuthal-equidistant map."""
    rings = np.linspace(0, max_polar, n_r + 1)[1:]
    phi = np.linspace(0, 2 * np.pi, n_phi, endpoint=False)
    P, F = np.meshgrid(rings, phi, indexing="ij")
    xyz = np.concatenate([[[0, 0, radius]], np.stack([radius * np.sin(P) * np.cos(F), radius * np.sin(P) * np.sin(F),
                                                       radius * np.cos(P)], -1).reshape(-1, 3)])
    uv = np.concatenate([[[0, 0]], np.stack([radius * P * np.cos(F), radius * P * np.sin(F)], -1).reshape(-1, 2)])
    j = np.arange(n_phi)
    fan = np.stack([np.zeros(n_phi, int), 1 + j, 1 + (j + 1) % n_phi], 1)
    i = np.arange(n_r - 1)[:, None]
    a = 1 + i * n_phi + j
    b = 1 + i * n_phi + (j + 1) % n_phi
    c = 1 + (i + 1) * n_phi + (j + 1) % n_phi
    d = 1 + (i + 1) * n_phi + j
    faces = np.concatenate([fan, np.stack([a, d, c], -1).reshape(-1, 3), np.stack([a, c, b], -1).reshape(-1, 3)])
    return Flattening(Surface(xyz, faces, name="cap"), uv, np.zeros((len(faces), 3)),
                      provenance=Provenance("flatten", "azimuthal_equidistant"))


def bench_mapping_speed(seed: int) -> None:
    flat = cap_flattening()
    rmax = np.linalg.norm(flat.uv, axis=1).max() * np.cos(np.pi / 320)  # inside the polygonal rim
    rng = np.random.default_rng(seed)
    print(f"mesh: {flat.surface.n_faces} triangles, {flat.surface.n_vertices} vertices")
    t = time.perf_counter()
    locate_points(flat.uv, flat.surface.faces, np.zeros((10, 2)))
    print(f"  first call (numba compile or cache load): {time.perf_counter() - t:.2f} s")
    for n in (10**5, 10**6):
        r = rmax * np.sqrt(rng.random(n)) * 0.999
        a = rng.random(n) * 2 * np.pi
        uv = np.column_stack([r * np.cos(a), r * np.sin(a)])
        path = PlanarPath(uv, np.zeros((n, 2), np.int64), 0.5)
        t = time.perf_counter()
        fid, _, _ = locate_points(flat.uv, flat.surface.faces, uv)
        t_loc = time.perf_counter() - t
        t = time.perf_counter()
        sp = map_to_surface(flat, path)
        t_map = time.perf_counter() - t
        print(f"  {n:>8d} points: locate {t_loc:.3f} s, map_to_surface (locate+normals+weights+stats) {t_map:.3f} s,"
              f" {np.count_nonzero(fid < 0)} unlocated, density_cv {sp.stats['density_cv']:.3f}")


def region_of(flat: Flattening) -> Region:
    try:  # the flatten stage's own helper when it is there
        from polishpath.flatten import boundary_region

        return boundary_region(flat)
    except ImportError:
        pass
    loops = meshops.boundary_loops(flat.surface.faces)
    polys = [flat.uv[lp] for lp in loops]
    areas = [abs(0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])) for p in polys]
    k = int(np.argmax(areas))
    return Region(polys[k], tuple(p for i, p in enumerate(polys) if i != k))


def bench_table2(seed: int, spacing: float = 0.5) -> None:
    print("\nTable 2: hemisphere R = 30 mm, 100,220 triangles, spacing 0.5 mm")
    try:
        from polishpath.flatten import flatten
        from polishpath.plan import plan
        from polishpath.surfaces import load_surface
    except ImportError as exc:
        print(f"  skipped: a stage is not available yet ({exc})")
        return
    t = time.perf_counter()
    surf = load_surface("hemisphere:R=30,triangles=100220")
    print(f"  surface: {surf.n_faces} triangles ({time.perf_counter() - t:.1f} s)")
    rows = []

    def run(name, flat, h, s=spacing):
        region = region_of(flat)
        t0 = time.perf_counter()
        path = plan(region, h, "pseudorandom", seed=seed)
        t1 = time.perf_counter()
        sp = map_to_surface(flat, path, surface_spacing=s)
        st = sp.stats
        rows.append((name, st["step_mean"], st["n_points"], st["step_max"], st["share_normal"], st["share_long"],
                     len(path.unreached), t1 - t0))
        return sp

    t = time.perf_counter()
    proj = flatten(surf, "projection")
    print(f"  projection flattening: {time.perf_counter() - t:.2f} s, folded {proj.metrics['folded_triangles']:.0f},"
          f" degenerate {proj.metrics['degenerate_triangles']:.0f}")
    run("projection", proj, spacing)
    t = time.perf_counter()
    mabf = flatten(surf, "mabf")
    print(f"  MABF flattening: {time.perf_counter() - t:.1f} s")
    run("mabf (plain planar grid)", mabf, spacing)

    hon = plan_on_surface(mabf, region_of(mabf), spacing, seed=seed)
    spm, h = hon.surface_path, hon.planar_spacing
    st = spm.stats
    rows.append((f"mabf (spacing on part, h={h:.4f})", st["step_mean"], st["n_points"], st["step_max"],
                 st["share_normal"], st["share_long"], len(spm.planar.unreached), float("nan")))
    print(f"  {'method':<38s} {'avg step':>9s} {'points':>7s} {'max step':>9s} {'normal':>7s} {'long':>6s} {'unreached':>9s}")
    for name, mean, n, mx, norm, lng, unr, _ in rows:
        print(f"  {name:<38s} {mean:9.4f} {n:7d} {mx:9.4f} {norm:7.3f} {lng:6.3f} {unr:9d}")
    for key, label in (("projection", "paper: projection"), ("mabf", "paper: space MABF mapping")):
        m, n, x = PAPER[key]
        print(f"  {label:<38s} {m:9.4f} {n:7d} {x:9.4f}")
    a3 = meshops.surface_area(surf.vertices, surf.faces)
    a_proj = float(np.abs(meshops.face_areas(proj.uv, surf.faces, signed=True)).sum())
    print(f"  Why the dwell counts differ: a square grid of spacing s puts area / s^2 points in a region, so"
          f" 0.5 mm gives {a_proj / spacing**2:.0f} points on the projected disc ({a_proj:.0f} mm^2) and"
          f" {a3 / spacing**2:.0f} on the hemisphere ({a3:.0f} mm^2) -- what we get. The paper's 2836 projection"
          f" points are what a 1 mm grid gives on the disc ({a_proj / 1.0:.0f}); its counts are not consistent"
          f" with 0.5 mm on the full hemisphere, while its average projection step (0.853 mm) matches ours.")

if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--skip-table2", action="store_true")
    args = ap.parse_args()
    bench_mapping_speed(args.seed)
    if not args.skip_table2:
        bench_table2(args.seed)
