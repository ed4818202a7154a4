"""The paper's eight interaction examples: posed, in contact, without penetration."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from interaction_tensor.errors import InputError
from interaction_tensor.examples import interactions, shapes
from interaction_tensor.evaluation.judge import Judge, JudgeScene

from conftest import SHARED_DATA


def test_eight_examples_with_the_papers_normals():
    assert interactions.names() == ["filling-mug", "filling-cup", "placing-bottle",
                                    "placing-bowl", "hanging-hanger", "hanging-handbag",
                                    "sitting-human", "riding-human"]
    for name, sp in interactions.EXAMPLES.items():
        assert sp.normal == ((0.0, 0.0, -1.0) if sp.affordance == "filling" else (0.0, 0.0, 1.0))


@pytest.mark.parametrize("name", interactions.names())
def test_procedural_example_is_posed_in_contact_and_valid(name):
    ex = interactions.build(name)
    assert ex.query.is_mesh and not ex.real_query
    q = interactions.surface_points(ex.query, 8000)
    s = interactions.surface_points(ex.scene_object, 100000, 1)
    gap = cKDTree(s).query(q)[0].min()
    assert gap < 0.005, f"{name}: the objects do not touch ({gap:.4f} m)"
    # realistic sizes (metres)
    size = np.ptp(ex.query.vertices, axis=0).max()
    assert 0.05 < size < 2.0
    # the example passes its own judge: no penetration, contact, support
    judge = Judge.for_example(ex)
    verdict = judge.judge(JudgeScene(ex.scene_object), np.eye(4))
    assert verdict.valid, verdict.reasons


def test_sizes_are_realistic():
    assert np.ptp(shapes.mug().vertices[:, 2]) == pytest.approx(0.095, abs=0.002)
    assert shapes.stool().vertices[:, 2].max() == pytest.approx(0.45)
    ex = interactions.build("sitting-human")
    assert ex.query.vertices[:, 2].min() == pytest.approx(0.0, abs=0.01)   # feet on the floor
    bike = interactions.build("riding-human").scene_object
    assert bike.vertices[:, 2].min() == pytest.approx(0.0, abs=0.005)      # wheels on the ground


def test_filling_descriptor_reference_point_is_the_tap():
    tensor = interactions.build_descriptor("filling-cup", spacing=0.02)
    assert tensor.affordance_normal[2] == pytest.approx(-1.0)
    assert tensor.reference_point[2] == pytest.approx(shapes.TAP_OUTLET[2], abs=0.02)


def test_real_query_objects_are_posed_by_the_same_rule():
    objects = SHARED_DATA / "objects"
    if not (objects / "ycb_mug.ply").exists():
        pytest.skip("shared data not found")
    for name in ("filling-mug", "placing-bowl", "sitting-human"):
        ex = interactions.build(name, objects)
        assert ex.real_query
        verdict = Judge.for_example(ex).judge(JudgeScene(ex.scene_object), np.eye(4))
        assert verdict.valid, (name, verdict.reasons)
    ex = interactions.build("hanging-hanger", objects)        # no real hanger: procedural
    assert not ex.real_query


def test_missing_objects_file_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="no such object file"):
        interactions.build("placing-bowl", tmp_path)
    with pytest.raises(InputError, match="unknown example"):
        interactions.spec("juggling-balls")


def test_drop_onto_measures_the_vertical_gap():
    q = np.array([[0.0, 0.0, 1.0], [0.1, 0.0, 1.2]])
    s = np.array([[0.0, 0.0, 0.7], [0.1, 0.0, 0.5], [0.0, 0.0, 1.5]])
    assert interactions.drop_onto(q, s) == pytest.approx(0.3)
    assert interactions.drop_onto(q + [5, 5, 0], s) == np.inf


def test_cli_examples_list_and_build(tmp_path, capsys):
    from interaction_tensor.cli_eval import main

    assert main(["examples", "list"]) == 0
    assert "riding-human" in capsys.readouterr().out
    out = tmp_path / "ex"
    assert main(["examples", "build", "-o", str(out), "--examples", "placing-bowl",
                 "--spacing", "0.02", "-q"]) == 0
    import interaction_tensor as it

    t = it.InteractionTensor.load(out / "placing-bowl.npz")
    assert t.affordance == "placing-bowl"
    assert (out / "placing-bowl_query.ply").exists() and (out / "examples.json").exists()
    assert main(["examples", "build", "-o", str(out), "--objects", str(tmp_path / "nope")]) == 2
