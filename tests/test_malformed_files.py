"""The last bad inputs: every malformed descriptor and intrinsics file, empty output path and
oversized job ends in one line (or the exact result) before any work, never a traceback;
the posed objects written are the query itself, moved.

Property-based tests tamper with a real descriptor's JSON header (a field dropped, a table
or list emptied, a value of the wrong type, NaN, a huge number, at the top level and inside
the nested tables) and with intrinsics files (extreme values of every field), and run the
command line on each."""

from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from PIL import Image
from plyfile import PlyData

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.capture import load_intrinsics
from interaction_tensor.cli.main import main
from interaction_tensor.descriptor.tensor import TABLE_KEYS
from interaction_tensor.errors import InputError, SettingsError
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.geometry import sampling
from interaction_tensor.geometry import scene as scene_mod
from interaction_tensor.geometry.files import write_mesh, write_ply_points

from support import corner_example, descriptor_with_header, shared_file

_FIXTURES = [HealthCheck.function_scoped_fixture]


@pytest.fixture(scope="module")
def corner(tmp_path_factory, corner_tensor):
    """The corner box's descriptor and its scene (a floor and two walls) as files."""
    d = tmp_path_factory.mktemp("corner")
    _, scene_object = corner_example()
    write_mesh(d / "scene.ply", scene_object.vertices, scene_object.faces)
    corner_tensor.save(d / "corner.npz")
    return d


def _header(path) -> dict:
    with np.load(path) as data:
        return json.loads(data["header"].tobytes())


def _one_line(text: str) -> str:
    assert "Traceback" not in text, text
    lines = text.strip().splitlines()
    assert len(lines) == 1, text
    return lines[0]


def _cli_error(argv, capsys) -> str:
    """Run ``itensor argv``; it must exit 2 with one line on stderr. Returns that line."""
    code = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert code == 2, err
    line = _one_line(err)
    assert line.startswith("itensor: error: "), line
    return line


# --------------------------------------------------------------------------- descriptors
def test_an_empty_thresholds_table_is_refused_naming_the_field(corner, tmp_path, capsys):
    bad = descriptor_with_header(corner / "corner.npz", tmp_path / "empty.npz", thresholds={})
    line = _cli_error(["detect", corner / "scene.ply", bad, "-o", tmp_path / "out"], capsys)
    assert line == (f"itensor: error: {bad}: descriptor field 'thresholds.paper-weighted' "
                    "is missing")
    assert not (tmp_path / "out").exists()
    for table in ("thresholds", "self_scores"):
        for key in TABLE_KEYS:
            header = _header(corner / "corner.npz")
            del header[table][key]
            path = descriptor_with_header(corner / "corner.npz", tmp_path / "d.npz",
                                          **{table: header[table]})
            with pytest.raises(InputError, match=f"'{table}.{key}' is missing"):
                it.InteractionTensor.load(path)
    path = descriptor_with_header(corner / "corner.npz", tmp_path / "x.npz",
                                  thresholds={**header["thresholds"], "paper-uniform": 0.5,
                                              "paper-strict": 0.5})
    with pytest.raises(InputError, match="'thresholds.paper-strict' is not one of"):
        it.InteractionTensor.load(path)


def test_a_descriptor_built_without_a_threshold_is_a_settings_error(corner_tensor):
    import copy

    tensor = copy.deepcopy(corner_tensor)
    del tensor.thresholds["gaussian-uniform"]
    scene = it.prepare_scene(corner_example()[1], 0.02)
    with pytest.raises(SettingsError, match="has no gaussian-uniform threshold; give one"):
        it.detect(scene, tensor, criterion="gaussian", keypoints="uniform")
    tensor.thresholds["paper-weighted"] = float("nan")
    with pytest.raises(SettingsError, match="nan as its paper-weighted threshold"):
        tensor.threshold()
    # a threshold given for the run needs none from the descriptor
    assert it.detect(scene, tensor, criterion="gaussian", keypoints="uniform",
                     threshold=0.5, sample_fraction=0.05).threshold == 0.5


