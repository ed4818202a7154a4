"""Exact triangle-mesh collision on python-fcl (the Flexible Collision Library): detection's
collision test of the ranked placements (:mod:`.detect`) and the judge's penetration test
(the paper's judge, ``itensor_paper.judge``).

The scene is one BVH of its triangles, built once; a query object is one or more BVHs of its
own triangles (its parts), moved by a 4x4 pose. Triangles are tested exactly, so a 3 mm wire
hook crossing a table top collides however thin it is; a triangle soup of overlapping closed
pieces is fine (only triangle-triangle intersections count).

Penetration depth is measured as fcl cannot for two meshes: as the smallest translation that
separates them, searched over a fixed set of 26 directions (the faces, edges and corners of a
cube) and a ladder of lengths. An object resting on a surface that it crosses by a few
millimetres (sampled test points, slanted seats) is freed by a short move; an object through a
table top, a wall or a sofa is not. An object that is not freed has to be tried at every
move; the triangle pairs found crossing at its pose and at the moves tried so far, with their
neighbours, answer most of them (a move that leaves one of them crossing by a margin is
blocked: :class:`Crossings`), so that fcl is asked only about the others (a person through a
backrest: about a quarter of the moves). Detection's tests keep those pairs from pose to pose
of one orientation (:class:`CrossingMemory`): the next test point along the same backrest is
then answered by them at nearly every move.
"""

from __future__ import annotations

import functools

import numpy as np

FCL_HINT = "pip install python-fcl (a dependency of interaction-tensor)"


def _fcl():
    try:
        import fcl
    except ImportError as exc:       # pragma: no cover - the test extra installs it
        raise ImportError(f"exact collision tests need python-fcl: {FCL_HINT}") from exc
    return fcl


def _bvh(vertices: np.ndarray, faces: np.ndarray):
    if len(faces) == 0:                 # fcl crashes (segmentation fault) on an empty model
        raise ValueError("a collision model needs at least one triangle")
    fcl = _fcl()
    m = fcl.BVHModel()
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int32)
    m.beginModel(len(v), len(f))
    m.addSubModel(v, f)
    m.endModel()
    return m


def _directions() -> np.ndarray:
    d = np.array([(i, j, k) for k in (1, 0, -1) for i in (0, 1, -1) for j in (0, 1, -1)
                  if (i, j, k) != (0, 0, 0)], float)
    return d / np.linalg.norm(d, axis=1, keepdims=True)


_DIRECTIONS = _directions()


def directions() -> np.ndarray:
    """(26, 3) unit directions: the faces, edges and corners of a cube, +Z first."""
    return _DIRECTIONS.copy()


#: The most triangle pairs a :class:`Crossings` keeps (the oldest written over first): a
#: seated person's tests along a sofa find a few thousand, and fewer send most moves to fcl
#: again (living-room4: 256 kept, 88,692 fcl calls; 1,024, 54,737; 4,096, 16,582).
CROSSING_KEPT = 4096
#: The most :class:`Crossings` a :class:`CrossingMemory` holds (the oldest dropped first):
#: one per body and orientation, up to about 1.7 MB each.
MEMORY_KEPT = 64
#: How many steps from a crossing body triangle, vertex to shared vertex, its neighbours
#: join it in a :class:`Crossings`.
CROSSING_RING = 2
#: and the mesh's triangles that many steps from its crossing triangle
CROSSING_SCENE_RING = 1
#: How far (m) an edge must pass through a triangle's plane, and inside its edges, for
#: :meth:`Crossings.kept` to take the two as crossing without fcl (far above rounding).
CROSSING_MARGIN = 1e-6


