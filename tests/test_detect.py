import os

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor.cli import main as cli
from interaction_tensor.detection.places import top_k
from interaction_tensor.detection.search import (
    Engine,
    candidate_mask,
    candidates,
    detect,
)
from interaction_tensor.engine.numba_backend import nearest_indices, score_pairs_numba
from interaction_tensor.engine.scoring import score_pairs, score_pairs_exact
from interaction_tensor.engine.torch_backend import TorchIndex, score_pairs_torch
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.geometry.grid import FAR_BLOCK, FAR_CELLS, build_grid
from interaction_tensor.geometry.scene import hot_copy

from support import corner_example, parallel_kernels_run


def moved_corner_scene(angle, shift):
    """The corner scene-object turned by ``angle`` about +Z and moved by ``shift``, on a
    larger floor, with a free-standing box elsewhere."""
    _, scene_object = corner_example()
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    v = scene_object.vertices @ rot.T + shift
    extra = parts_mesh([box_part("floor2", (shift[0] - 0.8, shift[1], shift[2] - 0.01), (0.6, 0.6, 0.02)),
                        box_part("crate", (shift[0] - 0.8, shift[1], shift[2] + 0.1), (0.2, 0.2, 0.2))])
    scene = it.Geometry(np.vstack([v, extra.vertices]),
                        np.vstack([scene_object.faces, extra.faces + len(v)]), source="moved")
    return scene, rot


@pytest.mark.parametrize("k", [2, 5])
def test_moved_copy_is_found_at_the_right_place_and_orientation(corner_tensor, k):
    angle = k * 2 * np.pi / 8
    shift = np.array([2.0, -1.0, 0.3])
    scene_geometry, rot = moved_corner_scene(angle, shift)
    scene = it.prepare_scene(scene_geometry, corner_tensor.scene_spacing, seed=3)
    result = it.detect(scene, corner_tensor, it.DetectSettings(sample_fraction=1.0, top_k=3,
                                                               oriented_normals=True))
    best = result.predictions[0]
    expected = rot @ corner_tensor.reference_point + shift
    assert np.linalg.norm(best.position - expected) < 0.03
    assert best.orientation_index == k
    # the pose puts the query box where the training box would be after the same motion
    box = corner_tensor.query_vertices
    placed = box @ best.pose[:3, :3].T + best.pose[:3, 3]
    np.testing.assert_allclose(placed, box @ rot.T + shift, atol=0.03)
    st = result.stats
    assert st["candidates_after_normal_filter"] <= st["test_points_sampled"] == len(scene)
    assert st["keypoint_comparisons"] > 0 and st["pairs_accepted"] >= 1


def test_detection_is_deterministic(corner_tensor):
    scene_geometry, _ = moved_corner_scene(0.3, np.array([0.0, 0.0, 0.0]))
    runs = []
    for _ in range(2):
        scene = it.prepare_scene(scene_geometry, 0.01, seed=5)
        r = it.detect(scene, corner_tensor, it.DetectSettings(sample_fraction=0.1, seed=9))
        runs.append(r)
    np.testing.assert_array_equal(runs[0].pairs.score, runs[1].pairs.score)
    np.testing.assert_array_equal(runs[0].candidate_indices, runs[1].candidate_indices)


def test_detection_decides_alike_in_any_number_of_threads(corner_tensor, tmp_path):
    """Numba's parallel kernels (normals, placement tests, scoring, the neighbour cache) in
    this process's threads (one each on a 2-core machine running tests in 2 workers) and
    in three, which splits their loops otherwise: the same normals, pairs and top k."""
    import subprocess
    import sys

    tensor = corner_tensor.save(tmp_path / "corner.npz")
    parallel_kernels_run(tmp_path / "here.npz", tensor)
    env = dict(os.environ, NUMBA_NUM_THREADS="3",
               PYTHONPATH=os.pathsep.join([os.path.dirname(__file__),
                                           os.environ.get("PYTHONPATH", "")]))
    code = "import sys, support; support.parallel_kernels_run(sys.argv[1], sys.argv[2])"
    subprocess.run([sys.executable, "-c", code, str(tmp_path / "threads.npz"), str(tensor)],
                   env=env, check=True, timeout=600)
    here, threads = np.load(tmp_path / "here.npz"), np.load(tmp_path / "threads.npz")
    assert sorted(here.files) == sorted(threads.files)
    assert here["mesh-False-accepted"].any() and here["cloud-False-accepted"].any()
    for name in here.files:
        assert np.array_equal(here[name], threads[name]), name


