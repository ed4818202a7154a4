"""Procedural validation rooms built of :mod:`.furniture`, with labelled affordance sites.

These scenes are not the 14 published test scenes: they are for tuning the detector's
acceptance thresholds per affordance and for proving a validity judge on labelled poses.
Everything is deterministic (no randomness). Units are metres, +Z up; the floor slab's top is
``z = 0`` (no floor and no walls in ``office_nofloor``, like the published office scenes) and
the walls (room_shell) run along the -x and -y sides of the floor.

:func:`check_scene` verifies what the sites promise (free space above a place, around an
astride support, below a hook; a tap outlet over a fill site; no piece inside another) with
python-fcl triangle collisions and exact point-in-solid tests on the closed primitives.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from interaction_tensor.examples.procedural import room_shell
from interaction_tensor.examples.shapes import _geometry
from interaction_tensor.geometry.core import Geometry
from itensor_paper.rooms import furniture as F

KINDS = F.KINDS


@dataclass
class ValidationScene:
    """One validation room.

    Attributes
    ----------
    name : scene name (:func:`scene_names`)
    geometry : one mesh of the whole room (floor slab and walls, except ``office_nofloor``)
    pieces : the :class:`~.furniture.Piece` objects standing in it
    sites : all :class:`~.furniture.Site` objects of the scene
    shell : the room's own closed primitives (floor slab first, then the walls)
    """

    name: str
    geometry: Geometry
    pieces: list
    sites: list
    shell: list

    def counts(self) -> dict:
        return {k: sum(s.kind == k for s in self.sites) for k in KINDS}

    def floor_area(self) -> float:
        """Floor area (m^2): the slab's top, or the furniture's x-y extent without a floor."""
        if self.shell:
            lo, hi = self.shell[0].bounds
            return float((hi[0] - lo[0]) * (hi[1] - lo[1]))
        lo, hi = self.geometry.vertices.min(axis=0), self.geometry.vertices.max(axis=0)
        return float((hi[0] - lo[0]) * (hi[1] - lo[1]))

    def surface_area(self) -> float:
        import trimesh

        return float(trimesh.triangles.area(self.geometry.vertices[self.geometry.faces]).sum())


# ------------------------------------------------------------------ scenes
def room(size_xy, wall_height: float = 2.4) -> list:
    """The closed primitives of :func:`~.procedural.room_shell`: a floor slab (top at
    z = 0) over [0, w] x [0, d] and walls along its -x and -y sides."""
    return F.part_meshes(room_shell(size_xy, wall_height))


def _shell(size_xy):
    return room(size_xy)


def _living_a():
    pieces = [
        F.sofa((0.465, 2.5), 0, places=3, name="sofa"),
        F.coffee_table((1.65, 2.5), 90, name="coffee table"),
        F.armchair((2.6, 4.1), -90, name="armchair"),
        F.side_table((0.35, 0.75), 0, name="side table"),
        F.floor_lamp((0.3, 0.25)),
        F.bookcase((2.9, 0.0), 90, name="bookcase"),
        F.tv_stand((4.1, 2.5), 180),
        F.wall_shelves((1.4, 0.0), 90, boards=(1.2, 1.42, 1.8), name="wall shelves"),
        F.shelf_unit((3.9, 1.0), 0, name="shelf unit"),
        F.door_in_partition((0.002, 4.85), -90, wall_length=0.6, name="door"),
        F.coat_pegs((0.0, 4.2), 0, height=1.75, count=3, name="coat pegs"),
        F.plant_pot((4.0, 4.4), radius=0.14, height=0.3, plant=0.5),
    ]
    return _shell((4.4, 4.9)), pieces


def _living_b():
    pieces = [
        F.bed((1.062, 3.3), 0, name="bed"),
        F.side_table((0.25, 2.3), 0, size=(0.4, 0.4), height=0.5, name="bedside table"),
        F.wall_shelves((0.0, 3.3), 0, boards=(1.3, 1.7), length=0.8, name="bedroom shelves"),
        F.bench((2.4, 3.3), 0, length=1.4, name="bench"),
        F.sofa((3.3, 0.477), 90, places=2, place_width=0.62, depth=0.95, seat_height=0.42,
               arm_height=0.6, arm_width=0.22, back_top=0.82, rounded=True, name="2-seat sofa"),
        F.radiator((1.2, 0.0), 90),
        F.vaulting_horse((3.5, 2.0), 0, name="vaulting horse"),
        F.low_beam((4.6, 2.4), 0, length=1.6, name="low wall"),
        F.clothes_rail((3.6, 3.9), 90, height=1.35, length=1.0, radius=0.01,
                       name="clothes rail"),
        F.floor_lamp((1.85, 0.3)),
        F.plant_pot((4.85, 4.25), radius=0.15, plant=0.5),
    ]
    return _shell((5.2, 4.6)), pieces


def _kitchen_a():
    sink = F.SinkSpec(y=-0.5, size=(0.40, 0.50), depth=0.17, tap="gooseneck", outlet_above=0.16)
    prep = F.SinkSpec(y=0.3, size=(0.36, 0.40), depth=0.16, tap="straight", outlet_above=0.11)
    pieces = [
        F.kitchen_counter((0.0, 1.6), 0, length=2.6, sinks=(sink,), wall_cabinet=(0.1, 1.25),
                          name="counter"),
        F.kitchen_counter((1.4, 0.0), 90, length=1.4, sinks=(prep,), name="prep counter"),
        F.fridge((0.0, 3.3), 0),
        F.breakfast_bar((3.2, 1.5), 90, name="breakfast bar"),
        F.dining_table((3.2, 3.45), 0, name="dining table"),
    ]
    for i, x in enumerate((2.7, 3.2, 3.7)):
        pieces.append(F.bar_stool((x, 2.02), -90, seat_height=(0.64, 0.65, 0.63)[i],
                                  name=f"bar stool {i + 1}"))
    # chairs pulled out from the table, with room to sit down
    for i, (x, y, a) in enumerate([(2.8, 2.68, 90), (3.6, 2.68, 90), (2.8, 4.22, -90),
                                   (3.6, 4.22, -90)]):
        pieces.append(F.dining_chair((x, y), a, name=f"dining chair {i + 1}"))
    return _shell((4.6, 4.6)), pieces


def _kitchen_b():
    sink = F.SinkSpec(y=0.2, size=(0.42, 0.5), depth=0.18, tap="straight", outlet_above=0.09)
    pieces = [
        F.kitchen_counter((2.6, 0.0), 90, length=2.4, sinks=(), wall_cabinet=(-1.1, -0.2),
                          name="counter"),
        F.wall_shelves((1.85, 0.0), 90, boards=(1.45, 1.8), name="kitchen shelves"),
        F.kitchen_counter((2.4, 1.9), 90, length=1.8, depth=0.9, sinks=(sink,),
                          back_overhang=0.3, name="island"),
        F.washbasin((0.0, 0.9), 0, outlet_above=0.05, name="washbasin 1"),
        F.washbasin((0.0, 3.4), 0, top=0.82, width=0.5, depth=0.42, bowl=0.13,
                    outlet_above=0.09, pedestal=True, tap="gooseneck", name="washbasin 2"),
        F.wall_shelves((0.0, 2.1), 0, boards=(1.25, 1.45, 1.85), length=0.8,
                       name="bathroom shelves"),
        F.plant_pot((4.2, 3.8), radius=0.2, height=0.4, plant=0.7),
    ]
    for i, x in enumerate((1.95, 2.85)):
        pieces.append(F.bar_stool((x, 1.38), 90, seat_height=0.62, radius=0.17,
                                  name=f"island stool {i + 1}"))
    return _shell((4.6, 4.2)), pieces


def _office_a():
    sink = F.SinkSpec(y=0.2, size=(0.34, 0.40), depth=0.15, tap="straight", outlet_above=0.12)
    pieces = [
        F.desk((1.4, 0.357), 90, name="desk 1"),
        F.office_chair((1.4, 1.157), -90, seat="round", name="office chair 1"),
        F.desk((0.357, 2.9), 0, size=(1.4, 0.7), height=0.72, pedestal=False, name="desk 2"),
        F.office_chair((1.157, 2.9), 180, seat="square", seat_height=0.5, arms=True,
                       name="office chair 2"),
        F.coat_pegs((0.0, 1.1), 0, height=1.7, count=4, name="coat pegs"),
        F.bookcase((3.0, 0.0), 90, width=0.9, depth=0.32,
                   boards=(0.05, 0.4, 0.75, 1.1, 1.45), name="bookcase"),
        F.clothes_rail((4.3, 3.5), 0, height=1.7, length=1.1, radius=0.012, style="A",
                       name="clothes rail"),
        F.kitchen_counter((4.3, 0.0), 90, length=1.2, sinks=(sink,), name="kitchenette"),
        F.washbasin((0.0, 4.1), 0, top=0.84, pedestal=True, outlet_above=0.1, name="washbasin"),
        F.free_panel((2.5, 2.2), 0, name="office divider"),
        F.stool((3.4, 2.4), 30, seat_height=0.46, size_xy=(0.34, 0.38), name="stool"),
    ]
    return _shell((5.0, 4.6)), pieces


def _office_nofloor():
    pieces = [
        F.desk((0.35, 1.0), 0, size=(1.4, 0.7), name="desk"),
        F.office_chair((1.15, 1.0), 180, seat="square", seat_size=0.48, name="office chair"),
        F.stool((2.2, 0.4), 0, seat_height=0.43, size_xy=(0.38, 0.4), name="stool"),
        F.free_panel((1.9, 2.4), 90, length=1.5, height=1.55, thickness=0.03,
                     name="side panel"),
        F.washbasin((0.0, 3.2), 0, pedestal=True, top=0.86, bowl=0.12, outlet_above=0.04,
                    name="washbasin"),
        F.shelf_unit((3.0, 1.3), 0, width=0.7, boards=(0.06, 0.44, 0.82, 1.2),
                     side_height=1.7, name="shelf unit"),
    ]
    return [], pieces


def _garage():
    pieces = [
        F.motorbike_frame((2.4, 3.0), 0, seat_height=0.8, name="motorbike 1"),
        F.motorbike_frame((2.4, 4.0), 180, seat_height=0.72, name="motorbike 2"),
        F.gym_bench((4.6, 2.5), 0, length=1.8, name="gym bench"),
        F.workbench((1.5, 0.354), 90, name="workbench"),
        F.coat_pegs((0.0, 2.0), 0, height=1.6, count=3, spacing=0.25, peg_length=0.12,
                    peg_radius=0.012, knob=False, name="garage pegs"),
        F.clothes_rail((4.6, 4.2), 90, height=1.8, length=1.0, radius=0.02, name="garage rail"),
        F.utility_sink((3.1, 0.0), 90),
        F.sawhorse((4.2, 0.9), 90),
        F.stool((0.9, 1.2), -90, seat_height=0.5, size_xy=(0.32, 0.32), name="workshop stool"),
    ]
    return _shell((5.4, 4.6)), pieces


def _judge_traps():
    """Not a validation room (the tuning never sees it): surfaces that fooled an earlier
    filling judge, a narrow bar a few centimetres over a mug that is not in a basin. A
    trestle table whose stretcher runs 16 cm above the floor, and a counter with a towel bar
    20 cm above its top, 10 cm in from its front edge. :data:`JUDGE_TRAPS` lists where a mug stands under each bar.
    For the sitting judge: the counter's front is flush with its top (a person on its edge
    has the calves along the front, :func:`flush_counter_edges`); two stepped units, a low
    one (a seat with a foot rest 20 cm up) and a tall one (its top 1.65 m up, the step 1.2 m:
    :func:`stepped_unit_seats`); and the floor slab's open +x and +y edges
    (:func:`floor_edge_seats`). For the riding judge: a low wall (0.9 m) and a low panel
    (0.7 m, 5 cm thick), partitions of 1.4 m and 1.6 m and a tall one (2.4 m), each 1.2 m
    long, whose tops a rider can straddle (:func:`wall_top_rides`)."""
    k = F._Kit()
    k.box((-0.6, -0.3, 0.71), (0.6, 0.3, 0.74))                      # table top
    for x in (-0.5, 0.5):
        k.box((x - 0.03, -0.25, 0.0), (x + 0.03, 0.25, 0.71))        # trestle legs
    k.box((-0.5, -0.02, 0.16), (0.5, 0.02, 0.19))                    # the stretcher
    table = k.piece("trestle table", (1.3, 1.2), 0)
    k = F._Kit()
    k.box((-0.6, -0.3, 0.0), (0.6, 0.3, 0.9))                        # counter block
    for x in (-0.5, 0.5):
        k.box((x - 0.01, -0.21, 0.9), (x + 0.01, -0.19, 1.1))        # bar posts
    k.add(F.rod((-0.5, -0.2, 1.1), (0.5, -0.2, 1.1), 0.012, sections=16))
    counter = k.piece("counter with towel bar", (1.3, 2.6), 0)
    units = []
    for name, xy, step in (("tall stepped unit", (3.2, 0.8), 1.2),
                           ("low stepped unit", (3.2, 1.9), 0.2)):
        # a block of 0.8 x 1.0 m to ``step`` high, and on its back half a block 0.45 m
        # higher: a person on the upper block's front edge has the feet on the step
        k = F._Kit()
        k.box((-0.4, -0.5, 0.0), (0.4, 0.5, step))
        k.box((0.0, -0.5, step), (0.4, 0.5, step + 0.45))
        units.append(k.piece(name, xy, 0))
    # a bench with a footstool pushed against its front (a sofa with the coffee table
    # against it): a person on the bench's edge has the knees over the stool's top and the
    # shins and feet inside the stool (:func:`footstool_bench_seats`)
    (bx0, bx1), (by0, by1), bench_top = FOOTSTOOL_BENCH
    k = F._Kit()
    k.box((bx0, by0, 0.0), (bx1, by1, bench_top))
    k.box((bx0, by1, 0.0), (bx1, by1 + 0.3, 0.3))
    bench = k.piece("bench with a footstool against it", (0.0, 0.0), 0)
    # a bench whose front part rises 3 cm, as a saddle rises to a tank: a rider on the low
    # part has the thighs a little into the rise, as on a motorbike (:func:`saddle_rides`)
    (sx0, sx1), (sy0, sy1), saddle_top = SADDLE_BENCH
    k = F._Kit()
    k.box((sx0, sy0, 0.0), (sx1, sy1, saddle_top))
    k.box((SADDLE_RISE_X, sy0, saddle_top), (sx1, sy1, saddle_top + 0.03))
    saddle = k.piece("bench with a raised front", (0.0, 0.0), 0)
    walls = []
    for name, x0, y0, height, thick in WALL_TOPS:
        k = F._Kit()
        k.box((-thick / 2, -0.6, 0.0), (thick / 2, 0.6, height))
        walls.append(k.piece(name, (x0, y0), 0))
    return _shell(TRAPS_SIZE), [table, counter, bench, saddle] + units + walls


def _floorless_traps():
    """Not a validation room: a scan without its floor, as the published office scans are.
    An office chair, whose star base a hook can go round 8-10 cm above where the floor would
    be (a hanger there hangs through the floor), and a clothes rail standing on its feet (a
    hanger on its bar hangs free: the control). :func:`star_base_hooks` lists the hooks."""
    return [], [F.office_chair((1.0, 1.0), 0, seat="round", name="office chair"),
                F.clothes_rail((2.4, 1.0), 0, height=1.7, length=1.0, radius=0.015,
                               name="clothes rail")]


def star_base_hooks(scene: "ValidationScene", radius: float = 0.2) -> list:
    """Where a hook goes round each leg of the office chair of :func:`_floorless_traps`:
    [(point on the leg's top (3,), the leg's horizontal direction (2,), note)], the point
    found by casting a ray down onto the scene ``radius`` (m) out from the column."""
    tri = scene.geometry.vertices[scene.geometry.faces]
    low = tri[tri[:, :, 2].max(axis=1) < 0.2]          # the base, not the seat above it
    out = []
    for i in range(5):
        a = 2 * math.pi * i / 5 + math.pi / 10
        d = np.array([math.cos(a), math.sin(a)])
        xy = np.array([1.0, 1.0]) + radius * d
        t = _ray_hits(low, np.array([[xy[0], xy[1], 0.2]]), np.array([0.0, 0.0, -1.0]))
        out.append((np.r_[xy, 0.2 - t.min()], d, f"office chair star-base leg {i + 1}"))
    return out


#: The judge traps' floor slab (m; open on its +x and +y edges).
TRAPS_SIZE = (5.6, 3.4)
#: The judge traps' walls a rider can straddle: (name, centre x, centre y, height,
#: thickness), all 1.2 m long along y.
WALL_TOPS = (("low wall", 4.9, 0.9, 0.9, 0.10), ("tall partition", 4.9, 2.5, 2.4, 0.10),
             ("mid partition", 4.2, 1.7, 1.6, 0.10), ("chest-high partition", 0.45, 1.7, 1.4,
                                                      0.10), ("low panel", 2.4, 2.2, 0.7, 0.05))


#: The judge traps' bench (x range, y range, top height; m), its front at the larger y, with
#: a footstool 0.3 m high and 0.3 m deep against that front.
FOOTSTOOL_BENCH = ((2.0, 2.7), (0.35, 0.75), 0.45)


#: The judge traps' bench with a raised front (x range, y range, top height; m): from
#: ``SADDLE_RISE_X`` on, its top is 3 cm higher.
SADDLE_BENCH = ((3.0, 3.9), (2.75, 3.05), 0.5)
SADDLE_RISE_X = 3.4


def saddle_rides() -> list:
    """Where a rider sits astride the low part of :func:`_judge_traps`'s bench with a raised
    front, facing the rise: [(seat point (3,), facing angle (radians), note)]."""
    (x0, _), (y0, y1), top = SADDLE_BENCH
    return [((x, (y0 + y1) / 2, top), 0.0,
             f"bench with a raised front, rise {SADDLE_RISE_X - x:.2f} m ahead")
            for x in (SADDLE_RISE_X - 0.10, SADDLE_RISE_X - 0.12)]


def footstool_bench_seats() -> list:
    """Where a person sits on the front edge of :func:`_judge_traps`'s bench, facing +y over
    the footstool: [(point on the bench's front edge (3,), facing angle (radians), note)]."""
    (x0, x1), (_, y1), top = FOOTSTOOL_BENCH
    return [((x, y1, top), math.pi / 2, f"bench with a footstool, x {x:.2f}")
            for x in (x0 + 0.2, x1 - 0.2)]


def wall_top_rides() -> list:
    """Where a rider straddles the top of :func:`_judge_traps`'s walls, facing along them:
    [(point on the top's centre line (3,), facing angle (radians), height m, note)]."""
    return [((x0, y0 + dy, height), angle, height, f"{name}, y {dy:+.1f}")
            for name, x0, y0, height, _ in WALL_TOPS for dy in (-0.25, -0.1, 0.0, 0.1, 0.25)
            for angle in (math.pi / 2, -math.pi / 2)]


#: Judge traps (:func:`_judge_traps`): (support point under the bar, note).
JUDGE_TRAPS = [((1.3 + x, 1.2, 0.0), f"floor under the stretcher, x {x:+.1f}")
               for x in (-0.3, 0.0, 0.25)] + \
              [((1.3 + x, 2.6 - 0.2, 0.9), f"counter under the towel bar, x {x:+.1f}")
               for x in (-0.3, 0.0, 0.25)]

def flush_counter_edges() -> list:
    """Where a person can be posed sitting on an edge of :func:`_judge_traps`'s counter block
    (its front flush with its top), facing out: [(point on the top's edge (3,), facing angle
    (radians), note)], away from the towel bar's posts."""
    cx, cy, top = 1.3, 2.6, 0.9
    out = [((cx + x, cy + 0.3, top), math.pi / 2, f"counter block back edge, x {x:+.1f}")
           for x in (-0.4, -0.2, 0.0, 0.2, 0.4)]
    out += [((cx + 0.6 * s, cy + 0.12, top), 0.0 if s > 0 else math.pi,
             f"counter block {'right' if s > 0 else 'left'} edge") for s in (1, -1)]
    return out


def stepped_unit_seats() -> list:
    """Where a person sits on the upper block of :func:`_judge_traps`'s stepped units, facing
    -x, the feet on the step: [(point on the upper block's front edge (3,), facing angle,
    step height above the floor m, note)]: on the low unit a seat with a foot rest, on the
    tall one the top of a 1.65 m unit with the feet 1.2 m above the floor."""
    return [((3.2, y0 + dy, step + 0.45), math.pi, step, f"{name}, y {dy:+.1f}")
            for name, y0, step in (("tall stepped unit", 0.8, 1.2),
                                   ("low stepped unit", 1.9, 0.2))
            for dy in (-0.3, 0.0, 0.3)]


def floor_edge_seats() -> list:
    """Where a person can be posed sitting on the open edges of :func:`_judge_traps`'s floor
    slab (no wall there), facing out, the legs hanging below the floor: [(point on the
    edge (3,), facing angle (radians), note)]."""
    sx, sy = TRAPS_SIZE
    out = [((sx, y, 0.0), 0.0, f"floor slab's +x edge, y {y:.1f}") for y in (0.6, 1.8)]
    out += [((x, sy, 0.0), math.pi / 2, f"floor slab's +y edge, x {x:.1f}")
            for x in (0.4, 2.5)]
    return out


_SCENES = {"living_a": _living_a, "living_b": _living_b, "kitchen_a": _kitchen_a,
           "kitchen_b": _kitchen_b, "office_a": _office_a, "office_nofloor": _office_nofloor,
           "garage": _garage}
#: Scenes for proving the judge only, never for tuning.
_JUDGE_ONLY = {"judge_traps": _judge_traps, "floorless_traps": _floorless_traps}


def scene_names() -> list[str]:
    """The validation rooms (tuning and the labelled set); not the judge-only scenes."""
    return list(_SCENES)


def build_scene(name: str) -> ValidationScene:
    """The validation scene ``name`` (deterministic), or a judge-only scene."""
    make = _SCENES.get(name) or _JUDGE_ONLY.get(name)
    if make is None:
        raise KeyError(f"unknown validation scene {name!r}; known: "
                       f"{', '.join(list(_SCENES) + list(_JUDGE_ONLY))}")
    shell, pieces = make()
    return compose(name, pieces, shell)


def compose(name: str, pieces, shell=()) -> ValidationScene:
    """A scene of ``pieces`` and the room primitives ``shell`` (floor slab first, then
    walls; empty for no room), e.g. ``F.part_meshes(room_shell((4, 4)))``."""
    meshes = list(shell) + [m for p in pieces for m in p.meshes]
    geometry = _geometry(meshes, f"validation scene {name}")
    sites = [s for p in pieces for s in p.sites]
    return ValidationScene(name, geometry, list(pieces), sites, list(shell))


# ------------------------------------------------------------------ geometric queries
_RAY_DIR = np.array([0.0137, 0.0291, 1.0]) / np.linalg.norm([0.0137, 0.0291, 1.0])


def _ray_hits(tri, origins, direction):
    """Distances along ``direction`` (3,) from each origin (N, 3) to each triangle (T, 3, 3):
    (N, T) with inf where missed (Moller-Trumbore)."""
    v0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    p = np.cross(direction, e2)                               # (T, 3)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-14
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = origins[:, None, :] - v0[None]                       # (N, T, 3)
    u = np.einsum("ntj,tj->nt", s, p) * inv
    q = np.cross(s, e1[None])
    v = np.einsum("ntj,j->nt", q, direction) * inv
    t = np.einsum("ntj,tj->nt", q, e2) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return np.where(hit, t, np.inf)


class Space:
    """The closed primitives of a scene, for clearance, ray and point-in-solid queries.

    ``owner[j]`` is the index of the piece primitive ``j`` belongs to (-1 for the room).
    """

    def __init__(self, pieces, shell=()):
        import trimesh

        self.prims, self.owner = [], []
        for i, p in enumerate(pieces):
            for m in p.meshes:
                self.prims.append(m)
                self.owner.append(i)
        #: index of the room's floor slab (the first shell primitive), None without one
        self.floor = len(self.prims) if len(shell) else None
        for m in shell:
            self.prims.append(m)
            self.owner.append(-1)
        self.owner = np.array(self.owner)
        self.tris = [np.asarray(m.triangles) for m in self.prims]
        self.lo = np.array([m.bounds[0] for m in self.prims])
        self.hi = np.array([m.bounds[1] for m in self.prims])
        self.manager = trimesh.collision.CollisionManager()
        for j, m in enumerate(self.prims):
            self.manager.add_object(str(j), m)

    def inside(self, j: int, points) -> np.ndarray:
        """(N,) bool: points inside closed primitive ``j`` (ray parity)."""
        pts = np.atleast_2d(np.asarray(points, float))
        out = np.zeros(len(pts), bool)
        box = np.all((pts >= self.lo[j] - 1e-9) & (pts <= self.hi[j] + 1e-9), axis=1)
        if box.any():
            d = _ray_hits(self.tris[j], pts[box], _RAY_DIR)
            out[box] = (np.isfinite(d).sum(axis=1) % 2) == 1
        return out

    def inside_any(self, points, candidates=None) -> np.ndarray:
        """(N,) int: the index of a primitive containing each point, -1 where none."""
        pts = np.atleast_2d(np.asarray(points, float))
        res = np.full(len(pts), -1)
        cand = range(len(self.prims)) if candidates is None else candidates
        plo, phi = pts.min(axis=0), pts.max(axis=0)
        for j in cand:
            if np.any(self.lo[j] > phi) or np.any(self.hi[j] < plo):
                continue
            todo = res < 0
            if not todo.any():
                break
            hit = self.inside(j, pts[todo])
            idx = np.flatnonzero(todo)[hit]
            res[idx] = j
        return res

    def box_hits(self, centre, axes, half, ignore=()) -> set:
        """Primitives that intersect the oriented box (``axes`` (3, 3): unit rows, ``half``
        (3,) half sizes), triangle crossings and containment either way; minus ``ignore``."""
        import trimesh

        centre, axes, half = (np.asarray(a, float) for a in (centre, axes, half))
        t = np.eye(4)
        t[:3, :3] = axes.T
        t[:3, 3] = centre
        probe = trimesh.creation.box(extents=2 * half)
        _, names = self.manager.in_collision_single(probe, transform=t, return_names=True)
        hits = {int(n) for n in names}
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)],
                           float) * half @ axes + centre
        blo, bhi = corners.min(axis=0), corners.max(axis=0)
        cand = np.flatnonzero(np.all(self.lo <= bhi, axis=1) & np.all(self.hi >= blo, axis=1))
        pts = np.vstack([corners, centre])
        for j in cand:
            if j in hits or j in ignore:
                continue
            local = (np.asarray(self.prims[j].vertices) - centre) @ axes.T
            if np.any(np.all(np.abs(local) < half, axis=1)) or self.inside(j, pts).any():
                hits.add(int(j))
        return hits - set(ignore)

    def ray(self, origin, direction, length: float, ignore=()) -> float:
        """Distance from ``origin`` along unit ``direction`` to the first primitive (within
        ``length``), inf when nothing is hit."""
        o, d = np.asarray(origin, float), np.asarray(direction, float)
        e = o + d * length
        lo, hi = np.minimum(o, e) - 1e-9, np.maximum(o, e) + 1e-9
        cand = np.flatnonzero(np.all(self.lo <= hi, axis=1) & np.all(self.hi >= lo, axis=1))
        best = np.inf
        for j in cand:
            if j in ignore:
                continue
            best = min(best, float(_ray_hits(self.tris[j], o[None], d).min()))
        return best if best <= length else np.inf

    def nearest(self, point, candidates) -> tuple:
        """(distance, primitive, unit normal of the nearest triangle) from ``point`` to the
        surfaces of the ``candidates`` primitives."""
        import trimesh

        p = np.asarray(point, float)
        best = (np.inf, -1, None)
        for j in candidates:
            tri = self.tris[j]
            cp = trimesh.triangles.closest_point(tri, np.repeat(p[None], len(tri), axis=0))
            d = np.linalg.norm(cp - p, axis=1)
            k = int(np.argmin(d))
            if d[k] < best[0]:
                n = np.cross(tri[k, 1] - tri[k, 0], tri[k, 2] - tri[k, 0])
                best = (float(d[k]), int(j), n / max(np.linalg.norm(n), 1e-15))
        return best


