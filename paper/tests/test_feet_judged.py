"""Detection's feet test (``DetectSettings.feet``, the descriptor's ``feet_reach``).

What stood on the example's ground (a seated person's feet) must find something to stand on
within the reach below it, or the scene's ground where the scan has no floor. These tests
check the columns it probes against the example, the fast search against a brute-force
reference, the seats it must keep and the counter tops it must reject (with a floor and
without one), and the setting's file round trip.
"""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.placement.checks import (
    FAILS_FEET,
    PLACED,
    check_placements,
    feet_gaps,
    feet_gaps_poses,
)

#: only the feet test decides
FEET_ONLY = ("clearance", "contact", "interior", "ground")


@pytest.fixture(scope="module")
def sitting():
    return affordances.build_descriptor("sitting-human")


def _room(floor: bool):
    """A stool (top 0.45 m) and a counter (top 0.9 m, its front edge at x = 0.1), with or
    without a floor; the lowest thing scanned without one is the furniture's base."""
    parts = [box_part("stool", (2.0, 0.0, 0.225), (0.4, 0.4, 0.45)),
             box_part("counter", (-0.2, 0.0, 0.45), (0.6, 1.2, 0.9))]
    if floor:
        parts.append(box_part("floor", (0.5, 0.0, -0.01), (4.0, 3.0, 0.02)))
    return it.prepare_scene(parts_mesh(parts), 0.01, seed=0)


@pytest.mark.parametrize("floor", [True, False])
def test_a_person_on_a_stool_stands_and_one_on_a_counter_edge_does_not(sitting, floor):
    """Facing +x (orientation 0): on the stool the feet rest on the floor (or, without a
    floor, at the height of the lowest thing scanned); on the counter's edge they hang 45 cm
    in the air, over the floor or over nothing."""
    scene = _room(floor)
    stool = np.array([[2.0, 0.0, 0.45]])
    counter = np.array([[0.0, 0.0, 0.9]])
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
