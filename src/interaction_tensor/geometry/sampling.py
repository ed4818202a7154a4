"""Area-uniform surface sampling, point-cloud normals and keypoint sampling."""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from interaction_tensor.errors import InputError
from interaction_tensor.geometry.core import Geometry
from interaction_tensor.geometry.grid import KNearest, knn_cell


def mesh_area(geometry: Geometry) -> float:
    """Surface area (m^2) of a mesh geometry."""
    import trimesh

    return float(trimesh.triangles.area(geometry.vertices[geometry.faces]).sum())


def sample_mesh(geometry: Geometry, count: int, seed, face_mask=None, with_faces: bool = False):
    """Area-uniform random samples on a mesh, with their face normals.

    Parameters
    ----------
    geometry : a mesh Geometry
    count : number of samples
    seed : int or numpy Generator
    face_mask : (F,) bool or None, restrict sampling to these faces

    Returns
    -------
    points : (count, 3) float64, metres
    normals : (count, 3) float64, unit face normals (orientation as the file's winding)
    faces : (count,) int64, with ``with_faces``: the face of each sample (an index into
        ``geometry.faces``)
    """
    import trimesh

    faces = geometry.faces if face_mask is None else geometry.faces[face_mask]
    if len(faces) == 0 or not trimesh.triangles.area(geometry.vertices[faces]).sum() > 0:
        raise InputError(geometry.source, "no surface to sample (zero area)")
    mesh = trimesh.Trimesh(geometry.vertices, faces, process=False)
    points, face_index = trimesh.sample.sample_surface(mesh, int(count), seed=seed)
    normals = np.asarray(mesh.face_normals)[face_index]
    if not with_faces:
        return points, normals
    index = np.arange(len(geometry.faces)) if face_mask is None else np.flatnonzero(face_mask)
    return points, normals, index[face_index]


#: How far (m) along its normal a sample is lifted before it is asked whether a closed part of
#: the mesh holds it: off its own surface, so that a sample on a face that another part's
#: face covers (a table top under a box standing on it) counts as inside that part.
BURIED_LIFT = 1e-3


