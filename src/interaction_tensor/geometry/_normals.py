"""The Numba kernels of point-cloud normals (imported only when Numba is available; see
:func:`~interaction_tensor.geometry.sampling.estimate_normals`): each point's neighbourhood
scatter matrix, summed in one pass over its neighbours instead of (n, k, 3) temporaries."""

import math

from numba import njit, prange


@njit(cache=True, parallel=True)
def scatter(points, idx, out):
    """``out[i]`` (3, 3): the scatter matrix of the points ``idx[i]`` about their mean."""
    k = idx.shape[1]
    for i in prange(idx.shape[0]):
        mx = my = mz = 0.0
        for j in range(k):
            p = idx[i, j]
            mx += points[p, 0]
            my += points[p, 1]
            mz += points[p, 2]
        mx /= k
        my /= k
        mz /= k
        _accumulate(points, idx, i, mx, my, mz, None, 0.0, out)


@njit(cache=True, parallel=True)
def refit_scatter(points, queries, idx, first, slab, out, count):
    """The scatter matrices of the neighbours within ``slab`` (m) of each query's first plane
    (through the query, normal ``first[i]``), about their own mean, and how many they are."""
    k = idx.shape[1]
    for i in prange(idx.shape[0]):
        qx, qy, qz = queries[i, 0], queries[i, 1], queries[i, 2]
        nx, ny, nz = first[i, 0], first[i, 1], first[i, 2]
        n = 0
        mx = my = mz = 0.0
        for j in range(k):
            p = idx[i, j]
            if abs((points[p, 0] - qx) * nx + (points[p, 1] - qy) * ny
                   + (points[p, 2] - qz) * nz) <= slab:
                n += 1
                mx += points[p, 0]
                my += points[p, 1]
                mz += points[p, 2]
        count[i] = n
        if n == 0:
            for a in range(3):
                for b in range(3):
                    out[i, a, b] = 0.0
            continue
        mx /= n
        my /= n
        mz /= n
        _accumulate(points, idx, i, mx, my, mz, first, slab, out, queries)


@njit(cache=True)
def _accumulate(points, idx, i, mx, my, mz, first, slab, out, queries=None):
    """Sum the scatter about (mx, my, mz) of point ``i``'s neighbours (with ``first``, only
    those within ``slab`` of the plane through ``queries[i]`` normal to ``first[i]``)."""
    sxx = sxy = sxz = syy = syz = szz = 0.0
    for j in range(idx.shape[1]):
        p = idx[i, j]
        if first is not None:
            if abs((points[p, 0] - queries[i, 0]) * first[i, 0]
                   + (points[p, 1] - queries[i, 1]) * first[i, 1]
                   + (points[p, 2] - queries[i, 2]) * first[i, 2]) > slab:
                continue
        dx = points[p, 0] - mx
        dy = points[p, 1] - my
        dz = points[p, 2] - mz
        sxx += dx * dx
        sxy += dx * dy
        sxz += dx * dz
        syy += dy * dy
        syz += dy * dz
        szz += dz * dz
    out[i, 0, 0] = sxx
    out[i, 0, 1] = sxy
    out[i, 0, 2] = sxz
    out[i, 1, 0] = sxy
    out[i, 1, 1] = syy
    out[i, 1, 2] = syz
    out[i, 2, 0] = sxz
    out[i, 2, 1] = syz
    out[i, 2, 2] = szz


@njit(cache=True)
def _insert(dist, idx, q, found, k, d2, p):
    """Put (d2, p) into query ``q``'s sorted best ``k`` (``found`` held so far); after any
    equal distance already held (the order of a stable sort)."""
    m = found if found < k else k - 1
    if found >= k and d2 >= dist[q, k - 1]:
        return found
    while m > 0 and dist[q, m - 1] > d2:
        dist[q, m] = dist[q, m - 1]
        idx[q, m] = idx[q, m - 1]
        m -= 1
    dist[q, m] = d2
    idx[q, m] = p
    return found + 1 if found < k else k


@njit(cache=True)
def _scan(points, starts, c, qx, qy, qz, dist, idx, q, found, k):
    """Offer cell ``c``'s points to query ``q``'s best ``k``."""
    for p in range(starts[c], starts[c + 1]):
        dx = points[p, 0] - qx
        dy = points[p, 1] - qy
        dz = points[p, 2] - qz
        found = _insert(dist, idx, q, found, k, dx * dx + dy * dy + dz * dz, p)
    return found


