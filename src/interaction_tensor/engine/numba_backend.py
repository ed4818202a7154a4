"""Numba kernels: exact nearest neighbours on a uniform grid and the per-pair scoring loop.

These compute the same thing as :func:`interaction_tensor.engine.scoring.score_pairs` with SciPy's
cKDTree, one (test point, orientation) pair per thread, keypoints in weight order, stopping a
pair as soon as its decision is known. Every nearest neighbour is exact: the grid's shell
search visits shells of cells around the query until no unvisited cell can hold a closer
point. With ``cache`` (detection: where test points are dense), :func:`score_jobs` answers
them instead from a :class:`NeighbourCache` kept on the grid (octrees of "which samples can
be nearest in this box" lists, built where the queries go; bit-identical results), which
pays off only when the same space is queried many times (see benchmarks/kernel_speed.py and
benchmarks/run.py).

Numba is imported lazily; :func:`available` says whether it can be used.
"""

from __future__ import annotations

import numpy as np

from interaction_tensor.engine.cache_layout import PAGE, PAGE_BITS
from interaction_tensor.engine.scoring import ScoreJob, paper_limits
from interaction_tensor.geometry.grid import FAR_BLOCK, Grid

_KERNELS = None

#: Pairs per work unit handed to a thread by the scoring kernel.
PARALLEL_CHUNK = 64
#: :func:`score_jobs` without a ``cache`` argument scores through the :class:`NeighbourCache`
#: (same results). Off: building it costs more than it saves on scattered queries
#: (benchmarks/kernel_speed.py: 0.9x on 3,000 random kitchen5 candidates, 0.4x on
#: living-room4; 1.8x and 5.9x once built); :func:`backends.cache_pays` turns it on where test
#: points are dense (benchmarks/run.py: 1.68-1.78x on kitchen5 at 30 %, 2.34-2.65x on living-room4;
#: sitting on the whole of living-room4 at the defaults: 4.47x).
NEIGHBOUR_CACHE = False
#: Neighbour cache (see :class:`NeighbourCache`). Root block edge, in grid cells (a grid cell
#: is 3 spacings, so 4 spacings).
CACHE_ROOT_CELLS = 4 / 3
#: Levels of octree below a root block (leaves down to 2 spacings).
CACHE_MAX_DEPTH = 1
#: A node whose list is longer than this is split into 8 children.
CACHE_LEAF_SIZE = 16
#: Leaf lists longer than this are not scanned: the query uses the grid search.
CACHE_SCAN_MAX = 256
#: Blocks of grid cells (per axis) whose emptiness the cache builder checks at once.
CACHE_OCC_CELLS = FAR_BLOCK
#: Separators of a box: candidates nearest to a (n + 1)^3 lattice over it.
CACHE_LATTICE = 2
#: Memory of one cache (bytes); past it the oldest trees are dropped (or all of them) and
#: rebuilt where needed.
CACHE_BYTES = 512 * 2**20
#: Part of the budget kept for the page table and pages (1 / this; 1.2 MB of 48 on
#: living-room4 with sitting-human).
CACHE_TABLE_SHARE = 16
#: Most root blocks (the page table holds one int32 per PAGE^3 of them); the block edge
#: doubles until they fit.
CACHE_MAX_BLOCKS = 16_000_000
#: Pairs scored between two cache builds (the first round, then doubling up to the most).
CACHE_FIRST_ROUND = 128
CACHE_ROUND = 2048
#: Before each round, the root blocks under the keypoints that this quantile of the last
#: round's pairs reached are built.
CACHE_PREPARE_QUANTILE = 0.9
#: ... reached by every this-many-th pair of the round in Z-order (neighbours reach nearly
#: the same blocks; the few others are built after the round that asked for them):
#: kitchen5, placing, 1 thread: 94.7 s of scoring against 99.2 s with every pair.
CACHE_PREPARE_STRIDE = 4
#: Distinct unbuilt root blocks one pair records per round.
CACHE_REQUESTS = 16
#: Room for one root block's tree in a build (nodes, list entries); bigger trees are built
#: again alone.
CACHE_TREE_ROOM = (1024, 8192)
#: Root blocks built per parallel call (bounds the build's scratch memory).
CACHE_BUILD_BATCH = 512

