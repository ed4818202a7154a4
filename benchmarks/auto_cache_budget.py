"""The auto neighbour cache's budget for a person on a small scene.

    NUMBA_NUM_THREADS=1 python benchmarks/auto_cache_budget.py [--scene office-desk1]

Detects sitting-human (the tuned descriptor, defaults, 30 % test points) on a published scene
three times in one process: the auto cache with 24 bytes a scene point and no floor (the
budget before 2026-11-26), the auto cache with today's floor (``CACHE_AUTO_FLOOR``), and the
cache kept at its full size (``neighbour_cache=True``). Prints scoring seconds, candidates/s
and whether every pair's decision, score and the top 5 are identical to the first run's.
"""

from __future__ import annotations

import argparse
import importlib
import time
from pathlib import Path

import numpy as np

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.geometry.load import load_geometry

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="office-desk1")
    ap.add_argument("--data", default=str(ROOT.parent / "shared" / "data"))
    args = ap.parse_args()
    det_mod = importlib.import_module("interaction_tensor.detection.search")
    tensor = affordances.build_descriptor("sitting-human", Path(args.data) / "objects")
    scene = it.prepare_scene(load_geometry(Path(args.data) / "scenes" / f"{args.scene}.ply"),
                             0.01, seed=0)
    floor = det_mod.CACHE_AUTO_FLOOR
    runs = [("auto, 24 B a point, no floor", 0, {}),
            (f"auto, floor {floor >> 20} MB (default)", floor, {}),
            ("neighbour_cache=True (512 MB)", floor, {"neighbour_cache": True})]
    print(f"{args.scene}: {len(scene):,} points; sitting-human, defaults\n")
    print("| cache | budget MB | scoring s | candidates/s | identical to the first |")
    print("|---|---:|---:|---:|---|")
    first = None
    for name, fl, kw in runs:
        det_mod.CACHE_AUTO_FLOOR = fl
        scene._grid = None                                 # a cold cache each time
        det = it.detect(scene, tensor, it.DetectSettings(top_k=5, **kw))
        st = det.stats
        budget = (512 if kw else max(fl, 24 * len(scene)) / 2**20)
        key = (det.pairs.accepted, det.pairs.score, [p.score for p in det.predictions])
        same = first is None or (np.array_equal(key[0], first[0]) and
                                 np.array_equal(key[1], first[1]) and key[2] == first[2])
        first = first or key
        print(f"| {name} | {budget:.1f} | {st['seconds']['scoring']:.1f} | "
              f"{st['candidates_per_second']:.0f} | {same} |", flush=True)
    det_mod.CACHE_AUTO_FLOOR = floor
    return 0


if __name__ == "__main__":
    t0 = time.perf_counter()
    rc = main()
    print(f"\n({time.perf_counter() - t0:.0f} s)")
    raise SystemExit(rc)
