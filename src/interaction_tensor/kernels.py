"""Numba kernels: exact nearest neighbours on a uniform grid and the per-pair scoring loop.

These compute the same thing as :func:`interaction_tensor.scoring.score_pairs` with SciPy's
cKDTree, one (test point, orientation) pair per thread, keypoints in weight order, stopping a
pair as soon as its decision is known. The nearest-neighbour search is exact: it visits grid
shells around the query until no unvisited cell can hold a closer point.

Numba is imported lazily; :func:`available` says whether it can be used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .scoring import paper_limits

_KERNELS = None
#: Largest number of grid cells (dense start table, 8 bytes each).
MAX_CELLS = 20_000_000
#: Pairs per work unit handed to a thread by the scoring kernel.
PARALLEL_CHUNK = 64


def available() -> bool:
    """True when Numba imports."""
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


@dataclass
class Grid:
    """Scene points sorted into a uniform grid of cubic cells.

    Attributes
    ----------
    points, normals : (N, 3) float64 sorted by cell
    order : (N,) int64, original index of each sorted point
    starts : (C + 1,) int64, points of cell c are ``starts[c]:starts[c + 1]``
    seed : (C,) int32, the non-empty cell whose centre is nearest to each cell's centre
    origin : (3,) float64, corner of cell (0, 0, 0)
    cell : float, cell edge (m)
    dims : (3,) int64 cells per axis
    """

    points: np.ndarray
    normals: np.ndarray
    order: np.ndarray
    starts: np.ndarray
    seed: np.ndarray
    origin: np.ndarray
    cell: float
    dims: np.ndarray


def build_grid(points: np.ndarray, normals: np.ndarray, cell: float) -> Grid:
    """Sort ``points`` into cells of edge ``cell`` (enlarged if the grid would be too big)."""
    lo = points.min(axis=0) - 1e-9
    extent = np.ptp(points, axis=0) + 2e-9
    cell = float(max(cell, (np.prod(extent + cell) / MAX_CELLS) ** (1 / 3), 1e-6))
    dims = np.maximum(np.ceil(extent / cell).astype(np.int64), 1)
    ijk = np.minimum(((points - lo) / cell).astype(np.int64), dims - 1)
    lin = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    order = np.argsort(lin, kind="stable")
    counts = np.bincount(lin, minlength=int(np.prod(dims)))
    starts = np.zeros(len(counts) + 1, np.int64)
    np.cumsum(counts, out=starts[1:])
    return Grid(np.ascontiguousarray(points[order]), np.ascontiguousarray(normals[order]),
                order, starts, _nearest_occupied(counts, dims), lo, cell, dims)


def _nearest_occupied(counts: np.ndarray, dims: np.ndarray) -> np.ndarray:
    """(C,) int32 linear index of the non-empty cell nearest to each cell (exact Euclidean
    distance transform of the occupancy, SciPy)."""
    from scipy.ndimage import distance_transform_edt

    empty = (counts == 0).reshape(tuple(dims))
    if not empty.any():
        return np.arange(len(counts), dtype=np.int32)
    ind = distance_transform_edt(empty, return_distances=False, return_indices=True)
    ind = ind.astype(np.int32, copy=False)
    lin = (ind[0] * int(dims[1]) + ind[1]) * int(dims[2]) + ind[2]
    return np.ascontiguousarray(lin.ravel(), dtype=np.int32)


def _compile():
    global _KERNELS
    if _KERNELS is None:
        import warnings

        # numba notes an old system TBB once per process and falls back to OpenMP: not the
        # user's concern
        warnings.filterwarnings("ignore", message=".*TBB.*")
        from . import _numba_kernels as nk

        _KERNELS = {"score": nk.score, "nearest_many": nk.nearest_many}
    return _KERNELS


def nearest_indices(grid: Grid, queries: np.ndarray) -> np.ndarray:
    """Exact nearest scene point (original index) of each query, (Q,) int64."""
    k = _compile()
    out = np.empty(len(queries), np.int64)
    k["nearest_many"](np.ascontiguousarray(queries, dtype=np.float64), grid.points,
                      grid.starts, grid.seed, grid.origin, grid.cell, grid.dims, out)
    return grid.order[out]


@dataclass
class ScoreJob:
    """One keypoint table to score over a set of (test point, orientation) pairs."""

    points: np.ndarray
    orient: np.ndarray
    table: object
    threshold: float
    vectors: str = "surface"
    rho: float = 0.01
    early_exit: bool = True


def _job_args(job: ScoreJob, grid: Grid) -> tuple:
    t = job.table
    pnorm = np.ascontiguousarray(np.linalg.norm(t.provenance[0], axis=1))
    big_w, cos_lim = paper_limits(t)
    return (np.ascontiguousarray(t.offsets), np.ascontiguousarray(t.provenance), pnorm,
            np.ascontiguousarray(t.weights), cos_lim, big_w, t.max_terms, t.rest,
            0 if t.criterion == "paper" else 1, t.c, t.a, float(t.weights.sum()),
            float(job.threshold), bool(job.early_exit), job.vectors == "surface",
            float(job.rho), grid.points, grid.normals, grid.starts, grid.seed, grid.origin, grid.cell,
            grid.dims)


def score_jobs(jobs: list, grid: Grid) -> list:
    """Score several jobs (e.g. several affordances) over one scene grid.

    Every nearest neighbour is exact: the results are identical to
    :func:`interaction_tensor.scoring.score_pairs`. Returns, per job, (score, accepted,
    decided_at, comparisons) arrays over its pairs.
    """
    k = _compile()
    outs = []
    for job in jobs:
        p = len(job.points)
        out = (np.zeros(p), np.zeros(p, np.bool_), np.zeros(p, np.int64), np.zeros(p, np.int64))
        if p:
            import numba

            # pairs differ a lot in cost (an accepted pair compares every keypoint): hand
            # them to the threads in small chunks rather than one static half each
            previous = numba.set_parallel_chunksize(PARALLEL_CHUNK)
            try:
                k["score"](np.ascontiguousarray(job.points, dtype=np.float64),
                           np.ascontiguousarray(job.orient, np.int64), *_job_args(job, grid),
                           *out)
            finally:
                numba.set_parallel_chunksize(previous)
        outs.append(out)
    return outs


def score_pairs_numba(points, orient, table, grid: Grid, threshold: float, vectors: str,
                      rho: float, early_exit: bool = True):
    """Numba version of :func:`interaction_tensor.scoring.score_pairs` (one job of
    :func:`score_jobs`). Returns score, accepted, decided_at, comparisons-per-pair arrays."""
    job = ScoreJob(points, orient, table, threshold, vectors, rho, early_exit)
    return score_jobs([job], grid)[0]
