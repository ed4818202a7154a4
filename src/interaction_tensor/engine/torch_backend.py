"""PyTorch backend: the same decisions as the Numba and NumPy paths, on a CUDA device.

A GPU wants uniform work, so this path compares every keypoint of every pair (no early
exit) and then reads the decision off the running sum exactly as the early exit would have
made it: the accept/reject flags, the accepted scores and ``decided_at`` are those of
:func:`interaction_tensor.engine.scoring.score_pairs` with the same keypoint order.

Nearest neighbours are exact. The scene's bounding box is cut into cubic tiles; each tile
keeps the scene points of the tile grown by a margin. A query's nearest point among its
tile's points is the true nearest point whenever it is closer than the query's distance to
the outside of the grown tile; the queries where that fails (far from every surface of the
tile) are answered by SciPy's cKDTree (or, with ``levels`` > 1, first asked again of a
level of larger tiles on the device). Pairs are scored in the order of their test
points' tiles, so that one block of pairs touches few tiles. Distances are float64
throughout.

PyTorch is imported lazily; ``pip install "interaction-tensor[torch]"``.
"""

from __future__ import annotations

import numpy as np

from interaction_tensor.engine.scoring import (
    ArrayOps,
    PairScores,
    onto_disks,
    paper_limits,
    vector_terms,
)
from interaction_tensor.errors import SettingsError

#: Largest candidate-distance matrix computed at once (entries), to bound device memory.
MAX_BLOCK = 1 << 25
#: Largest number of tiles.
MAX_TILES = 2_000_000


def torch_ops() -> ArrayOps:
    """torch's spelling of the array functions the shared scoring formulas use."""
    torch = import_torch()
    return ArrayOps(torch.where, torch.sqrt, torch.exp, lambda b: b.to(torch.float64))


def import_torch():
    """The ``torch`` module, or a SettingsError saying how to install it."""
    try:
        import torch
    except ImportError:
        raise SettingsError("backend 'torch' needs PyTorch: pip install "
                            "'interaction-tensor[torch]' (or pip install torch)") from None
    return torch


def resolve_device(name: str | None) -> str:
    """``None``/``auto``: ``cuda`` when a CUDA device is present, else ``cpu``."""
    torch = import_torch()
    if name in (None, "auto"):
        return "cuda" if torch.cuda.is_available() else "cpu"
    if name.startswith("cuda") and not torch.cuda.is_available():
        raise SettingsError(f"device {name!r} asked for, but PyTorch sees no CUDA device")
    try:
        torch.device(name)
    except (RuntimeError, TypeError, ValueError):
        raise SettingsError(f"device {name!r} is not a torch device (cpu, cuda, cuda:N, "
                            f"mps)") from None
    if name.startswith("cuda:") and int(name[5:]) >= torch.cuda.device_count():
        raise SettingsError(f"device {name!r} asked for, but PyTorch sees "
                            f"{torch.cuda.device_count()} CUDA device(s)")
    if name == "mps" and not (getattr(torch.backends, "mps", None)
                              and torch.backends.mps.is_available()):
        raise SettingsError("device 'mps' asked for, but PyTorch sees no MPS device")
    return name


