import json

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor.geometry.sampling import (
    mean_spacing,
    uniform_keypoints,
    unique_rows,
    weighted_keypoints,
)

from support import plane


@pytest.fixture(scope="module")
def planes_tensor():
    # query: a 0.2 m square 6 cm above a 0.2 m square scene-object
    settings = it.TrainSettings(query_points=4000, scene_spacing=0.004, crop_factor=2.0)
    return it.InteractionTensor.fit(plane(0.06), plane(0.0), "planes", settings)


def test_provenance_vectors_point_straight_at_the_scene_object(planes_tensor):
    t = planes_tensor
    central = np.abs(t.bisector_points[:, :2]).max(axis=1) < 0.04
    b, v = t.bisector_points[central], t.provenance_vectors[central]
    assert len(b) > 100
    np.testing.assert_allclose(b[:, 2], 0.03, atol=0.002)          # the mid-plane
    # straight down: the surface vector's lateral part vanishes where a sample's disk
    # (radius = spacing) lies under the point, and stays within the gap between samples
    lateral = np.linalg.norm(v[:, :2], axis=1)
    assert (lateral < 1e-9).mean() > 0.8 and lateral.max() < 0.004
    np.testing.assert_allclose(v[:, 2], -b[:, 2], atol=1e-9)         # to the plane z = 0
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 0.03, atol=0.002)  # half the gap


def test_weights_follow_equation_4(planes_tensor):
    t = planes_tensor
    mag = np.linalg.norm(t.provenance_vectors, axis=1)
    expected = 1 - (mag - mag.min()) / (mag.max() - mag.min())
    np.testing.assert_allclose(t.weights, expected)
    assert t.weights.max() == pytest.approx(1) and t.weights.min() == pytest.approx(0)
    for kp in (t.weighted, t.uniform):
        assert len(kp.points) == 512
        m = np.linalg.norm(kp.provenance, axis=1)
        assert np.all(np.diff(m) >= 0)                               # sorted by |v|
        np.testing.assert_allclose(kp.weights, 1 - (m - mag.min()) / (mag.max() - mag.min()))


def test_weighted_sampling_is_proportional_to_weight():
    # eq. 3: P(x_i) = w_i / sum w. Two groups, weights 1 and 0.25: over many seeds the
    # heavy group is chosen 4 times as often per point (without replacement, small n).
    w = np.r_[np.ones(1000), np.full(1000, 0.25)]
    counts = np.zeros(2000)
    for seed in range(200):
        counts[weighted_keypoints(w, 20, seed)] += 1
    ratio = counts[:1000].mean() / counts[1000:].mean()
    assert 3.4 < ratio < 4.7
    assert set(weighted_keypoints(np.r_[np.zeros(10), np.ones(3)], 5, 0)) >= {10, 11, 12}


def test_mean_spacing_of_a_grid_ignores_duplicates():
    # a 4 mm square grid on the plane z = 0.3 x: 1 / sqrt(points per m^2 of the plane) is
    # 4 mm * 1.09^(1/4), with or without every third point repeated (scans and converted
    # clouds repeat points)
    g = np.stack(np.meshgrid(np.arange(150), np.arange(150)), -1).reshape(-1, 2) * 0.004
    pts = np.c_[g, 0.3 * g[:, 0]] + [-1.0, 2.0, 0.5]
    assert mean_spacing(pts) == pytest.approx(0.004 * 1.09 ** 0.25, rel=0.03)
    assert mean_spacing(np.r_[pts, pts[::3]]) == pytest.approx(mean_spacing(pts), rel=0.03)


def test_unique_rows_is_numpys_unique():
    rng = np.random.default_rng(4)
    a = rng.integers(-5, 5, size=(3000, 3))
    np.testing.assert_array_equal(unique_rows(a), np.unique(a, axis=0))
    assert unique_rows(a[:0]).shape == (0, 3)


def test_uniform_sampling_covers_without_repeats():
    idx = uniform_keypoints(1000, 512, 3)
    assert len(set(idx.tolist())) == 512 and idx.max() < 1000


def test_fit_is_deterministic_for_a_seed(corner_tensor):
    from support import corner_example
    q, s = corner_example()
    again = it.InteractionTensor.fit(q, s, "corner-box", it.TrainSettings(query_points=3000, seed=1))
    np.testing.assert_array_equal(again.weighted.points, corner_tensor.weighted.points)
    np.testing.assert_array_equal(again.uniform.provenance, corner_tensor.uniform.provenance)
    assert again.thresholds == corner_tensor.thresholds


