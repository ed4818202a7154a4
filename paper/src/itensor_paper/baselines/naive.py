"""The Naive baseline (paper, section 4.2): ICP of the query object against the local scene.

At every candidate (the same test points and normal filter as the Interaction Tensor) and
every orientation, the query object is put where the iT would put it (the same pose rule,
``tensor.pose``), then aligned to the scene points within d_o by point-to-point ICP
(Open3D, or :mod:`.icp`'s NumPy version). The score is the ICP fitness (fraction of query
samples with a scene point within ``max_distance`` = one scene spacing); a pair is accepted
when it is at least the fitness the example itself gets against its own scene-object. The
scene is used at the density it was sampled at, as the example's scene-object is for that
fitness (no cap on the points: a cap would make large neighbourhoods sparser than the
calibration and fail them). The proposed pose is the ICP-refined one. There is no representation of the interaction: this is
what the paper calls matching the object instead of the interaction.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.spatial import cKDTree

from interaction_tensor.geometry.core import Geometry
from interaction_tensor.geometry.sampling import sample_mesh
from itensor_paper.baselines.common import BaselineResult, candidate_poses, local_points
from itensor_paper.baselines.icp import icp


def query_samples(tensor, count: int = 800, seed: int = 0) -> np.ndarray:
    """(count, 3) area-uniform samples of the tensor's query object (training frame)."""

    if tensor.query_is_mesh:
        return sample_mesh(Geometry(tensor.query_vertices, tensor.query_faces), count, seed)[0]
    v = tensor.query_vertices
    return v[np.random.default_rng(seed).choice(len(v), min(count, len(v)), replace=False)]


def example_fitness(tensor, samples, max_distance: float, backend: str = "auto") -> float:
    """ICP fitness of the training example: the query at its own pose vs its scene-object."""
    _, fit, _ = icp(samples, tensor.scene_points, np.eye(4), max_distance, backend=backend)
    return fit


def naive(scene, tensor, candidates: np.ndarray, n_orientations: int = 8,
          max_distance: float | None = None, iterations: int = 15,
          backend: str = "auto", seed: int = 0) -> BaselineResult:
    """Score every (candidate, orientation) with the Naive baseline.

    Parameters
    ----------
    scene : prepared Scene (points, tree)
    tensor : the example's InteractionTensor (pose rule, query object, example scene-object)
    candidates : (C,) scene indices (normal-filtered test points, capped by the caller)
    """
    t0 = time.perf_counter()
    md = max_distance or scene.spacing
    src = query_samples(tensor, seed=seed)
    thr = example_fitness(tensor, src, md, backend)
    point, orient, poses = candidate_poses(scene, tensor, candidates, n_orientations)
    score = np.zeros(len(point))
    for c, ci in enumerate(candidates):
        tgt = local_points(scene, scene.points[ci], tensor.radius)
        tree = cKDTree(tgt) if len(tgt) else None
        for k in range(c * n_orientations, (c + 1) * n_orientations):
            poses[k], score[k], _ = icp(src, tgt, poses[k], md, iterations, backend, tree)
    return BaselineResult(point, orient, score, score >= thr - 1e-12, poses, thr,
                          time.perf_counter() - t0)
