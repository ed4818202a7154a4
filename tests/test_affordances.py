"""The affordance registry: the paper's five declared once, and a sixth added as one module's
worth of declaration, taken up by training, the command line and detection."""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.affordances import (UP, Affordance, ExampleSpec, JudgeRule, Posed,
                                            register, unregister)
from interaction_tensor.cli.main import main
from interaction_tensor.examples.posing import pose_on
from interaction_tensor.examples.procedural import box_part, parts_mesh

CRATE_TOP = 0.4


def _box():
    box = parts_mesh([box_part("box", (0.0, 0.0, 0.05), (0.12, 0.08, 0.10))])
    box.source = "procedural box"
    return box


def _pose(query, spec, scene_object_file, seed):
    crate = parts_mesh([box_part("crate", (0.0, 0.0, CRATE_TOP / 2), (0.4, 0.4, CRATE_TOP))])
    return Posed(pose_on(query, crate, "bottom", (0.0, 0.0), CRATE_TOP, seed), crate,
                 (0.0, 0.0, CRATE_TOP))


#: A toy sixth affordance: a box stacked on a crate, accepted as placing is.
STACKING = Affordance(
    name="stacking",
    question="Could the box rest here, level, fully supported?",
    normal=UP,
    anchor="bottom",
    examples=(ExampleSpec("stacking-box", "a box stacked on a crate", _box),),
    pose=_pose,
    acceptance=affordances.acceptance("placing"),
    judge=JudgeRule(("upright", "penetration", "contact", "support"), hull=True),
)


@pytest.fixture
def stacking():
    register(STACKING)
    try:
        yield STACKING
    finally:
        unregister("stacking")


def test_the_papers_five_affordances_are_registered_with_their_examples():
    assert affordances.names() == ["filling", "placing", "hanging", "sitting", "riding"]
    for name in affordances.names():
        aff = affordances.get(name)
        assert aff.examples and aff.question.endswith("?") and aff.acceptance
        for ex in aff.examples:
            assert affordances.spec(ex.name).affordance == name
            assert affordances.of(ex.name) is aff and ex.normal == aff.normal
    with pytest.raises(it.InputError, match="unknown affordance 'lying'"):
        affordances.get("lying")
    with pytest.raises(ValueError, match="already registered"):
        register(affordances.get("placing"))


def test_a_sixth_affordance_goes_through_training_and_detection(stacking, tmp_path, capsys):
    assert "stacking" in affordances.names() and "stacking-box" in affordances.example_names()
    ex = affordances.build("stacking-box")
    assert ex.spec.affordance == "stacking" and ex.spec.normal == UP
    # posed resting on the crate's top
    assert abs(ex.query.vertices[:, 2].min() - CRATE_TOP) < 0.005
    tensor = affordances.build_descriptor("stacking-box", example=ex)
    assert tensor.threshold() == affordances.acceptance("placing")["threshold"]
    # the API and the command line take its acceptance by name
    trained = it.train(ex.query, ex.scene_object, "my-box", acceptance="stacking")
    assert trained.threshold() == tensor.threshold()
    assert main(["examples", "list"]) == 0
    assert "stacking-box" in capsys.readouterr().out
    # a room with a low and a high table: the box is found on free tops (the floor's too),
    # on more than one of them, and nowhere else
    room = parts_mesh([box_part("floor", (1.0, 0.0, -0.025), (4.0, 2.0, 0.05)),
                       box_part("low", (0.0, 0.0, 0.2), (0.6, 0.6, 0.4)),
                       box_part("high", (2.0, 0.0, 0.45), (0.5, 0.5, 0.9))])
    result = it.detect(room, tensor, sample_fraction=0.12, top_k=6)
    tops = result.positions[:, 2]
    on = np.isclose(tops[:, None], [0.0, 0.4, 0.9], atol=0.01)
    assert len(tops) >= 3 and on.any(axis=1).all() and on.any(axis=0).sum() >= 2, tops
