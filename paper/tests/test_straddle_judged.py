"""Detection's straddle and mount tests (riding: ``DetectSettings.straddle`` and ``.mount``,
the descriptor's ``straddle`` and ``mount_height``).

A rider needs the support to go on between the legs ahead of the seat and room for a leg on
each side, and a seat within reach from the ground. These tests check the box test (the
samples in boxes fixed to the rider) against a brute-force reference, the rider it must keep
(astride a narrow bench, facing along it) and the ones it must reject (across the bench, on
a bed's wide top, on a tall partition's top), the riding acceptance it ships with, and the settings' file round trip.
"""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.placement.checks import (
    FAILS_STRADDLE,
    PLACED,
    check_placements,
    straddle_passes,
    straddle_passes_poses,
)

#: only the straddle test decides
STRADDLE_ONLY = ("clearance", "contact", "interior", "ground", "feet", "mount")


@pytest.fixture(scope="module")
def riding():
    return affordances.build_descriptor("riding-human")


@pytest.fixture(scope="module")
def room():
    """A bench 10 cm wide along x (top 0.5 m, x from -1 to 1), a bed 1.6 m wide (top 0.5 m)
    at x = 3, a partition 10 cm wide (top 2.4 m) along x at y = 1, and a floor."""
    parts = [box_part("bench", (0.0, 0.0, 0.25), (2.0, 0.10, 0.5)),
             box_part("bed", (3.0, 0.0, 0.25), (1.0, 1.6, 0.5)),
             box_part("partition", (0.0, 1.0, 1.2), (2.0, 0.10, 2.4)),
             box_part("floor", (1.5, 0.0, -0.01), (6.0, 3.0, 0.02))]
    return it.prepare_scene(parts_mesh(parts), 0.01, seed=0)


def test_a_rider_astride_a_bench_passes_and_across_it_or_on_a_bed_does_not(riding, room):
    """Facing +x (orientation 0) or -x (4) along the bench the rider is astride it; facing +y
    (2) the bench crosses under the seat with nothing ahead between the legs; on the bed's
    top the legs have no room on either side."""
    assert riding.straddle is not None and riding.straddle["astride"] is not None
    bench, bed = [0.0, 0.0, 0.5], [3.0, 0.0, 0.5]
    points = np.array([bench, bench, bench, bed])
    orient = np.array([0, 4, 2, 0])
    ok = straddle_passes(points, orient, riding, room, 8)
    assert ok.tolist() == [True, True, False, False]
    assert check_placements(points, orient, riding, it.DetectSettings(skip_tests=STRADDLE_ONLY),
                            room)[1].tolist() == [PLACED, PLACED, FAILS_STRADDLE,
                                                  FAILS_STRADDLE]
    off = it.DetectSettings(skip_tests=STRADDLE_ONLY + ("straddle",))
    assert (check_placements(points, orient, riding, off, room)[1] == PLACED).all()
    # the same through 4x4 poses (the labelled set's form)
    poses = np.stack([riding.pose(p, o * np.pi / 4) for p, o in zip(points, orient)])
    np.testing.assert_array_equal(straddle_passes_poses(poses, riding, room), ok)
    # the seat is the bench's top, the bench between the legs: a rider, not a hover
    seat = poses[0][:3, :3] @ riding.reference_point + poses[0][:3, 3]
    assert seat[2] == pytest.approx(0.5) and abs(seat[1]) < 0.05
