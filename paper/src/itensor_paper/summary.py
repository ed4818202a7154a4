"""The tracked summary of an evaluation: what the README quotes, regenerated from a run.

An evaluation (``itensor paper evaluate``, ``merge``, ``rejudge``) writes its whole output into
a git-ignored folder; :func:`write_summary` copies the current figures out of it into the
tracked ``paper/results/``, overwriting what was there: Table 1 (Markdown and CSV, written
afresh from the run's verdicts by the current report), the judge's accuracy on its labelled
poses and one picture per affordance (the run's close-up sheet of iT's example and scene
whose top 5 the judge finds valid most often; ties by name).
"""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

from interaction_tensor.errors import InputError
from interaction_tensor.geometry.files import atomic_dir
from itensor_paper.merge import load_run
from itensor_paper.report import write_all
from itensor_paper.runner import METHODS, metrics

#: The files of a run the summary copies, as they are named there -> in the summary.
COPIED = {"table1.md": "table1.md", "table1.csv": "table1.csv",
          "judge_accuracy.csv": "judge_accuracy.csv"}
#: Files a summary may also hold (written by other commands into the same folder).
ALSO = ("panel_agreement.csv",)
#: The method whose pictures the summary shows.
METHOD = "iT-weighted"


def chosen_pictures(run: Path) -> dict:
    """{affordance: picture path} of a run: per affordance, the (example, scene) sheet of
    :data:`METHOD` whose top poses the judge found valid most often, ties by example and
    scene name; affordances without a picture are left out."""
    path = run / "judgements.csv"
    if not path.exists():
        return {}
    valid: dict = {}
    with open(path, newline="") as fh:
        for row in csv.DictReader(fh):
            if row["method"] != METHOD or row["group"] != "top":
                continue
            key = (row["affordance"], row["example"], row["scene"])
            valid[key] = valid.get(key, 0) + (row["valid"] == "True")
    best: dict = {}
    for (aff, example, scene), n in sorted(valid.items()):
        picture = run / "pictures" / f"{example}__{scene}.png"
        if picture.exists() and (aff not in best or n > best[aff][0]):
            best[aff] = (n, picture)
    return {aff: picture for aff, (_, picture) in sorted(best.items())}


def write_summary(run, out) -> Path:
    """Write the summary of evaluation output ``run`` into ``out`` as one transaction (the
    folder holds the new summary whole, or the old one). Returns ``out``."""
    run, out = Path(run), Path(out)
    missing = [name for name in COPIED if not (run / name).exists()]
    if missing:
        raise InputError(run, f"not an evaluation output (no {', '.join(missing)})")
    keep = {name: (out / name).read_bytes() for name in ALSO if (out / name).exists()}
    allowed = tuple(COPIED.values()) + ALSO + ("pictures",)
    with atomic_dir(out, "table1.md", allowed) as tmp:
        tables = tmp / ".tables"
        res = load_run(run)
        methods = tuple(m for m in METHODS if any(j["method"] == m for j in res.judgements))
        res.table = metrics(res.judgements, methods, res.runs)
        write_all(res, tables)
        for src, dst in COPIED.items():
            shutil.copyfile(tables / src, tmp / dst)
        shutil.rmtree(tables)
        for name, data in keep.items():
            (tmp / name).write_bytes(data)
        (tmp / "pictures").mkdir()
        for aff, picture in chosen_pictures(run).items():
            shutil.copyfile(picture, tmp / "pictures" / f"{aff}.png")
    return out