def test_save_load_round_trips_exactly(tmp_path, corner_tensor):
    path = corner_tensor.save(tmp_path / "d.npz")
    back = it.InteractionTensor.load(path)
    for name in ("reference_point", "affordance_normal", "bisector_points", "provenance_vectors",
                 "weights", "query_vertices", "query_faces", "contact_points", "scene_points",
                 "query_centroid"):
        np.testing.assert_array_equal(getattr(back, name), getattr(corner_tensor, name))
    for which in ("weighted", "uniform"):
        a, b = back.keypoints(which), corner_tensor.keypoints(which)
        np.testing.assert_array_equal(a.points, b.points)
        np.testing.assert_array_equal(a.provenance, b.provenance)
        np.testing.assert_array_equal(a.weights, b.weights)
    assert back.thresholds == corner_tensor.thresholds
    assert back.radius == corner_tensor.radius and back.vectors == corner_tensor.vectors
    assert back.affordance == "corner-box"
    with np.load(path, allow_pickle=False) as data:     # loads with pickle disabled
        assert "header" in data.files


def test_load_rejects_foreign_and_future_files(tmp_path, corner_tensor):
    other = tmp_path / "other.npz"
    np.savez(other, a=np.arange(3))
    with pytest.raises(it.InputError, match="not a descriptor"):
        it.InteractionTensor.load(other)
    pickled = tmp_path / "pickled.npz"
    np.savez(pickled, header=np.array([{"x": 1}], dtype=object))
    with pytest.raises(it.InputError):
        it.InteractionTensor.load(pickled)
    path = corner_tensor.save(tmp_path / "d.npz")
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    header = json.loads(arrays["header"].tobytes())
    header["format_version"] = 99
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), np.uint8)
    future = tmp_path / "future.npz"
    np.savez(future, **arrays)
    with pytest.raises(it.InputError, match="version 99"):
        it.InteractionTensor.load(future)
    text = tmp_path / "text.npz"
    text.write_text("hello")
    with pytest.raises(it.InputError, match="not a descriptor"):
        it.InteractionTensor.load(text)


def test_objects_that_do_not_touch_are_rejected():
    with pytest.raises(it.InputError, match="do not touch|do not interact"):
        it.InteractionTensor.fit(plane(2.0), plane(0.0), "far apart")


def test_reference_point_is_under_the_query(corner_tensor):
    # the box's footprint centre on the floor
    np.testing.assert_allclose(corner_tensor.reference_point, [0.2, 0.25, 0.0], atol=0.02)
    assert 0 < corner_tensor.threshold() < corner_tensor.self_scores["paper-weighted"]


def test_example_scores_high_at_its_own_pose(corner_tensor):
    # scored at exactly the reference point on a re-sampled scene-object, the example
    # matches itself; at sampled points a few millimetres off, contacts with the walls
    # loosen, which is what the calibrated threshold accounts for
    from support import corner_example
    _, s = corner_example()
    scene = it.prepare_scene(s, corner_tensor.scene_spacing, seed=11)
    at_ref = it.score_at(corner_tensor, scene, corner_tensor.reference_point[None], [0])
    assert at_ref[0] > 0.65
    turned = it.score_at(corner_tensor, scene, corner_tensor.reference_point[None], [4])
    assert turned[0] < 0.6 * at_ref[0]           # the box turned round does not fit
    assert corner_tensor.self_scores["paper-weighted"] > 0.4


def test_pose_maps_the_reference_point_to_the_test_point(corner_tensor):
    m = corner_tensor.pose([1.0, 2.0, 0.5], np.pi / 2)
    ref = np.r_[corner_tensor.reference_point, 1]
    np.testing.assert_allclose(m @ ref, [1.0, 2.0, 0.5, 1])
    np.testing.assert_allclose(m[:3, :3] @ [1, 0, 0], [0, 1, 0], atol=1e-12)


def test_a_descriptors_repr_is_one_line():
    from interaction_tensor import affordances

    tensor = affordances.build_descriptor("placing-bowl")
    text = repr(tensor)
    assert "\n" not in text and len(text) < 200 and str(tensor) == text
    assert "'placing-bowl'" in text and "512 weighted" in text
