"""The two keypoint orders on examples and published scenes, whole detection at 30 %.

    python benchmarks/keypoint_order.py [EXAMPLE SCENE | EXAMPLE:SCENE ...]
    # default: sitting-human living-room4

Trains each example as ``itensor evaluate`` does (real query objects from
../shared/data/objects where there are some), prepares the scene at 1 cm, compiles the
kernels on a tiny detection, then detects with ``keypoint_order="adaptive"`` and with the
paper's weight order, one after the other at the defaults otherwise (neighbour cache at
30 %). Prints each run's scoring time, candidates/s and comparisons per decision, and
whether the two give identical decisions, accepted scores and predictions. Timings:
benchmarks/RESULTS.md.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

DATA = Path(os.environ.get("ITENSOR_SHARED_DATA",
                           Path(__file__).resolve().parent.parent.parent / "shared" / "data"))


def compare(name: str, scene_name: str) -> float:
    """Both orders on one (example, scene); returns adaptive's speed-up over weight."""
    import interaction_tensor as it
    from interaction_tensor import affordances

    tensor = affordances.build_descriptor(name, seed=0, spacing=0.01,
                                           example=affordances.build(name, DATA / "objects", 0))
    scene = it.prepare_scene(it.load_geometry(DATA / "scenes" / f"{scene_name}.ply"), 0.01,
                             seed=0)
    scene.grid()
    it.detect(scene, tensor, it.DetectSettings(sample_fraction=0.001))      # compile
    res = {}
    for order in ("adaptive", "weight"):
        det = it.detect(scene, tensor, it.DetectSettings(sample_fraction=0.3,
                                                         keypoint_order=order))
        st = det.stats
        res[order] = det
        sc = st["deciding_seconds"]
        print(f"{name} on {scene_name}, {order}: scoring {sc:.1f} s (pilot "
              f"{st['seconds'].get('keypoint_order', 0):.2f} s), "
              f"{st['candidates_after_normal_filter']} candidates, "
              f"{st['candidates_after_normal_filter'] / sc:.0f} candidates/s, "
              f"{st['mean_comparisons_per_decision']:.1f} comparisons per decision, "
              f"{st['pairs_accepted']} pairs accepted", flush=True)
    a, w = res["adaptive"], res["weight"]
    acc = w.pairs.accepted
    same_pred = ([(p.point_index, p.orientation_index) for p in a.predictions]
                 == [(p.point_index, p.orientation_index) for p in w.predictions])
    ratio = w.stats["deciding_seconds"] / a.stats["deciding_seconds"]
    print(f"identical decisions: {np.array_equal(a.pairs.accepted, acc)}; largest accepted "
          f"score difference: {np.abs(a.pairs.score[acc] - w.pairs.score[acc]).max(initial=0)}; "
          f"identical predictions: {same_pred}; adaptive against weight: {ratio:.2f}x",
          flush=True)
    return ratio


def main() -> None:
    args = sys.argv[1:] or ["sitting-human", "living-room4"]
    if all(":" not in a for a in args):
        cases = [tuple(args[i:i + 2]) for i in range(0, len(args), 2)]
    else:
        cases = [tuple(a.split(":", 1)) for a in args]
    ratios = [compare(name, scene) for name, scene in cases]
    for (name, scene), r in zip(cases, ratios):
        print(f"| {name} | {scene} | {r:.2f}x |")


if __name__ == "__main__":
    main()
