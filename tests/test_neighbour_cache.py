"""The Numba neighbour cache answers exactly what the grid search does."""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor.detect import keypoint_table
from interaction_tensor.kernels import score_pairs_numba

from conftest import corner_example


@pytest.mark.parametrize("criterion,vectors", [("paper", "surface"), ("gaussian", "points")])
def test_cached_scoring_is_bit_identical(criterion, vectors):
    from interaction_tensor.examples import demo

    q, s = corner_example()
    t = it.InteractionTensor.fit(q, s, "corner-box", it.TrainSettings(query_points=3000, seed=1,
                                                                      vectors=vectors))
    scene = it.prepare_scene(demo.build().scene, 0.02, seed=3)
    rng = np.random.default_rng(0)
    idx = rng.choice(len(scene), 3000, replace=False)
    orient = rng.integers(0, 8, len(idx))
    st = it.DetectSettings(criterion=criterion)
    table = keypoint_table(t, st)
    grid = scene.grid()
    for early in (True, False):
        plain = score_pairs_numba(scene.points[idx], orient, table, grid, 0.6, vectors,
                                  scene.spacing, early, cache=False)
        for _ in range(2):                       # cold, then with the cache built
            cached = score_pairs_numba(scene.points[idx], orient, table, grid, 0.6, vectors,
                                       scene.spacing, early, cache=True)
            for a, b in zip(plain, cached):
                assert np.array_equal(a, b)


def test_detection_with_the_cache_decides_alike():
    q, s = corner_example()
    t = it.InteractionTensor.fit(q, s, "corner-box", it.TrainSettings(query_points=3000, seed=1))
    scene = it.prepare_scene(s, 0.01, seed=2)
    a = it.detect(scene, t, it.DetectSettings(sample_fraction=0.4))
    b = it.detect(scene, t, it.DetectSettings(sample_fraction=0.4, neighbour_cache=True))
    assert np.array_equal(a.pairs.score, b.pairs.score)
    assert np.array_equal(a.pairs.accepted, b.pairs.accepted)
