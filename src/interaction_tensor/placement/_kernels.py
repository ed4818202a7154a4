"""Numba kernels of the placement tests (:mod:`.checks`) and of hanging's fit test
(:func:`.hooks.fits`), each with a NumPy or SciPy reference it is tested against.

The clearance test's: for each placement, how many clearance points have a scene sample
nearer than their free space. A ball-emptiness test on the scene's grid: only the cells
that meet the ball are visited and a point stops at its first sample inside, so open space
costs a few cell look-ups. Exact: it answers ``d < need`` for the nearest sample's distance
``d``, as the reference (a bounded cKDTree query) does. The other tests' kernels visit the
cells under their boxes, columns, openings and axes in the same way.
"""

import math

import numpy as np
from numba import njit, prange


@njit(cache=True, inline="always")
def _cells(lo, hi, o, cell, n):
    """The cells (first, last) along one axis that meet [lo, hi]."""
    return (max(int(math.floor((lo - o) / cell)), 0),
            min(int(math.floor((hi - o) / cell)), n - 1))


@njit(cache=True, inline="always")
def _span(q, r, o, cell, n):
    """The cells (first, last) along one axis that meet [q - r, q + r]."""
    return _cells(q - r, q + r, o, cell, n)


#: Slack (m) on the free distance of a cell against the float32 rounding of its table: a
#: ball is known empty only when its radius is at most the free distance less this.
FREE_SLACK = 1e-6


@njit(cache=True, inline="always")
def _known_free(qx, qy, qz, r, free, ox, oy, oz, cell, nx, ny, nz):
    """True when no sample can lie within r of q: q's cell is at least r (less
    :data:`FREE_SLACK`) from every non-empty cell (``free``, :func:`.grid.free_distances`).
    False outside the grid, or where the table cannot tell."""
    ci = int(math.floor((qx - ox) / cell))
    cj = int(math.floor((qy - oy) / cell))
    ck = int(math.floor((qz - oz) / cell))
    if ci < 0 or ci >= nx or cj < 0 or cj >= ny or ck < 0 or ck >= nz:
        return False
    return free[(ci * ny + cj) * nz + ck] - FREE_SLACK >= r


@njit(cache=True, inline="always")
def _occupied_within(qx, qy, qz, r, pts, starts, ox, oy, oz, cell, nx, ny, nz):
    """True when some sample lies at a distance < r from q. Only the cells whose box comes
    within r of q (with 1 um of slack against the rounding of the box's edges) are
    visited."""
    i0, i1 = _span(qx, r, ox, cell, nx)
    j0, j1 = _span(qy, r, oy, cell, ny)
    k0, k1 = _span(qz, r, oz, cell, nz)
    rr = (r + 1e-6) * (r + 1e-6)
    for i in range(i0, i1 + 1):
        gx = max(ox + i * cell - qx, qx - (ox + (i + 1) * cell), 0.0)
        for j in range(j0, j1 + 1):
            gy = max(oy + j * cell - qy, qy - (oy + (j + 1) * cell), 0.0)
            if gx * gx + gy * gy > rr:
                continue
            base = (i * ny + j) * nz
            for k in range(k0, k1 + 1):
                gz = max(oz + k * cell - qz, qz - (oz + (k + 1) * cell), 0.0)
                if gx * gx + gy * gy + gz * gz > rr:
                    continue
                c = base + k
                for p in range(starts[c], starts[c + 1]):
                    dx = pts[p, 0] - qx
                    dy = pts[p, 1] - qy
                    dz = pts[p, 2] - qz
                    if math.sqrt(dx * dx + dy * dy + dz * dz) < r:
                        return True
    return False


@njit(cache=True, parallel=True)
def violation_counts(points, orient, offsets, need, stop, pts, starts, free, origin, cell,
                     dims, out):
    """out[i] = number of k with a sample nearer than need[k] to points[i] + offsets[orient[i], k],
    counted up to ``stop`` (a pair stops there). A point whose cell is known free that far
    (``free``) costs one look-up."""
    ox, oy, oz = origin[0], origin[1], origin[2]
    nx, ny, nz = dims[0], dims[1], dims[2]
    for i in prange(points.shape[0]):
        o = orient[i]
        n = 0
        for k in range(need.shape[0]):
            qx = points[i, 0] + offsets[o, k, 0]
            qy = points[i, 1] + offsets[o, k, 1]
            qz = points[i, 2] + offsets[o, k, 2]
            if _known_free(qx, qy, qz, need[k], free, ox, oy, oz, cell, nx, ny, nz):
                continue
            if _occupied_within(qx, qy, qz, need[k], pts, starts, ox, oy, oz, cell, nx, ny, nz):
                n += 1
                if n >= stop:
                    break
        out[i] = n


