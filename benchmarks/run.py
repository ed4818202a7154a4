"""Speed and memory of training and detection, against the exact reference in the same run.

    python benchmarks/run.py                     # every case below; about 25 minutes on 2 cores
    python benchmarks/run.py --only detect many  # some of them
    python benchmarks/run.py --protocol          # also the paper's protocol (14 scenes x 8)
    python benchmarks/run.py --baseline REV      # and the same cases on git revision REV
    python benchmarks/run.py --only detect --repeat 3   # each detection case's median of 3

Writes every figure to ``benchmarks/results.json`` and the summary drawn from it,
``benchmarks/RESULTS.md``, overwriting both: each figure with its command, the machine and,
where there is one, the ratio to the reference measured in the same run. A run of some cases
(``--only``) keeps the other cases' figures of their last run, so both files always hold
every case. Each case runs in a
process of its own, after the kernels are compiled (except the first-run case, which measures
compilation). The data come from ../shared/data (or $ITENSOR_SHARED_DATA).

With ``--baseline REV`` the ``detect``, ``many``, ``prepare`` and ``protocol`` cases run a
second time on the library of git revision REV (its ``src/`` exported into
``results/benchmarks/baseline/``, its kernels compiled there first), one after the other on
the same machine: each figure then has its ratio to REV's, and whether the two made the same
decisions (the same accepted pairs and the same top k). With ``--repeat N`` the ``detect``
cases run N times (alternating with the baseline's, so that a slow spell of the machine
falls on both): each case reports its run of median seconds, with the range of the N.

Cases:

- ``train``: seconds to train each of the paper's 8 examples and the demo's bowl (median of 3);
- ``detect``: detection at the defaults (30 % test points) of the demo's bowl in the demo
  room, the paper's bowl in kitchen5 and the seated person in living-room4 (the largest
  scene): seconds, candidates per second and the split between placement tests and scoring;
  then, on 1,000 of its candidates, the Numba backend against the exact NumPy reference
  (every keypoint, a cKDTree): the same decisions and the ratio of candidates per second;
- ``many``: the 8 examples in one pass over kitchen5 against the slowest of them alone;
- ``demo``: ``itensor demo`` (its picture included) with an empty Numba cache (a fresh
  install) and again;
- ``memory``: peak resident memory of ``itensor detect`` on a 2 M-point cloud without normals;
- ``density``: the places of a mesh scene against those of the same scene as clouds from 0.5
  to 3 times the descriptor's spacing, with and without normals (the demo room and bowl; a
  YCB mug trained on a plain box, in living-room2, 10 % test points);
- ``tests``: each placement test alone on 20,000 candidates of a seated person and a rider in
  living-room4, the paper's bowl in kitchen5 and the hanger in kitchen1: microseconds a pair
  and the share of pairs it rejects, and the cost of the tests in the library's order
  (``placement.checks.TEST_ORDER``) against the cheapest order of all;
- ``prepare``: seconds per million points to prepare living-room4 (a mesh: sampling, closed
  parts, the grid and its tables) and a 2 M-point cloud without normals, and to write a
  1.5 M-point scene's result (predictions, accepted pairs, heat map, glTF and picture);
- ``protocol`` (with ``--protocol``): detection of the paper's 8 examples on its 14 scenes.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DATA = Path(os.environ.get("ITENSOR_SHARED_DATA", ROOT.parent / "shared" / "data"))
OUT = ROOT / "results" / "benchmarks"
CASES = ("train", "detect", "many", "tests", "prepare", "demo", "memory", "density")
#: The cases ``--baseline`` runs on the baseline too
BASELINE_CASES = ("detect", "many", "prepare", "protocol")
#: (label, scene, example, sample fraction) of the detection cases
DETECT = (("demo room, the demo's bowl", "demo", "demo", 0.3),
          ("kitchen5, placing-bowl", "kitchen5", "placing-bowl", 0.3),
          ("living-room4, sitting-human", "living-room4", "sitting-human", 0.3))
#: candidates compared with the exact reference
REFERENCE_CANDIDATES = 1000


# --------------------------------------------------------------------------- the cases
def _descriptor(example: str):
    import interaction_tensor as it
    from interaction_tensor import affordances
    from interaction_tensor.examples import demo

    if example == "demo":
        ex = demo.build()
        return it.train(ex.query, ex.scene_object, "placing-bowl", spacing=demo.DEMO_SPACING)
    return affordances.build_descriptor(example, DATA / "objects")


def _scene(name: str, spacing: float):
    import interaction_tensor as it
    from interaction_tensor.examples import demo

    source = demo.build().scene if name == "demo" else DATA / "scenes" / f"{name}.ply"
    return it.load_scene(source, spacing)


def case_train() -> dict:
    from interaction_tensor import affordances
    from interaction_tensor.descriptor.tensor import InteractionTensor
    from interaction_tensor.examples import demo

    out = {}
    ex = demo.build()
    jobs = [("demo bowl", ex.query, ex.scene_object, None)]
    for name in affordances.example_names():
        e = affordances.build(name, DATA / "objects")
        jobs.append((name, e.query, e.scene_object, e))
    for name, q, s, e in jobs:
        seconds = []
        for _ in range(3):
            t = time.perf_counter()
            if e is None:
                InteractionTensor.fit(q, s, name)
            else:
                affordances.build_descriptor(name, example=e)
            seconds.append(time.perf_counter() - t)
        out[name] = round(statistics.median(seconds), 3)
    return out


def case_detect(scene_name: str, example: str, fraction: float) -> dict:
    import interaction_tensor as it
    from interaction_tensor.detection.search import Engine, detect

    tensor = _descriptor(example)
    scene = _scene(scene_name, tensor.scene_spacing)
    settings = it.DetectSettings(sample_fraction=fraction)
    t = time.perf_counter()
    det = detect(scene, tensor, settings)
    seconds = time.perf_counter() - t
    st = det.stats
    out = {"scene_points": len(scene), "candidates": st["candidates_after_normal_filter"],
           "pairs": st["pairs"], "seconds": round(seconds, 2), "decisions": _digest(det),
           "placement_tests_s": st["seconds"]["placement_tests"],
           "scoring_s": st["scoring_seconds"], "collision_s": st["seconds"]["collision"],
           "candidates_per_s": round(st["candidates_per_second"] or 0, 1),
           "predictions": len(det.predictions)}
    # the same candidates' subset on the default backend and on the exact reference
    rng = np.random.default_rng(0)
    sub = np.sort(rng.choice(det.candidate_indices,
                             min(REFERENCE_CANDIDATES, len(det.candidate_indices)),
                             replace=False))
    runs = {}
    for backend, engine in (("numba", Engine()), ("numpy", Engine(early_exit=False))):
        t = time.perf_counter()
        runs[backend] = detect(scene, tensor, it.DetectSettings(backend=backend),
                               test_indices=sub, engine=engine)
        runs[backend].stats["wall"] = time.perf_counter() - t
    a, b = runs["numba"], runs["numpy"]
    same = bool(np.array_equal(a.pairs.accepted, b.pairs.accepted)
                and np.allclose(a.pairs.score[a.pairs.accepted],
                                b.pairs.score[b.pairs.accepted], atol=1e-9))
    out["reference"] = {
        "candidates": int(len(sub)), "identical_decisions": same,
        "numba_candidates_per_s": round(len(sub) / a.stats["deciding_seconds"], 1),
        "reference_candidates_per_s": round(len(sub) / b.stats["deciding_seconds"], 1),
        "ratio": round(b.stats["deciding_seconds"] / a.stats["deciding_seconds"], 2)}
    return out


def _digest(det) -> str:
    """A fingerprint of a detection's decisions: its accepted (point, orientation) pairs and
    its top k (pose and score), to tell whether two runs decided alike."""
    import hashlib

    h = hashlib.sha1()
    acc = np.flatnonzero(det.pairs.accepted)
    h.update(np.asarray(det.pair_point, np.int64)[acc].tobytes())
    h.update(np.asarray(det.pair_orientation, np.int64)[acc].tobytes())
    for p in det.predictions:
        h.update(np.round(np.asarray(p.pose, float), 9).tobytes())
        h.update(np.float64(round(p.score, 12)).tobytes())
    return h.hexdigest()[:16]


def case_many(scene_name: str, fraction: float) -> dict:
    import interaction_tensor as it
    from interaction_tensor import affordances

    tensors = [affordances.build_descriptor(n, DATA / "objects")
               for n in affordances.example_names()]
    scene = _scene(scene_name, tensors[0].scene_spacing)
    settings = it.DetectSettings(sample_fraction=fraction)
    alone, digests = {}, []
    for t_ in tensors:
        t = time.perf_counter()
        digests.append(_digest(it.detect_many(scene, [t_], settings)[0]))
        alone[t_.affordance] = round(time.perf_counter() - t, 2)
    t = time.perf_counter()
    dets = it.detect_many(scene, tensors, settings)
    together = time.perf_counter() - t
    slowest = max(alone.values())
    return {"alone_s": alone, "one_pass_s": round(together, 2), "slowest_alone_s": slowest,
            "ratio_to_slowest": round(together / slowest, 2),
            "ratio_to_sum": round(together / sum(alone.values()), 2),
            "one_pass_as_alone": [_digest(d) for d in dets] == digests,
            "decisions": "-".join(digests)}


#: (label, scene, example) of the tests case
TESTS = (("living-room4, sitting-human", "living-room4", "sitting-human"),
         ("living-room4, riding-human", "living-room4", "riding-human"),
         ("kitchen5, placing-bowl", "kitchen5", "placing-bowl"),
         ("kitchen1, hanging-hanger", "kitchen1", "hanging-hanger"))
TEST_CANDIDATES = 20_000


def case_tests(scene_name: str, example: str) -> dict:
    """Each placement test alone on the pairs of :data:`TEST_CANDIDATES` candidates: us a
    pair and the share rejected; the tests' cost in ``TEST_ORDER`` and in the cheapest
    order of all (each test on the pairs that passed those before it)."""
    import itertools

    import interaction_tensor as it
    from interaction_tensor.detection.search import candidates
    from interaction_tensor.placement import checks
    from interaction_tensor.settings import PLACEMENT_TESTS

    tensor = _descriptor(example)
    scene = _scene(scene_name, tensor.scene_spacing)
    settings = it.DetectSettings().for_scene(scene)
    grid = scene.grid()
    grid.free                                         # the scene's tables, built once
    scene.columns().table()
    scene.ground_level(scene.points[:1], 1.0)
    cand = candidates(scene, tensor, settings)
    cand = np.sort(np.random.default_rng(0).choice(cand, min(TEST_CANDIDATES, len(cand)),
                                                   replace=False))
    n_o = settings.n_orientations
    at = scene.points[np.repeat(cand, n_o)]
    orient = np.tile(np.arange(n_o), len(cand))
    cost, fails = {}, {}
    for name in checks.TEST_ORDER:
        only = it.DetectSettings(skip_tests=tuple(t for t in PLACEMENT_TESTS if t != name))
        t = time.perf_counter()
        outcome = checks.check_placements(at, orient, tensor, only, scene, grid)[1]
        seconds = time.perf_counter() - t
        if (outcome != checks.PLACED).any() or seconds > 1e-3:
            cost[name], fails[name] = seconds / len(at), outcome != checks.PLACED

    def total(order):
        alive, c = np.ones(len(at), bool), 0.0
        for name in order:
            c += alive.sum() * cost[name]
            alive &= ~fails[name]
        return c
    used = [n for n in checks.TEST_ORDER if n in cost]
    best = min(itertools.permutations(used), key=total)
    return {"pairs": int(len(at)),
            "tests": {n: {"us_per_pair": round(1e6 * cost[n], 2),
                          "rejects": round(float(fails[n].mean()), 3)} for n in used},
            "order_s": round(total(used), 3), "best_order": list(best),
            "best_order_s": round(total(best), 3)}


def case_prepare() -> dict:
    """Seconds per million points to prepare a mesh scene and a cloud without normals, and
    to write a 1.5 M-point scene's result with its picture."""
    import interaction_tensor as it
    from interaction_tensor.geometry.files import write_ply_points

    out = {}
    t = time.perf_counter()
    scene = _scene("living-room4", 0.01)
    seconds = time.perf_counter() - t
    t = time.perf_counter()
    grid = scene.grid()
    getattr(grid, "free", None)                       # the tables, where the library has them
    if hasattr(scene, "columns"):
        scene.columns().table()
    tables = time.perf_counter() - t
    out["mesh"] = {"points": len(scene), "seconds": round(seconds, 2),
                   "tables_s": round(tables, 2),
                   "s_per_million": round((seconds + tables) / len(scene) * 1e6, 2)}
    with tempfile.TemporaryDirectory() as tmp:
        cloud = Path(tmp) / "room.ply"
        write_ply_points(cloud, room_cloud(2_000_000))
        t = time.perf_counter()
        c = it.load_scene(cloud, 0.01)
        seconds = time.perf_counter() - t
        out["cloud"] = {"points": len(c), "seconds": round(seconds, 2),
                        "s_per_million": round(seconds / len(c) * 1e6, 2)}
        del c
        big = _scene("kitchen5", 0.01)
        det = it.detect(big, _descriptor("placing-bowl"), sample_fraction=0.01)
        t = time.perf_counter()
        det.save(Path(tmp) / "out")
        out["write"] = {"points": len(big), "seconds": round(time.perf_counter() - t, 2)}
    return out


