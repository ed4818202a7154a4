"""Load meshes and point clouds (metres, +Z up) and write results atomically.

Formats: PLY, OBJ, OFF, STL through trimesh; PCD (ascii and binary) through a small
reader here, binary_compressed PCD through Open3D when it is installed.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InputError

MESH_SUFFIXES = (".ply", ".obj", ".off", ".stl")
CLOUD_SUFFIXES = (".pcd",)
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
    """

    vertices: np.ndarray
    faces: np.ndarray | None = None
    normals: np.ndarray | None = None
    colors: np.ndarray | None = None
    source: str = "<array>"

    @property
    def is_mesh(self) -> bool:
        return self.faces is not None and len(self.faces) > 0

    def transformed(self, matrix: np.ndarray) -> "Geometry":
        """A copy moved by the 4x4 rigid ``matrix``."""
        m = np.asarray(matrix, dtype=float)
        v = self.vertices @ m[:3, :3].T + m[:3, 3]
        n = None if self.normals is None else self.normals @ m[:3, :3].T
        return Geometry(v, None if self.faces is None else self.faces.copy(), n,
                        self.colors, self.source)


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
    if geometry.faces is not None and len(geometry.faces):
        f = geometry.faces
        if f.min() < 0 or f.max() >= len(v):
            raise InputError(name, "faces index vertices that do not exist")
        import trimesh

        area = trimesh.triangles.area(v[f]).sum()
        if not area > 0:
            raise InputError(name, "mesh has zero surface area (degenerate faces)")
    if extent.max() > 1000:
        raise InputError(name, f"extent {extent.max():.0f} m is implausible for metres; "
                               "pass --scale (e.g. 0.001 for millimetres)")
    return geometry


