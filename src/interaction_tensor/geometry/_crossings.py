"""The Numba kernels of :class:`~interaction_tensor.geometry.collision.Crossings`: which
moves of a posed body leave one of the triangle pairs known to cross still crossing (the
same rule as :func:`~interaction_tensor.geometry.collision._edges_cross`), and the pairs'
ring of slots, written as fcl finds them."""

import numpy as np
from numba import njit, types
from numba.typed import Dict


@njit(cache=True)
def _through(moving, sx, sy, sz, fixed, n, inward, margin):
    """Whether an edge of triangle ``moving`` (3, 3) moved by (sx, sy, sz) passes through
    triangle ``fixed`` (3, 3) of unit normal ``n`` (zero: no area) and inward edge normals
    ``inward`` (3, 3), its ends and its crossing point each ``margin`` (m) clear of the
    triangle's plane and edges."""
    if n[0] == 0.0 and n[1] == 0.0 and n[2] == 0.0:
        return False
    ox, oy, oz = fixed[0, 0], fixed[0, 1], fixed[0, 2]
    for v in range(3):
        w = (v + 1) % 3
        ax, ay, az = moving[v, 0] + sx, moving[v, 1] + sy, moving[v, 2] + sz
        bx, by, bz = moving[w, 0] + sx, moving[w, 1] + sy, moving[w, 2] + sz
        da = (ax - ox) * n[0] + (ay - oy) * n[1] + (az - oz) * n[2]
        db = (bx - ox) * n[0] + (by - oy) * n[1] + (bz - oz) * n[2]
        if not ((da > margin and db < -margin) or (da < -margin and db > margin)):
            continue
        t = da / (da - db)
        px, py, pz = ax + t * (bx - ax), ay + t * (by - ay), az + t * (bz - az)
        inside = True
        for j in range(3):
            if ((px - fixed[j, 0]) * inward[j, 0] + (py - fixed[j, 1]) * inward[j, 1]
                    + (pz - fixed[j, 2]) * inward[j, 2]) <= margin:
                inside = False
                break
        if inside:
            return True
    return False


@njit(cache=True)
def moves_kept(body, scene, scene_n, scene_in, body_n, body_in, box, head, count, moves,
               margin, out):
    """``out[m]``: whether, with ``body`` (P, 3, 3) moved by ``moves[m]``, some pair
    ``body[p]``, ``scene[p]`` still crosses (an edge of either through the other; each
    triangle's unit normal and inward edge normals given, the body's at its pose). The
    ``count`` pairs are a ring of slots, tried the latest written first (slot ``head`` - 1,
    backwards), and a move stops at the first that crosses; a pair whose triangles'
    bounding boxes the move does not make meet (``box``: the moves that do, low and high)
    cannot cross, and is passed over."""
    cap = body.shape[0]
    for m in range(moves.shape[0]):
        out[m] = False
        mx, my, mz = moves[m, 0], moves[m, 1], moves[m, 2]
        for q in range(count):
            p = (head - 1 - q) % cap
            if (mx < box[p, 0, 0] or mx > box[p, 1, 0] or my < box[p, 0, 1]
                    or my > box[p, 1, 1] or mz < box[p, 0, 2] or mz > box[p, 1, 2]):
                continue
            if _through(body[p], mx, my, mz, scene[p], scene_n[p], scene_in[p], margin):
                out[m] = True
                break
            # the scene's triangle moved back against the body's: the same relative move
            if _through(scene[p], -mx, -my, -mz, body[p], body_n[p], body_in[p], margin):
                out[m] = True
                break


@njit(cache=True)
def frames(tri, n, inward):
    """Of triangles ``tri`` (P, 3, 3): their unit normals into ``n`` (P, 3), zero where
    they have no area, and their edges' unit normals in their plane, pointing in, into
    ``inward`` (P, 3 edges from each vertex, 3)."""
    for p in range(tri.shape[0]):
        e0 = tri[p, 1] - tri[p, 0]
        e1 = tri[p, 2] - tri[p, 1]
        nx = e0[1] * e1[2] - e0[2] * e1[1]
        ny = e0[2] * e1[0] - e0[0] * e1[2]
        nz = e0[0] * e1[1] - e0[1] * e1[0]
        size = (nx * nx + ny * ny + nz * nz) ** 0.5
        if size <= 1e-18:
            nx = ny = nz = 0.0
        else:
            nx, ny, nz = nx / size, ny / size, nz / size
        n[p, 0], n[p, 1], n[p, 2] = nx, ny, nz
        for j in range(3):
            ex = tri[p, (j + 1) % 3, 0] - tri[p, j, 0]
            ey = tri[p, (j + 1) % 3, 1] - tri[p, j, 1]
            ez = tri[p, (j + 1) % 3, 2] - tri[p, j, 2]
            wx, wy, wz = ny * ez - nz * ey, nz * ex - nx * ez, nx * ey - ny * ex
            length = (wx * wx + wy * wy + wz * wz) ** 0.5
            if length > 0.0:
                wx, wy, wz = wx / length, wy / length, wz / length
            inward[p, j, 0], inward[p, j, 1], inward[p, j, 2] = wx, wy, wz


