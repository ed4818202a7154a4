"""interaction-tensor: where in this 3D scene can I do this?

Geometric affordances from a single example via the Interaction Tensor (Ruiz & Mayol-Cuevas).

Three lines of Python do what ``itensor train`` and ``itensor detect`` do::

    import interaction_tensor as it
    tensor = it.InteractionTensor.fit(it.load_geometry("bowl.ply"), it.load_geometry("table.ply"), "placing-bowl")
    result = it.detect(it.prepare_scene(it.load_geometry("kitchen.ply"), tensor.scene_spacing), tensor)
"""

__version__ = "0.1.0"

from .errors import InputError, ItensorError, SettingsError  # noqa: E402
from .io import Geometry, load_geometry  # noqa: E402
from .settings import DetectSettings, TrainSettings  # noqa: E402
from .descriptor import InteractionTensor, Keypoints  # noqa: E402
from .scene import Scene, prepare_scene  # noqa: E402
from .detect import Detection, detect, detect_many, score_at  # noqa: E402
from .predictions import Prediction, export  # noqa: E402
from .realdata import (load_intrinsics, load_rgbd, prepare_real_scene,  # noqa: E402
                       write_input_frame_outputs)

__all__ = [
    "__version__", "InputError", "ItensorError", "SettingsError", "Geometry", "load_geometry",
    "DetectSettings", "TrainSettings", "InteractionTensor", "Keypoints", "Scene",
    "prepare_scene", "Detection", "detect", "detect_many", "score_at", "Prediction", "export",
    "load_intrinsics", "load_rgbd", "prepare_real_scene", "write_input_frame_outputs",
]
