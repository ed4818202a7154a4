"""Completing only the placed pairs' scores, against completing every accepted pair's, in one
process (issue 16): the same detections, timed side by side.

    python benchmarks/completion.py --scenes kitchen3 [--examples placing-bowl ...]
        [--fraction 0.3] [--repeats 1]

The example descriptors are trained as ``itensor evaluate`` trains them (real query objects
from ``../shared/data/objects``). Per scene, one ``detect_many`` pass over them at the
defaults (30 % test points, the neighbour cache) with ``complete_scores='accepted'`` (every
pair the score accepts scored over all its keypoints: the behaviour before 2026-11-27, the
exact reference here) and one with ``'placed'`` (every pair stops at its decision; the pairs
that pass the placement tests go on from there), alternating, ``--repeats`` times each.
Checked per descriptor: identical decisions, placement outcomes, scores of the accepted
pairs, heat map and top 5. Then the clearance count of the score-accepted pairs, every
clearance point counted against the count that stops past the limit (identical outcomes).
Prints a Markdown table and writes ``benchmarks/completion.json``.
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
MODES = ("accepted", "placed")


def same(a, b) -> bool:
    """Whether two detections of one descriptor give the same results."""
    acc = a.pairs.accepted
    return bool(np.array_equal(acc, b.pairs.accepted)
                and np.array_equal(a.placement, b.placement)
                and np.array_equal(a.pairs.decided_at, b.pairs.decided_at)
                and np.array_equal(a.pairs.score[acc], b.pairs.score[acc])
                and np.array_equal(a.heat, b.heat)
                and [(p.point_index, p.orientation_index, p.score) for p in a.predictions]
                == [(p.point_index, p.orientation_index, p.score) for p in b.predictions])


def clearance_counts(scene, tensor, det, settings) -> dict:
    """The clearance count of ``det``'s score-accepted pairs, timed: every clearance point
    against the count that stops at the first past the limit."""
    from interaction_tensor.placement.checks import clearance_offsets, count_violations

    k = len(tensor.clearance_points)
    idx = np.flatnonzero(det.score_accepted)
    if not k or not len(idx):
        return {"pairs": int(len(idx)), "full_s": 0.0, "stopped_s": 0.0, "same_outcome": True}
    pts = scene.points[det.pair_point[idx]]
    orient = np.asarray(det.pair_orientation[idx], np.int64)
    off = clearance_offsets(tensor, settings.n_orientations)
    limit = tensor.clearance_limit
    grid = scene.grid()
    out = {}
    for name, stop in (("full", None), ("stopped", int(np.floor(limit * k)) + 1)):
        t = time.perf_counter()
        v = count_violations(pts, orient, off, tensor.clearance_radius,
                             settings.clearance_tolerance, scene, grid, stop=stop)
        out[name + "_s"] = round(time.perf_counter() - t, 3)
        out[name] = v > limit * k
    return {"pairs": int(len(idx)), "full_s": out["full_s"], "stopped_s": out["stopped_s"],
            "same_outcome": bool(np.array_equal(out["full"], out["stopped"]))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", required=True)
    ap.add_argument("--examples", nargs="+", default=None,
                    help="example names (default: the 8 of the protocol)")
    ap.add_argument("--fraction", type=float, default=0.3)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=str(HERE / "completion.json"))
    args = ap.parse_args()

    import interaction_tensor as it

    names, tensors = protocol_descriptors(args.examples, args.seed)
    rows = []
    for scene_name in args.scenes:
        scene = published_scene(scene_name, args.seed)
        it.detect_many(scene, tensors, it.DetectSettings(sample_fraction=0.0005, top_k=0))
        runs = {m: [] for m in MODES}
        dets = {}
        for r in range(args.repeats):
            for m in (MODES if r % 2 == 0 else MODES[::-1]):
                # both score first (the order this benchmark compares completions in;
                # the default since 2026-11-27 tests first: benchmarks/stage_order.py)
                st = it.DetectSettings(sample_fraction=args.fraction, seed=args.seed, top_k=5,
                                       complete_scores=m, stage_order="score-first")
                t = time.perf_counter()
                dets[m] = it.detect_many(scene, tensors, st)
                wall = time.perf_counter() - t
                sec = dets[m][0].stats["seconds"]
                runs[m].append({"wall_s": wall, "scoring_s": sec["scoring"],
                                "completion_s": sec.get("completion", 0.0),
                                "clearance_s": sec["clearance"],
                                "comparisons": sum(d.pairs.comparisons for d in dets[m])})
                print(f"{scene_name} {m}: {wall:.1f} s", flush=True)
        identical = [same(a, b) for a, b in zip(dets["accepted"], dets["placed"])]
        counts = [clearance_counts(scene, t, d, d.settings)
                  for t, d in zip(tensors, dets["placed"])]
        cands = sum(d.stats["candidates_after_normal_filter"] for d in dets["placed"])
        med = {m: {k: float(np.median([x[k] for x in runs[m]])) for k in runs[m][0]}
               for m in MODES}
        rows.append({"scene": scene_name, "points": len(scene), "candidates": int(cands),
                     "pairs": int(sum(len(d.pair_point) for d in dets["placed"])),
                     "pairs_completed": int(sum(d.stats["pairs_completed"]
                                                for d in dets["placed"])),
                     "median": med, "runs": runs, "identical": identical,
                     "clearance_count": dict(zip(names, counts))})
        del scene, dets
    out = {"date": datetime.datetime.now().isoformat(timespec="seconds"),
           "machine": f"{platform.machine()}, {os.cpu_count()} cores, "
                      f"Python {platform.python_version()}",
           "command": "python benchmarks/completion.py --scenes " + " ".join(args.scenes)
                      + (f" --examples {' '.join(args.examples)}" if args.examples else "")
                      + f" --fraction {args.fraction} --repeats {args.repeats}",
           "examples": names, "rows": rows}
    Path(args.out).write_text(json.dumps(out, indent=1))
    print(f"\n{out['command']} ({out['date']}, {out['machine']})\n")
    print("| scene | candidates | complete scores | detection s | scoring s (decisions + "
          "completion) | candidates/s | comparisons | identical results |")
    print("|---|---:|---|---:|---:|---:|---:|---|")
    for r in rows:
        for m in MODES:
            x = r["median"][m]
            sc = x["scoring_s"] + x["completion_s"]
            print(f"| {r['scene']} | {r['candidates']:,} | {m} | {x['wall_s']:.1f} | "
                  f"{sc:.1f} ({x['scoring_s']:.1f} + {x['completion_s']:.1f}) | "
                  f"{r['candidates'] / sc:,.0f} | {x['comparisons'] / 1e6:,.0f} M | "
                  f"{sum(r['identical'])}/{len(r['identical'])} |")
        a, p = r["median"]["accepted"], r["median"]["placed"]
        print(f"\n{r['scene']}: 'placed' {a['wall_s'] / p['wall_s']:.2f}x the detection speed, "
              f"{(a['scoring_s'] + a['completion_s']) / (p['scoring_s'] + p['completion_s']):.2f}x"
              f" the scoring's; {r['pairs_completed']:,} of {r['pairs']:,} pairs completed")
        cc = r["clearance_count"]
        full = sum(c["full_s"] for c in cc.values())
        stopped = sum(c["stopped_s"] for c in cc.values())
        print(f"clearance count of the score-accepted pairs: every point {full:.1f} s, stopped "
              f"past the limit {stopped:.1f} s ({full / max(stopped, 1e-9):.2f}x), identical "
              f"outcomes: {all(c['same_outcome'] for c in cc.values())}\n")


if __name__ == "__main__":
    main()
