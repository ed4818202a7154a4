"""Places and predictions: accepted pairs grouped into places (connected regions of a surface
or an edge), the top k (the best pose of each of the best places), and the heat map of
accepted scores over the scene.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from interaction_tensor.descriptor.tensor import InteractionTensor
from interaction_tensor.geometry.files import Gathered


@dataclass
class Prediction:
    """One place where the interaction can happen.

    Attributes
    ----------
    position : (3,) test point, metres
    orientation_index : i, the query object turned by i * 2 pi / n about +Z
    angle : radians
    score : normalised score in [0, 1]
    pose : (4, 4) rigid transform of the training-frame query object into the scene (a
        container stood on the surface under it: :meth:`.Detection.pair_pose`)
    point_index : index of the test point in the scene's points
    place : index of the :class:`Place` it lies in (-1: none given)
    """

    position: np.ndarray
    orientation_index: int
    angle: float
    score: float
    pose: np.ndarray
    point_index: int = -1
    place: int = -1

    def __post_init__(self):   # plain NumPy arrays and numbers, whatever made them
        self.position = np.array(self.position, dtype=np.float64).reshape(3)
        self.pose = np.array(self.pose, dtype=np.float64).reshape(4, 4)
        self.orientation_index = int(self.orientation_index)
        self.angle = float(self.angle)
        self.score = float(self.score)
        self.point_index = int(self.point_index)
        self.place = int(self.place)

    def __repr__(self) -> str:
        x, y, z = self.position
        return (f"Prediction(score={self.score:.3f}, position=({x:.3f}, {y:.3f}, {z:.3f}), "
                f"angle={np.degrees(self.angle):.0f} deg)")

    def to_dict(self) -> dict:
        return {"position": [float(v) for v in self.position],
                "orientation_index": self.orientation_index, "angle": self.angle,
                "score": self.score, "pose": np.asarray(self.pose).tolist(),
                "point_index": self.point_index, "place": self.place}


def top_k(positions: np.ndarray, scores: np.ndarray, k: int, radius: float,
          index: np.ndarray | None = None, accept=None,
          group: np.ndarray | None = None) -> list[int]:
    """Greedy non-maximum suppression: indices of up to ``k`` best, ``radius`` apart.

    Candidate i is at ``positions[i]``, or at ``positions[index[i]]`` when ``index`` is given
    (the scene's points and the pairs' point indices: no gathered (N, 3) copy).
    Ties in score are broken by the lower index. The candidates are swept best first in
    blocks; within a block, each one is tested against the picks so far at once (the same
    picks as repeatedly taking the best unsuppressed one, without an (N, 3) temporary per
    pick: a million accepted pairs cost their sort order only).

    With ``accept``, a callable taking a candidate's index: a candidate that would be picked
    is asked first and skipped when the answer is False (it suppresses nothing); None ends
    the search with the picks so far. The picks are then those of the same suppression
    among the candidates it accepts, and only candidates that no pick suppresses are asked
    (detection's collision test of its top k).

    With ``group``, (N,) int per candidate (-1: none), a pick suppresses every other
    candidate of its group (one pick per :class:`Place`) and, by the radius, only candidates
    of no group, or all when it has none: two places are two answers however near (a person
    on a desk's edge and on the chair beside it).
    """
    if index is not None:
        index = np.asarray(index)
        return top_k(Gathered(positions, index), scores, k, radius, accept=accept, group=group)
    scores = np.asarray(scores)
    if len(scores) == 0 or k <= 0:
        return []
    if group is not None:
        group = np.asarray(group, np.int64)
        taken = np.zeros(int(group.max(initial=-1)) + 2, bool)   # the last entry: group -1
    order = np.argsort(-scores, kind="stable")          # best first, lower index on ties
    if not np.isfinite(scores).all():
        order = order[np.isfinite(scores[order])]
    picks: list[int] = []
    r2 = float(radius) ** 2
    block = 4096
    for s in range(0, len(order), block):
        idx = order[s:s + block]
        pos = positions[idx]
        free = np.ones(len(idx), bool)
        if picks:
            chosen = positions[picks]
            near = (((pos[:, None, :] - chosen[None, :, :]) ** 2).sum(axis=2) <= r2)
            if group is not None:
                near &= ((group[idx] < 0)[:, None] | (group[picks] < 0)[None, :])
                free &= ~taken[group[idx]]
            free &= ~near.any(axis=1)
        for j in np.flatnonzero(free):            # at most k picks end this loop
            if not free[j]:
                continue
            if accept is not None:
                ok = accept(int(idx[j]))
                if ok is None:
                    return picks
                if not ok:
                    continue
            picks.append(int(idx[j]))
            if len(picks) == k:
                return picks
            near = ((pos - pos[j]) ** 2).sum(axis=1) <= r2
            if group is not None and group[idx[j]] >= 0:
                taken[group[idx[j]]] = True
                near = (near & (group[idx] < 0)) | (group[idx] == group[idx[j]])
            free &= ~near
    return picks


def heat_map(scene, pair_point: np.ndarray, pair_score: np.ndarray,
             pair_accepted: np.ndarray):
    """Per-point heat: the best accepted score of the nearest test point, spread to the
    scene points around it (within 1.5 x spacing), and the accepted orientations per point.

    Returns heat (N,) float64 in [0, 1] and count (N,) int.
    """
    n = len(scene)
    best = np.zeros(n)
    count = np.zeros(n, np.int32)
    if not pair_accepted.any():
        return best, count
    for s in range(0, len(pair_accepted), 1 << 20):     # bounded gathers of accepted pairs
        sl = slice(s, s + (1 << 20))
        acc = pair_accepted[sl]
        np.maximum.at(best, pair_point[sl][acc], pair_score[sl][acc])
        np.add.at(count, pair_point[sl][acc], 1)
    hot = np.flatnonzero(best > 0)
    hot_best = best[hot]                    # the scores spread, before spreading raises them
    tree = cKDTree(scene.points[hot])
    heat = best                             # spread in place: no second (N,) array
    for s in range(0, n, 500_000):          # bounds the query's (distance, index) arrays
        d, j = tree.query(scene.points[s:s + 500_000], distance_upper_bound=1.5 * scene.spacing,
                          workers=-1)
        near = np.flatnonzero(np.isfinite(d))
        heat[s + near] = np.maximum(heat[s + near], hot_best[j[near]])
    return heat, count


def suppression_radius(tensor: InteractionTensor) -> float:
    """Suppression radius (m) of a top k of poses that have no place (a ranking of rejected
    pairs): the query object's width (the larger side of its horizontal bounding box), so
    that their posed objects do not overlap."""
    return float(np.ptp(tensor.query_vertices[:, :2], axis=0).max())


# --------------------------------------------------------------------------- places
@dataclass
class Place:
    """A connected region of accepted pairs: one surface or edge where the interaction can
    happen (a table top, a shelf board, a rail).

    Attributes
    ----------
    index : its rank among the detection's places, by best score (0 is the best)
    score : the best accepted score in it
    pairs : accepted (point, orientation) pairs in it
    points : distinct test points in it
    lo, hi : (3,) corners of the box around its test points, metres
    centroid : (3,) mean of its test points, metres
    """

    index: int
    score: float
    pairs: int
    points: int
    lo: np.ndarray
    hi: np.ndarray
    centroid: np.ndarray

    def __repr__(self) -> str:
        size = " x ".join(f"{v:.2f}" for v in self.hi - self.lo)
        x, y, z = self.centroid
        return (f"Place({self.index}: score={self.score:.3f}, {self.pairs} pairs at "
                f"{self.points} points, centre=({x:.2f}, {y:.2f}, {z:.2f}), {size} m)")

    def to_dict(self) -> dict:
        return {"index": self.index, "score": self.score, "pairs": self.pairs,
                "points": self.points, "lo": [float(v) for v in self.lo],
                "hi": [float(v) for v in self.hi],
                "centroid": [float(v) for v in self.centroid]}


def _frame(normal) -> np.ndarray:
    """(3, 3) orthonormal rows: two directions across ``normal``, then ``normal``."""
    n = np.asarray(normal, np.float64)
    n = n / np.linalg.norm(n)
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(n, a)
    u /= np.linalg.norm(u)
    return np.stack([u, np.cross(n, u), n])


#: Offsets to the 13 cells of a cell's 26 neighbours that come after it (each neighbouring
#: pair of cells is met once).
_FORWARD = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)
                     if (i, j, k) > (0, 0, 0)], np.int64)


def place_cell(spacing: float, sample_fraction: float,
               surface: float | None = None) -> tuple[float, float]:
    """Edges (m) of the cells that join accepted test points into places, (across, along) the
    affordance's normal. Across: two and a half times the typical distance between test
    points (``spacing``, the scene's, / sqrt(``sample_fraction``)), so that the random gaps
    of the draw do not split a surface, whatever the fraction tested. Along: two of
    ``surface`` (the descriptor's spacing; the scene's when None or smaller): the test points
    of a surface lie on it however sparse the scene, so surfaces at different heights (a
    shelf 10 cm above the floor, a rug's top 7 cm above it) stay apart in a sparse cloud as
    in the mesh."""
    typical = spacing / np.sqrt(max(sample_fraction, 1e-6))
    along = spacing if surface is None else min(spacing, surface)
    return float(2.5 * typical), float(2.0 * along)


def group_places(points: np.ndarray, pair_point: np.ndarray, score: np.ndarray,
                 accepted: np.ndarray, cell: tuple[float, float],
                 normal=(0.0, 0.0, 1.0)) -> tuple[np.ndarray, list[Place]]:
    """Group accepted pairs into places: their test points are put in cells (edges ``cell``,
    across and along ``normal``, the affordance's normal), and cells that touch (26
    neighbours) are one place.

    ``points`` are the scene's points; ``pair_point`` and ``score`` are per pair, ``accepted``
    the indices of the accepted pairs. Returns (place of each accepted pair (A,) int64,
    places best first: :class:`Place`, ranked by best score, ties to the lower best pair).
    """
    accepted = np.asarray(accepted, np.int64)
    if len(accepted) == 0:
        return np.zeros(0, np.int64), []
    u, inv = np.unique(pair_point[accepted], return_inverse=True)
    pts = points[u]
    frame = _frame(normal)                              # rows: two across, then along
    local = pts @ frame.T
    edge = np.array([cell[0], cell[0], cell[1]])
    ijk = np.floor((local - local.min(axis=0)) / edge).astype(np.int64)
    dims = ijk.max(axis=0) + 3                          # a margin: neighbour keys stay unique
    ijk += 1

    def key(c):
        return (c[:, 0] * dims[1] + c[:, 1]) * dims[2] + c[:, 2]

    cells, point_cell = np.unique(key(ijk), return_inverse=True)
    n = len(cells)
    cell_ijk = np.column_stack([cells // (dims[1] * dims[2]), (cells // dims[2]) % dims[1],
                                cells % dims[2]])
    rows, cols = [np.arange(n)], [np.arange(n)]
    for off in _FORWARD:
        k = key(cell_ijk + off)
        j = np.minimum(np.searchsorted(cells, k), n - 1)
        hit = cells[j] == k
        rows.append(np.flatnonzero(hit))
        cols.append(j[hit])
    r, c = np.concatenate(rows), np.concatenate(cols)
    _, cell_label = connected_components(coo_matrix((np.ones(len(r), np.int8), (r, c)),
                                                    shape=(n, n)), directed=False)
    pair_label = cell_label[point_cell[inv]]
    point_label = cell_label[point_cell]
    m = int(cell_label.max()) + 1
    # each place's best pair (the lower pair on equal scores, as top_k breaks ties)
    by_rank = np.lexsort((accepted, -score[accepted]))
    _, first = np.unique(pair_label[by_rank], return_index=True)
    best_pair = accepted[by_rank[first]]
    best = score[best_pair]
    order = np.lexsort((best_pair, -best))              # best score first, then lower pair
    rank = np.empty(m, np.int64)
    rank[order] = np.arange(m)
    pair_place = rank[pair_label]
    point_place = rank[point_label]
    n_pairs = np.bincount(pair_place, minlength=m)
    n_points = np.bincount(point_place, minlength=m)
    lo = np.full((m, 3), np.inf)
    hi = np.full((m, 3), -np.inf)
    np.minimum.at(lo, point_place, pts)
    np.maximum.at(hi, point_place, pts)
    centre = np.zeros((m, 3))
    np.add.at(centre, point_place, pts)
    centre /= n_points[:, None]
    places = [Place(i, float(best[order[i]]), int(n_pairs[i]), int(n_points[i]), lo[i], hi[i],
                    centre[i]) for i in range(m)]
    return pair_place, places
