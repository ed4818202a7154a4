"""The real-scene pipeline: a captured cloud or scanned mesh cleaned, gravity-aligned and
wrapped as a Scene, with a report of every step."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from interaction_tensor.capture.alignment import (
    _up_hint,
    gravity_align,
    rotation_between,
    rotation_between_frames,
)
from interaction_tensor.capture.cleaning import (
    estimate_normals_o3d,
    orient_normals,
    remove_statistical_outliers,
    voxel_down_sample,
)
from interaction_tensor.errors import InputError, SettingsError
from interaction_tensor.geometry.core import Geometry, validate_geometry
from interaction_tensor.geometry.sampling import mean_spacing, mesh_area, sample_mesh
from interaction_tensor.geometry.scene import Scene, mesh_samples

#: Largest scene extent (m) that does not trigger the "wrong units?" warning.
PLAUSIBLE_EXTENT_M = 30.0


def _check_range(name: str, value, low, high, *, low_open: bool = False,
                 none_ok: bool = False) -> None:
    """Refuse ``value`` (NaN, infinite, out of [low, high]) naming the parameter."""
    if value is None and none_ok:
        return
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SettingsError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v < low or v > high or (low_open and v == low):
        raise SettingsError(f"{name} must be in {'(' if low_open else '['}{low:g}, {high:g}], "
                            f"got {value!r}")


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
    surface_noise : (m) the captured surface's noise (:func:`surface_noise`), 0 without one
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
    surface_noise: float = 0.0

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
            "surface_noise_m": round(float(self.surface_noise), 5),
            "intrinsics": self.intrinsics,
            "steps": self.steps,
            "warnings": self.warnings,
            "seconds": {k: round(v, 4) for k, v in self.seconds.items()},
        }


def unit_warnings(points, name: str = "scene") -> list[str]:
    """Warnings when a scene's extent (m) looks like millimetres or centimetres."""
    extent = float(np.ptp(np.asarray(points), axis=0).max())
    if extent > PLAUSIBLE_EXTENT_M:
        guess = "millimetres (scale 0.001)" if extent > 3000 else "centimetres (scale 0.01)" \
            if extent > 300 else "centimetres or inches (scale 0.01 or 0.0254)"
        return [f"{name}: extent {extent:.1f} m is large for a captured scene; are the units "
                f"{guess}?"]
    if extent < 0.05:
        return [f"{name}: extent {extent * 1000:.1f} mm is tiny for a scene; is the scale right (scale=, --scale)?"]
    return []


def prepare_real_scene(geometry: Geometry, spacing: float = 0.01, camera=None, *,
                       align: bool = True, up="auto", max_tilt_deg: float | None = None,
                       voxel_size: float | None = None, remove_outliers: bool = True,
                       outlier_neighbors: int = 20, outlier_std: float = 2.0,
                       plane_distance: float = 0.02, normals: str | None = None,
                       scale: float = 1.0, kind: str | None = None, seed: int = 0,
                       max_points: int = 5_000_000, surface=None):
    """Clean and gravity-align a captured scene, and wrap it as a :class:`Scene`.

    Parameters
    ----------
    geometry : Geometry, metres (already multiplied by ``scale``); a point cloud (RGB-D
        frame, scan) or a mesh (sampled at ``spacing / 2`` first; refused before that when
        its area at ``spacing`` means more than ``max_points`` samples)
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
    surface : (vertices (V, 3), faces (F, 3)) in the input frame, the captured surface (an
        RGB-D frame's :func:`~.rgbd.depth_faces`); None: a mesh geometry's own triangles. It
        is moved into the aligned frame and kept as the scene's ``mesh``, on which detection
        tests its ranked placements for collision; without it (a point cloud) that test is
        off

    Returns
    -------
    scene : Scene in the aligned frame (metres, +Z up, plane at z = 0), normals oriented
    report : :class:`RealSceneReport` (transform input -> aligned, steps, seconds, colours)
    """

    _check_range("spacing", spacing, 0.0, math.inf, low_open=True)
    _check_range("voxel_size", voxel_size, 0.0, 1.0, none_ok=True)
    _check_range("max_tilt_deg", max_tilt_deg, 0.0, 90.0, none_ok=True)
    _check_range("plane_distance", plane_distance, 0.0, 1.0, low_open=True)
    _check_range("outlier_std", outlier_std, 0.0, math.inf, low_open=True)
    _check_range("outlier_neighbors", outlier_neighbors, 1, 1000)
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
        mesh_samples(geometry, spacing, max_points)     # what the voxels keep: refused if huge
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
        points, colors = voxel_down_sample(points, colors, voxel, geometry.source)
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
                                          "try a smaller voxel size (voxel_size=, --voxel-size) or no outlier "
                                          "removal (remove_outliers=False, --no-remove-outliers)")

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
    if surface is None and geometry.is_mesh:
        surface = (geometry.vertices, geometry.faces)
    mesh, noise = None, 0.0
    if surface is not None:
        t = time.perf_counter()
        vertices = np.asarray(surface[0], np.float64)
        mesh = (vertices @ transform[:3, :3].T + transform[:3, 3],
                np.asarray(surface[1], np.int64))
        noise = surface_noise(mesh[0], points, nrm, tree, seed)
        _step(report, "surface", len(vertices), len(vertices),
              {"triangles": len(mesh[1]), "noise_m": round(noise, 5)}, t)
    report.surface_noise = noise
    scene = Scene(points, nrm, step, str(geometry.source), sampled=False, captured=True,
                  notes=list(geometry.notes), _tree=tree, mesh=mesh, surface_noise=noise)
    return scene, report


#: Vertices of a captured surface at most measured by :func:`surface_noise` (a seeded draw).
NOISE_SAMPLES = 200_000


def surface_noise(vertices: np.ndarray, points: np.ndarray, normals: np.ndarray, tree,
                  seed: int = 0) -> float:
    """How far (m) a captured surface's vertices stray from the surface its cleaned points
    describe: each vertex's distance from its nearest point along that point's normal, and
    of those distances three robust standard deviations (1.4826 x the median absolute
    deviation), so that the few vertices nearest another surface (at a depth edge) do not
    count. Deterministic: at most :data:`NOISE_SAMPLES` vertices, drawn with ``seed``."""
    vertices = np.asarray(vertices, np.float64)
    if len(vertices) > NOISE_SAMPLES:
        pick = np.random.default_rng(seed).choice(len(vertices), NOISE_SAMPLES, replace=False)
        vertices = vertices[np.sort(pick)]
    if not len(vertices):
        return 0.0
    _, nearest = tree.query(vertices)
    d = np.einsum("ij,ij->i", vertices - points[nearest], normals[nearest])
    return float(3.0 * 1.4826 * np.median(np.abs(d - np.median(d))))


def _step(report: RealSceneReport, name: str, before: int, after: int, params: dict, t0) -> None:
    seconds = time.perf_counter() - t0
    report.steps.append({"step": name, "points_before": int(before), "points_after": int(after),
                         "parameters": params, "seconds": round(seconds, 4)})
    report.seconds[name] = seconds