_JSON_VALUES = [None, True, False, 0, -1, 0.5, 2, 1e308, -1e308, 10 ** 400, float("nan"),
                float("inf"), float("-inf"), "", "x", "surface", [], [0.1], [[0.1, None]],
                [1, 2, 3], {}, {"a": 1}, [[[[[]]]]]]


def _paths(header: dict) -> list:
    """Every field of the header, and every entry of its nested tables and lists, as a
    key path."""
    out = []

    def walk(value, path):
        out.append(path)
        if isinstance(value, dict):
            for k, v in value.items():
                walk(v, path + (k,))
        elif isinstance(value, list):
            for i, v in enumerate(value[:3]):
                walk(v, path + (i,))

    for key, value in header.items():
        walk(value, (key,))
    return out


def _mutated(header: dict, path: tuple, how: str, value):
    """``header`` with the entry at ``path`` dropped, emptied or replaced by ``value``."""
    header = json.loads(json.dumps(header))
    parent = header
    for key in path[:-1]:
        parent = parent[key]
    key = path[-1]
    if how == "drop":
        if isinstance(parent, dict):
            del parent[key]
        else:
            parent.pop(key)
    elif how == "empty":
        old = parent[key]
        parent[key] = {} if isinstance(old, dict) else [] if isinstance(old, list) else ""
    else:
        parent[key] = value
    return header


@pytest.fixture(scope="module")
def riding(tmp_path_factory):
    """A descriptor with every nested table filled (the riding example's straddle boxes,
    collision tests, mount height) and its header."""
    d = tmp_path_factory.mktemp("riding")
    path = affordances.build_descriptor("riding-human").save(d / "riding.npz")
    header = _header(path)
    assert header["straddle"]["legroom"] and header["collision_tests"]
    return path, header


@settings(max_examples=60, deadline=None, suppress_health_check=_FIXTURES)
@given(data=st.data(), how=st.sampled_from(["drop", "empty", "value", "value"]),
       value=st.sampled_from(_JSON_VALUES))
def test_tampered_descriptor_headers_load_or_give_one_line(riding, corner, tmp_path, capsys,
                                                           data, how, value):
    """Whatever is dropped, emptied or replaced, at whatever depth of the header: the file
    loads (the change left a valid descriptor) or is refused in one line naming the file,
    and ``itensor detect`` then runs or exits 2 with that one line."""
    src, header = riding
    path = data.draw(st.sampled_from(_paths(header)))
    changed = _mutated(header, path, how, value)
    with np.load(src) as npz:
        raw = {k: npz[k] for k in npz.files}
    raw["header"] = np.frombuffer(json.dumps(changed).encode(), np.uint8)
    target = tmp_path / "tampered.npz"
    np.savez(target, **raw)
    try:
        it.InteractionTensor.load(target)
        loaded = True
    except (InputError, SettingsError) as exc:
        loaded = False
        text = _one_line(str(exc))
        assert text.startswith(f"{target}: "), text
    out = tmp_path / "out"
    code = main(["detect", str(corner / "scene.ply"), str(target), "-o", str(out), "-q",
                 "--sample-fraction", "0.02", "--top-k", "1", "--spacing", "0.03",
                 "--no-render"])
    err = capsys.readouterr().err
    event(f"loaded, detect exit {code}" if loaded else "refused")
    if loaded:
        assert code in (0, 2), err
    else:
        assert code == 2
    if code == 2:
        assert _one_line(err).startswith("itensor: error: ")


@settings(max_examples=40, deadline=None)
@given(key=st.sampled_from(["radius", "scene_spacing", "clearance_limit", "contact_angle",
                            "ground", "mount_height", "thresholds", "meta"]),
       value=st.one_of(st.sampled_from(_JSON_VALUES),
                       st.integers(-10 ** 300, 10 ** 300), st.floats(),
                       st.dictionaries(st.text(max_size=3), st.floats(), max_size=3),
                       st.recursive(st.none() | st.floats() | st.text(max_size=3),
                                    lambda inner: st.lists(inner, max_size=3), max_leaves=6)))
