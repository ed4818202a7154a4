"""The clearance test, exact best/worst ranking of pairs, and the tuning's choice of S_aff."""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor.affordances import acceptances
from interaction_tensor.cli.main import main
from interaction_tensor.detection.places import top_k
from interaction_tensor.detection.ranking import full_scores, rank_pairs
from interaction_tensor.detection.search import Engine, detect
from interaction_tensor.engine.scoring import score_pairs_exact
from interaction_tensor.examples import demo
from interaction_tensor.examples.procedural import box_part, parts_mesh, table
from interaction_tensor.geometry.files import write_mesh
from interaction_tensor.placement.checks import (
    FAILS_CLEARANCE,
    FAILS_COLLISION,
    PLACED,
    UNTESTED,
    clearance_offsets,
    nearest_distance_function,
    violations,
)

from support import corner_example


@pytest.fixture(scope="module")
def bowl():

    q, s = demo.training_example()
    return it.InteractionTensor.fit(q, s, "placing-bowl", it.TrainSettings(scene_spacing=0.02))


def test_clearance_points_keep_the_examples_free_space(bowl):
    r = bowl.clearance_radius
    assert len(bowl.clearance_points) == 256 and r.shape == (256,)
    assert 0.0 <= r.min() < 0.005                     # the foot ring touches the table
    assert r.max() == pytest.approx(0.02)            # capped at clearance_max
    assert bowl.clearance_limit == pytest.approx(0.05)


def test_a_board_through_the_bowl_violates_its_clearance(bowl, tmp_path):
    """The same table top: free above (no violation), and with a board 3 cm above the
    table, i.e. through the bowl (most of the bowl's upper clearance points violated)."""
    free = it.prepare_scene(parts_mesh(table("t", (0, 0), (1.0, 0.8), 0.7)), 0.01)
    board = it.prepare_scene(parts_mesh(table("t", (0, 0), (1.0, 0.8), 0.7)
                                        + [box_part("b", (0, 0, 0.74), (1.0, 0.8, 0.01))]), 0.01)
    off = clearance_offsets(bowl, 8)
    p = np.array([[0.0, 0.0, 0.7]])
    counts = []
    for sc in (free, board):
        # the test point: the table-top sample nearest the centre
        i = sc.tree.query(p)[1]
        v = violations(sc.points[i], np.array([0]), off, bowl.clearance_radius, 0.005,
                       nearest_distance_function(sc, bound=0.02))
        counts.append(int(v[0]))
    assert counts[0] <= 2 and counts[1] > 0.2 * 256, counts
    # saved and loaded, the clearance is the same
    bowl.save(tmp_path / "b.npz")
    t2 = it.InteractionTensor.load(tmp_path / "b.npz")
    assert np.array_equal(t2.clearance_points, bowl.clearance_points)
    assert t2.clearance_limit == bowl.clearance_limit


def test_detection_rejects_accepted_pairs_that_violate_clearance():
    q, s = corner_example()
    t = it.InteractionTensor.fit(q, s, "corner-box", it.TrainSettings(query_points=3000, seed=1))
    scene = it.prepare_scene(s, 0.01, seed=2)
    loose = it.detect(scene, t, it.DetectSettings(
        sample_fraction=0.5, skip_tests=("clearance", "contact", "interior")))
    strict = detect(scene, t, it.DetectSettings(sample_fraction=0.5),
                    engine=Engine(score_first=True))
    assert np.array_equal(loose.pairs.accepted, strict.score_accepted)
    assert strict.pairs.accepted.sum() < loose.pairs.accepted.sum()
    assert (strict.clearance_violations[~strict.score_accepted] == -1).all()
    assert (strict.placement[~strict.score_accepted] == -1).all()
    assert np.array_equal(strict.placement == 0, strict.pairs.accepted)
    st = strict.stats
    assert st["pairs_failing_clearance"] + st["pairs_failing_contact"] + \
        st["pairs_failing_interior"] > 0
    assert st["pairs_accepted_by_score"] - st["pairs_failing_clearance"] - \
        st["pairs_failing_contact"] - st["pairs_failing_interior"] == st["pairs_accepted"]
    # tests first (the default): every pair tested, the same pairs accepted
    first = it.detect(scene, t, it.DetectSettings(sample_fraction=0.5))
    np.testing.assert_array_equal(first.pairs.accepted, strict.pairs.accepted)
    assert (first.placement >= 0).all() and (first.clearance_violations >= 0).all()
    np.testing.assert_array_equal(first.placement == 0, first.scored)
    ft = first.stats
    assert ft["pairs_failing_clearance"] > st["pairs_failing_clearance"]
    assert ft["pairs"] - ft["pairs_failing_clearance"] - ft["pairs_failing_contact"] - \
        ft["pairs_failing_interior"] == ft["pairs_scored"] == int(first.scored.sum())


