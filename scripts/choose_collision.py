"""Choose detection's collision test per affordance on the judge's labelled set.

For every labelled pose (:mod:`interaction_tensor.evaluation.labelled`) and every option
(``above``: which query triangles are tested, all of them or those above the reference
point by more than ``above`` m; ``depth``: how deep a move may free them, m), the posed query
is tested against the scene's mesh as detection tests it (:class:`~interaction_tensor.detect.
CollisionCheck`). The option kept per affordance rejects the most invalid poses among those
that keep every valid one; ties go to testing more of the query (``above`` None first, then
the lower), then to the smaller depth.

    python scripts/choose_collision.py --objects ../shared/data/objects \\
        --shared ../shared/data -o docs/results/collision
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

from interaction_tensor import collision
from interaction_tensor.evaluation import labelled
from interaction_tensor.examples import interactions, validation
from interaction_tensor.io import load_geometry

ABOVE = (None, 0.0, 0.05, 0.10)
DEPTHS = (0.01, 0.02, 0.05)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", required=True)
    ap.add_argument("--shared", required=True)
    ap.add_argument("-o", "--out", default="docs/results/collision")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    poses = labelled.load()
    colliders, examples, rows = {}, {}, []
    for p in poses:
        if p.scene not in colliders:
            g = (load_geometry(Path(args.shared) / p.scene[7:]) if p.scene.startswith("shared:")
                 else validation.build_scene(p.scene.split(":", 1)[1]).geometry)
            colliders[p.scene] = collision.MeshCollider(g.vertices, g.faces)
        if p.example not in examples:
            ex = interactions.build(p.example, args.objects)
            v, f = ex.query.vertices, ex.query.faces
            bodies = {}
            for above in ABOVE:
                faces = collision.faces_above(v, f, None if above is None
                                              else ex.support_point[2] + above)
                if len(faces):                  # nothing of a bowl lies above its support
                    bodies[above] = collision.Body(v, faces)
            examples[p.example] = bodies
        for above, body in examples[p.example].items():
            sep = colliders[p.scene].separation(body, np.asarray(p.pose, float),
                                                limit=max(DEPTHS))
            rows.append({"affordance": p.affordance, "example": p.example, "scene": p.scene,
                         "case": p.case, "valid": p.valid,
                         "above": "all" if above is None else above,
                         "separation_m": sep if np.isfinite(sep) else "inf"})
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "labelled_separation.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = ["# Detection's collision test, chosen on the judge's labelled set", "",
             f"`python scripts/choose_collision.py --objects {args.objects} --shared "
             f"{args.shared} -o {args.out}` ({time.perf_counter() - t0:.0f} s). A pose passes "
             "when its tested triangles do not cross the scene's or a move of `depth` frees "
             "them; `above`: the triangles tested (all, or those above the reference point by "
             "more than that many metres). Kept: the most invalid poses rejected among the "
             "options that keep every valid pose (ties: more of the query tested, then the "
             "smaller depth).", "",
             "| affordance | above (m) | depth (m) | valid kept | invalid rejected | chosen |",
             "|---|---|---:|---:|---:|:---:|"]
    chosen = {}
    for aff in ("placing", "sitting", "hanging", "filling", "riding"):
        sub = [r for r in rows if r["affordance"] == aff]
        options = []
        for rank, above in enumerate(ABOVE):
            for depth in DEPTHS:
                got = [r for r in sub if r["above"] == ("all" if above is None else above)]
                if not got:
                    continue
                sep = np.array([float(r["separation_m"]) for r in got])
                valid = np.array([r["valid"] for r in got])
                kept = int((sep[valid] <= depth).sum())
                rejected = int((sep[~valid] > depth).sum())
                options.append((above, depth, kept, int(valid.sum()), rejected,
                                int((~valid).sum()), rank))
        ok = [o for o in options if o[2] == o[3]]
        best = max(ok, key=lambda o: (o[4], -o[6], -o[1])) if ok else None
        chosen[aff] = best
        for o in options:
            lines.append(f"| {aff} | {'all' if o[0] is None else f'{o[0]:g}'} | {o[1]:g} | "
                         f"{o[2]}/{o[3]} | {o[4]}/{o[5]} | {'**yes**' if o is best else ''} |")
    lines += ["", "Chosen (`ACCEPTANCE[...]['collision']` = (depth, above)):", ""]
    for aff, o in chosen.items():
        lines.append(f"- {aff}: " + ("none keeps every valid pose" if o is None else
                                     f"({o[1]:g}, {'None' if o[0] is None else f'{o[0]:g}'})"))
    (out / "choice.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
