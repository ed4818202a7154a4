"""The Numba clearance kernel counts exactly the violations the cKDTree reference counts."""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.engine.numba_backend import available
from interaction_tensor.geometry.grid import build_grid
from interaction_tensor.placement.checks import (
    clearance_offsets,
    contact_fractions,
    count_violations,
    nearest_distance_function,
    seat_fractions,
    violations,
)

pytestmark = pytest.mark.skipif(not available(), reason="needs Numba")


class _Scene:
    def __init__(self, points):
        from scipy.spatial import cKDTree

        self.points = points
        self.tree = cKDTree(points)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kernel_equals_reference_on_clutter(seed):

    rng = np.random.default_rng(seed)
    # a floor, a box top and scattered clutter, 1 cm-ish spacing
    floor = np.c_[rng.uniform(0, 1, (20000, 2)), np.zeros(20000)]
    top = np.c_[rng.uniform(0.3, 0.6, (3000, 2)), np.full(3000, 0.4)]
    clutter = rng.uniform(0, 1, (2000, 3)) * [1, 1, 0.8]
    pts = np.vstack([floor, top, clutter])
    grid = build_grid(pts, np.zeros_like(pts), 0.02)
    offsets = rng.normal(0, 0.1, (8, 64, 3))
    radius = rng.uniform(0, 0.03, 64)
    radius[:5] = 0.0                                # contact points: never violated
    n = 3000
    points = pts[rng.integers(0, len(pts), n)] + rng.normal(0, 0.02, (n, 3))
    points[:50] += 5.0                              # far outside the grid
    orient = rng.integers(0, 8, n)
    ref = violations(points, orient, offsets, radius, 0.005,
                     nearest_distance_function(_Scene(pts), None, radius.max()))
    fast = count_violations(points, orient, offsets, radius, 0.005, None, grid)
    assert ref.sum() > 0 and (ref == 0).any()
    np.testing.assert_array_equal(fast, ref)
    # counted up to a stop (detection's: the first count past the limit), the same below it
    for stop in (1, 3, int(np.median(ref[ref > 0])) + 1):
        stopped = count_violations(points, orient, offsets, radius, 0.005, None, grid, stop=stop)
        np.testing.assert_array_equal(stopped, np.minimum(ref, stop))
        assert (ref >= stop).any() and (ref < stop).any()


def test_kernel_equals_reference_on_a_descriptor():
    """The placing example's own clearance points over a procedural room."""

    tensor = affordances.build_descriptor("placing-bowl", seed=0, spacing=0.02)
    room = it.prepare_scene(affordances.build("placing-bowl").scene_object, 0.01, seed=0)
    rng = np.random.default_rng(0)
    idx = rng.integers(0, len(room.points), 4000)
    orient = rng.integers(0, 8, len(idx))
    offsets = clearance_offsets(tensor, 8)
    ref = count_violations(room.points[idx], orient, offsets, tensor.clearance_radius, 0.005,
                           room, None)
    fast = count_violations(room.points[idx], orient, offsets, tensor.clearance_radius, 0.005,
                            room, room.grid())
    assert ref.max() > 0
    np.testing.assert_array_equal(fast, ref)


@pytest.mark.parametrize("seed", [0, 1])
def test_bounded_nearest_answers_within_as_the_exact_nearest(seed):
    """``d <= r`` of the bounded search equals that of the exact nearest distance for every
    r in [lo, hi], on clutter, for queries at surfaces, in the air, outside the grid and on
    the samples themselves (distance 0)."""
    from scipy.spatial import cKDTree

    from interaction_tensor.placement._kernels import nearest_within

    rng = np.random.default_rng(seed)
    floor = np.c_[rng.uniform(0, 1, (20000, 2)), np.zeros(20000)]
    clutter = rng.uniform(0, 1, (3000, 3)) * [1, 1, 0.6]
    pts = np.vstack([floor, clutter])
    grid = build_grid(pts, np.zeros_like(pts), 0.03)
    q = np.vstack([pts[rng.integers(0, len(pts), 4000)] + rng.normal(0, 0.03, (4000, 3)),
                   pts[:200],                                   # on a sample
                   rng.uniform(-0.5, 1.5, (2000, 3)),            # in and outside the grid
                   [[0.5, 0.5, -0.02], [3.0, 3.0, 3.0]]])
    _, i = cKDTree(pts).query(q)
    exact = np.linalg.norm(pts[i] - q, axis=1)                  # as nearest_samples
    for lo, hi in ((0.02, 0.02), (0.01, 0.1), (0.0, 0.05), (0.03, 0.03)):
        d = nearest_within(q, lo, hi, grid)
        for r in np.unique(np.r_[lo, hi, np.linspace(lo, hi, 7)]):
            np.testing.assert_array_equal(d <= r, exact <= r)
        inner = (exact > lo) & (exact <= hi)
        np.testing.assert_array_equal(d[inner], exact[inner])   # the exact distance there
        assert np.isinf(d[exact > hi]).all() and (d[exact <= lo] <= lo).all()
        assert (exact <= lo).any() and (exact > hi).any() and (inner.any() or lo == hi)


