"""Detection: candidate test points, the scoring loop, and the result.

Data flow: scene -> test points (seeded random fraction) -> normal filter against N_aff ->
scores per (test point, orientation), keypoints in weight order with early exit ->
:class:`Detection` (accepted pairs, heat map, top-k poses, statistics).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .descriptor import InteractionTensor
from .predictions import Prediction, heat_map, top_k
from .scene import Scene
from .kernels import score_pairs_numba
from .scoring import PairScores, make_table, score_pairs
from .settings import DetectSettings


def resolve_backend(name: str) -> str:
    """``auto`` -> ``numba`` when Numba imports, else ``numpy``."""
    from . import kernels

    if name == "auto":
        return "numba" if kernels.available() else "numpy"
    if name == "numba" and not kernels.available():
        from .errors import SettingsError

        raise SettingsError("backend 'numba' needs Numba: pip install numba")
    return name


def keypoint_table(tensor: InteractionTensor, settings: DetectSettings):
    """The keypoint set chosen by ``settings``, rotated for every orientation."""
    kp = tensor.keypoints(settings.keypoints)
    return make_table(kp.points - tensor.reference_point, kp.provenance, kp.weights,
                      settings.n_orientations, settings.criterion, settings.theta_max,
                      settings.c, settings.gaussian_a)


def resolve_threshold(tensor: InteractionTensor, settings: DetectSettings) -> float:
    """The acceptance threshold: the settings' own, else the descriptor's calibrated one."""
    if settings.threshold is not None:
        return float(settings.threshold)
    return tensor.threshold(settings.criterion, settings.keypoints)


def score_at(tensor: InteractionTensor, scene: Scene, positions, orientation_index,
             **overrides) -> np.ndarray:
    """Full scores (no early exit) of given placements.

    Parameters
    ----------
    positions : (P, 3) test points, metres
    orientation_index : (P,) int, orientation i means angle i * 2 pi / n_orientations
    overrides : DetectSettings fields (criterion, keypoints, n_orientations, ...)

    Returns (P,) float64 normalised scores in [0, 1].
    """
    settings = DetectSettings(**overrides)
    table = keypoint_table(tensor, settings)
    res = score_pairs(np.asarray(positions, float), np.asarray(orientation_index, int), table,
                      scene, threshold=1.0, vectors=tensor.vectors, early_exit=False)
    return res.score


def candidate_mask(normals: np.ndarray, affordance_normal: np.ndarray,
                   tolerance_deg: float, oriented: bool) -> np.ndarray:
    """(N,) bool: normals within ``tolerance_deg`` of N_aff (of its line unless oriented)."""
    dot = normals @ np.asarray(affordance_normal, float)
    if not oriented:
        dot = np.abs(dot)
    return dot >= np.cos(np.radians(tolerance_deg)) - 1e-12


@dataclass
class Detection:
    """Everything one detection run found.

    Attributes
    ----------
    scene : the Scene searched
    tensor : the descriptor used
    settings : the DetectSettings used; ``threshold`` the threshold applied
    test_indices : (T,) scene indices drawn as test points
    candidate_indices : (C,) test points that passed the normal filter
    pair_point, pair_orientation : (P,) scene index and orientation of every scored pair
    pairs : PairScores of those pairs
    heat : (N,) per scene point: best accepted score near it (0 where none)
    accepted_count : (N,) accepted orientations at each scene point
    predictions : top-k after suppression, best first
    stats : counts and seconds per stage
    """

    scene: Scene
    tensor: InteractionTensor
    settings: DetectSettings
    threshold: float
    test_indices: np.ndarray
    candidate_indices: np.ndarray
    pair_point: np.ndarray
    pair_orientation: np.ndarray
    pairs: PairScores
    heat: np.ndarray
    accepted_count: np.ndarray
    predictions: list = field(default_factory=list)
    stats: dict = field(default_factory=dict)

    @property
    def accepted(self) -> np.ndarray:
        """Indices into the pair arrays of accepted pairs."""
        return np.flatnonzero(self.pairs.accepted)

    def angle(self, orientation_index) -> np.ndarray:
        return 2 * np.pi * np.asarray(orientation_index) / self.settings.n_orientations


def detect(scene: Scene, tensor: InteractionTensor, settings: DetectSettings | None = None,
           progress: bool = False) -> Detection:
    """Find where the interaction of ``tensor`` can happen in ``scene``.

    Parameters
    ----------
    scene : prepared scene (see :func:`interaction_tensor.scene.prepare_scene`)
    tensor : a fitted or loaded InteractionTensor
    settings : DetectSettings (defaults if None)
    progress : show a progress bar over candidate batches
    """
    settings = settings or DetectSettings()
    timings = {}
    t0 = time.perf_counter()
    rng = np.random.default_rng(settings.seed)
    n_test = max(1, int(round(settings.sample_fraction * len(scene))))
    test_idx = np.sort(rng.choice(len(scene), size=n_test, replace=False))
    ok = candidate_mask(scene.normals[test_idx], tensor.affordance_normal,
                        settings.normal_tolerance_deg, settings.oriented_normals)
    cand = test_idx[ok]
    timings["candidates"] = time.perf_counter() - t0

    t1 = time.perf_counter()
    backend = resolve_backend(settings.backend)
    if backend == "numba":       # build the index outside the timed scoring loop
        grid = scene.grid()
    else:
        _ = scene.tree
    timings["index"] = time.perf_counter() - t1

    t2 = time.perf_counter()
    table = keypoint_table(tensor, settings)
    threshold = resolve_threshold(tensor, settings)
    n_o = settings.n_orientations
    pair_point = np.repeat(cand, n_o)
    pair_orient = np.tile(np.arange(n_o), len(cand))
    score = np.zeros(len(pair_point))
    accepted = np.zeros(len(pair_point), bool)
    decided_at = np.zeros(len(pair_point), np.int64)
    comparisons = 0
    step = settings.batch_size * n_o
    batches = range(0, len(pair_point), step)
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(cand), unit="pt", desc=f"detect {tensor.affordance}",
                   leave=False)
    for start in batches:
        sl = slice(start, start + step)
        if backend == "numba":
            s, a, at, cmp = score_pairs_numba(scene.points[pair_point[sl]], pair_orient[sl],
                                              table, grid, threshold, tensor.vectors,
                                              scene.spacing, settings.early_exit)
            score[sl], accepted[sl], decided_at[sl] = s, a, at
            comparisons += int(cmp.sum())
        else:
            res = score_pairs(scene.points[pair_point[sl]], pair_orient[sl], table, scene,
                              threshold, vectors=tensor.vectors, early_exit=settings.early_exit)
            score[sl], accepted[sl], decided_at[sl] = res.score, res.accepted, res.decided_at
            comparisons += res.comparisons
        if bar is not None:
            bar.update((sl.stop if sl.stop < len(pair_point) else len(pair_point)) // n_o
                       - start // n_o)
    if bar is not None:
        bar.close()
    pairs = PairScores(score, accepted, decided_at, comparisons)
    timings["scoring"] = time.perf_counter() - t2

    t3 = time.perf_counter()
    heat, count = heat_map(scene, pair_point, pairs.score, pairs.accepted)
    radius = settings.nms_radius if settings.nms_radius is not None else 0.5 * tensor.radius
    acc = np.flatnonzero(accepted)
    angles = 2 * np.pi * pair_orient / n_o
    picks = top_k(scene.points[pair_point[acc]], score[acc], settings.top_k, radius)
    predictions = [
        Prediction(position=scene.points[pair_point[acc[i]]].copy(),
                   orientation_index=int(pair_orient[acc[i]]), angle=float(angles[acc[i]]),
                   score=float(score[acc[i]]),
                   pose=tensor.pose(scene.points[pair_point[acc[i]]], angles[acc[i]]),
                   point_index=int(pair_point[acc[i]]))
        for i in picks]
    timings["predictions"] = time.perf_counter() - t3
    timings["total"] = time.perf_counter() - t0
    n_decided = decided_at[accepted | ~accepted]
    stats = {
        "scene_points": int(len(scene)),
        "test_points_sampled": int(n_test),
        "candidates_after_normal_filter": int(len(cand)),
        "pairs_scored": int(len(pair_point)),
        "pairs_accepted": int(accepted.sum()),
        "keypoint_comparisons": int(comparisons),
        "keypoint_comparisons_to_decision": int(n_decided.sum()),
        "mean_comparisons_per_decision": float(n_decided.mean()) if len(n_decided) else 0.0,
        "threshold": threshold,
        "backend": backend,
        "seconds": {k: round(v, 4) for k, v in timings.items()},
        "test_points_per_second": (float(len(cand) / timings["scoring"])
                                   if timings["scoring"] > 0 else None),
    }
    return Detection(scene, tensor, settings, threshold, test_idx, cand, pair_point,
                     pair_orient, pairs, heat, count, predictions, stats)
