"""Real captured scenes: RGB-D frames and scanned point clouds, cleaned and gravity-aligned.

The paper's second experiment runs single-example tensors on RGB-D captures whose only
pre-processing is a ground-plane calibration. This module turns such data into a
:class:`~interaction_tensor.scene.Scene` in the library's frame (metres, +Z up, supporting
plane at z = 0) and remembers the transform back to the input's own frame.

Data flow::

    RGB-D frame (colour.png, depth.png, intrinsics.json) --back-projection--+
    scanned cloud / mesh (PLY, PCD, ...; --scale) --------------------------+
        -> voxel down-sampling (target spacing)        [optional, reported]
        -> statistical outlier removal                 [optional, reported]
        -> normals (PCA, Open3D)
        -> gravity alignment: RANSAC planes, pick the floor / supporting plane,
           rotate it to +Z and put it at z = 0           [optional: --no-align]
        -> normals oriented (towards the camera for a frame, else +Z)
        -> Scene  +  RealSceneReport (steps, seconds, 4x4 transform input -> aligned)

Three lines of Python::

    import interaction_tensor as it
    from interaction_tensor import realdata
    geometry, camera = realdata.rgbd_to_geometry("color.png", "depth.png",
                                                 realdata.load_intrinsics("intrinsics.json"))
    scene, report = realdata.prepare_real_scene(geometry, spacing=0.02, camera=camera)
    result = it.detect(scene, it.InteractionTensor.load("placing-bowl.npz"))

Open3D (``pip install 'interaction-tensor[open3d]'``) is needed for down-sampling, outlier
removal, normals and plane fitting; it is imported lazily. Images are read with Pillow.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import InputError, SettingsError
from .io import Geometry, validate_geometry, write_json, write_mesh, write_ply_points

#: Depth conventions when neither the intrinsics file nor the caller gives them: 1000 units
#: per metre (millimetre PNGs of Kinect v2, RealSense, Azure Kinect) and 3 m truncation,
#: Open3D's defaults for ``RGBDImage.create_from_color_and_depth``.
DEFAULT_DEPTH_SCALE = 1000.0
DEFAULT_DEPTH_TRUNC = 3.0

#: Largest scene extent (m) that does not trigger the "wrong units?" warning.
PLAUSIBLE_EXTENT_M = 30.0

#: Optical camera frame: +x right, +y down, +z forward. "Up" for a camera held level.
CAMERA_UP = np.array([0.0, -1.0, 0.0])

AXES = {"x": (1.0, 0, 0), "y": (0, 1.0, 0), "z": (0, 0, 1.0),
        "-x": (-1.0, 0, 0), "-y": (0, -1.0, 0), "-z": (0, 0, -1.0)}

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


# ============================================================================ intrinsics
@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics and depth convention of one RGB-D frame.

    Attributes
    ----------
    width, height : image size in pixels
    fx, fy : focal lengths in pixels
    cx, cy : principal point in pixels (0 is the centre of the first pixel)
    depth_scale : depth-image units per metre (5000 for TUM, 1000 for millimetre PNGs)
    depth_trunc : depth beyond this (m) is ignored
    source : where the values came from
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    depth_scale: float = DEFAULT_DEPTH_SCALE
    depth_trunc: float = DEFAULT_DEPTH_TRUNC
    source: str = "<intrinsics>"

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in ("width", "height", "fx", "fy", "cx", "cy",
                                              "depth_scale", "depth_trunc", "source")}


def load_intrinsics(path, overrides: dict | None = None) -> Intrinsics:
    """Read and validate camera intrinsics from a JSON file.

    Two layouts are accepted: flat keys ``width height fx fy cx cy`` (optionally
    ``depth_scale depth_trunc``), as in ``shared/data/rgbd/tum_desk/intrinsics.json``; and
    Open3D's ``PinholeCameraIntrinsic`` JSON (``width``, ``height``, ``intrinsic_matrix``: 9
    values, column-major).

    Parameters
    ----------
    path : str or Path, the JSON file
    overrides : dict or None; non-None values replace the file's (e.g. ``depth_scale``,
        ``depth_trunc`` from the command line)

    Raises :class:`InputError` naming ``path`` when a value is missing, not a number, not
    finite or not positive, or the principal point lies outside the image.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(path, "no such file")
    if path.is_dir():
        raise InputError(path, "is a directory, expected an intrinsics JSON file")
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(path, f"cannot read: {exc}") from None
    except json.JSONDecodeError as exc:
        raise InputError(path, f"not valid JSON ({exc.msg} at line {exc.lineno})") from None
    if not isinstance(data, dict):
        raise InputError(path, "expected a JSON object with width, height, fx, fy, cx, cy")
    data = dict(data)
    if "intrinsic_matrix" in data and "fx" not in data:     # Open3D layout, column-major
        m = data["intrinsic_matrix"]
        if not (isinstance(m, list) and len(m) == 9):
            raise InputError(path, "intrinsic_matrix must hold 9 numbers")
        data.update(fx=m[0], fy=m[4], cx=m[6], cy=m[7])
    for key, value in (overrides or {}).items():
        if value is not None:
            data[key] = value
    values = {}
    for key in ("width", "height", "fx", "fy", "cx", "cy"):
        if key not in data:
            raise InputError(path, f"intrinsics lack {key!r} (need width, height, fx, fy, cx, cy)")
        values[key] = _number(path, key, data[key])
    for key, default in (("depth_scale", DEFAULT_DEPTH_SCALE), ("depth_trunc", DEFAULT_DEPTH_TRUNC)):
        values[key] = _number(path, key, data.get(key, default))
    for key in ("width", "height"):
        if values[key] != int(values[key]):
            raise InputError(path, f"{key} must be a whole number of pixels, got {values[key]}")
    for key in ("width", "height", "fx", "fy", "depth_scale", "depth_trunc"):
        if not values[key] > 0:
            raise InputError(path, f"{key} must be positive, got {values[key]}")
    if not 0 <= values["cx"] <= values["width"]:
        raise InputError(path, f"cx={values['cx']} lies outside the image width {values['width']:.0f}")
    if not 0 <= values["cy"] <= values["height"]:
        raise InputError(path, f"cy={values['cy']} lies outside the image height {values['height']:.0f}")
    return Intrinsics(int(values["width"]), int(values["height"]), values["fx"], values["fy"],
                      values["cx"], values["cy"], values["depth_scale"], values["depth_trunc"],
                      str(path))


