"""Numba kernel of the clearance test (imported only when Numba is available; see
clearance.py): for each placement, how many clearance points have a scene sample nearer than
their free space. A ball-emptiness test on the scene's grid (:class:`kernels.Grid`): only the
cells that meet the ball are visited and a point stops at its first sample inside, so open
space costs a few cell look-ups. Exact: it answers ``d < need`` for the nearest sample's
distance ``d``, as the reference (a bounded cKDTree query) does.
"""

import math

import numpy as np
from numba import njit, prange


@njit(cache=True, inline="always")
def _occupied_within(qx, qy, qz, r, pts, starts, ox, oy, oz, cell, nx, ny, nz):
    """True when some sample lies at a distance < r from q."""
    i0 = max(int(math.floor((qx - r - ox) / cell)), 0)
    i1 = min(int(math.floor((qx + r - ox) / cell)), nx - 1)
    j0 = max(int(math.floor((qy - r - oy) / cell)), 0)
    j1 = min(int(math.floor((qy + r - oy) / cell)), ny - 1)
    k0 = max(int(math.floor((qz - r - oz) / cell)), 0)
    k1 = min(int(math.floor((qz + r - oz) / cell)), nz - 1)
    for i in range(i0, i1 + 1):
        for j in range(j0, j1 + 1):
            base = (i * ny + j) * nz
            for k in range(k0, k1 + 1):
                c = base + k
                for p in range(starts[c], starts[c + 1]):
                    dx = pts[p, 0] - qx
                    dy = pts[p, 1] - qy
                    dz = pts[p, 2] - qz
                    if math.sqrt(dx * dx + dy * dy + dz * dz) < r:
                        return True
    return False


@njit(cache=True, parallel=True)
def violation_counts(points, orient, offsets, need, pts, starts, origin, cell, dims, out):
    """out[i] = number of k with a sample nearer than need[k] to points[i] + offsets[orient[i], k]."""
    ox, oy, oz = origin[0], origin[1], origin[2]
    nx, ny, nz = dims[0], dims[1], dims[2]
    for i in prange(points.shape[0]):
        o = orient[i]
        n = 0
        for k in range(need.shape[0]):
            if _occupied_within(points[i, 0] + offsets[o, k, 0], points[i, 1] + offsets[o, k, 1],
                                points[i, 2] + offsets[o, k, 2], need[k], pts, starts,
                                ox, oy, oz, cell, nx, ny, nz):
                n += 1
        out[i] = n


def counts(points, orient, offsets, need, grid) -> np.ndarray:
    """(P,) int64 violations (see :func:`violation_counts`) on ``grid``."""
    out = np.zeros(len(points), np.int64)
    if len(points):
        violation_counts(np.ascontiguousarray(points, np.float64),
                         np.ascontiguousarray(orient, np.int64),
                         np.ascontiguousarray(offsets, np.float64),
                         np.ascontiguousarray(need, np.float64), grid.points, grid.starts,
                         np.asarray(grid.origin, np.float64), float(grid.cell),
                         np.asarray(grid.dims, np.int64), out)
    return out
