"""Load meshes and point clouds (metres, +Z up) and write results atomically.

:func:`load_geometry` reads a file (one reader per format, in :mod:`.readers`);
:func:`as_geometry` takes whatever a user already holds: a path, a :class:`Geometry`, a
``trimesh`` mesh or point cloud, an Open3D point cloud or triangle mesh, or an ``(N, 3)``
array.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import stat
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import InputError

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


def load_geometry(path, scale: float | None = None, up: str = "z",
                  max_extent: float = MAX_SCENE_EXTENT) -> Geometry:
    """Read a mesh or point cloud file into metres, +Z up.

    Parameters
    ----------
    path : str or Path: PLY (ASCII or binary, mesh or cloud), OBJ, OFF, STL, GLB/GLTF, PCD,
        XYZ (x y z [r g b]), XYZN (x y z nx ny nz), PTS, NPY ((N, 3) or (N, 6) with normals),
        LAS/LAZ (extra ``las``), E57 (extra ``e57``). See :mod:`interaction_tensor.readers`.
    scale : float, multiplies the coordinates (0.001 for a file in millimetres). None (the
        default) means metres, checked: a file larger than ``max_extent`` metres is refused,
        since its units are most likely millimetres or centimetres; give ``scale=1`` to
        read a large file as metres.
    up : ``"z"`` or ``"y"``, the file's up axis.
    max_extent : the largest plausible extent (m) without an explicit ``scale``
    """
    from .readers import READERS

    path = Path(path)
    try:
        st = path.stat()
    except FileNotFoundError:
        raise InputError(path, "no such file") from None
    except OSError as exc:
        raise InputError(path, f"cannot read: {exc.strerror}") from None
    if stat.S_ISDIR(st.st_mode):
        raise InputError(path, "is a directory, expected a mesh or point-cloud file")
    if not stat.S_ISREG(st.st_mode):
        raise InputError(path, "is not a regular file (a pipe or a device); give a file")
    suffix = path.suffix.lower()
    if suffix not in READERS:
        raise InputError(path, f"unknown format {suffix or '(no extension)'!r}; "
                               f"use one of {', '.join(SUFFIXES)}")
    _check_scale(scale, path)
    rot = up_rotation(up)
    try:
        with open(path, "rb"):
            pass
    except OSError as exc:
        raise InputError(path, f"cannot read: {exc.strerror}") from None
    if st.st_size == 0:
        raise InputError(path, "file is empty")
    try:
        geometry = READERS[suffix](path)
    except InputError:
        raise
    except MemoryError:
        raise
    except Exception as exc:  # parser errors of every kind become one line
        raise InputError(path, f"cannot parse as {suffix[1:].upper()}: {exc}") from None
    geometry.source = str(path)
    return _to_library_frame(geometry, scale, rot, path, max_extent)


def _check_scale(scale, name) -> None:
    if scale is not None and (isinstance(scale, bool) or not isinstance(scale, (int, float))
                              or not (np.isfinite(scale) and scale > 0)):
        raise InputError(name, f"scale must be a positive number, got {scale!r}")


def _to_library_frame(geometry: Geometry, scale, rot: np.ndarray, name,
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


def as_geometry(obj, normals=None, *, scale: float | None = None, up: str = "z",
                name: str = "geometry", max_extent: float = MAX_SCENE_EXTENT) -> Geometry:
    """Whatever a user holds, as a :class:`Geometry` in metres, +Z up.

    Parameters
    ----------
    obj : a path (str or Path; see :func:`load_geometry`), a :class:`Geometry`, a
        ``trimesh.Trimesh``, ``trimesh.PointCloud`` or ``trimesh.Scene``, an Open3D
        ``PointCloud`` or ``TriangleMesh``, or an ``(N, 3)`` array of points (an ``(N, 6)``
        array is points and normals)
    normals : optional ``(N, 3)`` normals of an array or a point cloud
    scale, up, max_extent : as for :func:`load_geometry`: multiply by ``scale`` (None:
        metres, refused beyond ``max_extent``), turn ``up`` to +Z
    name : how errors name the argument (e.g. ``"scene"``)
    """
    if isinstance(obj, (str, os.PathLike)):
        geometry = load_geometry(obj, scale, up, max_extent)
        if normals is not None:
            geometry.normals = np.asarray(normals, np.float64) @ up_rotation(up).T
            _to_library_frame(geometry, 1.0, np.eye(3), name)
        return geometry
    _check_scale(scale, name)
    rot = up_rotation(up)
    geometry = _from_object(obj, name)
    if normals is not None:
        geometry.normals = np.asarray(normals, np.float64)
    return _to_library_frame(geometry, scale, rot, name, max_extent)


def _from_object(obj, name: str) -> Geometry:
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

def make_dirs(directory, target=None) -> None:
    """``mkdir -p directory``; failures (a file in the way, no permission) become one-line
    errors naming ``target`` (default: the directory)."""
    directory = Path(directory)
    target = directory if target is None else target
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        raise InputError(target, "cannot write: a file is in the way of its directory "
                                 f"({directory})") from None
    except OSError as exc:
        raise InputError(target, f"cannot write: {exc.strerror}") from None


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    An interrupted or failed write leaves ``path`` as it was.
    """
    path = Path(path)
    make_dirs(path.parent, path)
    if path.is_dir():
        raise InputError(path, "cannot write: it is a directory")
    with _signals_deferred():           # no temporary left by a signal between these lines
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part" + path.suffix,
                                       dir=path.parent)
        except OSError as exc:
            raise InputError(path, f"cannot write: {exc.strerror}") from None
        os.close(fd)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the file normal permissions
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        with _signals_deferred():
            if os.path.exists(tmp):
                os.unlink(tmp)


