"""The clearance test: does a placement leave the query object the room it had in the example?

The Interaction Tensor describes the space *between* the two objects of the example; it says
little about the rest of the query object's surroundings, where its provenance vectors are
long and its tests lenient. So a chair's seat can match a stool's top while a table edge cuts
through the seated person's knees. The authors' later iTClearance work adds vectors from the
query object into the free space around it; here, each of ``K`` clearance points (area samples
of the query object's surface, training frame) keeps its free space ``r`` in the example (the
distance to the scene-object's sampled surface, at most ``clearance_max``). A placement
violates a clearance point when a scene sample lies nearer to it than ``r - tolerance``: the
scene comes closer to the object than it did in the example, where the example had room. A
sample is never nearer than the surface it lies on, so sparse sampling cannot cause a
violation (it can only hide one). Contact points have ``r`` near 0 and can never be violated;
the rest of the object must keep at least ``clearance_max - tolerance`` (1.5 cm by default)
from the scene.

Two more tests of the same kind (ours) complete the placement check; like the clearance test
they ask only where the scene's samples lie near points fixed to the query object (the
interior test on the clearance kernel, the contact test by exact nearest samples):

* **Interior**: a person sunk into a sofa or a shelf board through a seated body leaves the
  body's surface almost untouched (a board meets it along a line, so it violates a few
  clearance points only), but it passes *through* the body. ``I`` interior points (inside
  the query mesh, at least ``interior_min_depth`` from its surface) keep their depth ``r``
  (at most ``interior_max``); a scene sample nearer than ``r - tolerance`` to one lies
  inside the object. A placement is rejected when more than the descriptor's interior limit
  of them are violated.
* **Contact**: the parts of the query that touched the example's scene-object (or the
  ground it stood on) are grouped (the seat and each foot of a seated person; the inside of
  a hook; the base of a bowl), group 0 being the one at the reference point. A placement
  keeps its contact when at least ``contact_fraction`` of a group's points have their
  nearest scene sample within ``contact_distance`` (and, with ``contact_angle`` below 90
  degrees, a normal line within that angle of the one the example touched there), for
  group 0 (``main``) or every group (``all``): a
  person on a counter top with the feet in the air, or a hook lying on a shelf edge with
  nothing inside it, loses a contact the example had.
"""

from __future__ import annotations

import numpy as np

from interaction_tensor.engine.numba_backend import nearest_indices
from interaction_tensor.engine.scoring import rotation_z
from interaction_tensor.geometry.core import Geometry
from interaction_tensor.geometry.sampling import sample_mesh
from interaction_tensor.placement import taps

#: How much nearer (m) than in the example the scene may come to a clearance point: a little
#: closer than the example, never through the object (the clearance test).
CLEARANCE_TOLERANCE = 0.005
#: How much nearer (m) than its depth a scene sample may come to an interior point: a person
#: may sink a centimetre into a soft seat (the interior test).
INTERIOR_TOLERANCE = 0.01
#: Nearest-neighbour queries per chunk (bounds memory: about 100 bytes each).
CHUNK_QUERIES = 2_000_000
#: Why a placement the score accepted was rejected (``Detection.placement``): not tested
#: (the score rejected it), kept, or the first test it failed, in the order they run.
UNTESTED, PLACED, FAILS_CLEARANCE, FAILS_CONTACT, FAILS_INTERIOR = -1, 0, 1, 2, 3
#: A placement that passed these tests but whose triangles cross the scene's: detection's
#: exact collision test of the placements it ranks (:class:`~interaction_tensor.detection.ranking.CollisionCheck`).
FAILS_COLLISION = 4
#: A placement whose query object reaches more than the descriptor's ``below_ground`` below
#: the scene's ground (:func:`below_ground`).
FAILS_GROUND = 5
#: A placement whose standing contacts (a seated person's feet) find nothing to stand on
#: within the descriptor's ``feet_reach`` below them and dangle from a seat out of reach
#: (:func:`feet_pass`), or whose rider's feet find no floor or rest within it.
FAILS_FEET = 6
#: A placement with nothing going on between the legs ahead of the seat, or with the scene
#: where a leg goes on either side of it: the descriptor's ``straddle`` boxes
#: (:func:`straddle_passes`; riding).
FAILS_STRADDLE = 7
#: A placement whose reference point (a rider's seat) is more than the descriptor's
#: ``mount_height`` above the scene's ground (:func:`above_ground`; riding).
FAILS_MOUNT = 8
#: How far (m) above a sole a surface may be and still be what the foot stands on (the
#: judge's contact tolerance).
FEET_TOLERANCE = 0.02
#: How far (m) below the ground a foot with nothing under it may be: deeper, it hangs past
#: the edge of the scan's floor, under everything scanned around (the judge's
#: ``feet_below_ground``).
FEET_BELOW_GROUND = 0.05
#: Highest (m) above the ground a surface the feet stand on may be: higher, it is a ledge no
#: one climbs to from the floor to sit (the top of a 3 m wall unit with the feet on its
#: lower ledge; the judge's ``feet_above_ground``).
FEET_ABOVE_GROUND = 0.6
#: Highest (m) above the ground a seat may be for the feet to dangle from it (a desk's, a
#: table's or a counter's edge, on which the blind panel's raters passed a person with the
#: feet in the air); higher, no one climbs up to sit there. The judge's
#: ``seat_above_ground``, for sitting and riding alike.
SEAT_REACH = 1.2
#: How far (m) below a rider's soles a floor or a foot rest (at any height: a desk under a
#: partition's top) may be: the example rider's bent legs straightened (its soles are 0.37 m
#: under its seat). A rider straddles a 0.9 m wall on tiptoe, not a 2.4 m partition's top
#: with the feet a metre above the floor. The judge's ``rider_feet_reach``.
RIDER_REACH = 0.65
#: How far (m) above its lowest point a rider's feet reach (the judge's ``feet_height``).
FEET_HEIGHT = 0.12
#: How far (m) beyond the query object's size the ground is looked for around a placement
#: (the judge's ``ground_radius``).
GROUND_RADIUS = 1.5
#: A placement whose posed through-section (the opening of a hook or a strap's loop, where
#: the example's rail went through) no scene sample crosses (:func:`through_crossed`;
#: hanging). Detection's exact test (:class:`~interaction_tensor.detection.ranking.CollisionCheck`) asks the scene's
#: triangles the same of the pairs it ranks; this one asks every pair, so that the exact
#: tests are spent on pairs with something through the hook.
FAILS_THROUGH = 9
#: How far (in scene spacings) a sample may lie from the plane of the posed through-section
#: and count as crossing it (inside the polygon): a surface that crosses the section has
#: samples within about a spacing of the crossing.
THROUGH_SLAB = 1.0
#: Smallest angle (degrees) at which a surface must cross the plane of the through-section
#: for its samples to count: a rail or a panel's edge through the hook crosses it at about
#: 90; a wall or a board lying in that plane (a hook flat against it, the handbag's strap
#: along a cabinet's side) does not go through the opening (a fifth of the handbag's random
#: pairs in the validation rooms crossed it only so). Not 45: a hook turned 45 degrees to a
#: wall, one of the 8 orientations, has the wall across it at exactly that.
THROUGH_MIN_ANGLE = 30.0
#: Placements per chunk of the reference through test: its neighbour lists hold about 40
#: samples a placement at 1 cm, each tested against every edge of the polygon (about 25:
#: 400 bytes each), so a chunk takes some 60 MB.
THROUGH_CHUNK = 4_000
#: A placement of a container (a descriptor that asks for the filling tests,
#: :attr:`~.descriptor.InteractionTensor.fills`) with no tap's spout above its opening
#: (:func:`tap_passes`): asked of every pair first, it rejects all but a few hundred of a
#: kitchen's hundreds of thousands (shelves, cabinets and table tops cover the opening).
FAILS_TAP = 10
#: Contact modes: no contact test, the main group (at the reference point), every group,
#: or a person's seat region (:func:`seat_region`).
CONTACT_MODES = ("off", "main", "all", "seat")
#: A person's seat region (the ``seat`` contact mode; the judge's main contact of a person,
#: ``itensor_paper.judge.Judge._main_contact``): the query's surface within
#: ``SEAT_REGION_HEIGHT`` (m) above its lowest point among the samples within
#: ``SEAT_RADIUS`` (m) of the reference point and not lower than it by more than that
#: height: buttocks, crotch and thighs, whichever a seat of another shape touches.
SEAT_RADIUS = 0.3
SEAT_REGION_HEIGHT = 0.03
#: Query surface samples the seat region is found among, and at most how many of them it
#: keeps (evenly thinned: each placement looks each one up).
SEAT_SAMPLES = 20_000
SEAT_POINTS = 128


