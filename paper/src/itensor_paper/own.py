"""Interactions of a user's own: six procedural examples that are none of the paper's eight.

Each is trained as a user trains a pair of their own (:func:`interaction_tensor.train`, no
acceptance preset: the descriptor's own acceptance and placement tests) and detected in
procedural rooms, some holding places for it and some holding none. The judge rules the
accepted poses with the rule of the affordance the interaction belongs to (a book upright
on a shelf and a bottle on a windowsill are placing; an umbrella on a rail, a towel over a
towel bar and a mug by its handle on a cup hook are hanging), or with its own (a person
lying down: the body's whole underside supported, :data:`LYING`).

Units are metres, +Z up; every query rests on (or hangs from) its scene-object as a person
would set it there, and :func:`check_example` proves it (the judge accepts the example's own
pose and refuses it lifted off its support or pushed into it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np

from interaction_tensor import affordances
from interaction_tensor.affordances.registry import JudgeRule
from interaction_tensor.examples import shapes
from interaction_tensor.examples.posing import translated
from interaction_tensor.examples.shapes import _geometry, ball, box, polyline, revolve, rod
from interaction_tensor.geometry.core import Geometry
from itensor_paper.judge import Judge, JudgeSettings
from itensor_paper.rooms import furniture as F
from itensor_paper.rooms.validation import ValidationScene, compose, room

#: A person lying on their back: the judge's person rule, with the whole underside (head to
#: heels) as the main contact, of which half must touch (a person across a stool's seat is
#: not lying on it).
LYING = JudgeRule(("penetration", "contact", "support"), person=True)


@dataclass(frozen=True)
class OwnExample:
    """One interaction of a user's own.

    Attributes
    ----------
    name : e.g. ``book-shelf``
    description : what the example shows
    question : what a person is asked about a pose
    make : ``() -> (query, scene_object, support_point, loop)``, posed in one frame
    rule : the judge's rule
    judge_settings : overrides of :class:`~itensor_paper.judge.JudgeSettings`
    rooms_with, rooms_without : names of :data:`ROOMS` that hold a place for it / none
    """

    name: str
    description: str
    question: str
    make: Callable = field(repr=False, compare=False)
    rule: JudgeRule = JudgeRule(("upright", "penetration", "contact", "support"))
    judge_settings: dict = field(default_factory=dict)
    rooms_with: tuple = ()
    rooms_without: tuple = ()

    def build(self):
        """(query, scene_object, support_point (3,), loop or None)."""
        q, s, p, loop = self.make()
        return q, s, np.asarray(p, float), loop

    def judge(self) -> Judge:
        q, s, p, loop = self.build()
        st = replace(JudgeSettings(), **self.judge_settings)
        return Judge(q, s, self.name, p, loop, settings=st, rule=self.rule)


# ------------------------------------------------------------------ query objects
def book(width: float = 0.16, thickness: float = 0.035, height: float = 0.235) -> Geometry:
    """A closed hardback book standing upright on z = 0, its covers facing +-x:
    ``thickness`` along x, ``width`` along y, ``height`` up."""
    return _geometry([box((0, 0, height / 2), (thickness, width, height))], "procedural book")


def umbrella(hook_inner: float = 0.03, grip: float = 0.011, length: float = 0.85) -> Geometry:
    """A closed stick umbrella hanging by its J handle from z = 0: the handle an arc of inner
    radius ``hook_inner`` about the y axis from the -x side over the top down the +x side,
    the shaft down from its +x end, the furled canopy a slim cone, the tip at the bottom."""
    rc = hook_inner + grip
    ang = np.radians(np.linspace(200.0, 0.0, 14))
    arc = np.c_[rc * np.cos(ang), np.zeros_like(ang), rc * np.sin(ang)]
    x = rc
    shaft = rod((x, 0, 0.0), (x, 0, -0.16), grip)
    canopy = revolve([[0.0, 0.0], [0.012, 0.0], [0.045, 0.45], [0.02, 0.6], [0.0, 0.6]])
    canopy.apply_translation((x, 0, -0.78))
    tip = rod((x, 0, -0.78), (x, 0, -length), 0.006)
    top = rod((x, 0, -0.16), (x, 0, -0.18), 0.02)
    return _geometry([polyline(arc, grip, sections=10), shaft, top, canopy, tip],
                     "procedural umbrella")


def towel(fold_inner: float = 0.014, cloth: float = 0.004, width: float = 0.5,
          drop: float = 0.32) -> Geometry:
    """A towel folded over a bar along y: a half tube of inner radius ``fold_inner`` over the
    top (z >= 0, about the y axis) and two sheets ``drop`` long hanging down either side."""
    rc = fold_inner + cloth / 2
    ang = np.linspace(0.0, math.pi, 10)
    pts = np.c_[rc * np.cos(ang), rc * np.sin(ang)]
    parts = []
    for a, b in zip(pts[:-1], pts[1:]):
        parts.append(_slab(a, b, width, cloth))
    for sx in (-1, 1):
        parts.append(box((sx * rc, 0, -drop / 2), (cloth, width, drop)))
    return _geometry(parts, "procedural towel")


def _slab(a, b, width, thickness):
    """A box from x-z point ``a`` to ``b``, ``width`` along y, ``thickness`` across."""
    import trimesh

    a, b = np.asarray(a, float), np.asarray(b, float)
    d = b - a
    length = float(np.hypot(*d)) + thickness / 2
    m = trimesh.creation.box(extents=(length, width, thickness))
    m.apply_transform(trimesh.transformations.rotation_matrix(-math.atan2(d[1], d[0]),
                                                              (0, 1, 0)))
    mid = (a + b) / 2
    m.apply_translation((mid[0], 0.0, mid[1]))
    return m


def lying_human() -> Geometry:
    """A person (1.7 m) lying on their back along +x (head at -x), the underside of head,
    back, pelvis, legs and heels on z = 0, hands on the thighs. The pelvis is over x = 0."""
    parts = [ball((-0.68, 0.0, 0.1), 0.1),                                     # head
             rod((-0.52, 0.0, 0.14), (-0.12, 0.0, 0.14), 0.14),                # torso
             rod((0.0, -0.11, 0.1), (0.0, 0.11, 0.1), 0.1)]                    # pelvis
    for s in (-1, 1):
        y = 0.1 * s
        parts += [rod((0.02, y, 0.075), (0.45, y, 0.075), 0.075),              # thigh
                  rod((0.45, y, 0.055), (0.85, y, 0.055), 0.055),              # shin
                  box((0.9, y, 0.09), (0.08, 0.09, 0.18)),                     # foot
                  rod((-0.45, 0.2 * s, 0.16), (-0.2, 0.2 * s, 0.12), 0.045),   # upper arm
                  rod((-0.2, 0.2 * s, 0.12), (0.1, 0.14 * s, 0.2), 0.04)]      # forearm
    return _geometry(parts, "procedural lying human")


# ------------------------------------------------------------------ scene-objects
def compartment(top: float = 0.42, gap: float = 0.34, width: float = 0.8,
                depth: float = 0.3) -> Geometry:
    """A bookcase compartment: a board (2 cm) with its top at ``top``, the board above
    ``gap`` higher, the sides and the back."""
    b = 0.02
    parts = [box((0, 0, top - b / 2), (depth, width, b)),
             box((0, 0, top + gap + b / 2), (depth, width, b)),
             box((-depth / 2 - 0.005, 0, (top + gap) / 2 + 0.01), (0.01, width, top + gap + b))]
    for sy in (-1, 1):
        parts.append(box((0, sy * (width / 2 + 0.01), (top + gap) / 2 + 0.01),
                         (depth, 0.02, top + gap + b)))
    return _geometry(parts, "procedural bookcase compartment")


def window_with_sill(sill_top: float = 0.9, width: float = 1.2) -> Geometry:
    """A wall (face at x = -0.1) with a window: the sill (20 cm deep, 4 cm thick, its top
    at ``sill_top``), the glass 2 cm behind the wall face, the jambs at the window's sides
    and the lintel 1.1 m above the sill."""
    w = width
    parts = [box((-0.175, 0, (sill_top - 0.04) / 2), (0.15, w + 0.6, sill_top - 0.04)),
             box((0.0, 0, sill_top - 0.02), (0.3, w + 0.04, 0.04)),
             box((-0.13, 0, sill_top + 0.55), (0.01, w, 1.1)),
             box((-0.175, 0, sill_top + 1.2), (0.15, w + 0.6, 0.2))]
    for sy in (-1, 1):
        parts.append(box((-0.175, sy * (w / 2 + 0.15), sill_top + 0.55), (0.15, 0.3, 1.1)))
    return _geometry(parts, "procedural window")


def towel_bar(height: float = 1.0, length: float = 0.6, radius: float = 0.011,
              off_wall: float = 0.06) -> Geometry:
    """A towel bar along y, ``off_wall`` from the wall face (x = 0) on two brackets, its
    axis at ``height``, with the wall behind it from the floor up."""
    x = off_wall
    parts = [rod((x, -length / 2, height), (x, length / 2, height), radius, 24, caps=False),
             box((-0.05, 0, (height + 0.3) / 2), (0.1, length + 0.4, height + 0.3))]
    for sy in (-1, 1):
        parts.append(rod((0.0, sy * length / 2, height), (x, sy * length / 2, height), 0.009))
    return _geometry(parts, "procedural towel bar")


def cup_hook_board(height: float = 1.45, peg: float = 0.005, length: float = 0.09) -> Geometry:
    """A board 2 cm proud of a wall (the board's face at x = 0, the wall's at x = -0.02,
    from the floor), with one cup hook along +x at ``height``: a peg of radius ``peg``
    ``length`` long with an upturned tip."""
    tip = length + 0.01
    parts = [box((-0.01, 0, height), (0.02, 0.3, 0.08)),
             box((-0.06, 0, (height + 0.3) / 2), (0.08, 0.6, height + 0.3)),
             rod((0.0, 0, height), (tip, 0, height), peg, 16),
             rod((tip, 0, height), (tip, 0, height + 0.015), peg, 16)]
    return _geometry(parts, "procedural cup hook")


def bench_mesh(length: float = 1.9, width: float = 0.5, height: float = 0.45) -> Geometry:
    """A bench: a 5 cm top (``length`` along x) with its top at ``height`` on four legs."""
    t = 0.05
    parts = [box((0, 0, height - t / 2), (length, width, t))]
    for sx in (-1, 1):
        for sy in (-1, 1):
            parts.append(box((sx * (length / 2 - 0.06), sy * (width / 2 - 0.05),
                              (height - t) / 2), (0.05, 0.05, height - t)))
    return _geometry(parts, "procedural bench")


# ------------------------------------------------------------------ the examples posed
def _book_on_shelf():
    top = 0.42
    return (translated(book(), (0.0, 0.0, top)), compartment(top), (0.0, 0.0, top), None)


def _bottle_on_sill():
    top = 0.9
    return (translated(shapes.bottle(), (0.0, 0.0, top)), window_with_sill(top), (0.0, 0.0, top),
            None)


def _hang_on(query: Geometry, support: Geometry, axis_point, inner: float, top_z: float):
    """``query`` (hanging from its loop's top at z = 0 about ``axis_point``'s y line) moved
    so that its loop's inside rests on ``top_z``."""
    ax = np.asarray(axis_point, float)
    t = np.array([-ax[0], 0.0, top_z - (ax[2] + inner)])
    loop = (ax + t, inner, np.array([0.0, 1.0, 0.0]))
    return translated(query, t), support, (0.0, 0.0, top_z), loop


