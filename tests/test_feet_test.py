"""Detection's feet test (``DetectSettings.feet``, the descriptor's ``feet_reach``).

What stood on the example's ground (a seated person's feet) must find something to stand on
within the reach below it, or the scene's ground where the scan has no floor. These tests
check the columns it probes against the example, the fast search against a brute-force
reference, the seats it must keep (a stool, a counter's edge within reach with the feet
dangling) and those it must reject (a counter out of reach, a floor's edge, a high ledge),
and the setting's file round trip.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.detection.search import Engine, detect
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.placement.checks import (
    FAILS_FEET,
    PLACED,
    SEAT_REACH,
    check_placements,
    feet_gaps,
    feet_pass,
    standing_groups,
)

from support import stool_counter_room

#: only the feet test decides
FEET_ONLY = dict(clearance=False, contact=False, interior=False, ground=False)


@pytest.fixture(scope="module")
def sitting():
    return affordances.build_descriptor("sitting-human")


def test_the_sitting_example_stands_on_its_feet(sitting):
    groups = standing_groups(sitting)
    assert sitting.feet_reach == 0.25 and len(groups) >= 2
    sides = set()
    for pts, sole in groups:
        assert sole == pytest.approx(sitting.ground, abs=0.02) and len(pts) >= 3
        assert pts[:, 2].max() <= sitting.ground + 0.02
        sides.add(np.sign(pts[:, 1].mean()))
    assert sides == {-1, 1}                              # a left foot and a right foot
    hanger = affordances.build_descriptor("hanging-hanger")
    assert standing_groups(hanger) == [] and hanger.feet_reach is None


def _highest_under_reference(points, xy, limit, cell=0.02):
    """Brute force: every sample in the columns under each point and their neighbours."""
    cols = np.floor(points[:, :2] / cell).astype(np.int64)
    out = np.full(len(limit), -np.inf)
    for i, (q, lim) in enumerate(zip(xy, limit)):
        c = np.floor(q / cell).astype(np.int64)
        near = (np.abs(cols[:, None, :] - c[None]).max(axis=2) <= 1).any(axis=1)
        z = points[near & (points[:, 2] <= lim), 2]
        out[i] = z.max() if len(z) else -np.inf
    return out


@given(st.integers(0, 2 ** 31 - 1), st.integers(1, 5))
def test_the_column_search_is_exactly_a_brute_force_search(seed, g):
    rng = np.random.default_rng(seed)
    pts = rng.uniform((-0.5, -0.4, 0.0), (0.5, 0.4, 1.0), (rng.integers(1, 400), 3))
    pts[: len(pts) // 3, 2] = np.round(pts[: len(pts) // 3, 2], 1)   # equal heights
    scene = it.Scene(pts, np.tile([0.0, 0.0, 1.0], (len(pts), 1)), 0.01)
    xy = rng.uniform(-0.7, 0.7, (60, g, 2))                          # beside the scan too
    limit = rng.uniform(-0.1, 1.1, 60)
    limit[:10] = np.round(limit[:10], 1)                              # on a sample's height
    got = scene.highest_under(xy, limit)
    np.testing.assert_array_equal(got, _highest_under_reference(pts, xy, limit))


@given(st.integers(0, 2 ** 31 - 1), st.integers(1, 5))
def test_the_column_kernel_finds_what_the_column_search_finds(seed, g):
    """Detection's feet test reads the column table with a Numba kernel that poses each
    foot's points itself: the same heights as the searched (P, F, 2) arrays."""
    from interaction_tensor.placement._kernels import highest

    rng = np.random.default_rng(seed)
    pts = rng.uniform((-0.5, -0.4, 0.0), (0.5, 0.4, 1.0), (rng.integers(1, 400), 3))
    pts[: len(pts) // 3, 2] = np.round(pts[: len(pts) // 3, 2], 1)
    scene = it.Scene(pts, np.tile([0.0, 0.0, 1.0], (len(pts), 1)), 0.01)
    at = rng.uniform((-0.7, -0.7, 0.0), (0.7, 0.7, 1.0), (60, 3))
    orient = rng.integers(0, 4, 60)
    offsets = rng.normal(0.0, 0.1, (4, g, 2))
    limit = rng.uniform(-0.1, 1.1, 60)
    limit[:10] = np.round(limit[:10], 1)
    columns = scene.columns()
    got = highest(at, orient, offsets, limit, columns.table(), columns.cell)
    want = scene.highest_under(at[:, None, :2] + offsets[orient], limit)
    np.testing.assert_array_equal(got, want)


def test_the_feet_test_on_the_grid_equals_the_reference(sitting):
    room = it.prepare_scene(affordances.build("sitting-human").scene_object, 0.01, seed=0)
    rng = np.random.default_rng(2)
    at = room.points[rng.integers(0, len(room.points), 2000)]
    orient = rng.integers(0, 8, len(at))
    ref = feet_gaps(at, orient, sitting, room, 8)
    fast = feet_gaps(at, orient, sitting, room, 8, room.grid())
    assert np.isfinite(ref).any()
    np.testing.assert_array_equal(fast, ref)


def test_the_gap_is_the_drop_to_the_highest_sample_under_each_foot_or_the_ground(sitting):
    """A floor at 0 with a 30 cm step under part of the room; a scan with no floor, whose
    one sample beside the feet (a caster) is the ground."""
    rng = np.random.default_rng(3)
    floor = np.c_[rng.uniform(-2, 2, (20000, 2)), np.zeros(20000)]
    step = floor[floor[:, 0] > 0.5] + [0, 0, 0.3]
    for pts, over_step, over_floor in ((np.vstack([floor, step]), 0.3, 0.0),
                                       (np.array([[0.0, 1.0, -0.4]]), -0.4, -0.4)):
        scene = it.Scene(pts, np.tile([0.0, 0.0, 1.0], (len(pts), 1)), 0.01)
        ref = sitting.reference_point
        # the seat 0.9 m above the floor: the soles 0.9 - (ref z - sole) above it
        soles = 0.9 - (ref[2] - min(s for _, s in standing_groups(sitting)))
        far = np.array([[-1.0, 0.0, 0.9], [1.2, 0.0, 0.9]])          # over the floor, the step
        gap = feet_gaps(far, np.zeros(2, np.int64), sitting, scene, 8)
        np.testing.assert_allclose(gap, [soles - over_floor, soles - over_step], atol=1e-9)


def test_detection_on_a_counter_out_of_reach_predicts_no_one_on_it(sitting):
    """End to end: every pair the score accepts (a low threshold) on the room with a floor
    and a 1.4 m counter; with the feet test no accepted placement has its seat on the
    counter top (the feet dangle from a seat out of reach)."""
    scene = stool_counter_room(True, counter=1.4)
    tensor = affordances.build_descriptor("sitting-human")
    tensor.set_acceptance(1e-3)
    on_top = np.flatnonzero(scene.points[:, 2] > 1.39)
    loose = dict(skip_tests=("clearance", "contact", "interior", "collision"), top_k=3)
    det = detect(scene, tensor, it.DetectSettings(**loose), test_indices=on_top[::12],
                 engine=Engine(score_first=True))
    assert det.stats["pairs_accepted_by_score"] > 0
    # tests first: the same placements kept, and no pair failing the feet test scored
    first = it.detect(scene, tensor, it.DetectSettings(**loose), test_indices=on_top[::12])
    np.testing.assert_array_equal(first.pairs.accepted, det.pairs.accepted)
    assert first.stats["pairs_scored"] == len(first.pair_point) - \
        first.stats["pairs_failing_feet"] < len(first.pair_point)
    # the feet are 97.5 cm above the floor wherever the seat is on the top: the only
    # placements kept have them inside the counter (its faces within reach; the legs go
    # through it: the clearance and collision tests' business, off here)
    kept = np.flatnonzero(det.pairs.accepted)
    assert 0 < det.stats["pairs_failing_feet"] and len(kept) < 0.01 * len(det.pairs.accepted)
    for i in kept:
        pose = tensor.pose(scene.points[det.pair_point[i]], det.pair_orientation[i] * np.pi / 4)
        feet = np.concatenate([c for c, _ in standing_groups(tensor)])
        posed = feet @ pose[:3, :3].T + pose[:3, 3]
        assert np.any(np.all(np.abs(posed[:, :2] - [-0.2, 0.0]) < [0.3, 0.6], axis=1))
    det = detect(scene, tensor, it.DetectSettings(
        skip_tests=loose["skip_tests"] + ("feet",), top_k=3), test_indices=on_top[::12],
        engine=Engine(score_first=True))
    assert det.pairs.accepted.sum() == det.stats["pairs_accepted_by_score"]


def test_feet_may_dangle_from_a_seat_within_reach_of_the_ground(sitting):
    """On the edge of a 0.9 m counter the feet hang 47.5 cm above the floor, past the reach,
    but the seat is within :data:`.checks.SEAT_REACH` of the ground: a person sits on a desk
    or a counter so (the blind panel passed them); on a 1.4 m counter the seat is out of
    reach. Feet with nothing under them past a floor's edge fail however low the seat."""
    orient = np.zeros(2, np.int64)
    only = it.DetectSettings(skip_tests=tuple(FEET_ONLY))
    for counter, kept in ((0.9, PLACED), (1.4, FAILS_FEET)):
        scene = stool_counter_room(True, counter=counter)
        points = np.array([[2.0, 0.0, 0.45], [0.0, 0.0, counter]])
        gaps = feet_gaps(points, orient, sitting, scene, 8)
        assert gaps[0] <= sitting.feet_reach < 0.4 < gaps[1] < np.inf
        assert check_placements(points, orient, sitting, only, scene)[1].tolist() \
            == [PLACED, kept]
    np.testing.assert_array_equal(
        feet_pass([0.1, 0.5, 0.5, np.inf, np.inf], [2.0, 1.2, 1.21, 0.0, 0.5], 0.25),
        [True, True, False, False, False])
    assert SEAT_REACH == 1.2


def test_a_face_beside_the_shins_is_not_something_to_stand_on(sitting):
    """A block whose front is flush with its top (the counter of the judge's traps): a person
    on its edge with the calves 1 cm off the front has the front's samples under the heels'
    margin, but a vertical face is not a floor: the drop goes to the floor, 47.5 cm down."""
    scene = it.prepare_scene(parts_mesh([box_part("block", (0.0, 0.0, 0.45), (0.6, 1.2, 0.9)),
                                         box_part("floor", (0.5, 0.0, -0.01), (3.0, 3.0, 0.02))]),
                             0.01, seed=0)
    feet = np.concatenate([g for g, _ in standing_groups(sitting)])
    heel = float(feet[:, 0].min() - sitting.reference_point[0])
    point = np.array([[0.3 + 0.01 - heel, 0.0, 0.9]])   # the heels 1 cm off the front (x 0.3)
    gap = feet_gaps(point, np.zeros(1, np.int64), sitting, scene, 8)[0]
    soles = 0.9 - (sitting.reference_point[2] - min(s for _, s in standing_groups(sitting)))
    assert gap == pytest.approx(soles, abs=0.011)        # the floor's top at 0 (to a sample)
    # the front's own samples do lie within the footprint's margin, up to the soles
    c = np.floor(scene.points[:, :2] / 0.02).astype(int)
    front = (np.abs(scene.normals[:, 2]) < 0.1) & (scene.points[:, 2] < soles)
    posed = feet + (point[0] - sitting.reference_point)
    cells = np.floor(posed[:, :2] / 0.02).astype(int)
    near = (np.abs(c[front][:, None] - cells[None]).max(axis=2) <= 1).any(axis=1)
    assert near.any()


def test_feet_past_the_edge_of_a_floor_hang_below_the_ground_and_fail(sitting):
    """A floor slab 5 cm thick with nothing beyond its edge: a person on the edge with the
    legs over the void has nothing under the feet and the soles far below the slab's
    underside (the lowest thing around): an infinite gap, whatever the reach."""
    scene = it.prepare_scene(parts_mesh([box_part("floor", (0.0, 0.0, -0.025),
                                                  (2.0, 2.0, 0.05))]), 0.01, seed=0)
    feet = np.concatenate([g for g, _ in standing_groups(sitting)])
    heel = float(feet[:, 0].min() - sitting.reference_point[0])
    edge = np.array([[1.0 + 0.01 - heel, 0.0, 0.0]])     # the heels 1 cm past the edge
    inside = np.array([[0.0, 0.0, 0.45]])                 # a seat's height over the floor
    gaps = feet_gaps(np.vstack([edge, inside]), np.zeros(2, np.int64), sitting, scene, 8)
    assert gaps[0] == np.inf and gaps[1] == pytest.approx(0.45 - sitting.reference_point[2] +
                                                          min(s for _, s in
                                                              standing_groups(sitting)),
                                                          abs=0.011)


def test_feet_on_a_ledge_high_above_the_ground_fail(sitting):
    """A stepped unit: a block to 1.2 m with a 0.45 m block on its back half, on a floor. A
    person on the upper block's front edge has the feet on the 1.2 m step: no drop at all,
    but a ledge no one climbs to (an infinite gap); the same shape with a 0.2 m step is a
    seat with a foot rest (within reach of the step or the floor)."""
    gaps = []
    for step in (1.2, 0.2):
        scene = it.prepare_scene(parts_mesh([
            box_part("floor", (0.0, 0.0, -0.01), (3.0, 3.0, 0.02)),
            box_part("step", (0.0, 0.0, step / 2), (0.8, 1.0, step)),
            box_part("upper", (-0.2, 0.0, step + 0.225), (0.4, 1.0, 0.45))]), 0.01, seed=0)
        # facing +x, the seat 2 cm back from the upper block's front edge (x = 0)
        point = np.array([[-0.02, 0.0, step + 0.45]])
        gaps.append(feet_gaps(point, np.zeros(1, np.int64), sitting, scene, 8)[0])
    assert gaps[0] == np.inf and 0.0 <= gaps[1] <= sitting.feet_reach