class MeshParts:
    """A mesh's parts, worked out once: its vertices merged (shared corners join faces,
    trimesh's ``merge_vertices``; the faces keep their order), its parts (connected sets of
    faces), which of them are closed (every edge used by exactly two of the part's faces)
    and which of those are wound consistently (each edge walked once each way).

    Attributes
    ----------
    mesh : the merged ``trimesh.Trimesh``
    part : (F,) int64 part of each face; n_parts : int
    closed : (n_parts,) bool; consistent : (n_parts,) bool (closed and consistent)
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        import trimesh

        faces = np.asarray(faces, np.int64)
        mesh = trimesh.Trimesh(np.asarray(vertices, np.float64), faces, process=False)
        mesh.merge_vertices()
        self.mesh = mesh
        merged = np.asarray(mesh.faces)
        n = len(merged)
        adj = np.asarray(mesh.face_adjacency).reshape(-1, 2)
        graph = coo_matrix((np.ones(len(adj), np.int8), (adj[:, 0], adj[:, 1])), shape=(n, n))
        self.n_parts, part = connected_components(graph, directed=False)
        self.part = part.astype(np.int64)
        # one int64 key per (part, edge): the part, then the edge's two vertices
        nv = max(len(mesh.vertices), 1)
        directed = merged[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
        edge_part = np.repeat(self.part, 3)
        key = (edge_part * nv + directed.min(axis=1)) * nv + directed.max(axis=1)
        _, inv, counts = np.unique(key, return_inverse=True, return_counts=True)
        self.closed = np.ones(self.n_parts, bool)
        self.closed[edge_part[counts[inv.reshape(-1)] != 2]] = False
        walked, w_counts = np.unique((edge_part * nv + directed[:, 0]) * nv + directed[:, 1],
                                     return_counts=True)
        self.consistent = self.closed.copy()
        self.consistent[walked[w_counts > 1] // nv // nv] = False


def buried_samples(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray,
                   normals: np.ndarray, face_index: np.ndarray,
                   parts: "MeshParts | None" = None, rays: bool = True) -> np.ndarray:
    """(N,) bool: the samples of a mesh that lie inside a closed part of it other than their
    own (a table top under a box standing on it, a floor under a wardrobe): no object can
    reach them. A part is a connected set of faces whose every edge two of its faces share
    (:class:`MeshParts`, worked out here unless given); a sample inside one (generalised
    winding number of the part at the sample lifted by :data:`BURIED_LIFT` along its
    normal, at least 0.5 in magnitude) is buried. Open parts (a scanned room's single
    surface) bury nothing. Only the samples inside a part's bounding box are tested. With
    ``rays`` (and Numba), a part wound consistently is asked by the faces an upward ray
    crosses (:func:`closed_windings`: its winding number off its surface, in a look-up of
    the faces over the point), the generalised winding number only where the ray grazes an
    edge."""
    faces = np.asarray(faces, np.int64)
    buried = np.zeros(len(points), bool)
    if len(faces) < 8 or len(points) == 0:
        return buried
    parts = parts or MeshParts(vertices, faces)
    mesh, part, n_parts = parts.mesh, parts.part, parts.n_parts
    if n_parts < 2:
        return buried
    merged = np.asarray(mesh.faces)
    size = np.bincount(part, minlength=n_parts)
    tri = np.asarray(mesh.vertices)[merged]
    lo = np.full((n_parts, 3), np.inf)
    hi = np.full((n_parts, 3), -np.inf)
    np.minimum.at(lo, part, tri.min(axis=1))
    np.maximum.at(hi, part, tri.max(axis=1))
    lifted = points + BURIED_LIFT * normals
    sample_part = part[face_index]
    boxes = KNearest(lifted, BUCKET)
    by_part = np.argsort(part, kind="stable")                   # each part's faces, sliced
    start = np.concatenate([[0], np.cumsum(size)])
    for c in np.flatnonzero(parts.closed & (size >= 4)):        # closed parts, one at a time
        near = boxes.within(lo[c], hi[c])
        if not len(near):
            continue
        near = near[(sample_part[near] != c) & ~buried[near]
                    & (lifted[near] >= lo[c]).all(axis=1) & (lifted[near] <= hi[c]).all(axis=1)]
        if len(near):
            part_faces = merged[by_part[start[c]:start[c + 1]]]
            w = (closed_windings(lifted[near], mesh.vertices, part_faces)
                 if rays and parts.consistent[c] else
                 winding_numbers(lifted[near], mesh.vertices, part_faces))
            buried[near[np.abs(w) >= 0.5]] = True
    return buried


#: A closed part's faces are bucketed by plan in cells of about this many faces' share of
#: its plan box (:func:`closed_windings`).
RAY_FACES_PER_CELL = 4.0


def closed_windings(points: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(P,) winding numbers of ``points`` about a closed surface wound consistently (a
    :class:`MeshParts` part): off the surface an integer, the sum of the signs (the normals'
    z) of the faces an upward ray from the point crosses, found through a plan grid of the
    faces (a Numba kernel); where the ray grazes an edge, or the point lies on a face, the
    generalised winding number (:func:`winding_numbers`) instead. Without Numba, the
    generalised winding number everywhere."""
    try:
        from interaction_tensor.geometry._winding import ray_windings
    except ImportError:               # pragma: no cover - Numba is a dependency
        return winding_numbers(points, vertices, faces)
    points = np.ascontiguousarray(points, np.float64)
    tri = np.ascontiguousarray(np.asarray(vertices, np.float64)[np.asarray(faces, np.int64)])
    if len(points) == 0 or len(tri) == 0:
        return np.zeros(len(points))
    nz = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 2]
    sign = np.sign(nz).astype(np.int64)
    lo, hi = tri[:, :, :2].min(axis=1), tri[:, :, :2].max(axis=1)
    origin = lo.min(axis=0)
    extent = np.maximum(hi.max(axis=0) - origin, 1e-9)
    cell = float(max(np.sqrt(extent.prod() * RAY_FACES_PER_CELL / len(tri)), 1e-6))
    nx, ny = (int(v) for v in np.ceil(extent / cell) + 1)
    i0, j0 = (np.floor((lo - origin) / cell).astype(np.int64)).T
    i1, j1 = (np.floor((hi - origin) / cell).astype(np.int64)).T
    ni, nj = i1 - i0 + 1, j1 - j0 + 1
    count = ni * nj
    owner = np.repeat(np.arange(len(tri)), count)
    k = np.arange(len(owner)) - np.repeat(np.cumsum(count) - count, count)
    cells = (i0[owner] + k // nj[owner]) * ny + (j0[owner] + k % nj[owner])
    order = np.argsort(cells, kind="stable")
    members = owner[order]
    starts = np.searchsorted(cells[order], np.arange(nx * ny + 1)).astype(np.int64)
    w = np.zeros(len(points), np.int64)
    unsure = np.zeros(len(points), np.bool_)
    ray_windings(points, tri, sign, starts, members, origin, cell, nx, ny, 1e-9, w, unsure)
    out = w.astype(np.float64)
    if unsure.any():
        out[unsure] = winding_numbers(points[unsure], vertices, faces)
    return out


#: Edge (m) of the cells :func:`buried_samples` sorts the lifted samples into (a
#: :class:`~interaction_tensor.geometry.grid.KNearest`).
BUCKET = 0.1


def outward_faces(vertices: np.ndarray, faces: np.ndarray,
                  parts: "MeshParts | None" = None) -> np.ndarray:
    """(F,) int8: +1 where a face's normal (by its winding) points out of the closed part it
    belongs to, -1 where it points in, 0 where the mesh does not say (an open part: a CAD
    model's single surface, a scanned room; or a closed part whose faces are not wound
    consistently: :class:`MeshParts`, worked out here unless given). The sign of a
    consistently wound closed part's volume (the sum of its faces' signed tetrahedra) says
    whether its faces turn out or in."""
    faces = np.asarray(faces, np.int64)
    if len(faces) < 4:
        return np.zeros(len(faces), np.int8)
    parts = parts or MeshParts(vertices, faces)
    tri = np.asarray(parts.mesh.vertices)[np.asarray(parts.mesh.faces)]
    volume = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2]))
    part_volume = np.bincount(parts.part, weights=volume, minlength=parts.n_parts)
    sign = np.where(~parts.consistent | (np.abs(part_volume) <= 1e-15), 0,
                    np.sign(part_volume))
    return sign[parts.part].astype(np.int8)


