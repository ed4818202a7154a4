"""The Python API: three lines, any geometry a user holds, the CLI's defaults, plain arrays."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import trimesh

import interaction_tensor as it
from interaction_tensor.affordances import acceptance
from interaction_tensor.cli.main import main
from interaction_tensor.examples import demo
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.geometry.files import write_mesh

from support import ROOT, shared_file

SPACING = 0.02


def _kitchen() -> it.Geometry:
    """A small room: a 2 x 2 m floor and a 0.9 x 0.6 m table top at 0.75 m on four legs."""
    parts = [box_part("floor", (0, 0, -0.01), (2.0, 2.0, 0.02)),
             box_part("top", (0.2, 0.1, 0.735), (0.9, 0.6, 0.03))]
    parts += [box_part(f"leg{i}", (0.2 + sx * 0.4, 0.1 + sy * 0.25, 0.36), (0.04, 0.04, 0.72))
              for i, (sx, sy) in enumerate([(-1, -1), (1, -1), (-1, 1), (1, 1)])]
    return parts_mesh(parts)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """bowl.ply, table.ply (the demo example) and kitchen.ply in one directory."""
    d = tmp_path_factory.mktemp("api")
    ex = demo.build()
    write_mesh(d / "bowl.ply", ex.query.vertices, ex.query.faces)
    write_mesh(d / "table.ply", ex.scene_object.vertices, ex.scene_object.faces)
    k = _kitchen()
    write_mesh(d / "kitchen.ply", k.vertices, k.faces)
    return d


@pytest.fixture(scope="module")
def tensor(files):
    return it.train(files / "bowl.ply", files / "table.ply", "placing-bowl", spacing=SPACING)


def _on_the_table_then_the_floor(result):
    """The kitchen's two places, the table top first, one prediction each."""
    z = result.positions[:, 2]
    assert len(result.places) == len(result.predictions) == 2, result.places
    assert abs(z[0] - 0.75) < 0.03 and abs(z[1]) < 0.03, result.positions
    assert [p.place for p in result.predictions] == [0, 1]


def _readme_python_block() -> str:
    text = (ROOT / "README.md").read_text()
    m = re.search(r"<!-- readme-python:[^>]*-->\s*```python\n(.*?)```", text, re.S)
    assert m, "README has no marked Python block"
    return m.group(1)


def test_readme_python_snippet_runs_verbatim(files, monkeypatch):
    monkeypatch.chdir(files)
    namespace: dict = {}
    exec(compile(_readme_python_block(), "README.md", "exec"), namespace)
    result = namespace["result"]
    assert isinstance(result, it.Detection) and len(result.predictions) >= 1
    assert (files / "out" / "predictions.json").is_file()
    assert (files / "out" / "predictions.glb").is_file()
    assert (files / "out" / "render.png").is_file()                 # the picture by default
    assert namespace["page"].resolve() == (files / "out" / "index.html").resolve()
    assert namespace["page"].is_file()
    every = namespace["every"]
    assert len(every) == result.places[0].pairs and every[0].score == result.scores[0]
    # the best place is the table top, the other the floor: one bowl each
    _on_the_table_then_the_floor(result)
    assert isinstance(namespace["picture"], trimesh.Scene)


def test_result_is_plain_arrays_with_a_short_repr(files, tensor):
    result = it.detect(files / "kitchen.ply", tensor, top_k=4, sample_fraction=0.2)
    k = len(result.predictions)
    assert k >= 2
    for name, shape in (("positions", (k, 3)), ("scores", (k,)), ("orientations", (k,)),
                        ("poses", (k, 4, 4)), ("orientation_indices", (k,))):
        value = getattr(result, name)
        assert type(value) is np.ndarray and value.shape == shape, name
    assert np.all(np.diff(result.scores) <= 0)
    assert type(result.predictions[0].position) is np.ndarray
    assert type(result.predictions[0].pose) is np.ndarray
    assert len(repr(result)) < 200 and "placing-bowl" in repr(result)
    assert len(repr(result.predictions[0])) < 120
    # the pose takes the training-frame reference point to the position
    ref = np.append(tensor.reference_point, 1.0)
    assert np.allclose(np.einsum("kij,j->ki", result.poses, ref)[:, :3], result.positions)
    # converters
    scene = result.to_trimesh()
    assert isinstance(scene, trimesh.Scene) and len(scene.geometry) == 1 + k
    o3d = pytest.importorskip("open3d")
    geoms = result.to_open3d()
    assert isinstance(geoms[0], o3d.geometry.PointCloud) and len(geoms) == 1 + k
    assert isinstance(geoms[1], o3d.geometry.TriangleMesh)