def _number(path, key, value) -> float:
    if isinstance(value, bool):
        raise InputError(path, f"{key} must be a number, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InputError(path, f"{key} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise InputError(path, f"{key} must be finite, got {value!r}")
    return number


# ============================================================================ RGB-D frames
def _open_image(path, what: str):
    from PIL import Image, UnidentifiedImageError

    path = Path(path)
    if not path.exists():
        raise InputError(path, "no such file")
    if path.is_dir():
        raise InputError(path, f"is a directory, expected a {what} image")
    try:
        image = Image.open(path)
        image.load()
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise InputError(path, f"cannot read as an image: {exc}") from None
    return image


def read_depth(path, intrinsics: Intrinsics) -> np.ndarray:
    """Depth image in metres, (H, W) float64; 0 where there is no data or beyond truncation.

    The image must be single-channel (16-bit PNG as written by Kinect, RealSense, TUM; 32-bit
    integer or float TIFF also work): ``metres = value / depth_scale``.
    """
    image = _open_image(path, "depth")
    if image.mode not in ("I;16", "I;16B", "I;16L", "I", "F"):
        raise InputError(path, f"depth must be a single-channel 16-bit (or 32-bit) image, "
                               f"got mode {image.mode!r}")
    if image.size != (intrinsics.width, intrinsics.height):
        raise InputError(path, f"depth image is {image.size[0]}x{image.size[1]} but the "
                               f"intrinsics ({intrinsics.source}) are for "
                               f"{intrinsics.width}x{intrinsics.height}")
    raw = np.asarray(image).astype(np.float64)
    depth = raw / intrinsics.depth_scale
    depth[~np.isfinite(depth) | (depth <= 0) | (depth > intrinsics.depth_trunc)] = 0.0
    return depth


def read_color(path, size) -> np.ndarray:
    """Colour image as (H, W, 3) uint8 RGB; ``size`` = (width, height) it must have."""
    image = _open_image(path, "colour")
    if image.size != tuple(size):
        raise InputError(path, f"colour image is {image.size[0]}x{image.size[1]} but the depth "
                               f"image is {size[0]}x{size[1]}; register and resize them first")
    if image.mode in ("I;16", "I;16B", "I;16L", "I", "F"):
        raise InputError(path, f"colour image has mode {image.mode!r}; is it the depth image?")
    return np.asarray(image.convert("RGB"))


def back_project(depth: np.ndarray, intrinsics: Intrinsics) -> tuple[np.ndarray, np.ndarray]:
    """Pixels with depth -> 3D points in the optical camera frame (vectorised).

    Parameters
    ----------
    depth : (H, W) float, metres; 0 = no data

    Returns
    -------
    points : (M, 3) float64, metres; +x right, +y down, +z forward
    valid : (H, W) bool, the pixels the points came from (row-major order)
    """
    valid = depth > 0
    v, u = np.nonzero(valid)
    z = depth[v, u]
    x = (u - intrinsics.cx) * z / intrinsics.fx
    y = (v - intrinsics.cy) * z / intrinsics.fy
    return np.column_stack([x, y, z]), valid


def rgbd_to_geometry(color_path, depth_path, intrinsics) -> tuple[Geometry, np.ndarray]:
    """Back-project an RGB-D frame into a coloured point cloud in the camera frame.

    Parameters
    ----------
    color_path : str, Path or None; a colour image registered to the depth image (any
        format Pillow reads). None: no colours.
    depth_path : str or Path, a single-channel depth image
    intrinsics : :class:`Intrinsics` or a path to an intrinsics JSON file

    Returns
    -------
    geometry : Geometry point cloud, metres, optical camera frame (+x right, +y down,
        +z forward), ``colors`` (N, 3) uint8 when a colour image was given
    camera : (3,) float64, the camera centre in that frame (the origin)

    Raises :class:`InputError` naming the file for unreadable images, images whose size
    differs from each other or from the intrinsics, or a frame with no valid depth.
    """
    if not isinstance(intrinsics, Intrinsics):
        intrinsics = load_intrinsics(intrinsics)
    depth = read_depth(depth_path, intrinsics)
    points, valid = back_project(depth, intrinsics)
    colors = None
    if color_path is not None:
        colors = read_color(color_path, (intrinsics.width, intrinsics.height))[valid]
    if len(points) < 4:
        raise InputError(depth_path, f"no valid depth: {len(points)} pixels between 0 and "
                                     f"depth_trunc={intrinsics.depth_trunc} m "
                                     f"(depth_scale {intrinsics.depth_scale:g} units per metre)")
    geometry = Geometry(points, None, None, colors, str(depth_path))
    return validate_geometry(geometry, depth_path), np.zeros(3)


# ============================================================================ cleaning
def voxel_down_sample(points, colors=None, voxel_size: float = 0.01):
    """Average the points (and colours) in each ``voxel_size`` (m) cube.

    Returns (points (M, 3) float64, colors (M, 3) uint8 or None).
    """
    if not voxel_size > 0:
        raise SettingsError("voxel_size must be positive (metres)")
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
                               f"{len(planes)} RANSAC planes; pass --up or --no-align")
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