def point_offsets(points, reference_point, n_orientations: int) -> np.ndarray:
    """(O, K, 3) training-frame ``points`` relative to a test point, per orientation
    (``Rz(angle) (c - reference_point)``)."""
    rot = rotation_z(2 * np.pi * np.arange(n_orientations) / n_orientations)
    rel = np.asarray(points, float).reshape(-1, 3) - reference_point
    return np.einsum("oij,kj->oki", rot, rel)


def clearance_offsets(tensor, n_orientations: int) -> np.ndarray:
    """(O, K, 3) clearance points relative to a test point, per orientation."""
    return point_offsets(tensor.clearance_points, tensor.reference_point, n_orientations)


def violations(points: np.ndarray, orient: np.ndarray, offsets: np.ndarray,
               radius: np.ndarray, tolerance: float, nearest_distance) -> np.ndarray:
    """Clearance points violated by each placement.

    Parameters
    ----------
    points : (P, 3) test points, metres
    orient : (P,) int orientation index of each placement
    offsets : (O, K, 3) from :func:`clearance_offsets`
    radius : (K,) free space of each clearance point in the example (m)
    tolerance : metres
    nearest_distance : callable mapping (Q, 3) queries to the (Q,) distance (m) of their
        nearest scene sample

    Returns (P,) int64 counts in [0, K].
    """
    points = np.asarray(points, float)
    orient = np.asarray(orient, np.int64)
    k = offsets.shape[1]
    out = np.zeros(len(points), np.int64)
    if k == 0 or len(points) == 0:
        return out
    need = np.asarray(radius, float) - tolerance            # (K,)
    active = np.flatnonzero(need > 0)
    if len(active) == 0:
        return out
    off = offsets[:, active]
    need = need[active]
    step = max(1, CHUNK_QUERIES // len(active))
    for s in range(0, len(points), step):
        q = points[s:s + step, None, :] + off[orient[s:s + step]]     # (p, k, 3)
        d = np.asarray(nearest_distance(q.reshape(-1, 3))).reshape(q.shape[:2])
        out[s:s + step] = (d < need).sum(axis=1)
    return out


def count_violations(points: np.ndarray, orient: np.ndarray, offsets: np.ndarray,
                     radius: np.ndarray, tolerance: float, scene, grid=None,
                     stop: int | None = None) -> np.ndarray:
    """:func:`violations` of placements in ``scene``: on the Numba grid (``grid``, exact
    ball-emptiness tests, ``_numba_clearance``) when one is given, else with the scene's
    cKDTree (the reference). On the grid a pair's count stops at ``stop`` (None: every
    clearance point counted): a count of ``stop`` means at least that many. Returns (P,)
    int64."""
    if grid is None:
        return violations(points, orient, offsets, radius, tolerance,
                          nearest_distance_function(scene, None, float(np.max(radius, initial=0))))
    from interaction_tensor.placement import _kernels as _numba_clearance

    need = np.asarray(radius, float) - tolerance
    active = np.flatnonzero(need > 0)
    if len(active) == 0 or len(points) == 0:
        return np.zeros(len(points), np.int64)
    return _numba_clearance.counts(points, np.ascontiguousarray(orient, np.int64),
                                   offsets[:, active], need[active], grid, stop)


def nearest_samples(queries: np.ndarray, scene, grid=None):
    """Each query's nearest scene sample, exactly: ((Q,) distances in m, (Q,) indices into
    ``scene.points``); on the Numba grid when one is given, else with the scene's cKDTree
    (the reference)."""
    q = np.asarray(queries, np.float64).reshape(-1, 3)
    if len(q) == 0:
        return np.zeros(0), np.zeros(0, np.int64)
    if grid is None:
        d, i = scene.tree.query(q, workers=-1)
        return d, np.asarray(i, np.int64)

    i = nearest_indices(grid, q)
    return np.linalg.norm(scene.points[i] - q, axis=1), i


def _within(queries, lo: float, hi: float, grid) -> np.ndarray:
    """(Q,) distances of queries (..., 3) to the nearest scene sample where it lies within
    ``hi`` and beyond ``lo``, some distance up to ``lo`` where one lies that near, inf where
    none lies within ``hi`` (``_numba_clearance.bounded_nearest``): ``d <= r`` for any r in
    [lo, hi] is then exactly :func:`nearest_samples`' answer, without searching farther
    than ``hi`` (a contact point in the air searched far for its nearest sample)."""
    from interaction_tensor.placement import _kernels as _numba_clearance

    return _numba_clearance.nearest_within(queries, lo, hi, grid)


def contact_fractions(points, orient, tensor, tests, n_orientations: int, scene,
                      grid=None, chunk: int = 8192) -> np.ndarray:
    """(P, T, G) float64: per placement, contact test ``tests[t]`` = (distance m, angle
    degrees) and contact group ``g``, the fraction of the group's points whose nearest scene
    sample lies within the distance and, for an angle below 90, has a normal line within
    the angle of the example's (rotated with the placement). The nearest sample is found
    once for all the tests; G = 0 when the descriptor has none. ``chunk`` placements at a
    time bound the memory."""
    groups = np.asarray(tensor.contact_group_ids, np.int64)
    tests = [(float(d), float(a)) for d, a in tests]
    n_g = int(groups.max()) + 1 if len(groups) else 0
    out = np.zeros((len(points), len(tests), n_g))
    if n_g == 0 or len(points) == 0:
        return out
    offsets = point_offsets(tensor.contact_group_points, tensor.reference_point, n_orientations)
    rot = rotation_z(2 * np.pi * np.arange(n_orientations) / n_orientations)
    normals = np.einsum("oij,kj->oki", rot, np.asarray(tensor.contact_group_normals, float))
    size = np.bincount(groups, minlength=n_g).astype(float)
    member = groups[None, :] == np.arange(n_g)[:, None]                       # (G, K)
    points = np.asarray(points, float)
    orient = np.asarray(orient, np.int64)
    # on the grid a search bounded by the largest distance: distances alone (no angle
    # test) stop at the first sample within the least one; with an angle test, the nearest
    # sample within the largest, whose normal the angle test reads (_numba_clearance)
    angles = any(a < 90 for _, a in tests)
    far = max(t[0] for t in tests)
    for s in range(0, len(points), chunk):
        o = orient[s:s + chunk]
        q = points[s:s + chunk, None, :] + offsets[o]                          # (p, K, 3)
        if grid is not None and not angles:
            d = _within(q, min(t[0] for t in tests), far, grid)
        elif grid is not None:
            from interaction_tensor.placement import _kernels as _numba_clearance

            d, i = _numba_clearance.nearest_within(q, 0.0, far, grid, index=True)
            i = np.maximum(i, 0)                     # no sample within: d is inf, no touch
        else:
            d, i = nearest_samples(q.reshape(-1, 3), scene, grid)
        d = d.reshape(q.shape[:2])
        cos = None
        if any(a < 90 for _, a in tests):
            cos = np.abs(np.einsum("pki,pki->pk", scene.normals[i].reshape(q.shape),
                                   normals[o]))
        for t, (dist, angle) in enumerate(tests):
            touch = d <= dist
            if angle < 90:
                touch &= cos >= np.cos(np.radians(angle)) - 1e-12
            out[s:s + chunk, t] = (touch.astype(float) @ member.T) / size
    return out


def seat_region(tensor) -> np.ndarray:
    """(S, 3) training-frame samples of the descriptor's seat region (see
    :data:`SEAT_RADIUS`), at most :data:`SEAT_POINTS`; seeded, so the same on every call
    (kept on the descriptor after the first)."""
    cached = getattr(tensor, "_seat_region", None)
    if cached is not None:
        return cached

    region = np.zeros((0, 3))
    if len(tensor.query_faces):
        pts, _ = sample_mesh(Geometry(np.asarray(tensor.query_vertices, float),
                                      np.asarray(tensor.query_faces)), SEAT_SAMPLES, 0)
        ref = np.asarray(tensor.reference_point, float)
        near = ((np.linalg.norm(pts - ref, axis=1) <= SEAT_RADIUS)
                & (pts[:, 2] >= ref[2] - SEAT_REGION_HEIGHT))
        if near.any():
            low = pts[near, 2].min()
            region = pts[near & (pts[:, 2] <= low + SEAT_REGION_HEIGHT)]
            if len(region) > SEAT_POINTS:
                region = region[np.linspace(0, len(region) - 1, SEAT_POINTS).astype(np.int64)]
    tensor._seat_region = region
    return region


def seat_fractions_at(rot, shift, tensor, distance: float, scene, grid=None) -> np.ndarray:
    """(P,) fraction of the seat region (:func:`seat_region`) posed by ``rot`` (P, 3, 3) and
    ``shift`` (P, 3) whose nearest scene sample lies within ``distance`` (m); 1 where the
    descriptor has no seat region."""
    rot = np.asarray(rot, float).reshape(-1, 3, 3)
    region = seat_region(tensor)
    if len(region) == 0 or len(rot) == 0:
        return np.ones(len(rot))
    q = np.einsum("pij,kj->pki", rot, region) + np.asarray(shift, float).reshape(-1, 1, 3)
    d = (_within(q, distance, distance, grid) if grid is not None
         else nearest_samples(q.reshape(-1, 3), scene, grid)[0])
    return (d.reshape(q.shape[:2]) <= distance).mean(axis=1)


def seat_fractions(points, orient, tensor, distance: float, n_orientations: int, scene,
                   grid=None, chunk: int = 8192) -> np.ndarray:
    """(P,) :func:`seat_fractions_at` of placements (test points (P, 3), orientation
    indices (P,)), ``chunk`` placements at a time."""
    points = np.asarray(points, float).reshape(-1, 3)
    rots = rotation_z(2 * np.pi * np.arange(n_orientations) / n_orientations)
    out = np.ones(len(points))
    for s in range(0, len(points), chunk):
        rot = rots[np.asarray(orient[s:s + chunk], np.int64)]
        shift = points[s:s + chunk] - np.einsum("pij,j->pi", rot, tensor.reference_point)
        out[s:s + chunk] = seat_fractions_at(rot, shift, tensor, distance, scene, grid)
    return out


def seat_fractions_poses(poses, tensor, distance: float, scene, grid=None) -> np.ndarray:
    """(P,) :func:`seat_fractions_at` of placements given as 4x4 poses (P, 4, 4)."""
    poses = np.asarray(poses, float).reshape(-1, 4, 4)
    return seat_fractions_at(poses[:, :3, :3], poses[:, :3, 3], tensor, distance, scene, grid)


def contact_kept(fractions: np.ndarray, mode: str, fraction: float) -> np.ndarray:
    """(P,) bool: placements whose contact groups (``fractions`` (P, G) from
    :func:`contact_fractions`) pass: group 0 (``main``) or every group (``all``) has at least
    ``fraction`` of its points touching; always true with ``off`` or no groups (the ``seat``
    mode is :func:`seat_fractions`' instead)."""
    if mode not in CONTACT_MODES:
        raise ValueError(f"contact mode must be one of {CONTACT_MODES}, got {mode!r}")
    if mode in ("off", "seat") or fractions.shape[1] == 0:
        return np.ones(len(fractions), bool)
    f = fractions[:, :1] if mode == "main" else fractions
    return (f >= fraction - 1e-9).all(axis=1)


def interior_violations(points, orient, tensor, tolerance: float, n_orientations: int, scene,
                        grid=None, stop: int | None = None) -> np.ndarray:
    """(P,) int64: interior points of each placement with a scene sample nearer than their
    depth less ``tolerance`` (the scene passes through the object there), counted up to
    ``stop`` on the grid (:func:`count_violations`)."""
    if len(tensor.interior_points) == 0:
        return np.zeros(len(points), np.int64)
    offsets = point_offsets(tensor.interior_points, tensor.reference_point, n_orientations)
    return count_violations(points, orient, offsets, tensor.interior_radius, tolerance, scene,
                            grid, stop=stop)


def below_ground(points, tensor, scene) -> np.ndarray:
    """(P,) how far (m) the query object posed at each test point reaches below the scene's
    ground (:meth:`~.scene.Scene.ground_level`, within :data:`GROUND_RADIUS` plus the
    object's size); negative when it stays above. Turning about +Z keeps the object's lowest
    point, so the orientation does not matter."""
    v = tensor.query_vertices if len(tensor.query_vertices) else tensor.clearance_points
    lowest = float(v[:, 2].min() - tensor.reference_point[2])
    points = np.asarray(points, float)
    ground = scene.ground_level(points, GROUND_RADIUS + tensor.radius)
    return ground - (points[:, 2] + lowest)


def above_ground(points, tensor, scene) -> np.ndarray:
    """(P,) how far (m) test points (the posed reference point: a rider's seat) are above
    the scene's ground (:meth:`~.scene.Scene.ground_level`, within :data:`GROUND_RADIUS`
    plus the object's size)."""
    points = np.asarray(points, float).reshape(-1, 3)
    return points[:, 2] - scene.ground_level(points, GROUND_RADIUS + tensor.radius)


def standing_groups(tensor, tolerance: float = 0.02) -> list:
    """The example's standing contacts: each contact group whose points all lay within
    ``tolerance`` (m) of the example's ground (a seated person's feet; none without a
    ground); for a mounted example (``mount_height``: a rider, its feet on the pegs above
    the ground) its feet as the judge finds them, :func:`rider_feet`. Returns a list of
    ((F, 3) training-frame points, sole height m)."""
    if tensor.mount_height is not None:
        return rider_feet(tensor)
    if tensor.ground is None or len(tensor.contact_group_ids) == 0:
        return []
    ids = np.asarray(tensor.contact_group_ids)
    pts = np.asarray(tensor.contact_group_points, float)
    return [(pts[ids == g], float(pts[ids == g, 2].min())) for g in np.unique(ids)
            if pts[ids == g, 2].max() <= tensor.ground + tolerance]


def split_feet(points, height: float = FEET_HEIGHT) -> list:
    """A person's two feet among its surface points (N, 3), training frame: the points
    within ``height`` (m) of the lowest, on either side of the median across (y). The
    judge's feet, and detection's for a rider (:func:`rider_feet`)."""
    points = np.asarray(points, float).reshape(-1, 3)
    low = points[points[:, 2] <= points[:, 2].min(initial=np.inf) + height]
    mid = np.median(points[:, 1]) if len(points) else 0.0
    return [low[low[:, 1] > mid], low[low[:, 1] <= mid]]


def rider_feet(tensor, cell: float = 0.02) -> list:
    """A rider's two feet (:func:`split_feet` of the query's vertices), each thinned to one
    vertex a ``cell`` (m) square (the feet test searches a 2 cm column and its neighbours
    under each), with the foot's lowest height as its sole."""
    feet = []
    for foot in split_feet(tensor.query_vertices):
        if len(foot):
            _, keep = np.unique(np.floor(foot[:, :2] / cell).astype(np.int64), axis=0,
                                return_index=True)
            feet.append((foot[np.sort(keep)], float(foot[:, 2].min())))
    return feet


def feet_gaps_at(feet: list, scene, ground: np.ndarray, tolerance: float = FEET_TOLERANCE,
                 tops=None, ledge: float = FEET_ABOVE_GROUND):
    """(P,) the largest, over the standing groups, of the drop (m) from a group's posed sole
    to what it would stand on: the highest scene sample at most ``tolerance`` above the sole
    in the 2 cm columns under the group's contact points and their neighbours
    (:meth:`~.scene.Scene.highest_under`; the judge's footprint with a margin of 2-4 cm),
    or, with nothing under it at all, ``ground`` (P,) (the lowest scene sample around: a
    scan without its floor). ``feet`` holds, per group, ((P, F, 3) posed contact points,
    (P,) posed sole heights). Negative when the sole is below the surface it meets; inf
    when a group with nothing under it is more than :data:`FEET_BELOW_GROUND` below the
    ground (it hangs past the edge of the scan's floor) or stands on a surface more than
    ``ledge`` (:data:`FEET_ABOVE_GROUND`) above it (a ledge no one climbs to). ``tops``, if
    given, maps (group index, limit (P,)) to what ``highest_under`` finds there (the Numba
    kernel's answer, without the posed points, which may then be None)."""
    worst = np.full(len(ground), -np.inf)
    for g, (posed, soles) in enumerate(feet):
        top = (scene.highest_under(posed[:, :, :2], soles + tolerance) if tops is None
               else tops(g, soles + tolerance))
        none = ~np.isfinite(top)
        gap = soles - np.where(none, ground, top)
        gap[none & (soles < ground - FEET_BELOW_GROUND)] = np.inf
        gap[~none & (top > ground + ledge)] = np.inf
        worst = np.maximum(worst, gap)
    return worst


def ledge_height(tensor) -> float:
    """How high above the ground a surface the feet stand on may be (:func:`feet_gaps_at`):
    :data:`FEET_ABOVE_GROUND` for a seated person, any height for a rider's foot rest."""
    return np.inf if tensor.mount_height is not None else FEET_ABOVE_GROUND


def feet_pass(gaps, seat_heights, reach: float, seat_reach: float = SEAT_REACH) -> np.ndarray:
    """(P,) bool: the feet test of placements whose standing contacts are ``gaps`` (m) above
    what they would stand on (:func:`feet_gaps_at`) and whose seat is ``seat_heights`` (m)
    above the ground. The feet reach a floor, a step or a foot rest (a gap of at most
    ``reach``), or they dangle from a seat within ``seat_reach`` of the ground; a foot past
    the edge of the scan's floor or on a ledge no one climbs to (an infinite gap) fails
    either way."""
    gaps = np.asarray(gaps, float)
    return (gaps <= reach) | (np.isfinite(gaps)
                              & (np.asarray(seat_heights, float) <= seat_reach))


def feet_gaps(points, orient, tensor, scene, n_orientations: int, grid=None) -> np.ndarray:
    """(P,) :func:`feet_gaps_at` of placements (test points (P, 3), orientation indices
    (P,)); -inf for a descriptor without standing contacts. With ``grid`` (Numba), the
    columns are searched by a kernel over the scene's column table
    (:meth:`~.scene.ColumnIndex.table`; the reference where it has none), without the
    posed points' (P, F, 3) arrays."""
    points = np.asarray(points, float)
    orient = np.asarray(orient, np.int64)
    groups = standing_groups(tensor)
    if not groups or len(points) == 0:
        return np.full(len(points), -np.inf)
    ground = scene.ground_level(points, GROUND_RADIUS + tensor.radius)
    offsets = [point_offsets(g, tensor.reference_point, n_orientations) for g, _ in groups]
    soles = [points[:, 2] + (sole - tensor.reference_point[2]) for _, sole in groups]
    columns = scene.columns() if grid is not None else None
    table = columns.table() if columns is not None else None
    if table is None:
        feet = [(points[:, None, :] + off[orient], sole) for off, sole in zip(offsets, soles)]
        return feet_gaps_at(feet, scene, ground, ledge=ledge_height(tensor))
    from interaction_tensor.placement import _kernels as _numba_clearance

    def tops(g, limit):
        return _numba_clearance.highest(points, orient, offsets[g][:, :, :2], limit, table,
                                        columns.cell)
    return feet_gaps_at([(None, sole) for sole in soles], scene, ground, tops=tops,
                        ledge=ledge_height(tensor))


def feet_gaps_poses(poses, tensor, scene) -> np.ndarray:
    """(P,) :func:`feet_gaps_at` of placements given as 4x4 poses (P, 4, 4) of the
    training-frame query (a turn about +Z and a move: the judge's labelled poses)."""
    poses = np.asarray(poses, float).reshape(-1, 4, 4)
    groups = standing_groups(tensor)
    if not groups or len(poses) == 0:
        return np.full(len(poses), -np.inf)
    at = np.einsum("pij,j->pi", poses[:, :3, :3], tensor.reference_point) + poses[:, :3, 3]
    ground = scene.ground_level(at, GROUND_RADIUS + tensor.radius)
    feet = []
    for g, sole in groups:
        posed = np.einsum("pij,fj->pfi", poses[:, :3, :3], g) + poses[:, None, :3, 3]
        feet.append((posed, posed[:, :, 2].min(axis=1)))      # the sole: its lowest point
    return feet_gaps_at(feet, scene, ground, ledge=ledge_height(tensor))


def _ball_members(scene, centres, reach):
    """The scene samples within ``reach`` of each of ``centres`` (C, 3) as flat arrays
    (sample indices, owning centre), or None where no centre has any (the cKDTree
    references of the box and through tests)."""
    groups = scene.tree.query_ball_point(centres, reach)
    sizes = np.fromiter((len(g) for g in groups), np.int64, len(groups))
    if sizes.sum() == 0:
        return None
    return (np.concatenate([np.asarray(g, np.int64) for g in groups]),
            np.repeat(np.arange(len(centres)), sizes))


def _box_reference(rot, at, box, scene) -> np.ndarray:
    """(P,) whether a scene sample lies in each placement's box (:func:`box_occupied`'s test
    with the scene's cKDTree: the samples within the box's half-diagonal of its posed centre,
    then the exact test; the reference of the Numba kernel ``_numba_clearance.box_hits``)."""
    box = np.asarray(box, float)
    mid = box.mean(axis=1)
    reach = float(np.linalg.norm(box[:, 1] - box[:, 0])) / 2 + 1e-9
    hit = np.zeros(len(at), bool)
    for s in range(0, len(at), THROUGH_CHUNK):
        r, a = rot[s:s + THROUGH_CHUNK], at[s:s + THROUGH_CHUNK]
        centres = a + np.c_[np.einsum("pij,j->pi", r, mid[:2]), np.full(len(a), mid[2])]
        found = _ball_members(scene, centres, reach)
        if found is None:
            continue
        idx, owner = found
        d = scene.points[idx] - a[owner]
        uv = np.einsum("pji,pj->pi", r[owner], d[:, :2])          # rot.T @ (p - at)
        inside = ((uv[:, 0] >= box[0, 0]) & (uv[:, 0] <= box[0, 1]) & (uv[:, 1] >= box[1, 0])
                  & (uv[:, 1] <= box[1, 1]) & (d[:, 2] >= box[2, 0]) & (d[:, 2] <= box[2, 1]))
        hit[s + owner[inside]] = True
    return hit


def box_occupied(rot, at, box, scene, grid=None) -> np.ndarray:
    """(P,) whether a scene sample lies in a box ``((x0, x1), (y0, y1), (z0, z1))`` fixed to
    placements: relative to ``at`` (P, 3) and turned about +Z by ``rot`` (P, 2, 2), edges
    included (the judge's astride and legroom columns). Exact: on the Numba grid when one
    is given, else with the scene's cKDTree (the reference; the same test)."""
    rot = np.asarray(rot, float).reshape(-1, 2, 2)
    at = np.asarray(at, float).reshape(-1, 3)
    if grid is None:
        return _box_reference(rot, at, box, scene)
    from interaction_tensor.placement import _kernels as _numba_clearance

    return _numba_clearance.boxes(at, rot, np.asarray(box, float), grid)


def straddle_passes_at(rot: np.ndarray, at: np.ndarray, straddle: dict, scene,
                       grid=None) -> np.ndarray:
    """(P,) whether placements pass the straddle test: a scene sample in the ``astride`` box
    and none in a ``legroom`` box (:attr:`~.descriptor.InteractionTensor.straddle`; boxes
    relative to the reference point, training frame), the placement turning the boxes by
    ``rot`` (P, 2, 2) about +Z and moving them to ``at`` (P, 3), the posed reference
    point. The samples in a box themselves, as the judge counts them
    (:func:`box_occupied`)."""
    at = np.asarray(at, float).reshape(-1, 3)
    rot = np.asarray(rot, float).reshape(-1, 2, 2)
    ok = np.ones(len(at), bool)
    boxes = ([(straddle["astride"], True)] if straddle.get("astride") is not None else []) + \
        [(b, False) for b in straddle.get("legroom", ())]
    for box, wanted in boxes:
        todo = np.flatnonzero(ok)
        if len(todo) == 0:
            break
        hit = box_occupied(rot[todo], at[todo], box, scene, grid)
        ok[todo[hit != wanted]] = False
    return ok


def straddle_passes(points, orient, tensor, scene, n_orientations: int,
                    grid=None) -> np.ndarray:
    """(P,) :func:`straddle_passes_at` of placements (test points (P, 3) at the reference
    point, orientation indices (P,)); all True for a descriptor without the test."""
    points = np.asarray(points, float).reshape(-1, 3)
    if tensor.straddle is None or len(points) == 0:
        return np.ones(len(points), bool)
    rot = rotation_z(2 * np.pi * np.arange(n_orientations) / n_orientations)[:, :2, :2]
    return straddle_passes_at(rot[np.asarray(orient, np.int64)], points, tensor.straddle,
                              scene, grid)


def straddle_passes_poses(poses, tensor, scene, grid=None) -> np.ndarray:
    """(P,) :func:`straddle_passes_at` of placements given as 4x4 poses (P, 4, 4) of the
    training-frame query (a turn about +Z and a move: the judge's labelled poses)."""
    poses = np.asarray(poses, float).reshape(-1, 4, 4)
    if tensor.straddle is None or len(poses) == 0:
        return np.ones(len(poses), bool)
    at = np.einsum("pij,j->pi", poses[:, :3, :3], tensor.reference_point) + poses[:, :3, 3]
    return straddle_passes_at(poses[:, :2, :2], at, tensor.straddle, scene, grid)


def through_polygon(section) -> tuple:
    """A through-section (K, 3) (:attr:`~.descriptor.InteractionTensor.through_section`, a
    flat convex polygon) in its own plane: (centre (3,), axes (3, 3) with rows u, v and the
    normal n, (K, 2) vertices counter-clockwise in (u, v))."""
    ring = np.asarray(section, float).reshape(-1, 3)
    centre = ring.mean(axis=0)
    vt = np.linalg.svd(ring - centre, full_matrices=False)[2]
    axes = np.stack([vt[0], np.cross(vt[2], vt[0]), vt[2]])
    flat = (ring - centre) @ axes[:2].T
    x, y = flat[:, 0], flat[:, 1]
    if np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) < 0:    # clockwise: turn it
        flat = flat[::-1]
    return centre, axes, np.ascontiguousarray(flat)