def load_geometry(path, scale: float = 1.0, up: str = "z") -> Geometry:
    """Read a mesh or point cloud file into metres, +Z up.

    Parameters
    ----------
    path : str or Path. PLY, OBJ, OFF, STL (mesh or cloud) or PCD (cloud).
    scale : float, multiplies the coordinates (0.001 for a file in millimetres).
    up : ``"z"`` or ``"y"``, the file's up axis.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(path, "no such file")
    if path.is_dir():
        raise InputError(path, "is a directory, expected a mesh or point-cloud file")
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise InputError(path, f"unknown format {suffix or '(no extension)'!r}; "
                               f"use one of {', '.join(SUFFIXES)}")
    if not (np.isfinite(scale) and scale > 0):
        raise InputError(path, f"scale must be a positive number, got {scale}")
    rot = up_rotation(up)
    try:
        size = path.stat().st_size
        with open(path, "rb"):
            pass
    except OSError as exc:
        raise InputError(path, f"cannot read: {exc.strerror}") from None
    if size == 0:
        raise InputError(path, "file is empty")
    try:
        if suffix == ".pcd":
            geometry = _read_pcd(path)
        else:
            geometry = _read_trimesh(path)
    except InputError:
        raise
    except Exception as exc:  # parser errors of every kind become one line
        raise InputError(path, f"cannot parse as {suffix[1:].upper()}: {exc}") from None
    geometry.source = str(path)
    with np.errstate(invalid="ignore", over="ignore"):   # NaN/inf are reported below
        geometry.vertices = (geometry.vertices.astype(np.float64) * scale) @ rot.T
        if geometry.normals is not None:
            geometry.normals = geometry.normals.astype(np.float64) @ rot.T
    return validate_geometry(geometry, path)


def _read_trimesh(path: Path) -> Geometry:
    import trimesh

    loaded = trimesh.load(str(path), process=False, force=None)
    if isinstance(loaded, trimesh.Scene):
        if not loaded.geometry:
            raise InputError(path, "file holds no geometry")
        loaded = loaded.to_geometry() if hasattr(loaded, "to_geometry") else loaded.dump(concatenate=True)
    if isinstance(loaded, trimesh.Trimesh):
        faces = np.asarray(loaded.faces, dtype=np.int64)
        colors = None
        return Geometry(np.asarray(loaded.vertices, dtype=np.float64),
                        faces if len(faces) else None, None, colors)
    if isinstance(loaded, trimesh.PointCloud):
        colors = None
        vc = getattr(loaded, "colors", None)
        if vc is not None and len(vc) == len(loaded.vertices):
            colors = np.asarray(vc)[:, :3].astype(np.uint8)
        normals = None
        attrs = loaded.metadata.get("_ply_raw", {}).get("vertex", {}).get("data") \
            if isinstance(loaded.metadata, dict) else None
        if attrs is not None and all(k in attrs.dtype.names for k in ("nx", "ny", "nz")):
            normals = np.column_stack([attrs["nx"], attrs["ny"], attrs["nz"]]).astype(float)
        return Geometry(np.asarray(loaded.vertices, dtype=np.float64), None, normals, colors)
    raise InputError(path, f"unsupported content {type(loaded).__name__}")


_PCD_TYPES = {("F", 4): "<f4", ("F", 8): "<f8", ("U", 1): "<u1", ("U", 2): "<u2",
              ("U", 4): "<u4", ("I", 1): "<i1", ("I", 2): "<i2", ("I", 4): "<i4",
              ("U", 8): "<u8", ("I", 8): "<i8"}


def _read_pcd(path: Path) -> Geometry:
    raw = path.read_bytes()
    header = {}
    offset = 0
    while True:
        end = raw.find(b"\n", offset)
        if end < 0:
            raise InputError(path, "PCD header has no DATA line")
        line = raw[offset:end].decode("ascii", "replace").strip()
        offset = end + 1
        if not line or line.startswith("#"):
            continue
        key, _, value = line.partition(" ")
        header[key.upper()] = value.split()
        if key.upper() == "DATA":
            break
    try:
        names = header["FIELDS"]
        sizes = [int(s) for s in header["SIZE"]]
        types = header["TYPE"]
        counts = [int(c) for c in header.get("COUNT", ["1"] * len(names))]
        n = int(header["POINTS"][0])
        mode = header["DATA"][0].lower()
    except (KeyError, ValueError, IndexError):
        raise InputError(path, "PCD header lacks FIELDS/SIZE/TYPE/POINTS") from None
    if mode == "binary_compressed":
        try:
            import open3d as o3d
        except ImportError:
            raise InputError(path, "binary_compressed PCD needs Open3D: "
                                   "pip install 'interaction-tensor[open3d]'") from None
        pc = o3d.io.read_point_cloud(str(path))
        pts = np.asarray(pc.points, dtype=np.float64)
        nrm = np.asarray(pc.normals, dtype=np.float64) if pc.has_normals() else None
        col = (np.asarray(pc.colors) * 255).astype(np.uint8) if pc.has_colors() else None
        return Geometry(pts, None, nrm, col)
    dtype = []
    for name, size, typ, count in zip(names, sizes, types, counts):
        base = _PCD_TYPES.get((typ.upper(), size))
        if base is None:
            raise InputError(path, f"PCD field {name!r} has unsupported type {typ}{size}")
        dtype.append((name if name != "_" else f"_pad{len(dtype)}", base, (count,)) if count > 1
                     else (name if name != "_" else f"_pad{len(dtype)}", base))
    dtype = np.dtype(dtype)
    if mode == "binary":
        if len(raw) - offset < n * dtype.itemsize:
            raise InputError(path, "PCD binary data is shorter than its header says")
        data = np.frombuffer(raw, dtype=dtype, count=n, offset=offset)
    elif mode == "ascii":
        table = np.loadtxt(raw[offset:].decode("ascii").splitlines(), ndmin=2)
        if table.shape[0] != n:
            raise InputError(path, f"PCD header says {n} points, file has {table.shape[0]}")
        data = np.zeros(n, dtype=dtype)
        col = 0
        for name, count in zip(dtype.names, counts):
            data[name] = table[:, col] if count == 1 else table[:, col:col + count]
            col += count
    else:
        raise InputError(path, f"unknown PCD DATA mode {mode!r}")
    if not all(k in data.dtype.names for k in "xyz"):
        raise InputError(path, "PCD has no x y z fields")
    pts = np.column_stack([data["x"], data["y"], data["z"]]).astype(np.float64)
    keep = np.isfinite(pts).all(axis=1)  # PCL marks missing points with NaN
    normals = None
    if all(k in data.dtype.names for k in ("normal_x", "normal_y", "normal_z")):
        normals = np.column_stack([data["normal_x"], data["normal_y"], data["normal_z"]])[keep]
    colors = None
    for key in ("rgb", "rgba"):
        if key in data.dtype.names:
            packed = np.ascontiguousarray(data[key]).view(np.uint32)[keep]
            colors = np.column_stack([(packed >> 16) & 255, (packed >> 8) & 255,
                                      packed & 255]).astype(np.uint8)
    return Geometry(pts[keep], None, normals, colors)


# --- writing -------------------------------------------------------------------------

@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    An interrupted or failed write leaves ``path`` as it was.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part" + path.suffix,
                               dir=path.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file normal permissions
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


@contextlib.contextmanager
def atomic_dir(path, marker: str):
    """Yield a fresh temporary directory beside ``path``; swap it in for ``path`` on success.

    An interrupted or failed run leaves ``path`` as it was (the earlier complete result, or
    nothing). ``path`` may already exist only as an earlier output of the same command: empty,
    or holding ``marker`` (e.g. ``run.json``); a directory holding other files is refused rather
    than replaced.
    """
    path = Path(path)
    if path.exists():
        if not path.is_dir():
            raise InputError(path, "exists and is not a directory")
        if any(path.iterdir()) and not (path / marker).exists():
            raise InputError(path, f"exists and holds files that are not an earlier output "
                                   f"(no {marker}); give a new or empty directory")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent))
    os.chmod(tmp, 0o777 & ~_umask())
    try:
        yield tmp
        old = None
        if path.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".old", dir=path.parent))
            os.replace(path, old / "previous")
        os.replace(tmp, path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


def write_json(path, obj) -> None:
    """Write ``obj`` as indented JSON, atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(obj, indent=1) + "\n")


