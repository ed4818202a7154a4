"""The judge: an automatic validity oracle for a predicted pose, independent of any score.

The paper asked people (Amazon Mechanical Turk) whether a predicted placement was a good
place for the interaction. No raters are available here, so a predicted pose (a 4x4 taking
the training-frame query object into the scene) is judged by geometry alone, with the tests
and thresholds below. None of them looks at the Interaction Tensor, its score or its
keypoints; they only use the example (query object and scene-object as posed in training),
the scene mesh and the pose. The thresholds were set from physical reasoning before any
evaluation run and are not tuned to any detector.

1. **No penetration.** The scene is sampled area-uniformly at ``spacing`` = 1 cm (seeded; a
   1 cm sampling puts several points on any surface crossing a solid more than 1 cm deep).
   The query object is filled on a voxel grid (pitch 3 mm, or extent / 200 for large
   objects): ``solid="hull"`` fills its convex hull (mugs, cups, bowls, bottles: something
   inside their cavity penetrates the interaction as much as something inside their wall),
   ``solid="mesh"`` fills the closed mesh itself (humans, hanger, handbag, whose concavities
   are part of the interaction). The depth of a scene point is its Euclidean distance to
   the outside of the filled grid, less one voxel. Valid when the deepest scene point is at
   most ``penetration_depth`` = 1 cm inside: this absorbs the voxel quantisation and the
   1 cm sampling of the detectors' candidate points, but not an object sunk into a surface
   or passing through furniture. Limits: the scene is a surface, so an object entirely
   inside a closed piece of furniture without crossing its surface is not seen, and parts of
   the query thinner than twice the tolerance (a 6 mm hanger hook) cannot reach it.
2. **Contact like the example.** Contact points are the query samples within
   ``contact_tolerance`` = 1 cm of the scene-object in the training example. They are split
   into parts (connected at 3 cm: a seat and two hands and two feet for riding; the foot
   ring of a bowl); parts holding less than 5 % of the contact points are ignored. Each part
   must again be in contact: at least half its points within ``contact_distance`` = 2 cm of
   the scene (1 cm sampling + 1 cm slack). A floating object, or a rider with nothing under
   the hands, fails.
3. **Support from below** (placing and sitting). Support points are scene points under the
   posed query object's footprint (the convex hull of its samples in x-y) at the height of
   its lowest contact point, from 2 cm below to 1 cm above. The centre of mass (the centroid
   of the object's area-uniform surface samples, a stand-in for its mass) must project
   inside the convex hull of the support points in x-y by at least ``support_margin`` = 1 cm.
   An object half off an edge, or bridging a gap on one rim, fails.
4. **A tap above** (filling). Scene points must lie above the opening (within 3 cm of its
   x-y centre, 2 to 30 cm above the rim), and they must not be a ceiling or a shelf: the
   scene above the rim, within 15 cm of the opening in x-y and 2 to 30 cm higher, covers at
   most half of that disk (2 cm cells).

A pose is valid when every test that applies passes. :class:`Verdict` keeps each measured
value, so that a table can show why a pose failed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree


@dataclass(frozen=True)
class JudgeSettings:
    """Every threshold of the judge (metres), documented in the module docstring."""

    spacing: float = 0.01
    voxel: float = 0.003
    penetration_depth: float = 0.01
    contact_tolerance: float = 0.01
    contact_distance: float = 0.02
    contact_part_fraction: float = 0.5
    contact_part_link: float = 0.03
    min_part_share: float = 0.05
    support_below: float = 0.02
    support_above: float = 0.01
    support_margin: float = 0.01
    overhead_radius: float = 0.03
    overhead_range: tuple = (0.02, 0.30)
    overhead_disk: float = 0.15
    overhead_max_cover: float = 0.5
    seed: int = 0


@dataclass
class Verdict:
    """The judge's decision on one pose, with the measured values behind it."""

    valid: bool
    penetration: float
    contact: float
    support_margin: float | None = None
    overhead: bool | None = None
    reasons: list = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"valid": bool(self.valid), "penetration_m": round(float(self.penetration), 4),
                "contact_worst_part": round(float(self.contact), 3),
                "support_margin_m": None if self.support_margin is None
                else round(float(self.support_margin), 4),
                "overhead": self.overhead, "reasons": list(self.reasons)}


