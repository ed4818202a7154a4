"""Draw an evaluation's close-up pictures again from the poses in its ``judgements.csv``.

    python scripts/redraw_pictures.py EVAL_DIR --scenes ../shared/data/scenes \
        [--objects ../shared/data/objects]

For runs made before a change to the pictures (``interaction_tensor.evaluation.pictures``), or
merged with ``itensor evaluate-merge``: the numbers are not touched, only ``pictures/``.
"""

from __future__ import annotations

import argparse

from interaction_tensor.evaluation.pictures import redraw


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    ap.add_argument("eval_dir")
    ap.add_argument("--scenes", required=True, help="directory of the evaluated scenes")
    ap.add_argument("--objects", default=None, help="directory of the real query objects "
                                                    "(default: the run's own)")
    args = ap.parse_args()
    n = redraw(args.eval_dir, args.scenes, args.objects)
    print(f"drew {n} pictures in {args.eval_dir}/pictures")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
