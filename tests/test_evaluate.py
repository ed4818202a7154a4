"""Smoke test of the evaluation (CI subset): one example, two small published scenes."""

from __future__ import annotations

import csv

import pytest

from interaction_tensor.evaluation.runner import METHODS, metrics

from conftest import shared_file


def test_metrics_definitions():
    def j(aff, m, group, valid):
        return {"affordance": aff, "method": m, "group": group, "valid": valid}
    js = ([j("placing", "Naive", "top", True)] * 3 + [j("placing", "Naive", "top", False)] * 2
          + [j("placing", "Naive", "bottom", False)] * 4 + [j("placing", "Naive", "bottom", True)])
    rows = metrics(js, ("Naive",))
    r = rows[0]
    assert (r["tp"], r["fp"], r["tn"], r["fn"]) == (3, 2, 4, 1)
    assert r["accuracy"] == pytest.approx(70.0)
    assert r["f_score"] == pytest.approx(100 * 6 / 9)
    assert r["precision"] == pytest.approx(60.0)
    assert rows[-1]["affordance"] == "average" and rows[-1]["accuracy"] == pytest.approx(70.0)


def test_evaluate_smoke_on_two_scenes(tmp_path):
    from interaction_tensor.cli_eval import main

    s1 = shared_file("scenes/office-desk1.ply")
    s2 = shared_file("scenes/office-desk5.ply")
    out = tmp_path / "eval"
    code = main(["evaluate", "--scenes", str(s1), str(s2), "-o", str(out), "--examples",
                 "placing-bowl", "--test-points", "800", "--max-candidates", "12",
                 "--max-bs-candidates", "3", "--seed", "0", "--quiet"])
    assert code == 0
    with open(out / "table1.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == ["affordance", "method", "precision", "accuracy", "f_score",
                             "with_accepted", "runs"]
    assert {r["method"] for r in rows} == set(METHODS)
    assert [r["affordance"] for r in rows] == ["placing", "average"] * 4
    acc = {r["method"]: float(r["accuracy"]) for r in rows if r["affordance"] == "average"}
    f1 = {r["method"]: float(r["f_score"]) for r in rows if r["affordance"] == "average"}
    for v in list(acc.values()) + list(f1.values()):
        assert 0.0 <= v <= 100.0
    assert acc["iT-weighted"] > acc["Naive"]
    assert f1["iT-weighted"] > f1["Naive"]
    for name in ("table1.md", "sampling.csv", "sampling.md", "sampling.png", "timings.md",
                 "judgements.csv", "run.json", "judge_accuracy.csv", "runs.csv"):
        assert (out / name).stat().st_size > 0
    assert len(list((out / "pictures").glob("*.png"))) == 2
    with open(out / "judgements.csv") as fh:
        judged = list(csv.DictReader(fh))
    # scenes x methods x (top 5 + bottom 5); BS's 3 candidates may give fewer places
    it_rows = [j for j in judged if j["method"].startswith("iT")]
    assert len(it_rows) == 2 * 2 * 10
    assert len(judged) <= 2 * 4 * 10


def test_evaluate_bad_input_is_one_line_error(tmp_path, capsys):
    from interaction_tensor.cli_eval import main

    assert main(["evaluate", "--scenes", str(tmp_path / "none"), "-o", str(tmp_path)]) == 2
    assert main(["evaluate", "--scenes", str(tmp_path), "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("itensor: error:") == 2
