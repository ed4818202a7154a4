"""Merge evaluation runs made on disjoint sets of scenes into one Table 1; judge a finished
run again with the current judge.

``itensor evaluate`` on a long list of scenes can be split across processes or machines (one
``--scenes`` subset each, same settings and seed); ``itensor evaluate-merge A B ... -o OUT``
then reads each run's (or earlier merge's) per-judgement records (``judgements.csv``, ``runs.csv``,
``timings.csv``, ``judge_accuracy.csv``, ``run.json``) and writes the same files a single run
would have written, pictures included. The merge refuses runs whose settings differ or whose
scenes overlap, and builds its output in a temporary directory that replaces ``OUT`` only when
complete.
"""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import numpy as np

from interaction_tensor import affordances
from interaction_tensor import affordances as registry
from interaction_tensor.errors import InputError
from interaction_tensor.geometry.files import atomic_dir
from interaction_tensor.geometry.load import load_geometry
from itensor_paper import labelled
from itensor_paper.judge import Judge, JudgeScene, JudgeSettings
from itensor_paper.panel import add_panel_agreement
from itensor_paper.pictures import run_sheet
from itensor_paper.report import write_all
from itensor_paper.runner import METHODS, EvalResult, metrics

#: settings that may differ between the parts of one evaluation (the judge's labelled-set
#: check need run in one part only; a part may itself be a merge)
_PER_PART = {"scenes", "total_seconds", "judge_check", "merged_from", "rejudged_from"}

_INT = {"rank", "candidates", "pairs", "accepted", "valid_n", "valid_right", "invalid_n",
        "invalid_right", "panel_n", "panel_agree"}
_FLOAT = {"score", "x", "y", "z", "contact", "seconds", "judge_seconds", "valid_accuracy",
          "mean_comparisons_per_decision", "invalid_accuracy", "panel_agreement"}
_BOOL = {"valid", "any_accepted"}


def _value(key, text, path):
    if text == "" or text is None:
        return None
    if key == "accepted" and text in ("True", "False"):
        return text == "True"          # judgements.csv: accepted or not; runs.csv: a count
    try:
        if key in _BOOL:
            if text not in ("True", "False"):
                raise ValueError(text)
            return text == "True"
        if key in _INT:
            return int(text)
        if key in _FLOAT or key == "penetration_m":
            return text if (key == "penetration_m" and text == "inf") else float(text)
    except ValueError:
        raise InputError(path, f"column {key!r} holds {text!r}, not a "
                               f"{'boolean' if key in _BOOL else 'number'}") from None
    return text


def _rows(path: Path, required: tuple = ()) -> list[dict]:
    if not path.is_file():
        raise InputError(path, "missing: not the output directory of a finished "
                               "`itensor evaluate`")
    with open(path, newline="") as fh:
        reader = csv.DictReader(fh)
        missing = [c for c in required if c not in (reader.fieldnames or [])]
        if missing:
            raise InputError(path, f"missing column(s) {', '.join(missing)}")
        rows = []
        for r in reader:
            if None in r:
                raise InputError(path, f"line {reader.line_num} has more fields than the header")
            rows.append({k: _value(k, v, path) for k, v in r.items()})
    return rows


def _judgement(row: dict, path: Path) -> dict:
    if not isinstance(row["accepted"], bool):
        raise InputError(path, f"column 'accepted' holds {row['accepted']!r}, not True/False")
    nums = (row.pop("pose") or "").split()
    if len(nums) != 16:
        raise InputError(path, f"a pose with {len(nums)} numbers, not 16 "
                               f"({row.get('scene')}, {row.get('example')})")
    row["_pose"] = np.array([float(v) for v in nums]).reshape(4, 4)
    row["reasons"] = row.get("reasons") or ""
    return row


def load_run(directory) -> "EvalResult":
    """The records of one finished ``itensor evaluate`` run in ``directory``."""

    d = Path(directory)
    if not d.is_dir():
        raise InputError(d, "no such evaluation directory")
    try:
        info = json.loads((d / "run.json").read_text())
        settings = dict(info["settings"])
    except FileNotFoundError:
        raise InputError(d / "run.json", "missing: not the output directory of a finished "
                                         "`itensor evaluate`") from None
    except (ValueError, KeyError, TypeError) as e:
        raise InputError(d / "run.json", f"not an evaluation record ({e})") from None
    path = d / "judgements.csv"
    judg = [_judgement(r, path) for r in _rows(
        path, ("scene", "example", "affordance", "method", "group", "rank", "score",
               "accepted", "valid", "pose"))]
    runs = _rows(d / "runs.csv", ("scene", "example", "affordance", "method", "any_accepted"))
    timings = _rows(d / "timings.csv", ("stage", "method", "seconds"))
    acc_path = d / "judge_accuracy.csv"
    judge_acc = _rows(acc_path) if acc_path.is_file() else []
    samp_path = d / "sampling_runs.csv"
    sampling = _rows(samp_path) if samp_path.is_file() else []
    for s in sampling:
        for k in ("comparisons_to_accept_sum", "comparisons_to_accept_top20_sum",
                  "accepted_top20"):
            s[k] = int(s[k])
    return EvalResult(judgements=judg, runs=runs, judge_accuracy=judge_acc, sampling=sampling,
                      timings=timings, settings=settings)


