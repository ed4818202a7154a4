"""Detection's sampled through test (hanging: ``DetectSettings.through``, the descriptor's
``through`` and ``through_section``).

Every pair the score accepts asks whether scene samples cross the posed opening of the hook
(where the example's rail went through it); the exact test on the scene's triangles
(``CollisionCheck``) asks the same of the pairs it ranks. These tests check the grid search
against the cKDTree reference, the hooks it must keep (on a rail, on a thin desk top's edge:
that one is the collision test's to reject) and reject (beside the rail, above it, off its
end, on a cabinet's top), that it keeps every valid hang of the labelled set's validation
rooms, and what detection does with it on and off.
"""

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
