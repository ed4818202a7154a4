"""Exhaustive searches with the judge: does a scene hold any valid pose at all?

Table 1 counts a top 5 in every scene, so a scene with no place for an affordance adds five
invalid poses whatever a method does. These searches tell such scenes apart from a method's
misses by judging every pose of a family the scene's samples allow, independently of any
detector (diagnosis, never tuning; ``scripts/filling_oracle.py``, ``scripts/region_oracle.py``):

- :func:`standing_filling`: a mug standing on any sample whose normal line is near vertical,
  in ``n_orient`` orientations about its opening's axis (the judge's filling tests need it to
  stand: support, contact);
- :func:`region_poses`: a descriptor's own poses (:meth:`~.InteractionTensor.pose`, the
  family detection proposes) at every sample of a box, in ``n_orient`` orientations.

Both judge cheaply first (every test but penetration, which needs fcl) and in full only the
poses that pass, so the verdicts are the judge's own.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass, field

import numpy as np

from itensor_paper.judge import Judge, JudgeScene


@dataclass
class Search:
    """What an exhaustive search judged: ``samples`` (the scene samples it stood poses on,
    ``points``), ``poses`` tried, ``pretest`` (poses past a necessary pre-test), ``judged``
    (poses the judge was asked about), ``valid`` [(sample index, orientation)], ``reasons``
    (Counter of the judge's reasons over the judged poses; penetration is tested only where
    every other test passes) and ``rows`` (one dict per judged pose, where kept)."""

    samples: int = 0
    poses: int = 0
    pretest: int = 0
    judged: int = 0
    valid: list = field(default_factory=list)
    reasons: collections.Counter = field(default_factory=collections.Counter)
    rows: list = field(default_factory=list)
    points: np.ndarray | None = None


def _reason(r: str) -> str:
    """A judge's reason without its figures ("main contact only 3 % touching" -> "main
    contact")."""
    for cut in (" (", " only", " 0.", " 1.", " 2."):
        r = r.split(cut)[0]
    return r


def cheap_judge(judge: Judge) -> Judge:
    """A copy of ``judge`` without its penetration tests: every other verdict the same."""
    import copy

    j = copy.copy(judge)
    j.bodies = []
    return j


def judge_in_order(js: JudgeScene, judge: Judge, cheap: Judge, pose):
    """The judge's verdict of ``pose``, the penetration tests asked only when every other
    test passes (so the verdict's validity is the full judge's; its reasons may omit a
    penetration)."""
    v = cheap.judge(js, pose)
    return judge.judge(js, pose) if v.valid else v


def standing_pose(pivot: np.ndarray, at: np.ndarray, angle: float) -> np.ndarray:
    """4x4: the training-frame object turned by ``angle`` about the vertical through
    ``pivot``, which then lies at ``at``."""
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    pose = np.eye(4)
    pose[:3, :3] = rot
    pose[:3, 3] = np.asarray(at, float) - rot @ np.asarray(pivot, float)
    return pose


def tap_candidates(js: JudgeScene, judge: Judge, rim: float, at: np.ndarray,
                   chunk: int = 100_000) -> np.ndarray:
    """(N,) bool: whether some scene sample lies where the judge's tap test looks first
    (within ``overhead_radius`` of the opening's axis, ``overhead_range`` above the rim) for
    an opening over ``at`` (N, 3) with the rim ``rim`` m above it. A necessary condition of
    :meth:`Judge._overhead`, exact: balls of radius hypot(r, 1 cm) every 2 cm up the axis
    gather every sample of that cylinder, and those are checked against it."""
    st = judge.settings
    lo, hi = st.overhead_range
    steps = np.arange(lo, hi + 0.02, 0.02)
    r = float(np.hypot(st.overhead_radius, 0.01))
    at = np.asarray(at, float).reshape(-1, 3)
    out = np.zeros(len(at), bool)
    for s in range(0, len(at), chunk):
        axis = at[s:s + chunk] + [0.0, 0.0, rim]
        for dz in steps:
            todo = np.flatnonzero(~out[s:s + chunk])
            if not len(todo):
                break
            q = axis[todo] + [0.0, 0.0, dz]
            n = np.asarray(js.tree.query_ball_point(q, r, return_length=True, workers=-1))
            some = np.flatnonzero(n > 0)
            for j, idx in zip(some, js.tree.query_ball_point(q[some], r, workers=-1)):
                p = js.points[idx]
                a = axis[todo[j]]
                h = p[:, 2] - a[2]
                if ((np.hypot(p[:, 0] - a[0], p[:, 1] - a[1]) <= st.overhead_radius)
                        & (h >= lo) & (h <= hi)).any():
                    out[s + todo[j]] = True
    return out