def test_any_json_value_in_any_field_is_checked(corner_tensor, tmp_path_factory, key, value):
    """Numbers of every size, NaN, text, nested lists and tables in the fields the search
    above leaves at a few values: loaded only when valid, else one line."""
    path = tmp_path_factory.mktemp("any") / "d.npz"
    corner_tensor.save(path)
    descriptor_with_header(path, path, **{key: value})
    try:
        tensor = it.InteractionTensor.load(path)
    except InputError as exc:
        text = _one_line(str(exc))
        assert text.startswith(f"{path}: descriptor field '{key}"), text
        return
    assert tensor.threshold() > 0 and math.isfinite(tensor.radius)


# --------------------------------------------------------------------------- intrinsics
def _frame(directory, intrinsics: dict, depth_mm: int = 1500):
    """A small RGB-D frame directory: a tilted plane of depth, the intrinsics given; its image
    has the intrinsics' size where that is a small whole size, else 64 x 48."""
    w, h = intrinsics.get("width"), intrinsics.get("height")
    ok = all(isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= 256 for v in (w, h))
    w, h = (w, h) if ok else (64, 48)
    ramp = np.linspace(0, 300, w, dtype=np.int64)[None, :]          # a tilted plane
    Image.fromarray((depth_mm + ramp + np.zeros((h, 1), np.int64)).astype(np.uint16)).save(
        directory / "depth.png")
    (directory / "intrinsics.json").write_text(json.dumps(intrinsics))
    return directory


def test_a_tiny_focal_length_is_refused_before_open3d(corner, tmp_path, capsys):
    data = json.loads(shared_file("rgbd/tum_desk/intrinsics.json").read_text())
    data.update(fx=1e-6, fy=1e-6)
    frame = tmp_path / "frame"
    frame.mkdir()
    for name in ("depth.png", "color.png"):
        (frame / name).write_bytes(shared_file(f"rgbd/tum_desk/{name}").read_bytes())
    (frame / "intrinsics.json").write_text(json.dumps(data))
    line = _cli_error(["detect", frame, corner / "corner.npz", "-o", tmp_path / "out",
                       "--no-align"], capsys)
    assert line == (f"itensor: error: {frame / 'intrinsics.json'}: fx=1e-06 pixels is no "
                    "camera's focal length for a 640x480 image (expected 24 to 12800 pixels)")


@pytest.mark.parametrize("changes, says", [
    ({"width": 20000}, "width must be at most 16384 pixels"),
    ({"height": 0}, "height must be positive"),
    ({"fx": 2.0}, ("fx=2 pixels is no camera's focal length for a 64x48 image "
                   "(expected 2.4 to 1280 pixels)")),
    ({"fy": 1e5}, "fy=100000 pixels is no camera's focal length"),
    ({"fx": 10 ** 400}, "fx must be finite"),
    ({"cx": 64.5}, "cx=64.5 lies outside the image width 64"),
    ({"cy": -0.5}, "cy=-0.5 lies outside the image height 48"),
    ({"depth_scale": 1e7}, "depth_scale must be at most 1e+06 depth units per metre"),
    ({"depth_scale": float("inf")}, "depth_scale must be finite"),
    ({"depth_trunc": 101}, "depth_trunc must be at most 100 m"),
    ({"depth_trunc": 0}, "depth_trunc must be positive"),
])
def test_implausible_intrinsics_are_refused_naming_the_field(tmp_path, changes, says):
    base = {"width": 64, "height": 48, "fx": 50.0, "fy": 50.0, "cx": 31.5, "cy": 23.5,
            "depth_scale": 1000.0, "depth_trunc": 4.0}
    path = tmp_path / "intrinsics.json"
    path.write_text(json.dumps({**base, **changes}))
    with pytest.raises(InputError) as exc:
        load_intrinsics(path)
    assert str(exc.value).startswith(f"{path}: {says}"), str(exc.value)
    assert "\n" not in str(exc.value)


