"""The Interaction Tensor: fit from one example, save and load without pickle, pose helpers.

Training data flow (paper, section 3):
example geometry -> surface samples -> bisector surface -> provenance vectors and weights ->
keypoints -> descriptor file.
"""

from __future__ import annotations

import io as _io
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from interaction_tensor._version import __version__
from interaction_tensor.descriptor.bisector import bisector_points, trim_to_sphere
from interaction_tensor.descriptor.calibration import (
    CALIBRATION_POINTS,
    HANGING_BELOW_GROUND,
    HANGING_PERTURBATIONS,
    MIN_THRESHOLD,
    PERTURBATIONS,
    Perturbation,
    hangs_from,
    still_holds,
)
from interaction_tensor.engine.scoring import (
    KeypointTable,
    keypoint_terms,
    make_table,
    pair_test_vectors,
    score_pairs,
    surface_vectors,
)
from interaction_tensor.errors import InputError, SettingsError
from interaction_tensor.geometry.collision import (
    Body,
    MeshCollider,
    part_above,
    person_parts,
    polygon,
    through_section,
)
from interaction_tensor.geometry.core import Geometry, validate_geometry
from interaction_tensor.geometry.files import atomic_path, output_path
from interaction_tensor.geometry.sampling import (
    estimate_normals,
    mean_spacing,
    mesh_area,
    sample_mesh,
    uniform_keypoints,
    weighted_keypoints,
    winding_numbers,
)
from interaction_tensor.geometry.scene import Scene
from interaction_tensor.placement import hooks, taps
from interaction_tensor.settings import (
    CRITERIA,
    KEYPOINT_SETS,
    MIN_SPACING,
    NORMAL_TOLERANCE_DEG,
    DetectSettings,
    TrainSettings,
)

FORMAT = "interaction-tensor-descriptor"
FORMAT_VERSION = 3
#: Versions this code reads: 1 has no clearance points, 1 and 2 no interior points and no
#: contact groups (those tests are then skipped).
READABLE_VERSIONS = (1, 2, 3)
#: Scene-object normals within this angle of the N_aff line may hold the reference point.
REFERENCE_NORMAL_DEG = 30.0
#: Surface samples of the query from which its hook's opening and bottom are measured.
HOOK_SAMPLES = 20_000


@dataclass
class Keypoints:
    """One set of affordance keypoints, sorted by |provenance| ascending (weight descending).

    Attributes
    ----------
    points : (N, 3) float64 keypoint positions, training frame, metres
    provenance : (N, 3) float64 provenance vectors (keypoint -> nearest scene-object point)
    weights : (N,) float64 weights in [0, 1] (eq. 4)
    """

    points: np.ndarray
    provenance: np.ndarray
    weights: np.ndarray


#: Training refuses a query whose surface lies mostly on the scene-object's (a flat query
#: laid in a table top): more than this fraction of its samples within one spacing of it.
#: The shipped examples have 0.3-19 %.
MAX_SURFACE_SHARED = 0.6
#: Training refuses a query with more than this fraction of its surface inside the
#: scene-object (the example's objects interpenetrate; 0 in the shipped examples).
MAX_INSIDE = 0.01
#: (query sample, triangle) terms the winding-number test may cost.
MAX_WINDING_TERMS = 300_000_000


def _check_not_overlapping(query, scene_object, q_pts, q_nrm, gaps, spacing: float,
                           seed: int) -> None:
    """Refuse an example whose objects overlap instead of touching: the query's surface
    lying on the scene-object's, or inside it.

    Inside: a query sample whose two probes, a fifth of a spacing either side of the query's
    surface along its normal, both have a winding number over 0.5 with respect to the
    scene-object (exact for a closed mesh however thin its parts; a touching contact has one
    probe outside). Tested when the scene-object is a closed mesh and the query has normals
    (a mesh); otherwise only the shared-surface test runs."""
    shared = float(np.mean(gaps < spacing))
    if shared > MAX_SURFACE_SHARED:
        raise InputError(query.source, f"{shared:.0%} of the query's surface lies on the "
                                       f"scene-object's (within {spacing:g} m): the objects "
                                       "overlap; pose the query touching the scene-object")
    faces = scene_object.faces if scene_object.is_mesh else None
    n_pts = 0 if faces is None else min(2000, MAX_WINDING_TERMS // (2 * max(len(faces), 1)))
    if q_nrm is None or n_pts < 100 or not _closed(faces):
        return

    rng = np.random.default_rng(seed)
    pick = (np.arange(len(q_pts)) if len(q_pts) <= n_pts
            else rng.choice(len(q_pts), n_pts, replace=False))
    step = 0.2 * spacing * q_nrm[pick]
    probes = np.concatenate([q_pts[pick] + step, q_pts[pick] - step])
    w = winding_numbers(probes, scene_object.vertices, faces).reshape(2, -1)
    share = float(np.mean((w > 0.5).all(axis=0)))
    if share > MAX_INSIDE:
        raise InputError(query.source, f"{share:.0%} of the query's surface lies inside the "
                                       "scene-object: the objects interpenetrate; pose the "
                                       "query touching the scene-object, not through it")


def _closed(faces: np.ndarray) -> bool:
    """Every edge shared by exactly two triangles (a closed, watertight triangle mesh)."""
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]),
                    axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return bool(len(counts)) and bool(np.all(counts == 2))


#: The keys of a descriptor's calibrated tables (``thresholds``, ``self_scores``):
#: ``"<criterion>-<keypoint set>"``, every one of them.
TABLE_KEYS = tuple(f"{c}-{k}" for c in CRITERIA for k in KEYPOINT_SETS)


