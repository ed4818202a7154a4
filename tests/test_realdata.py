"""Real scenes: RGB-D frames and scans, cleaning and gravity alignment.

The TUM desk frame is read from ../shared/data/rgbd/tum_desk (or $ITENSOR_SHARED_DATA);
those tests are skipped when it is absent. Everything runs at 2 cm so that the file takes
well under two minutes on 2 cores.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import interaction_tensor as it
from interaction_tensor.api import load_scene
from interaction_tensor.capture import rgbd
from interaction_tensor.capture.pipeline import surface_noise
from interaction_tensor.cli.main import build_parser, scene_options
from interaction_tensor.errors import InputError
from interaction_tensor.examples.procedural import (
    bookcase,
    parts_mesh,
    room_shell,
    table,
)
from interaction_tensor.geometry.collision import Body, MeshCollider, box

from support import shared_file

rd = pytest.importorskip("interaction_tensor.capture")
pytest.importorskip("open3d")
Image = pytest.importorskip("PIL.Image")

SPACING = 0.02


# ----------------------------------------------------------------------------- helpers
def _angle_deg(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    c = a @ b / (np.linalg.norm(a) * np.linalg.norm(b))
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def _write_intrinsics(path, **changes):
    data = {"width": 64, "height": 48, "fx": 50.0, "fy": 50.0, "cx": 31.5, "cy": 23.5,
            "depth_scale": 1000.0, "depth_trunc": 4.0}
    data.update(changes)
    for key in [k for k, v in data.items() if v is _DROP]:
        del data[key]
    path.write_text(json.dumps(data))
    return path


_DROP = object()


def _write_depth(path, width=64, height=48, value=1500):
    Image.fromarray(np.full((height, width), value, np.uint16)).save(path)
    return path


def _write_color(path, width=64, height=48):
    Image.fromarray(np.full((height, width, 3), 120, np.uint8)).save(path)
    return path


@pytest.fixture(scope="module")
def tum():
    """The TUM frame converted and aligned at 2 cm: (geometry, camera, intrinsics, scene,
    report, floor normal of intrinsics.json in the camera frame)."""
    frame = shared_file("rgbd/tum_desk/depth.png").parent
    geometry, camera, intr = rd.load_rgbd(frame / "color.png", frame / "depth.png",
                                          frame / "intrinsics.json")
    scene, report = rd.prepare_real_scene(geometry, SPACING, camera)
    estimate = json.loads((frame / "intrinsics.json").read_text())["floor_plane_estimate"]
    return geometry, camera, intr, scene, report, np.array(estimate["normal_camera"])


@pytest.fixture(scope="module")
def placing_tensor():
    """The paper's bowl placed on a procedural 0.75 m table, trained at 2 cm."""
    bowl = it.load_geometry(shared_file("objects/paper_bowl.ply"))
    bowl.vertices = bowl.vertices + [0.0, 0.0, 0.75]
    tbl = parts_mesh(table("t", (0.0, 0.0), (1.0, 0.8), 0.75))
    return it.InteractionTensor.fit(bowl, tbl, "placing-bowl",
                                    it.TrainSettings(scene_spacing=SPACING, query_points=3000))


# ----------------------------------------------------------------------------- intrinsics
def test_tum_intrinsics_load():
    intr = rd.load_intrinsics(shared_file("rgbd/tum_desk/intrinsics.json"))
    assert (intr.width, intr.height) == (640, 480)
    assert (intr.fx, intr.fy, intr.cx, intr.cy) == (525.0, 525.0, 319.5, 239.5)
    assert (intr.depth_scale, intr.depth_trunc) == (5000.0, 4.0)
    over = rd.load_intrinsics(shared_file("rgbd/tum_desk/intrinsics.json"),
                              {"depth_scale": 1000, "depth_trunc": None})
    assert over.depth_scale == 1000 and over.depth_trunc == 4.0