def test_depth_overrides_are_checked_as_settings(tmp_path, capsys):
    path = shared_file("rgbd/tum_desk/intrinsics.json")
    for over, says in (({"depth_scale": 0}, "depth_scale must be positive"),
                       ({"depth_scale": 2e6}, "depth_scale must be at most 1e+06"),
                       ({"depth_trunc": float("nan")}, "depth_trunc must be finite"),
                       ({"depth_trunc": 500}, "depth_trunc must be at most 100 m"),
                       ({"depth_trunc": "far"}, "depth_trunc must be a number")):
        with pytest.raises(SettingsError) as exc:
            load_intrinsics(path, over)
        assert str(exc.value).startswith(says) and f"(given to override {path})" in str(exc.value)
    for option, value, says in (("--depth-scale", "2e6", "(0, 1e+06]"),
                                ("--depth-trunc", "500", "(0, 100]")):
        with pytest.raises(SystemExit) as info:
            main(["detect", "s.ply", "d.npz", "-o", str(tmp_path / "o"), option, value])
        assert info.value.code == 2
        assert f"argument {option}" in capsys.readouterr().err.strip().splitlines()[-1]
    with pytest.raises(InputError, match="fx=0.001 pixels is no camera's focal length"):
        it.capture.rgbd.Intrinsics(640, 480, 1e-3, 525.0, 319.5, 239.5)


#: each field of a 64 x 48 frame's intrinsics at the edges of what it may hold, and just
#: beyond them
_EDGES = {"width": [64, 65, 256, 16384, 0, 16385], "height": [48, 47, 256, 16384, 0, 16385],
          "fx": [2.4, 3, 1280, 2.39, 1281], "fy": [2.4, 1, 1280, 1e-6, 1e5],
          "cx": [0, 64, 0.01, -0.01, 64.01], "cy": [0, 48, 1, -1, 48.5],
          "depth_scale": [1e-3, 1e6, 5000, 1.01e6, 0],
          "depth_trunc": [1e-3, 100, 0.5, 100.5, -1]}
_EXTREMES = st.one_of(
    st.sampled_from([-1, 1e-12, 0.5, 1e300, -1e300, 10 ** 400, float("nan"), float("inf"),
                     float("-inf"), None, True, "", "64", "x", [], [1], {}]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-10 ** 30, 10 ** 30))


@settings(max_examples=50, deadline=None, suppress_health_check=_FIXTURES)
@given(data=st.data(), keys=st.sets(st.sampled_from(sorted(_EDGES)), min_size=1, max_size=3),
       drop=st.one_of(st.just(()), st.just(()), st.just(()),
                      st.sets(st.sampled_from(["width", "fy", "cx", "depth_scale"]),
                              min_size=1, max_size=1)))
