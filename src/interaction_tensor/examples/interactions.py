"""The paper's eight interaction examples, posed, with no external data.

Each example is a query object posed in interaction with a scene-object (paper, section 4.1):
filling-mug and filling-cup under a tap, placing-bottle and placing-bowl on a table,
hanging-hanger and hanging-handbag on a coat rail, sitting-human on a stool and riding-human
on a motorbike-like frame. The objects are procedural (:mod:`.shapes`); with ``objects_dir``
the query object (and, for sitting, the stool) is read from files instead, e.g.
``../shared/data/objects/ycb_mug.ply``, and posed by the same rule.

The posing rule is the same for every example and every query object: move the query
object's *anchor* (:attr:`ExampleSpec.anchor`) over the scene-object's target point, lift it
1 cm above the supporting surface, then drop it along -Z until it touches (:func:`drop_onto`,
vertical columns of 4 mm between surface samples). Anchors: ``bottom`` the x-y centre of the
object's lowest 1 cm (placing, filling: it ends resting on the table or the sink bottom);
``seat`` the lowest point of the body above 30 % of its height near its mid-plane (sitting,
riding: it ends seated); ``hook`` the frame origin, which hanging objects put on the rail axis
(shapes.coat_hanger, shapes.handbag). For riding the motorbike is built around the rider:
its seat under the pelvis, its grips under the hands, its pegs under the feet, measured on the
given rider mesh.

The expected scene normal N_aff follows the paper: filling down (the tap), everything else up.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from ..io import Geometry
from . import shapes

UP = (0.0, 0.0, 1.0)
DOWN = (0.0, 0.0, -1.0)


@dataclass(frozen=True)
class ExampleSpec:
    """What an example is: names, N_aff, the posing anchor and how the judge treats it.

    Attributes
    ----------
    name : ``<affordance>-<object>``, e.g. ``placing-bowl``
    affordance : the paper's affordance: filling, placing, hanging, sitting, riding
    normal : N_aff, the expected scene normal at the interaction (unit 3-vector)
    anchor : ``bottom``, ``seat`` or ``hook`` (module docstring)
    real_query : file in an objects directory used instead of the procedural query object
    real_scene_object : file used instead of the procedural scene-object (sitting: stool)
    solid : how the judge fills the query object: ``hull`` (convex hull, for containers
        whose cavity must stay free as well) or ``mesh`` (the closed mesh itself)
    support : the judge requires support from below (placing, sitting)
    overhead : the judge requires scene surface above the opening (filling: a tap)
    """

    name: str
    affordance: str
    normal: tuple
    anchor: str
    real_query: str | None
    real_scene_object: str | None
    solid: str
    support: bool
    overhead: bool
    description: str


EXAMPLES: dict[str, ExampleSpec] = {s.name: s for s in [
    ExampleSpec("filling-mug", "filling", DOWN, "bottom", "ycb_mug.ply", None, "hull", False,
                True, "a mug in a sink under the tap"),
    ExampleSpec("filling-cup", "filling", DOWN, "bottom", "hoi4d_mug.ply", None, "hull", False,
                True, "a cup in a sink under the tap"),
    ExampleSpec("placing-bottle", "placing", UP, "bottom", "ycb_mustard_bottle.ply", None,
                "hull", True, False, "a bottle standing on a table"),
    ExampleSpec("placing-bowl", "placing", UP, "bottom", "paper_bowl.ply", None, "hull", True,
                False, "a bowl resting on a table"),
    ExampleSpec("hanging-hanger", "hanging", UP, "hook", None, None, "mesh", False, False,
                "a coat hanger hooked on a clothes rail"),
    ExampleSpec("hanging-handbag", "hanging", UP, "hook", None, None, "mesh", False, False,
                "a handbag hanging from a clothes rail by its strap"),
    ExampleSpec("sitting-human", "sitting", UP, "seat", "human_sitting.ply", "stool.ply",
                "mesh", True, False, "a person seated on a stool"),
    ExampleSpec("riding-human", "riding", UP, "seat", "human_riding.ply", None, "mesh", False,
                False, "a person riding a motorbike"),
]}


@dataclass
class Example:
    """One interaction example, posed: the query object and the scene-object in one frame.

    Attributes
    ----------
    spec : what the example is
    query, scene_object : the two objects, posed, metres, +Z up
    support_point : (3,) the point of the scene-object the interaction rests on: the table
        top under the object, the basin bottom under the mug, the rail top under the hook,
        the seat top under the person. The judge's main contact is the query's contact
        nearest to it.
    loop : for hanging, ``(centre (3,), inner radius, axis (3,))`` of the hook or strap loop
        that the support passes through; None otherwise
    ground : height (m) of the floor the scene-object stands on (its lowest point): the
        seated person's feet rest on it
    real_query, real_scene_object : whether they were read from files
    """

    spec: ExampleSpec
    query: Geometry
    scene_object: Geometry
    support_point: np.ndarray
    loop: tuple | None = None
    real_query: bool = False
    real_scene_object: bool = False
    ground: float | None = None


def names() -> list[str]:
    return list(EXAMPLES)


def spec(name: str) -> ExampleSpec:
    if name not in EXAMPLES:
        raise InputError(None, f"unknown example {name!r}; known: {', '.join(EXAMPLES)}")
    return EXAMPLES[name]


# ------------------------------------------------------------------ posing helpers
def surface_points(g: Geometry, count: int = 20000, seed: int = 0) -> np.ndarray:
    """(N, 3) area-uniform samples of a mesh, or the points of a cloud (at most ``count``)."""
    from ..sampling import sample_mesh

    if g.is_mesh:
        return sample_mesh(g, count, seed)[0]
    v = g.vertices
    if len(v) > count:
        v = v[np.random.default_rng(seed).choice(len(v), count, replace=False)]
    return v


def drop_onto(query_points: np.ndarray, scene_points: np.ndarray, column: float = 0.004,
              below: float | None = None) -> float:
    """How far (m) the query can move down along -Z before it touches the scene-object.

    Scene points in the same vertical column as a query point (within ``column`` in x-y)
    and lower than it count; with ``below`` set, every scene point lower than ``below`` m
    counts, so that a query starting slightly inside its support is pushed up (a negative
    answer). Returns +inf when nothing is under it.
    """
    tq, ts = cKDTree(query_points[:, :2]), cKDTree(scene_points[:, :2])
    pairs = tq.sparse_distance_matrix(ts, column, output_type="ndarray")
    if len(pairs) == 0:
        return float("inf")
    gap = query_points[pairs["i"], 2] - scene_points[pairs["j"], 2]
    if below is None:
        gap = gap[gap >= 0]
    else:
        gap = gap[scene_points[pairs["j"], 2] < below]
    return float(gap.min()) if len(gap) else float("inf")


def _translated(g: Geometry, t) -> Geometry:
    m = np.eye(4)
    m[:3, 3] = t
    out = g.transformed(m)
    out.source = g.source
    return out


def anchor_point(g: Geometry, anchor: str, pts: np.ndarray | None = None,
                 rear: bool = False) -> np.ndarray:
    """(3,) the anchor of a query object (module docstring): x-y and its lowest z.

    ``seat``: among the surface samples facing down (normal z < -0.5) above 30 % of the
    object's height and within 5 cm of its x-z mid-plane, the x-y centre of the lowest 2 cm
    (the pelvis and thighs, not the shins or feet); with ``rear`` only the rear half (x at
    most the median), where a rider leaning forward has the pelvis.
    """
    pts = surface_points(g) if pts is None else pts
    z0, z1 = pts[:, 2].min(), pts[:, 2].max()
    if anchor == "bottom":
        low = pts[pts[:, 2] <= z0 + 0.01]
        return np.r_[low[:, :2].mean(axis=0), z0]
    if anchor == "seat":
        from ..sampling import estimate_normals, sample_mesh

        if g.is_mesh:
            p, n = sample_mesh(g, 40000, 7)
        else:
            p, n = pts, estimate_normals(pts)
        mid = (p[:, 2] > z0 + 0.3 * (z1 - z0)) & (np.abs(p[:, 1] - np.median(p[:, 1])) < 0.05)
        if rear:
            mid &= p[:, 0] <= np.median(p[:, 0])
        down = n[:, 2] < -0.5 if g.is_mesh else np.abs(n[:, 2]) > 0.5
        cand = p[mid & down] if (mid & down).any() else p[mid]
        zs = cand[:, 2].min()
        low = cand[cand[:, 2] <= zs + 0.02]
        return np.r_[low[:, :2].mean(axis=0), zs]
    if anchor == "hook":
        return np.zeros(3)
    raise ValueError(f"unknown anchor {anchor!r}")


def pose_on(query: Geometry, scene_object: Geometry, anchor: str, target_xy, support_z: float,
            seed: int = 0) -> Geometry:
    """The posing rule: anchor over ``target_xy``, 1 cm above ``support_z``, dropped along -Z."""
    q_pts = surface_points(query, 20000, seed)
    a = anchor_point(query, anchor, q_pts)
    t = np.r_[np.asarray(target_xy, float) - a[:2], support_z + 0.01 - a[2]]
    s_pts = surface_points(scene_object, 200000, seed + 1)
    dz = drop_onto(q_pts + t, s_pts, below=support_z + 0.03)
    if np.isfinite(dz):
        t[2] -= dz
    return _translated(query, t)


def _load(objects_dir, file: str) -> Geometry:
    from ..io import load_geometry

    path = Path(objects_dir) / file
    if not path.exists():
        raise InputError(path, "no such object file (expected in the --objects directory)")
    return load_geometry(path)


# ------------------------------------------------------------------ the examples
def build(name: str, objects_dir=None, seed: int = 0, real_scene_object: bool = False) -> Example:
    """The example ``name`` posed in interaction.

    Parameters
    ----------
    name : one of :data:`EXAMPLES`
    objects_dir : directory holding real query objects (``ExampleSpec.real_query``); None
        for procedural objects only. Examples without a real file stay procedural.
    real_scene_object : also read the scene-object from ``objects_dir`` where the example has
        one (sitting: ``stool.ply``, the paper's stool, a point cloud). Off by default: the
        point-cloud stool scores its own re-sampled copy poorly (self-score about 0.15, so a
        calibrated threshold near 0.14), and the procedural stool is a clean mesh.
    """
    sp = spec(name)
    real_q = objects_dir is not None and sp.real_query is not None
    real_s = (real_scene_object and objects_dir is not None
              and sp.real_scene_object is not None)
    procedural = {"filling-mug": shapes.mug, "filling-cup": shapes.cup,
                  "placing-bottle": shapes.bottle, "placing-bowl": None,
                  "hanging-hanger": shapes.coat_hanger, "hanging-handbag": shapes.handbag,
                  "sitting-human": shapes.seated_human, "riding-human": shapes.riding_human}
    if real_q:
        query = _load(objects_dir, sp.real_query)
    elif name == "placing-bowl":
        from .procedural import bowl

        query = bowl()
    else:
        query = procedural[name]()

    loop = None
    if sp.affordance == "filling":
        so = shapes.sink_with_tap()
        ox, oy, _ = shapes.TAP_OUTLET
        posed = pose_on(query, so, "bottom", (ox, oy), shapes.SINK_BOTTOM, seed)
        support = (ox, oy, shapes.SINK_BOTTOM)
    elif sp.affordance == "placing":
        so = shapes.table_mesh()
        posed = pose_on(query, so, "bottom", (0.0, 0.0), 0.75, seed)
        support = (0.0, 0.0, 0.75)
    elif sp.affordance == "hanging":
        so = shapes.coat_rail()
        q_pts = surface_points(query, 20000, seed)
        t = np.array([0.0, 0.0, shapes.RAIL_HEIGHT + 0.002])
        dz = drop_onto(q_pts + t, surface_points(so, 200000, seed + 1))
        t = t - [0, 0, dz if np.isfinite(dz) else 0.0]
        posed = _translated(query, t)
        support = (0.0, 0.0, shapes.RAIL_HEIGHT + shapes.RAIL_RADIUS)
        inner = shapes.HOOK_INNER if name == "hanging-hanger" else shapes.LOOP_INNER
        loop = (t.copy(), inner, np.array([0.0, 1.0, 0.0]))
    elif sp.affordance == "sitting":
        posed, so, support = _sitter_and_stool(query, objects_dir if real_s else None, seed)
    elif sp.affordance == "riding":
        posed, so, support = _rider_and_bike(query, seed)
    else:  # pragma: no cover - EXAMPLES is closed
        raise ValueError(name)
    ground = min(float(so.vertices[:, 2].min()), float(posed.vertices[:, 2].min()))
    return Example(sp, posed, so, np.asarray(support, float), loop, real_q, real_s, ground)


def seat_region(person: Geometry, seed: int = 7):
    """Where a seated person's weight rests, measured on its mesh.

    Returns ``(z, samples)``: the height (m) of the lowest down-facing surface of the thighs
    and buttocks (area samples with normal z < -0.5 between 25 % and 60 % of the body's height:
    not the feet, not the forearms) and those samples within 3 cm of it, (S, 3).
    """
    from ..sampling import estimate_normals, sample_mesh

    if person.is_mesh:
        p, n = sample_mesh(person, 80000, seed)
        down = n[:, 2] < -0.5
    else:
        p = person.vertices
        down = np.abs(estimate_normals(p)[:, 2]) > 0.5
    z0, z1 = p[:, 2].min(), p[:, 2].max()
    band = down & (p[:, 2] > z0 + 0.25 * (z1 - z0)) & (p[:, 2] < z0 + 0.6 * (z1 - z0))
    if not band.any():
        raise InputError(person.source, "no seat (down-facing thighs or buttocks) found on the "
                                        "seated person")
    zs = float(p[band, 2].min())
    return zs, p[band & (p[:, 2] <= zs + 0.03)]


def _sitter_and_stool(person: Geometry, objects_dir, seed: int):
    """A seated person in its own frame (feet flat on z = 0) on a stool built under its seat;
    returns the person, the stool and the stool's top centre.

    The stool's top touches the lowest point of the person's thighs and buttocks over the
    stool; it reaches from 2 cm behind the buttocks to 3 cm short of the calves, 40 cm wide,
    its legs on z = 0, the plane the feet stand on. With ``objects_dir`` the paper's stool
    point cloud (``stool.ply``) is moved under the seat instead (its top to the seat).
    """
    pts = surface_points(person, 60000, seed)
    person = _translated(person, [0.0, 0.0, -float(pts[:, 2].min())])      # feet on z = 0
    pts = pts - [0.0, 0.0, pts[:, 2].min()]
    zs, seat = seat_region(person)
    calves = pts[(pts[:, 2] < zs - 0.1) & (pts[:, 2] > 0.1)]
    front = float(calves[:, 0].min()) - 0.03 if len(calves) else float(seat[:, 0].max())
    back = float(seat[:, 0].min()) - 0.02
    cy = float((seat[:, 1].min() + seat[:, 1].max()) / 2)
    depth, width = front - back, 0.40
    dense = surface_points(person, 200000, seed + 3)
    over = ((np.abs(dense[:, 0] - (front + back) / 2) <= depth / 2)
            & (np.abs(dense[:, 1] - cy) <= width / 2) & (dense[:, 2] > 0.1))
    top = float(dense[over, 2].min())
    if objects_dir is None:
        stool = shapes.stool(top, centre_xy=((front + back) / 2, cy), size_xy=(depth, width))
        stool.source = f"procedural stool (top at {top:.3f} m)"
        return person, stool, ((front + back) / 2, cy, top)
    stool = _load(objects_dir, "stool.ply")
    v = stool.vertices
    centre = (v[:, :2].min(axis=0) + v[:, :2].max(axis=0)) / 2
    stool_top = float(np.percentile(v[np.linalg.norm(v[:, :2] - centre, axis=1) < 0.15, 2], 99))
    shift = np.r_[np.array([(front + back) / 2, cy]) - centre, top - stool_top]
    return person, _translated(stool, shift), ((front + back) / 2, cy, top)


def _rider_and_bike(rider: Geometry, seed: int):
    """Build the motorbike around the rider (seat, grips, pegs measured on its mesh), then lift
    both so that the wheels stand on z = 0; returns the rider, the bike and the seat point."""
    pts = surface_points(rider, 30000, seed)
    seat = anchor_point(rider, "seat", pts, rear=True)
    top = pts[:, 2].max()
    # hands: the most forward points in the upper-middle band, one per side
    band = pts[(pts[:, 2] > 0.4 * top) & (pts[:, 2] < 0.65 * top)]
    grips = []
    for s in (1, -1):
        side = band[band[:, 1] * s > 0.15]
        front = side[side[:, 0] >= np.percentile(side[:, 0], 97)]
        hand = front.mean(axis=0)
        near = side[np.linalg.norm(side[:, :2] - hand[:2], axis=1) < 0.05]
        grips.append((hand[0], hand[1], near[:, 2].min()))
    grips = np.array(grips)
    feet = pts[pts[:, 2] < pts[:, 2].min() + 0.01]
    pegs = [tuple(feet[feet[:, 1] * s > 0][:, :2].mean(axis=0)) for s in (1, -1)]
    # the seat: 16 cm wide, from 18 cm behind to 6 cm ahead of the pelvis, its top touching the
    # lowest point of the rider over it (buttocks, crotch and the start of the thighs; not the
    # legs below)
    span, width = (-0.18, 0.06), 0.16
    dense = surface_points(rider, 200000, seed + 3)
    over = ((dense[:, 0] >= seat[0] + span[0]) & (dense[:, 0] <= seat[0] + span[1])
            & (np.abs(dense[:, 1] - seat[1]) <= width / 2) & (dense[:, 2] > seat[2] - 0.1))
    seat = np.r_[seat[:2], dense[over, 2].min()]
    bike = shapes.motorbike(seat_xy=seat[:2], seat_top=seat[2], grips=grips,
                            grip_top=float(grips[:, 2].min()), pegs_xy=pegs,
                            peg_top=float(pts[:, 2].min()), ground=float(pts[:, 2].min()) - 0.3,
                            seat_span=span, seat_width=width)
    dz = drop_onto(pts + [0, 0, 0.005], surface_points(bike, 200000, seed + 1))
    lift = np.array([0.0, 0.0, 0.3 - float(pts[:, 2].min())])
    rider = _translated(rider, lift + [0, 0, 0.005 - (dz if np.isfinite(dz) else 0.005)])
    bike = _translated(bike, lift)
    bike.source = "procedural motorbike"
    return rider, bike, seat + lift + [(span[0] + span[1]) / 2, 0.0, 0.0]


#: Acceptance per affordance: S_aff, clearance limit, interior limit and contact test
#: (mode, distance, fraction, angle), chosen by :func:`interaction_tensor.evaluation.tuning.tune` on
#: the procedural validation scenes (never the published ones): the combination of largest
#: F1 of the pair decisions against the judge. The run, its curves and every judged pair:
#: docs/results/tuning/ (placing, filling) and docs/results/tuning-2026-11-26/ (sitting,
#: hanging, riding: tuned again with the tests not tuned there, the collision, through,
#: ground, feet, straddle and mount tests, applied first, as detection does).
ACCEPTANCE: dict = {
    # gaussian_threshold: S_aff of the gaussian criterion (captured scenes' default), the
    # threshold of largest F1 with these placement tests on the validation rooms' pairs
    # scored with it (`itensor tune --criterion gaussian`, tuning.shipped_thresholds;
    # docs/results/tuning-gaussian-2026-11-27/; riding's with its seat contact test off,
    # which the tuning does not measure); the authors' code fixed 0.5 for every affordance.
    # precision and recall of the pair decisions on the validation pairs (tuning.md); the
    # collision tests [(depth, above)] of ranked placements, the through test, the ground
    # test, the feet test and the straddle test chosen on the judge's labelled set: every
    # valid pose kept, the most invalid ones rejected (scripts/choose_collision.py,
    # docs/results/collision/choice.md)
    "placing": dict(threshold=0.03, gaussian_threshold=0.13,
                    clearance_limit=0.05, interior_limit=0.02,
                    contact=("main", 0.02, 0.9, 90.0),            # 99.2 %, 95.0 %
                    collision=[(0.01, None)], through=False),     # 30/76 invalid rejected
    "sitting": dict(threshold=0.11, gaussian_threshold=0.17,
                    clearance_limit=0.10, interior_limit=0.02,
                    contact=("main", 0.10, 0.75, 90.0),           # 91.5 %, 78.1 % (***)
                    collision=[(0.05, None), (0.01, -0.05)],      # 122/167: the whole body
                    through=False, below_ground=0.05,             # 5 cm, from 5 cm below the
                    feet_reach=0.25),                             # seat 1 cm; ground 126,
                                                                  # feet 154/167
    "hanging": dict(threshold=0.03, gaussian_threshold=0.16,
                    clearance_limit=0.10, interior_limit=1.0,
                    contact=("off", 0.02, 0.1, 90.0),             # 100 %, 4.3 % (**)
                    collision=[(0.01, None)], through=True,       # 110/125, with the
                    below_ground=0.01),                           # ground test 115/125
    "filling": dict(threshold=0.575, gaussian_threshold=0.675,
                    clearance_limit=0.02, interior_limit=1.0,
                    contact=("off", 0.02, 0.1, 90.0),             # 100 %, 71.7 %
                    collision=[(0.01, None)], through=True),      # 12/72 (support under it)
    "riding": dict(threshold=0.05, gaussian_threshold=0.22,
                   clearance_limit=0.20, interior_limit=1.0,
                   # tuned with contact off (83.5 %, 54.0 % (**)); the seat contact test
                   # chosen on the labelled set since (2 % of the seat region within 3 cm:
                   # 74/74 invalid rejected with everything below, 58 without it)
                   contact=("seat", 0.03, 0.02, 90.0),
                   collision=[(0.01, 0.05)], through=False,       # 11/74: 5 cm above the
                                                                  # seat (the thighs may
                                                                  # press on a rise ahead);
                   straddle={"astride": ((0.12, 0.32), (-0.03, 0.03), (-0.30, 0.02)),
                             "legroom": [((-0.10, 0.20), (0.16, 0.40), (-0.14, 0.02)),
                                         ((-0.10, 0.20), (-0.40, -0.16), (-0.14, 0.02))]},
                   mount_height=1.3),                             # straddle 40/74, mount 58
}
# (**) with the untuned tests applied first (2026-11-26): the score and the tuned tests are
#     left little to reject, so S_aff falls near the bottom of the range; hanging's recall
#     is held low by background pairs of large weight (at the sites a valid hang is accepted
#     in 8 of the 12 runs that have one); the top 5 of the validation runs are valid in 29/32
#     seated people, 48/50 hangs and 18/25 riders (docs/results/tuning-2026-11-26/tuning.md)
# (***) sitting tuned again on 2026-11-26 with Table 1's objective (the validation top 5,
#     ranked as the evaluation ranks, collision budget and all): its placement tests tie
#     with the ones shipped before (28/35 valid top poses each) and decide the validation
#     pairs better (F1 84.3 against 74.6), so they replace them; hanging's and riding's
#     shipped tests stay (53/70 and 18/35, the best of their candidates;
#     docs/results/tuning-top2-2026-11-26/tuning.md)


def acceptance(affordance: str) -> dict:
    """The tuned acceptance of one of the paper's five affordances (:data:`ACCEPTANCE`):
    keyword arguments of :meth:`InteractionTensor.set_acceptance`."""
    if affordance not in ACCEPTANCE:
        raise InputError(None, f"no tuned acceptance for {affordance!r}; known: "
                               f"{', '.join(ACCEPTANCE)}")
    return dict(ACCEPTANCE[affordance])


def train_settings(name: str, spacing: float = 0.01, seed: int = 0, query_points: int = 6000):
    """TrainSettings of an example: its N_aff, the spacing and the seed."""
    from ..settings import TrainSettings

    return TrainSettings(affordance_normal=spec(name).normal, scene_spacing=spacing,
                         query_points=query_points, seed=seed)


def build_descriptor(name: str, objects_dir=None, seed: int = 0, spacing: float = 0.01,
                     example: Example | None = None, tuned: bool = True):
    """Fit the Interaction Tensor of example ``name`` (see :func:`build`).

    The reference point p_scene is the example's support point (the seat's, the rail's or the
    table's point under the query), where detection's test points will be; for filling, whose
    test points are on the tap (N_aff down), it is found on the tap by
    :meth:`InteractionTensor.fit`. With ``tuned``, the affordance's S_aff and clearance limit
    (:data:`ACCEPTANCE`) replace the calibrated threshold.
    """
    from ..descriptor import InteractionTensor

    ex = example or build(name, objects_dir, seed)
    ref = None if ex.spec.affordance == "filling" else ex.support_point
    tensor = InteractionTensor.fit(ex.query, ex.scene_object, name,
                                   train_settings(name, spacing, seed), reference_point=ref,
                                   ground=ex.ground)
    if tuned and ex.spec.affordance in ACCEPTANCE:
        tensor.set_acceptance(**ACCEPTANCE[ex.spec.affordance])
    return tensor