def _in_range(value, low: float, high: float, low_open: bool = False) -> bool:
    """Whether ``value`` is a real number (not a bool), finite and in [low, high] ((low,
    high] with ``low_open``); a JSON integer too large for a float is not."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        return False
    try:
        v = float(value)
    except (OverflowError, ValueError):
        return False
    return math.isfinite(v) and (v > low if low_open else v >= low) and v <= high


def _short(value, limit: int = 60, quote: bool = True) -> str:
    """``repr(value)`` (or the text itself, without ``quote``) cut to ``limit`` characters:
    a value from a file, shown on one line however long it is."""
    try:
        text = repr(value) if quote else str(value)
    except ValueError:                              # an integer with too many digits
        text = f"<{type(value).__name__}>"
    text = text.encode("unicode_escape").decode("ascii") if not text.isprintable() else text
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _not_plain(value, where: str, depth: int = 0):
    """The path (``meta.a[2]``) of the first part of ``value`` that is not plain JSON (a
    text, a finite number, true/false, null, or lists and tables of them, 32 levels deep at
    most), or None."""
    if value is None or isinstance(value, (str, bool, int)):
        return None
    if isinstance(value, float):
        return None if math.isfinite(value) else where
    if depth >= 32 or not isinstance(value, (list, dict)):
        return where
    items = value.items() if isinstance(value, dict) else enumerate(value)
    for key, item in items:
        if isinstance(value, dict) and not isinstance(key, str):
            return where
        found = _not_plain(item, f"{where}.{str(key)[:40]}"
                           if isinstance(value, dict) else f"{where}[{key}]", depth + 1)
        if found is not None:
            return found
    return None


@dataclass
class InteractionTensor:
    """A single-example affordance descriptor.

    Every position is in the training frame (the frame of the example files, metres, +Z up).
    A prediction at test point ``t`` and orientation angle ``a`` poses the query object with
    ``x -> Rz(a) (x - reference_point) + t`` (:meth:`pose`).

    Attributes
    ----------
    affordance : name, e.g. ``placing-bowl``
    reference_point : (3,) p_scene, the centre of the scene-object's contact region
    affordance_normal : (3,) unit N_aff
    radius : RAD = d_o, the query object's bounding-box diagonal (m)
    query_centroid : (3,) centre of the trimming sphere
    bisector_points, provenance_vectors : (M, 3) the whole trimmed tensor field
    weights : (M,) in [0, 1]
    weighted, uniform : the two keypoint sets
    query_vertices, query_faces : the query object as given (faces (0, 3) for a cloud)
    contact_points : (C, 3) query samples that touch the scene-object in the example
    clearance_points : (K, 3) query surface samples, training frame (iTClearance)
    clearance_radius : (K,) free space (m) around each in the example, at most clearance_max
    clearance_limit : fraction of the clearance points a placement may violate
    interior_points : (I, 3) points inside the query mesh, training frame
    interior_radius : (I,) their depth (m), at most ``interior_max``
    interior_limit : fraction of the interior points a placement may violate (1: no test)
    contact_group_points : (G, 3) query samples that touched the scene-object (or the
        example's ground) in the example, grouped
    contact_group_ids : (G,) int group of each; group 0 is the one at the reference point
    contact_group_normals : (G, 3) unit normal of the scene-object (or ground) each touched
    contact_groups : contact test mode, ``off``, ``main`` (group 0), ``all`` or ``seat`` (a
        person's seat region: ``clearance.seat_region``)
    contact_distance, contact_fraction, contact_angle : a group keeps its contact when this
        fraction of its points have their nearest scene sample within this distance (m),
        whose normal line lies within this angle (degrees; 90: any) of the example's
    collision_tests : detection's collision tests of ranked placements on mesh scenes, each
        (depth, above): the query's triangles above the reference point by more than
        ``above`` m (None: all of them; a rider's legs hang where the support lets them) may
        cross the scene's only as deep as a move of ``depth`` m frees them
        (:mod:`.collision`); a placement must pass every test; empty: no collision test
    through_section : (K, 3) flat polygon, the cross-section of the scene-object that passed
        through the query object in the example (a rail through a hook:
        :func:`.collision.through_section`), or (0, 3)
    through : whether detection asks the scene to cross the posed ``through_section`` (on
        mesh scenes; hanging)
    hangs : whether detection asks a ranked placement to hang from what crosses its
        opening: what crosses fits inside the query's own outline round it (a rail in a
        hook, not a board's edge going on sideways through the wire) and the query's bottom
        keeps off tops and floors (:mod:`~interaction_tensor.placement.hooks`; hanging)
    fills : whether detection asks a ranked placement of the query (a container) to stand
        where it could be filled: a tap's spout above its opening, a basin round it and a
        sink under it (:mod:`~interaction_tensor.placement.taps`; filling)
    ground : height (m) of the ground plane of the example, or None
    below_ground : detection rejects a placement whose query object reaches more than this
        (m) below the scene's ground (the lowest scene sample within 1.5 m of it: a hanger
        hooked round a chair's star base in a scan without its floor hangs through where
        the floor is); None: no such test
    feet_reach : detection rejects a placement whose standing contacts (the contact groups
        that stood on the example's ground: a seated person's feet) find no scene surface
        within this (m) below them, nor the scene's ground, unless they dangle from a seat
        (the reference point) within :data:`~interaction_tensor.placement.checks.SEAT_REACH`
        of the ground (a person on a desk's edge passes, one on a wardrobe's top does not;
        :func:`~interaction_tensor.placement.checks.feet_pass`). With ``mount_height`` (a
        rider) they are the query's feet
        (:func:`~interaction_tensor.placement.checks.rider_feet`), a surface at any height
        is a rest, and the feet never dangle; None: no such test
    straddle : detection's straddle test (riding), or None: ``{"astride": box or None,
        "legroom": [box, ...]}``, boxes ``((x0, x1), (y0, y1), (z0, z1))`` (m, training frame,
        relative to the reference point, turning with the placement): the scene must have
        a sample in the ``astride`` box (something going on between the legs ahead of the
        seat) and none in a ``legroom`` box (room for a leg on each side)
        (:func:`~interaction_tensor.placement.checks.straddle_passes`)
    mount_height : detection rejects a placement whose reference point (a rider's seat) is
        more than this (m) above the scene's ground (the lowest scene sample within 1.5 m):
        no one climbs astride the top of a 2.4 m wall; None: no such test
    normal_tolerance : how far (degrees) a test point's normal may lie from N_aff, unless
        detection's settings give one (``DetectSettings.normal_tolerance_deg``): a tap's
        spout turns its underside 25 degrees off straight down; None: the settings' default
    scene_points : (S, 3) scene-object samples used for the Voronoi step (subsampled)
    scene_spacing : spacing (m) of the scene-object samples; detection samples at it
    vectors : ``surface`` or ``points``, how provenance (and test) vectors are measured
    thresholds : acceptance thresholds, key ``"<criterion>-<keypoint set>"``: derived from
        the example (:mod:`.calibration`) until :meth:`set_acceptance` sets them
    self_scores : score of the example on a re-sampled scene-object, same keys
    meta : settings, sources, timings, versions
    """

    affordance: str
    reference_point: np.ndarray
    affordance_normal: np.ndarray
    radius: float
    query_centroid: np.ndarray
    bisector_points: np.ndarray
    provenance_vectors: np.ndarray
    weights: np.ndarray
    weighted: Keypoints
    uniform: Keypoints
    query_vertices: np.ndarray
    query_faces: np.ndarray
    contact_points: np.ndarray
    scene_points: np.ndarray
    scene_spacing: float
    vectors: str = "surface"
    clearance_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    clearance_radius: np.ndarray = field(default_factory=lambda: np.zeros(0))
    clearance_limit: float = 0.05
    interior_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    interior_radius: np.ndarray = field(default_factory=lambda: np.zeros(0))
    interior_limit: float = 1.0
    contact_group_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    contact_group_ids: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    contact_group_normals: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    contact_groups: str = "off"
    contact_distance: float = 0.02
    contact_fraction: float = 0.25
    contact_angle: float = 90.0
    collision_tests: tuple = ()
    through_section: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    through: bool = False
    hangs: bool = False
    fills: bool = False
    ground: float | None = None
    below_ground: float | None = None
    feet_reach: float | None = None
    straddle: dict | None = None
    mount_height: float | None = None
    normal_tolerance: float | None = None
    thresholds: dict = field(default_factory=dict)
    self_scores: dict = field(default_factory=dict)
    meta: dict = field(default_factory=dict)

    # ------------------------------------------------------------------ helpers
    def keypoints(self, which: str = "weighted") -> Keypoints:
        """The ``weighted`` or ``uniform`` keypoint set."""
        if which not in ("weighted", "uniform"):
            raise ValueError(f"unknown keypoint set {which!r}")
        return getattr(self, which)

    def threshold(self, criterion: str = "paper", which: str = "weighted") -> float:
        """Default acceptance threshold for a criterion and keypoint set. A descriptor built
        without one (or with one outside (0, 1]) raises :class:`SettingsError`."""
        key = f"{criterion}-{which}"
        value = self.thresholds.get(key) if isinstance(self.thresholds, dict) else None
        if not _in_range(value, 0.0, 1.0, low_open=True):
            have = f"no {key} threshold" if value is None else \
                f"{_short(value)} as its {key} threshold, not a number in (0, 1]"
            raise SettingsError(f"descriptor {self.affordance!r} has {have}; give one "
                                "(threshold=, --threshold) or set one with set_acceptance()")
        return float(value)

    def set_acceptance(self, threshold: float, clearance_limit: float | None = None,
                       interior_limit: float | None = None, contact: tuple | None = None,
                       collision: tuple | list | str | None = None,
                       through: bool | None = None,
                       hangs: bool | None = None,
                       fills: bool | None = None,
                       below_ground: float | str | None = None,
                       feet_reach: float | str | None = None,
                       straddle: dict | str | None = None,
                       mount_height: float | str | None = None,
                       normal_tolerance: float | str | None = None,
                       gaussian_threshold: float | None = None) -> None:
        """Accept placements scoring at least ``threshold`` (both keypoint sets, paper
        criterion), violating at most ``clearance_limit`` of the clearance points and
        ``interior_limit`` of the interior points, and keeping their contact (``contact`` =
        (mode, distance, fraction[, angle]), see clearance.py), e.g. an affordance's
        acceptance tuned
        on validation scenes (:func:`interaction_tensor.examples.affordances.acceptance`).
        ``collision`` = (depth, above), or a list of them, sets the collision tests of ranked
        placements (:attr:`collision_tests`; above None: the whole query), ``"off"`` removes
        them; ``through`` turns the through-the-hook test on or off (:attr:`through`), and
        ``hangs`` the hanging tests (:attr:`hangs`) and ``fills`` the filling tests
        (:attr:`fills`);
        ``below_ground`` (m) sets the ground test (:attr:`below_ground`) and ``feet_reach``
        (m) the feet test (:attr:`feet_reach`), ``straddle`` (a dict of boxes) the straddle
        test (:attr:`straddle`) and ``mount_height`` (m) the mount test
        (:attr:`mount_height`), ``"off"`` removes any of them. ``normal_tolerance`` (degrees)
        sets the normal filter's tolerance detection uses unless its settings give one
        (:attr:`normal_tolerance`; ``"off"``: the settings' default). ``gaussian_threshold`` sets the
        threshold of the gaussian criterion (both keypoint sets; the default of captured
        scenes; derived from the example until set). Arguments left None keep their
        value."""
        if not 0 < threshold <= 1:
            raise ValueError("threshold must be in (0, 1]")
        if gaussian_threshold is not None and not 0 < gaussian_threshold <= 1:
            raise ValueError("gaussian_threshold must be in (0, 1]")
        for name, value in (("clearance_limit", clearance_limit),
                            ("interior_limit", interior_limit)):
            if value is not None and not 0 <= value <= 1:
                raise ValueError(f"{name} must be in [0, 1]")
        if contact is not None:
            mode, distance, fraction, angle = (tuple(contact) + (90.0,))[:4]
            if mode not in ("off", "main", "all", "seat") or not distance > 0 or \
                    not 0 <= fraction <= 1 or not 0 < angle <= 90:
                raise ValueError("contact must be (off|main|all|seat, distance > 0, fraction "
                                 "in [0, 1][, angle in (0, 90]])")
        for name, value, top in (("below_ground", below_ground, 1.0),
                                 ("feet_reach", feet_reach, 1.0),
                                 ("mount_height", mount_height, 10.0)):
            if value is not None and not (isinstance(value, str) and value == "off"):
                if isinstance(value, (str, bool)) or not 0 <= float(value) <= top:
                    raise ValueError(f"{name} must be a height in [0, {top:g}] m or 'off'")
        if normal_tolerance is not None and not (isinstance(normal_tolerance, str)
                                                 and normal_tolerance == "off"):
            if isinstance(normal_tolerance, (str, bool)) or not 0 <= float(normal_tolerance) <= 90:
                raise ValueError("normal_tolerance must be an angle in [0, 90] degrees or 'off'")
        boxes = None
        if straddle is not None and not (isinstance(straddle, str) and straddle == "off"):
            boxes = straddle_boxes(straddle)
        tests = None
        if collision is not None:
            tests = () if isinstance(collision, str) and collision == "off" else \
                collision_tests(collision)
        for which in ("weighted", "uniform"):
            self.thresholds[f"paper-{which}"] = float(threshold)
            if gaussian_threshold is not None:
                self.thresholds[f"gaussian-{which}"] = float(gaussian_threshold)
        if clearance_limit is not None:
            self.clearance_limit = float(clearance_limit)
        if interior_limit is not None:
            self.interior_limit = float(interior_limit)
        if contact is not None:
            self.contact_groups = str(mode)
            self.contact_distance, self.contact_fraction = float(distance), float(fraction)
            self.contact_angle = float(angle)
        if tests is not None:
            self.collision_tests = tests
        if through is not None:
            self.through = bool(through)
        if hangs is not None:
            self.hangs = bool(hangs)
        if fills is not None:
            self.fills = bool(fills)
        if below_ground is not None:
            self.below_ground = None if isinstance(below_ground, str) else float(below_ground)
        if feet_reach is not None:
            self.feet_reach = None if isinstance(feet_reach, str) else float(feet_reach)
        if straddle is not None:
            self.straddle = boxes
        if mount_height is not None:
            self.mount_height = (None if isinstance(mount_height, str)
                                 else float(mount_height))
        if normal_tolerance is not None:
            self.normal_tolerance = (None if isinstance(normal_tolerance, str)
                                     else float(normal_tolerance))
        for cache in self._FCL_CACHES:
            self.__dict__.pop(cache, None)

    #: Caches of python-fcl objects, which cannot be pickled or copied: rebuilt on first use.
    _FCL_CACHES = ("_collision_bodies", "_through_body")

    def __getstate__(self) -> dict:
        """The descriptor without its collision caches, so that it pickles (a Dask worker, a
        process pool) and copies after a detection has built them."""
        return {k: v for k, v in self.__dict__.items() if k not in self._FCL_CACHES}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)

    def collision_bodies(self) -> list:
        """Detection's collision tests as (:class:`~.collision.Body` of the tested query
        triangles in the training frame, depth m), built once; empty when the descriptor has
        no collision test or no triangles to test (a point-cloud query). A test with a height
        tests the query's triangles cut to 2 cm edges above it (:func:`.collision.part_above`);
        one whose height leaves no triangle is dropped. A ``"limbs"`` test tests a person's
        body and each of its limbs on its own (:func:`.collision.person_parts`, about the
        reference point; a rider's thighs with its legs when the descriptor has a straddle
        test), each to be freed by a move of the test's depth: the judge's rule."""
        if "_collision_bodies" not in self.__dict__:
            bodies = []
            if len(self.query_faces):

                for depth, above in self.collision_tests:
                    if above == LIMBS:
                        v, parts = person_parts(self.query_vertices, self.query_faces,
                                                self.reference_point, self.straddle is not None)
                        bodies += [(Body(v, part), depth) for _, part in parts if len(part)]
                        continue
                    v, faces = part_above(self.query_vertices, self.query_faces,
                                          None if above is None
                                          else self.reference_point[2] + above)
                    if len(faces):
                        bodies.append((Body(v, faces), depth))
            self.__dict__["_collision_bodies"] = bodies
        return self.__dict__["_collision_bodies"]

    def through_body(self):
        """The :attr:`through_section` as a closed flat :class:`~.collision.Body` (training
        frame, built once), or None when the test is off or the example had no section."""
        if not self.through or len(self.through_section) < 3:
            return None
        if "_through_body" not in self.__dict__:

            self.__dict__["_through_body"] = Body(*polygon(self.through_section))
        return self.__dict__["_through_body"]

    def hook_opening(self):
        """The query's opening round its :attr:`through_section` (training frame, built
        once: :func:`~interaction_tensor.placement.hooks.opening_of`), or None when the test
        is off or the example had no section."""
        if not self.hangs or len(self.through_section) < 3:
            return None
        if "_hook_opening" not in self.__dict__:
            self.__dict__["_hook_opening"] = hooks.opening_of(self._hook_samples(),
                                                              self.through_section)
        return self.__dict__["_hook_opening"]

    def hook_bottom(self) -> np.ndarray:
        """The query's bottom (:func:`~interaction_tensor.placement.hooks.bottom`, training
        frame, built once): what must hang free."""
        if "_hook_bottom" not in self.__dict__:
            self.__dict__["_hook_bottom"] = hooks.bottom(self._hook_samples())
        return self.__dict__["_hook_bottom"]

    def vessel(self):
        """The query as a container standing upright (training frame, built once:
        :class:`~interaction_tensor.placement.taps.Vessel`), or None when the filling
        tests are off."""
        if not self.fills:
            return None
        if "_vessel" not in self.__dict__:
            self.__dict__["_vessel"] = taps.Vessel.of(self._hook_samples())
        return self.__dict__["_vessel"]

    def _hook_samples(self) -> np.ndarray:
        """Dense samples of the query's surface (its points for a cloud; built once): a
        hook's wire is a few millimetres thick."""
        if not self.query_is_mesh:
            return self.query_vertices
        if "_surface_samples" not in self.__dict__:
            self.__dict__["_surface_samples"] = sample_mesh(
                Geometry(self.query_vertices, self.query_faces), HOOK_SAMPLES, 0)[0]
        return self.__dict__["_surface_samples"]

    def acceptance(self) -> dict:
        """What a placement must pass (the paper criterion's threshold and the placement
        tests), as stored in the descriptor."""
        return {"threshold": self.thresholds.get("paper-weighted"),
                "gaussian_threshold": self.thresholds.get("gaussian-weighted"),
                "clearance_limit": self.clearance_limit, "interior_limit": self.interior_limit,
                "contact_groups": self.contact_groups,
                "contact_distance": self.contact_distance,
                "contact_fraction": self.contact_fraction, "contact_angle": self.contact_angle,
                "collision_tests": [list(t) for t in self.collision_tests],
                "through": self.through, "hangs": self.hangs, "fills": self.fills,
                "below_ground": self.below_ground,
                "feet_reach": self.feet_reach, "straddle": _boxes_json(self.straddle),
                "mount_height": self.mount_height, "normal_tolerance": self.normal_tolerance}

    def pose(self, position, angle: float) -> np.ndarray:
        """4x4 pose taking the training-frame query object to ``position`` at ``angle``."""
        c, s = np.cos(angle), np.sin(angle)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        m = np.eye(4)
        m[:3, :3] = rot
        m[:3, 3] = np.asarray(position, float) - rot @ self.reference_point
        return m

    @property
    def query_is_mesh(self) -> bool:
        return len(self.query_faces) > 0

    # ------------------------------------------------------------------ training
    @classmethod
    def fit(cls, query: Geometry, scene_object: Geometry, affordance: str = "interaction",
            settings: TrainSettings | None = None, reference_point=None,
            progress=None, ground: float | None = None) -> "InteractionTensor":
        """Fit the Interaction Tensor of one example.

        Parameters
        ----------
        query : the query object, posed in the interaction (mesh or point cloud)
        scene_object : the scene-object in the same frame (mesh or point cloud)
        affordance : a name for the interaction
        settings : :class:`TrainSettings` (defaults if None)
        reference_point : (3,) override of p_scene; default: centre of the contact region
        progress : optional callable(str) told the name of each step
        ground : height (m) of the floor the example stands on, or None. It is not part of
            the tensor (the bisector is the two objects'), but it bounds the free space of
            the clearance points and counts as touched by the contact groups (a seated
            person's feet on the floor).
        """
        settings = settings or TrainSettings()
        say = progress or (lambda _msg: None)
        validate_geometry(query, min_points=4)
        validate_geometry(scene_object, min_points=4)
        if query.vertices.shape == scene_object.vertices.shape and \
                np.allclose(query.vertices, scene_object.vertices, atol=1e-9):
            raise InputError(query.source, "the query and the scene-object are the same "
                                           "geometry; give the two objects of the interaction")
        if ground is not None:
            ground = float(ground)
            low = float(query.vertices[:, 2].min())
            if not np.isfinite(ground) or ground > low + settings.contact_tolerance:
                raise InputError(None, f"ground {ground!r} must be a height (m) at or below "
                                       f"the query object's lowest point ({low:.3f} m)")
        timings = {}
        t0 = time.perf_counter()
        normal = np.asarray(settings.affordance_normal, float)
        normal /= np.linalg.norm(normal)

        # 1. samples --------------------------------------------------------------
        say("sampling")
        if query.is_mesh:
            q_pts, q_nrm = sample_mesh(query, settings.query_points, settings.seed)
        else:
            q_pts, q_nrm = query.vertices, None
        radius = float(np.linalg.norm(np.ptp(query.vertices, axis=0)))
        centre = q_pts.mean(axis=0)
        crop = settings.crop_factor * radius
        s_pts, s_nrm = _scene_object_samples(scene_object, centre, crop,
                                             settings.scene_spacing, settings.seed + 1)
        if len(s_pts) < 4:
            raise InputError(scene_object.source,
                             f"no scene-object surface within {crop:.3f} m of the query object: "
                             "the objects do not touch or interact")
        gap_tree = cKDTree(s_pts)
        gaps, _ = gap_tree.query(q_pts, workers=-1)
        if gaps.min() > radius:
            raise InputError(scene_object.source,
                             f"the objects do not touch: the scene-object is {gaps.min():.3f} m "
                             f"from the query object, more than its size {radius:.3f} m")
        _check_not_overlapping(query, scene_object, q_pts, q_nrm, gaps,
                               settings.scene_spacing, settings.seed)
        timings["sampling"] = time.perf_counter() - t0

        # 2. bisector surface and 3. provenance vectors, weights -----------------------
        say("bisector")
        t1 = time.perf_counter()
        bis = bisector_points(q_pts, s_pts, seed=settings.seed)
        bis = bis[trim_to_sphere(bis, centre, radius)]
        dist, nn = gap_tree.query(bis, workers=-1)
        # keep points whose empty sphere lies inside the crop ball: exact, see settings
        exact = np.linalg.norm(bis - centre, axis=1) + dist <= crop
        bis, nn = bis[exact], nn[exact]
        prov = surface_vectors(bis, s_pts, s_nrm, nn, settings.scene_spacing, settings.vectors)
        if len(bis) < 8:
            raise InputError(scene_object.source,
                             f"only {len(bis)} bisector points near the query object: the "
                             "objects do not interact (too far apart or too coarse sampling)")
        mag = np.linalg.norm(prov, axis=1)
        span = mag.max() - mag.min()
        weights = 1.0 - (mag - mag.min()) / span if span > 0 else np.ones_like(mag)
        timings["bisector"] = time.perf_counter() - t1

        # 4. keypoints --------------------------------------------------------------
        say("keypoints")
        t2 = time.perf_counter()
        n = settings.n_keypoints
        sets = {}
        for name, idx in (
                ("weighted", weighted_keypoints(weights, n, settings.seed + 2)),
                ("uniform", uniform_keypoints(len(bis), n, settings.seed + 3))):
            idx = idx[np.lexsort((idx, mag[idx]))]   # |v| ascending
            sets[name] = Keypoints(bis[idx], prov[idx], weights[idx])
        timings["keypoints"] = time.perf_counter() - t2

        # 5. clearance: free space around the query (iTClearance); interior points ----------
        t_c = time.perf_counter()
        k = min(settings.clearance_points, len(q_pts))
        c_idx = np.sort(np.random.default_rng(settings.seed + 4).choice(len(q_pts), k,
                                                                         replace=False))
        c_pts = q_pts[c_idx]
        _, c_nn = gap_tree.query(c_pts, workers=-1)
        c_free = np.linalg.norm(surface_vectors(c_pts, s_pts, s_nrm, c_nn,
                                                settings.scene_spacing, "surface"), axis=1)
        if ground is not None:
            c_free = np.minimum(c_free, np.maximum(c_pts[:, 2] - ground, 0.0))
        c_rad = np.minimum(c_free, settings.clearance_max)
        i_pts, i_rad = _interior_samples(query, settings)
        through = through_section_of(query, scene_object, settings)
        timings["clearance"] = time.perf_counter() - t_c

        # 6. reference point, contact ---------------------------------------------------
        ref, contact = _reference_point(q_pts, gaps, s_pts, s_nrm, normal,
                                        settings.contact_tolerance, settings.scene_spacing)
        if reference_point is not None:
            ref = np.asarray(reference_point, dtype=float).reshape(3)
            if not np.isfinite(ref).all():
                raise InputError(None, f"reference_point {ref.tolist()} is not finite")
            far = float(np.linalg.norm(s_pts - ref, axis=1).min())
            if far > radius:
                raise InputError(None, f"reference_point {np.round(ref, 3).tolist()} lies "
                                       f"{far:.2f} m from the scene-object, beyond the "
                                       f"interaction's radius ({radius:.2f} m)")
        _, q_nn = gap_tree.query(q_pts, workers=-1)
        q_surface_gap = np.linalg.norm(surface_vectors(q_pts, s_pts, s_nrm, q_nn,
                                                       settings.scene_spacing, "surface"),
                                       axis=1)
        g_pts, g_ids, g_nrm = _contact_groups(q_pts, q_surface_gap, s_nrm[q_nn], ground, ref,
                                              settings)

        # keep the query object itself for posing (clouds subsampled to 30k points)
        qv, qf = query.vertices, (query.faces if query.is_mesh else np.zeros((0, 3), np.int64))
        if not query.is_mesh and len(qv) > 30000:
            qv = qv[np.random.default_rng(settings.seed).choice(len(qv), 30000, replace=False)]
        keep_scene = s_pts
        if len(keep_scene) > 30000:
            keep_scene = s_pts[np.random.default_rng(settings.seed).choice(len(s_pts), 30000,
                                                                            replace=False)]
        tensor = cls(
            affordance=str(affordance), reference_point=ref, affordance_normal=normal,
            radius=radius, query_centroid=centre, bisector_points=bis,
            provenance_vectors=prov, weights=weights, weighted=sets["weighted"],
            uniform=sets["uniform"], query_vertices=np.asarray(qv, float),
            query_faces=np.asarray(qf, np.int64), contact_points=contact,
            scene_points=keep_scene, scene_spacing=float(settings.scene_spacing),
            vectors=settings.vectors, clearance_points=c_pts, clearance_radius=c_rad,
            clearance_limit=float(settings.clearance_limit), interior_points=i_pts,
            interior_radius=i_rad, interior_limit=float(settings.interior_limit),
            contact_group_points=g_pts, contact_group_ids=g_ids, contact_group_normals=g_nrm,
            contact_groups=_contact_mode(settings.contact_groups, g_ids),
            contact_distance=float(settings.contact_distance),
            contact_fraction=float(settings.contact_fraction),
            contact_angle=float(settings.contact_angle), through_section=through,
            ground=ground, collision_tests=_own_collision_tests(query, scene_object, settings))

        # an example hanging from its scene-object asks a new scene to hold it the same way
        if hangs_from(q_pts, ref, normal, through):
            tensor.through, tensor.hangs = True, True
            tensor.below_ground = HANGING_BELOW_GROUND

        # 7. calibration: the example scored on perturbed copies of its scene-object ------
        say("calibration")
        t3 = time.perf_counter()
        copies = tensor._calibrate(query, scene_object, settings)
        timings["calibration"] = time.perf_counter() - t3
        timings["total"] = time.perf_counter() - t0
        tensor.meta = {
            "settings": settings.to_dict(),
            "query_source": query.source, "scene_object_source": scene_object.source,
            "query_samples": int(len(q_pts)), "scene_object_samples": int(len(s_pts)),
            "bisector_points": int(len(bis)), "min_gap": float(gaps.min()),
            "interior_points": int(len(i_pts)),
            "contact_groups": [int(c) for c in np.bincount(g_ids)] if len(g_ids) else [],
            "calibration": copies,
            "timings_s": {k: round(v, 4) for k, v in timings.items()},
            "created_with": f"interaction-tensor {__version__}",
        }
        return tensor

    def _calibrate(self, query: Geometry, scene_object: Geometry,
                   settings: TrainSettings) -> list[dict]:
        """Set :attr:`self_scores` (the example on a re-sampled copy of its scene-object)
        and :attr:`thresholds`: ``calibration_ratio`` x the lowest score its interaction gets
        on :data:`~.calibration.PERTURBATIONS` of the scene-object, the changes a new scene
        brings (:mod:`.calibration`), of those on which the example's pose still holds
        (:func:`~.calibration.still_holds`). Returns each copy's best scores (None where
        it had no test point or does not hold: ``holds`` says which)."""
        crop = settings.crop_factor * self.radius
        pts, nrm = _scene_object_samples(scene_object, self.query_centroid, crop,
                                         self.scene_spacing, settings.seed + 101)
        scene = Scene(pts, nrm, self.scene_spacing, "calibration", True)
        # test points: the re-sampled points nearest the reference point
        k = min(9, len(pts))
        _, near = scene.tree.query(self.reference_point, k=k)
        positions = pts[np.atleast_1d(near)]
        tables = {f"{c}-{w}": self.keypoint_table(DetectSettings(criterion=c, keypoints=w))
                  for c in CRITERIA for w in KEYPOINT_SETS}
        for key, table in tables.items():
            s = score_pairs(positions, np.zeros(len(positions), int), table, scene,
                            threshold=1.0, vectors=self.vectors, early_exit=False).score
            self.self_scores[key] = float(np.median(s))
        # a copy without a test point near the reference point (a peg's top at a coarser
        # spacing: no sample faces N_aff there) says nothing of the score; the re-sampled
        # copy of itself always counts
        lowest = dict(self.self_scores)
        copies = []
        for i, perturbation in enumerate(PERTURBATIONS
                                         + (HANGING_PERTURBATIONS if self.hangs else ())):
            copy = perturbation.apply(scene_object, self.reference_point,
                                      self.affordance_normal)
            holds = still_holds(query, scene_object, copy, settings.collision_depth or 0.0)
            best = (self._perturbed_best(copy, perturbation, tables, crop,
                                         settings.seed + 102 + i) if holds
                    else {key: None for key in tables})
            copies.append({"perturbation": perturbation.name, "holds": bool(holds),
                           **{k: (None if v is None else round(v, 4))
                              for k, v in best.items()}})
            for key, v in best.items():
                if v is not None and key.split("-")[0] in perturbation.criteria:
                    lowest[key] = min(lowest[key], v)
        for key, low in lowest.items():
            self.thresholds[key] = float(np.clip(settings.calibration_ratio * low,
                                                 MIN_THRESHOLD, 1.0))
        return copies

    def _perturbed_best(self, g: Geometry, perturbation: Perturbation,
                        tables: dict, crop: float, seed: int) -> dict:
        """The best score of the example's pose at the test points a detection would have
        near the reference point (within 3 spacings, a spacing along N_aff, the normal line
        within 15 degrees of N_aff) on ``g``, the scene-object scaled and turned by
        ``perturbation`` (its sampling and noise applied here), per table; None where there
        is none."""
        ref = self.reference_point
        n = self.affordance_normal / np.linalg.norm(self.affordance_normal)
        spacing = self.scene_spacing * perturbation.spacing
        pts, nrm = _scene_object_samples(g, self.query_centroid, crop, spacing, seed)
        if len(pts) == 0:
            return {key: None for key in tables}
        if perturbation.noise:
            pts = pts + np.random.default_rng(seed).normal(0.0, perturbation.noise
                                                           * self.scene_spacing, pts.shape)
        scene = Scene(pts, nrm, spacing, "calibration", True)
        d = np.linalg.norm(pts - ref, axis=1)
        # on the surface through the reference point (not the board's other side)
        near = np.flatnonzero((d <= 3 * spacing) & (np.abs((pts - ref) @ n) <= spacing)
                              & (np.abs(nrm @ n) >= np.cos(np.radians(NORMAL_TOLERANCE_DEG))))
        if len(near) == 0:
            return {key: None for key in tables}
        near = near[np.argsort(d[near])[:CALIBRATION_POINTS]]
        orient = np.zeros(len(near), int)
        out, seen = {}, {}
        for key, table in tables.items():
            # the criteria of one keypoint set ask the same queries: answered once
            which = key.split("-", 1)[1]
            if which not in seen:
                seen[which] = pair_test_vectors(pts[near], orient, table, scene, self.vectors,
                                                lambda q: scene.tree.query(q, workers=-1)[1])
            terms = keypoint_terms(table, slice(0, table.n), orient, seen[which])
            out[key] = float(terms.sum(axis=1).max())
        return out

    def keypoint_table(self, settings: DetectSettings) -> KeypointTable:
        """The keypoint set that ``settings`` compares (``keypoints``), relative to the
        reference point, rotated for its ``n_orientations``, with what its ``criterion``
        needs (:func:`~interaction_tensor.engine.scoring.make_table`)."""
        kp = self.keypoints(settings.keypoints)
        return make_table(kp.points - self.reference_point, kp.provenance, kp.weights,
                          settings.n_orientations, settings.criterion, settings.theta_max,
                          settings.c, settings.gaussian_a)

    # ------------------------------------------------------------------ files
    def save(self, path) -> Path:
        """Write the descriptor as one ``.npz`` (no pickle) with JSON metadata, atomically."""
        path = output_path(path, "descriptor file")
        header = {
            "format": FORMAT, "format_version": FORMAT_VERSION, "affordance": self.affordance,
            "radius": self.radius, "scene_spacing": self.scene_spacing, "vectors": self.vectors,
            "clearance_limit": self.clearance_limit, "interior_limit": self.interior_limit,
            "contact_groups": self.contact_groups, "contact_distance": self.contact_distance,
            "contact_fraction": self.contact_fraction, "contact_angle": self.contact_angle,
            "collision_tests": [list(t) for t in self.collision_tests], "through": self.through,
            "hangs": self.hangs, "fills": self.fills,
            "ground": self.ground, "below_ground": self.below_ground,
            "feet_reach": self.feet_reach, "straddle": _boxes_json(self.straddle),
            "mount_height": self.mount_height, "normal_tolerance": self.normal_tolerance,
            "thresholds": self.thresholds, "self_scores": self.self_scores, "meta": self.meta,
        }
        arrays = {
            "header": np.frombuffer(json.dumps(header).encode("utf-8"), dtype=np.uint8),
            "reference_point": self.reference_point, "affordance_normal": self.affordance_normal,
            "query_centroid": self.query_centroid, "bisector_points": self.bisector_points,
            "provenance_vectors": self.provenance_vectors, "weights": self.weights,
            "query_vertices": self.query_vertices, "query_faces": self.query_faces,
            "contact_points": self.contact_points, "scene_points": self.scene_points,
            "clearance_points": self.clearance_points, "clearance_radius": self.clearance_radius,
            "interior_points": self.interior_points, "interior_radius": self.interior_radius,
            "contact_group_points": self.contact_group_points,
            "contact_group_ids": np.asarray(self.contact_group_ids, np.int64),
            "contact_group_normals": self.contact_group_normals,
            "through_section": self.through_section,
        }
        for name in ("weighted", "uniform"):
            kp = self.keypoints(name)
            arrays[f"{name}_points"] = kp.points
            arrays[f"{name}_provenance"] = kp.provenance
            arrays[f"{name}_weights"] = kp.weights
        buf = _io.BytesIO()
        np.savez_compressed(buf, **arrays)
        with atomic_path(path) as tmp:
            tmp.write_bytes(buf.getvalue())
        return path

    @classmethod
    def load(cls, path) -> "InteractionTensor":
        """Read a descriptor written by :meth:`save`; never executes code (no pickle)."""
        path = Path(path)
        if not path.exists():
            raise InputError(path, "no such descriptor file")
        if path.is_dir():
            raise InputError(path, "is a directory, expected a descriptor (.npz) file")
        try:
            with open(path, "rb") as fh:
                magic = fh.read(4)
        except OSError as exc:
            raise InputError(path, f"cannot read it ({exc.strerror or exc})") from None
        if magic != b"PK\x03\x04":           # every .npz is a zip archive
            reason = ("a pickle: it holds Python objects, which are never loaded"
                      if magic[:1] == b"\x80" else
                      "a single .npy array, not a .npz archive" if magic == b"\x93NUM"
                      else "not a .npz archive" if magic else "an empty file")
            raise InputError(path, f"not a descriptor file ({reason})")
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {k: data[k] for k in data.files}
        except Exception as exc:  # zip, npy and pickle refusals alike: one line, no advice
            reason = "holds Python objects, which are never loaded" \
                if "pickle" in str(exc).lower() else type(exc).__name__
            raise InputError(path, f"not a descriptor file ({reason})") from None
        try:
            header = json.loads(arrays.pop("header").tobytes().decode("utf-8"))
        except Exception:
            raise InputError(path, "not a descriptor file (no readable header)") from None
        if not isinstance(header, dict) or header.get("format") != FORMAT:
            raise InputError(path, "not an interaction-tensor descriptor")
        version = header.get("format_version")
        if isinstance(version, bool) or version not in READABLE_VERSIONS:
            raise InputError(path, f"descriptor format version {version!r} "
                                   "is not supported (this version reads "
                                   f"{', '.join(map(str, READABLE_VERSIONS))})")
        header, arrays = validate_descriptor(path, header, arrays)
        sets = {name: Keypoints(arrays[f"{name}_points"], arrays[f"{name}_provenance"],
                                arrays[f"{name}_weights"]) for name in ("weighted", "uniform")}
        tensor = cls(
            affordance=header["affordance"], reference_point=arrays["reference_point"],
            affordance_normal=arrays["affordance_normal"], radius=float(header["radius"]),
            query_centroid=arrays["query_centroid"], bisector_points=arrays["bisector_points"],
            provenance_vectors=arrays["provenance_vectors"], weights=arrays["weights"],
            weighted=sets["weighted"], uniform=sets["uniform"],
            query_vertices=arrays["query_vertices"], query_faces=arrays["query_faces"],
            contact_points=arrays["contact_points"], scene_points=arrays["scene_points"],
            scene_spacing=float(header["scene_spacing"]), vectors=header["vectors"],
            clearance_points=arrays["clearance_points"],
            clearance_radius=arrays["clearance_radius"],
            clearance_limit=float(header["clearance_limit"]),
            interior_points=arrays["interior_points"], interior_radius=arrays["interior_radius"],
            interior_limit=float(header["interior_limit"]),
            contact_group_points=arrays["contact_group_points"],
            contact_group_ids=arrays["contact_group_ids"],
            contact_group_normals=arrays["contact_group_normals"],
            contact_groups=header["contact_groups"],
            contact_angle=float(header["contact_angle"]),
            contact_distance=float(header["contact_distance"]),
            contact_fraction=float(header["contact_fraction"]),
            collision_tests=header["collision_tests"], through=header["through"],
            hangs=header["hangs"], fills=header["fills"],
            through_section=arrays["through_section"],
            ground=header["ground"], below_ground=header["below_ground"],
            feet_reach=header["feet_reach"], straddle=header["straddle"],
            mount_height=header["mount_height"],
            normal_tolerance=header["normal_tolerance"],
            thresholds=header["thresholds"],
            self_scores=header["self_scores"], meta=header["meta"])
        return tensor

    def __repr__(self) -> str:
        """One line: what it is for and what it holds (``summary()`` and ``itensor info``
        say the rest)."""
        n = np.round(np.asarray(self.affordance_normal, float), 3).tolist()
        return (f"<InteractionTensor {self.affordance!r}: {len(self.weighted.points)} weighted "
                f"+ {len(self.uniform.points)} uniform keypoints, "
                f"{len(self.bisector_points)} bisector points, radius {self.radius:.3f} m, "
                f"normal {n}, threshold {self.threshold():.3f}>")

    def summary(self) -> dict:
        """A JSON-able summary of what the descriptor holds (for ``itensor info``)."""
        def stats(kp: Keypoints):
            m = np.linalg.norm(kp.provenance, axis=1)
            return {"count": int(len(kp.points)), "min_|v|": float(m.min()),
                    "max_|v|": float(m.max()), "mean_weight": float(kp.weights.mean())}
        return {
            "affordance": self.affordance,
            "format": f"{FORMAT} v{FORMAT_VERSION}",
            "reference_point": [round(float(v), 5) for v in self.reference_point],
            "affordance_normal": [round(float(v), 4) for v in self.affordance_normal],
            "radius_d_o": round(self.radius, 5),
            "scene_spacing": self.scene_spacing, "vectors": self.vectors,
            "bisector_points": int(len(self.bisector_points)),
            "keypoints": {"weighted": stats(self.weighted), "uniform": stats(self.uniform)},
            "query_object": {"vertices": int(len(self.query_vertices)),
                             "faces": int(len(self.query_faces))},
            "contact_points": int(len(self.contact_points)),
            "clearance_points": int(len(self.clearance_points)),
            "clearance_limit": self.clearance_limit,
            "interior_points": int(len(self.interior_points)),
            "interior_limit": self.interior_limit,
            "contact_groups": {"mode": self.contact_groups,
                               "points_per_group": [int(c) for c in
                                                    np.bincount(self.contact_group_ids)]
                               if len(self.contact_group_ids) else [],
                               "distance": self.contact_distance,
                               "fraction": self.contact_fraction,
                               "angle_deg": self.contact_angle},
            "collision": ([{"depth": d, "above": a} for d, a in self.collision_tests]
                          or "off"),
            "through": ({"on": self.through, "section_vertices": int(len(self.through_section))}),
            "hangs": self.hangs, "fills": self.fills,
            "ground": self.ground, "below_ground": self.below_ground,
            "feet_reach": self.feet_reach, "straddle": _boxes_json(self.straddle),
            "mount_height": self.mount_height, "normal_tolerance_deg": self.normal_tolerance,
            "thresholds": self.thresholds, "self_scores": self.self_scores,
            "meta": self.meta,
        }