class MeshCollider:
    """A fixed triangle mesh (the scene) that posed bodies are tested against.

    Parameters
    ----------
    vertices : (N, 3) float, metres
    faces : (F, 3) int
    noise : how far (m) the triangles stray from the true surface (a captured surface's
        measured noise, 0 for a model): :meth:`penetrates` allows it on top of any depth
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, noise: float = 0.0):
        fcl = _fcl()
        self._fcl = fcl
        self.vertices = np.asarray(vertices, np.float64)
        self.faces = np.asarray(faces, np.int64)
        self.object = fcl.CollisionObject(_bvh(self.vertices, self.faces), fcl.Transform())
        self.noise = float(noise)

    @functools.cached_property
    def ring(self):
        """Each triangle's neighbours within :data:`CROSSING_SCENE_RING` steps
        (:func:`ring`)."""
        return ring(self.faces, CROSSING_SCENE_RING)

    def penetrates(self, body: "Body", pose: np.ndarray, depth: float,
                   memory: "CrossingMemory | None" = None) -> tuple[bool, float]:
        """The one penetration rule, for detection's collision test and the judge alike:
        whether ``body`` at ``pose`` lies more than ``depth`` (m) plus the surface's
        :attr:`noise` inside the mesh (no tried move of at most that length frees it), and
        the move that frees it (:meth:`separation` up to that length; ``inf`` past it).
        ``memory``: the crossings found at earlier poses (:meth:`separation`)."""
        allowed = depth + self.noise
        sep = self.separation(body, pose, limit=allowed, memory=memory)
        return sep > allowed, sep

    def collides(self, body: "Body", pose: np.ndarray) -> bool:
        """Whether ``body`` moved by the 4x4 ``pose`` intersects the mesh."""
        return len(self.crossing_pairs(body, pose, 1)) > 0

    def crossing_pairs(self, body: "Body", pose: np.ndarray,
                       most: int = 1) -> np.ndarray:
        """(n, 2) int64 pairs (the body's triangle, the mesh's) that cross with ``body`` at
        the 4x4 ``pose``: fcl's first ``most`` (none: they do not intersect; fcl stops at the
        first by default, and costs more the more it is asked for)."""
        fcl = self._fcl
        pose = np.asarray(pose, float)
        body.object.setTransform(fcl.Transform(pose[:3, :3], pose[:3, 3]))
        result = fcl.CollisionResult()
        if not fcl.collide(body.object, self.object,
                           fcl.CollisionRequest(num_max_contacts=most), result):
            return np.zeros((0, 2), np.int64)
        return np.array([(c.b1, c.b2) for c in result.contacts], np.int64).reshape(-1, 2)

    def frees(self, body: "Body", pose: np.ndarray, length: float,
              known: "Crossings | None" = None) -> bool:
        """Whether a move of ``length`` (m) in one of the 26 :func:`directions` takes
        ``body`` (at ``pose``) clear of the mesh. ``known``: triangle pairs found crossing
        at this pose or another of the same orientation; a move that leaves one of them
        crossing (:meth:`Crossings.kept`) is blocked without asking fcl, and the pairs fcl
        finds join them."""
        pose = np.asarray(pose, float)
        moves = length * _DIRECTIONS
        if known is not None:
            moves = moves[~known.kept(moves + known.offset(pose))]
        moved = pose.copy()
        found = []
        try:
            for move in moves:
                moved[:3, 3] = pose[:3, 3] + move
                pairs = self.crossing_pairs(body, moved)
                if not len(pairs):
                    return True
                found.append(pairs)
            return False
        finally:
            if known is not None and found:
                known.add(np.vstack(found))

    def separation(self, body: "Body", pose: np.ndarray, lengths=(0.002, 0.005, 0.01, 0.02,
                                                                   0.05, 0.1, 0.2),
                   limit: float | None = None,
                   memory: "CrossingMemory | None" = None) -> float:
        """Smallest of ``lengths`` (m) by which ``body`` can be moved in one of the 26
        :func:`directions` so that it no longer intersects the mesh: 0 when it does not
        intersect at its pose, ``inf`` when no tried move frees it. An upper bound of the
        penetration depth (the true minimal move may be shorter, in another direction).
        With ``limit``, only whether it is at most ``limit`` matters: the lengths shorter
        than ``limit``, then ``limit``, and ``inf`` past it. Every one of them is tried, in
        order: a move is not freer for being longer (a bowl on a counter with a board 5 mm
        above it is freed by 2 and 5 mm and blocked by 1 cm, where it hits the board; the
        judge, trying 1 cm first, once called such poses "penetrates deeply" or free as a
        micrometre of rounding made them touch the counter or not).

        The triangle pairs found crossing at the pose and at the moves tried so far answer
        the moves that leave one of them crossing (:class:`Crossings`): a body through a
        backrest is blocked in most of its moves by a pair already known, and fcl is asked
        only about the others (the answer is fcl's: a known pair is taken as crossing only
        where it crosses by a margin). With ``memory``, the pairs found at earlier poses of
        the body in the same orientation (a seat's last test point, 1 cm along the same
        backrest) answer this pose's moves as well, and the pairs found here join them."""
        pose = np.asarray(pose, float)
        pairs = self.crossing_pairs(body, pose)
        if not len(pairs):
            return 0.0
        if memory is None:
            known = Crossings(self, body, pose, pairs)
        else:
            known = memory.recall(self, body, pose)
            known.add(pairs)
        if limit is not None:
            lengths = [x for x in lengths if x < limit] + [limit]
        for length in lengths:
            if self.frees(body, pose, length, known):
                return float(length)
        return float("inf")


