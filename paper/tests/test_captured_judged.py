"""The judge on a captured frame: the seated person detection finds on the TUM desk frame's
chair is a valid seat on the frame's own triangles."""

from __future__ import annotations

import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from itensor_paper.judge import Judge, JudgeScene

from paper_support import shared_file

rd = pytest.importorskip("interaction_tensor.capture")


def test_tum_sitting_finds_the_chair():
    """The sitting example on the TUM frame, as ``itensor detect FRAME sitting-human.npz``
    runs it (the gaussian criterion with its tuned S_aff, the collision test on the frame's
    triangles): its best place is on the chair at the left of the view, the seat on the
    chair's seat (0.45-0.6 m up, not the 0.72 m desk top), the feet over the floor within
    reach, and the judge, on the frame's own triangles, finds it valid."""

    objects = shared_file("objects/paper_bowl.ply").parent
    ex = affordances.build("sitting-human", objects)
    tensor = affordances.build_descriptor("sitting-human", objects, example=ex)
    assert tensor.threshold("gaussian") == affordances.acceptance("sitting")[
        "gaussian_threshold"] < 0.5
    frame = shared_file("rgbd/tum_desk/depth.png").parent
    result = it.detect(str(frame), tensor, it.DetectSettings(top_k=3))
    assert result.settings.criterion == "gaussian" and result.stats["collision_test"] == "on"
    assert result.predictions, "no seat found"
    best = result.predictions[0]
    assert 0.45 < best.position[2] < 0.6 and best.position[0] < -0.3     # the left chair
    # the feet over the floor (z = 0), within the feet test's reach: this chair's seat is
    # 11 cm higher than the example's stool (0.425 m), so they hang about 11 cm above it
    lowest = (best.pose[:3, :3] @ tensor.query_vertices.T)[2].min() + best.pose[2, 3]
    assert 0.0 < lowest < tensor.feet_reach
    scene = result.scene
    verdict = Judge.for_example(ex).judge(JudgeScene(it.Geometry(*scene.mesh)), best.pose)
    assert verdict.valid, verdict.reasons