def _child(cmd: list, env=None) -> tuple[float, float]:
    """(peak resident MB, seconds) of one command run as a child process."""
    t = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, env=env)
    _, status, usage = os.wait4(proc.pid, 0)
    if os.waitstatus_to_exitcode(status):
        raise SystemExit(f"{' '.join(map(str, cmd))} failed")
    return usage.ru_maxrss / 1024, time.perf_counter() - t


def case_demo() -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=str(Path(tmp) / "numba"))
        cmd = [sys.executable, "-m", "interaction_tensor", "demo", "-q", "-o"]
        peak1, first = _child(cmd + [str(Path(tmp) / "a")], env)
        peak2, again = _child(cmd + [str(Path(tmp) / "b")], env)
    return {"first_run_s": round(first, 1), "again_s": round(again, 1),
            "peak_mb": round(max(peak1, peak2))}


def room_cloud(n: int, seed: int = 0) -> np.ndarray:
    """(n, 3) points on a 6 x 5 x 2.5 m room's floor and walls, a table and a stool top, with
    1 mm of noise."""
    rng = np.random.default_rng(seed)
    parts = [((0, 6), (0, 5), (0, 0), 0.30), ((0, 6), (0, 0), (0, 2.5), 0.15),
             ((0, 6), (5, 5), (0, 2.5), 0.15), ((0, 0), (0, 5), (0, 2.5), 0.12),
             ((6, 6), (0, 5), (0, 2.5), 0.12), ((2, 3.2), (2, 2.8), (0.75, 0.75), 0.10),
             ((1, 1.5), (1, 1.5), (0.45, 0.45), 0.06)]
    counts = [int(n * p[3]) for p in parts]
    counts[0] += n - sum(counts)
    pts = np.concatenate([
        np.column_stack([x[0] + (x[1] - x[0]) * u[:, 0], y[0] + (y[1] - y[0]) * u[:, 1],
                         z[0] + (z[1] - z[0]) * u[:, 2]])
        for (x, y, z, _), c in zip(parts, counts) for u in [rng.random((c, 3))]])
    return pts + rng.normal(scale=0.001, size=pts.shape)