def test_every_kind_of_geometry_gives_the_same_answer(files, tensor):
    """A path, a trimesh mesh, an Open3D mesh and a Geometry are the same scene; arrays and
    point clouds are accepted too."""
    kwargs = dict(top_k=3, sample_fraction=0.06, seed=3)
    ref = it.detect(str(files / "kitchen.ply"), tensor, **kwargs)
    mesh = trimesh.load(files / "kitchen.ply", process=False)
    inputs = [files / "kitchen.ply", mesh, it.load_geometry(files / "kitchen.ply")]
    o3d = pytest.importorskip("open3d")
    inputs.append(o3d.io.read_triangle_mesh(str(files / "kitchen.ply")))
    for scene in inputs:
        r = it.detect(scene, tensor, **kwargs)
        assert np.array_equal(r.positions, ref.positions), type(scene)
        assert np.array_equal(r.scores, ref.scores), type(scene)
    # a sampled point cloud, as an array, a trimesh PointCloud and an Open3D PointCloud
    prepared = it.load_scene(files / "kitchen.ply", spacing=SPACING)
    pts, nrm = prepared.points, prepared.normals
    clouds = [np.column_stack([pts, nrm]), trimesh.PointCloud(pts)]
    pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
    pc.normals = o3d.utility.Vector3dVector(nrm)
    clouds.append(pc)
    first = None
    for cloud in clouds:
        # normals: in the array and the Open3D cloud; given beside the trimesh cloud (a cloud
        # without them gets PCA normals, which this thin 3 cm table top at 2 cm spoils)
        extra = {"normals": nrm} if isinstance(cloud, trimesh.PointCloud) else {}
        r = it.detect(cloud, tensor, **kwargs, **extra)
        assert r.scene.captured is False and len(r.scene) == len(pts)
        _on_the_table_then_the_floor(r)
        first = first if first is not None else r.scores
        assert np.array_equal(r.scores, first), type(cloud)
    r = it.detect(pts, tensor, normals=nrm, **kwargs)
    assert np.array_equal(r.scores, first)


def test_train_takes_objects_too(files, tensor):
    q = trimesh.load(files / "bowl.ply", process=False)
    t2 = it.train(q, it.load_geometry(files / "table.ply"), "placing-bowl", spacing=SPACING)
    assert np.allclose(t2.reference_point, tensor.reference_point)
    assert t2.threshold() == pytest.approx(tensor.threshold())
    sitting = it.train(q, files / "table.ply", "x", spacing=SPACING, acceptance="sitting")

    assert sitting.threshold() == pytest.approx(acceptance("sitting")["threshold"])


def test_python_and_cli_give_the_same_result(files, tensor, tmp_path):

    desc = tensor.save(tmp_path / "bowl.npz")
    assert main(["detect", str(files / "kitchen.ply"), str(desc), "-o", str(tmp_path / "cli"),
                 "--top-k", "3", "--quiet"]) == 0
    doc = json.loads((tmp_path / "cli" / "predictions.json").read_text())
    r = it.detect(files / "kitchen.ply", desc, top_k=3)
    assert [p["score"] for p in doc["predictions"]] == r.scores.tolist()
    assert np.allclose([p["position"] for p in doc["predictions"]], r.positions)
    assert doc["parameters"]["criterion"] == "paper" == r.settings.criterion


def test_a_captured_frame_defaults_to_the_gaussian_criterion(tmp_path):
    """The module docstring's recipe on the shared RGB-D frame finds places (it accepted
    nothing with the paper criterion, which the CLI never used for frames)."""
    pytest.importorskip("open3d")
    frame = shared_file("rgbd/tum_desk/depth.png").parent
    ex = demo.build()
    tensor = it.train(ex.query, ex.scene_object, "placing-bowl", spacing=demo.DEMO_SPACING)
    result = it.detect(frame, tensor, sample_fraction=0.05, top_k=5)
    assert result.settings.criterion == "gaussian" and result.scene.captured
    assert int(result.pairs.accepted.sum()) > 0 and len(result.predictions) >= 1
    result.save(tmp_path)
    assert (tmp_path / "predictions_input_frame.json").is_file()
    explicit = it.detect(result.scene, tensor, sample_fraction=0.05, top_k=5, criterion="paper")
    assert explicit.settings.criterion == "paper"


