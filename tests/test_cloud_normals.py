"""A point cloud's normals: the k nearest neighbours found on a grid are the k-d tree's, the
closed-form least eigenvectors are LAPACK's, and the fast plane fits give the reference's
normals (to 1e-12 rad)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial import cKDTree

from interaction_tensor.examples import demo
from interaction_tensor.geometry.grid import KNearest, knn_cell
from interaction_tensor.geometry.sampling import (
    _least_eigenvectors,
    estimate_normals,
    mesh_area,
    sample_mesh,
)


def _room_cloud(spacing, noise=0.0, seed=0):
    ex = demo.build()
    pts = sample_mesh(ex.scene, int(mesh_area(ex.scene) / spacing ** 2), seed)[0]
    return pts + np.random.default_rng(seed).normal(0, noise, pts.shape) if noise else pts


def _check_against_tree(points, queries, k, cell):
    dist, idx = KNearest(points, cell).query(queries, k)
    ref_d, ref_i = cKDTree(points).query(queries, k=min(k, len(points)))
    ref_d, ref_i = ref_d.reshape(len(queries), -1), ref_i.reshape(len(queries), -1)
    assert dist.shape == ref_d.shape and idx.dtype == np.int64
    assert np.allclose(dist, ref_d, rtol=0, atol=1e-12)
    # each index is a point at the distance said (equal distances may come in any order)
    said = np.linalg.norm(points[idx] - queries[:, None], axis=2)
    assert np.allclose(said, dist, rtol=0, atol=1e-12)
    assert all(len(set(row)) == len(row) for row in idx)
    return idx, ref_i


@pytest.mark.parametrize("spacing,cell_factor", [(0.02, 1.0), (0.02, 0.3), (0.02, 4.0)])
def test_grid_neighbours_are_the_trees(spacing, cell_factor):
    pts = _room_cloud(spacing, noise=0.002)
    rng = np.random.default_rng(1)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    # the cloud's own points, points in the air, and points outside its box
    queries = np.vstack([pts[rng.choice(len(pts), 3000, replace=False)],
                         rng.uniform(lo, hi, (500, 3)), rng.uniform(lo - 2, hi + 2, (200, 3))])
    idx, ref = _check_against_tree(pts, queries, 16, cell_factor * knn_cell(spacing, 16))
    assert (idx == ref).mean() > 0.999                       # no ties in a random cloud


def test_grid_neighbours_of_a_cloud_of_uneven_density_and_tiny_ones():
    rng = np.random.default_rng(2)
    dense = rng.normal(0, 0.01, (5000, 3))
    sparse = rng.uniform(-3, 3, (300, 3))
    pts = np.vstack([dense, sparse])
    _check_against_tree(pts, pts, 12, 0.02)
    few = rng.uniform(0, 1, (5, 3))
    dist, idx = KNearest(few, 0.1).query(few, 16)            # k beyond the cloud: all of it
    assert dist.shape == (5, 5) and (np.sort(idx, axis=1) == np.arange(5)).all()


@settings(max_examples=40, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 60), st.just(3)),
              elements=st.floats(-1, 1, allow_nan=False).map(lambda v: round(v, 2))),
       st.integers(1, 8), st.floats(0.01, 0.5))
def test_grid_neighbours_with_duplicates_and_ties(points, k, cell):
    _check_against_tree(points, points, k, cell)


def _apart(a, b):
    """(n,) sines of the angles between unit vectors, either sign."""
    return np.linalg.norm(np.cross(a, b), axis=1)


def test_closed_form_least_eigenvectors_are_lapacks():
    rng = np.random.default_rng(5)
    n = 20000
    spreads = rng.uniform(1e-4, 1, (n, 1, 3))
    spreads[:2000, 0, :2] = 0.0                              # the two least equal (a line)
    spreads[2000:4000, 0, 2] = spreads[2000:4000, 0, 1]      # the two largest (a plane)
    spreads[4000:4100] = 0.3                                 # isotropic
    spreads[4100:4200] = 0.0                                 # all neighbours at one point
    x = rng.normal(size=(n, 16, 3)) * spreads
    turn = np.linalg.qr(rng.normal(size=(n, 3, 3)))[0]
    x = np.einsum("nki,nji->nkj", x, turn)
    cov = np.einsum("nki,nkj->nij", x, x)
    cov[4200:4300] = np.eye(3) * 2.0                         # exactly a multiple of I
    fast = _least_eigenvectors(cov)
    exact = np.linalg.eigh(cov)[1][:, :, 0]
    assert np.allclose(np.linalg.norm(fast, axis=1), 1.0)
    values = np.linalg.eigvalsh(cov)
    gap = (values[:, 1] - values[:, 0]) / np.abs(values[:, 2]).clip(1e-300)
    assert (gap > 1e-3).sum() > 15000
    assert _apart(fast[gap > 1e-3], exact[gap > 1e-3]).max() < 1e-10
    assert _apart(fast[gap > 1e-6], exact[gap > 1e-6]).max() < 1e-6
    # not defined (a line: the two least meet; a point; a multiple of I): LAPACK's own
    assert (gap[:2000] < 1e-9).all()
    assert np.array_equal(fast[:2000], exact[:2000])
    assert np.array_equal(fast[4100:4300], exact[4100:4300])


def test_fast_normals_are_the_references():
    spacing = 0.03
    pts = _room_cloud(spacing, noise=0.001)
    fast = estimate_normals(pts, spacing=spacing)
    assert _apart(fast, estimate_normals(pts, reference=True)).max() < 1e-12
    assert _apart(fast, estimate_normals(pts)).max() < 1e-12      # the tree, the fast fits
    at = np.arange(0, len(pts), 7)
    assert _apart(estimate_normals(pts, at=at, spacing=spacing),
                  estimate_normals(pts, at=at, reference=True)).max() < 1e-12
    assert (fast[np.abs(fast[:, 2]) > 1e-6, 2] > 0).all()       # up where not level
    up = np.abs(fast[:, 2]) > 0.99
    assert up.mean() > 0.3                                    # a room: floor, tops, seats


def test_a_vast_cloud_asks_the_tree_and_gets_the_same_normals():
    rng = np.random.default_rng(4)
    # two patches 5 km apart: a grid of 2.6 cm cells over it would need far more than the
    # cells allowed, so its cells grow and the tree answers
    patch = np.column_stack([rng.uniform(0, 1, (4000, 2)), rng.normal(0, 1e-3, 4000)])
    pts = np.vstack([patch, patch + [5000, 5000, 10]])
    assert KNearest(pts, knn_cell(0.016, 16)).cell > 2 * knn_cell(0.016, 16)
    assert _apart(estimate_normals(pts, spacing=0.016),
                  estimate_normals(pts, reference=True)).max() < 1e-12


def test_a_board_as_thick_as_the_spacing_keeps_its_tops_normals():
    """A 3 cm table top sampled 3 cm apart: both its faces lie in every neighbourhood, and
    the two fits tilt a quarter of the top's planes through both; choosing among the
    neighbours' planes the one the neighbours lie nearest brings them back up."""
    from interaction_tensor.examples.procedural import box_part, parts_mesh
    from interaction_tensor.geometry.sampling import _fits_numpy, _nearest_distance

    board = parts_mesh([box_part("top", (0, 0, 0.72), (1.2, 0.8, 0.03))])
    pts, true = sample_mesh(board, round(mesh_area(board) / 0.03 ** 2), 0)
    inner = (true[:, 2] > 0.99) & (np.abs(pts[:, 0]) < 0.5) & (np.abs(pts[:, 1]) < 0.3)
    tree = cKDTree(pts)
    _, idx = tree.query(pts, k=16)
    slab = _nearest_distance(pts, lambda q, k: tree.query(q, k=k))
    first, again, count = _fits_numpy(pts, pts, idx, slab)
    two = np.where((count >= 5)[:, None], again, first)
    up = np.cos(np.radians(10))
    assert (np.abs(two[inner, 2]) > up).mean() < 0.8
    fast = estimate_normals(pts, spacing=0.03)
    assert (fast[inner, 2] > up).mean() > 0.95
    assert _apart(fast, estimate_normals(pts, reference=True)).max() < 1e-12