#: A face is part of a surface curved tighter than the sampling spacing when a long edge of
#: it bends to its neighbour by at least this (radians) and by less than
#: :data:`CREST_MAX_BEND` (a crease, a box's edge, is not a curve).
CREST_MIN_BEND = 1e-3
CREST_MAX_BEND = np.radians(60.0)
#: ... and it lies within this (degrees) of level (a peg's or a rail's top or underside,
#: where an interaction along N_aff up or down rests).
CREST_LEVEL_DEG = 30.0
#: Such faces get a sample every this many spacings of their length.
CREST_STEP = 0.25


def crest_faces(vertices: np.ndarray, faces: np.ndarray, spacing: float,
                parts: "MeshParts | None" = None) -> np.ndarray:
    """(F,) bool: the faces of surfaces curved tighter than ``spacing`` (a peg, a hook, a thin
    rod: a radius under the spacing), near level. Area-uniform sampling at ``spacing`` gives
    a 5 mm peg's top one sample in several centimetres, so the few places along it where
    something can hang are missed. A face qualifies when it is narrower than half the
    spacing (twice its area over its longest edge), one of its long edges (at least half
    its longest) bends to the neighbouring face by an angle ``a`` between
    :data:`CREST_MIN_BEND` and :data:`CREST_MAX_BEND` with the faces' mean width under
    ``a`` x ``spacing`` (the curve's radius under the spacing), and its normal's line lies
    within :data:`CREST_LEVEL_DEG` of vertical (the mesh's :class:`MeshParts`, worked out
    here unless given, join the faces)."""
    faces = np.asarray(faces, np.int64)
    out = np.zeros(len(faces), bool)
    if len(faces) < 2:
        return out
    mesh = (parts or MeshParts(vertices, faces)).mesh
    tri = mesh.triangles
    longest = np.linalg.norm(np.roll(tri, -1, axis=1) - tri, axis=2).max(axis=1)
    area = mesh.area_faces
    width = np.divide(2 * area, longest, out=np.zeros_like(longest), where=longest > 0)
    adj = np.asarray(mesh.face_adjacency)
    if not len(adj):
        return out
    angle = np.asarray(mesh.face_adjacency_angles)
    ends = np.asarray(mesh.face_adjacency_edges)
    edge = np.linalg.norm(mesh.vertices[ends[:, 0]] - mesh.vertices[ends[:, 1]], axis=1)
    curved = ((angle >= CREST_MIN_BEND) & (angle < CREST_MAX_BEND)
              & ((width[adj[:, 0]] + width[adj[:, 1]]) / 2 < angle * spacing))
    for side in (0, 1):
        f = adj[:, side]
        out[f[curved & (edge >= 0.5 * longest[f])]] = True
    level = np.abs(np.asarray(mesh.face_normals)[:, 2]) >= np.cos(np.radians(CREST_LEVEL_DEG))
    return out & (width < spacing / 2) & level & (area > 0)


