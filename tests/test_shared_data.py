"""On the real data in ../shared/data: the paper's bowl, its stool, and kitchen5."""

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor.examples.procedural import parts_mesh, table

from support import shared_file


@pytest.fixture(scope="module")
def paper_bowl_on_table():
    bowl = it.load_geometry(shared_file("objects/paper_bowl.ply"))
    bowl.vertices = bowl.vertices + [0, 0, 0.75]          # resting on a 0.75 m table
    tbl = parts_mesh(table("t", (0, 0), (1.0, 0.8), 0.75))
    return it.InteractionTensor.fit(bowl, tbl, "placing-bowl")


def test_paper_bowl_tensor(paper_bowl_on_table):
    t = paper_bowl_on_table
    assert len(t.bisector_points) > 2000
    np.testing.assert_allclose(t.reference_point[2], 0.75, atol=1e-6)
    assert np.hypot(*t.reference_point[:2]) < 0.03       # under the bowl's centre
    assert t.self_scores["paper-weighted"] > 0.8
    assert t.meta["timings_s"]["total"] < 30


def test_paper_bowl_on_the_stool_point_cloud():
    bowl = it.load_geometry(shared_file("objects/paper_bowl.ply"))
    stool = it.load_geometry(shared_file("objects/stool.ply"))
    top = np.percentile(stool.vertices[:, 2], 99.5)
    centre = stool.vertices[stool.vertices[:, 2] > top - 0.01].mean(axis=0)
    bowl.vertices = bowl.vertices + [centre[0], centre[1], top]
    t = it.InteractionTensor.fit(bowl, stool, "placing-bowl-stool")
    assert abs(t.reference_point[2] - top) < 0.02
    assert len(t.weighted.points) == 512


def test_kitchen5_predictions_are_on_free_horizontal_surfaces(paper_bowl_on_table):
    t = paper_bowl_on_table
    scene = it.prepare_scene(it.load_geometry(shared_file("scenes/kitchen5.ply")),
                             t.scene_spacing, seed=0)
    result = it.detect(scene, t, it.DetectSettings(sample_fraction=0.02, top_k=5, seed=0))
    assert len(result.predictions) == 5
    bowl = t.query_vertices - t.reference_point
    radius = np.hypot(bowl[:, 0], bowl[:, 1]).max()
    height = bowl[:, 2].max()
    for p in result.predictions:
        # on a horizontal surface
        assert abs(scene.normals[p.point_index, 2]) > 0.95
        # nothing of the scene where the bowl would be
        rel = scene.points - p.position
        inside = (np.hypot(rel[:, 0], rel[:, 1]) < radius) & (rel[:, 2] > 0.004) & (rel[:, 2] < height)
        assert inside.sum() == 0, p.position
