"""Triton kernel of the torch backend's tile search (imported only when Triton is there: it
comes with PyTorch's CUDA builds; see torch_backend.py).

One launch answers every query of a block: the queries, sorted by tile, are cut into work
items of at most ``BLOCK_Q`` queries of one tile, and each work item reads its tile's member
points ``BLOCK_P`` at a time, keeping each query's nearest (the smallest squared distance,
float64, differences taken coordinate by coordinate; among equal distances the first
member). The cdist path it replaces launched a few kernels per tile of each block, thousands
per block, from a Python loop. Exactness is the caller's: a query's answer is its true
nearest point only where it lies within the query's room in the grown tile
(:meth:`.torch_backend._TileLevel.nearest`).
"""

from __future__ import annotations

import triton
import triton.language as tl

#: Queries of one work item (one tile) and member points read at a time.
BLOCK_Q = 32
BLOCK_P = 64


@triton.jit
def _nearest_in_tiles(qx, qy, qz, work_q0, work_q1, work_p0, work_p1, px, py, pz,
                      best_pos, best_d2, BLOCK_Q: tl.constexpr, BLOCK_P: tl.constexpr):
    w = tl.program_id(0)
    q0 = tl.load(work_q0 + w)
    q1 = tl.load(work_q1 + w)
    p0 = tl.load(work_p0 + w)
    p1 = tl.load(work_p1 + w)
    qi = q0 + tl.arange(0, BLOCK_Q)
    qm = qi < q1
    x = tl.load(qx + qi, mask=qm, other=0.0)
    y = tl.load(qy + qi, mask=qm, other=0.0)
    z = tl.load(qz + qi, mask=qm, other=0.0)
    best = tl.full([BLOCK_Q], float("inf"), tl.float64)
    arg = tl.full([BLOCK_Q], -1, tl.int64)
    s = p0
    while s < p1:                # (a while loop: the interpreter takes no loaded range bounds)
        pi = s + tl.arange(0, BLOCK_P)
        pm = pi < p1
        a = tl.load(px + pi, mask=pm, other=0.0)
        b = tl.load(py + pi, mask=pm, other=0.0)
        c = tl.load(pz + pi, mask=pm, other=0.0)
        dx = x[:, None] - a[None, :]
        dy = y[:, None] - b[None, :]
        dz = z[:, None] - c[None, :]
        d2 = dx * dx + dy * dy + dz * dz
        d2 = tl.where(pm[None, :], d2, float("inf"))
        m, j = tl.min(d2, axis=1, return_indices=True)
        better = m < best
        best = tl.where(better, m, best)
        arg = tl.where(better, s + j.to(tl.int64), arg)
        s += BLOCK_P
    tl.store(best_pos + qi, arg, mask=qm)
    tl.store(best_d2 + qi, best, mask=qm)


def nearest_in_tiles(torch, q_sorted, tile_sorted, starts, px, py, pz):
    """For queries (Q, 3) float64 sorted by tile (``tile_sorted`` (Q,) int64), each tile's
    members ``starts[t]:starts[t + 1]`` (device int64) of the member coordinates ``px``,
    ``py``, ``pz`` (M,) float64: (member position (Q,) int64, -1 where the tile has none,
    squared distance (Q,) float64) of each query's nearest member."""
    dev = q_sorted.device
    n = q_sorted.shape[0]
    pos = torch.full((n,), -1, dtype=torch.int64, device=dev)
    d2 = torch.full((n,), float("inf"), dtype=torch.float64, device=dev)
    if n == 0:
        return pos, d2
    uniq, counts = torch.unique_consecutive(tile_sorted, return_counts=True)
    first = torch.cumsum(counts, 0) - counts
    chunks = (counts + BLOCK_Q - 1) // BLOCK_Q
    group = torch.repeat_interleave(torch.arange(len(uniq), device=dev), chunks)
    within = torch.arange(len(group), device=dev) - torch.repeat_interleave(
        torch.cumsum(chunks, 0) - chunks, chunks)
    q0 = first[group] + within * BLOCK_Q
    q1 = torch.minimum(q0 + BLOCK_Q, first[group] + counts[group])
    t = uniq[group]
    p0 = starts[t].contiguous()
    p1 = starts[t + 1].contiguous()
    q = q_sorted.contiguous()
    _nearest_in_tiles[(len(group),)](q[:, 0].contiguous(), q[:, 1].contiguous(),
                                     q[:, 2].contiguous(), q0.contiguous(), q1.contiguous(),
                                     p0, p1, px, py, pz, pos, d2,
                                     BLOCK_Q=BLOCK_Q, BLOCK_P=BLOCK_P)
    return pos, d2
