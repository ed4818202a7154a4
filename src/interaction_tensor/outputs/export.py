"""Results: top-k with spatial non-maximum suppression, the heat map, and exports."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from interaction_tensor.geometry.files import (
    atomic_path,
    write_json,
    write_mesh,
    write_ply_points,
)


def colormap(values: np.ndarray, vmin: float = 0.0, vmax: float = 1.0) -> np.ndarray:
    """(N, 3) uint8 colours: grey for 0, then a perceptual ramp (viridis-like) above.

    A small built-in table, so that exports need no plotting library.
    """
    values = np.asarray(values, float)
    t = values - vmin                                   # one temporary, then in place
    t *= (len(_RAMP) - 2) / max(vmax - vmin, 1e-12)
    np.clip(t, 0, len(_RAMP) - 2, out=t)
    np.rint(t, out=t)
    level = t.astype(np.uint16)
    del t
    level += 1                                          # 1..1024 on the ramp
    level[values <= 0] = 0                              # 0: grey
    return _RAMP[level]


def _ramp(levels: int = 1024) -> np.ndarray:
    """(levels + 1, 3) uint8: grey, then the ramp's colours at ``levels`` even steps (a
    table, so that colouring N points costs a few bytes each, not N x 3 floats)."""
    anchors = np.array([[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98],
                        [253, 231, 37]], dtype=float)
    pos = np.linspace(0, len(anchors) - 1, levels)
    lo = np.floor(pos).astype(int).clip(0, len(anchors) - 2)
    frac = (pos - lo)[:, None]
    rgb = anchors[lo] * (1 - frac) + anchors[lo + 1] * frac
    return np.vstack([[170, 170, 170], rgb]).round().astype(np.uint8)


_RAMP = _ramp()


def heat_properties(detection) -> dict:
    """The heat map's vertex properties, under the names viewers show: ``quality`` (MeshLab's
    per-vertex quality) and ``scalar_score`` (CloudCompare's scalar fields) both hold the score
    (0: nothing accepted near); ``scalar_accepted`` the accepted orientations at the point."""
    return {"quality": detection.heat, "scalar_score": detection.heat,
            "scalar_accepted": detection.accepted_count}


OBJECT_COLOR = (230, 60, 40, 255)

#: the copy of the descriptor a result carries when its file is not named
#: (:meth:`~interaction_tensor.detection.result.Detection.save`)
DESCRIPTOR_FILE = "descriptor.npz"
#: The file of every accepted pair (:func:`write_accepted`), beside ``predictions.json``.
ACCEPTED_FILE = "accepted.npz"

#: every name a detection's output directory may hold (``Detection.save``, ``itensor view``)
OUTPUT_NAMES = ("predictions.json", ACCEPTED_FILE, DESCRIPTOR_FILE, "heatmap.ply",
                "predictions.glb", "top", "render.png", "index.html",
                "predictions_input_frame.json", "heatmap_input_frame.ply", "top_input_frame",
                "scene.ply", "scene_input_frame.ply")


def heat_colors(detection, step: int = 1) -> np.ndarray:
    """(N, 3) uint8 heat-map colours of the scene points (every ``step``-th one): the ramp
    from the threshold to 1, grey where nothing was accepted near."""
    lo = detection.threshold if detection.threshold < 1 else 0.0
    return colormap(detection.heat[::step], vmin=lo, vmax=1.0)       # heat <= 0: grey


def posed_objects(detection) -> list:
    """(vertices, faces or None) of the query object at each top prediction, best first."""
    tensor = detection.tensor
    faces = tensor.query_faces if tensor.query_is_mesh else None
    return [(tensor.query_vertices @ p.pose[:3, :3].T + p.pose[:3, 3], faces)
            for p in detection.predictions]


#: Heat-map points written into ``predictions.glb`` at most (an evenly strided subset of a
#: larger scene; ``heatmap.ply`` holds them all): a browser draws this many smoothly, and
#: trimesh's glTF export costs about 120 bytes a point (180 MB for a 2 M-point scene).
GLB_MAX_POINTS = 250_000


def result_scene(detection, max_points: int | None = None):
    """A ``trimesh.Scene`` of the heat-map points (every ``ceil(N / max_points)``-th one when
    there are more than ``max_points``) and the posed query objects."""
    import trimesh

    n = len(detection.scene)
    step = 1 if not max_points or n <= max_points else -(-n // max_points)
    colors = heat_colors(detection, step)
    colors = np.column_stack([colors, np.full(len(colors), 255, np.uint8)])
    out = trimesh.Scene()
    out.add_geometry(trimesh.PointCloud(detection.scene.points[::step], colors=colors),
                     node_name="heatmap", geom_name="heatmap")
    for rank, (v, f) in enumerate(posed_objects(detection), 1):
        if f is None:
            geom = trimesh.PointCloud(v, colors=np.tile(OBJECT_COLOR, (len(v), 1)))
        else:
            geom = trimesh.Trimesh(v, f, process=False)
            geom.visual.face_colors = OBJECT_COLOR
        out.add_geometry(geom, node_name=f"top_{rank:02d}", geom_name=f"top_{rank:02d}")
    return out


def result_open3d(detection) -> list:
    """Open3D geometries: the heat-map cloud, then the posed query objects."""
    try:
        import open3d as o3d
    except ImportError:
        raise ImportError("to_open3d() needs Open3D: pip install "
                          "'interaction-tensor[open3d]'") from None
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(detection.scene.points))
    cloud.colors = o3d.utility.Vector3dVector(heat_colors(detection) / 255.0)
    cloud.normals = o3d.utility.Vector3dVector(detection.scene.normals)
    out = [cloud]
    rgb = np.asarray(OBJECT_COLOR[:3]) / 255.0
    for v, f in posed_objects(detection):
        if f is None:
            geom = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(v))
            geom.paint_uniform_color(rgb)
        else:
            geom = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(v),
                                             o3d.utility.Vector3iVector(np.asarray(f, np.int32)))
            geom.compute_vertex_normals()
            geom.paint_uniform_color(rgb)
        out.append(geom)
    return out


def write_glb(detection, path) -> None:
    """``predictions.glb``: heat-map points and posed objects in one binary glTF, atomically.

    glTF is +Y up; the scene is turned so that the library's +Z up stays up in viewers.
    """
    import trimesh

    scene = result_scene(detection, GLB_MAX_POINTS)
    scene.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))
    with atomic_path(path) as tmp:
        tmp.write_bytes(trimesh.exchange.gltf.export_glb(scene))


#: Its arrays, one entry per accepted (test point, orientation) pair.
ACCEPTED_COLUMNS = ("point_index", "orientation_index", "score", "comparisons_to_decision",
                    "place")
#: Places listed in ``predictions.json`` at most (the best ones; every accepted pair's place
#: is in ``accepted.npz``): keeps the file small whatever the scene.
MAX_PLACES_LISTED = 1000


def write_accepted(path, detection, accepted) -> None:
    """``accepted.npz``: every accepted pair as the arrays of :data:`ACCEPTED_COLUMNS`
    (``point_index`` into the scene's points, int32; ``orientation_index``, int16;
    ``score``, float32; ``comparisons_to_decision``, int32; ``place``, int32, the index of
    its place, -1 where the result was not ranked), compressed, atomically; read it with
    ``numpy.load``, no pickle."""
    det = detection
    place = (det.accepted_place if det.accepted_place is not None
             else np.full(len(accepted), -1))
    arrays = {"point_index": det.pair_point[accepted].astype(np.int32),
              "orientation_index": det.pair_orientation[accepted].astype(np.int16),
              "score": det.pairs.score[accepted].astype(np.float32),
              "comparisons_to_decision": det.pairs.decided_at[accepted].astype(np.int32),
              "place": np.asarray(place).astype(np.int32)}
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    with atomic_path(path) as tmp:
        tmp.write_bytes(buf.getvalue())


def export(detection, outdir, scene_name: str | None = None,
           descriptor_name: str | None = None, descriptor_file: str | None = None) -> dict:
    """Write ``predictions.json``, ``accepted.npz``, ``heatmap.ply``, ``predictions.glb`` and
    ``top/`` into ``outdir``.

    Every file is written atomically. Returns the JSON document written.
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    det = detection
    tensor = det.tensor
    # heat map: heat in [threshold, 1] mapped onto the colour ramp
    write_ply_points(outdir / "heatmap.ply", det.scene.points, colors=heat_colors(det),
                     **heat_properties(det))
    top = outdir / "top"
    top.mkdir(exist_ok=True)
    for old in top.glob("top_*.ply"):
        old.unlink()
    for rank, (v, f) in enumerate(posed_objects(det), 1):
        write_mesh(top / f"top_{rank:02d}.ply", v, f, color=OBJECT_COLOR)
    write_glb(det, outdir / "predictions.glb")
    # the accepted pairs, however many, go to a compact binary file beside the JSON
    acc = det.accepted
    write_accepted(outdir / ACCEPTED_FILE, det, acc)
    accepted = {"count": int(len(acc)), "file": ACCEPTED_FILE, "columns": list(ACCEPTED_COLUMNS)}
    doc = {
        "scene": scene_name or det.scene.source,
        "descriptor": descriptor_name or tensor.affordance,
        **({"descriptor_file": descriptor_file} if descriptor_file else {}),
        "affordance": tensor.affordance,
        "parameters": {**det.settings.to_dict(), "threshold_used": det.threshold},
        "pose_convention": "x_scene = pose @ [x_query_training_frame, 1]; angle about +Z",
        "predictions": [p.to_dict() for p in det.predictions],
        "places": [p.to_dict() for p in det.places[:MAX_PLACES_LISTED]],
        "accepted": accepted,
        "stats": det.stats,
    }
    write_json(outdir / "predictions.json", doc)
    return doc
