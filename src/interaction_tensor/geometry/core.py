"""The geometry type of the library: a mesh or a point cloud in metres, +Z up.

:class:`Geometry` holds vertices, faces, normals and colours; :func:`validate_geometry` refuses
empty, non-finite and degenerate input; :func:`from_object` converts what a user holds (a
``trimesh`` or Open3D geometry, an ``(N, 3)`` array) and :func:`to_library_frame` scales and
turns it into metres, +Z up.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from interaction_tensor.errors import InputError

MESH_SUFFIXES = (".ply", ".obj", ".off", ".stl", ".glb", ".gltf")
CLOUD_SUFFIXES = (".pcd", ".xyz", ".xyzn", ".pts", ".npy", ".las", ".laz", ".e57")
SUFFIXES = MESH_SUFFIXES + CLOUD_SUFFIXES
UP_AXES = ("z", "y")


@dataclass
class Geometry:
    """A mesh (``faces`` set) or a point cloud (``faces`` None), in metres, +Z up.

    Attributes
    ----------
    vertices : (N, 3) float64, metres
    faces : (F, 3) int64 or None
    normals : (N, 3) float64 or None, unit normals of a point cloud when the file had them
    colors : (N, 3) uint8 or None
    source : str, where it came from (a path or a description)
    notes : what the reader changed and the user should know (e.g. points dropped)
    """

    vertices: np.ndarray
    faces: np.ndarray | None = None
    normals: np.ndarray | None = None
    colors: np.ndarray | None = None
    source: str = "<array>"
    notes: list = field(default_factory=list)

    @property
    def is_mesh(self) -> bool:
        return self.faces is not None and len(self.faces) > 0

    def transformed(self, matrix: np.ndarray) -> "Geometry":
        """A copy moved by the 4x4 rigid ``matrix``."""
        m = np.asarray(matrix, dtype=float)
        v = self.vertices @ m[:3, :3].T + m[:3, 3]
        n = None if self.normals is None else self.normals @ m[:3, :3].T
        return Geometry(v, None if self.faces is None else self.faces.copy(), n,
                        self.colors, self.source, list(self.notes))


def up_rotation(up: str) -> np.ndarray:
    """3x3 rotation taking a file's up axis to +Z: ``y`` maps (x, y, z) to (x, -z, y)."""
    if up == "z":
        return np.eye(3)
    if up == "y":
        return np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
    raise InputError(None, f"unknown up axis {up!r}; use one of {UP_AXES}")


