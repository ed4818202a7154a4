"""The placement tests beside the clearance test: interior points and contact groups.

Each test poses an example's query object where the example had it (test point = the
reference point, orientation 0) in small procedural scenes, valid and invalid, and checks
what the tests measure there: the contact a name promises (the seat on the seat, the feet on
the floor, the rail inside the hook) and a surface through the body.
"""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.examples import demo, shapes
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.geometry.sampling import winding_numbers
from interaction_tensor.placement.checks import (
    FAILS_CONTACT,
    FAILS_INTERIOR,
    PLACED,
    check_placements,
    contact_fractions,
    contact_kept,
    interior_violations,
    nearest_samples,
)


@pytest.fixture(scope="module")
def sitting():
    ex = affordances.build("sitting-human")
    return ex, affordances.build_descriptor("sitting-human", example=ex, tuned=False)


@pytest.fixture(scope="module")
def hanging():
    ex = affordances.build("hanging-hanger")
    return ex, affordances.build_descriptor("hanging-hanger", example=ex, tuned=False)


def _scene(parts):
    return it.prepare_scene(parts_mesh(parts), 0.01, seed=0)


def _floor():
    return box_part("floor", (0, 0, -0.025), (3.0, 3.0, 0.05))


def _seat(tensor, top: float):
    """A 0.45 x 0.45 m block under the example's seat point, its top at ``top``."""
    x, y, _ = tensor.reference_point
    return box_part("seat", (x, y, top / 2), (0.45, 0.45, top))


def _at_reference(tensor, height: float | None = None):
    p = tensor.reference_point.copy()
    if height is not None:
        p[2] = height
    return p[None, :], np.zeros(1, np.int64)


def test_the_seated_examples_contact_groups_are_the_seat_and_the_feet(sitting):
    ex, t = sitting
    ids, pts = t.contact_group_ids, t.contact_group_points
    seat_z = ex.support_point[2]
    groups = [pts[ids == g] for g in range(ids.max() + 1)]
    # group 0 lies on the stool's top, at the reference point
    assert np.abs(groups[0][:, 2] - seat_z).max() < 0.02
    assert t.ground == pytest.approx(0.0, abs=1e-9)
    # and both feet touch the floor the stool stands on (the example's ground)
    feet = [g for g in groups if g[:, 2].max() < 0.03]
    assert len(feet) >= 2
    assert {np.sign(g[:, 1].mean()) for g in feet} == {-1.0, 1.0}      # left and right
    # what each touched: the stool's top and the floor, both facing up (a few seat points
    # touch the top's rounded edge)
    up = np.abs(t.contact_group_normals[:, 2]) > 0.9
    assert all(up[ids == g].mean() > 0.9 for g in range(ids.max() + 1))
    # the feet's clearance points have no free space under them any more
    soles = t.clearance_points[:, 2] < 0.005
    assert soles.any() and (t.clearance_radius[soles] < 0.006).all()


def test_interior_points_lie_inside_the_body_at_their_depth(sitting):
    ex, t = sitting
    assert len(t.interior_points) >= 200
    w = winding_numbers(t.interior_points, ex.query.vertices, ex.query.faces)
    assert (w > 0.5).all()
    st = it.TrainSettings()
    assert t.interior_radius.min() >= st.interior_min_depth - 1e-12
    assert t.interior_radius.max() <= st.interior_max + 1e-12
    # thin-walled objects have none: the demo bowl

    q, s = demo.training_example()
    bowl = it.InteractionTensor.fit(q, s, "bowl", it.TrainSettings(scene_spacing=0.02))
    assert len(bowl.interior_points) == 0


def test_a_seat_at_the_examples_height_keeps_every_contact_and_a_counter_does_not(sitting):
    _, t = sitting
    seat_z = t.reference_point[2]
    tests = [(0.10, 90.0), (0.10, 30.0)]
    chair = _scene([_floor(), _seat(t, seat_z)])
    counter = _scene([_floor(), _seat(t, seat_z + 0.45)])
    f_chair = contact_fractions(*_at_reference(t), t, tests, 8, chair, chair.grid())
    f_counter = contact_fractions(*_at_reference(t, seat_z + 0.45), t, tests, 8, counter,
                                  counter.grid())
    ids = t.contact_group_ids
    feet = np.array([t.contact_group_points[ids == g, 2].max() < 0.03
                     for g in range(ids.max() + 1)])
    assert f_chair.shape == (1, 2, len(feet)) and feet.any() and not feet[0]
    assert (f_chair >= 0.9).all()                                # seat and feet touch
    assert (f_counter[0, :, ~feet] >= 0.9).all()                 # the seat still does
    # the feet hang in the air: nothing facing up within 10 cm (the counter's front is
    # within reach of the toes, but it faces sideways)
    assert f_counter[0, 1, feet].max() == 0.0
    for mode, chair_ok, counter_ok in (("main", True, True), ("all", True, False)):
        assert contact_kept(f_chair[:, 1], mode, 0.5)[0] == chair_ok
        assert contact_kept(f_counter[:, 1], mode, 0.5)[0] == counter_ok
    # the reference path (cKDTree) measures the same
    assert np.array_equal(contact_fractions(*_at_reference(t), t, tests, 8, chair, None),
                          f_chair)


