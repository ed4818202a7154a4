"""The built-in demo: its predictions must be on free horizontal surfaces."""

import json

import numpy as np

from interaction_tensor.examples import demo
from interaction_tensor.geometry.load import load_geometry


def test_demo_writes_its_outputs(demo_run):
    for name in ("predictions.json", "heatmap.ply", "placing-bowl.npz", "scene.ply",
                 "example_query.ply", "example_scene_object.ply"):
        assert (demo_run / name).stat().st_size > 0
    doc = json.loads((demo_run / "predictions.json").read_text())
    assert len(doc["predictions"]) == 10
    assert len(list((demo_run / "top").glob("top_*.ply"))) == 10
    assert doc["stats"]["test_points_sampled"] == round(0.3 * doc["stats"]["scene_points"])
    # tens of thousands of accepted pairs, in a binary file beside a small JSON
    with np.load(demo_run / "accepted.npz", allow_pickle=False) as acc:
        assert len(acc["score"]) == doc["accepted"]["count"] > 10_000
    assert (demo_run / "predictions.json").stat().st_size < 50_000


def test_demo_top_predictions_are_on_free_surfaces(demo_run):
    ex = demo.build()
    doc = json.loads((demo_run / "predictions.json").read_text())
    bowl = ex.query.vertices
    height = np.ptp(bowl[:, 2])
    for rank, p in enumerate(doc["predictions"][:5], 1):
        pos = np.asarray(p["position"])
        part = demo.support_part(ex.scene_parts, pos)
        # resting on the top face of a piece of furniture or the floor, facing up
        assert part is not None, f"#{rank} at {pos} rests on nothing"
        # with room above it: not under a table, a shelf board or inside the bookcase
        assert demo.clearance_above(ex, pos) > height + 0.05, f"#{rank} at {pos} under something"
        # and the posed bowl does not go into anything
        pose = np.asarray(p["pose"])
        placed = bowl @ pose[:3, :3].T + pose[:3, 3]
        assert demo.collisions(ex, placed, margin=0.003) == 0, f"#{rank} collides"
        posed = load_geometry(demo_run / "top" / f"top_{rank:02d}.ply")
        np.testing.assert_allclose(posed.vertices, placed, atol=1e-5)