class TorchIndex:
    """Scene points, normals and the tiles on one torch device.

    Parameters
    ----------
    scene : a :class:`~interaction_tensor.geometry.scene.Scene`
    device : torch device name (``cuda``, ``cuda:1``, ``cpu``)
    tile : tile edge (m) of the first level; None: 16 scene spacings, at least 0.1 m (a few
        thousand points per grown tile on a surface scene)
    margin : how far (m) each first-level tile reaches out for points; None: a quarter of
        the tile
    kernel : how a level finds each query's nearest member of its tile: ``"triton"`` (one
        launch of a Triton kernel per block of queries, :mod:`._triton_nearest`; Triton
        comes with PyTorch's CUDA builds; on the CPU only under ``TRITON_INTERPRET=1``, for
        tests), ``"cdist"`` (``torch.cdist`` tile by tile from a Python loop: a few kernel
        launches per tile), or ``"auto"``: Triton on a CUDA device when it imports, else
        cdist
    levels : tile levels, each ``coarsening`` times the tile and margin of the one before:
        a query whose nearest point the first level cannot prove (farther than its room to
        the grown tile's outside) is asked again at the next, on the device; only what the
        last level cannot prove goes to SciPy's cKDTree. Default (None): 3 levels each twice
        the one before with the Triton kernel (on an H200, kitchen5, placing-bowl, 30 %:
        12.5 s, against 16.7 s for 2 levels x4 and 32.5 s for 1, which sent 34M queries to
        the tree), 1 level with cdist (3 %: a second level took 11.0 s against 9.4 s for one;
        it sent 87k instead of 3.4M queries to the tree, but its large tiles cost more)
    coarsening : see ``levels``; None: 2 with Triton, 4 with cdist
    """

    def __init__(self, scene, device: str = "cuda", tile: float | None = None,
                 margin: float | None = None, levels: int | None = None,
                 coarsening: float | None = None, kernel: str = "auto"):
        torch = import_torch()
        self.torch = torch
        self.scene = scene
        self.device = torch.device(device)
        self.kernel = resolve_kernel(kernel, self.device)
        triton = self.kernel == "triton"
        levels = int(levels if levels is not None else 3 if triton else 1)
        coarsening = float(coarsening if coarsening is not None else 2.0 if triton else 4.0)
        pts = scene.points
        tile = float(tile if tile is not None else max(16 * scene.spacing, 0.1))
        margin = float(margin if margin is not None else tile / 4)
        if levels < 1 or coarsening < 1:
            raise SettingsError("TorchIndex needs levels >= 1 and coarsening >= 1")
        self.levels = [_TileLevel(pts, tile * coarsening ** k, margin * coarsening ** k,
                                  torch, self.device, self.kernel) for k in range(levels)]
        f64 = torch.float64
        self.points = torch.as_tensor(pts, dtype=f64, device=self.device)
        self.normals = torch.as_tensor(scene.normals, dtype=f64, device=self.device)
        #: queries answered by the cKDTree (none of the levels could prove them), a count
        self.tree_queries = 0

    def tile_of(self, p: np.ndarray) -> np.ndarray:
        """First-level linear tile index of each point (N, 3) (outside the box: the nearest)."""
        return self.levels[0].tile_of(p)

    def nearest(self, q):
        """Exact nearest scene point index of each query, (Q,) int64 tensor on the device."""
        torch = self.torch
        out = torch.full((q.shape[0],), -1, dtype=torch.int64, device=self.device)
        left = torch.arange(q.shape[0], device=self.device)
        for level in self.levels:
            if len(left) == 0:
                break
            got = level.nearest(q[left], self.points)
            out[left] = got
            left = left[got < 0]
        if len(left):                       # far from every surface of the tile: exact tree
            self.tree_queries += len(left)
            _, nn = self.scene.tree.query(q[left].cpu().numpy(), workers=-1)
            out[left] = torch.as_tensor(nn, dtype=torch.int64, device=self.device)
        return out


def resolve_kernel(kernel: str, device) -> str:
    """:class:`TorchIndex`'s ``kernel`` made concrete (``auto``: Triton on CUDA when it
    imports); SettingsError for an unknown one or Triton asked for and missing."""
    if kernel not in ("auto", "triton", "cdist"):
        raise SettingsError(f"kernel {kernel!r} must be auto, triton or cdist")
    if kernel == "cdist" or (kernel == "auto" and device.type != "cuda"):
        return "cdist"
    try:
        from interaction_tensor.engine import _triton_nearest  # noqa: F401
    except ImportError:
        if kernel == "triton":
            raise SettingsError("kernel 'triton' needs Triton (it comes with PyTorch's CUDA "
                                "builds: pip install triton)") from None
        return "cdist"
    return "triton"