def test_a_board_through_the_body_violates_the_interior_and_a_seat_does_not(sitting):
    _, t = sitting
    seat_z = t.reference_point[2]
    x, y, _ = t.reference_point
    chair = _scene([_floor(), _seat(t, seat_z)])
    board = _scene([_floor(), _seat(t, seat_z),
                    box_part("shelf", (x + 0.1, y, seat_z + 0.35), (0.9, 1.2, 0.02))])
    n = len(t.interior_points)
    ok = interior_violations(*_at_reference(t), t, 0.01, 8, chair, chair.grid())[0]
    through = interior_violations(*_at_reference(t), t, 0.01, 8, board, board.grid())[0]
    assert ok <= 0.01 * n
    assert through >= 0.05 * n
    assert interior_violations(*_at_reference(t), t, 0.01, 8, board, None)[0] == through
    # as a placement: the board fails the interior test (not the clearance test, which a
    # 2 cm board crossing a body hardly touches), the chair passes everything
    t2 = _copy_with(t, interior_limit=0.02, contact=("all", 0.1, 0.5, 30.0),
                    clearance_limit=0.2)
    st = it.DetectSettings()
    for sc, want in ((chair, PLACED), (board, FAILS_INTERIOR)):
        _, outcome = check_placements(*_at_reference(t), t2, st, sc, sc.grid())
        assert outcome[0] == want
    counter = _scene([_floor(), _seat(t, seat_z + 0.45)])
    _, outcome = check_placements(*_at_reference(t, seat_z + 0.45), t2, st, counter,
                                  counter.grid())
    assert outcome[0] == FAILS_CONTACT


def test_a_hook_on_a_round_rail_touches_along_its_arc_and_on_a_board_edge_only_at_its_top(
        hanging):
    _, t = hanging
    assert t.contact_group_ids.max() == 0 or (t.contact_group_ids == 0).sum() >= 8
    rail_top = t.reference_point[2]
    # the hook's contact arc faces the rail: its normals turn about the rail's axis (y)
    arc = t.contact_group_normals[t.contact_group_ids == 0]
    assert np.ptp(np.degrees(np.arctan2(arc[:, 0], arc[:, 2]))) > 40
    rail = it.prepare_scene(shapes.coat_rail(), 0.01, seed=0)
    # a 3 cm board whose top is the rail's top, the hook over its front edge
    board = _scene([box_part("board", (t.reference_point[0] - 0.2, 0, rail_top - 0.015),
                             (0.4, 0.9, 0.03))])
    tests = [(0.02, 90.0), (0.02, 30.0)]
    f_rail = contact_fractions(*_at_reference(t), t, tests, 8, rail, rail.grid())[0, :, 0]
    f_board = contact_fractions(*_at_reference(t), t, tests, 8, board, board.grid())[0, :, 0]
    assert f_rail[1] >= 0.6                      # normals all round the arc match
    assert f_board[0] >= 0.3                     # close enough to the board...
    assert f_board[1] < 0.5 * f_rail[1]          # ...but its flat top faces one way only


def test_nearest_samples_match_the_reference():
    rng = np.random.default_rng(3)
    sc = _scene([_floor(), box_part("b", (0.2, 0.1, 0.3), (0.3, 0.4, 0.6))])
    q = rng.uniform(-0.5, 0.5, (2000, 3)) + [0, 0, 0.5]
    d_grid, i_grid = nearest_samples(q, sc, sc.grid())
    d_ref, _ = nearest_samples(q, sc, None)
    assert np.allclose(d_grid, d_ref, atol=1e-12)
    assert np.allclose(np.linalg.norm(sc.points[i_grid] - q, axis=1), d_grid)


def _copy_with(tensor, **acceptance):
    import copy

    t = copy.deepcopy(tensor)
    t.set_acceptance(t.threshold(), **acceptance)
    return t


@pytest.mark.parametrize("example", ["sitting-human", "riding-human", "hanging-hanger"])
def test_the_order_of_the_tests_changes_no_decision(example):
    """A pair is placed when it passes every test, whatever their order, and reports the
    first of :data:`TEST_ORDER` it fails; each test alone gives the same answer as in the
    sequence, on the grid and on the reference alike."""
    from interaction_tensor.placement import checks
    from interaction_tensor.settings import PLACEMENT_TESTS

    ex = affordances.build(example)
    tensor = affordances.build_descriptor(example, example=ex)
    room = it.prepare_scene(demo.build().scene, 0.02, seed=0)
    rng = np.random.default_rng(1)
    at = room.points[rng.integers(0, len(room.points), 1500)]
    orient = rng.integers(0, 8, len(at))
    codes = {"fills": checks.FAILS_TAP, "ground": checks.FAILS_GROUND,
             "mount": checks.FAILS_MOUNT, "feet": checks.FAILS_FEET,
             "straddle": checks.FAILS_STRADDLE, "clearance": checks.FAILS_CLEARANCE,
             "through": checks.FAILS_THROUGH, "interior": checks.FAILS_INTERIOR,
             "contact": checks.FAILS_CONTACT}
    assert set(checks.TEST_ORDER) == set(codes) and set(codes) <= set(PLACEMENT_TESTS)
    for grid in (room.grid(), None):
        _, outcome = check_placements(at, orient, tensor, it.DetectSettings(), room, grid)
        alone = {}
        for name in checks.TEST_ORDER:
            others = tuple(t for t in PLACEMENT_TESTS if t != name)
            alone[name] = check_placements(at, orient, tensor,
                                           it.DetectSettings(skip_tests=others), room,
                                           grid)[1] == PLACED
        np.testing.assert_array_equal(outcome == PLACED,
                                      np.all(list(alone.values()), axis=0))
        for i in np.flatnonzero(outcome != PLACED):
            first = next(n for n in checks.TEST_ORDER if not alone[n][i])
            assert outcome[i] == codes[first]
        assert (outcome != PLACED).any() and len(np.unique(outcome)) >= 2