def test_open3d_intrinsics_layout(tmp_path):
    path = tmp_path / "o3d.json"
    path.write_text(json.dumps({"width": 640, "height": 480,
                                "intrinsic_matrix": [525, 0, 0, 0, 526, 0, 319.5, 239.5, 1]}))
    intr = rd.load_intrinsics(path)
    assert (intr.fx, intr.fy, intr.cx, intr.cy) == (525, 526, 319.5, 239.5)
    assert intr.depth_scale == rd.DEFAULT_DEPTH_SCALE


@pytest.mark.parametrize("changes, words", [
    ({"fx": _DROP}, "lack 'fx'"),
    ({"fy": -525.0}, "fy must be positive"),
    ({"cx": float("nan")}, "cx must be finite"),
    ({"width": "wide"}, "width must be a number"),
    ({"width": 64.5}, "whole number"),
    ({"depth_scale": 0}, "depth_scale must be positive"),
    ({"depth_trunc": -1}, "depth_trunc must be positive"),
    ({"cy": 900.0}, "outside the image height"),
])
def test_bad_intrinsics(tmp_path, changes, words):
    path = _write_intrinsics(tmp_path / "intr.json", **changes)
    with pytest.raises(InputError) as exc:
        rd.load_intrinsics(path)
    assert "intr.json" in str(exc.value) and words in str(exc.value)


def test_intrinsics_not_json(tmp_path):
    path = tmp_path / "intr.json"
    path.write_text("fx = 525")
    with pytest.raises(InputError, match="not valid JSON"):
        rd.load_intrinsics(path)
    with pytest.raises(InputError, match="no such file"):
        rd.load_intrinsics(tmp_path / "missing.json")


# ----------------------------------------------------------------------------- images
def test_small_frame_back_projection(tmp_path):
    intr = rd.load_intrinsics(_write_intrinsics(tmp_path / "i.json"))
    g, camera = rd.rgbd_to_geometry(_write_color(tmp_path / "c.png"),
                                    _write_depth(tmp_path / "d.png"), intr)
    assert g.vertices.shape == (64 * 48, 3) and g.colors.shape == (64 * 48, 3)
    assert np.allclose(g.vertices[:, 2], 1.5) and np.all(camera == 0)
    # the pixel at the principal point (31.5, 23.5) lies between pixels: x, y symmetric
    assert abs(g.vertices[:, 0].mean()) < 1e-9 and abs(g.vertices[:, 1].mean()) < 1e-9
    u, v = 0, 0    # first pixel: x = (0 - cx) z / fx
    assert np.allclose(g.vertices[0], [(u - 31.5) * 1.5 / 50, (v - 23.5) * 1.5 / 50, 1.5])


def _faces_normals(points, faces):
    a, b, c = points[faces[:, 0]], points[faces[:, 1]], points[faces[:, 2]]
    return np.cross(b - a, c - a)


def test_depth_faces_join_neighbours_and_leave_steps_open(tmp_path):
    intr = rd.load_intrinsics(_write_intrinsics(tmp_path / "i.json"))
    # a flat wall 1.5 m away: every square of neighbouring pixels gives two triangles, all
    # facing the camera, each joining pixels one apart
    flat = np.full((48, 64), 1.5)
    points, _ = rd.back_project(flat, intr)
    faces = rd.depth_faces(flat)
    assert faces.shape == (2 * 47 * 63, 3) and faces.dtype == np.int64
    assert np.all(_faces_normals(points, faces)[:, 2] < 0)            # toward the camera
    edges = np.linalg.norm(points[faces] - points[faces[:, [1, 2, 0]]], axis=2)
    assert edges.max() < 2 * 1.5 / 50                                 # a diagonal at most
    # a step of 0.5 m (a box's edge against the wall behind it) and a hole stay open;
    # a ramp of 1 cm per pixel (a floor seen at a grazing angle) stays joined
    depth = np.full((48, 64), 1.5)
    depth[:, 32:] = 1.0
    depth[10:14, 5:9] = 0.0
    depth[30:, :32] = 1.5 + 0.01 * np.arange(18)[:, None]
    points, valid = rd.back_project(depth, intr)
    faces = rd.depth_faces(depth)
    z = points[faces][:, :, 2]
    assert np.all(z.max(axis=1) - z.min(axis=1) <= 0.01 + 0.02 * z.min(axis=1) + 1e-12)
    assert not np.any((z.min(axis=1) < 1.2) & (z.max(axis=1) > 1.2))  # nothing spans the step
    u = np.nonzero(valid)[1]
    assert np.all(u[faces].max(axis=1) - u[faces].min(axis=1) <= 1)
    ramp = (np.nonzero(valid)[0][faces].min(axis=1) >= 30) & (u[faces].max(axis=1) <= 31)
    assert ramp.sum() == 2 * 17 * 31                                  # the ramp, all joined
    n_valid = int(valid.sum())
    assert faces.min() >= 0 and faces.max() < n_valid
    # a large image is joined on every k-th pixel: the count stays bounded
    big = np.full((480, 640), 2.0)
    few = rd.depth_faces(big, max_faces=20_000)
    assert 0 < len(few) <= 20_000 and len(np.unique(few)) < 480 * 640 / 4