# ============================================================================ pipeline
@dataclass
class RealSceneReport:
    """What :func:`prepare_real_scene` did, for ``predictions.json``.

    Attributes
    ----------
    source : the input (a file, or "color + depth" of a frame)
    kind : ``"rgbd"`` or ``"scan"``
    transform : (4, 4) input frame -> aligned (scene) frame; includes ``scale`` when the
        input was scaled, so that it maps the file's own coordinates
    scale : the factor applied to the input's coordinates to get metres
    steps : one dict per step: name, points before/after, parameters, seconds
    alignment : the gravity-alignment report (None when skipped)
    camera_input, camera_aligned : (3,) sensor position in both frames, or None
    normals : how normals were oriented: ``"camera"``, ``"up"`` or ``"none"``
    colors : (N, 3) uint8 colours of the scene points, or None (not written to JSON)
    warnings : things the user should check (units, no plane found, ...)
    seconds : per stage
    """

    source: str
    kind: str
    transform: np.ndarray
    scale: float = 1.0
    steps: list = field(default_factory=list)
    alignment: dict | None = None
    camera_input: np.ndarray | None = None
    camera_aligned: np.ndarray | None = None
    normals: str = "none"
    colors: np.ndarray | None = None
    warnings: list = field(default_factory=list)
    seconds: dict = field(default_factory=dict)
    intrinsics: dict | None = None

    @property
    def inverse(self) -> np.ndarray:
        """(4, 4) aligned frame -> input frame."""
        return np.linalg.inv(self.transform)

    def to_dict(self) -> dict:
        return {
            "source": self.source, "kind": self.kind, "scale": self.scale,
            "transform_input_to_aligned": np.asarray(self.transform).tolist(),
            "transform_aligned_to_input": self.inverse.tolist(),
            "transform_convention": "x_aligned = T @ [x_input, 1]; the aligned frame is "
                                    "metres, +Z up, the supporting plane at z = 0",
            "aligned": self.alignment is not None,
            "alignment": self.alignment,
            "camera_input_frame": None if self.camera_input is None
            else [float(v) for v in self.camera_input],
            "camera_aligned_frame": None if self.camera_aligned is None
            else [float(v) for v in self.camera_aligned],
            "normals_oriented": self.normals,
            "intrinsics": self.intrinsics,
            "steps": self.steps,
            "warnings": self.warnings,
            "seconds": {k: round(v, 4) for k, v in self.seconds.items()},
        }


