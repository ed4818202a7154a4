"""The scene's uniform grid: points sorted into cubic cells, for exact nearest-neighbour
search by the Numba kernels (:mod:`interaction_tensor.engine.numba_backend`) and the
placement tests.

A grid costs its cell tables only when the points are already in cell order (a
:class:`~interaction_tensor.geometry.scene.Scene` sorts them so): ``starts`` (8 bytes a cell),
``seed`` (the nearest non-empty cell of each cell, 4 bytes) and the block occupancy ``occ``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Block edge, in grid cells, of the grid's block occupancy (:attr:`Grid.occ`; also the
#: cache builder's, :data:`CACHE_OCC_CELLS`). Compiled into the Numba kernels.
FAR_BLOCK = 4


#: A nearest-neighbour query whose seed sample is farther than this (grid cells) searches
#: the occupied blocks of :attr:`Grid.occ` instead of every cell of the shells around it: a
#: seated person's head, 1 m above a desk frame of 6 cm cells, visited ~20,000 empty cells
#: per query (benchmarks/kernel_speed.py). Compiled into the Numba kernels.
FAR_CELLS = 3.0


#: Largest number of grid cells (dense start table, 8 bytes each).
MAX_CELLS = 20_000_000


@dataclass
class Grid:
    """Scene points sorted into a uniform grid of cubic cells.

    Attributes
    ----------
    points, normals : (N, 3) float64 sorted by cell
    order : (N,) int64, original index of each sorted point; None when the points were
        already in cell order (the grid then shares the scene's arrays)
    starts : (C + 1,) int32 (int64 beyond 2**31 points), points of cell c are
        ``starts[c]:starts[c + 1]``
    seed : (C,) int32, the non-empty cell whose centre is nearest to each cell's centre
        (a search starts there; the nearest one, not merely a near one: a coarser table
        of 4^3-cell blocks saved 3 bytes a cell and cost 12 % of kitchen5's scoring time)
    origin : (3,) float64, corner of cell (0, 0, 0)
    cell : float, cell edge (m)
    dims : (3,) int64 cells per axis
    occ : (ceil(nx / FAR_BLOCK) * ceil(ny / FAR_BLOCK) * ceil(nz / FAR_BLOCK),) int8, 1 where
        a block of FAR_BLOCK^3 cells holds a point (the far queries' search, :func:`nearest`)
    cache : the :class:`NeighbourCache` of :func:`score_jobs` (None until first used)
    """

    points: np.ndarray
    normals: np.ndarray
    order: np.ndarray
    starts: np.ndarray
    seed: np.ndarray
    origin: np.ndarray
    cell: float
    dims: np.ndarray
    occ: np.ndarray = field(default=None, repr=False, compare=False)
    cache: object = field(default=None, repr=False, compare=False)
    _free: np.ndarray = field(default=None, repr=False, compare=False)

    @property
    def free(self) -> np.ndarray:
        """(C,) float32: :func:`free_distances` of the cells (built on first use, kept: the
        placement tests of every descriptor read it)."""
        if self._free is None:
            self._free = free_distances(self)
        return self._free


def grid_cells(points: np.ndarray, cell: float):
    """(lin, lo, cell, dims): the linear cell index of each point in the grid of edge
    ``cell`` (enlarged if the grid would have more than :data:`MAX_CELLS` cells); ``lin`` is
    int32 when the cells fit, computed in blocks (no (N, 3) temporaries)."""
    lo = points.min(axis=0) - 1e-9
    extent = np.ptp(points, axis=0) + 2e-9
    cell = float(max(cell, (np.prod(extent + cell) / MAX_CELLS) ** (1 / 3), 1e-6))
    dims = np.maximum(np.ceil(extent / cell).astype(np.int64), 1)
    lin = np.empty(len(points), np.int32 if np.prod(dims) < 2 ** 31 else np.int64)
    for s in range(0, len(points), 1 << 18):
        ijk = ((points[s:s + (1 << 18)] - lo) / cell).astype(np.int64)
        np.minimum(ijk, dims - 1, out=ijk)
        lin[s:s + (1 << 18)] = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    return lin, lo, cell, dims


class KNearest:
    """Points sorted into the cells of a uniform grid once: the points in a box
    (:meth:`within`), and exact k-nearest-neighbour search (a Numba kernel,
    :func:`~interaction_tensor.geometry._normals.knn`): each query's neighbours gathered
    from shells of cells around its own until the k-th lies nearer than any cell not yet searched. With cells a little wider
    than the k-th neighbour's distance on a surface (:func:`knn_cell`), one shell of 27
    cells answers most queries; a cloud of very uneven density costs more shells where it
    is sparse and more points per cell where it is dense, never a wrong answer; a query
    farther than :data:`KNN_SHELLS` shells from its k-th neighbour (in the air, far from
    the cloud) is answered by a k-d tree instead."""

    def __init__(self, points: np.ndarray, cell: float):
        points = np.ascontiguousarray(points, np.float64)
        self._tree = None
        lin, self.origin, self.cell, self.dims = grid_cells(points, cell)
        self.order = np.argsort(lin, kind="stable")
        lin = lin[self.order]
        self.points = np.ascontiguousarray(points[self.order])
        n_cells = int(np.prod(self.dims))
        # cell c's first point, or the next occupied cell's: each occupied cell's first
        # position, then a running minimum from the end
        self.starts = np.full(n_cells + 1, len(points),
                              np.int32 if len(points) < 2 ** 31 else np.int64)
        first = np.flatnonzero(np.diff(lin, prepend=-1))
        self.starts[lin[first]] = first
        del first
        np.minimum.accumulate(self.starts[::-1], out=self.starts[::-1])

    def query(self, queries: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """((Q, k) distances, (Q, k) int64 indices into the points), nearest first, as
        ``cKDTree.query(queries, k)`` gives them (equal distances in no set order)."""
        from interaction_tensor.geometry._normals import knn

        queries = np.ascontiguousarray(queries, np.float64)
        k = int(min(k, len(self.points)))
        d2 = np.empty((len(queries), k))
        idx = np.empty((len(queries), k), np.int64)
        nx, ny, nz = (int(v) for v in self.dims)
        knn(self.points, self.starts, np.asarray(self.origin, np.float64), float(self.cell),
            nx, ny, nz, queries, k, KNN_SHELLS, d2, idx)
        dist = np.sqrt(d2)
        far = np.flatnonzero(idx[:, 0] < 0)
        if len(far):                              # far from every point: the k-d tree's
            from scipy.spatial import cKDTree

            if self._tree is None:
                self._tree = cKDTree(self.points)
            fd, fi = self._tree.query(queries[far], k=k)
            dist[far], idx[far] = fd.reshape(len(far), k), fi.reshape(len(far), k)
        return dist, self.order[idx]

    def within(self, lo, hi) -> np.ndarray:
        """(int64) indices of the points in the cells that meet the box ``lo``-``hi``: a
        superset of those in the box, gathered as slices of the cell order (no list a
        point)."""
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        if (hi < self.origin).any() or (lo > self.origin + self.dims * self.cell).any():
            return np.zeros(0, np.int64)
        a = np.clip(np.floor((lo - self.origin) / self.cell).astype(np.int64), 0, self.dims - 1)
        b = np.clip(np.floor((hi - self.origin) / self.cell).astype(np.int64), 0, self.dims - 1)
        i, j = np.meshgrid(np.arange(a[0], b[0] + 1), np.arange(a[1], b[1] + 1), indexing="ij")
        row = (i.ravel() * self.dims[1] + j.ravel()) * self.dims[2]
        first = self.starts[row + a[2]].astype(np.int64)
        count = self.starts[row + b[2] + 1] - first
        if not count.sum():
            return np.zeros(0, np.int64)
        idx = np.repeat(first - np.cumsum(count) + count, count) + np.arange(count.sum())
        return self.order[idx]


#: Shells of cells a :class:`KNearest` query searches before the k-d tree answers it.
KNN_SHELLS = 6


def knn_cell(spacing: float, k: int) -> float:
    """A :class:`KNearest` cell edge (m) for ``k`` neighbours of a surface sampled
    ``spacing`` apart: the k-th lies about sqrt(k / pi) spacings away, and a query's shell of
    27 cells reaches at least a cell past its own, so cells of 0.65 sqrt(k) spacings (2.6 for
    16) settle most queries in one shell."""
    return 0.65 * np.sqrt(max(int(k), 1)) * float(spacing)


def build_grid(points: np.ndarray, normals: np.ndarray, cell: float) -> Grid:
    """Sort ``points`` into cells of edge ``cell`` (enlarged if the grid would be too big).

    Points already in cell order (a :class:`Scene` from :func:`prepare_scene`) are used as
    they are, not copied: the grid then costs its cell tables only (8 bytes a cell)."""
    lin, lo, cell, dims = grid_cells(points, cell)
    if np.all(lin[1:] >= lin[:-1]):                # already in cell order: share the arrays
        order = None
        sorted_points, sorted_normals = points, normals
    else:
        order = np.argsort(lin, kind="stable")
        sorted_points, sorted_normals = points[order], normals[order]
        lin = lin[order]
    n_cells = int(np.prod(dims))
    # int32 cell starts when they fit: the dense table is the grid's largest part; found by
    # bisection of the sorted cell indices, a block of cells at a time (no int64 counts)
    starts = np.empty(n_cells + 1, np.int32 if len(points) < 2 ** 31 else np.int64)
    for c in range(0, n_cells + 1, 1 << 20):
        starts[c:c + (1 << 20)] = np.searchsorted(lin, np.arange(c, min(c + (1 << 20),
                                                                       n_cells + 1)))
    occupied = lin[np.r_[True, lin[1:] != lin[:-1]]] if len(lin) else lin
    del lin
    seed = _nearest_occupied(occupied, dims)
    grid = Grid(np.ascontiguousarray(sorted_points), np.ascontiguousarray(sorted_normals),
                order, starts, seed, lo, cell, dims)
    grid.occ = _block_occupancy(grid, FAR_BLOCK)
    return grid


def _nearest_occupied(occupied: np.ndarray, dims: np.ndarray) -> np.ndarray:
    """(C,) int32 linear index of the non-empty cell nearest to each cell (exact Euclidean
    distance transform of the occupancy, SciPy), from the sorted non-empty cells; int32 in
    place throughout (about 20 bytes a cell at its peak, 4 kept)."""
    from scipy.ndimage import distance_transform_edt

    n_cells = int(np.prod(dims))
    if len(occupied) == n_cells:
        return np.arange(n_cells, dtype=np.int32)
    empty = np.ones(n_cells, bool)
    empty[occupied] = False
    ind = np.empty((3,) + tuple(int(d) for d in dims), np.int32)   # SciPy fills it in place
    distance_transform_edt(empty.reshape(tuple(dims)), return_distances=False,
                           return_indices=True, indices=ind)
    del empty
    # (i * ny + j) * nz + k in int32, in a copy: a view of ind[0] would keep all of ind
    # (12 bytes a cell) alive for as long as the grid
    lin = ind[0].reshape(-1).copy()
    lin *= int(dims[1])
    lin += ind[1].reshape(-1)
    lin *= int(dims[2])
    lin += ind[2].reshape(-1)
    return lin


def _block_occupancy(grid: Grid, cb: int) -> np.ndarray:
    """(ceil(nx / cb) * ceil(ny / cb) * ceil(nz / cb),) int8: 1 where a block of cb^3 grid
    cells holds a sample."""
    nx, ny, nz = (int(v) for v in grid.dims)
    full = (np.diff(grid.starts) > 0).reshape(nx, ny, nz)
    mb = [-(-v // cb) for v in (nx, ny, nz)]
    pad = np.zeros([v * cb for v in mb], bool)
    pad[:nx, :ny, :nz] = full
    occ = pad.reshape(mb[0], cb, mb[1], cb, mb[2], cb).any(axis=(1, 3, 5))
    return np.ascontiguousarray(occ.ravel(), dtype=np.int8)


def free_distances(grid: Grid) -> np.ndarray:
    """(C,) float32: for each cell, the least distance (m) from any point of it to any sample:
    the distance between its box and the nearest non-empty cell's (0 for a non-empty cell
    and its 26 neighbours). A ball-emptiness or a bounded nearest-neighbour query whose
    radius is at most its cell's free distance finds nothing without visiting a cell: most
    of a seated person's clearance and interior points lie in open air. It is the exact
    Euclidean distance transform (SciPy) of the occupancy dilated by one cell, in cells:
    the nearest dilated cell's centre lies exactly as far as the nearest non-empty cell's box
    (per axis, max(0, |di| - 1) cells)."""
    from scipy.ndimage import binary_dilation, distance_transform_edt

    shape = tuple(int(d) for d in grid.dims)
    near = binary_dilation((np.diff(grid.starts) > 0).reshape(shape),
                           structure=np.ones((3, 3, 3), bool))
    if near.all():
        return np.zeros(int(np.prod(shape)), np.float32)
    out = distance_transform_edt(~near).astype(np.float32).reshape(-1)
    out *= np.float32(grid.cell)
    return out