@njit(cache=True)
def expand_pairs(pairs, body_ptr, body_near, scene_ptr, scene_near, scene_faces, cap):
    """Of crossing pairs (n, 2) (a body triangle, a scene triangle): each, then its body
    triangle's neighbours (CSR ``body_ptr``, ``body_near``) against the same scene triangle,
    then the body triangle against the scene triangle's neighbours (``scene_ptr``,
    ``scene_near``), leaving out repeats; at most ``cap``. Returns the (m, 2) pairs and
    their (m,) keys (body * ``scene_faces`` + scene)."""
    seen = set()
    out = np.empty((cap, 2), np.int64)
    keys = np.empty(cap, np.int64)
    m = 0
    for i in range(pairs.shape[0]):
        b, s = pairs[i, 0], pairs[i, 1]
        nb = body_ptr[b + 1] - body_ptr[b]
        ns = scene_ptr[s + 1] - scene_ptr[s]
        for j in range(-1, nb + ns):
            if m == cap:
                return out[:m], keys[:m]
            t, u = b, s
            if 0 <= j < nb:
                t = body_near[body_ptr[b] + j]
            elif j >= nb:
                u = scene_near[scene_ptr[s] + j - nb]
            key = t * scene_faces + u
            if key in seen:
                continue
            seen.add(key)
            out[m, 0], out[m, 1], keys[m] = t, u, key
            m += 1
    return out[:m], keys[:m]


@njit(cache=True)
def new_index():
    """An empty key -> slot table of a :class:`~.collision.Crossings`' pairs."""
    return Dict.empty(key_type=types.int64, value_type=types.int64)


@njit(cache=True)
def rebuild_index(keys, count, index):
    """Fill ``index`` with the slots of the first ``count`` ``keys``."""
    index.clear()
    for i in range(count):
        index[keys[i]] = i


@njit(cache=True)
def insert_pairs(new, new_keys, body_v, body_f, rot, shift, scene_v, scene_f, pairs, keys,
                 b, s, sn, si, bn, bi, box, state, index):
    """Write the pairs ``new`` (n, 2) of ``new_keys`` that are not in ``index`` (key ->
    slot) into the ring of slots (``state``: the next slot to write, the slots filled),
    over the oldest once every slot is filled, the first of ``new`` written last: their
    triangles (the body's posed by ``rot``, ``shift``; the scene's as they are),
    :func:`frames` (the scene's, then the body's) and ``box``, the moves of the body that
    make the two triangles' bounding boxes meet (low, high)."""
    cap = keys.shape[0]
    for i in range(new.shape[0] - 1, -1, -1):        # the first (the pair found) last
        key = new_keys[i]
        if key in index:
            continue
        slot = state[0]
        if state[1] == cap:
            del index[keys[slot]]
        else:
            state[1] += 1
        state[0] = (slot + 1) % cap
        index[key] = slot
        pairs[slot, 0], pairs[slot, 1], keys[slot] = new[i, 0], new[i, 1], key
        for v in range(3):
            p = body_v[body_f[new[i, 0], v]]
            for a in range(3):
                b[slot, v, a] = (rot[a, 0] * p[0] + rot[a, 1] * p[1] + rot[a, 2] * p[2]
                                 + shift[a])
                s[slot, v, a] = scene_v[scene_f[new[i, 1], v], a]
        frames(s[slot:slot + 1], sn[slot:slot + 1], si[slot:slot + 1])
        frames(b[slot:slot + 1], bn[slot:slot + 1], bi[slot:slot + 1])
        for a in range(3):
            box[slot, 0, a] = (min(s[slot, 0, a], s[slot, 1, a], s[slot, 2, a])
                               - max(b[slot, 0, a], b[slot, 1, a], b[slot, 2, a]))
            box[slot, 1, a] = (max(s[slot, 0, a], s[slot, 1, a], s[slot, 2, a])
                               - min(b[slot, 0, a], b[slot, 1, a], b[slot, 2, a]))
