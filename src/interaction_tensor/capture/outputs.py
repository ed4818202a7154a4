"""A detection written again in the input's own frame (camera frame, file units)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from interaction_tensor.capture.pipeline import RealSceneReport
from interaction_tensor.geometry.files import write_json, write_mesh, write_ply_points
from interaction_tensor.outputs.export import heat_colors, heat_properties


# ============================================================================ outputs
def write_input_frame_outputs(detection, outdir, transform, report: RealSceneReport | None = None,
                              write_scene: bool = True) -> dict:
    """Write the detection in the input's own frame next to ``it.export``'s aligned files.

    Files (all atomic): ``predictions_input_frame.json`` (every prediction's position and
    pose mapped by ``inverse(transform)``), ``heatmap_input_frame.ply``,
    ``top_input_frame/top_XX.ply``; with ``report`` colours, ``scene.ply`` (aligned) and
    ``scene_input_frame.ply`` carry the captured colours. When ``predictions.json`` exists in
    ``outdir`` (written by ``it.export``), a ``real_scene`` block (transform, alignment,
    cleaning steps, warnings) is added to it.

    Parameters
    ----------
    detection : Detection of the aligned scene
    transform : (4, 4) input -> aligned (``report.transform``; may include a scale)

    Returns the document written to ``predictions_input_frame.json``.
    """

    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    transform = np.asarray(transform, dtype=np.float64)
    inv = np.linalg.inv(transform)
    det = detection
    scene_pts = det.scene.points
    pts_in = scene_pts @ inv[:3, :3].T + inv[:3, 3]

    colors = heat_colors(det)
    write_ply_points(outdir / "heatmap_input_frame.ply", pts_in, colors=colors,
                     **heat_properties(det))
    top = outdir / "top_input_frame"
    top.mkdir(exist_ok=True)
    for old in top.glob("top_*.ply"):
        old.unlink()
    tensor = det.tensor
    preds = []
    for rank, p in enumerate(det.predictions, 1):
        pose_in = inv @ np.asarray(p.pose)
        v = tensor.query_vertices @ pose_in[:3, :3].T + pose_in[:3, 3]
        write_mesh(top / f"top_{rank:02d}.ply", v,
                   tensor.query_faces if tensor.query_is_mesh else None, color=(230, 60, 40, 255))
        pos = inv[:3, :3] @ np.asarray(p.position) + inv[:3, 3]
        preds.append({"rank": rank, "position": [float(x) for x in pos],
                      "position_aligned": [float(x) for x in p.position],
                      "orientation_index": p.orientation_index, "angle": p.angle,
                      "score": p.score, "pose": pose_in.tolist(), "point_index": p.point_index})
    if report is not None and write_scene and report.colors is not None \
            and len(report.colors) == len(scene_pts):
        write_ply_points(outdir / "scene.ply", scene_pts, colors=report.colors,
                         normals=det.scene.normals)
        write_ply_points(outdir / "scene_input_frame.ply", pts_in, colors=report.colors)
    doc = {
        "frame": "input",
        "transform_input_to_aligned": transform.tolist(),
        "transform_aligned_to_input": inv.tolist(),
        "pose_convention": "x_input = pose @ [x_query_training_frame, 1] (pose = "
                           "transform_aligned_to_input @ aligned pose; includes the input "
                           "scale when there was one)",
        "predictions": preds,
    }
    write_json(outdir / "predictions_input_frame.json", doc)
    main = outdir / "predictions.json"
    if main.exists():
        summary = json.loads(main.read_text())
        block = report.to_dict() if report is not None else {
            "transform_input_to_aligned": transform.tolist(),
            "transform_aligned_to_input": inv.tolist()}
        block["input_frame_outputs"] = ["predictions_input_frame.json",
                                        "heatmap_input_frame.ply", "top_input_frame/"]
        summary["real_scene"] = block
        write_json(main, summary)
    return doc
