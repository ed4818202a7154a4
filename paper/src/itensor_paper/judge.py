"""The judge: an automatic validity oracle for a predicted pose, independent of any score.

The paper asked people (Amazon Mechanical Turk) whether a predicted placement was a good
place for the interaction. No raters are available here, so a predicted pose (a 4x4 taking
the training-frame query object into the scene) is judged by geometry alone. None of the tests
looks at the Interaction Tensor, its score or its keypoints: they use the example (the query
object, the scene-object and the point the interaction rests on), the scene mesh and the pose.
Every threshold is in :class:`JudgeSettings`, set from physical reasoning; the judge is
proven on a labelled set of valid and invalid poses (:mod:`.labelled`), never on a detector's
output.

Tests, by affordance (each affordance's :class:`~interaction_tensor.affordances.JudgeRule`):

1. **No penetration** (all). The scene mesh and the query object are tested triangle against
   triangle with python-fcl (:mod:`~interaction_tensor.geometry.collision`), so thin parts (a 3 mm hook wire, a hanger's
   rods) are seen however thin they are. Containers (mugs, cups, bowls, bottles) are tested
   as their convex hull: something inside the cavity penetrates the interaction as much as
   something inside the wall. Depth is the shortest move (26 directions, a ladder of lengths)
   that separates the two: at most ``penetration_depth`` = 1 cm for an object, and 2 cm for
   every part of a person (``person_penetration_depth``, ``limb_penetration``): no body part
   more than 2 cm inside the scene, whose geometry knows nothing of cushions. On a captured
   surface its measured noise is allowed on top, by the same rule as detection's
   (``MeshCollider.penetrates``). A person's
   legs and arms are tested each on its own, so that a verdict says which part goes in
   (each lower leg, more than 5 cm below the seat, and a rider's thighs sloping to the
   knees; each arm, more than 8 cm above the seat and 16 cm to the side of the mid-plane, or
   20 to 50 cm above the seat and 18 cm ahead of it).
2. **Main contact** (all). The example's main contact is the query's surface within 1 cm of
   the scene-object near the point the interaction rests on, and not below it (the bowl's foot ring, the mug's
   bottom, the hook's inside top, the thighs and buttocks on the seat, the rider's seat). At
   least half of it must be within ``contact_distance`` = 2 cm of the scene again: a floating
   object fails. For a person the main contact is its seat region (its surface within 3 cm
   above its lowest point near the seat point: buttocks, crotch, thighs), of which 2 %
   must be within 2 cm of the scene, as a round beam or a narrow arm touches less of it than
   a flat seat. Other contacts of the example (a rider's hands and feet) are not required:
   the paper's raters accepted pretend riding without a motorbike.
3. **Support from below** (placing, filling, sitting). Scene points under the posed object's
   footprint at the height of the example's support point (2 cm below to 1 cm above) form the support
   polygon; the centre of mass (the centroid of the object's surface samples) must project
   inside it by ``support_margin`` = 1 cm. An object half off an edge fails.
4. **A tap above, in a basin** (filling). Scene points above the opening (within 3 cm of its
   axis, 2 to 30 cm above the rim) that are not a ceiling or a shelf (the scene in that
   height range covers at most half of the 15 cm disk around the opening) and that reach
   the opening from one side, as a spout ends over it: beyond the 3 cm, no two opposite
   eighths of that disk both hold scene surface (``overhead_one_side``), and what is there
   spans at most ``overhead_max_angle`` = 150 degrees around the axis (in 10 degree bins;
   the labelled taps span 0-100). A bar, a board's front edge or a monitor's bezel runs
   across or along the opening (220-280 degrees): office-desk2's keyboard niche and
   office-desk4's monitor fooled the judge without it; and walls around
   the object, as a sink's or a washbasin's: scene surface between the
   object's side and 30 cm from its axis, from 2 cm above its support up to its rim, in at
   least 5 of 8 sectors around it (a mug on the floor under a table's stretcher, or on a
   counter under a towel bar, has walls on a few sides at most); and **a sink**, where the
   water goes: within ``sink_radius`` = 15 cm of the opening's axis, an up-facing scene
   surface (a basin's bottom) no higher than 2 cm above the object's support and at most
   ``sink_depth`` = 45 cm below it, open above up to the opening (not a shelf inside a
   cabinet, not the floor under a seat) and closed all around: in at least ``sink_sectors`` =
   33 of 36 directions (10 degrees each) around it, within ``sink_reach`` = 35 cm, wall
   surface (not a board: its normal at least 37 degrees from vertical) both 2-6 and 8-14 cm
   above it: walls that rise from the bottom (a bucket seat's rim is lower; a wire rack's
   frame standing on a desk has only its legs near the desk); the costliest test, asked only
   of a pose that passes the others. The object may stand on that bottom or beside it (on
   a double sink's divider, under its tap; a water dispenser's niche with no tray is not a
   sink). The exhaustive search of every standing mug in the published scenes
   (:mod:`.oracle`) found the tap and basin tests passed by a mug beside a potted plant
   under its leaves (kitchen1), on a desk under a wire rack's foot and on chair seats under a
   desk's edge (office-desk6): none has a sink. The three tests are the library's
   (:mod:`interaction_tensor.placement.taps`), which detection asks of ranked poses.
5. **Through the loop** (hanging). The hook's (the strap's) inner disk must be crossed by the
   scene: the rail, peg, door top or panel edge passes through the loop, so the object hangs
   from it. A hanger standing on a flat top or beside an edge fails. So does one flat
   against a wall: the wall lies in the loop's plane and the triangle test calls that a
   crossing, so the scene must also cross the plane there, at ``loop_min_angle`` = 30
   degrees or more (a sample within ``spacing`` of the disk's plane, inside the disk, its
   normal that far from the loop's axis; a rail or an edge through the loop crosses it at
   about 90). Sampled on random wall points of a validation room, 27 of 40 hangers flat in
   the wall passed the triangle test and every other test.
   **What it hangs from fits in the loop** (``fits``): the scene's surface crossing the
   loop's plane is split into connected pieces, and each piece that reaches into the loop's
   opening must end within 1 cm of it wherever the object itself goes on around the opening
   (the hook's wire, the strap and its bag). A rail, a rod, a peg or a tap's spout lies
   inside the hook; a shelf board, a desk top or a counter's lip goes on sideways through the
   wire or the strap, which cannot be put round it, and which the collision test misses
   where the wire or the strap is thinner than its tolerance. The blind panel rejected
   hangers and bags hooked over board edges once the sheets showed cuts through the hook.
   **Hanging free** (``free``): the object's bottom (its lowest 3 cm) does not rest on a top
   or a floor (5 % of it within 1.5 cm of an up- or down-facing surface): a hanger lying on a
   chair's star base is not hanging. Both are the library's
   (:mod:`interaction_tensor.placement.hooks`), which detection asks of ranked poses with
   the opening a descriptor learnt from its example.
6. **Above the ground** (hanging). The hanging object's lowest point is at most
   ``below_ground`` = 1 cm below the ground: the lowest scene point within 1.5 m. Where the
   scan has a floor, hanging through it is test 1's business; the published office scans
   have none, and a hook round an office chair's star-base leg, 8-10 cm above where the
   floor is, passed every other test with the hanger 8 cm below the casters.
7. **Feet within reach** (sitting; a rider's feet may dangle, as on a vaulting horse). Under each foot the highest scene surface
   one can stand on (its normal line within ``stand_angle`` = 45 degrees of vertical: a floor,
   a step, a foot rail's top, not the face of a cabinet or a desk's side panel beside the
   shins) not above the sole (or, with none under it, the ground: the lowest scene point
   within 1.5 m; feet sunk into a floor are test 1's business) is at most ``feet_reach`` =
   25 cm below the sole (a bar stool), or the feet dangle from a seat at most
   ``seat_above_ground`` = 1.2 m above the ground (the library's
   :func:`~interaction_tensor.placement.checks.feet_pass`, which detection asks too): the
   blind panel passed people on a desk's, a table's or a counter's edge with the feet in
   the air, and rejected them on wardrobes and wall units 2-3 m up. A foot with nothing
   under it more than ``feet_below_ground`` = 5 cm below the ground hangs past the edge of
   the scan's floor (a person on a floor's edge with the legs in the void under it):
   "nothing under the feet";
   so does a foot on a surface more than ``feet_above_ground`` = 0.6 m above the ground (the
   top of a 3 m wall unit with the feet on its lower ledge: no one climbs there from the
   floor to sit; a bar stool's foot rest, 0.2-0.5 m up, is fine).
8. **Astride** (riding). The scene's surface goes on between the legs ahead of the seat:
   scene samples in a box 3 cm either side of the body's mid-plane, from 12 to 32 cm ahead of
   the seat point, from 30 cm below to 2 cm above the seat (a motorbike's tank, a panel or a
   wall's top going on between the knees; not a bench crossed sideways). And there is room
   for a leg on each side: no scene sample 18 to 35 cm either side of the mid-plane, from 10
   cm behind to 20 cm ahead of the seat point, from 14 cm below to 2 cm above the seat (a wide
   seat or a bed fails). Pretend riding does not need the example's motorbike, but the
   rider's legs are tested as every body part is (test 1): the example rider's legs are 7 cm
   apart from the seat down, so what it sits astride is at most about 11 cm wide there (a
   panel, a partition, a chair's back, a beam); the legs of this rider do not spread round a
   sofa's arm or a bench.
9. **Within reach from the ground** (riding). The seat (the posed point the example rests
   on) is at most ``seat_above_ground`` = 1.2 m above the ground (the lowest scene point
   within 1.5 m), and the feet reach a floor or a foot rest: under each foot, the highest
   surface one can stand on (as test 7, at any height: a desk under a partition's top is a
   foot rest) is at most ``rider_feet_reach`` = 0.65 m below the sole, the example rider's
   bent legs straightened (its soles are 0.37 m under its seat): a rider straddles a 0.9 m
   wall or a 1 m chair back on tiptoe, not the top of a 2.4 m wall or partition with the feet
   dangling a metre and more above the floor.

10. **Upright** (all). The example is posed under gravity: its query object's vertical
   (+Z of the training frame) stays within ``max_tilt`` = 15 degrees of the scene's +Z. A
   hanger hangs with the hook's plane vertical, a bowl rests level, a person sits upright.
   iT's poses only turn about the vertical, but a baseline's ICP may tilt the object: the
   Naive baseline laid hangers flat on the floor with the hook round a cabinet's plinth or
   leg, which passed every other test (the hook's contact, something through it, above the
   ground); a hanger turned level on its rail, the hook still round the rail, passes them
   too. The tolerance covers ICP's small tilts of resting objects (Naive's valid placings:
   median 4 degrees) and floors and tops that are not quite level.

A pose is valid when every test of its affordance passes. :class:`Verdict` keeps each measured
value, so that a table can show why a pose failed.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from interaction_tensor import affordances
from interaction_tensor.errors import InputError
from interaction_tensor.examples.posing import surface_points
from interaction_tensor.geometry import collision
from interaction_tensor.geometry.scene import GroundMap, prepare_scene
from interaction_tensor.placement import checks, hooks, taps


@dataclass(frozen=True)
class JudgeSettings:
    """Every threshold of the judge (metres), documented in the module docstring."""

    spacing: float = 0.01
    penetration_depth: float = 0.01
    person_penetration_depth: float = 0.02
    limb_penetration: float = 0.02
    # a person's parts: detection's "limbs" collision test cuts them the same way
    limb_below_seat: float = collision.LIMB_BELOW_SEAT
    arm_above_seat: float = collision.ARM_ABOVE_SEAT
    arm_lateral: float = collision.ARM_LATERAL
    forearm_above_seat: tuple = collision.FOREARM_ABOVE_SEAT
    forearm_ahead: float = collision.FOREARM_AHEAD
    feet_height: float = checks.FEET_HEIGHT
    contact_tolerance: float = 0.01
    contact_distance: float = 0.02
    contact_fraction: float = 0.5
    person_contact_fraction: float = 0.02
    seat_region_height: float = 0.03
    main_contact_radius: float = 0.3
    support_below: float = taps.SUPPORT_BELOW
    support_above: float = taps.SUPPORT_ABOVE
    support_margin: float = taps.SUPPORT_MARGIN
    overhead_radius: float = taps.TAP_RADIUS
    overhead_range: tuple = taps.TAP_RANGE
    overhead_disk: float = taps.TAP_DISK
    overhead_max_cover: float = taps.TAP_MAX_COVER
    overhead_one_side: bool = True
    overhead_max_angle: float = taps.TAP_MAX_ANGLE
    basin_radius: float = taps.BASIN_RADIUS
    basin_height: tuple = taps.BASIN_HEIGHT     # above the support, above the rim
    basin_sectors: int = taps.BASIN_SECTORS    # of 8
    sink_radius: float = taps.SINK_RADIUS
    sink_depth: float = taps.SINK_DEPTH
    sink_foot: tuple = taps.SINK_FOOT           # above the basin's bottom: walls low
    sink_wall: tuple = taps.SINK_WALL           # and high
    sink_reach: float = taps.SINK_REACH
    sink_sectors: int = taps.SINK_SECTORS      # of 36 (10 degrees each)
    loop_fraction: float = 0.85
    loop_min_angle: float = 30.0
    fit_margin: float = hooks.FIT_MARGIN       # past the loop's inner radius
    fit_slab: float = hooks.FIT_SLAB
    fit_reach: float = hooks.FIT_REACH
    fit_min_samples: int = hooks.FIT_MIN_SAMPLES
    free_band: float = hooks.FREE_BAND          # the object's bottom
    free_gap: float = hooks.FREE_GAP
    free_fraction: float = hooks.FREE_FRACTION
    below_ground: float = 0.01
    feet_reach: float = 0.25
    stand_angle: float = 45.0
    feet_below_ground: float = 0.05
    feet_above_ground: float = 0.6
    ground_radius: float = 1.5
    astride_ahead: tuple = (0.12, 0.32)
    astride_half_width: float = 0.03
    astride_below: tuple = (0.30, 0.02)        # (below, above) the seat
    legroom_lateral: tuple = (0.18, 0.35)
    legroom_along: tuple = (-0.10, 0.20)
    legroom_below: tuple = (0.14, 0.02)        # (below, above) the seat
    seat_above_ground: float = checks.SEAT_REACH
    rider_feet_reach: float = checks.RIDER_REACH
    max_tilt: float = 15.0                     # degrees
    seed: int = 0


@dataclass
class Verdict:
    """The judge's decision on one pose, with the measured values behind it.

    ``penetration`` is the separating move (m; 0 when not touching, inf when a move of the
    allowed depth does not free it); ``contact`` the fraction of the main contact touching the scene again; the
    optional fields are None where the test does not apply.
    """

    valid: bool
    penetration: float
    contact: float
    support_margin: float | None = None
    overhead: bool | None = None
    basin: int | None = None
    sink: int | None = None
    loop: bool | None = None
    fits: bool | None = None
    free: bool | None = None
    feet_gap: float | None = None
    below_ground: float | None = None
    astride: bool | None = None
    legroom: bool | None = None
    seat_height: float | None = None
    tilt: float | None = None
    reasons: list = field(default_factory=list)

    def to_dict(self) -> dict:
        def r(v, nd=4):
            return None if v is None else (None if not np.isfinite(v) else round(float(v), nd))
        return {"valid": bool(self.valid), "penetration_m": r(self.penetration),
                "contact": r(self.contact, 3), "support_margin_m": r(self.support_margin),
                "overhead": self.overhead, "basin_sectors": self.basin, "sink_sectors": self.sink,
                "loop": self.loop, "fits": self.fits, "free": self.free,
                "feet_gap_m": r(self.feet_gap), "below_ground_m": r(self.below_ground),
                "astride": self.astride, "legroom": self.legroom,
                "seat_height_m": r(self.seat_height), "tilt_deg": r(self.tilt, 2),
                "reasons": list(self.reasons)}


def tilt_degrees(pose) -> float:
    """The angle (degrees) between a pose's object vertical (+Z of the training frame) and
    the scene's +Z (the upright test)."""
    return float(np.degrees(np.arccos(np.clip(np.asarray(pose, float)[2, 2], -1.0, 1.0))))