def test_extreme_intrinsics_load_sane_or_give_one_line(corner, tmp_path_factory, capsys,
                                                       data, keys, drop):
    """Any extreme value of any field: the intrinsics load and are what a camera has, or
    they are refused in one line naming the file; ``itensor detect`` on the frame runs or
    exits 2 with one line, never Open3D's or NumPy's traceback."""
    values = {"width": 64, "height": 48, "fx": 50.0, "fy": 50.0, "cx": 31.5, "cy": 23.5,
              "depth_scale": 1000.0, "depth_trunc": 4.0}
    for key in sorted(keys):
        edge = st.sampled_from(_EDGES[key])
        values[key] = data.draw(st.one_of(edge, edge, edge, _EXTREMES), label=key)
    for key in drop:
        values.pop(key, None)
    frame = _frame(tmp_path_factory.mktemp("frame"), values)
    try:
        intr = load_intrinsics(frame / "intrinsics.json")
    except InputError as exc:
        text = _one_line(str(exc))
        assert text.startswith(f"{frame / 'intrinsics.json'}: "), text
        event("refused")
        _cli_error(["detect", frame, corner / "corner.npz", "-o", frame / "out"], capsys)
        return
    w, h = intr.width, intr.height
    assert 1 <= w <= 16384 and 1 <= h <= 16384
    assert 0.05 * min(w, h) <= min(intr.fx, intr.fy) <= max(intr.fx, intr.fy) <= 20 * max(w, h)
    assert 0 <= intr.cx <= w and 0 <= intr.cy <= h
    assert 0 < intr.depth_scale <= 1e6 and 0 < intr.depth_trunc <= 100
    if w * h > 256 * 256:
        event("loaded, too large to draw")
        return                              # its depth image would be too large to draw here
    code = main(["detect", str(frame), str(corner / "corner.npz"), "-o", str(frame / "out"),
                 "-q", "--no-align", "--sample-fraction", "0.05", "--top-k", "1"])
    err = capsys.readouterr().err
    event(f"loaded, detect exit {code}")
    assert code in (0, 2), err
    if code == 2:
        _one_line(err)


# --------------------------------------------------------------------------- bounded work
def test_a_scale_that_makes_the_mesh_huge_is_refused_before_sampling(corner, tmp_path, capsys,
                                                                     monkeypatch):
    def never(*args, **kwargs):
        raise AssertionError("sampled")

    monkeypatch.setattr(scene_mod, "sample_mesh", never)
    t0 = time.perf_counter()
    line = _cli_error(["detect", corner / "scene.ply", corner / "corner.npz", "-o",
                       tmp_path / "out", "--scale", "1e6"], capsys)
    assert time.perf_counter() - t0 < 30
    assert line.startswith(f"itensor: error: {corner / 'scene.ply'}: 1.56e+12 m^2 of surface "
                           "at a 0.01 m spacing means 15,600,000,")
    assert line.endswith("samples, more than the 5,000,000 allowed; give a larger spacing "
                         "(--spacing, spacing=), or the right scale (--scale, scale=) if the "
                         "file is not in metres")
    with pytest.raises(InputError, match="more than the 5,000,000 allowed"):
        it.load_scene(corner / "scene.ply", 0.001, scale=3.0)
    with pytest.raises(InputError, match="more than the 1,000 allowed"):
        it.prepare_scene(corner_example()[1], 0.01, max_points=1000)
    # a scanned mesh too (its samples are thinned to the spacing's voxels)
    line = _cli_error(["detect", corner / "scene.ply", corner / "corner.npz", "-o",
                       tmp_path / "out", "--scan", "--scale", "1e7"], capsys)
    assert "more than the 5,000,000 allowed" in line


def test_a_cloud_longer_than_open3d_can_voxelise_is_refused():
    from interaction_tensor.capture.cleaning import voxel_down_sample

    pts = np.array([[0.0, 0, 0], [3e7, 0, 0], [0, 1, 0], [0, 0, 1]])
    with pytest.raises(InputError) as exc:
        voxel_down_sample(pts, None, 0.01, "far.ply")
    assert str(exc.value) == ("far.ply: the cloud spans 3e+07 m, more than 2,147,483,647 "
                              "voxels of 0.01 m; is its scale right (scale=, --scale)? Else "
                              "give a larger voxel size (voxel_size=, --voxel-size)")
    assert len(voxel_down_sample(pts, None, 0.1)[0]) == 4


