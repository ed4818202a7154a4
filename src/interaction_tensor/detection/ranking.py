"""Ranking accepted pairs: the exact collision test of the poses that would enter a top k, and
the exact best and worst pairs of a detection by full score (the evaluation's top and bottom
5).
"""

from __future__ import annotations

import time

import numpy as np

from interaction_tensor.detection.places import top_k
from interaction_tensor.detection.result import Detection
from interaction_tensor.engine.backends import resolve_backend
from interaction_tensor.engine.numba_backend import score_pairs_numba
from interaction_tensor.engine.scoring import score_pairs
from interaction_tensor.geometry.collision import CrossingMemory
from interaction_tensor.placement import hooks, taps
from interaction_tensor.placement.checks import (
    FAILS_COLLISION,
    PLACED,
    UNTESTED,
    check_placements,
)


class CollisionCheck:
    """Detection's exact tests of ranked pairs: collision, hanging and filling (those
    ``DetectSettings.skip_tests`` leaves of ``collision``, ``hangs`` and ``fills``).

    A pair is posed (:meth:`.Detection.pair_pose`) and tested against
    the scene's mesh with python-fcl. It passes when, for each of the descriptor's
    :attr:`~.InteractionTensor.collision_tests`, its tested query triangles do not cross the
    scene's or a move of that test's depth in one of 26 directions frees them
    (:meth:`.MeshCollider.separation`), and, where the descriptor asks for it
    (:attr:`~.InteractionTensor.through`), the scene crosses the posed section of what went
    through the query in the example (a rail through the hook). Where the descriptor asks
    the query to hang (:attr:`~.InteractionTensor.hangs`; on any scene, triangles or not),
    what crosses its opening must fit inside it and its bottom must hang free
    (:mod:`~interaction_tensor.placement.hooks`); where it asks the query to be filled
    (:attr:`~.InteractionTensor.fills`), it is stood on the surface under it
    (:meth:`.Detection.lift`; with nothing there it fails) and a tap, a basin and a sink must
    be there (:mod:`~interaction_tensor.placement.taps`). Each pair is tested at most once
    (``state``: -1 untested, 0 passes, 1 fails); a pair that fails loses its acceptance
    (``placement`` :data:`~interaction_tensor.placement.checks.FAILS_COLLISION`). At most
    ``Engine.collision_max_tests`` pairs are tested; :meth:`free` answers None once they
    are spent.
    """

    def __init__(self, det: "Detection"):
        self.det = det
        st, tensor, scene = det.settings, det.tensor, det.scene
        self.reason = None
        if not st.runs("collision"):
            self.reason = "off (settings)"
        elif not tensor.collision_tests and not tensor.through:
            self.reason = "off (the descriptor has no collision test)"
        elif getattr(scene, "mesh", None) is None:
            self.reason = "off (the scene has no triangles)"
        elif not tensor.collision_bodies() and tensor.through_body() is None:
            self.reason = "off (no query triangles to test)"
        self.collides = self.reason is None
        if not self.collides:
            self.through = self.reason
        elif not tensor.through:
            self.through = "off (the descriptor does not ask for it)"
        elif tensor.through_body() is None:
            self.through = "off (the example had nothing through the query)"
        else:
            self.through = "on"
        self.hang = _status(st.runs("hangs"), tensor.hangs, tensor.hook_opening() is not None,
                            "the example had nothing through the query")
        self.fill = _status(st.runs("fills"), tensor.fills, True, "")
        self.on = self.collides or self.hang == "on" or self.fill == "on"
        self.state = np.full(len(det.pair_point), -1, np.int8) if self.on else None
        self.tests = 0
        self.failed_through = 0
        self.failed_hanging = 0
        self.failed_filling = 0
        self.seconds = 0.0
        self.exhausted = False
        self._flats = None
        self.memory = CrossingMemory()     # the pairs found crossing, by orientation

    def free(self, i: int):
        """Whether pair ``i`` passes the tests: True, False, or None when it is not tested
        because the tests allowed are spent (or the test is off: True)."""
        if not self.on:
            return True
        if self.state[i] >= 0:
            return bool(self.state[i] == 0)
        det = self.det
        if self.tests >= det.engine.collision_max_tests:
            self.exhausted = True
            return None
        t = time.perf_counter()
        tensor = det.tensor
        pose = det.pair_pose(i)           # a container stood on what is under it
        # cheapest and most rejecting first: through, hanging, filling, then penetration
        ok = True
        collider = det.scene.collider() if self.collides else None
        if collider is not None and tensor.through_body() is not None:
            ok = collider.collides(tensor.through_body(), pose)
            if not ok:
                self.failed_through += 1
        if ok and self.hang == "on":
            ok = self._hangs(pose)
            if not ok:
                self.failed_hanging += 1
        if ok and self.fill == "on":
            scene = det.scene
            ok = bool(np.isfinite(det.lift(i))) and taps.fills(
                tensor.vessel(), pose[:3, :3], pose[:3, 3], scene.points, scene.normals,
                scene.tree, scene.spacing)
            if not ok:
                self.failed_filling += 1
        for body, depth in tensor.collision_bodies() if ok and collider is not None else ():
            if collider.penetrates(body, pose, depth, self.memory)[0]:
                ok = False
                break
        self.tests += 1
        self.state[i] = 0 if ok else 1
        if not ok:
            det.pairs.accepted[i] = False
            if det.placement is not None and det.placement[i] == PLACED:
                det.placement[i] = FAILS_COLLISION
        self.seconds += time.perf_counter() - t
        return ok

    def _hangs(self, pose: np.ndarray) -> bool:
        """Whether the query posed by ``pose`` hangs from what crosses its opening:
        :func:`.hooks.fits` (on the mesh's exact section where the scene has triangles) and
        :func:`.hooks.hangs_free`."""
        scene, tensor = self.det.scene, self.det.tensor
        rot, t = pose[:3, :3], pose[:3, 3]
        if not hooks.fits(tensor.hook_opening(), rot, t, scene.points, scene.tree,
                          scene.spacing, sections=scene.sections(), normals=scene.normals):
            return False
        if self._flats is None:
            self._flats = hooks.flat_tree(scene.points, scene.normals)
        return hooks.hangs_free(tensor.hook_bottom() @ rot.T + t, self._flats)

    def stats(self) -> dict:
        """What the test did, for ``Detection.stats``."""
        return {"collision_test": "on" if self.collides else self.reason,
                "collision_tests": self.tests,
                "pairs_failing_collision": int((self.state == 1).sum()) if self.on else 0,
                "through_test": self.through,
                "pairs_with_nothing_through": self.failed_through,
                "hanging_test": self.hang,
                "pairs_not_hanging": self.failed_hanging,
                "filling_test": self.fill,
                "pairs_not_filling": self.failed_filling,
                "collision_tests_exhausted": self.exhausted}


