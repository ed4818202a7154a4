"""Tune the acceptance threshold S_aff of each affordance on the procedural validation scenes.

The paper tuned S_aff by hand per affordance. Here it is chosen by measurement, on scenes
that are not the 14 published ones (:mod:`..examples.validation`: living rooms, kitchens,
offices and a garage with chairs, sofas, beds, benches, rails, pegs, taps, a motorbike-like
frame...), with the judge (:mod:`.judge`, itself proven on :mod:`.labelled`) as the label:

1. every example's descriptor is tried on every validation scene at two kinds of test
   points: every scene point within ``near_site`` (3 cm) of a site of any kind or of a fill
   site's tap outlet (where the
   valid places and the hardest negatives are), and a seeded random ``background`` fraction
   (0.5 %) of the others; the paper's normal filter, every pair scored in full, and each
   pair's clearance violations counted;
2. judged: a stratified sample of the pairs (by 0.05 score band and by clearance violation
   band, in each of the two kinds), each pair weighted by the inverse of its probability of
   being drawn (Horvitz-Thompson: a background pair stands for 1 / 0.005 pairs of a dense
   search, a near-site pair for one), and the top-5 poses at every clearance limit tried;
3. for each threshold t and clearance limit v, the pair decisions (score >= t and at most a
   fraction v of the clearance points violated) are compared with the judge: precision,
   recall and F1, estimated with the sample weights, pooled over each affordance's examples
   and scenes;
4. (S_aff, V_aff) is the pair of largest F1 (ties: the stricter).

:func:`tune` runs it and :func:`write` keeps the raw judged pairs (CSV), the curves and the
choice (JSON, Markdown), so that the choice can be checked and redone.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

#: Site kind of each affordance (:mod:`..examples.furniture`).
SITE_OF = {"placing": "place", "sitting": "seat", "hanging": "hang", "filling": "fill",
           "riding": "astride"}
THRESHOLDS = tuple(np.round(np.r_[np.arange(0.02, 0.30, 0.01), np.arange(0.30, 0.951, 0.025)],
                            3))
#: Clearance limits tried (fraction of the clearance points a placement may violate).
LIMITS = (0.02, 0.05, 0.10, 0.20)



@dataclass
class TuneSettings:
    """Parameters of a tuning run (every random step seeded by ``seed``)."""

    scenes: tuple = ()
    examples: tuple = ()
    objects_dir: str | None = None
    spacing: float = 0.01
    near_site: float = 0.03
    background: float = 0.005
    per_band: int = 6
    top_k: int = 5
    seed: int = 0


@dataclass
class TuneResult:
    rows: list = field(default_factory=list)        # judged pairs
    runs: list = field(default_factory=list)        # per (scene, example) counts
    curves: dict = field(default_factory=dict)      # affordance -> per (threshold, limit) rows
    chosen: dict = field(default_factory=dict)      # affordance -> threshold, clearance limit
    settings: dict = field(default_factory=dict)


def _sample(keys: np.ndarray, idx: np.ndarray, per_band: int, rng):
    """Stratified sample of pairs ``idx`` by ``keys`` (their band): (chosen, weights)."""
    out, w = [], []
    for b in np.unique(keys):
        members = idx[keys == b]
        pick = members if len(members) <= per_band else rng.choice(members, per_band,
                                                                       replace=False)
        out.append(np.sort(pick))
        w.append(np.full(len(pick), len(members) / len(pick)))
    if not out:
        return np.zeros(0, np.int64), np.zeros(0)
    return np.concatenate(out), np.concatenate(w)


def _violation_band(v: np.ndarray, k: int) -> np.ndarray:
    return np.searchsorted(np.asarray(LIMITS) * k, v, side="left")


def tune(settings: TuneSettings | None = None, log=print) -> TuneResult:
    """Run the tuning (module docstring) and choose (S_aff, V_aff) per affordance."""
    import interaction_tensor as it
    from ..detect import detect, suppression_radius
    from ..examples import interactions, validation
    from ..predictions import top_k
    from .judge import Judge, JudgeScene

    st = settings or TuneSettings()
    names = list(st.examples) or interactions.names()
    scenes = list(st.scenes) or validation.scene_names()
    res = TuneResult(settings={**asdict(st), "limits": LIMITS})
    t0 = time.perf_counter()
    models = {}
    for n in names:
        ex = interactions.build(n, st.objects_dir, st.seed)
        models[n] = (ex, interactions.build_descriptor(n, seed=st.seed, spacing=st.spacing,
                                                        example=ex, tuned=False),
                     Judge.for_example(ex))
    rng = np.random.default_rng(st.seed)
    for sname in scenes:
        vs = validation.build_scene(sname)
        scene = it.prepare_scene(vs.geometry, st.spacing, seed=st.seed)
        jscene = JudgeScene(vs.geometry)
        kinds = vs.counts()
        # the sites, and above each fill site its tap outlet (filling's test points are there)
        sites = np.array([s.point for s in vs.sites]
                         + [np.add(s.point, (0, 0, s.width)) for s in vs.sites if s.kind == "fill"],
                         float).reshape(-1, 3)
        near = np.zeros(len(scene), bool)
        for group in scene.tree.query_ball_point(sites, st.near_site):
            near[np.asarray(group, np.int64)] = True
        others = np.flatnonzero(~near)
        back = np.sort(rng.choice(others, max(1, int(round(st.background * len(others)))),
                                  replace=False))
        test = np.union1d(np.flatnonzero(near), back)
        for n in names:
            ex, tensor, judge = models[n]
            aff = ex.spec.affordance
            t1 = time.perf_counter()
            det = detect(scene, tensor, it.DetectSettings(
                threshold=1e-9, clearance_max_violations=1.0, top_k=0, seed=st.seed,
                neighbour_cache=True),
                test_indices=test)
            k = len(tensor.clearance_points)
            score, viol = det.pairs.score, det.clearance_violations
            pos = scene.points[det.pair_point]
            is_near = near[det.pair_point]
            weight = np.where(is_near, 1.0, len(others) / len(back))
            radius = suppression_radius(tensor, det.settings)
            tops = set()
            allp = np.arange(len(score))
            for lim in LIMITS:                                # the top 5 at every limit
                ok = allp[viol <= lim * k]
                tops |= set(ok[top_k(pos[ok], score[ok], st.top_k, radius)].tolist())
            bands = (np.floor(score / 0.05).astype(int) * 100 + _violation_band(viol, k) * 10
                     + is_near)
            pick, frac = _sample(bands, allp, st.per_band, rng)
            chosen = {int(i): float(w * weight[i]) for i, w in zip(pick, frac)}
            for i in tops:
                chosen.setdefault(i, 0.0)                    # judged, not in the estimate
            for i, w in chosen.items():
                pose = tensor.pose(scene.points[det.pair_point[i]],
                                   2 * np.pi * det.pair_orientation[i] / det.settings.n_orientations)
                v = judge.judge(jscene, pose)
                res.rows.append({
                    "scene": sname, "example": n, "affordance": aff, "pair": int(i),
                    "near_site": bool(is_near[i]),
                    "score": round(float(score[i]), 5), "violations": int(viol[i]),
                    "clearance_points": k, "weight": round(w, 4), "top": i in tops,
                    "valid": bool(v.valid), "reasons": "; ".join(v.reasons)})
            res.runs.append({"scene": sname, "example": n, "affordance": aff,
                             "sites": int(kinds.get(SITE_OF[aff], 0)),
                             "pairs": int(len(score)), "near_site_pairs": int(is_near.sum()),
                             "seconds": round(time.perf_counter() - t1, 2)})
            judged = res.rows[-len(chosen):]
            log(f"{sname:>15} {n:<16} pairs {len(score):>6} (near sites {int(is_near.sum()):>5}) "
                f"judged {len(chosen):>4} (valid {sum(r['valid'] for r in judged):>3}) sites "
                f"{kinds.get(SITE_OF[aff], 0)} {time.perf_counter() - t1:.0f} s")
    res.curves, res.chosen = choose(res.rows, res.runs)
    res.settings["total_seconds"] = round(time.perf_counter() - t0, 1)
    return res


def curve(rows: list, thresholds=THRESHOLDS, limit: float = 1.0) -> list:
    """Per threshold: estimated precision, recall and F1 of the pair decisions (score >= t
    and at most ``limit`` of the clearance points violated) against the judge."""
    s = np.array([r["score"] for r in rows])
    ok = np.array([r["violations"] <= limit * r["clearance_points"] for r in rows], bool)
    w = np.array([r["weight"] for r in rows])
    v = np.array([r["valid"] for r in rows], bool)
    total_valid = float((w * v).sum())
    out = []
    for t in thresholds:
        acc = (s >= t - 1e-12) & ok
        tp = float((w * (acc & v)).sum())
        pp = float((w * acc).sum())
        prec = tp / pp if pp > 0 else float("nan")
        rec = tp / total_valid if total_valid > 0 else float("nan")
        f1 = 2 * prec * rec / (prec + rec) if pp > 0 and tp > 0 else 0.0
        out.append({"threshold": float(t), "limit": float(limit), "precision": prec,
                    "recall": rec, "f1": f1, "accepted_estimate": pp})
    return out


def choose(rows: list, runs: list):
    """Curves per affordance and clearance limit, and the chosen (S_aff, V_aff): largest F1,
    ties to the stricter (higher threshold, then lower limit)."""
    curves, chosen = {}, {}
    for aff in SITE_OF:
        rs = [r for r in rows if r["affordance"] == aff and r["weight"] > 0]
        if not rs:
            continue
        with_sites = {(r["scene"], r["example"]) for r in runs
                      if r["affordance"] == aff and r["sites"] > 0}
        c = []
        for lim in LIMITS:
            for row in curve(rs, limit=lim):
                t = row["threshold"]
                hit = {(r["scene"], r["example"]) for r in rows if r["affordance"] == aff
                       and r["valid"] and r["score"] >= t - 1e-12
                       and r["violations"] <= lim * r["clearance_points"]}
                row["runs_with_sites"] = len(with_sites)
                row["runs_with_a_valid_accepted"] = len(with_sites & hit)
                c.append(row)
        curves[aff] = c
        best = max(c, key=lambda r: (r["f1"], r["threshold"], -r["limit"]))
        chosen[aff] = {"threshold": best["threshold"], "clearance_limit": best["limit"]}
    return curves, chosen


def write(res: TuneResult, out_dir) -> None:
    """``tuning_pairs.csv`` (every judged pair), ``tuning.json`` (runs, curves, choice) and
    ``tuning.md`` (the chosen thresholds and their curves around them)."""
    from ..io import atomic_dir
    from .common import write_csv, write_json

    with atomic_dir(out_dir, "tuning.json") as out:
        write_csv(out / "tuning_pairs.csv", res.rows,
                  ["scene", "example", "affordance", "pair", "near_site", "score", "violations",
                   "clearance_points", "weight", "top", "valid", "reasons"])
        write_json(out / "tuning.json", {"settings": res.settings, "chosen": res.chosen,
                                         "runs": res.runs, "curves": res.curves})
        lines = ["# S_aff per affordance, tuned on the procedural validation scenes", "",
                 "| affordance | S_aff | clearance limit | precision | recall | F1 | "
                 "runs with a valid accepted pair |", "|---|---|---|---|---|---|---|"]
        for aff, ch in res.chosen.items():
            t, lim = ch["threshold"], ch["clearance_limit"]
            row = next(r for r in res.curves[aff] if r["threshold"] == t and r["limit"] == lim)
            lines.append(f"| {aff} | {t:.3f} | {lim:.2f} | {100 * row['precision']:.1f} | "
                         f"{100 * row['recall']:.1f} | {100 * row['f1']:.1f} | "
                         f"{row['runs_with_a_valid_accepted']}/{row['runs_with_sites']} |")
        lines += ["", "Top-5 poses judged valid per (scene, example):", ""]
        for r in res.runs:
            tops = [x for x in res.rows if x["scene"] == r["scene"]
                    and x["example"] == r["example"] and x["top"]]
            lines.append(f"- {r['scene']} / {r['example']}: {sum(x['valid'] for x in tops)}/"
                         f"{len(tops)} (sites of its kind: {r['sites']})")
        (out / "tuning.md").write_text("\n".join(lines) + "\n")