def counts(points, orient, offsets, need, grid, stop: int | None = None) -> np.ndarray:
    """(P,) int64 violations (see :func:`violation_counts`) on ``grid``, each counted up to
    ``stop`` (None: all of them)."""
    out = np.zeros(len(points), np.int64)
    if len(points):
        violation_counts(np.ascontiguousarray(points, np.float64),
                         np.ascontiguousarray(orient, np.int64),
                         np.ascontiguousarray(offsets, np.float64),
                         np.ascontiguousarray(need, np.float64),
                         len(need) + 1 if stop is None else int(stop), grid.points,
                         grid.starts, grid.free, np.asarray(grid.origin, np.float64),
                         float(grid.cell), np.asarray(grid.dims, np.int64), out)
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


@njit(cache=True, parallel=True)
def box_hits(at, rot, box, pts, starts, origin, cell, dims, out):
    """out[i] = 1 when some sample lies in placement i's box: ``box`` ((x0, x1), (y0, y1),
    (z0, z1)) relative to ``at[i]``, turned about +Z by ``rot[i]`` (2, 2) (a sample p is in
    it when ``rot[i].T @ (p - at[i])[:2]`` lies in the x-y ranges and ``p[2] - at[i, 2]`` in
    the z range, edges included, as the judge's ``_in_column``). Only the cells meeting the
    turned box's bounding box are visited; a placement stops at its first sample inside."""
    ox, oy, oz = origin[0], origin[1], origin[2]
    nx, ny, nz = dims[0], dims[1], dims[2]
    x0, x1, y0, y1, z0, z1 = box[0, 0], box[0, 1], box[1, 0], box[1, 1], box[2, 0], box[2, 1]
    for i in prange(at.shape[0]):
        r00, r01, r10, r11 = rot[i, 0, 0], rot[i, 0, 1], rot[i, 1, 0], rot[i, 1, 1]
        ax, ay, az = at[i, 0], at[i, 1], at[i, 2]
        lo_x = hi_x = r00 * x0 + r01 * y0
        lo_y = hi_y = r10 * x0 + r11 * y0
        for cx, cy in ((x0, y1), (x1, y0), (x1, y1)):
            wx = r00 * cx + r01 * cy
            wy = r10 * cx + r11 * cy
            lo_x = min(lo_x, wx)
            hi_x = max(hi_x, wx)
            lo_y = min(lo_y, wy)
            hi_y = max(hi_y, wy)
        # the cells of the bounding box, widened by 1 nm against rounding at its edges
        i0, i1 = _cells(ax + lo_x - 1e-9, ax + hi_x + 1e-9, ox, cell, nx)
        j0, j1 = _cells(ay + lo_y - 1e-9, ay + hi_y + 1e-9, oy, cell, ny)
        k0, k1 = _cells(az + z0 - 1e-9, az + z1 + 1e-9, oz, cell, nz)
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
                        h = pts[p, 2] - az
                        if h < z0 or h > z1:
                            continue
                        dx = pts[p, 0] - ax
                        dy = pts[p, 1] - ay
                        u = r00 * dx + r10 * dy
                        v = r01 * dx + r11 * dy
                        if u >= x0 and u <= x1 and v >= y0 and v <= y1:
                            found = True
                            break
        out[i] = 1 if found else 0


def boxes(at, rot, box, grid) -> np.ndarray:
    """(P,) bool :func:`box_hits` on ``grid``."""
    out = np.zeros(len(at), np.int8)
    if len(at):
        box_hits(np.ascontiguousarray(at, np.float64), np.ascontiguousarray(rot, np.float64),
                 np.ascontiguousarray(box, np.float64), grid.points, grid.starts,
                 np.asarray(grid.origin, np.float64), float(grid.cell),
                 np.asarray(grid.dims, np.int64), out)
    return out.astype(bool)


@njit(cache=True, inline="always")
def _scan_nearest(qx, qy, qz, s0, s1, pts, best, at):
    """The least distance (m) from q of samples ``s0:s1`` and ``best``, and its sample
    (``at`` where none of them is nearer)."""
    for p in range(s0, s1):
        dx = pts[p, 0] - qx
        dy = pts[p, 1] - qy
        dz = pts[p, 2] - qz
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        if d < best:
            best = d
            at = p
    return best, at