class JudgeScene:
    """The scene as the judge sees it: dense seeded samples and a KD-tree."""

    def __init__(self, geometry, spacing: float = 0.01, seed: int = 0):
        from ..scene import prepare_scene

        sc = prepare_scene(geometry, spacing, seed=seed + 9176)
        self.points = sc.points
        self.tree = cKDTree(self.points)
        self.spacing = spacing
        self.source = getattr(geometry, "source", "<scene>")


class Judge:
    """Judge poses of one example's query object in scenes.

    Parameters
    ----------
    query : Geometry, the query object as posed in the training example (training frame)
    scene_object : Geometry, the example's scene-object in the same frame
    solid : ``hull`` or ``mesh`` (module docstring)
    support, overhead : which optional tests apply (placing/sitting; filling)
    """

    def __init__(self, query, scene_object, solid: str = "mesh", support: bool = False,
                 overhead: bool = False, settings: JudgeSettings | None = None):
        from ..examples.interactions import surface_points

        self.settings = st = settings or JudgeSettings()
        self.support = support
        self.overhead = overhead
        self.samples = surface_points(query, 20000, st.seed)
        self.com = self.samples.mean(axis=0)
        s_pts = surface_points(scene_object, 300000, st.seed + 1)
        d, _ = cKDTree(s_pts).query(self.samples, workers=-1)
        contact = self.samples[d <= st.contact_tolerance]
        if len(contact) == 0:
            contact = self.samples[d <= d.min() + st.contact_tolerance]
        self.contact_points, self.contact_labels = _parts(contact, st.contact_part_link,
                                                          st.min_part_share)
        self.radius = float(np.linalg.norm(self.samples - self.com, axis=1).max())
        self._build_solid(query, solid)
        top = self.samples[:, 2].max()
        rim = self.samples[self.samples[:, 2] >= top - 0.01]
        self.opening = np.r_[rim[:, :2].mean(axis=0), top]

    @classmethod
    def for_example(cls, example, settings: JudgeSettings | None = None) -> "Judge":
        """The judge of an :class:`~interaction_tensor.examples.interactions.Example`."""
        sp = example.spec
        return cls(example.query, example.scene_object, sp.solid, sp.support, sp.overhead,
                   settings)

    # ------------------------------------------------------------------ solid
    def _build_solid(self, query, solid: str) -> None:
        import trimesh
        from scipy.ndimage import distance_transform_edt

        if solid == "hull" or not query.is_mesh:
            mesh = trimesh.Trimesh(self.samples).convex_hull if not query.is_mesh else \
                trimesh.Trimesh(query.vertices, query.faces, process=True).convex_hull
        else:
            mesh = trimesh.Trimesh(query.vertices, query.faces, process=False)
        from scipy.ndimage import binary_closing, binary_fill_holes

        ext = float(np.ptp(mesh.vertices, axis=0).max())
        pitch = max(self.settings.voxel, ext / 200.0)
        # surface voxels from dense samples (16 per voxel face on average), closed by one
        # voxel (a 6-connected closing) so that no gap between samples lets the fill leak
        area = float(mesh.area)
        count = int(np.clip(16 * area / pitch ** 2, 50000, 4_000_000))
        pts, _ = trimesh.sample.sample_surface(mesh, count, seed=self.settings.seed)
        lo = pts.min(axis=0) - 4 * pitch
        idx = np.floor((pts - lo) / pitch).astype(np.int64)
        shape = idx.max(axis=0) + 5
        occ = np.zeros(shape, bool)
        occ[idx[:, 0], idx[:, 1], idx[:, 2]] = True
        occ = binary_fill_holes(binary_closing(occ, iterations=1) | occ)
        self.pitch = pitch
        self.origin = lo + pitch / 2          # centre of voxel (0, 0, 0)
        self.depth = (distance_transform_edt(occ) * pitch - pitch).astype(np.float32)
        self.depth[~occ] = -1.0

    def depth_at(self, points_training_frame: np.ndarray) -> np.ndarray:
        """(N,) depth (m) of points inside the filled query object; -1 outside."""
        idx = np.rint((points_training_frame - self.origin) / self.pitch).astype(np.int64)
        ok = np.all((idx >= 0) & (idx < np.array(self.depth.shape)), axis=1)
        out = np.full(len(idx), -1.0)
        out[ok] = self.depth[idx[ok, 0], idx[ok, 1], idx[ok, 2]]
        return out

    # ------------------------------------------------------------------ judging
    def judge(self, scene: JudgeScene, pose) -> Verdict:
        """Judge one pose (4x4: training-frame query object -> scene)."""
        st = self.settings
        pose = np.asarray(pose, float)
        rot, t = pose[:3, :3], pose[:3, 3]
        com = rot @ self.com + t
        reasons = []

        near = scene.tree.query_ball_point(com, self.radius + 2 * st.spacing)
        near = np.asarray(near, np.int64)
        local = scene.points[near]
        depth = self.depth_at((local - t) @ rot) if len(local) else np.zeros(0)
        pen = float(max(depth.max(), 0.0)) if len(depth) else 0.0
        if pen > st.penetration_depth:
            reasons.append(f"penetration {pen * 100:.1f} cm")

        cp = self.contact_points @ rot.T + t
        d, _ = scene.tree.query(cp, workers=-1)
        close = d <= st.contact_distance
        worst = 1.0
        for lab in np.unique(self.contact_labels):
            worst = min(worst, float(close[self.contact_labels == lab].mean()))
        if worst < st.contact_part_fraction:
            reasons.append(f"contact part only {worst * 100:.0f} % touching")

        margin = None
        if self.support:
            margin = self._support_margin(local, cp, self.samples @ rot.T + t, com)
            if margin < st.support_margin:
                reasons.append("not supported under its centre of mass"
                               if np.isfinite(margin) else "nothing under it")
        over = None
        if self.overhead:
            over = self._overhead(scene, rot @ self.opening + t)
            if not over:
                reasons.append("no tap-like surface above the opening")
        return Verdict(not reasons, pen, worst, margin, over, reasons)

    def _support_margin(self, local, contact, samples, com) -> float:
        from scipy.spatial import ConvexHull, QhullError

        st = self.settings
        z0 = contact[:, 2].min()
        band = local[(local[:, 2] >= z0 - st.support_below) & (local[:, 2] <= z0 + st.support_above)]
        if len(band) < 3:
            return -np.inf
        try:
            foot = ConvexHull(samples[:, :2]).equations
            under = band[(band[:, :2] @ foot[:, :2].T + foot[:, 2]).max(axis=1) <= 1e-9]
            if len(under) < 3:
                return -np.inf
            hull = ConvexHull(under[:, :2])
        except (QhullError, ValueError):
            return -np.inf
        # signed distance of the centre of mass inside the hull (positive inside)
        eq = hull.equations
        return float(-(eq[:, :2] @ com[:2] + eq[:, 2]).max())

    def _overhead(self, scene: JudgeScene, opening) -> bool:
        st = self.settings
        lo, hi = opening[2] + st.overhead_range[0], opening[2] + st.overhead_range[1]
        idx = np.asarray(scene.tree.query_ball_point(opening + [0, 0, (lo + hi) / 2 - opening[2]],
                                                     np.hypot(st.overhead_disk, (hi - lo) / 2)),
                         np.int64)
        p = scene.points[idx]
        p = p[(p[:, 2] >= lo) & (p[:, 2] <= hi)]
        r = np.linalg.norm(p[:, :2] - opening[:2], axis=1)
        if not (r <= st.overhead_radius).any():
            return False
        disk = p[r <= st.overhead_disk]
        cell = 0.02
        cells = np.unique(np.floor(disk[:, :2] / cell).astype(np.int64), axis=0)
        cover = len(cells) * cell ** 2 / (np.pi * st.overhead_disk ** 2)
        return bool(cover <= st.overhead_max_cover)


def _parts(points: np.ndarray, link: float, min_share: float):
    """Connected parts of ``points`` (links shorter than ``link``), small ones dropped."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    if len(points) > 4000:
        points = points[np.random.default_rng(0).choice(len(points), 4000, replace=False)]
    pairs = cKDTree(points).query_pairs(link, output_type="ndarray")
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                   shape=(len(points), len(points)))
    _, lab = connected_components(g, directed=False)
    counts = np.bincount(lab)
    keep = counts[lab] >= min_share * len(points)
    return points[keep], lab[keep]
