"""Filling's tests of a posed container: a tap above its opening, a basin round it and a
sink under it, where the water goes.

A mug placed by its score alone stands wherever something hangs over it: under a shelf, a
counter's overhang, a desk top or inside a cabinet. Water comes from a spout that reaches
over the opening from one side (:func:`tap_above`: not a shelf or a ceiling covering the
opening, not a bar or a board's edge running across it), into a basin whose walls stand
round the container (:func:`basin_sectors`), with a bottom the water reaches, closed all
round by walls that rise from it (:func:`sink_sectors`: not a shelf inside a cabinet under
the counter, not the floor under a seat).

A tap's height above the basin differs from kitchen to kitchen, so the container's height
under the tap is not the example's: detection stands it on the highest surface under its base
(:func:`settle`) before asking the rest.

The paper's judge applies the same functions to the poses it judges
(:mod:`itensor_paper.judge`), detection to the placements of a descriptor that asks for them
(:attr:`~interaction_tensor.descriptor.InteractionTensor.fills`: the tap test of every pair,
with :func:`taps_above`, before the score; settling, basin and sink of the ranked ones), with
the container's :class:`Vessel` measured from its example.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The spout: scene surface within this (m) of the opening's vertical axis...
TAP_RADIUS = 0.03
#: ... this far (m) above the opening, (lowest, highest)...
TAP_RANGE = (0.02, 0.30)
#: ... and, in that height range, the disk of this radius (m) round the axis covered at most
#: this much (a shelf or a ceiling covers it)...
TAP_DISK = 0.15
TAP_MAX_COVER = 0.5
#: ... counted in plan cells of this edge (m)...
TAP_CELL = 0.02
#: ... reaching over the opening from one side (no two opposite eighths of the disk both
#: hold surface) and spanning at most this many degrees round the axis (a bar, a board's
#: front edge or a monitor's bezel runs across the opening: 220-280 degrees).
TAP_MAX_ANGLE = 150.0
#: The basin: scene surface between the container's side and this far (m) from its axis...
BASIN_RADIUS = 0.30
#: ... from this high (m) above its support to this high above its rim...
BASIN_HEIGHT = (0.02, 0.0)
#: ... in at least this many of 8 sectors round it.
BASIN_SECTORS = 5
#: The sink: an up-facing bottom within this (m) of the opening's axis...
SINK_RADIUS = 0.15
#: ... at most this far (m) below the container's support (and 2 cm above it)...
SINK_DEPTH = 0.45
#: ... with wall surface both this (foot) and this (wall) high above it (m)...
SINK_FOOT = (0.02, 0.06)
SINK_WALL = (0.08, 0.14)
#: ... within this (m) of it, in at least this many of 36 directions round it.
SINK_REACH = 0.35
SINK_SECTORS = 33
#: Plan cell (m) in which sink bottoms are thinned and checked open above.
SINK_CELL = 0.03
#: Settling: the container's base goes down at most this far (m) onto what is under it (a
#: tap 31 cm above a basin's bottom where the example's was 19 cm above the mug's base; the
#: tap test reaches 30 cm above the opening)...
SETTLE_DROP = 0.20
#: ... or up at most this far (m), out of a surface it sank into (the collision test's depth).
SETTLE_RISE = 0.01
#: Samples within this (m) of a container's lowest point are its base (:attr:`Vessel.foot`).
BASE_BAND = 0.01
#: It stands (:func:`stands`) where the scene samples from this far (m) below its base to
#: this far above it, under its outline, surround its centre of mass by this margin (m)
#: (the judge's support test).
SUPPORT_BELOW = 0.02
SUPPORT_ABOVE = 0.01
SUPPORT_MARGIN = 0.01


@dataclass(frozen=True)
class Vessel:
    """A container in its own frame: the centre of its ``opening`` (3,) (its rim's, at its
    top), its centre of mass ``com`` (3,), its ``support`` height (its lowest point's),
    ``side``, how far (m) its side reaches from the vertical through ``com``, and its base:
    the plan centre ``base`` (2,) and radius ``foot`` (m) of what lies within
    :data:`BASE_BAND` of its lowest point, and its ``outline`` (K, 2), the convex hull of
    its plan, counter-clockwise."""

    opening: np.ndarray
    com: np.ndarray
    support: float
    side: float
    base: np.ndarray
    foot: float
    outline: np.ndarray

    @classmethod
    def of(cls, samples: np.ndarray, rim: float = 0.01) -> "Vessel":
        """The vessel of surface ``samples`` (N, 3), standing upright: its rim is what lies
        within ``rim`` (m) of its top."""
        samples = np.asarray(samples, float)
        top = samples[:, 2].max()
        ring = samples[samples[:, 2] >= top - rim]
        com = samples.mean(axis=0)
        low = float(samples[:, 2].min())
        sole = samples[samples[:, 2] <= low + BASE_BAND, :2]
        base = sole.mean(axis=0)
        from scipy.spatial import ConvexHull

        plan = samples[:, :2]
        return cls(np.r_[ring[:, :2].mean(axis=0), top], com, low,
                   float(np.linalg.norm(plan - com[:2], axis=1).max()), base,
                   float(np.linalg.norm(sole - base, axis=1).max()),
                   plan[ConvexHull(plan).vertices])


def tap_above(points: np.ndarray, tree, opening, radius: float = TAP_RADIUS,
              height: tuple = TAP_RANGE, disk: float = TAP_DISK,
              max_cover: float = TAP_MAX_COVER, one_side: bool = True,
              max_angle: float = TAP_MAX_ANGLE) -> bool:
    """Whether a tap's spout is above the (posed) ``opening`` (3,): scene surface
    (``points`` and their cKDTree ``tree``) within ``radius`` of its vertical axis,
    ``height`` above it, that covers at most ``max_cover`` of the ``disk`` round the axis in
    that height range and (``one_side``) reaches the axis from one side, spanning at most
    ``max_angle`` degrees round it."""
    opening = np.asarray(opening, float)
    lo, hi = opening[2] + height[0], opening[2] + height[1]
    idx = np.asarray(tree.query_ball_point(np.r_[opening[:2], (lo + hi) / 2],
                                           np.hypot(disk, (hi - lo) / 2)), np.int64)
    p = points[idx]
    p = p[(p[:, 2] >= lo) & (p[:, 2] <= hi)]
    r = np.linalg.norm(p[:, :2] - opening[:2], axis=1)
    if not (r <= radius).any():
        return False
    cell = TAP_CELL
    cells = np.unique(np.floor(p[r <= disk, :2] / cell).astype(np.int64), axis=0)
    if len(cells) * cell ** 2 / (np.pi * disk ** 2) > max_cover:
        return False
    if not one_side:
        return True
    side = p[(r > radius) & (r <= disk), :2] - opening[:2]
    angle = np.arctan2(side[:, 1], side[:, 0]) + np.pi              # [0, 2 pi]
    eighths = np.zeros(8, bool)
    eighths[np.clip(np.floor(angle / (np.pi / 4)), 0, 7).astype(np.int64)] = True
    bins = np.unique(np.clip(np.floor(angle / np.radians(10)), 0, 35))
    return bool(not (eighths[:4] & eighths[4:]).any() and 10.0 * len(bins) <= max_angle)


def taps_above(openings: np.ndarray, points: np.ndarray, tree, grid=None) -> np.ndarray:
    """(P,) :func:`tap_above` of each of ``openings`` (P, 3), with the default limits: the
    Numba kernel on the scene's ``grid`` (cells sorted as ``points``), else the reference,
    one opening at a time."""
    openings = np.asarray(openings, float).reshape(-1, 3)
    if grid is not None:
        from interaction_tensor.placement import _kernels

        return _kernels.taps(openings, TAP_RADIUS, TAP_RANGE, TAP_DISK, TAP_MAX_COVER,
                             TAP_MAX_ANGLE, grid, TAP_CELL)
    return np.array([tap_above(points, tree, o) for o in openings], bool)


def settle(vessel: Vessel, rot: np.ndarray, t: np.ndarray, points: np.ndarray, tree,
           drop: float = SETTLE_DROP, rise: float = SETTLE_RISE) -> float:
    """How far (m) to move ``vessel`` posed by ``rot`` (a turn about +Z) and ``t`` up
    (positive) or down so that its base stands on the highest scene sample under it (within
    its :attr:`~Vessel.foot` of the base's vertical, from ``drop`` below the base to
    ``rise`` above it); NaN where there is none (it would fall)."""
    base = rot @ np.r_[vessel.base, vessel.support] + t
    lo, hi = base[2] - drop, base[2] + rise
    idx = np.asarray(tree.query_ball_point([base[0], base[1], (lo + hi) / 2],
                                           float(np.hypot(vessel.foot, (hi - lo) / 2))),
                     np.int64)
    p = points[idx]
    under = ((p[:, 2] >= lo) & (p[:, 2] <= hi)
             & (np.hypot(p[:, 0] - base[0], p[:, 1] - base[1]) <= vessel.foot))
    return float(p[under, 2].max() - base[2]) if under.any() else float("nan")


def margin_inside_support(points: np.ndarray, z0: float, footprint: np.ndarray, com,
                          below: float = SUPPORT_BELOW, above: float = SUPPORT_ABOVE) -> float:
    """How far (m) ``com`` (3,) lies inside the plan hull of the scene ``points`` (N, 3)
    that bear an object: from ``below`` under the height ``z0`` of its base to ``above``
    over it, inside the plan hull of its ``footprint`` (K, 2) (negative outside; -inf with
    fewer than three, or none in a hull). The judge's support test, and :func:`stands`."""
    from scipy.spatial import ConvexHull, QhullError

    band = points[(points[:, 2] >= z0 - below) & (points[:, 2] <= z0 + above)]
    if len(band) < 3:
        return -np.inf
    try:
        foot = ConvexHull(footprint).equations
        under = band[(band[:, :2] @ foot[:, :2].T + foot[:, 2]).max(axis=1) <= 1e-9]
        if len(under) < 3:
            return -np.inf
        eq = ConvexHull(under[:, :2]).equations
    except (QhullError, ValueError):
        return -np.inf
    return float(-(eq[:, :2] @ np.asarray(com, float)[:2] + eq[:, 2]).max())


def support_margin(vessel: Vessel, rot: np.ndarray, t: np.ndarray, points: np.ndarray, tree,
                   below: float = SUPPORT_BELOW, above: float = SUPPORT_ABOVE) -> float:
    """:func:`margin_inside_support` of ``vessel`` posed by ``rot`` (a turn about +Z) and
    ``t``: its centre of mass inside what bears its base, within its outline."""
    com = rot @ vessel.com + t
    z0 = vessel.support + t[2]
    outline = vessel.outline @ rot[:2, :2].T + t[:2]
    reach = float(np.linalg.norm(outline - com[:2], axis=1).max())
    idx = np.asarray(tree.query_ball_point([com[0], com[1], z0 + (above - below) / 2],
                                           float(np.hypot(reach, (above + below) / 2))),
                     np.int64)
    return margin_inside_support(points[idx], z0, outline, com, below, above)


def stands(vessel: Vessel, rot: np.ndarray, t: np.ndarray, points: np.ndarray, tree,
           margin: float = SUPPORT_MARGIN) -> bool:
    """Whether ``vessel`` posed so stands: its centre of mass at least ``margin`` inside
    what bears it (:func:`support_margin`), not tipping off a divider's edge."""
    return support_margin(vessel, rot, t, points, tree) >= margin


def basin_sectors(points: np.ndarray, tree, com, support: float, rim: float, side: float,
                  spacing: float, radius: float = BASIN_RADIUS,
                  height: tuple = BASIN_HEIGHT) -> int:
    """Of 8 sectors round the vertical through ``com`` (a posed container's centre of
    mass), how many hold scene surface between the container's ``side`` (plus a
    ``spacing``) and ``radius``, from ``height[0]`` above its ``support`` to ``height[1]``
    above its ``rim``: the walls of a sink, a washbasin or a niche."""
    lo, hi = support + height[0], rim + height[1]
    centre = np.r_[np.asarray(com, float)[:2], (lo + hi) / 2]
    idx = np.asarray(tree.query_ball_point(centre, float(np.hypot(radius, (hi - lo) / 2))),
                     np.int64)
    p = points[idx]
    d = p[:, :2] - centre[:2]
    r = np.hypot(d[:, 0], d[:, 1])
    wall = (p[:, 2] >= lo) & (p[:, 2] <= hi) & (r > side + spacing) & (r <= radius)
    sector = np.floor((np.arctan2(d[wall, 1], d[wall, 0]) + np.pi) / (np.pi / 4))
    return int(len(np.unique(np.clip(sector, 0, 7))))


def sink_sectors(points: np.ndarray, normals: np.ndarray, tree, opening, support: float,
                 radius: float = SINK_RADIUS, depth: float = SINK_DEPTH,
                 foot: tuple = SINK_FOOT, wall: tuple = SINK_WALL, reach: float = SINK_REACH,
                 cell: float = SINK_CELL) -> int:
    """The most directions (of 36) closed round a basin bottom near the (posed)
    ``opening``: up-facing samples within ``radius`` of its axis, from ``depth`` below the
    container's ``support`` to 2 cm above it (one per ``cell`` in plan), open above up to
    the opening (no sample within ``cell`` over them, 2 cm or more higher), each with wall
    surface (normal at least 37 degrees from vertical) both ``foot`` and ``wall`` above it
    within ``reach`` in how many of 36 directions round it."""
    lo, hi = support - depth, support + 0.02
    c = np.asarray(opening, float)
    ball = np.asarray(tree.query_ball_point(
        [c[0], c[1], (lo + hi) / 2], float(np.hypot(radius, (hi - lo) / 2))), np.int64)
    p, n = points[ball], normals[ball]
    bottom = ((p[:, 2] >= lo) & (p[:, 2] <= hi) & (np.abs(n[:, 2]) >= np.cos(np.radians(25)))
              & (np.hypot(p[:, 0] - c[0], p[:, 1] - c[1]) <= radius))
    b = p[bottom]
    if not len(b):
        return 0
    _, first = np.unique(np.floor(b / cell).astype(np.int64), axis=0, return_index=True)
    b = b[np.sort(first)]
    # a bottom water can reach: nothing over it (2 cm up to the opening, within a cell):
    # not a shelf in a cabinet under the counter, not the floor under a seat
    top = float(c[2])
    ball = np.asarray(tree.query_ball_point(
        [c[0], c[1], (lo + top) / 2], float(np.hypot(radius + cell, (top - lo) / 2))),
        np.int64)
    a = points[ball]
    a = a[a[:, 2] <= top]
    open_above = np.ones(len(b), bool)
    for s in range(0, len(b), 64):                  # bounded (64 x A) blocks
        bb = b[s:s + 64]
        dx = a[None, :, 0] - bb[:, None, 0]
        dy = a[None, :, 1] - bb[:, None, 1]
        over = (dx * dx + dy * dy <= cell ** 2) & (a[None, :, 2] - bb[:, None, 2] > 0.02)
        open_above[s:s + 64] = ~over.any(axis=1)
    b = b[open_above]
    if not len(b):
        return 0
    wlo, whi = b[:, 2].min() + foot[0], b[:, 2].max() + wall[1]
    far = radius + reach
    ball = np.asarray(tree.query_ball_point(
        [c[0], c[1], (wlo + whi) / 2], float(np.hypot(far, (whi - wlo) / 2))), np.int64)
    w, wn = points[ball], normals[ball]
    w = w[(w[:, 2] >= wlo) & (w[:, 2] <= whi) & (np.abs(wn[:, 2]) <= 0.8)]   # walls
    best = 0
    for s in range(0, len(b), 32):                  # bounded (32 x W) blocks
        bb = b[s:s + 32]
        dx = w[None, :, 0] - bb[:, None, 0]
        dy = w[None, :, 1] - bb[:, None, 1]
        h = w[None, :, 2] - bb[:, None, 2]
        near = dx * dx + dy * dy <= reach ** 2
        sector = np.clip(np.floor((np.arctan2(dy, dx) + np.pi) / (np.pi / 18)),
                         0, 35).astype(np.int64)
        # a basin's walls rise from its bottom: wall surface low (its foot) and high, in
        # the same direction
        closed = np.ones((len(bb), 36), bool)
        for lo_h, hi_h in (foot, wall):
            rows, cols = np.nonzero(near & (h >= lo_h) & (h <= hi_h))
            seen = np.zeros((len(bb), 36), bool)
            seen[rows, sector[rows, cols]] = True
            closed &= seen
        best = max(best, int(closed.sum(axis=1).max()))
        if best == 36:
            return best
    return best


def fills(vessel: Vessel, rot: np.ndarray, t: np.ndarray, points: np.ndarray,
          normals: np.ndarray, tree, spacing: float) -> bool:
    """Whether ``vessel`` posed upright (``rot`` (3, 3) a turn about +Z, ``t`` (3,)) could
    be filled where it stands: a tap above its opening, standing on what bears it
    (:func:`stands`), a basin round it (:data:`BASIN_SECTORS`) and a sink under it
    (:data:`SINK_SECTORS`), asked in that order (the sink, the costliest, last)."""
    opening = rot @ vessel.opening + t
    com = rot @ vessel.com + t
    support = float(vessel.support + t[2])
    return (tap_above(points, tree, opening)
            and stands(vessel, rot, t, points, tree)
            and basin_sectors(points, tree, com, support, float(opening[2]), vessel.side,
                              spacing) >= BASIN_SECTORS
            and sink_sectors(points, normals, tree, opening, support) >= SINK_SECTORS)