def test_rank_pairs_is_the_exact_best_and_worst_by_full_score(bowl):

    room = it.prepare_scene(demo.build().scene, 0.02, seed=0)
    det = it.detect(room, bowl, it.DetectSettings(sample_fraction=0.01, threshold=0.9))
    n = len(det.pairs.score)
    table_ = bowl.keypoint_table(det.settings)
    exact = np.concatenate([score_pairs_exact(room.points[det.pair_point[s:s + 1000]],
                                              det.pair_orientation[s:s + 1000], table_, room,
                                              2.0, bowl.vectors).score
                            for s in range(0, n, 1000)])
    full, ok = full_scores(det, np.arange(n))
    assert np.allclose(full, exact, atol=1e-12)
    pos = room.points[det.pair_point]
    best, best_s, _ = rank_pairs(det, 5, 0.15, block=64)
    assert best.tolist() == top_k(pos, np.where(ok, 2.0, 0.0) + full, 5, 0.15)
    assert np.allclose(best_s, full[best])
    worst, _, _ = rank_pairs(det, 5, 0.15, worst=True, block=64)
    assert worst.tolist() == top_k(pos, -full, 5, 0.15)


def test_rank_pairs_finds_the_best_rejected_pairs_when_nothing_is_accepted(bowl):
    """Every pair rejected: all bounds equal the threshold, so only the partial scores say
    which pairs to score again first; a fifth of them scored finds the exact best."""

    room = it.prepare_scene(demo.build().scene, 0.02, seed=0)
    det = it.detect(room, bowl, it.DetectSettings(sample_fraction=0.02, threshold=0.95))
    n = len(det.pairs.score)
    assert not det.pairs.accepted.any() and n > 1000
    full, ok = full_scores(det, np.arange(n))
    pos = room.points[det.pair_point]
    exact = top_k(pos, np.where(ok, 2.0, 0.0) + full, 5, 0.15)
    assert max(exact) >= n // 5          # not among the first fifth in pair order
    best, best_s, _ = rank_pairs(det, 5, 0.15, block=64, max_evaluations=n // 5)
    assert best.tolist() == exact
    assert np.allclose(best_s, full[exact])


def test_rank_pairs_reaches_placed_pairs_below_many_better_scored_failures(bowl):
    """The accepted pairs of the highest scores fail their placement tests (as a hanger's
    hooks through furniture do): the pairs that pass rank first however few evaluations
    are allowed, since an accepted pair's key is known without scoring it again (scored
    in score order, 64 evaluations reached only the failures)."""

    room = it.prepare_scene(demo.build().scene, 0.02, seed=0)
    det = it.detect(room, bowl, it.DetectSettings(sample_fraction=0.02, threshold=0.5,
                                                  skip_tests=("collision",)))
    acc = np.flatnonzero(det.pairs.accepted)
    failing = acc[np.argsort(-det.pairs.score[acc], kind="stable")][:len(acc) // 2]
    assert len(failing) > 200
    det.placement[failing] = FAILS_CLEARANCE
    det.pairs.accepted[failing] = False
    n = len(det.pairs.score)
    full, ok = full_scores(det, np.arange(n))
    pos = room.points[det.pair_point]
    exact = top_k(pos, np.where(ok, 2.0, 0.0) + full, 5, 0.15)
    assert ok[exact].all() and not np.isin(exact, failing).any()
    best, best_s, best_ok = rank_pairs(det, 5, 0.15, block=64, max_evaluations=64)
    assert best.tolist() == exact
    assert best_ok.all() and np.allclose(best_s, full[exact])


@pytest.mark.parametrize("threshold", [0.5, 0.7])
def test_testing_first_changes_only_the_work(bowl, threshold):
    """Detection (tests first) gives every pair the placement tests and
    scores only those that pass: the same final decisions, accepted scores bit for bit,
    heat map, predictions and rankings as score-first with every accepted pair completed;
    the same outcome of the tests wherever score-first ran them; the pairs it scored hold
    the very scores and decisions score-first gave them; the others were never compared."""

    room = it.prepare_scene(demo.build().scene, 0.02, seed=0)

    def run(**kw):
        return detect(room, bowl, it.DetectSettings(sample_fraction=0.03, threshold=threshold,
                                                    top_k=5), engine=Engine(**kw))
    t, a = run(), run(score_first=True)
    acc = a.pairs.accepted
    assert acc.sum() > 20 and (~t.scored).sum() > 50 and (~a.score_accepted).sum() > 50
    # some pair the score rejects passes the tests: scored by tests-first, not accepted
    assert (t.scored & ~a.score_accepted).sum() > 10
    np.testing.assert_array_equal(t.pairs.accepted, acc)
    np.testing.assert_array_equal(t.pairs.score[acc], a.pairs.score[acc])
    for name in ("heat", "accepted_count"):
        np.testing.assert_array_equal(getattr(t, name), getattr(a, name))
    assert [(q.point_index, q.orientation_index, q.score) for q in t.predictions] == \
        [(q.point_index, q.orientation_index, q.score) for q in a.predictions]
    tested = a.placement != UNTESTED
    assert not (t.placement == UNTESTED).any()
    np.testing.assert_array_equal(t.placement[tested], a.placement[tested])
    np.testing.assert_array_equal(t.clearance_violations[tested],
                                  a.clearance_violations[tested])
    np.testing.assert_array_equal(t.scored, np.isin(t.placement, (PLACED, FAILS_COLLISION)))
    np.testing.assert_array_equal(t.score_accepted, a.score_accepted & t.scored)
    np.testing.assert_array_equal(t.pairs.score[t.scored], a.pairs.score[t.scored])
    np.testing.assert_array_equal(t.pairs.decided_at[t.scored], a.pairs.decided_at[t.scored])
    assert (t.pairs.score[~t.scored] == 0).all() and (t.pairs.decided_at[~t.scored] == 0).all()
    np.testing.assert_array_equal(t.complete, acc | (t.placement == FAILS_COLLISION)
                                  & t.score_accepted)
    assert t.pairs.comparisons < a.pairs.comparisons
    assert t.stats["pairs_scored"] == int(t.scored.sum()) < t.stats["pairs"]
    assert t.stats["pairs_tested"] == t.stats["pairs"] == len(t.pair_point)
    for worst in (False, True):
        got = rank_pairs(t, 5, 0.15, worst=worst, block=64)
        want = rank_pairs(a, 5, 0.15, worst=worst, block=64)
        for g, w in zip(got, want):
            np.testing.assert_array_equal(g, w)


@pytest.fixture
def corner_files(tmp_path):
    """The corner example written as q.ply (the box) and s.ply (floor and walls)."""

    q, s = corner_example()
    write_mesh(tmp_path / "q.ply", q.vertices, q.faces)
    write_mesh(tmp_path / "s.ply", s.vertices, s.faces)
    return tmp_path


def test_train_with_a_tuned_acceptance_and_detect_without_clearance(corner_files):
    ACCEPTANCE = acceptances()

    tmp_path = corner_files
    out = tmp_path / "t.npz"
    assert main(["train", str(tmp_path / "q.ply"), str(tmp_path / "s.ply"), "--affordance",
                 "box", "-o", str(out), "--acceptance", "placing", "-q"]) == 0
    t = it.InteractionTensor.load(out)
    tuned = ACCEPTANCE["placing"]
    assert t.threshold() == tuned["threshold"]
    assert t.clearance_limit == tuned["clearance_limit"]
    assert t.interior_limit == tuned["interior_limit"]
    assert (t.contact_groups, t.contact_distance, t.contact_fraction,
            t.contact_angle) == tuned["contact"]
    assert main(["detect", str(tmp_path / "s.ply"), str(out), "-o", str(tmp_path / "d"),
                 "--skip-test", "clearance", "--sample-fraction", "0.2", "-q"]) == 0
    import json

    stats = json.loads((tmp_path / "d" / "predictions.json").read_text())["stats"]
    assert stats["pairs_failing_clearance"] == 0
    # every placement test off: the score alone decides
    assert main(["detect", str(tmp_path / "s.ply"), str(out), "-o", str(tmp_path / "e"),
                 "--skip-test", "clearance,contact", "--skip-test", "interior",
                 "--sample-fraction", "0.2",
                 "-q"]) == 0
    stats = json.loads((tmp_path / "e" / "predictions.json").read_text())["stats"]
    assert stats["pairs_failing_contact"] == stats["pairs_failing_interior"] == 0
    assert stats["pairs_accepted"] == stats["pairs_accepted_by_score"]


def test_train_with_a_ground_and_refuse_one_above_the_query(corner_files, capsys):

    tmp_path = corner_files
    out = tmp_path / "t.npz"
    # the box stands on z = 0: with the ground there, its bottom's clearance is nil
    assert main(["train", str(tmp_path / "q.ply"), str(tmp_path / "s.ply"), "--affordance",
                 "box", "-o", str(out), "--ground", "0", "-q"]) == 0
    t = it.InteractionTensor.load(out)
    assert t.ground == 0.0
    bottom = t.clearance_points[:, 2] < 0.002
    assert bottom.any() and (t.clearance_radius[bottom] < 0.0025).all()
    capsys.readouterr()
    assert main(["train", str(tmp_path / "q.ply"), str(tmp_path / "s.ply"), "--affordance",
                 "box", "-o", str(tmp_path / "u.npz"), "--ground", "0.05", "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "ground" in err[0] and "lowest point" in err[0], err
    assert not (tmp_path / "u.npz").exists()