class JudgeScene:
    """The scene as the judge sees it: its triangles (for exact collision), dense seeded
    surface samples and their KD-tree (for contact, support and what is above or below).
    ``surface_noise`` (m): a captured surface's measured noise, allowed on top of each
    penetration depth as detection allows it (:meth:`~interaction_tensor.geometry.collision.
    MeshCollider.penetrates`)."""

    def __init__(self, geometry, spacing: float = 0.01, seed: int = 0,
                 surface_noise: float = 0.0):

        if not geometry.is_mesh:
            raise InputError(getattr(geometry, "source", None),
                             "the judge needs a mesh scene (triangles), not a point cloud")
        sc = prepare_scene(geometry, spacing, seed=seed + 9176)
        self.points = sc.points
        self.normals = sc.normals
        self.tree = cKDTree(self.points)
        self.spacing = spacing
        self.collider = collision.MeshCollider(geometry.vertices, geometry.faces,
                                                 noise=surface_noise)
        self.source = getattr(geometry, "source", "<scene>")
        self._ground = GroundMap(self.points)

    @functools.cached_property
    def flat_tree(self) -> cKDTree:
        """A KD-tree of the samples on up- or down-facing surfaces (normal within 45 degrees
        of vertical): tops and floors."""
        return hooks.flat_tree(self.points, self.normals)

    def ground_level(self, centre, radius: float) -> float:
        """The lowest scene point within ``radius`` (m, horizontally, to 10 cm) of ``centre``."""
        return float(self._ground.level(np.asarray(centre, float)[None], radius)[0])


