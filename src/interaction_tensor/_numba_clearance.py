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
def _span(q, r, o, cell, n):
    """The cells (first, last) along one axis that meet [q - r, q + r]."""
    return (max(int(math.floor((q - r - o) / cell)), 0),
            min(int(math.floor((q + r - o) / cell)), n - 1))


@njit(cache=True, inline="always")
def _occupied_within(qx, qy, qz, r, pts, starts, ox, oy, oz, cell, nx, ny, nz):
    """True when some sample lies at a distance < r from q."""
    i0, i1 = _span(qx, r, ox, cell, nx)
    j0, j1 = _span(qy, r, oy, cell, ny)
    k0, k1 = _span(qz, r, oz, cell, nz)
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


@njit(cache=True, parallel=True)
def through_hits(centres, axes, ring, reach, slab, max_cos, pts, nrm, starts, origin, cell,
                 dims, out):
    """out[i] = 1 when some sample lies within ``slab`` of the plane of placement i's posed
    polygon (centre ``centres[i]``, rows u, v, n of ``axes[i]``), inside it (``ring``:
    (K, 2) counter-clockwise in (u, v)), on a surface that crosses the plane (its normal
    ``nrm`` at most ``max_cos`` along n, either way); only the cells within ``reach`` of the
    centre are visited, and a placement stops at its first such sample."""
    ox, oy, oz = origin[0], origin[1], origin[2]
    nx, ny, nz = dims[0], dims[1], dims[2]
    k_n = ring.shape[0]
    for i in prange(centres.shape[0]):
        cx, cy, cz = centres[i, 0], centres[i, 1], centres[i, 2]
        i0, i1 = _span(cx, reach, ox, cell, nx)
        j0, j1 = _span(cy, reach, oy, cell, ny)
        k0, k1 = _span(cz, reach, oz, cell, nz)
        found = False
        for a in range(i0, i1 + 1):
            if found:
                break
            for b in range(j0, j1 + 1):
                if found:
                    break
                base = (a * ny + b) * nz
                for c in range(k0, k1 + 1):
                    if found:
                        break
                    for p in range(starts[base + c], starts[base + c + 1]):
                        dx = pts[p, 0] - cx
                        dy = pts[p, 1] - cy
                        dz = pts[p, 2] - cz
                        h = dx * axes[i, 2, 0] + dy * axes[i, 2, 1] + dz * axes[i, 2, 2]
                        if abs(h) > slab:
                            continue
                        if abs(nrm[p, 0] * axes[i, 2, 0] + nrm[p, 1] * axes[i, 2, 1]
                               + nrm[p, 2] * axes[i, 2, 2]) > max_cos:
                            continue
                        u = dx * axes[i, 0, 0] + dy * axes[i, 0, 1] + dz * axes[i, 0, 2]
                        v = dx * axes[i, 1, 0] + dy * axes[i, 1, 1] + dz * axes[i, 1, 2]
                        inside = True
                        for e in range(k_n):
                            f = e + 1 if e + 1 < k_n else 0
                            ex = ring[f, 0] - ring[e, 0]
                            ey = ring[f, 1] - ring[e, 1]
                            if ex * (v - ring[e, 1]) - ey * (u - ring[e, 0]) < 0:
                                inside = False
                                break
                        if inside:
                            found = True
                            break
        out[i] = 1 if found else 0


def through(centres, axes, ring, reach, slab, max_cos, grid) -> np.ndarray:
    """(P,) bool :func:`through_hits` on ``grid``."""
    out = np.zeros(len(centres), np.int8)
    if len(centres):
        through_hits(np.ascontiguousarray(centres, np.float64),
                     np.ascontiguousarray(axes, np.float64),
                     np.ascontiguousarray(ring, np.float64), float(reach), float(slab),
                     float(max_cos), grid.points, grid.normals, grid.starts,
                     np.asarray(grid.origin, np.float64), float(grid.cell),
                     np.asarray(grid.dims, np.int64), out)
    return out.astype(bool)
