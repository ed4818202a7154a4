"""The benchmark: every example on every scene with iT (weight-driven and uniform keypoints),
Naive and BS; the judge; Table 1; the sampling experiment; pictures; wall times.

Protocol (after the paper's human-marker protocol, section 4.2):

* For each (method, example, scene) the method scores (test point, orientation) pairs on the
  same candidates: the paper's seeded random 30 % of the scene points (``sample_fraction``;
  ``test_points`` instead draws a fixed number), kept when their normal line is within 15
  degrees of N_aff. iT scores every candidate, with the example's S_aff (tuned per affordance
  on the procedural validation scenes, :mod:`.tuning`) and the placement tests (clearance,
  contact, interior: :mod:`~interaction_tensor.placement.checks`). Naive and BS,
  whose ICP per pair is 100 x slower, score a seeded random subset of ``max_candidates``
  (Naive, 64) and ``max_bs_candidates`` (BS, 12) of the same candidates, in all 8
  orientations, seeing the scene at the density they were calibrated at.
* **Top 5**: the 5 best pairs after spatial non-maximum suppression (radius d_o / 2): accepted
  pairs first (a method that accepts fewer than 5 still shows its 5 best); for iT, pairs
  passing the placement tests (the accepted pairs that would enter the top 5 tested for
  collision with the scene's triangles as well) before those failing them, then by full
  score (rejected pairs are scored again in full, :func:`~interaction_tensor.detection.ranking.rank_pairs`, exactly); a
  run of iT accepts a prediction when its best pair passes every test. **Bottom 5**: the 5 worst by
  full score, with the same suppression.
* The judge (:mod:`.judge`, proven on the labelled set of :mod:`.labelled`, whose accuracy is
  reported beside the table) labels each of these 10 poses valid or invalid.
* Top predictions are the method's positives, bottom ones its negatives: TP = top and valid,
  FP = top and invalid, TN = bottom and invalid, FN = bottom and valid. Per affordance, over
  its examples and scenes: **precision** = TP / (TP + FP), **accuracy** =
  (TP + TN) / (TP + FP + TN + FN), **F-score** = 2 TP / (2 TP + FP + FN), and how many
  (scene, example) runs accepted any prediction. Beside them, **precision of the accepted
  top predictions**: of the top poses the method itself accepted, the share valid (what a
  user is told; a scene with nothing to accept adds none, so this is not the paper's
  measure, but the one the project's targets are set on, with place recall and false
  acceptance; its average row pools the affordances' accepted top poses). **Place recall**:
  of the (scene, example) runs where a valid place is known, the share whose accepted top
  poses hold a valid one; **false acceptance**: of the runs where none is known, the share
  that accept anything (the right answer there is "no place here"). A place is known where
  any method's judged pose (top or bottom) in that run is valid, or where an exhaustive
  search with the judge found one (:data:`KNOWN_PLACES`, :mod:`.oracle`); a run with no place
  known may still hold one that every method and search missed. The average row
  is otherwise the mean over the five affordances (as the paper's Table 1). The paper's own
  numbers fit F = 2 P / (1 + P) in every row, i.e. its "accuracy" is the precision of the
  top predictions with every bottom prediction counted as a true negative: our precision
  column is the comparable number. Its raters chose the right places among the top 5 and
  bottom 5 shown together; **forced choice** is the share of the places the judge would
  choose there that come from the top 5, TP / (TP + FN) (undefined where it chooses none;
  the average row is the mean over the affordances where it is defined).
* Sampling experiment (paper, Fig. 8): for the pairs the score accepted with the
  weight-driven and the uniform keypoint sets, the keypoint comparisons needed to reach the
  acceptance threshold (``decided_at``), mean over all of them and over the top 20 % by score.
"""

from __future__ import annotations

