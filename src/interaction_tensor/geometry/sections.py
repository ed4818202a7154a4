"""Exact plane sections of a triangle mesh: where a plane cuts the scene's surfaces, as
points along the cut, with no sampling gaps (hanging's fit test on mesh scenes)."""

from __future__ import annotations

import numpy as np


class MeshSections:
    """A triangle mesh (the scene's, built once) cut by planes on demand.

    Parameters
    ----------
    vertices : (V, 3) float, metres
    faces : (F, 3) int
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        self.vertices = np.asarray(vertices, np.float64)
        self.faces = np.asarray(faces, np.int64)
        tri = self.vertices[self.faces]
        self.lo = tri.min(axis=1)
        self.hi = tri.max(axis=1)

    def segments(self, centre, normal, reach: float) -> np.ndarray:
        """(K, 2, 3) the segments where the plane through ``centre`` (3,) normal to
        ``normal`` (3,) cuts the faces whose bounding box comes within ``reach`` (m) of
        ``centre`` (a face lying in the plane cuts nothing)."""
        c = np.asarray(centre, float)
        n = np.asarray(normal, float) / np.linalg.norm(normal)
        near = np.flatnonzero(((self.lo <= c + reach) & (self.hi >= c - reach)).all(axis=1))
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