def _umbrella_on_rail():
    inner = 0.03
    rail = shapes.coat_rail()
    top = shapes.RAIL_HEIGHT + shapes.RAIL_RADIUS
    return _hang_on(umbrella(inner), rail, (0.0, 0.0, 0.0), inner, top)


def _towel_on_bar():
    inner, h, x, r = 0.014, 1.0, 0.06, 0.011
    q, s, p, loop = _hang_on(towel(inner), towel_bar(h, radius=r), (0.0, 0.0, 0.0), inner,
                             h + r)
    q = translated(q, (x, 0.0, 0.0))
    return q, s, (x, 0.0, h + r), (loop[0] + [x, 0.0, 0.0], inner, loop[2])


def _mug_on_hook():
    """The mug hung by the inside of its handle's outer bar on the hook's peg 8 cm out from
    the board, turned about y until its centre of mass hangs under that point (the lowest
    it can hang), its body 4 cm clear of the board."""
    mug = shapes.mug()
    bar = np.array([0.0675, 0.0, 0.046])        # the inside of the handle's outer bar
    centre = np.array([0.054, 0.0, 0.046])      # the handle opening's centre
    com = np.array([0.0, 0.0, 0.045])
    d = com - bar
    a = math.atan2(d[0], -d[2])                 # turns d onto -z about y
    c, s = math.cos(a), math.sin(a)
    rot = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    h, peg = 1.45, 0.005                        # the peg runs along y, 9 cm out of the board
    top = np.array([0.04, 0.0, h + peg])
    t = top - rot @ bar
    q = mug.transformed(_rigid(rot, t))
    loop = (rot @ centre + t, 0.012, np.array([0.0, 1.0, 0.0]))
    turn = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])       # its peg along +y
    b = cup_hook_board(h, peg).transformed(_rigid(turn, (0.04, -0.08, 0.0)))
    return q, b, top, loop