@given(hnp.arrays(np.float64, st.tuples(st.integers(1, 12), st.integers(1, 12)),
                  elements=st.sampled_from([0.0, 0.5, 0.505, 0.52, 1.0, 1.02, 3.0])),
       st.integers(2, 400))
def test_depth_faces_of_any_image_join_only_close_valid_neighbours(depth, max_faces):

    faces = rd.depth_faces(depth, max_faces=max_faces)
    valid = depth > 0
    assert faces.dtype == np.int64 and faces.ndim == 2 and faces.shape[1] == 3
    assert len(faces) <= max(max_faces, 0) or len(faces) == 0
    if len(faces):
        rows, cols = np.nonzero(valid)
        assert faces.min() >= 0 and faces.max() < valid.sum()
        z = depth[rows[faces], cols[faces]]
        assert np.all(z > 0)
        assert np.all(z.max(axis=1) - z.min(axis=1)
                      <= rgbd.DEPTH_JUMP_ABS + rgbd.DEPTH_JUMP_REL * z.min(axis=1) + 1e-12)
        # the three pixels of a triangle are corners of one square of the (strided) grid
        assert np.all(np.ptp(rows[faces], axis=1) == np.ptp(cols[faces], axis=1))
        assert len(np.unique(np.sort(faces, axis=1), axis=0)) == len(faces)


def test_a_frame_whose_pixels_join_nothing_has_no_surface(tmp_path):
    """Isolated depth pixels (a checkerboard of holes) make no triangle: the frame is a
    cloud, and detection's collision test says it is off."""
    depth = np.full((48, 64), 1500, np.uint16)
    depth[::2, ::2] = depth[1::2, 1::2] = 0
    from PIL import Image

    Image.fromarray(depth).save(tmp_path / "d.png")
    intr = _write_intrinsics(tmp_path / "i.json")
    assert len(rd.depth_faces(rd.read_depth(tmp_path / "d.png", rd.load_intrinsics(intr)))) == 0
    scene = it.load_scene(depth=str(tmp_path / "d.png"), intrinsics=str(intr), align=False,
                          remove_outliers=False, voxel_size=0)
    assert scene.mesh is None and scene.surface_noise == 0.0


