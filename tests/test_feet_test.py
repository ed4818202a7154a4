"""Detection's feet test (``DetectSettings.feet``, the descriptor's ``feet_reach``).

What stood on the example's ground (a seated person's feet) must find something to stand on
within the reach below it, or the scene's ground where the scan has no floor. These tests
check the columns it probes against the example, the fast search against a brute-force
reference, the seats it must keep and the counter tops it must reject (with a floor and
without one), and the setting's file round trip.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import interaction_tensor as it
from interaction_tensor.clearance import (FAILS_FEET, GROUND_RADIUS, PLACED, check_placements,
                                          feet_supported, feet_supported_poses,
                                          point_offsets, standing_columns)
from interaction_tensor.errors import InputError
from interaction_tensor.examples import interactions
from interaction_tensor.examples.procedural import box_part, parts_mesh

#: only the feet test decides
FEET_ONLY = dict(clearance=False, contact=False, interior=False, ground=False)


@pytest.fixture(scope="module")
def sitting():
    return interactions.build_descriptor("sitting-human")


def test_the_sitting_example_stands_on_its_feet_and_the_columns_cover_them(sitting):
    groups = standing_columns(sitting)
    assert sitting.feet_reach == 0.2 and len(groups) >= 2
    ids = np.asarray(sitting.contact_group_ids)
    sides = []
    for cols, sole, r in groups:
        assert sole == pytest.approx(sitting.ground, abs=0.02)
        assert 2 <= len(cols) <= 6 and 0.03 <= r < 0.12
        # every point of its group lies within r of a column, horizontally
        member = [g for g in np.unique(ids)
                  if np.isin(cols, sitting.contact_group_points[ids == g]).all(axis=1).all()]
        assert len(member) == 1
        pts = sitting.contact_group_points[ids == member[0]]
        d = np.linalg.norm(pts[:, None, :2] - cols[None, :, :2], axis=2).min(axis=1)
        assert d.max() <= r + 1e-12
        sides.append(np.sign(cols[:, 1].mean()))
    assert set(sides) == {-1, 1}                         # a left foot and a right foot
    hanger = interactions.build_descriptor("hanging-hanger")
    assert standing_columns(hanger) == [] and hanger.feet_reach is None


def _reference(points, orient, tensor, scene, n_o, reach, tolerance=0.02):
    """Brute force: every probe ball of every column against every scene sample."""
    out = np.ones(len(points), bool)
    ground = scene.ground_level(points, GROUND_RADIUS + tensor.radius)
    for cols, sole, r in standing_columns(tensor):
        rho = r * np.sqrt(5) / 2
        off = point_offsets(cols, tensor.reference_point, n_o)
        n = int(np.ceil((reach + tolerance) / r - 1e-9))
        for i, (p, o) in enumerate(zip(points, orient)):
            s = p[2] + sole - tensor.reference_point[2]
            probes = []
            for j in range(n):
                q = p + off[o]
                q[:, 2] = s + tolerance - r * (j + 0.5)
                probes.append(q)
            probes = np.concatenate(probes)
            d = np.linalg.norm(scene.points[None] - probes[:, None], axis=2)
            stands = bool((d <= rho).any()) or ground[i] >= s - reach
            out[i] &= stands
    return out


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2 ** 31 - 1), st.sampled_from([0.1, 0.2, 0.35]))
def test_the_search_is_exactly_the_brute_force_probes(sitting, seed, reach):
    tensor = sitting
    rng = np.random.default_rng(seed)
    # clutter at every height, sparse enough that some feet find nothing within reach
    pts = rng.uniform((-1.5, -1.5, 0.0), (1.5, 1.5, 1.2), (600, 3))
    scene = it.Scene(pts, np.tile([0.0, 0.0, 1.0], (len(pts), 1)), 0.01)
    points = rng.uniform((-1, -1, 0.3), (1, 1, 1.4), (40, 3))
    orient = rng.integers(0, 8, 40)
    got = feet_supported(points, orient, tensor, scene, 8, reach)
    np.testing.assert_array_equal(got, _reference(points, orient, tensor, scene, 8, reach))


def _room(floor: bool):
    """A stool (top 0.45 m) and a counter (top 0.9 m, its front edge at x = 0.1), with or
    without a floor; the lowest thing scanned without one is the furniture's base."""
    parts = [box_part("stool", (2.0, 0.0, 0.225), (0.4, 0.4, 0.45)),
             box_part("counter", (-0.2, 0.0, 0.45), (0.6, 1.2, 0.9))]
    if floor:
        parts.append(box_part("floor", (0.5, 0.0, -0.01), (4.0, 3.0, 0.02)))
    return it.prepare_scene(parts_mesh(parts), 0.01, seed=0)


