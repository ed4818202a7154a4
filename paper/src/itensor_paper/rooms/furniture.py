"""Procedural furniture with labelled affordance sites, in metres, +Z up.

Every builder takes a placement, ``xy`` (metres) and ``angle`` (degrees about +Z: the
direction the piece's front faces, 0 = +x), plus its own sizes, and returns a :class:`Piece`:
closed primitives (boxes, cylinders, capsules, spheres, solids of revolution from
``trimesh.creation``, possibly overlapping) already in scene coordinates, and the
:class:`Site` s where an interaction can happen. Pieces stand on the floor ``z = 0`` except
the wall-mounted ones (``Piece.wall_mounted``), whose origin is on the wall face with the
front (+x of the piece) pointing out of the wall.

In each builder's own frame the front is +x, the left is +y and the origin is the centre of
the footprint (free-standing pieces) or the middle of the back edge (pieces that go against a
wall: counters, washbasins, bookcases, shelves, pegs, TV stands, radiators).

Site semantics (``Site.kind``):

* ``seat``: a point on the top surface of a seat where a seated person's buttocks go (the
  seat's x-y centre for chairs and stools; one per seating place, centred in depth, on sofas
  and benches; 0.2 m in from the edge of a bed); ``facing`` where the seated person faces;
  ``width`` the free distance from the point, along -facing, to the front face of the
  backrest (``inf`` without a backrest).
* ``astride``: the top of a narrow support (<= 0.30 m wide) a person can sit astride, free
  down to the floor on both sides (a sofa or armchair arm: free on its outer side, the seat
  cushion on the inner side); ``facing`` the support's long axis; ``width`` its width.
* ``hang``: the top of a thin support a hanger hook (4.6 cm opening) or a strap loop (5 cm)
  can go over, with 0.45 m free below; ``facing`` along the support's long axis (for a wall
  peg, out of the wall); ``width`` the support's thickness across.
* ``place``: a point on a free horizontal top surface at least 0.12 m from its edges with
  0.30 m free above; ``facing`` (1, 0); ``width`` the distance to the nearest edge.
* ``fill``: the bottom of a sink basin right under the tap outlet; ``facing`` from the tap
  column towards the outlet; ``width`` the height of the outlet above the basin bottom.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from interaction_tensor.examples import procedural, shapes
from interaction_tensor.examples.shapes import ball, box, polyline, revolve, rod
from interaction_tensor.geometry.core import Geometry

KINDS = ("seat", "astride", "hang", "place", "fill")
INF = float("inf")


@dataclass(frozen=True)
class Site:
    """Where an interaction can happen (module docstring for each kind).

    Attributes
    ----------
    kind : ``seat``, ``astride``, ``hang``, ``place`` or ``fill``
    point : (3,) metres, on the surface the interaction rests on
    facing : (2,) unit x-y direction
    width : metres (seat: free depth to the backrest, inf without one; astride: support
        width; hang: support thickness; place: distance to the nearest edge; fill: outlet
        height above the basin bottom)
    note : a human description, e.g. ``"dining chair 2 seat"``
    """

    kind: str
    point: tuple
    facing: tuple
    width: float
    note: str


@dataclass
class Piece:
    """One piece of furniture: its closed primitives (scene coordinates) and its sites.

    ``wall_mounted`` pieces hang on a wall instead of standing on ``z = 0``.
    """

    name: str
    meshes: list
    sites: list
    wall_mounted: bool = False

    def geometry(self) -> Geometry:
        """All primitives as one mesh."""
        return shapes._geometry(self.meshes, f"procedural {self.name}")


# ------------------------------------------------------------------ building helpers
def _tm():
    import trimesh

    return trimesh


def cbox(lo, hi):
    """A closed box between corners ``lo`` and ``hi`` (3,), metres."""
    a, b = np.asarray(lo, float), np.asarray(hi, float)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    return box((lo + hi) / 2, hi - lo)


def cylinder_z(x, y, z0, z1, radius, sections=32):
    """A closed vertical cylinder (flat ends) from ``z0`` to ``z1`` about (x, y)."""
    return rod((x, y, z0), (x, y, z1), radius, sections=sections, caps=False)


def split_geometry(g: Geometry) -> list:
    """The closed primitives (connected components) of a concatenated mesh."""
    m = _tm().Trimesh(g.vertices, g.faces, process=False)
    return list(m.split(only_watertight=False))


def part_meshes(parts) -> list:
    """Closed box meshes of :class:`~.procedural.Part` boxes."""
    return [cbox(p.lo, p.hi) for p in parts]


class _Kit:
    """Collects primitives and sites in a piece's own frame, then places them."""

    def __init__(self):
        self.meshes, self.sites = [], []

    def add(self, *items):
        for m in items:
            if isinstance(m, Geometry):
                self.meshes.extend(split_geometry(m))
            elif isinstance(m, (list, tuple)):
                self.add(*m)
            else:
                self.meshes.append(m)

    def box(self, lo, hi):
        self.meshes.append(cbox(lo, hi))

    def site(self, kind, point, facing, width, note):
        assert kind in KINDS, kind
        self.sites.append((kind, np.asarray(point, float), np.asarray(facing, float),
                           float(width), note))

    def piece(self, name, xy, angle, wall_mounted=False) -> Piece:
        a = math.radians(angle)
        c, s = math.cos(a), math.sin(a)
        t = np.eye(4)
        t[:2, :2] = [[c, -s], [s, c]]
        t[:2, 3] = xy
        meshes = []
        for m in self.meshes:
            m = m.copy()
            m.apply_transform(t)
            meshes.append(m)
        sites = []
        for kind, p, f, w, note in self.sites:
            q = t[:3, :3] @ p + t[:3, 3]
            g = t[:2, :2] @ (f / np.linalg.norm(f)) if kind != "place" else np.array([1.0, 0])
            g = g / np.linalg.norm(g)
            sites.append(Site(kind, tuple(round(float(v), 12) for v in q),
                              tuple(round(float(v), 12) + 0.0 for v in g), w, note))
        return Piece(name, meshes, sites, wall_mounted)


def _even(lo: float, hi: float, spacing: float) -> list:
    """Evenly spaced positions from ``lo`` to ``hi`` about ``spacing`` apart (at least one,
    the middle)."""
    if hi - lo < 1e-9:
        return [(lo + hi) / 2]
    n = int((hi - lo) / spacing + 1e-9) + 1
    return list(np.linspace(lo, hi, n)) if n > 1 else [(lo + hi) / 2]


def _rect_edge_distance(p, lo, hi) -> float:
    """Distance from ``p`` (2,) inside the rectangle [lo, hi] to its nearest edge."""
    return float(min(p[0] - lo[0], hi[0] - p[0], p[1] - lo[1], hi[1] - p[1]))


def _place_grid(kit, lo, hi, z, note, spacing=0.45, margin=0.15, holes=()):
    """Place sites on the rectangle [lo, hi] (x-y) at height ``z``: a grid ``spacing`` apart
    at least ``margin`` from the edges and from the ``holes`` (rectangles, also edges)."""
    xs = _even(lo[0] + margin, hi[0] - margin, spacing) if hi[0] - lo[0] >= 2 * margin else []
    ys = _even(lo[1] + margin, hi[1] - margin, spacing) if hi[1] - lo[1] >= 2 * margin else []
    k = 0
    for x in xs:
        for y in ys:
            p = np.array([x, y])
            w = _rect_edge_distance(p, lo, hi)
            for hlo, hhi in holes:
                dx = max(hlo[0] - x, 0.0, x - hhi[0])
                dy = max(hlo[1] - y, 0.0, y - hhi[1])
                w = min(w, math.hypot(dx, dy))
            if w < margin - 1e-9:
                continue
            k += 1
            kit.site("place", (x, y, z), (1, 0), w, f"{note} {k}")