def test_frame_and_scan_keep_their_surface(tmp_path):
    """A frame's triangles (and a scanned mesh's own) become the scene's mesh, moved by the
    same alignment as its points, so that detection's collision test runs on captured data."""
    intr = _write_intrinsics(tmp_path / "i.json")
    depth = _write_depth(tmp_path / "d.png")
    frame = it.load_scene(depth=str(depth), intrinsics=str(intr), align=False)
    g, _ = rd.rgbd_to_geometry(None, depth, rd.load_intrinsics(intr), surface=True)
    assert frame.mesh is not None and len(frame.mesh[1]) == 2 * 47 * 63
    t = frame.report.transform
    assert np.allclose(frame.mesh[0], g.vertices @ t[:3, :3].T + t[:3, 3])
    # the flat wall faces the camera, so after the level-camera turn it stands 1.5 m ahead:
    # its points and its triangles agree
    assert np.allclose(frame.mesh[0][:, 1], frame.points[:, 1].mean(), atol=1e-6)
    assert frame.collider() is not None
    # a point cloud scan has no triangles; a mesh scan keeps its own, aligned
    cloud = rd.prepare_real_scene(it.Geometry(_room_cloud(noise=0.0)), SPACING)[0]
    assert cloud.mesh is None and cloud.collider() is None
    mesh = parts_mesh(room_shell((3.0, 3.0)) + table("t", (1.5, 1.6), (1.2, 0.8), 0.74))
    rot = _rotation((1, 0, 0), -90.0)                                  # stored Y-up
    scan = it.Geometry(mesh.vertices @ rot.T, np.asarray(mesh.faces), source="scan.ply")
    scene, report = rd.prepare_real_scene(scan, SPACING, up="y")
    t = report.transform
    assert np.allclose(scene.mesh[0], scan.vertices @ t[:3, :3].T + t[:3, 3])
    assert np.array_equal(scene.mesh[1], scan.faces)
    # levelled again: every vertex at its own height, shifted by one constant
    dz = scene.mesh[0][:, 2] - np.asarray(mesh.vertices)[:, 2]
    assert np.ptp(dz) < 0.01


def test_surface_noise_measures_the_spread_not_the_edges():
    from scipy.spatial import cKDTree


    rng = np.random.default_rng(0)
    grid = np.stack(np.meshgrid(np.arange(0, 1, 0.01), np.arange(0, 1, 0.01)), -1).reshape(-1, 2)
    points = np.c_[grid, np.zeros(len(grid))]
    normals = np.tile([0.0, 0.0, 1.0], (len(points), 1))
    tree = cKDTree(points)
    vertices = np.c_[rng.uniform(0, 1, (50_000, 2)), rng.normal(0, 0.003, 50_000)]
    assert surface_noise(vertices, points, normals, tree) == pytest.approx(0.009, rel=0.1)
    # a few vertices on another surface (a depth edge) do not count
    vertices[:2_000, 2] += 0.3
    assert surface_noise(vertices, points, normals, tree) == pytest.approx(0.009, rel=0.15)
    vertices[:, 2] = 0.0
    assert surface_noise(vertices, points, normals, tree) == 0.0
    assert surface_noise(vertices, points, normals, tree, seed=1) == 0.0


def test_tum_surface_collision_test():
    """On the TUM frame the scene's mesh is the frame's surface: a thin plate 2.5 cm above a
    clear patch of the desk top is clear of it, a block through the top's height is not, and
    neither is a post through it; so detection's collision test runs on the frame. The
    surface's noise is measured (under 1 cm at this spacing)."""

    frame = shared_file("rgbd/tum_desk/depth.png").parent
    scene = it.load_scene(str(frame), spacing=SPACING)
    assert scene.mesh is not None and len(scene.mesh[1]) > 400_000
    assert 0.002 < scene.surface_noise < 0.01
    assert scene.report.to_dict()["surface_noise_m"] == pytest.approx(scene.surface_noise,
                                                                       abs=1e-5)
    collider = scene.collider()
    assert isinstance(collider, MeshCollider)
    vertices = scene.mesh[0]
    top = scene.points[(np.abs(scene.points[:, 2] - 0.72) < 0.03) & (scene.normals[:, 2] > 0.95)]
    # a desk-top point whose surface within 8 cm (the frame's own vertices, 15 cm up and
    # down) lies within 1.5 cm of one height: nothing on the top there, no edge
    centre = None
    for p in top[::20]:
        v = vertices[(np.linalg.norm(vertices[:, :2] - p[:2], axis=1) < 0.08)
                     & (np.abs(vertices[:, 2] - p[2]) < 0.15)]
        if len(v) > 200 and np.all(np.abs(v[:, 2] - np.median(v[:, 2])) < 0.015):
            centre = np.r_[p[:2], np.median(v[:, 2])]
            break
    assert centre is not None, "no clear patch of the desk top"
    pose = np.eye(4)
    pose[:3, 3] = centre + [0, 0, 0.025]
    assert not collider.collides(Body(*box((-0.05, -0.05, 0), (0.05, 0.05, 0.001))), pose)
    pose[:3, 3] = centre
    assert collider.collides(Body(*box((-0.05, -0.05, -0.03), (0.05, 0.05, 0.03))), pose)
    assert collider.collides(Body(*box((-0.01, -0.01, -0.1), (0.01, 0.01, 0.1))), pose)


