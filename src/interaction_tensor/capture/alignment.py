"""Gravity alignment: RANSAC planes, the floor (or supporting plane) chosen and levelled at
z = 0, and the rotations between frames."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from interaction_tensor.capture.cleaning import _cloud, _open3d, voxel_down_sample
from interaction_tensor.errors import InputError, SettingsError

#: Optical camera frame: +x right, +y down, +z forward. "Up" for a camera held level.
CAMERA_UP = np.array([0.0, -1.0, 0.0])

AXES = {"x": (1.0, 0, 0), "y": (0, 1.0, 0), "z": (0, 0, 1.0),
        "-x": (-1.0, 0, 0), "-y": (0, -1.0, 0), "-z": (0, 0, -1.0)}


# ============================================================================ alignment
@dataclass
class Plane:
    """A RANSAC plane ``normal . p + offset = 0`` with ``normal`` facing the chosen side."""

    normal: np.ndarray
    offset: float
    inliers: int
    area_m2: float
    above_fraction: float = 0.0
    tilt_deg: float | None = None
    support_m2: float = 0.0
    centre: np.ndarray | None = None

    def to_dict(self) -> dict:
        return {"normal": [round(float(v), 6) for v in self.normal],
                "offset": round(float(self.offset), 6), "inliers": int(self.inliers),
                "area_m2": round(self.area_m2, 4), "above_fraction": round(self.above_fraction, 4),
                "tilt_from_hint_deg": None if self.tilt_deg is None else round(self.tilt_deg, 2),
                "parallel_surfaces_above_m2": round(self.support_m2, 4),
                "centre": None if self.centre is None else [round(float(v), 4) for v in self.centre]}


def fit_plane(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares plane through (N, 3) points: (unit normal, offset), n . p + d = 0."""
    centre = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - centre, full_matrices=False)
    normal = vt[2] / np.linalg.norm(vt[2])
    return normal, float(-normal @ centre)


def candidate_planes(points, distance: float = 0.02, max_planes: int = 10,
                     min_fraction: float = 0.02, seed: int = 0, iterations: int = 1000,
                     cell: float | None = None) -> list[Plane]:
    """Planes found by repeated RANSAC (Open3D ``segment_plane``) on (N, 3) points.

    Each plane's inliers are removed before the next search; a plane found again (normal
    within 5 degrees and offset within ``2 * distance`` of an earlier one) is merged with it.
    Stops after ``max_planes`` searches or when a plane has fewer than ``min_fraction`` of
    the points. Normals are refitted by least squares on the inliers; their sign is
    arbitrary. ``area_m2`` estimates the area as inliers x ``cell``^2 (``cell``: the point
    spacing of the input, default ``distance``).
    """
    o3d = _open3d()
    o3d.utility.random.seed(int(seed))
    points = np.asarray(points, dtype=np.float64)
    cell = distance if cell is None else cell
    remaining = np.arange(len(points))
    groups: list[list] = []          # [normal, offset, inlier index arrays]
    min_count = max(3, int(min_fraction * len(points)))
    for _ in range(max_planes):
        if len(remaining) < min_count:
            break
        pc = _cloud(points[remaining])
        _, idx = pc.segment_plane(float(distance), 3, int(iterations))
        idx = np.asarray(idx, dtype=np.int64)
        if len(idx) < min_count:
            break
        members = remaining[idx]
        normal, offset = fit_plane(points[members])
        for g in groups:
            same_dir = abs(float(g[0] @ normal)) > math.cos(math.radians(5))
            off = offset if g[0] @ normal > 0 else -offset
            if same_dir and abs(off - g[1]) < 2 * distance:
                g[2] = np.concatenate([g[2], members])
                g[0], g[1] = fit_plane(points[g[2]])
                break
        else:
            groups.append([normal, offset, members])
        keep = np.ones(len(remaining), bool)
        keep[idx] = False
        remaining = remaining[keep]
    return [Plane(g[0], g[1], len(g[2]), len(g[2]) * cell * cell,
                  centre=points[g[2]].mean(axis=0)) for g in groups]