def test_candidates_without_scoring_are_detections_candidates(corner_tensor):
    """The baselines take their candidates from detect.candidates when iT does not run:
    the same seeded draw and normal filter as a detection, for either N_aff."""
    from dataclasses import replace


    scene_geometry, _ = moved_corner_scene(0.3, np.array([0.0, 0.0, 0.0]))
    scene = it.prepare_scene(scene_geometry, 0.01, seed=5)
    down = replace(corner_tensor, affordance_normal=-np.asarray(corner_tensor.affordance_normal))
    for tensor in (corner_tensor, down):
        for frac, seed in ((0.1, 9), (0.5, 2)):
            s = it.DetectSettings(sample_fraction=frac, seed=seed)
            c = candidates(scene, tensor, s)
            np.testing.assert_array_equal(c, it.detect(scene, tensor, s).candidate_indices)
            assert 0 < len(c) < frac * len(scene) + 1


@pytest.fixture(scope="module")
def scored_setup(corner_tensor):
    shift = np.array([0.5, 0.5, 0.0])
    scene_geometry, rot = moved_corner_scene(np.pi / 2, shift)
    scene = it.prepare_scene(scene_geometry, 0.01, seed=2)
    # samples anywhere, and the nearest to where the example's reference point went (pairs
    # that pass among them)
    rng = np.random.default_rng(0)
    home = rot @ corner_tensor.reference_point + shift
    near = np.argsort(np.linalg.norm(scene.points - home, axis=1))[:60]
    idx = np.union1d(rng.choice(len(scene), 200, replace=False), near)
    idx = idx[candidate_mask(scene.normals[idx], corner_tensor.affordance_normal, 15, False)]
    pp = np.repeat(idx, 8)
    po = np.tile(np.arange(8), len(idx))
    return scene, pp, po


@pytest.mark.parametrize("criterion", ["paper", "gaussian"])
@pytest.mark.parametrize("keypoints", ["weighted", "uniform"])
def test_early_exit_and_numba_decide_like_the_exact_reference(corner_tensor, scored_setup,
                                                             criterion, keypoints):
    scene, pp, po = scored_setup
    settings = it.DetectSettings(criterion=criterion, keypoints=keypoints)
    table = corner_tensor.keypoint_table(settings)
    thr = corner_tensor.threshold(criterion, keypoints)
    ref = score_pairs_exact(scene.points[pp], po, table, scene, thr)
    assert 0 < ref.accepted.sum() < len(pp)           # a real mix of decisions
    fast = score_pairs(scene.points[pp], po, table, scene, thr, early_exit=True)
    np.testing.assert_array_equal(fast.accepted, ref.accepted)
    np.testing.assert_allclose(fast.score[ref.accepted], ref.score[ref.accepted], atol=1e-9)
    assert fast.comparisons < ref.comparisons           # the early exit saved work
    assert np.all(fast.score[~ref.accepted] <= ref.score[~ref.accepted] + 1e-9)
    s, a, at, cmp = score_pairs_numba(scene.points[pp], po, table, scene.grid(), thr,
                                      corner_tensor.vectors, scene.spacing)
    np.testing.assert_array_equal(a, ref.accepted)
    np.testing.assert_allclose(s[a], ref.score[a], atol=1e-9)
    np.testing.assert_array_equal(at, fast.decided_at)
    assert np.all(at <= table.n) and np.all(at >= 1)


