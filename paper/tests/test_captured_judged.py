"""The judge on a captured frame: the seated person detection finds on the TUM desk frame's
chair is a valid seat on the frame's own triangles."""

from __future__ import annotations

import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from itensor_paper.judge import Judge, JudgeScene

from paper_support import shared_file

rd = pytest.importorskip("interaction_tensor.capture")


def test_tum_sitting_finds_the_chairs():
    """The sitting example on the TUM frame, as ``itensor detect FRAME sitting-human.npz``
    runs it (the gaussian criterion with its tuned S_aff, the collision test on the frame's
    triangles): each of its best four places is a valid seat to the judge, on the frame's
    own triangles with the frame's measured noise allowed as detection allows it, and both
    chairs are among them (the others: two stretches of the desk top's front edge): the seat on a chair's seat (0.45-0.6 m up, not the 0.72 m desk
    top), the feet over the floor within reach."""

    objects = shared_file("objects/paper_bowl.ply").parent
    ex = affordances.build("sitting-human", objects)
    tensor = affordances.build_descriptor("sitting-human", objects, example=ex)
    assert tensor.threshold("gaussian") == affordances.acceptance("sitting")[
        "gaussian_threshold"] < 0.5
    frame = shared_file("rgbd/tum_desk/depth.png").parent
    result = it.detect(str(frame), tensor, it.DetectSettings(top_k=4))
    assert result.settings.criterion == "gaussian" and result.stats["collision_test"] == "on"
    assert len(result.predictions) == 4, "fewer than four seats found"
    scene = result.scene
    assert scene.surface_noise > 0.002
    judge = Judge.for_example(ex)
    judged = JudgeScene(it.Geometry(*scene.mesh), surface_noise=scene.surface_noise)
    chairs = []
    for p in result.predictions:
        verdict = judge.judge(judged, p.pose)
        assert verdict.valid, (p.position, verdict.reasons)
        if 0.45 < p.position[2] < 0.6:
            # the feet over the floor (z = 0), within the feet test's reach: these seats are
            # up to 11 cm higher than the example's stool (0.425 m)
            lowest = (p.pose[:3, :3] @ tensor.query_vertices.T)[2].min() + p.pose[2, 3]
            assert 0.0 < lowest < tensor.feet_reach
            chairs.append(p.position[0])
    assert min(chairs) < -0.3 and max(chairs) > 0.3, chairs       # the left and right chairs
