"""A labelled set of valid and invalid poses that proves the judge, per affordance.

Each :class:`LabelledPose` is a pose of one example's query object (4x4, training frame ->
scene) in a named scene, with a label given by construction, not by the judge: a valid pose
puts the object on a site that the scene's builder made for that interaction
(:mod:`.rooms.furniture`: a seat, a rail, a tap over a basin...) the way the example
has it; an invalid one is a hard negative made from a site or from a surface that does not
afford the interaction (sunk into the seat, hovering, through a table top or a wall, half off
an edge, under a shelf with no tap, sitting on a wide seat instead of astride...). The poses
in the published scenes were placed by hand at measured furniture (see :data:`HAND_POSED`).

:func:`generate` makes the set (``scripts/make_labelled_set.py`` writes it to
``evaluation/data/labelled_poses.json``), :func:`load` reads it, and :func:`judge_accuracy`
judges every pose and counts agreement per affordance and class. Scenes are named
``validation:<name>`` (:mod:`.rooms.validation`) or ``shared:<path>`` (a file under the
shared data directory, e.g. ``shared:scenes/office-desk1.ply``).
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from interaction_tensor import affordances
from interaction_tensor.errors import InputError
from interaction_tensor.examples.posing import surface_points
from interaction_tensor.geometry.files import atomic_path
from interaction_tensor.geometry.load import load_geometry
from interaction_tensor.placement import checks
from itensor_paper.judge import Judge, JudgeScene, tilt_degrees
from itensor_paper.rooms import validation

DATA_FILE = Path(__file__).resolve().parent / "data" / "labelled_poses.json"
FORMAT = "interaction-tensor-labelled-poses"
FORMAT_VERSION = 1
#: Hang sites on the top edge of a panel (no room below the hook for a rigid hanger).
PANEL = re.compile(r"door|divider|panel|side")
#: Seats at least 0.4 m wide (a round stool can be straddled; these cannot).
#: The widest support a rider can sit astride (m): the example rider's legs are 7 cm apart
#: from the seat down to the feet, and no body part goes more than 2 cm into the scene.
RIDER_SUPPORT_WIDTH = 0.11
#: Supports built to be ridden, whose body narrows under the seat between the legs.
RIDEABLE = re.compile(r"motorbike")
WIDE_SEAT = re.compile(r"sofa|bed|armchair|dining chair|office chair|bench seat")
#: Place sites on a high working top (no board above it) where a person could be posed
#: sitting on the edge with the feet in the air (valid within reach of the floor).
HIGH_TOP = re.compile(r"counter|island|breakfast bar|workbench|kitchenette")
#: How far (m) a board's underside reaches into the top of a hook's opening in the "pushed
#: up into a board's underside" negatives: past the wire (the example's through-section
#: keeps 2.5 mm from it) by a quarter of a millimetre, short of the judge's loop disk
#: (3.5 mm inside the wire): a graze, with nothing through the hook.
GRAZE = 0.00275
#: How far (m) behind a seat's front edge a seated person's calves are in the "knees behind
#: the seat's front edge" negatives: the tops of the shins 3 cm into the seat's top at the
#: knees, more than the 2 cm the judge lets a person's body into the scene.
KNEE_BEHIND = 0.03
#: The example judged for each affordance in the labelled set.
EXAMPLE_OF = {"placing": "placing-bowl", "filling": "filling-mug",
              "hanging": "hanging-hanger", "sitting": "sitting-human",
              "riding": "riding-human"}


@dataclass
class LabelledPose:
    """One labelled pose.

    Attributes
    ----------
    affordance, example : e.g. ``sitting``, ``sitting-human``
    scene : ``validation:<name>`` or ``shared:<relative path>``
    pose : 4x4 nested list, the example's training-frame query object -> scene
    valid : the label
    case : what kind of case it is, e.g. ``seat`` or ``sunk 10 cm into the seat``
    note : where (the site's note)
    """

    affordance: str
    example: str
    scene: str
    pose: list
    valid: bool
    case: str
    note: str


# ------------------------------------------------------------------ poses
def site_pose(example, point, angle: float, shift=(0.0, 0.0, 0.0)) -> np.ndarray:
    """4x4: the example's support point to ``point`` (3,), the query turned by ``angle``
    (radians, about +Z), then moved by ``shift`` (3,) in scene axes."""
    c, s = math.cos(angle), math.sin(angle)
    m = np.eye(4)
    m[:2, :2] = [[c, -s], [s, c]]
    m[:3, 3] = np.asarray(point, float) + np.asarray(shift, float) - m[:3, :3] @ example.support_point
    return m


def facing_angle(example, facing) -> float:
    """Angle (radians) that turns the example onto a site whose ``facing`` is given: a person
    faces +x in the training frame; a hook's support runs along +y."""
    a = math.atan2(facing[1], facing[0])
    return a - math.pi / 2 if example.spec.affordance == "hanging" else a


def seated_reach(example) -> tuple[float, float]:
    """How far (m) a seated person reaches along its facing from the support point: its back
    behind it (above the seat) and its calves ahead of it (from 10 cm below the seat down to
    10 cm above the floor). Training frame, facing +x."""

    q = surface_points(example.query, 20000)
    s = example.support_point
    back = float(s[0] - q[q[:, 2] > s[2] + 0.05, 0].min())
    calves = q[(q[:, 2] < s[2] - 0.1) & (q[:, 2] > q[:, 2].min() + 0.1)]
    return back, float(calves[:, 0].min() - s[0])


def edge_distance(points_tree, points, start, direction, z, step=0.01, reach=1.5) -> float:
    """Distance (m) from ``start`` along the horizontal ``direction`` to where the surface at
    height ``z`` ends: the first point with no sample within 2.5 cm horizontally and 1 cm
    vertically (wider than the gaps random 1 cm samples leave)."""
    d = np.asarray(direction, float)
    d = d / np.linalg.norm(d)
    for t in np.arange(0.0, reach, step):
        p = np.r_[np.asarray(start, float)[:2] + t * d[:2], z]
        near = np.asarray(points_tree.query_ball_point(p, 0.03), np.int64)
        q = points[near]
        if not np.any((np.abs(q[:, 2] - z) <= 0.01)
                      & (np.hypot(q[:, 0] - p[0], q[:, 1] - p[1]) <= 0.025)):
            return float(t)
    return float(reach)


def _knee_offset(example) -> float:
    """How far (m) a seated person's knees are from its mid-plane: the median lateral offset
    of its surface within 5 cm below the seat and ahead of it (the tops of the shins)."""

    q = surface_points(example.query, 20000)
    s = example.support_point
    band = q[(q[:, 2] < s[2]) & (q[:, 2] > s[2] - 0.05) & (q[:, 0] > s[0] + 0.1)]
    return float(np.median(np.abs(band[:, 1] - s[1])))


def _last_sample(points_tree, points, start, direction, reach: float) -> float:
    """Distance (m) from ``start`` along the horizontal ``direction`` to the farthest scene
    sample within 2 cm of that line horizontally and 1 cm of ``start``'s height, no farther
    than ``reach`` (an :func:`edge_distance`, which overshoots the edge by up to 2.5 cm):
    where the surface really ends, to the samples' spacing."""
    d = np.asarray(direction, float)[:2]
    d = d / np.linalg.norm(d)
    s = np.asarray(start, float)
    mid = np.r_[s[:2] + 0.5 * reach * d, s[2]]
    near = np.asarray(points_tree.query_ball_point(mid, 0.5 * reach + 0.03), np.int64)
    q = points[near] - s
    along = q[:, :2] @ d
    across = np.abs(q[:, 0] * d[1] - q[:, 1] * d[0])
    on = (along >= 0) & (along <= reach) & (across <= 0.02) & (np.abs(q[:, 2]) <= 0.01)
    return float(along[on].max()) if on.any() else 0.0


def _feet_samples(example) -> np.ndarray:
    """(N, 3) a seated person's surface samples within 12 cm of its lowest point (its feet),
    training frame."""

    q = surface_points(example.query, 20000)
    return q[q[:, 2] <= q[:, 2].min() + 0.12]


def _nothing_under(scene_points, feet, pose, floor_gap: float = 0.05) -> bool:
    """Whether no scene sample lies under the posed ``feet`` (their horizontal bounding box,
    2 cm wider) between ``floor_gap`` above the scene's lowest point and the soles."""
    f = feet @ pose[:3, :3].T + pose[:3, 3]
    lo, hi = f[:, :2].min(axis=0) - 0.02, f[:, :2].max(axis=0) + 0.02
    col = scene_points[np.all((scene_points[:, :2] >= lo) & (scene_points[:, :2] <= hi), axis=1)]
    floor = scene_points[:, 2].min() + floor_gap
    return not np.any((col[:, 2] > floor) & (col[:, 2] <= f[:, 2].min()))


def _upper_body_samples(example, below: float = 0.05) -> np.ndarray:
    """(N, 3) a seated person's surface samples higher than ``below`` under its seat point
    (the buttocks, the thighs, the body, the arms and the head), training frame."""

    q = surface_points(example.query, 20000)
    return q[q[:, 2] > example.support_point[2] - below]


def _clear_above(scene_points, body, pose, top: float, margin: float = 0.03) -> bool:
    """Whether no scene sample lies over the posed ``body`` (its horizontal bounding box,
    ``margin`` wider) between 2 cm above the ``top`` it sits on and 10 cm over its head:
    nothing on or above the top (a wall cabinet, a shelf, a raised back) where the person
    sitting on it is."""
    b = body @ pose[:3, :3].T + pose[:3, 3]
    lo, hi = b[:, :2].min(axis=0) - margin, b[:, :2].max(axis=0) + margin
    col = scene_points[np.all((scene_points[:, :2] >= lo) & (scene_points[:, :2] <= hi),
                              axis=1)]
    return not np.any((col[:, 2] > top + 0.02) & (col[:, 2] < b[:, 2].max() + 0.1))


def _below_hook(example, drop: float = 0.02) -> np.ndarray:
    """(N, 3) a hanging example's surface samples more than ``drop`` below its support point
    (the hanger's body under the hook), training frame."""

    q = surface_points(example.query, 20000)
    return q[q[:, 2] < example.support_point[2] - drop]


def _underside(jscene, point, depth: float = 0.1, radius: float = 0.01):
    """Height (m) of the underside of the board whose top ``point`` (3,) is on: the highest
    sample within ``radius`` horizontally of it and between 3 mm and ``depth`` below it, whose
    normal points down; None under a solid block (a counter) or with nothing there."""
    p = np.asarray(point, float)
    near = np.asarray(jscene.tree.query_ball_point(p - [0.0, 0.0, depth / 2],
                                                   depth / 2 + radius), np.int64)
    q = jscene.points[near]
    under = ((np.hypot(q[:, 0] - p[0], q[:, 1] - p[1]) <= radius)
             & (q[:, 2] <= p[2] - 0.003) & (q[:, 2] >= p[2] - depth)
             & (jscene.normals[near, 2] < -0.9))
    return float(q[under, 2].max()) if under.any() else None


def _wall_behind(jscene, point, out_of_wall, reach: float = 0.3):
    """How far (m) behind ``point`` (against ``out_of_wall``) the wall's face is: the nearest
    sample within 5 cm of that line whose normal runs along it (a wall, not the peg), or
    None."""
    d = np.asarray(out_of_wall, float)
    near = np.asarray(jscene.tree.query_ball_point(np.asarray(point, float) - 0.5 * reach * d,
                                                   0.5 * reach + 0.05), np.int64)
    rel = jscene.points[near] - point
    along = -(rel @ d)
    off = np.linalg.norm(rel + np.outer(along, d), axis=1)
    wall = (along > 0.02) & (off <= 0.05) & (np.abs(jscene.normals[near] @ d) > 0.9)
    return float(along[wall].min()) if wall.any() else None


# ------------------------------------------------------------------ generation
def _entry(ex, scene, pose, valid, case, note) -> LabelledPose:
    return LabelledPose(ex.spec.affordance, ex.spec.name, scene,
                        np.round(np.asarray(pose, float), 6).tolist(), bool(valid), case, note)


def _validation_poses(ex, name, vs, jscene) -> list:
    """Poses of example ``ex`` in validation scene ``vs`` (label by construction)."""
    from scipy.spatial import cKDTree

    aff = ex.spec.affordance
    scene = f"validation:{name}"
    out = []
    by = {k: [s for s in vs.sites if s.kind == k] for k in ("seat", "astride", "hang", "place",
                                                            "fill")}
    tree = cKDTree(jscene.points)

    def add(pose, valid, case, note):
        out.append(_entry(ex, scene, pose, valid, case, note))

    if aff == "sitting":
        back, calves = seated_reach(ex)
        knee = _knee_offset(ex)
        for i, s in enumerate(by["seat"]):
            a = facing_angle(ex, s.facing)
            f = np.r_[s.facing, 0.0]
            # where a person sits on this seat: the back clear of the backrest, the calves in
            # front of the seat's front edge (a deep sofa: sitting forward)
            front = edge_distance(tree, jscene.points, s.point, f, s.point[2])
            fwd = max(0.0, back + 0.03 - s.width if math.isfinite(s.width) else 0.0,
                      front + 0.01 - calves)
            add(site_pose(ex, s.point, a, fwd * f), True, "seat", s.note)
            gap = s.width + fwd - back               # the back to the backrest
            if gap < 0.035:
                # a chair whose backrest, not the seat's depth, set where the person sits:
                # the back 3.5 cm into the backrest, the legs as free as on the seat
                add(site_pose(ex, s.point, a, (fwd - gap - 0.035) * f), False,
                    "leaning 3.5 cm into the backrest", s.note)
            # moved back until the calves are KNEE_BEHIND behind the seat's front edge: the
            # tops of the shins through the seat's top at the knees (the published scenes'
            # counters, tables and TV units, sat on at their edge), the back still clear of
            # any backrest
            side = np.r_[-f[1], f[0], 0.0]
            edge = min(_last_sample(tree, jscene.points, s.point + k * knee * side, f, front)
                       for k in (1, -1))              # under each knee (a round seat)
            back_to = edge - KNEE_BEHIND - calves
            if not math.isfinite(s.width) or s.width + back_to - back >= 0.0:
                add(site_pose(ex, s.point, a, back_to * f), False,
                    f"knees {KNEE_BEHIND * 100:.0f} cm behind the seat's front edge", s.note)
            add(site_pose(ex, s.point, a, fwd * f + [0, 0, -0.04]), False,
                "sunk 4 cm into the seat", s.note)
            if i % 2 == 0:
                add(site_pose(ex, s.point, a, fwd * f + [0, 0, -0.10]), False,
                    "sunk 10 cm into the seat", s.note)
            else:
                add(site_pose(ex, s.point, a, fwd * f + [0, 0, 0.10]), False,
                    "hovering 10 cm above the seat", s.note)
            if math.isfinite(s.width) and re.search("sofa|armchair", s.note):
                # a solid upholstered back (a ladder-back chair could be straddled)
                add(site_pose(ex, s.point, a + math.pi), False, "facing the backrest", s.note)
        ahead = np.array([math.cos(0.3), math.sin(0.3), 0.0])
        for s in by["place"][::3]:
            # the top goes on past the calves (near its edge the legs hang over it)
            if s.point[2] > 0.6 and edge_distance(tree, jscene.points, s.point, ahead,
                                                  s.point[2]) >= calves:
                add(site_pose(ex, s.point, 0.3), False, "on a table top, legs through it",
                    s.note)
        feet, upper = _feet_samples(ex), _upper_body_samples(ex)
        for s in by["place"]:
            if s.point[2] >= 0.85 and HIGH_TOP.search(s.note):
                # on the edge of a counter or a workbench, facing out over its nearest edge
                # with nothing under the feet down to the floor: the thighs on the top, the
                # calves 1 cm past the edge, the feet 40 cm or more in the air (the
                # published scenes' kitchens: people on counters), within reach of the
                # floor (the blind panel passed people on desks and counters so)
                angles = np.arange(16) * (math.pi / 8)
                dirs = np.c_[np.cos(angles), np.sin(angles), np.zeros(16)]
                reach = np.array([edge_distance(tree, jscene.points, s.point, d, s.point[2])
                                  for d in dirs])
                for k in np.argsort(reach, kind="stable"):
                    pose = site_pose(ex, s.point, float(angles[k]),
                                     (reach[k] + 0.01 - calves) * dirs[k])
                    if _nothing_under(jscene.points, feet, pose):
                        # valid within reach of the floor, with nothing above the top near
                        # the body and the edge square across the thighs, under both knees
                        # (under a wall cabinet, or across a corner with a knee over the
                        # top, it is neither: left out)
                        reach_ok = s.point[2] <= checks.SEAT_REACH
                        side = np.r_[-dirs[k, 1], dirs[k, 0], 0.0]
                        square = all(abs(edge_distance(tree, jscene.points,
                                                       s.point + j * knee * side, dirs[k],
                                                       s.point[2]) - reach[k]) <= 0.02
                                     for j in (1, -1))
                        if not reach_ok or (square and _clear_above(jscene.points, upper,
                                                                    pose, s.point[2])):
                            add(pose, reach_ok, "on a high top's edge, feet dangling"
                                + (" within reach" if reach_ok else ", out of reach"), s.note)
                        break
    elif aff == "riding":
        for i, s in enumerate(by["astride"]):
            a = facing_angle(ex, s.facing)
            if s.width <= RIDER_SUPPORT_WIDTH or RIDEABLE.search(s.note):
                add(site_pose(ex, s.point, a), True, "astride", s.note)
                add(site_pose(ex, s.point, a + math.pi), True, "astride, facing the other way",
                    s.note)
            else:
                add(site_pose(ex, s.point, a), False,
                    "astride a support wider than the legs are apart, legs through it", s.note)
            add(site_pose(ex, s.point, a + math.pi / 2), False, "across the support, not astride",
                s.note)
            if i % 2 == 0:
                add(site_pose(ex, s.point, a, (0, 0, 0.12)), False, "hovering 12 cm", s.note)
            else:
                add(site_pose(ex, s.point, a, (0, 0, 0.06)), False, "hovering 6 cm", s.note)
        for s in by["seat"]:
            if WIDE_SEAT.search(s.note):
                add(site_pose(ex, s.point, facing_angle(ex, s.facing)), False,
                    "on a wide seat, not astride", s.note)
    elif aff == "hanging":
        for i, s in enumerate(by["hang"]):
            a = facing_angle(ex, s.facing)
            if PANEL.search(s.note):
                # a panel (door, divider, shelf side) under its top edge: the rigid hanger
                # hangs across the edge, so its shoulders go through the panel
                add(site_pose(ex, s.point, a), False, "hook over a panel top, body through the panel",
                    s.note)
                continue
            add(site_pose(ex, s.point, a + (math.pi if i % 2 else 0.0)), True, "hook over the support",
                s.note)
            if i % 3 == 0:
                add(site_pose(ex, s.point, a, (0, 0, 0.05)), False, "hovering 5 cm above the support",
                    s.note)
            elif i % 3 == 1:
                add(site_pose(ex, s.point, a + math.pi / 2), False,
                    "turned along the support: the hook wire lies on it", s.note)
            else:
                side = np.r_[-s.facing[1], s.facing[0], 0.0]
                add(site_pose(ex, s.point, a, 0.08 * side), False, "8 cm beside the support",
                    s.note)
            if "peg" in s.note:
                out_of_wall = np.r_[s.facing, 0.0]
                add(site_pose(ex, s.point, a, -0.12 * out_of_wall), False,
                    "pushed 12 cm back along the peg, through the wall", s.note)
                under = np.asarray(s.point, float) - [0.0, 0.0, 0.3]
                back = _wall_behind(jscene, under, out_of_wall)
                if back is not None:
                    # 30 cm under the peg (below the pegs' board), the hanger's plane in the
                    # wall's face: the wall lies in the hook's opening, nothing goes through
                    # it (random wall points of a validation room gave such hooks that the
                    # judge passed; its loop test now asks for a surface across the loop)
                    add(site_pose(ex, under, a, -back * out_of_wall), False,
                        "flat against the wall under the peg", s.note)
        for s in by["place"][::2]:
            add(site_pose(ex, s.point, 0.7), False, "hook on a flat top, hanger through it",
                s.note)
        body = _below_hook(ex)
        for i, s in enumerate(by["place"][1::2]):
            under = _underside(jscene, s.point)
            if under is None:
                continue
            pose = site_pose(ex, np.r_[s.point[:2], under + GRAZE], 0.4 + 0.8 * i)
            if jscene.tree.query(body @ pose[:3, :3].T + pose[:3, 3])[0].min() >= 0.01:
                # the hook pushed up into a board's underside, the wire in the board and the
                # hanger hanging free below it: the board grazes the top of the opening and
                # nothing goes through it (scans' wall cabinets and seat undersides gave
                # such hooks that detection's through test passed)
                add(pose, False, "hook pushed up into a board's underside, hanging free",
                    s.note)
    elif aff == "placing":
        for i, s in enumerate(by["place"]):
            a = 0.4 * i
            add(site_pose(ex, s.point, a), True, "on a free top", s.note)
            if i % 3 == 0:
                d = np.array([math.cos(a), math.sin(a), 0.0])
                t = edge_distance(tree, jscene.points, s.point, d, s.point[2])
                add(site_pose(ex, s.point, a, (t + 0.005) * d), False, "half off the edge",
                    s.note)
            elif i % 3 == 1:
                add(site_pose(ex, s.point, a, (0, 0, -0.03)), False, "sunk 3 cm into the top",
                    s.note)
            else:
                add(site_pose(ex, s.point, a, (0, 0, 0.05)), False, "floating 5 cm", s.note)
    elif aff == "filling":
        for i, s in enumerate(by["fill"]):
            for j, a in enumerate((0.0, 2.0, 4.0)):
                off = 0.01 * np.array([math.cos(1.7 * (i + j)), math.sin(1.7 * (i + j)), 0.0])
                add(site_pose(ex, s.point, a, off), True, "in the basin under the tap", s.note)
            side = np.array([-s.facing[1], s.facing[0], 0.0])
            add(site_pose(ex, s.point, 1.0, 0.12 * side), False,
                "in the basin 12 cm beside the outlet", s.note)
            add(site_pose(ex, s.point, 1.0, (0, 0, 0.04)), False, "floating 4 cm under the tap",
                s.note)
        for s in by["place"][::2]:
            add(site_pose(ex, s.point, 0.5), False, "on a top with no tap above", s.note)
    return out


def generate(objects_dir=None, shared_dir=None, scenes=None, log=print) -> list:
    """The labelled set: every validation scene (or ``scenes``) for each affordance's example,
    plus the hand-posed cases in the published scenes when ``shared_dir`` is given."""

    names = list(scenes) if scenes else validation.scene_names()
    examples = {a: affordances.build(n, objects_dir) for a, n in EXAMPLE_OF.items()}
    out = []
    for name in names:
        vs = validation.build_scene(name)
        jscene = JudgeScene(vs.geometry)
        for aff, ex in examples.items():
            got = _validation_poses(ex, name, vs, jscene)
            out += got
        log(f"{name}: {len(out)} poses so far")
    if scenes is None:
        # the judge-only traps: a mug under a narrow bar, not in a basin
        ex = examples["filling"]
        for point, note in validation.JUDGE_TRAPS:
            for angle in (0.0, 2.0):
                out.append(_entry(ex, "validation:judge_traps", site_pose(ex, point, angle),
                                  False, "under a bar, not in a basin", note))
        # people on the edges of the counter block, whose front is flush with its top: the
        # calves 1 cm off the front, the feet in the air beside it, within reach of the
        # floor (a judge that took the front's face under the heels for a floor found the
        # feet on it: office-desk1's desk)
        ex = examples["sitting"]
        _, calves = seated_reach(ex)
        for point, angle, note in validation.flush_counter_edges():
            d = np.array([math.cos(angle), math.sin(angle), 0.0])
            out.append(_entry(ex, "validation:judge_traps",
                              site_pose(ex, point, angle, (0.01 - calves) * d), True,
                              "on a flush-fronted counter's edge, feet dangling beside its "
                              "front", note))
        # people on the stepped units' upper blocks with the feet on the step: a seat with a
        # foot rest 20 cm above the floor, and the top of a tall unit with the feet 1.2 m
        # up (living-room4's top seats: on a 3 m wall unit, the feet on its lower ledge)
        for point, angle, step, note in validation.stepped_unit_seats():
            d = np.array([math.cos(angle), math.sin(angle), 0.0])
            low = step < 0.5
            out.append(_entry(ex, "validation:judge_traps",
                              site_pose(ex, point, angle, (0.01 - calves) * d), low,
                              "seat with the feet on a step 20 cm above the floor" if low
                              else "on top of a tall unit, the feet on a step 1.2 m above the "
                              "floor", note))
        # people on the front edge of a bench with a footstool pushed against it: the knees
        # over the stool's top, the shins and feet 20-30 cm inside it (the published
        # scenes' people on a desk with the legs down through its drawer unit; only the
        # legs cross the scene, which the judge allows 10 cm)
        for point, angle, note in validation.footstool_bench_seats():
            d = np.array([math.cos(angle), math.sin(angle), 0.0])
            out.append(_entry(ex, "validation:judge_traps",
                              site_pose(ex, point, angle, (0.01 - calves) * d), False,
                              "on a bench's edge, the legs through a footstool against it",
                              note))
        # people on the open edges of the traps' floor slab, the legs hanging below it into
        # the void past the scan (fooled the judge in kitchen4: nothing under the feet, and
        # the feet 42 cm below the lowest thing scanned around)
        for point, angle, note in validation.floor_edge_seats():
            d = np.array([math.cos(angle), math.sin(angle), 0.0])
            out.append(_entry(ex, "validation:judge_traps",
                              site_pose(ex, point, angle, (0.01 - calves) * d), False,
                              "on a floor's open edge, legs hanging below it", note))
        # riders astride the top of a low wall (0.9 m: pretend riding) and of partitions of
        # 1.4, 1.6 and 2.4 m (out of reach, the feet dangling 0.5-1.5 m above the floor; the
        # published kitchens' top riders straddled their 2.4-2.7 m walls)
        ex = examples["riding"]
        for point, angle, height, note in validation.wall_top_rides():
            low = height < 1.2
            out.append(_entry(ex, "validation:judge_traps",
                              site_pose(ex, point, angle),
                              low, "astride a low wall's top" if low else
                              f"astride a {height:g} m partition's top, out of reach", note))
        # riders on a 0.3 m bench whose front rises 3 cm 10-12 cm ahead of the seat, as a
        # saddle rises to a tank: the legs, 7 cm apart, go through the bench
        for point, angle, note in validation.saddle_rides():
            out.append(_entry(ex, "validation:judge_traps", site_pose(ex, point, angle), False,
                              "astride a bench with a raised front, legs through the bench",
                              note))
        log(f"judge_traps: {len(out)} poses so far")
        # a hook round an office chair's star-base leg in a scan without its floor: the
        # hanger hangs through where the floor is (fooled the judge in office-desk6); and
        # hangers on a clothes rail in the same floorless scan, which hang free
        ex = examples["hanging"]
        vs = validation.build_scene("floorless_traps")
        for point, d, note in validation.star_base_hooks(vs):
            angle = math.atan2(d[1], d[0]) - math.pi / 2        # the support along its +y
            out.append(_entry(ex, "validation:floorless_traps", site_pose(ex, point, angle),
                              False, "hook on a chair's star base, hanging through the floor "
                              "line of a floorless scan", note))
        for i, s in enumerate(x for x in vs.sites if x.kind == "hang"):
            a = facing_angle(ex, s.facing) + (math.pi if i % 2 else 0.0)
            out.append(_entry(ex, "validation:floorless_traps", site_pose(ex, s.point, a), True,
                              "hook over a rail in a floorless scan", s.note))
        log(f"floorless_traps: {len(out)} poses so far")
        # hangers turned level on their support, the hook still round it (the judge's upright
        # test: gravity swings a hanger down; nothing else in the judge sees it)
        ex = examples["hanging"]
        hangs = [p for p in out if p.affordance == "hanging" and p.valid
                 and p.scene.startswith("validation:")]
        for i, p in enumerate(hangs):
            out.append(_entry(ex, p.scene, level_on_support(ex, np.asarray(p.pose, float),
                                                            (-1) ** i * math.pi / 2),
                              False, "turned level on its support, the hook still round it",
                              p.note))
        log(f"level hangers: {len(out)} poses so far")
    if shared_dir is not None:
        for aff, scene, point, angle, valid, case, note in HAND_POSED:
            ex = examples[aff]
            shift = (0.0, 0.0, 0.0)
            out.append(_entry(ex, f"shared:{scene}", site_pose(ex, point, angle, shift), valid,
                              case, note))
        for aff, scene, pose, valid, case, note in HAND_POSED_POSES:
            out.append(_entry(examples[aff], f"shared:{scene}", pose, valid, case, note))
    return out


def level_on_support(example, pose, angle: float, below: float = 0.01) -> np.ndarray:
    """A hanging pose turned by ``angle`` (radians) about the support: the line along the
    hook's loop axis ``below`` m under the example's support point (about a rail's or peg's
    axis), so that the hook stays round the support while the hanger leaves the vertical."""
    from scipy.spatial.transform import Rotation

    rot = pose[:3, :3]
    axis = rot @ np.asarray(example.loop[2], float)
    centre = rot @ (np.asarray(example.support_point, float) - [0.0, 0.0, below]) + pose[:3, 3]
    turn = np.eye(4)
    turn[:3, :3] = Rotation.from_rotvec(axis / np.linalg.norm(axis) * angle).as_matrix()
    turn[:3, 3] = centre - turn[:3, :3] @ centre
    return turn @ pose


#: Hand-posed cases in the published scenes: (affordance, scene file under the shared data
#: directory, support point (3,) on the furniture's top (found by casting rays down on a 5 cm
#: grid), angle (radians), valid, case, note). Each was drawn (close-ups from four sides) and
#: labelled by eye before the judge saw it.
HAND_POSED: list = [
    # the bench is lower than the example's stool: seated on it, the example's soles go
    # 3-5 cm into the floor, more than any body part may go into the scene
    ("sitting", "scenes/living-room2.ply", (3.65, 3.53, 0.401), 3 * math.pi / 2, False,
     "on a seat lower than the example's, the feet into the floor",
     "living-room2 upholstered bench, facing out"),
    ("sitting", "scenes/living-room2.ply", (3.65, 3.53, 0.401), math.pi / 2, False,
     "legs along the seat, through it", "living-room2 upholstered bench"),
    ("sitting", "scenes/living-room2.ply", (5.82, 1.93, 0.415), 0.0, True,
     "seat", "living-room2 round stool"),
    ("sitting", "scenes/living-room2.ply", (5.82, 1.93, 0.415), math.pi / 2, True,
     "seat", "living-room2 round stool"),
    ("sitting", "scenes/living-room2.ply", (5.82, 1.93, 0.415), 3 * math.pi / 2, False,
     "head in the wall cabinet", "living-room2 round stool"),
    ("sitting", "scenes/living-room2.ply", (2.39, 0.55, 0.47), math.pi / 2, False,
     "on a TV sideboard, legs through its front", "living-room2 TV sideboard"),
    ("riding", "scenes/kitchen5.ply", (2.64, 0.57, 0.524), 0.0, False,
     "on a kitchen unit, legs through it", "kitchen5 low unit"),
    ("riding", "scenes/kitchen5.ply", (2.64, 0.57, 0.524), math.pi / 2, False,
     "on a kitchen unit, body in the counter", "kitchen5 low unit"),
    ("riding", "scenes/living-room2.ply", (1.60, 0.54, 0.586), 0.0, False,
     "on a cabinet top, not astride", "living-room2 side cabinet"),
    ("riding", "scenes/living-room2.ply", (1.60, 0.54, 0.586), math.pi, False,
     "on a cabinet top, not astride", "living-room2 side cabinet"),
    # offices have no tap: a mug in a desk's keyboard niche under the desk top's front edge,
    # and one beside a monitor's stand under its bezel (both judged valid before the tap
    # test asked the surface above to reach the opening from one side)
    ("filling", "scenes/office-desk2.ply", (1.556, 1.117, 0.767), math.pi / 2, False,
     "in a niche under a board's edge, no tap", "office-desk2 keyboard niche"),
    ("filling", "scenes/office-desk2.ply", (1.564, 1.114, 0.767), math.pi, False,
     "in a niche under a board's edge, no tap", "office-desk2 keyboard niche"),
    ("filling", "scenes/office-desk4.ply", (1.316, 0.234, 0.738), math.pi / 2, False,
     "beside a monitor's stand under its bezel, no tap", "office-desk4 desk"),
    # found by the exhaustive search of every standing mug (oracle.py) among poses an earlier
    # judge passed; drawn from four sides and labelled by eye: a mug on a double sink's divider under the tap (a
    # place a person fills a mug at), and, with no tap or no sink, a mug beside a potted
    # plant under its leaves, on a desk under a wire rack's foot (the rack's frame walls it
    # in above the desk) and on chair seats under a desk's edge
    ("filling", "scenes/kitchen1.ply", (7.098, 10.115, 0.884), 0.0, True,
     "on a double sink's divider under the tap", "kitchen1 sink"),
    ("filling", "scenes/kitchen1.ply", (7.094, 10.126, 0.884), math.pi / 2, True,
     "on a double sink's divider under the tap", "kitchen1 sink"),
    ("filling", "scenes/kitchen1.ply", (6.6, 10.395, 0.916), 0.0, False,
     "beside a potted plant under its leaves, no tap", "kitchen1 counter"),
    ("filling", "scenes/office-desk6.ply", (0.129, 0.258, 0.769), 5 * math.pi / 4, False,
     "under a wire rack's foot, no tap, no sink", "office-desk6 desk"),
    ("filling", "scenes/office-desk6.ply", (0.347, 0.313, 0.769), 0.0, False,
     "under a wire rack's foot, no tap, no sink", "office-desk6 desk"),
    ("filling", "scenes/office-desk6.ply", (0.944, -1.098, 0.443), 0.0, False,
     "on a chair seat under a desk's edge, no tap, no sink", "office-desk6 chair"),
    ("filling", "scenes/office-desk6.ply", (0.94, 1.143, 0.444), 0.0, False,
     "on a chair seat under a desk's edge, no tap, no sink", "office-desk6 chair"),
    # found by the search of the riding descriptor's poses over whole scenes (one sample per
    # 10 cm cube, oracle.region_poses), drawn and labelled by eye: riders crouched on a
    # kitchen counter, the seat on a tap's spout (kitchen1, over its double sink's divider)
    # or on a sink's rim (kitchen3). The judge passes both: its two known errors on the set.
    ("riding", "scenes/kitchen1.ply", (7.1047, 10.1444, 1.0942), math.pi / 2, False,
     "seat on a tap's spout, feet in the sink", "kitchen1 sink"),
    ("riding", "scenes/kitchen3.ply", (3.2023, 2.8681, 0.905), 0.0, False,
     "seat on a sink's rim, feet on the counter", "kitchen3 sink"),
]


#: Hand-labelled poses in the published scenes given whole (affordance, scene, 4x4 pose,
#: valid, case, note): hangers of the Naive baseline's top 5 that lay flat, tilted 90 degrees,
#: with the hook round something low, which a judge without the upright test passes (drawn
#: from four sides and labelled by eye).
HAND_POSED_POSES: list = [
    ("hanging", "scenes/kitchen1.ply",
     [[0.50517, 0.001467, -0.863019, 9.70808], [-0.863018, 0.003203, -0.505164, 9.65082],
      [0.002023, 0.999994, 0.002884, -0.004599], [0.0, 0.0, 0.0, 1.0]], False,
     "lying flat on the floor, the hook round a low edge", "kitchen1 cabinet plinth (Naive #4)"),
    ("hanging", "scenes/living-room1.ply",
     [[-0.124931, -0.002854, 0.992161, -0.251713], [0.992164, -0.002259, 0.124925, 0.292142],
      [0.001885, 0.999993, 0.003114, -0.004857], [0.0, 0.0, 0.0, 1.0]], False,
     "lying flat on the floor, the hook round a low edge", "living-room1 wall's foot (Naive #2)"),
    ("hanging", "scenes/office-desk4.ply",
     [[0.968734, -0.001197, 0.248099, 3.78702], [-0.2481, -0.000894, 0.968734, 0.172082],
      [-0.000937, -0.999999, -0.001163, 0.698249], [0.0, 0.0, 0.0, 1.0]], False,
     "lying flat on a desk top, the hook round an object on it",
     "office-desk4 desk top (Naive #3)"),
]


# ------------------------------------------------------------------ files
def save(poses: list, path=DATA_FILE, meta: dict | None = None) -> Path:
    """Write the set as JSON (versioned)."""

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    doc = {"format": FORMAT, "format_version": FORMAT_VERSION, "meta": meta or {},
           "poses": [asdict(p) for p in poses]}
    with atomic_path(path) as tmp:
        Path(tmp).write_text(json.dumps(doc, indent=0))
    return path


def load(path=DATA_FILE) -> list:
    """Read a set written by :func:`save`."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(path, f"cannot read the labelled poses ({exc})") from None
    if doc.get("format") != FORMAT or doc.get("format_version") != FORMAT_VERSION:
        raise InputError(path, "not a labelled-poses file of a version this code reads")
    return [LabelledPose(**p) for p in doc["poses"]]


def upright(poses: list, tolerance: float = 1.0) -> list:
    """The poses whose object keeps its vertical (within ``tolerance`` degrees): those
    detection can propose, as it only turns an example about +Z. The scripts that choose
    detection's tests on the labelled set leave the tilted negatives out, which only the
    judge's upright test is for."""

    return [p for p in poses if tilt_degrees(p.pose) <= tolerance]


# ------------------------------------------------------------------ judging the judge
def scene_geometry(scene: str, shared_dir=None):
    """The Geometry of a labelled pose's ``scene``: ``shared:<path>`` read from
    ``shared_dir``, ``validation:<name>`` built (:func:`.rooms.validation.build_scene`)."""

    if scene.startswith("shared:"):
        return load_geometry(Path(shared_dir) / scene[7:])
    return validation.build_scene(scene.split(":", 1)[1]).geometry


def judge_accuracy(poses: list, objects_dir=None, shared_dir=None, log=None):
    """Judge every pose; returns (rows per affordance, per-pose verdicts).

    A row: affordance, valid_n, valid_right, invalid_n, invalid_right, and the accuracies
    (%) on each class. Poses in the shared scenes are skipped without ``shared_dir``.
    """

    judges, scenes, verdicts = {}, {}, []
    for p in poses:
        if p.scene.startswith("shared:") and shared_dir is None:
            continue
        key = p.scene
        if key not in scenes:
            scenes[key] = JudgeScene(scene_geometry(key, shared_dir))
        if p.example not in judges:
            judges[p.example] = Judge.for_example(affordances.build(p.example, objects_dir))
        v = judges[p.example].judge(scenes[key], np.asarray(p.pose, float))
        verdicts.append((p, v))
    rows = []
    for aff in ("placing", "sitting", "filling", "riding", "hanging"):
        vs = [(p, v) for p, v in verdicts if p.affordance == aff]
        if not vs:
            continue
        pos = [(p, v) for p, v in vs if p.valid]
        neg = [(p, v) for p, v in vs if not p.valid]
        vr = sum(v.valid for _, v in pos)
        ir = sum(not v.valid for _, v in neg)
        rows.append({"affordance": aff, "valid_n": len(pos), "valid_right": vr,
                     "invalid_n": len(neg), "invalid_right": ir,
                     "valid_accuracy": 100.0 * vr / len(pos) if pos else float("nan"),
                     "invalid_accuracy": 100.0 * ir / len(neg) if neg else float("nan")})
    return rows, verdicts


def summary_markdown(verdicts: list) -> str:
    """The labelled set case by case, with how many of each the judge got right
    (``verdicts`` from :func:`judge_accuracy`)."""
    from collections import defaultdict

    cases = defaultdict(lambda: [0, 0])
    scenes = defaultdict(set)
    for p, v in verdicts:
        c = cases[(p.affordance, p.valid, p.case)]
        c[0] += 1
        c[1] += int(bool(v.valid) == p.valid)
        scenes[(p.affordance, p.valid, p.case)].add(p.scene.split(":", 1)[1])
    lines = ["| affordance | label | case | poses | judged right | scenes |",
             "|---|---|---|---:|---:|---|"]
    order = {a: i for i, a in enumerate(("placing", "sitting", "filling", "riding", "hanging"))}
    for key in sorted(cases, key=lambda k: (order.get(k[0], 9), not k[1], k[2])):
        n, right = cases[key]
        lines.append(f"| {key[0]} | {'valid' if key[1] else 'invalid'} | {key[2]} | {n} | "
                     f"{right} | {', '.join(sorted(scenes[key]))} |")
    return "\n".join(lines)
