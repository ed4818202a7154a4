"""The judge proven on the labelled set: valid poses it must accept, hard negatives it must
reject, per affordance; and the set itself regenerates from code."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from interaction_tensor import affordances
from interaction_tensor.errors import InputError
from itensor_paper import labelled
from itensor_paper.judge import Judge, JudgeScene, JudgeSettings
from itensor_paper.labelled import LabelledPose, summary_markdown
from itensor_paper.rooms import validation

from paper_support import SHARED_DATA


@pytest.fixture(scope="module")
def poses():
    return labelled.load()


@pytest.fixture(scope="module")
def sitting_traps():
    """The sitting example, the judge-only traps scene and the sitting judge."""

    ex = affordances.build("sitting-human", _objects())
    return ex, JudgeScene(validation.build_scene("judge_traps").geometry), Judge.for_example(ex)


def _objects():
    objects = SHARED_DATA / "objects"
    if not (objects / "ycb_mug.ply").exists():
        pytest.skip("shared data not found")
    return str(objects)


def test_the_set_has_20_valid_and_20_invalid_poses_per_affordance(poses):
    counts = Counter((p.affordance, p.valid) for p in poses)
    for aff in ("placing", "sitting", "filling", "riding", "hanging"):
        assert counts[(aff, True)] >= 20 and counts[(aff, False)] >= 20, aff
    # the hard negatives the old judge passed are there
    cases = {p.case for p in poses if not p.valid}
    for needle in ("hook on a flat top", "sunk 10 cm into the seat", "half off the edge",
                   "on a top with no tap above", "hovering", "through the wall",
                   "under a bar, not in a basin", "star base", "on top of a tall unit",
                   "flat against the wall", "turned level on its support",
                   "lying flat on the floor"):
        assert any(needle in c for c in cases), needle


def test_the_bar_traps_fail_the_basin_test_and_the_one_side_tap_test(poses):
    """The mugs under a bar pass every filling test but the basin's when the tap test only
    asks for surface over the opening (what fooled the judge before it had a basin test);
    the bar runs across the opening, so the tap test's one-side rule rejects them as well,
    and no sink is under them: each test alone would (the lenient judge here has no sink
    test, so that the basin's is seen alone)."""

    traps = [p for p in poses if p.scene == "validation:judge_traps" and p.affordance == "filling"]
    assert len(traps) == 12 and not any(p.valid for p in traps)
    example = affordances.build("filling-mug", _objects())
    judge = Judge.for_example(example)
    lenient = Judge.for_example(example, JudgeSettings(overhead_one_side=False,
                                                       overhead_max_angle=360.0,
                                                       sink_sectors=0))     # no sink test
    scene = JudgeScene(validation.build_scene("judge_traps").geometry)
    for p in traps:
        v = lenient.judge(scene, np.asarray(p.pose))
        assert v.overhead and not v.valid
        assert len(v.reasons) == 1 and v.reasons[0].startswith("not in a basin"), v.reasons
        v = judge.judge(scene, np.asarray(p.pose))
        assert v.overhead is False and v.basin < judge.settings.basin_sectors
        opening = np.asarray(p.pose)[:3, :3] @ judge.opening + np.asarray(p.pose)[:3, 3]
        support = (np.asarray(p.pose)[:3, :3] @ example.support_point
                   + np.asarray(p.pose)[:3, 3])[2]
        assert judge._sink(scene, opening, support) < judge.settings.sink_sectors   # no sink
    assert "judge_traps" not in validation.scene_names()        # never tuned on


def test_a_hook_on_a_star_base_hangs_below_the_floor_line_of_a_floorless_scan(poses):
    """The hangers hooked round an office chair's star-base legs (no floor in the scan, as in
    the published office scans) fail the ground test alone; hangers on a rail in the same
    floorless scan pass it."""

    traps = [p for p in poses if p.scene == "validation:floorless_traps"]
    judge = Judge.for_example(affordances.build("hanging-hanger", _objects()))
    scene = JudgeScene(validation.build_scene("floorless_traps").geometry)
    hooks = [p for p in traps if not p.valid and "star base" in p.case]
    rails = [p for p in traps if p.valid]
    assert len(hooks) == 5 and len(rails) >= 3
    for p in hooks:
        v = judge.judge(scene, np.asarray(p.pose))
        assert v.loop and v.contact == 1.0, v.reasons            # hooked round the leg
        assert v.reasons == [f"hangs {v.below_ground * 100:.0f} cm below the ground"]
        assert 0.05 < v.below_ground < 0.12
    for p in rails:
        v = judge.judge(scene, np.asarray(p.pose))
        assert v.valid and v.below_ground < -1.0, v.reasons
    assert "floorless_traps" not in validation.scene_names()     # never tuned on


def test_the_judge_is_right_on_95_percent_of_each_class(poses):
    rows, verdicts = labelled.judge_accuracy(poses, _objects(), SHARED_DATA)
    assert {r["affordance"] for r in rows} == {"placing", "sitting", "filling", "riding",
                                               "hanging"}
    wrong = [(p.affordance, p.valid, p.case, p.note, v.reasons) for p, v in verdicts
             if v.valid != p.valid]
    for r in rows:
        assert r["valid_accuracy"] >= 95.0 and r["invalid_accuracy"] >= 95.0, (r, wrong)


def test_the_file_is_what_the_generator_makes():
    """Regenerating one validation scene gives exactly the stored poses of that scene."""
    stored = [p for p in labelled.load() if p.scene == "validation:office_nofloor"]
    fresh = labelled.generate(_objects(), scenes=["office_nofloor"], log=lambda s: None)
    assert len(fresh) == len(stored) > 0
    for a, b in zip(fresh, stored):
        assert (a.affordance, a.valid, a.case, a.note) == (b.affordance, b.valid, b.case, b.note)
        assert np.allclose(a.pose, b.pose, atol=1e-6)


def test_a_tampered_file_is_refused(tmp_path):
    bad = tmp_path / "poses.json"
    bad.write_text('{"format": "something else"}')

    with pytest.raises(InputError, match="labelled-poses"):
        labelled.load(bad)


def test_summary_counts_cases_and_judge_errors():
    from types import SimpleNamespace


    def pose(valid, case, scene="validation:living_a"):
        return LabelledPose("sitting", "sitting-human", scene, [[1.0]], valid, case, "")
    verdicts = [(pose(True, "seat"), SimpleNamespace(valid=True)),
                (pose(True, "seat", "shared:scenes/living-room2.ply"),
                 SimpleNamespace(valid=False)),
                (pose(False, "sunk"), SimpleNamespace(valid=False))]
    md = summary_markdown(verdicts).splitlines()
    assert md[2] == "| sitting | valid | seat | 2 | 1 | living_a, scenes/living-room2.ply |"
    assert md[3] == "| sitting | invalid | sunk | 1 | 1 | living_a |"


def test_a_person_on_a_high_tops_edge_dangles_the_feet_within_reach(poses):
    """The people sitting on a counter's or a workbench's edge: nothing under the feet down
    to the floor by construction, the feet 40 cm and more in the air, and the seat within
    reach of the floor, where the blind panel passed people on desks and counters: the
    judge passes every one, and a judge that asked the feet to reach the floor would not."""

    edge = [p for p in poses if p.case == "on a high top's edge, feet dangling within reach"]
    assert len(edge) >= 10 and all(p.valid for p in edge)
    assert len({p.scene for p in edge}) >= 3
    ex = affordances.build("sitting-human", _objects())
    judge = Judge.for_example(ex)
    strict = Judge.for_example(ex, JudgeSettings(seat_above_ground=0.0))
    feet = labelled._feet_samples(ex)
    scenes = {}
    for p in edge[::3]:
        if p.scene not in scenes:
            scenes[p.scene] = JudgeScene(validation.build_scene(p.scene.split(":")[1]).geometry)
        pose = np.asarray(p.pose)
        assert labelled._nothing_under(scenes[p.scene].points, feet, pose)
        v = judge.judge(scenes[p.scene], pose)
        assert v.valid and v.feet_gap > 0.4 and v.seat_height <= 1.2
        assert not strict.judge(scenes[p.scene], pose).valid


def test_a_person_with_the_calves_along_a_flush_front_has_nothing_to_stand_on(poses, sitting_traps):
    """The people on the judge traps' flush-fronted counter: the front's vertical face lies
    under the heels' margin; a judge that stood the feet on any surface found them standing
    on it (as it did office-desk1's person on a desk with the legs down its side panel); the
    judge that asks for a surface one can stand on finds them dangling, 40 cm and more
    above the floor, from a seat within reach, and passes them for that alone."""

    flush = [p for p in poses if "flush-fronted" in p.case]
    assert len(flush) >= 5 and all(p.valid for p in flush)
    ex, scene, judge = sitting_traps
    any_surface = Judge.for_example(ex, JudgeSettings(stand_angle=91))
    strict = Judge.for_example(ex, JudgeSettings(seat_above_ground=0.0))
    for p in flush:
        v = judge.judge(scene, np.asarray(p.pose))
        assert v.valid and v.feet_gap > 0.4 and v.seat_height <= 1.2
        assert any_surface.judge(scene, np.asarray(p.pose)).feet_gap <= 0.25
        assert strict.judge(scene, np.asarray(p.pose)).reasons == [
            f"feet dangle from a seat {v.seat_height:.1f} m above the ground: out of reach to "
            "sit"]


def test_a_person_on_a_floors_open_edge_hangs_the_legs_below_everything(poses, sitting_traps):
    """The people on the open edge of the judge traps' floor slab: nothing under the feet and
    the soles 37.5 cm below the lowest thing scanned around (kitchen4's top seats on the edge
    of the scan's floor); a judge that let such feet stand on the ground passed them."""

    edge = [p for p in poses if p.case == "on a floor's open edge, legs hanging below it"]
    assert len(edge) >= 4 and not any(p.valid for p in edge)
    ex, scene, judge = sitting_traps
    lenient = Judge.for_example(ex, JudgeSettings(feet_below_ground=10.0))
    for p in edge:
        v = judge.judge(scene, np.asarray(p.pose))
        assert v.reasons == ["nothing under the feet"] and v.feet_gap == np.inf
        assert lenient.judge(scene, np.asarray(p.pose)).valid


def test_feet_on_a_step_high_above_the_floor_are_no_seat_and_a_foot_rest_is(poses,
                                                                            sitting_traps):
    """The judge traps' stepped units: on the low one the feet rest on a step 20 cm above the
    floor (a seat with a foot rest: valid); on the tall one they rest on a step 1.2 m up, on
    top of a 1.65 m unit no one climbs to sit on (living-room4's top seats, on a 3 m wall
    unit): a judge that took any step for a floor passed them."""

    steps = [p for p in poses if "step" in p.case and p.scene == "validation:judge_traps"]
    assert sum(p.valid for p in steps) >= 3 and sum(not p.valid for p in steps) >= 3
    ex, scene, judge = sitting_traps
    lenient = Judge.for_example(ex, JudgeSettings(feet_above_ground=100.0))
    for p in steps:
        v = judge.judge(scene, np.asarray(p.pose))
        assert v.valid == p.valid, (p.case, v.reasons)
        if not p.valid:
            assert v.reasons == ["feet on a surface 1.2 m above the ground"]
            assert lenient.judge(scene, np.asarray(p.pose)).valid


def test_a_rider_on_a_tall_partition_is_out_of_reach_and_one_on_a_low_wall_rides(poses):
    """The judge traps' walls: astride a 0.9 m wall's or a 0.7 m panel's top is pretend
    riding (valid); astride a 1.4, 1.6 or 2.4 m partition's top the rider passes every other
    test (the partition goes on between the legs, the legs have room, the seat touches) and
    is out of reach from the floor (the published kitchens' top riders straddled their
    2.4-2.7 m walls)."""

    walls = [p for p in poses if p.affordance == "riding" and "wall" in p.case
             or "partition" in p.case]
    assert sum(p.valid for p in walls) >= 6 and sum(not p.valid for p in walls) >= 18
    ex = affordances.build("riding-human", _objects())
    scene = JudgeScene(validation.build_scene("judge_traps").geometry)
    judge = Judge.for_example(ex)
    lenient = Judge.for_example(ex, JudgeSettings(seat_above_ground=100.0,
                                                  rider_feet_reach=100.0))
    for p in walls:
        v = judge.judge(scene, np.asarray(p.pose))
        assert v.valid == p.valid, (p.case, v.reasons)
        assert v.astride and v.legroom and v.contact > 0.1
        if p.valid:
            assert 0.65 <= v.seat_height <= 1.0
        else:
            assert len(v.reasons) == 1 and v.reasons[0].endswith("out of reach to ride")
            assert v.seat_height > 1.4 > judge.settings.seat_above_ground
            assert lenient.judge(scene, np.asarray(p.pose)).valid


def test_knees_behind_a_seats_front_edge_and_legs_through_a_footstool_fail_on_the_body(
        poses, sitting_traps):
    """The knees negatives cross the seat's top with the tops of the shins (the core of the
    person, 2 cm allowed); the footstool negatives cross the scene with the legs only (10 cm
    allowed)."""
    knees = [p for p in poses if p.case.startswith("knees 3 cm behind")]
    stool = [p for p in poses if p.case.startswith("on a bench's edge, the legs through")]
    assert len(knees) >= 20 and len(stool) >= 2
    assert not any(p.valid for p in knees + stool)
    ex, scene, judge = sitting_traps
    for p in stool:
        pose = np.asarray(p.pose)
        v = judge.judge(scene, pose)
        assert set(v.reasons) == {"left leg penetrates the scene deeply",
                                  "right leg penetrates the scene deeply"}
        assert v.penetration == 0.0                       # the core is free
    rows, verdicts = labelled.judge_accuracy(knees[:4], _objects(), SHARED_DATA)
    for _, v in verdicts:
        assert "body penetrates the scene deeply" in v.reasons