def _frame(facing):
    """Unit rows: along ``facing`` (x-y), to its left, up."""
    f = np.r_[np.asarray(facing, float)[:2], 0.0]
    f /= np.linalg.norm(f)
    return f, np.array([-f[1], f[0], 0.0]), np.array([0.0, 0.0, 1.0])


def _box(space, p, f, l, u_rng, v_rng, z_rng, ignore=()):
    """Primitives in the box spanning ``u_rng`` along f, ``v_rng`` along l and ``z_rng``
    (absolute heights) around the site point p."""
    (u0, u1), (v0, v1), (z0, z1) = u_rng, v_rng, z_rng
    centre = p + f * (u0 + u1) / 2 + l * (v0 + v1) / 2
    centre[2] = (z0 + z1) / 2
    half = np.array([(u1 - u0) / 2, (v1 - v0) / 2, (z1 - z0) / 2])
    return space.box_hits(centre, np.stack([f, l, [0, 0, 1.0]]), half, ignore)


def _names(space, pieces, hits):
    return sorted({pieces[space.owner[j]].name if space.owner[j] >= 0 else "room"
                   for j in hits})


# ------------------------------------------------------------------ checks
def check_site(space, pieces, i, site) -> list[str]:
    """Problems with ``site`` of piece ``i`` (empty when it is right)."""
    errs = []
    p = np.asarray(site.point, float)
    f, l, up = _frame(site.facing)
    own = np.flatnonzero(space.owner == i)
    tag = f"{pieces[i].name}: {site.kind} '{site.note}'"
    dist, j, normal = space.nearest(p, own)
    if dist > 0.002:
        errs.append(f"{tag}: {dist * 1000:.1f} mm from the piece's surface")
    if normal is not None and normal[2] < 0.5:
        errs.append(f"{tag}: the nearest surface does not face up (normal {normal.round(2)})")
    if space.inside_any(p + [0, 0, 0.002])[0] >= 0:
        errs.append(f"{tag}: the point is inside a solid (not on a top surface)")
    if space.inside_any(p - [0, 0, 0.004], own)[0] < 0 and site.kind != "hang":
        errs.append(f"{tag}: no solid of the piece right under the point")
    z = p[2]
    w = site.width
    if site.kind == "place":
        if w < 0.12 - 1e-9:
            errs.append(f"{tag}: {w:.3f} m from the edge (< 0.12)")
        hits = _box(space, p, f, l, (-0.08, 0.08), (-0.08, 0.08), (z + 0.003, z + 0.3))
        if hits:
            errs.append(f"{tag}: not 0.3 m free above ({_names(space, pieces, hits)})")
        est = _edge_distance(space, own, p)
        if abs(est - w) > 0.015:
            errs.append(f"{tag}: width {w:.3f} but the nearest edge is {est:.3f} m away")
    elif site.kind == "seat":
        back = min(w, 0.3) - 0.01 if math.isfinite(w) else 0.25
        hits = _box(space, p, f, l, (-back, 0.2), (-0.2, 0.2), (z + 0.005, z + 1.0))
        if hits:
            errs.append(f"{tag}: not free above the seat ({_names(space, pieces, hits)})")
        hits = _box(space, p, f, l, (0.15, 0.45), (-0.15, 0.15), (0.15, z - 0.12), ignore=own)
        if hits:
            errs.append(f"{tag}: no room for the legs ({_names(space, pieces, hits)})")
        d = min(space.ray(p + up * dz, -f, 0.6) for dz in np.arange(0.1, 0.55, 0.05))
        if math.isfinite(w) and abs(d - w) > 0.01:
            errs.append(f"{tag}: width {w:.3f} but the backrest is {d:.3f} m behind")
        if not math.isfinite(w) and d < 0.3:
            errs.append(f"{tag}: no backrest declared but something {d:.3f} m behind")
    elif site.kind == "astride":
        if w > 0.30 + 1e-9:
            errs.append(f"{tag}: support {w:.3f} m wide (> 0.30)")
        sides = []
        for s in (-1, 1):
            v_rng = tuple(sorted((s * (w / 2 + 0.01), s * (w / 2 + 0.36))))
            full = _box(space, p, f, l, (-0.2, 0.2), v_rng, (0.02, z + 0.3))
            ledge = _box(space, p, f, l, (-0.2, 0.2), v_rng, (z - 0.15, z + 0.3))
            sides.append("full" if not full else ("ledge" if not ledge else "blocked"))
            if ledge:
                errs.append(f"{tag}: side {s:+d} blocked ({_names(space, pieces, ledge)})")
        if sides.count("full") == 0:
            errs.append(f"{tag}: neither side is free down to the floor")
        if "arm" not in site.note and sides != ["full", "full"]:
            errs.append(f"{tag}: both sides must be free down to the floor ({sides})")
        hits = _box(space, p, f, l, (-0.15, 0.15), (-0.1, 0.1), (z + 0.005, z + 0.8))
        if hits:
            errs.append(f"{tag}: not free above ({_names(space, pieces, hits)})")
        est = _support_width(space, own, p, l, w)
        if abs(est - w) > 0.01:
            errs.append(f"{tag}: width {w:.3f} but the support is {est:.3f} m wide")
    elif site.kind == "hang":
        errs += _check_hang(space, pieces, own, p, f, l, w, tag)
    elif site.kind == "fill":
        if not 0.15 <= w <= 0.35:
            errs.append(f"{tag}: outlet {w:.3f} m above the basin bottom (not 0.15-0.35)")
        d = space.ray(p + up * 0.001, up, 0.6) + 0.001
        if abs(d - w) > 0.003:
            errs.append(f"{tag}: width {w:.3f} but the first thing above is {d:.3f} m up")
        for direction in (f, -f, l, -l):
            if not np.isfinite(space.ray(p + up * 0.05, direction, 0.4, ignore=())):
                errs.append(f"{tag}: no basin wall within 0.4 m towards {direction[:2].round(2)}")
        hits = _box(space, p, f, l, (-0.04, 0.04), (-0.04, 0.04), (z + 0.003, z + 0.1))
        if hits:
            errs.append(f"{tag}: no room for a 10 cm mug ({_names(space, pieces, hits)})")
    else:
        errs.append(f"{tag}: unknown kind")
    return errs