def test_grid_nearest_neighbour_is_exact():
    from scipy.spatial import cKDTree
    rng = np.random.default_rng(4)
    pts = rng.random((5000, 3)) * [2, 1, 0.5]
    grid = build_grid(pts, np.zeros_like(pts), 0.05)
    q = rng.random((3000, 3)) * [3, 2, 1.5] - [0.5, 0.5, 0.5]     # inside and outside
    ref = cKDTree(pts).query(q)[1]
    got = nearest_indices(grid, q)
    d_ref = np.linalg.norm(pts[ref] - q, axis=1)
    d_got = np.linalg.norm(pts[got] - q, axis=1)
    np.testing.assert_allclose(d_got, d_ref, rtol=0, atol=1e-12)


@pytest.mark.parametrize("cell", [0.02, 0.05, 0.13])
def test_far_queries_search_occupied_blocks_exactly(cell):
    """A floor, a thin pole and a small box with metres of empty space between them: queries
    far from every sample (the block search of :func:`nearest`), near ones (the shell
    search), outside the grid, on samples and on cell faces find the cKDTree's nearest."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(7)
    pts = np.r_[rng.random((3000, 3)) * [2, 2, 0],
                rng.random((300, 3)) * [0.01, 0.01, 1.5] + [1.7, 0.2, 0],
                rng.random((500, 3)) * [0.2, 0.2, 0.2] + [0.3, 1.5, 1.2]]
    grid = build_grid(pts, np.zeros_like(pts), cell)
    q = np.r_[rng.random((4000, 3)) * [4, 4, 4] - [1, 1, 1],
              pts[rng.choice(len(pts), 200)],
              grid.origin + np.round(rng.random((500, 3)) * grid.dims) * grid.cell]
    d_ref, ref = cKDTree(pts).query(q)
    assert (d_ref > FAR_CELLS * grid.cell).mean() > 0.3 and (d_ref < grid.cell).any()
    got = nearest_indices(grid, q)
    np.testing.assert_allclose(np.linalg.norm(pts[got] - q, axis=1), d_ref, rtol=0, atol=1e-12)
    # the block table: 1 exactly where a block of FAR_BLOCK^3 cells holds a sample
    blocks = -(-grid.dims // FAR_BLOCK)
    ijk = np.minimum(((grid.points - grid.origin) / grid.cell).astype(int), grid.dims - 1)
    bijk = ijk // FAR_BLOCK
    expect = np.zeros(int(np.prod(blocks)), np.int8)
    expect[(bijk[:, 0] * blocks[1] + bijk[:, 1]) * blocks[2] + bijk[:, 2]] = 1
    np.testing.assert_array_equal(grid.occ, expect)


@pytest.mark.parametrize("shuffled", [False, True])
def test_grid_tables_are_exact_and_own_their_memory(shuffled):
    """Cell starts cover each cell's points; each cell's seed is a non-empty cell at the
    least centre distance; the tables are int32 arrays of their own (a view would keep the
    distance transform's 12 bytes a cell alive)."""
    rng = np.random.default_rng(5)
    pts = rng.random((3000, 3)) * [1, 0.6, 0.05] + [0, 0, 0.3]      # a slab: many empty cells
    if not shuffled:
        pts = pts[np.lexsort(((pts[:, 2] // 0.04), (pts[:, 1] // 0.04), (pts[:, 0] // 0.04)))]
    grid = build_grid(pts, np.zeros_like(pts), 0.04)
    nx, ny, nz = (int(v) for v in grid.dims)
    n_cells = nx * ny * nz
    assert grid.starts.dtype == np.int32 and grid.seed.dtype == np.int32
    assert grid.seed.base is None and grid.seed.shape == (n_cells,)
    cell_of = np.minimum(((grid.points - grid.origin) / grid.cell).astype(int), grid.dims - 1)
    lin = (cell_of[:, 0] * ny + cell_of[:, 1]) * nz + cell_of[:, 2]
    np.testing.assert_array_equal(np.diff(grid.starts), np.bincount(lin, minlength=n_cells))
    occupied = np.flatnonzero(np.diff(grid.starts) > 0)
    ijk = np.stack(np.unravel_index(np.arange(n_cells), (nx, ny, nz)), 1)
    occ_ijk = ijk[occupied]
    best = ((ijk[:, None, :] - occ_ijk[None]) ** 2).sum(2).min(1)
    got = ((ijk - ijk[grid.seed]) ** 2).sum(1)
    assert np.all(np.diff(grid.starts)[grid.seed] > 0)
    np.testing.assert_array_equal(got, best)


def test_backends_give_the_same_detection(corner_tensor):
    scene_geometry, _ = moved_corner_scene(1.0, np.array([0.2, 0.1, 0.0]))
    scene = it.prepare_scene(scene_geometry, 0.01, seed=1)
    a = it.detect(scene, corner_tensor, it.DetectSettings(sample_fraction=0.05, backend="numpy"))
    b = it.detect(scene, corner_tensor, it.DetectSettings(sample_fraction=0.05, backend="numba"))
    np.testing.assert_array_equal(a.pairs.accepted, b.pairs.accepted)
    assert [p.point_index for p in a.predictions] == [p.point_index for p in b.predictions]


def test_normal_filter_line_and_oriented():
    n = np.array([[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, np.sin(0.2), np.cos(0.2)]], float)
    assert candidate_mask(n, [0, 0, 1], 15, False).tolist() == [True, True, False, True]
    assert candidate_mask(n, [0, 0, 1], 15, True).tolist() == [True, False, False, True]
    assert candidate_mask(n, [0, 0, 1], 10, True).tolist() == [True, False, False, False]


def test_top_k_suppression_keeps_predictions_apart(corner_tensor):
    pos = np.array([[0, 0, 0], [0.01, 0, 0], [1, 0, 0], [1.02, 0, 0], [3, 0, 0]], float)
    sc = np.array([0.9, 0.95, 0.8, 0.85, 0.1])
    assert top_k(pos, sc, 10, 0.05) == [1, 3, 4]
    assert top_k(pos, sc, 2, 0.05) == [1, 3]
    assert top_k(pos, sc, 0, 0.05) == []


def test_settings_are_validated():
    with pytest.raises(it.SettingsError):
        it.DetectSettings(sample_fraction=0)
    with pytest.raises(it.SettingsError):
        it.DetectSettings(criterion="magic")
    with pytest.raises(it.SettingsError):
        it.TrainSettings(affordance_normal=(0, 0, 0))


def test_detect_many_equals_one_at_a_time(corner_tensor):
    from support import corner_example
    q, s = corner_example()
    # a second descriptor: the same interaction with the box turned into a 'down' tensor
    other = it.InteractionTensor.fit(q, s, "corner-box-2", it.TrainSettings(query_points=2000, seed=4))
    scene_geometry, _ = moved_corner_scene(0.7, np.array([0.3, 0.2, 0.0]))
    scene = it.prepare_scene(scene_geometry, 0.01, seed=8)
    settings = it.DetectSettings(sample_fraction=0.06, seed=2)
    many = it.detect_many(scene, [corner_tensor, other], settings)
    for tensor, res in zip([corner_tensor, other], many):
        one = it.detect(scene, tensor, settings)
        np.testing.assert_array_equal(one.pairs.accepted, res.pairs.accepted)
        np.testing.assert_array_equal(one.pairs.score, res.pairs.score)
        assert [p.point_index for p in one.predictions] == [p.point_index for p in res.predictions]


def test_default_detection_keeps_the_papers_partial_scores(corner_tensor):
    """A rejected pair keeps its partial score at the rejection, which depends on the keypoint
    order: it is the paper's, weight order with early exit (the NumPy reference), whichever
    stage comes first."""
    scene_geometry, _ = moved_corner_scene(0.4, np.array([0.1, -0.2, 0.0]))
    scene = it.prepare_scene(scene_geometry, 0.01, seed=6)
    # a threshold that both accepts and rejects many of this scene's pairs
    settings = it.DetectSettings(sample_fraction=0.2,
                                 threshold=0.9 * corner_tensor.self_scores["paper-weighted"])
    det = detect(scene, corner_tensor, settings, engine=Engine(score_first=True))
    table = corner_tensor.keypoint_table(det.settings)
    ref = score_pairs(scene.points[det.pair_point], det.pair_orientation, table, scene,
                      det.threshold, vectors=corner_tensor.vectors)
    rej = ~ref.accepted
    assert rej.sum() > 10 and ref.accepted.sum() > 10
    np.testing.assert_array_equal(det.pairs.accepted, ref.accepted)
    np.testing.assert_array_equal(det.pairs.decided_at, ref.decided_at)
    np.testing.assert_allclose(det.pairs.score, ref.score, atol=1e-9)
    # tests first (the default): the pairs it scores keep the very same partial scores
    first = it.detect(scene, corner_tensor, settings)
    np.testing.assert_array_equal(first.pairs.accepted, det.pairs.accepted)
    assert first.scored.any() and not first.scored.all()
    np.testing.assert_array_equal(first.pairs.decided_at[first.scored],
                                  ref.decided_at[first.scored])
    np.testing.assert_allclose(first.pairs.score[first.scored], ref.score[first.scored],
                               atol=1e-9)


def _torch_devices():
    """``cpu`` always; ``cuda`` where PyTorch sees a GPU (run on a lent GPU machine)."""
    try:
        import torch
        cuda = torch.cuda.is_available()
    except ImportError:
        cuda = False
    return ["cpu", pytest.param("cuda", marks=pytest.mark.skipif(not cuda, reason="no CUDA"))]


def _triton_usable() -> bool:
    """Triton imports, and runs: on a CUDA device, or on the CPU under its interpreter
    (``TRITON_INTERPRET=1``, set before the tests start)."""
    try:
        import torch
        import triton  # noqa: F401
    except ImportError:
        return False
    return torch.cuda.is_available() or os.environ.get("TRITON_INTERPRET") == "1"


KERNELS = ["cdist", pytest.param("triton", marks=pytest.mark.skipif(
    not _triton_usable(), reason="no Triton, or neither CUDA nor TRITON_INTERPRET=1"))]


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("device", _torch_devices())
@pytest.mark.parametrize("criterion", ["paper", "gaussian"])
def test_torch_backend_decides_like_the_cpu_paths(corner_tensor, scored_setup, criterion, device,
                                                  kernel):
    torch = pytest.importorskip("torch")
    if kernel == "triton" and device == "cpu" and os.environ.get("TRITON_INTERPRET") != "1":
        pytest.skip("Triton on the CPU runs under TRITON_INTERPRET=1 only")
    scene, pp, po = scored_setup
    pp, po = pp[::3], po[::3]
    settings = it.DetectSettings(criterion=criterion)
    table = corner_tensor.keypoint_table(settings)
    # thresholds that accept some of these pairs and reject others
    thr = 0.9 * corner_tensor.self_scores["paper-weighted"] if criterion == "paper" else 0.5
    ref = score_pairs(scene.points[pp], po, table, scene, thr)
    assert 0 < ref.accepted.sum() < len(pp)
    # small tiles so that many queries fall back to the tree and tiles border each other
    index = TorchIndex(scene, device, tile=0.15, margin=0.03, kernel=kernel)
    assert index.kernel == kernel
    for spatial in (True, False):      # blocks in tile order and in the caller's order
        got = score_pairs_torch(scene.points[pp], po, table, index, thr, pairs_per_block=500,
                                spatial_order=spatial)
        np.testing.assert_array_equal(got.accepted, ref.accepted)
        np.testing.assert_array_equal(got.decided_at, ref.decided_at)
        np.testing.assert_allclose(got.score, ref.score, atol=1e-9)
    # the tiled nearest neighbour is exact, inside and outside the scene's box
    rng = np.random.default_rng(3)
    lo, hi = scene.points.min(0) - 0.2, scene.points.max(0) + 0.2
    q = rng.uniform(lo, hi, (4000, 3))
    d_ref = scene.tree.query(q)[0]
    asked = {}
    for levels in (1, 2):       # the coarser level proves on the device what the tree did
        index = TorchIndex(scene, device, tile=0.15, margin=0.03, levels=levels, kernel=kernel)
        nn = index.nearest(torch.as_tensor(q, device=device)).cpu().numpy()
        np.testing.assert_allclose(np.linalg.norm(scene.points[nn] - q, axis=1), d_ref,
                                   atol=1e-12)
        asked[levels] = index.tree_queries
    assert 0 < asked[2] < asked[1] < len(q)


@pytest.mark.parametrize("device", _torch_devices())
def test_torch_backend_detection_matches_numba(corner_tensor, device):
    pytest.importorskip("torch")
    scene_geometry, _ = moved_corner_scene(1.0, np.array([0.2, 0.1, 0.0]))
    scene = it.prepare_scene(scene_geometry, 0.01, seed=1)
    thr = 0.9 * corner_tensor.self_scores["paper-weighted"]     # accepts some pairs here
    a = it.detect(scene, corner_tensor, it.DetectSettings(sample_fraction=0.015, backend="torch",
                                                          device=device, threshold=thr))
    b = it.detect(scene, corner_tensor, it.DetectSettings(sample_fraction=0.015, backend="numba",
                                                          threshold=thr))
    assert a.pairs.accepted.any()
    np.testing.assert_array_equal(a.pairs.accepted, b.pairs.accepted)
    np.testing.assert_array_equal(a.pairs.decided_at, b.pairs.decided_at)
    assert [p.point_index for p in a.predictions] == [p.point_index for p in b.predictions]
    assert a.stats["backend"] == "torch" and a.stats["device"] == device


def test_torch_backend_asks_for_a_cuda_device_it_does_not_have(corner_tensor):
    torch = pytest.importorskip("torch")
    if torch.cuda.is_available():
        pytest.skip("a CUDA device is present")
    scene = it.prepare_scene(moved_corner_scene(0.0, np.zeros(3))[0], 0.02, seed=1)
    with pytest.raises(it.SettingsError, match="no CUDA device"):
        it.detect(scene, corner_tensor, it.DetectSettings(backend="torch", device="cuda"))


@pytest.mark.parametrize("n", [0, 7, 400_000])
def test_hot_copy_is_the_reordered_array(n):
    """The scene's sorted points and normals (asked for huge pages when large): exactly
    ``a[order]``, C-contiguous, of their own memory, for an empty, a small and a 9.6 MB
    array."""

    rng = np.random.default_rng(1)
    a = rng.random((n, 3))
    order = rng.permutation(n)
    got = hot_copy(a, order)
    np.testing.assert_array_equal(got, a[order])
    assert got.flags.c_contiguous and got.base is None and got.dtype == a.dtype


def test_command_line_turns_numpys_huge_pages_off():
    """The one-shot CLI process keeps NumPy's arrays on 4 kB pages (a 2 M-point detection's
    peak varied by 130 MB from run to run with huge pages); the switch is restored here
    (the glibc settings of :func:`cli._one_shot_memory` are left out: they would stay)."""

    switch = getattr(np._core.multiarray, "_set_madvise_hugepage", None)
    if switch is None:
        pytest.skip("this NumPy has no huge-page switch")
    before = switch(True)
    try:
        cli._numpy_small_pages()
        assert switch(True) is False
    finally:
        switch(before)