class Crossings:
    """Triangle pairs of a posed body and the scene's mesh known to cross, and which moves
    of the body leave one of them crossing.

    A pair is taken as crossing after a move when an edge of one of its triangles passes
    through the other's plane and inside its edges, each by at least
    :data:`CROSSING_MARGIN`: then they share a point, whatever fcl's rounding, and fcl
    would find the body and the mesh intersecting. A move that leaves no known pair so is
    not decided here."""

    def __init__(self, collider: MeshCollider, body: "Body", pose: np.ndarray,
                 pairs: np.ndarray):
        self._collider, self._body = collider, body
        self._rot, self._shift = pose[:3, :3].copy(), pose[:3, 3].copy()
        self._state = np.zeros(2, np.int64)           # the next slot written, slots filled
        self._index = None                            # key -> slot (a Numba table)
        self._grow(0)
        self.add(pairs)

    def _grow(self, size: int) -> None:
        """Room for ``size`` pairs, the pairs kept in order (oldest first)."""
        head, count = self._state
        old = getattr(self, "_slots", None)
        order = (head - count + np.arange(count)) % max(len(self._keys), 1) if count else []
        # pairs, keys, the body's and the scene's triangles, the scene's normals and inward
        # edge normals, the body's, and the moves that make their boxes meet (low, high)
        shapes = ((2,), (), (3, 3), (3, 3), (3,), (3, 3), (3,), (3, 3), (2, 3))
        kinds = (np.int64, np.int64) + (np.float64,) * 7
        self._slots = [np.zeros((size,) + sh, k) for sh, k in zip(shapes, kinds)]
        if old is not None and count:
            for new, was in zip(self._slots, old):
                new[:count] = was[order]
        self._state[:] = (count % size if size else 0, count)
        if self._index is not None:
            from interaction_tensor.geometry._crossings import rebuild_index

            rebuild_index(self._keys, count, self._index)

    @property
    def _keys(self) -> np.ndarray:
        return self._slots[1]

    @property
    def pairs(self) -> np.ndarray:
        """(n, 2) the pairs known to cross (the body's triangle, the mesh's), the latest
        found first."""
        head, count = self._state
        return self._slots[0][(head - 1 - np.arange(count)) % max(len(self._keys), 1)]

    def add(self, pairs: np.ndarray) -> None:
        """Take in (n, 2) pairs (the body's triangle, the mesh's) found crossing, with the
        body's triangles near theirs (:attr:`Body.ring`) against the same mesh triangle (a
        move shifts a crossing onto the next triangles of the body); :data:`CROSSING_KEPT`
        at most, the oldest written over first."""
        from interaction_tensor.geometry._crossings import (
            expand_pairs,
            insert_pairs,
            new_index,
        )

        if not len(pairs) or CROSSING_KEPT <= 0:
            return
        body, scene = self._body, self._collider
        near, scene_near = body.ring, scene.ring
        new, keys = expand_pairs(np.ascontiguousarray(pairs, np.int64), near.indptr,
                                 near.indices, scene_near.indptr, scene_near.indices,
                                 len(scene.faces), CROSSING_KEPT)
        if self._index is None:
            self._index = new_index()
        room = len(self._keys)
        if self._state[1] + len(new) > room and room < CROSSING_KEPT:
            self._grow(min(CROSSING_KEPT, max(2 * room, 64, int(self._state[1]) + len(new))))
        insert_pairs(new, keys, body.vertices, body.faces, self._rot, self._shift,
                     scene.vertices, scene.faces, *self._slots, self._state, self._index)

    def offset(self, pose: np.ndarray) -> np.ndarray:
        """(3,) the move from the pose these pairs were posed at to ``pose``, which must
        turn the body the same way (a ``ValueError`` otherwise)."""
        pose = np.asarray(pose, float)
        if not np.array_equal(pose[:3, :3], self._rot):
            raise ValueError("the pose turns the body otherwise than the known crossings")
        return pose[:3, 3] - self._shift

    def kept(self, moves: np.ndarray, reference: bool = False) -> np.ndarray:
        """(M,) bool: whether the body moved by each of ``moves`` (M, 3) from the pose the
        pairs were posed at (:meth:`offset`) leaves a known pair crossing (a Numba kernel;
        ``reference``: NumPy, the rule it is tested against)."""
        moves = np.ascontiguousarray(moves, np.float64)
        head, count = (int(x) for x in self._state)
        if not count:
            return np.zeros(len(moves), bool)
        b, s = self._slots[2][:count], self._slots[3][:count]
        if reference:
            hit = (_edges_cross(b, s, moves, CROSSING_MARGIN)
                   | _edges_cross(s, b, -moves, CROSSING_MARGIN))
            return hit.any(axis=1)
        from interaction_tensor.geometry._crossings import moves_kept

        out = np.empty(len(moves), np.bool_)
        moves_kept(*self._slots[2:], head, count, moves, CROSSING_MARGIN, out)
        return out


