"""Places and predictions: the top k accepted pairs a suppression radius apart, and the heat
map of accepted scores over the scene.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from interaction_tensor.descriptor.tensor import InteractionTensor
from interaction_tensor.geometry.files import Gathered
from interaction_tensor.settings import DetectSettings


@dataclass
class Prediction:
    """One place where the interaction can happen.

    Attributes
    ----------
    position : (3,) test point, metres
    orientation_index : i, the query object turned by i * 2 pi / n about +Z
    angle : radians
    score : normalised score in [0, 1]
    pose : (4, 4) rigid transform of the training-frame query object into the scene
    point_index : index of the test point in the scene's points
    """

    position: np.ndarray
    orientation_index: int
    angle: float
    score: float
    pose: np.ndarray
    point_index: int = -1

    def __post_init__(self):   # plain NumPy arrays and numbers, whatever made them
        self.position = np.array(self.position, dtype=np.float64).reshape(3)
        self.pose = np.array(self.pose, dtype=np.float64).reshape(4, 4)
        self.orientation_index = int(self.orientation_index)
        self.angle = float(self.angle)
        self.score = float(self.score)
        self.point_index = int(self.point_index)

    def __repr__(self) -> str:
        x, y, z = self.position
        return (f"Prediction(score={self.score:.3f}, position=({x:.3f}, {y:.3f}, {z:.3f}), "
                f"angle={np.degrees(self.angle):.0f} deg)")

    def to_dict(self) -> dict:
        return {"position": [float(v) for v in self.position],
                "orientation_index": self.orientation_index, "angle": self.angle,
                "score": self.score, "pose": np.asarray(self.pose).tolist(),
                "point_index": self.point_index}


def top_k(positions: np.ndarray, scores: np.ndarray, k: int, radius: float,
          index: np.ndarray | None = None, accept=None) -> list[int]:
    """Greedy non-maximum suppression: indices of up to ``k`` best, ``radius`` apart.

    Candidate i is at ``positions[i]``, or at ``positions[index[i]]`` when ``index`` is given
    (the scene's points and the pairs' point indices: no gathered (N, 3) copy).
    Ties in score are broken by the lower index. The candidates are swept best first in
    blocks; within a block, each one is tested against the picks so far at once (the same
    picks as repeatedly taking the best unsuppressed one, without an (N, 3) temporary per
    pick: a million accepted pairs cost their sort order only).

    With ``accept``, a callable taking a candidate's index: a candidate that would be picked
    is asked first and skipped when the answer is False (it suppresses nothing); None ends
    the search with the picks so far. The picks are then those of the same suppression
    among the candidates it accepts, and only candidates that no pick suppresses are asked
    (detection's collision test of its top k).
    """
    if index is not None:
        index = np.asarray(index)
        return top_k(Gathered(positions, index), scores, k, radius, accept=accept)
    scores = np.asarray(scores)
    if len(scores) == 0 or k <= 0:
        return []
    order = np.argsort(-scores, kind="stable")          # best first, lower index on ties
    if not np.isfinite(scores).all():
        order = order[np.isfinite(scores[order])]
    picks: list[int] = []
    r2 = float(radius) ** 2
    block = 4096
    for s in range(0, len(order), block):
        idx = order[s:s + block]
        pos = positions[idx]
        free = np.ones(len(idx), bool)
        if picks:
            chosen = positions[picks]
            d2 = ((pos[:, None, :] - chosen[None, :, :]) ** 2).sum(axis=2)
            free &= ~(d2 <= r2).any(axis=1)
        for j in np.flatnonzero(free):            # at most k picks end this loop
            if not free[j]:
                continue
            if accept is not None:
                ok = accept(int(idx[j]))
                if ok is None:
                    return picks
                if not ok:
                    continue
            picks.append(int(idx[j]))
            if len(picks) == k:
                return picks
            near = ((pos - pos[j]) ** 2).sum(axis=1) <= r2
            free &= ~near
    return picks


def heat_map(scene, pair_point: np.ndarray, pair_score: np.ndarray,
             pair_accepted: np.ndarray):
    """Per-point heat: the best accepted score of the nearest test point, spread to the
    scene points around it (within 1.5 x spacing), and the accepted orientations per point.

    Returns heat (N,) float64 in [0, 1] and count (N,) int.
    """
    n = len(scene)
    best = np.zeros(n)
    count = np.zeros(n, np.int32)
    if not pair_accepted.any():
        return best, count
    for s in range(0, len(pair_accepted), 1 << 20):     # bounded gathers of accepted pairs
        sl = slice(s, s + (1 << 20))
        acc = pair_accepted[sl]
        np.maximum.at(best, pair_point[sl][acc], pair_score[sl][acc])
        np.add.at(count, pair_point[sl][acc], 1)
    hot = np.flatnonzero(best > 0)
    hot_best = best[hot]                    # the scores spread, before spreading raises them
    from scipy.spatial import cKDTree

    tree = cKDTree(scene.points[hot])
    heat = best                             # spread in place: no second (N,) array
    for s in range(0, n, 500_000):          # bounds the query's (distance, index) arrays
        d, j = tree.query(scene.points[s:s + 500_000], distance_upper_bound=1.5 * scene.spacing,
                          workers=-1)
        near = np.flatnonzero(np.isfinite(d))
        heat[s + near] = np.maximum(heat[s + near], hot_best[j[near]])
    return heat, count


def suppression_radius(tensor: InteractionTensor, settings: DetectSettings) -> float:
    """Top-k suppression radius (m): the setting, else the query object's width."""
    if settings.nms_radius is not None:
        return float(settings.nms_radius)
    return float(np.ptp(tensor.query_vertices[:, :2], axis=0).max())