def available() -> bool:
    """True when Numba imports."""
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def _compile():
    global _KERNELS
    if _KERNELS is None:
        import warnings

        # numba notes an old system TBB once per process and falls back to OpenMP: not the
        # user's concern
        warnings.filterwarnings("ignore", message=".*TBB.*")
        from interaction_tensor.engine import _numba_kernels as nk

        _KERNELS = {name: getattr(nk, name) for name in (
            "score", "score_cached", "nearest_many", "nearest_many_cached",
            "collect_requests", "build_roots",
            "integrate", "morton_order", "touched_roots", "shift_trees")}
    return _KERNELS


def morton_order(points: np.ndarray, origin: np.ndarray, cell: float) -> np.ndarray:
    """(N,) int64 order of ``points`` (N, 3) along the Z-order curve of the grid cells of
    edge ``cell`` from ``origin`` (stable)."""
    return _compile()["morton_order"](points, origin, cell)


def nearest_indices(grid: Grid, queries: np.ndarray) -> np.ndarray:
    """Exact nearest scene point (original index) of each query, (Q,) int64; through the
    grid's neighbour cache where it has one (the trees it holds; nothing is built)."""
    k = _compile()
    out = np.empty(len(queries), np.int64)
    q = np.ascontiguousarray(queries, dtype=np.float64)
    cache = getattr(grid, "cache", None)
    if cache is not None and len(q):
        k["nearest_many_cached"](q, grid.points, grid.starts, grid.seed, grid.occ, grid.origin,
                                 grid.cell, grid.dims, *cache.state(), out)
    else:
        k["nearest_many"](q, grid.points, grid.starts, grid.seed, grid.occ, grid.origin,
                          grid.cell, grid.dims, out)
    return out if grid.order is None else grid.order[out]


def _job_args(job: ScoreJob, grid: Grid) -> tuple:
    t = job.table
    pnorm = np.ascontiguousarray(np.linalg.norm(t.provenance[0], axis=1))
    big_w, cos_lim = paper_limits(t)
    return (np.ascontiguousarray(t.offsets), np.ascontiguousarray(t.provenance), pnorm,
            np.ascontiguousarray(t.weights), cos_lim, big_w, t.max_terms, t.rest,
            0 if t.criterion == "paper" else 1, t.c, t.a, float(t.weights.sum()),
            float(job.threshold), int(job.early_exit), job.vectors == "surface",
            float(job.rho), job.resume_at is not None, grid.points, grid.normals, grid.starts,
            grid.seed, grid.origin, grid.cell, grid.dims, grid.occ)


