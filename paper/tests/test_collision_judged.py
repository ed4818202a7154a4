"""The collision test of ranked placements against the judge: the tuned examples carry the
collision tests chosen on the labelled set, the tuning's top ranks untested placements as the
evaluation does, and a seated person's knees through a seat's front edge are rejected."""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.detection.places import suppression_radius
from interaction_tensor.detection.ranking import CollisionCheck, full_scores, rank_pairs
from interaction_tensor.detection.search import Engine, detect
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.geometry.collision import MeshCollider
from itensor_paper.judge import Judge
from itensor_paper.labelled import seated_reach, site_pose
from itensor_paper.tuning import RankingCheck, table_top

#: every pair accepted by score and the sampled placement tests off: only collision decides
OPEN = dict(threshold=1e-3, skip_tests=("clearance", "contact", "interior", "ground"),
            top_k=3)


@pytest.fixture(scope="module")
def hanging():
    ex = affordances.build("hanging-hanger")
    return ex, affordances.build_descriptor("hanging-hanger", example=ex)


def test_the_tuned_examples_carry_the_collision_test_chosen_on_the_labelled_set(hanging):
    _, tensor = hanging
    assert tensor.collision_tests == ((0.01, None),) and tensor.through
    riding = affordances.acceptance("riding")
    assert riding["collision"] == [(0.02, "limbs")] and not riding["through"]
    assert affordances.acceptance("sitting")["collision"] == [(0.02, "limbs")]
    (body, depth), = tensor.collision_bodies()
    assert len(body) == len(tensor.query_faces) and depth == 0.01


def test_the_tunings_top_ranks_untested_placements_as_the_evaluation_does(hanging):
    """With the tests allowed spent part way, the tuning's top k (``table_top``) over the
    full scores picks what the evaluation's ranking of a fresh detection picks with the same
    allowance: a placement it could not test ranks with the pairs that fail a test, not
    above them nor out. The tuning's candidates share one check's verdicts, each ranked
    with an allowance of its own (``RankingCheck``)."""

    ex, tensor = hanging
    scene = it.prepare_scene(ex.scene_object, 0.01, seed=0)
    d = np.linalg.norm(scene.points - ex.support_point, axis=1)
    test = np.r_[np.argsort(d)[:6], np.flatnonzero(d > 0.3)[::97]]

    def fresh(budget):
        return detect(scene, tensor, it.DetectSettings(**OPEN), test_indices=test,
                      engine=Engine(rank=False, collision_max_tests=budget))

    base = fresh(10 ** 6)
    full, placed = full_scores(base, np.arange(len(base.pair_point)))
    position = scene.points[base.pair_point]
    radius = suppression_radius(tensor)
    shared = CollisionCheck(base)
    untested_placed = 0
    for budget in (0, 1, 2, 3, 6, 12, 1000):
        det = fresh(budget)
        idx, _, _ = rank_pairs(det, 4, radius)
        check = det.collisions
        assert check.tests <= budget
        assert table_top(position, full, placed, 4, radius, check).tolist() == idx.tolist()
        view = RankingCheck(shared, budget)
        assert table_top(position, full, placed, 4, radius, view).tolist() == idx.tolist()
        assert view.n_asked == check.tests and view.exhausted == check.exhausted
        untested_placed += int((placed[idx] & (check.state[idx] < 0)).sum())
    assert untested_placed > 0            # the case in question happened


@pytest.mark.parametrize("behind, free", [(-0.01, True), (0.0, True), (0.03, False)])
def test_sitting_collision_test_rejects_knees_through_a_seats_front_edge(behind, free):
    """Sitting's test (the body and each limb freed by its own move of at most 2 cm): sat
    with the calves 1 cm past a 3 cm seat top's front edge, or flush with it, it passes;
    moved back until they are 3 cm behind it, the knees cross the top and no move of 2 cm
    frees the body (the published scenes' counters and TV units, sat on at their edge), and
    the judge rejects it for the same part."""

    ex = affordances.build("sitting-human")
    tensor = affordances.build_descriptor("sitting-human", example=ex)
    _, calves = seated_reach(ex)
    seat = 0.45
    edge = calves + behind                         # the front edge, ahead of the seat point
    scene = parts_mesh([box_part("seat", (edge - 0.3, 0.0, seat - 0.015), (0.6, 0.8, 0.03))])
    collider = MeshCollider(scene.vertices, scene.faces)
    pose = site_pose(ex, (0.0, 0.0, seat), 0.0)
    deep = [collider.penetrates(b, pose, depth)[0] for b, depth in tensor.collision_bodies()]
    assert (not any(deep)) == free
    judged = [name for b, depth, name in Judge.for_example(ex).bodies
              if collider.penetrates(b, pose, depth)[0]]
    assert judged == ([] if free else ["body"]) and deep[0] == (not free)


@pytest.mark.parametrize("example", ["sitting-human", "riding-human"])
def test_the_limbs_test_cuts_a_person_as_the_judge_does(example):
    """One rule in one place: detection's ``"limbs"`` collision test and the judge's
    penetration test cut a person into the same body and limbs (a rider's thighs with its
    legs), so a pose passes the one at 2 cm exactly when every part passes the other."""
    ex = affordances.build(example)
    tensor = affordances.build_descriptor(example, example=ex)
    tensor.set_acceptance(tensor.threshold(), collision=[(0.02, "limbs")])
    judge = Judge.for_example(ex)
    np.testing.assert_allclose(judge.support_point, tensor.reference_point, atol=1e-9)
    mine = [b for b, _ in tensor.collision_bodies()]
    theirs = [(b, depth) for b, depth, _ in judge._bodies(ex.query)]
    assert [len(b) for b in mine] == [len(b) for b, _ in theirs]
    for a, (b, depth) in zip(mine, theirs):
        assert depth == 0.02
        np.testing.assert_array_equal(a.faces, b.faces)
        np.testing.assert_allclose(a.vertices, b.vertices)
