"""The three calls most users need: :func:`train`, :func:`detect` and ``result.save``.

Every geometry argument takes what a user already holds: a path (any format of
:mod:`.readers`), a :class:`~interaction_tensor.geometry.core.Geometry`, a ``trimesh`` mesh, point cloud or
scene, an Open3D point cloud or triangle mesh, or an ``(N, 3)`` array (``(N, 6)``: points and
normals). The command line is a thin shell over exactly these functions, with the same
defaults::

    import interaction_tensor as it
    tensor = it.train("bowl.ply", "table.ply", affordance="placing-bowl")
    result = it.detect("kitchen.ply", tensor)
    result.save("out/")
"""

from __future__ import annotations

import os
import time
from dataclasses import fields, replace
from pathlib import Path

import numpy as np

from interaction_tensor import affordances
from interaction_tensor.capture import load_rgbd, prepare_real_scene
from interaction_tensor.descriptor.tensor import InteractionTensor
from interaction_tensor.detection.search import detect_many
from interaction_tensor.errors import InputError, SettingsError
from interaction_tensor.geometry.core import MAX_OBJECT_EXTENT, Geometry
from interaction_tensor.geometry.load import as_geometry
from interaction_tensor.geometry.scene import MAX_MESH_SAMPLES, Scene, prepare_scene
from interaction_tensor.settings import MIN_SPACING, DetectSettings, TrainSettings

#: cleaning and alignment options of frames and scans (see :func:`prepare_real_scene`)
CLEANING_OPTIONS = ("align", "max_tilt_deg", "voxel_size", "remove_outliers",
                    "outlier_neighbors", "outlier_std", "plane_distance", "normals_orientation")



def _direction(value, name: str):
    """``"up"``, ``"down"`` or a 3-vector, as a tuple of floats."""
    named = {"up": (0.0, 0.0, 1.0), "down": (0.0, 0.0, -1.0)}
    if isinstance(value, str):
        if value not in named:
            raise SettingsError(f"{name} must be 'up', 'down' or a 3-vector, got {value!r}")
        return named[value]
    try:
        vec = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise SettingsError(f"{name} must be 'up', 'down' or a 3-vector, got {value!r}") from None
    if len(vec) != 3:
        raise SettingsError(f"{name} must have three components, got {len(vec)}")
    return vec


def load_tensor(tensor):
    """An :class:`InteractionTensor` from itself or from a descriptor path."""

    if isinstance(tensor, InteractionTensor):
        return tensor
    if isinstance(tensor, (str, os.PathLike)):
        return InteractionTensor.load(tensor)
    raise InputError(None, f"tensor: expected an InteractionTensor or a descriptor path, got "
                           f"a {type(tensor).__name__}")


def train(query, scene_object, affordance: str = "interaction", *, acceptance: str | None = None,
          normal="up", spacing: float = 0.01, query_points: int = 6000,
          vectors: str = "surface", reference_point=None, seed: int = 0,
          scale: float | None = None, up: str = "z", settings: TrainSettings | None = None,
          ground: float | None = None):
    """Fit an Interaction Tensor from one example (what ``itensor train`` does).

    Parameters
    ----------
    query, scene_object : the two objects, posed in the interaction in one frame (a path, a
        trimesh or Open3D geometry, a Geometry or an (N, 3) array)
    affordance : the interaction's name, e.g. ``"placing-bowl"``
    acceptance : accept as one of the paper's affordances was tuned to (``"placing"``,
        ``"filling"``, ``"hanging"``, ``"sitting"``, ``"riding"``) instead of the acceptance
        derived from the example (:mod:`~interaction_tensor.descriptor.calibration`)
    normal : the expected scene normal N_aff: ``"up"``, ``"down"`` (filling under a tap) or a
        3-vector
    spacing : scene-object sample spacing in metres; detection samples mesh scenes the same way
    query_points, vectors, reference_point, seed : see :class:`TrainSettings`
    scale, up : unit factor to metres and up axis (``"z"`` or ``"y"``) of both inputs; with no
        scale an object larger than 10 m is refused (millimetres read as metres)
    settings : a full :class:`TrainSettings` instead of ``normal``, ``spacing``,
        ``query_points``, ``vectors`` and ``seed``
    ground : height (m, after ``scale`` and ``up``) of the floor the example stands on, if
        it matters to the interaction (a seated person's feet): not part of the tensor, but
        the clearance test then knows the floor was there and the contact test asks for it
        again

    Returns the fitted :class:`InteractionTensor` (``.save(path)`` writes the descriptor).
    """

    if acceptance is not None and acceptance not in affordances.acceptances():
        raise SettingsError(f"acceptance must be one of {tuple(affordances.acceptances())}, "
                            f"got {acceptance!r}")

    q = as_geometry(query, scale=scale, up=up, name="query", max_extent=MAX_OBJECT_EXTENT)
    s = as_geometry(scene_object, scale=scale, up=up, name="scene_object",
                    max_extent=MAX_OBJECT_EXTENT)
    if settings is None:
        settings = TrainSettings(query_points=query_points, scene_spacing=spacing,
                                 affordance_normal=_direction(normal, "normal"), seed=seed,
                                 vectors=vectors)
    if reference_point is not None:
        reference_point = _direction(reference_point, "reference_point")
    if ground is not None and (isinstance(ground, bool) or not isinstance(ground, (int, float))
                               or not np.isfinite(ground)):
        raise SettingsError(f"ground must be a height in metres, got {ground!r}")
    tensor = InteractionTensor.fit(q, s, affordance, settings, reference_point=reference_point,
                                   ground=ground)
    if acceptance is not None:
        tensor.set_acceptance(**affordances.acceptance(acceptance))
    return tensor


