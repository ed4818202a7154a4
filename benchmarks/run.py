"""Speed and memory benchmarks of training and detection, against the exact reference.

Usage::

    python benchmarks/run.py                 # everything, writes benchmarks/RESULTS.md/.json
    python benchmarks/run.py --quick         # smaller sample fractions (minutes)
    python benchmarks/run.py --only train    # one group: train, detect, sitting, big, many,
                                             # torch (--sitting-full: that case's whole run)

Each case runs in its own subprocess so that its peak resident memory is its own.
The data come from ../shared/data (or $ITENSOR_SHARED_DATA).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DATA = Path(os.environ.get("ITENSOR_SHARED_DATA", ROOT.parent / "shared" / "data"))


# --------------------------------------------------------------------------- cases
def _paper_bowl_tensor(seed=0):
    import interaction_tensor as it
    from interaction_tensor.examples.procedural import parts_mesh, table

    bowl = it.load_geometry(DATA / "objects" / "paper_bowl.ply")
    bowl.vertices = bowl.vertices + [0, 0, 0.75]
    tbl = parts_mesh(table("t", (0, 0), (1.0, 0.8), 0.75))
    return bowl, tbl


def _examples():
    """(name, query, scene_object, settings) of every training example available."""
    import interaction_tensor as it
    from interaction_tensor.examples import demo

    out = []
    q, s = demo.training_example()
    out.append(("demo placing-bowl (procedural)", q, s, it.TrainSettings()))
    q, s = _paper_bowl_tensor()
    out.append(("paper_bowl.ply on a table", q, s, it.TrainSettings()))
    try:
        from interaction_tensor import affordances
    except ImportError:
        return out
    for name in affordances.example_names():
        ex = affordances.build(name)
        out.append((name, ex.query, ex.scene_object, affordances.train_settings(name)))
    return out


def case_train(repeats: int) -> dict:
    """Training time per example and stage (sampling, Voronoi, keypoints, calibration),
    median of ``repeats`` fits with different seeds."""
    import dataclasses

    import interaction_tensor as it

    rows = []
    for name, q, s, settings in _examples():
        runs = []
        for r in range(repeats):
            t = it.InteractionTensor.fit(q, s, name, dataclasses.replace(settings, seed=r))
            runs.append(t.meta)
        stages = runs[0]["timings_s"].keys()
        rows.append({"example": name, "runs": repeats,
                     "median_s": {k: statistics.median(m["timings_s"][k] for m in runs)
                                  for k in stages},
                     "samples": runs[0]["query_samples"] + runs[0]["scene_object_samples"],
                     "bisector_points": runs[0]["bisector_points"]})
    return {"train": rows}


def _top5(det) -> list:
    return [[*np.round(p.position, 4).tolist(), p.orientation_index] for p in det.predictions[:5]]


def case_detect(scene_name: str, fraction: float, n_ref: int) -> dict:
    """Detection of the paper's bowl at the default settings (Numba, the paper's weight
    order, the neighbour cache at 30 %), in the adaptive order, and through the grid search
    alone (weight order); then the exact reference on a candidate subset."""
    import interaction_tensor as it
    from interaction_tensor.engine.numba_backend import score_pairs_numba
    from interaction_tensor.engine.scoring import score_pairs_exact

    bowl, tbl = _paper_bowl_tensor()
    tensor = it.InteractionTensor.fit(bowl, tbl, "placing-bowl", it.TrainSettings())
    t0 = time.perf_counter()
    scene = it.prepare_scene(it.load_geometry(DATA / "scenes" / f"{scene_name}.ply"), 0.01, seed=0)
    prepare_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    scene.grid()
    index_s = time.perf_counter() - t0
    it.detect(scene, tensor, it.DetectSettings(sample_fraction=0.001))   # compile the kernels
    out = {"scene": scene_name, "scene_points": len(scene), "sample_fraction": fraction,
           "prepare_s": round(prepare_s, 3), "index_s": round(index_s, 3)}
    dets = {}
    # the defaults (weight order, the neighbour cache at 30 % test points), the adaptive
    # order, and the grid search alone in weight order (the default path before
    # 2026-11-24): same decisions, same run
    for order, cache in (("weight", None), ("adaptive", None), ("grid", False)):
        det = it.detect(scene, tensor, it.DetectSettings(
            sample_fraction=fraction, keypoint_order="weight" if order == "grid" else order,
            neighbour_cache=cache))
        st = det.stats
        dets[order] = det
        sc = st["deciding_seconds"]
        out[order] = {
            "test_points": st["test_points_sampled"],
            "candidates": st["candidates_after_normal_filter"],
            "pairs": st["pairs"], "accepted_pairs": st["pairs_accepted"],
            "scoring_s": round(sc, 3), "order_s": round(st["seconds"].get("keypoint_order", 0), 3),
            # rates count the work done: candidates (all 8 orientations decided) and pairs
            "candidates_per_s": st["candidates_after_normal_filter"] / sc,
            "pairs_per_s": st["pairs"] / sc,
            "keypoint_evaluations_per_s": st["keypoint_comparisons"] / sc,
            "mean_comparisons_per_decision": st["mean_comparisons_per_decision"],
            "top5": _top5(det)}
    a, d, g = dets["weight"], dets["adaptive"], dets["grid"]     # the default first
    acc = a.pairs.accepted
    out["orders_agree"] = {
        "decisions": float(np.mean(d.pairs.accepted == acc)),
        "max_accepted_score_difference": float(
            np.abs(d.pairs.score[acc] - a.pairs.score[acc]).max(initial=0)),
        "top5": _top5(d) == _top5(a),
        # adaptive against the default weight order, and against the grid search
        "speedup": out["weight"]["scoring_s"] / out["adaptive"]["scoring_s"],
        "speedup_vs_grid": out["grid"]["scoring_s"] / out["adaptive"]["scoring_s"]}
    out["grid_agrees"] = {            # the neighbour cache against the grid, both weight order
        "decisions": float(np.mean(a.pairs.accepted == g.pairs.accepted)),
        "scores": bool(np.array_equal(a.pairs.score, g.pairs.score)),
        "top5": _top5(a) == _top5(g),
        "speedup": out["grid"]["scoring_s"] / out["weight"]["scoring_s"]}
    # exact reference: every keypoint of every pair, batched cKDTree, no early exit
    rng = np.random.default_rng(0)
    cand = np.sort(rng.choice(a.candidate_indices, size=min(n_ref, len(a.candidate_indices)),
                              replace=False))
    n_o = a.settings.n_orientations
    pp, po = np.repeat(cand, n_o), np.tile(np.arange(n_o), len(cand))
    table = tensor.keypoint_table(a.settings)
    _ = scene.tree          # the reference's index, built outside its timing like the grid
    t0 = time.perf_counter()
    ref = score_pairs_exact(scene.points[pp], po, table, scene, a.threshold, tensor.vectors)
    ref_s = time.perf_counter() - t0
    # the fast path (default settings) on exactly the reference's pairs
    t0 = time.perf_counter()
    s, acc, _, _ = score_pairs_numba(scene.points[pp], po, table, scene.grid(), a.threshold,
                                     tensor.vectors, scene.spacing)
    fast_s = time.perf_counter() - t0
    # and through the neighbour cache (the default at 30 %): its decisions, not its speed
    # (1,000 scattered candidates leave each block of it nearly unused)
    s_c, acc_c, _, _ = score_pairs_numba(scene.points[pp], po, table, scene.grid(), a.threshold,
                                         tensor.vectors, scene.spacing, cache=True)
    scene.grid().cache = None
    from interaction_tensor.detection.places import suppression_radius, top_k

    def top(score, accepted):
        idx = np.flatnonzero(accepted)
        picks = top_k(scene.points[pp[idx]], score[idx], 5, suppression_radius(tensor, a.settings))
        return [(int(pp[idx[i]]), int(po[idx[i]])) for i in picks]
    out["reference"] = {
        "candidates": int(len(cand)), "pairs": int(len(pp)), "seconds": round(ref_s, 3),
        "candidates_per_s": len(cand) / ref_s, "fast_seconds_same_subset": round(fast_s, 3),
        "speedup": ref_s / fast_s,
        "decision_agreement": float(np.mean(acc == ref.accepted)),
        "accepted_reference": int(ref.accepted.sum()),
        "max_accepted_score_difference": float(np.abs(s[acc & ref.accepted] - ref.score[acc & ref.accepted]).max(initial=0)),
        "top5_identical": top(s, acc) == top(ref.score, ref.accepted),
        "cache_decision_agreement": float(np.mean(acc_c == ref.accepted)),
        "cache_top5_identical": top(s_c, acc_c) == top(ref.score, ref.accepted)}
    return out


def case_big(n_points: int, fraction: float) -> dict:
    """kitchen5 sampled to ``n_points`` points, detected with the default settings."""
    import interaction_tensor as it

    bowl, tbl = _paper_bowl_tensor()
    tensor = it.InteractionTensor.fit(bowl, tbl, "placing-bowl", it.TrainSettings())
    geometry = it.load_geometry(DATA / "scenes" / "kitchen5.ply")
    from interaction_tensor.geometry.sampling import mesh_area
    spacing = float(np.sqrt(mesh_area(geometry) / n_points))
    t0 = time.perf_counter()
    scene = it.prepare_scene(geometry, spacing, seed=0, max_points=n_points)
    det = it.detect(scene, tensor, it.DetectSettings(sample_fraction=fraction))
    return {"scene_points": len(scene), "spacing": spacing, "sample_fraction": fraction,
            "candidates": det.stats["candidates_after_normal_filter"],
            "scoring_s": round(det.stats["deciding_seconds"], 2),
            "seconds": round(time.perf_counter() - t0, 2)}


def case_sitting(scene_name: str, fraction: float, n_patch: int, rounds: int, full: bool) -> dict:
    """sitting-human (a 1.7 m person: its keypoints lie far from any surface, where the grid
    search is slowest) on the largest scene: the grid search against the neighbour cache on a
    dense patch (the ``n_patch`` candidates nearest, in plan, to a seeded random candidate, at
    the detection's test-point density), interleaved, outputs compared bit for bit; with
    ``full``, the whole detection at the defaults as well."""
    import interaction_tensor as it
    from interaction_tensor import affordances
    from interaction_tensor.detection.search import (
        _test_points,
        candidate_mask,
        resolve_threshold,
    )
    from interaction_tensor.engine import numba_backend as kernels

    tensor = affordances.build_descriptor("sitting-human", objects_dir=DATA / "objects",
                                           spacing=0.01)
    scene = it.prepare_scene(it.load_geometry(DATA / "scenes" / f"{scene_name}.ply"), 0.01,
                             seed=0)
    grid = scene.grid()
    st = it.DetectSettings(sample_fraction=fraction).for_scene(scene)
    test = _test_points(scene, st)
    cand = test[candidate_mask(scene.normals[test], tensor.affordance_normal,
                               st.normal_tolerance_deg, st.oriented_normals)]
    rng = np.random.default_rng(0)
    centre = scene.points[rng.choice(cand), :2]
    patch = np.sort(cand[np.argsort(np.linalg.norm(scene.points[cand, :2] - centre, axis=1))
                         [:n_patch]])
    n_o = st.n_orientations
    pp = np.repeat(patch, n_o)
    job = kernels.ScoreJob(scene.points[pp], np.tile(np.arange(n_o), len(patch)),
                           tensor.keypoint_table(st), resolve_threshold(tensor, st),
                           tensor.vectors, scene.spacing, True)
    kernels.score_jobs([kernels.ScoreJob(job.points[:64], job.orient[:64], job.table,
                                         job.threshold, job.vectors, job.rho)], grid, False)
    kernels.score_jobs([kernels.ScoreJob(job.points[:64], job.orient[:64], job.table,
                                         job.threshold, job.vectors, job.rho)], grid, True)
    from interaction_tensor.engine.backends import (
        CACHE_AUTO_BYTES_PER_POINT,
        CACHE_AUTO_FLOOR,
    )

    auto_budget = min(kernels.CACHE_BYTES,
                      max(CACHE_AUTO_FLOOR, CACHE_AUTO_BYTES_PER_POINT * len(scene)))
    times = {"grid": [], "cache_cold": [], "cache_warm": [], "cache_auto": []}
    same = True
    for _ in range(rounds):
        t0 = time.perf_counter()
        ref = kernels.score_jobs([job], grid, False)[0]
        times["grid"].append(time.perf_counter() - t0)
        grid.cache = None
        for label, budget in (("cache_cold", kernels.CACHE_BYTES),
                              ("cache_warm", kernels.CACHE_BYTES), ("cache_auto", auto_budget)):
            if label == "cache_auto":
                grid.cache = None
            t0 = time.perf_counter()
            got = kernels.score_jobs([job], grid, True, budget)[0]
            times[label].append(time.perf_counter() - t0)
            same &= all(np.array_equal(x, y) for x, y in zip(ref, got))
        grid.cache = None
    med = {k: statistics.median(v) for k, v in times.items()}
    out = {"scene": scene_name, "scene_points": len(scene), "sample_fraction": fraction,
           "patch_candidates": int(len(patch)),
           "patch_extent_m": np.ptp(scene.points[patch, :2], axis=0).round(2).tolist(),
           "patch_accepted_pairs": int(ref[1].sum()), "patch_pairs": int(len(pp)),
           "rounds": rounds, "median_s": med,
           "candidates_per_s": {k: len(patch) / v for k, v in med.items()},
           "speedup_cold": med["grid"] / med["cache_cold"],
           "speedup_warm": med["grid"] / med["cache_warm"],
           "speedup_auto": med["grid"] / med["cache_auto"], "auto_budget_mb":
           auto_budget / 2 ** 20, "identical": bool(same)}
    if full:
        # the whole detection at the defaults (auto: the cache within its budget per scene
        # point), then again with the grid search alone; same candidates, compared
        runs = {}
        for label, mode in (("defaults", None), ("grid", False)):
            grid.cache = None
            det = it.detect(scene, tensor, it.DetectSettings(sample_fraction=fraction,
                                                            neighbour_cache=mode))
            sd = det.stats
            runs[label] = det
            out["full" if label == "defaults" else "full_grid"] = {
                "candidates": sd["candidates_after_normal_filter"],
                "pairs": sd["pairs"], "accepted_pairs": sd["pairs_accepted"],
                "scoring_s": round(sd["deciding_seconds"], 1),
                "candidates_per_s": sd["candidates_after_normal_filter"] /
                sd["deciding_seconds"]}
        a, b = runs["defaults"].pairs, runs["grid"].pairs
        out["full"]["identical"] = bool(all(np.array_equal(getattr(a, n), getattr(b, n))
                                            for n in ("score", "accepted", "decided_at")))
        out["full"]["top5_identical"] = _top5(runs["defaults"]) == _top5(runs["grid"])
        out["full"]["speedup"] = (out["full"]["candidates_per_s"] /
                                  out["full_grid"]["candidates_per_s"])
    return out


def _scaled_descriptors(count: int) -> list:
    """``count`` descriptors: the 8 examples, then the same examples scaled as a whole
    (query and scene-object about the query's base) by 0.8 ... 1.3."""
    import interaction_tensor as it
    from interaction_tensor import affordances

    sizes = [1.0, 0.8, 0.85, 0.9, 0.95, 1.05, 1.1, 1.15, 1.2, 1.25, 1.3]
    tensors = []
    for size in sizes:
        for name in affordances.example_names():
            if len(tensors) == count:
                return tensors
            ex = affordances.build(name)
            base = ex.query.vertices.min(axis=0)
            q = it.Geometry((ex.query.vertices - base) * size + base, ex.query.faces)
            s = it.Geometry((ex.scene_object.vertices - base) * size + base,
                            ex.scene_object.faces, ex.scene_object.normals)
            tensors.append(it.InteractionTensor.fit(q, s, f"{name}@{size}",
                                                    affordances.train_settings(name)))
    return tensors


def case_many(scene_name: str, fraction: float, counts: list[int]) -> dict:
    """Scoring time of 1, 8, 32, 84 descriptors in one pass over shared test points and
    scene index, against one descriptor alone."""
    import interaction_tensor as it

    tensors = _scaled_descriptors(max(counts))
    scene = it.prepare_scene(it.load_geometry(DATA / "scenes" / f"{scene_name}.ply"), 0.01, seed=0)
    scene.grid()
    settings = it.DetectSettings(sample_fraction=fraction, seed=0)
    rows = []
    for n in counts:
        t0 = time.perf_counter()
        res = it.detect_many(scene, tensors[:n], settings)
        rows.append({"descriptors": n, "seconds": time.perf_counter() - t0,
                     # the scoring stage and the placement tests (tests-first scores only
                     # the pairs the tests pass)
                     "scoring_s": res[0].stats["deciding_seconds"],
                     "accepted": [int(r.pairs.accepted.sum()) for r in res]})
        # what the authors' agglomeration could share: the distinct small cells that the
        # keypoints of every orientation fall in, per descriptor and over all of them
        # (keypoint positions relative to the test point, as in one scoring pass)
        cells = [_keypoint_cells(t, settings, 0.01) for t in tensors[:n]]
        rows[-1]["cells_1cm_sum"] = int(sum(len(c) for c in cells))
        rows[-1]["cells_1cm_union"] = int(len(np.unique(np.concatenate(cells))))
        rows[-1]["comparisons_per_candidate"] = [
            r.stats["keypoint_comparisons"] / max(r.stats["candidates_after_normal_filter"], 1)
            for r in res]
    for r in rows:
        r["cost_vs_one"] = r["scoring_s"] / rows[0]["scoring_s"]
    return {"scene": scene_name, "fraction": fraction,
            "test_points": int(round(fraction * len(scene))), "rows": rows}


def _keypoint_cells(tensor, settings, size: float) -> np.ndarray:
    """Distinct cells of edge ``size`` holding a keypoint of ``tensor`` in any orientation,
    keypoints placed relative to the test point; one int64 key per cell."""
    
    ijk = np.floor(tensor.keypoint_table(settings).offsets.reshape(-1, 3) / size).astype(np.int64)
    ijk += 1 << 20                                  # non-negative for any object under 10 km
    return np.unique((ijk[:, 0] << 42) | (ijk[:, 1] << 21) | ijk[:, 2])


# --------------------------------------------------------------------------- driver
def run_case(argv: list[str]) -> dict:
    """Run one case in a subprocess; return its JSON plus its peak RSS."""
    proc = subprocess.run([sys.executable, __file__, "--one", *argv], capture_output=True,
                          text=True)
    if proc.returncode != 0:
        raise SystemExit(f"case {argv} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def one(argv: list[str]) -> None:
    kind = argv[0]
    if kind == "train":
        out = case_train(int(argv[1]))
    elif kind == "detect":
        out = case_detect(argv[1], float(argv[2]), int(argv[3]))
    elif kind == "sitting":
        out = case_sitting(argv[1], float(argv[2]), int(argv[3]), int(argv[4]), argv[5] == "1")
    elif kind == "big":
        out = case_big(int(argv[1]), float(argv[2]))
    elif kind == "many":
        out = case_many(argv[1], float(argv[2]), [int(v) for v in argv[3].split(",")])
    elif kind == "torch":
        try:
            out = case_torch(argv[1], float(argv[2]))
        except Exception as exc:   # no torch installed: say so in the results
            out = {"error": f"{type(exc).__name__}: {exc}"}
    else:
        raise SystemExit(f"unknown case {kind}")
    out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps(out, default=float))


def largest_scene() -> str:
    import trimesh

    best, area = None, -1.0
    for f in sorted((DATA / "scenes").glob("*.ply")):
        a = trimesh.load(f, process=False).area
        if a > area:
            best, area = f.stem, a
    return best


def case_torch(scene_name: str, fraction: float) -> dict:
    """The torch backend (CUDA when present, else its CPU build) against the Numba path."""
    import functools

    import interaction_tensor as it
    from interaction_tensor.engine.torch_backend import import_torch, resolve_device

    torch = import_torch()
    device = resolve_device(None)
    if device == "cpu":        # the CPU build: a small sample, for the agreement only
        fraction = min(fraction, 0.002)
    bowl, tbl = _paper_bowl_tensor()
    tensor = it.InteractionTensor.fit(bowl, tbl, "placing-bowl", it.TrainSettings())
    scene = it.prepare_scene(it.load_geometry(DATA / "scenes" / f"{scene_name}.ply"), 0.01, seed=0)
    it.detect(scene, tensor, it.DetectSettings(sample_fraction=0.0005))    # compile / warm up
    it.detect(scene, tensor, it.DetectSettings(sample_fraction=0.0005, backend="torch"))
    res = {"numba": it.detect(scene, tensor, it.DetectSettings(sample_fraction=fraction))}
    # the torch path as it is, and the same run as the code before 2026-11-26 scored it
    # (pairs in the caller's order: blocks spread over the whole scene); with more tile
    # levels (the queries one level cannot prove asked again of larger tiles on the device
    # instead of the CPU's cKDTree); "cdist": the tiles searched with torch.cdist from a
    # Python loop over them (the kernel before the Triton one, and the one without Triton);
    # $ITENSOR_BENCH_VARIANTS picks (default: torch, before)
    variants = {"torch": {}, "one_level": {"levels": 1, "coarsening": 4.0},
                "two_levels": {"levels": 2, "coarsening": 4.0},
                "three_levels": {"levels": 3, "coarsening": 2.0},
                "before": {"spatial_order": False}, "cdist": {"kernel": "cdist"},
                "cdist_two_levels": {"kernel": "cdist", "levels": 2}}
    chosen = os.environ.get("ITENSOR_BENCH_VARIANTS", "torch,before").split(",")
    from interaction_tensor.engine import torch_backend
    index_cls, scorer = torch_backend.TorchIndex, torch_backend.score_pairs_torch
    made = {}
    out = {}
    for name in chosen:
        opts = variants[name]

        def index(*a, _opts=opts, _name=name, **k):
            made[_name] = index_cls(*a, levels=_opts.get("levels"),
                                    coarsening=_opts.get("coarsening"),
                                    kernel=_opts.get("kernel", "auto"), **k)
            return made[_name]

        torch_backend.TorchIndex = index
        torch_backend.score_pairs_torch = functools.partial(
            scorer, spatial_order=opts.get("spatial_order", True))
        try:
            det = it.detect(scene, tensor, it.DetectSettings(sample_fraction=fraction,
                                                             backend="torch"))
        finally:
            torch_backend.TorchIndex, torch_backend.score_pairs_torch = index_cls, scorer
        res[name] = det
        sc = det.stats["deciding_seconds"]
        out[name] = {"scoring_s": round(sc, 3),
                     "candidates_per_s": det.stats["candidates_after_normal_filter"] / sc,
                     "tree_queries": made[name].tree_queries,
                     "kernel": made[name].kernel,
                     "identical_decisions": bool(np.array_equal(det.pairs.accepted,
                                                                res["numba"].pairs.accepted)),
                     "identical_top5": _top5(det) == _top5(res["numba"])}
    a = res["numba"]
    b = res[chosen[0]]
    sc = b.stats["deciding_seconds"]
    return {"scene": scene_name, "fraction": fraction, "device": device,
            "device_name": (torch.cuda.get_device_name(0) if device.startswith("cuda") else "cpu"),
            "torch": torch.__version__, "test_points": b.stats["test_points_sampled"],
            "candidates": b.stats["candidates_after_normal_filter"],
            "torch_scoring_s": round(sc, 3),
            "torch_candidates_per_s": b.stats["candidates_after_normal_filter"] / sc,
            "numba_scoring_s": round(a.stats["deciding_seconds"], 3),
            "numba_threads": numba_threads(),
            "variants": out,
            "decision_agreement": float(np.mean(a.pairs.accepted == b.pairs.accepted)),
            "top5_identical": all(v["identical_top5"] for v in out.values())}


def numba_threads() -> int:
    import numba

    return int(numba.get_num_threads())


NOTES = """## Where the time goes, and what was tried

The measurements behind the kept and dropped designs before 2026-11-27 (profiles of a
query, the adaptive order, approximate neighbours, finer cells, sharing queries between
descriptors) are in [`HISTORY.md`](HISTORY.md), in the units of their day; those of
2026-11-27 are in the sections below.
"""


def _torch_rate(g: dict) -> str:
    """The torch run's rate in candidates/s (runs recorded before the candidates were)."""
    if "torch_candidates_per_s" in g:
        return f"{g['torch_candidates_per_s']:.0f} candidates/s"
    return "candidates not recorded"


def markdown(results: dict, summary: str = "") -> str:
    """RESULTS.md from a run's figures; ``summary`` (the block between :data:`SUMMARY` and
    :data:`SUMMARY_END` of the file it replaces, kept as it is) follows the header."""
    lines = ["# Benchmark results", "",
             f"- date: {results['date']}", f"- machine: {results['machine']}",
             f"- command: `{results['command']}`"]
    lines += [f"- then: `{u}`" for u in results.get("updates", [])]
    lines += [""]
    if summary:
        lines += [summary.strip("\n"), ""]
    tr = results["train"]["train"]
    lines += ["## Training (median of runs, seconds)", "",
              "| example | samples | bisector points | sampling | bisector | keypoints | calibration | total |",
              "|---|---|---|---|---|---|---|---|"]
    for r in tr:
        m = r["median_s"]
        lines.append(f"| {r['example']} | {r['samples']} | {r['bisector_points']} | "
                     f"{m['sampling']:.3f} | {m['bisector']:.3f} | {m['keypoints']:.3f} | "
                     f"{m['calibration']:.3f} | **{m['total']:.3f}** |")
    lines += ["", f"Peak memory of the training process: {results['train']['peak_rss_mb']:.0f} MB", ""]
    lines += ["## Detection (placing-bowl, paper criterion, weighted keypoints, Numba backend)", "",
              "`weight` is the default keypoint order (the paper's); `adaptive` compares first "
              "the keypoints that fail most often on a seeded pilot of the scene's own pairs "
              "(faster for this bowl, slower for a person: measured in HISTORY.md and in "
              "*Keypoint order* below). Both decide "
              "exactly alike and give the same accepted scores and top 5; only the partial "
              "scores kept by rejected pairs differ (README). Both answer nearest neighbours "
              "from the neighbour cache, the default at 30 % test points; `grid` is the weight "
              "order through the grid search alone (the default path before 2026-11-24, here "
              "with the same Z-ordered batches), in the same run.", "",
              "Rates count the work done: a candidate is a test point that passed the normal "
              "filter, decided in all 8 orientations (the placement tests and the score); a pair is one (candidate, orientation). "
              "Sampled test points are a count, not a rate.", "",
              "| scene | points | fraction | order | test points sampled | candidates | deciding s (placement tests and scoring) | candidates/s | pairs/s | keypoint evals/s | comparisons/decision | peak MB |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for d in results["detect"]:
        for order in ("weight", "adaptive", "grid"):
            if order not in d:
                continue
            o = d[order]
            lines.append(f"| {d['scene']} | {d['scene_points']} | {d['sample_fraction']} | {order} | "
                         f"{o['test_points']} | {o['candidates']} | {o['scoring_s']:.1f} | "
                         f"**{o['candidates_per_s']:.0f}** | "
                         f"{o.get('pairs_per_s', o['pairs'] / o['scoring_s']):.0f} | "
                         f"{o['keypoint_evaluations_per_s'] / 1e6:.2f} M | "
                         f"{o['mean_comparisons_per_decision']:.0f} | {d['peak_rss_mb']:.0f} |")
    lines += ["", "Adaptive order against the default (the paper's weight order), same run: " + "; ".join(
        f"{d['scene']}: **{d['orders_agree']['speedup']:.2f}x** the candidates/s "
        f"({d['orders_agree']['speedup_vs_grid']:.2f}x the grid search's), "
        f"{100 * d['orders_agree']['decisions']:.2f} % identical decisions, accepted scores "
        f"within {d['orders_agree']['max_accepted_score_difference']:.1e}, "
        f"identical top 5: {d['orders_agree']['top5']}" for d in results["detect"]) + "."]
    if all("grid_agrees" in d for d in results["detect"]):
        lines += ["", "Neighbour cache (default) against the grid search alone, both in weight "
                  "order, same run: " +
                  "; ".join(f"{d['scene']}: **{d['grid_agrees']['speedup']:.2f}x** the "
                            f"candidates/s, {100 * d['grid_agrees']['decisions']:.2f} % identical "
                            f"decisions, identical scores: {d['grid_agrees']['scores']}, "
                            f"identical top 5: {d['grid_agrees']['top5']}"
                            for d in results["detect"]) + "."]
    lines += ["", "### Against the exact reference (same candidates, all 512 keypoints, batched cKDTree, no early exit)", "",
              "| scene | candidates | reference cand/s | fast cand/s | speed-up | identical decisions | identical top 5 |",
              "|---|---|---|---|---|---|---|"]
    for d in results["detect"]:
        r = d["reference"]
        lines.append(f"| {d['scene']} | {r['candidates']} | {r['candidates_per_s']:.0f} | "
                     f"{r['candidates'] / r['fast_seconds_same_subset']:.0f} | "
                     f"{r['speedup']:.1f}x | {100 * r['decision_agreement']:.2f} % | "
                     f"{r['top5_identical']} |")
    if all("cache_decision_agreement" in d["reference"] for d in results["detect"]):
        lines += ["", "Through the neighbour cache, the same candidates decide as the reference "
                  "does: " + "; ".join(
                      f"{d['scene']}: {100 * d['reference']['cache_decision_agreement']:.2f} %, "
                      f"identical top 5: {d['reference']['cache_top5_identical']}"
                      for d in results["detect"]) + "."]
    if "sitting" in results:
        si = results["sitting"]
        cps = si["candidates_per_s"]
        lines += ["", f"## Sitting (sitting-human on {si['scene']}, {si['scene_points']} points, "
                  f"{si['sample_fraction']:.0%} test points)", "",
                  f"A dense patch: the {si['patch_candidates']} candidates nearest in plan to a "
                  f"seeded random one ({si['patch_extent_m'][0]} x {si['patch_extent_m'][1]} m, "
                  f"{si['patch_pairs']} pairs, {si['patch_accepted_pairs']} accepted), scored "
                  f"{si['rounds']} times interleaved; medians. A person's keypoints lie far from "
                  "the surfaces, where the grid search visits many cells.", "",
                  "| path | seconds | candidates/s | against the grid search |", "|---|---|---|---|",
                  f"| grid search | {si['median_s']['grid']:.2f} | {cps['grid']:.0f} | 1.00x |",
                  f"| neighbour cache, from empty | {si['median_s']['cache_cold']:.2f} | "
                  f"{cps['cache_cold']:.0f} | **{si['speedup_cold']:.2f}x** |",
                  f"| neighbour cache, built | {si['median_s']['cache_warm']:.2f} | "
                  f"{cps['cache_warm']:.0f} | {si['speedup_warm']:.2f}x |",
                  f"| neighbour cache from empty, detect's default budget "
                  f"({si['auto_budget_mb']:.0f} MB) | {si['median_s']['cache_auto']:.2f} | "
                  f"{cps['cache_auto']:.0f} | **{si['speedup_auto']:.2f}x** |", "",
                  f"Outputs bit-identical to the grid search's: {si['identical']}."]
        if "full" in si:
            f, g = si["full"], si["full_grid"]
            lines += ["", "The whole detection, the same candidates: ", "",
                      "| run | candidates | pairs (accepted) | deciding s | candidates/s | "
                      "against the grid search |", "|---|---|---|---|---|---|",
                      f"| defaults (auto neighbour cache) | {f['candidates']} | {f['pairs']} "
                      f"({f['accepted_pairs']}) | {f['scoring_s']} | "
                      f"{f['candidates_per_s']:.0f} | **{f['speedup']:.2f}x** |",
                      f"| grid search alone | {g['candidates']} | {g['pairs']} "
                      f"({g['accepted_pairs']}) | {g['scoring_s']} | "
                      f"{g['candidates_per_s']:.0f} | 1.00x |", "",
                      f"Scores, decisions and decided-at bit-identical: {f['identical']}; "
                      f"identical top 5: {f['top5_identical']}."]
    b = results["big"]
    lines += ["", "## A 5-million-point scene", "",
              f"kitchen5 sampled at {b['spacing'] * 1000:.1f} mm: {b['scene_points']} points, "
              f"fraction {b['sample_fraction']}, {b['candidates']} candidates, scoring "
              f"{b['scoring_s']} s, whole run {b['seconds']} s, peak memory **{b['peak_rss_mb']:.0f} MB**."]
    m = results["many"]
    lines += ["", f"## Many affordances in one pass ({m['scene']}, {m['test_points']} test "
                  "points; shared test points and scene index, exact)", "",
              "The 8 paper examples (procedural query objects) and copies scaled 0.8-1.3x, "
              "at 0.5 % test points; \"one\" is the first of them, filling-mug, the cheapest "
              "per candidate, so the ratios say how the cost grows with the number of "
              "descriptors, not issue 16's 8 against one (placing-bowl as `itensor evaluate` "
              "trains it, at 30 %: the summary above, `many_vs_one.py`).", "",
              "| descriptors | deciding s (placement tests and scoring) | cost vs one | cost per "
              "descriptor vs one |", "|---|---|---|---|"]
    for r in m["rows"]:
        lines.append(f"| {r['descriptors']} | {r['scoring_s']:.1f} | {r['cost_vs_one']:.1f}x | "
                     f"{r['cost_vs_one'] / r['descriptors']:.2f}x |")
    if "cells_1cm_union" in m["rows"][0]:
        one = m["rows"][0]["comparisons_per_candidate"][0]
        lines += ["", "What sharing queries could save (the authors' agglomerative descriptor: one "
                  "nearest-neighbour query per occupied 1 cm cell, every keypoint of every "
                  "orientation, no early exit). Cells are counted relative to the test point; "
                  f"one descriptor alone, exact with early exit, makes {one:.0f} comparisons per "
                  "candidate (8 orientations).", "",
                  "| descriptors | 1 cm cells, sum over descriptors | 1 cm cells, union | shared | "
                  "union vs one descriptor's exact comparisons |", "|---|---|---|---|---|"]
        for r in m["rows"]:
            lines.append(f"| {r['descriptors']} | {r['cells_1cm_sum']} | {r['cells_1cm_union']} | "
                         f"{100 * (1 - r['cells_1cm_union'] / r['cells_1cm_sum']):.0f} % | "
                         f"{r['cells_1cm_union'] / one:.1f}x |")
    if "torch" in results:
        g = results["torch"]
        lines += ["", "## torch backend", ""]
        if "error" in g:
            lines.append(f"Not measured: {g['error']}")
        else:
            lines.append(f"{g['scene']}, fraction {g['fraction']}, device {g['device']} "
                         f"({g['device_name']}, torch {g['torch']}): scoring {g['torch_scoring_s']} s "
                         f"({_torch_rate(g)}) against Numba "
                         f"{g['numba_scoring_s']} s; {100 * g['decision_agreement']:.2f} % identical "
                         f"decisions, identical top 5: {g['top5_identical']}.")
    if "torch_gpu" in results:
        g = results["torch_gpu"]
        lines += ["", "## torch backend on a GPU", "",
                  f"{g['date']}, {g['machine']}; {g['scene']}, {g['example']}. Command: "
                  f"`{g['command']}`. Each lease is one machine; compare rows of one lease "
                  "only. " + " ".join(f"Lease {k}: {v}." for k, v in g["leases"].items()), "",
                  "| lease | fraction | candidates | torch path | deciding s | candidates/s | "
                  "queries sent to the CPU's cKDTree | identical decisions and top 5 | Numba on "
                  "the same machine (threads): deciding s, candidates/s |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for x in g["rows"]:
            tq = "" if x["tree_queries"] is None else f"{x['tree_queries']:,}"
            lines.append(f"| {x['lease']} | {x['fraction']} | {x['candidates']:,} | "
                         f"{x['variant']} | {x['scoring_s']} | **{x['candidates_per_s']:,}** | "
                         f"{tq} | {x['identical_decisions'] and x['identical_top5']} | "
                         f"{x['numba_scoring_s']} s ({x['numba_threads']}), "
                         f"{x['candidates'] / x['numba_scoring_s']:,.0f} |")
        lines += ["", GPU_NOTES]
    # the targets, read off the figures above
    k5 = next(d for d in results["detect"] if d["scene"] == "kitchen5")
    worst_train = max(r["median_s"]["total"] for r in tr)
    lines += ["", "## Against the targets, from this run's figures (2 cores, CPU only)", "",
              "Issue 16's own measures (the placing-bowl example as `itensor evaluate` trains "
              "it, the 8 examples, the protocol) are in the summary above; the rows here are "
              "this run's cases (the paper's bowl with its calibrated S_aff; the many-"
              "descriptor case is no measure of a target: its one is the cheapest).", "",
              "| target | reached | met |", "|---|---|---|",
              f"| training under 2 s median per example | slowest {worst_train:.2f} s | "
              f"{'yes' if worst_train < 2 else 'no'} |",
              f"| 8,000 candidates/s on kitchen5, the paper's bowl, defaults | "
              f"{k5['weight']['candidates_per_s']:.0f} (adaptive order: "
              f"{k5['adaptive']['candidates_per_s']:.0f}) | "
              f"{'yes' if k5['weight']['candidates_per_s'] >= 8000 else 'no'} |",
              f"| >= 99.5 % identical decisions, identical top 5 | "
              f"{100 * k5['reference']['decision_agreement']:.2f} %, top 5 {k5['reference']['top5_identical']} | "
              f"{'yes' if k5['reference']['decision_agreement'] >= 0.995 and k5['reference']['top5_identical'] else 'no'} |"]
    lines.append(f"| 5M-point scene under 2 GB | {b['peak_rss_mb']:.0f} MB | "
                 f"{'yes' if b['peak_rss_mb'] < 2048 else 'no'} |")
    lines += ["", NOTES]
    return "\n".join(lines) + "\n"


GPU_NOTES = """On the H200 the torch path decides exactly as the Numba path (every run above:
identical decisions and top 5; the torch tests pass on CUDA, with both kernels).
**Lease 3 (the Triton kernel):** a level's tile search is one Triton kernel launch per block
of queries (`_triton_nearest.py`: queries sorted by tile, 32 to a work item, each reading its
tile's members 64 at a time and keeping the nearest, float64) instead of `torch.cdist` tile
by tile from a Python loop: 2.7x the candidates/s at 3 % (3.78 s against 10.21 s, same
lease). With the kernel cheap, the queries left to the CPU's cKDTree dominate: at 30 %, one
level sent 34M there (32.5 s); a second level of tiles 4x as large on the device cut that
to 886k (19.9 s), larger blocks (8,192 pairs: fewer launches) to 16.7 s, and three levels
each twice the one before to 12.5 s (`benchmarks/torch_levels.py`, one process). The
committed defaults (Triton on CUDA, 3 levels x2, 8,192 pairs per block) score kitchen5 at
30 % in **12.1 s, 15,155 candidates/s: 1.2x Numba on the same machine's 16 cores** (14.6 s)
and 2.8x Numba on this 2-core machine (5,422, 2026-11-25). Numba's own figure moved from
44.6 s (the lease's first 30 % run) to 14.8 s and 14.6 s in its later runs: compare within
a run. Without Triton (or off CUDA) the cdist loop stays, as before: 3-5x slower than Numba
on the same machine (leases 1-2)."""


#: RESULTS.md below this line is written by the other benchmarks' runs and kept as it is
KEPT = "<!-- the sections below come from the other benchmarks; run.py keeps them -->"
#: RESULTS.md between these lines (the summary of figures from several benchmarks, written
#: by hand from their recorded results) is kept as it is, under the header
SUMMARY = "<!-- summary: written from the benchmarks' recorded results; run.py keeps it -->"
SUMMARY_END = "<!-- end of summary -->"


def write_markdown(path: Path, results: dict) -> None:
    """``markdown(results)`` with the existing file's summary (between :data:`SUMMARY` and
    :data:`SUMMARY_END`), then whatever followed :data:`KEPT` in it."""
    kept = summary = ""
    if path.exists():
        old = path.read_text()
        if KEPT in old:
            kept = old[old.index(KEPT):]
        if SUMMARY in old and SUMMARY_END in old:
            summary = old[old.index(SUMMARY):old.index(SUMMARY_END) + len(SUMMARY_END)]
    path.write_text(markdown(results, summary) + ("\n" + kept if kept else ""))


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--one":
        one(sys.argv[2:])
        return
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller fractions, fewer repeats")
    ap.add_argument("--only", choices=("train", "detect", "sitting", "big", "many", "torch"),
                    default=None)
    ap.add_argument("--sitting-full", action="store_true",
                    help="the sitting case also runs the whole detection at the defaults and with "
                         "the grid search alone (about 45 min)")
    ap.add_argument("--out", default=str(HERE / "RESULTS"))
    ap.add_argument("--render", action="store_true",
                    help="only rewrite OUT.md from the figures recorded in OUT.json")
    args = ap.parse_args()
    if args.render:
        write_markdown(Path(args.out + ".md"), json.loads(Path(args.out + ".json").read_text()))
        return
    fraction = 0.05 if args.quick else 0.30
    repeats = 3 if args.quick else 5
    results = {"date": datetime.datetime.now().isoformat(timespec="seconds"),
               "machine": f"{platform.node()} {platform.machine()}, {os.cpu_count()} cores, "
                          f"Python {platform.python_version()}",
               "command": " ".join(["python", "benchmarks/run.py", *sys.argv[1:]])}
    if args.only in (None, "train"):
        results["train"] = run_case(["train", str(repeats)])
    if args.only in (None, "detect"):
        results["detect"] = [run_case(["detect", name, str(fraction), "1000"])
                             for name in ("kitchen5", largest_scene())]
    if args.only in (None, "sitting"):
        results["sitting"] = run_case(["sitting", largest_scene(), str(fraction),
                                       "300" if args.quick else "1500", "3",
                                       "1" if args.sitting_full else "0"])
    if args.only in (None, "big"):
        results["big"] = run_case(["big", "5000000", "0.01" if args.quick else "0.30"])
    if args.only in (None, "many"):
        results["many"] = run_case(["many", "kitchen5", "0.002" if args.quick else "0.005",
                                    "1,8" if args.quick else "1,8,32,84"])
    if args.only in (None, "torch"):
        results["torch"] = run_case(["torch", "kitchen5", str(fraction)])
    previous = Path(args.out + ".json")
    if args.only is not None and previous.exists():   # update one group of an earlier run
        merged = json.loads(previous.read_text())
        merged.update({k: v for k, v in results.items() if k not in ("date", "command")})
        merged.setdefault("updates", []).append(f"{results['date']}: {results['command']}")
        results = merged
    previous.write_text(json.dumps(results, indent=1, default=float))
    if all(k in results for k in ("train", "detect", "big", "many")):
        write_markdown(Path(args.out + ".md"), results)
    print(json.dumps(results, indent=1, default=float))


if __name__ == "__main__":
    main()