def _rigid(rot, t) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = rot, t
    return m


def _lying_on_bench():
    h = 0.45
    return (translated(lying_human(), (0.0, 0.0, h)), bench_mesh(height=h), (0.0, 0.0, h), None)


HANGING_RULE = affordances.get("hanging").judge
PLACING_RULE = affordances.get("placing").judge

EXAMPLES = (
    OwnExample("book-shelf", "a book standing upright on a bookcase shelf",
               "Could this book be stood up here like this?", _book_on_shelf, PLACING_RULE,
               rooms_with=("study", "lounge"), rooms_without=("rails",)),
    OwnExample("bottle-windowsill", "a bottle standing on a windowsill",
               "Could this bottle be put down here, to stand there on its own?",
               _bottle_on_sill, PLACING_RULE,
               rooms_with=("study", "lounge"), rooms_without=("rails",)),
    OwnExample("umbrella-rail", "a furled umbrella hooked on a clothes rail by its handle",
               "Could this umbrella be hung up here like this?", _umbrella_on_rail,
               HANGING_RULE, rooms_with=("hall", "study"), rooms_without=("blocks",)),
    OwnExample("towel-bar", "a towel folded over a towel bar",
               "Could this towel be hung over here like this?", _towel_on_bar, HANGING_RULE,
               rooms_with=("bathroom", "hall"), rooms_without=("blocks",)),
    OwnExample("mug-hook", "a mug hanging by its handle from a cup hook",
               "Could this mug be hung up here by its handle like this?", _mug_on_hook,
               HANGING_RULE, rooms_with=("kitchen", "hall"), rooms_without=("blocks",)),
    OwnExample("lying-bench", "a person lying on their back on a bench",
               "Could a person lie down here like this?", _lying_on_bench, LYING,
               judge_settings=dict(main_contact_radius=1.2, person_contact_fraction=0.5),
               rooms_with=("lounge", "bedroom"), rooms_without=("seats",)),
)


