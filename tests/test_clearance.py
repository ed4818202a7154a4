"""The clearance test, exact best/worst ranking of pairs, and the tuning's choice of S_aff."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import interaction_tensor as it
from interaction_tensor.clearance import clearance_offsets, nearest_distance_function, violations
from interaction_tensor.detect import full_scores, keypoint_table, rank_pairs
from interaction_tensor.evaluation.tuning import _columns, accepts, choose, curve
from interaction_tensor.examples.procedural import box_part, parts_mesh, table
from interaction_tensor.predictions import top_k
from interaction_tensor.scoring import score_pairs_exact

from conftest import corner_example


@pytest.fixture(scope="module")
def bowl():
    from interaction_tensor.examples import demo

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
    loose = it.detect(scene, t, it.DetectSettings(sample_fraction=0.5, clearance=False,
                                                  contact=False, interior=False))
    strict = it.detect(scene, t, it.DetectSettings(sample_fraction=0.5,
                                                   stage_order="score-first"))
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
    from interaction_tensor.examples import demo

    room = it.prepare_scene(demo.build().scene, 0.02, seed=0)
    det = it.detect(room, bowl, it.DetectSettings(sample_fraction=0.01, threshold=0.9))
    n = len(det.pairs.score)
    table_ = keypoint_table(bowl, det.settings)
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
    from interaction_tensor.examples import demo

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
    from interaction_tensor.clearance import FAILS_CLEARANCE
    from interaction_tensor.examples import demo

    room = it.prepare_scene(demo.build().scene, 0.02, seed=0)
    det = it.detect(room, bowl, it.DetectSettings(sample_fraction=0.02, threshold=0.5,
                                                  collision=False))
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


@pytest.mark.parametrize("threshold", [0.3, 0.6])
def test_completing_only_the_placed_pairs_changes_only_the_work(bowl, threshold):
    """complete_scores='placed' (the default) stops every pair at its decision and scores
    again in full only the pairs that pass the placement tests: the same decisions, the
    same scores of those pairs bit for bit, the same heat map, predictions and rankings as
    'accepted' (every pair the score accepts completed), with fewer comparisons; a pair the
    score accepted that failed a placement test keeps the partial score of its decision
    until a ranking completes it."""
    from interaction_tensor.clearance import FAILS_COLLISION, PLACED
    from interaction_tensor.examples import demo

    room = it.prepare_scene(demo.build().scene, 0.02, seed=0)

    def run(mode):
        return it.detect(room, bowl, it.DetectSettings(sample_fraction=0.03, threshold=threshold,
                                                       complete_scores=mode, top_k=5,
                                                       stage_order="score-first"))
    p, a = run("placed"), run("accepted")
    failed = a.score_accepted & (a.placement != PLACED) & (a.placement != FAILS_COLLISION)
    acc = a.pairs.accepted
    assert failed.sum() > 50 and acc.sum() > 20 and (~a.score_accepted).sum() > 50
    for name in ("score_accepted", "placement", "heat", "accepted_count"):
        np.testing.assert_array_equal(getattr(p, name), getattr(a, name))
    np.testing.assert_array_equal(p.pairs.accepted, acc)
    np.testing.assert_array_equal(p.pairs.decided_at, a.pairs.decided_at)
    np.testing.assert_array_equal(p.pairs.score[acc], a.pairs.score[acc])
    np.testing.assert_array_equal(p.pairs.score[~a.score_accepted],
                                  a.pairs.score[~a.score_accepted])
    assert [(q.point_index, q.orientation_index, q.score) for q in p.predictions] == \
        [(q.point_index, q.orientation_index, q.score) for q in a.predictions]
    np.testing.assert_array_equal(p.complete, a.score_accepted & ~failed)
    assert p.stats["pairs_completed"] == int((a.score_accepted & ~failed).sum())
    assert (p.pairs.score[failed] <= a.pairs.score[failed]).all()
    assert (p.pairs.score[failed] < a.pairs.score[failed]).mean() > 0.5
    assert p.pairs.comparisons < a.pairs.comparisons
    for worst in (False, True):
        got = rank_pairs(p, 5, 0.15, worst=worst, block=64)
        want = rank_pairs(a, 5, 0.15, worst=worst, block=64)
        for g, w in zip(got, want):
            np.testing.assert_array_equal(g, w)
    # the ranking completed the failed pairs' scores in place
    assert p.complete[failed].all()
    np.testing.assert_array_equal(p.pairs.score[failed], a.pairs.score[failed])


@pytest.mark.parametrize("threshold", [0.3, 0.6])
def test_testing_first_changes_only_the_work(bowl, threshold, monkeypatch):
    """stage_order 'tests-first' (the default) gives every pair the placement tests and
    scores only those that pass: the same final decisions, accepted scores bit for bit,
    heat map, predictions and rankings as score-first with every accepted pair completed;
    the same outcome of the tests wherever score-first ran them; the pairs it scored hold
    the very scores and decisions score-first gave them; the others were never compared."""
    from interaction_tensor.clearance import FAILS_COLLISION, PLACED, UNTESTED
    from interaction_tensor.examples import demo

    room = it.prepare_scene(demo.build().scene, 0.02, seed=0)

    def run(**kw):
        return it.detect(room, bowl, it.DetectSettings(sample_fraction=0.03, threshold=threshold,
                                                       top_k=5, **kw))
    t, a = run(), run(complete_scores="accepted", stage_order="score-first")
    assert t.stats["stage_order"] == "tests-first" and a.stats["stage_order"] == "score-first"
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
    # in another keypoint order too (the adaptive one's pilot made to choose the reverse of
    # the weight order): the rankings' bounds follow the order the pairs were scored in
    import sys

    monkeypatch.setattr(sys.modules["interaction_tensor.detect"], "pilot_order",
                        lambda table, *a, **k: np.arange(table.n)[::-1].copy())
    # (the gaussian criterion, whose keypoints' largest terms differ, so that the bounds
    # depend on the order)
    def gaussian(**kw):
        return it.detect(room, bowl, it.DetectSettings(sample_fraction=0.03, threshold=0.6,
                                                       criterion="gaussian", **kw))
    ad = gaussian(keypoint_order="adaptive")
    ref = gaussian(complete_scores="accepted", stage_order="score-first")
    np.testing.assert_array_equal(ad.pairs.accepted, ref.pairs.accepted)
    scored = np.flatnonzero(ad.scored & ~ad.pairs.accepted)
    assert len(scored) > 10
    full = full_scores(ad, scored)[0]
    bound = ad.pairs.score[scored] + ad.rest[ad.pairs.decided_at[scored]]
    assert (full <= bound + 1e-12).all() and (full >= ad.pairs.score[scored] - 1e-12).all()


def test_tests_first_cannot_complete_every_accepted_pair():
    with pytest.raises(Exception, match="tests-first"):
        it.DetectSettings(stage_order="tests-first", complete_scores="accepted")
    assert not it.DetectSettings(complete_scores="accepted").tests_first
    assert not it.DetectSettings(early_exit=False).tests_first
    assert it.DetectSettings().tests_first
    assert not it.DetectSettings(stage_order="score-first").tests_first


def test_tuning_chooses_the_threshold_of_best_f1(tmp_path):
    from interaction_tensor.evaluation.tuning import COLUMNS

    def row(score, valid, weight=1.0, viol=0, inner=0, touch=1.0):
        r = {"affordance": "placing", "scene": "s", "example": "placing-bowl",
             "score": score, "valid": valid, "weight": weight, "violations": viol,
             "clearance_points": 100, "interior_violations": inner, "interior_points": 200,
             "top": False, "pair": 0, "near_site": True, "reasons": ""}
        r.update({c: touch for c in COLUMNS if c.startswith("contact_")})
        return r
    rows = ([row(0.9, True)] * 8 + [row(0.7, True)] * 2 + [row(0.6, False)] * 6
            + [row(0.95, False, viol=50)] * 4 + [row(0.2, False, weight=10)] * 3)
    c = {r["threshold"]: r for r in curve(rows, limit=0.05)}
    assert c[0.65]["precision"] == pytest.approx(1.0) and c[0.65]["recall"] == pytest.approx(1.0)
    assert c[0.5]["precision"] == pytest.approx(10 / 16)
    runs = [{"affordance": "placing", "scene": "s", "example": "placing-bowl", "sites": 3}]
    _, chosen = choose(rows, runs)
    assert 0.6 < chosen["placing"]["threshold"] <= 0.7
    assert chosen["placing"]["clearance_limit"] < 0.5
    # ties go to the simpler acceptance: no interior or contact test is needed here
    assert chosen["placing"]["interior_limit"] == 1.0
    assert chosen["placing"]["contact"][0] == "off"

    # invalid pairs that score as well as the valid ones but lost their contact, and others
    # with a surface through them: only the new tests can tell them apart
    rows2 = ([row(0.9, True)] * 8 + [row(0.9, False, touch=0.0)] * 6
             + [row(0.9, False, inner=100)] * 5)
    _, chosen2 = choose(rows2, runs)
    ch = chosen2["placing"]
    assert ch["contact"][0] != "off" and ch["interior_limit"] < 1
    assert ch["precision"] == pytest.approx(1.0) and ch["recall"] == pytest.approx(1.0)
    assert ch["without_new_tests"]["precision"] == pytest.approx(8 / 19)

    # pairs failing a fixed test (ground, feet, straddle, mount: column ``fixed``) are never
    # accepted, whatever the threshold and the tuned tests (rows without the column, a
    # tuning recorded before it, are judged on the other columns alone: above)
    # and so are the judged pairs failing the exact collision or through test (``free``)
    rows3 = ([dict(row(0.9, True), fixed=True, free=True)] * 8
             + [dict(row(0.95, False), fixed=False, free=True)] * 4
             + [dict(row(0.95, False), fixed=True, free=False)] * 2)
    ok = accepts(_columns(rows3), 0.5, 0.05, 1.0, ("off", 0.02, 0.1, 90.0))
    assert ok.tolist() == [True] * 8 + [False] * 6
    ch3 = choose(rows3, runs)[1]["placing"]
    assert ch3["precision"] == pytest.approx(1.0) and ch3["recall"] == pytest.approx(1.0)
    assert ch3["contact"][0] == "off" and ch3["interior_limit"] == 1.0

    # a criterion's S_aff for the placement tests an affordance ships with (the gaussian
    # criterion's, for captured scenes): the best F1 threshold once those tests are applied
    from interaction_tensor.evaluation.tuning import shipped_thresholds
    from interaction_tensor.examples.interactions import ACCEPTANCE

    assert ACCEPTANCE["placing"]["clearance_limit"] == 0.05
    rows4 = ([row(0.8, True)] * 6 + [row(0.62, True)] * 2 + [row(0.55, False)] * 5
             + [row(0.95, False, touch=0.0)] * 5)   # lost its contact: the shipped test says no
    best = shipped_thresholds(rows4)["placing"]
    assert 0.55 < best["threshold"] <= 0.62
    assert best["precision"] == pytest.approx(1.0) and best["recall"] == pytest.approx(1.0)
    assert set(shipped_thresholds(rows4)) == {"placing"}

    # the tuning's record is written as one transaction and replaces an earlier one
    from interaction_tensor.evaluation.tuning import TuneResult, write

    curves, chosen = choose(rows, runs)
    res = TuneResult(rows=rows, runs=runs, curves=curves, chosen=chosen, settings={"seed": 0})
    for _ in range(2):
        write(res, tmp_path / "tuning")
    assert sorted(p.name for p in (tmp_path / "tuning").iterdir()) == [
        "tuning.json", "tuning.md", "tuning_pairs.csv"]
    assert "| placing |" in (tmp_path / "tuning" / "tuning.md").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tuning"]


class _FakeCheck:
    """A CollisionCheck stand-in: ``free`` answers from a table and records what it was
    asked."""

    on, exhausted = True, False

    def __init__(self, free):
        self.table, self.asked = free, []

    def free(self, i):
        self.asked.append(i)
        return self.table[i]


def _table_top_reference(pos, score, placed, free, k, radius):
    """Brute force: placed pairs that pass the collision test best first, picked when no
    pick is within ``radius``; then the other pairs that do not cross the scene, with them
    the placed pairs the check could not test (None: its tests are spent); then the pairs
    that cross it."""
    picks = []
    free = np.asarray(free, object)
    passes = np.array([f is True for f in free])
    crosses = np.array([f is False for f in free])
    groups = (placed & passes, ~(placed & passes) & ~crosses, crosses)
    for group in map(np.flatnonzero, groups):
        for i in group[np.argsort(-score[group], kind="stable")]:
            if len(picks) == k:
                return picks
            if all(np.linalg.norm(pos[i] - pos[j]) > radius for j in picks):
                picks.append(int(i))
    return picks


@given(st.integers(0, 2 ** 31 - 1), st.integers(1, 6))
@settings(max_examples=60, deadline=None)
def test_the_tunings_top_is_the_evaluations_ranking(seed, k):
    from interaction_tensor.evaluation.tuning import table_top

    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 80))
    pos = rng.uniform(0, 1, (n, 3))
    score = rng.permutation(n) / n                     # no ties
    placed = rng.uniform(size=n) < 0.4
    # True passes, False crosses the scene, None: not tested (the tests are spent)
    free = [(True, False, None)[c] for c in rng.choice(3, n, p=[0.6, 0.25, 0.15])]
    got = table_top(pos, score, placed, k, 0.3, _FakeCheck(free)).tolist()
    assert got == _table_top_reference(pos, score, placed, free, k, 0.3)
    # the threshold plays no part: only the placement tests and the collision test
    assert table_top(pos, score, placed, k, 0.3).tolist() == _table_top_reference(
        pos, score, placed, [True] * n, k, 0.3)


def test_the_tuning_chooses_the_placement_tests_whose_top_5_are_valid(tmp_path):
    """Two clearance limits: the lenient one has the larger F1 but lets high-scoring invalid
    pairs (10 % of their clearance points violated) into the top 5; the top objective
    takes the strict one, whose top 5 are the valid pairs, and keeps the F1 choice for the
    record."""
    from types import SimpleNamespace

    from interaction_tensor.evaluation.tuning import (TuneResult, TuneSettings, _Run,
                                                      choose_by_tops)

    n = 20
    pos = np.c_[np.arange(n) * 1.0, np.zeros(n), np.zeros(n)]     # 1 m apart: no suppression
    bad = np.arange(n) < 10                                        # the 10 best scores
    feats = {"score": np.linspace(0.9, 0.5, n), "violations": np.where(bad, 10, 0),
             "clearance_points": np.full(n, 100), "interior_violations": np.zeros(n),
             "interior_points": np.full(n, 100)}
    run = _Run("room", "placing-bowl", "placing", SimpleNamespace(radius=0.2), pos,
               np.zeros(n, np.int64), feats, None)
    off = ["off", 0.02, 0.1, 90.0]

    def option(limit, f1):
        return {"threshold": 0.5, "limit": limit, "interior_limit": 1.0, "contact": off,
                "precision": f1, "recall": f1, "f1": f1, "runs_with_a_valid_accepted": 1,
                "runs_with_sites": 1}
    res = TuneResult(curves={"placing": [option(0.2, 0.8), option(0.05, 0.6)]})
    res.chosen["placing"] = {"threshold": 0.5, "clearance_limit": 0.2, "interior_limit": 1.0,
                             "contact": off, "precision": 0.8, "recall": 0.8, "f1": 0.8,
                             "runs_with_a_valid_accepted": 1, "runs_with_sites": 1,
                             "without_new_tests": {"threshold": 0.5, "limit": 0.2,
                                                   "precision": 0.8, "recall": 0.8, "f1": 0.8,
                                                   "runs_with_a_valid_accepted": 1}}

    class Verdicts:
        def valid(self, r, i):
            return (not bad[i], "")
    choose_by_tops(res, [run], Verdicts(), TuneSettings(), lambda _s: None)
    ch = res.chosen["placing"]
    assert ch["clearance_limit"] == 0.05 and ch["top_valid"] == 5 and ch["top_judged"] == 5
    assert ch["by_f1"]["clearance_limit"] == 0.2
    table = {r["limit"]: r["top_valid"] for r in res.top_objective["placing"]}
    assert table == {0.2: 0, 0.05: 5}
    # the record lists every candidate with its top 5
    from interaction_tensor.evaluation.tuning import write

    res.settings = {"seed": 0}
    write(res, tmp_path / "tuning")
    md = (tmp_path / "tuning" / "tuning.md").read_text()
    assert "| 0.05 | off | off | 0.500 | 60.0 | 5/5 |" in md and "| 0.20 | off | off" in md

    # the shipped placement tests are tried however low their F1, and marked
    from interaction_tensor.evaluation.tuning import _contact_column
    from interaction_tensor.examples.interactions import ACCEPTANCE

    acc = ACCEPTANCE["placing"]
    mode, d, _, angle = acc["contact"]
    feats[_contact_column(mode, d, angle)] = np.ones(n)
    shipped = {**option(acc["clearance_limit"], 0.1), "interior_limit": acc["interior_limit"],
               "contact": list(acc["contact"])}
    res.curves = {"placing": [option(0.2, 0.8), option(0.05, 0.6), shipped]}
    choose_by_tops(res, [run], Verdicts(), TuneSettings(top_candidates=1), lambda _s: None)
    rows = res.top_objective["placing"]
    assert [(r["f1"], r["shipped"]) for r in rows] == [(0.8, False), (0.1, True)]
    assert res.chosen["placing"]["top_valid"] == 5          # the shipped tests' top 5
    write(res, tmp_path / "tuning")
    assert "(shipped) |" in (tmp_path / "tuning" / "tuning.md").read_text()


@pytest.fixture
def corner_files(tmp_path):
    """The corner example written as q.ply (the box) and s.ply (floor and walls)."""
    from interaction_tensor.io import write_mesh

    q, s = corner_example()
    write_mesh(tmp_path / "q.ply", q.vertices, q.faces)
    write_mesh(tmp_path / "s.ply", s.vertices, s.faces)
    return tmp_path


def test_train_with_a_tuned_acceptance_and_detect_without_clearance(corner_files):
    from interaction_tensor.cli import main
    from interaction_tensor.examples.interactions import ACCEPTANCE

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
                 "--no-clearance", "--sample-fraction", "0.2", "-q"]) == 0
    import json

    stats = json.loads((tmp_path / "d" / "predictions.json").read_text())["stats"]
    assert stats["pairs_failing_clearance"] == 0
    # every placement test off: the score alone decides
    assert main(["detect", str(tmp_path / "s.ply"), str(out), "-o", str(tmp_path / "e"),
                 "--no-clearance", "--no-contact", "--no-interior", "--sample-fraction", "0.2",
                 "-q"]) == 0
    stats = json.loads((tmp_path / "e" / "predictions.json").read_text())["stats"]
    assert stats["pairs_failing_contact"] == stats["pairs_failing_interior"] == 0
    assert stats["pairs_accepted"] == stats["pairs_accepted_by_score"]


def test_train_with_a_ground_and_refuse_one_above_the_query(corner_files, capsys):
    from interaction_tensor.cli import main

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
