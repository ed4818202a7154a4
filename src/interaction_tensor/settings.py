"""Every parameter of training and detection, in one place, with the paper's defaults.

Each default cites where it comes from: ``paper`` is ``shared/paper.tex`` (Ruiz &
Mayol-Cuevas), ``code`` the authors' public implementation as summarised in
``shared/REFERENCE.md``, and ``ours`` a choice of this project, explained in the comment.
"""

from __future__ import annotations

import math
import numbers
import re
from dataclasses import asdict, dataclass, fields, replace

from .errors import SettingsError

CRITERIA = ("paper", "gaussian")
KEYPOINT_SETS = ("weighted", "uniform")
BACKENDS = ("auto", "numba", "numpy", "torch")
KEYPOINT_ORDERS = ("adaptive", "weight")
COMPLETE_SCORES = ("accepted", "placed")
STAGE_ORDERS = ("auto", "score-first", "tests-first")
#: Smallest sampling spacing (m): finer sampling grows memory as 1 / spacing^2 (a 1e-6 m
#: spacing asked for gigabytes before any check), and no scan resolves below a millimetre.
MIN_SPACING = 1e-3


def _check_seed(seed) -> None:
    _check(isinstance(seed, numbers.Integral) and not isinstance(seed, bool)
           and 0 <= seed < 2 ** 63, f"seed must be an integer in [0, 2**63), got {seed!r}")


def _check(cond: bool, message: str) -> None:
    if not cond:
        raise SettingsError(message)


