"""The Numba kernel of generalised winding numbers (imported only when Numba is available;
see :func:`~interaction_tensor.geometry.sampling.winding_numbers`)."""

import math

import numpy as np
from numba import njit, prange


@njit(cache=True, parallel=True, fastmath=False)
def winding_numbers(points, tri):
    """Generalised winding numbers of ``points`` (P, 3) for triangles ``tri`` (F, 3, 3): the
    same formula as :func:`interaction_tensor.geometry.sampling.winding_numbers_reference`."""
    out = np.zeros(points.shape[0])
    for i in prange(points.shape[0]):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        total = 0.0
        for f in range(tri.shape[0]):
            ax, ay, az = tri[f, 0, 0] - px, tri[f, 0, 1] - py, tri[f, 0, 2] - pz
            bx, by, bz = tri[f, 1, 0] - px, tri[f, 1, 1] - py, tri[f, 1, 2] - pz
            cx, cy, cz = tri[f, 2, 0] - px, tri[f, 2, 1] - py, tri[f, 2, 2] - pz
            la = math.sqrt(ax * ax + ay * ay + az * az)
            lb = math.sqrt(bx * bx + by * by + bz * bz)
            lc = math.sqrt(cx * cx + cy * cy + cz * cz)
            det = (ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz)
                   + az * (bx * cy - by * cx))
            den = (la * lb * lc + (ax * bx + ay * by + az * bz) * lc
                   + (bx * cx + by * cy + bz * cz) * la + (cx * ax + cy * ay + cz * az) * lb)
            total += math.atan2(det, den)
        out[i] = total / (2.0 * math.pi)
    return out
