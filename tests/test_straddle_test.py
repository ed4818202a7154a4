"""Detection's straddle and mount tests (riding: ``DetectSettings.straddle`` and ``.mount``,
the descriptor's ``straddle`` and ``mount_height``).

A rider needs the support to go on between the legs ahead of the seat and room for a leg on
each side, and a seat within reach from the ground. These tests check the column search
against a brute-force reference, the rider it must keep (astride a narrow bench, facing
along it) and the ones it must reject (across the bench, on a bed's wide top, on a tall
partition's top), the riding acceptance it ships with, and the settings' file round trip.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import interaction_tensor as it
from interaction_tensor.clearance import (FAILS_MOUNT, FAILS_STRADDLE, PLACED, above_ground,
                                          box_lattice, check_placements, straddle_passes,
                                          straddle_passes_poses)
from interaction_tensor.errors import InputError
from interaction_tensor.examples import interactions
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.scene import ColumnIndex

from conftest import descriptor_with_header

#: only the straddle test decides
STRADDLE_ONLY = dict(clearance=False, contact=False, interior=False, ground=False, feet=False,
                     mount=False)


@pytest.fixture(scope="module")
def riding():
    return interactions.build_descriptor("riding-human")


@pytest.fixture(scope="module")
def room():
    """A bench 10 cm wide along x (top 0.5 m, x from -1 to 1), a bed 1.6 m wide (top 0.5 m)
    at x = 3, a partition 10 cm wide (top 2.4 m) along x at y = 1, and a floor."""
    parts = [box_part("bench", (0.0, 0.0, 0.25), (2.0, 0.10, 0.5)),
             box_part("bed", (3.0, 0.0, 0.25), (1.0, 1.6, 0.5)),
             box_part("partition", (0.0, 1.0, 1.2), (2.0, 0.10, 2.4)),
             box_part("floor", (1.5, 0.0, -0.01), (6.0, 3.0, 0.02))]
    return it.prepare_scene(parts_mesh(parts), 0.01, seed=0)


def _occupied_reference(points, xy, low, high, cell=0.02):
    """Brute force: any sample between low and high in the columns holding the points."""
    cols = np.floor(points[:, :2] / cell).astype(np.int64)
    out = np.zeros(len(low), bool)
    for i in range(len(low)):
        c = np.floor(xy[i] / cell).astype(np.int64)
        inside = (cols[:, None, :] == c[None]).all(axis=2).any(axis=1)
        z = points[inside, 2]
        out[i] = bool(((z >= low[i]) & (z <= high[i])).any())
    return out


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2 ** 31 - 1), st.integers(1, 6))
def test_the_column_search_without_margin_is_exact(seed, g):
    rng = np.random.default_rng(seed)
    points = rng.uniform([-0.2, -0.2, 0.0], [0.2, 0.2, 0.5], (300, 3))
    xy = rng.uniform(-0.25, 0.25, (40, g, 2))
    low = rng.uniform(-0.1, 0.5, 40)
    high = low + rng.uniform(0.0, 0.3, 40)
    index = ColumnIndex(points)
    got = index.highest_under(xy, high, neighbours=False) >= low
    np.testing.assert_array_equal(got, _occupied_reference(points, xy, low, high))
    scene = it.Scene(points, np.tile([0.0, 0.0, 1.0], (len(points), 1)), 0.01)
    np.testing.assert_array_equal(scene.occupied(xy, low, high), got)


def test_a_box_lattice_covers_the_footprint_at_the_column_size():
    lat = box_lattice(((-0.10, 0.20), (0.16, 0.40), (0.0, 1.0)))
    assert lat[:, 0].min() == -0.10 and lat[:, 0].max() == 0.20
    assert lat[:, 1].min() == 0.16 and lat[:, 1].max() == 0.40
    assert np.diff(np.unique(lat[:, 0])).max() <= 0.02 + 1e-12
    assert np.diff(np.unique(lat[:, 1])).max() <= 0.02 + 1e-12


def test_a_rider_astride_a_bench_passes_and_across_it_or_on_a_bed_does_not(riding, room):
    """Facing +x (orientation 0) or -x (4) along the bench the rider is astride it; facing +y
    (2) the bench crosses under the seat with nothing ahead between the legs; on the bed's
    top the legs have no room on either side."""
    assert riding.straddle is not None and riding.straddle["astride"] is not None
    bench, bed = [0.0, 0.0, 0.5], [3.0, 0.0, 0.5]
    points = np.array([bench, bench, bench, bed])
    orient = np.array([0, 4, 2, 0])
    ok = straddle_passes(points, orient, riding, room, 8)
    assert ok.tolist() == [True, True, False, False]
    assert check_placements(points, orient, riding, it.DetectSettings(**STRADDLE_ONLY),
                            room)[1].tolist() == [PLACED, PLACED, FAILS_STRADDLE,
                                                  FAILS_STRADDLE]
    off = it.DetectSettings(**STRADDLE_ONLY, straddle=False)
    assert (check_placements(points, orient, riding, off, room)[1] == PLACED).all()
    # the same through 4x4 poses (the labelled set's form)
    poses = np.stack([riding.pose(p, o * np.pi / 4) for p, o in zip(points, orient)])
    np.testing.assert_array_equal(straddle_passes_poses(poses, riding, room), ok)
    # the seat is the bench's top, the bench between the legs: a rider, not a hover
    seat = poses[0][:3, :3] @ riding.reference_point + poses[0][:3, 3]
    assert seat[2] == pytest.approx(0.5) and abs(seat[1]) < 0.05


def test_detection_on_the_bench_and_bed_keeps_riders_along_the_bench_only(riding, room):
    """End to end, every pair the score accepts (a low threshold): with the straddle test the
    kept riders sit on the bench's top facing along it; none on the bed."""
    tensor = interactions.build_descriptor("riding-human")
    tensor.set_acceptance(1e-3)
    pts = room.points
    top = (pts[:, 2] > 0.49) & (pts[:, 2] < 0.6)                # the bench's and the bed's
    bench = np.flatnonzero(top & (np.abs(pts[:, 0]) < 0.6))
    bed = np.flatnonzero(top & (np.abs(pts[:, 0] - 3.0) < 0.3) & (np.abs(pts[:, 1]) < 0.5))
    tops = np.r_[bench[::4], bed[::40]]
    loose = dict(clearance=False, contact=False, interior=False, collision=False, top_k=3)
    det = it.detect(room, tensor, it.DetectSettings(**loose), test_indices=tops)
    assert det.stats["pairs_failing_straddle"] > 0
    kept = np.flatnonzero(det.pairs.accepted)
    assert len(kept) > 0
    at = room.points[det.pair_point[kept]]
    assert (np.abs(at[:, 1]) <= 0.05 + 1e-9).all() and (at[:, 0] < 1.0).all()
    assert set(det.pair_orientation[kept].tolist()) <= {0, 4}
    det = it.detect(room, tensor, it.DetectSettings(**loose, straddle=False),
                    test_indices=tops)
    assert det.pairs.accepted.sum() == det.stats["pairs_accepted_by_score"]
    assert det.stats["pairs_failing_straddle"] == 0


