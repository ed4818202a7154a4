"""The Numba neighbour cache answers exactly what the grid search does."""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor.detection.search import Engine, detect
from interaction_tensor.engine import backends
from interaction_tensor.engine import numba_backend as kernels
from interaction_tensor.engine.backends import (
    CACHE_AUTO_FRACTION,
    CACHE_COLD_PAIRS,
    cache_pays,
    pairs_of,
    spatial_order,
)
from interaction_tensor.engine.numba_backend import score_pairs_numba
from interaction_tensor.examples import demo

from support import corner_example


@pytest.mark.parametrize("criterion,vectors", [("paper", "surface"), ("gaussian", "points")])
def test_cached_scoring_is_bit_identical(criterion, vectors):

    q, s = corner_example()
    t = it.InteractionTensor.fit(q, s, "corner-box", it.TrainSettings(query_points=3000, seed=1,
                                                                      vectors=vectors))
    scene = it.prepare_scene(demo.build().scene, 0.02, seed=3)
    rng = np.random.default_rng(0)
    idx = rng.choice(len(scene), 3000, replace=False)
    orient = rng.integers(0, 8, len(idx))
    st = it.DetectSettings(criterion=criterion)
    table = t.keypoint_table(st)
    grid = scene.grid()
    for early in (True, False):
        plain = score_pairs_numba(scene.points[idx], orient, table, grid, 0.6, vectors,
                                  scene.spacing, early, cache=False)
        for _ in range(2):                       # cold, then with the cache built
            cached = score_pairs_numba(scene.points[idx], orient, table, grid, 0.6, vectors,
                                       scene.spacing, early, cache=True)
            for a, b in zip(plain, cached):
                assert np.array_equal(a, b)


def test_nearest_through_a_built_cache_is_the_grid_search():
    """The placement tests' nearest samples go through the grid's cache as scoring left
    it (built trees scanned, the rest searched): the same indices as the grid search."""

    q, s = corner_example()
    t = it.InteractionTensor.fit(q, s, "corner-box", it.TrainSettings(query_points=3000, seed=1))
    scene = it.prepare_scene(demo.build().scene, 0.02, seed=3)
    rng = np.random.default_rng(1)
    idx = rng.choice(len(scene), 2000, replace=False)
    grid = scene.grid()
    grid.cache = None
    score_pairs_numba(scene.points[idx], rng.integers(0, 8, len(idx)),
                      t.keypoint_table(it.DetectSettings()), grid, 0.6, t.vectors,
                      scene.spacing, True, cache=True)
    cache = grid.cache
    assert cache is not None and cache.used[0] > 0
    near = scene.points[rng.integers(0, len(scene), 20000)] + rng.normal(0, 0.03, (20000, 3))
    far = rng.uniform(-3, 8, (5000, 3))                       # partly outside the cache
    queries = np.vstack([near, far])
    cached = kernels.nearest_indices(grid, queries)
    grid.cache = None
    plain = kernels.nearest_indices(grid, queries)
    grid.cache = cache
    np.testing.assert_array_equal(cached, plain)
    d = np.linalg.norm(scene.points[plain] - queries, axis=1)
    np.testing.assert_allclose(d, scene.tree.query(queries)[0], rtol=0, atol=1e-12)


def test_detection_with_the_cache_decides_alike(monkeypatch):
    """Grid search (False), auto (None: dense test points, so the cache, within a budget
    per scene point that here is ample, forces resets, or leaves no room at all) and a kept
    cache (True) give bit-identical pairs; auto drops its cache when the search ends."""

    q, s = corner_example()
    t = it.InteractionTensor.fit(q, s, "corner-box", it.TrainSettings(query_points=3000, seed=1))
    scene = it.prepare_scene(s, 0.01, seed=2)

    def run(mode):
        det = detect(scene, t, it.DetectSettings(sample_fraction=0.4),
                     engine=Engine(neighbour_cache=mode, batch_size=256))
        assert (scene.grid().cache is not None) == (mode is True)
        return det.pairs

    plain = run(False)
    assert plain.accepted.any() and not plain.accepted.all()
    budgets = []
    # tiny budgets (no floor) drop and rebuild the cache's trees: still exact
    monkeypatch.setattr(backends, "CACHE_AUTO_FLOOR", 0)
    for mode, per_point in ((None, 64), (None, 8), (None, 1), (True, 64)):
        monkeypatch.setattr(backends, "CACHE_AUTO_BYTES_PER_POINT", per_point)
        got = run(mode)
        for name in ("score", "accepted", "decided_at"):
            assert np.array_equal(getattr(plain, name), getattr(got, name)), (mode, per_point)
        assert got.comparisons == plain.comparisons
        if mode is True:
            budgets.append(scene.grid().cache.budget)
    assert budgets == [kernels.CACHE_BYTES]


