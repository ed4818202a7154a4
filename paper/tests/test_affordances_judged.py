"""A sixth affordance, registered as the library's docs say, is judged by the rule it
declares: its detected places on free tops are valid, a pose in the air or sunk into a top is
not."""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor.affordances import (UP, Affordance, ExampleSpec, JudgeRule, Posed,
                                            acceptance, build, build_descriptor, register,
                                            unregister)
from interaction_tensor.examples.posing import pose_on
from interaction_tensor.examples.procedural import box_part, parts_mesh
from itensor_paper.judge import Judge, JudgeScene


def _box():
    return parts_mesh([box_part("box", (0.0, 0.0, 0.05), (0.12, 0.08, 0.10))])


def _pose(query, spec, scene_object_file, seed):
    crate = parts_mesh([box_part("crate", (0.0, 0.0, 0.2), (0.4, 0.4, 0.4))])
    return Posed(pose_on(query, crate, "bottom", (0.0, 0.0), 0.4, seed), crate, (0.0, 0.0, 0.4))


@pytest.fixture
def stacking():
    aff = register(Affordance(
        name="stacking", question="Could the box rest here, level, fully supported?",
        normal=UP, anchor="bottom", pose=_pose, acceptance=acceptance("placing"),
        examples=(ExampleSpec("stacking-box", "a box stacked on a crate", _box),),
        judge=JudgeRule(("upright", "penetration", "contact", "support"), hull=True)))
    try:
        yield aff
    finally:
        unregister("stacking")


def test_the_judge_applies_a_new_affordances_rule(stacking):
    ex = build("stacking-box")
    judge = Judge.for_example(ex)
    assert judge.tests == stacking.judge.tests and judge.hull and not judge.person
    room = parts_mesh([box_part("floor", (1.0, 0.0, -0.025), (4.0, 2.0, 0.05)),
                       box_part("low", (0.0, 0.0, 0.2), (0.6, 0.6, 0.4)),
                       box_part("high", (2.0, 0.0, 0.45), (0.5, 0.5, 0.9))])
    scene = JudgeScene(room)
    tensor = build_descriptor("stacking-box", example=ex)
    result = it.detect(room, tensor, sample_fraction=0.12, top_k=4)
    assert len(result.predictions) >= 2
    for pose in result.poses:
        v = judge.judge(scene, pose)
        assert v.valid, v.reasons
    up, down = result.poses[0].copy(), result.poses[0].copy()
    up[2, 3] += 0.05                                  # floating above the top
    down[2, 3] -= 0.04                                # sunk into it
    assert not judge.judge(scene, up).valid
    assert not judge.judge(scene, down).valid
    np.testing.assert_allclose(result.poses[0][:3, :3] @ [0, 0, 1], [0, 0, 1], atol=1e-9)