# ------------------------------------------------------------------ seats
def dining_chair(xy, angle=0.0, seat_height=0.46, seat_depth=0.42, seat_width=0.44,
                 back_top=None, rail=0.025, rail_height=0.05, name="dining chair") -> Piece:
    """A wooden dining chair: a 4 cm seat slab (``seat_depth`` x ``seat_width``, top at
    ``seat_height``, default 0.46 m) on four 3.5 cm legs, the rear legs rising into back posts
    joined by an open ladder-back top rail (``rail`` thick, ``rail_height`` tall, top at ``back_top``,
    default seat + 0.48 m). Sites: the seat (facing front) and a hang site on the top rail
    (free below down to the seat)."""
    sh, d, w, leg = seat_height, seat_depth, seat_width, 0.035
    bt = sh + 0.48 if back_top is None else back_top
    k = _Kit()
    k.box((-d / 2, -w / 2, sh - 0.04), (d / 2, w / 2, sh))
    for sy in (-1, 1):
        y0 = sy * (w / 2 - leg / 2)
        k.box((d / 2 - leg, y0 - leg / 2, 0), (d / 2, y0 + leg / 2, sh - 0.04))        # front
        k.box((-d / 2, y0 - leg / 2, 0), (-d / 2 + leg, y0 + leg / 2, bt - 0.02))     # back
        k.box((-d / 2 + leg, y0 - 0.01, 0.15), (d / 2 - leg, y0 + 0.01, 0.18))      # stretcher
    front = -d / 2 + leg                      # front face of the back posts and the rail
    k.box((front - rail, -w / 2, bt - rail_height), (front, w / 2, bt))
    k.site("seat", (0, 0, sh), (1, 0), -front, f"{name} seat")
    k.site("hang", (front - rail / 2, 0, bt), (0, 1), rail, f"{name} back top rail")
    return k.piece(name, xy, angle)


def _upholstered(k, length, depth, seat_height, arm_height, arm_width, back_top, back,
                 places, place_width, rounded, arm_sites, name):
    """Sofa-like body in the kit: feet, base, back, arms, one cushion per place."""
    D, sh, aw, ah = depth, seat_height, arm_width, arm_height
    L = length
    inner = places * place_width / 2              # half the length between the arms
    for sx in (-1, 1):
        for sy in (-1, 1):
            x0, y0 = sx * (D / 2 - 0.06), sy * (L / 2 - 0.06)
            k.box((x0 - 0.025, y0 - 0.025, 0), (x0 + 0.025, y0 + 0.025, 0.07))
    k.box((-D / 2, -inner, 0.07), (D / 2, inner, sh - 0.13))                      # base
    k.box((-D / 2, -inner, 0.07), (-D / 2 + back, inner, back_top))                 # back
    front = -D / 2 + back
    for i in range(places):
        y0 = -inner + i * place_width
        k.box((front, y0 + 0.005, sh - 0.13), (D / 2, y0 + place_width - 0.005, sh))
    for sy, free in ((-1, arm_sites[0]), (1, arm_sites[1])):
        yc = sy * (inner + aw / 2)
        top = ah - aw / 2 if rounded else ah
        k.box((-D / 2, yc - aw / 2, 0.07), (D / 2, yc + aw / 2, top))
        if rounded:
            k.add(rod((-D / 2, yc, ah - aw / 2), (D / 2, yc, ah - aw / 2), aw / 2, sections=32,
                      caps=False))
        if free:
            side = "left" if sy > 0 else "right"
            k.site("astride", ((front + D / 2) / 2, yc, ah), (1, 0), aw, f"{name} {side} arm")
    return front


def armchair(xy, angle=0.0, seat_height=0.41, width=0.86, depth=0.84, arm_height=0.62,
             arm_width=0.17, back_top=0.84, back=0.18, rounded=False, arm_sites=(True, True),
             name="armchair") -> Piece:
    """An upholstered armchair ``width`` x ``depth`` (0.86 x 0.84 m): cushion top at
    ``seat_height`` (0.41 m), arms ``arm_width`` wide with tops at ``arm_height`` (0.62 m),
    back 0.18 m thick up to ``back_top``, on four short feet. Sites: the seat, and the arms as
    astride sites where ``arm_sites`` (right, left) says their outer side is free."""
    k = _Kit()
    inner = width - 2 * arm_width
    front = _upholstered(k, width, depth, seat_height, arm_height, arm_width, back_top, back,
                         1, inner, rounded, arm_sites, name)
    k.site("seat", ((front + depth / 2) / 2, 0, seat_height), (1, 0), (depth / 2 - front) / 2,
           f"{name} seat")
    return k.piece(name, xy, angle)


def sofa(xy, angle=0.0, places=3, place_width=0.6, depth=0.92, seat_height=0.43,
         arm_height=0.62, arm_width=0.2, back_top=0.86, back=0.22, rounded=False,
         arm_sites=(True, True), name="sofa") -> Piece:
    """A sofa with ``places`` seat cushions ``place_width`` wide (3 x 0.6 m), ``depth`` deep
    (0.92 m), cushion tops at ``seat_height`` (0.43 m), a back ``back`` thick up to
    ``back_top`` and two arms ``arm_width`` wide (0.2 m) with tops at ``arm_height`` (0.62 m),
    square or ``rounded`` (a roll on top). Sites: one seat per place (centred on the cushion
    in depth), the arms as astride sites where ``arm_sites`` (right, left)."""
    k = _Kit()
    length = places * place_width + 2 * arm_width
    front = _upholstered(k, length, depth, seat_height, arm_height, arm_width, back_top, back,
                         places, place_width, rounded, arm_sites, name)
    for i in range(places):
        y = -places * place_width / 2 + (i + 0.5) * place_width
        k.site("seat", ((front + depth / 2) / 2, y, seat_height), (1, 0),
               (depth / 2 - front) / 2, f"{name} place {i + 1}")
    return k.piece(name, xy, angle)


def office_chair(xy, angle=0.0, seat_height=0.48, seat="round", seat_size=0.46,
                 back_height=0.52, arms=False, base_radius=0.32, name="office chair") -> Piece:
    """A swivel office chair: a 5-star base (``base_radius``, casters on the floor), a gas
    column, a 7 cm ``round`` or ``square`` seat cushion (``seat_size`` across, top at
    ``seat_height``, 0.48 m), a backrest panel 5 cm thick up to ``back_height`` above the seat
    on a bent bar, optional armrests. Sites: the seat."""
    sh, r = seat_height, seat_size / 2
    k = _Kit()
    for i in range(5):
        a = 2 * math.pi * i / 5 + math.pi / 10
        c, s = math.cos(a), math.sin(a)
        k.add(rod((0.03 * c, 0.03 * s, 0.1), (base_radius * c, base_radius * s, 0.065), 0.02,
                  sections=12),
              cylinder_z(base_radius * c, base_radius * s, 0.0, 0.05, 0.025, sections=16))
    k.add(cylinder_z(0, 0, 0.07, 0.12, 0.045), cylinder_z(0, 0, 0.1, 0.32, 0.028),
          cylinder_z(0, 0, 0.3, sh - 0.08, 0.02))
    k.box((-0.12, -0.1, sh - 0.1), (0.1, 0.1, sh - 0.07))
    if seat == "round":
        k.add(cylinder_z(0, 0, sh - 0.07, sh, r, sections=40))
    else:
        k.box((-r, -r, sh - 0.07), (r, r, sh))
    front = -r + 0.03                          # backrest front face, over the seat's rear
    k.box((front - 0.05, -0.22, sh + 0.1), (front, 0.22, sh + back_height))
    bx = front - 0.06
    k.add(polyline([(-0.08, 0, sh - 0.09), (bx, 0, sh - 0.09), (bx, 0, sh + 0.3)], 0.014))
    if arms:
        for sy in (-1, 1):
            y = sy * (r + 0.03)
            k.add(polyline([(-0.05, sy * 0.09, sh - 0.09), (-0.05, y, sh - 0.09),
                            (-0.05, y, sh + 0.2)], 0.012))
            k.box((-0.2, y - 0.03, sh + 0.2), (0.12, y + 0.03, sh + 0.23))
    k.site("seat", (0, 0, sh), (1, 0), -front, f"{name} seat")
    return k.piece(name, xy, angle)