def unit_warnings(points, name: str = "scene") -> list[str]:
    """Warnings when a scene's extent (m) looks like millimetres or centimetres."""
    extent = float(np.ptp(np.asarray(points), axis=0).max())
    if extent > PLAUSIBLE_EXTENT_M:
        guess = "millimetres (--scale 0.001)" if extent > 3000 else "centimetres (--scale 0.01)" \
            if extent > 300 else "centimetres or inches (--scale 0.01 or 0.0254)"
        return [f"{name}: extent {extent:.1f} m is large for a captured scene; are the units "
                f"{guess}?"]
    if extent < 0.05:
        return [f"{name}: extent {extent * 1000:.1f} mm is tiny for a scene; is --scale right?"]
    return []


def prepare_real_scene(geometry: Geometry, spacing: float = 0.01, camera=None, *,
                       align: bool = True, up="auto", max_tilt_deg: float | None = None,
                       voxel_size: float | None = None, remove_outliers: bool = True,
                       outlier_neighbors: int = 20, outlier_std: float = 2.0,
                       plane_distance: float = 0.02, normals: str | None = None,
                       scale: float = 1.0, kind: str | None = None, seed: int = 0,
                       max_points: int = 5_000_000):
    """Clean and gravity-align a captured scene, and wrap it as a :class:`Scene`.

    Parameters
    ----------
    geometry : Geometry, metres (already multiplied by ``scale``); a point cloud (RGB-D
        frame, scan) or a mesh (sampled at ``spacing / 2`` first)
    spacing : target point spacing (m): the voxel size unless ``voxel_size`` says otherwise;
        use the descriptor's ``scene_spacing``
    camera : (3,) sensor position in the input frame (the origin for a frame), or None
    align : find the floor / supporting plane and level it (else keep the input axes;
        for a frame, the camera is assumed level: camera -Y becomes +Z)
    up : rough up direction of the input: ``"auto"`` (a frame: camera -Y within 75 deg;
        a file: every direction), an axis name (``"z"``, ``"y"``, ``"-y"``, ...) or (3,)
    max_tilt_deg : largest angle between ``up`` and the plane's normal (default 75 for a
        frame's camera -Y, 45 for an axis given by the user)
    voxel_size : voxel edge (m); None: ``spacing``; 0: no down-sampling
    remove_outliers : statistical outlier removal with ``outlier_neighbors`` and
        ``outlier_std`` (Open3D's ``remove_statistical_outlier``)
    plane_distance : RANSAC inlier distance (m)
    normals : ``"camera"`` (default with a camera), ``"up"`` (default otherwise) or ``"none"``
    scale : the factor already applied to the input (recorded in the transform)
    kind : ``"rgbd"`` or ``"scan"`` (default: ``"rgbd"`` when ``camera`` is given)

    Returns
    -------
    scene : Scene in the aligned frame (metres, +Z up, plane at z = 0), normals oriented
    report : :class:`RealSceneReport` (transform input -> aligned, steps, seconds, colours)
    """
    from .scene import Scene
    from .sampling import mean_spacing, mesh_area, sample_mesh

    if not (spacing and spacing > 0):
        raise SettingsError("spacing must be positive (metres)")
    kind = kind or ("rgbd" if camera is not None else "scan")
    normals_mode = normals or ("camera" if camera is not None else "up")
    if normals_mode not in ("camera", "up", "none"):
        raise SettingsError("normals must be 'camera', 'up' or 'none'")
    if normals_mode == "camera" and camera is None:
        raise SettingsError("normals='camera' needs a camera position")
    validate_geometry(geometry)
    report = RealSceneReport(str(geometry.source), kind, np.eye(4), float(scale))
    t_all = time.perf_counter()
    cam = None if camera is None else np.asarray(camera, dtype=np.float64).reshape(3)
    report.camera_input = None if cam is None else cam / scale

    points, colors = geometry.vertices, geometry.colors
    if geometry.is_mesh:
        t = time.perf_counter()
        count = int(np.clip(round(mesh_area(geometry) / (spacing / 2) ** 2), 100, max_points))
        points, _ = sample_mesh(geometry, count, seed)
        colors = None
        _step(report, "mesh_sampling", len(geometry.vertices), len(points),
              {"samples": count, "spacing_m": spacing / 2}, t)
    report.warnings += unit_warnings(points, Path(str(geometry.source)).name)

    voxel = spacing if voxel_size is None else float(voxel_size)
    if voxel > 0:
        t = time.perf_counter()
        n0 = len(points)
        points, colors = voxel_down_sample(points, colors, voxel)
        _step(report, "voxel_down_sample", n0, len(points), {"voxel_size_m": voxel}, t)
    if remove_outliers and len(points) > outlier_neighbors + 1:
        t = time.perf_counter()
        n0 = len(points)
        keep = remove_statistical_outliers(points, outlier_neighbors, outlier_std)
        points = points[keep]
        colors = None if colors is None else colors[keep]
        _step(report, "statistical_outlier_removal", n0, len(points),
              {"nb_neighbors": outlier_neighbors, "std_ratio": outlier_std}, t)
    if len(points) > max_points:
        t = time.perf_counter()
        idx = np.sort(np.random.default_rng(seed).choice(len(points), max_points, replace=False))
        _step(report, "random_subsample", len(points), max_points, {"max_points": max_points}, t)
        points = points[idx]
        colors = None if colors is None else colors[idx]
    if len(points) < 10:
        raise InputError(geometry.source, f"only {len(points)} points left after cleaning; "
                                          "try a smaller --voxel-size or --no-remove-outliers")

    # gravity alignment
    t = time.perf_counter()
    hint, tilt = _up_hint(up, cam is not None, max_tilt_deg)
    if align:
        transform, report.alignment = gravity_align(
            points, hint, tilt, cam, plane_distance, max(0.03, voxel), seed=seed)
        if report.alignment["kind"] == "support":
            report.warnings.append(
                "no floor seen: the supporting plane chosen (points above: "
                f"{report.alignment['plane_points_above_fraction']:.0%}) is put at z = 0")
    elif cam is not None and up == "auto":   # a frame, camera assumed level
        transform = np.eye(4)
        transform[:3, :3] = rotation_between_frames()
    elif hint is not None:
        transform = np.eye(4)
        transform[:3, :3] = rotation_between(hint, (0.0, 0.0, 1.0))
    else:
        transform = np.eye(4)
    report.seconds["alignment"] = time.perf_counter() - t
    points = points @ transform[:3, :3].T + transform[:3, 3]
    cam_aligned = None if cam is None else transform[:3, :3] @ cam + transform[:3, 3]
    report.camera_aligned = cam_aligned

    # normals, oriented
    t = time.perf_counter()
    from scipy.spatial import cKDTree

    tree = cKDTree(points)
    step = mean_spacing(points, tree)
    nrm = estimate_normals_o3d(points, radius=max(3.0 * max(voxel, step), 1e-6), max_nn=30)
    if normals_mode == "camera":
        nrm = orient_normals(points, nrm, cam_aligned)
    elif normals_mode == "up":
        nrm = orient_normals(points, nrm, "up")
    report.normals = normals_mode
    _step(report, "normals", len(points), len(points),
          {"radius_m": round(3.0 * max(voxel, step), 5), "max_nn": 30, "oriented": normals_mode}, t)

    s = np.eye(4)
    s[:3, :3] *= scale
    report.transform = transform @ s
    report.colors = colors
    report.seconds["total"] = time.perf_counter() - t_all
    scene = Scene(points, nrm, step, str(geometry.source), sampled=False, _tree=tree)
    return scene, report


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