@contextlib.contextmanager
def atomic_dir(path, marker: str, allowed=None):
    """Yield a fresh temporary directory beside ``path``; swap it in for ``path`` on success.

    An interrupted or failed run leaves ``path`` as it was (the earlier complete result, or
    nothing). ``path`` may already exist only as an earlier output of the same command: empty,
    or holding ``marker`` (e.g. ``run.json``) and, when ``allowed`` (names) is given, nothing
    but those names; a directory holding other files is refused rather than replaced.

    A lock file beside ``path`` (``.NAME.lock``) makes a second run into the same directory
    refuse while the first is writing; temporaries left by a killed run are removed.
    """
    path = Path(path)
    _check_replaceable(path, marker, allowed)
    make_dirs(path.parent, path)
    with _directory_lock(path):
        _remove_stale(path)
        # SIGINT/SIGTERM wait while the temporary directory is made, swapped in or removed:
        # arriving in between they left it behind, or the old result moved aside. A signal
        # held while it is made is raised as that block ends, inside the try, so that the
        # finally below removes it
        tmp = None
        try:
            with _signals_deferred():
                try:
                    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".part",
                                                dir=path.parent))
                except OSError as exc:
                    raise InputError(path, f"cannot write: {exc.strerror}") from None
                os.chmod(tmp, 0o777 & ~_umask())
            yield tmp
            with _signals_deferred():
                _check_replaceable(path, marker, allowed)   # nothing new appeared meanwhile
                old = None
                if path.exists():
                    old = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".old",
                                                dir=path.parent))
                    os.replace(path, old / "previous")
                os.replace(tmp, path)
                if old is not None:
                    shutil.rmtree(old, ignore_errors=True)
        finally:
            with _signals_deferred():
                if tmp is not None and tmp.exists():
                    shutil.rmtree(tmp, ignore_errors=True)


