"""The sampled through test keeps every valid hang of the judge's labelled set."""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.engine.numba_backend import available as numba_available
from interaction_tensor.placement.checks import through_crossed_poses
from itensor_paper import labelled
from itensor_paper.rooms import validation


@pytest.fixture(scope="module")
def hanging():
    ex = affordances.build("hanging-hanger")
    return ex, affordances.build_descriptor("hanging-hanger", example=ex)


def test_every_valid_hang_of_the_labelled_set_passes(hanging):
    """The labelled set's validation rooms: every hang the label calls valid has something
    through the hook for the sampled test too (the exact test's positives)."""

    _, tensor = hanging
    valid = [p for p in labelled.load() if p.affordance == "hanging" and p.valid
             and p.scene.startswith("validation:")]
    assert len(valid) >= 20
    for name in sorted({p.scene for p in valid}):
        scene = it.prepare_scene(validation.build_scene(name.split(":", 1)[1]).geometry, 0.01,
                                 seed=0)
        poses = np.array([p.pose for p in valid if p.scene == name], float)
        grid = scene.grid() if numba_available() else None
        assert through_crossed_poses(poses, tensor, scene, grid).all(), name
