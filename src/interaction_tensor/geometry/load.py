"""Reading geometry: a file through its format's reader, or whatever a user holds.

:func:`load_geometry` reads a file (one reader per format, :mod:`.readers`);
:func:`as_geometry` takes a path, a :class:`~.core.Geometry`, a ``trimesh`` mesh, point cloud
or scene, an Open3D point cloud or triangle mesh, or an ``(N, 3)`` array.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import numpy as np

from interaction_tensor.errors import InputError
from interaction_tensor.geometry.core import (
    MAX_SCENE_EXTENT,
    SUFFIXES,
    Geometry,
    check_scale,
    from_object,
    to_library_frame,
    up_rotation,
)
from interaction_tensor.geometry.readers import READERS


def load_geometry(path, scale: float | None = None, up: str = "z",
                  max_extent: float = MAX_SCENE_EXTENT) -> Geometry:
    """Read a mesh or point cloud file into metres, +Z up.

    Parameters
    ----------
    path : str or Path: PLY (ASCII or binary, mesh or cloud), OBJ, OFF, STL, GLB/GLTF, PCD,
        XYZ (x y z [r g b]), XYZN (x y z nx ny nz), PTS, NPY ((N, 3) or (N, 6) with normals),
        LAS/LAZ (extra ``las``), E57 (extra ``e57``). See :mod:`interaction_tensor.geometry.readers`.
    scale : float, multiplies the coordinates (0.001 for a file in millimetres). None (the
        default) means metres, checked: a file larger than ``max_extent`` metres is refused,
        since its units are most likely millimetres or centimetres; give ``scale=1`` to
        read a large file as metres.
    up : ``"z"`` or ``"y"``, the file's up axis.
    max_extent : the largest plausible extent (m) without an explicit ``scale``
    """
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
    check_scale(scale, path)
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
    return to_library_frame(geometry, scale, rot, path, max_extent)


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
            to_library_frame(geometry, 1.0, np.eye(3), name)
        return geometry
    check_scale(scale, name)
    rot = up_rotation(up)
    geometry = from_object(obj, name)
    if normals is not None:
        geometry.normals = np.asarray(normals, np.float64)
    return to_library_frame(geometry, scale, rot, name, max_extent)