def crest_samples(geometry: Geometry, spacing: float, seed, face_mask=None,
                  parts: "MeshParts | None" = None) -> tuple:
    """Samples of the :func:`crest_faces` of a mesh (of those in ``face_mask``, (F,) bool,
    if given), each face one every :data:`CREST_STEP` spacings of its longest edge, uniform
    in the face: ((C, 3) points, (C, 3) face normals, (C,) face indices)."""
    crest = crest_faces(geometry.vertices, geometry.faces, spacing, parts)
    sel = np.flatnonzero(crest if face_mask is None else crest & np.asarray(face_mask, bool))
    if not len(sel):
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int64)
    tri = np.asarray(geometry.vertices, np.float64)[np.asarray(geometry.faces)[sel]]
    longest = np.linalg.norm(np.roll(tri, -1, axis=1) - tri, axis=2).max(axis=1)
    count = np.ceil(longest / (CREST_STEP * spacing)).astype(np.int64)
    owner = np.repeat(np.arange(len(sel)), count)
    rng = np.random.default_rng(seed)
    a, b = rng.random((2, len(owner)))
    flip = a + b > 1
    a, b = np.where(flip, 1 - a, a), np.where(flip, 1 - b, b)
    t = tri[owner]
    points = t[:, 0] + a[:, None] * (t[:, 1] - t[:, 0]) + b[:, None] * (t[:, 2] - t[:, 0])
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    return points, normal[owner], sel[owner]


#: :func:`estimate_normals` fits each point's plane twice: the second time with the
#: neighbours within this many nearest-neighbour distances of the first plane through the
#: point (when at least :data:`NORMAL_REFIT_MIN` are).
NORMAL_REFIT_SLAB = 1.0
NORMAL_REFIT_MIN = 5
#: :func:`estimate_normals` then chooses each point's plane among those of its ``k``
#: nearest, by how near they pass to its ``NORMAL_WIDE * k`` nearest, and fits it again
#: with those near the chosen plane.
NORMAL_WIDE = 2
#: the nearest neighbours whose planes a point chooses among (itself the first)
NORMAL_CANDIDATES = 8
#: a point whose ``k`` nearest all lie within this share of the slab of its plane keeps
#: the plane (a clean face: nothing to choose)
NORMAL_CLEAN = 0.25
#: nor does a point whose :data:`NORMAL_CANDIDATES` nearest's planes all lie within this
#: angle (degrees) of its own (a noisy face: whichever it chose, the plane would be the same)
NORMAL_AGREE = 10.0
#: points whose nearest distinct neighbour's distance gives the plane's slab (a seeded draw)
NORMAL_SLAB_SAMPLE = 2000


def _least_spread(centred: np.ndarray) -> np.ndarray:
    """(n, 3) unit directions of least spread of (n, k, 3) centred neighbourhoods."""
    return np.linalg.eigh(np.einsum("nki,nkj->nij", centred, centred))[1][:, :, 0]


def _fits_numpy(points, queries, idx, slab):
    """:func:`estimate_normals`' two plane fits of each query's neighbours ``idx`` (n, k),
    in NumPy: the first plane's normal, the refitted one's and how many neighbours lie
    within ``slab`` (m) of the first plane."""
    nb = points[idx]
    first = _least_spread(nb - nb.mean(axis=1, keepdims=True))
    again, count = _refit_numpy(points, queries, idx, first, slab)
    return first, again, count


def _refit_numpy(points, queries, idx, plane, slab):
    """The normals fitted to each query's neighbours ``idx`` within ``slab`` (m) of the
    plane through it normal to ``plane`` (n, 3), and how many those are."""
    nb = points[idx]
    near = np.abs(np.einsum("nki,ni->nk", nb - queries[:, None], plane)) <= slab
    weight = near.astype(np.float64)
    count = weight.sum(axis=1)
    centre = np.einsum("nk,nki->ni", weight, nb) / np.maximum(count, 1.0)[:, None]
    return _least_spread((nb - centre[:, None]) * weight[..., None]), count


def _choose_numpy(points, queries, idx, planes, candidates, slab):
    """Each query's plane among the ``planes`` (normals, a row a point) of its first
    ``candidates`` neighbours in ``idx`` (n, w): the one its neighbours lie nearest, each
    counting 1 - (h / slab)^2 within ``slab`` of the plane through the query (h its
    distance), summed in the kernel's order; ties to the nearer neighbour's. The reference
    of :func:`~interaction_tensor.geometry._normals.choose_planes`."""
    off = points[idx] - queries[:, None]
    inv = 1.0 / (slab * slab) if slab > 0 else 0.0
    best = np.full(len(idx), -1.0)
    choice = np.zeros((len(idx), 3))
    for j in range(min(candidates, idx.shape[1])):
        c = planes[idx[:, j]]
        h = off[..., 0] * c[:, None, 0] + off[..., 1] * c[:, None, 1] \
            + off[..., 2] * c[:, None, 2]
        h2 = h * h
        weight = np.where(h2 < slab * slab, 1.0 - h2 * inv, 0.0)
        score = np.zeros(len(idx))
        for m in range(idx.shape[1]):
            score = score + weight[:, m]
        better = (score > best) & ~np.isnan(c[:, 0])
        best = np.where(better, score, best)
        choice[better] = c[better]
    return choice


