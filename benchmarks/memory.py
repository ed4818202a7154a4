"""Peak memory of ``itensor detect`` at its defaults, per scene point.

    python benchmarks/memory.py [--points 500000 2000000] [--example placing-bowl]
        [--sample-fraction 0.3]

For each size, a seeded procedural room cloud (floor, four walls, a table and a stool top;
1 mm noise; no normals, so they are estimated as for a real scan) is written as a binary
PLY, and ``itensor detect CLOUD EXAMPLE.npz -o OUT`` runs in a fresh process at the
defaults. The peak resident set (``getrusage`` of the child) is reported whole and per scene
point, beside the resident set of a process that only imports the library and loads its
Numba kernels (the fixed cost every run pays). Issue 15's target: at most 250 bytes per scene
point (a 2 M-point cloud under 0.5 GB). Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def room_cloud(n: int, seed: int = 0) -> np.ndarray:
    """(n, 3) points on a 6 x 5 x 2.5 m room's floor and walls, a table and a stool top."""
    rng = np.random.default_rng(seed)
    parts = [((0, 6), (0, 5), (0, 0), 0.30), ((0, 6), (0, 0), (0, 2.5), 0.15),
             ((0, 6), (5, 5), (0, 2.5), 0.15), ((0, 0), (0, 5), (0, 2.5), 0.12),
             ((6, 6), (0, 5), (0, 2.5), 0.12), ((2, 3.2), (2, 2.8), (0.75, 0.75), 0.10),
             ((1, 1.5), (1, 1.5), (0.45, 0.45), 0.06)]
    counts = [int(n * p[3]) for p in parts]
    counts[0] += n - sum(counts)
    out = []
    for (x, y, z, _), c in zip(parts, counts):
        u = rng.random((c, 3))
        out.append(np.column_stack([x[0] + (x[1] - x[0]) * u[:, 0], y[0] + (y[1] - y[0]) * u[:, 1],
                                    z[0] + (z[1] - z[0]) * u[:, 2]]))
    pts = np.concatenate(out)
    return pts + rng.normal(scale=0.001, size=pts.shape)


def child_peak_mb(cmd: list) -> tuple[float, float]:
    """(peak resident MB, seconds) of one command run as a child process (its own rusage,
    from ``os.wait4``)."""
    t = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode:
        raise SystemExit(f"{' '.join(cmd)} exited {proc.returncode}")
    return usage.ru_maxrss / 1024, time.perf_counter() - t


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--points", type=int, nargs="+", default=[2_000_000])
    ap.add_argument("--example", default="placing-bowl")
    ap.add_argument("--sample-fraction", type=float, default=0.3)
    args = ap.parse_args()
    from interaction_tensor.geometry.files import write_ply_points

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        subprocess.run([sys.executable, "-m", "interaction_tensor.cli.main", "examples", "build",
                        "-o", str(tmp / "ex"), "--examples", args.example, "-q"], check=True)
        base, _ = child_peak_mb([sys.executable, "-c",
                                 "import interaction_tensor, interaction_tensor.cli.main; "
                                 "from interaction_tensor.engine import numba_backend as kernels; kernels._compile()"])
        for n in sorted(args.points):
            cloud = tmp / f"room{n}.ply"
            write_ply_points(cloud, room_cloud(n))
            peak, seconds = child_peak_mb(
                [sys.executable, "-m", "interaction_tensor.cli.main", "detect", str(cloud),
                 str(tmp / "ex" / f"{args.example}.npz"), "-o", str(tmp / f"out{n}"), "-q",
                 "--sample-fraction", str(args.sample_fraction)])
            rows.append((n, peak, peak * 2 ** 20 / n, (peak - base) * 2 ** 20 / n, seconds))
    print(f"`python benchmarks/memory.py --points {' '.join(map(str, args.points))} "
          f"--example {args.example} --sample-fraction {args.sample_fraction}` on "
          f"{platform.node()} ({platform.machine()}), {time.strftime('%Y-%m-%d')}; imports and "
          f"kernels alone: {base:.0f} MB")
    print()
    print("| scene points | peak RSS | bytes per point | bytes per point above imports | seconds |")
    print("|---:|---:|---:|---:|---:|")
    for n, peak, bpp, above, s in rows:
        print(f"| {n:,} | {peak:,.0f} MB | {bpp:,.0f} | {above:,.0f} | {s:,.0f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
