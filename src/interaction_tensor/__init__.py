"""interaction-tensor: where in this 3D scene can I do this?

Geometric affordances from a single example via the Interaction Tensor (Ruiz & Mayol-Cuevas).

Three lines of Python do what ``itensor train`` and ``itensor detect`` do::

    import interaction_tensor as it
    tensor = it.train("bowl.ply", "table.ply", affordance="placing-bowl")
    result = it.detect("kitchen.ply", tensor)
    result.save("out/")

Every geometry argument takes a path, a trimesh or Open3D geometry, or an (N, 3) array;
``result.positions``, ``scores``, ``orientations`` and ``poses`` are NumPy arrays of the top
predictions, ``result.to_trimesh()`` and ``result.to_open3d()`` the scene with its heat map
and the posed objects.

Where things live: :mod:`.api` (the calls above), :mod:`.settings`, :mod:`.affordances` (the
registry of affordances and their examples), :mod:`.geometry` (formats, sampling, the scene
index), :mod:`.descriptor` (the tensor and its file), :mod:`.engine` (scoring backends),
:mod:`.placement` (placement tests), :mod:`.detection` (the search, places, ranking),
:mod:`.outputs` (files, pictures, viewer), :mod:`.capture` (RGB-D frames and scans),
:mod:`.examples` (procedural shapes, the demo), :mod:`.cli`.
"""

from interaction_tensor._version import __version__
from interaction_tensor.api import detect, load_scene, load_tensor, train
from interaction_tensor.batch import batch
from interaction_tensor.capture import (
                                        load_intrinsics,
                                        load_rgbd,
                                        prepare_real_scene,
                                        write_input_frame_outputs,
)
from interaction_tensor.descriptor.tensor import InteractionTensor, Keypoints
from interaction_tensor.detection.places import Place, Prediction
from interaction_tensor.detection.result import Detection
from interaction_tensor.detection.search import detect_many, score_at
from interaction_tensor.errors import InputError, ItensorError, SettingsError
from interaction_tensor.geometry.core import Geometry, validate_geometry
from interaction_tensor.geometry.load import as_geometry, load_geometry
from interaction_tensor.geometry.scene import Scene, prepare_scene
from interaction_tensor.outputs.export import export
from interaction_tensor.outputs.html import write_viewer as view
from interaction_tensor.settings import PLACEMENT_TESTS, DetectSettings, TrainSettings

__all__ = [
    "__version__", "InputError", "ItensorError", "SettingsError", "Geometry", "as_geometry",
    "load_geometry", "validate_geometry", "DetectSettings", "TrainSettings", "PLACEMENT_TESTS",
    "InteractionTensor", "Keypoints", "Scene", "prepare_scene", "Detection", "detect",
    "detect_many", "load_scene", "load_tensor", "train", "batch", "score_at", "Prediction",
    "Place", "view",
    "export", "load_intrinsics", "load_rgbd", "prepare_real_scene",
    "write_input_frame_outputs",
]