import csv
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.detection.places import top_k
from interaction_tensor.detection.ranking import rank_pairs
from interaction_tensor.detection.search import Engine, candidates, detect
from interaction_tensor.engine.backends import CACHE_AUTO_FRACTION
from interaction_tensor.errors import InputError
from interaction_tensor.geometry.core import MESH_SUFFIXES
from interaction_tensor.geometry.files import atomic_dir
from itensor_paper import labelled
from itensor_paper.baselines.bisector_icp import bisector_baseline
from itensor_paper.baselines.common import capped_candidates
from itensor_paper.baselines.icp import resolve_backend
from itensor_paper.baselines.naive import naive
from itensor_paper.common import AFFORDANCES, METHODS, ranking_radius  # noqa: F401 (METHODS: re-exported)
from itensor_paper.judge import Judge, JudgeScene, JudgeSettings
from itensor_paper.panel import add_panel_agreement
from itensor_paper.pictures import run_sheet
from itensor_paper.report import write_all


@dataclass
class EvalSettings:
    """Parameters of one evaluation run (every random step seeded by ``seed``)."""

    examples: tuple = ()
    objects_dir: str | None = None
    spacing: float = 0.01
    #: test points: the paper's 30 % of the scene points, or ``test_points`` per scene
    sample_fraction: float = 0.30
    test_points: int | None = None
    max_candidates: int = 64
    max_bs_candidates: int = 12
    methods: tuple = METHODS
    judge_spacing: float = 0.01
    n_judged: int = 5
    pictures: bool = True
    #: judge the labelled set first and report the judge's accuracy (needs objects_dir)
    judge_check: bool = True
    seed: int = 0


@dataclass
class EvalResult:
    judgements: list = field(default_factory=list)
    runs: list = field(default_factory=list)
    judge_accuracy: list = field(default_factory=list)
    sampling: list = field(default_factory=list)
    timings: list = field(default_factory=list)
    table: list = field(default_factory=list)
    settings: dict = field(default_factory=dict)


def scene_files(paths) -> list[Path]:
    """PLY/OBJ/OFF/STL files among ``paths`` (files or directories), sorted by name."""

    out = []
    for p in paths:
        p = Path(p)
        if p.is_dir():
            out += sorted(q for q in p.iterdir() if q.suffix.lower() in MESH_SUFFIXES)
        elif p.exists():
            out.append(p)
        else:
            raise InputError(p, "no such scene file or directory")
    if not out:
        raise InputError(None, "no scene files (.ply, .obj, .off, .stl) found")
    return out


def _select(positions, key, k, radius):

    return top_k(positions, key, k, radius)


def _pick(scene, point, score, accepted, k, radius):
    """Indices of the top-k (accepted first) and bottom-k pairs, with suppression."""
    pos = scene.points[point]
    key = np.where(accepted, 10.0, 0.0) + score
    top = _select(pos, key, k, radius)
    rest = np.setdiff1d(np.arange(len(score)), top)
    bottom = [int(rest[i]) for i in _select(pos[rest], -score[rest], k, radius)]
    return top, bottom


def evaluate(scenes, out_dir, settings: EvalSettings | None = None, log=print) -> EvalResult:
    """Run the benchmark and write its tables, plots and pictures into ``out_dir``.

    Parameters
    ----------
    scenes : scene files or directories of them (metres, +Z up)
    out_dir : output directory: new, empty, or an earlier evaluation's (replaced only
        when the new run is complete)
    settings : :class:`EvalSettings`
    log : callable(str) for progress lines (``lambda s: None`` for quiet)
    """

    st = settings or EvalSettings()
    files = scene_files(scenes if isinstance(scenes, (list, tuple)) else [scenes])
    names = list(st.examples) or affordances.example_names()
    for n in names:
        affordances.spec(n)
    for m in st.methods:
        if m not in METHODS:
            raise InputError(None, f"unknown method {m!r}; known: {', '.join(METHODS)}")
    icp_backend = resolve_backend("auto")
    # every output is built in a temporary directory that replaces out_dir when complete
    with atomic_dir(out_dir, "run.json") as out:
        return _run(files, names, st, icp_backend, out, log)


