"""The z-buffer splat of :meth:`~.raster.Canvas.points` as a Numba kernel: the same pixels,
depths and winners as the NumPy reference (``Canvas.points(..., reference=True)``), without
its scatter-minimum (``np.minimum.at``), which cost most of a large scene's picture, in one
pass over every splat size, and in bands of rows shared among the threads."""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True, parallel=True)
def splat(ix, iy, z, gx, gy, radius, dx, dy, first, w, h, bands, depth,
          winner):  # pragma: no cover - compiled
    """Splat points (pixel ``ix``, ``iy``, depth ``z``; depth slopes ``gx``, ``gy`` across
    the disk, or empty; point ``i`` with the disk offsets ``dx``, ``dy`` from
    ``first[radius[i]]`` to ``first[radius[i] + 1]``) into ``depth`` (flat, float32, kept
    at the minimum), then mark in ``winner`` (flat, int64, -1 elsewhere) the last point
    whose depth at a pixel is that minimum: the same pass twice, first keeping the
    minimum, then marking who reaches it. Given the points in the reference's order (by
    radius, then as given), the depths and winners are the reference's. Each of ``bands``
    bands of rows is one thread's, which takes every point in order: a pixel is written by
    one thread only, whatever their number."""
    n = ix.shape[0]
    slope = gx.shape[0] > 0
    rows = (h + bands - 1) // bands
    for b in prange(bands):
        y0 = b * rows
        y1 = min(h, y0 + rows)
        for mark in (False, True):
            for i in range(n):
                r = radius[i]
                if iy[i] + r < y0 or iy[i] - r >= y1:
                    continue
                for j in range(first[r], first[r + 1]):
                    x, y = ix[i] + dx[j], iy[i] + dy[j]
                    if x < 0 or x >= w or y < y0 or y >= y1:
                        continue
                    d = z[i]
                    if slope:
                        d = d + gx[i] * np.float32(dx[j])
                        d = d + gy[i] * np.float32(dy[j])
                    f = y * w + x
                    if not mark:
                        if d < depth[f]:
                            depth[f] = d
                    elif d <= depth[f]:
                        winner[f] = i
