"""Numba-compiled kernels (imported only when Numba is available; see kernels.py)."""

import math

import numpy as np
from numba import njit, prange


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


@njit(cache=True, fastmath=False, inline="always")
def nearest(qx, qy, qz, pts, starts, seed, ox, oy, oz, cell, nx, ny, nz):
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


@njit(cache=True, parallel=True, fastmath=False)
def score(tp, orient, offsets, prov, pnorm, weights, cos_lim, big_w, max_terms, rest,
          criterion, c, a, wsum, threshold, early_exit, surface, rho,
          pts, nrm, starts, seed, origin, cell, dims, out_score, out_acc, out_at, out_cmp):
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
        for k in range(nk):
            qx = tp[i, 0] + offsets[o, k, 0]
            qy = tp[i, 1] + offsets[o, k, 1]
            qz = tp[i, 2] + offsets[o, k, 2]
            p = nearest(qx, qy, qz, pts, starts, seed, ox, oy, oz, cell, nx, ny, nz)
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
                s += term / (2.0 * nk)
            else:
                dx = vx - px
                dy = vy - py
                dz = vz - pz
                d = math.sqrt(dx * dx + dy * dy + dz * dz) / max(pnorm[k], 1e-12)
                sg = a * (1.0 + weights[k])
                s += weights[k] * math.exp(-d * d / (2.0 * sg * sg)) / wsum
            done += 1
            if not decided:
                if s >= threshold - eps:
                    decided = True
                    acc = True
                    at = k + 1
                elif s + rest[k + 1] < threshold - eps:
                    decided = True
                    at = k + 1
                    if early_exit:
                        break
        if not decided:
            acc = s >= threshold - eps
        out_score[i] = s
        out_acc[i] = acc
        out_at[i] = at
        out_cmp[i] = done

@njit(cache=True, parallel=True)
def nearest_many(q, pts, starts, seed, origin, cell, dims, out):
    for i in prange(q.shape[0]):
        out[i] = nearest(q[i, 0], q[i, 1], q[i, 2], pts, starts, seed, origin[0], origin[1],
                         origin[2], cell, dims[0], dims[1], dims[2])

