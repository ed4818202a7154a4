"""Numba kernel of :class:`~interaction_tensor.geometry.sections.MeshSections`: the
triangles near a point, from the faces indexed by the cubes their boxes meet."""

import math

import numpy as np
from numba import njit


@njit(cache=True)
def near_triangles(c, reach, vertices, faces, lo, hi, keys, starts, members, large, origin,
                   cell, dims, max_cells, stamp, mark):
    """(M, 3, 3) the triangles whose bounding box (``lo``, ``hi``) comes within ``reach``
    of ``c`` along each axis (:meth:`.sections.MeshSections.near_faces`, in another order):
    those listed in the cubes the query's box meets (sorted cube ``keys``, ``starts``,
    ``members``) and the ``large`` ones, each once (``stamp[f] == mark`` once seen), or
    every face's box where the query meets more than ``max_cells`` cubes."""
    a = np.empty(3, np.int64)
    b = np.empty(3, np.int64)
    for j in range(3):
        a[j] = max(int(math.floor((c[j] - reach - origin[j]) / cell)), 0)
        b[j] = min(int(math.floor((c[j] + reach - origin[j]) / cell)), dims[j] - 1)
    cand = np.empty(len(large) + 64, np.int64)
    n = 0
    for f in large:
        if n == len(cand):
            cand = np.concatenate((cand, np.empty(len(cand), np.int64)))
        cand[n] = f
        n += 1
    every = (b[0] - a[0] + 1) * (b[1] - a[1] + 1) * (b[2] - a[2] + 1) > max_cells
    if every:
        cand = np.arange(faces.shape[0])
        n = faces.shape[0]
    elif a[0] <= b[0] and a[1] <= b[1] and a[2] <= b[2] and len(keys):
        for i in range(a[0], b[0] + 1):
            for j in range(a[1], b[1] + 1):
                for k in range(a[2], b[2] + 1):
                    key = (i * dims[1] + j) * dims[2] + k
                    s = np.searchsorted(keys, key)
                    if s == len(keys) or keys[s] != key:
                        continue
                    for m in range(starts[s], starts[s + 1]):
                        f = members[m]
                        if stamp[f] == mark:
                            continue
                        stamp[f] = mark
                        if n == len(cand):
                            cand = np.concatenate((cand, np.empty(len(cand), np.int64)))
                        cand[n] = f
                        n += 1
    out = np.empty((n, 3, 3))
    kept = 0
    for q in range(n):
        f = cand[q]
        ok = True
        for j in range(3):
            if lo[f, j] > c[j] + reach or hi[f, j] < c[j] - reach:
                ok = False
        if ok:
            for v in range(3):
                for j in range(3):
                    out[kept, v, j] = vertices[faces[f, v], j]
            kept += 1
    return out[:kept]
