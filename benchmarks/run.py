"""Speed and memory benchmarks of training and detection, against the exact reference.

Usage::

    python benchmarks/run.py                 # everything, writes benchmarks/RESULTS.md/.json
    python benchmarks/run.py --quick         # smaller sample fractions (minutes)
    python benchmarks/run.py --only train    # one group: train, detect, reference, big

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
        from interaction_tensor.examples import interactions
    except ImportError:
        return out
    for name in interactions.names():
        ex = interactions.build(name)
        out.append((name, ex.query, ex.scene_object, interactions.train_settings(name)))
    return out


def _scaled_descriptors(count: int) -> list:
    """``count`` descriptors: the 8 examples, then the same examples scaled as a whole
    (query and scene-object about the query's base) by 0.8 ... 1.3."""
    import interaction_tensor as it
    from interaction_tensor.examples import interactions

    sizes = [1.0, 0.8, 0.85, 0.9, 0.95, 1.05, 1.1, 1.15, 1.2, 1.25, 1.3]
    tensors = []
    for size in sizes:
        for name in interactions.names():
            if len(tensors) == count:
                return tensors
            ex = interactions.build(name)
            base = ex.query.vertices.min(axis=0)
            q = it.Geometry((ex.query.vertices - base) * size + base, ex.query.faces)
            s = it.Geometry((ex.scene_object.vertices - base) * size + base,
                            ex.scene_object.faces, ex.scene_object.normals)
            tensors.append(it.InteractionTensor.fit(q, s, f"{name}@{size}",
                                                    interactions.train_settings(name)))
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
                     "scoring_s": res[0].stats["seconds"]["scoring"],
                     "accepted": [int(r.pairs.accepted.sum()) for r in res]})
    for r in rows:
        r["cost_vs_one"] = r["scoring_s"] / rows[0]["scoring_s"]
    return {"scene": scene_name, "fraction": fraction,
            "test_points": int(round(fraction * len(scene))), "rows": rows}


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
    elif kind == "big":
        out = case_big(int(argv[1]), float(argv[2]))
    elif kind == "many":
        out = case_many(argv[1], float(argv[2]), [int(v) for v in argv[3].split(",")])
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


def markdown(results: dict) -> str:
    lines = [f"# Benchmark results", "",
             f"- date: {results['date']}", f"- machine: {results['machine']}",
             f"- command: `{results['command']}`"]
    lines += [f"- then: `{u}`" for u in results.get("updates", [])]
    lines += [""]
    lines += ["## Training (median of runs, seconds)", "",
              "| example | samples | bisector points | sampling | bisector | keypoints | calibration | total |",
              "|---|---|---|---|---|---|---|---|"]
    for r in results["train"]["train"]:
        m = r["median_s"]
        lines.append(f"| {r['example']} | {r['samples']} | {r['bisector_points']} | "
                     f"{m['sampling']:.3f} | {m['bisector']:.3f} | {m['keypoints']:.3f} | "
                     f"{m['calibration']:.3f} | **{m['total']:.3f}** |")
    lines += ["", f"Peak memory of the training process: {results['train']['peak_rss_mb']:.0f} MB", ""]
    lines += ["## Detection (placing-bowl, paper criterion, weighted keypoints, Numba backend)", "",
              "| scene | points | fraction | test points | candidates | scoring s | test points/s | candidates/s | keypoint evals/s | comparisons/decision | peak MB |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for d in results["detect"]:
        lines.append(f"| {d['scene']} | {d['scene_points']} | {d['sample_fraction']} | "
                     f"{d['test_points']} | {d['candidates']} | {d['scoring_s']:.1f} | "
                     f"**{d['test_points_per_s']:.0f}** | {d['candidates_per_s']:.0f} | "
                     f"{d['keypoint_evaluations_per_s'] / 1e6:.2f} M | "
                     f"{d['mean_comparisons_per_decision']:.0f} | {d['peak_rss_mb']:.0f} |")
    lines += ["", "### Against the exact reference (same candidates, all 512 keypoints, batched cKDTree, no early exit)", "",
              "| scene | candidates | reference cand/s | fast cand/s | speed-up | identical decisions | identical top 5 |",
              "|---|---|---|---|---|---|---|"]
    for d in results["detect"]:
        r = d["reference"]
        lines.append(f"| {d['scene']} | {r['candidates']} | {r['candidates_per_s']:.0f} | "
                     f"{r['candidates'] / r['fast_seconds_same_subset']:.0f} | "
                     f"{r['speedup']:.1f}x | {100 * r['decision_agreement']:.2f} % | "
                     f"{r['top5_identical']} |")
    if "big" in results:
        b = results["big"]
        lines += ["", "## A 5-million-point scene", "",
                  f"kitchen5 sampled at {b['spacing'] * 1000:.1f} mm: {b['scene_points']} points, "
                  f"fraction {b['sample_fraction']}, {b['candidates']} candidates, "
                  f"{b['seconds']} s, peak memory **{b['peak_rss_mb']:.0f} MB**."]
    if "many" in results:
        m = results["many"]
        lines += ["", f"## Many affordances in one pass ({m['scene']}, {m['test_points']} test "
                      "points; shared test points and scene index, exact)", "",
                  "| descriptors | scoring s | cost vs one |", "|---|---|---|"]
        for r in m["rows"]:
            lines.append(f"| {r['descriptors']} | {r['scoring_s']:.1f} | {r['cost_vs_one']:.1f}x |")
    return "\n".join(lines) + "\n"


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--one":
        one(sys.argv[2:])
        return
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller fractions, fewer repeats")
    ap.add_argument("--only", choices=("train", "detect", "big", "many"), default=None)
    ap.add_argument("--out", default=str(HERE / "RESULTS"))
    args = ap.parse_args()
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
    if args.only in (None, "big"):
        results["big"] = run_case(["big", "5000000", "0.01" if args.quick else "0.05"])
    if args.only in (None, "many"):
        results["many"] = run_case(["many", "kitchen5", "0.002" if args.quick else "0.005",
                                    "1,8" if args.quick else "1,8,32,84"])
    previous = Path(args.out + ".json")
    if args.only is not None and previous.exists():   # update one group of an earlier run
        merged = json.loads(previous.read_text())
        merged.update({k: v for k, v in results.items() if k not in ("date", "command")})
        merged.setdefault("updates", []).append(f"{results['date']}: {results['command']}")
        results = merged
    previous.write_text(json.dumps(results, indent=1, default=float))
    if all(k in results for k in ("train", "detect", "big", "many")):
        Path(args.out + ".md").write_text(markdown(results))
    print(json.dumps(results, indent=1, default=float))


if __name__ == "__main__":
    main()
