"""Diagnosis (not tuning): is there any valid filling pose in a scene for the example as it is?

The filling example puts the mug where its base was, 19 cm under the tap's outlet on its
axis, so every pose detection can propose is the example's pose at a scene sample
(``tensor.pose``). For every scene sample whose normal faces down within 15 degrees of
N_aff (the undersides detection's test points take the outlet for) and lies 0.6-1.8 m high,
one per 3 cm cell, the judge's tests other than penetration are asked in orientation 0 (the
mug's axis is vertical: its support, basin and tap tests barely turn with it); the cells
that pass are judged in full in all 8 orientations. Prints, per scene, how many cells pass
and how many hold a valid pose, and how many of those lie a suppression radius apart (what
could fill a top 5).

    python scripts/filling_anywhere.py --objects ../shared/data/objects \
        --scenes ../shared/data/scenes/*.ply
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import interaction_tensor as it
from interaction_tensor.detect import candidate_mask, suppression_radius
from interaction_tensor.evaluation.judge import Judge, JudgeScene
from interaction_tensor.evaluation.oracle import cheap_judge
from interaction_tensor.examples import interactions
from interaction_tensor.io import load_geometry
from interaction_tensor.settings import DetectSettings


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", required=True)
    ap.add_argument("--scenes", nargs="+", required=True)
    ap.add_argument("--example", default="filling-mug")
    ap.add_argument("--cell", type=float, default=0.03, help="one candidate per cell (m)")
    args = ap.parse_args(argv)
    tensor = interactions.build_descriptor(args.example, args.objects)
    built = interactions.build(args.example, args.objects)
    full = Judge.for_example(built)
    cheap = cheap_judge(full)               # every test but penetration: a necessary check
    radius = suppression_radius(tensor, DetectSettings())
    print(f"| scene | down-facing samples 0.6-1.8 m | {args.cell * 100:g} cm cells | pass without "
          f"the penetration test | hold a valid pose | valid, {radius:.2f} m apart | s |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for path in args.scenes:
        t0 = time.perf_counter()
        geometry = load_geometry(path)
        scene = it.prepare_scene(geometry, 0.01, seed=0)
        p = scene.points
        cand = np.flatnonzero(candidate_mask(scene.normals, tensor.affordance_normal, 15, True)
                              & (p[:, 2] > 0.6) & (p[:, 2] < 1.8))
        _, first = np.unique(np.floor(p[cand] / args.cell).astype(np.int64), axis=0,
                             return_index=True)
        cells = cand[np.sort(first)]
        js = JudgeScene(geometry)
        ok = [q for q in cells if cheap.judge(js, tensor.pose(p[q], 0.0)).valid]
        valid = [q for q in ok if any(full.judge(js, tensor.pose(p[q], o * np.pi / 4)).valid
                                      for o in range(8))]
        apart = []
        for q in valid:
            if all(np.linalg.norm(p[q] - p[k]) >= radius for k in apart):
                apart.append(q)
        print(f"| {Path(path).stem} | {len(cand)} | {len(cells)} | {len(ok)} | {len(valid)} | "
              f"{len(apart)} | {time.perf_counter() - t0:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
