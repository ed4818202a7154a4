"""The torch backend's Triton path on a GPU: tile levels x pairs per block, in one process.

kitchen5, placing-bowl (paper_bowl.ply on a table), 30 % test points: one Numba detection
(the reference, the machine's own threads), then the torch backend with each
(levels, coarsening, pairs per block); scoring seconds, candidates per second, the queries
the levels left to the CPU's cKDTree, and whether the decisions (accepted flags and
decided-at) are identical to Numba's. Prints one JSON line per run. Needs a CUDA device
(or runs the cdist kernel on the CPU: slow, and not what it measures).

    ITENSOR_SHARED_DATA=../shared/data python benchmarks/torch_levels.py

Recorded in RESULTS.md (*torch backend on a GPU*, lease 3).
"""

from __future__ import annotations

import functools
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import run as B  # noqa: E402

import interaction_tensor as it  # noqa: E402
from interaction_tensor.engine import torch_backend as TB  # noqa: E402

#: (levels, coarsening, pairs per block) tried, in order
RUNS = ((2, 4.0, 2048), (2, 4.0, 8192), (2, 4.0, 32768), (3, 2.0, 8192), (3, 4.0, 8192))


def main() -> None:
    bowl, tbl = B._paper_bowl_tensor()
    tensor = it.InteractionTensor.fit(bowl, tbl, "placing-bowl", it.TrainSettings())
    scene = it.prepare_scene(it.load_geometry(B.DATA / "scenes" / "kitchen5.ply"), 0.01, seed=0)
    it.detect(scene, tensor, it.DetectSettings(sample_fraction=0.0005, backend="torch"))
    ref = it.detect(scene, tensor, it.DetectSettings(sample_fraction=0.3))
    print(json.dumps({"numba_scoring_s": ref.stats["deciding_seconds"]}), flush=True)
    cls, scorer = TB.TorchIndex, TB.score_pairs_torch
    for levels, coarse, ppb in RUNS:
        made = {}

        def index(*a, _l=levels, _c=coarse, **k):
            made["i"] = cls(*a, levels=_l, coarsening=_c, **k)
            return made["i"]

        TB.TorchIndex = index
        TB.score_pairs_torch = functools.partial(scorer, pairs_per_block=ppb)
        try:
            det = it.detect(scene, tensor, it.DetectSettings(sample_fraction=0.3,
                                                             backend="torch"))
        finally:
            TB.TorchIndex, TB.score_pairs_torch = cls, scorer
        sc = det.stats["deciding_seconds"]
        print(json.dumps({
            "levels": levels, "coarsening": coarse, "pairs_per_block": ppb,
            "kernel": made["i"].kernel, "scoring_s": round(sc, 3),
            "candidates_per_s": round(det.stats["candidates_after_normal_filter"] / sc),
            "tree_queries": made["i"].tree_queries,
            "identical_decisions": bool(
                np.array_equal(det.pairs.accepted, ref.pairs.accepted)
                and np.array_equal(det.pairs.decided_at, ref.pairs.decided_at))}), flush=True)


if __name__ == "__main__":
    main()