def test_a_noisy_face_whose_neighbours_agree_keeps_its_plane(monkeypatch):
    """Where the neighbours' planes agree, choosing among them would change next to
    nothing: the normals of a noisy room are as good as when every point chooses."""
    from interaction_tensor.geometry import sampling

    spacing = 0.02
    pts, true = sample_mesh(demo.build().scene, int(mesh_area(demo.build().scene)
                                                    / spacing ** 2), 0)
    pts = pts + np.random.default_rng(0).normal(0, 0.002, pts.shape)
    kept = estimate_normals(pts, spacing=spacing)
    monkeypatch.setattr(sampling, "NORMAL_AGREE", 0.0)        # every unsure point chooses
    chosen = estimate_normals(pts, spacing=spacing)
    off = [(_apart(n, true) > np.sin(np.radians(10))).mean() for n in (kept, chosen)]
    assert off[0] <= off[1] + 0.002
    assert (_apart(kept, chosen) > 1e-9).mean() > 0.05           # the rule skipped many
    assert off[0] < 0.05


@settings(max_examples=30, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 80), st.just(3)),
              elements=st.floats(-1, 1, allow_nan=False).map(lambda v: round(v, 1))),
       st.sampled_from([None, 0.05, 0.2]), st.booleans())
def test_normals_of_tiny_and_degenerate_clouds_are_unit_vectors(points, spacing, subset):
    """A point, two, duplicates, collinear or coarse-grid points: every normal is a finite
    unit vector, whatever the neighbour search and the points asked for."""
    at = np.arange(0, len(points), 2) if subset else None
    normals = estimate_normals(points, spacing=spacing, at=at)
    assert normals.shape == (len(points) if at is None else len(at), 3)
    assert np.all(np.isfinite(normals))
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-9)