def test_mismatched_sizes(tmp_path):
    intr = rd.load_intrinsics(_write_intrinsics(tmp_path / "i.json"))
    small_depth = _write_depth(tmp_path / "small_depth.png", 32, 24)
    with pytest.raises(InputError) as exc:
        rd.rgbd_to_geometry(None, small_depth, intr)
    assert "small_depth.png" in str(exc.value) and "32x24" in str(exc.value) \
        and "64x48" in str(exc.value)
    depth = _write_depth(tmp_path / "d.png")
    odd_color = _write_color(tmp_path / "odd_color.png", 64, 40)
    with pytest.raises(InputError) as exc:
        rd.rgbd_to_geometry(odd_color, depth, intr)
    assert "odd_color.png" in str(exc.value) and "64x40" in str(exc.value)


def test_bad_depth_images(tmp_path):
    intr = rd.load_intrinsics(_write_intrinsics(tmp_path / "i.json"))
    rgb_depth = _write_color(tmp_path / "rgb_depth.png")
    with pytest.raises(InputError, match="single-channel"):
        rd.rgbd_to_geometry(None, rgb_depth, intr)
    empty = _write_depth(tmp_path / "zeros.png", value=0)
    with pytest.raises(InputError, match="no valid depth"):
        rd.rgbd_to_geometry(None, empty, intr)
    far = _write_depth(tmp_path / "far.png", value=60000)     # 60 m > depth_trunc
    with pytest.raises(InputError, match="no valid depth"):
        rd.rgbd_to_geometry(None, far, intr)
    text = tmp_path / "text.png"
    text.write_text("not an image")
    with pytest.raises(InputError, match="cannot read as an image"):
        rd.rgbd_to_geometry(None, text, intr)
    with pytest.raises(InputError, match="is the depth image|colour image"):
        rd.rgbd_to_geometry(_write_depth(tmp_path / "d2.png"), _write_depth(tmp_path / "d.png"),
                            intr)


def test_orient_normals():
    pts = np.array([[0.0, 0, 1], [0, 0, 2], [1, 0, 0]])
    nrm = np.array([[0.0, 0, 1], [0, 0, -1], [0, 0, -1]])
    towards_cam = rd.orient_normals(pts, nrm, np.zeros(3))
    assert np.allclose(towards_cam[:, 2], [-1, -1, -1])
    assert np.allclose(rd.orient_normals(pts, nrm, "up")[:, 2], 1)
    assert np.allclose(rd.orient_normals(pts, nrm, ("direction", (0, 0, -1)))[:, 2], -1)


# ----------------------------------------------------------------------------- TUM frame
def test_tum_conversion(tum):
    geometry, camera, intr, scene, report, _ = tum
    n = len(geometry.vertices)
    assert 0.75 * 640 * 480 < n < 0.81 * 640 * 480          # 80.8 % valid, minus > 4 m
    assert geometry.colors.shape == (n, 3) and geometry.colors.dtype == np.uint8
    assert 2.0 < np.median(geometry.vertices[:, 2]) < 2.8     # median depth 2.42 m
    names = [s["step"] for s in report.steps]
    assert names[:2] == ["voxel_down_sample", "statistical_outlier_removal"]
    assert report.colors is not None and len(report.colors) == len(scene.points)
    assert len(scene.points) < n and scene.normals.shape == scene.points.shape


