"""Diagnosis (not tuning): does any published scene hold a valid filling pose at all?

The judge (``evaluation/judge.py``) calls a filling pose valid when the mug stands upright on
a support, touching it, with a tap-like surface over its opening (2-30 cm above the rim,
within 3 cm of its axis, reaching it from one side), in a basin, without penetrating the
scene. This judges **every standing pose** of an example's mug that the scene's samples
allow, not only the poses a detector proposes (:func:`itensor_paper.oracle.
standing_filling`): the mug's base on each of the judge's own scene samples whose normal line
is within 25 degrees of vertical (all of them, about one per square centimetre of surface),
in 8 orientations about its opening's axis. A pose is judged when the sample passes the tap
test (its exact necessary condition first, for all samples at once).

So the count of valid poses is exact for that family: zero means that no method, ranking or
S_aff can give filling a valid top pose in that scene. Prints a Markdown table; ``--out DIR``
also writes ``oracle.csv`` (per scene and example) and ``near.csv`` (every pose past the tap
test, with the judge's reasons).

    python paper/scripts/filling_oracle.py --objects ../shared/data/objects \\
        --scenes ../shared/data/scenes/*.ply --out build/paper/oracle/filling
    python paper/scripts/filling_oracle.py --objects ../shared/data/objects \\
        --validation kitchen_a --fraction 0.05       # the check: a validation room's sinks
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from interaction_tensor import affordances
from interaction_tensor.detection.places import top_k
from interaction_tensor.geometry.load import load_geometry
from itensor_paper.common import ranking_radius, write_csv
from itensor_paper.judge import Judge, JudgeScene
from itensor_paper.oracle import standing_filling
from itensor_paper.rooms.validation import build_scene

ORACLE_COLUMNS = ["scene", "example", "support_samples", "poses", "tap_pretest", "tap_test",
                  "valid", "valid_places", "seconds"]
NEAR_COLUMNS = ["scene", "example", "x", "y", "z", "orientation", "valid", "reasons"]


def _write(out: Path, rows: list, near: list) -> None:
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "oracle.csv", rows, ORACLE_COLUMNS)
    write_csv(out / "near.csv", near, NEAR_COLUMNS)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", required=True)
    ap.add_argument("--scenes", nargs="*", default=[])
    ap.add_argument("--validation", nargs="*", default=[],
                    help="procedural validation rooms (examples/validation.py): their sinks "
                         "must hold valid poses")
    ap.add_argument("--examples", nargs="+", default=["filling-mug", "filling-cup"])
    ap.add_argument("--max-tilt", type=float, default=25.0,
                    help="support samples: normal line within this of vertical (degrees)")
    ap.add_argument("--fraction", type=float, default=1.0,
                    help="a seeded share of the support samples (1: all; less only to check "
                         "the search on a validation room quickly)")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)

    examples = {n: affordances.build(n, args.objects) for n in args.examples}
    judges = {n: Judge.for_example(ex) for n, ex in examples.items()}
    radii = {n: ranking_radius(affordances.build_descriptor(n, args.objects, example=ex))
             for n, ex in examples.items()}
    rows, near = [], []
    print("| scene | example | support samples | poses | past the tap pre-test | past the "
          "tap test | valid | valid places 0.5 d_o apart | reasons past the tap test "
          "(penetration asked only where the others pass) | s |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---|---:|", flush=True)
    for path in list(args.scenes) + [f"validation:{v}" for v in args.validation]:
        if path.startswith("validation:"):
            name, geometry = path, build_scene(path.split(":", 1)[1]).geometry
        else:
            name, geometry = Path(path).stem, load_geometry(path)
        js = JudgeScene(geometry)
        for n, ex in examples.items():
            t0 = time.perf_counter()
            res = standing_filling(js, judges[n], ex.support_point, args.max_tilt,
                                   fraction=args.fraction)
            places = 0
            if res.valid:
                pos = res.points[[i for i, _ in res.valid]]
                places = len(top_k(pos, np.ones(len(pos)), len(pos), radii[n]))
            secs = time.perf_counter() - t0
            why = ", ".join(f"{r} {c}" for r, c in res.reasons.most_common(4))
            print(f"| {name} | {n} | {res.samples:,} | {res.poses:,} | {res.pretest:,} | "
                  f"{res.judged:,} | {len(res.valid)} | {places} | {why} | {secs:.0f} |",
                  flush=True)
            rows.append({"scene": name, "example": n, "support_samples": res.samples,
                         "poses": res.poses, "tap_pretest": res.pretest,
                         "tap_test": res.judged, "valid": len(res.valid),
                         "valid_places": places, "seconds": round(secs, 1)})
            near += [{"scene": name, "example": n, **r} for r in res.rows]
            if args.out:                     # written after each scene: a partial run keeps
                _write(Path(args.out), rows, near)                  # what it has judged
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
