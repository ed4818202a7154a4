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


def score_pairs_numba(points, orient, table, grid: Grid, threshold: float, vectors: str,
                      rho: float, early_exit: bool = True, cache_cell: float | None = None):
    """Numba version of :func:`interaction_tensor.scoring.score_pairs`.

    With ``cache_cell`` None the nearest neighbours are exact and the results identical to
    the NumPy path. With ``cache_cell`` h, a keypoint uses the nearest sample of the centre of
    its h-sized cell, found once per cell and shared by every keypoint that falls in it (the
    authors' agglomerative trick); the vector is still measured from the keypoint itself.

    Returns score, accepted, decided_at, comparisons-per-pair arrays.
    """
    k = _compile()
    n = table.n
    pnorm = np.ascontiguousarray(np.linalg.norm(table.provenance[0], axis=1))
    wmax = table.weights.max()
    with np.errstate(divide="ignore"):
        big_w = np.where(table.weights > 0, wmax / np.where(table.weights > 0, table.weights, 1), np.inf)
    angle_lim = np.minimum(big_w * table.theta_max, np.pi)   # angle limit per keypoint
    rest = np.r_[np.cumsum(table.max_terms[::-1])[::-1], 0.0]
    p = len(points)
    out_score = np.empty(p)
    out_acc = np.empty(p, np.bool_)
    out_at = np.empty(p, np.int64)
    out_cmp = np.empty(p, np.int64)
    args = (np.ascontiguousarray(table.offsets), np.ascontiguousarray(table.provenance),
            pnorm, np.ascontiguousarray(table.weights), angle_lim, big_w, table.max_terms,
            rest, 0 if table.criterion == "paper" else 1, table.c, table.a,
            float(table.weights.sum()), float(threshold), bool(early_exit),
            vectors == "surface", float(rho), grid.points, grid.normals, grid.starts,
            grid.origin, grid.cell, grid.dims)
    points = np.ascontiguousarray(points, dtype=np.float64)
    orient = np.ascontiguousarray(orient, np.int64)
    if not cache_cell:
        k["score"](points, orient, *args, out_score, out_acc, out_at, out_cmp,
                   False, np.full(1, -1, np.int32), np.zeros(3), 1.0, np.ones(3, np.int64))
        return out_score, out_acc, out_at, out_cmp
    # cached: split the pairs into cubic tiles so that each tile's cache stays small
    reach = float(np.abs(table.offsets).max()) + cache_cell
    tile = max(0.1, (MAX_CACHE_CELLS ** (1 / 3)) * cache_cell - 2 * reach)
    key = np.floor(points / tile).astype(np.int64)
    _, tile_of = np.unique(key, axis=0, return_inverse=True)
    tile_of = tile_of.ravel()
    order = np.argsort(tile_of, kind="stable")
    bounds = np.flatnonzero(np.diff(tile_of[order])) + 1
    for sel in np.split(order, bounds):
        tp = points[sel]
        co = tp.min(axis=0) - reach
        cd = np.ceil((tp.max(axis=0) + reach - co) / cache_cell).astype(np.int64) + 1
        cache_arr = np.full(int(np.prod(cd)), -1, np.int32)
        o_s, o_a = np.empty(len(sel)), np.empty(len(sel), np.bool_)
        o_t, o_c = np.empty(len(sel), np.int64), np.empty(len(sel), np.int64)
        k["score"](tp, orient[sel], *args, o_s, o_a, o_t, o_c, True, cache_arr, co,
                   float(cache_cell), cd)
        out_score[sel], out_acc[sel], out_at[sel], out_cmp[sel] = o_s, o_a, o_t, o_c
    return out_score, out_acc, out_at, out_cmp
