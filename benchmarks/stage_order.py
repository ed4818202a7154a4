"""The placement tests before the score, against the score before the tests, in one process
(issue 16): the same detections, timed side by side.

    python benchmarks/stage_order.py --scenes kitchen5 [--examples placing-bowl ...]
        [--fraction 0.3] [--repeats 1] [--configs reference,before,score-first,tests-first]

The example descriptors are trained as ``itensor evaluate`` trains them (real query objects
from ``../shared/data/objects``). Per scene, one ``detect_many`` pass over them at the
defaults (30 % test points, the neighbour cache) per configuration, alternating,
``--repeats`` times each:

- ``reference``: score first, every pair the score accepts scored over all its keypoints
  (``complete_scores='accepted'``; the exact reference here);
- ``before``: the default of 2026-11-27 (score first, every pair stopped at its decision,
  the placed pairs completed), with the contact tests' nearest samples found by the exact
  nearest-neighbour search as on that day (``clearance._within`` replaced for the run);
- ``score-first``: the same with today's bounded search for the contact tests;
- ``tests-first``: the default since 2026-11-27 (every pair tested, only the placed pairs
  scored).

Checked per descriptor against the reference: identical final decisions, scores of the
accepted pairs, heat map and top 5, and identical placement outcomes wherever the
reference ran the tests. Rates count candidates (test points past the normal filter) over
the seconds that decide every pair: the scoring stage and the placement tests. Prints a
Markdown table and writes ``benchmarks/stage_order.json``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from _protocol import protocol_descriptors, published_scene

HERE = Path(__file__).resolve().parent
CONFIGS = ("reference", "before", "score-first", "tests-first")
SETTINGS = {"reference": {"complete_scores": "accepted", "stage_order": "score-first"},
            "before": {"stage_order": "score-first"},
            "score-first": {"stage_order": "score-first"},
            "tests-first": {"stage_order": "tests-first"}}


@contextmanager
def nearest_contacts(on: bool, scene):
    """With ``on``, the contact and seat tests find each point's nearest sample with the
    exact nearest-neighbour search (the code of 2026-11-27) instead of the bounded one."""
    from interaction_tensor.placement import checks as clearance

    saved = clearance._within
    if on:
        clearance._within = lambda q, lo, hi, grid: clearance.nearest_samples(
            np.reshape(q, (-1, 3)), scene, grid)[0]
    try:
        yield
    finally:
        clearance._within = saved


def same(ref, b) -> bool:
    """Whether a detection gives the reference's results."""
    from interaction_tensor.placement.checks import UNTESTED

    acc = ref.pairs.accepted
    tested = ref.placement != UNTESTED
    return bool(np.array_equal(acc, b.pairs.accepted)
                and np.array_equal(ref.placement[tested], b.placement[tested])
                and np.array_equal(ref.pairs.score[acc], b.pairs.score[acc])
                and np.array_equal(ref.heat, b.heat)
                and [(p.point_index, p.orientation_index, p.score) for p in ref.predictions]
                == [(p.point_index, p.orientation_index, p.score) for p in b.predictions])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", required=True)
    ap.add_argument("--examples", nargs="+", default=None,
                    help="example names (default: the 8 of the protocol)")
    ap.add_argument("--fraction", type=float, default=0.3)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--configs", default=",".join(CONFIGS),
                    help=f"which of {','.join(CONFIGS)} (reference always runs)")
    ap.add_argument("--out", default=str(HERE / "stage_order.json"))
    args = ap.parse_args()
    configs = ["reference"] + [c for c in args.configs.split(",")
                               if c in CONFIGS and c != "reference"]

    import interaction_tensor as it

    names, tensors = protocol_descriptors(args.examples, args.seed)
    rows = []
    for scene_name in args.scenes:
        scene = published_scene(scene_name, args.seed)
        for c in configs:                                   # compile every kernel first
            with nearest_contacts(c == "before", scene):
                it.detect_many(scene, tensors, it.DetectSettings(sample_fraction=0.0005,
                                                                 top_k=0, **SETTINGS[c]))
        runs = {c: [] for c in configs}
        identical = {}
        for r in range(args.repeats):
            for c in (configs if r % 2 == 0 else configs[::-1]):
                st = it.DetectSettings(sample_fraction=args.fraction, seed=args.seed, top_k=5,
                                       **SETTINGS[c])
                t = time.perf_counter()
                with nearest_contacts(c == "before", scene):
                    dets = it.detect_many(scene, tensors, st)
                wall = time.perf_counter() - t
                sec = dets[0].stats["seconds"]
                runs[c].append({"wall_s": wall, "scoring_s": sec["scoring"],
                                "completion_s": sec.get("completion", 0.0),
                                "tests_s": sec["clearance"],
                                "comparisons": sum(d.pairs.comparisons for d in dets),
                                "pairs_scored": sum(d.stats["pairs_scored"] for d in dets)})
                if c == "reference":
                    ref = dets
                else:
                    identical[c] = [same(a, b) for a, b in zip(ref, dets)]
                print(f"{scene_name} {c}: {wall:.1f} s", flush=True)
                del dets
        cands = sum(d.stats["candidates_after_normal_filter"] for d in ref)
        med = {c: {k: float(np.median([x[k] for x in runs[c]])) for k in runs[c][0]}
               for c in configs}
        rows.append({"scene": scene_name, "points": len(scene), "candidates": int(cands),
                     "pairs": int(sum(len(d.pair_point) for d in ref)),
                     "median": med, "runs": runs, "identical": identical})
        del scene, ref
    out = {"date": datetime.datetime.now().isoformat(timespec="seconds"),
           "machine": f"{platform.machine()}, {os.cpu_count()} cores, "
                      f"Python {platform.python_version()}",
           "command": "python benchmarks/stage_order.py --scenes " + " ".join(args.scenes)
                      + (f" --examples {' '.join(args.examples)}" if args.examples else "")
                      + f" --fraction {args.fraction} --repeats {args.repeats}"
                      + f" --configs {','.join(configs)}",
           "examples": names, "rows": rows}
    Path(args.out).write_text(json.dumps(out, indent=1))
    print(f"\n{out['command']} ({out['date']}, {out['machine']})\n")
    print("| scene | candidates | configuration | detection s | deciding s (tests + scoring "
          "+ completion) | candidates/s | pairs scored | comparisons | identical to the "
          "reference |")
    print("|---|---:|---|---:|---:|---:|---:|---:|---|")
    for r in rows:
        for c in configs:
            x = r["median"][c]
            dec = x["tests_s"] + x["scoring_s"] + x["completion_s"]
            same_ = r["identical"].get(c)
            print(f"| {r['scene']} | {r['candidates']:,} | {c} | {x['wall_s']:.1f} | "
                  f"{dec:.1f} ({x['tests_s']:.1f} + {x['scoring_s']:.1f} + "
                  f"{x['completion_s']:.1f}) | {r['candidates'] / dec:,.0f} | "
                  f"{x['pairs_scored']:,.0f} | {x['comparisons'] / 1e6:,.0f} M | "
                  f"{'(reference)' if same_ is None else f'{sum(same_)}/{len(same_)}'} |")
        ref = r["median"]["reference"]
        for c in configs[1:]:
            x = r["median"][c]
            print(f"{r['scene']}: {c} {ref['wall_s'] / x['wall_s']:.2f}x the reference's "
                  f"detection speed"
                  + (f", {r['median']['before']['wall_s'] / x['wall_s']:.2f}x before's"
                     if "before" in r["median"] and c != "before" else ""))
        print()


if __name__ == "__main__":
    main()