@njit(cache=True, parallel=True)
def bounded_nearest(q, lo, hi, pts, starts, free, origin, cell, dims, out, at):
    """out[i] = the distance of query i's nearest sample when it lies in (lo, hi], some
    distance <= lo when one does (the query stops there), inf when none lies within hi;
    at[i] the sample (-1 with inf). Whether the nearest sample lies within any r in
    [lo, hi] is then ``out <= r``, as for the exact nearest distance, and with ``lo`` 0,
    ``at`` is the nearest sample itself wherever it lies within hi. A query whose cell is
    known free past hi (``free``) costs one look-up; otherwise the query's own cell is
    scanned first (a contact point touching a surface stops there), then the other cells
    that meet the ball of ``hi``; the distance is numpy's ``norm(p - q)`` (the same sums,
    in the same order)."""
    ox, oy, oz = origin[0], origin[1], origin[2]
    nx, ny, nz = dims[0], dims[1], dims[2]
    for i in prange(q.shape[0]):
        qx, qy, qz = q[i, 0], q[i, 1], q[i, 2]
        best = math.inf
        near = -1
        if _known_free(qx, qy, qz, hi, free, ox, oy, oz, cell, nx, ny, nz):
            out[i] = math.inf
            at[i] = -1
            continue
        ci = int(math.floor((qx - ox) / cell))
        cj = int(math.floor((qy - oy) / cell))
        ck = int(math.floor((qz - oz) / cell))
        own = ci >= 0 and ci < nx and cj >= 0 and cj < ny and ck >= 0 and ck < nz
        if own:
            c = (ci * ny + cj) * nz + ck
            best, near = _scan_nearest(qx, qy, qz, starts[c], starts[c + 1], pts, best, near)
        if best > lo:
            i0, i1 = _span(qx, hi, ox, cell, nx)
            j0, j1 = _span(qy, hi, oy, cell, ny)
            k0, k1 = _span(qz, hi, oz, cell, nz)
            for a in range(i0, i1 + 1):
                if best <= lo:
                    break
                gx = max(ox + a * cell - qx, qx - (ox + (a + 1) * cell), 0.0)
                for b in range(j0, j1 + 1):
                    if best <= lo:
                        break
                    gy = max(oy + b * cell - qy, qy - (oy + (b + 1) * cell), 0.0)
                    base = (a * ny + b) * nz
                    for c in range(k0, k1 + 1):
                        if own and a == ci and b == cj and c == ck:
                            continue
                        gz = max(oz + c * cell - qz, qz - (oz + (c + 1) * cell), 0.0)
                        # a cell whose box lies beyond the ball (with 1 um of slack
                        # against rounding of the box's edges) holds no sample within hi
                        if gx * gx + gy * gy + gz * gz > (hi + 1e-6) * (hi + 1e-6):
                            continue
                        best, near = _scan_nearest(qx, qy, qz, starts[base + c],
                                                   starts[base + c + 1], pts, best, near)
                        if best <= lo:
                            break
        if best <= hi:
            out[i] = best
            at[i] = near
        else:
            out[i] = math.inf
            at[i] = -1


def nearest_within(q, lo: float, hi: float, grid, index: bool = False):
    """(Q,) :func:`bounded_nearest` of queries ``q`` (Q, 3) on ``grid``; with ``index``,
    also (Q,) the samples found (indices into the scene's points, -1 where none)."""
    q = np.ascontiguousarray(q, np.float64).reshape(-1, 3)
    out = np.empty(len(q))
    at = np.empty(len(q), np.int64)
    if len(q):
        bounded_nearest(q, float(lo), float(hi), grid.points, grid.starts, grid.free,
                        np.asarray(grid.origin, np.float64), float(grid.cell),
                        np.asarray(grid.dims, np.int64), out, at)
    if not index:
        return out
    if grid.order is not None:
        at = np.where(at >= 0, grid.order[np.maximum(at, 0)], -1)
    return out, at


@njit(cache=True, inline="always")
def _outward(centre, t):
    """The t-th cell from ``centre`` outwards along an axis: centre, +1, -1, +2, -2, ..."""
    d = (t + 1) // 2
    return centre + d if t % 2 == 1 else centre - d