def stool(xy, angle=0.0, seat_height=0.47, size_xy=(0.36, 0.36), name="stool") -> Piece:
    """A four-legged upholstered stool (:func:`shapes.stool`): seat ``size_xy`` (0.36 m
    square), top at ``seat_height`` (0.47 m). Sites: the seat, no backrest."""
    k = _Kit()
    try:
        k.add(shapes.stool(seat_height, size_xy=size_xy))
    except TypeError:                         # a shapes.stool with square seats only
        k.add(shapes.stool(seat_height, size=max(size_xy)))
    k.site("seat", (0, 0, seat_height), (1, 0), INF, f"{name} seat")
    return k.piece(name, xy, angle)


def bar_stool(xy, angle=0.0, seat_height=0.65, radius=0.18, ring_height=0.3,
              name="bar stool") -> Piece:
    """A bar (counter) stool: a round seat ``radius`` (0.18 m), 5 cm thick, top at
    ``seat_height`` (0.62-0.66 m), four splayed tube legs and a foot ring at
    ``ring_height``. Sites: the seat, no backrest."""
    sh = seat_height
    k = _Kit()
    k.add(cylinder_z(0, 0, sh - 0.05, sh, radius, sections=40))
    top_r, foot_r, z_top, z_foot = 0.11, 0.21, sh - 0.05, 0.015
    for i in range(4):
        a = math.pi / 4 + i * math.pi / 2
        c, s = math.cos(a), math.sin(a)
        k.add(rod((top_r * c, top_r * s, z_top), (foot_r * c, foot_r * s, z_foot), 0.015,
                  sections=12, caps=False),
              cylinder_z(foot_r * c, foot_r * s, 0.0, 0.025, 0.019, sections=12))
    t = (z_top - ring_height) / (z_top - z_foot)
    ring = _tm().creation.torus(top_r + (foot_r - top_r) * t, 0.01, major_sections=48,
                                minor_sections=10)
    ring.apply_translation((0, 0, ring_height))
    k.add(ring)
    k.site("seat", (0, 0, sh), (1, 0), INF, f"{name} seat")
    return k.piece(name, xy, angle)