#: descriptor arrays: name -> (shape with None for any length, kind: "f" float or "i" int)
_ARRAYS = {
    "reference_point": ((3,), "f"), "affordance_normal": ((3,), "f"),
    "query_centroid": ((3,), "f"), "bisector_points": ((None, 3), "f"),
    "provenance_vectors": ((None, 3), "f"), "weights": ((None,), "f"),
    "query_vertices": ((None, 3), "f"), "query_faces": ((None, 3), "i"),
    "contact_points": ((None, 3), "f"), "scene_points": ((None, 3), "f"),
    "clearance_points": ((None, 3), "f"), "clearance_radius": ((None,), "f"),
    "interior_points": ((None, 3), "f"), "interior_radius": ((None,), "f"),
    "contact_group_points": ((None, 3), "f"), "contact_group_ids": ((None,), "i"),
    "contact_group_normals": ((None, 3), "f"), "through_section": ((None, 3), "f"),
    **{f"{k}_{part}": (shape, "f") for k in ("weighted", "uniform")
       for part, shape in (("points", (None, 3)), ("provenance", (None, 3)),
                           ("weights", (None,)))},
}


#: arrays that older format versions lack, and what stands in for them (no such test)
_OPTIONAL = {
    "clearance_points": lambda: np.zeros((0, 3)), "clearance_radius": lambda: np.zeros(0),
    "interior_points": lambda: np.zeros((0, 3)), "interior_radius": lambda: np.zeros(0),
    "contact_group_points": lambda: np.zeros((0, 3)),
    "contact_group_ids": lambda: np.zeros(0, np.int64),
    "contact_group_normals": lambda: np.zeros((0, 3)),
    "through_section": lambda: np.zeros((0, 3)),
}


