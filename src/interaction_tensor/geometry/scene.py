"""Scene preparation: sampled points, normals and the nearest-neighbour index."""

from __future__ import annotations

import ctypes
import sys
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from interaction_tensor.errors import InputError
from interaction_tensor.geometry.collision import MeshCollider
from interaction_tensor.geometry.core import Geometry, validate_geometry
from interaction_tensor.geometry.grid import build_grid, grid_cells
from interaction_tensor.geometry.sampling import (
    MeshParts,
    buried_samples,
    crest_samples,
    estimate_normals,
    mean_spacing,
    mesh_area,
    outward_faces,
    sample_mesh,
)
from interaction_tensor.geometry.sections import MeshSections

#: Grid cell edge of the Numba nearest-neighbour search, in scene spacings (fastest of
#: 1, 2, 3, 4 on the demo room; see benchmarks/).
GRID_CELL_FACTOR = 3.0


@dataclass
class Scene:
    """A scene ready for detection.

    Attributes
    ----------
    points : (N, 3) float64, metres, +Z up
    normals : (N, 3) float64 unit normals (their sign may be arbitrary, see DetectSettings)
    spacing : float, mean distance (m) between neighbouring points
    source : str, where the scene came from
    sampled : bool, True when the points were sampled from a mesh
    captured : bool, True for captured data (an RGB-D frame, a scan): detection then defaults
        to the ``gaussian`` criterion (see :meth:`DetectSettings.for_scene`)
    report : for captured data, the :class:`~interaction_tensor.capture.RealSceneReport` of
        its cleaning and alignment (the transform from the input frame); else None
    notes : what loading changed that the user should know (the reader's notes)
    mesh : the scene's triangles, (V, 3) float64 vertices (m) and (F, 3) int64 faces, which
        detection's collision test uses (:meth:`collider`): the mesh it was sampled from, a
        scanned mesh's own or an RGB-D frame's surface (:func:`~.realdata.depth_faces`), in
        the scene's frame; None for point clouds
    surface_noise : how far (m) the triangles of a captured surface stray from the surface
        through its cleaned points (three robust standard deviations of the vertices'
        distances along the points' normals, :func:`~.realdata.pipeline.surface_noise`);
        detection's collision test allows it on top of each test's depth. 0 for meshes
    """

    points: np.ndarray
    normals: np.ndarray
    spacing: float
    source: str = "<array>"
    sampled: bool = False
    captured: bool = False
    report: object = field(default=None, repr=False)
    notes: list = field(default_factory=list, repr=False)
    mesh: tuple | None = field(default=None, repr=False)
    surface_noise: float = 0.0
    #: whether the normals were estimated (PCA of neighbourhoods; a cloud given without them)
    normals_estimated: bool = False
    #: (N,) bool, where the normal is known to point out of the surface (a closed part of a
    #: mesh, :func:`~.sampling.outward_faces`): the side N_aff must face there; None where
    #: no normal's side is known
    oriented: np.ndarray | None = field(default=None, repr=False)
    _tree: cKDTree | None = field(default=None, repr=False)
    _grid: object = field(default=None, repr=False)
    _collider: object = field(default=None, repr=False)
    _sections: object = field(default=None, repr=False)
    _ground: object = field(default=None, repr=False)
    _columns: object = field(default=None, repr=False)

    @property
    def tree(self) -> cKDTree:
        """KD-tree over ``points`` (built on first use)."""
        if self._tree is None:
            self._tree = cKDTree(self.points)
        return self._tree

    def grid(self):
        """Uniform grid over ``points`` for the Numba kernels (built on first use)."""
        if self._grid is None:

            self._grid = build_grid(self.points, self.normals, GRID_CELL_FACTOR * self.spacing)
        return self._grid

    def collider(self):
        """The scene's triangles as a :class:`~.collision.MeshCollider` (python-fcl; built on
        first use), or None for a scene without a mesh."""
        if self._collider is None and self.mesh is not None:

            self._collider = MeshCollider(*self.mesh, noise=self.surface_noise)
        return self._collider

    def sections(self):
        """The scene's triangles as :class:`~.sections.MeshSections` (exact plane cuts; built
        on first use), or None for a scene without a mesh."""
        if self._sections is None and self.mesh is not None:
            self._sections = MeshSections(*self.mesh)
        return self._sections

    def ground_level(self, points: np.ndarray, radius: float) -> np.ndarray:
        """(N,) the lowest scene point within ``radius`` (m) of each of ``points`` (N, 3)
        (:class:`GroundMap`, built on first use)."""
        if self._ground is None:
            self._ground = GroundMap(self.points)
        return self._ground.level(points, radius)

    def columns(self) -> "ColumnIndex":
        """The scene samples one can stand on (their normal line within
        :data:`STAND_ANGLE` of vertical) by 2 cm column (:class:`ColumnIndex`, built on
        first use)."""
        if self._columns is None:
            flat = np.abs(self.normals[:, 2]) >= np.cos(np.radians(STAND_ANGLE))
            self._columns = ColumnIndex(self.points[flat])
        return self._columns

    def highest_under(self, xy: np.ndarray, limit: np.ndarray) -> np.ndarray:
        """(P,) the highest scene sample one can stand on at most ``limit`` (P,) high in the
        2 cm columns under ``xy`` (P, G, 2) and their neighbours (:meth:`columns`); -inf
        where there is none."""
        return self.columns().highest_under(xy, limit)

    def __len__(self) -> int:
        return len(self.points)