def case_memory(points: int = 2_000_000) -> dict:
    from interaction_tensor.geometry.files import write_ply_points

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        subprocess.run([sys.executable, "-m", "interaction_tensor", "examples", "build", "-o",
                        str(tmp / "ex"), "--examples", "placing-bowl", "-q"], check=True)
        cloud = tmp / "room.ply"
        write_ply_points(cloud, room_cloud(points))
        peak, seconds = _child([sys.executable, "-m", "interaction_tensor", "detect",
                                str(cloud), str(tmp / "ex" / "placing-bowl.npz"), "-o",
                                str(tmp / "out"), "-q"])
    return {"points": points, "peak_mb": round(peak), "bytes_per_point": round(peak * 2**20 /
                                                                              points),
            "seconds": round(seconds, 1)}


#: (label, scene, descriptor, sample fraction, cloud spacings as multiples of the
#: descriptor's) of the density case
DENSITY = (("demo room, the demo's bowl (2 cm)", "demo", "demo", 0.3, (0.5, 1.0, 1.5, 2.0)),
           ("living-room2, a YCB mug trained on a box (1 cm)", "living-room2", "mug", 0.1,
            (0.5, 1.0, 2.0, 3.0)))


def _mug_on_a_box():
    """The README's own-pair case: a YCB mug standing on a plain 1.0 x 0.6 m box top."""
    import interaction_tensor as it
    from interaction_tensor.examples.procedural import box_part, parts_mesh
    from interaction_tensor.geometry.load import load_geometry

    mug = load_geometry(DATA / "objects" / "ycb_mug.ply")
    v = mug.vertices
    v = v - [(v[:, 0].min() + v[:, 0].max()) / 2, (v[:, 1].min() + v[:, 1].max()) / 2,
             v[:, 2].min() - 0.5]
    box = parts_mesh([box_part("box", (0, 0, 0.25), (1.0, 0.6, 0.5))])
    return it.train(it.Geometry(v, mug.faces), box, affordance="placing-mug")