def _seated_pairs(seed: int):
    """The sitting example's stool room, 3,000 placements (touching, near and in the air)
    and the seated descriptor."""
    room = it.prepare_scene(affordances.build("sitting-human").scene_object, 0.01, seed=0)
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, len(room.points), 3000)
    pts = room.points[idx] + rng.normal(0, 0.05, (3000, 3)) * (rng.random((3000, 1)) < 0.5)
    orient = rng.integers(0, 8, len(idx))
    return room, pts, orient, affordances.build_descriptor("sitting-human", seed=0,
                                                           spacing=0.02)


def test_contact_and_seat_fractions_on_the_grid_equal_the_reference():
    """The placement tests' contact and seat fractions through the bounded search equal
    those of the cKDTree's nearest samples, for the sitting and riding examples' pairs in a
    procedural room (touching, near and in the air)."""

    room, pts, orient, sit = _seated_pairs(3)
    tests = [(0.02, 90.0), (0.1, 90.0), (0.05, 90.0)]
    ref = contact_fractions(pts, orient, sit, tests, 8, room, None)
    fast = contact_fractions(pts, orient, sit, tests, 8, room, room.grid())
    assert 0 < ref[:, :, 0].mean() < 1
    np.testing.assert_array_equal(fast, ref)
    ride = affordances.build_descriptor("riding-human", seed=0, spacing=0.02)
    ref = seat_fractions(pts, orient, ride, 0.03, 8, room, None)
    fast = seat_fractions(pts, orient, ride, 0.03, 8, room, room.grid())
    assert (ref > 0).any() and (ref < 1).any()
    np.testing.assert_array_equal(fast, ref)


@pytest.mark.parametrize("seed", [0, 1])
def test_a_cells_free_distance_is_what_its_box_keeps_from_every_sample(seed):
    """The free table (every cell's distance to the nearest non-empty cell's box) bounds
    from below the nearest-sample distance of any point in the cell, and is exact for the
    boxes: the brute-force box distance to the nearest non-empty cell."""
    from scipy.spatial import cKDTree

    from interaction_tensor.geometry.grid import free_distances

    rng = np.random.default_rng(seed)
    pts = np.vstack([np.c_[rng.uniform(0, 1, (3000, 2)), np.zeros(3000)],
                     rng.uniform(0, 1, (40, 3)) * [1, 1, 0.7]])
    grid = build_grid(pts, np.zeros_like(pts), 0.05)
    free = free_distances(grid)
    assert free is grid.free or np.array_equal(free, grid.free)
    dims = grid.dims
    occupied = np.argwhere((np.diff(grid.starts) > 0).reshape(tuple(dims)))
    cells = np.argwhere(np.ones(tuple(dims), bool))
    gap = np.maximum(np.abs(cells[:, None, :] - occupied[None]) - 1, 0)
    box = np.sqrt((gap ** 2).sum(axis=2)).min(axis=1) * grid.cell
    np.testing.assert_allclose(free, box, rtol=1e-6, atol=1e-7)
    assert (free > 0).any() and (free == 0).any()
    q = rng.uniform(grid.origin, grid.origin + dims * grid.cell, (20000, 3))
    c = np.minimum(np.floor((q - grid.origin) / grid.cell).astype(int), dims - 1)
    lin = (c[:, 0] * dims[1] + c[:, 1]) * dims[2] + c[:, 2]
    d, _ = cKDTree(pts).query(q)
    assert (d >= free[lin] - 1e-6).all()


def test_contact_with_an_angle_on_the_grid_equals_the_reference():
    """With an angle test the nearest sample within the largest distance is searched on the
    grid, and its normal read: the fractions equal those of the cKDTree's nearest samples."""
    room, pts, orient, sit = _seated_pairs(5)
    tests = [(0.02, 30.0), (0.05, 60.0), (0.03, 90.0)]
    ref = contact_fractions(pts, orient, sit, tests, 8, room, None)
    fast = contact_fractions(pts, orient, sit, tests, 8, room, room.grid())
    assert 0 < ref[:, 0, 0].mean() < 1 and (ref[:, 0] != ref[:, 1]).any()
    np.testing.assert_array_equal(fast, ref)
