"""Diagnosis (not tuning): what the filling example scores at the taps of the published kitchens.

The taps were located by eye on top views of the scenes (``TAPS``: the spout's outlet, x y
in metres). For every scene sample within 30 cm of it, 0.9-1.5 m high, whose normal is
within 45 degrees of N_aff (down: the underside of the spout), and each of the 8
orientations, the full score of the filling example (no early exit) and the judge's verdict
on the pose; and how far below the outlet the first upward-facing surface lies (the basin's
bottom), against the example's. Prints a Markdown table and, with ``--pictures DIR``, draws
the 4 best poses at each tap (green: the judge passes it, red: it fails). Nothing here feeds
the acceptance.

    python scripts/filling_at_taps.py --objects ../shared/data/objects --shared ../shared/data \
        --pictures docs/results/filling-taps-2026-11-26
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import interaction_tensor as it
from interaction_tensor.detect import candidate_mask, score_at
from interaction_tensor.evaluation.judge import Judge, JudgeScene
from interaction_tensor.examples import interactions, shapes
from interaction_tensor.io import load_geometry

#: The taps seen on top views (scene: outlet x, y in metres).
TAPS = {"kitchen1": (7.12, 10.15), "kitchen4": (0.52, 2.78), "kitchen5": (2.16, 0.97)}


def drop_below(scene, xy, top: float) -> float:
    """Height (m) from ``top`` down to the highest sample one can stand on at least 2 cm
    below it in the 2 cm columns around ``xy``
    (:meth:`~interaction_tensor.scene.Scene.highest_under`); inf where there is none."""
    below = scene.highest_under(np.asarray(xy, float).reshape(1, 1, 2), np.array([top - 0.02]))
    return float(top - below[0])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", required=True)
    ap.add_argument("--shared", required=True)
    ap.add_argument("--pictures", help="folder for a picture per tap")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    example = "filling-mug"
    tensor = interactions.build_descriptor(example, args.objects)
    built = interactions.build(example, args.objects)
    judge = Judge.for_example(built)
    drop = shapes.TAP_OUTLET[2] - shapes.SINK_BOTTOM
    print(f"{example}: S_aff {tensor.threshold():.3f}; the example's outlet is {drop:.2f} m "
          "above the basin bottom\n")
    print("| scene | candidate points | best score | 99th percentile | outlet above the "
          "surface below it m | judge on the 10 best |")
    print("|---|---:|---:|---:|---:|---|")
    for name, xy in TAPS.items():
        geometry = load_geometry(Path(args.shared) / "scenes" / f"{name}.ply")
        scene = it.prepare_scene(geometry, 0.01, seed=0)
        p = scene.points
        near = (np.linalg.norm(p[:, :2] - xy, axis=1) < 0.3) & (p[:, 2] > 0.9) & (p[:, 2] < 1.5)
        idx = np.flatnonzero(near & candidate_mask(scene.normals, tensor.affordance_normal,
                                                   45, True))
        pos = np.repeat(idx, 8)
        orient = np.tile(np.arange(8), len(idx))
        s = score_at(tensor, scene, p[pos], orient)
        best = np.argsort(-s)[:10]
        js = JudgeScene(geometry)
        reasons, drawn = {}, []
        for k in best:
            pose = tensor.pose(p[pos[k]], orient[k] * np.pi / 4)
            v = judge.judge(js, pose)
            if len(drawn) < 4:
                drawn.append((pose, v.valid, f"score {s[k]:.2f} at {np.round(p[pos[k]], 2)}\n"
                                             + ("valid" if v.valid else "; ".join(v.reasons))))
            for r in v.reasons or ["valid"]:
                key = r.split(" (")[0] if "basin" not in r else "not in a basin"
                key = "main contact not touching" if key.startswith("main contact") else key
                reasons[key] = reasons.get(key, 0) + 1
        if args.pictures:
            from interaction_tensor.evaluation.pictures import sheet

            sheet(Path(args.pictures) / f"{example}__{name}.png", geometry, built.query,
                  [d[0] for d in drawn], [d[1] for d in drawn], [d[2] for d in drawn],
                  f"{example} at the tap of {name}: its 4 best poses")
        top = p[pos[best[0]]]
        print(f"| {name} | {len(idx)} | {s.max():.3f} | {np.percentile(s, 99):.3f} | "
              f"{drop_below(scene, top[:2], top[2]):.2f} | "
              + "; ".join(f"{k} {v}" for k, v in sorted(reasons.items(), key=lambda x: -x[1]))
              + " |")
    print(f"\n({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