def _step(report: RealSceneReport, name: str, before: int, after: int, params: dict, t0) -> None:
    seconds = time.perf_counter() - t0
    report.steps.append({"step": name, "points_before": int(before), "points_after": int(after),
                         "parameters": params, "seconds": round(seconds, 4)})
    report.seconds[name] = seconds


def load_rgbd(color_path, depth_path, intrinsics_path, depth_scale=None, depth_trunc=None):
    """Intrinsics + back-projection in one call: (Geometry in the camera frame, camera (3,),
    Intrinsics)."""
    intr = load_intrinsics(intrinsics_path, {"depth_scale": depth_scale,
                                             "depth_trunc": depth_trunc})
    geometry, camera = rgbd_to_geometry(color_path, depth_path, intr)
    return geometry, camera, intr


# ============================================================================ outputs
def write_input_frame_outputs(detection, outdir, transform, report: RealSceneReport | None = None,
                              write_scene: bool = True) -> dict:
    """Write the detection in the input's own frame next to ``it.export``'s aligned files.

    Files (all atomic): ``predictions_input_frame.json`` (every prediction's position and
    pose mapped by ``inverse(transform)``), ``heatmap_input_frame.ply``,
    ``top_input_frame/top_XX.ply``; with ``report`` colours, ``scene.ply`` (aligned) and
    ``scene_input_frame.ply`` carry the captured colours. When ``predictions.json`` exists in
    ``outdir`` (written by ``it.export``), a ``real_scene`` block (transform, alignment,
    cleaning steps, warnings) is added to it.

    Parameters
    ----------
    detection : Detection of the aligned scene
    transform : (4, 4) input -> aligned (``report.transform``; may include a scale)

    Returns the document written to ``predictions_input_frame.json``.
    """
    from .predictions import colormap

    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    transform = np.asarray(transform, dtype=np.float64)
    inv = np.linalg.inv(transform)
    det = detection
    scene_pts = det.scene.points
    pts_in = scene_pts @ inv[:3, :3].T + inv[:3, 3]

    lo = det.threshold if det.threshold < 1 else 0.0
    colors = colormap(np.where(det.heat > 0, det.heat, 0), vmin=lo, vmax=1.0)
    write_ply_points(outdir / "heatmap_input_frame.ply", pts_in, colors=colors,
                     score=det.heat, accepted=det.accepted_count)
    top = outdir / "top_input_frame"
    top.mkdir(exist_ok=True)
    for old in top.glob("top_*.ply"):
        old.unlink()
    tensor = det.tensor
    preds = []
    for rank, p in enumerate(det.predictions, 1):
        pose_in = inv @ np.asarray(p.pose)
        v = tensor.query_vertices @ pose_in[:3, :3].T + pose_in[:3, 3]
        write_mesh(top / f"top_{rank:02d}.ply", v,
                   tensor.query_faces if tensor.query_is_mesh else None, color=(230, 60, 40, 255))
        pos = inv[:3, :3] @ np.asarray(p.position) + inv[:3, 3]
        preds.append({"rank": rank, "position": [float(x) for x in pos],
                      "position_aligned": [float(x) for x in p.position],
                      "orientation_index": p.orientation_index, "angle": p.angle,
                      "score": p.score, "pose": pose_in.tolist(), "point_index": p.point_index})
    if report is not None and write_scene and report.colors is not None \
            and len(report.colors) == len(scene_pts):
        write_ply_points(outdir / "scene.ply", scene_pts, colors=report.colors,
                         normals=det.scene.normals)
        write_ply_points(outdir / "scene_input_frame.ply", pts_in, colors=report.colors)
    doc = {
        "frame": "input",
        "transform_input_to_aligned": transform.tolist(),
        "transform_aligned_to_input": inv.tolist(),
        "pose_convention": "x_input = pose @ [x_query_training_frame, 1] (pose = "
                           "transform_aligned_to_input @ aligned pose; includes the input "
                           "scale when there was one)",
        "predictions": preds,
    }
    write_json(outdir / "predictions_input_frame.json", doc)
    main = outdir / "predictions.json"
    if main.exists():
        summary = json.loads(main.read_text())
        block = report.to_dict() if report is not None else {
            "transform_input_to_aligned": transform.tolist(),
            "transform_aligned_to_input": inv.tolist()}
        block["input_frame_outputs"] = ["predictions_input_frame.json",
                                        "heatmap_input_frame.ply", "top_input_frame/"]
        summary["real_scene"] = block
        write_json(main, summary)
    return doc


