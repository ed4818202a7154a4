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
    # one prediction per place, the best 10 places (the room has fewer)
    n = min(10, len(doc["places"]))
    assert len(doc["predictions"]) == n >= 5
    assert len(list((demo_run / "top").glob("top_*.ply"))) == n
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


def test_demo_top_5_are_five_places(demo_run):
    """The room has more than five free surfaces: the top 5 lie on five of them, one each,
    and the places listed are ranked by their best score and hold every accepted pair."""
    ex = demo.build()
    doc = json.loads((demo_run / "predictions.json").read_text())
    places = doc["places"]
    assert doc["stats"]["places"] == len(places) >= 6
    assert [p["index"] for p in places] == list(range(len(places)))
    assert all(a["score"] >= b["score"] for a, b in zip(places, places[1:]))
    top = doc["predictions"][:5]
    assert [p["place"] for p in top] == [0, 1, 2, 3, 4]
    surfaces = demo.surface_names(ex, [p["position"] for p in top])
    assert len(set(surfaces)) == 5 and "nothing" not in surfaces, surfaces
    for p in top:                             # each place is one flat surface round its best
        place = places[p["place"]]
        assert place["hi"][2] - place["lo"][2] < 0.02
        assert np.all(np.asarray(place["lo"]) - 1e-9 <= p["position"])
        assert np.all(np.asarray(p["position"]) <= np.asarray(place["hi"]) + 1e-9)
        assert p["score"] == place["score"]
    with np.load(demo_run / "accepted.npz", allow_pickle=False) as acc:
        assert np.bincount(acc["place"], minlength=len(places)).tolist() == \
            [p["pairs"] for p in places]
        for p in places:
            assert acc["score"][acc["place"] == p["index"]].max() == np.float32(p["score"])