def _spread_numpy(points, queries, idx, plane):
    """(n,) the farthest of each query's neighbours ``idx`` from the plane through it
    normal to ``plane`` (n, 3), metres."""
    return np.abs(np.einsum("nki,ni->nk", points[idx] - queries[:, None], plane)).max(axis=1)


def _agree_numpy(planes, near, rows, normals):
    """(n,) the least |cosine| between each of ``normals`` (n, 3) and the ``planes`` of the
    points ``near[rows]`` (n, c)."""
    return np.abs(np.einsum("nci,ni->nc", planes[near[rows]], normals)).min(axis=1)


def _agree_numba(planes, near, rows, normals):
    """:func:`_agree_numpy` by a Numba kernel."""
    from interaction_tensor.geometry._normals import planes_agree

    out = np.empty(len(rows))
    planes_agree(planes, near, np.ascontiguousarray(rows, np.int64),
                 np.ascontiguousarray(normals), out)
    return out


def _spread_numba(points, queries, idx, plane):
    """:func:`_spread_numpy` by a Numba kernel."""
    from interaction_tensor.geometry._normals import plane_spread

    out = np.empty(len(idx))
    plane_spread(points, np.ascontiguousarray(queries), idx, np.ascontiguousarray(plane), out)
    return out


def _fits_numba(points, queries, idx, slab):
    """:func:`_fits_numpy` with the scatter matrices summed by Numba kernels (no (n, k, 3)
    temporaries) and their least eigenvectors in closed form (:func:`_least_eigenvectors`;
    NumPy's ``eigh`` within 1e-12 rad where sure, itself elsewhere)."""
    from interaction_tensor.geometry import _normals

    cov = np.empty((len(idx), 3, 3))
    _normals.scatter(points, idx, cov)
    first = _least_eigenvectors(cov)
    again, count = _refit_numba(points, queries, idx, first, slab, cov)
    return first, again, count


def _refit_numba(points, queries, idx, plane, slab, cov=None):
    """:func:`_refit_numpy` by a Numba kernel (``cov``: (n, 3, 3) scratch, if at hand)."""
    from interaction_tensor.geometry import _normals

    cov = np.empty((len(idx), 3, 3)) if cov is None else cov
    count = np.empty(len(idx), np.int64)
    _normals.refit_scatter(points, np.ascontiguousarray(queries), idx,
                           np.ascontiguousarray(plane), slab, cov, count)
    return _least_eigenvectors(cov), count


def _choose_numba(points, queries, idx, planes, candidates, slab):
    """:func:`_choose_numpy` by a Numba kernel."""
    from interaction_tensor.geometry._normals import choose_planes

    choice = np.empty((len(idx), 3))
    choose_planes(points, np.ascontiguousarray(queries), idx, planes,
                  int(min(candidates, idx.shape[1])), float(slab), choice)
    return choice


#: :func:`estimate_normals`' closed-form eigen-solver hands a matrix to NumPy's where its
#: two least eigenvalues are nearer each other than this share of its largest (the
#: closed form's vector loses digits as they meet; a line's neighbourhood).
EIGEN_GAP = 1e-4


def _least_eigenvectors(cov: np.ndarray) -> np.ndarray:
    """(n, 3) unit eigenvectors of the least eigenvalues of (n, 3, 3) symmetric matrices:
    in closed form (a Numba kernel), NumPy's ``eigh`` where the closed form is unsure
    (:data:`EIGEN_GAP`)."""
    from interaction_tensor.geometry._normals import least_eigenvectors

    out = np.empty((len(cov), 3))
    unsure = np.empty(len(cov), np.bool_)
    least_eigenvectors(cov, EIGEN_GAP, out, unsure)
    if unsure.any():
        out[unsure] = np.linalg.eigh(cov[unsure])[1][:, :, 0]
    return out