def _replace_runs(parts: list) -> None:
    """In place: each part's records of a (scene, example, method) it ran drop those of
    earlier parts (the judgements, runs, sampling rows and timings of that run)."""
    def key(r, method=None):
        return r.get("scene"), r.get("example"), method or r.get("method")

    for i, later in enumerate(parts):
        done = {key(r) for r in later.runs}
        for earlier in parts[:i]:
            for name in ("judgements", "runs", "timings"):
                setattr(earlier, name, [r for r in getattr(earlier, name)
                                        if key(r) not in done])
            earlier.sampling = [r for r in earlier.sampling
                                if key(r, "iT-" + r["keypoints"]) not in done]


def merge(directories, out_dir, log=print, allow=(), replace: bool = False) -> "EvalResult":
    """Merge the runs in ``directories`` (disjoint scenes, equal settings) into ``out_dir``.

    ``allow``: settings the parts may hold differently (e.g. ``icp_backend`` when one part
    ran where Open3D could not load); the merged ``run.json`` then lists each part's value
    of them under ``per_part``, so that no table hides the difference.

    ``replace``: the parts may share scenes; a later part's results for a (scene, example,
    method) it ran replace the earlier parts' (a method or some examples run again with new
    settings on the same scenes; the parts' ``methods`` and ``examples`` may then differ and
    are listed under ``per_part``, as is every key of ``allow``)."""

    dirs = [Path(p) for p in directories]
    if len(dirs) < 2:
        raise InputError(None, "give at least two evaluation directories to merge")
    parts = [load_run(d) for d in dirs]
    if replace:
        allow = tuple(allow) + tuple(k for k in ("methods", "examples") if k not in allow)
    skip = _PER_PART | {"per_part"} | set(allow)
    base = {k: v for k, v in parts[0].settings.items() if k not in skip}
    seen: dict[str, Path] = {}
    for d, p in zip(dirs, parts):
        own = {k: v for k, v in p.settings.items() if k not in skip}
        diff = sorted(k for k in set(base) | set(own) if base.get(k) != own.get(k))
        if diff:
            raise InputError(d, f"settings differ from {dirs[0]}: {', '.join(diff)}")
        for s in p.settings.get("scenes", []):
            if s in seen and not replace:
                raise InputError(d, f"scene {s} is also in {seen[s]} (--replace lets a "
                                    "later run replace the methods it ran)")
            seen[s] = d
    if replace:
        _replace_runs(parts)
    res = EvalResult(settings={**parts[0].settings,
                               "scenes": list(dict.fromkeys(
                                   s for p in parts for s in p.settings["scenes"])),
                               # the parts ran side by side: the longest is the wall time
                               "total_seconds": max(p.settings.get("total_seconds") or 0
                                                    for p in parts),
                               # a part that is itself a merge lists its own parts
                               "merged_from": [m for d, p in zip(dirs, parts)
                                               for m in (p.settings.get("merged_from")
                                                         or [str(d)])]})
    per_part = {}
    for key in allow:
        rows = []
        for d, p in zip(dirs, parts):
            earlier = (p.settings.get("per_part") or {}).get(key)
            rows += earlier if earlier else [{"part": str(d), "scenes": p.settings["scenes"],
                                              "value": p.settings.get(key)}]
        if len({json.dumps(r["value"]) for r in rows}) > 1:
            per_part[key] = rows
    if per_part:
        res.settings["per_part"] = per_part
        for key in per_part:
            res.settings[key] = "differs per part (see per_part)"
    for p in parts:
        res.judgements += p.judgements
        res.runs += p.runs
        res.sampling += p.sampling
        res.timings += [t for t in p.timings if t["stage"] != "train" or p is parts[0]]
    res.judge_accuracy = next((p.judge_accuracy for p in parts if p.judge_accuracy), [])
    ran = {m for p in parts for m in (p.settings.get("methods") or METHODS)}
    methods = tuple(m for m in METHODS if m in ran)
    if replace:
        res.settings["methods"] = list(methods)
        res.settings["examples"] = sorted({r["example"] for r in res.runs})
    res.table = metrics(res.judgements, methods, res.runs)


    with atomic_dir(out_dir, "run.json") as tmp:
        write_all(res, tmp)
        for d in dirs:
            for png in sorted((d / "pictures").glob("*.png")):
                (tmp / "pictures").mkdir(exist_ok=True)
                shutil.copy2(png, tmp / "pictures" / png.name)
    log(f"merged {len(dirs)} runs{' (later ones replacing methods)' if replace else ''} "
        f"({len(res.settings['scenes'])} scenes, "
        f"{len(res.judgements)} judgements) into {out_dir}")
    return res


