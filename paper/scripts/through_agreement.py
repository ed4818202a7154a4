"""How well the sampled through test (every pair) agrees with the exact one (python-fcl, the
pairs detection ranks): both asked of the same pairs of a hanging descriptor in the validation
rooms and in published scenes.

    python paper/scripts/through_agreement.py [--examples hanging-hanger hanging-handbag]
        [--published ../shared/data/scenes/office-desk2.ply ...] [--pairs 4000] [--seed 0]

For each (scene, example): a seeded sample of ``--pairs`` (test point, orientation) pairs
among the scene's points (every orientation of the points drawn), the exact test
(``MeshCollider.collides`` of the descriptor's through body), the sampled test on the Numba
grid and on the cKDTree reference. Prints a Markdown table: pairs, exact crossed, sampled
crossed, both, exact only (the sampled test would drop a pair the exact test passes), sampled
only (the exact test still rejects it at ranking), and whether the two sampled paths agree.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.placement.checks import through_crossed
from itensor_paper.rooms import validation


def main(argv=None) -> int:

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--examples", nargs="+", default=["hanging-hanger", "hanging-handbag"])
    ap.add_argument("--published", nargs="*", default=[])
    ap.add_argument("--pairs", type=int, default=4000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--spacing", type=float, default=0.01)
    args = ap.parse_args(argv)
    tensors = {n: affordances.build_descriptor(n, seed=args.seed, spacing=args.spacing)
               for n in args.examples}
    scenes = [(name, lambda name=name: it.prepare_scene(validation.build_scene(name).geometry,
                                                        args.spacing, seed=args.seed))
              for name in validation.scene_names()]
    scenes += [(p.rsplit("/", 1)[-1].removesuffix(".ply"),
                lambda p=p: it.load_scene(p, args.spacing)) for p in args.published]
    print("| scene | example | pairs | exact | sampled | both | exact only | sampled only | "
          "paths agree | exact s | sampled s |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---|---:|---:|")
    for name, make in scenes:
        scene = make()
        collider = scene.collider()
        rng = np.random.default_rng(args.seed)
        for n, tensor in tensors.items():
            n_o = 8
            pick = rng.choice(len(scene), max(1, args.pairs // n_o), replace=False)
            pts = np.repeat(scene.points[pick], n_o, axis=0)
            orient = np.tile(np.arange(n_o), len(pick))
            body = tensor.through_body()
            t = time.perf_counter()
            exact = np.array([collider.collides(body, tensor.pose(p, 2 * np.pi * o / n_o))
                              for p, o in zip(pts, orient)])
            t_exact = time.perf_counter() - t
            t = time.perf_counter()
            fast = through_crossed(pts, orient, tensor, scene, n_o, scene.grid())
            t_fast = time.perf_counter() - t
            ref = through_crossed(pts, orient, tensor, scene, n_o, None)
            print(f"| {name} | {n} | {len(pts)} | {exact.sum()} | {fast.sum()} | "
                  f"{(exact & fast).sum()} | {(exact & ~fast).sum()} | {(fast & ~exact).sum()} | "
                  f"{'yes' if (fast == ref).all() else f'no ({(fast != ref).sum()})'} | "
                  f"{t_exact:.2f} | {t_fast:.3f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
