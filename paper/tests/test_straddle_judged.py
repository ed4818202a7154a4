"""The straddle test against the judge: a rider astride a bench passes, across it or on a bed
does not."""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.placement.checks import (
    FAILS_STRADDLE,
    PLACED,
    check_placements,
    straddle_passes,
    straddle_passes_poses,
)

from support import bench_bed_room

#: only the straddle test decides
STRADDLE_ONLY = ("clearance", "contact", "interior", "ground", "feet", "mount")


@pytest.fixture(scope="module")
def riding():
    return affordances.build_descriptor("riding-human")


@pytest.fixture(scope="module")
def room():
    return bench_bed_room()


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