def rejudge(directory, out_dir, scenes_dir, objects_dir=None, affordances=None,
            judge_check: bool = True, log=print) -> "EvalResult":
    """Judge every pose of the finished run in ``directory`` again with the current judge
    (every method's top and bottom poses; only ``affordances`` when given), and write the
    run's files to ``out_dir`` with the new verdicts: the tables recomputed, the pictures of
    the (scene, example) pairs whose verdicts changed drawn again, the others copied, and the
    judge's labelled-set accuracy measured again (unless ``judge_check`` is False). Nothing is
    detected again: the poses, scores and acceptances are the run's. ``out_dir`` is replaced
    only when complete. ``run.json`` records ``rejudged_from``."""

    d = Path(directory)
    res = load_run(d)
    st = res.settings
    objects_dir = objects_dir or st.get("objects_dir")
    spacing, seed = float(st.get("judge_spacing", 0.01)), int(st.get("seed", 0))
    scenes_dir = Path(scenes_dir)
    todo = [r for r in res.judgements if affordances is None or r["affordance"] in affordances]
    examples, judges, changed = {}, {}, set()
    for scene in sorted({r["scene"] for r in todo}):
        path = scenes_dir / f"{scene}.ply"
        if not path.is_file():
            raise InputError(path, f"scene {scene!r} of {d} not found in {scenes_dir}")
        geom = load_geometry(path)
        jscene = JudgeScene(geom, spacing, seed)
        for r in (r for r in todo if r["scene"] == scene):
            if r["example"] not in judges:
                examples[r["example"]] = registry.build(r["example"], objects_dir, seed)
                judges[r["example"]] = Judge.for_example(
                    examples[r["example"]], JudgeSettings(spacing=spacing, seed=seed))
            v = judges[r["example"]].judge(jscene, r["_pose"])
            if bool(v.valid) != r["valid"] or "; ".join(v.reasons) != r["reasons"]:
                changed.add((scene, r["example"]))
            r["valid"] = bool(v.valid)
            r["penetration_m"] = (round(float(v.penetration), 4) if np.isfinite(v.penetration)
                                  else "inf")
            r["contact"] = round(float(v.contact), 3)
            r["reasons"] = "; ".join(v.reasons)
        log(f"judged {scene} again")
    methods = tuple(m for m in METHODS if m in (st.get("methods") or METHODS))
    res.table = metrics(res.judgements, methods, res.runs)
    if judge_check and objects_dir:
        res.judge_accuracy = labelled.judge_accuracy(labelled.load(), objects_dir,
                                                     Path(objects_dir).parent)[0]
        add_panel_agreement(res.judge_accuracy, scenes_dir, objects_dir, log)
    res.settings["rejudged_from"] = str(d)
    method = "iT-weighted" if "iT-weighted" in methods else methods[0]
    with atomic_dir(out_dir, "run.json") as tmp:
        write_all(res, tmp)
        (tmp / "pictures").mkdir(exist_ok=True)
        for png in sorted((d / "pictures").glob("*.png")):
            example, _, scene = png.stem.partition("__")
            if (scene, example) not in changed:
                shutil.copy2(png, tmp / "pictures" / png.name)
        for scene, example in sorted(changed):
            rows = sorted((r for r in res.judgements if r["scene"] == scene
                           and r["example"] == example and r["method"] == method
                           and r["group"] == "top"), key=lambda r: r["rank"])
            if rows:
                run_sheet(tmp / "pictures" / f"{example}__{scene}.png",
                          load_geometry(scenes_dir / f"{scene}.ply"),
                          examples[example].query, rows, example, scene, method)
    log(f"judged {len(todo)} poses again ({len(changed)} (scene, example) pairs changed) "
        f"into {out_dir}")
    return res


def redraw(eval_dir, scenes_dir, objects_dir=None, method: str = "iT-weighted",
           log=print) -> int:
    """Draw ``eval_dir/pictures/`` again from the poses in its ``judgements.csv`` (for runs
    made before a change to these pictures, or merged from several machines); returns the
    number of pictures drawn."""
    from itensor_paper.merge import load_run

    res = load_run(eval_dir)
    objects_dir = objects_dir or res.settings.get("objects_dir")
    runs: dict = {}
    for r in res.judgements:
        if r["method"] == method and r["group"] == "top":
            runs.setdefault((r["scene"], r["example"]), []).append(r)
    queries: dict = {}
    count = 0
    for scene in sorted({s for s, _ in runs}):
        geom = load_geometry(Path(scenes_dir) / f"{scene}.ply")
        for (s, example), rows in sorted(runs.items()):
            if s != scene:
                continue
            if example not in queries:
                queries[example] = affordances.build(example, objects_dir,
                                                      res.settings.get("seed", 0)).query
            rows = sorted(rows, key=lambda r: r["rank"])
            run_sheet(Path(eval_dir) / "pictures" / f"{example}__{scene}.png", geom,
                      queries[example], rows, example, scene, method)
            count += 1
        log(f"drew {scene}")
    return count