def _status(runs: bool, asked: bool, possible: bool, why_not: str) -> str:
    """``on``, or ``off`` with the reason, of one of the ranked tests beside collision."""
    if not runs:
        return "off (settings)"
    if not asked:
        return "off (the descriptor does not ask for it)"
    return "on" if possible else f"off ({why_not})"


def collision_check(det: "Detection") -> CollisionCheck:
    """The detection's :class:`CollisionCheck` (built on first use, shared by its rankings)."""
    if det.collisions is None:
        det.collisions = CollisionCheck(det)
    return det.collisions


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
        table = det.tensor.keypoint_table(st)
        pts = det.scene.points[det.pair_point[sub]]
        orient = det.pair_orientation[sub]
        if resolve_backend(st.backend) == "numba":
            scores[redo] = score_pairs_numba(pts, orient, table, det.scene.grid(), 2.0,
                                             det.tensor.vectors, det.scene.spacing,
                                             early_exit=False, cache=det.engine.neighbour_cache)[0]
        else:
            scores[redo] = score_pairs(pts, orient, table, det.scene, 2.0,
                                       vectors=det.tensor.vectors, early_exit=False).score
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
    rest = det.rest if det.rest is not None else det.tensor.keypoint_table(det.settings).rest
    upper = np.where(done, score, score + rest[det.pairs.decided_at])
    key = np.full(n, np.nan)
    full = np.full(n, np.nan)
    okv = np.zeros(n, bool)
    # a pair the score accepted was completed, and detection gave it its placement tests:
    # its key is known without scoring it again, so it ranks from the start (scoring them in
    # the order of their scores spent the evaluations allowed on pairs that failed their
    # tests: hanging-handbag in office-desk6 never reached 47,872 of its placed pairs)
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
