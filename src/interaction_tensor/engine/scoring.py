"""Score kernels: how well test vectors match provenance vectors, keypoint by keypoint.

Two criteria (REFERENCE.md):

* ``paper`` (eq. 5): per keypoint, Theta = 1 when the angle between the provenance vector p
  and the test vector v_t is at most W * theta_max, and only then Delta = 1 when
  | |p| - |v_t| | <= W |p| / c, with W = w_max / w_i. Term in {0, 1, 2}; the normalised
  score is sum(terms) / (2 N).
* ``gaussian`` (the authors' code): d = |v_t - p| / |p|, sigma = a (1 + w_i), term
  w_i exp(-d^2 / (2 sigma^2)); the score is sum(terms) / sum(w).

Test vectors, like the provenance vectors of training, go from a keypoint to the scene:
``vectors="surface"`` (default) to the nearest point of the sampled surface, each sample
standing for a disk of radius ``spacing`` in its tangent plane (:func:`surface_vectors`), so
that they do not depend on where the random samples fell; ``vectors="points"`` to the nearest
sample itself, as in the paper's definition on dense clouds.

Both are sums of bounded non-negative terms over keypoints, so a partial sum bounds the final
score from below and the partial sum plus the largest possible rest bounds it from above: the
early exit in :func:`score_pairs` decides exactly as the full sum would.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np


@dataclass
class KeypointTable:
    """Keypoints of one set prepared for scoring, in weight order (largest first).

    Attributes
    ----------
    offsets : (O, N, 3) keypoint positions relative to the test point, per orientation
    provenance : (O, N, 3) provenance vectors, rotated per orientation
    weights : (N,) keypoint weights in [0, 1]
    max_terms : (N,) largest contribution each keypoint can make to the normalised score
    """

    offsets: np.ndarray
    provenance: np.ndarray
    weights: np.ndarray
    max_terms: np.ndarray
    criterion: str
    theta_max: float
    c: float
    a: float

    @property
    def n(self) -> int:
        return self.weights.shape[0]

    @property
    def rest(self) -> np.ndarray:
        """(N + 1,) largest score keypoints k..N-1 can still add (0 after the last): the
        early exit's upper bound."""
        return np.r_[np.cumsum(self.max_terms[::-1])[::-1], 0.0]


def rotation_z(angles: np.ndarray) -> np.ndarray:
    """(K, 3, 3) rotations about +Z (counter-clockwise) by ``angles`` (radians)."""
    angles = np.atleast_1d(np.asarray(angles, dtype=np.float64))
    c, s = np.cos(angles), np.sin(angles)
    r = np.zeros((len(angles), 3, 3))
    r[:, 0, 0], r[:, 0, 1], r[:, 1, 0], r[:, 1, 1], r[:, 2, 2] = c, -s, s, c, 1.0
    return r


def make_table(keypoints_rel, provenance, weights, n_orientations: int, criterion: str,
               theta_max: float, c: float, a: float) -> KeypointTable:
    """Rotate keypoints (relative to the reference point) and vectors for every orientation.

    Keypoints are re-ordered by weight, largest first (paper: high-weight keypoints are
    compared first), ties by the shorter provenance vector.
    """
    weights = np.asarray(weights, dtype=np.float64)
    norms = np.linalg.norm(provenance, axis=1)
    order = np.lexsort((norms, -weights))
    rot = rotation_z(2 * np.pi * np.arange(n_orientations) / n_orientations)
    offsets = np.einsum("oij,nj->oni", rot, np.asarray(keypoints_rel)[order])
    prov = np.einsum("oij,nj->oni", rot, np.asarray(provenance)[order])
    w = weights[order]
    if criterion == "paper":
        max_terms = np.full(len(w), 1.0 / len(w))      # 2 / (2N)
    else:
        max_terms = w / w.sum()
    return KeypointTable(offsets, prov, w, max_terms, criterion, theta_max, c, a)