def _crossed_reference(centres, axes, ring, reach, slab, max_cos, scene) -> np.ndarray:
    """:func:`through_crossed_at`'s test with the scene's cKDTree (the reference of the
    Numba kernel ``_numba_clearance.through_hits``): samples within ``reach`` of each posed
    centre, in the slab, inside the polygon, their normal at most ``max_cos`` along the
    plane's."""
    hit = np.zeros(len(centres), bool)
    edges = np.roll(ring, -1, axis=0) - ring
    for s in range(0, len(centres), THROUGH_CHUNK):
        c = centres[s:s + THROUGH_CHUNK]
        found = _ball_members(scene, c, reach)
        if found is None:
            continue
        idx, owner = found
        local = np.einsum("pij,pj->pi", axes[s:s + THROUGH_CHUNK][owner],
                          scene.points[idx] - c[owner])
        rel = local[:, None, :2] - ring[None]
        across = np.abs(np.einsum("pj,pj->p", scene.normals[idx],
                                  axes[s:s + THROUGH_CHUNK][owner, 2])) <= max_cos
        inside = ((edges[None, :, 0] * rel[..., 1] - edges[None, :, 1] * rel[..., 0]) >= 0
                  ).all(axis=1) & (np.abs(local[:, 2]) <= slab) & across
        hit[s + owner[inside]] = True
    return hit


