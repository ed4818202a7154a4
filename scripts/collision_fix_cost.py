"""Diagnosis: what the collision test's fix (d49f879) costs a detection and its rankings.

Runs one example on one published scene as ``itensor evaluate`` runs iT (30 % test points,
the paper's keypoint order, the neighbour cache, then the top and bottom 5 by full score
with their collision checks) and prints, as one JSON line, the seconds of detection and of
ranking, the seconds and pairs of the collision checks, the fcl tests made, and the picks.
``old`` patches in ``MeshCollider.separation`` as it was before d49f879 (a body the limit's
move does not free is called deep at once), ``new`` keeps today's (the shorter moves first).

    python scripts/collision_fix_cost.py new kitchen3 sitting-human
    python scripts/collision_fix_cost.py old kitchen3 sitting-human
"""
import sys, time, json
import numpy as np
import interaction_tensor as it
from interaction_tensor import collision
from interaction_tensor.detect import rank_pairs
from interaction_tensor.examples import interactions
from interaction_tensor.evaluation.common import ranking_radius

variant, scene_name, example = sys.argv[1:4]
SHARED = "../shared/data" if len(sys.argv) < 5 else sys.argv[4]
if variant == "old":
    def separation(self, body, pose, lengths=(0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2), limit=None):
        pose = np.asarray(pose, float)
        if not self.collides(body, pose):
            return 0.0
        if limit is not None:
            if not self.frees(body, pose, limit):
                return float("inf")
            lengths = [x for x in lengths if x < limit] + [limit]
        for length in lengths:
            if self.frees(body, pose, length):
                return float(length)
        return float("inf")
    collision.MeshCollider.separation = separation
calls = [0]
orig = collision.MeshCollider.collides
def counted(self, body, pose):
    calls[0] += 1
    return orig(self, body, pose)
collision.MeshCollider.collides = counted
tensor = interactions.build_descriptor(example, f"{SHARED}/objects")
geom = it.load_geometry(f"{SHARED}/scenes/{scene_name}.ply")
scene = it.prepare_scene(geom, 0.01, seed=0)
t0 = time.perf_counter()
det = it.detect(scene, tensor, it.DetectSettings(sample_fraction=0.3, top_k=0, seed=0,
                keypoint_order="weight", neighbour_cache=True))
t1 = time.perf_counter()
radius = ranking_radius(tensor)
top, top_s, top_ok = rank_pairs(det, 5, radius)
bottom, bot_s, _ = rank_pairs(det, 5, radius, worst=True)
t2 = time.perf_counter()
c = det.collisions
print(json.dumps({"variant": variant, "scene": scene_name, "example": example,
                  "detect_s": round(t1 - t0, 1), "rank_s": round(t2 - t1, 1),
                  "collision_s": round(c.seconds, 1) if c else None,
                  "pairs_tested": c.tests if c else None, "fcl_calls": calls[0],
                  "top": [int(i) for i in top], "top_ok": [bool(x) for x in top_ok],
                  "bottom": [int(i) for i in bottom]}))