@njit(cache=True, parallel=True)
def knn(points, starts, origin, cell, nx, ny, nz, queries, k, max_shell, dist, idx):
    """The ``k`` nearest of ``points`` (sorted by cell: cell c's are
    ``starts[c]:starts[c + 1]`` of the ``nx`` x ``ny`` x ``nz`` grid of edge ``cell`` from
    ``origin``) to each of ``queries``, nearest first: squared distances into ``dist`` and
    indices into ``idx`` (Q, k). Shells of cells around the query's are searched until the
    k-th nearest lies nearer than any cell not yet searched; a query not settled within
    ``max_shell`` shells (far from every point) gets ``idx[q, 0] = -1``."""
    for q in prange(queries.shape[0]):
        qx, qy, qz = queries[q, 0], queries[q, 1], queries[q, 2]
        ci = min(max(int((qx - origin[0]) / cell), 0), nx - 1)
        cj = min(max(int((qy - origin[1]) / cell), 0), ny - 1)
        ck = min(max(int((qz - origin[2]) / cell), 0), nz - 1)
        found = 0
        r = 0
        while True:
            for i in range(max(ci - r, 0), min(ci + r, nx - 1) + 1):
                edge_i = i == ci - r or i == ci + r
                for j in range(max(cj - r, 0), min(cj + r, ny - 1) + 1):
                    base = (i * ny + j) * nz
                    if edge_i or j == cj - r or j == cj + r:        # a face of the shell
                        for kk in range(max(ck - r, 0), min(ck + r, nz - 1) + 1):
                            found = _scan(points, starts, base + kk, qx, qy, qz, dist, idx,
                                          q, found, k)
                    else:                                           # its top and bottom
                        if ck - r >= 0:
                            found = _scan(points, starts, base + ck - r, qx, qy, qz, dist,
                                          idx, q, found, k)
                        if ck + r <= nz - 1:
                            found = _scan(points, starts, base + ck + r, qx, qy, qz, dist,
                                          idx, q, found, k)
            if ci - r <= 0 and cj - r <= 0 and ck - r <= 0 and ci + r >= nx - 1 \
                    and cj + r >= ny - 1 and ck + r >= nz - 1:
                break                                           # every cell searched
            if found == k:
                margin = min(qx - (origin[0] + (ci - r) * cell),
                             origin[0] + (ci + r + 1) * cell - qx,
                             qy - (origin[1] + (cj - r) * cell),
                             origin[1] + (cj + r + 1) * cell - qy,
                             qz - (origin[2] + (ck - r) * cell),
                             origin[2] + (ck + r + 1) * cell - qz)
                if margin > 0 and dist[q, k - 1] <= margin * margin:
                    break
            if r >= max_shell:
                idx[q, 0] = -1
                break
            r += 1


@njit(cache=True)
def _cross_vector(a00, a01, a02, a11, a12, a22, least):
    """The longest cross product of two rows of A - least I (A symmetric, by its upper
    triangle) and its squared length: along A's eigenvector of ``least``."""
    r0x, r0y, r0z = a00 - least, a01, a02
    r1x, r1y, r1z = a01, a11 - least, a12
    r2x, r2y, r2z = a02, a12, a22 - least
    c0x, c0y, c0z = r0y * r1z - r0z * r1y, r0z * r1x - r0x * r1z, r0x * r1y - r0y * r1x
    c1x, c1y, c1z = r0y * r2z - r0z * r2y, r0z * r2x - r0x * r2z, r0x * r2y - r0y * r2x
    c2x, c2y, c2z = r1y * r2z - r1z * r2y, r1z * r2x - r1x * r2z, r1x * r2y - r1y * r2x
    n0 = c0x * c0x + c0y * c0y + c0z * c0z
    n1 = c1x * c1x + c1y * c1y + c1z * c1z
    n2 = c2x * c2x + c2y * c2y + c2z * c2z
    if n0 >= n1 and n0 >= n2:
        return c0x, c0y, c0z, n0
    if n1 >= n2:
        return c1x, c1y, c1z, n1
    return c2x, c2y, c2z, n2