def paper_limits(table: KeypointTable) -> tuple[np.ndarray, np.ndarray]:
    """Per keypoint, W = w_max / w_i and the cosine of the angle limit min(W theta_max, pi).

    Comparing cosines (angle <= limit  <=>  cos(angle) >= cos(limit)) avoids an arccos per
    comparison; a limit of pi accepts every angle (cosine limit -inf).
    """
    w = table.weights
    with np.errstate(divide="ignore"):
        big_w = np.where(w > 0, w.max() / np.where(w > 0, w, 1), np.inf)
    limit = big_w * table.theta_max
    cos_lim = np.where(limit >= np.pi, -np.inf, np.cos(np.minimum(limit, np.pi)))
    return big_w, cos_lim


def permuted(table: KeypointTable, order: np.ndarray) -> KeypointTable:
    """The same keypoints compared in ``order`` (a permutation of 0..N-1).

    Scores are sums over keypoints, so the order changes only how soon the early exit
    decides, never the decision or an accepted pair's score.
    """
    order = np.asarray(order, dtype=np.int64)
    return replace(table, offsets=table.offsets[:, order], provenance=table.provenance[:, order],
                   weights=table.weights[order], max_terms=table.max_terms[order])


@dataclass(frozen=True)
class ArrayOps:
    """The few array functions the scoring formulas need that NumPy and torch spell
    differently; everything else in :func:`vector_terms` and :func:`onto_disks` is operators
    and methods both share. ``NUMPY_OPS`` here, ``torch_backend.torch_ops()`` for torch."""

    where: object
    sqrt: object
    exp: object
    as_float: object                # bool array -> float64 array


NUMPY_OPS = ArrayOps(np.where, np.sqrt, np.exp, lambda b: b.astype(np.float64))


def _length(v, ops: ArrayOps):
    """Length of 3-vectors along the last axis (summed x, y, z in that order, as the Numba
    kernel does)."""
    return ops.sqrt((v * v).sum(-1))


def vector_terms(table: KeypointTable, prov, test_vectors, pn, weights, big_w, cos_lim,
                 ops: ArrayOps = NUMPY_OPS):
    """Normalised contribution of each keypoint, given its provenance and test vector.

    Parameters
    ----------
    prov, test_vectors : (..., K, 3) provenance and test vectors (arrays of ``ops``' library)
    pn, weights, big_w, cos_lim : (K,) |p|, weights, W and the cosine limit of those keypoints
    ops : NumPy's or torch's functions

    Returns (..., K) float64 contributions, each in [0, max_terms].
    """
    vn = _length(test_vectors, ops)
    if table.criterion == "paper":
        den = pn * vn
        cosang = ops.where(den > 0, (prov * test_vectors).sum(-1) / ops.where(den > 0, den, 1.0),
                           0.0)
        theta_ok = cosang >= cos_lim                  # angle <= W theta_max, without acos
        delta_ok = theta_ok & (abs(pn - vn) <= big_w * pn / table.c)
        return (ops.as_float(theta_ok) + ops.as_float(delta_ok)) / (2 * table.n)
    d = _length(test_vectors - prov, ops) / pn.clip(min=1e-12)
    sigma = table.a * (1.0 + weights)
    return weights * ops.exp(-d * d / (2 * sigma * sigma)) / float(table.weights.sum())


def keypoint_terms(table: KeypointTable, k: slice, orient: np.ndarray,
                   test_vectors: np.ndarray) -> np.ndarray:
    """Normalised contributions of keypoints ``k`` for pairs in orientations ``orient``.

    Parameters
    ----------
    k : slice of keypoint indices
    orient : (P,) int orientation index of each pair
    test_vectors : (P, K, 3) nearest scene point minus keypoint position

    Returns (P, K) float64, each in [0, max_terms[k]].
    """
    p = table.provenance[orient, k]                 # (P, K, 3)
    big_w, cos_lim = paper_limits(table)
    return vector_terms(table, p, test_vectors, _length(p, NUMPY_OPS), table.weights[k],
                        big_w[k], cos_lim[k])


