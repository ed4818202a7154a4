"""Diagnosis (not tuning): does a box of a published scene hold any valid pose of an example?

Judges the example descriptor's own poses (``InteractionTensor.pose``: the family detection
proposes) at every judge sample in the box whose normal line is within 15 degrees of the
descriptor's N_aff, in ``--orientations`` orientations (8 is detection's; more to see whether
the 45-degree steps alone miss a place), optionally one sample per ``--cell`` m in plan
(:func:`itensor_paper.oracle.region_poses`). Used for the seats a method found
no valid sitter on (a chair pushed under a table); prints one Markdown row per box.

    python paper/scripts/region_oracle.py --objects ../shared/data/objects --example sitting-human \\
        --scene ../shared/data/scenes/office-desk1.ply --box 0.1,-0.26,0.37 0.55,0.25,0.48
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from interaction_tensor import affordances
from interaction_tensor.geometry.load import load_geometry
from itensor_paper.common import write_csv
from itensor_paper.judge import Judge, JudgeScene
from itensor_paper.oracle import region_poses


def _xyz(text: str) -> tuple:
    v = tuple(float(x) for x in text.split(","))
    if len(v) != 3:
        raise argparse.ArgumentTypeError(f"{text!r}: expected x,y,z")
    return v


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", required=True)
    ap.add_argument("--example", required=True)
    ap.add_argument("--scene", required=True)
    ap.add_argument("--box", nargs=2, type=_xyz, default=None, metavar="X,Y,Z",
                    help="lower and upper corners (m); default: the whole scene")
    ap.add_argument("--orientations", type=int, default=8)
    ap.add_argument("--cell", type=float, default=None, help="one sample per cell (m)")
    ap.add_argument("--cell-3d", action="store_true",
                    help="one sample per cell cube, not per cell in plan (a whole room)")
    ap.add_argument("--valid-csv", default=None,
                    help="write the valid poses here (x, y, z, orientation)")
    args = ap.parse_args(argv)
    ex = affordances.build(args.example, args.objects)
    tensor = affordances.build_descriptor(args.example, args.objects, example=ex)
    js = JudgeScene(load_geometry(args.scene))
    if args.box is None:
        args.box = (tuple(js.points.min(axis=0) - 1e-6), tuple(js.points.max(axis=0) + 1e-6))
    t0 = time.perf_counter()
    res = region_poses(js, Judge.for_example(ex), tensor, args.box[0], args.box[1],
                       args.orientations, args.cell, cell_3d=args.cell_3d, progress=True)
    if args.valid_csv:
        write_csv(Path(args.valid_csv),
                  [{"scene": Path(args.scene).stem, "example": args.example,
                    "x": float(res.points[i, 0]), "y": float(res.points[i, 1]),
                    "z": float(res.points[i, 2]), "orientation": k} for i, k in res.valid],
                  ["scene", "example", "x", "y", "z", "orientation"])
    why = ", ".join(f"{r} {c}" for r, c in res.reasons.most_common(4))
    print("| scene | example | box (m) | samples | orientations | poses | valid | reasons | s |")
    print("|---|---|---|---:|---:|---:|---:|---|---:|")
    box = " - ".join(",".join(f"{v:.2f}" for v in c) for c in args.box)
    print(f"| {Path(args.scene).stem} | {args.example} | {box} | "
          f"{res.samples:,} | {args.orientations} | {res.poses:,} | {len(res.valid)} | {why} | "
          f"{time.perf_counter() - t0:.0f} |")
    for i, k in res.valid[:20]:
        print(f"valid: {res.points[i].round(3).tolist()} orientation {k}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
