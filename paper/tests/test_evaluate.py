"""Smoke test of the evaluation (CI subset): one example, two small published scenes."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from interaction_tensor.cli.main import main
from interaction_tensor.detection.search import Engine
from interaction_tensor.errors import InputError
from interaction_tensor.geometry.files import atomic_dir
from itensor_paper import runner
from itensor_paper.merge import redraw
from itensor_paper.pictures import PANEL, TITLE
from itensor_paper.runner import METHODS, metrics

from paper_support import shared_file


def test_metrics_definitions():
    def j(aff, m, group, valid, accepted=True, scene="s1"):
        return {"affordance": aff, "method": m, "group": group, "valid": valid,
                "accepted": accepted, "scene": scene, "example": aff + "-x"}
    # a top 5 of 2 accepted valid poses, 1 accepted invalid, and 2 rejected fillers (one
    # of them valid all the same)
    js = ([j("placing", "Naive", "top", True)] * 2 + [j("placing", "Naive", "top", False)]
          + [j("placing", "Naive", "top", True, False), j("placing", "Naive", "top", False, False)]
          + [j("placing", "Naive", "bottom", False, False)] * 4
          + [j("placing", "Naive", "bottom", True, False)]
          # sitting accepts nothing: its precision of accepted top poses is undefined
          + [j("sitting", "Naive", "top", False, False)] * 5)
    rows = metrics(js, ("Naive",))
    r = rows[0]
    assert (r["tp"], r["fp"], r["tn"], r["fn"]) == (3, 2, 4, 1)
    assert r["accuracy"] == pytest.approx(70.0)
    assert r["f_score"] == pytest.approx(100 * 6 / 9)
    assert r["precision"] == pytest.approx(60.0)
    # of the 4 valid places among top and bottom, 3 are in the top
    assert r["forced_choice"] == pytest.approx(75.0)
    # of the 3 top poses it accepted, 2 are valid; the rejected fillers do not count
    assert (r["accepted_top"], r["accepted_top_valid"]) == (3, 2)
    assert r["accepted_precision"] == pytest.approx(100 * 2 / 3)
    sit = rows[1]
    assert sit["affordance"] == "sitting" and sit["accepted_top"] == 0
    assert np.isnan(sit["accepted_precision"]) and sit["precision"] == 0.0
    assert np.isnan(sit["forced_choice"])                 # nothing valid to choose
    avg = rows[-1]
    assert avg["affordance"] == "average"
    assert avg["accuracy"] == pytest.approx((70.0 + 0.0) / 2)
    assert avg["forced_choice"] == pytest.approx(75.0)    # over the affordances defining it
    # the average share pools the accepted top poses (sitting adds none)
    assert avg["accepted_precision"] == pytest.approx(100 * 2 / 3)
    assert (avg["accepted_top"], avg["accepted_top_valid"]) == (3, 2)
    # pooled, not the mean of the affordances' shares: 3 of 4, not (2/3 + 1) / 2
    rows = metrics(js + [j("hanging", "Naive", "top", True)], ("Naive",))
    assert rows[-1]["accepted_precision"] == pytest.approx(75.0)


def test_known_places_are_the_searches_that_found_one(tmp_path):
    path = tmp_path / "known.csv"
    path.write_text("scene,example,valid_places,search\n"
                    "k1,filling-mug,2,filling_oracle.py\n"
                    "l2,riding-human,0,region_oracle.py\n")
    assert runner.known_places(path) == {("k1", "filling-mug")}
    assert runner.known_places(tmp_path / "none.csv") == set()
    shipped = runner.known_places()
    assert ("kitchen1", "filling-mug") in shipped
    assert ("living-room2", "riding-human") not in shipped


def test_place_recall_and_false_acceptance():
    def j(scene, m, group, valid, accepted):
        return {"affordance": "sitting", "method": m, "group": group, "valid": valid,
                "accepted": accepted, "scene": scene, "example": "sitting-human"}

    def run(scene, m, any_accepted):
        return {"scene": scene, "example": "sitting-human", "affordance": "sitting",
                "method": m, "any_accepted": any_accepted}
    js = [j("a", "iT", "top", True, True),        # a: a place, and iT reports it
          j("a", "Naive", "top", False, True),    # ... Naive reports a wrong one
          j("b", "iT", "top", False, True),       # b: iT reports a wrong place; Naive's
          j("b", "Naive", "bottom", True, False),  # bottom pose shows b holds one
          j("c", "iT", "top", False, False),      # c: nothing valid seen, iT accepts none,
          j("c", "Naive", "top", False, True),    # Naive accepts a wrong one
          j("d", "iT", "top", False, False),      # d: a place only a search found
          j("d", "Naive", "top", False, True)]
    runs = [run(s, m, any(x["accepted"] for x in js if x["scene"] == s and x["method"] == m))
            for s in "abcd" for m in ("iT", "Naive")]
    rows = {r["method"]: r for r in metrics(js, ("iT", "Naive"), runs,
                                            known={("d", "sitting-human")})
            if r["affordance"] == "sitting"}
    it, naive = rows["iT"], rows["Naive"]
    assert (it["runs_finding_place"], it["runs_with_place"]) == (1, 3)     # a of a, b, d
    assert it["place_recall"] == pytest.approx(100 / 3)
    assert (it["runs_accepting_falsely"], it["runs_without_place"]) == (0, 1)   # c
    assert (naive["runs_finding_place"], naive["runs_accepting_falsely"]) == (0, 1)
    assert naive["false_acceptance"] == pytest.approx(100.0)
    # without the search, d is a run with no place known: Naive accepting there is false
    rows = {r["method"]: r for r in metrics(js, ("iT", "Naive"), runs, known=())
            if r["affordance"] == "average"}
    assert (rows["Naive"]["runs_accepting_falsely"], rows["Naive"]["runs_without_place"]) == (2, 2)
    assert (rows["iT"]["runs_finding_place"], rows["iT"]["runs_with_place"]) == (1, 2)


def test_evaluate_smoke_on_two_scenes(tmp_path):

    s1 = shared_file("scenes/office-desk1.ply")
    s2 = shared_file("scenes/office-desk5.ply")
    out = tmp_path / "eval"
    code = main(["paper", "evaluate", "--scenes", str(s1), str(s2), "-o", str(out), "--examples",
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
                 "judgements.csv", "run.json", "judge_accuracy.csv", "runs.csv",
                 "scenes_accepting.csv"):
        assert (out / name).stat().st_size > 0
    assert len(list((out / "pictures").glob("*.png"))) == 2
    with open(out / "scenes_accepting.csv") as fh:
        scenes = {r["method"]: r for r in csv.DictReader(fh)}
    assert scenes["iT-weighted"]["scenes"] == "2"
    assert 0 <= int(scenes["iT-weighted"]["scenes_accepting"]) <= 2
    with open(out / "judgements.csv") as fh:
        judged = list(csv.DictReader(fh))
    # scenes x methods x (top 5 + bottom 5); BS's 3 candidates may give fewer places
    it_rows = [j for j in judged if j["method"].startswith("iT")]
    assert len(it_rows) == 2 * 2 * 10
    assert len(judged) <= 2 * 4 * 10
    # the top poses each method accepted, counted from the judgements themselves
    with open(out / "table1_detailed.csv") as fh:
        detailed = {(r["affordance"], r["method"]): r for r in csv.DictReader(fh)}
    for m in METHODS:
        said = [j for j in judged if j["method"] == m and j["group"] == "top"
                and j["accepted"] == "True"]
        r = detailed[("placing", m)]
        assert int(r["accepted_top"]) == len(said)
        assert int(r["accepted_top_valid"]) == sum(j["valid"] == "True" for j in said)
    assert "## The top predictions each method accepted" in (out / "table1.md").read_text()
    # the tracked summary: Table 1 written afresh from the verdicts, the judge's figures, one
    # picture per affordance and their close-ups, and the folder replaced whole by the next
    # summary
    summary = tmp_path / "summary"
    assert main(["paper", "summary", str(out), "-o", str(summary), "--quiet"]) == 0
    assert (summary / "table1.md").read_text() == (out / "table1.md").read_text()
    assert (summary / "table1.csv").read_text() == (out / "table1.csv").read_text()
    assert (summary / "judge_accuracy.csv").exists()
    assert sorted(p.name for p in (summary / "pictures").iterdir()) == ["closeups.png",
                                                                       "placing.png"]
    chosen = (summary / "pictures" / "placing.png").read_bytes()
    scene = next(p.stem.split("__")[1] for p in (out / "pictures").glob("*.png")
                 if p.read_bytes() == chosen)
    first = next(int(j["rank"]) - 1 for j in sorted(
        (j for j in judged if j["method"] == "iT-weighted" and j["group"] == "top"
         and j["scene"] == scene), key=lambda j: (j["accepted"] != "True", int(j["rank"]))))
    sheet = np.asarray(Image.open(summary / "pictures" / "placing.png").convert("RGB"))
    strip = np.asarray(Image.open(summary / "pictures" / "closeups.png").convert("RGB"))
    w, h = PANEL                       # the close-up: the chosen sheet's panel of its first
    x, y = first * w, TITLE            # accepted pose (one row of 5)
    assert np.array_equal(strip[:h, :w], sheet[y:y + h, x:x + w])
    assert main(["paper", "summary", str(tmp_path / "nothing"), "-o", str(summary)]) == 2
    assert (summary / "table1.md").exists()


def test_evaluate_bad_input_is_one_line_error(tmp_path, capsys):

    assert main(["paper", "evaluate", "--scenes", str(tmp_path / "none"), "-o", str(tmp_path)]) == 2
    assert main(["paper", "evaluate", "--scenes", str(tmp_path), "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("itensor: error:") == 2


def test_evaluate_merge_equals_one_run(tmp_path, capsys):
    """Runs on disjoint scene subsets merge into the table one run over all scenes gives."""

    s1 = shared_file("scenes/office-desk1.ply")
    s2 = shared_file("scenes/office-desk5.ply")
    common = ["--examples", "placing-bowl", "--test-points", "150", "--methods",
              "iT-weighted,Naive", "--max-candidates", "6", "--seed", "0", "--quiet"]
    for name, scenes in (("a", [s1]), ("b", [s2]), ("ab", [s1, s2])):
        assert main(["paper", "evaluate", "--scenes", *map(str, scenes), "-o",
                     str(tmp_path / name), *common]) == 0
    out = tmp_path / "merged"
    assert main(["paper", "merge", str(tmp_path / "a"), str(tmp_path / "b"), "-o", str(out),
                 "--quiet"]) == 0
    for name in ("table1.csv", "runs.csv", "judgements.csv"):
        assert (out / name).read_text() == (tmp_path / "ab" / name).read_text(), name
    assert sorted(p.name for p in (out / "pictures").glob("*.png")) == sorted(
        p.name for p in (tmp_path / "ab" / "pictures").glob("*.png"))

    # a method run again on the same scenes replaces the earlier run's results for it
    it_only = [v if v != "iT-weighted,Naive" else "iT-weighted" for v in common]
    assert main(["paper", "evaluate", "--scenes", str(s1), str(s2), "-o", str(tmp_path / "it"),
                 *it_only, "--no-judge-check"]) == 0
    assert main(["paper", "merge", str(tmp_path / "ab"), str(tmp_path / "it"), "-o",
                 str(tmp_path / "ab_it")]) == 2                  # shared scenes: refused
    assert main(["paper", "merge", str(tmp_path / "ab"), str(tmp_path / "it"), "-o",
                 str(tmp_path / "ab_it"), "--replace", "--quiet"]) == 0
    for name in ("table1.csv", "runs.csv", "scenes_accepting.csv"):     # rows in any order
        assert (sorted((tmp_path / "ab_it" / name).read_text().splitlines()) ==
                sorted((tmp_path / "ab" / name).read_text().splitlines())), name
    with open(tmp_path / "ab_it" / "judgements.csv") as fh:
        merged = list(csv.DictReader(fh))
    with open(tmp_path / "it" / "judgements.csv") as fh:
        again = list(csv.DictReader(fh))
    assert [r for r in merged if r["method"] == "iT-weighted"] == again
    info = json.loads((tmp_path / "ab_it" / "run.json").read_text())["settings"]
    assert info["methods"] == ["iT-weighted", "Naive"]
    assert [r["value"] for r in info["per_part"]["methods"]] == [["iT-weighted", "Naive"],
                                                                 ["iT-weighted"]]
    capsys.readouterr()

    # a baseline run alone takes the candidates iT would have scored (detect.candidates,
    # no detection): the same poses, scores and verdicts as beside iT
    naive_only = [v if v != "iT-weighted,Naive" else "Naive" for v in common]
    assert main(["paper", "evaluate", "--scenes", str(s1), str(s2), "-o", str(tmp_path / "nv"),
                 *naive_only, "--no-judge-check"]) == 0
    with open(tmp_path / "nv" / "judgements.csv") as fh:
        alone = list(csv.DictReader(fh))
    with open(tmp_path / "ab" / "judgements.csv") as fh:
        beside = [r for r in csv.DictReader(fh) if r["method"] == "Naive"]
    assert alone == beside and len(alone) >= 10

    # a merge is itself a part: (a + b) + c gives what a + b + c gives, its parts listed
    s3 = shared_file("scenes/office-desk2.ply")
    assert main(["paper", "evaluate", "--scenes", str(s3), "-o", str(tmp_path / "c3"), *common]) == 0
    parts = [str(tmp_path / n) for n in ("a", "b", "c3")]
    assert main(["paper", "merge", *parts, "-o", str(tmp_path / "abc"), "--quiet"]) == 0
    assert main(["paper", "merge", str(out), parts[2], "-o", str(tmp_path / "ab_c"),
                 "--quiet"]) == 0
    for name in ("table1.csv", "runs.csv", "judgements.csv", "scenes_accepting.csv"):
        assert ((tmp_path / "ab_c" / name).read_text() ==
                (tmp_path / "abc" / name).read_text()), name
    info = json.loads((tmp_path / "ab_c" / "run.json").read_text())["settings"]
    assert info["merged_from"] == parts
    assert [Path(s).stem for s in info["scenes"]] == ["office-desk1", "office-desk5",
                                                      "office-desk2"]

    # the pictures drawn again from the recorded poses: the same pictures
    from PIL import Image


    for p in (out / "pictures").glob("*.png"):
        p.unlink()
    assert redraw(out, s1.parent, log=lambda _s: None) == 2
    for p in (tmp_path / "ab" / "pictures").glob("*.png"):
        a = np.asarray(Image.open(p), float)
        b = np.asarray(Image.open(out / "pictures" / p.name), float)
        assert a.shape == b.shape and np.abs(a - b).mean() < 1.0, p.name

    # refused: the same scene twice, other settings, a damaged record; the output untouched
    before = (out / "table1.csv").read_text()
    assert main(["paper", "merge", str(tmp_path / "a"), str(tmp_path / "ab"), "-o",
                 str(out)]) == 2
    assert main(["paper", "evaluate", "--scenes", str(s2), "-o", str(tmp_path / "c"),
                 *common[:-3], "--seed", "1", "--quiet", "--no-pictures"]) == 0
    assert main(["paper", "merge", str(tmp_path / "a"), str(tmp_path / "c"), "-o",
                 str(out)]) == 2
    path = tmp_path / "b" / "judgements.csv"
    path.write_text(path.read_text().replace(" 0 0 0 1\n", " 0 0 1\n", 1))
    assert main(["paper", "merge", str(tmp_path / "a"), str(tmp_path / "b"), "-o",
                 str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and all(e.startswith("itensor: error:") for e in err), err
    assert "office-desk1" in err[0] and "seed" in err[1] and "16" in err[2]
    assert (out / "table1.csv").read_text() == before

    # settings named as allowed to differ merge, each part's value recorded
    assert main(["paper", "merge", str(tmp_path / "a"), str(tmp_path / "c"), "-o",
                 str(tmp_path / "ac"), "--allow-differing", "seed,pictures", "--quiet"]) == 0
    info = json.loads((tmp_path / "ac" / "run.json").read_text())["settings"]
    assert [r["value"] for r in info["per_part"]["seed"]] == [0, 1]
    assert [r["scenes"] for r in info["per_part"]["seed"]] == [["office-desk1.ply"],
                                                               ["office-desk5.ply"]]
    assert info["seed"] == "differs per part (see per_part)"


def test_evaluate_rejudge_restores_the_verdicts_of_the_current_judge(tmp_path, capsys):
    """A finished run judged again: with the same judge the files are the run's; a verdict
    tampered with is judged again (and its picture drawn again), the table follows it."""

    scene = shared_file("scenes/office-desk1.ply")
    run = tmp_path / "run"
    assert main(["paper", "evaluate", "--scenes", str(scene), "-o", str(run), "--examples",
                 "placing-bowl", "--test-points", "300", "--methods", "iT-weighted",
                 "--seed", "0", "--quiet", "--no-judge-check"]) == 0
    path = run / "judgements.csv"
    rows = list(csv.DictReader(open(path)))
    i = next(k for k, r in enumerate(rows) if r["group"] == "top")
    rows[i]["valid"] = str(rows[i]["valid"] != "True")        # the verdict of another judge
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    picture = run / "pictures" / "placing-bowl__office-desk1.png"
    picture.write_bytes(b"stale")
    out = tmp_path / "again"
    assert main(["paper", "rejudge", str(run), "-o", str(out), "--scenes",
                 str(scene.parent), "--no-judge-check", "--quiet"]) == 0
    again = list(csv.DictReader(open(out / "judgements.csv")))
    assert again[i]["valid"] != rows[i]["valid"]                # restored
    assert [r["valid"] for k, r in enumerate(again) if k != i] == \
        [r["valid"] for k, r in enumerate(rows) if k != i]
    assert (out / "pictures" / picture.name).read_bytes()[:4] == b"\x89PNG"   # drawn again
    info = json.loads((out / "run.json").read_text())
    assert info["settings"]["rejudged_from"] == str(run)
    # a scene directory without the run's scene: one clear error, nothing written
    assert main(["paper", "rejudge", str(run), "-o", str(tmp_path / "x"), "--scenes",
                 str(tmp_path), "--quiet"]) != 0
    assert "office-desk1" in capsys.readouterr().err and not (tmp_path / "x").exists()


def test_atomic_dir_keeps_the_earlier_result_on_failure(tmp_path):

    out = tmp_path / "out"
    with atomic_dir(out, "run.json") as d:
        (d / "run.json").write_text("1")
    assert (out / "run.json").read_text() == "1"
    with pytest.raises(RuntimeError):
        with atomic_dir(out, "run.json") as d:
            (d / "run.json").write_text("2")
            raise RuntimeError("interrupted")
    assert (out / "run.json").read_text() == "1"          # the complete earlier result
    with atomic_dir(out, "run.json") as d:
        (d / "run.json").write_text("3")
    assert (out / "run.json").read_text() == "3"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]   # no staging left behind
    other = tmp_path / "mine"
    other.mkdir()
    (other / "notes.txt").write_text("keep me")
    with pytest.raises(InputError, match="not an earlier output"):
        with atomic_dir(other, "run.json"):
            pass
    assert (other / "notes.txt").read_text() == "keep me"


def test_a_top_pair_the_collision_tests_never_reached_is_not_counted_accepted(tmp_path,
                                                                              monkeypatch):
    """With the collision tests' budget spent (here none allowed), the top pairs pass the
    score and the placement tests but are never tested against the scene's triangles:
    the run accepts nothing, and none of its top poses is counted accepted (they were,
    while ``accepted`` was the score's and placement tests' decision alone)."""
    import dataclasses



    no_budget = Engine(collision_max_tests=0)
    monkeypatch.setattr(runner, "Engine", lambda **kw: dataclasses.replace(no_budget, **kw))
    out = tmp_path / "eval"
    assert main(["paper", "evaluate", "--scenes", str(shared_file("scenes/office-desk1.ply")), "-o",
                 str(out), "--examples", "placing-bowl", "--test-points", "800",
                 "--methods", "iT-weighted", "--no-judge-check", "--seed", "0",
                 "--quiet"]) == 0
    with open(out / "runs.csv") as fh:
        runs = list(csv.DictReader(fh))
    assert [r["any_accepted"] for r in runs] == ["False"] and int(runs[0]["accepted"]) > 0
    with open(out / "judgements.csv") as fh:
        top = [j for j in csv.DictReader(fh) if j["group"] == "top"]
    assert len(top) == 5 and not any(j["accepted"] == "True" for j in top)
