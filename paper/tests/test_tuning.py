"""The tuning of each affordance's acceptance on the validation rooms: the threshold of best F1,
the ranking the evaluation uses, and placement tests whose top 5 the judge finds valid."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from interaction_tensor.affordances import acceptances
from itensor_paper.tuning import (
    COLUMNS,
    TuneResult,
    TuneSettings,
    _columns,
    _contact_column,
    _Run,
    accepts,
    choose,
    choose_by_tops,
    curve,
    shipped_thresholds,
    table_top,
    write,
)

from support import FakeCheck


def test_tuning_chooses_the_threshold_of_best_f1(tmp_path):

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
    ACCEPTANCE = acceptances()

    assert ACCEPTANCE["placing"]["clearance_limit"] == 0.05
    rows4 = ([row(0.8, True)] * 6 + [row(0.62, True)] * 2 + [row(0.55, False)] * 5
             + [row(0.95, False, touch=0.0)] * 5)   # lost its contact: the shipped test says no
    best = shipped_thresholds(rows4)["placing"]
    assert 0.55 < best["threshold"] <= 0.62
    assert best["precision"] == pytest.approx(1.0) and best["recall"] == pytest.approx(1.0)
    assert set(shipped_thresholds(rows4)) == {"placing"}

    # the tuning's record is written as one transaction and replaces an earlier one

    curves, chosen = choose(rows, runs)
    res = TuneResult(rows=rows, runs=runs, curves=curves, chosen=chosen, settings={"seed": 0})
    for _ in range(2):
        write(res, tmp_path / "tuning")
    assert sorted(p.name for p in (tmp_path / "tuning").iterdir()) == [
        "tuning.json", "tuning.md", "tuning_pairs.csv"]
    assert "| placing |" in (tmp_path / "tuning" / "tuning.md").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tuning"]


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

    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 80))
    pos = rng.uniform(0, 1, (n, 3))
    score = rng.permutation(n) / n                     # no ties
    placed = rng.uniform(size=n) < 0.4
    # True passes, False crosses the scene, None: not tested (the tests are spent)
    free = [(True, False, None)[c] for c in rng.choice(3, n, p=[0.6, 0.25, 0.15])]
    got = table_top(pos, score, placed, k, 0.3, FakeCheck(free)).tolist()
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

    res.settings = {"seed": 0}
    write(res, tmp_path / "tuning")
    md = (tmp_path / "tuning" / "tuning.md").read_text()
    assert "| 0.05 | off | off | 0.500 | 60.0 | 5/5 |" in md and "| 0.20 | off | off" in md

    # the shipped placement tests are tried however low their F1, and marked
    ACCEPTANCE = acceptances()

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