def bench(xy, angle=0.0, length=1.4, depth=0.35, height=0.45, name="bench") -> Piece:
    """A flat wooden bench ``length`` (1.4 m) along its own y, ``depth`` (0.35 m), 4 cm top
    at ``height`` (0.45 m) on two end trestles. Sites: a seat per 0.6 m place facing +x
    (no backrest) and a place site in the middle of the top."""
    L, D, h = length, depth, height
    k = _Kit()
    k.box((-D / 2, -L / 2, h - 0.04), (D / 2, L / 2, h))
    for sy in (-1, 1):
        y0 = sy * (L / 2 - 0.1)
        k.box((-D / 2 + 0.02, y0 - 0.02, 0), (D / 2 - 0.02, y0 + 0.02, h - 0.04))
    k.box((-0.02, -L / 2 + 0.1, 0.12), (0.02, L / 2 - 0.1, 0.17))                   # stretcher
    n = max(1, int(L // 0.6))
    for i in range(n):
        y = -L / 2 + (i + 0.5) * L / n
        k.site("seat", (0, y, h), (1, 0), INF, f"{name} place {i + 1}")
    k.site("place", (0, 0, h), (1, 0), D / 2, f"{name} top")
    return k.piece(name, xy, angle)


def gym_bench(xy, angle=0.0, length=1.2, width=0.25, height=0.45, name="gym bench") -> Piece:
    """A narrow padded gym bench: an 8 cm pad ``width`` (0.25 m) x ``length`` (1.2 m) along
    its own y, top at ``height`` (0.45 m), on a steel frame: a central floor rail and two
    uprights with foot bars near the ends. Sites per 0.6 m: astride (facing along the bench)
    and seat (facing +x, no backrest) at the same points."""
    L, W, h = length, width, height
    k = _Kit()
    k.box((-W / 2, -L / 2, h - 0.08), (W / 2, L / 2, h))
    k.box((-0.03, -L / 2 + 0.05, h - 0.11), (0.03, L / 2 - 0.05, h - 0.08))
    for sy in (-1, 1):
        y0 = sy * (L / 2 - 0.05)
        k.box((-0.025, y0 - 0.025, 0.04), (0.025, y0 + 0.025, h - 0.08))
        k.box((-0.17, y0 - 0.03, 0), (0.17, y0 + 0.03, 0.04))
    k.box((-0.025, -L / 2 + 0.05, 0), (0.025, L / 2 - 0.05, 0.04))
    n = max(1, int(L // 0.6))
    for i in range(n):
        y = -L / 2 + (i + 0.5) * L / n
        k.site("astride", (0, y, h), (0, 1), W, f"{name} astride {i + 1}")
        k.site("seat", (0, y, h), (1, 0), INF, f"{name} seat {i + 1}")
    return k.piece(name, xy, angle)


def bed(xy, angle=0.0, length=2.0, width=1.4, mattress_top=0.5, seat_sides=(True, True),
        name="bed") -> Piece:
    """A bed ``length`` x ``width`` (2.0 x 1.4 m; head at -x): frame on legs, a mattress
    with its top at ``mattress_top`` (0.45-0.55 m), a headboard up to 1.0 m and two pillows.
    Sites: seats on the mattress 0.2 m in from each long edge where ``seat_sides``
    (right -y, left +y), facing out, no backrest."""
    L, W, mt = length, width, mattress_top
    k = _Kit()
    for sx in (-1, 1):
        for sy in (-1, 1):
            x0, y0 = sx * (L / 2 - 0.05), sy * (W / 2 - 0.05)
            k.box((x0 - 0.04, y0 - 0.04, 0), (x0 + 0.04, y0 + 0.04, 0.12))
    k.box((-L / 2, -W / 2, 0.12), (L / 2, W / 2, 0.3))
    k.box((-L / 2 + 0.02, -W / 2 + 0.02, 0.3), (L / 2 - 0.02, W / 2 - 0.02, mt))
    k.box((-L / 2 - 0.06, -W / 2 - 0.02, 0), (-L / 2, W / 2 + 0.02, 1.0))
    for sy in (-1, 1):
        k.box((-L / 2 + 0.06, sy * 0.04, mt), (-L / 2 + 0.42, sy * (W / 2 - 0.06), mt + 0.12))
    for sy, free in ((-1, seat_sides[0]), (1, seat_sides[1])):
        if not free:
            continue
        for i, x in enumerate((-0.2 * L / 2, 0.45 * L / 2)):
            k.site("seat", (x, sy * (W / 2 - 0.2), mt), (0, sy), INF,
                   f"{name} {'left' if sy > 0 else 'right'} edge {i + 1}")
    return k.piece(name, xy, angle)


# ------------------------------------------------------------------ tables and surfaces
def dining_table(xy, angle=0.0, size=(1.6, 0.9), height=0.74, name="dining table") -> Piece:
    """A four-legged table (:func:`procedural.table`): ``size`` (1.6 x 0.9 m), top at
    ``height`` (0.74 m). Sites: place sites on the top, 0.45 m apart, >= 0.15 m from edges."""
    k = _Kit()
    k.add(part_meshes(procedural.table(name, (0, 0), size, height, top=0.035, leg=0.055)))
    w, d = size
    _place_grid(k, (-w / 2, -d / 2), (w / 2, d / 2), height, f"{name} top",
                spacing=max(0.45, w / 2 - 0.2))
    return k.piece(name, xy, angle)


def coffee_table(xy, angle=0.0, size=(1.1, 0.55), height=0.42, lower_shelf=0.14,
                 name="coffee table") -> Piece:
    """A low table ``size`` (1.1 x 0.55 m), top at ``height`` (0.42 m), with a lower shelf at
    ``lower_shelf`` (0.14 m: less than 0.3 m free above it, so no site there). Sites: place
    sites on the top."""
    k = _Kit()
    k.add(part_meshes(procedural.table(name, (0, 0), size, height, top=0.03, leg=0.045,
                                       lower_shelf=lower_shelf)))
    w, d = size
    _place_grid(k, (-w / 2, -d / 2), (w / 2, d / 2), height, f"{name} top", spacing=0.5)
    return k.piece(name, xy, angle)


def side_table(xy, angle=0.0, size=(0.45, 0.45), height=0.56, name="side table") -> Piece:
    """A small four-legged side table ``size`` (0.45 m square), top at ``height`` (0.56 m).
    Sites: one place site in the middle of the top."""
    k = _Kit()
    k.add(part_meshes(procedural.table(name, (0, 0), size, height, top=0.025, leg=0.035)))
    k.site("place", (0, 0, height), (1, 0), min(size) / 2, f"{name} top")
    return k.piece(name, xy, angle)


def desk(xy, angle=0.0, size=(1.4, 0.7), height=0.74, monitor=True, pedestal=True,
         name="desk") -> Piece:
    """An office desk: a 3 cm top ``size`` (1.4 m along its own y, 0.7 m deep along x, back
    edge at -x), top at ``height`` (0.74 m), a side panel on the left, a drawer pedestal on
    the right (or a second panel), a modesty panel at the back and optionally a monitor at the
    back middle. Sites: place sites at the front corners (clear of the monitor)."""
    L, D, h = size[0], size[1], height
    k = _Kit()
    k.box((-D / 2, -L / 2, h - 0.03), (D / 2, L / 2, h))
    k.box((-D / 2 + 0.02, L / 2 - 0.045, 0), (D / 2 - 0.02, L / 2 - 0.02, h - 0.03))
    if pedestal:
        k.box((-D / 2 + 0.05, -L / 2 + 0.02, 0), (D / 2 - 0.03, -L / 2 + 0.44, h - 0.03))
        for z in (0.25, 0.45, 0.62):                          # drawer handles
            k.box((D / 2 - 0.03, -L / 2 + 0.17, z - 0.008), (D / 2 - 0.01, -L / 2 + 0.29, z))
    else:
        k.box((-D / 2 + 0.02, -L / 2 + 0.02, 0), (D / 2 - 0.02, -L / 2 + 0.045, h - 0.03))
    k.box((-D / 2 + 0.03, -L / 2 + 0.045, 0.3), (-D / 2 + 0.05, L / 2 - 0.045, h - 0.03))
    if monitor:
        x0 = -D / 2 + 0.15
        k.box((x0 - 0.09, -0.12, h), (x0 + 0.09, 0.12, h + 0.015))
        k.box((x0 - 0.03, -0.025, h + 0.015), (x0 - 0.01, 0.025, h + 0.25))
        k.box((x0 - 0.01, -0.3, h + 0.1), (x0 + 0.02, 0.3, h + 0.45))
    for i, sy in enumerate((-1, 1)):
        k.site("place", (D / 2 - 0.2, sy * (L / 2 - 0.22), h), (1, 0), 0.2,
               f"{name} top {'left' if sy > 0 else 'right'}")
    return k.piece(name, xy, angle)


def workbench(xy, angle=0.0, size=(1.6, 0.7), height=0.9, lower_shelf=0.22, vice=True,
              name="workbench") -> Piece:
    """A heavy workbench: 5 cm top ``size`` (1.6 m along its own y, 0.7 m deep), top at
    ``height`` (0.9 m), four legs, a lower shelf at ``lower_shelf`` and a vice on the front
    right corner. Sites: place sites on the top (clear of the vice) and one on the shelf."""
    L, D, h = size[0], size[1], height
    k = _Kit()
    k.add(part_meshes(procedural.table(name, (0, 0), (D, L), h, top=0.05, leg=0.07,
                                       lower_shelf=lower_shelf)))
    if vice:
        y0 = -L / 2 + 0.2
        k.box((D / 2 - 0.2, y0 - 0.08, h), (D / 2 + 0.02, y0 + 0.08, h + 0.12))
        k.add(rod((D / 2 + 0.02, y0, h + 0.06), (D / 2 + 0.15, y0, h + 0.06), 0.012))
    for i, y in enumerate((-0.1, L / 2 - 0.3)):
        k.site("place", (0.0, y, h), (1, 0), min(D / 2, L / 2 - abs(y)), f"{name} top {i + 1}")
    k.site("place", (0.0, 0.0, lower_shelf), (1, 0), D / 2 - 0.07, f"{name} lower shelf")
    return k.piece(name, xy, angle)


def wall_shelves(xy, angle=0.0, boards=(1.1, 1.5), length=0.9, depth=0.26, board=0.025,
                 name="wall shelves") -> Piece:
    """Wall shelf boards (``length`` 0.9 m along the wall, ``depth`` 0.26 m) with top
    surfaces at ``boards`` (m), each on two steel brackets. Wall-mounted: the origin is on the
    wall face, boards towards +x. Sites: two place sites on each board with at least 0.32 m
    free above it (a board closer under another one gets none)."""
    L, D = length, depth
    k = _Kit()
    zs = sorted(boards)
    for i, z in enumerate(zs):
        k.box((0.002, -L / 2, z - board), (D, L / 2, z))
        for sy in (-1, 1):
            y0 = sy * (L / 2 - 0.07)
            k.box((0.002, y0 - 0.008, z - board - 0.16), (0.012, y0 + 0.008, z - board))
            k.box((0.012, y0 - 0.008, z - board - 0.025), (D - 0.04, y0 + 0.008, z - board))
        above = zs[i + 1] - board - z if i + 1 < len(zs) else INF
        if above >= 0.32:
            for j, y in enumerate((-L / 4, L / 4)):
                k.site("place", (D / 2, y, z), (1, 0), min(D / 2, L / 2 - abs(y)),
                       f"{name} board {i + 1} place {j + 1}")
    return k.piece(name, xy, angle, wall_mounted=True)


def bookcase(xy, angle=0.0, width=0.8, depth=0.3, boards=(0.06, 0.42, 0.78, 1.14, 1.5, 1.86),
             name="bookcase") -> Piece:
    """A bookcase (:func:`procedural.bookcase`) ``width`` x ``depth`` (0.8 x 0.3 m), 2 cm side
    panels up to the top board, boards with tops at ``boards`` and a 1 cm back panel; its
    back at x = 0 (against a wall). Sites: a place site in the middle of each board with at
    least 0.32 m free above (the top board is flush with the side panels, so no hang site)."""
    k = _Kit()
    parts = procedural.bookcase(name, (0, 0), (width, depth), list(boards))
    for m in part_meshes(parts):              # its width is along x: turn it to our y
        m.apply_transform(_tm().transformations.rotation_matrix(math.pi / 2, (0, 0, 1)))
        m.apply_translation((depth / 2 + 0.012, 0, 0))
        k.add(m)
    k.box((0.002, -width / 2, 0), (0.012, width / 2, max(boards)))
    _board_sites(k, boards, 0.012 + depth / 2, depth / 2, width / 2 - 0.02, name)
    return k.piece(name, xy, angle, wall_mounted=False)


def _board_sites(k, boards, x, half_depth, half_width, name):
    zs = sorted(boards)
    for i, z in enumerate(zs):
        above = zs[i + 1] - 0.02 - z if i + 1 < len(zs) else INF
        if above >= 0.32:
            k.site("place", (x, 0, z), (1, 0), min(half_depth, half_width),
                   f"{name} board {i + 1}")


def shelf_unit(xy, angle=0.0, width=0.8, depth=0.32, boards=(0.06, 0.42, 0.78, 1.14),
               side_height=1.66, side=0.02, hang_sides=(True, True),
               name="shelf unit") -> Piece:
    """An open shelf unit (a room divider, no back): 2 cm side panels ``side_height`` tall
    (1.66 m) rising well above the top board, boards with tops at ``boards``. The side panel
    tops are thin supports a hanger can go over. Sites: a place site on each board with room
    above, and hang sites on the side panel tops where ``hang_sides`` (right, left)."""
    W, D = width, depth
    k = _Kit()
    for sy in (-1, 1):
        k.box((-D / 2, sy * W / 2 - side / 2, 0), (D / 2, sy * W / 2 + side / 2, side_height))
    for z in boards:
        k.box((-D / 2, -W / 2 + side / 2, z - 0.02), (D / 2, W / 2 - side / 2, z))
    k.box((-D / 2, -W / 2 + side / 2, 0.0), (-D / 2 + 0.02, W / 2 - side / 2, 0.06))
    _board_sites(k, boards, 0.0, D / 2, (W - side) / 2, name)
    for sy, free in ((-1, hang_sides[0]), (1, hang_sides[1])):
        if free:
            k.site("hang", (0, sy * W / 2, side_height), (1, 0), side,
                   f"{name} {'left' if sy > 0 else 'right'} side panel top")
    return k.piece(name, xy, angle)


# ------------------------------------------------------------------ sinks and taps
def _basin(k, x0, x1, y0, y1, top, bottom, wall=0.01):
    """A basin filling the opening [x0, x1] x [y0, y1]: 2 cm bottom with its top surface at
    ``bottom`` and four walls up to ``top``."""
    k.box((x0, y0, bottom - 0.02), (x1, y1, bottom))
    k.box((x0, y0, bottom - 0.02), (x0 + wall, y1, top))
    k.box((x1 - wall, y0, bottom - 0.02), (x1, y1, top))
    k.box((x0, y0, bottom - 0.02), (x1, y0 + wall, top))
    k.box((x0, y1 - wall, bottom - 0.02), (x1, y1, top))


def _tap(k, kind, column_xy, outlet_x, base_z, outlet_z):
    """A tap on a deck at ``base_z``: a column at ``column_xy`` and a spout reaching forward
    (+x) to an outlet at x = ``outlet_x`` whose flat, downward opening is at ``outlet_z``.
    ``kind``: ``gooseneck`` (a tall arc) or ``straight`` (a horizontal spout)."""
    cx, cy = column_xy
    reach = outlet_x - cx
    k.add(cylinder_z(cx, cy, base_z, base_z + 0.015, 0.028))
    if kind == "gooseneck":
        rho = reach / 2
        z_arc = outlet_z + 0.16
        k.add(rod((cx, cy, base_z), (cx, cy, z_arc), 0.016, caps=False))
        phi = np.linspace(math.pi, 0.0, 13)
        arc = np.c_[cx + rho + rho * np.cos(phi), np.full_like(phi, cy), z_arc + rho * np.sin(phi)]
        k.add(polyline(np.vstack([arc, [[outlet_x, cy, outlet_z + 0.035]]]), 0.012))
        k.add(rod((cx, cy + 0.01, base_z + 0.12), (cx, cy + 0.09, base_z + 0.15), 0.007))
    elif kind == "straight":
        z_s = outlet_z + 0.045
        k.add(rod((cx, cy, base_z), (cx, cy, z_s + 0.03), 0.017))
        k.add(rod((cx, cy, z_s), (outlet_x, cy, z_s - 0.01), 0.012))
        k.add(rod((cx, cy + 0.01, z_s + 0.04), (cx, cy + 0.08, z_s + 0.06), 0.007))
    else:
        raise ValueError(f"unknown tap kind {kind!r}")
    k.add(rod((outlet_x, cy, outlet_z + 0.045), (outlet_x, cy, outlet_z), 0.014, caps=False))


@dataclass(frozen=True)
class SinkSpec:
    """A sink in a counter: its centre along the counter (``y``), opening ``size``
    (depth across x, width along y), basin ``depth`` below the worktop, the tap ``kind`` and
    the outlet height above the worktop."""

    y: float = 0.0
    size: tuple = (0.40, 0.50)
    depth: float = 0.17
    tap: str = "gooseneck"
    outlet_above: float = 0.16


def kitchen_counter(xy, angle=0.0, length=2.4, depth=0.62, height=0.9, sinks=(SinkSpec(),),
                    wall_cabinet=None, back_overhang=0.0, name="kitchen counter") -> Piece:
    """A run of base cabinets with a 4 cm worktop at ``height`` (0.9 m), ``length`` along its
    own y (2.4 m), ``depth`` (0.62 m) from its back edge at x = 0, with inset sinks
    (:class:`SinkSpec`: a basin in a worktop opening and a tap behind it) and optionally wall
    cabinets 0.35 m deep, 0.7 m tall, 0.5 m above the worktop over ``wall_cabinet`` = (y0, y1)
    (keep them away from the sinks). ``back_overhang`` extends the worktop behind the cabinets
    (an island with stools on its back side). Sites: a fill site under each tap outlet and
    place sites on the worktop away from the sinks and taps."""
    L, D, H, t = length, depth, height, 0.04
    k = _Kit()
    xb = 0.002 - back_overhang                     # back edge of the worktop
    holes = []
    for s in sinks:
        sx, sy = s.size
        xc = 0.002 + (D - 0.002) / 2 + 0.02
        holes.append(((xc - sx / 2, s.y - sy / 2), (xc + sx / 2, s.y + sy / 2), s))
    holes.sort(key=lambda h: h[0][1])
    # worktop: full-depth strips between holes, back and front strips beside each hole
    y = -L / 2
    for (hx0, hy0), (hx1, hy1), _ in holes:
        k.box((xb, y, H - t), (D, hy0, H))
        k.box((xb, hy0, H - t), (hx0, hy1, H))
        k.box((hx1, hy0, H - t), (D, hy1, H))
        y = hy1
    k.box((xb, y, H - t), (D, L / 2, H))
    # cabinets: plinth, carcasses (lower under the basins), door fronts
    k.box((0.002, -L / 2, 0), (D - 0.09, L / 2, 0.1))
    y = -L / 2
    for (hx0, hy0), (hx1, hy1), s in holes:
        k.box((0.002, y, 0.1), (D - 0.03, hy0 - 0.01, H - t))
        k.box((0.002, hy0 - 0.01, 0.1), (D - 0.03, hy1 + 0.01, H - s.depth - 0.03))
        y = hy1 + 0.01
    k.box((0.002, y, 0.1), (D - 0.03, L / 2, H - t))
    n_doors = max(1, int(round(L / 0.6)))
    for i in range(n_doors):                                  # door handles
        y0 = -L / 2 + (i + 0.5) * L / n_doors
        k.box((D - 0.03, y0 - 0.06, H - t - 0.08), (D - 0.01, y0 + 0.06, H - t - 0.065))
    taps = []
    for i, ((hx0, hy0), (hx1, hy1), s) in enumerate(holes):
        bottom = H - s.depth
        _basin(k, hx0, hx1, hy0, hy1, H, bottom)
        col = (hx0 - 0.045, (hy0 + hy1) / 2)
        outlet_x = (hx0 + hx1) / 2 - 0.03
        oz = H + s.outlet_above
        _tap(k, s.tap, col, outlet_x, H, oz)
        taps.append(col)
        k.site("fill", (outlet_x, col[1], bottom), (1, 0), oz - bottom,
               f"{name} sink {i + 1} ({s.tap} tap)")
    if wall_cabinet is not None:
        y0, y1 = wall_cabinet
        k.box((0.002, y0, H + 0.5), (0.35, y1, H + 1.2))
        k.box((0.35, y0 + 0.003, H + 0.503), (0.37, (y0 + y1) / 2 - 0.003, H + 1.197))
        k.box((0.35, (y0 + y1) / 2 + 0.003, H + 0.503), (0.37, y1 - 0.003, H + 1.197))
    # place sites along the middle of the worktop, clear of openings and taps
    hole_rects = [((hx0, hy0), (hx1, hy1)) for (hx0, hy0), (hx1, hy1), _ in holes]
    before = len(k.sites)
    _place_grid(k, (xb, -L / 2), (D, L / 2), H, f"{name} top", spacing=0.5, margin=0.15,
                holes=hole_rects)
    keep = k.sites[:before]
    for site in k.sites[before:]:
        p = site[1]
        if all(math.hypot(p[0] - cx, p[1] - cy) > 0.2 for cx, cy in taps):
            keep.append(site)
    k.sites = keep
    return k.piece(name, xy, angle)


def breakfast_bar(xy, angle=0.0, length=1.8, depth=0.6, height=1.0, overhang=0.32,
                  name="breakfast bar") -> Piece:
    """A breakfast bar: a 4 cm top ``length`` (1.8 m along its own y) x ``depth`` (0.6 m) at
    ``height`` (1.0 m) on a cabinet at its back (-x), overhanging ``overhang`` (0.32 m) at
    the front (+x) for the knees of people on bar stools. Sites: place sites on the top."""
    L, D, H = length, depth, height
    k = _Kit()
    k.box((-D / 2, -L / 2, H - 0.04), (D / 2, L / 2, H))
    k.box((-D / 2 + 0.02, -L / 2 + 0.02, 0), (D / 2 - overhang, L / 2 - 0.02, H - 0.04))
    _place_grid(k, (-D / 2, -L / 2), (D / 2, L / 2), H, f"{name} top", spacing=0.55)
    return k.piece(name, xy, angle)


def washbasin(xy, angle=0.0, top=0.85, width=0.56, depth=0.45, bowl=0.14, outlet_above=0.08,
              pedestal=False, tap="straight", name="washbasin") -> Piece:
    """A bathroom washbasin against a wall (origin on the wall face, front +x): a ceramic-like
    body ``width`` x ``depth`` (0.56 x 0.45 m), rim at ``top`` (0.85 m), a bowl ``bowl``
    deep (0.14 m) with a 12 cm deck at the back carrying a short tap whose outlet is
    ``outlet_above`` (8 cm) above the rim; wall-mounted, or on a ``pedestal``. Sites: a fill
    site under the outlet."""
    W, D, T = width, depth, top
    bb = T - bowl
    k = _Kit()
    k.box((0.12, -W / 2 + 0.025, bb - 0.03), (D - 0.025, W / 2 - 0.025, bb))
    k.box((D - 0.025, -W / 2, bb - 0.03), (D, W / 2, T))
    for sy in (-1, 1):
        k.box((0.002, sy * W / 2, bb - 0.03), (D, sy * (W / 2 - 0.025), T))
    k.box((0.002, -W / 2, bb - 0.03), (0.12, W / 2, T))
    k.add(cylinder_z(0.22, 0, bb - 0.035, bb, 0.03))                      # drain
    if pedestal:
        k.box((0.12, -0.1, 0), (0.3, 0.1, bb - 0.03))
    outlet_x = 0.23
    _tap(k, tap, (0.06, 0), outlet_x, T, T + outlet_above)
    k.site("fill", (outlet_x, 0, bb), (1, 0), outlet_above + bowl, f"{name} ({tap} tap)")
    return k.piece(name, xy, angle, wall_mounted=not pedestal)


def utility_sink(xy, angle=0.0, top=0.9, size=(0.5, 0.6), tub=0.24, outlet_above=0.07,
                 name="utility sink") -> Piece:
    """A free-standing utility tub on four legs: ``size`` (0.5 deep x 0.6 m wide), rim at
    ``top`` (0.9 m), ``tub`` deep (0.24 m), with a 10 cm deck at the back carrying a
    straight-spout tap. Sites: a fill site under the outlet."""
    (D, W), T = size, top
    bb = T - tub
    k = _Kit()
    _basin(k, 0.1, D, -W / 2, W / 2, T, bb, wall=0.015)
    k.box((0.002, -W / 2, T - 0.05), (0.1, W / 2, T))
    for x0 in (0.02, D - 0.04):
        for sy in (-1, 1):
            k.box((x0, sy * (W / 2 - 0.03) - 0.02, 0), (x0 + 0.04, sy * (W / 2 - 0.03) + 0.02,
                                                        bb - 0.02))
    outlet_x = 0.28
    _tap(k, "straight", (0.05, 0), outlet_x, T, T + outlet_above)
    k.site("fill", (outlet_x, 0, bb), (1, 0), outlet_above + tub, f"{name} (straight tap)")
    return k.piece(name, xy, angle)


# ------------------------------------------------------------------ hanging supports
def clothes_rail(xy, angle=0.0, height=1.5, length=1.0, radius=0.015, style="H",
                 name="clothes rail") -> Piece:
    """A free-standing clothes rail: a round bar of ``radius`` (10-20 mm) along its own y,
    ``length`` long (1.0 m), its axis at ``height`` (1.3-1.8 m). ``H`` style: two upright
    tubes on foot bars across; ``A`` style: two splayed A-frame legs at each end. Sites: hang
    sites along the bar every ~0.25 m, 0.12 m clear of the uprights."""
    L, h, r = length, height, radius
    k = _Kit()
    k.add(rod((0, -L / 2 - 0.03, h), (0, L / 2 + 0.03, h), r, sections=24, caps=False))
    for sy in (-1, 1):
        y = sy * (L / 2 + 0.03)
        if style == "H":
            k.add(rod((0, y, 0.04), (0, y, h + 0.02), 0.016, sections=16))
            k.box((-0.28, y - 0.025, 0), (0.28, y + 0.025, 0.04))
        elif style == "A":
            for sx in (-1, 1):
                k.add(rod((0, y, h), (sx * 0.32, y, 0.02), 0.015, sections=12, caps=False),
                      cylinder_z(sx * 0.32, y, 0.0, 0.025, 0.02, sections=12))
            k.add(rod((-0.2, y, 0.45), (0.2, y, 0.45), 0.01, sections=12))
        else:
            raise ValueError(f"unknown rail style {style!r}")
    for i, yy in enumerate(_even(-L / 2 + 0.12, L / 2 - 0.12, 0.25)):
        k.site("hang", (0, yy, h + r), (0, 1), 2 * r, f"{name} bar {i + 1}")
    return k.piece(name, xy, angle)


def coat_pegs(xy, angle=0.0, height=1.7, count=4, spacing=0.22, peg_length=0.1,
              peg_radius=0.011, knob=True, name="coat pegs") -> Piece:
    """A wall board (2 cm thick, 10 cm tall) with ``count`` horizontal pegs ``spacing`` apart
    at ``height`` (1.7 m), sticking ``peg_length`` (8-12 cm) out of the board, radius
    ``peg_radius``, with a knob at the tip. Wall-mounted: origin on the wall face. Sites: one
    hang site per peg on the top of the peg just inside the knob, facing along the peg (out of
    the wall): a hook goes over it as over a short rail, the hanger hanging along the wall."""
    k = _Kit()
    L = count * spacing
    k.box((0.002, -L / 2, height - 0.05), (0.022, L / 2, height + 0.05))
    for i in range(count):
        y = -L / 2 + (i + 0.5) * spacing
        tip = 0.022 + peg_length
        k.add(rod((0.012, y, height), (tip, y, height), peg_radius, sections=24, caps=False))
        if knob:
            k.add(ball((tip, y, height), peg_radius + 0.007))
            x = tip - peg_radius - 0.02
        else:
            k.add(ball((tip, y, height), peg_radius))
            x = tip - 0.015
        k.site("hang", (x, y, height + peg_radius), (1, 0), 2 * peg_radius, f"{name} peg {i + 1}")
    return k.piece(name, xy, angle, wall_mounted=True)


def door_in_partition(xy, angle=0.0, wall_length=1.2, opening=0.9, wall_height=2.4,
                      door=(0.8, 0.04, 2.0), name="door") -> Piece:
    """A partition wall (10 cm thick, ``wall_height`` tall) along its own +y from the origin,
    ``wall_length`` long, then a door opening ``opening`` wide under a lintel (2.1 m) and a
    closing post. A ``door`` panel (0.8 x 0.04 x 2.0 m, 1 cm above the floor) hangs on three
    hinges on the opening's first jamb, open at 90 degrees towards +x, so that its top edge is
    free. Sites: hang sites on the door's top edge 0.3 m and 0.55 m from the hinge."""
    wl, op, wh = wall_length, opening, wall_height
    dw, dt, dh = door
    k = _Kit()
    k.box((-0.05, 0, 0), (0.05, wl, wh))
    k.box((-0.05, wl, 2.1), (0.05, wl + op, wh))
    k.box((-0.05, wl + op, 0), (0.05, wl + op + 0.1, wh))
    for y0, y1 in ((wl, wl + 0.02), (wl + op - 0.02, wl + op)):
        k.box((-0.06, y0, 0), (0.06, y1, 2.1))
    k.box((-0.06, wl, 2.08), (0.06, wl + op, 2.1))
    y0 = wl + 0.025
    k.box((0.055, y0, 0.01), (0.055 + dw, y0 + dt, 0.01 + dh))
    for z in (0.25, 1.0, 1.75):
        k.add(cylinder_z(0.05, y0 - 0.004, z - 0.05, z + 0.05, 0.008, sections=12))
    xh = 0.055 + dw - 0.07
    k.add(rod((xh, y0 - 0.06, 1.0), (xh, y0 + dt + 0.06, 1.0), 0.009, sections=12))
    for sy in (-1, 1):
        yy = y0 - 0.06 if sy < 0 else y0 + dt + 0.06
        k.add(rod((xh, yy, 1.0), (xh - 0.12, yy, 1.0), 0.009, sections=12))
    top = 0.01 + dh
    for i, x in enumerate((0.3, 0.55)):
        k.site("hang", (0.055 + x, y0 + dt / 2, top), (1, 0), dt, f"{name} top edge {i + 1}")
    return k.piece(name, xy, angle)


def free_panel(xy, angle=0.0, length=1.2, height=1.45, thickness=0.025,
               name="free-standing panel") -> Piece:
    """A free-standing screen panel (an office divider) ``length`` (1.2 m) along its own y,
    ``thickness`` (2.5 cm), its top edge at ``height`` (1.45 m), on two foot bars 0.44 m
    long across. Sites: hang sites along the top edge every ~0.3 m, 0.15 m from the ends."""
    L, h, t = length, height, thickness
    k = _Kit()
    k.box((-t / 2, -L / 2, 0.05), (t / 2, L / 2, h))
    for sy in (-1, 1):
        y0 = sy * (L / 2 - 0.12)
        k.box((-0.22, y0 - 0.025, 0), (0.22, y0 + 0.025, 0.05))
    for i, y in enumerate(_even(-L / 2 + 0.15, L / 2 - 0.15, 0.3)):
        k.site("hang", (0, y, h), (0, 1), t, f"{name} top edge {i + 1}")
    return k.piece(name, xy, angle)


# ------------------------------------------------------------------ astride supports
def vaulting_horse(xy, angle=0.0, length=1.5, width=0.28, height=0.75,
                   name="vaulting horse") -> Piece:
    """A saddle (vaulting) horse: a padded body ``width`` (0.28 m) x ``length`` (1.5 m) along
    its own y with a rounded top at ``height`` (0.75 m), on four upright legs with floor pads
    near its ends, all within its width. Sites: astride sites every ~0.6 m."""
    L, W, h = length, width, height
    k = _Kit()
    k.box((-W / 2, -L / 2, h - 0.3), (W / 2, L / 2, h - W / 2))
    k.add(rod((0, -L / 2, h - W / 2), (0, L / 2, h - W / 2), W / 2, sections=32, caps=False))
    for sy in (-1, 1):
        y0 = sy * (L / 2 - 0.1)
        for sx in (-1, 1):
            k.add(cylinder_z(sx * (W / 2 - 0.04), y0, 0.03, h - 0.3, 0.025, sections=16))
        k.box((-W / 2, y0 - 0.04, 0), (W / 2, y0 + 0.04, 0.03))
    n = max(1, int(L // 0.6))
    for i in range(n):
        y = -L / 2 + (i + 0.5) * L / n
        k.site("astride", (0, y, h), (0, 1), W, f"{name} {i + 1}")
    return k.piece(name, xy, angle)


def low_beam(xy, angle=0.0, length=2.0, width=0.2, height=0.5, name="low wall") -> Piece:
    """A solid low wall or beam ``width`` (0.2 m) x ``length`` (2.0 m) along its own y,
    ``height`` (0.5 m) tall, with a 2 cm coping on top. Sites every ~0.6 m: astride (along
    it) and seat (facing +x, no backrest)."""
    L, W, h = length, width, height
    k = _Kit()
    k.box((-W / 2, -L / 2, 0), (W / 2, L / 2, h - 0.02))
    k.box((-W / 2, -L / 2, h - 0.02), (W / 2, L / 2, h))
    n = max(1, int(L // 0.6))
    for i in range(n):
        y = -L / 2 + (i + 0.5) * L / n
        k.site("astride", (0, y, h), (0, 1), W, f"{name} astride {i + 1}")
        k.site("seat", (0, y, h), (1, 0), INF, f"{name} seat {i + 1}")
    return k.piece(name, xy, angle)


def sawhorse(xy, angle=0.0, length=1.0, height=0.7, name="sawhorse") -> Piece:
    """A carpenter's sawhorse: a 9 cm wide beam ``length`` (1.0 m) along its own y, top at
    ``height`` (0.7 m), on two pairs of legs splayed across at its ends. Sites: one astride
    site in the middle (the legs are at the ends, the middle is free to the floor)."""
    L, h = length, height
    k = _Kit()
    k.box((-0.045, -L / 2, h - 0.09), (0.045, L / 2, h))
    for sy in (-1, 1):
        y = sy * (L / 2 - 0.08)
        for sx in (-1, 1):
            k.add(rod((sx * 0.03, y, h - 0.1), (sx * 0.3, y + sy * 0.06, 0.02), 0.02,
                      sections=10, caps=False),
                  cylinder_z(sx * 0.3, y + sy * 0.06, 0.0, 0.03, 0.025, sections=10))
        k.box((-0.2, y - 0.01, 0.25), (0.2, y + 0.01, 0.3))
    k.site("astride", (0, 0, h), (0, 1), 0.09, f"{name} beam")
    return k.piece(name, xy, angle)


def motorbike_frame(xy, angle=0.0, seat_height=0.8, name="motorbike") -> Piece:
    """A motorbike-like frame (:func:`shapes.motorbike`, facing +x): wheels of radius 0.3 m on
    the floor, 1.4 m apart, a 0.3 x 0.14 m seat whose top is at ``seat_height`` (0.8 m),
    handlebar grips 0.5 m ahead of the seat's front, foot pegs at 0.33 m. Sites: astride on
    the seat (facing along the bike)."""
    sh = seat_height
    k = _Kit()
    grips = ((0.5, 0.32, sh + 0.15), (0.5, -0.32, sh + 0.15))
    k.add(shapes.motorbike(seat_xy=(0.0, 0.0), seat_top=sh, grips=grips, grip_top=sh + 0.1,
                           pegs_xy=((0.18, 0.17), (0.18, -0.17)), peg_top=0.36, ground=0.0))
    k.box((-0.26, -0.04, sh - 0.16), (-0.04, 0.04, sh - 0.09))        # seat post on the frame
    k.site("astride", (-0.15, 0, sh), (1, 0), 0.14, f"{name} seat")
    return k.piece(name, xy, angle)


# ------------------------------------------------------------------ distractors (no sites)
def floor_lamp(xy, height=1.6, name="floor lamp") -> Piece:
    """A floor lamp: a 0.15 m radius base, a pole and a conical shade (top at ``height``)."""
    k = _Kit()
    k.add(cylinder_z(0, 0, 0, 0.03, 0.15), rod((0, 0, 0.03), (0, 0, height - 0.2), 0.012))
    shade = revolve([[0, 0], [0.2, 0], [0.12, 0.28], [0, 0.28]], sections=40)
    shade.apply_translation((0, 0, height - 0.28))
    k.add(shade)
    return k.piece(name, xy, 0.0)


def radiator(xy, angle=0.0, length=0.8, height=0.6, name="radiator") -> Piece:
    """A double-panel radiator ``length`` x ``height`` (0.8 x 0.6 m) from 0.12 m up, 4 cm
    off the wall on two floor feet (origin on the wall face)."""
    k = _Kit()
    for x0 in (0.04, 0.1):
        k.box((x0, -length / 2, 0.12), (x0 + 0.025, length / 2, 0.12 + height))
    for y in np.linspace(-length / 2 + 0.03, length / 2 - 0.03, 12):
        k.box((0.065, y - 0.01, 0.14), (0.1, y + 0.01, 0.1 + height))
    for sy in (-1, 1):
        k.box((0.05, sy * (length / 2 - 0.08) - 0.02, 0), (0.115, sy * (length / 2 - 0.08) + 0.02,
                                                            0.12))
    return k.piece(name, xy, angle)


def tv_stand(xy, angle=0.0, length=1.2, depth=0.4, height=0.5, tv=(1.1, 0.65),
             name="TV stand") -> Piece:
    """A low TV cabinet ``length`` x ``depth`` x ``height`` (1.2 x 0.4 x 0.5 m) carrying a
    flat TV ``tv`` (1.1 x 0.65 m) on a pedestal foot that covers most of the top."""
    L, D, h = length, depth, height
    k = _Kit()
    k.box((-D / 2, -L / 2, 0.05), (D / 2, L / 2, h))
    for sy in (-1, 1):
        k.box((-D / 2 + 0.03, sy * (L / 2 - 0.05) - 0.03, 0), (D / 2 - 0.03,
                                                                 sy * (L / 2 - 0.05) + 0.03, 0.05))
    tw, th = tv
    k.box((-D / 2 + 0.03, -L / 2 + 0.05, h), (D / 2 - 0.03, L / 2 - 0.05, h + 0.03))
    k.box((-0.04, -0.05, h + 0.03), (0.0, 0.05, h + 0.12))
    k.box((-0.02, -tw / 2, h + 0.1), (0.035, tw / 2, h + 0.1 + th))
    return k.piece(name, xy, angle)


def plant_pot(xy, radius=0.17, height=0.34, plant=0.6, name="plant pot") -> Piece:
    """A tapered plant pot (``radius`` at the rim, ``height``) with soil and a bushy plant
    ``plant`` tall above it: a few stems carrying clumps of leaves."""
    k = _Kit()
    r, h, s = radius, height, plant / 0.6
    k.add(revolve([[0, 0], [0.7 * r, 0], [r, h], [0, h]], sections=40))
    for i in range(6):
        a = 2 * math.pi * i / 6 + 0.3
        reach, top = (0.12 + 0.05 * (i % 2)) * s, (0.35 + 0.08 * (i % 3)) * plant
        tip = (reach * math.cos(a), reach * math.sin(a), h + top)
        k.add(rod((0, 0, h - 0.02), tip, 0.008, sections=8),
              ball(tip, (0.07 + 0.015 * (i % 2)) * s))
    k.add(ball((0, 0, h + plant - 0.09 * s), 0.09 * s))
    k.add(rod((0, 0, h - 0.02), (0, 0, h + plant - 0.09 * s), 0.01, sections=8))
    return k.piece(name, xy, 0.0)


def wall_cabinet(xy, angle=0.0, length=0.8, bottom=1.4, height=0.7, depth=0.35,
                 name="wall cabinet") -> Piece:
    """A wall cabinet ``length`` x ``depth`` x ``height`` with its bottom at ``bottom``
    (origin on the wall face)."""
    k = _Kit()
    k.box((0.002, -length / 2, bottom), (depth, length / 2, bottom + height))
    k.box((depth, -length / 2 + 0.003, bottom + 0.003), (depth + 0.02, length / 2 - 0.003,
                                                         bottom + height - 0.003))
    return k.piece(name, xy, angle, wall_mounted=True)


def fridge(xy, angle=0.0, size=(0.65, 0.6), height=1.8, name="fridge") -> Piece:
    """A tall fridge ``size`` (depth x width) and ``height``, its back at x = 0."""
    D, W = size
    k = _Kit()
    k.box((0.002, -W / 2, 0), (D, W / 2, height))
    k.box((D, W / 2 - 0.06, 1.0), (D + 0.04, W / 2 - 0.04, 1.4))
    return k.piece(name, xy, angle)
