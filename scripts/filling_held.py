"""Diagnosis (not tuning): would a cup *held* under the tap find the published kitchens' taps?

The filling examples stand the mug on the basin bottom 19 cm under the outlet, and no
down-facing sample of the 14 published scenes holds a valid pose of that (filling_anywhere.py):
kitchen1's and kitchen4's taps stand over a double basin's divider. A person fills a mug there
by holding it under the outlet. This fits the Interaction Tensor of the filling-cup example's
cup lifted until its rim is ``--gap`` under the example's outlet (held, touching nothing) and
scores it, in full (no early exit), on a seeded 30 % of each scene's down-facing samples
(detection's candidates, 8 orientations): the best poses within 40 cm of each tap (located by
eye, as in filling_at_taps.py) and, with ``--whole``, the best anywhere in the scene, 15 cm
apart. Nothing here feeds the acceptance.

    python scripts/filling_held.py --objects ../shared/data/objects --shared ../shared/data \
        --gap 0.03 --whole kitchen1
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import interaction_tensor as it
from interaction_tensor.descriptor import InteractionTensor
from interaction_tensor.detect import candidate_mask, score_at
from interaction_tensor.examples import interactions, shapes
from interaction_tensor.io import Geometry, load_geometry
from interaction_tensor.predictions import top_k

#: The taps seen on top views (scene: outlet x, y in metres), as in filling_at_taps.py.
TAPS = {"kitchen1": (7.12, 10.15), "kitchen4": (0.52, 2.78), "kitchen5": (2.16, 0.97)}


def held_tensor(objects: str, gap: float, seed: int = 0) -> InteractionTensor:
    """The filling-cup example with its cup lifted until the rim is ``gap`` (m) under the
    outlet, fitted as detection fits the examples."""
    ex = interactions.build("filling-cup", objects, seed)
    v = ex.query.vertices + [0.0, 0.0, shapes.TAP_OUTLET[2] - gap - ex.query.vertices[:, 2].max()]
    cup = Geometry(v, ex.query.faces, source=f"cup held {gap * 100:g} cm under the outlet")
    return InteractionTensor.fit(cup, ex.scene_object, "filling-cup-held",
                                 interactions.train_settings("filling-cup", seed=seed),
                                 ground=ex.ground)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", required=True)
    ap.add_argument("--shared", required=True)
    ap.add_argument("--gap", type=float, default=0.03, help="rim under the outlet, m")
    ap.add_argument("--whole", nargs="*", default=[], help="scenes also scored everywhere")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    tensor = held_tensor(args.objects, args.gap, args.seed)
    print(f"cup held with its rim {args.gap * 100:g} cm under the outlet; calibrated "
          f"threshold {tensor.threshold():.3f}, tuned filling S_aff "
          f"{interactions.acceptance('filling')['threshold']}\n")
    print("| scene | where | candidates | best 5 scores, 15 cm apart (distance to the tap m) |")
    print("|---|---|---:|---|")
    for name in sorted(set(TAPS) | set(args.whole)):
        t0 = time.perf_counter()
        scene = it.prepare_scene(load_geometry(Path(args.shared) / "scenes" / f"{name}.ply"),
                                 0.01, seed=args.seed)
        p = scene.points
        idx = np.flatnonzero(candidate_mask(scene.normals, tensor.affordance_normal, 15, True))
        idx = idx[np.random.default_rng(args.seed).random(len(idx)) < 0.3]
        tap = np.asarray(TAPS.get(name, (np.nan, np.nan)))
        for where in (["at the tap"] if name in TAPS else []) + (
                ["anywhere"] if name in args.whole else []):
            sel = idx[np.linalg.norm(p[idx, :2] - tap, axis=1) < 0.4] if where != "anywhere" \
                else idx
            pos, orient = np.repeat(sel, 8), np.tile(np.arange(8), len(sel))
            s = score_at(tensor, scene, p[pos], orient)
            best = top_k(p, s, 5, 0.15, index=pos)       # the best 5, 15 cm apart
            cells = ", ".join(f"{s[k]:.3f} ({np.linalg.norm(p[pos[k], :2] - tap):.2f})"
                              if name in TAPS else f"{s[k]:.3f}" for k in best)
            print(f"| {name} | {where} | {len(sel)} | {cells} |", flush=True)
        print(f"<!-- {name}: {time.perf_counter() - t0:.0f} s -->", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
