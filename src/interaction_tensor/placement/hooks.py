"""Hanging's tests of a posed hook (or a strap's loop): what passes through its opening fits
inside it, and the object hangs free below.

A hanger whose hook lies *along* a desk's or a shelf's edge has the scene crossing its
opening, so it passes the through test, but the board goes on sideways through the hook's
wire: no one can hang it there. :func:`fits` splits the scene crossing the opening's plane
into connected pieces and asks each piece that reaches into the opening to stay inside the
object's own outline around it (the hook's wire, the strap's legs and bag); a rail, a rod, a
peg or a tap's spout does, a board's edge along the hook does not, and a board's edge
*across* the hook leaves through the hook's gap, where the object does not close. A hanger
lying on a chair's star base, or a bag standing on the shelf under the edge it is hooked
to, is not hanging: :func:`hangs_free` asks its bottom to keep off up- and down-facing
surfaces.

The paper's judge applies the same two functions with its own loop (:mod:`itensor_paper.judge`),
detection with the opening a descriptor learnt from its example (:func:`opening_of`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

#: How far (m) past the object's own outline the scene through its opening may go.
FIT_MARGIN = 0.01
#: Half-thickness (m) of the slab about the opening's plane in which the object's outline is
#: measured.
FIT_SLAB = 0.015
#: How far (m) from the opening's centre the outline and the scene's pieces are followed.
FIT_REACH = 0.30
#: A placement fails when at least this many scene samples go past the outline.
FIT_MIN_SAMPLES = 2
#: Scene samples (or points of a mesh's cut) closer than this (in scene spacings) belong to
#: the same piece.
FIT_LINK = 2.5
#: On a mesh scene, the step (in scene spacings) of the points along the planes' exact cuts
#: of the mesh that :func:`fits` follows...
SECTION_STEP = 0.2
#: ... the planes' offsets (in scene spacings) from the opening's, across the slab the
#: scene's samples are taken from...
SECTION_OFFSETS = (-0.5, 0.0, 0.5)
#: ... and the angle (degrees) within which a face's normal lies along the opening's axis
#: for its samples in that slab to be taken as well: the cuts run along such a face (a
#: shade's end, a bracket's plate) or miss it.
FACING_ANGLE = 30.0
#: The object's bottom: its samples within this (m) of its lowest point.
FREE_BAND = 0.03
#: A bottom sample rests on a surface when one lies within this (m) of it.
FREE_GAP = 0.015
#: The object rests (does not hang free) when at least this fraction of its bottom does.
FREE_FRACTION = 0.05
#: A scene sample is on an up- or down-facing surface (a top, a floor) when the vertical
#: component of its unit normal is at least this (within about 45 degrees of vertical).
FLAT_NORMAL_Z = 0.7
#: Directions about the opening's centre in which the outline is measured (10 degrees each).
BINS = 36


@dataclass(frozen=True)
class Opening:
    """An object's opening in its own frame: ``centre`` (3,) and the unit ``axis`` (3,)
    normal to its plane; ``up`` and ``side`` span the plane (``up`` as near +Z as the plane
    allows). Scene samples within ``inside`` (m) of the centre, in the plane, pass through
    the opening; ``limit`` (BINS,) is how far (m) from the centre the scene may go in each
    direction (inf where the object does not close round the opening: a hook's gap)."""

    centre: np.ndarray
    axis: np.ndarray
    up: np.ndarray
    side: np.ndarray
    inside: float
    limit: np.ndarray


def plane_frame(axis) -> tuple:
    """(axis, up, side): the unit ``axis`` and two unit directions spanning the plane
    normal to it, ``up`` the nearest to +Z."""
    axis = np.asarray(axis, float)
    axis = axis / np.linalg.norm(axis)
    up = np.array([0.0, 0.0, 1.0]) - axis * axis[2]
    if np.linalg.norm(up) <= 1e-9:                 # a level opening: any in-plane direction
        up = np.array([1.0, 0.0, 0.0]) - axis * axis[0]
    up /= np.linalg.norm(up)
    return axis, up, np.cross(axis, up)


def direction_bins(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The :data:`BINS` direction bins (0 to BINS - 1) of in-plane offsets ``(x, z)``."""
    return np.clip(np.floor((np.arctan2(z, x) + np.pi) / (2 * np.pi / BINS)),
                   0, BINS - 1).astype(np.int64)


def outline(samples: np.ndarray, centre, axis, up, side, nearest: float = 0.0,
            slab: float = FIT_SLAB, reach: float = FIT_REACH) -> np.ndarray:
    """(BINS,) how far out from ``centre`` the object (its surface ``samples``, same frame)
    first goes on in each direction of the plane, counting its samples within ``slab`` of
    the plane and between ``nearest`` and ``reach`` of the centre; inf where none do."""
    d = np.asarray(samples, float) - centre
    h = d @ axis
    x, z = d @ side, d @ up
    r = np.hypot(x, z)
    mine = (np.abs(h) <= slab) & (r >= nearest) & (r <= reach)
    out = np.full(BINS, np.inf)
    np.minimum.at(out, direction_bins(x[mine], z[mine]), r[mine])
    return out


def opening(samples: np.ndarray, centre, axis, inside: float, slab: float = FIT_SLAB,
            reach: float = FIT_REACH, nearest: float | None = None,
            tight: bool = False) -> Opening:
    """The :class:`Opening` of radius ``inside`` (m) about ``centre``, in the plane normal
    to ``axis``, of an object with surface ``samples`` (same frame). What passes through it
    may go on past that radius only in the directions where the object does not close round
    it (its :func:`outline`, from ``nearest`` out; by default 0.9 of the radius): a strap's
    legs and its bag close the sides and below, a hook's wire and the hanger under it close
    it all round, and only an open hook's gap stays open. With ``tight``, not even that
    far where the object's own outline is nearer (a towel's fold round its bar)."""
    axis, up, side = plane_frame(axis)
    centre = np.asarray(centre, float)
    nearest = 0.9 * inside if nearest is None else nearest
    closed = outline(samples, centre, axis, up, side, nearest, slab, reach)
    limit = np.minimum(closed, inside) if tight else np.full(BINS, float(inside))
    return Opening(centre, axis, up, side, float(inside),
                   np.where(np.isfinite(closed), limit, np.inf))


def opening_of(samples: np.ndarray, section: np.ndarray) -> Opening | None:
    """The :func:`opening` of a descriptor's query object (surface ``samples``, training
    frame) round the section of what passed through it in the example (``section`` (K, 3),
    the descriptor's ``through_section``: the rail widened by a spacing, which fills a
    hook's opening), or None without a section: centred on the section's centroid, across
    its plane, as wide as the section. Its outline is followed from 0.9 of the section's
    radius or of the object's own nearest sample in the plane, whichever is nearer, and
    bounds what passes through where it is nearer than the section (``tight``): a towel's
    fold or a mug's handle hugs its bar closer than the widened section, and a bar held
    against the fold's cloth from inside (the towel hung from the bar's underside) or a
    wall's top under it goes on past the fold."""
    section = np.asarray(section, float)
    if len(section) < 3 or len(samples) == 0:
        return None
    centre = section.mean(axis=0)
    axis = np.linalg.svd(section - centre, full_matrices=False)[2][-1]
    inside = float(np.linalg.norm(section - centre, axis=1).max())
    d = np.asarray(samples, float) - centre
    h = d @ axis
    r = np.sqrt(np.maximum(np.einsum("ij,ij->i", d, d) - h * h, 0.0))[np.abs(h) <= FIT_SLAB]
    own = float(r.min()) if len(r) else inside
    return opening(samples, centre, axis, inside, nearest=0.9 * min(inside, own),
                   tight=True)