def example(name: str) -> OwnExample:
    for e in EXAMPLES:
        if e.name == name:
            return e
    raise KeyError(f"unknown own example {name!r}; known: {', '.join(e.name for e in EXAMPLES)}")


def check_example(ex: OwnExample) -> list[str]:
    """What is wrong with example ``ex`` as posed (empty: nothing): the judge must accept its
    own pose and refuse it lifted 5 cm off its support or pushed 3 cm into it."""
    from itensor_paper.judge import JudgeScene

    q, s, p, loop = ex.build()
    judge, js = ex.judge(), JudgeScene(s)
    wrong = []
    for what, shift, valid in (("as posed", (0, 0, 0), True), ("lifted 5 cm", (0, 0, 0.05), False),
                               ("pushed 3 cm down", (0, 0, -0.03), False)):
        pose = np.eye(4)
        pose[:3, 3] = shift
        v = judge.judge(js, pose)
        if v.valid != valid:
            wrong.append(f"{ex.name} {what}: judged {'valid' if v.valid else 'invalid'} "
                         f"({'; '.join(v.reasons) or 'no reason'})")
    return wrong


# ------------------------------------------------------------------ rooms
def _wall_piece(name: str, g: Geometry, xy, angle: float = 0.0) -> F.Piece:
    """A wall-mounted piece of the example scene-objects above (origin on the wall face)."""
    k = F._Kit()
    k.add(g)
    return k.piece(name, xy, angle, wall_mounted=True)