@njit(cache=True, parallel=True)
def tap_hits(openings, radius, h_lo, h_hi, disk, max_cover, max_angle, cover_cell, eighth,
             ten, pts, starts, origin, cell, dims, out):
    """out[i] = 1 when a tap's spout is above opening i (:func:`.taps.tap_above`, the same
    arithmetic): samples from ``h_lo`` to ``h_hi`` above it and within ``disk`` of its
    vertical axis, some within ``radius``, covering at most ``max_cover`` of the disk in
    ``cover_cell`` plan cells, and those beyond ``radius`` in no two opposite eighths
    (``eighth``: pi / 4) and in at most ``max_angle`` degrees of 10-degree bins (``ten``:
    10 degrees in radians)."""
    ox, oy, oz = origin[0], origin[1], origin[2]
    nx, ny, nz = dims[0], dims[1], dims[2]
    side = int(2.0 * disk / cover_cell) + 4
    for i in prange(openings.shape[0]):
        cx, cy = openings[i, 0], openings[i, 1]
        lo = openings[i, 2] + h_lo
        hi = openings[i, 2] + h_hi
        i0, i1 = _span(cx, disk, ox, cell, nx)
        j0, j1 = _span(cy, disk, oy, cell, ny)
        k0, k1 = _cells(lo, hi, oz, cell, nz)
        fx = math.floor((cx - disk) / cover_cell) - 1
        fy = math.floor((cy - disk) / cover_cell) - 1
        covered = np.zeros((side, side), np.bool_)
        eighths = np.zeros(8, np.bool_)
        bins = np.zeros(36, np.bool_)
        near = False
        n_cover = 0
        most = max_cover * math.pi * disk ** 2 / cover_cell ** 2
        dead = False                  # a test already failed: the rest cannot save it
        # columns from the axis outwards: under a shelf or a ceiling, the samples on either
        # side of the axis fail the test within a few columns (the decision is the same in
        # any order: it needs every sample, or fails at the first that fails it)
        ac = min(max(int(math.floor((cx - ox) / cell)), i0), i1)
        bc = min(max(int(math.floor((cy - oy) / cell)), j0), j1)
        for ta in range(2 * (i1 - i0) + 1):
            if dead:
                break
            a = _outward(ac, ta)
            if a < i0 or a > i1:
                continue
            for tb in range(2 * (j1 - j0) + 1):
                if dead:
                    break
                b = _outward(bc, tb)
                if b < j0 or b > j1:
                    continue
                base = (a * ny + b) * nz
                for c in range(k0, k1 + 1):
                    if dead:
                        break
                    for p in range(starts[base + c], starts[base + c + 1]):
                        z = pts[p, 2]
                        if z < lo or z > hi:
                            continue
                        dx = pts[p, 0] - cx
                        dy = pts[p, 1] - cy
                        r = math.sqrt(dx * dx + dy * dy)
                        if r > disk:
                            continue
                        u = min(max(int(math.floor(pts[p, 0] / cover_cell) - fx), 0), side - 1)
                        v = min(max(int(math.floor(pts[p, 1] / cover_cell) - fy), 0), side - 1)
                        if not covered[u, v]:
                            covered[u, v] = True
                            n_cover += 1
                            if n_cover > most + 1.0:      # surely past the cover allowed
                                dead = True
                                break
                        if r <= radius:
                            near = True
                        else:
                            angle = math.atan2(dy, dx) + math.pi
                            e = int(min(max(math.floor(angle / eighth), 0.0), 7.0))
                            eighths[e] = True
                            if eighths[(e + 4) % 8]:
                                dead = True
                                break
                            g = min(max(math.floor(angle / ten), 0.0), 35.0)
                            bins[int(g)] = True
        ok = near and not dead and n_cover * cover_cell ** 2 / (math.pi * disk ** 2) <= max_cover
        if ok:
            n = 0
            for g in range(36):
                if bins[g]:
                    n += 1
            ok = 10.0 * n <= max_angle
        out[i] = 1 if ok else 0


def taps(openings, radius, height, disk, max_cover, max_angle, grid,
         cover_cell: float = 0.02) -> np.ndarray:
    """(P,) bool :func:`tap_hits` on ``grid``."""
    out = np.zeros(len(openings), np.int8)
    if len(openings):
        tap_hits(np.ascontiguousarray(openings, np.float64), float(radius), float(height[0]),
                 float(height[1]), float(disk), float(max_cover), float(max_angle),
                 float(cover_cell), float(np.pi / 4), float(np.radians(10)), grid.points,
                 grid.starts, np.asarray(grid.origin, np.float64), float(grid.cell),
                 np.asarray(grid.dims, np.int64), out)
    return out.astype(bool)