class CrossingMemory:
    """The :class:`Crossings` of a body at earlier poses, one per body and orientation
    (its rotation, exactly), for :meth:`MeshCollider.separation`: a detection tests many
    poses of one orientation a centimetre apart (the test points along one backrest), and
    the pairs found crossing at one of them answer most moves of the next. A pose in
    another place merely finds none of them crossing; the latest found are kept
    (:data:`CROSSING_KEPT`, and :data:`MEMORY_KEPT` orientations and bodies)."""

    def __init__(self):
        self._known: dict = {}

    def recall(self, collider: MeshCollider, body: "Body",
               pose: np.ndarray) -> "Crossings":
        """The crossings known of ``body`` against ``collider`` in ``pose``'s orientation
        (none yet: an empty one, posed at ``pose``)."""
        pose = np.asarray(pose, float)
        key = (id(collider), id(body), np.ascontiguousarray(pose[:3, :3]).tobytes())
        known = self._known.get(key)
        if known is None or known._collider is not collider or known._body is not body:
            known = Crossings(collider, body, pose, np.zeros((0, 2), np.int64))
            self._known.pop(key, None)
            while len(self._known) >= MEMORY_KEPT:
                del self._known[next(iter(self._known))]
            self._known[key] = known
        return known


def _edges_cross(moving: np.ndarray, fixed: np.ndarray, moves: np.ndarray,
                 margin: float) -> np.ndarray:
    """(M, P) bool: whether an edge of triangle ``moving[p]`` (P, 3, 3) moved by
    ``moves[m]`` passes through triangle ``fixed[p]``: its ends on either side of the
    triangle's plane, and the point where it crosses inside the triangle's three edges,
    each by ``margin`` (m). A triangle of no area crosses nothing."""
    e = np.roll(fixed, -1, axis=1) - fixed                      # (P, 3 edges, 3)
    n = np.cross(e[:, 0], e[:, 1])
    size = np.linalg.norm(n, axis=1)
    flat = size > 1e-18
    n = n / np.where(flat, size, 1.0)[:, None]
    inward = np.cross(n[:, None], e)                            # (P, 3, 3): into the triangle
    inward /= np.maximum(np.linalg.norm(inward, axis=2, keepdims=True), 1e-300)
    a = moving[None] + moves[:, None, None]                     # (M, P, 3 vertices, 3)
    b = np.roll(a, -1, axis=2)
    da = np.einsum("mpvi,pi->mpv", a - fixed[None, :, :1], n)   # heights over the plane
    db = np.einsum("mpvi,pi->mpv", b - fixed[None, :, :1], n)
    through = ((da > margin) & (db < -margin)) | ((da < -margin) & (db > margin))
    t = da / np.where(through, da - db, 1.0)
    at = a + t[..., None] * (b - a)                             # (M, P, 3 edges, 3)
    inside = np.einsum("mpvi,pji->mpvj", at, inward) - np.einsum("pji,pji->pj", fixed,
                                                                 inward)[None, :, None]
    return (through & (inside > margin).all(axis=3)).any(axis=2) & flat[None]