def test_errors_speak_of_arguments_not_flags(tensor):
    with pytest.raises(it.InputError, match=r"^scene: expected an \(N, 3\) array") as e:
        it.detect(np.zeros((10, 2)), tensor)
    assert "--" not in str(e.value)
    with pytest.raises(it.InputError, match="scale=0.001") as e:
        it.train(np.random.default_rng(0).random((50, 3)) * 5000, np.eye(3) * 4000, "x")
    with pytest.raises(it.InputError, match="^query: cannot use a builtins.dict"):
        it.train({"a": 1}, np.eye(3), "x")
    with pytest.raises(it.InputError, match="^tensor: expected an InteractionTensor"):
        it.detect(np.eye(3), 42)
    with pytest.raises(it.SettingsError, match="unknown option topk"):
        it.detect(np.random.default_rng(0).random((50, 3)), tensor, topk=3)
    with pytest.raises(it.SettingsError, match="acceptance must be one of"):
        it.train(np.eye(4), np.eye(4), "x", acceptance="flying")
    with pytest.raises(it.InputError, match="no such file"):
        it.detect(Path("no/such/kitchen.ply"), tensor)


def test_degenerate_inputs_and_runaway_work_are_refused_up_front(tensor):
    line = np.column_stack([np.linspace(0, 1, 50), np.zeros(50), np.zeros(50)])
    with pytest.raises(it.InputError, match="scene: all points lie on one line"):
        it.detect(line, tensor)
    box = np.random.default_rng(0).random((200, 3))
    with pytest.raises(it.SettingsError, match="between 0.001 and 1 metre"):
        it.train(box, box + [0, 0, 1], "x", spacing=1e-6)
    with pytest.raises(it.SettingsError, match="between 0.001 and 1 metre"):
        it.detect(box, tensor, scene_spacing=1e-6)
    with pytest.raises(it.SettingsError, match="between 0.001 and 1 metre"):
        it.load_scene(box, spacing=float("nan"))
    with pytest.raises(it.SettingsError, match="query_points must be between"):
        it.train(box, box + [0, 0, 1], "x", query_points=10**9)


def test_units_are_checked_and_training_inputs_make_sense(files, tmp_path):

    ex = demo.build()
    # the bowl and the table in millimetres: refused as objects, accepted with the scale
    bowl_mm, table_mm = ex.query.transformed(np.diag([1000.0] * 3 + [1])), \
        ex.scene_object.transformed(np.diag([1000.0] * 3 + [1]))
    with pytest.raises(it.InputError, match="^query: extent .* implausible for an object.*"
                                            "scale=0.001"):
        it.train(bowl_mm, table_mm, "x", spacing=SPACING)
    t = it.train(bowl_mm, table_mm, "x", spacing=SPACING, scale=0.001)
    assert 0.1 < t.radius < 0.5
    # a 2 x 2 m room in millimetres is refused as a scene, read with scale=0.001 or scale=1
    write_mesh(tmp_path / "room_mm.ply", *(lambda g: (g.vertices * 1000, g.faces))(_kitchen()))
    with pytest.raises(it.InputError, match="room_mm.ply: extent 2000 m is implausible for a "
                                            "scene.*--scale 0.001"):
        it.load_scene(tmp_path / "room_mm.ply", spacing=SPACING)
    assert len(it.load_scene(tmp_path / "room_mm.ply", spacing=SPACING, scale=0.001)) > 1000
    big = parts_mesh([box_part("hall", (0, 0, 0), (150.0, 150.0, 0.1))])
    write_mesh(tmp_path / "hall.ply", big.vertices, big.faces)
    with pytest.raises(it.InputError, match="implausible for a scene"):
        it.load_scene(tmp_path / "hall.ply", spacing=1.0)
    assert len(it.load_scene(tmp_path / "hall.ply", spacing=1.0, scale=1)) > 100
    with pytest.raises(it.InputError, match="same geometry"):
        it.train(ex.scene_object, ex.scene_object, "x", spacing=SPACING)
    with pytest.raises(it.InputError, match="reference_point .* beyond the interaction"):
        it.train(ex.query, ex.scene_object, "x", spacing=SPACING, reference_point=(9, 9, 9))