# ============================================================================ CLI glue
def _axis_or_vector(text: str):
    import argparse

    if text in AXES or text == "auto":
        return text
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected auto, an axis (z, y, -y, ...) or x,y,z; "
                                         f"got {text!r}") from None
    if len(values) != 3 or not any(values):
        raise argparse.ArgumentTypeError(f"expected three numbers, not all zero: {text!r}")
    return values


def add_realdata_options(parser) -> None:
    """Add the RGB-D / scan / alignment / cleaning options to an ``itensor detect`` parser.

    If the parser already has ``--up`` (``choices=("z", "y")``, default ``z``), it is widened
    to ``auto``, the other axes and x,y,z, with default ``auto``; otherwise ``--up`` is added
    (default ``auto``). For a plain scene file (no --scan, not a frame) ``auto`` means ``z``,
    the old default, so mesh scenes behave exactly as before.
    """
    import argparse

    g = parser.add_argument_group(
        "real scenes (RGB-D frames, scans)",
        "An RGB-D frame is given with --depth and --intrinsics (and --color), or as a directory "
        "holding color.png, depth.png and intrinsics.json in place of SCENE. --scan treats a "
        "scene file as a captured cloud. Both are cleaned and gravity-aligned.")
    g.add_argument("--color", help="colour image registered to the depth image")
    g.add_argument("--depth", help="depth image (single-channel 16-bit PNG)")
    g.add_argument("--intrinsics", help="JSON with width, height, fx, fy, cx, cy "
                                        "[, depth_scale, depth_trunc]")
    g.add_argument("--depth-scale", type=float, default=None,
                   help="depth units per metre (overrides the JSON; TUM 5000, mm PNG 1000)")
    g.add_argument("--depth-trunc", type=float, default=None,
                   help="ignore depth beyond this many metres (overrides the JSON)")
    g.add_argument("--scan", action="store_true",
                   help="SCENE is a captured point cloud (or scanned mesh): clean and align it")
    g.add_argument("--no-align", action="store_true",
                   help="skip gravity alignment (a frame's camera is then assumed level)")
    g.add_argument("--max-tilt", type=float, default=None,
                   help="largest angle (deg) between --up and the supporting plane's normal")
    g.add_argument("--plane-distance", type=float, default=0.02,
                   help="RANSAC inlier distance in metres (default 0.02)")
    g.add_argument("--voxel-size", type=float, default=None,
                   help="voxel down-sampling edge in metres (default: the descriptor's "
                        "spacing; 0 = none)")
    g.add_argument("--remove-outliers", action=argparse.BooleanOptionalAction, default=True,
                   help="statistical outlier removal (default on)")
    g.add_argument("--outlier-neighbors", type=int, default=20)
    g.add_argument("--outlier-std", type=float, default=2.0)
    g.add_argument("--orient-normals", choices=("camera", "up", "none"), default=None,
                   help="normal orientation (default: camera for a frame, up for a scan)")
    up_help = ("up direction of the input: auto (a frame: camera -Y; a scan: search every "
               "direction), z, y, -y, ... or x,y,z")
    existing = getattr(parser, "_option_string_actions", {}).get("--up")
    if existing is not None:      # widen the detect parser's --up z|y (default z -> auto;
        existing.choices = None   # a plain scene file still reads auto as z)
        existing.type = _axis_or_vector
        existing.default = "auto"
        parser.set_defaults(up="auto")
        existing.help = up_help
    else:
        g.add_argument("--up", type=_axis_or_vector, default="auto", help=up_help)