def _same_place(a, b) -> bool:
    """Whether places ``a`` and ``b`` are the same surface: their boxes overlap across and
    their heights differ by at most 4 cm."""
    return bool(np.all(a.lo[:2] <= b.hi[:2] + 0.02) and np.all(b.lo[:2] <= a.hi[:2] + 0.02)
                and abs(a.centroid[2] - b.centroid[2]) <= 0.04)


def case_density(scene_name: str, example: str, fraction: float, factors: list) -> dict:
    import interaction_tensor as it
    from interaction_tensor.examples import demo
    from interaction_tensor.geometry.load import load_geometry
    from interaction_tensor.geometry.sampling import mesh_area, sample_mesh

    tensor = _mug_on_a_box() if example == "mug" else _descriptor(example)
    mesh = (demo.build().scene if scene_name == "demo"
            else load_geometry(DATA / "scenes" / f"{scene_name}.ply"))
    settings = it.DetectSettings(sample_fraction=fraction, seed=0)
    t = time.perf_counter()
    ref = it.detect(mesh, tensor, settings)
    out = {"mesh": {"places": len(ref.places), "seconds": round(time.perf_counter() - t, 1)}}
    for factor in factors:
        spacing = factor * tensor.scene_spacing
        points, normals = sample_mesh(mesh, round(mesh_area(mesh) / spacing ** 2), 1)
        for label, cloud in (("normals", np.column_stack([points, normals])),
                             ("points", points)):
            t = time.perf_counter()
            r = it.detect(cloud, tensor, settings)
            found = sum(any(_same_place(p, q) for q in r.places) for p in ref.places)
            out[f"{100 * spacing:.1f} cm, {label}"] = {
                "points": len(points), "measured_cm": round(100 * r.scene.spacing, 2),
                "places": len(r.places), "mesh_places_found": found,
                "seconds": round(time.perf_counter() - t, 1)}
    return out