def _hook_board(name, xy, angle=0.0):
    """The example's cup hook board on a room's wall: its own wall face on the room's."""
    return _wall_piece(name, translated(cup_hook_board(1.45), (0.02, 0.0, 0.0)), xy, angle)


def _window(xy, angle=0.0, name="window"):
    return _wall_piece(name, translated(window_with_sill(), (0.1, 0.0, 0.0)), xy, angle)


def _study():
    return room((4.5, 4.0)), [
        F.bookcase((2.6, 0.0), 90, name="bookcase"),
        F.desk((1.4, 0.357), 90, name="desk"),
        F.office_chair((1.4, 1.157), -90, seat="round", name="office chair"),
        _window((0.0, 2.6), 0, name="window"),
        F.clothes_rail((3.6, 3.0), 0, height=1.6, length=1.0, radius=0.012, style="A",
                       name="clothes rail"),
        F.coat_pegs((0.0, 1.2), 0, height=1.7, count=3, name="coat pegs"),
    ]


def _lounge():
    return room((5.0, 4.6)), [
        F.sofa((0.465, 2.5), 0, places=3, name="sofa"),
        F.coffee_table((1.65, 2.5), 90, name="coffee table"),
        F.shelf_unit((4.3, 1.2), 180, name="shelf unit"),
        _window((2.6, 0.0), 90, name="window"),
        F.bench((2.8, 4.0), 0, length=1.9, depth=0.5, height=0.45, name="bench"),
    ]


def _hall():
    return room((4.0, 4.0)), [
        F.coat_pegs((0.0, 1.0), 0, height=1.7, count=4, name="coat pegs"),
        F.clothes_rail((2.6, 2.4), 90, height=1.5, length=1.0, radius=0.015, name="rail"),
        _wall_piece("towel bar", towel_bar(1.0), (0.0, 2.6)),
        _hook_board("cup hooks", (1.6, 0.0), 90),
        F.bench((2.0, 0.4), 0, length=1.2, depth=0.35, name="bench"),
    ]


def _bathroom():
    return room((3.0, 3.0)), [
        F.washbasin((0.0, 1.0), 0, name="washbasin"),
        _wall_piece("towel bar", towel_bar(1.1), (0.0, 2.2)),
        _wall_piece("towel rail", towel_bar(0.9, length=0.5, radius=0.013), (1.8, 0.0), 90),
        F.wall_shelves((1.0, 0.0), 90, boards=(1.3, 1.6), length=0.6, name="shelves"),
    ]


def _kitchen():
    return room((4.0, 4.0)), [
        F.kitchen_counter((0.0, 1.8), 0, length=2.4, sinks=(), wall_cabinet=(0.1, 1.25),
                          name="counter"),
        _hook_board("cup hook 1", (2.4, 0.0), 90),
        _hook_board("cup hook 2", (2.8, 0.0), 90),
        F.dining_table((2.8, 2.8), 0, name="dining table"),
        F.dining_chair((2.4, 2.05), 90, name="chair"),
    ]