def _run(files, names, st, icp_backend, out, log) -> EvalResult:

    res = EvalResult(settings={**asdict(st), "icp_backend": icp_backend,
                               "scenes": [f.name for f in files]})
    t_all = time.perf_counter()

    # the judge's own accuracy on the labelled set (shared-scene cases when the data is there)
    # (its poses are of the examples built with the real query objects: --objects)
    if st.objects_dir and st.judge_check:
        poses = labelled.load()
        res.judge_accuracy, _ = labelled.judge_accuracy(poses, st.objects_dir,
                                                        Path(st.objects_dir).parent)
        add_panel_agreement(res.judge_accuracy, files[0].parent, st.objects_dir, log)
        for r in res.judge_accuracy:
            log(f"judge on the labelled set, {r['affordance']}: valid {r['valid_right']}/"
                f"{r['valid_n']}, invalid {r['invalid_right']}/{r['invalid_n']}; agreeing "
                f"with the panel on {r['panel_agree']}/{r['panel_n']} held-out poses")
    else:
        log("judge accuracy on the labelled set not measured (it needs --objects)")

    # training: one descriptor and one judge per example
    models = {}
    for n in names:
        t0 = time.perf_counter()
        ex = affordances.build(n, st.objects_dir, st.seed)
        tensor = affordances.build_descriptor(n, seed=st.seed, spacing=st.spacing, example=ex)
        judge = Judge.for_example(ex, JudgeSettings(spacing=st.judge_spacing, seed=st.seed))
        models[n] = (ex, tensor, judge)
        res.timings.append({"stage": "train", "example": n, "scene": "",
                            "method": "iT", "seconds": round(time.perf_counter() - t0, 3)})
        log(f"trained {n} ({'real' if ex.real_query else 'procedural'} query) "
            f"in {time.perf_counter() - t0:.1f} s")

    for f in files:
        t0 = time.perf_counter()
        geom = it.load_geometry(f)
        scene = it.prepare_scene(geom, st.spacing, seed=st.seed)
        jscene = JudgeScene(geom, st.judge_spacing, st.seed)
        res.timings.append({"stage": "scene", "example": "", "scene": f.stem, "method": "",
                            "seconds": round(time.perf_counter() - t0, 3)})
        for n in names:
            ex, tensor, judge = models[n]
            aff = ex.spec.affordance
            frac = (st.sample_fraction if st.test_points is None
                    else min(1.0, st.test_points / len(scene)))
            radius = ranking_radius(tensor)
            cand = None
            for m in st.methods:
                t1 = time.perf_counter()
                if m.startswith("iT"):
                    kp = m.split("-")[1]
                    det = detect(scene, tensor, it.DetectSettings(
                        sample_fraction=frac, keypoints=kp, seed=st.seed), engine=Engine(
                        # every pair scored first, the accepted ones in full: the sampling
                        # record ranks them by full score, and rank_pairs starts from every
                        # pair's partial score. A container's tap test comes first: it
                        # leaves a few hundred of a scene's pairs, and the score, whose
                        # threshold accepts nearly every pair, would be taken in full of all
                        score_first=not tensor.fills, rank=False,
                        # the exact neighbour cache, kept on the scene's grid for every
                        # example of the scene: at 30 % test points it pays for persons as
                        # well
                        neighbour_cache=True if frac >= CACHE_AUTO_FRACTION else None))
                    cand = det.candidate_indices
                    point = det.pair_point
                    acc = det.pairs.accepted
                    poses = None
                    da = det.pairs.decided_at[det.score_accepted]
                    sc_acc = det.pairs.score[det.score_accepted]
                    top20 = da[sc_acc >= np.quantile(sc_acc, 0.8)] if len(da) else da
                    res.sampling.append({
                        "example": n, "affordance": aff, "scene": f.stem, "keypoints": kp,
                        "pairs": int(len(acc)), "accepted": int(len(da)),
                        "comparisons_to_accept_sum": int(da.sum()),
                        "comparisons_to_accept_top20_sum": int(top20.sum()),
                        "accepted_top20": int(len(top20)),
                        "mean_comparisons_per_decision":
                            det.stats["mean_comparisons_per_decision"]})
                    secs = time.perf_counter() - t1
                    # the best and worst pairs by full score (rejected pairs scored again)
                    # (accepted pairs that would enter the top are tested for collision)
                    top, top_s, top_ok = rank_pairs(det, st.n_judged, radius)
                    # accepted: by the score, and its placement and collision tests passed
                    # (a pair the collision tests never reached, their budget spent, is not)
                    top_accepted = det.pairs.accepted[top] & top_ok
                    any_accepted = bool(top_accepted.any())
                    bottom, bot_s, _ = rank_pairs(det, st.n_judged, radius, worst=True)
                    score = np.zeros(len(acc))
                    score[top], score[bottom] = top_s, bot_s
                else:
                    if cand is None:     # iT did not run: the candidates it would score
                        cand = candidates(scene, tensor, it.DetectSettings(
                            sample_fraction=frac, seed=st.seed))
                    cap = st.max_candidates if m == "Naive" else st.max_bs_candidates
                    sub = capped_candidates(cand, cap, st.seed)
                    fn = naive if m == "Naive" else bisector_baseline
                    r = fn(scene, tensor, sub, backend=icp_backend, seed=st.seed)
                    point, score, acc, poses = r.pair_point, r.score, r.accepted, r.poses
                    secs = time.perf_counter() - t1
                    top, bottom = _pick(scene, point, score, acc, st.n_judged, radius)
                    top_accepted = acc[top]
                    any_accepted = bool(acc.any())
                t2 = time.perf_counter()
                shown = []
                for group, idxs in (("top", top), ("bottom", bottom)):
                    for rank, i in enumerate(idxs, 1):
                        pose = poses[i] if poses is not None else det.pair_pose(int(i))
                        v = judge.judge(jscene, pose)
                        res.judgements.append({
                            "scene": f.stem, "example": n, "affordance": aff, "method": m,
                            "group": group, "rank": rank, "score": round(float(score[i]), 4),
                            "accepted": bool(top_accepted[rank - 1] if group == "top"
                                             else acc[i]), "valid": bool(v.valid),
                            "x": round(float(pose[0, 3]), 3), "y": round(float(pose[1, 3]), 3),
                            "z": round(float(pose[2, 3]), 3),
                            "penetration_m": (round(float(v.penetration), 4)
                                              if np.isfinite(v.penetration) else "inf"),
                            "contact": round(float(v.contact), 3),
                            "reasons": "; ".join(v.reasons), "_pose": pose})
                        if group == "top":
                            shown.append(res.judgements[-1])
                res.runs.append({"scene": f.stem, "example": n, "affordance": aff, "method": m,
                                 "candidates": int(len(np.unique(point))),
                                 "pairs": int(len(acc)), "accepted": int(acc.sum()),
                                 "any_accepted": any_accepted})
                res.timings.append({"stage": "detect", "example": n, "scene": f.stem,
                                    "method": m, "seconds": round(secs, 3),
                                    "candidates": int(len(np.unique(point))),
                                    "pairs": int(len(acc)), "accepted": int(acc.sum()),
                                    "judge_seconds": round(time.perf_counter() - t2, 3)})
                if st.pictures and m == "iT-weighted":

                    run_sheet(out / "pictures" / f"{n}__{f.stem}.png", geom, ex.query, shown,
                              n, f.stem, m)
            done = [r for r in res.judgements if r["scene"] == f.stem and r["example"] == n]
            summary = ", ".join(
                f"{m} {sum(r['valid'] for r in done if r['method'] == m and r['group'] == 'top')}/"
                f"{sum(1 for r in done if r['method'] == m and r['group'] == 'top')}"
                for m in st.methods)
            log(f"{f.stem:>14} {n:<16} valid top: {summary} "
                f"({time.perf_counter() - t0:.0f} s into the scene)")
    res.settings["total_seconds"] = round(time.perf_counter() - t_all, 1)
    res.table = metrics(res.judgements, st.methods, res.runs)

    write_all(res, out)
    return res


