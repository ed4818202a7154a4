"""The z-buffer splat of :meth:`~.raster.Canvas.points` as a Numba kernel: the same pixels,
depths and winners as the NumPy reference (``Canvas.points(..., reference=True)``), without
its scatter-minimum (``np.minimum.at``), which cost most of a large scene's picture."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def splat(ix, iy, z, gx, gy, dx, dy, w, h, depth, winner):  # pragma: no cover - compiled
    """Splat points (pixel ``ix``, ``iy``, depth ``z``; depth slopes ``gx``, ``gy`` across
    the disk, or empty) with the disk offsets ``dx``, ``dy`` into ``depth`` (flat, float32,
    kept at the minimum), then mark in ``winner`` (flat, int64, -1 elsewhere) the last point
    whose depth at a pixel is that minimum, as the reference does: the same pass twice,
    first keeping the minimum, then marking who reaches it."""
    n, m = ix.shape[0], dx.shape[0]
    slope = gx.shape[0] > 0
    for mark in (False, True):
        for i in range(n):
            for j in range(m):
                x, y = ix[i] + dx[j], iy[i] + dy[j]
                if x < 0 or x >= w or y < 0 or y >= h:
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
