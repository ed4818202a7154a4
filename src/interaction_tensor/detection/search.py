"""The search: test points, placement tests, scores, and a :class:`Detection` per descriptor.

Data flow: scene -> test points (a seeded random fraction) -> normal filter against N_aff ->
placement tests of every (test point, orientation) pair -> scores of the pairs that pass them,
keypoints in weight order with early exit -> :class:`~.result.Detection` (accepted pairs, heat
map, top-k poses, statistics).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from interaction_tensor.descriptor.tensor import InteractionTensor
from interaction_tensor.detection.places import (
    group_places,
    heat_map,
    place_cell,
    top_k,
)
from interaction_tensor.detection.ranking import collision_check
from interaction_tensor.detection.result import Detection, accepted_indices
from interaction_tensor.engine.backends import (await_cache_kernels, cache_budget, cache_pays,
                                                open_backend, prefetch_cache_kernels)
from interaction_tensor.engine.scoring import (
    EXIT_AT_REJECTION,
    EXIT_NEVER,
    PairScores,
    ScoreJob,
    score_pairs,
)
from interaction_tensor.errors import InputError
from interaction_tensor.geometry.scene import MAX_PAIRS, Scene
from interaction_tensor.placement.checks import (
    FAILS_CLEARANCE,
    FAILS_CONTACT,
    FAILS_FEET,
    FAILS_GROUND,
    FAILS_INTERIOR,
    FAILS_MOUNT,
    FAILS_STRADDLE,
    FAILS_TAP,
    FAILS_THROUGH,
    PLACED,
    UNTESTED,
    check_placements,
)
from interaction_tensor.settings import DetectSettings


@dataclass(frozen=True)
class Engine:
    """How the search does its work: choices that change the work and what it leaves behind
    for pairs that were not accepted, never a decision, an accepted score or a prediction.

    Attributes
    ----------
    early_exit : stop comparing a pair's keypoints once it is rejected (paper, 4.2.1)
    score_first : score every pair first (the accepted ones over every keypoint) and give the
        placement tests to those the score accepts; by default the tests come first and only
        the pairs that pass them are scored. Score-first keeps the partial score of every
        pair, which a ranking of rejected pairs (the evaluation's worst 5) starts from.
    neighbour_cache : the Numba backend's neighbour cache: None where the test points are
        dense and its kernels are compiled or worth compiling (``cache_pays``; dropped after
        the search), True always (kept on the scene's grid for later searches of the same
        scene), False never
    collision_max_tests : exact collision tests one ranking may make; a pose left untested
        when they run out is not predicted
    batch_size : candidates scored per batch (bounds memory; a progress-bar step)
    rank : rank the accepted pairs into predictions (False: decisions only)
    """

    early_exit: bool = True
    score_first: bool = False
    neighbour_cache: bool | None = None
    collision_max_tests: int = 50_000
    batch_size: int = 4096
    rank: bool = True


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
    table = tensor.keypoint_table(settings)
    res = score_pairs(np.asarray(positions, float), np.asarray(orientation_index, int), table,
                      scene, threshold=1.0, vectors=tensor.vectors, early_exit=False)
    return res.score


def candidate_mask(normals: np.ndarray, affordance_normal: np.ndarray,
                   tolerance_deg: float, oriented) -> np.ndarray:
    """(N,) bool: normals within ``tolerance_deg`` of N_aff, of its line where the normal's
    side is not known: ``oriented`` True (every normal's side is known), False (none is) or
    (N,) bool, per normal (a closed part's outside, :attr:`~.geometry.scene.Scene.oriented`:
    the underside of a shelf or of a peg does not face up)."""
    dot = normals @ np.asarray(affordance_normal, float)
    dot = np.where(oriented, dot, np.abs(dot))
    return dot >= np.cos(np.radians(tolerance_deg)) - 1e-12


def _test_points(scene: Scene, settings: DetectSettings) -> np.ndarray:
    rng = np.random.default_rng(settings.seed)
    n_test = max(1, int(round(settings.sample_fraction * len(scene))))
    return np.sort(rng.choice(len(scene), size=n_test, replace=False))


def test_all(scene, tensor, settings: DetectSettings, pair_point, pair_orient, grid=None,
             idx=None):
    """The placement tests (:func:`~interaction_tensor.placement.checks.check_placements`) of
    pairs ``idx`` (default: every pair). Returns (clearance violations (P,) int, -1 where not
    tested or the clearance test is off; outcome (P,) int8: -1 where not tested, else
    ``PLACED`` or the first test failed)."""
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
        if settings.runs("clearance") and k:
            viol[sl] = v
    return viol, outcome


def _finish(scene, tensor, settings, engine, threshold, test_idx, cand, pair_point,
            pair_orient, pairs, timings, backend, t0, score_acc, viol, outcome, rest,
            complete, scored) -> Detection:
    """Places, the top k (the best pose of each of the best places; those that would enter
    it tested for collision), heat map, statistics."""
    det = Detection(scene, tensor, settings, threshold, test_idx, cand, pair_point,
                    pair_orient, pairs, None, None, [], {}, score_acc, viol, rest, outcome,
                    complete=complete, scored=scored, engine=engine)
    t3 = time.perf_counter()
    acc = accepted_indices(pairs.accepted)
    check = collision_check(det)
    picks = []
    if engine.rank:
        # accepted pairs grouped into places; the top k: the best pose of each of the best
        # places (one that passes the collision test); every accepted pair has a place, so
        # no radius parts them. A pair that fails the ranked tests loses its acceptance:
        # the places are grouped again without it (a place whose pairs all failed is no
        # place found) until a ranking fails none (the tested pairs keep their outcome)
        cell = place_cell(scene.spacing, settings.sample_fraction, tensor.scene_spacing)
        while True:
            acc = accepted_indices(pairs.accepted)
            place, det.places = group_places(scene.points, pair_point, pairs.score, acc,
                                             cell, tensor.affordance_normal)
            picks = top_k(scene.points, pairs.score[acc], settings.top_k, 0.0,
                          index=pair_point[acc], group=place,
                          accept=(lambda i: check.free(int(acc[i]))) if check.on else None)
            if pairs.accepted[acc].all():
                break
        det.pair_place = np.full(len(pair_point), -1, np.int32)
        det.pair_place[acc] = place
        det.predictions = [det.prediction(int(acc[i]), int(place[i])) for i in picks]
    timings["collision"] = check.seconds
    det.heat, det.accepted_count = heat_map(scene, pair_point, pairs.score, pairs.accepted)
    timings["predictions"] = time.perf_counter() - t3
    timings["total"] = time.perf_counter() - t0
    decided = pairs.decided_at if scored is None else pairs.decided_at[scored]
    acc_scored = pairs.accepted if scored is None else pairs.accepted[scored]

    def failing(code):
        return int((outcome == code).sum())
    scoring_s = timings.get("scoring", 0)
    # every pair decided: tested and scored
    deciding_s = scoring_s + timings.get("placement_tests", 0)
    det.stats.update({
        "scene_points": int(len(scene)),
        "scene_notes": list(getattr(scene, "notes", [])),
        "test_points_sampled": int(len(test_idx)),
        "candidates_after_normal_filter": int(len(cand)),
        # (point, orientation) pairs decided; of them scored and given the placement tests
        "pairs": int(len(pair_point)),
        "pairs_scored": int(len(pair_point) if scored is None else scored.sum()),
        "pairs_tested": int((outcome != UNTESTED).sum()),
        "pairs_accepted": int(pairs.accepted.sum()),
        "pairs_accepted_by_score": int(score_acc.sum()),
        "places": len(det.places),
        "pairs_failing_tap": failing(FAILS_TAP),
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
        "backend": backend.name,
        "device": backend.device,
        "seconds": {k: round(v, 4) for k, v in timings.items()},
        "scoring_seconds": round(scoring_s, 4),
        # the placement tests and the scoring: every pair's final decision
        "deciding_seconds": round(deciding_s, 4),
        # rates count the work done: candidates (test points past the normal filter, all
        # orientations decided) and (point, orientation) pairs decided, never sampled points
        "candidates_per_second": (float(len(cand) / deciding_s) if deciding_s > 0 else None),
        "pairs_per_second": (float(len(pair_point) / deciding_s) if deciding_s > 0 else None),
    })
    if engine.rank and not det.predictions:
        det.warnings += empty_result_warnings(det)
    elif engine.rank:
        det.warnings += sparse_scene_warnings(det)
    det.stats["warnings"] = list(det.warnings)
    return det


#: A scene whose points are this many times further apart than the descriptor's training
#: spacing is too sparse for the placement tests, which look for scene points near the
#: query's surface at that spacing.
SPARSE_FACTOR = 1.5
#: Past this many times the descriptor's spacing, a cloud's places may be missed or split
#: even with its normals (``benchmarks/run.py --only density``: up to 3x they are the mesh's);
#: past :data:`SPARSE_FACTOR`, when its normals were estimated.
SPARSE_WARN_FACTOR = 3.0


def sparse_scene_warnings(det) -> list:
    """A line for a result found on a cloud too sparse to trust it whole: places may be
    missed or split, and what to give instead."""
    spacing, trained = float(det.scene.spacing), float(det.tensor.scene_spacing)
    ratio = spacing / trained if trained > 0 else 0.0
    if ratio > SPARSE_WARN_FACTOR:
        return [f"the scene's points are {100 * spacing:.1f} cm apart, {ratio:.1f} times the "
                f"descriptor's {100 * trained:.1f} cm: places may be missed or split; give a "
                f"denser scan or cloud, or a mesh"]
    if ratio > SPARSE_FACTOR and det.scene.normals_estimated:
        return [f"the scene's normals were estimated from points {100 * spacing:.1f} cm "
                f"apart, {ratio:.1f} times the descriptor's {100 * trained:.1f} cm: places "
                f"may be missed; give the cloud's normals (N x 6) or a denser cloud"]
    return []


def empty_result_warnings(det) -> list:
    """Why a detection found no place, as one line that says what to do: the scene too
    sparse for the descriptor, nothing past the normal filter, no pair scoring to the
    threshold, or the placement tests rejecting every pair that did (which tests, how
    many)."""
    st, tensor = det.stats, det.tensor
    spacing, trained = float(det.scene.spacing), float(tensor.scene_spacing)
    if spacing > SPARSE_FACTOR * trained:
        return [f"no place found, and the scene's points are {100 * spacing:.1f} cm apart "
                f"where the descriptor expects {100 * trained:.1f} cm: give a denser scan or "
                f"cloud, or a mesh (sampled at the descriptor's spacing)"]
    if not st["candidates_after_normal_filter"]:
        return ["no place found: no test point faces the descriptor's direction (N_aff); "
                "check that the scene is +Z up in metres (--up, --scale)"]
    if not st["pairs_accepted_by_score"]:
        return [f"no place found: no pair scored {st['threshold']:.3f} or more; the scene "
                "may hold no such place, or try a larger --sample-fraction"]
    if st.get("collision_tests_exhausted"):
        return ["no place found: the collision test's budget was spent before a pair passed "
                "it; the scene may hold no such place"]
    failing = {k[len("pairs_failing_"):]: v for k, v in st.items()
               if k.startswith("pairs_failing_") and v}
    worst = ", ".join(f"{k} {v:,}" for k, v in sorted(failing.items(), key=lambda kv: -kv[1]))
    return [f"no place found: {st['pairs_accepted_by_score']:,} pairs scored high enough but "
            f"the placement tests rejected them ({worst or 'collision'}); the scene may hold "
            "no such place (--skip-test NAME shows what a test rejects)"]


def _filtered(scene: Scene, tensor, settings: DetectSettings, test_idx) -> np.ndarray:
    """The test points whose normal passes the tensor's N_aff filter."""
    oriented = settings.oriented_normals
    if not oriented and scene.oriented is not None:
        oriented = scene.oriented[test_idx]
    ok = candidate_mask(scene.normals[test_idx], tensor.affordance_normal,
                        settings.normal_tolerance(tensor), oriented)
    return test_idx[ok]


def candidates(scene: Scene, tensor, settings: DetectSettings | None = None) -> np.ndarray:
    """The candidates :func:`detect` would score for ``tensor``, without scoring them: the
    seeded draw of test points, then the normal filter (scene indices, sorted). The
    baselines of ``itensor evaluate`` take theirs from here when iT does not run."""
    settings = (settings or DetectSettings()).for_scene(scene)
    return _filtered(scene, tensor, settings, _test_points(scene, settings))


def detect_many(scene: Scene, tensors: list, settings: DetectSettings | None = None,
                progress: bool = False, test_indices=None,
                engine: Engine | None = None) -> list:
    """Detect several interactions in one pass over a scene.

    The test points and the scene index are shared by all descriptors; each gets its own
    candidates (its N_aff), threshold and :class:`~.result.Detection`, identical to what
    :func:`detect` gives for it alone. ``test_indices`` (scene indices) replaces the seeded
    random draw of ``settings.sample_fraction``; ``engine`` how the work is done
    (:class:`Engine`).
    """
    settings = (settings or DetectSettings()).for_scene(scene)
    engine = engine or Engine()
    t0 = time.perf_counter()
    timings = {}
    if test_indices is None:
        test_idx = _test_points(scene, settings)
    else:
        test_idx = np.unique(np.asarray(test_indices, np.int64))
        if len(test_idx) and (test_idx[0] < 0 or test_idx[-1] >= len(scene)):
            raise ValueError("test_indices must be indices of the scene's points")
    n_o = settings.n_orientations
    pairs = len(test_idx) * n_o * len(tensors)
    if pairs > MAX_PAIRS:            # a scene prepared elsewhere (a frame, a scan, a caller's)
        many = f" x {len(tensors)} descriptors" if len(tensors) > 1 else ""
        raise InputError(scene.source, f"{len(test_idx):,} test points x {n_o} orientations"
                                       f"{many} make {pairs:,} placements to decide, more "
                                       f"than the {MAX_PAIRS:,} allowed; give a smaller "
                                       "--sample-fraction or fewer --orientations")
    exit_mode = EXIT_AT_REJECTION if engine.early_exit else EXIT_NEVER
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
        jobs.append(ScoreJob(pp, po, tensor.keypoint_table(settings),   # points: indices
                             resolve_threshold(tensor, settings), tensor.vectors,
                             scene.spacing, exit_mode))
    timings["candidates"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    backend = open_backend(settings.backend, scene, settings.device)
    timings["index"] = time.perf_counter() - t1
    label = tensors[0].affordance if len(tensors) == 1 else f"{len(tensors)} affordances"
    use_cache = (backend.name == "numba"
                 and cache_pays(engine.neighbour_cache, len(test_idx) / max(len(scene), 1),
                                sum(len(pp) for pp in pp_list)))
    if use_cache:
        prefetch_cache_kernels()
    cache = dict(cache=use_cache, cache_bytes=cache_budget(len(scene), engine.neighbour_cache),
                 keep_cache=engine.neighbour_cache is True)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=max((len(j.points) for j in jobs), default=0) // n_o, unit="pt",
                   desc=f"detect {label}", leave=False)
    if not engine.score_first:
        # the placement tests of every pair, then the scores of the pairs that pass them
        t3 = time.perf_counter()
        tested = [test_all(scene, tensor, settings, pp, po, backend.grid)
                  for tensor, pp, po in zip(tensors, pp_list, po_list)]
        timings["placement_tests"] = time.perf_counter() - t3
        scored = [outcome == PLACED for _, outcome in tested]
        keep = [np.flatnonzero(m) for m in scored]
        subs = [ScoreJob(job.points[i], job.orient[i], job.table, job.threshold, job.vectors,
                         job.rho, job.early_exit) for job, i in zip(jobs, keep)]
        t2 = time.perf_counter()
        await_cache_kernels()
        scores = backend.score(subs, n_o, engine.batch_size, bar, grouped=False, **cache)
        timings["scoring"] = time.perf_counter() - t2
        # back to every pair: those that failed a test were never scored; the accepted ones
        # were scored in full (stopped only at a rejection)
        scores = [_scattered(pairs, m, i) for pairs, m, i in zip(scores, scored, keep)]
        score_acc = [pairs.accepted.copy() for pairs in scores]
        viols = [viol for viol, _ in tested]
        outcomes = [outcome for _, outcome in tested]
        complete = [pairs.accepted.copy() if engine.early_exit else m.copy()
                    for pairs, m in zip(scores, scored)]
    else:
        # the scores of every pair (accepted ones in full), then the placement tests of the
        # pairs the score accepted
        t2 = time.perf_counter()
        await_cache_kernels()
        scores = backend.score(jobs, n_o, engine.batch_size, bar, grouped=True, **cache)
        timings["scoring"] = time.perf_counter() - t2
        t3 = time.perf_counter()
        score_acc, viols, outcomes = [], [], []
        for tensor, pp, po, pairs in zip(tensors, pp_list, po_list, scores):
            score_acc.append(pairs.accepted.copy())
            idx = np.flatnonzero(pairs.accepted)
            viol, outcome = test_all(scene, tensor, settings, pp, po, backend.grid, idx)
            pairs.accepted[idx[outcome[idx] != PLACED]] = False
            viols.append(viol)
            outcomes.append(outcome)
        timings["placement_tests"] = time.perf_counter() - t3
        complete = ([acc.copy() for acc in score_acc] if engine.early_exit
                    else [np.ones(len(pp), bool) for pp in pp_list])
        scored = [None] * len(jobs)
    if bar is not None:
        bar.close()
    return [_finish(scene, tensor, settings, engine, job.threshold, test_idx, cand, pp, po,
                    pairs, dict(timings), backend, t0, sa, viol, outcome, job.table.rest, cm, sc)
            for tensor, job, cand, pp, po, pairs, sa, viol, outcome, cm, sc in zip(
                tensors, jobs, cands, pp_list, po_list, scores, score_acc, viols, outcomes,
                complete, scored)]


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


def detect(scene: Scene, tensor: InteractionTensor, settings: DetectSettings | None = None,
           progress: bool = False, test_indices=None, engine: Engine | None = None) -> Detection:
    """Find where the interaction of ``tensor`` can happen in ``scene`` (a prepared
    :class:`~interaction_tensor.geometry.scene.Scene`); see :func:`detect_many`."""
    return detect_many(scene, [tensor], settings, progress, test_indices, engine)[0]
