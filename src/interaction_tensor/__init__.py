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
"""

__version__ = "0.1.0"

from .errors import InputError, ItensorError, SettingsError  # noqa: E402
from .io import Geometry, as_geometry, load_geometry  # noqa: E402
from .settings import DetectSettings, TrainSettings  # noqa: E402
from .descriptor import InteractionTensor, Keypoints  # noqa: E402
from .scene import Scene, prepare_scene  # noqa: E402
from .detect import Detection, detect_many, score_at  # noqa: E402
from .api import detect, load_scene, load_tensor, train  # noqa: E402
from .batch import batch  # noqa: E402
from .predictions import Prediction, export  # noqa: E402
from .realdata import (load_intrinsics, load_rgbd, prepare_real_scene,  # noqa: E402
                       write_input_frame_outputs)

__all__ = [
    "__version__", "InputError", "ItensorError", "SettingsError", "Geometry", "as_geometry",
    "load_geometry", "DetectSettings", "TrainSettings", "InteractionTensor", "Keypoints",
    "Scene", "prepare_scene", "Detection", "detect", "detect_many", "load_scene",
    "load_tensor", "train", "batch", "score_at", "Prediction", "export", "load_intrinsics",
    "load_rgbd", "prepare_real_scene", "write_input_frame_outputs",
]