#: Bytes a scene point costs ``detect`` at its defaults, with a margin (benchmarks/memory.py
#: measures it); a scene needing more than the memory available is refused up front.
BYTES_PER_POINT = 300
#: (test point, orientation) pairs per scene point that :data:`BYTES_PER_POINT` covers: the
#: defaults' 30 % of the points in 8 orientations.
PAIRS_PER_POINT = 2.4
#: Bytes each pair beyond those costs, with a margin: the pair arrays, scores, decisions and
#: placement tests' outcomes (a 500k-point cloud at 100 % in 32 orientations, 16 M pairs, 6 M
#: of them past the normal filter, took 335 MB more than before detection).
BYTES_PER_PAIR = 64
#: Most (test point, orientation) pairs one detection decides: 4 x a 5 M-point scene's at
#: the defaults. More is refused before any work (lower the sample fraction or the
#: orientations).
MAX_PAIRS = 50_000_000
#: Most samples a mesh scene is sampled into (area / spacing^2 more is refused).
MAX_MESH_SAMPLES = 5_000_000


class GroundMap:
    """The ground around a place: the lowest of ``points`` (N, 3) per ``cell`` (m) column,
    and :meth:`level`, the lowest within a square window of columns around a place. The floor,
    or where a scan has no floor the lowest thing scanned around. Detection's ground test
    and the judge's read it."""

    def __init__(self, points: np.ndarray, cell: float = 0.1):
        self.cell = float(cell)
        ij = np.floor(points[:, :2] / self.cell).astype(np.int64)
        self.origin = ij.min(axis=0)
        ij -= self.origin
        shape = tuple(int(v) for v in ij.max(axis=0) + 1)
        low = np.full(shape[0] * shape[1], np.inf)
        np.minimum.at(low, ij[:, 0] * shape[1] + ij[:, 1], points[:, 2])
        self.low = low.reshape(shape)
        self._filtered: dict = {}

    def level(self, points: np.ndarray, radius: float) -> np.ndarray:
        """(N,) the lowest point within ``radius`` (m, horizontally, rounded up to whole
        columns) of each of ``points`` (N, 3); -inf where the window holds none. The map
        filtered for a radius is built once."""
        from scipy.ndimage import minimum_filter

        r = int(np.ceil(radius / self.cell))
        if r not in self._filtered:
            padded = np.pad(self.low, r, constant_values=np.inf)
            low = minimum_filter(padded, size=2 * r + 1, mode="constant", cval=np.inf)
            self._filtered[r] = np.where(np.isfinite(low), low, -np.inf)
        low = self._filtered[r]
        c = np.floor(np.asarray(points, float).reshape(-1, 3)[:, :2] / self.cell).astype(
            np.int64) - self.origin + r
        inside = np.all((c >= 0) & (c < low.shape), axis=1)
        out = np.full(len(c), -np.inf)
        out[inside] = low[c[inside, 0], c[inside, 1]]
        return out