def load_scene(scene=None, spacing: float = 0.01, *, scan: bool = False, normals=None,
               color=None, depth=None, intrinsics=None, depth_scale: float | None = None,
               depth_trunc: float | None = None, scale: float | None = None, up="auto",
               seed: int = 0, max_points: int = MAX_MESH_SAMPLES,
               pairs_per_point: float | None = None, progress: bool = False, **cleaning):
    """A :class:`Scene` ready for detection, from any input (what ``itensor detect`` does).

    Parameters
    ----------
    scene : a mesh or point cloud (path, trimesh/Open3D geometry, Geometry, (N, 3) array), a
        directory holding an RGB-D frame (``color.png``, ``depth.png``, ``intrinsics.json``),
        an already prepared :class:`Scene` (returned as it is), or None with ``depth`` and
        ``intrinsics``
    spacing : mesh sampling spacing (m); use the descriptor's ``scene_spacing``
    scan : the scene is captured data (a scan): clean it and align it with gravity
    normals : (N, 3) normals of an array or point cloud input
    color, depth, intrinsics : an RGB-D frame's images and intrinsics JSON
    depth_scale, depth_trunc : override the intrinsics file's depth units per metre and range
    scale : unit factor to metres of a file or array; None: metres, and a scene larger than
        100 m is refused (millimetres or centimetres read as metres; give ``scale=1`` for a
        really large scene)
    up : up axis of the input: ``"auto"`` (``"z"`` for a plain scene; searched for a scan; the
        camera's -Y for a frame), ``"z"``, ``"y"``, ``"-y"``, ... or a 3-vector (scans, frames)
    seed : seed of mesh sampling and RANSAC
    max_points : most samples of a mesh (more is refused before sampling) or points of a
        cleaned frame or scan (more are thinned at random)
    pairs_per_point : what detection will do with each point (sample fraction x
        orientations), checked with the memory before any work (:func:`.scene.check_memory`)
    progress : show a progress bar while a cloud's normals are estimated
    cleaning : options of :func:`prepare_real_scene` for frames and scans: ``align``,
        ``max_tilt_deg``, ``voxel_size``, ``remove_outliers``, ``outlier_neighbors``,
        ``outlier_std``, ``plane_distance``, ``normals_orientation`` (camera, up or none)

    A captured scene (frame, scan) has ``captured`` set, so that detection defaults to the
    gaussian criterion, and ``report`` (what cleaning and alignment did, with the transform
    from the input frame). A frame's ``mesh`` is its depth image's triangles
    (:func:`~.realdata.depth_faces`), a mesh scan's its own, both aligned with the points and
    with their ``surface_noise``: detection's collision test runs on them.
    """

    if isinstance(scene, Scene):
        return scene
    unknown = sorted(set(cleaning) - set(CLEANING_OPTIONS))
    if unknown:
        raise SettingsError(f"unknown option{'s' if len(unknown) > 1 else ''} "
                            f"{', '.join(unknown)}")
    if "normals_orientation" in cleaning:
        cleaning["normals"] = cleaning.pop("normals_orientation")

    if not (spacing and np.isfinite(spacing) and MIN_SPACING <= spacing <= 1.0):
        raise SettingsError(f"spacing must be between {MIN_SPACING} and 1 metre, got {spacing}")
    is_dir = isinstance(scene, (str, os.PathLike)) and Path(scene).is_dir()
    frame = is_dir or any(v is not None for v in (color, depth, intrinsics))
    if not frame and not scan:
        if cleaning:
            raise SettingsError(f"{', '.join(sorted(cleaning))}: only for RGB-D frames and "
                                "scans (scan=True)")
        if scene is None:
            raise InputError(None, "scene: give a scene (a file, an array, a mesh or cloud) or "
                                   "an RGB-D frame (depth and intrinsics)")
        if up not in ("auto", "z", "y"):
            raise SettingsError(f"up={up!r} needs a scan (scan=True); a plain scene takes "
                                "'z' or 'y'")
        geometry = as_geometry(scene, normals, scale=scale, up="z" if up == "auto" else up,
                               name="scene")
        return prepare_scene(geometry, spacing, seed, max_points,
                             pairs_per_point=pairs_per_point, progress=progress)

    if frame:
        color, depth, intrinsics = _frame_paths(scene if is_dir else None, color, depth,
                                                intrinsics, scene)
        t = time.perf_counter()
        frame, camera, intr = load_rgbd(color, depth, intrinsics, depth_scale, depth_trunc,
                                        surface=True)
        t_conv = time.perf_counter() - t
        # the measured points are the scene; the triangles joining them, for the collision test
        geometry = Geometry(frame.vertices, None, None, frame.colors,
                            f"{depth}" + (f" + {color}" if color else ""), list(frame.notes))
        surface = (frame.vertices, frame.faces) if frame.is_mesh else None
        prepared, report = prepare_real_scene(geometry, spacing, camera, up=up, seed=seed,
                                              max_points=max_points, surface=surface,
                                              **cleaning)
        report.intrinsics = intr.to_dict()
        report.steps.insert(0, {"step": "rgbd_back_projection",
                                "points_before": intr.width * intr.height,
                                "points_after": len(geometry.vertices),
                                "parameters": {"depth_scale": intr.depth_scale,
                                               "depth_trunc_m": intr.depth_trunc,
                                               "surface_triangles": 0 if surface is None
                                               else len(surface[1])},
                                "seconds": round(t_conv, 4)})
        report.seconds["rgbd_back_projection"] = t_conv
    else:
        t = time.perf_counter()
        geometry = as_geometry(scene, normals, scale=scale, up="z", name="scene")
        t_load = time.perf_counter() - t
        prepared, report = prepare_real_scene(geometry, spacing, None, up=up,
                                              scale=scale or 1.0, seed=seed,
                                              max_points=max_points, **cleaning)
        report.steps.insert(0, {"step": "load", "points_before": len(geometry.vertices),
                                "points_after": len(geometry.vertices),
                                "parameters": {"scale": scale or 1.0},
                                "seconds": round(t_load, 4)})
        report.seconds["load"] = t_load
    prepared.report = report
    return prepared