def test_tum_alignment_floor_horizontal(tum):
    _, _, _, scene, report, floor_normal_camera = tum
    align = report.alignment
    assert align["kind"] == "floor"
    # the floor normal estimated independently (intrinsics.json) comes out +Z within 3 deg
    assert _angle_deg(report.transform[:3, :3] @ floor_normal_camera, (0, 0, 1)) < 3.0
    assert abs(align["camera_height_m"] - 1.777) < 0.06
    assert report.camera_aligned[2] == pytest.approx(align["camera_height_m"], abs=1e-3)
    # the desk top is a parallel plane about 0.72 m above the floor
    assert any(abs(h - 0.72) < 0.03 for h in align["parallel_planes_heights_m"])
    # the floor is at z = 0: most upward-facing points lie at 0 or on the desk
    z = scene.points[:, 2][scene.normals[:, 2] > 0.95]
    assert np.mean(np.abs(z) < 0.05) > 0.3 and np.mean(np.abs(z - 0.72) < 0.04) > 0.1
    # normals were oriented towards the camera
    to_cam = report.camera_aligned - scene.points
    assert np.all(np.einsum("ij,ij->i", scene.normals, to_cam) >= -1e-9)
    json.dumps(report.to_dict())                             # serialisable


def test_tum_placing_on_desk(tum, placing_tensor, tmp_path):
    _, _, _, scene, report, _ = tum
    settings = it.DetectSettings(sample_fraction=0.08, top_k=8, criterion="gaussian", seed=0)
    result = it.detect(scene, placing_tensor, settings)
    z = np.array([p.position[2] for p in result.predictions])
    on_desk = np.abs(z - 0.72) < 0.05
    assert on_desk[0], z                                  # the desk top is the best place

    it.export(result, tmp_path)
    doc = rd.write_input_frame_outputs(result, tmp_path, report.transform, report)
    for name in ("predictions.json", "heatmap.ply", "predictions_input_frame.json",
                 "heatmap_input_frame.ply", "scene.ply", "scene_input_frame.ply"):
        assert (tmp_path / name).is_file(), name
    assert len(list((tmp_path / "top_input_frame").glob("top_*.ply"))) == len(result.predictions)
    main = json.loads((tmp_path / "predictions.json").read_text())
    assert np.allclose(main["real_scene"]["transform_input_to_aligned"], report.transform)
    assert main["real_scene"]["alignment"]["kind"] == "floor"
    # input-frame positions are camera-frame points: in front of the camera, and mapped back
    inv = np.linalg.inv(report.transform)
    for p, q in zip(result.predictions, doc["predictions"]):
        assert np.allclose(q["position"], inv[:3, :3] @ p.position + inv[:3, 3])
        assert np.allclose(np.asarray(q["pose"]), inv @ p.pose)
        assert q["position"][2] > 0.5                          # depth along the optical axis


# ----------------------------------------------------------------------------- synthetic
def _room_cloud(seed=0, noise=0.003):
    """A 3 x 3 m room (floor, two walls, a 0.74 m table, a bookcase) as a noisy point cloud
    of the surfaces a scanner would see."""
    parts = room_shell((3.0, 3.0)) + table("t", (1.5, 1.6), (1.2, 0.8), 0.74) \
        + bookcase("b", (2.4, 0.3), (0.8, 0.35), [0.3, 0.7, 1.1])
    scene = it.prepare_scene(parts_mesh(parts), 0.02, seed=seed)
    pts = scene.points
    keep = (pts[:, 2] > -1e-6) & np.all(pts[:, :2] > -1e-6, axis=1)   # no slab underside
    rng = np.random.default_rng(seed)
    pts = pts[keep] + rng.normal(0, noise, (keep.sum(), 3))
    return pts


def _rotation(axis, degrees):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    t = math.radians(degrees)
    return np.eye(3) + math.sin(t) * k + (1 - math.cos(t)) * k @ k