@njit(cache=True, parallel=True)
def highest_offsets(points, orient, offsets, limit, starts, heights, origin, cell, nx, ny,
                    out):
    """out[i] = the highest of ``heights`` at most ``limit[i]`` in the columns (of edge
    ``cell``, the :meth:`.scene.ColumnIndex.table`) under the points
    ``points[i, :2] + offsets[orient[i], f]`` and their 8 neighbours, -inf where there is
    none: :meth:`~.scene.ColumnIndex.highest_under` without its (P, F, 2) arrays."""
    ox, oy = origin[0], origin[1]
    for i in prange(points.shape[0]):
        o = orient[i]
        lim = limit[i]
        best = -math.inf
        for f in range(offsets.shape[1]):
            ci = int(math.floor((points[i, 0] + offsets[o, f, 0]) / cell)) - ox
            cj = int(math.floor((points[i, 1] + offsets[o, f, 1]) / cell)) - oy
            for a in range(ci - 1, ci + 2):
                if a < 0 or a >= nx:
                    continue
                for b in range(cj - 1, cj + 2):
                    if b < 0 or b >= ny:
                        continue
                    c = a * ny + b
                    lo, hi = starts[c], starts[c + 1]
                    if lo == hi or heights[lo] > lim or heights[hi - 1] <= best:
                        continue
                    # the last height <= lim (ascending): a binary search
                    while hi - lo > 1:
                        mid = (lo + hi) // 2
                        if heights[mid] <= lim:
                            lo = mid
                        else:
                            hi = mid
                    if heights[lo] > best:
                        best = heights[lo]
        out[i] = best


def highest(points, orient, offsets, limit, table, cell: float) -> np.ndarray:
    """(P,) :func:`highest_offsets` on a column table (:meth:`.scene.ColumnIndex.table`)."""
    starts, heights, origin, nx, ny = table
    out = np.empty(len(points))
    if len(points):
        highest_offsets(np.ascontiguousarray(points, np.float64),
                        np.ascontiguousarray(orient, np.int64),
                        np.ascontiguousarray(offsets, np.float64),
                        np.ascontiguousarray(limit, np.float64), starts, heights,
                        np.asarray(origin, np.int64), float(cell), int(nx), int(ny), out)
    return out