@contextlib.contextmanager
def _signals_deferred():
    """Hold SIGINT and SIGTERM back (they are raised right after, with the handlers that were
    in place) while a few file operations that must not be cut in half run; a no-op off the
    main thread. Python-level handlers, not a signal mask: a mask holds only the calling
    thread, and the kernel hands a process signal to any thread that does not mask it (Numba's
    and tqdm's threads), whose arrival Python then runs in the main thread all the same."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught = []

    def hold(signum, _frame):
        caught.append(signum)

    previous = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        handler = signal.getsignal(sig)
        if handler is None:                 # installed outside Python: cannot be restored
            continue
        previous[sig] = signal.signal(sig, hold)
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        for sig in dict.fromkeys(caught):
            signal.raise_signal(sig)


def _check_replaceable(path: Path, marker: str, allowed) -> None:
    if not path.exists():
        return
    if not path.is_dir():
        raise InputError(path, "exists and is not a directory")
    names = {p.name for p in path.iterdir()}
    if names and marker not in names:
        raise InputError(path, f"exists and holds files that are not an earlier output "
                               f"(no {marker}); give a new or empty directory")
    if allowed is not None:
        foreign = sorted(names - set(allowed))
        if foreign:
            raise InputError(path, f"holds files that are not this command's output "
                                   f"({', '.join(foreign[:3])}{', ...' if len(foreign) > 3 else ''}"
                                   "); they would be lost, so give a new or empty directory")


@contextlib.contextmanager
def _directory_lock(path: Path):
    """An exclusive, non-blocking lock on ``.NAME.lock`` beside ``path`` (POSIX)."""
    try:
        import fcntl
    except ImportError:     # no advisory locks here: go on without one
        yield
        return
    lock_path = path.parent / f".{path.name}.lock"
    try:
        fh = open(lock_path, "a+")
    except OSError as exc:
        raise InputError(path, f"cannot write: {exc.strerror}") from None
    try:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise InputError(path, "another itensor run is writing this directory; wait for it "
                                   "or give another one") from None
        try:
            yield
        finally:
            try:
                lock_path.unlink()
            except OSError:
                pass
            fcntl.flock(fh, fcntl.LOCK_UN)
    finally:
        fh.close()


def _remove_stale(path: Path) -> None:
    """Remove ``.NAME.*.part`` / ``.NAME.*.old`` siblings left by a killed run (called with
    the directory's lock held, so no live run owns them)."""
    for pattern in (f".{path.name}.*.part", f".{path.name}.*.old"):
        for stale in path.parent.glob(pattern):
            if stale.is_dir():
                shutil.rmtree(stale, ignore_errors=True)


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


class Gathered:
    """``base[index]`` without gathering it: indexing (``g[i]``, ``g[a:b]``) gathers only the
    entries asked for, so a column of a million accepted pairs is written or searched a block
    at a time (:func:`write_json` writes it as an array)."""

    def __init__(self, base: np.ndarray, index: np.ndarray):
        self.base, self.index = base, index

    def __len__(self) -> int:
        return len(self.index)

    def __getitem__(self, i):
        return self.base[self.index[i]]


def write_json(path, obj) -> None:
    """Write ``obj`` as indented JSON, atomically.

    NumPy arrays (and :class:`Gathered` columns) in ``obj`` are written as one-line JSON
    lists, a block at a time (floats rounded to 6 decimals), so that a million accepted pairs
    cost no million Python objects.
    """
    arrays = []

    def swap(o):
        if isinstance(o, (np.ndarray, Gathered)):
            arrays.append(o.ravel() if isinstance(o, np.ndarray) else o)
            return f"@@itensor-array-{len(arrays) - 1}@@"
        if isinstance(o, dict):
            return {k: swap(v) for k, v in o.items()}
        if isinstance(o, (list, tuple)):
            return [swap(v) for v in o]
        return o

    parts = re.split(r'"@@itensor-array-(\d+)@@"', json.dumps(swap(obj), indent=1))
    with atomic_path(path) as tmp, open(tmp, "w") as fh:
        for i, part in enumerate(parts):
            if i % 2 == 0:
                fh.write(part)
                continue
            a = arrays[int(part)]
            fh.write("[")
            for s in range(0, len(a), 100_000):
                block = a[s:s + 100_000]
                block = np.round(block, 6) if block.dtype.kind == "f" else block
                fh.write(("," if s else "") + json.dumps(block.tolist())[1:-1])
            fh.write("]")
        fh.write("\n")


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
    kinds = {"<f4": "float", "u1": "uchar"}
    header = ["ply", "format binary_little_endian 1.0", "comment made by interaction-tensor",
              f"element vertex {len(points)}"]
    header += [f"property {kinds[t]} {n}" for n, t in fields]
    header.append("end_header")
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(("\n".join(header) + "\n").encode("ascii"))
            for s in range(0, len(points), 250_000):     # a block at a time: bounded memory
                sl = slice(s, s + 250_000)
                data = np.empty(len(points[sl]), dtype=fields)
                data["x"], data["y"], data["z"] = points[sl].T
                if normals is not None:
                    data["nx"], data["ny"], data["nz"] = np.asarray(normals[sl]).T
                if colors is not None:
                    data["red"], data["green"], data["blue"] = np.asarray(colors[sl],
                                                                          dtype=np.uint8).T
                for k, v in scalars.items():
                    data[k] = v[sl]
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