def ring(faces: np.ndarray, steps: int = 1):
    """Each triangle's neighbours: those within ``steps`` steps of it from vertex to shared
    vertex, itself left out (a SciPy CSR matrix, row by triangle)."""
    from scipy import sparse

    f = len(faces)
    incidence = sparse.csr_matrix((np.ones(3 * f), (np.repeat(np.arange(f), 3),
                                                     np.asarray(faces).ravel())),
                                  shape=(f, int(np.max(faces)) + 1 if f else 0))
    step = (incidence @ incidence.T).tocsr()
    near = step
    for _ in range(steps - 1):
        near = near @ step
    near = near.tocsr()
    near.setdiag(0)
    near.eliminate_zeros()
    near.sort_indices()
    return near


class Body:
    """A query object part as a BVH of its triangles, in its own (training) frame. The BVH is
    built on the first test that needs it: a detection whose pairs all fail earlier tests (a
    person's descriptor on a scene with no seat) never pays for it."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        _fcl()                              # a missing python-fcl is said here, not mid-run
        self.vertices = np.asarray(vertices, float)
        self.faces = np.asarray(faces, np.int64)
        if len(self.faces) == 0:
            raise ValueError("a collision model needs at least one triangle")

    @functools.cached_property
    def object(self):
        """The python-fcl collision object of the triangles."""
        fcl = _fcl()
        return fcl.CollisionObject(_bvh(self.vertices, self.faces), fcl.Transform())

    @functools.cached_property
    def ring(self):
        """Each triangle's neighbours within :data:`CROSSING_RING` steps (:func:`ring`)."""
        return ring(self.faces, CROSSING_RING)

    def __len__(self) -> int:
        return len(self.faces)


#: Longest edge (m) of the triangles a part of a query object is cut into before it is
#: selected by height (:func:`part_above`): a capsule's long triangles (a shin from knee to
#: ankle) would otherwise drop out whole. The judge cuts a person into parts the same way.
PART_EDGE = 0.02


def part_above(vertices: np.ndarray, faces: np.ndarray, z: float | None,
               max_edge: float = PART_EDGE):
    """The part of a triangle mesh above height ``z`` (m): its triangles cut to edges of at
    most ``max_edge`` (trimesh's ``subdivide_to_size``), then those whose three vertices lie
    above ``z``. Returns (vertices, faces); the mesh as it is for ``z`` None.

    Only the triangles that cross ``z`` are cut (a triangle is cut on its own edges alone, so
    the pieces kept are those of cutting them all); the ones wholly above are kept whole,
    which keeps the part's BVH, and a collision test with it, small."""
    vertices, faces = np.asarray(vertices, float), np.asarray(faces, np.int64)
    if z is None:
        return vertices, faces
    import trimesh

    high = (vertices[:, 2] > z)[faces]
    whole = faces[high.all(axis=1)]
    crossing = faces[high.any(axis=1) & ~high.all(axis=1)]
    if not len(crossing):
        return vertices, whole
    v, f = trimesh.remesh.subdivide_to_size(vertices, crossing, max_edge=max_edge,
                                            max_iter=12)
    pieces = f[(v[:, 2] > z)[f].all(axis=1)]
    return np.vstack([vertices, v]), np.vstack([whole, pieces + len(vertices)])


def split_faces(vertices: np.ndarray, faces: np.ndarray, mask_vertices: np.ndarray):
    """Faces whose three vertices are all in ``mask_vertices`` (N,) bool, and the others."""
    inside = np.asarray(mask_vertices, bool)[faces].all(axis=1)
    return faces[inside], faces[~inside]


