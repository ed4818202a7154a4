"""The bisector-surface (BS) baseline (paper, section 4.2): compare bisector surfaces by ICP.

At every candidate and orientation the query object is posed by the iT's pose rule; the
bisector surface between it and the scene points within d_o of the query's centre is
computed (the same qhull bisector as training, trimmed to the sphere of radius d_o about the
query) and compared with the example's own bisector surface, moved by the same pose, by ICP
fitness (fraction of the example's bisector points with a test bisector point within
``max_distance`` = the voxel size). A pair is accepted when the fitness is at least the
example's own fitness against the bisector computed the same way from its own scene-object.
Scene points are thinned to one per ``voxel`` (2 cm) cell in both, so the calibration and the
test see the same density (a cap on the count would thin large neighbourhoods more). The proposed pose is the initial pose
(ICP only measures the match; moving the object by the bisector's alignment is not a pose).
"""

from __future__ import annotations

import time

import numpy as np

from interaction_tensor.descriptor.bisector import bisector_points, trim_to_sphere
from itensor_paper.baselines.common import (
    BaselineResult,
    candidate_poses,
    local_points,
    voxel_down,
)
from itensor_paper.baselines.icp import icp
from itensor_paper.baselines.naive import query_samples


def _bisector(q_pts, s_pts, centre, radius, seed):
    if len(s_pts) < 4:
        return np.zeros((0, 3))
    b = bisector_points(q_pts, s_pts, seed=seed)
    return b[trim_to_sphere(b, centre, radius)]


def _subsample(points, cap, seed):
    if len(points) <= cap:
        return points
    return points[np.random.default_rng(seed).choice(len(points), cap, replace=False)]


def bisector_baseline(scene, tensor, candidates: np.ndarray, n_orientations: int = 8,
                      voxel: float = 0.02, query_count: int = 600, bisector_cap: int = 800,
                      iterations: int = 10, backend: str = "auto",
                      seed: int = 0) -> BaselineResult:
    """Score every (candidate, orientation) with the BS baseline (see the module docstring)."""
    t0 = time.perf_counter()
    md = voxel
    q = query_samples(tensor, query_count, seed)
    qc = q.mean(axis=0)
    ref_bs = _subsample(tensor.bisector_points, bisector_cap, seed)
    # the example's own fitness: its bisector recomputed the same way vs the stored one
    own_scene = tensor.scene_points[np.linalg.norm(tensor.scene_points - qc, axis=1)
                                    <= tensor.radius]
    own = _bisector(q, voxel_down(own_scene, voxel), qc, tensor.radius, seed)
    _, thr, _ = icp(ref_bs, own, np.eye(4), md, iterations, backend)
    point, orient, poses = candidate_poses(scene, tensor, candidates, n_orientations)
    score = np.zeros(len(point))
    for k, pose in enumerate(poses):
        qp = q @ pose[:3, :3].T + pose[:3, 3]
        centre = pose[:3, :3] @ qc + pose[:3, 3]
        tgt = local_points(scene, centre, tensor.radius, voxel)
        test_bs = _bisector(qp, tgt, centre, tensor.radius, seed)
        ex_bs = ref_bs @ pose[:3, :3].T + pose[:3, 3]
        _, score[k], _ = icp(ex_bs, test_bs, np.eye(4), md, iterations, backend)
    return BaselineResult(point, orient, score, score >= thr - 1e-12, poses, thr,
                          time.perf_counter() - t0)