def test_the_straddle_setting_survives_a_file_and_a_bad_one_is_refused(riding, tmp_path):
    tensor = interactions.build_descriptor("riding-human")
    assert tensor.acceptance()["straddle"]["legroom"][0] == [[-0.1, 0.2], [0.16, 0.4],
                                                            [-0.14, 0.02]]
    back = it.InteractionTensor.load(tensor.save(tmp_path / "r.npz"))
    assert back.straddle == tensor.straddle
    tensor.set_acceptance(tensor.threshold(), straddle={"legroom": [((0, 0.1), (0.2, 0.3),
                                                                     (-0.1, 0.0))]})
    assert tensor.straddle["astride"] is None and len(tensor.straddle["legroom"]) == 1
    tensor.set_acceptance(tensor.threshold(), straddle="off")
    assert tensor.straddle is None
    assert it.InteractionTensor.load(tensor.save(tmp_path / "o.npz")).straddle is None
    for wrong in ({}, {"legroom": []}, {"astride": ((0.1, 0.0), (0, 1), (0, 1))},
                  {"astride": ((0, 1), (0, 1))}, {"legroom": "box"}, {"seat": None},
                  {"astride": ((0, 9), (0, 1), (0, 1))}, [1, 2]):
        with pytest.raises(ValueError, match="straddle|box|legroom|astride"):
            tensor.set_acceptance(tensor.threshold(), straddle=wrong)
    for name, value in (("a.npz", "wide"), ("b.npz", {"astride": [[0, 1], [1, 0], [0, 1]]}),
                        ("c.npz", {"legroom": [[[0, 1], [0, 1], [0, float("inf")]]]})):
        descriptor_with_header(tmp_path / "r.npz", tmp_path / name, straddle=value)
        with pytest.raises(InputError, match="straddle"):
            it.InteractionTensor.load(tmp_path / name)
    old = descriptor_with_header(tmp_path / "r.npz", tmp_path / "old.npz", drop="straddle")
    assert it.InteractionTensor.load(old).straddle is None


def test_a_rider_on_a_tall_partition_is_out_of_reach_and_one_on_the_bench_is_not(riding, room):
    """Astride the partition's top, facing along it, the rider passes the straddle test (the
    partition between the legs, room on each side) and fails the mount test: the seat is
    2.4 m up (the published kitchens' top riders on their walls)."""
    assert riding.mount_height == 1.5
    points = np.array([[0.0, 0.0, 0.5], [0.0, 1.0, 2.4]])
    orient = np.array([0, 0])
    assert straddle_passes(points, orient, riding, room, 8).tolist() == [True, True]
    np.testing.assert_allclose(above_ground(points, riding, room), [0.52, 2.42], atol=0.011)
    only = dict(STRADDLE_ONLY, straddle=True, mount=True)
    assert check_placements(points, orient, riding, it.DetectSettings(**only),
                            room)[1].tolist() == [PLACED, FAILS_MOUNT]
    off = dict(only, mount=False)
    assert (check_placements(points, orient, riding, it.DetectSettings(**off),
                             room)[1] == PLACED).all()