# ----------------------------------------------------------------------- hanging's fit
@njit(cache=True)
def section_fit(tri, c, normal, offsets, extra, reach, step, rot, side, up, inside, limit,
                margin, link, least, bins):
    """:func:`.hooks.fits` on a mesh's cuts, the same arithmetic: the planes normal to
    ``normal`` at ``offsets`` (m) from ``c`` cut triangles ``tri`` (M, 3, 3) (the two edges
    each crosses, in edge order), a point every ``step`` or closer along each cut, and the
    scene points ``extra`` (E, 3) beside them, those within ``reach`` of ``c`` taken to the
    opening's frame (``rot``'s columns; ``side`` and ``up`` span its plane); pieces are the
    points linked within ``link``; True unless some piece reaching within ``inside`` of the
    axis has ``least`` points past ``limit`` (per direction bin, of ``bins``) plus
    ``margin``."""
    m = tri.shape[0]
    # the cuts' segments
    seg = np.empty((m * len(offsets), 2, 3))
    sv = np.empty(3)
    k = 0
    for o in offsets:
        for f in range(m):
            smin = math.inf
            smax = -math.inf
            for v in range(3):
                s0 = ((tri[f, v, 0] - c[0]) * normal[0] + (tri[f, v, 1] - c[1]) * normal[1]
                      + (tri[f, v, 2] - c[2]) * normal[2]) - o
                sv[v] = s0
                smin = min(smin, s0)
                smax = max(smax, s0)
            if not (smin < 0.0 and smax > 0.0):
                continue
            e = 0
            for v in range(3):
                w = (v + 1) % 3
                sa, sb = sv[v], sv[w]
                if (sa < 0.0 and sb >= 0.0) or (sa >= 0.0 and sb < 0.0):
                    t = sa / (sa - sb)
                    for j in range(3):
                        seg[k, e, j] = tri[f, v, j] + t * (tri[f, w, j] - tri[f, v, j])
                    e += 1
                    if e == 2:
                        break
            k += 1
    # the points along them, within reach, in the opening's frame
    total = 0
    counts = np.empty(k, np.int64)
    for g in range(k):
        dx = seg[g, 1, 0] - seg[g, 0, 0]
        dy = seg[g, 1, 1] - seg[g, 0, 1]
        dz = seg[g, 1, 2] - seg[g, 0, 2]
        counts[g] = int(math.ceil(math.sqrt(dx * dx + dy * dy + dz * dz) / step)) + 1
        total += counts[g]
    d = np.empty((total + extra.shape[0], 3))
    n = 0
    for g in range(k):
        cnt = counts[g]
        den = max(cnt - 1, 1)
        for q in range(cnt):
            f = q / den
            px = seg[g, 0, 0] + f * (seg[g, 1, 0] - seg[g, 0, 0]) - c[0]
            py = seg[g, 0, 1] + f * (seg[g, 1, 1] - seg[g, 0, 1]) - c[1]
            pz = seg[g, 0, 2] + f * (seg[g, 1, 2] - seg[g, 0, 2]) - c[2]
            if math.sqrt(px * px + py * py + pz * pz) > reach:
                continue
            for j in range(3):
                d[n, j] = px * rot[0, j] + py * rot[1, j] + pz * rot[2, j]
            n += 1
    for g in range(extra.shape[0]):
        px = extra[g, 0] - c[0]
        py = extra[g, 1] - c[1]
        pz = extra[g, 2] - c[2]
        if math.sqrt(px * px + py * py + pz * pz) > reach:
            continue
        for j in range(3):
            d[n, j] = px * rot[0, j] + py * rot[1, j] + pz * rot[2, j]
        n += 1
    d = d[:n]
    ins = np.zeros(n, np.bool_)
    past = np.zeros(n, np.bool_)
    any_inside = False
    n_past = 0
    width = 2.0 * math.pi / bins
    for i in range(n):
        x = d[i, 0] * side[0] + d[i, 1] * side[1] + d[i, 2] * side[2]
        z = d[i, 0] * up[0] + d[i, 1] * up[1] + d[i, 2] * up[2]
        r = math.hypot(x, z)
        ins[i] = r <= inside
        any_inside = any_inside or ins[i]
        b = int(min(max(math.floor((math.atan2(z, x) + math.pi) / width), 0.0), bins - 1.0))
        past[i] = r > limit[b] + margin
        if past[i]:
            n_past += 1
    if not any_inside or n_past < least:
        return True
    # the pieces through the opening: a flood from the points inside it over the links
    # (points within link of each other, found on a grid of cells link wide), counting
    # the points past the limit it reaches, until least of them
    lo = np.empty(3)
    dims = np.empty(3, np.int64)
    for j in range(3):
        lo[j] = d[:, j].min()
        dims[j] = int(math.floor((d[:, j].max() - lo[j]) / link)) + 1
    cell = np.empty((n, 3), np.int64)
    key = np.empty(n, np.int64)
    for i in range(n):
        for j in range(3):
            cell[i, j] = int(math.floor((d[i, j] - lo[j]) / link))
        key[i] = (cell[i, 0] * dims[1] + cell[i, 1]) * dims[2] + cell[i, 2]
    order = np.argsort(key)
    skey = key[order]
    seen = ins.copy()
    queue = np.flatnonzero(ins)
    stack = np.empty(n, np.int64)
    top = len(queue)
    stack[:top] = queue
    bad = 0
    for i in range(top):
        if past[stack[i]]:
            bad += 1
    if bad >= least:
        return False
    l2 = link * link
    while top > 0:
        top -= 1
        i = stack[top]
        for a in range(max(cell[i, 0] - 1, 0), min(cell[i, 0] + 1, dims[0] - 1) + 1):
            for b in range(max(cell[i, 1] - 1, 0), min(cell[i, 1] + 1, dims[1] - 1) + 1):
                for cc in range(max(cell[i, 2] - 1, 0), min(cell[i, 2] + 1, dims[2] - 1) + 1):
                    kk = (a * dims[1] + b) * dims[2] + cc
                    s = np.searchsorted(skey, kk)
                    while s < n and skey[s] == kk:
                        o = order[s]
                        s += 1
                        if seen[o]:
                            continue
                        ex = d[o, 0] - d[i, 0]
                        ey = d[o, 1] - d[i, 1]
                        ez = d[o, 2] - d[i, 2]
                        if ex * ex + ey * ey + ez * ez <= l2:
                            seen[o] = True
                            stack[top] = o
                            top += 1
                            if past[o]:
                                bad += 1
                                if bad >= least:
                                    return False
    return True
