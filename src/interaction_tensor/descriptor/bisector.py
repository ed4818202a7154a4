"""The bisector surface between two point sets, from their Voronoi diagram (qhull).

A bisector point is a Voronoi vertex on a ridge that separates cells of different objects
(paper, section 3.1). In the dual Delaunay tetrahedralisation a Voronoi vertex is the
circumcentre of a tetrahedron, and a ridge between cells of points a and b is the dual of
the edge (a, b); so a Voronoi vertex lies on a ridge between objects exactly when its
tetrahedron has corners on both objects. :func:`bisector_points` uses that identity to stay
vectorised; :func:`bisector_points_voronoi` walks SciPy's Voronoi ridges and is kept as the
plain reference the tests compare against.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay, Voronoi

from interaction_tensor.errors import InputError

#: Relative size of the seeded jitter added before qhull: coplanar samples (a table top) make
#: qhull's exact-arithmetic merging very slow; a jitter of 1e-7 of the extent (0.1 um on a
#: metre) removes the degeneracy without moving anything measurably.
JITTER = 1e-7


def _labelled(query_points, scene_points, seed=0):
    points = np.vstack([query_points, scene_points]).astype(np.float64)
    scale = JITTER * float(np.ptp(points, axis=0).max())
    points = points + np.random.default_rng(seed).normal(scale=scale, size=points.shape)
    labels = np.r_[np.zeros(len(query_points), bool), np.ones(len(scene_points), bool)]
    if len(query_points) < 4 or len(scene_points) < 4:
        raise InputError(None, "each object needs at least 4 points for a bisector")
    return points, labels


def circumcentres(tetrahedra: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Circumcentres of tetrahedra.

    Parameters
    ----------
    tetrahedra : (T, 4, 3) float64 corner coordinates

    Returns
    -------
    centres : (T, 3) float64; rows of flat tetrahedra are NaN
    ok : (T,) bool, False for flat (degenerate) tetrahedra
    """
    a = tetrahedra[:, 0]
    e = tetrahedra[:, 1:] - a[:, None, :]          # (T, 3, 3) edge vectors
    rhs = 0.5 * np.einsum("tij,tij->ti", e, e)     # |e_i|^2 / 2
    det = np.linalg.det(e)
    scale = np.einsum("tij,tij->t", e, e) ** 1.5
    ok = np.abs(det) > 1e-12 * np.maximum(scale, 1e-300)
    centres = np.full(a.shape, np.nan)
    if ok.any():
        centres[ok] = a[ok] + np.linalg.solve(e[ok], rhs[ok][..., None])[..., 0]
    return centres, ok


def bisector_points(query_points: np.ndarray, scene_points: np.ndarray, seed: int = 0) -> np.ndarray:
    """Voronoi vertices on ridges between the two objects' cells.

    Parameters
    ----------
    query_points : (Nq, 3) float, metres
    scene_points : (Ns, 3) float, metres

    Returns
    -------
    (M, 3) float64 bisector points (unique), metres
    """
    points, labels = _labelled(query_points, scene_points, seed)
    try:
        tri = Delaunay(points, qhull_options="Qbb Qc Qz Q12 Qt")
    except Exception as exc:  # qhull errors: flat or degenerate input
        raise InputError(None, f"Voronoi/Delaunay of the example failed: {exc}") from None
    corner_labels = labels[tri.simplices]
    mixed = corner_labels.any(axis=1) & ~corner_labels.all(axis=1)
    centres, ok = circumcentres(points[tri.simplices[mixed]])
    centres = centres[ok]
    # Cospherical points give several tetrahedra with one circumcentre (qhull's Qt option
    # triangulates them); keep one copy, as the Voronoi diagram has one vertex.
    key = np.round(centres / 1e-9).astype(np.int64)
    _, first = np.unique(key, axis=0, return_index=True)
    return centres[np.sort(first)]


def bisector_points_voronoi(query_points: np.ndarray, scene_points: np.ndarray,
                            seed: int = 0) -> np.ndarray:
    """Reference: the same set through ``scipy.spatial.Voronoi`` ridges (slower)."""
    points, labels = _labelled(query_points, scene_points, seed)
    vor = Voronoi(points)
    rp = vor.ridge_points
    cross = labels[rp[:, 0]] != labels[rp[:, 1]]
    ids = {v for i in np.flatnonzero(cross) for v in vor.ridge_vertices[i] if v >= 0}
    return vor.vertices[sorted(ids)]


def trim_to_sphere(points: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """Boolean mask of ``points`` within ``radius`` (m) of ``centre``."""
    return np.linalg.norm(points - np.asarray(centre), axis=1) <= radius
