"""Results: top-k with spatial non-maximum suppression, the heat map, and exports."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .io import Gathered, atomic_path, write_json, write_mesh, write_ply_points


@dataclass
class Prediction:
    """One place where the interaction can happen.

    Attributes
    ----------
    position : (3,) test point, metres
    orientation_index : i, the query object turned by i * 2 pi / n about +Z
    angle : radians
    score : normalised score in [0, 1]
    pose : (4, 4) rigid transform of the training-frame query object into the scene
    point_index : index of the test point in the scene's points
    """

    position: np.ndarray
    orientation_index: int
    angle: float
    score: float
    pose: np.ndarray
    point_index: int = -1

    def __post_init__(self):   # plain NumPy arrays and numbers, whatever made them
        self.position = np.array(self.position, dtype=np.float64).reshape(3)
        self.pose = np.array(self.pose, dtype=np.float64).reshape(4, 4)
        self.orientation_index = int(self.orientation_index)
        self.angle = float(self.angle)
        self.score = float(self.score)
        self.point_index = int(self.point_index)

    def __repr__(self) -> str:
        x, y, z = self.position
        return (f"Prediction(score={self.score:.3f}, position=({x:.3f}, {y:.3f}, {z:.3f}), "
                f"angle={np.degrees(self.angle):.0f} deg)")

    def to_dict(self) -> dict:
        return {"position": [float(v) for v in self.position],
                "orientation_index": self.orientation_index, "angle": self.angle,
                "score": self.score, "pose": np.asarray(self.pose).tolist(),
                "point_index": self.point_index}


def top_k(positions: np.ndarray, scores: np.ndarray, k: int, radius: float,
          index: np.ndarray | None = None, accept=None) -> list[int]:
    """Greedy non-maximum suppression: indices of up to ``k`` best, ``radius`` apart.

    Candidate i is at ``positions[i]``, or at ``positions[index[i]]`` when ``index`` is given
    (the scene's points and the pairs' point indices: no gathered (N, 3) copy).
    Ties in score are broken by the lower index. The candidates are swept best first in
    blocks; within a block, each one is tested against the picks so far at once (the same
    picks as repeatedly taking the best unsuppressed one, without an (N, 3) temporary per
    pick: a million accepted pairs cost their sort order only).

    With ``accept``, a callable taking a candidate's index: a candidate that would be picked
    is asked first and skipped when the answer is False (it suppresses nothing); None ends
    the search with the picks so far. The picks are then those of the same suppression
    among the candidates it accepts, and only candidates that no pick suppresses are asked
    (detection's collision test of its top k).
    """
    if index is not None:
        index = np.asarray(index)
        return top_k(Gathered(positions, index), scores, k, radius, accept=accept)
    scores = np.asarray(scores)
    if len(scores) == 0 or k <= 0:
        return []
    order = np.argsort(-scores, kind="stable")          # best first, lower index on ties
    if not np.isfinite(scores).all():
        order = order[np.isfinite(scores[order])]
    picks: list[int] = []
    r2 = float(radius) ** 2
    block = 4096
    for s in range(0, len(order), block):
        idx = order[s:s + block]
        pos = positions[idx]
        free = np.ones(len(idx), bool)
        if picks:
            chosen = positions[picks]
            d2 = ((pos[:, None, :] - chosen[None, :, :]) ** 2).sum(axis=2)
            free &= ~(d2 <= r2).any(axis=1)
        for j in np.flatnonzero(free):            # at most k picks end this loop
            if not free[j]:
                continue
            if accept is not None:
                ok = accept(int(idx[j]))
                if ok is None:
                    return picks
                if not ok:
                    continue
            picks.append(int(idx[j]))
            if len(picks) == k:
                return picks
            near = ((pos - pos[j]) ** 2).sum(axis=1) <= r2
            free &= ~near
    return picks


def heat_map(scene, pair_point: np.ndarray, pair_score: np.ndarray,
             pair_accepted: np.ndarray):
    """Per-point heat: the best accepted score of the nearest test point, spread to the
    scene points around it (within 1.5 x spacing), and the accepted orientations per point.

    Returns heat (N,) float64 in [0, 1] and count (N,) int.
    """
    n = len(scene)
    best = np.zeros(n)
    count = np.zeros(n, np.int32)
    if not pair_accepted.any():
        return best, count
    for s in range(0, len(pair_accepted), 1 << 20):     # bounded gathers of accepted pairs
        sl = slice(s, s + (1 << 20))
        acc = pair_accepted[sl]
        np.maximum.at(best, pair_point[sl][acc], pair_score[sl][acc])
        np.add.at(count, pair_point[sl][acc], 1)
    hot = np.flatnonzero(best > 0)
    hot_best = best[hot]                    # the scores spread, before spreading raises them
    from scipy.spatial import cKDTree

    tree = cKDTree(scene.points[hot])
    heat = best                             # spread in place: no second (N,) array
    for s in range(0, n, 500_000):          # bounds the query's (distance, index) arrays
        d, j = tree.query(scene.points[s:s + 500_000], distance_upper_bound=1.5 * scene.spacing,
                          workers=-1)
        near = np.flatnonzero(np.isfinite(d))
        heat[s + near] = np.maximum(heat[s + near], hot_best[j[near]])
    return heat, count


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

#: every name a detection's output directory may hold (``Detection.save``, ``itensor view``)
OUTPUT_NAMES = ("predictions.json", "heatmap.ply", "predictions.glb", "top", "render.png",
                "index.html", "predictions_input_frame.json", "heatmap_input_frame.ply",
                "top_input_frame", "scene.ply", "scene_input_frame.ply")


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


def export(detection, outdir, scene_name: str | None = None,
           descriptor_name: str | None = None) -> dict:
    """Write ``predictions.json``, ``heatmap.ply``, ``predictions.glb`` and ``top/`` into
    ``outdir``.

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
    # the accepted pairs' columns: gathered a block at a time as io.write_json writes them
    acc = det.accepted
    accepted = {
        "count": int(len(acc)),
        "columns": ["point_index", "orientation_index", "score", "comparisons_to_decision"],
        "point_index": Gathered(det.pair_point, acc),
        "orientation_index": Gathered(det.pair_orientation, acc),
        "score": Gathered(det.pairs.score, acc),
        "comparisons_to_decision": Gathered(det.pairs.decided_at, acc),
    }
    doc = {
        "scene": scene_name or det.scene.source,
        "descriptor": descriptor_name or tensor.affordance,
        "affordance": tensor.affordance,
        "parameters": {**det.settings.to_dict(), "threshold_used": det.threshold},
        "pose_convention": "x_scene = pose @ [x_query_training_frame, 1]; angle about +Z",
        "predictions": [p.to_dict() for p in det.predictions],
        "accepted": accepted,
        "stats": det.stats,
    }
    write_json(outdir / "predictions.json", doc)
    return doc
