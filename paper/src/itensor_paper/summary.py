"""The tracked summary of an evaluation: what the README quotes, regenerated from a run.

An evaluation (``itensor paper evaluate``, ``merge``, ``rejudge``) writes its whole output into
a git-ignored folder; :func:`write_summary` copies the current figures out of it into the
tracked ``paper/results/``, overwriting what was there: Table 1 (Markdown and CSV, written
afresh from the run's verdicts by the current report), the judge's accuracy on its labelled
poses, one picture per affordance (the run's close-up sheet of iT's example and scene
whose top 5 the judge finds valid most often; ties by name) and ``closeups.png``, the
README's picture: from each of those sheets, the close-up of the best pose the tool reports
(the first accepted; the first shown where none is), its affordance, example, scene and
verdict under it.
"""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

from interaction_tensor.errors import InputError
from interaction_tensor.geometry.files import atomic_dir
from itensor_paper.common import AFFORDANCES
from itensor_paper.merge import load_run
from itensor_paper.report import write_all
from itensor_paper.runner import METHODS, metrics

#: The files of a run the summary copies, as they are named there -> in the summary.
COPIED = {"table1.md": "table1.md", "table1.csv": "table1.csv",
          "judge_accuracy.csv": "judge_accuracy.csv"}
#: Files a summary may also hold (written by other commands into the same folder).
ALSO = ("panel_agreement.csv", "own.md", "own.csv")
#: The method whose pictures the summary shows.
METHOD = "iT-weighted"


#: Close-ups per row of ``closeups.png``.
COLUMNS = 3


def _top_rows(run: Path) -> dict:
    """{(affordance, example, scene): [judgement rows of :data:`METHOD`'s top poses, by
    rank]} of a run."""
    path = run / "judgements.csv"
    if not path.exists():
        return {}
    rows: dict = {}
    with open(path, newline="") as fh:
        for row in csv.DictReader(fh):
            if row["method"] == METHOD and row["group"] == "top":
                rows.setdefault((row["affordance"], row["example"], row["scene"]),
                                []).append(row)
    for items in rows.values():
        items.sort(key=lambda r: int(r["rank"]))
    return rows


def _chosen(run: Path) -> dict:
    """{affordance: (picture path, its top rows)}: per affordance, the (example, scene)
    sheet of :data:`METHOD` whose top poses the judge found valid most often, ties by
    example and scene name; affordances without a picture are left out."""
    best: dict = {}
    for (aff, example, scene), rows in sorted(_top_rows(run).items()):
        n = sum(r["valid"] == "True" for r in rows)
        picture = run / "pictures" / f"{example}__{scene}.png"
        if picture.exists() and (aff not in best or n > best[aff][0]):
            best[aff] = (n, picture, rows)
    return {aff: (picture, rows) for aff, (_, picture, rows) in sorted(best.items())}


def chosen_pictures(run: Path) -> dict:
    """{affordance: picture path} of a run (:func:`_chosen`)."""
    return {aff: picture for aff, (picture, _) in _chosen(run).items()}


def closeups(run: Path, path: Path) -> Path | None:
    """Write ``path``: one close-up per affordance, cut from its chosen sheet
    (:func:`_chosen`, drawn by :func:`.pictures.run_sheet`): the first accepted pose's panel
    (the first shown where none is accepted), with the affordance, example, scene, rank,
    whether the tool reports it and the judge's verdict under it. None without pictures."""
    from PIL import Image, ImageDraw

    from interaction_tensor.outputs.render import _font
    from itensor_paper.pictures import CAPTION, PANEL, panel_origin

    chosen = _chosen(run)
    order = [a for a in AFFORDANCES if a in chosen] + sorted(set(chosen) - set(AFFORDANCES))
    if not order:
        return None
    w, h = PANEL
    cols = min(COLUMNS, len(order))
    img = Image.new("RGB", (cols * w, -(-len(order) // cols) * (h + CAPTION)),
                    (255, 255, 255))
    draw = ImageDraw.Draw(img)
    for i, aff in enumerate(order):
        picture, rows = chosen[aff]
        cx, cy = (i % cols) * w, (i // cols) * (h + CAPTION)
        k = next((j for j, r in enumerate(rows) if r["accepted"] == "True"), 0)
        sheet = Image.open(picture).convert("RGB")
        x, y = panel_origin(k, len(rows))
        img.paste(sheet.crop((x, y, x + w, y + h)), (cx, cy))
        draw.rectangle([cx, cy, cx + w - 1, cy + h - 1], outline=(210, 210, 210))
        r = rows[k]
        said = "reported" if r["accepted"] == "True" else "not reported"
        verdict = "valid" if r["valid"] == "True" else "invalid"
        lines = (f"{aff}: {r['example']} in {r['scene']}",
                 f"#{r['rank']} {said}, judged {verdict}")
        for n, line in enumerate(lines):
            draw.text((cx + 6, cy + h + 2 + 16 * n), line[:52], fill=(20, 20, 20),
                      font=_font(12))
    with open(path, "wb") as fh:
        img.save(fh, format="PNG", optimize=True)
    return path


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
        closeups(run, tmp / "pictures" / "closeups.png")
    return out