@dataclass(frozen=True)
class TrainSettings:
    """How an Interaction Tensor is fitted from one example."""

    #: Area-uniform samples on the query object. Paper/code: 100k. Ours: 6000 is enough
    #: for the bisector near the contact and keeps the Voronoi step well under a second.
    query_points: int = 6000
    #: Mean spacing (m) of the samples on the scene-object. Detection samples mesh scenes at
    #: the same spacing, so that the provenance vectors learnt here and the test vectors
    #: measured there see the same point density (ours).
    scene_spacing: float = 0.01
    #: Scene-object samples are kept within ``crop_factor * radius`` of the query centroid
    #: before the Voronoi step. Bisector points whose empty sphere leaves that ball are
    #: dropped, so every point kept is exactly a point of the full diagram (ours).
    crop_factor: float = 2.0
    #: Affordance keypoints per set. Paper: N = 512.
    n_keypoints: int = 512
    #: Provenance (and later test) vectors: ``surface``, to the nearest point of the sampled
    #: surface (each sample a disk of radius ``scene_spacing``), or ``points``, to the nearest
    #: sample as in the paper's dense clouds. ``surface`` makes the vectors independent of
    #: where random samples fell, which the paper's tight tests on short vectors need (ours).
    vectors: str = "surface"
    #: Expected normal N_aff of the scene-object at the interaction, +Z up. Paper: up for
    #: placing, hanging, sitting, riding; down for filling (the tap).
    affordance_normal: tuple = (0.0, 0.0, 1.0)
    #: Contact: query samples within this distance (m) of the scene-object, plus the smallest
    #: gap, define the contact region whose centre gives the reference point (ours).
    contact_tolerance: float = 0.01
    #: Acceptance threshold of the paper criterion as a fraction of the score that the
    #: training example itself gets on a re-sampled copy of its scene-object (ours; the paper
    #: tunes S_aff by hand per affordance).
    calibration_ratio: float = 0.9
    #: Clearance points: query surface samples whose free space is recorded (the clearance
    #: idea of the authors' later iTClearance work: the query needs room, not an identical
    #: scene-object). 0 disables it (ours).
    clearance_points: int = 256
    #: Largest clearance (m) recorded per clearance point: the free space around the query
    #: that a new scene must leave, up to this (ours).
    clearance_max: float = 0.02
    #: Fraction of the clearance points a placement may violate before detection rejects it
    #: (stored in the descriptor; ours).
    clearance_limit: float = 0.05
    #: Interior points: points inside the query mesh, at least ``interior_min_depth`` (m)
    #: from its surface, whose depth (at most ``interior_max``) the scene must not come
    #: within: a surface passing through the object (a board through a seated body) meets
    #: many of them, a surface touching it none (see clearance.py). 0 disables it; a point
    #: cloud query has none (ours).
    interior_points: int = 512
    interior_min_depth: float = 0.015
    interior_max: float = 0.05
    #: Fraction of the interior points a placement may violate (stored in the descriptor;
    #: 1 turns the test off; ours).
    interior_limit: float = 0.05
    #: Contact groups: the query's samples within ``contact_tolerance`` of the scene-object
    #: (or of the example's ground plane) joined into groups by links of ``contact_link``
    #: (m), at most ``contact_group_points`` kept per group (ours).
    contact_group_points: int = 32
    contact_link: float = 0.03
    #: The contact test stored in the descriptor: ``main`` (the group at the reference
    #: point), ``all`` groups or ``off``; a group keeps its contact when at least
    #: ``contact_fraction`` of its points have a scene sample within ``contact_distance`` (m)
    #: (ours; the paper's examples carry values tuned per affordance).
    contact_groups: str = "main"
    contact_distance: float = 0.02
    contact_fraction: float = 0.25
    #: ... and, below 90, the normal line of that nearest sample within this angle (degrees)
    #: of the normal the example's scene-object (or ground) had there: a hook's inner arc
    #: meets a round rail's normals all around, a flat shelf top's only at its apex (ours).
    contact_angle: float = 90.0
    #: Seed of every random step of training.
    seed: int = 0

    def __post_init__(self):
        _check(100 <= self.query_points <= 1_000_000,
               "query_points must be between 100 and 1,000,000 (memory grows with it)")
        _check(self.clearance_points >= 0, "clearance_points must be non-negative")
        _check(self.clearance_max > 0, "clearance_max must be positive (metres)")
        _check(0 <= self.clearance_limit <= 1, "clearance_limit must be in [0, 1]")
        _check_seed(self.seed)
        _check(math.isfinite(self.scene_spacing) and MIN_SPACING <= self.scene_spacing <= 1.0,
               f"scene_spacing must be between {MIN_SPACING} and 1 metre (samples cost "
               "memory as 1 / spacing^2), got {self.scene_spacing}")
        _check(self.crop_factor >= 1.0, "crop_factor must be at least 1")
        _check(self.n_keypoints >= 8, "n_keypoints must be at least 8")
        _check(self.vectors in ("surface", "points"), "vectors must be 'surface' or 'points'")
        _check(0 < self.calibration_ratio <= 1, "calibration_ratio must be in (0, 1]")
        _check(self.contact_tolerance > 0, "contact_tolerance must be positive")
        _check(self.interior_points >= 0, "interior_points must be non-negative")
        _check(0 < self.interior_min_depth <= self.interior_max,
               "interior_min_depth must be positive and at most interior_max (metres)")
        _check(0 <= self.interior_limit <= 1, "interior_limit must be in [0, 1]")
        _check(self.contact_group_points >= 1, "contact_group_points must be at least 1")
        _check(self.contact_link > 0, "contact_link must be positive (metres)")
        _check(self.contact_groups in ("off", "main", "all", "seat"),
               "contact_groups must be 'off', 'main', 'all' or 'seat'")
        _check(self.contact_distance > 0, "contact_distance must be positive (metres)")
        _check(0 <= self.contact_fraction <= 1, "contact_fraction must be in [0, 1]")
        _check(0 < self.contact_angle <= 90, "contact_angle must be in (0, 90] degrees")
        n = [float(v) for v in self.affordance_normal]
        _check(len(n) == 3 and math.isfinite(sum(n)) and sum(v * v for v in n) > 0,
               "affordance_normal must be a non-zero 3-vector")

    def to_dict(self) -> dict:
        d = asdict(self)
        d["affordance_normal"] = [float(v) for v in self.affordance_normal]
        return d