class NeighbourCache:
    """Exact candidate lists of the nearest scene sample over boxes of space, for one grid.

    Root blocks (cubes of edge ``hb`` on a block grid covering ``lo``..``hi``) are built
    when a query first lands in them: an octree whose nodes are split in 8 while their list
    is longer than :data:`CACHE_LEAF_SIZE`, at most :data:`CACHE_MAX_DEPTH` levels deep. A
    leaf's list holds every sample that can be the nearest one (at the smallest computed
    squared distance) to some point of its box, enlarged by 1e-6 of its edge: a sample is
    left out only when another sample is closer to all of the box by more than ``tol``
    (m^2), so scanning the list gives exactly the grid search's answer. A root gathers the
    samples within d + 2 r of its centre (d: distance to its nearest sample, r:
    half-diagonal); children filter their parent's list.

    Attributes
    ----------
    lo, hi : (3,) float64, the covered box (m): queries outside use the grid search
    bo : (3,) float64 corner of block (0, 0, 0) (m); hb : block edge (m); bdims : (3,) int64
    ptab : int32 page of each group of PAGE^3 blocks (-1 none); pdims : (3,) groups per axis
    pool : int32 pages of PAGE^3 entries: a block's root node (-1 not built, -2 requested,
        -3 grid search); owner : group of each page (-1 free)
    child, llen : (M,) int32; lstart : (M,) int64; lists : (E,) int32 (see _numba_kernels)
    used : (2,) int64, nodes and list entries in use
    tol : squared-distance margin (m^2) for rounding; slack : gather radius margin (m)
    chunks : [(first node, first entry, blocks)] of each batch of trees, oldest first (trees
        are appended, so a batch's nodes and entries run up to the next batch's)
    evictions : times the oldest trees were dropped for memory; resets : times it was emptied
    grows : times the node or list arrays were enlarged (copied)
    """

    def __init__(self, grid: Grid, lo: np.ndarray, hi: np.ndarray, budget: int = CACHE_BYTES):
        self.budget = int(budget)
        lo = np.asarray(lo, np.float64)
        hi = np.asarray(hi, np.float64)
        hb = CACHE_ROOT_CELLS * grid.cell
        while np.prod(np.ceil((hi - lo) / hb) + 1) > CACHE_MAX_BLOCKS:
            hb *= 2.0
        self.lo, self.hi, self.bo, self.hb = lo, hi, lo.copy(), float(hb)
        self.bdims = (np.ceil((hi - lo) / hb).astype(np.int64) + 1).clip(1)
        self.pdims = -(-self.bdims // PAGE)
        self.ptab = np.full(int(np.prod(self.pdims)), -1, np.int32)
        self.pool = np.full(0, -1, np.int32)
        self.owner = np.full(0, -1, np.int64)
        nodes = min(1 << 16, max(256, self.budget // 64))     # grown as needed
        self.child = np.full(nodes, -1, np.int32)
        self.lstart = np.zeros(nodes, np.int64)
        self.llen = np.zeros(nodes, np.int32)
        self.lists = np.zeros(min(1 << 20, max(1024, self.budget // 16)), np.int32)
        self.used = np.zeros(2, np.int64)
        self.occ = grid.occ            # CACHE_OCC_CELLS = FAR_BLOCK
        m = float(max(np.abs(lo).max(), np.abs(hi).max(), 1.0))
        self.tol = 1e-13 * (1.0 + m) ** 2
        self.slack = float(np.sqrt(self.tol)) + 1e-9
        self.chunks = []
        self.evictions = 0
        self.resets = 0
        self.grows = 0

    def covers(self, lo, hi) -> bool:
        """True when the box lo..hi (m) is inside the covered box."""
        return bool(np.all(lo >= self.lo) and np.all(hi <= self.hi))

    @property
    def table_bytes(self) -> int:
        """Bytes of the root blocks' page table and pages."""
        return int(self.ptab.nbytes + self.pool.nbytes + self.owner.nbytes)

    @property
    def nbytes(self) -> int:
        return int(self.table_bytes + self.child.nbytes + self.lstart.nbytes +
                   self.llen.nbytes + self.lists.nbytes)

    def state(self) -> tuple:
        """The arrays :func:`_numba_kernels.score_cached` reads, in its order."""
        return (self.ptab, self.pdims, self.pool, self.bo, self.hb, self.bdims, self.child,
                self.lstart, self.llen, self.lists, CACHE_SCAN_MAX)

    def _coords(self, blocks: np.ndarray):
        d1, d2 = int(self.bdims[1]), int(self.bdims[2])
        return blocks // (d1 * d2), (blocks // d2) % d1, blocks % d2

    def _groups(self, blocks: np.ndarray) -> np.ndarray:
        """The page-table entry (group of PAGE^3 blocks) of each root block."""
        bi, bj, bk = self._coords(blocks)
        sh = PAGE_BITS
        return ((bi >> sh) * int(self.pdims[1]) + (bj >> sh)) * int(self.pdims[2]) + (bk >> sh)

    def _slots(self, blocks: np.ndarray) -> np.ndarray:
        """Where each root block's entry lies in the pool (their pages allocated)."""
        bi, bj, bk = self._coords(blocks)
        m = PAGE - 1
        page = self.ptab[self._groups(blocks)].astype(np.int64)
        return ((page * PAGE + (bi & m)) * PAGE + (bj & m)) * PAGE + (bk & m)

    def _allocate(self, blocks: np.ndarray) -> np.ndarray:
        """Pages for these root blocks where they have none: free pages first, then the pool
        grows, within 1 / :data:`CACHE_TABLE_SHARE` of the budget (past it, the oldest
        trees are dropped to free theirs). Returns which blocks have a page (those without
        stay unbuilt: the grid search answers there)."""
        g = self._groups(blocks)
        new = np.unique(g[self.ptab[g] < 0])
        if len(new):
            size = PAGE ** 3 * 4 + 8
            cap = max(0, (self.budget // CACHE_TABLE_SHARE - self.ptab.nbytes) // size)
            if int((self.owner >= 0).sum()) + len(new) > cap:
                if not self._evict(0, 0):
                    self._reset()
            free = np.flatnonzero(self.owner < 0)
            if len(free) < len(new) and len(self.owner) < cap:
                have = len(self.owner)
                grow = min(cap, max(2 * have, have + len(new) - len(free))) - have
                self.owner = np.concatenate([self.owner, np.full(grow, -1, np.int64)])
                self.pool = np.concatenate([self.pool, np.full(grow * PAGE ** 3, -1, np.int32)])
                free = np.flatnonzero(self.owner < 0)
            take = free[:len(new)]
            self.owner[take] = new[:len(take)]
            self.ptab[new[:len(take)]] = take
        return self.ptab[g] >= 0

    def _free_pages(self):
        """Give back the pages none of whose blocks is built, requested or marked."""
        held = np.flatnonzero(self.owner >= 0)
        empty = held[(self.pool.reshape(-1, PAGE ** 3)[held] == -1).all(axis=1)]
        self.ptab[self.owner[empty]] = -1
        self.owner[empty] = -1

    def _reset(self):
        self.pool[self.pool >= 0] = -1
        self._free_pages()
        self.used[:] = 0
        self.chunks = []
        self.resets += 1

    def _evict(self, nodes: int, entries: int) -> bool:
        """Drop the oldest batches of trees (first built, first dropped: the Z-ordered search
        has mostly moved on from them) until the rest and ``nodes`` / ``entries`` more fill
        at most half the room the budget leaves beside the root table, and move the rest to
        the front. False when nothing would be kept (the caller empties the cache)."""
        room = (self.budget - self.table_bytes) // 2 - (16 * nodes + 4 * entries)
        n_end, e_end = int(self.used[0]), int(self.used[1])
        keep = len(self.chunks)
        while keep > 0:
            n0, e0, _ = self.chunks[keep - 1]
            if 16 * (n_end - n0) + 4 * (e_end - e0) > room:
                break
            keep -= 1
        if keep in (0, len(self.chunks)):
            return False
        n_cut, e_cut = self.chunks[keep][0], self.chunks[keep][1]
        for _, _, blocks in self.chunks[:keep]:
            self.pool[self._slots(blocks)] = -1
        kept = self.chunks[keep:]
        for _, _, blocks in kept:
            self.pool[self._slots(blocks)] -= n_cut
        self._free_pages()
        _compile()["shift_trees"](self.child, self.lstart, self.llen, self.lists, n_cut,
                                  n_end, e_cut, e_end)
        self.chunks = [(n0 - n_cut, e0 - e_cut, b) for n0, e0, b in kept]
        self.used[:] = (n_end - n_cut, e_end - e_cut)
        self.evictions += 1
        return True

    def _reserve(self, nodes: int, entries: int) -> bool:
        """Room for ``nodes`` more nodes and ``entries`` more list entries: False when that
        would pass its ``budget`` (bytes; the caller drops the oldest trees, then all)."""
        need_n = int(self.used[0]) + nodes
        need_e = int(self.used[1]) + entries
        cap_n, cap_e = len(self.child), len(self.lists)
        if need_n <= cap_n and need_e <= cap_e:
            return True
        table = max(self.table_bytes, self.budget // CACHE_TABLE_SHARE)   # pages' share
        least_n, least_e = max(cap_n, need_n), max(cap_e, need_e)
        if table + least_n * 16 + least_e * 4 > self.budget:
            return False
        new_n = cap_n if need_n <= cap_n else max(need_n, 2 * cap_n)
        new_e = cap_e if need_e <= cap_e else max(need_e, 2 * cap_e)
        if table + new_n * 16 + new_e * 4 > self.budget:
            # doubling would pass the budget: the arrays that must grow share what is left
            # of it (growing them only by what this batch needs copied them again on almost
            # every batch near the budget: 1.9 s of kitchen5's 17 s of scoring)
            grow_n, grow_e = need_n > cap_n, need_e > cap_e
            spare = (self.budget - table - least_n * 16 - least_e * 4) // (
                2 if grow_n and grow_e else 1)
            new_n = least_n + (spare // 16 if grow_n else 0)
            new_e = least_e + (spare // 4 if grow_e else 0)
        n0, e0 = int(self.used[0]), int(self.used[1])
        self.grows += 1
        if new_n > cap_n:
            for name, fill in (("child", -1), ("lstart", 0), ("llen", 0)):
                old = getattr(self, name)
                arr = np.full(new_n, fill, old.dtype)
                arr[:n0] = old[:n0]
                setattr(self, name, arr)
        if new_e > cap_e:
            arr = np.zeros(new_e, np.int32)
            arr[:e0] = self.lists[:e0]
            self.lists = arr
        return True

    def prepare(self, grid: Grid, perm, tp, orient, offsets, n_keys: int):
        """Build the root blocks that keypoints ``0..n_keys - 1`` of pairs ``perm`` land in."""
        k = _compile()
        touched = np.empty((len(perm), n_keys), np.int64)
        k["touched_roots"](perm, tp, orient, offsets, n_keys, self.ptab, self.pdims, self.pool,
                           self.bo, self.hb, self.bdims, touched)
        self.update(grid, touched, np.full(len(perm), n_keys, np.int64))

    def update(self, grid: Grid, req: np.ndarray, nreq: np.ndarray):
        """Build the root blocks ``req[j, :nreq[j]]`` (entries < 0 ignored) that are not
        built yet, e.g. those the last round of queries asked for (see
        :func:`_numba_kernels.score_cached`)."""
        total = int(nreq.sum())
        if total == 0:
            return
        k = _compile()
        blocks = np.empty(total, np.int64)
        blocks = blocks[:k["collect_requests"](req, nreq, self.bdims, self.ptab, self.pdims,
                                               self.pool, blocks)]
        blocks = np.unique(blocks)
        blocks = blocks[self._allocate(blocks)]
        self.pool[self._slots(blocks)] = -2
        for start in range(0, len(blocks), CACHE_BUILD_BATCH):
            self._build(grid, blocks[start:start + CACHE_BUILD_BATCH])

    def _build(self, grid: Grid, blocks: np.ndarray, room=None):
        """Build root blocks ``blocks`` and add them to the cache (``room``: (T, 2) nodes and
        entries per tree, default :data:`CACHE_TREE_ROOM`)."""
        k = _compile()
        t = len(blocks)
        if room is None:
            room = np.tile(np.array(CACHE_TREE_ROOM, np.int64), (t, 1))
        noff = np.zeros(t + 1, np.int64)
        eoff = np.zeros(t + 1, np.int64)
        np.cumsum(room[:, 0], out=noff[1:])
        np.cumsum(room[:, 1], out=eoff[1:])
        nchild = np.empty(int(noff[-1]), np.int32)
        nstart = np.empty(int(noff[-1]), np.int64)
        nlen = np.empty(int(noff[-1]), np.int32)
        ent = np.empty(int(eoff[-1]), np.int32)
        counts = np.zeros((t, 2), np.int64)
        k["build_roots"](blocks, self.bo, self.hb, self.bdims, CACHE_LATTICE, self.tol,
                         self.slack, CACHE_LEAF_SIZE, CACHE_MAX_DEPTH, grid.points,
                         grid.starts, grid.seed, self.occ, CACHE_OCC_CELLS, grid.origin,
                         grid.cell, grid.dims, noff, eoff, nchild, nstart, nlen, ent, counts)
        fits = (counts[:, 0] <= room[:, 0]) & (counts[:, 1] <= room[:, 1])
        nodes, entries = int(counts[fits, 0].sum()), int(counts[fits, 1].sum())
        if not self._reserve(nodes, entries):
            if not (self._evict(nodes, entries) and self._reserve(nodes, entries)):
                self._reset()
                if not self._reserve(nodes, entries):
                    self.pool[self._slots(blocks[fits])] = -3   # too big: grid search
                    fits[:] = False
        if fits.any():
            self.chunks.append((int(self.used[0]), int(self.used[1]), blocks[fits]))
        k["integrate"](blocks, noff, eoff, nchild, nstart, nlen, ent,
                       np.where(fits[:, None], counts, np.iinfo(np.int64).max), self.bdims,
                       self.ptab, self.pdims, self.pool,
                       self.child, self.lstart, self.llen, self.lists, self.used)
        again = np.flatnonzero(~fits & (counts[:, 0] > 0))
        again = again[(counts[again, 0] > room[again, 0]) | (counts[again, 1] > room[again, 1])]
        if len(again):                      # trees bigger than their room: once more
            self._build(grid, blocks[again], counts[again])


def _cache_for(grid: Grid, points: np.ndarray, offsets: np.ndarray,
               budget: int = CACHE_BYTES) -> NeighbourCache:
    """The grid's cache, (re)made to cover the scene and every query of these pairs, held to
    ``budget`` bytes (made anew if it holds more)."""
    reach = np.abs(offsets).reshape(-1, 3).max(axis=0) + grid.cell
    scene_lo = grid.origin
    scene_hi = grid.origin + grid.dims * grid.cell
    lo = np.minimum(scene_lo, points.min(axis=0)) - reach
    hi = np.maximum(scene_hi, points.max(axis=0)) + reach
    cache = grid.cache
    if cache is None or not cache.covers(lo, hi) or cache.nbytes > budget:
        if cache is not None:
            lo, hi = np.minimum(lo, cache.lo), np.maximum(hi, cache.hi)
        grid.cache = cache = NeighbourCache(grid, lo, hi, budget)
    elif cache.budget != budget:
        cache.budget = int(budget)
        cache.pool[cache.pool == -3] = -1          # too big for the old budget: try again
        cache._free_pages()
    return cache


def score_jobs(jobs: list, grid: Grid, cache: bool | None = None,
               cache_bytes: int = CACHE_BYTES) -> list:
    """Score several jobs (e.g. several affordances) over one scene grid.

    Every nearest neighbour is exact: the results are identical to
    :func:`interaction_tensor.engine.scoring.score_pairs`, and bit for bit the same with or
    without the neighbour cache (``cache``; None: :data:`NEIGHBOUR_CACHE`; at most
    ``cache_bytes`` bytes: past it the oldest trees are dropped, rebuilt where needed).
    Returns, per job, (score, accepted, decided_at, comparisons) arrays over its pairs.
    """
    use_cache = NEIGHBOUR_CACHE if cache is None else bool(cache)
    import numba

    outs = []
    for job in jobs:
        p = len(job.points)
        out = (np.zeros(p), np.zeros(p, np.bool_), np.zeros(p, np.int64), np.zeros(p, np.int64))
        if job.resume_at is not None:
            out[0][:] = job.resume_score
            out[1][:] = True
            out[2][:] = job.resume_at
        if p:
            # pairs differ a lot in cost (an accepted pair compares every keypoint): hand
            # them to the threads in small chunks rather than one static half each
            previous = numba.set_parallel_chunksize(PARALLEL_CHUNK)
            try:
                tp = np.ascontiguousarray(job.points, dtype=np.float64)
                orient = np.ascontiguousarray(job.orient, np.int64)
                if use_cache:
                    _score_cached(job, tp, orient, grid, out, cache_bytes)
                else:
                    _compile()["score"](tp, orient, *_job_args(job, grid), *out)
            finally:
                numba.set_parallel_chunksize(previous)
        outs.append(out)
    return outs


def _score_cached(job: ScoreJob, tp: np.ndarray, orient: np.ndarray, grid: Grid, out: tuple,
                  budget: int = CACHE_BYTES):
    """One job through the grid's :class:`NeighbourCache`: pairs in Z-order of their test
    points, in rounds (:data:`CACHE_FIRST_ROUND` pairs, doubling up to :data:`CACHE_ROUND`);
    before a round the root blocks under the keypoints most pairs reached last round are
    built (those of every :data:`CACHE_PREPARE_STRIDE`-th pair), after it those its
    queries still missed."""
    k = _compile()
    p = len(tp)
    args = _job_args(job, grid)
    args = args[:6] + args[7:]                  # score_cached has no max_terms
    cache = _cache_for(grid, tp, args[0], budget)
    perm = k["morton_order"](tp, cache.lo, cache.hb)
    n = min(CACHE_ROUND, p)
    req = np.empty((n, CACHE_REQUESTS), np.int64)
    nreq = np.zeros(n, np.int64)
    nk = job.table.n
    depth = nk                                  # keypoints reached per pair, so far
    start, size = 0, CACHE_FIRST_ROUND
    while start < p:
        sub = perm[start:start + size]
        m = len(sub)
        cache.prepare(grid, sub[::CACHE_PREPARE_STRIDE], tp, orient, args[0], min(nk, depth))
        k["score_cached"](sub, tp, orient, *args, *cache.state(), req[:m], nreq[:m], *out)
        cache.update(grid, req[:m], nreq[:m])
        depth = int(np.quantile(out[3][sub], CACHE_PREPARE_QUANTILE))
        start += m
        size = min(2 * size, CACHE_ROUND)


def score_pairs_numba(points, orient, table, grid: Grid, threshold: float, vectors: str,
                      rho: float, early_exit: bool = True, cache: bool | None = None):
    """Numba version of :func:`interaction_tensor.engine.scoring.score_pairs` (one job of
    :func:`score_jobs`). Returns score, accepted, decided_at, comparisons-per-pair arrays."""
    job = ScoreJob(points, orient, table, threshold, vectors, rho, early_exit)
    return score_jobs([job], grid, cache)[0]