def test_auto_cache_follows_the_test_point_density(monkeypatch):

    assert Engine().neighbour_cache is None
    monkeypatch.setattr(backends, "cache_kernels_ready", lambda: True)
    assert cache_pays(None, 0.3, 10) and cache_pays(None, CACHE_AUTO_FRACTION, 10)
    assert not cache_pays(None, 0.05, CACHE_COLD_PAIRS)
    assert cache_pays(True, 0.001, 10)
    assert not cache_pays(False, 1.0, CACHE_COLD_PAIRS)
    # never compiled on this machine: only a search big enough to pay for compiling them
    monkeypatch.setattr(backends, "cache_kernels_ready", lambda: False)
    assert not cache_pays(None, 0.3, CACHE_COLD_PAIRS - 1)
    assert cache_pays(None, 0.3, CACHE_COLD_PAIRS)
    assert cache_pays(True, 0.3, 10)


def test_spatial_order_keeps_each_candidate_whole():

    rng = np.random.default_rng(4)
    pts = rng.random((500, 3))
    cand = np.sort(rng.choice(500, 120, replace=False))
    pp = np.repeat(cand, 8)
    from types import SimpleNamespace

    order = spatial_order(pts, pp, 8, SimpleNamespace(origin=np.zeros(3), cell=0.1))
    assert sorted(order.tolist()) == list(range(120))       # a permutation of candidates
    pairs = pairs_of(order, 8)
    assert np.array_equal(np.sort(pairs), np.arange(960))
    assert np.all(pp[pairs].reshape(-1, 8) == pp[pairs][::8, None])   # runs of one point
    # nearby candidates come together: Z-order cells are contiguous
    cells = np.floor(pts[cand[order]] / 0.1).astype(int)
    keys = [tuple(c) for c in cells]
    seen, last = set(), None
    for k in keys:
        if k != last:
            assert k not in seen
            seen.add(k)
        last = k


def test_a_cache_over_its_budget_drops_its_oldest_trees_and_stays_exact():
    """Past its budget the cache drops its oldest trees and moves the rest to the front
    (or, with too little room for that, empties itself): answers stay bit-identical, its
    arrays stay within the budget, and only the pages of built blocks are kept."""
    q, s = corner_example()
    t = it.InteractionTensor.fit(q, s, "corner-box", it.TrainSettings(query_points=3000, seed=1))
    scene = it.prepare_scene(s, 0.01, seed=2)
    rng = np.random.default_rng(5)
    idx = rng.choice(len(scene), 4000, replace=False)
    job = kernels.ScoreJob(scene.points[idx], rng.integers(0, 8, len(idx)),
                           t.keypoint_table(it.DetectSettings()), 0.6, t.vectors,
                           scene.spacing, True)
    grid = scene.grid()
    plain = kernels.score_jobs([job], grid, False)[0]
    grid.cache = None
    kernels.score_jobs([job], grid, True)
    full = grid.cache
    assert full.evictions == full.resets == 0
    built = int((full.pool >= 0).sum())
    assert built > 100 and int((full.owner >= 0).sum()) < len(full.ptab)
    trees = int(full.used[0]) * 16 + int(full.used[1]) * 4
    seen = set()
    for share in (0.6, 0.25, 0.02):
        grid.cache = None
        budget = int(share * trees) + full.table_bytes
        got = kernels.score_jobs([job], grid, True, budget)[0]
        for a, b in zip(plain, got):
            assert np.array_equal(a, b), share
        c = grid.cache
        assert c.nbytes <= budget
        seen.add((c.evictions > 0, c.resets > 0))
        # a block's page is held only while one of its group's blocks is built or marked
        held = np.flatnonzero(c.owner >= 0)
        assert np.all(c.ptab[c.owner[held]] == held)
        assert np.all((c.pool.reshape(-1, kernels.PAGE ** 3)[held] != -1).any(axis=1))
        assert int((c.ptab >= 0).sum()) == len(held)
        # every built block's tree lies in the used part of the arrays
        roots = c.pool[c.pool >= 0]
        assert np.all(roots < c.used[0])
    assert any(e for e, _ in seen) and any(r for _, r in seen)    # both ways were taken


