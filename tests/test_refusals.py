"""Bad options and bad examples are refused up front, naming what is wrong .

Option values are checked by argparse types (:func:`cli_common.number`) and again by the
settings dataclasses for Python callers; training refuses examples whose objects overlap;
a PCD's NaN points are dropped and said."""

import numpy as np
import pytest
import trimesh
from hypothesis import given
from hypothesis import settings as hsettings
from hypothesis import strategies as st

import interaction_tensor as it
from interaction_tensor.capture import load_intrinsics, prepare_real_scene
from interaction_tensor.cli.main import build_parser, main
from interaction_tensor.detection.places import top_k
from interaction_tensor.errors import InputError, SettingsError
from interaction_tensor.geometry import scene as scene_mod
from interaction_tensor.geometry.files import write_ply_points
from interaction_tensor.geometry.sampling import (
    winding_numbers,
    winding_numbers_reference,
)
from interaction_tensor.settings import DetectSettings, TrainSettings

from support import plane

# (subcommand and positional arguments, option, a refused value, what the message says)
BAD_OPTIONS = [
    (["detect", "s.ply", "d.npz"], "--seed", "-3", "non-negative integer"),
    (["detect", "s.ply", "d.npz"], "--seed", "1.5", "non-negative integer"),
    (["detect", "s.ply", "d.npz"], "--voxel-size", "nan", "[0, 1]"),
    (["detect", "s.ply", "d.npz"], "--voxel-size", "-0.01", "[0, 1]"),
    (["detect", "s.ply", "d.npz"], "--max-tilt", "91", "[0, 90]"),
    (["detect", "s.ply", "d.npz"], "--outlier-std", "0", "> 0"),
    (["detect", "s.ply", "d.npz"], "--outlier-neighbors", "0", "[1, 1000]"),
    (["detect", "s.ply", "d.npz"], "--plane-distance", "inf", "(0, 1]"),
    (["detect", "s.ply", "d.npz"], "--top-k", "ten", "integer >= 1"),
    (["detect", "s.ply", "d.npz"], "--top-k", "0", "integer >= 1"),
    (["detect", "s.ply", "d.npz"], "--sample-fraction", "abc", "(0, 1]"),
    (["detect", "s.ply", "d.npz"], "--sample-fraction", "0", "(0, 1]"),
    (["detect", "s.ply", "d.npz"], "--spacing", "1e-6", "[0.001, 1]"),
    (["detect", "s.ply", "d.npz"], "--normal-tolerance", "nan", "[0, 180]"),
    (["detect", "s.ply", "d.npz"], "--scale", "-1", "> 0"),
    (["detect", "s.ply", "d.npz"], "--depth-scale", "0", "(0, 1e+06]"),
    (["detect", "s.ply", "d.npz"], "--depth-trunc", "1e3", "(0, 100]"),
    (["train", "q.ply", "s.ply"], "--spacing", "inf", "[0.001, 1]"),
    (["train", "q.ply", "s.ply"], "--query-points", "50", "[100, 1e+06]"),
    (["batch", "--scenes", "s.ply", "--descriptors", "d.npz", "-o", "out"],
     "--workers", "-1", "[0, 1024]"),
    (["paper", "evaluate"], "--spacing", "0", "[0.001, 1]"),
    (["demo"], "--seed", "-1", "non-negative integer"),
]


@pytest.mark.parametrize("argv, option, value, says", BAD_OPTIONS,
                         ids=[f"{a[0]}{o}={v}" for a, o, v, _ in BAD_OPTIONS])
def test_bad_option_values_are_refused_naming_the_option(argv, option, value, says, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv + [option, value])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"argument {option}" in err and says in err, err
    assert "invalid" not in err and "Traceback" not in err


@hsettings(max_examples=60, deadline=None)
@given(st.one_of(st.text(max_size=12), st.floats(allow_nan=True, allow_infinity=True)
                 .map(repr), st.integers(-10**30, 10**30).map(str)))
def test_numeric_options_never_take_what_they_cannot_use(text):
    """Whatever the text, a numeric option is either a finite in-range number or refused."""
    parser = build_parser()
    for option, low, high in (("--voxel-size", 0, 1), ("--max-tilt", 0, 90),
                              ("--normal-tolerance", 0, 180), ("--seed", 0, 2**63 - 1)):
        action = parser._subparsers._group_actions[0].choices["detect"]._option_string_actions[
            option]
        try:
            value = action.type(text)
        except Exception as exc:          # argparse turns this into "argument --x: ..."
            assert type(exc).__name__ == "ArgumentTypeError", exc
            continue
        assert np.isfinite(value) and low <= value <= high