def is_real_input(args) -> bool:
    """True when ``args`` ask for the real-scene pipeline (a frame, a frame directory, --scan)."""
    if any(getattr(args, k, None) for k in ("color", "depth", "intrinsics")):
        return True
    scene = getattr(args, "scene", None)
    return bool(getattr(args, "scan", False)) or (scene is not None and Path(scene).is_dir())


def frame_paths(args):
    """(color, depth, intrinsics) paths of the frame ``args`` describe.

    A directory given as SCENE supplies ``color.png``, ``depth.png`` and
    ``intrinsics.json``; the explicit options take precedence.
    """
    scene = getattr(args, "scene", None)
    color, depth, intr = args.color, args.depth, args.intrinsics
    if scene is not None and Path(scene).is_dir():
        d = Path(scene)
        color = color or (str(d / "color.png") if (d / "color.png").exists() else None)
        depth = depth or str(d / "depth.png")
        intr = intr or str(d / "intrinsics.json")
    elif scene is not None and (depth or intr):
        raise InputError(scene, "give either a scene file or an RGB-D frame "
                                "(--depth/--intrinsics), not both")
    if not depth:
        raise InputError(intr or color, "an RGB-D frame needs --depth (and --intrinsics)")
    if not intr:
        raise InputError(depth, "an RGB-D frame needs --intrinsics (a JSON file)")
    return color, depth, intr