@dataclass(frozen=True)
class DetectSettings:
    """How a scene is searched for places where a trained interaction can happen."""

    #: Fraction of scene points drawn at random as test points. Paper: 30 %.
    sample_fraction: float = 0.30
    #: Orientations of the query object about +Z, i * 2 pi / n. Paper and code: 8.
    n_orientations: int = 8
    #: Largest angle (degrees) between a test point's normal line and N_aff. Normals of CAD
    #: scenes and scans are not consistently oriented, so the sign is ignored unless
    #: ``oriented_normals`` (ours; the paper only says n_i ~ N_aff).
    normal_tolerance_deg: float = 15.0
    oriented_normals: bool = False
    #: ``paper``: eq. 5 angle and magnitude tests; ``gaussian``: the authors' code criterion.
    #: None: by the kind of scene, ``gaussian`` for captured data (RGB-D frames and scans,
    #: whose depth noise the paper criterion's tight tests on short vectors do not tolerate),
    #: ``paper`` for meshes and clouds (see :meth:`for_scene`).
    criterion: str | None = None
    #: Paper criterion: theta_max = pi / 18 and c = 5 (paper, section 3.2).
    theta_max: float = math.pi / 18
    c: float = 5.0
    #: Gaussian criterion: sigma = a (1 + w), accept when score > 0.5 (code).
    gaussian_a: float = 0.4
    #: Acceptance threshold on the normalised score in [0, 1]. None: the descriptor's
    #: calibrated threshold for the paper criterion, 0.5 for the gaussian one (code).
    threshold: float | None = None
    #: Which keypoint set to compare: ``weighted`` (paper) or ``uniform``.
    keypoints: str = "weighted"
    #: Stop comparing a candidate as soon as its decision is known (paper, section 4.2.1).
    early_exit: bool = True
    #: Which pairs get a complete score (every keypoint), with ``early_exit``. ``placed``
    #: (default): with ``stage_order`` tests-first, the pairs the score accepts, of those
    #: that passed the tests (the only ones scored). With score-first, every pair stops at
    #: its decision, accepted or rejected; the placement
    #: tests run on the decisions, and only the pairs that pass them are scored again in
    #: full. Their scores, the predictions and the heat map are bit for bit those of
    #: ``accepted``; a pair the score accepted that fails a placement test keeps the partial
    #: score of its decision, as a rejected pair does (``Detection.complete`` tells which
    #: scores are whole). ``accepted``: every pair the score accepts is scored in full (the
    #: behaviour before 2026-11-27; with the tuned placing descriptor 99.7 % of the pairs
    #: are accepted by the score and only 38 % of them placed, benchmarks/RESULTS.md). The
    #: Numba backend only: the reference and torch paths score accepted pairs in full.
    complete_scores: str = "placed"
    #: Which comes first, the score or the placement tests. ``tests-first``: every pair gets
    #: the placement tests, and only the pairs that pass them are scored, stopping at a
    #: rejection (an accepted pair is scored over every keypoint). The keypoints, their order
    #: and the running sum are those of ``score-first``, so the decisions, the accepted
    #: scores (bit for bit), the heat map and the predictions are the same; a pair that fails
    #: a test is never scored (score 0, ``Detection.scored`` False) and its placement outcome
    #: is known whatever its score; a ranking of such pairs (``detect.rank_pairs``) scores
    #: them again, at most 50,000, so past that it can differ from score-first's. ``score-first``: every pair is scored to its decision and
    #: the tests run on the pairs the score accepts (the only order before 2026-11-27).
    #: ``auto`` (default): ``tests-first``, unless ``complete_scores`` is ``accepted`` or
    #: ``early_exit`` is off, which ask for the scores of pairs whatever their tests. With
    #: the tuned descriptors the score accepts nearly every pair and the tests reject most:
    #: on kitchen3 at 30 % 16 % of the 8 examples' pairs pass the tests
    #: (benchmarks/RESULTS.md).
    stage_order: str = "auto"
    #: Order in which keypoints are compared. ``weight`` (default): largest weight first (the
    #: paper's, and the authors' code's). ``adaptive``: the cheapest order on a seeded pilot
    #: of this scene's own pairs (:func:`~interaction_tensor.detect.pilot_order`: the weight
    #: order or a blend of ordering for acceptance and for rejection per unit of modelled
    #: lookup cost, whichever decides the pilot's pairs with the least search). Scores are
    #: sums over keypoints, so the order never changes a decision, an accepted score (bit for
    #: bit with the paper's criterion, to rounding with the gaussian one), the heat map or the
    #: predictions (tested). It does change what depends on where the early exit stopped: a
    #: rejected pair's partial score and every pair's ``decided_at``
    #: (``comparisons_to_decision`` in predictions.json). Measured at 30 % with the neighbour
    #: cache and the tuned descriptors (2026-11-27, benchmarks/RESULTS.md): 0.97x the weight
    #: order's speed for placing-bowl on kitchen5, 1.00x on office-desk1, 1.05x for
    #: sitting-human on office-desk5 (10-20 % fewer comparisons; the rest of the scoring
    #: stage dominates). So it is not the default; ``itensor evaluate`` asks for ``weight``
    #: itself.
    keypoint_order: str = "weight"
    #: Pairs fully scored to measure the adaptive order.
    pilot_pairs: int = 256
    #: Clearance test (when the descriptor has clearance points): an accepted pair must also
    #: leave the query room, i.e. no scene sample nearer than ``r - tolerance`` to a clearance
    #: point whose free space in the example was r (at most ``clearance_max``), at more than
    #: ``clearance_max_violations`` (a fraction) of the clearance points; None: the
    #: descriptor's own limit (tuned per affordance for the paper's examples, else
    #: ``TrainSettings.clearance_limit``). A sample is never nearer than the surface it lies
    #: on, so sampling cannot cause a violation; the tolerance only allows the scene a little
    #: closer than the example (ours).
    clearance: bool = True
    clearance_tolerance: float = 0.005
    clearance_max_violations: float | None = None
    #: Contact test (when the descriptor has contact groups and its mode is not ``off``): the
    #: parts that touched the example's scene-object must touch the scene again (ours; see
    #: clearance.py).
    contact: bool = True
    #: Interior test (when the descriptor has interior points): no scene sample nearer than
    #: ``depth - interior_tolerance`` to more than the descriptor's interior limit of them.
    #: The 1 cm tolerance lets a person sink a centimetre into a soft seat (ours).
    interior: bool = True
    #: Ground test (when the descriptor has ``below_ground``): the posed query object no
    #: deeper than that below the lowest scene sample within 1.5 m of it (a hanger hooked
    #: round a chair's star base in a scan without its floor; ours).
    ground: bool = True
    #: Feet test (when the descriptor has ``feet_reach``): what stood on the example's ground
    #: (a seated person's feet) finds a scene surface at most that far below it, or the
    #: scene's ground (a person on a counter top with the feet in the air; ours).
    feet: bool = True
    #: Straddle test (when the descriptor has ``straddle``: riding): the scene goes on
    #: between the legs ahead of the seat and leaves room for a leg on each side (a bench
    #: crossed sideways, a wide seat or a bed fails; ours).
    straddle: bool = True
    #: Mount test (when the descriptor has ``mount_height``: riding): the seat no higher
    #: than that above the scene's ground (no one climbs astride a 2.4 m wall; ours).
    mount: bool = True
    #: Through test (when the descriptor asks for it, ``InteractionTensor.through``: hanging):
    #: scene samples cross the posed section of what went through the query in the example
    #: (a rail through the hook), on every pair; the exact collision test asks the scene's
    #: triangles the same of the pairs it ranks (ours).
    through: bool = True
    interior_tolerance: float = 0.01
    #: Collision test (when the scene is a triangle mesh, ``Scene.mesh``, and the descriptor
    #: has a collision depth): a placement that reaches the top k is moved into the scene
    #: and its triangles tested against the scene's (python-fcl, exact, however thin the
    #: parts); it is rejected when no move of the descriptor's ``collision_depth`` in one of
    #: 26 directions frees it. The sampled placement tests miss a thin panel or a wall
    #: through a seated person; this one does not. Only the placements that would enter the
    #: top k are tested (a few milliseconds each), best first, at most
    #: ``collision_max_tests`` per ranking; a placement left untested when they run out is
    #: not predicted (ours). 2,000 (until 2026-11-26) left hanging with no prediction in 8 of
    #: 12 small-scene runs: on office-desk4 the hanger's top 5 (on chair armrests, all valid)
    #: took 5,889 tests (13 s, about 2 ms each: the rest are hooks through desk tops and
    #: seats, where something does go through the hook), the handbag's two 26,989 (28 s); a
    #: seated person's top 5 there took 1,143 (3 s): about 2 minutes when all are spent.
    collision: bool = True
    collision_max_tests: int = 50_000
    #: Predictions kept after non-maximum suppression.
    top_k: int = 10
    #: Suppression radius (m) of the top-k; None: the query object's width (the larger side
    #: of its horizontal bounding box), so that the posed objects of the top-k do not overlap.
    nms_radius: float | None = None
    #: Spacing (m) at which mesh scenes are sampled; None: the descriptor's training spacing.
    scene_spacing: float | None = None
    #: Hard cap on scene samples, to bound memory on huge meshes.
    max_scene_points: int = 5_000_000
    #: Candidates scored per batch (bounds memory; a progress-bar step).
    batch_size: int = 4096
    #: ``auto``: the Numba kernel when Numba imports, else ``numpy``; ``numpy`` is the plain
    #: vectorised path over SciPy's cKDTree; ``torch``: PyTorch, on a CUDA device when one is
    #: present (see ``device``), same decisions as the CPU paths.
    backend: str = "auto"
    #: Numba backend: answer nearest-neighbour queries from a cache of per-block candidate
    #: lists on the scene's grid (exact: identical results). None (auto): when at least 10 %
    #: of the scene's points are tested (the default 30 % is), and dropped when the search
    #: ends; True: always, kept on the grid for later searches of the same scene (many
    #: affordances, the evaluation); False: the grid search alone.
    neighbour_cache: bool | None = None
    #: Torch device of the ``torch`` backend; None: ``cuda`` when present, else ``cpu``.
    device: str | None = None
    #: Seed of the test-point draw and of scene sampling.
    seed: int = 0

    def __post_init__(self):
        _check(0 < self.sample_fraction <= 1, "sample_fraction must be in (0, 1]")
        _check(self.n_orientations >= 1, "n_orientations must be at least 1")
        _check(0 <= self.normal_tolerance_deg <= 180, "normal_tolerance_deg must be in [0, 180]")
        _check(self.criterion is None or self.criterion in CRITERIA,
               f"criterion must be one of {CRITERIA} (or None: by the kind of scene)")
        _check(self.keypoints in KEYPOINT_SETS, f"keypoints must be one of {KEYPOINT_SETS}")
        _check(self.theta_max > 0 and self.c > 0 and self.gaussian_a > 0,
               "theta_max, c and gaussian_a must be positive")
        _check(self.threshold is None or 0 < self.threshold <= 1,
               "threshold must be in (0, 1]")
        _check(self.top_k >= 0, "top_k must be non-negative")
        _check(self.collision_max_tests >= 0, "collision_max_tests must be non-negative")
        _check(self.clearance_tolerance >= 0,
               "clearance_tolerance must be non-negative (metres)")
        _check(self.clearance_max_violations is None or 0 <= self.clearance_max_violations <= 1,
               "clearance_max_violations must be in [0, 1]")
        _check(self.interior_tolerance >= 0,
               "interior_tolerance must be non-negative (metres)")
        _check(self.nms_radius is None or self.nms_radius >= 0, "nms_radius must be >= 0")
        _check(self.scene_spacing is None or (math.isfinite(self.scene_spacing) and
                                              MIN_SPACING <= self.scene_spacing <= 1.0),
               f"scene_spacing must be between {MIN_SPACING} and 1 metre (samples cost "
               f"memory as 1 / spacing^2), got {self.scene_spacing}")
        _check(self.backend in BACKENDS, f"backend must be one of {BACKENDS}")
        _check(self.device is None or self.backend == "torch",
               f"device {self.device!r} applies to the torch backend only "
               f"(backend is {self.backend!r}; add --backend torch / backend='torch')")
        _check(self.device is None or isinstance(self.device, str) and bool(
            re.fullmatch(r"auto|cpu|mps|cuda(:\d+)?", self.device)),
            f"device must be auto, cpu, mps, cuda or cuda:N, got {self.device!r}")
        _check_seed(self.seed)
        _check(self.keypoint_order in KEYPOINT_ORDERS,
               f"keypoint_order must be one of {KEYPOINT_ORDERS}")
        _check(self.complete_scores in COMPLETE_SCORES,
               f"complete_scores must be one of {COMPLETE_SCORES}")
        _check(self.stage_order in STAGE_ORDERS, f"stage_order must be one of {STAGE_ORDERS}")
        _check(not (self.stage_order == "tests-first" and self.complete_scores == "accepted"),
               "stage_order 'tests-first' never scores a pair that fails a placement test, "
               "so it cannot complete every pair the score accepts (complete_scores "
               "'accepted'): use stage_order 'score-first' or 'auto'")
        _check(self.pilot_pairs >= 1, "pilot_pairs must be at least 1")
        _check(self.batch_size >= 1 and self.max_scene_points >= 100,
               "batch_size and max_scene_points must be positive")

    def to_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @property
    def tests_first(self) -> bool:
        """Whether detection runs the placement tests before the score (``stage_order``,
        ``auto`` resolved)."""
        if self.stage_order == "auto":
            return self.early_exit and self.complete_scores == "placed"
        return self.stage_order == "tests-first"

    def for_scene(self, scene) -> "DetectSettings":
        """These settings with the defaults that depend on the scene filled in: the criterion
        (``gaussian`` for a captured scene, ``scene.captured``; else ``paper``)."""
        if self.criterion is not None:
            return self
        return replace(self, criterion="gaussian" if getattr(scene, "captured", False)
                       else "paper")