def test_settings_refuse_what_the_cli_refuses():
    for bad in (-1, 2**63, 1.5, True, "3"):
        with pytest.raises(SettingsError, match="seed"):
            DetectSettings(seed=bad)
        with pytest.raises(SettingsError, match="seed"):
            TrainSettings(seed=bad)
    with pytest.raises(SettingsError, match="torch backend only"):
        DetectSettings(device="cuda")                          # backend auto/numba
    with pytest.raises(SettingsError, match="cpu, mps, cuda"):
        DetectSettings(backend="torch", device="bogus")
    DetectSettings(backend="torch", device="cuda:1")           # well-formed: checked on use


def test_realdata_cleaning_options_are_checked(tmp_path):

    g = plane(0.0, 0.5)
    for name, value in (("voxel_size", float("nan")), ("voxel_size", -0.01),
                        ("max_tilt_deg", 120.0), ("plane_distance", 0.0),
                        ("outlier_std", float("inf")), ("outlier_neighbors", 0)):
        with pytest.raises(SettingsError, match=name):
            prepare_real_scene(it.Geometry(g.vertices), 0.01, **{name: value})


def test_pcd_nan_points_are_dropped_and_said(tmp_path, capsys, corner_tensor):
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.random((3000, 2)) * 0.6, np.zeros(3000)])
    pts[::10] = np.nan
    path = tmp_path / "organised.pcd"
    header = ("VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3000\n"
              "HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3000\nDATA ascii\n")
    path.write_text(header + "\n".join(" ".join(f"{v:.6f}" for v in p) for p in pts) + "\n")
    scene = it.load_scene(path)
    assert len(scene) == 2700
    assert scene.notes == ["300 of 3000 PCD points with NaN or infinite coordinates dropped "
                           "(PCL marks missing points so)"]
    result = it.detect(scene, corner_tensor, sample_fraction=0.05)
    assert result.stats["scene_notes"] == scene.notes


# --------------------------------------------------------------------------- training
def _bowl_on_table():
    table = trimesh.creation.box((0.8, 0.6, 0.03))
    table.apply_translation((0, 0, 0.735))                    # top at z = 0.75
    bowl = trimesh.creation.cylinder(radius=0.07, height=0.05, sections=48)
    bowl.apply_translation((0, 0, 0.775))                     # resting on the top
    return bowl, table


def test_training_accepts_touching_and_refuses_interpenetrating_objects():
    bowl, table = _bowl_on_table()
    it.train(bowl, table, "placing", query_points=2000)     # touching: fine
    for depth in (0.01, 0.04):                               # sunk 1 cm, or through the top
        sunk = bowl.copy()
        sunk.apply_translation((0, 0, -depth))
        with pytest.raises(InputError, match="interpenetrate"):
            it.train(sunk, table, "placing", query_points=2000)


def test_training_refuses_a_flat_query_laid_in_the_scene_object():
    _, table = _bowl_on_table()
    sheet = trimesh.creation.box((0.3, 0.3, 0.001))
    sheet.apply_translation((0, 0, 0.7495))
    with pytest.raises(InputError, match="lies on the scene-object"):
        it.train(sheet, table, "placing", query_points=2000)


def test_thin_parts_are_inside_by_winding_number():
    """A rod through a 2 cm desk top is inside it, which no clearance tolerance sees."""
    desk = trimesh.creation.box((1.0, 0.6, 0.02))
    rod = np.array([[0.1, 0.0, z] for z in np.linspace(-0.009, 0.009, 7)])
    assert (winding_numbers(rod, desk.vertices, desk.faces) > 0.5).all()
    outside = rod + [0, 0, 0.02]
    assert (winding_numbers(outside, desk.vertices, desk.faces) < 0.5).all()


def test_winding_number_kernel_matches_the_reference():
    mesh = trimesh.creation.icosphere(2)
    pts = np.random.default_rng(3).normal(size=(300, 3))
    fast = winding_numbers(pts, mesh.vertices, mesh.faces)
    ref = winding_numbers_reference(pts, mesh.vertices, mesh.faces, chunk=10_000)
    np.testing.assert_allclose(fast, ref, atol=1e-9)
    inside = np.linalg.norm(pts, axis=1) < 0.9                 # well inside the polyhedron
    assert (fast[inside] > 0.99).all() and (fast[np.linalg.norm(pts, axis=1) > 1.01] < 0.01).all()


# --------------------------------------------------------------------------- RGB-D frames
_JSON_VALUES = st.one_of(st.none(), st.booleans(), st.text(max_size=6),
                         st.floats(allow_nan=True, allow_infinity=True),
                         st.integers(-10**6, 10**6), st.lists(st.integers(), max_size=3))


@hsettings(max_examples=80, deadline=None)
@given(changes=st.dictionaries(st.sampled_from(["width", "height", "fx", "fy", "cx", "cy",
                                                "depth_scale", "depth_trunc"]),
                               _JSON_VALUES, min_size=1, max_size=3),
       drop=st.sets(st.sampled_from(["width", "fx", "cy"]), max_size=1))