def test_placements_beyond_the_bound_are_refused_up_front(corner, tmp_path, capsys, monkeypatch,
                                                          corner_tensor):
    """Points x sample fraction x orientations: more than MAX_PAIRS refused before the
    scene is prepared (a cloud's normals not estimated) or, for a scene prepared
    elsewhere, before the search."""
    rng = np.random.default_rng(0)
    cloud = tmp_path / "cloud.ply"
    write_ply_points(cloud, np.column_stack([rng.random((60_000, 2)), np.zeros(60_000)]))

    def never(*args, **kwargs):
        raise AssertionError("normals estimated")

    monkeypatch.setattr(scene_mod, "estimate_normals", never)
    monkeypatch.setattr(scene_mod, "MAX_PAIRS", 10_000_000)
    line = _cli_error(["detect", cloud, corner / "corner.npz", "-o", tmp_path / "out",
                       "--sample-fraction", "1", "--orientations", "360"], capsys)
    assert line == (f"itensor: error: {cloud}: 60,000 scene points x 360 placements each "
                    "(sample fraction x orientations) = 21,600,000 placements to decide, more "
                    "than the 10,000,000 allowed; give a smaller --sample-fraction or fewer "
                    "--orientations")
    # the memory the pairs need counts too
    with pytest.raises(InputError, match=r"1,000,000 scene points and 100,000,000 test "
                                         r"placements need about 6.1 GB and 1.0 GB"):
        monkeypatch.setattr(scene_mod, "MAX_PAIRS", 10 ** 9)
        scene_mod.check_memory(1_000_000, "big.ply", available=2 ** 30, pairs_per_point=100)
    scene_mod.check_memory(1_000_000, "big.ply", available=2 ** 30, pairs_per_point=2.4)
    # a prepared scene: refused by the search before any pair is made
    from interaction_tensor.detection import search

    monkeypatch.setattr(search, "MAX_PAIRS", 1000)
    scene = it.prepare_scene(corner_example()[1], 0.02)
    with pytest.raises(InputError, match=r"test points x 8 orientations make [\d,]+ "
                                         r"placements to decide, more than the 1,000"):
        it.detect(scene, corner_tensor, sample_fraction=0.5)


def test_normal_estimation_shows_its_progress(corner_tensor, capsys):
    rng = np.random.default_rng(1)
    pts = np.column_stack([rng.random((120_000, 2)) * 3, rng.random(120_000) * 1e-3])
    normals = sampling.estimate_normals(pts, progress=True)
    err = capsys.readouterr().err
    assert "normals:" in err and "/120k" in err and "fit/s" in err, err
    np.testing.assert_allclose(np.abs(normals[:, 2]), 1.0, atol=0.2)
    assert np.array_equal(normals, sampling.estimate_normals(pts))
    assert capsys.readouterr().err == ""
    # through detect (what the CLI asks for on a terminal)
    it.detect(pts[:60_000], corner_tensor, sample_fraction=0.01, progress=True)
    assert "normals" in capsys.readouterr().err


# --------------------------------------------------------------------------- empty outputs
def test_an_empty_output_path_is_named_before_any_work(corner, tmp_path, capsys, monkeypatch):
    work = tmp_path / "cwd"
    work.mkdir()
    monkeypatch.chdir(work)
    q, _ = corner_example()
    write_mesh(tmp_path / "q.ply", q.vertices, q.faces)
    (tmp_path / "det").mkdir()
    assert main(["detect", str(corner / "scene.ply"), str(corner / "corner.npz"), "-o",
                 str(tmp_path / "det" / "o"), "-q", "--sample-fraction", "0.05",
                 "--no-render"]) == 0
    cases = [
        (["train", tmp_path / "q.ply", corner / "scene.ply", "--affordance", "x", "-o", ""],
         "-o/--output is empty; give the descriptor file to write (.npz)"),
        (["detect", corner / "scene.ply", corner / "corner.npz", "-o", ""],
         "-o/--output is empty; give a directory"),
        (["batch", "--scenes", corner / "scene.ply", "--descriptors", corner / "corner.npz",
          "-o", "", "--workers", "0"], "-o/--output is empty; give a directory"),
        (["demo", "-o", ""], "-o/--output is empty; give a directory"),
        (["examples", "build", "-o", ""], "-o/--output is empty; give a directory"),
        (["render", tmp_path / "det" / "o", "-o", ""],
         ("-o/--output is empty; give the PNG file to write (or leave -o out for "
          "OUTDIR/render.png)")),
        (["show", corner / "corner.npz", "--render", " "],
         "--render is empty; give the PNG file to write"),
    ]
    for argv, says in cases:
        line = _cli_error(argv, capsys)
        assert line == f"itensor: error: {says}", (argv, line)
    assert list(work.iterdir()) == []                    # nothing written where we stand
    assert not (tmp_path / "det" / "o" / "render.png").exists()
    # the same from Python
    tensor = it.InteractionTensor.load(corner / "corner.npz")
    result = it.detect(corner / "scene.ply", tensor, sample_fraction=0.05)
    for call, what in ((lambda: tensor.save(""), "descriptor file"),
                       (lambda: result.save(""), "output directory"),
                       (lambda: it.batch([corner / "scene.ply"], [tensor], "", workers=0),
                        "output directory"),
                       (lambda: write_mesh("", q.vertices, q.faces), "output file")):
        with pytest.raises(InputError) as exc:
            call()
        assert str(exc.value) == f"the {what} path is empty; give one"
    assert list(work.iterdir()) == []


