"""Compare one method's results in two evaluations on the scenes they share.

    python paper/scripts/compare_evaluations.py BEFORE_DIR AFTER_DIR [--method iT-weighted]

Both directories are ``itensor evaluate`` (or ``evaluate-merge``) outputs. Only the scenes of
AFTER_DIR are used from BEFORE_DIR, so that a partial re-run is compared with the same scenes
of a complete one. Prints a Markdown table per affordance: the precision of the top 5 (valid
top poses / top poses), how many of the top poses were accepted and how many of those are
valid, and the (scene, example) runs and scenes with any accepted pair.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

AFFORDANCES = ("placing", "sitting", "filling", "riding", "hanging")


def load(directory: Path, method: str, scenes=None):
    with open(directory / "judgements.csv", newline="") as f:
        judged = [r for r in csv.DictReader(f) if r["method"] == method]
    with open(directory / "runs.csv", newline="") as f:
        runs = [r for r in csv.DictReader(f) if r["method"] == method]
    if scenes is not None:
        judged = [r for r in judged if r["scene"] in scenes]
        runs = [r for r in runs if r["scene"] in scenes]
    return judged, runs


def summary(judged: list, runs: list) -> dict:
    out = {}
    for aff in AFFORDANCES:
        top = [r for r in judged if r["affordance"] == aff and r["group"] == "top"]
        valid = sum(r["valid"] == "True" for r in top)
        accepted = [r for r in top if r["accepted"] == "True"]
        mine = [r for r in runs if r["affordance"] == aff]
        any_acc = [r for r in mine if r["any_accepted"] == "True"]
        out[aff] = {"precision": 100.0 * valid / len(top) if top else float("nan"),
                    "valid": valid, "top": len(top),
                    "accepted": len(accepted),
                    "accepted_valid": sum(r["valid"] == "True" for r in accepted),
                    "runs": f"{len(any_acc)}/{len(mine)}",
                    "scenes": f"{len({r['scene'] for r in any_acc})}/"
                              f"{len({r['scene'] for r in mine})}"}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    ap.add_argument("--method", default="iT-weighted")
    args = ap.parse_args(argv)
    after_j, after_r = load(args.after, args.method)
    scenes = sorted({r["scene"] for r in after_r})
    before = summary(*load(args.before, args.method, set(scenes)))
    after = summary(after_j, after_r)
    print(f"{args.method} on {len(scenes)} scenes: {', '.join(scenes)}\n")
    print("| affordance | before: top-5 precision | before: accepted top poses valid | before: "
          "runs / scenes accepting | after: top-5 precision | after: accepted top poses valid "
          "| after: runs / scenes accepting |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for aff in AFFORDANCES:
        cells = []
        for s in (before[aff], after[aff]):
            cells += [f"{s['precision']:.1f} ({s['valid']}/{s['top']})",
                      f"{s['accepted_valid']}/{s['accepted']}", f"{s['runs']} / {s['scenes']}"]
        print(f"| {aff} | " + " | ".join(cells) + " |")
    mean = [sum(x[a]["precision"] for a in AFFORDANCES) / len(AFFORDANCES) for x in (before, after)]
    print(f"| **average** | {mean[0]:.1f} | | | {mean[1]:.1f} | | |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
