"""Speed and exactness of the Numba neighbour cache against the grid search.

Usage::

    python benchmarks/kernel_speed.py                   # 3000 candidates per case, 3 rounds
    python benchmarks/kernel_speed.py --candidates 0    # every candidate (minutes)
    python benchmarks/kernel_speed.py --only kitchen5 --rounds 5

Cases: kitchen5 with ``placing-bowl`` and living-room4 with ``sitting-human`` (descriptors
fitted at 1 cm, scenes sampled at 1 cm, seed 0), test points drawn as
:func:`interaction_tensor.detection.search.detect` draws them (``--fraction``, default 5 %), normal
filter applied, 8 orientations per candidate; ``--candidates`` keeps a seeded subset.

Kernels, run interleaved (``--rounds`` rounds, Numba compiled beforehand):

* ``reference``: :func:`interaction_tensor.engine.numba_backend.score_jobs` without the cache (the grid
  shell search per keypoint, the kernel before the cache, bit for bit);
* ``cache``: the same with ``cache=True``, from an empty cache each round ("cold", what one
  detection pays) and once more on the filled cache ("warm", what a second search of the
  same scene pays).

Every output (score, accepted, decided_at, comparisons) of every pair must be identical to
the reference's: for the timed configuration (paper criterion, surface vectors, early
exit) and, on ``--check`` candidates, for both criteria x both vector modes x early exit
on / off. Prints candidates per second per kernel, the median ratio to the reference, peak
memory and the cache's size. The machine may be shared: only ratios of interleaved runs mean
much.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DATA = Path(os.environ.get("ITENSOR_SHARED_DATA", ROOT.parent / "shared" / "data"))
CASES = {"kitchen5": "placing-bowl", "living-room4": "sitting-human"}


def build_case(scene_name: str, interaction: str, fraction: float, n_candidates: int, seed: int):
    """(scene, grid, tensor, candidate scene indices) of one case."""
    import interaction_tensor as it
    from interaction_tensor import affordances
    from interaction_tensor.detection.search import _test_points, candidate_mask

    tensor = affordances.build_descriptor(interaction, objects_dir=DATA / "objects",
                                           spacing=0.01)
    scene = it.prepare_scene(it.load_geometry(DATA / "scenes" / f"{scene_name}.ply"), 0.01,
                             seed=0)
    settings = it.DetectSettings(sample_fraction=fraction, seed=seed)
    test = _test_points(scene, settings)
    ok = candidate_mask(scene.normals[test], tensor.affordance_normal,
                        settings.normal_tolerance_deg, settings.oriented_normals)
    cand = test[ok]
    if 0 < n_candidates < len(cand):
        rng = np.random.default_rng(seed)
        cand = np.sort(rng.choice(cand, n_candidates, replace=False))
    return scene, scene.grid(), tensor, cand


def make_job(scene, tensor, cand, criterion="paper", vectors=None, early_exit=True):
    """The ScoreJob of candidates ``cand`` x 8 orientations (points as coordinates)."""
    import interaction_tensor as it
    from interaction_tensor.detection.search import resolve_threshold
    from interaction_tensor.engine.scoring import ScoreJob

    settings = it.DetectSettings(criterion=criterion, early_exit=early_exit)
    n_o = settings.n_orientations
    pp, po = np.repeat(cand, n_o), np.tile(np.arange(n_o), len(cand))
    return ScoreJob(scene.points[pp], po, tensor.keypoint_table(settings),
                    resolve_threshold(tensor, settings), vectors or tensor.vectors,
                    scene.spacing, early_exit)


def run_reference(job, grid):
    """The grid search, no cache: (score, accepted, decided_at, comparisons)."""
    from interaction_tensor.engine import numba_backend as kernels

    return kernels.score_jobs([job], grid, cache=False)[0]


def run_cache(job, grid, cold=True):
    from interaction_tensor.engine import numba_backend as kernels

    if cold:
        grid.cache = None
    return kernels.score_jobs([job], grid, cache=True)[0]


def mismatches(ref, got) -> int:
    """Pairs whose outputs differ in any of the four arrays (bit for bit)."""
    bad = np.zeros(len(ref[0]), bool)
    for a, b in zip(ref, got):
        bad |= ~((a == b) | (np.isnan(a) & np.isnan(b)) if a.dtype.kind == "f" else (a == b))
    return int(bad.sum())


def timed(fn, *args):
    t0 = time.perf_counter()
    out = fn(*args)
    return time.perf_counter() - t0, out


def bench_case(name: str, args) -> dict:
    t0 = time.perf_counter()
    scene, grid, tensor, cand = build_case(name, CASES[name], args.fraction, args.candidates,
                                           args.seed)
    print(f"\n== {name} / {CASES[name]}: {len(scene)} points, {len(cand)} candidates "
          f"({8 * len(cand)} pairs), set-up {time.perf_counter() - t0:.0f} s", flush=True)
    # compile everything on a few pairs
    warm = make_job(scene, tensor, cand[:4])
    run_reference(warm, grid), run_cache(warm, grid)

    # exactness over every criterion / vector mode / early-exit combination
    sub = cand[:args.check]
    bad_total, pairs_total = 0, 0
    for criterion in ("paper", "gaussian"):
        for vectors in ("surface", "points"):
            for early in (True, False):
                job = make_job(scene, tensor, sub, criterion, vectors, early)
                ref = run_reference(job, grid)
                for label, got in (("cache", run_cache(job, grid)),):
                    bad = mismatches(ref, got)
                    bad_total += bad
                    pairs_total += len(job.points)
                    if bad:
                        print(f"  MISMATCH {label} {criterion}/{vectors}/early={early}: {bad}")
    print(f"  exactness: {pairs_total} pair results over 2 criteria x 2 vector modes x early "
          f"exit on/off, {bad_total} differ")

    # timing, interleaved
    job = make_job(scene, tensor, cand)
    times = {"reference": [], "cache cold": [], "cache warm": []}
    bad = 0
    for r in range(args.rounds):
        dt, ref = timed(run_reference, job, grid)
        times["reference"].append(dt)
        dt, got = timed(run_cache, job, grid, True)
        times["cache cold"].append(dt)
        bad += mismatches(ref, got)
        dt, got = timed(run_cache, job, grid, False)
        times["cache warm"].append(dt)
        bad += mismatches(ref, got)
        print(f"  round {r + 1}: " + ", ".join(f"{k} {v[-1]:.2f} s" for k, v in times.items()),
              flush=True)
    cache = grid.cache
    row = {"case": name, "candidates": len(cand), "pairs": len(job.points),
           "mean_comparisons": float(ref[3].mean()), "timed_mismatches": bad,
           "cache_mib": cache.nbytes / 2**20 if cache is not None else 0.0}
    print(f"  timed runs: {bad} pair results differ from the reference; "
          f"{row['mean_comparisons']:.0f} comparisons per pair")
    base = times["reference"]
    for k, v in times.items():
        ratio = statistics.median(b / t for b, t in zip(base, v))
        cps = len(cand) / statistics.median(v)
        row[k] = {"candidates_per_s": cps, "median_ratio": ratio}
        print(f"  {k:>10}: {cps:8.0f} candidates/s   x{ratio:.2f} vs reference")
    print(f"  cache size {row['cache_mib']:.0f} MiB; peak RSS "
          f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB")
    grid.cache = None
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", choices=sorted(CASES), action="append")
    ap.add_argument("--fraction", type=float, default=0.05, help="test point fraction")
    ap.add_argument("--candidates", type=int, default=3000,
                    help="seeded subset of the candidates (0: all)")
    ap.add_argument("--check", type=int, default=300,
                    help="candidates checked over every criterion / mode combination")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    import numba

    print(f"numba {numba.__version__}, {numba.get_num_threads()} threads, "
          f"{os.cpu_count()} CPUs, fraction {args.fraction}")
    rows = [bench_case(name, args) for name in (args.only or list(CASES))]
    ok = all(r["timed_mismatches"] == 0 for r in rows)
    print("\nall outputs identical to the reference" if ok else "\nOUTPUTS DIFFER")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