def _bedroom():
    return room((4.5, 4.5)), [
        F.bed((1.062, 3.2), 0, name="bed"),
        F.side_table((0.25, 2.2), 0, size=(0.4, 0.4), height=0.5, name="bedside table"),
        F.bench((3.0, 0.6), 0, length=1.9, depth=0.5, height=0.45, name="bench"),
    ]


def _rails():
    """No floor (a scan of a coat corner): round rails and pegs, nothing flat."""
    return [], [
        F.clothes_rail((0.8, 1.0), 0, height=1.6, length=1.0, radius=0.012, style="A",
                       name="rail 1"),
        F.clothes_rail((2.2, 1.0), 0, height=1.4, length=1.2, radius=0.015, style="A",
                       name="rail 2"),
        F.coat_pegs((3.0, 0.5), 0, height=1.7, count=4, name="coat pegs"),
    ]


def _blocks():
    """Solid furniture and nothing to hook on: no edge thin enough, no rail."""
    return room((4.5, 4.5)), [
        F.fridge((0.0, 3.5), 0),
        F.sofa((0.465, 1.6), 0, places=3, name="sofa"),
        F.armchair((3.2, 3.6), -90, name="armchair"),
        F.plant_pot((3.8, 0.6)),
    ]


def _seats():
    """No floor: chairs and stools, nothing long enough to lie on."""
    return [], [
        F.dining_chair((0.5, 0.5), 0, name="chair 1"),
        F.dining_chair((1.5, 0.5), 90, name="chair 2"),
        F.stool((2.5, 0.5), 0, name="stool"),
        F.bar_stool((3.4, 0.5), 0, name="bar stool"),
        F.office_chair((1.0, 1.8), 0, seat="square", name="office chair"),
    ]


ROOMS = {"study": _study, "lounge": _lounge, "hall": _hall, "bathroom": _bathroom,
         "kitchen": _kitchen, "bedroom": _bedroom, "rails": _rails, "blocks": _blocks,
         "seats": _seats}


def build_room(name: str) -> ValidationScene:
    if name not in ROOMS:
        raise KeyError(f"unknown room {name!r}; known: {', '.join(ROOMS)}")
    shell, pieces = ROOMS[name]()
    return compose(name, pieces, shell)


# ------------------------------------------------------------------ the measurement
@dataclass
class OwnSettings:
    """How :func:`evaluate` runs: the user's defaults (:func:`interaction_tensor.detect`'s)
    unless set. ``top_k``: the predictions judged per room."""

    examples: tuple = tuple(e.name for e in EXAMPLES)
    top_k: int = 10
    sample_fraction: float | None = None
    seed: int = 0


ROW_COLUMNS = ["example", "room", "holds_place", "pairs", "accepted_pairs", "places",
               "predictions", "valid", "first_invalid", "threshold", "seconds"]


