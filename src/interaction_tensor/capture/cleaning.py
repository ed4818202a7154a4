"""Cleaning a captured cloud with Open3D: voxel down-sampling, statistical outlier removal,
normals and their orientation."""

from __future__ import annotations

import numpy as np

from interaction_tensor.errors import InputError, SettingsError

_OPEN3D_HINT = "pip install 'interaction-tensor[open3d]'"


def _open3d():
    """Import Open3D with a one-line message when it is missing."""
    try:
        import open3d as o3d
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise InputError(None, f"real-scene processing needs Open3D ({exc}); {_OPEN3D_HINT}") \
            from None
    return o3d


def _cloud(points, normals=None, colors=None):
    o3d = _open3d()
    pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.ascontiguousarray(points, float)))
    if normals is not None:
        pc.normals = o3d.utility.Vector3dVector(np.ascontiguousarray(normals, float))
    if colors is not None:
        pc.colors = o3d.utility.Vector3dVector(np.asarray(colors, float) / 255.0)
    return pc


def _arrays(pc):
    pts = np.asarray(pc.points, dtype=np.float64).copy()
    nrm = np.asarray(pc.normals, dtype=np.float64).copy() if pc.has_normals() else None
    col = (np.clip(np.asarray(pc.colors), 0, 1) * 255).round().astype(np.uint8) \
        if pc.has_colors() else None
    return pts, nrm, col


# ============================================================================ cleaning
#: Voxels along the longest side Open3D's down-sampling indexes (its ``int``): a longer
#: cloud is refused (a wrong scale, or a focal length no camera has) instead of Open3D's
#: "voxel_size is too small".
MAX_VOXELS_PER_SIDE = 2 ** 31 - 1


def voxel_down_sample(points, colors=None, voxel_size: float = 0.01, source=None):
    """Average the points (and colours) in each ``voxel_size`` (m) cube. ``source`` names
    the input in the refusal of a cloud too long for that voxel size.

    Returns (points (M, 3) float64, colors (M, 3) uint8 or None).
    """
    if not voxel_size > 0:
        raise SettingsError("voxel_size must be positive (metres)")
    points = np.asarray(points, float)
    extent = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
    if extent >= voxel_size * MAX_VOXELS_PER_SIDE:
        raise InputError(source, f"the cloud spans {extent:.3g} m, more than "
                                 f"{MAX_VOXELS_PER_SIDE:,} voxels of {voxel_size:g} m; is its "
                                 "scale right (scale=, --scale)? Else give a larger voxel size "
                                 "(voxel_size=, --voxel-size)")
    pc = _cloud(points, colors=colors).voxel_down_sample(float(voxel_size))
    pts, _, col = _arrays(pc)
    return pts, col


def remove_statistical_outliers(points, nb_neighbors: int = 20, std_ratio: float = 2.0):
    """Indices of the points kept by statistical outlier removal (Open3D).

    A point is dropped when its mean distance to ``nb_neighbors`` neighbours exceeds the
    global mean by more than ``std_ratio`` standard deviations.
    Returns (K,) int64 indices into ``points``.
    """
    if nb_neighbors < 1 or not std_ratio > 0:
        raise SettingsError("outlier removal needs nb_neighbors >= 1 and std_ratio > 0")
    _, idx = _cloud(points).remove_statistical_outlier(int(nb_neighbors), float(std_ratio))
    return np.asarray(idx, dtype=np.int64)


def estimate_normals_o3d(points, radius: float, max_nn: int = 30) -> np.ndarray:
    """Unit normals by PCA of the neighbours within ``radius`` (at most ``max_nn``); sign
    arbitrary. Returns (N, 3) float64."""
    o3d = _open3d()
    pc = _cloud(points)
    pc.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=float(radius),
                                                             max_nn=int(max_nn)))
    normals = np.asarray(pc.normals, dtype=np.float64).copy()
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, length, out=np.tile([0.0, 0.0, 1.0], (len(normals), 1)),
                     where=length > 0)


def orient_normals(points, normals, towards="up") -> np.ndarray:
    """Flip normals so that they face a viewpoint or a direction.

    Parameters
    ----------
    points : (N, 3) metres
    normals : (N, 3) unit normals, any sign
    towards : ``"up"`` (+Z: n_z >= 0), ``"camera"``-style (3,) position (n . (c - p) >= 0,
        the side a sensor at c saw), or ``("direction", (3,))`` for any fixed direction.

    Returns (N, 3) float64, a flipped copy.
    """
    normals = np.array(normals, dtype=np.float64, copy=True)
    if isinstance(towards, str):
        if towards != "up":
            raise SettingsError(f"towards must be 'up', a position or ('direction', v), "
                                f"got {towards!r}")
        flip = normals[:, 2] < 0
    elif isinstance(towards, tuple) and len(towards) == 2 and towards[0] == "direction":
        flip = normals @ np.asarray(towards[1], float) < 0
    else:
        c = np.asarray(towards, dtype=np.float64).reshape(3)
        flip = np.einsum("ij,ij->i", normals, c - np.asarray(points, float)) < 0
    normals[flip] *= -1
    return normals