@njit(cache=True, parallel=True)
def least_eigenvectors(cov, gap, out, unsure):
    """``out[i]``: the unit eigenvector of the least eigenvalue of the symmetric ``cov[i]``
    (3, 3), in closed form: the eigenvalues by the trigonometric solution of the
    characteristic cubic, the vector as the longest cross product of two rows of
    ``cov[i] - least * I``. Where the two least eigenvalues lie within ``gap`` of the
    largest of each other (a line's neighbourhood: the vector is barely defined) or the
    matrix is a multiple of the identity, ``unsure[i]`` is set and the caller asks an
    iterative solver."""
    for i in prange(cov.shape[0]):
        a00, a01, a02 = cov[i, 0, 0], cov[i, 0, 1], cov[i, 0, 2]
        a11, a12, a22 = cov[i, 1, 1], cov[i, 1, 2], cov[i, 2, 2]
        scale = max(abs(a00), abs(a01), abs(a02), abs(a11), abs(a12), abs(a22))
        unsure[i] = True
        out[i, 0] = 0.0
        out[i, 1] = 0.0
        out[i, 2] = 1.0
        if scale <= 0.0:
            continue
        a00 /= scale
        a01 /= scale
        a02 /= scale
        a11 /= scale
        a12 /= scale
        a22 /= scale
        q = (a00 + a11 + a22) / 3.0
        b00, b11, b22 = a00 - q, a11 - q, a22 - q
        p2 = (b00 * b00 + b11 * b11 + b22 * b22
              + 2.0 * (a01 * a01 + a02 * a02 + a12 * a12)) / 6.0
        if p2 <= 1e-30:
            continue
        p = math.sqrt(p2)
        det = (b00 * (b11 * b22 - a12 * a12) - a01 * (a01 * b22 - a12 * a02)
               + a02 * (a01 * a12 - b11 * a02))
        r = min(max(det / (2.0 * p2 * p), -1.0), 1.0)
        phi = math.acos(r) / 3.0
        big = q + 2.0 * p * math.cos(phi)
        least = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
        middle = 3.0 * q - big - least
        if middle - least <= gap * max(abs(big), 1e-300):
            continue
        # the vector from the rows of A - least I, then again with the least eigenvalue
        # as the vector's Rayleigh quotient: the cubic's root is good to sqrt(eps) where
        # the two largest eigenvalues meet (a plane's neighbourhood), the quotient to eps
        vx, vy, vz, n = _cross_vector(a00, a01, a02, a11, a12, a22, least)
        if n <= 1e-300:
            continue
        n = math.sqrt(n)
        vx, vy, vz = vx / n, vy / n, vz / n
        least = (vx * (a00 * vx + a01 * vy + a02 * vz) + vy * (a01 * vx + a11 * vy + a12 * vz)
                 + vz * (a02 * vx + a12 * vy + a22 * vz))
        vx, vy, vz, n = _cross_vector(a00, a01, a02, a11, a12, a22, least)
        if n <= 1e-300:
            continue
        n = math.sqrt(n)
        out[i, 0] = vx / n
        out[i, 1] = vy / n
        out[i, 2] = vz / n
        unsure[i] = False


@njit(cache=True, parallel=True)
def choose_planes(points, queries, idx, planes, candidates, slab, choice):
    """``choice[i]``: of the plane normals ``planes[idx[i, j]]`` (j < ``candidates``; rows
    of NaN skipped), the one whose plane through ``queries[i]`` the neighbours ``idx[i]``
    lie nearest: each within ``slab`` counts 1 - (h / slab)^2 at distance h, summed in
    neighbour order; ties to the nearer neighbour's (the reference: ``_choose_numpy``)."""
    w = idx.shape[1]
    s2 = slab * slab
    inv = 1.0 / s2 if slab > 0 else 0.0
    for i in prange(idx.shape[0]):
        qx, qy, qz = queries[i, 0], queries[i, 1], queries[i, 2]
        best = -1.0
        bx = by = bz = 0.0
        for j in range(candidates):
            c = idx[i, j]
            cx, cy, cz = planes[c, 0], planes[c, 1], planes[c, 2]
            if cx != cx:
                continue
            score = 0.0
            for m in range(w):
                p = idx[i, m]
                h = (points[p, 0] - qx) * cx + (points[p, 1] - qy) * cy \
                    + (points[p, 2] - qz) * cz
                h2 = h * h
                score = score + (1.0 - h2 * inv if h2 < s2 else 0.0)
            if score > best:
                best = score
                bx, by, bz = cx, cy, cz
        choice[i, 0] = bx
        choice[i, 1] = by
        choice[i, 2] = bz


@njit(cache=True, parallel=True)
def plane_spread(points, queries, idx, plane, out):
    """``out[i]``: the farthest of the neighbours ``idx[i]`` from the plane through
    ``queries[i]`` normal to ``plane[i]`` (m)."""
    for i in prange(idx.shape[0]):
        far = 0.0
        for j in range(idx.shape[1]):
            p = idx[i, j]
            h = abs((points[p, 0] - queries[i, 0]) * plane[i, 0]
                    + (points[p, 1] - queries[i, 1]) * plane[i, 1]
                    + (points[p, 2] - queries[i, 2]) * plane[i, 2])
            if h > far:
                far = h
        out[i] = far


@njit(cache=True, parallel=True)
def planes_agree(planes, near, rows, normals, out):
    """``out[i]``: the least |cosine| between ``normals[i]`` and the ``planes`` of the
    points ``near[rows[i]]``."""
    for i in prange(rows.shape[0]):
        least = 1.0
        r = rows[i]
        for j in range(near.shape[1]):
            p = near[r, j]
            c = abs(planes[p, 0] * normals[i, 0] + planes[p, 1] * normals[i, 1]
                    + planes[p, 2] * normals[i, 2])
            if c < least:
                least = c
        out[i] = least