def fits(opening: Opening, rot: np.ndarray, t: np.ndarray, points: np.ndarray,
         tree: cKDTree, spacing: float, margin: float = FIT_MARGIN,
         min_samples: int = FIT_MIN_SAMPLES, reach: float = FIT_REACH,
         sections=None, normals: np.ndarray | None = None, reference: bool = False) -> bool:
    """Whether what passes through the opening, posed by ``rot`` (3, 3) and ``t`` (3,),
    fits inside it. The scene's samples (``points`` and their ``tree``, at ``spacing``)
    within a spacing of the posed plane and ``reach`` of its centre are split into connected
    pieces; every piece with a sample within ``opening.inside`` of the centre must keep
    within the opening's limit, plus ``margin``, in each direction (fewer than
    ``min_samples`` past it): a rail, a rod, a peg or a tap's spout lies inside a hook; a
    shelf board, a desk top or a counter's lip goes on sideways through the hook's wire or
    a bag's strap, which cannot be put round it. True when nothing passes through.

    With ``sections`` (the scene mesh's :class:`~interaction_tensor.geometry.sections.
    MeshSections`), the scene in that slab is the mesh's exact cuts by the planes at
    :data:`SECTION_OFFSETS` across it instead, a point every :data:`SECTION_STEP` of a
    spacing along each, and a piece fails with a spacing's length of cut past the limit:
    random samples leave gaps of several centimetres in a thin slab, and a wall's top under
    a towel's fold then looks like a rod. The cuts off the plane find a pipe running along
    the hook a few millimetres beside it, and with the samples' ``normals`` the slab's
    samples on faces that lie along the plane (:data:`FACING_ANGLE`) are added, which no
    cut meets: the flat end of a lamp's shade. Its points link into pieces as samples do
    (within :data:`FIT_LINK` spacings), across the gaps a modelled scene leaves between a
    board's front and its lip, or a cabinet's panels: linked only along the cut, the lip a
    hook lies along came apart from the board past the hook. The cuts and their pieces are
    one Numba kernel (:func:`~interaction_tensor.placement._kernels.section_fit`);
    ``reference``: NumPy and SciPy, the path it is tested against."""
    c = rot @ opening.centre + t
    if sections is not None:
        step = SECTION_STEP * spacing
        link, least = FIT_LINK * spacing, max(min_samples, int(round(1.0 / SECTION_STEP)))
        normal = rot @ opening.axis
        normal = normal / np.linalg.norm(normal)
        offsets = np.asarray(SECTION_OFFSETS, np.float64) * spacing
        if not reference:
            from interaction_tensor.placement import _kernels

            tri = np.ascontiguousarray(sections.triangles_near(c, reach))

            def cut(offs, more):
                return bool(_kernels.section_fit(
                    tri, c, normal, offs, np.ascontiguousarray(more, np.float64),
                    float(reach), float(step), np.ascontiguousarray(rot, np.float64),
                    np.asarray(opening.side, np.float64), np.asarray(opening.up, np.float64),
                    float(opening.inside), np.asarray(opening.limit, np.float64),
                    float(margin), float(link), int(least), BINS))
            # the plane's own cut first: what fails on some of the points fails on all
            # (pieces only join and points past the limit only add), and most poses do
            return (cut(np.zeros(1), np.zeros((0, 3)))
                    and cut(offsets, _facing(points, normals, tree, c, normal, spacing, reach)))
        pts = np.vstack([sections.points(c + o * normal, normal, reach, step)
                         for o in offsets]
                        + [_facing(points, normals, tree, c, normal, spacing, reach)])
        d = (pts[np.linalg.norm(pts - c, axis=1) <= reach] - c) @ rot
    else:
        near = np.asarray(tree.query_ball_point(c, reach), np.int64)
        d = (points[near] - c) @ rot                      # the opening's (training) frame
        d = d[np.abs(d @ opening.axis) <= spacing]
        link, least = FIT_LINK * spacing, min_samples
    if not len(d):
        return True
    x, z = d @ opening.side, d @ opening.up
    r = np.hypot(x, z)
    inside = r <= opening.inside
    if not inside.any():
        return True
    past = r > opening.limit[direction_bins(x, z)] + margin
    if int(past.sum()) < least:          # too few past the limit, however they are connected
        return True
    pairs = cKDTree(d).query_pairs(link, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(d), len(d)))
    _, label = connected_components(graph, directed=False)
    through = np.isin(label, np.unique(label[inside]))
    return int((past & through).sum()) < least