def scene_from_args(args, default_spacing: float):
    """Build the detection scene from ``itensor detect`` arguments.

    Parameters
    ----------
    args : argparse namespace with the options of :func:`add_realdata_options` plus
        ``scene``, ``scale``, ``up``, ``seed`` and ``spacing`` (the detect parser's)
    default_spacing : the descriptor's ``scene_spacing`` (m)

    Returns
    -------
    scene : Scene in the aligned frame
    report : :class:`RealSceneReport` (``.to_dict()`` for JSON; ``.colors`` for the coloured
        scene export), or None when the input is a plain scene file (no --scan, not a
        frame): then the scene is prepared exactly as before (``prepare_scene``)
    transform : (4, 4) input -> aligned, or None
    """
    from .io import load_geometry
    from .scene import prepare_scene

    spacing = getattr(args, "spacing", None) or default_spacing
    seed = getattr(args, "seed", 0)
    scale = getattr(args, "scale", 1.0) or 1.0
    up = getattr(args, "up", "auto")
    if not is_real_input(args):
        if getattr(args, "scene", None) is None:
            raise InputError(None, "give a scene file, an RGB-D frame directory, or "
                                   "--depth and --intrinsics (and --color)")
        if not (up in ("z", "y", "auto") if isinstance(up, str) else False):
            raise InputError(args.scene, f"--up {up} needs --scan (a plain scene file takes "
                                         "--up z or y)")
        geometry = load_geometry(args.scene, scale, "z" if up == "auto" else up)
        return prepare_scene(geometry, spacing, seed), None, None
    options = dict(align=not getattr(args, "no_align", False),
                   max_tilt_deg=getattr(args, "max_tilt", None),
                   voxel_size=getattr(args, "voxel_size", None),
                   remove_outliers=getattr(args, "remove_outliers", True),
                   outlier_neighbors=getattr(args, "outlier_neighbors", 20),
                   outlier_std=getattr(args, "outlier_std", 2.0),
                   plane_distance=getattr(args, "plane_distance", 0.02),
                   normals=getattr(args, "orient_normals", None), seed=seed)
    if getattr(args, "plane_distance", 0.02) is not None and not args.plane_distance > 0:
        raise SettingsError("--plane-distance must be positive (metres)")
    scene_path = getattr(args, "scene", None)
    if any(getattr(args, k, None) for k in ("color", "depth", "intrinsics")) or (
            scene_path is not None and Path(scene_path).is_dir()):
        color, depth, intr_path = frame_paths(args)
        t = time.perf_counter()
        geometry, camera, intr = load_rgbd(color, depth, intr_path,
                                           getattr(args, "depth_scale", None),
                                           getattr(args, "depth_trunc", None))
        t_conv = time.perf_counter() - t
        geometry.source = f"{depth}" + (f" + {color}" if color else "")
        scene, report = prepare_real_scene(geometry, spacing, camera, up=up, **options)
        report.intrinsics = intr.to_dict()
        report.steps.insert(0, {"step": "rgbd_back_projection", "points_before":
                                intr.width * intr.height, "points_after": len(geometry.vertices),
                                "parameters": {"depth_scale": intr.depth_scale,
                                               "depth_trunc_m": intr.depth_trunc},
                                "seconds": round(t_conv, 4)})
        report.seconds["rgbd_back_projection"] = t_conv
    else:
        t = time.perf_counter()
        geometry = load_geometry(scene_path, scale, "z")   # the file's own frame (x scale)
        t_load = time.perf_counter() - t
        scene, report = prepare_real_scene(geometry, spacing, None, up=up, scale=scale,
                                           **options)
        report.steps.insert(0, {"step": "load", "points_before": len(geometry.vertices),
                                "points_after": len(geometry.vertices),
                                "parameters": {"scale": scale}, "seconds": round(t_load, 4)})
        report.seconds["load"] = t_load
    return scene, report, report.transform