@pytest.mark.parametrize("up", ["z", "auto"])
def test_tilted_scene_recovered(up):
    pts = _room_cloud()
    rot = _rotation((0.6, 0.8, 0.0), 28.0) @ _rotation((0, 0, 1), 40.0)
    shift = np.array([0.3, -1.2, 0.9])
    tilted = pts @ rot.T + shift
    g = it.Geometry(tilted, source="tilted room")
    scene, report = rd.prepare_real_scene(g, SPACING, up=up)
    # the true up direction, seen in the input frame, is rot @ z; it must come out +Z
    recovered = report.transform[:3, :3] @ (rot @ np.array([0.0, 0, 1]))
    assert _angle_deg(recovered, (0, 0, 1)) < 2.0
    assert report.alignment["kind"] == "floor"
    z = scene.points[:, 2]
    assert np.percentile(z, 1) > -0.03 and np.median(np.abs(z[np.abs(z) < 0.05])) < 0.01
    # the 0.74 m table top comes out level at its height (its underside is at 0.71 m, a
    # bookcase board at 0.70 m)
    top = z[(scene.normals[:, 2] > 0.95) & (z > 0.725) & (z < 0.9)]
    assert abs(np.median(top) - 0.74) < 0.006 and np.std(top) < 0.01
    # input -> aligned maps the true floor origin onto z = 0
    origin = report.transform @ np.r_[shift, 1.0]
    assert abs(origin[2]) < 0.01


def test_no_align_and_units_warning():
    pts = _room_cloud(noise=0.0)
    g = it.Geometry(pts * 100.0, source="room_in_cm.ply")      # centimetres read as metres
    _, report = rd.prepare_real_scene(g, 2.0, align=False, remove_outliers=False)
    assert report.alignment is None and np.allclose(report.transform, np.eye(4))
    assert any("centimetres" in w for w in report.warnings)
    _, report = rd.prepare_real_scene(it.Geometry(pts, source="room.ply"), SPACING,
                                      align=False, up="y", remove_outliers=False)
    assert np.allclose(report.transform[:3, :3] @ [0, 1, 0], [0, 0, 1])


# ----------------------------------------------------------------------------- CLI glue
def _detect_args(argv):
    """``itensor detect`` arguments parsed by the real parser."""

    return build_parser().parse_args(["detect", *argv, "-o", "unused"])


def _scene(argv):

    args = _detect_args(argv)
    return load_scene(args.scene, SPACING, **scene_options(args))


def test_cli_options_parse():

    a = _detect_args(["d.npz", "--depth", "x.png", "--intrinsics", "i.json",
                      "--depth-scale", "5000", "--no-remove-outliers", "--up", "auto"])
    assert a.scene is None and a.descriptor == "d.npz" and a.depth == "x.png"
    assert a.remove_outliers is False and a.up == "auto" and a.depth_scale == 5000
    a = _detect_args(["room.ply", "d.npz", "--scan", "--up", "0,1,0", "--no-align"])
    assert a.scene == "room.ply" and a.up == (0.0, 1.0, 0.0) and a.no_align and a.scan
    plain = scene_options(_detect_args(["room.ply", "d.npz"]))
    assert "scan" not in plain and "depth" not in plain and "align" not in plain


def test_scene_from_args_frame_dir_and_errors(tmp_path):
    frame = shared_file("rgbd/tum_desk/depth.png").parent
    scene = _scene([str(frame), "d.npz", "--voxel-size", "0.05"])
    report = scene.report
    assert scene.captured and report.kind == "rgbd" and report.alignment["kind"] == "floor"
    assert report.steps[0]["step"] == "rgbd_back_projection" and len(scene.points) > 1000
    # a bad intrinsics file given on the command line
    bad = _write_intrinsics(tmp_path / "bad.json", fx=_DROP)
    with pytest.raises(InputError, match="bad.json"):
        _scene(["d.npz", "--depth", str(frame / "depth.png"), "--intrinsics", str(bad)])
    # intrinsics for another image size
    other = _write_intrinsics(tmp_path / "other.json")
    with pytest.raises(InputError, match="depth.png.*640x480.*64x48"):
        _scene(["d.npz", "--depth", str(frame / "depth.png"), "--intrinsics", str(other)])
    with pytest.raises(InputError, match="intrinsics"):
        _scene(["d.npz", "--depth", "x.png"])
