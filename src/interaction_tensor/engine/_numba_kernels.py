"""Numba-compiled kernels (imported only when Numba is available; see numba_backend.py).

Two exact nearest-neighbour searches feed the same per-keypoint arithmetic (:func:`_term`):

* :func:`nearest`: shell search on the uniform grid of :class:`~interaction_tensor.geometry.grid.Grid` (any query, no
  set-up; about 0.2 us near the surface); a query more than ``FAR_CELLS`` cells from its
  seed sample searches the occupied blocks of ``FAR_BLOCK``^3 cells instead
  (:func:`_nearest_far`), where the shells would visit every empty cell of the ball;
* the neighbour cache (:func:`_leaf`, :func:`_scan_list`; used by :func:`score_cached`):
  octrees over root blocks of the queried space whose leaves hold every scene sample that
  can be the nearest one to some point of the leaf's box (the samples whose Voronoi cell
  meets the box, plus possibly a few more). A query descends to its leaf and scans one short
  list (10 to 30 samples). Root blocks are built whole when queries reach them
  (:func:`touched_roots`, :func:`collect_requests`, :func:`build_roots`, :func:`integrate`);
  until its block is built a query uses :func:`nearest`, so every answer is exact.

Ties: both searches return, among samples at the same computed squared distance, the one
scanned first; the shell and block searches scan the seed cell first and then by cell, the
lists are in sorted-point order, so they agree except for exact distance ties between
samples of different grid cells (none in the shared scenes; see benchmarks/kernel_speed.py).
"""

import math

import numpy as np
from numba import njit, prange

from interaction_tensor.engine.cache_layout import PAGE, PAGE_BITS
from interaction_tensor.geometry.grid import FAR_BLOCK, FAR_CELLS


@njit(cache=True, inline="always")
def _gap(f, c, d):
    """Distance, in cells, from coordinate ``f`` (cell units, in cell ``c``) to cell c + d."""
    if d > 0:
        return d - (f - c)
    if d < 0:
        return (f - c) - d - 1.0
    return 0.0


@njit(cache=True, inline="always")
def _scan_cell(qx, qy, qz, pts, lo, hi, best, besti):
    """Closest of points ``lo:hi`` to q if closer than ``best`` (squared): (best, besti)."""
    for p in range(lo, hi):
        dx = pts[p, 0] - qx
        dy = pts[p, 1] - qy
        dz = pts[p, 2] - qz
        d2 = dx * dx + dy * dy + dz * dz
        if d2 < best:
            best = d2
            besti = p
    return best, besti


@njit(cache=True, inline="always")
def _box_gap(q, lo, hi):
    """Distance from coordinate ``q`` to the interval [lo, hi] (0 inside)."""
    if q < lo:
        return lo - q
    if q > hi:
        return q - hi
    return 0.0


