"""Tables (Markdown, CSV), the sampling plot and the per-scene pictures of an evaluation."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from itensor_paper.common import (
    AFFORDANCES,
    METHODS,
    PAPER,
    machine,
    write_csv,
    write_json,
)


def _fmt(v) -> str:
    return "n/a" if v is None or (isinstance(v, float) and np.isnan(v)) else f"{v:.1f}"


def _method_grid(rows: list[dict], methods, heads, cells) -> str:
    """A Markdown table with one line per affordance (and the average) and, per method, the
    columns ``heads(m)`` filled by ``cells(row)`` (blank where the method has no row)."""
    affs = [a for a in list(AFFORDANCES) + ["average"] if any(r["affordance"] == a for r in rows)]
    methods = [m for m in methods if any(r["method"] == m for r in rows)]
    width = len(heads(""))
    lines = ["| affordance | " + " | ".join(h for m in methods for h in heads(m)) + " |",
             "|---|" + "---:|" * (width * len(methods))]
    for a in affs:
        line = []
        for m in methods:
            r = next((r for r in rows if r["affordance"] == a and r["method"] == m), None)
            line += [""] * width if r is None else cells(r)
        name = f"**{a}**" if a == "average" else a
        lines.append(f"| {name} | " + " | ".join(line) + " |")
    return "\n".join(lines)


def table_markdown(rows: list[dict], methods=METHODS) -> str:
    """Table 1 as Markdown: one line per affordance; per method the precision of the top 5
    (the paper's comparable number), accuracy and F-score over top and bottom 5, the forced
    choice (of the judge's chosen places among top and bottom 5, the share from the top),
    and the (scene, example) runs that accepted any prediction."""
    return _method_grid(
        rows, methods, lambda m: (f"{m} prec / acc / F", f"{m} forced choice",
                                  f"{m} runs accepting"),
        lambda r: [f"{_fmt(r['precision'])} / {_fmt(r['accuracy'])} / {_fmt(r['f_score'])}",
                   _fmt(r.get("forced_choice")),
                   f"{r.get('with_accepted', 0)}/{r.get('runs', 0)}"])


def accepted_markdown(rows: list[dict], methods=METHODS) -> str:
    """Per affordance and method: the top poses the method accepted, how many of them the
    judge found valid, and that share (%)."""
    return _method_grid(
        rows, methods, lambda m: (f"{m} valid / accepted top", f"{m} %"),
        lambda r: [f"{r['accepted_top_valid']}/{r['accepted_top']}",
                   _fmt(r["accepted_precision"])])


def places_markdown(rows: list[dict], methods=METHODS) -> str:
    """Per affordance and method: place recall (runs finding a valid place / runs where one
    is known, %) and false acceptance (runs accepting anything / runs where none is known,
    %)."""
    return _method_grid(
        rows, methods, lambda m: (f"{m} place recall", f"{m} false acceptance"),
        lambda r: [f"{r['runs_finding_place']}/{r['runs_with_place']} "
                   f"({_fmt(r['place_recall'])})",
                   f"{r['runs_accepting_falsely']}/{r['runs_without_place']} "
                   f"({_fmt(r['false_acceptance'])})"])


def scene_rows(runs: list[dict], methods=METHODS) -> list[dict]:
    """Per affordance and method: the scenes where any of the affordance's examples accepted a
    prediction (``scenes_accepting``) out of the scenes run (``scenes``)."""
    out = []
    for a in AFFORDANCES:
        for m in methods:
            rr = [r for r in runs if r["affordance"] == a and r["method"] == m]
            if rr:
                out.append({"affordance": a, "method": m,
                            "scenes": len({r["scene"] for r in rr}),
                            "scenes_accepting": len({r["scene"] for r in rr
                                                     if r["any_accepted"]})})
    return out


def scenes_markdown(rows: list[dict]) -> str:
    methods = [m for m in METHODS if any(r["method"] == m for r in rows)]
    lines = ["| affordance | " + " | ".join(methods) + " |",
             "|---|" + "---:|" * len(methods)]
    for a in AFFORDANCES:
        cells = []
        for m in methods:
            r = next((r for r in rows if r["affordance"] == a and r["method"] == m), None)
            cells.append(f"{r['scenes_accepting']}/{r['scenes']}" if r else "")
        if any(cells):
            lines.append(f"| {a} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def judge_markdown(rows: list[dict]) -> str:
    """The judge's accuracy on the labelled set, per affordance and class, and its agreement
    with the blind panel's majority on the held-out poses."""
    lines = ["| affordance | valid poses judged valid | invalid poses judged invalid | "
             "agreeing with the panel (held-out poses) |",
             "|---|---:|---:|---:|"]
    for r in rows:
        n = r.get("panel_n") or 0
        panel = (f"{r['panel_agree']}/{n} ({_fmt(r['panel_agreement'])} %)" if n else "-")
        lines.append(f"| {r['affordance']} | {r['valid_right']}/{r['valid_n']} "
                     f"({_fmt(r['valid_accuracy'])} %) | {r['invalid_right']}/{r['invalid_n']} "
                     f"({_fmt(r['invalid_accuracy'])} %) | {panel} |")
    return "\n".join(lines)


def paper_markdown() -> str:
    lines = ["| affordance | iT acc | iT F | Naive acc | Naive F | BS acc | BS F |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for a, d in PAPER.items():
        lines.append(f"| {a} | " + " | ".join(f"{d[m][0]:.2f} | {d[m][1]:.2f}"
                                               for m in ("iT", "Naive", "BS")) + " |")
    return "\n".join(lines)


def sampling_rows(sampling: list[dict]) -> list[dict]:
    """Per affordance (and all): mean comparisons to accept, weight-driven vs uniform."""
    out = []
    affs = [a for a in AFFORDANCES if any(s["affordance"] == a for s in sampling)] + ["all"]
    for a in affs:
        row = {"affordance": a}
        for kp in ("weighted", "uniform"):
            ss = [s for s in sampling if (a == "all" or s["affordance"] == a)
                  and s["keypoints"] == kp]
            acc = sum(s["accepted"] for s in ss)
            row[f"{kp}_accepted"] = acc
            row[f"{kp}_mean"] = (sum(s["comparisons_to_accept_sum"] for s in ss) / acc
                                 if acc else float("nan"))
            a20 = sum(s["accepted_top20"] for s in ss)
            row[f"{kp}_top20_mean"] = (sum(s["comparisons_to_accept_top20_sum"] for s in ss)
                                       / a20 if a20 else float("nan"))
        w, u = row["weighted_mean"], row["uniform_mean"]
        row["uniform_extra_percent"] = 100.0 * (u - w) / w if w and w == w and u == u else float("nan")
        out.append(row)
    return out


def write_all(res, out: Path) -> None:
    out = Path(out)
    rows = res.table
    write_csv(out / "table1.csv", rows,
              ["affordance", "method", "precision", "accuracy", "f_score", "with_accepted",
               "runs"])
    write_csv(out / "table1_detailed.csv", rows,
              ["affordance", "method", "precision", "accuracy", "f_score", "forced_choice",
               "tp", "fp", "tn", "fn",
               "with_accepted", "runs", "accepted_top", "accepted_top_valid",
               "accepted_precision", "runs_with_place", "runs_finding_place", "place_recall",
               "runs_without_place", "runs_accepting_falsely", "false_acceptance"])
    write_csv(out / "judge_accuracy.csv", res.judge_accuracy,
              ["affordance", "valid_n", "valid_right", "valid_accuracy", "invalid_n",
               "invalid_right", "invalid_accuracy", "panel_n", "panel_agree",
               "panel_agreement"])
    scenes = scene_rows(res.runs)
    write_csv(out / "scenes_accepting.csv", scenes,
              ["affordance", "method", "scenes_accepting", "scenes"])
    write_csv(out / "runs.csv", res.runs,
              ["scene", "example", "affordance", "method", "candidates", "pairs", "accepted",
               "any_accepted"])
    judg = [{k: v for k, v in j.items() if not k.startswith("_")} for j in res.judgements]
    for j, src in zip(judg, res.judgements):
        j["pose"] = " ".join(f"{v:.6g}" for v in np.asarray(src["_pose"]).ravel())
    write_csv(out / "judgements.csv", judg,
              ["scene", "example", "affordance", "method", "group", "rank", "score", "accepted",
               "valid", "x", "y", "z", "penetration_m", "contact", "reasons", "pose"])
    # per-example precision of the top 5, for the discussion
    per_ex = []
    for ex in sorted({j["example"] for j in judg}):
        row = {"example": ex}
        for m in METHODS:
            tops = [j for j in judg if j["example"] == ex and j["method"] == m and j["group"] == "top"]
            row[m] = 100.0 * sum(j["valid"] for j in tops) / len(tops) if tops else float("nan")
        per_ex.append(row)
    write_csv(out / "top5_valid_per_example.csv", per_ex, ["example"] + list(METHODS))

    samp = sampling_rows(res.sampling)
    cols = ["affordance", "weighted_accepted", "weighted_mean", "weighted_top20_mean",
            "uniform_accepted", "uniform_mean", "uniform_top20_mean", "uniform_extra_percent"]
    write_csv(out / "sampling.csv", samp, cols)
    # the per-run records behind it (so that `itensor evaluate-merge` can combine runs)
    write_csv(out / "sampling_runs.csv", res.sampling,
              ["example", "affordance", "scene", "keypoints", "pairs", "accepted",
               "comparisons_to_accept_sum", "comparisons_to_accept_top20_sum",
               "accepted_top20", "mean_comparisons_per_decision"])
    lines = ["| affordance | accepted (weighted) | comparisons to accept, weighted | top 20 % | "
             "accepted (uniform) | comparisons to accept, uniform | top 20 % | uniform extra |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in samp:
        lines.append(f"| {r['affordance']} | {r['weighted_accepted']} | {_fmt(r['weighted_mean'])} | "
                     f"{_fmt(r['weighted_top20_mean'])} | {r['uniform_accepted']} | "
                     f"{_fmt(r['uniform_mean'])} | {_fmt(r['uniform_top20_mean'])} | "
                     f"{_fmt(r['uniform_extra_percent'])} % |")
    (out / "sampling.md").write_text(
        "# Sampling experiment: keypoint comparisons needed to reach the acceptance threshold\n\n"
        "Mean over accepted (test point, orientation) pairs of the keypoints compared before "
        "the running score reached the threshold (512 keypoints per set, compared in weight "
        "order).\n\n" + "\n".join(lines) + "\n")
    sampling_plot(samp, out / "sampling.png")

    # timings
    write_csv(out / "timings.csv", res.timings,
              ["stage", "example", "scene", "method", "seconds", "candidates", "pairs",
               "accepted", "judge_seconds"])
    tl = ["| method | seconds (scoring) | pairs scored | pairs per second | seconds judging |",
          "|---|---:|---:|---:|---:|"]
    for m in METHODS:
        ts = [t for t in res.timings if t["stage"] == "detect" and t["method"] == m]
        if ts:
            s = sum(t["seconds"] for t in ts)
            p = sum(t["pairs"] for t in ts)
            tl.append(f"| {m} | {s:.1f} | {p} | {p / s if s else 0:.0f} | "
                      f"{sum(t['judge_seconds'] for t in ts):.1f} |")
    train = sum(t["seconds"] for t in res.timings if t["stage"] == "train")
    prep = sum(t["seconds"] for t in res.timings if t["stage"] == "scene")
    (out / "timings.md").write_text(
        "# Wall time per method\n\n" + "\n".join(tl) +
        f"\n\nTraining (8 descriptors and judges): {train:.1f} s; scene preparation "
        f"(detector sampling + judge sampling): {prep:.1f} s; whole run: "
        f"{res.settings.get('total_seconds')} s"
        + (f" (the longest of {len(res.settings['merged_from'])} runs made side by side on "
           "disjoint scenes and merged)" if res.settings.get("merged_from") else "")
        + f" on {machine()}. Naive and BS score a capped "
        "subset of the candidates (see run.json), so compare pairs per second.\n")

    md = ["# Table 1 (reproduced): validity of the top and bottom predictions, judged "
          "automatically\n",
          "Precision of the top 5, accuracy and F-score over the top and bottom 5, the forced "
          "choice (of the places the judge would choose among the top and bottom 5 shown "
          "together, as the paper's raters did, the share from the top 5), in %, per "
          "affordance, and the (scene, example) runs that accepted any prediction "
          "(definitions in `paper/src/itensor_paper/runner.py`).\n", table_markdown(rows),
          "", "## The top predictions each method accepted\n",
          "A top 5 holds the method's best pairs, accepted ones first; where it accepted fewer "
          "than 5 (a scene with no tap, no seat), rejected pairs fill it and count in the "
          "precision above, as the paper's raters saw a top 5 in every scene. Here only the "
          "top poses the method accepted, i.e. what it tells a user: how many, and the share "
          "the judge finds valid (not the paper's measure, but the one the project's targets "
          "are set on).\n",
          accepted_markdown(rows),
          "", "## Place recall and false acceptance\n",
          ("Per (scene, example) run. Place recall: of the runs where a valid place is known, "
           "those whose accepted top poses hold one; false acceptance: of the runs where none "
           "is known, those that accept anything. A place is known where any method's judged "
           "pose in the run is valid, or where an exhaustive search with the judge found one "
           "(`paper/src/itensor_paper/data/known_places.csv` lists the runs searched and "
           "what each search found); a run with none known may still hold a place every "
           "method and search missed.\n"),
          places_markdown(rows),
          "", "## Scenes where the affordance accepted any prediction (any of its examples)\n",
          scenes_markdown(scenes), "",
          "## The judge on the labelled set\n", judge_markdown(res.judge_accuracy), "",
          "## The paper's Table 1 (human markers)\n", paper_markdown(), ""]
    (out / "table1.md").write_text("\n".join(md) + "\n")
    write_json(out / "run.json", {"settings": res.settings, "machine": machine()})


def sampling_plot(samp: list[dict], path: Path) -> None:
    """A bar chart (Pillow, no plotting library) of the mean keypoint comparisons needed to
    accept, weight-driven beside uniform keypoints, per affordance; 512 dotted."""
    from PIL import Image, ImageDraw, ImageFont

    width, height = 770, 400
    left, right, top, bottom = 70, 20, 40, 60
    img = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(img)
    try:
        font = ImageFont.load_default(size=13)
    except TypeError:       # Pillow < 10.1
        font = ImageFont.load_default()
    values = [v for r in samp for v in (r["weighted_mean"], r["uniform_mean"])
              if v is not None and np.isfinite(v)]
    vmax = max([512.0, *values]) * 1.05
    plot_h = height - top - bottom

    def y_of(v: float) -> float:
        return top + plot_h * (1 - v / vmax)

    draw.text((left, 10), "Keypoint comparisons needed to reach the acceptance threshold (mean)",
              fill="black", font=font)
    for tick in range(0, int(vmax) + 1, 128):
        y = y_of(tick)
        draw.line([(left - 4, y), (width - right, y)], fill=(225, 225, 225))
        draw.text((left - 8, y), str(tick), fill="black", font=font, anchor="rm")
    y512 = y_of(512)
    for x in range(left, width - right, 8):
        draw.line([(x, y512), (x + 3, y512)], fill="grey")
    colours = {"weight-driven": (31, 119, 180), "uniform": (255, 127, 14)}
    slot = (width - left - right) / max(len(samp), 1)
    for i, r in enumerate(samp):
        x0 = left + i * slot + slot * 0.1
        bar = slot * 0.4
        for j, (key, colour) in enumerate(zip(("weighted_mean", "uniform_mean"),
                                              colours.values())):
            v = r[key]
            if v is None or not np.isfinite(v):
                continue
            draw.rectangle([x0 + j * bar, y_of(v), x0 + (j + 1) * bar - 2, y_of(0)], fill=colour)
        draw.text((x0 + bar, height - bottom + 8), str(r["affordance"]), fill="black",
                  font=font, anchor="mt")
    draw.line([(left, top), (left, y_of(0)), (width - right, y_of(0))], fill="black")
    lx = width - right - 150
    for k, (name, colour) in enumerate(colours.items()):
        draw.rectangle([lx, top + 4 + 18 * k, lx + 12, top + 16 + 18 * k], fill=colour)
        draw.text((lx + 18, top + 10 + 18 * k), name, fill="black", font=font, anchor="lm")
    path.parent.mkdir(parents=True, exist_ok=True)
    img.save(path)
