"""What both baselines share: candidate placements and the result type."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class BaselineResult:
    """Scores of (candidate point, orientation) pairs by a baseline.

    Attributes
    ----------
    pair_point : (P,) scene index of each pair's test point
    pair_orientation : (P,) orientation index (angle i * 2 pi / n about +Z)
    score : (P,) ICP fitness in [0, 1]
    accepted : (P,) score >= threshold
    poses : (P, 4, 4) the pose the baseline proposes (Naive: after ICP; BS: the initial pose)
    threshold : the acceptance threshold (the example's own fitness)
    seconds : wall time of the scoring
    """

    pair_point: np.ndarray
    pair_orientation: np.ndarray
    score: np.ndarray
    accepted: np.ndarray
    poses: np.ndarray
    threshold: float
    seconds: float


def capped_candidates(candidates: np.ndarray, cap: int | None, seed: int = 0) -> np.ndarray:
    """A seeded random subset of at most ``cap`` candidate indices (sorted)."""
    candidates = np.asarray(candidates, np.int64)
    if cap is None or len(candidates) <= cap:
        return candidates
    rng = np.random.default_rng(seed)
    return np.sort(rng.choice(candidates, cap, replace=False))


def local_points(scene, centre, radius: float, voxel: float | None = None) -> np.ndarray:
    """Scene points within ``radius`` of ``centre``, thinned to one per ``voxel`` (m) cell
    when given (the same thinning the baseline's calibration sees)."""
    idx = np.asarray(scene.tree.query_ball_point(centre, radius), np.int64)
    pts = scene.points[np.sort(idx)]
    return voxel_down(pts, voxel) if voxel else pts


def voxel_down(points: np.ndarray, voxel: float) -> np.ndarray:
    """One point per cubic cell of edge ``voxel`` (the first in input order): a thinning that
    gives the same density wherever it is applied, unlike a cap on the count."""
    points = np.asarray(points, float)
    if len(points) == 0:
        return points
    keys = np.floor(points / voxel).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    return points[np.sort(first)]


def candidate_poses(scene, tensor, candidates: np.ndarray, n_orientations: int):
    """Every (candidate, orientation) pair with the pose iT would propose there.

    Returns pair_point (P,), pair_orientation (P,) and poses (P, 4, 4), candidate-major:
    pair ``c * n_orientations + o`` is candidate ``c`` turned by ``o * 2 pi / n``.
    """
    point = np.repeat(np.asarray(candidates, np.int64), n_orientations)
    orient = np.tile(np.arange(n_orientations), len(candidates))
    poses = np.array([tensor.pose(scene.points[p], 2 * np.pi * o / n_orientations)
                      for p, o in zip(point, orient)]).reshape(-1, 4, 4)
    return point, orient, poses