class Judge:
    """Judge poses of one example's query object in scenes.

    Parameters
    ----------
    query : Geometry, the query object as posed in the training example (training frame)
    scene_object : Geometry, the example's scene-object in the same frame
    affordance : a registered affordance (:mod:`interaction_tensor.affordances`)
    support_point : (3,) the point of the scene-object the interaction rests on
    loop : hanging only: (centre (3,), inner radius, axis (3,)) of the hook or strap loop
    rule : the rule to judge by (:class:`~interaction_tensor.affordances.JudgeRule`);
        default: the registered ``affordance``'s
    """

    def __init__(self, query, scene_object, affordance: str, support_point, loop=None,
                 settings: JudgeSettings | None = None, rule=None):
        rule = rule or affordances.get(affordance).judge
        if not query.is_mesh:
            raise InputError(query.source, "the judge needs the query object as a mesh")
        self.settings = st = settings or JudgeSettings()
        self.affordance = affordance
        self.tests = rule.tests
        self.person = rule.person
        self.hull = rule.hull
        self.samples = surface_points(query, 20000, st.seed)
        self.com = self.samples.mean(axis=0)
        self.radius = float(np.linalg.norm(self.samples - self.com, axis=1).max())
        self.support_point = np.asarray(support_point, float)
        self.main_contact = self._main_contact(scene_object)
        if len(self.main_contact) > 2000:
            keep = np.random.default_rng(st.seed).choice(len(self.main_contact), 2000,
                                                         replace=False)
            self.main_contact = self.main_contact[np.sort(keep)]
        self.bodies = self._bodies(query)
        vessel = taps.Vessel.of(self.samples)        # a container's opening and side
        self.opening, self.side = vessel.opening, vessel.side
        self.feet = checks.split_feet(self.samples, st.feet_height)
        self.loop_body = None
        if "loop" in self.tests:
            if loop is None:
                raise ValueError("a hanging judge needs the example's loop")
            centre, inner, axis = loop
            v, f = collision.disk(centre, st.loop_fraction * inner, axis)
            self.loop_body = collision.Body(v, f)
            axis = np.asarray(axis, float)
            self.loop = (np.asarray(centre, float), st.loop_fraction * inner,
                         axis / np.linalg.norm(axis))
            self.loop_inner = float(inner)
            self.opening_fit = self._opening()
        if "free" in self.tests:        # the bottom of what hangs: within free_band of its lowest
            self.hanging_part = hooks.bottom(self.samples, st.free_band)
        s = self.support_point
        # columns (training frame: x-y box, z range) the astride and legroom tests look in
        self.astride_column = ((s[0] + st.astride_ahead[0], s[0] + st.astride_ahead[1]),
                               (s[1] - st.astride_half_width, s[1] + st.astride_half_width),
                               (s[2] - st.astride_below[0], s[2] + st.astride_below[1]))
        self.legroom_columns = [((s[0] + st.legroom_along[0], s[0] + st.legroom_along[1]),
                                 tuple(sorted(s[1] + side * np.asarray(st.legroom_lateral))),
                                 (s[2] - st.legroom_below[0], s[2] + st.legroom_below[1]))
                                for side in (1, -1)]

    @classmethod
    def for_example(cls, example, settings: JudgeSettings | None = None) -> "Judge":
        """The judge of an :class:`~interaction_tensor.affordances.Example`."""
        return cls(example.query, example.scene_object, example.spec.affordance,
                   example.support_point, example.loop, settings)

    # ------------------------------------------------------------------ set-up
    def _main_contact(self, scene_object) -> np.ndarray:
        """(C, 3) query samples touching the scene-object near the support point; for a
        person, the seat region: its surface within 3 cm above its lowest point within
        ``main_contact_radius`` of the support point and not below the seat (buttocks, crotch and thighs: a seat of
        another shape, round or narrow, touches another part of it than the example's)."""

        st = self.settings
        if self.person:
            near = ((np.linalg.norm(self.samples - self.support_point, axis=1)
                     <= st.main_contact_radius)
                    & (self.samples[:, 2] >= self.support_point[2] - st.seat_region_height))
            low = self.samples[near, 2].min()
            return self.samples[near & (self.samples[:, 2] <= low + st.seat_region_height)]
        s_pts = surface_points(scene_object, 300000, st.seed + 1)
        d, _ = cKDTree(s_pts).query(self.samples, workers=-1)
        touching = d <= st.contact_tolerance
        if not touching.any():
            touching = d <= d.min() + st.contact_tolerance
        size = float(np.linalg.norm(np.ptp(self.samples, axis=0)))
        radius = min(st.main_contact_radius, 0.5 * size)
        near = ((np.linalg.norm(self.samples - self.support_point, axis=1) <= radius)
                & (self.samples[:, 2] >= self.support_point[2] - 2 * st.contact_tolerance))
        main = self.samples[touching & near]
        if len(main) == 0:       # the support point is off the contact: the nearest contact
            cand = self.samples[touching]
            dist = np.linalg.norm(cand - self.support_point, axis=1)
            main = cand[dist <= dist.min() + 0.05]
        return main

    def _bodies(self, query) -> list:
        """[(Body, allowed depth, name)]: the query's triangles, split for a person into the
        body and the feet."""
        import trimesh

        st = self.settings
        if self.hull:
            hull = trimesh.Trimesh(query.vertices, query.faces, process=True).convex_hull
            return [(collision.Body(hull.vertices, hull.faces), st.penetration_depth, "object")]
        v, f = query.vertices, query.faces
        if not self.person:
            return [(collision.Body(v, f), st.penetration_depth, "object")]
        v, parts = collision.person_parts(
            v, f, self.support_point, "legroom" in self.tests, st.limb_below_seat,
            st.arm_above_seat, st.arm_lateral, st.forearm_above_seat, st.forearm_ahead)
        return [(collision.Body(v, part), st.person_penetration_depth if name == "body"
                 else st.limb_penetration, name) for name, part in parts]

    def _loop_crossed(self, scene: JudgeScene, rot, t) -> bool:
        """Whether some scene sample within a spacing of the posed loop disk's plane, inside
        the disk, lies on a surface crossing that plane at ``loop_min_angle`` or more."""
        centre, radius, axis = self.loop
        c, a = rot @ centre + t, rot @ axis
        near = np.asarray(scene.tree.query_ball_point(c, radius + scene.spacing), np.int64)
        d = scene.points[near] - c
        h = d @ a
        inside = (np.abs(h) <= scene.spacing) & (np.einsum("ij,ij->i", d, d) - h * h
                                                   <= radius * radius)
        across = np.abs(scene.normals[near] @ a) <= np.cos(np.radians(
            self.settings.loop_min_angle))
        return bool(np.any(inside & across))

    def _opening(self) -> hooks.Opening:
        """The loop as the library's :func:`~interaction_tensor.placement.hooks.opening`
        (the one detection builds from a descriptor's section, here from the example's
        loop)."""
        st = self.settings
        centre, _, axis = self.loop
        return hooks.opening(self.samples, centre, axis, self.loop_inner, st.fit_slab,
                             st.fit_reach)

    def _fits(self, scene: JudgeScene, rot, t) -> bool:
        """Whether what passes through the loop fits inside it (:func:`.hooks.fits`): a
        rail, a rod, a peg or a tap's spout lies inside a hook; a shelf board, a desk top or
        a counter's lip goes on sideways through the hook's wire or the bag's strap, which
        cannot be put round it (and which the collision test misses where the wire or the
        strap is thinner than its tolerance)."""
        st = self.settings
        return hooks.fits(self.opening_fit, rot, t, scene.points, scene.tree, scene.spacing,
                          st.fit_margin, st.fit_min_samples, st.fit_reach)

    def _free(self, scene: JudgeScene, rot, t) -> bool:
        """Whether the object hangs free (:func:`.hooks.hangs_free`): a hanger lying on a
        chair's base or a bag standing on the shelf under the edge it is hooked to is not
        hanging."""
        st = self.settings
        return hooks.hangs_free(self.hanging_part @ rot.T + t, scene.flat_tree, st.free_gap,
                                st.free_fraction)

    # ------------------------------------------------------------------ judging
    def judge(self, scene: JudgeScene, pose) -> Verdict:
        """Judge one pose (4x4: training-frame query object -> scene)."""
        st = self.settings
        pose = np.asarray(pose, float)
        rot, t = pose[:3, :3], pose[:3, 3]

        def moved(p):
            return p @ rot.T + t

        com = moved(self.com)
        reasons = []
        tilt = tilt_degrees(pose)
        if "upright" in self.tests and tilt > st.max_tilt:
            reasons.append(f"tilted {tilt:.0f} degrees from upright")
        pen = 0.0
        for body, allowed, name in self.bodies:
            deep, depth = scene.collider.penetrates(body, pose, allowed)
            if name == "body" or name == "object":
                pen = max(pen, depth)
            if deep:
                reasons.append(f"{name} penetrates the scene "
                               + (f"{depth * 100:.0f} cm" if np.isfinite(depth) else "deeply"))

        cp = moved(self.main_contact)
        d, _ = scene.tree.query(cp, distance_upper_bound=st.contact_distance * 1.01)
        contact = float((d <= st.contact_distance).mean())
        need = st.person_contact_fraction if self.person else st.contact_fraction
        if contact < need:
            reasons.append(f"main contact only {contact * 100:.0f} % touching")

        verdict = Verdict(False, pen, contact, tilt=tilt)
        near = np.asarray(scene.tree.query_ball_point(com, self.radius + 2 * st.spacing),
                          np.int64)
        local = scene.points[near]
        if "support" in self.tests:
            m = self._support_margin(local, moved(self.support_point)[2], moved(self.samples), com)
            verdict.support_margin = m
            if m < st.support_margin:
                reasons.append("not supported under its centre of mass"
                               if np.isfinite(m) else "nothing under it")
        if "overhead" in self.tests:
            verdict.overhead = self._overhead(scene, moved(self.opening))
            if not verdict.overhead:
                reasons.append("no tap-like surface above the opening")
        if "basin" in self.tests:
            verdict.basin = self._basin(scene, com, moved(self.support_point)[2],
                                        moved(self.opening)[2])
            if verdict.basin < st.basin_sectors:
                reasons.append(f"not in a basin (walls on {verdict.basin} of 8 sides)")
        if "sink" in self.tests and not reasons:    # the costliest test (10-20 ms): asked
            # only of a pose that passes the others (Verdict.sink stays None otherwise)
            verdict.sink = self._sink(scene, moved(self.opening), moved(self.support_point)[2])
            if verdict.sink < st.sink_sectors:
                reasons.append(f"no sink under it (a bottom closed in at most {verdict.sink} "
                               "of 36 directions)")
        if "loop" in self.tests:
            verdict.loop = (scene.collider.collides(self.loop_body, pose)
                            and self._loop_crossed(scene, rot, t))
            if not verdict.loop:
                reasons.append("nothing passes through the hook")
        if "fits" in self.tests and verdict.loop is not False:   # what passes through
            verdict.fits = self._fits(scene, rot, t)
            if not verdict.fits:
                reasons.append("what it hangs from goes on sideways out of the hook")
        if "free" in self.tests:
            verdict.free = self._free(scene, rot, t)
            if not verdict.free:
                reasons.append("rests on a surface below instead of hanging free")
        if "ground" in self.tests:
            lowest = float(moved(self.samples)[:, 2].min())
            ground = scene.ground_level(com, st.ground_radius + self.radius)
            verdict.below_ground = ground - lowest
            if verdict.below_ground > st.below_ground:
                reasons.append(f"hangs {verdict.below_ground * 100:.0f} cm below the ground")
        if "feet" in self.tests:
            gap, why = self._feet_gap(scene, [moved(f) for f in self.feet], com)
            verdict.feet_gap = gap
            verdict.seat_height = self._seat_height(scene, moved(self.support_point))
            if not checks.feet_pass(gap, verdict.seat_height, st.feet_reach,
                                    st.seat_above_ground):
                reasons.append(why or f"feet dangle from a seat {verdict.seat_height:.1f} m "
                               "above the ground: out of reach to sit")
        local_t = (local - t) @ rot            # the scene near the pose, training frame
        if "astride" in self.tests:
            verdict.astride = bool(_in_column(local_t, self.astride_column).any())
            if not verdict.astride:
                reasons.append("nothing between the legs: not astride")
        if "legroom" in self.tests:
            verdict.legroom = not any(_in_column(local_t, c).any() for c in self.legroom_columns)
            if not verdict.legroom:
                reasons.append("no room for a leg on each side of the support")
        if "mount" in self.tests:
            verdict.seat_height = self._seat_height(scene, moved(self.support_point))
            if verdict.seat_height > st.seat_above_ground:
                reasons.append(f"seat {verdict.seat_height:.1f} m above the ground: out of "
                               "reach to ride")
            elif "feet" not in self.tests:          # a rider's feet reach a floor or a rest
                gap, why = self._feet_gap(scene, [moved(f) for f in self.feet], com,
                                          above_ground=np.inf)   # a rest at any height
                verdict.feet_gap = gap
                if not gap <= st.rider_feet_reach:
                    reasons.append(why or f"feet {gap:.2f} m above what they could rest on: "
                                   "out of reach to ride")
        verdict.reasons = reasons
        verdict.valid = not reasons
        return verdict

    def _seat_height(self, scene: JudgeScene, seat) -> float:
        """How far (m) the posed seat point is above the ground (the feet and mount tests)."""
        return float(seat[2]) - scene.ground_level(seat, self.settings.ground_radius
                                                   + self.radius)

    def _support_margin(self, local, z0, samples, com) -> float:
        """:func:`.taps.margin_inside_support` of the posed ``samples`` over ``local``."""
        st = self.settings
        return taps.margin_inside_support(local, z0, samples[:, :2], com, st.support_below,
                                          st.support_above)

    def _overhead(self, scene: JudgeScene, opening) -> bool:
        """A tap's spout above the opening (:func:`.taps.tap_above`)."""
        st = self.settings
        return taps.tap_above(scene.points, scene.tree, opening, st.overhead_radius,
                              st.overhead_range, st.overhead_disk, st.overhead_max_cover,
                              st.overhead_one_side, st.overhead_max_angle)

    def _basin(self, scene: JudgeScene, com, support_z: float, rim_z: float) -> int:
        """Of 8 sectors round the object's axis, how many hold a basin's walls
        (:func:`.taps.basin_sectors`)."""
        st = self.settings
        return taps.basin_sectors(scene.points, scene.tree, com, support_z, rim_z, self.side,
                                  st.spacing, st.basin_radius, st.basin_height)

    def _sink(self, scene: JudgeScene, opening, support_z: float) -> int:
        """The most directions (of 36) closed round a basin bottom near the opening
        (:func:`.taps.sink_sectors`)."""
        st = self.settings
        return taps.sink_sectors(scene.points, scene.normals, scene.tree, opening, support_z,
                                 st.sink_radius, st.sink_depth, st.sink_foot, st.sink_wall,
                                 st.sink_reach)

    def _feet_gap(self, scene: JudgeScene, feet: list, com,
                  above_ground: float | None = None) -> tuple:
        """Largest distance (m) from a sole down to the highest scene surface under it that one
        can stand on (the ground where none is under it); negative when the sole is below
        that surface; inf when a foot with nothing under it hangs more than
        ``feet_below_ground`` below the ground (past the edge of a scan's floor), or stands
        on a surface more than ``feet_above_ground`` above it. Returns (gap, the reason of
        an infinite gap or None)."""
        st = self.settings
        ground = scene.ground_level(com, st.ground_radius + self.radius)
        worst = -np.inf
        for foot in feet:
            if len(foot) == 0:
                continue
            sole = foot[:, 2].min()
            lo, hi = foot[:, :2].min(axis=0) - 0.02, foot[:, :2].max(axis=0) + 0.02
            centre = np.r_[(lo + hi) / 2, sole]
            idx = np.asarray(scene.tree.query_ball_point(
                centre - [0, 0, 0.5], float(np.hypot(*(hi - lo)) / 2 + 0.5)), np.int64)
            around = scene.points[idx]
            flat = np.abs(scene.normals[idx, 2]) >= np.cos(np.radians(st.stand_angle))
            under = around[np.all((around[:, :2] >= lo) & (around[:, :2] <= hi), axis=1)
                           & (around[:, 2] <= sole + st.contact_tolerance) & flat]
            if len(under):
                top = under[:, 2].max()
                if top > ground + (st.feet_above_ground if above_ground is None
                                   else above_ground):
                    return float("inf"), (f"feet on a surface {top - ground:.1f} m above "
                                          "the ground")
                worst = max(worst, sole - top)
            elif sole < ground - st.feet_below_ground:
                return float("inf"), "nothing under the feet"   # below all scanned around
            else:
                worst = max(worst, sole - ground)
        return float(worst), None


def _in_column(points: np.ndarray, column) -> np.ndarray:
    """(N,) bool: points inside the axis-aligned box ``((x0, x1), (y0, y1), (z0, z1))``."""
    (x0, x1), (y0, y1), (z0, z1) = column
    return ((points[:, 0] >= x0) & (points[:, 0] <= x1) & (points[:, 1] >= y0)
            & (points[:, 1] <= y1) & (points[:, 2] >= z0) & (points[:, 2] <= z1))
