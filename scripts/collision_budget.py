"""How many exact collision tests a ranking spends before its top k are found, and what they
cost: detection as ``itensor evaluate`` runs it (30 % test points, the weight order, the
neighbour cache), then the top k ranked with a collision budget, judged and drawn.

    python scripts/collision_budget.py SCENE.ply EXAMPLE [--budget 50000] [--k 5]
        [--objects ../shared/data/objects] [--picture out.png]

Prints one line: scene, example, budget, collision tests spent, seconds in them, whether the
budget ran out, pairs failing the exact tests (and of them with nothing through the hook),
how many of the top k are accepted (passed every test) and how many the judge calls valid.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np


def main(argv=None) -> int:
    import interaction_tensor as it
    from interaction_tensor.detect import collision_check, rank_pairs
    from interaction_tensor.evaluation.common import ranking_radius
    from interaction_tensor.evaluation.judge import Judge, JudgeScene
    from interaction_tensor.examples import interactions
    from interaction_tensor.io import load_geometry

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("example")
    ap.add_argument("--budget", type=int, default=it.DetectSettings().collision_max_tests)
    ap.add_argument("--k", type=int, default=5)
    ap.add_argument("--objects", default=str(Path(__file__).resolve().parents[1].parent
                                             / "shared" / "data" / "objects"))
    ap.add_argument("--picture", default=None)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    scene = it.load_scene(args.scene, 0.01)
    ex = interactions.build(args.example, args.objects)
    tensor = interactions.build_descriptor(args.example, args.objects, example=ex)
    det = it.detect(scene, tensor, it.DetectSettings(
        sample_fraction=0.3, top_k=0, seed=args.seed, keypoint_order="weight",
        neighbour_cache=True, collision_max_tests=args.budget))
    t = time.perf_counter()
    top, score, ok = rank_pairs(det, args.k, ranking_radius(tensor))
    seconds = time.perf_counter() - t
    check = collision_check(det).stats()
    geometry = load_geometry(args.scene)
    judge, jscene = Judge.for_example(ex), JudgeScene(geometry)
    n_o = det.settings.n_orientations
    poses = [tensor.pose(scene.points[det.pair_point[i]],
                         2 * np.pi * det.pair_orientation[i] / n_o) for i in top]
    verdicts = [judge.judge(jscene, p) for p in poses]
    accepted = det.pairs.accepted[top] & ok
    print(f"{Path(args.scene).stem} {args.example} budget {args.budget}: "
          f"{check['collision_tests']} tests in {seconds:.1f} s (exhausted: "
          f"{check['collision_tests_exhausted']}), failing {check['pairs_failing_collision']} "
          f"(nothing through {check['pairs_with_nothing_through']}); top {len(top)}: "
          f"accepted {int(accepted.sum())}, judged valid {sum(v.valid for v in verdicts)}")
    if args.picture:
        from interaction_tensor.evaluation.pictures import sheet

        sheet(Path(args.picture), geometry, ex.query, poses, [v.valid for v in verdicts],
              [f"#{k + 1} {score[k]:.3f} {'accepted' if accepted[k] else 'rejected'}\n"
               + ("valid" if v.valid else "; ".join(v.reasons)) for k, v in enumerate(verdicts)],
              f"{args.example} in {Path(args.scene).stem}: top {len(top)}, collision budget "
              f"{args.budget}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
