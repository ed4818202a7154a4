"""The feet test against the judge's labelled poses: a person on a stool stands, one on the
edge of a counter out of reach does not."""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.placement.checks import (
    FAILS_FEET,
    PLACED,
    check_placements,
    feet_gaps,
    feet_gaps_poses,
)

from support import stool_counter_room

#: only the feet test decides
FEET_ONLY = ("clearance", "contact", "interior", "ground")


@pytest.fixture(scope="module")
def sitting():
    return affordances.build_descriptor("sitting-human")


@pytest.mark.parametrize("floor", [True, False])
def test_a_person_on_a_stool_stands_and_one_on_a_counter_edge_does_not(sitting, floor):
    """Facing +x (orientation 0): on the stool the feet rest on the floor (or, without a
    floor, at the height of the lowest thing scanned); on the edge of a 1.4 m counter they
    hang 95 cm in the air, over the floor or over nothing, from a seat out of reach."""
    scene = stool_counter_room(floor, counter=1.4)
    stool = np.array([[2.0, 0.0, 0.45]])
    counter = np.array([[0.0, 0.0, 1.4]])
    points = np.vstack([stool, counter])
    orient = np.zeros(2, np.int64)
    gaps = feet_gaps(points, orient, sitting, scene, 8)
    assert gaps[0] <= sitting.feet_reach < 0.4 < gaps[1]
    settings_ = it.DetectSettings(skip_tests=FEET_ONLY)
    assert check_placements(points, orient, sitting, settings_, scene)[1].tolist() \
        == [PLACED, FAILS_FEET]
    off = it.DetectSettings(skip_tests=FEET_ONLY + ("feet",))
    assert check_placements(points, orient, sitting, off, scene)[1].tolist() == [PLACED, PLACED]
    # the same through 4x4 poses (the labelled set's form)
    poses = np.stack([sitting.pose(p, 0.0) for p in points])
    np.testing.assert_allclose(feet_gaps_poses(poses, sitting, scene), gaps, atol=1e-12)