def disk(centre, radius: float, axis, sections: int = 24):
    """A flat closed disk (two triangle fans, back to back) of ``radius`` about ``centre``,
    perpendicular to ``axis``: (V, 3) vertices, (F, 3) faces."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    u = np.cross(axis, [0.0, 0.0, 1.0] if abs(axis[2]) < 0.9 else [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    w = np.cross(axis, u)
    t = 2 * np.pi * np.arange(sections) / sections
    rim = np.asarray(centre, float) + radius * (np.cos(t)[:, None] * u + np.sin(t)[:, None] * w)
    return polygon(rim, centre)


def box(lo, hi):
    """An axis-aligned closed box from corner ``lo`` to ``hi``: (8, 3) vertices, (12, 3) faces."""
    import trimesh

    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    m = trimesh.creation.box(extents=hi - lo)
    m.apply_translation((lo + hi) / 2)
    return np.asarray(m.vertices), np.asarray(m.faces)


def through_section(query_vertices: np.ndarray, scene_points: np.ndarray,
                    query_points: np.ndarray, margin: float, gap: float,
                    min_points: int = 12, cell: float = 0.001,
                    band: float = 0.0) -> np.ndarray:
    """Where the scene-object passes through the query object in an example (a rail through
    a hook, a peg through a strap's loop), as a flat convex polygon: (K, 3) vertices in
    order, or (0, 3) when nothing of the scene-object lies inside the query's convex hull.

    ``scene_points`` are dense samples of the scene-object near the query, ``query_points``
    dense samples of the query's surface. The scene-object samples inside the query's
    convex hull are projected along the direction in which the scene-object runs through it
    (the principal axis of its samples within twice their extent: the rail's) onto the plane
    through their centroid. The polygon is their region widened by ``margin`` (m) within that
    plane, less what lies within ``gap`` (m) of the query's surface: the opening of the hook
    around the rail, short of the wire. A surface that only touches the hook where it rests
    (a flat top under the hook) does not reach it; a rail, peg or panel edge through the
    hook crosses it. Its top ``band`` (m, measured up +Z within the plane; none when the
    plane is within 30 degrees of level) is left out as well: a surface that only grazes the
    top of the opening (the hook pushed up into a board's underside, the wire in the board)
    does not reach what is left, while a rail, peg or edge through the hook crosses it below.
    The region is found on a grid of ``cell`` (m; coarser for a section over 20 cm across: 200
    cells at most). Detection poses the polygon and asks the scene's triangles to cross it
    (:class:`~.detect.CollisionCheck`).
    """
    from scipy import ndimage
    from scipy.spatial import ConvexHull, Delaunay, QhullError, cKDTree

    empty = np.zeros((0, 3))
    q = np.asarray(query_vertices, float)
    pts = np.asarray(scene_points, float)
    if len(q) < 4 or len(pts) < min_points or len(query_points) == 0:
        return empty
    try:
        hull = Delaunay(q[ConvexHull(q).vertices])
    except QhullError:
        return empty
    inside = pts[hull.find_simplex(pts) >= 0]
    if len(inside) < min_points:
        return empty
    centre = inside.mean(axis=0)
    extent = float(np.linalg.norm(np.ptp(inside, axis=0)))
    near = pts[np.linalg.norm(pts - centre, axis=1) <= 2 * extent]
    axis = np.linalg.svd(near - near.mean(axis=0), full_matrices=False)[2][0]
    u = np.linalg.svd(inside - centre - np.outer((inside - centre) @ axis, axis),
                      full_matrices=False)[2][0]
    w = np.cross(axis, u)
    flat = np.c_[(inside - centre) @ u, (inside - centre) @ w]
    lo, hi = flat.min(axis=0) - margin, flat.max(axis=0) + margin
    cell = max(cell, float((hi - lo).max()) / 200)          # at most 200 cells across
    gu, gw = (np.arange(lo[k], hi[k] + cell, cell) for k in (0, 1))
    grid = np.stack(np.meshgrid(gu, gw, indexing="ij"), -1).reshape(-1, 2)
    near_t, _ = cKDTree(flat).query(grid, distance_upper_bound=margin + cell)
    keep = np.isfinite(near_t)
    lifted = centre + grid[keep, :1] * u + grid[keep, 1:] * w
    touching, _ = cKDTree(np.asarray(query_points, float)).query(lifted,
                                                                 distance_upper_bound=gap)
    keep[keep] = ~np.isfinite(touching)                  # no query sample within ``gap``
    keep = keep.reshape(len(gu), len(gw))
    # the opening itself: the free cells connected to the middle of the scene-object's
    # section, not the inside of the hook's wire beyond it
    parts, _ = ndimage.label(keep)
    middle = np.argmin(np.where(keep.ravel(), (grid ** 2).sum(axis=1), np.inf))
    if not keep.ravel()[middle]:
        return empty
    grid = grid[parts.ravel() == parts.ravel()[middle]]
    up = np.array([u[2], w[2]])                      # +Z within the plane
    if band > 0 and np.linalg.norm(up) >= 0.5:
        height = grid @ (up / np.linalg.norm(up))
        grid = grid[height <= height.max() - band]
    if len(grid) < 3:
        return empty
    try:
        ring = ConvexHull(grid).vertices             # counter-clockwise in 2-D
    except QhullError:                                # all on one line
        return empty
    return centre + grid[ring, :1] * u + grid[ring, 1:] * w


def polygon(vertices: np.ndarray, centre=None):
    """A flat convex polygon as a closed body (two triangle fans about ``centre``, by default
    its vertices' mean, back to back): (V, 3) vertices, (F, 3) faces."""
    ring = np.asarray(vertices, float)
    n = len(ring)
    v = np.vstack([ring.mean(axis=0) if centre is None else np.asarray(centre, float), ring])
    i = np.arange(n)
    front = np.c_[np.zeros(n, int), 1 + i, 1 + (i + 1) % n]
    return v, np.vstack([front, front[:, [0, 2, 1]]])


# --------------------------------------------------------------------------- a person's parts
#: A person's limbs, tested each on its own (the judge's rule and detection's ``"limbs"``
#: collision test): each lower leg more than this (m) below the seat point, ...
LIMB_BELOW_SEAT = 0.05
#: ... each arm more than this above the seat and ``ARM_LATERAL`` to the side of the
#: mid-plane, ...
ARM_ABOVE_SEAT = 0.08
ARM_LATERAL = 0.16
#: ... or a forearm this high above the seat and ``FOREARM_AHEAD`` ahead of it, ...
FOREARM_ABOVE_SEAT = (0.20, 0.50)
FOREARM_AHEAD = 0.18
#: ... and, for a rider (``straddle``), the thighs sloping to the knees: ahead of the seat by
#: more than the first and below it plus the second.
THIGH_AHEAD_BELOW = (0.06, 0.08)


def person_parts(vertices: np.ndarray, faces: np.ndarray, seat, straddle: bool = False,
                 limb_below_seat: float = LIMB_BELOW_SEAT, arm_above_seat: float = ARM_ABOVE_SEAT,
                 arm_lateral: float = ARM_LATERAL, forearm_above_seat=FOREARM_ABOVE_SEAT,
                 forearm_ahead: float = FOREARM_AHEAD):
    """A person's triangles split into the body and its limbs, each to be tested on its own
    (no body part more than so deep inside the scene: a leg through a seat's front edge is
    not excused by the body resting above it). The mesh is first cut to 2 cm edges, so that
    a face's centroid says which part it belongs to; ``seat`` is the point the person sits
    on, in the mesh's frame (+X ahead, +Z up). Returns (vertices, [(name, faces), ...]),
    the body first, then the left and right leg and arm that have triangles."""
    import trimesh

    v, f = trimesh.remesh.subdivide_to_size(np.asarray(vertices, float),
                                            np.asarray(faces, np.int64), max_edge=PART_EDGE,
                                            max_iter=12)
    sp = np.asarray(seat, float)
    c = v[f].mean(axis=1)                       # face centroids
    lower = c[:, 2] < sp[2] - limb_below_seat
    if straddle:                                # a rider's thighs, sloping to the knees
        lower |= ((c[:, 0] > sp[0] + THIGH_AHEAD_BELOW[0])
                  & (c[:, 2] < sp[2] + THIGH_AHEAD_BELOW[1]))
    up = c[:, 2] - sp[2]
    arm = (((up > arm_above_seat) & (np.abs(c[:, 1] - sp[1]) > arm_lateral))
           | ((up > forearm_above_seat[0]) & (up < forearm_above_seat[1])
              & (c[:, 0] > sp[0] + forearm_ahead)))
    left = c[:, 1] > sp[1]
    parts, rest = [], np.ones(len(f), bool)
    for name, part in (("left leg", lower & left), ("right leg", lower & ~left),
                       ("left arm", arm & left), ("right arm", arm & ~left)):
        if part.any():
            rest &= ~part
            parts.append((name, f[part]))
    return v, [("body", f[rest])] + parts