def evaluate(settings: OwnSettings = OwnSettings(), output=None, log=print) -> list[dict]:
    """One row per (example, room): each example trained as a user trains their own pair
    (no preset) and detected in its rooms with detect's defaults; the accepted top
    predictions judged (``valid`` of ``predictions``; ``first_invalid``: the first
    rejected one's rank, position and the judge's reasons). With ``output``, each result
    is saved there as ``itensor detect -o`` saves it (``EXAMPLE_ROOM/``, with its picture)."""
    import time

    import interaction_tensor as it
    from itensor_paper.judge import JudgeScene

    rows = []
    for name in settings.examples:
        ex = example(name)
        q, s, _, _ = ex.build()
        tensor = it.train(q, s, affordance=ex.name, seed=settings.seed)
        judge = ex.judge()
        for room_name, holds in ([(r, True) for r in ex.rooms_with]
                                 + [(r, False) for r in ex.rooms_without]):
            scene = build_room(room_name)
            opts = dict(top_k=settings.top_k, seed=settings.seed)
            if settings.sample_fraction is not None:
                opts["sample_fraction"] = settings.sample_fraction
            t0 = time.perf_counter()
            det = it.detect(scene.geometry, tensor, **opts)
            secs = time.perf_counter() - t0
            if output is not None:
                det.save(Path(output) / f"{name}_{room_name}", scene_name=room_name)
            js = JudgeScene(scene.geometry, seed=settings.seed)
            valid, first = 0, ""
            for rank, pred in enumerate(det.predictions, 1):
                v = judge.judge(js, pred.pose)
                valid += bool(v.valid)
                if not v.valid and not first:
                    first = (f"#{rank} at {np.round(pred.position, 2).tolist()}: "
                             + "; ".join(v.reasons))
            rows.append({"example": name, "room": room_name, "holds_place": holds,
                         "pairs": int(det.stats["pairs"]),
                         "accepted_pairs": int(det.stats["pairs_accepted"]),
                         "places": len(det.places), "predictions": len(det.predictions),
                         "valid": valid, "first_invalid": first,
                         "threshold": round(float(det.stats["threshold"]), 4),
                         "seconds": round(secs, 1)})
            log(f"{name:18s} {room_name:9s} {'place' if holds else 'none ':5s} "
                f"accepted {rows[-1]['accepted_pairs']:>7,} places {rows[-1]['places']:>3} "
                f"valid {valid}/{len(det.predictions)} {secs:5.0f} s  {first[:90]}")
    return rows


def summary(rows: list[dict]) -> list[dict]:
    """Per example: the accepted top predictions' precision over its rooms, the rooms that
    hold a place with at least one valid accepted prediction, the rooms that hold none
    with nothing accepted."""
    out = []
    for name in dict.fromkeys(r["example"] for r in rows):
        mine = [r for r in rows if r["example"] == name]
        acc = sum(r["predictions"] for r in mine)
        val = sum(r["valid"] for r in mine)
        w = [r for r in mine if r["holds_place"]]
        wo = [r for r in mine if not r["holds_place"]]
        out.append({"example": name, "valid": val, "accepted": acc,
                    "precision": round(100.0 * val / acc, 1) if acc else float("nan"),
                    "rooms_with_found": sum(r["valid"] > 0 for r in w), "rooms_with": len(w),
                    "rooms_without_silent": sum(r["predictions"] == 0 for r in wo),
                    "rooms_without": len(wo)})
    return out


def summary_markdown(rows: list[dict]) -> str:
    lines = ["| example | accepted top valid | % | rooms with a place: one found | "
             "rooms with none: nothing accepted |", "|---|---:|---:|---:|---:|"]
    for s in summary(rows):
        pct = "n/a" if not s["accepted"] else s["precision"]
        lines.append(f"| {s['example']} | {s['valid']}/{s['accepted']} | {pct} | "
                     f"{s['rooms_with_found']}/{s['rooms_with']} | "
                     f"{s['rooms_without_silent']}/{s['rooms_without']} |")
    return "\n".join(lines)


def write(rows: list[dict], out) -> Path:
    """``own.csv`` (one row per example and room) and ``own.md`` (the summary table) in
    ``out``, each written whole or not at all. Returns ``out``."""
    from interaction_tensor.geometry.files import atomic_path
    from itensor_paper.common import write_csv

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "own.csv", rows, ROW_COLUMNS)
    with atomic_path(out / "own.md") as tmp:
        tmp.write_text(MARKDOWN_HEAD + summary_markdown(rows) + "\n")
    return out


MARKDOWN_HEAD = """# Interactions of a user's own, untuned

Each example trained as a user trains a pair of their own (`it.train(query, scene_object)`,
no acceptance preset) and detected with `it.detect`'s defaults in procedural rooms that hold
a place for it and rooms that hold none; its accepted top 10 judged (definitions in
`paper/src/itensor_paper/own.py`; regenerate with `itensor paper own -o results/own
--summary paper/results`).

"""