def validate_descriptor(path, header: dict, arrays: dict):
    """Check a descriptor's header and arrays against the format before any use.

    Shapes, dtypes, finiteness, ranges, known names and index bounds; the first problem is
    raised as an :class:`InputError` naming the field. Returns (header, arrays) with arrays
    as float64 / int64 and the optional fields of older versions filled in.
    """
    def bad(field, problem):
        raise InputError(path, f"descriptor field {field!r} {problem}")

    out = {}
    for name, (shape, kind) in _ARRAYS.items():
        if name not in arrays:
            if name in _OPTIONAL:                   # absent from older format versions
                out[name] = _OPTIONAL[name]()
                continue
            bad(name, "is missing")
        a = arrays[name]
        if a.dtype.kind not in ("fiu" if kind == "f" else "iu") or a.dtype.kind == "b":
            bad(name, f"has type {a.dtype}, expected {'numbers' if kind == 'f' else 'integers'}")
        if a.ndim != len(shape) or any(want is not None and got != want
                                       for got, want in zip(a.shape, shape)):
            want = "(" + ", ".join("N" if w is None else str(w) for w in shape) + ")"
            bad(name, f"has shape {a.shape}, expected {want}")
        a = a.astype(np.float64 if kind == "f" else np.int64)
        if kind == "f" and not np.isfinite(a).all():
            bad(name, "holds NaN or infinite values")
        out[name] = a
    for name in ("bisector_points", "weighted_points", "uniform_points", "query_vertices"):
        if len(out[name]) == 0:
            bad(name, "is empty")
    for prefix in ("weighted", "uniform"):
        n = len(out[f"{prefix}_points"])
        for part in ("provenance", "weights"):
            if len(out[f"{prefix}_{part}"]) != n:
                bad(f"{prefix}_{part}", f"has {len(out[f'{prefix}_{part}'])} rows for {n} points")
    if len(out["provenance_vectors"]) != len(out["bisector_points"]) or \
            len(out["weights"]) != len(out["bisector_points"]):
        bad("provenance_vectors", "and weights must have one row per bisector point")
    if len(out["clearance_radius"]) != len(out["clearance_points"]):
        bad("clearance_radius", "must have one value per clearance point")
    for name in ("weights", "weighted_weights", "uniform_weights"):
        w = out[name]
        if w.min() < 0 or w.max() > 1:
            bad(name, f"must lie in [0, 1], found {w.min():.3g}..{w.max():.3g}")
    for name in ("weighted_weights", "uniform_weights"):
        if not out[name].sum() > 0:
            bad(name, "are all zero")
    for name in ("clearance_radius", "interior_radius"):
        if out[name].size and out[name].min() < 0:
            bad(name, "holds negative values")
    if len(out["interior_radius"]) != len(out["interior_points"]):
        bad("interior_radius", "must have one value per interior point")
    ids = out["contact_group_ids"]
    if len(ids) != len(out["contact_group_points"]):
        bad("contact_group_ids", "must have one value per contact group point")
    if len(out["contact_group_normals"]) != len(ids):
        bad("contact_group_normals", "must have one row per contact group point")
    if len(ids) and not (np.abs(np.linalg.norm(out["contact_group_normals"], axis=1) - 1)
                         < 1e-6).all():
        bad("contact_group_normals", "must be unit vectors")
    if len(ids) and (ids.min() < 0 or np.setdiff1d(np.arange(ids.max() + 1), ids).size):
        bad("contact_group_ids", "must number the groups 0, 1, ... with none empty")
    if not np.linalg.norm(out["affordance_normal"]) > 1e-9:
        bad("affordance_normal", "is zero")
    faces = out["query_faces"]
    if faces.size and (faces.min() < 0 or faces.max() >= len(out["query_vertices"])):
        bad("query_faces", f"index vertices that do not exist (0..{faces.max()} for "
                           f"{len(out['query_vertices'])} vertices)")

    def number(field, low, high, default=None, low_open=False):
        value = header.get(field, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            bad(field, f"must be a number, got {_short(value)}")
        if not _in_range(value, low, high, low_open):
            bad(field, f"must be in {'(' if low_open else '['}{low:g}, {high:g}], got "
                       f"{_short(value)}")
        return float(value)

    affordance = header.get("affordance")
    if not isinstance(affordance, str) or not affordance.strip():
        bad("affordance", f"must be a non-empty name, got {_short(affordance)}")
    if len(affordance) > 200 or not affordance.isprintable():
        bad("affordance", f"must be a one-line name of at most 200 characters, got "
                          f"{_short(affordance)}")
    radius = number("radius", 1e-4, 100.0)
    number("scene_spacing", MIN_SPACING, 1.0)
    number("clearance_limit", 0.0, 1.0, 0.05)
    number("interior_limit", 0.0, 1.0, 1.0)
    number("contact_distance", 1e-4, 10.0, 0.02)
    number("contact_fraction", 0.0, 1.0, 0.25)
    number("contact_angle", 1e-6, 90.0, 90.0)
    groups = header.get("contact_groups", "off")
    if not isinstance(groups, str) or groups not in ("off", "main", "all", "seat"):
        bad("contact_groups", f"must be 'off', 'main', 'all' or 'seat', got {_short(groups)}")
    ground = header.get("ground")
    if ground is not None:
        number("ground", -1e4, 1e4)
    below = header.get("below_ground")
    if below is not None:
        below = number("below_ground", 0.0, 1.0)
    feet = header.get("feet_reach")
    if feet is not None:
        feet = number("feet_reach", 0.0, 1.0)
    mount = header.get("mount_height")
    if mount is not None:
        mount = number("mount_height", 0.0, 10.0)
    tolerance = header.get("normal_tolerance")
    if tolerance is not None:
        tolerance = number("normal_tolerance", 0.0, 90.0)
    straddle = header.get("straddle")
    if straddle is not None:
        try:
            straddle = straddle_boxes(straddle)
        except (TypeError, ValueError, OverflowError) as exc:
            bad("straddle", _short(str(exc), 200, quote=False))
    if "collision_tests" in header:
        if not isinstance(header["collision_tests"], list):
            bad("collision_tests", f"must be a list of (depth, above), got "
                                   f"{_short(header['collision_tests'])}")
        try:
            tests = collision_tests(header["collision_tests"])
        except (TypeError, ValueError, OverflowError) as exc:
            bad("collision_tests", _short(str(exc), 200, quote=False))
    else:       # format 3 files with one test, as collision_depth and collision_above
        depth, above = header.get("collision_depth"), header.get("collision_above")
        if depth is not None:
            depth = number("collision_depth", 0.0, 1.0)
        if above is not None:
            above = number("collision_above", -10.0, 10.0)
        tests = () if depth is None else ((depth, above),)
    through = header.get("through", False)
    if not isinstance(through, bool):
        bad("through", f"must be true or false, got {_short(through)}")
    hangs, fills = header.get("hangs", False), header.get("fills", False)
    for name, value in (("hangs", hangs), ("fills", fills)):
        if not isinstance(value, bool):
            bad(name, f"must be true or false, got {_short(value)}")
    if len(out["through_section"]) and len(out["through_section"]) < 3:
        bad("through_section", "must be a polygon of at least 3 vertices, or empty")
    vectors = header.get("vectors")
    if not isinstance(vectors, str) or vectors not in ("surface", "points"):
        bad("vectors", f"must be 'surface' or 'points', got {_short(vectors)}")
    # the calibrated tables: every criterion and keypoint set, nothing else
    for table_name, low_open in (("thresholds", True), ("self_scores", False)):
        table = header.get(table_name)
        if not isinstance(table, dict):
            bad(table_name, f"must be a table of {', '.join(TABLE_KEYS)}, got {_short(table)}")
        for key in TABLE_KEYS:
            if key not in table:
                bad(f"{table_name}.{key}", "is missing")
            if not _in_range(table[key], 0.0, 1.0, low_open):
                bad(f"{table_name}.{key}", f"must be a number in {'(0, 1]' if low_open else '[0, 1]'}"
                                           f", got {_short(table[key])}")
        extra = sorted(set(table) - set(TABLE_KEYS))
        if extra:
            bad(f"{table_name}.{str(extra[0])[:40]}",
                f"is not one of {', '.join(TABLE_KEYS)}")
    meta = header.get("meta", {})
    if not isinstance(meta, dict):
        bad("meta", f"must be a table, got {_short(meta)}")
    where = _not_plain(meta, "meta")
    if where is not None:
        bad(where, "must be plain JSON (text, finite numbers, true/false, null, lists, "
                   "tables)")
    if np.linalg.norm(out["reference_point"] - out["query_centroid"]) > 10 * radius:
        bad("reference_point", "lies far outside the query object (more than 10 x its radius)")
    header = {**header, "clearance_limit": header.get("clearance_limit", 0.05),
              "interior_limit": header.get("interior_limit", 1.0),
              "contact_groups": header.get("contact_groups", "off"),
              "contact_distance": header.get("contact_distance", 0.02),
              "contact_fraction": header.get("contact_fraction", 0.25),
              "contact_angle": header.get("contact_angle", 90.0),
              "collision_tests": tests, "through": through, "hangs": hangs,
              "fills": fills,
              "ground": None if ground is None else float(ground),
              "below_ground": None if below is None else float(below),
              "feet_reach": None if feet is None else float(feet), "straddle": straddle,
              "mount_height": mount, "normal_tolerance": tolerance,
              "meta": meta}
    return header, out


#: Samples of the scene-object in the query's box, and of the query near them, that
#: :func:`through_section_of` looks at.
THROUGH_SAMPLES = 40_000
#: How far (in training spacings) the through section keeps from the query's surface: a
#: surface that touches the hook only where it rests does not reach the section.
THROUGH_GAP = 0.25
#: How much (in training spacings) of the through section's top is left out: a surface that
#: only grazes the top of the opening (a hook pushed up into a board's underside) does not
#: reach the rest. Chosen on the judge's labelled set (``paper/scripts/choose_through_band.py``):
#: the smallest band that rejects every hanging pose it can while keeping every valid one.
THROUGH_BAND = 0.25


def _faces_in_box(g: Geometry, lo, hi) -> np.ndarray:
    """(F,) bool: the faces of mesh ``g`` whose bounding boxes meet the box ``lo``-``hi``."""
    tri = g.vertices[g.faces]
    return ((tri.max(axis=1) >= lo) & (tri.min(axis=1) <= hi)).all(axis=1)


def through_section_of(query: Geometry, scene_object: Geometry, settings: TrainSettings,
                       band: float | None = None):
    """Where the scene-object passes through the query (:func:`.collision.through_section`),
    from dense samples of the scene-object in the query's box and of the query around them
    (a hook's inside is a few millimetres thick: the detection spacing would miss it): the
    opening widened by the training spacing, kept :data:`THROUGH_GAP` spacings from the
    query's surface, less its top ``band`` spacings (by default :data:`THROUGH_BAND`)."""

    s = settings.scene_spacing
    lo, hi = query.vertices.min(axis=0) - s, query.vertices.max(axis=0) + s
    if scene_object.is_mesh:
        mask = _faces_in_box(scene_object, lo, hi)
        if not mask.any():
            return np.zeros((0, 3))
        # the faces' samples beyond the box too: they show which way the rail runs
        pts, _ = sample_mesh(scene_object, THROUGH_SAMPLES, settings.seed + 8, face_mask=mask)
    else:                   # a cloud: its points around the box too, for the same reason
        v, reach = scene_object.vertices, float(np.linalg.norm(hi - lo))
        pts = v[((v >= lo - reach) & (v <= hi + reach)).all(axis=1)]
    if len(pts) == 0:
        return np.zeros((0, 3))
    if query.is_mesh:       # the query where the scene-object is, sampled as densely
        near = pts[((pts >= lo) & (pts <= hi)).all(axis=1)]
        if len(near) == 0:
            return np.zeros((0, 3))
        q_mask = _faces_in_box(query, near.min(axis=0) - 2 * s, near.max(axis=0) + 2 * s)
        q_pts = sample_mesh(query, THROUGH_SAMPLES, settings.seed + 9, face_mask=q_mask)[0] \
            if q_mask.any() else np.zeros((0, 3))
    else:
        q_pts = query.vertices
    return through_section(query.vertices, pts, q_pts, s, THROUGH_GAP * s,
                           band=(THROUGH_BAND if band is None else band) * s)


def _scene_object_samples(scene_object: Geometry, centre, crop: float, spacing: float, seed):
    """Scene-object samples (and unit normals) within ``crop`` m of ``centre``.

    Meshes: faces that reach the ball are sampled at ``spacing``; clouds denser than
    ``spacing`` are thinned by a seeded random subset; normals of clouds are estimated.
    """
    import trimesh

    if scene_object.is_mesh:
        tri = scene_object.vertices[scene_object.faces]
        closest = trimesh.triangles.closest_point(tri, np.tile(centre, (len(tri), 1)))
        mask = np.linalg.norm(closest - centre, axis=1) <= crop
        if not mask.any():
            return np.zeros((0, 3)), np.zeros((0, 3))
        area = mesh_area(Geometry(scene_object.vertices, scene_object.faces[mask]))
        count = int(np.clip(round(area / spacing ** 2), 100, 3_000_000))
        pts, nrm = sample_mesh(scene_object, count, seed, face_mask=mask)
    else:
        pts = scene_object.vertices
        tree = cKDTree(pts)
        nrm = scene_object.normals
        if nrm is None:
            nrm = estimate_normals(pts, tree=tree)
        s = mean_spacing(pts, tree)
        keep = np.linalg.norm(pts - centre, axis=1) <= crop * 1.2
        pts, nrm = pts[keep], nrm[keep]
        frac = min(1.0, (s / spacing) ** 2)
        if frac < 1.0 and len(pts):
            rng = np.random.default_rng(seed)
            sub = rng.random(len(pts)) < frac
            pts, nrm = pts[sub], nrm[sub]
    inside = np.linalg.norm(pts - centre, axis=1) <= crop
    return pts[inside], nrm[inside]


def _reference_point(q_pts, q_gaps, s_pts, s_nrm, normal, tolerance, spacing):
    """p_scene: centre of the scene-object's contact patch facing the query along N_aff.

    Candidates are scene-object samples whose normal line is within 30 degrees of N_aff and
    whose nearest query sample lies on the N_aff side of them. The patch is every candidate
    within ``tolerance`` of the smallest such gap that is connected (links of 2.5 spacings)
    to the closest one.

    Returns the reference point (3,) and the query's contact samples (C, 3).
    """
    cos_lim = np.cos(np.radians(REFERENCE_NORMAL_DEG))
    aligned = np.abs(s_nrm @ normal) >= cos_lim
    q_tree = cKDTree(q_pts)
    d, qi = q_tree.query(s_pts, k=min(8, len(q_pts)), workers=-1)
    # the query lies on the N_aff side of a point when its 8 nearest query samples do on
    # average (a touching contact has its nearest sample beside it, not above it); where
    # they are level with it (a flat bottom resting on the surface), when its centroid does
    local = ((q_pts[qi] - s_pts[:, None, :]) @ normal).mean(axis=1)
    level = 0.1 * spacing
    facing = (local > level) | ((local > -level) & ((q_pts.mean(axis=0) - s_pts) @ normal > 0))
    d = d[:, 0]
    cand = np.flatnonzero(aligned & facing)
    if len(cand) == 0:
        cand = np.flatnonzero(facing) if facing.any() else np.arange(len(s_pts))
    best = cand[np.argmin(d[cand])]
    patch = cand[d[cand] <= d[best] + tolerance]
    # keep the connected piece of the patch that holds the closest point (a seat, not the
    # foot rests as well)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    pairs = cKDTree(s_pts[patch]).query_pairs(2.5 * spacing, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(patch), len(patch)))
    _, label = connected_components(graph, directed=False)
    patch = patch[label == label[np.flatnonzero(patch == best)[0]]]
    ref = s_pts[patch].mean(axis=0)
    contact = q_pts[q_gaps <= q_gaps.min() + tolerance]
    return ref, contact


def _interior_samples(query: Geometry, settings: TrainSettings):
    """Interior points of a query mesh and their depth (see clearance.py).

    Seeded uniform candidates in the query's bounding box are kept when they lie behind the
    surface, i.e. on the inner side of the face normals of their 8 nearest dense surface
    samples (a majority of them), and their distance to the nearest sample, the depth, is at
    least ``interior_min_depth``; at most ``interior_points`` are kept and each is confirmed
    by its generalised winding number (a winding-number test of every candidate cost 2.7 s
    for a person, of the kept ones 0.1 s). Depth is capped at ``interior_max``. A point
    cloud (no inside) or a thin-walled object (a mug, a hook) gives none.

    Returns (I, 3) points and (I,) radii (m).
    """
    if not query.is_mesh or settings.interior_points == 0:
        return np.zeros((0, 3)), np.zeros(0)
    faces = np.asarray(query.faces)
    lo, hi = query.vertices.min(axis=0), query.vertices.max(axis=0)
    rng = np.random.default_rng(settings.seed + 5)
    cand = rng.uniform(lo, hi, (16 * settings.interior_points, 3))
    dense, normals = sample_mesh(query, 60000, settings.seed + 6)
    dist, nn = cKDTree(dense).query(cand, k=8, workers=-1)
    behind = np.einsum("pki,pki->pk", cand[:, None, :] - dense[nn], normals[nn]) < 0
    keep = (behind.mean(axis=1) > 0.5) & (dist[:, 0] >= settings.interior_min_depth)
    inside, depth = cand[keep], dist[keep, 0]
    if len(inside) > settings.interior_points:
        pick = np.sort(rng.choice(len(inside), settings.interior_points, replace=False))
        inside, depth = inside[pick], depth[pick]
    if len(inside) and len(inside) * len(faces) <= MAX_WINDING_TERMS:
        # confirmed by the winding number (exact for closed meshes, unions of closed parts
        # included), which only the few points kept can afford

        sure = winding_numbers(inside, query.vertices, faces) > 0.5
        inside, depth = inside[sure], depth[sure]
    return inside, np.minimum(depth, settings.interior_max)


def _contact_mode(mode: str, group_ids: np.ndarray) -> str:
    """The contact test a trained descriptor carries: the settings' ``mode``, ``auto``
    meaning every contact group when the example touched its scene-object in several places
    (a person lying on a bench from head to heels: a new place must bear all of it), else
    the main one."""
    if mode != "auto":
        return mode
    return "all" if len(np.unique(group_ids)) > 1 else "main"


def _contact_groups(q_pts, q_gap, q_normal, ground, reference, settings: TrainSettings):
    """The query's contact groups: its samples within ``contact_tolerance`` of the
    scene-object's surface (``q_gap``, m) or of the ground plane, joined by links of
    ``contact_link``; groups smaller than 2 % of the contact samples (and than 3 samples)
    are dropped. Group 0 holds the contact sample nearest ``reference``, the rest follow
    by size; each keeps at most ``contact_group_points`` samples (seeded). Each keeps the
    normal of what it touched: ``q_normal`` (the scene-object's normal at its nearest
    sample) or, where the ground is nearer, +Z.

    Returns (G, 3) points, (G,) int64 group ids and (G, 3) unit normals.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    touch = q_gap <= settings.contact_tolerance
    nrm = np.asarray(q_normal, float).copy()
    if ground is not None:
        height = q_pts[:, 2] - ground
        touch |= height <= settings.contact_tolerance
        nrm[height < q_gap] = (0.0, 0.0, 1.0)
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-12)
    pts, nrm = q_pts[touch], nrm[touch]
    if len(pts) == 0:
        return np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros((0, 3))
    pairs = cKDTree(pts).query_pairs(settings.contact_link, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(pts), len(pts)))
    _, label = connected_components(graph, directed=False)
    sizes = np.bincount(label)
    main = label[np.argmin(np.linalg.norm(pts - reference, axis=1))]
    big = np.flatnonzero(sizes >= max(3, 0.02 * len(pts)))
    order = [main] + sorted((g for g in big if g != main), key=lambda g: (-sizes[g], g))
    rng = np.random.default_rng(settings.seed + 7)
    out_p, out_g, out_n = [], [], []
    for new, g in enumerate(order):
        members = np.flatnonzero(label == g)
        if len(members) > settings.contact_group_points:
            members = np.sort(rng.choice(members, settings.contact_group_points,
                                         replace=False))
        out_p.append(pts[members])
        out_n.append(nrm[members])
        out_g.append(np.full(len(members), new, np.int64))
    return np.concatenate(out_p), np.concatenate(out_g), np.concatenate(out_n)


def _own_collision_tests(query: Geometry, scene_object: Geometry,
                         settings: TrainSettings) -> tuple:
    """The collision test a descriptor fitted from this example carries: the whole query at
    most ``settings.collision_depth`` inside the scene, or as deep as the example's own
    query lies in its scene-object (the shortest freeing move, :meth:`~..geometry.collision.
    MeshCollider.separation`) where that is deeper, so the example passes its own test.
    No test for a point-cloud query (no triangles to test), for ``collision_depth`` None, or
    where no move up to 20 cm frees the example (a query built through its scene-object)."""
    if settings.collision_depth is None or not query.is_mesh:
        return ()
    depth = float(settings.collision_depth)
    if scene_object.is_mesh:
        own = MeshCollider(scene_object.vertices, scene_object.faces).separation(
            Body(query.vertices, query.faces), np.eye(4))
        if not np.isfinite(own):
            return ()
        depth = max(depth, own)
    return ((depth, None),)


#: A collision test's ``above`` that tests a person part by part (:attr:`InteractionTensor.collision_tests`).
LIMBS = "limbs"


def collision_tests(value) -> tuple:
    """Detection's collision tests from (depth, above) or a list of them, checked: depth in
    [0, 1] m, above None, a height in [-10, 10] m or ``"limbs"``. Raises ValueError."""
    try:
        items = list(value) if not isinstance(value, (str, bytes)) else None
    except TypeError:                              # a number, None, ...
        items = None
    if items and not isinstance(items[0], (list, tuple)):
        items = [items]                            # one (depth, above)
    if items is None:
        raise ValueError("must be (depth, above) or a list of them")
    tests = []
    for item in items:
        item = tuple(item) if isinstance(item, (list, tuple)) else ()
        limbs = len(item) == 2 and item[1] == LIMBS
        ok = len(item) == 2 and all(v is None or (isinstance(v, (int, float)) and
                                                  not isinstance(v, bool))
                                    for v in (item[:1] if limbs else item))
        depth, above = item if ok else (None, None)
        if not ok or depth is None or not (np.isfinite(depth) and 0 <= depth <= 1) or \
                (above is not None and not limbs
                 and not (np.isfinite(above) and abs(above) <= 10)):
            raise ValueError(f"collision test {list(item) if item else value!r} must be (depth "
                             "in [0, 1] m, above: None, a height in [-10, 10] m or 'limbs')")
        tests.append((float(depth), above if above is None or limbs else float(above)))
    return tuple(tests)


def straddle_boxes(value) -> dict:
    """The straddle test's boxes (:attr:`InteractionTensor.straddle`) from ``{"astride": box
    or None, "legroom": [box, ...]}``, checked: each box ``((x0, x1), (y0, y1), (z0, z1))``
    of finite numbers with x0 < x1 (and so on) within 5 m of the reference point, at most 8
    legroom boxes, at least one box in all. Raises ValueError."""
    if not isinstance(value, dict) or not set(value) <= {"astride", "legroom"}:
        raise ValueError("must be {'astride': box or None, 'legroom': [box, ...]}")

    def box(b):
        try:
            arr = np.asarray(b, float)
        except (TypeError, ValueError):
            arr = np.zeros(0)
        if arr.shape != (3, 2) or not np.isfinite(arr).all() or \
                not (arr[:, 0] < arr[:, 1]).all() or np.abs(arr).max() > 5:
            raise ValueError(f"box {b!r} must be ((x0, x1), (y0, y1), (z0, z1)) m with each "
                             "low < high, within 5 m of the reference point")
        return tuple((float(lo), float(hi)) for lo, hi in arr)

    astride = value.get("astride")
    legroom = value.get("legroom") or []
    if isinstance(legroom, (str, bytes, dict)) or not hasattr(legroom, "__len__") or \
            len(legroom) > 8:
        raise ValueError("legroom must be a list of at most 8 boxes")
    out = {"astride": None if astride is None else box(astride),
           "legroom": tuple(box(b) for b in legroom)}
    if out["astride"] is None and not out["legroom"]:
        raise ValueError("needs an astride box or a legroom box")
    return out


def _boxes_json(straddle):
    """The straddle boxes as JSON lists (None without the test)."""
    if straddle is None:
        return None
    return {"astride": None if straddle["astride"] is None
            else [list(r) for r in straddle["astride"]],
            "legroom": [[list(r) for r in b] for b in straddle["legroom"]]}
