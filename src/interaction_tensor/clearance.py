"""The clearance test: does a placement leave the query object the room it had in the example?

The Interaction Tensor describes the space *between* the two objects of the example; it says
little about the rest of the query object's surroundings, where its provenance vectors are
long and its tests lenient. So a chair's seat can match a stool's top while a table edge cuts
through the seated person's knees. The authors' later iTClearance work adds vectors from the
query object into the free space around it; here, each of ``K`` clearance points (area samples
of the query object's surface, training frame) keeps its free space ``r`` in the example (the
distance to the scene-object's sampled surface, at most ``clearance_max``). A placement
violates a clearance point when a scene sample lies nearer to it than ``r - tolerance``: the
scene comes closer to the object than it did in the example, where the example had room. A
sample is never nearer than the surface it lies on, so sparse sampling cannot cause a
violation (it can only hide one). Contact points have ``r`` near 0 and can never be violated;
the rest of the object must keep at least ``clearance_max - tolerance`` (1.5 cm by default)
from the scene.
"""

from __future__ import annotations

import numpy as np

from .scoring import rotation_z

#: Nearest-neighbour queries per chunk (bounds memory: about 100 bytes each).
CHUNK_QUERIES = 2_000_000


def clearance_offsets(tensor, n_orientations: int) -> np.ndarray:
    """(O, K, 3) clearance points relative to a test point, per orientation
    (``Rz(angle) (c - reference_point)``)."""
    rot = rotation_z(2 * np.pi * np.arange(n_orientations) / n_orientations)
    rel = np.asarray(tensor.clearance_points, float) - tensor.reference_point
    return np.einsum("oij,kj->oki", rot, rel)


def violations(points: np.ndarray, orient: np.ndarray, offsets: np.ndarray,
               radius: np.ndarray, tolerance: float, nearest_distance) -> np.ndarray:
    """Clearance points violated by each placement.

    Parameters
    ----------
    points : (P, 3) test points, metres
    orient : (P,) int orientation index of each placement
    offsets : (O, K, 3) from :func:`clearance_offsets`
    radius : (K,) free space of each clearance point in the example (m)
    tolerance : metres
    nearest_distance : callable mapping (Q, 3) queries to the (Q,) distance (m) of their
        nearest scene sample

    Returns (P,) int64 counts in [0, K].
    """
    points = np.asarray(points, float)
    orient = np.asarray(orient, np.int64)
    k = offsets.shape[1]
    out = np.zeros(len(points), np.int64)
    if k == 0 or len(points) == 0:
        return out
    need = np.asarray(radius, float) - tolerance            # (K,)
    active = np.flatnonzero(need > 0)
    if len(active) == 0:
        return out
    off = offsets[:, active]
    need = need[active]
    step = max(1, CHUNK_QUERIES // len(active))
    for s in range(0, len(points), step):
        q = points[s:s + step, None, :] + off[orient[s:s + step]]     # (p, k, 3)
        d = np.asarray(nearest_distance(q.reshape(-1, 3))).reshape(q.shape[:2])
        out[s:s + step] = (d < need).sum(axis=1)
    return out


def count_violations(points: np.ndarray, orient: np.ndarray, offsets: np.ndarray,
                     radius: np.ndarray, tolerance: float, scene, grid=None) -> np.ndarray:
    """:func:`violations` of placements in ``scene``: on the Numba grid (``grid``, exact
    ball-emptiness tests, ``_numba_clearance``) when one is given, else with the scene's
    cKDTree (the reference). Returns (P,) int64."""
    if grid is None:
        return violations(points, orient, offsets, radius, tolerance,
                          nearest_distance_function(scene, None, float(np.max(radius, initial=0))))
    from . import _numba_clearance

    need = np.asarray(radius, float) - tolerance
    active = np.flatnonzero(need > 0)
    if len(active) == 0 or len(points) == 0:
        return np.zeros(len(points), np.int64)
    return _numba_clearance.counts(points, np.ascontiguousarray(orient, np.int64),
                                   offsets[:, active], need[active], grid)


def nearest_distance_function(scene, grid=None, bound: float | None = None):
    """A ``nearest_distance`` for :func:`violations`: the distance (m) to the nearest scene
    sample, or ``inf`` beyond ``bound`` (the test only asks whether a sample is nearer than
    the largest clearance, so a bounded search is exact for it and fast in open space). The
    scene's cKDTree; ``grid`` is accepted for symmetry with the scoring backends."""
    def dist(q):
        return scene.tree.query(q, distance_upper_bound=np.inf if bound is None else bound,
                                workers=-1)[0]
    return dist