def case_protocol(fraction: float = 0.3) -> dict:
    import interaction_tensor as it
    from interaction_tensor import affordances

    tensors = [affordances.build_descriptor(n, DATA / "objects")
               for n in affordances.example_names()]
    per = {}
    t0 = time.perf_counter()
    for path in sorted((DATA / "scenes").glob("*.ply")):
        t = time.perf_counter()
        scene = it.load_scene(path, tensors[0].scene_spacing)
        it.detect_many(scene, tensors, it.DetectSettings(sample_fraction=fraction))
        per[path.stem] = round(time.perf_counter() - t, 1)
    return {"scenes_s": per, "total_min": round((time.perf_counter() - t0) / 60, 1)}


# --------------------------------------------------------------------------- running
def _warm() -> None:
    """Compile the kernels (once per machine: the Numba cache keeps them)."""
    import interaction_tensor as it
    from interaction_tensor.examples import demo

    ex = demo.build()
    tensor = it.train(ex.query, ex.scene_object, "placing-bowl", spacing=demo.DEMO_SPACING)
    it.detect(ex.scene, tensor, sample_fraction=0.3)


def one(argv: list) -> None:
    """Run one case in this process and print its JSON (the parent's child)."""
    name, args = argv[0], json.loads(argv[1])
    if name != "demo":
        _warm()
    fn = {"train": case_train, "detect": case_detect, "many": case_many, "demo": case_demo,
          "memory": case_memory, "protocol": case_protocol, "density": case_density,
          "tests": case_tests, "prepare": case_prepare}[name]
    print(json.dumps(fn(*args)))