VECTOR_MODES = ("surface", "points")


def surface_vectors(queries: np.ndarray, points: np.ndarray, normals: np.ndarray,
                    nn: np.ndarray, radius: float, mode: str = "surface") -> np.ndarray:
    """Vectors from ``queries`` to the scene, given their nearest samples ``nn``.

    Parameters
    ----------
    queries : (..., 3) positions, metres
    points, normals : (N, 3) scene samples and their unit normals
    nn : (...) int index of each query's nearest sample
    radius : disk radius (m) each sample stands for (the sampling spacing)
    mode : ``"surface"``: to the nearest point of the sample's disk; ``"points"``: to the
        sample itself

    Returns (..., 3) float64.
    """
    d = points[nn] - queries
    if mode == "points":
        return d
    return onto_disks(d, normals[nn], radius)


def onto_disks(d, n, radius: float, ops: ArrayOps = NUMPY_OPS):
    """Vectors ``d`` to samples of normals ``n`` (both (..., 3)), shortened to the nearest
    point of each sample's disk of ``radius`` in its tangent plane."""
    along = (d * n).sum(-1)[..., None] * n
    lateral = d - along
    lat = _length(lateral, ops)[..., None]
    shrink = ops.where(lat > radius, (lat - radius) / ops.where(lat > 0, lat, 1.0), 0.0)
    return along + lateral * shrink


@dataclass
class PairScores:
    """Outcome of scoring P (test point, orientation) pairs.

    Attributes
    ----------
    score : (P,) float64, full normalised score for accepted pairs; for rejected pairs the
        partial score when the decision was made (a lower bound of the full score)
    accepted : (P,) bool
    decided_at : (P,) int, keypoint comparisons needed to reach the decision
    comparisons : int, keypoint comparisons made in total
    """

    score: np.ndarray
    accepted: np.ndarray
    decided_at: np.ndarray
    comparisons: int


def score_pairs(points: np.ndarray, orient: np.ndarray, table: KeypointTable, scene,
                threshold: float, vectors: str = "surface", early_exit: bool = True,
                chunk: int = 32) -> PairScores:
    """Score (test point, orientation) pairs, keypoints in weight order.

    Parameters
    ----------
    points : (P, 3) test point of each pair, metres
    orient : (P,) int orientation index of each pair
    table : the keypoints
    scene : a :class:`~interaction_tensor.geometry.scene.Scene` (points, normals, spacing, tree)
    threshold : acceptance threshold on the normalised score
    early_exit : drop a pair from further comparisons as soon as it can no longer reach
        the threshold; accepted pairs are always completed, to rank them by full score
    chunk : keypoints compared per vectorised step
    """
    n_pairs, n = len(points), table.n
    score = np.zeros(n_pairs)
    decided_at = np.full(n_pairs, n, dtype=np.int64)
    decided = np.zeros(n_pairs, bool)
    accepted = np.zeros(n_pairs, bool)
    rest = table.rest
    alive = np.arange(n_pairs)
    comparisons = 0
    eps = 1e-12
    for k0 in range(0, n, chunk):
        if len(alive) == 0:
            break
        k = slice(k0, min(k0 + chunk, n))
        kk = k.stop - k.start
        queries = points[alive, None, :] + table.offsets[orient[alive], k]
        q = queries.reshape(-1, 3)
        _, nn = scene.tree.query(q, workers=_workers(len(q)))
        test_vectors = surface_vectors(queries, scene.points, scene.normals,
                                       nn.reshape(queries.shape[:2]), scene.spacing, vectors)
        terms = keypoint_terms(table, k, orient[alive], test_vectors)
        comparisons += terms.size
        partial = score[alive, None] + np.cumsum(terms, axis=1)      # (A, K)
        und = ~decided[alive]
        if und.any():
            reach = partial >= threshold - eps
            lost = partial + rest[k.start + 1:k.stop + 1] < threshold - eps
            first_acc = np.where(reach.any(1), reach.argmax(1), kk)
            first_rej = np.where(lost.any(1), lost.argmax(1), kk)
            at = np.minimum(first_acc, first_rej)
            now = und & (at < kk)
            idx = alive[now]
            decided[idx] = True
            decided_at[idx] = k.start + at[now] + 1
            accepted[idx] = first_acc[now] <= first_rej[now]
            # a rejected pair keeps the partial score at its decision
            rej = now & ~accepted[alive]
            score[alive[rej]] = partial[rej, at[rej]]
        keep = ~(decided[alive] & ~accepted[alive]) if early_exit else np.ones(len(alive), bool)
        upd = keep | ~decided[alive]
        score[alive[upd]] = partial[upd, -1]
        alive = alive[keep]
    # pairs never decided (threshold reached exactly at the end is handled above)
    left = ~decided
    accepted[left] = score[left] >= threshold - eps
    return PairScores(score, accepted, decided_at, comparisons)