#: Steepest surface (degrees between its normal line and the vertical) a foot stands on: a
#: floor, a step or a rail's top, not the face of a cabinet beside the shins (the judge's
#: ``stand_angle``).
STAND_ANGLE = 45.0


#: Most columns :meth:`ColumnIndex.table` lays out densely (8 bytes each): a 40 x 40 m
#: extent at 2 cm.
MAX_TABLE_COLUMNS = 4_000_000


class ColumnIndex:
    """The scene's samples by vertical column of ``cell`` (m), each column's heights sorted:
    what lies under a place (detection's feet test). Stored as one sorted array of integer
    keys (column, then the height's rank among all heights), so a query is a binary search:
    memory O(N) however large the scene's extent."""

    def __init__(self, points: np.ndarray, cell: float = 0.02):
        self.cell = float(cell)
        points = np.asarray(points, float).reshape(-1, 3)
        if len(points) == 0:                               # nothing: every query finds none
            points = np.array([[0.0, 0.0, np.inf]])
        ij = np.floor(points[:, :2] / self.cell).astype(np.int64)
        self.origin = ij.min(axis=0) - 1                   # neighbours stay >= 0
        ij -= self.origin
        self.ny = int(ij[:, 1].max()) + 2
        self.z = np.sort(np.asarray(points[:, 2], float))   # every height, ascending
        rank = np.searchsorted(self.z, points[:, 2], side="left")
        self.stride = len(self.z) + 1
        self.code = np.sort((ij[:, 0] * self.ny + ij[:, 1]) * self.stride + rank)

    def table(self):
        """The index as a dense table of columns, for the Numba feet test: (starts
        (nx * ny + 1,) int64, each column's heights ``heights[starts[c]:starts[c + 1]]``
        ascending, origin (2,) int64 column, nx, ny), column c = i * ny + j of the cell
        (i, j) + origin; None where the scene's extent holds more than
        :data:`MAX_TABLE_COLUMNS` columns (a large scan: :meth:`highest_under` serves it).
        Built on first use."""
        if "_table" not in self.__dict__:
            key = self.code // self.stride
            nx = int(key[-1] // self.ny) + 2
            if nx * self.ny > MAX_TABLE_COLUMNS:
                self._table = None
            else:
                starts = np.searchsorted(key, np.arange(nx * self.ny + 1)).astype(np.int64)
                self._table = (starts, self.z[self.code % self.stride], self.origin.copy(),
                               nx, self.ny)
        return self._table

    def highest_under(self, xy: np.ndarray, limit: np.ndarray, chunk: int = 4096) -> np.ndarray:
        """(P,) the highest sample at most ``limit`` (P,) high in the columns under ``xy``
        (P, G, 2) and their 8 neighbours (a margin of at least one cell around each point);
        -inf where there is none. Exact (tested against a brute-force search)."""
        xy = np.asarray(xy, float)
        limit = np.asarray(limit, float)
        p = len(limit)
        out = np.full(p, -np.inf)
        if p == 0 or xy.shape[1] == 0:
            return out
        d = np.array([(a, b) for a in (-1, 0, 1) for b in (-1, 0, 1)], np.int64)
        chunk = max(1, chunk * 9 // len(d) // max(1, xy.shape[1] // 64))
        for s in range(0, p, chunk):
            c = np.floor(xy[s:s + chunk] / self.cell).astype(np.int64) - self.origin
            c = (c[:, :, None, :] + d).reshape(len(c), -1, 2)           # (p, 9G, 2)
            ok = (c[..., 0] >= 0) & (c[..., 1] >= 0) & (c[..., 1] < self.ny)
            key = c[..., 0] * self.ny + c[..., 1]
            # the largest height rank <= limit, then the last code at or below (key, rank)
            r = np.searchsorted(self.z, limit[s:s + chunk], side="right") - 1
            want = key * self.stride + r[:, None]
            at = np.searchsorted(self.code, want, side="right") - 1
            hit = ok & (r[:, None] >= 0) & (at >= 0)
            at = np.maximum(at, 0)
            hit &= self.code[at] // self.stride == key
            z = np.where(hit, self.z[self.code[at] % self.stride], -np.inf)
            out[s:s + chunk] = z.max(axis=1)
        return out


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation (Linux ``MemAvailable``, or the cgroup
    limit a container sets when it is lower); None where it cannot be read."""
    avail = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except OSError:
        return None
    for limit_file, usage_file in (("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
                                   ("/sys/fs/cgroup/memory/memory.limit_in_bytes",
                                    "/sys/fs/cgroup/memory/memory.usage_in_bytes")):
        try:
            limit = open(limit_file).read().strip()
            if limit.isdigit() and int(limit) < 2 ** 60:
                free = int(limit) - int(open(usage_file).read().strip())
                avail = free if avail is None else min(avail, free)
            break
        except (OSError, ValueError):
            continue
    return avail


def check_memory(n_points: int, source, available: int | None = None,
                 pairs_per_point: float | None = None) -> None:
    """Refuse, before any work, a scene of ``n_points`` that would need more memory than is
    available (:data:`BYTES_PER_POINT` each, and :data:`BYTES_PER_PAIR` for each
    (test point, orientation) pair beyond :data:`PAIRS_PER_POINT` a point when detection's
    ``pairs_per_point``, sample fraction x orientations, asks for more), or more pairs than
    :data:`MAX_PAIRS`: one clear line instead of an OOM kill or a run without end."""

    pairs = None if pairs_per_point is None else round(n_points * pairs_per_point)
    if pairs is not None and pairs > MAX_PAIRS:
        raise InputError(source, f"{n_points:,} scene points x {pairs_per_point:g} "
                                 "placements each (sample fraction x orientations) = "
                                 f"{pairs:,} placements to decide, more than the "
                                 f"{MAX_PAIRS:,} allowed; give a smaller --sample-fraction "
                                 "or fewer --orientations")
    available = available_memory() if available is None else available
    extra = 0 if pairs is None else max(0, pairs - int(PAIRS_PER_POINT * n_points))
    need = int(n_points) * BYTES_PER_POINT + extra * BYTES_PER_PAIR
    if available is not None and need > available:
        work = f" and {pairs:,} test placements" if extra else ""
        raise InputError(source, f"{n_points:,} scene points{work} need about "
                                 f"{need / 2**30:.1f} GB and {available / 2**30:.1f} GB is "
                                 "available; sample fewer (a coarser --spacing for a mesh, "
                                 "--voxel-size with --scan for a cloud"
                                 f"{', a smaller --sample-fraction' if extra else ''}) or use a "
                                 "machine with more memory")


def mesh_samples(geometry: Geometry, spacing: float, max_samples: int = MAX_MESH_SAMPLES,
                 face_mask=None) -> int:
    """The samples a mesh scene gets at ``spacing`` (m): its area / spacing^2, at least 100.
    Counted from the area before any sampling; more than ``max_samples`` is refused in one
    line naming the scene (a wrong scale, or a spacing too fine for its size)."""
    area = mesh_area(geometry) if face_mask is None else mesh_area(
        Geometry(geometry.vertices, geometry.faces[face_mask]))
    implied = area / spacing ** 2
    if not implied <= max_samples:
        raise InputError(geometry.source, f"{area:.4g} m^2 of surface at a {spacing:g} m "
                                          f"spacing means {implied:,.0f} samples, more than "
                                          f"the {max_samples:,} allowed; give a larger "
                                          "spacing (--spacing, spacing=), or the right scale "
                                          "(--scale, scale=) if the file is not in metres")
    return max(100, round(implied))


#: Linux's transparent huge page size and madvise's MADV_HUGEPAGE.
HUGE_PAGE = 2 << 20
_MADV_HUGEPAGE = 14


def hot_copy(a: np.ndarray, order: np.ndarray) -> np.ndarray:
    """``a[order]`` in memory that Linux may back with 2 MB (transparent huge) pages: the
    scene's points and normals, which every nearest-neighbour query reads at random (5 % of
    kitchen5's scoring time with 4 kB pages). NumPy asks for huge pages under every array
    of 4 MB or more; the command line turns that off (:func:`cli._one_shot_memory`: with
    them a 2 M-point detection peaked at 488-622 MB from run to run, without them at
    475 MB every time), so they are asked for here only, for arrays filled whole."""
    out = np.empty((len(order),) + a.shape[1:], a.dtype)
    if out.nbytes >= 2 * HUGE_PAGE and sys.platform.startswith("linux"):
        start = out.ctypes.data
        lo = -(-start // HUGE_PAGE) * HUGE_PAGE
        hi = (start + out.nbytes) // HUGE_PAGE * HUGE_PAGE
        try:
            ctypes.CDLL(None).madvise(ctypes.c_void_p(lo), ctypes.c_size_t(hi - lo),
                                      _MADV_HUGEPAGE)
        except (OSError, AttributeError):
            pass
    np.take(a, order, axis=0, out=out)
    return out


def spatially_sorted(points: np.ndarray, normals: np.ndarray | None, spacing: float, *more):
    """``points`` and ``normals`` (or None) and any ``more`` arrays of a value a point
    reordered cell by cell as :meth:`Scene.grid` sorts them, so that the grid shares the
    scene's arrays instead of copying them (48 bytes a point) and neighbouring points lie
    near each other in memory."""

    lin, *_ = grid_cells(points, GRID_CELL_FACTOR * spacing)
    order = np.argsort(lin, kind="stable")
    del lin
    return ((hot_copy(points, order), None if normals is None else hot_copy(normals, order))
            + tuple(m[order] for m in more))


def prepare_scene(geometry: Geometry, spacing: float = 0.01, seed: int = 0,
                  max_points: int = MAX_MESH_SAMPLES, face_mask=None, *,
                  pairs_per_point: float | None = None, progress: bool = False) -> Scene:
    """Turn a mesh or a point cloud into a :class:`Scene`.

    Meshes are sampled area-uniformly at ``spacing`` (m): count = area / spacing^2; a mesh
    whose count exceeds ``max_points`` is refused before sampling (:func:`mesh_samples`).
    The scene keeps the mesh (``Scene.mesh``) for detection's collision test. Point clouds
    are used as they are, unless more than :data:`DENSE_FACTOR` times denser than
    ``spacing``: then thinned to it (:func:`thinned`, said in the scene's notes); their
    normals are estimated by PCA when the file had none (a progress bar with ``progress``).
    Mesh samples inside another closed part of the mesh are left out
    (:func:`~.sampling.buried_samples`). ``pairs_per_point``: detection's sample fraction x
    orientations, checked with the memory (:func:`check_memory`) before any work.
    """
    validate_geometry(geometry)
    if geometry.is_mesh:
        count = mesh_samples(geometry, spacing, max_points, face_mask)
        check_memory(count, geometry.source, pairs_per_point=pairs_per_point)
        points, normals, faces = sample_mesh(geometry, count, seed, face_mask=face_mask,
                                             with_faces=True)
        notes = list(geometry.notes)
        parts = MeshParts(geometry.vertices, geometry.faces)
        # a peg's or a thin rod's top: samples a quarter spacing apart along it
        c_points, c_normals, c_faces = crest_samples(geometry, spacing, seed, face_mask, parts)
        if len(c_points):
            points = np.vstack([points, c_points])
            normals = np.vstack([normals, c_normals])
            faces = np.concatenate([faces, c_faces])
        buried = buried_samples(geometry.vertices, geometry.faces, points, normals, faces,
                                parts)
        if buried.any():
            keep = ~buried
            points, normals, faces = points[keep], normals[keep], faces[keep]
            notes.append(f"{int(buried.sum()):,} samples inside closed parts of the mesh "
                         "dropped (a surface another part covers: nothing can reach it)")
        # where a closed part says which side is out, the normals point out of it
        side = outward_faces(geometry.vertices, geometry.faces, parts)[faces]
        del faces, parts
        normals *= np.where(side < 0, -1.0, 1.0)[:, None]
        points, normals, oriented = spatially_sorted(points, normals, spacing, side != 0)
        return Scene(points, normals, spacing, geometry.source, sampled=True, notes=notes,
                     mesh=(np.asarray(geometry.vertices, np.float64),
                           np.asarray(geometry.faces, np.int64)),
                     oriented=oriented if oriented.any() else None)
    points = geometry.vertices
    normals = geometry.normals
    if normals is not None and len(normals) != len(points):
        normals = None
    estimated = normals is None
    notes = list(geometry.notes)
    check_memory(len(points), geometry.source, pairs_per_point=pairs_per_point)
    tree = cKDTree(points)
    measured = mean_spacing(points, tree)
    if 0 < measured < spacing / DENSE_FACTOR:
        # denser than the descriptor looks: thinned to its spacing (the same places as the
        # mesh, a fraction of the work); a smaller spacing keeps more
        keep = thinned(points, spacing)
        notes.append(f"thinned from {len(points):,} points ({1000 * measured:.1f} mm apart) "
                     f"to {len(keep):,} at the descriptor's {1000 * spacing:.0f} mm spacing "
                     "(give a smaller spacing to keep more)")
        # normals from the whole cloud's neighbourhoods: a thin board keeps its two faces
        normals = (estimate_normals(points, tree=tree, progress=progress, at=keep,
                                    spacing=measured)
                   if normals is None else normals[keep])
        points = points[keep]
        tree = cKDTree(points)
        measured = mean_spacing(points, tree)
    # the tree is not kept: the default (Numba) backend searches its own grid, and a
    # cKDTree costs 32 bytes a point (rebuilt on first use by the other paths)
    del tree
    if normals is None:                 # sorted first: neighbours' searches near in memory
        points, _ = spatially_sorted(points, None, measured)
        normals = estimate_normals(points, progress=progress, spacing=measured)
    else:
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        normals = np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)
        points, normals = spatially_sorted(points, normals, measured)
    return Scene(points, normals, measured, geometry.source, False, notes=notes,
                 normals_estimated=estimated)


#: A point cloud this many times denser than the spacing asked for (the descriptor's) is
#: thinned to it (:func:`thinned`).
DENSE_FACTOR = 1.5


def thinned(points: np.ndarray, spacing: float) -> np.ndarray:
    """Indices (sorted) of one point per cube of edge ``spacing``: the one nearest the cube's
    centre (ties to the lower index). A surface keeps about one point per ``spacing`` squared,
    as a mesh sampled at that spacing does, and every point kept is a measured one."""
    p = np.asarray(points, np.float64)
    cell = np.floor((p - p.min(axis=0)) / spacing).astype(np.int64)
    dims = cell.max(axis=0) + 1
    key = (cell[:, 0] * dims[1] + cell[:, 1]) * dims[2] + cell[:, 2]
    off = ((p - p.min(axis=0)) / spacing - cell - 0.5) ** 2
    order = np.lexsort((np.arange(len(p)), off.sum(axis=1), key))
    first = np.ones(len(order), bool)
    first[1:] = key[order][1:] != key[order][:-1]
    return np.sort(order[first])