def choose_support_plane(points, planes: list[Plane], up_hint=None, max_tilt_deg: float = 45.0,
                         camera=None, distance: float = 0.02,
                         min_area_m2: float = 0.1) -> tuple[Plane | None, list[Plane]]:
    """Pick the floor or the dominant supporting plane among RANSAC ``planes``.

    Each plane's normal is oriented (towards ``up_hint`` when given, else towards the side
    most points are on) and scored on three counts, in this order:

    1. *most points above*: the fraction of all points not below it (more than
       ``2 * distance`` under the plane); planes within 0.03 of the best fraction are "low";
    2. *large*: planes under ``min_area_m2`` are ignored unless nothing else is left;
    3. among the low, large planes, the largest area plus the area of the parallel planes
       (within 10 degrees) above it: the supporting surfaces that gravity makes parallel
       to the floor (desk tops, seats), which walls seldom have.

    With ``up_hint`` only planes within ``max_tilt_deg`` of it are candidates; with a
    ``camera`` position, the camera must be above the plane (a sensor looks down on the
    floor and the desk it stands over).

    Returns (the chosen plane or None, every plane with its scores filled in).
    """
    points = np.asarray(points, dtype=np.float64)
    hint = None if up_hint is None else np.asarray(up_hint, float) / np.linalg.norm(up_hint)
    for p in planes:
        if hint is not None:
            sign = 1.0 if p.normal @ hint >= 0 else -1.0
        else:
            sd = points @ p.normal + p.offset
            sign = 1.0 if (sd > -2 * distance).mean() >= (sd < 2 * distance).mean() else -1.0
        p.normal, p.offset = sign * p.normal, sign * p.offset
        sd = points @ p.normal + p.offset
        p.above_fraction = float((sd > -2 * distance).mean())
        p.tilt_deg = None if hint is None else float(
            np.degrees(np.arccos(np.clip(p.normal @ hint, -1, 1))))
    ok = [p for p in planes
          if (p.tilt_deg is None or p.tilt_deg <= max_tilt_deg)
          and (camera is None or float(np.asarray(camera) @ p.normal + p.offset) > 0)]
    large = [p for p in ok if p.area_m2 >= min_area_m2] or ok
    if not large:
        return None, planes
    best_above = max(p.above_fraction for p in large)
    low = [p for p in large if p.above_fraction >= best_above - 0.03]
    cos10 = math.cos(math.radians(10))
    for p in low:
        p.support_m2 = sum(q.area_m2 for q in planes if q is not p
                           and abs(float(q.normal @ p.normal)) > cos10
                           and _height_above(q, p) > 2 * distance)
    return max(low, key=lambda p: p.area_m2 + p.support_m2), planes


def _height_above(q: Plane, p: Plane) -> float:
    """Height of plane ``q`` above plane ``p`` along p's normal, at q's inlier centroid."""
    foot = -q.offset * q.normal if q.centre is None else q.centre
    return float(p.normal @ foot + p.offset)


def alignment_transform(normal, offset, x_hint=None, origin=None) -> np.ndarray:
    """4x4 rigid transform putting the plane ``normal . p + offset = 0`` at z = 0, +Z = normal.

    ``x_hint`` (3,) is the input direction that becomes +X after projection onto the plane
    (the camera's right for a frame); None takes the smallest rotation. ``origin`` (3,), an
    input point whose projection onto the plane becomes the new origin; None keeps x, y of
    the smallest rotation.
    """
    n = np.asarray(normal, float)
    n = n / np.linalg.norm(n)
    if x_hint is not None:
        x = np.asarray(x_hint, float) - (np.asarray(x_hint, float) @ n) * n
        if np.linalg.norm(x) < 1e-6:
            x_hint = None
        else:
            x = x / np.linalg.norm(x)
            y = np.cross(n, x)
            rot = np.vstack([x, y, n])
    if x_hint is None:
        rot = rotation_between(n, np.array([0.0, 0.0, 1.0]))
    m = np.eye(4)
    m[:3, :3] = rot
    m[2, 3] = offset      # z' = n . p + d
    if origin is not None:
        o = m[:3, :3] @ np.asarray(origin, float) + m[:3, 3]
        m[0, 3] -= o[0]
        m[1, 3] -= o[1]
    return m


def rotation_between(a, b) -> np.ndarray:
    """Smallest 3x3 rotation R with R a = b for unit vectors a, b (Rodrigues)."""
    a = np.asarray(a, float) / np.linalg.norm(a)
    b = np.asarray(b, float) / np.linalg.norm(b)
    v = np.cross(a, b)
    c = float(a @ b)
    if c < -1 + 1e-12:     # opposite: turn by pi about any axis perpendicular to a
        axis = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
        axis /= np.linalg.norm(axis)
        return 2 * np.outer(axis, axis) - np.eye(3)
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + k + k @ k / (1 + c)