#: Queries of a cKDTree answered by all cores from this many on: below it, starting the
#: threads costs more than they save (a descriptor's self-score, a test's few pairs).
PARALLEL_QUERIES = 8192


def _workers(n: int) -> int:
    return -1 if n >= PARALLEL_QUERIES else 1


def pair_test_vectors(points: np.ndarray, orient: np.ndarray, table: KeypointTable, scene,
                      vectors: str, nearest) -> np.ndarray:
    """(P, N, 3) test vectors of every keypoint of every pair: what both criteria compare
    (tables of one keypoint set share them). ``nearest`` maps (Q, 3) queries to the indices
    of their nearest scene points."""
    queries = points[:, None, :] + table.offsets[orient]
    nn = np.asarray(nearest(queries.reshape(-1, 3))).reshape(queries.shape[:2])
    return surface_vectors(queries, scene.points, scene.normals, nn, scene.spacing, vectors)


def all_terms(points: np.ndarray, orient: np.ndarray, table: KeypointTable, scene,
              vectors: str, nearest) -> np.ndarray:
    """(P, N) terms of every keypoint of every pair, no early exit (:func:`pair_test_vectors`
    compared by ``table``'s criterion)."""
    test_vectors = pair_test_vectors(points, orient, table, scene, vectors, nearest)
    return keypoint_terms(table, slice(0, table.n), orient, test_vectors)


def score_pairs_exact(points: np.ndarray, orient: np.ndarray, table: KeypointTable, scene,
                      threshold: float, vectors: str = "surface") -> PairScores:
    """Reference: every keypoint of every pair, one batched query of the scene's cKDTree, no
    early exit."""
    terms = all_terms(points, orient, table, scene, vectors,
                      lambda q: scene.tree.query(q, workers=-1)[1])
    score = terms.sum(axis=1)
    accepted = score >= threshold - 1e-12
    return PairScores(score, accepted, np.full(len(points), table.n), terms.size)


#: ``ScoreJob.early_exit``: every keypoint of every pair; stop a pair when it is rejected (an
#: accepted pair's score is complete); stop a pair at its decision, accepted or rejected
EXIT_NEVER, EXIT_AT_REJECTION, EXIT_AT_DECISION = 0, 1, 2


@dataclass
class ScoreJob:
    """One keypoint table to score over a set of (test point, orientation) pairs.
    ``early_exit``: :data:`EXIT_NEVER`, :data:`EXIT_AT_REJECTION` (or True) or
    :data:`EXIT_AT_DECISION` (the Numba kernels only)."""

    points: np.ndarray
    orient: np.ndarray
    table: object
    threshold: float
    vectors: str = "surface"
    rho: float = 0.01
    early_exit: bool | int = True
    #: (P,) partial score and keypoint of each pair's decision: go on from there (the Numba
    #: kernels: the scores of accepted pairs that stopped at their decision, completed;
    #: every pair of the job is taken as accepted)
    resume_score: np.ndarray | None = None
    resume_at: np.ndarray | None = None
