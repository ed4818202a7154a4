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


@njit(cache=True, parallel=True)
def ray_windings(points, tri, sign, starts, members, origin, cell, nx, ny, margin, out, unsure):
    """Winding numbers of ``points`` (P, 3) about a closed, consistently wound surface
    (triangles ``tri`` (F, 3, 3), ``sign[f]`` the sign of face f's normal's z), by the faces
    an upward ray from each point crosses: each adds its sign. The faces are bucketed by
    their plan boxes in a grid of ``cell`` (m) from ``origin`` (2,), ``nx`` x ``ny``
    cells (cell c's faces ``members[starts[c]:starts[c + 1]]``). Where the ray passes
    within ``margin`` (relative) of a face's edge in plan, or the point lies within
    ``margin`` (m) of a face's height, the count is not trusted: ``unsure`` is set (the
    caller asks the generalised winding number there)."""
    for i in prange(points.shape[0]):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        ci = int(math.floor((px - origin[0]) / cell))
        cj = int(math.floor((py - origin[1]) / cell))
        w = 0
        bad = False
        if ci >= 0 and ci < nx and cj >= 0 and cj < ny:
            c = ci * ny + cj
            for m in range(starts[c], starts[c + 1]):
                f = members[m]
                ax, ay = tri[f, 0, 0] - px, tri[f, 0, 1] - py
                bx, by = tri[f, 1, 0] - px, tri[f, 1, 1] - py
                cx, cy = tri[f, 2, 0] - px, tri[f, 2, 1] - py
                e0 = ax * by - ay * bx
                e1 = bx * cy - by * cx
                e2 = cx * ay - cy * ax
                area = e0 + e1 + e2
                scale = (abs(ax) + abs(ay) + abs(bx) + abs(by) + abs(cx) + abs(cy)) ** 2
                near = margin * scale
                if abs(area) <= near:
                    continue                              # a face seen edge-on from above
                s = 1.0 if area > 0 else -1.0
                f0, f1, f2 = s * e0, s * e1, s * e2
                if f0 < -near or f1 < -near or f2 < -near:
                    continue                              # the ray misses the face
                if f0 <= near or f1 <= near or f2 <= near:
                    bad = True                            # it grazes an edge or a corner
                    continue
                # the face's height over the point (barycentric: e1 at a, e2 at b, e0 at c)
                z = (e1 * tri[f, 0, 2] + e2 * tri[f, 1, 2] + e0 * tri[f, 2, 2]) / area
                if abs(z - pz) <= margin:
                    bad = True
                elif z > pz:
                    w += sign[f]
        out[i] = w
        unsure[i] = bad
