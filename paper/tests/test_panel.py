"""The blind panel: poses drawn from an evaluation's verdicts without anything that tells
where they came from, the raters' answers kept as labelled data, and the judge's agreement
with the panel's majority."""

from __future__ import annotations

import numpy as np
import pytest

from interaction_tensor.cli.main import main
from interaction_tensor.errors import InputError
from itensor_paper import panel

from paper_support import shared_file


def _rows():
    rows = []
    for aff, example in (("placing", "placing-bowl"), ("hanging", "hanging-hanger")):
        for scene in ("kitchen3", "kitchen1", "office-desk1"):
            for method, group in (("iT-weighted", "top"), ("iT-weighted", "bottom"),
                                  ("Naive", "top")):
                for rank in range(1, 6):
                    pose = np.eye(4)
                    pose[:3, 3] = (rank, len(rows), 0.75)
                    rows.append({"affordance": aff, "example": example, "scene": scene,
                                 "method": method, "group": group, "rank": str(rank),
                                 "pose": " ".join(map(str, pose.ravel()))})
    return rows


def test_poses_are_drawn_from_every_source_and_scene_and_held_out_by_scene():
    poses = panel.select(_rows(), per_affordance=10, seed=3)
    assert len(poses) == 20 and len({p.id for p in poses}) == 20
    for aff in ("placing", "hanging"):
        mine = [p for p in poses if p.affordance == aff]
        assert {(p.method, p.group) for p in mine} == {("iT-weighted", "top"),
                                                         ("iT-weighted", "bottom"),
                                                         ("Naive", "top")}
        assert len({p.scene for p in mine}) == 3
    assert all(p.held_out == (p.scene not in panel.DEVELOPMENT_SCENES) for p in poses)
    again = panel.shuffled_ids(panel.select(_rows(), per_affordance=10, seed=3), 5)
    assert sorted(p.id for p in again) == [f"Q{k:04d}" for k in range(1, 21)]


def test_answers_make_the_labelled_data_and_the_agreement(tmp_path):
    poses = panel.shuffled_ids(panel.select(_rows(), per_affordance=10, seed=3), 5)
    panel.save(poses, tmp_path / "key.csv")
    ids = [p.id for p in poses]
    for rater, says in (("a", "yes"), ("b", "yes"), ("c", "no")):
        (tmp_path / f"{rater}.csv").write_text("id,answer\n" + "".join(
            f"{i},{says if k % 2 else 'no'}\n" for k, i in enumerate(ids)))
    merged = panel.merge_answers(panel.load(tmp_path / "key.csv"), *(tmp_path / f"{r}.csv"
                                                                     for r in "abc"))
    panel.save(merged, tmp_path / "panel.csv")
    back = panel.load(tmp_path / "panel.csv")
    assert [p.answers for p in back] == [p.answers for p in merged]
    assert [p.majority for p in back] == [bool(k % 2) for k in range(len(ids))]
    np.testing.assert_allclose(back[0].pose, poses[0].pose)
    judged = {p.id: True for p in back}
    rows = {r["affordance"]: r for r in panel.agreement(back, judged, held_out_only=False)}
    assert rows["all"]["poses"] == 20 and rows["all"]["agree"] == 10
    (tmp_path / "bad.csv").write_text("Q0001,maybe\n")
    with pytest.raises(InputError, match="not yes or no"):
        panel.answers_from(tmp_path / "bad.csv")


