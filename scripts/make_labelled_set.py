"""Regenerate the labelled pose set that proves the judge.

    python scripts/make_labelled_set.py [--objects ../shared/data/objects] [-o FILE]

Writes ``src/interaction_tensor/evaluation/data/labelled_poses.json`` (by default): every
validation scene's sites turned into valid poses and hard negatives for the five affordances'
examples (:mod:`interaction_tensor.evaluation.labelled`), plus the hand-posed cases in the
published scenes. Deterministic: the same code and data give the same file.
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path

from interaction_tensor.evaluation import labelled

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    ap.add_argument("--objects", default=str(ROOT.parent / "shared" / "data" / "objects"),
                    help="directory of the real query objects (default ../shared/data/objects)")
    ap.add_argument("-o", "--output", default=str(labelled.DATA_FILE))
    args = ap.parse_args()
    objects = Path(args.objects)
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