def estimate_normals(points: np.ndarray, k: int = 16, tree: cKDTree | None = None,
                     progress: bool = False, at: np.ndarray | None = None,
                     reference: bool = False, spacing: float | None = None) -> np.ndarray:
    """Unit normals of a point cloud, by PCA of neighbourhoods in three steps.

    1. Each point's plane is fitted to its ``k`` nearest neighbours, then again to those
       near that first plane through the point (a sparse cloud's neighbourhood reaches
       past a narrow board's top to its edge and underside: at 3 cm, 37 % of a furnished
       room's up-facing points came out within 15 degrees of up with one fit, 71 % with
       two).
    2. Each point then takes, of the planes of its ``k`` nearest, the one its
       ``NORMAL_WIDE * k`` nearest lie nearest (each within the slab counting
       1 - (h / slab)^2 at distance h from the plane through the point), and the plane is
       fitted once more to those within the slab of it. A board as thick as the cloud's
       spacing puts both its faces in every neighbourhood, and one fit of them tilts many
       a top's plane through both (a 3 cm table top sampled 3 cm apart: 30 % of its
       normals more than 10 degrees off); a neighbour's plane that lies along the top
       holds the top's points exactly and wins (5 % off). Beside a crease, the plane of
       the face the point lies on holds more of its neighbours than the other face's.
       A point has no choice to make, and keeps its plane, where its ``k`` nearest all lie
       within :data:`NORMAL_CLEAN` of the slab of it, or where the planes of its
       :data:`NORMAL_CANDIDATES` nearest all lie within :data:`NORMAL_AGREE` degrees of
       it (a noisy face: a room's cloud with 1 mm of noise, 7 mm apart, left 90 % of its
       points a choice by the first rule, 18 % by both; normals more than 10 degrees off
       in the demo room's cloud at 1 cm with 1 mm of noise: 1.15 % choosing everywhere,
       1.16 % so).

    The slab is :data:`NORMAL_REFIT_SLAB` times the median distance from a seeded draw of
    points to their nearest distinct neighbour. The work goes 50,000 points at a time
    (with ``progress``, a progress bar of the plane fits); with ``at`` (indices), the
    normals at those points only, their neighbours taken from the whole cloud (the first
    step then runs at them and their ``k`` nearest). Given the cloud's ``spacing`` (m),
    the neighbours are found on a grid (:class:`~interaction_tensor.geometry.grid.KNearest`;
    a k-d tree where the cloud's extent would make its cells more than twice as wide), and
    the fits and choices are Numba kernels; ``reference``: the k-d tree and NumPy, the path
    the fast one is tested against.

    The sign is chosen so that normals point to +Z where they are not horizontal
    (normals of clouds are unoriented; callers that need a side use their own rule).

    Returns (N, 3) float64, or (len(at), 3).
    """
    points = np.asarray(points, dtype=np.float64)
    k = int(min(k, len(points)))
    wide = int(min(round(NORMAL_WIDE * k), len(points)))
    queries = np.arange(len(points)) if at is None else np.asarray(at, np.int64)
    search = None
    if spacing and spacing > 0 and not reference:
        grid = KNearest(points, knn_cell(spacing, k))
        # a grid whose cells had to grow (a vast extent) would hold too many points a cell
        if grid.cell <= 2 * knn_cell(spacing, k):
            search = grid.query
        else:
            del grid
    if search is None:
        tree = cKDTree(points) if tree is None else tree

        def search(q, k):
            d, i = tree.query(q, k=k, workers=-1)
            return d.reshape(len(q), k), np.asarray(i, np.int64).reshape(len(q), k)
    slab = NORMAL_REFIT_SLAB * _nearest_distance(points, search)
    fit, choose, refit, spread, agreement = (
        (_fits_numpy, _choose_numpy, _refit_numpy, _spread_numpy, _agree_numpy) if reference
        else (_fits_numba, _choose_numba, _refit_numba, _spread_numba, _agree_numba))
    step = 50_000  # bounds the (step, wide, 3) neighbourhood arrays (about 40 MB)
    if at is None:
        support = queries
        planes = np.empty_like(points)
    else:                               # the queries and their k nearest: the candidates
        near = [search(points[queries[s:s + step]], k)[1].ravel()
                for s in range(0, len(queries), step)]
        support = np.unique(np.concatenate([queries] + near))
        planes = np.full_like(points, np.nan)
    bar = None
    if progress and len(support) > step:         # plane fits: at each point, then again
        from tqdm import tqdm                    # where it has a choice (total grows then)

        bar = tqdm(total=len(support), unit="fit", unit_scale=True, desc="normals",
                   leave=False)
    clean = np.zeros(len(points), np.bool_)
    candidates = min(k, NORMAL_CANDIDATES)
    near = np.zeros((len(support), candidates), np.int32 if len(points) < 2 ** 31 else np.int64)
    try:
        for start in range(0, len(support), step):
            rows = support[start:start + step]
            _, idx = search(points[rows], k)
            first, again, count = fit(points, points[rows], idx, slab)
            plane = np.where((count >= NORMAL_REFIT_MIN)[:, None], again, first)
            planes[rows] = plane
            clean[rows] = spread(points, points[rows], idx, plane) <= NORMAL_CLEAN * slab
            near[start:start + step] = idx[:, :candidates]
            if bar is not None:
                bar.update(len(rows))
        normals = planes[queries]
        # the candidates' planes, all known now: where they agree, there is no choice
        at_support = queries if at is None else np.searchsorted(support, queries)
        least = np.empty(len(queries))
        for start in range(0, len(queries), step):
            q = slice(start, start + step)
            least[q] = agreement(planes, near, at_support[q], normals[q])
        clean[queries] |= least >= np.cos(np.radians(NORMAL_AGREE))
        del near
        unsure = np.flatnonzero(~clean[queries])
        if bar is not None:
            bar.total = len(support) + len(unsure)
            bar.refresh()
        for start in range(0, len(unsure), step):
            at_rows = unsure[start:start + step]
            q = points[queries[at_rows]]
            _, idx = search(q, wide)
            choice = choose(points, q, idx, planes, candidates, slab)
            again, count = refit(points, q, idx, choice, slab)
            normals[at_rows] = np.where((count >= NORMAL_REFIT_MIN)[:, None], again, choice)
            if bar is not None:
                bar.update(len(at_rows))
    finally:
        if bar is not None:
            bar.close()
    flip = normals[:, 2] < 0
    normals[flip] *= -1
    return normals


