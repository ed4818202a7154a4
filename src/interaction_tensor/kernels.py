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

_KERNELS = None
#: Largest number of grid cells (dense start table, 8 bytes each).
MAX_CELLS = 20_000_000
#: Largest nearest-neighbour cache of one tile (int32 entries).
MAX_CACHE_CELLS = 8_000_000


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
    origin : (3,) float64, corner of cell (0, 0, 0)
    cell : float, cell edge (m)
    dims : (3,) int64 cells per axis
    """

    points: np.ndarray
    normals: np.ndarray
    order: np.ndarray
    starts: np.ndarray
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
                order, starts, lo, cell, dims)


def _compile():
    global _KERNELS
    if _KERNELS is None:
        from . import _numba_kernels as nk

        _KERNELS = {"score": nk.score, "nearest_many": nk.nearest_many}
    return _KERNELS


def nearest_indices(grid: Grid, queries: np.ndarray) -> np.ndarray:
    """Exact nearest scene point (original index) of each query, (Q,) int64."""
    k = _compile()
    out = np.empty(len(queries), np.int64)
    k["nearest_many"](np.ascontiguousarray(queries, dtype=np.float64), grid.points,
                      grid.starts, grid.origin, grid.cell, grid.dims, out)
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
    wmax = t.weights.max()
    with np.errstate(divide="ignore"):
        big_w = np.where(t.weights > 0, wmax / np.where(t.weights > 0, t.weights, 1), np.inf)
    angle_lim = np.minimum(big_w * t.theta_max, np.pi)   # angle limit per keypoint
    rest = np.r_[np.cumsum(t.max_terms[::-1])[::-1], 0.0]
    return (np.ascontiguousarray(t.offsets), np.ascontiguousarray(t.provenance), pnorm,
            np.ascontiguousarray(t.weights), angle_lim, big_w, t.max_terms, rest,
            0 if t.criterion == "paper" else 1, t.c, t.a, float(t.weights.sum()),
            float(job.threshold), bool(job.early_exit), job.vectors == "surface",
            float(job.rho), grid.points, grid.normals, grid.starts, grid.origin, grid.cell,
            grid.dims)


def score_jobs(jobs: list, grid: Grid, cache_cell: float | None = None) -> list:
    """Score several jobs (e.g. several affordances) over one scene grid.

    With ``cache_cell`` None every nearest neighbour is exact and the results are identical
    to :func:`interaction_tensor.scoring.score_pairs`. With ``cache_cell`` h, a keypoint uses
    the nearest sample of the centre of its h-sized cell, found once and shared by every
    keypoint of every job that falls in that cell (the authors' agglomerative descriptor);
    the vector is still measured from the keypoint itself. The pairs are processed in cubic
    tiles so that each tile's cache stays small.

    Returns, per job, (score, accepted, decided_at, comparisons) arrays over its pairs.
    """
    k = _compile()
    outs, args = [], []
    for job in jobs:
        p = len(job.points)
        job.points = np.ascontiguousarray(job.points, dtype=np.float64)
        job.orient = np.ascontiguousarray(job.orient, np.int64)
        outs.append((np.zeros(p), np.zeros(p, np.bool_), np.zeros(p, np.int64),
                     np.zeros(p, np.int64)))
        args.append(_job_args(job, grid))
    if not cache_cell:
        for job, a, o in zip(jobs, args, outs):
            if len(job.points):
                k["score"](job.points, job.orient, *a, *o, False, np.full(1, -1, np.int32),
                           np.zeros(3), 1.0, np.ones(3, np.int64))
        return outs
    reach = max(float(np.abs(j.table.offsets).max()) for j in jobs) + cache_cell
    tile = max(0.1, (MAX_CACHE_CELLS ** (1 / 3)) * cache_cell - 2 * reach)
    all_points = np.vstack([j.points for j in jobs])
    if len(all_points) == 0:
        return outs
    keys = np.floor(all_points / tile).astype(np.int64)
    uniq, tile_of = np.unique(keys, axis=0, return_inverse=True)
    tile_of = tile_of.ravel()
    starts = np.cumsum([0] + [len(j.points) for j in jobs])
    for t in range(len(uniq)):
        members = tile_of == t
        tp_all = all_points[members]
        co = tp_all.min(axis=0) - reach
        cd = np.ceil((tp_all.max(axis=0) + reach - co) / cache_cell).astype(np.int64) + 1
        cache_arr = np.full(int(np.prod(cd)), -1, np.int32)
        for j, (job, a, o) in enumerate(zip(jobs, args, outs)):
            sel = np.flatnonzero(members[starts[j]:starts[j + 1]])
            if len(sel) == 0:
                continue
            res = (np.empty(len(sel)), np.empty(len(sel), np.bool_),
                   np.empty(len(sel), np.int64), np.empty(len(sel), np.int64))
            k["score"](job.points[sel], job.orient[sel], *a, *res, True, cache_arr, co,
                       float(cache_cell), cd)
            for dst, src in zip(o, res):
                dst[sel] = src
    return outs


def score_pairs_numba(points, orient, table, grid: Grid, threshold: float, vectors: str,
                      rho: float, early_exit: bool = True, cache_cell: float | None = None):
    """Numba version of :func:`interaction_tensor.scoring.score_pairs` (one job of
    :func:`score_jobs`). Returns score, accepted, decided_at, comparisons-per-pair arrays."""
    job = ScoreJob(points, orient, table, threshold, vectors, rho, early_exit)
    return score_jobs([job], grid, cache_cell)[0]