class _TileLevel:
    """One level of tiles: cubes of edge ``tile``, each keeping the scene points of the cube
    grown by ``margin`` (a point may belong to several grown tiles)."""

    def __init__(self, pts: np.ndarray, tile: float, margin: float, torch, device,
                 kernel: str = "cdist"):
        self.torch, self.device, self.kernel = torch, device, kernel
        self.lo = pts.min(axis=0)
        extent = np.ptp(pts, axis=0) + 1e-9
        # a wide scene gets larger tiles rather than a huge tile table
        self.tile = float(max(tile, (np.prod(extent + tile) / MAX_TILES) ** (1 / 3)))
        self.margin = float(margin * self.tile / tile)
        self.dims = np.maximum(np.ceil(extent / self.tile), 1).astype(np.int64)
        first = np.floor((pts - self.margin - self.lo) / self.tile).astype(np.int64)
        last = np.floor((pts + self.margin - self.lo) / self.tile).astype(np.int64)
        first = np.clip(first, 0, self.dims - 1)
        last = np.clip(last, 0, self.dims - 1)
        members, tiles = [], []
        span = int(np.ceil(2 * self.margin / self.tile)) + 1
        for dx in range(span):
            for dy in range(span):
                for dz in range(span):
                    t = first + (dx, dy, dz)
                    ok = np.all(t <= last, axis=1)
                    members.append(np.flatnonzero(ok))
                    tiles.append(self._linear(t[ok]))
        members = np.concatenate(members)
        tiles = np.concatenate(tiles)
        order = np.argsort(tiles, kind="stable")
        self.members = members[order]
        counts = np.bincount(tiles, minlength=int(np.prod(self.dims)))
        self.starts = np.r_[0, np.cumsum(counts)]
        self._members = torch.as_tensor(self.members, device=device)
        self._lo = torch.as_tensor(self.lo, dtype=torch.float64, device=device)
        self._dims = torch.as_tensor(self.dims, device=device)
        if kernel == "triton":
            # the members' coordinates in tile order, one array per axis (the kernel reads
            # a tile's members contiguously)
            self._starts = torch.as_tensor(self.starts, dtype=torch.int64, device=device)
            self._xyz = [torch.as_tensor(np.ascontiguousarray(pts[self.members, a]),
                                         dtype=torch.float64, device=device) for a in range(3)]

    def _linear(self, t: np.ndarray) -> np.ndarray:
        return (t[:, 0] * self.dims[1] + t[:, 1]) * self.dims[2] + t[:, 2]

    def tile_of(self, p: np.ndarray) -> np.ndarray:
        t = np.floor((np.asarray(p, np.float64) - self.lo) / self.tile).astype(np.int64)
        return self._linear(np.clip(t, 0, self.dims - 1))

    def nearest(self, q, points):
        """Nearest point index of each query where this level proves it, else -1."""
        torch = self.torch
        out = torch.full((q.shape[0],), -1, dtype=torch.int64, device=self.device)
        lo, dims = self._lo.to(q.dtype), self._dims
        t3 = torch.floor((q - lo) / self.tile).to(torch.int64)
        t3 = torch.minimum(torch.clamp(t3, min=0), dims - 1)
        lin = (t3[:, 0] * dims[1] + t3[:, 1]) * dims[2] + t3[:, 2]
        # squared distance from each query to the outside of its grown tile (0 outside it)
        box_lo = lo + t3.to(q.dtype) * self.tile - self.margin
        box_hi = box_lo + self.tile + 2 * self.margin
        room2 = torch.minimum(q - box_lo, box_hi - q).min(dim=1).values.clamp(min=0).square()
        order = torch.argsort(lin, stable=True)
        if self.kernel == "triton":
            from interaction_tensor.engine._triton_nearest import nearest_in_tiles

            pos, d2 = nearest_in_tiles(torch, q[order], lin[order], self._starts, *self._xyz)
            nn = self._members[pos.clamp(min=0)]
            # proven where the nearest member lies inside the grown tile's room
            out[order] = torch.where((pos >= 0) & (d2 <= room2[order]), nn, out[order])
            return out
        uniq, counts = torch.unique_consecutive(lin[order], return_counts=True)
        uniq = uniq.cpu().numpy()                       # one transfer per call
        bounds = np.r_[0, np.cumsum(counts.cpu().numpy())]
        corners = self.lo + np.stack(np.unravel_index(uniq, self.dims), 1) * self.tile
        for u, corner, a, b in zip(uniq, corners, bounds[:-1], bounds[1:]):
            s, e = self.starts[u], self.starts[u + 1]
            if e == s:
                continue
            cand = self._members[s:e]
            # coordinates about the tile's centre keep the matrix form of cdist accurate
            centre = torch.tensor(corner + 0.5 * self.tile, dtype=q.dtype).to(
                self.device, non_blocking=True)
            p = points[cand] - centre
            step = max(1, MAX_BLOCK // int(e - s))
            for c0 in range(a, b, step):
                idx = order[c0:min(c0 + step, b)]
                d2 = torch.cdist(q[idx] - centre, p).square_()
                nn = cand[d2.argmin(dim=1)]
                exact = (points[nn] - q[idx]).square().sum(dim=1)
                # proven where the nearest point lies inside the grown tile's room
                out[idx] = torch.where(exact <= room2[idx], nn, out[idx])
        return out


def score_pairs_torch(points: np.ndarray, orient: np.ndarray, table, index: TorchIndex,
                      threshold: float, vectors: str = "surface", early_exit: bool = True,
                      pairs_per_block: int | None = None,
                      spatial_order: bool = True) -> PairScores:
    """Score pairs like :func:`interaction_tensor.engine.scoring.score_pairs`, on ``index.device``.

    Returns the same accepted flags, accepted scores and ``decided_at``; a rejected pair's
    score is its partial sum at the decision when ``early_exit`` (as on the CPU), its full
    score otherwise. ``comparisons`` counts every keypoint compared (all of them here).
    ``spatial_order`` scores the pairs in the order of their test points' tiles (the same
    results, fewer tiles per block). ``pairs_per_block`` None: 8,192 with the Triton kernel
    (one launch per block: larger blocks, fewer launches; 16.7 s against 20.0 s for 2,048 on
    the H200 run above), 2,048 with cdist.
    """
    torch = index.torch
    if pairs_per_block is None:
        pairs_per_block = 8192 if index.kernel == "triton" else 2048
    dev, f64 = index.device, torch.float64
    n = table.n
    offsets = torch.as_tensor(table.offsets, dtype=f64, device=dev)
    prov = torch.as_tensor(table.provenance, dtype=f64, device=dev)
    w = torch.as_tensor(table.weights, dtype=f64, device=dev)
    pn = torch.sqrt((prov[0] * prov[0]).sum(-1))
    ops = torch_ops()
    rest_next = torch.as_tensor(table.rest[1:], dtype=f64, device=dev)
    big_w, cos_lim = (torch.as_tensor(a, dtype=f64, device=dev) for a in paper_limits(table))
    eps = 1e-12
    points = np.asarray(points, np.float64)
    orient = np.asarray(orient, np.int64)
    # pairs in tile order, so that one block's queries fall in few tiles (fewer kernel launches
    # per block); the results are put back in the caller's order
    if spatial_order and len(points):
        by_tile = np.argsort(index.tile_of(points), kind="stable")
    else:
        by_tile = np.arange(len(points))
    out_s = np.zeros(len(points))
    out_a = np.zeros(len(points), bool)
    out_at = np.zeros(len(points), np.int64)
    for b0 in range(0, len(points), pairs_per_block):
        sl = by_tile[b0:b0 + pairs_per_block]
        tp = torch.as_tensor(points[sl], dtype=f64, device=dev)
        o = torch.as_tensor(orient[sl], device=dev)
        q = tp[:, None, :] + offsets[o]                                     # (P, N, 3)
        nn = index.nearest(q.reshape(-1, 3)).reshape(q.shape[:2])
        v = index.points[nn] - q
        if vectors == "surface":
            v = onto_disks(v, index.normals[nn], float(index.scene.spacing), ops)
        terms = vector_terms(table, prov[o], v, pn, w, big_w, cos_lim, ops)
        cs = torch.cumsum(terms, dim=1)
        reach = cs >= threshold - eps
        lost = cs + rest_next < threshold - eps
        never = torch.full((cs.shape[0],), n, dtype=torch.int64, device=dev)
        first_acc = torch.where(reach.any(1), reach.to(torch.int8).argmax(1), never)
        first_rej = torch.where(lost.any(1), lost.to(torch.int8).argmax(1), never)
        acc = first_acc <= first_rej
        at = torch.minimum(first_acc, first_rej)
        score = cs[:, -1]
        if early_exit:
            partial = cs.gather(1, at.clamp(max=n - 1)[:, None])[:, 0]
            score = torch.where(acc, score, partial)
        out_s[sl] = score.cpu().numpy()
        out_a[sl] = acc.cpu().numpy()
        out_at[sl] = (at + 1).clamp(max=n).cpu().numpy()
    return PairScores(out_s, out_a, out_at, len(points) * n)
