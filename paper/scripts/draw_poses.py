"""Draw poses of an example in a published scene: one row of four close-ups (front, side,
oblique, above) per pose, green where the judge finds it valid and red where not (its
reasons printed), to look at before trusting a verdict; with ``--neutral``, every pose in
the blind panel's one colour and no verdict, a sheet to show raters.

    python paper/scripts/draw_poses.py --objects ../shared/data/objects --scene kitchen1 \\
        --example filling-mug --family standing -o out.png 7.098,10.115,0.884,0 ...

Each pose is ``x,y,z,k``: a scene point and an orientation k of 8, or 16 numbers (a 4x4 pose
row by row, as the ``pose`` column of ``judgements.csv``, spaces or commas). ``--family detection``
poses the example as detection does (``InteractionTensor.pose`` at the point, turned by
k x 45 degrees); ``standing`` stands a filling example's mug on the point, turned about its
opening's axis (``evaluation.oracle.standing_pose``, the exhaustive filling search's poses).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from PIL import Image

from interaction_tensor import affordances
from interaction_tensor.geometry.load import load_geometry
from itensor_paper import pictures as P
from itensor_paper.judge import Judge, JudgeScene
from itensor_paper.oracle import standing_pose
from itensor_paper.panel import NEUTRAL


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", required=True)
    ap.add_argument("--scene", required=True, help="a published scene's name")
    ap.add_argument("--example", required=True)
    ap.add_argument("--family", choices=("detection", "standing"), default="detection")
    ap.add_argument("--neutral", action="store_true",
                    help="the panel's one colour and no verdict: a sheet for raters")
    ap.add_argument("-o", "--output", required=True)
    ap.add_argument("poses", nargs="+", help="x,y,z,k or a 4x4 pose (16 numbers)")
    args = ap.parse_args(argv)
    objects = Path(args.objects)
    ex = affordances.build(args.example, objects)
    geometry = load_geometry(objects.parent / "scenes" / f"{args.scene}.ply")
    sp, sn = P._samples(geometry, 0.01)
    qp, qn = P._samples(ex.query, 0.003)
    judge = Judge.for_example(ex)
    js = JudgeScene(geometry)
    if args.family == "standing":
        support = np.asarray(ex.support_point, float)
        pivot = np.r_[judge.opening[:2], support[2]]
    else:
        tensor = affordances.build_descriptor(args.example, objects, example=ex)
    rows = []
    for text in args.poses:
        values = [float(v) for v in text.replace(",", " ").split()]
        if len(values) == 16:
            pose = np.array(values).reshape(4, 4)
        elif len(values) == 4:
            x, y, z, k = values
            pose = (standing_pose(pivot, [x, y, z], 2 * np.pi * k / 8)
                    if args.family == "standing"
                    else tensor.pose(np.array([x, y, z]), 2 * np.pi * k / 8))
        else:
            ap.error(f"{text!r}: expected x,y,z,k or 16 numbers")
        if args.neutral:
            colour = NEUTRAL
        else:
            v = judge.judge(js, pose)
            print(f"{text}: {'valid' if v.valid else 'invalid: ' + '; '.join(v.reasons)}")
            colour = P.VALID if v.valid else P.INVALID
        rows.append(np.hstack([P.closeup(sp, sn, qp, qn, pose, colour, spacing=0.01,
                                         azimuths=(az,), elevation=el, size=(420, 340),
                                         margin=0.35)
                               for az, el in ((0, 10), (90, 10), (45, 40), (0, 85))]))
    Image.fromarray(np.vstack(rows)).save(args.output)
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
