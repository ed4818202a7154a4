"""Regenerate the labelled pose set that proves the judge.

    python paper/scripts/make_labelled_set.py [--objects ../shared/data/objects] [-o FILE]
    python paper/scripts/make_labelled_set.py --summary build/paper/labelled_set.md

Writes ``paper/src/itensor_paper/data/labelled_poses.json`` (by default): every
validation scene's sites turned into valid poses and hard negatives for the five affordances'
examples (:mod:`itensor_paper.labelled`), plus the hand-posed cases in the
published scenes. Deterministic: the same code and data give the same file. ``--summary``
judges the committed set instead and writes its case-by-case summary (Markdown).
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path

from itensor_paper import labelled
from itensor_paper.report import judge_markdown

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    ap.add_argument("--objects", default=str(ROOT.parent / "shared" / "data" / "objects"),
                    help="directory of the real query objects (default ../shared/data/objects)")
    ap.add_argument("-o", "--output", default=str(labelled.DATA_FILE))
    ap.add_argument("--summary", default=None,
                    help="judge the committed set and write its summary here instead")
    args = ap.parse_args()
    objects = Path(args.objects)
    if args.summary:

        rows, verdicts = labelled.judge_accuracy(labelled.load(), str(objects), objects.parent)
        Path(args.summary).write_text(
            "# The labelled pose set that proves the judge\n\n"
            "Made by `python paper/scripts/make_labelled_set.py` "
            "(`paper/src/itensor_paper/data/labelled_poses.json`); "
            "this summary by `python paper/scripts/make_labelled_set.py --summary "
            f"{args.summary}`.\n\n" + judge_markdown(rows) + "\n\n"
            + labelled.summary_markdown(verdicts) + "\n")
        print(f"wrote {args.summary}")
        return 0
    poses = labelled.generate(str(objects), shared_dir=objects.parent)
    labelled.save(poses, args.output, meta={"objects": "shared/data/objects",
                                            "generator": "scripts/make_labelled_set.py"})
    counts = Counter((p.affordance, p.valid) for p in poses)
    for aff in ("placing", "sitting", "filling", "riding", "hanging"):
        print(f"{aff:<8} valid {counts[(aff, True)]:>4}  invalid {counts[(aff, False)]:>4}")
    print(f"wrote {args.output} ({len(poses)} poses)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
