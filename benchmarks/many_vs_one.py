"""Eight descriptors in one pass against one, at the protocol's settings (issue 16: the 8 at
most 3x one), in one process.

    python benchmarks/many_vs_one.py [--scene kitchen5] [--one placing-bowl]
        [--fraction 0.3] [--repeats 1] [--each]

The 8 example descriptors are trained as ``itensor evaluate`` trains them (real query
objects from ``../shared/data/objects``). On one scene at the defaults (30 % test points,
the neighbour cache, the placement tests first), with no top k (as ``benchmarks/protocol.py``):
``detect_many`` over the one descriptor alone, then over all 8 (the one among them),
alternating, ``--repeats`` times each. Checked: the one descriptor's detection is the same
alone and among the 8 (decisions, accepted scores, heat map). Prints the seconds of the
detection and of deciding (the placement tests and the scoring), and their ratios; with
``--each`` also each of the 8 alone, once (the one pass against their sum: what sharing the
test points and the scene index saves). Writes ``benchmarks/many_vs_one.json``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import time
from pathlib import Path

import numpy as np
from _protocol import protocol_descriptors, published_scene

HERE = Path(__file__).resolve().parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="kitchen5")
    ap.add_argument("--one", default="placing-bowl", help="the one descriptor (an example)")
    ap.add_argument("--fraction", type=float, default=0.3)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--each", action="store_true",
                    help="also each of the 8 alone, once: the sum of their times against the "
                         "one pass (what the shared test points and scene index save)")
    ap.add_argument("--out", default=str(HERE / "many_vs_one.json"))
    args = ap.parse_args()

    import interaction_tensor as it

    names, tensors = protocol_descriptors(seed=args.seed)
    one = names.index(args.one)
    scene = published_scene(args.scene, args.seed)
    it.detect_many(scene, tensors, it.DetectSettings(sample_fraction=0.0005, top_k=0))
    settings = it.DetectSettings(sample_fraction=args.fraction, top_k=0, seed=args.seed)
    runs = {"one": [], "eight": []}
    kept = {}
    for r in range(args.repeats):
        for which in (("one", "eight") if r % 2 == 0 else ("eight", "one")):
            group = [tensors[one]] if which == "one" else tensors
            t = time.perf_counter()
            dets = it.detect_many(scene, group, settings)
            wall = time.perf_counter() - t
            runs[which].append({"detect_s": wall,
                                "deciding_s": dets[0].stats["deciding_seconds"],
                                "candidates": sum(d.stats["candidates_after_normal_filter"]
                                                  for d in dets)})
            kept[which] = dets[0 if which == "one" else one]
            print(f"{args.scene} {which}: {wall:.1f} s", flush=True)
            del dets
    each = {}
    if args.each:
        for n, t in zip(names, tensors):
            t0 = time.perf_counter()
            it.detect_many(scene, [t], settings)
            each[n] = time.perf_counter() - t0
            print(f"{args.scene} {n} alone: {each[n]:.1f} s", flush=True)
    a, b = kept["one"], kept["eight"]
    acc = a.pairs.accepted
    same = bool(np.array_equal(acc, b.pairs.accepted)
                and np.array_equal(a.pairs.score[acc], b.pairs.score[acc])
                and np.array_equal(a.heat, b.heat))
    med = {k: {m: float(np.median([x[m] for x in v])) for m in v[0]} for k, v in runs.items()}
    out = {"date": datetime.datetime.now().isoformat(timespec="seconds"),
           "machine": f"{platform.machine()}, {os.cpu_count()} cores, "
                      f"Python {platform.python_version()}",
           "command": f"python benchmarks/many_vs_one.py --scene {args.scene} --one {args.one}"
                      f" --fraction {args.fraction} --repeats {args.repeats}"
                      + (" --each" if args.each else ""),
           "examples": names, "one": args.one, "points": len(scene), "median": med,
           "runs": runs, "same_detection_alone_and_among_8": same,
           "detect_ratio": med["eight"]["detect_s"] / med["one"]["detect_s"],
           "deciding_ratio": med["eight"]["deciding_s"] / med["one"]["deciding_s"],
           "each_alone_s": each}
    Path(args.out).write_text(json.dumps(out, indent=1))
    print(f"\n{out['command']} ({out['date']}, {out['machine']})\n")
    print("| descriptors | candidates | detection s | deciding s (tests and scoring) |")
    print("|---|---:|---:|---:|")
    for k, label in (("one", f"1 ({args.one})"), ("eight", "8")):
        x = med[k]
        print(f"| {label} | {x['candidates']:,.0f} | {x['detect_s']:.1f} | "
              f"{x['deciding_s']:.1f} |")
    print(f"\n8 descriptors: {out['detect_ratio']:.2f}x one's detection, "
          f"{out['deciding_ratio']:.2f}x its deciding; the one's detection the same alone and "
          f"among the 8: {same}")
    if each:
        total = sum(each.values())
        print(f"each alone: {', '.join(f'{n} {v:.1f} s' for n, v in each.items())}; "
              f"sum {total:.1f} s: the one pass takes {med['eight']['detect_s'] / total:.2f}x "
              f"the sum, {med['eight']['detect_s'] / (total / len(each)):.2f}x the mean single")


if __name__ == "__main__":
    main()