def test_a_new_round_joins_the_labelled_data(tmp_path):
    """``panel-verdicts`` adds a round's poses and answers to the labelled data: a pose it
    already holds gets the new answers beside its own, a new one is added under its id, an
    id given to another pose is refused in one line."""
    rated = panel.shuffled_ids(panel.select(_rows(), per_affordance=10, seed=3), 5)
    for p in rated:
        p.answers = ["yes", "no", "yes"]
    panel.save(rated, tmp_path / "panel.csv")
    again = panel.PanelPose("C0001", rated[0].affordance, rated[0].example, rated[0].scene,
                            "iT-weighted", "top", 1, rated[0].pose + 1e-6)
    fresh = panel.PanelPose("C0002", "hanging", "hanging-hanger", "kitchen1", "iT-weighted",
                            "top", 2, np.eye(4))
    panel.save([again, fresh], tmp_path / "key.csv")
    (tmp_path / "r1.csv").write_text("id,answer\nC0001,no\nC0002,yes\n")
    (tmp_path / "r2.csv").write_text("id,answer\nC0001,no\nC0002,yes\n")
    assert main(["paper", "panel-verdicts", str(tmp_path / "key.csv"), str(tmp_path / "r1.csv"),
                 str(tmp_path / "r2.csv"), "-o", str(tmp_path / "panel.csv"), "-q"]) == 0
    back = {p.id: p for p in panel.load(tmp_path / "panel.csv")}
    assert len(back) == len(rated) + 1
    assert back[rated[0].id].answers == ["yes", "no", "yes", "no", "no"]
    assert back[rated[0].id].majority is False
    assert back["C0002"].answers == ["yes", "yes"] and back["C0002"].scene == "kitchen1"
    clash = panel.PanelPose(rated[1].id, "hanging", "hanging-hanger", "kitchen1",
                            "iT-weighted", "top", 3, 2 * np.eye(4))
    with pytest.raises(InputError, match=f"pose id {rated[1].id} is already"):
        panel.add_round(panel.load(tmp_path / "panel.csv"), [clash])


def test_sheets_show_ids_and_no_verdict(tmp_path):
    objects = shared_file("objects/paper_bowl.ply").parent
    scenes = shared_file("scenes/office-desk1.ply").parent
    pose = np.eye(4)
    pose[:3, 3] = (0.5, 0.3, 0.75)
    poses = [panel.PanelPose("Q0001", "placing", "placing-bowl", "office-desk1", "Naive",
                             "top", 1, pose)]
    panel.draw(poses, scenes, objects, tmp_path / "sheets")
    from PIL import Image

    img = np.asarray(Image.open(tmp_path / "sheets" / "placing" / "sheet_01.png").convert("RGB"))
    hue = img.astype(int) - panel.NEUTRAL
    drawn = (img[..., 0] > img[..., 2] + 40) & (np.abs(hue).sum(axis=2) < 200)
    assert drawn.sum() > 200                      # the object, in the one colour, every view
    views, cuts = drawn[:panel.VIEW[1]], drawn[panel.VIEW[1] + 4:]
    for k in range(3):
        assert views[:, 90 + k * panel.VIEW[0]:90 + (k + 1) * panel.VIEW[0]].sum() > 20
    for k in range(2):                            # its outline in both cuts
        assert cuts[:, 90 + k * panel.CUT[0]:90 + (k + 1) * panel.CUT[0]].sum() > 20
    question = (tmp_path / "sheets" / "placing" / "question.txt").read_text()
    assert question.startswith("Could this object be put down here")
    assert not any(w in question for w in ("Naive", "iT", "score", "valid"))
    assert (tmp_path / "sheets" / "key.csv").read_text().count("\n") == 2


def test_agreement_rows_split_development_and_held_out_and_count_raters():
    pose = np.eye(4)
    poses = [panel.PanelPose("Q0001", "placing", "placing-bowl", "kitchen3", "Naive", "top", 1,
                             pose, False, ["yes", "yes", "no"]),
             panel.PanelPose("Q0002", "placing", "placing-bowl", "kitchen1", "Naive", "top", 2,
                             pose, True, ["no", "no", "no"]),
             panel.PanelPose("Q0003", "placing", "placing-bowl", "kitchen1", "Naive", "top", 3,
                             pose, True, ["yes", "yes", "yes"])]
    assert panel.rater_agreement(poses) == round(100 * 7 / 9, 1)
    rows = panel.agreement_rows(poses, {"Q0001": True, "Q0002": True, "Q0003": True})
    dev = next(r for r in rows if r["affordance"] == "placing" and r["split"] == "development")
    held = next(r for r in rows if r["affordance"] == "placing" and r["split"] == "held-out")
    assert (dev["poses"], dev["agree"], dev["agreement"]) == (1, 1, 100.0)
    assert (held["poses"], held["agree"], held["agreement"]) == (2, 1, 50.0)
    assert (held["panel_valid"], held["judge_valid"], held["raters_agree"]) == (1, 2, 100.0)
    table = panel.agreement_markdown(rows)
    assert "| placing | 1/2 (50.0 %) | 1/1 (100.0 %) | 1 / 2 | 100.0 % |" in table