def through_crossed_at(rot, shift, tensor, scene, grid=None) -> np.ndarray:
    """(P,) whether the scene crosses the descriptor's through-section posed by ``rot``
    (P, 3, 3) and ``shift`` (P, 3) (a training-frame point x goes to ``rot @ x + shift``):
    a scene sample within :data:`THROUGH_SLAB` spacings of its plane, inside the polygon, on
    a surface that crosses the plane at :data:`THROUGH_MIN_ANGLE` or more (a rail, a peg or
    a panel's edge through the hook; a hook beside an edge, over a flat top or flat against
    a wall has none). On the Numba grid when one is given, else with the scene's cKDTree (the
    reference; the same test). All True for a descriptor without a through-section."""
    rot = np.asarray(rot, float).reshape(-1, 3, 3)
    if len(tensor.through_section) < 3 or len(rot) == 0:
        return np.ones(len(rot), bool)
    centre, axes, ring = through_polygon(tensor.through_section)
    centres = np.einsum("pij,j->pi", rot, centre) + np.asarray(shift, float).reshape(-1, 3)
    posed_axes = np.einsum("pij,kj->pki", rot, axes)           # rows: posed u, v, n
    slab = THROUGH_SLAB * float(scene.spacing)
    reach = float(np.linalg.norm(ring, axis=1).max()) + slab
    max_cos = float(np.cos(np.radians(THROUGH_MIN_ANGLE)))
    if grid is None:
        return _crossed_reference(centres, posed_axes, ring, reach, slab, max_cos, scene)
    from interaction_tensor.placement import _kernels as _numba_clearance

    return _numba_clearance.through(centres, posed_axes, ring, reach, slab, max_cos, grid)


