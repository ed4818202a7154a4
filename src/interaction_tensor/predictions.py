"""Results: top-k with spatial non-maximum suppression, the heat map, and exports."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .io import write_json, write_mesh, write_ply_points


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

    def to_dict(self) -> dict:
        return {"position": [float(v) for v in self.position],
                "orientation_index": self.orientation_index, "angle": self.angle,
                "score": self.score, "pose": np.asarray(self.pose).tolist(),
                "point_index": self.point_index}


def top_k(positions: np.ndarray, scores: np.ndarray, k: int, radius: float) -> list[int]:
    """Greedy non-maximum suppression: indices of up to ``k`` best, ``radius`` apart.

    Ties in score are broken by the lower index. ``k`` passes over the arrays, no loop over
    points.
    """
    if len(scores) == 0 or k <= 0:
        return []
    live = np.ones(len(scores), bool)
    picks = []
    masked = np.where(live, scores, -np.inf)
    for _ in range(k):
        i = int(np.argmax(masked))
        if not np.isfinite(masked[i]):
            break
        picks.append(i)
        near = np.linalg.norm(positions - positions[i], axis=1) <= radius
        masked[near] = -np.inf
        masked[i] = -np.inf
    return picks


def heat_map(scene, pair_point: np.ndarray, pair_score: np.ndarray,
             pair_accepted: np.ndarray):
    """Per-point heat: the best accepted score of the nearest test point, spread to the
    scene points around it (within 1.5 x spacing), and the accepted orientations per point.

    Returns heat (N,) float64 in [0, 1] and count (N,) int.
    """
    n = len(scene)
    best = np.zeros(n)
    count = np.zeros(n, np.int64)
    acc = np.flatnonzero(pair_accepted)
    if len(acc) == 0:
        return best, count
    np.maximum.at(best, pair_point[acc], pair_score[acc])
    np.add.at(count, pair_point[acc], 1)
    hot = np.flatnonzero(best > 0)
    from scipy.spatial import cKDTree

    tree = cKDTree(scene.points[hot])
    d, j = tree.query(scene.points, distance_upper_bound=1.5 * scene.spacing, workers=-1)
    near = np.isfinite(d)
    heat = best.copy()
    heat[near] = np.maximum(heat[near], best[hot[j[near]]])
    return heat, count


def colormap(values: np.ndarray, vmin: float = 0.0, vmax: float = 1.0) -> np.ndarray:
    """(N, 3) uint8 colours: grey for 0, then a perceptual ramp (viridis-like) above.

    A small built-in table, so that exports need no plotting library.
    """
    anchors = np.array([[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98],
                        [253, 231, 37]], dtype=float)
    t = np.clip((np.asarray(values, float) - vmin) / max(vmax - vmin, 1e-12), 0, 1)
    pos = t * (len(anchors) - 1)
    lo = np.floor(pos).astype(int).clip(0, len(anchors) - 2)
    frac = (pos - lo)[:, None]
    rgb = anchors[lo] * (1 - frac) + anchors[lo + 1] * frac
    rgb[np.asarray(values) <= 0] = (170, 170, 170)
    return rgb.round().astype(np.uint8)


def export(detection, outdir, scene_name: str | None = None,
           descriptor_name: str | None = None) -> dict:
    """Write ``predictions.json``, ``heatmap.ply`` and ``top/`` into ``outdir``.

    Every file is written atomically. Returns the JSON document written.
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    det = detection
    tensor = det.tensor
    acc = det.accepted
    accepted = {
        "count": int(len(acc)),
        "columns": ["point_index", "orientation_index", "score", "comparisons_to_decision"],
        "point_index": det.pair_point[acc].tolist(),
        "orientation_index": det.pair_orientation[acc].tolist(),
        "score": [round(float(s), 6) for s in det.pairs.score[acc]],
        "comparisons_to_decision": det.pairs.decided_at[acc].tolist(),
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
    # heat map: heat in [threshold, 1] mapped onto the colour ramp
    lo = det.threshold if det.threshold < 1 else 0.0
    colors = colormap(np.where(det.heat > 0, det.heat, 0), vmin=lo, vmax=1.0)
    write_ply_points(outdir / "heatmap.ply", det.scene.points, colors=colors,
                     score=det.heat, accepted=det.accepted_count)
    top = outdir / "top"
    top.mkdir(exist_ok=True)
    for old in top.glob("top_*.ply"):
        old.unlink()
    for rank, p in enumerate(det.predictions, 1):
        v = tensor.query_vertices @ p.pose[:3, :3].T + p.pose[:3, 3]
        write_mesh(top / f"top_{rank:02d}.ply", v,
                   tensor.query_faces if tensor.query_is_mesh else None,
                   color=(230, 60, 40, 255))
    write_json(outdir / "predictions.json", doc)
    return doc