def test_panel_agreement_writes_the_judges_agreement(tmp_path, capsys):
    from interaction_tensor.cli.main import main

    objects = shared_file("objects/paper_bowl.ply").parent
    scenes = shared_file("scenes/office-desk1.ply").parent
    floating = np.eye(4)
    floating[:3, 3] = (0.5, 0.3, 3.0)                    # a bowl in the air: invalid
    poses = [panel.PanelPose("Q0001", "placing", "placing-bowl", "office-desk1", "Naive", "top",
                             1, floating, True, ["no", "no", "yes"]),
             panel.PanelPose("Q0002", "placing", "placing-bowl", "office-desk1", "Naive", "top",
                             2, floating, True, ["yes", "yes", "no"])]
    panel.save(poses, tmp_path / "panel.csv")
    assert main(["paper", "panel-agreement", "--scenes", str(scenes), "--objects", str(objects),
                 "--panel", str(tmp_path / "panel.csv"), "-o", str(tmp_path / "out")]) == 0
    assert "| placing | 1/2 (50.0 %) |" in capsys.readouterr().out
    import csv

    with open(tmp_path / "out" / "panel_agreement.csv", newline="") as fh:
        rows = {(r["affordance"], r["split"]): r for r in csv.DictReader(fh)}
    held = rows[("placing", "held-out")]
    assert (held["poses"], held["agree"], held["judge_valid"]) == ("2", "1", "0")


def test_panel_sheets_draws_a_panels_own_poses_again_without_their_answers(tmp_path):
    from interaction_tensor.cli.main import main

    objects = shared_file("objects/paper_bowl.ply").parent
    scenes = shared_file("scenes/office-desk1.ply").parent
    pose = np.eye(4)
    pose[:3, 3] = (0.5, 0.3, 0.75)
    poses = [panel.PanelPose("Q0001", "placing", "placing-bowl", "office-desk1", "Naive", "top",
                             1, pose, True, ["yes", "no", "yes"]),
             panel.PanelPose("Q0002", "hanging", "hanging-hanger", "office-desk1", "Naive",
                             "top", 1, pose, True, ["no", "no", "no"])]
    panel.save(poses, tmp_path / "panel.csv")
    assert main(["paper", "panel-sheets", str(tmp_path / "panel.csv"), "--affordance", "placing",
                 "-o", str(tmp_path / "sheets"), "--scenes", str(scenes), "--objects",
                 str(objects), "--quiet"]) == 0
    assert (tmp_path / "sheets" / "placing" / "sheet_01.png").is_file()
    assert not (tmp_path / "sheets" / "hanging").exists()
    key = panel.load(tmp_path / "sheets" / "key.csv")
    assert [(p.id, p.answers) for p in key] == [("Q0001", [])]


def test_a_new_round_draws_only_poses_the_panel_has_not_shown_all_held_out():
    rows = _rows()
    first = panel.shuffled_ids(panel.select(rows, per_affordance=10, seed=3), 5)
    again = panel.new_round(rows, first, per_affordance=10, seed=7)
    assert len(again) == 20 and sorted(p.id for p in again) == [f"R{k:04d}"
                                                                  for k in range(1, 21)]
    shown = {(p.scene, p.affordance, tuple(np.asarray(p.pose).ravel())) for p in first}
    assert not any((p.scene, p.affordance, tuple(np.asarray(p.pose).ravel())) in shown
                   for p in again)
    assert all(p.held_out for p in again)            # development scenes' poses too
    assert {p.affordance for p in panel.new_round(rows, first, 10, 7, ["hanging"], "S")} \
        == {"hanging"}
    # every pose shown: nothing left to draw
    assert len(panel.unseen(rows, panel.new_round(rows, [], 100, 1))) == 0
    assert len(panel.unseen(rows, first)) == len(rows) - 20