def standing_filling(js: JudgeScene, judge: Judge, support_point, max_tilt: float = 25.0,
                     n_orient: int = 8, fraction: float = 1.0, seed: int = 0) -> Search:
    """Every standing pose of a filling example's mug in the judge's scene ``js``.

    The mug's base (the example's ``support_point``) on each scene sample whose normal line
    is within ``max_tilt`` degrees of vertical (``fraction`` of them, seeded; 1: all), turned
    in ``n_orient`` orientations about the vertical through its opening, so that the opening
    stays over the sample (the base moves by the opening's offset from it, under 1 mm for
    the paper's mugs) and the tap test depends on the sample alone: its necessary condition
    (:func:`tap_candidates`) for all samples at once, then the judge's own tap test once per
    sample, then the judge in each orientation (:func:`judge_in_order`).
    """
    support = np.asarray(support_point, float)
    up = np.abs(js.normals[:, 2]) >= np.cos(np.radians(max_tilt))
    at = js.points[up]
    if fraction < 1.0:
        at = at[np.random.default_rng(seed).random(len(at)) < fraction]
    pivot = np.r_[judge.opening[:2], support[2]]
    rim = float(judge.opening[2] - support[2])
    cheap = cheap_judge(judge)
    out = Search(samples=len(at), poses=n_orient * len(at))
    maybe = np.flatnonzero(tap_candidates(js, judge, rim, at))
    out.pretest = n_orient * len(maybe)
    for i in maybe:
        if not judge._overhead(js, at[i] + [0.0, 0.0, rim]):
            continue
        for k in range(n_orient):
            v = judge_in_order(js, judge, cheap, standing_pose(pivot, at[i],
                                                               2 * np.pi * k / n_orient))
            out.judged += 1
            out.reasons.update(_reason(r) for r in v.reasons)
            if v.valid:
                out.valid.append((int(i), k))
            out.rows.append({"x": round(float(at[i, 0]), 3), "y": round(float(at[i, 1]), 3),
                             "z": round(float(at[i, 2]), 3), "orientation": k,
                             "valid": bool(v.valid), "reasons": "; ".join(v.reasons)})
    out.points = at
    return out


def region_poses(js: JudgeScene, judge: Judge, tensor, lo, hi, n_orient: int = 8,
                 cell: float | None = None, max_tilt: float = 15.0,
                 cell_3d: bool = False, progress: bool = False) -> Search:
    """The descriptor's poses (:meth:`~.InteractionTensor.pose`: the family detection
    proposes) at every judge sample in the box [``lo``, ``hi``] whose normal line is within
    ``max_tilt`` degrees of the descriptor's N_aff line (one per ``cell`` m in plan when
    given, or per ``cell`` m cube with ``cell_3d``: a whole room, where a table stands over
    the floor), in ``n_orient`` orientations, each judged (:func:`judge_in_order`)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    n_aff = np.asarray(tensor.affordance_normal, float)
    n_aff = n_aff / np.linalg.norm(n_aff)
    m = (np.all((js.points >= lo) & (js.points <= hi), axis=1)
         & (np.abs(js.normals @ n_aff) >= np.cos(np.radians(max_tilt))))
    at = js.points[m]
    if cell:
        _, first = np.unique(np.floor(at[:, :3 if cell_3d else 2] / cell).astype(np.int64),
                             axis=0, return_index=True)
        at = at[np.sort(first)]
    cheap = cheap_judge(judge)
    out = Search(samples=len(at), poses=n_orient * len(at))
    out.pretest = out.poses
    from tqdm import tqdm

    for i, p in enumerate(tqdm(at, desc="samples", disable=not progress)):
        for k in range(n_orient):
            v = judge_in_order(js, judge, cheap, tensor.pose(p, 2 * np.pi * k / n_orient))
            out.judged += 1
            out.reasons.update(_reason(r) for r in v.reasons)
            if v.valid:
                out.valid.append((i, k))
    out.points = at
    return out
