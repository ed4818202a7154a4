"""Clearance test: the Numba grid kernel against the cKDTree reference, in one run.

    python benchmarks/clearance_speed.py [--scene ../shared/data/scenes/living-room2.ply]
        [--placements 20000] [--repeats 3]

For three examples' descriptors (1 cm), a seeded random set of placements (scene point,
orientation) of the scene is tested both ways; the counts must be identical. Prints
placements per second (each placement tests every clearance point with free space) and the
ratio. Both are timed after a warm-up call (Numba compiled, the grid and the tree built).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.placement.checks import clearance_offsets, count_violations

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default=str(ROOT.parent / "shared/data/scenes/living-room2.ply"))
    ap.add_argument("--placements", type=int, default=20_000)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    scene = it.prepare_scene(it.load_geometry(args.scene), 0.01, seed=0)
    grid = scene.grid()
    scene.tree  # noqa: B018  (built before timing)
    rng = np.random.default_rng(1)
    idx = rng.integers(0, len(scene.points), args.placements)
    orient = rng.integers(0, 8, len(idx))
    pts = scene.points[idx]
    print(f"{Path(args.scene).name}: {len(scene.points)} points, {len(idx)} placements")
    print("| example | reference (cKDTree) placements/s | kernel placements/s | ratio | "
          "identical counts | placements violated |")
    print("|---|---:|---:|---:|---|---:|")
    for name in ("sitting-human", "placing-bowl", "hanging-hanger"):
        tensor = affordances.build_descriptor(name, seed=0, spacing=0.01)
        off = clearance_offsets(tensor, 8)
        r = tensor.clearance_radius
        count_violations(pts[:10], orient[:10], off, r, 0.005, scene, grid)
        times = {"ref": [], "fast": []}
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            a = count_violations(pts, orient, off, r, 0.005, scene, None)
            t1 = time.perf_counter()
            b = count_violations(pts, orient, off, r, 0.005, scene, grid)
            t2 = time.perf_counter()
            times["ref"].append(t1 - t0)
            times["fast"].append(t2 - t1)
        ref, fast = min(times["ref"]), min(times["fast"])
        print(f"| {name} | {len(idx) / ref:,.0f} | {len(idx) / fast:,.0f} | {ref / fast:.1f} | "
              f"{bool((a == b).all())} | {int((a > 0).sum())} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