#: (scene, example) runs searched exhaustively with the judge (``scripts/filling_oracle.py``,
#: ``region_oracle.py``) and how many valid places the search found (0: none in the family
#: it searched).
KNOWN_PLACES = Path(__file__).resolve().parent / "data" / "known_places.csv"


def known_places(path=KNOWN_PLACES) -> set:
    """{(scene, example)} of the runs in which :data:`KNOWN_PLACES` found a valid place
    (empty without the file)."""

    path = Path(path)
    if not path.exists():
        return set()
    with open(path, newline="") as fh:
        return {(r["scene"], r["example"]) for r in csv.DictReader(fh)
                if int(r["valid_places"]) > 0}


def metrics(judgements, methods=METHODS, runs=(), known=None) -> list[dict]:
    """Table 1 rows: per affordance and method, accuracy, F-score and precision (%), the
    (scene, example) runs with any accepted prediction (``with_accepted`` of ``runs``), place
    recall and false acceptance over ``runs`` (a place known in a run where any judged pose
    of it is valid, or where ``known`` says so: default :func:`known_places`), and the
    average over affordances (module docstring)."""
    rows = []
    present = [a for a in AFFORDANCES if any(j["affordance"] == a for j in judgements)]
    known = known_places() if known is None else set(known)
    known |= {(j["scene"], j["example"]) for j in judgements if j["valid"]}
    found = {(j["scene"], j["example"], j["method"]) for j in judgements
             if j["group"] == "top" and j["accepted"] and j["valid"]}
    for m in methods:
        per = []
        for a in present:
            js = [j for j in judgements if j["affordance"] == a and j["method"] == m]
            tp = sum(j["group"] == "top" and j["valid"] for j in js)
            fp = sum(j["group"] == "top" and not j["valid"] for j in js)
            tn = sum(j["group"] == "bottom" and not j["valid"] for j in js)
            fn = sum(j["group"] == "bottom" and j["valid"] for j in js)
            n = tp + fp + tn + fn
            acc = 100.0 * (tp + tn) / n if n else float("nan")
            f1 = 100.0 * 2 * tp / (2 * tp + fp + fn) if (2 * tp + fp + fn) else 0.0
            prec = 100.0 * tp / (tp + fp) if (tp + fp) else 0.0
            choice = _share(tp, tp + fn)
            # the top poses the method itself accepted (the others fill a top 5 that has
            # fewer accepted ones): what a user is told, and how often it holds
            said = [j for j in js if j["group"] == "top" and j["accepted"]]
            said_ok = sum(bool(j["valid"]) for j in said)
            rr = [r for r in runs if r["affordance"] == a and r["method"] == m]
            with_place = [r for r in rr if (r["scene"], r["example"]) in known]
            no_place = [r for r in rr if (r["scene"], r["example"]) not in known]
            hit = sum((r["scene"], r["example"], m) in found for r in with_place)
            false = sum(bool(r["any_accepted"]) for r in no_place)
            row = {"affordance": a, "method": m, "accuracy": acc, "f_score": f1,
                   "precision": prec, "forced_choice": choice,
                   "tp": tp, "fp": fp, "tn": tn, "fn": fn,
                   "runs": len(rr), "with_accepted": sum(r["any_accepted"] for r in rr),
                   "accepted_top": len(said), "accepted_top_valid": said_ok,
                   "accepted_precision": _share(said_ok, len(said)),
                   "runs_with_place": len(with_place), "runs_finding_place": hit,
                   "place_recall": _share(hit, len(with_place)),
                   "runs_without_place": len(no_place), "runs_accepting_falsely": false,
                   "false_acceptance": _share(false, len(no_place))}
            per.append(row)
            rows.append(row)
        if per:
            avg = {"affordance": "average", "method": m,
                   **{k: float(np.mean([r[k] for r in per]))
                      for k in ("accuracy", "f_score", "precision")},
                   **{k: int(sum(r[k] for r in per))
                      for k in ("tp", "fp", "tn", "fn", "runs", "with_accepted",
                                "accepted_top", "accepted_top_valid", "runs_with_place",
                                "runs_finding_place", "runs_without_place",
                                "runs_accepting_falsely")}}
            chosen = [r["forced_choice"] for r in per if not np.isnan(r["forced_choice"])]
            avg["forced_choice"] = float(np.mean(chosen)) if chosen else float("nan")
            # the accepted top poses (and the runs) of all affordances together, as the
            # counts beside them
            avg["accepted_precision"] = _share(avg["accepted_top_valid"], avg["accepted_top"])
            avg["place_recall"] = _share(avg["runs_finding_place"], avg["runs_with_place"])
            avg["false_acceptance"] = _share(avg["runs_accepting_falsely"],
                                             avg["runs_without_place"])
            rows.append(avg)
    return rows


def _share(part: int, whole: int) -> float:
    """``part`` of ``whole`` in %; NaN when ``whole`` is 0 (nothing to count)."""
    return 100.0 * part / whole if whole else float("nan")