def gravity_align(points, up_hint=None, max_tilt_deg: float = 45.0, camera=None,
                  distance: float = 0.02, search_voxel: float = 0.03, max_planes: int = 10,
                  seed: int = 0, x_hint=None) -> tuple[np.ndarray, dict]:
    """Find the floor (or dominant supporting plane) and the transform that levels it.

    Parameters
    ----------
    points : (N, 3) float, metres, input frame
    up_hint : (3,) rough up direction in the input frame, or None to search all directions
    max_tilt_deg : candidates must lie within this angle of ``up_hint``
    camera : (3,) sensor position in the input frame, or None; the chosen plane must lie
        below it, and the aligned frame puts the camera above the origin with +X its right
    distance : RANSAC inlier distance (m)
    search_voxel : the plane search runs on a copy down-sampled to this voxel (m); each
        plane is then refitted on the full points within ``distance`` of it
    seed : seed of Open3D's RANSAC

    Returns
    -------
    transform : (4, 4) rigid, input frame -> aligned frame (+Z up, the plane at z = 0)
    report : dict: the plane in the input frame, whether it looks like a floor or another
        support (desk), its tilt, the camera height, the candidates, seconds
    """
    t0 = time.perf_counter()
    points = np.asarray(points, dtype=np.float64)
    coarse = points
    if search_voxel and search_voxel > 0 and len(points) > 2000:
        coarse, _ = voxel_down_sample(points, None, search_voxel)
    cell = max(search_voxel or 0.0, distance / 2)
    planes = candidate_planes(coarse, distance, max_planes, seed=seed, cell=cell)
    chosen, planes = choose_support_plane(coarse, planes, up_hint, max_tilt_deg, camera, distance)
    if chosen is None:
        where = "" if up_hint is None else f" within {max_tilt_deg:g} deg of up"
        raise InputError(None, f"gravity alignment found no supporting plane{where} among "
                               f"{len(planes)} RANSAC planes; give the up direction (up=, --up) or skip the alignment (align=False, --no-align)")
    # refine on the full-resolution points near the chosen plane
    near = np.abs(points @ chosen.normal + chosen.offset) < distance
    if near.sum() >= 3:
        normal, offset = fit_plane(points[near])
        if normal @ chosen.normal < 0:
            normal, offset = -normal, -offset
    else:
        normal, offset = chosen.normal, chosen.offset
    if x_hint is None and camera is not None:
        x_hint = (1.0, 0.0, 0.0)
    transform = alignment_transform(normal, offset, x_hint=x_hint, origin=camera)
    # a parallel plane below the chosen one would mean it is not the floor
    refined = Plane(normal, offset, chosen.inliers, chosen.area_m2)
    heights = sorted(_height_above(q, refined) for q in planes
                     if q is not chosen and abs(float(q.normal @ normal)) > math.cos(
                         math.radians(10)))
    kind = "floor" if chosen.above_fraction > 0.97 else "support"
    report = {
        "plane_input_frame": {"normal": [float(v) for v in normal], "offset": float(offset),
                              "equation": "height = normal . p + offset (input frame, metres)"},
        "kind": kind,
        "plane_points_above_fraction": round(chosen.above_fraction, 4),
        "plane_area_m2": round(chosen.area_m2, 3),
        "tilt_from_hint_deg": None if up_hint is None else round(float(np.degrees(np.arccos(
            np.clip(normal @ (np.asarray(up_hint, float) / np.linalg.norm(up_hint)), -1, 1)))), 3),
        "parallel_planes_heights_m": [round(h, 3) for h in heights],
        "candidates": [p.to_dict() for p in planes],
        "ransac": {"distance_m": distance, "search_voxel_m": search_voxel,
                   "max_planes": max_planes, "seed": seed},
        "seconds": round(time.perf_counter() - t0, 4),
    }
    if camera is not None:
        report["camera_height_m"] = round(float(np.asarray(camera) @ normal + offset), 4)
    return transform, report


def rotation_between_frames() -> np.ndarray:
    """Optical camera frame (x right, y down, z forward) -> level frame (x right, y forward,
    z up): (x, y, z) -> (x, z, -y)."""
    return np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])


def _up_hint(up, is_frame: bool, max_tilt_deg):
    """(hint vector or None, max tilt) from the ``up`` argument."""
    if up is None or (isinstance(up, str) and up == "auto"):
        if is_frame:
            return CAMERA_UP, 75.0 if max_tilt_deg is None else max_tilt_deg
        return None, 180.0 if max_tilt_deg is None else max_tilt_deg
    if isinstance(up, str):
        if up not in AXES:
            raise SettingsError(f"up must be 'auto', one of {sorted(AXES)} or x,y,z; got {up!r}")
        vec = np.array(AXES[up])
    else:
        vec = np.asarray(up, dtype=float).reshape(3)
        if not (np.isfinite(vec).all() and np.linalg.norm(vec) > 0):
            raise SettingsError("up must be a non-zero 3-vector")
    return vec / np.linalg.norm(vec), 45.0 if max_tilt_deg is None else max_tilt_deg