def baseline_tree(rev: str) -> Path:
    """The library of git revision ``rev`` exported (``git archive``) into
    ``results/benchmarks/baseline/REV``, once; returns its ``src`` folder."""
    sha = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", rev],
                         capture_output=True, text=True, check=True).stdout.strip()
    where = OUT / "baseline" / sha
    if not (where / "src" / "interaction_tensor").exists():
        where.mkdir(parents=True, exist_ok=True)
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", sha,
                                  "src"], capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", str(where)], input=archive, check=True)
    return where / "src"


def run_case(name: str, *args, library: Path | None = None) -> dict:
    """One case in a child process: on this tree's library, or on ``library`` (a
    :func:`baseline_tree`)."""
    env = dict(os.environ)
    if library is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(library), env.get("PYTHONPATH", "")])
    proc = subprocess.run([sys.executable, __file__, "--one", name, json.dumps(list(args))],
                          capture_output=True, text=True, env=env)
    if proc.returncode:
        raise SystemExit(f"case {name}{args} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def machine() -> str:
    import numba

    return (f"{platform.system()} {platform.machine()}, {os.cpu_count()} cores, Python "
            f"{platform.python_version()}, Numba {numba.__version__} "
            f"({numba.config.NUMBA_NUM_THREADS} threads)")


def median_run(runs: list) -> dict:
    """Of repeated ``detect`` results (label -> figures), each label's run of median seconds
    (the lower of the two middle ones for an even count), with every run's seconds in
    ``seconds_runs``."""
    if len(runs) == 1:
        return runs[0]
    out = {}
    for label in runs[0]:
        ranked = sorted((r[label] for r in runs), key=lambda f: f["seconds"])
        out[label] = dict(ranked[(len(ranked) - 1) // 2],
                          seconds_runs=[f["seconds"] for f in ranked])
    return out


def _seconds(figures: dict) -> str:
    """A case's seconds, with the range where it is the median of repeated runs."""
    runs = figures.get("seconds_runs")
    if not runs:
        return f"{figures['seconds']}"
    return f"{figures['seconds']} (median of {len(runs)}: {runs[0]}-{runs[-1]})"


def _ratio(old, new) -> str:
    return f"{old / new:.1f}x" if new else "n/a"


def markdown(res: dict) -> str:
    base = res.get("baseline", {})
    revs = {case: res.get("baseline_revs", {}).get(case, res.get("baseline_rev"))
            for case in base}
    used = sorted(set(revs.values()))
    lines = ["# Benchmark results", "",
             f"Written by `python benchmarks/run.py`{' --protocol' if 'protocol' in res else ''}"
             f"{f' --baseline {used[0]}' if len(used) == 1 else ''} on "
             f"{res['machine']}, the machine "
             "otherwise idle. Ratios compare two measurements made in the same run. Rates "
             "count candidates (test points past the normal filter, every orientation decided "
             "by the placement tests and the score) over the seconds of both.", ""]
    if base:
        named = ", ".join(f"`{r}` ({', '.join(c for c in base if revs[c] == r)})"
                          for r in used)
        lines += [f"The baseline{'s' if len(used) > 1 else ''}, {named}: the library of that "
                  "git revision, measured in the same run as the case on the same machine, "
                  "one case after the other; *same decisions* says whether both accepted the "
                  "same pairs and predicted the same top k.", ""]
    if len(set(res.get("runs", {}).values())) > 1:
        groups: dict = {}
        for case, r in res["runs"].items():
            groups.setdefault(r, []).append(case)
        lines += ["Measured in separate runs (`--only`): " + "; ".join(
            ", ".join(v) for _, v in sorted(groups.items())) + ".", ""]
    if "detect" in res:
        b = base.get("detect", {})
        rev = revs.get("detect")
        lines += ["## Detection at the defaults (30 % test points)", "",
                  "| case | scene points | candidates | seconds | placement tests / scoring / "
                  "collision s | candidates/s | exact reference on 1,000 candidates: same "
                  "decisions, Numba / reference candidates/s, ratio |"
                  + (f" `{rev}` seconds (tests / scoring / collision) | ratio | same decisions |"
                     if b else ""),
                  "|---|---:|---:|---:|---:|---:|---|" + ("---:|---:|---|" if b else "")]
        for label, r in res["detect"].items():
            ref = r["reference"]
            row = (f"| {label} | {r['scene_points']:,} | {r['candidates']:,} | {_seconds(r)} | "
                   f"{r['placement_tests_s']:.1f} / {r['scoring_s']:.1f} / "
                   f"{r.get('collision_s', 0):.1f} | {r['candidates_per_s']:,.0f} | "
                   f"{'yes' if ref['identical_decisions'] else 'NO'}, "
                   f"{ref['numba_candidates_per_s']:,.0f} / "
                   f"{ref['reference_candidates_per_s']:,.0f}, {ref['ratio']}x |")
            if label in b:
                o = b[label]
                row += (f" {_seconds(o)} ({o['placement_tests_s']:.1f} / {o['scoring_s']:.1f}"
                        f" / {o.get('collision_s', 0):.1f}) | {_ratio(o['seconds'], r['seconds'])}"
                        f" | {'yes' if o.get('decisions') == r.get('decisions') else 'NO'} |")
            lines.append(row)
        lines.append("")
    if "tests" in res:
        lines += ["## The placement tests, each alone", "",
                  f"On the pairs of {TEST_CANDIDATES:,} candidates (8 orientations each) at "
                  "the defaults: microseconds a pair and the share it rejects; then the cost of "
                  "all of them in the library's order (each on the pairs the tests before it "
                  "left) and in the cheapest order of all.", "",
                  "| case | test: us a pair, rejects | in the library's order, s | cheapest "
                  "order, s |", "|---|---|---:|---|"]
        for label, r in res["tests"].items():
            tests = "; ".join(f"{n} {v['us_per_pair']}, {100 * v['rejects']:.0f} %"
                              for n, v in r["tests"].items())
            lines.append(f"| {label} | {tests} | {r['order_s']} | {r['best_order_s']} "
                         f"({', '.join(r['best_order'])}) |")
        lines.append("")
    if "many" in res:
        m = res["many"]
        lines += ["## The 8 examples in one pass (kitchen5, 30 %)", "",
                  f"One pass: {m['one_pass_s']} s; the slowest example alone: "
                  f"{m['slowest_alone_s']} s ({m['ratio_to_slowest']}x); the 8 alone: "
                  f"{sum(m['alone_s'].values()):.1f} s (one pass {m['ratio_to_sum']}x)"
                  + ("; the same decisions as each alone" if m.get("one_pass_as_alone")
                     else "") + "."]
        if "many" in base:
            o, rev = base["many"], revs["many"]
            lines.append(f"`{rev}`: one pass {o['one_pass_s']} s "
                         f"({_ratio(o['one_pass_s'], m['one_pass_s'])}), the slowest alone "
                         f"{o['slowest_alone_s']} s; same decisions: "
                         f"{'yes' if o.get('decisions') == m.get('decisions') else 'NO'}.")
        lines.append("")
    if "prepare" in res:
        p = res["prepare"]
        o, rev = base.get("prepare"), revs.get("prepare")

        def vs(key, field):
            return (f" (`{rev}` {o[key][field]}, {_ratio(o[key][field], p[key][field])})"
                    if o else "")
        lines += ["## Preparing and writing", "",
                  f"- living-room4 (a mesh, {p['mesh']['points']:,} samples): "
                  f"{p['mesh']['s_per_million']} s per million points, its tables included"
                  f"{vs('mesh', 's_per_million')};",
                  f"- a {p['cloud']['points']:,}-point cloud without normals: "
                  f"{p['cloud']['s_per_million']} s per million points{vs('cloud', 's_per_million')};",
                  f"- writing kitchen5's result ({p['write']['points']:,} points: predictions, "
                  f"accepted pairs, heat map, glTF, picture): {p['write']['seconds']} s"
                  f"{vs('write', 'seconds')}.", ""]
    if "demo" in res:
        d = res["demo"]
        lines += ["## The demo (`itensor demo`, its picture included)", "",
                  f"First run, with an empty Numba cache (a fresh install): {d['first_run_s']} "
                  f"s; again: {d['again_s']} s; peak memory {d['peak_mb']} MB.", ""]
    if "memory" in res:
        m = res["memory"]
        lines += ["## Memory", "",
                  f"`itensor detect` at the defaults on a {m['points']:,}-point cloud without "
                  f"normals: peak {m['peak_mb']} MB ({m['bytes_per_point']} bytes a point), "
                  f"{m['seconds']} s.", ""]
    if "density" in res:
        lines += ["## Density: a cloud's places against the mesh's", "",
                  "The same scene as clouds sampled from the mesh (`python benchmarks/run.py "
                  "--only density`): the places found, and how many of the mesh's places are "
                  "among them (boxes overlapping across, heights within 4 cm).", "",
                  "| case | scene | measured spacing cm | places | the mesh's places found "
                  "| seconds |", "|---|---|---:|---:|---:|---:|"]
        for label, r in res["density"].items():
            m = r["mesh"]
            lines.append(f"| {label} | mesh | | {m['places']} | | {m['seconds']} |")
            lines += [f"| | cloud, {k} | {v['measured_cm']} | {v['places']} | "
                      f"{v['mesh_places_found']}/{m['places']} | {v['seconds']} |"
                      for k, v in r.items() if k != "mesh"]
        lines.append("")
    if "train" in res:
        lines += ["## Training (median of 3)", "", "| example | seconds |", "|---|---:|"]
        lines += [f"| {k} | {v} |" for k, v in res["train"].items()]
        lines.append("")
    if "protocol" in res:
        p = res["protocol"]
        o, rev = base.get("protocol"), revs.get("protocol")
        lines += ["## The paper's protocol, detection only", "",
                  f"The 8 examples on the 14 published scenes at 30 %: {p['total_min']} min"
                  + (f" (`{rev}`: {o['total_min']} min, {_ratio(o['total_min'], p['total_min'])})"
                     if o else "") + ".", ""]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--one", nargs=2, help=argparse.SUPPRESS)
    ap.add_argument("--only", nargs="+", choices=CASES, default=list(CASES))
    ap.add_argument("--protocol", action="store_true", help="also the paper's protocol")
    ap.add_argument("--repeat", type=int, default=1, metavar="N",
                    help="run the detect cases N times (alternating with the baseline's) and "
                         "report each case's median")
    ap.add_argument("--baseline", metavar="REV",
                    help="also run the detect, many, prepare and protocol cases on git "
                         "revision REV's library, for their ratios")
    args = ap.parse_args()
    if args.one:
        one(args.one)
        return
    # the cases not run now keep their figures of the last run (each case's own run is noted)
    previous = HERE / "results.json"
    res = json.loads(previous.read_text()) if previous.exists() and args.only != list(CASES) \
        else {}
    res["machine"] = machine()
    res.setdefault("runs", {c: 1 for c in CASES + ("protocol",) if c in res})
    run_id = len(set(res["runs"].values())) + 1 if res["runs"] else 1
    library = None
    if args.baseline:
        library = baseline_tree(args.baseline)
        res.setdefault("baseline", {})
        # the revision each case's baseline figures are of (earlier runs' may differ)
        res.setdefault("baseline_revs", {c: res.get("baseline_rev") for c in res["baseline"]})
        res["baseline_rev"] = library.parent.name

    def measure(name, lib=None):
        if name == "detect":
            return {label: run_case("detect", scene, example, frac, library=lib)
                    for label, scene, example, frac in DETECT}
        if name == "many":
            return run_case("many", "kitchen5", 0.3, library=lib)
        if name == "density":
            return {label: run_case("density", scene, example, frac, list(factors))
                    for label, scene, example, frac, factors in DENSITY}
        if name == "tests":
            return {label: run_case("tests", scene, example) for label, scene, example in TESTS}
        return run_case(name, library=lib)

    names = list(args.only) + (["protocol"] if args.protocol else [])
    for name in names:
        res["runs"][name] = run_id
        t = time.perf_counter()
        runs, base_runs = [], []
        with_base = library is not None and name in BASELINE_CASES
        for _ in range(max(1, args.repeat) if name == "detect" else 1):
            runs.append(measure(name))
            if with_base:
                base_runs.append(measure(name, library))
        res[name] = median_run(runs)
        if with_base:
            res["baseline"][name] = median_run(base_runs)
            res["baseline_revs"][name] = library.parent.name
        elif "baseline" in res:
            res["baseline"].pop(name, None)
            res.get("baseline_revs", {}).pop(name, None)
        print(f"{name}: {time.perf_counter() - t:.0f} s", flush=True)
    (HERE / "results.json").write_text(json.dumps(res, indent=1) + "\n")
    (HERE / "RESULTS.md").write_text(markdown(res))
    print(f"wrote {HERE / 'results.json'} and {HERE / 'RESULTS.md'}")


if __name__ == "__main__":
    main()
