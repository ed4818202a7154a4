"""Rigid ICP (point to point): Open3D when installed, else a small NumPy/SciPy version.

Both report Open3D's measures: ``fitness``, the fraction of source points with a target point
within ``max_distance`` after alignment, and ``rmse`` over those correspondences.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

OPEN3D_HINT = "pip install 'interaction-tensor[open3d]'"


def open3d_available() -> bool:
    try:
        import open3d  # noqa: F401
    except Exception:
        return False
    return True


def resolve_backend(name: str = "auto") -> str:
    """``auto`` -> ``open3d`` when it imports, else ``numpy``."""
    if name == "auto":
        return "open3d" if open3d_available() else "numpy"
    if name == "open3d" and not open3d_available():
        raise ImportError(f"the Open3D ICP backend needs Open3D: {OPEN3D_HINT}")
    if name not in ("open3d", "numpy"):
        raise ValueError(f"unknown ICP backend {name!r}")
    return name


def icp(source: np.ndarray, target: np.ndarray, init: np.ndarray, max_distance: float,
        iterations: int = 20, backend: str = "auto", target_tree: cKDTree | None = None):
    """Align ``source`` (N, 3) to ``target`` (M, 3) starting from the 4x4 ``init``.

    Returns (transformation 4x4, fitness in [0, 1], rmse in metres).
    """
    init = np.asarray(init, float)
    if len(target) < 3 or len(source) < 3:
        return init, 0.0, np.inf
    if resolve_backend(backend) == "open3d":
        import open3d as o3d

        reg = o3d.pipelines.registration
        src = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(source, float)))
        tgt = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(target, float)))
        res = reg.registration_icp(src, tgt, max_distance, init,
                                   reg.TransformationEstimationPointToPoint(),
                                   reg.ICPConvergenceCriteria(max_iteration=iterations))
        return np.asarray(res.transformation), float(res.fitness), float(res.inlier_rmse)
    tree = target_tree if target_tree is not None else cKDTree(target)
    m = init.copy()
    for _ in range(iterations):
        moved = source @ m[:3, :3].T + m[:3, 3]
        d, j = tree.query(moved, distance_upper_bound=max_distance, workers=-1)
        ok = np.isfinite(d)
        if ok.sum() < 3:
            break
        a, b = moved[ok], target[j[ok]]
        ca, cb = a.mean(axis=0), b.mean(axis=0)
        u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
        r = vt.T @ u.T
        if np.linalg.det(r) < 0:
            vt[-1] *= -1
            r = vt.T @ u.T
        step = np.eye(4)
        step[:3, :3], step[:3, 3] = r, cb - r @ ca
        m = step @ m
        if np.abs(step[:3, 3]).max() < 1e-5 and np.abs(r - np.eye(3)).max() < 1e-6:
            break
    moved = source @ m[:3, :3].T + m[:3, 3]
    d, _ = tree.query(moved, distance_upper_bound=max_distance, workers=-1)
    ok = np.isfinite(d)
    fitness = float(ok.mean())
    rmse = float(np.sqrt(np.mean(d[ok] ** 2))) if ok.any() else np.inf
    return m, fitness, rmse
