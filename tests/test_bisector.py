import numpy as np

from interaction_tensor.descriptor.bisector import (
    bisector_points,
    bisector_points_voronoi,
    circumcentres,
    trim_to_sphere,
)


def random_plane(n, z, half, rng):
    return np.column_stack([rng.uniform(-half, half, (n, 2)), np.full(n, z)])


def test_parallel_planes_give_the_mid_plane():
    rng = np.random.default_rng(0)
    bottom = random_plane(3000, 0.0, 0.1, rng)
    top = random_plane(3000, 0.05, 0.1, rng)
    b = bisector_points(top, bottom)
    central = b[np.abs(b[:, :2]).max(axis=1) < 0.05]
    assert len(central) > 500
    # every Voronoi vertex between the planes lies on their mid-plane, up to sampling
    np.testing.assert_allclose(central[:, 2], 0.025, atol=0.002)
    assert abs(np.median(central[:, 2]) - 0.025) < 2e-4


def test_delaunay_route_equals_voronoi_ridges():
    rng = np.random.default_rng(1)
    q = rng.normal(size=(300, 3)) * 0.05 + [0, 0, 0.2]
    s = rng.normal(size=(300, 3)) * 0.05
    fast = bisector_points(q, s)
    ref = bisector_points_voronoi(q, s)
    assert len(fast) == len(ref)
    # same set of points (order differs)
    fs = fast[np.lexsort(fast.T)]
    rs = ref[np.lexsort(ref.T)]
    np.testing.assert_allclose(fs, rs, atol=1e-9)


def test_circumcentre_is_equidistant():
    rng = np.random.default_rng(2)
    tets = rng.normal(size=(50, 4, 3))
    c, ok = circumcentres(tets)
    assert ok.all()
    d = np.linalg.norm(tets - c[:, None, :], axis=2)
    np.testing.assert_allclose(d, np.repeat(d[:, :1], 4, axis=1), rtol=1e-9)


def test_flat_tetrahedra_are_flagged():
    flat = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]], float)
    _, ok = circumcentres(flat)
    assert not ok[0]


def test_trim_to_sphere():
    pts = np.array([[0, 0, 0], [0.5, 0, 0], [2, 0, 0]], float)
    assert trim_to_sphere(pts, [0, 0, 0], 1.0).tolist() == [True, True, False]