def _frame_paths(directory, color, depth, intrinsics, scene):
    """(color, depth, intrinsics) of an RGB-D frame given as a directory and/or paths."""
    if directory is not None:
        d = Path(directory)
        color = color or (str(d / "color.png") if (d / "color.png").exists() else None)
        depth = depth or str(d / "depth.png")
        intrinsics = intrinsics or str(d / "intrinsics.json")
    elif scene is not None:
        raise InputError(None, "scene: give either a scene or an RGB-D frame (depth and "
                               "intrinsics), not both")
    if not depth:
        raise InputError(intrinsics or color, "an RGB-D frame needs a depth image (and "
                                              "intrinsics)")
    if not intrinsics:
        raise InputError(depth, "an RGB-D frame needs its intrinsics (a JSON file)")
    return color, depth, intrinsics


def detect(scene, tensor, settings: DetectSettings | None = None, *, progress: bool = False,
           test_indices=None, **options):
    """Find where the interaction of ``tensor`` can happen in ``scene`` (``itensor detect``).

    Parameters
    ----------
    scene : anything :func:`load_scene` takes (a path, a frame directory, a trimesh or Open3D
        geometry, an (N, 3) array, a prepared Scene)
    tensor : an :class:`InteractionTensor` or the path of a descriptor
    settings : :class:`DetectSettings`; defaults as the command line's: the criterion by the
        kind of input (gaussian for frames and scans, else paper), meshes sampled at the
        descriptor's spacing
    progress : show a progress bar
    test_indices : scene point indices to test instead of a seeded random fraction
    options : :func:`load_scene` options (``scan``, ``scale``, ``up``, ``normals``, ``color``,
        ``depth``, ``intrinsics``, cleaning options) and :class:`DetectSettings` fields
        (``top_k``, ``sample_fraction``, ``seed``, ...), which override ``settings``

    Returns a :class:`Detection`: ``positions``, ``scores``, ``orientations`` and ``poses`` of
    the top predictions as arrays, ``save(dir)``, ``to_trimesh()``, ``to_open3d()``.
    """


    tensor = load_tensor(tensor)
    names = {f.name for f in fields(DetectSettings)}
    overrides = {k: options.pop(k) for k in list(options) if k in names}
    try:
        settings = replace(settings or DetectSettings(), **overrides)
    except TypeError as exc:
        raise SettingsError(str(exc)) from None
    t0 = time.perf_counter()
    spacing = settings.scene_spacing or tensor.scene_spacing
    prepared = load_scene(scene, spacing, seed=settings.seed, progress=progress,
                          pairs_per_point=settings.sample_fraction * settings.n_orientations,
                          **options)
    t_prep = time.perf_counter() - t0
    result = detect_many(prepared, [tensor], settings, progress, test_indices)[0]
    if prepared is not scene:
        result.stats["seconds"]["scene_preparation"] = round(t_prep, 4)
    return result