def test_the_cache_arrays_grow_geometrically_up_to_the_budget():
    """Trees added a little at a time enlarge the node and list arrays a few times, not once
    per batch as they near the budget (each enlargement copies them), and never past it."""
    q, s = corner_example()
    scene = it.prepare_scene(s, 0.01, seed=2)
    grid = scene.grid()
    budget = 8 * 2**20
    c = kernels.NeighbourCache(grid, grid.origin, grid.origin + 1.0, budget)
    added = 0
    while c._reserve(1000, 10000):
        c.used += (1000, 10000)
        added += 1
        assert c.nbytes <= budget
    assert added > 100 and c.grows <= 12
    assert c.nbytes > 0.9 * budget - c.table_bytes      # the room was used


def test_the_auto_cache_has_a_floor_whatever_the_scene_size(monkeypatch):
    """A small scene's auto cache gets at least CACHE_AUTO_FLOOR bytes (24 bytes a point left
    a person's search rebuilding its trees), a large one 24 bytes a point, both at most the
    cache's own limit; the budget reaches the kernels, whichever stage comes first."""
    seen = []
    real = backends.NumbaBackend.score

    def spy(self, *args, **kwargs):
        seen.append(kwargs.get("cache_bytes"))
        return real(self, *args, **kwargs)

    monkeypatch.setattr(backends.NumbaBackend, "score", spy)
    q, s = corner_example()
    t = it.InteractionTensor.fit(q, s, "corner-box", it.TrainSettings(query_points=3000, seed=1))
    scene = it.prepare_scene(s, 0.01, seed=2)
    it.detect(scene, t, it.DetectSettings(sample_fraction=0.4))
    assert seen == [backends.CACHE_AUTO_FLOOR] and backends.CACHE_AUTO_FLOOR >= 32 * 2**20
    detect(scene, t, it.DetectSettings(sample_fraction=0.4), engine=Engine(score_first=True))
    assert seen == [backends.CACHE_AUTO_FLOOR] * 2
    assert backends.cache_budget(10**8, None) == kernels.CACHE_BYTES
    assert backends.cache_budget(10**8, True) == kernels.CACHE_BYTES
    assert backends.CACHE_AUTO_BYTES_PER_POINT * 10**8 > kernels.CACHE_BYTES >= \
        backends.CACHE_AUTO_FLOOR


def test_the_cache_kernels_compile_aside_the_first_time_only(monkeypatch):
    """Where Numba's cache lacks the neighbour cache's kernels, one process compiles them
    while detection runs its placement tests, and the scoring waits for it; where they are
    compiled, or inside that process, nothing is started."""
    started = []

    class FakeProcess:
        def __init__(self, cmd, **kwargs):
            started.append((cmd, kwargs["env"]))
            self.waited = False

        def wait(self):
            self.waited = True

    monkeypatch.setattr(backends.subprocess, "Popen", FakeProcess)
    monkeypatch.setattr(backends, "_PREFETCH", None)
    monkeypatch.setattr(backends, "cache_kernels_ready", lambda: True)
    backends.prefetch_cache_kernels()
    assert started == []
    monkeypatch.setattr(backends, "cache_kernels_ready", lambda: False)
    monkeypatch.setenv(backends.PREFETCHING, "1")
    backends.prefetch_cache_kernels()
    assert started == []
    monkeypatch.delenv(backends.PREFETCHING)
    backends.prefetch_cache_kernels()
    backends.prefetch_cache_kernels()                 # one process, however often asked
    assert len(started) == 1 and "compile_cache_kernels" in started[0][0][-1]
    assert started[0][1][backends.PREFETCHING] == "1"
    process = backends._PREFETCH
    backends.await_cache_kernels()
    assert process.waited and backends._PREFETCH is None


def test_compiling_the_cache_kernels_scores_through_the_cache():
    backends.compile_cache_kernels()                  # compiled already: runs in a moment
    assert backends.cache_kernels_ready()
