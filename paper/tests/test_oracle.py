"""The exhaustive searches with the judge (evaluation/oracle.py) on procedural scenes whose
answers are known: a sink with a tap, a stool in the open and a stool under a table."""

from __future__ import annotations

import numpy as np
import pytest

from interaction_tensor import affordances
from interaction_tensor.examples import shapes
from interaction_tensor.examples.shapes import _geometry, box
from itensor_paper import oracle as O
from itensor_paper.judge import Judge, JudgeScene


@pytest.fixture(scope="module")
def sink():
    ex = affordances.build("filling-mug")
    return ex, Judge.for_example(ex), JudgeScene(shapes.sink_with_tap())


def test_tap_pretest_is_necessary(sink):
    """Wherever the judge's tap test passes, its pre-test does: the pre-test may only drop
    samples the tap test would drop."""
    ex, judge, js = sink
    rng = np.random.default_rng(0)
    at = js.points[rng.choice(len(js.points), 1500, replace=False)]
    at = np.vstack([at, [[0.0, 0.02, shapes.SINK_BOTTOM]]])          # under the outlet
    rim = float(judge.opening[2] - ex.support_point[2])
    pre = O.tap_candidates(js, judge, rim, at, chunk=400)
    full = np.array([judge._overhead(js, a + [0.0, 0.0, rim]) for a in at])
    assert full[-1] and pre[-1]
    assert not (full & ~pre).any()
    assert (~pre).sum() > 100                       # and it does drop samples


def test_standing_mug_found_under_the_tap_only(sink):
    ex, judge, js = sink
    res = O.standing_filling(js, judge, ex.support_point, fraction=0.25)
    assert res.valid, res.reasons
    ox, oy, _ = shapes.TAP_OUTLET
    at = res.points[[i for i, _ in res.valid]]
    # every valid mug stands on the basin bottom with its opening under the outlet (a
    # sample of the outlet, a tube of radius 1.1 cm, within 3 cm of the opening's axis)
    assert np.allclose(at[:, 2], shapes.SINK_BOTTOM, atol=0.015)
    assert np.hypot(at[:, 0] - ox, at[:, 1] - oy).max() <= \
        judge.settings.overhead_radius + 0.011 + 0.002
    assert {k for _, k in res.valid} == set(range(8))
    # the counter top holds up-facing samples, none of them valid
    assert (np.abs(res.points[:, 2] - 0.9) < 0.01).sum() > 500
    assert res.judged < res.poses and res.pretest < res.poses


def test_standing_pose_keeps_the_opening_over_the_sample(sink):
    ex, judge, _ = sink
    support = np.asarray(ex.support_point)
    pivot = np.r_[judge.opening[:2], support[2]]
    for k in range(8):
        pose = O.standing_pose(pivot, [1.0, 2.0, 0.5], 2 * np.pi * k / 8)
        opening = pose[:3, :3] @ judge.opening + pose[:3, 3]
        assert np.allclose(opening[:2], [1.0, 2.0]) and np.isclose(opening[2] - 0.5,
                                                                  judge.opening[2] - support[2])


@pytest.fixture(scope="module")
def sitter():
    ex = affordances.build("sitting-human")
    tensor = affordances.build_descriptor("sitting-human", example=ex)
    return tensor, Judge.for_example(ex)


def _room(extra):
    return _geometry([box((0.0, 0.0, -0.01), (4.0, 4.0, 0.02))] + extra, "test room")


def _stool() -> list:
    """A 0.45 m stool at the origin: a 40 cm seat on four legs."""
    return [box((0.0, 0.0, 0.42), (0.4, 0.4, 0.06))] + \
        [box((x, y, 0.195), (0.04, 0.04, 0.39)) for x in (-0.17, 0.17) for y in (-0.17, 0.17)]


def test_a_stool_in_the_open_holds_a_sitter(sitter):
    tensor, judge = sitter
    js = JudgeScene(_room(_stool()))
    res = O.region_poses(js, judge, tensor, (-0.2, -0.2, 0.4), (0.2, 0.2, 0.5), cell=0.1)
    assert res.samples >= 9 and res.valid, res.reasons


def test_a_stool_under_a_table_holds_none(sitter):
    """The seat of a stool pushed under a table top 30 cm above it: the body crosses the
    table in every orientation (office-desk1's chair, kitchen1's chairs)."""
    tensor, judge = sitter
    js = JudgeScene(_room(_stool() + [box((0.0, 0.0, 0.735), (1.2, 1.2, 0.03))]))
    res = O.region_poses(js, judge, tensor, (-0.2, -0.2, 0.4), (0.2, 0.2, 0.5), cell=0.1)
    assert res.samples >= 9 and not res.valid
    assert res.reasons["body penetrates the scene deeply"] > 0


def test_a_room_search_keeps_the_seat_over_the_floor(sitter):
    """One sample per cell cube (``cell_3d``, a whole room): the stool's seat and the floor
    under it both keep samples, and the sitters found are on the seat; one per cell in plan
    keeps a single layer."""
    tensor, judge = sitter
    js = JudgeScene(_room(_stool()))
    lo, hi = (-0.4, -0.4, -0.1), (0.4, 0.4, 0.6)
    room = O.region_poses(js, judge, tensor, lo, hi, n_orient=4, cell=0.2, cell_3d=True)
    plan = O.region_poses(js, judge, tensor, lo, hi, n_orient=1, cell=0.2)
    z = room.points[:, 2]
    assert (z > 0.4).sum() >= 4 and (z < 0.05).sum() >= 9
    assert plan.samples < room.samples
    assert room.valid and all(room.points[i][2] > 0.4 for i, _ in room.valid)
