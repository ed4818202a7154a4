"""The point splats of :meth:`~.raster.Canvas.points` as Numba kernels: the projection and
culling of the points (the same arithmetic, in the same order, as the NumPy reference's,
so the same bits), and the z-buffer splat, the same pixels, depths, colours and normals as
the reference (``Canvas.points(..., reference=True)``) without its scatter-minimum
(``np.minimum.at``), which cost most of a large scene's picture, in one pass over every
splat size, in bands of rows shared among the threads."""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True, inline="always")
def _camera(pts, i, eye, axes, focal, w, h):  # pragma: no cover - compiled
    """Point ``i`` in the camera's frame (right, up, forward) and its pixel coordinates."""
    x = pts[i, 0] - eye[0]
    y = pts[i, 1] - eye[1]
    z = pts[i, 2] - eye[2]
    c0 = x * axes[0, 0] + y * axes[0, 1] + z * axes[0, 2]
    c1 = x * axes[1, 0] + y * axes[1, 1] + z * axes[1, 2]
    c2 = x * axes[2, 0] + y * axes[2, 1] + z * axes[2, 2]
    zs = c2 if abs(c2) > 1e-9 else 1e-9
    px = 0.5 * w + focal * c0 / zs
    py = 0.5 * h - focal * c1 / zs
    return c0, c1, c2, px, py


@njit(cache=True, parallel=True)
def visible(pts, eye, axes, focal, w, h, near, keep):  # pragma: no cover - compiled
    """``keep[i]``: point ``i`` lies past the near plane and within 50 pixels of the
    picture."""
    for i in prange(pts.shape[0]):
        _, _, c2, px, py = _camera(pts, i, eye, axes, focal, w, h)
        keep[i] = (c2 > near and px > -50 and px < w + 50 and py > -50 and py < h + 50
                   and np.isfinite(px) and np.isfinite(py))


@njit(cache=True, parallel=True)
def prepare(pts, normals, idx, eye, axes, focal, w, h, half_size, fixed, max_radius,
            ix, iy, z, radius, nrm, gx, gy):  # pragma: no cover - compiled
    """For the points ``idx``: pixel ``ix``, ``iy``, depth ``z`` and splat ``radius``
    (``fixed`` pixels, or ``half_size`` m across at the depth, at most ``max_radius``);
    with ``normals`` (else empty), the normals turned to face the camera (``nrm``) and
    the depth's slopes across the disk (``gx``, ``gy``)."""
    shaded = normals.shape[0] > 0
    for k in prange(idx.shape[0]):
        i = idx[k]
        c0, c1, c2, px, py = _camera(pts, i, eye, axes, focal, w, h)
        ix[k] = np.int64(np.rint(px))
        iy[k] = np.int64(np.rint(py))
        z[k] = c2
        if fixed >= 0:
            radius[k] = fixed
        else:
            radius[k] = min(max(np.int64(np.rint(half_size * focal / c2)), 0), max_radius)
        if shaded:
            n0, n1, n2 = normals[i, 0], normals[i, 1], normals[i, 2]
            a = n0 * axes[0, 0] + n1 * axes[0, 1] + n2 * axes[0, 2]
            b = n0 * axes[1, 0] + n1 * axes[1, 1] + n2 * axes[1, 2]
            c = n0 * axes[2, 0] + n1 * axes[2, 1] + n2 * axes[2, 2]
            sign = -1.0 if a * c0 + b * c1 + c * c2 > 0 else 1.0
            nrm[k, 0], nrm[k, 1], nrm[k, 2] = n0 * sign, n1 * sign, n2 * sign
            a, b, c = a * sign, b * sign, c * sign
            c = min(c, -0.35) if c < 0 else max(c, 0.35)
            gx[k] = np.float32(-a / c * c2 / focal)
            gy[k] = np.float32(b / c * c2 / focal)


@njit(cache=True, parallel=True)
def splat(ix, iy, z, gx, gy, radius, order, dx, dy, first, w, h, bands, depth, winner, box,
          idx, cols, nrm, albedo, normal, lit):  # pragma: no cover - compiled
    """Splat the points ``order`` (pixel ``ix``, ``iy``, depth ``z``; depth slopes ``gx``,
    ``gy`` across the disk, or empty; point ``i`` with the disk offsets ``dx``, ``dy`` from
    ``first[radius[i]]`` to ``first[radius[i] + 1]``) into ``depth`` (flat, float32, kept
    at the minimum), then paint each pixel a point reached with the colour (``cols`` of
    ``idx[i]``, 0-255, or its one row for all) and, unless ``nrm`` is empty, the normal
    (lit) of the last point ``i`` in ``order`` whose depth there is the minimum.

    Each of ``bands`` bands of rows is one thread's, which takes every point in order and
    keeps at each pixel the depth and the last point at or below it (``winner``, flat,
    int64, -1 everywhere before and after), so a pixel is written by one thread only,
    whatever their number. Given the points in the reference's order (by radius, then as
    given), that point is the one the reference paints last: a later point wins a tie, as
    its paint over the scatter-minimum does. Then the band's part of ``box`` (x0, x1, y0,
    y1: the pixels the disks reach) is painted and its winners reset."""
    slope = gx.shape[0] > 0
    shaded = nrm.shape[0] > 0
    one = cols.shape[0] == 1
    rows = (h + bands - 1) // bands
    for b in prange(bands):
        y0 = b * rows
        y1 = min(h, y0 + rows)
        for i in order:
            r = radius[i]
            if iy[i] + r < y0 or iy[i] - r >= y1:
                continue
            zi = np.float32(z[i])
            for j in range(first[r], first[r + 1]):
                x, y = ix[i] + dx[j], iy[i] + dy[j]
                if x < 0 or x >= w or y < y0 or y >= y1:
                    continue
                d = zi
                if slope:
                    d = d + gx[i] * np.float32(dx[j])
                    d = d + gy[i] * np.float32(dy[j])
                f = y * w + x
                if d <= depth[f]:
                    depth[f] = d
                    winner[f] = i
        for y in range(max(y0, box[2]), min(y1, box[3])):
            for x in range(box[0], box[1]):
                f = y * w + x
                i = winner[f]
                if i < 0:
                    continue
                winner[f] = -1
                o = 0 if one else idx[i]
                for c in range(3):
                    albedo[f, c] = cols[o, c] / np.float32(255.0)
                if shaded:
                    for c in range(3):
                        normal[f, c] = nrm[i, c]
                lit[f] = shaded