def validate_geometry(geometry: Geometry, name=None, min_points: int = 4) -> Geometry:
    """Check a geometry for emptiness, NaN/inf and degeneracy; return it unchanged.

    Raises :class:`InputError` naming ``name`` (default ``geometry.source``).
    """
    name = geometry.source if name is None else name
    v = geometry.vertices
    if v.ndim != 2 or v.shape[1] != 3:
        raise InputError(name, f"expected (N, 3) coordinates, got shape {v.shape}")
    if len(v) == 0:
        raise InputError(name, "no points or vertices (empty geometry)")
    if not np.isfinite(v).all():
        bad = int((~np.isfinite(v)).any(axis=1).sum())
        raise InputError(name, f"{bad} vertices have NaN or infinite coordinates")
    if len(v) < min_points:
        raise InputError(name, f"only {len(v)} points; need at least {min_points}")
    extent = np.ptp(v, axis=0)
    if extent.max() <= 0:
        raise InputError(name, "all points coincide (degenerate geometry)")
    sample = v[:: max(1, len(v) // 100_000)]
    spread = np.linalg.svd(sample - sample.mean(axis=0), compute_uv=False)
    if spread[1] <= 1e-9 * spread[0]:
        raise InputError(name, "all points lie on one line (degenerate geometry)")
    if geometry.faces is not None and len(geometry.faces):
        f = geometry.faces
        if f.min() < 0 or f.max() >= len(v):
            raise InputError(name, "faces index vertices that do not exist")
        import trimesh

        area = trimesh.triangles.area(v[f]).sum()
        if not area > 0:
            raise InputError(name, "mesh has zero surface area (degenerate faces)")
    return geometry


#: Largest extent (m) a file read without an explicit scale may have: a scene (a room, a
#: floor of a building) and an object (a query or a scene-object of a training example).
#: Millimetres or centimetres read as metres exceed these, and are refused with a hint.
MAX_SCENE_EXTENT = 100.0
MAX_OBJECT_EXTENT = 10.0


def check_scale(scale, name) -> None:
    if scale is not None and (isinstance(scale, bool) or not isinstance(scale, (int, float))
                              or not (np.isfinite(scale) and scale > 0)):
        raise InputError(name, f"scale must be a positive number, got {scale!r}")


def to_library_frame(geometry: Geometry, scale, rot: np.ndarray, name,
                      max_extent: float | None = None) -> Geometry:
    with np.errstate(invalid="ignore", over="ignore"):   # NaN/inf are reported below
        geometry.vertices = (geometry.vertices.astype(np.float64) * (scale or 1.0)) @ rot.T
        if geometry.normals is not None:
            geometry.normals = geometry.normals.astype(np.float64) @ rot.T
    if geometry.normals is not None and len(geometry.normals) != len(geometry.vertices):
        raise InputError(name, f"{len(geometry.normals)} normals for "
                               f"{len(geometry.vertices)} points")
    if geometry.colors is not None and len(geometry.colors) != len(geometry.vertices):
        raise InputError(name, f"{len(geometry.colors)} colours for "
                               f"{len(geometry.vertices)} points")
    validate_geometry(geometry, name)
    if scale is None and max_extent is not None:
        extent = float(np.ptp(geometry.vertices, axis=0).max())
        if extent > max_extent:
            what = "an object" if max_extent <= MAX_OBJECT_EXTENT else "a scene"
            raise InputError(name, f"extent {extent:.4g} m is implausible for {what} in metres; "
                                   "give the scale to metres (scale=0.001 or --scale 0.001 for "
                                   "millimetres, 0.01 for centimetres; scale=1 or --scale 1 "
                                   "if it really is metres)")
    return geometry


def from_object(obj, name: str) -> Geometry:
    """A copy of ``obj`` as a Geometry in its own units and axes."""
    if isinstance(obj, Geometry):
        return Geometry(np.array(obj.vertices, np.float64),
                        None if obj.faces is None else np.array(obj.faces, np.int64),
                        None if obj.normals is None else np.array(obj.normals, np.float64),
                        obj.colors, obj.source)
    module = type(obj).__module__ or ""
    kind = type(obj).__name__
    if module.startswith("trimesh"):
        import trimesh

        if isinstance(obj, trimesh.Scene):
            if not obj.geometry:
                raise InputError(None, f"{name}: the trimesh Scene holds no geometry")
            obj = obj.to_geometry() if hasattr(obj, "to_geometry") else obj.dump(concatenate=True)
        if isinstance(obj, trimesh.Trimesh):
            colors = None
            if getattr(obj.visual, "kind", None) == "vertex":
                colors = np.asarray(obj.visual.vertex_colors)[:, :3].astype(np.uint8)
            return Geometry(np.array(obj.vertices, np.float64),
                            np.array(obj.faces, np.int64) if len(obj.faces) else None,
                            None, colors, f"<trimesh {name}>")
        if isinstance(obj, trimesh.PointCloud):
            vc = getattr(obj, "colors", None)
            colors = np.asarray(vc)[:, :3].astype(np.uint8) \
                if vc is not None and len(vc) == len(obj.vertices) else None
            return Geometry(np.array(obj.vertices, np.float64), None, None, colors,
                            f"<trimesh {name}>")
    if module.startswith("open3d"):
        if hasattr(obj, "triangles") and hasattr(obj, "vertices"):
            faces = np.asarray(obj.triangles, np.int64)
            colors = (np.asarray(obj.vertex_colors) * 255).round().astype(np.uint8) \
                if obj.has_vertex_colors() else None
            return Geometry(np.array(obj.vertices, np.float64), faces if len(faces) else None,
                            None, colors, f"<open3d {name}>")
        if hasattr(obj, "points"):
            normals = np.array(obj.normals, np.float64) if obj.has_normals() else None
            colors = (np.asarray(obj.colors) * 255).round().astype(np.uint8) \
                if obj.has_colors() else None
            return Geometry(np.array(obj.points, np.float64), None, normals, colors,
                            f"<open3d {name}>")
    if isinstance(obj, (np.ndarray, list, tuple)):
        try:
            arr = np.array(obj, dtype=np.float64)
        except (TypeError, ValueError):
            raise InputError(None, f"{name}: expected numbers, got a {kind} that is not "
                                   "numeric") from None
        if arr.ndim != 2 or arr.shape[1] not in (3, 6):
            raise InputError(None, f"{name}: expected an (N, 3) array of points (or (N, 6) "
                                   f"with normals), got shape {arr.shape}")
        return Geometry(arr[:, :3].copy(), None,
                        arr[:, 3:].copy() if arr.shape[1] == 6 else None, None,
                        f"<array {name}>")
    raise InputError(None, f"{name}: cannot use a {module + '.' if module else ''}{kind}; give "
                           "a path, a trimesh or Open3D geometry, or an (N, 3) array")


# --- writing -------------------------------------------------------------------------