def write_ply_points(path, points, colors=None, normals=None, **scalars) -> None:
    """Write a binary PLY point cloud, atomically.

    Parameters
    ----------
    points : (N, 3) float, metres
    colors : (N, 3) uint8 or None
    normals : (N, 3) float or None
    scalars : name -> (N,) array, written as extra float32 vertex properties
    """
    points = np.asarray(points)
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if normals is not None:
        fields += [("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
    if colors is not None:
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    fields += [(k, "<f4") for k in scalars]
    data = np.empty(len(points), dtype=fields)
    data["x"], data["y"], data["z"] = points.T
    if normals is not None:
        data["nx"], data["ny"], data["nz"] = np.asarray(normals).T
    if colors is not None:
        data["red"], data["green"], data["blue"] = np.asarray(colors, dtype=np.uint8).T
    for k, v in scalars.items():
        data[k] = v
    kinds = {"<f4": "float", "u1": "uchar"}
    header = ["ply", "format binary_little_endian 1.0", "comment made by interaction-tensor",
              f"element vertex {len(points)}"]
    header += [f"property {kinds[t]} {n}" for n, t in fields]
    header.append("end_header")
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(("\n".join(header) + "\n").encode("ascii"))
            fh.write(data.tobytes())


def write_mesh(path, vertices, faces=None, color=None) -> None:
    """Write a mesh (or, with no faces, a point cloud) as binary PLY, atomically."""
    import trimesh

    if faces is None or len(faces) == 0:
        cols = None if color is None else np.tile(np.asarray(color, np.uint8)[:3], (len(vertices), 1))
        write_ply_points(path, vertices, colors=cols)
        return
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    if color is not None:
        mesh.visual.face_colors = np.asarray(color, dtype=np.uint8)
    with atomic_path(path) as tmp:
        tmp.write_bytes(trimesh.exchange.ply.export_ply(mesh, encoding="binary"))