def test_a_saved_result_carries_its_descriptor_for_the_viewer(files, tensor, tmp_path):
    """A descriptor made in Python has no file: the result carries a copy, and the viewer
    shows the training example from it. One named by its file is not copied."""
    from interaction_tensor.outputs.html import build_data

    result = it.detect(files / "kitchen.ply", tensor, sample_fraction=0.05, top_k=2, seed=0)
    out = result.save(tmp_path / "api")
    doc = json.loads((out / "predictions.json").read_text())
    assert doc["descriptor"] == "placing-bowl" and doc["descriptor_file"] == "descriptor.npz"
    copy = it.InteractionTensor.load(out / "descriptor.npz")
    np.testing.assert_array_equal(copy.bisector_points, tensor.bisector_points)
    data = build_data(out)
    assert data["example"] is not None and data["descriptor_note"] is None
    named = tensor.save(tmp_path / "bowl.npz")
    out = result.save(tmp_path / "cli", descriptor_name=str(named))
    assert not (out / "descriptor.npz").exists()
    assert "descriptor_file" not in json.loads((out / "predictions.json").read_text())
    assert build_data(out)["example"] is not None


def test_an_empty_result_says_why_and_what_to_do(tmp_path):
    """A cloud much sparser than the descriptor's spacing where nothing is found: the result
    says it may be the spacing instead of being silently empty; so does a scene with no
    surface facing the descriptor's way (a wall for a bowl). A result found on a cloud more
    than 3 times sparser, or 1.5 times without its normals, says its places may be missed."""
    from interaction_tensor.geometry.sampling import mesh_area, sample_mesh

    ex = demo.build()
    bowl = it.train(ex.query, ex.scene_object, affordance="placing-bowl")     # at 1 cm
    roof = it.Geometry(np.array([[0, 0, 0], [2, 0, 0], [2, 1, 1], [0, 1, 1.0],
                                 [2, 2, 0], [0, 2, 0]]),
                       np.array([[0, 1, 2], [0, 2, 3], [3, 2, 4], [3, 4, 5]]))  # pitched 45 deg
    sparse, normals = sample_mesh(roof, int(mesh_area(roof) / 0.1 ** 2), 0)
    result = it.detect(sparse, bowl, sample_fraction=0.5, seed=0)
    assert not result.predictions and len(result.warnings) == 1
    assert "cm apart" in result.warnings[0] and "denser" in result.warnings[0]
    out = result.save(tmp_path / "sparse")
    assert json.loads((out / "predictions.json").read_text())["stats"]["warnings"] == \
        result.warnings
    # a result found on a cloud too sparse to trust whole says so, and what to give (the
    # example's table alone: the warnings are of the spacing, whatever the scene's size)
    table = ex.scene_object
    cloud, normals = sample_mesh(table, int(mesh_area(table) / 0.04 ** 2), 0)
    found = it.detect(np.column_stack([cloud, normals]), bowl, sample_fraction=0.3, seed=0)
    assert found.predictions and len(found.warnings) == 1, found.warnings
    assert "times the descriptor's 1.0 cm: places may be missed or split" in found.warnings[0]
    cloud = sample_mesh(ex.scene, int(mesh_area(ex.scene) / 0.025 ** 2), 0)[0]
    bare = it.detect(cloud, bowl, sample_fraction=0.3, seed=0)
    assert bare.scene.normals_estimated and not found.scene.normals_estimated
    assert bare.predictions and "normals were estimated" in bare.warnings[0]
    near, normals = sample_mesh(table, int(mesh_area(table) / 0.012 ** 2), 0)
    near = it.detect(near, bowl, sample_fraction=0.3, seed=0)
    assert near.predictions and near.warnings == []
    wall = it.Geometry(np.array([[0, 0, 0], [2, 0, 0], [2, 0, 2], [0, 0, 2.0]]),
                       np.array([[0, 1, 2], [0, 2, 3]]))              # nothing faces up
    result = it.detect(wall, bowl, sample_fraction=0.2, seed=0)
    assert not result.predictions and "faces the descriptor's direction" in result.warnings[0]
