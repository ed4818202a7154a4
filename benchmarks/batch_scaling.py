"""itensor batch: wall time on 1 and 2 Dask workers (and in this process) for the same work.

    python benchmarks/batch_scaling.py [--scenes office-desk1 office-desk5 ...]
        [--examples placing-bowl filling-mug] [--sample-fraction 0.3] [--workers 0 1 2]

Builds the examples' descriptors (1 cm), then runs ``itensor batch`` (no pictures) over the
published scenes once per worker count into a fresh directory, and checks that every run wrote
identical predictions (same scores and positions). Prints a Markdown table: workers, seconds,
(scene, descriptor) pairs per minute, (point, orientation) pairs decided per second, speed-up
over 1 worker. Needs ../shared/data and ``pip install "interaction-tensor[dask]"``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import tempfile
import time
from pathlib import Path

import interaction_tensor as it
from interaction_tensor import affordances

ROOT = Path(__file__).resolve().parents[1]
SCENES = ("office-desk1", "office-desk5", "office-desk6", "living-room2", "living-room1",
          "living-room5", "kitchen3", "kitchen4")


def _predictions(out: Path) -> dict:
    return {str(p.parent.relative_to(out)): [(q["score"], q["position"])
                                             for q in json.loads(p.read_text())["predictions"]]
            for p in sorted(out.glob("*/*/predictions.json"))}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", nargs="+", default=list(SCENES))
    ap.add_argument("--examples", nargs="+", default=["placing-bowl", "filling-mug"])
    ap.add_argument("--sample-fraction", type=float, default=0.3)
    ap.add_argument("--workers", nargs="+", type=int, default=[0, 1, 2])
    args = ap.parse_args()
    data = Path(os.environ.get("ITENSOR_SHARED_DATA", ROOT.parent / "shared" / "data"))
    work = Path(tempfile.mkdtemp(prefix="itensor-batch-bench-"))
    descs = []
    for name in args.examples:
        descs.append(affordances.build_descriptor(name, seed=0, spacing=0.01)
                     .save(work / f"{name}.npz"))
    scenes = [data / "scenes" / f"{s}.ply" for s in args.scenes]
    print(f"{len(scenes)} scenes x {len(descs)} descriptors, sample fraction "
          f"{args.sample_fraction}, {platform.system()} {os.cpu_count()} cores")
    rows, reference = [], None
    for n in args.workers:
        out = work / f"out-{n}"
        t0 = time.perf_counter()
        res = it.batch(scenes, descs, out, workers=n, render=False,
                       sample_fraction=args.sample_fraction)
        seconds = time.perf_counter() - t0
        assert res.failed == 0, res.rows
        preds = _predictions(out)
        if reference is None:
            reference = preds
        identical = preds == reference
        pairs = sum(r["pairs"] for r in res.rows)          # decided (tests and score)
        rows.append((n, seconds, len(res.rows), pairs, identical))
    one = next((s for n, s, *_ in rows if n == 1), None)
    print("| workers | seconds | results per minute | pairs decided per second | "
          "speed-up over 1 worker | identical predictions |")
    print("|---|---:|---:|---:|---:|---|")
    for n, s, k, pairs, same in rows:
        label = "0 (this process, no Dask)" if n == 0 else str(n)
        print(f"| {label} | {s:.1f} | {60 * k / s:.1f} | {pairs / s:.0f} | "
              f"{one / s if one else float('nan'):.2f} | {'yes' if same else 'NO'} |")
    shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