def _edge_distance(space, own, p, step=0.005, reach=1.2, directions=72):
    """Distance from p to the nearest edge of the flat top it lies on (the top of a solid of
    the piece whose highest point is at p's height), over ``directions`` rays."""
    tops = [j for j in own if abs(space.hi[j][2] - p[2]) < 0.0015]
    ang = np.linspace(0, 2 * np.pi, directions, endpoint=False)
    r = np.arange(step, reach, step)
    pts = (p[None, None, :2] + r[None, :, None] * np.stack([np.cos(ang), np.sin(ang)], 1)[:, None])
    q = np.concatenate([pts.reshape(-1, 2), np.full((pts.size // 2, 1), p[2] - 0.002)], axis=1)
    on = space.inside_any(q, tops) >= 0
    on = on.reshape(directions, len(r))
    first = np.where(~on.all(axis=1), np.argmin(on, axis=1), len(r))
    return float(r[first.min()] - step / 2) if first.min() < len(r) else reach


def _support_width(space, own, p, l, w):
    """Widest cross-section of the piece's support across ``l`` below p (down to w/2)."""
    best = 0.0
    s = np.arange(-0.3, 0.3001, 0.0025)
    for dz in np.arange(0.005, min(w / 2, 0.15) + 0.006, 0.005):
        q = p[None] + s[:, None] * l[None] - [0, 0, dz]
        on = space.inside_any(q, own) >= 0
        mid = len(s) // 2
        if not on[mid]:
            continue
        a = mid
        while a > 0 and on[a - 1]:
            a -= 1
        b = mid
        while b < len(s) - 1 and on[b + 1]:
            b += 1
        best = max(best, s[b] - s[a] + 0.0025)
    return best


def _check_hang(space, pieces, own, p, f, l, w, tag):
    errs = []
    z = p[2]
    if w > 0.04 + 1e-9:
        errs.append(f"{tag}: support {w:.3f} m thick (a hook opens 4.6 cm)")
    support = [j for j in own if space.nearest(p, [j])[0] < 0.003]
    if not support:
        return errs + [f"{tag}: no support under the point"]
    v = np.vstack([np.asarray(space.prims[j].vertices) for j in support])
    ext_f, ext_l = np.ptp(v @ f), np.ptp(v @ l)
    if abs(min(ext_f, ext_l) - w) > 0.003:
        errs.append(f"{tag}: width {w:.3f} but the support is {min(ext_f, ext_l):.3f} thick")
    rail_like = ext_f >= ext_l            # the hanging plane is across the support's long axis
    a, b = (f, l) if rail_like else (l, f)
    hits = _box(space, p, a, b, (-0.01, 0.01), (-0.04, 0.04), (z + 0.003, z + 0.07))
    if hits:
        errs.append(f"{tag}: no room for the hook over the support ({_names(space, pieces, hits)})")
    hits = _box(space, p, a, b, (-0.02, 0.02), (-0.02, 0.02), (z - 0.45, z - w - 0.02),
                ignore=support)
    if hits:
        errs.append(f"{tag}: not 0.45 m free straight below ({_names(space, pieces, hits)})")
    for s in (-1, 1):
        rng = tuple(sorted((s * (w / 2 + 0.02), s * 0.25)))
        hits = _box(space, p, a, b, (-0.04, 0.04), rng, (z - 0.45, z - 0.05), ignore=support)
        if hits:
            errs.append(f"{tag}: side {s:+d} not free below ({_names(space, pieces, hits)})")
    return errs


def check_pieces(scene: ValidationScene, space: Space) -> list[str]:
    """Problems with the pieces: non-finite or open primitives, pieces off the floor, pieces
    that cross each other or the walls."""
    import trimesh

    errs = []
    for i, piece in enumerate(scene.pieces):
        for k, m in enumerate(piece.meshes):
            if not np.isfinite(m.vertices).all():
                errs.append(f"{piece.name}: primitive {k} has non-finite vertices")
            if not m.is_watertight:
                errs.append(f"{piece.name}: primitive {k} is not closed")
        zmin = min(float(m.bounds[0][2]) for m in piece.meshes)
        if not piece.wall_mounted and abs(zmin) > 1e-6:
            errs.append(f"{piece.name}: does not stand on z = 0 (lowest point {zmin:.4f})")
        if piece.wall_mounted and zmin <= 0.0:
            errs.append(f"{piece.name}: wall-mounted but reaches the floor")
    manager = trimesh.collision.CollisionManager()
    for i, piece in enumerate(scene.pieces):
        manager.add_object(f"p{i}", trimesh.util.concatenate(piece.meshes))
    for k, m in enumerate(scene.shell[1:]):                   # the walls, not the floor
        manager.add_object(f"w{k}", m)
    hit, pairs = manager.in_collision_internal(return_names=True)
    for a, b in sorted(pairs):
        na = scene.pieces[int(a[1:])].name if a[0] == "p" else "wall"
        nb = scene.pieces[int(b[1:])].name if b[0] == "p" else "wall"
        if a[0] == "w" and b[0] == "w":
            continue
        errs.append(f"{na} and {nb} cross each other")
    # a piece entirely inside another (no crossing triangles): vertices inside solids
    for i, piece in enumerate(scene.pieces):
        v = np.vstack([np.asarray(m.vertices[:1]) for m in piece.meshes])
        others = [j for j in np.flatnonzero(space.owner != i) if j != space.floor]
        inside = space.inside_any(v, others)
        for j in set(inside[inside >= 0].tolist()):
            o = space.owner[j]
            errs.append(f"{piece.name} is inside {scene.pieces[o].name if o >= 0 else 'the room'}")
    return errs


def check_scene(scene: ValidationScene) -> list[str]:
    """Every problem found in ``scene`` (empty when the scene is right)."""
    space = Space(scene.pieces, scene.shell)
    errs = check_pieces(scene, space)
    for i, piece in enumerate(scene.pieces):
        for site in piece.sites:
            errs += check_site(space, scene.pieces, i, site)
    return errs


def summary() -> list[dict]:
    """Per scene: site counts per kind, floor and surface areas (m^2) and the number of
    points sampling the surface every 1 cm would give."""
    rows = []
    for name in scene_names():
        sc = build_scene(name)
        area = sc.surface_area()
        rows.append({"name": name, **sc.counts(), "floor_m2": round(sc.floor_area(), 1),
                     "surface_m2": round(area, 1), "points_1cm": int(area / 1e-4)})
    return rows