def _facing(points, normals, tree, c, normal, spacing: float, reach: float) -> np.ndarray:
    """The scene samples within ``spacing`` of the plane through ``c`` normal to ``normal``
    and ``reach`` of ``c`` whose ``normals`` lie within :data:`FACING_ANGLE` of the plane's
    (none without normals)."""
    if normals is None or not len(points):
        return np.zeros((0, 3))
    near = np.asarray(tree.query_ball_point(c, reach), np.int64)
    h = (points[near] - c) @ normal
    along = np.abs(normals[near] @ normal) >= np.cos(np.radians(FACING_ANGLE))
    return points[near[(np.abs(h) <= spacing) & along]]


def bottom(samples: np.ndarray, band: float = FREE_BAND) -> np.ndarray:
    """The object's bottom: its ``samples`` within ``band`` (m) of its lowest."""
    samples = np.asarray(samples, float)
    return samples[samples[:, 2] <= samples[:, 2].min() + band]


def flat_tree(points: np.ndarray, normals: np.ndarray) -> cKDTree:
    """A KD-tree of the scene samples on up- or down-facing surfaces (tops and floors:
    :data:`FLAT_NORMAL_Z`)."""
    flat = np.asarray(points)[np.abs(np.asarray(normals)[:, 2]) >= FLAT_NORMAL_Z]
    return cKDTree(flat if len(flat) else np.full((1, 3), np.inf))


def hangs_free(bottom_posed: np.ndarray, flats: cKDTree, gap: float = FREE_GAP,
               fraction: float = FREE_FRACTION) -> bool:
    """Whether a posed object hangs free: fewer than ``fraction`` of its posed bottom
    samples lie within ``gap`` of a top or a floor (``flats``, :func:`flat_tree`)."""
    d, _ = flats.query(bottom_posed, distance_upper_bound=gap * 1.01)
    return float((d <= gap).mean()) < fraction