@pytest.mark.parametrize("floor", [True, False])
def test_a_person_on_a_stool_stands_and_one_on_a_counter_edge_does_not(sitting, floor):
    """Facing +x (orientation 0): on the stool the feet rest on the floor (or, without a
    floor, at the height of the lowest thing scanned); on the counter's edge they hang 45 cm
    in the air, over the floor or over nothing."""
    scene = _room(floor)
    stool = np.array([[2.0, 0.0, 0.45]])
    counter = np.array([[0.0, 0.0, 0.9]])
    points = np.vstack([stool, counter])
    orient = np.zeros(2, np.int64)
    assert feet_supported(points, orient, sitting, scene, 8).tolist() == [True, False]
    settings_ = it.DetectSettings(**FEET_ONLY, feet=True)
    assert check_placements(points, orient, sitting, settings_, scene)[1].tolist() \
        == [PLACED, FAILS_FEET]
    off = it.DetectSettings(**FEET_ONLY, feet=False)
    assert check_placements(points, orient, sitting, off, scene)[1].tolist() == [PLACED, PLACED]
    # the counter's feet are 47.5 cm above the floor: a reach of 0.5 m lets them stand
    assert feet_supported(counter, orient[:1], sitting, scene, 8, 0.5).tolist() == [True]
    # the same through 4x4 poses (the labelled set's form)
    poses = np.stack([sitting.pose(p, 0.0) for p in points])
    assert feet_supported_poses(poses, sitting, scene).tolist() == [True, False]


def test_detection_on_the_counter_room_predicts_no_one_on_the_counter(sitting):
    """End to end: every pair the score accepts (a low threshold) on the room with a floor;
    with the feet test no accepted placement has its seat on the counter top."""
    scene = _room(True)
    tensor = interactions.build_descriptor("sitting-human")
    tensor.set_acceptance(1e-3)
    on_top = np.flatnonzero(scene.points[:, 2] > 0.89)
    loose = dict(clearance=False, contact=False, interior=False, collision=False, top_k=3)
    det = it.detect(scene, tensor, it.DetectSettings(**loose), test_indices=on_top[::4])
    assert det.stats["pairs_accepted_by_score"] > 0
    # the feet are 47.5 cm above the floor wherever the seat is on the top: the only
    # placements kept have them inside the counter (its faces within reach; the legs go
    # through it: the clearance and collision tests' business, off here)
    kept = np.flatnonzero(det.pairs.accepted)
    assert 0 < det.stats["pairs_failing_feet"] and len(kept) < 0.01 * len(det.pairs.accepted)
    for i in kept:
        pose = tensor.pose(scene.points[det.pair_point[i]], det.pair_orientation[i] * np.pi / 4)
        feet = np.concatenate([c for c, _, _ in standing_columns(tensor)])
        posed = feet @ pose[:3, :3].T + pose[:3, 3]
        assert np.any(np.all(np.abs(posed[:, :2] - [-0.2, 0.0]) < [0.3, 0.6], axis=1))
    det = it.detect(scene, tensor, it.DetectSettings(**loose, feet=False),
                    test_indices=on_top[::4])
    assert det.pairs.accepted.sum() == det.stats["pairs_accepted_by_score"]


def test_the_feet_setting_survives_a_file_and_a_bad_one_is_refused(sitting, tmp_path):
    tensor = interactions.build_descriptor("sitting-human")
    assert tensor.acceptance()["feet_reach"] == 0.2
    tensor.set_acceptance(tensor.threshold(), feet_reach=0.3)
    assert it.InteractionTensor.load(tensor.save(tmp_path / "f.npz")).feet_reach == 0.3
    tensor.set_acceptance(tensor.threshold(), feet_reach="off")
    assert tensor.feet_reach is None
    for wrong in (-0.01, 2.0, "on", True):
        with pytest.raises(ValueError, match="feet_reach"):
            tensor.set_acceptance(tensor.threshold(), feet_reach=wrong)
    with np.load(tmp_path / "f.npz") as data:
        raw = {k: data[k] for k in data.files}
    header = json.loads(raw["header"].tobytes())
    for name, value in (("a.npz", "far"), ("b.npz", -1.0), ("c.npz", 3.0)):
        raw["header"] = np.frombuffer(json.dumps({**header, "feet_reach": value}).encode(),
                                      np.uint8)
        np.savez(tmp_path / name, **raw)
        with pytest.raises(InputError, match="feet_reach"):
            it.InteractionTensor.load(tmp_path / name)
    old = {k: v for k, v in header.items() if k != "feet_reach"}   # a file of before
    raw["header"] = np.frombuffer(json.dumps(old).encode(), np.uint8)
    np.savez(tmp_path / "old.npz", **raw)
    assert it.InteractionTensor.load(tmp_path / "old.npz").feet_reach is None