def through_crossed(points, orient, tensor, scene, n_orientations: int,
                    grid=None) -> np.ndarray:
    """(P,) :func:`through_crossed_at` of placements (test points (P, 3), orientation
    indices (P,))."""
    points = np.asarray(points, float).reshape(-1, 3)
    rot = rotation_z(2 * np.pi * np.arange(n_orientations) / n_orientations)[
        np.asarray(orient, np.int64)]
    shift = points - np.einsum("pij,j->pi", rot, tensor.reference_point)
    return through_crossed_at(rot, shift, tensor, scene, grid)


def through_crossed_poses(poses, tensor, scene, grid=None) -> np.ndarray:
    """(P,) :func:`through_crossed_at` of placements given as 4x4 poses (P, 4, 4)."""
    poses = np.asarray(poses, float).reshape(-1, 4, 4)
    return through_crossed_at(poses[:, :3, :3], poses[:, :3, 3], tensor, scene, grid)


def tap_passes(points, orient, tensor, scene, n_orientations: int, grid=None) -> np.ndarray:
    """(P,) whether a tap's spout is above the opening of the container posed at test points
    ``points`` (P, 3) in orientations ``orient`` (P,) (:func:`.taps.taps_above`; the Numba
    kernel on ``grid``, else the reference)."""
    vessel = tensor.vessel()
    offsets = point_offsets(vessel.opening, tensor.reference_point, n_orientations)[:, 0]
    openings = np.asarray(points, float) + offsets[np.asarray(orient, np.int64)]
    return taps.taps_above(openings, scene.points, scene.tree, grid)