@njit(cache=True, fastmath=False)
def _nearest_far(qx, qy, qz, pts, starts, occ, ox, oy, oz, cell, nx, ny, nz, best, besti):
    """:func:`nearest` for a query far from every sample (its seed sample ``besti``, at
    squared distance ``best``, more than :data:`FAR_CELLS` cells away): visits the blocks of
    ``FAR_BLOCK``^3 cells (``occ``: 1 where a block holds a sample) that meet the ball of
    radius sqrt(best), and in the occupied ones the cells that meet it, each block or cell
    skipped when its box is farther than the best sample so far. A shell search of the
    same ball visits every one of its (radius / cell)^3 cells, empty or not.

    Boxes are compared with ``best`` enlarged by 1e-9 of itself, so that a sample on a box
    face is never missed by rounding; samples are taken when strictly closer, as in
    :func:`nearest` (the seed first, then by block and cell)."""
    B = FAR_BLOCK
    mby = (ny + B - 1) // B
    mbz = (nz + B - 1) // B
    bw = cell * B
    r = math.sqrt(best) * (1.0 + 1e-9) + 1e-12
    i0 = max(int(math.floor((qx - r - ox) / bw)), 0)
    i1 = min(int(math.floor((qx + r - ox) / bw)), (nx + B - 1) // B - 1)
    j0 = max(int(math.floor((qy - r - oy) / bw)), 0)
    j1 = min(int(math.floor((qy + r - oy) / bw)), mby - 1)
    k0 = max(int(math.floor((qz - r - oz) / bw)), 0)
    k1 = min(int(math.floor((qz + r - oz) / bw)), mbz - 1)
    for bi in range(i0, i1 + 1):
        gx = _box_gap(qx, ox + bi * bw, ox + (bi + 1) * bw)
        gx2 = gx * gx
        if gx2 > best * (1.0 + 1e-9):
            continue
        for bj in range(j0, j1 + 1):
            gy = _box_gap(qy, oy + bj * bw, oy + (bj + 1) * bw)
            gxy = gx2 + gy * gy
            if gxy > best * (1.0 + 1e-9):
                continue
            for bk in range(k0, k1 + 1):
                if occ[(bi * mby + bj) * mbz + bk] == 0:
                    continue
                gz = _box_gap(qz, oz + bk * bw, oz + (bk + 1) * bw)
                if gxy + gz * gz > best * (1.0 + 1e-9):
                    continue
                for i in range(bi * B, min(bi * B + B, nx)):
                    hx = _box_gap(qx, ox + i * cell, ox + (i + 1) * cell)
                    hx2 = hx * hx
                    if hx2 > best * (1.0 + 1e-9):
                        continue
                    for j in range(bj * B, min(bj * B + B, ny)):
                        hy = _box_gap(qy, oy + j * cell, oy + (j + 1) * cell)
                        hxy = hx2 + hy * hy
                        if hxy > best * (1.0 + 1e-9):
                            continue
                        base = (i * ny + j) * nz
                        for k in range(bk * B, min(bk * B + B, nz)):
                            c = base + k
                            if starts[c] == starts[c + 1]:
                                continue
                            hz = _box_gap(qz, oz + k * cell, oz + (k + 1) * cell)
                            if hxy + hz * hz > best * (1.0 + 1e-9):
                                continue
                            best, besti = _scan_cell(qx, qy, qz, pts, starts[c],
                                                     starts[c + 1], best, besti)
    return besti


@njit(cache=True, fastmath=False, inline="always")
def nearest(qx, qy, qz, pts, starts, seed, occ, ox, oy, oz, cell, nx, ny, nz):
    """Index (into the sorted points) of the exact nearest point to q.

    Starts from the points of the non-empty cell nearest to q's cell (``seed``, a distance
    transform of the occupancy), so that far queries begin with a close bound; then visits
    shells of cells around q's cell, skipping every cell (and every row and slab of cells)
    whose box is farther from q than the best point so far, and stops when no unvisited
    shell can hold a closer point.
    """
    fx = (qx - ox) / cell
    fy = (qy - oy) / cell
    fz = (qz - oz) / cell
    ci = int(math.floor(fx))
    cj = int(math.floor(fy))
    ck = int(math.floor(fz))
    # distance from q to the faces of its own cell, in cells (0 if outside the grid)
    m = min(fx - ci, ci + 1 - fx, fy - cj, cj + 1 - fy, fz - ck, ck + 1 - fz)
    # shells needed at least to reach the grid from outside
    out = max(0, -ci, ci - (nx - 1), -cj, cj - (ny - 1), -ck, ck - (nz - 1))
    if out > 0:
        m = 0.0
    best = np.inf
    besti = -1
    c2 = cell * cell
    sc = -1
    if out == 0:
        sc = seed[(ci * ny + cj) * nz + ck]
        best, besti = _scan_cell(qx, qy, qz, pts, starts[sc], starts[sc + 1], best, besti)
    else:                           # outside the grid: the seed of the nearest grid cell
        sf = seed[(min(max(ci, 0), nx - 1) * ny + min(max(cj, 0), ny - 1)) * nz
                  + min(max(ck, 0), nz - 1)]
        far, fi = _scan_cell(qx, qy, qz, pts, starts[sf], starts[sf + 1], np.inf, -1)
        if far > FAR_CELLS * FAR_CELLS * c2:
            return _nearest_far(qx, qy, qz, pts, starts, occ, ox, oy, oz, cell, nx, ny, nz,
                                far, fi)
    if best > FAR_CELLS * FAR_CELLS * c2 and besti >= 0:
        return _nearest_far(qx, qy, qz, pts, starts, occ, ox, oy, oz, cell, nx, ny, nz, best,
                            besti)
    bc = best / c2                  # best squared distance in cell units
    smax = max(nx, ny, nz) + out + 1
    for s in range(smax + 1):
        if besti >= 0:
            bound = (s - 1 + m) * cell
            if bound > 0 and best <= bound * bound:
                break
        if s < out:
            continue
        for di in range(-s, s + 1):
            i = ci + di
            if i < 0 or i >= nx:
                continue
            gx = _gap(fx, ci, di)
            gx2 = gx * gx
            if gx2 >= bc:
                continue
            edge_i = di == -s or di == s
            for dj in range(-s, s + 1):
                j = cj + dj
                if j < 0 or j >= ny:
                    continue
                gy = _gap(fy, cj, dj)
                gxy = gx2 + gy * gy
                if gxy >= bc:
                    continue
                if edge_i or dj == -s or dj == s:
                    step = 1
                else:
                    step = 2 * s if s > 0 else 1
                base = (i * ny + j) * nz
                dk = -s
                while dk <= s:
                    k = ck + dk
                    if 0 <= k < nz:
                        gz = _gap(fz, ck, dk)
                        c = base + k
                        if gxy + gz * gz < bc and c != sc:      # the seed cell is done
                            best, besti = _scan_cell(qx, qy, qz, pts, starts[c], starts[c + 1],
                                                     best, besti)
                            bc = best / c2
                    dk += step
    return besti


# --------------------------------------------------------------------- per-keypoint term
@njit(cache=True, inline="always")
def _term(qx, qy, qz, p, k, o, pts, nrm, prov, pnorm, weights, cos_lim, big_w, criterion, c,
          a, wsum, nk, surface, rho):
    """Normalised contribution of keypoint ``k`` (orientation ``o``, position q) whose nearest
    scene sample is ``p``: the test vector (to ``p``, or to its disk of radius ``rho`` when
    ``surface``) against the provenance vector, ``criterion`` 0 = paper, 1 = gaussian.
    The only copy of the scoring arithmetic: change it here."""
    vx = pts[p, 0] - qx
    vy = pts[p, 1] - qy
    vz = pts[p, 2] - qz
    if surface:
        ax = nrm[p, 0]
        ay = nrm[p, 1]
        az = nrm[p, 2]
        al = vx * ax + vy * ay + vz * az
        lx = vx - al * ax
        ly = vy - al * ay
        lz = vz - al * az
        lat = math.sqrt(lx * lx + ly * ly + lz * lz)
        sh = (lat - rho) / lat if lat > rho else 0.0
        vx = al * ax + lx * sh
        vy = al * ay + ly * sh
        vz = al * az + lz * sh
    px = prov[o, k, 0]
    py = prov[o, k, 1]
    pz = prov[o, k, 2]
    vn = math.sqrt(vx * vx + vy * vy + vz * vz)
    if criterion == 0:
        den = pnorm[k] * vn
        cosang = (px * vx + py * vy + pz * vz) / den if den > 0 else 0.0
        term = 0.0
        if cosang >= cos_lim[k]:       # angle <= limit, without acos
            term = 1.0
            if abs(pnorm[k] - vn) <= big_w[k] * pnorm[k] / c:
                term = 2.0
        return term / (2.0 * nk)
    dx = vx - px
    dy = vy - py
    dz = vz - pz
    d = math.sqrt(dx * dx + dy * dy + dz * dz) / max(pnorm[k], 1e-12)
    sg = a * (1.0 + weights[k])
    return weights[k] * math.exp(-d * d / (2.0 * sg * sg)) / wsum


@njit(cache=True, inline="always")
def _decision(s, k, rest, threshold, eps):
    """After keypoint ``k`` with running score ``s``: 1 when the threshold is reached
    (accepted), -1 when even the largest rest cannot reach it (rejected), 0 undecided."""
    if s >= threshold - eps:
        return 1
    if s + rest[k + 1] < threshold - eps:
        return -1
    return 0


@njit(cache=True, parallel=True, fastmath=False)
def score(tp, orient, offsets, prov, pnorm, weights, cos_lim, big_w, max_terms, rest,
          criterion, c, a, wsum, threshold, early_exit, surface, rho, resume,
          pts, nrm, starts, seed, origin, cell, dims, occ, out_score, out_acc, out_at,
          out_cmp):
    """Score pairs with the grid shell search for every keypoint (no set-up; the reference
    of :func:`score_cached`). Pair i: test point ``tp[i]`` (m), orientation ``orient[i]``;
    outputs per pair: score, accepted, decided_at, comparisons. ``early_exit``: 0 every
    keypoint of every pair, 1 a pair stops when it is rejected (the score of an accepted
    pair is complete), 2 a pair stops at its decision either way (the score is the partial
    sum at the decision). ``resume``: every pair goes on from its decision, keypoint
    ``out_at[i]`` on, adding to ``out_score[i]`` (the same sums, in the same order, as a
    pair never stopped)."""
    n_pairs = tp.shape[0]
    nk = offsets.shape[1]
    ox, oy, oz = origin[0], origin[1], origin[2]
    nx, ny, nz = dims[0], dims[1], dims[2]
    eps = 1e-12
    for i in prange(n_pairs):
        o = orient[i]
        s = 0.0
        decided = False
        acc = False
        at = nk
        done = 0
        first = 0
        if resume:
            s, decided, acc, at, first = out_score[i], True, out_acc[i], out_at[i], out_at[i]
        for k in range(first, nk):
            qx = tp[i, 0] + offsets[o, k, 0]
            qy = tp[i, 1] + offsets[o, k, 1]
            qz = tp[i, 2] + offsets[o, k, 2]
            p = nearest(qx, qy, qz, pts, starts, seed, occ, ox, oy, oz, cell, nx, ny, nz)
            s += _term(qx, qy, qz, p, k, o, pts, nrm, prov, pnorm, weights, cos_lim, big_w,
                       criterion, c, a, wsum, nk, surface, rho)
            done += 1
            if not decided:
                d = _decision(s, k, rest, threshold, eps)
                if d != 0:
                    decided, acc, at = True, d > 0, k + 1
                    if early_exit == 2 or (d < 0 and early_exit == 1):
                        break
        if not decided:
            acc = s >= threshold - eps
        out_score[i] = s
        out_acc[i] = acc
        out_at[i] = at
        out_cmp[i] = done


# --------------------------------------------------------------------- neighbour cache
# Cache layout (arrays owned by kernels.NeighbourCache):
#   root blocks on a block grid (origin ``bo``, block edge ``hb`` (m), ``bdims`` blocks per
#       axis, block (i, j, k) numbered (i * bdims[1] + j) * bdims[2] + k); their entries: the
#       root node, -1 not built, -2 requested, -3 not to be built (grid search), kept in
#       pages of PAGE^3 blocks: ``ptab`` (one int32 per PAGE^3 group of blocks, ``pdims``
#       groups per axis) gives the group's page or -1, ``pool`` holds the pages (:func:`_slot`)
#   child (M,) int32: first of the node's 8 children (octant = 4 x-high + 2 y-high + z-high),
#       -1 for a leaf
#   lstart (M,) int64, llen (M,) int32: a leaf's candidate list is
#       ``lists[lstart:lstart + llen]``, sorted-point indices in increasing order
# A node of depth d under root block (i, j, k) has edge hb / 2**d; its corner is the block
# corner ``bo + (i, j, k) * hb`` plus ``h / 2`` on every axis where it is in the upper half
# of its parent (h: the parent's edge), computed the same way by the queries and the builder.

@njit(cache=True, inline="always")
def _dominated(p, n, cx, cy, cz, e, tol, pts):
    """True when sample ``n`` is closer than sample ``p`` to every point of the cube of centre
    c and half-edge ``e`` by more than ``tol`` in squared distance, so that ``p`` can never
    be the nearest sample of a query in that cube. (|q-p|^2 - |q-n|^2 is linear in q: its
    minimum over the cube is its value at c minus 2 e |p - n|_1.)"""
    ax = pts[p, 0] - cx
    ay = pts[p, 1] - cy
    az = pts[p, 2] - cz
    bx = pts[n, 0] - cx
    by = pts[n, 1] - cy
    bz = pts[n, 2] - cz
    g = (ax * ax + ay * ay + az * az) - (bx * bx + by * by + bz * bz)
    g -= 2.0 * e * (abs(ax - bx) + abs(ay - by) + abs(az - bz))
    return g > tol


@njit(cache=True)
def _lattice_nearest(cand, m, lx, ly, lz, h, lattice, pts, out):
    """For the (lattice + 1)^3 points ``l + (a, b, c) h / lattice`` of a cube (corner l, edge
    ``h``, m), the candidate of ``cand[:m]`` nearest to each (first at equal distance), in
    ``out`` (index (a * (lattice + 1) + b) * (lattice + 1) + c)."""
    stp = h / lattice
    t = 0
    for ia in range(lattice + 1):
        qx = lx + ia * stp
        for ib in range(lattice + 1):
            qy = ly + ib * stp
            for ic in range(lattice + 1):
                qz = lz + ic * stp
                out[t] = _scan_list(qx, qy, qz, cand, 0, m, pts)
                t += 1


@njit(cache=True)
def _filter(cand, m, lx, ly, lz, h, pts, sep, lattice, tol):
    """Keep, in place and in order, the candidates ``cand[:m]`` (sorted-point indices) that
    no separator dominates on the cube of corner l and edge ``h`` (m), enlarged by h * 1e-6
    on every side for rounding (:func:`_dominated`). ``sep``: (lattice + 1)^3 samples in the
    order of :func:`_lattice_nearest` (any samples do; the nearer the box, the more they
    remove); each candidate is tried first against the separator of the lattice point
    nearest to it. Returns the new count."""
    dl = h * 1e-6
    e = 0.5 * h + dl
    cx = lx + 0.5 * h
    cy = ly + 0.5 * h
    cz = lz + 0.5 * h
    n1 = lattice + 1
    uniq = sep.copy()
    ns = _distinct(uniq, uniq.shape[0])
    stp = h / lattice
    w = 0
    for u in range(m):
        p = cand[u]
        ia = min(max(int(round((pts[p, 0] - lx) / stp)), 0), lattice)
        ib = min(max(int(round((pts[p, 1] - ly) / stp)), 0), lattice)
        ic = min(max(int(round((pts[p, 2] - lz) / stp)), 0), lattice)
        n = sep[(ia * n1 + ib) * n1 + ic]
        keep = n == p or not _dominated(p, n, cx, cy, cz, e, tol, pts)
        if keep:
            for t in range(ns):
                n = uniq[t]
                if n != p and _dominated(p, n, cx, cy, cz, e, tol, pts):
                    keep = False
                    break
        if keep:
            cand[w] = p
            w += 1
    return w


@njit(cache=True)
def _distinct(a, n):
    """Move the distinct values of ``a[:n]`` to its front (first occurrences, in order);
    returns their count."""
    k = 0
    for t in range(n):
        dup = False
        for v in range(k):
            if a[v] == a[t]:
                dup = True
                break
        if not dup:
            a[k] = a[t]
            k += 1
    return k


@njit(cache=True, inline="always")
def _box_dominated(x0, x1, y0, y1, z0, z1, n, cx, cy, cz, e, tol, pts):
    """True when sample ``n`` dominates (:func:`_dominated`) every point of the box
    [x0, x1] x [y0, y1] x [z0, z1] on the cube of centre c and half-edge ``e``: a lower bound
    of |c-p|^2 - |c-n|^2 - 2 e |p-n|_1 over the box exceeds ``tol``."""
    gx = max(x0 - cx, 0.0, cx - x1)
    gy = max(y0 - cy, 0.0, cy - y1)
    gz = max(z0 - cz, 0.0, cz - z1)
    bx = pts[n, 0] - cx
    by = pts[n, 1] - cy
    bz = pts[n, 2] - cz
    l1 = (max(abs(x0 - pts[n, 0]), abs(x1 - pts[n, 0])) +
          max(abs(y0 - pts[n, 1]), abs(y1 - pts[n, 1])) +
          max(abs(z0 - pts[n, 2]), abs(z1 - pts[n, 2])))
    g = (gx * gx + gy * gy + gz * gz) - (bx * bx + by * by + bz * bz) - 2.0 * e * l1
    return g > tol


@njit(cache=True, inline="always")
def _box_skipped(x0, y0, z0, size, cx, cy, cz, r2, lx, ly, lz, stp, lattice, sep, e, tol,
                 pts):
    """True when the cube of corner (x0, y0, z0) and edge ``size`` lies farther than sqrt(r2)
    from c, or the separator nearest to its centre dominates it (:func:`_box_dominated`)."""
    gx = max(x0 - cx, 0.0, cx - x0 - size)
    gy = max(y0 - cy, 0.0, cy - y0 - size)
    gz = max(z0 - cz, 0.0, cz - z0 - size)
    if gx * gx + gy * gy + gz * gz > r2:
        return True
    n1 = lattice + 1
    ia = min(max(int(round((x0 + 0.5 * size - lx) / stp)), 0), lattice)
    ib = min(max(int(round((y0 + 0.5 * size - ly) / stp)), 0), lattice)
    ic = min(max(int(round((z0 + 0.5 * size - lz) / stp)), 0), lattice)
    return _box_dominated(x0, x0 + size, y0, y0 + size, z0, z0 + size,
                          sep[(ia * n1 + ib) * n1 + ic], cx, cy, cz, e, tol, pts)


@njit(cache=True)
def _gather(lx, ly, lz, h, r, sep, lattice, tol, pts, starts, occ, cb, ox, oy, oz, cell, nx,
            ny, nz):
    """Candidates of the cube of corner l and edge ``h`` (m): the samples within ``r`` of its
    centre that no separator ``sep`` dominates on it (:func:`_filter`, same arguments),
    in increasing order: (array, count). Blocks of cb^3 grid cells with no sample (``occ``
    0) and boxes of cells or blocks that the separator nearest to them dominates are
    skipped whole."""
    buf = np.empty(1024, np.int64)
    m = 0
    dl = h * 1e-6
    e = 0.5 * h + dl
    cx = lx + 0.5 * h
    cy = ly + 0.5 * h
    cz = lz + 0.5 * h
    stp = h / lattice
    r2 = r * r
    i0 = max(0, int(math.floor((cx - r - ox) / cell)))
    i1 = min(nx - 1, int(math.floor((cx + r - ox) / cell)))
    j0 = max(0, int(math.floor((cy - r - oy) / cell)))
    j1 = min(ny - 1, int(math.floor((cy + r - oy) / cell)))
    k0 = max(0, int(math.floor((cz - r - oz) / cell)))
    k1 = min(nz - 1, int(math.floor((cz + r - oz) / cell)))
    mby = (ny + cb - 1) // cb
    mbz = (nz + cb - 1) // cb
    bc = cb * cell
    for bi in range(i0 // cb, i1 // cb + 1):
        x0 = ox + bi * bc
        for bj in range(j0 // cb, j1 // cb + 1):
            y0 = oy + bj * bc
            for bk in range(k0 // cb, k1 // cb + 1):
                if occ[(bi * mby + bj) * mbz + bk] == 0:
                    continue
                z0 = oz + bk * bc
                if _box_skipped(x0, y0, z0, bc, cx, cy, cz, r2, lx, ly, lz, stp, lattice, sep,
                                e, tol, pts):
                    continue
                for i in range(max(i0, bi * cb), min(i1, bi * cb + cb - 1) + 1):
                    xa = ox + i * cell
                    for j in range(max(j0, bj * cb), min(j1, bj * cb + cb - 1) + 1):
                        ya = oy + j * cell
                        base = (i * ny + j) * nz
                        for k in range(max(k0, bk * cb), min(k1, bk * cb + cb - 1) + 1):
                            c = base + k
                            if starts[c] == starts[c + 1]:
                                continue
                            za = oz + k * cell
                            if _box_skipped(xa, ya, za, cell, cx, cy, cz, r2, lx, ly, lz, stp,
                                            lattice, sep, e, tol, pts):
                                continue
                            for p in range(starts[c], starts[c + 1]):
                                dx = pts[p, 0] - cx
                                dy = pts[p, 1] - cy
                                dz = pts[p, 2] - cz
                                if dx * dx + dy * dy + dz * dz <= r2:
                                    if m == buf.shape[0]:
                                        nb = np.empty(2 * m, np.int64)
                                        nb[:m] = buf
                                        buf = nb
                                    buf[m] = p
                                    m += 1
    return buf, _filter(buf, m, lx, ly, lz, h, pts, sep, lattice, tol)


@njit(cache=True)
def _nearest_call(qx, qy, qz, pts, starts, seed, occ, ox, oy, oz, cell, nx, ny, nz):
    """:func:`nearest` as a real call: keeps the rare fallback out of the hot loop's code."""
    return nearest(qx, qy, qz, pts, starts, seed, occ, ox, oy, oz, cell, nx, ny, nz)


@njit(cache=True, inline="always")
def _slot(bi, bj, bk, ptab, pdims):
    """Where root block (bi, bj, bk)'s entry lies in the page pool (pages of PAGE^3 blocks,
    ``ptab``: page of each PAGE^3 group of blocks, -1 none), or -1 when its page is not
    allocated (the block is not built)."""
    pg = ptab[((bi >> PAGE_BITS) * pdims[1] + (bj >> PAGE_BITS)) * pdims[2] + (bk >> PAGE_BITS)]
    if pg < 0:
        return -1
    m = PAGE - 1
    return ((pg * PAGE + (bi & m)) * PAGE + (bj & m)) * PAGE + (bk & m)


@njit(cache=True, inline="always")
def _block_slot(b, bdims, ptab, pdims):
    """:func:`_slot` of root block b (linear index on the block grid)."""
    bk = b % bdims[2]
    bj = (b // bdims[2]) % bdims[1]
    bi = b // (bdims[2] * bdims[1])
    return _slot(bi, bj, bk, ptab, pdims)


@njit(cache=True, inline="always")
def _leaf(qx, qy, qz, ptab, pdims, pool, bo, hb, bdims, child):
    """Leaf of the cache holding q (>= 0), or -1 outside the cache's blocks, or -(b + 2)
    when q's root block b is not built."""
    fi = math.floor((qx - bo[0]) / hb)
    fj = math.floor((qy - bo[1]) / hb)
    fk = math.floor((qz - bo[2]) / hb)
    if (fi < 0 or fj < 0 or fk < 0 or fi >= bdims[0] or fj >= bdims[1] or fk >= bdims[2]):
        return -1
    bi = int(fi)
    bj = int(fj)
    bk = int(fk)
    b = (bi * bdims[1] + bj) * bdims[2] + bk
    sl = _slot(bi, bj, bk, ptab, pdims)
    n = pool[sl] if sl >= 0 else -1
    if n < 0:
        return -(b + 2) if n == -1 else -1
    lx = bo[0] + bi * hb
    ly = bo[1] + bj * hb
    lz = bo[2] + bk * hb
    h = hb
    while child[n] >= 0:
        h2 = 0.5 * h
        oc = 0
        if qx >= lx + h2:
            oc += 4
            lx = lx + h2
        if qy >= ly + h2:
            oc += 2
            ly = ly + h2
        if qz >= lz + h2:
            oc += 1
            lz = lz + h2
        n = child[n] + oc
        h = h2
    return n


@njit(cache=True, inline="always")
def _scan_list(qx, qy, qz, lists, s0, m, pts):
    """First of the samples ``lists[s0:s0 + m]`` at the smallest squared distance to q."""
    best = np.inf
    besti = -1
    for u in range(s0, s0 + m):
        p = lists[u]
        dx = pts[p, 0] - qx
        dy = pts[p, 1] - qy
        dz = pts[p, 2] - qz
        d2 = dx * dx + dy * dy + dz * dz
        closer = d2 < best
        best = d2 if closer else best
        besti = p if closer else besti
    return besti


@njit(cache=True, inline="always")
def _cached_nearest(qx, qy, qz, n, pts, starts, seed, occ, ox, oy, oz, cell, nx, ny, nz,
                    lstart, llen, lists, scan_max):
    """Nearest sample of q whose cache leaf is ``n`` (:func:`_leaf`): the leaf's list
    scanned, or the grid searched when q's root block is not built or the list is longer
    than ``scan_max``."""
    if n >= 0 and llen[n] <= scan_max:
        return _scan_list(qx, qy, qz, lists, lstart[n], llen[n], pts)
    return _nearest_call(qx, qy, qz, pts, starts, seed, occ, ox, oy, oz, cell, nx, ny, nz)


#: Keypoints whose leaves are looked up together before they are scored (the lookups of a
#: block overlap in the memory system; at most this many are wasted by an early exit).
LOOKAHEAD = 8


@njit(cache=True, parallel=True, fastmath=False)
def score_cached(perm, tp, orient, offsets, prov, pnorm, weights, cos_lim, big_w, rest,
                 criterion, c, a, wsum, threshold, early_exit, surface, rho, resume,
                 pts, nrm, starts, seed, origin, cell, dims, occ,
                 ptab, pdims, pool, bo, hb, bdims, child, lstart, llen, lists, scan_max,
                 req, nreq, out_score, out_acc, out_at, out_cmp):
    """Score pairs ``perm`` (indices into tp / orient / outputs) with the neighbour cache.

    Same outputs as :func:`score`, bit for bit: each keypoint's nearest sample is its
    leaf's list scanned (:func:`_leaf`, :func:`_scan_list`), or :func:`nearest` when its
    root block is not built (or the list is longer than ``scan_max``). Pair ``perm[j]`` also
    records up to ``req.shape[1]`` distinct unbuilt root blocks: ``req[j, :nreq[j]]``.
    """
    nk = offsets.shape[1]
    ox, oy, oz = origin[0], origin[1], origin[2]
    nx, ny, nz = dims[0], dims[1], dims[2]
    eps = 1e-12
    cap = req.shape[1]
    for j in prange(perm.shape[0]):
        i = perm[j]
        o = orient[i]
        s = 0.0
        decided = False
        acc = False
        at = nk
        done = 0
        first = 0
        if resume:
            s, decided, acc, at, first = out_score[i], True, out_acc[i], out_at[i], out_at[i]
        nr = 0
        leaves = np.empty(LOOKAHEAD, np.int64)
        stop = False
        for k0 in range(first, nk, LOOKAHEAD):
            k1 = min(k0 + LOOKAHEAD, nk)
            for k in range(k0, k1):
                leaves[k - k0] = _leaf(tp[i, 0] + offsets[o, k, 0], tp[i, 1] + offsets[o, k, 1],
                                       tp[i, 2] + offsets[o, k, 2], ptab, pdims, pool, bo, hb,
                                       bdims, child)
            for k in range(k0, k1):
                qx = tp[i, 0] + offsets[o, k, 0]
                qy = tp[i, 1] + offsets[o, k, 1]
                qz = tp[i, 2] + offsets[o, k, 2]
                n = leaves[k - k0]
                p = _cached_nearest(qx, qy, qz, n, pts, starts, seed, occ, ox, oy, oz, cell, nx,
                                    ny, nz, lstart, llen, lists, scan_max)
                if n <= -2 and nr < cap:          # its root block not built: ask for it
                    rq = -n - 2
                    new = True
                    for u in range(nr):
                        if req[j, u] == rq:
                            new = False
                            break
                    if new:
                        req[j, nr] = rq
                        nr += 1
                s += _term(qx, qy, qz, p, k, o, pts, nrm, prov, pnorm, weights, cos_lim,
                           big_w, criterion, c, a, wsum, nk, surface, rho)
                done += 1
                if not decided:
                    d = _decision(s, k, rest, threshold, eps)
                    if d != 0:
                        decided, acc, at = True, d > 0, k + 1
                        if early_exit == 2 or (d < 0 and early_exit == 1):
                            stop = True
                            break
            if stop:
                break
        if not decided:
            acc = s >= threshold - eps
        nreq[j] = nr
        out_score[i] = s
        out_acc[i] = acc
        out_at[i] = at
        out_cmp[i] = done


@njit(cache=True, parallel=True)
def nearest_many_cached(q, pts, starts, seed, occ, origin, cell, dims, ptab, pdims, pool, bo,
                        hb, bdims, child, lstart, llen, lists, scan_max, out):
    """:func:`nearest_many` through the neighbour cache as it stands (nothing is built):
    a query whose root block is built scans its leaf's list, as :func:`score_cached` does;
    the others search the grid. The same answers, bit for bit."""
    for i in prange(q.shape[0]):
        qx, qy, qz = q[i, 0], q[i, 1], q[i, 2]
        n = _leaf(qx, qy, qz, ptab, pdims, pool, bo, hb, bdims, child)
        out[i] = _cached_nearest(qx, qy, qz, n, pts, starts, seed, occ, origin[0], origin[1],
                                 origin[2], cell, dims[0], dims[1], dims[2], lstart, llen, lists,
                                 scan_max)


@njit(cache=True, parallel=True)
def touched_roots(perm, tp, orient, offsets, n_keys, ptab, pdims, pool, bo, hb, bdims, out):
    """Unbuilt root blocks (no page, or -1 in the pool) under keypoints ``0..n_keys - 1``
    of pairs ``perm``: ``out[j, k]`` the block of keypoint k of pair perm[j], or -1 (built,
    requested, or outside the cache's blocks)."""
    for j in prange(perm.shape[0]):
        i = perm[j]
        o = orient[i]
        for k in range(n_keys):
            fi = math.floor((tp[i, 0] + offsets[o, k, 0] - bo[0]) / hb)
            fj = math.floor((tp[i, 1] + offsets[o, k, 1] - bo[1]) / hb)
            fk = math.floor((tp[i, 2] + offsets[o, k, 2] - bo[2]) / hb)
            out[j, k] = -1
            if (fi < 0 or fj < 0 or fk < 0 or fi >= bdims[0] or fj >= bdims[1] or
                    fk >= bdims[2]):
                continue
            bi, bj, bk = int(fi), int(fj), int(fk)
            sl = _slot(bi, bj, bk, ptab, pdims)
            if sl < 0 or pool[sl] == -1:
                out[j, k] = (bi * bdims[1] + bj) * bdims[2] + bk


@njit(cache=True)
def collect_requests(req, nreq, bdims, ptab, pdims, pool, out):
    """Root blocks still to build among the recorded requests ``req[j, :nreq[j]]``
    (entries < 0 ignored), those with a page marked as requested (-1 -> -2 in the pool, so
    listed once; blocks without a page may be listed more than once). Returns their count;
    the blocks in ``out``."""
    r = 0
    for j in range(nreq.shape[0]):
        for u in range(nreq[j]):
            if req[j, u] < 0:
                continue
            b = req[j, u]
            sl = _block_slot(b, bdims, ptab, pdims)
            if sl >= 0:
                if pool[sl] != -1:
                    continue
                pool[sl] = -2
            out[r] = b
            r += 1
    return r


@njit(cache=True)
def _build_tree(lx, ly, lz, h, cand, m, pts, tol, leaf_size, max_depth, nchild, nstart, nlen,
                ent):
    """Octree of one root block (corner l, edge ``h``, m) over its candidates ``cand[:m]``.

    Node 0 is the root; a node is split into 8 children (octant = 4 x-high + 2 y-high +
    z-high, child corner ``l + h / 2`` on the high axes) while its list is longer than
    ``leaf_size`` and it is less than ``max_depth`` levels deep; each child filters its
    parent's list (:func:`_filter`) with the parent's candidates nearest to its 8 corners.
    Writes node child / list start / list length (relative to this tree) and the leaf lists
    while they fit in ``nchild`` and ``ent``; returns the node and entry counts (larger than
    the room when it did not fit).
    """
    # depth-first: stack of pending nodes with their corner, edge, depth and candidates
    sk_node = np.empty(8 * (max_depth + 1), np.int64)
    sk_geo = np.empty((8 * (max_depth + 1), 4))
    sk_depth = np.empty(8 * (max_depth + 1), np.int64)
    sk_list = [cand[:m].copy()]
    lat = np.empty(27, np.int64)
    sep = np.empty(8, np.int64)
    sk_node[0] = 0
    sk_geo[0, 0] = lx
    sk_geo[0, 1] = ly
    sk_geo[0, 2] = lz
    sk_geo[0, 3] = h
    sk_depth[0] = 0
    top = 1
    nodes = 1
    entries = 0
    while top > 0:
        top -= 1
        nd = sk_node[top]
        x = sk_geo[top, 0]
        y = sk_geo[top, 1]
        z = sk_geo[top, 2]
        e = sk_geo[top, 3]
        dep = sk_depth[top]
        lst = sk_list.pop()
        L = lst.shape[0]
        if L <= leaf_size or dep >= max_depth:
            if nd < nchild.shape[0]:
                nchild[nd] = -1
                nstart[nd] = entries
                nlen[nd] = L
            if entries + L <= ent.shape[0]:
                for u in range(L):
                    ent[entries + u] = lst[u]
            entries += L
            continue
        first = nodes
        nodes += 8
        if nd < nchild.shape[0]:
            nchild[nd] = first
            nstart[nd] = 0
            nlen[nd] = 0
        # the 27 points of the node's 3 x 3 x 3 lattice are its children's corners
        _lattice_nearest(lst, L, x, y, z, e, 2, pts, lat)
        e2 = 0.5 * e
        for oc in range(8):
            hx = (oc >> 2) & 1
            hy = (oc >> 1) & 1
            hz = oc & 1
            t = 0
            for ia in range(2):
                for ib in range(2):
                    for ic in range(2):
                        sep[t] = lat[((hx + ia) * 3 + hy + ib) * 3 + hz + ic]
                        t += 1
            cx = x + e2 if hx else x
            cy = y + e2 if hy else y
            cz = z + e2 if hz else z
            sub = lst.copy()
            k = _filter(sub, L, cx, cy, cz, e2, pts, sep, 1, tol)
            sk_node[top] = first + oc
            sk_geo[top, 0] = cx
            sk_geo[top, 1] = cy
            sk_geo[top, 2] = cz
            sk_geo[top, 3] = e2
            sk_depth[top] = dep + 1
            sk_list.append(sub[:k])
            top += 1
    return nodes, entries


@njit(cache=True)
def _build_root(t, blocks, bo, hb, bdims, lattice, tol, slack, leaf_size, max_depth, pts, starts,
                seed, occ, cb, origin, cell, dims, noff, eoff, nchild, nstart, nlen, ent,
                counts):
    """Root block ``blocks[t]`` of :func:`build_roots`: its candidates gathered and filtered,
    its octree built (a function of its own: the parallel loop stays a plain call, which
    Numba compiles in a fraction of the time of the whole body)."""
    ox, oy, oz = origin[0], origin[1], origin[2]
    nx, ny, nz = dims[0], dims[1], dims[2]
    b = blocks[t]
    bk = b % bdims[2]
    bj = (b // bdims[2]) % bdims[1]
    bi = b // (bdims[2] * bdims[1])
    lx = bo[0] + bi * hb
    ly = bo[1] + bj * hb
    lz = bo[2] + bk * hb
    cx = lx + 0.5 * hb
    cy = ly + 0.5 * hb
    cz = lz + 0.5 * hb
    nc = _nearest_call(cx, cy, cz, pts, starts, seed, occ, ox, oy, oz, cell, nx, ny, nz)
    dx = pts[nc, 0] - cx
    dy = pts[nc, 1] - cy
    dz = pts[nc, 2] - cz
    r = math.sqrt(dx * dx + dy * dy + dz * dz) + math.sqrt(3.0) * (hb + 2e-6 * hb)
    # gather with the centre's nearest sample as the only separator, then filter with
    # the gathered samples nearest to a lattice over the block (exact: a point of the
    # block has its nearest sample among those the centre's does not dominate)
    sep = np.full(8, nc, np.int64)
    buf, m = _gather(lx, ly, lz, hb, r + slack, sep, 1, tol, pts, starts, occ, cb, ox, oy,
                     oz, cell, nx, ny, nz)
    if m > 1:
        sep = np.empty((lattice + 1) ** 3, np.int64)
        _lattice_nearest(buf, m, lx, ly, lz, hb, lattice, pts, sep)
        m = _filter(buf, m, lx, ly, lz, hb, pts, sep, lattice, tol)
    a0, a1 = noff[t], noff[t + 1]
    e0, e1 = eoff[t], eoff[t + 1]
    nn, ne = _build_tree(lx, ly, lz, hb, buf, m, pts, tol, leaf_size, max_depth,
                         nchild[a0:a1], nstart[a0:a1], nlen[a0:a1], ent[e0:e1])
    counts[t, 0] = nn
    counts[t, 1] = ne


@njit(cache=True, parallel=True)
def build_roots(blocks, bo, hb, bdims, lattice, tol, slack, leaf_size, max_depth, pts, starts,
                seed, occ, cb, origin, cell, dims, noff, eoff, nchild, nstart, nlen, ent,
                counts):
    """Octrees of root blocks ``blocks`` (linear indices on the block grid), in parallel.

    A root's candidates are the samples within d + 2 r (+ ``slack``) of its centre (d: to
    its nearest sample, r: half-diagonal of the block enlarged by 1e-6 of its edge),
    filtered on the block (separators: those nearest to a (lattice + 1)^3 lattice over it;
    :func:`_gather`, ``occ`` / ``cb``: its block occupancy); then :func:`_build_tree`.
    Tree t goes to nodes ``noff[t]:noff[t + 1]`` and entries ``eoff[t]:eoff[t + 1]``;
    ``counts[t]`` = (nodes, entries) it needs (more than its room: build it again with more).
    """
    for t in prange(blocks.shape[0]):
        _build_root(t, blocks, bo, hb, bdims, lattice, tol, slack, leaf_size, max_depth, pts,
                    starts, seed, occ, cb, origin, cell, dims, noff, eoff, nchild, nstart, nlen,
                    ent, counts)


@njit(cache=True)
def integrate(blocks, noff, eoff, nchild, nstart, nlen, ent, counts, bdims, ptab, pdims, pool,
              child, lstart, llen, lists, used):
    """Append built trees (:func:`build_roots`; trees that did not fit their room are
    skipped) to the cache: nodes from ``used[0]``, list entries from ``used[1]`` (both
    advanced). The cache arrays must have room."""
    for t in range(blocks.shape[0]):
        nn = counts[t, 0]
        ne = counts[t, 1]
        if nn > noff[t + 1] - noff[t] or ne > eoff[t + 1] - eoff[t]:
            continue
        n0 = used[0]
        e0 = used[1]
        for u in range(nn):
            c = nchild[noff[t] + u]
            child[n0 + u] = c + n0 if c >= 0 else -1
            lstart[n0 + u] = nstart[noff[t] + u] + e0
            llen[n0 + u] = nlen[noff[t] + u]
        for u in range(ne):
            lists[e0 + u] = ent[eoff[t] + u]
        used[0] += nn
        used[1] += ne
        pool[_block_slot(blocks[t], bdims, ptab, pdims)] = n0


@njit(cache=True)
def shift_trees(child, lstart, llen, lists, n_cut, n_end, e_cut, e_end):
    """Move the cache's nodes ``n_cut:n_end`` and list entries ``e_cut:e_end`` to the front
    (in place, front to back), their child and list-start indices with them."""
    for u in range(n_end - n_cut):
        c = child[n_cut + u]
        child[u] = c - n_cut if c >= 0 else -1
        lstart[u] = lstart[n_cut + u] - e_cut
        llen[u] = llen[n_cut + u]
    for u in range(e_end - e_cut):
        lists[u] = lists[e_cut + u]


@njit(cache=True)
def morton_order(q, lo, step):
    """Order of points ``q`` (P, 3) along a Z-order curve of cells of edge ``step`` (m) from
    corner ``lo``: (P,) int64, stable."""
    keys = np.empty(q.shape[0], np.int64)
    for i in range(q.shape[0]):
        key = 0
        for ax in range(3):
            v = int((q[i, ax] - lo[ax]) / step)
            v = min(max(v, 0), (1 << 21) - 1)
            for bit in range(21):
                key |= ((v >> bit) & 1) << (3 * bit + (2 - ax))
        keys[i] = key
    return np.argsort(keys, kind="mergesort")


@njit(cache=True, parallel=True)
def nearest_many(q, pts, starts, seed, occ, origin, cell, dims, out):
    for i in prange(q.shape[0]):
        out[i] = nearest(q[i, 0], q[i, 1], q[i, 2], pts, starts, seed, occ, origin[0], origin[1],
                         origin[2], cell, dims[0], dims[1], dims[2])


