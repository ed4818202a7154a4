"""Real captured scenes: RGB-D frames and scanned point clouds, cleaned and gravity-aligned.

The paper's second experiment runs single-example tensors on RGB-D captures whose only
pre-processing is a ground-plane calibration. This module turns such data into a
:class:`~interaction_tensor.geometry.scene.Scene` in the library's frame (metres, +Z up, supporting
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

Three lines of Python (what ``itensor detect FRAME_DIR placing-bowl.npz`` does; the frame is
detected with the gaussian criterion, as for every captured scene)::

    import interaction_tensor as it
    result = it.detect("frame_dir/", "placing-bowl.npz")   # color.png, depth.png, intrinsics.json
    result.save("out/")                                    # also the input-frame outputs

Open3D (``pip install 'interaction-tensor[open3d]'``) is needed for down-sampling, outlier
removal, normals and plane fitting; it is imported lazily. Images are read with Pillow.
"""

from interaction_tensor.capture.alignment import (  # noqa: F401
                        AXES,
                        CAMERA_UP,
                        Plane,
                        alignment_transform,
                        candidate_planes,
                        choose_support_plane,
                        fit_plane,
                        gravity_align,
                        rotation_between,
                        rotation_between_frames,
)
from interaction_tensor.capture.cleaning import (  # noqa: F401
                        estimate_normals_o3d,
                        orient_normals,
                        remove_statistical_outliers,
                        voxel_down_sample,
)
from interaction_tensor.capture.outputs import write_input_frame_outputs  # noqa: F401
from interaction_tensor.capture.pipeline import (  # noqa: F401
                        PLAUSIBLE_EXTENT_M,
                        RealSceneReport,
                        prepare_real_scene,
                        unit_warnings,
)
from interaction_tensor.capture.rgbd import (  # noqa: F401
                        DEFAULT_DEPTH_SCALE,
                        DEFAULT_DEPTH_TRUNC,
                        Intrinsics,
                        back_project,
                        depth_faces,
                        load_intrinsics,
                        load_rgbd,
                        read_color,
                        read_depth,
                        rgbd_to_geometry,
)

__all__ = [
    "AXES", "CAMERA_UP", "Plane", "alignment_transform", "candidate_planes",
    "choose_support_plane", "fit_plane", "gravity_align", "rotation_between",
    "rotation_between_frames", "estimate_normals_o3d", "orient_normals",
    "remove_statistical_outliers", "voxel_down_sample", "write_input_frame_outputs",
    "PLAUSIBLE_EXTENT_M", "RealSceneReport", "prepare_real_scene", "unit_warnings",
    "DEFAULT_DEPTH_SCALE", "DEFAULT_DEPTH_TRUNC", "Intrinsics", "back_project", "depth_faces",
    "load_intrinsics", "load_rgbd", "read_color", "read_depth", "rgbd_to_geometry",
]