#: The order of the placement tests: the cheapest per pair and the most rejecting first (a
#: pair stops at the first it fails, so the order changes the work and which failure a pair
#: reports, never a decision). Measured per pair on the published scenes at the defaults
#: (``benchmarks/run.py --only tests``): the ground and mount tests read a map (0.2-0.8 us)
#: and reject 19-65 % of a person's pairs, the feet test a column table (4 us, 84 % of a
#: seated person's), the straddle test visits the cells under two boxes (11 us, 99.9 % of a
#: rider's), then the ball tests: clearance (7-15 us), through, interior (20 us) and the
#: contact test, which rejects the fewest (2-6 %).
TEST_ORDER = ("fills", "ground", "mount", "feet", "straddle", "clearance", "through",
              "interior", "contact")


def check_placements(points, orient, tensor, settings, scene, grid=None):
    """The placement tests of pairs, in :data:`TEST_ORDER`, each on the pairs that passed
    the tests before it: tap (a container's, when the descriptor asks for the filling
    tests: :func:`tap_passes`), ground (when the descriptor has ``below_ground``: the query
    object no deeper than that below the scene's ground), mount (when it has
    ``mount_height``: the reference point no higher than that above the ground,
    :func:`above_ground`), feet (when it has ``feet_reach``: its standing contacts find
    something to stand on, or dangle from a seat within reach, :func:`feet_pass`; a
    rider's feet find a floor or a rest at any height within reach, no dangling),
    straddle (when it has ``straddle``: :func:`straddle_passes`), clearance (every
    descriptor with clearance points), through (when the descriptor asks for its
    through-section to be crossed: :func:`through_crossed`), interior and contact.

    Parameters
    ----------
    points : (P, 3) test points; orient : (P,) orientation indices
    tensor : the descriptor (its points, radii and limits)
    settings : DetectSettings (which tests run: ``skip_tests``; ``n_orientations``)

    Returns ``(clearance violations (P,) int64, -1 where the clearance test did not run,
    outcome (P,) int8)``, outcome :data:`PLACED` or the first test failed
    (:data:`FAILS_CLEARANCE`, ...).
    """
    n_o = settings.n_orientations
    p = len(points)
    outcome = np.full(p, PLACED, np.int8)
    viol = np.full(p, -1, np.int64)
    k = len(tensor.clearance_points)
    n_int = len(tensor.interior_points)
    mode = tensor.contact_groups if settings.runs("contact") else "off"

    def fills(at, o):
        return tap_passes(at, o, tensor, scene, n_o, grid)

    def ground(at, o):
        return below_ground(at, tensor, scene) <= tensor.below_ground

    def mount(at, o):
        return above_ground(at, tensor, scene) <= tensor.mount_height

    def feet(at, o):
        gaps = feet_gaps(at, o, tensor, scene, n_o, grid)
        if tensor.mount_height is not None:           # a rider's feet reach a floor or a rest
            return gaps <= tensor.feet_reach
        return feet_pass(gaps, above_ground(at, tensor, scene), tensor.feet_reach)

    def straddle(at, o):
        return straddle_passes(at, o, tensor, scene, n_o, grid)

    def clearance(at, o):
        # a pair fails past limit * k violations: its count stops at the first past it
        limit = tensor.clearance_limit
        v = count_violations(at, o, clearance_offsets(tensor, n_o), tensor.clearance_radius,
                             CLEARANCE_TOLERANCE, scene, grid,
                             stop=int(np.floor(limit * k)) + 1)
        return v <= limit * k, v

    def through(at, o):
        return through_crossed(at, o, tensor, scene, n_o, grid)

    def interior(at, o):
        limit = tensor.interior_limit * n_int
        return interior_violations(at, o, tensor, INTERIOR_TOLERANCE, n_o, scene, grid,
                                   stop=int(np.floor(limit)) + 1) <= limit

    def contact(at, o):
        if mode == "seat":
            frac = seat_fractions(at, o, tensor, tensor.contact_distance, n_o, scene, grid)
            return frac >= tensor.contact_fraction - 1e-9
        frac = contact_fractions(at, o, tensor, [(tensor.contact_distance,
                                                  tensor.contact_angle)], n_o, scene,
                                 grid)[:, 0]
        return contact_kept(frac, mode, tensor.contact_fraction)

    steps = {
        "fills": (tensor.fills, fills, FAILS_TAP),
        "ground": (tensor.below_ground is not None, ground, FAILS_GROUND),
        "mount": (tensor.mount_height is not None, mount, FAILS_MOUNT),
        "feet": (tensor.feet_reach is not None, feet, FAILS_FEET),
        "straddle": (tensor.straddle is not None, straddle, FAILS_STRADDLE),
        "clearance": (k > 0, clearance, FAILS_CLEARANCE),
        "through": (bool(tensor.through) and len(tensor.through_section) >= 3, through,
                    FAILS_THROUGH),
        "interior": (n_int > 0 and tensor.interior_limit < 1, interior, FAILS_INTERIOR),
        "contact": (mode != "off" and (mode == "seat" or len(tensor.contact_group_ids) > 0),
                    contact, FAILS_CONTACT),
    }
    for name in TEST_ORDER:
        applies, test, code = steps[name]
        todo = np.flatnonzero(outcome == PLACED)
        if not (applies and settings.runs(name) and len(todo)):
            continue
        passed = test(points[todo], orient[todo])
        if name == "clearance":
            passed, viol[todo] = passed
        outcome[todo[~np.asarray(passed, bool)]] = code
    return viol, outcome


def nearest_distance_function(scene, grid=None, bound: float | None = None):
    """A ``nearest_distance`` for :func:`violations`: the distance (m) to the nearest scene
    sample, or ``inf`` beyond ``bound`` (the test only asks whether a sample is nearer than
    the largest clearance, so a bounded search is exact for it and fast in open space). The
    scene's cKDTree; ``grid`` is accepted for symmetry with the scoring backends."""
    def dist(q):
        return scene.tree.query(q, distance_upper_bound=np.inf if bound is None else bound,
                                workers=-1)[0]
    return dist