def _nearest_distance(points: np.ndarray, search) -> float:
    """The median distance (m) from a seeded draw of :data:`NORMAL_SLAB_SAMPLE` points to
    their nearest distinct neighbour (0 for fewer than two points)."""
    if len(points) < 2:
        return 0.0
    rng = np.random.default_rng(0)
    draw = np.sort(rng.choice(len(points), min(NORMAL_SLAB_SAMPLE, len(points)),
                              replace=False))
    dist, _ = search(points[draw], min(8, len(points)))
    nearest = np.where(dist > 1e-9, dist, np.inf).min(axis=1)
    nearest = nearest[np.isfinite(nearest)]
    return float(np.median(nearest)) if len(nearest) else 0.0


def unique_rows(a: np.ndarray) -> np.ndarray:
    """The distinct rows of a 2-D integer array in lexicographic order, as
    ``np.unique(a, axis=0)`` gives them, about twice as fast (one lexsort, no void view)."""
    if len(a) == 0:
        return a.copy()
    s = a[np.lexsort(a.T[::-1])]
    return s[np.r_[True, np.any(s[1:] != s[:-1], axis=1)]]


#: :func:`mean_spacing`: the counting disk's radius in nearest-neighbour distances (about
#: four spacings), the nearest points that give a centre's local plane, and how far from it
#: (a fraction of the disk's radius: about a spacing) a neighbour still counts.
DISK_NEIGHBOUR_DISTANCES = 8.0
PLANE_NEIGHBOURS = 16
PLANE_SLAB = 0.25


def mean_spacing(points: np.ndarray, tree: cKDTree | None = None, sample: int = 2000,
                 seed: int = 0) -> float:
    """Sampling spacing (m) of a surface point cloud: 1 / sqrt(points per square metre).

    The same meaning as the spacing at which meshes are sampled (count = area / spacing^2).
    The density is the median number of distinct neighbours within a disk of eight
    nearest-neighbour distances, over a random subset of centres; duplicated points (common
    in scans and converted clouds) do not count, nor do those farther than a quarter of the
    disk's radius from the centre's local plane (a PCA of its 16 nearest points): another
    surface crossing the disk (a wall at a floor's edge, a box on a table, a board's other
    face) would otherwise count, and in a furnished room the spacing came out 15-25 % short.
    Memory: the tree and the subset's neighbourhoods, no copy of the cloud.
    """
    points = np.asarray(points, np.float64)
    if len(points) < 3:
        return 0.0
    rng = np.random.default_rng(seed)
    tree = cKDTree(points) if tree is None else tree
    centres = points[rng.choice(len(points), size=min(sample, len(points)), replace=False)]
    # nearest *distinct* neighbour (duplicates at distance 0 skipped) of each centre
    d, _ = tree.query(centres, k=min(8, len(points)), workers=-1)
    nn = np.where(d > 1e-6, d, np.inf).min(axis=1)
    if not np.isfinite(nn).any():
        return 0.0
    radius = DISK_NEIGHBOUR_DISTANCES * float(np.median(nn[np.isfinite(nn)]))
    # each centre's local plane: the normal of least spread of its nearest points
    _, idx = tree.query(centres, k=min(PLANE_NEIGHBOURS, len(points)), workers=-1)
    normal = _least_spread(points[idx] - points[idx].mean(axis=1, keepdims=True))
    # distinct neighbours within the radius and near the plane, counted without a copy of
    # the whole cloud: (centre, micrometre cell) keys of the neighbours, made unique
    lists = tree.query_ball_point(centres, radius, workers=-1)
    lengths = np.fromiter((len(x) for x in lists), np.int64, len(lists))
    near = np.fromiter((i for x in lists for i in x), np.int64, int(lengths.sum()))
    owner = np.repeat(np.arange(len(lists)), lengths)
    height = np.abs(((points[near] - centres[owner]) * normal[owner]).sum(axis=1))
    flat = height <= PLANE_SLAB * radius
    keys = np.column_stack([owner[flat], np.round(points[near[flat]] / 1e-6).astype(np.int64)])
    counts = np.bincount(unique_rows(keys)[:, 0], minlength=len(lists))
    density = np.median(counts) / (np.pi * radius ** 2)
    return float(1.0 / np.sqrt(density)) if density > 0 else float(np.median(nn))