def test_tampered_intrinsics_are_refused_or_sane(changes, drop, tmp_path_factory):
    """Any change to the real frame's intrinsics is read as sane numbers or refused in one
    line naming the file; never a traceback, never NaN, a negative focal length or a
    principal point outside the image."""
    import json

    from support import shared_file

    data = json.loads(shared_file("rgbd/tum_desk/intrinsics.json").read_text())
    data.update(changes)
    for key in drop:
        data.pop(key, None)
    path = tmp_path_factory.mktemp("intr") / "intrinsics.json"
    path.write_text(json.dumps(data))
    try:
        intr = load_intrinsics(path)
    except InputError as exc:
        assert str(exc).startswith(str(path)) and "\n" not in str(exc)
        return
    values = [intr.fx, intr.fy, intr.cx, intr.cy, intr.depth_scale, intr.depth_trunc]
    assert all(np.isfinite(values)) and min(intr.fx, intr.fy, intr.depth_scale,
                                            intr.depth_trunc) > 0
    assert intr.width >= 1 and intr.height >= 1
    assert 0 <= intr.cx <= intr.width and 0 <= intr.cy <= intr.height


@hsettings(max_examples=30, deadline=None)
@given(which=st.sampled_from(["depth.png", "color.png"]), fraction=st.floats(0.0, 0.98),
       garbage=st.binary(max_size=16))
def test_cut_or_damaged_frame_images_are_refused(which, fraction, garbage, tmp_path_factory):
    import shutil

    from support import shared_file

    frame = tmp_path_factory.mktemp("frame")
    for name in ("depth.png", "color.png", "intrinsics.json"):
        shutil.copy(shared_file(f"rgbd/tum_desk/{name}"), frame / name)
    raw = (frame / which).read_bytes()
    (frame / which).write_bytes(raw[:int(fraction * len(raw))] + garbage)
    with pytest.raises(InputError) as exc:
        it.load_scene(frame)
    assert str(frame / which) in str(exc.value) and "\n" not in str(exc.value)


def test_a_scene_too_big_for_memory_is_refused_up_front(monkeypatch):

    scene_mod.check_memory(1_000_000, "big.ply", available=2 ** 31)          # 0.3 GB: fine
    with pytest.raises(InputError, match=r"big.ply: 20,000,000 scene points need about 5.6 GB "
                                         r"and 1.0 GB is available"):
        scene_mod.check_memory(20_000_000, "big.ply", available=2 ** 30)
    monkeypatch.setattr(scene_mod, "available_memory", lambda: 10_000 * scene_mod.BYTES_PER_POINT)
    with pytest.raises(InputError, match="scene points need"):
        it.load_scene(plane(0.0, 1.0))                                       # 1 cm: 40,000 points
    assert scene_mod.available_memory is not None


def _greedy_reference(positions, scores, k, radius):
    """Take the best unsuppressed candidate k times (the definition top_k must match)."""
    masked = np.asarray(scores, float).copy()
    picks = []
    for _ in range(k if len(masked) else 0):
        i = int(np.argmax(masked))
        if not np.isfinite(masked[i]):
            break
        picks.append(i)
        masked[np.linalg.norm(positions - positions[i], axis=1) <= radius] = -np.inf
    return picks


@hsettings(max_examples=40, deadline=None)
@given(n=st.integers(0, 9000), k=st.integers(0, 30), radius=st.floats(0.0, 0.5),
       ties=st.booleans(), seed=st.integers(0, 2**32 - 1))
def test_top_k_sweep_is_the_greedy_suppression(n, k, radius, ties, seed):
    """The block sweep (no (N, 3) temporary per pick) picks exactly what the greedy
    definition picks, ties to the lower index included."""

    rng = np.random.default_rng(seed)
    positions = rng.random((n, 3)) * [2, 2, 0.1]
    scores = np.round(rng.random(n), 1) if ties else rng.random(n)
    expected = _greedy_reference(positions, scores, k, radius)
    assert top_k(positions, scores, k, radius) == expected
    # through an index into a larger array (the scene's points), as detect calls it
    base = np.vstack([rng.random((n, 3)), positions[::-1]])
    index = np.arange(2 * n - 1, n - 1, -1)
    assert top_k(base, scores, k, radius, index=index) == expected


def test_a_scene_with_no_candidate_says_why(tmp_path, capsys, corner_tensor):
    """A valid scene where no normal fits the affordance exits 0 and says why."""
    g = np.stack(np.meshgrid(np.linspace(0, 0.5, 30), np.linspace(0, 0.5, 30)), -1).reshape(-1, 2)
    pts = np.column_stack([np.zeros(len(g)), g])                   # a wall: normals along x
    normals = np.tile([1.0, 0.0, 0.0], (len(pts), 1))
    write_ply_points(tmp_path / "wall.ply", pts, normals=normals)
    corner_tensor.save(tmp_path / "t.npz")
    assert main(["detect", str(tmp_path / "wall.ply"), str(tmp_path / "t.npz"),
                 "-o", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "0 after the normal filter" in out and "no candidate: no test point's normal" in out
