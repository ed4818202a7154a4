"""Detection: candidate test points, the scoring loop, and the result.

Data flow: scene -> test points (seeded random fraction) -> normal filter against N_aff ->
placement tests of every (test point, orientation) pair -> scores of the pairs that pass
them, keypoints in weight order with early exit -> :class:`Detection` (accepted pairs, heat
map, top-k poses, statistics). ``DetectSettings.stage_order`` score-first scores every pair
first and tests those the score accepts.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .predictions import Prediction, heat_map, top_k
from .scene import Scene
from .kernels import (CACHE_BYTES, EXIT_AT_DECISION, EXIT_AT_REJECTION, EXIT_NEVER, ScoreJob,
                      score_jobs)
from .kernels import available as kernels_available
from .scoring import PairScores, all_terms, make_table, permuted, score_pairs
from .settings import DetectSettings

#: Auto neighbour cache (``DetectSettings.neighbour_cache`` None): used when at least this
#: fraction of the scene's points is tested (see :func:`cache_pays`; benchmarks/RESULTS.md).
CACHE_AUTO_FRACTION = 0.1
#: Memory of the auto neighbour cache, per scene point (bytes; at most
#: :data:`kernels.CACHE_BYTES`): past it the oldest trees are dropped and rebuilt where
#: needed. 24 keeps a 2 M-point cloud at the defaults under 250 bytes a point
#: (benchmarks/memory.py: 476 MB; 64 gave 616 MB).
CACHE_AUTO_BYTES_PER_POINT = 24
#: Least memory of the auto neighbour cache (bytes), whatever the scene's size: below it a
#: person's far keypoints make the cache drop and rebuild its trees hundreds of times
#: (sitting-human on office-desk1, 78,197 points: 24 bytes a point, 1.8 MB, scored 3.2x
#: slower than 64 MB or 512 MB, identical results; 2026-11-26, one thread, quiet machine).
CACHE_AUTO_FLOOR = 64 * 2**20

if TYPE_CHECKING:   # annotations only: descriptor imports this module to calibrate
    from .descriptor import InteractionTensor


def resolve_backend(name: str) -> str:
    """``auto`` -> ``numba`` when Numba imports, else ``numpy``."""
    from . import kernels

    if name == "auto":
        return "numba" if kernels.available() else "numpy"
    if name == "numba" and not kernels.available():
        from .errors import SettingsError

        raise SettingsError("backend 'numba' needs Numba: pip install numba")
    if name == "torch":
        from .torch_backend import import_torch

        import_torch()
    return name


def keypoint_table(tensor: InteractionTensor, settings: DetectSettings):
    """The keypoint set chosen by ``settings``, rotated for every orientation."""
    kp = tensor.keypoints(settings.keypoints)
    return make_table(kp.points - tensor.reference_point, kp.provenance, kp.weights,
                      settings.n_orientations, settings.criterion, settings.theta_max,
                      settings.c, settings.gaussian_a)


def resolve_threshold(tensor: InteractionTensor, settings: DetectSettings) -> float:
    """The acceptance threshold: the settings' own, else the descriptor's calibrated one."""
    if settings.threshold is not None:
        return float(settings.threshold)
    return tensor.threshold(settings.criterion, settings.keypoints)


def score_at(tensor: InteractionTensor, scene: Scene, positions, orientation_index,
             **overrides) -> np.ndarray:
    """Full scores (no early exit) of given placements.

    Parameters
    ----------
    positions : (P, 3) test points, metres
    orientation_index : (P,) int, orientation i means angle i * 2 pi / n_orientations
    overrides : DetectSettings fields (criterion, keypoints, n_orientations, ...)

    Returns (P,) float64 normalised scores in [0, 1].
    """
    settings = DetectSettings(**overrides).for_scene(scene)
    table = keypoint_table(tensor, settings)
    res = score_pairs(np.asarray(positions, float), np.asarray(orientation_index, int), table,
                      scene, threshold=1.0, vectors=tensor.vectors, early_exit=False)
    return res.score


def candidate_mask(normals: np.ndarray, affordance_normal: np.ndarray,
                   tolerance_deg: float, oriented: bool) -> np.ndarray:
    """(N,) bool: normals within ``tolerance_deg`` of N_aff (of its line unless oriented)."""
    dot = normals @ np.asarray(affordance_normal, float)
    if not oriented:
        dot = np.abs(dot)
    return dot >= np.cos(np.radians(tolerance_deg)) - 1e-12


@dataclass
class Detection:
    """Everything one detection run found.

    Attributes
    ----------
    scene : the Scene searched
    tensor : the descriptor used
    settings : the DetectSettings used; ``threshold`` the threshold applied
    test_indices : (T,) scene indices drawn as test points
    candidate_indices : (C,) test points that passed the normal filter
    pair_point, pair_orientation : (P,) scene index and orientation of every scored pair
    pairs : PairScores of those pairs; ``pairs.accepted`` is the final decision (score and
        placement tests)
    score_accepted : (P,) bool, accepted by the score alone (False for a pair never scored:
        ``DetectSettings.stage_order`` tests-first scores only the pairs that pass the
        placement tests, see ``scored``)
    clearance_violations : (P,) int16 (int32 past 32,767 clearance points), clearance points
        violated (-1 where not tested: score-first, pairs the score rejected; or no
        clearance test); on
        the Numba backend counted up to the first past the limit (a pair that fails the
        test holds the limit's count + 1)
    placement : (P,) int8, the outcome of the placement tests (see the attribute)
    heat : (N,) per scene point: best accepted score near it (0 where none)
    accepted_count : (N,) accepted orientations at each scene point
    predictions : top-k after suppression, best first
    stats : counts and seconds per stage
    """

    scene: Scene
    tensor: InteractionTensor
    settings: DetectSettings
    threshold: float
    test_indices: np.ndarray
    candidate_indices: np.ndarray
    pair_point: np.ndarray
    pair_orientation: np.ndarray
    pairs: PairScores
    heat: np.ndarray
    accepted_count: np.ndarray
    predictions: list = field(default_factory=list)
    stats: dict = field(default_factory=dict)
    score_accepted: np.ndarray | None = None
    clearance_violations: np.ndarray | None = None
    #: (N + 1,) the largest score keypoints k.. can still add, in the order they were
    #: compared: ``score + rest[decided_at]`` bounds a rejected pair's full score
    rest: np.ndarray | None = None
    #: (P,) int8 outcome of the placement tests: -1 not tested (score-first: the score
    #: rejected the pair; tests-first tests every pair), 0 placed, else the first test
    #: failed (1 clearance, 2 contact, 3 interior, 4 collision, ...: :mod:`.clearance`; the
    #: collision test runs on ranked pairs only)
    placement: np.ndarray | None = None
    #: the collision test of ranked pairs (:class:`CollisionCheck`), None until built
    collisions: "CollisionCheck | None" = field(default=None, repr=False)
    #: (P,) bool: pairs whose score covers every keypoint (the others hold the partial sum
    #: at their decision, ``DetectSettings.complete_scores``); None: those the score accepted
    complete: np.ndarray | None = None
    #: (P,) bool: pairs that were scored at all (``DetectSettings.stage_order``
    #: ``tests-first`` scores only the pairs that pass the placement tests; the others hold
    #: score 0, decided at 0, and ``score_accepted`` False); None: every pair
    scored: np.ndarray | None = None

    @property
    def accepted(self) -> np.ndarray:
        """Indices into the pair arrays of accepted pairs (int32 when they fit)."""
        return accepted_indices(self.pairs.accepted)

    # ------------------------------------------------------------ the top predictions as arrays
    @property
    def positions(self) -> np.ndarray:
        """(K, 3) test points of the top predictions, best first (metres)."""
        return np.array([p.position for p in self.predictions], np.float64).reshape(-1, 3)

    @property
    def scores(self) -> np.ndarray:
        """(K,) normalised scores of the top predictions, best first."""
        return np.array([p.score for p in self.predictions], np.float64)

    @property
    def orientations(self) -> np.ndarray:
        """(K,) angles (radians) about +Z of the top predictions."""
        return np.array([p.angle for p in self.predictions], np.float64)

    @property
    def orientation_indices(self) -> np.ndarray:
        """(K,) orientation indices i (angle = i * 2 pi / n_orientations)."""
        return np.array([p.orientation_index for p in self.predictions], np.int64)

    @property
    def poses(self) -> np.ndarray:
        """(K, 4, 4) rigid transforms of the training-frame query object into the scene."""
        return np.array([p.pose for p in self.predictions], np.float64).reshape(-1, 4, 4)

    def __repr__(self) -> str:
        best = f", best {self.predictions[0].score:.3f}" if self.predictions else ""
        return (f"<Detection {self.tensor.affordance!r} in {self.scene.source}: "
                f"{len(self.predictions)} predictions{best}; {int(self.pairs.accepted.sum())} of "
                f"{len(self.pair_point)} pairs accepted at threshold {self.threshold:.3f}>")

    # ------------------------------------------------------------ outputs
    def save(self, outdir, *, render: bool = False, scene_name: str | None = None,
             descriptor_name: str | None = None, also: dict | None = None) -> Path:
        """Write the result into ``outdir`` (what ``itensor detect -o`` writes), as one
        transaction: built in a temporary sibling directory and swapped in, so ``outdir``
        holds either the complete earlier result or the complete new one.

        ``predictions.json``, ``heatmap.ply`` (score as ``quality`` and ``scalar_score``),
        ``predictions.glb`` (scene heat map and posed objects, for browsers and Blender) and
        ``top/``; for a captured scene also the same in the input's own frame; with
        ``render`` also ``render.png``. ``also`` maps further file names to functions that
        write them (given the path), inside the same transaction. An existing ``outdir`` must
        be empty or hold an earlier result (and nothing else). Returns ``outdir`` as a Path.
        """
        from .io import atomic_dir
        from .predictions import OUTPUT_NAMES, export

        outdir = Path(outdir)
        t = time.perf_counter()
        report = getattr(self.scene, "report", None)
        also = dict(also or {})
        with atomic_dir(outdir, "predictions.json", OUTPUT_NAMES + tuple(also)) as tmp:
            for name, write in also.items():
                write(tmp / name)
            export(self, tmp, scene_name or (report.source if report is not None else None),
                   descriptor_name)
            if report is not None:
                from .realdata import write_input_frame_outputs

                write_input_frame_outputs(self, tmp, report.transform, report)
            self.stats["seconds"]["export"] = round(time.perf_counter() - t, 4)
            if render:
                from .viz.render import render_outdir

                render_outdir(tmp)
        return outdir

    def to_trimesh(self):
        """A ``trimesh.Scene``: the scene points coloured by the heat map (grey: nothing
        accepted near) and the query object posed at each top prediction."""
        from .predictions import result_scene

        return result_scene(self)

    def to_open3d(self) -> list:
        """Open3D geometries: the heat-map point cloud, then one posed query per prediction
        (``open3d.visualization.draw_geometries(result.to_open3d())``)."""
        from .predictions import result_open3d

        return result_open3d(self)


def accepted_indices(accepted: np.ndarray) -> np.ndarray:
    """Indices of the True entries of a per-pair mask, int32 when they fit (a 2 M-point scene
    at 30 % accepts millions of pairs)."""
    idx = np.flatnonzero(accepted)
    return idx.astype(np.int32) if len(accepted) < 2 ** 31 else idx


def suppression_radius(tensor: InteractionTensor, settings: DetectSettings) -> float:
    """Top-k suppression radius (m): the setting, else the query object's width."""
    if settings.nms_radius is not None:
        return float(settings.nms_radius)
    return float(np.ptp(tensor.query_vertices[:, :2], axis=0).max())


def _test_points(scene: Scene, settings: DetectSettings) -> np.ndarray:
    rng = np.random.default_rng(settings.seed)
    n_test = max(1, int(round(settings.sample_fraction * len(scene))))
    return np.sort(rng.choice(len(scene), size=n_test, replace=False))


def _prepare_index(scene: Scene, settings: DetectSettings):
    backend = resolve_backend(settings.backend)
    if backend == "numba":
        return backend, scene.grid()
    _ = scene.tree
    if backend == "torch":
        from .torch_backend import TorchIndex, resolve_device

        return backend, TorchIndex(scene, resolve_device(settings.device))
    return backend, None


#: Distance (m) at which :func:`pilot_order` models a lookup as costing twice one at a
#: surface (the measured profile: 2x at 2-5 cm, 6-15x at 5-12 cm).
LOOKUP_COST_SCALE = 0.03
#: The blends :func:`pilot_order` tries between ordering for acceptance (0: the largest
#: expected term first) and for rejection (1: the largest expected shortfall first).
ORDER_BLENDS = (0.0, 0.25, 0.5, 0.75, 1.0)


def simulated_cost(terms: np.ndarray, max_terms: np.ndarray, cost: np.ndarray,
                   threshold: float, order: np.ndarray, eps: float = 1e-9) -> float:
    """Summed lookup cost of deciding pairs whose every term is known (``terms`` (P, N),
    ``max_terms`` (N,), per-keypoint ``cost`` (N,)) when keypoints are compared in ``order``
    with the kernels' early exit: accepted once the running score reaches ``threshold``,
    rejected once even the largest rest cannot (``_numba_kernels._decision``)."""
    t = terms[:, order]
    run = np.cumsum(t, axis=1)
    rest = float(max_terms.sum()) - np.cumsum(max_terms[order])
    done = (run >= threshold - eps) | (run + rest[None] < threshold - eps)
    done[:, -1] = True
    at = np.argmax(done, axis=1)
    return float(np.cumsum(cost[order])[at].sum())


def pilot_order(table, scene: Scene, pair_point: np.ndarray, orient: np.ndarray, grid,
                vectors: str, n_pairs: int, seed: int, threshold: float) -> np.ndarray:
    """Keypoint order for :attr:`DetectSettings.keypoint_order` ``adaptive``.

    Scores ``n_pairs`` seeded random (test point, orientation) pairs on every keypoint, then
    replays their early exit (:func:`simulated_cost`) in candidate orders and returns the
    cheapest: the table's own (the paper's weight order) and, for each blend ``b`` of
    :data:`ORDER_BLENDS`, keypoints by ``(1 - b) * term / threshold + b * shortfall /
    (total - threshold)`` per unit of lookup cost, largest first (the mean term reached, the
    mean shortfall from the largest possible term, each as a share of what decides a pair:
    a low threshold is reached by the heavy keypoints, a high one failed by the ones that
    miss most). A lookup's cost grows with the distance ``d`` of its nearest sample (the grid
    search visits the cells of that ball): modelled as ``1 + (d / LOOKUP_COST_SCALE)**2``
    from the measured profile (benchmarks/RESULTS.md: about 330 ns within 2 cm of a surface,
    660 ns at 2-5 cm, 2-5 us beyond), averaged over the pilot's queries of each keypoint.
    Distances, not timings: the order is the same on every run. Ties go to the weight order.

    Parameters
    ----------
    pair_point : (P,) scene index of each pair's test point; orient : (P,) orientation index
    grid : the Numba grid, or None to use the scene's cKDTree
    threshold : the score that accepts a pair
    """
    if len(pair_point) == 0:
        return np.arange(table.n)
    rng = np.random.default_rng((seed, 0x1D0))
    pick = np.sort(rng.choice(len(pair_point), size=min(n_pairs, len(pair_point)), replace=False))
    found = []
    if grid is not None:
        from .kernels import nearest_indices

        def nearest(q):
            found.append((q, nearest_indices(grid, q)))
            return found[-1][1]
    else:
        def nearest(q):
            found.append((q, scene.tree.query(q, workers=-1)[1]))
            return found[-1][1]
    terms = all_terms(scene.points[pair_point[pick]], orient[pick], table, scene, vectors, nearest)
    q, idx = found[0]
    dist = np.linalg.norm(scene.points[idx] - q, axis=1).reshape(terms.shape)
    cost = (1.0 + (dist / LOOKUP_COST_SCALE) ** 2).mean(0)
    total = float(table.max_terms.sum())
    gain = terms.mean(0) / max(threshold, 1e-12)
    shortfall = (table.max_terms - terms).mean(0) / max(total - threshold, 1e-12)
    orders = [np.arange(table.n)] + [
        np.argsort(-((1 - b) * gain + b * shortfall) / cost, kind="stable")
        for b in ORDER_BLENDS]
    spent = [simulated_cost(terms, table.max_terms, cost, threshold, o) for o in orders]
    return orders[int(np.argmin(spent))]


def spatial_order(points: np.ndarray, pair_points: np.ndarray, n_o: int, grid) -> np.ndarray:
    """Candidates (runs of ``n_o`` pairs of one scene point each, as :func:`detect_many`
    makes them) in Z-order of their points over the grid's cells: (C,) int64 candidate
    numbers, stable (ties keep their order)."""
    from .kernels import _compile

    cand = pair_points[::n_o]
    q = np.ascontiguousarray(points[cand], dtype=np.float64)
    return _compile()["morton_order"](q, np.asarray(grid.origin, np.float64), float(grid.cell))


def _pairs_of(cands: np.ndarray, n_o: int) -> np.ndarray:
    """Pair indices of candidates ``cands`` (each candidate's ``n_o`` pairs, in order)."""
    return (cands[:, None] * n_o + np.arange(n_o)).ravel()


def cache_pays(settings: DetectSettings, test_fraction: float) -> bool:
    """Whether the Numba backend answers nearest neighbours from the neighbour cache:
    ``settings.neighbour_cache`` when set, else (auto) when the test points are dense
    enough that each block of space is queried many times (at least
    :data:`CACHE_AUTO_FRACTION` of the scene's points tested)."""
    if settings.neighbour_cache is not None:
        return bool(settings.neighbour_cache)
    return test_fraction >= CACHE_AUTO_FRACTION


def _score_all(scene, jobs, backend, index, settings, progress, label, use_cache=False,
               cache_bytes=CACHE_BYTES, grouped=True):
    """Score every job's pairs in candidate batches; returns per job PairScores.

    Here a job's ``points`` are scene indices, gathered batch by batch to bound memory;
    ``grouped``: they come in runs of ``n_orientations`` pairs of one candidate each (else
    any pairs, ordered one by one);
    ``index`` is the backend's search structure (Numba grid, TorchIndex, or None for cKDTree);
    ``use_cache``: the Numba backend's neighbour cache (see :func:`cache_pays`), of at most
    ``cache_bytes`` bytes.
    """
    n_o = settings.n_orientations
    step = settings.batch_size * n_o
    totals = [np.zeros(len(j.points)) for j in jobs]
    acc = [np.zeros(len(j.points), bool) for j in jobs]
    at = [np.zeros(len(j.points), np.int32) for j in jobs]
    cmp_ = [0] * len(jobs)
    longest = max((len(j.points) for j in jobs), default=0)
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=longest // n_o, unit="pt", desc=f"detect {label}", leave=False)
    # Numba: candidates in Z-order, so that a batch's keypoints stay in a compact region and
    # consecutive batches overlap (the neighbour cache is built once where they go)
    run = n_o if grouped else 1
    zorder = ([spatial_order(scene.points, j.points, run, index) for j in jobs]
              if backend == "numba" else None)
    for start in range(0, longest, step):
        sl = slice(start, start + step)
        if backend == "numba":
            picks = [_pairs_of(z[start // run:(start + step) // run], run) for z in zorder]
            batch = [ScoreJob(scene.points[j.points[pk]], j.orient[pk], j.table, j.threshold,
                              j.vectors, j.rho, j.early_exit,
                              None if j.resume_at is None else j.resume_score[pk],
                              None if j.resume_at is None else j.resume_at[pk])
                     for j, pk in zip(jobs, picks)]
            for i, (s, a, d, c) in enumerate(score_jobs(batch, index, use_cache, cache_bytes)):
                totals[i][picks[i]], acc[i][picks[i]], at[i][picks[i]] = s, a, d
                cmp_[i] += int(c.sum())
        else:
            for i, j in enumerate(jobs):
                if start >= len(j.points):
                    continue
                if backend == "torch":
                    from .torch_backend import score_pairs_torch

                    res = score_pairs_torch(scene.points[j.points[sl]], j.orient[sl], j.table,
                                            index, j.threshold, j.vectors, j.early_exit)
                else:
                    res = score_pairs(scene.points[j.points[sl]], j.orient[sl], j.table, scene,
                                      j.threshold, vectors=j.vectors, early_exit=j.early_exit)
                totals[i][sl], acc[i][sl], at[i][sl] = res.score, res.accepted, res.decided_at
                cmp_[i] += res.comparisons
        if bar is not None:
            bar.update(min(step, longest - start) // n_o)
    if bar is not None:
        bar.close()
    return [PairScores(t, a, d, c) for t, a, d, c in zip(totals, acc, at, cmp_)]


class CollisionCheck:
    """Detection's exact collision tests of ranked pairs (``DetectSettings.collision``).

    A pair is posed (the descriptor's :meth:`~.InteractionTensor.pose`) and tested against
    the scene's mesh with python-fcl. It passes when, for each of the descriptor's
    :attr:`~.InteractionTensor.collision_tests`, its tested query triangles do not cross the
    scene's or a move of that test's depth in one of 26 directions frees them
    (:meth:`.MeshCollider.separation`), and, where the descriptor asks for it
    (:attr:`~.InteractionTensor.through`), the scene crosses the posed section of what went
    through the query in the example (a rail through the hook). Each pair is tested at most
    once (``state``: -1 untested, 0 passes, 1 fails); a pair that fails loses its acceptance
    (``placement`` :data:`.clearance.FAILS_COLLISION`). At most
    ``settings.collision_max_tests`` pairs are tested; :meth:`free` answers None once they
    are spent.
    """

    def __init__(self, det: "Detection"):
        self.det = det
        st, tensor, scene = det.settings, det.tensor, det.scene
        self.reason = None
        if not st.collision:
            self.reason = "off (settings)"
        elif not tensor.collision_tests and not tensor.through:
            self.reason = "off (the descriptor has no collision test)"
        elif getattr(scene, "mesh", None) is None:
            self.reason = "off (the scene has no triangles)"
        elif not tensor.collision_bodies() and tensor.through_body() is None:
            self.reason = "off (no query triangles to test)"
        self.on = self.reason is None
        if not self.on:
            self.through = self.reason
        elif not tensor.through:
            self.through = "off (the descriptor does not ask for it)"
        elif tensor.through_body() is None:
            self.through = "off (the example had nothing through the query)"
        else:
            self.through = "on"
        self.state = np.full(len(det.pair_point), -1, np.int8) if self.on else None
        self.tests = 0
        self.failed_through = 0
        self.seconds = 0.0
        self.exhausted = False

    def free(self, i: int):
        """Whether pair ``i`` passes the tests: True, False, or None when it is not tested
        because the tests allowed are spent (or the test is off: True)."""
        if not self.on:
            return True
        if self.state[i] >= 0:
            return bool(self.state[i] == 0)
        det = self.det
        if self.tests >= det.settings.collision_max_tests:
            self.exhausted = True
            return None
        t = time.perf_counter()
        tensor = det.tensor
        pose = tensor.pose(det.scene.points[det.pair_point[i]],
                           2 * np.pi * int(det.pair_orientation[i]) / det.settings.n_orientations)
        collider = det.scene.collider()
        through = tensor.through_body()
        ok = through is None or collider.collides(through, pose)
        if not ok:
            self.failed_through += 1
        # a captured surface's own noise is allowed on top of each test's depth
        noise = float(getattr(det.scene, "surface_noise", 0.0))
        for body, depth in tensor.collision_bodies() if ok else ():
            if collider.separation(body, pose, limit=depth + noise) > depth + noise:
                ok = False
                break
        self.tests += 1
        self.state[i] = 0 if ok else 1
        if not ok:
            from .clearance import FAILS_COLLISION, PLACED

            det.pairs.accepted[i] = False
            if det.placement is not None and det.placement[i] == PLACED:
                det.placement[i] = FAILS_COLLISION
        self.seconds += time.perf_counter() - t
        return ok

    def stats(self) -> dict:
        """What the test did, for ``Detection.stats``."""
        return {"collision_test": "on" if self.on else self.reason,
                "collision_tests": self.tests,
                "pairs_failing_collision": int((self.state == 1).sum()) if self.on else 0,
                "through_test": self.through,
                "pairs_with_nothing_through": self.failed_through,
                "collision_tests_exhausted": self.exhausted}


def collision_check(det: "Detection") -> CollisionCheck:
    """The detection's :class:`CollisionCheck` (built on first use, shared by its rankings)."""
    if det.collisions is None:
        det.collisions = CollisionCheck(det)
    return det.collisions


def check_clearance(scene, tensor, settings: DetectSettings, pair_point, pair_orient,
                    pairs: PairScores, grid=None):
    """Apply the placement tests (clearance, contact, interior: :mod:`.clearance`) to the
    pairs the score accepted (in place on ``pairs.accepted``). Returns (score_accepted (P,)
    bool, clearance violations (P,) int, -1 where not tested, outcome (P,) int8: -1 where
    not tested, else :data:`.clearance.PLACED` or the first test failed)."""
    from .clearance import PLACED

    score_acc = pairs.accepted.copy()
    idx = np.flatnonzero(score_acc)
    viol, outcome = test_all(scene, tensor, settings, pair_point, pair_orient, grid, idx)
    pairs.accepted[idx[outcome[idx] != PLACED]] = False
    return score_acc, viol, outcome


def test_all(scene, tensor, settings: DetectSettings, pair_point, pair_orient, grid=None,
             idx=None):
    """The placement tests (:func:`.clearance.check_placements`) of pairs ``idx`` (default:
    every pair, before any score: ``DetectSettings.stage_order`` ``tests-first``). Returns
    (clearance violations (P,) int, -1 where not tested or the clearance test is off;
    outcome (P,) int8: -1 where not tested, else :data:`.clearance.PLACED` or the first
    test failed)."""
    from .clearance import UNTESTED, check_placements

    k = len(tensor.clearance_points)
    n = len(pair_point)
    viol = np.full(n, -1, np.int16 if k < 2 ** 15 else np.int32)
    outcome = np.full(n, UNTESTED, np.int8)
    step = 262_144                                  # bounds the gathered positions
    for s in range(0, n if idx is None else len(idx), step):
        sl = slice(s, s + step) if idx is None else idx[s:s + step]
        v, outcome[sl] = check_placements(scene.points[pair_point[sl]],
                                          np.asarray(pair_orient[sl], np.int64), tensor,
                                          settings, scene, grid)
        if settings.clearance and k:
            viol[sl] = v
    return viol, outcome


def _finish(scene, tensor, settings, threshold, test_idx, cand, pair_point, pair_orient,
            pairs, timings, backend, t0, device="cpu", clearance=None, rest=None,
            complete=None, scored=None) -> Detection:
    """Top-k with suppression (placements that reach it tested for collision), heat map,
    statistics."""
    score_acc, viol, outcome = (clearance if clearance is not None
                                else (pairs.accepted.copy(), None, None))
    det = Detection(scene, tensor, settings, threshold, test_idx, cand, pair_point,
                    pair_orient, pairs, None, None, [], {}, score_acc, viol, rest, outcome,
                    complete=complete, scored=scored)
    n_o = settings.n_orientations
    t3 = time.perf_counter()
    radius = suppression_radius(tensor, settings)
    acc = accepted_indices(pairs.accepted)
    check = collision_check(det)
    picks = top_k(scene.points, pairs.score[acc], settings.top_k, radius,
                  index=pair_point[acc],
                  accept=(lambda i: check.free(int(acc[i]))) if check.on else None)
    for i in picks:
        o, p = int(pair_orient[acc[i]]), int(pair_point[acc[i]])
        angle = 2 * np.pi * o / n_o
        det.predictions.append(Prediction(position=scene.points[p].copy(), orientation_index=o,
                                          angle=float(angle), score=float(pairs.score[acc[i]]),
                                          pose=tensor.pose(scene.points[p], angle),
                                          point_index=p))
    timings["collision"] = check.seconds
    det.heat, det.accepted_count = heat_map(scene, pair_point, pairs.score, pairs.accepted)
    timings["predictions"] = time.perf_counter() - t3
    timings["total"] = time.perf_counter() - t0
    decided = pairs.decided_at if scored is None else pairs.decided_at[scored]
    acc_scored = pairs.accepted if scored is None else pairs.accepted[scored]
    from .clearance import (FAILS_CLEARANCE, FAILS_CONTACT, FAILS_FEET, FAILS_GROUND,
                            FAILS_INTERIOR, FAILS_MOUNT, FAILS_STRADDLE, FAILS_THROUGH)

    def failing(code):
        return int((outcome == code).sum()) if outcome is not None else 0
    scoring_s = timings.get("scoring", 0) + timings.get("completion", 0)
    # every pair decided: scored (to its decision, the placed ones completed) and tested
    deciding_s = scoring_s + timings.get("clearance", 0)
    det.stats.update({
        "scene_points": int(len(scene)),
        "scene_notes": list(getattr(scene, "notes", [])),
        "test_points_sampled": int(len(test_idx)),
        "candidates_after_normal_filter": int(len(cand)),
        "stage_order": "tests-first" if scored is not None else "score-first",
        # (point, orientation) pairs decided; of them scored (tests-first: those that
        # passed the placement tests) and given the placement tests (score-first: those
        # the score accepted)
        "pairs": int(len(pair_point)),
        "pairs_scored": int(len(pair_point) if scored is None else scored.sum()),
        "pairs_tested": int(len(pair_point) if scored is not None
                            else (outcome != -1).sum() if outcome is not None else 0),
        "pairs_accepted": int(pairs.accepted.sum()),
        "pairs_accepted_by_score": int(score_acc.sum()),
        "pairs_failing_clearance": failing(FAILS_CLEARANCE),
        "pairs_failing_contact": failing(FAILS_CONTACT),
        "pairs_failing_interior": failing(FAILS_INTERIOR),
        "pairs_failing_ground": failing(FAILS_GROUND),
        "pairs_failing_feet": failing(FAILS_FEET),
        "pairs_failing_straddle": failing(FAILS_STRADDLE),
        "pairs_failing_mount": failing(FAILS_MOUNT),
        "pairs_failing_through": failing(FAILS_THROUGH),
        **check.stats(),
        "keypoint_comparisons": int(pairs.comparisons),
        "keypoint_comparisons_to_decision": int(decided.sum()),
        "mean_comparisons_per_decision": float(decided.mean()) if len(decided) else 0.0,
        "mean_comparisons_to_accept": (float(decided[acc_scored].mean())
                                       if acc_scored.any() else None),
        "mean_comparisons_to_reject": (float(decided[~acc_scored].mean())
                                       if (~acc_scored).any() else None),
        "threshold": threshold,
        "backend": backend,
        "device": device,
        "keypoint_order": settings.keypoint_order,
        "seconds": {k: round(v, 4) for k, v in timings.items()},
        "pairs_completed": int(complete.sum()) if complete is not None else None,
        # the scoring stage: the decisions, then the placed pairs' scores completed
        "scoring_seconds": round(scoring_s, 4),
        # the scoring stage and the placement tests: every pair's final decision
        "deciding_seconds": round(deciding_s, 4),
        # rates count the work done: candidates (test points past the normal filter, all
        # orientations decided by the score and the placement tests, the placed pairs'
        # scores complete) and (point, orientation) pairs decided, never sampled points;
        # over the time of both stages (since 2026-11-27: tests-first scores only the pairs
        # the tests pass, so the scoring stage alone decides only those)
        "candidates_per_second": (float(len(cand) / deciding_s) if deciding_s > 0 else None),
        "pairs_per_second": (float(len(pair_point) / deciding_s) if deciding_s > 0 else None),
    })
    return det


def _filtered(scene: Scene, tensor, settings: DetectSettings, test_idx) -> np.ndarray:
    """The test points whose normal passes the tensor's N_aff filter."""
    ok = candidate_mask(scene.normals[test_idx], tensor.affordance_normal,
                        settings.normal_tolerance_deg, settings.oriented_normals)
    return test_idx[ok]


def candidates(scene: Scene, tensor, settings: DetectSettings | None = None) -> np.ndarray:
    """The candidates :func:`detect` would score for ``tensor``, without scoring them: the
    seeded draw of test points, then the normal filter (scene indices, sorted). The
    baselines of ``itensor evaluate`` take theirs from here when iT does not run."""
    settings = (settings or DetectSettings()).for_scene(scene)
    return _filtered(scene, tensor, settings, _test_points(scene, settings))


def detect_many(scene: Scene, tensors: list, settings: DetectSettings | None = None,
                progress: bool = False, test_indices=None) -> list:
    """Detect several interactions in one pass over a scene.

    The test points and the scene index are shared by all descriptors; each gets its own
    candidates (its N_aff), threshold and :class:`Detection`, identical to what
    :func:`detect` gives for it alone. ``test_indices`` (scene indices) replaces the seeded
    random draw of ``settings.sample_fraction``.
    """
    settings = (settings or DetectSettings()).for_scene(scene)
    t0 = time.perf_counter()
    timings = {}
    if test_indices is None:
        test_idx = _test_points(scene, settings)
    else:
        test_idx = np.unique(np.asarray(test_indices, np.int64))
        if len(test_idx) and (test_idx[0] < 0 or test_idx[-1] >= len(scene)):
            raise ValueError("test_indices must be indices of the scene's points")
    n_o = settings.n_orientations
    cands, jobs, pp_list, po_list = [], [], [], []
    for tensor in tensors:
        cand = _filtered(scene, tensor, settings, test_idx)
        # compact pair arrays (a 2 M-point scene at 30 % has millions of pairs): int32 point
        # and int16 orientation indices, widened where a kernel needs int64
        pp = np.repeat(cand.astype(np.int32 if len(scene) < 2 ** 31 else np.int64), n_o)
        po = np.tile(np.arange(n_o, dtype=np.int16 if n_o < 2 ** 15 else np.int64), len(cand))
        cands.append(cand)
        pp_list.append(pp)
        po_list.append(po)
        jobs.append(ScoreJob(pp, po, keypoint_table(tensor, settings),   # points: indices
                             resolve_threshold(tensor, settings), tensor.vectors,
                             scene.spacing, settings.early_exit))
    timings["candidates"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    backend, index = _prepare_index(scene, settings)
    tests_first = settings.tests_first
    # score-first: the Numba kernels stop every pair at its decision; the pairs that pass
    # the placement tests are scored in full afterwards (DetectSettings.complete_scores).
    # tests-first: only the pairs that passed the tests are scored, accepted ones in full
    decide_first = (not tests_first and settings.early_exit
                    and settings.complete_scores == "placed" and backend == "numba")
    for job in jobs:
        job.early_exit = (EXIT_AT_DECISION if decide_first
                          else EXIT_AT_REJECTION if settings.early_exit else EXIT_NEVER)
    timings["index"] = time.perf_counter() - t1
    # the placement tests on the Numba grid where Numba imports, whichever backend scores
    # (exact either way: the cKDTree is their reference); the torch backend's tests ran on
    # the cKDTree before, slower than its scoring on a GPU
    grid = (index if backend == "numba"
            else scene.grid() if backend == "torch" and kernels_available() else None)
    scored = [None] * len(jobs)
    if tests_first:
        t3 = time.perf_counter()
        tested = [test_all(scene, tensor, settings, pp, po, grid)
                  for tensor, pp, po in zip(tensors, pp_list, po_list)]
        timings["clearance"] = time.perf_counter() - t3
        from .clearance import PLACED

        scored = [outcome == PLACED for _, outcome in tested]
        keep = [np.flatnonzero(m) for m in scored]
        full_jobs = jobs
        jobs = [ScoreJob(job.points[i], job.orient[i], job.table, job.threshold, job.vectors,
                         job.rho, job.early_exit) for job, i in zip(jobs, keep)]
    if settings.keypoint_order == "adaptive":
        t1 = time.perf_counter()
        for job in jobs:
            order = pilot_order(job.table, scene, job.points, job.orient,
                                index if backend == "numba" else None,
                                job.vectors, settings.pilot_pairs, settings.seed,
                                job.threshold)
            job.table = permuted(job.table, order)
        timings["keypoint_order"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    label = tensors[0].affordance if len(tensors) == 1 else f"{len(tensors)} affordances"
    use_cache = backend == "numba" and cache_pays(settings, len(test_idx) / max(len(scene), 1))
    auto = settings.neighbour_cache is None
    budget = (min(CACHE_BYTES, max(CACHE_AUTO_FLOOR, CACHE_AUTO_BYTES_PER_POINT * len(scene)))
              if auto else CACHE_BYTES)
    scores = _score_all(scene, jobs, backend, index, settings, progress, label, use_cache,
                        budget, grouped=not tests_first)
    if use_cache and auto:
        # auto: its memory goes back after the scoring, before score-first's placement
        # tests (the completion builds what it needs again: 581 MB peak against 744 MB
        # kept, a 2 M-point cloud, benchmarks/memory.py) and export
        index.cache = None
    timings["scoring"] = time.perf_counter() - t2
    if tests_first:
        # back to every pair: those that failed a test were never scored; the accepted ones
        # were scored in full (stopped only at a rejection)
        scores = [_scattered(pairs, m, i) for pairs, m, i in zip(scores, scored, keep)]
        clear = [(pairs.accepted.copy(), viol, outcome)
                 for pairs, (viol, outcome) in zip(scores, tested)]
        complete = [pairs.accepted.copy() if settings.early_exit else m.copy()
                    for pairs, m in zip(scores, scored)]
        for full, sub in zip(full_jobs, jobs):
            full.table = sub.table                # the keypoint order the scores used
        jobs = full_jobs
    else:
        t3 = time.perf_counter()
        clear = [check_clearance(scene, tensor, settings, pp, po, pairs, grid)
                 for tensor, pp, po, pairs in zip(tensors, pp_list, po_list, scores)]
        timings["clearance"] = time.perf_counter() - t3
        if decide_first:
            t4 = time.perf_counter()
            complete = _complete_placed(scene, jobs, scores, backend, index, settings,
                                        progress, label, use_cache, budget)
            if use_cache and auto:
                index.cache = None
            timings["completion"] = time.perf_counter() - t4
        elif settings.early_exit:
            complete = [cl[0].copy() for cl in clear]            # accepted by the score
        else:
            complete = [np.ones(len(pp), bool) for pp in pp_list]
    device = str(index.device) if backend == "torch" else "cpu"
    return [_finish(scene, tensor, settings, job.threshold, test_idx, cand, pp, po, pairs,
                    dict(timings), backend, t0, device, cl, job.table.rest, cm, sc)
            for tensor, job, cand, pp, po, pairs, cl, cm, sc in zip(
                tensors, jobs, cands, pp_list, po_list, scores, clear, complete, scored)]


def _scattered(pairs: PairScores, scored: np.ndarray, idx: np.ndarray) -> PairScores:
    """PairScores of every pair from those of the scored pairs ``idx`` (``scored`` their
    (P,) mask): the others hold score 0, not accepted, decided at 0."""
    score = np.zeros(len(scored))
    score[idx] = pairs.score
    accepted = np.zeros(len(scored), bool)
    accepted[idx] = pairs.accepted
    at = np.zeros(len(scored), np.asarray(pairs.decided_at).dtype)
    at[idx] = pairs.decided_at
    return PairScores(score, accepted, at, pairs.comparisons)


def _complete_placed(scene, jobs, scores, backend, index, settings, progress, label,
                     use_cache, budget) -> list:
    """Complete the scores of the pairs that passed the placement tests: each goes on from
    its decision (where it stopped) over the rest of the keypoints, in place on
    ``scores``; returns per job the (P,) bool mask of complete scores. The same kernel,
    keypoint order and running sum as a pair the score accepted gets with
    ``complete_scores='accepted'``: the scores are bit for bit those."""
    idx = [np.flatnonzero(pairs.accepted) for pairs in scores]
    subs = [ScoreJob(job.points[i], job.orient[i], job.table, job.threshold, job.vectors,
                     job.rho, EXIT_AT_REJECTION, pairs.score[i], pairs.decided_at[i])
            for job, i, pairs in zip(jobs, idx, scores)]
    again = _score_all(scene, subs, backend, index, settings, progress,
                       f"complete {label}", use_cache, budget, grouped=False)
    out = []
    for pairs, i, res in zip(scores, idx, again):
        pairs.score[i] = res.score
        pairs.comparisons += res.comparisons
        done = np.zeros(len(pairs.score), bool)
        done[i] = True
        out.append(done)
    return out


def _complete_mask(det: Detection) -> np.ndarray:
    """(P,) bool: the pairs of ``det`` whose score covers every keypoint."""
    if det.complete is not None:
        return det.complete
    return det.score_accepted if det.score_accepted is not None else det.pairs.accepted


def complete_scores(det: Detection, idx: np.ndarray) -> None:
    """Score pairs ``idx`` of ``det`` over every keypoint where they stopped at their
    decision, in place (``det.pairs.score``, ``det.complete``)."""
    idx = np.asarray(idx, np.int64)
    todo = idx[~_complete_mask(det)[idx]]
    for s in range(0, len(todo), 262_144):                # bounds the gathered positions
        sl = todo[s:s + 262_144]
        det.pairs.score[sl] = full_scores(det, sl)[0]
    if det.complete is None:
        det.complete = _complete_mask(det).copy()
    det.complete[todo] = True


def full_scores(det: Detection, idx: np.ndarray):
    """Full scores (every keypoint) and clearance of pairs ``idx`` of a detection.

    Returns (scores (I,) float64, placed (I,) bool: the pair passes the placement tests,
    clearance, contact and interior). Complete scores (``Detection.complete``: the pairs
    that passed the placement tests, or every pair the score accepted) are read off; the
    others are scored again without early exit.
    """
    idx = np.asarray(idx, np.int64)
    st = det.settings
    scores = det.pairs.score[idx].copy()
    redo = ~_complete_mask(det)[idx]
    if redo.any():
        sub = idx[redo]
        table = keypoint_table(det.tensor, st)
        pts = det.scene.points[det.pair_point[sub]]
        orient = det.pair_orientation[sub]
        if resolve_backend(st.backend) == "numba":
            from .kernels import score_pairs_numba

            scores[redo] = score_pairs_numba(pts, orient, table, det.scene.grid(), 2.0,
                                             det.tensor.vectors, det.scene.spacing,
                                             early_exit=False, cache=st.neighbour_cache)[0]
        else:
            scores[redo] = score_pairs(pts, orient, table, det.scene, 2.0,
                                       vectors=det.tensor.vectors, early_exit=False).score
    from .clearance import PLACED, UNTESTED, check_placements

    outcome = (det.placement[idx].copy() if det.placement is not None
               else np.full(len(idx), UNTESTED, np.int8))
    todo = outcome == UNTESTED
    if todo.any():
        grid = det.scene.grid() if resolve_backend(st.backend) == "numba" else None
        outcome[todo] = check_placements(det.scene.points[det.pair_point[idx[todo]]],
                                         np.asarray(det.pair_orientation[idx[todo]], np.int64),
                                         det.tensor, st, det.scene, grid)[1]
    return scores, outcome == PLACED


def ranked_with_check(pos, key, full, ok, crossed, have, check, k: int, radius: float) -> list:
    """The top ``k`` of pairs ``have`` by ``key``, ``radius`` apart, asking ``check`` (a
    :class:`CollisionCheck` or a view of one) about each pair that would enter: ``key`` is
    2 + ``full`` for a pair that passed the placement tests (``ok``), ``full`` for the others,
    by pair index. A pair that crosses the scene is re-keyed below every other
    (``full`` - 2, ``crossed`` set); one that passed the placement tests but could not be
    tested (the tests are spent) ranks with those that failed them (``ok`` cleared), and once
    the tests are spent so do all such untested pairs; the top is then taken again until
    nothing moves. ``key``, ``ok`` and ``crossed`` are updated in place. Returns pair
    indices, best first (:func:`rank_pairs`, and the tuning's ranking of the same pairs)."""
    from .predictions import top_k

    demoted = []                              # pairs whose key one pass of top_k lowered

    def collision_free(j):
        i = have[j]
        if crossed[i]:
            return True
        free = check.free(i)
        if free or (free is None and not ok[i]):
            return True
        ok[i], key[i] = False, full[i] - (2.0 if free is False else 0.0)
        crossed[i] = free is False
        demoted.append(i)
        return False

    while True:
        demoted.clear()
        out = [int(have[i]) for i in top_k(pos[have], key[have], k, radius,
                                           accept=collision_free if check.on else None)]
        if check.exhausted:                   # untested pairs cannot be confirmed
            lost = have[ok[have] & (check.state[have] < 0)]
            ok[lost], key[lost] = False, full[lost]
            demoted.extend(lost)
        if not demoted:
            return out


def rank_pairs(det: Detection, k: int, radius: float, worst: bool = False, block: int = 2048,
               max_evaluations: int = 50_000):
    """The ``k`` best (or worst) pairs of a detection by full score, ``radius`` apart.

    Best: pairs that pass the placement tests rank before those that do not, then by full
    score; a pair that would enter the k is tested for collision first
    (:class:`CollisionCheck`, when it applies): one that crosses the scene ranks below every
    other pair, one that passed the other tests but could not be tested (the tests allowed
    are spent) with those that failed them. Worst: by full score alone (lowest first).
    Accepted pairs were completed (those that failed a placement test are completed first,
    :func:`complete_scores`) and given their placement tests, so they rank from the
    start. Rejected pairs kept only a partial score; their full score lies between it and
    ``score + rest[decided_at]``, so they are scored fully in the order of those bounds
    until no unscored pair can enter the k (branch and bound: exact, up to
    ``max_evaluations`` pairs scored again; past that, the best of the accepted pairs and
    the rejected pairs scored, which are those of the highest bounds and, among equal
    bounds, of the highest partial scores).

    With ``DetectSettings.stage_order`` tests-first the pairs that failed a test were never
    scored, so a ranking that reaches into them scores more of them again, and past
    ``max_evaluations`` keeps other pairs than after score-first with every accepted pair
    completed (``complete_scores='accepted'``, what ``itensor evaluate`` asks for).

    Returns (indices into the pair arrays (<= k,), full scores, clearance_ok), best first
    (worst first when ``worst``).
    """
    from .predictions import top_k

    n = len(det.pairs.score)
    if n == 0 or k <= 0:
        return np.zeros(0, np.int64), np.zeros(0), np.zeros(0, bool)
    # pairs the score accepted and that failed a placement test stopped at their decision
    # (complete_scores='placed'): scored in full first, so that they rank from the start as
    # when every accepted pair was completed (exactly the same ranking)
    accepted = det.score_accepted if det.score_accepted is not None else det.pairs.accepted
    complete_scores(det, np.flatnonzero(accepted & ~_complete_mask(det)))
    score = det.pairs.score
    done = _complete_mask(det) & accepted
    rest = det.rest if det.rest is not None else keypoint_table(det.tensor, det.settings).rest
    upper = np.where(done, score, score + rest[det.pairs.decided_at])
    key = np.full(n, np.nan)
    full = np.full(n, np.nan)
    okv = np.zeros(n, bool)
    # a pair the score accepted was completed, and detection gave it its placement tests:
    # its key is known without scoring it again, so it ranks from the start (scoring them in
    # the order of their scores spent the evaluations allowed on pairs that failed their
    # tests: hanging-handbag in office-desk6 never reached 47,872 of its placed pairs)
    from .clearance import PLACED, UNTESTED

    known = np.zeros(n, bool)
    if det.placement is not None:
        known = done & (det.placement != UNTESTED)
        okv[known] = det.placement[known] == PLACED
    full[known] = score[known]
    key[known] = -full[known] if worst else np.where(okv[known], 2.0, 0.0) + full[known]
    # optimistic key of a pair not scored yet: the key is (2 if it passes the placement
    # tests) + full score for the best, -full score for the worst. Pairs of equal bound are
    # scored best partial score first (for the worst, lowest): a run that accepted nothing
    # rejected every pair where its bound fell just below the threshold, so the bounds of
    # all its pairs are equal and only the partial scores tell the promising ones
    # (a pair known to fail a test, as every one tests-first did not score, gets no 2)
    may_place = (np.ones(n, bool) if det.placement is None
                 else (det.placement == PLACED) | (det.placement == UNTESTED))
    bound = -score if worst else upper + np.where(may_place, 2.0, 0.0)
    left = np.flatnonzero(~known)
    order = left[np.lexsort(((score if worst else -score)[left], -bound[left]))]
    m = len(order)
    pos = det.scene.points[det.pair_point]
    check = None if worst else collision_check(det)
    have = np.zeros(0, np.int64)
    crossed = np.zeros(n, bool)               # pairs already ranked below every other

    def ranked():
        return ranked_with_check(pos, key, full, okv, crossed, have, check, k, radius)

    cursor = 0
    picks = []
    while True:
        if cursor < m and cursor < max_evaluations:
            sl = order[cursor:cursor + block]
            cursor += len(sl)
            f, ok = full_scores(det, sl)
            full[sl], okv[sl] = f, ok
            key[sl] = -f if worst else np.where(ok, 2.0, 0.0) + f
        have = np.flatnonzero(np.isfinite(key))
        picks = ([int(have[i]) for i in top_k(pos[have], key[have], k, radius)] if worst
                 else ranked())
        if cursor >= m or cursor >= max_evaluations:
            break
        if len(picks) == k and key[picks[-1]] >= bound[order[cursor]]:
            break
    picks = np.asarray(picks, np.int64)
    return picks, full[picks], okv[picks]


def detect(scene: Scene, tensor: InteractionTensor, settings: DetectSettings | None = None,
           progress: bool = False, test_indices=None) -> Detection:
    """Find where the interaction of ``tensor`` can happen in ``scene``.

    Parameters
    ----------
    scene : prepared scene (see :func:`interaction_tensor.scene.prepare_scene`)
    tensor : a fitted or loaded InteractionTensor
    settings : DetectSettings (defaults if None)
    progress : show a progress bar over candidate batches
    test_indices : scene indices to test instead of a random ``sample_fraction`` of them
    """
    return detect_many(scene, [tensor], settings, progress, test_indices)[0]