def weighted_keypoints(weights: np.ndarray, n: int, seed) -> np.ndarray:
    """Weight-driven keypoint indices: ``n`` draws without replacement with probability
    proportional to ``weights`` (paper, eq. 3).

    Points of zero weight are drawn only when fewer than ``n`` have a positive weight.
    Returns (min(n, len(weights)),) int64 indices, unsorted.
    """
    weights = np.asarray(weights, dtype=np.float64)
    n = min(int(n), len(weights))
    rng = np.random.default_rng(seed)
    positive = np.flatnonzero(weights > 0)
    if len(positive) <= n:
        rest = np.setdiff1d(np.arange(len(weights)), positive)
        extra = rng.choice(rest, size=n - len(positive), replace=False)
        return np.r_[positive, extra]
    p = weights[positive] / weights[positive].sum()
    return positive[rng.choice(len(positive), size=n, replace=False, p=p)]


def uniform_keypoints(count: int, n: int, seed) -> np.ndarray:
    """``n`` indices drawn uniformly without replacement from ``count`` points."""
    rng = np.random.default_rng(seed)
    return rng.choice(int(count), size=min(int(n), int(count)), replace=False)


def winding_numbers(points: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Generalised winding number of each point with respect to a triangle mesh: the Numba
    kernel when Numba imports, else :func:`winding_numbers_reference` (same formula)."""
    try:
        from interaction_tensor.geometry._winding import winding_numbers as kernel
    except ImportError:                                     # no Numba: the NumPy reference
        return winding_numbers_reference(points, vertices, faces)
    tri = np.ascontiguousarray(np.asarray(vertices, np.float64)[np.asarray(faces, np.int64)])
    return kernel(np.ascontiguousarray(points, dtype=np.float64), tri)


def winding_numbers_reference(points: np.ndarray, vertices: np.ndarray, faces: np.ndarray,
                              chunk: int = 2_000_000) -> np.ndarray:
    """Generalised winding number of each point with respect to a triangle mesh (NumPy).

    About 1 inside a closed, outward-wound mesh, 0 outside, 0.5 on its surface (Jacobson et
    al. 2013: the sum of the triangles' signed solid angles over 4 pi, each from van
    Oosterom & Strackee's formula). Exact for watertight meshes however thin their parts;
    vectorised in blocks of about ``chunk`` (point, triangle) terms.
    """
    p = np.asarray(points, np.float64)
    tri = np.asarray(vertices, np.float64)[np.asarray(faces, np.int64)]      # (F, 3, 3)
    out = np.zeros(len(p))
    step = max(1, chunk // max(len(tri), 1))
    for s in range(0, len(p), step):
        r = tri[None, :, :, :] - p[s:s + step, None, None, :]                  # (P, F, 3, 3)
        a, b, c = r[:, :, 0], r[:, :, 1], r[:, :, 2]
        la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
        det = np.einsum("pfi,pfi->pf", a, np.cross(b, c))
        den = (la * lb * lc + np.einsum("pfi,pfi->pf", a, b) * lc
               + np.einsum("pfi,pfi->pf", b, c) * la + np.einsum("pfi,pfi->pf", c, a) * lb)
        out[s:s + step] = np.arctan2(det, den).sum(axis=1) / (2 * np.pi)
    return out
