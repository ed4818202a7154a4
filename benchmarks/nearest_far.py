"""Nearest-neighbour lookups of the scoring kernel's keypoints, against SciPy's cKDTree.

Usage::

    python benchmarks/nearest_far.py                 # 300 test points per case, 3 rounds
    python benchmarks/nearest_far.py --points 1000 --rounds 5

Cases: the RGB-D frame ``rgbd/tum_desk`` (a desk seen from one side: metres of empty space
around a seated person's keypoints) and kitchen5, each with ``sitting-human`` and
``placing-bowl`` (fitted at 1 cm; scenes at 1 cm). Queries: every keypoint of every
orientation at ``--points`` seeded random scene points, i.e. all the lookups an exhaustive
score of those pairs makes. Prints the distribution of the queries' distance to the
scene in grid cells (the shell search visits about (distance / cell)^3 cells; queries past
``kernels.FAR_CELLS`` search the occupied blocks instead), lookups per second of
:func:`interaction_tensor.engine.numba_backend.nearest_indices` (Numba, one thread) and of
``cKDTree.query`` (one worker), their ratio per round (interleaved: only ratios mean much on
a shared machine), and whether every answer is at the cKDTree's distance.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DATA = Path(os.environ.get("ITENSOR_SHARED_DATA", HERE.parent.parent / "shared" / "data"))
SCENES = {"tum_desk": DATA / "rgbd" / "tum_desk", "kitchen5": DATA / "scenes" / "kitchen5.ply"}
EXAMPLES = ("sitting-human", "placing-bowl")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=300)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)

    import numba
    from scipy.spatial import cKDTree

    import interaction_tensor as it
    from interaction_tensor import affordances
    from interaction_tensor.engine import numba_backend as kernels

    numba.set_num_threads(1)
    tensors = {ex: affordances.build_descriptor(ex, objects_dir=DATA / "objects", spacing=0.01)
               for ex in EXAMPLES}
    far = getattr(kernels, "FAR_CELLS", np.inf)          # inf: a version without the block search
    print(f"{kernels.__file__}: FAR_CELLS = {far}")
    for name, path in SCENES.items():
        scene = it.load_scene(path, spacing=0.01)
        grid = scene.grid()
        tree = cKDTree(scene.points)
        rng = np.random.default_rng(args.seed)
        tp = scene.points[rng.choice(len(scene), min(args.points, len(scene)), replace=False)]
        for ex, tensor in tensors.items():
            table = tensor.keypoint_table(it.DetectSettings())
            q = (tp[:, None, None, :] + table.offsets[None]).reshape(-1, 3)
            kernels.nearest_indices(grid, q[:16])                    # compile
            ratios, rates, exact = [], [], True
            for _ in range(args.rounds):
                t0 = time.perf_counter()
                got = kernels.nearest_indices(grid, q)
                t_grid = time.perf_counter() - t0
                t0 = time.perf_counter()
                d_ref, _ = tree.query(q, workers=1)
                t_tree = time.perf_counter() - t0
                d_got = np.linalg.norm(scene.points[got] - q, axis=1)
                exact &= bool(np.all(d_got == d_ref))
                ratios.append(t_tree / t_grid)
                rates.append(len(q) / t_grid)
            dc = d_ref / grid.cell
            print(f"{name:9s} {ex:14s} {len(scene):7d} points, cell {grid.cell * 100:.0f} cm, "
                  f"{len(q):8d} lookups; distance in cells p50 {np.median(dc):.1f} "
                  f"p90 {np.quantile(dc, 0.9):.1f}, past FAR_CELLS "
                  f"{100 * np.mean(dc > far):.0f} %; grid "
                  f"{statistics.median(rates) / 1e6:.2f} M lookups/s, "
                  f"{statistics.median(ratios):.2f}x cKDTree; exact: {exact}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
