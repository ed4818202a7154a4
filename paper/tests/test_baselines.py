"""The Naive and bisector-surface baselines and their ICP."""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from itensor_paper.baselines import icp as icp_mod
from itensor_paper.baselines.bisector_icp import bisector_baseline
from itensor_paper.baselines.common import capped_candidates
from itensor_paper.baselines.naive import naive


def _cloud(n=600, seed=0):
    rng = np.random.default_rng(seed)
    p = rng.uniform(-0.1, 0.1, (n, 3))
    p[:, 2] = 0.05 * np.sin(20 * p[:, 0]) + 0.03 * np.cos(15 * p[:, 1])
    return p


@pytest.mark.parametrize("backend", ["numpy", "open3d"])
def test_icp_recovers_a_small_shift(backend):
    if backend == "open3d" and not icp_mod.open3d_available():
        pytest.skip("open3d not installed")
    target = _cloud()
    shift = np.eye(4)
    shift[:3, 3] = [0.006, -0.004, 0.003]
    source = target - shift[:3, 3]
    m, fitness, rmse = icp_mod.icp(source, target, np.eye(4), 0.02, 50, backend)
    assert fitness > 0.95 and rmse < 0.003
    assert np.allclose(m[:3, 3], shift[:3, 3], atol=0.002)


def test_icp_backend_resolution():
    assert icp_mod.resolve_backend("numpy") == "numpy"
    assert icp_mod.resolve_backend("auto") in ("numpy", "open3d")
    with pytest.raises(ValueError):
        icp_mod.resolve_backend("nope")


def test_capped_candidates_is_seeded_subset():
    c = np.arange(100)
    a, b = capped_candidates(c, 10, 3), capped_candidates(c, 10, 3)
    assert np.array_equal(a, b) and len(a) == 10 and np.isin(a, c).all()
    assert np.array_equal(capped_candidates(c[:5], 10), c[:5])


@pytest.fixture(scope="module")
def bowl_case():
    ex = affordances.build("placing-bowl")
    tensor = affordances.build_descriptor("placing-bowl", spacing=0.02, example=ex)
    scene = it.prepare_scene(ex.scene_object, 0.02, seed=5)
    centre = np.argmin(np.linalg.norm(scene.points - tensor.reference_point, axis=1))
    low = np.argmin(scene.points[:, 2])                 # the bottom of a table leg
    return tensor, scene, np.array([centre, low])


def test_naive_accepts_the_example_place(bowl_case):
    tensor, scene, cand = bowl_case
    r = naive(scene, tensor, cand, n_orientations=2, backend="numpy")
    assert r.score.shape == (4,) and r.poses.shape == (4, 4, 4)
    assert 0 < r.threshold <= 1
    assert r.score[:2].max() >= r.score[2:].max()
    assert r.accepted[:2].any()


def test_bisector_baseline_prefers_the_example_place(bowl_case):
    tensor, scene, cand = bowl_case
    r = bisector_baseline(scene, tensor, cand, n_orientations=2, backend="numpy")
    assert r.score.shape == (4,)
    assert r.score[:2].max() > r.score[2:].max()
    # the proposed pose is the iT pose rule at the candidate
    assert np.allclose(r.poses[0], tensor.pose(scene.points[cand[0]], 0.0))
