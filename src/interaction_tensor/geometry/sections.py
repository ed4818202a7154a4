"""Exact plane sections of a triangle mesh: where a plane cuts the scene's surfaces, as
points along the cut, with no sampling gaps (hanging's fit test on mesh scenes)."""

from __future__ import annotations

import numpy as np

#: The edge (m) of the cubes faces are indexed by (hanging's fit test follows a cut 30 cm
#: out from a hook: a few cubes a query)...
CELL = 0.15
#: ... the most cubes a face is listed in (larger ones are tested on every query)...
MAX_CELLS = 64
#: ... and the most cubes a query visits (a larger one tests every face's box).
MAX_QUERY_CELLS = 512


class MeshSections:
    """A triangle mesh (the scene's, built once) cut by planes on demand; its faces indexed
    by the cubes their bounding boxes meet, so that a cut visits the faces near it only.

    Parameters
    ----------
    vertices : (V, 3) float, metres
    faces : (F, 3) int
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, cell: float = CELL):
        self.vertices = np.asarray(vertices, np.float64)
        self.faces = np.asarray(faces, np.int64)
        tri = self.vertices[self.faces]
        self.lo = tri.min(axis=1)
        self.hi = tri.max(axis=1)
        self._index(cell)
        self._stamp, self._mark = None, 0          # triangles_near's faces seen, per call

    def _index(self, cell: float) -> None:
        """The faces by the cubes of edge ``cell`` (m) their bounding boxes meet, as sorted
        cube keys and a face list (CSR); a face whose box meets more than
        :data:`MAX_CELLS` cubes (a floor's large triangle) is in :attr:`large` instead."""
        self.cell = float(cell)
        if not len(self.faces):
            self.origin = np.zeros(3)
            self.dims = np.ones(3, np.int64)
            self.keys, self.starts = np.zeros(0, np.int64), np.zeros(1, np.int64)
            self.members, self.large = np.zeros(0, np.int64), np.zeros(0, np.int64)
            return
        self.origin = self.lo.min(axis=0)
        a = np.floor((self.lo - self.origin) / cell).astype(np.int64)
        b = np.floor((self.hi - self.origin) / cell).astype(np.int64)
        self.dims = b.max(axis=0) + 1
        span = b - a + 1
        count = span.prod(axis=1)
        small = np.flatnonzero(count <= MAX_CELLS)
        self.large = np.flatnonzero(count > MAX_CELLS)
        # every (face, cube) of the small faces: the face's corner cube plus its offsets
        n = count[small]
        face = np.repeat(small, n)
        k = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
        sy, sz = span[face, 1], span[face, 2]
        ijk = a[face] + np.column_stack([k // (sy * sz), (k // sz) % sy, k % sz])
        key = (ijk[:, 0] * self.dims[1] + ijk[:, 1]) * self.dims[2] + ijk[:, 2]
        order = np.lexsort((face, key))
        key, self.members = key[order], face[order]
        first = np.r_[True, key[1:] != key[:-1]]
        self.keys = key[first]
        self.starts = np.r_[np.flatnonzero(first), len(key)]

    def near_faces(self, centre, reach: float) -> np.ndarray:
        """The faces (ascending) whose bounding box comes within ``reach`` (m) of ``centre``
        along each axis, every face's box tested: the reference of :meth:`triangles_near`."""
        c = np.asarray(centre, float)
        return np.flatnonzero(((self.lo <= c + reach) & (self.hi >= c - reach)).all(axis=1))

    def triangles_near(self, centre, reach: float) -> np.ndarray:
        """(M, 3, 3) the triangles of :meth:`near_faces` (in another order), gathered from
        the cubes the query's box meets by a Numba kernel (:func:`._sections.near_triangles`)."""
        from interaction_tensor.geometry import _sections

        if self._stamp is None:
            self._stamp = np.zeros(len(self.faces), np.int64)
        self._mark += 1
        return _sections.near_triangles(
            np.asarray(centre, np.float64), float(reach), self.vertices, self.faces, self.lo,
            self.hi, self.keys, self.starts, self.members, self.large, self.origin,
            self.cell, self.dims, MAX_QUERY_CELLS, self._stamp, self._mark)

    def segments(self, centre, normal, reach: float) -> np.ndarray:
        """(K, 2, 3) the segments where the plane through ``centre`` (3,) normal to
        ``normal`` (3,) cuts the faces whose bounding box comes within ``reach`` (m) of
        ``centre`` (a face lying in the plane cuts nothing)."""
        c = np.asarray(centre, float)
        n = np.asarray(normal, float) / np.linalg.norm(normal)
        near = self.near_faces(c, reach)
        if not len(near):
            return np.zeros((0, 2, 3))
        tri = self.vertices[self.faces[near]]                     # (M, 3, 3)
        s = (tri - c) @ n                                          # (M, 3) signed heights
        cut = (s.min(axis=1) < 0) & (s.max(axis=1) > 0)
        tri, s = tri[cut], s[cut]
        if not len(tri):
            return np.zeros((0, 2, 3))
        # the edges whose ends lie on either side (or one end on the plane, the other above)
        a, b = tri, np.roll(tri, -1, axis=1)
        sa, sb = s, np.roll(s, -1, axis=1)
        crosses = ((sa < 0) & (sb >= 0)) | ((sa >= 0) & (sb < 0))        # exactly 2 a face
        w = np.divide(sa, sa - sb, out=np.zeros_like(sa), where=crosses)
        p = a + w[..., None] * (b - a)                              # (M, 3, 3)
        order = np.argsort(~crosses, axis=1, kind="stable")[:, :2]  # the two crossing edges
        return np.take_along_axis(p, order[..., None], axis=1)

    def points(self, centre, normal, reach: float, step: float) -> np.ndarray:
        """(P, 3) points every ``step`` (m) or closer along the cut of the plane through
        ``centre`` normal to ``normal`` (:meth:`segments`; both ends of each segment),
        within ``reach`` of ``centre``."""
        seg = self.segments(centre, normal, reach)
        if not len(seg):
            return np.zeros((0, 3))
        length = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1)
        count = np.ceil(length / step).astype(np.int64) + 1
        owner = np.repeat(np.arange(len(seg)), count)
        first = np.repeat(np.cumsum(count) - count, count)
        f = (np.arange(len(owner)) - first) / np.maximum(count[owner] - 1, 1)
        pts = seg[owner, 0] + f[:, None] * (seg[owner, 1] - seg[owner, 0])
        return pts[np.linalg.norm(pts - np.asarray(centre, float), axis=1) <= reach]