# --------------------------------------------------------------------------- posed objects
def _read_ply(path):
    data = PlyData.read(str(path))
    v = np.column_stack([data["vertex"][k] for k in "xyz"])
    f = np.vstack(data["face"]["vertex_indices"]) if "face" in data and data["face"].count \
        else np.zeros((0, 3), np.int64)
    return v, f


def test_posed_objects_are_the_query_itself_moved(tmp_path, corner_tensor):
    """The seated person (33 closed bodies, some vertices of different bodies at the same
    place) written at each prediction is the query's vertices, moved by the pose, and its
    faces as they are: watertight as the query is, nothing merged or dropped."""
    ex = affordances.build("sitting-human")
    tensor = affordances.build_descriptor("sitting-human", example=ex)
    qv, qf = tensor.query_vertices, tensor.query_faces
    query = trimesh.Trimesh(qv, qf, process=False)
    assert query.is_watertight and len(np.unique(qv, axis=0)) < len(qv)
    floor = parts_mesh([box_part("floor", (0.0, 0.0, ex.ground - 0.01), (1.2, 1.2, 0.02))])
    so = ex.scene_object
    scene = it.Geometry(np.vstack([so.vertices, floor.vertices]),
                        np.vstack([so.faces, floor.faces + len(so.vertices)]))
    result = it.detect(scene, tensor, top_k=2, sample_fraction=0.1)
    assert result.predictions
    out = result.save(tmp_path / "out")
    for rank, p in enumerate(result.predictions, 1):
        v, f = _read_ply(out / "top" / f"top_{rank:02d}.ply")
        pose = np.asarray(p.pose)
        assert v.dtype == np.float64 and len(v) == len(qv)
        np.testing.assert_array_equal(f, qf)
        np.testing.assert_array_equal(v, qv @ pose[:3, :3].T + pose[:3, 3])
        assert trimesh.Trimesh(v, f, process=False).is_watertight
    # a point-cloud query: every point, moved, the repeated ones too
    import copy

    cloud = copy.deepcopy(corner_tensor)
    cloud.query_vertices = np.vstack([cloud.query_vertices, cloud.query_vertices[:3]])
    cloud.query_faces = np.zeros((0, 3), np.int64)
    result = it.detect(it.prepare_scene(corner_example()[1], 0.02), cloud, top_k=1,
                       sample_fraction=0.2)
    assert result.predictions
    out = result.save(tmp_path / "cloud")
    v, f = _read_ply(out / "top" / "top_01.ply")
    pose = np.asarray(result.predictions[0].pose)
    assert len(f) == 0
    np.testing.assert_array_equal(v, cloud.query_vertices @ pose[:3, :3].T + pose[:3, 3])
